"""The road panel of ``labsim plot``: each robot's offset from the road's centreline, along the road.

A stage after the run, drawn under the still map of ``labsim.runtime.pictures.plot`` when the world has a
road. On the map of a long road a robot's lateral error is a fraction of a pixel; here it is the
vertical axis. Each robot's trace poses (x, y) are located on the world's first road with
``labsim.backends.scene.ground.RoadTracker``, so the panel needs no ``road_offset`` column: the
horizontal axis is the distance the robot has driven along the road since its start (the seam
of a closed road is crossed smoothly), the vertical one its signed offset, left of the road's
direction positive. The road's edges are drawn at plus and minus half its width. OpenCV only,
in the map's look.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import cv2
import numpy as np

from labsim.backends.scene.ground import RoadTracker
from labsim.backends.scene.world import World, first_road
from labsim.runtime.pictures.map_frame import nice_step
from labsim.runtime.pictures.paint import AA, FRAME, GRID, INK, MAP_BG, MUTED, ONE, SHIFT, Painter, bgr, darker

MAX_POINTS = 2000  # per robot: more poses than pixels across adds nothing but time


@dataclass
class RoadCurve:
    """One robot against the road: distance driven along it and offset from its centreline (m)."""

    name: str
    colour: tuple[int, int, int]
    along_m: np.ndarray
    offset_m: np.ndarray


def road_curves(world: World, robots: list[tuple[str, tuple[int, int, int], np.ndarray]]
                ) -> tuple[list[RoadCurve], float] | None:
    """Each robot's (name, colour, (n, 2) path in metres) located on the world's road, and the
    road's half width; None when the world has no road."""
    road = first_road(world)
    if road is None:
        return None
    tracker = RoadTracker(road)
    curves = []
    for name, colour, xy in robots:
        if len(xy) == 0:
            continue
        # keep the last pose: the panel should end where the map's path ends
        step = max(1, math.ceil(len(xy) / MAX_POINTS))
        idx = np.unique(np.concatenate((np.arange(0, len(xy), step), [len(xy) - 1])))
        # sampled poses must stay less than half a loop apart for the lap count's seam rule
        pts = xy[idx]
        tracker.start(name, float(pts[0, 0]), float(pts[0, 1]))
        along = np.empty(len(pts))
        offset = np.empty(len(pts))
        for k, (x, y) in enumerate(pts):
            tracker.update(name, float(x), float(y))
            along[k] = tracker.progress_m(name)
            offset[k] = tracker.offset(float(x), float(y))
        curves.append(RoadCurve(name, colour, along, offset))
    return curves, tracker.half_width_m


def panel_height(P: Painter) -> int:
    """The pixels the panel takes under the map, its title and axis labels included."""
    return round(250 * P.s)


def draw_road_panel(img: np.ndarray, P: Painter, world: World,
                    robots: list[tuple[str, tuple[int, int, int], np.ndarray]],
                    box: tuple[int, int, int, int]) -> tuple[float, float, float, float] | None:
    """Draw the panel in ``box`` (left, top, width, height in pixels, labels included).

    Returns the data extent drawn (along_min, along_max, offset_min, offset_max), or None when
    the world has no road (nothing is drawn then).
    """
    found = road_curves(world, robots)
    if found is None:
        return None
    curves, half_w = found
    left, top, width, height = box
    s = P.s
    title_h, axis_h = round(30 * s), round(40 * s)
    x0, x1 = left, left + width
    y0, y1 = top + title_h, top + height - axis_h
    a_lo = min([0.0, *(float(c.along_m.min()) for c in curves)])
    a_hi = max([1.0, *(float(c.along_m.max()) for c in curves)])
    # scaled to the robots' error, so that a few centimetres show; the road's edges join the
    # panel once the error comes near them
    lim = max([0.05, *(float(np.abs(c.offset_m).max()) * 1.2 for c in curves)])
    edges = lim > 0.6 * half_w
    if edges:
        lim = max(lim, half_w * 1.25)
    P.put(img, f"offset from the road's centreline (m, left of travel +; the road's edges are at +-{half_w:g} m)",
          (x0, top + round(18 * s)), P.text, INK, thick=max(1, round(1.4 * s)), max_w=width)
    ext = (a_lo, a_hi, -lim, lim)

    def px(along: np.ndarray, off: np.ndarray) -> np.ndarray:
        u = x0 + (along - a_lo) / (a_hi - a_lo) * (x1 - x0)
        v = y0 + (lim - off) / (2 * lim) * (y1 - y0)
        return np.column_stack((u, v))

    cv2.rectangle(img, (x0, y0), (x1, y1), MAP_BG, -1)
    road = first_road(world)
    if road is not None:  # the road itself, edge to edge, in its own colour but pale
        r = np.round(px(np.array([a_lo, a_hi]), np.array([min(half_w, lim), -min(half_w, lim)]))).astype(int)
        pale = tuple(int(c) for c in (np.array(bgr(road.rgb)) * 0.18 + np.array(MAP_BG) * 0.82))
        cv2.rectangle(img, (x0, int(r[0, 1])), (x1, int(r[1, 1])), pale, -1)
    _panel_grid(img, P, ext, (x0, y0, x1, y1), px)
    for edge in (half_w, -half_w) if edges else ():
        v = round(float(px(np.array([a_lo]), np.array([edge]))[0, 1]))
        _dashed(img, (x0, v), (x1, v), MUTED, P.lw, round(8 * s))
        P.put(img, "road edge", (x1 - round(4 * s), v - round(4 * s)), P.small, MUTED, align="right")
    line_w = max(2, round(2 * s))
    for c in curves:
        pts = np.round(px(c.along_m, c.offset_m) * ONE).astype(np.int32).reshape(-1, 1, 2)
        cv2.polylines(img, [pts], False, c.colour, line_w, AA, SHIFT)
        end = px(c.along_m[-1:], c.offset_m[-1:])[0]
        cv2.circle(img, (round(end[0]), round(end[1])), round(3 * s), darker(c.colour), -1, AA)
    cv2.rectangle(img, (x0, y0), (x1, y1), FRAME, P.lw)
    P.put(img, "distance driven along the road (m)", (x1, y1 + round(36 * s)), P.small, MUTED, align="right")
    return ext


def _panel_grid(img: np.ndarray, P: Painter, ext: tuple[float, float, float, float],
                frame: tuple[int, int, int, int], px: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> None:
    """Grid lines and tick labels on both axes, about 80 px apart."""
    a_lo, a_hi, o_lo, o_hi = ext
    x0, y0, x1, y1 = frame
    s = P.s
    for axis, (lo, hi, span_px) in enumerate(((a_lo, a_hi, x1 - x0), (o_lo, o_hi, y1 - y0))):
        step = nice_step((hi - lo) / max(span_px / ((80 if axis == 0 else 36) * s), 1.0))
        k = math.ceil(lo / step - 1e-9)
        while k * step <= hi + 1e-9:
            v = k * step
            k += 1
            text = f"{v:g}" if abs(v) > 1e-9 else "0"
            if axis == 0:
                u = round(float(px(np.array([v]), np.array([0.0]))[0, 0]))
                cv2.line(img, (u, y0), (u, y1), GRID, P.lw)
                P.put(img, text, (u, y1 + round(18 * s)), P.small, MUTED, align="center")
            else:
                r = round(float(px(np.array([a_lo]), np.array([v]))[0, 1]))
                cv2.line(img, (x0, r), (x1, r), FRAME if abs(v) < 1e-9 else GRID, P.lw)
                P.put(img, text, (x0 - round(8 * s), r + round(5 * s)), P.small, MUTED, align="right")


def _dashed(img: np.ndarray, a: tuple[int, int], b: tuple[int, int], colour: tuple[int, int, int],
            thick: int, dash: int) -> None:
    """A horizontal dashed line from a to b."""
    for u in range(a[0], b[0], 2 * dash):
        cv2.line(img, (u, a[1]), (min(u + dash, b[0]), b[1]), colour, thick, AA)
