"""A labsim trace as an MCAP file, the container Foxglove, Rerun and PlotJuggler read.

One channel set per robot, each message stamped with the tick's simulated time (tick x dt,
exact, rather than the trace's 6-digit ``time`` cell), JSON-encoded with a JSON Schema:

- ``/ROBOT/pose`` (``foxglove.PoseInFrame``; ROBOT is the robot's name, ``pioneer[2]`` as
  ``pioneer_2``: ``topic_names``) and ``/tf`` (``foxglove.FrameTransform``, frame
  ``ROBOT`` in ``world``): Foxglove's 3D panel draws the robot and, with the topic's history
  on, its path;
- ``/ROBOT/trace`` (``labsim.TraceRow``): every column of the row, numbers as numbers, so any
  of them plots against time; ``inf`` (a sensor that sees nothing) and ``nan`` have no JSON
  number and are written as null, a gap in a plot;
- ``/ROBOT/state`` (``labsim.State``): the rule state and the rule that fired, as text;
- ``/events`` (``foxglove.Log``): each event of the ``events`` column, named by its robot;
- ``/world`` (``foxglove.SceneUpdate``, once, at time 0): the world's walls and blocks as
  boxes, its bounds as a line loop.

The trace's header goes in as MCAP metadata (``labsim``). The trace is read and checked as
``labsim plot`` reads it (``labsim.runtime.trace``), so what is not a labsim trace is refused
with plot's words; the file is written beside its target and renamed into place.
"""
from __future__ import annotations

import json
import math
import re
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.writer import CompressionType, Writer

from labsim.backends.scene.world import World
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.files import check_output, written
from labsim.runtime.trace import Trace, TraceFormatError, read_trace, trace_world

PROFILE = ""  # no ROS profile: plain JSON channels
FRAME = "world"
TEXT_COLUMNS = frozenset({"robot", "state", "rule", "events"})
_NS = 1_000_000_000

_TIME = {"type": "object", "properties": {"sec": {"type": "integer", "minimum": 0},
                                          "nsec": {"type": "integer", "minimum": 0}}}
_VEC = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_QUAT = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}
_POSE = {"type": "object", "properties": {"position": _VEC, "orientation": _QUAT}}
_COLOR = {"type": "object", "properties": {k: {"type": "number"} for k in "rgba"}}
SCHEMAS: dict[str, dict[str, Any]] = {
    "foxglove.PoseInFrame": {"title": "foxglove.PoseInFrame", "type": "object", "properties": {
        "timestamp": _TIME, "frame_id": {"type": "string"}, "pose": _POSE}},
    "foxglove.FrameTransform": {"title": "foxglove.FrameTransform", "type": "object", "properties": {
        "timestamp": _TIME, "parent_frame_id": {"type": "string"}, "child_frame_id": {"type": "string"},
        "translation": _VEC, "rotation": _QUAT}},
    "foxglove.Log": {"title": "foxglove.Log", "type": "object", "properties": {
        "timestamp": _TIME, "level": {"type": "integer"}, "message": {"type": "string"},
        "name": {"type": "string"}, "file": {"type": "string"}, "line": {"type": "integer"}}},
    "foxglove.SceneUpdate": {"title": "foxglove.SceneUpdate", "type": "object", "properties": {
        "deletions": {"type": "array"}, "entities": {"type": "array", "items": {"type": "object", "properties": {
            "timestamp": _TIME, "frame_id": {"type": "string"}, "id": {"type": "string"},
            "lifetime": _TIME, "frame_locked": {"type": "boolean"},
            "cubes": {"type": "array", "items": {"type": "object", "properties": {
                "pose": _POSE, "size": _VEC, "color": _COLOR}}},
            "lines": {"type": "array"}}}}}},
    "labsim.State": {"title": "labsim.State", "type": "object", "properties": {
        "state": {"type": "string"}, "rule": {"type": "string"}}},
}
LOG_INFO = 2  # foxglove.Log's level INFO
LAST_NS = 2 ** 64 - 1  # MCAP's times are unsigned 64-bit nanoseconds
EMPTY_ENTITY: dict[str, list[Any]] = {"metadata": [], "arrows": [], "cubes": [], "spheres": [], "cylinders": [],
                                      "lines": [], "triangles": [], "texts": [], "models": []}


@dataclass(frozen=True)
class Exported:
    robots: tuple[str, ...]
    ticks: int
    messages: int
    world_note: str  # why the walls are missing, or ''
    cut_short: str = ""  # why the run did not end by itself (Trace.cut_short), or ''


def export_trace(trace_path: str | Path, out: str | Path) -> Exported:
    """Write the trace at ``trace_path`` as an MCAP file at ``out``; LabsimError for a file that
    is not a labsim trace (plot's messages) or an output that cannot be written."""
    out = Path(out)
    if out.suffix.lower() != ".mcap":
        raise LabsimError([Diagnostic(str(out), f"'{out.suffix or out.name}' is not a kind of file labsim export "
                                                "writes; use .mcap")])
    check_output(out, [trace_path])  # as labsim plot checks its output
    try:
        trace = read_trace(trace_path)
    except TraceFormatError as e:
        raise LabsimError([e.diagnostic(str(trace_path))]) from None
    if not trace.rows:
        raise LabsimError([Diagnostic(str(trace_path), "the trace has no rows: nothing ran")])
    for column in ("tick", "robot", "x", "y", "heading"):
        if column not in trace.columns:
            raise LabsimError([Diagnostic(str(trace_path), f"the trace has no '{column}' column")])
    world, note = trace_world(trace)
    with written(out) as f:
        exported = write_mcap(trace, world, f)
    return Exported(exported.robots, exported.ticks, exported.messages, note, trace.cut_short())


class _Out:
    """The MCAP writer with its schemas registered once and a channel per topic, made on first use."""

    def __init__(self, stream: Any, row_schema: dict[str, Any]) -> None:
        self.writer = Writer(stream, compression=CompressionType.ZSTD)
        self.writer.start(profile=PROFILE, library="labsim")
        self.schemas = {name: self.writer.register_schema(name, "jsonschema", json.dumps(s).encode())
                        for name, s in {**SCHEMAS, "labsim.TraceRow": row_schema}.items()}
        self.channels: dict[str, int] = {}
        self.messages = 0

    def put(self, topic: str, schema: str, at_ns: int, message: dict[str, Any]) -> None:
        if topic not in self.channels:
            self.channels[topic] = self.writer.register_channel(topic, "json", self.schemas[schema])
        self.writer.add_message(self.channels[topic], at_ns, json.dumps(message, allow_nan=False).encode(), at_ns)
        self.messages += 1


def write_mcap(trace: Trace, world: World | None, stream: Any) -> Exported:
    """The MCAP file of a checked trace, written to a binary stream."""
    columns = trace.columns
    col = {name: i for i, name in enumerate(columns)}
    text = [name in TEXT_COLUMNS or name.startswith("label:") for name in columns]
    out = _Out(stream, {"title": "labsim.TraceRow", "type": "object", "properties": {
        c: {"type": "string" if t else ["number", "null"]} for c, t in zip(columns, text)}})
    out.writer.add_metadata("labsim", {k: json.dumps(v, sort_keys=True) for k, v in trace.header.items()})
    topics = topic_names(dict.fromkeys(r[col["robot"]] for r in trace.rows))
    out.writer.add_metadata("labsim topics", topics)  # robot -> the name its topics use
    out.put("/world", "foxglove.SceneUpdate", 0, _scene(world))
    dt = trace.header.get("dt")
    ticks: set[int] = set()
    for row in trace.rows:
        robot, tick = row[col["robot"]], int(row[col["tick"]])
        part = topics[robot]
        ticks.add(tick)
        at_ns = _stamp(tick, dt, row[col["time"]] if "time" in col else "0")
        stamp = {"sec": min(at_ns // _NS, 2 ** 32 - 1), "nsec": at_ns % _NS}
        x, y, heading = (_number(row[col[c]]) for c in ("x", "y", "heading"))
        position, rotation = {"x": x, "y": y, "z": 0.0}, _yaw(heading)
        out.put(f"/{part}/pose", "foxglove.PoseInFrame", at_ns,
                {"timestamp": stamp, "frame_id": FRAME, "pose": {"position": position, "orientation": rotation}})
        out.put("/tf", "foxglove.FrameTransform", at_ns,
                {"timestamp": stamp, "parent_frame_id": FRAME, "child_frame_id": robot, "translation": position,
                 "rotation": rotation})
        out.put(f"/{part}/trace", "labsim.TraceRow", at_ns,
                {c: cell if t else _number(cell) for c, cell, t in zip(columns, row, text)})
        if "state" in col or "rule" in col:
            state, rule = (row[col[c]] if c in col else "" for c in ("state", "rule"))
            out.put(f"/{part}/state", "labsim.State", at_ns, {"state": state, "rule": rule})
        for event in _events(row[col["events"]] if "events" in col else ""):
            out.put("/events", "foxglove.Log", at_ns, {"timestamp": stamp, "level": LOG_INFO, "message": event,
                                                       "name": robot, "file": "", "line": 0})
    out.writer.finish()
    return Exported(tuple(topics), len(ticks), out.messages, "")


def topic_names(robots: Iterable[str]) -> dict[str, str]:
    """Each robot's name as a topic's part: ``pioneer[2]`` is ``pioneer_2``, as Foxglove's message
    paths and Rerun's entity paths take it without quotes; a name taken twice gets ``_2``, ``_3``."""
    out: dict[str, str] = {}
    for robot in robots:
        base = re.sub(r"[^A-Za-z0-9_]+", "_", robot).strip("_") or "robot"
        name, k = base, 1
        while name in out.values():
            k += 1
            name = f"{base}_{k}"
        out[robot] = name
    return out


def _stamp(tick: int, dt: object, time_cell: str) -> int:
    """The tick's simulated time in nanoseconds: tick x dt when the header has a step."""
    try:
        if isinstance(dt, (int, float)) and not isinstance(dt, bool) and math.isfinite(dt) and dt > 0:
            seconds = tick * float(dt)
        else:
            seconds = _number(time_cell) or 0.0
        return max(0, min(round(seconds * _NS), LAST_NS))
    except OverflowError:  # an edited trace's tick 10**400: the last time MCAP can hold
        return LAST_NS


def _number(cell: str) -> float | None:
    """A cell as a JSON number; None for inf, nan and what is no number."""
    try:
        v = float(cell)
    except ValueError:
        return None
    return v if math.isfinite(v) else None


def _events(cell: str) -> Iterable[str]:
    return [e for e in cell.split(";") if e] if cell else []


def _yaw(heading: float | None) -> dict[str, float]:
    h = heading or 0.0
    return {"x": 0.0, "y": 0.0, "z": math.sin(h / 2), "w": math.cos(h / 2)}


def _rgb(rgb: tuple[int, int, int], alpha: float = 1.0) -> dict[str, float]:
    return {"r": rgb[0] / 255, "g": rgb[1] / 255, "b": rgb[2] / 255, "a": alpha}


def _scene(world: World | None) -> dict[str, Any]:
    """The world's walls and blocks as boxes, and its bounds as a line loop (nothing when the
    trace's world cannot be found)."""
    if world is None:
        return {"deletions": [], "entities": []}
    cubes = []
    for w in world.walls:
        (ax, ay), (bx, by) = w.a, w.b
        length = math.hypot(bx - ax, by - ay)
        cubes.append({"pose": {"position": {"x": (ax + bx) / 2, "y": (ay + by) / 2, "z": w.height_m / 2},
                               "orientation": _yaw(math.atan2(by - ay, bx - ax))},
                      "size": {"x": length + w.thickness_m, "y": w.thickness_m, "z": w.height_m},
                      "color": _rgb(w.rgb)})
    lines = []
    for b in world.blocks:
        points = [{"x": x, "y": y, "z": b.height_m} for x, y in b.corners]
        lines.append({"type": 1, "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": _yaw(0.0)},
                      "thickness": 0.03, "scale_invariant": False, "points": points, "color": _rgb(b.rgb),
                      "colors": [], "indices": []})
    x0, y0, x1, y1 = world.bounds
    lines.append({"type": 1, "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": _yaw(0.0)},
                  "thickness": 0.02, "scale_invariant": False,
                  "points": [{"x": x, "y": y, "z": 0.0} for x, y in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))],
                  "color": {"r": 0.5, "g": 0.5, "b": 0.5, "a": 1.0}, "colors": [], "indices": []})
    entity = {**EMPTY_ENTITY, "timestamp": {"sec": 0, "nsec": 0}, "frame_id": FRAME, "id": f"world:{world.name}",
              "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": False, "cubes": cubes, "lines": lines}
    return {"deletions": [], "entities": [entity]}
