"""A robot's whole ray set cast in one call a tick: the pymunk backend's one ray caster.

``labsim.backends.pymunk.fleet_sense`` gives each robot that reads rays (``SonarRay``: a lone
ray, or a sonar's cone of rays with its incidence limit; a lidar's beams) one ``RaySet``, and
the generated ``sense()`` calls its ``cast`` once a tick with the body's pose. Every sonar
and IR ray is chipmunk's own segment query (``cpSpaceSegmentQueryFirst``), so the readings
are chipmunk's bit for bit and every body chipmunk holds is seen where it is now: walls,
blocks, other robots. A lidar's beams, hundreds of them, are cast in the same call against
the faces and circles ``labsim.backends.pymunk.lidar_fan`` keeps of the scene (chipmunk's
reading to 1e-12 m; docs/decisions.md §25, §39): the kernel dispatches inside C.

The rays go under two conservative tests, as ``fleet_sense.ray_groups`` arranges them: the
rays whose directions lie within a quarter turn of each other share a circle that holds them
all, and one point query asks whether any shape comes into it (mostly none does, and the group
reads ``inf`` without a cast); a cone's rays go under one more test, of the cone's own circle.

Where the install built the C kernel (``backends/pymunk/_fan.c``, ``rays``) one call of it does
a robot's whole set, calling chipmunk from C; elsewhere each ray is the same call with the same
arithmetic, made from Python through pymunk's cffi layer (``labsim.backends.pymunk.chipmunk``),
and reads the same bit for bit, and the lidar's beams go through its numpy fan (``KERNEL`` says
which: "c" or "python"; ``tests/contract/test_ray_cast.py`` compares them). The Python rays
skip the test of a circle whose rays hit something the tick before: each call from Python
costs half a microsecond or so.
"""
from __future__ import annotations

import math
from array import array
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any, Protocol, cast

import pymunk

from labsim.backends.pymunk import chipmunk
from labsim.backends.pymunk.chipmunk import ffi, lib

Rays = Callable[[float, float, float, float], list[float]]  # cast(x, y, cos, sin) -> each ray's reading
_Member = tuple[int, float, float, float, "tuple[float, float, float] | None", "float | None",
                tuple[tuple[float, float], ...]]


def _bind() -> Callable[..., list[float]] | None:
    """The kernel's ``rays`` once it holds chipmunk's two queries, or None: not built, or built
    for structs of another size than this pymunk's."""
    try:
        from labsim.backends.pymunk import _fan
    except ImportError:  # no C compiler at install time: the Python rays
        return None
    try:
        segment, point = (int(ffi.cast("uintptr_t", ffi.addressof(lib, name)))
                          for name in ("cpSpaceSegmentQueryFirst", "cpSpacePointQueryNearest"))
        _fan.bind(segment, point, ffi.sizeof("cpShapeFilter"), ffi.sizeof("cpBitmask"),
                  ffi.offsetof("cpShapeFilter", "mask"), ffi.sizeof("cpSegmentQueryInfo"),
                  ffi.offsetof("cpSegmentQueryInfo", "normal"), ffi.offsetof("cpSegmentQueryInfo", "alpha"),
                  ffi.sizeof("cpPointQueryInfo"))
    except (AttributeError, TypeError, ValueError, ffi.error):  # an older kernel, another chipmunk or cffi
        return None
    return _fan.rays


@dataclass(frozen=True)
class SonarRay:
    """A sonar in the robot frame: its mount, and its axis's end's offset from the mount.

    The end is the whole range along the sonar's axis, so a hit's alpha times the range is
    the distance. A cone (``labsim.backends.scene.models.Sonar.cone_deg``) has its rays' ends
    in ``fan``, from its right edge to its left, and reads the nearest hit among them; with
    ``incidence_cos`` a hit counts only where the ray meets the surface within that angle of
    its normal (normal . ray <= -incidence_cos * range). A lone ray has neither.
    """

    mount_x_m: float
    mount_y_m: float
    end_dx_m: float
    end_dy_m: float
    range_m: float
    fan: tuple[tuple[float, float], ...] = ()
    incidence_cos: float | None = None

    def ends(self) -> tuple[tuple[float, float], ...]:
        """Every ray's end, as offsets from the mount: the fan's, or the axis's alone."""
        return self.fan or ((self.end_dx_m, self.end_dy_m),)


# Rays whose directions lie within this angle of a group's first ray join its group.
GROUP_SPREAD_RAD = math.pi / 2
# ... up to this many rays. Four neighbouring sonars of the Pioneer's ring fit a circle of
# 0.86 m as single rays, 0.99 m as cones; a larger group's circle is seldom empty (measured
# in docs/decisions.md §18, for single rays).
GROUP_SIZE = 4
# Added to a group's circle, in metres: far beyond the rounding of the poses and ray ends
# (about 1e-15 of the coordinates), so a shape the circle misses cannot touch a ray.
CIRCLE_MARGIN_M = 1e-6


def ray_groups(specs: Sequence[object]) -> list[list[int]]:
    """The indices of the sonar specs, in groups that share one test of their circle.

    The rays are taken in the order of their directions (from -180 to 180 degrees in the robot
    frame); a ray joins the group before it while that group has fewer than ``GROUP_SIZE``
    rays and the ray's direction is within ``GROUP_SPREAD_RAD`` of the group's first ray's,
    and starts a new group otherwise. The Pioneer's ring of 16 sonars makes four groups of
    four, one per quarter of the ring.
    """
    rays = sorted((k for k, spec in enumerate(specs) if isinstance(spec, SonarRay)),
                  key=lambda k: _direction(cast(SonarRay, specs[k])))
    groups: list[list[int]] = []
    for k in rays:
        direction = _direction(cast(SonarRay, specs[k]))
        first = _direction(cast(SonarRay, specs[groups[-1][0]])) if groups else math.nan
        if groups and len(groups[-1]) < GROUP_SIZE and direction - first <= GROUP_SPREAD_RAD:
            groups[-1].append(k)
        else:
            groups.append([k])
    return groups


def enclosing_circle(rays: list[SonarRay]) -> tuple[float, float, float]:
    """A circle in the robot frame that holds every point of these rays (every ray of a
    cone): centre x, y and radius.

    Its centre is the middle of the box around the rays' ends; a ray is a segment, so a circle
    that holds both of its ends holds all of it. The radius includes ``CIRCLE_MARGIN_M``.
    """
    ends = [(ray.mount_x_m, ray.mount_y_m) for ray in rays]
    ends += [(ray.mount_x_m + dx, ray.mount_y_m + dy) for ray in rays for dx, dy in ray.ends()]
    xs, ys = [x for x, _ in ends], [y for _, y in ends]
    cx, cy = (min(xs) + max(xs)) / 2.0, (min(ys) + max(ys)) / 2.0
    return cx, cy, max(math.hypot(x - cx, y - cy) for x, y in ends) + CIRCLE_MARGIN_M


def _direction(ray: SonarRay) -> float:
    return math.atan2(ray.end_dy_m, ray.end_dx_m)


# where a segment query's alpha and normal lie in its result, counted in doubles
ALPHA = ffi.offsetof("cpSegmentQueryInfo", "alpha") // ffi.sizeof("double")
NORMAL = ffi.offsetof("cpSegmentQueryInfo", "normal") // ffi.sizeof("double")

_kernel = _bind()
KERNEL = "c" if _kernel is not None else "python"


class Lidar(Protocol):
    """A lidar's fan (``lidar_fan.LidarFan``, which imports this module and numpy): its beams
    cast in the robot's one call a tick."""

    def joined(self, count: int, kernel: Callable[..., list[float]] | None, head: tuple[object, ...],
               python: Rays) -> Rays: ...


class RaySet:
    """One robot's rays: ``cast(x, y, c, s)`` gives each of them its reading for the body at
    (x, y) heading a, c = cos(a) and s = sin(a): metres, or ``inf`` where nothing is within range.

    ``rays`` are the robot's sonars and IR sensors (``fleet_sense.SonarRay``) in the order
    ``cast`` returns them; ``ray_filter`` keeps the rays off the robot's own shape. With its
    ``lidar`` (``lidar_fan.LidarFan``) every beam's range follows them, in the lidar's order,
    cast in the same call of the kernel. ``compiled=False`` takes the Python rays (and the
    numpy fan) even where the kernel was built (the tests compare the two).
    """

    def __init__(self, space: pymunk.Space, ray_filter: pymunk.ShapeFilter, rays: Sequence[SonarRay],
                 *, lidar: Lidar | None = None, compiled: bool = True) -> None:
        groups = ray_groups(rays)
        table: list[float] = [float(len(rays)), float(len(groups))]
        # the Python rays' plan: per group its circle (None: no test) and its members, each its
        # value's slot, mount x, y, range, cone's circle (None: a lone ray), incidence threshold
        # (None: no limit) and rays' ends
        plan: list[tuple[tuple[float, float, float] | None, list[_Member]]] = []
        for group in groups:
            members = [rays[k] for k in group]
            circle = enclosing_circle(members) if len(group) > 1 else None
            table += [*(circle or (0.0, 0.0, -1.0)), float(len(group))]
            plan_members = []
            for k, ray in zip(group, members):
                cone = enclosing_circle([ray]) if ray.fan else (0.0, 0.0, -1.0)
                # the limit as a hit must meet it: normal . ray <= -cos(limit) * range
                limited = bool(ray.fan) and ray.incidence_cos is not None
                threshold = -ray.incidence_cos * ray.range_m if ray.incidence_cos is not None and limited else 0.0
                ends = ray.fan or ((ray.end_dx_m, ray.end_dy_m),)
                table += [float(k), 1.0 if ray.fan else 0.0, ray.mount_x_m, ray.mount_y_m, ray.range_m,
                          *cone, 1.0 if limited else 0.0, threshold, float(len(ends))]
                table += [v for end in ends for v in end]
                plan_members.append((k, ray.mount_x_m, ray.mount_y_m, ray.range_m,
                                     cone if ray.fan else None, threshold if limited else None, ends))
            plan.append((circle, plan_members))
        python = _python_rays(plan, len(rays), space, chipmunk.shape_filter(ray_filter), chipmunk.query_info(),
                              chipmunk.point_info())
        # the kernel's first arguments: the space (its address, and what keeps it alive while the
        # cast lives), the ray filter's fields, the table
        head = (int(ffi.cast("uintptr_t", chipmunk.c_space(space))), space, ray_filter.group,
                ray_filter.categories, ray_filter.mask, array("d", table).tobytes())
        kernel = _kernel if compiled else None
        if lidar is not None:
            self.cast: Rays = lidar.joined(len(rays), kernel, head, python)
        else:
            self.cast = python if kernel is None else partial(kernel, *head)


def _python_rays(plan: list[tuple[tuple[float, float, float] | None, list[_Member]]], count: int,
                 owner: pymunk.Space, flt: Any, info: Any, nearest: Any) -> Rays:
    """The kernel's rays, cast from Python: each by the same chipmunk call with the same
    arithmetic (each expression as the kernel writes it), so each reads the same bit for bit.
    A closure: its names are the cheapest a function can read, and it runs a few times a tick.

    The points go to chipmunk as three ``cpVect`` structs made once (a ray's start and end, a
    circle's centre) whose doubles are written through a memoryview: cffi converts a tuple to
    a struct for each call, which cost a third of a ray. A hit's alpha and normal are read
    through a memoryview of the result, cheaper than its fields or a cdata pointer.
    Over 60 lines: one closure on the hot path, as the kernel's loop is one function; the cone's
    loop as a function of its own would add a call for each sonar each tick.
    """
    query, near, inf = chipmunk.segment_query_first, chipmunk.point_query_nearest, math.inf
    space = chipmunk.c_space(owner)
    points = ffi.new("cpVect[3]")
    start, end, centre = points[0], points[1], points[2]  # each a struct sharing the array's memory
    at = memoryview(ffi.buffer(points)).cast("d")  # start x, y, end x, y, centre x, y
    raw = memoryview(ffi.buffer(info)).cast("d")  # the hit, as doubles
    alpha, normal_x, normal_y = ALPHA, NORMAL, NORMAL + 1

    # The groups and cones a ray of which hit something the tick before: their circle's test
    # would pass again but on the tick the robot leaves them (then their rays miss, and the next
    # tick tests again), so it is skipped. A skipped test changes no reading, only the work.
    warm_group = [False] * len(plan)
    warm = [False] * count
    groups = [(g, circle, members) for g, (circle, members) in enumerate(plan)]

    def cast(x: float, y: float, c: float, s: float) -> list[float]:
        values = [inf] * count
        for g, circle, members in groups:
            if circle is not None and not warm_group[g]:
                cx, cy, radius = circle
                at[4] = x + c * cx - s * cy
                at[5] = y + s * cx + c * cy
                if not near(space, centre, radius, flt, nearest):
                    continue
            seen = False
            for slot, mx, my, rng, cone, threshold, ends in members:
                if cone is None:  # a lone ray
                    ox = x + c * mx - s * my
                    oy = y + s * mx + c * my
                    ex, ey = ends[0]
                    at[0] = ox
                    at[1] = oy
                    at[2] = ox + c * ex - s * ey
                    at[3] = oy + s * ex + c * ey
                    if query(space, start, end, 0.0, flt, info):
                        values[slot] = raw[alpha] * rng
                        seen = True
                    continue
                if not warm[slot]:
                    cx, cy, radius = cone
                    at[4] = x + c * cx - s * cy
                    at[5] = y + s * cx + c * cy
                    if not near(space, centre, radius, flt, nearest):
                        continue
                ox = x + c * mx - s * my
                oy = y + s * mx + c * my
                at[0] = ox
                at[1] = oy
                v = inf
                hit = False
                for ex, ey in ends:
                    wx = c * ex - s * ey
                    wy = s * ex + c * ey
                    at[2] = ox + wx
                    at[3] = oy + wy
                    if query(space, start, end, 0.0, flt, info):
                        hit = True
                        d = raw[alpha] * rng
                        if d < v and (threshold is None or raw[normal_x] * wx + raw[normal_y] * wy <= threshold):
                            v = d
                warm[slot] = hit
                if hit:
                    seen = True
                values[slot] = v
            warm_group[g] = seen
        return values

    cast.__dict__["space"] = owner  # the space's shapes live while the cast does
    return cast
