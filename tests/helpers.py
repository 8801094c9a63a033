"""What the test modules share: the repository's paths, fixture expectations, trace rows, a
``labsim serve`` process started and stopped, the worked examples of docs/language.md, and
hand-made traces for the pictures.

Test modules import from here (``from helpers import ...``; pyproject's ``pythonpath`` puts
tests/ on the path), never from conftest.py or from one another: conftest.py holds only the
fixtures and hooks pytest finds by itself, and a test module is a module of tests, not a
library. Nothing here is collected as a test.
"""
from __future__ import annotations

import ast
import contextlib
import functools
import math
import re
import select
import subprocess
import sys
from collections.abc import Callable, Collection, Iterator
from pathlib import Path
from typing import Any

import pytest

from labsim.backends import load_backend
from labsim.backends.scene.world import builtin_worlds
from labsim.dsl.compile import compile_file
from labsim.runtime.result import RunResult
from labsim.runtime.run import Run
from labsim.runtime.trace import FORMAT, TraceWriter

ROOT = Path(__file__).resolve().parent.parent  # the repository root, which is the package root
PACKAGE_DIRS = ("foundation", "dsl", "runtime", "backends")  # the package's folders of Python code
FIXTURES = ROOT / "tests" / "fixtures"
BEHAVIOURS = ROOT / "behaviours"
BENCHMARKS = ROOT / "benchmarks"
DOCS = ROOT / "docs"

# lab_run(path, **overrides) -> the RunResult of that behaviour's whole run (the conftest fixture)
LabRun = Callable[..., RunResult]


def expectations(path: Path) -> set[tuple[int, int, str]]:
    """The `# expect: LINE:COL: message` (or `# expect: -: message`) lines of a fixture."""
    out = set()
    for line in path.read_text().splitlines():
        m = re.match(r"# expect: (?:(\d+):(\d+)|-): (.*)$", line)
        if m:
            out.add((int(m.group(1) or 0), int(m.group(2) or 0), m.group(3)))
    return out


def trace_rows(path: Path) -> list[str]:
    """A trace's rows as text, without its header lines and its `# end` footer."""
    return [line for line in path.read_text().splitlines()[1:] if not line.startswith("#")]


def embedded_and_served(lab: Path, port: int, folder: Path, *options: str) -> tuple[list[str], list[str]]:
    """The rows of ``labsim run LAB`` on the embedded backend and through the CoppeliaSim backend
    on ``port`` (a scene ``labsim scene`` built there), each traced into ``folder``."""
    from labsim.runtime.cli.main import main

    ref, remote = folder / "ref.csv", folder / "remote.csv"
    assert main(["run", str(lab), "-q", *options, "--trace", str(ref)]) == 0
    assert main(["run", str(lab), "-q", *options, "--trace", str(remote),
                 "--backend", "coppeliasim", "--port", str(port)]) == 0
    return trace_rows(ref), trace_rows(remote)


def inner_rows(path: Path) -> list[str]:
    """A trace's lines less the first (the header, which names the backend) and the last (the footer)."""
    return path.read_text().splitlines()[1:-1]


# --- a `labsim serve` process ------------------------------------------------------------------
# No test measures how long something takes: on a loaded machine anything can be slow.
# PATIENCE_S only keeps a broken test from hanging forever.

PATIENCE_S = 60.0  # how long a test waits for a process or an answer before calling it hung
PATH_ERROR = "object does not exist, or alias/path is ill formatted."


def serve(*args: str) -> tuple[subprocess.Popen, int]:
    """A `labsim serve ARGS` process on a free port, once it says it listens; and that port."""
    proc = subprocess.Popen([sys.executable, "-m", "labsim", "serve", "--port", "0", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    ready, _, _ = select.select([proc.stdout], [], [], PATIENCE_S)
    if not ready:
        proc.kill()
        raise AssertionError(f"labsim serve did not start within {PATIENCE_S:g} s")
    line = proc.stdout.readline()  # type: ignore[union-attr]
    assert "listening on tcp://127.0.0.1:" in line, line + proc.stderr.read()  # type: ignore[union-attr]
    return proc, int(line.split("127.0.0.1:")[1].split(";")[0])


def stop(proc: subprocess.Popen) -> None:
    """End a `labsim serve` process: politely, then by force if it does not go."""
    proc.terminate()
    try:
        proc.wait(PATIENCE_S)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()


def serve_and_run(tmp_path: Path, behaviour: Path, *serve_args: str) -> tuple[list[str], list[str]]:
    """Trace rows of a behaviour on pymunk, and on coppeliasim against `labsim serve ...`."""
    # the command line pulls in the applications: imported here, so that a module that only
    # needs the paths does not pay for them
    from labsim.runtime.cli.main import main

    proc, port = serve("-q", *serve_args)
    try:
        ref, remote = tmp_path / "ref.csv", tmp_path / "remote.csv"
        assert main(["run", str(behaviour), "-q", "--trace", str(ref)]) == 0
        assert main(["run", str(behaviour), "-q", "--trace", str(remote), "--backend", "coppeliasim",
                     "--port", str(port)]) == 0
    finally:
        proc.terminate()
        proc.wait(PATIENCE_S)
    return inner_rows(ref), inner_rows(remote)


# --- the worked examples of docs/language.md ---------------------------------------------------

def examples(doc: str = "language.md") -> dict[str, str]:
    """A doc's YAML blocks that start with '# example: NAME' (docs/language.md's by default)."""
    blocks = re.findall(r"```yaml\n(# example: (\w+)\n.*?)```", (DOCS / doc).read_text(), re.S)
    return {name: text for text, name in blocks}


def run_example(name: str, tmp_path: Path, trace: bool = False, doc: str = "language.md"
                ) -> tuple[Run, object, list[str]]:
    """The example NAME of a doc run to its end on pymunk: the run, its summary and what it warned."""
    path = tmp_path / f"{name}.yaml"
    path.write_text(examples(doc)[name])
    warned: list[str] = []
    run = Run(compile_file(path), load_backend("pymunk"), trace_path=tmp_path / "t.csv" if trace else None,
              warn=warned.append)
    return run, run.run(), warned


# --- hand-made traces, for the pictures --------------------------------------------------------

COLUMNS = ["tick", "time", "robot", "x", "y", "heading", "collided", "state", "rule",
           "wheel_left", "wheel_right", "events"]
DT = 0.05


def header(**changes: object) -> dict:
    """A trace header for walls_lab4 and one robot, with CHANGES on top."""
    h = {"format": FORMAT, "labsim": "0.1.0", "backend": "pymunk", "behaviour": "behaviours/test.yaml",
         "name": "Plot test", "world": "walls_lab4", "world_file": str(builtin_worlds()["walls_lab4"]),
         "dt": DT, "seed": 7, "params": {}, "robots": {"pioneer": "pioneer_p3dx"},
         "metrics": {"bumps": "count", "busy": "duration"}}
    h.update(changes)
    return h


def write_trace(path: Path, poses: dict[str, list[tuple[float, float, float, int, str]]],
                **header_changes: object) -> Path:
    """A trace of the given (x, y, heading, collided, events) per robot, ticks interleaved."""
    h = header(**header_changes)
    h["robots"] = {name: "pioneer_p3dx" for name in poses}
    w = TraceWriter(path, h, COLUMNS)
    try:
        for t in range(max(len(p) for p in poses.values())):
            for name, p in poses.items():
                if t < len(p):
                    x, y, heading, collided, events = p[t]
                    w.write([t, round(t * DT, 9), name, x, y, heading, collided, "go", "go:1",
                             1.0, 1.0, events])
    finally:
        w.close()
    return path


def straight(x0: float, y0: float, x1: float, y1: float, n: int = 50) -> list:
    """N poses (x, y, heading, collided, events) on the straight line from (x0, y0) to (x1, y1)."""
    heading = math.atan2(y1 - y0, x1 - x0)
    return [(x0 + (x1 - x0) * i / (n - 1), y0 + (y1 - y0) * i / (n - 1), heading, 0, "")
            for i in range(n)]


# On Linux a child's peak resident set (wait4's ru_maxrss) starts from its parent's at fork,
# the address space it copied: a test process grown to hundreds of MB would inflate every figure.
# So a small launcher forks the command measured and reports what wait4 says of it.
_PEAK_LAUNCHER = ("import os, subprocess, sys\n"
                  "p = subprocess.Popen(sys.argv[2:])\n"
                  "_, status, usage = os.wait4(p.pid, 0)\n"
                  "open(sys.argv[1], 'w').write(f'{os.waitstatus_to_exitcode(status)} {usage.ru_maxrss}')\n")


def measured_command(report: Path, argv: list[str]) -> list[str]:
    """``argv`` run by the launcher, which writes its exit code and peak resident set to ``report``."""
    return [sys.executable, "-c", _PEAK_LAUNCHER, str(report), *argv]


def measured_result(report: Path) -> tuple[int, float]:
    """(exit code, peak resident set in MiB) of a command run by ``measured_command``."""
    code, kib = report.read_text().split()
    return int(code), int(kib) / 1024  # Linux reports kilobytes


def cases(items: list, long: Collection[str] = ()) -> list:
    """Parametrised cases named by their ``name``; those named in ``long`` are marked ``slow`` and
    ``long`` (minutes on a loaded machine: .ci/run runs them in a stage of their own)."""
    return [pytest.param(c, id=c.name, marks=(pytest.mark.slow, pytest.mark.long) if c.name in long else ())
            for c in items]


@contextlib.contextmanager
def local_cluster(processes: bool = True) -> Iterator[Any]:
    """A Dask cluster on this machine: two worker processes, or (``processes=False``) one worker
    of two threads in this process, which starts in a fraction of a second: the quick check of
    the Dask path in the plain command (nothing crosses a process), the processes' in ``-m long``.
    The test is skipped without Dask."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2 if processes else 1, threads_per_worker=1 if processes else 2,
                                  processes=processes, dashboard_address=None, silence_logs=50) as c:
        yield c


# a module's cluster fixture's params: in threads (seconds: the plain command, not -m "not slow"),
# and in processes (-m long)
CLUSTERS = [pytest.param(False, id="threads", marks=pytest.mark.slow),
            pytest.param(True, id="processes", marks=(pytest.mark.slow, pytest.mark.long))]


@functools.cache
def parsed(path: Path) -> tuple[str, ast.Module]:
    """A source file's text and syntax tree, read and parsed once a process for every test that
    walks the package (the code's shape, its imports): parsing it is most of their time. Trees
    are read, never changed."""
    text = path.read_text(encoding="utf-8")
    return text, ast.parse(text)
