"""``labsim scene`` for a world's mechanism (the tower crane): bodies, joints and force sensors.

Where it sits: ``scene_builder.build`` hands a world's ``Mechanism`` to ``build_mechanism``,
which makes it in CoppeliaSim through the backend's ``connection.Connection``, every call one
CoppeliaSim 4.6 documents (cited at each). ``labsim serve --empty`` reads the same calls back
into a ``Mechanism`` (``mechanism_edit``), so the crane's run in a built scene gives the
embedded backend's trace.

The mechanism's vertical plane (labsim: x along, z up) is CoppeliaSim's plane y = 0, before
the slew turns it. What each part becomes:

* a body: a primitive shape (a box a cuboid ``[w, depth, h]``, an upright cylinder a cylinder
  ``[d, d, h]``) at its centre, aliased with its name; static ones static, moving ones dynamic
  with their mass (``sim.setShapeMass``); a body tilted in the plane gets its matrix;
* a joint: ``sim.createJoint`` in dynamic mode between its parent and child (the parent body
  holds the joint, the joint holds the child), its z axis the joint's axis: a slew joint the
  vertical, a revolute joint across the plane (-y), a prismatic joint its rail; a motorised
  joint's control mode is velocity, its maximum force, speed and acceleration set, a passive
  one free; limits from ``sim.setJointInterval`` (a joint without limits is cyclic);
* a rope (a winch, ``rope: true``): a passive revolute joint ``<name>Swing`` at the anchor, so
  that the load can swing, holding the prismatic joint along -z (the rope's length);
* a fixed joint: a force sensor (CoppeliaSim's rigid link between two dynamic shapes) aliased
  with the joint's name, at the child's centre;
* a force sensor: a force sensor at its first anchor on the first body, holding the second
  body, and a dummy ``<name>End`` at its second anchor (the cable's lower end: labsim's sensor
  is a cable of that length);
* gravity (``sim.setArrayParam(sim.arrayparam_gravity, ...)``) and the damping of every moving
  body (Bullet's linear and angular damping, ``1 - exp(-damping)``: Bullet scales velocities
  by ``(1 - d)`` per second).
"""
from __future__ import annotations

import math

from labsim.backends.coppeliasim.connection import Connection
from labsim.backends.scene.mechanism import BodySpec, ForceSensorSpec, JointSpec, Mechanism


def build_mechanism(conn: Connection, mech: Mechanism) -> str:
    """Build ``mech`` in the CoppeliaSim ``conn`` reaches (stopped); a line saying what was built."""
    sim = conn.sim
    # sim.setArrayParam(int parameter, list arrayOfValues): CoppeliaSim 4.6
    conn.call("sim.setArrayParam", sim.arrayparam_gravity, [0.0, 0.0, -mech.gravity_m_s2])
    bodies = {b.name: _body(conn, b, mech.damping_1_s) for b in mech.bodies}
    for j in mech.joints:
        _joint(conn, j, bodies, mech)
    for f in mech.force_sensors:
        _force_sensor(conn, f, bodies, mech)
    return (f"labsim scene: the mechanism, {len(mech.bodies)} bodies, {len(mech.joints)} joints and "
            f"{len(mech.force_sensors)} force sensors")


def _body(conn: Connection, b: BodySpec, damping_1_s: float) -> int:
    sim = conn.sim
    w, h = b.size
    if b.shape == "cylinder":
        kind, sizes = sim.primitiveshape_cylinder, [w, w, h]
    else:
        kind, sizes = sim.primitiveshape_cuboid, [w, b.depth_m if b.depth_m is not None else w, h]
    # sim.createPrimitiveShape(int primitiveType, list sizes, int options = 0): CoppeliaSim 4.6
    shape = int(conn.call("sim.createPrimitiveShape", kind, sizes, 0))
    conn.call("sim.setObjectAlias", shape, b.name)  # sim.setObjectAlias(int objectHandle, string alias): 4.6
    # sim.setObjectInt32Param(int objectHandle, int parameterID, int parameter): CoppeliaSim 4.6
    conn.call("sim.setObjectInt32Param", shape, sim.shapeintparam_static, int(b.static))
    conn.call("sim.setObjectInt32Param", shape, sim.shapeintparam_respondable, 1)
    if not b.static:
        conn.call("sim.setShapeMass", shape, b.mass)  # sim.setShapeMass(int shapeHandle, float mass): 4.6
        d = 1.0 - math.exp(-damping_1_s)
        # sim.setEngineFloatParam(int paramId, int objectHandle, float val): CoppeliaSim 4.6
        conn.call("sim.setEngineFloatParam", sim.bullet_body_lineardamping, shape, d)
        conn.call("sim.setEngineFloatParam", sim.bullet_body_angulardamping, shape, d)
    cx, cz = b.center
    conn.call("sim.setObjectMatrix", shape, _matrix((cx, cz), _tilt(b.angle_rad)), conn.world_h)
    return shape


def _tilt(theta: float) -> tuple[float, float, float]:
    """The body's z axis once tilted by ``theta`` in the plane (counter-clockwise from x toward z)."""
    return (-math.sin(theta), 0.0, math.cos(theta))


def _matrix(at: tuple[float, float], z_axis: tuple[float, float, float]) -> list[float]:
    """CoppeliaSim's 12-number matrix (rows of [x y z | position]) at plane point ``at`` with
    ``z_axis``; y is the plane's normal (0, 1, 0) unless z is along it, and x = y x z."""
    zx, zy, zz = z_axis
    y = (0.0, 0.0, 1.0) if abs(zy) > 0.5 else (0.0, 1.0, 0.0)  # z across the plane: y up
    x = (y[1] * zz - y[2] * zy, y[2] * zx - y[0] * zz, y[0] * zy - y[1] * zx)
    pos = (at[0], 0.0, at[1])
    return [v for row in range(3) for v in (x[row], y[row], z_axis[row], pos[row])]


def _new_joint(conn: Connection, kind: int, alias: str, at: tuple[float, float],
               axis: tuple[float, float, float], parent: int) -> int:
    sim = conn.sim
    # sim.createJoint(int jointType, int jointMode, int options, list sizes = nil): CoppeliaSim 4.6
    h = int(conn.call("sim.createJoint", kind, sim.jointmode_dynamic, 0, [0.15, 0.02]))
    conn.call("sim.setObjectAlias", h, alias)
    conn.call("sim.setObjectMatrix", h, _matrix(at, axis), conn.world_h)  # (handle, matrix, relativeTo): 4.6
    conn.call("sim.setObjectParent", h, parent, True)  # (int objectHandle, int parent, bool keepInPlace): 4.6
    return h


def _joint(conn: Connection, j: JointSpec, bodies: dict[str, int], mech: Mechanism) -> None:
    sim = conn.sim
    parent, child = bodies[j.parent], bodies[j.child]
    if j.kind == "fixed":  # a force sensor is CoppeliaSim's rigid link between dynamic shapes
        held = _force(conn, j.name, mech.body(j.child).center, parent)
        conn.call("sim.setObjectParent", child, held, True)
        return
    if j.kind == "prismatic" and j.rope:
        swing = _new_joint(conn, sim.joint_revolute_subtype, f"{j.name}Swing", j.anchor, (0.0, -1.0, 0.0), parent)
        _mode(conn, swing, free=True)
        conn.call("sim.setJointInterval", swing, True, [-math.pi, 2 * math.pi])
        h = _new_joint(conn, sim.joint_prismatic_subtype, j.name, j.anchor, (0.0, 0.0, -1.0), swing)
    elif j.kind == "prismatic":
        h = _new_joint(conn, sim.joint_prismatic_subtype, j.name, j.anchor, (j.axis[0], 0.0, j.axis[1]), parent)
    else:  # a slew turns about the vertical, a revolute joint about -y (counter-clockwise in the plane)
        axis = (0.0, 0.0, 1.0) if j.kind == "slew" else (0.0, -1.0, 0.0)
        h = _new_joint(conn, sim.joint_revolute_subtype, j.name, j.anchor, axis, parent)
    _mode(conn, h, free=j.motor is None)
    if j.limits is None:
        conn.call("sim.setJointInterval", h, True, [-math.pi, 2 * math.pi])
    else:  # sim.setJointInterval(int objectHandle, bool cyclic, list interval [min, range]): 4.6
        lo, hi = j.limits
        conn.call("sim.setJointInterval", h, False, [lo, hi - lo])
    m = j.motor
    if m is not None:
        conn.call("sim.setJointTargetForce", h, m.max_force)  # (int objectHandle, float forceOrTorque): 4.6
        # sim.setObjectFloatParam(int objectHandle, int parameterID, float parameter): 4.6;
        # the joint's motion limits (its controller's maximum velocity and acceleration)
        conn.call("sim.setObjectFloatParam", h, sim.jointfloatparam_maxvel, m.max_speed)
        if m.max_accel is not None:
            conn.call("sim.setObjectFloatParam", h, sim.jointfloatparam_maxaccel, m.max_accel)
    conn.call("sim.setObjectParent", child, h, True)


def _mode(conn: Connection, h: int, free: bool) -> None:
    sim = conn.sim
    # sim.setObjectInt32Param(h, sim.jointintparam_dynctrlmode, ...): CoppeliaSim 4.6
    conn.call("sim.setObjectInt32Param", h, sim.jointintparam_dynctrlmode,
              sim.jointdynctrl_free if free else sim.jointdynctrl_velocity)


def _force(conn: Connection, alias: str, at: tuple[float, float], parent: int) -> int:
    # sim.createForceSensor(int options, list intParams, list floatParams): CoppeliaSim 4.6;
    # intParams: filter type, filter size, consecutive violations; floatParams: size, force and
    # torque thresholds (none)
    h = int(conn.call("sim.createForceSensor", 0, [0, 1, 1, 0, 0], [0.05, 0.0, 0.0, 0.0, 0.0]))
    conn.call("sim.setObjectAlias", h, alias)
    conn.call("sim.setObjectMatrix", h, _matrix(at, (0.0, 0.0, 1.0)), conn.world_h)
    conn.call("sim.setObjectParent", h, parent, True)
    return h


def _force_sensor(conn: Connection, f: ForceSensorSpec, bodies: dict[str, int], mech: Mechanism) -> None:
    first, second = (mech.body(n) for n in f.between)
    top, bottom = f.anchors if f.anchors is not None else (first.center, second.center)
    h = _force(conn, f.name, top, bodies[first.name])
    conn.call("sim.setObjectParent", bodies[second.name], h, True)
    end = int(conn.call("sim.createDummy", 0.02))  # sim.createDummy(float size): CoppeliaSim 4.6
    conn.call("sim.setObjectAlias", end, f"{f.name}End")
    conn.call("sim.setObjectMatrix", end, _matrix(bottom, (0.0, 0.0, 1.0)), conn.world_h)
    conn.call("sim.setObjectParent", end, h, True)
