"""The Python API for notebooks and scripts: what ``import labsim`` offers (docs/api.md).

A thin layer over the runtime, at the same place in the pipeline as the command line:
``run`` compiles a behaviour file, runs it and returns the summary ``labsim run --json``
writes; ``read_trace`` reads a trace into a pandas DataFrame (pandas is the optional extra
``labsim[pandas]``) with the trace's header in ``DataFrame.attrs``; ``compile_behaviour``
(the runtime's own, ``labsim.runtime.run``) compiles once for many runs
(``Behaviour.bind(load_backend()).run()``). The package root
imports these lazily, so ``import labsim`` (and ``labsim check``'s start) stays cheap.
"""
from __future__ import annotations

import time as clock
from pathlib import Path
from typing import TYPE_CHECKING, Any

from labsim.backends import DEFAULT, load_backend
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.runtime.run import Behaviour, Setting, compile_behaviour
from labsim.runtime.summary_json import summary_dict
from labsim.runtime.trace import TraceFormatError
from labsim.runtime.trace import read_trace as _read_trace

if TYPE_CHECKING:
    import pandas


class RunStopped(LabsimError):
    """A run that did not reach its stop condition: ``summary`` is what it did until then."""

    def __init__(self, path: str, message: str, summary: dict[str, Any]):
        super().__init__([Diagnostic(path, message)])
        self.summary = summary


class OverBudget(RunStopped):
    """A run a budget stopped: its ticks, its trace's size or its memory (docs/security.md)."""


class RunTimeout(RunStopped):
    """A run still going after ``timeout`` seconds of wall time."""


def run(behaviour: str | Path | Behaviour, *, params: dict[str, Setting] | None = None, seed: int | None = None,
        backend: str = DEFAULT, trace: str | Path | None = None, budget: dict[str, int] | None = None,
        timeout: float | None = None) -> dict[str, Any]:
    """Run a behaviour file, a shipped lab by name, or a compiled ``Behaviour`` to its stop condition and return its
    summary: the same figures as ``labsim run --json`` (docs/summary-json.md).

    ``params`` override the file's ``params:`` as ``--set`` does; ``seed`` its seed; ``trace``
    is where to write the trace; ``budget`` raises or lowers the run's budgets as ``--budget``
    does (``{"ticks": 20000, "memory_mb": 500}``); ``timeout`` stops the run after that many
    seconds of wall time. A mistake in the file raises ``LabsimError``, whose ``diagnostics``
    say where; a run a budget stops raises ``OverBudget``, one past its timeout ``RunTimeout``
    (both ``LabsimError``s, with the ``summary`` so far). Ctrl-C raises ``KeyboardInterrupt``.
    """
    if isinstance(behaviour, Behaviour):
        if params or seed is not None or budget is not None:
            raise LabsimError([Diagnostic("run", "a compiled behaviour has its parameters, seed and budgets; "
                                                 "give them to compile_behaviour")])
        compiled = behaviour
    else:
        compiled = compile_behaviour(behaviour, params=params, seed=seed, budget=budget)
    if timeout is not None and not timeout > 0:
        raise LabsimError([Diagnostic("timeout", "give a positive number of seconds")])
    bound = compiled.bind(load_backend(backend), trace=trace)
    deadline = None if timeout is None else clock.monotonic() + timeout
    timed_out = []

    def progress(tick: int, time_s: float) -> None:  # every 256 ticks (Run.run)
        if deadline is not None and clock.monotonic() > deadline:
            timed_out.append(tick)
            raise KeyboardInterrupt  # ends the run as Ctrl-C does: the trace gets its footer
    try:
        result = bound.run(progress=progress)
    finally:
        bound.close()
    summary = summary_dict(result)
    path = compiled.program.path
    if timed_out:
        raise RunTimeout(path, f"the run was still going after {timeout:g} s of wall time "
                               f"({timed_out[0]:,} ticks); give it a longer timeout", summary)
    if result.over_budget:
        raise OverBudget(path, result.over_budget, summary)
    if result.interrupted:
        raise KeyboardInterrupt
    return summary


def read_trace(path: str | Path) -> pandas.DataFrame:
    """A trace as a DataFrame, one row per robot per tick, numbers as numbers; the trace's JSON
    header (behaviour, world, params, seed, ...) is ``df.attrs``. Needs pandas."""
    try:
        import pandas
    except ImportError:  # pragma: no cover - the extra is installed in the tests
        raise ImportError("labsim.read_trace needs pandas: pip install 'labsim[pandas]'") from None
    try:
        trace = _read_trace(path)
    except TraceFormatError as e:
        raise LabsimError([Diagnostic(str(path), str(e).removeprefix(f"{path}: "))]) from None
    frame = pandas.DataFrame(trace.rows, columns=trace.columns)
    for column in frame.columns:
        converted = pandas.to_numeric(frame[column], errors="coerce")
        if converted.notna().sum() == frame[column].ne("").sum():  # every non-empty cell is a number
            frame[column] = converted
    frame.attrs.update(trace.header)
    return frame


__all__ = ["Behaviour", "LabsimError", "OverBudget", "RunStopped", "RunTimeout", "compile_behaviour", "load_backend",
           "read_trace", "run"]
