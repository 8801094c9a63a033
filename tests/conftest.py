"""The suite's fixtures and hooks: its own cache folder, a tiny behaviour writer, the labs' long
runs (each made once per session and shared by every test that reads it), and a ``labsim serve
--empty`` of a test's own. What test modules import lives in tests/helpers.py; the tiers
(unit, contract, labs, hostile, serve, apps, browser) are the subfolders, and ``-m "not slow"``
leaves out the long tests. Every test under tests/browser is marked ``browser`` here, and slow
tests are handed out first (see ``pytest_collection_modifyitems``)."""
from __future__ import annotations

import atexit
import contextlib
import hashlib
import os
import pickle
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest
from helpers import LabRun, serve, stop
from hypothesis import settings

from labsim.backends import load_backend
from labsim.runtime.result import RunResult
from labsim.runtime.run import compile_behaviour

# No test asserts a wall-clock time, and hypothesis's default deadline (200 ms an example) is
# one: on a shared machine under load it fails tests that hold (an example took 390 ms at a load
# of 14). Tests that set their own settings keep them; the rest inherit no deadline.
settings.register_profile("labsim", deadline=None)
settings.load_profile("labsim")

# the suite's own cache folder (grammar tables, drawn grounds), not the user's: set before
# anything is built, and inherited by every labsim process a test starts
if "LABSIM_CACHE_DIR" not in os.environ:
    os.environ["LABSIM_CACHE_DIR"] = tempfile.mkdtemp(prefix="labsim-test-cache-")
    atexit.register(shutil.rmtree, os.environ["LABSIM_CACHE_DIR"], True)


BROWSER = Path(__file__).resolve().parent / "browser"
MODULE_MARKS = re.compile(r"^pytestmark\s*=\s*(.*)$", re.M)


def _left_out(markexpr: str) -> set[str]:
    """The marks a ``-m`` expression leaves out whatever else a test carries: the X of each
    ``not X`` it is a conjunction of (``not slow``, ``not long and not browser``); nothing for
    an expression with ``or`` or parentheses, which this does not read."""
    if not markexpr or "(" in markexpr or re.search(r"\bor\b", markexpr):
        return set()
    conjuncts = [c.strip() for c in re.split(r"\band\b", markexpr)]
    return {c.split()[1] for c in conjuncts if re.fullmatch(r"not\s+\w+", c)}


def pytest_ignore_collect(collection_path: Path, config: pytest.Config) -> bool | None:
    """Leave unimported a test module whose every test ``-m`` leaves out: the browser tier, and
    a module marked whole (``pytestmark = pytest.mark.slow``). Importing it only to deselect
    its tests cost every worker its imports (a stand-in server's, Dask's, pandas'): a second of
    CPU each in ``-m "not slow"``."""
    left_out = _left_out(config.getoption("markexpr", ""))
    if not left_out:
        return None
    path = collection_path.resolve()
    if path == BROWSER or path.is_relative_to(BROWSER):
        return bool(left_out & {"browser", "slow"}) or None
    if path.suffix != ".py" or not path.name.startswith("test_"):
        return None
    found = MODULE_MARKS.search(path.read_text(encoding="utf-8"))
    marks = set(re.findall(r"pytest\.mark\.(\w+)", found.group(1))) if found else set()
    return bool(marks & left_out) or None


@pytest.hookimpl(tryfirst=True)  # before pytest's own hook deselects by marker
def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark the browser tier ``browser`` and put the slow tests first.

    The marker comes from the folder, not from each module, so that a new browser test is left
    out of the plain command and run in .ci/run's browser stage without anyone remembering it.
    Slow first: with ``--dist worksteal`` the seconds-long tests start while both workers are
    busy and the quick ones fill the gaps, instead of one long test running alone at the end.
    The sort is stable, so a module's tests keep their order (and their module fixtures).
    """
    for item in items:
        if item.path.resolve().is_relative_to(BROWSER):
            item.add_marker(pytest.mark.slow)
            item.add_marker(pytest.mark.browser)
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)


@pytest.fixture
def write(tmp_path: Path):
    """write(text, name='b.yaml') -> path of a new file holding text."""
    def _write(text: str, name: str = "b.yaml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write


@pytest.fixture(scope="session")
def lab_run(tmp_path_factory: pytest.TempPathFactory) -> LabRun:
    """lab_run(path, **overrides) -> the RunResult of that behaviour run to its end on pymunk.

    The labs' long runs (ten simulated minutes of five camera robots, 25 minutes of the wall
    lab) cost seconds each: a run is made once per session for the same file and settings
    (the seed is the file's), and every test that asks reads the same summary. The xdist
    workers of a session share it through a folder of the session's: the first to ask runs it
    while holding the key's lock, the others wait for it and read it. Summaries are read,
    never changed.
    """
    done: dict[str, RunResult] = {}
    session = tmp_path_factory.getbasetemp()
    shared = (session.parent if os.environ.get("PYTEST_XDIST_WORKER") else session) / "lab-runs"
    shared.mkdir(exist_ok=True)

    def run(path: Path, **overrides: str) -> RunResult:
        text = Path(path).read_bytes() + repr((str(path), sorted(overrides.items()))).encode()
        key = hashlib.sha256(text).hexdigest()[:32]
        if key not in done:
            with _locked(shared / f"{key}.lock"):
                stored = shared / f"{key}.pickle"
                if stored.exists():
                    done[key] = pickle.loads(stored.read_bytes())
                else:
                    r = compile_behaviour(path, overrides).bind(load_backend("pymunk"), warn=lambda m: None)
                    try:
                        done[key] = r.run()
                    finally:
                        r.close()
                    partial = stored.with_suffix(".partial")
                    partial.write_bytes(pickle.dumps(done[key]))
                    partial.replace(stored)
        return done[key]

    return run


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """An exclusive lock on ``path`` between the processes of a session (none where fcntl is missing)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX: each worker runs its own
        yield
        return
    with open(path, "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(held, fcntl.LOCK_UN)


@pytest.fixture
def empty():
    """The port of a ``labsim serve --empty`` of this test's own, stopped after it."""
    pytest.importorskip("zmq")
    pytest.importorskip("coppeliasim_zmqremoteapi_client")
    proc, port = serve("-q", "--empty")
    yield port
    stop(proc)
