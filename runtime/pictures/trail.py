"""An animation's fading paths, drawn a frame's worth at a time.

Part of ``labsim.runtime.pictures.animate``: every frame shows each robot's path up to the
frame's time, pale where it is older than the fade and in the robot's colour for the recent
part. Redrawing the whole path on every frame made an animation's cost grow with the run's
length; here two layers are kept instead and only what changed since the last frame is drawn:
the *pale layer* (the backdrop and every path segment that has become old, drawn pale, never
undone) and the *shown layer* (the pale layer with the recent segments in colour on top). A
frame draws its new segments pale on the pale layer, copies the pale layer back into the small
boxes where segments appeared or turned pale, and redraws there, clipped to each box, the
recent segments that cross it. The pixels are those of drawing the pale and then the recent
polylines whole (within OpenCV's rounding at a box's edge), except that every robot's recent
path lies above every pale one.
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from labsim.runtime.pictures.paint import AA, ONE, SHIFT

Box = tuple[int, int, int, int]  # x0, y0, x1, y1 pixels, x1 and y1 excluded


@dataclass(frozen=True)
class TrailPoints:
    """One robot's finite poses in the frame's fixed-point pixels, their times, and for each
    trace row of the robot how many of those poses come up to it."""

    colour: tuple[int, int, int]
    pts: np.ndarray  # (m, 2) int32, pixels * ONE
    t: np.ndarray  # (m,) simulated seconds
    upto: np.ndarray  # (rows,) number of finite poses among the robot's rows up to this one


@dataclass
class _State:
    points: TrailPoints
    lo: np.ndarray  # (m - 1, 2) each segment's box, whole pixels, with room for the line's width
    hi: np.ndarray
    shown: int = 0  # poses on screen
    pale: int = 0  # segments drawn pale (the first ones)


class Trails:
    """The paths of every robot over a backdrop, advanced frame by frame (times never go back)."""

    def __init__(self, backdrop: np.ndarray, robots: list[TrailPoints], width_px: int):
        self.pale_layer = backdrop.copy()
        self.shown = backdrop.copy()
        self.width = width_px
        margin = width_px + 2  # a round cap's radius and the antialiased edge, with room to spare
        self._robots = []
        self._dirty: list[Box] = []  # drawn over since the last frame: restored by the next
        self._redrawn: list[Box] = []  # restored or redrawn by the last ``advance``
        for r in robots:
            a, b = r.pts[:-1], r.pts[1:]
            lo = (np.minimum(a, b) >> SHIFT) - margin
            hi = (np.maximum(a, b) >> SHIFT) + margin + 1
            self._robots.append(_State(r, lo.reshape(-1, 2), hi.reshape(-1, 2)))

    def advance(self, rows: list[int], recent_from: float) -> np.ndarray:
        """The layer showing each robot's path up to its row ``rows[k]`` (its index among the
        robot's rows), pale before ``recent_from``. The array is the trails' own: what is drawn on
        it must be in boxes given to ``drawn_over`` before the next call."""
        boxes, self._dirty = self._dirty, []
        for st, row in zip(self._robots, rows):
            p = st.points
            shown = max(st.shown, int(p.upto[row]))
            recent = max(st.pale, min(int(np.searchsorted(p.t, recent_from)), max(shown - 1, 0)))
            if recent > st.pale:  # segments that turned old: pale for good
                cv2.polylines(self.pale_layer, [p.pts[st.pale:recent + 1].reshape(-1, 1, 2)], False,
                              pale(p.colour), self.width, AA, SHIFT)
                boxes.append(self._box(st, st.pale, recent))
            if shown > st.shown and shown > 1:  # segments that appeared
                boxes.append(self._box(st, max(st.shown - 1, 0), shown - 1))
            st.shown, st.pale = shown, recent
        for box in boxes:
            self._redraw(box)
        self._redrawn = boxes
        return self.shown

    def changed(self) -> list[Box]:
        """The boxes outside which the shown layer is as it was at the previous frame (what the
        last ``advance`` redrew, and what was drawn over since): an encoder converts only these."""
        return [*self._redrawn, *self._dirty]

    def drawn_over(self, box: Box) -> None:
        """Say that the shown layer was drawn on inside ``box`` (a robot, a caption): the next
        frame puts the trails back there first."""
        self._dirty.append(box)

    def _box(self, st: _State, first: int, end: int) -> Box:
        """The box around segments first..end-1, inside the image."""
        lo, hi = st.lo[first:end].min(axis=0), st.hi[first:end].max(axis=0)
        h, w = self.shown.shape[:2]
        return (max(int(lo[0]), 0), max(int(lo[1]), 0), min(int(hi[0]), w), min(int(hi[1]), h))

    def _redraw(self, box: Box) -> None:
        """The shown layer inside ``box``: the pale layer, and every recent segment crossing the box
        drawn over it in order. They are drawn on a piece a few pixels wider than the box, of which
        only the box is kept: OpenCV's antialiasing is off at the edge of what it draws on."""
        h, w = self.shown.shape[:2]
        x0, y0, x1, y1 = max(box[0], 0), max(box[1], 0), min(box[2], w), min(box[3], h)
        if x0 >= x1 or y0 >= y1:
            return
        m = self.width + 2
        u0, v0, u1, v1 = max(x0 - m, 0), max(y0 - m, 0), min(x1 + m, w), min(y1 + m, h)
        part = self.pale_layer[v0:v1, u0:u1].copy()
        origin = (u0 * ONE, v0 * ONE)
        for st in self._robots:
            first, end = st.pale, st.shown - 1  # recent segments: pale..shown-2
            if end <= first:
                continue
            lo, hi = st.lo[first:end], st.hi[first:end]
            inside = np.flatnonzero((lo[:, 0] < u1) & (hi[:, 0] > u0) & (lo[:, 1] < v1) & (hi[:, 1] > v0))
            if not len(inside):
                continue
            # runs of consecutive segments, each one polyline through its poses
            cut = np.flatnonzero(np.diff(inside) > 1)
            starts = np.concatenate(([inside[0]], inside[cut + 1])) + first
            ends = np.concatenate((inside[cut], [inside[-1]])) + first + 2
            lines = [(st.points.pts[a:b] - origin).reshape(-1, 1, 2) for a, b in zip(starts, ends)]
            cv2.polylines(part, lines, False, st.points.colour, self.width, AA, SHIFT)
        self.shown[y0:y1, x0:x1] = part[y0 - v0:y1 - v0, x0 - u0:x1 - u0]


def pale(colour: tuple[int, int, int]) -> tuple[int, int, int]:
    """A robot's colour faded most of the way to white: its path's old part."""
    b, g, r = (int(c + (255 - c) * 0.6) for c in colour)
    return (b, g, r)
