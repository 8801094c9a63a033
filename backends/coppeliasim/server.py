"""``labsim serve``: a stand-in for CoppeliaSim's ZMQ remote API, backed by the pymunk backend.

Where it sits: a CoppeliaSim client (labsim's own ``CoppeliaSimBackend``, or a student's script
using ``coppeliasim_zmqremoteapi_client``) talks to this server exactly as it would to
CoppeliaSim's ZMQ remote API add-on; the server keeps a small scene tree of CoppeliaSim object
names and drives ``labsim.backends.pymunk.backend.PymunkBackend`` through the public backend
protocol (open / sense / act / command / step / pose / close). No CoppeliaSim is needed.

The wire (protocol v2, docs/coppeliasim.md and the reference notes it cites): one ZMQ REP
socket; every message is one CBOR map. A request is ``{func, args, argsL, uuid[, ver, lang,
timeout]}``; a reply is ``{"ret": [...]}``, ``{"err": "..."}`` or ``{"func": "_*wait*_"}``.
``sim.step`` answers with the wait message and advances when the client sends
``_*executed*_``, as CoppeliaSim does. Errors carry CoppeliaSim's texts (``No such function:
...``, ``object does not exist, or alias/path is ill formatted.``) followed by labsim's hint.

What the scene holds, for ``robots`` Pioneer P3DX robots (``/PioneerP3DX[i]`` in the order
given), each with ``leftMotor``, ``rightMotor``, 16 ``ultrasonicSensor`` children and, when its
model has cameras, a vision sensor (``Vision_sensor`` for the channel ``camera``); for a world
with a mechanism (the crane), its joints (all but fixed ones), force sensors and moving bodies
at the top level, by their names.

Semantics kept from CoppeliaSim, and where the stand-in differs (all in docs/coppeliasim.md):

* Proximity and vision sensors report what the last step saw: before the first step after
  ``startSimulation`` a sonar detects nothing and an image is black, as on CoppeliaSim, where
  sensors are handled at the end of a step. A sonar that sees nothing reads ``[0, 0.0,
  [0, 0, 0], -1, [0, 0, 0]]``; one that sees something reads ``[1, d, [0, 0, d], -1, [0, 0,
  0]]``: the detected object's handle and the surface normal are not modelled.
* Wheel targets are applied at the next step, and only when they changed, so re-sending an
  unchanged target costs nothing and changes nothing.
* Without stepping (``sim.setStepping(True)``) a running simulation advances on its own at
  about real time. With stepping, each ``sim.step`` of a stepping client advances one step;
  several stepping clients do not wait for each other.
* A new client finds the scene as the last one left it, except that a stepping client that
  went away without stopping the simulation (killed, crashed) has its simulation stopped
  when the next client arrives, once it has been silent for ``takeover_s``: otherwise the
  next program would find a half-run simulation frozen at its last step.
* Orientations are yaw only (``[0, 0, yaw]``): the scene is flat. Robots can be placed (set
  position / orientation / pose) only while the simulation is stopped; ``stopSimulation``
  puts them back where they were when it started, as CoppeliaSim restores a scene.
"""
from __future__ import annotations

import math
import random
import re
import threading
import time
import traceback
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from labsim.backends.coppeliasim import DEFAULT_PORT, camera_alias
from labsim.backends.scene.models import PIONEER_P3DX, RobotModel
from labsim.backends.protocol import BackendError, RobotRequest
from labsim.backends.scene.world import Pose, World

try:
    import cbor2
    import zmq
except ImportError as _missing:  # pragma: no cover - depends on the installation
    raise BackendError(
        f"labsim serve needs pyzmq and cbor2 ({_missing.name} is missing); install them with: "
        "pip install 'labsim[coppeliasim]'"
    ) from None

# --- CoppeliaSim's constants and texts ---------------------------------------------------------
# Values from CoppeliaSim's simConst.h (see the reference notes); a client reads them from
# zmqRemoteApi.info, so scripts use the names (sim.handle_world), never the numbers.
HANDLE_WORLD, HANDLE_ALL, HANDLE_PARENT = -1, -2, -11
STOPPED, PAUSED, RUNNING = 0x00, 0x08, 0x11  # simulation_advancing_running
CONSTANTS: dict[str, object] = {
    "handle_world": HANDLE_WORLD, "handle_all": HANDLE_ALL, "handle_self": -4,
    "handle_parent": HANDLE_PARENT, "handle_scene": -12, "handle_inverse": -14,
    "simulation_stopped": STOPPED, "simulation_paused": PAUSED, "simulation_advancing": 0x10,
    "simulation_advancing_firstafterstop": 0x10, "simulation_advancing_running": RUNNING,
    "simulation_advancing_lastbeforepause": 0x13, "simulation_advancing_firstafterpause": 0x14,
    "simulation_advancing_abouttostop": 0x15, "simulation_advancing_lastbeforestop": 0x16,
    "floatparam_rand": 0, "floatparam_simulation_time_step": 1,
}
E_PATH = "object does not exist, or alias/path is ill formatted."
E_HANDLE = "object does not exist."
E_ARGS = "one of the function's argument type is not correct."
E_FEW = "function requires more arguments."
E_VERSION = "The client ZeroMQ remote API version does not match CoppeliaSim's version"

# Functions a CoppeliaSim script commonly calls that this stand-in does not offer: listed in
# zmqRemoteApi.info so that calling one gives a clear error rather than an AttributeError.
UNSUPPORTED = (
    "addLog", "getObjectQuaternion", "setObjectQuaternion", "getObjectMatrix", "getObjectChild",
    "getObjectsInTree", "handleProximitySensor", "readVisionSensor", "getVisionSensorDepth",
    "setJointPosition", "setJointTargetForce", "getJointForce", "setFloatParam",
    "getInt32Param", "setInt32Param", "getBoolParam", "setBoolParam", "setSimulationTimeStep",
    "callScriptFunction", "executeScriptString", "loadScene", "loadModel", "removeObjects",
)

ROBOT_Z_M = PIONEER_P3DX.wheel_radius_m  # the robot frame's origin: the wheel axle, above the floor
SONAR_Z_M = 0.1  # nominal mount heights above the robot origin; the scene is flat
TAKEOVER_S = 2.0
POLL_MS = 100  # how often an idle server looks at its stop flag
MAX_LAG_S = 0.25  # free-running behind real time by more than this: skip ahead, do not spiral

_SEGMENT = re.compile(r"^(?P<alias>[^\[\]{}/]+?)(?:\[(?P<sib>\d+)\]|\{(?P<any>\d+)\})?$")


class _SimError(Exception):
    """An error a CoppeliaSim function would raise; becomes {"err": "<text> (in function ...)"}."""


@dataclass(eq=False)
class _Obj:
    """A scene object: what sim.getObject hands out a handle for."""

    handle: int
    alias: str
    kind: str  # robot | motor | sonar | camera | joint | force | body
    parent: _Obj | None = None
    children: list[_Obj] = field(default_factory=list)
    robot: int = -1  # the robot it belongs to
    index: int = -1  # sonar number - 1; motor side (0 left, 1 right)
    name: str = ""  # channel, joint, force sensor or body name
    mount: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)  # x, y, z, yaw in the parent frame
    resolution: tuple[int, int] = (0, 0)  # vision sensors: (resX, resY)


@dataclass(eq=False)
class _Robot:
    model: RobotModel
    pose: Pose  # where it starts: the scene's pose, changed by set* while stopped
    obj: _Obj
    row: dict[str, int] = field(default_factory=dict)  # channel -> index in its sense() row
    target: list[float] = field(default_factory=lambda: [0.0, 0.0])  # rad/s asked by a client
    acted: list[float] = field(default_factory=lambda: [0.0, 0.0])  # rad/s the backend has
    wheel: list[float] = field(default_factory=lambda: [0.0, 0.0])  # wheel angles, rad, from odometry
    wheel_rate: list[float] = field(default_factory=lambda: [0.0, 0.0])  # rad/s over the last step
    last: tuple[float, float, float] = (0.0, 0.0, 0.0)  # pose after the last step
    yaw_rate: float = 0.0  # rad/s over the last step


@dataclass(eq=False)
class _Client:
    uuid: str
    lang: str
    timeout_s: float
    last_seen: float
    stepping: int = 0  # sim.setStepping level (cumulative, as CoppeliaSim's)
    step_pending: bool | None = None  # after sim.step: whether _*executed*_ advances


def _wrap(a: float) -> float:
    r = math.remainder(a, 2.0 * math.pi)
    return math.pi if r == -math.pi else r


class Server:
    """The stand-in. ``bind()`` then ``serve_forever()``; ``stop()`` from any thread.

    ``robots``: a count of Pioneer P3DX robots, placed at the world's spawn poses (then at free
    random poses), or a sequence of ``RobotRequest``-like objects whose ``model`` and ``pose``
    are used (their channels are not: the server offers every channel of the model).
    ``port=0`` binds a free port; ``port`` then says which.
    """

    def __init__(self, world: World, robots: int | Sequence[object] = 1, *, host: str = "127.0.0.1",
                 port: int = DEFAULT_PORT, dt_s: float = 0.05, takeover_s: float = TAKEOVER_S,
                 log: Callable[[str], None] | None = None) -> None:
        if not (isinstance(dt_s, (int, float)) and math.isfinite(dt_s) and dt_s > 0):
            raise BackendError(f"labsim serve: the time step must be positive, not {dt_s!r}")
        self.world = world
        self.host = host
        self.port = port
        self.dt_s = float(dt_s)
        self.takeover_s = takeover_s
        self.log = log or (lambda message: None)
        self.messages = 0  # requests answered, for tests and the log

        self._objs: dict[int, _Obj] = {}
        self._top: list[_Obj] = []
        self._old_names: dict[str, _Obj] = {}
        specs = self.robot_specs(world, robots)
        if world.mechanism is not None and specs:
            raise BackendError(f"labsim serve: world '{world.name}' is a mechanism; it has no place for "
                               f"robots (serve it with --robots 0)")
        self._robots: list[_Robot] = [self._add_robot(i, model, pose) for i, (model, pose) in enumerate(specs)]
        self._mech: int | None = None  # the mechanism's index among the backend's robots
        self._mech_row: dict[str, int] = {}
        self._mech_targets: dict[str, tuple[str, float]] = {}  # joint -> (mode, value) asked
        self._mech_pending: dict[str, tuple[str, float]] = {}  # not yet given to the backend
        self._add_mechanism(world)

        self._backend: object | None = None
        self._state = STOPPED
        self._steps = 0
        self._snap: list[list[object]] | None = None
        self._next_due = 0.0  # perf_counter time of the next free-running step
        self._clients: dict[str, _Client] = {}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._context: zmq.Context | None = None
        self._socket: zmq.Socket | None = None
        self._funcs: dict[str, Callable[[_Client, list], list]] = {
            name: getattr(self, "_sim_" + name.removeprefix("sim.")) for name in self.functions()
            if name.startswith("sim.")}
        self._funcs["zmqRemoteApi.require"] = self._require
        self._funcs["zmqRemoteApi.info"] = self._info

    # --- the scene ---------------------------------------------------------------------------

    @staticmethod
    def robot_specs(world: World, robots: int | Sequence[object]) -> list[tuple[RobotModel, Pose]]:
        """(model, start pose) of each robot: a count of Pioneers at the world's spawn poses
        (then at free random places, 1.2 m apart), or the models and poses of requests."""
        if isinstance(robots, int):
            if robots < 0:
                raise BackendError(f"labsim serve: the number of robots must be 0 or more, not {robots}")
            out: list[tuple[RobotModel, Pose]] = []
            spawns = list(world.spawns)
            rng = random.Random(f"labsim serve/{world.name}")
            for i in range(robots):
                if i < len(spawns):
                    pose = spawns[i]
                else:  # more robots than spawn poses: free places, 1.2 m apart
                    pose = world.random_pose(rng, 0.6)
                    for _ in range(1000):
                        if all(math.hypot(pose.x_m - p.x_m, pose.y_m - p.y_m) >= 1.2 for _, p in out):
                            break
                        pose = world.random_pose(rng, 0.6)
                out.append((PIONEER_P3DX, pose))
            return out
        return [(getattr(r, "model"), getattr(r, "pose")) for r in robots if getattr(r, "model", None) is not None]

    def _new(self, alias: str, kind: str, parent: _Obj | None, **fields: object) -> _Obj:
        obj = _Obj(len(self._objs) + 1, alias, kind, parent, **fields)  # type: ignore[arg-type]
        self._objs[obj.handle] = obj
        (parent.children if parent is not None else self._top).append(obj)
        return obj

    def _add_robot(self, i: int, model: RobotModel, pose: Pose) -> _Robot:
        if model.name != "pioneer_p3dx":
            raise BackendError(f"labsim serve: no CoppeliaSim scene names for robot model '{model.name}'")
        base = self._new("PioneerP3DX", "robot", None, robot=i)
        half = model.axle_length_m / 2
        left = self._new("leftMotor", "motor", base, robot=i, index=0, mount=(0.0, half, 0.0, 0.0))
        right = self._new("rightMotor", "motor", base, robot=i, index=1, mount=(0.0, -half, 0.0, 0.0))
        sonars = [self._new("ultrasonicSensor", "sonar", base, robot=i, index=k, name=s.name,
                            mount=(s.x_m, s.y_m, SONAR_Z_M, s.angle_rad))
                  for k, s in enumerate(model.sonars)]
        for c in model.cameras:
            self._new(camera_alias(model.name, c.name), "camera", base, robot=i, name=c.name,
                      mount=(c.x_m, 0.0, c.height_m - ROBOT_Z_M, 0.0),
                      resolution=(c.width_px, c.height_px))
        # The names of V-REP and CoppeliaSim before 4.3 (sim.getObjectHandle), with #n for
        # the second robot on: old scripts still use them.
        suffix = "" if i == 0 else f"#{i - 1}"
        self._old_names[f"Pioneer_p3dx{suffix}"] = base
        self._old_names[f"Pioneer_p3dx_leftMotor{suffix}"] = left
        self._old_names[f"Pioneer_p3dx_rightMotor{suffix}"] = right
        for k, s in enumerate(sonars):
            self._old_names[f"Pioneer_p3dx_ultrasonicSensor{k + 1}{suffix}"] = s
        channels = [s.name for s in model.sonars] + ["x", "y", "heading", "collided"]
        if "forward_speed" in model.channels():
            channels.append("forward_speed")
        channels += [c.name for c in model.cameras]
        robot = _Robot(model, pose, base, {ch: n for n, ch in enumerate(channels)})
        robot.last = (pose.x_m, pose.y_m, _wrap(pose.heading_rad))
        return robot

    def _add_mechanism(self, world: World) -> None:
        """Joints, force sensors and moving bodies of the world's mechanism, if the pymunk
        backend can simulate it (a RobotRequest with model None, and ``command``)."""
        m = world.mechanism
        if m is None:
            return
        from labsim.backends.pymunk.backend import PymunkBackend

        if not callable(getattr(PymunkBackend, "command", None)):
            self.log("labsim serve: this pymunk backend cannot simulate mechanisms; "
                     f"the joints of '{world.name}' are not served")
            return
        channels = []
        for j in getattr(m, "joints", ()):
            if j.kind != "fixed":
                self._new(j.name, "joint", None, name=j.name)
                channels.append(j.name)
        for s in getattr(m, "force_sensors", ()):
            self._new(s.name, "force", None, name=s.name)
            channels.append(s.name)
        for b in getattr(m, "bodies", ()):
            if not b.static:
                self._new(b.name, "body", None, name=b.name)
                channels.append(b.name)
        self._mech = len(self._robots)
        self._mech_row = {ch: n for n, ch in enumerate(channels)}

    def objects(self) -> list[str]:
        """Every object's full path, as ``sim.getObjectAlias(h, 2)`` gives it (for the log)."""
        return [self._path(o) for o in self._objs.values()]

    def robot_paths(self) -> list[str]:
        """The robots' paths, ``/PioneerP3DX[i]``, in order."""
        return [self._path(r.obj) for r in self._robots]

    def describe(self) -> str:
        """What the scene holds, in a line: robots, or the mechanism's joints and sensors."""
        parts = [", ".join(self.robot_paths())] if self._robots else []
        for kind, label in (("joint", "joints"), ("force", "force sensors"), ("body", "bodies")):
            names = [o.alias for o in self._top if o.kind == kind]
            if names:
                parts.append(f"{label} {', '.join(names)}")
        return "; ".join(parts) or "an empty scene"

    @property
    def simulation_time_s(self) -> float:
        return self._steps * self.dt_s

    @staticmethod
    def functions() -> list[str]:
        return [f"sim.{n}" for n in (
            "getObject", "getObjectHandle", "getObjectAlias", "getObjectParent",
            "setJointTargetVelocity", "getJointTargetVelocity", "setJointTargetPosition",
            "getJointTargetPosition", "getJointPosition", "getJointVelocity",
            "readProximitySensor", "getVisionSensorImg", "getVisionSensorResolution", "readForceSensor",
            "getSimulationTime", "getSimulationState", "getSimulationTimeStep", "getFloatParam",
            "setStepping", "step", "startSimulation", "stopSimulation", "pauseSimulation",
            "getObjectPosition", "getObjectOrientation", "getObjectPose", "getObjectVelocity",
            "setObjectPosition", "setObjectOrientation", "setObjectPose", "checkCollision",
        )]

    # --- running -----------------------------------------------------------------------------

    def bind(self) -> int:
        """Open the socket; returns the port (a free one when ``port`` is 0)."""
        if self._socket is not None:
            return self.port
        self._context = zmq.Context()
        sock = self._context.socket(zmq.REP)
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.SNDTIMEO, 1000)  # a reply never waits long for a peer
        try:
            if self.port == 0:
                self.port = sock.bind_to_random_port(f"tcp://{self.host}")
            else:
                sock.bind(f"tcp://{self.host}:{self.port}")
        except zmq.ZMQError as e:
            sock.close()
            self._context.term()
            self._context = None
            raise BackendError(f"labsim serve: cannot listen on {self.host}:{self.port}: {e.strerror}"
                               + (" (another server, or CoppeliaSim, already uses it; try --port)"
                                  if e.errno == zmq.EADDRINUSE else "")) from None
        self._socket = sock
        return self.port

    def serve_forever(self) -> None:
        """Answer requests until ``stop()``; KeyboardInterrupt propagates after cleaning up."""
        self.bind()
        sock = self._socket
        assert sock is not None
        timeout = -2
        try:
            while not self._stop.is_set():
                wait = self._poll_ms()
                if wait != timeout:  # a blocking recv with a timeout: cheaper than poll + recv
                    sock.setsockopt(zmq.RCVTIMEO, wait)
                    timeout = wait
                try:
                    raw = sock.recv()
                except zmq.Again:
                    self._run_clock()
                    continue
                reply = self.handle(raw)
                try:
                    sock.send(reply)
                except zmq.ZMQError:
                    # The peer went away mid-request and the reply could not leave: start
                    # a fresh socket rather than leave REP waiting to send forever.
                    self.log("labsim serve: a reply could not be sent; reopening the socket")
                    sock = self._reopen()
                    timeout = -2
                self._run_clock()
        finally:
            self._close()

    def stop(self) -> None:
        """Ask the serving loop to end (thread-safe); it does within POLL_MS."""
        self._stop.set()

    def start(self) -> Server:
        """Bind, then serve in a daemon thread (for tests and embedding); returns self."""
        self.bind()
        self._thread = threading.Thread(target=self.serve_forever, name="labsim-serve", daemon=True)
        self._thread.start()
        return self

    def join(self, timeout: float | None = 5.0) -> None:
        if self._thread is not None:
            self._thread.join(timeout)

    def __enter__(self) -> Server:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
        self.join()

    def _reopen(self) -> zmq.Socket:
        assert self._socket is not None
        self._socket.close(0)
        self._socket = None
        ctx = self._context
        self._context = None
        if ctx is not None:
            ctx.term()
        self.bind()
        assert self._socket is not None
        return self._socket

    def _close(self) -> None:
        if self._backend is not None:
            self._stop_simulation()
        if self._socket is not None:
            self._socket.close(0)
            self._socket = None
        if self._context is not None:
            self._context.term()
            self._context = None

    def _poll_ms(self) -> int:
        if self._state == RUNNING and not self._stepping():
            return max(0, min(POLL_MS, int((self._next_due - time.perf_counter()) * 1000) + 1))
        return POLL_MS

    def _stepping(self) -> bool:
        return any(c.stepping > 0 for c in self._clients.values())

    def _run_clock(self) -> None:
        """Free-running: advance to real time. Also forgets clients silent past their timeout."""
        if self._state != RUNNING or self._stepping():
            return
        now = time.perf_counter()
        if now - self._next_due > MAX_LAG_S:
            self._next_due = now  # too far behind (a slow machine): catch up from now
        while now >= self._next_due:
            self._advance()
            self._next_due += self.dt_s
        for c in list(self._clients.values()):
            if now - c.last_seen > c.timeout_s:
                del self._clients[c.uuid]

    # --- messages ----------------------------------------------------------------------------

    def handle(self, raw: bytes) -> bytes:
        """One request's bytes -> the reply's bytes. Never raises."""
        self.messages += 1
        try:
            req = cbor2.loads(raw)
        except Exception:
            return cbor2.dumps({"err": "labsim serve: the request is not a CBOR message"})
        if not isinstance(req, dict) or not isinstance(req.get("func"), str):
            return cbor2.dumps({"err": "labsim serve: a request is a CBOR map with a 'func' text"})
        if "uuid" not in req:  # a protocol-1 client (pip package before 2.0): what CoppeliaSim says
            return cbor2.dumps({"success": False, "error": E_VERSION})
        try:
            return cbor2.dumps(self._request(req))
        except Exception as e:  # a bug here must not take the server down
            self.log("labsim serve: internal error\n" + traceback.format_exc())
            return cbor2.dumps({"err": f"labsim serve: internal error in {req['func']}: {e!r}"})

    def _request(self, req: dict) -> dict:
        now = time.perf_counter()
        client = self._clients.get(str(req["uuid"]))
        if client is None:
            client = self._arrive(str(req["uuid"]), req, now)
        client.last_seen = now
        func: str = req["func"]
        args = req.get("args")
        if args is None:
            args = []
        elif not isinstance(args, list):
            return {"err": f"{E_ARGS} (in function '{func}')"}
        if func == "_*executed*_":
            pending, client.step_pending = client.step_pending, None
            if pending:
                self._client_step(client)
            return {"ret": []}
        handler = self._funcs.get(func)
        if handler is None:
            name = func.removeprefix("sim.")
            if func.startswith("sim.") and name in UNSUPPORTED:
                return {"err": f"labsim serve: {func} is not supported by this stand-in for CoppeliaSim "
                               f"(docs/coppeliasim.md lists what is)"}
            return {"err": f"No such function: {func}"}
        try:
            ret = handler(client, args)
        except _SimError as e:
            return {"err": f"{e} (in function '{func}')"}
        if ret is _WAIT:
            return {"func": "_*wait*_", "args": []}
        return {"ret": ret}

    def _arrive(self, uuid: str, req: dict, now: float) -> _Client:
        """A new client. Stepping clients silent for takeover_s are taken to have gone away:
        their simulation is stopped, so the newcomer does not find it frozen half-way."""
        gone = [c for c in self._clients.values() if now - c.last_seen > self.takeover_s]
        for c in gone:
            del self._clients[c.uuid]
        if any(c.stepping > 0 for c in gone) and self._state != STOPPED and not self._stepping():
            self.log(f"labsim serve: the client driving the simulation went away at "
                     f"t = {self._steps * self.dt_s:.2f} s; simulation stopped")
            self._stop_simulation()
        timeout = req.get("timeout", 600)
        client = _Client(uuid, str(req.get("lang", "?")),
                         float(timeout) if isinstance(timeout, (int, float)) and timeout > 0 else 600.0, now)
        self._clients[uuid] = client
        self.log(f"labsim serve: client {uuid[:8]} ({client.lang}) connected")
        return client

    # --- simulation --------------------------------------------------------------------------

    def _start_simulation(self) -> None:
        from labsim.backends.pymunk.backend import PymunkBackend

        backend = PymunkBackend()
        requests = [RobotRequest(f"PioneerP3DX[{i}]", r.model, r.pose, tuple(r.row))
                    for i, r in enumerate(self._robots)]
        if self._mech is not None:
            requests.append(RobotRequest(self.world.name, None, Pose(0.0, 0.0, 0.0),  # type: ignore[arg-type]
                                         tuple(self._mech_row)))
        backend.open(self.world, requests, self.dt_s, 0)
        self._backend = backend
        self._state = RUNNING
        self._steps = 0
        self._snap = None
        self._next_due = time.perf_counter() + self.dt_s
        for r in self._robots:
            r.target, r.acted = [0.0, 0.0], [0.0, 0.0]
            r.wheel, r.wheel_rate, r.yaw_rate = [0.0, 0.0], [0.0, 0.0], 0.0
            r.last = (r.pose.x_m, r.pose.y_m, _wrap(r.pose.heading_rad))
        self._mech_targets.clear()
        self._mech_pending.clear()
        self.log(f"labsim serve: simulation started (dt {self.dt_s:g} s)")

    def _stop_simulation(self) -> None:
        if self._backend is not None:
            self._backend.close()  # type: ignore[attr-defined]
            self.log(f"labsim serve: simulation stopped at t = {self._steps * self.dt_s:.2f} s "
                     f"({self._steps} steps)")
        self._backend = None
        self._state = STOPPED
        self._steps = 0
        self._snap = None
        for c in self._clients.values():
            c.stepping = 0  # CoppeliaSim's stopSimulation resets every client's stepping level
        for r in self._robots:
            r.target, r.wheel, r.wheel_rate, r.yaw_rate = [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], 0.0
        self._mech_targets.clear()
        self._mech_pending.clear()

    def _client_step(self, client: _Client) -> None:
        if self._state != RUNNING:
            return
        self._advance()
        if client.stepping == 0:
            # A free-running client asked to wait for the next step: it has happened now, so
            # the real-time clock restarts from here rather than stepping twice.
            self._next_due = time.perf_counter() + self.dt_s

    def _advance(self) -> None:
        """One step: wheel targets that changed, joint targets, physics, odometry."""
        backend = self._backend
        assert backend is not None
        for i, r in enumerate(self._robots):
            if r.target != r.acted:
                backend.act(i, r.target[0], r.target[1])  # type: ignore[attr-defined]
                r.acted = list(r.target)
        if self._mech_pending:
            for joint, (mode, value) in self._mech_pending.items():
                backend.command(self._mech, joint, mode, value)  # type: ignore[attr-defined]
            self._mech_pending.clear()
        backend.step()  # type: ignore[attr-defined]
        self._steps += 1
        self._snap = None
        dt = self.dt_s
        for i, r in enumerate(self._robots):
            # The wheels' angles follow from how the body moved (no slip): what a student
            # doing odometry from sim.getJointPosition expects, also when a wall stops it.
            x, y, a = backend.pose(i)  # type: ignore[attr-defined]
            x0, y0, a0 = r.last
            da = _wrap(a - a0)
            mid = a0 + da / 2
            d = (x - x0) * math.cos(mid) + (y - y0) * math.sin(mid)
            half = r.model.axle_length_m / 2
            radius = r.model.wheel_radius_m
            for side, sign in ((0, -1.0), (1, 1.0)):
                turn = (d + sign * da * half) / radius
                r.wheel[side] += turn
                r.wheel_rate[side] = turn / dt
            r.yaw_rate = da / dt
            r.last = (x, y, a)

    def _snapshot(self) -> list[list[object]]:
        if self._snap is None:
            self._snap = self._backend.sense()  # type: ignore[attr-defined]
        return self._snap

    def _robot_pose(self, i: int) -> tuple[float, float, float]:
        if self._backend is not None:
            return self._backend.pose(i)  # type: ignore[attr-defined]
        p = self._robots[i].pose
        return (p.x_m, p.y_m, _wrap(p.heading_rad))

    # --- arguments ---------------------------------------------------------------------------

    def _obj(self, args: list, i: int = 0, kinds: tuple[str, ...] = (), what: str = "") -> _Obj:
        if len(args) <= i:
            raise _SimError(E_FEW)
        h = args[i]
        if not isinstance(h, int) or isinstance(h, bool):
            raise _SimError(E_ARGS)
        obj = self._objs.get(h)
        if obj is None:
            raise _SimError(E_HANDLE)
        if kinds and obj.kind not in kinds:
            raise _SimError(f"object is not a {what}.")
        return obj

    @staticmethod
    def _num(args: list, i: int, default: float | None = None) -> float:
        if len(args) <= i or args[i] is None:
            if default is None:
                raise _SimError(E_FEW)
            return default
        v = args[i]
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
            raise _SimError(E_ARGS)
        return float(v)

    @staticmethod
    def _int(args: list, i: int, default: int) -> int:
        if len(args) <= i or args[i] is None:
            return default
        v = args[i]
        if not isinstance(v, int) or isinstance(v, bool):
            raise _SimError(E_ARGS)
        return v

    @staticmethod
    def _vec(args: list, i: int, n: int) -> list[float]:
        if len(args) <= i:
            raise _SimError(E_FEW)
        v = args[i]
        if not isinstance(v, (list, tuple)) or len(v) < n or not all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v[:n]):
            raise _SimError(E_ARGS)
        return [float(x) for x in v[:n]]

    # --- zmqRemoteApi ------------------------------------------------------------------------

    def _require(self, client: _Client, args: list) -> list:
        name = args[0] if args else None
        if name != "sim":
            raise _SimError(f"module '{name}' not found: labsim serve offers only 'sim'")
        return []

    def _info(self, client: _Client, args: list) -> list:
        if not args or args[0] != "sim":
            raise _SimError(f"labsim serve: no object '{args[0] if args else None}' (only 'sim')")
        info: dict[str, object] = {name.removeprefix("sim."): {"func": {}} for name in self.functions()}
        info.update({name: {"func": {}} for name in UNSUPPORTED})
        info.update({name: {"const": value} for name, value in CONSTANTS.items()})
        return [info]

    # --- objects -----------------------------------------------------------------------------

    def _path(self, obj: _Obj, short: bool = False) -> str:
        parts = []
        o: _Obj | None = obj
        while o is not None:
            siblings = o.parent.children if o.parent is not None else self._top
            same = [s for s in siblings if s.alias == o.alias]
            parts.append(f"{o.alias}[{same.index(o)}]" if len(same) > 1 or not short else o.alias)
            o = o.parent
        return "/" + "/".join(reversed(parts))

    def _find(self, path: str, index: int, proxy: _Obj | None) -> _Obj | None:
        """sim.getObject's rules: see the module docstring of this file and the manual's
        'Accessing scene objects programmatically'. None when nothing matches."""
        if path.startswith("/"):
            base, rest = None, path[1:]
        elif path in (".", "..", ":") or path.startswith(("./", ":/")):
            if proxy is None:
                return None  # relative paths need a proxy object: a remote client has no script
            if path == ".":
                return proxy
            if path == "..":
                return proxy.parent
            model = proxy
            while model.parent is not None:
                model = model.parent
            if path == ":":
                return model
            base, rest = (proxy, path[2:]) if path.startswith("./") else (model, path[2:])
        else:
            return self._old_names.get(path)  # an old-style object name
        if not rest:
            return base
        segments = rest.split("/")
        for n, seg in enumerate(segments):
            m = _SEGMENT.match(seg)
            if m is None:
                return None
            pattern = re.compile(re.escape(m["alias"]).replace(r"\*", ".*").replace(r"\?", "."))
            level = base.children if base is not None else self._top
            last = n == len(segments) - 1
            if m["any"] is not None or (last and index >= 0 and m["sib"] is None):
                # {n} or the index option: the n-th match anywhere below, level by level
                k = int(m["any"]) if m["any"] is not None else index
                found = []
                while level and len(found) <= k:
                    found += [o for o in level if pattern.fullmatch(o.alias)]
                    level = [c for o in level for c in o.children]
                if k >= len(found):
                    return None
                base = found[k]
            else:
                # alias[n]: the n-th match among the first level below that has any
                k = int(m["sib"] or 0)
                while level:
                    found = [o for o in level if pattern.fullmatch(o.alias)]
                    if found:
                        break
                    level = [c for o in level for c in o.children]
                else:
                    return None
                if k >= len(found):
                    return None
                base = found[k]
        return base

    def _sim_getObject(self, client: _Client, args: list) -> list:
        if not args:
            raise _SimError(E_FEW)
        path = args[0]
        options = args[1] if len(args) > 1 and args[1] is not None else {}
        if not isinstance(path, str) or not isinstance(options, (dict, list)):
            raise _SimError(E_ARGS)
        options = options if isinstance(options, dict) else {}  # an empty Lua table may arrive as []
        index = options.get("index", -1)
        proxy_h = options.get("proxy", -1)
        if not isinstance(index, int) or not isinstance(proxy_h, int):
            raise _SimError(E_ARGS)
        proxy = self._objs.get(proxy_h) if proxy_h != -1 else None
        if proxy_h != -1 and proxy is None:
            raise _SimError(E_HANDLE)
        obj = self._find(path, index, proxy)
        if obj is not None:
            return [obj.handle]
        if options.get("noError"):
            return [-1]
        robots = [self._path(r.obj) for r in self._robots]
        hint = (f"this scene has {len(robots)} robot{'s' if len(robots) != 1 else ''}: "
                + ", ".join(robots) if robots else "this scene has no robots")
        if path.startswith(("./", ":/")) and proxy is None:
            hint = "a relative path needs the proxy option, e.g. {'proxy': robotHandle}"
        raise _SimError(f"{E_PATH} (labsim serve: no object '{path}'; {hint})")

    def _sim_getObjectHandle(self, client: _Client, args: list) -> list:
        return self._sim_getObject(client, args[:1])

    def _sim_getObjectAlias(self, client: _Client, args: list) -> list:
        obj = self._obj(args)
        options = self._int(args, 1, -1)
        if options == -1:
            return [obj.alias]
        if options == 0:
            siblings = obj.parent.children if obj.parent is not None else self._top
            return [f"{obj.alias}[{[s for s in siblings if s.alias == obj.alias].index(obj)}]"]
        if options in (1, 5):
            return [self._path(obj, short=True)]
        if options in (3, 4):
            return [f"{obj.alias}__{obj.handle}__"]
        return [self._path(obj)]

    def _sim_getObjectParent(self, client: _Client, args: list) -> list:
        obj = self._obj(args)
        return [obj.parent.handle if obj.parent is not None else -1]

    # --- joints ------------------------------------------------------------------------------

    def _joint_spec(self, obj: _Obj) -> object:
        return self.world.mechanism.joint(obj.name)  # type: ignore[union-attr]

    def _set_joint(self, obj: _Obj, mode: str, value: float) -> None:
        spec = self._joint_spec(obj)
        motor = getattr(spec, "motor", None)
        if motor is None:
            raise _SimError(f"labsim serve: joint '{obj.name}' has no motor: it moves only as pushed")
        if not getattr(motor, mode, True):
            other = "position" if mode == "velocity" else "velocity"
            raise _SimError(f"labsim serve: joint '{obj.name}' takes {other} targets only")
        self._mech_targets[obj.name] = (mode, value)
        if self._state != STOPPED:
            self._mech_pending[obj.name] = (mode, value)

    def _sim_setJointTargetVelocity(self, client: _Client, args: list) -> list:
        obj = self._obj(args, 0, ("motor", "joint"), "joint")
        v = self._num(args, 1)
        if obj.kind == "motor":
            self._robots[obj.robot].target[obj.index] = v
        else:
            self._set_joint(obj, "velocity", v)
        return []

    def _sim_getJointTargetVelocity(self, client: _Client, args: list) -> list:
        obj = self._obj(args, 0, ("motor", "joint"), "joint")
        if obj.kind == "motor":
            return [self._robots[obj.robot].target[obj.index]]
        mode, value = self._mech_targets.get(obj.name, ("velocity", 0.0))
        return [value if mode == "velocity" else 0.0]

    def _sim_setJointTargetPosition(self, client: _Client, args: list) -> list:
        obj = self._obj(args, 0, ("motor", "joint"), "joint")
        p = self._num(args, 1)
        if obj.kind == "motor":
            raise _SimError("labsim serve: the wheel motors are velocity-controlled; "
                            "use sim.setJointTargetVelocity")
        self._set_joint(obj, "position", p)
        return []

    def _sim_getJointTargetPosition(self, client: _Client, args: list) -> list:
        obj = self._obj(args, 0, ("motor", "joint"), "joint")
        if obj.kind == "motor":
            return [0.0]
        mode, value = self._mech_targets.get(obj.name, ("velocity", 0.0))
        return [value if mode == "position" else self._joint_state(obj)[0]]

    def _joint_state(self, obj: _Obj) -> tuple[float, float]:
        if self._backend is None:
            spec = self._joint_spec(obj)
            return (self.world.mechanism.initial_position(spec), 0.0)  # type: ignore[union-attr]
        value = self._snapshot()[self._mech][self._mech_row[obj.name]]  # type: ignore[index]
        return (float(value[0]), float(value[1]))  # type: ignore[index]

    def _sim_getJointPosition(self, client: _Client, args: list) -> list:
        obj = self._obj(args, 0, ("motor", "joint"), "joint")
        if obj.kind == "motor":
            # Wheels are cyclic revolute joints: CoppeliaSim reports their angle in (-pi, pi].
            return [_wrap(self._robots[obj.robot].wheel[obj.index])]
        return [self._joint_state(obj)[0]]

    def _sim_getJointVelocity(self, client: _Client, args: list) -> list:
        obj = self._obj(args, 0, ("motor", "joint"), "joint")
        if obj.kind == "motor":
            return [self._robots[obj.robot].wheel_rate[obj.index]]
        return [self._joint_state(obj)[1]]

    # --- sensors -----------------------------------------------------------------------------

    def _sim_readProximitySensor(self, client: _Client, args: list) -> list:
        obj = self._obj(args, 0, ("sonar",), "proximity sensor")
        if self._backend is None or self._steps == 0:  # not yet handled by a step
            return [0, 0.0, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]]
        r = self._robots[obj.robot]
        d = self._snapshot()[obj.robot][r.row[obj.name]]
        if d == math.inf:
            return [0, 0.0, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0]]
        return [1, d, [0.0, 0.0, d], -1, [0.0, 0.0, 0.0]]

    def _image(self, obj: _Obj) -> np.ndarray:
        """The camera's image as CoppeliaSim's buffer: RGB, rows from the bottom up."""
        w, h = obj.resolution
        if self._backend is None or self._steps == 0:
            return np.zeros((h, w, 3), np.uint8)
        img = self._snapshot()[obj.robot][self._robots[obj.robot].row[obj.name]]
        return np.asarray(img, dtype=np.uint8)[::-1]  # labsim: row 0 is the far edge (the top)

    def _sim_getVisionSensorImg(self, client: _Client, args: list) -> list:
        obj = self._obj(args, 0, ("camera",), "vision sensor")
        options = self._int(args, 1, 0)
        img = self._image(obj)
        w, h = obj.resolution
        pos = args[3] if len(args) > 3 and args[3] else [0, 0]
        size = args[4] if len(args) > 4 and args[4] else [0, 0]
        try:
            x0, y0 = int(pos[0]), int(pos[1])
            sx, sy = int(size[0]) or w - x0, int(size[1]) or h - y0
        except (TypeError, ValueError, IndexError):
            raise _SimError(E_ARGS) from None
        if not (0 <= x0 < w and 0 <= y0 < h and 0 < sx <= w - x0 and 0 < sy <= h - y0):
            raise _SimError(E_ARGS)
        img = img[y0:y0 + sy, x0:x0 + sx]
        if options & 1:  # greyscale, one byte a pixel
            img = (img.astype(np.uint16).sum(axis=2) // 3).astype(np.uint8)
        elif options & 2:  # RGBA
            img = np.concatenate([img, np.full(img.shape[:2] + (1,), 255, np.uint8)], axis=2)
        return [np.ascontiguousarray(img).tobytes(), [sx, sy]]

    def _sim_getVisionSensorResolution(self, client: _Client, args: list) -> list:
        obj = self._obj(args, 0, ("camera",), "vision sensor")
        return [list(obj.resolution)]

    def _sim_readForceSensor(self, client: _Client, args: list) -> list:
        obj = self._obj(args, 0, ("force",), "force sensor")
        if self._backend is None or self._steps == 0:
            return [0, [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
        value = self._snapshot()[self._mech][self._mech_row[obj.name]]  # type: ignore[index]
        tension = float(value[0] if isinstance(value, (tuple, list)) else value)  # type: ignore[index]
        return [1, [0.0, 0.0, tension], [0.0, 0.0, 0.0]]

    def _sim_checkCollision(self, client: _Client, args: list) -> list:
        a = self._obj(args, 0)
        if len(args) < 2 or not isinstance(args[1], int):
            raise _SimError(E_FEW if len(args) < 2 else E_ARGS)
        if a.kind != "robot" or args[1] != HANDLE_ALL:
            raise _SimError("labsim serve: only sim.checkCollision(robot, sim.handle_all) is supported")
        if self._backend is None or self._steps == 0:
            return [0, [-1, -1]]
        hit = bool(self._snapshot()[a.robot][self._robots[a.robot].row["collided"]])
        return [1, [a.handle, -1]] if hit else [0, [-1, -1]]

    # --- time and state ----------------------------------------------------------------------

    def _sim_getSimulationTime(self, client: _Client, args: list) -> list:
        return [self._steps * self.dt_s]

    def _sim_getSimulationState(self, client: _Client, args: list) -> list:
        return [self._state]

    def _sim_getSimulationTimeStep(self, client: _Client, args: list) -> list:
        return [self.dt_s]

    def _sim_getFloatParam(self, client: _Client, args: list) -> list:
        param = self._int(args, 0, -1)
        if param == CONSTANTS["floatparam_simulation_time_step"]:
            return [self.dt_s]
        raise _SimError("labsim serve: only sim.floatparam_simulation_time_step can be read")

    def _sim_setStepping(self, client: _Client, args: list) -> list:
        before = client.stepping
        if args and args[0]:
            client.stepping += 1
        elif client.stepping > 0:
            client.stepping -= 1
        if before > 0 and not self._stepping():
            self._next_due = time.perf_counter() + self.dt_s  # free-running again from now
        return [before]

    def _sim_step(self, client: _Client, args: list) -> object:
        client.step_pending = self._state == RUNNING
        return _WAIT

    def _sim_startSimulation(self, client: _Client, args: list) -> list:
        if self._state == STOPPED:
            self._start_simulation()
        elif self._state == PAUSED:
            self._state = RUNNING
            self._next_due = time.perf_counter() + self.dt_s
        return []

    def _sim_stopSimulation(self, client: _Client, args: list) -> list:
        self._stop_simulation()
        return []

    def _sim_pauseSimulation(self, client: _Client, args: list) -> list:
        if self._state == RUNNING:
            self._state = PAUSED
        return []

    # --- poses -------------------------------------------------------------------------------

    def _world_pose(self, obj: _Obj) -> tuple[float, float, float, float]:
        """x, y, z, yaw of an object in the world."""
        if obj.kind == "robot":
            x, y, a = self._robot_pose(obj.robot)
            return (x, y, ROBOT_Z_M, a)
        if obj.kind in ("joint", "force", "body"):
            x, y, z, slew, _ = self._mechanism_frame(obj)
            return (x, y, z, _wrap(slew))
        assert obj.parent is not None
        px, py, pz, pa = self._world_pose(obj.parent)
        mx, my, mz, ma = obj.mount
        c, s = math.cos(pa), math.sin(pa)
        return (px + c * mx - s * my, py + s * mx + c * my, pz + mz, _wrap(pa + ma))

    def _mechanism_frame(self, obj: _Obj) -> tuple[float, float, float, float, float]:
        """X, Y, Z of a mechanism part in 3D, the slew angle and its angle in the plane.

        A body's place in the vertical plane (x along, z up) turned by the slew angle about the
        slew axis (labsim.backends.scene.mechanism); a joint is where its child body is, a force
        sensor where its second body is."""
        m = self.world.mechanism
        name = obj.name
        if obj.kind == "joint":
            name = self._joint_spec(obj).child  # type: ignore[attr-defined]
        elif obj.kind == "force":
            name = next(s.between[1] for s in m.force_sensors if s.name == obj.name)  # type: ignore[union-attr]
        if self._backend is not None and name in self._mech_row:
            x, z, theta = self._snapshot()[self._mech][self._mech_row[name]]  # type: ignore[index, misc]
        else:
            body = m.body(name)  # type: ignore[union-attr]
            (x, z), theta = body.center, body.angle_rad
        slew = m.slew  # type: ignore[union-attr]
        angle = 0.0
        if slew is not None and slew.name in self._mech_row:
            angle = self._joint_state(next(o for o in self._top if o.name == slew.name))[0]
        if angle == 0.0:
            return (float(x), 0.0, float(z), 0.0, float(theta))
        ax = slew.anchor[0]  # type: ignore[union-attr]
        r = float(x) - ax
        return (ax + r * math.cos(angle), r * math.sin(angle), float(z), angle, float(theta))

    @staticmethod
    def _plane_rotation(slew: float, theta: float) -> tuple[list[float], list[float]]:
        """CoppeliaSim's Euler angles and quaternion (x, y, z, w) of Rz(slew) Ry(-theta): a body
        tilted by theta in its vertical plane (counter-clockwise from x toward z), turned by
        the slew about the vertical."""
        if slew == 0.0 and abs(theta) <= math.pi / 2:
            # Ry(-theta) alone: beta is exactly -theta, which the backend reads back exactly
            c2, st2 = math.cos(theta / 2), math.sin(theta / 2)
            return [0.0, -theta, 0.0], [0.0, -st2, 0.0, c2]
        cs, ss, ct, st = math.cos(slew), math.sin(slew), math.cos(theta), math.sin(theta)
        # R = Rx(alpha) Ry(beta) Rz(gamma) with R = [[cs ct, -ss, -cs st], [ss ct, cs, -ss st], [st, 0, ct]]
        euler = [math.atan2(ss * st, ct), math.asin(max(-1.0, min(1.0, -cs * st))), math.atan2(ss, cs * ct)]
        c2, s2, ct2, st2 = math.cos(slew / 2), math.sin(slew / 2), math.cos(theta / 2), math.sin(theta / 2)
        return euler, [s2 * st2, -c2 * st2, s2 * ct2, c2 * ct2]

    def _relative(self, obj: _Obj, rel: int) -> tuple[float, float, float, float]:
        if obj.kind == "robot" and rel in (HANDLE_WORLD, HANDLE_PARENT):
            return self._world_pose(obj)  # exactly what the backend says, no arithmetic
        if rel == HANDLE_PARENT:
            if obj.parent is None:
                return self._world_pose(obj)
            return obj.mount
        x, y, z, a = self._world_pose(obj)
        if rel == HANDLE_WORLD:
            return (x, y, z, a)
        ref = self._objs.get(rel)
        if ref is None:
            raise _SimError(E_HANDLE)
        rx, ry, rz, ra = self._world_pose(ref)
        c, s = math.cos(ra), math.sin(ra)
        dx, dy = x - rx, y - ry
        return (c * dx + s * dy, -s * dx + c * dy, z - rz, _wrap(a - ra))

    def _sim_getObjectPosition(self, client: _Client, args: list) -> list:
        obj = self._obj(args)
        x, y, z, _ = self._relative(obj, self._int(args, 1, HANDLE_WORLD))
        return [[x, y, z]]

    def _mechanism_part(self, obj: _Obj, args: list) -> bool:
        """Whether obj is part of the mechanism (asked for in the world frame: the only one)."""
        if obj.kind not in ("joint", "force", "body"):
            return False
        if self._int(args, 1, HANDLE_WORLD) not in (HANDLE_WORLD, HANDLE_PARENT):
            raise _SimError("labsim serve: a mechanism's parts are given relative to the world only")
        return True

    def _sim_getObjectOrientation(self, client: _Client, args: list) -> list:
        obj = self._obj(args)
        if self._mechanism_part(obj, args):
            *_, slew, theta = self._mechanism_frame(obj)
            return [self._plane_rotation(slew, theta)[0]]
        *_, a = self._relative(obj, self._int(args, 1, HANDLE_WORLD))
        return [[0.0, 0.0, a]]

    def _sim_getObjectPose(self, client: _Client, args: list) -> list:
        obj = self._obj(args)
        if self._mechanism_part(obj, args):
            x, y, z, slew, theta = self._mechanism_frame(obj)
            return [[x, y, z, *self._plane_rotation(slew, theta)[1]]]
        x, y, z, a = self._relative(obj, self._int(args, 1, HANDLE_WORLD))
        return [[x, y, z, 0.0, 0.0, math.sin(a / 2), math.cos(a / 2)]]

    def _sim_getObjectVelocity(self, client: _Client, args: list) -> list:
        obj = self._obj(args)
        if obj.kind != "robot" or self._backend is None:
            return [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
        r = self._robots[obj.robot]
        row = self._snapshot()[obj.robot]
        a = row[r.row["heading"]]
        v = row[r.row["forward_speed"]] if "forward_speed" in r.row else 0.0
        return [[v * math.cos(a), v * math.sin(a), 0.0], [0.0, 0.0, r.yaw_rate]]  # type: ignore[operator]

    def _placeable(self, args: list) -> tuple[_Robot, object, int]:
        """The robot to move and the remaining (value, frame) arguments, in either order:
        (h, value, frame) since CoppeliaSim 4.5, (h, frame, value) before."""
        obj = self._obj(args)
        if obj.kind != "robot":
            raise _SimError("labsim serve: only robots can be moved")
        if self._state != STOPPED:
            raise _SimError("labsim serve: robots can be placed only while the simulation is stopped")
        if len(args) < 2:
            raise _SimError(E_FEW)
        if isinstance(args[1], int) and not isinstance(args[1], bool) and len(args) > 2:
            value, rel = args[2], args[1]
        else:
            value, rel = args[1], (args[2] if len(args) > 2 and args[2] is not None else HANDLE_WORLD)
        if rel not in (HANDLE_WORLD, HANDLE_PARENT):
            raise _SimError("labsim serve: robots are placed relative to the world only")
        return self._robots[obj.robot], value, rel

    def _sim_setObjectPosition(self, client: _Client, args: list) -> list:
        r, value, _ = self._placeable(args)
        x, y, _z = self._vec([value], 0, 3)
        r.pose = Pose(x, y, r.pose.heading_rad)
        return []

    def _sim_setObjectOrientation(self, client: _Client, args: list) -> list:
        r, value, _ = self._placeable(args)
        alpha, beta, gamma = self._vec([value], 0, 3)
        if abs(alpha) > 1e-6 or abs(beta) > 1e-6:
            raise _SimError("labsim serve: the scene is flat; robots turn about z only (alpha = beta = 0)")
        r.pose = Pose(r.pose.x_m, r.pose.y_m, gamma)
        return []

    def _sim_setObjectPose(self, client: _Client, args: list) -> list:
        r, value, _ = self._placeable(args)
        x, y, _z, qx, qy, qz, qw = self._vec([value], 0, 7)
        if abs(qx) > 1e-6 or abs(qy) > 1e-6:
            raise _SimError("labsim serve: the scene is flat; robots turn about z only")
        r.pose = Pose(x, y, _wrap(2.0 * math.atan2(qz, qw)))
        return []


_WAIT = object()  # a handler's answer meaning: reply _*wait*_


def serve(world: World, robots: int | Sequence[object] = 1, port: int = DEFAULT_PORT,
          host: str = "127.0.0.1", *, dt_s: float = 0.05, takeover_s: float = TAKEOVER_S,
          log: Callable[[str], None] | None = None,
          ready: Callable[[Server], None] | None = None) -> None:
    """Serve until Ctrl-C (SIGINT), SIGTERM or ``stop()`` on the server given to ``ready``.

    ``ready(server)`` is called once the socket is bound (``server.port`` is then the real
    port, also for ``port=0``).
    """
    server = Server(world, robots, host=host, port=port, dt_s=dt_s, takeover_s=takeover_s, log=log)
    server.bind()
    previous = None
    if threading.current_thread() is threading.main_thread():
        import signal

        # SIGTERM (a service manager, `kill`) ends the loop like Ctrl-C, closing the socket.
        previous = signal.signal(signal.SIGTERM, lambda *_: server.stop())
    try:
        if ready is not None:
            ready(server)
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server._close()
        if previous is not None:
            import signal

            signal.signal(signal.SIGTERM, previous)
