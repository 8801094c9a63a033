"""The Dask executor against runs that kill their process, and against Ctrl-C (docs/sweep.md,
"Beyond one machine"): a run's death is that run's row and nobody else's, and a stopped sweep
leaves nothing computing on the cluster."""
from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import psutil
import pytest
from helpers import BEHAVIOURS, local_cluster

from labsim.runtime.cli.main import main

pytestmark = [pytest.mark.slow, pytest.mark.long]  # a Dask cluster of two processes, a worker killed
distributed = pytest.importorskip("distributed")

LAB = str(BEHAVIOURS / "wall_follow.yaml")
PATIENCE_S = 60.0
ISOLATED = "labsim.runtime.sweep.isolated"


@pytest.fixture(scope="module")
def cluster():
    with local_cluster() as c:
        yield c


def _workers(cluster) -> dict[str, int]:
    with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
        return client.run(os.getpid)


def _runs(worker_pids: list[int]) -> list[psutil.Process]:
    """The processes of the runs in progress: the Dask workers' isolated children."""
    out = []
    for pid in worker_pids:
        with contextlib.suppress(psutil.NoSuchProcess):
            out += [c for c in psutil.Process(pid).children() if ISOLATED in " ".join(c.cmdline())]
    return out


def test_a_run_that_kills_its_process_fails_alone(capsys, tmp_path: Path, cluster) -> None:
    """The run's process is killed (as the OOM killer or a crash would); the Dask workers live
    on, no run is retried, and every other row is ok."""
    before = _workers(cluster)
    killed: list[int] = []

    def kill_one_run() -> None:
        deadline = time.monotonic() + PATIENCE_S
        while time.monotonic() < deadline and not killed:
            runs = _runs(list(before.values()))
            if runs:
                time.sleep(0.5)  # into the run
                with contextlib.suppress(psutil.NoSuchProcess):  # ended already: the next one
                    runs[0].kill()
                    killed.append(runs[0].pid)
            time.sleep(0.05)

    killer = threading.Thread(target=kill_one_run)
    killer.start()
    path = tmp_path / "r.json"
    # 60 simulated minutes: the run is still going when it is killed (half a second of CPU after
    # its process's start-up: the sonars are cast in C), and the three that live cost little
    code = main(["sweep", LAB, "--set", "minutes=60", "--seeds", "1-4", "--executor", "dask",
                 "--scheduler", cluster.scheduler_address, "--json", str(path)])
    killer.join()
    out, err = capsys.readouterr()
    assert killed and "Traceback" not in out + err
    rows = json.loads(path.read_text())["rows"]
    assert code == 1 and sorted(r["status"] for r in rows) == ["ok"] * 3 + ["runtime error"]
    dead = next(r for r in rows if r["status"] == "runtime error")
    assert "the run's process died while running it (killed by signal 9); the Dask worker carries on" in dead["message"]
    assert all(r["retries"] == 0 for r in rows)
    assert _workers(cluster) == before  # the same worker processes


def test_ctrl_c_stops_the_runs_on_the_cluster(tmp_path: Path, cluster) -> None:
    workers = list(_workers(cluster).values())
    proc = subprocess.Popen([sys.executable, "-m", "labsim", "sweep", LAB, "--set", "minutes=10000", "--seeds",
                             "1-6", "--executor", "dask", "--scheduler", cluster.scheduler_address,
                             "-o", str(tmp_path / "r.csv")], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    began = time.monotonic()
    while len(_runs(workers)) < 2:
        assert proc.poll() is None and time.monotonic() - began < PATIENCE_S, proc.communicate()
        time.sleep(0.1)
    runs = _runs(workers)
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=PATIENCE_S)
    assert proc.returncode == 130 and "Traceback" not in err, err
    _, alive = psutil.wait_procs(runs, timeout=15)  # each looks at the sweep's Event twice a second
    assert alive == []
    with distributed.Client(cluster.scheduler_address, set_as_default=False) as client:
        deadline = time.monotonic() + 15
        while any(client.processing().values()) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not any(client.processing().values())
    lines = (tmp_path / "r.csv").read_text().splitlines()
    # the runs submitted (two per worker thread) are rows; the two never sent are not
    assert len(lines) == 5 and all(",interrupted,stopped by Ctrl-C," in line for line in lines[1:])
