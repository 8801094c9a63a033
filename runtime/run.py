"""The tick loop: a compiled behaviour driving a backend, one fixed step at a time.

``compile_behaviour(path) -> Behaviour``, ``Behaviour.bind(backend) -> Run``, ``Run.tick()``:
compile once, tick many times. Binding opens the behaviour's world on the backend with the
robots the compiler placed (``Program.starts``), chooses the run's observers
(``labsim.runtime.observers``: the trace, a live view's watcher, the log printer, slider inputs,
joint commands, and any the caller adds) and builds the tick from them once
(``labsim.runtime.tick``). ``Run.run()`` ticks until the stop condition holds, a budget or
Ctrl-C stops it, and hands back a frozen ``RunResult`` (``labsim.runtime.result``).

Each robot owns its slots, command, random generator (seeded from the behaviour's seed and
the robot's name) and metric accumulators; nothing is shared between robots or runs. A robot's
declared noise sits between the backend and its program (``labsim.runtime.noise``).
"""
from __future__ import annotations

import math
import random
import time as clock
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from labsim.backends.protocol import Backend, RobotRequest
from labsim.backends.scene.world import Pose, World
from labsim.backends.scene.world_names import builtin_name
from labsim.dsl.compile import compile_file
from labsim.dsl.emit.program import Program
from labsim.dsl.library.support import Faults, FaultSite, metric_result
from labsim.dsl.syntax.noise import Noise
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.foundation.memory import memory_cap, out_of_memory
from labsim.foundation.version import version
from labsim.runtime.budgets import RunWatch, out_of_memory_message, trace_full_message
from labsim.runtime.hands import Hand, Hands, HandsOn, event_text
from labsim.runtime.interrupts import CallbackInterrupts
from labsim.runtime.labs import behaviour_path
from labsim.runtime.noise import NoisyIO, noisy, robot_noise
from labsim.runtime.observers import (
    CAP_NOTE,
    LOG_RATE,
    TRACE_POSE,
    Inputs,
    JointCommands,
    LogPrinter,
    Observer,
    Schedule,
    TraceRows,
    Watcher,
    hooks,
    trace_columns,
)
from labsim.runtime.result import (
    BUDGET,
    INTERRUPTED,
    MAX_TICKS,
    STOP_CONDITION,
    RobotResult,
    RuleResult,
    RunResult,
    fleet_value,
)
from labsim.runtime.state import RobotRun
from labsim.runtime.tick import make_tick
from labsim.runtime.trace import FORMAT, TraceFull, TraceWriteError, TraceWriter

Setting = float | int | bool | str  # a parameter's value from Python (--set gives text)
Replay = dict[int, list[tuple[str, float]]]  # tick -> slider settings (trace.slider_events)
# The summary names at most this many lines of the file whose logs were not all printed, then
# counts the rest together: a file of 500 logs has a summary of a screen, not of 500 lines.
UNPRINTED_SHOWN = 20


def compile_behaviour(behaviour: str | Path, params: Mapping[str, Setting] | None = None, seed: int | None = None, *,
                      budget: Budgets | Mapping[str, int] | None = None, strict: bool = False,
                      text: str | None = None) -> Behaviour:
    """Compile a behaviour file, or a shipped lab by name ('wall_follow'), once for many runs;
    raises LabsimError listing every problem in it. The one way in to the compiler for the
    command line, the applications and the Python API (``labsim.compile_behaviour``).

    ``params`` set parameters as ``--set`` does (numbers, booleans or their text); ``seed``
    replaces the file's ``seed:``; ``budget`` bounds what its runs may cost (``Budgets``, or
    ``{"ticks": 20000, "memory_mb": 500}`` checked as ``--budget`` is; docs/security.md);
    ``strict`` makes warnings errors; ``text`` is compiled in place of the file's (a live view's edit).
    """
    budgets, problems = (budget, []) if isinstance(budget, Budgets) else DEFAULT_BUDGETS.parse(
        [f"{k}={v}" for k, v in (budget or {}).items()])
    if problems:
        raise LabsimError([Diagnostic(where.replace("--budget ", "budget "), message) for where, message in problems])
    overrides = {k: ("true" if v else "false") if isinstance(v, bool) else str(v) for k, v in (params or {}).items()}
    return Behaviour(compile_file(behaviour_path(str(behaviour)), overrides, seed, strict, budgets, text), budgets)


@dataclass
class Behaviour:
    program: Program
    budgets: Budgets = DEFAULT_BUDGETS

    def bind(self, backend: Backend, *, trace: str | Path | None = None,
             warn: Callable[[str], None] | None = None, log: Callable[[str], None] | None = None,
             replay: Replay | None = None, watch: bool = False,
             observers: Sequence[Observer] = (), hands: Hands | None = None) -> Run:
        """Open the behaviour's world on a backend, ready to tick.

        ``warn`` is told each runtime warning as it happens, ``log`` each line a ``log(...)``
        prints (``warn`` when not given); ``replay`` (tick -> slider settings, see
        ``slider_events``) replaces the file's timeline: a recorded run's slider moves, fed
        back. ``watch`` keeps the rule each robot fired last (``Run.last_rule``, for a live
        view); ``observers`` are the caller's own, after labsim's; ``hands`` a recorded run's
        changes by hand (``labsim.runtime.hands.hand_events``), done again.
        """
        return Run(self.program, backend, trace_path=trace, warn=warn, log=log, replay=replay,
                   budgets=self.budgets, watch=watch, observers=observers, hands=hands)


class Run:
    """A behaviour bound to a backend; see the module docstring."""

    def __init__(self, program: Program, backend: Backend, *, trace_path: str | Path | None = None,
                 warn: Callable[[str], None] | None = None, log: Callable[[str], None] | None = None,
                 replay: Replay | None = None, budgets: Budgets = DEFAULT_BUDGETS, watch: bool = False,
                 observers: Sequence[Observer] = (), hands: Hands | None = None):
        self.program = program
        self.budgets = budgets
        self.backend = backend
        self.dt_s = program.dt_s
        self.tick_index = 0
        self.finished = False
        self.stopped_by: str | None = None  # the first robot whose stop condition held
        self.stop_part = -1  # which top-level 'or' part of the stop condition held for it
        self.over_budget = ""  # why the run stopped before its stop condition held, if a budget stopped it
        self.interrupted = False
        self.wall_time_s = 0.0
        self.warnings: list[str] = []  # the runtime warnings so far
        self._warn = warn
        self.faults = Faults(self._warned, clock=lambda: self.tick_index)
        self.fired = [0] * len(program.rules)
        self.idle = 0
        self.trace: TraceWriter | None = None
        # format 1.3: what each robot reads of the others, last tick's (Program.peer_start); the tick replaces it
        self.peers: list[tuple] = program.peer_start() if program.peer_fields else []
        self.trace_error: TraceWriteError | None = None  # the OS refused a trace write: the run stopped
        # a live view shows every image signal after the tick: kept, while they fit the memory budget
        self.robots = self._robots(watch and program.image_bytes_all <= budgets.memory_mb * 1_000_000)
        self._actuator_sites = [
            FaultSite(f"rule {r.id}", Diagnostic(program.path, "", r.line, 1, 0, "warning", ""))
            for r in program.rules]
        # the trace records every robot's pose and contact state: a channel the behaviour reads
        # too is read once and lands in both; the others are read after the behaviour's own.
        # Without a trace they are not read at all. An observer names the channels it reads of
        # every robot (``Observer.reads``: an in-memory recording's poses) and gets them so too.
        traced = (*(TRACE_POSE if trace_path is not None else ()), *(c for o in observers for c in o.reads))
        self.channels = program.channels + tuple(dict.fromkeys(c for c in traced if c not in program.channels))
        requests = [RobotRequest(r.name, r.model, r.start, self.channels, r.paths) for r in self.robots]
        backend.open(program.world, requests, self.dt_s, program.seed)
        self.sense, self._act, self.step = backend.sense, backend.act, backend.step
        self.noise = self._noise()
        self.hands_on = HandsOn(program.world, [r.name for r in self.robots], backend)
        self.observers = self._observers(trace_path, log or warn, replay, watch, observers, hands)
        for o in self.observers:
            o.bind(self)
        self.tick = make_tick(self, hooks(self.observers))

    # -- set-up ------------------------------------------------------------------------------
    def _robots(self, keep_images: bool) -> list[RobotRun]:
        """The robots the compiler placed, each with its program bound to its own generator."""
        p = self.program
        if p.mechanism_agent:  # no robots: one agent reads and drives the mechanism
            program = p.robot(p.world.name, random.Random(f"{p.seed}/{p.world.name}"), self.faults, None,
                                keep_images=keep_images)
            return [RobotRun(0, p.world.name, None, program, math.inf, start=Pose(0.0, 0.0, 0.0),
                             sent_joints=[math.nan] * len(p.targets))]
        robots: list[RobotRun] = []
        for start in p.starts:
            group = p.robots[start.group]
            program = p.robot(start.name, random.Random(f"{p.seed}/{start.name}"), self.faults, group.model,
                              group, start.index, keep_images, start.pose,
                              self.peers)
            robots.append(RobotRun(len(robots), start.name, group.model, program,
                                   group.model.max_wheel_speed_rad_s, start=start.pose,
                                   sent_joints=[math.nan] * len(p.targets), paths=group.paths,
                                   noise=group.noise_of(start.index)))
        return robots

    def _noise(self) -> NoisyIO | None:
        """The robots' noise in front of the backend's calls; None (and no cost) when none has any."""
        robots = [robot_noise(self.program, r.index, r.name, r.model, r.noise or Noise())
                  for r in self.robots if r.model is not None and noisy(r.model, r.noise)]
        if not robots:
            return None
        io = NoisyIO(robots, self.sense, self._act, self.step)
        self.sense, self._act, self.step = io.sense, io.act, io.step
        return io

    def _observers(self, trace_path: str | Path | None, log: Callable[[str], None] | None,
                   replay: Replay | None, watch: bool, extra: Sequence[Observer],
                   hands: Hands | None) -> list[Observer]:
        """labsim's observers this run needs, then the caller's: chosen once, here. A live view
        (``watch``) may change the world by hand: its inputs record that in the trace's events."""
        p = self.program
        out: list[Observer] = []
        wanted = p.slider_names or p.timeline or replay or hands or watch
        self.inputs = Inputs(self._schedule(replay), hands, self.hands_on.apply) if wanted else None
        if self.inputs is not None:
            out.append(self.inputs)
        if p.targets:
            command = getattr(self.backend, "command", None)
            assert command is not None  # a behaviour that moves joints runs on a backend with joints
            out.append(JointCommands(p.targets, command))
        # a caller's observer may be the watcher (a live view's recorder): one hook a tick, not two
        given = next((o for o in extra if isinstance(o, Watcher)), None)
        self.watcher = given or (Watcher() if watch else None)
        if self.watcher is not None and given is None:
            out.append(self.watcher)
        self.log_printer = LogPrinter(log) if p.logs else None
        if self.log_printer is not None:
            out.append(self.log_printer)
        self.trace_rows: TraceRows | None = None
        if trace_path is not None:
            self.trace = TraceWriter(trace_path, self.header() | self._noise_header(), trace_columns(self),
                                     max_chars=self.budgets.trace_mb * 1_000_000)
            self.trace_rows = TraceRows(self.trace, self.inputs)
            out.append(self.trace_rows)
        return out + list(extra)

    def _noise_header(self) -> dict:
        """The trace header's ``noise``: each noisy robot's models; nothing at all without noise."""
        noise = {r.name: r.noise.header() for r in self.robots if r.noise}
        return {"noise": noise} if noise else {}

    def _better_header(self) -> dict:
        """The trace header's ``metric_better``: only when a metric's direction is not its aggregate's
        default, so that the trace of a file that declares none (every golden's) keeps its header."""
        p = self.program
        if all(b is a.better for a, b in zip(p.metric_aggregates, p.metric_better)):
            return {}
        return {"metric_better": {m: b.value if b is not None else None
                                  for m, b in zip(p.metric_names, p.metric_better)}}

    def header(self) -> dict:
        p = self.program
        return {
            "format": FORMAT, "labsim": version(), "backend": getattr(self.backend, "name", "?"),
            "behaviour": p.path, "name": p.name, "sha256": p.sha256, "world": p.world.name,
            "world_file": _world_file(p.world), **_world_identity(p.world),
            "dt": self.dt_s, "seed": p.seed, "params": dict(p.params),
            "robots": {r.name: r.model.name if r.model else "mechanism" for r in self.robots},
            "metrics": dict(zip(p.metric_names, (a.value for a in p.metric_aggregates))),
        } | self._better_header() | ({"lists": {k: [list(v) if isinstance(v, tuple) else v for v in value]
                                                for k, value in p.lists.items()}} if p.lists else {})

    def _schedule(self, replay: Replay | None) -> Schedule:
        """The timeline by tick: an event at time t applies at the first tick whose time >= t."""
        p = self.program
        out: Schedule = {}
        if replay is not None:
            for tick, moves in replay.items():
                for name, value in moves:
                    if name not in p.slot_of or name not in p.slider_ranges:
                        raise LabsimError([Diagnostic(p.path, f"the replayed trace moves slider '{name}', "
                                                      "which this behaviour does not have")])
                    out.setdefault(tick, []).append((p.slot_of[name], value, f"{name}={value:g}"))
            return out
        for time_s, settings in p.timeline:
            tick = max(0, math.ceil(time_s / self.dt_s - 1e-9))
            for name, value in settings:
                out.setdefault(tick, []).append((p.slot_of[name], value, f"{name}={value:g}"))
        return out

    # -- during the run ----------------------------------------------------------------------
    def set_slider(self, name: str, value: float) -> None:
        """Move a slider now (from the next tick's signals on): what a live view's drag does.

        The move is recorded in the trace's events column, as the timeline's are.
        """
        p = self.program
        lo, hi = p.slider_ranges[name]
        value = min(hi, max(lo, value))
        assert self.inputs is not None  # a behaviour with sliders has inputs
        self.inputs.move(self.tick_index, p.slot_of[name], value, f"{name}={value:g}")

    def hand(self, hand: Hand) -> str | None:
        """Change the world now, before the next tick senses (a live view's drag: a robot put, a
        block moved, added or removed); why not, when refused. Recorded in the trace's events
        column, so a replay does the same (``labsim.runtime.hands``)."""
        why = self.hands_on.apply(hand)
        if why is None:
            assert self.inputs is not None  # a watched run has inputs
            self.inputs.notes.setdefault(self.tick_index, []).append(event_text(hand))
        return why

    @property
    def last_rule(self) -> list[int]:
        """The rule each robot fired on the last tick (-1: none); bound with ``watch=True``."""
        return self.watcher.last_rule if self.watcher is not None else [-1] * len(self.robots)

    def send(self, r: RobotRun, left: float, right: float, rule: int) -> None:
        """A robot's wheel command to the backend, clamped to its limit; nan stops the wheel."""
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

    def _actuator_fault(self, r: RobotRun, rule: int, what: str) -> None:
        if rule >= 0:
            site = self._actuator_sites[rule]
        else:
            site = FaultSite("no rule", Diagnostic(self.program.path, ""))
        self.faults.report(site, what, self.tick_index, r.name)

    def _warned(self, message: str) -> None:
        self.warnings.append(message)
        if self._warn is not None:
            self._warn(message)

    # -- the loop ----------------------------------------------------------------------------
    def run(self, progress: Callable[[int, float], None] | None = None,
            max_ticks: int | None = None) -> RunResult:
        """Tick until the stop condition holds (or max_ticks); always closes the trace.

        The run's budgets (``budgets``) stop it too: past its ticks or its trace size it ends
        with ``over_budget`` saying which, the trace so far kept (docs/security.md).
        """
        start = clock.perf_counter()
        ended = False
        watch = RunWatch(self.budgets, self.dt_s, self.program.stop_horizon_s, start, self._warned)
        limit = self.budgets.ticks if max_ticks is None else min(max_ticks, self.budgets.ticks)
        tick = self.tick
        try:
            with CallbackInterrupts() as caught, memory_cap(self.budgets.memory_mb):  # docs/security.md
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
                        progress(self.tick_index, self.tick_index * self.dt_s)
                ended = not self.over_budget  # a run a budget stopped is cut short: its footer says so
        except KeyboardInterrupt:
            self.interrupted = True
        except TraceFull as full:
            self.over_budget = trace_full_message(self.trace, self.budgets.trace_mb, full.tick)
        except TraceWriteError as e:  # the run stops; its summary is still shown (docs/trace-format.md)
            self.trace_error = e
            self.interrupted = True
        except Exception as e:  # only running out of memory is the run's own end; anything else is a bug
            if not out_of_memory(e):
                raise
            self.over_budget = out_of_memory_message(self.budgets.memory_mb, self.tick_index)
        finally:
            self._close_trace(not ended)
        self.wall_time_s = clock.perf_counter() - start
        return self.result()

    def _close_trace(self, interrupted: bool) -> None:
        """The trace's footer and its rename into place; a failure is kept for the command to report."""
        if self.trace is None:
            return
        recorded = self.trace_rows.recorded if self.trace_rows is not None else 0
        try:
            self.trace.close(max(self.tick_index, recorded), interrupted)
        except TraceWriteError as e:
            self.trace_error = self.trace_error or e

    def end_trace(self) -> None:
        """The trace's footer once a live view's run has ended: interrupted only if a budget
        ended it, as ``run`` writes it."""
        self._close_trace(bool(self.over_budget))

    def close(self) -> None:
        self._close_trace(True)  # closed already unless the run never started
        self.backend.close()

    # -- the result --------------------------------------------------------------------------
    def stop_reason(self) -> str:
        if self.interrupted:
            return INTERRUPTED
        if self.over_budget:
            return BUDGET
        return STOP_CONDITION if self.finished else MAX_TICKS

    def result(self) -> RunResult:
        """What the run did so far, as data (see ``labsim.runtime.result``)."""
        p = self.program
        robots = {r.name: self._robot_result(r) for r in self.robots}
        fleet = {name: fleet_value(agg, [r.metrics[name] for r in robots.values()])
                 for name, agg in zip(p.metric_names, p.metric_aggregates)} if len(robots) > 1 else {}
        stop_condition = ""
        if self.stopped_by is not None:
            parts = p.stop_parts
            stop_condition = parts[self.stop_part] if 0 <= self.stop_part < len(parts) else p.stop_text
        return RunResult(
            name=p.name, path=p.path, sha256=p.sha256, backend=getattr(self.backend, "name", "?"),
            world=p.world.name, dt_s=p.dt_s, seed=p.seed, params=dict(p.params), overridden=tuple(p.overridden),
            lists=dict(p.lists), metric_aggregates=dict(zip(p.metric_names, p.metric_aggregates)),
            metric_better=dict(zip(p.metric_names, p.metric_better)),
            ticks=self.tick_index, sim_time_s=self.tick_index * self.dt_s, wall_time_s=self.wall_time_s,
            stop_reason=self.stop_reason(), stopped_by=self.stopped_by, stop_condition=stop_condition,
            over_budget=self.over_budget, robots=robots, fleet=fleet,
            rules=tuple(RuleResult(rule.id, rule.text, n) for rule, n in zip(p.rules, self._fired())),
            idle_ticks=self.idle, faults=tuple(self._fault_lines()), logs_unprinted=tuple(self._unprinted()),
            warnings=tuple(_warning_line(d) for d in p.warnings) + tuple(self.warnings),
            logs=tuple(self.log_printer.lines) if self.log_printer is not None else (),
            trace=str(self.trace.path) if self.trace is not None else None)

    def _robot_result(self, r: RobotRun) -> RobotResult:
        p = self.program
        contacts = self.backend.contacts(r.index)
        noisy = next((n for n in self.noise.robots if n.name == r.name), None) if self.noise is not None else None
        return RobotResult(
            name=r.name, mechanism=r.model is None, contacts=contacts.count, contact_time_s=contacts.time_s,
            clamped_ticks=r.clamped_ticks, wheel_limit_rad_s=None if r.model is None else r.limit,
            metrics={name: metric_result(agg, acc, self.dt_s) for name, agg, acc in
                     zip(p.metric_names, p.metric_aggregates, r.program.metric_values)},
            labels=p.label_text(r.program.slots) if p.labels else {},
            noise=noisy.noise.header() if noisy is not None else {},
            noise_text=self.noise.describe(noisy) if self.noise is not None and noisy is not None else "",
            sonar_readings_lost=noisy.dropped if noisy is not None else 0,
            faults=self.faults.by_robot.get(r.name, 0),
            params={k: r.program.slots[slot] for k, slot in p.robot_slots.items()})

    def _fired(self) -> list[int]:
        """Ticks each rule fired; a 'when' rule's are the ticks it logged, counted by each robot's program."""
        fired = list(self.fired)
        for j, k in enumerate(self.program.when_rules):
            fired[k] = sum(r.program.when_fired[j] for r in self.robots)
        return fired

    def _unprinted(self) -> list[str]:
        """The log lines not printed: by the file's line (a line with 500 logs is one entry), the
        first ``UNPRINTED_SHOWN`` lines, then the rest together, then the run's cap."""
        out: list[str] = []
        if self.log_printer is None:
            return out
        by_line: dict[int, int] = {}
        for site_index, n in self.log_printer.dropped.items():
            line = self.program.logs[site_index][0]
            by_line[line] = by_line.get(line, 0) + n
        for line, n in sorted(by_line.items())[:UNPRINTED_SHOWN]:
            out.append(f"log on line {line}: {n} line{'s' if n != 1 else ''} not printed "
                       f"(at most {LOG_RATE} a simulated second; the trace has them all)")
        rest = sorted(by_line.items())[UNPRINTED_SHOWN:]
        if rest:
            n = sum(k for _, k in rest)
            out.append(f"logs on {len(rest)} more lines: {n} line{'s' if n != 1 else ''} not printed "
                       f"(at most {LOG_RATE} a simulated second each; the trace has them all)")
        n = self.log_printer.over_cap
        if n:
            out.append(f"{n} more line{'s' if n != 1 else ''} not printed: {CAP_NOTE}; the trace has them all")
        return out

    def _fault_lines(self) -> list[str]:
        return self.faults.summary()


def _warning_line(d: Diagnostic) -> str:
    """A compiler warning on one line: ``path:line:col: warning: message``."""
    return d.format().splitlines()[0]


def _world_file(world: World) -> str:
    """Where the world came from, for the trace: '' for a built-in (its name says it all)."""
    if builtin_name(world.source):
        return ""
    try:
        return str(Path(world.source).resolve().relative_to(Path.cwd()))
    except ValueError:
        return str(Path(world.source))


def _world_identity(world: World) -> dict[str, str]:
    """The world's SHA-256 (of its file's text, as the compiler read it), and for a built-in the
    labsim version that shipped it: a golden says when the world changed under it."""
    out = {"world_sha256": world.sha256}
    if world.source and builtin_name(world.source):
        out["world_version"] = f"built-in, labsim {version()}"
    return out
