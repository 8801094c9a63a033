"""One graded run, on whichever worker takes it: a submission's files, the grader's params, a seed.

``labsim grade`` (runtime/grade/driver.py) makes a ``Job`` per submission and seed once the
submission has met the assignment's contract (runtime/grade/contract.py). A job carries the
behaviour file's bytes and its world file's, so a local worker process and a Dask worker run it
the same way: ``run_job`` lays them out in a scratch folder, compiles with the grader's params
and the seed, runs under the assignment's budgets and stops itself at the per-run timeout, and
hands back a ``SeedRun`` of plain values (never an exception), with the trace, compressed, when
the job asks for it (the feedback page's map). Names of the scratch folder never leave it.
"""
from __future__ import annotations

import gzip
import tempfile
import time as clock
import traceback
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from labsim.backends import DEFAULT, load_backend
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.files import allowing, read_input, read_text
from labsim.foundation.limits import Budgets
from labsim.runtime.result import STOP_CONDITION, RunResult
from labsim.runtime.run import compile_behaviour

# what became of a run
RAN, TIMED_OUT, OVER_BUDGET, CRASHED, NOT_COMPILED = "ran", "timeout", "budget stop", "crash", "compile error"
STOPPED = "interrupted"  # a signal ended it before its end: not a result, so never cached nor graded


@dataclass(frozen=True)
class Job:
    """One submission x one seed, with everything a worker on another machine needs."""

    student: str
    seed: int
    behaviour: str  # the file's path inside ``files``
    files: tuple[tuple[str, bytes], ...]  # (relative path, bytes): the behaviour and its world file
    shown_as: str  # the behaviour's path as the teacher gave it (messages name it so)
    params: tuple[tuple[str, str], ...]
    budgets: Budgets
    timeout_s: float
    trace: bool = False  # send the trace back (the feedback page draws seed 1's)


@dataclass(frozen=True)
class SeedRun:
    """What one run did, as plain values (they go to JSON, the cache and the pages)."""

    seed: int
    status: str  # RAN, TIMED_OUT, OVER_BUDGET, CRASHED, NOT_COMPILED or STOPPED
    message: str = ""
    metrics: Mapping[str, float] = field(default_factory=dict)
    stopped: bool = False  # its stop condition held
    faults: tuple[str, ...] = ()
    collisions: int = 0
    warnings: tuple[str, ...] = ()
    logs: tuple[str, ...] = ()
    never_fired: tuple[str, ...] = ()  # "id: text" of the rules that never acted
    ticks: int = 0
    sim_time_s: float = 0.0
    wall_time_s: float = 0.0
    diagnostics: tuple[Diagnostic, ...] = ()
    trace_gz: bytes = b""  # the run's trace, gzip-compressed, when the job asked for it


class _Deadline(Exception):
    pass


def run_job(job: Job) -> SeedRun:
    """Run one job in a scratch folder; a ``SeedRun`` whatever happens."""
    started = clock.perf_counter()
    with tempfile.TemporaryDirectory(prefix="labsim-grade-") as d:
        for rel, data in job.files:
            target = Path(d) / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        local = str(Path(d) / job.behaviour)
        trace = str(Path(d) / "trace.csv") if job.trace else None
        with allowing(d):
            out = _run(job, local, trace, started)

        def named(text: str) -> str:  # the scratch folder's names, as the teacher gave them
            return text.replace(local, job.shown_as).replace(d, str(Path(job.shown_as).parent))

        out = replace(out, message=named(out.message), warnings=tuple(map(named, out.warnings)),
                      faults=tuple(map(named, out.faults)), logs=tuple(map(named, out.logs)))
        if trace is not None and out.status in (RAN, OVER_BUDGET) and Path(trace).exists():
            # level 1: a third of the size for a twelfth of level 9's time (about 12 ms, not 140, for a
            # 5-minute run's 0.8 MB); the bytes only cross a pipe or the cluster's network once
            out = replace(out, trace_gz=gzip.compress(named(read_text(trace, "trace")).encode(), 1, mtime=0))
    return out


def _run(job: Job, local: str, trace: str | None, started: float) -> SeedRun:
    def took() -> float:
        return clock.perf_counter() - started

    try:
        behaviour = compile_behaviour(local, dict(job.params), seed=job.seed, budgets=job.budgets)
    except LabsimError as e:
        diagnostics = tuple(_renamed(d, local, job.shown_as) for d in e.diagnostics)
        first = next((d for d in diagnostics if d.severity == "error"), diagnostics[0] if diagnostics else None)
        return SeedRun(job.seed, NOT_COMPILED, first.format().splitlines()[0] if first else str(e),
                       wall_time_s=took(), diagnostics=diagnostics)
    limit = started + job.timeout_s

    def deadline(tick: int, sim_time_s: float) -> None:
        if clock.perf_counter() > limit:
            raise _Deadline(f"stopped after its time limit of {job.timeout_s:g} s, at {sim_time_s:.1f} s simulated")

    try:
        run = behaviour.bind(load_backend(DEFAULT), trace=trace)
    except Exception as e:
        return SeedRun(job.seed, CRASHED, _exception_line(e), wall_time_s=took())
    try:
        result = run.run(progress=deadline)
    except _Deadline as e:
        return SeedRun(job.seed, TIMED_OUT, str(e), wall_time_s=took())
    except MemoryError:
        return SeedRun(job.seed, OVER_BUDGET, "it ran out of memory", wall_time_s=took())
    except Exception as e:  # a bug in labsim, or a simulator's failure: that student's row says so
        return SeedRun(job.seed, CRASHED, _exception_line(e), wall_time_s=took())
    finally:
        run.close()
    return seed_run(job.seed, result, took())


def seed_run(seed: int, result: RunResult, wall_s: float) -> SeedRun:
    """A finished run as plain values."""
    status = OVER_BUDGET if result.over_budget else STOPPED if result.interrupted else RAN
    metrics = {k: float(v) for k, v in result.metric_values().items()}  # a count is a float too, as the cache keeps it
    return SeedRun(seed, status, result.over_budget, metrics, result.stop_reason == STOP_CONDITION,
                   result.faults, sum(r.contacts for r in result.robots.values()), result.warnings, result.logs,
                   tuple(f"{r.id}: {r.text}" for r in result.rules if r.ticks == 0), result.ticks,
                   result.sim_time_s, wall_s)


def _renamed(d: Diagnostic, local: str, shown: str) -> Diagnostic:
    return replace(d, path=d.path.replace(local, shown), message=d.message.replace(local, shown))


def _exception_line(e: BaseException) -> str:
    frames = traceback.extract_tb(e.__traceback__)
    where = f" (at {Path(frames[-1].filename).name}:{frames[-1].lineno})" if frames else ""
    return f"{type(e).__name__}: {e}{where}"


def make_job(student: str, behaviour: Path, world_file: str | None, seed: int, params: Mapping[str, str],
             budgets: Budgets, timeout_s: float, trace: bool) -> Job:
    """A job for a submission whose world is built in (``world_file`` None) or a file beside it."""
    files = [(behaviour.name, read_input(behaviour, "behaviour"))]
    base = "."
    if world_file is not None:
        rel = Path(world_file).resolve().relative_to(behaviour.resolve().parent)
        files.append((str(rel), read_input(world_file, "world")))
    return Job(student, seed, str(Path(base) / behaviour.name), tuple(files), str(behaviour),
               tuple(sorted(params.items())), budgets, timeout_s, trace)

