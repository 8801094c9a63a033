"""CoppeliaSim through its ZeroMQ remote API: the backend, and a stand-in server for it.

Two halves that meet on the wire (docs/coppeliasim.md):

* ``backend.CoppeliaSimBackend`` drives a real CoppeliaSim (4.6 or newer, the ZMQ remote API
  add-on running) with the unmodified client ``coppeliasim_zmqremoteapi_client``. The runtime
  reaches it through ``labsim.backends.protocol.Backend``, like the embedded backend.
* ``server.Server`` (``labsim serve``) answers the same protocol from labsim's pymunk backend,
  so the backend can be tested without CoppeliaSim, and scripts written for CoppeliaSim run
  against labsim.

This module holds only what both halves agree on: the scene object names of each robot model,
and the few CoppeliaSim constants both use. It imports nothing, so loading the package costs
nothing and needs neither pyzmq nor cbor2.

The modules, client side: ``backend`` (the registered class: lifecycle and routing),
``connection`` (the client's socket, calls, round trips and error explanations), ``fleet``
(wheeled robots), ``mechanism`` (a world's mechanism, such as the tower crane). Server side:
``server`` (the wire loop), ``sim_api`` (the ``sim.*`` functions), ``simulation`` (the pymunk
backend behind the scene), ``scene_tree`` (objects and CoppeliaSim's path language). Both:
``frames`` (3D frames and odometry, pure maths).
"""
from __future__ import annotations

DEFAULT_PORT = 23000  # CoppeliaSim's default (before 4.8 adds the process id to it)

# CoppeliaSim's values (simConst.h): sim.handle_world, sim.handle_all, sim.handle_parent, and
# sim.simulation_stopped, sim.simulation_paused, sim.simulation_advancing_running. A client
# reads them from zmqRemoteApi.info; the backend falls back on these when a server omits one.
HANDLE_WORLD, HANDLE_ALL, HANDLE_PARENT = -1, -2, -11
STOPPED, PAUSED, RUNNING = 0x00, 0x08, 0x11

# Object paths of a model in a CoppeliaSim scene (CoppeliaSim 4.3+ aliases). ``robot`` is
# absolute, a template whose {i} is the robot's number among the robots of that model;
# the others are relative to the robot (resolved with the ``proxy`` option of sim.getObject)
# and ``sonar``'s {k} is sonar number - 1 (templates: scene/object_paths.py; channel sonar1 is
# ultrasonicSensor[0]). A camera channel ``c`` is ``cameras[c]`` (the behaviour's ``paths:
# {camera: ...}`` for the channel ``camera``); when neither names it, the backend looks for
# each alias of ``CAMERA_ALIASES`` under the robot, then for ``./c``.
# ``collision``: what sim.checkCollision tests the robot against; None is sim.handle_all.
# ``sonar`` may also use {n}, the sensor's number from 1 (the e-puck's ePuck_proxSensor1..8).
# ``bumpers`` and ``ground`` name a model's bumpers (proximity sensors of their reach: detected
# is pressed) and ground sensors (1 x 1 vision sensors looking down: sim.readVisionSensor's
# average intensity is the reflectance) by channel. CoppeliaSim's stock e-puck names its
# robot, motors, IR sensors and camera so (its own script: sim.getObjectHandle('ePuck_leftJoint'),
# 'ePuck_proxSensor'..i for i = 1..8, 'ePuck_camera'); it has no ground sensors, so
# ``ePuck_groundSensor1..3`` are labsim's names for the ones a scene adds. The Pioneer's stock
# model has no bumpers: ``bumper_front_left`` .. are labsim's names too.
MODEL_PATHS: dict[str, dict[str, object]] = {
    "pioneer_p3dx": {
        "robot": "/PioneerP3DX[{i}]",
        "left_motor": "./leftMotor",
        "right_motor": "./rightMotor",
        "sonar": "./ultrasonicSensor[{k}]",
        "cameras": {},  # found under CAMERA_ALIASES
        "collision": None,
        "bumpers": {f"bump_{end}_{side}": f"./bumper_{end}_{side}" for end in ("front", "back")
                    for side in ("left", "right")},
        "ground": {},
    },
    "epuck": {
        "robot": "/ePuck[{i}]",
        "left_motor": "./ePuck_leftJoint",
        "right_motor": "./ePuck_rightJoint",
        "sonar": "./ePuck_proxSensor{n}",
        "cameras": {"camera": "./ePuck_camera"},
        "collision": None,
        "bumpers": {},
        "ground": {f"ground{n}": f"./ePuck_groundSensor{n}" for n in (1, 2, 3)},
    },
}

# The alias CoppeliaSim gives a new vision sensor (Add > Vision sensor, or sim.createVisionSensor):
# ``visionSensor`` from CoppeliaSim 4.8 on, ``Vision_sensor`` in 4.3 to 4.7 (docs/coppeliasim.md
# has the table). The backend tries them in this order; the stand-in names its cameras with the
# last, as the 4.6 and 4.7 servers it answers for do.
CAMERA_ALIASES = ("visionSensor", "Vision_sensor")


def camera_alias(model: str, channel: str) -> str:
    """The alias of a robot's camera object for a camera channel (``camera`` -> Vision_sensor)."""
    cameras = MODEL_PATHS.get(model, {}).get("cameras", {})
    path = cameras.get(channel) if isinstance(cameras, dict) else None
    if path is None:
        return CAMERA_ALIASES[-1] if model in MODEL_PATHS and channel == "camera" else channel
    return str(path).rsplit("/", 1)[-1]


def lidar_signals(i: int) -> tuple[str, str]:
    """The string signals that carry the lidar of the i-th robot of its model (docs/coppeliasim.md):
    the points CoppeliaSim's stock 2D laser scanners publish (``sim.packFloatTable`` of x, y, z
    in the sensor's frame, one triple a beam that detects something), then every beam's range
    in beam order (``sim.packDoubleTable``, inf where nothing is in range), which the backend reads.
    The first robot's carry the stock names; the next ones' end in their number."""
    suffix = str(i) if i else ""
    return f"measuredDataAtThisTime{suffix}", f"labsimLidarRanges{suffix}"
