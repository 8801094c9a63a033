"""Bumpers, ground sensors and the e-puck on the pymunk backend: worked examples with numbers."""
from __future__ import annotations

import math

import pytest

from labsim.backends.protocol import RobotRequest
from labsim.backends.pymunk.backend import PymunkBackend
from labsim.backends.pymunk.camera import luminance
from labsim.backends.scene.ground import Ground, Patch
from labsim.backends.scene.models import EPUCK, MODELS, PIONEER_P3DX, Kind, RobotModel
from labsim.backends.scene.world import Pose, Wall, World

FACE, THICK, DT = 1.0, 0.1, 0.05
BUMPERS = ("bump_front_left", "bump_front_right", "bump_back_left", "bump_back_right")


def room(ground: Ground | None = None) -> World:
    c, e = FACE + THICK / 2, FACE + THICK
    walls = (Wall((-e, -c), (e, -c), THICK), Wall((c, -e), (c, e), THICK),
             Wall((e, c), (-e, c), THICK), Wall((-c, e), (-c, -e), THICK))
    return World("room", "test room", (-FACE, -FACE, FACE, FACE), walls, ground=ground)


def opened(world: World, model: RobotModel, pose: Pose, channels: tuple[str, ...]) -> PymunkBackend:
    b = PymunkBackend()
    b.open(world, [RobotRequest("r", model, pose, channels)], DT, seed=1)
    return b


def test_the_models_offer_their_sensors_as_channel_kinds() -> None:
    assert set(MODELS) == {"pioneer_p3dx", "epuck"}
    p3dx = PIONEER_P3DX.channels()
    assert all(p3dx[b] is Kind.CONTACT for b in BUMPERS)
    epuck = EPUCK.channels()
    assert [c for c, k in epuck.items() if k is Kind.DISTANCE] == [f"prox{i}" for i in range(1, 9)]
    assert [c for c, k in epuck.items() if k is Kind.REFLECTANCE] == ["ground1", "ground2", "ground3"]
    assert epuck["camera"] is Kind.IMAGE


@pytest.mark.parametrize(("gap_m", "pressed"), [(0.01, True), (0.05, False)])
def test_the_front_bumpers_close_within_their_reach_of_a_wall(gap_m: float, pressed: bool) -> None:
    """The front switches sit 0.1909 m ahead of the axle and close within 2 cm."""
    x = FACE - 0.1909 - gap_m
    b = opened(room(), PIONEER_P3DX, Pose(x, 0.0, 0.0), BUMPERS)
    assert b.sense()[0] == [pressed, pressed, False, False]
    b.close()


def test_driving_into_a_wall_presses_the_front_bumpers_only() -> None:
    b = opened(room(), PIONEER_P3DX, Pose(0.0, 0.0, 0.0), (*BUMPERS, "collided"))
    b.act(0, 8.0, 8.0)
    seen = []
    for _ in range(60):  # 3 s at 0.78 m/s: into the wall at x = 1
        b.step()
        seen.append(b.sense()[0])
    assert seen[0] == [False] * 5 and seen[-1] == [True, True, False, False, True]
    b.close()


def test_a_ground_sensor_reads_the_brightness_of_the_floor_under_it() -> None:
    """A black patch under ground1 (left) only: the other two read the white floor."""
    ground = Ground(floor_rgb=(250, 250, 250), px_per_m=500.0,
                    patches=(Patch(((0.026, 0.006), (0.034, 0.006), (0.034, 0.014), (0.026, 0.014)), (20, 20, 20)),))
    b = opened(room(ground), EPUCK, Pose(0.0, 0.0, 0.0), ("ground1", "ground2", "ground3"))
    left, middle, right = b.sense()[0]
    assert left == pytest.approx(luminance(20, 20, 20), abs=1e-12)
    assert middle == right == pytest.approx(luminance(250, 250, 250), abs=1e-12)
    assert 0.07 < left < 0.08 and 0.97 < middle < 0.99
    b.close()
    bare = opened(room(), EPUCK, Pose(0.0, 0.0, 0.0), ("ground2",))  # no ground: the default floor
    assert bare.sense()[0][0] == pytest.approx(luminance(*Ground().floor_rgb))
    bare.close()


def test_the_epuck_drives_at_its_wheel_radius_and_turns_about_its_axle() -> None:
    b = opened(room(), EPUCK, Pose(0.0, 0.0, 0.0), ("x", "heading"))
    b.act(0, 6.24, 6.24)
    for _ in range(20):  # 1 s
        b.step()
    x, _ = b.sense()[0]
    assert x == pytest.approx(6.24 * 0.0205, rel=1e-6)  # 0.128 m/s, the e-puck's top speed
    b.act(0, -2.0, 2.0)
    for _ in range(20):
        b.step()
    _, heading = b.sense()[0]
    assert heading == pytest.approx(2 * 2.0 * 0.0205 / 0.052, rel=1e-6)  # 2 r w / axle, rad in 1 s
    b.close()


def test_the_epucks_ir_sensors_read_the_wall_ahead_and_its_camera_is_52_by_39() -> None:
    """prox3 and prox4 look 17 degrees either side of ahead, from the body's edge (r = 35 mm)."""
    x = FACE - 0.035 - 0.03
    b = opened(room(), EPUCK, Pose(x, 0.0, 0.0), ("prox3", "prox4", "prox1", "camera"))
    prox3, prox4, prox1, image = b.sense()[0]
    mount = 0.035 * math.cos(math.radians(17))
    assert prox3 == prox4 == pytest.approx((FACE - x - mount) / math.cos(math.radians(17)), abs=1e-9)
    assert prox1 == math.inf  # the side sensor sees nothing within its 7 cm
    assert image.shape == (39, 52, 3) and image.dtype == "uint8"
    b.close()
