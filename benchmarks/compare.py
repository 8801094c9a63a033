"""What bench_wall.py and bench_road.py share: run labsim and a hand-written loop in turns,
report their medians and ratio, and check that both ended with the same poses."""
from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable
from pathlib import Path

from labsim.backends import load_backend
from labsim.runtime.run import compile_behaviour

Pose = tuple[float, float, float]
Side = Callable[[], tuple[float, list[Pose]]]  # one run: (wall seconds, final poses)


def labsim_side(lab: Path, robots: int) -> tuple[float, list[Pose]]:
    """One labsim run of a behaviour file on the pymunk backend: its wall time and final poses."""
    behaviour = compile_behaviour(lab)
    backend = load_backend("pymunk")
    run = behaviour.bind(backend, warn=lambda m: None)
    start = time.perf_counter()
    run.run()
    elapsed = time.perf_counter() - start
    poses = [backend.pose(i) for i in range(robots)]
    run.close()
    return elapsed, poses


def labsim_scene(lab: Path):
    """The scene a hand-written loop drives: bound exactly as labsim binds it (same seed, same
    start poses). Returns the compiled program, the pymunk backend and the bound run."""
    behaviour = compile_behaviour(lab)
    backend = load_backend("pymunk")
    return behaviour.program, backend, behaviour.bind(backend, warn=lambda m: None)


def compare(description: str, title: str, labsim_run: Side, hand_run: Side, repeat: int = 7) -> float:
    """Parse --repeat, time both sides interleaved, print the figures; return the ratio."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--repeat", type=int, default=repeat)
    args = parser.parse_args()
    labsim_times, hand_times = [], []
    for _ in range(args.repeat):  # interleaved, so both sides see the same machine load
        t, labsim_poses = labsim_run()
        labsim_times.append(t)
        t, hand_poses = hand_run()
        hand_times.append(t)
    same = len(labsim_poses) == len(hand_poses) and all(
        math.isclose(a, b, rel_tol=0, abs_tol=1e-12) for p, q in zip(labsim_poses, hand_poses) for a, b in zip(p, q))
    lab, hand = statistics.median(labsim_times), statistics.median(hand_times)
    print(f"{title}, median of {args.repeat}:")
    print(f"  hand-written loop    {hand:.3f} s   ({', '.join(f'{t:.3f}' for t in hand_times)})")
    print(f"  labsim               {lab:.3f} s   ({', '.join(f'{t:.3f}' for t in labsim_times)})")
    print(f"  ratio labsim / hand  {lab / hand:.3f}   (goal <= 1.05)")
    print(f"  same final poses: {'yes' if same else 'NO'}")
    if not same:
        for p, q in zip(labsim_poses, hand_poses):
            print(f"    labsim {p}  hand {q}")
    return lab / hand
