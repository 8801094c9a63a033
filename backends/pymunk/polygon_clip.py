"""Clipping a convex polygon for the camera's scene renderer: to the near plane, and to a box.

Used by ``labsim.backends.pymunk.scene_view`` on a face that crosses the camera's near plane or
the picture's edge, before it is filled (``project_face``); plain Sutherland-Hodgman, in the renderer's order of
operations, so that a face clipped here gives the same fixed-point corners every time.
"""
from __future__ import annotations

import numpy as np


def project_face(corners: np.ndarray, f: float, c0: float, r0: float, width_px: int, height_px: int,
                 near_m: float, one: int) -> np.ndarray | None:
    """A face's corners (camera coordinates: right, down, forward; ``f`` the focal length and
    ``c0``, ``r0`` the optical axis's column and row, pixels) as fixed-point pixel corners for
    OpenCV (``one`` to a pixel), clipped to the near plane and to a margin around the picture;
    None when nothing of it is left."""
    if corners[:, 2].min() < near_m:
        corners = clip_near(corners, near_m)
        if len(corners) < 3:
            return None
    z = corners[:, 2]
    cols = f * corners[:, 0] / z + c0
    rows = r0 - f * corners[:, 1] / z
    pts = np.column_stack((cols, rows))
    w, h = width_px, height_px
    if pts.min() < -2 or cols.max() > w + 1 or rows.max() > h + 1:
        pts = clip_box(pts, -2.0, -2.0, w + 1.0, h + 1.0)
        if len(pts) < 3:
            return None
    return np.round(pts * one).astype(np.int32)


def clip_near(corners: np.ndarray, near_m: float) -> np.ndarray:
    """Sutherland-Hodgman: the part of a convex polygon (n x 3, the third column depth) at depth
    ``near_m`` or more."""
    out = []
    n = len(corners)
    for k in range(n):
        p, q = corners[k], corners[(k + 1) % n]
        if p[2] >= near_m:
            out.append(p)
        if (p[2] >= near_m) != (q[2] >= near_m):
            out.append(p + (q - p) * ((near_m - p[2]) / (q[2] - p[2])))
    return np.array(out).reshape(-1, 3)


def clip_box(pts: np.ndarray, x0: float, y0: float, x1: float, y1: float) -> np.ndarray:
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
