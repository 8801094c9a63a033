"""The drawing primitives of ``labsim plot``: its colours, fonts, markers, text and the world.

``labsim.runtime.pictures.plot`` lays a figure out and draws a trace on it through these: a
``Painter`` sized to the figure's width (text, start and end markers, collision crosses,
event triangles) and the world's parts to scale (walls at their thickness, the ground's
patches, roads and lines, a mechanism from the side). OpenCV only; colours are BGR.
"""
from __future__ import annotations

import colorsys
from collections.abc import Callable

import cv2
import numpy as np

from labsim.backends.scene.ground import Ground

PxMap = Callable[[np.ndarray], np.ndarray]  # an (n, 2) array of metres to pixel coordinates

# Colours are BGR, as OpenCV wants them. Robots take the Tableau palette without its red, so
# that red means one thing only in the figure: a collision.
_ROBOT_RGB = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (148, 103, 189),
              (140, 86, 75), (227, 119, 194), (188, 189, 34), (23, 190, 207)]
_EVENT_RGB = [(255, 193, 7), (0, 150, 136), (156, 39, 176), (233, 30, 99),
              (63, 81, 181), (139, 195, 74), (121, 85, 72), (0, 188, 212)]
PAPER = (255, 255, 255)
MAP_BG = (246, 247, 248)
GRID = (222, 222, 222)
FRAME = (150, 150, 150)
WALL = (55, 55, 55)
BLOCK_FILL = (185, 185, 185)
BLOCK_EDGE = (95, 95, 95)
INK = (35, 35, 35)
MUTED = (120, 120, 120)
COLLISION = (30, 30, 220)
WARNING = (20, 20, 170)

FONT = cv2.FONT_HERSHEY_SIMPLEX
TITLE_FONT = cv2.FONT_HERSHEY_DUPLEX
AA = cv2.LINE_AA
SHIFT = 4  # polylines take fixed-point coordinates: 4 fractional bits keep paths smooth
ONE = 1 << SHIFT


def bgr(rgb: tuple[int, int, int]) -> tuple[int, int, int]:
    return (rgb[2], rgb[1], rgb[0])


def robot_colour(i: int) -> tuple[int, int, int]:
    """The i-th robot's colour (BGR); past the palette, hues spaced by the golden angle."""
    if i < len(_ROBOT_RGB):
        return bgr(_ROBOT_RGB[i])
    hue = (0.1 + (i - len(_ROBOT_RGB)) * 0.618034) % 1.0
    hue = 0.06 + hue * 0.88  # keep clear of red at both ends of the hue circle
    r, g, b = colorsys.hsv_to_rgb(hue, 0.75, 0.8)
    return (int(b * 255), int(g * 255), int(r * 255))


def event_colour(i: int) -> tuple[int, int, int]:
    return bgr(_EVENT_RGB[i % len(_EVENT_RGB)])


def darker(c: tuple[int, int, int], f: float = 0.6) -> tuple[int, int, int]:
    return (int(c[0] * f), int(c[1] * f), int(c[2] * f))


def ascii(text: object) -> str:
    # OpenCV's Hershey fonts have ASCII glyphs only; anything else would print as '?' anyway
    return str(text).encode("ascii", "replace").decode("ascii")



class Painter:
    """Sizes scaled to the requested width, and the text/marker primitives that use them."""

    def __init__(self, width_px: int):
        # sizes follow the width, but not below what stays legible: small plots get
        # relatively bigger text and markers, and a smaller share for the map
        self.s = s = max(width_px / 1000, 0.8)
        self.lw = max(1, round(s))  # hairline width for text and frames
        self.pad = round(14 * s)
        self.text = 0.45 * s
        self.small = 0.4 * s
        self.title = 0.72 * s
        self.line_h = round(22 * s)

    def size(self, text: str, scale: float, font: int = FONT, thick: int | None = None) -> tuple[int, int]:
        (w, h), _ = cv2.getTextSize(text, font, scale, thick or self.lw)
        return w, h

    def put(self, img: np.ndarray, text: str, org: tuple[float, float], scale: float,
            colour: tuple[int, int, int] = INK, font: int = FONT, thick: int | None = None,
            align: str = "left", max_w: int | None = None) -> None:
        text = ascii(text)
        if max_w is not None and self.size(text, scale, font, thick)[0] > max_w:
            while len(text) > 1 and self.size(text + "...", scale, font, thick)[0] > max_w:
                text = text[:-1]
            text += "..."
        w, h = self.size(text, scale, font, thick)
        x, y = org
        if align == "center":
            x -= w / 2
        elif align == "right":
            x -= w
        cv2.putText(img, text, (round(x), round(y)), font, scale, colour, thick or self.lw, AA)

    # markers, centred on pixel points; used on the map and, the same, in the legend
    def start(self, img: np.ndarray, pts: np.ndarray, colour: tuple[int, int, int]) -> None:
        r = round(6 * self.s)
        for u, v in np.round(pts).astype(int):
            cv2.circle(img, (u, v), r, PAPER, -1, AA)
            cv2.circle(img, (u, v), r, colour, max(2, round(2.5 * self.s)), AA)

    def end(self, img: np.ndarray, pts: np.ndarray, colour: tuple[int, int, int]) -> None:
        r = round(5 * self.s)
        for u, v in np.round(pts).astype(int):
            cv2.rectangle(img, (u - r, v - r), (u + r, v + r), colour, -1, AA)
            cv2.rectangle(img, (u - r, v - r), (u + r, v + r), darker(colour, 0.5), self.lw, AA)

    def crosses(self, img: np.ndarray, pts: np.ndarray) -> None:
        if not len(pts):
            return
        r = 6 * self.s * ONE
        c = pts * ONE
        # both strokes of every X in one polylines call: thousands of collisions stay cheap
        d1 = np.stack((c + (-r, -r), c + (r, r)), axis=1)
        d2 = np.stack((c + (-r, r), c + (r, -r)), axis=1)
        strokes = np.round(np.concatenate((d1, d2))).astype(np.int32)
        cv2.polylines(img, list(strokes), False, PAPER, max(4, round(5 * self.s)), AA, SHIFT)
        cv2.polylines(img, list(strokes), False, COLLISION, max(2, round(2.5 * self.s)), AA, SHIFT)

    def triangles(self, img: np.ndarray, pts: np.ndarray, colour: tuple[int, int, int]) -> None:
        if not len(pts):
            return
        r = 6.5 * self.s * ONE
        shape = np.array([(0, -r), (0.87 * r, 0.5 * r), (-0.87 * r, 0.5 * r)])
        tris = np.round(pts[:, None, :] * ONE + shape[None, :, :]).astype(np.int32)
        cv2.fillPoly(img, list(tris), colour, AA, SHIFT)
        cv2.polylines(img, list(tris), True, darker(colour, 0.45), self.lw, AA, SHIFT)



def draw_ground(img: np.ndarray, ground: Ground, px: PxMap, mpp: float) -> None:
    """Patches, roads and lines to scale, in the order a camera sees them drawn.

    Roads are thick polylines (OpenCV gives their joints round caps, so the band keeps its
    width around corners), at least a pixel wide; lines are filled bands with square ends.
    ``px`` maps an (n, 2) array of metres to pixel coordinates.
    """
    for patch in ground.patches:
        poly = np.round(px(np.array(patch.corners, float)) * ONE).astype(np.int32)
        cv2.fillPoly(img, [poly], bgr(patch.rgb), AA, SHIFT)
    for road in ground.roads:
        pts = np.round(px(np.array(road.points, float)) * ONE).astype(np.int32)
        cv2.polylines(img, [pts], road.closed, bgr(road.rgb), max(1, round(road.width_m / mpp)), AA, SHIFT)
    for line in ground.lines:
        a, b = px(np.array([line.a, line.b], float))
        d = b - a
        n = float(np.hypot(*d))
        if n == 0:
            continue
        across = np.array([-d[1], d[0]]) / n * max(line.width_m / mpp, 1.0) / 2
        band = np.round(np.array([a + across, b + across, b - across, a - across]) * ONE).astype(np.int32)
        cv2.fillPoly(img, [band], bgr(line.rgb), AA, SHIFT)


def draw_wall(img: np.ndarray, ab: np.ndarray, thick_px: float) -> None:
    """A wall as a filled band, its ends extended by half the thickness.

    The extension closes the corners where walls meet (the physics gives its thick segments
    round ends of that radius). A polygon rather than a thick cv2.line, whose antialiased ends
    come out pointed and whose width is rounded to whole pixels.
    """
    a, b = ab
    r = thick_px / 2
    d = b - a
    n = float(np.hypot(*d))
    along = d / n * r if n > 0 else np.array([r, 0.0])
    across = np.array([-along[1], along[0]])
    a, b = a - along, b + along
    band = np.round(np.array([a + across, b + across, b - across, a - across]) * ONE).astype(np.int32)
    cv2.fillPoly(img, [band], WALL, AA, SHIFT)
