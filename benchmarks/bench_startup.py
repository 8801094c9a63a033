"""Cold start: whole `labsim check` and `labsim run` processes on the wall lab.

    python benchmarks/bench_startup.py [--repeat 7] [--minutes 25] [--no-cache]

Each round starts ``python -m labsim check behaviours/wall_follow.yaml`` and ``python -m
labsim run behaviours/wall_follow.yaml`` (the lab's 25 minutes, 30,000 ticks) as new
processes, in a fresh random order, and prints the median CPU time of each process (user +
system, from the operating system's accounting of finished children), with its median wall
time beside it (goals: check <= 0.2 s, the whole run <= 1.0 s). labsim's cache folder
(grammar tables) is used as an installed labsim uses it, warmed by one untimed round first;
``--no-cache`` gives every process an empty cache folder of its own instead.
"""
from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import alternate, children_cpu, machine, report

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml"


def process(argv: list[str], no_cache: bool, walls: list[float]) -> Callable[[], float]:
    """A side that starts ``python -m labsim *argv`` and returns the process's CPU seconds."""
    def once() -> float:
        env = dict(os.environ)
        with tempfile.TemporaryDirectory() as empty:
            if no_cache:
                env["LABSIM_CACHE_DIR"] = empty
            before, start = children_cpu(), time.perf_counter()
            done = subprocess.run([sys.executable, "-m", "labsim", *argv], env=env, capture_output=True, text=True)
            walls.append(time.perf_counter() - start)
            cpu = children_cpu() - before
        if done.returncode != 0:
            raise SystemExit(f"labsim {' '.join(argv)} failed:\n{done.stderr}")
        return cpu
    return once


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--minutes", type=float, default=25)
    parser.add_argument("--no-cache", action="store_true")
    args = parser.parse_args()
    check_walls: list[float] = []
    run_walls: list[float] = []
    sides = {"labsim check": process(["check", str(LAB)], args.no_cache, check_walls),
             "labsim run": process(["run", str(LAB), "--set", f"minutes={args.minutes:g}"], args.no_cache, run_walls)}
    for side in sides.values():  # warm the cache (and the disk's) once, untimed
        side()
    check_walls.clear()
    run_walls.clear()
    print(machine())
    times = alternate(sides, args.repeat)
    report(f"cold processes, wall lab ({args.minutes:g} simulated minutes), "
           f"{'empty cache' if args.no_cache else 'cache warm'}; CPU time of the whole process", times)
    print(f"  labsim check: median {statistics.median(times['labsim check']):.3f} s CPU, "
          f"{statistics.median(check_walls):.3f} s wall   (goal <= 0.2 s)")
    print(f"  labsim run:   median {statistics.median(times['labsim run']):.3f} s CPU, "
          f"{statistics.median(run_walls):.3f} s wall   (goal <= 1.0 s)")


if __name__ == "__main__":
    main()
