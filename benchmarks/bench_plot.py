"""How long `labsim plot` takes, and how much memory it needs, for a long trace: the wall lab's
golden (30,000 rows) as a map, and a trace of about ``--mb`` megabytes made of the golden's rows
repeated (its ticks and times running on) as a map, a signals chart and a GIF.

    python benchmarks/bench_plot.py [--repeat 3] [--mb 250]

Each picture is made by a new `python -m labsim plot` process. Prints for each the median wall
time and CPU time (user + system, with children) over the rounds, the largest peak resident
memory, and the load average. Goals: the golden's map <= 3 s; memory that does not grow with the
trace's size (docs/pictures.md states the bound).
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import machine
from timed_child import MIB, labsim, load, print_medians, rounds

TRACE = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.golden.csv"


def long_trace(path: Path, megabytes: float) -> int:
    """The golden's rows again and again, ticks and times running on, to about ``megabytes``;
    returns the rows written."""
    lines = TRACE.read_text().splitlines(keepends=True)
    head, rows = lines[:2], [ln for ln in lines[2:] if not ln.startswith("#")]
    ticks = int(rows[-1].split(",", 1)[0]) + 1
    dt = float(rows[1].split(",")[1]) - float(rows[0].split(",")[1])
    n = 0
    with path.open("w") as f:
        f.writelines(head)
        lap = 0
        while f.tell() < megabytes * MIB:
            for row in rows:
                tick, time, rest = row.split(",", 2)
                t = int(tick) + lap * ticks
                f.write(f"{t},{t * dt:.6g},{rest}")
            n += len(rows)
            lap += 1
    return n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--mb", type=float, default=250.0, help="the long trace's size, megabytes")
    args = parser.parse_args()
    print(machine())
    with tempfile.TemporaryDirectory() as d:
        big = Path(d) / "long.csv"
        rows = long_trace(big, args.mb)
        size = big.stat().st_size / MIB
        cases = {"golden, 30,000 rows, map PNG": labsim("plot", str(TRACE), "-o", str(Path(d) / "golden.png")),
                 f"{size:.0f} MiB, {rows:,} rows, map PNG": labsim("plot", str(big), "-o", str(Path(d) / "map.png")),
                 f"{size:.0f} MiB, signals PNG": labsim("plot", str(big), "--signals", "ahead,right",
                                                        "-o", str(Path(d) / "signals.png")),
                 f"{size:.0f} MiB, GIF": labsim("plot", str(big), "-o", str(Path(d) / "run.gif"))}
        before = load()
        times = rounds(cases, args.repeat)
    print(f"medians of {args.repeat} rounds in random order ({before} before, {load()} after):")
    print_medians(times)


if __name__ == "__main__":
    main()
