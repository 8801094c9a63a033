"""labsim.backends.pymunk: sonar geometry, differential drive, contacts, determinism, call order."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import pytest

from labsim.backends import load_backend
from labsim.backends.protocol import BackendError, BackendStateError, RobotRequest
from labsim.backends.pymunk.backend import PymunkBackend
from labsim.backends.scene.models import CONE_RAYS, PIONEER_P3DX, RobotModel
from labsim.backends.scene.world import Block, Pose, Wall, World

M = PIONEER_P3DX
R = M.wheel_radius_m
DT = 0.05
SONARS = tuple(s.name for s in M.sonars)
ALL = SONARS + ("x", "y", "heading", "collided")
FRONT = max(x for x, _ in M.footprint)  # robot origin to its front edge, 0.2095 m

FACE = 1.0  # the room's inner walls are at x, y = +-FACE
THICK = 0.1


def room(face: float = FACE, blocks: tuple[Block, ...] = ()) -> World:
    """A square room whose wall faces are at +-face; the walls overlap at the corners."""
    c = face + THICK / 2  # wall centre lines
    e = face + THICK  # wall ends, past the corners so they are closed
    walls = (
        Wall((-e, -c), (e, -c), THICK), Wall((c, -e), (c, e), THICK),
        Wall((e, c), (-e, c), THICK), Wall((-c, e), (-c, -e), THICK),
    )
    return World("room", "test room", (-face, -face, face, face), walls, blocks)


EMPTY = World("empty", "nothing at all", (-10.0, -10.0, 10.0, 10.0))


def req(pose: Pose, channels: tuple[str, ...] = ALL, name: str = "pioneer",
        model: RobotModel = M) -> RobotRequest:
    return RobotRequest(name, model, pose, channels)


def opened(world: World, *poses: Pose, channels: tuple[str, ...] = ALL, **kw: int) -> PymunkBackend:
    b = PymunkBackend(**kw)
    b.open(world, [req(p, channels, f"pioneer[{i}]") for i, p in enumerate(poses)], DT, seed=1)
    return b


def expected_in_room(pose: Pose, sonar_name: str, face: float = FACE) -> float:
    """Distance from a sonar's mount to the nearest face of ``room(face)`` its cone detects:
    the nearest first hit of its rays that meets the face within the incidence limit."""
    s = next(s for s in M.sonars if s.name == sonar_name)
    c, si = math.cos(pose.heading_rad), math.sin(pose.heading_rad)
    ox = pose.x_m + c * s.x_m - si * s.y_m
    oy = pose.y_m + si * s.x_m + c * s.y_m
    best = math.inf
    for angle in s.ray_angles_rad():
        a = pose.heading_rad + angle
        dx, dy = math.cos(a), math.sin(a)
        hits = []  # (distance, cosine of the angle between the ray and the face's normal)
        if abs(dx) > 1e-12:
            hits.append((((face if dx > 0 else -face) - ox) / dx, abs(dx)))
        if abs(dy) > 1e-12:
            hits.append((((face if dy > 0 else -face) - oy) / dy, abs(dy)))
        t, cos_incidence = min(hits)
        if t <= s.range_m and cos_incidence >= math.cos(math.radians(s.incidence_limit_deg)) - 1e-12:
            best = min(best, t)
    return best


def fan_distance(mount: tuple[float, float], axis_rad: float,
                 segments: list[tuple[tuple[float, float], tuple[float, float]]]) -> float:
    """A Pioneer sonar's reading by hand: the nearest hit of its cone's rays (30 degrees, from
    edge to edge) on these segments (world frame) that meets its segment within 45 degrees of
    the segment's normal; inf when none does within 1 m."""
    s = M.sonars[0]
    best = math.inf
    for k in range(CONE_RAYS):
        a = axis_rad + math.radians(-s.cone_deg / 2 + k * s.cone_deg / (CONE_RAYS - 1))
        dx, dy = math.cos(a), math.sin(a)
        first = (math.inf, 0.0)
        for (x1, y1), (x2, y2) in segments:
            ex, ey = x2 - x1, y2 - y1
            den = dx * ey - dy * ex
            if abs(den) < 1e-12:
                continue
            t = ((x1 - mount[0]) * ey - (y1 - mount[1]) * ex) / den  # along the ray
            u = ((x1 - mount[0]) * dy - (y1 - mount[1]) * dx) / den  # along the segment
            if t >= 0.0 and 0.0 <= u <= 1.0 and t < first[0]:
                first = (t, abs(dx * ey - dy * ex) / math.hypot(ex, ey))  # |cos| of the incidence
        if first[0] <= s.range_m and first[1] >= math.cos(math.radians(s.incidence_limit_deg)):
            best = min(best, first[0])
    return best


def run(b: PymunkBackend, ticks: int, left: float, right: float, robot: int = 0) -> None:
    b.act(robot, left, right)
    for _ in range(ticks):
        b.step()


# --- sonars -----------------------------------------------------------------------------------

def test_sonars_read_the_wall_distance_from_their_mount() -> None:
    pose = Pose(0.3, 0.2, 0.0)
    b = opened(room(), pose)
    got = dict(zip(ALL, b.sense()[0]))
    # By hand: sonar1 (+90 deg) sits at y = 0.2 + 0.1382 and looks straight at the wall face
    # at y = 1; sonar5 (-10 deg) sits at x = 0.3 + 0.2095, and its 30-degree cone (-25 to +5
    # deg) holds the perpendicular to x = 1, so it reads the wall's nearest point, as sonar4.
    assert got["sonar1"] == pytest.approx(1.0 - 0.3382, abs=0.01)
    assert got["sonar5"] == pytest.approx(1.0 - 0.5095, abs=0.01)
    assert got["sonar4"] == pytest.approx(1.0 - 0.5095, abs=0.01)
    assert got["sonar8"] == math.inf  # the wall below is 1.06 m away, beyond the 1 m range
    for name in SONARS:
        want = expected_in_room(pose, name)
        if want == math.inf:
            assert got[name] == math.inf, name
        else:
            assert got[name] == pytest.approx(want, abs=0.01), name
    b.close()


@pytest.mark.parametrize(
    "pose", [Pose(-0.2, 0.1, 2.0), Pose(0.35, -0.4, -0.7), Pose(0.0, 0.0, math.pi)]
)
def test_sonars_match_the_geometry_at_any_heading(pose: Pose) -> None:
    b = opened(room(), pose, channels=SONARS)
    readings = b.sense()[0]
    finite = 0
    for name, got in zip(SONARS, readings):
        want = expected_in_room(pose, name)
        if want == math.inf:
            assert got == math.inf, name
        else:
            finite += 1
            assert got == pytest.approx(want, abs=0.01), name
    assert finite >= 3  # the poses are chosen so that several sonars see a wall
    b.close()


def wall_facing(mount: tuple[float, float], direction_deg: float, distance_m: float, length_m: float,
                normal_deg: float | None = None) -> Wall:
    """A thin wall whose face's point in ``direction_deg`` from ``mount`` (world frame) is
    ``distance_m`` away; the face's normal points back along ``normal_deg`` (by default the
    direction itself, so the wall faces the mount squarely)."""
    thick = 0.02
    d = math.radians(direction_deg)
    n = math.radians(direction_deg if normal_deg is None else normal_deg)
    px, py = mount[0] + distance_m * math.cos(d), mount[1] + distance_m * math.sin(d)
    cx, cy = px + thick / 2 * math.cos(n), py + thick / 2 * math.sin(n)  # the wall's centre line
    tx, ty = -math.sin(n) * length_m / 2, math.cos(n) * length_m / 2
    return Wall((cx - tx, cy - ty), (cx + tx, cy + ty), thick)


def test_a_wall_off_the_axis_inside_the_cone_is_seen_at_its_distance() -> None:
    """A worked example on sonar4 (axis +10 degrees; cone 30 degrees, rays at -5, 2.5, 10,
    17.5 and 25 in the robot's frame). A short wall (12 cm) 12 degrees off the axis, 0.5 m
    from the mount and facing it, spans 15.2 to 28.8 degrees: the rays at 17.5 and 25 meet it,
    the nearer at 0.5 / cos(3 deg) (CoppeliaSim's exact nearest point: 0.5 m, 1.4 mm less). A
    single ray along the axis would miss it. 12 degrees the other side (-8.8 to 4.8) the rays
    at -5 and 2.5 meet it, -5 again 3 degrees from its normal. The same wall 25 degrees off
    the axis (28.2 to 41.8, or -21.8 to -8.2), outside the cone, is not seen at all."""
    s4 = M.sonars[3]
    mount, axis = (s4.x_m, s4.y_m), math.degrees(s4.angle_rad)
    for off, want in [(12.0, 0.5 / math.cos(math.radians(3.0))), (-12.0, 0.5 / math.cos(math.radians(3.0))),
                      (25.0, math.inf), (-25.0, math.inf)]:
        world = World("w", "one wall", (-3.0, -3.0, 3.0, 3.0), (wall_facing(mount, axis + off, 0.5, 0.12),))
        b = opened(world, Pose(0.0, 0.0, 0.0), channels=("sonar4",))
        assert b.sense()[0][0] == pytest.approx(want, abs=1e-9), off
        b.close()


def test_a_wall_met_more_obliquely_than_45_degrees_is_not_seen() -> None:
    """CoppeliaSim's limited angle detection: a long wall crossing sonar4's axis 0.5 m out,
    its normal 60 degrees off the axis, is met by every ray of the cone at 45 to 75 degrees:
    the edge ray at 25 degrees meets it at exactly 45 and counts; turned to 65 degrees it is
    met at 50 or more, and the sonar reads nothing, where a single ray would have read it."""
    s4 = M.sonars[3]
    mount, axis = (s4.x_m, s4.y_m), math.degrees(s4.angle_rad)
    for normal_off, seen in [(55.0, True), (65.0, False)]:
        wall = wall_facing(mount, axis, 0.5, 3.0, normal_deg=axis + normal_off)
        b = opened(World("w", "one wall", (-3.0, -3.0, 3.0, 3.0), (wall,)), Pose(0.0, 0.0, 0.0),
                   channels=("sonar4",))
        got = b.sense()[0][0]
        face = wall.a, wall.b  # the hand-made oracle on the wall's face, offset half a thickness
        nx, ny = math.cos(math.radians(axis + normal_off)), math.sin(math.radians(axis + normal_off))
        shifted = [((face[0][0] - 0.01 * nx, face[0][1] - 0.01 * ny), (face[1][0] - 0.01 * nx, face[1][1] - 0.01 * ny))]
        assert got == pytest.approx(fan_distance(mount, s4.angle_rad, shifted), abs=1e-6)
        assert (got < math.inf) is seen, normal_off
        b.close()


def test_a_block_is_seen() -> None:
    block = Block(((0.6, -0.3), (0.8, -0.3), (0.8, 0.3), (0.6, 0.3)))
    b = opened(room(blocks=(block,)), Pose(0.0, 0.0, 0.0), channels=("sonar4", "sonar5"))
    want = (0.6 - FRONT) / math.cos(math.radians(10))
    assert b.sense()[0] == [pytest.approx(want, abs=0.01), pytest.approx(want, abs=0.01)]


def test_nothing_in_range_reads_inf_and_the_own_body_is_invisible() -> None:
    b = opened(EMPTY, Pose(0.0, 0.0, 0.3), channels=SONARS)
    readings = b.sense()[0]
    assert readings == [math.inf] * len(SONARS)  # never 0, though every ray starts on the body
    assert all(isinstance(v, float) for v in readings)


def test_another_robot_is_detected() -> None:
    # B stands 1 m ahead of A, turned sideways: its left flank (a flat edge at 0.81 m from A's
    # origin) faces A, and A's front right corner region faces B's left-side sonar.
    a_pose, b_pose = Pose(0.0, 0.0, 0.0), Pose(1.0, 0.0, math.pi / 2)
    b = opened(EMPTY, a_pose, b_pose, channels=("sonar1", "sonar4", "sonar5"))
    ra, rb = b.sense()
    assert 0.6 < ra[1] < 0.7 and 0.6 < ra[2] < 0.7  # sonar4 / sonar5 see B's flank
    # B's sonar1 (+90 deg, pointing at world -x) starts at x = 1 - 0.1382, y = 0.1067; its
    # cone's rays meet A's outline, the nearest of them squarely enough to count.
    outline = [(M.footprint[k], M.footprint[(k + 1) % len(M.footprint)]) for k in range(len(M.footprint))]
    assert rb[0] == pytest.approx(fan_distance((1.0 - 0.1382, 0.1067), math.pi, outline), abs=0.005)
    alone = opened(EMPTY, a_pose, channels=("sonar1", "sonar4", "sonar5"))
    assert alone.sense() == [[math.inf] * 3]


def test_channels_come_back_in_the_requested_order() -> None:
    pose = Pose(0.3, 0.2, 0.0)
    b = opened(room(), pose, channels=("collided", "sonar5", "y", "sonar1", "x", "heading"))
    collided, s5, y, s1, x, heading = b.sense()[0]
    assert collided is False
    assert (x, y, heading) == (0.3, 0.2, 0.0)
    assert s5 == pytest.approx(expected_in_room(pose, "sonar5"), abs=0.01)
    assert s1 == pytest.approx(expected_in_room(pose, "sonar1"), abs=0.01)
    assert opened(room(), pose, channels=()).sense() == [[]]


# --- drive ------------------------------------------------------------------------------------

@pytest.mark.parametrize("substeps", [1, 4])
@pytest.mark.parametrize("heading", [0.0, 1.0])
def test_both_wheels_forward_drive_straight_ahead(heading: float, substeps: int) -> None:
    b = opened(EMPTY, Pose(0.5, -0.25, heading), substeps=substeps)
    w = 5.0
    run(b, round(1.0 / DT), w, w)
    x, y, h = b.pose(0)
    moved = R * w * 1.0
    assert math.hypot(x - 0.5, y + 0.25) == pytest.approx(moved, rel=0.01)
    assert x - 0.5 == pytest.approx(moved * math.cos(heading), abs=0.01 * moved)
    assert y + 0.25 == pytest.approx(moved * math.sin(heading), abs=0.01 * moved)
    assert h == pytest.approx(heading, abs=1e-9)
    assert b.sense()[0][-4:] == [x, y, h, False]


def test_opposite_wheels_turn_in_place_counter_clockwise_when_right_is_faster() -> None:
    b = opened(EMPTY, Pose(0.0, 0.0, 0.0))
    w = 2.0
    run(b, round(1.0 / DT), -w, w)
    x, y, h = b.pose(0)
    assert h == pytest.approx(R * 2 * w / M.axle_length_m, rel=0.01)  # 1.18 rad, CCW
    assert math.hypot(x, y) < 1e-9
    run(b, round(1.0 / DT), w, -w)  # and back, clockwise
    assert b.pose(0)[2] == pytest.approx(0.0, abs=1e-9)


def test_an_arc_turns_left_when_the_right_wheel_is_faster() -> None:
    b = opened(EMPTY, Pose(0.0, 0.0, 0.0))
    run(b, 10, 3.0, 4.0)
    x, y, h = b.pose(0)
    assert x > 0 and y > 0 and h == pytest.approx(R * 1.0 / M.axle_length_m * 0.5, rel=1e-6)


def test_heading_stays_wrapped() -> None:
    b = opened(EMPTY, Pose(0.0, 0.0, 3.0), channels=("heading",))
    b.act(0, -10.0, 10.0)  # 5.9 rad/s: more than a turn in the run below
    seen = []
    for _ in range(60):
        b.step()
        seen.append(b.sense()[0][0])
        assert seen[-1] == b.pose(0)[2]
    assert all(-math.pi < h <= math.pi for h in seen)
    assert min(seen) < -3 and max(seen) > 3  # it did cross the +-pi seam


# --- contacts ---------------------------------------------------------------------------------

def test_driving_into_a_wall_stops_there_and_counts_one_contact() -> None:
    b = opened(room(), Pose(0.0, 0.0, 0.0))
    b.act(0, 12.0, 12.0)  # 1.17 m/s; the wall face is 0.79 m ahead of the front edge
    for _ in range(30):
        b.step()
    assert b.sense()[0][-1] is True
    t_then = b.contacts(0).time_s
    assert t_then > 0
    for _ in range(70):  # keep pushing for 3.5 s
        b.step()
        x = b.pose(0)[0]
        assert x + FRONT <= FACE + 0.005  # does not sink into or pass through the wall
    assert x + FRONT > FACE - 0.01  # it is at the wall, not short of it
    stats = b.contacts(0)
    assert stats.count == 1
    assert stats.time_s == pytest.approx(t_then + 70 * DT, abs=1e-9)
    assert b.sense()[0][-1] is True

    run(b, 10, -5.0, -5.0)  # back off
    assert b.sense()[0][-1] is False
    left = b.contacts(0)
    run(b, 10, -5.0, -5.0)
    assert b.contacts(0) == left  # no new contact, no more contact time
    assert left.count == 1

    run(b, 30, 5.0, 5.0)  # and bump again: a second contact
    assert b.contacts(0).count == 2


def test_driving_into_a_corner_is_one_contact() -> None:
    # Straight into the corner: the chamfered front ends up against both walls at once.
    b = opened(room(), Pose(0.3, 0.3, math.pi / 4))
    run(b, 60, 8.0, 8.0)
    x, y, h = b.pose(0)
    assert x == pytest.approx(y, abs=1e-6) and x > 0.75
    assert h == pytest.approx(math.pi / 4, abs=1e-3)
    assert b.contacts(0).count == 1
    assert b.sense()[0][-1] is True


def test_two_robots_driven_into_each_other_collide() -> None:
    b = opened(EMPTY, Pose(-0.6, 0.0, 0.0), Pose(0.6, 0.0, math.pi))
    b.act(0, 5.0, 5.0)
    b.act(1, 5.0, 5.0)
    for _ in range(40):
        b.step()
    (xa, _, _), (xb, _, _) = b.pose(0), b.pose(1)
    assert xb - xa >= 2 * FRONT - 0.01  # they meet front to front and stop there
    for i in (0, 1):
        assert b.contacts(i).count == 1
        assert b.contacts(i).time_s > 0
        assert b.sense()[i][-1] is True


def test_contacts_survive_close() -> None:
    b = opened(room(), Pose(0.5, 0.0, 0.0))
    run(b, 10, 8.0, 8.0)
    stats = b.contacts(0)
    assert stats.count == 1
    b.close()
    assert b.contacts(0) == stats


# --- determinism ------------------------------------------------------------------------------

def _scenario(ticks: int = 200) -> list[list[list[object]]]:
    """Two robots wandering a room with a pillar, steering on their own sonars."""
    pillar = Block(((0.1, 0.3), (0.4, 0.3), (0.4, 0.6), (0.1, 0.6)))
    b = PymunkBackend()
    b.open(room(1.5, (pillar,)), [req(Pose(-0.8, -0.5, 0.4), name="a"),
                                  req(Pose(0.8, 0.2, 2.5), name="b")], DT, seed=3)
    history = []
    for tick in range(ticks):
        readings = b.sense()
        history.append(readings)
        for i, r in enumerate(readings):
            ahead = min(r[3], r[4])
            if ahead < 0.4:
                b.act(i, -3.0, 3.0)
            else:
                b.act(i, 6.0 + (tick % 7) * 0.5, 6.0 + (tick % 5) * 0.6)
        b.step()
    history.append([[b.contacts(i).count, b.contacts(i).time_s] for i in range(2)])
    b.close()
    return history


def _hexed(history: list) -> str:
    def enc(v: object) -> object:
        if isinstance(v, list):
            return [enc(e) for e in v]
        return float.hex(v) if isinstance(v, float) else v
    return json.dumps(enc(history))


def test_same_inputs_give_identical_readings() -> None:
    first, second = _scenario(), _scenario()
    assert first == second
    assert any(r[-1] is True for tick in first[:-1] for r in tick)  # it did bump into things


def test_identical_readings_in_another_process() -> None:
    here = __file__.rsplit("/", 1)[0]
    code = (
        f"import sys; sys.path[:0] = {[here] + sys.path!r}\n"
        "from test_backend_pymunk import _scenario, _hexed\n"
        "print(_hexed(_scenario()))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert out.strip() == _hexed(_scenario())


# --- call order and errors --------------------------------------------------------------------

CALLS = {
    "sense": lambda b: b.sense(),
    "act": lambda b: b.act(0, 1.0, 1.0),
    "step": lambda b: b.step(),
    "pose": lambda b: b.pose(0),
}


@pytest.mark.parametrize("call", sorted(CALLS))
def test_calls_before_open_raise(call: str) -> None:
    b = PymunkBackend()
    with pytest.raises(BackendStateError, match=f"{call}.*before open"):
        CALLS[call](b)


@pytest.mark.parametrize("call", sorted(CALLS))
def test_calls_after_close_raise(call: str) -> None:
    b = opened(room(), Pose(0.0, 0.0, 0.0))
    b.close()
    b.close()  # idempotent
    with pytest.raises(BackendStateError, match=f"{call}.*after close"):
        CALLS[call](b)


def test_contacts_before_open_and_open_twice_raise() -> None:
    b = PymunkBackend()
    with pytest.raises(BackendStateError):
        b.contacts(0)
    b.close()  # closing what was never opened is fine too
    b.open(room(), [req(Pose(0.0, 0.0, 0.0))], DT, seed=1)
    with pytest.raises(BackendStateError, match="twice"):
        b.open(room(), [req(Pose(0.0, 0.0, 0.0))], DT, seed=1)


def test_reopen_after_close_starts_afresh() -> None:
    b = opened(room(), Pose(0.5, 0.0, 0.0))
    run(b, 10, 8.0, 8.0)
    b.close()
    b.open(room(), [req(Pose(0.0, 0.0, 0.0))], DT, seed=1)
    assert b.pose(0) == (0.0, 0.0, 0.0)
    assert b.contacts(0).count == 0
    assert b.sense()[0][-1] is False


def test_unknown_channel_raises_naming_channel_and_robot() -> None:
    b = PymunkBackend()
    with pytest.raises(BackendError, match=r"pioneer\[1\].*'sonar17'") as info:
        b.open(room(), [
            req(Pose(0.0, 0.0, 0.0), name="pioneer[0]"),
            req(Pose(0.5, 0.0, 0.0), ALL + ("sonar17",), name="pioneer[1]"),
        ], DT, seed=1)
    assert not isinstance(info.value, BackendStateError)
    assert b.space is None  # nothing half-built
    b.open(room(), [req(Pose(0.0, 0.0, 0.0))], DT, seed=1)  # and it is still usable


def test_bad_options_raise() -> None:
    with pytest.raises(BackendError, match="substeps"):
        PymunkBackend(substeps=0)
    with pytest.raises(BackendError, match="dt_s"):
        PymunkBackend().open(room(), [req(Pose(0.0, 0.0, 0.0))], 0.0, seed=1)


def test_registered_as_the_default_backend() -> None:
    b = load_backend("pymunk", substeps=2)
    assert isinstance(b, PymunkBackend) and b.name == "pymunk" and b.substeps == 2


def test_public_space_and_bodies() -> None:
    b = opened(room(), Pose(0.1, 0.2, 0.3), Pose(-0.5, 0.0, 0.0))
    assert b.space is not None and len(b.bodies) == 2
    assert tuple(b.bodies[0].position) == (0.1, 0.2) and b.bodies[0].angle == 0.3
    assert all(body.space is b.space for body in b.bodies)
    b.close()
    assert b.space is None and b.bodies == []


# --- forward speed and road channels ----------------------------------------------------------

def road_compact() -> World:
    from labsim.backends.scene.world import builtin_worlds
    from labsim.backends.scene.world_file import load_world
    from labsim.foundation.diagnostics import Report
    world = load_world(builtin_worlds()["road_compact"], Report())
    assert world is not None
    return world


def test_forward_speed_is_the_velocity_along_the_heading() -> None:
    b = opened(EMPTY, Pose(0.0, 0.0, 2.0), channels=("forward_speed", "heading"))
    assert b.sense()[0][0] == 0.0
    run(b, 10, 6.0, 6.0)
    assert b.sense()[0][0] == pytest.approx(6.0 * R, rel=1e-9)
    run(b, 10, -4.0, -4.0)
    assert b.sense()[0][0] == pytest.approx(-4.0 * R, rel=1e-9)
    run(b, 10, -3.0, 3.0)  # turning on the spot: no speed along the heading
    assert b.sense()[0][0] == pytest.approx(0.0, abs=1e-9)
    run(b, 10, 3.0, 5.0)  # an arc: the mean of the wheels
    assert b.sense()[0][0] == pytest.approx(4.0 * R, rel=1e-6)


def test_forward_speed_against_a_wall_is_what_the_wall_leaves() -> None:
    b = opened(room(), Pose(0.0, 0.0, 0.0), channels=("forward_speed", "collided"))
    run(b, 60, 10.0, 10.0)  # long enough to reach the wall and push
    speed, collided = b.sense()[0]
    assert collided and abs(speed) < 0.05


def test_road_channels_on_and_off_the_road() -> None:
    world = road_compact()
    start = world.spawns[0]  # on the bottom straight, heading east
    left = Pose(start.x_m, start.y_m + 1.2, 0.0)
    right = Pose(start.x_m + 2.0, start.y_m - 0.3, 0.0)
    b = PymunkBackend()
    b.open(world, [req(p, ("road_offset", "on_road", "x"), f"p[{i}]") for i, p in enumerate((start, left, right))],
           DT, seed=1)
    (o0, on0, _), (o1, on1, _), (o2, on2, _) = b.sense()
    assert o0 == pytest.approx(0.0, abs=1e-9) and on0 is True
    assert o1 == pytest.approx(1.2) and on1 is False  # half the road is 1 m
    assert o2 == pytest.approx(-0.3) and on2 is True


def test_laps_counted_driving_round_the_loop() -> None:
    world = road_compact()
    road = world.ground.roads[0]
    b = PymunkBackend()
    b.open(world, [req(world.spawns[0], ("laps", "x", "y"))], DT, seed=1)
    body = b.bodies[0]
    # teleport the robot along the centreline, from the point after its start, tick by tick
    pts = list(road.points)
    k0 = min(range(len(pts)), key=lambda k: math.dist(pts[k], (world.spawns[0].x_m, world.spawns[0].y_m)))
    order = pts[k0 + 1:] + pts[:k0 + 1]
    seen = []
    for lap in range(2):
        for x, y in order[::3] + [order[-1]]:
            body.position = (x, y)
            b.step()
            seen.append(b.sense()[0][0])
        # the start spawn lies just past points[k0]: a little short of each lap
        assert b.sense()[0][0] == lap
        body.position = (world.spawns[0].x_m + 0.1, world.spawns[0].y_m)
        b.step()
        assert b.sense()[0][0] == lap + 1
    assert seen == sorted(seen)  # it never counted down
    # and backwards: back over the start counts down, and so does a whole loop backwards
    body.position = (world.spawns[0].x_m - 0.1, world.spawns[0].y_m)
    b.step()
    assert b.sense()[0][0] == 1
    for x, y in (order[::-3] + [order[0]]):
        body.position = (x, y)
        b.step()
    body.position = (world.spawns[0].x_m - 0.2, world.spawns[0].y_m)
    b.step()
    assert b.sense()[0][0] == 0


def test_road_channels_need_a_road() -> None:
    b = PymunkBackend()
    with pytest.raises(BackendError, match=r"'road_offset'.*no road") as info:
        b.open(room(), [req(Pose(0.0, 0.0, 0.0), ("x", "road_offset"))], DT, seed=1)
    assert "pioneer" in str(info.value)
    assert b.space is None
    with pytest.raises(BackendError, match=r"'laps'"):
        b.open(room(), [req(Pose(0.0, 0.0, 0.0), ("laps",))], DT, seed=1)


def test_sonar_only_sense_computes_nothing_else() -> None:
    b = opened(road_compact(), Pose(0.0, -4.0, 0.0), channels=("sonar5", "sonar8", "collided"))
    names = set(b._sim.sense.__code__.co_names)
    assert not names & {"render", "offset", "laps", "velocity"}
    assert b._sim._lap_robots == []  # and step() counts no laps
