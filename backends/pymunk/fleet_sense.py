"""The rover fleet's ``sense()``, generated as straight-line Python for its robots and channels.

``labsim.backends.pymunk.fleet.FleetSimulator`` describes, once at open, what each robot reads
(``SensePlan``: its body, its rays' shape filter, one spec per channel in the requested order)
and ``compile_sense`` turns that into one function. It runs every tick, so its cost beyond the
ray casts and camera frames themselves must stay near zero, so it reads bodies and casts rays
through chipmunk's C functions directly (``labsim.backends.pymunk.chipmunk``).

A robot's sonars and IR sensors (``SonarRay``: a lone ray, or a sonar's cone of rays) and its
lidar's beams are cast together, one call a tick, by its ``labsim.backends.pymunk.ray_cast.RaySet``
(the C kernel where the install built it; the beams through the lidar's ``lidar_fan.LidarFan``).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import cast

import pymunk

from labsim.backends.pymunk import chipmunk
from labsim.backends.pymunk.ray_cast import RaySet, SonarRay
from labsim.backends.scene.ground import RoadTracker
from labsim.backends.scene.models import Camera
from labsim.backends.scene.world import wrap

SenseFn = Callable[[], list[list[object]]]


@dataclass(frozen=True)
class LidarBeam:
    """One beam of a lidar mounted ``x_m`` ahead of the robot's origin, at ``angle_rad`` in the
    robot frame; a robot's beams are cast together, as one fan (``lidar_fan.LidarFan``), in the
    call that casts its other rays."""

    x_m: float
    range_m: float
    angle_rad: float


@dataclass(frozen=True)
class CameraRead:
    """A camera channel: the image ``render`` gives for the robot's pose."""

    camera: Camera


@dataclass(frozen=True)
class BumperRead:
    """A bumper: whether any shape but the robot's own comes within ``reach_m`` of its point."""

    x_m: float
    y_m: float
    reach_m: float


@dataclass(frozen=True)
class GroundRead:
    """A ground sensor: the floor's reflectance under its point (``reflectance(x, y)``)."""

    x_m: float
    y_m: float


# A channel's spec: a ray (sonar or IR sensor), a lidar beam, a camera, a bumper, a ground sensor,
# or the name of a channel read from the body or the backend's lists (x, y, heading, collided,
# forward_speed, road_offset, on_road, laps).
Spec = SonarRay | LidarBeam | CameraRead | BumperRead | GroundRead | str


@dataclass(frozen=True)
class SensePlan:
    """One robot: its body, the filter that keeps its rays off its own shape, its channels."""

    body: pymunk.Body
    ray_filter: pymunk.ShapeFilter
    specs: tuple[Spec, ...]


_SONAR = "sonar"  # the kind of a SonarRay spec in the set of kinds below
_CAMERA = "camera"  # the kind of a CameraRead spec (a camera's own name could be anything)
_LIDAR = "lidar"  # the kind of a LidarBeam spec
_POINT = "point"  # the kind of a BumperRead or GroundRead spec: a point on the robot, in the world


def _kind(spec: Spec) -> str:
    if isinstance(spec, SonarRay):
        return _SONAR
    if isinstance(spec, CameraRead):
        return _CAMERA
    if isinstance(spec, (BumperRead, GroundRead)):
        return _POINT
    if isinstance(spec, LidarBeam):
        return _LIDAR
    return spec


def compile_sense(
    space: pymunk.Space,
    robots: list[SensePlan],
    touching: list[int],
    render: Callable[..., object] | None = None,
    tracker: RoadTracker | None = None,
    laps: list[int] | None = None,
    reflectance: Callable[[float, float], float] | None = None,
    poses: Callable[[], object] | None = None,
) -> SenseFn:
    """Generate ``sense()`` as straight-line code for these robots and channels.

    Unrolled code skips the per-channel loop and dispatch. For one robot asking for sonar1,
    sonar2 and collided it reads::

        def sense():
            p = position(body0)
            x0 = p.x
            y0 = p.y
            a0 = angle(body0)
            c = cos(a0)
            s = sin(a0)
            sv0 = rays0(x0, y0, c, s)
            return [[sv0[0], sv0[1], touching[0] > 0]]

    ``body0`` is the robot's ``cpBody *``, ``rays0`` its rays' caster (``RaySet.cast``: every
    sonar and IR ray of the robot in one call, in the order of the specs), ``near`` chipmunk's
    ``cpSpacePointQueryNearest`` (the nearest shape less than the radius away, or NULL) and
    ``filter0`` the robot's shape filter as a C struct: the same calls pymunk's wrappers make,
    without their allocations (measured in ``labsim.backends.pymunk.chipmunk``). repr() of a
    float reads back as the same float, so the literals change no reading. Cameras call
    ``render(x, y, angle, camera, robot)`` (the robot's index, not seen by its camera;
    ``_scene_lines``); road channels call ``tracker.offset`` once per robot; ``laps`` reads the
    list the fleet's ``step()`` keeps. Nothing is computed for a channel no robot reads. A bumper
    is one ``near`` test of the disc around its point, a ground sensor one call of
    ``reflectance(x, y)`` at its point.
    """
    env = _names(space, touching, render, tracker, laps)
    env["reflectance"] = reflectance
    half_width = tracker.half_width_m if tracker is not None else 0.0
    lines = ["def sense():", *_scene_lines(robots, poses, env)]
    rows = []
    for r, plan in enumerate(robots):
        _add_robot_names(space, r, plan, env)
        values = _robot_lines(r, plan.specs, env, lines, half_width)
        # a robot that reads only its rays, in the caster's order: the caster's new list is the row;
        # its rays then a few values more (a live view's pose, a trace's): the list, extended
        alone = _rays_alone(r, plan.specs)
        more = values[len(alone):]
        if values == alone:
            rows.append(f"sv{r}")
        elif alone != [""] and values[:len(alone)] == alone and not any(v.startswith("*") for v in more):
            lines.append(f"    sv{r} += ({', '.join(more)},)")
            rows.append(f"sv{r}")
        else:
            rows.append(f"[{', '.join(values)}]")
    lines.append(f"    return [{', '.join(rows)}]")
    exec(compile("\n".join(lines), "<labsim pymunk sense>", "exec"), env)
    return cast(SenseFn, env["sense"])


def _rays_alone(r: int, specs: tuple[Spec, ...]) -> list[str]:
    """The expressions of robot r's values when it reads its sonars and IR sensors, then its
    lidar's beams, and nothing else, each in the caster's order (``_robot_lines``'s)."""
    sonars = sum(isinstance(spec, SonarRay) for spec in specs)
    beams = ([f"*sv{r}[{sonars}:]" if sonars else f"*sv{r}"]
             if any(isinstance(spec, LidarBeam) for spec in specs) else [])
    return [f"sv{r}[{k}]" for k in range(sonars)] + beams if sonars or beams else [""]


def _scene_lines(robots: list[SensePlan], poses: Callable[[], object] | None, env: dict[str, object]) -> list[str]:
    """With cameras and ``poses``: every robot's pose read once, at the top, for all the tick's
    cameras (``render(..., scene)``): reading each body per camera cost O(robots^2) C calls.
    Bodies do not move while ``sense()`` runs."""
    env["poses"] = poses
    if poses is None or not any(isinstance(spec, CameraRead) for plan in robots for spec in plan.specs):
        env["poses"] = None
        return []
    return ["    scene = poses()"]


def _names(space: pymunk.Space, touching: list[int], render: Callable[..., object] | None,
           tracker: RoadTracker | None, laps: list[int] | None) -> dict[str, object]:
    """The names the generated ``sense()`` calls and reads; each robot's body and filter join them."""
    return {
        "space": chipmunk.c_space(space), "near": chipmunk.point_query_nearest, "nearest": chipmunk.point_info(),
        "position": chipmunk.body_position, "angle": chipmunk.body_angle,
        "velocity": chipmunk.body_velocity, "cos": math.cos, "sin": math.sin, "inf": math.inf, "wrap": wrap,
        "touching": touching, "abs": abs, "render": render, "laps": laps,
        "offset": tracker.offset if tracker is not None else None,
    }


def _robot_lines(r: int, specs: tuple[Spec, ...], env: dict[str, object], lines: list[str],
                 half_width: float) -> list[str]:
    """Append robot r's lines to ``lines``; return the expressions of its values, in order."""
    kinds = {_kind(spec) for spec in specs}
    if kinds & {_SONAR, "x", "y", _CAMERA, "road_offset", "on_road", _POINT, _LIDAR}:
        lines += [f"    p = position(body{r})", f"    x{r} = p.x", f"    y{r} = p.y"]
    if kinds & {_SONAR, "heading", _CAMERA, "forward_speed", _POINT, _LIDAR}:
        lines.append(f"    a{r} = angle(body{r})")
    if kinds & {_SONAR, _POINT, _LIDAR}:
        lines += [f"    c = cos(a{r})", f"    s = sin(a{r})"]
    if kinds & {"road_offset", "on_road"}:
        lines.append(f"    ro{r} = offset(x{r}, y{r})")  # once, for both channels
    if kinds & {_SONAR, _LIDAR}:  # every ray of the robot, its lidar's beams last, in one call (ray_cast.RaySet)
        lines.append(f"    sv{r} = rays{r}(x{r}, y{r}, c, s)")
    sonars = [k for k, spec in enumerate(specs) if isinstance(spec, SonarRay)]
    beams = [k for k, spec in enumerate(specs) if isinstance(spec, LidarBeam)]
    values = []
    for k, spec in enumerate(specs):
        if isinstance(spec, CameraRead):
            env[f"cam{r}_{k}"] = spec.camera
            scene = ", scene" if env["poses"] is not None else ""
            lines.append(f"    v{r}_{k} = render(x{r}, y{r}, a{r}, cam{r}_{k}, {r}{scene})")
            values.append(f"v{r}_{k}")
        elif isinstance(spec, SonarRay):  # cast above, in the order of the specs
            values.append(f"sv{r}[{sonars.index(k)}]")
        elif isinstance(spec, LidarBeam):  # cast above, after the sonars, in the order of the specs
            if beams == list(range(beams[0], beams[0] + len(beams))):  # one run: spliced at its first
                if k == beams[0]:
                    values.append(f"*sv{r}[{len(sonars)}:]" if sonars else f"*sv{r}")
            else:
                values.append(f"sv{r}[{len(sonars) + beams.index(k)}]")
        elif isinstance(spec, (BumperRead, GroundRead)):
            lines += [f"    px = x{r} + c * {spec.x_m!r} - s * {spec.y_m!r}",
                      f"    py = y{r} + s * {spec.x_m!r} + c * {spec.y_m!r}"]
            lines.append(f"    v{r}_{k} = bool(near(space, (px, py), {spec.reach_m!r}, filter{r}, nearest))"
                         if isinstance(spec, BumperRead) else f"    v{r}_{k} = reflectance(px, py)")
            values.append(f"v{r}_{k}")
        elif spec == "forward_speed":
            lines += [
                f"    vv = velocity(body{r})",
                f"    v{r}_{k} = vv.x * cos(a{r}) + vv.y * sin(a{r})",
            ]
            values.append(f"v{r}_{k}")
        else:
            values.append({
                "x": f"x{r}", "y": f"y{r}", "heading": f"wrap(a{r})",
                "collided": f"touching[{r}] > 0",
                "road_offset": f"ro{r}", "on_road": f"abs(ro{r}) <= {half_width!r}",
                "laps": f"laps[{r}]",
            }[spec])
    return values


def _add_robot_names(space: pymunk.Space, r: int, plan: SensePlan, env: dict[str, object]) -> None:
    """Robot r's body and ray filter as ``body{r}`` and ``filter{r}``, and the caster of its
    sonars', IR sensors' and lidar's rays as ``rays{r}`` (the sonars and IR sensors, then the
    beams, each in the order of the specs) if it reads any."""
    env[f"body{r}"] = chipmunk.c_body(plan.body)
    env[f"filter{r}"] = chipmunk.shape_filter(plan.ray_filter)
    rays = [spec for spec in plan.specs if isinstance(spec, SonarRay)]
    beams = [spec for spec in plan.specs if isinstance(spec, LidarBeam)]
    lidar = None
    if beams:
        from labsim.backends.pymunk.lidar_fan import LidarFan  # numpy: only for a lidar
        lidar = LidarFan(space, plan.body, plan.ray_filter, [b.angle_rad for b in beams], beams[0].x_m,
                         beams[0].range_m)
    if rays or lidar is not None:
        env[f"rays{r}"] = RaySet(space, plan.ray_filter, rays, lidar=lidar).cast


def cone_hit(space: pymunk.Space, plan: SensePlan, ray: SonarRay) -> tuple[float, int] | None:
    """What one sonar of ``plan``'s robot detects now: its distance and the index of the ray
    that found it (in ``ray.ends()``), or None. The same chipmunk calls, in the same order and
    with the same arithmetic, as the robot's ``RaySet`` makes (in C or in Python), so the
    distance is its reading bit for bit: ``labsim serve`` asks it where in the cone the detected
    point lies.
    """
    cp_space, body, info = chipmunk.c_space(space), chipmunk.c_body(plan.body), chipmunk.query_info()
    f = chipmunk.shape_filter(plan.ray_filter)
    p = chipmunk.body_position(body)
    a = chipmunk.body_angle(body)
    c, s = math.cos(a), math.sin(a)
    mx, my, rng = ray.mount_x_m, ray.mount_y_m, ray.range_m
    ox = p.x + c * mx - s * my
    oy = p.y + s * mx + c * my
    if not ray.fan:
        ex, ey = ray.end_dx_m, ray.end_dy_m
        hit = chipmunk.segment_query_first(cp_space, (ox, oy), (ox + c * ex - s * ey, oy + s * ex + c * ey),
                                           0.0, f, info)
        return (info.alpha * rng, 0) if hit else None
    best: tuple[float, int] | None = None
    for i, (ex, ey) in enumerate(ray.fan):
        wx = c * ex - s * ey
        wy = s * ex + c * ey
        if chipmunk.segment_query_first(cp_space, (ox, oy), (ox + wx, oy + wy), 0.0, f, info) \
                and info.alpha * rng < (math.inf if best is None else best[0]) \
                and (ray.incidence_cos is None
                     or info.normal.x * wx + info.normal.y * wy <= -ray.incidence_cos * rng):
            best = (info.alpha * rng, i)
    return best
