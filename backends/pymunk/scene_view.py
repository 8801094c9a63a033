"""Camera images that see the scene: other robots, walls and blocks standing on the ground.

The step after ``labsim.backends.pymunk.camera`` in the pymunk backend's ``sense()``: that
module warps the ground into a frame, and this one draws over it everything that stands on the
floor, each as an upright prism (its outline raised to its height, flat-shaded):

* other robots: their model's ``footprint``, ``height_m`` and ``rgb``
  (``labsim.backends.scene.models``), at their bodies' poses when ``sense()`` runs. A camera
  does not see the robot it is mounted on.
* walls: the box around the segment, as thick as the wall, its ends squared off over pymunk's
  round caps; blocks: their corners. Both with the world file's ``height`` and ``color``.

Projection and occlusion are exact for prisms: each visible face (a side facing the camera, a
top below it) is clipped to the camera's near plane, projected with the same pinhole model as
the ground (``camera_axes``) and filled with ``cv2.fillConvexPoly`` at 1/16 pixel. A solid
always hides the floor behind it (it stands on it). When the faces of two solids may overlap
in the picture, every face is drawn through a per-pixel depth test: a plane's inverse depth is
an affine function of the pixel, so one multiply-add per pixel gives it. The faces of one convex
solid never overlap, so a lone solid needs no test. No antialiasing, nothing random: the same
poses give the same bytes.

Cost: each solid is first tested against the camera's frustum (a capsule around a wall's
segment, a sphere around a robot or block), in plain Python, so a solid out of view costs a few
microseconds; solids whose every point is deeper than ``FAR_M`` are not drawn, as the floor
there is sky. ``benchmarks/bench_road.py`` measures the whole tick.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from labsim.backends.pymunk import chipmunk
from labsim.backends.pymunk.camera import FAR_M, GroundView, camera_axes
from labsim.backends.scene.models import Camera, RobotModel
from labsim.backends.scene.world import Block, Wall, World

NEAR_M = 0.01  # faces are clipped this far in front of the camera
_SHIFT = 4  # fixed-point bits for cv2.fillConvexPoly: edges to 1/16 pixel
_ONE = 1 << _SHIFT
# Flat shading: a side facing the light gets 0.9 of its colour, one facing away 0.5, a top all
# of it; a fixed light (from the north-west, horizontally) keeps frames the same at every pose.
_LIGHT = (-0.6, 0.8)


@dataclass(frozen=True)
class Solid:
    """An upright prism: a convex outline (counter-clockwise, metres), its height and colour.

    ``a``, ``b`` and ``radius_m`` bound it for culling: every point of the prism lies within
    ``radius_m`` of the segment a-b raised to half its height.
    """

    outline: tuple[tuple[float, float], ...]
    height_m: float
    rgb: tuple[int, int, int]
    a: tuple[float, float]
    b: tuple[float, float]
    radius_m: float


def _ccw(points: Sequence[tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    area2 = sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(points, [*points[1:], points[0]]))
    return tuple(points) if area2 >= 0 else tuple(reversed(points))


def _solid(outline: Sequence[tuple[float, float]], height: float, rgb: tuple[int, int, int],
           a: tuple[float, float] | None = None, b: tuple[float, float] | None = None) -> Solid:
    """A prism; bounded by a sphere around its outline's centre unless a spine a-b is given."""
    if a is None or b is None:
        xs, ys = [p[0] for p in outline], [p[1] for p in outline]
        a = b = ((min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2)
    reach = max(_segment_distance(p, a, b) for p in outline)
    return Solid(_ccw(outline), height, rgb, a, b, math.hypot(reach, height / 2) * (1 + 1e-9) + 1e-9)


def wall_solid(wall: Wall) -> Solid:
    (ax, ay), (bx, by) = wall.a, wall.b
    length = math.hypot(bx - ax, by - ay)
    t2 = wall.thickness_m / 2
    ux, uy = (bx - ax) / length * t2, (by - ay) / length * t2  # along, t/2 long
    nx, ny = -uy, ux  # across, to the left
    box = [(ax - ux - nx, ay - uy - ny), (bx + ux - nx, by + uy - ny),
           (bx + ux + nx, by + uy + ny), (ax - ux + nx, ay - uy + ny)]
    return _solid(box, wall.height_m, wall.rgb, wall.a, wall.b)


def block_solid(block: Block) -> Solid:
    return _solid(block.corners, block.height_m, block.rgb)


def robot_solid(model: RobotModel) -> Solid:
    """A robot's prism in its own frame, bounded by a sphere about its origin (the body's
    position), which is where ``render`` puts it."""
    return _solid(model.footprint, model.height_m, model.rgb, (0.0, 0.0), (0.0, 0.0))


def _segment_distance(p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    dx, dy = b[0] - a[0], b[1] - a[1]
    n2 = dx * dx + dy * dy
    t = 0.0 if n2 == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / n2))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


@dataclass(frozen=True)
class _Lens:
    """What a camera's projection needs that does not depend on the pose."""

    axes_t: np.ndarray  # rows: the picture's right, its downwards, the viewing direction
    f: float  # focal length, pixels
    c0: float  # the column and row of the optical axis (pixel centres are whole numbers)
    r0: float
    planes: tuple[tuple[float, float, float, float], ...]  # (nx, ny, nz, offset): outside when > 0
    mount_x_m: float
    height_m: float
    width_px: int
    height_px: int


def _lens(camera: Camera) -> _Lens:
    axes, f = camera_axes(camera)
    w, h = camera.width_px, camera.height_px
    tx, ty = w / 2 / f, h / 2 / f
    kx, ky = math.hypot(1, tx), math.hypot(1, ty)
    # The frustum in camera coordinates (right, down, forward), each plane as a unit normal
    # pointing out and an offset: the near plane, the far one, then the picture's four edges.
    planes = ((0.0, 0.0, -1.0, NEAR_M), (0.0, 0.0, 1.0, -FAR_M),
              (1 / kx, 0.0, -tx / kx, 0.0), (-1 / kx, 0.0, -tx / kx, 0.0),
              (0.0, 1 / ky, -ty / ky, 0.0), (0.0, -1 / ky, -ty / ky, 0.0))
    return _Lens(axes.T.copy(), f, w / 2 - 0.5, h / 2 - 0.5, planes, float(camera.x_m), float(camera.height_m), w, h)


class SceneView:
    """A world's ground, its walls and blocks, and its robots' bodies, seen by cameras.

    ``render(x_m, y_m, heading_rad, camera, robot)`` is ``GroundView.render`` with the solids
    drawn over it; ``robot`` is the index of the robot the camera is on (-1: none), whose body
    is left out. ``bodies`` are the robots' pymunk bodies, read when a frame is rendered.
    """

    def __init__(self, ground: GroundView, statics: Sequence[Solid],
                 robots: Sequence[tuple[Any, Solid]] = ()) -> None:
        self._ground = ground
        self._statics = tuple(statics)
        self._robots = [(chipmunk.c_body(body), solid) for body, solid in robots]
        self._lenses: dict[Camera, _Lens] = {}

    def render(self, x_m: float, y_m: float, heading_rad: float, camera: Camera, robot: int = -1) -> np.ndarray:
        image = self._ground.render(x_m, y_m, heading_rad, camera)
        lens = self._lenses.get(camera)
        if lens is None:
            lens = self._lenses[camera] = _lens(camera)
        ch, sh = math.cos(heading_rad), math.sin(heading_rad)
        eye = (x_m + lens.mount_x_m * ch, y_m + lens.mount_x_m * sh, lens.height_m)
        # World offsets to camera coordinates: the robot's heading undone, then the axes.
        turn = np.array([[ch, sh, 0.0], [-sh, ch, 0.0], [0.0, 0.0, 1.0]])
        g = lens.axes_t @ turn
        rows = tuple(tuple(float(v) for v in row) for row in g)
        seen = [(np.asarray(s.outline), s) for s in self._statics if _may_see(lens, rows, eye, s, s.a, s.b)]
        for i, (body, solid) in enumerate(self._robots):
            if i == robot:
                continue
            p = chipmunk.body_position(body)
            at = (p.x, p.y)
            if _may_see(lens, rows, eye, solid, at, at):
                a = chipmunk.body_angle(body)
                c, s = math.cos(a), math.sin(a)
                outline = np.asarray(solid.outline) @ np.array([[c, s], [-s, c]]) + at
                seen.append((outline, solid))
        if seen:
            _draw(image, lens, g, eye, seen)
        return image


def _may_see(lens: _Lens, g: tuple[tuple[float, ...], ...], eye: tuple[float, float, float], solid: Solid,
             a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether the capsule around a-b (raised to half the solid's height) reaches into the
    frustum: for each plane, the part of a-b not farther out than the radius is cut down
    (Liang-Barsky); nothing left means out of view. Conservative: it may keep a solid whose
    corners all lie outside different planes, which then draws nothing."""
    z = solid.height_m / 2 - eye[2]
    da = (a[0] - eye[0], a[1] - eye[1], z)
    db = (b[0] - eye[0], b[1] - eye[1], z)
    qa = [r[0] * da[0] + r[1] * da[1] + r[2] * z for r in g]
    qb = [r[0] * db[0] + r[1] * db[1] + r[2] * z for r in g]
    lo, hi, rho = 0.0, 1.0, solid.radius_m
    for nx, ny, nz, off in lens.planes:
        sa = nx * qa[0] + ny * qa[1] + nz * qa[2] + off - rho
        sb = nx * qb[0] + ny * qb[1] + nz * qb[2] + off - rho
        if sa > 0 and sb > 0:
            return False
        if sa > 0:  # a is out, b in: keep from the crossing on
            lo = max(lo, sa / (sa - sb))
        elif sb > 0:
            hi = min(hi, sa / (sa - sb))
        if lo > hi:
            return False
    return True


def _faces(outline: np.ndarray, solid: Solid, g: np.ndarray,
           eye: tuple[float, float, float]) -> list[tuple[np.ndarray, np.ndarray, float, tuple[int, int, int]]]:
    """The faces of a prism the camera looks at: each as its corners in camera coordinates, its
    plane's normal there and offset (normal . q = offset for a point q on it), and its colour."""
    ex, ey, ez = eye
    rel = outline - (ex, ey)
    base = rel @ g[:, :2].T - ez * g[:, 2]  # the outline on the floor, camera coordinates
    up = solid.height_m * g[:, 2]
    top = base + up
    edge = np.roll(outline, -1, axis=0) - outline
    out: list[tuple[np.ndarray, np.ndarray, float, tuple[int, int, int]]] = []
    n = len(outline)
    for i in range(n):
        nx, ny = float(edge[i, 1]), float(-edge[i, 0])  # outward: the outline runs counter-clockwise
        # The side's plane, n . (p - eye) = n . (corner i - eye); the camera is in front of
        # the side when that is negative.
        offset = nx * float(rel[i, 0]) + ny * float(rel[i, 1])
        if offset >= 0:
            continue
        j = (i + 1) % n
        length = math.hypot(nx, ny)
        shade = 0.7 + 0.2 * (nx * _LIGHT[0] + ny * _LIGHT[1]) / length
        rgb = (round(solid.rgb[0] * shade), round(solid.rgb[1] * shade), round(solid.rgb[2] * shade))
        normal = g[:, 0] * nx + g[:, 1] * ny
        out.append((np.array([base[i], base[j], top[j], top[i]]), normal, offset, rgb))
    if ez > solid.height_m:  # the top, seen from above
        out.append((top, g[:, 2].copy(), solid.height_m - ez, solid.rgb))
    return out


def _draw(image: np.ndarray, lens: _Lens, g: np.ndarray, eye: tuple[float, float, float],
          seen: list[tuple[np.ndarray, Solid]]) -> None:
    """Fill the visible faces of the solids seen; through a depth buffer when two may overlap."""
    polygons = []  # per solid: its faces as (fixed-point pixel corners, plane, colour)
    boxes = []
    for outline, solid in seen:
        faces = []
        for corners, normal, offset, rgb in _faces(outline, solid, g, eye):
            pts = _project(corners, lens)
            if pts is not None:
                faces.append((pts, normal, offset, rgb))
        if faces:
            every = np.vstack([f[0] for f in faces])
            polygons.append(faces)
            boxes.append((*every.min(axis=0), *every.max(axis=0)))
    if not polygons:
        return
    if not _overlap(boxes):
        for faces in polygons:
            for pts, _, _, rgb in faces:
                cv2.fillConvexPoly(image, pts, rgb, cv2.LINE_8, _SHIFT)
        return
    depth = np.zeros(image.shape[:2])  # inverse depth, 1/m: 0 is the floor and sky, farthest
    for faces in polygons:
        for pts, normal, offset, rgb in faces:
            _fill_nearer(image, depth, lens, pts, normal, offset, rgb)


def _overlap(boxes: list[tuple[int, int, int, int]]) -> bool:
    return any(a[0] <= b[2] and b[0] <= a[2] and a[1] <= b[3] and b[1] <= a[3]
               for k, a in enumerate(boxes) for b in boxes[k + 1:])


def _project(corners: np.ndarray, lens: _Lens) -> np.ndarray | None:
    """A face's corners (camera coordinates) as fixed-point pixel corners for OpenCV, clipped
    to the near plane and to a margin around the picture; None when nothing of it is left."""
    if corners[:, 2].min() < NEAR_M:
        corners = _clip_near(corners)
        if len(corners) < 3:
            return None
    z = corners[:, 2]
    cols = lens.f * corners[:, 0] / z + lens.c0
    rows = lens.r0 - lens.f * corners[:, 1] / z
    pts = np.column_stack((cols, rows))
    w, h = lens.width_px, lens.height_px
    if pts.min() < -2 or cols.max() > w + 1 or rows.max() > h + 1:
        pts = _clip_box(pts, -2.0, -2.0, w + 1.0, h + 1.0)
        if len(pts) < 3:
            return None
    return np.round(pts * _ONE).astype(np.int32)


def _clip_near(corners: np.ndarray) -> np.ndarray:
    """Sutherland-Hodgman: the part of a convex polygon at depth NEAR_M or more."""
    out = []
    n = len(corners)
    for k in range(n):
        p, q = corners[k], corners[(k + 1) % n]
        if p[2] >= NEAR_M:
            out.append(p)
        if (p[2] >= NEAR_M) != (q[2] >= NEAR_M):
            out.append(p + (q - p) * ((NEAR_M - p[2]) / (q[2] - p[2])))
    return np.array(out).reshape(-1, 3)


def _clip_box(pts: np.ndarray, x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
    """Sutherland-Hodgman: the part of a convex polygon inside the box [x0, x1] x [y0, y1]."""
    poly = [(float(x), float(y)) for x, y in pts]
    for axis, bound, keep_below in ((0, x0, False), (0, x1, True), (1, y0, False), (1, y1, True)):
        out = []
        for k, p in enumerate(poly):
            q = poly[(k + 1) % len(poly)]
            p_in = (p[axis] <= bound) if keep_below else (p[axis] >= bound)
            q_in = (q[axis] <= bound) if keep_below else (q[axis] >= bound)
            if p_in:
                out.append(p)
            if p_in != q_in:
                t = (bound - p[axis]) / (q[axis] - p[axis])
                out.append((p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t))
        poly = out
        if not poly:
            break
    return np.array(poly).reshape(-1, 2)


def _fill_nearer(image: np.ndarray, depth: np.ndarray, lens: _Lens, pts: np.ndarray, normal: np.ndarray,
                 offset: float, rgb: tuple[int, int, int]) -> None:
    """Fill a face where it is nearer than what is drawn there.

    On the face's plane (normal . q = offset), the point seen through pixel (c, r) is at depth
    d along the axis with q = d (xn, yn, 1), xn = (c - c0) / f, yn = (r0 - r) / f; so
    1 / d = (normal . (xn, yn, 1)) / offset, affine in c and r.
    """
    h, w = depth.shape
    left, top = max(0, int(pts[:, 0].min()) >> _SHIFT), max(0, int(pts[:, 1].min()) >> _SHIFT)
    right = min(w, (int(pts[:, 0].max()) >> _SHIFT) + 2)
    bottom = min(h, (int(pts[:, 1].max()) >> _SHIFT) + 2)
    if left >= right or top >= bottom:
        return
    mask = np.zeros((bottom - top, right - left), np.uint8)
    cv2.fillConvexPoly(mask, pts - np.array([left << _SHIFT, top << _SHIFT], np.int32), 1, cv2.LINE_8, _SHIFT)
    f, nx, ny, nz = lens.f, float(normal[0]), float(normal[1]), float(normal[2])
    a, b = nx / (f * offset), -ny / (f * offset)
    c = (nz - nx * lens.c0 / f + ny * lens.r0 / f) / offset
    inverse = a * np.arange(left, right) + (b * np.arange(top, bottom) + c)[:, None]
    region = depth[top:bottom, left:right]
    nearer = (mask != 0) & (inverse > region)
    region[nearer] = inverse[nearer]
    image[top:bottom, left:right][nearer] = rgb


def scene_view(ground: GroundView, world: World, robots: Sequence[tuple[Any, RobotModel]] = ()) -> SceneView:
    """The SceneView of a world's walls and blocks and of robots (pymunk body, model)."""
    statics = [wall_solid(w) for w in world.walls] + [block_solid(b) for b in world.blocks]
    return SceneView(ground, statics, [(body, robot_solid(model)) for body, model in robots])
