"""JSON Schemas for the files labsim reads, built from the readers' own key tables.

This sits beside the file readers of the scene layer: ``world_schema()`` describes a world file
(``world_file.py``, ``mechanism_file.py``), and the builders here (``mapping``, ``number``, ...)
are what ``labsim.dsl.syntax.schema`` describes a behaviour file with. ``mapping(keys, ...)`` takes a
reader's tuple of known keys and refuses to build unless every one of them has a description
and no other does, so a key added to a reader without one here fails at once (and in
tests/unit/test_schema.py), and the schema cannot drift from what the readers accept. Editors
(yaml-language-server) use the schemas to complete keys, show descriptions and flag wrong keys
and types as one types; ``labsim schema world`` prints this one.

What a schema cannot say: which names exist (robot models, built-in worlds, sensors, joints),
whether a rule or expression string parses and type-checks, and the checks across keys (a
slider's value within its min and max, an arc starting on its circle). ``labsim check`` does.
"""
from __future__ import annotations

from typing import Any

from labsim.backends.scene.mechanism import JOINT_KINDS, SHAPES
from labsim.backends.scene.mechanism_file import BODY_KEYS, JOINT_KEYS, MOTOR_KEYS, SENSOR_KEYS, TARGETS
from labsim.backends.scene.mechanism_file import KEYS as MECHANISM_KEYS
from labsim.backends.scene.world_file import (
    ARC_KEYS,
    BLOCK_KEYS,
    GROUND_KEYS,
    KEYS,
    LINE_KEYS,
    PATCH_KEYS,
    ROAD_KEYS,
    WALL_KEYS,
)
from labsim.foundation.limits import MAX_COORD_M, MAX_RADIUS_M, MAX_SIZE_M, MIN_SIZE_M

Schema = dict[str, Any]
DRAFT = "http://json-schema.org/draft-07/schema#"  # the draft yaml-language-server reads best
IDENTIFIER = r"^[A-Za-z_][A-Za-z0-9_]*$"


class SchemaDrift(Exception):
    """A reader's key table and its schema's descriptions disagree (a labsim bug, not a user's)."""


def mapping(keys: tuple[str, ...], properties: dict[str, Schema], description: str = "",
            required: tuple[str, ...] = ()) -> Schema:
    """An object with exactly a reader's known keys; other keys are errors, as in the reader."""
    missing, extra = set(keys) - set(properties), set(properties) - set(keys)
    if missing or extra:
        raise SchemaDrift(f"keys read but not described: {sorted(missing)}; described but not read: {sorted(extra)}")
    out: Schema = {"type": "object", "properties": {k: properties[k] for k in keys}, "additionalProperties": False}
    if required:
        out["required"] = list(required)
    if description:
        out["description"] = description
    return out


def named(value: Schema, description: str) -> Schema:
    """A mapping from names the file chooses (robots, bodies, sliders) to values of one shape."""
    return {"type": "object", "description": description, "propertyNames": {"pattern": IDENTIFIER},
            "additionalProperties": value}


def number(description: str, minimum: float | None = None, maximum: float | None = None,
           exclusive_minimum: float | None = None, integer: bool = False) -> Schema:
    out: Schema = {"type": "integer" if integer else "number", "description": description}
    for key, value in (("minimum", minimum), ("maximum", maximum), ("exclusiveMinimum", exclusive_minimum)):
        if value is not None:
            out[key] = value
    return out


def text(description: str) -> Schema:
    return {"type": "string", "description": description}


def flag(description: str) -> Schema:
    return {"type": "boolean", "description": description}


def numbers(description: str, count: int | tuple[int, int], item: Schema | None = None) -> Schema:
    lo, hi = (count, count) if isinstance(count, int) else count
    return {"type": "array", "description": description, "items": item or {"type": "number"},
            "minItems": lo, "maxItems": hi}


def one_of(description: str, *choices: str) -> Schema:
    return {"type": "string", "description": description, "enum": list(choices)}


def version(key: str) -> Schema:
    return {"const": 1, "description": f"the file format version: '{key}: 1'"}


def document(title: str, body: Schema) -> Schema:
    return {"$schema": DRAFT, "title": title, **body}


def _point(what: str) -> Schema:
    return numbers(f"{what}: [x, y] in metres", 2, number("metres from the origin", -MAX_COORD_M, MAX_COORD_M))


def _colour(default: str) -> Schema:
    return numbers(f"[red, green, blue], each 0..255 (default {default})", 3,
                   {"type": "number", "minimum": 0, "maximum": 255})


def _ground() -> Schema:
    arc = mapping(ARC_KEYS, {
        "center": _point("the circle's centre"),
        "radius": number("the circle's radius in metres", MIN_SIZE_M, MAX_RADIUS_M),
        "to_deg": number("where the arc ends: degrees counter-clockwise from +x"),
    }, "an arc on from the previous point, around center", required=ARC_KEYS)
    path_item = {"anyOf": [_point("a point"), mapping(("arc",), {"arc": arc}, required=("arc",))]}
    return mapping(GROUND_KEYS, {
        "floor": _colour("[205, 205, 200]"),
        "px_per_m": number("texture resolution in pixels per metre (default 100)", exclusive_minimum=0,
                           maximum=1000),
        "roads": {"type": "array", "description": "roads cameras follow; the first is the one road_offset, on_road "
                                                  "and laps refer to",
                  "items": mapping(ROAD_KEYS, {
                      "width": number("the road's width in metres", exclusive_minimum=0),
                      "color": _colour("[25, 25, 25]"),
                      "closed": flag("the last point joins the first (default false)"),
                      "path": {"type": "array", "description": "the centreline: points [x, y] and arcs "
                                                               "{arc: {center, radius, to_deg}}", "items": path_item},
                  }, "a road", required=("width", "path"))},
        "lines": {"type": "array", "description": "painted lines with square ends", "items": mapping(LINE_KEYS, {
            "from": _point("one end"), "to": _point("the other end"),
            "width": number("metres (default 0.05)", exclusive_minimum=0), "color": _colour("[255, 255, 255]"),
        }, required=("from", "to"))},
        "patches": {"type": "array", "description": "painted boxes", "items": mapping(PATCH_KEYS, {
            "center": _point("the centre"), "size": numbers("[width, depth] in metres", 2),
            "color": _colour("[25, 25, 25]"), "angle_deg": number("rotation in degrees (default 0)"),
        }, required=("center", "size"))},
    }, "what is painted on the floor, for cameras to see")


def _mechanism() -> Schema:
    pair = numbers("[x, z] in metres", 2)
    body = mapping(BODY_KEYS, {
        "shape": one_of("box or an upright cylinder (default box)", *SHAPES),
        "center": numbers("where its centre starts: [x, z] in metres", 2),
        "size": numbers("[width, height] in metres (a cylinder's width is its diameter)", 2),
        "depth": number("its size across the plane, in metres, for its volume (default its width)",
                        exclusive_minimum=0),
        "mass": number("kg (or give density)", exclusive_minimum=0),
        "density": number("kg/m^3 (or give mass)", exclusive_minimum=0),
        "static": flag("fixed to the world (default false)"),
        "angle_deg": number("its rotation at the start, in degrees (default 0)"),
    }, "a rigid body")
    motor = mapping(MOTOR_KEYS, {
        "max_force": number("N (N·m for revolute and slew joints)", exclusive_minimum=0),
        "max_speed": number("m/s (rad/s for revolute and slew joints)", exclusive_minimum=0),
        "max_accel": number("m/s^2 (rad/s^2 for revolute and slew joints)", exclusive_minimum=0),
        "targets": {"type": "array", "description": "what a program may set: velocity, position",
                    "items": {"enum": list(TARGETS)}},
    }, "the joint's motor")
    joint = mapping(JOINT_KEYS, {
        "kind": one_of("what the joint does", *JOINT_KINDS),
        "parent": text("the body it is mounted on"),
        "child": text("the body it moves"),
        "anchor": numbers("where the joint is: pivot, rail origin, rope's top or slew axis; [x, z] in metres", 2),
        "axis": numbers("a prismatic rail's direction of travel: [x, z]", 2),
        "rope": flag("prismatic only: hang the child on a winch rope whose length is the joint's position"),
        "limits": numbers("[low, high] in m, or rad for revolute and slew joints", 2),
        "limits_deg": numbers("[low, high] in degrees, for revolute and slew joints", 2),
        "motor": motor,
    }, "a joint; its name is what programs use", required=("kind", "parent", "child"))
    sensor = mapping(SENSOR_KEYS, {
        "between": numbers("the two bodies the cable joins", 2, {"type": "string"}),
        "anchors": numbers("where it is attached on each: [[x, z], [x, z]]", 2, pair),
    }, "a cable between two bodies that reads its tension", required=SENSOR_KEYS)
    return mapping(MECHANISM_KEYS, {
        "gravity": number("the size of g along -z, m/s^2 (default 9.81)", minimum=0),
        "damping": number("1/s: velocities decay as exp(-damping t) (default 0)", minimum=0),
        "floor": {"type": ["number", "null"], "description": "z of the floor in metres; null for none (default 0)"},
        "bodies": named(body, "the rigid bodies, by name"),
        "joints": named(joint, "the joints, by name"),
        "force_sensors": named(sensor, "force sensors, by name"),
    }, "an articulated mechanism seen from the side (x along the plane, z up)", required=("bodies",))


def world_schema() -> Schema:
    """The JSON Schema of a world file."""
    pose = numbers("[x, y, heading_deg] (heading optional, default 0)", (2, 3))
    return document("labsim world file", mapping(KEYS, {
        "labsim-world": version("labsim-world"),
        "name": text("the world's name (default: the file's name)"),
        "description": text("one line about the world"),
        "bounds": numbers("[xmin, ymin, xmax, ymax] in metres: where robots may be placed", 4),
        "wall_thickness": number("metres (default 0.1)", exclusive_minimum=0),
        "wall_height": number("metres: how high walls stand for cameras (default 0.5)", MIN_SIZE_M, MAX_SIZE_M),
        "walls": {"type": "array", "description": "wall segments", "items": mapping(WALL_KEYS, {
            "from": _point("one end"), "to": _point("the other end"),
            "thickness": number("metres (default wall_thickness)", exclusive_minimum=0),
            "height": number("metres: how high it stands for cameras (default wall_height)", MIN_SIZE_M, MAX_SIZE_M),
            "color": _colour("[175, 175, 170]"),
        }, required=("from", "to"))},
        "blocks": {"type": "array", "description": "solid boxes", "items": mapping(BLOCK_KEYS, {
            "center": _point("the centre"), "size": numbers("[width, depth] in metres", 2),
            "angle_deg": number("rotation in degrees (default 0)"),
            "height": number("metres: how high it stands for cameras (default 0.5)", MIN_SIZE_M, MAX_SIZE_M),
            "color": _colour("[150, 120, 90]"),
        }, required=("center", "size"))},
        "spawns": {"type": "array", "description": "numbered start poses ('at: spawn' takes them in order)",
                   "items": pose},
        "ground": _ground(),
        "mechanism": _mechanism(),
    }, required=("labsim-world",)))
