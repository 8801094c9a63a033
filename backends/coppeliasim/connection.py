"""The coppeliasim backend's connection: one client, its calls, round trips and errors.

Where it sits: ``backend.CoppeliaSimBackend`` opens one ``Connection`` per run and hands it to
what it drives (``fleet``, ``mechanism``), which make every remote call through ``call``. It is
the only module that imports the unmodified client ``coppeliasim_zmqremoteapi_client``.

Failures never hang: the client's socket gets ``LINGER`` 0 and send/receive timeouts of
``timeout_s``; no answer in time is a ``BackendError`` naming host and port, and the
connection is then dead (a REQ socket cannot be reused after a lost reply). An error the
server answered leaves it usable, explained for the user when it says something about
versions. ``round_trips`` counts every request sent, including the "executed" of
``sim.step``, so the summary can report round trips per tick. ``sim.step`` is never
retried: a retry could step twice.
"""
from __future__ import annotations

import math
import sys
import time
from collections.abc import Callable
from typing import Any, TypeVar

from labsim.backends.coppeliasim import HANDLE_ALL, HANDLE_WORLD, STOPPED
from labsim.backends.coppeliasim.replies import check
from labsim.backends.protocol import BackendError

try:
    import zmq
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient
except ImportError as _missing:  # pragma: no cover - depends on the installation
    raise BackendError(
        f"the coppeliasim backend needs the CoppeliaSim ZMQ remote API client ({_missing.name} is "
        "missing); install it with: pip install 'labsim[coppeliasim]' "
        "(coppeliasim-zmqremoteapi-client==2.0.4, pyzmq, cbor2)"
    ) from None

T = TypeVar("T")


class Connection:
    """A CoppeliaSim at ``host``:``port``, reached through the ZMQ remote API (protocol 2)."""

    def __init__(self, host: str, port: int, timeout_s: float) -> None:
        self.host = host
        self.port = port
        self.timeout_s = timeout_s
        self.round_trips = 0  # requests sent (each is one round trip)
        self.steps = 0  # sim.step calls through step(), for the error messages and the summary
        self.dt_s = 0.0
        self.client: Any = None  # the RemoteAPIClient while connected
        self.busy = False  # a request is out and its answer not yet in (interrupted mid-call)
        self.dead = ""  # why the connection cannot be used any more
        self.running = False  # we started the simulation and have not stopped it
        self.sim: Any = None  # client.require("sim"): the server's functions and constants
        # the server's constants (read from it by require_sim; CoppeliaSim's values until then)
        self.world_h, self.handle_all, self.stopped = HANDLE_WORLD, HANDLE_ALL, STOPPED
        self.names: dict[int, str] = {}  # handle -> what it is, for errors about its replies
        # ask the simulation's state after each step: set by a part that reads object by object,
        # where nothing else would notice that someone else stopped the simulation (the steps
        # of a stopped simulation do nothing, and every read still answers)
        self.watch_state = False

    @property
    def where(self) -> str:
        return f"{self.host}:{self.port}"

    def open(self, dt_s: float) -> None:
        """Connect afresh, for a run of time step ``dt_s``; nothing is sent yet."""
        self.dt_s = dt_s
        self.dead = ""
        self.sim = None
        self.round_trips = self.steps = 0
        self.names = {}
        self.client = self._connect(self.timeout_s)

    def _connect(self, timeout_s: float) -> Any:
        main = sys.modules["__main__"].__dict__
        had, previous = "require" in main, main.get("require")
        client = RemoteAPIClient(self.host, self.port)
        # The client puts its `require` into __main__'s globals (for interactive use); a
        # backend has no business changing the program's namespace, so undo it.
        if had:
            main["require"] = previous
        else:
            main.pop("require", None)
        sock = client.socket
        sock.setsockopt(zmq.LINGER, 0)  # closing never waits for unsent requests
        sock.setsockopt(zmq.RCVTIMEO, max(1, int(timeout_s * 1000)))
        sock.setsockopt(zmq.SNDTIMEO, max(1, int(timeout_s * 1000)))
        send = client._send

        def counted(req: dict[str, Any]) -> None:
            self.round_trips += 1
            send(req)

        client._send = counted  # count every request, including the "executed" of sim.step
        return client

    @staticmethod
    def _disconnect(client: Any) -> None:
        try:
            client.socket.close(0)
            client.context.term()
        except zmq.ZMQError:
            pass

    def require_sim(self) -> None:
        """The first request: the server's ``sim`` namespace, and the constants it lists."""
        self.busy = True
        try:
            sim = self.client.require("sim")
        except Exception as e:
            raise self._failure(e, "zmqRemoteApi.require") from None
        self.busy = False
        self.sim = sim
        self.handle_all = getattr(sim, "handle_all", HANDLE_ALL)
        self.world_h = getattr(sim, "handle_world", HANDLE_WORLD)
        self.stopped = getattr(sim, "simulation_stopped", STOPPED)

    # --- calls -------------------------------------------------------------------------------

    def call(self, func: str, *args: object) -> Any:
        """One remote call; every failure becomes a BackendError naming the server, and so does
        a reply that is not what CoppeliaSim sends (``replies``)."""
        client = self.client
        if client is None:
            raise BackendError(f"coppeliasim backend: {func} called without a connection")
        if self.dead:
            raise BackendError(self.dead)
        self.busy = True
        try:
            out = client.call(func, list(args))
        except Exception as e:  # zmq.Again, zmq.ZMQError, KeyError, or the server's error
            failure = self._failure(e, func)
            raise (self._stopped_from_outside(func) or failure) from None
        self.busy = False
        try:
            return check(func, out, self.names.get(args[0], "") if args and type(args[0]) is int else "")
        except BackendError as e:
            raise BackendError(f"CoppeliaSim at {self.where}: {e}") from None

    def checked(self, check_reply: Callable[[], T]) -> T:
        """``check_reply()`` (one of ``replies``' checks of a script function's reply), its
        error naming the server, as every other reply's does."""
        try:
            return check_reply()
        except BackendError as e:
            raise BackendError(f"CoppeliaSim at {self.where}: {e}") from None

    def name(self, handle: int, what: str) -> int:
        """Remember what ``handle`` is, for the errors about replies that concern it."""
        self.names[handle] = what
        return handle

    def get(self, path: str, proxy: int, what: str) -> int:
        """The handle of the object at ``path`` (relative to ``proxy`` unless it is -1);
        ``what`` says what it is for, in the error when the scene has no such object."""
        try:
            h = self.call("sim.getObject", path, {"proxy": proxy} if proxy >= 0 else {})
        except BackendError as e:
            if self.dead:
                raise
            raise BackendError(
                f"{what}: CoppeliaSim at {self.where} has no object '{path}'"
                f"{' under the robot' if proxy >= 0 else ''} ({e}). The scene must hold what the "
                f"behaviour uses, named as docs/coppeliasim.md lists (one Pioneer P3DX per robot)") from None
        if not isinstance(h, int) or h < 0:
            raise BackendError(f"{what}: CoppeliaSim at {self.where} gave no handle for '{path}' ({h!r})")
        return self.name(h, f"{what} ('{path}')")

    # --- the simulation ----------------------------------------------------------------------

    def stop_running(self) -> None:
        """Someone else's simulation may be running: stop it (robots can be placed only while
        it is stopped)."""
        if self.call("sim.getSimulationState") != self.stopped:
            self.call("sim.stopSimulation")
            self.wait_stopped()

    def check_dt(self) -> None:
        """The simulation time step must be the behaviour's dt: an error says both and how to fix it."""
        if hasattr(self.sim, "getSimulationTimeStep"):
            dt = self.call("sim.getSimulationTimeStep")
        else:  # before CoppeliaSim 4.7
            dt = self.call("sim.getFloatParam", getattr(self.sim, "floatparam_simulation_time_step", 1))
        if not isinstance(dt, (int, float)) or not math.isclose(dt, self.dt_s, rel_tol=1e-6):
            raise BackendError(
                f"CoppeliaSim at {self.where} steps {dt!r} s (its simulation time step) but the "
                f"behaviour's dt is {self.dt_s:g} s; they must agree. Set CoppeliaSim's time step to "
                f"{self.dt_s * 1000:g} ms (Simulation settings, dt; labsim serve --dt {self.dt_s:g}), or "
                f"write 'dt: {dt:g}' in the behaviour file")

    def start_stepping(self) -> None:
        self.call("sim.setStepping", True)
        self.call("sim.startSimulation")
        self.running = True

    def step(self) -> None:
        """One simulation step, counted (CoppeliaSim answers "wait", the client says
        "executed", then the step's end comes back: two round trips)."""
        self.call("sim.step")
        self.steps += 1
        if self.watch_state and self.running and self.call("sim.getSimulationState") == self.stopped:
            self.running = False
            raise BackendError(self._outside("sim.step"))

    def wait_stopped(self) -> None:
        """CoppeliaSim stops asynchronously: wait for it, at most ``timeout_s``."""
        deadline = time.monotonic() + self.timeout_s
        while self.call("sim.getSimulationState") != self.stopped:
            if time.monotonic() > deadline:
                raise BackendError(f"CoppeliaSim at {self.where} did not stop its simulation within "
                                   f"{self.timeout_s:g} s")
            time.sleep(0.01)

    def close(self) -> None:
        """Stop the simulation if we started it and can, close the socket; safe to call twice,
        never raises for a lost connection (the error that ended the run has been reported)."""
        client = self.client
        if client is None:
            return
        try:
            if self.running and not self.dead:
                if self.busy:
                    # Interrupted mid-request (Ctrl-C): this socket waits for an answer that
                    # will never be read. A fresh client can still stop the simulation, so
                    # CoppeliaSim is not left frozen in stepping mode.
                    self._disconnect(client)
                    self.client = client = self._connect(min(self.timeout_s, 1.0))
                    self.busy = False
                self.call("sim.stopSimulation")
                self.wait_stopped()
        except (BackendError, KeyboardInterrupt):
            pass
        finally:
            self.running = False
            self.client = None
            self._disconnect(client)

    # --- errors ------------------------------------------------------------------------------

    def _failure(self, e: BaseException, func: str) -> BackendError:
        """The BackendError for an exception of the client during ``func``.

        No answer in time, or a socket error, kills the connection (a REQ socket whose reply
        was lost cannot send again, and sim.step must not be sent twice); an error the server
        answered leaves it usable."""
        if isinstance(e, BackendError):
            return e
        if isinstance(e, zmq.Again):
            if self.sim is None:  # the first request: nothing there, or not CoppeliaSim's API
                self.dead = (
                    f"no answer from CoppeliaSim at {self.where} within {self.timeout_s:g} s. Is "
                    f"CoppeliaSim running, with its ZMQ remote API add-on listening on port "
                    f"{self.port}? (Without CoppeliaSim: labsim serve --port {self.port})")
            else:
                self.dead = (
                    f"CoppeliaSim at {self.where} stopped answering: no reply to {func} within "
                    f"{self.timeout_s:g} s{self._progress()}. CoppeliaSim (or labsim serve) may "
                    f"have been closed, or be busy; the run cannot go on")
            return BackendError(self.dead)
        if isinstance(e, zmq.ZMQError):
            self.dead = f"CoppeliaSim at {self.where}: connection failed during {func}: {e}"
            return BackendError(self.dead)
        self.busy = False  # the server answered: the exchange is complete
        if isinstance(e, KeyError):  # a reply without 'ret': a protocol-1 server
            return BackendError(
                f"CoppeliaSim at {self.where} answered {func} in an older protocol ({e!r} missing): "
                f"CoppeliaSim 4.5 or earlier; use CoppeliaSim 4.6 or newer with "
                f"coppeliasim-zmqremoteapi-client 2.x")
        return BackendError(self._explain(func, str(e)))  # the server's {"err": ...}

    def _stopped_from_outside(self, func: str) -> BackendError | None:
        """When a call the server refused fails because someone else (another client, the
        simulator's stop button) stopped the simulation we run: that error, else None. The
        refusal itself (a script not initialized, a step of a stopped simulation) would not
        say why."""
        if not self.running or self.dead or self.busy or func == "sim.getSimulationState":
            return None
        try:
            state = self.call("sim.getSimulationState")
        except BackendError:
            return None
        if state != self.stopped:
            return None
        self.running = False  # nothing of ours to stop any more
        return BackendError(self._outside(func))

    def _outside(self, func: str) -> str:
        return (f"CoppeliaSim at {self.where}: the simulation was stopped from outside (another client, or "
                f"the simulator's stop button){self._progress()}; the run cannot go on (seen at {func})")

    def _explain(self, func: str, err: str) -> str:
        if "No such function: zmqRemoteApi.require" in err or \
                "client ZeroMQ remote API version does not match" in err:
            return (f"CoppeliaSim at {self.where} speaks another version of the ZMQ remote API "
                    f"({err!r}). labsim uses coppeliasim-zmqremoteapi-client 2.0.4 (protocol 2), "
                    f"which needs CoppeliaSim 4.6 or newer; update CoppeliaSim, or its ZMQ remote "
                    f"API add-on")
        return f"CoppeliaSim at {self.where}: {func} failed: {err}"

    def _progress(self) -> str:
        if not self.steps:
            return ""
        return f", after {self.steps} steps (t = {self.steps * self.dt_s:.2f} s)"
