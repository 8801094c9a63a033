"""What a trace costs: the wall lab's run phase with and without ``--trace``.

    python benchmarks/bench_trace.py [--repeat 5] [--minutes 25]

Runs behaviours/wall_follow.yaml with no trace and with a trace to a temporary file, alternated
in random order, and checks the trace is byte for byte the one ``labsim run --trace`` writes.
Prints the median CPU time of each side and the median of the per-round ratios (goal: traced
<= 1.5 x untraced), with the load average. CPU seconds are noisy on a shared machine; for a
figure that is not, count the instructions of the two runs with ``valgrind --tool=callgrind``
(and of a run of a few ticks, to take the start-up out).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import alternate, machine, report, run_phase

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--minutes", type=float, default=25)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "run.csv"
        ticks = [0]

        def side(trace: Path | None) -> Callable[[], float]:
            def timed() -> float:
                elapsed, ticks[0] = run_phase(LAB, {"minutes": str(args.minutes)}, trace)
                return elapsed
            return timed

        print(machine())
        times = alternate({"untraced": side(None), "traced": side(path)}, args.repeat)
        rows = path.read_text().count("\n") - 3  # the header, the columns and the footer lines
    report(f"wall lab, {ticks[0]} ticks, {rows:,} trace rows", times, ("traced", "untraced"), "<= 1.5")


if __name__ == "__main__":
    main()
