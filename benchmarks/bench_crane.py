"""Real-time factor of the crane lab: simulated seconds per CPU second.

    python benchmarks/bench_crane.py [--repeat 7]

Runs behaviours/crane.yaml (60 simulated seconds, 1200 ticks) without a trace and with one,
alternated in random order, and prints the median CPU time and real-time factor of each
(goal: >= 400x real time without a trace), with the load average.
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import alternate, machine, report

from labsim.backends import load_backend
from labsim.runtime.run import compile_behaviour

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "crane.yaml"


def once(trace: Path | None) -> tuple[float, float]:
    run = compile_behaviour(LAB).bind(load_backend("pymunk"), trace=trace, warn=lambda m: None)
    start = time.process_time()
    summary = run.run()
    elapsed = time.process_time() - start
    run.close()
    return elapsed, summary.sim_time_s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    sim = [0.0]

    def side(trace: Path | None) -> Callable[[], float]:
        def timed() -> float:
            elapsed, sim[0] = once(trace)
            return elapsed
        return timed

    print(machine())
    with tempfile.TemporaryDirectory() as d:
        times = alternate({"no trace": side(None), "with trace": side(Path(d) / "crane.csv")}, args.repeat)
    report(f"crane lab, {sim[0]:.0f} s simulated", times)
    for label, values in times.items():
        median = statistics.median(values)
        print(f"  {label}: {sim[0] / median:,.0f}x real time" + ("   (goal >= 400x)" if label == "no trace" else ""))


if __name__ == "__main__":
    main()
