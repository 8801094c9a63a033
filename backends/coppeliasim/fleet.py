"""The coppeliasim backend's robots: a fleet of wheeled robots (Pioneer P3DX) in a CoppeliaSim scene.

Where it sits: ``backend.CoppeliaSimBackend`` hands the robots of a run (the requests with a
model) to one ``Fleet``, which finds their objects, places them and reads and drives them
through the backend's ``connection``. A world's mechanism is ``mechanism``'s business.

* ``Fleet(...)`` checks every channel against ``RobotModel.channels()`` and the world's
  (``labsim.backends.scene.ground.world_channels``) before anything is sent.
* ``find`` looks the objects up by path (``MODEL_PATHS``: ``/PioneerP3DX[i]`` for the i-th
  robot of its model, then ``./leftMotor``, ``./rightMotor``, ``./ultrasonicSensor[k]``
  relative to it), and ``place`` moves each robot to the start pose the behaviour asks for,
  keeping the scene's height and tilt.
* ``sense`` reads only the channels the behaviour asked for, in one call per value: a sonar
  is ``sim.readProximitySensor`` (nothing detected: ``math.inf``, where CoppeliaSim says 0),
  ``x``/``y`` one ``sim.getObjectPosition``, ``heading`` one ``sim.getObjectOrientation``
  (yaw), a camera ``sim.getVisionSensorImg`` as it comes (rows bottom first, labsim's order too). ``collided`` is
  ``sim.checkCollision(robot, sim.handle_all)``, read every tick for every robot because the
  contact count of the summary is built from it (a contact = a tick on which it turns true).
  Road channels are computed here from the pose, as the embedded backend computes them. A
  lidar's beams are one ``sim.getStringSignal`` a tick (``lidar_signals``: every range, packed doubles).
* ``act`` sends a wheel's target velocity only when that wheel's command changed.
"""
from __future__ import annotations

import math
import struct
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from labsim.backends.coppeliasim import CAMERA_ALIASES, HANDLE_ALL, MODEL_PATHS, lidar_signals
from labsim.backends.coppeliasim import fleet_script as fs
from labsim.backends.coppeliasim.connection import Connection
from labsim.backends.coppeliasim.frames import yaw
from labsim.backends.coppeliasim.replies import check_sense
from labsim.backends.protocol import BackendError, ContactStats, RobotRequest
from labsim.backends.scene.ground import ROAD_CHANNELS, RoadTracker
from labsim.backends.scene.models import Kind, is_lidar_beam
from labsim.backends.scene.object_paths import PLACEHOLDERS, fill, problem
from labsim.backends.scene.world import World, first_road, world_channels


@dataclass(frozen=True)
class _Readings:
    """One robot's replies, as the per-object calls return them (or the fleet script, which
    returns the same values): what sense() turns into channels."""

    sonars: Any  # sim.readProximitySensor, one per sonar read
    images: Any  # sim.getVisionSensorImg, one per camera
    position: Any  # sim.getObjectPosition, or [] when not read
    orientation: Any  # sim.getObjectOrientation, or []
    velocity: Any  # sim.getObjectVelocity (linear, angular), or []
    collision: Any  # sim.checkCollision


@dataclass(eq=False)
class _Rover:
    """What sense() and act() need for one robot: handles and where each value goes."""

    req: RobotRequest
    paths: dict[str, object]  # MODEL_PATHS for its model, with the overrides
    handle: int = -1
    motors: tuple[int, int] = (-1, -1)
    sonars: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot)
    cameras: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot)
    bumpers: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot): proximity sensors
    ground: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot): 1-pixel vision sensors
    lidar: list[tuple[int, int]] = field(default_factory=list)  # (beam index from 0, slot)
    lidar_signal: str = ""  # the string signal with every beam's range (lidar_signals)
    collide_with: int = HANDLE_ALL
    slots: dict[str, int] = field(default_factory=dict)  # pose, collided, speed, road channels
    read_position: bool = False
    read_orientation: bool = False
    read_velocity: bool = False
    sent: list[float] = field(default_factory=lambda: [math.nan, math.nan])  # last wheel targets sent
    # contacts, counted from collided (kept after close for the summary)
    touching: bool = False
    contacts: int = 0
    contact_s: float = 0.0

    @property
    def name(self) -> str:
        return self.req.name


class Fleet:
    """Wheeled robots, each of a model ``MODEL_PATHS`` (or ``paths``) names the objects of."""

    def __init__(self, conn: Connection, world: World, requests: Sequence[RobotRequest],
                 paths: dict[str, object]) -> None:
        self.rovers = [_Rover(req, _paths(world, req, paths)) for req in requests]
        self._conn = conn
        self._road = first_road(world)
        self._tracker: RoadTracker | None = None
        self._script = -1  # the fleet script's handle (fleet_script), -1: object by object
        self._plan: list[list[object]] = []  # what labsimSense reads, robot by robot
        self._pending: list[object] = []  # labsimAct's commands: motor, velocity, ...

    @property
    def primes(self) -> bool:
        """Whether sensors need one step before the first tick: CoppeliaSim reads proximity
        and vision sensors at the end of a step. A robot at rest does not move in it."""
        return bool(self.rovers)

    def find(self) -> None:
        """Every robot's objects, by path; then the road tracker, if a robot reads the road."""
        counts: dict[str, int] = {}
        for r in self.rovers:
            model = r.req.model
            assert model is not None
            i = counts.get(model.name, 0)
            counts[model.name] = i + 1
            self._find(r, i)
        road = self._road
        self._tracker = RoadTracker(road) if road is not None and any(
            r.slots.keys() & ROAD_CHANNELS.keys() for r in self.rovers) else None
        if self._tracker is not None:
            for r in self.rovers:
                if "laps" in r.req.channels:
                    self._tracker.start(r.name, r.req.pose.x_m, r.req.pose.y_m)
        self._find_script()

    def _find_script(self) -> None:
        """The fleet script, if the scene has it (``labsim scene`` adds it): then a tick is a few
        round trips for the whole fleet, else one request per value."""
        self._script = fs.find_script(self._conn)
        if self._script < 0:
            self._conn.watch_state = True  # object by object: only the state tells a stop from outside
            return
        self._plan = [[r.handle, r.collide_with,
                       (fs.POSITION * r.read_position) | (fs.ORIENTATION * r.read_orientation)
                       | (fs.VELOCITY * r.read_velocity),
                       [h for h, _ in r.sonars], [h for h, _ in r.cameras]] for r in self.rovers]

    def _find(self, r: _Rover, i: int) -> None:
        conn = self._conn
        req, paths, get = r.req, r.paths, conn.get
        assert req.model is not None
        offered = req.model.channels()
        sonars = [name for name, kind in offered.items() if kind is Kind.DISTANCE]
        h = r.handle = get(fill(str(paths["robot"]), i=i), -1, f"robot '{req.name}'")
        r.collide_with = conn.handle_all
        r.motors = (get(str(paths["left_motor"]), h, f"robot '{req.name}', left motor"),
                    get(str(paths["right_motor"]), h, f"robot '{req.name}', right motor"))
        for slot, ch in enumerate(req.channels):
            kind = offered.get(ch)
            if is_lidar_beam(ch):
                r.lidar.append((int(ch[5:]) - 1, slot))
                r.lidar_signal = lidar_signals(i)[1]
            elif kind is Kind.DISTANCE:
                path = fill(str(paths["sonar"]), k=sonars.index(ch), n=sonars.index(ch) + 1)
                r.sonars.append((get(path, h, f"robot '{req.name}', {ch}"), slot))
            elif kind in (Kind.CONTACT, Kind.REFLECTANCE):
                key = "bumpers" if kind is Kind.CONTACT else "ground"
                table = paths.get(key)
                where = table.get(ch) if isinstance(table, dict) else None
                if where is None:
                    raise BackendError(f"robot '{req.name}': no scene object named for '{ch}'; name it with "
                                       f"paths={{'{key}': {{'{ch}': ...}}}}")
                found = (get(str(where), h, f"robot '{req.name}', {ch}"), slot)
                (r.bumpers if kind is Kind.CONTACT else r.ground).append(found)
            elif kind is Kind.IMAGE:
                r.cameras.append((self._camera(paths, ch, h, f"robot '{req.name}', {ch}"), slot))
            else:
                r.slots[ch] = slot
        r.read_position = bool(r.slots.keys() & {"x", "y", *ROAD_CHANNELS})
        r.read_velocity = "forward_speed" in r.slots
        r.read_orientation = "heading" in r.slots or r.read_velocity
        target = paths.get("collision")
        if target:
            r.collide_with = get(str(target), -1, f"robot '{req.name}', collision target")

    def _camera(self, paths: dict[str, object], ch: str, robot_h: int, what: str) -> int:
        """A camera's vision sensor: the path the behaviour or ``paths`` give, else the first of
        ``CAMERA_ALIASES`` under the robot (4.8's ``visionSensor``, then ``Vision_sensor``)."""
        cameras = paths.get("cameras")
        path = paths.get("camera") if ch == "camera" else None
        if path is None and isinstance(cameras, dict):
            path = cameras.get(ch)
        if path is not None:
            return self._conn.get(str(path), robot_h, what)
        for alias in (*CAMERA_ALIASES, ch) if ch == "camera" else (ch,):
            # sim.getObject's noError option (CoppeliaSim 4.3+): -1 instead of an error
            h = self._conn.call("sim.getObject", f"./{alias}", {"proxy": robot_h, "noError": True})
            if isinstance(h, int) and h >= 0:
                return self._conn.name(h, f"{what} ('./{alias}')")
        tried = ", ".join(f"./{a}" for a in (*CAMERA_ALIASES, ch)) if ch == "camera" else f"./{ch}"
        return self._conn.get(f"./{ch}", robot_h, f"{what} (tried {tried}; name it with paths: {{camera: ...}})")

    def place(self) -> None:
        """Each robot at the behaviour's start pose, keeping the scene's height and tilt."""
        call, world_h = self._conn.call, self._conn.world_h
        for r in self.rovers:
            pose = r.req.pose
            _, _, z = call("sim.getObjectPosition", r.handle, world_h)
            alpha, beta, _ = call("sim.getObjectOrientation", r.handle, world_h)
            call("sim.setObjectPosition", r.handle, [pose.x_m, pose.y_m, z], world_h)
            call("sim.setObjectOrientation", r.handle, [alpha, beta, pose.heading_rad], world_h)

    def rest(self) -> None:
        """Every wheel's target velocity 0, as the embedded backend starts: a target a client
        left in the scene would otherwise move the robot in the priming step. Object by object
        even with the fleet script: a child script runs only once the simulation has started."""
        for r in self.rovers:
            for m in r.motors:
                self._conn.call("sim.setJointTargetVelocity", m, 0.0)
            r.sent = [0.0, 0.0]

    # --- a tick ------------------------------------------------------------------------------

    def sense(self, first: bool) -> list[list[object]]:
        """Every robot's channels; ``first``: the first sense() since open (no contact time yet)."""
        if self._script >= 0:  # the fleet script: every robot's readings in one call
            reply = self._conn.call("sim.callScriptFunction", fs.SENSE, self._script, self._plan)
            replies = self._conn.checked(lambda: check_sense(reply, [r.name for r in self.rovers], self._plan))
            out = [self._sense(r, _Readings(*reply), first) for r, reply in zip(self.rovers, replies)]
        else:
            out = [self._sense(r, self._read(r), first) for r in self.rovers]
        for r, values in zip(self.rovers, out):
            if r.bumpers or r.ground:  # one request each, beside the script (it knows neither)
                self._switches_and_ground(r, values)
            if r.lidar:
                self._lidar(r, values, first)
        return out

    def _lidar(self, r: _Rover, values: list[object], first: bool) -> None:
        """A lidar's beams: one sim.getStringSignal of every beam's range, packed doubles; no
        signal on the first tick (a scanner that has not run yet) reads nothing in range, and
        none after it is an error: the scene has no scanner, and a run would drive blind."""
        data = self._conn.call("sim.getStringSignal", r.lidar_signal)
        if data is None and not first:
            raise BackendError(f"robot '{r.name}': CoppeliaSim at {self._conn.where} publishes no signal "
                               f"'{r.lidar_signal}' after a step, so the scene has no laser scanner for the "
                               f"behaviour's lidar (labsim scene builds none; docs/coppeliasim.md, \"A lidar's scan\")")
        if data is None:
            for _, slot in r.lidar:
                values[slot] = math.inf
            return
        if not isinstance(data, (bytes, bytearray)) or len(data) % 8:
            raise BackendError(f"robot '{r.name}': signal '{r.lidar_signal}' is not packed doubles "
                               f"(got {str(data)[:80]})")
        # checked as every other reply is: a scanner publishes one range per beam, each in
        # 0..range (inf: nothing met); anything else would be read as a distance and driven on
        model = r.req.model
        assert model is not None and model.lidars
        lidar = model.lidars[0]
        where = f"robot '{r.name}': signal '{r.lidar_signal}' of CoppeliaSim at {self._conn.where}"
        if len(data) // 8 != lidar.beams:
            raise BackendError(f"{where} has {len(data) // 8} ranges; the robot's lidar has {lidar.beams} beams")
        ranges = struct.unpack(f"<{lidar.beams}d", data)
        for k, slot in r.lidar:
            v = ranges[k]
            if not (v == math.inf or 0.0 <= v <= lidar.range_m * (1 + 1e-9)):
                raise BackendError(f"{where}: beam {k + 1} reads {v!r}, not a range in 0..{lidar.range_m:g} m "
                                   f"or inf")
            values[slot] = v

    def _switches_and_ground(self, r: _Rover, values: list[object]) -> None:
        """Bumpers (a proximity sensor that detects is pressed) and ground sensors (the average
        intensity of a one-pixel vision sensor, ``sim.readVisionSensor``'s first packet)."""
        call = self._conn.call
        for h, slot in r.bumpers:
            res = call("sim.readProximitySensor", h)
            values[slot] = bool(isinstance(res, (list, tuple)) and res and res[0] > 0)
        for h, slot in r.ground:
            res = call("sim.readVisionSensor", h)
            packet = res[1] if isinstance(res, (list, tuple)) and len(res) > 1 else None
            if not (isinstance(packet, (list, tuple)) and len(packet) > 10 and isinstance(packet[10], (int, float))):
                raise BackendError(f"robot '{r.name}': sim.readVisionSensor gave no intensity for a ground "
                                   f"sensor (got {str(res)[:80]})")
            values[slot] = min(1.0, max(0.0, float(packet[10])))

    def _read(self, r: _Rover) -> _Readings:
        """One robot's readings, one request each (a scene without the fleet script)."""
        call, world_h = self._conn.call, self._conn.world_h
        return _Readings(
            [call("sim.readProximitySensor", h) for h, _ in r.sonars],
            [call("sim.getVisionSensorImg", h) for h, _ in r.cameras],
            call("sim.getObjectPosition", r.handle, world_h) if r.read_position else [],
            call("sim.getObjectOrientation", r.handle, world_h) if r.read_orientation else [],
            call("sim.getObjectVelocity", r.handle) if r.read_velocity else [],
            call("sim.checkCollision", r.handle, r.collide_with))

    def _sense(self, r: _Rover, got: _Readings, first: bool) -> list[object]:
        values: list[object] = [None] * len(r.req.channels)
        slots = r.slots
        x = y = heading = 0.0
        if r.read_position:
            x, y, _ = got.position
        if r.read_orientation:
            heading = yaw(got.orientation)
        for (_, slot), res in zip(r.sonars, got.sonars):
            # CoppeliaSim: (detected, distance, point, object, normal); distance 0 when
            # nothing is detected, which labsim reads as inf (docs/decisions.md, 2).
            values[slot] = float(res[1]) if res[0] > 0 else math.inf
        for (_, slot), (img, (w, hgt)) in zip(r.cameras, got.images):
            import numpy as np  # only a behaviour with a camera needs it

            # CoppeliaSim's rows run from the bottom up, as labsim's do: no flip.
            values[slot] = np.frombuffer(img, np.uint8).reshape(hgt, w, 3)
        self._collided(r, got.collision, first)
        if "collided" in slots:
            values[slots["collided"]] = r.touching
        for ch, value in (("x", x), ("y", y), ("heading", heading)):
            if ch in slots:
                values[slots[ch]] = value
        if r.read_velocity:
            (vx, vy, _), _ang = got.velocity
            values[slots["forward_speed"]] = vx * math.cos(heading) + vy * math.sin(heading)
        if self._tracker is not None and slots.keys() & ROAD_CHANNELS.keys():
            self._road_channels(r, values, x, y)
        return values

    def _collided(self, r: _Rover, res: object, first: bool) -> None:
        """Count contacts from ``collided`` (sim.checkCollision's reply), as the embedded backend counts them."""
        hit = bool((res[0] if isinstance(res, (tuple, list)) else res) > 0)  # type: ignore[operator]
        if hit and not r.touching:
            r.contacts += 1
        if hit and not first:  # time after each step, as the embedded backend counts it
            r.contact_s += self._conn.dt_s
        r.touching = hit

    def _road_channels(self, r: _Rover, values: list[object], x: float, y: float) -> None:
        """Road channels from the pose, computed here as the embedded backend computes them."""
        tracker, slots = self._tracker, r.slots
        assert tracker is not None  # find() builds it when a robot reads a road channel
        if "road_offset" in slots or "on_road" in slots:
            offset = tracker.offset(x, y)
            if "road_offset" in slots:
                values[slots["road_offset"]] = offset
            if "on_road" in slots:
                values[slots["on_road"]] = abs(offset) <= tracker.half_width_m
        if "laps" in slots:
            values[slots["laps"]] = tracker.update(r.name, x, y)

    def act(self, k: int, left_rad_s: float, right_rad_s: float) -> None:
        r = self.rovers[k]
        for wheel, value in enumerate((left_rad_s, right_rad_s)):
            if value != r.sent[wheel]:
                if self._script >= 0:  # sent with the others before the step
                    self._pending += [r.motors[wheel], value]
                else:
                    self._conn.call("sim.setJointTargetVelocity", r.motors[wheel], value)
                r.sent[wheel] = value

    def before_step(self) -> None:
        """Send the wheel targets that changed this tick, in one call of the fleet script."""
        if self._pending:
            self._conn.call("sim.callScriptFunction", fs.ACT, self._script, self._pending)
            self._pending = []

    def command(self, k: int, joint: str, mode: str, value: float) -> None:
        raise BackendError(f"'{self.rovers[k].name}' has no motorised joint '{joint}'")

    def pose(self, k: int) -> tuple[float, float, float]:
        r, call, world_h = self.rovers[k], self._conn.call, self._conn.world_h
        x, y, _ = call("sim.getObjectPosition", r.handle, world_h)
        return (x, y, yaw(call("sim.getObjectOrientation", r.handle, world_h)))

    def contacts(self, k: int) -> ContactStats:
        r = self.rovers[k]
        return ContactStats(r.contacts, r.contact_s)


def _paths(world: World, req: RobotRequest, overrides: dict[str, object]) -> dict[str, object]:
    """A robot's object paths, after checking its channels; no connection needed."""
    model = req.model
    assert model is not None
    paths = dict(MODEL_PATHS.get(model.name, {}))
    if not paths and not overrides:
        raise BackendError(
            f"robot '{req.name}': the coppeliasim backend knows no scene object names for model "
            f"'{model.name}'; pass paths={{'robot': ..., 'left_motor': ..., ...}}")
    paths.update(overrides)
    paths.update(dict(req.paths))  # the behaviour file's, for this robot
    for key in PLACEHOLDERS:  # templates, filled literally (scene/object_paths.py)
        wrong = problem(key, str(paths[key])) if isinstance(paths.get(key), str) else None
        if wrong is not None:
            raise BackendError(f"robot '{req.name}': {wrong[1]} (in '{str(paths[key])[:80]}')")
    offered = model.channels()
    from_world = world_channels(world)
    for ch in req.channels:
        if ch not in offered and ch not in from_world:
            raise BackendError(
                f"robot '{req.name}' asks for unknown channel '{ch}'; model "
                f"'{model.name}' offers: {', '.join([*offered, *from_world])}")
    return paths
