"""An MP4's frames converted to yuv420p only where they changed (``movie.to_i420``) are byte for
byte the whole frame's conversion, whatever the boxes' parity and however they overlap the edge."""
from __future__ import annotations

import cv2
import numpy as np

from labsim.runtime.pictures.movie import to_i420


def test_boxes_converted_alone_give_the_whole_frames_conversion() -> None:
    rng = np.random.default_rng(1)
    frame = rng.integers(0, 256, (64, 96, 3), dtype=np.uint8)
    last = to_i420(frame, None, None)
    assert np.array_equal(last, cv2.cvtColor(frame, cv2.COLOR_BGR2YUV_I420))
    for _ in range(40):
        boxes = []
        for _ in range(int(rng.integers(0, 4))):
            x0, y0 = int(rng.integers(-5, 96)), int(rng.integers(-5, 64))
            box = (x0, y0, x0 + int(rng.integers(0, 30)), y0 + int(rng.integers(0, 30)))
            frame[max(box[1], 0):max(box[3], 0), max(box[0], 0):max(box[2], 0)] = rng.integers(0, 256, 3)
            boxes.append(box)
        last = to_i420(frame, boxes, last)
        assert np.array_equal(last, cv2.cvtColor(frame, cv2.COLOR_BGR2YUV_I420))


def test_without_boxes_or_a_last_frame_the_whole_frame_is_converted() -> None:
    frame = np.full((32, 48, 3), 200, np.uint8)
    assert np.array_equal(to_i420(frame, [(0, 0, 2, 2)], None), cv2.cvtColor(frame, cv2.COLOR_BGR2YUV_I420))
