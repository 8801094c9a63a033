"""A 360-beam lidar on one robot: ticks per CPU second, the backend alone and a whole run.

``benchmarks/lidar_wander.yaml`` puts a Pioneer with a 360-beam, 5 m lidar in the wall lab's
room. Three figures, each side timed in CPU seconds in alternated rounds (a fresh random order
each round, so a load that comes and goes falls on both): the fan cast (the robot's ray caster,
``labsim.backends.pymunk.ray_cast``, with its ``lidar_fan``) against casting every beam through chipmunk, over the
same poses of the robot; the pymunk backend's ``sense()`` and ``step()`` alone for the robot
reading every beam; and labsim's whole run of the behaviour (the scan reduced with ``min``
and ``argmin`` every tick). Goal: >= 20,000 ticks per CPU second. A fifth side is the floor:
the whole run of ``benchmarks/lidar_floor.yaml``, the same robot, room and start without the
lidar, what a tick costs before a beam is cast.

    python benchmarks/bench_lidar.py [--repeat 5] [--ticks 2000]
"""
from __future__ import annotations

import argparse
import math
import statistics
import time
from pathlib import Path

from compare import alternate, labsim_scene, machine, pair_ratios

LAB = Path(__file__).resolve().parent / "lidar_wander.yaml"
FLOOR = LAB.with_name("lidar_floor.yaml")  # no lidar
GOAL = 20_000


def poses_and_fan(ticks: int) -> tuple[list[tuple[float, float, float]], object, object]:
    """The robot's poses over ``ticks`` ticks of a slow arc, its ray caster (the call sense()
    makes: ``cast(x, y, angle)`` here) and its lidar fan."""
    _program, backend, run = labsim_scene(LAB)
    backend.act(0, 3.0, 2.0)
    poses = []
    for _ in range(ticks):
        backend.sense()
        backend.step()
        poses.append(backend.pose(0))
    rays = backend._sim.sense.__globals__["rays0"]  # the caster the generated sense() calls
    return poses, lambda x, y, a: rays(x, y, math.cos(a), math.sin(a)), rays.lidar


def casts(poses: list[tuple[float, float, float]], cast: object) -> float:
    """CPU seconds of one cast per pose."""
    start = time.process_time()
    for x, y, a in poses:
        cast(x, y, a)  # type: ignore[operator]
    return time.process_time() - start


def backend_alone(ticks: int) -> float:
    """CPU seconds of the backend's sense() and step() for ``ticks`` ticks, the robot driving a slow arc."""
    _program, backend, run = labsim_scene(LAB)
    backend.act(0, 3.0, 2.0)
    start = time.process_time()
    for _ in range(ticks):
        backend.sense()
        backend.step()
    elapsed = time.process_time() - start
    run.close()
    return elapsed


def whole_run(ticks: int, lab: Path = LAB) -> float:
    """CPU seconds of labsim running the behaviour for ``ticks`` ticks."""
    _program, _backend, run = labsim_scene(lab)
    start = time.process_time()
    for _ in range(ticks):
        run.tick()
    elapsed = time.process_time() - start
    run.close()
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--ticks", type=int, default=2000)
    args = parser.parse_args()
    print(machine())
    poses, cast, fan = poses_and_fan(args.ticks)
    times = alternate({
        "fan cast": lambda: casts(poses, cast),
        "chipmunk casts": lambda: casts(poses, fan.cast_through_chipmunk),  # type: ignore[attr-defined]
        "backend sense + step": lambda: backend_alone(args.ticks),
        "labsim run": lambda: whole_run(args.ticks),
        "labsim run, no lidar (floor)": lambda: whole_run(args.ticks, FLOOR),
    }, args.repeat)
    for name, seconds in times.items():
        rates = [args.ticks / s for s in seconds]
        median = statistics.median(rates)
        wall = statistics.median(args.ticks / s for s in times.wall[name])  # the whole call, set-up included
        print(f"  {name}: median {median:,.0f} ticks per CPU second over {args.repeat} x {args.ticks} ticks "
              f"(runs: {', '.join(f'{r:,.0f}' for r in rates)}); {wall:,.0f} ticks per wall second, set-up included"
              + ("" if "casts" in name or "floor" in name
                 else f"; goal >= {GOAL:,}: {'met' if median >= GOAL else 'NOT met'}"))
    ratios = pair_ratios(times["chipmunk casts"], times["fan cast"])
    print(f"  chipmunk casts / fan cast, per round: median {statistics.median(ratios):.1f} "
          f"({', '.join(f'{r:.1f}' for r in ratios)})")
    print(f"  {machine()}")


if __name__ == "__main__":
    main()
