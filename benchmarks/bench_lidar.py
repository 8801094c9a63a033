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


def backend_alone(ticks: int) -> float:
    """Ticks per CPU second of the backend's sense() and step(), the robot driving a slow arc."""
    _program, backend, run = labsim_scene(LAB)
    backend.act(0, 3.0, 2.0)
    start = time.process_time()
    for _ in range(ticks):
        backend.sense()
        backend.step()
    elapsed = time.process_time() - start
    run.close()
    return ticks / elapsed


def whole_run(ticks: int) -> float:
    """Ticks per CPU second of labsim running the behaviour for ``ticks`` ticks."""
    _program, _backend, run = labsim_scene(LAB)
    start = time.process_time()
    for _ in range(ticks):
        run.tick()
    elapsed = time.process_time() - start
    run.close()
    return ticks / elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--ticks", type=int, default=2000)
    args = parser.parse_args()
    print(machine())
    for name, fn in (("backend sense + step", backend_alone), ("labsim run", whole_run)):
        rates = [fn(args.ticks) for _ in range(args.repeat)]
        median = statistics.median(rates)
        print(f"  {name}: median {median:,.0f} ticks per CPU second over {args.repeat} x {args.ticks} ticks "
              f"(goal >= {GOAL:,}: {'met' if median >= GOAL else 'NOT met'})")


if __name__ == "__main__":
    main()
