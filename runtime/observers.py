"""What watches a run's ticks: observers, chosen once when a behaviour is bound.

The tick core (``labsim.runtime.tick``) senses, evaluates, decides, acts and steps; everything
else a run may do on a tick is an ``Observer`` handed to it, in the manner of py_trees' pre-
and post-tick handlers: the trace writer, the live view's watcher, the log printer, the
inputs that move sliders (the file's timeline, a replayed trace, a live drag) and the joint
commands of a mechanism. An observer overrides only the hooks it needs; the core collects
each hook once, when the run is bound, so a hook nobody overrides costs nothing and adding an
observer never edits the hot path.

The hooks, in the order a tick calls them:

* ``before_tick(tick)``: before anything is sensed (inputs set the slots the signals read);
* ``after_act(robot, rule, values)``: after a robot's rule acted (``rule`` -1: none held) and
  its wheels were commanded, before its events are cleared and its ``goto`` takes effect;
* ``at_stop(robot, values)``: on the tick the stop condition held (format 1.1), after its
  metrics were folded; no rule acts on it.

``bind(run)`` is called once, after the run's robots exist and before the first tick.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from labsim.backends.protocol import BackendError
from labsim.backends.scene.models import Kind, is_lidar_beam
from labsim.dsl.library.builtins import Type
from labsim.dsl.library.support import STATE
from labsim.foundation.code_writer import Writer, render
from labsim.foundation.inert import inert
from labsim.runtime.hands import Hand, Hands, event_text
from labsim.runtime.state import RobotRun, RunState
from labsim.runtime.trace import BATCH, TraceWriter, csv_cell

TRACE_POSE = ("x", "y", "heading", "collided")  # what the trace records of every robot, in its columns

# A log(...) prints at most this many lines per simulated second (per log in the file): a rule
# that fires every tick cannot flood the terminal; the trace keeps every line.
LOG_RATE = 5
# And a run prints at most this many log lines and bytes in all: 500 logs in one rule passed the
# rate above and printed 25 MB a simulated 10 s. The summary counts the lines left unprinted.
LOG_LINES_PER_RUN = 1000
LOG_BYTES_PER_RUN = 1_000_000
# One log line's text, printed or traced, is cut to this many characters (and '...').
LOG_TEXT_CHARS = 500
# A tick's events cell holds at most this many characters of log text (each log cut as above),
# then one "log: ... (N more logs this tick)": the cell stays under what a CSV reader takes
# (Python's csv: 131,072 characters), so a trace of 500 long logs a tick still reads back.
EVENTS_LOG_CHARS = 100_000
CAP_NOTE = (f"no more log lines are printed in this run (at most {LOG_LINES_PER_RUN:,} lines and "
            f"{LOG_BYTES_PER_RUN // 1_000_000} MB)")

Schedule = dict[int, list[tuple[int, float, str]]]  # tick -> (slot, value, "name=value") moves


class Observer:
    """A watcher of ticks; see the module docstring. The base hooks do nothing."""

    reads: tuple[str, ...] = ()  # the channels it reads of every robot, read for it even when the behaviour does not

    def bind(self, run: RunState) -> None:
        """Once, when the run is bound: read what the run set up."""

    def before_tick(self, tick: int) -> None:
        """Before the tick's sensing."""

    def after_act(self, robot: RobotRun, rule: int, values: list) -> None:
        """After one robot acted on the tick; ``values`` are its readings."""

    def at_stop(self, robot: RobotRun, values: list) -> None:
        """On the tick the stop condition held (no rule acts), for every robot."""


@dataclass(frozen=True)
class Hooks:
    """The hooks of a run's observers, each kept only where an observer overrides it."""

    before_tick: tuple[Callable[[int], None], ...]
    after_act: tuple[Callable[[RobotRun, int, list], None], ...]
    at_stop: tuple[Callable[[RobotRun, list], None], ...]


def hooks(observers: Sequence[Observer]) -> Hooks:
    """The hooks the tick calls, in the observers' order; a hook nobody overrides is left out."""
    return Hooks(
        before_tick=tuple(o.before_tick for o in observers if type(o).before_tick is not Observer.before_tick),
        after_act=tuple(o.after_act for o in observers if type(o).after_act is not Observer.after_act),
        at_stop=tuple(o.at_stop for o in observers if type(o).at_stop is not Observer.at_stop))


class Inputs(Observer):
    """Slider moves: the file's timeline or a replayed trace's, and live drags (``move``).

    A move applies to every robot's slots before the tick's signals read them, and is kept in
    ``applied`` for the trace's events column.
    """

    def __init__(self, schedule: Schedule, hands: Hands | None = None,
                 apply: Callable[[Hand], str | None] | None = None):
        self.schedule = schedule
        self._soonest: float | None = None  # the first tick with a move (None: to be looked up)
        self.applied: list[str] = []  # this tick's moves, "name=value"
        self._slots: list[list] = []
        self.hands = dict(hands or {})  # a replayed trace's changes by hand (robots, blocks), by tick
        self.notes: dict[int, list[str]] = {}  # events done live, for the trace (a drag)
        self._apply = apply

    def bind(self, run: RunState) -> None:
        self._slots = [r.program.slots for r in run.robots]

    def before_tick(self, tick: int) -> None:
        # every tick of a run with sliders or a live view: a tick with nothing to do makes no list
        if self.applied:
            self.applied = []
        if tick in self.schedule:
            self._soonest = None
            for slot, value, text in self.schedule.pop(tick):
                for s in self._slots:
                    s[slot] = value
                self.applied.append(text)
        if self.hands and tick in self.hands:
            self._redo(tick)
        if self.notes:
            self.applied += self.notes.pop(tick, ())

    def quiet(self, tick: int, n: int) -> bool:
        """Whether ticks ``tick`` to ``tick + n - 1`` have nothing to apply or clear: a live view
        runs them without this hook (moves arrive between its stretches of ticks)."""
        if self.applied or self.notes or self.hands:
            return False
        if self._soonest is None:  # a move was applied or added since the last look
            self._soonest = min(self.schedule, default=math.inf)
        return self._soonest >= tick + n

    def _redo(self, tick: int) -> None:
        """Change the world as the replayed trace's run did by hand, before this tick senses."""
        for hand in self.hands.pop(tick):
            why = self._apply(hand) if self._apply is not None else "this run cannot"
            if why is not None:
                raise BackendError(f"the replayed trace's '{event_text(hand)[:80]}' cannot be done: {why}")
            self.applied.append(event_text(hand))

    def move(self, tick: int, slot: int, value: float, text: str) -> None:
        """A move from tick ``tick`` on (a live drag lands on the next tick's signals)."""
        self.schedule.setdefault(tick, []).append((slot, value, text))
        self._soonest = None


class Watcher(Observer):
    """The rule each robot fired on the last tick (-1: none), for a live view."""

    def __init__(self) -> None:
        self.last_rule: list[int] = []

    def bind(self, run: RunState) -> None:
        self.last_rule = [-1] * len(run.robots)

    def after_act(self, robot: RobotRun, rule: int, values: list) -> None:
        self.last_rule[robot.index] = rule


class JointCommands(Observer):
    """A mechanism's joint targets, sent to the backend when they change (nan: not yet set)."""

    def __init__(self, targets: Sequence[tuple[str, str]], command: Callable[[int, str, str, float], None]):
        self.targets = tuple(targets)
        self.command = command

    def after_act(self, robot: RobotRun, rule: int, values: list) -> None:
        sent = robot.sent_joints
        for k, value in enumerate(robot.program.joint_command):
            if value != sent[k] and value == value:
                sent[k] = value
                joint, mode = self.targets[k]
                self.command(robot.index, joint, mode, value)


class LogPrinter(Observer):
    """Each ``log(...)`` of a tick, printed: at most ``LOG_RATE`` lines a simulated second per
    log in the file, and ``LOG_LINES_PER_RUN`` lines and ``LOG_BYTES_PER_RUN`` bytes (as printed,
    inert) in all; the rest are counted (``dropped`` by log, ``over_cap`` past the run's cap) for
    the summary. ``lines`` keeps what was printed, apart from the run's warnings; the trace
    records every line."""

    def __init__(self, emit: Callable[[str], None] | None):
        self.emit = emit
        self.lines: list[str] = []
        self.dropped: dict[int, int] = {}  # log site -> lines not printed
        self.over_cap = 0  # lines not printed because the run's cap was reached
        self.printed_bytes = 0
        self._windows: dict[int, list[int]] = {}  # log site -> [simulated second, lines in it]

    def bind(self, run: RunState) -> None:
        self.run = run

    def after_act(self, robot: RobotRun, rule: int, values: list) -> None:
        events = robot.program.events
        if not events:
            return
        run = self.run
        now = run.tick_index * run.dt_s
        second = int(now)
        for e in events:
            if isinstance(e, int):  # a metric's event, not a log
                continue
            site = e[0]
            window = self._windows.setdefault(site, [second, 0])
            if window[0] != second:
                window[:] = [second, 0]
            window[1] += 1
            if window[1] > LOG_RATE:
                self.dropped[site] = self.dropped.get(site, 0) + 1
                continue
            if self.over_cap:
                self.over_cap += 1
                continue
            line = f"[{now:.2f} s] {robot.name}: {log_line_text(run.program.log_text(*e))}"
            size = len(inert(line).encode("utf-8")) + 1  # what the terminal gets, and its newline
            if len(self.lines) >= LOG_LINES_PER_RUN or self.printed_bytes + size > LOG_BYTES_PER_RUN:
                self.over_cap = 1
                if self.emit is not None:
                    self.emit(f"[{now:.2f} s] {CAP_NOTE}; the summary counts the rest")
                continue
            self.printed_bytes += size
            self.lines.append(line)
            if self.emit is not None:
                self.emit(line)


class TraceRows(Observer):
    """A trace row per robot per tick (docs/trace-format.md): pose, state, rule, what the
    behaviour reads and computes, sliders, labels, wheel commands and the tick's events."""

    def __init__(self, writer: TraceWriter, inputs: Inputs | None):
        self.writer = writer
        self.inputs = inputs
        self.recorded = 0  # the ticks the trace has rows of (its footer's count)

    def bind(self, run: RunState) -> None:
        self.run = run
        p = run.program
        self.pose_at = [run.channels.index(c) for c in TRACE_POSE]
        self.channels, self.lets = traced(run)
        self.sliders = [p.slot_of[name] for name in p.slider_names]
        self.states = [csv_cell(name) for name in p.state_names] or [""]
        self.rule_ids = [csv_cell(rule.id) for rule in p.rules] + [""]  # [-1]: the stop row's empty rule
        self.names = {r.name: csv_cell(r.name) for r in run.robots}
        self.cells = _row_cells(self.pose_at, self.channels, self.lets + self.sliders, len(p.labels))
        if not p.labels and self.inputs is None:  # the common case, in one generated call a row
            self.after_act = _fast_rows(self)  # type: ignore[method-assign,assignment]

    def at_stop(self, robot: RobotRun, values: list) -> None:
        self.after_act(robot, -1, values)

    def after_act(self, r: RobotRun, rule: int, values: list) -> None:
        """The row of ``r`` this tick (the hot path of a traced run: one format, one write)."""
        run, p, prog = self.run, self.run.program, r.program
        s = prog.slots
        cmd = prog.command
        labels = [inert(text) for text in p.label_text(s).values()] if p.labels else []
        cell = self.events(p, prog.events) if prog.events or self.inputs is not None else ""
        t = run.tick_index
        time_s = round(t * run.dt_s, 9)
        try:
            line = self.cells(t, time_s, self.names[r.name], values, s, self.states[s[STATE]], self.rule_ids[rule],
                              [csv_cell(text) for text in labels] if labels else labels, cmd,
                              csv_cell(cell) if cell else "")
        except (TypeError, ValueError):
            line = "e+"
        if "e+" in line:  # an int of 10**6 or more (fmt() writes it whole), a value "%.6g" cannot take, or a text
            self.writer.write([t, time_s, r.name, *(values[i] for i in self.pose_at),
                               p.state_names[s[STATE]] if p.state_names else "", p.rules[rule].id if rule >= 0 else "",
                               *(values[i] for i in self.channels), *(s[i] for i in self.lets + self.sliders),
                               *labels, cmd[0], cmd[1], cell])
        else:
            self.writer.write_line(line)
        self.recorded = t + 1  # an interrupt may land before the tick ends: count rows

    def events(self, p: object, raised: list) -> str:
        """The tick's events cell: the count metrics that rose, the logs, the slider moves applied."""
        return events_cell(p, raised, self.inputs.applied if self.inputs is not None else [])


def events_cell(p: object, raised: list, applied: list[str] | None = None) -> str:
    """A tick's events cell (``p`` the program): the count metrics that rose, the logs, the slider
    moves ``applied``."""
    events = [p.metric_names[e] if isinstance(e, int)  # type: ignore[attr-defined]
              else "log: " + _one_field(log_line_text(p.log_text(*e)))  # type: ignore[attr-defined]
              for e in raised] + (applied or [])
    cell = ";".join(events)
    return _bounded_events(events) if len(cell) > EVENTS_LOG_CHARS else cell


def _fast_rows(rows: TraceRows) -> Callable[[RobotRun, int, list], None]:
    """``rows.after_act`` for a program without labels or slider inputs: a tick with no events
    is one format and one write in one call; anything else goes the general way."""
    numbers = [f"values[{i}]" for i in rows.channels] + [f"s[{i}]" for i in rows.lets + rows.sliders]
    w = Writer()
    w.line("def after_act(r, rule, values):")
    with w.indent():
        w.line("prog = r.program")
        w.line("if prog.events:")
        with w.indent():
            w.line("return general(r, rule, values)")
        w.line("s, cmd, t = prog.slots, prog.command, run.tick_index")
        w.line("try:")
        with w.indent():
            w.line(f"line = LINE % (t, round(t * run.dt_s, 9), names[r.name], "
                   f"{', '.join(f'values[{i}]' for i in rows.pose_at)},")
            w.line(f"               states[s[STATE]], rule_ids[rule], {''.join(n + ', ' for n in numbers)}"
                   "cmd[0], cmd[1], \"\")")
        w.line("except (TypeError, ValueError):")
        with w.indent():
            w.line("return general(r, rule, values)")
        w.line('if "e+" in line:')
        with w.indent():
            w.line("return general(r, rule, values)")
        w.line("pending.append(line)")
        w.line("if len(pending) >= BATCH:")
        with w.indent():
            w.line("drain()")
        w.line("rows.recorded = t + 1")
    source = render(w.body())[0]
    line = "%d,%.6g,%s,%.6g,%.6g,%.6g,%.6g,%s,%s," + "%.6g," * len(numbers) + "%.6g,%.6g,%s\n"
    space: dict[str, Any] = {"LINE": line, "general": rows.after_act, "run": rows.run, "names": rows.names,
                             "states": rows.states, "rule_ids": rows.rule_ids, "STATE": STATE, "BATCH": BATCH,
                             "pending": rows.writer.pending, "drain": rows.writer.drain, "rows": rows}
    exec(compile(source, "<labsim trace row>", "exec"), space)  # column indices only, no file text
    made: Callable[[RobotRun, int, list], None] = space["after_act"]
    return made


def _row_cells(pose: list[int], channels: list[int], slots: list[int], labels: int) -> Callable[..., str]:
    """A trace row as one ``%`` format of one tuple, written for this program's columns: numbers
    as "%.6g" (what fmt() writes for a float or a bool, and for an int below 10**6), texts as the
    caller quoted them. The source is made of column indices only."""
    numbers = [f"values[{i}]" for i in channels] + [f"s[{i}]" for i in slots]
    line = ("%d,%.6g,%s,%.6g,%.6g,%.6g,%.6g,%s,%s," + "%.6g," * len(numbers) + "%s," * labels + "%.6g,%.6g,%s\n")
    cells = ["t", "time_s", "name", *(f"values[{i}]" for i in pose), "state", "rule", *numbers,
             *(f"labels[{i}]" for i in range(labels)), "cmd[0]", "cmd[1]", "cell"]
    w = Writer()
    w.line("def cells(t, time_s, name, values, s, state, rule, labels, cmd, cell):")
    with w.indent():
        w.line(f"return LINE % ({', '.join(cells)})")
    source = render(w.body())[0]
    space: dict = {"LINE": line}
    exec(compile(source, "<labsim trace row>", "exec"), space)  # indices only, no file text
    return space["cells"]


# channels with one CSV cell: numbers and booleans (a lidar's beams are distances, but see traced)
TRACED_KINDS = (Kind.DISTANCE, Kind.NUMBER, Kind.BOOL, Kind.CONTACT, Kind.REFLECTANCE)


def traced(run: RunState) -> tuple[list[int], list[int]]:
    """Which channel values and which signal slots the trace records: numbers and booleans.

    Images and records have no CSV cell; a behaviour traces what it derives from them
    (``cx: centroid(lane).x`` is a column). Nor has a lidar's beam: hundreds of columns of
    one scan; trace what the behaviour reduces the scan to (``nearest: min(scan)``).
    """
    p = run.program
    kinds = p.channel_kinds
    channels = [i for i, c in enumerate(p.channels) if c not in TRACE_POSE
                and kinds.get(c) in TRACED_KINDS and not is_lidar_beam(c)]
    lets = [p.slot_of[n] for n in p.let_names if p.signal_types.get(n) in (Type.NUMBER, Type.BOOL)]
    # then what it read of other robots (format 1.3: 'leader.x'), but a state, which the other's row shows
    lets += [p.slot_of[n] for n, t in p.received if t in (Type.NUMBER, Type.BOOL)]
    return channels, lets


def trace_columns(run: RunState) -> list[str]:
    """The trace's columns, in the order ``TraceRows.row`` writes them."""
    p = run.program
    channels, lets = traced(run)
    names = {slot: name for name, slot in p.slot_of.items()}
    return (["tick", "time", "robot", "x", "y", "heading", "collided", "state", "rule"]
            + [p.channels[i] for i in channels] + [names[i] for i in lets] + list(p.slider_names)
            + [f"label:{slider}" for slider, _ in p.labels]
            + ["wheel_left", "wheel_right", "events"])


def log_line_text(text: str) -> str:
    """A log's text as printed and traced: at most ``LOG_TEXT_CHARS`` characters, '...' where cut."""
    return text if len(text) <= LOG_TEXT_CHARS else text[:LOG_TEXT_CHARS - 3] + "..."


def _bounded_events(events: list[str]) -> str:
    """A tick's events with at most ``EVENTS_LOG_CHARS`` of log text: metrics and slider moves
    all kept (a replay needs them; the file bounds them), the logs in order while they fit."""
    kept, used, left = [], 0, 0
    for e in events:
        if e.startswith("log: "):
            if left or used + len(e) > EVENTS_LOG_CHARS:
                left += 1
                continue
            used += len(e) + 1
        kept.append(e)
    return ";".join(kept + [f"log: ... ({left} more logs this tick)"] if left else kept)


def _one_field(text: str) -> str:
    """A log's text as one cell of the events column: no ';' (the separator), no newline, and
    inert (a trace is read in terminals too)."""
    return inert(text.replace(";", ",").replace("\n", " "))


__all__ = [
    "CAP_NOTE",
    "EVENTS_LOG_CHARS",
    "LOG_BYTES_PER_RUN",
    "LOG_LINES_PER_RUN",
    "LOG_RATE",
    "LOG_TEXT_CHARS",
    "TRACE_POSE",
    "Hooks",
    "Inputs",
    "JointCommands",
    "LogPrinter",
    "Observer",
    "TraceRows",
    "Watcher",
    "events_cell",
    "hooks",
    "log_line_text",
]
