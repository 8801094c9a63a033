"""The documents a live view sends: a scene once per run, then frames (docs/view.md).

A *scene* is what does not change during a run: the world's geometry (walls, blocks, ground,
a mechanism's bodies and joints as they stand at the start), each robot's outline and
sonars, the table's columns, the sliders, parameters and rules. A *frame* is one moment: the
tick, every robot's pose, state, rule, sonar distances and column values, a mechanism's body
poses and joint targets, the sliders and their labels. Both are plain JSON-ready dicts built
here from plain data (``labsim.backends.scene``), so the same code serves a live run and a
replayed trace. Numbers that JSON cannot hold are sent as strings: ``"inf"``, ``"-inf"``,
and ``null`` for nan.
"""
from __future__ import annotations

import base64
import math
from typing import Any

import cv2
import numpy as np

from labsim.backends.scene.models import Kind, RobotModel, upright
from labsim.backends.scene.world import World
from labsim.dsl.emit.program import Program
from labsim.dsl.library.builtins import Type

SCHEMA = 1  # the message schema version; docs/view.md describes it
FRAME_INTERVAL_S = 1 / 30  # at most 30 frames a second, whatever the speed
# At "as fast as it goes" 20: every frame carries the path and chart samples of the ticks since
# the last, so fewer frames lose nothing drawn, and each costs the server about 1.3 ms and a
# headless Chromium about 10 ms of CPU (mostly its compositor's, out of the page's reach); 10
# would halve the browser's share but carry twice the path a frame, over the 4 KB a frame the
# view keeps to (docs/decisions.md §11)
FLAT_OUT_INTERVAL_S = 1 / 20

Json = dict[str, Any]


def number(v: object) -> float | str | None:
    """A value for a JSON cell: a finite number, "inf"/"-inf", or None (nan, or not a number)."""
    if isinstance(v, bool):
        return 1.0 if v else 0.0
    if isinstance(v, (int, float, np.integer, np.floating)):
        f = float(v)
        if f == f and f not in (math.inf, -math.inf):
            return f
        return None if f != f else ("inf" if f > 0 else "-inf")
    return None


def short(v: object) -> float | str | None:
    """A path point's coordinate: a tenth of a millimetre is plenty to draw and keeps frames
    small (``round`` is three times as fast as formatting to significant digits)."""
    if type(v) is float and v - v == 0.0:  # finite
        return round(v, 4)
    n = number(v)
    return round(n, 4) if isinstance(n, float) else n


def part(value: object, k: int) -> float | str | None:
    """A table column's cell: the reading itself (``k`` -1) or item ``k`` of a joint's or body's tuple."""
    if k < 0:
        return number(value)
    if isinstance(value, tuple) and k < len(value):
        return number(value[k])
    return None


def world_doc(world: World) -> Json:
    """The world's geometry, metres (a mechanism's plane: x along, z up)."""
    doc: Json = {
        "name": world.name, "description": world.description, "bounds": list(world.bounds),
        "walls": [[*w.a, *w.b, w.thickness_m] for w in world.walls],
        "blocks": [[list(c) for c in b.corners] for b in world.blocks],
        "ground": None, "mechanism": None,
    }
    g = world.ground
    if g is not None:
        doc["ground"] = {
            "floor": list(g.floor_rgb),
            "roads": [{"points": [list(p) for p in r.points], "closed": r.closed, "width": r.width_m,
                       "rgb": list(r.rgb)} for r in g.roads],
            "lines": [{"a": list(ln.a), "b": list(ln.b), "width": ln.width_m, "rgb": list(ln.rgb)}
                      for ln in g.lines],
            "patches": [{"corners": [list(c) for c in pa.corners], "rgb": list(pa.rgb)} for pa in g.patches],
        }
    m = world.mechanism
    if m is not None:
        doc["mechanism"] = {
            "bodies": [{"name": b.name, "shape": b.shape, "center": list(b.center), "size": list(b.size),
                        "angle": b.angle_rad, "static": b.static} for b in m.bodies],
            "joints": [{"name": j.name, "kind": j.kind, "parent": j.parent, "child": j.child,
                        "anchor": list(j.anchor), "rope": j.rope} for j in m.joints],
            "force_sensors": [{"name": f.name, "between": list(f.between),
                               "anchors": [list(a) for a in f.anchors] if f.anchors else None}
                              for f in m.force_sensors],
            "floor_z": m.floor_z_m, "slew": m.slew.name if m.slew is not None else None,
        }
    return doc


def channel_kinds(world: World, model: RobotModel | None) -> dict[str, Kind]:
    """What each channel of a robot (or of the world's mechanism, for None) holds."""
    from labsim.backends.scene.world import world_channels

    if model is None:
        return world.mechanism.channels() if world.mechanism is not None else {}
    return {**model.channels(), **world_channels(world)}


_PARTS = {Kind.JOINT: ("position", "velocity"), Kind.FORCE: ("force",), Kind.BODY: ("x", "z", "angle")}


def sensor_columns(channels: tuple[str, ...], kinds: dict[str, Kind]) -> list[tuple[str, int, int]]:
    """The table's sensor columns: (column name, channel index, part index or -1).

    Numbers, distances and booleans are one column each; a joint is ``J.position`` and
    ``J.velocity``, a force sensor ``F.force``, a body ``B.x``, ``B.z``, ``B.angle``;
    images have no column (they are shown as pictures).
    """
    out = []
    for i, name in enumerate(channels):
        kind = kinds.get(name, Kind.NUMBER)
        if kind in _PARTS:
            out += [(f"{name}.{part}", i, k) for k, part in enumerate(_PARTS[kind])]
        elif kind is not Kind.IMAGE:
            out.append((name, i, -1))
    return out


def robot_doc(name: str, model: RobotModel | None, channels: tuple[str, ...]) -> Json:
    """A robot's outline and the sonars the behaviour reads (their order is the frames')."""
    if model is None:
        return {"name": name, "model": None, "footprint": [], "sonars": [], "cameras": [], "ground": [], "reach": 0.0}
    read = set(channels)
    return {
        "name": name, "model": model.name, "footprint": [list(p) for p in model.footprint],
        "sonars": [{"name": s.name, "x": s.x_m, "y": s.y_m, "angle": s.angle_rad, "range": s.range_m}
                   for s in model.rays() if s.name in read],
        "cameras": [c.name for c in model.cameras if c.name in read],
        # the ground sensors the behaviour reads, at their mounts (their readings are the frames')
        "ground": [{"name": g.name, "x": g.x_m, "y": g.y_m} for g in model.ground_sensors if g.name in read],
        "reach": max((math.hypot(x, y) for x, y in model.footprint), default=0.2),  # for the heading mark
    }


def png_data_url(image: object) -> str | None:
    """An image value (uint8 or bool, gray or RGB) as a PNG data: URL, or None if it is not one.

    Turned upright: image values run bottom row first (CoppeliaSim's order), a page shows
    them as a person sees the scene.
    """
    if not isinstance(image, np.ndarray) or image.ndim not in (2, 3) or image.size == 0:
        return None
    img = np.ascontiguousarray(upright(image))
    if img.dtype == np.bool_:
        img = img.astype(np.uint8) * 255
    elif img.dtype != np.uint8:
        img = np.clip(img, 0, 255).astype(np.uint8)
    if img.ndim == 3:
        if img.shape[2] != 3:
            return None
        img = cv2.cvtColor(img, cv2.COLOR_RGB2BGR)
    ok, buf = cv2.imencode(".png", img)
    if not ok:
        return None
    return "data:image/png;base64," + base64.b64encode(buf.tobytes()).decode("ascii")


def message(kind: str, **fields: object) -> Json:
    """A server message: its type, the schema version, and its fields."""
    return {"type": kind, "v": SCHEMA, **fields}


def value_slots(program: Program) -> tuple[list[int], list[bool], set[int]]:
    """The slots of the table's signal columns, then of what the behaviour reads of other robots
    (format 1.3: 'leader.x', 'heard(ping)'); whether each of them, then each slider, is a number
    to chart; which of them are states (shown by their names)."""
    names = (*program.single_signals, *(n for n, _ in program.received))
    types = {**program.signal_types, **dict(program.received)}
    return ([program.slot_of[n] for n in names],
            [types.get(n) in (Type.NUMBER, Type.BOOL) for n in names] + [True] * len(program.slider_names),
            {k for k, n in enumerate(names) if types.get(n) is Type.STATE})


def value_columns(program: Program) -> list[Json]:
    """The table's signal columns, then its columns of what the behaviour reads of other robots."""
    numeric = (Type.NUMBER, Type.BOOL)
    return ([{"name": n, "group": "signal", "numeric": program.signal_types.get(n) in numeric}
             for n in program.single_signals]
            + [{"name": n, "group": "other robots", "numeric": t in numeric} for n, t in program.received])


def shown_values(slots: list, at: list[int], states: set[int], state_names: tuple[str, ...]) -> list:
    """The values at slots ``at`` for the table: numbers, and a state (a place in ``states``) by its name."""
    return [state_names[int(slots[s])] if k in states else number(slots[s]) for k, s in enumerate(at)]
