"""Ctrl-C on ``labsim grade`` (docs/grading.md, "Stopping and resuming"): a real grading is sent
each signal that can end it while two students' runs go on; then no worker is left, the students
whose runs were done are cached and graded in the gradebook, the others are ``interrupted`` rows,
the exit code is 128 + the signal, and a second grading runs only the interrupted students."""
from __future__ import annotations

import contextlib
import csv
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest
from helpers import FIXTURES, local_cluster

pytestmark = pytest.mark.slow  # labsim grades, signalled mid-run

PATIENCE_S = 60.0  # how long a test waits for a process before calling it hung
ASSIGNMENT = ("labsim-assignment: 1\ntitle: signals\nworld: walls_lab4\nrobots: 1\nparams: {minutes: 0.05}\n"
              "seeds: [1]\ntimeout_s: 600\nbudgets: {ticks: 1000000000}\ncriteria:\n  ran_to_stop: {}\n")
LONG = "stop: time >= minutes * 60 * 1000000"  # runs until a signal ends it


def _class(tmp_path: Path) -> None:
    """Two students whose runs end at once (first in the queue), two whose runs never end."""
    lab = (FIXTURES / "grading" / "class" / "valid_01.yaml").read_text()
    (tmp_path / "class").mkdir()
    (tmp_path / "assignment.yaml").write_text(ASSIGNMENT)
    for name in ("a_quick", "b_quick"):  # each its own file (the cache is keyed by the bytes)
        (tmp_path / "class" / f"{name}.yaml").write_text(f"# {name}\n{lab}")
    for name in ("y_long", "z_long"):
        long = lab.replace("stop: time >= minutes * 60", LONG)
        (tmp_path / "class" / f"{name}.yaml").write_text(f"# {name}\n{long}")


def _grade(tmp_path: Path) -> subprocess.Popen[str]:
    return subprocess.Popen([sys.executable, "-m", "labsim", "grade", "assignment.yaml", "class", "--out", "out",
                             "-j", "2"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def _when_the_long_runs_go(tmp_path: Path, proc: subprocess.Popen[str]) -> list[int]:
    """Wait until the quick students are cached (so the long runs have their workers); every pid
    the grading started."""
    began = time.monotonic()
    while len(list((tmp_path / "out" / "cache").glob("*.json"))) < 2:
        if proc.poll() is not None or time.monotonic() - began > PATIENCE_S:
            proc.kill()
            raise AssertionError("the quick students were not cached: " + proc.communicate()[1])
        time.sleep(0.05)
    time.sleep(1.0)  # the long runs sent and going
    return [c.pid for c in psutil.Process(proc.pid).children(recursive=True)]


def _left(pids: list[int]) -> list[int]:
    """The pids still running after PATIENCE_S (none, when every process ended)."""
    procs = []
    for pid in pids:
        with contextlib.suppress(psutil.NoSuchProcess):
            procs.append(psutil.Process(pid))
    _, alive = psutil.wait_procs(procs, timeout=PATIENCE_S)
    for p in alive:  # leave nothing behind, whatever the test says
        p.kill()
    return [p.pid for p in alive]


def _statuses(tmp_path: Path) -> dict[str, str]:
    with open(tmp_path / "out" / "gradebook.csv", newline="") as f:
        return {r["Student"]: r["Status"] for r in csv.DictReader(f)}


@pytest.mark.parametrize(("sig", "group", "code"), [
    (signal.SIGINT, True, 130),  # a terminal's Ctrl-C reaches every process of the group
    (signal.SIGTERM, False, 143),  # kill PID: the grader alone
    (signal.SIGHUP, True, 129),  # the terminal closed: every process of the group
])
def test_a_signalled_grading_keeps_what_is_done_and_leaves_no_worker(
        tmp_path: Path, sig: int, group: bool, code: int) -> None:
    _class(tmp_path)
    proc = _grade(tmp_path)
    children = _when_the_long_runs_go(tmp_path, proc)
    if group:
        os.killpg(proc.pid, sig)
    else:
        proc.send_signal(sig)
    out, err = proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == code, err
    assert "Traceback" not in err
    assert _left(children) == []
    assert _statuses(tmp_path) == {"a_quick": "graded", "b_quick": "graded", "y_long": "interrupted",
                                   "z_long": "interrupted"}
    assert "2 runs made, 0 taken from the cache" in out
    assert "interrupted: 2 submissions left to grade" in out
    assert (tmp_path / "out" / "feedback" / "y_long.html").is_file()
    assert (tmp_path / "out" / "index.html").is_file()


def test_a_second_grading_runs_only_the_interrupted_students(tmp_path: Path) -> None:
    _class(tmp_path)
    proc = _grade(tmp_path)
    _when_the_long_runs_go(tmp_path, proc)
    os.killpg(proc.pid, signal.SIGINT)
    proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == 130
    for name in ("y_long", "z_long"):  # the students finish their work; their runs end now
        path = tmp_path / "class" / f"{name}.yaml"
        path.write_text(path.read_text().replace(LONG, "stop: time >= minutes * 60"))
    again = subprocess.run([sys.executable, "-m", "labsim", "grade", "assignment.yaml", "class", "--out", "out",
                            "-j", "2"], cwd=tmp_path, capture_output=True, text=True, timeout=PATIENCE_S * 5)
    assert again.returncode == 0, again.stderr
    assert "2 runs made, 2 taken from the cache" in again.stdout
    assert set(_statuses(tmp_path).values()) == {"graded"}


@pytest.fixture(scope="module")
def cluster():
    with local_cluster() as c:
        yield c


@pytest.mark.slow
@pytest.mark.long  # a cluster of worker processes, and a grading process signalled mid-run
@pytest.mark.parametrize(("sig", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_a_signalled_grading_on_dask_stops_its_runs_and_keeps_what_is_done(
        tmp_path: Path, cluster, sig: int, code: int) -> None:
    import distributed

    _class(tmp_path)
    proc = subprocess.Popen([sys.executable, "-m", "labsim", "grade", "assignment.yaml", "class", "--out", "out",
                             "--executor", "dask", "--scheduler", cluster.scheduler_address], cwd=tmp_path,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    _when_the_long_runs_go(tmp_path, proc)
    with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
        assert sum(_busy(client).values()) == 2  # the two long runs, going
        proc.send_signal(sig)
        out, err = proc.communicate(timeout=PATIENCE_S)
        # the runs stopped themselves (a worker thread cannot be killed), before the grader ended
        assert sum(_busy(client).values()) == 0
    assert proc.returncode == code, err
    assert "Traceback" not in err
    assert _statuses(tmp_path) == {"a_quick": "graded", "b_quick": "graded", "y_long": "interrupted",
                                   "z_long": "interrupted"}
    assert "2 runs made, 0 taken from the cache" in out
    assert "interrupted: 2 submissions left to grade" in out


def _busy(client) -> dict[str, int]:
    """Each Dask worker's threads running a task now (a cancelled task's thread runs on until its
    function returns: what the scheduler says would not tell)."""
    return client.run(lambda dask_worker: len(dask_worker.active_threads))
