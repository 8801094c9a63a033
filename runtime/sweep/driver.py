"""``labsim sweep`` from options to exit code: check everything, run the grid, show and write it.

The command line's options for it (``add_sweep_arguments``) live here too: the command line
(runtime/cli/parser.py) imports this module only when the command is ``sweep``.

Everything a user can get wrong (a ``--set`` the files do not take, an output that cannot be
written, a missing optional extra) is found here before the first run starts, and reported
as a LabsimError (exit 2). Then the tasks go to the chosen executor; each row as it comes
moves the progress bar; Ctrl-C stops the executor, marks the runs in progress as
interrupted, and everything done so far is still written.
"""
from __future__ import annotations

import argparse
import importlib.util
import os
import sys
from collections.abc import Generator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

from labsim.foundation import options
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.foundation.exits import EXIT_FAILED, EXIT_OK
from labsim.foundation.files import check_output
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.runtime.ending import batch_signals, ending, exit_code
from labsim.runtime.summary_json import check_json_output
from labsim.runtime.sweep.grid import (
    FileInfo,
    Row,
    Setting,
    Task,
    check_grid_size,
    grid,
    inspect_files,
    parse_seeds,
    parse_setting,
)
from labsim.runtime.sweep.output import (
    SweepProgress,
    failures,
    format_comparison,
    status_counts,
    sweep_json,
    write_csv,
    write_json,
)
from labsim.runtime.sweep.stats import comparison

# A run's real time unless --timeout-per-run says otherwise: a file within every budget can still
# take over an hour (a camera per robot at the pixel budget, every tick), which a class's sweep
# should not wait for; the labs take seconds (docs/sweep.md, "Limits").
DEFAULT_TIMEOUT_S = 600.0
# A local worker's address space: labsim with OpenCV and a camera run maps about 650 MB; a
# run that needs three times that is a run gone wrong (docs/sweep.md, "Limits").
DEFAULT_MEMORY_MB = 2048


@dataclass
class SweepOptions:
    """The command line's options, as ``labsim sweep --help`` describes them."""

    files: list[str]
    sets: list[str] = field(default_factory=list)
    seeds: str | None = None
    jobs: int | None = None
    executor: str = "local"
    scheduler: str | None = None
    output: str | None = None
    json: str | None = None
    plot: str | None = None
    timeout_s: float | None = DEFAULT_TIMEOUT_S
    traces: str | None = None
    maximize: list[str] = field(default_factory=list)
    progress: bool | None = None
    budgets: Budgets = DEFAULT_BUDGETS  # every run's (docs/security.md)
    memory_mb: int = DEFAULT_MEMORY_MB  # each local worker's address space; 0: no limit


class Executor(Protocol):
    def results(self, tasks: list[Task]) -> Generator[Row, None, None]: ...

    def interrupt(self, why: str) -> list[Row]: ...


def _fail(where: str, message: str, *notes: str) -> LabsimError:
    return LabsimError([Diagnostic(where, message, notes=tuple(notes))])


def check_options(o: SweepOptions) -> tuple[list[Setting], tuple[int, ...] | None]:
    """Every option's mistake, before anything runs."""
    settings = [parse_setting(s) for s in o.sets]
    names = [s.name for s in settings]
    for name in names:
        if names.count(name) > 1:
            raise _fail(f"--set {name}", "this parameter is set twice; give all its values in one --set")
    seeds = parse_seeds(o.seeds) if o.seeds is not None else None
    check_grid_size(o.files, settings, seeds)
    if o.jobs is not None and o.jobs < 1:
        raise _fail("-j", "give 1 or more processes")
    if o.timeout_s is not None and not o.timeout_s > 0:
        raise _fail("--timeout-per-run", "give a positive number of seconds")
    if o.memory_mb < 0:
        raise _fail("--memory-per-run", "give megabytes, or 0 for no limit")
    if o.executor == "dask":
        if not o.scheduler:
            raise _fail("--executor dask", "needs --scheduler tcp://HOST:8786, the address of a running Dask "
                                           "scheduler (docs/sweep.md)")
        if importlib.util.find_spec("distributed") is None:
            raise _fail("--executor dask", "needs Dask's distributed scheduler, which is not installed",
                        "install it with: pip install 'labsim[dask]'")
    elif o.scheduler:
        raise _fail("--scheduler", "only --executor dask takes a scheduler")
    inputs = [Path(f) for f in o.files]
    for option, path in (("-o", o.output), ("--json", o.json), ("--plot", o.plot)):
        if path is not None and path != "-":
            check_json_output(path, inputs, option)
    if o.plot is not None:
        if not o.plot.lower().endswith((".png", ".svg", ".pdf")):
            raise _fail(f"--plot {o.plot}", "give a .png, .svg or .pdf file")
        if importlib.util.find_spec("matplotlib") is None:
            raise _fail("--plot", "needs matplotlib, which is not installed",
                        "it is one of labsim's dependencies: reinstall labsim (pip install labsim)")
    if o.traces is not None:
        if not Path(o.traces).is_dir():
            raise _fail(f"--traces {o.traces}", "no such folder; create it first")
        if not os.access(o.traces, os.W_OK):
            raise _fail(f"--traces {o.traces}", "cannot write there (permission denied)")
    return settings, seeds


def check_outputs(o: SweepOptions, info: dict[str, FileInfo], tasks: list[Task]) -> None:
    """No output over an input of the sweep (a behaviour, or the world file one names), by the
    check ``labsim run`` makes, once the files are compiled and their worlds known: a run's
    trace in ``--traces`` too."""
    inputs = [Path(f) for f in o.files] + [Path(i.world_file) for i in info.values() if i.world_file]
    for option, path in (("-o", o.output), ("--json", o.json), ("--plot", o.plot)):
        if path is not None and path != "-":
            check_output(path, inputs, option)
    for task in tasks:
        if task.trace is not None:
            check_output(task.trace, inputs, "--traces")


def _executor(o: SweepOptions, info: dict[str, FileInfo]) -> Executor:
    if o.executor == "dask":
        from labsim.runtime.sweep.dask_pool import DaskPool

        return DaskPool(o.scheduler, info, timeout_s=o.timeout_s, memory_mb=o.memory_mb)
    from labsim.runtime.sweep.pool import LocalPool, default_jobs

    return LocalPool(o.jobs or default_jobs(), o.timeout_s, o.memory_mb)


def run_sweep(o: SweepOptions, out: Any = None) -> int:
    """Run a sweep; print its table; write its files. The exit code: 0, 1 (a run failed), or
    128 + the signal that ended it (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP; docs/sweep.md)."""
    out = out or sys.stdout
    settings, seeds = check_options(o)
    if o.executor == "local":
        from labsim.runtime.sweep.pool import warm_up

        warm_up()  # its imports overlap the compiles below
    info = inspect_files(o.files, settings, o.budgets)
    if o.maximize:
        known = {m for i in info.values() for m in i.metrics}
        for m in o.maximize:
            if known and m not in known:
                raise _fail(f"--maximize {m}", f"no metric '{m}'", "metrics: " + ", ".join(sorted(known)))
    tasks = grid(o.files, settings, seeds, info, o.traces, o.budgets)
    check_outputs(o, info, tasks)
    rows, signum, error = _run_grid(_executor(o, info), tasks, o)
    rows.sort(key=lambda r: r.task.index)
    comp = comparison(rows, tuple(o.maximize))
    meta = {"files": o.files, "settings": {s.name: list(s.values) for s in settings},
            "seeds": list(seeds) if seeds is not None else None, "executor": o.executor,
            "timeout_per_run_s": o.timeout_s, "interrupted": signum is not None or error is not None}
    wrote = _write(o, rows, comp, meta, settings)  # first: a closed terminal must not cost the files
    if error is not None:
        raise error
    text = sys.stderr if o.json == "-" else out
    try:
        _show(rows, comp, len(tasks), signum is not None, len(set(o.files)) > 1, text)
        for path in wrote:
            print(f"wrote {path}", file=text)
    except OSError:  # the terminal went away (SIGHUP): the files hold everything
        if signum is None:
            raise
    if signum is not None:
        return exit_code(signum)
    return EXIT_FAILED if any(r.failed for r in rows) else EXIT_OK


def _run_grid(executor: Executor, tasks: list[Task],
              o: SweepOptions) -> tuple[list[Row], int | None, Exception | None]:
    """Every row the executor gives, the signal that ended the sweep early (None: it ran to the
    end) and the error of labsim's own that did. Ctrl-C, SIGTERM and SIGHUP stop the runs in
    progress, which become interrupted rows with what each did so far; so does an error, which
    is raised again once the rows are written."""
    bar = SweepProgress(len(tasks), show=o.progress if o.progress is not None else sys.stderr.isatty())
    rows: list[Row] = []
    results = executor.results(tasks)
    try:
        with batch_signals():
            for row in results:
                rows.append(row)
                bar.update(row)
    except KeyboardInterrupt as e:
        signum, why = ending(e)
        rows += executor.interrupt(why)
        return rows, signum, None
    except Exception as e:  # labsim's own: reported by the command line once the rows are written
        rows += executor.interrupt("an error in labsim")
        return rows, None, e
    finally:
        results.close()
        bar.clear()
    return rows, None, None


def _write(o: SweepOptions, rows: list[Row], comp: dict[str, Any], meta: dict[str, Any],
           settings: list[Setting]) -> list[str]:
    """The sweep's files (CSV, JSON, chart); the paths written, but standard output."""
    wrote = []
    if o.output:
        write_csv(rows, o.output, [s.name for s in settings])
        wrote.append(o.output)
    if o.json:
        write_json(sweep_json(rows, comp, meta), o.json)
        wrote += [o.json] if o.json != "-" else []
    if o.plot:
        from labsim.runtime.sweep.plot import plot_comparison

        plot_comparison(comp, o.plot)
        wrote.append(o.plot)
    return wrote


def _show(rows: list[Row], comp: dict[str, Any], total: int, interrupted: bool, several_files: bool,
          text: Any) -> None:
    """The comparison table, the counts and the failures, on the terminal."""
    aggregates: dict[str, str] = {}
    for r in rows:
        if r.result is not None:
            aggregates.update({k: a.value for k, a in r.result.metric_aggregates.items() if k not in aggregates})
    print(format_comparison(comp, aggregates, several_files=several_files), file=text)
    print(("interrupted: " if interrupted else "") + status_counts(rows)
          + (f" (of {total})" if interrupted else ""), file=text)
    for line in failures(rows):
        print(line, file=text)
    retried = [r for r in rows if r.retries]
    if retried:
        print(f"{len(retried)} run{'s were' if len(retried) != 1 else ' was'} started again after a Dask worker "
              f"was lost ({sum(r.retries for r in retried)} retries; the rows' retries column)", file=text)


def add_sweep_arguments(sweep: argparse.ArgumentParser) -> None:
    """``labsim sweep``'s options; docs/sweep.md."""
    sweep.add_argument("files", nargs="+", metavar="FILE", help="behaviour files or lab names (a class's "
                                                                "submissions, or versions of one behaviour)")
    sweep.add_argument("--set", action="append", default=[], metavar="NAME=V1,V2,...|NAME=START:STOP:STEP",
                       help="values of a parameter to try (repeatable; the grid is every combination)")
    sweep.add_argument("--seeds", metavar="1-20", help="seeds to run each setting with: 1-20, 1,2,5 or 1-5,9 "
                                                       "(default: the file's own seed)")
    sweep.add_argument("-j", "--jobs", type=int, metavar="N", help="processes on this machine (default: the cores)")
    sweep.add_argument("--executor", choices=("local", "dask"), default="local",
                       help="where the runs go: this machine's processes, or a Dask cluster (default: %(default)s)")
    sweep.add_argument("--scheduler", metavar="ADDRESS", help="the Dask scheduler, e.g. tcp://HOST:8786")
    sweep.add_argument("-o", "--output", metavar="CSV", help="write one row per run to this CSV file")
    sweep.add_argument("--json", metavar="PATH|-", help="write the rows, their summaries and the comparison as JSON")
    sweep.add_argument("--plot", metavar="PNG", help="draw each metric across the settings: a .png, .svg or .pdf file")
    sweep.add_argument("--timeout-per-run", type=options.run_timeout_s, metavar="S", dest="timeout",
                       default=DEFAULT_TIMEOUT_S, help="stop a run after S seconds of real time; its row says "
                                                       "timeout (default: %(default)g, up to 86400)")
    sweep.add_argument("--memory-per-run", type=int, metavar="MB", dest="memory_mb", default=DEFAULT_MEMORY_MB,
                       help="limit each local worker process's memory (address space) to MB, where the "
                            "platform allows; 0: no limit (default: %(default)s)")
    sweep.add_argument("--traces", metavar="DIR", help="write each run's trace into this folder")
    sweep.add_argument("--maximize", action="append", default=[], metavar="METRIC",
                       help="mark the highest mean of this metric as best (default: the way the file says "
                            "the metric is better)")
    sweep.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                       help="show a progress bar (default: when stderr is a terminal)")


def sweep_options(args: argparse.Namespace) -> SweepOptions:
    """The parsed command line as SweepOptions."""
    budgets, problems = DEFAULT_BUDGETS.parse(args.budget)
    if problems:
        raise LabsimError([Diagnostic(where, message) for where, message in problems])
    return SweepOptions(args.files, args.set, args.seeds, args.jobs, args.executor, args.scheduler, args.output,
                        args.json, args.plot, args.timeout, args.traces, args.maximize, args.progress,
                        budgets, args.memory_mb)
