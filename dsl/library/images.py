"""Image functions of the language, on NumPy arrays with OpenCV.

Images are uint8 arrays, height x width (gray) or height x width x 3 (RGB), in CoppeliaSim's
row order: row 0 is the BOTTOM row of the picture (for a camera looking down and forward, the
near edge of the floor), column 0 the left. That is the array ``sim.getVisionSensorImg``
hands a script, so the functions here give a behaviour the numbers a CoppeliaSim script
computes with OpenCV on the same camera, without a flip on either side (docs/decisions.md,
"Camera images in CoppeliaSim's row order"). Every function here is a few OpenCV or NumPy
calls; none loops over pixels in Python.
"""
from __future__ import annotations

import cv2
import numpy as np

from labsim.foundation.threads import limit_cv2_threads

EMPTY = np.zeros((0, 0), np.uint8)
limit_cv2_threads(cv2)  # one thread per run unless LABSIM_THREADS says otherwise (foundation/threads.py)


class EmptyCentroid(Exception):
    """centroid() of an image with no set pixel; carries the defined result."""

    def __init__(self, result: tuple[float, float, bool]):
        super().__init__("centroid of an image with no set pixel")
        self.result = result


def gray(img: np.ndarray) -> np.ndarray:
    """RGB to gray (ITU-R BT.601 weights, as OpenCV); a gray or empty image is returned as it is."""
    return cv2.cvtColor(img, cv2.COLOR_RGB2GRAY) if img.ndim == 3 and img.size else img


def threshold(img: np.ndarray, level: float) -> np.ndarray:
    """OpenCV THRESH_BINARY on the gray image: 255 where a pixel is > level, else 0."""
    if not img.size:
        return EMPTY  # OpenCV gives None for an empty image
    return cv2.threshold(gray(img), level, 255, cv2.THRESH_BINARY)[1]


def invert(img: np.ndarray) -> np.ndarray:
    """255 - each pixel."""
    return cv2.bitwise_not(img) if img.size else EMPTY


def crop(img: np.ndarray, x: float, y: float, w: float, h: float) -> np.ndarray:
    """The w x h rectangle whose first pixel is (x, y): columns x.., rows y.. (rows count from
    the bottom, so as a picture (x, y) is its bottom-left corner), clipped to the image."""
    x0, y0 = max(0, int(x)), max(0, int(y))
    x1, y1 = min(img.shape[1], int(x + w)), min(img.shape[0], int(y + h))
    if x1 <= x0 or y1 <= y0:
        raise ValueError(f"the rectangle ({x:g}, {y:g}, {w:g}, {h:g}) holds no pixel of the "
                         f"{img.shape[1]} x {img.shape[0]} image")
    return img[y0:y1, x0:x1]


def mean(img: np.ndarray) -> float:
    """Mean pixel value, 0..255 (over all channels of a colour image); nan for no pixel."""
    if img.size == 0:
        raise ValueError("mean of an image with no pixel")
    return float(img.mean())


def area(img: np.ndarray) -> float:
    """How many pixels are set (non-zero) in the gray image."""
    return float(cv2.countNonZero(gray(img))) if img.size else 0.0


def width(img: np.ndarray) -> float:
    return float(img.shape[1]) if img.ndim >= 2 else 0.0


def height(img: np.ndarray) -> float:
    return float(img.shape[0])


def _binary_moments(g: np.ndarray) -> dict[str, float]:
    """The moments of g's set pixels, each counted as 1.

    A threshold's output holds only 0 and 255, and then plain moments are 255 times the
    binary ones, exactly (sums of whole numbers far below 2**53), so every ratio of two of
    them is the same float; plain moments cost half as much. Any other image takes
    OpenCV's binary path.
    """
    m = cv2.moments(g)
    if m["m00"] == 255.0 * cv2.countNonZero(g):  # every set pixel is 255
        return m
    return cv2.moments(g, binaryImage=True)


def centroid(img: np.ndarray) -> tuple[float, float, bool]:
    """(x, y, found): the centre of mass of the set pixels, from the image moments.

    x counts columns from the left, y rows from the bottom (row 0), in pixels. An image with
    no set pixel has no centroid: the result is the image centre with found = false, and
    EmptyCentroid says so (the compiled call turns it into one warning).
    """
    g = gray(img)
    m = _binary_moments(g) if g.size else {"m00": 0}
    if m["m00"] == 0:
        h, w = g.shape[:2]
        raise EmptyCentroid(((w - 1) / 2, (h - 1) / 2, False))
    return (m["m10"] / m["m00"], m["m01"] / m["m00"], True)
