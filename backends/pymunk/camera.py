"""Camera images for the pymunk backend: the world's ground seen through a pinhole camera.

This module draws the floor; ``labsim.backends.pymunk.scene_view`` then draws what stands on
it (walls, blocks, other robots) over each frame. When a world loads, its
``Ground`` (``labsim.backends.scene.ground``: floor colour, roads, lines, patches) is drawn once into
a top-down texture at ``Ground.px_per_m``. A frame is then one ``cv2.warpPerspective`` of that
texture: for a pinhole camera above a plane, image pixels and floor points are related by a
homography, which this module builds in closed form from the robot's pose and the camera's
mount. Everything the texture does not cover is floor colour (the warp's border). A drawn
texture is kept in labsim's cache folder (``labsim.foundation.cache``), so that opening the
same world again reads it rather than drawing it.

What the image shows, and what it does not:

* RGB, ``height_px`` x ``width_px``, column 0 the left, and row 0 the BOTTOM of the picture (the
  near edge of the floor): CoppeliaSim's row order, the array ``sim.getVisionSensorImg`` hands a
  script (docs/decisions.md §9). Whatever shows a
  frame to a person flips it upright (``upright``).
* Only the ground: walls, blocks and robots are drawn over it by ``scene_view``.
* Above the floor's horizon (and beyond ``FAR_M`` of floor) the image shows ``SKY_RGB``, a
  light gray: a camera may look straight ahead. Only the rows that see floor are warped; with
  rows bottom first the sky is the image's last rows.
* Bilinear sampling, no mipmapping: detail finer than a camera pixel aliases in the far rows.

``GroundView.render`` is called by ``SceneView.render``, from the backend's generated
``sense()``, for each camera channel a behaviour reads; a 128 x 128 frame costs about 50 us
on the road loop, most of it the warp (``benchmarks/bench_road.py`` measures the whole tick).
"""
from __future__ import annotations

import functools
import hashlib
import io
import itertools
import math
import zipfile
from pathlib import Path

import cv2
import numpy as np

from labsim.backends.scene.ground import Ground
from labsim.backends.scene.models import Camera
from labsim.foundation.cache import cache_dir, write_atomically
from labsim.foundation.threads import limit_cv2_threads

_SHIFT = 4  # fixed-point bits for OpenCV drawing: sub-pixel accurate edges
_ONE = 1 << _SHIFT
FAR_M = 30.0  # floor farther than this is drawn as sky: at a few pixels a metre it is noise
SKY_RGB = (225, 228, 232)  # light, so that a threshold for a dark road reads it as not-road
limit_cv2_threads(cv2)  # one thread per run unless LABSIM_THREADS says otherwise (foundation/threads.py)


def check_camera(camera: Camera) -> None:
    """Raise ValueError, saying what is wrong, if this camera cannot be rendered."""
    name = f"camera '{camera.name}'"
    for what, v in (("width_px", camera.width_px), ("height_px", camera.height_px)):
        if not isinstance(v, int) or isinstance(v, bool) or not 1 <= v <= 4096:
            raise ValueError(f"{name}: {what} must be a whole number from 1 to 4096, not {v!r}")
    for what, number in (("fov_deg", camera.fov_deg), ("height_m", camera.height_m),
                         ("pitch_deg", camera.pitch_deg), ("x_m", camera.x_m),
                         ("roll_deg", camera.roll_deg)):
        if not isinstance(number, (int, float)) or not math.isfinite(number):
            raise ValueError(f"{name}: {what} must be a finite number, not {number!r}")
    if not 0 < camera.fov_deg < 180:
        raise ValueError(f"{name}: fov_deg must be between 0 and 180, not {camera.fov_deg}")
    if camera.height_m <= 0:
        raise ValueError(f"{name}: height_m must be above the floor (> 0), not {camera.height_m}")
    if not 0 <= camera.pitch_deg <= 90:
        raise ValueError(f"{name}: pitch_deg must be 0 (straight ahead) to 90 (straight down), "
                         f"not {camera.pitch_deg}")


def draw_ground(ground: Ground) -> tuple[np.ndarray, float, float]:
    """The ground as a top-down RGB texture, and the world (xmin, ymax) of its top-left corner.

    Texture pixel (row i, column j) covers x in xmin + [j, j + 1] / px_per_m and y in
    ymax - [i + 1, i] / px_per_m: north up, as a map. Shapes are antialiased from their exact
    geometry (each pixel's coverage from its centre's distance to the shape's edge), so a
    road is as wide as it says to a fraction of a pixel: OpenCV's antialiased fills and thick
    lines come out 1 to 2 pixels (1-2 cm at 100 px/m) wider than asked.
    """
    ppm = float(ground.px_per_m)
    if not (math.isfinite(ppm) and ppm > 0):
        raise ValueError(f"ground px_per_m must be positive, not {ground.px_per_m!r}")
    if ground.texture is not None:  # a picture of the ground: decoded, not drawn
        bgr = cv2.imdecode(np.frombuffer(ground.texture.png, np.uint8), cv2.IMREAD_COLOR)
        if bgr is None:
            raise ValueError("the ground's texture is not an image")
        picture = cv2.cvtColor(bgr, cv2.COLOR_BGR2RGB)
        picture.flags.writeable = False
        return picture, ground.texture.xmin, ground.texture.ymax
    floor = _colour(ground.floor_rgb)
    box = ground.texture_box()
    if box is None:  # a bare floor: the warp's border colour does all the work
        return np.full((2, 2, 3), floor, np.uint8), 0.0, 0.0
    problem = ground.texture_problem()
    if problem:
        raise ValueError(problem)
    xmin, ymin, xmax, ymax, w, h = box
    img = np.full((h, w, 3), floor, np.uint8)

    def px(points: object) -> np.ndarray:
        """World points to texture coordinates: pixel (i, j) spans [j, j + 1] x [i, i + 1]."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        return np.column_stack(((p[:, 0] - xmin) * ppm, (ymax - p[:, 1]) * ppm))

    for patch in ground.patches:
        _paint_polygon(img, px(patch.corners), patch.rgb)
    for road in ground.roads:
        pts = px(road.points)
        if road.closed:
            pts = np.vstack((pts, pts[:1]))
        _paint_band(img, pts, road.width_m * ppm / 2, road.rgb)
    for line in ground.lines:
        (ax, ay), (bx, by) = line.a, line.b
        n = math.hypot(bx - ax, by - ay)
        if n == 0:
            continue
        nx, ny = -(by - ay) / n * line.width_m / 2, (bx - ax) / n * line.width_m / 2
        band = [(ax + nx, ay + ny), (bx + nx, by + ny), (bx - nx, by - ny), (ax - nx, ay - ny)]
        _paint_polygon(img, px(band), line.rgb)
    img.flags.writeable = False  # shared by every backend that opens this ground
    return img, xmin, ymax


def luminance(r: float, g: float, b: float) -> float:
    """A colour's brightness, 0 (black) to 1 (white): ITU-R BT.601 luma, as a ground sensor reads."""
    return (0.299 * r + 0.587 * g + 0.114 * b) / 255.0


def _colour(rgb: tuple[int, int, int]) -> tuple[int, int, int]:
    return (int(rgb[0]), int(rgb[1]), int(rgb[2]))


def _blend(img: np.ndarray, top: int, left: int, cover: np.ndarray, rgb: tuple[int, int, int]) -> None:
    """Paint rgb over img[top:, left:] with per-pixel coverage 0..1."""
    h, w = cover.shape
    region = img[top:top + h, left:left + w]
    touched = cover > 0  # a road's bounding box is mostly floor: blend only what it covers
    c = cover[touched][:, None]
    region[touched] = np.rint(region[touched] * (1.0 - c) + np.asarray(rgb, float) * c).astype(np.uint8)


def _window(img: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[int, int, int, int] | None:
    """Rows and columns (top, bottom, left, right) of img that the box [lo, hi] (u, v) touches."""
    left, top = max(0, math.floor(lo[0])), max(0, math.floor(lo[1]))
    right, bottom = min(img.shape[1], math.ceil(hi[0])), min(img.shape[0], math.ceil(hi[1]))
    return None if left >= right or top >= bottom else (top, bottom, left, right)


def _paint_band(img: np.ndarray, pts: np.ndarray, half_px: float, rgb: tuple[int, int, int]) -> None:
    """Everything within half_px of the polyline pts (texture coordinates): a road.

    Round ends and joints, as the set of points near a polyline is. The coverage of the whole
    band is gathered first (the largest over its segments), then painted once, so where
    segments overlap nothing is painted twice.
    """
    pad = half_px + 1.0
    box = _window(img, pts.min(axis=0) - pad, pts.max(axis=0) + pad)
    if box is None:
        return
    top, bottom, left, right = box
    cover = np.zeros((bottom - top, right - left), np.float32)
    for (au, av), (bu, bv) in itertools.pairwise(pts):
        # Long segments in short pieces, so each works on a small window even when diagonal.
        pieces = max(1, math.ceil(math.hypot(bu - au, bv - av) / 64.0))
        for k in range(pieces):
            pu, pv = au + (bu - au) * k / pieces, av + (bv - av) * k / pieces
            qu, qv = au + (bu - au) * (k + 1) / pieces, av + (bv - av) * (k + 1) / pieces
            win = _window(img, np.array([min(pu, qu), min(pv, qv)]) - pad,
                          np.array([max(pu, qu), max(pv, qv)]) + pad)
            if win is None:
                continue
            t0, b0, l0, r0 = win
            u = np.arange(l0, r0) + 0.5 - pu  # pixel centres relative to the piece's start
            v = (np.arange(t0, b0) + 0.5 - pv)[:, None]
            du, dv = qu - pu, qv - pv
            n2 = du * du + dv * dv
            t = np.clip((u * du + v * dv) / n2, 0.0, 1.0) if n2 > 0 else np.zeros((1, 1))
            dist = np.hypot(u - t * du, v - t * dv)
            sub = cover[t0 - top:b0 - top, l0 - left:r0 - left]
            np.maximum(sub, np.clip(half_px + 0.5 - dist, 0.0, 1.0), out=sub)
    _blend(img, top, left, cover, rgb)


def _paint_polygon(img: np.ndarray, pts: np.ndarray, rgb: tuple[int, int, int]) -> None:
    """A filled polygon (texture coordinates): a patch, or a line's band.

    A convex polygon's coverage comes from the distance of each pixel centre inside its
    nearest edge; a polygon that is not convex falls back to OpenCV's antialiased fill.
    """
    n = len(pts)
    u, v = pts[:, 0], pts[:, 1]
    area2 = float(np.dot(u, np.roll(v, -1)) - np.dot(np.roll(u, -1), v))
    if n < 3 or abs(area2) < 1e-12:
        return
    d = np.roll(pts, -1, axis=0) - pts
    turns = d[:, 0] * np.roll(d, -1, axis=0)[:, 1] - d[:, 1] * np.roll(d, -1, axis=0)[:, 0]
    if not (np.all(turns >= -1e-9) or np.all(turns <= 1e-9)):
        shifted = np.round((pts - 0.5) * _ONE).astype(np.int32)  # OpenCV's pixel centres are integers
        cv2.fillPoly(img, [shifted], _colour(rgb), cv2.LINE_AA, _SHIFT)
        return
    box = _window(img, pts.min(axis=0) - 1.0, pts.max(axis=0) + 1.0)
    if box is None:
        return
    top, bottom, left, right = box
    cu = np.arange(left, right) + 0.5
    cv = (np.arange(top, bottom) + 0.5)[:, None]
    sign = 1.0 if area2 > 0 else -1.0  # inside is to the left of each edge when area2 > 0
    inside = np.full((bottom - top, right - left), np.inf)
    for (au, av), (du, dv) in zip(pts, d):
        length = math.hypot(du, dv)
        if length == 0:
            continue
        np.minimum(inside, sign * (du * (cv - av) - dv * (cu - au)) / length, out=inside)
    _blend(img, top, left, np.clip(inside + 0.5, 0.0, 1.0), rgb)


def camera_axes(camera: Camera) -> tuple[np.ndarray, float]:
    """The camera's axes in a frame turned with the robot (x forward, y left, z up), as the
    columns of a 3x3 matrix (the picture's right, its downwards, the viewing direction), and
    its focal length in pixels.

    Pixel (c, r) -> the ray's direction, for a robot heading along +x:
      d = forward + xn * right + yn * down, xn = (c + 0.5 - w/2) / f, yn = (h/2 - r - 0.5) / f
    (pixel centres; rows count from the bottom, so yn, the picture's downwards, shrinks as r
    grows: the flip to CoppeliaSim's row order is folded in here and costs nothing per frame),
    with forward = (cp, 0, -sp), right = (0, -1, 0), down = -up, up = (sp, 0, cp). A roll turns
    right and up about forward: right' = cr right - sr up, up' = cr up + sr right. The axes are
    orthonormal, so their transpose takes a direction back to (xn, yn, 1) times its depth.
    """
    w = camera.width_px
    f = (w / 2) / math.tan(math.radians(camera.fov_deg) / 2)  # focal length, pixels
    p = math.radians(camera.pitch_deg)
    cp, sp = math.cos(p), math.sin(p)
    right, up = np.array([0.0, -1.0, 0.0]), np.array([sp, 0.0, cp])
    roll = math.radians(camera.roll_deg)
    cr, sr = math.cos(roll), math.sin(roll)
    return np.column_stack((cr * right - sr * up, -(cr * up + sr * right), (cp, 0.0, -sp))), f


class GroundView:
    """A ground drawn once, and cameras rendered from it.

    ``render(x_m, y_m, heading_rad, camera)`` gives the camera's image for a robot at that
    pose: a new ``height_px x width_px x 3`` uint8 RGB array per call, row 0 the bottom of the
    picture (CoppeliaSim's order), column 0 the left. Build one with ``ground_view(ground)``,
    which shares textures.
    """

    def __init__(self, ground: Ground):
        self.ground = ground
        rgb, self._xmin, self._ymax = _drawn(ground)
        # The warp reads a 4-channel texture: OpenCV's vectorised path for 4 channels makes a
        # 128 x 128 frame about twice as fast as 3 channels do, and dropping the unused 4th
        # channel afterwards costs a couple of microseconds.
        self._rgba = cv2.cvtColor(rgb, cv2.COLOR_RGB2RGBA)
        self._rgba.flags.writeable = False
        self._border = (*(float(c) for c in ground.floor_rgb), 255.0)
        self._ppm = float(ground.px_per_m)
        self._cameras: dict[Camera, tuple] = {}
        self._floor_luminance = luminance(*ground.floor_rgb)

    def _plan(self, camera: Camera) -> tuple:
        """What a camera's homography needs that does not depend on the pose."""
        check_camera(camera)
        w, h = camera.width_px, camera.height_px
        axes, f = camera_axes(camera)
        p = math.radians(camera.pitch_deg)
        cp, sp = math.cos(p), math.sin(p)
        # As a matrix applied to pixel (c, r, 1): the ray's direction (see camera_axes).
        k_inv = np.array([[1 / f, 0, (0.5 - w / 2) / f], [0, -1 / f, (h / 2 - 0.5) / f], [0, 0, 1]])
        if camera.roll_deg:
            return self._plan_rolled(camera, axes @ k_inv)
        # The rows that see floor nearer than FAR_M come first (from the bottom); the rows above
        # them are sky. The ray through row r (at the centre column) falls dz = -(sp + yn cp)
        # per unit and goes forward (cp - yn sp); it meets the floor at horizontal distance
        # h * forward / -dz.
        floor = 0
        for r in range(h):
            yn = (h / 2 - r - 0.5) / f
            dz = -(sp + yn * cp)
            if not (dz < 0 and camera.height_m * (cp - yn * sp) / -dz <= FAR_M):
                break
            floor = r + 1
        # Warping only the floor rows, 0 to floor - 1: the sky fills the rest.
        plan = (axes @ k_inv, (w, floor), float(camera.x_m), float(camera.height_m), floor, None,
                _sky_block(h - floor, w))
        self._cameras[camera] = plan
        return plan

    def _plan_rolled(self, camera: Camera, b: np.ndarray) -> tuple:
        """A rolled camera's plan: its horizon is not a row, so every pixel whose ray misses
        the floor nearer than FAR_M is masked to sky after the warp of the whole image."""
        w, h = camera.width_px, camera.height_px
        c, r = np.meshgrid(np.arange(w, dtype=float), np.arange(h, dtype=float))
        d = np.einsum("ij,jrc->irc", b, np.stack((c, r, np.ones_like(c))))
        falls = d[2] < 0
        reach = camera.height_m * np.hypot(d[0], d[1]) / np.where(falls, -d[2], 1.0)
        sky = ~(falls & (reach <= FAR_M))
        plan = (b, (w, h), float(camera.x_m), float(camera.height_m), h, sky if sky.any() else None, None)
        self._cameras[camera] = plan
        return plan

    def _homography(self, plan: tuple, x_m: float, y_m: float, heading_rad: float) -> np.ndarray:
        """The 3x3 map from image pixels (column, row, 1) to texture pixels (column, row, 1)."""
        b, _, mount_x, height, _, _, _ = plan
        ch, sh = math.cos(heading_rad), math.sin(heading_rad)
        cx, cy = x_m + mount_x * ch, y_m + mount_x * sh  # the camera's centre over the floor
        ppm = self._ppm
        # Composed in closed form: texture <- floor (scale, flip y) <- ray (where it meets
        # z = 0 from height h: point = C + h d / -d_z) <- heading rotation <- b (see _plan).
        # In homogeneous floor coordinates the hit point is (h dx - Cx dz, h dy - Cy dz, -dz).
        k = ppm * height
        e0 = -(ppm * (cx - self._xmin) - 0.5)
        e1 = ppm * (self._ymax - cy) - 0.5
        front = np.array([[k * ch, -k * sh, e0], [-k * sh, -k * ch, -e1], [0.0, 0.0, -1.0]])
        return front @ b

    def render(self, x_m: float, y_m: float, heading_rad: float, camera: Camera) -> np.ndarray:
        """The camera's RGB image for a robot at (x_m, y_m) heading heading_rad."""
        plan = self._cameras.get(camera) or self._plan(camera)
        floor = plan[4]  # how many rows, from the bottom, see floor
        if not floor:  # looking up at the sky
            return plan[6].copy()
        rgba = cv2.warpPerspective(
            self._rgba, self._homography(plan, x_m, y_m, heading_rad), plan[1],
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_CONSTANT, borderValue=self._border,
        )
        seen = cv2.cvtColor(rgba, cv2.COLOR_RGBA2RGB)
        if plan[5] is not None:  # a rolled camera that sees the horizon
            seen[plan[5]] = SKY_RGB
        if floor == camera.height_px:
            return seen
        image = np.empty((camera.height_px, camera.width_px, 3), np.uint8)
        image[:floor] = seen
        image[floor:] = plan[6]  # a block copy: broadcasting SKY_RGB costs 4 times as much
        return image

    def reflectance(self, x_m: float, y_m: float) -> float:
        """A ground sensor's reading at a world point: the luminance of the texture pixel under
        it, 0 (black) to 1 (white); the floor's beyond the texture (see ``models.GroundSensor``)."""
        i, j = math.floor((self._ymax - y_m) * self._ppm), math.floor((x_m - self._xmin) * self._ppm)
        rows, cols = self._rgba.shape[:2]
        if 0 <= i < rows and 0 <= j < cols:
            r, g, b, _ = self._rgba[i, j].tolist()
            return luminance(r, g, b)
        return self._floor_luminance

    @property
    def texture(self) -> np.ndarray:
        """The drawn ground, RGB, north up (a read-only view)."""
        return self._rgba[..., :3]


def _drawn(ground: Ground) -> tuple[np.ndarray, float, float]:
    """``draw_ground(ground)``, from labsim's cache folder when it was drawn before.

    Drawing the road loop's 734 segments takes about a quarter of a second, as long as the
    lab's whole run, and gives the same texture every time. The cache entry is named by a
    hash of the ground's description, this module's source and the numpy and OpenCV
    versions, so a changed ground or drawing code never reads a stale texture. A picture
    of the ground is only decoded, which is quick: it is not cached.
    """
    folder = cache_dir() if ground.texture is None else None
    if folder is None:
        return draw_ground(ground)
    try:
        source = Path(__file__).read_bytes()
    except OSError:  # installed without its sources: nothing to name the drawing code by
        return draw_ground(ground)
    key = hashlib.sha256(source)
    for part in (repr(ground), np.__version__, cv2.__version__):
        key.update(b"\0" + part.encode("utf-8"))
    path = folder / f"ground-{key.hexdigest()[:32]}.npz"
    try:
        with np.load(path, allow_pickle=False) as saved:
            img, origin = saved["img"], saved["origin"]
        if img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3 and origin.shape == (2,):
            img.flags.writeable = False
            return img, float(origin[0]), float(origin[1])
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        pass  # not there, or not whole: draw it
    img, xmin, ymax = draw_ground(ground)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, img=img, origin=np.array([xmin, ymax]))  # mostly floor: 20 MB -> 0.1 MB
    write_atomically(path, buffer.getvalue())
    return img, xmin, ymax


def _sky_block(rows: int, width: int) -> np.ndarray:
    """The rows above a camera's horizon (the image's last rows), made once per camera and
    copied into each frame."""
    block = np.empty((rows, width, 3), np.uint8)
    block[:] = SKY_RGB
    block.flags.writeable = False
    return block


@functools.lru_cache(maxsize=4)
def ground_view(ground: Ground) -> GroundView:
    """The GroundView of a ground, drawn once and shared: re-opening a world redraws nothing."""
    return GroundView(ground)
