"""A submission's graded runs, on whichever worker takes them: its files, the grader's params, its seeds.

``labsim grade`` (runtime/grade/driver.py) makes a ``Job`` per submission once it has met the
assignment's contract (runtime/grade/contract.py). A job carries the behaviour file's bytes and
its world file's, so a local worker process and a Dask worker run it the same way: ``run_job``
lays them out in a scratch folder, reads and checks the file with the grader's params and
measured metrics once (``labsim.runtime.grade.measure.prepare_graded``), and for each seed
places the robots, runs under the assignment's budgets and stops itself at the per-run timeout,
handing back a ``SeedRun`` of plain values for each (never an exception). The seeds' runs share
one compile because a student's seeds go to one worker (decisions, "Grading speed"). The first
seed's run, when the job carries the pictures' renderer (for the feedback page), is recorded in
memory (``labsim.runtime.recording``) and drawn right there, so that only the map's and the
animation's bytes come back: no trace is written, sent or read again. Names of the scratch
folder never leave it.
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
from labsim.dsl.syntax.read import MetricDecl
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.files import allowing, read_input
from labsim.foundation.limits import Budgets
from labsim.runtime.batch import stop_asked
from labsim.runtime.grade.assignment import budget_words
from labsim.runtime.grade.measure import (
    SPEED_METRIC,
    is_measure_fault,
    measure_fault_words,
    prepare_graded,
    split_metrics,
)
from labsim.runtime.recording import Recording
from labsim.runtime.result import STOP_CONDITION, RunResult
from labsim.runtime.run import Behaviour, Run
from labsim.runtime.trace import Trace, read_trace

# what became of a run
RAN, TIMED_OUT, OVER_BUDGET, CRASHED, NOT_COMPILED = "ran", "timeout", "budget stop", "crash", "compile error"
STOPPED = "interrupted"  # a signal ended it before its end: not a result, so never cached nor graded
# a run and its world to a map (PNG) and a short animation (GIF): the pictures' renderer, handed over
Pictures = Callable[[Trace, World | None], tuple[bytes, bytes]]


@dataclass(frozen=True)
class Job:
    """One submission and its seeds, with everything a worker on another machine needs."""

    student: str
    seeds: tuple[int, ...]
    behaviour: str  # the file's path inside ``files``
    files: tuple[tuple[str, bytes], ...]  # (relative path, bytes): the behaviour and its world file
    shown_as: str  # the behaviour's path as the teacher gave it (messages name it so)
    params: tuple[tuple[str, str], ...]
    budgets: Budgets
    timeout_s: float
    pictures: Pictures | None = None  # draw the first seed's run (the feedback page's)
    measure: tuple[MetricDecl, ...] = ()  # the assignment's measured metrics (runtime/grade/measure.py)
    moved: bool = False  # measure the distance each robot drives (the built-in criterion moved)


@dataclass(frozen=True)
class SeedRun:
    """What one run did, as plain values (they go to JSON, the cache and the pages)."""

    seed: int
    status: str  # RAN, TIMED_OUT, OVER_BUDGET, CRASHED, NOT_COMPILED or STOPPED
    message: str = ""
    metrics: Mapping[str, float] = field(default_factory=dict)  # the student's own metrics
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
    measured: Mapping[str, float] = field(default_factory=dict)  # the assignment's measured metrics
    distance_m: float | None = None  # the least distance a robot drove (when the assignment asks)
    # the faults of the assignment's measured metrics (a division by zero in its formula): the
    # assignment's, never the student's, so no_faults does not read them
    measure_faults: tuple[str, ...] = ()


class _Deadline(Exception):
    pass


def run_job(job: Job) -> tuple[SeedRun, ...]:
    """Run one job's seeds in a scratch folder; a ``SeedRun`` for each whatever happens, up to
    the first that a signal stopped (the runs after it are not made)."""
    started = clock.perf_counter()
    with tempfile.TemporaryDirectory(prefix="labsim-grade-") as d:
        for rel, data in job.files:
            target = Path(d) / rel
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_bytes(data)
        local = str(Path(d) / job.behaviour)
        with allowing(d):
            out = _runs(job, local, started)

        def named(text: str) -> str:  # the scratch folder's names, as the teacher gave them
            return budget_words(text.replace(local, job.shown_as).replace(d, str(Path(job.shown_as).parent)))

    return tuple(replace(r, message=named(r.message), warnings=tuple(map(named, r.warnings)),
                         faults=tuple(map(named, r.faults)), logs=tuple(map(named, r.logs))) for r in out)


def _runs(job: Job, local: str, started: float) -> list[SeedRun]:
    try:
        prepared = prepare_graded(local, dict(job.params), job.budgets, job.measure, job.moved)
    except LabsimError as e:  # the same errors whatever the seed
        return [_not_compiled(seed, e, local, job.shown_as, started) for seed in job.seeds]
    out: list[SeedRun] = []
    for i, seed in enumerate(job.seeds):
        if i:
            started = clock.perf_counter()  # each run has the whole time limit; the first counts the compile
        try:
            # the stopping tick folded into the metrics whatever the file's format version (a
            # format-1 file's run leaves it out): the grader's metrics mean the same for everyone
            program = replace(prepared.program(seed), fold_stop=True)
        except LabsimError as e:
            out.append(_not_compiled(seed, e, local, job.shown_as, started))
            continue
        out.append(_run(job, Behaviour(program, job.budgets), seed, local, started, pictures=i == 0))
        if out[-1].status == STOPPED:
            break
    return out


def _not_compiled(seed: int, e: LabsimError, local: str, shown_as: str, started: float) -> SeedRun:
    diagnostics = tuple(_renamed(d, local, shown_as) for d in e.diagnostics)
    first = next((d for d in diagnostics if d.severity == "error"), diagnostics[0] if diagnostics else None)
    return SeedRun(seed, NOT_COMPILED, first.format().splitlines()[0] if first else str(e),
                   wall_time_s=clock.perf_counter() - started, diagnostics=diagnostics)


def _run(job: Job, behaviour: Behaviour, seed: int, local: str, started: float, pictures: bool) -> SeedRun:
    def took() -> float:
        return clock.perf_counter() - started

    limit = started + job.timeout_s

    def deadline(tick: int, sim_time_s: float) -> None:
        if clock.perf_counter() > limit:
            raise _Deadline(f"stopped after its time limit of {job.timeout_s:g} s, at {sim_time_s:.1f} s simulated")
        if stop_asked():  # on Dask, the grading was stopped: the run ends as Ctrl-C ends it
            raise KeyboardInterrupt

    world = behaviour.program.world
    draw = job.pictures if pictures else None
    # a mechanism's pictures read its joints from a trace's columns: such a run is traced to a file
    traced = str(Path(local).parent / "trace.csv") if draw and world.mechanism is not None else None
    recording = Recording() if draw and traced is None else None
    try:
        run = behaviour.bind(load_backend(DEFAULT), trace=traced, observers=[recording] if recording else [])
    except Exception as e:
        return SeedRun(seed, CRASHED, _exception_line(e), wall_time_s=took())
    try:
        result = run.run(progress=deadline)
    except _Deadline as e:
        return SeedRun(seed, TIMED_OUT, str(e), wall_time_s=took())
    except MemoryError:
        return SeedRun(seed, OVER_BUDGET, "it ran out of memory", wall_time_s=took())
    except Exception as e:  # a bug in labsim, or a simulator's failure: that student's row says so
        return SeedRun(seed, CRASHED, _exception_line(e), wall_time_s=took())
    finally:
        run.close()
    out = seed_run(seed, result, took())
    if draw is not None and out.status in (RAN, OVER_BUDGET):
        png, gif = _pictures(draw, run, recording, traced, local, world)
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
    """A finished run as plain values: the student's metrics apart from the grader's."""
    status = OVER_BUDGET if result.over_budget else STOPPED if result.interrupted else RAN
    values = {k: float(v) for k, v in result.metric_values().items()}  # a count is a float too, as the cache keeps it
    metrics, measured = split_metrics(values)
    faults = tuple(f for f in result.faults if not is_measure_fault(f))
    measure_faults = tuple(measure_fault_words(f) for f in result.faults if is_measure_fault(f))
    speeds = [float(r.metrics[SPEED_METRIC]) for r in result.robots.values() if SPEED_METRIC in r.metrics]
    distance = min((s * result.sim_time_s if s == s else 0.0 for s in speeds), default=None)
    return SeedRun(seed, status, result.over_budget, metrics, result.stop_reason == STOP_CONDITION,
                   faults, sum(r.contacts for r in result.robots.values()), result.warnings, result.logs,
                   tuple(f"{r.id}: {r.text}" for r in result.rules if r.ticks == 0), result.ticks,
                   result.sim_time_s, wall_s, measured=measured, distance_m=distance, measure_faults=measure_faults)


def _renamed(d: Diagnostic, local: str, shown: str) -> Diagnostic:
    return replace(d, path=d.path.replace(local, shown), message=d.message.replace(local, shown))


def _exception_line(e: BaseException) -> str:
    frames = traceback.extract_tb(e.__traceback__)
    where = f" (at {Path(frames[-1].filename).name}:{frames[-1].lineno})" if frames else ""
    return f"{type(e).__name__}: {e}{where}"


def make_job(student: str, behaviour: Path, world_file: str | None, seeds: tuple[int, ...],
             params: Mapping[str, str], budgets: Budgets, timeout_s: float, pictures: Pictures | None,
             measure: tuple[MetricDecl, ...] = (), moved: bool = False) -> Job:
    """A job for a submission whose world is built in (``world_file`` None) or a file beside it."""
    files = [(behaviour.name, read_input(behaviour, "behaviour"))]
    base = "."
    if world_file is not None:
        rel = Path(world_file).resolve().relative_to(behaviour.resolve().parent)
        files.append((str(rel), read_input(world_file, "world")))
    return Job(student, tuple(seeds), str(Path(base) / behaviour.name), tuple(files), str(behaviour),
               tuple(sorted(params.items())), budgets, timeout_s, pictures, measure, moved)
