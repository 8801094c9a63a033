"""The stand-in's objects beyond the lab: dummies, 3D poses, the tree, parents, removal, colour.

Where it sits: ``server.Server`` answers the calls listed in ``OBJECT_CALLS`` here, before the
simulation's (``sim_api``) or the scene editor's (``scene_edit``, ``--empty``) handlers, which
it reaches through ``Host.base_handlers()`` for every object this module does not own. What
scripts and CoppeliaSim's own examples do with objects that are not a lab's: create dummies
(``sim.createDummy``) and place them anywhere in 3D (they have no physics), read any object's
pose as a matrix or a quaternion, build matrices, list a tree, parent, remove, colour.

Flat-world answers (docs/coppeliasim.md, the compatibility table): a robot, its sensors and a
mechanism's parts keep the poses labsim's 2D simulation gives them, so their matrices and
quaternions are those of those poses; a robot's parts stay mounted where its model puts them
(moving one is refused, naming the call that moves the robot); removing a robot or a
mechanism's part is refused (``sim.loadScene`` starts a scene afresh); a colour is kept and
changes nothing a camera sees. A dummy parented to an object keeps its world pose from then on
(it does not ride along with a moving robot).
"""
from __future__ import annotations

import contextlib
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from labsim.backends.coppeliasim import HANDLE_ALL, HANDLE_PARENT, HANDLE_WORLD, STOPPED
from labsim.backends.coppeliasim.fleet_script import ALIAS as FLEET_ALIAS
from labsim.runtime.serve import matrices as mx
from labsim.runtime.serve.scene_tree import glob_match
from labsim.runtime.serve.sim_args import E_ARGS, E_FEW, E_HANDLE, Args, Handler, SimError, Wait, as_handle
from labsim.runtime.serve.simulation import Client, Simulation

DUMMY_BASE = 2_000_000  # a dummy's handle when no scene editor hands one out
HANDLE_MASK = 0x003FFFFF  # simConst.h sim_handleflag_handlemask: a handle without its flags
WXYZ = 0x01000000  # sim_handleflag_wxyzquat (32-bit handles, CoppeliaSim 4.6)
HANDLE_SCENE = -12

# simConst.h (sceneobject_*, 4.8's names, and the object_*_type names 4.6 used for them)
TYPES = {"shape": 0, "joint": 1, "dummy": 4, "proximitysensor": 5, "visionsensor": 9, "forcesensor": 12}
OBJECT_CONSTANTS: dict[str, int] = {
    **{f"sceneobject_{k}": v for k, v in TYPES.items()},
    **{f"object_{k}_type": v for k, v in TYPES.items()},
    "handle_tree": -6, "handleflag_wxyzquat": WXYZ, "colorcomponent_ambient_diffuse": 0,
    "colorcomponent_ambient": 0, "colorcomponent_diffuse": 1, "colorcomponent_specular": 2,
    "colorcomponent_emission": 3, "colorcomponent_transparency": 4, "colorcomponent_auxiliary": 5,
}
_KIND_TYPE = {"robot": 0, "body": 0, "motor": 1, "joint": 1, "sonar": 5, "camera": 9, "force": 12}
OBJECT_CALLS = tuple(f"sim.{n}" for n in (
    "createDummy", "getObject", "getObjectAlias", "setObjectAlias", "getObjectParent", "setObjectParent",
    "getObjectPosition", "getObjectOrientation", "getObjectPose", "getObjectQuaternion", "getObjectMatrix",
    "setObjectPosition", "setObjectOrientation", "setObjectPose", "setObjectQuaternion", "setObjectMatrix",
    "buildMatrix", "getObjectsInTree", "getObjectChild", "removeObject", "removeObjects", "setShapeColor",
))



def call_base(server: Any, name: str, client: Client, args: Args) -> list[object]:
    """A call answered by the stand-in's base handlers (``sim_api``), under a session's or the
    objects' own wrapper of the same name."""
    handler = server.base_handlers().get(name)
    if handler is None:
        raise SimError(E_HANDLE)
    ret = handler(client, args)
    assert not isinstance(ret, Wait)
    return ret

class Host(Protocol):
    """What the object calls need of the server (``server.Server``)."""

    simulation: Simulation
    editor: Any  # scene_edit.SceneEditor in --empty, else None

    def base_handlers(self) -> dict[str, Handler]: ...


@dataclass(eq=False)
class Dummy:
    """A dummy a client made: a frame in the world, nothing else."""

    alias: str = "Dummy"  # CoppeliaSim 4.6's default; 4.8 says "dummy" (both are answered)
    matrix: list[float] = field(default_factory=lambda: list(mx.IDENTITY))
    parent: int = -1


def _number_list(value: object, n: int) -> list[float]:
    # finite numbers only: an angle of inf has no sine, a position of inf no place (the type
    # error, as every other handler answers a non-finite coordinate)
    if not isinstance(value, (list, tuple)) or len(value) < n or not all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in value[:n]):
        raise SimError(E_ARGS)
    return [float(v) for v in value[:n]]


def _handle(args: Args, i: int = 0) -> int:
    if len(args) <= i:
        raise SimError(E_FEW)
    return as_handle(args[i])


class ObjectCalls:
    """Dummies and colours of the scene, and the handlers of ``OBJECT_CALLS`` (``handlers()``)."""

    def __init__(self, server: Host) -> None:
        self.server = server
        self.dummies: dict[int, Dummy] = {}
        self.colours: dict[int, list[float]] = {}
        self._next = DUMMY_BASE

    def handlers(self) -> dict[str, Handler]:
        return {name: getattr(self, "_" + name.removeprefix("sim.")) for name in OBJECT_CALLS}

    def clear(self) -> None:
        """A new scene (sim.loadScene, sim.closeScene): no dummies, no colours."""
        self.dummies.clear()
        self.colours.clear()

    def _inner(self, name: str, client: Client, args: Args) -> list[object]:
        return call_base(self.server, name, client, args)

    # --- dummies -----------------------------------------------------------------------------

    def _createDummy(self, client: Client, args: Args) -> list[object]:
        # sim.createDummy(float size): CoppeliaSim 4.6 (older scripts add a 12-colour list, ignored)
        if not args or not isinstance(args[0], (int, float)) or isinstance(args[0], bool):
            raise SimError(E_FEW if not args else E_ARGS)
        if "sim.createDummy" in self.server.base_handlers() and self.server.simulation.state == STOPPED:
            # --empty: the scene editor's own, which the fleet script and a mechanism's cable end need
            h = int(self._inner("sim.createDummy", client, args[:1])[0])  # type: ignore[call-overload]
        else:
            h, self._next = self._next, self._next + 1
        self.dummies[h] = Dummy()
        return [h]

    def _dummy(self, args: Args, i: int = 0) -> Dummy | None:
        return self.dummies.get(_handle(args, i) & HANDLE_MASK)

    def _getObject(self, client: Client, args: Args) -> list[object]:
        try:
            ret = self._inner("sim.getObject", client, args)
        except SimError:
            found = self._find(args)
            if found is None:
                raise
            return [found]
        if ret == [-1]:
            return [self._find(args) or -1]
        return ret

    def _find(self, args: Args) -> int | None:
        """A top-level dummy's handle by ``/alias`` or ``/alias[n]``; None when there is none."""
        path = args[0] if args and isinstance(args[0], str) else ""
        if not path.startswith("/") or "/" in path[1:]:
            return None
        name, n = path[1:], 0
        if name.endswith("]") and "[" in name:
            name, index = name[:-1].split("[", 1)
            if not index.isdigit() or len(index) > 9:
                return None
            n = int(index)
        # the fleet script's dummy is found only while it carries labsim's script (script_host),
        # which the backend takes the fast path on
        found = [h for h, d in self.dummies.items() if d.parent == -1 and d.alias != FLEET_ALIAS and (
            glob_match(name, d.alias) or (d.alias == "Dummy" and name == "dummy"))]
        return found[n] if n < len(found) else None

    def _getObjectAlias(self, client: Client, args: Args) -> list[object]:
        d = self._dummy(args)
        if d is None:
            return self._inner("sim.getObjectAlias", client, args)
        option = args[1] if len(args) > 1 and isinstance(args[1], int) else -1
        return [d.alias if option == -1 else f"/{d.alias}" if option in (1, 2, 5) else d.alias]

    def _setObjectAlias(self, client: Client, args: Args) -> list[object]:
        d = self._dummy(args)
        if d is None:
            return self._inner("sim.setObjectAlias", client, args)
        if len(args) < 2 or not isinstance(args[1], str) or not args[1]:
            raise SimError(E_ARGS)
        d.alias = args[1]
        if "sim.setObjectAlias" in self.server.base_handlers() and self.server.editor is not None:
            self._inner("sim.setObjectAlias", client, args)  # the fleet script's dummy is found by it
        return []

    def _getObjectParent(self, client: Client, args: Args) -> list[object]:
        d = self._dummy(args)
        return [d.parent] if d is not None else self._inner("sim.getObjectParent", client, args)

    def _setObjectParent(self, client: Client, args: Args) -> list[object]:
        # sim.setObjectParent(int objectHandle, int parentObjectHandle, bool keepInPlace): 4.6
        d = self._dummy(args)
        if d is None:
            if "sim.setObjectParent" in self.server.base_handlers():
                return self._inner("sim.setObjectParent", client, args)
            raise SimError("labsim serve: a robot's parts stay where its model mounts them; parent dummies "
                           "(sim.createDummy) to them instead")
        parent = _handle(args, 1)
        taken = self._also_inner("sim.setObjectParent", client, args)  # --empty: a cable end, the fleet's
        if parent != -1:
            try:
                world = self._world(client, parent)
            except SimError:
                if not taken:  # no such object
                    raise
                world = mx.IDENTITY  # a mechanism's part being built: it has no pose yet
            if not (len(args) > 2 and args[2]):  # keep the local pose: it was relative to the world
                d.matrix = mx.times(world, d.matrix)
        d.parent = parent
        return []

    def _also_inner(self, name: str, client: Client, args: Args) -> bool:
        """In --empty, tell the scene editor too: a dummy may be the fleet script's or a
        mechanism's cable end (mechanism_edit reads those from their matrix and parent).
        Whether the editor took it (a dummy of the client's own it does not know)."""
        if self.server.editor is not None and name in self.server.base_handlers():
            with contextlib.suppress(SimError):
                self._inner(name, client, args)
                return True
        return False

    def _removeObject(self, client: Client, args: Args) -> list[object]:
        h = _handle(args)
        if self.dummies.pop(h, None) is not None:
            self._forget(h)
            return []
        editor = self.server.editor
        if editor is not None and h in editor.shapes:
            del editor.shapes[h]  # an obstacle of --empty's scene: gone from the next start
            editor.dirty = True
            return []
        if h in self.server.simulation.tree.objects:
            raise SimError("labsim serve: a robot, its parts and a mechanism's parts cannot be taken out of "
                           "labsim's simulation; sim.loadScene gives the lab's scene afresh")
        raise SimError(E_HANDLE)

    def _removeObjects(self, client: Client, args: Args) -> list[object]:
        if not args or not isinstance(args[0], list):
            raise SimError(E_FEW if not args else E_ARGS)
        for h in args[0]:
            self._removeObject(client, [h])
        return []

    def _forget(self, h: int) -> None:
        self.colours.pop(h, None)
        for d in self.dummies.values():
            if d.parent == h:
                d.parent = -1

    def _setShapeColor(self, client: Client, args: Args) -> list[object]:
        # sim.setShapeColor(int shapeHandle, string colorName, int colorComponent, list rgbData): 4.6
        if len(args) < 4:
            raise SimError(E_FEW)
        h = _handle(args)
        if h in self.dummies:
            raise SimError("object is not a shape.")
        self._world(None, h)  # it exists, or CoppeliaSim's error
        transparency = args[2] == OBJECT_CONSTANTS["colorcomponent_transparency"]  # one number, not three
        self.colours[h] = _number_list(args[3], 1 if transparency else 3)
        return []

    # --- poses -------------------------------------------------------------------------------

    def _world(self, client: Client | None, h: int) -> list[float]:
        """The world matrix of any object: a dummy's own, else the simulation's pose of it."""
        d = self.dummies.get(h)
        if d is not None:
            return d.matrix
        editor = self.server.editor
        if editor is not None and h in editor.shapes and h not in self.server.simulation.tree.objects:
            s = editor.shapes[h]  # a wall, block or floor: where it was built (a body moves: below)
            return mx.from_euler((s.x, s.y, s.z), (0.0, 0.0, s.yaw))
        handler = self.server.base_handlers()["sim.getObjectPose"]
        ret = handler(client or _NOBODY, [h, HANDLE_WORLD])
        assert isinstance(ret, list)
        return mx.from_pose(ret[0])  # type: ignore[arg-type]

    def _relative(self, client: Client, args: Args) -> tuple[int, list[float]]:
        """(handle, its matrix in the frame args[1] names: the world, its parent, or an object)."""
        h = _handle(args) & HANDLE_MASK
        rel = args[1] if len(args) > 1 and args[1] is not None else HANDLE_WORLD
        if not isinstance(rel, int) or isinstance(rel, bool):
            raise SimError(E_ARGS)
        m = self._world(client, h)
        if rel == HANDLE_PARENT:
            d = self.dummies.get(h)
            rel = d.parent if d is not None else HANDLE_WORLD
        return h, m if rel == HANDLE_WORLD else mx.seen_from(m, self._world(client, rel))

    def _own(self, args: Args) -> bool:
        """Whether this module answers a pose call: for a dummy, or relative to one."""
        rel = args[1] if len(args) > 1 and isinstance(args[1], int) else HANDLE_WORLD
        return self._dummy(args) is not None or rel in self.dummies

    def _getObjectPosition(self, client: Client, args: Args) -> list[object]:
        if not self._own(args):
            return self._inner("sim.getObjectPosition", client, args)
        m = self._relative(client, args)[1]
        return [[m[3], m[7], m[11]]]

    def _getObjectOrientation(self, client: Client, args: Args) -> list[object]:
        if not self._own(args):
            return self._inner("sim.getObjectOrientation", client, args)
        return [mx.euler(self._relative(client, args)[1])]

    def _getObjectPose(self, client: Client, args: Args) -> list[object]:
        if not self._own(args):
            return self._inner("sim.getObjectPose", client, args)
        return [mx.pose(self._relative(client, args)[1])]

    def _getObjectMatrix(self, client: Client, args: Args) -> list[object]:
        return [self._relative(client, args)[1]]

    def _getObjectQuaternion(self, client: Client, args: Args) -> list[object]:
        q = mx.quaternion(self._relative(client, args)[1])
        return [[q[3], *q[:3]] if _handle(args) & WXYZ else q]

    def _buildMatrix(self, client: Client, args: Args) -> list[object]:
        if len(args) < 2:
            raise SimError(E_FEW)
        return [mx.from_euler(_number_list(args[0], 3), _number_list(args[1], 3))]

    def _set(self, name: str, client: Client, args: Args, to_matrix: Callable[[list[float], Any], list[float]],
             n: int) -> list[object]:
        """A set-pose call: a dummy takes any 3D pose; anything else goes to the simulation as
        sim.setObjectPose (a flat robot, placed while stopped) or to the scene editor."""
        if len(args) < 2:
            raise SimError(E_FEW)
        # (h, value, frame) since CoppeliaSim 4.5, (h, frame, value) before
        old = isinstance(args[1], int) and not isinstance(args[1], bool) and len(args) > 2
        value, rel = (args[2], args[1]) if old else (args[1], args[2] if len(args) > 2 else HANDLE_WORLD)
        rel = HANDLE_WORLD if rel is None else rel
        d = self._dummy(args)
        if d is None:
            if name in self.server.base_handlers():
                try:
                    return self._inner(name, client, args)
                except SimError:
                    if self.server.simulation.tree.objects.get(_handle(args)) is None:
                        raise  # not a robot: the editor's or the simulation's error stands
            h = _handle(args)
            current = self._world(client, h)
            m = to_matrix(_number_list(value, n), current)
            return self._inner("sim.setObjectPose", client, [h, mx.pose(m), rel])
        self._also_inner(name, client, args)
        if not isinstance(rel, int) or isinstance(rel, bool):
            raise SimError(E_ARGS)
        ref = mx.IDENTITY if rel in (HANDLE_WORLD, HANDLE_PARENT) and (rel == HANDLE_WORLD or d.parent == -1) \
            else self._world(client, d.parent if rel == HANDLE_PARENT else rel)
        local = mx.seen_from(d.matrix, ref)
        d.matrix = mx.times(ref, to_matrix(_number_list(value, n), local))
        return []

    def _setObjectPosition(self, client: Client, args: Args) -> list[object]:
        return self._set("sim.setObjectPosition", client, args, lambda v, m: [*m[:3], v[0], *m[4:7], v[1],
                                                                              *m[8:11], v[2]], 3)

    def _setObjectOrientation(self, client: Client, args: Args) -> list[object]:
        return self._set("sim.setObjectOrientation", client, args,
                         lambda v, m: mx.from_euler((m[3], m[7], m[11]), v), 3)

    def _setObjectPose(self, client: Client, args: Args) -> list[object]:
        return self._set("sim.setObjectPose", client, args, lambda v, m: mx.from_pose(v), 7)

    def _setObjectQuaternion(self, client: Client, args: Args) -> list[object]:
        return self._set("sim.setObjectQuaternion", client, args,
                         lambda v, m: mx.from_pose([m[3], m[7], m[11], *v]), 4)

    def _setObjectMatrix(self, client: Client, args: Args) -> list[object]:
        return self._set("sim.setObjectMatrix", client, args, lambda v, m: v, 12)

    # --- the tree ----------------------------------------------------------------------------

    def _kids(self) -> dict[int, list[tuple[int, int]]]:
        """Each object's children in order, as (handle, type); -1: the scene's top level."""
        tree = self.server.simulation.tree
        editor = self.server.editor
        kids: dict[int, list[tuple[int, int]]] = {}
        for o in tree.objects.values():
            kids.setdefault(o.parent.handle if o.parent is not None else -1, []).append(
                (o.handle, _KIND_TYPE.get(o.kind, 0)))
        if editor is not None:
            kids.setdefault(-1, []).extend((h, 0) for h in editor.shapes if h not in tree.objects)
        for h, d in self.dummies.items():
            kids.setdefault(d.parent, []).append((h, TYPES["dummy"]))
        return kids

    def _getObjectChild(self, client: Client, args: Args) -> list[object]:
        # sim.getObjectChild(int objectHandle, int index): CoppeliaSim 4.6 to 4.10 (sim-1); the
        # index-th child, -1 past the last
        base, index = _handle(args), _handle(args, 1)
        kids = self._kids()
        if base not in {h for pairs in kids.values() for h, _ in pairs}:
            raise SimError(E_HANDLE)
        children = kids.get(base, [])
        return [children[index][0] if 0 <= index < len(children) else -1]

    def _getObjectsInTree(self, client: Client, args: Args) -> list[object]:
        # sim.getObjectsInTree(int treeBaseHandle, int objectType = sim.handle_all, int options = 0):
        # options bit 0 leaves the base out, bit 1 takes only its first children
        base = _handle(args)
        kind = args[1] if len(args) > 1 and isinstance(args[1], int) else HANDLE_ALL
        options = args[2] if len(args) > 2 and isinstance(args[2], int) else 0
        kids = self._kids()
        types = {h: t for pairs in kids.values() for h, t in pairs}
        if base != HANDLE_SCENE and base not in types:
            raise SimError(E_HANDLE)
        start = -1 if base == HANDLE_SCENE else base
        found: list[int] = [] if base == HANDLE_SCENE or options & 1 else [base]
        level = [h for h, _ in kids.get(start, [])]
        while level:
            found += level
            level = [] if options & 2 else [c for h in level for c, _ in kids.get(h, [])]
        return [[h for h in found if kind == HANDLE_ALL or types[h] == kind]]


_NOBODY = Client("labsim", "-", 600.0, 0.0)  # the caller of an internal read, which no handler looks at
