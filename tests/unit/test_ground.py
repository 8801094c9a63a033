"""labsim.backends.scene.ground and the ground section of world files: road geometry, laps, errors."""
from __future__ import annotations

import collections
import math
from pathlib import Path

import pytest

from labsim.backends.scene.ground import ROAD_CHANNELS, Ground, Line, Patch, Road, RoadTracker
from labsim.backends.scene.models import Kind
from labsim.backends.scene.world import World, builtin_worlds, first_road, world_channels
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import Report

CHORD_M = 1e-3  # arcs are chords within 0.5 mm of their circle


def world_file(tmp_path: Path, ground: str, extra: str = "") -> Path:
    text = "labsim-world: 1\nname: t\nbounds: [-10, -10, 10, 10]\n" + extra + ground
    p = tmp_path / "w.yaml"
    p.write_text(text)
    return p


def load(tmp_path: Path, ground: str, extra: str = "") -> tuple[World | None, Report]:
    report = Report()
    return load_world(world_file(tmp_path, ground, extra), report), report


def errors(tmp_path: Path, ground: str) -> list[tuple[int, int, str]]:
    world, report = load(tmp_path, ground)
    assert world is None
    return [(d.line, d.col, d.message) for d in report.errors]


CIRCLE = """\
ground:
  roads:
    - width: 0.8
      closed: true
      path:
        - [2, 0]
        - {arc: {center: [0, 0], radius: 2, to_deg: 360}}
"""


# --- RoadTracker: offsets and positions ---------------------------------------------------------

def test_offset_on_a_straight_is_signed_left_positive() -> None:
    t = RoadTracker(Road(((0.0, 0.0), (10.0, 0.0)), False, 0.8))
    assert t.locate(5.0, 0.3) == pytest.approx((0.3, 5.0))
    assert t.locate(5.0, -0.2) == pytest.approx((-0.2, 5.0))
    assert t.offset(2.0, 0.0) == 0.0
    assert t.on_road(5.0, 0.4) and not t.on_road(5.0, -0.41)
    # the same road driven the other way: left and right swap, s runs from the other end
    back = RoadTracker(Road(((10.0, 0.0), (0.0, 0.0)), False, 0.8))
    assert back.locate(3.0, 0.3) == pytest.approx((-0.3, 7.0))


def test_offset_on_a_diagonal_straight() -> None:
    t = RoadTracker(Road(((0.0, 0.0), (3.0, 4.0)), False, 1.0))  # 5 m long, direction (0.6, 0.8)
    # 1 m along, then 0.5 m to the left (-0.8, 0.6)
    x, y = 0.6 - 0.4, 0.8 + 0.3
    assert t.locate(x, y) == pytest.approx((0.5, 1.0))
    assert t.length_m == pytest.approx(5.0)


@pytest.mark.parametrize("angle_deg", [0, 30, 90, 135, 200, 300, 359])
def test_offset_on_a_counter_clockwise_circle(tmp_path: Path, angle_deg: float) -> None:
    world, report = load(tmp_path, CIRCLE)
    assert world is not None, report.diagnostics
    t = RoadTracker(first_road(world))
    assert t.length_m == pytest.approx(4 * math.pi, abs=2e-3)  # chords are a little shorter
    a = math.radians(angle_deg)
    # driving counter-clockwise, the centre is on the left: inside is positive
    for r, expected in ((1.7, 0.3), (2.0, 0.0), (2.25, -0.25)):
        off, s = t.locate(r * math.cos(a), r * math.sin(a))
        assert off == pytest.approx(expected, abs=CHORD_M)
        # off the centreline, the nearest point of a chord is not quite radial: s shifts by up
        # to the offset times half a chord's angle
        assert s == pytest.approx(2 * a, abs=2e-3 if expected == 0 else 1e-2)


def test_offset_on_a_clockwise_arc(tmp_path: Path) -> None:
    world, report = load(tmp_path, """\
ground:
  roads:
    - width: 0.5
      path:
        - [0, 3]
        - {arc: {center: [0, 0], radius: 3, to_deg: 0}}
""")
    assert world is not None, report.diagnostics
    road = first_road(world)
    assert road.points[-1] == pytest.approx((3.0, 0.0))
    t = RoadTracker(road)
    a = math.radians(45)
    # clockwise: the centre is on the right, so inside is negative
    assert t.offset(2.6 * math.cos(a), 2.6 * math.sin(a)) == pytest.approx(-0.4, abs=CHORD_M)
    assert t.offset(3.1 * math.cos(a), 3.1 * math.sin(a)) == pytest.approx(0.1, abs=CHORD_M)
    assert t.locate(3 * math.cos(a), 3 * math.sin(a))[1] == pytest.approx(3 * math.pi / 4, abs=1e-3)


def test_offset_at_a_sharp_corner_uses_the_bisector() -> None:
    t = RoadTracker(Road(((0.0, 0.0), (1.0, 0.0), (1.0, 1.0)), False, 0.4))  # a left turn
    assert t.offset(1.5, -0.5) == pytest.approx(-math.sqrt(0.5))  # outside the corner: right
    assert t.offset(0.7, 0.2) == pytest.approx(0.2)  # inside: left
    assert t.offset(1.2, 0.5) == pytest.approx(-0.2)


def test_road_tracker_refuses_degenerate_roads() -> None:
    with pytest.raises(ValueError):
        RoadTracker(Road(((1.0, 1.0),), False, 0.8))
    with pytest.raises(ValueError):
        RoadTracker(Road(((1.0, 1.0), (1.0, 1.0)), True, 0.8))


# --- laps -------------------------------------------------------------------------------------

SQUARE = Road(((0.0, 0.0), (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)), True, 0.8)  # 16 m, counter-clockwise


def around(t: RoadTracker, robot: object, s_from: float, s_to: float, step: float = 0.5) -> None:
    """Move robot along the square's centreline from arc length s_from to s_to."""
    n = max(1, math.ceil(abs(s_to - s_from) / step))
    for i in range(1, n + 1):
        s = (s_from + (s_to - s_from) * i / n) % 16.0
        side, along = divmod(s, 4.0)
        x, y = [(along, 0.0), (4.0, along), (4.0 - along, 4.0), (0.0, 4.0 - along)][int(side)]
        t.update(robot, x, y + 0.05)  # a little off the centreline changes nothing


def test_laps_count_full_loops_forward_and_back() -> None:
    t = RoadTracker(SQUARE)
    t.start("a", 2.0, 0.0)  # starts at s = 2, half-way along the first side
    around(t, "a", 2.0, 17.9)
    assert t.laps("a") == 0  # 0.1 m short of a full loop
    around(t, "a", 17.9, 18.0)
    assert t.laps("a") == 1  # back at the start: one lap
    around(t, "a", 18.0, 2.0 + 16 * 2.5)
    assert t.laps("a") == 2
    assert t.progress_m("a") == pytest.approx(40.0)
    around(t, "a", 42.0, 2.0 + 16 * 0.5)  # driving backwards counts down
    assert t.laps("a") == 0
    assert t.progress_m("a") == pytest.approx(8.0)
    around(t, "a", 8.0, 1.0)  # backing up a little behind the start: still 0
    assert t.laps("a") == 0
    around(t, "a", 1.0, 2.0 - 16.0)
    assert t.laps("a") == -1


def test_laps_are_per_robot() -> None:
    t = RoadTracker(SQUARE)
    t.start(0, 0.0, 0.0)
    t.start(1, 4.0, 2.0)
    around(t, 0, 0.0, 16.5)
    assert (t.laps(0), t.laps(1)) == (1, 0)


def test_open_road_has_no_laps() -> None:
    t = RoadTracker(Road(((0.0, 0.0), (10.0, 0.0)), False, 0.8))
    t.start(0, 0.0, 0.0)
    for x in range(1, 11):
        t.update(0, float(x), 0.0)
    assert t.laps(0) == 0 and t.progress_m(0) == pytest.approx(10.0)


# --- channels ---------------------------------------------------------------------------------

def test_world_channels() -> None:
    bare = World("w", "", (-1.0, -1.0, 1.0, 1.0))
    assert world_channels(bare) == {}
    triangle = Patch(((0, 0), (1, 0), (1, 1)), (0, 0, 0))
    painted = World("w", "", (-1.0, -1.0, 1.0, 1.0), ground=Ground(patches=(triangle,)))
    assert world_channels(painted) == {}  # a ground without roads offers nothing
    road = World("w", "", (-1.0, -1.0, 1.0, 1.0), ground=Ground(roads=(SQUARE,)))
    assert world_channels(road) == {"road_offset": Kind.NUMBER, "on_road": Kind.BOOL, "laps": Kind.NUMBER}
    assert world_channels(road) == ROAD_CHANNELS
    assert first_road(road) is SQUARE


def test_ground_extent() -> None:
    g = Ground(roads=(Road(((0.0, 0.0), (2.0, 1.0)), False, 0.4),),
               lines=(Line((5.0, 0.0), (5.0, 2.0), 0.1, (255, 255, 255)),))
    assert g.extent() == pytest.approx((-0.2, -0.2, 5.05, 2.05))
    assert Ground().extent() is None


# --- the built-in road world ------------------------------------------------------------------

@pytest.mark.parametrize("name, width_m, length_m", [("road_loop", 3.0, 408.0), ("road_compact", 2.0, 123.0)])
def test_road_worlds(name: str, width_m: float, length_m: float) -> None:
    report = Report()
    world = load_world(builtin_worlds()[name], report)
    assert world is not None, [d.format() for d in report.diagnostics]
    ground = world.ground
    assert isinstance(ground, Ground) and len(ground.roads) == 1
    road = ground.roads[0]
    assert road.closed and road.width_m == width_m
    assert ground.floor_rgb[0] > 180 and road.rgb[0] < 50
    t = RoadTracker(road)
    assert t.length_m == pytest.approx(length_m, abs=1.0)
    # five spawns on the centreline, heading along the road, well apart, clear of the walls
    assert len(world.spawns) >= 5
    positions = []
    for p in world.spawns[:5]:
        off, s = t.locate(p.x_m, p.y_m)
        assert abs(off) < 1e-3
        ahead = t.locate(p.x_m + 0.05 * math.cos(p.heading_rad), p.y_m + 0.05 * math.sin(p.heading_rad))
        assert ahead[1] - s == pytest.approx(0.05, abs=1e-3) and abs(ahead[0]) < 1e-3
        assert world.clearance(p.x_m, p.y_m) > 2.0
        positions.append(s)
    positions.sort()
    gaps = [(b - a) % t.length_m for a, b in zip(positions, positions[1:] + positions[:1])]
    assert min(gaps) > 2.0
    # the whole road is well inside the walls
    assert min(world.clearance(x, y) for x, y in road.points) - road.width_m / 2 > 1.5


def road_radii(road: Road) -> list[float]:
    """Radii of the circles through consecutive triples of points (inf on straights)."""
    out = []
    pts = road.points
    n = len(pts)
    for i in range(n):
        (ax, ay), (bx, by), (cx, cy) = pts[i - 1], pts[i], pts[(i + 1) % n]
        cross = (bx - ax) * (cy - by) - (by - ay) * (cx - bx)
        if abs(cross) < 1e-12:
            out.append(math.inf)
            continue
        ab, bc, ca = math.dist((ax, ay), (bx, by)), math.dist((bx, by), (cx, cy)), math.dist((cx, cy), (ax, ay))
        out.append(ab * bc * ca / (2 * abs(cross)))
    return out


@pytest.mark.parametrize("name, radii_m", [("road_loop", {50, 55, 60}), ("road_compact", {10, 12, 15})])
def test_road_worlds_have_straights_and_curves_of_different_radii(name: str, radii_m: set[int]) -> None:
    road = first_road(load_world(builtin_worlds()[name], Report()))
    # the arcs' chords give their radius; a triple across an arc's end gives something between
    counts = collections.Counter(round(r) for r in road_radii(road) if r < 1000)
    assert {r for r, n in counts.items() if n >= 10} == radii_m
    segs = [math.dist(a, b) for a, b in zip(road.points, road.points[1:] + road.points[:1])]
    straights = [s for s in segs if s > 5.0]
    assert len(straights) == 4 and min(straights) >= 8.0


# --- world files: the ground section ----------------------------------------------------------

def test_ground_section_reads_every_kind(tmp_path: Path) -> None:
    world, report = load(tmp_path, """\
ground:
  floor: [200, 201, 202]
  px_per_m: 50
  roads:
    - width: 0.6
      color: [10, 20, 30]
      path: [[0, 0], [5, 0]]
  lines:
    - {from: [1, -1], to: [1, 1]}
    - {from: [2, -1], to: [2, 1], width: 0.1, color: [250, 250, 0]}
  patches:
    - {center: [3, 3], size: [2, 1], color: [200, 30, 30], angle_deg: 90}
""")
    assert world is not None, [d.format() for d in report.diagnostics]
    g = world.ground
    assert g.floor_rgb == (200, 201, 202) and g.px_per_m == 50
    assert g.roads == (Road(((0.0, 0.0), (5.0, 0.0)), False, 0.6, (10, 20, 30)),)
    assert g.lines[0] == Line((1.0, -1.0), (1.0, 1.0), 0.05, (255, 255, 255))
    assert g.lines[1].width_m == 0.1 and g.lines[1].rgb == (250, 250, 0)
    xs = sorted(round(c[0], 9) for c in g.patches[0].corners)
    ys = sorted(round(c[1], 9) for c in g.patches[0].corners)
    assert (xs[0], xs[-1], ys[0], ys[-1]) == (2.5, 3.5, 2.0, 4.0)  # turned by 90 degrees


def test_a_world_without_ground_has_none(tmp_path: Path) -> None:
    world, _ = load(tmp_path, "")
    assert world is not None and world.ground is None


def test_arc_points_lie_on_the_circle_and_close_the_loop(tmp_path: Path) -> None:
    world, _ = load(tmp_path, CIRCLE)
    road = first_road(world)
    assert road.closed and road.points[0] == (2.0, 0.0)
    # the path came back to its start, so the repeated point was dropped
    assert math.dist(road.points[-1], road.points[0]) > 0.01
    for x, y in road.points:
        assert math.hypot(x, y) == pytest.approx(2.0, abs=1e-12)
    # chords stay within 0.5 mm of the circle
    step = math.dist(road.points[0], road.points[1])
    assert 2.0 - math.sqrt(4.0 - (step / 2) ** 2) <= 0.0005


def test_arc_direction_follows_to_deg(tmp_path: Path) -> None:
    # from (0, -2) on a circle round the origin: the start angle is -90
    world, _ = load(tmp_path, """\
ground:
  roads:
    - {width: 0.5, path: [[0, -2], {arc: {center: [0, 0], radius: 2, to_deg: 0}}]}
    - {width: 0.5, path: [[0, -2], {arc: {center: [0, 0], radius: 2, to_deg: -180}}]}
""")
    ccw, cw = world.ground.roads
    assert ccw.points[-1] == pytest.approx((2.0, 0.0)) and ccw.points[1][0] > 0  # through x > 0
    assert cw.points[-1] == pytest.approx((-2.0, 0.0)) and cw.points[1][0] < 0


GROUND_ERRORS = [
    ("one point", """\
ground:
  roads:
    - width: 0.8
      path:
        - [1, 2]
""", (5, 9, "a road needs at least two points")),
    ("width zero", """\
ground:
  roads:
    - width: 0
      path: [[0, 0], [1, 0]]
""", (3, 14, "a road's width must be positive")),
    ("width negative", """\
ground:
  roads:
    - {width: -0.5, path: [[0, 0], [1, 0]]}
""", (3, 15, "a road's width must be positive")),
    ("colour out of range", """\
ground:
  roads:
    - width: 0.8
      color: [25, 25, 256]
      path: [[0, 0], [1, 0]]
""", (4, 23, "color must be three numbers 0..255: [red, green, blue]")),
    ("colour of two numbers", """\
ground:
  floor: [25, 25]
""", (2, 10, "floor must be three numbers 0..255: [red, green, blue]")),
    ("colour not numbers", """\
ground:
  patches:
    - {center: [0, 0], size: [1, 1], color: red}
""", (3, 45, "color must be three numbers 0..255: [red, green, blue]")),
    ("arc off its circle", """\
ground:
  roads:
    - width: 0.8
      path:
        - [3, -2.05]
        - {arc: {center: [3, 0], radius: 2, to_deg: 90}}
""", (6, 26, "the arc starts at the previous point (3, -2.05), which is 2.05 m from the centre, "
              "not on the circle of radius 2 (allowed: 1 cm)")),
    ("unknown road key", """\
ground:
  roads:
    - width: 0.8
      colour: [1, 2, 3]
      path: [[0, 0], [1, 0]]
""", (4, 7, "unknown key 'colour' in roads (did you mean 'color'?)")),
    ("unknown ground key", """\
ground:
  road:
    - width: 0.8
""", (2, 3, "unknown key 'road' in ground (did you mean 'roads'?)")),
    ("unknown arc key", """\
ground:
  roads:
    - width: 0.8
      path: [[0, 0], {arc: {centre: [0, 1], radius: 1, to_deg: 0}}]
""", (4, 29, "unknown key 'centre' in an arc (did you mean 'center'?)")),
    ("arc first", """\
ground:
  roads:
    - width: 0.8
      path:
        - {arc: {center: [0, 0], radius: 1, to_deg: 90}}
""", (5, 11, "an arc continues from the previous point: start the path with a point [x, y]")),
    ("missing width", """\
ground:
  roads:
    - path: [[0, 0], [1, 0]]
""", (3, 7, "a road needs 'width' (width: metres, path: a list of points [x, y] and arcs)")),
    ("closed with two points", """\
ground:
  roads:
    - {width: 0.8, closed: true, path: [[0, 0], [1, 0]]}
""", (3, 40, "a closed road needs at least three points")),
    ("px_per_m", """\
ground:
  px_per_m: 0
""", (2, 13, "px_per_m must be positive")),
    ("patch size", """\
ground:
  patches:
    - {center: [0, 0], size: [1, 0]}
""", (3, 30, "a patch's size must be positive")),
]


@pytest.mark.parametrize("ground, expected", [(g, e) for _, g, e in GROUND_ERRORS],
                         ids=[name for name, _, _ in GROUND_ERRORS])
def test_ground_errors_have_exact_positions(tmp_path: Path, ground: str, expected: tuple) -> None:
    # the world file's first three lines come before the ground section
    line, col, message = expected
    assert errors(tmp_path, ground) == [(line + 3, col, message)]


def test_every_ground_error_is_reported_at_once(tmp_path: Path) -> None:
    found = errors(tmp_path, """\
ground:
  floor: [1, 2]
  roads:
    - width: 0
      path: [[0, 0]]
  lines:
    - {from: [0, 0]}
""")
    assert [m for _, _, m in found] == [
        "floor must be three numbers 0..255: [red, green, blue]",
        "a road's width must be positive",
        "a road needs at least two points",
        "a line needs 'from: [x, y]' and 'to: [x, y]'",
    ]


def test_mechanism_key_goes_to_its_reader(tmp_path: Path) -> None:
    world, report = load(tmp_path, """\
mechanism:
  bodies:
    base: {center: [0, 0.5], size: [1, 1], static: true}
""")
    assert world is not None and world.mechanism is not None
    assert [b.name for b in world.mechanism.bodies] == ["base"] and not report.errors


def test_a_ground_too_large_to_render_is_an_error_with_the_px_per_m_that_fits(tmp_path: Path) -> None:
    # 2 km of road at 100 px/m would be a 200,000 px texture: said when the world loads, so
    # `labsim check` reports it, not the first camera frame
    (err,) = errors(tmp_path, """\
ground:
  px_per_m: 100
  roads:
    - width: 2
      path: [[0, 0], [2000, 0]]
""")
    line, col, message = err
    assert (line, col) == (5, 13)
    assert message.startswith("the ground would be a 200250 x 250 px texture (2002.5 x 2.5 m at 100 px/m)")
    fits = int(message.rsplit("px_per_m: ", 1)[1].split()[0])
    assert fits == 15  # 32,000 px a side / 2002.5 m, a little under
    world, report = load(tmp_path, f"""\
ground:
  px_per_m: {fits}
  roads:
    - width: 2
      path: [[0, 0], [2000, 0]]
""")
    assert world is not None and not report.errors
    # without px_per_m, the default's problem is pointed at the ground section itself
    (err,) = errors(tmp_path, """\
ground:
  roads:
    - width: 2
      path: [[0, 0], [2000, 0]]
""")
    assert err[:2] == (5, 3) and "px_per_m: 15 or less" in err[2]


def _scan(t: RoadTracker, x: float, y: float) -> tuple[int, float, float, float]:
    from labsim.backends.scene.ground import _closest

    return _closest(x, y, t._ax, t._ay, t._dx, t._dy, t._len2)


@pytest.mark.parametrize("closed", [True, False])
def test_the_index_finds_the_segment_a_scan_of_them_all_finds(closed: bool) -> None:
    # Bit for bit, the first of equals included: on the road, beside it, far off it, on its
    # points and on the cells' edges, where a wrong index would show.
    import numpy as np

    rng = np.random.default_rng(7)
    arc = [(20 * math.cos(a), 20 * math.sin(a)) for a in np.linspace(0, 1.5 * math.pi, 300)]
    road = Road(points=((-30.0, -30.0), (-10.0, -30.0), *arc, (-30.0, 20.0)), width_m=3.0, closed=closed)
    t = RoadTracker(road)
    assert t._cells
    points = [(float(x), float(y)) for x, y in rng.uniform(-40, 30, (3000, 2))]
    points += [(float(x) + float(dx), float(y) + float(dy)) for (x, y), (dx, dy)
               in zip(arc, rng.normal(0, 1.5, (len(arc), 2)))]
    points += [p for p in road.points] + [(2.0 * i, 2.0 * j) for i in range(-20, 15) for j in range(-20, 15)]
    points += [(-20.0, -30.0 + 1e-13), (-20.0, -32.0), (-20.0, -28.0)]  # on a cell's edge and the margin's
    for x, y in points:
        assert t._nearest(x, y) == _scan(t, x, y)


def test_a_road_of_long_diagonals_is_not_indexed_but_still_located() -> None:
    road = Road(points=((0.0, 0.0), (5000.0, 5000.0), (0.0, 9000.0)), width_m=3.0, closed=True)
    t = RoadTracker(road)
    assert not t._cells
    assert t.locate(2500.0, 2500.0) == pytest.approx((0.0, 2500 * math.sqrt(2)))
