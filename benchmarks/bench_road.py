"""Interpreter overhead on the road-following lab: labsim against a hand-written loop.

Five robots, 600 ticks (30 s), a 128 x 128 camera each. Both sides drive the same pymunk scene
(built by the pymunk backend from ``road_loop``) and render with the same scene renderer; the
hand loop then does by hand what ``behaviours/road_follow.yaml`` says: gray, threshold at 20
(not inverted), the row of the centroid from the image moments, the PID, the wheel speeds, and the lab's five
metrics. Both must end with the same poses, bit for bit, which shows they did the same work.

    python benchmarks/bench_road.py [--repeat 7]
    python benchmarks/bench_road.py --threads [--repeat 7]

Prints the median CPU time of each side, alternated in random order, and the median of the
per-round ratios (goal: labsim <= 1.05 x hand), with the load average.

``--threads`` instead runs the lab as whole ``labsim run`` processes with the native libraries
on one thread each (labsim's default) and on their own defaults (``LABSIM_THREADS=0``: OpenCV
and OpenBLAS a thread per core), alternated, and prints the median CPU time (the process's,
children included) and wall time of each, and that their traces are byte-identical.
"""
from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import pymunk
from compare import compare, labsim_scene, labsim_side
from pymunk._chipmunk_cffi import ffi, lib  # chipmunk itself, as labsim's backend calls it

from labsim.backends.pymunk.camera import ground_view
from labsim.backends.pymunk.scene_view import scene_view
from labsim.backends.scene.ground import RoadTracker

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "road_follow.yaml"


def labsim_run() -> tuple[float, list[tuple[float, float, float]]]:
    return labsim_side(LAB, 5)


def hand_run() -> tuple[float, list[tuple[float, float, float]]]:
    # Long and flat on purpose: the hand-written baseline labsim is measured against.
    # The scene: built exactly as labsim builds it.
    p, backend, run = labsim_scene(LAB)
    space: pymunk.Space = backend.space
    bodies: list[pymunk.Body] = list(backend.bodies)
    model = p.models["pioneer"]
    camera = model.cameras[0]
    world = p.world

    # --- from here on, a hand-written controller on raw pymunk, OpenCV and the renderer ---
    dt, speed, kp, ki, kd, scale = 0.05, 5.0, 0.05, 0.01, 0.0, 0.5
    radius, axle, limit = model.wheel_radius_m, model.axle_length_m, model.max_wheel_speed_rad_s
    # the camera sees the ground and the other robots on it, as labsim's does
    render = scene_view(ground_view(world.ground), world, [(b, model) for b in bodies]).render
    road = world.ground.roads[0]
    tracker = RoadTracker(road)
    half_width = road.width_m / 2
    n = len(bodies)
    for i, b in enumerate(bodies):
        tracker.start(i, b.position.x, b.position.y)
    drive = [[0.0, 0.0] for _ in range(n)]  # forward speed m/s, turn rate rad/s
    # The wheel drive as a C velocity callback through chipmunk, as the pymunk backend does.
    get_angle, set_v, set_w = lib.cpBodyGetAngle, lib.cpBodySetVelocity, lib.cpBodySetAngularVelocity
    position, velocity = lib.cpBodyGetPosition, lib.cpBodyGetVelocity
    cos, sin = math.cos, math.sin

    def wheel_drive(i: int):  # type: ignore[no-untyped-def]
        @ffi.callback("cpBodyVelocityFunc")
        def velocity(b: object, gravity: object, damping: float, step: float) -> None:
            a = get_angle(b)
            set_v(b, (drive[i][0] * cos(a), drive[i][0] * sin(a)))
            set_w(b, drive[i][1])
        return velocity

    callbacks = [wheel_drive(i) for i in range(n)]  # kept alive as long as the bodies step
    for b, callback in zip(bodies, callbacks):
        lib.cpBodySetVelocityUpdateFunc(b._body, callback)
    touching = [0] * n

    def begin(arbiter: pymunk.Arbiter, s: pymunk.Space, data: object) -> None:
        for shape in arbiter.shapes:
            if shape.collision_type > 0:
                touching[shape.collision_type - 1] += 1

    def separate(arbiter: pymunk.Arbiter, s: pymunk.Space, data: object) -> None:
        for shape in arbiter.shapes:
            if shape.collision_type > 0:
                touching[shape.collision_type - 1] -= 1

    space.on_collision(None, None, begin=begin, separate=separate)

    integral = [0.0] * n
    previous = [0.0] * n
    sent = [(math.nan, math.nan)] * n
    laps = [0] * n
    sum_sq, count_sq, worst = [0.0] * n, [0] * n, [-math.inf] * n
    off_ticks, speed_sum, speed_count = [0] * n, [0.0] * n, [0] * n
    start = time.process_time()
    tick = 0
    while tick * dt < 30:
        sensed = []
        for i, b in enumerate(bodies):  # every robot senses before any acts
            p = position(b._body)
            x, y = p.x, p.y
            a = get_angle(b._body)
            image = render(x, y, a, camera, i)
            v = velocity(b._body)
            sensed.append((image, v.x * cos(a) + v.y * sin(a), tracker.offset(x, y)))
        for i, b in enumerate(bodies):
            image, forward, offset = sensed[i]
            gray = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
            lane = cv2.threshold(gray, 20, 255, cv2.THRESH_BINARY)[1]
            m = cv2.moments(lane)  # 0/255: the centroid is that of the set pixels
            cy = m["m01"] / m["m00"] if m["m00"] else 63.5
            error = 64 - cy
            integral[i] += error
            angle = scale * (kp * error + ki * integral[i] + kd * (error - previous[i]))
            previous[i] = error
            left, right = speed - angle / 180 * speed, speed + angle / 180 * speed
            if (left, right) != sent[i]:
                sent[i] = (left, right)
                wl, wr = max(-limit, min(limit, left)), max(-limit, min(limit, right))
                drive[i] = [radius / 2 * (wl + wr), radius / axle * (wr - wl)]
                if touching[i] == 0:
                    a = get_angle(b._body)
                    set_v(b._body, (drive[i][0] * cos(a), drive[i][0] * sin(a)))
                    set_w(b._body, drive[i][1])
            sum_sq[i] += offset * offset
            count_sq[i] += 1
            worst[i] = max(worst[i], abs(offset))
            off_ticks[i] += abs(offset) > half_width
            speed_sum[i] += forward
            speed_count[i] += 1
        lib.cpSpaceStep(space._space, dt)
        for i, b in enumerate(bodies):
            laps[i] = tracker.update(i, b.position.x, b.position.y)
        tick += 1
    elapsed = time.process_time() - start
    poses = [(b.position.x, b.position.y, math.remainder(b.angle, 2 * math.pi)) for b in bodies]
    run.close()
    return elapsed, poses


ONE, DEFAULT = "1 thread each", "libraries' default"


def threads(repeat: int) -> None:
    """One thread per library against the libraries' defaults, as whole processes."""
    import os
    import statistics
    import subprocess
    import sys
    import tempfile

    from compare import alternate, children_cpu, machine, report

    walls: dict[str, list[float]] = {ONE: [], DEFAULT: []}
    traces: dict[str, bytes] = {}

    def side(name: str, value: str) -> Callable[[], float]:
        def once() -> float:
            env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
            env["LABSIM_THREADS"] = value
            with tempfile.TemporaryDirectory() as d:
                trace = Path(d) / "t.csv"
                before, start = children_cpu(), time.perf_counter()
                subprocess.run([sys.executable, "-m", "labsim", "run", str(LAB), "-q", "--trace", str(trace)],
                               env=env, check=True)
                walls[name].append(time.perf_counter() - start)
                cpu = children_cpu() - before
                traces[name] = trace.read_bytes()
            return cpu
        return once

    print(machine())
    times = alternate({ONE: side(ONE, ""), DEFAULT: side(DEFAULT, "0")}, repeat)
    report("road lab, whole `labsim run` processes (5 robots x 600 ticks); CPU of the process", times,
           ratio=(DEFAULT, ONE), goal="CPU, default threads over one each")
    for name, values in walls.items():
        print(f"  {name}: median {statistics.median(values):.3f} s wall")
    same = traces[ONE] == traces[DEFAULT]
    print(f"  traces byte-identical: {same}")
    print(f"  {machine()[2:]}")


def main() -> None:
    if "--threads" in sys.argv:
        sys.argv.remove("--threads")
        repeat = int(sys.argv[sys.argv.index("--repeat") + 1]) if "--repeat" in sys.argv else 7
        threads(repeat)
        return
    compare(__doc__.splitlines()[0], "road lab, 5 robots x 600 ticks with cameras", labsim_run, hand_run, repeat=7)


if __name__ == "__main__":
    main()
