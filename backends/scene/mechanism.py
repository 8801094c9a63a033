"""Articulated mechanisms as plain data: bodies, joints and force sensors seen from the side.

A world file's ``mechanism:`` section (``labsim.backends.scene.mechanism_file`` reads it, with positions
for its errors) becomes a frozen ``Mechanism``. A backend builds a scene from it
(``labsim.backends.pymunk.mechanism.MechanismScene`` for the embedded one); nothing here
imports a simulator.

The frame is the vertical plane of the mechanism: ``x`` horizontal, ``z`` up, metres, with
gravity along -z. Every coordinate is given as in the world at the start, before anything
moves. The one motion out of the plane is a ``slew`` joint: the rotation of the whole plane
about a vertical axis (a tower crane's slewing ring), which a 2D backend integrates as an
angle rather than simulating.

Joint positions are SI: metres for prismatic joints, radians for revolute and slew joints.
How each kind defines its position is documented on ``JointSpec``.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from labsim.backends.scene.models import Kind

SHAPES = ("box", "cylinder")
JOINT_KINDS = ("revolute", "prismatic", "slew", "fixed")
ANGULAR_KINDS = ("revolute", "slew")
WELDING_KINDS = ("fixed", "slew")  # joints that join two bodies rigidly in the plane


@dataclass(frozen=True)
class BodySpec:
    """A rigid body: a box or an upright cylinder, seen from the side.

    In the plane both are rectangles ``size = (w, h)``: a cylinder's ``w`` is its diameter and
    its axis is vertical (along z). ``depth_m`` is the size across the plane (along y), used
    only for the volume when the mass comes from a density; it defaults to ``w`` (a square
    section, or the cylinder's diameter, which is its depth whatever is given).
    """

    name: str
    shape: str  # "box" | "cylinder"
    center: tuple[float, float]  # (x_m, z_m) of the centre at the start
    size: tuple[float, float]  # (w_m along x, h_m along z), both > 0
    mass_kg: float | None = None  # give this or density_kg_m3 for a moving body
    density_kg_m3: float | None = None  # mass = density * volume when mass_kg is None
    static: bool = False  # fixed to the world: never moves, needs no mass
    depth_m: float | None = None  # size along y; None means w
    angle_rad: float = 0.0  # rotation in the plane at the start, counter-clockwise from +x

    @property
    def volume_m3(self) -> float:
        w, h = self.size
        if self.shape == "cylinder":
            return math.pi * (w / 2) ** 2 * h
        return w * h * (self.depth_m if self.depth_m is not None else w)

    @property
    def mass(self) -> float:
        """Mass in kg: mass_kg, else density * volume, else 0 (static bodies)."""
        if self.mass_kg is not None:
            return self.mass_kg
        if self.density_kg_m3 is not None:
            return self.density_kg_m3 * self.volume_m3
        return 0.0

    @property
    def moment_kg_m2(self) -> float:
        """Moment of inertia about the body's centre for rotation in the plane (about y)."""
        w, h = self.size
        if self.shape == "cylinder":  # an upright solid cylinder about a transverse axis
            return self.mass * (3 * (w / 2) ** 2 + h * h) / 12
        return self.mass * (w * w + h * h) / 12

    def corners(self) -> tuple[tuple[float, float], ...]:
        """The outline's corners in the plane at the start, counter-clockwise, metres."""
        w, h = self.size
        c, s = math.cos(self.angle_rad), math.sin(self.angle_rad)
        cx, cz = self.center
        local = ((-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2), (-w / 2, h / 2))
        return tuple((cx + x * c - z * s, cz + x * s + z * c) for x, z in local)


@dataclass(frozen=True)
class MotorSpec:
    """A joint's actuator: it drives the joint to a target velocity or position.

    Units follow the joint: N, m/s, m/s^2 for prismatic joints; N m, rad/s, rad/s^2 for revolute
    and slew joints. A backend that integrates a joint kinematically (the slew in 2D, the
    winch of a rope) uses the speed and acceleration limits and not ``max_force``, except that
    a winch pays out rope when the load pulls harder than ``max_force``.
    """

    max_force: float  # N or N m, > 0: the most the actuator can push or twist
    max_speed: float  # m/s or rad/s, > 0: commands are clamped to this
    max_accel: float | None = None  # m/s^2 or rad/s^2; None: as fast as max_force allows
    velocity: bool = True  # accepts target velocities
    position: bool = True  # accepts target positions


@dataclass(frozen=True)
class JointSpec:
    """A joint between a parent and a child body, with an optional motor.

    ``name`` is the alias programs use (``Crab_Actuator``). Positions and ``anchor`` are
    world coordinates at the start. Kinds:

    - ``revolute``: the child turns about ``anchor`` (an axis across the plane). Position: the
      child's angle relative to the parent, radians counter-clockwise, 0 at the start.
    - ``prismatic``: the child slides along ``axis`` (a direction fixed to the parent) through
      ``anchor``, without turning. Position: (child centre - anchor) . axis, metres, so it is
      whatever the start geometry gives (not necessarily 0). With ``rope`` the child instead
      hangs from ``anchor`` on a rope: position is the rope's length (a winch), the child can
      swing and the rope can go slack; ``axis`` is not used.
    - ``slew``: the whole plane turns about the vertical axis through ``anchor`` (only its x
      counts). Position: the plane's angle, radians, counter-clockwise seen from above (from
      +x toward +y), 0 at the start. In the plane parent and child are rigidly joined.
    - ``fixed``: the child is welded to the parent (a counterweight on a jib); no position.

    ``limits`` bound the position, (lo, hi) with lo < hi, in the joint's units; None means
    unlimited (a revolute or slew joint turns freely).
    """

    name: str
    kind: str  # one of JOINT_KINDS
    parent: str  # body name
    child: str  # body name
    anchor: tuple[float, float] = (0.0, 0.0)  # (x_m, z_m) at the start
    axis: tuple[float, float] = (1.0, 0.0)  # unit vector in the plane; prismatic rails only
    limits: tuple[float, float] | None = None  # (lo, hi): m or rad
    motor: MotorSpec | None = None  # None: a passive joint (it moves only as pushed)
    rope: bool = False  # prismatic only: the child hangs on a winch rope

    @property
    def angular(self) -> bool:
        return self.kind in ANGULAR_KINDS


@dataclass(frozen=True)
class ForceSensorSpec:
    """A force sensor: a cable of fixed length between two bodies, reading its tension.

    The cable runs from ``anchors[0]`` on ``between[0]`` to ``anchors[1]`` on ``between[1]``
    (world points at the start; the bodies' centres when None) and its length is their
    distance at the start. It pulls and never pushes: the reading is the tension in newtons,
    the hanging weight at rest, and 0 when it is slack.
    """

    name: str
    between: tuple[str, str]  # two different body names
    anchors: tuple[tuple[float, float], tuple[float, float]] | None = None


@dataclass(frozen=True)
class Mechanism:
    """Bodies, joints and force sensors in a vertical plane under gravity.

    ``floor_z_m`` puts a floor (an infinite static line) at that height, which every body
    rests on; None means no floor. ``damping_1_s`` is the air drag and rope friction of every
    moving body: velocities decay as exp(-damping_1_s * t) when nothing drives them, so a
    swinging load's amplitude decays as exp(-damping_1_s * t / 2).
    """

    bodies: tuple[BodySpec, ...]
    joints: tuple[JointSpec, ...] = ()
    force_sensors: tuple[ForceSensorSpec, ...] = ()
    gravity_m_s2: float = 9.81  # along -z
    damping_1_s: float = 0.0
    floor_z_m: float | None = 0.0

    def body(self, name: str) -> BodySpec:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    def joint(self, name: str) -> JointSpec:
        for j in self.joints:
            if j.name == name:
                return j
        raise KeyError(name)

    @property
    def slew(self) -> JointSpec | None:
        """The joint that turns the plane about a vertical axis, if there is one (at most one)."""
        for j in self.joints:
            if j.kind == "slew":
                return j
        return None

    def initial_position(self, joint: JointSpec) -> float:
        """A joint's position at the start, from the geometry (see ``JointSpec``)."""
        return start_position(joint, self.body(joint.child))

    def channels(self) -> dict[str, Kind]:
        """What a behaviour reads from this mechanism, in a stable order: every joint but the
        fixed ones (position, velocity), every force sensor (tension), every moving body
        (x, z, angle in the plane)."""
        out: dict[str, Kind] = {j.name: Kind.JOINT for j in self.joints if j.kind != "fixed"}
        out.update({f.name: Kind.FORCE for f in self.force_sensors})
        out.update({b.name: Kind.BODY for b in self.bodies if not b.static})
        return out

    def motor_modes(self) -> dict[str, frozenset[str]]:
        """Joint name -> the target modes ("velocity", "position") its motor accepts; an
        empty set for a passive joint. Fixed joints are not listed."""
        out: dict[str, frozenset[str]] = {}
        for j in self.joints:
            if j.kind == "fixed":
                continue
            m = j.motor
            out[j.name] = frozenset() if m is None else frozenset(
                mode for mode, ok in (("velocity", m.velocity), ("position", m.position)) if ok)
        return out

    def weld_groups(self) -> list[list[BodySpec]]:
        """The bodies that move as one, in file order: ``fixed`` and ``slew`` joints weld
        their parent and child together in the plane. Each group lists its bodies in file
        order, and groups come in the order of their first body."""
        return [[self.body(n) for n in names] for names in weld_groups(
            [b.name for b in self.bodies],
            [(j.parent, j.child) for j in self.joints if j.kind in WELDING_KINDS])]


def start_position(joint: JointSpec, child: BodySpec) -> float:
    """A joint's position at the start: m along a rail or of rope, 0 for angular joints."""
    if joint.kind != "prismatic":
        return 0.0
    dx, dz = child.center[0] - joint.anchor[0], child.center[1] - joint.anchor[1]
    if joint.rope:
        return math.hypot(dx, dz)
    return dx * joint.axis[0] + dz * joint.axis[1]


def weld_groups(names: list[str], welds: list[tuple[str, str]]) -> list[list[str]]:
    """Partition ``names`` into the groups the ``welds`` (pairs of names) join, by union-find.

    Groups keep the order of ``names``, and so does each group's list: a run that builds
    bodies from them is the same on every run.
    """
    root = {n: n for n in names}

    def find(n: str) -> str:
        while root[n] != n:
            root[n] = root[root[n]]
            n = root[n]
        return n

    for a, b in welds:
        ra, rb = find(a), find(b)
        if ra != rb:
            root[rb] = ra
    members: dict[str, list[str]] = {}
    for n in names:
        members.setdefault(find(n), []).append(n)
    return list(members.values())
