"""World files: YAML with positions to a ``labsim.backends.scene.world.World``.

A world file describes a scene once for every backend: the room's walls, solid blocks, the
area robots may be placed in, numbered spawn poses and, optionally, what is painted on the
floor for cameras to see (``ground``, to ``labsim.backends.scene.ground.Ground``) and an articulated
``mechanism`` (read by ``labsim.backends.scene.mechanism_file``). Its errors are reported like a
behaviour file's, with the world file's path, line and column, all of them at once.

    labsim-world: 1
    name: walls_lab4
    bounds: [-7.5, -7.5, 7.5, 7.5]          # xmin, ymin, xmax, ymax in metres
    wall_height: 0.5                         # default for walls, metres (default 0.5)
    walls:                                   # segments; thickness defaults to wall_thickness
      - {from: [-7.5, -7.5], to: [7.5, -7.5], height: 1.0, color: [175, 175, 170]}
    blocks:                                  # solid boxes: centre, size, optional angle_deg,
      - {center: [6.5, 6.5], size: [2, 2]}   # height (default 0.5) and color
    spawns:                                  # [x, y, heading_deg]
      - [0, 0, 90]
    ground:                                  # what cameras see (optional)
      floor: [205, 205, 200]                 # RGB 0..255 (default [205, 205, 200])
      px_per_m: 100                          # texture resolution (default 100, at most 1000)
      roads:
        - width: 0.8                         # metres, > 0 (required)
          color: [25, 25, 25]                # default [25, 25, 25]
          closed: true                       # the last point joins the first (default false)
          path:                              # the centreline, in the road's direction of travel
            - [-3, -2]                       # a point [x, y]
            - [3, -2]
            - {arc: {center: [3, 0], radius: 2, to_deg: 90}}
      lines:                                 # painted, square ends; width (default 0.05) and
        - {from: [0, -2.4], to: [0, -1.6], width: 0.05, color: [255, 255, 255]}   # color optional
      patches:                               # painted boxes; color (default [25, 25, 25]) and
        - {center: [5, 5], size: [1, 0.5], color: [200, 30, 30], angle_deg: 0}   # angle optional
    mechanism: ...                           # read by labsim.backends.scene.mechanism_file

A road's path is points and arcs. An arc continues from the previous point around ``center``
with ``radius`` to the angle ``to_deg`` (degrees, counter-clockwise from +x): its start angle
is where the previous point lies on the circle, in (-180, 180], and the previous point must be
on the circle within 1 cm. It turns counter-clockwise if ``to_deg`` is greater than the start
angle, clockwise if smaller, by at most one full turn; so ``to_deg: 270`` from the circle's
left point (180) goes counter-clockwise through the bottom. Arcs become chords within 0.5 mm of
the circle. A road needs at least two points (three when closed); a closed road whose path
ends where it began is joined there. The first road is the one ``road_offset``, ``on_road``
and ``laps`` refer to (labsim.backends.scene.ground).
"""
from __future__ import annotations

import dataclasses
import hashlib
import math
from pathlib import Path

from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from labsim.backends.scene.ground import (
    DEFAULT_FLOOR_RGB,
    DEFAULT_PX_PER_M,
    DEFAULT_ROAD_RGB,
    Ground,
    Line,
    Patch,
    Road,
)
from labsim.backends.scene.mechanism_file import read_mechanism
from labsim.backends.scene.world import (
    BLOCK_HEIGHT_M,
    BLOCK_RGB,
    WALL_HEIGHT_M,
    WALL_RGB,
    Block,
    Pose,
    Wall,
    World,
)
from labsim.foundation.diagnostics import Diagnostic, LabsimError, Report
from labsim.foundation.kinds import WORLD_VERSION_KEY
from labsim.foundation.limits import (
    MAX_ARC_CHORDS,
    MAX_COORD_M,
    MAX_RADIUS_M,
    MAX_SIZE_M,
    MAX_THICKNESS_M,
    MIN_SIZE_M,
)
from labsim.foundation.source import Document, Reader, load, scalar_value

KEYS = ("labsim-world", "name", "description", "bounds", "wall_thickness", "wall_height", "walls", "blocks",
        "spawns", "ground", "mechanism")
GROUND_KEYS = ("floor", "px_per_m", "roads", "lines", "patches")
ROAD_KEYS = ("width", "color", "closed", "path")
LINE_KEYS = ("from", "to", "width", "color")
PATCH_KEYS = ("center", "size", "color", "angle_deg")
WALL_KEYS = ("from", "to", "thickness", "height", "color")
BLOCK_KEYS = ("center", "size", "angle_deg", "height", "color")
ARC_KEYS = ("center", "radius", "to_deg")

ARC_ON_CIRCLE_M = 0.01  # how far an arc's start may be off its circle
CHORD_SAGITTA_M = 0.0005  # arcs become chords no further than this from the circle
CLOSE_M = 0.001  # a closed road's last point this near its first is the same point
MAX_PX_PER_M = 1000.0
LINE_WIDTH_M = 0.05
LINE_RGB = (255, 255, 255)
PATCH_RGB = DEFAULT_ROAD_RGB


def load_world(path: str | Path, report: Report) -> World | None:
    """Read a world file; problems go to the report and give None."""
    try:
        doc = load(path, kind="world")
    except LabsimError as e:  # YAML that does not parse is not echoed either: it may be no world file
        for d in e.diagnostics:
            report.add(dataclasses.replace(d, source_line=""))
        return None
    if not _declares_world(doc):
        # docs/security.md: a file that is no world file is not quoted (it may be anyone's file)
        report.add(Diagnostic(str(path), "not a labsim world file (it has no 'labsim-world: 1' line); "
                                         "its contents are not shown"))
        return None
    before = len(report.errors)
    world = _WorldReader(doc, report).read()
    return world if len(report.errors) == before else None


def _declares_world(doc: Document) -> bool:
    """Whether the file says it is a world file: a mapping with a ``labsim-world`` key. Only such a
    file's lines are echoed in diagnostics, so its version key, not ``kind_of_keys``'s guess from
    its other keys, decides (docs/security.md)."""
    root = doc.root
    return isinstance(root, MappingNode) and any(
        isinstance(k, ScalarNode) and k.value == WORLD_VERSION_KEY for k, _ in root.value)


class _WorldReader(Reader):
    """Reads a world file. A world with any error is dropped whole (``load_world`` gives None),
    so the values built after an error only have to let the reading go on."""

    def coordinates(self, node: Node, what: str, counts: tuple[int, ...] = (2,)) -> list[float] | None:
        """``numbers``, but an item that is no number (reported) reads as 0.0 and the list is
        still given, so that the checks on the whole value (bounds in order, a wall's two ends
        apart, a size positive) run too."""
        items = self.number_list(node, what, counts)
        if items is None:
            return None
        return [0.0 if v is None else v for v in (self.number(item, what) for item in items)]

    def point(self, node: Node, what: str, counts: tuple[int, ...] = (2,)) -> list[float] | None:
        """``coordinates`` of a place in the world, each within +-MAX_COORD_M; None after an error."""
        values = self.coordinates(node, what, counts)
        if values is None:
            return None
        if any(abs(v) > MAX_COORD_M for v in values):
            self.error(node, f"{what} must lie within +-{MAX_COORD_M:g} m of the origin "
                             f"(a world is at most {2 * MAX_COORD_M:g} m across)")
            return None
        return values

    def size(self, node: Node, what: str, largest: float = MAX_SIZE_M) -> list[float] | None:
        """``coordinates`` of an extent [width, depth]: each from MIN_SIZE_M to ``largest``
        (an extent outside that is reported once, as not positive or too large, and read as 1.0)."""
        values = self.coordinates(node, what)
        if values is None:
            return None
        if any(v <= 0 for v in values):
            return values  # the caller says it must be positive, in its own words
        if any(not MIN_SIZE_M <= v <= largest for v in values):
            self.error(node, f"{what} must be from {MIN_SIZE_M:g} to {largest:g} m")
            return [1.0, 1.0]
        return values

    def length(self, node: Node, what: str, largest: float) -> float | None:
        """A positive length (a width, a radius) from MIN_SIZE_M to ``largest`` metres."""
        value = self.positive(node, what)
        if value is not None and not MIN_SIZE_M <= value <= largest:
            self.error(node, f"{what} must be from {MIN_SIZE_M:g} to {largest:g} m, not {value:g}")
            return None
        return value

    def number_or_zero(self, node: Node, what: str) -> float:
        """A number, or 0.0 after reporting that it is none, so that the checks after it run too."""
        value = self.number(node, what)
        return 0.0 if value is None else value

    def list_of(self, f: dict[str, Node], key: str) -> list[Node]:
        """The items of an optional list field: none when it is absent or no list (reported)."""
        return (self.items(f[key], key) or []) if key in f else []

    def read(self) -> World:
        root = self.doc.root
        if not isinstance(root, MappingNode):
            self.error(0, "a world file is a YAML mapping (labsim-world: 1, name: ..., walls: ...)")
            return World("", "", (0, 0, 0, 0))
        f = self.fields(root, KEYS, "a world file") or {}
        if "labsim-world" not in f:
            self.error(0, "missing 'labsim-world: 1' (the world format version)")
        elif self.number(f["labsim-world"], "labsim-world") != 1:  # also said after "must be a number"
            self.error(f["labsim-world"], "this labsim reads world format version 1")
        name = _text(f.get("name"), Path(self.doc.path).stem)
        description = _text(f.get("description"), "")
        thickness = self.number_or_zero(f["wall_thickness"], "wall_thickness") if "wall_thickness" in f else 0.1
        bounds = (-10.0, -10.0, 10.0, 10.0)
        if "bounds" in f:
            b = self.point(f["bounds"], "bounds", (4,))
            if b is not None:
                if b[0] >= b[2] or b[1] >= b[3]:
                    self.error(f["bounds"], "bounds are [xmin, ymin, xmax, ymax] with xmin < xmax and ymin < ymax")
                bounds = (b[0], b[1], b[2], b[3])
        height = self.height(f["wall_height"], "wall_height") if "wall_height" in f else WALL_HEIGHT_M
        walls, blocks = self.walls(f, thickness, height or WALL_HEIGHT_M), self.blocks(f)
        spawns = []
        for item in self.list_of(f, "spawns"):
            p = self.numbers(item, "a spawn pose [x, y, heading_deg]", (2, 3))
            if p is not None and any(abs(v) > MAX_COORD_M for v in p[:2]):
                self.error(item, f"a spawn pose must lie within +-{MAX_COORD_M:g} m of the origin")
            elif p is not None:
                spawns.append(Pose(p[0], p[1], math.radians(p[2]) if len(p) == 3 else 0.0))
        ground = self.ground(f["ground"]) if "ground" in f else None
        mechanism = read_mechanism(f["mechanism"], self.doc, self.report) if "mechanism" in f else None
        return World(name, description, bounds, walls, blocks, tuple(spawns), self.doc.path,
                     sha256=hashlib.sha256(self.doc.text.encode()).hexdigest(), ground=ground, mechanism=mechanism)

    def height(self, node: Node, what: str) -> float | None:
        """How high a wall or block stands, for cameras: a length from MIN_SIZE_M to MAX_SIZE_M."""
        return self.length(node, what, MAX_SIZE_M)

    def looks(self, item: dict[str, Node], height: float,
              rgb: tuple[int, int, int]) -> tuple[float, tuple[int, int, int]]:
        """An item's optional height and color, or the defaults given (also after an error, which
        is reported and drops the world)."""
        h = self.height(item["height"], "height") if "height" in item else height
        c = self.colour(item["color"], "color") if "color" in item else rgb
        return (height if h is None else h), (rgb if c is None else c)

    def walls(self, f: dict[str, Node], thickness: float, height: float) -> tuple[Wall, ...]:
        walls = []
        for item in self.list_of(f, "walls"):
            w = self.fields(item, WALL_KEYS, "walls") or {}
            if "from" not in w or "to" not in w:
                self.error(item, "a wall needs 'from: [x, y]' and 'to: [x, y]'")
                continue
            a, b = self.point(w["from"], "from"), self.point(w["to"], "to")
            t = self.number_or_zero(w["thickness"], "thickness") if "thickness" in w else thickness
            if a is not None and b is not None:
                if a == b:
                    self.error(item, "a wall's 'from' and 'to' must differ")
                elif t <= 0:
                    self.error(w.get("thickness", item), "a wall's thickness must be positive")
                elif not MIN_SIZE_M <= t <= MAX_THICKNESS_M:
                    self.error(w.get("thickness", item), f"a wall's thickness must be from {MIN_SIZE_M:g} "
                                                        f"to {MAX_THICKNESS_M:g} m, not {t:g}")
                walls.append(Wall((a[0], a[1]), (b[0], b[1]), t, *self.looks(w, height, WALL_RGB)))
        return tuple(walls)

    def blocks(self, f: dict[str, Node]) -> tuple[Block, ...]:
        blocks = []
        for item in self.list_of(f, "blocks"):
            bl = self.fields(item, BLOCK_KEYS, "blocks") or {}
            if "center" not in bl or "size" not in bl:
                self.error(item, "a block needs 'center: [x, y]' and 'size: [width, depth]'")
                continue
            c, s = self.point(bl["center"], "center"), self.size(bl["size"], "size")
            angle = self.number(bl["angle_deg"], "angle_deg") if "angle_deg" in bl else 0.0
            if c is not None and s is not None:
                if s[0] <= 0 or s[1] <= 0:
                    self.error(bl["size"], "a block's size must be positive")
                    continue
                if angle is not None:
                    blocks.append(Block(_box(c[0], c[1], s[0], s[1], math.radians(angle)),
                                        *self.looks(bl, BLOCK_HEIGHT_M, BLOCK_RGB)))
        return tuple(blocks)

    # --- ground ---------------------------------------------------------------------------------

    def ground(self, node: Node) -> Ground | None:
        before = self.error_count
        if not isinstance(node, MappingNode):
            self.error(node, "'ground' is a mapping: floor, px_per_m, roads, lines, patches")
            return None
        g = self.fields(node, GROUND_KEYS, "ground") or {}
        floor = self.colour(g["floor"], "floor") if "floor" in g else DEFAULT_FLOOR_RGB
        ppm = DEFAULT_PX_PER_M
        if "px_per_m" in g:
            value = self.positive(g["px_per_m"], "px_per_m")
            if value is not None and value > MAX_PX_PER_M:
                self.error(g["px_per_m"], f"px_per_m must be at most {MAX_PX_PER_M:g} (1 mm per pixel)")
            ppm = DEFAULT_PX_PER_M if value is None else value
        roads = [r for item in self.list_of(g, "roads") if (r := self.road(item)) is not None]
        lines, patches = self.lines(g), self.patches(g)
        if self.error_count != before or floor is None:
            return None
        ground = Ground(floor, tuple(roads), lines, patches, ppm)
        problem = ground.texture_problem()
        if problem:
            self.error(g.get("px_per_m", node), problem)
            return None
        return ground

    def lines(self, g: dict[str, Node]) -> tuple[Line, ...]:
        lines = []
        for item in self.list_of(g, "lines"):
            ln = self.fields(item, LINE_KEYS, "lines")
            if ln is None:
                continue
            if "from" not in ln or "to" not in ln:
                self.error(item, "a line needs 'from: [x, y]' and 'to: [x, y]'")
                continue
            a, b = self.point(ln["from"], "from"), self.point(ln["to"], "to")
            width = self.length(ln["width"], "a line's width", MAX_SIZE_M) if "width" in ln else LINE_WIDTH_M
            rgb = self.colour(ln["color"], "color") if "color" in ln else LINE_RGB
            if a is not None and b is not None:
                if a == b:
                    self.error(item, "a line's 'from' and 'to' must differ")
                if width is not None and rgb is not None:
                    lines.append(Line((a[0], a[1]), (b[0], b[1]), width, rgb))
        return tuple(lines)

    def patches(self, g: dict[str, Node]) -> tuple[Patch, ...]:
        patches = []
        for item in self.list_of(g, "patches"):
            pa = self.fields(item, PATCH_KEYS, "patches")
            if pa is None:
                continue
            if "center" not in pa or "size" not in pa:
                self.error(item, "a patch needs 'center: [x, y]' and 'size: [width, depth]'")
                continue
            c, sz = self.point(pa["center"], "center"), self.size(pa["size"], "size")
            angle = self.number(pa["angle_deg"], "angle_deg") if "angle_deg" in pa else 0.0
            rgb = self.colour(pa["color"], "color") if "color" in pa else PATCH_RGB
            if c is not None and sz is not None:
                if sz[0] <= 0 or sz[1] <= 0:
                    self.error(pa["size"], "a patch's size must be positive")
                    continue
                if angle is not None and rgb is not None:
                    patches.append(Patch(_box(c[0], c[1], sz[0], sz[1], math.radians(angle)), rgb))
        return tuple(patches)

    def road(self, item: Node) -> Road | None:
        r = self.fields(item, ROAD_KEYS, "roads")
        if r is None:
            return None
        if "path" not in r or "width" not in r:
            missing = " and ".join(f"'{k}'" for k in ("width", "path") if k not in r)
            self.error(item, f"a road needs {missing} (width: metres, path: a list of points [x, y] and arcs)")
            if "path" not in r:
                return None
        width = self.length(r["width"], "a road's width", MAX_SIZE_M) if "width" in r else None
        rgb = self.colour(r["color"], "color") if "color" in r else DEFAULT_ROAD_RGB
        closed = self.flag(r["closed"], "closed") is True if "closed" in r else False
        points = self.path(r["path"])
        if points is None:
            return None
        if closed and len(points) > 2 and math.dist(points[0], points[-1]) <= CLOSE_M:
            points.pop()  # the path came back to its start: the closing segment joins them
        if len(points) < 2:
            self.error(r["path"], "a road needs at least two points")
            return None
        if closed and len(points) < 3:
            self.error(r["path"], "a closed road needs at least three points")
            return None
        if width is None or rgb is None:
            return None
        return Road(tuple(points), closed, width, rgb)

    def path(self, node: Node) -> list[tuple[float, float]] | None:
        """The points of a road's path, arcs expanded into chords; None after an error."""
        if not isinstance(node, SequenceNode):
            self.error(node, "a road's 'path' must be a list of points [x, y] and arcs")
            return None
        before = self.error_count
        points: list[tuple[float, float]] = []
        for item in node.value:
            if isinstance(item, MappingNode):
                arc = self.fields(item, ("arc",), "a path") or {}
                if "arc" not in arc:
                    if not item.value:
                        self.error(item, "a path item is a point [x, y] or {arc: {center, radius, to_deg}}")
                    continue
                if not points:
                    if self.error_count == before:  # else the point before it was the mistake
                        self.error(item, "an arc continues from the previous point: start the path with a point [x, y]")
                    continue
                points += self.arc(arc["arc"], points[-1])
            else:
                p = self.point(item, "a path point [x, y]")
                if p is not None:
                    points.append((p[0], p[1]))
        return points if self.error_count == before else None

    def arc(self, node: Node, start: tuple[float, float]) -> list[tuple[float, float]]:
        """The chord end points of an arc from start (exclusive) to its end (inclusive)."""
        before = self.error_count
        a = self.fields(node, ARC_KEYS, "an arc")
        if a is None:
            return []
        missing = [k for k in ARC_KEYS if k not in a]
        if missing:
            if self.error_count == before:  # after a misspelt key, did-you-mean says enough
                self.error(node, "an arc needs " + ", ".join(f"'{k}'" for k in missing)
                           + " ({center: [x, y], radius: metres, to_deg: degrees})")
            return []
        c = self.point(a["center"], "an arc's center")
        radius = self.length(a["radius"], "an arc's radius", MAX_RADIUS_M)
        to_deg = self.number(a["to_deg"], "to_deg")
        if c is None or radius is None or to_deg is None or self.error_count != before:
            return []
        # + 0.0 turns -0.0 into 0.0, so a point written [x, -0] starts at 180, not -180
        dx, dy = start[0] - c[0] + 0.0, start[1] - c[1] + 0.0
        off = math.hypot(dx, dy) - radius
        if abs(off) > ARC_ON_CIRCLE_M:
            self.error(a["center"], f"the arc starts at the previous point ({start[0]:g}, {start[1]:g}), "
                       f"which is {math.hypot(dx, dy):.4g} m from the centre, not on the circle of "
                       f"radius {radius:g} (allowed: {ARC_ON_CIRCLE_M * 100:g} cm)")
            return []
        from_deg = math.degrees(math.atan2(dy, dx))
        sweep = math.radians(to_deg - from_deg)
        if abs(sweep) < 1e-9:
            self.error(a["to_deg"], f"the arc ends where it starts ({from_deg:g} degrees on its circle)")
            return []
        if abs(sweep) > 2 * math.pi + 1e-9:
            self.error(a["to_deg"], f"an arc turns at most one full circle; it starts at {from_deg:.4g} degrees")
            return []
        step = min(math.radians(5), 2 * math.acos(max(-1.0, 1 - CHORD_SAGITTA_M / radius)))
        # beyond 1.6 km of radius the cap makes the chords coarser than CHORD_SAGITTA_M (limits.py)
        n = min(MAX_ARC_CHORDS, max(1, math.ceil(abs(sweep) / step)))
        start_rad = math.atan2(dy, dx)
        return [(c[0] + radius * math.cos(start_rad + sweep * i / n),
                 c[1] + radius * math.sin(start_rad + sweep * i / n)) for i in range(1, n + 1)]


def _text(node: Node | None, default: str) -> str:
    """An optional text field: a single value as Python writes it; else the default."""
    return str(scalar_value(node)) if isinstance(node, ScalarNode) else default


def _box(cx: float, cy: float, w: float, d: float, angle: float) -> tuple[tuple[float, float], ...]:
    c, s = math.cos(angle), math.sin(angle)
    corners = ((-w / 2, -d / 2), (w / 2, -d / 2), (w / 2, d / 2), (-w / 2, d / 2))
    return tuple((cx + x * c - y * s, cy + x * s + y * c) for x, y in corners)
