"""The stand-in's scene editing: ``labsim serve --empty`` builds its scene from remote calls.

Where it sits: ``server.Server(empty=True)`` starts with an empty scene and hands every
request to a ``SceneEditor``, which answers the calls ``labsim scene``
(``scene_builder``) makes to build a lab in CoppeliaSim, and passes the others to the
simulation's ``sim_api.SimApi``. Edits collect here; at the first call that is not an edit
(``sim.getObject``, ``sim.startSimulation``, ...) the server's ``simulation.Simulation`` is
rebuilt from them, so what the backend then finds is what was built.

What the stand-in makes of each built object (docs/coppeliasim.md, "labsim scene"):

* a static cuboid aliased ``wall`` (``sim.createPrimitiveShape``) is labsim's wall: the segment
  along its length, less its thickness (labsim's walls have rounded ends), its thickness wide;
  any other static cuboid is a block (a box); a static mesh (``sim.createMeshShape``) is a
  block, its corners the vertices at the floor;
* a plane (``sim.primitiveshape_plane``) is the floor: the world's bounds;
* ``sim.loadModel`` of CoppeliaSim's ``pioneer p3dx.ttm`` or ``e-puck.ttm`` adds a Pioneer
  P3DX or an e-puck at the origin, with its own script (``sim.getScript``,
  ``sim.removeScript`` take it away; a simulation started with a script left is logged,
  since on CoppeliaSim it would drive the wheels);
* ``sim.setFloatParam(sim.floatparam_simulation_time_step, dt)`` sets the time step, as in
  CoppeliaSim 4.6 to 4.10 (none of them has a ``sim.setSimulationTimeStep``).

Coordinates are rounded to the nanometre and angles to the nanoradian when the world is
rebuilt, so a wall written as ``[7.5, -7.5]`` comes back as exactly that, and a run
reproduces the embedded backend's trace.

* ``sim.createTexture`` of a PNG, or of a blank texture ``sim.writeTexture`` fills
  (``texture_edit``), makes a textured plane; the ground its cameras see is that
  picture, placed and scaled as the plane is (``labsim.backends.scene.ground.Texture``), the
  floor's colour its corner pixel's;
* a vision sensor (``sim.createVisionSensor``) parented to a robot (``sim.setObjectParent``)
  and placed with ``sim.setObjectMatrix`` becomes that robot's camera: resolution, view
  angle, mount, pitch and roll read back from them (angles rounded to 1e-6 degrees); one
  aliased as a ground sensor (``ePuck_groundSensor1..3``) is that ground sensor
  (``built.robot_model``).

A world's mechanism (joints, force sensors, masses) is ``mechanism_edit``'s, the fleet script
``script_host``'s. Not built here (the stand-in answers with an error saying so):
``sim.saveScene``.
"""
from __future__ import annotations

import copy
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol

from labsim.backends.coppeliasim import MODEL_PATHS, RUNNING, STOPPED
from labsim.backends.protocol import BackendError, RobotRequest
from labsim.backends.scene.models import RobotModel
from labsim.backends.scene.object_paths import fill
from labsim.backends.scene.world import Pose, World
from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.serve.built import (
    LOADED_MODELS,
    MAX_SIZE_M,
    Sensor,
    Shape,
    primitive,
    read_shapes,
    robot_model,
)
from labsim.runtime.serve.mechanism_edit import (
    MECHANISM_CALLS,
    MECHANISM_CONSTANTS,
    MechanismEditor,
    floats,
)
from labsim.runtime.serve.scene_tree import glob_match
from labsim.runtime.serve.script_host import SCRIPT_CALLS, SCRIPT_CONSTANTS, ScriptHost
from labsim.runtime.serve.sim_api import value_and_frame
from labsim.runtime.serve.sim_args import E_ARGS, E_FEW, E_HANDLE, Args, Handler, SimError, Wait, as_handle, shown
from labsim.runtime.serve.simulation import Client, Simulation
from labsim.runtime.serve.texture_edit import TextureEdits

FIRST_HANDLE = 1_000_000  # built shapes and scripts; the scene tree's own handles count from 1
RESOURCES = "/labsim-serve"  # what sim.getStringParam(sim.stringparam_resourcesdir) answers
EMPTY = World("scene", "an empty scene", (-10.0, -10.0, 10.0, 10.0))  # its bounds: with no floor built

# simConst.h values (CoppeliaSim 4.6); the client reads them from zmqRemoteApi.info.
EDIT_CONSTANTS: dict[str, int] = {
    "primitiveshape_plane": 1, "primitiveshape_disc": 2, "primitiveshape_cuboid": 3,
    "primitiveshape_spheroid": 4, "primitiveshape_cylinder": 5,
    "shapeintparam_static": 3003, "shapeintparam_respondable": 3004,
    "scripttype_childscript": 1, "stringparam_resourcesdir": 141,
}
EDITS = tuple(f"sim.{n}" for n in (
    "createPrimitiveShape", "createMeshShape", "setObjectAlias", "setObjectInt32Param", "setFloatParam",
    "loadModel", "getScript", "removeScript", "getStringParam", "setObjectPosition",
    "setObjectOrientation", "getObjectPosition", "getObjectOrientation", "saveScene",
    "createVisionSensor", "createTexture", "writeTexture", "setObjectParent", "setObjectMatrix", "getObjectAlias",
    "getObject",
))


class Host(Protocol):
    """What the scene editor needs of the server that holds it (``server.Server``)."""

    simulation: Simulation
    dt_s: float
    log: Callable[[str], None]
    folder: Path  # where it started: a client's relative path starts here

    def sim_handlers(self) -> dict[str, Handler]: ...
    def rebuild(self, world: World, robots: Sequence[RobotRequest]) -> None: ...


class SceneEditor(TextureEdits):
    """Edits of an empty scene, and the handlers that take them (``handlers()``)."""

    def __init__(self, server: Host, base: World = EMPTY, base_robots: Sequence[RobotRequest] = ()) -> None:
        self.server = server
        self.base = base  # the scene sim.loadScene loaded: the edits add to it
        self.base_models = [r.model for r in base_robots if r.model is not None]
        self.shapes: dict[int, Shape] = {}
        self.scripts: dict[int, int] = {}  # script handle -> robot index
        self.sensors: dict[int, Sensor] = {}
        self.robots: list[Pose] = [r.pose for r in base_robots]
        self.loaded: dict[int, RobotModel] = {}  # robot index -> the model sim.loadModel loaded
        self.dirty = False
        self._next = FIRST_HANDLE
        self.script_host = ScriptHost(self._handle, self._stopped, lambda: self.server.simulation.state == RUNNING
                                      and self.server.simulation.steps > 0)
        self.mechanism_edit = MechanismEditor(self)
        self._good = self._state()  # what the last rebuild was made of (_settle)

    def _handle(self) -> int:
        self._next += 1
        return self._next - 1

    # --- the handlers --------------------------------------------------------------------------

    def handlers(self) -> dict[str, Handler]:
        """The simulation's handlers, each rebuilding the scene first if it was edited, and the edits."""
        funcs = {name: self._after_edits(name) for name in self.server.sim_handlers()}
        for name in EDITS:
            funcs[name] = getattr(self, "_" + name.removeprefix("sim."))
        start = funcs["sim.startSimulation"]

        def start_simulation(client: Client, args: Args) -> list[object] | Wait:
            self._warn_scripts()
            return start(client, args)
        funcs["sim.startSimulation"] = start_simulation
        info = funcs["zmqRemoteApi.info"]
        funcs["zmqRemoteApi.info"] = lambda client, args: self._info(info(client, args))
        return self.mechanism_edit.wrap(self.script_host.wrap(funcs))  # fleet script, mechanism

    def _warn_scripts(self) -> None:
        for i in sorted(self.scripts.values()):
            self.server.log(f"labsim serve: {self._path(i)} still has its script; in CoppeliaSim it would "
                            f"drive the wheels and fight the client's commands (sim.removeScript)")

    def _path(self, i: int) -> str:
        """Robot i's path in the scene: its model's, numbered among the robots of that model."""
        model = self.loaded[i] if i in self.loaded else self.base_models[i]
        j = sum(1 for k in range(i) if (self.loaded.get(k) or self.base_models[k]).name == model.name)
        return fill(str(MODEL_PATHS[model.name]["robot"]), i=j)

    def _after_edits(self, name: str) -> Handler:
        def call(client: Client, args: Args) -> list[object] | Wait:
            self._settle()
            return self.server.sim_handlers()[name](client, args)
        return call

    def _settle(self) -> None:
        """Rebuild the simulation from the edits, if any, and only while it is stopped: a shape
        added to a running scene becomes an obstacle from the next start (a rebuild would end
        the run). An edit set that cannot be simulated is this request's error, and the scene
        goes back to the last one that could be: never a server that fails every request after."""
        if not self.dirty or self.server.simulation.state != STOPPED:
            return
        try:
            self.apply()
        except (BackendError, LabsimError) as e:
            self._restore()
            raise SimError(f"labsim serve: the scene as edited cannot be simulated ({e}); the edits since "
                           f"it last could are undone") from None

    def _info(self, ret: list[object] | Wait) -> list[object]:
        assert isinstance(ret, list) and isinstance(ret[0], dict)
        info = dict(ret[0])
        info.update({name.removeprefix("sim."): {"func": {}} for name in EDITS})
        info.update({name: {"const": value} for name, value in EDIT_CONSTANTS.items()})
        info.update({name.removeprefix("sim."): {"func": {}} for name in SCRIPT_CALLS})
        info.update({name: {"const": value} for name, value in SCRIPT_CONSTANTS.items()})
        info.update({name.removeprefix("sim."): {"func": {}} for name in MECHANISM_CALLS})
        info.update({name: {"const": value} for name, value in MECHANISM_CONSTANTS.items()})
        return [info]

    # --- rebuilding the simulation -------------------------------------------------------------

    def built_handles(self) -> dict[str, int]:
        """Name -> handle of what a mechanism was built from: the simulation answers to those."""
        return self.mechanism_edit.handles()

    def world(self) -> World:
        """The world the built shapes make (walls, blocks, the floor's bounds), over the loaded
        scene's (``base``: sim.loadScene, else nothing)."""
        walls, blocks, bounds, ground, floor_z = read_shapes(self.shapes, self.mechanism_edit.bodies())
        b = self.base
        mechanism = self.mechanism_edit.mechanism(floor_z) or b.mechanism
        return World(b.name, "a scene built through the remote API", bounds or b.bounds, b.walls + walls,
                     b.blocks + blocks, spawns=b.spawns, ground=ground or b.ground, mechanism=mechanism)

    def apply(self) -> None:
        """Rebuild the server's simulation from the edits (the robots keep the poses they were given)."""
        sim = self.server.simulation
        poses = [r.pose for r in sim.robots] + self.robots[len(sim.robots):]
        self.robots = poses
        built: dict[int, list[Sensor]] = {}
        for sensor in self.sensors.values():
            if sensor.robot >= 0 and sensor.matrix:
                built.setdefault(sensor.robot, []).append(sensor)
        models = [self.base_models[i] if i < len(self.base_models)  # a loaded scene's robots keep their cameras
                  else robot_model(self.loaded[i], built.get(i, [])) for i in range(len(poses))]
        requests = [RobotRequest(self._path(i).lstrip("/"), m, p, ()) for i, (m, p) in enumerate(zip(models, poses))]
        self.server.rebuild(self.world(), requests)
        self.dirty = False
        self._good = self._state()

    def _state(self) -> tuple[object, ...]:
        mech, host = self.mechanism_edit, self.script_host
        return copy.deepcopy((self.shapes, self.sensors, self.scripts, self.robots, self.loaded, mech.parts,
                              mech.parents, mech.tilts, mech.ends, mech.masses, host.dummies, host.scripts))

    def _restore(self) -> None:
        mech, host = self.mechanism_edit, self.script_host
        (self.shapes, self.sensors, self.scripts, self.robots, self.loaded, mech.parts, mech.parents, mech.tilts,
         mech.ends, mech.masses, host.dummies, host.scripts) = copy.deepcopy(self._good)  # type: ignore[assignment]
        self.dirty = False

    # --- edits -------------------------------------------------------------------------------

    def _stopped(self) -> None:
        if self.server.simulation.state != STOPPED:
            raise SimError("labsim serve: the scene is built while the simulation is stopped")

    def _new(self, shape: Shape) -> list[object]:
        if self.server.simulation.state != STOPPED:
            self.server.log("labsim serve: a shape added while the simulation runs is an obstacle from its "
                            "next start")
        h = self._next
        self._next += 1
        self.shapes[h] = shape
        self.dirty = True
        return [h]

    def _shape(self, args: Args) -> Shape | None:
        """The built shape ``args[0]`` names, or None for an object of the simulation."""
        if not args:
            raise SimError(E_FEW)
        h = as_handle(args[0])
        if h >= FIRST_HANDLE and h not in self.shapes and h not in self.sensors:
            raise SimError(E_HANDLE)
        return self.shapes.get(h)

    def _createPrimitiveShape(self, client: Client, args: Args) -> list[object]:
        # sim.createPrimitiveShape(int primitiveType, list sizes, int options = 0): CoppeliaSim 4.6
        if len(args) < 2:
            raise SimError(E_FEW)
        kind = {1: "plane", 3: "cuboid"}.get(args[0]) if isinstance(args[0], int) else None
        if kind is None:
            raise SimError("labsim serve: only planes and cuboids are built by the stand-in")
        sizes = floats(args[1], 3)
        flat = 2 if kind == "plane" else 3  # a plane's third size is its (nil) thickness
        if not all(math.isfinite(v) and 0 < v <= MAX_SIZE_M for v in sizes[:flat]) or \
                not (math.isfinite(sizes[2]) and 0 <= sizes[2] <= MAX_SIZE_M):
            raise SimError(f"labsim serve: a {kind}'s sizes are finite numbers of metres, greater than 0 and at "
                           f"most {MAX_SIZE_M:g}, not {', '.join(f'{v:g}' for v in sizes)}")
        return self._new(primitive(kind, sizes, args, "Plane" if kind == "plane" else "Cuboid"))

    def _createMeshShape(self, client: Client, args: Args) -> list[object]:
        # sim.createMeshShape(int options, float shadingAngle, list vertices, list indices): 4.6
        if len(args) < 4:
            raise SimError(E_FEW)
        v = floats(args[2], len(args[2]) if isinstance(args[2], list) else 0)
        points = [(v[i], v[i + 1], v[i + 2]) for i in range(0, len(v) - 2, 3)]
        floor = tuple((x, y) for x, y, z in points if abs(z) < 1e-9)
        if len(floor) < 3:
            raise SimError("labsim serve: a mesh is read as a prism standing on the floor (z = 0)")
        height = max(z for _, _, z in points)
        return self._new(Shape("mesh", (0.0, 0.0, height), corners=floor, alias="Shape"))

    def _setObjectAlias(self, client: Client, args: Args) -> list[object]:
        shape = self._shape(args)
        if len(args) < 2 or not isinstance(args[1], str):
            raise SimError(E_ARGS)
        if args[0] in self.sensors:
            self.sensors[args[0]].alias = args[1]
            return []
        if shape is None:
            raise SimError("labsim serve: only built shapes and sensors take a new alias")
        shape.alias = args[1]
        self.dirty = True
        return []

    def _setObjectInt32Param(self, client: Client, args: Args) -> list[object]:
        shape = self._shape(args)
        if len(args) < 3 or shape is None:
            raise SimError(E_FEW if len(args) < 3 else "labsim serve: only built shapes take parameters")
        if args[1] == EDIT_CONSTANTS["shapeintparam_static"]:
            shape.static = bool(args[2])
            self.dirty = True
        elif args[1] == EDIT_CONSTANTS["shapeintparam_respondable"]:
            shape.respondable = bool(args[2])
            self.dirty = True
        return []

    def _setFloatParam(self, client: Client, args: Args) -> list[object]:
        # sim.setFloatParam(sim.floatparam_simulation_time_step, dt): CoppeliaSim 4.6
        self._stopped()
        if len(args) < 2:
            raise SimError(E_FEW)
        if args[0] != 1 or not isinstance(args[1], (int, float)) or not args[1] > 0:
            raise SimError("labsim serve: only the simulation time step (a positive number) can be set")
        self.server.dt_s = float(args[1])
        self.dirty = True
        return []

    def _getStringParam(self, client: Client, args: Args) -> list[object]:
        if not args or args[0] != EDIT_CONSTANTS["stringparam_resourcesdir"]:
            raise SimError("labsim serve: only sim.stringparam_resourcesdir is answered")
        return [RESOURCES]

    def _loadModel(self, client: Client, args: Args) -> list[object]:
        # sim.loadModel(string filename): CoppeliaSim 4.6
        self._stopped()
        if not args or not isinstance(args[0], str):
            raise SimError(E_ARGS)
        name = args[0].replace("\\", "/").lower().rsplit("/", 1)[-1]
        if not args[0].replace("\\", "/").lower().endswith("/" + name) or name not in LOADED_MODELS:
            raise SimError(f"labsim serve: the stand-in loads only CoppeliaSim's models/robots/mobile/"
                           f"{' and '.join(LOADED_MODELS)}, not '{shown(args[0])}'")
        if self.mechanism_edit.parts:
            raise SimError("labsim serve: this scene holds a mechanism's joints; a labsim world has either a "
                           "mechanism or robots (sim.loadScene gives a lab's scene, or start from an empty one)")
        self._settle()
        self.robots.append(Pose(0.0, 0.0, 0.0))
        self.loaded[len(self.robots) - 1] = LOADED_MODELS[name]
        self.dirty = True
        self._settle()
        i = len(self.robots) - 1
        script = self._next
        self._next += 1
        self.scripts[script] = i
        return [self.server.simulation.robots[i].obj.handle]

    def _getScript(self, client: Client, args: Args) -> list[object]:
        # sim.getScript(int scriptType, int objectHandle): CoppeliaSim 4.6; -1 when it has none
        if len(args) < 2:
            raise SimError(E_FEW)
        self._settle()
        obj = self.server.simulation.tree.objects.get(args[1]) if isinstance(args[1], int) else None
        if obj is None or obj.kind != "robot":
            return [-1]
        return [next((h for h, i in self.scripts.items() if i == obj.robot), -1)]

    def _removeScript(self, client: Client, args: Args) -> list[object]:
        if not args or args[0] not in self.scripts:
            raise SimError(E_HANDLE)
        del self.scripts[args[0]]
        return []

    def _setObjectPosition(self, client: Client, args: Args) -> list[object]:
        shape = self._shape(args)
        if shape is None:
            return self._simulation("sim.setObjectPosition", client, args)
        value, _rel = value_and_frame(args, "shapes")
        shape.x, shape.y, shape.z = floats(value, 3)
        self.dirty = True
        return []

    def _setObjectOrientation(self, client: Client, args: Args) -> list[object]:
        shape = self._shape(args)
        if shape is None:
            return self._simulation("sim.setObjectOrientation", client, args)
        value, _rel = value_and_frame(args, "shapes")
        alpha, beta, gamma = floats(value, 3)
        if abs(alpha) > 1e-9 or abs(beta) > 1e-9:
            raise SimError("labsim serve: the scene is flat; shapes turn about z only (alpha = beta = 0)")
        shape.yaw = gamma
        self.dirty = True
        return []

    def _simulated(self, args: Args) -> Shape | None:
        """The built shape ``args[0]`` names, unless the simulation moves it (a mechanism's body,
        which answers to its built handle): then None, and the simulation answers for it."""
        shape = self._shape(args)
        if shape is not None:
            self._settle()
            if as_handle(args[0]) in self.server.simulation.tree.objects:
                return None
        return shape

    def _getObjectPosition(self, client: Client, args: Args) -> list[object]:
        shape = self._simulated(args)
        if shape is None:
            return self._simulation("sim.getObjectPosition", client, args)
        return [[shape.x, shape.y, shape.z]]

    def _getObjectOrientation(self, client: Client, args: Args) -> list[object]:
        shape = self._simulated(args)
        if shape is None:
            return self._simulation("sim.getObjectOrientation", client, args)
        return [[0.0, 0.0, shape.yaw]]

    def _simulation(self, name: str, client: Client, args: Args) -> list[object]:
        self._settle()
        ret = self.server.sim_handlers()[name](client, args)
        assert isinstance(ret, list)
        return ret

    def _getObjectAlias(self, client: Client, args: Args) -> list[object]:
        # a built wall, block or floor is no object of the simulation's tree: its alias is here
        shape = self._shape(args)
        h = as_handle(args[0])
        self._settle()
        if shape is None or h in self.server.simulation.tree.objects:
            return self._simulation("sim.getObjectAlias", client, args)
        options = as_handle(args[1]) if len(args) > 1 and args[1] is not None else -1
        tree = self.server.simulation.tree.objects
        same = [k for k, s in self.shapes.items() if s.alias == shape.alias and k not in tree]
        n = same.index(h)
        return [shape.alias if options == -1 else f"{shape.alias}[{n}]" if options == 0 else f"/{shape.alias}[{n}]"]

    def _getObject(self, client: Client, args: Args) -> list[object]:
        # the simulation's objects by CoppeliaSim's paths, then the built walls, blocks and floors
        # at the top level: "/wall", "/wall[3]", "./labsimFloor". With {noError: true} the
        # simulation answers -1 where it would raise: the built shapes are looked up all the same
        # (in CoppeliaSim noError only silences the error).
        try:
            ret = self._simulation("sim.getObject", client, args)
        except SimError:
            found = self._built(args)
            if found is None:
                raise
            return [found]
        if ret == [-1]:
            found = self._built(args)
            return [-1 if found is None else found]
        return ret

    def _built(self, args: Args) -> int | None:
        """The built wall, block or floor a top-level path names; None when there is none."""
        path = args[0] if args and isinstance(args[0], str) else ""
        name = path.removeprefix("/").removeprefix("./").removeprefix(":/")
        alias, _, rest = name.partition("[")
        n = 0 if not rest else int(rest[:-1]) if rest.endswith("]") and rest[:-1].isdigit() and len(rest) <= 10 \
            else -1
        tree = self.server.simulation.tree.objects
        same = [k for k, s in self.shapes.items() if k not in tree and alias and glob_match(alias, s.alias)]
        if "/" not in name and 0 <= n < len(same):
            return same[n]
        return None

    def _saveScene(self, client: Client, args: Args) -> list[object]:
        raise SimError("labsim serve: the stand-in writes no .ttt files; --save needs CoppeliaSim")

    def _createVisionSensor(self, client: Client, args: Args) -> list[object]:
        # sim.createVisionSensor(int options, list intParams, list floatParams): CoppeliaSim 4.6
        self._stopped()
        if len(args) < 3:
            raise SimError(E_FEW)
        res = floats(args[1], 2)
        params = floats(args[2], 3)
        h = self._next
        self._next += 1
        self.sensors[h] = Sensor((int(res[0]), int(res[1])), params[2])
        self.dirty = True
        return [h]

    def _setObjectParent(self, client: Client, args: Args) -> list[object]:
        # sim.setObjectParent(int objectHandle, int parentHandle, bool keepInPlace): CoppeliaSim 4.6
        if len(args) < 2:
            raise SimError(E_FEW)
        sensor = self.sensors.get(args[0])
        self._settle()
        parent = self.server.simulation.tree.objects.get(args[1]) if isinstance(args[1], int) else None
        if sensor is None or parent is None or parent.kind != "robot":
            raise SimError("labsim serve: only a built vision sensor is parented, and only to a robot")
        sensor.robot = parent.robot
        self.dirty = True
        return []

    def _setObjectMatrix(self, client: Client, args: Args) -> list[object]:
        # sim.setObjectMatrix(int objectHandle, list matrix, int relativeTo): CoppeliaSim 4.6
        if len(args) < 3:
            raise SimError(E_FEW)
        sensor = self.sensors.get(args[0])
        if sensor is None or sensor.robot < 0:
            raise SimError("labsim serve: only a vision sensor parented to a robot takes a matrix")
        robot = self.server.simulation.robots[sensor.robot].obj.handle
        if args[2] != robot:
            raise SimError("labsim serve: a vision sensor's matrix is taken relative to its robot")
        sensor.matrix = floats(args[1], 12)
        self.dirty = True
        return []
