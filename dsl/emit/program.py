"""The compiled behaviour the runtime reads: what the language hands over, sealed.

``labsim.dsl.compile`` builds a ``Program`` from a checked behaviour file and the Python that
``labsim.dsl.emit.codegen`` generated for it. A Program is read-only plain data: settings, names,
the slot layout, the timeline as (time_s, settings) pairs, the stop condition's horizon,
diagnostics prepared for the runtime to raise, and the generated ``Code``. Nothing of the YAML
file or of the front end (nodes, ``Checked``) is reachable from it, and nothing changes it
after compilation: a different seed is a different compilation.

``Program.robot`` binds the generated code to one robot's slots, random generator, model and
fault sink (``labsim.dsl.library.support``) and returns that robot's ``RobotProgram``, the mutable
per-robot half; each robot has its own state and its callables take no user data.
"""
from __future__ import annotations

import linecache
import math
import random
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import CodeType
from typing import Any, cast

from labsim.backends.scene.models import Kind, RobotModel
from labsim.backends.scene.world import Pose, World, wrap
from labsim.dsl.analysis.placement import Start
from labsim.dsl.library.builtins import Aggregate, Better, Type
from labsim.dsl.library.support import (
    STATE,
    Faults,
    FaultSite,
    Slots,
    guard,
    initial_accumulator,
    namespace,
    show_field,
)
from labsim.dsl.syntax.noise import Noise
from labsim.foundation.diagnostics import Diagnostic

Setting = tuple[str, float]  # a slider and the value it takes
TimelineEvent = tuple[float, tuple[Setting, ...]]  # at time_s, these settings
LabelPart = str | tuple[int, str]  # literal text, or (slot, format spec) of a field


# Guards bound to make()'s parameters by name, each a local of the generated functions; past them (a
# lidar's thousand beams member by member, a memory each) they are read from one tuple, _G[k]: Python's
# compiler and a call's keyword matching take time quadratic in the number of names
NAMED_SITES = 256

@dataclass(frozen=True)
class SharedLabel:
    """A label several sliders write (``label_name``, format 1.2): it shows the text of the slider
    whose value changed last, as a script's slider callbacks writing into one label do."""

    name: str
    choice: int  # the slot holding which slider's text shows: its index in ``sliders``
    sliders: tuple[tuple[int, int], ...]  # each slider's slot, and the slot of its value last tick
    texts: tuple[tuple[LabelPart, ...], ...]  # each slider's text
    names: tuple[str, ...] = ()  # the sliders, in the order of ``sliders``


@dataclass(frozen=True)
class GroupSignal:
    """A ``let`` signal that is a group: where its members are, for a breakpoint to read them."""

    name: str
    size: int
    slots: tuple[int, ...] | None  # None: the group names values that have slots, or constants
    expr: str  # the expression as written (only the names it is written with are read when slots is None)


@dataclass(frozen=True)
class FunctionText:
    """A function of the file's own as written, for a breakpoint to call it: ``nearer(a, b): min(a, b)``."""

    name: str
    params: tuple[str, ...]
    body: str
    line: int  # where the body starts in the file, for a problem found in it
    col: int
    source_line: str = ""  # the file's line it starts on, shown under a problem


@dataclass(frozen=True)
class RuleLabel:
    """A rule as the summary and the trace name it: ``wander:2``."""

    state: str
    number: int
    text: str
    line: int

    @property
    def id(self) -> str:
        return f"{self.state}:{self.number}"


@dataclass(frozen=True)
class RobotGroup:
    """One entry of ``robots:``: ``count`` robots of one model, placed as ``at`` says."""

    name: str
    model: RobotModel
    count: int
    # "spawn", "random", (x_m, y_m, heading_deg), or (format 1.3) one such pose per member
    at: str | tuple[float, float, float] | tuple[tuple[float, float, float], ...]
    paths: tuple[tuple[str, str], ...] = ()  # scene object names for a simulator (CoppeliaSim)
    params: tuple[tuple[str, tuple[float | bool, ...]], ...] = ()  # the group's own values, one per member
    noise: Noise | None = None  # what the runtime adds to its readings and commands (labsim.runtime.noise)
    # each member's, when the group's own parameter values give its members different noise (format
    # 1.2); then ``noise`` is None. Empty when every member has ``noise``: read it with ``noise_of``.
    member_noise: tuple[Noise | None, ...] = ()

    def noise_of(self, index: int) -> Noise | None:
        """The noise of the group's member ``index`` (its place in the group, from 0)."""
        return self.member_noise[index] if self.member_noise else self.noise


@dataclass(frozen=True)
class Code:
    """The Python generated for a behaviour, compiled once and shared by every robot."""

    source: str  # what was compiled: slots, literals, operators, bound names; no user text
    listing: str  # the same lines, with each rule's, signal's and metric's file line and text as comments
    filename: str  # what tracebacks name, e.g. "<labsim behaviours/wall_follow.yaml>"
    compiled: CodeType
    sites: tuple[tuple[str, FaultSite], ...]  # guard _gN: the operation it checks and where it is
    functions: tuple[str, ...]  # built-ins the code calls directly, bound as _<name>
    marks: tuple[int, ...] = ()  # per line of the source: the behaviour file's line it comes from, 0 for none
    drops: bool = False  # make() takes ``_drop``: free image signals after their last use (codegen.drop_images)
    # make() takes ``_L0``...: each a list parameter's column (format 1.3) read at a place known only while
    # running, bound once rather than written into the code at every read
    columns: tuple[tuple[float, ...], ...] = ()


@dataclass(frozen=True)
class RobotProgram:
    """One robot's compiled behaviour: functions bound to its slots, generator and faults.

    ``signals(time_s, tick, values)`` takes the tick's channel values (in ``channels``
    order), evaluates the ``let`` signals into the slots and returns whether the stop
    condition holds; ``decide()`` runs the first rule that holds (writing ``command``: left
    and right wheel rad/s and the next state) and folds the metrics, returning the index of
    the rule that fired, or -1. ``both(time_s, tick, values)`` does the two in one call and
    returns -2 when the stop condition holds; a run with a single robot uses it.
    """

    slots: Slots
    command: list  # [left rad/s, right rad/s, next state index]
    signals: Callable[[float, int, list], bool]
    decide: Callable[[], int]
    both: Callable[[float, int, list], int]
    metric_values: list[list[float]]  # per metric accumulator, read by support.metric_result
    events: list[int]  # indices of count metrics that rose this tick (cleared by the runtime)
    source: str  # the generated Python, for debugging
    joint_command: list[float] = field(default_factory=list)  # per Program.targets, nan: none yet
    # fold(time_s, tick, values): the signals already evaluated, fold the metrics; no rule acts
    fold: Callable[[float, int, list], None] = lambda time_s, tick, values: None
    stop_part: list[int] = field(default_factory=lambda: [-1])  # the stop condition's 'or' part that held
    when_fired: list[int] = field(default_factory=list)  # per Program.when_rules: the ticks it logged
    # format 1.3, per Program.said: what the robot said this tick (nan: nothing) and how far it carries,
    # and what it heard last (nan: nothing yet); labsim.runtime.radio delivers after every tick
    outbox: list[float] = field(default_factory=list)
    reach: list[float] = field(default_factory=list)
    inbox: list[float] = field(default_factory=list)


@dataclass(frozen=True, eq=False)
class Program:
    """A compiled behaviour: everything a run needs, read-only."""

    # the file and its settings
    name: str
    path: str
    sha256: str
    dt_s: float
    seed: int
    world: World
    params: Mapping[str, float | bool]  # after --set overrides
    overridden: tuple[str, ...]  # the params set on the command line
    warnings: tuple[Diagnostic, ...]
    # who runs it
    robots: tuple[RobotGroup, ...]
    models: Mapping[str, RobotModel]  # robot group -> model
    mechanism_agent: bool  # no robots: one agent reads and drives the world's mechanism
    starts: tuple[Start, ...]  # every robot and its start pose, in the file's order (dsl/analysis/placement.py)
    # what it reads and computes
    channels: tuple[str, ...]  # sensor channels, in the order values are passed to signals()
    channel_kinds: Mapping[str, Kind]
    let_names: tuple[str, ...]
    signal_types: Mapping[str, Type]  # let name -> its type
    state_names: tuple[str, ...]
    rules: tuple[RuleLabel, ...]  # in the order decide() numbers them
    metric_names: tuple[str, ...]
    metric_aggregates: tuple[Aggregate, ...]
    metric_better: tuple[Better | None, ...]  # which way each metric is better (None: it declares none)
    stop_horizon_s: float | None  # sim time by which the stop condition surely holds, if it says so plainly
    # sliders, their labels and the timeline that moves them
    slider_names: tuple[str, ...]
    slider_ranges: Mapping[str, tuple[float, float]]
    slider_start: Mapping[str, float]
    labels: tuple[tuple[str, tuple[LabelPart, ...]], ...]  # label -> its parts (a shared one: see shared_labels)
    timeline: tuple[TimelineEvent, ...]
    # where values live, and the generated code that reads and writes them
    slot_of: Mapping[str, int]
    slot_count: int
    targets: tuple[tuple[str, str], ...]  # joint targets (joint, "velocity" | "position") in command order
    code: Code
    logs: tuple[tuple[int, tuple[LabelPart, ...]], ...] = ()  # each log(): its line, text and (value, format)
    stop_text: str = ""  # the stop condition as written, for the summary
    stop_parts: tuple[str, ...] = ()  # its top-level 'or' parts: the summary names the one that held
    fold_stop: bool = False  # format 1.1: the stopping tick is traced and folded into metrics
    texts: tuple[str, ...] = ()  # what generated code shows as text: the state names, then text values
    when_rules: tuple[int, ...] = ()  # the 'when' rules, by index in ``rules``: RobotProgram.when_fired counts them
    image_bytes_all: int = 0  # every image signal of every robot held at once (labsim.dsl.analysis.image_memory)
    shared_labels: tuple[SharedLabel, ...] = ()  # labels several sliders write (format 1.2)
    # what a breakpoint (labsim.dsl.watch) reads beyond the slots of single values, as text it parses:
    # each group signal, its members' slots (None: its uses read the names it is written with) and
    # its expression; each function of the file's own
    group_signals: tuple[GroupSignal, ...] = ()
    functions: tuple[FunctionText, ...] = ()
    lists: Mapping[str, tuple] = field(default_factory=dict)  # list parameters (format 1.3), after --set
    version: float = 1  # the file's format: a breakpoint is checked as the file is
    # format 1.3: what the robots read of each other (leader.x), and the slots each robot's values of
    # them are kept from after every tick, for the others to read on the next (``peer_start``)
    peer_fields: tuple[str, ...] = ()
    peer_slots: tuple[int, ...] = ()
    # the values read of another robot at a place known before the run, as written ('leader.x'), then
    # what is heard on each channel ('heard(target)'), and their types: each has a slot (``slot_of``)
    # the trace and the live view read
    received: tuple[tuple[str, Type], ...] = ()
    said: tuple[str, ...] = ()  # the channels say() sends on (labsim.runtime.radio), as RobotProgram.outbox has them

    def peer_start(self) -> list[tuple]:
        """What the robots read of each other on the first tick: each robot's start pose, its first
        state, and 0 (false) for a signal, as no tick has computed one yet."""
        out = []
        for start in self.starts:
            pose = {"x": start.pose.x_m, "y": start.pose.y_m, "heading": wrap(start.pose.heading_rad), "state": 0}
            out.append(tuple(pose.get(f, False if self.signal_types.get(f) is Type.BOOL else 0.0)
                             for f in self.peer_fields))
        return out

    def log_text(self, site: int, values: tuple) -> str:
        """The text of a ``log(...)`` from the values of its fields."""
        return "".join(p if isinstance(p, str) else show_field(values[p[0]], p[1]) for p in self.logs[site][1])

    def first_slots(self, group: RobotGroup | None, index: int, start: Pose | None) -> Slots:
        """A robot's slots before its first tick: its parameters (a group's own values for member
        ``index``), its place, its start pose read back, and the sliders' first values."""
        slots = Slots([0.0] * self.slot_count)
        slots[STATE] = 0
        for param, slot in self.robot_slots.items():
            slots[slot] = self.params[param]  # every robot starts from the file's (or --set's) value
        if "index" in self.slot_of:
            slots[self.slot_of["index"]] = float(index)
        for variable, value in start_values(start).items():
            if variable in self.slot_of:
                slots[self.slot_of[variable]] = value
        for param, values in group.params if group is not None else ():
            if param in self.robot_slots:
                slots[self.robot_slots[param]] = values[index]
        for slider in self.slider_names:
            slots[self.slot_of[slider]] = self.slider_start[slider]
        for shared in self.shared_labels:  # the first slider's text shows until one moves
            for slot, last in shared.sliders:
                slots[last] = slots[slot]
        return slots

    def robot(self, name: str, rng: random.Random, faults: Faults, model: RobotModel | None = None,
              group: RobotGroup | None = None, index: int = 0, keep_images: bool = False,
              start: Pose | None = None, peers: list[tuple] | None = None) -> RobotProgram:
        """Bind the generated functions to one robot's slots, generator, model and fault sink.

        ``index`` is the robot's place in its ``group``, whose own parameter values it takes;
        ``keep_images`` keeps every image signal in its slot after the tick (a live view shows them);
        ``start`` is where the robot starts, which ``start_x``, ``start_y`` and ``start_heading`` read.
        ``peers`` is the run's list of what each robot reads of the others (``peer_start``), shared by
        every robot of the run and replaced after each tick by the runtime.
        """
        code = self.code
        slots = self.first_slots(group, index, start)
        command: list = [0.0, 0.0, 0]
        joint_command = [math.nan] * len(self.targets)
        events: list[int] = []
        metric_values = [initial_accumulator(a) for a in self.metric_aggregates]
        bindings = namespace(rng, model or next(iter(self.models.values()), None), code.functions)
        stop_part = [-1]
        when_fired = [0] * len(self.when_rules)

        def held(part: int) -> bool:
            stop_part[0] = part
            return True
        bindings.update(s=slots, cmd=command, events=events, m=metric_values, jc=joint_command, _st=[-1, 0],
                        _held=held, _texts=self.texts, _wf=when_fired)
        if code.drops:
            bindings["_drop"] = not keep_images
        if self.peer_fields:
            bindings["_P"] = peers if peers is not None else self.peer_start()
        outbox, reach, inbox = [math.nan] * len(self.said), [math.inf] * len(self.said), [math.nan] * len(self.said)
        if self.said:
            bindings.update(_out=outbox, _reach=reach, _in=inbox)
        guards = [guard(kind, site, faults, slots, name, rng, self.dt_s) for kind, site in code.sites]
        bindings.update(zip((f"_g{i}" for i in range(NAMED_SITES)), guards))
        if len(guards) > NAMED_SITES:  # the others, as one tuple (codegen.NAMED_SITES)
            bindings["_G"] = tuple(guards)
        for i, column in enumerate(code.columns):
            bindings[f"_L{i}"] = column
        show_in_tracebacks(code)
        # Only generated text reaches exec: user names became slot indices, numbers are
        # repr(float), operators come from a fixed table (see labsim.dsl.emit.codegen). The functions
        # are made by a factory so that everything they use is a closure cell, not a global.
        scope: dict[str, object] = {"__builtins__": {}}
        exec(code.compiled, scope)
        make = cast(Callable[..., tuple[Any, Any, Any, Any]], scope["make"])
        signals, decide, both, fold = make(**bindings)
        return RobotProgram(slots, command, signals, decide, both, metric_values, events, code.source,
                            joint_command, fold, stop_part, when_fired, outbox, reach, inbox)

    @property
    def single_signals(self) -> tuple[str, ...]:
        """The signals that hold one value (a group holds one per member, in slots of their own)."""
        return tuple(n for n in self.let_names if self.signal_types.get(n) not in (Type.NUMBERS, Type.BOOLS))

    @property
    def robot_slots(self) -> dict[str, int]:
        """Parameters that differ between robots, and their slots."""
        return {p: slot for p, slot in self.slot_of.items() if p in self.params}

    def label_of(self, slider: str) -> str:
        """The label a slider's text goes into: its own name, or the one it shares."""
        return next((sh.name for sh in self.shared_labels if slider in sh.names), slider)

    def label_text(self, slots: list) -> dict[str, str]:
        """Each label, formatted from the label fields' values in the slots."""
        out = {}
        shared = {sh.name: sh for sh in self.shared_labels}
        for slider, parts in self.labels:
            if slider in shared:
                parts = shared[slider].texts[int(slots[shared[slider].choice])]
            text = []
            for part in parts:
                if isinstance(part, tuple):
                    slot, spec = part
                    text.append(show_field(slots[slot], spec))
                else:
                    text.append(part)
            out[slider] = "".join(text)
        return out


def start_values(start: Pose | None) -> dict[str, float]:
    """``start_x``, ``start_y`` and ``start_heading`` of a start pose: metres, and radians as ``heading``
    reads them, in (-pi, pi] (``at: [0, 0, 270]`` starts at -pi/2); 0 without one."""
    if start is None:
        return {"start_x": 0.0, "start_y": 0.0, "start_heading": 0.0}
    return {"start_x": float(start.x_m), "start_y": float(start.y_m), "start_heading": wrap(start.heading_rad)}


def show_in_tracebacks(code: Code) -> None:
    """Give tracebacks through the generated functions their lines, with the listing's comments.

    The listing has the source's lines at the same numbers. An entry without a modification
    time is one ``linecache.checkcache`` keeps; binding a robot registers it again, so the
    program being run is the one shown.
    """
    linecache.cache[code.filename] = (len(code.listing), None, code.listing.splitlines(keepends=True),
                                      code.filename)
