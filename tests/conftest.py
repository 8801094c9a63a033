"""Shared helpers: paths, fixture expectations, a tiny in-memory behaviour writer, and the
labs' long runs, each run once per test session and shared by every test that reads it."""
from __future__ import annotations

import atexit
import os
import re
import shutil
import tempfile
from collections.abc import Callable
from pathlib import Path

import pytest

from labsim.backends import load_backend
from labsim.runtime.result import RunResult as Summary
from labsim.runtime.run import compile_behaviour

# the suite's own cache folder (grammar tables, drawn grounds), not the user's: set before
# anything is built, and inherited by every labsim process a test starts
if "LABSIM_CACHE_DIR" not in os.environ:
    os.environ["LABSIM_CACHE_DIR"] = tempfile.mkdtemp(prefix="labsim-test-cache-")
    atexit.register(shutil.rmtree, os.environ["LABSIM_CACHE_DIR"], True)

ROOT = Path(__file__).resolve().parent.parent
FIXTURES = Path(__file__).resolve().parent / "fixtures"
BEHAVIOURS = ROOT / "behaviours"


def expectations(path: Path) -> set[tuple[int, int, str]]:
    """The `# expect: LINE:COL: message` (or `# expect: -: message`) lines of a fixture."""
    out = set()
    for line in path.read_text().splitlines():
        m = re.match(r"# expect: (?:(\d+):(\d+)|-): (.*)$", line)
        if m:
            out.add((int(m.group(1) or 0), int(m.group(2) or 0), m.group(3)))
    return out


@pytest.fixture
def write(tmp_path: Path):
    """write(text, name='b.yaml') -> path of a new file holding text."""
    def _write(text: str, name: str = "b.yaml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write


LabRun = Callable[..., Summary]


@pytest.fixture(scope="session")
def lab_run() -> LabRun:
    """lab_run(path, **overrides) -> the Summary of that behaviour run to its end on pymunk.

    The labs' long runs (ten simulated minutes of five camera robots, 25 minutes of the wall
    lab) cost seconds each: a run is made once per session and every test that asks for the
    same file and settings reads the same summary. Summaries are read, never changed.
    """
    done: dict[tuple[str, tuple[tuple[str, str], ...]], Summary] = {}

    def run(path: Path, **overrides: str) -> Summary:
        key = (str(path), tuple(sorted(overrides.items())))
        if key not in done:
            r = compile_behaviour(path, overrides).bind(load_backend("pymunk"), warn=lambda m: None)
            try:
                done[key] = r.run()
            finally:
                r.close()
        return done[key]

    return run


@pytest.fixture
def empty():
    """The port of a ``labsim serve --empty`` of this test's own, stopped after it."""
    pytest.importorskip("zmq")
    pytest.importorskip("coppeliasim_zmqremoteapi_client")
    from test_serve import _serve, _stop

    proc, port = _serve("-q", "--empty")
    yield port
    _stop(proc)


def trace_rows(path: Path) -> list[str]:
    """A trace's rows as text, without its header lines and its `# end` footer."""
    return [line for line in path.read_text().splitlines()[1:] if not line.startswith("#")]
