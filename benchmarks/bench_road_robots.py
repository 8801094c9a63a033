"""How the road lab scales with its fleet: CPU and wall time per robot-tick at 1, 5, 20 and 100 robots.

    python benchmarks/bench_road_robots.py [--repeat 5] [--seconds 5] [--robots 1 5 20 100]

Runs behaviours/road_follow.yaml's behaviour with N camera robots spread evenly along the road's
centreline (each heading along it, so that every robot follows the road as in the lab), N from
``--robots``, alternated in random order, and times the run phase. Prints the median CPU and wall
microseconds per robot-tick of each, and the median of the per-round ratios of the largest fleet
to five robots (goal: <= 1.15: a robot costs the same however many drive), with the load average.
The runs are in this process: there are no children, and the CPU time is the process's.

``--split-drawing`` adds, for five robots and the largest fleet, a side where each camera still
finds the robots in its view (the cull and the frustum tests are paid) but draws none of them:
the ratio of those two sides is the tick core's own growth with the fleet, apart from the
drawing of robots that are really in view (none at five robots, about four a camera at 100).
"""
from __future__ import annotations

import argparse
import itertools
import math
import statistics
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import alternate, machine, pair_ratios, run_phase

from labsim.backends.pymunk import scene_view
from labsim.runtime.run import compile_behaviour

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "road_follow.yaml"
ROBOTS = "  pioneer:\n    model: pioneer_p3dx\n    count: 5\n    at: spawn\n"
CAMERA = "    camera: {resolution: [128, 128], fov_deg: 40, height_m: 3, pitch_deg: 30, roll_deg: -90}\n"


def poses(n: int) -> list[tuple[float, float, float]]:
    """n poses evenly spaced along the lab's road, on its centreline, heading along it (degrees)."""
    road = compile_behaviour(LAB).program.world.ground.roads[0]
    points = [tuple(p) for p in road.points] + ([tuple(road.points[0])] if road.closed else [])
    segments = [(a, b, math.dist(a, b)) for a, b in itertools.pairwise(points) if math.dist(a, b) > 1e-9]
    total = sum(length for _, _, length in segments)
    out: list[tuple[float, float, float]] = []
    s, k = 0.0, 0
    for (ax, ay), (bx, by), length in segments:
        while k < n and k * total / n < s + length:
            t = (k * total / n - s) / length
            out.append((ax + t * (bx - ax), ay + t * (by - ay), math.degrees(math.atan2(by - ay, bx - ax))))
            k += 1
        s += length
    return out


def fleet(n: int, folder: Path) -> Path:
    """The lab with n robots, each its own group of one (a group's robots cannot share a pose)."""
    text = LAB.read_text()
    assert ROBOTS + CAMERA in text
    groups = "".join(f"  r{i}:\n    model: pioneer_p3dx\n    at: [{x!r}, {y!r}, {h!r}]\n{CAMERA}"
                     for i, (x, y, h) in enumerate(poses(n)))
    path = folder / f"road_{n}.yaml"
    path.write_text(text.replace(ROBOTS + CAMERA, groups))
    return path


def not_drawing(seen: Callable[..., list[object]]) -> Callable[..., list[object]]:
    """``SceneView._robots_seen`` that finds the robots in view as it does, then draws none."""
    def tested_not_drawn(*args: object, **kwargs: object) -> list[object]:
        seen(*args, **kwargs)
        return []
    return tested_not_drawn


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=5)
    parser.add_argument("--robots", type=int, nargs="+", default=[1, 5, 20, 100])
    parser.add_argument("--split-drawing", action="store_true",
                        help="also time 5 robots and the largest fleet with the robots in view not drawn")
    args = parser.parse_args()
    print(machine())
    cpu: dict[str, list[float]] = {}
    wall: dict[str, list[float]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        seen = scene_view.SceneView._robots_seen

        def side(n: int, drawn: bool = True) -> Callable[[], float]:
            path = fleet(n, Path(tmp))
            walls = wall.setdefault(f"{n} robots" + ("" if drawn else ", not drawn"), [])

            def once() -> float:
                scene_view.SceneView._robots_seen = seen if drawn else not_drawing(seen)  # type: ignore[method-assign]
                try:
                    elapsed, ticks = run_phase(path, {"seconds": str(args.seconds)}, walls=walls)
                finally:
                    scene_view.SceneView._robots_seen = seen  # type: ignore[method-assign]
                walls[-1] /= ticks * n
                return elapsed / (ticks * n)
            return once

        sides = {f"{n} robots": side(n) for n in args.robots}
        if args.split_drawing:
            sides |= {f"{n} robots, not drawn": side(n, drawn=False) for n in sorted({5, max(args.robots)})}
        cpu = alternate(sides, args.repeat)
    print(f"road lab, {args.seconds:g} s simulated, per robot-tick, medians of {args.repeat} rounds in random order:")
    for name in cpu:
        print(f"  {name:>20}  {statistics.median(cpu[name]) * 1e6:8.1f} µs CPU"
              f"  {statistics.median(wall[name]) * 1e6:8.1f} µs wall"
              f"   (CPU {', '.join(f'{v * 1e6:.1f}' for v in cpu[name])})")
    for tail in ("", ", not drawn"):
        top, five = f"{max(args.robots)} robots{tail}", f"5 robots{tail}"
        if top in cpu and five in cpu and top != five:
            for label, times in (("CPU", cpu), ("wall", wall)):
                ratio = statistics.median(pair_ratios(times[top], times[five]))
                print(f"  {top} / {five}, {label} per robot-tick: median of per-round ratios {ratio:.3f}"
                      "   (goal <= 1.15)")
    print(f"  {machine()[2:]}")


if __name__ == "__main__":
    main()
