"""Animations: ``labsim plot TRACE -o run.gif`` (or ``.mp4``) plays a finished run back.

A stage after the run, beside the still map: each frame is the map of
``labsim.runtime.pictures.plot`` without the run on it (its backdrop: the world, grid, title and
legend, drawn once), and on it, at the frame's simulated time, every robot's path fading
from old to recent, the robot itself with its heading, or a mechanism in that tick's pose
(``labsim.runtime.pictures.mechanism_pose``); a caption under the map gives the time, each robot's
state and rule, the slider labels, and a top view of the slew when the arm turned.

Long runs are sampled, not refused: by default a frame shows the tick at its time and the
playback speeds up so that the animation lasts at most ``MAX_SECONDS``. Frames are encoded
with imageio: MP4 through its ffmpeg plugin (H.264, yuv420p, which browsers play), GIF
through Pillow. Frames are made one at a time, so memory stays flat for an MP4.
"""
from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from labsim.foundation.files import Output
from labsim.runtime.pictures.mechanism_pose import draw_pose, mechanism_poses, slew_inset
from labsim.runtime.pictures.paint import AA, INK, ONE, PAPER, SHIFT, Painter, darker, robot_colour
from labsim.runtime.pictures.plot import render_figure
from labsim.runtime.trace import Trace, TraceFormatError, trace_world

MAX_SECONDS = 30.0  # the default longest animation: a run longer than this plays faster
FADE_S = 0.15  # the share of the run shown at full strength behind a robot; older path is pale
MAX_FRAMES = 3000


@dataclass
class Track:
    """One robot's rows: times, poses, states and rules, and the trace rows they came from."""

    name: str
    colour: tuple[int, int, int]
    t: np.ndarray
    xy: np.ndarray  # (n, 2) metres
    heading: np.ndarray
    caption: list[str]  # "state (rule)" per row
    rows: np.ndarray  # indices into trace.rows


def _tracks(trace: Trace) -> list[Track]:
    for needed in ("time", "robot", "x", "y"):
        if needed not in trace.columns:
            raise TraceFormatError(f"{trace.path}: the trace has no '{needed}' column")
    col = {c: i for i, c in enumerate(trace.columns)}

    def num(row: list[str], c: str) -> float:
        try:
            return float(row[col[c]]) if c in col else math.nan
        except ValueError:
            return math.nan

    names = list(dict.fromkeys(r[col["robot"]] for r in trace.rows))
    out = []
    for k, name in enumerate(names):
        idx = np.array([i for i, r in enumerate(trace.rows) if r[col["robot"]] == name])
        rows = [trace.rows[i] for i in idx]
        caption = [f"{r[col['state']]} ({r[col['rule']]})" if "state" in col and "rule" in col and r[col["state"]]
                   else "" for r in rows]
        out.append(Track(name, robot_colour(k), np.array([num(r, "time") for r in rows]),
                         np.array([(num(r, "x"), num(r, "y")) for r in rows]),
                         np.array([num(r, "heading") for r in rows]), caption, idx))
    return out


def frame_times(t0: float, t1: float, fps: float, speed: float) -> np.ndarray:
    """The simulated time each frame shows: ``speed`` simulated seconds per second of video."""
    n = min(MAX_FRAMES, max(1, math.floor((t1 - t0) / speed * fps + 1e-9) + 1))
    return t0 + np.arange(n) * speed / fps


def default_speed(duration_s: float) -> float:
    """Real time, or faster so the animation lasts at most MAX_SECONDS."""
    return max(1.0, duration_s / MAX_SECONDS)


def animate(trace: Trace, out: Path, *, width_px: int = 720, fps: float | None = None,
            speed: float | None = None) -> int:
    """Write the animation to ``out`` (.gif or .mp4); returns the number of frames."""
    import imageio.v2 as imageio

    gif = out.suffix.lower() == ".gif"
    fps = fps or (10.0 if gif else 20.0)
    tracks = _tracks(trace)
    t0 = min(float(tr.t[0]) for tr in tracks)
    t1 = max(float(tr.t[-1]) for tr in tracks)
    times = frame_times(t0, t1, fps, speed or default_speed(t1 - t0))
    # written beside the target under a name with the same suffix, renamed into place when whole
    target = Output(out, partial=out.with_name(f".{out.stem}.partial{out.suffix}"))
    target.file.close()  # the writer opens it by name
    if gif:
        writer = imageio.get_writer(target.partial, mode="I", duration=1000 / fps, loop=0)
    else:
        writer = imageio.get_writer(target.partial, format="FFMPEG", mode="I", fps=fps, codec="libx264",
                                    pixelformat="yuv420p", macro_block_size=16, ffmpeg_log_level="error")
    n = 0
    try:
        for frame in frames(trace, tracks, times, width_px):
            writer.append_data(frame)
            n += 1
        writer.close()
    except BaseException:
        writer.close()
        target.discard()
        raise
    target.commit()
    return n


def frames(trace: Trace, tracks: list[Track], times: np.ndarray, width_px: int) -> Iterator[np.ndarray]:
    """RGB frames, one per time, all the same size (a multiple of 16 each way, as H.264 likes)."""
    world, note = trace_world(trace)
    fig = render_figure(trace, width_px=width_px, world=world, world_note=note, backdrop=True)
    P = Painter(width_px)
    mech = world.mechanism if world is not None else None
    poses = mechanism_poses(trace, mech) if mech is not None else None
    inset = round(150 * P.s) if poses is not None and poses.slew is not None else 0
    labels = [c for c in trace.columns if c.startswith("label:")]
    lines = 1 + (len(labels) if mech is not None else len(tracks))
    band = max(P.line_h * lines + P.pad, inset + 2 * P.pad)
    h, w = fig.image.shape[0] + band, fig.image.shape[1]
    H, W = -(-h // 16) * 16, -(-w // 16) * 16
    base = np.full((H, W, 3), PAPER, np.uint8)
    base[: fig.image.shape[0], : fig.image.shape[1]] = fig.image

    def px(xy: np.ndarray) -> np.ndarray:
        out = np.empty_like(xy, dtype=float)
        out[:, 0] = fig.left + (xy[:, 0] - fig.xmin) / fig.m_per_px
        out[:, 1] = fig.top + (fig.ymax - xy[:, 1]) / fig.m_per_px
        return out

    fade = FADE_S * max(float(times[-1] - times[0]), 1e-9)
    top = fig.image.shape[0]
    for t in times:
        img = base.copy()
        at = [max(0, int(np.searchsorted(tr.t, t, side="right")) - 1) for tr in tracks]
        for tr, i in zip(tracks, at):
            _path(img, P, px, tr, i, t - fade)
        if mech is not None and poses is not None:
            draw_pose(img, mech, poses, int(tracks[0].rows[at[0]]), px, P, fixed=False)
        else:
            for tr, i in zip(tracks, at):
                _robot(img, P, px, tr, i, fig.m_per_px)
        y = top + round(4 * P.s)
        P.put(img, f"t = {t:7.2f} s", (P.pad, y + P.line_h // 2), P.text, INK, thick=max(1, round(1.6 * P.s)))
        row = trace.rows[int(tracks[0].rows[at[0]])]
        texts = ([f"{row[trace.columns.index(c)]}" for c in labels] if mech is not None
                 else [f"{tr.name}: {tr.caption[i]}" for tr, i in zip(tracks, at)])
        for k, text in enumerate(texts):
            colour = tracks[k].colour if mech is None else INK
            P.put(img, text, (P.pad, y + P.line_h * (k + 1) + P.line_h // 2), P.text, darker(colour, 0.8),
                  max_w=W - 2 * P.pad - inset)
        if inset and mech is not None and poses is not None:
            slew_inset(img, P, mech, trace, (W - inset - P.pad, top + P.pad // 2, inset),
                       i=int(tracks[0].rows[at[0]]), poses=poses)
        yield cv2.cvtColor(img, cv2.COLOR_BGR2RGB)


def _path(img: np.ndarray, P: Painter, px: object, tr: Track, i: int, recent_from: float) -> None:
    """The path up to row i: pale where it is old, the robot's colour for the recent part."""
    assert callable(px)
    xy = tr.xy[: i + 1]
    ok = np.isfinite(xy).all(axis=1)
    if ok.sum() < 2:
        return
    pts = np.round(px(xy[ok]) * ONE).astype(np.int32).reshape(-1, 1, 2)
    split = int(np.searchsorted(tr.t[: i + 1][ok], recent_from))
    pale = tuple(int(c + (255 - c) * 0.6) for c in tr.colour)
    width = max(2, round(2 * P.s))
    if split > 1:
        cv2.polylines(img, [pts[: split + 1]], False, pale, width, AA, SHIFT)
    if len(pts) - split > 1:
        cv2.polylines(img, [pts[max(0, split):]], False, tr.colour, width, AA, SHIFT)


def _robot(img: np.ndarray, P: Painter, px: object, tr: Track, i: int, mpp: float) -> None:
    """The robot as a disc of its size (never under a few pixels) with a line for its heading."""
    assert callable(px)
    if not np.isfinite(tr.xy[i]).all():
        return
    c = px(tr.xy[i : i + 1])[0]
    r = max(0.22 / mpp, 5 * P.s)
    centre = tuple(np.round(c * ONE).astype(int))
    cv2.circle(img, centre, round(r * ONE), tr.colour, -1, AA, SHIFT)
    cv2.circle(img, centre, round(r * ONE), darker(tr.colour, 0.5), max(1, P.lw), AA, SHIFT)
    h = float(tr.heading[i])
    if math.isfinite(h):
        tip = c + (r + 10 * P.s) * np.array([math.cos(h), -math.sin(h)])
        cv2.line(img, centre, tuple(np.round(tip * ONE).astype(int)), darker(tr.colour, 0.5),
                 max(2, round(2 * P.s)), AA, SHIFT)
