"""Many independent runs in worker processes or on Dask: the one pool ``labsim sweep`` and ``labsim grade`` share.

It sits on the tick loop, below the applications that run a grid or a class (docs/decisions.md,
"One pool for sweeps and grading"). ``LocalBatch`` sends each item to one of N clean worker
processes and yields each outcome as it finishes. On Linux a worker is forked from the caller
itself, once it has imported labsim and compiled its files, so that it starts with nothing to
import (a fork server's fresh interpreter put its third of a second of imports on a short
sweep's critical path); it closes the other workers' pipes it inherited, and the caller forks
only while it runs no other thread. Elsewhere, or when the process has other threads (a program
that runs some, as pytest-xdist does), a worker comes from multiprocessing's fork server, a
fresh interpreter that has imported labsim and the simulator and never runs anything (``spawn``
where there is no fork server). An item past its time limit, or a worker that dies, costs that
one process: it is killed, the item's outcome says so, and a new worker takes its place. Workers
ignore Ctrl-C, take SIGTERM and SIGHUP as the end of their item (runtime/ending.py: a run ends
as Ctrl-C ends ``labsim run``, its trace closed with its footer) and die with their parent; the
caller stops them with ``interrupt``, which gives the outcomes of the items in progress.
``DaskBatch`` does the same on a Dask distributed cluster, where a worker thread cannot be
killed, so the function must stop itself at its own deadline, and when the batch is stopped
(``stop_asked``, which looks at a Dask ``Event`` the caller's ``interrupt`` sets). The function and the items must
pickle.
"""
from __future__ import annotations

import contextlib
import contextvars
import multiprocessing
import os
import signal
import sys
import threading
import time as clock
from collections import deque
from collections.abc import Callable, Generator
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, cast

from labsim.backends import DEFAULT, REGISTRY
from labsim.foundation.files import allow, allowed_folders
from labsim.foundation.memory import limit_memory
from labsim.runtime.ending import Stopped, WorkerSignals, deaf, die_with_parent, ending

POLL_S = 0.25  # how often the parent looks at the clock while every worker is busy
KILL_WAIT_S = 5.0  # how long to wait for a killed worker to be gone
# how long an interrupted batch waits for its busy workers' values: a run ends within one block
# of ticks (milliseconds) and then writes its trace's footer; a worker stuck elsewhere is killed
STOP_WAIT_S = 3.0
# DONE: the function's value; TIMEOUT, DIED: killed, or it raised; STOPPED: a signal ended the
# item before the function gave a value (while compiling, say)
DONE, TIMEOUT, DIED, STOPPED = "done", "timeout", "died", "stopped"
PER_THREAD = 2  # Dask: items submitted ahead per worker thread, so that Ctrl-C leaves little to cancel


@dataclass(frozen=True)
class Outcome:
    """What became of one item: ``DONE`` with the function's value, or another kind with why."""

    index: int
    kind: str
    value: Any = None
    message: str = ""
    wall_s: float = 0.0
    worker: str = ""  # "local:PID" of the process that ran it ('' on Dask)


@dataclass(frozen=True)
class _Failed:
    """What a worker sends back when the function raised."""

    message: str


@dataclass(frozen=True)
class _Stopped:
    """What a worker sends back when a signal ended the item before the function returned."""

    why: str


def default_jobs() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _serve(conn: Connection, allowed: list[str], memory_mb: int = 0, inherited: tuple[int, ...] = ()) -> None:
    """A worker's life: receive (function, item), send its value, until told to stop (None),
    signalled (SIGTERM, SIGHUP: the item in progress ends as for Ctrl-C and its value is sent)
    or orphaned (the parent-death signal). ``allowed``: the --allow-path folders (a fork
    server's children do not see the parent's); ``memory_mb``: the worker's limit, 0 for none;
    ``inherited``: the parent's ends of the pipes, which a worker forked from the parent holds
    copies of and closes (while open, a worker would not see its parent go)."""
    signals = WorkerSignals()
    signals.install()
    for fd in inherited:
        with contextlib.suppress(OSError):
            os.close(fd)
    die_with_parent()
    allow(allowed)
    limit_memory(memory_mb)
    while not signals.asked:
        job = None
        value: Any
        signals.armed = True
        try:
            job = conn.recv()
            if job is None:
                return
            value = _value(*job)
        except Stopped as e:  # between items (the worker's end), or before the function could end its run itself
            if job is None:
                return
            value = _Stopped(str(e))
        except (EOFError, OSError):  # from recv only (_value keeps the function's): the parent is gone
            return
        finally:
            signals.armed = False
        try:
            conn.send(value)
        except (BrokenPipeError, OSError):  # the parent is gone: so is the reason to go on
            return


def _value(function: Callable[[Any], Any], item: Any) -> Any:
    try:
        return function(item)
    except Exception as e:  # the function's own failure: that item's outcome, and the worker goes on
        return _Failed(f"{type(e).__name__}: {e}")


# what every run imports: labsim's tick loop and the default backend's module (named by the registry)
PRELOAD = ["labsim.runtime.batch", "labsim.runtime.run", REGISTRY[DEFAULT].partition(":")[0]]


Context = (multiprocessing.context.ForkContext | multiprocessing.context.ForkServerContext
           | multiprocessing.context.SpawnContext)


def fork_here() -> bool:
    """Whether workers are forked from this process: on Linux, while it runs no other thread
    (a thread holding a lock at the fork would leave the worker's copy of the lock held)."""
    return sys.platform.startswith("linux") and threading.active_count() == 1


def _context(preload: tuple[str, ...] = ()) -> Context:
    """This process forked (``fork_here``), else the fork server, with labsim (and ``preload``:
    the application's module of the function its workers run) imported in it; ``spawn`` where
    there is none (Windows). The preload counts only until the fork server starts: once a process."""
    if fork_here():
        return multiprocessing.get_context("fork")
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([*PRELOAD, *preload])
    return context


def warm_up(preload: tuple[str, ...] = ()) -> None:
    """Start the fork server now, when workers will come from it, so that its imports (a fresh
    interpreter loading labsim and the simulator, about 0.3 s) overlap the caller's own checks
    and compiles instead of following them. Workers forked from the caller need none."""
    if not fork_here() and "forkserver" in multiprocessing.get_all_start_methods():
        from multiprocessing import forkserver

        _context(preload)  # its preload named first
        forkserver.ensure_running()


@dataclass
class _Worker:
    process: multiprocessing.process.BaseProcess
    conn: Connection
    index: int | None = None
    started: float = 0.0

    @property
    def name(self) -> str:
        return f"local:{self.process.pid}"


class LocalBatch:
    """``outcomes(function, items)``: each item's outcome as it finishes, on ``jobs`` processes;
    ``interrupt(why)`` after a signal: the outcomes of the items in progress."""

    def __init__(self, jobs: int, timeout_s: float | None = None, memory_mb: int = 0,
                 name: str = "labsim-batch-worker", preload: tuple[str, ...] = ()) -> None:
        self.jobs = max(1, jobs)
        self.timeout_s = timeout_s
        self.memory_mb = memory_mb  # each worker's address space (limit_memory); 0: none
        self.name = name
        self.in_flight: dict[int, Any] = {}  # index: item, of the items sent and not yet answered
        self._context = _context(preload)
        self._workers: list[_Worker] = []
        self._stopped: list[Outcome] | None = None  # what interrupt() gave, once it has run

    def _start(self) -> _Worker:
        parent, child = self._context.Pipe()
        allowed = [str(p) for p in allowed_folders()]
        # a forked worker's copies of the parent's pipe ends (a fork server's children have none)
        inherited = tuple(c.fileno() for c in [parent, *(w.conn for w in self._workers)] if not c.closed) \
            if self._context.get_start_method() == "fork" else ()
        process = self._context.Process(target=_serve, args=(child, allowed, self.memory_mb, inherited),
                                        daemon=True, name=self.name)
        # a terminal's Ctrl-C reaches every process of the group: a worker ignores it from its
        # first instruction (an ignored signal stays ignored across exec), so that it does not
        # die with a traceback while still importing; the parent stops the workers itself
        main = threading.current_thread() is threading.main_thread()
        previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
        try:
            process.start()
        finally:
            if main:
                signal.signal(signal.SIGINT, previous)
        child.close()
        return _Worker(process, parent)

    def _replace(self, w: _Worker) -> None:
        self._kill(w)
        self._workers[self._workers.index(w)] = self._start()

    @staticmethod
    def _kill(w: _Worker) -> None:
        if w.process.is_alive():
            w.process.kill()
        w.process.join(KILL_WAIT_S)
        w.conn.close()

    def outcomes(self, function: Callable[[Any], Any], items: list[Any]) -> Generator[Outcome, None, None]:
        """Run function(item) for every item; always stops every worker, also when the caller
        stops early. A signal that reaches this loop stops the items in progress first."""
        pending = deque(enumerate(items))
        self._workers = [self._start() for _ in range(min(self.jobs, len(items)))]
        try:
            while pending or self.in_flight:
                self._feed(function, pending)
                yield from self._collect()
        except KeyboardInterrupt as e:  # the runs in progress end as Ctrl-C ends a run; the caller asks for them
            self.interrupt(ending(e)[1])
            raise
        finally:
            self.close()

    def _feed(self, function: Callable[[Any], Any], pending: deque[tuple[int, Any]]) -> None:
        for w in self._workers:
            if w.index is None and pending:
                index, item = pending.popleft()
                try:
                    w.conn.send((function, item))
                except (BrokenPipeError, OSError):  # it died while idle: a new one takes the item
                    self._replace(w)
                    pending.appendleft((index, item))
                    continue
                w.index, w.started = index, clock.perf_counter()
                self.in_flight[index] = item

    def _answer(self, w: _Worker, replace: bool = True) -> Outcome:
        """The busy worker ``w``'s answer, once its pipe is readable; a dead worker is replaced
        (unless the batch is being stopped)."""
        index, took, name = cast(int, w.index), clock.perf_counter() - w.started, w.name
        self.in_flight.pop(index, None)
        w.index = None
        try:
            value = w.conn.recv()
        except (EOFError, OSError):
            code = w.process.exitcode if not w.process.is_alive() else None
            if replace:
                self._replace(w)
            return Outcome(index, DIED, message=f"the worker process died while running it (exit code {code})",
                           wall_s=took, worker=name)
        if isinstance(value, _Failed):
            return Outcome(index, DIED, message=value.message, wall_s=took, worker=name)
        if isinstance(value, _Stopped):
            return Outcome(index, STOPPED, message=f"stopped by {value.why}", wall_s=took, worker=name)
        return Outcome(index, DONE, value, wall_s=took, worker=name)

    def _collect(self) -> Generator[Outcome, None, None]:
        busy = {w.conn: w for w in self._workers if w.index is not None}
        wait_s = POLL_S
        if self.timeout_s is not None and busy:
            first = min(w.started for w in busy.values())
            wait_s = min(wait_s, max(0.0, first + self.timeout_s - clock.perf_counter()))
        for conn in wait(list(busy), wait_s):
            yield self._answer(busy[cast(Connection, conn)])  # wait() hands back the objects it was given
        if self.timeout_s is not None:
            now = clock.perf_counter()
            for w in list(self._workers):
                if w.index is not None and now - w.started > self.timeout_s:
                    index, name = w.index, w.name
                    self.in_flight.pop(index, None)
                    self._replace(w)  # the only way to stop a run that does not return
                    yield Outcome(index, TIMEOUT, message=f"killed after its time limit of {self.timeout_s:g} s",
                                  wall_s=now - w.started, worker=name)

    def interrupt(self, why: str) -> list[Outcome]:
        """Stop the items in progress and give their outcomes: each busy worker is sent SIGTERM,
        which ends its run as Ctrl-C ends ``labsim run`` (its trace closed with its footer, the
        value saying interrupted, with what the run did so far), and has STOP_WAIT_S to send it;
        then every worker is stopped. An item with no answer by then is ``STOPPED``, with ``why``
        ('Ctrl-C', 'SIGTERM', 'SIGHUP'). Further calls give the same outcomes."""
        if self._stopped is not None:
            return self._stopped
        got: list[Outcome] = []
        busy = {w.conn: w for w in self._workers if w.index is not None and w.process.is_alive()}
        with deaf():  # a second Ctrl-C must not lose the values being sent
            for w in busy.values():
                with contextlib.suppress(ProcessLookupError):
                    os.kill(cast(int, w.process.pid), signal.SIGTERM)
            deadline = clock.perf_counter() + STOP_WAIT_S
            while busy and clock.perf_counter() < deadline:
                for conn in wait(list(busy), max(0.0, deadline - clock.perf_counter())):
                    got.append(self._answer(busy.pop(cast(Connection, conn)), replace=False))
            self.close()
        got = [Outcome(o.index, STOPPED, message=f"stopped by {why}", wall_s=o.wall_s, worker=o.worker)
               if o.kind in (STOPPED, DIED) else o for o in got]
        got += [Outcome(index, STOPPED, message=f"stopped by {why}") for index in self.in_flight]
        self.in_flight.clear()
        self._stopped = got
        return got

    def close(self) -> None:
        """Stop every worker: idle ones are asked, busy ones are killed."""
        for w in self._workers:
            try:
                if w.index is None and w.process.is_alive():
                    w.conn.send(None)
                    w.process.join(1.0)
            except (BrokenPipeError, OSError):
                pass
            self._kill(w)
        self._workers = []


STOP_POLL_S = 0.5  # Dask: how often a function asking ``stop_asked`` looks at the batch's Event (a round trip)
_STOP: contextvars.ContextVar[Callable[[], bool] | None] = contextvars.ContextVar("labsim_batch_stop", default=None)


def stop_asked() -> bool:
    """Whether the Dask batch running this function was stopped (Ctrl-C, SIGTERM on its caller):
    a function that takes long asks now and then and ends its work as a signal would end it.
    Always False outside a Dask batch (a local worker is signalled instead); it costs a look at
    the clock, and a look at the cluster every STOP_POLL_S."""
    asked = _STOP.get()
    return asked is not None and asked()


def _watched(function: Callable[[Any], Any], item: Any, stop: str) -> Any:
    """function(item) on a Dask worker, with ``stop_asked`` looking at the Event named ``stop``."""
    from distributed import Event

    try:
        event: Any = Event(stop)
    except ValueError:  # not on a worker (called directly): nothing can ask it to stop
        return function(item)
    looked = [clock.perf_counter()]  # when it last looked
    told = [False]

    def asked() -> bool:
        now = clock.perf_counter()
        if not told[0] and now - looked[0] >= STOP_POLL_S:
            looked[0] = now
            with contextlib.suppress(Exception):  # the scheduler out of reach: go on, its timeout stops it
                told[0] = bool(event.is_set())
        return told[0]

    token = _STOP.set(asked)
    try:
        return function(item)
    finally:
        _STOP.reset(token)


class DaskBatch:
    """``outcomes(function, items)`` on the Dask cluster at ``scheduler`` (an address, or a
    ``distributed.Client``'s), each as it finishes; ``interrupt(why)`` after a signal: the
    items not yet started are cancelled, the running ones are told to stop (a Dask ``Event``
    their function sees through ``stop_asked``) and give their outcomes within STOP_WAIT_S,
    as a local worker does when sent SIGTERM. A worker thread cannot be killed: the function
    must also stop itself at its own deadline."""

    def __init__(self, scheduler: object, connect_timeout_s: float = 10.0) -> None:
        self.scheduler = scheduler
        self.connect_timeout_s = connect_timeout_s
        self.stop = f"labsim-batch-stop-{os.getpid()}-{clock.time_ns()}"  # the Event its functions watch
        self._client: Any = None
        self._futures: dict[Any, tuple[int, float]] = {}  # future -> (index, when submitted)
        self._stopped: list[Outcome] | None = None

    def outcomes(self, function: Callable[[Any], Any], items: list[Any]) -> Generator[Outcome, None, None]:
        from distributed import Client, as_completed

        owned = isinstance(self.scheduler, str)
        client: Any = Client(self.scheduler, timeout=self.connect_timeout_s) if owned else self.scheduler
        self._client = client
        try:
            threads = max(1, sum(client.nthreads().values()))
            pending = deque(enumerate(items))
            flow = as_completed()

            def submit() -> None:
                while pending and len(self._futures) < threads * PER_THREAD:
                    index, item = pending.popleft()
                    future = client.submit(_watched, function, item, self.stop, pure=False)
                    self._futures[future] = (index, clock.perf_counter())
                    flow.add(future)

            submit()
            for future in flow:
                if future not in self._futures:  # interrupted meanwhile: its outcome was given there
                    continue
                yield self._outcome(future, *self._futures.pop(future))
                submit()
        except KeyboardInterrupt as e:  # the runs in progress end as Ctrl-C ends a run; the caller asks for them
            self.interrupt(ending(e)[1])
            raise
        finally:
            self.interrupt("the end of the batch")  # stops whatever is left when the caller stops early
            if owned:
                client.close()

    @staticmethod
    def _outcome(future: Any, index: int, started: float) -> Outcome:
        took = clock.perf_counter() - started
        try:
            value = future.result()
        except Exception as e:  # a lost worker, too many retries: that item's outcome
            return Outcome(index, DIED, message=f"{type(e).__name__}: {e}", wall_s=took)
        return Outcome(index, DONE, value, wall_s=took)

    def interrupt(self, why: str) -> list[Outcome]:
        """Stop the items in progress and give their outcomes (see the class docstring): one that
        ended meanwhile is ``DONE``; one with no answer by then is ``STOPPED``, with ``why``.
        Further calls give the same outcomes."""
        if self._stopped is not None:
            return self._stopped
        got: list[Outcome] = []
        self._stopped = got
        if not self._futures or self._client is None:
            return got
        from distributed import Event
        from distributed import wait as dask_wait

        client, futures = self._client, dict(self._futures)
        self._futures.clear()
        with deaf():  # a second Ctrl-C must not lose the values being sent
            with contextlib.suppress(Exception):
                Event(self.stop, client=client).set()  # the running functions stop themselves
                running = {key for keys in client.processing().values() for key in keys}
                client.cancel([f for f in futures if f.status == "pending" and f.key not in running])
            with contextlib.suppress(Exception):
                dask_wait(list(futures), timeout=STOP_WAIT_S + STOP_POLL_S)
            for future, (index, started) in futures.items():
                outcome = self._outcome(future, index, started) if future.status == "finished" else None
                got.append(outcome if outcome is not None and outcome.kind == DONE
                           else Outcome(index, STOPPED, message=f"stopped by {why}"))
            with contextlib.suppress(Exception):
                client.cancel(list(futures))
        return got

