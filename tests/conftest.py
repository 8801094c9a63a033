"""The suite's fixtures and hooks: its own cache folder, a tiny behaviour writer, the labs' long
runs (each made once per session and shared by every test that reads it), and a ``labsim serve
--empty`` of a test's own. What test modules import lives in tests/helpers.py; the tiers
(unit, contract, labs, hostile, serve, apps, browser) are the subfolders, and ``-m "not slow"``
leaves out the long tests."""
from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

import pytest
from helpers import LabRun, serve, stop

from labsim.backends import load_backend
from labsim.runtime.result import RunResult
from labsim.runtime.run import compile_behaviour

# the suite's own cache folder (grammar tables, drawn grounds), not the user's: set before
# anything is built, and inherited by every labsim process a test starts
if "LABSIM_CACHE_DIR" not in os.environ:
    os.environ["LABSIM_CACHE_DIR"] = tempfile.mkdtemp(prefix="labsim-test-cache-")
    atexit.register(shutil.rmtree, os.environ["LABSIM_CACHE_DIR"], True)


@pytest.fixture
def write(tmp_path: Path):
    """write(text, name='b.yaml') -> path of a new file holding text."""
    def _write(text: str, name: str = "b.yaml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write


@pytest.fixture(scope="session")
def lab_run() -> LabRun:
    """lab_run(path, **overrides) -> the RunResult of that behaviour run to its end on pymunk.

    The labs' long runs (ten simulated minutes of five camera robots, 25 minutes of the wall
    lab) cost seconds each: a run is made once per session and every test that asks for the
    same file and settings reads the same summary. Summaries are read, never changed.
    """
    done: dict[tuple[str, tuple[tuple[str, str], ...]], RunResult] = {}

    def run(path: Path, **overrides: str) -> RunResult:
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
    proc, port = serve("-q", "--empty")
    yield port
    stop(proc)
