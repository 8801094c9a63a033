"""Real-time factor of the crane lab: simulated seconds per wall-clock second.

    python benchmarks/bench_crane.py [--repeat 7]

Runs behaviours/crane.yaml (60 simulated seconds, 1200 ticks, no trace) and prints the median
wall time and real-time factor, with and without writing a trace (goal: >= 200x real time).
"""
from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from labsim.backends import load_backend
from labsim.runtime.run import compile_behaviour

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "crane.yaml"


def once(trace: Path | None) -> tuple[float, float]:
    run = compile_behaviour(LAB).bind(load_backend("pymunk"), trace=trace, warn=lambda m: None)
    start = time.perf_counter()
    summary = run.run()
    elapsed = time.perf_counter() - start
    run.close()
    return elapsed, summary.sim_time_s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as d:
        plain, traced, sim = [], [], 0.0
        for _ in range(args.repeat):
            t, sim = once(None)
            plain.append(t)
            traced.append(once(Path(d) / "crane.csv")[0])
    for label, times in (("no trace", plain), ("with trace", traced)):
        median = statistics.median(times)
        print(f"crane lab, {sim:.0f} s simulated, {label:10s}: median {median:.3f} s, "
              f"{sim / median:,.0f}x real time   (goal >= 200x)")


if __name__ == "__main__":
    main()
