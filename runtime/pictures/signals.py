"""Signals over time: ``labsim plot TRACE --signals a,b -o signals.png`` charts trace columns.

A stage after the run, beside the map of ``labsim.runtime.pictures.plot``: this module reads a trace
(``labsim.runtime.trace``) and draws, with matplotlib on its Agg canvas (no display needed),
one panel per named column against simulated time, one line per robot, the robot's states
shaded behind (or, with several robots in several states, a band per robot on top), the
ticks a count metric rose as marks along the top, and slider moves as labelled dashed lines.
Units come from docs/language.md for the built-in columns and from the comment after a
``let:`` line (``swing: Load.x - Crab.x  # m, ...``) for the behaviour's own. Without
names it charts the columns the behaviour's metrics read.
"""
from __future__ import annotations

import itertools
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from labsim.foundation.files import save_figure
from labsim.runtime.pictures.paint import robot_colour
from labsim.runtime.pictures.trace_behaviour import behaviour_data
from labsim.runtime.trace import Trace, TraceFormatError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

# columns every trace of a kind has, with their units (docs/language.md, docs/trace-format.md)
_UNITS = {"x": "m", "y": "m", "heading": "rad", "time": "s", "forward_speed": "m/s", "road_offset": "m",
          "wheel_left": "rad/s", "wheel_right": "rad/s", "on_road": "0/1", "collided": "0/1"}
_NOT_SIGNALS = {"tick", "time", "robot", "state", "rule", "events"}
_UNIT_WORD = re.compile(r"^\s*([A-Za-z]+(?:[/^.][A-Za-z0-9^]+)*|0/1)\s*(?:,|$)")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


@dataclass
class SignalSet:
    """What a chart draws, taken from a trace: per robot its times, values and states."""

    robots: list[str]
    time: dict[str, np.ndarray]
    values: dict[str, dict[str, np.ndarray]]  # column -> robot -> values (nan where not a number)
    states: dict[str, list[str]]
    events: list[tuple[float, str]]  # (time, metric name) of every count metric that rose
    moves: list[tuple[float, str]]  # (time, "slider=value") of every slider move


def _float(s: str) -> float:
    try:
        v = float(s)
    except ValueError:
        return np.nan
    return v if np.isfinite(v) else np.nan  # a sonar that sees nothing is a gap, not a spike


def _behaviour_lets(trace: Trace, warn: bool = True) -> tuple[dict[str, str], dict[str, str]]:
    """The behaviour's ``let:`` and ``metrics:`` expressions, and a unit per let from its comment.

    Read from the file the header names; a trace moved without its behaviour gets neither.
    """
    text, doc = behaviour_data(trace, warn)
    if not doc:
        return {}, {}
    units: dict[str, str] = {}
    lets = doc["let"] if isinstance(doc.get("let"), dict) else {}
    for line in text.splitlines():
        key, _, rest = line.strip().partition(":")
        if key in lets and "#" in rest:
            m = _UNIT_WORD.match(rest.split("#", 1)[1])
            if m:
                units[key] = m.group(1)
    metrics = doc["metrics"] if isinstance(doc.get("metrics"), dict) else {}
    return units, {str(k): str(v) for k, v in metrics.items()}


def default_signals(trace: Trace) -> list[str]:
    """The columns the behaviour's metrics read, in the order the metrics name them.

    Falls back to the behaviour's own columns (those after the standard ones) when the
    behaviour file is not there to read.
    """
    _, metrics = _behaviour_lets(trace, warn=False)  # the chart reads it again, and warns
    cols = set(trace.columns) - _NOT_SIGNALS
    picked = [n for expr in metrics.values() for n in _NAME.findall(expr) if n in cols]
    if not picked:
        start = trace.columns.index("rule") + 1 if "rule" in trace.columns else 0
        picked = [c for c in trace.columns[start:] if c in cols and not c.startswith(("label:", "wheel_"))]
    return list(dict.fromkeys(picked))[:6]


def drawn_without(trace: Trace, names: list[str], chosen: bool) -> list[str]:
    """What a chart lacks when the behaviour file is not there: the units of the behaviour's own
    columns, and (when the columns were not named) the choice of those the metrics read."""
    own = [n for n in names if n not in _UNITS]
    out = [f"the units of {', '.join(own)}"] if own else []
    return out + ([] if chosen else ["the choice of the columns its metrics read"])


def check_signals(trace: Trace, names: list[str]) -> None:
    """An unknown column is a mistake the user can fix: say which ones the trace has."""
    known = [c for c in trace.columns if c not in _NOT_SIGNALS]
    for n in names:
        if n not in trace.columns or n in _NOT_SIGNALS:
            raise ValueError(f"--signals: the trace has no column '{n}'; its columns are {', '.join(known)}")


def signal_set(trace: Trace, names: list[str]) -> SignalSet:
    """The named columns split by robot; the trace's events and slider moves by time."""
    for needed in ("time", "robot"):
        if needed not in trace.columns:
            raise TraceFormatError(f"{trace.path}: the trace has no '{needed}' column")
    ti, ri = trace.columns.index("time"), trace.columns.index("robot")
    si = trace.columns.index("state") if "state" in trace.columns else -1
    ei = trace.columns.index("events") if "events" in trace.columns else -1
    robots = list(dict.fromkeys(r[ri] for r in trace.rows))
    rows_of: dict[str, list[list[str]]] = {r: [] for r in robots}
    for row in trace.rows:
        rows_of[row[ri]].append(row)
    time = {r: np.array([_float(row[ti]) for row in rows], float) for r, rows in rows_of.items()}
    values = {n: {r: np.array([_float(row[trace.columns.index(n)]) for row in rows], float)
                  for r, rows in rows_of.items()} for n in names}
    states = {r: [row[si] if si >= 0 else "" for row in rows] for r, rows in rows_of.items()}
    events: list[tuple[float, str]] = []
    moves: list[tuple[float, str]] = []
    if ei >= 0:
        for row in trace.rows:
            if row[ei]:
                for ev in row[ei].split(";"):
                    if ev:
                        (moves if "=" in ev else events).append((_float(row[ti]), ev))
    # the moves of one tick (one robot's row carries them, and a timeline line may move several
    # sliders) as one mark: "hoist=0, arm=5"
    grouped: dict[float, list[str]] = {}
    for t, move in moves:
        if move not in grouped.setdefault(t, []):
            grouped[t].append(move)
    return SignalSet(robots, time, values, states, events, [(t, ", ".join(m)) for t, m in grouped.items()])


def _spans(states: list[str], t: np.ndarray) -> list[tuple[str, float, float]]:
    """Runs of one state as (state, start time, end time)."""
    out: list[tuple[str, float, float]] = []
    if not len(t):
        return out
    change = [0, *(i for i in range(1, len(states)) if states[i] != states[i - 1]), len(states)]
    dt = float(t[1] - t[0]) if len(t) > 1 else 0.0
    for a, b in itertools.pairwise(change):
        out.append((states[a], float(t[a]), float(t[b - 1]) + dt))
    return out


def chart(trace: Trace, names: list[str], out: Path, *, width_px: int = 1000) -> Path:
    """Draw the named columns against time to ``out`` (.png, .svg or .pdf); returns ``out``."""
    import matplotlib.pyplot as plt

    fig = chart_figure(trace, names, width_px=width_px)
    save_figure(fig, out, dpi=fig.dpi)
    plt.close(fig)
    return out


def chart_figure(trace: Trace, names: list[str], *, width_px: int = 1000) -> Figure:
    """The chart as a matplotlib Figure (Agg), 100 dpi, one axes per panel, time on x."""
    # one function for one figure: the panels share their time axis and their marks
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    check_signals(trace, names)
    data = signal_set(trace, names)
    units, _ = _behaviour_lets(trace)
    all_states = list(dict.fromkeys(s for r in data.robots for s in data.states[r] if s))
    multi = len(data.robots) > 1 and len(all_states) > 1
    palette = [plt.get_cmap("Pastel2")(k) for k in range(8)]
    state_colour = {s: palette[k % len(palette)] for k, s in enumerate(all_states)}
    rgb = {r: tuple(c / 255 for c in reversed(robot_colour(k))) for k, r in enumerate(data.robots)}

    n = len(names) + (1 if multi else 0)
    ratios = ([0.25 + 0.12 * len(data.robots)] if multi else []) + [1.0] * len(names)
    dpi = 100
    fig, axes = plt.subplots(n, 1, sharex=True, squeeze=False, figsize=(width_px / dpi, 0.6 + 2.0 * sum(ratios)),
                             dpi=dpi, gridspec_kw={"height_ratios": ratios})
    axs = list(axes[:, 0])
    title = trace.header.get("name") or Path(str(trace.header.get("behaviour") or trace.path)).stem
    fig.suptitle(str(title), x=0.01, ha="left", fontsize=12)
    if multi:  # one band per robot, coloured by its state, above the signals
        band = axs.pop(0)
        for k, r in enumerate(data.robots):
            for s, a, b in _spans(data.states[r], data.time[r]):
                band.axvspan(a, b, ymin=1 - (k + 1) / len(data.robots), ymax=1 - k / len(data.robots),
                             color=state_colour.get(s, "white"), lw=0)
        band.set_yticks([1 - (k + 0.5) / len(data.robots) for k in range(len(data.robots))], data.robots)
        band.set_ylim(0, 1)
        band.set_ylabel("state")
    for ax, name in zip(axs, names):
        if not multi and data.robots and len(all_states) > 1:
            r0 = data.robots[0]
            for s, a, b in _spans(data.states[r0], data.time[r0]):
                ax.axvspan(a, b, color=state_colour[s], alpha=0.55, lw=0) if s else None
        for r in data.robots:
            ax.plot(data.time[r], data.values[name][r], color=rgb[r], lw=1.1, label=r)
        unit = units.get(name) or _UNITS.get(name) or ("m" if name.startswith("sonar") else "")
        ax.set_ylabel(f"{name} ({unit})" if unit else name)
        ax.grid(True, color="0.88", lw=0.6)
        _marks(ax, data)
    axs[-1].set_xlabel("time (s)")
    handles = [*axs[0].get_legend_handles_labels()[0]] if len(data.robots) > 1 else []
    handles += [Patch(color=state_colour[s], label=f"state {s}") for s in all_states if len(all_states) > 1]
    event_names = list(dict.fromkeys(e for _, e in data.events))
    count = {e: sum(1 for _, x in data.events if x == e) for e in event_names}
    handles += [plt.Line2D([], [], color=f"C{k + 1}", marker="v", ls="", label=f"{e} ({count[e]})")
                for k, e in enumerate(event_names)]
    if data.moves:
        handles.append(plt.Line2D([], [], color="0.45", ls="--", lw=0.9, label="slider moved"))
    if handles:
        fig.legend(handles=handles, loc="upper right", ncol=min(len(handles), 5), fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, 0, 1, 0.97))
    return fig


def _marks(ax: object, data: SignalSet) -> None:
    """Count-metric events as small triangles on the top edge; slider moves as dashed lines."""
    from matplotlib.axes import Axes

    assert isinstance(ax, Axes)
    names = list(dict.fromkeys(e for _, e in data.events))
    for k, e in enumerate(names):
        ts = [t for t, x in data.events if x == e]
        ax.plot(ts, [1.0] * len(ts), "v", color=f"C{k + 1}", ms=5, transform=ax.get_xaxis_transform(),
                clip_on=False)
    for t, move in data.moves:
        ax.axvline(t, color="0.45", ls="--", lw=0.9)
        ax.annotate(move, (t, 0.02), xycoords=("data", "axes fraction"), rotation=90, fontsize=7,
                    color="0.35", ha="right", va="bottom")
