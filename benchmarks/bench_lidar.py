"""A 360-beam lidar on one robot: ticks per CPU second, the backend alone and a whole run.

``benchmarks/lidar_wander.yaml`` puts a Pioneer with a 360-beam, 5 m lidar in the wall lab's
room. Two figures: the pymunk backend's ``sense()`` and ``step()`` alone for the robot reading
every beam (the rays, grouped and cast through chipmunk as the sonars are), and labsim's whole
run of the behaviour (the scan reduced with ``min`` and ``argmin`` every tick). Goal: >= 20,000
ticks per CPU second.

    python benchmarks/bench_lidar.py [--repeat 5] [--ticks 2000]
"""
from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path

from compare import labsim_scene, machine

LAB = Path(__file__).resolve().parent / "lidar_wander.yaml"
GOAL = 20_000


def backend_alone(ticks: int) -> tuple[float, float]:
    """Ticks per CPU second and per wall second of the backend's sense() and step(), the robot
    driving a slow arc."""
    _program, backend, run = labsim_scene(LAB)
    backend.act(0, 3.0, 2.0)
    start, wall = time.process_time(), time.perf_counter()
    for _ in range(ticks):
        backend.sense()
        backend.step()
    elapsed, wall = time.process_time() - start, time.perf_counter() - wall
    run.close()
    return ticks / elapsed, ticks / wall


def whole_run(ticks: int) -> tuple[float, float]:
    """Ticks per CPU second and per wall second of labsim running the behaviour for ``ticks`` ticks."""
    _program, _backend, run = labsim_scene(LAB)
    start, wall = time.process_time(), time.perf_counter()
    for _ in range(ticks):
        run.tick()
    elapsed, wall = time.process_time() - start, time.perf_counter() - wall
    run.close()
    return ticks / elapsed, ticks / wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--ticks", type=int, default=2000)
    args = parser.parse_args()
    print(machine())
    for name, fn in (("backend sense + step", backend_alone), ("labsim run", whole_run)):
        rates = [fn(args.ticks) for _ in range(args.repeat)]
        median = statistics.median(cpu for cpu, _ in rates)
        wall = statistics.median(w for _, w in rates)
        print(f"  {name}: median {wall:,.0f} ticks per wall second, {median:,.0f} per CPU second over "
              f"{args.repeat} x {args.ticks} ticks (goal >= {GOAL:,} per CPU second: "
              f"{'met' if median >= GOAL else 'NOT met'})")
    print(f"  {machine()[2:]}")  # the load again: wall figures depend on it


if __name__ == "__main__":
    main()
