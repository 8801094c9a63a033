"""The local executor of a sweep: N worker processes on this machine, one run at a time each.

A worker is a process forked from the sweep itself on Linux, once the sweep has imported
labsim and compiled its files, so that it starts with nothing to import (a fork server's fresh
interpreter put its third of a second of imports on a short sweep's critical path); it closes
the other workers' pipes it inherited, and the sweep forks only while it has no other thread.
Elsewhere, or when the process has other threads (a sweep started from a program that runs
some, as pytest-xdist does), a worker is forked from multiprocessing's fork server, a fresh
interpreter that has imported labsim and the simulator and never runs anything (``spawn``
where there is no fork server). A worker compiles and runs the tasks it is sent
(runtime/sweep/grid.py ``run_task``) and sends back each result. A run past its time limit, or a
worker that dies, costs that one process: it is killed, the run becomes a ``timeout`` or
``runtime error`` row, and a new worker takes its place; the other workers carry on.
Workers ignore Ctrl-C; the parent stops them.
"""
from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import sys
import threading
import time as clock
from collections import deque
from collections.abc import Generator, Iterator
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from typing import Any, cast

from labsim.backends import DEFAULT, REGISTRY
from labsim.foundation.files import allow, allowed_folders
from labsim.foundation.memory import limit_memory
from labsim.runtime.sweep.ending import Stopped, WorkerSignals, deaf, die_with_parent, ending
from labsim.runtime.sweep.grid import INTERRUPTED, RUNTIME_ERROR, TIMEOUT, Row, Task, row_of, run_task

POLL_S = 0.25  # how often the parent looks at the clock while every worker is busy
KILL_WAIT_S = 5.0  # how long to wait for a killed worker to be gone
# how long an interrupted sweep waits for its busy workers' rows: a run ends within one block of
# ticks (milliseconds) and then writes its trace's footer; a worker stuck elsewhere is killed
STOP_WAIT_S = 3.0


def default_jobs() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def _serve(conn: Connection, allowed: list[str], memory_mb: int = 0, inherited: tuple[int, ...] = ()) -> None:
    """A worker's life: receive a task, send its result, until told to stop (None), signalled
    (SIGTERM, SIGHUP: the run in progress ends as for Ctrl-C, its trace closed, and its row is
    sent) or orphaned (the parent-death signal). ``allowed``: the sweep's --allow-path folders (a
    fork server's children do not see its environment); ``memory_mb``: the worker's memory limit,
    0 for none; ``inherited``: the sweep's ends of the pipes, which a worker forked from the
    sweep holds copies of and closes (while open, a worker would not see its sweep go)."""
    signals = WorkerSignals()
    signals.install()
    for fd in inherited:
        with contextlib.suppress(OSError):
            os.close(fd)
    die_with_parent()
    allow(allowed)
    limit_memory(memory_mb)
    while not signals.asked:
        task = None
        try:
            signals.armed = True
            task = conn.recv()
            if task is None:
                return
            result = run_task(task)
        except Stopped as e:  # between runs, or while compiling: nothing to keep but the row
            if task is None:
                return
            result = {"status": INTERRUPTED, "result": None, "message": f"stopped by {e}", "task_time_s": 0.0}
        except (EOFError, OSError):
            return
        finally:
            signals.armed = False
        try:
            conn.send(result)
        except (BrokenPipeError, OSError):  # the parent is gone: so is the reason to go on
            return


# what every run imports: labsim and the default backend's module (named by the registry)
PRELOAD = ["labsim.runtime.sweep.pool", REGISTRY[DEFAULT].partition(":")[0]]


Context = (multiprocessing.context.ForkContext | multiprocessing.context.ForkServerContext
           | multiprocessing.context.SpawnContext)


def fork_here() -> bool:
    """Whether workers are forked from this process: on Linux, while it runs no other thread
    (a thread holding a lock at the fork would leave the worker's copy of the lock held)."""
    return sys.platform.startswith("linux") and threading.active_count() == 1


def _context() -> Context:
    """This process forked (``fork_here``), else the fork server, with labsim imported in it;
    ``spawn`` where there is none (Windows)."""
    if fork_here():
        return multiprocessing.get_context("fork")
    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload(PRELOAD)
    return context


def warm_up() -> None:
    """Start the fork server now, when workers will come from it, so that its imports (a fresh
    interpreter loading labsim and the simulator, about 0.3 s) overlap the sweep's own checks
    and compiles instead of following them. Workers forked from the sweep need none."""
    if not fork_here() and "forkserver" in multiprocessing.get_all_start_methods():
        from multiprocessing import forkserver

        _context()  # its preload named first
        forkserver.ensure_running()


@dataclass
class _Worker:
    process: multiprocessing.process.BaseProcess
    conn: Connection
    task: Task | None = None
    started: float = 0.0

    @property
    def name(self) -> str:
        return f"local:{self.process.pid}"


class LocalPool:
    """Runs tasks in ``jobs`` processes; ``results`` yields a row per task as each finishes."""

    def __init__(self, jobs: int, timeout_s: float | None = None, memory_mb: int = 0):
        self.jobs = jobs
        self.timeout_s = timeout_s
        self.memory_mb = memory_mb  # each worker's address space (limit_memory); 0: none
        self.in_flight: dict[int, Task] = {}
        self._context = _context()
        self._workers: list[_Worker] = []
        self._stopped: list[Row] | None = None  # the rows interrupt() gave, once it has run

    def _start(self) -> _Worker:
        parent, child = self._context.Pipe()
        allowed = [str(p) for p in allowed_folders()]
        # a forked worker's copies of the sweep's pipe ends (a fork server's children have none)
        inherited = tuple(c.fileno() for c in [parent, *(w.conn for w in self._workers)] if not c.closed) \
            if self._context.get_start_method() == "fork" else ()
        process = self._context.Process(target=_serve, args=(child, allowed, self.memory_mb, inherited),
                                        daemon=True, name="labsim-sweep-worker")
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

    def results(self, tasks: list[Task]) -> Generator[Row, None, None]:
        """Run every task; always stops every worker, also when the caller stops early."""
        pending = deque(tasks)
        self._workers = [self._start() for _ in range(min(self.jobs, len(tasks)))]
        try:
            while pending or self.in_flight:
                self._feed(pending)
                yield from self._collect()
        except KeyboardInterrupt as e:  # the runs in progress end as Ctrl-C ends a run; the caller asks for their rows
            self.interrupt(ending(e)[1])
            raise
        finally:
            self.close()

    def interrupt(self, why: str) -> list[Row]:
        """Stop the runs in progress and give their rows: each busy worker is sent SIGTERM, which
        ends its run as Ctrl-C ends ``labsim run`` (its trace closed with its footer, the row
        saying interrupted, with what the run did so far), and has STOP_WAIT_S to send it; then
        every worker is stopped. ``why`` ('Ctrl-C', 'SIGTERM', 'SIGHUP') goes in the rows'
        message. Further calls give the same rows."""
        if self._stopped is not None:
            return self._stopped
        rows: list[Row] = []
        busy = {w.conn: w for w in self._workers if w.task is not None and w.process.is_alive()}
        with deaf():  # a second Ctrl-C must not lose the rows being sent
            for w in busy.values():
                with contextlib.suppress(ProcessLookupError):
                    os.kill(cast(int, w.process.pid), signal.SIGTERM)
            deadline = clock.perf_counter() + STOP_WAIT_S
            while busy and clock.perf_counter() < deadline:
                for conn in wait(list(busy), max(0.0, deadline - clock.perf_counter())):
                    w = busy.pop(cast(Connection, conn))
                    try:
                        result: dict[str, Any] = w.conn.recv()
                    except (EOFError, OSError):  # it died instead: the row below
                        continue
                    task = cast(Task, w.task)
                    w.task = None
                    if result["status"] == INTERRUPTED:
                        result["message"] = f"stopped by {why}"
                    rows.append(self._done(task, result, w.name))
            self.close()
        rows += [Row(t, INTERRUPTED, f"stopped by {why}") for t in self.in_flight.values()]
        self.in_flight.clear()
        self._stopped = rows
        return rows

    def _feed(self, pending: deque[Task]) -> None:
        for w in self._workers:
            if w.task is None and pending:
                task = pending.popleft()
                try:
                    w.conn.send(task)
                except (BrokenPipeError, OSError):  # it died while idle: a new one takes the task
                    self._replace(w)
                    pending.appendleft(task)
                    continue
                w.task, w.started = task, clock.perf_counter()
                self.in_flight[task.index] = task

    def _collect(self) -> Iterator[Row]:
        busy = {w.conn: w for w in self._workers if w.task is not None}
        now = clock.perf_counter()
        wait_s = POLL_S
        if self.timeout_s is not None and busy:
            wait_s = min(wait_s, max(0.0, min(w.started for w in busy.values()) + self.timeout_s - now))
        for conn in wait(list(busy), wait_s):
            w = busy[cast(Connection, conn)]  # wait() hands back the objects it was given
            task = w.task
            assert task is not None
            try:
                result: dict[str, Any] = w.conn.recv()
            except (EOFError, OSError):
                code = w.process.exitcode if not w.process.is_alive() else None
                result = {"status": RUNTIME_ERROR, "result": None,
                          "message": f"the worker process died while running it (exit code {code})",
                          "task_time_s": clock.perf_counter() - w.started}
                name = w.name
                self._replace(w)
                yield self._done(task, result, name)
                continue
            w.task = None
            yield self._done(task, result, w.name)
        if self.timeout_s is not None:
            now = clock.perf_counter()
            for w in list(self._workers):
                if w.task is not None and now - w.started > self.timeout_s:
                    task, name = w.task, w.name
                    self._replace(w)  # the only way to stop a run that does not return
                    yield self._done(task, {"status": TIMEOUT, "result": None, "task_time_s": now - w.started,
                                            "message": f"killed after --timeout-per-run {self.timeout_s:g} s"}, name)

    def _done(self, task: Task, result: dict[str, Any], worker: str) -> Row:
        self.in_flight.pop(task.index, None)
        return row_of(task, result, worker)

    def close(self) -> None:
        """Stop every worker: idle ones are asked, busy ones are killed."""
        for w in self._workers:
            try:
                if w.task is None and w.process.is_alive():
                    w.conn.send(None)
                    w.process.join(1.0)
            except (BrokenPipeError, OSError):
                pass
            self._kill(w)
        self._workers = []
