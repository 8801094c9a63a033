"""The Dask executor of a sweep: runs go to an existing Dask distributed cluster.

Each task carries its behaviour file and the world file it names (a *bundle*), so a worker
needs only labsim installed. The Dask task runs it in a process of its own
(runtime/sweep/isolated.py), which writes the bundle into a temporary folder, runs it with
runtime/sweep/grid.py ``run_task``, and names the files in the result as the user gave them, so a
row is the same as the local executor's. A trace (``--traces``) comes back compressed and
is written here. A run past ``--timeout-per-run`` is stopped from inside its tick loop, and its
process killed if it does not stop; each run's process has ``--memory-per-run``.

A run that kills its process (memory, a crash) is that run's ``runtime error`` row: the Dask
worker carries on, so no other run is lost or retried for it. A worker that is lost for
another reason (a machine reboots) takes its runs with it; the scheduler starts them again on
another worker (a run is deterministic, so a retry gives the same row), up to Dask's
``distributed.scheduler.allowed-failures`` times. The row counts its retries. Only a few runs
per worker thread are submitted at a time; Ctrl-C cancels them and sets a Dask ``Event`` that
stops the runs in progress within STOP_POLL_S.
"""
from __future__ import annotations

import dataclasses
import gzip
import json
import os
import pickle
import subprocess
import sys
import tempfile
import threading
import time as clock
from collections.abc import Callable, Generator
from dataclasses import dataclass, replace
from enum import Enum
from pathlib import Path
from typing import IO, Any, cast

from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.files import allowing, read_input, read_text, write_output
from labsim.runtime.sweep.grid import (
    COMPILE_ERROR,
    INTERRUPTED,
    RUNTIME_ERROR,
    TIMEOUT,
    FileInfo,
    Row,
    Task,
    row_of,
    run_task,
)

CONNECT_TIMEOUT_S = 10.0
STOP_POLL_S = 0.5  # how often a Dask task looks whether its sweep was stopped (one scheduler round trip)
STOP_GRACE_S = 3.0  # how long a stopped run has to end before its process is killed
KILL_GRACE_S = 5.0  # past its deadline, how long a run has to stop itself (between blocks of ticks)
PER_THREAD = 2  # runs submitted ahead per worker thread


@dataclass(frozen=True)
class Bundle:
    """A behaviour file and the world file it names, as bytes, at their paths relative to each other."""

    behaviour: str  # relative path of the behaviour file inside the bundle
    files: tuple[tuple[str, bytes], ...]
    base: str  # the folder inside the bundle that stands for the behaviour file's folder


def make_bundle(info: FileInfo) -> Bundle:
    """The files a run of ``info.path`` reads, laid out so that its world path still resolves."""
    behaviour = Path(info.path).resolve()
    ups = 0
    world_rel = ""
    if info.world_file:
        world_rel = os.path.relpath(Path(info.world_file).resolve(), behaviour.parent)
        ups = sum(part == ".." for part in Path(world_rel).parts)
    base = "/".join(["d"] * ups) or "."
    files = [(os.path.normpath(f"{base}/{behaviour.name}"), read_input(behaviour, "behaviour"))]
    if world_rel:
        files.append((os.path.normpath(f"{base}/{world_rel}"), read_input(info.world_file, "world")))
    return Bundle(files[0][0], tuple(files), base)


def run_here(task: Task, bundle: Bundle, deadline_s: float | None) -> dict[str, Any]:
    """In the run's own process: unpack the bundle, run the task, and give the files back their
    users' names."""
    with tempfile.TemporaryDirectory(prefix="labsim-run-") as d:
        for rel, data in bundle.files:
            target = Path(d) / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        local = str(Path(d) / bundle.behaviour)
        trace = str(Path(d) / "trace.csv") if task.trace else None
        with allowing(d):  # the files the sweep checked, laid out here as they were on its machine
            result = run_task(dataclasses.replace(task, trace=trace), path=local, deadline_s=deadline_s)
        folder = str(Path(d) / bundle.base) if bundle.base != "." else d
        mapping = [(local, task.file), (folder, str(Path(task.file).parent))]
        result = _renamed(result, mapping)
        if result["result"] is not None and trace is not None:
            result["result"] = replace(result["result"], trace=task.trace)
            text = read_text(trace, "trace")
            head, _, rest = text.partition("\n")
            for old, new in mapping:
                head = head.replace(json.dumps(old)[1:-1], json.dumps(new)[1:-1])
            result["trace_gz"] = gzip.compress((head + "\n" + rest).encode("utf-8"), compresslevel=3)
    return result


def run_bundled(task: Task, bundle: Bundle, deadline_s: float | None, memory_mb: int = 0,
                stop: str = "") -> dict[str, Any]:
    """On a Dask worker: the run in a process of its own (runtime/sweep/isolated.py), so that a
    run that kills its process is that run's failure and never the worker's. The process is
    stopped (as Ctrl-C stops a run) when the sweep sets the Dask Event named ``stop``, and
    killed KILL_GRACE_S after the deadline if its run did not stop itself."""
    started = clock.perf_counter()
    job = {"runner": run_here, "args": (task, bundle, deadline_s), "allowed": [], "memory_mb": memory_mb}
    proc = subprocess.Popen([sys.executable, "-m", "labsim.runtime.sweep.isolated"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    output: list[bytes] = []
    reader = threading.Thread(target=lambda: output.append(cast(IO[bytes], proc.stdout).read()), daemon=True)
    reader.start()
    try:
        with cast(IO[bytes], proc.stdin) as stdin:
            stdin.write(pickle.dumps(job, protocol=pickle.HIGHEST_PROTOCOL))
    except BrokenPipeError:  # it died before reading: its exit code says why
        pass
    ended = _wait(proc, started, deadline_s, stop)
    reader.join()
    result: dict[str, Any]
    if proc.returncode == 0 and output and output[0]:
        result = pickle.loads(output[0])  # written by labsim's own child process, above
    else:
        code = proc.returncode
        how = f"killed by signal {-code}" if code < 0 else f"exit code {code}"
        status, message = {"timeout": (TIMEOUT, f"killed {KILL_GRACE_S:g} s after --timeout-per-run "
                                                f"{deadline_s or 0:g} s"),
                           "stopped": (INTERRUPTED, "stopped by the sweep")}.get(
            ended, (RUNTIME_ERROR, f"the run's process died while running it ({how}); the Dask worker carries on"))
        result = {"status": status, "result": None, "message": message,
                  "task_time_s": clock.perf_counter() - started}
    result["worker"] = _worker_address()
    return result


def _wait(proc: subprocess.Popen[bytes], started: float, deadline_s: float | None, stop: str) -> str:
    """Wait for the run's process: '' when it ended by itself, 'stopped' when the sweep asked
    (Ctrl-C), 'timeout' when it outlived its deadline by KILL_GRACE_S."""
    ended = ""
    event = _event(stop)
    while True:
        try:
            proc.wait(timeout=STOP_POLL_S)
            return ended
        except subprocess.TimeoutExpired:
            pass
        if ended:
            proc.kill()  # it had STOP_GRACE_S to end its run
        elif event is not None and _is_set(event):
            ended = "stopped"
            proc.terminate()  # ends the run as Ctrl-C does
            proc_deadline = clock.perf_counter() + STOP_GRACE_S
            while proc.poll() is None and clock.perf_counter() < proc_deadline:
                clock.sleep(0.05)
        elif deadline_s is not None and clock.perf_counter() - started > deadline_s + KILL_GRACE_S:
            ended = "timeout"
            proc.kill()


def _event(name: str) -> Any:
    if not name:
        return None
    from distributed import Event

    try:
        return Event(name)
    except ValueError:  # not on a worker (called directly): nothing can ask it to stop
        return None


def _is_set(event: Any) -> bool:
    try:
        return bool(event.is_set())
    except Exception:  # the scheduler is gone: so is the sweep that wanted this run
        return True


def _renamed(value: Any, mapping: list[tuple[str, str]]) -> Any:
    """Every string in a result with the temporary paths replaced by the user's."""
    if isinstance(value, Enum):
        return value
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return replace(value, **{k: _renamed(v, mapping) for k, v in vars(value).items()})
    if isinstance(value, str):
        for old, new in mapping:
            value = value.replace(old, new)
        return value
    if isinstance(value, dict):
        return {k: _renamed(v, mapping) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return type(value)(_renamed(v, mapping) for v in value)
    return value


def _worker_address() -> str:
    from distributed import get_worker

    try:
        return str(get_worker().address)
    except ValueError:  # not on a worker (called directly)
        return ""


def _suspicious(dask_scheduler: Any, keys: list[str]) -> dict[str, int]:
    """On the scheduler: how many times each task was on a worker that died."""
    out = {}
    for key in keys:
        ts = dask_scheduler.tasks.get(key)
        if ts is not None and ts.suspicious:
            out[key] = int(ts.suspicious)
    return out


class DaskPool:
    """Runs tasks on a Dask cluster; ``results`` yields a row per task as each finishes."""

    def __init__(self, scheduler: str | None, info: dict[str, FileInfo], timeout_s: float | None = None,
                 memory_mb: int = 0):
        self.scheduler = scheduler
        self.info = info  # what the sweep learnt of each file: the world file it names
        self.timeout_s = timeout_s
        self.memory_mb = memory_mb  # each run's process's address space (pool.limit_memory); 0: none
        self.stop = f"labsim-sweep-stop-{os.getpid()}-{clock.time_ns()}"  # the Event its runs watch
        self.in_flight: dict[int, Task] = {}
        self._cancel: Callable[[], None] = lambda: None  # cancels the submitted runs, while there are any

    def interrupt(self, why: str) -> list[Row]:
        """Cancel the runs submitted and not finished (their rows: interrupted, ``why`` in the message)."""
        self._cancel()
        rows = [Row(t, INTERRUPTED, f"stopped by {why}") for t in self.in_flight.values()]
        self.in_flight.clear()
        return rows

    def _client(self) -> Any:
        from distributed import Client

        try:
            return Client(self.scheduler, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
        except (OSError, TimeoutError) as e:
            raise LabsimError([Diagnostic(f"--scheduler {self.scheduler}", f"cannot reach the Dask scheduler: {e}",
                                          notes=("start one with: dask scheduler (docs/sweep.md)",))]) from None

    def results(self, tasks: list[Task]) -> Generator[Row, None, None]:
        from distributed import as_completed

        client = self._client()
        try:
            threads = sum(client.nthreads().values()) or 1
            bundles = self._bundles(tasks)
            pending = list(reversed(tasks))
            running: dict[str, tuple[Task, Any]] = {}
            done = as_completed(loop=client.loop)

            def cancel() -> None:
                from distributed import Event

                Event(self.stop, client=client).set()  # the runs in progress stop themselves
                client.cancel([f for _, f in running.values()], force=True)
                running.clear()

            self._cancel = cancel

            def submit() -> None:
                while pending and len(running) < threads * PER_THREAD:
                    task = pending.pop()
                    bundle = bundles.get(task.file)
                    if isinstance(bundle, str):  # it does not compile here: it would not there either
                        done_rows.append(row_of(task, {"status": COMPILE_ERROR, "message": bundle,
                                                       "result": None, "task_time_s": 0.0}))
                        continue
                    future = client.submit(run_bundled, task, bundle, self.timeout_s, self.memory_mb, self.stop,
                                           pure=False,
                                           key=f"labsim-run-{task.index}-{os.getpid()}-{clock.time_ns()}")
                    running[future.key] = (task, future)
                    self.in_flight[task.index] = task
                    done.add(future)

            done_rows: list[Row] = []
            submit()
            while running or done_rows:
                yield from done_rows
                done_rows.clear()
                if not running:
                    submit()
                    continue
                batch = next(done.batches())
                retries = client.run_on_scheduler(_suspicious, keys=[f.key for f in batch])
                for future in batch:
                    task, _ = running.pop(future.key)
                    self.in_flight.pop(task.index, None)
                    yield self._row(task, future, retries.get(future.key, 0))
                submit()
        except KeyboardInterrupt:
            self._cancel()
            raise
        finally:
            self._cancel = lambda: None
            client.close()

    def _bundles(self, tasks: list[Task]) -> dict[str, Bundle | str]:
        out: dict[str, Bundle | str] = {}
        for f in dict.fromkeys(t.file for t in tasks):
            info = self.info.get(f) or FileInfo(f)
            if info.error:  # its first error, as a worker would find it (the world file may not travel)
                out[f] = info.error
                continue
            try:
                out[f] = make_bundle(info)
            except OSError as e:
                out[f] = f"{f}: error: cannot read the behaviour file: {e.strerror or e}"
        return out

    def _row(self, task: Task, future: Any, retries: int) -> Row:
        try:
            result = future.result()
        except Exception as e:  # KilledWorker: it lost every worker it was given; or a transport failure
            name = type(e).__name__
            message = (f"lost {retries or 'its'} worker(s) while running it; Dask gave up ({name})"
                       if name == "KilledWorker" else f"{name}: {e}")
            return row_of(task, {"status": RUNTIME_ERROR, "message": message, "result": None,
                                 "task_time_s": 0.0}, retries=retries)
        trace = result.pop("trace_gz", None)
        if trace is not None and task.trace:
            write_output(task.trace, gzip.decompress(trace))  # beside it, renamed into place
        row = row_of(task, result, result.get("worker", ""), retries)
        if retries:
            note = f"retried {retries} time(s) after a worker was lost"
            row.message = f"{row.message}; {note}" if row.message else note
        return row
