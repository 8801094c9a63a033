"""A lidar's whole fan of beams cast at once, in C or with numpy, outside chipmunk: the pymunk backend's lidar.

A robot's ray caster (``labsim.backends.pymunk.ray_cast.RaySet``, one call a tick for all its
rays) casts its lidar's beams through ``LidarFan.joined``, where a sonar is one chipmunk ray
cast (chipmunk's segment query costs about 0.6 us a ray even from C, so 360 beams could never
run at 20,000 ticks a second). The
fan reads the same shapes chipmunk would: every shape of the space its ray filter lets through,
taken apart once into straight faces and circles (a wall, a capsule, is its two long faces and
two round ends; a polygon its edges, and its bevel circles when it has a radius). Each tick the
faces and circles near the lidar are put in its frame, and one matrix product with the beams'
fixed directions gives, for every beam and face, the two cross products that say whether the
beam crosses the face and where. The ranges are those of chipmunk's cast up to rounding
(within 1e-12 m but for a beam that grazes a round end; ``tests/contract/test_lidar_fan.py``
compares them on random worlds), and two of chipmunk's ways are kept: a lidar inside a shape
reads 0 on every beam, and in a wall's band the beams that can meet that wall are cast through
chipmunk (``_band_beams``).

Distances are found as their inverses, 1 / t, which a face gives without a division per beam:
a beam u crosses the face p1 -> p2 (seen counter-clockwise from the lidar) where
``1 / t = (cross(p1, u) + cross(u, p2)) / cross(p1, p2)`` with both cross products >= 0. A
missed beam reads 0 or less there, so the nearest face is a maximum over faces, and a beam
whose maximum is below 1 / range_m reads ``inf``.

Where the install built ``_fan.c`` (a C compiler was there) the robot's one call of it does the
point test, the faces, the circles and the list of ranges after its other rays', each face and
circle tried only by the beams within its angular extent; else numpy does them as above.
``KERNEL`` says which ("c" or "numpy"); both read the same to 1e-12 m (docs/decisions.md §25,
§39).
"""
from __future__ import annotations

import bisect
import math
from array import array
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pymunk

from labsim.backends.pymunk import chipmunk, ray_cast
from labsim.backends.pymunk.ray_cast import Rays

# How far the lidar may move before the faces near it are chosen again, in metres: the faces
# kept are those within range_m + SLACK_M of where they were chosen, so a smaller slack keeps
# fewer faces and chooses more often (0.5 m: every ten ticks at 1 m/s and 20 ticks a second).
SLACK_M = 0.5
# The largest distance chipmunk's point query takes for "the lidar is inside a shape": the
# smallest positive double, so that ``distance < TOUCH_M`` is ``distance <= 0``, chipmunk's
# own test before it casts (a ray that starts in a shape hits it at once: reads 0).
TOUCH_M = 5e-324
# Added to a circle's half-width when choosing the beams to test against it, in radians: far
# beyond the rounding of the angles, so no beam that meets it is left out.
ANGLE_MARGIN_RAD = 1e-9
TAU = 2.0 * math.pi
maximum = np.maximum  # its reduce, without ndarray.max's Python layer

# Whether the C kernel casts (``ray_cast.KERNEL``): the fan's beams in the same call of it as
# the robot's other rays, else numpy (docs/decisions.md §25, §39).
KERNEL = "c" if ray_cast.KERNEL == "c" else "numpy"


@dataclass(frozen=True)
class Outline:
    """Shapes taken apart, in one frame: faces p1 -> p2 (outside on their left, so a lidar
    outside sees them counter-clockwise) and circles (centre and radius), as numpy arrays."""

    p1: np.ndarray  # (F, 2) metres
    p2: np.ndarray  # (F, 2)
    centres: np.ndarray  # (K, 2)
    radii: np.ndarray  # (K,)
    # each round-ended segment: its unit normal n (chipmunk's), n . a, its radius, its first
    # face, its ends a and b
    walls: list[tuple[float, float, float, float, int, float, float, float, float]]


def rejects(a: pymunk.ShapeFilter, b: pymunk.ShapeFilter) -> bool:
    """chipmunk's ``cpShapeFilterReject``: whether a ray with filter b skips a shape with filter a."""
    return ((a.group != 0 and a.group == b.group) or (a.categories & b.mask) == 0
            or (a.mask & b.categories) == 0)


def outline(shapes: list[pymunk.Shape]) -> Outline:
    """The faces and circles of these shapes, in their bodies' own frames (a static body's is
    the world's). Segments and polygons with a radius grow by it, as chipmunk's queries do."""
    p1: list[tuple[float, float]] = []
    p2: list[tuple[float, float]] = []
    centres: list[tuple[float, float]] = []
    radii: list[float] = []
    walls: list[tuple[float, float, float, float, int, float, float, float, float]] = []
    for shape in shapes:
        if isinstance(shape, pymunk.Segment):
            (ax, ay), (bx, by), r = shape.a, shape.b, shape.radius
            length = math.hypot(bx - ax, by - ay)
            if length > 0.0:
                nx, ny = (by - ay) / length * r, -(bx - ax) / length * r  # chipmunk's n (right), times r
                p1 += [(bx + nx, by + ny), (ax - nx, ay - ny)]
                p2 += [(ax + nx, ay + ny), (bx - nx, by - ny)]
            if r > 0.0:
                centres += [(ax, ay), (bx, by)]
                radii += [r, r]
                if length > 0.0:
                    nx, ny = nx / r, ny / r
                    walls.append((nx, ny, nx * ax + ny * ay, r, len(p1) - 2, ax, ay, bx, by))
        elif isinstance(shape, pymunk.Poly):
            verts = [(v.x, v.y) for v in shape.get_vertices()]  # counter-clockwise, as chipmunk keeps them
            r = shape.radius
            for (ax, ay), (bx, by) in zip(verts, verts[1:] + verts[:1]):
                length = math.hypot(bx - ax, by - ay)
                nx, ny = (by - ay) / length * r, -(bx - ax) / length * r
                p1.append((bx + nx, by + ny))  # clockwise: the outside on the left
                p2.append((ax + nx, ay + ny))
            if r > 0.0:
                centres += verts
                radii += [r] * len(verts)
        elif isinstance(shape, pymunk.Circle):
            centres.append((shape.offset.x, shape.offset.y))
            radii.append(shape.radius)
    return Outline(np.array(p1, float).reshape(-1, 2), np.array(p2, float).reshape(-1, 2),
                   np.array(centres, float).reshape(-1, 2), np.array(radii, float), walls)


Face = tuple[float, float, float, float]  # p1.x, p1.y, p2.x, p2.y, world metres
Band = tuple[float, float, float, float, float, float, float, float]  # _Near.bands
Circle = tuple[float, float, float]  # centre x, y, radius squared


@dataclass(frozen=True)
class _Near:
    """The static faces and circles within reach of a disc of SLACK_M around (x_m, y_m)."""

    x_m: float
    y_m: float
    faces: list[Face]
    circles: list[Circle]
    # walls whose band (their line, r either side) comes near: (n.x, n.y, n . a, r, a.x, a.y, b.x, b.y) each
    bands: list[Band]


class LidarFan:
    """One robot's lidar: ``cast(x, y, angle)`` gives its beams' ranges for the body's pose.

    ``angles_rad`` are the beams' directions in the robot frame, in the order ``cast`` returns
    them; ``mount_x_m`` the lidar's place ahead of the body's origin. Static shapes are taken
    apart once; other bodies' shapes (other robots) are put where their bodies are every tick.
    A tick's work is the robot's one call of the C kernel (``KERNEL == "c"``), or with numpy
    plain Python per face or circle (a handful of them) and numpy per beam; ``compiled=False``
    takes the numpy fan even where the kernel was built (the tests compare the two).
    """

    def __init__(self, space: pymunk.Space, body: pymunk.Body, ray_filter: pymunk.ShapeFilter,
                 angles_rad: list[float], mount_x_m: float, range_m: float, *, compiled: bool = True) -> None:
        seen = [s for s in space.shapes if not s.sensor and not rejects(s.filter, ray_filter) and s.body is not None]
        static = outline([s for s in seen if _body(s).body_type == pymunk.Body.STATIC])
        self._static = Outline(static.p1, static.p2, *_unique(static.centres, static.radii), static.walls)
        moving = [s for s in seen if _body(s).body_type != pymunk.Body.STATIC and s.body is not body]
        # a moving round-ended segment (no robot is one) would need its band checked as it moves
        self._always_chipmunk = any(isinstance(s, pymunk.Segment) and s.radius > 0.0 for s in moving)
        self._moving = [_Moving.of(s) for s in moving]
        self._owner, self._ray_filter = space, ray_filter
        self._space = chipmunk.c_space(space)
        self._filter = chipmunk.shape_filter(ray_filter)
        self._info = chipmunk.point_info()
        self._seg = chipmunk.query_info()
        self._ends = [(range_m * math.cos(a), range_m * math.sin(a)) for a in angles_rad]
        self._cos = [math.cos(a) for a in angles_rad]
        self._sin = [math.sin(a) for a in angles_rad]
        # cross(q, u) = q.x * u.y - q.y * u.x: a face's (q.x, q.y) times these rows
        self._cross = np.array([self._sin, [-x for x in self._cos]])
        # the beams by direction in [0, 2 pi), to find those a circle's angular extent covers
        order = sorted(range(len(angles_rad)), key=lambda k: angles_rad[k] % TAU)
        self._by_angle = [angles_rad[k] % TAU for k in order]
        self._order = order
        self._compiled = compiled
        self._cast: Rays | None = None  # cast's own caster, made on its first call
        # the kernel's table of the beams: cos, sin, the sorted directions and their beams
        self._table = array("d", self._cos + self._sin + self._by_angle + [float(k) for k in order]).tobytes()
        self._beams = len(angles_rad)
        self._mount_x_m = mount_x_m
        self._range_m = range_m
        self._inv_range = 1.0 / range_m
        self._near: _Near | None = None
        self._inf = np.full(len(angles_rad), math.inf)  # copied as each cast's ranges
        self._zero = np.zeros(len(angles_rad))  # 1 / t where no face is seen (read, never written)

    def cast(self, x_m: float, y_m: float, angle_rad: float) -> list[float]:
        """Every beam's range in metres (inf beyond range_m) for the body at this pose: this
        lidar alone, through the caster a robot's rays go through (``ray_cast.RaySet``)."""
        if self._cast is None:
            self._cast = ray_cast.RaySet(self._owner, self._ray_filter, [], lidar=self, compiled=self._compiled).cast
        return self._cast(x_m, y_m, math.cos(angle_rad), math.sin(angle_rad))

    def joined(self, count: int, kernel: Callable[..., list[float]] | None, head: tuple[object, ...],
               python: Rays) -> Rays:
        """``RaySet.cast`` of a robot with this lidar: ``cast(x, y, c, s)`` gives its ``count``
        sonar and IR readings, then every beam's range.

        ``kernel``, where the C kernel casts, is ``_fan.rays``, and ``head`` its first six
        arguments (the space, its owner, the ray filter's three fields, the robot's table of
        rays); given the faces and circles near the lidar it casts the beams too: one call a
        tick. Without it the Python rays (``python``) and the numpy fan cast the same. A lidar
        inside a shape reads 0 on every beam (chipmunk's cast does); among moving round-ended
        segments every beam goes through chipmunk, as it does in a wall's band.
        """
        f = self._ray_filter
        if tuple(head[2:5]) != (f.group, f.categories, f.mask):  # the kernel's inside test uses the robot's
            raise ValueError("a lidar is cast with its robot's ray filter")
        near, space, flt, info, touch = chipmunk.point_query_nearest, self._space, self._filter, self._info, TOUCH_M
        mount, zeros, always, moving = self._mount_x_m, [0.0] * self._beams, self._always_chipmunk, self._moving
        choose, with_moving, band_beams, rays = self._choose, self._with_moving, self._band_beams, self._rays
        numpy_ranges, table, inv_range, hypot, fan = self._numpy_ranges, self._table, self._inv_range, math.hypot, self
        at, owner, group, categories, mask, rows = head if kernel is not None else (0, None, 0, 0, 0, b"")

        def alone(x: float, y: float, c: float, s: float) -> list[float]:
            """The other rays alone, in their one call."""
            if kernel is not None:
                return kernel(at, owner, group, categories, mask, rows, x, y, c, s)
            return python(x, y, c, s)

        def cast(x: float, y: float, c: float, s: float) -> list[float]:
            ox = x + c * mount  # as a sonar's mount
            oy = y + s * mount
            if kernel is None or always:  # the kernel makes this test itself
                if near(space, (ox, oy), touch, flt, info):
                    return alone(x, y, c, s) + zeros  # inside a shape: chipmunk's cast reads 0 for every ray
                if always:
                    return alone(x, y, c, s) + rays(ox, oy, c, s)
            scene = fan._near
            if scene is None or hypot(ox - scene.x_m, oy - scene.y_m) > SLACK_M:
                scene = fan._near = choose(ox, oy)
            bands = scene.bands
            faces, circles = scene.faces, scene.circles
            if moving:
                faces, circles = with_moving(ox, oy, faces, circles)
            if kernel is not None:
                out = kernel(at, owner, group, categories, mask, rows, x, y, c, s, faces, circles, table, inv_range,
                             ox, oy)
                if bands and out[count] == 0.0:  # inside a shape (no beam the fan casts reads 0)
                    return out
            else:
                out = python(x, y, c, s) + numpy_ranges(ox, oy, c, s, faces, circles)
            if bands:  # in a wall's band: chipmunk's own reading where that wall can be seen
                inside = [band for band in bands if abs(band[0] * ox + band[1] * oy - band[2]) <= band[3]]
                if inside:
                    band_beams(ox, oy, c, s, inside, out, count)
            return out

        cast.__dict__["lidar"] = self  # what the benchmarks and tests reach the fan by
        return cast

    def _numpy_ranges(self, ox: float, oy: float, c: float, s: float, faces: list[Face],
                      circles: list[Circle]) -> list[float]:
        """What the C kernel gives, with numpy: the faces' and the circles' nearest, or inf."""
        inv = self._faces(ox, oy, c, s, faces)
        out = self._inf.copy()
        np.divide(1.0, inv, out=out, where=inv >= self._inv_range)
        ranges: list[float] = out.tolist()
        hits = self._circles(ox, oy, c, s, circles)
        if hits:
            for k, v in zip(*hits):
                if v >= self._inv_range and 1.0 / v < ranges[k]:
                    ranges[k] = 1.0 / v
        return ranges

    def cast_through_chipmunk(self, x_m: float, y_m: float, angle_rad: float) -> list[float]:
        """What ``cast`` gives, by casting each beam through chipmunk as a sonar is (the oracle
        the fan is tested against, and what the fan itself does in a wall's band)."""
        c, s = math.cos(angle_rad), math.sin(angle_rad)
        return self._rays(x_m + c * self._mount_x_m, y_m + s * self._mount_x_m, c, s)

    def _rays(self, ox: float, oy: float, c: float, s: float) -> list[float]:
        """Each beam cast through chipmunk, as a sonar is: the oracle the fan is tested
        against, and what a lidar among moving round-ended segments reads.

        In a wall's band (its line, as wide as the wall, beyond its ends) chipmunk's segment
        query of the wall is not the capsule's geometry: it tests the beam against the long
        face on the lidar's side, which is then behind the lidar, and looks at the round ends
        only when the beam's line misses that face (a beam that meets a round end can read
        farther, or nothing). There ``_band_beams`` casts through chipmunk the beams that can
        meet that wall.
        """
        out = []
        query, space, flt, info, rng = chipmunk.segment_query_first, self._space, self._filter, self._seg, self._range_m
        for ex, ey in self._ends:
            hit = query(space, (ox, oy), (ox + c * ex - s * ey, oy + s * ex + c * ey), 0.0, flt, info)
            out.append(info.alpha * rng if hit else math.inf)
        return out

    def _band_beams(self, ox: float, oy: float, c: float, s: float, bands: list[Band], ranges: list[float],
                    at: int = 0) -> None:
        """Each beam that can meet a wall whose band the lidar is in, cast through chipmunk into
        ``ranges`` from ``at`` on (see ``_rays`` for why chipmunk reads otherwise there). Every point chipmunk's
        query of the wall can report lies in the wall's capsule, whose directions from the lidar
        (outside it: the point test said so) are those between its two round ends' extents; the
        other beams cannot meet the wall, and the fan reads them as chipmunk does. A robot
        crosses a band in a tick or two, and then casts a few beams, not all of them."""
        query, space, flt, info, rng = chipmunk.segment_query_first, self._space, self._filter, self._seg, self._range_m
        for _nx, _ny, _at, r, ax, ay, bx, by in bands:
            (mid_a, half_a), (mid_b, half_b) = (self._extent(ox, oy, c, s, ax, ay, r),
                                                self._extent(ox, oy, c, s, bx, by, r))
            to_b = (mid_b - mid_a + math.pi) % TAU - math.pi  # b's direction from a's, in [-pi, pi)
            lo, hi = min(-half_a, to_b - half_b), max(half_a, to_b + half_b)
            for first, last in _arcs(mid_a + lo, mid_a + hi):
                for j in range(bisect.bisect_left(self._by_angle, first), bisect.bisect_right(self._by_angle, last)):
                    k = self._order[j]
                    ex, ey = self._ends[k]
                    hit = query(space, (ox, oy), (ox + c * ex - s * ey, oy + s * ex + c * ey), 0.0, flt, info)
                    ranges[at + k] = info.alpha * rng if hit else math.inf

    @staticmethod
    def _extent(ox: float, oy: float, c: float, s: float, x: float, y: float, r: float) -> tuple[float, float]:
        """The direction in [0, 2 pi) of a circle at (x, y) seen from the lidar, in its frame,
        and its half-width in radians with a margin (the whole circle when the lidar is in it)."""
        dx, dy = x - ox, y - oy
        qx, qy = c * dx + s * dy, c * dy - s * dx
        distance = math.hypot(qx, qy)
        half = math.asin(r / distance) if distance > r else math.pi
        return math.atan2(qy, qx) % TAU, half + ANGLE_MARGIN_RAD

    def _faces(self, ox: float, oy: float, c: float, s: float, faces: list[Face]) -> np.ndarray:
        """1 / t of the nearest face each beam crosses (<= 0 for none): see the module docstring."""
        # per face: cross(p1, u) / num, cross(-p2, u) / num, cross(-e, u) / num, as (x, y) pairs
        rows_a: list[float] = []
        rows_b: list[float] = []
        rows_e: list[float] = []
        for p1x, p1y, p2x, p2y in faces:
            ax, ay, bx, by = p1x - ox, p1y - oy, p2x - ox, p2y - oy
            num = ax * by - ay * bx  # cross(p1, p2), turning-free: > 0 seen from outside
            if num > 0.0:  # a face seen from behind or edge-on reads nothing
                k = 1.0 / num
                # in the lidar's frame (turned by -angle)
                q1x, q1y = (c * ax + s * ay) * k, (c * ay - s * ax) * k
                q2x, q2y = (c * bx + s * by) * k, (c * by - s * bx) * k
                rows_a += (q1x, q1y)
                rows_b += (-q2x, -q2y)
                rows_e += (q1x - q2x, q1y - q2y)
        n = len(rows_a) // 2
        if n == 0:
            return self._zero
        # one matrix product: every beam and face
        cross = np.array(rows_a + rows_b + rows_e).reshape(3 * n, 2) @ self._cross
        # 1 / t, the last rows, where the beam lies between p1 and p2 (both others >= 0), else < 0
        return maximum.reduce(np.copysign(cross[2 * n:], np.minimum(cross[:n], cross[n:2 * n])))

    def _circles(self, ox: float, oy: float, c: float, s: float,
                 circles: list[Circle]) -> tuple[list[int], list[float]] | None:
        """The beams that meet a circle and their 1 / t, trying the beams within each circle's
        angular extent; None when none does.

        With h = |q|^2 - r^2 (> 0: the lidar is outside) and p = q . u, a beam meets the circle
        first at t = h / (p + sqrt(p^2 - h)), where p > 0 and p^2 >= h.
        """
        beams: list[int] = []
        inverses: list[float] = []
        by_angle, order, cos_u, sin_u = self._by_angle, self._order, self._cos, self._sin
        for cx, cy, r2 in circles:
            dx, dy = cx - ox, cy - oy
            qx, qy = c * dx + s * dy, c * dy - s * dx
            h = qx * qx + qy * qy - r2
            if h <= 0.0:
                continue  # the lidar touches it: the point query said so already
            # the beams within its half-width (and a margin) of its direction, which the exact
            # test below sorts out
            half = math.asin(min(1.0, math.sqrt(r2 / (h + r2)))) + ANGLE_MARGIN_RAD
            mid = math.atan2(qy, qx) % TAU
            for lo, hi in _arcs(mid - half, mid + half):
                for j in range(bisect.bisect_left(by_angle, lo), bisect.bisect_right(by_angle, hi)):
                    k = order[j]
                    p = qx * cos_u[k] + qy * sin_u[k]
                    d = p * p - h
                    if p > 0.0 and d >= 0.0:
                        beams.append(k)
                        inverses.append((p + math.sqrt(d)) / h)
        return (beams, inverses) if beams else None

    def _choose(self, ox: float, oy: float) -> _Near:
        """The static faces and circles a beam from within SLACK_M of (ox, oy) can reach."""
        st, reach = self._static, self._range_m + SLACK_M
        o = np.array((ox, oy))
        e = st.p2 - st.p1
        length_sq = (e * e).sum(axis=1)
        safe = np.where(length_sq > 0.0, length_sq, 1.0)
        along = np.clip(((o - st.p1) * e).sum(axis=1) / safe, 0.0, 1.0)
        gap = o - (st.p1 + along[:, None] * e)
        distance = np.sqrt((gap * gap).sum(axis=1))
        # how far o is on the face's outside (its left): a face the disc is wholly behind is unseen
        outside = (e[:, 0] * (o[1] - st.p1[:, 1]) - e[:, 1] * (o[0] - st.p1[:, 0])) / np.sqrt(safe)
        keep = (distance <= reach) & (outside > -SLACK_M) & (length_sq > 0.0)
        ring = np.sqrt(((st.centres - o) ** 2).sum(axis=1)) - st.radii <= reach
        centres, radii = st.centres[ring], st.radii[ring]
        faces = np.column_stack((st.p1[keep], st.p2[keep])).tolist()
        circles = np.column_stack((centres, radii * radii)).tolist()
        far = distance.tolist()
        bands = [(nx, ny, at, r, ax, ay, bx, by) for nx, ny, at, r, face, ax, ay, bx, by in st.walls
                 if far[face] - r <= reach and abs(nx * ox + ny * oy - at) <= r + SLACK_M]
        return _Near(ox, oy, [tuple(f) for f in faces], [tuple(c) for c in circles], bands)

    def _with_moving(self, ox: float, oy: float, faces: list[Face],
                     circles: list[Circle]) -> tuple[list[Face], list[Circle]]:
        """The static faces and circles with those of the other bodies within range, where they are now."""
        faces, circles = list(faces), list(circles)
        for m in self._moving:
            p = chipmunk.body_position(m.body)
            if math.hypot(p.x - ox, p.y - oy) - m.reach_m > self._range_m:
                continue
            a = chipmunk.body_angle(m.body)
            c, s, x, y = math.cos(a), math.sin(a), p.x, p.y
            faces += [(x + c * ax - s * ay, y + s * ax + c * ay, x + c * bx - s * by, y + s * bx + c * by)
                      for ax, ay, bx, by in m.faces]
            circles += [(x + c * cx - s * cy, y + s * cx + c * cy, r2) for cx, cy, r2 in m.circles]
        return faces, circles


@dataclass(frozen=True)
class _Moving:
    """A shape on another body, in the body's frame, and how far it reaches from the body's origin."""

    body: object  # its cpBody *
    faces: list[Face]
    circles: list[Circle]
    reach_m: float

    @staticmethod
    def of(shape: pymunk.Shape) -> _Moving:
        o = outline([shape])
        faces = [(a[0], a[1], b[0], b[1]) for a, b in zip(o.p1.tolist(), o.p2.tolist())]
        circles = [(x, y, r * r) for (x, y), r in zip(o.centres.tolist(), o.radii.tolist())]
        return _Moving(chipmunk.c_body(_body(shape)), faces, circles, _reach(o))


def _body(shape: pymunk.Shape) -> pymunk.Body:
    assert shape.body is not None  # the shapes of a space all have a body
    return shape.body


def _arcs(lo: float, hi: float) -> list[tuple[float, float]]:
    """The interval [lo, hi] of directions (lo in [-pi, 2 pi)) as intervals within [0, 2 pi)."""
    if hi - lo >= TAU:
        return [(0.0, TAU)]
    if lo < 0.0:
        return [(0.0, hi), (lo + TAU, TAU)]
    if hi >= TAU:
        return [(lo, TAU), (0.0, hi - TAU)]
    return [(lo, hi)]


def _reach(shape: Outline) -> float:
    """How far a body's shape reaches from the body's origin, in metres."""
    ends = np.concatenate((shape.p1, shape.p2))
    far = float(np.sqrt((ends * ends).sum(axis=1)).max()) if len(ends) else 0.0
    if len(shape.radii):
        far = max(far, float((np.sqrt((shape.centres ** 2).sum(axis=1)) + shape.radii).max()))
    return far


def _unique(centres: np.ndarray, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The circles without repeats (two walls meeting end to end share a round end)."""
    if len(radii) < 2:
        return centres, radii
    table = np.unique(np.column_stack((centres, radii)), axis=0)
    return table[:, :2], table[:, 2]
