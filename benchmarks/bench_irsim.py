"""labsim against IR-SIM: steps per CPU second, one robot with 16 range beams in the same room.

IR-SIM (https://github.com/hanruihua/ir-sim) is a Python 2D robot simulator for navigation
and learning; install it with the optional extra (``pip install -e '.[bench]'``). Both sides:

- the wall lab's room, ``walls_lab4`` (its walls as line strings, its box as a polygon);
- one differential-drive robot starting at (-4, -4) heading 45 degrees, 0.05 s steps;
- 16 range readings of 1 m each step (labsim: the Pioneer's 16 sonars, each a cone of 30
  degrees cast as 5 rays since docs/decisions.md §24, 80 rays; IR-SIM: a 16-beam 2D
  lidar all round, 16 rays), all of which the controller reads; "labsim, 16 single rays" gives
  each sonar one ray along its axis, the same count of rays as IR-SIM;
- the same wander/avoid controller: turn left on the spot while anything is within 0.5 m in
  front (the beams within 30 degrees of the heading), else drive on a slight curve; and the
  nearest reading over all beams kept as a metric;
- headless (IR-SIM: ``display=False``, no rendering); only the stepping is timed (sensing,
  deciding, stepping), not building the world.

    python benchmarks/bench_irsim.py [--repeat 5] [--irsim-steps 2000] [--labsim-steps 30000]

Prints steps per CPU second of each side, alternated in random order, and the median of the
per-round ratios labsim / IR-SIM (goal: >= 26x), with the load average; also labsim with every
ray cast ("labsim, all rays"): labsim normally casts a group of rays only when some shape comes
into a circle holding them all (``labsim.backends.pymunk.ray_cast.ray_groups``, exact: the
same readings), and that skip is part of its lead, so the ratio is given with and without it.
Each side also reports its wall time per step; the runs are in this process (no children).
Without IR-SIM installed it says so and exits with 0.
"""
from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import math
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from compare import alternate, machine, pair_ratios, report

from labsim.backends import load_backend
from labsim.runtime.run import compile_behaviour

DT = 0.05
START = (-4.0, -4.0, 45.0)
RADIUS, AXLE = 0.0975, 0.331  # the Pioneer's wheels, for IR-SIM's (v, w) commands
AVOID, CRUISE = (-3.0, 3.0), (6.0, 5.0)  # wheel speeds, rad/s: turning on the spot, cruising

BEHAVIOUR = f"""\
labsim: 1
name: IR-SIM comparison
world: walls_lab4
dt: {DT}
seed: 1
stop: time >= seconds
robots:
  pioneer: {{model: pioneer_p3dx, at: [{START[0]}, {START[1]}, {START[2]}]}}
params:
  seconds: 100
let:
  front: min(sonar3, sonar4, sonar5, sonar6)   # 30, 10, -10 and -30 degrees
rules:
  go:
    - if front < 0.5 then arc({AVOID[0]}, {AVOID[1]})
    - else arc({CRUISE[0]}, {CRUISE[1]})
metrics:
  nearest: minimum(min({", ".join(f"sonar{i}" for i in range(1, 17))}))
"""


def labsim_steps(path: Path, steps: int, every_ray: bool = False, single_rays: bool = False) -> tuple[float, int]:
    """``every_ray``: no group of rays skipped; ``single_rays``: each sonar one ray along its axis,
    as IR-SIM's beams, instead of the 5-ray cone of 30 degrees the Pioneer's sonars are."""
    from labsim.backends.pymunk import ray_cast
    from labsim.backends.scene import models

    grouped = ray_cast.ray_groups
    pioneer = models.MODELS["pioneer_p3dx"]
    if every_ray:  # a group of one is cast without the circle's test
        ray_cast.ray_groups = lambda specs: [[k] for g in grouped(specs) for k in g]  # type: ignore[assignment]
    if single_rays:
        models.MODELS["pioneer_p3dx"] = dataclasses.replace(pioneer, sonars=tuple(
            dataclasses.replace(s, cone_deg=0.0, incidence_limit_deg=90.0) for s in pioneer.sonars))
    try:
        run = compile_behaviour(path, {"seconds": str(steps * DT)}).bind(load_backend("pymunk"), warn=lambda m: None)
    finally:
        ray_cast.ray_groups = grouped  # type: ignore[assignment]
        models.MODELS["pioneer_p3dx"] = pioneer
    start = time.process_time()
    summary = run.run()
    elapsed = time.process_time() - start
    run.close()
    return elapsed, summary.ticks


def irsim_world(lab: Path, folder: Path) -> Path:
    """The lab's world (walls_lab4) as an IR-SIM world file, with the robot and its lidar."""
    world = compile_behaviour(lab).program.world
    lines = ["world:", "  height: 15", "  width: 15", f"  step_time: {DT}", f"  sample_time: {DT}",
             "  offset: [-7.5, -7.5]", "  collision_mode: stop", "",
             "robot:", "  - kinematics: {name: diff}", "    shape: {name: circle, radius: 0.22}",
             f"    state: [{START[0]}, {START[1]}, {math.radians(START[2])}]",
             "    vel_max: [1.5, 8.0]", "    vel_min: [-1.5, -8.0]", "    acce: [1000, 1000]",
             "    sensors:", "      - {name: lidar2d, range_min: 0, range_max: 1.0, angle_range: 6.283185307179586,"
             " number: 16}", "", "obstacle:"]
    for wall in world.walls:
        (ax, ay), (bx, by) = wall.a, wall.b
        lines += [f"  - shape: {{name: linestring, vertices: [[{ax}, {ay}], [{bx}, {by}]]}}", "    state: [0, 0, 0]"]
    for block in world.blocks:
        vertices = ", ".join(f"[{x}, {y}]" for x, y in block.corners)
        lines += [f"  - shape: {{name: polygon, vertices: [{vertices}]}}", "    state: [0, 0, 0]"]
    path = folder / "walls_lab4_irsim.yaml"
    path.write_text("\n".join(lines) + "\n")
    return path


def irsim_steps(irsim: object, world: Path, steps: int) -> tuple[float, int]:
    import numpy as np

    with contextlib.redirect_stdout(io.StringIO()):
        env = irsim.make(str(world), display=False, log_level="ERROR")  # type: ignore[attr-defined]
    beams = None
    cruise = np.array([[RADIUS / 2 * sum(CRUISE)], [RADIUS / AXLE * (CRUISE[1] - CRUISE[0])]])
    avoid = np.array([[RADIUS / 2 * sum(AVOID)], [RADIUS / AXLE * (AVOID[1] - AVOID[0])]])
    nearest = math.inf
    start = time.process_time()
    for _ in range(steps):
        scan = env.get_lidar_scan()
        ranges = scan["ranges"]
        if beams is None:  # the beams within 30 degrees of the heading
            angles = np.linspace(scan["angle_min"], scan["angle_max"], len(ranges))
            beams = np.flatnonzero(np.abs(np.remainder(angles + math.pi, 2 * math.pi) - math.pi) <= math.radians(30))
        front = float(ranges[beams].min())
        nearest = min(nearest, float(ranges.min()))
        env.step(avoid if front < 0.5 else cruise)
    elapsed = time.process_time() - start
    env.end(0) if hasattr(env, "end") else None
    return elapsed, steps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--irsim-steps", type=int, default=2000)
    parser.add_argument("--labsim-steps", type=int, default=30000)
    args = parser.parse_args()
    os.environ.setdefault("MPLBACKEND", "Agg")  # headless: IR-SIM imports matplotlib
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            import irsim
    except ImportError:
        print("IR-SIM is not installed: skipped (pip install -e '.[bench]' installs it)")
        return
    with tempfile.TemporaryDirectory() as d:
        lab = Path(d) / "irsim_compare.yaml"
        lab.write_text(BEHAVIOUR)
        world = irsim_world(lab, Path(d))
        rates: dict[str, list[float]] = {"labsim": [], "labsim, all rays": [], "labsim, 16 single rays": [],
                                         "IR-SIM": []}
        walls: dict[str, list[float]] = {name: [] for name in rates}

        def side(name: str, once: object, *more: object) -> object:
            def timed() -> float:
                wall = time.perf_counter()
                elapsed, steps = once(*more)  # type: ignore[operator]
                walls[name].append((time.perf_counter() - wall) / steps)  # set-up included
                rates[name].append(steps / elapsed)
                return elapsed / steps
            return timed

        print(machine())
        version = getattr(irsim, "__version__", "?")
        times = alternate({"labsim": side("labsim", labsim_steps, lab, args.labsim_steps),  # type: ignore[dict-item]
                           "labsim, all rays": side("labsim, all rays", labsim_steps, lab, args.labsim_steps,
                                                    True),
                           "labsim, 16 single rays": side("labsim, 16 single rays", labsim_steps, lab,  # type: ignore[dict-item]
                                                          args.labsim_steps, False, True),
                           "IR-SIM": side("IR-SIM", irsim_steps, irsim, world, args.irsim_steps)},
                          args.repeat)
    per_step = {name: [t * 1e6 for t in values] for name, values in times.items()}
    report(f"one robot, 16 beams, walls_lab4, IR-SIM {version} headless; CPU time per step", per_step,
           unit="us")
    for name, values in walls.items():
        print(f"  {name}: median {statistics.median(values) * 1e6:.1f} us wall per step (building the world included)")
    print("  steps per CPU second: " + ", ".join(f"{name} {statistics.median(v):,.0f}" for name, v in rates.items()))
    for name, goal in (("labsim", "   (goal >= 26x; 16 sonars of 5 rays against 16 beams)"),
                       ("labsim, all rays", "   (every ray cast, no group skipped)"),
                       ("labsim, 16 single rays", "   (equal rays: one a sonar, as IR-SIM's 16 beams)")):
        ratio = statistics.median(pair_ratios(rates[name], rates["IR-SIM"]))
        print(f"  {name} / IR-SIM steps per second: median of per-round ratios {ratio:.1f}x{goal}")
    print(f"  {machine()[2:]}")


if __name__ == "__main__":
    main()
