"""The tick loop: a compiled behaviour driving a backend, one fixed step at a time.

``compile_behaviour(path) -> Behaviour``, ``Behaviour.bind(backend) -> Run``, ``Run.tick()``:
compile once, tick many times. A tick is, for every robot at once:

1. sense: the backend returns one consistent snapshot of every channel the behaviour reads;
2. the ``let`` signals are evaluated in order;
3. the stop condition: when it holds for any robot, the run ends before acting (in format
   1.1 the stopping tick is still folded into metrics and traced);
4. the first rule of the robot's current state whose condition holds acts; wheel commands
   are clamped to the model's limit (and counted) and sent only when they change;
5. metrics fold the tick's values; the trace gets one row per robot;
6. ``goto`` takes effect (the next tick uses the new state); the backend steps ``dt``.

Each robot owns its slots, command, random generator (seeded from the behaviour's seed and
the robot's name) and metric accumulators; nothing is shared between robots or runs. A robot's
declared noise sits between the backend and its program (``labsim.runtime.noise``).

Over 500 lines: the tick loop is one closure on purpose (the hot path), and the set-up, the
trace rows and the summary it fills read the same per-robot state; the summary's type and
the replay's reader live in ``summary.py`` and ``trace.py``.
"""
from __future__ import annotations

import hashlib
import math
import random
import time as clock
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from labsim import __version__
from labsim.backends.protocol import Backend, RobotRequest
from labsim.backends.scene.models import Kind, RobotModel
from labsim.backends.scene.world import BUILTIN_DIR, PLACEMENT_CLEARANCE_M, Pose, World
from labsim.dsl.builtins import Type
from labsim.dsl.compile import compile_file
from labsim.dsl.noise import Noise
from labsim.dsl.program import Program, RobotProgram
from labsim.dsl.support import STATE, Faults, FaultSite, metric_result
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.runtime.budgets import RunWatch
from labsim.runtime.interrupts import CallbackInterrupts
from labsim.runtime.noise import NoisyIO, robot_noise
from labsim.runtime.summary import Summary, fleet_value
from labsim.runtime.trace import FORMAT, TraceWriteError, TraceWriter

TRACE_POSE = ("x", "y", "heading", "collided")  # what the trace records of every robot, in its columns


def compile_behaviour(path: str | Path, overrides: dict[str, str] | None = None,
                      seed: int | None = None, strict: bool = False,
                      budgets: Budgets = DEFAULT_BUDGETS) -> Behaviour:
    """Compile a behaviour file; raises LabsimError listing every problem in it.

    ``overrides`` set parameters, as ``--set`` does; ``seed`` replaces the file's ``seed:``;
    ``budgets`` bound what its runs may cost (docs/security.md).
    """
    return Behaviour(compile_file(path, overrides, seed, strict, budgets), budgets)


@dataclass
class Behaviour:
    program: Program
    budgets: Budgets = DEFAULT_BUDGETS

    def bind(self, backend: Backend, *, trace: str | Path | None = None,
             warn: Callable[[str], None] | None = None,
             replay: dict[int, list[tuple[str, float]]] | None = None) -> Run:
        """Open the behaviour's world on a backend, ready to tick.

        ``replay`` (tick -> slider settings, see ``slider_events``) replaces the file's
        timeline: a recorded run's slider moves, fed back.
        """
        return Run(self.program, backend, trace_path=trace, warn=warn, replay=replay, budgets=self.budgets)


@dataclass
class RobotRun:
    """A robot during a run: its compiled program and what the runtime tracks for it."""

    index: int
    name: str
    model: RobotModel | None  # None: the world's mechanism
    program: RobotProgram
    limit: float  # wheel speed limit, rad/s
    start: Pose  # where it was placed
    sent_left: float = math.nan  # the last command sent to the backend, rad/s
    sent_right: float = math.nan
    sent_joints: list[float] = field(default_factory=list)  # per Program.targets
    clamping: bool = False  # whether the command now held exceeds the limit
    clamped_ticks: int = 0
    paths: tuple[tuple[str, str], ...] = ()  # the behaviour file's scene names for it
    noise: Noise | None = None  # its declared noise (labsim.runtime.noise), None: none


class Run:
    def __init__(self, program: Program, backend: Backend, *, trace_path: str | Path | None = None,
                 warn: Callable[[str], None] | None = None,
                 replay: dict[int, list[tuple[str, float]]] | None = None,
                 budgets: Budgets = DEFAULT_BUDGETS):
        self.program = program
        self.budgets = budgets
        self.over_budget = ""  # why the run stopped before its stop condition held, if a budget stopped it
        self._warn = warn
        self.backend = backend
        self.dt = program.dt_s
        self.tick_index = 0
        self.finished = False
        self.stopped_by: str | None = None  # the first robot whose stop condition held
        self.stop_part = -1  # which top-level 'or' part of the stop condition held for it
        self.faults = Faults(warn, clock=lambda: self.tick_index)
        self.fired = [0] * len(program.rules)
        self._log_windows: dict[int, list[int]] = {}  # log site -> [simulated second, lines in it]
        self.logs_dropped: dict[int, int] = {}  # log site -> lines not printed (LOG_RATE)
        self.idle = 0
        self.trace: TraceWriter | None = None
        self.trace_error: TraceWriteError | None = None  # the OS refused a trace write: the run stopped
        self.recorded = 0  # the ticks the trace has rows of (its footer's count)
        self.robots = self._robots()
        self.watched = False  # see watch()
        self.last_rule: list[int] = [-1] * len(self.robots)
        self._nch = len(program.channels)
        self._actuator_sites = [
            FaultSite(f"rule {r.id}", Diagnostic(program.path, "", r.line, 1, 0, "warning", ""))
            for r in program.rules]
        # the trace records every robot's pose and contact state: a channel the behaviour reads
        # too is read once and lands in both; the others are read after the behaviour's own.
        # Without a trace they are not read at all.
        traced = TRACE_POSE if trace_path is not None else ()
        self._extra = tuple(c for c in traced if c not in program.channels)
        channels = program.channels + self._extra
        self._pose_at = [channels.index(c) for c in traced]  # where the trace finds each
        requests = [RobotRequest(r.name, r.model, r.start, channels, r.paths) for r in self.robots]
        backend.open(program.world, requests, self.dt, program.seed)
        self._sense, self._act, self._step = backend.sense, backend.act, backend.step
        self.noise = self._noise()
        self._command = getattr(backend, "command", None)
        self._trace_fields = self._traced()
        self._timeline = self._schedule(replay)
        self._slider_events: list[str] = []  # the timeline's settings applied this tick, for the trace
        if trace_path is not None:
            self.trace = TraceWriter(trace_path, self.header() | self._noise_header(), self.columns())
        self.tick = self._make_tick()

    # -- set-up ------------------------------------------------------------------------------
    def _robots(self) -> list[RobotRun]:
        p = self.program
        placement = random.Random(f"{p.seed}/placement")
        spawns = list(p.world.spawns)
        taken: list[Pose] = []
        robots: list[RobotRun] = []
        if p.mechanism_agent:  # no robots: one agent reads and drives the mechanism
            program = p.robot(p.world.name, random.Random(f"{p.seed}/{p.world.name}"), self.faults, None)
            return [RobotRun(0, p.world.name, None, program, math.inf, start=Pose(0.0, 0.0, 0.0),
                             sent_joints=[math.nan] * len(p.targets))]
        for group in p.robots:
            model = group.model
            for k in range(group.count):
                name = group.name if group.count == 1 else f"{group.name}[{k}]"
                if group.at == "spawn":
                    if not spawns:
                        assert p.spawn_shortage is not None  # the compiler found this robot short of one
                        raise LabsimError([p.spawn_shortage])
                    pose = spawns.pop(0)
                elif group.at == "random":
                    pose = _free_pose(p.world, placement, taken)
                else:
                    assert not isinstance(group.at, str)
                    x, y, heading_deg = group.at
                    pose = Pose(x, y, math.radians(heading_deg))
                taken.append(pose)
                rng = random.Random(f"{p.seed}/{name}")
                program = p.robot(name, rng, self.faults, model, group, k)
                robots.append(RobotRun(len(robots), name, model, program, model.max_wheel_speed_rad_s, start=pose,
                                       sent_joints=[math.nan] * len(p.targets), paths=group.paths,
                                       noise=group.noise))
        return robots

    def _noise(self) -> NoisyIO | None:
        """The robots' noise in front of the backend's calls; None (and no cost) when none has any."""
        noisy = [robot_noise(self.program, r.index, r.name, r.model, r.noise)
                 for r in self.robots if r.noise and r.model is not None]
        if not noisy:
            return None
        io = NoisyIO(noisy, self._sense, self._act, self._step)
        self._sense, self._act, self._step = io.sense, io.act, io.step
        return io

    def _noise_header(self) -> dict:
        """The trace header's ``noise``: each noisy robot's models; nothing at all without noise."""
        noise = {r.name: r.noise.header() for r in self.robots if r.noise}
        return {"noise": noise} if noise else {}

    def header(self) -> dict:
        p = self.program
        return {
            "format": FORMAT, "labsim": __version__, "backend": getattr(self.backend, "name", "?"),
            "behaviour": p.path, "name": p.name, "sha256": p.sha256, "world": p.world.name,
            "world_file": _world_file(p.world), **_world_identity(p.world),
            "dt": self.dt, "seed": p.seed, "params": dict(p.params),
            "robots": {r.name: r.model.name if r.model else "mechanism" for r in self.robots},
            "metrics": dict(zip(p.metric_names, (a.value for a in p.metric_aggregates))),
        }

    def _schedule(self, replay: dict[int, list[tuple[str, float]]] | None = None
                  ) -> dict[int, list[tuple[int, float, str]]]:
        """The timeline by tick: an event at time t applies at the first tick whose time >= t."""
        p = self.program
        out: dict[int, list[tuple[int, float, str]]] = {}
        if replay is not None:
            for tick, moves in replay.items():
                for name, value in moves:
                    if name not in p.slot_of or name not in p.slider_ranges:
                        raise LabsimError([Diagnostic(p.path, f"the replayed trace moves slider '{name}', "
                                                      "which this behaviour does not have")])
                    out.setdefault(tick, []).append((p.slot_of[name], value, f"{name}={value:g}"))
            return out
        for time_s, settings in p.timeline:
            tick = max(0, math.ceil(time_s / self.dt - 1e-9))
            for name, value in settings:
                out.setdefault(tick, []).append((p.slot_of[name], value, f"{name}={value:g}"))
        return out

    def set_slider(self, name: str, value: float) -> None:
        """Move a slider now (from the next tick's signals on): what a live view's drag does.

        The move is recorded in the trace's events column, as the timeline's are.
        """
        p = self.program
        lo, hi = p.slider_ranges[name]
        value = min(hi, max(lo, value))
        self._timeline.setdefault(self.tick_index, []).append((p.slot_of[name], value, f"{name}={value:g}"))

    def _traced(self) -> tuple[list[int], list[int]]:
        """Which channel values and which signal slots the trace records: numbers and booleans.

        Images and records have no CSV cell; a behaviour traces what it derives from them
        (``cx: centroid(lane).x`` is a column).
        """
        p = self.program
        kinds = p.channel_kinds
        channels = [i for i, c in enumerate(p.channels) if c not in TRACE_POSE
                    and kinds.get(c) in (Kind.DISTANCE, Kind.NUMBER, Kind.BOOL)]
        lets = [p.slot_of[n] for n in p.let_names if p.signal_types.get(n) in (Type.NUMBER, Type.BOOL)]
        return channels, lets

    def columns(self) -> list[str]:
        p = self.program
        channels, lets = self._traced()
        names = {slot: name for name, slot in p.slot_of.items()}
        return (["tick", "time", "robot", "x", "y", "heading", "collided", "state", "rule"]
                + [p.channels[i] for i in channels] + [names[i] for i in lets] + list(p.slider_names)
                + [f"label:{slider}" for slider, _ in p.labels]
                + ["wheel_left", "wheel_right", "events"])

    # -- the loop ----------------------------------------------------------------------------
    def _make_tick(self) -> Callable[[], bool]:
        """Build ``tick()``: one tick of the run, False once the stop condition has held.

        Long, as one closure over locals, because it is the hot path: an attribute lookup per robot per
        tick costs as much as a rule. A fleet senses and evaluates every robot's signals
        before any robot acts, so that the stop condition can end the run before anyone
        acts; a single robot does both in one generated function.
        """
        robots = [(r.index, r.program.slots, r.program.signals, r.program.decide, r.program.command,
                   r.program.events, r) for r in self.robots]
        sense, step, send = self._sense, self._step, self._send
        fired = self.fired
        n = self._nch
        dt = self.dt
        trace, trace_row = self.trace, self._trace_row
        timeline = self._timeline
        has_sliders = bool(self.program.slider_names) or bool(timeline)
        targets = self.program.targets
        command = self._command
        watched, last_rule = self.watched, self.last_rule
        has_logs = bool(self.program.logs)
        fold_stop = self.program.fold_stop

        def last(r: RobotRun, values: list) -> None:
            """The stopping tick (format 1.1): sensed, folded into metrics and traced; no rule acts."""
            r.program.fold(self.tick_index * dt, self.tick_index, values if len(values) == n else values[:n])
            if trace is not None:
                trace_row(r, values, -1)
            r.program.events.clear()

        def inputs(t: int) -> None:
            """The timeline's slider settings for this tick, before anything reads them."""
            self._slider_events = []
            for slot, value, text in timeline.pop(t, ()):
                for _, s, *_ in robots:
                    s[slot] = value
                self._slider_events.append(text)

        def act(r: RobotRun, s: list, cmd: list, events: list, rule: int, values: list) -> None:
            if rule >= 0:
                fired[rule] += 1
            else:
                self.idle += 1
            if watched:
                last_rule[r.index] = rule
            if r.model is not None and (cmd[0] != r.sent_left or cmd[1] != r.sent_right):
                send(r, cmd[0], cmd[1], rule)
            if r.clamping:
                r.clamped_ticks += 1
            if targets:
                assert command is not None  # a behaviour that moves joints runs on a backend with joints
                joints, sent = r.program.joint_command, r.sent_joints
                for k, value in enumerate(joints):
                    if value != sent[k] and value == value:
                        sent[k] = value
                        command(r.index, targets[k][0], targets[k][1], value)
            if events and has_logs:
                self._print_logs(r, events)
            if trace is not None:
                trace_row(r, values, rule)
            if events:
                events.clear()
            s[STATE] = cmd[2]  # a goto takes effect from the next tick

        if len(robots) == 1:
            (_, s1, _, _, cmd1, events1, r1), = robots
            both = r1.program.both

            def tick_one() -> bool:
                if self.finished:
                    return False
                t = self.tick_index
                if has_sliders:
                    inputs(t)
                values = sense()[0]
                rule = both(t * dt, t, values if len(values) == n else values[:n])
                if rule == -2:
                    self.stopped_by = r1.name
                    self.stop_part = r1.program.stop_part[0]
                    self.finished = True
                    if fold_stop:
                        last(r1, values)
                    return False
                if rule >= 0 and trace is None and not events1 and not targets and r1.model is not None \
                        and not watched:
                    fired[rule] += 1  # the common case, inline
                    if cmd1[0] != r1.sent_left or cmd1[1] != r1.sent_right:
                        send(r1, cmd1[0], cmd1[1], rule)
                    if r1.clamping:
                        r1.clamped_ticks += 1
                    s1[STATE] = cmd1[2]
                else:
                    act(r1, s1, cmd1, events1, rule, values)
                step()
                self.tick_index = t + 1
                return True
            return tick_one

        def tick() -> bool:
            if self.finished:
                return False
            t = self.tick_index
            if has_sliders:
                inputs(t)
            now = t * dt
            readings = sense()
            stop = False
            for i, _, signals, _, _, _, _ in robots:
                values = readings[i]
                if signals(now, t, values if len(values) == n else values[:n]) and not stop:
                    stop = True
                    self.stopped_by = self.robots[i].name
                    self.stop_part = self.robots[i].program.stop_part[0]
            if stop:
                self.finished = True
                if fold_stop:
                    for i, *_, r in robots:
                        last(r, readings[i])
                return False
            for i, s, _, decide, cmd, events, r in robots:
                act(r, s, cmd, events, decide(), readings[i])
            step()
            self.tick_index = t + 1
            return True

        return tick

    def watch(self) -> None:
        """Keep the rule each robot fired on the last tick in ``last_rule`` (-1: none), for a
        live view. An unwatched run does not pay for it."""
        self.watched = True
        self.tick = self._make_tick()

    def _send(self, r: RobotRun, left: float, right: float, rule: int) -> None:
        r.sent_left, r.sent_right = left, right  # what the behaviour asked, to notice a change
        limit = r.limit
        if -limit <= left <= limit and -limit <= right <= limit:  # false for nan too
            r.clamping = False
            self._act(r.index, left, right)
            return
        out = []
        for v in (left, right):
            if v != v:
                self._actuator_fault(r, rule, "nan wheel command (the wheel is stopped)")
                v = 0.0
            elif v > limit or v < -limit:
                if v in (math.inf, -math.inf):
                    self._actuator_fault(r, rule, "infinite wheel command (clamped to the speed limit)")
                v = limit if v > 0 else -limit
            out.append(v)
        # nan is stopped, not clamped: only a real excess counts as clamping
        r.clamping = any(abs(v) > limit for v in (left, right))
        self._act(r.index, out[0], out[1])

    def _print_logs(self, r: RobotRun, events: list) -> None:
        """Print each ``log(...)`` of this tick, at most ``LOG_RATE`` lines a simulated second per
        log; the rest are counted for the summary (the trace records them all)."""
        emit = self.faults.emit
        second = int(self.tick_index * self.dt)
        for e in events:
            if isinstance(e, int):
                continue
            site = e[0]
            window = self._log_windows.setdefault(site, [second, 0])
            if window[0] != second:
                window[:] = [second, 0]
            window[1] += 1
            if window[1] > LOG_RATE:
                self.logs_dropped[site] = self.logs_dropped.get(site, 0) + 1
            elif emit is not None:
                emit(f"[{self.tick_index * self.dt:.2f} s] {r.name}: {self.program.log_text(*e)}")

    def _actuator_fault(self, r: RobotRun, rule: int, what: str) -> None:
        if rule >= 0:
            site = self._actuator_sites[rule]
        else:
            site = FaultSite("no rule", Diagnostic(self.program.path, ""))
        self.faults.report(site, what, self.tick_index, r.name)

    def _trace_row(self, r: RobotRun, values: list, rule: int) -> None:
        assert self.trace is not None
        p = self.program
        prog = r.program
        s = prog.slots
        at = self._pose_at
        x, y, heading, collided = values[at[0]], values[at[1]], values[at[2]], values[at[3]]
        channels, slots = self._trace_fields
        extra = [values[i] for i in channels]
        lets = [s[i] for i in slots]
        label = p.rules[rule].id if rule >= 0 else ""
        cmd = prog.command
        sliders = [s[p.slot_of[name]] for name in p.slider_names]
        labels = list(p.label_text(s).values()) if p.labels else []
        events = [p.metric_names[e] if isinstance(e, int) else "log: " + _one_field(p.log_text(*e))
                  for e in prog.events] + self._slider_events
        state = p.state_names[s[STATE]] if p.state_names else ""
        self.trace.write([self.tick_index, round(self.tick_index * self.dt, 9), r.name, x, y, heading,
                          collided, state, label, *extra, *lets, *sliders, *labels,
                          cmd[0], cmd[1], ";".join(events)])
        self.recorded = self.tick_index + 1  # an interrupt may land before the tick ends: count rows

    def run(self, progress: Callable[[int, float], None] | None = None,
            max_ticks: int | None = None) -> Summary:
        """Tick until the stop condition holds (or max_ticks); always closes the trace.

        The run's budgets (``budgets``) stop it too: past its ticks or its trace size it ends
        with ``over_budget`` saying which, the trace so far kept (docs/security.md).
        """
        start = clock.perf_counter()
        interrupted = ended = False
        watch = RunWatch(self.budgets, self.dt, self.program.stop_horizon_s, start, self._warn)
        limit = self.budgets.ticks if max_ticks is None else min(max_ticks, self.budgets.ticks)
        tick = self.tick
        try:
            with CallbackInterrupts() as caught:  # an interrupt inside a C callback still ends the run
                while True:
                    end = min(limit, self.tick_index + 256)
                    while self.tick_index < end:
                        if not tick():
                            break
                    caught.check()
                    if self.finished or (max_ticks is not None and self.tick_index >= max_ticks):
                        break
                    self.over_budget = watch.check(self.tick_index, self.trace)
                    if self.over_budget:
                        break
                    if progress is not None:
                        progress(self.tick_index, self.tick_index * self.dt)
                ended = not self.over_budget  # a run a budget stopped is cut short: its footer says so
        except KeyboardInterrupt:
            interrupted = True
        except TraceWriteError as e:  # the run stops; its summary is still shown (docs/trace-format.md)
            self.trace_error = e
            interrupted = True
        finally:
            self._close_trace(not ended)
        summary = self.summary(clock.perf_counter() - start, interrupted)
        summary.over_budget = self.over_budget
        return summary

    def _close_trace(self, interrupted: bool) -> None:
        """The trace's footer and its rename into place; a failure is kept for the command to report."""
        if self.trace is None:
            return
        try:
            self.trace.close(max(self.tick_index, self.recorded), interrupted)
        except TraceWriteError as e:
            self.trace_error = self.trace_error or e

    def summary(self, wall_time_s: float, interrupted: bool = False) -> Summary:
        p = self.program
        out = Summary(p.name, getattr(self.backend, "name", "?"), self.tick_index,
                      self.tick_index * self.dt, wall_time_s, interrupted,
                      trace=str(self.trace.path) if self.trace is not None else None)
        for r in self.robots:
            contacts = self.backend.contacts(r.index)
            metrics = {name: metric_result(agg, acc, self.dt) for name, agg, acc in
                       zip(p.metric_names, p.metric_aggregates, r.program.metric_values)}
            out.robots[r.name] = {"contacts": contacts.count, "contact_time_s": contacts.time_s,
                                  "clamped_ticks": r.clamped_ticks, "metrics": metrics,
                                  "labels": p.label_text(r.program.slots) if p.labels else {},
                                  "mechanism": r.model is None}
        if len(self.robots) > 1:
            for name, agg in zip(p.metric_names, p.metric_aggregates):
                out.fleet[name] = fleet_value(agg, [r["metrics"][name] for r in out.robots.values()])
        out.stopped_by = self.stopped_by
        out.noise = self.noise.summary() if self.noise is not None else {}
        if self.stopped_by is not None:
            parts = p.stop_parts
            out.stop_condition = parts[self.stop_part] if 0 <= self.stop_part < len(parts) else p.stop_text
        out.rule_counts = {rule.id: n for rule, n in zip(p.rules, self.fired)}
        out.rule_labels = {rule.id: rule.text for rule in p.rules}
        out.idle_ticks = self.idle
        for site_index, n in self.logs_dropped.items():
            line = p.logs[site_index][0]
            out.faults.append(f"log on line {line}: {n} line{'s' if n != 1 else ''} not printed "
                              f"(at most {LOG_RATE} a simulated second; the trace has them all)")
        for (site, what), n in self.faults.counts.items():
            tick, robot = self.faults.first[(site, what)]
            out.faults.append(f"{site.where}: {what}: {n} time{'s' if n != 1 else ''} "
                              f"(first at tick {tick}, robot {robot})")
        return out

    def close(self) -> None:
        self._close_trace(True)  # closed already unless the run never started
        self.backend.close()


# A log(...) prints at most this many lines per simulated second (per log in the file): a rule
# that fires every tick cannot flood the terminal; the trace keeps every line.
LOG_RATE = 5


def _one_field(text: str) -> str:
    """A log's text as one cell of the events column: no ';' (the separator) and no newline."""
    return text.replace(";", ",").replace("\n", " ")


def _world_file(world: World) -> str:
    """Where the world came from, for the trace: '' for a built-in (its name says it all)."""
    source = Path(world.source)
    if source.parent == BUILTIN_DIR:
        return ""
    try:
        return str(source.resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(source)


def _world_identity(world: World) -> dict[str, str]:
    """The world's SHA-256 (of its file's text), and for a built-in the labsim version that
    shipped it: a golden says when the world changed under it."""
    try:
        digest = hashlib.sha256(Path(world.source).read_bytes()).hexdigest() if world.source else ""
    except OSError:
        digest = ""
    out = {"world_sha256": digest}
    if world.source and Path(world.source).parent == BUILTIN_DIR:
        out["world_version"] = f"built-in, labsim {__version__}"
    return out


def _free_pose(world: World, rng: random.Random, taken: list[Pose]) -> Pose:
    pose = world.free_pose(rng, taken, PLACEMENT_CLEARANCE_M)
    if pose is None:  # the compiler places robots the same way, and says so at the robot's line
        raise LabsimError([Diagnostic(world.source or world.name, "no free place left for another robot")])
    return pose

