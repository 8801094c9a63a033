"""How long `labsim plot`'s pictures take, as a user meets them: the road lab's 30-second MP4, the
wall lab's 25-minute GIF, the wall lab's MP4 at 10 and at 60 simulated minutes (the same 601
frames: its time should not grow with the run), a signals PNG of the wall lab's 30,000-row
trace, and the road lab's map with its road panel and a camera strip.

    python benchmarks/bench_pictures.py [--repeat 3]

Each picture is made by a new `python -m labsim plot` process, from the trace file to the written
file, the cases in a fresh random order each round. Prints for each the median wall time, the
median CPU time (user + system, ffmpeg's included), and the peak resident memory of the process
or its ffmpeg (the largest over the rounds), with the load average before and after; then the
60-minute MP4's time over the 10-minute one's, the median of the per-round ratios. Goals (issue
30): GIF <= 4 s wall and <= 200 MiB; each MP4 <= 2.5 s wall, 60 over 10 minutes <= 1.3; signals
PNG < 2 s.
"""
from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import machine
from timed_child import labsim, load, print_medians, rounds

LABS = Path(__file__).resolve().parent.parent / "behaviours"


def cases(d: Path, quick: bool) -> dict[str, list[str]]:
    """The commands by name; the wall lab's 10- and 60-minute traces are made first, in ``d``
    (``quick``: 1 and 6 minutes, and every animation at 1 frame a second, to see that it runs)."""
    for minutes in (10, 60):
        run = minutes / 10 if quick else minutes
        subprocess.run(labsim("run", str(LABS / "wall_follow.yaml"), "--set", f"minutes={run:g}", "--quiet",
                              "--trace", str(d / f"wall{minutes}.csv")), check=True)
    wall, road = str(LABS / "wall_follow.golden.csv"), str(LABS / "road_follow.golden.csv")
    fps = ["--fps", "1"] if quick else []
    return {
        "road lab, 30 s, MP4": labsim("plot", road, "-o", str(d / "road.mp4"), *fps),
        "wall lab, 25 min, GIF": labsim("plot", wall, "-o", str(d / "wall.gif"), *fps),
        "wall lab, 10 min, MP4": labsim("plot", str(d / "wall10.csv"), "-o", str(d / "wall10.mp4"), *fps),
        "wall lab, 60 min, MP4": labsim("plot", str(d / "wall60.csv"), "-o", str(d / "wall60.mp4"), *fps),
        "wall lab, 30,000 rows, signals PNG": labsim("plot", wall, "--signals", "-o", str(d / "signals.png")),
        "road lab, map, road panel, camera strip": labsim("plot", road, "--camera", "pioneer[0]",
                                                          "-o", str(d / "road.png")),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--quick", action="store_true", help="short runs and few frames: does it run (no figures)")
    args = parser.parse_args()
    print(machine())
    with tempfile.TemporaryDirectory() as d:
        commands = cases(Path(d), args.quick)
        before = load()
        times = rounds(commands, args.repeat)
    print(f"medians of {args.repeat} rounds in random order ({before} before, {load()} after):")
    print_medians(times)
    long, short = times["wall lab, 60 min, MP4"], times["wall lab, 10 min, MP4"]
    wall_ratio = statistics.median(a.wall_s / b.wall_s for a, b in zip(long, short))
    cpu_ratio = statistics.median(a.cpu_s / b.cpu_s for a, b in zip(long, short))
    print(f"  MP4, 60 over 10 minutes: {wall_ratio:.2f}x wall, {cpu_ratio:.2f}x CPU (goal <= 1.3x)")


if __name__ == "__main__":
    main()
