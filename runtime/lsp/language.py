"""The server's one door into the language, the scene's readers and their tables.

Everything ``labsim lsp`` knows of behaviour and world files comes through here: the checker
(``check_behaviour`` is ``labsim check``'s compile, on the editor's unsaved text), the world
file reader, the JSON Schemas (the keys to complete), the built-in functions, actions and
variables, and the robot models' sensors. Keeping these imports in one module keeps the rest of
the server independent of how the language's modules are laid out.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from labsim.backends.scene.models import MODELS, Kind, RobotModel
from labsim.backends.scene.schema import world_schema
from labsim.backends.scene.world_file import _declares_world, _WorldReader
from labsim.backends.scene.world_names import builtin_worlds
from labsim.dsl.compile import compile_file
from labsim.dsl.library.builtins import (
    ACTIONS,
    AGGREGATES,
    CONSTANTS,
    FUNCTIONS,
    KEYWORDS,
    READ_BACK,
    REDUCTIONS,
    VARIABLES,
    Type,
)
from labsim.dsl.syntax.lidar import LIDAR_LIMITS
from labsim.dsl.syntax.schema import behaviour_schema
from labsim.foundation.diagnostics import Diagnostic, LabsimError, Report
from labsim.foundation.limits import DEFAULT_BUDGETS
from labsim.foundation.source import loads

Checker = Callable[[str, str], list[Diagnostic]]  # (path, unsaved text) -> what `labsim check` says


def check_behaviour(path: str, text: str) -> list[Diagnostic]:
    """Exactly ``labsim check``'s diagnostics for a behaviour file holding ``text``: its errors,
    else its warnings; its world found from the file's folder, as check finds it."""
    try:
        program = compile_file(path, budgets=DEFAULT_BUDGETS, text=text)
    except LabsimError as e:
        return list(e.diagnostics)
    return list(program.warnings)


def check_world(path: str, text: str) -> list[Diagnostic]:
    """The world file reader's diagnostics for ``text`` (what a behaviour naming it would get)."""
    report = Report()
    try:
        doc = loads(text, path)
    except LabsimError as e:
        return list(e.diagnostics)
    if not _declares_world(doc):
        return [Diagnostic(path, "not a labsim world file (it has no 'labsim-world: 1' line)")]
    _WorldReader(doc, report).read()
    return sorted(report.diagnostics, key=lambda d: (d.path, d.line, d.col))  # as a LabsimError lists them


def behaviour_keys() -> dict[str, Any]:
    return behaviour_schema()


def world_keys() -> dict[str, Any]:
    return world_schema()


def world_names() -> list[str]:
    """The built-in worlds, by the name a behaviour's ``world:`` gives."""
    return sorted(builtin_worlds())


def model_names() -> list[str]:
    return sorted(MODELS)


# -- the names every expression may use -----------------------------------------------------------

@dataclass(frozen=True)
class Builtin:
    """A built-in name as completion and hover show it."""

    name: str
    kind: str  # "function", "action", "variable", "constant", "keyword", "aggregate"
    signature: str
    doc: str


def _function_signature(name: str) -> str:
    f = FUNCTIONS.get(name)
    if f is None:
        r = REDUCTIONS[name]
        return f"{name}({r.takes}) -> {r.returns}"
    args = list(f.names) if f.names else [str(t) for t in f.params]
    if f.optional:
        args[-f.optional:] = [f"[{a}]" for a in args[-f.optional:]]
    if f.variadic:
        args.append("...")
    return f"{name}({', '.join(args)}) -> {f.returns}"


def builtins() -> dict[str, Builtin]:
    """Every built-in name: functions (with their signatures), actions, variables, constants,
    metric aggregates and keywords."""
    out: dict[str, Builtin] = {}
    for name in REDUCTIONS:
        out[name] = Builtin(name, "function", _function_signature(name), REDUCTIONS[name].doc)
    for name, f in FUNCTIONS.items():
        doc = f.doc if name not in REDUCTIONS else f"{f.doc}; of a group: {REDUCTIONS[name].doc}"
        if f.params and all(p in (Type.NUMBER, Type.BOOL) for p in f.params):
            doc += "; given groups where it takes values, member by member (format 1.3)"
        out[name] = Builtin(name, "function", _function_signature(name), doc)
    out["detected"] = Builtin("detected", "function", "detected(sensor) -> boolean",
                              "true when the distance sensor named sees something (reads less than inf)")
    for name, a in ACTIONS.items():
        out[name] = Builtin(name, "action", f"{name}({', '.join(a.params)})", a.doc)
    # format 1.3: messages between robots (docs/language.md, "Other robots and messages")
    out["say"] = Builtin("say", "action", "say(channel, value[, range_m])",
                         "send a number on a channel: every other robot (within range_m metres) hears it after the "
                         "tick; the nearest of several")
    out["heard"] = Builtin("heard", "function", "heard(channel[, default]) -> number",
                           "the last value this robot heard on a channel, from the tick after it was said; "
                           "default (0) until it hears one")
    variable_docs = {"time": "simulated seconds since the start", "tick": "ticks since the start, from 0",
                     "dt": "seconds per tick", "state": "the rule state the robot is in",
                     "state_time": "seconds since the robot entered its state",
                     "entered": "true on the first tick in a state", "index": "the robot's number in its group, from 0"}
    for name, t in VARIABLES.items():
        out[name] = Builtin(name, "variable", f"{name}: {t}", variable_docs.get(name, ""))
    read_back = {"wheel_left": "the left wheel's command of the last tick, rad/s, as sent (clamped to the model's "
                               "limit; 0 on the first tick; format 1.3)",
                 "wheel_right": "the right wheel's command of the last tick, rad/s, as sent (clamped to the "
                                "model's limit; 0 on the first tick; format 1.3)",
                 "start_x": "where the robot started: x in metres (format 1.3)",
                 "start_y": "where the robot started: y in metres (format 1.3)",
                 "start_heading": "the robot's heading at the start, radians in (-pi, pi] (format 1.3)"}
    for name, t in READ_BACK.items():
        out[name] = Builtin(name, "variable", f"{name}: {t}", read_back[name])
    out["len"] = Builtin("len", "function", "len(list) -> number",
                         "how many rows a list parameter has, or members a group (format 1.3)")
    for name, value in CONSTANTS.items():
        out[name] = Builtin(name, "constant", f"{name} = {value:g}",
                            "infinity: what a distance sensor reads when it sees nothing" if math.isinf(value)
                            else "the ratio of a circle's circumference to its diameter")
    for name, agg in AGGREGATES.items():
        out.setdefault(name, Builtin(name, "aggregate", f"{name}({agg.argument})",
                                     f"a metric's aggregate: {name} over the run"))
    for word in sorted(KEYWORDS):
        out.setdefault(word, Builtin(word, "keyword", word, "a keyword of the rule language"))
    return out


# -- sensors ---------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Sensor:
    name: str
    doc: str  # what it reads: units, range, what it reads when it sees nothing


def sensors(model_name: str, lidar: dict[str, float] | None = None) -> list[Sensor]:
    """The channels a robot of this model reads, in the model's order, each with what it reads;
    ``lidar`` the robot's ``lidar:`` settings when it has one (defaults filled in)."""
    model = MODELS.get(model_name)
    if model is None:
        return []
    out = [Sensor(s.name, _ray_doc(model, s.name, s.range_m, math.degrees(s.angle_rad), s.cone_deg))
           for s in model.sonars]
    if lidar is not None:
        settings = {key: limits[2] for key, limits in LIDAR_LIMITS.items()} | lidar
        beams = max(1, min(int(settings["beams"]), int(LIDAR_LIMITS["beams"][1])))
        fov, reach = settings["fov_deg"], settings["range_m"]
        step = fov / (beams if fov >= 360 or beams == 1 else beams - 1)
        start = 0.0 if beams == 1 and fov < 360 else -fov / 2
        out += [Sensor(f"lidar{k + 1}", f"lidar beam {k + 1} of {beams}, pointing {start + k * step:g}° "
                       f"(counter-clockwise from ahead): the distance in metres to the nearest thing it meets, "
                       f"0 to {reach:g} m; `inf` when nothing is seen within {reach:g} m") for k in range(beams)]
    for name, kind in _other_channels(model).items():
        out.append(Sensor(name, _CHANNEL_DOCS.get(kind, kind.value) if name not in _POSE_DOCS else _POSE_DOCS[name]))
    return out


def _ray_doc(model: RobotModel, name: str, range_m: float, angle_deg: float, cone_deg: float) -> str:
    what = "IR proximity sensor" if name.startswith("prox") else "sonar"
    cone = f", a {cone_deg:g}° cone" if cone_deg else ""
    return (f"{model.name} {what} `{name}`, pointing {angle_deg:+.0f}° (counter-clockwise from ahead{cone}): "
            f"the distance in metres to the nearest thing it sees, 0 to {range_m:g} m; "
            f"`inf` when nothing is seen within {range_m:g} m (test it with detected({name}))")


def _other_channels(model: RobotModel) -> dict[str, Kind]:
    rays = {s.name for s in model.rays()}
    return {name: kind for name, kind in model.channels().items() if name not in rays}


_CHANNEL_DOCS = {
    Kind.IMAGE: "camera image (RGB, row 0 at the bottom): for image functions such as threshold, area, centroid",
    Kind.CONTACT: "bumper: true while this part of the chassis touches something",
    Kind.REFLECTANCE: "ground sensor: the floor's brightness under it, 0 (black) to 1 (white), no unit",
    Kind.NUMBER: "a number", Kind.BOOL: "true or false",
}
_POSE_DOCS = {"x": "the robot's x position in metres (world frame)", "y": "the robot's y position in metres",
              "heading": "the robot's heading in radians, counter-clockwise from the x axis",
              "forward_speed": "the robot's speed along its heading, m/s",
              "collided": "true while the robot touches something"}


def lidar_keys() -> tuple[str, ...]:
    return tuple(LIDAR_LIMITS)


def is_behaviour_path(path: str | Path) -> bool:
    return Path(path).suffix in (".yaml", ".yml")
