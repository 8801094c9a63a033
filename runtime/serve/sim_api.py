"""The stand-in's ``sim.*`` functions: what ``labsim serve`` answers to each remote call.

Where it sits: the wire loop (``server``) decodes a request, finds its handler here by name
and encodes what it returns; a handler reads and drives the ``simulation``, finds objects in
its ``scene_tree``, and turns poses into CoppeliaSim's 3D frames with ``frames``. Every handler
takes the calling client and the request's arguments and returns the reply's values (the
``ret`` list), ``WAIT`` for ``sim.step``, or raises ``SimError`` with CoppeliaSim's own text
(``object does not exist.``), which the loop sends as ``{"err": "<text> (in function ...)"}``.
docs/coppeliasim.md lists what is offered and where it differs from CoppeliaSim.

Semantics kept from CoppeliaSim, and where the stand-in differs:

* Proximity and vision sensors report what the last step saw: before the first step after
  ``startSimulation`` a sonar detects nothing and an image is black. A sonar that sees nothing
  reads ``[0, 0.0, [0, 0, 0], -1, [0, 0, 0]]``; one that sees something ``[1, d, [0, 0, d], -1,
  [0, 0, 0]]``: the detected object's handle and the surface normal are not modelled.
* Orientations are yaw only (``[0, 0, yaw]``): the scene is flat. A mechanism's parts tilt in
  their vertical plane, turned by the slew, and are given in the world frame only. Robots
  can be placed (set position / orientation / pose) only while the simulation is stopped.
"""
from __future__ import annotations

import math
import time
from typing import cast

import numpy as np

from labsim.backends.coppeliasim import HANDLE_ALL, HANDLE_PARENT, HANDLE_WORLD, PAUSED, RUNNING, STOPPED
from labsim.backends.coppeliasim.frames import Pose3, plane_rotation, quaternion_yaw, seen_from, wrap, yaw_quaternion
from labsim.backends.scene.world import Pose
from labsim.runtime.serve import matrices as mx
from labsim.runtime.serve.scene_tree import SceneObject
from labsim.runtime.serve.sim_args import (
    E_ARGS,
    E_FEW,
    E_HANDLE,
    E_PATH,
    WAIT,
    Args,
    Handler,
    SimError,
    Wait,
    as_handle,
    crop,
    integer,
    num,
    shown,
    vec,
)
from labsim.runtime.serve.simulation import Client, Robot, Simulation

# Values from CoppeliaSim's simConst.h (see the reference notes); a client reads them from
# zmqRemoteApi.info, so scripts use the names (sim.handle_world), never the numbers.
CONSTANTS: dict[str, object] = {
    "handle_world": HANDLE_WORLD, "handle_all": HANDLE_ALL, "handle_self": -4,
    "handle_parent": HANDLE_PARENT, "handle_scene": -12, "handle_inverse": -14,
    "simulation_stopped": STOPPED, "simulation_paused": PAUSED, "simulation_advancing": 0x10,
    "simulation_advancing_firstafterstop": 0x10, "simulation_advancing_running": RUNNING,
    "simulation_advancing_lastbeforepause": 0x13, "simulation_advancing_firstafterpause": 0x14,
    "simulation_advancing_abouttostop": 0x15, "simulation_advancing_lastbeforestop": 0x16,
    "floatparam_rand": 0, "floatparam_simulation_time_step": 1,
}
# A sonar's axes in its yaw-only mount frame: x to the beam's left, y up, z along the beam
# (columns (0, 1, 0), (0, 0, 1), (1, 0, 0)), the frame readProximitySensor's point is in.
SENSOR_AXES = [0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]
FUNCTIONS = tuple(f"sim.{n}" for n in (
    "getObject", "getObjectHandle", "getObjectAlias", "getObjectParent",
    "setJointTargetVelocity", "getJointTargetVelocity", "setJointTargetPosition",
    "getJointTargetPosition", "getJointPosition", "getJointVelocity",
    "readProximitySensor", "readVisionSensor", "getVisionSensorImg", "getVisionSensorResolution", "readForceSensor",
    "getSimulationTime", "getSimulationState", "getSimulationTimeStep", "getFloatParam",
    "setStepping", "step", "startSimulation", "stopSimulation", "pauseSimulation",
    "getObjectPosition", "getObjectOrientation", "getObjectPose", "getObjectVelocity",
    "setObjectPosition", "setObjectOrientation", "setObjectPose", "checkCollision",
))

# Functions a CoppeliaSim script commonly calls that this stand-in does not offer: listed in
# zmqRemoteApi.info so that calling one gives a clear error rather than an AttributeError.
UNSUPPORTED = ("getBoolParam", "setBoolParam", "executeScriptString", "setFloatParam", "loadModel")

_MECHANISM = ("joint", "force", "body")



class SimApi:
    """The handlers, by remote name (``handlers()``), over one simulation."""

    def __init__(self, sim: Simulation) -> None:
        self.sim = sim
        self.tree = sim.tree

    def handlers(self) -> dict[str, Handler]:
        funcs: dict[str, Handler] = {
            name: getattr(self, "_sim_" + name.removeprefix("sim.")) for name in FUNCTIONS}
        funcs["zmqRemoteApi.require"] = self._require
        funcs["zmqRemoteApi.info"] = self._info
        return funcs

    def _obj(self, args: Args, i: int = 0, kinds: tuple[str, ...] = (), what: str = "") -> SceneObject:
        if len(args) <= i:
            raise SimError(E_FEW)
        obj = self.tree.objects.get(as_handle(args[i]))
        if obj is None:
            raise SimError(E_HANDLE)
        if kinds and obj.kind not in kinds:
            raise SimError(f"object is not a {what}.")
        return obj

    def _robot(self, obj: SceneObject) -> Robot:
        return self.sim.robots[obj.robot]

    # --- zmqRemoteApi ------------------------------------------------------------------------

    def _require(self, client: Client, args: Args) -> list[object]:
        name = args[0] if args else None
        if name != "sim":
            raise SimError(f"module '{shown(name)}' not found: labsim serve offers only 'sim'")
        return []

    def _info(self, client: Client, args: Args) -> list[object]:
        if not args or args[0] != "sim":
            raise SimError(f"labsim serve: no object '{shown(args[0] if args else None)}' (only 'sim')")
        info: dict[str, object] = {name.removeprefix("sim."): {"func": {}} for name in FUNCTIONS}
        info.update({name: {"func": {}} for name in UNSUPPORTED})
        info.update({name: {"const": value} for name, value in CONSTANTS.items()})
        return [info]

    # --- objects -----------------------------------------------------------------------------

    def _sim_getObject(self, client: Client, args: Args) -> list[object]:
        if not args:
            raise SimError(E_FEW)
        path = args[0]
        options = args[1] if len(args) > 1 and args[1] is not None else {}
        if not isinstance(path, str) or not isinstance(options, (dict, list)):
            raise SimError(E_ARGS)
        options = options if isinstance(options, dict) else {}  # an empty Lua table may arrive as []
        index = options.get("index", -1)
        proxy_h = options.get("proxy", -1)
        if not isinstance(index, int) or not isinstance(proxy_h, int):
            raise SimError(E_ARGS)
        proxy = self.tree.objects.get(proxy_h) if proxy_h != -1 else None
        if proxy_h != -1 and proxy is None:
            raise SimError(E_HANDLE)
        obj = self.tree.find(path, index, proxy)
        if obj is not None:
            return [obj.handle]
        if options.get("noError"):
            return [-1]
        old = self.tree.old_name(path)
        if old is not None:
            # CoppeliaSim 4.6's sim.getObject takes paths ("Accessing scene objects
            # programmatically"); a pre-4.3 name is for the deprecated sim.getObjectHandle
            raise SimError(f"{E_PATH} (labsim serve: '{path}' is an object name from before CoppeliaSim 4.3; "
                           f"sim.getObject takes a path: '{self.tree.path(old, short=True)}')")
        raise SimError(f"{E_PATH} (labsim serve: no object '{shown(path)}'; {self.tree.hint(path)})")

    def _sim_getObjectHandle(self, client: Client, args: Args) -> list[object]:
        """Deprecated since CoppeliaSim 4.3, kept in 4.6: a path, or a name from before 4.3."""
        old = self.tree.old_name(args[0]) if args and isinstance(args[0], str) else None
        return [old.handle] if old is not None else self._sim_getObject(client, args[:1])

    def _sim_getObjectAlias(self, client: Client, args: Args) -> list[object]:
        obj = self._obj(args)
        return [self.tree.alias(obj, integer(args, 1, -1))]

    def _sim_getObjectParent(self, client: Client, args: Args) -> list[object]:
        obj = self._obj(args)
        return [obj.parent.handle if obj.parent is not None else -1]

    # --- joints ------------------------------------------------------------------------------

    def _set_joint(self, obj: SceneObject, mode: str, value: float) -> None:
        motor = self.sim.joint_spec(obj).motor
        if motor is None:
            raise SimError(f"labsim serve: joint '{obj.name}' has no motor: it moves only as pushed")
        if not getattr(motor, mode, True):
            other = "position" if mode == "velocity" else "velocity"
            raise SimError(f"labsim serve: joint '{obj.name}' takes {other} targets only")
        self.sim.mech_targets[obj.name] = (mode, value)
        if self.sim.state != STOPPED:
            self.sim.mech_pending[obj.name] = (mode, value)
        else:  # the scene's value: kept into the next run, as CoppeliaSim keeps a joint's target
            self.sim.mech_scene[obj.name] = (mode, value)

    def _joint(self, args: Args) -> SceneObject:
        return self._obj(args, 0, ("motor", "joint"), "joint")

    def _sim_setJointTargetVelocity(self, client: Client, args: Args) -> list[object]:
        obj = self._joint(args)
        v = num(args, 1)
        if obj.kind == "motor":
            r = self._robot(obj)
            r.target[obj.index] = v
            if self.sim.state == STOPPED:
                r.scene_target[obj.index] = v
        else:
            self._set_joint(obj, "velocity", v)
        return []

    def _sim_getJointTargetVelocity(self, client: Client, args: Args) -> list[object]:
        obj = self._joint(args)
        if obj.kind == "motor":
            return [self._robot(obj).target[obj.index]]
        mode, value = self.sim.mech_targets.get(obj.name, ("velocity", 0.0))
        return [value if mode == "velocity" else 0.0]

    def _sim_setJointTargetPosition(self, client: Client, args: Args) -> list[object]:
        obj = self._joint(args)
        p = num(args, 1)
        if obj.kind == "motor":
            # CoppeliaSim keeps it and ignores it: the wheels' motors are in velocity mode
            self._robot(obj).target_pos[obj.index] = p
            return []
        self._set_joint(obj, "position", p)
        return []

    def _sim_getJointTargetPosition(self, client: Client, args: Args) -> list[object]:
        obj = self._joint(args)
        if obj.kind == "motor":
            return [self._robot(obj).target_pos[obj.index]]
        mode, value = self.sim.mech_targets.get(obj.name, ("velocity", 0.0))
        return [value if mode == "position" else self.sim.joint_state(obj)[0]]

    def _sim_getJointPosition(self, client: Client, args: Args) -> list[object]:
        obj = self._joint(args)
        if obj.kind == "motor":
            # Wheels are cyclic revolute joints: CoppeliaSim reports their angle in (-pi, pi].
            return [wrap(self._robot(obj).wheel[obj.index])]
        return [self.sim.joint_state(obj)[0]]

    def _sim_getJointVelocity(self, client: Client, args: Args) -> list[object]:
        obj = self._joint(args)
        if obj.kind == "motor":
            return [self._robot(obj).wheel_rate[obj.index]]
        return [self.sim.joint_state(obj)[1]]

    # --- sensors -----------------------------------------------------------------------------

    def _sim_readProximitySensor(self, client: Client, args: Args) -> list[object]:
        obj = self._obj(args, 0, ("sonar", "bumper"), "proximity sensor")
        d = self.sim.sensed(obj)
        if d is None or d == math.inf or d is False:  # not yet handled by a step, nothing seen, a bumper free
            return [0, 0.0, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]]
        dist = d if isinstance(d, float) else 0.0  # a bumper pressed: detected at no distance
        return [1, dist, self.sim.detected_point(obj, dist), -1, [0.0, 0.0, 0.0]]

    def _sim_readVisionSensor(self, client: Client, args: Args) -> list[object]:
        # a ground sensor: [result, auxPacket1], 15 values (min, max, mean of intensity r g b depth)
        v = self.sim.sensed(self._obj(args, 0, ("ground",), "vision sensor"))
        return [0, [v, v, v, v, 0.0] * 3] if isinstance(v, float) else [-1, []]

    def _sim_getVisionSensorImg(self, client: Client, args: Args) -> list[object]:
        obj = self._obj(args, 0, ("camera", "ground"), "vision sensor")
        options = integer(args, 1, 0)
        w, h = obj.resolution
        seen = self.sim.sensed(obj)
        if obj.kind == "ground":  # a ground sensor is a 1 x 1 vision sensor: its one grey pixel
            level = 0 if not isinstance(seen, float) else min(255, max(0, round(seen * 255)))
            img = np.full((1, 1, 3), level, np.uint8)
        else:  # CoppeliaSim's buffer: RGB, rows from the bottom up, which is labsim's own row order
            img = np.zeros((h, w, 3), np.uint8) if seen is None else np.asarray(seen, dtype=np.uint8)
        x0, y0, sx, sy = crop(args[3] if len(args) > 3 else None, args[4] if len(args) > 4 else None, w, h)
        img = img[y0:y0 + sy, x0:x0 + sx]
        if options & 1:  # greyscale, one byte a pixel
            img = (img.astype(np.uint16).sum(axis=2) // 3).astype(np.uint8)[..., None]
        if options & 2:  # and an alpha byte after each pixel: option 3 is grey + alpha
            img = np.concatenate([img, np.full(img.shape[:2] + (1,), 255, np.uint8)], axis=2)
        # CoppeliaSim 4.6-4.9 (_simGetVisionSensorImg) returns the sensor's resolution, not
        # the size of the portion read
        return [np.ascontiguousarray(img).tobytes(), [w, h]]

    def _sim_getVisionSensorResolution(self, client: Client, args: Args) -> list[object]:
        obj = self._obj(args, 0, ("camera", "ground"), "vision sensor")
        return [list(obj.resolution)]

    def _sim_readForceSensor(self, client: Client, args: Args) -> list[object]:
        obj = self._obj(args, 0, ("force",), "force sensor")
        if not self.sim.running or self.sim.steps == 0:
            return [0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
        tension = float(self.sim.part(obj.name)[0])
        return [1, [0.0, 0.0, tension], [0.0, 0.0, 0.0]]

    def _sim_checkCollision(self, client: Client, args: Args) -> list[object]:
        a = self._obj(args, 0)
        if len(args) < 2 or not isinstance(args[1], int):
            raise SimError(E_FEW if len(args) < 2 else E_ARGS)
        if a.kind != "robot" or args[1] != HANDLE_ALL:
            raise SimError("labsim serve: only sim.checkCollision(robot, sim.handle_all) is supported")
        if not self.sim.running or self.sim.steps == 0:
            return [0, [-1, -1]]
        hit = bool(self.sim.snapshot()[a.robot][self._robot(a).row["collided"]])
        return [1, [a.handle, -1]] if hit else [0, [-1, -1]]

    # --- time and state ----------------------------------------------------------------------

    def _sim_getSimulationTime(self, client: Client, args: Args) -> list[object]:
        return [self.sim.steps * self.sim.dt_s]

    def _sim_getSimulationState(self, client: Client, args: Args) -> list[object]:
        return [self.sim.state]

    def _sim_getSimulationTimeStep(self, client: Client, args: Args) -> list[object]:
        return [self.sim.dt_s]

    def _sim_getFloatParam(self, client: Client, args: Args) -> list[object]:
        param = integer(args, 0, -1)
        if param == CONSTANTS["floatparam_simulation_time_step"]:
            return [self.sim.dt_s]
        raise SimError("labsim serve: only sim.floatparam_simulation_time_step can be read")

    def _sim_setStepping(self, client: Client, args: Args) -> list[object]:
        before = client.stepping
        if args and args[0]:
            client.stepping += 1
        elif client.stepping > 0:
            client.stepping -= 1
        if before > 0 and not self.sim.stepping():
            self.sim.next_due = time.perf_counter() + self.sim.dt_s  # free-running again from now
        return [before]

    def _sim_step(self, client: Client, args: Args) -> Wait:
        client.step_pending = self.sim.state == RUNNING
        return WAIT

    def _sim_startSimulation(self, client: Client, args: Args) -> list[object]:
        self.sim.start()
        return []

    def _sim_stopSimulation(self, client: Client, args: Args) -> list[object]:
        self.sim.stop()
        return []

    def _sim_pauseSimulation(self, client: Client, args: Args) -> list[object]:
        self.sim.pause()
        return []

    # --- poses -------------------------------------------------------------------------------

    def _relative(self, obj: SceneObject, rel: int) -> Pose3:
        world_pose = self.sim.world_pose
        if obj.kind == "robot" and rel in (HANDLE_WORLD, HANDLE_PARENT):
            return world_pose(obj)  # exactly what the backend says, no arithmetic
        if rel == HANDLE_PARENT:
            if obj.parent is None:
                return world_pose(obj)
            return obj.mount
        pose = world_pose(obj)
        if rel == HANDLE_WORLD:
            return pose
        ref = self.tree.objects.get(rel)
        if ref is None:
            raise SimError(E_HANDLE)
        return seen_from(pose, world_pose(ref))

    def _sensor_frame(self, obj: SceneObject, rel: int) -> mx.Matrix | None:
        """obj's matrix in the frame ``rel`` names when a sonar is either of them, else None.

        A proximity sensor detects along its z axis, and readProximitySensor's point is in
        that frame (z along the beam, x to its left, y up: ``Simulation.detected_point``), as
        on CoppeliaSim's Pioneer: so its orientation is that frame, and ``M * point`` of its
        matrix lands where the sonar met something. Everything else stays yaw-only."""
        if rel == HANDLE_PARENT:
            ref = obj.parent
        elif rel == HANDLE_WORLD:
            ref = None
        else:
            ref = self.tree.objects.get(rel)
            if ref is None:
                raise SimError(E_HANDLE)
        if obj.kind != "sonar" and (ref is None or ref.kind != "sonar"):
            return None
        m = self._world_frame(obj)
        return m if ref is None else mx.seen_from(m, self._world_frame(ref))

    def _world_frame(self, obj: SceneObject) -> mx.Matrix:
        x, y, z, a = self.sim.world_pose(obj)
        m = mx.from_euler((x, y, z), (0.0, 0.0, a))
        return mx.times(m, SENSOR_AXES) if obj.kind == "sonar" else m

    def _mechanism_part(self, obj: SceneObject, args: Args) -> bool:
        """Whether obj is part of the mechanism (asked for in the world frame: the only one)."""
        if obj.kind not in _MECHANISM:
            return False
        if integer(args, 1, HANDLE_WORLD) not in (HANDLE_WORLD, HANDLE_PARENT):
            raise SimError("labsim serve: a mechanism's parts are given relative to the world only")
        return True

    def _sim_getObjectPosition(self, client: Client, args: Args) -> list[object]:
        obj = self._obj(args)
        m = self._sensor_frame(obj, integer(args, 1, HANDLE_WORLD))
        if m is not None:
            return [[m[3], m[7], m[11]]]
        x, y, z, _ = self._relative(obj, integer(args, 1, HANDLE_WORLD))
        return [[x, y, z]]

    def _sim_getObjectOrientation(self, client: Client, args: Args) -> list[object]:
        obj = self._obj(args)
        if self._mechanism_part(obj, args):
            *_, slew, theta = self.sim.mechanism_frame(obj)
            return [plane_rotation(slew, theta)[0]]
        m = self._sensor_frame(obj, integer(args, 1, HANDLE_WORLD))
        if m is not None:
            return [mx.euler(m)]
        *_, a = self._relative(obj, integer(args, 1, HANDLE_WORLD))
        return [[0.0, 0.0, a]]

    def _sim_getObjectPose(self, client: Client, args: Args) -> list[object]:
        obj = self._obj(args)
        if self._mechanism_part(obj, args):
            x, y, z, slew, theta = self.sim.mechanism_frame(obj)
            return [[x, y, z, *plane_rotation(slew, theta)[1]]]
        m = self._sensor_frame(obj, integer(args, 1, HANDLE_WORLD))
        if m is not None:
            return [mx.pose(m)]
        x, y, z, a = self._relative(obj, integer(args, 1, HANDLE_WORLD))
        return [[x, y, z, *yaw_quaternion(a)]]

    def _sim_getObjectVelocity(self, client: Client, args: Args) -> list[object]:
        obj = self._obj(args)
        if obj.kind != "robot" or not self.sim.running:
            return [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
        r = self._robot(obj)
        row = self.sim.snapshot()[obj.robot]
        a = cast(float, row[r.row["heading"]])
        v = cast(float, row[r.row["forward_speed"]]) if "forward_speed" in r.row else 0.0
        return [[v * math.cos(a), v * math.sin(a), 0.0], [0.0, 0.0, r.yaw_rate]]

    # --- placing robots ----------------------------------------------------------------------

    def _placeable(self, args: Args) -> tuple[Robot, object]:
        """The robot to move and the value to set, in either argument order: (h, value,
        frame) since CoppeliaSim 4.5, (h, frame, value) before."""
        obj = self._obj(args)
        if obj.kind != "robot":
            raise SimError("labsim serve: only robots can be moved")
        if self.sim.state != STOPPED:
            raise SimError("labsim serve: robots can be placed only while the simulation is stopped")
        value, _ = value_and_frame(args, "robots")
        return self._robot(obj), value

    def _sim_setObjectPosition(self, client: Client, args: Args) -> list[object]:
        r, value = self._placeable(args)
        x, y, _z = vec([value], 0, 3)
        r.pose = Pose(x, y, r.pose.heading_rad)
        return []

    def _sim_setObjectOrientation(self, client: Client, args: Args) -> list[object]:
        r, value = self._placeable(args)
        alpha, beta, gamma = vec([value], 0, 3)
        if abs(alpha) > 1e-6 or abs(beta) > 1e-6:
            raise SimError("labsim serve: the scene is flat; robots turn about z only (alpha = beta = 0)")
        r.pose = Pose(r.pose.x_m, r.pose.y_m, gamma)
        return []

    def _sim_setObjectPose(self, client: Client, args: Args) -> list[object]:
        r, value = self._placeable(args)
        x, y, _z, qx, qy, qz, qw = vec([value], 0, 7)
        if abs(qx) > 1e-6 or abs(qy) > 1e-6:
            raise SimError("labsim serve: the scene is flat; robots turn about z only")
        r.pose = Pose(x, y, quaternion_yaw(qz, qw))
        return []


def value_and_frame(args: Args, what: str) -> tuple[object, object]:
    """(value, frame) of a set-pose call in either argument order: (h, value, frame) since
    CoppeliaSim 4.5, (h, frame, value) before. Only the world frame is served."""
    if len(args) < 2:
        raise SimError(E_FEW)
    if isinstance(args[1], int) and not isinstance(args[1], bool) and len(args) > 2:
        value, rel = args[2], args[1]
    else:
        value, rel = args[1], (args[2] if len(args) > 2 and args[2] is not None else HANDLE_WORLD)
    if rel not in (HANDLE_WORLD, HANDLE_PARENT):
        raise SimError(f"labsim serve: {what} are placed relative to the world only")
    return value, rel
