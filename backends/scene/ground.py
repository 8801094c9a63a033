"""What a camera sees on the floor: roads, painted lines and patches, as plain data and geometry.

A world file's ``ground:`` section (``labsim.backends.scene.world_file`` reads it) becomes a frozen ``Ground``
stored in ``World.ground``. Backends draw it (the pymunk backend's camera renders it from a
texture, ``labsim.backends.pymunk.camera``), ``labsim plot`` draws it under the trajectories,
and ``RoadTracker`` measures a robot against a road: its signed lateral offset from the
centreline, its arc-length position along it, and the laps it has driven. ``world_channels``
names the channels a world with a road offers every robot, for the checker and the backends.

Nothing here imports a simulator or OpenCV. Frames and units as everywhere in labsim: x east,
y north, metres, angles counter-clockwise; colours are RGB 0..255.
"""
from __future__ import annotations

import math
from collections.abc import Hashable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from labsim.backends.scene.models import Kind

if TYPE_CHECKING:  # numpy only where a road is measured: `labsim check` reads grounds without it
    import numpy as np

RGB = tuple[int, int, int]
Point = tuple[float, float]

DEFAULT_FLOOR_RGB: RGB = (205, 205, 200)  # a light floor; also what a camera sees in a world without ground
DEFAULT_ROAD_RGB: RGB = (25, 25, 25)
DEFAULT_PX_PER_M = 100.0  # texture resolution: 1 cm per texture pixel
TEXTURE_MARGIN_M = 0.25  # texture beyond the painted extent, so antialiased edges are not cut
MAX_TEXTURE_SIDE_PX = 32_000  # OpenCV's warps address the source with 16-bit coordinates
MAX_TEXTURE_PX = 64_000_000  # 192 MB of RGB; beyond this, a lower px_per_m is the answer


@dataclass(frozen=True)
class Road:
    """A road of constant width along a centreline polyline.

    ``points`` (metres, at least two) are the centreline in the road's direction of travel:
    offsets are positive to the left of that direction, and laps count in it. A closed road
    joins its last point back to its first (a last point equal to the first is allowed and
    adds nothing). Arcs in world files arrive here as many short chords (within 0.5 mm of
    the circle).
    """

    points: tuple[Point, ...]
    closed: bool
    width_m: float
    rgb: RGB = DEFAULT_ROAD_RGB


@dataclass(frozen=True)
class Line:
    """A painted straight line from a to b, width_m wide; its ends are cut square at a and b."""

    a: Point
    b: Point
    width_m: float
    rgb: RGB


@dataclass(frozen=True)
class Patch:
    """A painted polygon on the floor, corners in order, world frame."""

    corners: tuple[Point, ...]
    rgb: RGB


@dataclass(frozen=True)
class Texture:
    """The ground as a picture only: a PNG (north up) whose top-left corner is at (xmin, ymax),
    at the ground's ``px_per_m``. What a simulator given a textured floor renders from
    (``labsim serve --empty``), in place of the roads, lines and patches it was drawn from."""

    png: bytes
    xmin: float
    ymax: float


@dataclass(frozen=True)
class Ground:
    """The floor's colour and what is painted on it.

    Drawn in this order, each kind in file order: patches, then roads, then lines (so a
    start line crosses a road, and a road crosses a patch). ``px_per_m`` is the resolution of
    the texture a backend may draw this into.
    """

    floor_rgb: RGB = DEFAULT_FLOOR_RGB
    roads: tuple[Road, ...] = ()
    lines: tuple[Line, ...] = ()
    patches: tuple[Patch, ...] = ()
    px_per_m: float = DEFAULT_PX_PER_M
    texture: Texture | None = None  # drawn already: cameras render this picture

    def extent(self) -> tuple[float, float, float, float] | None:
        """xmin, ymin, xmax, ymax (metres) of everything painted, widths included; None if bare."""
        xs: list[float] = []
        ys: list[float] = []
        for r in self.roads:
            h = r.width_m / 2
            xs += [min(p[0] for p in r.points) - h, max(p[0] for p in r.points) + h]
            ys += [min(p[1] for p in r.points) - h, max(p[1] for p in r.points) + h]
        for ln in self.lines:
            h = ln.width_m / 2  # square ends: no corner lies further out than this
            xs += [min(ln.a[0], ln.b[0]) - h, max(ln.a[0], ln.b[0]) + h]
            ys += [min(ln.a[1], ln.b[1]) - h, max(ln.a[1], ln.b[1]) + h]
        for pa in self.patches:
            xs += [c[0] for c in pa.corners]
            ys += [c[1] for c in pa.corners]
        if not xs:
            return None
        return (min(xs), min(ys), max(xs), max(ys))

    def texture_box(self) -> tuple[float, float, float, float, int, int] | None:
        """xmin, ymin, xmax, ymax (metres, margin included) and width, height (pixels) of the
        top-down texture this ground draws into at ``px_per_m``; None if nothing is painted."""
        ext = self.extent()
        if ext is None:
            return None
        m = TEXTURE_MARGIN_M
        xmin, ymin, xmax, ymax = ext[0] - m, ext[1] - m, ext[2] + m, ext[3] + m
        ppm = float(self.px_per_m)
        return xmin, ymin, xmax, ymax, math.ceil((xmax - xmin) * ppm), math.ceil((ymax - ymin) * ppm)

    def texture_problem(self) -> str | None:
        """Why this ground cannot be drawn as one texture (too large), or None."""
        box = self.texture_box()
        if box is None:
            return None
        xmin, ymin, xmax, ymax, w, h = box
        if max(w, h) <= MAX_TEXTURE_SIDE_PX and w * h <= MAX_TEXTURE_PX:
            return None
        wm, hm = xmax - xmin, ymax - ymin
        fits = min(MAX_TEXTURE_SIDE_PX / max(wm, hm), math.sqrt(MAX_TEXTURE_PX / (wm * hm)))
        return (f"the ground would be a {w} x {h} px texture ({wm:.1f} x {hm:.1f} m at {self.px_per_m:g} "
                f"px/m), more than a camera can render from; use px_per_m: {math.floor(fits * 0.99):g} "
                f"or less")


# --- channels ---------------------------------------------------------------------------------

# What a world with a road offers every robot, measured at the robot's origin (the middle of
# its wheel axle) against the world's FIRST road.
ROAD_CHANNELS: dict[str, Kind] = {
    "road_offset": Kind.NUMBER,  # metres from the centreline, positive = left of the road's direction
    "on_road": Kind.BOOL,  # |road_offset| <= width / 2
    "laps": Kind.NUMBER,  # completed laps since the start (RoadTracker.laps)
}


# --- geometry ---------------------------------------------------------------------------------

_RECENT = 1024  # points RoadTracker remembers: a tick's robots (up to 100 in a group), several times over
_CELL_M = 2.0  # the side of a cell of RoadTracker's index of segments
_MARGIN_M = 2.0  # a cell lists every segment that comes within this of it
_MAX_CELLS = 200_000  # entries of the index at most (a few MB)
_SLACK_M = 1e-6  # far more than the rounding of a computed distance, far less than a segment


def _closest(x: float, y: float, ax: np.ndarray, ay: np.ndarray, dx: np.ndarray, dy: np.ndarray,
             len2: np.ndarray) -> tuple[int, float, float, float]:
    """Over segments a -> a + d (numpy arrays): the first nearest to (x, y), the parameter of
    its nearest point and the vector from that point to (x, y)."""
    px = x - ax
    py = y - ay
    t = (px * dx + py * dy) / len2
    t.clip(0.0, 1.0, out=t)  # the array's methods: numpy's functions add a wrapper call
    qx = px - t * dx  # from the nearest point of each segment to (x, y)
    qy = py - t * dy
    k = int((qx * qx + qy * qy).argmin())
    return k, float(t[k]), float(qx[k]), float(qy[k])


class RoadTracker:
    """Where points are relative to one road, and how many laps each robot has driven on it.

    * ``locate(x, y)`` -> ``(offset_m, s_m)``: the nearest point of the centreline (over all
      its segments, so it is right wherever the robot is; a grid of cells, each listing the
      segments near it, finds it among a few), the signed distance to it
      (positive to the left of the road's direction) and its arc length from the first point.
      At a corner of the polyline the side is judged against the bisector of the two segments'
      directions; past an end of an open road the offset is the distance to that end.
    * Laps, per robot (any hashable key): ``start(robot, x, y)`` marks where it starts,
      ``update(robot, x, y)`` must then be called after every move (each tick) and adds the
      change of ``s`` to the robot's progress. On a closed road the change is taken modulo the
      road's length, the short way round, so crossing the seam between the last point and the
      first is continuous; a robot must therefore move less than half the loop between two
      updates. ``laps(robot)`` is the progress in whole loops, truncated toward zero: 0 until
      one full loop forward (or backward) from the start, then 1 (or -1), and so on; a robot
      that backs up a little from its start has 0 laps, and driving backwards counts down.
      On an open road laps stay 0. Progress follows the nearest centreline point, so a robot
      cutting across off the road is credited with the arc length it skipped.
    """

    def __init__(self, road: Road):
        import numpy as np  # here, not at the top: `labsim check` reads grounds without numpy

        pts = np.asarray(road.points, dtype=float).reshape(-1, 2)
        if len(pts) < 2 or not np.isfinite(pts).all():
            raise ValueError("a road needs at least two finite points")
        starts = pts
        ends = np.roll(pts, -1, axis=0) if road.closed else pts[1:]
        starts = starts[: len(ends)]
        d = ends - starts
        length = np.hypot(d[:, 0], d[:, 1])
        keep = length > 1e-9  # a repeated point (or a closed road's repeated first point) adds nothing
        if not keep.any():
            raise ValueError("a road's points must not all be the same")
        self.road = road
        self.closed = road.closed
        self.half_width_m = road.width_m / 2
        self._ax = starts[keep, 0].copy()
        self._ay = starts[keep, 1].copy()
        self._dx = d[keep, 0].copy()
        self._dy = d[keep, 1].copy()
        self._len = length[keep]
        self._len2 = self._len * self._len
        self._ux = self._dx / self._len
        self._uy = self._dy / self._len
        self._s0 = np.concatenate(([0.0], np.cumsum(self._len)[:-1]))
        self.length_m = float(self._len.sum())
        self._n = len(self._len)
        self._last_s: dict[Hashable, float] = {}
        self._progress: dict[Hashable, float] = {}
        # The points located lately: a fleet's step() locates each robot for its laps, and the
        # next sense() asks for the road offset at the very same point.
        self._recent: dict[tuple[float, float], tuple[float, float]] = {}
        self._cells = self._index()

    def _index(self) -> dict[tuple[int, int], list[tuple[int, float, float, float, float, float]]]:
        """Per grid cell (ix, iy): the segments that come within _MARGIN_M of it, in order, with
        their numbers as plain floats (a loop over a few floats costs less than numpy's calls
        on a few elements, about 2.5 µs each). Each segment is entered in the cells its bounding
        box, grown by the margin, overlaps: a point of the segment within the margin of a cell
        lies in that box, so the cell lists every segment that close to it."""
        import numpy as np  # imported already by __init__

        members: dict[tuple[int, int], list[int]] = {}
        bx, by = self._ax + self._dx, self._ay + self._dy
        low_x, high_x = np.minimum(self._ax, bx) - _MARGIN_M, np.maximum(self._ax, bx) + _MARGIN_M
        low_y, high_y = np.minimum(self._ay, by) - _MARGIN_M, np.maximum(self._ay, by) + _MARGIN_M
        cells = ((np.floor(high_x / _CELL_M) - np.floor(low_x / _CELL_M) + 1)
                 * (np.floor(high_y / _CELL_M) - np.floor(low_y / _CELL_M) + 1)).sum()
        if cells > _MAX_CELLS:  # long diagonal segments would fill too many: every locate scans them all
            return {}
        for k in range(self._n):
            for ix in range(math.floor(low_x[k] / _CELL_M), math.floor(high_x[k] / _CELL_M) + 1):
                for iy in range(math.floor(low_y[k] / _CELL_M), math.floor(high_y[k] / _CELL_M) + 1):
                    members.setdefault((ix, iy), []).append(k)
        numbers = list(zip(range(self._n), self._ax.tolist(), self._ay.tolist(), self._dx.tolist(),
                           self._dy.tolist(), self._len2.tolist()))
        return {cell: [numbers[k] for k in ks] for cell, ks in members.items()}

    def locate(self, x: float, y: float) -> tuple[float, float]:
        """(signed lateral offset in metres, arc length in metres) of the nearest centreline point."""
        key = (x, y)
        found = self._recent.get(key)
        if found is None:
            if len(self._recent) >= _RECENT:
                self._recent.clear()
            found = self._recent[key] = self._locate(x, y)
        return found

    def _nearest(self, x: float, y: float) -> tuple[int, float, float, float]:
        """The nearest segment (the first of equals), the parameter of its nearest point and
        the vector from there to (x, y): from the point's cell of the index when the circle
        through that nearest point lies inside the cell grown by the margin (every segment that
        near is then in the cell's list, which keeps the segments' order, so the first of
        equals is the same), else over every segment. The arithmetic is the same either way."""
        ix, iy = math.floor(x / _CELL_M), math.floor(y / _CELL_M)
        cell = self._cells.get((ix, iy))
        if cell is not None:
            best = math.inf
            k = -1
            tk = ex = ey = 0.0
            for j, ax, ay, dx, dy, len2 in cell:  # as _closest does, operation for operation
                px = x - ax
                py = y - ay
                t = (px * dx + py * dy) / len2
                t = 0.0 if t < 0.0 else 1.0 if t > 1.0 else t
                qx = px - t * dx
                qy = py - t * dy
                d = qx * qx + qy * qy
                if d < best:
                    best, k, tk, ex, ey = d, j, t, qx, qy
            reach = math.hypot(ex, ey) + _SLACK_M
            if (x - reach >= ix * _CELL_M - _MARGIN_M and x + reach <= (ix + 1) * _CELL_M + _MARGIN_M
                    and y - reach >= iy * _CELL_M - _MARGIN_M and y + reach <= (iy + 1) * _CELL_M + _MARGIN_M):
                return k, tk, ex, ey
        return _closest(x, y, self._ax, self._ay, self._dx, self._dy, self._len2)

    def _locate(self, x: float, y: float) -> tuple[float, float]:
        k, tk, ex, ey = self._nearest(x, y)
        ux, uy = float(self._ux[k]), float(self._uy[k])
        # At a corner the nearest point is the vertex; the side is judged against the bisector,
        # as neither segment's own direction says which side of the corner the point is on.
        if tk <= 0.0 and (k > 0 or self.closed):
            j = k - 1
            ux, uy = ux + float(self._ux[j]), uy + float(self._uy[j])
        elif tk >= 1.0 and (k < self._n - 1 or self.closed):
            j = (k + 1) % self._n
            ux, uy = ux + float(self._ux[j]), uy + float(self._uy[j])
        dist = math.hypot(ex, ey)
        side = ux * ey - uy * ex  # z of tangent x (point - nearest): > 0 on the left
        offset = dist if side > 0 else -dist if side < 0 else 0.0
        return offset, float(self._s0[k] + tk * self._len[k])

    def offset(self, x: float, y: float) -> float:
        """Signed lateral offset in metres from the centreline, positive to the left."""
        return self.locate(x, y)[0]

    def on_road(self, x: float, y: float) -> bool:
        return abs(self.locate(x, y)[0]) <= self.half_width_m

    # laps --------------------------------------------------------------------------------------

    def start(self, robot: Hashable, x: float, y: float) -> None:
        """Start counting laps for robot from (x, y); its progress is 0 there."""
        self._last_s[robot] = self.locate(x, y)[1]
        self._progress[robot] = 0.0

    def update(self, robot: Hashable, x: float, y: float) -> int:
        """Record the robot's new position; returns its completed laps."""
        s = self.locate(x, y)[1]
        ds = s - self._last_s[robot]
        if self.closed:
            ds = math.remainder(ds, self.length_m)  # the short way round the seam
        self._last_s[robot] = s
        self._progress[robot] += ds
        return self.laps(robot)

    def progress_m(self, robot: Hashable) -> float:
        """Metres driven along the road since start(), forward positive."""
        return self._progress[robot]

    def laps(self, robot: Hashable) -> int:
        """Completed laps since start(): whole loops of progress, truncated toward zero."""
        if not self.closed:
            return 0
        loops = self._progress[robot] / self.length_m
        # A robot put back exactly on its start after a loop may sum to 0.9999999999 loops.
        return math.trunc(loops + math.copysign(1e-9, loops))
