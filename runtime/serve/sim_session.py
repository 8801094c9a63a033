"""The stand-in's session calls: scenes, parameters, the log, time, scripts, and the sensor and
joint calls a lab does not need but students' scripts make.

Where it sits: ``server.Server`` answers the calls listed in ``SESSION_CALLS`` here, before the
simulation's (``sim_api``) or the scene editor's (``scene_edit``) handlers, which it reaches
through ``Host.base_handlers()``. Each is answered as CoppeliaSim 4.6 to 4.10 answers it
(CoppeliaRobotics/manual ``en/sim-1/*.htm``, coppeliaSimLib's ``simInternal.cpp`` and
``apiErrors.h``, simConst.h; ../shared/reference/coppeliasim-zmq-protocol.md), with these
flat-world and no-Lua answers (docs/coppeliasim.md, the compatibility table):

* ``sim.loadScene(name)`` loads a lab (``wall_follow``) or a world (``walls_lab4``) by name; a
  ``.ttt`` file cannot be read and says so. ``sim.saveScene`` writes no ``.ttt`` file.
* No script runs: ``sim.getScript`` hands out the main script's handle and -1 for an object's
  simulation script, and ``sim.callScriptFunction`` answers CoppeliaSim's "script function does
  not exist." (labsim's own fleet script is answered first: ``script_host``).
* A vision sensor's depth is the floor's, through the camera's optics: a flat world's only
  surface a camera sees at a distance; its packet is the image's statistics.
* ``sim.getJointForce`` is 0 (labsim's motors report no torque); ``sim.setJointTargetForce`` is
  kept and read back by nothing: the model's motors are strong enough for the labs.
"""
from __future__ import annotations

import math
import os
import tempfile
import time
from collections.abc import Callable, Sequence
from typing import Any, Protocol

import numpy as np

from labsim.backends.coppeliasim import HANDLE_ALL, RUNNING, STOPPED
from labsim.backends.protocol import BackendError, RobotRequest
from labsim.backends.scene.world import World
from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.serve.sim_args import E_ARGS, E_FEW, E_HANDLE, Args, Handler, SimError, Wait, as_handle, crop, shown
from labsim.runtime.serve.sim_objects import call_base
from labsim.runtime.serve.simulation import Client, Simulation
from labsim.runtime.serve.wire_limits import Deadline

RESOURCES = "/labsim-serve"  # CoppeliaSim's folders, as the stand-in names them (it reads none)
VERSION = 40600  # sim.intparam_program_version: the stand-in answers as CoppeliaSim 4.6.0
MAIN_SCRIPT = 3_000_000  # the main script's handle (sim.getScript(sim.scripttype_main))
MAX_WAIT_S = 60.0  # of simulation time, per sim.wait call
NEAR_M, FAR_M = 0.01, 10.0  # a vision sensor's clipping planes, as labsim scene makes them

# simConst.h (CoppeliaSim 4.6 to 4.10): the names a script reads from zmqRemoteApi.info
VERBOSITY = {"useglobal": -1, "none": 100, "errors": 200, "warnings": 300, "loadinfos": 400, "questions": 410,
             "scripterrors": 420, "scriptwarnings": 430, "scriptinfos": 450, "msgs": 450, "infos": 500,
             "debug": 600, "trace": 700, "tracelua": 800, "traceall": 900}
STRING_PARAMS = {"application_path": 0, "scene_path_and_name": 13, "scene_path": 14, "scene_name": 15,
                 "scene_unique_id": 118, "uniqueid": 126, "tempdir": 127, "importexportdir": 130,
                 "scenedefaultdir": 132, "modeldefaultdir": 133, "resourcesdir": 141}
INT_PARAMS = {"program_version": 1, "dynamic_step_divider": 7, "dynamic_engine": 8, "idle_fps": 26,
              "program_revision": 30, "scene_index": 34, "speedmodifier": 36, "verbosity": 40,
              "statusbarverbosity": 41, "processid": 52}
SESSION_CONSTANTS: dict[str, int] = {
    **{f"verbosity_{k}": v for k, v in VERBOSITY.items()}, "verbosity_undecorated": 0xF000,
    "verbosity_onlyterminal": 0x10000, "verbosity_once": 0x20000,
    **{f"stringparam_{k}": v for k, v in STRING_PARAMS.items()},
    **{f"intparam_{k}": v for k, v in INT_PARAMS.items()},
    "scripttype_main": 0, "scripttype_simulation": 1, "scripttype_childscript": 1, "scripttype_customization": 6,
    "jointfloatparam_velocity": 2012, "handleflag_greyscale": 0x00400000, "handle_all_except_explicit": -3,
}
SESSION_CALLS = tuple(f"sim.{n}" for n in (
    "loadScene", "closeScene", "saveScene", "getStringParam", "getInt32Param", "setInt32Param", "addLog",
    "getSystemTime", "wait", "getScript", "callScriptFunction", "handleProximitySensor", "readVisionSensor",
    "handleVisionSensor", "getVisionSensorDepth", "getVisionSensorCharImage", "setJointPosition",
    "setJointTargetForce", "setJointForce", "getJointForce", "getObjectFloatParam", "checkProximitySensor",
    "getVisionSensorImage",
))


class Host(Protocol):
    """What the session calls need of the server (``server.Server``)."""

    simulation: Simulation
    editor: Any
    log: Callable[[str], None]

    def base_handlers(self) -> dict[str, Handler]: ...
    def load(self, world: World, robots: int | Sequence[RobotRequest], dt_s: float) -> None: ...


def scene_named(name: str) -> tuple[World, int | list[RobotRequest], float]:
    """The scene sim.loadScene(name) gives: a lab's world, robots and dt, or a world's with one
    robot (none for a mechanism). Raises SimError for anything else, .ttt files first."""
    from labsim.backends.scene.world import builtin_worlds
    from labsim.runtime.labs import labs

    if name.lower().endswith((".ttt", ".simscene.xml", ".ttm")) or "/" in name or "\\" in name:
        raise SimError(f"file not found. (labsim serve: labsim cannot read .ttt scenes; load the lab by name, "
                       f"e.g. sim.loadScene('wall_follow'): labs {', '.join(sorted(labs()))}; worlds "
                       f"{', '.join(sorted(builtin_worlds()))})")
    lab = labs().get(name)
    if lab is not None:
        from labsim.runtime.run import compile_behaviour

        program = compile_behaviour(lab.path).program
        models = [g.model for g in program.robots for _ in range(g.count)]
        from labsim.runtime.serve.simulation import robot_specs

        poses = [p for _, p in robot_specs(program.world, len(models))]
        return program.world, [RobotRequest(f"PioneerP3DX[{i}]", m, p, ())
                               for i, (m, p) in enumerate(zip(models, poses))], program.dt_s
    path = builtin_worlds().get(name)
    if path is None:
        raise SimError(f"file not found. (labsim serve: no lab or world '{shown(name)}'; labs "
                       f"{', '.join(sorted(labs()))}; worlds {', '.join(sorted(builtin_worlds()))})")
    from labsim.backends.scene.world_file import load_world
    from labsim.foundation.diagnostics import Report

    world = load_world(path, Report())
    assert world is not None  # a built-in world loads
    return world, 0 if world.mechanism is not None else 1, 0.05


class SessionCalls:
    """The handlers of ``SESSION_CALLS`` (``handlers()``) and what they keep between calls."""

    def __init__(self, server: Host) -> None:
        self.server = server
        self.ints: dict[int, int] = {INT_PARAMS["speedmodifier"]: 1, INT_PARAMS["idle_fps"]: 8,
                                     INT_PARAMS["verbosity"]: VERBOSITY["loadinfos"],
                                     INT_PARAMS["statusbarverbosity"]: VERBOSITY["msgs"],
                                     INT_PARAMS["dynamic_step_divider"]: 1}
        self.forces: dict[int, float] = {}  # joint -> the force or torque a script allowed it
        self.handled: set[int] = set()  # vision sensors handled explicitly (sim.handleVisionSensor)
        self.started = time.perf_counter()

    def handlers(self) -> dict[str, Handler]:
        return {name: getattr(self, "_" + name.removeprefix("sim.")) for name in SESSION_CALLS}

    def _inner(self, name: str, client: Client, args: Args) -> list[object]:
        return call_base(self.server, name, client, args)

    def _stopped(self) -> None:
        if self.server.simulation.state != STOPPED:
            raise SimError("simulation is not stopped.")

    # --- scenes ------------------------------------------------------------------------------

    def _loadScene(self, client: Client, args: Args) -> list[object]:
        # sim.loadScene(string filename): CoppeliaSim 4.6; refused while a simulation runs
        if not args or not isinstance(args[0], str):
            raise SimError(E_FEW if not args else E_ARGS)
        self._stopped()
        world, robots, dt = scene_named(args[0].removesuffix("@keepCurrent"))
        try:
            self.server.load(world, robots, dt)
        except (BackendError, LabsimError) as e:
            raise SimError(f"labsim serve: cannot load '{shown(args[0])}': {e}") from None
        self.server.log(f"labsim serve: scene '{args[0]}' loaded")
        return []

    def _closeScene(self, client: Client, args: Args) -> list[object]:
        # int result = sim.closeScene(): the index of the scene now current (simInternal.cpp)
        self._stopped()
        self.server.load(World("scene", "an empty scene", (-10.0, -10.0, 10.0, 10.0)), 0, self.server.simulation.dt_s)
        return [0]

    def _saveScene(self, client: Client, args: Args) -> list[object]:
        raise SimError("labsim serve: the stand-in writes no .ttt files (a CoppeliaSim binary); save from "
                       "CoppeliaSim, or rebuild the scene with sim.loadScene or labsim scene")

    # --- parameters and the log --------------------------------------------------------------

    def _getStringParam(self, client: Client, args: Args) -> list[object]:
        p = args[0] if args else None
        name = self.server.simulation.world.name
        values = {0: RESOURCES, 13: f"{RESOURCES}/scenes/{name}.ttt", 14: f"{RESOURCES}/scenes", 15: name,
                  118: f"labsim-{name}", 126: f"labsim-{os.getpid()}", 127: tempfile.gettempdir(),
                  130: f"{RESOURCES}/export", 132: f"{RESOURCES}/scenes", 133: f"{RESOURCES}/models", 141: RESOURCES}
        if not isinstance(p, int) or p not in values:
            raise SimError(f"invalid parameter. (labsim serve answers sim.stringparam_ "
                           f"{', '.join(sorted(STRING_PARAMS))})")
        return [values[p]]

    def _getInt32Param(self, client: Client, args: Args) -> list[object]:
        p = args[0] if args else None
        fixed = {1: VERSION, 8: 0, 30: 0, 34: 0, 52: os.getpid()}  # Bullet 2.78, as CoppeliaSim's default
        if isinstance(p, int) and p in fixed:
            return [fixed[p]]
        if isinstance(p, int) and p in self.ints:
            return [self.ints[p]]
        raise SimError(f"invalid parameter. (labsim serve answers sim.intparam_ {', '.join(sorted(INT_PARAMS))})")

    def _setInt32Param(self, client: Client, args: Args) -> list[object]:
        if len(args) < 2:
            raise SimError(E_FEW)
        p, v = args[0], args[1]
        if not isinstance(v, int) or isinstance(v, bool):
            raise SimError(E_ARGS)
        if p not in self.ints:
            raise SimError("could not set parameter. (labsim serve sets sim.intparam_speedmodifier, idle_fps, "
                           "verbosity, statusbarverbosity and dynamic_step_divider; they change nothing it does)")
        self.ints[int(p)] = v
        return []

    def _addLog(self, client: Client, args: Args) -> list[object]:
        # sim.addLog(int verbosity, string message): CoppeliaSim 4.6
        if len(args) < 2:
            raise SimError(E_FEW)
        if not isinstance(args[0], int) or not isinstance(args[1], str):
            raise SimError(E_ARGS)
        level = args[0] & 0xFFF
        if level <= self.ints[INT_PARAMS["verbosity"]] or level == VERBOSITY["scriptinfos"]:
            kind = next((k for k, v in VERBOSITY.items() if v == level), str(level))
            self.server.log(f"[{client.lang} client {client.uuid[:8]}:{kind}] {shown(args[1])}")
        return []

    # --- time ----------------------------------------------------------------------------------

    def _getSystemTime(self, client: Client, args: Args) -> list[object]:
        return [time.perf_counter() - self.started]  # seconds, from an arbitrary start, as CoppeliaSim's

    def _wait(self, client: Client, args: Args) -> list[object]:
        # float deltaTimeLeft = sim.wait(float dt, bool simulationTime = true): the steps it waits
        # for are taken at once (the script would only wait for them); the answer is the
        # overshoot, <= 0. Real time is slept, up to 2 s a call (the server serves others): a
        # longer real-time wait answers the time it did not wait, > 0, for the script to wait again.
        if not args or not isinstance(args[0], (int, float)) or isinstance(args[0], bool) \
                or not math.isfinite(args[0]):
            raise SimError(E_FEW if not args else E_ARGS)
        dt = max(0.0, float(args[0]))
        sim = self.server.simulation
        if len(args) > 1 and args[1] is False:
            time.sleep(min(dt, 2.0))
            return [dt - 2.0 if dt > 2.0 else 0.0]
        if sim.state != RUNNING:
            return [0.0]
        if dt > MAX_WAIT_S:  # one request must end within its budget; a script loops for longer waits
            raise SimError(f"labsim serve: sim.wait takes at most {MAX_WAIT_S:g} s of simulation time a call")
        n = math.ceil(dt / sim.dt_s - 1e-9)
        for _ in range(n):
            Deadline.check()
            sim.advance()
        sim.next_due = time.perf_counter() + sim.dt_s
        return [dt - n * sim.dt_s]

    # --- scripts ---------------------------------------------------------------------------------

    def _getScript(self, client: Client, args: Args) -> list[object]:
        # int scriptHandle = sim.getScript(int scriptType, int objectHandle / string name): 4.6
        if not args or not isinstance(args[0], int):
            raise SimError(E_FEW if not args else E_ARGS)
        if args[0] == SESSION_CONSTANTS["scripttype_main"]:
            return [MAIN_SCRIPT]
        if "sim.getScript" in self.server.base_handlers():
            return self._inner("sim.getScript", client, args)
        return self.no_script(client, args)

    def no_script(self, client: Client, args: Args) -> list[object]:
        """sim.getScript of an object that carries none: every object but the fleet script's dummy."""
        obj = args[1] if len(args) > 1 else None
        if isinstance(obj, int) and obj not in self.server.simulation.tree.objects:
            raise SimError(E_HANDLE)
        return [-1]  # the robots carry no script: labsim drives them only from clients

    def _callScriptFunction(self, client: Client, args: Args) -> list[object] | Wait:
        # 4.6: (string functionName, int scriptHandle, ...); 4.8 on: (int scriptHandle, string functionName, ...)
        if "sim.callScriptFunction" in self.server.base_handlers():
            handler = self.server.base_handlers()["sim.callScriptFunction"]
            return handler(client, args)  # labsim's fleet script, else its error
        return self.no_function(client, args)

    def no_function(self, client: Client, args: Args) -> list[object]:
        """sim.callScriptFunction of any script but labsim's fleet script: no Lua runs here."""
        if len(args) < 2:
            raise SimError(E_FEW)
        name = args[0] if isinstance(args[0], str) else args[1]
        raise SimError(f"script function does not exist. (labsim serve runs no Lua: '{shown(name)}' is in no "
                       f"script of its scene; read and drive objects with sim.* calls instead)")

    # --- sensors -------------------------------------------------------------------------------

    def _handleProximitySensor(self, client: Client, args: Args) -> list[object]:
        # the stand-in senses at every step, as CoppeliaSim does for sensors not handled explicitly
        if args and args[0] in (HANDLE_ALL, SESSION_CONSTANTS["handle_all_except_explicit"]):
            return [0, 0.0, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]]
        return self._inner("sim.readProximitySensor", client, args[:1])

    def _checkProximitySensor(self, client: Client, args: Args) -> list[object]:
        # int result, float distance, list detectedPoint = sim.checkProximitySensor(int sensorHandle,
        # int entityHandle): CoppeliaSim 4.6 to 4.10; the stand-in knows what a sonar sees, not which
        # object it is, so it answers for sim.handle_all only
        if len(args) < 2:
            raise SimError(E_FEW)
        if as_handle(args[1]) != HANDLE_ALL:
            raise SimError("labsim serve: sim.checkProximitySensor answers for sim.handle_all only (the stand-in "
                           "does not tell which object a sensor detects)")
        ret = self._inner("sim.readProximitySensor", client, args[:1])
        return ret[:3]

    def _getVisionSensorImage(self, client: Client, args: Args) -> list[object]:
        # sim.getVisionSensorImage(int sensorHandle, int posX = 0, int posY = 0, int sizeX = 0,
        # int sizeY = 0, int returnType = 0): CoppeliaSim 4.6 to 4.10 (sim-1); returnType 0: a
        # table of floats in [0, 1], 1: a buffer of bytes; rows bottom first, as getVisionSensorImg
        h = as_handle(args[0]) if args else None
        if h is None:
            raise SimError(E_FEW)
        nums = [_coord(a) for a in args[1:6]] + [0] * 5
        grey = 1 if h & SESSION_CONSTANTS["handleflag_greyscale"] else 0
        img, _res = self._inner("sim.getVisionSensorImg", client,
                                [h & 0x003FFFFF, grey, 0, nums[0:2], nums[2:4]])
        assert isinstance(img, (bytes, bytearray))
        return [bytes(img)] if nums[4] == 1 else [[b / 255.0 for b in img]]

    def _is_ground_sensor(self, args: Args) -> bool:
        if not args or not isinstance(args[0], int) or isinstance(args[0], bool):
            return False
        obj = self.server.simulation.tree.objects.get(args[0] & 0x003FFFFF)
        return obj is not None and obj.kind == "ground"

    def _camera(self, args: Args) -> tuple[Any, Any]:
        """(scene object, labsim Camera) of the vision sensor args[0] names."""
        if not args or not isinstance(args[0], int) or isinstance(args[0], bool):
            raise SimError(E_FEW if not args else E_ARGS)
        sim = self.server.simulation
        obj = sim.tree.objects.get(args[0] & 0x003FFFFF)
        if obj is None:
            raise SimError(E_HANDLE)
        if obj.kind != "camera":
            raise SimError("object is not a vision sensor.")
        cam = next(c for c in sim.robots[obj.robot].model.cameras if c.name == obj.name)
        return obj, cam

    def _depth(self, args: Args) -> np.ndarray:
        """The depth of each pixel (rows bottom first), 0 at the near plane to 1 at the far one:
        the floor's, along the view axis, through the camera's pinhole, pitch and roll."""
        obj, cam = self._camera(args)
        w, h = obj.resolution
        fx = math.tan(math.radians(cam.fov_deg) / 2)
        fy = math.tan(math.radians(cam.vertical_fov_deg) / 2)
        u = (np.arange(w) + 0.5) / w * 2 - 1
        v = (np.arange(h) + 0.5) / h * 2 - 1  # row 0 is the bottom: v = -1
        pitch, roll = math.radians(cam.pitch_deg), math.radians(cam.roll_deg)
        side, up = u[None, :] * fx, v[:, None] * fy  # the ray: forward 1, side, up (camera frame)
        dz = -math.sin(pitch) + (up * math.cos(roll) - side * math.sin(roll)) * math.cos(pitch)
        with np.errstate(divide="ignore"):
            along = np.where(dz < 0, cam.height_m / -dz, np.inf)
        return np.clip((along - NEAR_M) / (FAR_M - NEAR_M), 0.0, 1.0)

    def _packet(self, args: Args) -> list[float]:
        """The default auxiliary packet: min, max and mean of intensity, red, green, blue, depth."""
        img, res = self._inner("sim.getVisionSensorImg", _NOBODY, args[:1])
        assert isinstance(img, bytes) and isinstance(res, list)
        rgb = np.frombuffer(img, np.uint8).reshape(res[1], res[0], 3).astype(np.float64) / 255
        planes = [rgb.mean(axis=2), rgb[..., 0], rgb[..., 1], rgb[..., 2], self._depth(args)]
        return [float(p.min()) for p in planes] + [float(p.max()) for p in planes] + [float(p.mean()) for p in planes]

    def _readVisionSensor(self, client: Client, args: Args) -> list[object]:
        # int result, list packet1 = sim.readVisionSensor(int handle): -1 before it was ever handled
        if self._is_ground_sensor(args):  # a ground sensor's reading: the base handler's
            return self._inner("sim.readVisionSensor", client, args)
        obj, _ = self._camera(args)
        if self.server.simulation.steps == 0 and obj.handle not in self.handled:
            return [-1]
        return [0, self._packet(args)]

    def _handleVisionSensor(self, client: Client, args: Args) -> list[object]:
        if self._is_ground_sensor(args):  # handled by every step already: its reading as it is
            return self._inner("sim.readVisionSensor", client, args)
        obj, _ = self._camera(args)
        self.handled.add(obj.handle)
        return [0, self._packet(args)]

    def _getVisionSensorDepth(self, client: Client, args: Args) -> list[object]:
        # bytes depth, [resX, resY] = sim.getVisionSensorDepth(handle, options = 0, pos, size): 4.6;
        # packed floats (sim.unpackFloatTable), option bit 0: metres
        if self._is_ground_sensor(args):
            raise SimError("labsim serve: a ground sensor's depth is not served (the stand-in keeps its intensity "
                           "only: sim.readVisionSensor, sim.getVisionSensorImg)")
        obj, _ = self._camera(args)
        depth = self._depth(args)
        options = args[1] if len(args) > 1 and isinstance(args[1], int) else 0
        if options & 1:
            depth = NEAR_M + depth * (FAR_M - NEAR_M)
        w, h = obj.resolution
        x0, y0, sx, sy = crop(args[2] if len(args) > 2 else None, args[3] if len(args) > 3 else None, w, h)
        part = depth[y0:y0 + sy, x0:x0 + sx].astype("<f4")
        return [part.tobytes(), [w, h]]

    def _getVisionSensorCharImage(self, client: Client, args: Args) -> list[object]:
        # before 4.6: buffer image, int resX, int resY = sim.getVisionSensorCharImage(handle, posX = 0,
        # posY = 0, sizeX = 0, sizeY = 0); handle + sim.handleflag_greyscale for one byte a pixel
        h = args[0] if args else None
        if not isinstance(h, int) or isinstance(h, bool):
            raise SimError(E_FEW if not args else E_ARGS)
        nums = [_coord(a) for a in args[1:5]] + [0] * 4
        grey = 1 if h & SESSION_CONSTANTS["handleflag_greyscale"] else 0
        img, res = self._inner("sim.getVisionSensorImg", client,
                               [h & 0x003FFFFF, grey, 0, nums[0:2], nums[2:4]])
        return [img, *res]  # type: ignore[misc]

    # --- joints ----------------------------------------------------------------------------------

    def _joint(self, args: Args) -> Any:
        if not args or not isinstance(args[0], int) or isinstance(args[0], bool):
            raise SimError(E_FEW if not args else E_ARGS)
        obj = self.server.simulation.tree.objects.get(args[0])
        if obj is None:
            return None
        if obj.kind not in ("motor", "joint"):
            raise SimError("object is not a joint.")
        return obj

    def _setJointPosition(self, client: Client, args: Args) -> list[object]:
        obj = self._joint(args)
        if obj is None:
            raise SimError(E_HANDLE)
        if len(args) < 2 or not isinstance(args[1], (int, float)) or not math.isfinite(args[1]):
            raise SimError(E_FEW if len(args) < 2 else E_ARGS)
        if obj.kind == "motor":  # a wheel's angle only: it turns freely in a velocity-controlled joint
            self.server.simulation.robots[obj.robot].wheel[obj.index] = float(args[1])
            return []
        raise SimError("labsim serve: a mechanism's joint is moved by its motor in labsim's physics; use "
                       "sim.setJointTargetPosition or sim.setJointTargetVelocity")

    def _setJointTargetForce(self, client: Client, args: Args) -> list[object]:
        obj = self._joint(args)
        if obj is None:  # --empty: a joint being built (mechanism_edit reads its force)
            return self._inner("sim.setJointTargetForce", client, args)
        if len(args) < 2 or not isinstance(args[1], (int, float)):
            raise SimError(E_FEW if len(args) < 2 else E_ARGS)
        self.forces[obj.handle] = abs(float(args[1]))
        return []

    def _setJointForce(self, client: Client, args: Args) -> list[object]:
        # sim.setJointForce(int objectHandle, float forceOrTorque): CoppeliaSim 4.6 to 4.10 (sim-1),
        # setJointTargetForce's older name (coppeliaSimLib registers it as setJointMaxForce)
        return self._setJointTargetForce(client, args)

    def _getJointForce(self, client: Client, args: Args) -> list[object]:
        if self._joint(args) is None:
            raise SimError(E_HANDLE)
        return [0.0]

    def _getObjectFloatParam(self, client: Client, args: Args) -> list[object]:
        # float value = sim.getObjectFloatParam(int handle, int parameterID): 4.6
        if len(args) < 2:
            raise SimError(E_FEW)
        if args[1] == SESSION_CONSTANTS["jointfloatparam_velocity"]:
            return self._inner("sim.getJointVelocity", client, args[:1])
        raise SimError("invalid parameter. (labsim serve answers sim.jointfloatparam_velocity; "
                       "other object parameters: the matching sim.get* call)")


_NOBODY = Client("labsim", "-", 600.0, 0.0)  # the caller of an internal read, which no handler looks at


def _coord(value: object) -> float:
    """A position or size of the older image calls: nil is 0, any number as given (``crop``
    checks it against the image), anything else the type error."""
    if value is None:
        return 0
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise SimError(E_ARGS)
    return value
