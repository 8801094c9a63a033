"""A mechanism's joints in pymunk: one small class per kind, and the planner that drives them.

``labsim.backends.pymunk.mechanism.MechanismScene`` welds the bodies into groups (``Group``:
one pymunk body each), then calls ``build_joint`` for every ``JointSpec``: it checks the spec,
adds the kind's constraints to the space, and returns the joint that reads its position and
velocity and carries out the velocity ``control`` plans for it once a tick. How each kind
becomes constraints, and why, is in that module's docstring.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import pymunk

from labsim.backends.pymunk import chipmunk
from labsim.backends.scene.mechanism import BodySpec, JointSpec, Mechanism, MotorSpec

# A groove long enough to be a line: a prismatic joint without limits, and the driver's groove
# across the axis.
LONG_M = 1.0e4


class MechanismError(ValueError):
    """A mechanism this backend cannot build, or a call naming a joint or body wrongly."""


def clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


@dataclass
class Group:
    """Bodies welded together: one pymunk body."""

    members: list[BodySpec]
    body: pymunk.Body
    static: bool

    def local(self, point: tuple[float, float]) -> tuple[float, float]:
        """A world point at the start in this group's body frame (every group starts at angle 0)."""
        px, pz = self.body.position
        return (point[0] - px, point[1] - pz)


@dataclass(kw_only=True)
class Joint:
    """A joint and its controller's state; as such, a ``fixed`` joint (no position)."""

    spec: JointSpec
    lo: float = -math.inf
    hi: float = math.inf
    mode: str = "velocity"  # what the last target set: "velocity" | "position"
    target: float = 0.0
    command: float = 0.0  # velocity commanded on the last tick, after speed/accel limits
    # Integrated from the command (the slew, a rope's winch) rather than simulated: the
    # position moves exactly command * dt a tick.
    kinematic: ClassVar[bool] = False

    def position(self) -> float:
        """m or rad, as ``JointSpec`` defines it for the kind."""
        raise MechanismError(f"joint '{self.spec.name}' is fixed: it has no position")

    def velocity(self) -> float:
        """m/s or rad/s: the child's motion relative to the parent."""
        raise MechanismError(f"joint '{self.spec.name}' is fixed: it has no velocity")

    def drive(self, v: float, pos: float, goal: float, dt: float) -> None:
        """Carry out this tick's planned velocity v, from position pos (goal: a position
        target, or nan)."""


def _tick_end(j: Joint, pos: float, v: float, goal: float, dt: float) -> float:
    """Where an integrated joint ends the tick: exactly on a limit or target when it gets
    there (sums of v * h would miss it by a rounding error)."""
    end = clamp(pos + v * dt, j.lo, j.hi)
    for exact in (goal, j.lo, j.hi):
        if abs(end - exact) < 1e-9:
            end = exact
    return end


@dataclass(kw_only=True)
class Slew(Joint):
    """The plane's rotation about the tower: an angle integrated from the command."""

    value: float = 0.0  # rad
    kinematic: ClassVar[bool] = True

    def position(self) -> float:
        return self.value

    def velocity(self) -> float:
        return self.command  # integrated on the last tick

    def drive(self, v: float, pos: float, goal: float, dt: float) -> None:
        self.value = _tick_end(self, pos, v, goal, dt)


@dataclass(kw_only=True)
class Revolute(Joint):
    parent: Group
    child: Group
    motor: pymunk.SimpleMotor | None = None

    def position(self) -> float:
        return self.child.body.angle - self.parent.body.angle

    def velocity(self) -> float:
        return self.child.body.angular_velocity - self.parent.body.angular_velocity

    def drive(self, v: float, pos: float, goal: float, dt: float) -> None:
        motor = self.motor
        if motor is not None:
            motor.rate = -v  # pymunk's rate is a.w - b.w


@dataclass(kw_only=True)
class Rail(Joint):
    """A prismatic joint on a groove; ``driver`` is a motorised rail's kinematic servo body."""

    parent: Group
    child: Group
    child_local: tuple[float, float]  # child's centre in its group body
    anchor_local: tuple[float, float]  # anchor in the parent's group body
    axis: tuple[float, float]  # unit vector in the parent's frame
    driver: pymunk.Body | None = None

    def position(self) -> float:
        p = self.parent.body.world_to_local(self.child.body.local_to_world(self.child_local))
        return (p.x - self.anchor_local[0]) * self.axis[0] + (p.y - self.anchor_local[1]) * self.axis[1]

    def velocity(self) -> float:
        a, b = self.parent.body, self.child.body
        p = b.local_to_world(self.child_local)
        rel = b.velocity_at_world_point(p) - a.velocity_at_world_point(p)
        ux, uz = self.axis
        c, s = math.cos(a.angle), math.sin(a.angle)
        return rel.x * (ux * c - uz * s) + rel.y * (ux * s + uz * c)

    def drive(self, v: float, pos: float, goal: float, dt: float) -> None:
        driver = self.driver
        if driver is not None:
            ux, uz = self.axis
            driver.velocity = (v * ux, v * uz)


@dataclass(kw_only=True)
class Rope(Joint):
    """A prismatic joint whose child hangs on a rope of fixed length (``value``, m)."""

    parent: Group
    child: Group
    child_local: tuple[float, float]
    anchor_local: tuple[float, float]
    rope: pymunk.SlideJoint
    value: float  # the rope's length, m
    kinematic: ClassVar[bool] = True

    def position(self) -> float:
        return self.value

    def velocity(self) -> float:
        return self.command


@dataclass(kw_only=True)
class Winch(Rope):
    """A motorised rope: it hangs from a kinematic pulley at the parent's anchor."""

    pulley: pymunk.Body
    impulse_sum: float = 0.0  # the rope's impulses over the current tick, N s
    rope_dir: tuple[float, float] = (0.0, -1.0)  # unit vector pulley -> hook this sub-step
    pull: tuple[float, float] = (0.0, 0.0)  # the rope's force on the parent, N, for the next sub-step
    target_value: float = 0.0  # the rope length at the end of the current sub-step, m
    tick_start: float = 0.0  # the length at the start of the tick
    tick_end: float = 0.0  # ... and where the command takes it by the end

    def drive(self, v: float, pos: float, goal: float, dt: float) -> None:
        self.tick_start, self.tick_end = pos, _tick_end(self, pos, v, goal, dt)

    def wind(self, h: float, done: float) -> None:
        """Before a sub-step (``done`` of the tick when it ends): the pulley to the anchor,
        moving at the winch's speed.

        It runs before every sub-step, so it calls chipmunk directly, as pymunk's wrappers
        would with the same arguments (``labsim.backends.pymunk.chipmunk``): about a third of
        the crane's run went to the wrappers' vectors and attribute layer.
        """
        parent = chipmunk.c_body(self.parent.body)
        top = chipmunk.local_to_world(parent, self.anchor_local)
        hook = chipmunk.local_to_world(chipmunk.c_body(self.child.body), self.child_local)
        dx, dz = hook.x - top.x, hook.y - top.y
        d = math.hypot(dx, dz)
        nx, nz = (dx / d, dz / d) if d > 1e-9 else (0.0, -1.0)
        new = self.tick_end if done == 1.0 else self.tick_start + (self.tick_end - self.tick_start) * done
        u = (new - self.value) / h
        self.target_value = new
        fx, fz = self.pull
        if not self.parent.static and (fx or fz):
            chipmunk.apply_force_at_world_point(parent, (fx, fz), top)
        self.rope_dir = (nx, nz)
        v = chipmunk.velocity_at_world_point(parent, top)
        pulley = chipmunk.c_body(self.pulley)
        chipmunk.set_position(pulley, top)
        chipmunk.set_velocity(pulley, (v.x + u * nx, v.y + u * nz))
        chipmunk.set_slide_max(chipmunk.c_constraint(self.rope), self.value)  # the length at the sub-step's start

    def pay_out(self) -> None:
        """The load pulls harder than the winch can hold: the rope runs out to where it is."""
        top = self.parent.body.local_to_world(self.anchor_local)
        hook = self.child.body.local_to_world(self.child_local)
        d = (hook - top).length
        if d > self.value:
            self.value = min(d, self.hi)


# -- building ------------------------------------------------------------------------------


def build_joint(spec: JointSpec, m: Mechanism, group_of: dict[str, Group], space: pymunk.Space) -> Joint:
    """Check a joint, add its constraints to the space, and return it."""
    lo, hi = -math.inf, math.inf
    if spec.limits is not None:
        lo, hi = spec.limits
        if not lo < hi:
            raise MechanismError(f"joint '{spec.name}': limits must have lo < hi")
    motor = spec.motor
    if motor is not None and not (motor.max_force > 0 and motor.max_speed > 0):
        raise MechanismError(f"joint '{spec.name}': the motor's max_force and max_speed must be positive")
    if spec.kind == "fixed":
        return Joint(spec=spec, lo=lo, hi=hi)
    if spec.kind == "slew":
        return Slew(spec=spec, lo=lo, hi=hi)
    if spec.kind not in ("revolute", "prismatic"):
        raise MechanismError(f"joint '{spec.name}': unknown kind '{spec.kind}'")
    parent, child = group_of[spec.parent], group_of[spec.child]
    if parent is child:
        raise MechanismError(f"joint '{spec.name}': '{spec.parent}' and '{spec.child}' are welded together")
    if child.static:
        raise MechanismError(f"joint '{spec.name}': the child '{spec.child}' is static and cannot move")
    start = m.initial_position(spec)
    if not lo - 1e-9 <= start <= hi + 1e-9:
        raise MechanismError(f"joint '{spec.name}' starts at {start:g}, outside its limits [{lo:g}, {hi:g}]")
    if spec.kind == "revolute":
        return _revolute(spec, parent, child, lo, hi, space)
    if spec.rope:
        return _rope(spec, parent, child, lo, hi, start, m.body(spec.child).center, space)
    return _rail(spec, parent, child, lo, hi, start, m.body(spec.child).center, space)


def _revolute(spec: JointSpec, parent: Group, child: Group, lo: float, hi: float, space: pymunk.Space) -> Revolute:
    """A pivot, a rotary limit when limited, and a torque-limited velocity servo when motorised."""
    a, b = parent.body, child.body
    pivot = pymunk.PivotJoint(a, b, spec.anchor)
    pivot.collide_bodies = False
    space.add(pivot)
    if spec.limits is not None:
        limit = pymunk.RotaryLimitJoint(a, b, lo, hi)
        limit.collide_bodies = False
        space.add(limit)
    servo = None
    if spec.motor is not None:
        servo = pymunk.SimpleMotor(a, b, 0.0)
        servo.max_force = spec.motor.max_force  # N m
        servo.collide_bodies = False
        space.add(servo)
    return Revolute(spec=spec, lo=lo, hi=hi, parent=parent, child=child, motor=servo)


def _rope(spec: JointSpec, parent: Group, child: Group, lo: float, hi: float, start: float,
          child_centre: tuple[float, float], space: pymunk.Space) -> Rope:
    """A slide joint from the anchor (or from a winch's pulley there) to the child's centre."""
    child_local, anchor_local = child.local(child_centre), parent.local(spec.anchor)
    motor = spec.motor
    if motor is None:  # a rope of fixed length
        rope = pymunk.SlideJoint(parent.body, child.body, anchor_local, child_local, 0.0, start)
        space.add(rope)
        return Rope(spec=spec, lo=lo, hi=hi, parent=parent, child=child, child_local=child_local,
                    anchor_local=anchor_local, rope=rope, value=start)
    pulley = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
    pulley.position = spec.anchor
    space.add(pulley)
    rope = pymunk.SlideJoint(pulley, child.body, (0.0, 0.0), child_local, 0.0, start)
    rope.max_force = motor.max_force
    space.add(rope)
    return Winch(spec=spec, lo=lo, hi=hi, parent=parent, child=child, child_local=child_local,
                 anchor_local=anchor_local, rope=rope, value=start, pulley=pulley)


def _rail(spec: JointSpec, parent: Group, child: Group, lo: float, hi: float, start: float,
          child_centre: tuple[float, float], space: pymunk.Space) -> Rail:
    """A groove through the child's centre and a gear against turning; a motorised rail adds a
    kinematic driver body and a servo groove across the axis."""
    child_local, anchor_local = child.local(child_centre), parent.local(spec.anchor)
    ax, az = spec.axis
    n = math.hypot(ax, az)
    if not n > 0:
        raise MechanismError(f"joint '{spec.name}': the axis must not be zero")
    ux, uz = ax / n, az / n
    g_lo = lo if spec.limits is not None else -LONG_M
    g_hi = hi if spec.limits is not None else LONG_M
    a, b = parent.body, child.body
    # The groove passes through the child's centre, which sits at s = start on it; the child
    # may sit off the line through the anchor (it is then offset across the axis).
    off_x = anchor_local[0] + (child_centre[0] - spec.anchor[0]) - start * ux
    off_z = anchor_local[1] + (child_centre[1] - spec.anchor[1]) - start * uz
    groove = pymunk.GrooveJoint(
        a, b, (off_x + g_lo * ux, off_z + g_lo * uz), (off_x + g_hi * ux, off_z + g_hi * uz), child_local)
    groove.collide_bodies = False
    gear = pymunk.GearJoint(a, b, 0.0, 1.0)
    gear.collide_bodies = False
    space.add(groove, gear)
    joint = Rail(spec=spec, lo=lo, hi=hi, parent=parent, child=child, child_local=child_local,
                 anchor_local=anchor_local, axis=(ux, uz))
    if spec.motor is not None:
        if not parent.static:
            raise MechanismError(
                f"joint '{spec.name}': a motorised prismatic joint needs a static parent in the pymunk "
                f"backend ('{spec.parent}' moves)")
        driver = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        driver.position = child_centre
        servo = pymunk.GrooveJoint(driver, b, (-uz * LONG_M, ux * LONG_M), (uz * LONG_M, -ux * LONG_M), child_local)
        servo.max_force = spec.motor.max_force  # N
        servo.max_bias = 0.0  # velocity only: the driver's position never matters
        servo.collide_bodies = False
        space.add(driver, servo)
        joint.driver = driver
    return joint


# -- the planner ---------------------------------------------------------------------------


def _stop_speed(distance: float, amax: float | None, dt: float) -> float:
    """The fastest speed from which ticks that each slow by amax * dt stop within distance.

    Such a stop covers v^2 / 2a + v dt / 2 (whatever sub-step lag the joint has, see
    ``control``); planning every tick's speed by it never asks for more deceleration than amax.
    """
    if amax is None:
        return math.inf
    half = amax * dt / 2
    return -half + math.sqrt(half * half + 2 * amax * max(distance, 0.0))


def control(j: Joint, motor: MotorSpec, dt: float, h: float) -> None:
    """This tick's velocity command from the target, within the motor's limits (h: the
    sub-step, s), carried out by the joint."""
    vmax, amax = motor.max_speed, motor.max_accel
    pos = j.position()
    # pymunk moves bodies before it solves velocities, so a simulated joint's first sub-step
    # still runs at the last tick's velocity; plan from where that leaves it, over the rest of
    # the tick. Integrated joints move exactly v * dt.
    lag = 0.0 if j.kinematic else h
    reach = pos + j.command * lag
    rest = dt - lag
    if j.mode == "position":
        goal = clamp(j.target, j.lo, j.hi)
        e = goal - reach
        # arrive within the tick when nothing else limits
        v = math.copysign(min(abs(e) / rest, _stop_speed(abs(e), amax, dt), vmax), e)
    else:
        goal = math.nan
        v = clamp(j.target, -vmax, vmax)
    # A limit is a place to stop, as a crane's limit switches slow it down before its end
    # stop: driven at it, the joint brakes at amax and stops on it.
    if j.hi < math.inf:
        v = min(v, (j.hi - reach) / rest, _stop_speed(j.hi - reach, amax, dt))
    if j.lo > -math.inf:
        v = max(v, (j.lo - reach) / rest, -_stop_speed(reach - j.lo, amax, dt))
    if amax is not None:
        step = amax * dt
        # The last tick of a stop may slow by a little more than one step, to end exactly on
        # the target or limit rather than just past it.
        landing = abs(j.command) <= 2 * step and v * j.command >= 0 and abs(v) < abs(j.command)
        if not landing:
            v = clamp(v, j.command - step, j.command + step)
    j.command = v
    j.drive(v, pos, goal, dt)
