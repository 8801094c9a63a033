"""``labsim serve``: a stand-in for CoppeliaSim's ZMQ remote API, backed by the pymunk backend.

Where it sits: a CoppeliaSim client (labsim's own ``CoppeliaSimBackend``, or a student's script
using ``coppeliasim_zmqremoteapi_client``) talks to this server exactly as it would to
CoppeliaSim's ZMQ remote API add-on. This module is the wire loop: the socket, the framing,
the clients and the real-time clock. What a call does is in ``sim_api`` (the ``sim.*``
functions), ``sim_objects``, ``sim_session`` and ``sim_signals`` (the calls scripts make beyond a
lab's, answered first), over ``simulation`` (the pymunk backend behind the scene) and ``scene_tree`` (the
objects and CoppeliaSim's path language). No CoppeliaSim is needed.

The wire (protocol v2, docs/coppeliasim.md and the reference notes it cites): one ZMQ REP
socket; every message is one CBOR map. A request is ``{func, args, argsL, uuid[, ver, lang,
timeout]}``; a reply is ``{"ret": [...]}``, ``{"err": "..."}`` or ``{"func": "_*wait*_"}``.
``sim.step`` answers with the wait message and advances when the client sends
``_*executed*_``, as CoppeliaSim does. Errors carry CoppeliaSim's texts (``No such function:
...``, ``object does not exist, or alias/path is ill formatted.``) followed by labsim's hint.

Clients come and go, several at once, each with its own stepping level; ``_*end*_`` (sent by
the C++, Java, MATLAB and Octave clients as they close) is answered with an empty map and the
client forgotten, as the add-on does. A new client finds the scene as the last one left it,
except that a stepping client that went away without stopping the simulation (killed,
crashed) has its simulation stopped when the next client arrives, once it has been silent for
``takeover_s``: otherwise the next program would find a half-run simulation frozen at its
last step.

A hostile or broken client cannot wedge it (docs/security.md, "The server"): a message over
``MAX_MESSAGE_BYTES`` is dropped by ZeroMQ, every frame of a request is read and a request of
more than one frame is answered with an error, ``wire_limits`` refuses a message too deep, too
many-valued or malformed before cbor2 decodes it, a request running past its time budget is
answered with an error, and the socket is never reopened, so a client waiting in the socket's
queue keeps its place.
"""
from __future__ import annotations

import itertools
import math
import signal
import threading
import time
import traceback
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from labsim.backends.coppeliasim import DEFAULT_PORT, RUNNING, STOPPED
from labsim.backends.protocol import BackendError, RobotRequest
from labsim.backends.scene.models import RobotModel
from labsim.backends.scene.world import Pose, World
from labsim.runtime.serve.scene_edit import SceneEditor
from labsim.runtime.serve.script_host import ScriptHost
from labsim.runtime.serve.sim_api import FUNCTIONS, UNSUPPORTED, SimApi
from labsim.runtime.serve.sim_args import E_ARGS, WAIT, Handler, SimError, shown
from labsim.runtime.serve.sim_objects import OBJECT_CALLS, OBJECT_CONSTANTS, ObjectCalls
from labsim.runtime.serve.sim_session import SESSION_CALLS, SESSION_CONSTANTS, SessionCalls
from labsim.runtime.serve.sim_signals import SIGNAL_CALLS, SignalCalls
from labsim.runtime.serve.simulation import Client, Simulation, robot_specs
from labsim.runtime.serve.wire_limits import MAX_MESSAGE_BYTES, REQUEST_BUDGET_S, BudgetExceeded, Deadline
from labsim.runtime.serve.wire_limits import refusal as wire_refusal

try:
    import cbor2
    import zmq
except ImportError as _missing:  # pragma: no cover - depends on the installation
    raise BackendError(
        f"labsim serve needs pyzmq and cbor2 ({_missing.name} is missing); install them with: "
        "pip install 'labsim[coppeliasim]'"
    ) from None

__all__ = ["STOPPED", "Server", "serve"]

E_VERSION = "The client ZeroMQ remote API version does not match CoppeliaSim's version"
TAKEOVER_S = 2.0
POLL_MS = 100  # how often an idle server looks at its stop flag
MAX_UUID_CHARS = 256  # the client sends a 36-character uuid4
MAX_CLIENTS = 1000  # clients remembered at once; past it the longest silent is forgotten
FLEET_HANDLE = 1_500_000  # the served fleet script's dummy and script: past the tree's, before dummies'


# Calls whose arguments keep a whole float a float: the value comes back as it was given.
FLOAT_VALUES = frozenset({"sim.setFloatSignal", "sim.setFloatParam", "sim.callScriptFunction"})


def lua_numbers(func: str, args: list[Any]) -> list[Any]:
    """A request's arguments as CoppeliaSim's Lua functions take them: a number is a number,
    so a whole float (numpy's 4.0, a handle kept in ``np.zeros(16)``) is accepted wherever an
    integer is (``luaToInt``: ``lua_tointeger``, else the number cast). Whole floats at the top
    level, and in a top-level map (``sim.getObject``'s options), become ints."""
    if func in FLOAT_VALUES:
        return args
    out: list[Any] = []
    for a in args:
        if isinstance(a, float) and a.is_integer() and abs(a) < 2 ** 53:
            a = int(a)
        elif isinstance(a, dict):
            a = {k: int(v) if isinstance(v, float) and v.is_integer() and abs(v) < 2 ** 53 else v
                 for k, v in a.items()}
        out.append(a)
    return out



class Server:
    """The stand-in. ``bind()`` then ``serve_forever()``; ``stop()`` from any thread.

    ``robots``: a count of Pioneer P3DX robots, placed at the world's spawn poses (then at free
    random poses), or a sequence of ``RobotRequest``s whose ``model`` and ``pose`` are used
    (their channels are not: the server offers every channel of the model).
    ``port=0`` binds a free port; ``port`` then says which. ``fleet_script``: the scene
    carries labsim's fleet script, as a scene ``labsim scene`` built does (``labsim serve``
    serves one so; without it a client reads object by object, as in a scene built by hand).
    """

    def __init__(self, world: World, robots: int | Sequence[RobotRequest] = 1, *, host: str = "127.0.0.1",
                 port: int = DEFAULT_PORT, dt_s: float = 0.05, takeover_s: float = TAKEOVER_S,
                 log: Callable[[str], None] | None = None, empty: bool = False,
                 budget_s: float = REQUEST_BUDGET_S, fleet_script: bool = False) -> None:
        if not (isinstance(dt_s, (int, float)) and math.isfinite(dt_s) and dt_s > 0):
            raise BackendError(f"labsim serve: the time step must be positive, not {dt_s!r}")
        self.world = world
        self.host = host
        self.port = port
        self.dt_s = float(dt_s)
        self.takeover_s = takeover_s
        self.budget_s = budget_s  # each request's time budget (wire_limits.Deadline)
        self.log = log or (lambda message: None)
        self.folder = Path.cwd()  # a client's relative path starts here; it may read only here and
        # in labsim scene's temporary folders and --allow-path folders (foundation/files.served_problem)
        self.messages = 0  # requests answered, for tests and the log
        self.simulation = Simulation(world, 0 if empty else robots, self.dt_s, self.log)
        # fleet_script: the served scene carries labsim's fleet script, as labsim scene builds it
        # (--empty has its own, built by the client); the handles are outside the tree's
        self.fleet_script = ScriptHost(itertools.count(FLEET_HANDLE).__next__, lambda: None, self._stepped) \
            if fleet_script and not empty else None
        self._sim_funcs = self._with_script(SimApi(self.simulation).handlers())
        self._clients = self.simulation.clients
        # --empty: the scene is built through the remote API (labsim scene), see scene_edit
        self.editor = SceneEditor(self) if empty else None
        self._editor_funcs = self.editor.handlers() if self.editor is not None else {}
        # what scripts call beyond a lab's needs, over whichever of the two answers the rest
        self.object_calls, self.session_calls = ObjectCalls(self), SessionCalls(self)
        self.signal_calls = SignalCalls(lambda: self.simulation)  # a lidar's scan, as CoppeliaSim's scanners
        self._extra = {**self.session_calls.handlers(), **self.object_calls.handlers(),
                       **self.signal_calls.handlers(), "zmqRemoteApi.info": self._info}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._context: zmq.Context | None = None
        self._socket: zmq.Socket | None = None

    # --- the scene ---------------------------------------------------------------------------

    @staticmethod
    def robot_specs(world: World, robots: int | Sequence[RobotRequest]) -> list[tuple[RobotModel, Pose]]:
        """(model, start pose) of each robot: a count of Pioneers at the world's spawn poses
        (then at free random places, 1.2 m apart), or the models and poses of requests."""
        return robot_specs(world, robots)

    def objects(self) -> list[str]:
        """Every object's full path, as ``sim.getObjectAlias(h, 2)`` gives it (for the log)."""
        tree = self.simulation.tree
        return [tree.path(o) for o in tree.objects.values()]

    def robot_paths(self) -> list[str]:
        """The robots' paths, ``/PioneerP3DX[i]``, in order."""
        return [self.simulation.tree.path(r.obj) for r in self.simulation.robots]

    def describe(self) -> str:
        """What the scene holds, in a line: robots, or the mechanism's joints and sensors."""
        parts = [", ".join(self.robot_paths())] if self.simulation.robots else []
        for kind, label in (("joint", "joints"), ("force", "force sensors"), ("body", "bodies")):
            names = [o.alias for o in self.simulation.tree.top_level(kind)]
            if names:
                parts.append(f"{label} {', '.join(names)}")
        return "; ".join(parts) or "an empty scene"

    def sim_handlers(self) -> dict[str, Handler]:
        """The handlers of the current simulation's ``sim.*`` functions."""
        return self._sim_funcs

    def rebuild(self, world: World, robots: Sequence[RobotRequest]) -> None:
        """A new simulation of ``world`` and ``robots`` (stopped), keeping the connected clients."""
        handles = self.editor.built_handles() if self.editor is not None else None
        simulation = Simulation(world, robots, self.dt_s, self.log, handles)
        simulation.clients = self._clients
        self.world, self.simulation = world, simulation
        self._sim_funcs = self._with_script(SimApi(simulation).handlers())

    def _with_script(self, funcs: dict[str, Handler]) -> dict[str, Handler]:
        """``funcs`` with the fleet script's calls when the served scene carries it."""
        if self.fleet_script is None:
            return funcs
        fallback: dict[str, Handler] = {"sim.getScript": lambda c, a: self.session_calls.no_script(c, a),
                                        "sim.callScriptFunction": lambda c, a: self.session_calls.no_function(c, a)}
        return self.fleet_script.serve(funcs, fallback)

    def _stepped(self) -> bool:
        """A child script is initialized by the simulation's first step (script_host)."""
        return self.simulation.state == RUNNING and self.simulation.steps > 0

    def base_handlers(self) -> dict[str, Handler]:
        """The handlers under sim_objects' and sim_session's: the scene editor's, or the simulation's."""
        return self._editor_funcs if self.editor is not None else self._sim_funcs

    def load(self, world: World, robots: int | Sequence[RobotRequest], dt_s: float) -> None:
        """sim.loadScene: a new scene (stopped), keeping the connected clients; in --empty, later
        edits add to it."""
        specs = robot_specs(world, robots)
        requests = [RobotRequest(f"PioneerP3DX[{i}]", m, p, ()) for i, (m, p) in enumerate(specs)]
        dt_before = self.dt_s
        self.dt_s = dt_s
        try:
            self.rebuild(world, requests)
        except BaseException:
            self.dt_s = dt_before
            raise
        self.object_calls.clear()
        if self.editor is not None:
            self.editor = SceneEditor(self, world, requests)
            self._editor_funcs = self.editor.handlers()

    def _info(self, client: Client, args: list[Any]) -> list[object]:
        ret = self.base_handlers()["zmqRemoteApi.info"](client, args)
        assert isinstance(ret, list) and isinstance(ret[0], dict)
        info = dict(ret[0])
        info.update({name.removeprefix("sim."): {"func": {}}
                     for name in (*SESSION_CALLS, *OBJECT_CALLS, *SIGNAL_CALLS)})
        info.update({name: {"const": value} for name, value in {**SESSION_CONSTANTS, **OBJECT_CONSTANTS}.items()})
        return [info]

    @staticmethod
    def functions() -> list[str]:
        return list(FUNCTIONS)

    # --- running -----------------------------------------------------------------------------

    def bind(self) -> int:
        """Open the socket; returns the port (a free one when ``port`` is 0)."""
        if self._socket is not None:
            return self.port
        self._context = zmq.Context()
        sock = self._context.socket(zmq.REP)
        sock.setsockopt(zmq.LINGER, 0)
        sock.setsockopt(zmq.SNDTIMEO, 1000)  # a reply never waits long for a peer
        sock.setsockopt(zmq.MAXMSGSIZE, MAX_MESSAGE_BYTES)  # ZeroMQ drops a peer sending more
        try:
            if self.port == 0:
                self.port = sock.bind_to_random_port(f"tcp://{self.host}")
            else:
                sock.bind(f"tcp://{self.host}:{self.port}")
        except zmq.ZMQError as e:
            sock.close()
            self._context.term()
            self._context = None
            raise BackendError(f"labsim serve: cannot listen on {self.host}:{self.port}: {e.strerror}"
                               + (" (another server, or CoppeliaSim, already uses it; try --port)"
                                  if e.errno == zmq.EADDRINUSE else "")) from None
        self._socket = sock
        return self.port

    def serve_forever(self) -> None:
        """Answer requests until ``stop()``; KeyboardInterrupt propagates after cleaning up."""
        self.bind()
        sock = self._socket
        assert sock is not None
        timeout = -2
        try:
            while not self._stop.is_set():
                wait = self._poll_ms()
                if wait != timeout:  # a blocking recv with a timeout: cheaper than poll + recv
                    sock.setsockopt(zmq.RCVTIMEO, wait)
                    timeout = wait
                try:
                    # every frame: REP cannot answer before it has read the whole request
                    frames = sock.recv_multipart(copy=True)
                except zmq.Again:
                    self._run_clock()
                    continue
                reply = self.handle_frames(frames)
                try:
                    sock.send(reply)
                except zmq.ZMQError as e:
                    # The peer went away before its reply left. The socket stays: reopening it
                    # would drop the requests other clients have queued in it.
                    self.log(f"labsim serve: a reply could not be sent ({e.strerror}); dropped")
                self._run_clock()
        finally:
            self._close()

    def stop(self) -> None:
        """Ask the serving loop to end (thread-safe); it does within POLL_MS."""
        self._stop.set()

    def start(self) -> Server:
        """Bind, then serve in a daemon thread (for tests and embedding); returns self."""
        self.bind()
        self._thread = threading.Thread(target=self.serve_forever, name="labsim-serve", daemon=True)
        self._thread.start()
        return self

    def join(self, timeout: float | None = 5.0) -> None:
        if self._thread is not None:
            self._thread.join(timeout)

    def __enter__(self) -> Server:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
        self.join()

    def _close(self) -> None:
        if self.simulation.running:
            self.simulation.stop()
        if self._socket is not None:
            self._socket.close(0)
            self._socket = None
        if self._context is not None:
            self._context.term()
            self._context = None

    def _poll_ms(self) -> int:
        sim = self.simulation
        if sim.state == RUNNING and not sim.stepping():
            return max(0, min(POLL_MS, int((sim.next_due - time.perf_counter()) * 1000) + 1))
        return POLL_MS

    def _run_clock(self) -> None:
        """Free-running: advance to real time. Also forgets clients silent past their timeout."""
        sim = self.simulation
        if sim.state != RUNNING or sim.stepping():
            return
        now = time.perf_counter()
        sim.run_clock(now)
        for c in list(self._clients.values()):
            if now - c.last_seen > c.timeout_s:
                del self._clients[c.uuid]

    # --- messages ----------------------------------------------------------------------------

    def handle_frames(self, frames: Sequence[bytes]) -> bytes:
        """All the frames of one request -> the reply's bytes. Never raises."""
        if len(frames) != 1:
            self.messages += 1
            return cbor2.dumps({"err": f"labsim serve: a request is one ZeroMQ frame holding one CBOR map, as "
                                       f"CoppeliaSim's remote API expects; this one had {len(frames)} frames"})
        return self.handle(frames[0])

    def handle(self, raw: bytes) -> bytes:
        """One request's bytes -> the reply's bytes, within the time budget. Never raises."""
        self.messages += 1
        token = Deadline.start(self.budget_s)
        try:
            return cbor2.dumps(self._decoded(raw))
        except BudgetExceeded as e:
            return cbor2.dumps({"err": str(e)})
        except Exception as e:  # a reply cbor2 cannot encode: a bug, which must not take the server down
            self.log("labsim serve: internal error\n" + traceback.format_exc())
            return cbor2.dumps({"err": f"labsim serve: internal error: {type(e).__name__}"})
        finally:
            Deadline.end(token)

    def _decoded(self, raw: bytes) -> dict[str, Any]:
        why = wire_refusal(raw)  # before cbor2 builds anything
        if why is not None:
            return {"err": why}
        try:
            req = cbor2.loads(raw)
        except Exception:
            return {"err": "labsim serve: the request is not a CBOR message"}
        if not isinstance(req, dict) or not isinstance(req.get("func"), str):
            return {"err": "labsim serve: a request is a CBOR map with a 'func' text"}
        if "uuid" not in req:  # a protocol-1 client (pip package before 2.0): what CoppeliaSim says
            return {"success": False, "error": E_VERSION}
        if not isinstance(req["uuid"], str) or not 0 < len(req["uuid"]) <= MAX_UUID_CHARS:
            return {"err": f"labsim serve: a request's 'uuid' is a text of 1 to {MAX_UUID_CHARS} characters"}
        try:
            return self._request(req)
        except BudgetExceeded:
            raise
        except Exception as e:  # a bug here must not take the server down
            self.log("labsim serve: internal error\n" + traceback.format_exc())
            return {"err": f"labsim serve: internal error in {req['func'][:80]}: {type(e).__name__}"}

    def _request(self, req: dict[str, Any]) -> dict[str, Any]:
        now = time.perf_counter()
        if req["func"] == "_*end*_":
            # What the C++, Java, MATLAB and Octave clients send as they close: the add-on answers
            # an empty map and forgets the client (its stepping level with it), as here.
            gone = self._clients.pop(str(req["uuid"]), None)
            if gone is not None:
                self.log(f"labsim serve: client {gone.uuid[:8]} ({gone.lang}) left")
                if gone.stepping > 0 and not self.simulation.stepping():
                    self.simulation.next_due = now + self.dt_s  # free-running from now, as after setStepping(False)
            return {}
        client = self._clients.get(str(req["uuid"]))
        if client is None:
            client = self._arrive(str(req["uuid"]), req, now)
        client.last_seen = now
        func: str = req["func"]
        args = req.get("args")
        if args is None:
            args = []
        elif not isinstance(args, list):
            return {"err": f"{E_ARGS} (in function '{func}')"}
        if func == "_*executed*_":
            pending, client.step_pending = client.step_pending, None
            if pending:
                self.simulation.client_step(client)
            return {"ret": []}
        handler = self._extra.get(func) or self.base_handlers().get(func)
        if handler is None:
            name = func.removeprefix("sim.")
            if func.startswith("sim.") and name in UNSUPPORTED:
                return {"err": f"labsim serve: {func} is not supported by this stand-in for CoppeliaSim "
                               f"(docs/coppeliasim.md lists what is)"}
            return {"err": f"No such function: {shown(func)}"}
        try:
            ret = handler(client, lua_numbers(func, args))
        except SimError as e:
            return {"err": f"{e} (in function '{func}')"}
        if ret is WAIT:
            return {"func": "_*wait*_", "args": []}
        return {"ret": ret}

    def _arrive(self, uuid: str, req: dict[str, Any], now: float) -> Client:
        """A new client. Stepping clients silent for takeover_s are taken to have gone away:
        their simulation is stopped, so the newcomer does not find it frozen half-way."""
        gone = [c for c in self._clients.values() if now - c.last_seen > self.takeover_s]
        if len(self._clients) - len(gone) >= MAX_CLIENTS:  # a flood of fresh ids: forget the oldest
            gone.append(min((c for c in self._clients.values() if c not in gone), key=lambda c: c.last_seen))
        for c in gone:
            del self._clients[c.uuid]
        sim = self.simulation
        if any(c.stepping > 0 for c in gone) and sim.state != STOPPED and not sim.stepping():
            self.log(f"labsim serve: the client driving the simulation went away at "
                     f"t = {sim.steps * self.dt_s:.2f} s; simulation stopped")
            sim.stop()
        timeout = req.get("timeout", 600)
        client = Client(uuid, str(req.get("lang", "?")),
                         float(timeout) if isinstance(timeout, (int, float)) and timeout > 0 else 600.0, now)
        self._clients[uuid] = client
        self.log(f"labsim serve: client {uuid[:8]} ({client.lang}) connected")
        return client


def serve(world: World, robots: int | Sequence[RobotRequest] = 1, port: int = DEFAULT_PORT,
          host: str = "127.0.0.1", *, dt_s: float = 0.05, takeover_s: float = TAKEOVER_S,
          log: Callable[[str], None] | None = None,
          ready: Callable[[Server], None] | None = None, empty: bool = False,
          fleet_script: bool = False) -> None:
    """Serve until Ctrl-C (SIGINT), SIGTERM or ``stop()`` on the server given to ``ready``.

    ``ready(server)`` is called once the socket is bound (``server.port`` is then the real
    port, also for ``port=0``).
    """
    server = Server(world, robots, host=host, port=port, dt_s=dt_s, takeover_s=takeover_s, log=log, empty=empty,
                    fleet_script=fleet_script)
    server.bind()
    previous = None
    if threading.current_thread() is threading.main_thread():
        # SIGTERM (a service manager, `kill`) ends the loop like Ctrl-C, closing the socket.
        previous = signal.signal(signal.SIGTERM, lambda *_: server.stop())
    try:
        if ready is not None:
            ready(server)
        server.serve_forever()
    except KeyboardInterrupt:
        pass
    finally:
        server._close()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
