"""The coppeliasim backend's mechanism: a world's articulated model (the tower crane) in CoppeliaSim.

Where it sits: ``backend.CoppeliaSimBackend`` hands the requests without a model (the world's
mechanism, ``labsim.backends.scene.mechanism.Mechanism``) to one ``MechanismDriver``, which
finds its parts, reads and commands them through the backend's ``connection``. Wheeled
robots are ``fleet``'s business.

A mechanism's parts are top-level objects named as in the world file (``/Crab_Actuator``):
its joints (all but fixed ones), force sensors and moving bodies, the channels
``Mechanism.channels()`` lists. A joint reads ``sim.getJointPosition`` and
``sim.getJointVelocity``, a force sensor the magnitude of ``sim.readForceSensor``'s force,
a body its 3D pose turned back into the mechanism's vertical plane (``frames.plane_pose``,
undoing the slew). ``x``, ``y`` are the last moving body's position in the plane (x along,
y up), ``heading`` the slew angle, and ``collided`` is always false: a mechanism's parts
touch by design. Commands are ``sim.setJointTargetVelocity`` / ``Position`` of a motorised
joint. A mechanism needs no step before the first tick: gravity would move it, and its
joints are state, readable from the start (force sensors read 0 until a step, as the
embedded backend's do).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from labsim.backends.coppeliasim import fleet_script as fs
from labsim.backends.coppeliasim.connection import Connection
from labsim.backends.coppeliasim.frames import plane_pose
from labsim.backends.coppeliasim.replies import check_parts
from labsim.backends.protocol import BackendError, ContactStats, RobotRequest
from labsim.backends.scene.mechanism import Mechanism
from labsim.backends.scene.models import Kind
from labsim.backends.scene.world import World

# What a mechanism offers beyond its parts: where it is (for the trace) and collided.
_OWN_CHANNELS = ("x", "y", "heading", "collided")
_TARGETS = {"velocity": "sim.setJointTargetVelocity", "position": "sim.setJointTargetPosition"}


@dataclass(eq=False)
class _Parts:
    """Handles by channel, and what turns 3D poses into the mechanism's plane."""

    name: str
    channels: tuple[str, ...]
    joints: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot): (position, velocity)
    forces: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot): (tension,)
    bodies: list[tuple[int, int]] = field(default_factory=list)  # (handle, slot): (x, z, angle)
    slots: dict[str, int] = field(default_factory=dict)  # x, y, heading, collided
    joint_handles: dict[str, int] = field(default_factory=dict)  # motorised joints, for command()
    slew: int = -1  # the slew joint's handle, -1 without one
    slew_axis_x: float = 0.0
    tracked: int = -1  # the body whose plane position is x, y (the last moving body)
    read_slew: bool = False  # read the slew each tick: a plane position or the heading needs it


class MechanismDriver:
    """The world's mechanism, once for each request without a model."""

    primes = False  # no step before the first tick (see the module docstring)

    def __init__(self, conn: Connection, world: World, requests: Sequence[RobotRequest]) -> None:
        self._conn = conn
        self._mechanism = _mechanism(world, requests)
        self.parts = [_Parts(req.name, req.channels) for req in requests]
        self._script = -1  # the fleet script's handle (fleet_script), -1: part by part

    def find(self) -> None:
        for p in self.parts:
            self._find(p)
        self._script = fs.find_script(self._conn)
        if self._script < 0:
            self._conn.watch_state = True  # part by part: only the state tells a stop from outside

    def _find(self, p: _Parts) -> None:
        mech = self._mechanism
        assert mech is not None  # _mechanism() checked it, as there are requests
        kinds = mech.channels()
        moving = [name for name, kind in kinds.items() if kind is Kind.BODY]
        handles: dict[str, int] = {}

        def get(name: str) -> int:
            if name not in handles:
                handles[name] = self._conn.get(f"/{name}", -1, f"'{p.name}', {name}")
            return handles[name]

        lists = {Kind.JOINT: p.joints, Kind.FORCE: p.forces, Kind.BODY: p.bodies}
        for slot, ch in enumerate(p.channels):
            kind = kinds.get(ch)
            if kind is None:
                p.slots[ch] = slot
            else:
                lists[kind].append((get(ch), slot))
        for j in mech.joints:
            if j.kind != "fixed" and j.motor is not None:
                p.joint_handles[j.name] = get(j.name)
        if moving:
            p.tracked = get(moving[-1])
        slew = mech.slew
        if slew is not None:
            p.slew, p.slew_axis_x = get(slew.name), slew.anchor[0]
        p.read_slew = bool(p.bodies) or bool(p.slots.keys() & {"x", "y", "heading"})

    def place(self) -> None:
        """A mechanism stays as the scene has it: the world file gives its start."""

    def rest(self) -> None:
        """Every motorised joint's target velocity 0 (its controller is in velocity mode, as the
        embedded backend starts): a target a client left in the scene would move it otherwise."""
        for h in {h for p in self.parts for h in p.joint_handles.values()}:
            self._conn.call("sim.setJointTargetVelocity", h, 0.0)

    # --- a tick ------------------------------------------------------------------------------

    def sense(self, first: bool) -> list[list[object]]:
        return [self._sense(p) for p in self.parts]

    def _sense(self, p: _Parts) -> list[object]:
        """Joints, force sensors, and bodies in the mechanism's plane (undoing the slew)."""
        read = self._conn.call
        if self._script >= 0 and self._conn.steps > 0:
            # the fleet script: every reading in one call, then looked up. Not before the first
            # step: CoppeliaSim initializes a child script in it (a fleet gets a priming step)
            read = self._batch(p)
        call = read
        values: list[object] = [None] * len(p.channels)
        positions: dict[int, float] = {}
        if p.slew >= 0 and p.read_slew:
            positions[p.slew] = call("sim.getJointPosition", p.slew)
        slew = positions.get(p.slew, 0.0)
        for h, slot in p.joints:
            if h not in positions:
                positions[h] = call("sim.getJointPosition", h)
            values[slot] = (positions[h], call("sim.getJointVelocity", h))
        for h, slot in p.forces:
            _res, force, _torque = call("sim.readForceSensor", h)
            values[slot] = (math.sqrt(sum(f * f for f in force)),)
        planar: dict[int, tuple[float, float, float]] = {}
        for h, slot in p.bodies:
            planar[h] = self._in_plane(h, slew, p.slew_axis_x, read)
            values[slot] = planar[h]
        slots = p.slots
        if p.tracked >= 0 and slots.keys() & {"x", "y"}:
            x, z, _ = planar[p.tracked] if p.tracked in planar else self._in_plane(p.tracked, slew, p.slew_axis_x,
                                                                                   read)
            if "x" in slots:
                values[slots["x"]] = x
            if "y" in slots:
                values[slots["y"]] = z
        if "heading" in slots:
            values[slots["heading"]] = math.remainder(slew, 2 * math.pi)
        if "collided" in slots:
            values[slots["collided"]] = False  # a mechanism's parts touch by design
        return values

    def _in_plane(self, h: int, slew: float, axis_x: float,
                  call: Callable[..., Any] | None = None) -> tuple[float, float, float]:
        """(x, z, angle) of a body in the mechanism's vertical plane from its 3D pose."""
        call, world_h = call or self._conn.call, self._conn.world_h
        position = call("sim.getObjectPosition", h, world_h)
        return plane_pose(position, call("sim.getObjectOrientation", h, world_h), slew, axis_x)

    def _batch(self, p: _Parts) -> Callable[..., Any]:
        """The parts' readings from one call of the fleet script (``fleet_script.PARTS``), as a
        stand-in for the connection's ``call``: the same function and handle give the same value."""
        joints = ([p.slew] if p.slew >= 0 and p.read_slew else []) + [h for h, _ in p.joints]
        forces = [h for h, _ in p.forces]
        bodies = [h for h, _ in p.bodies] + ([p.tracked] if p.tracked >= 0 and p.slots.keys() & {"x", "y"} else [])
        plan = [list(dict.fromkeys(joints)), forces, list(dict.fromkeys(bodies))]
        raw = self._conn.call("sim.callScriptFunction", fs.PARTS, self._script, plan)
        reply: Any = self._conn.checked(lambda: check_parts(raw, p.name, plan))
        got: dict[tuple[str, int], object] = {}
        for h, (position, velocity) in zip(plan[0], reply[0]):
            got["sim.getJointPosition", h], got["sim.getJointVelocity", h] = position, velocity
        for h, force in zip(plan[1], reply[1]):
            got["sim.readForceSensor", h] = force
        for h, (position, orientation) in zip(plan[2], reply[2]):
            got["sim.getObjectPosition", h], got["sim.getObjectOrientation", h] = position, orientation
        return lambda func, h, *rest: got[func, h]

    def act(self, k: int, left_rad_s: float, right_rad_s: float) -> None:
        raise BackendError(f"'{self.parts[k].name}' is a mechanism: it has no wheels; command its joints")

    def command(self, k: int, joint: str, mode: str, value: float) -> None:
        p = self.parts[k]
        h = p.joint_handles.get(joint)
        if h is None:
            raise BackendError(f"'{p.name}' has no motorised joint '{joint}'")
        func = _TARGETS.get(mode)
        if func is None:
            raise BackendError(f"joint '{joint}': mode must be 'velocity' or 'position', not {mode!r}")
        self._conn.call(func, h, value)

    def before_step(self) -> None:
        """Commands go out as they come: nothing is held back."""

    def pose(self, k: int) -> tuple[float, float, float]:
        """As the embedded backend: the last moving body in the plane, and the slew."""
        p = self.parts[k]
        slew = float(self._conn.call("sim.getJointPosition", p.slew)) if p.slew >= 0 else 0.0
        x, z, _ = self._in_plane(p.tracked, slew, p.slew_axis_x) if p.tracked >= 0 else (0.0, 0.0, 0.0)
        return (x, z, math.remainder(slew, 2 * math.pi))

    def contacts(self, k: int) -> ContactStats:
        return ContactStats(0, 0.0)  # collided is always false: no contacts


def _mechanism(world: World, requests: Sequence[RobotRequest]) -> Mechanism | None:
    """The world's mechanism, after checking every request's channels against it."""
    mech = world.mechanism
    for req in requests:
        if mech is None:
            raise BackendError(f"'{req.name}': world '{world.name}' has no mechanism")
        known = mech.channels()
        for ch in req.channels:
            if ch not in known and ch not in _OWN_CHANNELS:
                raise BackendError(f"'{req.name}' asks for unknown channel '{ch}'; world "
                                   f"'{world.name}' offers: {', '.join(sorted(known))}")
    return mech
