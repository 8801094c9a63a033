"""Trace plots: ``labsim plot TRACE -o out.png`` draws a finished run as one picture.

This is the last stage of the pipeline: ``labsim.runtime.run`` writes a trace (see
``labsim.runtime.trace``), and this module reads it back with the world it names and draws,
to scale and with OpenCV only, the floor and what is painted on it (roads, lines, patches, when
the world has a ground), the room's walls and blocks, every robot's path with its start,
end and heading, the ticks it collided and the metric events it raised, and a legend and title
that say which behaviour, world, seed and backend made the run; on a world with a road, a panel
under the map of each robot's offset from the centreline (``labsim.runtime.pictures.road_panel``).
``render_figure`` builds the image in memory (tests and other front ends use it); ``plot_trace``
also writes the file.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from labsim.backends.scene.ground import Ground
from labsim.backends.scene.world import World, first_road
from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.files import write_output
from labsim.runtime.pictures.map_frame import Figure, RobotPath, grid, legend
from labsim.runtime.pictures.mechanism_pose import draw_run_mechanism, has_slew, slew_inset
from labsim.runtime.pictures.paint import (
    AA,
    BLOCK_EDGE,
    BLOCK_FILL,
    FRAME,
    INK,
    MAP_BG,
    MUTED,
    ONE,
    PAPER,
    SHIFT,
    TITLE_FONT,
    WARNING,
    Painter,
    PxMap,
    bgr,
    darker,
    draw_ground,
    draw_wall,
    event_colour,
    robot_colour,
)
from labsim.runtime.pictures.road_panel import draw_road_panel, panel_height
from labsim.runtime.pictures.trace_sample import read_for_picture
from labsim.runtime.trace import Trace, TraceFormatError, trace_world

MIN_WIDTH_PX = 400
PATH_STEP_PX = 1.0  # a map's path keeps a point every this many pixels along it

# -- the data ----------------------------------------------------------------------------------

def _floats(trace: Trace, name: str) -> np.ndarray:
    if name in trace.numbers:  # a run recorded in memory: numbers already
        return trace.numbers[name]
    i = trace.columns.index(name)
    try:
        return np.array([r[i] for r in trace.rows], dtype=float)
    except ValueError:
        bad = next(r[i] for r in trace.rows if not _is_float(r[i]))
        raise TraceFormatError(f"{trace.path}: column '{name}' holds '{bad}', not a number") from None


def _is_float(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def robot_paths(trace: Trace) -> list[RobotPath]:
    """Split the rows by robot (header order first) and pick out collisions and events."""
    for needed in ("robot", "x", "y"):
        if needed not in trace.columns:
            raise TraceFormatError(f"{trace.path}: the trace has no '{needed}' column")
    xs, ys = _floats(trace, "x"), _floats(trace, "y")
    heading = _floats(trace, "heading") if "heading" in trace.columns else np.full(len(xs), np.nan)
    collided = (_floats(trace, "collided") > 0.5) if "collided" in trace.columns else np.zeros(len(xs), bool)
    column = trace.column("robot")
    seen = dict.fromkeys(column)  # each name once, in the order of the rows
    names = np.array(column, dtype=object)
    models = trace.header.get("robots") or {}
    order = list(dict.fromkeys([*(n for n in models if n in seen), *seen]))
    ei = trace.columns.index("events") if "events" in trace.columns else -1
    cells = trace.column("events") if ei >= 0 else []
    # most rows have no events: the rows that have are found in C, not looked at one by one
    with_events = np.fromiter(map(bool, cells), bool, len(cells))

    paths = []
    for k, name in enumerate(order):
        # rows are tick-ordered, so this is the path in time
        idx = np.arange(len(column)) if len(seen) == 1 else np.flatnonzero(names == name)
        x, y = xs[idx], ys[idx]
        ok = np.isfinite(x) & np.isfinite(y)
        c = collided[idx]
        # a collision is its first tick; the robot grinding along a wall is one collision
        onset = c & ~np.concatenate(([False], c[:-1]))
        hit = onset & ok
        events: dict[str, list[int]] = {}
        if ei >= 0:
            for j in idx[with_events[idx]]:
                for ev in cells[j].split(";"):
                    if ev:
                        events.setdefault(ev, []).append(int(j))
        h = heading[idx][ok]
        paths.append(RobotPath(
            name=str(name), model=str(models.get(name, "")), colour=robot_colour(k),
            xy=np.column_stack((x[ok], y[ok])), heading=float(h[-1]) if len(h) else math.nan,
            collisions=np.column_stack((x[hit], y[hit])),
            events={ev: np.column_stack((xs[js], ys[js]))[np.isfinite(xs[js]) & np.isfinite(ys[js])]
                    for ev, js in events.items()},
        ))
    return paths


# -- the layout --------------------------------------------------------------------------------

def _extents(world: World | None, paths: list[RobotPath]) -> tuple[float, float, float, float]:
    xs: list[float] = []
    ys: list[float] = []
    if world is not None:
        xs += [world.bounds[0], world.bounds[2]]
        ys += [world.bounds[1], world.bounds[3]]
        for w in world.walls:
            r = w.thickness_m / 2
            xs += [w.a[0] - r, w.a[0] + r, w.b[0] - r, w.b[0] + r]
            ys += [w.a[1] - r, w.a[1] + r, w.b[1] - r, w.b[1] + r]
        for b in world.blocks:
            xs += [c[0] for c in b.corners]
            ys += [c[1] for c in b.corners]
        for body in world.mechanism.bodies if world.mechanism is not None else ():
            xs += [c[0] for c in body.corners()]
            ys += [c[1] for c in body.corners()]
        ground_ext = world.ground.extent() if isinstance(world.ground, Ground) else None
        if ground_ext is not None:
            xs += [ground_ext[0], ground_ext[2]]
            ys += [ground_ext[1], ground_ext[3]]
    for p in paths:
        if len(p.xy):
            xs += [float(p.xy[:, 0].min()), float(p.xy[:, 0].max())]
            ys += [float(p.xy[:, 1].min()), float(p.xy[:, 1].max())]
    if not xs:
        return (-1.0, -1.0, 1.0, 1.0)
    x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
    # a margin so markers at the edge stay whole, and a floor so a robot that never moved
    # still gets a readable few metres around it
    margin = max(0.04 * max(x1 - x0, y1 - y0), 0.3)
    cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
    hw, hh = max((x1 - x0) / 2 + margin, 1.0), max((y1 - y0) / 2 + margin, 1.0)
    return (cx - hw, cy - hh, cx + hw, cy + hh)


# -- drawing -----------------------------------------------------------------------------------

def render_figure(trace: Trace, *, width_px: int = 1000, world: World | None = None,
                  world_note: str | None = None, backdrop: bool = False) -> Figure:
    """Draw a trace; the world is looked up from its header unless given.

    A ``backdrop`` is the figure without the run on it (no paths, a mechanism's fixed parts
    only): what ``labsim.runtime.pictures.animate`` draws each frame on.
    """
    if not isinstance(width_px, int) or width_px < MIN_WIDTH_PX:
        raise ValueError(f"plot width must be at least {MIN_WIDTH_PX} px (got {width_px})")
    if world is None and world_note is None:
        world, world_note = trace_world(trace)
    world_note = world_note or ""
    paths = robot_paths(trace)
    events = _event_names(trace.header, paths)
    P = Painter(width_px)
    at = _layout(trace, P, width_px, world, paths, events, 3 if world_note else 2, backdrop)
    panels = (("road panel",) if at.road else ()) + (("slew panel",) if at.inset else ())
    base = _background(world, width_px, at)
    img = base.copy()
    fig = Figure(img, at.x0, at.y1, at.mpp, at.map_left, at.map_top, panels, base)
    _draw_map(img, P, fig, at, trace, world, paths, events, backdrop)
    _draw_title(img, P, trace, world, paths, world_note, at.map_left)
    if at.road and world is not None:
        draw_road_panel(img, P, world, [(p.name, p.colour, p.xy) for p in paths],
                        (at.map_left, at.map_top + at.map_h + at.bottom_axis, at.map_w, at.panel_h))
    legend_x = at.map_left + at.map_w + round(22 * P.s)
    legend_end = legend(img, P, paths, events, legend_x, at.map_top, at.map_h, at.mpp, at.inset)
    if at.inset and world is not None and world.mechanism is not None:
        slew_inset(img, P, world.mechanism, trace, (legend_x, legend_end, at.inset))
    return fig


@dataclass(frozen=True)
class _Layout:
    """Where one figure's parts go: the map (its extent in metres, its box in pixels), the
    legend's inset and the road panel under the map; the title fills the rows above the map."""

    height: int  # of the whole figure, pixels
    x0: float  # the map's extent, metres
    y0: float
    x1: float
    y1: float
    mpp: float  # metres per pixel, the same on both axes
    map_left: int
    map_top: int
    map_w: int
    map_h: int
    bottom_axis: int  # rows under the map for the x axis' labels
    inset: int  # the side of the slew's top view under the legend; 0: none
    road: bool  # a road panel under the map
    panel_h: int

    def px(self, xy: np.ndarray) -> np.ndarray:
        """Metres (an (n, 2) array) to the figure's pixel coordinates."""
        out = np.empty_like(xy, dtype=float)
        out[:, 0] = self.map_left + (xy[:, 0] - self.x0) / self.mpp
        out[:, 1] = self.map_top + (self.y1 - xy[:, 1]) / self.mpp
        return out


def _layout(trace: Trace, P: Painter, width_px: int, world: World | None, paths: list[RobotPath],
            events: list[str], title_lines: int, backdrop: bool) -> _Layout:
    """One layout that the map, the road panel, the title and the legend share."""
    s, pad = P.s, P.pad
    title_h = round((20 + 24 * title_lines) * s)
    # the map: equal metres per pixel on both axes, sized by the width left after the axis
    # labels and the legend column; very tall worlds are capped so the image stays sane
    left_axis, bottom_axis = round(50 * s), round(46 * s)
    legend_w = round(235 * s)
    x0, y0, x1, y1 = _extents(world, paths)
    avail_w = width_px - left_axis - legend_w - pad
    mpp = (x1 - x0) / avail_w
    if (y1 - y0) / mpp > 1.5 * avail_w:
        mpp = (y1 - y0) / (1.5 * avail_w)
    map_w, map_h = round((x1 - x0) / mpp), round((y1 - y0) / mpp)
    map_left = left_axis + (avail_w - map_w) // 2
    map_top = title_h

    legend_h = P.line_h * (len(paths) + len(events) + 9)
    inset = 0  # a top view of the slew, under the legend, when the run turned the arm
    if world is not None and world.mechanism is not None and not backdrop and has_slew(trace, world.mechanism):
        inset = legend_w - pad
        legend_h += inset + P.line_h
    # the road panel: lateral error, invisible at the map's scale, along the distance driven
    road = not backdrop and world is not None and world.mechanism is None and first_road(world) is not None
    panel_h = panel_height(P) if road else 0
    height = max(map_top + map_h + bottom_axis + panel_h, map_top + legend_h) + pad
    return _Layout(height, x0, y0, x1, y1, mpp, map_left, map_top, map_w, map_h, bottom_axis, inset, road,
                   panel_h)


def _background(world: World | None, width_px: int, at: _Layout) -> np.ndarray:
    """The figure before the run is drawn on it: the paper, the map's floor, its grid and axes,
    and the world; the same pixels for every run of a world at one size, so drawn once a
    process (``labsim grade`` draws a map and a GIF for each student of a class in one world).
    Read-only: copy it to draw on. A world that cannot be a key (unhashable) is drawn each time."""
    try:
        return _cached_background(world, width_px, at)
    except TypeError:  # an unhashable world
        return _draw_background(world, width_px, at)


@functools.lru_cache(maxsize=8)  # a few worlds at two sizes (a feedback page's map and GIF)
def _cached_background(world: World | None, width_px: int, at: _Layout) -> np.ndarray:
    img = _draw_background(world, width_px, at)
    img.flags.writeable = False  # shared by every later figure: drawn on only through a copy
    return img


def _draw_background(world: World | None, width_px: int, at: _Layout) -> np.ndarray:
    P = Painter(width_px)
    img = np.full((at.height, width_px, 3), PAPER, np.uint8)
    fig = Figure(img, at.x0, at.y1, at.mpp, at.map_left, at.map_top, ())
    box = (at.map_left, at.map_top), (at.map_left + at.map_w, at.map_top + at.map_h)
    ground = world.ground if world is not None and isinstance(world.ground, Ground) else None
    # a ground's floor colour replaces the map's background; the grid stays visible on it
    floor = bgr(ground.floor_rgb) if ground is not None else MAP_BG
    cv2.rectangle(img, *box, floor, -1)
    grid(img, P, fig, at.map_w, at.map_h, (at.x0, at.y0, at.x1, at.y1),
         "z (m)" if world is not None and world.mechanism is not None else "y (m)")
    _draw_world(img, P, world, ground, at.px, at.mpp)
    return img


def _draw_map(img: np.ndarray, P: Painter, fig: Figure, at: _Layout, trace: Trace, world: World | None,
              paths: list[RobotPath], events: list[str], backdrop: bool) -> None:
    """On the background (``_background``): a mechanism, the run, the map's frame."""
    box = (at.map_left, at.map_top), (at.map_left + at.map_w, at.map_top + at.map_h)
    if world is not None and world.mechanism is not None:
        draw_run_mechanism(img, P, world.mechanism, trace, at.px, backdrop)
    if not backdrop:
        _draw_paths(img, P, paths, events, at.px, world)
    cv2.rectangle(img, *box, FRAME, P.lw)


def _draw_title(img: np.ndarray, P: Painter, trace: Trace, world: World | None, paths: list[RobotPath],
                world_note: str, left: int) -> None:
    """The behaviour's name, then the run's particulars, then the note about its world if any."""
    header = trace.header
    title = header.get("name") or Path(str(header.get("behaviour") or trace.path)).stem
    subtitle = "  |  ".join(_run_facts(trace, world, paths))
    title_w = img.shape[1] - left - P.pad
    P.put(img, title, (left, round(34 * P.s)), P.title, INK, TITLE_FONT, max_w=title_w)
    P.put(img, subtitle, (left, round(58 * P.s)), P.text, MUTED, max_w=title_w)
    if world_note:
        P.put(img, world_note, (left, round(82 * P.s)), P.text, WARNING, max_w=title_w)


def _draw_world(img: np.ndarray, P: Painter, world: World | None, ground: Ground | None, px: PxMap,
                mpp: float) -> None:
    """The world under everything: what is painted on the floor, then blocks filled, and walls
    at their real thickness (round ends, as the physics backend models a wall as a thick
    segment), and a mechanism from the side."""
    if ground is not None:
        draw_ground(img, ground, px, mpp)
    if world is not None:
        for b in world.blocks:
            poly = np.round(px(np.array(b.corners, float)) * ONE).astype(np.int32)
            cv2.fillPoly(img, [poly], BLOCK_FILL, AA, SHIFT)
            cv2.polylines(img, [poly], True, BLOCK_EDGE, P.lw, AA, SHIFT)
        for w in world.walls:
            draw_wall(img, px(np.array([w.a, w.b], float)), max(w.thickness_m / mpp, 2.0))


def _draw_paths(img: np.ndarray, P: Painter, paths: list[RobotPath], events: list[str], px: PxMap,
                world: World | None) -> None:
    """Every robot's path, its metric events and collisions, its start, and its end with the
    heading it ended on."""
    s = P.s
    # paths: one polylines call per robot, however long the run
    line_w = max(2, round(2 * s))
    for p in paths:
        if len(p.xy) > 1:
            pts = np.round(_pixel_apart(px(p.xy)) * ONE).astype(np.int32).reshape(-1, 1, 2)
            cv2.polylines(img, [pts], False, p.colour, line_w, AA, SHIFT)
    for k, ev in enumerate(events):
        for p in paths:
            if ev in p.events:
                P.triangles(img, px(p.events[ev]), event_colour(k))
    for p in paths:
        P.crosses(img, px(p.collisions))
    for p in paths:
        if not len(p.xy):
            continue
        ends = px(p.xy[[0, -1]])
        P.start(img, ends[:1], p.colour)
        if math.isfinite(p.heading) and (world is None or world.mechanism is None):
            # the arrow is the robot's last heading: a fixed on-screen length reads better
            # than a metric one, which vanishes in big worlds and swamps small ones
            n = 26 * s
            tip = ends[1] + n * np.array([math.cos(p.heading), -math.sin(p.heading)])
            cv2.arrowedLine(img, tuple(np.round(ends[1] * ONE).astype(int)),
                            tuple(np.round(tip * ONE).astype(int)), darker(p.colour),
                            max(2, round(2 * s)), AA, SHIFT, 0.35)
        P.end(img, ends[1:], p.colour)


def _pixel_apart(at: np.ndarray) -> np.ndarray:
    """A path's points (pixels) one every ``PATH_STEP_PX`` or more along it, and its last: a thick
    antialiased polyline costs a segment and a round join a point, and a run's ticks lie closer
    than a pixel apart at a map's scale (the wall lab's 6,000 poses over some 3,500 pixels)."""
    along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(at, axis=0).T))))
    keep = np.diff(np.floor(along / PATH_STEP_PX), prepend=-1.0) > 0
    keep[-1] = True
    return at[keep]


def _run_facts(trace: Trace, world: World | None, paths: list[RobotPath]) -> list[str]:
    h = trace.header
    facts = [f"world {h.get('world') or (world.name if world else '?')}"]
    if "seed" in h:
        facts.append(f"seed {h['seed']}")
    if h.get("backend"):
        facts.append(f"backend {h['backend']}")
    duration = _duration(trace)
    if duration is not None:
        facts.append(f"{duration:.1f} s simulated")
    if world is not None and world.mechanism is not None:
        facts.append("side view, the path of the last moving body")
    else:
        facts.append(f"{len(paths)} robot{'s' if len(paths) != 1 else ''}")
    return facts


def _duration(trace: Trace) -> float | None:
    """Simulated time: the last row's time plus the tick it stood for."""
    if not trace.rows or "time" not in trace.columns:
        return None
    try:
        times = trace.numbers.get("time")  # a run recorded in memory: numbers only
        last = float(times[-1]) if times is not None else float(trace.rows[-1][trace.columns.index("time")])
    except ValueError:
        return None
    dt = trace.header.get("dt")
    return last + (float(dt) if isinstance(dt, (int, float)) else 0.0)


def _event_names(header: dict, paths: list[RobotPath]) -> list[str]:
    """Count metrics in the header's order (even those that never rose), then any others."""
    declared = [m for m, agg in (header.get("metrics") or {}).items() if agg == "count"]
    seen = [ev for p in paths for ev in p.events]
    return list(dict.fromkeys(declared + seen))


# -- writing -----------------------------------------------------------------------------------

def check_output(out_path: str | Path) -> Path:
    """Fail before any drawing if the image could not be written where asked."""
    out = Path(out_path)
    if out.suffix == "":
        raise ValueError(f"{out}: no image extension; name the file .png (or .jpg, .bmp, ...)")
    if not cv2.haveImageWriter(str(out.with_name("x" + out.suffix.lower()))):
        raise ValueError(f"{out}: OpenCV cannot write '{out.suffix}' images; use .png (or .jpg, .bmp, ...)")
    if out.is_dir():
        raise ValueError(f"{out}: is a directory; give an image file name")
    parent = out.parent
    if not parent.is_dir():
        what = "is not a directory" if parent.exists() else "does not exist"
        raise ValueError(f"{out}: cannot write the plot: directory {parent} {what}")
    return out


def plot_trace(trace_path: str | Path, out_path: str | Path, *, width_px: int = 1000) -> Path:
    """Draw a trace file to an image file; returns the image's path.

    Raises TraceFormatError for an unreadable trace and ValueError for an unwritable output
    (a missing directory, an extension OpenCV can't encode, ...), both with printable messages.
    """
    out = check_output(out_path)
    fig = render_figure(read_for_picture(str(trace_path))[0], width_px=width_px)
    # imencode + an ordinary write rather than cv2.imwrite: imwrite reports every failure as a
    # bare False, while Python's write says why (permissions, full disk) and takes any path
    ok, data = cv2.imencode(out.suffix.lower(), fig.image)
    if not ok:
        raise ValueError(f"{out}: OpenCV could not encode the image as '{out.suffix}'")
    try:
        write_output(out, data.tobytes())  # beside the target, renamed into place
    except LabsimError as e:
        raise ValueError(f"{out}: {e.diagnostics[0].message}") from None
    return out
