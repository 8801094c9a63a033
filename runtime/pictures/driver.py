"""``labsim plot`` from options to a file: the map, a signals chart or an animation, by suffix.

The command line declares the command's options with ``add_plot_arguments`` (imported only
when the command is ``plot``) and hands them to ``run_plot``, which checks them all before
drawing (an unknown column, an unsupported suffix, a bad time range: exit 2 with what would be
accepted) and then calls the module that draws that kind of picture:
``labsim.runtime.pictures.plot`` for the still map (PNG, JPEG, ...),
``labsim.runtime.pictures.signals`` for charts against time (PNG, SVG, PDF), and
``labsim.runtime.pictures.animate`` for a GIF or MP4 of the run. ``--camera ROBOT`` puts a
strip of the robot's camera frames under the map (``labsim.runtime.pictures.camera_strip``).
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.exits import EXIT_OK
from labsim.foundation.files import check_output, write_output
from labsim.runtime.pictures.trace_sample import Wanted, read_for_picture
from labsim.runtime.trace import Trace, TraceFormatError, trace_world

if TYPE_CHECKING:
    import numpy as np

    from labsim.backends.scene.world import World
    from labsim.runtime.pictures.map_frame import Figure

MAP_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".webp", ".tif", ".tiff")
CHART_SUFFIXES = (".png", ".svg", ".pdf")
MOVIE_SUFFIXES = (".gif", ".mp4")
ALL_SUFFIXES = tuple(dict.fromkeys(MAP_SUFFIXES + CHART_SUFFIXES + MOVIE_SUFFIXES))


def add_plot_arguments(plot: argparse.ArgumentParser) -> None:
    """``labsim plot``'s options; docs/pictures.md."""
    plot.description = ("The output's suffix says what is drawn: .png (the map, or with --signals a chart), "
                        ".svg/.pdf (a chart of signals), .gif/.mp4 (an animation of the run).")
    plot.add_argument("trace")
    plot.add_argument("-o", "--output", required=True, metavar="FILE",
                      help="run.png (the map), signals.png/.svg/.pdf with --signals, run.gif or run.mp4")
    plot.add_argument("--signals", nargs="?", const="", default=None, metavar="COL,COL",
                      help="chart these trace columns against time, one panel each (alone: the columns "
                           "the behaviour's metrics read)")
    plot.add_argument("--width", type=int, default=None, metavar="PX",
                      help="image width in pixels (default: 1000 for pictures, 720 for animations)")
    plot.add_argument("--fps", type=float, default=None, help="animation frames per second (default: 20 for "
                                                              "MP4, 10 for GIF)")
    plot.add_argument("--speed", type=float, default=None, metavar="X",
                      help="simulated seconds per second of animation (default: 1, or faster so that the "
                           "animation lasts at most 30 s)")
    plot.add_argument("--from", dest="t_from", type=float, default=None, metavar="S",
                      help="start of the animation or chart, simulated seconds")
    plot.add_argument("--to", dest="t_to", type=float, default=None, metavar="S",
                      help="end of the animation or chart, simulated seconds")
    plot.add_argument("--camera", default=None, metavar="ROBOT",
                      help="add a strip of this robot's camera frames under the map, re-rendered from the "
                           "trace's poses")
    plot.add_argument("--behaviour", default=None, metavar="PATH",
                      help="the behaviour file (or lab name) that made the trace, when it is not where the "
                           "trace's header says: the crane's slew panel, --camera and a chart's units read it")


MIN_WIDTH_PX = 400  # plot.MIN_WIDTH_PX, without importing the drawing (cv2) to check an option


def _fail(where: str, message: str) -> LabsimError:
    return LabsimError([Diagnostic(where, message)])


def _time_window(trace: Trace, t_from: float | None, t_to: float | None) -> Trace:
    """The rows between two simulated times (both optional), as a trace of their own."""
    if t_from is None and t_to is None:
        return trace
    lo = -float("inf") if t_from is None else t_from
    hi = float("inf") if t_to is None else t_to
    if lo >= hi:
        raise _fail(trace.path, f"--from {lo:g} is not before --to {hi:g}")
    ti = trace.columns.index("time")
    rows = [r for r in trace.rows if lo <= float(r[ti]) <= hi]
    if not rows:
        raise _fail(trace.path, f"no ticks between {lo:g} s and {hi:g} s (the trace runs from "
                                f"{trace.rows[0][ti]} s to {trace.rows[-1][ti]} s)")
    return Trace(trace.path, trace.header, trace.columns, rows, behaviour_given=trace.behaviour_given)


def _check_suffix(out: Path, signals: bool) -> str:
    """What the suffix asks for: "map", "chart" or "movie"."""
    suffix = out.suffix.lower()
    if suffix in MOVIE_SUFFIXES:
        return "movie"
    if signals or suffix in (".svg", ".pdf"):
        if suffix not in CHART_SUFFIXES:
            raise _fail(str(out), f"a signals chart is written as {', '.join(CHART_SUFFIXES)}, not '{out.suffix}'")
        return "chart"
    if suffix not in MAP_SUFFIXES:
        raise _fail(str(out), f"'{out.suffix or out.name}' is not a kind of picture labsim plot writes; "
                              f"use one of {', '.join(ALL_SUFFIXES)}")
    return "map"


def _check_numbers(args: argparse.Namespace) -> None:
    """--width, --fps and --speed within what labsim draws."""
    notes = {"--width": f"{MIN_WIDTH_PX} px is the narrowest picture labsim draws (narrower, the labels and the "
                        "legend would cover the map); leave --width out for the default"}
    for name, value, low in (("--width", args.width, MIN_WIDTH_PX), ("--fps", args.fps, 0.1),
                             ("--speed", args.speed, 1e-6)):
        if value is not None and value < low:
            raise LabsimError([Diagnostic("labsim plot", f"{name} must be at least {low:g} (got {value:g})",
                                          notes=(notes[name],) if name in notes else ())])


def run_plot(args: argparse.Namespace) -> int:
    """Check the options, draw, write; exit code 0, or a LabsimError (exit 2) for a mistake."""
    out = Path(args.output)
    kind = _check_suffix(out, args.signals is not None)
    if getattr(args, "camera", None) is not None and kind != "map":
        raise _fail(str(out), "--camera adds camera frames under the map: write the map "
                              f"({', '.join(MAP_SUFFIXES)}), without --signals")
    check_output(out, [args.trace])  # never the trace itself, a device or a folder
    if out.is_dir() or not out.parent.is_dir():
        where = "it is a directory" if out.is_dir() else f"no directory {out.parent}"
        raise _fail(str(out), f"cannot write here: {where}")
    _check_numbers(args)
    try:
        wanted: Wanted | None = None
        if kind == "movie":  # an animation reads a few columns: only those are split into cells
            from labsim.runtime.pictures.animate import movie_columns as wanted
        trace, thinned = read_for_picture(args.trace, wanted=wanted)  # in bounded memory, whatever its size
        if not trace.rows:
            raise _fail(args.trace, "the trace has no rows: nothing ran")
        check_output(out, drawn_from(trace))  # now that the trace says which files it names
        if trace.cut_short():
            sys.stderr.write(f"{args.trace}: warning: {trace.cut_short()}; drawn as far as it goes\n")
        if thinned:
            sys.stderr.write(f"{args.trace}: note: {thinned}\n")
        if kind != "chart":
            _check_in_world(trace)
        trace = _time_window(_with_behaviour(trace, getattr(args, "behaviour", None)), args.t_from, args.t_to)
        if kind == "chart":
            from labsim.runtime.pictures.signals import chart, check_signals, default_signals

            named = [n.strip() for n in args.signals.split(",") if n.strip()] if args.signals else []
            try:
                check_signals(trace, named)  # a mistake first, before a warning about the rest
                names = named or default_signals(trace)
                missing = _what_is_missing(trace, kind, names, bool(named))
                chart(trace, names, out, width_px=args.width or 1000)
            except ValueError as e:
                raise _fail(args.trace, str(e)) from None
        elif kind == "movie":
            from labsim.runtime.pictures.animate import animate

            missing = _what_is_missing(trace, kind, [], True)
            n = animate(trace, out, width_px=args.width or 720, fps=args.fps, speed=args.speed)
            print(f"{n} frames")
        else:
            missing = _what_is_missing(trace, kind, [], True)
            _still(trace, out, args)
    except TraceFormatError as e:
        raise LabsimError([e.diagnostic(args.trace)]) from None
    except (ValueError, OverflowError) as e:  # what is in the trace cannot be drawn
        raise _fail(args.trace, f"cannot draw this trace: {e}") from None
    print(f"wrote {out}")
    if missing:  # after the picture: what it lacks is a warning, and the picture stands (exit 0)
        sys.stderr.write(f"{args.trace}: warning: {missing}\n")
    return EXIT_OK


def _with_behaviour(trace: Trace, argument: str | None) -> Trace:
    """The trace with ``--behaviour``'s file, said on stderr if it is not the one the run used."""
    if argument is None:
        return trace
    from labsim.runtime.pictures.trace_behaviour import given_behaviour

    trace, note = given_behaviour(trace, argument)
    if note:
        sys.stderr.write(f"{trace.path}: warning: {note}\n")
    return trace


def _what_is_missing(trace: Trace, kind: str, names: list[str], chosen: bool) -> str:
    """What the picture will lack for want of the behaviour file, and how to give it; '' when
    nothing (the file is there, or this picture does not read it)."""
    from labsim.runtime.pictures.trace_behaviour import behaviour_file, missing_note

    if behaviour_file(trace) is not None:
        return ""
    if kind == "chart":
        from labsim.runtime.pictures.signals import drawn_without

        parts = drawn_without(trace, names, chosen)
    else:
        from labsim.runtime.pictures.mechanism_pose import drawn_without as mechanism_without

        world, _ = trace_world(trace)
        parts = mechanism_without(trace, world.mechanism) if world is not None and world.mechanism else []
    return missing_note(trace, parts) if parts else ""


def drawn_from(trace: Trace) -> list[Path]:
    """Every file a picture of the trace reads, which ``-o`` must not overwrite: the trace, the
    world file and the behaviour file its header names (as far as the access policy reads them)."""
    from labsim.runtime.pictures.trace_behaviour import behaviour_file

    world, _ = trace_world(trace)
    behaviour = behaviour_file(trace)
    return [Path(trace.path), *([Path(world.source)] if world is not None and world.source else []),
            *([behaviour] if behaviour is not None else [])]


FAR_M = 1000.0  # a pose this far past the world's bounds (or from 0 without a world) is no robot's


def _check_in_world(trace: Trace) -> None:
    """A map whose poses lie far outside the world would draw nothing visible: say so, with the
    first such row's line, instead (x = 1e308 in a damaged or edited trace)."""
    world, _ = trace_world(trace)
    x0, y0, x1, y1 = world.bounds if world is not None else (0.0, 0.0, 0.0, 0.0)
    xi, yi, ri = (trace.columns.index(c) if c in trace.columns else -1 for c in ("x", "y", "robot"))
    if xi < 0 or yi < 0:
        return
    rows, lines = trace.rows, trace.lines
    if "x" in trace.numbers and "y" in trace.numbers and len(trace.numbers["x"]) == len(rows) == len(lines):
        import numpy as np

        # the columns as numbers already (Trace.numbers): the first far row found in C, said as below
        xs, ys = trace.numbers["x"], trace.numbers["y"]
        far = np.flatnonzero(((xs < x0 - FAR_M) | (xs > x1 + FAR_M) | (ys < y0 - FAR_M) | (ys > y1 + FAR_M))
                             & (xs == xs) & (ys == ys))
        rows, lines = [rows[int(k)] for k in far[:1]], [lines[int(k)] for k in far[:1]]
    for row, line in zip(rows, lines):
        x, y = float(row[xi]), float(row[yi])
        if (x < x0 - FAR_M or x > x1 + FAR_M or y < y0 - FAR_M or y > y1 + FAR_M) and x == x and y == y:
            where = f"world '{world.name}' ({x0:g}..{x1:g} x {y0:g}..{y1:g} m)" if world else "the origin"
            robot = f"robot {row[ri][:40]}" if ri >= 0 else "a robot"
            raise LabsimError([Diagnostic(trace.path, f"{robot} is at ({x:.6g}, {y:.6g}), over {FAR_M:g} m "
                                          f"outside {where}: the picture would show nothing; is the trace "
                                          "damaged?", line, 1)])


def _still(trace: Trace, out: Path, args: argparse.Namespace) -> None:
    import cv2

    from labsim.runtime.pictures.plot import check_output, render_figure

    try:
        check_output(out)
    except ValueError as e:
        raise _fail(str(out), str(e)) from None
    world, note = trace_world(trace)
    fig = render_figure(trace, width_px=args.width or 1000, world=world, world_note=note)
    image = fig.image
    if getattr(args, "camera", None) is not None:
        image = _with_camera(trace, fig, world, args.camera)
    ok, data = cv2.imencode(out.suffix.lower(), image)
    if not ok:
        raise ValueError(f"{out}: OpenCV could not encode the image as '{out.suffix}'")
    write_output(out, data.tobytes())  # beside the target, renamed into place


def _with_camera(trace: Trace, fig: Figure, world: World | None, robot: str) -> np.ndarray:
    """The map with the robot's numbered poses on it, and its camera strip under it."""
    import numpy as np

    from labsim.runtime.pictures.camera_strip import draw_strip, mark_shots, shots
    from labsim.runtime.pictures.paint import Painter
    from labsim.runtime.pictures.plot import robot_paths

    camera, frames = shots(trace, robot, world)
    colour = next(p.colour for p in robot_paths(trace) if p.name == robot)
    width = fig.image.shape[1]
    mark_shots(fig, Painter(width), frames, colour)
    return np.vstack((fig.image, draw_strip(width, robot, camera, frames, colour)))
