"""Animations: ``labsim plot TRACE -o run.gif`` (or ``.mp4``) plays a finished run back.

A stage after the run, beside the still map: each frame is the map of
``labsim.runtime.pictures.plot`` without the run on it (its backdrop: the world, grid, title and
legend, drawn once), and on it, at the frame's simulated time, every robot's path fading
from old to recent, the robot itself with its heading, or a mechanism in that tick's pose
(``labsim.runtime.pictures.mechanism_pose``); a caption under the map gives the time, each robot's
state and rule, the slider labels, and a top view of the slew when the arm turned.

Long runs are sampled, not refused: by default a frame shows the tick at its time and the
playback speeds up so that the animation lasts at most ``MAX_SECONDS``. Each frame draws only
what changed since the one before (the paths through ``labsim.runtime.pictures.trail``), so a
frame costs the same however long the run, and goes to the file as soon as it is made
(``labsim.runtime.pictures.movie``: MP4 through ffmpeg, GIF with one palette), so memory stays
flat however many frames there are.
"""
from __future__ import annotations

import contextlib
import io
import itertools
import math
from collections.abc import Generator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from labsim.backends.scene.world import World
from labsim.foundation.files import Output
from labsim.runtime.pictures.mechanism_pose import draw_pose, mechanism_poses, slew_inset
from labsim.runtime.pictures.movie import GifWriter, MovieWriter, Mp4Writer, run_palette
from labsim.runtime.pictures.paint import (
    AA,
    COLLISION,
    INK,
    MUTED,
    ONE,
    PAPER,
    SHIFT,
    WARNING,
    Painter,
    darker,
    event_colour,
    robot_colour,
)
from labsim.runtime.pictures.plot import render_figure
from labsim.runtime.pictures.trail import Box, TrailPoints, Trails, pale
from labsim.runtime.trace import Trace, TraceFormatError, trace_world

MAX_SECONDS = 30.0  # the default longest animation: a run longer than this plays faster
FADE_S = 0.15  # the share of the run shown at full strength behind a robot; older path is pale
MAX_FRAMES = 3000
STEP_PX = 2.0  # an animation's path keeps a pose every this many pixels along it


DEFAULT_RADIUS_M = 0.22  # a robot whose model the trace does not name: a Pioneer's size


def model_radius(model: object) -> float:
    """How far a robot model's outline reaches from the middle of its axle, metres."""
    from labsim.backends.scene.models import MODELS

    m = MODELS.get(str(model))
    if m is None or not m.footprint:
        return DEFAULT_RADIUS_M
    return max(math.hypot(x, y) for x, y in m.footprint)


@dataclass(frozen=True)
class Track:
    """One robot's rows: times and poses, and the trace rows they came from."""

    name: str
    colour: tuple[int, int, int]
    t: np.ndarray
    xy: np.ndarray  # (n, 2) metres
    heading: np.ndarray
    rows: np.ndarray  # indices into trace.rows
    radius_m: float = DEFAULT_RADIUS_M  # its model's reach from the axle's middle (the trace's header names the model)


# what an animation of robots reads of a trace (its tracks, captions, and the backdrop's legend
# of events), with what ``labsim plot`` reads before it draws (--from/--to, the world's bounds)
MOVIE_COLUMNS = ("tick", "time", "robot", "x", "y", "heading", "collided", "state", "rule", "events")


def movie_columns(path: str, header: dict, columns: list[str]) -> list[str] | None:
    """The columns an animation of this trace reads (``read_for_picture``'s ``wanted``): None,
    all of them, for a mechanism, whose joints and labels have columns of their own."""
    world, _ = trace_world(Trace(path, header, columns, []))
    if world is not None and world.mechanism is not None:
        return None
    return [c for c in columns if c in MOVIE_COLUMNS]


def _numbers(trace: Trace, name: str) -> np.ndarray:
    """A column as floats, nan where a cell is not a number (or the column is missing)."""
    if name in trace.numbers:  # a run recorded in memory: numbers already
        return trace.numbers[name]
    if name not in trace.columns:
        return np.full(len(trace.rows), math.nan)
    cells = trace.column(name)
    try:
        return np.array(cells, dtype=float)
    except ValueError:
        return np.array([_number(c) for c in cells], dtype=float)


def _number(cell: str) -> float:
    try:
        return float(cell)
    except ValueError:
        return math.nan


def _tracks(trace: Trace) -> list[Track]:
    for needed in ("time", "robot", "x", "y"):
        if needed not in trace.columns:
            raise TraceFormatError(f"{trace.path}: the trace has no '{needed}' column")
    t, x, y, heading = (_numbers(trace, c) for c in ("time", "x", "y", "heading"))
    robot = np.array(trace.column("robot"), dtype=object)
    models = trace.header.get("robots")
    models = models if isinstance(models, dict) else {}
    out = []
    for k, name in enumerate(dict.fromkeys(robot)):
        idx = np.flatnonzero(robot == name)
        out.append(Track(str(name), robot_colour(k), t[idx], np.column_stack((x[idx], y[idx])), heading[idx], idx,
                         model_radius(models.get(str(name)))))
    return out


def _caption(trace: Trace, tr: Track, i: int) -> str:
    """"state (rule)" of the robot's i-th row, or '' when the trace has no state there."""
    if "state" not in trace.columns or "rule" not in trace.columns:
        return ""
    row = trace.rows[int(tr.rows[i])]
    state = row[trace.columns.index("state")]
    return f"{state} ({row[trace.columns.index('rule')]})" if state else ""


def frame_times(t0: float, t1: float, fps: float, speed: float) -> np.ndarray:
    """The simulated time each frame shows: ``speed`` simulated seconds per second of video."""
    n = min(MAX_FRAMES, max(1, math.floor((t1 - t0) / speed * fps + 1e-9) + 1))
    return t0 + np.arange(n) * speed / fps


def default_speed(duration_s: float) -> float:
    """Real time, or faster so the animation lasts at most MAX_SECONDS."""
    return max(1.0, duration_s / MAX_SECONDS)


def animate(trace: Trace, out: Path, *, width_px: int = 720, fps: float | None = None,
            speed: float | None = None, world: tuple[World | None, str] | None = None) -> int:
    """Write the animation to ``out`` (.gif or .mp4); returns the number of frames. ``world``:
    the trace's world and note (``trace_world``) when the caller has read them already."""
    world = world or trace_world(trace)  # read once: it is a YAML file, parsed anew each time
    gif = out.suffix.lower() == ".gif"
    fps = fps or (10.0 if gif else 20.0)
    tracks = _tracks(trace)
    t0 = min(float(tr.t[0]) for tr in tracks)
    t1 = max(float(tr.t[-1]) for tr in tracks)
    times = frame_times(t0, t1, fps, speed or default_speed(t1 - t0))
    # written beside the target under a name with the same suffix, renamed into place when whole
    target = Output(out, partial=out.with_name(f".{out.stem}.partial{out.suffix}"))
    changed: list[Box] = []  # where each frame differs from the one before: an MP4 converts only that
    made = frames(trace, tracks, times, width_px, known=world, changed=changed)
    writer: MovieWriter | None = None
    n = 0
    try:
        if gif:
            # the palette from what the frames show: the backdrop and the run's last frame
            first, last = next(made), frame_at(trace, tracks, times, width_px, world)
            writer = GifWriter(target.file, np.vstack((first, last)), fps)
        else:
            target.file.close()  # ffmpeg opens it by name
            first = next(made)
            writer = Mp4Writer(target.partial, (first.shape[1], first.shape[0]), fps)
        for frame in itertools.chain([first], made):
            writer.append(frame, changed)
            n += 1
        writer.close()
    except BaseException:
        made.close()
        if writer is not None:
            with contextlib.suppress(Exception):
                writer.close()
        target.discard()
        raise
    target.commit()
    return n


def gif_bytes(trace: Trace, *, width_px: int, fps: float, speed: float,
              world: tuple[World | None, str]) -> bytes:
    """An animated GIF in memory, as ``animate`` writes one (a feedback page's short one): its
    frames are kept until the last, whose colours the palette needs too, rather than drawing the
    last one twice; for a few frames only."""
    tracks = _tracks(trace)
    t0 = min(float(tr.t[0]) for tr in tracks)
    t1 = max(float(tr.t[-1]) for tr in tracks)
    drawn_on: list[np.ndarray] = []
    made = frames(trace, tracks, frame_times(t0, t1, fps, speed), width_px, known=world, drawn_on=drawn_on)
    first = next(made)
    out = io.BytesIO()
    writer = GifWriter(out, None, fps, palette=run_palette(drawn_on[0], _run_colours(tracks)))
    for frame in itertools.chain([first], made):
        writer.append(frame)
    writer.close()
    return out.getvalue()


def _run_colours(tracks: list[Track]) -> list[tuple[int, int, int]]:
    """What a run's frames draw over their background: each robot's path, pale path, outline,
    caption and markers, the text, a collision's cross and the events' triangles."""
    robots = [c for tr in tracks for c in (tr.colour, pale(tr.colour), darker(tr.colour, 0.5),
                                             darker(tr.colour, 0.8), darker(tr.colour))]
    events = [c for k in range(4) for c in (event_colour(k), darker(event_colour(k), 0.45))]
    return [PAPER, INK, MUTED, COLLISION, WARNING, *robots[:30], *events]


def frame_at(trace: Trace, tracks: list[Track], times: np.ndarray, width_px: int,
             world: tuple[World | None, str] | None = None) -> np.ndarray:
    """The last of these frames alone (its paths drawn in one step)."""
    made = frames(trace, tracks, times[-1:], width_px, fade_s=_fade(times), known=world)
    try:
        return next(made)
    finally:
        made.close()


def _fade(times: np.ndarray) -> float:
    return FADE_S * max(float(times[-1] - times[0]), 1e-9)


def frames(trace: Trace, tracks: list[Track], times: np.ndarray, width_px: int,
           fade_s: float | None = None, known: tuple[World | None, str] | None = None,
           changed: list[Box] | None = None, drawn_on: list[np.ndarray] | None = None,
           ) -> Generator[np.ndarray, None, None]:
    """BGR frames, one per time, all the same size (a multiple of 16 each way, as H.264 likes);
    a path is pale where older than ``fade_s`` (by default a share of the frames' span). A frame
    is drawn over by the next: copy it to keep it. ``changed``, when given, holds at each frame the
    boxes outside which it equals the frame before (the whole frame for the first); ``drawn_on``
    gets the backdrop's ``Figure.background`` before the first frame."""
    # one function for one frame's layers: the backdrop, the paths, the robots, the caption
    world, note = known or trace_world(trace)  # ``known``: read by the caller already
    fig = render_figure(trace, width_px=width_px, world=world, world_note=note, backdrop=True)
    if drawn_on is not None and fig.background is not None:
        drawn_on.append(fig.background)
    P = Painter(width_px)
    mech = world.mechanism if world is not None else None
    poses = mechanism_poses(trace, mech) if mech is not None else None
    inset = round(150 * P.s) if poses is not None and poses.slew is not None else 0
    labels = [c for c in trace.columns if c.startswith("label:")]
    lines = 1 + (len(labels) if mech is not None else len(tracks))
    band = max(P.line_h * lines + P.pad, inset + 2 * P.pad)
    H, W = -(-(fig.image.shape[0] + band) // 16) * 16, -(-fig.image.shape[1] // 16) * 16
    base = np.full((H, W, 3), PAPER, np.uint8)
    base[: fig.image.shape[0], : fig.image.shape[1]] = fig.image

    def px(xy: np.ndarray) -> np.ndarray:
        out = np.empty_like(xy, dtype=float)
        out[:, 0] = fig.left + (xy[:, 0] - fig.xmin) / fig.m_per_px
        out[:, 1] = fig.top + (fig.ymax - xy[:, 1]) / fig.m_per_px
        return out

    fade = _fade(times) if fade_s is None else fade_s
    top = fig.image.shape[0]
    trails = Trails(base, [_points(tr, px) for tr in tracks], max(2, round(2 * P.s)))
    for f, t in enumerate(times):
        at = [max(0, int(np.searchsorted(tr.t, t, side="right")) - 1) for tr in tracks]
        img = trails.advance(at, t - fade)
        whole = mech is not None or f == 0
        if mech is not None and poses is not None:
            img = img.copy()  # a mechanism's bodies reach anywhere: drawn on a copy
            draw_pose(img, mech, poses, int(tracks[0].rows[at[0]]), px, P, fixed=False)
        else:
            for tr, i in zip(tracks, at):
                trails.drawn_over(_robot(img, P, px, tr, i, fig.m_per_px))
        trails.drawn_over((0, top, W, H))  # the caption
        y = top + round(4 * P.s)
        P.put(img, f"t = {t:7.2f} s", (P.pad, y + P.line_h // 2), P.text, INK, thick=max(1, round(1.6 * P.s)))
        row = trace.rows[int(tracks[0].rows[at[0]])]
        texts = ([f"{row[trace.columns.index(c)]}" for c in labels] if mech is not None
                 else [f"{tr.name}: {_caption(trace, tr, i)}" for tr, i in zip(tracks, at)])
        for k, text in enumerate(texts):
            colour = tracks[k].colour if mech is None else INK
            P.put(img, text, (P.pad, y + P.line_h * (k + 1) + P.line_h // 2), P.text, darker(colour, 0.8),
                  max_w=W - 2 * P.pad - inset)
        if inset and mech is not None and poses is not None:
            slew_inset(img, P, mech, trace, (W - inset - P.pad, top + P.pad // 2, inset),
                       i=int(tracks[0].rows[at[0]]), poses=poses)
        if changed is not None:
            changed[:] = [(0, 0, W, H)] if whole else trails.changed()
        yield img


def _points(tr: Track, px: object) -> TrailPoints:
    """A track's finite poses in fixed-point pixels, for its trail: one every ``STEP_PX`` along
    the path (the rest lie on the line between them to a tenth of a pixel, and each costs a
    segment to draw)."""
    assert callable(px)
    ok = np.flatnonzero(np.isfinite(tr.xy).all(axis=1))
    at = px(tr.xy[ok]) if len(ok) else np.zeros((0, 2))
    along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(at, axis=0).T)))) if len(ok) else np.zeros(0)
    step = np.floor(along / STEP_PX)
    keep = np.diff(step, prepend=-1.0) > 0
    if len(keep):
        keep[-1] = True
    kept = np.zeros(len(tr.t), bool)
    kept[ok[keep]] = True
    return TrailPoints(tr.colour, np.round(at[keep] * ONE).astype(np.int32), tr.t[ok][keep], np.cumsum(kept))


def _robot(img: np.ndarray, P: Painter, px: object, tr: Track, i: int, mpp: float) -> Box:
    """The robot as a disc of its model's size (never under a few pixels) with a line for its
    heading, as long as the robot is wide (an e-puck's 7 cm, not a fixed third of a metre);
    returns the box it was drawn in."""
    assert callable(px)
    if not np.isfinite(tr.xy[i]).all():
        return (0, 0, 0, 0)
    c = px(tr.xy[i : i + 1])[0]
    r = max(tr.radius_m / mpp, 5 * P.s)
    centre = tuple(np.round(c * ONE).astype(int))
    cv2.circle(img, centre, round(r * ONE), tr.colour, -1, AA, SHIFT)
    cv2.circle(img, centre, round(r * ONE), darker(tr.colour, 0.5), max(1, P.lw), AA, SHIFT)
    h = float(tr.heading[i])
    nose = max(1.6 * r, r + 3 * P.s)  # past the outline, in proportion to it
    if math.isfinite(h):
        tip = c + nose * np.array([math.cos(h), -math.sin(h)])
        cv2.line(img, centre, tuple(np.round(tip * ONE).astype(int)), darker(tr.colour, 0.5),
                 max(1, round(min(2 * P.s, r / 2))), AA, SHIFT)
    reach = nose + 2 * P.s + 3  # the heading line's tip, its width and its antialiased edge
    if not (abs(c) < 1e6).all():
        return (0, 0, img.shape[1], img.shape[0])
    return (int(c[0] - reach), int(c[1] - reach), int(c[0] + reach) + 2, int(c[1] + reach) + 2)
