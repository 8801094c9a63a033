"""Many independent runs in worker processes or on Dask: the batch layer applications share.

It sits on the tick loop, below the applications that run a class or a grid (``labsim grade``
today; docs/decisions.md, "Grading a class", says why the sweep keeps its own pool for now).
``LocalBatch`` sends each item to one of N clean worker processes (multiprocessing's fork
server, labsim imported there once) and yields each outcome as it finishes; an item past its
time limit, or a worker that dies, costs that one process: it is killed, the item's outcome
says so, and a new worker takes its place. ``dask_outcomes`` does the same on a Dask
distributed cluster, where a worker thread cannot be killed, so the function must stop itself
at its own deadline. Workers ignore Ctrl-C; the caller's loop stops and the batch closes them,
keeping every outcome already yielded. The function and the items must pickle.
"""
from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time as clock
from collections import deque
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, cast

from labsim.backends import DEFAULT, REGISTRY
from labsim.foundation.files import allow, allowed_folders

POLL_S = 0.25  # how often the parent looks at the clock while every worker is busy
KILL_WAIT_S = 5.0
DONE, TIMEOUT, DIED = "done", "timeout", "died"
PER_THREAD = 2  # Dask: items submitted ahead per worker thread, so that Ctrl-C leaves little to cancel


@dataclass(frozen=True)
class Outcome:
    """What became of one item: ``DONE`` with the function's value, or ``TIMEOUT``/``DIED`` with why."""

    index: int
    kind: str
    value: Any = None
    message: str = ""
    wall_s: float = 0.0


@dataclass(frozen=True)
class _Failed:
    """What a worker sends back when the function raised."""

    message: str


def default_jobs() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _serve(conn: Connection, allowed: list[str]) -> None:
    """A worker's life: receive (function, item), send its value, until told to stop or orphaned."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    allow(allowed)  # a fork server's children do not see the parent's --allow-path
    while True:
        try:
            job = conn.recv()
        except (EOFError, OSError):
            return
        if job is None:
            return
        function, item = job
        try:
            value = function(item)
        except Exception as e:  # the function's own failure: that item's outcome, and the worker goes on
            value = _Failed(f"{type(e).__name__}: {e}")
        try:
            conn.send(value)
        except (BrokenPipeError, OSError):
            return


PRELOAD = ["labsim.runtime.batch", "labsim.runtime.run", REGISTRY[DEFAULT].partition(":")[0]]


def _context() -> multiprocessing.context.ForkServerContext | multiprocessing.context.SpawnContext:
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(PRELOAD)
    return context


@dataclass
class _Worker:
    process: multiprocessing.process.BaseProcess
    conn: Connection
    index: int | None = None
    started: float = 0.0


class LocalBatch:
    """``outcomes(function, items)``: each item's outcome as it finishes, on ``jobs`` processes."""

    def __init__(self, jobs: int, timeout_s: float | None = None) -> None:
        self.jobs = max(1, jobs)
        self.timeout_s = timeout_s
        self._context = _context()
        self._workers: list[_Worker] = []

    def _start(self) -> _Worker:
        parent, child = self._context.Pipe()
        process = self._context.Process(target=_serve, args=(child, [str(p) for p in allowed_folders()]),
                                        daemon=True, name="labsim-batch-worker")
        # a terminal's Ctrl-C reaches the whole process group: the worker ignores it from its
        # first instruction, and the parent stops it
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
        if w.process.is_alive():
            w.process.kill()
        w.process.join(KILL_WAIT_S)
        w.conn.close()
        self._workers[self._workers.index(w)] = self._start()

    def outcomes(self, function: Callable[[Any], Any], items: list[Any]) -> Iterator[Outcome]:
        """Run function(item) for every item; always stops every worker, also when the caller stops early."""
        pending = deque(enumerate(items))
        self._workers = [self._start() for _ in range(min(self.jobs, len(items)))]
        try:
            while pending or any(w.index is not None for w in self._workers):
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
                yield from self._collect()
        finally:
            self.close()

    def _collect(self) -> Iterator[Outcome]:
        busy = {w.conn: w for w in self._workers if w.index is not None}
        wait_s = POLL_S
        if self.timeout_s is not None and busy:
            first = min(w.started for w in busy.values())
            wait_s = min(wait_s, max(0.0, first + self.timeout_s - clock.perf_counter()))
        for conn in wait(list(busy), wait_s):
            w = busy[cast(Connection, conn)]
            index, took = cast(int, w.index), clock.perf_counter() - w.started
            w.index = None
            try:
                value = w.conn.recv()
            except (EOFError, OSError):
                code = w.process.exitcode if not w.process.is_alive() else None
                self._replace(w)
                yield Outcome(index, DIED, message=f"the worker process died while running it (exit code {code})",
                              wall_s=took)
                continue
            if isinstance(value, _Failed):
                yield Outcome(index, DIED, message=value.message, wall_s=took)
                continue
            yield Outcome(index, DONE, value, wall_s=took)
        if self.timeout_s is not None:
            now = clock.perf_counter()
            for w in list(self._workers):
                if w.index is not None and now - w.started > self.timeout_s:
                    index = w.index
                    self._replace(w)  # the only way to stop a run that does not return
                    yield Outcome(index, TIMEOUT, message=f"killed after its time limit of {self.timeout_s:g} s",
                                  wall_s=now - w.started)

    def close(self) -> None:
        """Stop every worker: idle ones are asked, busy ones are killed."""
        for w in self._workers:
            try:
                if w.index is None and w.process.is_alive():
                    w.conn.send(None)
                    w.process.join(1.0)
            except (BrokenPipeError, OSError):
                pass
            if w.process.is_alive():
                w.process.kill()
            w.process.join(KILL_WAIT_S)
            w.conn.close()
        self._workers = []


def dask_outcomes(scheduler: object, function: Callable[[Any], Any], items: list[Any],
                  connect_timeout_s: float = 10.0) -> Iterator[Outcome]:
    """Run function(item) for every item on the Dask cluster at ``scheduler`` (an address, or a
    ``distributed.Client``'s); outcomes as they finish. The function stops itself at its deadline."""
    from distributed import Client, as_completed

    client: Any = scheduler if not isinstance(scheduler, str) else Client(scheduler, timeout=connect_timeout_s)
    owned = isinstance(scheduler, str)
    try:
        threads = max(1, sum(client.nthreads().values()))
        pending = deque(enumerate(items))
        futures: dict[Any, tuple[int, float]] = {}
        flow = as_completed()

        def submit() -> None:
            while pending and len(futures) < threads * PER_THREAD:
                index, item = pending.popleft()
                future = client.submit(function, item, pure=False)
                futures[future] = (index, clock.perf_counter())
                flow.add(future)

        submit()
        for future in flow:
            index, started = futures.pop(future)
            took = clock.perf_counter() - started
            try:
                value = future.result()
            except Exception as e:  # a lost worker, too many retries: that item's outcome
                yield Outcome(index, DIED, message=f"{type(e).__name__}: {e}", wall_s=took)
            else:
                yield Outcome(index, DONE, value, wall_s=took)
            submit()
    finally:
        if owned:
            client.close()
