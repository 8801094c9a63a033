"""The map's frame in ``labsim plot``: its pixel mapping, metre grid, axis labels, legend and scale bar.

``labsim.runtime.pictures.plot`` lays out the still map and draws the world and the run on it; this
module draws what surrounds them, so that the map, the road panel (``labsim.runtime.pictures.road_panel``)
and the animations (``labsim.runtime.pictures.animate``) share one frame. OpenCV only, as the rest of the
map.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np

from labsim.runtime.pictures.paint import AA, FRAME, GRID, INK, MUTED, Painter, darker, event_colour


@dataclass
class RobotPath:
    name: str
    model: str
    colour: tuple[int, int, int]
    xy: np.ndarray  # (n, 2) metres, non-finite poses dropped
    heading: float  # at the last pose, radians; nan when the trace has none
    collisions: np.ndarray  # (k, 2) metres: where collided went 0 -> 1
    events: dict[str, np.ndarray] = field(default_factory=dict)  # name -> (k, 2) metres



@dataclass
class Figure:
    """A rendered plot and the mapping from world metres to its pixels."""

    image: np.ndarray  # BGR, uint8
    xmin: float
    ymax: float
    m_per_px: float
    left: int  # pixel column of xmin
    top: int  # pixel row of ymax
    panels: tuple[str, ...] = ()  # what is drawn beside the map: "road panel", "slew panel"
    # the read-only background the figure was drawn on (paper, floor, grid, world): the same array
    # for every figure of a world at one size, so what is derived from it can be kept with it
    background: np.ndarray | None = None

    def to_px(self, x: float, y: float) -> tuple[float, float]:
        """Pixel (column, row) of world point (x, y); y grows up in the world, down in images."""
        return (self.left + (x - self.xmin) / self.m_per_px, self.top + (self.ymax - y) / self.m_per_px)


def nice_step(at_least: float) -> float:
    """The smallest 1-2-5 x 10^k not below at_least."""
    exp = math.floor(math.log10(at_least))
    for m in (1, 2, 5, 10):
        if m * 10 ** exp >= at_least - 1e-12:
            return m * 10 ** exp
    return 10 ** (exp + 1)


def nice_below(at_most: float) -> float:
    """The largest 1-2-5 x 10^k not above at_most."""
    exp = math.floor(math.log10(at_most))
    for m in (5, 2, 1):
        if m * 10 ** exp <= at_most + 1e-12:
            return m * 10 ** exp
    return 5 * 10 ** (exp - 1)


def grid(img: np.ndarray, P: Painter, fig: Figure, map_w: int, map_h: int,
          ext: tuple[float, float, float, float], vertical: str = "y (m)") -> None:
    """A 1 m grid (coarser only when 1 m would be a smear), labelled without crowding."""
    x0, y0, x1, y1 = ext
    mpp, s = fig.m_per_px, P.s
    step = nice_step(max(1.0, 12 * s * mpp))
    label_step = step * max(1, round(nice_step(38 * s * mpp / step)))
    right, bottom = fig.left + map_w, fig.top + map_h
    for axis, (lo, hi) in enumerate(((x0, x1), (y0, y1))):
        k = math.ceil(lo / step - 1e-9)
        while k * step <= hi + 1e-9:
            v = k * step
            k += 1
            if axis == 0:
                u = round(fig.to_px(v, 0)[0])
                if not fig.left < u < right:
                    continue
                cv2.line(img, (u, fig.top), (u, bottom), GRID, P.lw)
            else:
                r = round(fig.to_px(0, v)[1])
                if not fig.top < r < bottom:
                    continue
                cv2.line(img, (fig.left, r), (right, r), GRID, P.lw)
            if abs(v / label_step - round(v / label_step)) > 1e-6:
                continue
            text = f"{v:g}" if abs(v) > 1e-9 else "0"
            tick = round(5 * s)
            if axis == 0:
                cv2.line(img, (u, bottom), (u, bottom + tick), FRAME, P.lw)
                P.put(img, text, (u, bottom + tick + round(15 * s)), P.small, MUTED, align="center")
            else:
                cv2.line(img, (fig.left - tick, r), (fig.left, r), FRAME, P.lw)
                P.put(img, text, (fig.left - tick - round(4 * s), r + round(5 * s)), P.small, MUTED,
                      align="right")
    P.put(img, "x (m)", (right, bottom + round(38 * s)), P.small, MUTED, align="right")
    P.put(img, vertical, (fig.left - round(9 * s), fig.top - round(8 * s)), P.small, MUTED, align="right")


def legend(img: np.ndarray, P: Painter, paths: list[RobotPath], events: list[str],
            x: int, top: int, map_h: int, mpp: float, reserve: int = 0) -> int:
    """The legend column; returns the row where ``reserve`` pixels were left free under it."""
    s, lh = P.s, P.line_h
    w = img.shape[1] - x - P.pad
    sym = x + round(12 * s)  # centre column of the symbols
    tx = x + round(32 * s)  # where the words start
    y = top + round(12 * s)

    def heading(text: str) -> None:
        nonlocal y
        P.put(img, text, (x, y + round(5 * s)), P.text, INK, thick=max(1, round(1.6 * s)))
        y += lh

    def row(text: str, colour: tuple[int, int, int] = INK) -> None:
        nonlocal y
        P.put(img, text, (tx, y + round(5 * s)), P.text, colour, max_w=w - (tx - x))
        y += lh

    heading("robots")
    for p in paths:
        u = round(11 * s)
        cv2.line(img, (sym - u, y), (sym + u, y), p.colour, max(3, round(3 * s)), AA)
        label = p.name + (f" ({p.model})" if p.model and p.model != p.name else "")
        row(label)
    if not paths:
        row("(no rows in the trace)", MUTED)
    y += lh // 2

    heading("markers")
    pt = np.array([[sym, y]], float)
    P.start(img, pt, MUTED)
    row("start")
    pt = np.array([[sym - round(3 * s), y]], float)
    cv2.arrowedLine(img, (int(pt[0, 0]), y), (int(pt[0, 0] + 17 * s), y), darker(MUTED),
                    max(2, round(2 * s)), AA, 0, 0.4)
    P.end(img, pt, MUTED)
    row("end, heading")
    P.crosses(img, np.array([[sym, y]], float))
    n_coll = sum(len(p.collisions) for p in paths)
    row(f"collision ({n_coll})")
    if events:
        y += lh // 2
        heading("events")
        for k, ev in enumerate(events):
            P.triangles(img, np.array([[sym, y]], float), event_colour(k))
            n = sum(len(p.events.get(ev, ())) for p in paths)
            row(f"{ev} ({n})")

    # the scale bar at the foot of the map, unless the legend (and what it reserves) reaches lower
    below = y + round(20 * s) + (reserve + lh if reserve else 0)
    _scale_bar(img, P, x, max(top + map_h - round(8 * s), below), mpp)
    return y + lh // 2


def _scale_bar(img: np.ndarray, P: Painter, x: int, y: int, mpp: float) -> None:
    """The longest 1-2-5 length that fits in ~110 px, as a bar from column x on row y."""
    s = P.s
    length = nice_below(110 * s * mpp)
    bar = round(length / mpp)
    tick = round(4 * s)
    cv2.line(img, (x, y), (x + bar, y), INK, max(2, round(2 * s)))
    for u in (x, x + bar):
        cv2.line(img, (u, y - tick), (u, y + tick), INK, max(2, round(2 * s)))
    P.put(img, f"{length:g} m", (x + bar + round(8 * s), y + round(5 * s)), P.text, INK)


