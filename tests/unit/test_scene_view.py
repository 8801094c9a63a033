"""Cameras that see the scene (labsim.backends.pymunk.scene_view): where solids land in the
picture, which hides which, the same bytes every time, and the road lab's robot ahead."""
from __future__ import annotations

import dataclasses
import hashlib
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pymunk

from labsim.backends import load_backend
from labsim.backends.pymunk.camera import GroundView, camera_axes
from labsim.backends.pymunk.scene_view import SceneView, block_solid, robot_solid, scene_view, wall_solid
from labsim.backends.scene.ground import Ground
from labsim.backends.scene.models import PIONEER_P3DX, Camera, RobotModel
from labsim.backends.scene.world import Block, Wall, World
from labsim.foundation.diagnostics import Report
from labsim.runtime.run import compile_behaviour

FLOOR = (205, 205, 200)
GROUND = GroundView(Ground(FLOOR))
# Level, 90 degrees wide, 0.5 m up at the robot's origin: the focal length is 64 px, and a
# point at depth d, y_m to the left and z_m up lands at column 63.5 - 64 y / d, row
# 63.5 + 64 (z - 0.5) / d (row 0 the bottom).
LEVEL = Camera("camera", 128, 128, 90.0, 0.5, 0.0, 0.0)
ROAD_LAB = Path(__file__).resolve().parents[2] / "behaviours" / "road_follow.yaml"


def coloured(img: np.ndarray, camera: Camera | None = None) -> np.ndarray:
    """Where the image is not floor or sky: where it differs from the bare ground, which looks
    the same from every pose."""
    return (img != GROUND.render(0.0, 0.0, 0.0, camera or LEVEL)).any(axis=2)


def is_rgb(img: np.ndarray, rgb: tuple[int, int, int], tolerance: int = 0) -> np.ndarray:
    return (np.abs(img.astype(int) - rgb) <= tolerance).all(axis=2)


def body_at(x: float, y: float, angle: float = 0.0) -> pymunk.Body:
    body = pymunk.Body(1.0, 1.0)
    body.position, body.angle = (x, y), angle
    return body


def test_a_block_lands_at_the_rows_and_columns_its_projection_gives() -> None:
    # A 2 m wide wall of a block, 1 m high, its front face 3.9 m ahead: columns 63.5 -+ 64/3.9
    # (47.1 to 79.9), rows 63.5 + 64 (0 - 0.5)/3.9 = 55.3 to 63.5 + 64 (1 - 0.5)/3.9 = 71.7.
    block = Block(((3.9, -1.0), (4.1, -1.0), (4.1, 1.0), (3.9, 1.0)), 1.0, (40, 90, 200))
    img = SceneView(GROUND, [block_solid(block)]).render(0.0, 0.0, 0.0, LEVEL)
    rows, cols = np.nonzero(coloured(img))
    # OpenCV fills a pixel whose centre is within about half a pixel of the edge
    assert abs(rows.min() - 55.3) <= 1 and abs(rows.max() - 71.7) <= 1
    assert abs(cols.min() - 47.1) <= 1 and abs(cols.max() - 79.9) <= 1
    # its front face, square to the camera: 0.6 + 0.3 * cos(the angle to its first corner) of its colour
    shade = 0.6 + 0.3 * 3.9 / math.hypot(3.9, 1.0)
    expected = tuple(round(v * shade) for v in (40, 90, 200))
    assert is_rgb(img[60:68, 60:68].reshape(1, -1, 3), expected).all()  # type: ignore[arg-type]
    # turned a quarter to the left, the camera looks along +y and sees only floor
    assert not coloured(SceneView(GROUND, [block_solid(block)]).render(0.0, 0.0, math.pi / 2, LEVEL)).any()


def test_a_wall_is_a_box_of_its_thickness_and_height_and_a_camera_above_sees_its_top() -> None:
    wall = Wall((3.0, -2.0), (3.0, 2.0), 0.2, 0.3, (90, 90, 90))
    view = SceneView(GROUND, [wall_solid(wall)])
    img = view.render(0.0, 0.0, 0.0, LEVEL)
    rows, _ = np.nonzero(coloured(img))
    # front face at x = 2.9: from the floor (row 63.5 - 32/2.9 = 52.5) to 0.3 m (row 59.1); the
    # top, seen from 0.5 m, runs back to x = 3.1 (row 63.5 - 12.8/3.1 = 59.4): lighter
    assert abs(rows.min() - 52.5) <= 1 and abs(rows.max() - 59.4) <= 1
    assert is_rgb(img, (90, 90, 90)).any()  # the top, in the wall's own colour


def test_a_near_robot_hides_a_far_one_whatever_the_order() -> None:
    # a taller robot 0.6 m behind a Pioneer, its top showing over it
    camera = dataclasses.replace(LEVEL, fov_deg=40.0, height_m=1.0, pitch_deg=20.0)
    near_model = dataclasses.replace(PIONEER_P3DX, rgb=(0, 200, 0))
    far_model = dataclasses.replace(PIONEER_P3DX, height_m=0.6, rgb=(0, 0, 200))
    near, far = (body_at(1.6, 0.0, 0.3), near_model), (body_at(2.2, 0.05), far_model)

    def seen(*robots: tuple[pymunk.Body, RobotModel]) -> np.ndarray:
        return SceneView(GROUND, [], [(b, robot_solid(m)) for b, m in robots]).render(0.0, 0.0, 0.0, camera)

    alone_near, alone_far = seen(near), seen(far)
    both = coloured(alone_near, camera) & coloured(alone_far, camera)
    assert both.sum() > 100  # they overlap in the picture ...
    for img in (seen(near, far), seen(far, near)):
        assert np.array_equal(img[both], alone_near[both])  # ... and the near one is in front
        only_far = coloured(alone_far, camera) & ~coloured(alone_near, camera)
        assert np.array_equal(img[only_far], alone_far[only_far])  # the far one shows past it


def test_a_camera_does_not_see_its_own_robot_and_sees_the_others_where_they_are() -> None:
    robots = [(body_at(0.0, 0.0), robot_solid(PIONEER_P3DX)), (body_at(3.0, 0.0), robot_solid(PIONEER_P3DX))]
    view = SceneView(GROUND, [], robots)
    camera = dataclasses.replace(LEVEL, x_m=-0.5, height_m=0.1)  # behind robot 0, below its top
    mine = view.render(0.0, 0.0, 0.0, camera, 0)
    _, cols = np.nonzero(coloured(mine, camera))
    # robot 1 alone: 0.38 m wide, its near side 3.5 - 0.21 m from the camera: +-7.4 px
    assert abs(cols.mean() - 63.5) < 1 and cols.max() - cols.min() <= 2 * 64 * 0.19 / 3.29 + 2
    assert coloured(view.render(0.0, 0.0, 0.0, camera, -1), camera).sum() > coloured(mine, camera).sum()


def test_the_same_scene_gives_the_same_bytes() -> None:
    world = World("t", "", (-9.0, -9.0, 9.0, 9.0), walls=(Wall((4.0, -3.0), (4.0, 3.0), 0.1),),
                  blocks=(Block(((2.0, 0.5), (2.5, 0.5), (2.5, 1.0), (2.0, 1.0))),))
    camera = dataclasses.replace(LEVEL, pitch_deg=10.0, roll_deg=-20.0)
    robots = [(body_at(2.5, -0.6, 0.4), PIONEER_P3DX)]
    a = scene_view(GROUND, world, robots).render(0.1, -0.1, 0.05, camera)
    b = scene_view(GroundView(Ground(FLOOR)), world, robots).render(0.1, -0.1, 0.05, camera)
    assert a.tobytes() == b.tobytes() and coloured(a, camera).sum() > 500


FRAMES = """
import hashlib, sys
from pathlib import Path
from labsim.backends import load_backend
from labsim.runtime.run import compile_behaviour
run = compile_behaviour(Path(sys.argv[1])).bind(load_backend("pymunk"), warn=lambda m: None)
digest = hashlib.sha256()
for _ in range(3):
    for row in run.backend.sense():
        digest.update(row[0].tobytes())
    run.backend.step()
print(digest.hexdigest())
"""


def road_frames_digest() -> str:
    run = compile_behaviour(ROAD_LAB).bind(load_backend("pymunk"), warn=lambda m: None)
    digest = hashlib.sha256()
    for _ in range(3):
        for row in run.backend.sense():
            digest.update(row[0].tobytes())
        run.backend.step()
    run.close()
    return digest.hexdigest()


def test_road_lab_frames_are_the_same_in_another_process() -> None:
    other = subprocess.run([sys.executable, "-c", FRAMES, str(ROAD_LAB)], capture_output=True, text=True,
                           check=True)
    assert other.stdout.strip() == road_frames_digest()


def test_the_road_labs_first_robot_sees_the_robot_ahead_where_the_projection_puts_it() -> None:
    behaviour = compile_behaviour(ROAD_LAB)
    backend = load_backend("pymunk")
    run = behaviour.bind(backend, warn=lambda m: None)
    images = [row[0] for row in backend.sense()]
    camera = behaviour.program.models["pioneer"].cameras[0]
    (x0, y0, h0), (x1, y1, _) = backend.pose(0), backend.pose(1)
    run.close()
    # where robot 1's middle, half its height up, lands in robot 0's picture
    axes, f = camera_axes(camera)
    c, s = math.cos(h0), math.sin(h0)
    dx, dy = x1 - x0 - camera.x_m * c, y1 - y0 - camera.x_m * s
    q = axes.T @ np.array([c * dx + s * dy, -s * dx + c * dy, PIONEER_P3DX.height_m / 2 - camera.height_m])
    col = f * q[0] / q[2] + camera.width_px / 2 - 0.5
    row = camera.height_px / 2 - 0.5 - f * q[1] / q[2]
    red = (images[0][..., 0] > 120) & (images[0][..., 1] < 60)
    rows, cols = np.nonzero(red)
    assert len(rows) >= 10, "robot 0 does not see robot 1, 12.5 m ahead"
    assert abs(rows.mean() - row) < 2 and abs(cols.mean() - col) < 3
    # the road's threshold reads the red body as not-road (gray above 20)
    assert (images[0][red].astype(float) @ (0.299, 0.587, 0.114) > 20).all()
    for image in images[1:]:  # the others have no robot within sight
        assert not ((image[..., 0] > 120) & (image[..., 1] < 60)).any()


def test_world_file_heights_and_colours(tmp_path: Path) -> None:
    from labsim.backends.scene.world_file import load_world

    path = tmp_path / "w.yaml"
    path.write_text("labsim-world: 1\nwall_height: 1.5\nwalls:\n  - {from: [0, 0], to: [1, 0]}\n"
                    "  - {from: [0, 1], to: [1, 1], height: 0.3, color: [1, 2, 3]}\n"
                    "blocks:\n  - {center: [3, 3], size: [1, 1]}\n  - {center: [5, 5], size: [1, 1], height: 2}\n",
                    encoding="utf-8")
    world = load_world(path, Report())
    assert world is not None
    assert [(w.height_m, w.rgb) for w in world.walls] == [(1.5, (175, 175, 170)), (0.3, (1, 2, 3))]
    assert [b.height_m for b in world.blocks] == [0.5, 2.0]
    path.write_text("labsim-world: 1\nwalls:\n  - {from: [0, 0], to: [1, 0], height: -1}\n", encoding="utf-8")
    report = Report()
    assert load_world(path, report) is None
    (error,) = report.errors
    assert (error.line, error.col) == (3, 40) and "height" in error.message


def test_solids_across_the_pictures_edge_and_behind_the_camera_are_clipped() -> None:
    # a long wall across the view, its ends far outside the picture, and one beside and
    # behind the camera, reaching past its near plane
    across = Wall((2.0, -50.0), (2.0, 50.0), 0.1, 1.0, (90, 90, 90))
    beside = Wall((-3.0, 0.6), (1.5, 0.6), 0.1, 1.0, (60, 60, 60))
    img = SceneView(GROUND, [wall_solid(across), wall_solid(beside)]).render(0.0, 0.0, 0.0, LEVEL)
    drawn = coloured(img)
    assert drawn[64].all()  # the row at the camera's height: wall from edge to edge
    left = drawn[:, :20]
    assert left.all(axis=1).sum() > 60  # the wall beside fills the left edge over many rows


def test_culling_robots_out_of_reach_leaves_every_pixel_as_drawing_them_all() -> None:
    # A crowded road: 60 robots along the lab's road, jittered and turned, some nose to tail,
    # seen by each one's road camera. Without the cull every robot goes through the renderer's
    # scalar reach and frustum tests, as before the cull existed (an infinite radius passes
    # the vectorised test); with it, only those the vectorised test keeps.
    behaviour = compile_behaviour(ROAD_LAB)
    world, camera = behaviour.program.world, behaviour.program.models["pioneer"].cameras[0]
    road = world.ground.roads[0]
    rng = np.random.default_rng(3)
    picks = rng.choice(len(road.points), 60)
    bodies = [body_at(float(road.points[k][0] + rng.normal(0, 0.5)), float(road.points[k][1] + rng.normal(0, 0.5)),
                      float(rng.uniform(-math.pi, math.pi))) for k in picks]
    culled = scene_view(GroundView(world.ground), world, [(b, PIONEER_P3DX) for b in bodies])
    every = scene_view(GroundView(world.ground), world, [(b, PIONEER_P3DX) for b in bodies])
    every._radii = np.full(len(bodies), np.inf)
    poses = culled.poses()
    seen = 0
    for i, body in enumerate(bodies):
        x, y, a = body.position.x, body.position.y, body.angle
        image = culled.render(x, y, a, camera, i, poses)
        assert image.tobytes() == every.render(x, y, a, camera, i).tobytes(), f"robot {i}'s camera"
        seen += bool(is_rgb(image, PIONEER_P3DX.rgb, 60).any())
    assert seen >= 10  # crowded: many cameras do see other robots


def test_robots_of_one_model_projected_together_get_the_corners_each_gets_alone() -> None:
    # _draw projects all the robots of one shape a camera sees in one stacked product; each
    # must get the fixed-point corners, sides and shades the product of its pose alone gives.
    from labsim.backends.pymunk import scene_view as sv

    behaviour = compile_behaviour(ROAD_LAB)
    camera = behaviour.program.models["pioneer"].cameras[0]
    lens = sv._lens(camera)
    shape = sv._shape(robot_solid(PIONEER_P3DX))
    rng = np.random.default_rng(5)
    eye = (0.0, 0.0, camera.height_m)
    g = [tuple(r) for r in lens.axes_t]
    poses = [(float(rng.uniform(0.3, 12)), float(rng.uniform(-4, 4)), float(rng.uniform(-4, 4))) for _ in range(40)]
    together = sv._faces(shape, poses, g, eye, lens)
    for pose, (faces, _) in zip(poses, together):
        [(alone, _)] = sv._faces(shape, [pose], g, eye, lens)
        assert [(f.tobytes(), k, rgb) for f, k, rgb in faces] == [(f.tobytes(), k, rgb) for f, k, rgb in alone]
