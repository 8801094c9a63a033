"""What a live view keeps of the ticks between two frames: each robot's path and chart samples.

A page gets at most 30 frames a second, and at "as fast as it goes" hundreds of ticks run
between two of them: drawn from the frames alone, a path cuts corners through walls and a
chart gets a point every few simulated seconds. ``TickRecorder`` is an ``Observer``
(``labsim.runtime.observers``) the live session hands to the run when it binds it, so the tick
loop is not edited: after every robot acts it adds the robot's position to a ``PathThinner``
(which keeps only the points where the path bends, so a frame stays small without losing a
corner), keeps the tick's chart values (``labsim.runtime.view.peaks.Kept``), notes the tick's events
(a slider move, the timeline's, a change by hand, a count metric or a log, a state entered, a
collision begun, a breakpoint that held: what the page's Events list shows), and asks the
breakpoints (``labsim.runtime.view.breaks``) whether the run pauses here. ``take_path``,
``take_samples`` and ``take_events`` hand what was kept to the next frame and start again.
When every chart column is a value of its own, a tick with nothing to note goes a shorter way:
one call of the C extension ``runtime/view/_tap.c`` (``Tap``, with the paths as its ``Path``) where
the install built it, else a hook generated for the run's columns (``fast_after_act``); anything
else goes the general way. ``labsim.runtime.view.peaks.KERNEL`` says which: "c" or "python".
"""
from __future__ import annotations

import math
import struct
from collections.abc import Callable, Sequence
from typing import Any

from labsim.dsl.library.builtins import Aggregate
from labsim.dsl.library.support import STATE
from labsim.foundation.code_writer import Writer, render
from labsim.runtime.observers import Watcher, events_cell
from labsim.runtime.state import RobotRun, RunState
from labsim.runtime.view import peaks
from labsim.runtime.view.breaks import Breakpoint
from labsim.runtime.view.peaks import PACK_ERRORS, Kept, packed

PATH_TOLERANCE_M = 0.005  # a drawn path is never further than this from the simulated one
MAX_PATH_POINTS = 2000  # per robot between two frames (no page connected): the oldest go
MAX_SAMPLES_KEPT = 16384  # per robot between two frames: beyond, every other one goes
MAX_EVENTS_KEPT = 1000  # events between two frames (no page connected): the oldest go
EVENT_CHARS = 100  # an event's text as the page lists it (a log may be longer: the trace has it whole)


class PathThinner:
    """A path as the points where it bends: a point is kept when the path, from the last kept
    point, leaves the straight line it set out on by more than ``tolerance_m`` (or turns
    back). Every point between two kept ones lies within about ``tolerance_m`` of the segment
    between them, so a corner is never cut. One check per point: no look-back.

    Its state is plain floats in slots, not tuples: ``add`` runs every tick of every robot, and
    a tuple made and an item read each cost it a tenth of its time."""

    __slots__ = ("_along", "_ax", "_ay", "_lx", "_ly", "_on", "_seen", "_ux", "_uy", "points", "tol")

    def __init__(self, tolerance_m: float = PATH_TOLERANCE_M):
        self.tol = tolerance_m
        self.points: list[tuple[float, float]] = []  # kept since the last take
        self._ax = self._ay = math.nan  # the last kept point (nan: none yet)
        self._on = False  # whether a direction is set
        self._ux = self._uy = 0.0  # the unit vector from the last kept point
        self._along = 0.0  # the furthest along the direction so far, m
        self._seen = False  # whether a point was seen since the last kept one
        self._lx = self._ly = 0.0  # that point

    def add(self, x: float, y: float) -> None:
        if self._on:  # the common case, on every tick: still on the line (nan is not)
            dx, dy, tol = x - self._ax, y - self._ay, self.tol
            off = dx * self._uy - dy * self._ux
            if -tol <= off <= tol:
                along = dx * self._ux + dy * self._uy
                if along >= self._along - tol:
                    if along > self._along:
                        self._along = along
                    self._lx, self._ly = x, y
                    return
        self._add(x, y)

    def _add(self, x: float, y: float) -> None:
        if not (math.isfinite(x) and math.isfinite(y)):
            return
        if self._ax != self._ax:  # no point kept yet
            self._keep(x, y)
            return
        dx, dy = x - self._ax, y - self._ay
        if not self._on:  # still within the tolerance of the anchor: no direction yet
            dist = math.sqrt(dx * dx + dy * dy)  # as the C twin (_tap.c's Path) rounds it
            if dist >= self.tol:
                self._on, self._ux, self._uy, self._along = True, dx / dist, dy / dist, dist
            self._seen, self._lx, self._ly = True, x, y
            return
        along = dx * self._ux + dy * self._uy
        if abs(dx * self._uy - dy * self._ux) > self.tol or along < self._along - self.tol:
            self._keep(self._lx, self._ly)  # a direction is set by a point, which is the last seen
            self.add(x, y)  # again, from the point just kept
            return
        self._along = max(self._along, along)
        self._seen, self._lx, self._ly = True, x, y

    def jump(self, x: float, y: float) -> None:
        """The robot was put somewhere else: the path starts again there (no line across)."""
        self._ax = self._ay = math.nan
        self._on = self._seen = False
        self.points.append((math.nan, math.nan))
        self.add(x, y)

    def _keep(self, x: float, y: float) -> None:
        self.points.append((x, y))
        if len(self.points) > MAX_PATH_POINTS:
            del self.points[: len(self.points) - MAX_PATH_POINTS]
        self._ax, self._ay, self._on, self._along, self._seen = x, y, False, 0.0, False

    def pending(self) -> tuple[float, float] | None:
        """The last point seen and not kept (a path drawn now ends there), if any."""
        return (self._lx, self._ly) if self._seen else None

    def take(self) -> list[tuple[float, float]]:
        """The points kept since the last take (the frame's pose follows them on the page)."""
        out, self.points = self.points, []
        return out


class TickRecorder(Watcher):
    """See the module docstring. ``start`` is called once the run is bound, before it ticks.

    It is the run's ``Watcher`` too (the rule each robot fired last), and it keeps each robot's
    readings of the last tick run in the list ``start`` is given (``ObservedBackend.last``):
    one hook a tick for everything the view keeps, as each robot acts."""

    def __init__(self) -> None:
        self.xy: list[tuple[int, ...] | None] = []
        self.paths: list[Any] = []  # PathThinner, or its C twin
        self.samples: list[Kept] = []
        self.breaks: list[Breakpoint] = []
        self.hit: dict[str, object] | None = None  # the breakpoint that held on the last tick run
        self._run: RunState | None = None
        self.last: list = []
        self.events: list[list] = []  # [tick, time, robot, text] since the last frame
        self._inputs: Any = None  # the run's slider moves and changes by hand (``Inputs``), if any
        self.read: Any = None  # see ``chart``
        self.keep: Any = None
        self.pack: Any = None
        self.width = 0
        self._limit = 0

    def start(self, xy: list[tuple[int, ...] | None], last: list) -> None:
        """``xy[i]``: where robot i's x, y and collided sit in its readings (None: a mechanism, no path);
        ``last[i]`` gets robot i's readings each tick."""
        self.xy = xy
        self.last = last
        self.paths = [new_path() for _ in xy]
        self.touching = [False] * len(xy)  # per robot, whether it collided on the last tick
        self.collisions = [0] * len(xy)  # collisions begun so far
        self.hits: list[list[tuple[float, float]]] = [[] for _ in xy]  # where, since the last frame
        # where a count metric rose (a near miss, as the map of ``labsim plot`` marks it): [k, x, y],
        # k the metric's place among the count metrics (``count_names``), since the last frame
        self.marks: list[list[list]] = [[] for _ in xy]
        self.states: list[float | None] = [None] * len(xy)  # each robot's state on the last tick run (before a goto)
        self.chart(lambda _values: (), lambda _slots: (), 0)

    def chart(self, read: Any, keep: Any, width: int,
              columns: tuple[Sequence[int], Sequence[int]] | None = None) -> None:
        """What a tick keeps for the chart: ``read(values)`` and ``keep(slots)``, ``width`` values
        together (``labsim.runtime.view.peaks.Sampler``); what was kept before goes. ``columns``, the
        channels and slots read (when every column is a value of its own), has them packed as doubles
        (``Kept.data``) and makes ``after_act`` one call of the C extension (``tap``) or a generated
        function (``fast_after_act``), and ``quiet_act`` the same for ticks with no slider move (the
        live session's quiet tick): the run's hooks are to be collected again."""
        self.read, self.keep, self.width = read, keep, width
        self.pack = struct.Struct(f"{width}d").pack if columns is not None else None
        self._limit = MAX_SAMPLES_KEPT * width
        self.samples = [self._kept(self._run.tick_index if self._run is not None else 0) for _ in self.xy]
        self.__dict__.pop("after_act", None)
        self.quiet_act: Callable[[RobotRun, int, list], None] = self.after_act
        if columns is not None and self.xy and all(xy == self.xy[0] for xy in self.xy):
            make = tap if peaks.KERNEL == "c" else fast_after_act
            self.after_act = make(self, *columns, self._inputs)  # type: ignore[method-assign,assignment]
            # for a stretch of ticks with no slider move to apply (``Inputs.quiet``): no look at them
            self.quiet_act = make(self, *columns, None) if self._inputs is not None else self.after_act

    def bind(self, run: RunState) -> None:
        super().bind(run)
        self._run = run
        self._inputs = getattr(run, "inputs", None)
        counts = [i for i, a in enumerate(run.program.metric_aggregates) if a is Aggregate.COUNT]
        self.count_names = [run.program.metric_names[i] for i in counts]
        self._count_of = {i: k for k, i in enumerate(counts)}

    def after_act(self, robot: RobotRun, rule: int, values: list) -> None:
        """Every tick of every robot: what it keeps is a few C calls, and what happens seldom (a state
        entered, an event, a collision begun or ended, a breakpoint) costs one test each until it does."""
        i = robot.index
        self.last_rule[i] = rule
        self.last[i] = values
        program = robot.program
        slots = program.slots
        state, was = slots[STATE], self.states[i]
        self.states[i] = state  # a goto changes it after the tick: the frame shows this one
        if state != was or program.events or (i == 0 and self._inputs is not None and self._inputs.applied):
            self._note(robot, state, was, values)
        xy = self.xy[i]
        if xy is not None:
            self.paths[i].add(values[xy[0]], values[xy[1]])
            if len(xy) > 2 and bool(values[xy[2]]) is not self.touching[i]:  # a collision begins (or ends)
                self._touch(robot, values, xy)
        # every tick, so that a frame's envelope misses no peak: two itemgetter calls, in C
        kept = self.samples[i]
        if kept.data is not None:
            d = kept.data
            d += packed(self.pack, self.read(values) + self.keep(slots))
            full = len(d) > 8 * self._limit
        else:
            v = kept.values
            v.extend(self.read(values))
            v.extend(self.keep(slots))
            full = len(v) > self._limit
        if full:  # no page took them (none is ready): every other one goes
            kept.thin()
        if self.breaks:
            self._check(robot, rule, values)

    def _touch(self, robot: RobotRun, values: list, xy: tuple[int, ...]) -> None:
        """A collision begins (its place, for the page's mark) or ends."""
        i = robot.index
        c = self.touching[i] = not self.touching[i]
        if c:
            self.collisions[i] += 1
            self.hits[i].append((values[xy[0]], values[xy[1]]))
            self.event(robot.name, f"collision at ({values[xy[0]]:.2f}, {values[xy[1]]:.2f})")

    def _check(self, robot: RobotRun, rule: int, values: list) -> None:
        """Every breakpoint, every tick, for every robot: a condition must see each tick to know
        when it becomes true, and two that hold on one tick are both named."""
        assert self._run is not None
        t, dt = self._run.tick_index, self._run.dt_s
        fired = [b.spec for b in self.breaks if b.hit(robot, rule, values, t, dt)]
        if not fired:
            return
        # the state and rule of this tick (a goto takes effect on the next one)
        p = self._run.program
        state = int(robot.program.slots[STATE])
        self.event(robot.name, "breakpoint: " + " and ".join(fired))
        mine = {"robot": robot.name, "what": fired, "state": p.state_names[state] if p.state_names else "",
                "rule": p.rules[rule].id if rule >= 0 else None}
        if self.hit is None or self.hit["tick"] != t:
            self.hit = {"tick": t, "time": round(t * dt, 9), **mine, "what": " and ".join(fired), "fired": [mine]}
        else:  # another robot, the same tick
            fired_all: list = self.hit["fired"]  # type: ignore[assignment]
            fired_all.append(mine)

    def _note(self, robot: RobotRun, state: float, was: float | None, values: list) -> None:
        """The tick's events of ``robot``: a state entered (not the first), its count metrics (and
        where each rose) and logs, and (robot 0 only: they are the run's) the slider moves and
        changes by hand."""
        assert self._run is not None
        p = self._run.program
        xy, marks = self.xy[robot.index], self.marks[robot.index]
        if xy is not None:
            for e in robot.program.events:
                if type(e) is int and e in self._count_of and len(marks) < MAX_PATH_POINTS:
                    marks.append([self._count_of[e], values[xy[0]], values[xy[1]]])
        if was is not None and state != was and p.state_names:
            self.event(robot.name, f"state {p.state_names[int(was)]} → {p.state_names[int(state)]}")
        applied = self._inputs.applied if robot.index == 0 and self._inputs is not None else []
        if robot.program.events or applied:
            for text in events_cell(p, robot.program.events, applied).split(";"):
                self.event(robot.name, text)

    def event(self, robot: str, text: str) -> None:
        """One event on the tick running now, for the page's Events list."""
        assert self._run is not None
        t = self._run.tick_index
        text = text if len(text) <= EVENT_CHARS else text[:EVENT_CHARS - 3] + "..."
        self.events.append([t, round(t * self._run.dt_s, 9), robot, text])
        if len(self.events) > MAX_EVENTS_KEPT:
            del self.events[: len(self.events) - MAX_EVENTS_KEPT]

    def take_events(self) -> list[list]:
        out, self.events = self.events, []
        return out

    def take_path(self, robot: int) -> list[tuple[float, float]]:
        return self.paths[robot].take()

    def take_samples(self, robot: int) -> Kept:
        """The ticks kept since the last take, the last tick left out (the frame itself shows it)."""
        assert self._run is not None
        kept, self.samples[robot] = self.samples[robot].drop_last(), self._kept(self._run.tick_index)
        return kept

    def _kept(self, first: int) -> Kept:
        return Kept(first, self.width, packed=self.pack is not None)


def new_path() -> Any:
    """A robot's ``PathThinner``: the C twin where ``peaks.KERNEL`` is "c"."""
    return peaks._tap.Path(PATH_TOLERANCE_M, MAX_PATH_POINTS) if peaks.KERNEL == "c" else PathThinner()


def tap(rec: TickRecorder, channels: Sequence[int], slots: Sequence[int],
        inputs: Any) -> Callable[[RobotRun, int, list], None]:
    """``fast_after_act``'s hook as one call of the C extension (``_tap.Tap``): the same checks
    for a tick with something to note (which it hands to the general hook), then the rule, the
    readings, the path point and the chart's values packed, in one call. The recorder's paths
    are the extension's ``Path``. ``inputs`` None: ticks with no slider move to apply, which it
    need not look for."""
    assert rec._run is not None
    xy = rec.xy[0] or ()
    first = rec._run.robots[0].program
    one = len(rec.xy) == 1
    limit, pack = 8 * rec._limit, rec.pack

    def slow(kept: Kept, row: tuple) -> None:  # a value that is no number: packed as nan
        assert kept.data is not None
        kept.data += packed(pack, row)
        if len(kept.data) > limit:
            kept.thin()

    made: Callable[[RobotRun, int, list], None] = peaks._tap.Tap(
        TickRecorder.after_act.__get__(rec), slow, rec.states, rec.touching, rec.last_rule, rec.last, rec.paths,
        rec.samples, rec.breaks, inputs, first.slots if one else None, first.events if one else None, STATE,
        xy[0] if xy else -1, xy[1] if xy else -1, xy[2] if len(xy) > 2 else -1, limit, channels, slots)
    return made


def fast_after_act(rec: TickRecorder, channels: Sequence[int], slots: Sequence[int],
                   inputs: Any) -> Callable[[RobotRun, int, list], None]:
    """``rec.after_act`` as one generated function: a tick with nothing to note (no state entered,
    no event, slider move, collision begun or ended, no breakpoint set) keeps the rule, the
    readings, the path point and the chart's values (the columns written out, packed in one
    call); any other goes the general way. Every robot's readings put its position at the same
    place (``rec.xy``); a single robot's slots and events lists are the function's globals (a
    run keeps them for its length). Columns written out and the recorder's lists as globals cost
    a tick half the general hook's time."""
    assert rec._run is not None
    xy = rec.xy[0]
    one = len(rec.xy) == 1
    i = "0" if one else "i"
    values = [f"values[{c}]" for c in channels] + [f"s[{c}]" for c in slots]
    w = Writer()
    w.line("def after_act(r, rule, values):")
    with w.indent():
        if not one:
            w.line("i = r.index")
            w.line("prog = r.program")
            w.line("s, events = prog.slots, prog.events")
        unusual = [f"s[STATE] != states[{i}]", "events", "breaks"]
        if inputs is not None:  # (None: a quiet tick, with no slider move)
            unusual.append("inputs.applied" if one else "(inputs.applied and i == 0)")
        if xy is not None and len(xy) > 2:  # a collision begins or ends (the general hook tells which)
            unusual.append(f"values[{xy[2]}] != touching[{i}]")
        w.line(f"if {' or '.join(unusual)}:")
        with w.indent():
            w.line("return general(r, rule, values)")
        w.line(f"last_rule[{i}] = rule")
        w.line(f"last[{i}] = values")
        if xy is not None:
            _path_lines(w, i, xy)
        if values:
            _chart_lines(w, i, ", ".join(values))
    source = render(w.body())[0]
    first = rec._run.robots[0].program
    space: dict[str, Any] = {"general": TickRecorder.after_act.__get__(rec), "states": rec.states, "STATE": STATE,
                             "breaks": rec.breaks, "inputs": inputs, "touching": rec.touching,
                             "last_rule": rec.last_rule, "last": rec.last, "paths": rec.paths,
                             "samples": rec.samples, "LIMIT": 8 * rec._limit, "PACK": rec.pack,
                             "PACK_ERRORS": PACK_ERRORS, "packed": packed, "s": first.slots, "events": first.events}
    exec(compile(source, "<labsim view tick>", "exec"), space)  # column indices only, no file text
    made: Callable[[RobotRun, int, list], None] = space["after_act"]
    return made



def _path_lines(w: Writer, i: str, xy: tuple[int, ...]) -> None:
    """``PathThinner.add``'s common case written out (a call less a tick); the rest its own way."""
    w.line(f"p = paths[{i}]")
    w.line(f"x = values[{xy[0]}]")
    w.line(f"y = values[{xy[1]}]")
    w.line("if p._on:")
    with w.indent():
        w.line("dx = x - p._ax")
        w.line("dy = y - p._ay")
        w.line("tol = p.tol")
        w.line("if -tol <= dx * p._uy - dy * p._ux <= tol and "
               "(along := dx * p._ux + dy * p._uy) >= p._along - tol:")
        with w.indent():
            w.line("if along > p._along:")
            with w.indent():
                w.line("p._along = along")
            w.line("p._lx = x")
            w.line("p._ly = y")
        w.line("else:")
        with w.indent():
            w.line("p._add(x, y)")
    w.line("else:")
    with w.indent():
        w.line("p._add(x, y)")


def _chart_lines(w: Writer, i: str, row: str) -> None:
    """The tick's chart values packed while they are fresh in the cache (``Kept``), in one call."""
    w.line(f"kept = samples[{i}]")
    w.line("d = kept.data")
    w.line("try:")
    with w.indent():
        w.line(f"d += PACK({row})")
    w.line("except PACK_ERRORS:")
    with w.indent():
        w.line(f"d += packed(PACK, ({row},))")
    w.line("if len(d) > LIMIT:")
    with w.indent():
        w.line("kept.thin()")
