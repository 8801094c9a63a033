"""A ``Mechanism`` simulated in pymunk: the physics of side-view labs such as the tower crane.

The backend builds one ``MechanismScene`` from a world's ``labsim.backends.scene.mechanism.Mechanism``
and, every tick, sets joint targets, calls ``step()`` and reads joint positions, velocities
and force sensors. Nothing here knows the language or the runtime.

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
tick at dt = 0.05 s, some 550 times faster than real time (tests/test_mechanism.py measures
it); the sub-steps are nearly all of it, about 8 us each.

Joint targets are followed by a planner that runs once a tick (``_control``): speed clamped to
max_speed, changed by at most max_accel * dt a tick, slowing down in time to stop exactly on a
position target, and on a limit when driven at it.
"""
from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field

import pymunk

from labsim.backends.scene.mechanism import BodySpec, ForceSensorSpec, JointSpec, Mechanism, MotorSpec

# 5 ms sub-steps at dt = 0.05 s. The crane's pendulum (about 6.5 m, period 5 s) needs far less;
# the chain rope - 10 kg hook - sling - 200 kg load is what needs small steps and many
# iterations. Its two cables each go slack for a sub-step when the solver has not converged,
# which loses their warm start, so an under-resolved chain keeps jiggling instead of settling:
# measured on the crane right after a lift, the sling's reading wanders by 35 % at 4 sub-steps
# and 10 iterations, 13 % at 8 and 20, and by less than 0.001 % at 10 and 30. Iterations are
# nearly free (41 vs 37 us a tick at 4 sub-steps); sub-steps are the cost.
DEFAULT_SUBSTEPS = 10
SOLVER_ITERATIONS = 30
# Allowed overlap between shapes, metres (pymunk's default 0.1 assumes pixels).
COLLISION_SLOP_M = 0.0005
FRICTION = 0.8
# A groove long enough to be a line: a prismatic joint without limits, and the driver's groove
# across the axis.
_LONG_M = 1.0e4
# The winch pays out when the rope's mean tension over a tick reaches this fraction of its
# max_force.
_SATURATED = 0.999


class MechanismError(ValueError):
    """A mechanism this backend cannot build, or a call naming a joint or body wrongly."""


def _did_you_mean(word: str, candidates: list[str]) -> str:
    m = difflib.get_close_matches(word, candidates, n=1, cutoff=0.6)
    return f" (did you mean '{m[0]}'?)" if m else ""


def _clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


def _stop_speed(distance: float, amax: float | None, dt: float) -> float:
    """The fastest speed from which ticks that each slow by amax * dt stop within distance.

    Such a stop covers v^2 / 2a + v dt / 2 (whatever sub-step lag the joint has, see
    ``_control``); planning every tick's speed by it never asks for more deceleration than amax.
    """
    if amax is None:
        return math.inf
    half = amax * dt / 2
    return -half + math.sqrt(half * half + 2 * amax * max(distance, 0.0))


@dataclass
class _Group:
    """Bodies welded together: one pymunk body."""

    members: list[BodySpec]
    body: pymunk.Body
    static: bool


@dataclass
class _Joint:
    """A joint's constraints and its controller's state."""

    spec: JointSpec
    parent: _Group | None = None
    child: _Group | None = None
    lo: float = -math.inf
    hi: float = math.inf
    mode: str = "velocity"  # what the last target set: "velocity" | "position"
    target: float = 0.0
    command: float = 0.0  # velocity commanded on the last tick, after speed/accel limits
    # prismatic rail
    child_local: tuple[float, float] = (0.0, 0.0)  # child's centre in its group body
    anchor_local: tuple[float, float] = (0.0, 0.0)  # anchor in the parent's group body
    axis: tuple[float, float] = (1.0, 0.0)
    driver: pymunk.Body | None = None
    # revolute
    motor: pymunk.SimpleMotor | None = None
    # rope and slew: integrated state
    value: float = 0.0  # rope length (m) or slew angle (rad)
    rope: pymunk.SlideJoint | None = None
    impulse_sum: float = 0.0  # the rope's impulses over the current tick, N s
    pulley: pymunk.Body | None = None  # a motorised rope's top end
    rope_dir: tuple[float, float] = (0.0, -1.0)  # unit vector pulley -> hook this sub-step
    pull: tuple[float, float] = (0.0, 0.0)  # the rope's force on the parent, N, for the next sub-step
    target_value: float = 0.0  # the rope length at the end of the current sub-step, m
    tick_start: float = 0.0  # a winch's or slew's position at the start of the tick
    tick_end: float = 0.0  # ... and where the command takes it by the end


@dataclass
class _Sensor:
    name: str
    cable: pymunk.SlideJoint
    impulse_sum: float = 0.0
    force_n: float = 0.0


@dataclass
class _Plan:
    """Per-tick lists the step loop walks, so it does no dispatch on joint kinds."""

    controlled: list[_Joint] = field(default_factory=list)
    winches: list[_Joint] = field(default_factory=list)


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

        names = [b.name for b in mechanism.bodies]
        if len(set(names)) != len(names):
            raise MechanismError("body names must be unique")
        self._body_names = names
        specs = {b.name: b for b in mechanism.bodies}
        for j in mechanism.joints:
            for role in ("parent", "child"):
                n = getattr(j, role)
                if n not in specs:
                    raise MechanismError(f"joint '{j.name}': no body '{n}' as {role}{_did_you_mean(n, names)}")
        for s in mechanism.force_sensors:
            for n in s.between:
                if n not in specs:
                    raise MechanismError(f"force sensor '{s.name}': no body '{n}'{_did_you_mean(n, names)}")
        if sum(j.kind == "slew" for j in mechanism.joints) > 1:
            raise MechanismError("at most one slew joint: the plane turns about one axis")

        self._member_local: dict[str, tuple[float, float]] = {}  # each body's centre in its group body
        self._groups, self._group_of = self._build_groups(mechanism, specs)
        if mechanism.floor_z_m is not None:
            z = mechanism.floor_z_m
            floor = pymunk.Segment(space.static_body, (-_LONG_M, z), (_LONG_M, z), 0.0)
            floor.friction = FRICTION
            space.add(floor)

        self._joints: dict[str, _Joint] = {}
        self._slew: _Joint | None = None
        self._plan = _Plan()
        for spec in mechanism.joints:
            self._joints[spec.name] = self._build_joint(spec)
        self._sensors: dict[str, _Sensor] = {}
        for s in mechanism.force_sensors:
            self._sensors[s.name] = self._build_sensor(s)
        self._sensor_list = list(self._sensors.values())

    # -- building -------------------------------------------------------------------------

    def _build_groups(self, m: Mechanism, specs: dict[str, BodySpec]) -> tuple[list[_Group], dict[str, _Group]]:
        members = {bodies[0].name: bodies for bodies in m.weld_groups()}
        groups, group_of = [], {}
        for bodies in members.values():
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
            g = _Group(bodies, body, static)
            groups.append(g)
            for b in bodies:
                group_of[b.name] = g
                self._member_local[b.name] = (b.center[0] - px, b.center[1] - pz)
        return groups, group_of

    def _local(self, g: _Group, point: tuple[float, float]) -> tuple[float, float]:
        """A world point at the start in a group body's frame (every group starts at angle 0)."""
        px, pz = g.body.position
        return (point[0] - px, point[1] - pz)

    def _build_joint(self, spec: JointSpec) -> _Joint:
        m = self.mechanism
        j = _Joint(spec)
        if spec.limits is not None:
            j.lo, j.hi = spec.limits
            if not j.lo < j.hi:
                raise MechanismError(f"joint '{spec.name}': limits must have lo < hi")
        motor = spec.motor
        if motor is not None and not (motor.max_force > 0 and motor.max_speed > 0):
            raise MechanismError(f"joint '{spec.name}': the motor's max_force and max_speed must be positive")
        if spec.kind == "fixed":
            return j
        if spec.kind == "slew":
            j.value = 0.0
            self._slew = j
            if motor is not None:
                self._plan.controlled.append(j)
            return j
        if spec.kind not in ("revolute", "prismatic"):
            raise MechanismError(f"joint '{spec.name}': unknown kind '{spec.kind}'")
        parent, child = self._group_of[spec.parent], self._group_of[spec.child]
        j.parent, j.child = parent, child
        if parent is child:
            raise MechanismError(f"joint '{spec.name}': '{spec.parent}' and '{spec.child}' are welded together")
        if child.static:
            raise MechanismError(f"joint '{spec.name}': the child '{spec.child}' is static and cannot move")
        start = m.initial_position(spec)
        if not j.lo - 1e-9 <= start <= j.hi + 1e-9:
            raise MechanismError(
                f"joint '{spec.name}' starts at {start:g}, outside its limits [{j.lo:g}, {j.hi:g}]")
        a, b = parent.body, child.body
        child_centre = m.body(spec.child).center
        j.child_local = self._local(child, child_centre)
        j.anchor_local = self._local(parent, spec.anchor)
        space = self.space

        if spec.kind == "revolute":
            pivot = pymunk.PivotJoint(a, b, spec.anchor)
            pivot.collide_bodies = False
            space.add(pivot)
            if spec.limits is not None:
                limit = pymunk.RotaryLimitJoint(a, b, j.lo, j.hi)
                limit.collide_bodies = False
                space.add(limit)
            if motor is not None:
                j.motor = pymunk.SimpleMotor(a, b, 0.0)
                j.motor.max_force = motor.max_force  # N m
                j.motor.collide_bodies = False
                space.add(j.motor)
                self._plan.controlled.append(j)
            return j

        if spec.rope:
            j.value = start
            if motor is None:  # a rope of fixed length
                rope = pymunk.SlideJoint(a, b, j.anchor_local, j.child_local, 0.0, start)
            else:
                j.pulley = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
                j.pulley.position = spec.anchor
                space.add(j.pulley)
                rope = pymunk.SlideJoint(j.pulley, b, (0.0, 0.0), j.child_local, 0.0, start)
                rope.max_force = motor.max_force
            j.rope = rope
            space.add(rope)
            if motor is not None:
                self._plan.controlled.append(j)
                self._plan.winches.append(j)
            return j

        ax, az = spec.axis
        n = math.hypot(ax, az)
        if not n > 0:
            raise MechanismError(f"joint '{spec.name}': the axis must not be zero")
        j.axis = (ax / n, az / n)
        ux, uz = j.axis
        lo = j.lo if spec.limits is not None else -_LONG_M
        hi = j.hi if spec.limits is not None else _LONG_M
        # The groove passes through the child's centre, which sits at s = start on it; the
        # child may sit off the line through the anchor (it is then offset across the axis).
        off_x = j.anchor_local[0] + (child_centre[0] - spec.anchor[0]) - start * ux
        off_z = j.anchor_local[1] + (child_centre[1] - spec.anchor[1]) - start * uz
        groove = pymunk.GrooveJoint(
            a, b, (off_x + lo * ux, off_z + lo * uz), (off_x + hi * ux, off_z + hi * uz), j.child_local)
        groove.collide_bodies = False
        gear = pymunk.GearJoint(a, b, 0.0, 1.0)
        gear.collide_bodies = False
        space.add(groove, gear)
        if motor is not None:
            if not parent.static:
                raise MechanismError(
                    f"joint '{spec.name}': a motorised prismatic joint needs a static parent in the pymunk "
                    f"backend ('{spec.parent}' moves)")
            driver = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            driver.position = child_centre
            servo = pymunk.GrooveJoint(driver, b, (-uz * _LONG_M, ux * _LONG_M), (uz * _LONG_M, -ux * _LONG_M),
                                       j.child_local)
            servo.max_force = motor.max_force  # N
            servo.max_bias = 0.0  # velocity only: the driver's position never matters
            servo.collide_bodies = False
            space.add(driver, servo)
            j.driver = driver
            self._plan.controlled.append(j)
        return j

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
        cable = pymunk.SlideJoint(ga.body, gb.body, self._local(ga, pa), self._local(gb, pb), 0.0, length)
        self.space.add(cable)
        return _Sensor(s.name, cable)

    # -- stepping -------------------------------------------------------------------------

    def step(self) -> None:
        """Advance dt_s: plan each controlled joint's velocity, then run the sub-steps."""
        dt = self.dt_s
        for j in self._plan.controlled:
            self._control(j, dt)
        h = self._h
        step = self.space.step
        sensors = self._sensor_list
        winches = self._plan.winches
        n = self.substeps
        for k in range(1, n + 1):
            for w in winches:
                self._wind(w, h, k / n)
            step(h)
            for s in sensors:
                s.impulse_sum += s.cable.impulse
            for w in winches:
                j_ns = w.rope.impulse  # type: ignore[union-attr]
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
            if w.impulse_sum >= _SATURATED * w.rope.max_force * dt:  # type: ignore[union-attr]
                self._pay_out(w)
            w.impulse_sum = 0.0
        self.time_s += dt

    def _control(self, j: _Joint, dt: float) -> None:
        """This tick's velocity command from the target, within the motor's limits."""
        motor: MotorSpec = j.spec.motor  # type: ignore[assignment]
        vmax, amax = motor.max_speed, motor.max_accel
        pos = self._position(j)
        kinematic = j.spec.kind == "slew" or j.rope is not None
        # pymunk moves bodies before it solves velocities, so a simulated joint's first
        # sub-step still runs at the last tick's velocity; plan from where that leaves it,
        # over the rest of the tick. Integrated joints move exactly v * dt.
        lag = 0.0 if kinematic else self._h
        reach = pos + j.command * lag
        rest = dt - lag
        if j.mode == "position":
            goal = _clamp(j.target, j.lo, j.hi)
            e = goal - reach
            # arrive within the tick when nothing else limits
            v = math.copysign(min(abs(e) / rest, _stop_speed(abs(e), amax, dt), vmax), e)
        else:
            goal = math.nan
            v = _clamp(j.target, -vmax, vmax)
        # A limit is a place to stop, as a crane's limit switches slow it down before its end
        # stop: driven at it, the joint brakes at amax and stops on it.
        if j.hi < math.inf:
            v = min(v, (j.hi - reach) / rest, _stop_speed(j.hi - reach, amax, dt))
        if j.lo > -math.inf:
            v = max(v, (j.lo - reach) / rest, -_stop_speed(reach - j.lo, amax, dt))
        if amax is not None:
            step = amax * dt
            # The last tick of a stop may slow by a little more than one step, to end exactly
            # on the target or limit rather than just past it.
            landing = abs(j.command) <= 2 * step and v * j.command >= 0 and abs(v) < abs(j.command)
            if not landing:
                v = _clamp(v, j.command - step, j.command + step)
        j.command = v
        kind = j.spec.kind
        if kinematic:
            # Where the tick ends, exactly on a limit or target when it gets there (sums of
            # v * h would miss it by a rounding error).
            end = _clamp(pos + v * dt, j.lo, j.hi)
            for exact in (goal, j.lo, j.hi):
                if abs(end - exact) < 1e-9:
                    end = exact
            j.tick_start, j.tick_end = pos, end
            if kind == "slew":
                j.value = end
        elif kind == "revolute":
            j.motor.rate = -v  # type: ignore[union-attr]  # pymunk's rate is a.w - b.w
        elif j.driver is not None:
            ux, uz = j.axis
            j.driver.velocity = (v * ux, v * uz)

    def _wind(self, w: _Joint, h: float, done: float) -> None:
        """Before a sub-step (``done`` of the tick when it ends): the pulley to the anchor,
        moving at the winch's speed."""
        parent = w.parent.body  # type: ignore[union-attr]
        ax, az = w.anchor_local
        top = parent.local_to_world((ax, az))
        hook = w.child.body.local_to_world(w.child_local)  # type: ignore[union-attr]
        dx, dz = hook.x - top.x, hook.y - top.y
        d = math.hypot(dx, dz)
        nx, nz = (dx / d, dz / d) if d > 1e-9 else (0.0, -1.0)
        new = w.tick_end if done == 1.0 else w.tick_start + (w.tick_end - w.tick_start) * done
        u = (new - w.value) / h
        w.target_value = new
        fx, fz = w.pull
        if not w.parent.static and (fx or fz):  # type: ignore[union-attr]
            parent.apply_force_at_world_point((fx, fz), top)
        w.rope_dir = (nx, nz)
        v = parent.velocity_at_world_point(top)
        pulley = w.pulley
        pulley.position = top  # type: ignore[union-attr]
        pulley.velocity = (v.x + u * nx, v.y + u * nz)  # type: ignore[union-attr]
        w.rope.max = w.value  # type: ignore[union-attr]  # the length at the start of the sub-step

    def _pay_out(self, w: _Joint) -> None:
        """The load pulls harder than the winch can hold: the rope runs out to where it is."""
        top = w.parent.body.local_to_world(w.anchor_local)  # type: ignore[union-attr]
        hook = w.child.body.local_to_world(w.child_local)  # type: ignore[union-attr]
        d = (hook - top).length
        if d > w.value:
            w.value = min(d, w.hi)

    # -- reading and commanding -----------------------------------------------------------

    def _joint(self, name: str) -> _Joint:
        try:
            return self._joints[name]
        except KeyError:
            raise MechanismError(f"no joint '{name}'{_did_you_mean(name, list(self._joints))}") from None

    def _position(self, j: _Joint) -> float:
        kind = j.spec.kind
        if kind == "slew" or j.rope is not None:
            return j.value
        if kind == "revolute":
            return j.child.body.angle - j.parent.body.angle  # type: ignore[union-attr]
        if kind == "prismatic":
            p = j.parent.body.world_to_local(j.child.body.local_to_world(j.child_local))  # type: ignore[union-attr]
            return (p.x - j.anchor_local[0]) * j.axis[0] + (p.y - j.anchor_local[1]) * j.axis[1]
        raise MechanismError(f"joint '{j.spec.name}' is fixed: it has no position")

    def joint_names(self) -> list[str]:
        return list(self._joints)

    def joint_position(self, name: str) -> float:
        """m (prismatic: along the axis, or a rope's length) or rad (revolute, slew)."""
        return self._position(self._joint(name))

    def joint_velocity(self, name: str) -> float:
        """m/s or rad/s: the child's motion relative to the parent (a winch's and the slew's
        velocity is the one integrated on the last tick)."""
        j = self._joint(name)
        kind = j.spec.kind
        if kind == "slew" or j.rope is not None:
            return j.command
        if kind == "revolute":
            return j.child.body.angular_velocity - j.parent.body.angular_velocity  # type: ignore[union-attr]
        if kind == "prismatic":
            a, b = j.parent.body, j.child.body  # type: ignore[union-attr]
            p = b.local_to_world(j.child_local)
            rel = b.velocity_at_world_point(p) - a.velocity_at_world_point(p)
            ux, uz = j.axis
            c, s = math.cos(a.angle), math.sin(a.angle)
            return rel.x * (ux * c - uz * s) + rel.y * (ux * s + uz * c)
        raise MechanismError(f"joint '{name}' is fixed: it has no velocity")

    def _motorised(self, name: str, target: str) -> _Joint:
        j = self._joint(name)
        motor = j.spec.motor
        if motor is None:
            raise MechanismError(f"joint '{name}' has no motor: it cannot be driven")
        if not getattr(motor, target):
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

    def _member(self, name: str) -> tuple[_Group, BodySpec]:
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
