"""benchmarks/bench_coppeliasim.py runs, and reports the round trips per tick of each way.

Speed is not checked (shared machines are noisy); round trips per tick are counts, not times.
"""
from __future__ import annotations

import subprocess
import sys

import pytest
from helpers import BENCHMARKS

pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

pytestmark = pytest.mark.slow  # the benchmark runs every lab through labsim serve

SCRIPT = BENCHMARKS / "bench_coppeliasim.py"


@pytest.mark.slow
@pytest.mark.long
def test_the_coppeliasim_benchmark_reports_every_lab_every_way() -> None:
    done = subprocess.run([sys.executable, str(SCRIPT), "--repeat", "1", "--minutes", "0.1"],
                          capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    rows = {tuple(line.split()[:3]): float(line.split()[3]) for line in done.stdout.splitlines()
            if line.startswith("  ") and line.split()[0] in ("wall_follow", "road_follow", "crane")}
    assert "load average" in done.stdout and "CPU" in done.stdout
    for lab in ("wall_follow", "road_follow", "crane"):
        per_object, fleet = rows[lab, "per", "object"], rows[lab, "fleet", "script"]
        assert fleet <= 4.3 < per_object, done.stdout  # 3 or 4 a tick, and the close over few ticks
        assert rows[lab, "serve", "--for"] <= 4.3, done.stdout  # the student's path has the fleet script
