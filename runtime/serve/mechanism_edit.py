"""The stand-in's mechanism editing: ``labsim serve --empty`` reads a built mechanism back.

Where it sits: ``scene_edit.SceneEditor.handlers`` passes its handler table through
``MechanismEditor.wrap``, which answers the calls ``labsim scene`` makes for a world's
mechanism (``mechanism_builder``: joints, force sensors, masses, gravity, damping, matrices,
parents) and passes the rest on. When the editor rebuilds the simulation, ``mechanism``
turns what was built back into a ``Mechanism``, reading each part as ``mechanism_builder``'s
docstring says it is made:

* a cuboid or cylinder whose alias is none of the scene's own (``wall``, ``block``, the floor's,
  CoppeliaSim's defaults) is a body of that name, its centre and tilt from its matrix;
* a joint is a revolute joint (a slew when its axis is vertical), or prismatic; a prismatic
  joint held by a free revolute joint is a rope; its child is the shape it holds;
* a force sensor with a dummy under it is a force sensor (the dummy the cable's lower end);
  one without is a fixed joint;
* gravity is ``sim.arrayparam_gravity``'s z, the damping Bullet's linear damping read back
  (``-ln(1 - d)``).

Numbers are rounded to the nanometre (``scene_edit``'s rule), so a world file's ``0.6`` comes
back as ``0.6`` and the run gives the embedded backend's trace.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from labsim.backends.scene.mechanism import BodySpec, ForceSensorSpec, JointSpec, Mechanism, MotorSpec
from labsim.runtime.serve.built import primitive, rounded
from labsim.runtime.serve.sim_args import E_ARGS, E_FEW, Args, Handler, SimError, Wait
from labsim.runtime.serve.simulation import Client

# simConst.h names the stand-in adds to zmqRemoteApi.info (a client reads the values from there)
MECHANISM_CONSTANTS: dict[str, int] = {
    "joint_revolute_subtype": 10, "joint_prismatic_subtype": 11, "jointmode_dynamic": 5,
    "jointintparam_dynctrlmode": 2030, "jointdynctrl_free": 0, "jointdynctrl_velocity": 3,
    "jointfloatparam_maxvel": 2036, "jointfloatparam_maxaccel": 2037,
    "arrayparam_gravity": 0, "bullet_body_lineardamping": 2009, "bullet_body_angulardamping": 2010,
}
MECHANISM_CALLS = ("sim.createJoint", "sim.createForceSensor", "sim.setJointInterval", "sim.setJointTargetForce",
                   "sim.setObjectFloatParam", "sim.setShapeMass", "sim.setEngineFloatParam", "sim.setArrayParam")
WRAPPED = ("sim.createPrimitiveShape", "sim.setObjectAlias", "sim.setObjectMatrix", "sim.setObjectParent",
           "sim.setObjectInt32Param")
NOT_BODIES = {"wall", "block", "labsimFloor", "labsimGround", "Cuboid", "Cylinder", "Shape", "Plane"}


@dataclass(eq=False)
class _Part:
    """A joint or force sensor built through the remote API."""

    kind: str  # joint | force
    subtype: int = 0  # a joint's type
    alias: str = ""
    matrix: list[float] = field(default_factory=list)
    free: bool = True  # a joint's control mode is free (passive)
    cyclic: bool = True
    interval: tuple[float, float] = (0.0, 0.0)  # min, range
    force: float = 0.0
    maxvel: float = 0.0
    maxaccel: float | None = None


class MechanismEditor:
    """Parts of a mechanism being built; ``editor`` is the ``scene_edit.SceneEditor``."""

    def __init__(self, editor: Any) -> None:
        self.editor = editor
        self.parts: dict[int, _Part] = {}
        self.parents: dict[int, int] = {}  # object -> parent, for shapes, parts and dummies
        self.tilts: dict[int, tuple[float, float, float]] = {}  # a shape's z axis
        self.ends: dict[int, tuple[float, float]] = {}  # a dummy's place in the plane
        self.masses: dict[int, float] = {}
        self.gravity = 9.81
        self.damping = 0.0

    def wrap(self, funcs: dict[str, Handler]) -> dict[str, Handler]:
        out = dict(funcs)
        for name in MECHANISM_CALLS:
            out[name] = self._edit(getattr(self, "_" + name.removeprefix("sim.")))
        for name in WRAPPED:
            mine, inner = getattr(self, "_own_" + name.removeprefix("sim.")), funcs[name]
            out[name] = self._first(mine, inner)
        return out

    def _edit(self, handler: Callable[[Args], list[object]]) -> Handler:
        def call(client: Client, args: Args) -> list[object]:
            self.editor._stopped()
            ret = handler(args)
            self.editor.dirty = True
            return ret
        return call

    def _first(self, mine: Callable[[Args], list[object] | None], inner: Handler) -> Handler:
        def call(client: Client, args: Args) -> list[object] | Wait:
            ret = mine(args)
            if ret is None:
                return inner(client, args)
            self.editor.dirty = True
            return ret
        return call

    def _part(self, args: Args, n: int) -> _Part:
        if len(args) < n:
            raise SimError(E_FEW)
        part = self.parts.get(args[0]) if isinstance(args[0], int) else None
        if part is None:
            raise SimError("labsim serve: that call is taken only by a built joint or force sensor")
        return part

    # --- the mechanism's calls -----------------------------------------------------------------

    def _createJoint(self, args: Args) -> list[object]:
        self._no_robots()
        if len(args) < 2 or args[0] not in (10, 11):
            raise SimError("labsim serve: the stand-in builds revolute and prismatic joints")
        h = self.editor._handle()
        self.parts[h] = _Part("joint", subtype=int(args[0]))
        return [h]

    def _createForceSensor(self, args: Args) -> list[object]:
        self._no_robots()
        h = self.editor._handle()
        self.parts[h] = _Part("force")
        return [h]

    def _no_robots(self) -> None:
        if self.editor.robots:
            raise SimError("labsim serve: this scene holds robots; a labsim world has either robots or a "
                           "mechanism, so it takes no joints or force sensors (build them in an empty scene)")

    def _setJointInterval(self, args: Args) -> list[object]:
        part = self._part(args, 3)
        part.cyclic = bool(args[1])
        lo, span = floats(args[2], 2)
        part.interval = (lo, span)
        return []

    def _setJointTargetForce(self, args: Args) -> list[object]:
        self._part(args, 2).force = floats(args[1:2], 1)[0]
        return []

    def _setObjectFloatParam(self, args: Args) -> list[object]:
        part = self._part(args, 3)
        value = floats(args[2:3], 1)[0]
        if args[1] == MECHANISM_CONSTANTS["jointfloatparam_maxvel"]:
            part.maxvel = value
        elif args[1] == MECHANISM_CONSTANTS["jointfloatparam_maxaccel"]:
            part.maxaccel = value
        return []

    def _setShapeMass(self, args: Args) -> list[object]:
        if len(args) < 2 or args[0] not in self.editor.shapes:
            raise SimError(E_FEW if len(args) < 2 else "labsim serve: only a built shape takes a mass")
        self.masses[args[0]] = floats(args[1:2], 1)[0]
        return []

    def _setEngineFloatParam(self, args: Args) -> list[object]:
        if len(args) < 3:
            raise SimError(E_FEW)
        if args[0] == MECHANISM_CONSTANTS["bullet_body_lineardamping"]:
            self.damping = -math.log1p(-floats(args[2:3], 1)[0])
        return []

    def _setArrayParam(self, args: Args) -> list[object]:
        if len(args) < 2 or args[0] != MECHANISM_CONSTANTS["arrayparam_gravity"]:
            raise SimError("labsim serve: only sim.arrayparam_gravity is set by the stand-in")
        self.gravity = -floats(args[1], 3)[2]
        return []

    # --- calls the scene editor also takes -----------------------------------------------------

    def _own_createPrimitiveShape(self, args: Args) -> list[object] | None:
        if len(args) < 2 or args[0] != 5:  # sim.primitiveshape_cylinder; the rest is the editor's
            return None
        sizes = floats(args[1], 3)
        return list(self.editor._new(primitive("cylinder", sizes, args, "Cylinder")))

    def _own_setObjectAlias(self, args: Args) -> list[object] | None:
        part = self.parts.get(args[0]) if args and isinstance(args[0], int) else None
        if part is None:
            return None
        if len(args) < 2 or not isinstance(args[1], str):
            raise SimError(E_ARGS)
        part.alias = args[1]
        return []

    def _own_setObjectMatrix(self, args: Args) -> list[object] | None:
        h = args[0] if args and isinstance(args[0], int) else None
        dummy = h in self.editor.script_host.dummies
        if h is None or not (h in self.parts or h in self.editor.shapes or dummy):
            return None
        if len(args) < 3:
            raise SimError(E_FEW)
        if args[2] != -1:
            raise SimError("labsim serve: a mechanism's parts are placed in the world frame")
        m = floats(args[1], 12)
        if h in self.parts:
            self.parts[h].matrix = m
        elif dummy:
            self.ends[h] = (m[3], m[11])
        else:
            shape = self.editor.shapes[h]
            shape.x, shape.y, shape.z = m[3], m[7], m[11]
            self.tilts[h] = (m[2], m[6], m[10])
        return []

    def _own_setObjectParent(self, args: Args) -> list[object] | None:
        if len(args) < 2 or not isinstance(args[0], int):
            return None
        h, parent = args[0], args[1]
        ours = self.parts.keys() | self.editor.script_host.dummies.keys()
        if h in ours or parent in self.parts or (h in self.editor.shapes and parent in self.editor.shapes):
            self.parents[h] = parent
            return []
        return None

    def _own_setObjectInt32Param(self, args: Args) -> list[object] | None:
        part = self.parts.get(args[0]) if args and isinstance(args[0], int) else None
        if part is None:
            return None
        if len(args) < 3:
            raise SimError(E_FEW)
        if args[1] == MECHANISM_CONSTANTS["jointintparam_dynctrlmode"]:
            part.free = args[2] == MECHANISM_CONSTANTS["jointdynctrl_free"]
        return []

    # --- reading it back -----------------------------------------------------------------------

    def bodies(self) -> dict[int, str]:
        """Handle -> name of every shape that is a mechanism's body."""
        if self.editor.robots:  # a scene with robots has no mechanism: its shapes are obstacles
            return {}
        return {h: s.alias for h, s in self.editor.shapes.items()
                if s.kind in ("cuboid", "cylinder") and s.alias not in NOT_BODIES}

    def handles(self) -> dict[str, int]:
        """Name -> the handle each body, joint and force sensor was built with."""
        out = {name: h for h, name in self.bodies().items()}
        out.update({part.alias: h for h, part in self.parts.items() if part.alias})
        return out

    def mechanism(self, floor_z: float | None) -> Mechanism | None:
        """The mechanism built so far, or None when no body was; ``floor_z`` the floor plane's height."""
        names = self.bodies()
        if not names:
            return None
        bodies = tuple(self._body(h, name) for h, name in names.items())
        joints: list[JointSpec] = []
        sensors: list[ForceSensorSpec] = []
        for h in sorted(self.parts):
            part = self.parts[h]
            child = next((c for c, p in self.parents.items() if p == h and c in names), None)
            if child is None or h not in self.parents:
                continue  # a rope's swing joint (it holds a joint, not a body), or a loose part
            if part.kind == "force":
                self._force(h, part, names, child, joints, sensors)
            else:
                joints.append(self._joint(h, part, names, child))
        return Mechanism(bodies, tuple(joints), tuple(sensors), rounded(self.gravity), rounded(self.damping),
                         None if floor_z is None else rounded(floor_z))

    def _body(self, h: int, name: str) -> BodySpec:
        s = self.editor.shapes[h]
        zx, _, zz = self.tilts.get(h, (0.0, 0.0, 1.0))
        mass = None if s.static else self.masses.get(h)
        return BodySpec(name, "box" if s.kind == "cuboid" else "cylinder", (rounded(s.x), rounded(s.z)),
                        (rounded(s.size[0]), rounded(s.size[2])), mass_kg=mass, static=s.static,
                        depth_m=rounded(s.size[1]) if s.kind == "cuboid" else None,
                        angle_rad=rounded(math.atan2(-zx, zz)))

    def _force(self, h: int, part: _Part, names: dict[int, str], child: int,
               joints: list[JointSpec], sensors: list[ForceSensorSpec]) -> None:
        parent = names.get(self.parents[h], "")
        end = next((d for d, p in self.parents.items() if p == h and d in self.ends), None)
        if end is None:
            joints.append(JointSpec(part.alias, "fixed", parent, names[child]))
            return
        m, (ex, ez) = part.matrix, self.ends[end]
        sensors.append(ForceSensorSpec(part.alias, (parent, names[child]),
                                       ((rounded(m[3]), rounded(m[11])), (rounded(ex), rounded(ez)))))

    def _joint(self, h: int, part: _Part, names: dict[int, str], child: int) -> JointSpec:
        parent, rope = self.parents[h], False
        holder = self.parts.get(parent)
        if holder is not None and holder.kind == "joint" and holder.free:
            parent, rope = self.parents.get(parent, -1), True  # a rope hangs from a free swing joint
        m = part.matrix or [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        zx, zz = m[2], m[10]
        if part.subtype == MECHANISM_CONSTANTS["joint_prismatic_subtype"]:
            kind, axis = "prismatic", (1.0, 0.0) if rope else (rounded(zx), rounded(zz))
        else:
            kind, axis = "slew" if abs(zz) > 0.5 else "revolute", (1.0, 0.0)
        lo, span = part.interval
        limits = None if part.cyclic else (rounded(lo), rounded(lo + span))
        motor = None if part.free else MotorSpec(part.force, part.maxvel, part.maxaccel)
        return JointSpec(part.alias, kind, names.get(parent, ""), names[child], (rounded(m[3]), rounded(m[11])),
                         axis, limits, motor, rope)


def floats(value: object, n: int) -> list[float]:
    """The first n numbers of a request's list argument, as floats; else CoppeliaSim's error."""
    if not isinstance(value, list) or len(value) < n or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) for v in value[:n]):
        raise SimError(E_ARGS)
    return [float(v) for v in value[:n]]
