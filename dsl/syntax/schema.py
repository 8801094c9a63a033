"""The JSON Schema of a behaviour file, built from the key tables of ``labsim.dsl.syntax.read``.

The language's half of the schemas (the world file's is ``labsim.backends.scene.schema``, whose
builders this uses): every mapping here is made from the reader's own tuple of keys
(``TOP_KEYS``, ``ROBOT_KEYS``, ``CAMERA_KEYS``, ...), and building fails when a key lacks a
description or a description names no key, so the schema and the reader cannot drift. Rule and
expression strings are only "text" here: whether they parse, and which names (sensors, models,
worlds, functions) exist, is the checker's business (``labsim check``).
"""
from __future__ import annotations

from labsim.backends.scene.schema import IDENTIFIER, Schema, document, mapping, named, number, numbers, text
from labsim.dsl.library.builtins import Better
from labsim.dsl.syntax.lidar import LIDAR_KEYS, LIDAR_LIMITS
from labsim.dsl.syntax.noise import CAMERA_NOISE_KEYS, LIMITS, NOISE_KEYS, SONAR_NOISE_KEYS, WHEEL_NOISE_KEYS
from labsim.dsl.syntax.read import (
    CAMERA_KEYS,
    MAX_CAMERA_PX,
    METRIC_KEYS,
    PATH_KEYS,
    REQUIRED,
    ROBOT_KEYS,
    SLIDER_KEYS,
    TOP_KEYS,
)
from labsim.foundation.limits import MAX_DT_S, MIN_DT_S

EXPRESSION: Schema = {"type": ["string", "number", "boolean"]}


def expression(description: str) -> Schema:
    return {**EXPRESSION, "description": description + " (an expression: docs/language.md)"}


def _robot() -> Schema:
    camera = mapping(CAMERA_KEYS, {
        "resolution": numbers(f"[width, height] in pixels, 1 to {MAX_CAMERA_PX} a side (default [128, 128])", 2,
                              {"type": "integer", "minimum": 1, "maximum": MAX_CAMERA_PX}),
        "fov_deg": number("horizontal field of view in degrees (default 60)", 1, 170),
        "height_m": number("the camera's height above the floor in metres (default 0.3)", 0.01, 10),
        "pitch_deg": number("how far it looks down, in degrees (default 45)", 0, 90),
        "x_m": number("how far ahead of the robot's centre it sits, in metres (default 0.2)", -1, 1),
        "roll_deg": number("its turn about its own axis, in degrees; positive turns the image's top edge "
                           "towards the robot's right (default 0)", -180, 180),
    }, "a camera looking ahead and down at the floor")
    paths = mapping(PATH_KEYS, {
        "robot": text("the robot's path in a CoppeliaSim scene, e.g. /PioneerP3DX[{i}]"),
        "left_motor": text("the left motor's path, e.g. ./leftMotor"),
        "right_motor": text("the right motor's path, e.g. ./rightMotor"),
        "sonar": text("the sonar's path, e.g. ./ultrasonicSensor[{k}]"),
        "camera": text("the camera's vision sensor, e.g. ./visionSensor (default: ./visionSensor, "
                       "then ./Vision_sensor)"),
    }, "object paths in your own CoppeliaSim scene ({i}: the robot's index from 0; {k}: the sonar's)")
    at = {"description": "where it starts: spawn (the world's spawn poses), random, [x, y, heading_deg], or "
                         "(format 1.3) one such pose per robot of the group",
          "anyOf": [{"enum": ["spawn", "random"]}, numbers("[x, y] or [x, y, heading_deg]", (2, 3)),
                    {"type": "array", "minItems": 1, "maxItems": 100,
                     "description": "a start pose per robot (format 1.3)",
                     "items": numbers("[x, y] or [x, y, heading_deg]", (2, 3))}]}
    return mapping(ROBOT_KEYS, {
        "model": text("the robot model, e.g. pioneer_p3dx (labsim check knows the models)"),
        "count": number("how many robots of this group (default 1)", 1, 100, integer=True),
        "at": at,
        "camera": camera,
        "lidar": mapping(LIDAR_KEYS, {
            key: number(f"{what} (default {default:g})", lo, hi, integer=key == "beams")
            for key, (lo, hi, default, what) in LIDAR_LIMITS.items()}, "a 2D lidar: beams lidar1 .. lidarN"),
        "paths": paths,
        "noise": _noise(),
        "params": {"type": "object",
                   "description": "this group's own values of the file's parameters (format 1.1): one value for "
                                  "every robot of the group, or a list with one value per robot",
                   "propertyNames": {"pattern": r"^[A-Za-z_][A-Za-z0-9_]*$"},
                   "additionalProperties": {"anyOf": [{"type": ["number", "boolean"]},
                                                      {"type": "array", "minItems": 1,
                                                       "items": {"type": ["number", "boolean"]}}]}},
    }, "a group of robots", required=("model",))


def _noise() -> Schema:
    def value(key: str) -> Schema:
        lo, hi, what = LIMITS[key]
        return {"description": f"{what}; or the name of a parameter of 'params:' (format 1.2)",
                "anyOf": [number(what, lo, hi), {"type": "string", "pattern": IDENTIFIER}]}

    def model(name: str, keys: tuple[str, ...], what: str) -> Schema:
        return mapping(keys, {k: value(f"{name}.{k}") for k in keys}, what)
    return mapping(NOISE_KEYS, {
        "sonar": model("sonar", SONAR_NOISE_KEYS, "sonar noise: Gaussian jitter and dropout"),
        "camera": model("camera", CAMERA_NOISE_KEYS, "camera noise: Gaussian on every pixel (needs a camera)"),
        "wheels": model("wheels", WHEEL_NOISE_KEYS, "wheel noise: Gaussian on the command, and slip"),
    }, "seeded noise the runtime adds to this group's readings and wheel commands (off when absent)")


def _controls() -> dict[str, Schema]:
    slider = mapping(SLIDER_KEYS, {
        "min": number("the slider's lowest value"),
        "max": number("the slider's highest value"),
        "value": number("where it starts (default 0 if within range, else min)"),
        "label": text("its label: text with {expression} or {expression:.2f} fields"),
        "label_name": {"type": "string", "pattern": IDENTIFIER,
                       "description": "format 1.2: the label its text goes into; sliders naming the same "
                                      "label share it, which shows the text of the one moved last"},
    }, "a slider a person moves in labsim view", required=("min", "max"))
    return {
        "sliders": named(slider, "sliders, by name; programs read them by name"),
        "bind": {"type": "object", "description": "JOINT.velocity or JOINT.position: the expression that drives it",
                 "propertyNames": {"pattern": r"^[A-Za-z_][A-Za-z0-9_]*\.(velocity|position)$"},
                 "additionalProperties": expression("the joint's target")},
        "timeline": {"type": "array", "description": "slider moves: '- at 2.5: arm = 0, crab = -3'",
                     "items": {"type": "object", "minProperties": 1, "maxProperties": 1,
                               "propertyNames": {"pattern": r"^at\s+[0-9]*\.?[0-9]+([eE][+-]?\d+)?\s*$"},
                               "additionalProperties": {"type": "string"}}},
    }


def _metric() -> Schema:
    aggregate = "an aggregate over the run, e.g. duration(state == follow)"
    return {"anyOf": [expression(aggregate), mapping(METRIC_KEYS, {
        "value": expression(aggregate),
        "better": {"enum": [b.value for b in Better],
                   "description": "which way is better: a sweep marks the setting with the highest or lowest mean "
                                  "as best (default: lower for count, mean, rms, maximum; higher for minimum, final; "
                                  "none for duration)"},
    }, "a metric and which way it is better", required=("value",))]}


def behaviour_schema() -> Schema:
    """The JSON Schema of a behaviour file."""
    rules = {"type": "array", "minItems": 1, "items": {"type": "string"}}
    return document("labsim behaviour file", mapping(TOP_KEYS, {
        "labsim": {"enum": [1, 1.1, 1.2, 1.3], "description": "the file format version: 'labsim: 1.3' for a new file; "
                                                              "1, 1.1 and 1.2 files keep their meaning"},
        "name": text("the lab's name, shown in summaries"),
        "description": text("what the behaviour does"),
        "world": text("a built-in world (labsim worlds) or the path of a world file"),
        "dt": number("the time step in seconds (default 0.05)", MIN_DT_S, MAX_DT_S),
        "seed": number("the seed of every random choice (default 0)", minimum=0, integer=True),
        "stop": expression("when the run ends, e.g. time >= 60"),
        "robots": named(_robot(), "the robots, by group name"),
        "params": {"type": "object", "description": "parameters, overridable with --set NAME=VALUE",
                   "propertyNames": {"pattern": r"^[A-Za-z_][A-Za-z0-9_]*$"},
                   "additionalProperties": {"anyOf": [
                       {"type": ["number", "boolean"]},
                       {"type": "array", "minItems": 1, "description": "a list (format 1.3): numbers, or rows of "
                                                                       "numbers of one length",
                        "anyOf": [{"items": {"type": "number"}},
                                  {"items": {"type": "array", "minItems": 1, "items": {"type": "number"}}}]}]}},
        "functions": {"type": "object", "description": "functions of your own (format 1.2): 'name(a, b): expression'",
                      "propertyNames": {"pattern": r"^\s*[A-Za-z_][A-Za-z0-9_]*\s*\([^()]*\)\s*$"},
                      "additionalProperties": expression("the function's value, from its parameters")},
        "let": named({"anyOf": [expression("a signal"),
                                {"type": "array", "minItems": 1, "description": "a group of values (format 1.2)",
                                 "items": {"type": ["string", "number", "boolean"]}}]},
                     "signals computed every tick, by name"),
        "rules": {"description": "a list of rules ('if COND then ACTION'), or states mapping to lists of rules",
                  "anyOf": [rules, {"type": "object", "additionalProperties": rules}]},
        "metrics": named(_metric(), "metrics reported at the end of the run, by name"),
        **_controls(),
    }, required=REQUIRED))
