"""``labsim scene``: a behaviour's scene built in a running CoppeliaSim, through its ZMQ remote API.

Where it sits: the runtime's ``scene_cmd`` compiles the behaviour, works out the robots'
start poses as a run would, and hands the world and the robots to ``build``, which drives the
unmodified client through the backend's ``connection.Connection``. ``labsim serve --empty``
(``scene_edit``) answers the same calls, so the whole path is tested without CoppeliaSim.

What it builds, each call one CoppeliaSim 4.6 documents in its API reference (the version is
cited at each call):

* the simulation time step set to the behaviour's ``dt``;
* the floor: a plane the size of the world's bounds (not respondable: CoppeliaSim's own
  floor carries the robots), aliased ``labsimFloor``; a world that paints its floor (roads,
  lines) gets a second plane just above it, textured with labsim's own drawing of that
  ground (the picture its cameras see, ``labsim.backends.pymunk.camera.draw_ground``, written
  to a PNG), aliased ``labsimGround``;
* each wall a static, respondable cuboid aliased ``wall``: as long as the wall plus its
  thickness (labsim's walls have rounded ends), as high as the world says (``Wall.height_m``,
  the height labsim's own cameras see); each block a static
  cuboid aliased ``block`` when it is a rectangle, else a prism (``sim.createMeshShape``);
* one stock model per robot (CoppeliaSim's own ``models/robots/mobile/pioneer p3dx.ttm`` or
  ``e-puck.ttm``, ``sim.loadModel``), its script removed (it drives the wheels itself and
  would fight labsim's commands), at the robot's start pose;
* each camera of a Pioneer a vision sensor with the behaviour's resolution, field of view,
  mount, pitch and roll, under its robot, aliased ``Vision_sensor`` (the name the labs' scenes
  and scripts use); an e-puck's camera is its model's own ``ePuck_camera``;
* each ground sensor of an e-puck (the stock model has none) a 1 x 1 vision sensor under it,
  looking down from just above the floor at the sensor's point, aliased
  ``ePuck_groundSensor1..3`` (the names the backend reads, ``MODEL_PATHS``).

A world's mechanism (the crane) is ``mechanism_builder``'s: bodies as primitive shapes, joints
in the modes its motors take, force sensors, gravity and damping, with labsim's names.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from labsim.backends.coppeliasim import CAMERA_ALIASES, MODEL_PATHS
from labsim.backends.coppeliasim import fleet_script as fs
from labsim.backends.coppeliasim.connection import Connection
from labsim.backends.protocol import BackendError, RobotRequest
from labsim.backends.scene.models import Camera, GroundSensor
from labsim.backends.scene.world import Block, Wall, World
from labsim.runtime.builder.mechanism import build_mechanism

# Each model's file under CoppeliaSim's resources folder, and what the log calls it
MODEL_FILES = {"pioneer_p3dx": "models/robots/mobile/pioneer p3dx.ttm", "epuck": "models/robots/mobile/e-puck.ttm"}
MODEL_LABELS = {"pioneer_p3dx": "Pioneer P3DX", "epuck": "e-puck"}
GROUND_SENSOR_Z_M = 0.005  # a ground sensor's height above the floor: under the chassis, over the tape


def unsupported(world: World) -> str:
    """Why ``build`` cannot build ``world``, or "" (every world can be built now)."""
    return ""


def build(conn: Connection, world: World, robots: Sequence[RobotRequest], dt_s: float,
          save: str | None = None, log: Callable[[str], None] = lambda line: None) -> None:
    """Build ``world`` and ``robots`` in the CoppeliaSim ``conn`` reaches (stopping it first)."""
    why = unsupported(world)
    if why:
        raise BackendError(f"labsim scene: {why}")
    other = next((r for r in robots if r.model is not None and r.model.name not in MODEL_FILES), None)
    if other is not None and other.model is not None:  # before anything is built
        raise BackendError(f"labsim scene: builds Pioneer P3DX and e-puck robots only, and robot '{other.name}' "
                           f"has model "
                           f"'{other.model.name}'; load its model into your scene by hand "
                           "(docs/coppeliasim.md names its objects) and run with --backend coppeliasim")
    unbuilt = _unbuilt_sensors(robots)
    if unbuilt:  # before anything is built: never a scene that silently lacks a sensor
        raise BackendError(f"labsim scene: {unbuilt}")
    conn.open(dt_s)
    try:
        conn.require_sim()
        conn.stop_running()
        sim = conn.sim
        # the time step as CoppeliaSim 4.6 to 4.10 set it: sim.setFloatParam(sim.floatparam_simulation_time_step,
        # dt) (coppeliaSimLib registers no sim.setSimulationTimeStep in any version)
        conn.call("sim.setFloatParam", sim.floatparam_simulation_time_step, dt_s)
        mech = world.mechanism
        if mech is None or mech.floor_z_m is not None:
            _floor(conn, world)
        if world.ground is not None and world.ground.extent() is not None:
            _ground(conn, world)
        for wall in world.walls:
            _wall(conn, wall)
        for block in world.blocks:
            _block(conn, block)
        walls, blocks = len(world.walls), len(world.blocks)
        log(f"labsim scene: the floor, {walls} wall{'s' * (walls != 1)} and {blocks} block{'s' * (blocks != 1)}")
        if mech is not None:
            log(build_mechanism(conn, mech))
        for req in robots:
            _robot(conn, req)
        if robots:
            log(f"labsim scene: {_counted(robots)}, their scripts removed")
        if robots or mech is not None:
            log(_fleet_script(conn))
        if save:
            try:
                conn.call("sim.saveScene", save)  # sim.saveScene(string filename): CoppeliaSim 4.6
            except BackendError as e:
                raise BackendError(f"labsim scene: the scene is built, but saving it as {save} failed: {e}") from None
            log(f"labsim scene: saved {save}")
    finally:
        conn.close()


def _unbuilt_sensors(robots: Sequence[RobotRequest]) -> str:
    """Why a robot's sensors cannot all be built, naming the first sensor that cannot, or ""."""
    for req in robots:
        model = req.model
        assert model is not None
        if model.lidars:
            beams = model.lidars[0].beams
            return (f"robot '{req.name}' has a lidar (lidar1..lidar{beams}), and labsim scene builds no laser "
                    f"scanner: the scene would read nothing in range on every beam. Add a scanner to your "
                    f"CoppeliaSim scene by hand that publishes every beam's range as the string signal "
                    f"'labsimLidarRanges' (docs/coppeliasim.md, \"A lidar's scan\"), or run the behaviour on the "
                    f"embedded backend")
        bumpers = [ch for ch in req.channels if ch in {b.name for b in model.bumpers}]
        if bumpers and model.name == "pioneer_p3dx":
            return (f"robot '{req.name}' reads {bumpers[0]}, and CoppeliaSim's Pioneer P3DX has no bumpers: "
                    f"labsim scene builds none. Add proximity sensors of 2 cm aliased bumper_front_left .. "
                    f"bumper_back_right under the robot by hand (docs/coppeliasim.md), or read its sonars")
    return ""


def _counted(robots: Sequence[RobotRequest]) -> str:
    """The robots built, by model: "5 Pioneer P3DX", "1 e-puck (3 ground sensors added)"."""
    parts = []
    for name, label in MODEL_LABELS.items():
        mine = [r.model for r in robots if r.model is not None and r.model.name == name]
        grounds = sum(len(m.ground_sensors) for m in mine) if MODEL_PATHS[name]["ground"] else 0
        if mine:
            parts.append(f"{len(mine)} {label}" + (f" ({grounds} ground sensors added)" if grounds else ""))
    return " and ".join(parts)


def _static(conn: Connection, h: int, alias: str, respondable: bool = True) -> None:
    sim = conn.sim
    # sim.setObjectInt32Param(int objectHandle, int parameterID, int parameter): CoppeliaSim 4.6
    conn.call("sim.setObjectInt32Param", h, sim.shapeintparam_static, 1)
    conn.call("sim.setObjectInt32Param", h, sim.shapeintparam_respondable, int(respondable))
    conn.call("sim.setObjectAlias", h, alias)  # sim.setObjectAlias(int objectHandle, string alias): 4.6


def _place(conn: Connection, h: int, x: float, y: float, z: float, yaw: float) -> None:
    # sim.setObjectPosition(int objectHandle, list position, int relativeTo): CoppeliaSim 4.6
    # (4.5 and later take the position before the frame)
    conn.call("sim.setObjectPosition", h, [x, y, z], conn.world_h)
    if yaw:
        conn.call("sim.setObjectOrientation", h, [0.0, 0.0, yaw], conn.world_h)


def _cuboid(conn: Connection, sizes: list[float]) -> int:
    # sim.createPrimitiveShape(int primitiveType, list sizes, int options = 0): CoppeliaSim 4.6
    h = conn.call("sim.createPrimitiveShape", conn.sim.primitiveshape_cuboid, sizes, 0)
    return int(h)


def _floor(conn: Connection, world: World) -> None:
    xmin, ymin, xmax, ymax = world.bounds
    z = 0.0
    if world.mechanism is not None:  # bounds in the mechanism's plane (x, z): a square floor at its height
        ymin, ymax = (xmin - xmax) / 2, (xmax - xmin) / 2
        z = world.mechanism.floor_z_m or 0.0
    h = int(conn.call("sim.createPrimitiveShape", conn.sim.primitiveshape_plane, [xmax - xmin, ymax - ymin, 0.0], 0))
    _static(conn, h, "labsimFloor", respondable=False)
    _place(conn, h, (xmin + xmax) / 2, (ymin + ymax) / 2, z, 0.0)


def _ground(conn: Connection, world: World) -> None:
    """The painted floor: labsim's drawing of it as the texture of a plane just above the floor,
    sent as data: a CoppeliaSim on another machine cannot read a file on this one."""
    import numpy as np

    from labsim.backends.pymunk.camera import draw_ground

    assert world.ground is not None
    picture, xmin, ymax = draw_ground(world.ground)
    ppm = float(world.ground.px_per_m)
    height_px, width_px = picture.shape[:2]
    w, h = width_px / ppm, height_px / ppm
    # sim.createTexture(string fileName, int options, list planeSizes, list scalingUV, list xy_g,
    # int fixedResolution, list resolution): CoppeliaSim 4.6 to 4.10; an empty fileName makes a
    # plane of that size with a blank texture of that resolution, and returns the plane's
    # handle, the texture's id and its resolution (coppeliaSimLib simCreateTexture_internal)
    ret = conn.call("sim.createTexture", "", 0, [w, h], [w, h], [0.0, 0.0, 0.0], 0, [width_px, height_px])
    if not isinstance(ret, (list, tuple)) or len(ret) < 2:
        raise BackendError(f"labsim scene: sim.createTexture answered {ret!r}, not a plane and a texture id")
    plane, texture = int(ret[0]), int(ret[1])
    # sim.writeTexture(int textureId, int options, buffer data): RGB rows from the picture's top,
    # the order CoppeliaSim's own loader gives a texture read from a file (imgLoaderSaver.cpp)
    conn.call("sim.writeTexture", texture, 0, np.ascontiguousarray(picture, dtype=np.uint8).tobytes())
    _static(conn, plane, "labsimGround", respondable=False)
    _place(conn, plane, xmin + w / 2, ymax - h / 2, 0.001, 0.0)


def _wall(conn: Connection, wall: Wall) -> None:
    (ax, ay), (bx, by), t = wall.a, wall.b, wall.thickness_m
    length = math.hypot(bx - ax, by - ay)
    h = _cuboid(conn, [length + t, t, wall.height_m])
    _static(conn, h, "wall")
    _place(conn, h, (ax + bx) / 2, (ay + by) / 2, wall.height_m / 2, math.atan2(by - ay, bx - ax))


def _block(conn: Connection, block: Block) -> None:
    c = block.corners
    box = _rectangle(c)
    if box is not None:
        cx, cy, w, d, yaw = box
        h = _cuboid(conn, [w, d, block.height_m])
        _static(conn, h, "block")
        _place(conn, h, cx, cy, block.height_m / 2, yaw)
        return
    n = len(c)
    vertices = [v for x, y in c for v in (x, y, 0.0)] + [v for x, y in c for v in (x, y, block.height_m)]
    fan = ([k for i in range(1, n - 1) for k in (0, i + 1, i)]  # the bottom, facing down
           + [k for i in range(1, n - 1) for k in (n, n + i, n + i + 1)])  # the top
    sides = [k for i in range(n) for k in (i, (i + 1) % n, n + (i + 1) % n, i, n + (i + 1) % n, n + i)]
    # sim.createMeshShape(int options, float shadingAngle, list vertices, list indices): CoppeliaSim 4.6
    h = int(conn.call("sim.createMeshShape", 0, 0.0, vertices, fan + sides))
    _static(conn, h, "block")


def _rectangle(c: tuple[tuple[float, float], ...]) -> tuple[float, float, float, float, float] | None:
    """(centre x, y, width, depth, yaw) of a four-cornered block with right angles, else None."""
    if len(c) != 4:
        return None
    ex, ey = c[1][0] - c[0][0], c[1][1] - c[0][1]
    fx, fy = c[2][0] - c[1][0], c[2][1] - c[1][1]
    w, d = math.hypot(ex, ey), math.hypot(fx, fy)
    if w == 0 or d == 0 or abs(ex * fx + ey * fy) > 1e-9 * w * d:
        return None
    if abs(c[3][0] - (c[0][0] + fx)) > 1e-9 or abs(c[3][1] - (c[0][1] + fy)) > 1e-9:
        return None
    return ((c[0][0] + c[2][0]) / 2, (c[0][1] + c[2][1]) / 2, w, d, math.atan2(ey, ex))


def _fleet_script(conn: Connection) -> str:
    """The fleet's script (``fleet_script``) on a dummy aliased ``labsimFleet``: the backend then
    reads and drives the whole fleet in a few round trips a tick."""
    sim = conn.sim
    if not hasattr(sim, "addScript"):  # removed after 4.7 by script objects: the fleet goes per object
        return ("labsim scene: no fleet script (this CoppeliaSim has no sim.addScript); the backend drives "
                "the robots object by object")
    h = int(conn.call("sim.createDummy", 0.05))  # sim.createDummy(float size): CoppeliaSim 4.6
    conn.call("sim.setObjectAlias", h, fs.ALIAS)
    script = int(conn.call("sim.addScript", sim.scripttype_childscript))  # sim.addScript(int scriptType): 4.6
    # sim.setScriptStringParam(int scriptHandle, int parameterID, buffer parameter): 4.6
    conn.call("sim.setScriptStringParam", script, sim.scriptstringparam_text, fs.LUA)
    conn.call("sim.associateScriptWithObject", script, h)  # (int scriptHandle, int objectHandle): 4.6
    return f"labsim scene: the fleet script on /{fs.ALIAS} (a tick in a few round trips)"


def _robot(conn: Connection, req: RobotRequest) -> None:
    sim = conn.sim
    # sim.getStringParam(sim.stringparam_resourcesdir), sim.loadModel(string filename): CoppeliaSim 4.6
    assert req.model is not None
    resources = conn.call("sim.getStringParam", sim.stringparam_resourcesdir)
    h = int(conn.call("sim.loadModel", f"{resources}/{MODEL_FILES[req.model.name]}"))
    # The stock models' child scripts set the wheels' speeds every step (a Braitenberg
    # walk); labsim sends a wheel's target only when it changes, so the script would win.
    # sim.getScript(int scriptType, int objectHandle): CoppeliaSim 4.6, -1 when there is none;
    # sim.removeScript(int scriptHandle): CoppeliaSim 4.6.
    script = conn.call("sim.getScript", sim.scripttype_childscript, h)
    if isinstance(script, int) and script >= 0:
        conn.call("sim.removeScript", script)
    # sim.getObjectPosition / getObjectOrientation(int objectHandle, int relativeTo): 4.6
    _, _, z = conn.call("sim.getObjectPosition", h, conn.world_h)
    alpha, beta, _ = conn.call("sim.getObjectOrientation", h, conn.world_h)
    pose = req.pose
    conn.call("sim.setObjectPosition", h, [pose.x_m, pose.y_m, z], conn.world_h)
    conn.call("sim.setObjectOrientation", h, [alpha, beta, pose.heading_rad], conn.world_h)
    if not MODEL_PATHS[req.model.name]["cameras"]:  # else the model's own camera, named in MODEL_PATHS
        for camera in req.model.cameras:
            _camera(conn, h, z, camera)
    aliases = MODEL_PATHS[req.model.name]["ground"]
    assert isinstance(aliases, dict)
    for g in req.model.ground_sensors if aliases else ():
        _ground_sensor(conn, h, z, g, str(aliases[g.name]).rsplit("/", 1)[-1])


def _ground_sensor(conn: Connection, robot_h: int, robot_z: float, g: GroundSensor, alias: str) -> None:
    """A ground sensor: a 1 x 1 vision sensor under the robot, its z axis (the way it looks)
    straight down, GROUND_SENSOR_Z_M above the floor; sim.readVisionSensor's average intensity
    of its one pixel is the reflectance the backend reads."""
    # sim.createVisionSensor(int options, list intParams, list floatParams): CoppeliaSim 4.6;
    # options bit 1: perspective; near 1 mm, far 2 cm (the floor is 5 mm below), a 10 degree cone
    h = int(conn.call("sim.createVisionSensor", 2, [1, 1, 0, 0],
                      [0.001, 0.02, math.radians(10.0), 0.005, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
    conn.call("sim.setObjectAlias", h, alias)  # first: the stand-in tells a ground sensor by its alias
    conn.call("sim.setObjectParent", h, robot_h, True)  # (int objectHandle, int parent, bool keepInPlace): 4.6
    # turned half a turn about x: z down, y to the robot's right, x ahead (rows [x y z | position])
    matrix = [1.0, 0.0, 0.0, g.x_m, 0.0, -1.0, 0.0, g.y_m, 0.0, 0.0, -1.0, GROUND_SENSOR_Z_M - robot_z]
    conn.call("sim.setObjectMatrix", h, matrix, robot_h)  # (handle, matrix, relativeTo): 4.6


def _camera(conn: Connection, robot_h: int, robot_z: float, cam: Camera) -> None:
    """A vision sensor under the robot: it looks along its z axis, image up along its y axis."""
    near, far = 0.01, 10.0
    fov = math.radians(max(cam.fov_deg, cam.vertical_fov_deg))  # the angle spans the larger side
    # sim.createVisionSensor(int options, list intParams, list floatParams): CoppeliaSim 4.6;
    # options bit 1: perspective; intParams: resolution x, y, 0, 0; floatParams: near, far,
    # view angle, sensor size x, 0, 0, null pixel r, g, b, 0, 0
    h = int(conn.call("sim.createVisionSensor", 2, [cam.width_px, cam.height_px, 0, 0],
                      [near, far, fov, 0.02, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
    conn.call("sim.setObjectParent", h, robot_h, True)  # (int objectHandle, int parent, bool keepInPlace): 4.6
    conn.call("sim.setObjectMatrix", h, camera_matrix(cam, robot_z), robot_h)  # (handle, matrix, relativeTo): 4.6
    # the labs' own name (their scenes were made in CoppeliaSim 4.6-4.7), so a lab's script finds
    # the camera in a scene built here; the backend and the stand-in answer both names
    conn.call("sim.setObjectAlias", h, CAMERA_ALIASES[-1])


def camera_matrix(cam: Camera, robot_z: float) -> list[float]:
    """The sensor's pose in the robot's frame, as CoppeliaSim's 12-number matrix (rows of
    [x y z | position]): z forward and down by the pitch, y the image's up, turned by the roll."""
    p, r = math.radians(cam.pitch_deg), math.radians(cam.roll_deg)
    z_axis = (math.cos(p), 0.0, -math.sin(p))
    up = (math.sin(p), 0.0, math.cos(p))
    right = (0.0, -1.0, 0.0)
    # + roll turns the image's top towards the robot's right (labsim's Camera)
    y_axis = tuple(math.cos(r) * u + math.sin(r) * v for u, v in zip(up, right))
    x_axis = (y_axis[1] * z_axis[2] - y_axis[2] * z_axis[1], y_axis[2] * z_axis[0] - y_axis[0] * z_axis[2],
              y_axis[0] * z_axis[1] - y_axis[1] * z_axis[0])
    pos = (cam.x_m, 0.0, cam.height_m - robot_z)
    return [v for row in range(3) for v in (x_axis[row], y_axis[row], z_axis[row], pos[row])]
