"""An animation's fading paths, drawn a frame's worth at a time.

Part of ``labsim.runtime.pictures.animate``: every frame shows each robot's path up to the
frame's time, pale where it is older than the fade and in the robot's colour for the recent
part. A frame's work is what changed since the last one, whatever the run's length: the *pale
layer* (the backdrop and every segment that has become old, drawn pale, never undone), the
*recent layer* (pixel by pixel: how much of it the recent passes cover, in which colour, and the
time of the latest), and the *shown layer* (the recent layer over the pale one). A frame's new
segments are one *pass*: drawn once, as a coverage, and laid over what recent passes left in
their pixels, as OpenCV blends a line over a picture. A pass is recent while its last segment
is; once it is old, the pixels whose latest pass it was show the pale layer again. Redrawing
every recent segment crossing a changed box instead cost as much as the robot's passes over it
in the fade, six times as many in an hour's run as in ten minutes. What this changes in the
picture (docs/pictures.md): a pass turns pale as a whole, within one frame's path of where the
segment-by-segment cut falls, and a pixel keeps the coverage of older passes while a later
one over it is recent (edges where the robot went round again are drawn at full strength).
"""
from __future__ import annotations

import heapq
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
        h, w = backdrop.shape[:2]
        # the recent layer, pixel by pixel: the time of the latest pass over it (the start of its
        # last segment), how much of the pixel the passes still recent cover (of 255), in whose colour
        self._when = np.full((h, w), -np.inf)
        self._alpha = np.zeros((h, w), np.uint8)
        self._colour = np.zeros((h, w, 3), np.uint8)
        self._recent_from = -np.inf
        self._inked: Box = (w, h, 0, 0)  # a box around every pass drawn: outside it, the pale layer
        self._passes: list[tuple[float, Box]] = []  # the recent ones, a heap by time
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
        self._recent_from = recent_from
        while self._passes and self._passes[0][0] < recent_from:  # passes that turned old: pale where
            boxes.append(heapq.heappop(self._passes)[1])  # no later pass still recent covers them
        for st, row in zip(self._robots, rows):
            p = st.points
            shown = max(st.shown, int(p.upto[row]))
            recent = max(st.pale, min(int(np.searchsorted(p.t, recent_from)), max(shown - 1, 0)))
            if recent > st.pale:  # segments that turned old: pale for good
                cv2.polylines(self.pale_layer, [p.pts[st.pale:recent + 1].reshape(-1, 1, 2)], False,
                              pale(p.colour), self.width, AA, SHIFT)
                boxes.append(self._box(st, st.pale, recent))
            first = max(st.shown - 1, recent, 0)
            if shown - 1 > first:  # segments that appeared, and are recent
                boxes.append(self._pass(st, first, shown - 1))
            st.shown, st.pale = shown, recent
        for box in boxes:
            self._compose(box)
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

    def _pass(self, st: _State, first: int, end: int) -> Box:
        """Segments first..end-1 put on the recent layer as one pass, of the time of its last
        segment: drawn once, as a coverage, on a piece as large as their box (which leaves room
        for the line's antialiased edge), and laid over what the passes still recent left there."""
        box = self._box(st, first, end)
        x0, y0, x1, y1 = box
        if x0 >= x1 or y0 >= y1:
            return box
        p = st.points
        cover = np.zeros((y1 - y0, x1 - x0), np.uint8)
        line = (p.pts[first:end + 1] - (x0 * ONE, y0 * ONE)).reshape(-1, 1, 2)
        cv2.polylines(cover, [line], False, 255, self.width, AA, SHIFT)
        hit = cover > 0
        when, alpha, colour = self._when[y0:y1, x0:x1], self._alpha[y0:y1, x0:x1], self._colour[y0:y1, x0:x1]
        # the pass over what is still recent there, as OpenCV blends a line over a picture
        c = cover[hit].astype(np.float32) / 255
        under = np.where(when[hit] >= self._recent_from, alpha[hit], 0).astype(np.float32) / 255 * (1 - c)
        both = c + under
        mixed = (np.array(p.colour, np.float32) * c[:, None] + colour[hit] * under[:, None]) / both[:, None]
        alpha[hit] = np.rint(both * 255)
        colour[hit] = np.rint(mixed)
        when[hit] = p.t[end - 1]
        heapq.heappush(self._passes, (float(p.t[end - 1]), box))
        u0, v0, u1, v1 = self._inked
        self._inked = (min(u0, x0), min(v0, y0), max(u1, x1), max(v1, y1))
        return box

    def _compose(self, box: Box) -> None:
        """The shown layer inside ``box``: the pale layer, and the recent layer's colour over it
        where its pass is still recent, by its coverage (as OpenCV blends an antialiased edge)."""
        h, w = self.shown.shape[:2]
        x0, y0, x1, y1 = max(box[0], 0), max(box[1], 0), min(box[2], w), min(box[3], h)
        if x0 >= x1 or y0 >= y1:
            return
        pale, when = self.pale_layer[y0:y1, x0:x1], self._when[y0:y1, x0:x1]
        u0, v0, u1, v1 = self._inked
        if x1 <= u0 or x0 >= u1 or y1 <= v0 or y0 >= v1 or when.max() < self._recent_from:
            # no recent path here (the caption under the map, a robot off its path)
            self.shown[y0:y1, x0:x1] = pale
            return
        a = np.where(when >= self._recent_from, self._alpha[y0:y1, x0:x1], 0).astype(np.float32)
        self.shown[y0:y1, x0:x1] = cv2.blendLinear(self._colour[y0:y1, x0:x1], pale, a, 255 - a)


def pale(colour: tuple[int, int, int]) -> tuple[int, int, int]:
    """A robot's colour faded most of the way to white: its path's old part."""
    b, g, r = (int(c + (255 - c) * 0.6) for c in colour)
    return (b, g, r)
