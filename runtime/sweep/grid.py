"""Sweeps: many runs of one or more behaviour files, over a grid of parameters and seeds.

``labsim sweep`` builds the grid here (every combination of ``--set`` values x every seed x
every file), checks it before anything runs, hands the tasks to an executor (a local pool of
processes, runtime/sweep/pool.py, or a Dask cluster, runtime/sweep/dask_pool.py), and turns what comes
back into rows: one per run, with the run's ``RunResult`` inside (its JSON is ``labsim run --json``'s). The
comparison of the rows is runtime/sweep/stats.py; writing them out and drawing them is
runtime/sweep/output.py.

A run is executed by ``run_task`` wherever the executor puts it; it never raises for a
behaviour's fault: a file that does not compile, a run that raises, are rows with a status.
"""
from __future__ import annotations

import itertools
import math
import time as clock
import traceback
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from labsim.backends import DEFAULT, load_backend
from labsim.backends.scene.world_names import builtin_name
from labsim.dsl.compile import file_seed
from labsim.dsl.emit.program import Program
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.foundation.numbers import WHOLE_LIMIT
from labsim.runtime.labs import behaviour_path
from labsim.runtime.result import RunResult
from labsim.runtime.run import Behaviour, compile_behaviour

OK, COMPILE_ERROR, RUNTIME_ERROR = "ok", "compile error", "runtime error"
TIMEOUT, INTERRUPTED = "timeout", "interrupted"
STATUSES = (OK, COMPILE_ERROR, RUNTIME_ERROR, TIMEOUT, INTERRUPTED)
# runs in one sweep (docs/sweep.md, "Limits"): days of runs on a class's machines, and a grid of
# tasks that fits in memory (about 30 MB); a typo such as 0:1000:0.00001 is caught before it starts
MAX_GRID = 100_000
MAX_INSPECTED = 8  # combinations of the settings a file is compiled with before the sweep, until one compiles


@dataclass(frozen=True)
class Setting:
    """One ``--set``: a parameter and the values (as typed, the way ``--set`` passes them) to try."""

    name: str
    values: tuple[str, ...]


@dataclass(frozen=True)
class Task:
    """One run of the grid: which file, which parameter values, which seed, where its trace goes."""

    index: int
    file: str
    settings: tuple[tuple[str, str], ...]
    seed: int
    trace: str | None = None
    budgets: Budgets = DEFAULT_BUDGETS  # what the run may cost (docs/security.md)

    @property
    def label(self) -> str:
        """The settings as ``front=0.5 side=0.3`` ('' when the sweep sets none)."""
        return " ".join(f"{k}={v}" for k, v in self.settings)


@dataclass
class Row:
    """What one run gave: its status, a message when it did not finish, and its result."""

    task: Task
    status: str
    message: str = ""
    result: RunResult | None = None
    task_time_s: float = 0.0  # in the worker: compile and run, seconds
    worker: str = ""
    retries: int = 0  # times it was started again after its worker was lost

    @property
    def failed(self) -> bool:
        return self.status != OK


@dataclass(frozen=True)
class FileInfo:
    """What the sweep learns about a file before running it (from one compile)."""

    path: str
    seed: int = 0
    params: tuple[str, ...] = ()
    metrics: tuple[str, ...] = ()
    error: str = ""  # the first compile error, one line; '' when it compiles
    world_file: str = ""  # a world file it names ('' for a built-in world)


# -- the grid ---------------------------------------------------------------------------------

def parse_setting(text: str) -> Setting:
    """``NAME=V1,V2,...`` or ``NAME=START:STOP:STEP`` (STOP included when the steps reach it)."""
    where = f"--set {text}"
    name, eq, spec = text.partition("=")
    name, spec = name.strip(), spec.strip()
    if not eq or not name or not spec:
        raise LabsimError([Diagnostic(where, "--set takes NAME=V1,V2,... or NAME=START:STOP:STEP, "
                                             "e.g. --set front=0.5,1.0")])
    if spec.startswith("["):  # a list parameter (format 1.3): its commas are not a sweep's
        raise LabsimError([Diagnostic(_short(where), f"a sweep takes numbers or true/false for '{name}', not a list: "
                                             "a list parameter is not swept", notes=(
            f"sweep a number that picks a row instead, as in --set route=0,1,2 with {name}[route] in the file; "
            "or run each list with labsim run --set",))])
    if ":" not in spec:
        values = tuple(v.strip() for v in spec.split(","))
        if any(not v for v in values):
            raise LabsimError([Diagnostic(where, "an empty value in the list; separate values with commas")])
        return Setting(name, values)
    parts = spec.split(":")
    try:
        start, stop, step = (float(p) for p in parts) if len(parts) == 3 else (math.nan,) * 3
    except ValueError:
        start = stop = step = math.nan
    if not all(math.isfinite(v) for v in (start, stop, step)):
        raise LabsimError([Diagnostic(where, "a range is START:STOP:STEP with three finite numbers, "
                                             "e.g. front=0.5:1.0:0.25")])
    if step <= 0 or stop < start:
        raise LabsimError([Diagnostic(where, "a range needs STOP >= START and a positive STEP")])
    steps = (stop - start) / step  # inf when the numbers are huge: no count to floor
    if not steps < MAX_GRID:
        shown = f"{math.floor(steps) + 1:,}" if steps < 10 * MAX_GRID else f"more than {10 * MAX_GRID:,}"
        raise LabsimError([Diagnostic(where, f"this range has {shown} values; a sweep has at most "
                                             f"{MAX_GRID:,} runs (docs/sweep.md, \"Limits\")")])
    # STOP is reached when the steps come within rounding of it (0.5:0.5000001:1e-10 is 1,001 values)
    return Setting(name, range_values(where, start, step, math.floor(steps * (1 + 1e-9) + 1e-9) + 1))


def range_values(where: str, start: float, step: float, count: int) -> tuple[str, ...]:
    """The values of a range as text, with 10 significant digits, or more (up to 17, which tells
    any two floats apart) when 10 would show two values the same: each run's value is the one
    its row shows. A step too small for the numbers to differ at all is refused."""
    numbers = [start + k * step for k in range(count)]
    if len(set(numbers)) < count:
        raise LabsimError([Diagnostic(where, f"the step {step:g} is too small to change a number near {start:g}; "
                                             "give a larger STEP")])
    for digits in range(10, 18):
        values = tuple(f"{v:.{digits}g}" for v in numbers)
        if len(set(values)) == count:
            return values
    return tuple(repr(v) for v in numbers)  # not reached: 17 digits tell any two floats apart


def parse_seeds(text: str) -> tuple[int, ...]:
    """``1-20``, ``1,2,5`` or ``1-5,9``: the seeds, in order, without repeats; at most MAX_GRID
    of them, counted before any range is expanded (linear in the seeds given)."""
    seeds: dict[int, None] = {}  # ordered, and a repeat is found in constant time
    for part in text.split(","):
        lo, dash, hi = part.strip().partition("-")
        try:
            first, last = int(lo), int(hi) if dash else int(lo)
        except ValueError:
            raise LabsimError([Diagnostic(f"--seeds {text[:80]}",
                                          "seeds are whole numbers: 1-20, 1,2,5 or 1-5,9")]) from None
        if first < 0 or last < first or last > WHOLE_LIMIT:
            raise LabsimError([Diagnostic(f"--seeds {text[:80]}", f"'{part.strip()[:40]}' is not a range of seeds "
                                                                  "(0 to 2**53, low-high)")])
        if len(seeds) + (last - first) >= MAX_GRID:
            raise LabsimError([Diagnostic(f"--seeds {text[:80]}", f"too many seeds; a sweep has at most "
                                                                  f"{MAX_GRID:,} runs (docs/sweep.md, \"Limits\")")])
        seeds.update(dict.fromkeys(range(first, last + 1)))
    return tuple(seeds)


def grid_size(files: list[str], settings: list[Setting], seeds: tuple[int, ...] | None) -> int:
    """How many runs the grid has, counted without building it."""
    return len(files) * math.prod(len(s.values) for s in settings) * (len(seeds) if seeds is not None else 1)


def check_grid_size(files: list[str], settings: list[Setting], seeds: tuple[int, ...] | None) -> None:
    """A grid over MAX_GRID runs is refused before anything is compiled or run."""
    size = grid_size(files, settings, seeds)
    if size > MAX_GRID:
        parts = [f"{len(files)} file{'s' if len(files) != 1 else ''}",
                 *(f"{len(s.values):,} values of {s.name}" for s in settings),
                 f"{len(seeds):,} seeds" if seeds is not None else "1 seed"]
        raise LabsimError([Diagnostic("labsim sweep", f"this grid has {size:,} runs ({' x '.join(parts)}); "
                                                      f"a sweep has at most {MAX_GRID:,}",
                                      notes=("split it into several sweeps, or give fewer values or seeds",))])


def inspect_files(files: list[str], settings: list[Setting],
                  budgets: Budgets = DEFAULT_BUDGETS) -> dict[str, FileInfo]:
    """Compile every file once (with the first value of each setting) before anything runs.

    A file that does not compile is noted (its runs become compile-error rows); a ``--set``
    the file does not accept (an unknown name, a value of the wrong type) is the user's
    mistake for the whole sweep: LabsimError, with the file's parameters listed.
    """
    usage: list[Diagnostic] = []
    out: dict[str, FileInfo] = {}
    for f in files:
        if f in out:
            continue
        program, error = _first_compiled(f, settings, budgets)
        if program is None:
            assert error is not None
            bad = [d for d in error.diagnostics if d.path.startswith("--set ")]
            if bad and not [d for d in error.diagnostics if d.severity == "error" and d not in bad]:
                usage += [Diagnostic(f"{_short(d.path)} (in {f})", d.message, notes=d.notes) for d in bad]
            out[f] = FileInfo(f, file_seed(behaviour_path(f)), error=first_error(error))
            continue
        world = Path(program.world.source)
        out[f] = FileInfo(f, program.seed, tuple(program.params), tuple(program.metric_names),
                          world_file="" if builtin_name(world) or not world.is_file() else str(world))
        usage += _check_values(f, settings, program.params)
    if usage:
        raise LabsimError(usage)
    return out


def _first_compiled(f: str, settings: list[Setting], budgets: Budgets) -> tuple[Program | None, LabsimError | None]:
    """The file compiled with the first combination of the settings that compiles, of the first
    MAX_INSPECTED in the grid's order (a value that fails, as ``--set r=-1,2,3`` with a range that
    must be more than 0, fails its own rows only: the others run with the file's seed); else None
    and the first combination's errors."""
    first: LabsimError | None = None
    combos = itertools.product(*[[(s.name, v) for v in s.values] for s in settings])
    for combo in itertools.islice(combos, MAX_INSPECTED):
        try:
            return compile_behaviour(f, dict(combo), budget=budgets).program, None
        except LabsimError as e:
            if first is None:
                first = e
            if any(d.path.startswith("--set ") for d in e.diagnostics):  # a --set the file lacks: so do all
                break
    return None, first


def _short(where: str, at_most: int = 80) -> str:
    """A ``--set`` as a message's place: a 5,000-digit value is shown by its start."""
    return where if len(where) <= at_most else where[:at_most] + "..."


def _check_values(f: str, settings: list[Setting], params: Mapping[str, float | bool]) -> list[Diagnostic]:
    """Each value of each setting must suit the parameter's type (number or true/false)."""
    problems = []
    for s in settings:
        current = params.get(s.name)
        for value in s.values:
            if isinstance(current, bool):
                ok = value.lower() in ("true", "false")
            else:
                try:
                    ok = math.isfinite(float(value))
                except ValueError:
                    ok = False
            if not ok:
                kind = "true or false" if isinstance(current, bool) else "a finite number"
                where = _short(f"--set {s.name}={value}")
                problems.append(Diagnostic(f"{where} (in {f})", f"parameter '{s.name}' is {kind}"))
    return problems


def first_error(e: LabsimError) -> str:
    """A compile failure on one line: the first error, ``path:line:col: error: message``."""
    errors = [d for d in e.diagnostics if d.severity == "error"] or e.diagnostics
    own = [d for d in errors if not d.path.startswith("--")]  # the file's own before a --set it lacks
    errors = own or errors
    return errors[0].format().splitlines()[0] if errors else str(e)


def grid(files: list[str], settings: list[Setting], seeds: tuple[int, ...] | None,
         info: dict[str, FileInfo], traces: str | None = None, budgets: Budgets = DEFAULT_BUDGETS) -> list[Task]:
    """Every file x every combination of the settings x every seed (default: the file's own)."""
    tasks: list[Task] = []
    combos = list(itertools.product(*[[(s.name, v) for v in s.values] for s in settings]))
    for f in files:
        for combo in combos:
            for seed in seeds if seeds is not None else (info[f].seed,):
                trace = None
                if traces is not None:
                    trace = str(Path(traces) / trace_name(len(tasks), f, combo, seed))
                tasks.append(Task(len(tasks), f, tuple(combo), seed, trace, budgets))
    return tasks


def trace_name(index: int, file: str, combo: tuple[tuple[str, str], ...], seed: int) -> str:
    """``0003-wall_follow-front=0.5-seed2.csv``: unique (the index), and readable."""
    parts = [f"{index:04d}", Path(file).stem, *(f"{k}={v}" for k, v in combo), f"seed{seed}"]
    return "-".join(p.replace("/", "_") for p in parts) + ".csv"


# -- one run, in a worker ---------------------------------------------------------------------

def compile_seeded(path: str, overrides: dict[str, str], seed: int,
                   budgets: Budgets = DEFAULT_BUDGETS) -> Behaviour:
    """Compile a file with its seed replaced, as ``labsim run --seed`` does."""
    return compile_behaviour(path, overrides, seed=seed, budget=budgets)


class RunTimeout(Exception):
    """A run went past its deadline (raised from inside the tick loop)."""


def run_task(task: Task, path: str | None = None, deadline_s: float | None = None) -> dict[str, Any]:
    """Compile and run one task; a dict (status, message, result, task_time_s), never an exception.

    ``path`` is where the file is on this machine when it differs from ``task.file``;
    ``deadline_s`` stops the run from inside its loop after that many seconds (the local pool
    kills the process instead; a Dask worker cannot be killed for one task).
    """
    started = clock.perf_counter()

    def done(status: str, message: str = "", result: RunResult | None = None) -> dict[str, Any]:
        return {"status": status, "message": message, "result": result,
                "task_time_s": clock.perf_counter() - started}

    try:
        behaviour = compile_seeded(path or task.file, dict(task.settings), task.seed, task.budgets)
    except LabsimError as e:
        return done(COMPILE_ERROR, first_error(e))
    except Exception as e:  # a bug in labsim must not stop the batch: the row says what it was
        return done(COMPILE_ERROR, _exception_line(e))
    progress: Callable[[int, float], None] | None = None
    if deadline_s is not None:
        limit = started + deadline_s

        def progress(tick: int, sim_time_s: float) -> None:
            if clock.perf_counter() > limit:
                raise RunTimeout(f"stopped after {deadline_s:g} s at tick {tick} ({sim_time_s:.1f} s simulated)")

    try:
        run = behaviour.bind(load_backend(DEFAULT), trace=task.trace)
    except Exception as e:
        return done(RUNTIME_ERROR, first_error(e) if isinstance(e, LabsimError) else _exception_line(e))
    try:
        result = run.run(progress=progress)
    except RunTimeout as e:
        return done(TIMEOUT, str(e))
    except Exception as e:
        return done(RUNTIME_ERROR, first_error(e) if isinstance(e, LabsimError) else _exception_line(e))
    finally:
        run.close()
    if result.over_budget:  # stopped by a budget: a failed row, with what it did up to there
        return done(RUNTIME_ERROR, result.over_budget, result)
    return done(INTERRUPTED if result.interrupted else OK, "", result)


def _exception_line(e: BaseException) -> str:
    """An unexpected exception on one line, with where it was raised."""
    frames = traceback.extract_tb(e.__traceback__)
    where = f" (at {Path(frames[-1].filename).name}:{frames[-1].lineno})" if frames else ""
    return f"{type(e).__name__}: {e}{where}"


def row_of(task: Task, result: dict[str, Any], worker: str = "", retries: int = 0) -> Row:
    return Row(task, result["status"], result["message"], result["result"], result["task_time_s"], worker, retries)


# -- rows as flat records ---------------------------------------------------------------------

@dataclass
class Columns:
    """The CSV columns of a sweep: fixed ones, then the settings, then every metric seen."""

    settings: list[str] = field(default_factory=list)
    metrics: list[str] = field(default_factory=list)

    def names(self) -> list[str]:
        return (["file", "name", "sha256", *self.settings, "seed", "status", "message", "ticks", "sim_time_s",
                 "wall_time_s", "task_time_s", "contacts", "clamped_ticks", "faults", "logs", "stop_reason",
                 *self.metrics, "retries", "worker"])


def flat(row: Row) -> dict[str, Any]:
    """One row as a flat record: the figures a spreadsheet wants (see Columns.names)."""
    out: dict[str, Any] = {"file": row.task.file, **dict(row.task.settings), "seed": row.task.seed,
                           "status": row.status, "message": row.message, "task_time_s": round(row.task_time_s, 6),
                           "retries": row.retries, "worker": row.worker}
    s = row.result
    if s is not None:
        robots = s.robots.values()
        out.update(name=s.name, sha256=s.sha256, ticks=s.ticks, sim_time_s=s.sim_time_s,
                   wall_time_s=round(s.wall_time_s, 6), contacts=sum(r.contacts for r in robots),
                   clamped_ticks=sum(r.clamped_ticks for r in robots), faults=len(s.faults),
                   logs=len(s.logs),
                   stop_reason=s.stop_reason)
        out.update(s.metric_values())
    return out
