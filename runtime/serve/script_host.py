"""The stand-in's scripts: ``labsim serve`` answers the fleet script ``labsim scene`` adds.

Where it sits: ``scene_edit.SceneEditor.handlers`` (``--empty``) passes its handler table
through ``ScriptHost.wrap``, which adds the calls that put a script in the scene (a dummy, a
child script, its text) and ``sim.callScriptFunction``; a served lab's scene (``serve --for``,
``serve WORLD``) goes through ``ScriptHost.serve``, which puts the fleet script in it from the
start, as ``labsim scene`` would have, and adds only the calls that find and call it. The
stand-in runs no Lua: it recognises the one script labsim writes (``fleet_script.LUA``,
compared as text) and does what its functions do, through the same ``sim.*`` handlers a
client's per-object calls reach, so the fast path reads exactly what the per-object path
reads. Any other script is refused with an error saying so.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from labsim.backends.coppeliasim import HANDLE_WORLD
from labsim.backends.coppeliasim import fleet_script as fs
from labsim.runtime.serve.sim_args import E_ARGS, E_FEW, Args, Handler, SimError, Wait
from labsim.runtime.serve.simulation import Client

# simConst.h names the stand-in adds to zmqRemoteApi.info (its values; a client reads them
# from there, so only their being distinct matters)
SCRIPT_CONSTANTS: dict[str, int] = {"scripttype_childscript": 1, "scriptstringparam_text": 10110}
SCRIPT_CALLS = ("sim.createDummy", "sim.addScript", "sim.setScriptStringParam",
                "sim.associateScriptWithObject", "sim.callScriptFunction")


@dataclass(eq=False)
class _Dummy:
    alias: str = "dummy"
    script: int = -1


class ScriptHost:
    """Dummies and scripts of a scene being built; ``new_handle`` hands out their handles."""

    def __init__(self, new_handle: Callable[[], int], stopped: Callable[[], None],
                 ready: Callable[[], bool]) -> None:
        self._new_handle, self._stopped, self._ready = new_handle, stopped, ready
        self.dummies: dict[int, _Dummy] = {}
        self.scripts: dict[int, str] = {}  # script handle -> its text

    def wrap(self, funcs: dict[str, Handler]) -> dict[str, Handler]:
        """``funcs`` with the script calls added and the object calls that must know dummies wrapped."""
        out = dict(funcs)
        self._funcs = out
        for name in SCRIPT_CALLS:
            out[name] = getattr(self, "_" + name.removeprefix("sim."))
        for name in ("sim.getObject", "sim.getScript", "sim.setObjectAlias"):
            out[name] = self._wrapped(name, funcs[name])
        return out

    def serve(self, funcs: dict[str, Handler], fallback: dict[str, Handler]) -> dict[str, Handler]:
        """``funcs`` of a served lab's scene with the fleet script in it: ``sim.getObject`` finds
        its dummy, ``sim.getScript`` its script, ``sim.callScriptFunction`` calls it; any other
        object or script goes to ``fallback`` (the session's answers). The building calls stay
        ``--empty``'s: the script is there from the start, as ``labsim scene`` would put it."""
        if self.fleet() < 0:
            dummy, script = self._new_handle(), self._new_handle()
            self.scripts[script] = fs.LUA
            self.dummies[dummy] = _Dummy(fs.ALIAS, script)
        out = dict(funcs)
        self._funcs = out
        out["sim.getObject"] = self._wrapped("sim.getObject", funcs["sim.getObject"])
        out["sim.getScript"] = self._wrapped("sim.getScript", fallback["sim.getScript"])
        other = fallback["sim.callScriptFunction"]

        def call(client: Client, args: Args) -> list[object] | Wait:
            ours = len(args) > 1 and isinstance(args[0], str) and args[1] in self.scripts
            return self._callScriptFunction(client, args) if ours else other(client, args)
        out["sim.callScriptFunction"] = call
        return out

    def fleet(self) -> int:
        """The handle of the dummy carrying the fleet script, or -1."""
        return next((h for h, d in self.dummies.items() if d.alias == fs.ALIAS and d.script >= 0
                     and self.scripts.get(d.script) == fs.LUA), -1)

    def _wrapped(self, name: str, inner: Handler) -> Handler:
        mine = getattr(self, "_own_" + name.removeprefix("sim."))

        def call(client: Client, args: Args) -> list[object] | Wait:
            ret = mine(args)
            return inner(client, args) if ret is None else ret
        return call

    # --- objects that know dummies -----------------------------------------------------------

    def _own_getObject(self, args: Args) -> list[object] | None:
        h = self.fleet()
        return [h] if h >= 0 and args and args[0] == f"/{fs.ALIAS}" else None

    def _own_getScript(self, args: Args) -> list[object] | None:
        # sim.getScript(int scriptType, int objectHandle): CoppeliaSim 4.6, -1 when there is none
        dummy = self.dummies.get(args[1]) if len(args) > 1 and isinstance(args[1], int) else None
        return None if dummy is None else [dummy.script]

    def _own_setObjectAlias(self, args: Args) -> list[object] | None:
        dummy = self.dummies.get(args[0]) if args and isinstance(args[0], int) else None
        if dummy is None:
            return None
        if len(args) < 2 or not isinstance(args[1], str):
            raise SimError(E_ARGS)
        dummy.alias = args[1]
        return []

    # --- building ------------------------------------------------------------------------------

    def _createDummy(self, client: Client, args: Args) -> list[object]:
        # int objectHandle = sim.createDummy(float size): CoppeliaSim 4.6
        self._stopped()
        h = self._new_handle()
        self.dummies[h] = _Dummy()
        return [h]

    def _addScript(self, client: Client, args: Args) -> list[object]:
        # int scriptHandle = sim.addScript(int scriptType): CoppeliaSim 4.6
        self._stopped()
        if not args or args[0] != SCRIPT_CONSTANTS["scripttype_childscript"]:
            raise SimError("labsim serve: the stand-in adds child scripts only")
        h = self._new_handle()
        self.scripts[h] = ""
        return [h]

    def _setScriptStringParam(self, client: Client, args: Args) -> list[object]:
        # sim.setScriptStringParam(int scriptHandle, int parameterID, buffer parameter): 4.6
        if len(args) < 3:
            raise SimError(E_FEW)
        if args[0] not in self.scripts or args[1] != SCRIPT_CONSTANTS["scriptstringparam_text"]:
            raise SimError("labsim serve: only a built script's text can be set")
        text = args[2].decode() if isinstance(args[2], bytes) else args[2]
        if not isinstance(text, str):
            raise SimError(E_ARGS)
        self.scripts[args[0]] = text
        return []

    def _associateScriptWithObject(self, client: Client, args: Args) -> list[object]:
        # sim.associateScriptWithObject(int scriptHandle, int objectHandle): CoppeliaSim 4.6
        if len(args) < 2:
            raise SimError(E_FEW)
        if args[0] not in self.scripts or args[1] not in self.dummies:
            raise SimError("labsim serve: a built script goes with a built dummy")
        self.dummies[args[1]].script = args[0]
        return []

    # --- calling -------------------------------------------------------------------------------

    def _callScriptFunction(self, client: Client, args: Args) -> list[object] | Wait:
        # ... = sim.callScriptFunction(string functionName, int scriptHandle, ...): CoppeliaSim 4.6
        if len(args) < 2:
            raise SimError(E_FEW)
        name, script = args[0], args[1]
        if not isinstance(name, str) or not isinstance(script, int):
            raise SimError(E_ARGS)
        text = self.scripts.get(script)
        if text is None:
            raise SimError("invalid script handle.")
        if text != fs.LUA:
            raise SimError("labsim serve: the stand-in runs no Lua; it answers only the fleet script "
                           "labsim scene adds (docs/coppeliasim.md)")
        if not self._ready():
            # a child script is initialized by the simulation's first step; the stand-in does not
            # answer before it (CoppeliaSim may, from its start: the stricter rule is the safe one)
            raise SimError("script is not initialized (the simulation has not stepped since it started).")
        if name == fs.SENSE and len(args) == 3 and isinstance(args[2], list):
            return [[self._sense(client, p) for p in args[2]]]
        if name == fs.ACT and len(args) == 3 and isinstance(args[2], list):
            return self._act(client, args[2])
        if name == fs.PARTS and len(args) == 3 and isinstance(args[2], list) and len(args[2]) == 3:
            return [self._parts(client, args[2])]
        raise SimError(f"function {name!r} does not exist in the script, or its arguments are wrong.")

    def _call(self, client: Client, name: str, *args: object) -> list[object]:
        ret = self._funcs[name](client, list(args))
        assert isinstance(ret, list)
        return ret

    def _sense(self, client: Client, p: object) -> list[object]:
        """What ``labsimSense`` returns for one robot (see ``fleet_script``)."""
        if not (isinstance(p, list) and len(p) == 5 and all(isinstance(v, int) for v in p[:3])
                and isinstance(p[3], list) and isinstance(p[4], list)):
            raise SimError(E_ARGS)
        robot, other, flags = p[0], p[1], p[2]
        sonars = [self._call(client, "sim.readProximitySensor", h) for h in p[3]]
        images = [self._call(client, "sim.getVisionSensorImg", h) for h in p[4]]
        pos = self._call(client, "sim.getObjectPosition", robot, HANDLE_WORLD)[0] if flags & fs.POSITION else []
        ori = self._call(client, "sim.getObjectOrientation", robot, HANDLE_WORLD)[0] if flags & fs.ORIENTATION else []
        vel = self._call(client, "sim.getObjectVelocity", robot) if flags & fs.VELOCITY else []
        return [sonars, images, pos, ori, vel, self._call(client, "sim.checkCollision", robot, other)]

    def _parts(self, client: Client, plan: list[object]) -> list[object]:
        """What ``labsimParts`` returns: joints, force sensors, bodies (see ``fleet_script``)."""
        joints, forces, bodies = plan
        if not all(isinstance(v, list) for v in plan):
            raise SimError(E_ARGS)
        assert isinstance(joints, list) and isinstance(forces, list) and isinstance(bodies, list)
        return [[[self._call(client, "sim.getJointPosition", h)[0], self._call(client, "sim.getJointVelocity", h)[0]]
                 for h in joints],
                [self._call(client, "sim.readForceSensor", h) for h in forces],
                [[self._call(client, "sim.getObjectPosition", h, HANDLE_WORLD)[0],
                  self._call(client, "sim.getObjectOrientation", h, HANDLE_WORLD)[0]] for h in bodies]]

    def _act(self, client: Client, commands: list[object]) -> list[object]:
        if len(commands) % 2:
            raise SimError(E_ARGS)
        for k in range(0, len(commands), 2):
            self._call(client, "sim.setJointTargetVelocity", commands[k], commands[k + 1])
        return []
