"""How long `labsim plot`'s other pictures take: the road lab's 30-second MP4, the wall lab's
25-minute GIF, a signals PNG of the wall lab's 30,000-row trace, and the road lab's map with its
road panel and a camera strip.

    python benchmarks/bench_pictures.py [--repeat 3]

Prints the median CPU time of each (ffmpeg's included), from the trace file to the written file, through the same
command as a user types (goal for the signals PNG: < 2 s).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import children_cpu, machine

from labsim.runtime.cli.main import main as labsim

LABS = Path(__file__).resolve().parent.parent / "behaviours"
CASES = [("road lab, 30 s, MP4", "road_follow.golden.csv", "road.mp4", []),
         ("wall lab, 25 min, GIF", "wall_follow.golden.csv", "wall.gif", []),
         ("wall lab, 30,000 rows, signals PNG", "wall_follow.golden.csv", "signals.png", ["--signals"]),
         ("road lab, map with road panel and camera strip", "road_follow.golden.csv", "road.png",
          ["--camera", "pioneer[0]"])]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(machine())
    with tempfile.TemporaryDirectory() as d:
        for what, trace, out, extra in CASES:
            times = []
            for _ in range(args.repeat):
                start = time.process_time() + children_cpu()  # the MP4's ffmpeg is a child
                with contextlib.redirect_stdout(io.StringIO()):
                    code = labsim(["plot", str(LABS / trace), "-o", str(Path(d) / out), *extra])
                times.append(time.process_time() + children_cpu() - start)
                assert code == 0, what
            print(f"{what}: median {statistics.median(times):.2f} s CPU over {args.repeat} runs")


if __name__ == "__main__":
    main()
