"""A feedback page's pictures drawn for a class: the background drawn once a world and copied, the
GIF's palette made once a world from what a run draws, and the map's path a point a pixel; each
the same picture as drawing it all anew."""
from __future__ import annotations

import io

import numpy as np
from helpers import BEHAVIOURS
from PIL import Image

from labsim.runtime.pictures import plot
from labsim.runtime.pictures.animate import _run_colours, _tracks, frame_times, frames, gif_bytes
from labsim.runtime.pictures.movie import run_palette
from labsim.runtime.pictures.plot import render_figure
from labsim.runtime.trace import read_trace, trace_world

GOLDEN = BEHAVIOURS / "wall_follow.golden.csv"


def test_the_background_is_drawn_once_a_world_and_size_and_copied() -> None:
    trace = read_trace(GOLDEN)
    world, note = trace_world(trace)
    first = render_figure(trace, width_px=500, world=world, world_note=note)
    again = render_figure(trace, width_px=500, world=world, world_note=note)
    assert first.background is again.background is not None  # drawn once, shared
    assert not first.background.flags.writeable  # drawn on only through a copy
    assert (first.image == again.image).all()
    assert (first.image != first.background).any()  # the run was drawn on the copy, not on it
    plot._cached_background.cache_clear()
    anew = render_figure(trace, width_px=500, world=world, world_note=note)
    assert anew.background is not first.background
    assert (anew.background == first.background).all() and (anew.image == first.image).all()


def test_a_feedback_gif_keeps_to_the_frames_drawn() -> None:
    trace = read_trace(GOLDEN)
    world, note = trace_world(trace)
    tracks = _tracks(trace)
    t0, t1 = float(tracks[0].t[0]), float(tracks[0].t[-1])
    speed = (t1 - t0) / 3
    data = gif_bytes(trace, width_px=400, fps=5, speed=speed, world=(world, note))
    drawn_on: list[np.ndarray] = []
    drawn = [f[:, :, ::-1].copy() for f in frames(trace, tracks, frame_times(t0, t1, 5, speed), 400,
                                                  known=(world, note), drawn_on=drawn_on)]
    gif = Image.open(io.BytesIO(data))
    assert gif.n_frames == len(drawn) == 16
    errors = []
    for k, want in enumerate(drawn):
        gif.seek(k)
        errors.append(np.abs(np.asarray(gif.convert("RGB")).astype(int) - want).max(axis=2))
    # Pillow maps a colour to the palette entry nearest its 5-6-5 bit cell, so even the paper comes
    # out a level or two off: the palette made from the frames themselves gave 2.7 on average here
    assert np.mean(errors) < 2.5
    assert np.percentile(errors, 99) <= 16
    # the palette is made once a world: the same object for the next run, holding the run's colours
    palette = run_palette(drawn_on[0], _run_colours(tracks))
    assert run_palette(drawn_on[0], _run_colours(tracks)) is palette
    entries = np.array(palette.getpalette()[:768]).reshape(-1, 3).tolist()
    assert all(list(c) in entries for c in _run_colours(tracks))


def test_a_map_path_keeps_a_point_every_pixel_and_its_last() -> None:
    along = np.linspace(0.0, 10.3, 104)  # 0.1 px apart
    at = np.column_stack((along, np.zeros_like(along)))
    kept = plot._pixel_apart(at)
    assert kept[0].tolist() == [0.0, 0.0] and kept[-1].tolist() == at[-1].tolist()
    assert len(kept) == 12  # 0, 1, ..., 10 px and the last
    assert (np.diff(kept[:-1, 0]) >= 1.0 - 1e-9).all()
    still = np.zeros((50, 2))  # a robot that never moved: its one point, twice
    assert len(plot._pixel_apart(still)) == 2
