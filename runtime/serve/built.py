"""What the stand-in's scene editing builds: shapes and vision sensors, as plain data.

``scene_edit`` makes them from remote calls, ``mechanism_edit`` reads a mechanism back from
them; both import them from here, so neither imports the other for its data. ``read_shapes``,
``camera`` and ``robot_model`` read them back as labsim's walls, blocks, floor, ground, cameras
and the robots' models with the sensors built on them.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

from labsim.backends.coppeliasim import MODEL_PATHS
from labsim.backends.protocol import BackendError
from labsim.backends.scene.ground import Ground, Texture
from labsim.backends.scene.models import EPUCK, PIONEER_P3DX, Camera, GroundSensor, RobotModel
from labsim.backends.scene.world import Block, Wall
from labsim.runtime.serve.scene_tree import ROBOT_Z_M

_ROUND = 9  # coordinates to the nanometre: a world file's 0.6 comes back as 0.6
MAX_SIZE_M = 10_000.0  # a built shape's largest size: a room of 10 km is no lab's


@dataclass(eq=False)
class Shape:
    """A shape built through the remote API, in the world frame."""

    kind: str  # plane | cuboid | cylinder | mesh | texture
    size: tuple[float, float, float]
    corners: tuple[tuple[float, float], ...] = ()  # a mesh's outline at the floor
    x: float = 0.0
    y: float = 0.0
    z: float = 0.0
    yaw: float = 0.0
    alias: str = "Cuboid"
    static: bool = False
    respondable: bool = False  # robots collide with it (a static or respondable shape is an obstacle)
    png: bytes = b""  # a textured plane's picture (sim.createTexture)
    px: tuple[int, int] = (0, 0)  # its width and height in pixels


@dataclass(eq=False)
class Sensor:
    """A vision sensor built through the remote API: it becomes its robot's camera, or one of
    its ground sensors when its alias is one (``robot_model``)."""

    resolution: tuple[int, int]
    angle_rad: float  # the view angle, across the larger side
    robot: int = -1  # the robot it was parented to
    matrix: list[float] = field(default_factory=list)  # its pose in the robot's frame
    alias: str = "visionSensor"


def primitive(kind: str, sizes: list[float], args: list[Any], alias: str) -> Shape:
    """A shape of sim.createPrimitiveShape(type, sizes, options); its options (CoppeliaSim 4.6
    manual): bit 3 respondable, bit 4 static."""
    options = args[2] if len(args) > 2 and isinstance(args[2], int) and not isinstance(args[2], bool) else 0
    return Shape(kind, (sizes[0], sizes[1], sizes[2]), alias=alias, static=bool(options & 16),
                 respondable=bool(options & 8))


def rounded(v: float) -> float:
    """A coordinate as the stand-in keeps it: rounded to _ROUND digits, never -0.0."""
    return round(v, _ROUND) + 0.0  # + 0.0: no -0.0


Bounds = tuple[float, float, float, float]


def read_shapes(shapes: dict[int, Shape], bodies: dict[int, str]
                ) -> tuple[tuple[Wall, ...], tuple[Block, ...], Bounds | None, Ground | None, float | None]:
    """Walls, blocks, the floor's bounds, the painted ground and the floor's height the built
    shapes make (``bodies``: the handles that are a mechanism's, not obstacles)."""
    walls: list[Wall] = []
    blocks: list[Block] = []
    bounds: Bounds | None = None
    ground: Ground | None = None
    floor_z: float | None = None
    for h, s in shapes.items():
        c, si = math.cos(s.yaw), math.sin(s.yaw)
        if s.kind == "texture":
            ground = _textured(s)
        elif s.kind == "plane":
            hw, hd = s.size[0] / 2, s.size[1] / 2
            bounds = (rounded(s.x - hw), rounded(s.y - hd), rounded(s.x + hw), rounded(s.y + hd))
            floor_z = s.z
        elif not (s.static or s.respondable) or h in bodies:
            continue  # robots pass through a non-respondable shape; a body is the mechanism's
        elif s.kind == "cuboid" and s.alias == "wall":
            half = (s.size[0] - s.size[1]) / 2
            walls.append(Wall((rounded(s.x - half * c), rounded(s.y - half * si)),
                              (rounded(s.x + half * c), rounded(s.y + half * si)), rounded(s.size[1])))
        elif s.kind == "cuboid":
            w, d = s.size[0], s.size[1]
            local = ((-w / 2, -d / 2), (w / 2, -d / 2), (w / 2, d / 2), (-w / 2, d / 2))
            blocks.append(Block(tuple((rounded(s.x + x * c - y * si), rounded(s.y + x * si + y * c))
                                      for x, y in local)))
        elif s.kind == "cylinder":  # a fixed post: its footprint as a 16-sided block
            r = s.size[0] / 2
            blocks.append(Block(tuple((rounded(s.x + r * math.cos(k * math.pi / 8)),
                                       rounded(s.y + r * math.sin(k * math.pi / 8))) for k in range(16))))
        else:
            blocks.append(Block(tuple((rounded(s.x + x), rounded(s.y + y)) for x, y in s.corners)))
    return tuple(walls), tuple(blocks), bounds, ground, floor_z


def _textured(s: Shape) -> Ground:
    """The ground a textured plane shows: its picture, placed and scaled as the plane is."""
    import cv2
    import numpy as np

    bgr = cv2.imdecode(np.frombuffer(s.png, np.uint8), cv2.IMREAD_COLOR)
    assert bgr is not None  # sim.createTexture decoded it already
    b, g, r = (int(v) for v in bgr[0, 0])  # the margin around what is painted: the floor
    ppm = round(s.px[0] / s.size[0], 6)
    return Ground(floor_rgb=(r, g, b), px_per_m=ppm,
                  texture=Texture(s.png, rounded(s.x - s.size[0] / 2), rounded(s.y + s.size[1] / 2)))


def camera(s: Sensor) -> Camera:
    """A vision sensor's pose and optics as labsim's camera (see scene_builder.camera_matrix)."""
    m = s.matrix
    y_axis, z_axis = (m[1], m[5], m[9]), (m[2], m[6], m[10])
    pitch = math.asin(max(-1.0, min(1.0, -z_axis[2])))
    up = (math.sin(pitch), 0.0, math.cos(pitch))
    roll = math.atan2(-y_axis[1], sum(a * b for a, b in zip(y_axis, up)))
    w, h = s.resolution
    fov = s.angle_rad if w >= h else 2 * math.atan(math.tan(s.angle_rad / 2) * w / h)
    return Camera("camera", w, h, _deg(fov), rounded(m[11] + ROBOT_Z_M), _deg(pitch), rounded(m[3]), _deg(roll))


def _deg(v: float) -> float:
    return round(math.degrees(v), 6) + 0.0


# What sim.loadModel loads, by the file's name under models/robots/mobile/ (CoppeliaSim 4.6's
# resources): labsim's model of it, with only what the stock model has (the Pioneer's bumpers
# are labsim's, added by hand in a real scene: docs/coppeliasim.md).
LOADED_MODELS: dict[str, RobotModel] = {"pioneer p3dx.ttm": replace(PIONEER_P3DX, bumpers=()), "e-puck.ttm": EPUCK}


def robot_model(loaded: RobotModel, sensors: list[Sensor]) -> RobotModel:
    """A loaded robot with the vision sensors built on it. A sensor aliased as one of the
    model's ground sensors (``ePuck_groundSensor1..3``: ``MODEL_PATHS``) is that ground sensor,
    read where its matrix puts it; the others are cameras of a model whose cameras are found by
    alias (the Pioneer). An e-puck keeps its stock ``ePuck_camera``, and its ground sensors are
    only those built (the stock model has none)."""
    paths, stock_cameras = MODEL_PATHS[loaded.name]["ground"], MODEL_PATHS[loaded.name]["cameras"]
    assert isinstance(paths, dict)
    channel_of = {str(path).rsplit("/", 1)[-1]: channel for channel, path in paths.items()}
    grounds: dict[str, GroundSensor] = {}
    cameras: list[Camera] = []
    for s in sensors:
        if s.alias in channel_of:
            if s.resolution != (1, 1) or s.matrix[10] > -0.999:  # its z axis: the way it looks
                raise BackendError(f"the ground sensor {s.alias} is a 1 x 1 vision sensor looking down")
            channel = channel_of[s.alias]
            grounds[channel] = GroundSensor(channel, rounded(s.matrix[3]), rounded(s.matrix[7]))
        elif stock_cameras:  # the model names its own camera: no other is read
            raise BackendError(f"a {loaded.name} keeps its model's camera; a vision sensor aliased "
                               f"'{s.alias}' on it is neither that nor a ground sensor")
        else:
            cameras.append(camera(s))
    order = [channel for channel in paths if channel in grounds]
    return replace(loaded, cameras=loaded.cameras if stock_cameras else tuple(cameras),
                   ground_sensors=tuple(grounds[c] for c in order) if paths else loaded.ground_sensors)
