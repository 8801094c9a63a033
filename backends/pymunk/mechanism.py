"""A ``Mechanism`` simulated in pymunk: the pymunk backend's simulator for side-view worlds.

``labsim.backends.pymunk.backend.PymunkBackend`` opens a ``MechanismSimulator`` for a world
with a mechanism (such as the tower crane). It builds one ``MechanismScene`` from the world's
``labsim.backends.scene.mechanism.Mechanism`` and, every tick, sets joint targets, calls
``step()`` and reads the channels the mechanism offers (``Mechanism.channels()``): joint
positions and velocities, force sensors and moving bodies. The joint kinds and their planner
are in ``labsim.backends.pymunk.joints``. Nothing here knows the language or the runtime.

pymunk is 2D, so the scene is the mechanism's vertical plane: x along it, z up (pymunk's y),
gravity (0, -g). How each joint becomes pymunk constraints, and why:

- ``fixed`` and ``slew`` joints weld bodies together. Welded bodies become one pymunk body
  with one shape per member, its mass and moment summed about the common centre of mass: a
  weld made of constraints would flex, and costs solver work for nothing.
- ``prismatic`` rail: a ``GrooveJoint`` from the parent holds the child's centre on the line
  anchor + s * axis, lo <= s <= hi; the groove's ends *are* the limits, a hard stop no motor
  force can push through. A ``GearJoint`` (ratio 1) keeps the child from turning. The motor
  is a second ``GrooveJoint``, from a kinematic driver body moving at the commanded velocity
  along the axis, whose groove runs across the axis: it transmits force only along the axis,
  at most ``max_force``, and with ``max_bias = 0`` it corrects velocity, never position, so
  it is a velocity servo whose driver never has to be reset to the child. Because the driver
  is kinematic its reaction goes to the world, which is exact only when the parent is
  static, so a motorised rail needs a static parent here (the crane's crab runs on the arm,
  which is static in the plane).
- ``prismatic`` rope (the hoist): a ``SlideJoint`` (0 <= distance <= L) to the child's
  centre. It pulls and never pushes, so the hook swings as a pendulum, and the rope goes
  slack when the load rests on the floor. The winch length L is the joint's position,
  integrated from the command (speed- and acceleration-limited). A motorised rope hangs from
  a kinematic *pulley* body, put at the parent's anchor before every sub-step and moving
  with it plus the winch speed along the rope: a SlideJoint's own velocity target is never
  "lengthen at u", so changing only its maximum length makes a paid-out load fall and stop
  in turns (the sling then reads 0.2 to 1.7 times the weight) and a hauled-in load trail
  80 mm behind. The pulley's velocity makes the winch's speed part of the constraint. The
  pulley is kinematic, so the rope's pull on the parent is applied to it by hand, as a force
  during the next sub-step (5 ms late; the crab's rail and servo take it). The rope's
  ``max_force`` is the winch's: a load pulling harder, over a whole tick, makes it pay out
  rope (L follows the real distance).
- ``revolute``: a ``PivotJoint`` at the anchor, a ``RotaryLimitJoint`` for limits, and a
  ``SimpleMotor`` (torque-limited velocity servo) for the motor.
- ``slew``: the rotation of the plane about the tower; it cannot be simulated in a plane. Its
  angle is integrated from the commanded velocity with the motor's speed and acceleration
  limits. Nothing in the plane feels it: no centrifugal swing of the load, no twisting of
  the tower, and everything in the plane turns with it, including a load standing on the
  floor. ``world_position`` applies it to draw a 3D path.
- force sensors: a ``SlideJoint`` of fixed length (a cable, like the sling between the crane's
  hook and load). pymunk reports only the magnitude of a constraint's impulse, so a rigid
  link could not tell tension from compression; a cable can only be in tension. The reading
  is the mean tension over the tick: summed impulses / dt.
- the floor is a static segment; every moving body collides with it and with static bodies.
  Bodies joined by a rail or pivot do not collide with each other (they overlap by design),
  bodies joined by a rope or cable do.

Stability and cost: ``DEFAULT_SUBSTEPS`` sub-steps of dt / substeps each and
``SOLVER_ITERATIONS`` solver iterations (see their comments). The crane costs about 90 us a
tick at dt = 0.05 s, some 550 times faster than real time (tests/unit/test_mechanism.py measures
it); the sub-steps are nearly all of it, about 8 us each.

Joint targets are followed by a planner that runs once a tick (``joints.control``): speed
clamped to max_speed, changed by at most max_accel * dt a tick, slowing down in time to stop
exactly on a position target, and on a limit when driven at it.
"""
from __future__ import annotations

import difflib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import pymunk

from labsim.backends.protocol import BackendError, ContactStats, RobotRequest
from labsim.backends.pymunk import chipmunk
from labsim.backends.pymunk.joints import (
    LONG_M,
    Group,
    Joint,
    MechanismError,
    Slew,
    Winch,
    build_joint,
    control,
)
from labsim.backends.pymunk.simulator import COLLISION_SLOP_M
from labsim.backends.scene.mechanism import BodySpec, ForceSensorSpec, Mechanism, MotorSpec
from labsim.backends.scene.models import Kind
from labsim.backends.scene.world import World, wrap

__all__ = ["DEFAULT_SUBSTEPS", "MechanismError", "MechanismScene", "MechanismSimulator"]

# 5 ms sub-steps at dt = 0.05 s. The crane's pendulum (about 6.5 m, period 5 s) needs far less;
# the chain rope - 10 kg hook - sling - 200 kg load is what needs small steps and many
# iterations. Its two cables each go slack for a sub-step when the solver has not converged,
# which loses their warm start, so an under-resolved chain keeps jiggling instead of settling:
# measured on the crane right after a lift, the sling's reading wanders by 35 % at 4 sub-steps
# and 10 iterations, 13 % at 8 and 20, and by less than 0.001 % at 10 and 30. Iterations are
# nearly free (41 vs 37 us a tick at 4 sub-steps); sub-steps are the cost.
DEFAULT_SUBSTEPS = 10
SOLVER_ITERATIONS = 30
FRICTION = 0.8
# The winch pays out when the rope's mean tension over a tick reaches this fraction of its
# max_force.
_SATURATED = 0.999


def _did_you_mean(word: str, candidates: list[str]) -> str:
    m = difflib.get_close_matches(word, candidates, n=1, cutoff=0.6)
    return f" (did you mean '{m[0]}'?)" if m else ""


@dataclass
class _Sensor:
    name: str
    cable: pymunk.SlideJoint
    impulse_sum: float = 0.0
    force_n: float = 0.0


@dataclass
class _Plan:
    """Per-tick lists the step loop walks, so it does no dispatch on joint kinds."""

    controlled: list[tuple[Joint, MotorSpec]] = field(default_factory=list)
    winches: list[Winch] = field(default_factory=list)


class MechanismScene:
    """A pymunk space built from a ``Mechanism``, stepped dt_s at a time.

    Joint positions and velocities are m, m/s (prismatic) or rad, rad/s (revolute, slew);
    see ``JointSpec`` for each kind's definition. Deterministic: the same mechanism and the
    same calls give identical readings.
    """

    def __init__(self, mechanism: Mechanism, dt_s: float = 0.05, substeps: int = DEFAULT_SUBSTEPS):
        if not dt_s > 0 or substeps < 1:
            raise MechanismError("dt_s must be positive and substeps at least 1")
        self.mechanism = mechanism
        self.dt_s = dt_s
        self.substeps = substeps
        self.time_s = 0.0
        self._h = dt_s / substeps
        self.space = space = pymunk.Space()
        space.gravity = (0.0, -mechanism.gravity_m_s2)
        # pymunk keeps this fraction of every velocity per second.
        space.damping = math.exp(-mechanism.damping_1_s)
        space.iterations = SOLVER_ITERATIONS
        space.collision_slop = COLLISION_SLOP_M
        self._body_names = self._check_names(mechanism)

        self._member_local: dict[str, tuple[float, float]] = {}  # each body's centre in its group body
        self._group_of = self._build_groups(mechanism)
        if mechanism.floor_z_m is not None:
            z = mechanism.floor_z_m
            floor = pymunk.Segment(space.static_body, (-LONG_M, z), (LONG_M, z), 0.0)
            floor.friction = FRICTION
            space.add(floor)

        self._joints: dict[str, Joint] = {}
        self._slew: Slew | None = None
        self._plan = _Plan()
        for spec in mechanism.joints:
            j = build_joint(spec, mechanism, self._group_of, space)
            self._joints[spec.name] = j
            if isinstance(j, Slew):
                self._slew = j
            if spec.motor is not None and spec.kind != "fixed":
                self._plan.controlled.append((j, spec.motor))
                if isinstance(j, Winch):
                    self._plan.winches.append(j)
        self._sensors: dict[str, _Sensor] = {}
        for s in mechanism.force_sensors:
            self._sensors[s.name] = self._build_sensor(s)
        self._sensor_list = list(self._sensors.values())

    # -- building -------------------------------------------------------------------------

    @staticmethod
    def _check_names(mechanism: Mechanism) -> list[str]:
        """The body names, once every name a joint or sensor uses is known to be one."""
        names = [b.name for b in mechanism.bodies]
        if len(set(names)) != len(names):
            raise MechanismError("body names must be unique")
        known = set(names)
        for j in mechanism.joints:
            for role, n in (("parent", j.parent), ("child", j.child)):
                if n not in known:
                    raise MechanismError(f"joint '{j.name}': no body '{n}' as {role}{_did_you_mean(n, names)}")
        for s in mechanism.force_sensors:
            for n in s.between:
                if n not in known:
                    raise MechanismError(f"force sensor '{s.name}': no body '{n}'{_did_you_mean(n, names)}")
        if sum(j.kind == "slew" for j in mechanism.joints) > 1:
            raise MechanismError("at most one slew joint: the plane turns about one axis")
        return names

    def _build_groups(self, m: Mechanism) -> dict[str, Group]:
        """One pymunk body per weld group (``Mechanism.weld_groups``), by body name."""
        group_of: dict[str, Group] = {}
        for bodies in m.weld_groups():
            static = any(b.static for b in bodies)
            if static:
                body = pymunk.Body(body_type=pymunk.Body.STATIC)
                body.position = bodies[0].center
            else:
                for b in bodies:
                    if not b.mass > 0:
                        raise MechanismError(f"body '{b.name}' moves, so it needs a positive mass or density")
                mass = sum(b.mass for b in bodies)
                cx = sum(b.mass * b.center[0] for b in bodies) / mass
                cz = sum(b.mass * b.center[1] for b in bodies) / mass
                moment = sum(
                    b.moment_kg_m2 + b.mass * ((b.center[0] - cx) ** 2 + (b.center[1] - cz) ** 2) for b in bodies
                )
                body = pymunk.Body(mass, moment)
                body.position = (cx, cz)
            px, pz = body.position
            shapes = []
            for b in bodies:
                shape = pymunk.Poly(body, [(x - px, z - pz) for x, z in b.corners()])
                shape.friction = FRICTION
                shapes.append(shape)
            self.space.add(body, *shapes)
            g = Group(bodies, body, static)
            for b in bodies:
                group_of[b.name] = g
                self._member_local[b.name] = (b.center[0] - px, b.center[1] - pz)
        return group_of

    def _build_sensor(self, s: ForceSensorSpec) -> _Sensor:
        if s.between[0] == s.between[1]:
            raise MechanismError(f"force sensor '{s.name}' must join two different bodies")
        ga, gb = self._group_of[s.between[0]], self._group_of[s.between[1]]
        if ga is gb:
            raise MechanismError(f"force sensor '{s.name}': its bodies are welded together")
        if s.anchors is None:
            pa, pb = self.mechanism.body(s.between[0]).center, self.mechanism.body(s.between[1]).center
        else:
            pa, pb = s.anchors
        length = math.hypot(pb[0] - pa[0], pb[1] - pa[1])
        cable = pymunk.SlideJoint(ga.body, gb.body, ga.local(pa), gb.local(pb), 0.0, length)
        self.space.add(cable)
        return _Sensor(s.name, cable)

    # -- stepping -------------------------------------------------------------------------

    def step(self) -> None:
        """Advance dt_s: plan each controlled joint's velocity, then run the sub-steps."""
        dt = self.dt_s
        h = self._h
        for j, motor in self._plan.controlled:
            control(j, motor, dt, h)
        # chipmunk's step and impulses themselves (labsim.backends.pymunk.chipmunk): pymunk's
        # Space.step adds the handling of shapes added or removed from callbacks, and a
        # mechanism has no callbacks.
        step, space, impulse = chipmunk.space_step, chipmunk.c_space(self.space), chipmunk.impulse
        c = chipmunk.c_constraint
        sensors = self._sensor_list
        winches = self._plan.winches
        n = self.substeps
        for k in range(1, n + 1):
            for w in winches:
                w.wind(h, k / n)
            step(space, h)
            for s in sensors:
                s.impulse_sum += impulse(c(s.cable))
            for w in winches:
                j_ns = impulse(c(w.rope))
                w.impulse_sum += j_ns
                # The rope pulls the parent toward the hook; pymunk gives the size only.
                w.pull = (w.rope_dir[0] * j_ns / h, w.rope_dir[1] * j_ns / h)
                w.value = w.target_value
        for s in sensors:
            s.force_n = s.impulse_sum / dt
            s.impulse_sum = 0.0
        for w in winches:
            # Slip on the tick's mean tension, not on one sub-step: a swinging load gives the
            # solver single-sub-step peaks at max_force, and paying out on those would drop
            # the load a little every tick.
            if w.impulse_sum >= _SATURATED * w.rope.max_force * dt:
                w.pay_out()
            w.impulse_sum = 0.0
        self.time_s += dt

    # -- reading and commanding -----------------------------------------------------------

    def _joint(self, name: str) -> Joint:
        try:
            return self._joints[name]
        except KeyError:
            raise MechanismError(f"no joint '{name}'{_did_you_mean(name, list(self._joints))}") from None

    def joint_position(self, name: str) -> float:
        """m (prismatic: along the axis, or a rope's length) or rad (revolute, slew)."""
        return self._joint(name).position()

    def joint_velocity(self, name: str) -> float:
        """m/s or rad/s: the child's motion relative to the parent (a winch's and the slew's
        velocity is the one integrated on the last tick)."""
        return self._joint(name).velocity()

    def _motorised(self, name: str, target: str) -> Joint:
        j = self._joint(name)
        motor = j.spec.motor
        if motor is None:
            raise MechanismError(f"joint '{name}' has no motor: it cannot be driven")
        if not (motor.velocity if target == "velocity" else motor.position):
            other = "position" if target == "velocity" else "velocity"
            raise MechanismError(f"joint '{name}' takes {other} targets only")
        return j

    def set_target_velocity(self, name: str, v: float) -> None:
        """Drive the joint at v (m/s or rad/s), clamped to its motor's max_speed, until changed."""
        if not math.isfinite(v):
            raise MechanismError(f"joint '{name}': target velocity must be finite, not {v}")
        j = self._motorised(name, "velocity")
        j.mode, j.target = "velocity", float(v)

    def set_target_position(self, name: str, p: float) -> None:
        """Move the joint to p (m or rad, clamped to its limits) and hold it there."""
        if not math.isfinite(p):
            raise MechanismError(f"joint '{name}': target position must be finite, not {p}")
        j = self._motorised(name, "position")
        j.mode, j.target = "position", float(p)

    def force(self, name: str) -> float:
        """Tension in newtons of a force sensor's cable, averaged over the last tick (0 before
        the first step, and when the cable is slack)."""
        try:
            return self._sensors[name].force_n
        except KeyError:
            raise MechanismError(
                f"no force sensor '{name}'{_did_you_mean(name, list(self._sensors))}") from None

    def _member(self, name: str) -> tuple[Group, BodySpec]:
        g = self._group_of.get(name)
        if g is None:
            raise MechanismError(f"no body '{name}'{_did_you_mean(name, self._body_names)}")
        return g, next(b for b in g.members if b.name == name)

    def body_pose(self, name: str) -> tuple[float, float, float]:
        """(x_m, z_m, angle_rad) of a body's centre in the plane."""
        g, spec = self._member(name)
        p = g.body.local_to_world(self._member_local[name])
        return (p.x, p.y, g.body.angle + spec.angle_rad)

    @property
    def slew_angle(self) -> float:
        """The plane's angle about the slew axis, rad (0 without a slew joint)."""
        return self._slew.value if self._slew is not None else 0.0

    def world_position(self, name: str) -> tuple[float, float, float]:
        """(x_m, y_m, z_m) of a body's centre in 3D: its place in the plane, turned by the slew
        angle about the vertical axis through the slew joint's anchor."""
        x, z, _ = self.body_pose(name)
        if self._slew is None:
            return (x, 0.0, z)
        ax = self._slew.spec.anchor[0]
        a = self._slew.value
        r = x - ax
        return (ax + r * math.cos(a), r * math.sin(a), z)


class MechanismSimulator:
    """A world's mechanism, read and driven by one agent; built open by the constructor.

    Channels (``Mechanism.channels()``): a joint reads (position, velocity), a force sensor
    (tension N,), a moving body (x, z, angle) in the plane; x, y are the last moving body's
    (x, z) and heading the slew angle, so that a trace follows the load; collided is always
    False, and there are no contacts.
    """

    def __init__(self, world: World, mechanism: Mechanism, robots: Sequence[RobotRequest], dt_s: float) -> None:
        if any(req.model is not None for req in robots):
            raise BackendError(f"world '{world.name}' is a mechanism: it has no place for robots")
        try:
            scene = MechanismScene(mechanism, dt_s)
        except MechanismError as e:
            raise BackendError(f"world '{world.name}': {e}") from None
        offered = mechanism.channels()
        moving = [name for name, kind in offered.items() if kind is Kind.BODY]
        tracked = moving[-1] if moving else None

        def getter(name: str, ch: str) -> Callable[[], object]:
            kind = offered.get(ch)
            if kind is Kind.JOINT:
                return lambda: (scene.joint_position(ch), scene.joint_velocity(ch))
            if kind is Kind.FORCE:
                return lambda: (scene.force(ch),)
            if kind is Kind.BODY:
                return lambda: scene.body_pose(ch)
            if tracked is not None and ch in ("x", "y"):
                index = 0 if ch == "x" else 1
                return lambda: scene.body_pose(tracked)[index]
            if ch == "heading":
                return lambda: scene.slew_angle
            if ch == "collided":
                return lambda: False
            raise BackendError(f"'{name}' asks for unknown channel '{ch}'; world '{world.name}' offers: "
                               + ", ".join(sorted(offered)))

        getters = [[getter(req.name, ch) for ch in req.channels] for req in robots]
        self.scene = scene
        self.space = scene.space
        self.bodies: list[pymunk.Body] = []  # a mechanism's bodies are no robots: see body channels
        self.sense: Callable[[], list[list[object]]] = lambda: [[g() for g in row] for row in getters]
        self.step = scene.step
        self._world = world.name
        self._tracked = tracked
        self._contacts = [ContactStats(0, 0.0)] * len(robots)

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        raise BackendError(f"pymunk backend: world '{self._world}' is a mechanism: it has no wheels; "
                           f"its joints take command()")

    def command(self, robot: int, joint: str, mode: str, value: float) -> None:
        """A joint's target velocity or position (see the protocol)."""
        try:
            if mode == "velocity":
                self.scene.set_target_velocity(joint, value)
            else:
                self.scene.set_target_position(joint, value)
        except MechanismError as e:
            raise BackendError(str(e)) from None

    def pose(self, robot: int) -> tuple[float, float, float]:
        scene = self.scene
        x, z, _ = scene.body_pose(self._tracked) if self._tracked is not None else (0.0, 0.0, 0.0)
        return (x, z, wrap(scene.slew_angle))

    def contacts(self, robot: int) -> ContactStats:
        return self._contacts[robot]
