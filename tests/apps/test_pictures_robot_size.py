"""Robots in an animation (GIF, MP4) at their model's size: an e-puck is a 7 cm disc, not a
Pioneer's 44 cm, and its heading mark is in proportion to it."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from helpers import ROOT

from labsim.runtime.pictures import animate
from labsim.runtime.pictures.animate import DEFAULT_RADIUS_M, _tracks, frame_at, model_radius
from labsim.runtime.pictures.paint import ONE
from labsim.runtime.trace import read_trace


def test_each_model_has_its_own_radius() -> None:
    assert model_radius("epuck") == pytest.approx(0.035, abs=0.003)
    assert model_radius("pioneer_p3dx") == pytest.approx(0.215, abs=0.003)
    assert model_radius("no such model") == DEFAULT_RADIUS_M


@pytest.mark.slow
def test_an_epuck_is_drawn_at_its_size(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    trace = tmp_path / "line.csv"
    subprocess.run([sys.executable, "-m", "labsim", "run", "behaviours/line_follow.yaml", "--trace", str(trace),
                    "-q"], check=True, cwd=ROOT)
    t = read_trace(trace)
    tracks = _tracks(t)
    assert [tr.radius_m for tr in tracks] == [model_radius("epuck")]
    discs: list[float] = []
    lines: list[tuple] = []
    circle, line, robot = animate.cv2.circle, animate.cv2.line, animate._robot
    scale: list[float] = []
    monkeypatch.setattr(animate, "_robot", lambda img, P, px, tr, i, mpp: (scale.append(mpp),
                                                                            robot(img, P, px, tr, i, mpp))[1])
    monkeypatch.setattr(animate.cv2, "circle", lambda img, c, r, *a: (discs.append(r / ONE), circle(img, c, r, *a)))
    monkeypatch.setattr(animate.cv2, "line", lambda img, a, b, *rest: (lines.append((a, b)), line(img, a, b, *rest)))
    frame_at(t, tracks, np.array([0.0, 10.0]), 720)
    assert discs and scale, "no robot drawn"
    r_px = max(discs)  # its size in the world, in this picture's metres a pixel (a Pioneer's was 6 times it)
    assert r_px == pytest.approx(model_radius("epuck") / scale[-1], abs=1 / ONE)  # drawn to a 16th of a pixel
    assert r_px < DEFAULT_RADIUS_M / scale[-1] / 5
    (ax, ay), (bx, by) = lines[-1]
    assert np.hypot(bx - ax, by - ay) / ONE <= max(1.6 * r_px, r_px + 3 * 1.0) + 1
