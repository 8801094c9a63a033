"""Names and types: the checker, between reading and compiling.

Every name in every expression is resolved before a run — sensors of the robots' models,
parameters (after ``--set`` overrides), ``let`` signals defined earlier, built-in variables and
functions, rule states — and every expression gets a type (number, boolean, state). Arity,
action arguments, ``goto`` targets, unreachable rules and metric aggregates are checked too.
Every problem goes to the report with a did-you-mean where one helps; the result, ``Checked``,
is what the compiler needs and nothing more. This module declares the names and checks the
file's parts; ``labsim.dsl.analysis.infer`` types each expression against the names declared.

Over 500 lines: the checks of one file's parts share the names it declares; expression
typing is its own module (``labsim.dsl.analysis.infer``), and so are the warnings (``labsim.dsl.analysis.lint``).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

from yaml.nodes import MappingNode, Node

from labsim.backends.scene.mechanism import Mechanism
from labsim.backends.scene.models import MODELS, Kind, RobotModel
from labsim.backends.scene.world import World, world_channels
from labsim.backends.scene.world_names import find_world
from labsim.dsl.analysis.functions import RANDOM, Expansion, check_bodies, check_definitions, claimed_in_13
from labsim.dsl.analysis.infer import ExprChecker
from labsim.dsl.analysis.messages import SAY, check_channels, check_say
from labsim.dsl.analysis.peers import Received, check_later
from labsim.dsl.analysis.wording import arity_message, log_example, say_example, shown_setting
from labsim.dsl.library.builtins import (
    ACTIONS,
    AGGREGATES,
    CONSTANTS,
    DETECTED,
    FUNCTIONS,
    JOINT_ACTIONS,
    KEYWORDS,
    PRINTS,
    READ_BACK,
    SHADOWABLE,
    STATEFUL,
    TRACE_COLUMNS,
    VARIABLES,
    WHEELS,
    Aggregate,
    Better,
    Type,
)
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.lists import ListValue, is_table, list_setting
from labsim.dsl.syntax.noise import Noise, resolve_noise
from labsim.dsl.syntax.read import (
    BehaviourFile,
    BindDecl,
    FunctionDecl,
    Parsed,
    RuleDecl,
    SliderDecl,
    later_format,
)
from labsim.foundation.diagnostics import Diagnostic, Report, did_you_mean
from labsim.foundation.numbers import TOO_LARGE, NumberError, to_float
from labsim.foundation.source import Place, Text

_KIND_TYPES = {Kind.DISTANCE: Type.NUMBER, Kind.NUMBER: Type.NUMBER, Kind.BOOL: Type.BOOL,
               Kind.IMAGE: Type.IMAGE, Kind.JOINT: Type.JOINT, Kind.FORCE: Type.FORCE, Kind.BODY: Type.BODY,
               Kind.CONTACT: Type.BOOL, Kind.REFLECTANCE: Type.NUMBER}
LOGGED = (Type.NUMBER, Type.BOOL, Type.TEXT, Type.STATE)  # what a log's field may show
_SHADOWABLE_KIND = "built-in name"  # a name added after version 1, which a file's own name hides
_KIND_WORDS = {Kind.JOINT: "joint", Kind.FORCE: "force sensor", Kind.BODY: "body", Kind.CONTACT: "bumper",
               Kind.REFLECTANCE: "ground sensor"}


@dataclass(frozen=True)
class Metric:
    name: str
    aggregate: Aggregate
    expr: ast.Expr
    text: Text
    better: Better | None = None  # as declared, else the aggregate's default (None: no direction)


@dataclass
class Checked:
    """A behaviour whose every name and type is known: the compiler's input."""

    file: BehaviourFile
    world: World | None
    models: dict[str, RobotModel]  # robot group -> model
    params: dict[str, float | bool]  # after overrides
    channels: tuple[str, ...]  # sensor channels the behaviour reads, in model order
    distance_channels: frozenset[str]
    lets: list[tuple[str, Parsed]]
    states: dict[str, list[RuleDecl]]
    metrics: list[Metric]
    overridden: tuple[str, ...] = ()
    let_types: dict[str, Type] = field(default_factory=dict)
    channel_kinds: dict[str, Kind] = field(default_factory=dict)
    node_types: dict[int, Type] = field(default_factory=dict)  # id(AST node) -> its type
    sliders: list[SliderDecl] = field(default_factory=list)
    labels: list[tuple[str, str, tuple]] = field(default_factory=list)  # label, slider, its parts
    binds: list[BindDecl] = field(default_factory=list)
    mechanism_agent: bool = False  # no robots: one agent, the world's mechanism
    used: frozenset[str] = frozenset()  # every name an expression reads
    robot_params: dict[str, tuple[tuple[str, tuple[float | bool, ...]], ...]] = field(default_factory=dict)
    noise: dict[str, tuple[Noise | None, ...]] = field(default_factory=dict)  # group -> each member's
    # version 1.2: each call of a user function and its typed body; groups' sizes; prev() of a signal in itself
    expansions: dict[int, Expansion] = field(default_factory=dict)
    group_sizes: dict[str, int] = field(default_factory=dict)  # a signal that is a group -> its members
    sizes: dict[int, int] = field(default_factory=dict)  # id(AST node) of a group expression -> its members
    self_prev: frozenset[int] = frozenset()
    functions: dict[str, FunctionDecl] = field(default_factory=dict)
    called: frozenset[str] = frozenset()
    lists: dict[str, ListValue] = field(default_factory=dict)  # list parameters (format 1.3), after --set
    lengths: dict[int, int] = field(default_factory=dict)  # id(call) of len(...) -> its value
    # format 1.3: what the robots read of each other (x, y, heading, state, signals), in the order first read
    peer_fields: tuple[str, ...] = ()
    received: tuple[Received, ...] = ()  # each value read of another robot at a place known before the run
    received_at: dict[int, str] = field(default_factory=dict)  # id(Peer node) -> its name in ``received``
    said: tuple[str, ...] = ()  # the channels say() sends on (format 1.3), in the order first said
    heard: tuple[str, ...] = ()  # the channels heard() reads, each said somewhere


def check(bf: BehaviourFile, report: Report, overrides: dict[str, str] | None = None) -> Checked:
    c = _Checker(bf, report)
    return c.run(overrides or {})


class _Checker(ExprChecker):
    """Declares every name of the file, checks each part; reports through ``error`` (a place in
    the file, or None) and ``setting_error`` (a ``--set`` override)."""

    def __init__(self, bf: BehaviourFile, report: Report) -> None:
        super().__init__(bf.doc, report)
        self.bf = bf
        self.version = bf.version
        self.motors: dict[str, frozenset[str]] = {}  # joint -> the target modes its motor takes
        self.grader_wheels = False  # a grader's measured metric may read the wheels (read_back)
        self.robot_counts = {r.name: r.count for r in bf.robots}  # format 1.3: leader.x reads robot 'leader'
        self.signal_names = tuple(name for name, _, _ in bf.lets)

    def setting_error(self, setting: str, message: str, notes: tuple[str, ...] = ()) -> None:
        """Report a problem with a ``--set NAME=VALUE`` override, which has no place in the file."""
        self.report.add(Diagnostic(setting, message, notes=notes))

    # -- the whole file ----------------------------------------------------------------------
    def run(self, overrides: dict[str, str]) -> Checked:
        bf = self.bf
        world = self.world()
        models = self.models()
        mechanism = world.mechanism if world is not None else None
        channels: dict[str, Kind] = {}
        if models:
            # one behaviour drives every robot: only channels all its models offer are readable
            offered = [m.channels() for m in models.values()]
            channels = {k: v for k, v in offered[0].items() if all(k in o for o in offered[1:])}
            if world is not None:
                channels.update(world_channels(world))
        elif mechanism is not None:
            channels = mechanism.channels()
        self.presence(world, mechanism)
        self.spawns(world)
        for name, kind in channels.items():
            self.declare(name, _KIND_TYPES[kind], _KIND_WORDS.get(kind, "sensor"))
        self.distance = {name for name, kind in channels.items() if kind is Kind.DISTANCE}
        self.poisoned = set(self.bf.failed_names)
        if self.robots_failed(world, mechanism):  # reported: what a robot would read is not unknown too
            self.poisoned |= {name for m in MODELS.values() for name in m.channels()} - set(channels)
        for name, t in VARIABLES.items():
            self.declare(name, t, "built-in variable" if name not in SHADOWABLE else _SHADOWABLE_KIND)
        for name in CONSTANTS:
            self.declare(name, Type.NUMBER, "constant")
        self.read_back(models, world)
        for name, (_, key) in bf.states.items():
            if key is not None and self.reserved(name, key, "state"):
                continue
            if self.taken(name) and key is not None:
                self.clash(key, "state", name)
            self.declare(name, Type.STATE, "state")
        params = self.params(overrides)
        robot_params = self.robot_params(params)
        self.known_values(params, robot_params)
        noise = self.noise(params, robot_params, overrides)
        sliders = self.sliders()
        self.user_functions = check_definitions(self, bf.functions)
        check_bodies(self, self.user_functions)
        lets = self.lets()
        labels = self.labels()
        self.metric_names = {m.name for m in bf.metrics}
        if bf.stop is not None:
            self.expect(bf.stop, bf.stop.node, Type.BOOL, "the stop condition")
        self.motors = mechanism.motor_modes() if mechanism is not None else {}
        states, binds = self.rules(), self.binds()
        self.timeline(sliders)
        metrics = self.metrics()
        used_channels = tuple(ch for ch in channels if ch in self.used)
        return Checked(bf, world, models, params, used_channels,
                       frozenset(k for k, v in channels.items() if v is Kind.DISTANCE),
                       lets, states, metrics, tuple(overrides),
                       {name: self.types[name] for name, _ in lets}, {ch: channels[ch] for ch in used_channels},
                       self.node_types, sliders, labels, binds, mechanism is not None and not models,
                       frozenset(self.used), robot_params, noise, self.expansions, self.group_sizes, self.sizes,
                       frozenset(self.self_prev), self.user_functions, frozenset(self.called), dict(self.lists),
                       self.lengths,
                       tuple(self.peer_fields), tuple(self.received.values()), self.received_at,
                       tuple(self.said), tuple(h for h in self.heard if h in self.said))

    def known_values(self, params: dict[str, float | bool],
                     robot_params: dict[str, tuple[tuple[str, tuple[float | bool, ...]], ...]]) -> None:
        """The values the code generator folds (parameters every robot shares, constants, dt), and
        each robot's with its own parameters: a group's place made of them is checked (infer.index)."""
        own = {name for pairs in robot_params.values() for name, _ in pairs}
        self.constants = {**CONSTANTS, "dt": self.bf.dt_s, **{k: v for k, v in params.items() if k not in own},
                          **self.lists}
        counts = {r.name: r.count for r in self.bf.robots}
        self.robot_constants = [] if not own else [
            (name if count == 1 else f"{name}[{k}]", {**self.constants, **params, **{
                p: values[min(k, len(values) - 1)] for p, values in robot_params.get(name, ())}})
            for name, count in counts.items() for k in range(count)]
        # each robot's, with its place in its group: a list's row picked by 'index' is known per robot
        own_of = dict(self.robot_constants)
        self.member_constants = [(who, {**own_of.get(who, self.constants), "index": float(k)})
                                 for name, count in counts.items() for k in range(count)
                                 for who in (name if count == 1 else f"{name}[{k}]",)]

    def read_back(self, models: dict[str, RobotModel], world: World | None) -> None:
        """Format 1.3: ``wheel_left``, ``wheel_right`` and the start pose, where every robot has wheels;
        else each is unknown with the reason, said where it is read."""
        version = self.bf.version
        wheelless = [m.name for m in models.values() if m.wheel_radius_m <= 0 or m.max_wheel_speed_rad_s <= 0]
        for name, t in READ_BACK.items():
            what = "a robot's wheel command" if name in WHEELS else "a robot's start pose"
            self.unavailable_notes[name] = (f"read-back is of robots with wheels: {', '.join(MODELS)}",)
            if version < 1.3:
                self.unavailable_notes[name] = ()
                self.unavailable[name] = later_format(f"'{name}'", 1.3)
            elif wheelless:
                self.unavailable[name] = f"'{name}' reads {what}, and robot model '{wheelless[0]}' has no wheels"
            elif not models and world is not None and world.mechanism is not None:
                self.unavailable[name] = (f"'{name}' reads {what}, and world '{world.name}' is a mechanism: there is "
                                          "no robot with wheels")
            elif not models:
                self.poisoned.add(name)  # the robots are reported as wrong, or the world: nothing more to say
            else:
                self.declare(name, t, _SHADOWABLE_KIND)
        self.grader_wheels = bool(models) and not wheelless and version < 1.3  # measured metrics read them

    def robots_failed(self, world: World | None, mechanism: Mechanism | None) -> bool:
        """Whether a robot was reported as wrong (an unknown model, no model, a mistyped or missing
        'robots:'): the names its model would have given are then not reported as unknown."""
        bf = self.bf
        return (bf.robots_failed or any(r.model not in MODELS for r in bf.robots)
                or (not bf.has_robots and mechanism is None and world is not None))

    def presence(self, world: World | None, mechanism: Mechanism | None) -> None:
        """robots: and rules: are needed unless the world is a mechanism and bind: drives it."""
        bf = self.bf
        if not isinstance(bf.doc.root, MappingNode):
            return  # the reader said what the file should be
        if world is not None and mechanism is not None and bf.has_robots:
            self.error(bf.robots[0].key if bf.robots else bf.doc.root,
                       f"world '{world.name}' is a mechanism: it has no place for robots")
        if not bf.has_robots and mechanism is None and world is not None:
            self.error(None, "missing required key 'robots:'",
                       notes=("e.g. 'robots: {pioneer: {model: pioneer_p3dx, at: spawn}}'",))
        if not bf.has_rules and not bf.binds and not bf.states:
            self.error(None, "missing required key 'rules:'",
                       notes=("e.g. 'rules: [\"always move(2)\"]', or 'bind:' for a mechanism",))

    def taken(self, name: str) -> bool:
        """Whether a name is declared already; the names added after version 1 give way to the file's."""
        return name in self.types and self.kinds[name] != _SHADOWABLE_KIND

    def clash(self, place: Place, what: str, name: str) -> None:
        """Report a name two declarations share. The first keeps it; uses that read it as the
        other (``follow + 1`` with a state 'follow' and a parameter 'follow') say nothing more."""
        self.error(place, f"{what} '{name}' has the name of a {self.kinds[name]}; choose another name")
        self.clashed.add(name)

    def key_of(self, value: Node) -> Node:
        """The key of a value under 'params:' (the name a mistake is in), or the value itself."""
        root = self.bf.doc.root
        for key, node in root.value if isinstance(root, MappingNode) else ():
            if key.value == "params" and isinstance(node, MappingNode):
                return next((k for k, v in node.value if v is value), value)
        return value

    def free(self, name: str, node: Node, what: str) -> bool:
        """Whether the file may take a name for its own: not the language's or the trace's, and not
        declared already (each reported at the name)."""
        if self.reserved(name, node, what):
            return False
        if self.taken(name):
            self.clash(node, what, name)
            return False
        return True

    def reserved(self, name: str, node: Node, what: str) -> bool:
        """Report a name the language or the trace already uses; True if it was one."""
        claimed = claimed_in_13(self, name)
        if claimed is not None:
            self.error(node, f"{what} '{name}' {claimed[0]}; choose another name", notes=claimed[1])
            self.poisoned.add(name)  # its uses say nothing more
            return True
        why = _reserved_why(name)
        if why is None:
            return False
        self.error(node, f"{what} '{name}' {why}; choose another name")
        self.poisoned.add(name)  # reported here: its uses say nothing more
        return True

    def sliders(self) -> list[SliderDecl]:
        out = []
        for slider in self.bf.sliders:
            if not self.free(slider.name, slider.key, "slider"):
                continue
            self.declare(slider.name, Type.NUMBER, "slider")
            out.append(slider)
        return out

    def labels(self) -> list[tuple[str, str, tuple]]:
        """Each slider's label fields must be numbers or booleans; a label is the slider's name or
        its ``label_name`` (format 1.2, which sliders may share)."""
        out = []
        for slider in self.bf.sliders:
            if slider.label is None:
                continue
            for part in slider.label.parts:
                if isinstance(part, tuple):
                    parsed, _ = part
                    t = self.infer(parsed.node, parsed.text)
                    if t is not None and t not in (Type.NUMBER, Type.BOOL):
                        self.error(parsed.text.at(parsed.node.span),
                                   f"a label shows numbers and booleans, not {t.a}")
            name = slider.name if slider.label_name is None else str(slider.label_name.value)
            out.append((name, slider.name, slider.label.parts))
        return out

    def binds(self) -> list[BindDecl]:
        out = []
        for b in self.bf.binds:
            if not self.joint_target(b.joint, b.mode, b.key):
                continue
            if self.expect(b.expr, b.expr.node, Type.NUMBER, f"the {b.mode} bound to {b.joint}"):
                out.append(b)
        return out

    def joint_target(self, joint: str, mode: str, place: Place) -> bool:
        """Whether a joint exists and its motor takes targets of this mode; else reported at place."""
        motors = self.motors
        if joint not in motors:
            known = list(motors)
            self.error(place, f"no joint named '{joint}'{did_you_mean(joint, known)}",
                       ("joints of this world: " + (", ".join(known) or "none"),))
            return False
        accepts = motors[joint]
        if not accepts:
            self.error(place, f"joint '{joint}' has no motor: nothing can set its {mode}")
            return False
        if mode not in accepts:
            self.error(place, f"joint '{joint}' takes target {' and '.join(sorted(accepts))}s, not {mode}s")
            return False
        return True

    def timeline(self, sliders: list[SliderDecl]) -> None:
        by_name = {s.name: s for s in sliders}
        last = -math.inf
        for event in self.bf.timeline:
            if event.time_s < last:
                self.error(event.node, f"timeline entries go forward in time: "
                                       f"{event.time_s:g} s comes after {last:g} s")
            last = max(last, event.time_s)
            for name, value, start in event.settings:
                where = event.text.at((start, start + len(name)))
                slider = by_name.get(name)
                if slider is None:
                    self.error(where, f"no slider named '{name}'{did_you_mean(name, by_name)}")
                elif not slider.lo <= value <= slider.hi:
                    self.error(where, f"{name} = {value:g} is outside the slider's "
                                      f"range {slider.lo:g} .. {slider.hi:g}")

    def spawns(self, world: World | None) -> None:
        """Robots placed 'at: spawn' need as many spawn poses as there are of them; robots
        placed at [x, y] must be inside the world's bounds."""
        if world is None:
            return
        xmin, ymin, xmax, ymax = world.bounds
        for r in self.bf.robots:
            for (x, y, _), node in r.fixed():
                if not (xmin <= x <= xmax and ymin <= y <= ymax):
                    self.error(node, f"({x:g}, {y:g}) is outside world '{world.name}' "
                               f"({xmin:g}..{xmax:g} x {ymin:g}..{ymax:g})")
        needed = 0
        for r in self.bf.robots:
            if r.at == "spawn":
                needed += r.count
                if needed > len(world.spawns):
                    node = r.at_node if r.at_node is not None else r.key
                    self.error(node, f"world '{world.name}' has {len(world.spawns)} spawn poses, too few for "
                                     f"{needed} robots placed 'at: spawn'",
                               notes=("use 'at: random', give poses as [x, y, heading_deg], or fewer robots",)
                               if self.bf.version < 1.3 else ("use 'at: random', fewer robots, or a pose for each "
                                                              "robot: 'at: [[x, y, heading_deg], ...]'",))
                    return

    def world(self) -> World | None:
        from labsim.backends.scene.world_file import load_world  # late: world files use this package too

        bf = self.bf
        if bf.world_node is None:
            return None
        found = find_world(bf.world, Path(bf.doc.path).parent)
        if found.path is None:
            self.error(bf.world_node, found.problem, notes=found.notes)
            self.world_failed = True
            return None
        world = load_world(found.path, self.report)
        self.world_failed = world is None
        return world

    def models(self) -> dict[str, RobotModel]:
        out = {}
        for r in self.bf.robots:
            model = MODELS.get(r.model)
            if model is None:
                node = r.model_node if r.model_node is not None else r.key
                self.error(node, f"unknown robot model '{r.model}'{did_you_mean(r.model, MODELS)}",
                           notes=("models: " + ", ".join(MODELS),))
            else:
                model = dataclasses.replace(model, cameras=(r.camera,)) if r.camera else model
                out[r.name] = dataclasses.replace(model, lidars=(r.lidar,)) if r.lidar else model
        return out

    def params(self, overrides: dict[str, str]) -> dict[str, float | bool]:
        self.overrides = dict(overrides)  # a place made of one names its --set
        values: dict[str, float | bool] = {}
        for name, (value, node) in self.bf.params.items():
            key = self.key_of(node)
            if not self.free(name, key, "parameter"):
                continue
            values[name] = value
            self.declare(name, Type.BOOL if isinstance(value, bool) else Type.NUMBER, "parameter")
        self.list_params()
        self.set_values = dict(overrides)  # a message about a value known before the run names them
        for name, raw in overrides.items():
            where = shown_setting(name, raw)
            self.settings[name] = where
            if name in self.lists:
                listed, problem, notes = list_setting(raw, name, self.lists[name])
                if listed is None:
                    self.setting_error(where, problem, notes)
                else:
                    self.lists[name] = listed
                    if not is_table(listed):
                        self.group_sizes[name] = len(listed)
                continue
            if name not in values:
                named = [*values, *self.lists]
                known = ", ".join(named) or "none"
                self.setting_error(where, f"unknown parameter '{name}'{did_you_mean(name, named)}",
                                   notes=(f"parameters of {self.bf.path}: {known}",))
                continue
            values[name] = self.override(name, raw, values[name], where)
        return values

    def list_params(self) -> None:
        """Format 1.3: each list parameter, a group of numbers (``gains: [0.5, 1, 2]``) or a list of rows."""
        for name, (value, node) in self.bf.lists.items():
            key = self.key_of(node)
            if not self.free(name, key, "parameter"):
                continue
            self.lists[name] = value
            if is_table(value):
                self.declare(name, Type.LIST, "list parameter")
            else:
                self.declare(name, Type.NUMBERS, "list parameter")
                self.group_sizes[name] = len(value)

    def robot_params(self, params: dict[str, float | bool]
                     ) -> dict[str, tuple[tuple[str, tuple[float | bool, ...]], ...]]:
        """Each robot group's own values of parameters 'params:' declares, of the same type."""
        out = {}
        for r in self.bf.robots:
            own = []
            for name, values, key in r.params:
                if name in self.lists:
                    self.error(key, f"robot '{r.name}' sets list parameter '{name}': a list is the same for every "
                               "robot", notes=(f"give each robot its own row of '{name}' and pick it with "
                                               f"{name}[index]",))
                elif name not in params:
                    known = ", ".join(params) or "none"
                    self.error(key, f"robot '{r.name}' sets parameter '{name}', which 'params:' does not declare"
                               f"{did_you_mean(name, params)}", notes=(f"parameters: {known}",))
                elif any(isinstance(v, bool) != isinstance(params[name], bool) for v in values):
                    want = "true or false" if isinstance(params[name], bool) else "a number"
                    self.error(key, f"parameter '{name}' is {want} in 'params:', and so must be robot "
                               f"'{r.name}'s")
                else:
                    own.append((name, values))
            out[r.name] = tuple(own)
        return out

    def noise(self, params: dict[str, float | bool],
              robot_params: dict[str, tuple[tuple[str, tuple[float | bool, ...]], ...]],
              overrides: dict[str, str]) -> dict[str, tuple[Noise | None, ...]]:
        """Each group's noise, per member, the parameters it names resolved (``labsim.dsl.syntax.noise``)."""
        out = {}
        for r in self.bf.robots:
            if r.noise is not None:
                self.used |= r.noise.names  # a parameter that only sets noise is used
                members = resolve_noise(r.noise, r.name, r.count, params, dict(robot_params.get(r.name, ())),
                                        overrides, self.bf.params, self.error, self.lists)
                if members is not None:
                    out[r.name] = members
        return out

    def lets(self) -> list[tuple[str, Parsed]]:
        """Each signal in the file's order; one that another robot's value is read of above it
        (``1 if leader.flag else 0`` before 'flag') is checked first, when what it reads by name
        allows, so that its type is known there (format 1.3: the value is the last tick's)."""
        decls = self.bf.lets
        index = {name: i for i, (name, _, _) in enumerate(decls)}
        # a signal refused for its name is not one to wait for: its uses above read what else has the name
        self.later = {name: key for name, _, key in decls
                      if _reserved_why(name) is None and claimed_in_13(self, name) is None}
        self.poisoned |= {name for name, _, _ in decls if name not in self.later}  # reported at the name
        done: dict[int, tuple[str, Parsed] | None] = {}
        busy: set[int] = set()

        def check(i: int) -> None:
            if i in done or i in busy:
                return
            busy.add(i)
            for e in ast.walk(decls[i][1].node):
                j = index.get(e.attr, -1) if isinstance(e, ast.Peer) else -1
                for k in _hoisted(decls, index, j, set(done), busy) if j > i else ():
                    check(k)
            done[i] = self.let(*decls[i])
            busy.discard(i)

        for i in range(len(decls)):
            check(i)
        # the trace's columns of what is read of the others follow the signals reading them, as
        # without the checks moved up: by the first signal reading each (a stable sort)
        first: dict[str, int] = {}
        for i, (_, parsed, _) in enumerate(decls):
            for e in ast.walk(parsed.node):
                if id(e) in self.received_at:
                    first.setdefault(self.received_at[id(e)], i)
        self.received = {n: self.received[n] for n in sorted(self.received, key=lambda n: first.get(n, len(decls)))}
        self.later = {}
        check_later(self)  # another robot's signals read above their definitions
        return [kept for _, kept in sorted(done.items()) if kept is not None]

    def let(self, name: str, parsed: Parsed, key: Node) -> tuple[str, Parsed] | None:
        """One signal checked and declared; None if it is wrong (reported)."""
        if self.taken(name):
            self.later.pop(name, None)  # uses read what has the name already
            self.clash(key, "signal", name)
            return None
        if self.reserved(name, key, "signal"):
            return None
        self.later.pop(name, None)
        self.current_let, self.self_prev_types = name, []
        written, said = self.members_written, len(self.report.diagnostics)
        t = self.infer(parsed.node, parsed.text)
        if self.starts_each_member(t, parsed) and len(self.report.diagnostics) == said:
            t = self.each_member_reads_itself(t, parsed, written)
        self.current_let = ""
        t = self.self_read(name, t, parsed)
        if t is Type.LIST:  # v: wp; its uses name the list itself
            assert isinstance(parsed.node, ast.Name)
            lst = parsed.node.id
            self.error(parsed.text.at(parsed.node.span), f"a signal cannot hold the list of rows '{lst}': name "
                       f"'{lst}' where it is used, as in {lst}[i], {lst}[i][0] or len({lst})")
            t = None
        if t is None:
            self.poisoned.add(name)  # already reported: its uses stay quiet
            return None
        self.declare(name, t, "signal")
        if t in (Type.NUMBERS, Type.BOOLS):
            self.group_sizes[name] = self.size(parsed.node)
        return name, parsed

    def starts_each_member(self, t: Type | None, parsed: Parsed) -> bool:
        """Whether a group signal reads itself from one start for every member, as in prev(smooth, 1)."""
        return self.version >= 1.3 and t in (Type.NUMBERS, Type.BOOLS) and bool(self.self_prev_types) and all(
            initial is t.member and not any(isinstance(n, ast.Call) and n.func in STATEFUL | RANDOM
                                            for n in ast.walk(call.args[1]))
            for call, initial in self.self_prev_types)

    def each_member_reads_itself(self, t: Type | None, parsed: Parsed, written: int) -> Type | None:
        """smooth: 0.8 * prev(smooth, 1) + 0.2 * front is a group, each member from that start: read again
        with prev(smooth, 1) a group of smooth's size; as first read if that is wrong ([prev(f, 0) + 1, 2])."""
        first = (t, self.self_prev_types, self.members_written)
        report, self.report = self.report, Report()
        self.members_written, self.self_prev_types, self.group_self = written, [], self.size(parsed.node)
        try:
            again = self.infer(parsed.node, parsed.text)
        finally:
            self.report, self.group_self, scratch = report, 0, self.report
        if again is None or scratch.diagnostics:
            t, self.self_prev_types, self.members_written = first
            return t
        return again

    def self_read(self, name: str, t: Type | None, parsed: Parsed) -> Type | None:
        """A signal that reads itself through prev(name, initial) is of its initial value's type."""
        for call, initial in self.self_prev_types:
            if t in (Type.NUMBERS, Type.BOOLS) and initial is t.member:  # smooth: 0.8 * prev(smooth, 1) + ...
                n, start = self.size(parsed.node), parsed.text.value[call.args[1].span[0]:call.args[1].span[1]]
                example = f"[{', '.join([start] * n)}]" if n <= 8 and len(start) <= 6 else "a group of as many"
                self.error(parsed.text.at(call.args[1].span), f"signal '{name}' is a group of {n} {t.member}s, so "
                           f"prev({name}, ...) starts from a group of {n} too, a value for each member; this is "
                           f"{initial.a}",
                           notes=(f"start each member from its own value, as in prev({name}, {example})",))
                return None
            if t is not None and initial is not None and initial is not t:
                self.error(parsed.text.at(call.args[1].span), f"signal '{name}' is {t.a}, so prev({name}, ...) "
                           f"starts from {t.a} too; this is {initial.a}")
                return None
            if t in (Type.NUMBERS, Type.BOOLS) and self.size(call) != self.size(parsed.node):
                self.error(parsed.text.at(call.args[1].span), f"signal '{name}' has {self.size(parsed.node)} "
                           f"members, so prev({name}, ...) starts from as many; this has {self.size(call)}")
                return None
        return t

    def rules(self) -> dict[str, list[RuleDecl]]:
        states = {name: rules for name, (rules, _) in self.bf.states.items()}
        for rules in states.values():
            unconditional: RuleDecl | None = None
            for decl in rules:
                rule = decl.rule
                if unconditional is not None:
                    line = unconditional.text.node.start_mark.line + 1
                    self.error(decl.text.at(rule.span), f"this rule can never fire: the "
                               f"'{unconditional.rule.kind}' rule on line {line} fires first, every tick")
                if rule.condition is not None:
                    self.expect(Parsed(rule.condition, decl.text), rule.condition, Type.BOOL, "a rule's condition")
                elif unconditional is None:
                    unconditional = decl
                self.actions(decl, states)
        check_channels(self)  # every channel heard is said by a rule
        return states

    def actions(self, decl: RuleDecl, states: dict[str, list[RuleDecl]]) -> None:
        text = decl.text
        if decl.rule.kind == "when":
            for a in decl.rule.actions:
                if isinstance(a, ast.Goto) or (a.name != "log" and a.text is None and a.name in ACTIONS):
                    logs = "logs and says" if self.version >= 1.3 else "logs"
                    self.error(text.at(a.span), f"a 'when' rule only {logs}, and the rules below it go on; to "
                               f"{'switch states' if isinstance(a, ast.Goto) else 'drive'}, write an 'if' rule",
                               notes=("e.g. 'when rising(collided) then log(\"hit\")', then "
                                      "'if collided then move(-2)'",))
                    for said in decl.rule.actions:  # what hears on its channels says nothing more
                        if isinstance(said, ast.Action) and said.name == SAY and said.args \
                                and isinstance(said.args[0], ast.Name) and self.version >= 1.3:
                            self.said.setdefault(said.args[0].id, None)
                    return
        actions = [a for a in decl.rule.actions if isinstance(a, ast.Action)]
        for action in actions:
            if action.name == "log" or action.text is not None:
                self.log_action(action, text)
        said_here: set[str] = set()
        for action in actions:
            if action.name == SAY and action.text is None:
                check_say(self, action, text, said_here)
        actions = [a for a in actions if a.name not in ("log", SAY) and a.text is None]
        drives = [a for a in actions if a.name not in JOINT_ACTIONS]
        for action in actions:
            if action.name in JOINT_ACTIONS:
                self.joint_action(action, text)
        gotos = [a for a in decl.rule.actions if isinstance(a, ast.Goto)]
        if len(drives) > 1:
            self.error(text.at(drives[1].span), "a rule can drive the wheels once: this action would override "
                       f"'{drives[0].name}(...)'")
        if len(gotos) > 1:
            self.error(text.at(gotos[1].span), "a rule can 'goto' one state")
        for action in drives:
            spec = ACTIONS.get(action.name)
            if spec is None and action.name in PRINTS:  # print(x): to print, there is log("...")
                self.log_action(action, text)
                continue
            if spec is None:
                self.unknown_action(action, text)
                continue
            if len(action.args) != len(spec.params):
                self.error(text.at(action.span), arity_message(action.name, spec.params, len(action.args)))
            for arg in action.args:
                self.expect(Parsed(arg, text), arg, Type.NUMBER, f"an argument of {action.name}()")
        for goto in gotos:
            if goto.state not in states:
                if list(states) == ["main"]:
                    notes = ("to use states, write 'rules:' as a mapping from state names to lists of rules",)
                else:
                    notes = ("states: " + ", ".join(states),)
                self.error(text.at(goto.state_span),
                           f"no state named '{goto.state}'{did_you_mean(goto.state, states)}", notes=notes)

    def unknown_action(self, action: ast.Action, text: Text) -> None:
        """An action that does not exist, with the nearest (say() too, format 1.3); a mistyped say's
        channel counts as said, so that what hears on it is not reported as well."""
        says = self.version >= 1.3
        hint = did_you_mean(action.name, [*ACTIONS, *((SAY,) if says else ())])
        what = "function, not an action" if action.name in FUNCTIONS else "action"
        listed = [f"{a.name}({', '.join(a.params)})" for a in ACTIONS.values()]
        if says:
            listed.insert(listed.index("log(text)") if "log(text)" in listed else len(listed),
                          "say(channel, value[, range_m])")
        self.error(text.at(action.name_span), f"unknown action '{action.name}'{hint}" if what == "action"
                   else f"'{action.name}' is a {what}", notes=("actions: " + ", ".join(listed) + ", goto STATE",))
        if hint == f" (did you mean '{SAY}'?)" and action.args and isinstance(action.args[0], ast.Name):
            self.said.setdefault(action.args[0].id, None)

    def log_action(self, action: ast.Action, text: Text) -> None:
        """log("text {expr:.2f}"): quoted text whose fields are numbers or booleans."""
        if action.name == SAY and self.version >= 1.3:  # say("pos", 2): the channel is a name, not text
            self.error(text.at(action.name_span),
                       f"a channel is a name written without quotes: {say_example(action, text)}")
            words = "".join(p for p in action.text or () if isinstance(p, str)).strip()
            if words.isidentifier():  # what hears on it is not reported as well
                self.said.setdefault(words, None)
            return
        if action.name not in ACTIONS:  # print("..."), say("hi", 2) before 1.3: an action that does not exist
            self.error(text.at(action.name_span), f"unknown action '{action.name}' (to print text, use "
                       f'log("...")' + ")", notes=(f"e.g. {log_example(action, text)}: printed with the time and "
                                                  "the robot, and recorded in the trace",))
            return
        if action.name != "log":
            self.error(text.at(action.span), f"only log() takes text in quotes; {action.name}() takes numbers",
                       notes=('to print text, add log("...") as another action of the rule',))
            return
        if action.text is None:
            self.error(text.at(action.span), 'log() takes text in quotes, as in log("hit at {time:.1f} s")')
            return
        if action.args:  # log("wall!", x): the values belong in the text's fields
            self.error(text.at((action.args[0].span[0], action.args[-1].span[1])),
                       f"log() takes one text, and values go in its fields: {log_example(action, text)}")
            return
        for part in action.text:
            if isinstance(part, tuple):
                t = self.infer(part[0], text)
                if t is not None and t not in LOGGED:
                    self.error(text.at(part[0].span), f"a log text shows numbers, booleans, text and states, "
                               f"not {t.a}", notes=(("show a member, as in {front[0]}, or a reduction, as in "
                                                     "{min(front)}",) if t in (Type.NUMBERS, Type.BOOLS) else ()))

    def joint_action(self, action: ast.Action, text: Text) -> None:
        """set_velocity(Joint, v), set_position(Joint, p)."""
        if len(action.args) != 2:
            self.error(text.at(action.span), arity_message(action.name, ACTIONS[action.name].params,
                                                           len(action.args)))
            return
        joint, value = action.args
        if not isinstance(joint, ast.Name):
            self.error(text.at(joint.span), f"{action.name}() takes a joint's name first, as in "
                       f"{action.name}(Hoist_Actuator, 0.5)")
            return
        self.joint_target(joint.id, JOINT_ACTIONS[action.name], text.at(joint.span))
        self.expect(Parsed(value, text), value, Type.NUMBER, f"the {JOINT_ACTIONS[action.name]} in {action.name}()")

    def metrics(self) -> list[Metric]:
        out = []
        names = ", ".join(f"{a}(...)" for a in AGGREGATES)
        for decl in self.bf.metrics:
            name, parsed = decl.name, decl.value
            e = parsed.node
            if not (isinstance(e, ast.Call) and e.func in AGGREGATES):
                hint = ""
                if isinstance(e, ast.Call) and e.func in ("max", "min", "sum", "avg", "average", "time"):
                    hint = did_you_mean({"max": "maximum", "min": "minimum", "avg": "mean", "average": "mean",
                                         "time": "duration", "sum": "count"}[e.func], AGGREGATES)
                self.error(parsed.text.at(e.span), f"metric '{name}' must be an aggregate over the run{hint}",
                           notes=(f"aggregates: {names}",))
                continue
            agg = AGGREGATES[e.func]
            if len(e.args) != 1:
                self.error(parsed.text.at(e.span), f"{e.func}() takes 1 argument, given {len(e.args)}")
                continue
            what = "a condition" if agg.argument is Type.BOOL else "a number"
            argument = e.args[0]
            if decl.grader and self.grader_wheels:  # a grader's metric reads the wheels in a file of any format
                for wheel in WHEELS:
                    self.declare(wheel, Type.NUMBER, _SHADOWABLE_KIND)
            if self.expect(Parsed(argument, parsed.text), argument, agg.argument,
                           f"{e.func}() needs {what}: its argument"):
                better = decl.better if decl.better is not None else agg.better
                out.append(Metric(name, agg, argument, parsed.text, better))
        return out

    def override(self, name: str, raw: str, current: float | bool, setting: str) -> float | bool:
        """A parameter's value given by ``--set`` (setting: 'NAME=VALUE'); the current one if wrong."""
        # sweep takes a list as comma-separated values: --set keep=[1,2] is pointed at --set keep=1,2
        listed = ",".join(v.strip() for v in raw.strip().strip("[]").split(",")) if "[" in raw or "]" in raw else raw
        several = (f"a run takes one value; to try several, use labsim sweep {self.bf.path} "
                   f"{shown_setting(name, listed)}",) if "," in raw else ()
        if isinstance(current, bool):
            if raw.lower() in ("true", "false"):
                return raw.lower() == "true"
            self.setting_error(setting, f"parameter '{name}' is true or false, not '{raw[:40]}'", several)
            return current
        try:
            value = to_float(raw)  # the one rule for numbers: --set front=1e309 is too large
        except NumberError as e:
            self.setting_error(setting, f"parameter '{name}': {e}" if str(e).startswith(TOO_LARGE)
                               else f"parameter '{name}' is a number, not '{raw[:40]}'", several)
            return current
        if not math.isfinite(value):
            self.setting_error(setting, f"parameter '{name}' must be a finite number")
            return current
        return int(value) if isinstance(current, int) and value == int(value) else value


def _reserved_why(name: str) -> str | None:
    """Why a name the language or the trace already uses cannot be a file's own, or None if it can."""
    if name in SHADOWABLE:
        return None  # a version 1 file may use it for its own
    if name in KEYWORDS:
        return "is a keyword of the language"
    if name in FUNCTIONS or name in ACTIONS or name in AGGREGATES or name == DETECTED:
        return "is the name of a built-in function or action"
    if name in TRACE_COLUMNS:
        return "is the name of a trace column"
    return None


def _hoisted(decls: list[tuple[str, Parsed, Node]], index: dict[str, int], j: int, done: set[int],
             busy: set[int]) -> list[int]:
    """The signals to check, in order, so that signal j is checked before its place in the file: those
    above it that it reads by name and are not checked yet, then j; none if j is checked already, or
    if one of them is being checked (a same-robot read keeps the file's order)."""
    if j in done or j in busy:
        return []
    plan: list[int] = []
    for e in ast.walk(decls[j][1].node):
        k = index.get(e.id, -1) if isinstance(e, ast.Name) else -1
        if not 0 <= k < j or k in plan or k in done:
            continue
        sub = _hoisted(decls, index, k, done, busy | {j})
        if not sub:
            return []
        plan += [n for n in sub if n not in plan]
    return [*plan, j]
