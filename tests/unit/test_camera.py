"""labsim.backends.pymunk.camera: what a robot's camera sees of the ground, checked pixel by pixel."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from labsim.backends.protocol import BackendError, RobotRequest
from labsim.backends.pymunk.backend import PymunkBackend
from labsim.backends.pymunk.camera import SKY_RGB, GroundView, check_camera, draw_ground, ground_view
from labsim.backends.scene.ground import Ground, Line, Patch, Road
from labsim.backends.scene.models import PIONEER_P3DX, Camera
from labsim.backends.scene.world import Pose, World, builtin_worlds
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import Report

FLOOR = (205, 205, 200)
DARK = (25, 25, 25)
CAM = Camera("camera", 128, 128, fov_deg=60.0, height_m=0.4, pitch_deg=35.0, x_m=0.2)
STRAIGHT = Ground(FLOOR, roads=(Road(((-20.0, 0.0), (20.0, 0.0)), False, 0.4, DARK),))


def dark(img: np.ndarray) -> np.ndarray:
    return img.astype(int).sum(axis=2) < 3 * 115  # half-way between road and floor


def centroid(mask: np.ndarray) -> tuple[float, float]:
    """(column, row) mean of the true pixels."""
    rows, cols = np.nonzero(mask)
    assert len(cols), "nothing dark in the image"
    return float(cols.mean()), float(rows.mean())


def square(cx: float, cy: float, side: float, rgb: tuple[int, int, int] = DARK) -> Patch:
    h = side / 2
    return Patch(((cx - h, cy - h), (cx + h, cy - h), (cx + h, cy + h), (cx - h, cy + h)), rgb)


def project(x: float, y: float, heading: float, cam: Camera, gx: float, gy: float) -> tuple[float, float]:
    """Where a floor point appears in the image: (column, row) of a pixel index, pinhole model.

    Written from the definition, independently of the renderer's homography: the camera sits
    x_m ahead of the robot at height_m, looks along the heading, pitched down by pitch_deg.
    Rows count from the bottom of the picture, as CoppeliaSim's do.
    """
    ch, sh = math.cos(heading), math.sin(heading)
    p = math.radians(cam.pitch_deg)
    cx, cy, cz = x + cam.x_m * ch, y + cam.x_m * sh, cam.height_m
    v = (gx - cx, gy - cy, -cz)
    forward = (ch * math.cos(p), sh * math.cos(p), -math.sin(p))
    right = (sh, -ch, 0.0)
    up = (ch * math.sin(p), sh * math.sin(p), math.cos(p))

    def dot(a: tuple, b: tuple) -> float:
        return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]

    f = (cam.width_px / 2) / math.tan(math.radians(cam.fov_deg) / 2)
    z = dot(v, forward)
    return (cam.width_px / 2 + f * dot(v, right) / z - 0.5,
            cam.height_px / 2 + f * dot(v, up) / z - 0.5)


# --- what the image shows ---------------------------------------------------------------------

def test_image_shape_and_type() -> None:
    cam = dataclasses.replace(CAM, width_px=160, height_px=120)
    img = GroundView(STRAIGHT).render(0.0, 0.0, 0.0, cam)
    assert img.shape == (120, 160, 3) and img.dtype == np.uint8
    assert img.flags.writeable
    assert set(map(tuple, img.reshape(-1, 3))) >= {FLOOR, DARK}


def test_on_a_straight_road_the_road_is_centred() -> None:
    img = GroundView(STRAIGHT).render(1.0, 0.0, 0.0, CAM)
    mask = dark(img)
    assert abs(centroid(mask)[0] - (CAM.width_px - 1) / 2) < 2.0
    # its edges are in view: floor on both sides, road in the middle
    assert not mask[0, 0] and not mask[0, -1] and mask[0, 64]
    assert not mask[-1, 0] and not mask[-1, -1] and mask[-1, 64]
    # the road narrows towards the far edge, the last row (perspective)
    assert mask[-1].sum() < mask[-41].sum() < mask[0].sum()


def test_left_of_the_road_sees_it_in_the_right_half() -> None:
    view = GroundView(STRAIGHT)
    left = centroid(dark(view.render(1.0, 0.25, 0.0, CAM)))[0]  # 0.25 m left of the centreline
    right = centroid(dark(view.render(1.0, -0.25, 0.0, CAM)))[0]
    assert left > 64 + 10
    assert right < 63 - 10
    assert left + right == pytest.approx(127.0, abs=1.0)  # mirror images
    # the same holds for a road running any other way
    turned = Ground(FLOOR, roads=(Road(((0.0, 10.0), (0.0, -10.0)), False, 0.4, DARK),))  # heading south
    img = GroundView(turned).render(0.25, 1.0, -math.pi / 2, CAM)  # east of it: its left
    assert centroid(dark(img))[0] > 64 + 10


def test_the_near_edge_is_row_zero() -> None:
    rows = []
    for d in (0.7, 1.0, 1.5):
        view = GroundView(Ground(FLOOR, patches=(square(d, 0.0, 0.1),)))
        col, row = centroid(dark(view.render(0.0, 0.0, 0.0, CAM)))
        assert col == pytest.approx(63.5, abs=0.5)
        rows.append(row)
    assert rows[0] < rows[1] < rows[2]  # further ahead is higher in the picture: a later row


def test_left_is_column_zero() -> None:
    view = GroundView(Ground(FLOOR, patches=(square(1.0, 0.2, 0.1),)))  # ahead, to the left
    col, _ = centroid(dark(view.render(0.0, 0.0, 0.0, CAM)))
    assert col < 40


@pytest.mark.parametrize("pose", [(0.0, 0.0, 0.0), (2.0, -1.0, 1.0), (-3.0, 4.0, -2.5), (1.0, 1.0, math.pi)])
def test_patches_appear_where_the_pinhole_model_puts_them(pose: tuple[float, float, float]) -> None:
    x, y, heading = pose
    cam = dataclasses.replace(CAM, width_px=96, height_px=72, fov_deg=70.0, pitch_deg=40.0, x_m=0.15)
    ch, sh = math.cos(heading), math.sin(heading)
    # small patches, each at a known spot in the robot's frame (ahead, left)
    layout = [(0.6, 0.0), (0.8, 0.25), (1.2, -0.3), (0.5, -0.15)]
    for ahead, left in layout:
        gx, gy = x + ahead * ch - left * sh, y + ahead * sh + left * ch
        view = GroundView(Ground(FLOOR, patches=(square(gx, gy, 0.04),)))
        col, row = centroid(dark(view.render(x, y, heading, cam)))
        ec, er = project(x, y, heading, cam, gx, gy)
        assert (col, row) == pytest.approx((ec, er), abs=0.75), (ahead, left)


def test_known_layout_centroid() -> None:
    # two equal patches symmetric about the robot's axis: their centroid is on the centre column,
    # and on the row of their common distance
    view = GroundView(Ground(FLOOR, patches=(square(1.0, 0.3, 0.1), square(1.0, -0.3, 0.1))))
    img = view.render(0.0, 0.0, 0.0, CAM)
    col, row = centroid(dark(img))
    assert col == pytest.approx(63.5, abs=0.25)
    assert row == pytest.approx(project(0.0, 0.0, 0.0, CAM, 1.0, 0.0)[1], abs=0.75)


def test_painted_colours_lines_and_the_floor_beyond_the_texture() -> None:
    red = (200, 30, 30)
    g = Ground(FLOOR, lines=(Line((1.0, -3.0), (1.0, 3.0), 0.1, (255, 255, 255)),),
               patches=(square(0.7, 0.0, 0.1, red),))
    img = GroundView(g).render(0.0, 0.0, 0.0, CAM)
    _, r = project(0.0, 0.0, 0.0, CAM, 1.0, 0.0)
    assert tuple(img[round(r), 64]) == (255, 255, 255)  # the line across the view
    _, r = project(0.0, 0.0, 0.0, CAM, 0.7, 0.0)
    assert tuple(img[round(r), 64]) == red
    # far from anything painted, the camera sees plain floor
    assert (GroundView(g).render(50.0, 50.0, 0.3, CAM) == np.array(FLOOR, np.uint8)).all()


def test_a_bare_ground_is_plain_floor() -> None:
    img = GroundView(Ground((10, 20, 30))).render(1.0, 2.0, 3.0, CAM)
    assert (img == np.array((10, 20, 30), np.uint8)).all()


def test_the_texture_draws_roads_to_scale() -> None:
    for width in (0.8, 0.37):
        g = Ground(FLOOR, roads=(Road(((-1.0, 0.0), (1.0, 0.0)), False, width, DARK),))
        tex, _, _ = draw_ground(g)
        column = tex[:, tex.shape[1] // 2, 0].astype(float)
        covered_m = ((FLOOR[0] - column) / (FLOOR[0] - DARK[0])).sum() / g.px_per_m
        assert covered_m == pytest.approx(width, abs=0.003)


def test_ground_views_are_shared_and_read_only() -> None:
    g = Ground(FLOOR, roads=(Road(((0.0, 0.0), (1.0, 0.0)), False, 0.4, DARK),))
    assert ground_view(g) is ground_view(Ground(FLOOR, roads=(Road(((0.0, 0.0), (1.0, 0.0)), False, 0.4, DARK),)))
    with pytest.raises(ValueError):
        ground_view(g).texture[0, 0, 0] = 1


# --- cameras that cannot work -----------------------------------------------------------------

def test_a_camera_looking_at_the_horizon_sees_sky_above_it() -> None:
    from labsim.backends.pymunk.camera import SKY_RGB
    half = CAM.vertical_fov_deg / 2  # 30 degrees for a square 60-degree camera
    level = GroundView(STRAIGHT).render(0.0, 0.0, 0.0, dataclasses.replace(CAM, pitch_deg=0.0))
    h = CAM.height_px
    # looking straight ahead, the upper half (the last rows) is sky, the lower half floor and road
    assert (level[h // 2 + 1:] == SKY_RGB).all()
    assert not (level[: h // 2 - 1] == SKY_RGB).all(axis=2).any()
    tilted = GroundView(STRAIGHT).render(0.0, 0.0, 0.0, dataclasses.replace(CAM, pitch_deg=half + 5))
    assert not (tilted == SKY_RGB).all(axis=2).any()  # all floor once the top (last) row looks down
    with pytest.raises(ValueError, match="pitch_deg"):
        check_camera(dataclasses.replace(CAM, pitch_deg=-10.0))


@pytest.mark.parametrize("change, words", [
    ({"width_px": 0}, "width_px"), ({"height_px": 1.5}, "height_px"), ({"fov_deg": 180.0}, "fov_deg"),
    ({"height_m": 0.0}, "height_m"), ({"pitch_deg": 95.0}, "pitch_deg"), ({"x_m": math.nan}, "x_m"),
])
def test_bad_cameras_are_refused(change: dict, words: str) -> None:
    with pytest.raises(ValueError, match=words):
        check_camera(dataclasses.replace(CAM, **change))


def test_looking_straight_down() -> None:
    cam = dataclasses.replace(CAM, pitch_deg=90.0, x_m=0.0, height_m=1.0)
    view = GroundView(Ground(FLOOR, patches=(square(0.3, 0.0, 0.05),)))  # ahead of the robot
    col, row = centroid(dark(view.render(0.0, 0.0, 0.0, cam)))
    assert col == pytest.approx(63.5, abs=0.5) and row > 63.5 + 10  # ahead is up in the picture


# --- speed --------------------------------------------------------------------------------------

# --- through the backend ------------------------------------------------------------------------

def road_world() -> World:
    world = load_world(builtin_worlds()["road_compact"], Report())
    assert world is not None
    return world


MODEL = dataclasses.replace(PIONEER_P3DX, cameras=(CAM,))


def test_backend_returns_the_camera_image_for_the_robots_pose() -> None:
    world = road_world()
    b = PymunkBackend()
    poses = world.spawns[:5]
    b.open(world, [RobotRequest(f"p[{i}]", MODEL, p, ("camera", "x")) for i, p in enumerate(poses)], 0.05, 1)
    b.act(0, 4.0, 5.0)
    for _ in range(5):
        b.step()
    readings = b.sense()
    view = ground_view(world.ground)
    for i, (img, x) in enumerate(readings):
        px, py, ph = b.pose(i)
        assert x == px
        assert np.array_equal(img, view.render(px, py, ph, CAM))
        # every robot starts on the road, heading along it: it sees road straight ahead
        assert dark(img)[0, 64]
    assert readings[0][0] is not readings[1][0]


def test_backend_camera_in_a_world_without_ground_sees_the_floor() -> None:
    b = PymunkBackend()
    b.open(World("bare", "", (-5.0, -5.0, 5.0, 5.0)), [RobotRequest("p", MODEL, Pose(0.0, 0.0, 0.0), ("camera",))],
           0.05, 1)
    img = b.sense()[0][0]
    assert img.shape == (128, 128, 3) and len(set(map(tuple, img.reshape(-1, 3)))) == 1


def test_backend_renders_only_when_a_camera_is_read() -> None:
    world = road_world()
    b = PymunkBackend()
    b.open(world, [RobotRequest("p", MODEL, world.spawns[0], ("sonar5", "x"))], 0.05, 1)
    assert "render" not in b._sim.sense.__code__.co_names  # the generated sense() never draws
    b.close()
    b.open(world, [RobotRequest("p", MODEL, world.spawns[0], ("camera",))], 0.05, 1)
    assert "render" in b._sim.sense.__code__.co_names


def test_backend_refuses_a_camera_it_cannot_render() -> None:
    bad = dataclasses.replace(PIONEER_P3DX, cameras=(dataclasses.replace(CAM, pitch_deg=-10.0),))
    b = PymunkBackend()
    with pytest.raises(BackendError, match=r"robot 'p'.*camera 'camera'.*pitch_deg"):
        b.open(road_world(), [RobotRequest("p", bad, Pose(0.0, -4.0, 0.0), ("camera",))], 0.05, 1)
    assert b.space is None
    # not read, not checked: the model may carry a camera the behaviour ignores
    b.open(road_world(), [RobotRequest("p", bad, Pose(0.0, -4.0, 0.0), ("x",))], 0.05, 1)


# --- roll -------------------------------------------------------------------------------------

def test_a_camera_rolled_180_sees_the_image_turned_upside_down() -> None:
    view = GroundView(Ground(FLOOR, patches=(square(1.0, 0.2, 0.1),)))  # ahead, to the left
    plain = view.render(0.0, 0.0, 0.0, CAM)
    turned = view.render(0.0, 0.0, 0.0, dataclasses.replace(CAM, roll_deg=180.0))
    diff = np.abs(turned.astype(int) - plain[::-1, ::-1].astype(int))
    assert diff.max() <= 2  # the same floor sampled at the same points, within rounding


def test_a_camera_rolled_minus_90_puts_the_right_at_row_zero_and_the_far_at_the_right() -> None:
    cam = dataclasses.replace(CAM, roll_deg=-90.0)
    view = GroundView(Ground(FLOOR, patches=(square(1.0, 0.2, 0.1),)))  # ahead, to the left
    col, row = centroid(dark(view.render(0.0, 0.0, 0.0, cam)))
    assert row > 64 + 10  # left of the way ahead: the last rows (the top of the picture)
    right = GroundView(Ground(FLOOR, patches=(square(1.0, -0.2, 0.1),)))
    assert centroid(dark(right.render(0.0, 0.0, 0.0, cam)))[1] < 63 - 10
    near = GroundView(Ground(FLOOR, patches=(square(0.7, 0.0, 0.1),)))
    far = GroundView(Ground(FLOOR, patches=(square(1.5, 0.0, 0.1),)))
    assert centroid(dark(far.render(0.0, 0.0, 0.0, cam)))[0] > centroid(dark(near.render(0.0, 0.0, 0.0, cam)))[0]
    # the unrolled array turned a quarter anticlockwise (np.rot90): its right column becomes
    # row 0, its last row (the far edge) the right column; pixel for pixel, within rounding
    plain = view.render(0.0, 0.0, 0.0, CAM)
    assert np.abs(view.render(0.0, 0.0, 0.0, cam).astype(int) - np.rot90(plain).astype(int)).max() <= 2


def test_a_rolled_camera_sees_sky_beyond_its_horizon() -> None:
    cam = dataclasses.replace(CAM, pitch_deg=5.0, roll_deg=-90.0)
    img = GroundView(STRAIGHT).render(0.0, 0.0, 0.0, cam)
    plain = GroundView(STRAIGHT).render(0.0, 0.0, 0.0, dataclasses.replace(cam, roll_deg=0.0))
    assert np.abs(img.astype(int) - np.rot90(plain).astype(int)).max() <= 2
    assert (img[:, -1] == SKY_RGB).all() and (img[:, 0] != SKY_RGB).any()
