"""Signals and traces (docs/security.md, docs/trace-format.md): SIGTERM is handled as Ctrl-C
is, every trace that labsim closes ends with its ``# end`` footer, and a trace cut off by
SIGKILL is still readable by pandas beside its target (``PATH.partial``)."""
from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import cbor2
import pandas as pd
import pytest
import zmq

from labsim.backends.scene.world import builtin_worlds
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import Report
from labsim.runtime.serve.server import Server
from labsim.runtime.trace import read_trace

pytestmark = pytest.mark.slow  # labsim processes, signalled mid-run

PATIENCE_S = 60.0  # how long a test waits for a process before calling it hung
LONG = ["--set", "minutes=10000"]  # runs until a signal ends it


def _start(tmp_path: Path, *extra: str) -> tuple[subprocess.Popen, Path]:
    trace = tmp_path / "run.csv"
    proc = subprocess.Popen([sys.executable, "-m", "labsim", "run", "wall_follow", "--trace", str(trace),
                             *LONG, *extra], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    partial = Path(str(trace) + ".partial")
    began = time.monotonic()
    # rows reach the file at least once a second: wait for some past the header
    while not (partial.exists() and partial.stat().st_size > 4000):
        if proc.poll() is not None or time.monotonic() - began > PATIENCE_S:
            proc.kill()
            raise AssertionError("the run did not start writing its trace: " + proc.communicate()[1])
        time.sleep(0.05)
    return proc, trace


def _footer(trace: Path) -> dict:
    last = trace.read_text().rstrip("\n").rsplit("\n", 1)[1]
    assert last.startswith("# end "), last
    return json.loads(last[len("# end "):])


@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143), (signal.SIGHUP, 129)])
def test_an_interrupted_run_closes_its_trace_with_a_footer(tmp_path: Path, sig: int, code: int) -> None:
    proc, trace = _start(tmp_path)
    proc.send_signal(sig)
    out, err = proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == code, err
    assert "interrupted:" in out and "Traceback" not in err  # the summary is printed
    assert not Path(str(trace) + ".partial").exists()  # renamed into place
    footer = _footer(trace)
    assert footer["interrupted"] is True
    frame = pd.read_csv(trace, comment="#")
    assert len(frame) == footer["ticks"] and frame["tick"].iloc[-1] == footer["ticks"] - 1
    assert read_trace(trace).cut_short() == f"the run was interrupted after {footer['ticks']} ticks"


def test_a_finished_run_has_a_footer_saying_so(tmp_path: Path) -> None:
    trace = tmp_path / "run.csv"
    done = subprocess.run([sys.executable, "-m", "labsim", "run", "wall_follow", "--set", "minutes=0.05",
                           "--trace", str(trace), "-q"], capture_output=True, text=True, timeout=PATIENCE_S)
    assert done.returncode == 0, done.stderr
    assert _footer(trace) == {"interrupted": False, "ticks": 61}  # 60 and the stopping tick (format 1.2)
    assert read_trace(trace).cut_short() == ""


def test_a_killed_run_leaves_a_partial_trace_pandas_reads(tmp_path: Path) -> None:
    proc, trace = _start(tmp_path)
    proc.kill()
    proc.communicate(timeout=PATIENCE_S)
    partial = Path(str(trace) + ".partial")
    assert not trace.exists() and partial.exists()
    frame = pd.read_csv(partial, comment="#")
    assert len(frame) > 0 and list(frame.columns[:3]) == ["tick", "time", "robot"]
    assert "no '# end' line" in read_trace(partial).cut_short()
    # the plot of it says it was cut short, and still draws
    drawn = subprocess.run([sys.executable, "-m", "labsim", "plot", str(partial), "-o", str(tmp_path / "p.png")],
                           capture_output=True, text=True, timeout=PATIENCE_S)
    assert drawn.returncode == 0 and "no '# end' line" in drawn.stderr, drawn.stderr


def _simulation_state(port: int) -> int:
    ctx = zmq.Context()
    sock = ctx.socket(zmq.REQ)
    sock.setsockopt(zmq.LINGER, 0)
    sock.setsockopt(zmq.RCVTIMEO, int(PATIENCE_S * 1000))
    try:
        sock.connect(f"tcp://127.0.0.1:{port}")
        sock.send(cbor2.dumps({"func": "sim.getSimulationState", "args": [], "uuid": "checker",
                               "ver": 2, "lang": "python"}))
        reply = cbor2.loads(sock.recv())
    finally:
        sock.close()
        ctx.term()
    return int(reply["ret"][0])


def test_sigterm_on_a_run_through_labsim_serve_stops_the_simulation(tmp_path: Path) -> None:
    world = load_world(builtin_worlds()["walls_lab4"], Report())
    assert world is not None
    with Server(world, 1, port=0) as server:
        proc, trace = _start(tmp_path, "--backend", "coppeliasim", "--port", str(server.port))
        assert _simulation_state(server.port) != 0  # running, in stepping mode
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=PATIENCE_S)
        assert proc.returncode == 143, err
        assert "interrupted:" in out
        assert _simulation_state(server.port) == 0  # sim.simulation_stopped
    assert _footer(trace)["interrupted"] is True
