"""What a command imports: ``labsim run`` and ``labsim check`` load no application they do not run.

Each command runs in a new process, as a user starts it, and reports the modules it loaded
once done: a sweep's, the pictures', the live view's, the stand-in server's and the scene
builder's modules load only when their own command runs, and so do the heavy libraries
behind them (matplotlib, imageio, aiohttp, Dask, ZMQ; OpenCV for a lab without a camera).
"""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import BEHAVIOURS

LAB = BEHAVIOURS / "wall_follow.yaml"  # no camera: nothing of it needs OpenCV
MARK = "--modules--"
PROBE = ("import json, sys\n"
         "from labsim.runtime.cli.main import main\n"
         "code = main(sys.argv[1:])\n"
         f"print({MARK!r}, json.dumps(sorted(sys.modules)))\n"
         "sys.exit(code)\n")

APPLICATIONS = ("labsim.runtime.sweep", "labsim.runtime.pictures", "labsim.runtime.view", "labsim.runtime.serve",
                "labsim.runtime.builder")
LIBRARIES = ("matplotlib", "imageio", "imageio_ffmpeg", "aiohttp", "dask", "distributed", "zmq",
             "coppeliasim_zmqremoteapi_client", "cbor2", "cv2")


def modules_after(*argv: str) -> set[str]:
    """The modules a labsim process had loaded when the command ``argv`` finished."""
    done = subprocess.run([sys.executable, "-c", PROBE, *argv], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    line = next(line for line in done.stdout.splitlines() if line.startswith(MARK))
    return set(json.loads(line.removeprefix(MARK)))


def unwanted(modules: set[str]) -> list[str]:
    return sorted(m for m in modules
                  if m.startswith(tuple(a + "." for a in APPLICATIONS)) or m in APPLICATIONS
                  or m.split(".")[0] in LIBRARIES)


@pytest.mark.parametrize("argv", [("run", str(LAB), "--set", "minutes=0.05", "-q"),
                                  ("run", "wall_follow", "--set", "minutes=0.05", "--json"),
                                  ("check", str(LAB))], ids=["run", "run-json-lab-name", "check"])
def test_a_command_on_the_tick_loop_loads_no_application(argv: tuple[str, ...]) -> None:
    modules = modules_after(*argv)
    assert {"labsim.runtime.run", "labsim.dsl.compile"} <= modules  # the probe saw the command run
    assert unwanted(modules) == []


def test_an_applications_command_loads_its_application_only(tmp_path: Path) -> None:
    trace = tmp_path / "run.csv"
    modules_after("run", str(LAB), "--set", "minutes=0.05", "-q", "--trace", str(trace))
    modules = modules_after("plot", str(trace), "-o", str(tmp_path / "run.png"))
    assert "labsim.runtime.pictures.driver" in modules  # what the probe would see of one
    assert [m for m in unwanted(modules) if not m.startswith(("labsim.runtime.pictures", "cv2"))] == []
