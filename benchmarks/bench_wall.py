"""Interpreter overhead on the wall-following lab: labsim against two hand-written pymunk loops.

All sides drive the same pymunk scene (built by the pymunk backend from ``walls_lab4``)
for the lab's 30,000 ticks: the same six sonar cones per tick (5 rays across each 30-degree
cone, the nearest hit met within 45 degrees of the surface's normal), the same random
numbers, the same rules, wheel clamping and metrics. labsim runs ``behaviours/wall_follow.yaml``;
the two loops do by hand what it says:

- "labsim's internals, by hand": the loop written the way labsim's backend works inside, with
  chipmunk's C functions through pymunk's raw cffi layer, the six cones cast in one call a tick
  by the backend's ray caster (``labsim.backends.pymunk.ray_cast.RaySet``: the C kernel where
  the install built it), and the wheel drive as a C velocity callback. It measures what
  labsim's interpreter costs over the same machinery (goal: labsim <= 1.05 x it).
- "plain pymunk loop": what a student writes on pymunk's public API: ``body.position`` and
  ``body.angle``, every ray of every cone a ``space.segment_query_first`` (the hit's
  ``normal`` for the incidence limit), the wheel speeds set as ``body.velocity`` and
  ``body.angular_velocity`` before each ``space.step``, and while the robot touches a wall
  through ``body.velocity_func`` inside the step (as labsim drives it). This is the user's
  anchor: what labsim costs against doing the lab by hand.

The final poses must agree to 1e-12 m (the internals loop bit for bit; the plain loop computes
the rays' ends in another order of operations), which shows all did the same lab.

    python benchmarks/bench_wall.py [--repeat 5] [--minutes 25]

Where the C kernel was built, a fourth side is labsim with the Python rays (what an install
without a C compiler casts with; goal: at most 2.5 x labsim's time with the kernel).

Prints the median CPU time of each side (the runs are in this process, no children) and its
wall time, alternated in random order, the medians of the per-round ratios of labsim to each
loop (and of the Python rays to the kernel), and the load average.
"""
from __future__ import annotations

import argparse
import math
import random
import statistics
import time
from pathlib import Path

import pymunk
from compare import alternate_poses, labsim_scene, labsim_side, machine, report, same_poses
from pymunk._chipmunk_cffi import ffi, lib  # chipmunk itself, as labsim's backend calls it

from labsim.backends.pymunk import ray_cast
from labsim.backends.pymunk.fleet import sonar_spec
from labsim.backends.pymunk.ray_cast import RaySet

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml"


WALLS: dict[str, list[float]] = {}  # each side's wall times, in order
MINUTES = [25.0]  # the lab's simulated minutes (its own 25 unless --minutes says less)
LABSIM, INTERNALS, PLAIN = "labsim", "labsim's internals, by hand", "plain pymunk loop"
PYTHON_RAYS = "labsim, Python rays"  # labsim without the C kernel's rays (an install without a compiler)


def labsim_run() -> tuple[float, list[tuple[float, float, float]]]:
    return labsim_side(LAB, 1, WALLS.setdefault(LABSIM, []), {"minutes": repr(MINUTES[0])})


def python_rays_run() -> tuple[float, list[tuple[float, float, float]]]:
    kernel = ray_cast._kernel
    ray_cast._kernel = None  # the sonars' RaySet is made when the run binds, inside labsim_side
    try:
        return labsim_side(LAB, 1, WALLS.setdefault(PYTHON_RAYS, []), {"minutes": repr(MINUTES[0])})
    finally:
        ray_cast._kernel = kernel


def hand_run() -> tuple[float, list[tuple[float, float, float]]]:
    # Long and flat on purpose: labsim's backend written out by hand, the baseline labsim's
    # interpreter is measured against, so it is not factored into helpers.
    # The scene: built exactly as labsim builds it (same start pose from the same seed).
    p, backend, run = labsim_scene(LAB, {"minutes": repr(MINUTES[0])})
    space: pymunk.Space = backend.space
    body: pymunk.Body = backend.bodies[0]
    model = p.models["pioneer"]

    # --- from here on, a hand-written controller on raw pymunk ---
    dt = 0.05
    front, side, cruise = 0.5, 0.3, 2.0
    radius, axle, limit = model.wheel_radius_m, model.axle_length_m, model.max_wheel_speed_rad_s
    rng = random.Random(f"{p.seed}/pioneer")
    sonars = {s.name: s for s in model.sonars}
    # Each sonar a cone: a fan of rays, the nearest hit met within its incidence limit counts
    # (fleet.sonar_spec gives the rays' ends and the limit as the backend casts them).
    specs = tuple(sonar_spec(sonars[n]) for n in ("sonar2", "sonar5", "sonar8", "sonar9", "sonar14", "sonar15"))
    # The six cones in one call a tick, as the backend casts them (ray_cast.RaySet: the C kernel
    # where it was built), each group of cones under one test of its circle, each cone under one
    # of its own: when no shape comes into a circle, none of its rays can hit.
    cast = RaySet(space, pymunk.ShapeFilter(group=1), specs).cast
    # Velocities straight through chipmunk, as the pymunk backend does: the wheel drive set
    # after each step while the body is free, through a C velocity callback while it touches.
    drive = [0.0, 0.0]  # forward speed m/s, turn rate rad/s
    cp_body, cp_space = body._body, space._space
    get_angle, set_v, set_w = lib.cpBodyGetAngle, lib.cpBodySetVelocity, lib.cpBodySetAngularVelocity
    cos, sin = math.cos, math.sin

    @ffi.callback("cpBodyVelocityFunc")
    def velocity(b: object, gravity: object, damping: float, step: float) -> None:
        a = get_angle(b)
        set_v(b, (drive[0] * cos(a), drive[0] * sin(a)))
        set_w(b, drive[1])

    own = ffi.addressof(lib, "cpBodyUpdateVelocity")  # chipmunk's own velocity update
    touching = [0]
    contacts = [0]

    def begin(arbiter: pymunk.Arbiter, s: pymunk.Space, data: object) -> None:
        if touching[0] == 0:
            contacts[0] += 1
            lib.cpBodySetVelocityUpdateFunc(cp_body, velocity)  # driven inside the step while touching
        touching[0] += 1

    def separate(arbiter: pymunk.Arbiter, s: pymunk.Space, data: object) -> None:
        touching[0] -= 1

    space.on_collision(None, None, begin=begin, separate=separate)
    position, step = lib.cpBodyGetPosition, lib.cpSpaceStep
    inf = math.inf

    wall, start = time.perf_counter(), time.process_time()
    following = False
    left_cmd = right_cmd = 0.0
    sent = (math.nan, math.nan)
    near_misses, was_near, overshoot_ticks, following_ticks, closest = 0, False, 0, 0, inf
    turn_squares, turn_ticks, prev_h = 0.0, 0, None
    contact_time = 0.0
    released = 0  # contacts after which the body went back to chipmunk's own update
    tick = 0
    while tick * dt < MINUTES[0] * 60:
        p = position(cp_body)
        x, y = p.x, p.y
        a = get_angle(cp_body)
        c, s = cos(a), sin(a)
        d = cast(x, y, c, s)
        s2, s5, s8, s9, s14, s15 = d
        r = rng.randint(-2, 2)
        ahead, right, left = min(s5, s2), min(s8, s9), min(s15, s14)
        h = math.remainder(a, 2 * math.pi)
        turned = h - (h if prev_h is None else prev_h)
        turn = math.degrees(math.atan2(sin(turned), cos(turned))) / dt
        prev_h = h

        was_following = following
        if not following:
            if ahead <= front or s8 <= front or s15 <= front or min(s9, s14) <= front:
                following = True
            else:
                left_cmd, right_cmd = min(cruise, cruise - r), min(cruise, cruise + r)
        elif ahead <= front:
            left_cmd, right_cmd = -2, 2
        elif s8 <= side:
            left_cmd, right_cmd = cruise - 1, cruise
        elif s15 <= side:
            left_cmd, right_cmd = cruise, cruise - 1
        elif s8 <= front and s9 <= front and s8 < s9:
            left_cmd, right_cmd = cruise - 0.5, cruise
        elif s8 <= front and s9 <= front:
            left_cmd, right_cmd = cruise, cruise - 0.5
        elif s8 <= front:
            left_cmd = right_cmd = cruise
        elif s9 <= front:
            left_cmd, right_cmd = cruise, cruise / 4
        else:
            left_cmd, right_cmd = cruise, cruise / 2

        if (left_cmd, right_cmd) != sent:
            sent = (left_cmd, right_cmd)
            wl = max(-limit, min(limit, left_cmd))
            wr = max(-limit, min(limit, right_cmd))
            drive[0] = radius / 2 * (wl + wr)
            drive[1] = radius / axle * (wr - wl)
            if touching[0] == 0:
                set_v(cp_body, (drive[0] * c, drive[0] * s))
                set_w(cp_body, drive[1])

        near = min(ahead, right, left) < 0.25
        if near and not was_near:
            near_misses += 1
        was_near = near
        if was_following and s8 == inf and s9 == inf:
            overshoot_ticks += 1
        if was_following and (s8 < inf or s9 < inf):
            following_ticks += 1
        closest = min(closest, ahead, right, left)
        turn_squares += turn * turn  # smoothness: rms(turn)
        turn_ticks += 1

        step(cp_space, dt)
        if touching[0]:
            contact_time += dt
        else:  # free: the wheel speeds along the new heading, set after the step
            if contacts[0] != released:
                released = contacts[0]
                lib.cpBodySetVelocityUpdateFunc(cp_body, own)
            a = get_angle(cp_body)
            set_v(cp_body, (drive[0] * cos(a), drive[0] * sin(a)))
            set_w(cp_body, drive[1])
        tick += 1
    elapsed = time.process_time() - start
    WALLS.setdefault(INTERNALS, []).append(time.perf_counter() - wall)
    x, y = body.position
    pose = (x, y, math.remainder(body.angle, 2 * math.pi))
    run.close()
    return elapsed, [pose]


def plain_run() -> tuple[float, list[tuple[float, float, float]]]:
    # Long and flat on purpose, as a student writes it: pymunk's public API only.
    p, backend, run = labsim_scene(LAB, {"minutes": repr(MINUTES[0])})  # the same scene, start pose and seed
    space: pymunk.Space = backend.space
    body: pymunk.Body = backend.bodies[0]
    model = p.models["pioneer"]
    # (labsim's contact handler is replaced by this loop's own below, which does the same: a
    # body touching a wall is driven through its velocity_func, inside the step)

    dt = 0.05
    front, side, cruise = 0.5, 0.3, 2.0
    radius, axle, limit = model.wheel_radius_m, model.axle_length_m, model.max_wheel_speed_rad_s
    rng = random.Random(f"{p.seed}/pioneer")
    sonars = {s.name: s for s in model.sonars}
    # Each sonar a cone of rays from edge to edge; it reads the nearest hit that a ray meets
    # within the incidence limit of the surface's normal (an echo seen too obliquely is lost).
    cones = [(sonars[n].x_m, sonars[n].y_m, sonars[n].ray_angles_rad(), sonars[n].range_m,
              math.cos(math.radians(sonars[n].incidence_limit_deg)))
             for n in ("sonar2", "sonar5", "sonar8", "sonar9", "sonar14", "sonar15")]
    ray_filter = pymunk.ShapeFilter(group=1)  # the robot's own shape is in group 1
    v = w = 0.0  # the wheels' forward speed m/s and turn rate rad/s
    touching, driven = [0], [False]

    def wheels(b: pymunk.Body, gravity: object, damping: float, step: float) -> None:
        # against a wall, the wheels drive inside the step, and the wall takes what it blocks
        b.velocity = (v * math.cos(b.angle), v * math.sin(b.angle))
        b.angular_velocity = w

    def begin(arbiter: pymunk.Arbiter, s: pymunk.Space, data: object) -> None:
        if touching[0] == 0:
            body.velocity_func = wheels
            driven[0] = True
        touching[0] += 1

    def separate(arbiter: pymunk.Arbiter, s: pymunk.Space, data: object) -> None:
        touching[0] -= 1

    space.on_collision(None, None, begin=begin, separate=separate)

    wall, start = time.perf_counter(), time.process_time()
    following = False
    left_cmd = right_cmd = 0.0
    near_misses, was_near, overshoot_ticks, following_ticks, closest = 0, False, 0, 0, math.inf
    turn_squares, turn_ticks, prev_h = 0.0, 0, None
    contact_time = 0.0
    tick = 0
    while tick * dt < MINUTES[0] * 60:
        x, y = body.position
        a = body.angle
        d = []
        for mx, my, angles, reach, square in cones:
            ox = x + math.cos(a) * mx - math.sin(a) * my
            oy = y + math.sin(a) * mx + math.cos(a) * my
            nearest = math.inf
            for angle in angles:
                ux, uy = math.cos(a + angle), math.sin(a + angle)
                hit = space.segment_query_first((ox, oy), (ox + ux * reach, oy + uy * reach), 0.0, ray_filter)
                # met within the limit: the ray against the normal by at least cos(limit)
                if hit and hit.alpha * reach < nearest and hit.normal.x * ux + hit.normal.y * uy <= -square:
                    nearest = hit.alpha * reach
            d.append(nearest)
        s2, s5, s8, s9, s14, s15 = d
        r = rng.randint(-2, 2)
        ahead, right, left = min(s5, s2), min(s8, s9), min(s15, s14)
        h = math.remainder(a, 2 * math.pi)
        turned = h - (h if prev_h is None else prev_h)
        turn = math.degrees(math.atan2(math.sin(turned), math.cos(turned))) / dt
        prev_h = h

        was_following = following
        if not following:
            if ahead <= front or s8 <= front or s15 <= front or min(s9, s14) <= front:
                following = True
            else:
                left_cmd, right_cmd = min(cruise, cruise - r), min(cruise, cruise + r)
        elif ahead <= front:
            left_cmd, right_cmd = -2, 2
        elif s8 <= side:
            left_cmd, right_cmd = cruise - 1, cruise
        elif s15 <= side:
            left_cmd, right_cmd = cruise, cruise - 1
        elif s8 <= front and s9 <= front and s8 < s9:
            left_cmd, right_cmd = cruise - 0.5, cruise
        elif s8 <= front and s9 <= front:
            left_cmd, right_cmd = cruise, cruise - 0.5
        elif s8 <= front:
            left_cmd = right_cmd = cruise
        elif s9 <= front:
            left_cmd, right_cmd = cruise, cruise / 4
        else:
            left_cmd, right_cmd = cruise, cruise / 2

        wl = max(-limit, min(limit, left_cmd))
        wr = max(-limit, min(limit, right_cmd))
        v, w = radius / 2 * (wl + wr), radius / axle * (wr - wl)
        if touching[0] == 0:  # free: set now (touching, ``wheels`` sets them in the step)
            body.velocity = (v * math.cos(a), v * math.sin(a))
            body.angular_velocity = w

        near = min(ahead, right, left) < 0.25
        if near and not was_near:
            near_misses += 1
        was_near = near
        if was_following and s8 == math.inf and s9 == math.inf:
            overshoot_ticks += 1
        if was_following and (s8 < math.inf or s9 < math.inf):
            following_ticks += 1
        closest = min(closest, ahead, right, left)
        turn_squares += turn * turn  # smoothness: rms(turn)
        turn_ticks += 1

        space.step(dt)
        if touching[0]:
            contact_time += dt
        elif driven[0]:  # free again: back to pymunk's own velocity update
            body.velocity_func = pymunk.Body.update_velocity
            driven[0] = False
        tick += 1
    elapsed = time.process_time() - start
    WALLS.setdefault(PLAIN, []).append(time.perf_counter() - wall)
    x, y = body.position
    pose = (x, y, math.remainder(body.angle, 2 * math.pi))
    run.close()
    return elapsed, [pose]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--minutes", type=float, default=25.0,
                        help="simulated minutes (a shorter try; the lab's 25 by default)")
    args = parser.parse_args()
    MINUTES[0] = args.minutes
    print(machine())
    sides = {INTERNALS: hand_run, PLAIN: plain_run, LABSIM: labsim_run}
    if ray_cast.KERNEL == "c":
        sides[PYTHON_RAYS] = python_rays_run
    times, poses = alternate_poses(sides, args.repeat)
    report(f"wall lab, {round(args.minutes * 1200)} ticks", times, (LABSIM, INTERNALS), "<= 1.05")
    ratio = statistics.median(times[LABSIM][i] / times[PLAIN][i] for i in range(args.repeat))
    print(f"  {LABSIM} / {PLAIN}: median of per-round ratios {ratio:.3f}   (below 1: labsim is faster)")
    if PYTHON_RAYS in times:
        ratio = statistics.median(times[PYTHON_RAYS][i] / times[LABSIM][i] for i in range(args.repeat))
        print(f"  {PYTHON_RAYS} / {LABSIM} (the C kernel): median of per-round ratios {ratio:.3f}   (goal <= 2.5)")
    else:
        print("  (the C kernel was not built: every labsim side casts with the Python rays)")
    for name, values in WALLS.items():
        print(f"  {name}: median {statistics.median(values):.4f} s wall")
    for name in [n for n in (INTERNALS, PLAIN, PYTHON_RAYS) if n in poses]:
        gap = max(abs(a - b) for p, q in zip(poses[LABSIM], poses[name]) for a, b in zip(p, q))
        print(f"  {name}: final pose {'agrees' if same_poses(poses[LABSIM], poses[name]) else 'DIFFERS'} "
              f"with labsim's (largest difference {gap:.1e})")
    print(f"  {machine()[2:]}")


if __name__ == "__main__":
    main()
