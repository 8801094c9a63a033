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
an affine function of the pixel, so one multiply-add per pixel gives it. The faces of one
convex solid never overlap, so a lone solid needs no test, and a solid looks the same either
way. A top has the solid's colour; a side 0.6 to 0.9 of it, the more squarely it faces the
camera, so edges show. No antialiasing, nothing random: the same poses give the same bytes.

Cost: each solid is first tested against the camera's reach (how far its lowest-looking ray
goes before the floor) and frustum (a capsule around a wall's segment, a sphere around a robot
or block); solids whose every point is deeper than ``FAR_M`` are not drawn, as the floor there
is sky. Robots are tested all at once, in numpy, from poses read once a tick (``poses``), and
the robots of one model a camera sees are projected together, so that a camera costs the
same whatever the fleet's size, plus what it draws. ``benchmarks/bench_road.py`` measures the
whole tick, ``benchmarks/bench_road_robots.py`` the tick per robot at 1 to 100 robots.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np
import pymunk

from labsim.backends.pymunk import chipmunk
from labsim.backends.pymunk.camera import FAR_M, GroundView, camera_axes, ground_view
from labsim.backends.pymunk.polygon_clip import project_face
from labsim.backends.scene.ground import Ground
from labsim.backends.scene.models import Camera, RobotModel
from labsim.backends.scene.world import Block, Wall, World

NEAR_M = 0.01  # faces are clipped this far in front of the camera
_SHIFT = 4  # fixed-point bits for cv2.fillConvexPoly: edges to 1/16 pixel
_ONE = 1 << _SHIFT
_FLIP = np.array([1.0, -1.0])
_CROWD = 8  # robots: more, and a camera first tests their distances in numpy (see _robots_seen)


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

    axes_t: tuple[tuple[float, float, float], ...]  # rows: the picture's right, its downwards, the view
    f: float  # focal length, pixels
    c0: float  # the column and row of the optical axis (pixel centres are whole numbers)
    r0: float
    planes: tuple[tuple[float, float, float, float], ...]  # (nx, ny, nz, offset): outside when > 0
    reach_m: float  # nothing farther than this, horizontally, is in view
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
    # How far a ray at the picture's edge goes before it is below the floor: no solid beyond
    # that can be seen, whatever its height. Sampled densely along the edges, with a margin.
    t = np.linspace(-1.0, 1.0, 65)
    edge = np.concatenate([np.column_stack((t * tx, np.full_like(t, s * ty))) for s in (-1, 1)]
                          + [np.column_stack((np.full_like(t, s * tx), t * ty)) for s in (-1, 1)])
    rays = axes @ np.column_stack((edge, np.ones(len(edge)))).T
    falls = rays[2] < 0
    reach = FAR_M + 1.0
    if falls.all():
        reach = min(reach, 1.02 * camera.height_m * float((np.hypot(rays[0], rays[1]) / -rays[2]).max()) + 0.01)
    rows = tuple((float(r[0]), float(r[1]), float(r[2])) for r in axes.T)
    return _Lens(rows, f, w / 2 - 0.5, h / 2 - 0.5, planes, reach, float(camera.x_m), float(camera.height_m), w, h)


@dataclass(frozen=True)
class _Shape:
    """A solid's numbers for drawing, in its own frame: corners, outward side normals (not unit)
    and their lengths, each side's plane offset n . corner, and each side's four corners among
    the prism's (the floor ring, then the top ring)."""

    solid: Solid
    corners: np.ndarray  # n x 2
    normals: np.ndarray  # n x 2
    lengths: np.ndarray  # n
    offsets: np.ndarray  # n
    quads: np.ndarray  # n x 4, indices into the 2n corners of the prism


def _shape(solid: Solid) -> _Shape:
    corners = np.asarray(solid.outline, float)
    n = len(corners)
    edge = np.roll(corners, -1, axis=0) - corners
    normals = np.column_stack((edge[:, 1], -edge[:, 0]))  # outward: the outline runs counter-clockwise
    k = np.arange(n)
    quads = np.column_stack((k, (k + 1) % n, n + (k + 1) % n, n + k))
    return _Shape(solid, corners, normals, np.hypot(edge[:, 0], edge[:, 1]), (normals * corners).sum(axis=1), quads)


class SceneView:
    """A world's ground, its walls and blocks, and its robots' bodies, seen by cameras.

    ``render(x_m, y_m, heading_rad, camera, robot)`` is ``GroundView.render`` with the solids
    drawn over it; ``robot`` is the index of the robot the camera is on (-1: none), whose body
    is left out. ``bodies`` are the robots' pymunk bodies, read when a frame is rendered.
    """

    def __init__(self, ground: GroundView, statics: Sequence[Solid],
                 robots: Sequence[tuple[Any, Solid]] = (), blocks: Sequence[Solid] = ()) -> None:
        self._ground = ground
        self._walls = [_shape(s) for s in statics]
        self._blocks = {k: _shape(b) for k, b in enumerate(blocks)}  # by number: a live view moves them
        self._statics = self._walls + list(self._blocks.values())
        shapes: dict[Solid, _Shape] = {}  # one for equal solids: _draw draws those together
        self._robots = [(chipmunk.c_body(body), shapes.setdefault(solid, _shape(solid))) for body, solid in robots]
        self._radii = np.array([shape.solid.radius_m for _, shape in self._robots], float)
        self._lenses: dict[Camera, _Lens] = {}

    def poses(self) -> np.ndarray:
        """The robots' poses now, one row (x m, y m, angle rad) each: read once for every camera
        of a tick and handed to ``render``, where reading each body per camera made a tick's
        cameras cost O(robots^2) C calls."""
        out = np.empty((len(self._robots), 3))
        for i, (body, _) in enumerate(self._robots):
            p = chipmunk.body_position(body)
            out[i] = p.x, p.y, chipmunk.body_angle(body)
        return out

    def set_block(self, block: int, solid: Solid | None) -> None:
        """Block ``block`` moved, added (a new number) or removed (None)."""
        if solid is None:
            self._blocks.pop(block, None)
        else:
            self._blocks[block] = _shape(solid)
        self._statics = self._walls + list(self._blocks.values())

    def render(self, x_m: float, y_m: float, heading_rad: float, camera: Camera, robot: int = -1,
               poses: np.ndarray | None = None) -> np.ndarray:
        """The camera's image; ``poses`` as ``poses()`` gives them (None: read now)."""
        image = self._ground.render(x_m, y_m, heading_rad, camera)
        lens = self._lenses.get(camera)
        if lens is None:
            lens = self._lenses[camera] = _lens(camera)
        ch, sh = math.cos(heading_rad), math.sin(heading_rad)
        ex, ey = x_m + lens.mount_x_m * ch, y_m + lens.mount_x_m * sh
        eye = (ex, ey, lens.height_m)
        # World offsets to camera coordinates: the robot's heading undone, then the axes.
        g = [(r[0] * ch - r[1] * sh, r[0] * sh + r[1] * ch, r[2]) for r in lens.axes_t]
        reach = lens.reach_m
        seen: list[tuple[_Shape, float, float, float]] = []  # a shape and its pose
        for shape in self._statics:
            solid = shape.solid
            # most solids are out of reach: a cheap test of the distance first
            if _segment_distance((ex, ey), solid.a, solid.b) - solid.radius_m <= reach \
                    and _may_see(lens, g, eye, solid, solid.a, solid.b):
                seen.append((shape, 0.0, 0.0, 0.0))
        if self._robots:
            seen += self._robots_seen(lens, g, eye, robot, self.poses() if poses is None else poses)
        if seen:
            _draw(image, lens, g, eye, seen)
        return image

    def _robots_seen(self, lens: _Lens, g: list[tuple[float, float, float]], eye: tuple[float, float, float],
                     robot: int, poses: np.ndarray) -> list[tuple[_Shape, float, float, float]]:
        """The robots (other than ``robot``) that may be in view, in their order, with their poses.

        In a crowd (more than ``_CROWD`` robots) one numpy test of every robot's distance first
        keeps those within the camera's reach, with a micrometre to spare; in a small fleet
        that test costs more than the scalar tests it saves. Either way the robots kept go
        through the scalar tests the renderer always made (distance, then frustum), so the
        same robots are drawn as when each was tested in turn.
        """
        ex, ey, _ = eye
        reach = lens.reach_m
        if len(self._robots) > _CROWD:
            near = np.hypot(poses[:, 0] - ex, poses[:, 1] - ey) - self._radii <= reach + 1e-6
            candidates = np.flatnonzero(near).tolist()
        else:
            candidates = range(len(self._robots))
        seen = []
        for i in candidates:
            if i == robot:
                continue
            shape = self._robots[i][1]
            x, y, a = poses[i].tolist()
            solid = shape.solid
            if math.hypot(x - ex, y - ey) - solid.radius_m <= reach and _may_see(lens, g, eye, solid, (x, y), (x, y)):
                seen.append((shape, x, y, a))
        return seen


def _may_see(lens: _Lens, g: list[tuple[float, float, float]], eye: tuple[float, float, float], solid: Solid,
             a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether the capsule around a-b (raised to half the solid's height) reaches into the
    frustum: for each plane, the part of a-b not farther out than the radius is cut down
    (Liang-Barsky); nothing left means out of view. Conservative: it may keep a solid whose
    corners all lie outside different planes, which then draws nothing."""
    z = solid.height_m / 2 - eye[2]
    ax, ay, bx, by = a[0] - eye[0], a[1] - eye[1], b[0] - eye[0], b[1] - eye[1]
    qa = [r[0] * ax + r[1] * ay + r[2] * z for r in g]
    qb = [r[0] * bx + r[1] * by + r[2] * z for r in g]
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


Face = tuple[np.ndarray, int, tuple[int, int, int]]  # fixed-point pixel corners, side (-1: top), colour
Plane = tuple[np.ndarray, float]  # in camera coordinates: normal . q = offset on the face


def _faces(shape: _Shape, poses: list[tuple[float, float, float]], g: list[tuple[float, float, float]],
           eye: tuple[float, float, float], lens: _Lens) -> list[tuple[list[Face], Any]]:
    """For each pose (x, y, a) of a prism, the faces the camera looks at, projected, and what
    ``_planes`` needs to give their planes for the depth test.

    Worked in the solid's own frame, where its numbers are fixed: the camera's position there
    decides which sides face it (a side's plane is n . p = n . corner, and the camera is in
    front of it when n . eye > n . corner), and one 2 x 3 matrix takes its corners to camera
    coordinates. A side is shaded by how squarely it faces the camera, a top is its colour.
    All poses at once, as stacked products: numpy computes each slice of a stacked matmul as
    the product of that one pose would be, so a crowd costs a few numpy calls, not a few per robot.
    """
    ex, ey, ez = eye
    solid = shape.solid
    top = ez > solid.height_m
    trig = [(math.cos(a), math.sin(a)) for _, _, a in poses]
    # the camera in each solid's frame
    local = [(c * (ex - x) + s * (ey - y), -s * (ex - x) + c * (ey - y)) for (x, y, _), (c, s) in zip(poses, trig)]
    facing = np.matmul(shape.normals, np.array(local)[:, :, None])[:, :, 0] - shape.offsets  # > 0: faces it
    # q = G (R p + (x, y) - eye, z - ez): the solid's frame to camera coordinates
    m = np.array([[[r[0] * c + r[1] * s, -r[0] * s + r[1] * c, r[0] * (x - ex) + r[1] * (y - ey) - r[2] * ez]
                   for r in g] for (x, y, _), (c, s) in zip(poses, trig)])
    base = np.matmul(shape.corners, m[:, :, :2].transpose(0, 2, 1)) + m[:, None, :, 2]
    corners = np.concatenate((base, base + np.array([r[2] * solid.height_m for r in g])), axis=1)
    z = corners[:, :, 2:]
    with np.errstate(divide="ignore", invalid="ignore"):  # a solid with a corner behind the camera is not used
        # column f x / z + c0, row r0 - f y / z: r0 + -(f y / z) is the same number
        pts = lens.f * corners[:, :, :2] / z * _FLIP + (lens.c0, lens.r0)
        fixed = np.rint(pts * _ONE).astype(np.int32)
    # all in front of the camera and within the picture's margin: its corners projected once
    inside = ((z.min(axis=(1, 2)) >= NEAR_M) & (pts.min(axis=(1, 2)) >= -2)
              & (pts.max(axis=1) <= (lens.width_px + 1, lens.height_px + 1)).all(axis=1)).tolist()
    n = len(shape.corners)
    first_x, first_y = shape.corners[0]
    lengths = shape.lengths.tolist()
    out: list[tuple[list[Face], Any]] = []
    for i, ((c, s), (eye_x, eye_y), row) in enumerate(zip(trig, local, facing.tolist())):
        ks = [k for k, f in enumerate(row) if f > 0]
        if not ks and not top:
            out.append(([], None))
            continue
        distance = math.hypot(eye_x - first_x, eye_y - first_y) + 1e-12
        rgbs = []
        for k in ks:  # the same float operations numpy made, and rint's rounding half to even
            shade = 0.6 + 0.3 * min(1.0, row[k] / (lengths[k] * distance))
            rgbs.append((round(shade * solid.rgb[0]), round(shade * solid.rgb[1]), round(shade * solid.rgb[2])))
        if inside[i]:
            faces: list[Face] = list(zip(fixed[i][shape.quads[ks]], ks, rgbs))
            if top:
                faces.append((fixed[i][n:], -1, solid.rgb))
        else:
            faces = _clipped_faces(shape, corners[i], ks, rgbs, top, lens)
        out.append((faces, (ks, facing[i], c, s, top)))
    return out


def _clipped_faces(shape: _Shape, corners: np.ndarray, ks: list[int], rgbs: list[tuple[int, int, int]],
                   top: bool, lens: _Lens) -> list[Face]:
    """A solid near the camera or across the picture's edge: its faces clipped one by one."""
    n = len(shape.corners)
    faces = []
    for k, rgb in [*zip(ks, rgbs), (-1, shape.solid.rgb)]:
        if k < 0 and not top:
            continue
        projected = project_face(corners[shape.quads[k]] if k >= 0 else corners[n:], lens.f, lens.c0, lens.r0,
                                 lens.width_px, lens.height_px, NEAR_M, _ONE)
        if projected is not None:
            faces.append((projected, k, rgb))
    return faces


def _planes(faces: list[Face], later: Any, shape: _Shape, g: list[tuple[float, float, float]],
            eye: tuple[float, float, float]) -> list[Plane]:
    """Each face's plane in camera coordinates, normal . q = offset (see ``_faces``)."""
    _, facing, c, s, _ = later
    out: list[Plane] = []
    for _, k, _ in faces:
        if k < 0:
            out.append((np.array([r[2] for r in g]), shape.solid.height_m - eye[2]))
        else:
            out.append((_side_normal(g, shape.normals[k], c, s), -float(facing[k])))
    return out


def _side_normal(g: list[tuple[float, float, float]], normal: np.ndarray, c: float, s: float) -> np.ndarray:
    """A side's normal (solid frame) in camera coordinates: turned by the solid's angle, then G."""
    nx, ny = c * float(normal[0]) - s * float(normal[1]), s * float(normal[0]) + c * float(normal[1])
    return np.array([r[0] * nx + r[1] * ny for r in g])


def _draw(image: np.ndarray, lens: _Lens, g: list[tuple[float, float, float]], eye: tuple[float, float, float],
          seen: list[tuple[_Shape, float, float, float]]) -> None:
    """Fill the visible faces of the solids seen; through a depth buffer when two may overlap."""
    solids = []  # per solid: its faces, its shape and what gives their planes, and its pixel box
    together: dict[int, list[int]] = {}  # robots of one model share their shape: drawn at once
    for j, (shape, *_) in enumerate(seen):
        together.setdefault(id(shape), []).append(j)
    made: list[tuple[list[Face], Any]] = [([], None)] * len(seen)
    for js in together.values():
        for j, done in zip(js, _faces(seen[js[0]][0], [seen[j][1:] for j in js], g, eye, lens)):
            made[j] = done
    for (shape, *_), (faces, later) in zip(seen, made):
        if faces:
            every = np.concatenate([f[0] for f in faces])
            low, high = every.min(axis=0), every.max(axis=0)
            solids.append((faces, shape, later, (int(low[0]), int(low[1]), int(high[0]), int(high[1]))))
    if not solids:
        return
    if len(solids) == 1 or not _overlap([box for *_, box in solids]):
        for faces, *_ in solids:
            for pts, _, rgb in faces:
                cv2.fillConvexPoly(image, pts, rgb, cv2.LINE_8, _SHIFT)
        return
    depth = np.zeros(image.shape[:2])  # inverse depth, 1/m: 0 is the floor and sky, farthest
    for faces, shape, later, box in solids:
        planes = _planes(faces, later, shape, g, eye)
        _merge_nearer(image, depth, lens, [(pts, normal, offset, rgb) for (pts, _, rgb), (normal, offset)
                                           in zip(faces, planes)], box)


def _overlap(boxes: list[tuple[int, int, int, int]]) -> bool:
    return any(a[0] <= b[2] and b[0] <= a[2] and a[1] <= b[3] and b[1] <= a[3]
               for k, a in enumerate(boxes) for b in boxes[k + 1:])


def _merge_nearer(image: np.ndarray, depth: np.ndarray, lens: _Lens,
                  faces: list[tuple[np.ndarray, np.ndarray, float, tuple[int, int, int]]],
                  box: tuple[int, int, int, int]) -> None:
    """Draw a solid where it is nearer than what is drawn there.

    Its faces are filled in the same order as when it is drawn alone, each face's number into
    a small buffer, so it looks the same as alone (a pixel on the edge of two faces goes to the
    later). Each pixel's depth is then that of its face: on a plane normal . q = offset, the
    point seen through pixel (c, r) is at depth d along the axis with q = d (xn, yn, 1),
    xn = (c - c0) / f, yn = (r0 - r) / f; so 1 / d = (normal . (xn, yn, 1)) / offset, affine
    in c and r.
    """
    h, w = depth.shape
    left, top = max(0, int(box[0]) >> _SHIFT), max(0, int(box[1]) >> _SHIFT)
    right, bottom = min(w, (int(box[2]) >> _SHIFT) + 2), min(h, (int(box[3]) >> _SHIFT) + 2)
    if left >= right or top >= bottom:
        return
    which = np.zeros((bottom - top, right - left), np.uint8)
    corner = np.array([left << _SHIFT, top << _SHIFT], np.int32)
    for k, (pts, _, _, _) in enumerate(faces):
        cv2.fillConvexPoly(which, pts - corner, k + 1, cv2.LINE_8, _SHIFT)
    cols, rows = np.arange(left, right, dtype=float), np.arange(top, bottom, dtype=float)[:, None]
    f = lens.f
    region, picture = depth[top:bottom, left:right], image[top:bottom, left:right]
    for k, (_, normal, offset, rgb) in enumerate(faces):
        nx, ny, nz = float(normal[0]), float(normal[1]), float(normal[2])
        inverse = (nx / (f * offset)) * cols + ((-ny / (f * offset)) * rows
                                                + (nz - nx * lens.c0 / f + ny * lens.r0 / f) / offset)
        nearer = (which == k + 1) & (inverse > region)
        region[nearer] = inverse[nearer]
        picture[nearer] = rgb


def scene_view(ground: GroundView, world: World, robots: Sequence[tuple[Any, RobotModel]] = ()) -> SceneView:
    """The SceneView of a world's walls and blocks and of robots (pymunk body, model)."""
    return SceneView(ground, [wall_solid(w) for w in world.walls],
                     [(body, robot_solid(model)) for body, model in robots], [block_solid(b) for b in world.blocks])


class PosedScene:
    """A world seen by a camera with its robots where a caller puts them, with no simulation:
    ``labsim plot --camera`` re-renders a robot's frames from a trace's poses this way, through
    the same ``SceneView`` a run's cameras use, so a frame shows what the robot saw then.

    ``render(x_m, y_m, heading_rad, camera, robot, poses)``: ``poses`` holds each robot's
    (x, y, heading) or None (not in the picture), in the order of ``models``; ``robot`` is the
    index of the robot the camera is on, which it does not see.
    """

    def __init__(self, ground: GroundView, world: World | None, models: Sequence[RobotModel]) -> None:
        # bodies outside any space: the view reads only their poses, which render() sets
        self._bodies = [pymunk.Body(body_type=pymunk.Body.KINEMATIC) for _ in models]
        statics = [] if world is None else [wall_solid(w) for w in world.walls] + [block_solid(b) for b in world.blocks]
        self._view = SceneView(ground, statics, [(b, robot_solid(m)) for b, m in zip(self._bodies, models)])

    def render(self, x_m: float, y_m: float, heading_rad: float, camera: Camera, robot: int,
               poses: Sequence[tuple[float, float, float] | None]) -> np.ndarray:
        for body, pose in zip(self._bodies, poses):
            # a robot with no pose then stands far beyond any camera's reach
            body.position = (pose[0], pose[1]) if pose is not None else (_NOWHERE_M, _NOWHERE_M)
            body.angle = pose[2] if pose is not None else 0.0
        return self._view.render(x_m, y_m, heading_rad, camera, robot)


def posed_scene(ground: Ground, world: World | None, models: Sequence[RobotModel]) -> PosedScene:
    """The PosedScene of a world (None: the ground alone) and these robots' models."""
    return PosedScene(ground_view(ground), world, models)


_NOWHERE_M = 1e9
