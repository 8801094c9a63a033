"""World files: YAML with positions to a ``labsim.backends.world.World``.

A world file describes a scene once for every backend: the room's walls, solid blocks, the
area robots may be placed in, and numbered spawn poses. Its errors are reported like a
behaviour file's, with the world file's path, line and column.

    labsim-world: 1
    name: walls_lab4
    bounds: [-7.5, -7.5, 7.5, 7.5]          # xmin, ymin, xmax, ymax in metres
    walls:                                   # segments; thickness defaults to wall_thickness
      - {from: [-7.5, -7.5], to: [7.5, -7.5]}
    blocks:                                  # solid boxes: centre, size, optional angle_deg
      - {center: [6.5, 6.5], size: [2, 2]}
    spawns:                                  # [x, y, heading_deg]
      - [0, 0, 90]
"""
from __future__ import annotations

import math
from pathlib import Path

from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from labsim.backends.world import Block, Pose, Wall, World
from labsim.dsl.errors import LabsimError, Report, did_you_mean
from labsim.dsl.source import Document, load, scalar_value

KEYS = ("labsim-world", "name", "description", "bounds", "wall_thickness", "walls", "blocks", "spawns")


def load_world(path: str | Path, report: Report) -> World | None:
    """Read a world file; problems go to the report and give None."""
    try:
        doc = load(path, kind="world")
    except LabsimError as e:
        for d in e.diagnostics:
            report.add(d)
        return None
    before = len(report.errors)
    world = _WorldReader(doc, report).read()
    return world if len(report.errors) == before else None


class _WorldReader:
    def __init__(self, doc: Document, report: Report):
        self.doc = doc
        self.report = report

    def error(self, node: Node, message: str) -> None:
        self.report.add(self.doc.diagnostic(node, message))

    def number(self, node: Node, what: str) -> float:
        v = scalar_value(node) if isinstance(node, ScalarNode) else None
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            self.error(node, f"{what} must be a number")
            return 0.0
        return float(v)

    def numbers(self, node: Node, n: tuple[int, ...], what: str) -> list[float] | None:
        if not isinstance(node, SequenceNode) or len(node.value) not in n:
            counts = " or ".join(str(k) for k in n)
            self.error(node, f"{what} must be a list of {counts} numbers")
            return None
        return [self.number(v, what) for v in node.value]

    def items(self, node: Node, what: str) -> list[Node]:
        if not isinstance(node, SequenceNode):
            self.error(node, f"'{what}' must be a list")
            return []
        return list(node.value)

    def fields(self, node: Node, allowed: tuple[str, ...], what: str) -> dict[str, Node]:
        if not isinstance(node, MappingNode):
            self.error(node, f"each of '{what}' is a mapping such as {{{allowed[0]}: ...}}")
            return {}
        out = {}
        for k, v in node.value:
            if k.value not in allowed:
                self.error(k, f"unknown key '{k.value}' in {what}{did_you_mean(k.value, allowed)}")
            else:
                out[k.value] = v
        return out

    def read(self) -> World:
        root = self.doc.root
        if not isinstance(root, MappingNode):
            self.report.add(self.doc.diagnostic_at(0, "a world file is a YAML mapping (labsim-world: 1, name: ..., walls: ...)"))
            return World("", "", (0, 0, 0, 0))
        f = self.fields(root, KEYS, "a world file")
        if "labsim-world" not in f:
            self.report.add(self.doc.diagnostic_at(0, "missing 'labsim-world: 1' (the world format version)"))
        elif self.number(f["labsim-world"], "labsim-world") != 1:
            self.error(f["labsim-world"], "this labsim reads world format version 1")
        name = str(scalar_value(f["name"])) if "name" in f and isinstance(f["name"], ScalarNode) else Path(self.doc.path).stem
        description = str(scalar_value(f["description"])) if "description" in f and isinstance(f["description"], ScalarNode) else ""
        thickness = self.number(f["wall_thickness"], "wall_thickness") if "wall_thickness" in f else 0.1
        bounds = (-10.0, -10.0, 10.0, 10.0)
        if "bounds" in f:
            b = self.numbers(f["bounds"], (4,), "bounds")
            if b is not None:
                if b[0] >= b[2] or b[1] >= b[3]:
                    self.error(f["bounds"], "bounds are [xmin, ymin, xmax, ymax] with xmin < xmax and ymin < ymax")
                bounds = (b[0], b[1], b[2], b[3])
        walls = []
        for item in self.items(f["walls"], "walls") if "walls" in f else []:
            w = self.fields(item, ("from", "to", "thickness"), "walls")
            if "from" not in w or "to" not in w:
                self.error(item, "a wall needs 'from: [x, y]' and 'to: [x, y]'")
                continue
            a, b = self.numbers(w["from"], (2,), "from"), self.numbers(w["to"], (2,), "to")
            t = self.number(w["thickness"], "thickness") if "thickness" in w else thickness
            if a and b:
                if a == b:
                    self.error(item, "a wall's 'from' and 'to' must differ")
                elif t <= 0:
                    self.error(w.get("thickness", item), "a wall's thickness must be positive")
                walls.append(Wall((a[0], a[1]), (b[0], b[1]), t))
        blocks = []
        for item in self.items(f["blocks"], "blocks") if "blocks" in f else []:
            bl = self.fields(item, ("center", "size", "angle_deg"), "blocks")
            if "center" not in bl or "size" not in bl:
                self.error(item, "a block needs 'center: [x, y]' and 'size: [width, depth]'")
                continue
            c, s = self.numbers(bl["center"], (2,), "center"), self.numbers(bl["size"], (2,), "size")
            angle = math.radians(self.number(bl["angle_deg"], "angle_deg")) if "angle_deg" in bl else 0.0
            if c and s:
                if s[0] <= 0 or s[1] <= 0:
                    self.error(bl["size"], "a block's size must be positive")
                    continue
                blocks.append(Block(_box(c[0], c[1], s[0], s[1], angle)))
        spawns = []
        for item in self.items(f["spawns"], "spawns") if "spawns" in f else []:
            p = self.numbers(item, (2, 3), "a spawn pose [x, y, heading_deg]")
            if p:
                spawns.append(Pose(p[0], p[1], math.radians(p[2]) if len(p) == 3 else 0.0))
        return World(name, description, bounds, tuple(walls), tuple(blocks), tuple(spawns), self.doc.path)


def _box(cx: float, cy: float, w: float, d: float, angle: float) -> tuple[tuple[float, float], ...]:
    c, s = math.cos(angle), math.sin(angle)
    corners = ((-w / 2, -d / 2), (w / 2, -d / 2), (w / 2, d / 2), (-w / 2, d / 2))
    return tuple((cx + x * c - y * s, cy + x * s + y * c) for x, y in corners)
