"""Behaviour file structure: the YAML document read into a ``BehaviourFile``.

This stage knows the top-level keys and their shapes (``robots`` is a mapping of robot
groups, ``rules`` a list or a mapping of states, ...), converts plain values, and parses every
rule and expression string with ``labsim.dsl.syntax.parse``. It reports every problem it finds into a
``Report`` and keeps going, so that one run of ``labsim check`` shows them all. Names and
types are the checker's business, not this module's.

Over 500 lines: the checker and the compiler import the declarations from here, and each
section's reader builds them, so readers and declarations cannot part without a cycle.
"""
from __future__ import annotations

import hashlib
import math
import re
from dataclasses import dataclass, field
from typing import Any

from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from labsim.backends.scene import object_paths
from labsim.backends.scene.models import Camera, Lidar
from labsim.backends.scene.world_names import builtin_copy
from labsim.dsl.library.builtins import KEYWORDS, Better
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.lidar import MAX_BEAMS, beam_names, read_lidar
from labsim.dsl.syntax.lists import ListValue, list_value
from labsim.dsl.syntax.noise import NoiseDecl, read_noise
from labsim.dsl.syntax.parse import ParseError, parse_expr, parse_label, parse_printf, parse_rule
from labsim.foundation.diagnostics import Report, did_you_mean
from labsim.foundation.kinds import kind_of_keys
from labsim.foundation.limits import MAX_COORD_M, MAX_DT_S, MIN_DT_S
from labsim.foundation.numbers import TOO_LARGE, WHOLE_LIMIT, NumberError, to_float
from labsim.foundation.source import Document, Reader, Text, scalar_value, shape_of

FORMAT_VERSION = 1
VERSIONS = (1, 1.1, 1.2, 1.3)  # docs/language.md; a file's version keeps its meaning



def later_format(what: str, version: float) -> str:
    """The error for a construct a later format brings, e.g. ``"'label_name' is format 1.2: start the file
    with 'labsim: 1.2'"``: a file's version keeps its meaning, so what it did not have is refused, not guessed."""
    return f"{what} is format {version:g}: start the file with 'labsim: {version:g}'"


TOP_KEYS = ("labsim", "name", "description", "world", "dt", "seed", "stop", "robots", "params",
            "functions", "let", "rules", "metrics", "sliders", "bind", "timeline")
REQUIRED = ("labsim", "world", "stop")  # robots and rules: see check.py (a mechanism needs neither)
SLIDER_KEYS = ("min", "max", "value", "label", "label_name")  # label_name: format 1.2
METRIC_KEYS = ("value", "better")  # a metric written as a mapping: its aggregate, and which way is better
# Words students write for a direction, and the one they mean
_BETTER_MEANT = {"more": "higher", "high": "higher", "max": "higher", "maximum": "higher", "maximize": "higher",
                 "larger": "higher", "bigger": "higher", "up": "higher", "less": "lower", "low": "lower",
                 "min": "lower", "minimum": "lower", "minimize": "lower", "smaller": "lower", "fewer": "lower",
                 "down": "lower"}
ROBOT_KEYS = ("model", "count", "at", "camera", "lidar", "paths", "params", "noise")
PATH_KEYS = ("robot", "left_motor", "right_motor", "sonar", "camera")
CAMERA_KEYS = ("resolution", "fov_deg", "height_m", "pitch_deg", "x_m", "roll_deg")
MAX_CAMERA_PX = 2048  # per side: beyond this a frame costs more than a tick should


@dataclass(frozen=True)
class Parsed:
    """A parsed string and where it came from."""

    node: Any  # ast.Expr or ast.Rule
    text: Text


Pose = tuple[float, float, float]  # x_m, y_m, heading_deg as a file writes it


@dataclass(frozen=True)
class RobotDecl:
    name: str
    model: str
    count: int
    # "spawn", "random", (x_m, y_m, heading_deg), or (format 1.3) a tuple of such poses, one per member
    at: str | Pose | tuple[Pose, ...]
    key: Node  # for diagnostics
    model_node: Node | None
    camera: Camera | None = None
    at_node: Node | None = None
    paths: tuple[tuple[str, str], ...] = ()  # scene object names for a simulator (CoppeliaSim)
    # parameters this group sets for itself: name, one value per member (or one for all), node
    params: tuple[tuple[str, tuple[float | bool, ...], Node], ...] = ()
    noise: NoiseDecl | None = None  # labsim.dsl.syntax.noise, resolved by the checker; None: none declared
    lidar: Lidar | None = None  # labsim.dsl.syntax.lidar; the checker puts it on the group's model

    def fixed(self) -> list[tuple[Pose, Node]]:
        """The fixed start poses a group's ``at:`` gives, each with where it is written: one pose (for
        every member), or one per member; none for 'spawn' and 'random'."""
        at, node = self.at, self.at_node if self.at_node is not None else self.key
        if isinstance(at, str):
            return []
        if isinstance(at[0], tuple):
            assert isinstance(node, SequenceNode)
            return [(pose, item) for pose, item in zip(at, node.value)]
        return [(at, node)]

    def start(self, k: int) -> Pose | None:
        """Member k's fixed start pose; None for 'spawn' and 'random'."""
        if isinstance(self.at, str):
            return None
        pose = self.at[k] if isinstance(self.at[0], tuple) else self.at
        return pose


@dataclass(frozen=True)
class FunctionDecl:
    """``steer(offset, gain): clamp(gain * offset, -2, 2)`` under ``functions:`` (version 1.2)."""

    name: str
    params: tuple[str, ...]
    body: Parsed
    key: Node  # the key, where a problem with the definition is reported
    param_spans: tuple[tuple[int, int], ...] = ()  # each parameter's characters in the key


@dataclass(frozen=True)
class MetricDecl:
    """``NAME: aggregate(expr)``, or ``NAME: {value: aggregate(expr), better: higher}``."""

    name: str
    value: Parsed
    key: Node
    better: Better | None = None  # None: not declared (the checker takes the aggregate's default)
    grader: bool = False  # a grader's measured metric (labsim grade): it reads the wheels in a file of any format


@dataclass(frozen=True)
class RuleDecl:
    state: str
    number: int  # 1-based within its state
    rule: ast.Rule
    text: Text


@dataclass(frozen=True)
class Label:
    """A slider's label: literal text and {expression:format} fields, in order."""

    parts: tuple[str | tuple[Parsed, str], ...]


@dataclass(frozen=True)
class SliderDecl:
    name: str
    lo: float
    hi: float
    value: float
    label: Label | None
    key: Node
    label_name: Node | None = None  # format 1.2: the label it writes, shared with sliders naming the same


@dataclass(frozen=True)
class BindDecl:
    """``Joint.velocity: expression`` under ``bind:``."""

    joint: str
    mode: str  # "velocity" or "position"
    expr: Parsed
    key: Node


@dataclass(frozen=True)
class Event:
    """One timeline entry: at time_s, the sliders take these values."""

    time_s: float
    settings: tuple[tuple[str, float, int], ...]  # slider, value, offset of the setting in text
    node: Node
    text: Text


@dataclass
class BehaviourFile:
    doc: Document
    sha256: str
    version: float = FORMAT_VERSION  # 1, 1.1, 1.2 or 1.3
    name: str = ""
    description: str = ""
    world: str = ""
    world_node: Node | None = None
    dt_s: float = 0.05
    seed: int = 0
    stop: Parsed | None = None
    robots: list[RobotDecl] = field(default_factory=list)
    params: dict[str, tuple[float | bool, Node]] = field(default_factory=dict)
    lists: dict[str, tuple[ListValue, Node]] = field(default_factory=dict)  # list parameters (format 1.3)
    functions: list[FunctionDecl] = field(default_factory=list)
    lets: list[tuple[str, Parsed, Node]] = field(default_factory=list)
    states: dict[str, tuple[list[RuleDecl], Node | None]] = field(default_factory=dict)
    metrics: list[MetricDecl] = field(default_factory=list)
    sliders: list[SliderDecl] = field(default_factory=list)
    binds: list[BindDecl] = field(default_factory=list)
    timeline: list[Event] = field(default_factory=list)
    has_robots: bool = False
    robots_failed: bool = False  # a robot was reported as wrong and left out: its names' uses stay quiet
    has_rules: bool = False
    failed_names: set[str] = field(default_factory=set)  # lets, metrics and cameras that were reported as wrong

    @property
    def path(self) -> str:
        return self.doc.path


def _is_world_file(root: MappingNode) -> bool:
    """A world file given where a behaviour belongs, by the one rule for file kinds."""
    return kind_of_keys({k.value for k, _ in root.value if isinstance(k, ScalarNode)}) == "world"


def read(doc: Document, report: Report) -> BehaviourFile:
    bf = BehaviourFile(doc, hashlib.sha256(doc.text.encode()).hexdigest())
    r = _Reader(doc, report)
    root = doc.root
    if not isinstance(root, MappingNode):
        message = "a behaviour file is a YAML mapping of keys such as 'world:', 'robots:' and 'rules:'"
        if root is not None:
            r.error(root, message)
        else:
            r.error(0, "the file is empty: " + message)
        return bf
    if _is_world_file(root):
        name = builtin_copy(doc.path, doc.text) or doc.path
        r.error(root.value[0][0], "this is a world file, not a behaviour: a behaviour names it with 'world:'",
                notes=(f"run a behaviour with 'world: {name}' in it; 'labsim new wall_follow my_lab' copies a "
                       "lab into the folder my_lab to start from (labsim labs lists the labs), and docs/worlds.md "
                       "describes world files",))
        report.raise_if_errors()  # nothing else of it is worth saying
    keys = r.known_keys(root, TOP_KEYS, "", "the file")
    for k in REQUIRED:
        if k not in keys:
            r.error(None, f"missing required key '{k}:'", notes=(_REQUIRED_HINTS[k],))
    r.header(keys, bf)
    r.sections(keys, bf)
    bf.failed_names |= r.failed_names
    bf.robots_failed = r.robots_failed
    return bf


_REQUIRED_HINTS = {
    "labsim": "start the file with 'labsim: 1' (the format version)",
    "world": "e.g. 'world: walls_lab4' (a built-in world) or a path to a world file",
    "stop": "when the run ends, e.g. 'stop: time >= 60'",
    "robots": "e.g. 'robots: {pioneer: {model: pioneer_p3dx, at: spawn}}'",
    "rules": "e.g. 'rules: [\"always move(2)\"]'",
}


class _Reader(Reader):
    def __init__(self, doc: Document, report: Report) -> None:
        super().__init__(doc, report)
        self.failed_names: set[str] = set()  # declared, but reported as wrong: uses stay quiet
        self.robots_failed = False
        self.robot_names: frozenset[str] = frozenset()  # format 1.3: leader.x reads robot 'leader'

    def number_problem(self, node: Node, what: str, integer: bool) -> tuple[str, tuple[str, ...]]:
        if not isinstance(node, ScalarNode):
            return f"{what} must be a single value, not a {shape_of(node)}", ()
        value = scalar_value(node)
        if value is None:
            return f"{what} needs a value", ()
        if isinstance(value, float) and not math.isfinite(value):
            return f"{what} must be a finite number, not '{node.value}'", ()
        return f"{what} must be {'a whole number' if integer else 'a number'}, not '{node.value}'", ()

    # -- the file's own keys ------------------------------------------------------------------

    def header(self, keys: dict[str, Node], bf: BehaviourFile) -> None:
        """The format version, name, description, world, time step and seed."""
        if "labsim" in keys:
            v = self.number(keys["labsim"], "labsim")
            if v is not None and v not in VERSIONS:
                self.error(keys["labsim"], f"this labsim reads format versions 1, 1.1, 1.2 and 1.3, not {v:g}")
            elif v is not None:
                bf.version = v
        bf.name = (self.string(keys["name"], "name") or "") if "name" in keys else self.doc.path
        if "description" in keys:
            bf.description = self.string(keys["description"], "description") or ""
        if "world" in keys:
            bf.world = self.string(keys["world"], "world") or ""
            bf.world_node = keys["world"]
        if "dt" in keys:
            dt = self.number(keys["dt"], "dt")
            if dt is not None and not MIN_DT_S <= dt <= MAX_DT_S:
                self.error(keys["dt"], f"dt must be from {MIN_DT_S:g} to {MAX_DT_S:g} second, not {dt:g}")
            elif dt is not None:
                bf.dt_s = dt
        if "seed" in keys:
            seed = self.number(keys["seed"], "seed", integer=True)
            if seed is not None and not 0 <= seed <= WHOLE_LIMIT:
                self.error(keys["seed"], f"seed must be a whole number from 0 to {WHOLE_LIMIT} (2**53)")
            elif seed is not None:
                bf.seed = int(seed)

    def sections(self, keys: dict[str, Node], bf: BehaviourFile) -> None:
        """Everything after the header: stop, robots, params, let, rules, metrics and the controls."""
        robots = keys.get("robots")
        if bf.version >= 1.3 and isinstance(robots, MappingNode):  # leader.x reads robot 'leader' (format 1.3)
            self.robot_names = frozenset(k.value for k, _ in robots.value if isinstance(k, ScalarNode)
                                         and isinstance(k.value, str))
        if "stop" in keys:
            bf.stop = self.expr(keys["stop"], "stop")
        if "robots" in keys:
            bf.robots = self.robots(keys["robots"], bf.version)
            bf.has_robots = True
        if "params" in keys:
            bf.params = self.params(keys["params"], bf.version, bf.lists)
        if "functions" in keys:
            bf.functions = self.functions(keys["functions"])
        if "let" in keys:
            bf.lets = self.named_exprs(keys["let"], "let")
            declared = {k.value for k, _ in keys["let"].value} if isinstance(keys["let"], MappingNode) else set()
            bf.failed_names = declared - {n for n, _, _ in bf.lets}
        if "rules" in keys:
            bf.states = self.states(keys["rules"])
            bf.has_rules = True
        if "metrics" in keys:
            bf.metrics = self.metrics(keys["metrics"])
        if "sliders" in keys:
            bf.sliders = self.sliders(keys["sliders"], bf.version)
        if "bind" in keys:
            bf.binds = self.binds(keys["bind"])
        if "timeline" in keys:
            bf.timeline = self.timeline(keys["timeline"])

    # -- shapes a behaviour file uses ----------------------------------------------------------

    def expr(self, node: Node, what: str) -> Parsed | None:
        if isinstance(node, SequenceNode) and node.flow_style and node.start_mark.line == node.end_mark.line:
            # a group written as YAML reads it, [sonar4, sonar5]: its text is the group's expression,
            # the file's characters as they are (no quote to skip: a nested [sonar5] keeps its place)
            node = ScalarNode("tag:yaml.org,2002:str", self.doc.text[node.start_mark.index:node.end_mark.index],
                              node.start_mark, node.end_mark)
        elif isinstance(node, SequenceNode):
            self.error(node, f"{what} is a group: write it on one line, as in [sonar4, sonar5], or as a range, "
                             "as in sonar1..sonar8")
            return None
        if not isinstance(node, ScalarNode) or node.tag.endswith(":null"):
            self.error(node, f"{what} must be an expression written as text, not a {shape_of(node)}",
                       notes=_mapping_hint(node))
            return None
        text = self.doc.text_of(node)
        try:
            return Parsed(parse_expr(text.value, self.robot_names), text)
        except ParseError as e:
            self.error(text.at((e.start, e.end)), e.message, e.notes)
            return None

    def mapping(self, node: Node, what: str) -> list[tuple[ScalarNode, Node]]:
        """The entries of a mapping; none for an empty value."""
        if isinstance(node, ScalarNode) and node.tag.endswith(":null"):
            return []
        if not isinstance(node, MappingNode):
            self.error(node, f"{what} must be a mapping of names to values, not a {shape_of(node)}")
            return []
        return list(node.value)

    def known_keys(self, node: Node, allowed: tuple[str, ...], kind: str, what: str,
                   more: str = "") -> dict[str, Node]:
        """The values of a mapping's known keys; each unknown key is reported with the known ones
        listed (``kind``: 'robot' for "unknown robot key", '' for the file's own keys)."""
        fields = {}
        for key, value in self.mapping(node, what):
            if key.value not in allowed:
                self.error(key, f"unknown {kind + ' ' if kind else ''}key '{key.value}'"
                                f"{did_you_mean(key.value, allowed)}",
                           notes=(f"{kind or 'known'} keys: " + ", ".join(allowed) + more,))
            else:
                fields[key.value] = value
        return fields

    def identifier(self, key: ScalarNode, what: str) -> str | None:
        """A key that names something programs refer to."""
        name = key.value
        if not name.isidentifier() or not name.isascii():
            self.error(key, f"'{name}' is not a valid {what} name: use letters, digits and '_', "
                            "starting with a letter")
            return None
        return str(name)

    # -- robots ---------------------------------------------------------------------------------

    def robots(self, node: Node, version: float = FORMAT_VERSION) -> list[RobotDecl]:
        out = []
        entries = self.mapping(node, "robots")
        if not entries and isinstance(node, (ScalarNode, MappingNode)):
            self.error(node, "'robots' names no robot", notes=("e.g. robots: {pioneer: {model: pioneer_p3dx}}",))
        for key, value in entries:
            name = self.identifier(key, "robot")
            if name is None:
                self.robots_failed = True
                continue
            if version >= 1.3 and name in KEYWORDS:  # it could not be read: 'and.x' is no expression
                self.error(key, f"robot '{name}' is a keyword of the language, and a robot is read by its name "
                           f"({name}.x) in format 1.3; choose another name",
                           notes=("the language's reserved words: " + ", ".join(sorted(KEYWORDS)),))
            fields = self.known_keys(value, ROBOT_KEYS, "robot", f"robot '{name}'")
            if "model" not in fields:
                self.error(key, f"robot '{name}' needs a 'model:' (e.g. model: pioneer_p3dx)")
                self.robots_failed = True
                continue
            model = self.string(fields["model"], "model") or ""
            count = 1
            if "count" in fields:
                c = self.number(fields["count"], "count", integer=True)
                if c is not None and not 1 <= c <= 100:
                    self.error(fields["count"], f"count must be between 1 and 100, not {c:g}")
                elif c is not None:
                    count = int(c)
            at = self.placement(fields.get("at"), name, count, version)
            camera = self.camera(fields["camera"]) if "camera" in fields else None
            if "camera" in fields and camera is None:
                self.failed_names.add("camera")
            lidar = read_lidar(self, fields["lidar"], name) if "lidar" in fields else None
            if "lidar" in fields and lidar is None:  # reported: its beams' uses stay quiet
                self.failed_names.update(beam_names(MAX_BEAMS))
            paths = self.paths(fields["paths"]) if "paths" in fields else ()
            own = self.robot_params(fields["params"], name, count) if "params" in fields else ()
            noise = (read_noise(self, fields["noise"], name, "camera" in fields, names=version >= 1.2)
                     if "noise" in fields else None)
            if at is None:
                self.robots_failed = True
            else:
                out.append(RobotDecl(name, model, count, at, key, fields["model"], camera, fields.get("at"), paths,
                                     own, noise, lidar))
        return out

    def robot_params(self, node: Node, robot: str, count: int
                     ) -> tuple[tuple[str, tuple[float | bool, ...], Node], ...]:
        """A group's own parameters: ``NAME: value`` for every member, or ``NAME: [v0, v1, ...]``, one each."""
        out = []
        for key, value in self.mapping(node, f"params of robot '{robot}'"):
            name = self.identifier(key, "parameter")
            if name is None:
                continue
            items = value.value if isinstance(value, SequenceNode) else [value]
            nested = next((item for item in items if isinstance(item, SequenceNode)), None)
            if nested is not None:  # a list for each robot: a list parameter's rows are the way (format 1.3)
                self.error(nested, f"robot '{robot}' gives '{name}' a list: a robot's own value is a number or "
                                   "true/false", notes=(f"for a list per robot, give the file a list parameter of rows "
                                                        f"and pick each robot's with {name}[index] (format 1.3)",))
                continue
            if isinstance(value, SequenceNode) and len(items) != count:
                self.error(value, f"robot '{robot}' has {count} member{'s' if count != 1 else ''}, so "
                           f"'{name}' needs {count} value{'s' if count != 1 else ''} (or one for all), "
                           f"not {len(items)}")
                continue
            values = []
            for item in items:
                v = scalar_value(item) if isinstance(item, ScalarNode) else None
                if isinstance(v, bool) or (isinstance(v, (int, float)) and math.isfinite(v)):
                    values.append(v if isinstance(v, bool) else float(v))
                else:
                    self.error(item, f"parameter '{name}' of robot '{robot}' must be a number or true/false")
            if len(values) == len(items):
                out.append((name, tuple(values) * (count if len(values) == 1 else 1), key))
        return tuple(out)

    def paths(self, node: Node) -> tuple[tuple[str, str], ...]:
        """paths: {robot: "/MyPioneer[{i}]", left_motor: ./leftMotor, sonar: "./sonar[{k}]", camera: ./cam}"""
        out = []
        fields = self.known_keys(node, PATH_KEYS, "path", "paths",
                                 " ({i} is the robot's index among all robots, from 0; {k} the sonar's, from 0)")
        for key, value in fields.items():
            text = self.string(value, key)
            if text is None:
                continue
            wrong = object_paths.problem(key, text)  # templates, never str.format: object_paths
            if wrong is not None and isinstance(value, ScalarNode):
                at = wrong[0]
                self.error(self.doc.text_of(value).at((at, min(at + 1, len(text)) or 1)), wrong[1])
            elif wrong is not None:
                self.error(value, wrong[1])
            else:
                out.append((key, text))
        return tuple(out)

    def camera(self, node: Node) -> Camera | None:
        """camera: {resolution: [w, h], fov_deg: 60, height_m: 0.3, pitch_deg: 45, x_m: 0.2, roll_deg: 0}"""
        fields = self.known_keys(node, CAMERA_KEYS, "camera", "camera")
        ok = True
        size = (128, 128)
        if "resolution" in fields:
            resolution = self.resolution(fields["resolution"])
            ok = resolution is not None
            size = resolution or size
        values = {"fov_deg": 60.0, "height_m": 0.3, "pitch_deg": 45.0, "x_m": 0.2, "roll_deg": 0.0}
        limits = {"fov_deg": (1, 170), "height_m": (0.01, 10), "pitch_deg": (0, 90), "x_m": (-1, 1),
                  "roll_deg": (-180, 180)}
        for key in values:
            if key in fields:
                v = self.number(fields[key], key)
                lo, hi = limits[key]
                if v is None:
                    ok = False
                elif not lo <= v <= hi:
                    self.error(fields[key], f"{key} must be between {lo:g} and {hi:g}, not {v:g}")
                    ok = False
                else:
                    values[key] = v
        if not ok:
            return None
        return Camera("camera", size[0], size[1], values["fov_deg"], values["height_m"], values["pitch_deg"],
                      values["x_m"], values["roll_deg"])

    def resolution(self, node: Node) -> tuple[int, int] | None:
        """A camera's [width, height] in pixels."""
        values = node.value if isinstance(node, SequenceNode) else []
        if len(values) != 2:
            self.error(node, "resolution is [width, height] in pixels")
            return None
        width, height = (self.number(v, "a resolution", integer=True) for v in values)
        if width is None or height is None:
            return None
        if not (1 <= width <= MAX_CAMERA_PX and 1 <= height <= MAX_CAMERA_PX):
            self.error(node, f"camera resolution must be 1 to {MAX_CAMERA_PX} pixels a side, "
                             f"not {width:g} x {height:g}")
            return None
        return (int(width), int(height))

    def placement(self, node: Node | None, robot: str = "", count: int = 1, version: float = FORMAT_VERSION
                  ) -> str | Pose | tuple[Pose, ...] | None:
        if isinstance(node, SequenceNode) and ((node.value and isinstance(node.value[0], SequenceNode))
                                               or (not node.value and version >= 1.3)):  # [] is a list of no poses
            return self.poses(node, robot, count, version)
        return self.one_placement(node)

    def poses(self, node: SequenceNode, robot: str, count: int, version: float) -> tuple[Pose, ...] | None:
        """``at: [[x, y, heading_deg], ...]`` (format 1.3): one pose per member of the group."""
        if version < 1.3:
            self.error(node, later_format("a list of start poses, one per robot,", 1.3))
            return None
        many = "s" if count != 1 else ""
        if len(node.value) != count:
            self.error(node, f"robot '{robot}' has {count} member{many}, so 'at' needs {count} pose{many}, one each, "
                             f"not {len(node.value)}",
                       notes=(f"give one [x, y, heading_deg] per robot, or set 'count: {len(node.value)}'",)
                       if node.value else ("give one [x, y, heading_deg] per robot, as in at: [[-3, -3, 0], "
                                           "[0, -3, 90]]",))
            return None
        out: list[Pose] = []
        for item in node.value:
            if not isinstance(item, SequenceNode) or len(item.value) not in (2, 3) or any(
                    not isinstance(v, ScalarNode) for v in item.value):
                self.error(item, "each start pose of a list is [x, y] or [x, y, heading_deg]",
                           notes=("e.g. at: [[-3, -3, 0], [0, -3, 90], [3, -3, 180]]",))
                continue
            pose = self.one_placement(item)
            if isinstance(pose, tuple):
                out.append(pose)
        return tuple(out) if len(out) == count else None

    def one_placement(self, node: Node | None) -> str | Pose | None:
        if node is None:
            return "spawn"
        if isinstance(node, ScalarNode):
            if node.value in ("spawn", "random"):
                return str(node.value)
            self.error(node, f"'at' is 'spawn', 'random' or [x, y, heading_deg], not '{node.value}'")
            return None
        if isinstance(node, SequenceNode) and len(node.value) in (2, 3):
            nums = [self.number(n, "a coordinate") for n in node.value]
            coordinates = [n for n in nums if n is not None]
            if len(coordinates) != len(nums):
                return None
            x, y, *h = coordinates
            if abs(x) > MAX_COORD_M or abs(y) > MAX_COORD_M:
                self.error(node, f"a start pose must lie within +-{MAX_COORD_M:g} m of the origin")
                return None
            return (x, y, h[0] if h else 0.0)
        self.error(node, "'at' is 'spawn', 'random' or [x, y, heading_deg]")
        return None

    # -- values and signals ---------------------------------------------------------------------

    def params(self, node: Node, version: float = FORMAT_VERSION,
               lists: dict[str, tuple[ListValue, Node]] | None = None) -> dict[str, tuple[float | bool, Node]]:
        """The file's parameters: numbers and booleans, and (format 1.3, into ``lists``) lists."""
        out: dict[str, tuple[float | bool, Node]] = {}
        for key, value in self.mapping(node, "params"):
            name = self.identifier(key, "parameter")
            if isinstance(value, SequenceNode) and version >= 1.3 and lists is not None:
                listed = list_value(value, key.value, self.error)
                if name is not None and listed is not None:
                    lists[name] = (listed, value)
                elif name is not None:
                    self.failed_names.add(name)  # reported: its uses stay quiet
                continue
            if isinstance(value, SequenceNode):
                self.error(value, later_format("a list parameter", 1.3))
                if name is not None:
                    self.failed_names.add(name)  # reported: its uses stay quiet
                continue
            scalar = self.scalar(value, f"parameter '{key.value}'")
            if name is None:
                continue
            v = scalar_value(scalar) if scalar is not None else None
            if isinstance(v, float) and not math.isfinite(v):
                self.error(value, f"parameter '{name}' must be a finite number, not '{value.value}'")
                self.failed_names.add(name)  # reported: its uses stay quiet
            elif isinstance(v, (int, float)):
                out[name] = (v if isinstance(v, bool) else float(v), value)  # floats: see check.params
            elif scalar is not None:
                self.error(value, f"parameter '{name}' must be a number or true/false, not '{value.value}'",
                           notes=("computed values belong under 'let:'",))
                self.failed_names.add(name)
        return out

    def named_exprs(self, node: Node, what: str) -> list[tuple[str, Parsed, Node]]:
        out: list[tuple[str, Parsed, Node]] = []
        for key, value in self.mapping(node, what):
            name = self.identifier(key, "signal")
            parsed = self.expr(value, f"'{key.value}'")
            if name is not None and parsed is not None:
                out.append((name, parsed, key))
        return out

    def metrics(self, node: Node) -> list[MetricDecl]:
        """Each metric, in the plain form or as ``{value: ..., better: higher | lower}``."""
        out = []
        for key, value in self.mapping(node, "metrics"):
            name = self.identifier(key, "metric")
            better: Better | None = None
            # A mapping none of whose keys is a name is an expression YAML split at ': ' (expr's hint)
            if isinstance(value, MappingNode) and any(str(k.value).isidentifier() for k, _ in value.value):
                fields = self.known_keys(value, METRIC_KEYS, "metric", f"metric '{key.value}'")
                if "better" in fields:
                    better = self.better(fields["better"], key.value)
                if "value" not in fields:
                    if set(fields) == {str(k.value) for k, _ in value.value}:  # else a misspelt key said it
                        self.error(key, f"metric '{key.value}' needs 'value:', the aggregate over the run",
                                   notes=(f'e.g. {key.value}: {{value: "duration(state == follow)", '
                                          'better: higher}',))
                    continue
                value = fields["value"]
            parsed = self.expr(value, f"'{key.value}'")
            if name is not None and parsed is not None:
                out.append(MetricDecl(name, parsed, key, better))
        return out

    def better(self, node: Node, metric: str) -> Better | None:
        """``better: higher`` or ``better: lower``; anything else is reported, with the word meant."""
        word = scalar_value(node) if isinstance(node, ScalarNode) else None
        choices = tuple(b.value for b in Better)
        if isinstance(word, str) and word in choices:
            return Better(word)
        if isinstance(node, ScalarNode) and node.tag.endswith(":null"):
            self.error(node, f"'better' of metric '{metric}' is empty: write higher or lower")
            return None
        if isinstance(word, str):
            meant = _BETTER_MEANT.get(word.lower())
            shown = f"'{word}'{f' (did you mean {meant!r}?)' if meant else did_you_mean(word, choices)}"
        else:
            shown = f"'{node.value}'" if isinstance(node, ScalarNode) else f"a {shape_of(node)}"
        self.error(node, f"'better' of metric '{metric}' is higher or lower, not {shown}")
        return None

    def functions(self, node: Node) -> list[FunctionDecl]:
        """``NAME(a, b): expression``: each key a name with its parameters, each value the body."""
        out = []
        for key, value in self.mapping(node, "functions"):
            m = _SIGNATURE.fullmatch(key.value)
            if m is None:
                self.error(key, f"a function is written 'name(a, b): expression', not '{key.value}'",
                           notes=("e.g. functions: {steer(offset, gain): clamp(gain * offset, -2, 2)}",))
                continue
            params = tuple(p.strip() for p in m.group(2).split(",")) if m.group(2).strip() else ()
            text = self.doc.text_of(key)
            spans = []
            at = m.start(2)
            for p in m.group(2).split(",") if params else ():
                start = at + len(p) - len(p.lstrip())
                spans.append((start, start + len(p.strip())))
                at += len(p) + 1
            bad = [(p, sp) for p, sp in zip(params, spans) if not p.isidentifier() or not p.isascii()]
            if bad:
                self.error(text.at(bad[0][1]), f"'{bad[0][0]}' is not a valid parameter name: use letters, digits "
                           "and '_', starting with a letter")
                self.failed_names.add(m.group(1))  # reported here: its calls stay quiet
                continue
            twice = [k for k, p in enumerate(params) if p in params[:k]]
            if twice:
                self.error(text.at(spans[twice[0]]), f"function '{m.group(1)}' names its parameter "
                           f"'{params[twice[0]]}' twice")
                self.failed_names.add(m.group(1))
                continue
            body = self.expr(value, f"the body of '{m.group(1)}'")
            if body is not None:
                out.append(FunctionDecl(m.group(1), params, body, key, tuple(spans)))
            else:
                self.failed_names.add(m.group(1))
        return out

    # -- a mechanism's controls ----------------------------------------------------------------

    def sliders(self, node: Node, version: float = FORMAT_VERSION) -> list[SliderDecl]:
        out = []
        for key, value in self.mapping(node, "sliders"):
            name = self.identifier(key, "slider")
            fields = self.known_keys(value, SLIDER_KEYS, "slider", f"slider '{key.value}'")
            if name is None or "min" not in fields or "max" not in fields:
                if name is not None:
                    self.error(key, f"slider '{name}' needs 'min:' and 'max:'")
                continue
            lo, hi = self.number(fields["min"], "min"), self.number(fields["max"], "max")
            if lo is None or hi is None:
                continue
            if lo >= hi:
                self.error(fields["max"], f"a slider's max must exceed its min ({lo:g})")
                continue
            start = 0.0 if lo <= 0 <= hi else lo
            if "value" in fields:
                v = self.number(fields["value"], "value")
                if v is not None and not lo <= v <= hi:
                    self.error(fields["value"], f"value {v:g} is outside the slider's range {lo:g} .. {hi:g}")
                elif v is not None:
                    start = v
            label = self.label(fields["label"], name or "") if "label" in fields else None
            out.append(SliderDecl(name, lo, hi, start, label, key, self.label_name(fields, version)))
        return out

    def label_name(self, fields: dict[str, Node], version: float) -> Node | None:
        """``label_name: speed`` (format 1.2): the label this slider's text goes into; sliders that
        name the same label share it, and it shows the text of the one moved last."""
        node = fields.get("label_name")
        if node is None:
            return None
        if version < 1.2:
            self.error(node, later_format("'label_name'", 1.2))
        elif "label" not in fields:
            self.error(node, "'label_name' says where the slider's label goes: give the slider a 'label:'")
        elif not isinstance(node, ScalarNode) or not str(node.value).isidentifier() or not str(node.value).isascii():
            self.error(node, "a label's name uses letters, digits and '_', starting with a letter",
                       notes=("e.g. label_name: speed",))
        else:
            return node
        return None

    def label(self, node: Node, slider: str = "") -> Label | None:
        """'Arm Speed: {0.02 * arm:.2f}': text, and {expression:format} fields; or 'Arm Speed: %.2f'."""
        if not isinstance(node, ScalarNode):
            self.error(node, "a label is text, with {expression} or {expression:.2f} fields")
            return None
        text = self.doc.text_of(node)
        try:
            parts = parse_printf(text.value, slider) or parse_label(text.value, self.robot_names)
        except ParseError as e:
            self.error(text.at((e.start, e.end)), e.message)
            return None
        return Label(tuple(part if isinstance(part, str) else (Parsed(part[0], text), part[1]) for part in parts))

    def binds(self, node: Node) -> list[BindDecl]:
        out = []
        for key, value in self.mapping(node, "bind"):
            joint, dot, mode = key.value.partition(".")
            if not dot or mode not in ("velocity", "position") or not joint.isidentifier():
                self.error(key, f"a binding is JOINT.velocity or JOINT.position, not '{key.value}'",
                           notes=("e.g. Arm_Actuator.velocity: 0.02 * arm",))
                continue
            parsed = self.expr(value, f"'{key.value}'")
            if parsed is not None:
                out.append(BindDecl(joint, mode, parsed, key))
        return out

    def timeline(self, node: Node) -> list[Event]:
        """- at 2.5: arm = 0, crab = -3"""
        if not isinstance(node, SequenceNode):
            self.error(node, "'timeline' is a list of entries such as '- at 2: arm = 5, crab = -3'")
            return []
        out = []
        for item in node.value:
            if not (isinstance(item, MappingNode) and len(item.value) == 1):
                self.error(item, "a timeline entry reads 'at TIME: slider = value, ...'",
                           notes=("e.g. - at 2: arm = 0, crab = -3",))
                continue
            key, value = item.value[0]
            m = _AT.fullmatch(key.value.strip())
            if not m:
                self.error(key, f"a timeline entry starts with 'at' and a time in seconds, not '{key.value}'")
                continue
            if not _fits(m.group(1)):
                self.error(key, TOO_LARGE)
                continue
            if not isinstance(value, ScalarNode) or not value.value.strip():
                self.error(value, "after 'at TIME:' come slider settings such as 'arm = 5, crab = -3'")
                continue
            text = self.doc.text_of(value)
            out.append(Event(float(m.group(1)), self.settings(text), item, text))
        return out

    def settings(self, text: Text) -> tuple[tuple[str, float, int], ...]:
        """'arm = 0, crab = -3': (slider, value, offset of the setting in the text); each
        setting that is not 'slider = number' is reported and left out."""
        settings = []
        offset = 0
        for piece in text.value.split(","):
            sm = _SETTING.fullmatch(piece)
            start = offset + len(piece) - len(piece.lstrip())
            offset += len(piece) + 1
            number = None
            if sm:
                try:
                    number = to_float(sm.group(2))
                except NumberError as e:
                    if str(e).startswith(TOO_LARGE):
                        self.error(text.at((start, start + len(piece.strip()))), str(e))
                        continue
            if sm is None or number is None:
                self.error(text.at((start, start + len(piece.strip()))),
                           f"a setting reads 'slider = number', not '{piece.strip()}'")
                continue
            settings.append((sm.group(1), number, start))
        return tuple(settings)

    # -- rules ----------------------------------------------------------------------------------

    def states(self, node: Node) -> dict[str, tuple[list[RuleDecl], Node | None]]:
        if isinstance(node, SequenceNode):
            return {"main": (self.rule_list(node, "main"), None)}
        if isinstance(node, MappingNode):
            out: dict[str, tuple[list[RuleDecl], Node | None]] = {}
            for key, value in node.value:
                name = self.identifier(key, "state")
                if name is None:
                    continue
                if not isinstance(value, SequenceNode):
                    self.error(value, f"state '{name}' must hold a list of rules (lines starting with '- ')")
                    continue
                out[name] = (self.rule_list(value, name), key)
            if not out and not node.value:
                self.error(node, "'rules' is empty")
            return out
        self.error(node, "'rules' must be a list of rules, or a mapping from state names to lists of rules",
                   notes=("e.g. rules:\n          - if sonar5 <= 0.5 then arc(-2, 2)\n          - else move(2)",))
        return {}

    def rule_list(self, node: SequenceNode, state: str) -> list[RuleDecl]:
        out = []
        if not node.value:
            self.error(node, f"state '{state}' has no rules" if state != "main" else "'rules' is empty")
        for i, item in enumerate(node.value, 1):
            if not isinstance(item, ScalarNode) or item.tag.endswith(":null"):
                self.error(item, f"a rule must be text such as 'if COND then ACTION', not a {shape_of(item)}",
                           notes=_mapping_hint(item))
                continue
            text = self.doc.text_of(item)
            try:
                out.append(RuleDecl(state, i, parse_rule(text.value, self.robot_names), text))
            except ParseError as e:
                notes = e.notes
                if text.spans_lines:
                    second = item.start_mark.line + 2
                    notes += (f"hint: YAML joined line {second} onto this rule; if line {second} is a "
                              "rule of its own, indent its '-' like the one above",)
                self.error(text.at((e.start, e.end)), e.message, notes)
        return out


# one way to read each number: "[0-9]*\.?[0-9]+" split a long run of digits every way and took
# minutes on a timeline key of 100,000 digits
_AT = re.compile(r"at\s+((?:[0-9]+(?:\.[0-9]+)?|\.[0-9]+)(?:[eE][+-]?\d+)?)\s*$")
_SIGNATURE = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*\(([^()]*)\)\s*")
_SETTING = re.compile(r"\s*([A-Za-z_][A-Za-z0-9_]*)\s*=\s*(\S+?)\s*$")


def _fits(text: str) -> bool:
    try:
        to_float(text)
    except NumberError:
        return False
    return True


def _mapping_hint(node: Node | None) -> tuple[str, ...]:
    if isinstance(node, MappingNode) and node.value:
        key = node.value[0][0]
        if isinstance(key, ScalarNode):
            return (f"hint: YAML read '{key.value}: ...' as a mapping because of the ': '; "
                    "remove the colon (a rule reads 'if COND then ACTION'), or quote the whole text",)
    return ()
