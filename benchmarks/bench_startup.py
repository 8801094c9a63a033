"""Cold start: whole `labsim check`, `labsim run` and one-run `labsim sweep` processes on the wall lab.

    python benchmarks/bench_startup.py [--repeat 7] [--minutes 25] [--no-cache]

Each round starts ``python -m labsim check behaviours/wall_follow.yaml``, ``python -m
labsim run behaviours/wall_follow.yaml`` (the lab's 25 minutes, 30,000 ticks) and ``python -m
labsim sweep`` of that one run as new processes, in a fresh random order, and prints the
median CPU time of each (user + system of the process and every process it started: a
sweep's fork server and workers outlive it briefly and are collected here, this process
being their subreaper on Linux), its median wall time and its peak RSS (the largest of its
processes) beside it (goals: check <= 0.2 s, the whole run <= 1.0 s; a one-run sweep's fixed
cost over the run, the median of the rounds' differences, <= 0.25 s wall, peak RSS <= 60 MiB).
labsim's cache folder (grammar tables) is used as an installed labsim uses it, warmed by one
untimed round first; ``--no-cache`` gives every process an empty cache folder of its own.
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
from compare import alternate, machine, report

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml"


PR_SET_CHILD_SUBREAPER = 36  # linux/prctl.h: orphaned descendants come to this process


def subreaper() -> None:
    """Become the parent of every orphaned descendant (Linux), so that their CPU time and memory
    are counted here when they end; elsewhere only the direct child and what it waited for are."""
    if sys.platform.startswith("linux"):
        import ctypes

        ctypes.CDLL(None).prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)


def process(argv: list[str], no_cache: bool, walls: list[float], peaks: list[float]) -> Callable[[], float]:
    """A side that starts ``python -m labsim *argv`` and returns the CPU seconds of it and every
    process it started; its wall time and peak RSS (MiB, the largest process) go in the lists."""
    def once() -> float:
        env = dict(os.environ)
        with tempfile.TemporaryDirectory() as empty, tempfile.TemporaryFile() as err:
            if no_cache:
                env["LABSIM_CACHE_DIR"] = empty
            start = time.perf_counter()
            proc = subprocess.Popen([sys.executable, "-m", "labsim", *argv], env=env, stdout=subprocess.DEVNULL,
                                    stderr=err)
            _, status, usage = os.wait4(proc.pid, 0)
            walls.append(time.perf_counter() - start)
            proc.returncode = os.waitstatus_to_exitcode(status)
            cpu, peak = usage.ru_utime + usage.ru_stime, usage.ru_maxrss
            while True:  # the orphans: a sweep's fork server (with its workers' time in its own)
                try:
                    _, _, usage = os.wait4(-1, 0)
                except ChildProcessError:
                    break
                cpu, peak = cpu + usage.ru_utime + usage.ru_stime, max(peak, usage.ru_maxrss)
            peaks.append(peak / 1024)
            if proc.returncode != 0:
                err.seek(0)
                raise SystemExit(f"labsim {' '.join(argv)} failed:\n{err.read().decode()}")
        return cpu
    return once


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--minutes", type=float, default=25)
    parser.add_argument("--no-cache", action="store_true")
    args = parser.parse_args()
    subreaper()
    walls: dict[str, list[float]] = {"labsim check": [], "labsim run": [], "labsim sweep": []}
    peaks: dict[str, list[float]] = {name: [] for name in walls}
    minutes = f"minutes={args.minutes:g}"
    argvs = {"labsim check": ["check", str(LAB)], "labsim run": ["run", str(LAB), "--set", minutes],
             "labsim sweep": ["sweep", str(LAB), "--set", minutes]}
    sides = {name: process(argv, args.no_cache, walls[name], peaks[name]) for name, argv in argvs.items()}
    for side in sides.values():  # warm the cache (and the disk's) once, untimed
        side()
    for lists in (*walls.values(), *peaks.values()):
        lists.clear()
    print(machine())
    times = alternate(sides, args.repeat)
    report(f"cold processes, wall lab ({args.minutes:g} simulated minutes), "
           f"{'empty cache' if args.no_cache else 'cache warm'}; CPU time of the process and its children", times)
    for name, goal in (("labsim check", "(goal <= 0.2 s)"), ("labsim run", "(goal <= 1.0 s)"), ("labsim sweep", "")):
        print(f"  {name + ':':<14}median {statistics.median(times[name]):.3f} s CPU, "
              f"{statistics.median(walls[name]):.3f} s wall, peak RSS {max(peaks[name]):.1f} MiB   {goal}".rstrip())
    wall_cost = statistics.median(s - r for s, r in zip(walls["labsim sweep"], walls["labsim run"]))
    cpu_cost = statistics.median(s - r for s, r in zip(times["labsim sweep"], times["labsim run"]))
    print(f"  one-run sweep over labsim run: +{wall_cost:.3f} s wall, +{cpu_cost:.3f} s CPU (medians of the rounds' "
          f"differences; goal <= +0.25 s wall, peak RSS <= 60 MiB)")
    print(f"  {machine()[2:]}")  # the load once more: it may have changed while measuring


if __name__ == "__main__":
    main()
