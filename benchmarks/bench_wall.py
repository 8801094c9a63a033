"""Interpreter overhead on the wall-following lab: labsim against a hand-written pymunk loop.

Both sides drive the same pymunk scene (built by the pymunk backend from ``walls_lab4``)
for the lab's 30,000 ticks: the same six sonar cones per tick (5 rays each), the same random numbers, the
same rules, wheel clamping and metrics. The hand loop is what a competent student would
write in plain Python against pymunk; labsim runs ``behaviours/wall_follow.yaml``. They must
end at the same pose (bit for bit), which shows they did the same work.

    python benchmarks/bench_wall.py [--repeat 5]

Prints the median CPU time of each side, alternated in random order, and the median of the
per-round ratios (goal: labsim <= 1.05 x hand), with the load average.
"""
from __future__ import annotations

import math
import random
import time
from pathlib import Path

import pymunk
from compare import compare, labsim_scene, labsim_side
from pymunk._chipmunk_cffi import ffi, lib  # chipmunk itself, as labsim's backend calls it

from labsim.backends.pymunk.fleet import sonar_spec
from labsim.backends.pymunk.fleet_sense import enclosing_circle, ray_groups

LAB = Path(__file__).resolve().parent.parent / "behaviours" / "wall_follow.yaml"


def labsim_run() -> tuple[float, list[tuple[float, float, float]]]:
    return labsim_side(LAB, 1)


def hand_run() -> tuple[float, list[tuple[float, float, float]]]:
    # Long and flat on purpose: this is the loop a student would write by hand, the baseline
    # labsim's interpreter is measured against, so it is not factored into helpers.
    # The scene: built exactly as labsim builds it (same start pose from the same seed).
    p, backend, run = labsim_scene(LAB)
    space: pymunk.Space = backend.space
    body: pymunk.Body = backend.bodies[0]
    model = p.models["pioneer"]

    # --- from here on, a hand-written controller on raw pymunk ---
    dt = 0.05
    front, side, hold, cruise = 0.5, 0.3, 0.45, 4.0
    radius, axle, limit = model.wheel_radius_m, model.axle_length_m, model.max_wheel_speed_rad_s
    rng = random.Random(f"{p.seed}/pioneer")
    sonars = {s.name: s for s in model.sonars}
    # Each sonar a cone: a fan of rays, the nearest hit met within its incidence limit counts
    # (fleet.sonar_spec gives the rays' ends and the limit as the backend casts them).
    specs = tuple(sonar_spec(sonars[n]) for n in ("sonar2", "sonar5", "sonar8", "sonar9", "sonar14", "sonar15"))
    # The sonars in the backend's groups (8 9 5 right and ahead, 2 15 left, 14 alone), each group
    # under one test of the circle that holds its cones, each cone under one of its own: when no
    # shape comes into a circle, none of its rays can hit, and they read inf without being cast.
    groups = []
    for members in ray_groups(specs):
        cx, cy, circle = enclosing_circle([specs[i] for i in members])
        cones = []
        for i in members:
            sp = specs[i]
            assert sp.incidence_cos is not None
            kx, ky, kr = enclosing_circle([sp])
            lim = -sp.incidence_cos * sp.range_m  # normal . ray at most this: met within the limit
            cones.append((i, sp.mount_x_m, sp.mount_y_m, kx, ky, kr, sp.fan, sp.range_m, lim))
        groups.append((cx, cy, circle, cones))
    # Rays and velocities straight through chipmunk, as the pymunk backend does: one reused
    # result struct for the ray casts and one for the groups' tests, and the wheel drive as a
    # C velocity callback.
    ray_filter = ffi.new("cpShapeFilter *", (1, pymunk.ShapeFilter.ALL_CATEGORIES(), pymunk.ShapeFilter.ALL_MASKS()))[0]
    drive = [0.0, 0.0]  # forward speed m/s, turn rate rad/s
    cp_body, cp_space = body._body, space._space
    get_angle, set_v, set_w = lib.cpBodyGetAngle, lib.cpBodySetVelocity, lib.cpBodySetAngularVelocity
    cos, sin = math.cos, math.sin

    @ffi.callback("cpBodyVelocityFunc")
    def velocity(b: object, gravity: object, damping: float, step: float) -> None:
        a = get_angle(b)
        set_v(b, (drive[0] * cos(a), drive[0] * sin(a)))
        set_w(b, drive[1])

    lib.cpBodySetVelocityUpdateFunc(cp_body, velocity)
    touching = [0]
    contacts = [0]

    def begin(arbiter: pymunk.Arbiter, s: pymunk.Space, data: object) -> None:
        if touching[0] == 0:
            contacts[0] += 1
        touching[0] += 1

    def separate(arbiter: pymunk.Arbiter, s: pymunk.Space, data: object) -> None:
        touching[0] -= 1

    space.on_collision(None, None, begin=begin, separate=separate)
    query, info = lib.cpSpaceSegmentQueryFirst, ffi.new("cpSegmentQueryInfo *")
    crowded, nearest = lib.cpSpacePointQueryNearest, ffi.new("cpPointQueryInfo *")
    position, step = lib.cpBodyGetPosition, lib.cpSpaceStep
    inf = math.inf

    start = time.process_time()
    following = False
    left_cmd = right_cmd = 0.0
    sent = (math.nan, math.nan)
    near_misses, was_near, overshoot_ticks, following_ticks, closest = 0, False, 0, 0, inf
    contact_time = 0.0
    tick = 0
    while tick * dt < 25 * 60:
        p = position(cp_body)
        x, y = p.x, p.y
        a = get_angle(cp_body)
        c, s = cos(a), sin(a)
        d = [inf] * 6
        for cx, cy, circle, cones in groups:
            if crowded(cp_space, (x + c * cx - s * cy, y + s * cx + c * cy), circle, ray_filter, nearest):
                for i, mx, my, kx, ky, kr, fan, reach, lim in cones:
                    if not crowded(cp_space, (x + c * kx - s * ky, y + s * kx + c * ky), kr, ray_filter, nearest):
                        continue
                    ox, oy = x + c * mx - s * my, y + s * mx + c * my
                    v = inf
                    for ex, ey in fan:
                        wx, wy = c * ex - s * ey, s * ex + c * ey
                        if query(cp_space, (ox, oy), (ox + wx, oy + wy), 0.0, ray_filter, info) \
                                and info.alpha * reach < v and info.normal.x * wx + info.normal.y * wy <= lim:
                            v = info.alpha * reach
                    d[i] = v
        s2, s5, s8, s9, s14, s15 = d
        r = rng.randint(0, 100)
        ahead, right, left = min(s5, s2), min(s8, s9), min(s14, s15)
        steer = 4 * (s9 - s8) + 3 * (hold - right) if s8 < inf and s9 < inf else 0

        was_following = following
        if not following:
            if ahead <= front or right <= front:
                following = True
            else:
                left_cmd, right_cmd = r - 1, r + 1
        elif ahead <= front:
            left_cmd, right_cmd = -2, 2
        elif right <= side:
            left_cmd, right_cmd = cruise - 2, cruise
        elif left <= side:
            left_cmd, right_cmd = cruise, cruise - 1
        elif s8 < inf and s9 < inf:
            left_cmd, right_cmd = cruise - steer, cruise + steer
        elif s8 < inf or s9 < inf:
            left_cmd = right_cmd = cruise
        else:
            left_cmd, right_cmd = cruise, cruise / 3

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

        step(cp_space, dt)
        if touching[0]:
            contact_time += dt
        tick += 1
    elapsed = time.process_time() - start
    x, y = body.position
    pose = (x, y, math.remainder(body.angle, 2 * math.pi))
    run.close()
    return elapsed, [pose]


def main() -> None:
    compare(__doc__.splitlines()[0], "wall lab, 30000 ticks", labsim_run, hand_run, repeat=5)


if __name__ == "__main__":
    main()
