"""One graded run, on whichever worker takes it: a submission's files, the grader's params, a seed.

``labsim grade`` (runtime/grade/driver.py) makes a ``Job`` per submission and seed once the
submission has met the assignment's contract (runtime/grade/contract.py). A job carries the
behaviour file's bytes and its world file's, so a local worker process and a Dask worker run it
the same way: ``run_job`` lays them out in a scratch folder, compiles with the grader's params
and the seed, runs under the assignment's budgets and stops itself at the per-run timeout, and
hands back a ``SeedRun`` of plain values (never an exception). A job that carries the pictures'
renderer (seed 1's, for the feedback page) records its run in memory (``labsim.runtime.recording``)
and draws the map and the animation right there, so that only their bytes come back: no trace is
written, sent or read again. Names of the scratch folder never leave it.
"""
from __future__ import annotations

import tempfile
import time as clock
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

from labsim.backends import DEFAULT, load_backend
from labsim.backends.scene.world import World
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.files import allowing, read_input
from labsim.foundation.limits import Budgets
from labsim.runtime.batch import stop_asked
from labsim.runtime.recording import Recording
from labsim.runtime.result import STOP_CONDITION, RunResult
from labsim.runtime.run import Run, compile_behaviour
from labsim.runtime.trace import Trace, read_trace

# what became of a run
RAN, TIMED_OUT, OVER_BUDGET, CRASHED, NOT_COMPILED = "ran", "timeout", "budget stop", "crash", "compile error"
STOPPED = "interrupted"  # a signal ended it before its end: not a result, so never cached nor graded
# a run and its world to a map (PNG) and a short animation (GIF): the pictures' renderer, handed over
Pictures = Callable[[Trace, World | None], tuple[bytes, bytes]]


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
    pictures: Pictures | None = None  # draw the run (the feedback page's seed 1)


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
    map_png: bytes = b""  # the run's pictures, when the job asked for them
    animation_gif: bytes = b""


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
        with allowing(d):
            out = _run(job, local, started)

        def named(text: str) -> str:  # the scratch folder's names, as the teacher gave them
            return text.replace(local, job.shown_as).replace(d, str(Path(job.shown_as).parent))

        out = replace(out, message=named(out.message), warnings=tuple(map(named, out.warnings)),
                      faults=tuple(map(named, out.faults)), logs=tuple(map(named, out.logs)))
    return out


def _run(job: Job, local: str, started: float) -> SeedRun:
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
        if stop_asked():  # on Dask, the grading was stopped: the run ends as Ctrl-C ends it
            raise KeyboardInterrupt

    world = behaviour.program.world
    # a mechanism's pictures read its joints from a trace's columns: such a run is traced to a file
    traced = str(Path(local).parent / "trace.csv") if job.pictures and world.mechanism is not None else None
    recording = Recording() if job.pictures and traced is None else None
    try:
        run = behaviour.bind(load_backend(DEFAULT), trace=traced, observers=[recording] if recording else [])
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
    out = seed_run(job.seed, result, took())
    if job.pictures is not None and out.status in (RAN, OVER_BUDGET):
        png, gif = _pictures(job.pictures, run, recording, traced, local, world)
        out = replace(out, map_png=png, animation_gif=gif)
    return out


def _pictures(draw: Pictures, run: Run, recording: Recording | None, traced: str | None, local: str,
              world: World) -> tuple[bytes, bytes]:
    """The run's map and animation; none when they cannot be drawn (the page shows the rest)."""
    try:
        trace = recording.trace(local, run.header()) if recording is not None else read_trace(str(traced))
        return draw(trace, world)
    except Exception:
        return b"", b""


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
             budgets: Budgets, timeout_s: float, pictures: Pictures | None) -> Job:
    """A job for a submission whose world is built in (``world_file`` None) or a file beside it."""
    files = [(behaviour.name, read_input(behaviour, "behaviour"))]
    base = "."
    if world_file is not None:
        rel = Path(world_file).resolve().relative_to(behaviour.resolve().parent)
        files.append((str(rel), read_input(world_file, "world")))
    return Job(student, seed, str(Path(base) / behaviour.name), tuple(files), str(behaviour),
               tuple(sorted(params.items())), budgets, timeout_s, pictures)

