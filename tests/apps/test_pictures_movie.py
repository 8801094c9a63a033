"""Animations drawn frame by frame: the trails against drawing every path whole, the GIF writer's
colours and boxes, and the wall lab's frames against the ones a whole redraw makes."""
from __future__ import annotations

import io
import math
from pathlib import Path

import cv2
import imageio.v2 as imageio
import numpy as np
import pytest
from helpers import BEHAVIOURS

from labsim.runtime.pictures.animate import _tracks, default_speed, frame_times, frames
from labsim.runtime.pictures.movie import GifWriter
from labsim.runtime.pictures.paint import AA, ONE, SHIFT
from labsim.runtime.pictures.trail import TrailPoints, Trails
from labsim.runtime.trace import read_trace

BACKDROP = (246, 247, 248)
COLOURS = [(180, 119, 31), (14, 127, 255)]


def _loops(k: int, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """A path that goes round the same circle three times (so recent and old parts overlap)."""
    a = np.linspace(0, 6 * math.pi, n)
    xy = np.column_stack((100 + 60 * np.cos(a) + 25 * k, 100 + 60 * np.sin(a)))
    return np.round(xy * ONE).astype(np.int32), np.linspace(0.0, 40.0, n)


def _whole(pts: list[np.ndarray], passes: list[tuple[int, int]], pale: list[int]) -> np.ndarray:
    """What the trails stand for: every pale path, then every recent pass (a frame's new segments,
    recent while the last one is) in the order they came, each robot's in turn."""
    img = np.full((220, 260, 3), BACKDROP, np.uint8)
    for p, k, c in zip(pts, pale, COLOURS):
        if k:
            cv2.polylines(img, [p[: k + 1].reshape(-1, 1, 2)], False, tuple(int(v + (255 - v) * 0.6) for v in c),
                          2, AA, SHIFT)
    for first, end in passes:
        for p, c in zip(pts, COLOURS):
            cv2.polylines(img, [p[first:end + 1].reshape(-1, 1, 2)], False, c, 2, AA, SHIFT)
    return img


def test_trails_drawn_a_frame_at_a_time_match_the_paths_drawn_whole() -> None:
    paths = [_loops(k) for k in range(2)]
    robots = [TrailPoints(c, p, t, np.arange(1, len(t) + 1)) for (p, t), c in zip(paths, COLOURS)]
    trails = Trails(np.full((220, 260, 3), BACKDROP, np.uint8), robots, 2)
    worst = 0.0
    for row in range(0, 400, 7):
        t = paths[0][1][row]
        shown = trails.advance([row, row], t - 8.0).copy()
        pale = [min(int(np.searchsorted(p[1], t - 8.0)), row) for p in paths]
        # the frames' passes: segments row-7..row-1, recent while segment row-1 is
        passes = [(r - 7, r) for r in range(7, row + 1, 7) if paths[0][1][r - 1] >= t - 8.0]
        whole = _whole([p[0] for p in paths], passes, pale)
        differ = np.abs(shown.astype(int) - whole.astype(int)).max(axis=2)
        drawn = (np.abs(whole.astype(int) - np.array(BACKDROP)).max(axis=2) > 0).sum()
        # the same pixels but for antialiased edges where the drawing was cut into pieces
        worst = max(worst, (differ > 64).sum() / max(drawn, 1))
        assert differ[whole.sum(axis=2) < 400].max(initial=0) < 100
    assert worst < 0.02


def test_drawing_over_a_frame_is_undone_by_the_next() -> None:
    p, t = _loops(0)
    trails = Trails(np.full((220, 260, 3), BACKDROP, np.uint8), [TrailPoints(COLOURS[0], p, t, np.arange(1, 401))], 2)
    first = trails.advance([10], -1.0)
    cv2.rectangle(first, (0, 0), (40, 40), (0, 0, 255), -1)
    trails.drawn_over((0, 0, 41, 41))
    again = trails.advance([10], -1.0)
    assert (again[:41, :41] == BACKDROP).all()


def test_gif_frames_keep_their_flat_colours_exactly() -> None:
    base = np.full((64, 96, 3), BACKDROP, np.uint8)
    made = []
    for k in range(5):
        img = base.copy()
        cv2.rectangle(img, (5 + 10 * k, 10), (20 + 10 * k, 30), COLOURS[k % 2], -1)
        made.append(img)
    out = io.BytesIO()
    writer = GifWriter(out, np.vstack(made), fps=5)
    for img in made:
        writer.append(img)
    writer.close()
    back = imageio.mimread(out.getvalue(), format="GIF")
    assert len(back) == 5
    for img, got in zip(made, back):
        assert (got[:, :, :3] == img[:, :, ::-1]).all()  # BGR in, RGB in the file


def test_wall_lab_frames_look_as_a_whole_redraw_draws_them() -> None:
    trace = read_trace(BEHAVIOURS / "wall_follow.golden.csv")
    tracks = _tracks(trace)
    t1 = float(tracks[0].t[-1])
    times = frame_times(0.0, t1, 2, default_speed(t1))
    fade = 0.15 * float(times[-1] - times[0])
    made = frames(trace, tracks, times, 720)
    last = next(made)
    for last in made:  # noqa: B007 (the last frame is the one compared)
        pass
    # the last frame, made by the trails, against its paths drawn whole on a frame made alone
    alone = next(frames(trace, tracks, times[-1:], 720, fade_s=fade))
    differ = np.abs(last.astype(int) - alone.astype(int)).max(axis=2)
    assert (differ > 64).sum() < 0.01 * differ.size


def test_an_mp4_whose_ffmpeg_fails_raises_in_the_drawing_thread(tmp_path: Path) -> None:
    """The frames go to ffmpeg from a thread of their own; ffmpeg's failure (here: no folder to
    write in) reaches the caller at a later frame or at close, never a hang or a lost error."""
    from labsim.runtime.pictures.movie import Mp4Writer

    writer = Mp4Writer(tmp_path / "no such folder" / "run.mp4", (64, 64), 10.0)
    frame = np.zeros((64, 64, 3), np.uint8)
    with pytest.raises(Exception):  # noqa: B017 - whichever error the pipe or ffmpeg gives
        for _ in range(1000):
            writer.append(frame)
        writer.close()
    writer.close()  # closing again after the error is quiet
    assert not (tmp_path / "no such folder").exists()
