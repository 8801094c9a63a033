"""A sweep ends with its parent (docs/sweep.md, "Ending a sweep"): a real ``labsim sweep`` is sent
each signal that can end it, and then no worker is left, the CSV holds the rows done so far, and
every trace has its footer. Exit codes: 128 + the signal (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP)."""
from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

pytestmark = pytest.mark.slow  # labsim sweeps, signalled mid-run

PATIENCE_S = 60.0  # how long a test waits for a process before calling it hung
# two short runs that finish, then two that run until a signal ends them, on two workers
GRID = ["--set", "minutes=0.05,10000", "--seeds", "1-2", "-j", "2"]


def _start(tmp_path: Path, *extra: str) -> tuple[subprocess.Popen, list[int]]:
    """A sweep in a session of its own (a terminal's process group), once its long runs are
    writing their traces; the pids of every process it started."""
    (tmp_path / "t").mkdir()
    proc = subprocess.Popen([sys.executable, "-m", "labsim", "sweep", "wall_follow", *GRID, "--traces",
                             str(tmp_path / "t"), "-o", str(tmp_path / "r.csv"), *extra],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True)
    began = time.monotonic()
    while len([p for p in (tmp_path / "t").glob("*.partial") if p.stat().st_size > 4000]) < 2:
        if proc.poll() is not None or time.monotonic() - began > PATIENCE_S:
            proc.kill()
            raise AssertionError("the sweep's long runs did not start: " + proc.communicate()[1])
        time.sleep(0.05)
    return proc, [c.pid for c in psutil.Process(proc.pid).children(recursive=True)]


def _gone(pids: list[int]) -> list[int]:
    """The pids still running after PATIENCE_S (none, when every process ended)."""
    _, alive = psutil.wait_procs([p for p in (_process(pid) for pid in pids) if p], timeout=PATIENCE_S)
    for p in alive:  # leave nothing behind, whatever the test says
        p.kill()
    return [p.pid for p in alive]


def _process(pid: int) -> psutil.Process | None:
    try:
        return psutil.Process(pid)
    except psutil.NoSuchProcess:
        return None


def _footers(tmp_path: Path) -> dict[str, dict]:
    out = {}
    for trace in sorted((tmp_path / "t").iterdir()):
        last = trace.read_text().rstrip("\n").rsplit("\n", 1)[1]
        assert last.startswith("# end "), (trace.name, last)
        out[trace.name.split("-")[2]] = out.get(trace.name.split("-")[2], []) + [json.loads(last[len("# end "):])]
    return out


@pytest.mark.parametrize(("sig", "group", "code", "name"), [
    (signal.SIGINT, True, 130, "Ctrl-C"),  # a terminal's Ctrl-C reaches every process of the group
    (signal.SIGTERM, False, 143, "SIGTERM"),  # kill PID: the sweep alone
    (signal.SIGHUP, True, 129, "SIGHUP"),  # the terminal closed: every process of the group
])
def test_a_signalled_sweep_writes_its_rows_closes_its_traces_and_leaves_no_worker(
        tmp_path: Path, sig: int, group: bool, code: int, name: str) -> None:
    proc, children = _start(tmp_path)
    if group:
        os.killpg(proc.pid, sig)
    else:
        proc.send_signal(sig)
    out, err = proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == code, err
    assert "Traceback" not in err
    assert _gone(children) == []
    with open(tmp_path / "r.csv", newline="") as f:
        rows = [(r["minutes"], r["status"], r["message"], r["ticks"]) for r in csv.DictReader(f)]
    assert [r[:3] for r in rows] == [("0.05", "ok", "")] * 2 + [("10000", "interrupted", f"stopped by {name}")] * 2
    footers = _footers(tmp_path)
    assert footers["minutes=0.05"] == [{"interrupted": False, "ticks": 61}] * 2  # and the stopping tick
    assert [f["interrupted"] for f in footers["minutes=10000"]] == [True, True]
    # a worker the signal reached first may end before it sends its count: its row leaves ticks
    # blank, its trace's footer has them
    assert all(f["ticks"] > 60 and (r[3] == "" or int(r[3]) > 60) for f, r in zip(footers["minutes=10000"], rows[2:]))
    if sig != signal.SIGHUP:  # after a hangup there is no terminal to show the table on
        assert "interrupted: 4 runs: 2 ok, 2 interrupted (of 4)" in out


def test_a_killed_sweep_takes_its_workers_with_it(tmp_path: Path) -> None:
    """SIGKILL: the sweep's handlers never run, and no CSV is written; its workers get the
    parent-death signal (Linux), end their runs as for SIGTERM and close their traces."""
    if not sys.platform.startswith("linux"):
        pytest.skip("the parent-death signal is Linux's")
    proc, children = _start(tmp_path)
    proc.kill()
    proc.communicate(timeout=PATIENCE_S)
    assert _gone(children) == []
    footers = _footers(tmp_path)
    assert [f["interrupted"] for f in footers["minutes=10000"]] == [True, True]


def test_a_worker_that_dies_costs_its_run_only(tmp_path: Path) -> None:
    proc, children = _start(tmp_path)
    # the workers: forked from the sweep (Linux) or from its fork server, they start nothing
    workers = [c for c in psutil.Process(proc.pid).children(recursive=True)
               if not c.children() and "resource_tracker" not in " ".join(c.cmdline())]
    os.kill(workers[0].pid, signal.SIGKILL)
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)  # the other long run, ended
    _, err = proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == 143 and "Traceback" not in err
    assert _gone(children) == []
    with open(tmp_path / "r.csv", newline="") as f:
        statuses = sorted(r["status"] for r in csv.DictReader(f))
    assert statuses == ["interrupted", "ok", "ok", "runtime error"]
