"""Camera images in CoppeliaSim's row order: row 0 is the bottom of the picture, everywhere a
behaviour or a script reads an image; only what shows a picture to a person turns it upright."""
from __future__ import annotations

import base64

import cv2
import numpy as np
import pytest
from helpers import BEHAVIOURS

from labsim.backends import ground_camera
from labsim.backends.scene.ground import Ground, Patch
from labsim.backends.scene.models import Camera, upright
from labsim.backends.scene.world import builtin_worlds
from labsim.backends.scene.world_file import load_world
from labsim.dsl.compile import compile_file
from labsim.dsl.library import images
from labsim.foundation.diagnostics import Report
from labsim.runtime.pictures.camera_strip import shots
from labsim.runtime.trace import read_trace, trace_world
from labsim.runtime.view.frames import png_data_url

ROAD = BEHAVIOURS / "road_follow.golden.csv"
FLOOR = (205, 205, 200)
CAM = Camera("camera", 64, 48, fov_deg=60.0, height_m=0.4, pitch_deg=35.0, x_m=0.2)


def marked(rows: int = 6, cols: int = 8) -> np.ndarray:
    """A black RGB image whose row 0 is red."""
    img = np.zeros((rows, cols, 3), np.uint8)
    img[0] = (255, 0, 0)
    return img


def decode(url: str) -> np.ndarray:
    data = base64.b64decode(url.split(",", 1)[1])
    return cv2.imdecode(np.frombuffer(data, np.uint8), cv2.IMREAD_UNCHANGED)


def test_upright_puts_row_zero_at_the_bottom() -> None:
    img = marked()
    shown = upright(img)
    assert (shown[-1] == (255, 0, 0)).all() and not shown[:-1].any()
    assert np.array_equal(upright(shown), img)  # one flip, nothing else


def test_the_near_floor_is_row_zero() -> None:
    # a dark patch just ahead of the camera's view, and one far ahead: rows count from the bottom
    def row_of(ahead_m: float) -> float:
        g = Ground(FLOOR, patches=(Patch(((ahead_m - 0.05, -0.05), (ahead_m + 0.05, -0.05),
                                          (ahead_m + 0.05, 0.05), (ahead_m - 0.05, 0.05)), (20, 20, 20)),))
        rows, _ = np.nonzero(ground_camera(g)(0.0, 0.0, 0.0, CAM).sum(axis=2) < 300)
        assert len(rows)
        return float(rows.mean())

    assert row_of(0.6) < CAM.height_px / 2 < row_of(1.4)


@pytest.mark.parametrize("image", [marked(), marked()[..., 0] > 0, marked()[..., 0]])
def test_the_live_view_shows_images_upright(image: np.ndarray) -> None:
    url = png_data_url(image)
    assert url is not None
    shown = decode(url)
    bright = shown.reshape(shown.shape[0], shown.shape[1], -1).max(axis=2) > 0
    assert bright[-1].all() and not bright[:-1].any()  # row 0 drawn as the picture's bottom


def test_the_camera_strip_shows_frames_upright() -> None:
    trace = read_trace(ROAD)
    world, note = trace_world(trace)
    assert world is not None, note
    camera, frames = shots(trace, "pioneer[0]", world)
    render = ground_camera(world.ground)
    for shot in frames[:2]:
        seen = render(shot.x_m, shot.y_m, shot.heading_rad, camera)
        # the ground alone: the strip also shows pioneer[1] ahead, a few dozen pixels of it
        upright = (shot.image == cv2.cvtColor(np.ascontiguousarray(seen[::-1]), cv2.COLOR_RGB2BGR)).all(axis=2)
        wrong = (shot.image == cv2.cvtColor(np.ascontiguousarray(seen), cv2.COLOR_RGB2BGR)).all(axis=2)
        b, g, r = (shot.image[..., k].astype(int) for k in range(3))
        robot = (r > 120) & (g < 60) & (b < 60)
        assert not (~upright & ~robot).any()  # only the robot differs from the ground seen upright
        assert (~wrong & ~robot).any()  # the test can tell the two apart


def script_cy(img: np.ndarray) -> float:
    """The original road-following script's steps, on the image as CoppeliaSim hands it."""
    gray = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    _, thresh = cv2.threshold(gray, 20, 225, 0)
    m = cv2.moments(thresh)
    return float(m["m01"] / m["m00"]) if m["m00"] else 64.0


@pytest.mark.parametrize("side_m, turn", [(0.6, "right"), (-0.6, "left")])
def test_the_road_labs_rows_steer_an_unmodified_script_back_to_the_road(side_m: float, turn: str) -> None:
    """A robot left of the road's centreline must turn right: 64 - cy < 0, so that the lab's
    wheels (v - angle/180 v, v + angle/180 v) turn it right, and the other way round. The
    behaviour's centroid reads the same cy from the same array."""
    world = load_world(builtin_worlds()["road_loop"], Report())
    assert world is not None and world.ground is not None
    camera = road_camera()
    start = world.spawns[0]  # on the bottom straight, heading east: left is +y
    img = ground_camera(world.ground)(start.x_m, start.y_m + side_m, start.heading_rad, camera)
    cy = script_cy(img)
    assert (64 - cy < -2) if turn == "right" else (64 - cy > 2), cy
    assert images.centroid(images.threshold(img, 20))[1] == pytest.approx(cy, abs=1e-9)


def road_camera() -> Camera:
    """The road lab's camera, as its behaviour file declares it."""
    program = compile_file(ROAD.parent / "road_follow.yaml")
    model = program.robots[0].model
    assert model.cameras and model.cameras[0].roll_deg == -90.0
    return model.cameras[0]
