"""A world file's ``mechanism:`` section to a ``labsim.backends.scene.mechanism.Mechanism``.

``labsim.backends.scene.world_file`` reads the rest of a world file and hands this section's node here. Like
every reader it reports each mistake as a positioned diagnostic (file:line:col, caret under
the value) into the ``Report`` and keeps going, so one ``labsim check`` shows them all. The
frame is the mechanism's vertical plane: x along it, z up, metres; every coordinate is where
things are at the start. ::

    mechanism:
      gravity: 9.81            # m/s^2, along -z (default 9.81)
      damping: 0.1             # 1/s: velocities of moving bodies decay as exp(-damping t) (default 0)
      floor: 0                 # z of the floor in metres; null for none (default 0)
      bodies:                  # NAME: {...}
        tower: {shape: box, center: [-2, 4.15], size: [0.4, 7.7], static: true}
        crab:  {shape: box, center: [1, 7.825], size: [0.55, 0.35], depth: 0.35, mass: 50}
        load:  {shape: cylinder, center: [1, 0.3], size: [0.6, 0.6], density: 700}
      joints:                  # NAME: {...}; the name is what programs use
        Crab_Actuator:
          kind: prismatic      # revolute | prismatic | slew | fixed
          parent: arm
          child: crab
          anchor: [-2, 7.825]  # where the joint is: pivot, rail origin, rope's top, slew axis
          axis: [1, 0]         # prismatic rails: the direction of travel
          limits: [0.6, 7.2]   # m, or rad for revolute/slew (or limits_deg: [lo, hi])
          motor: {max_force: 2000, max_speed: 1.0, max_accel: 0.5, targets: [velocity, position]}
      force_sensors:           # NAME: {...}: a cable between two bodies that reads its tension
        Force_sensor: {between: [gripper, load], anchors: [[1, 1.7], [1, 0.6]]}

Body keys: ``shape`` (box | cylinder, upright; default box), ``center`` [x, z], ``size`` [w, h]
(a cylinder's w is its diameter), ``depth`` (size across the plane, for the volume; default w),
``mass`` (kg) or ``density`` (kg/m^3) for a body that moves, ``static`` (true: fixed to the
world), ``angle_deg``. A joint with ``rope: true`` (prismatic only) hangs its child from the
anchor on a winch rope whose length is the joint's position. The meaning of every field is
documented on the dataclasses in ``labsim.backends.scene.mechanism``.
"""
from __future__ import annotations

import contextlib
import math

from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from labsim.backends.scene.mechanism import (
    ANGULAR_KINDS,
    JOINT_KINDS,
    SHAPES,
    WELDING_KINDS,
    BodySpec,
    ForceSensorSpec,
    JointSpec,
    Mechanism,
    MotorSpec,
    start_position,
    weld_groups,
)
from labsim.foundation.diagnostics import Report, did_you_mean
from labsim.foundation.limits import MAX_COORD_M
from labsim.foundation.source import Document, Reader, scalar_value

KEYS = ("gravity", "damping", "floor", "bodies", "joints", "force_sensors")
BODY_KEYS = ("shape", "center", "size", "depth", "mass", "density", "static", "angle_deg")
JOINT_KEYS = ("kind", "parent", "child", "anchor", "axis", "rope", "limits", "limits_deg", "motor")
MOTOR_KEYS = ("max_force", "max_speed", "max_accel", "targets")
SENSOR_KEYS = ("between", "anchors")
TARGETS = ("velocity", "position")


def read_mechanism(node: Node, doc: Document, report: Report) -> Mechanism | None:
    """The mechanism a ``mechanism:`` node describes; None when it has any error (all reported)."""
    before = len(report.errors)
    mechanism = _Reader(doc, report).read(node)
    return mechanism if len(report.errors) == before else None


class _Reader(Reader):
    def __init__(self, doc: Document, report: Report) -> None:
        super().__init__(doc, report)
        self.declared: set[str] = set()  # every body named, read or not

    def pair(self, node: Node, what: str) -> tuple[float, float] | None:
        """Every pair of a mechanism (centres, sizes, anchors, axes) within the world's
        coordinate range, so that the simulator never meets a number it cannot step."""
        p = super().pair(node, what)
        if p is not None and any(abs(v) > MAX_COORD_M for v in p):
            self.error(node, f"{what} must be within +-{MAX_COORD_M:g} m")
            return None
        return p

    def number_problem(self, node: Node, what: str, integer: bool) -> tuple[str, tuple[str, ...]]:
        message, notes = super().number_problem(node, what, integer)
        value = scalar_value(node) if isinstance(node, ScalarNode) else None
        if isinstance(value, str):
            with contextlib.suppress(ValueError):  # text that is no number at all needs no hint
                notes = (f"hint: YAML reads '{value}' as text; write it with a dot, such as {float(value)!r}",)
        return message, notes

    def body_ref(self, node: Node, what: str) -> str | None:
        n = self.name(node, what)
        if n is not None and n not in self.declared:
            self.error(node, f"unknown body '{n}'{did_you_mean(n, sorted(self.declared))}")
            return None
        return n

    def not_negative(self, f: dict[str, Node], key: str, default: float, message: str) -> float:
        """An optional number that must not be negative; the default when absent or wrong (reported)."""
        if key not in f:
            return default
        value = self.number(f[key], key)
        if value is not None and value < 0:
            self.error(f[key], message)
            return default
        return default if value is None else value

    # -- sections -------------------------------------------------------------------------

    def read(self, node: Node) -> Mechanism | None:
        f = self.fields(node, KEYS, "mechanism")
        if f is None:
            return None
        gravity = self.not_negative(f, "gravity", 9.81,
                                    "gravity is the size of g along -z (m/s^2) and must not be negative")
        damping = self.not_negative(f, "damping", 0.0, "damping (1/s) must not be negative")
        floor: float | None = 0.0
        if "floor" in f:
            v = f["floor"]
            floor = None if isinstance(v, ScalarNode) and scalar_value(v) is None else self.number(v, "floor")
        if "bodies" not in f:
            self.error(node, "a mechanism needs 'bodies'")
            return None
        bodies: dict[str, BodySpec] = {}  # the bodies read without error
        declared: set[str] = set()  # so that a broken body is not also "unknown" to its joints
        for key, value in self.entries(f["bodies"], "bodies") or []:
            declared.add(key.value)
            b = self.body(key.value, value)
            if b is not None:
                bodies[b.name] = b
        if isinstance(f["bodies"], MappingNode) and not declared:
            self.error(f["bodies"], "a mechanism needs at least one body")
        self.declared = declared
        names: dict[str, Node] = {}
        joints = self.joints(f["joints"], bodies, names) if "joints" in f else []
        sensors = []
        for key, value in (self.entries(f["force_sensors"], "force_sensors") or []) if "force_sensors" in f else []:
            self.unique(key, names)
            s = self.sensor(key.value, value, bodies)
            if s is not None:
                sensors.append(s)
        self.check_welds(bodies, joints, f.get("joints"))
        return Mechanism(tuple(bodies.values()), tuple(joints), tuple(sensors), gravity, damping, floor)

    def joints(self, node: Node, bodies: dict[str, BodySpec], names: dict[str, Node]) -> list[JointSpec]:
        joints: list[JointSpec] = []
        moved_by: dict[str, str] = {}  # child body -> the joint that moves it
        slew: str | None = None
        for key, value in self.entries(node, "joints") or []:
            self.unique(key, names)
            j = self.joint(key.value, value, bodies)
            if j is None:
                continue
            if j.child in moved_by:
                self.error(key, f"body '{j.child}' is already the child of joint '{moved_by[j.child]}'; "
                                f"a body has one parent joint")
                continue
            if j.kind == "slew":
                if slew is not None:
                    self.error(key, f"a mechanism has at most one slew joint ('{slew}' is one)")
                    continue
                slew = j.name
            moved_by[j.child] = j.name
            joints.append(j)
        return joints

    def unique(self, key: ScalarNode, names: dict[str, Node]) -> None:
        """Joints and force sensors share one namespace: both are names programs read."""
        if key.value in names:
            first = names[key.value].start_mark.line + 1
            self.error(key, f"duplicate name '{key.value}' (a joint or force sensor on line {first})")
        else:
            names[key.value] = key

    def body(self, name: str, node: Node) -> BodySpec | None:
        f = self.fields(node, BODY_KEYS, f"body '{name}'")
        if f is None:
            return None
        ok = True
        shape = "box"
        if "shape" in f:
            s = self.name(f["shape"], "shape")
            if s is not None and s not in SHAPES:
                self.error(f["shape"], f"unknown shape '{s}': box or cylinder{did_you_mean(s, SHAPES)}")
                ok = False
            elif s is not None:
                shape = s
        center = size = None
        for key in ("center", "size"):
            if key not in f:
                self.error(node, f"body '{name}' needs '{key}: [{'x, z' if key == 'center' else 'w, h'}]'")
                ok = False
        if "center" in f:
            center = self.pair(f["center"], "center")
        if "size" in f:
            size = self.pair(f["size"], "size")
            if size is not None and not (size[0] > 0 and size[1] > 0):
                self.error(f["size"], "a body's size must be positive")
                size = None
        static = self.flag(f["static"], "static") is True if "static" in f else False
        depth = self.positive(f["depth"], "depth") if "depth" in f else None
        if depth is not None and shape == "cylinder":
            self.error(f["depth"], "a cylinder's depth is its diameter (the first number of 'size')")
            ok = False
        mass = self.positive(f["mass"], "mass (kg)") if "mass" in f else None
        density = self.positive(f["density"], "density (kg/m^3)") if "density" in f else None
        if "mass" in f and "density" in f:
            self.error(f["density"], "give 'mass' or 'density', not both")
            ok = False
        elif not static and "mass" not in f and "density" not in f:
            self.error(node, f"body '{name}' moves, so it needs 'mass' (kg) or 'density' (kg/m^3); "
                             f"or say 'static: true'")
            ok = False
        angle = 0.0
        if "angle_deg" in f:
            a = self.number(f["angle_deg"], "angle_deg")
            angle = math.radians(a) if a is not None else 0.0
        if not ok or center is None or size is None or ("depth" in f and depth is None) \
                or ("mass" in f and mass is None) or ("density" in f and density is None):
            return None
        return BodySpec(name, shape, center, size, mass, density, static, depth, angle)

    def joint(self, name: str, node: Node, bodies: dict[str, BodySpec]) -> JointSpec | None:
        f = self.fields(node, JOINT_KEYS, f"joint '{name}'")
        if f is None:
            return None
        ok = True
        for key in ("kind", "parent", "child"):
            if key not in f:
                self.error(node, f"joint '{name}' needs '{key}'")
                ok = False
        kind = self.name(f["kind"], "kind") if "kind" in f else None
        if kind is not None and kind not in JOINT_KINDS:
            self.error(f["kind"], f"unknown joint kind '{kind}': {', '.join(JOINT_KINDS)}"
                                  f"{did_you_mean(kind, JOINT_KINDS)}")
            kind = None
        parent = self.body_ref(f["parent"], "parent") if "parent" in f else None
        child = self.body_ref(f["child"], "child") if "child" in f else None
        if parent is not None and parent == child:
            self.error(f["child"], f"joint '{name}' joins '{child}' to itself")
            ok = False
        if kind is None or parent is None or child is None:
            return None
        rope = self.flag(f["rope"], "rope") is True if "rope" in f else False
        if rope and kind != "prismatic":
            self.error(f["rope"], "only a prismatic joint can be a rope (a winch)")
            ok = False
        anchor = (0.0, 0.0)
        if "anchor" in f:
            a = self.pair(f["anchor"], "anchor")
            ok = ok and a is not None
            anchor = a or anchor
        elif kind != "fixed":
            self.error(node, f"joint '{name}' needs 'anchor: [x, z]' (where the joint is, at the start)")
            ok = False
        axis = self.axis(f, node, name, kind, rope)
        ok = ok and axis is not None
        if child in bodies and bodies[child].static and kind in ("revolute", "prismatic"):
            self.error(f["child"], f"'{child}' is static: a {kind} joint's child must be able to move")
            ok = False
        limits_ok, limits = self.limits(f, kind)
        ok = ok and limits_ok
        motor = None
        if "motor" in f:
            if kind == "fixed":
                self.error(f["motor"], "a fixed joint has no motor")
                ok = False
            else:
                motor = self.motor(f["motor"], name, kind)
                ok = ok and motor is not None
        if not ok or axis is None:
            return None
        spec = JointSpec(name, kind, parent, child, anchor, axis, limits, motor, rope)
        return spec if self.starts_within_limits(spec, f, bodies) else None

    def axis(self, f: dict[str, Node], node: Node, name: str, kind: str, rope: bool) -> tuple[float, float] | None:
        """A prismatic rail's direction as a unit vector, (1, 0) for other joints; None after an error."""
        if "axis" not in f:
            if kind == "prismatic" and not rope:
                self.error(node, f"joint '{name}' needs 'axis: [x, z]' (the direction it slides in)")
                return None
            return (1.0, 0.0)
        if kind != "prismatic" or rope:
            self.error(f["axis"], "only a prismatic rail has an axis" +
                       (" (a rope hangs where gravity takes it)" if rope else ""))
            return None
        ax = self.pair(f["axis"], "axis")
        if ax is None:
            return None
        n = math.hypot(*ax)
        if n == 0:
            self.error(f["axis"], "the axis must not be [0, 0]")
            return None
        return (ax[0] / n, ax[1] / n)

    def starts_within_limits(self, spec: JointSpec, f: dict[str, Node], bodies: dict[str, BodySpec]) -> bool:
        """Whether a joint's start position is within its limits (else reported): a prismatic
        joint's is where its child is, an angular joint's is 0."""
        limits = spec.limits
        if limits is None:
            return True
        where = f.get("limits") or f["limits_deg"]
        if spec.kind == "prismatic" and spec.child in bodies:
            start = start_position(spec, bodies[spec.child])
            if not limits[0] - 1e-9 <= start <= limits[1] + 1e-9:
                self.error(where, f"'{spec.child}' starts at {start:g} m along '{spec.name}', outside its limits "
                                  f"[{limits[0]:g}, {limits[1]:g}]")
                return False
        if spec.kind in ANGULAR_KINDS and not limits[0] <= 0 <= limits[1]:
            self.error(where, f"'{spec.name}' starts at angle 0, so its limits must include 0")
            return False
        return True

    def limits(self, f: dict[str, Node], kind: str) -> tuple[bool, tuple[float, float] | None]:
        """(whether they are right, (lo, hi) in SI or None): None when absent or null (unlimited)
        and after an error (reported)."""
        if "limits" in f and "limits_deg" in f:
            self.error(f["limits_deg"], "give 'limits' (SI) or 'limits_deg', not both")
            return False, None
        key = "limits" if "limits" in f else "limits_deg" if "limits_deg" in f else None
        if key is None:
            return True, None
        node = f[key]
        if isinstance(node, ScalarNode) and scalar_value(node) is None:
            return True, None  # written out as null: unlimited
        if kind == "fixed":
            self.error(node, "a fixed joint does not move, so it has no limits")
            return False, None
        if key == "limits_deg" and kind not in ANGULAR_KINDS:
            self.error(node, f"'limits_deg' is for revolute and slew joints; a {kind} joint's limits are in metres")
            return False, None
        p = self.pair(node, key)
        if p is None:
            return False, None
        lo, hi = (math.radians(p[0]), math.radians(p[1])) if key == "limits_deg" else p
        if not lo < hi:
            self.error(node, f"limits are [lo, hi] with lo < hi (got [{p[0]:g}, {p[1]:g}])")
            return False, None
        return True, (lo, hi)

    def motor(self, node: Node, joint: str, kind: str) -> MotorSpec | None:
        f = self.fields(node, MOTOR_KEYS, f"the motor of '{joint}'")
        if f is None:
            return None
        angular = kind in ANGULAR_KINDS
        units = {"max_force": "N m" if angular else "N", "max_speed": "rad/s" if angular else "m/s",
                 "max_accel": "rad/s^2" if angular else "m/s^2"}
        values: dict[str, float | None] = {}
        ok = True
        for key in ("max_force", "max_speed"):
            if key not in f:
                self.error(node, f"the motor of '{joint}' needs '{key}' ({units[key]})")
                ok = False
        for key in ("max_force", "max_speed", "max_accel"):
            if key in f:
                values[key] = v = self.positive(f[key], f"{key} ({units[key]})")
                ok = ok and v is not None
        targets = set(TARGETS)
        if "targets" in f:
            t = f["targets"]
            if not isinstance(t, SequenceNode) or not t.value:
                self.error(t, "targets must be a list: [velocity], [position] or [velocity, position]")
                ok = False
            else:
                targets = set()
                for item in t.value:
                    n = self.name(item, "a target")
                    if n is not None and n not in TARGETS:
                        self.error(item, f"unknown target '{n}': velocity or position{did_you_mean(n, TARGETS)}")
                        ok = False
                    elif n is not None:
                        targets.add(n)
        force, speed = values.get("max_force"), values.get("max_speed")
        if not ok or force is None or speed is None:
            return None
        return MotorSpec(force, speed, values.get("max_accel"), "velocity" in targets, "position" in targets)

    def sensor(self, name: str, node: Node, bodies: dict[str, BodySpec]) -> ForceSensorSpec | None:
        f = self.fields(node, SENSOR_KEYS, f"force sensor '{name}'")
        if f is None:
            return None
        if "between" not in f:
            self.error(node, f"force sensor '{name}' needs 'between: [body, body]'")
            return None
        b = f["between"]
        if not isinstance(b, SequenceNode) or len(b.value) != 2:
            self.error(b, "between must be a list of 2 bodies")
            return None
        a, c = (self.body_ref(v, "between") for v in b.value)
        if a is None or c is None:
            return None
        if a == c:
            self.error(b.value[1], f"force sensor '{name}' must join two different bodies")
            return None
        anchors = None
        if "anchors" in f:
            n = f["anchors"]
            if not isinstance(n, SequenceNode) or len(n.value) != 2:
                self.error(n, "anchors must be a list of 2 points: [[x, z], [x, z]]")
                return None
            pa, pc = (self.pair(v, "an anchor") for v in n.value)
            if pa is None or pc is None:
                return None
            if pa == pc:
                self.error(n, "the two anchors must differ: the cable has a length")
                return None
            anchors = (pa, pc)
        elif a in bodies and c in bodies and bodies[a].center == bodies[c].center:
            self.error(node, f"'{a}' and '{c}' have the same centre; give 'anchors' for the cable's ends")
            return None
        return ForceSensorSpec(name, (a, c), anchors)

    def check_welds(self, bodies: dict[str, BodySpec], joints: list[JointSpec], node: Node | None) -> None:
        """Moving joints must join bodies that are not welded together, to a child that can move.

        ``fixed`` and ``slew`` joints weld bodies in the plane; a body welded to a static one
        is static itself.
        """
        if node is None or len(bodies) != len(self.declared):
            return  # a body is broken: its joints cannot be judged
        keys = {k.value: k for k, _ in node.value} if isinstance(node, MappingNode) else {}
        group_of = {n: k for k, names in enumerate(weld_groups(
            list(bodies), [(j.parent, j.child) for j in joints if j.kind in WELDING_KINDS])) for n in names}
        static = {group_of[n] for n, b in bodies.items() if b.static}
        for j in joints:
            if j.kind not in ("revolute", "prismatic") or bodies[j.child].static:
                continue
            if group_of[j.parent] == group_of[j.child]:
                self.error(keys[j.name], f"joint '{j.name}' joins '{j.parent}' and '{j.child}', which fixed or "
                                         f"slew joints already weld together")
            elif group_of[j.child] in static:
                self.error(keys[j.name], f"joint '{j.name}': '{j.child}' is welded to a static body, so it "
                                         f"cannot move")
