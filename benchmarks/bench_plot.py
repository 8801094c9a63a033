"""How long `labsim plot` takes to draw a long trace: the wall lab's golden, 30,000 rows.

    python benchmarks/bench_plot.py [--repeat 5]

Prints the median CPU time of reading the trace and drawing it to a PNG (goal: <= 3 s).
"""
from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import machine

from labsim.runtime.pictures.plot import plot_trace

TRACE = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.golden.csv"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    times = []
    with tempfile.TemporaryDirectory() as d:
        for _ in range(args.repeat):
            start = time.process_time()
            plot_trace(TRACE, Path(d) / "wall.png")
            times.append(time.process_time() - start)
    rows = sum(1 for line in TRACE.open() if not line.startswith("#")) - 1
    print(machine())
    print(f"plot of {rows:,} rows: median {statistics.median(times):.3f} s CPU over {args.repeat} runs "
          f"(goal <= 3 s)")


if __name__ == "__main__":
    main()
