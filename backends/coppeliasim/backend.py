"""CoppeliaSim as a labsim backend, through its ZeroMQ remote API.

Where it sits: the runtime drives this class through ``labsim.backends.protocol.Backend``
exactly as it drives the embedded pymunk backend; this class turns each call into remote API
calls of the unmodified client ``coppeliasim_zmqremoteapi_client`` (imported here and
nowhere else), sent to a CoppeliaSim 4.6+ with the ZMQ remote API add-on, or to ``labsim
serve`` (``server.py``), which answers the same protocol without CoppeliaSim.

* ``open`` checks the simulation time step against the behaviour's ``dt`` (a mismatch is an
  error saying both and how to fix it), finds the objects by path (``MODEL_PATHS``:
  ``/PioneerP3DX[i]`` for the i-th robot, then ``./leftMotor``, ``./rightMotor``,
  ``./ultrasonicSensor[k]`` relative to it), moves each robot to the start pose the behaviour
  asks for, and starts the simulation in stepping mode, with one step (robots at rest) so that
  every sensor has been read once (CoppeliaSim handles sensors at the end of a step).
* ``sense`` reads only the channels the behaviour asked for, in one call per value: a sonar
  is ``sim.readProximitySensor`` (nothing detected: ``math.inf``, where CoppeliaSim says 0),
  ``x``/``y`` one ``sim.getObjectPosition``, ``heading`` one ``sim.getObjectOrientation``
  (yaw), a camera ``sim.getVisionSensorImg`` flipped to row 0 = far edge. ``collided`` is
  ``sim.checkCollision(robot, sim.handle_all)``, read every tick for every robot because the
  contact count of the summary is built from it (a contact = a tick on which it turns true).
* ``act`` sends a wheel's target velocity only when that wheel's command changed.
* ``step`` is one ``sim.step`` (two round trips: CoppeliaSim answers "wait", the client says
  "executed", then the step's end comes back). It is never retried: a retry could step twice.

Failures never hang: the client's socket gets ``LINGER`` 0 and send/receive timeouts of
``timeout_s``; no answer in time is a ``BackendError`` naming host and port, and the
connection is then dead (a REQ socket cannot be reused after a lost reply). ``round_trips``
counts every request sent, so the summary can report round trips per tick.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from typing import Sequence

from labsim.backends.coppeliasim import DEFAULT_PORT, MODEL_PATHS
from labsim.backends.scene.ground import ROAD_CHANNELS, RoadTracker, first_road, world_channels
from labsim.backends.protocol import BackendError, BackendStateError, ContactStats, RobotRequest
from labsim.backends.scene.world import World

try:
    import zmq
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient
except ImportError as _missing:  # pragma: no cover - depends on the installation
    raise BackendError(
        f"the coppeliasim backend needs the CoppeliaSim ZMQ remote API client ({_missing.name} is "
        "missing); install it with: pip install 'labsim[coppeliasim]' "
        "(coppeliasim-zmqremoteapi-client==2.0.4, pyzmq, cbor2)"
    ) from None

HANDLE_WORLD, HANDLE_ALL = -1, -2  # sim.handle_world, sim.handle_all (also read from the server)
SIMULATION_STOPPED = 0


@dataclass(eq=False)
class _Robot:
    """What sense() and act() need for one robot: handles and where each value goes."""

    name: str
    handle: int
    channels: tuple[str, ...]
    motors: tuple[int, int] = (-1, -1)
    sonars: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot)
    cameras: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot)
    collide_with: int = HANDLE_ALL
    slots: dict[str, int] = field(default_factory=dict)  # pose, collided, speed, road channels
    read_position: bool = False
    read_orientation: bool = False
    read_velocity: bool = False
    sent: list[float] = field(default_factory=lambda: [math.nan, math.nan])  # last wheel targets sent
    # a mechanism: handles by channel, and what turns 3D poses into its plane
    joints: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot): (position, velocity)
    forces: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot): (tension,)
    bodies: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot): (x, z, angle)
    joint_handles: dict[str, int] = field(default_factory=dict)  # motorised joints, for command()
    mechanism: bool = False
    slew: int = -1  # the slew joint's handle, -1 without one
    slew_axis_x: float = 0.0
    tracked: int = -1  # the body whose plane position is x, y (the last moving body)
    # contacts, counted from collided (kept after close for the summary)
    touching: bool = False
    contacts: int = 0
    contact_s: float = 0.0


class CoppeliaSimBackend:
    """The ``Backend`` protocol on CoppeliaSim's ZMQ remote API (protocol 2, CoppeliaSim 4.6+).

    ``paths`` overrides entries of ``MODEL_PATHS[model]`` (e.g. ``{"robot": "/Pioneer[{i}]"}``);
    ``place_robots=False`` keeps the robots where the scene has them instead of moving them to
    the behaviour's start poses.
    """

    name = "coppeliasim"

    def __init__(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT, timeout_s: float = 5.0,
                 paths: dict[str, object] | None = None, place_robots: bool = True) -> None:
        if not (isinstance(timeout_s, (int, float)) and math.isfinite(timeout_s) and timeout_s > 0):
            raise BackendError(f"coppeliasim backend: timeout_s must be a positive number of seconds, "
                               f"not {timeout_s!r}")
        if not isinstance(port, int) or not 0 < port < 65536:
            raise BackendError(f"coppeliasim backend: port must be 1..65535, not {port!r}")
        self.host = host
        self.port = port
        self.timeout_s = float(timeout_s)
        self.paths = dict(paths or {})
        self.place_robots = place_robots
        self.round_trips = 0  # requests sent (each is one round trip)
        self.round_trips_open = 0  # ... of which open() sent
        self.steps = 0  # sim.step calls since open, the priming step not counted
        self._client: RemoteAPIClient | None = None
        self._robots: list[_Robot] = []
        self._dt = 0.0
        self._tracker: RoadTracker | None = None
        self._sensed = 0  # sense() calls since open
        self._opened = False
        self._running = False  # we started the simulation and have not stopped it
        self._busy = False  # a request is out and its answer not yet in (interrupted mid-call)
        self._dead = ""  # why the connection cannot be used any more
        self._sim: object | None = None  # client.require("sim"): the server's functions and constants

    @property
    def where(self) -> str:
        return f"{self.host}:{self.port}"

    # --- the connection ----------------------------------------------------------------------

    def _connect(self, timeout_s: float) -> RemoteAPIClient:
        main = sys.modules["__main__"].__dict__
        had, previous = "require" in main, main.get("require")
        client = RemoteAPIClient(self.host, self.port)
        # The client puts its `require` into __main__'s globals (for interactive use); a
        # backend has no business changing the program's namespace, so undo it.
        if had:
            main["require"] = previous
        else:
            main.pop("require", None)
        sock = client.socket
        sock.setsockopt(zmq.LINGER, 0)  # closing never waits for unsent requests
        sock.setsockopt(zmq.RCVTIMEO, max(1, int(timeout_s * 1000)))
        sock.setsockopt(zmq.SNDTIMEO, max(1, int(timeout_s * 1000)))
        send = client._send

        def counted(req: dict) -> None:
            self.round_trips += 1
            send(req)

        client._send = counted  # count every request, including the "executed" of sim.step
        return client

    @staticmethod
    def _disconnect(client: RemoteAPIClient) -> None:
        try:
            client.socket.close(0)
            client.context.term()
        except zmq.ZMQError:
            pass

    def _call(self, func: str, *args: object) -> object:
        """One remote call; every failure becomes a BackendError naming the server."""
        client = self._client
        if client is None:
            raise self._state_error(func)
        if self._dead:
            raise BackendError(self._dead)
        self._busy = True
        try:
            out = client.call(func, list(args))
        except Exception as e:  # zmq.Again, zmq.ZMQError, KeyError, or the server's error
            raise self._failure(e, func) from None
        self._busy = False
        return out

    def _failure(self, e: BaseException, func: str) -> BackendError:
        """The BackendError for an exception of the client during ``func``.

        No answer in time, or a socket error, kills the connection (a REQ socket whose reply
        was lost cannot send again, and sim.step must not be sent twice); an error the server
        answered leaves it usable."""
        if isinstance(e, BackendError):
            return e
        if isinstance(e, zmq.Again):
            if self._sim is None:  # the first request: nothing there, or not CoppeliaSim's API
                self._dead = (
                    f"no answer from CoppeliaSim at {self.where} within {self.timeout_s:g} s. Is "
                    f"CoppeliaSim running, with its ZMQ remote API add-on listening on port "
                    f"{self.port}? (Without CoppeliaSim: labsim serve --port {self.port})")
            else:
                self._dead = (
                    f"CoppeliaSim at {self.where} stopped answering: no reply to {func} within "
                    f"{self.timeout_s:g} s{self._progress()}. CoppeliaSim (or labsim serve) may "
                    f"have been closed, or be busy; the run cannot go on")
            return BackendError(self._dead)
        if isinstance(e, zmq.ZMQError):
            self._dead = f"CoppeliaSim at {self.where}: connection failed during {func}: {e}"
            return BackendError(self._dead)
        self._busy = False  # the server answered: the exchange is complete
        if isinstance(e, KeyError):  # a reply without 'ret': a protocol-1 server
            return BackendError(
                f"CoppeliaSim at {self.where} answered {func} in an older protocol ({e!r} missing): "
                f"CoppeliaSim 4.5 or earlier; use CoppeliaSim 4.6 or newer with "
                f"coppeliasim-zmqremoteapi-client 2.x")
        return BackendError(self._explain(func, str(e)))  # the server's {"err": ...}

    def _explain(self, func: str, err: str) -> str:
        if "No such function: zmqRemoteApi.require" in err or \
                "client ZeroMQ remote API version does not match" in err:
            return (f"CoppeliaSim at {self.where} speaks another version of the ZMQ remote API "
                    f"({err!r}). labsim uses coppeliasim-zmqremoteapi-client 2.0.4 (protocol 2), "
                    f"which needs CoppeliaSim 4.6 or newer; update CoppeliaSim, or its ZMQ remote "
                    f"API add-on")
        return f"CoppeliaSim at {self.where}: {func} failed: {err}"

    def _progress(self) -> str:
        if not self.steps:
            return ""
        return f", after {self.steps} steps (t = {self.steps * self._dt:.2f} s)"

    # --- protocol ----------------------------------------------------------------------------

    def open(self, world: World, robots: Sequence[RobotRequest], dt_s: float, seed: int) -> None:
        """Connect, check dt, find the objects, place the robots, start stepping."""
        if self._client is not None:
            raise BackendStateError("coppeliasim backend: open() called twice; close() it first")
        if not dt_s > 0:
            raise BackendError(f"coppeliasim backend: dt_s must be positive, not {dt_s!r}")
        plans = self._plans(world, robots)  # every channel checked before connecting
        self._dt = float(dt_s)
        self._dead = ""
        self._sim = None
        self.round_trips = self.steps = self._sensed = 0
        self._client = self._connect(self.timeout_s)
        try:
            self._open(world, robots, plans)
        except BaseException:
            self.close()
            raise
        self._opened = True
        self.round_trips_open = self.round_trips

    def _plans(self, world: World, robots: Sequence[RobotRequest]) -> list[dict[str, object]]:
        """Each robot's paths, checked against its channels; no connection needed."""
        from_world = world_channels(world)
        plans = []
        for req in robots:
            if req.model is None:  # the world's mechanism
                mech = world.mechanism
                if mech is None:
                    raise BackendError(f"'{req.name}': world '{world.name}' has no mechanism")
                known = {j.name for j in mech.joints if j.kind != "fixed"}  # type: ignore[attr-defined]
                known |= {s.name for s in mech.force_sensors}  # type: ignore[attr-defined]
                known |= {b.name for b in mech.bodies if not b.static}  # type: ignore[attr-defined]
                for ch in req.channels:
                    if ch not in known and ch not in ("x", "y", "heading", "collided"):
                        raise BackendError(f"'{req.name}' asks for unknown channel '{ch}'; world "
                                           f"'{world.name}' offers: {', '.join(sorted(known))}")
                plans.append({})
                continue
            paths = dict(MODEL_PATHS.get(req.model.name, {}))
            if not paths and not self.paths:
                raise BackendError(
                    f"robot '{req.name}': the coppeliasim backend knows no scene object names for model "
                    f"'{req.model.name}'; pass paths={{'robot': ..., 'left_motor': ..., ...}}")
            paths.update(self.paths)
            paths.update(dict(req.paths))  # the behaviour file's, for this robot
            offered = req.model.channels()
            for ch in req.channels:
                if ch not in offered and ch not in from_world:
                    raise BackendError(
                        f"robot '{req.name}' asks for unknown channel '{ch}'; model "
                        f"'{req.model.name}' offers: {', '.join([*offered, *from_world])}")
            plans.append(paths)
        return plans

    def _open(self, world: World, robots: Sequence[RobotRequest], plans: list[dict[str, object]]) -> None:
        self._busy = True
        try:
            sim = self._client.require("sim")  # type: ignore[union-attr]
        except Exception as e:
            raise self._failure(e, "zmqRemoteApi.require") from None
        self._busy = False
        self._sim = sim
        handle_all = getattr(sim, "handle_all", HANDLE_ALL)
        world_h = getattr(sim, "handle_world", HANDLE_WORLD)
        stopped = getattr(sim, "simulation_stopped", SIMULATION_STOPPED)
        self._world_h, self._stopped = world_h, stopped

        # Someone else's simulation may be running: the robots can be placed only while it is
        # stopped, so stop it (CoppeliaSim stops asynchronously: wait for it).
        if self._call("sim.getSimulationState") != stopped:
            self._call("sim.stopSimulation")
            self._wait_stopped()

        if hasattr(sim, "getSimulationTimeStep"):
            dt = self._call("sim.getSimulationTimeStep")
        else:  # before CoppeliaSim 4.7
            dt = self._call("sim.getFloatParam", getattr(sim, "floatparam_simulation_time_step", 1))
        if not isinstance(dt, (int, float)) or not math.isclose(dt, self._dt, rel_tol=1e-6):
            raise BackendError(
                f"CoppeliaSim at {self.where} steps {dt!r} s (its simulation time step) but the "
                f"behaviour's dt is {self._dt:g} s; they must agree. Set CoppeliaSim's time step to "
                f"{self._dt * 1000:g} ms (Simulation settings, dt; labsim serve --dt {self._dt:g}), or "
                f"write 'dt: {dt:g}' in the behaviour file")

        counts: dict[str, int] = {}
        self._robots = []
        for req, paths in zip(robots, plans):
            if req.model is None:
                self._robots.append(self._find_mechanism(req, world))
                continue
            i = counts.get(req.model.name, 0)
            counts[req.model.name] = i + 1
            self._robots.append(self._find_robot(req, paths, i, handle_all, world))

        road = first_road(world)
        self._tracker = RoadTracker(road) if road is not None and any(
            r.slots.keys() & ROAD_CHANNELS.keys() for r in self._robots) else None
        for r, req in zip(self._robots, robots):
            if self._tracker is not None and "laps" in r.channels:
                self._tracker.start(r.name, req.pose.x_m, req.pose.y_m)

        if self.place_robots:
            for r, req in zip(self._robots, robots):
                if r.mechanism:
                    continue
                # Keep the scene's height and tilt; only x, y and the heading are the behaviour's.
                _, _, z = self._call("sim.getObjectPosition", r.handle, world_h)  # type: ignore[misc]
                alpha, beta, _ = self._call("sim.getObjectOrientation", r.handle, world_h)  # type: ignore[misc]
                self._call("sim.setObjectPosition", r.handle, [req.pose.x_m, req.pose.y_m, z], world_h)
                self._call("sim.setObjectOrientation", r.handle, [alpha, beta, req.pose.heading_rad], world_h)

        self._call("sim.setStepping", True)
        self._call("sim.startSimulation")
        self._running = True
        if any(not r.mechanism for r in self._robots):
            # One step with the wheels still, so that the sensors have been handled once:
            # CoppeliaSim reads proximity and vision sensors at the end of a step. A robot at
            # rest does not move in it. A mechanism gets none: gravity would move it, and its
            # joints are state, readable from the start (force sensors read 0 until a step,
            # as the embedded backend's do).
            self._call("sim.step")

    def _get(self, path: str, proxy: int, what: str) -> int:
        try:
            h = self._call("sim.getObject", path, {"proxy": proxy} if proxy >= 0 else {})
        except BackendError as e:
            if self._dead:
                raise
            raise BackendError(
                f"{what}: CoppeliaSim at {self.where} has no object '{path}'"
                f"{' under the robot' if proxy >= 0 else ''} ({e}). The scene must hold what the "
                f"behaviour uses, named as docs/coppeliasim.md lists (one Pioneer P3DX per robot)") from None
        if not isinstance(h, int) or h < 0:
            raise BackendError(f"{what}: CoppeliaSim at {self.where} gave no handle for '{path}' ({h!r})")
        return h

    def _find_robot(self, req: RobotRequest, paths: dict[str, object], i: int, handle_all: int,
                    world: World) -> _Robot:
        model = req.model
        assert model is not None
        robot_path = str(paths["robot"]).format(i=i)
        h = self._get(robot_path, -1, f"robot '{req.name}'")
        r = _Robot(req.name, h, req.channels, collide_with=handle_all)
        r.motors = (self._get(str(paths["left_motor"]), h, f"robot '{req.name}', left motor"),
                    self._get(str(paths["right_motor"]), h, f"robot '{req.name}', right motor"))
        sonar_index = {s.name: k for k, s in enumerate(model.sonars)}
        cameras = {c.name for c in model.cameras}
        camera_paths = paths.get("cameras") if isinstance(paths.get("cameras"), dict) else {}
        for slot, ch in enumerate(req.channels):
            if ch in sonar_index:
                path = str(paths["sonar"]).format(k=sonar_index[ch])
                r.sonars.append((self._get(path, h, f"robot '{req.name}', {ch}"), slot))
            elif ch in cameras:
                path = str(camera_paths.get(ch, f"./{ch}"))  # type: ignore[union-attr]
                r.cameras.append((self._get(path, h, f"robot '{req.name}', {ch}"), slot))
            else:
                r.slots[ch] = slot
        r.read_position = bool(r.slots.keys() & {"x", "y", *ROAD_CHANNELS})
        r.read_velocity = "forward_speed" in r.slots
        r.read_orientation = "heading" in r.slots or r.read_velocity
        target = paths.get("collision")
        if target:
            r.collide_with = self._get(str(target), -1, f"robot '{req.name}', collision target")
        return r

    def _find_mechanism(self, req: RobotRequest, world: World) -> _Robot:
        """A mechanism's parts are top-level objects named as in the world file (/Crab_Actuator)."""
        mech = world.mechanism
        r = _Robot(req.name, -1, req.channels, mechanism=True)
        forces = {s.name for s in mech.force_sensors}  # type: ignore[union-attr]
        joints = {j.name for j in mech.joints if j.kind != "fixed"}  # type: ignore[union-attr]
        moving = [b.name for b in mech.bodies if not b.static]  # type: ignore[union-attr]
        handles: dict[str, int] = {}

        def get(name: str) -> int:
            if name not in handles:
                handles[name] = self._get(f"/{name}", -1, f"'{req.name}', {name}")
            return handles[name]

        for slot, ch in enumerate(req.channels):
            if ch in joints:
                r.joints.append((get(ch), slot))
            elif ch in forces:
                r.forces.append((get(ch), slot))
            elif ch in moving:
                r.bodies.append((get(ch), slot))
            else:
                r.slots[ch] = slot
        for j in mech.joints:  # type: ignore[union-attr]
            if j.kind != "fixed" and j.motor is not None:
                r.joint_handles[j.name] = get(j.name)
        if moving:
            r.tracked = get(moving[-1])
        slew = mech.slew  # type: ignore[union-attr]
        if slew is not None:
            r.slew, r.slew_axis_x = get(slew.name), slew.anchor[0]
        # read the slew each tick only when a plane position or the heading needs it
        r.read_orientation = bool(r.bodies) or bool(r.slots.keys() & {"x", "y", "heading"})
        return r

    def _sense_mechanism(self, r: _Robot) -> list[object]:
        """Joints, force sensors, and bodies in the mechanism's plane (undoing the slew)."""
        call, world_h = self._call, self._world_h
        values: list[object] = [None] * len(r.channels)
        positions: dict[int, float] = {}
        if r.slew >= 0 and r.read_orientation:
            positions[r.slew] = call("sim.getJointPosition", r.slew)  # type: ignore[assignment]
        slew = positions.get(r.slew, 0.0)
        for h, slot in r.joints:
            if h not in positions:
                positions[h] = call("sim.getJointPosition", h)  # type: ignore[assignment]
            values[slot] = (positions[h], call("sim.getJointVelocity", h))
        for h, slot in r.forces:
            _res, force, _torque = call("sim.readForceSensor", h)  # type: ignore[misc]
            values[slot] = (math.sqrt(sum(f * f for f in force)),)
        planar: dict[int, tuple[float, float, float]] = {}
        for h, slot in r.bodies:
            planar[h] = values[slot] = self._in_plane(h, slew, r.slew_axis_x)  # type: ignore[assignment]
        slots = r.slots
        if r.tracked >= 0 and slots.keys() & {"x", "y"}:
            x, z, _ = planar[r.tracked] if r.tracked in planar else self._in_plane(r.tracked, slew, r.slew_axis_x)
            if "x" in slots:
                values[slots["x"]] = x
            if "y" in slots:
                values[slots["y"]] = z
        if "heading" in slots:
            values[slots["heading"]] = math.remainder(slew, 2 * math.pi)
        if "collided" in slots:
            values[slots["collided"]] = False  # a mechanism's parts touch by design
        return values

    def _in_plane(self, h: int, slew: float, axis_x: float) -> tuple[float, float, float]:
        """(x, z, angle) of a body in the mechanism's vertical plane from its 3D pose."""
        x, y, z = self._call("sim.getObjectPosition", h, self._world_h)  # type: ignore[misc]
        alpha, beta, gamma = self._call("sim.getObjectOrientation", h, self._world_h)  # type: ignore[misc]
        if slew == 0.0 and alpha == 0.0 and gamma == 0.0:
            return (x, z, -beta)  # only tilted in the plane (about -y): exact, no trigonometry
        ca, sa, cb, sb = math.cos(alpha), math.sin(alpha), math.cos(beta), math.sin(beta)
        cg, sg = math.cos(gamma), math.sin(gamma)
        r00, r10, r20 = cb * cg, ca * sg + sa * sb * cg, sa * sg - ca * sb * cg  # the body's x axis
        if slew == 0.0:
            return (x, z, math.atan2(r20, r00))
        cs, ss = math.cos(slew), math.sin(slew)
        # turn back by the slew about the vertical axis x = axis_x, y = 0
        return (axis_x + (x - axis_x) * cs + y * ss, z, math.atan2(r20, cs * r00 + ss * r10))

    def _wait_stopped(self) -> None:
        deadline = time.monotonic() + self.timeout_s
        while self._call("sim.getSimulationState") != self._stopped:
            if time.monotonic() > deadline:
                raise BackendError(f"CoppeliaSim at {self.where} did not stop its simulation within "
                                   f"{self.timeout_s:g} s")
            time.sleep(0.01)

    def sense(self) -> list[list[object]]:
        if not self._opened:
            raise self._state_error("sense")
        call, world_h, tracker = self._call, self._world_h, self._tracker
        first = self._sensed == 0
        self._sensed += 1
        out = []
        for r in self._robots:
            if r.mechanism:
                out.append(self._sense_mechanism(r))
                continue
            values: list[object] = [None] * len(r.channels)
            slots = r.slots
            x = y = heading = 0.0
            if r.read_position:
                x, y, _ = call("sim.getObjectPosition", r.handle, world_h)  # type: ignore[misc]
            if r.read_orientation:
                heading = _yaw(call("sim.getObjectOrientation", r.handle, world_h))  # type: ignore[arg-type]
            for h, slot in r.sonars:
                res = call("sim.readProximitySensor", h)
                # CoppeliaSim: (detected, distance, point, object, normal); distance 0 when
                # nothing is detected, which labsim reads as inf (docs/decisions.md, 2).
                values[slot] = float(res[1]) if res[0] > 0 else math.inf  # type: ignore[index]
            for h, slot in r.cameras:
                img, (w, hgt) = call("sim.getVisionSensorImg", h)  # type: ignore[misc]
                import numpy as np  # only a behaviour with a camera needs it

                # CoppeliaSim's rows run from the bottom up; labsim's row 0 is the far edge.
                values[slot] = np.ascontiguousarray(np.frombuffer(img, np.uint8).reshape(hgt, w, 3)[::-1])
            res = call("sim.checkCollision", r.handle, r.collide_with)
            hit = bool((res[0] if isinstance(res, (tuple, list)) else res) > 0)  # type: ignore[operator]
            if hit and not r.touching:
                r.contacts += 1
            if hit and not first:  # time after each step, as the embedded backend counts it
                r.contact_s += self._dt
            r.touching = hit
            if "collided" in slots:
                values[slots["collided"]] = hit
            if "x" in slots:
                values[slots["x"]] = x
            if "y" in slots:
                values[slots["y"]] = y
            if "heading" in slots:
                values[slots["heading"]] = heading
            if r.read_velocity:
                (vx, vy, _), _ang = call("sim.getObjectVelocity", r.handle)  # type: ignore[misc]
                values[slots["forward_speed"]] = vx * math.cos(heading) + vy * math.sin(heading)
            if tracker is not None and slots.keys() & ROAD_CHANNELS.keys():
                self._road(r, values, x, y)
            out.append(values)
        return out

    def _road(self, r: _Robot, values: list[object], x: float, y: float) -> None:
        """Road channels from the pose, computed here as the embedded backend computes them."""
        tracker, slots = self._tracker, r.slots
        assert tracker is not None  # _open builds it when a robot reads a road channel
        if "road_offset" in slots or "on_road" in slots:
            offset = tracker.offset(x, y)
            if "road_offset" in slots:
                values[slots["road_offset"]] = offset
            if "on_road" in slots:
                values[slots["on_road"]] = abs(offset) <= tracker.half_width_m
        if "laps" in slots:
            values[slots["laps"]] = tracker.update(r.name, x, y)

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        if not self._opened:
            raise self._state_error("act")
        r = self._robots[robot]
        if left_rad_s != r.sent[0]:
            self._call("sim.setJointTargetVelocity", r.motors[0], left_rad_s)
            r.sent[0] = left_rad_s
        if right_rad_s != r.sent[1]:
            self._call("sim.setJointTargetVelocity", r.motors[1], right_rad_s)
            r.sent[1] = right_rad_s

    def command(self, robot: int, joint: str, mode: str, value: float) -> None:
        if not self._opened:
            raise self._state_error("command")
        r = self._robots[robot]
        h = r.joint_handles.get(joint)
        if h is None:
            raise BackendError(f"'{r.name}' has no motorised joint '{joint}'")
        func = {"velocity": "sim.setJointTargetVelocity", "position": "sim.setJointTargetPosition"}.get(mode)
        if func is None:
            raise BackendError(f"joint '{joint}': mode must be 'velocity' or 'position', not {mode!r}")
        self._call(func, h, value)

    def step(self) -> None:
        if not self._opened:
            raise self._state_error("step")
        self._call("sim.step")
        self.steps += 1

    def pose(self, robot: int) -> tuple[float, float, float]:
        if not self._opened:
            raise self._state_error("pose")
        r = self._robots[robot]
        if r.mechanism:  # as the embedded backend: the last moving body in the plane, the slew
            slew = float(self._call("sim.getJointPosition", r.slew)) if r.slew >= 0 else 0.0  # type: ignore[arg-type]
            x, z, _ = self._in_plane(r.tracked, slew, r.slew_axis_x) if r.tracked >= 0 else (0.0, 0.0, 0.0)
            return (x, z, math.remainder(slew, 2 * math.pi))
        x, y, _ = self._call("sim.getObjectPosition", r.handle, self._world_h)  # type: ignore[misc]
        return (x, y, _yaw(self._call("sim.getObjectOrientation", r.handle, self._world_h)))  # type: ignore[arg-type]

    def contacts(self, robot: int) -> ContactStats:
        """Contacts so far, counted from ``collided`` once a tick; readable after ``close``."""
        if not self._robots:
            raise BackendStateError("coppeliasim backend: contacts() called before open()")
        r = self._robots[robot]
        return ContactStats(r.contacts, r.contact_s)

    def close(self) -> None:
        """Stop the simulation if it can, close the socket; safe to call twice, never raises
        for a lost connection (the error that ended the run has been reported already)."""
        client = self._client
        if client is None:
            return
        self._opened = False
        try:
            if self._running and not self._dead:
                if self._busy:
                    # Interrupted mid-request (Ctrl-C): this socket waits for an answer that
                    # will never be read. A fresh client can still stop the simulation, so
                    # CoppeliaSim is not left frozen in stepping mode.
                    self._disconnect(client)
                    self._client = client = self._connect(min(self.timeout_s, 1.0))
                    self._busy = False
                self._call("sim.stopSimulation")
                self._wait_stopped()
        except (BackendError, KeyboardInterrupt):
            pass
        finally:
            self._running = False
            self._client = None
            self._disconnect(client)

    # --- helpers -----------------------------------------------------------------------------

    def _state_error(self, call: str) -> BackendStateError:
        when = "after close()" if self._robots else "before open()"
        return BackendStateError(f"coppeliasim backend: {call}() called {when}; open() a world first")


def _yaw(euler: Sequence[float]) -> float:
    """Heading (yaw of the robot's x axis, radians) from CoppeliaSim's Euler angles.

    CoppeliaSim's (alpha, beta, gamma) rotate about x, then the new y, then the new z. On a
    flat floor alpha = beta = 0 and gamma is the heading, returned as it is (no rounding);
    otherwise the heading is that of the x axis projected onto the floor.
    """
    alpha, beta, gamma = euler[0], euler[1], euler[2]
    if alpha == 0.0 and beta == 0.0:
        return float(gamma)
    ca, sa, cb, sb = math.cos(alpha), math.sin(alpha), math.cos(beta), math.sin(beta)
    cg, sg = math.cos(gamma), math.sin(gamma)
    return math.atan2(ca * sg + sa * sb * cg, cb * cg)
