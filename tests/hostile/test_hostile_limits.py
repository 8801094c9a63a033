"""Hostile sizes and limits, as a table: each case is files and a command line, the exit code,
and what the message must name. Every case runs as a user would (a process of its own), and
must end within a generous timeout, with no traceback and a bounded amount of output.

The catalogue's other categories (special files, permissions, numbers, replayed traces,
server replies) have tables of their own; these are the cases of runs that never end, world
geometry at the extremes, options, bounded output and per-run budgets.
"""
from __future__ import annotations

import csv
import json
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from helpers import BEHAVIOURS, cases

pytestmark = pytest.mark.slow  # every case is a labsim process of its own, a few of them seconds of work

TIMEOUT_S = 300  # generous: the machine is shared; a hang is what this catches, not slowness
MAX_OUTPUT = 20_000  # bytes of stdout + stderr any case may print

HEAD = "labsim: 1\nworld: walls_lab4\n"
ONE = "robots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\nrules:\n  - always move(1)\n"


def behaviour(stop: str = "time >= 1", robots: str = "", extra: str = "", world: str = "walls_lab4") -> str:
    body = robots or ONE
    if robots:
        body = "robots:\n" + robots + "rules:\n  - always move(1)\n"
    return f"labsim: 1\nworld: {world}\n{extra}stop: {stop}\n{body}"


def groups(n: int, count: int, at: str) -> str:
    return "".join(f"  g{i}: {{model: pioneer_p3dx, count: {count}, at: {at}}}\n" for i in range(n))


def world(body: str) -> str:
    return "labsim-world: 1\nname: hostile\nbounds: [-5, -5, 5, 5]\n" + body


@dataclass
class Case:
    name: str
    args: list[str]  # after `labsim`; {b} is the behaviour file's path
    code: int
    says: tuple[str, ...]  # in stdout + stderr, each
    files: dict[str, str] = field(default_factory=dict)  # name -> text, in a fresh folder


ARC = ("ground:\n  roads:\n    - width: 0.5\n      path:\n        - [1, 0]\n"
       "        - {arc: {center: [0, 0], radius: R, to_deg: 90}}\n")

CASES = [
    # -- every run ends -------------------------------------------------------------------------
    Case("stop false", ["run", "{b}"], 2, ("b.yaml:3:7: error: the stop condition never holds (it is always false)",),
         {"b.yaml": behaviour("false")}),
    Case("stop time < 0", ["check", "{b}"], 2,
         ("b.yaml:3:7: error: the stop condition never holds ('time' is never below 0)",),
         {"b.yaml": behaviour("time < 0")}),
    Case("stop tick <= -1 and", ["run", "{b}"], 2, ("b.yaml:3:7", "never holds"),
         {"b.yaml": behaviour("time > 5 and tick <= -1")}),
    Case("dt 0", ["run", "{b}"], 2, ("b.yaml:3:5: error: dt must be from 0.0001 to 1 second, not 0",),
         {"b.yaml": behaviour(extra="dt: 0\n")}),
    Case("dt -1", ["run", "{b}"], 2, ("b.yaml:3:5: error: dt must be from 0.0001 to 1 second, not -1",),
         {"b.yaml": behaviour(extra="dt: -1\n")}),
    Case("dt 1e-300", ["run", "{b}"], 2, ("b.yaml:3:5: error: dt must be from 0.0001 to 1 second, not 1e-300",),
         {"b.yaml": behaviour(extra="dt: 1e-300\n")}),
    Case("a stop that never holds, no time cap: the tick budget ends it", ["run", "{b}", "--budget", "ticks=3000",
                                                                           "--trace", "t.csv", "-q"], 2,
         ("b.yaml: error: the run reached its budget of 3,000 ticks (150 s simulated)", "--budget ticks=N"),
         {"b.yaml": behaviour("x > 100000")}),
    Case("a stop time of 1e308 s: the tick budget ends it", ["run", "{b}", "--budget", "ticks=3000", "-q"], 2,
         ("b.yaml: error: the run reached its budget of 3,000 ticks (150 s simulated)",),
         {"b.yaml": behaviour("time >= 1e308")}),
    Case("1000 robots on one spot, ten groups of 100", ["run", "{b}"], 2,
         ("b.yaml:5:45: error: the 100 robots of 'g0' would all start at (0, 0), on top of each other",),
         {"b.yaml": behaviour(robots=groups(10, 100, "[0, 0, 0]"))}),
    Case("1000 single robots on one spot", ["run", "{b}"], 2,
         ("b.yaml:6:", "would start 0.00 m from robot 'g0', overlapping it", "b.yaml: ... and 979 more", "999 errors"),
         {"b.yaml": behaviour(robots=groups(1000, 1, "[0, 0, 0]"))}),
    Case("100 robots on spawn poses that are one spot", ["run", "{b}"], 2,
         ("b.yaml:5:44: error: robot 'g[1]' would start 0.00 m from robot 'g[0]'", "b.yaml: ... and 79 more"),
         {"b.yaml": behaviour(world="w.yaml", robots="  g: {model: pioneer_p3dx, count: 100, at: spawn}\n"),
          "w.yaml": world("spawns:\n" + "  - [0, 0, 0]\n" * 100)}),
    # -- world geometry ---------------------------------------------------------------------------
    Case("line from -1e308 to 1e308", ["check", "{b}"], 2,
         ("w.yaml:5:12: error: from must lie within +-10000 m of the origin", "w.yaml:5:29: error: to must lie"),
         {"b.yaml": behaviour(world="w.yaml"), "w.yaml": world("walls:\n  - {from: [-1e308, 0], to: [1e308, 0]}\n")}),
    Case("arc radius 1e15", ["check", "{b}"], 2,
         ("w.yaml:9:42: error: an arc's radius must be from 0.0001 to 10000 m, not 1e+15",),
         {"b.yaml": behaviour(world="w.yaml"), "w.yaml": world(ARC.replace("R", "1e15"))}),
    Case("arc radius 1e12", ["check", "{b}"], 2,
         ("w.yaml:9:42: error: an arc's radius must be from 0.0001 to 10000 m, not 1e+12",),
         {"b.yaml": behaviour(world="w.yaml"), "w.yaml": world(ARC.replace("R", "1e12"))}),
    Case("ground of 1e6 m", ["check", "{b}"], 2, ("w.yaml:7:14: error: a path point [x, y] must lie within +-10000 m",),
         {"b.yaml": behaviour(world="w.yaml"),
          "w.yaml": world("ground:\n  roads:\n    - width: 1\n      path: [[-1e6, 0], [1e6, 0]]\n")}),
    Case("a patch of 1e6 m", ["check", "{b}"], 2, ("w.yaml:6:30: error: size must be from 0.0001 to 20000 m",),
         {"b.yaml": behaviour(world="w.yaml"),
          "w.yaml": world("ground:\n  patches:\n    - {center: [0, 0], size: [1e6, 1e6]}\n")}),
    Case("no free spot for at: random", ["run", "{b}"], 2,
         ("b.yaml:5:3: error: no free place left in world 'hostile' for robot 'p' (0 robots fit",),
         {"b.yaml": behaviour(world="w.yaml", robots="  p: {model: pioneer_p3dx, at: random}\n"),
          "w.yaml": world("blocks:\n  - {center: [0, 0], size: [10, 10]}\n")}),
    Case("a start pose at 1e9 m", ["check", "{b}"], 2, ("b.yaml:5:32: error: a start pose must lie within +-10000 m",),
         {"b.yaml": behaviour(robots="  p: {model: pioneer_p3dx, at: [1e9, 0]}\n")}),
    Case("a mechanism body at 1e12 m", ["serve", "w.yaml"], 2, ("w.yaml:6:32: error: center must be within +-10000 m",),
         {"w.yaml": world("mechanism:\n  bodies:\n    Post: {shape: box, center: [0, 1e12], size: [0.2, 0.2], "
                          "static: true}\n")}),
    # -- options ---------------------------------------------------------------------------------
    Case("--timeout 1e308", ["run", "{b}", "--backend", "coppeliasim", "--timeout", "1e308"], 2,
         ("labsim: error: argument --timeout: give from 0.01 to 3600 seconds, not 1e308",), {"b.yaml": behaviour()}),
    Case("--timeout 1e10", ["run", "{b}", "--backend", "coppeliasim", "--timeout", "1e10"], 2,
         ("argument --timeout: give from 0.01 to 3600 seconds, not 1e10",), {"b.yaml": behaviour()}),
    Case("--timeout nan", ["test", "{b}", "--backend", "coppeliasim", "--timeout", "nan"], 2,
         ("argument --timeout: 'nan' is not a finite number",), {"b.yaml": behaviour()}),
    Case("--host 'bad host!'", ["run", "{b}", "--backend", "coppeliasim", "--host", "bad host!"], 2,
         ("labsim: error: argument --host: 'bad host!' is not a host name or an IP address",), {"b.yaml": behaviour()}),
    Case("serve --host 'bad host!'", ["serve", "--host", "bad host!"], 2,
         ("argument --host: 'bad host!' is not a host",)),
    Case("--port 70000", ["run", "{b}", "--backend", "coppeliasim", "--port", "70000"], 2,
         ("argument --port: a port is from 0 to 65535, not 70000",), {"b.yaml": behaviour()}),
    Case("serve --dt 0", ["serve", "--dt", "0"], 2, ("argument --dt: give from 0.0001 to 1 seconds, not 0",)),
    Case("serve --robots 10000", ["serve", "--robots", "10000"], 2,
         ("argument --robots: give 0 to 1000 robots, not 10000",)),
    Case("--budget unknown", ["run", "{b}", "--budget", "tics=5"], 2,
         ("--budget tics=5: error: give NAME=VALUE with NAME one of robots, camera_px",), {"b.yaml": behaviour()}),
    Case("--budget negative", ["run", "{b}", "--budget", "ticks=-5"], 2,
         ("--budget ticks=-5: error: the value is a whole number",), {"b.yaml": behaviour()}),
    # -- budgets --------------------------------------------------------------------------------
    Case("10,000 robots", ["run", "{b}"], 2,
         ("b.yaml:15:3: error: 10000 robots in all, more than this run's budget of 1000", "--budget robots=10000"),
         {"b.yaml": behaviour(robots=groups(100, 100, "random"))}),
    Case("camera of 100,000 px a side", ["check", "{b}"], 2,
         ("b.yaml:5:49: error: camera resolution must be 1 to 2048 pixels a side, not 100000 x 100000",),
         {"b.yaml": behaviour(robots="  p: {model: pioneer_p3dx, camera: {resolution: [100000, 100000]}}\n")}),
    Case("camera pixels past the budget", ["check", "{b}"], 2,
         ("b.yaml:5:3: error: the cameras render 83,886,080 pixels a tick with robot 'p'", "--budget camera_px="),
         {"b.yaml": behaviour(robots="  p: {model: pioneer_p3dx, count: 20, at: random, "
                                     "camera: {resolution: [2048, 2048]}}\n")}),
    Case("world segments past the budget", ["check", "{b}", "--budget", "segments=3"], 2,
         ("b.yaml:2:8: error: world 'walls_lab4' has", "more than this run's budget of 3"), {"b.yaml": behaviour()}),
    Case("trace past its budget", ["run", "{b}", "--budget", "trace_mb=0", "--trace", "t.csv", "-q"], 2,
         ("b.yaml: error: the trace t.csv reached its budget of 0 MB after 0 ticks",),
         {"b.yaml": behaviour("time > 100")}),
    # -- bounded output -------------------------------------------------------------------------
    Case("9000 unknown names", ["check", "{b}"], 2,
         ("b.yaml:", "unknown name", "b.yaml: ... and 8980 more (the first 20 are shown)"),
         {"b.yaml": HEAD + "stop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\nrules:\n"
          + "".join(f"  - if nosuch{i} > 1 then move(1)\n" for i in range(9000)) + "  - else move(1)\n"}),
    Case("a 980 KB line with a mistake at its end", ["check", "{b}"], 2, ("b.yaml:4:960015: error: YAML syntax error",),
         {"b.yaml": HEAD + "stop: time >= 1\nparams: {a: [" + "1, " * 320_000 + "]] }\n" + ONE}),
    Case("150,000 \\u escapes in one string", ["check", "{b}"], 2,
         ("b.yaml:3:23: error: 'and' needs a boolean, but this is text",),
         {"b.yaml": HEAD + 'stop: "time >= 1 and \\"' + "\\u00e9" * 150_000 + '\\" "\n' + ONE}),
]


@pytest.mark.parametrize("case", cases(CASES, long={"9000 unknown names", "a 980 KB line with a mistake at its end"}))
def test_hostile_limit(case: Case, tmp_path: Path) -> None:
    for name, text in case.files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    args = [a.replace("{b}", "b.yaml") for a in case.args]
    proc = subprocess.run([sys.executable, "-m", "labsim", *args], cwd=tmp_path, capture_output=True,
                          text=True, timeout=TIMEOUT_S, stdin=subprocess.DEVNULL)
    said = proc.stdout + proc.stderr
    assert "Traceback" not in said, said[-3000:]
    assert proc.returncode == case.code, said[-3000:]
    for text in case.says:
        assert text in said, said[-3000:]
    assert len(said.encode()) <= MAX_OUTPUT, said[:3000]
    for name, text in case.files.items():  # an input is never changed
        assert (tmp_path / name).read_text(encoding="utf-8") == text


def test_a_run_stopped_by_its_tick_budget_keeps_a_readable_trace(tmp_path: Path) -> None:
    (tmp_path / "b.yaml").write_text(behaviour("x > 100000"), encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "labsim", "run", "b.yaml", "--budget", "ticks=1000",
                           "--trace", "t.csv"], cwd=tmp_path, capture_output=True, text=True, timeout=TIMEOUT_S)
    assert proc.returncode == 2 and "done: 1000 ticks" in proc.stdout  # the summary is printed before the error
    lines = (tmp_path / "t.csv").read_text().splitlines()
    assert lines[-1].startswith('# end {"interrupted": true')  # cut short by its budget, and says so
    rows = list(csv.reader(lines[1:-1]))
    assert rows[0][0] == "tick" and rows[-1][0] == "999" and len(rows) == 1001


def test_the_json_summary_says_a_budget_stopped_the_run(tmp_path: Path) -> None:
    (tmp_path / "b.yaml").write_text(behaviour("x > 100000"), encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "labsim", "run", "b.yaml", "--budget", "ticks=300", "--json"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=TIMEOUT_S)
    assert proc.returncode == 2 and "budget of 300 ticks" in proc.stderr
    summary = json.loads(proc.stdout)
    assert summary["stop_reason"] == "budget" and summary["ticks"] == 300


def test_a_long_run_gets_one_warning_with_its_estimate(tmp_path: Path) -> None:
    (tmp_path / "b.yaml").write_text(behaviour("x > 100000"), encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "labsim", "run", "b.yaml", "--budget", "ticks=2000",
                           "--budget", "warn_wall_s=0", "-q"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=TIMEOUT_S)
    assert proc.returncode == 2
    assert proc.stderr.count("labsim: warning: this run may take about") == 1
    assert "2,000 ticks to its tick budget" in proc.stderr


def test_a_sweep_applies_the_budgets_to_every_run(tmp_path: Path) -> None:
    (tmp_path / "b.yaml").write_text(behaviour("x > 100000"), encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "labsim", "sweep", "b.yaml", "--seeds", "1-2", "-j", "1",
                           "--budget", "ticks=500"], cwd=tmp_path, capture_output=True, text=True, timeout=TIMEOUT_S)
    assert proc.returncode == 1, proc.stdout + proc.stderr  # runs failed; the sweep completed
    assert proc.stdout.count("runtime error: the run reached its budget of 500 ticks") == 2


def test_a_worker_of_a_large_process_still_runs_under_its_limit() -> None:
    # forked from a process that has mapped more than a run's megabytes already (a notebook's
    # kernel, a test runner): the limit counts from what it has, so its stack still grows and a
    # run compiles; capped at the megabytes themselves, it crashed inside the checker
    code = ("import mmap\n"
            "big = mmap.mmap(-1, 3 * 1024 ** 3)  # 3 GB mapped, never touched\n"
            "from labsim.foundation.memory import limit_memory\n"
            "assert limit_memory(1024)\n"
            "from labsim.runtime.run import compile_behaviour\n"
            f"compile_behaviour({str(BEHAVIOURS / 'wall_follow.yaml')!r}, {{}})\n"
            "def deep(n):\n    return 0 if n == 0 else 1 + deep(n - 1)\n"
            "print(deep(900))\n"
            "try:\n    bytearray(4 * 1024 ** 3)\nexcept MemoryError:\n    print('MemoryError')\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=TIMEOUT_S)
    assert proc.returncode == 0 and proc.stdout.split() == ["900", "MemoryError"], proc.stderr[-2000:]


def test_a_sweep_worker_has_a_memory_limit() -> None:
    # what the local pool's worker does first; a run that asks for more gets MemoryError
    code = ("from labsim.foundation.memory import limit_memory\n"
            "assert limit_memory(1024)\n"
            "try:\n    bytearray(4 * 1024 ** 3)\nexcept MemoryError:\n    print('MemoryError')\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=TIMEOUT_S)
    assert proc.stdout.strip() == "MemoryError", proc.stderr


@pytest.mark.parametrize("ticks", [pytest.param(200_000, marks=(pytest.mark.slow, pytest.mark.long)), 1000])
def test_a_run_its_budget_stops_is_not_recorded_as_a_golden(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                             ticks: int) -> None:
    """The default budget of 200,000 ticks (seconds of CPU: the long stage), and the same path to
    the refusal with a budget of 1,000 ticks given to the golden's compile (the plain command)."""
    from labsim.foundation.diagnostics import LabsimError
    from labsim.foundation.limits import Budgets
    from labsim.runtime import golden
    from labsim.runtime.golden import golden_path, record_golden

    if ticks != Budgets().ticks:
        compile_behaviour = golden.compile_behaviour
        monkeypatch.setattr(golden, "compile_behaviour",
                            lambda path: compile_behaviour(path, budget=Budgets(ticks=ticks)))
    path = tmp_path / "b.yaml"
    path.write_text(behaviour("x > 100000"), encoding="utf-8")
    with pytest.raises(LabsimError, match=rf"budget of {ticks:,} ticks.*no golden recorded"):
        record_golden(path)
    assert not golden_path(path).exists() and sorted(p.name for p in tmp_path.iterdir()) == ["b.yaml"]
