"""The benchmarks' shared harness: time two sides fairly on a shared, noisy machine.

Every ``bench_*.py`` that compares two things (labsim against a hand-written loop, labsim
against IR-SIM, noise against none, a cold ``check`` against a cold ``run``) goes through
``alternate``: each round runs every side once, in a fresh random order, so that a busy
moment or a warm cache does not always favour the same side. Times are CPU time
(``time.process_time``, or the children's CPU time for a side that starts processes), which
another job on the machine slows far less than wall-clock time. ``report`` prints each side's
median and the median of the per-round ratios (one ratio per round, both sides measured
moments apart: steadier than the ratio of the medians), and ``machine`` the line that says
when and where, with the load average, so that the figures can be pasted as they are.
Beside the time a side measures itself, ``alternate`` takes each side's whole call (its
set-up included) in wall time and in CPU time with its children's (workers, ffmpeg, a
browser: whatever it started and waited for), and ``report`` prints both with the load
average at the end: a CPU figure alone hides work done in other processes, a wall figure
alone hides the load.
"""
from __future__ import annotations

import argparse
import math
import os
import platform
import random
import resource
import statistics
import time
from collections.abc import Callable, Sequence
from datetime import datetime, timezone
from pathlib import Path

from labsim.backends import load_backend
from labsim.runtime.run import compile_behaviour

Pose = tuple[float, float, float]
Side = Callable[[], tuple[float, list[Pose]]]  # one run: (CPU seconds, final poses)


def machine() -> str:
    """When and where: the date, the machine, its cores and the load average now."""
    one, five, fifteen = os.getloadavg()
    return (f"# {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.system()} {platform.machine()}, "
            f"{os.cpu_count()} cores, Python {platform.python_version()}; "
            f"load average {one:.2f} {five:.2f} {fifteen:.2f} (1, 5, 15 min)")


def cpu_timed(fn: Callable[[], object]) -> tuple[float, object]:
    """fn's CPU time in this process, and what it returned."""
    start = time.process_time()
    result = fn()
    return time.process_time() - start, result


def run_phase(path: Path, params: dict[str, str], trace: Path | None = None,
              walls: list[float] | None = None) -> tuple[float, int]:
    """The CPU seconds of one run's run phase (compiled and bound beforehand), and its ticks;
    its wall seconds are appended to ``walls`` when given."""
    run = compile_behaviour(path, params).bind(load_backend("pymunk"), trace=trace, warn=lambda m: None)
    wall, start = time.perf_counter(), time.process_time()
    summary = run.run()
    elapsed = time.process_time() - start
    if walls is not None:
        walls.append(time.perf_counter() - wall)
    run.close()
    return elapsed, summary.ticks


def report_walls(walls: dict[str, list[float]]) -> None:
    """Each side's median wall time, after ``report``'s CPU figures (an in-process side has no
    children: its CPU time is the process's own)."""
    width = max(len(name) for name in walls)
    for name, values in walls.items():
        print(f"  {name:<{width}}  {statistics.median(values):.4f} s wall")


def children_cpu() -> float:
    """CPU seconds used so far by this process's finished children (user + system)."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


class Times(dict[str, list[float]]):
    """Each side's own times by name (what ``alternate`` returned before), and of each side's
    whole calls: ``wall`` seconds and ``cpu`` seconds, this process's and its children's."""

    def __init__(self, names: Sequence[str]) -> None:
        super().__init__({name: [] for name in names})
        self.wall: dict[str, list[float]] = {name: [] for name in names}
        self.cpu: dict[str, list[float]] = {name: [] for name in names}


def alternate(sides: dict[str, Callable[[], float]], repeat: int, seed: int | None = None) -> Times:
    """Run each side ``repeat`` times, every round in a fresh random order; their times by name.

    A side returns the seconds it measured itself (only the part that is timed); its whole
    call is timed too, in wall and CPU (children included) seconds (``Times``).
    """
    rng = random.Random(seed)
    times = Times(list(sides))
    names = list(sides)
    for _ in range(repeat):
        rng.shuffle(names)
        for name in names:
            wall, cpu = time.perf_counter(), time.process_time() + children_cpu()
            times[name].append(sides[name]())
            times.wall[name].append(time.perf_counter() - wall)
            times.cpu[name].append(time.process_time() + children_cpu() - cpu)
    return times


def pair_ratios(top: Sequence[float], bottom: Sequence[float]) -> list[float]:
    """Round by round, top / bottom."""
    return [t / b for t, b in zip(top, bottom)]


def report(title: str, times: dict[str, list[float]], ratio: tuple[str, str] | None = None,
           goal: str = "", unit: str = "s CPU") -> float | None:
    """Print each side's median (and its runs), then the median of the per-round ratios of
    ``ratio`` = (top, bottom) with its goal; return that ratio."""
    repeat = len(next(iter(times.values())))
    print(f"{title}, medians of {repeat} rounds in random order:")
    width = max(len(name) for name in times)
    for name, values in times.items():
        print(f"  {name:<{width}}  {statistics.median(values):.4f} {unit}   ({', '.join(f'{v:.4f}' for v in values)})")
    if isinstance(times, Times):
        print("  each side's whole call (set-up included), medians: wall time first, then CPU time of the "
              "process and the children it waited for:")
        for name in times:
            print(f"  {name:<{width}}  {statistics.median(times.wall[name]):.4f} s wall, "
                  f"{statistics.median(times.cpu[name]):.4f} s CPU")
        one, five, _ = os.getloadavg()
        print(f"  load average at the end: {one:.2f} {five:.2f} (1, 5 min; {os.cpu_count()} cores): "
              "wall times grow with it")
    if ratio is None:
        return None
    top, bottom = ratio
    median = statistics.median(pair_ratios(times[top], times[bottom]))
    print(f"  {top} / {bottom}: median of per-round ratios {median:.3f}" + (f"   (goal {goal})" if goal else ""))
    return median


def labsim_side(lab: Path, robots: int, walls: list[float] | None = None,
                params: dict[str, str] | None = None) -> tuple[float, list[Pose]]:
    """One labsim run of a behaviour file on the pymunk backend: its CPU time and final poses
    (its wall time appended to ``walls`` when given)."""
    behaviour = compile_behaviour(lab, params or {})
    backend = load_backend("pymunk")
    run = behaviour.bind(backend, warn=lambda m: None)
    wall, start = time.perf_counter(), time.process_time()
    run.run()
    elapsed = time.process_time() - start
    if walls is not None:
        walls.append(time.perf_counter() - wall)
    poses = [backend.pose(i) for i in range(robots)]
    run.close()
    return elapsed, poses


def labsim_scene(lab: Path, params: dict[str, str] | None = None):
    """The scene a hand-written loop drives: bound exactly as labsim binds it (same seed, same
    start poses). Returns the compiled program, the pymunk backend and the bound run."""
    behaviour = compile_behaviour(lab, params or {})
    backend = load_backend("pymunk")
    return behaviour.program, backend, behaviour.bind(backend, warn=lambda m: None)


def same_poses(a: list[Pose], b: list[Pose]) -> bool:
    return len(a) == len(b) and all(
        math.isclose(x, y, rel_tol=0, abs_tol=1e-12) for p, q in zip(a, b) for x, y in zip(p, q))


def alternate_poses(sides: dict[str, Side], repeat: int) -> tuple[Times, dict[str, list[Pose]]]:
    """``alternate`` for sides that return (seconds, final poses): their times, and each side's
    poses of its last round."""
    poses: dict[str, list[Pose]] = {}

    def side(name: str, run: Side) -> Callable[[], float]:
        def once() -> float:
            seconds, poses[name] = run()
            return seconds
        return once

    return alternate({name: side(name, run) for name, run in sides.items()}, repeat), poses


def compare(description: str, title: str, labsim_run: Side, hand_run: Side, repeat: int = 7) -> float:
    """Parse --repeat, time both sides in alternation, print the figures; return the ratio."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--repeat", type=int, default=repeat)
    args = parser.parse_args()
    print(machine())
    times, poses = alternate_poses({"hand-written loop": hand_run, "labsim": labsim_run}, args.repeat)
    ratio = report(title, times, ("labsim", "hand-written loop"), "<= 1.05")
    same = same_poses(poses["labsim"], poses["hand-written loop"])
    print(f"  same final poses: {'yes' if same else 'NO'}")
    if not same:
        for p, q in zip(poses["labsim"], poses["hand-written loop"]):
            print(f"    labsim {p}  hand {q}")
    assert ratio is not None
    return ratio
