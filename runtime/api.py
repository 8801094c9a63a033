"""The Python API for notebooks and scripts: what ``import labsim`` offers (docs/api.md).

A thin layer over the runtime, at the same place in the pipeline as the command line:
``run`` compiles a behaviour file, runs it and returns the summary ``labsim run --json``
writes; ``read_trace`` reads a trace into a pandas DataFrame (pandas is the optional extra
``labsim[pandas]``) with the trace's header in ``DataFrame.attrs``; ``compile_behaviour``
(the runtime's own, ``labsim.runtime.run``) compiles once for many runs
(``Behaviour.bind(load_backend()).run()``). The package root imports these lazily, so
``import labsim`` (and ``labsim check``'s start) stays cheap.

The summary ``run`` returns is a dict, a ``RunSummary``: in Jupyter it shows as a table with
the run's map (``_repr_html_``), drawn from its trace file, or else from the same run made again
on the embedded simulator when the summary is first shown (the same file and seed give the
same run, so a summary never shown costs nothing), thinned to at most ``DRAWN_TICKS`` ticks.
The pictures are drawn by the pictures' renderer named in ``PICTURES`` ("module:name", as the backends' registry names
its backends), imported when a summary is first shown: the tick loop imports no application.
"""
from __future__ import annotations

import base64
import functools
import html
import importlib
import math
import tempfile
import time as clock
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from labsim.backends import DEFAULT, load_backend
from labsim.foundation.diagnostics import Diagnostic, LabsimError
from labsim.runtime.recording import Recording
from labsim.runtime.run import Behaviour, Setting, compile_behaviour
from labsim.runtime.summary_json import summary_dict
from labsim.runtime.trace import Trace, TraceFormatError
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
        timeout: float | None = None, animation: bool = False) -> RunSummary:
    """Run a behaviour file, a shipped lab by name, or a compiled ``Behaviour`` to its stop condition and return its
    summary: the same figures as ``labsim run --json`` (docs/summary-json.md).

    ``params`` override the file's ``params:`` as ``--set`` does; ``seed`` its seed; ``trace``
    is where to write the trace; ``budget`` raises or lowers the run's budgets as ``--budget``
    does (``{"ticks": 20000, "memory_mb": 500}``); ``timeout`` stops the run after that many
    seconds of wall time. A mistake in the file raises ``LabsimError``, whose ``diagnostics``
    say where; a run a budget stops raises ``OverBudget``, one past its timeout ``RunTimeout``
    (both ``LabsimError``s, with the ``summary`` so far). Ctrl-C raises ``KeyboardInterrupt``.
    In Jupyter the summary shows as a table with the run's map; ``animation`` adds a short
    animation of the run (``RunSummary``).
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
    # the map is drawn when the summary is first shown: the embedded simulator gives the same
    # run again from the same compiled file and seed, so a run that is never shown costs nothing
    again = None if timed_out or result.interrupted or backend != DEFAULT else functools.partial(_again, compiled)
    summary = RunSummary(summary_dict(result), str(trace) if trace is not None else None, animation, again)
    path = compiled.program.path
    if timed_out:
        raise RunTimeout(path, f"the run was still going after {timeout:g} s of wall time "
                               f"({timed_out[0]:,} ticks); give it a longer timeout", summary)
    if result.over_budget:
        raise OverBudget(path, result.over_budget, summary)
    if result.interrupted:
        raise KeyboardInterrupt
    return summary


# -- the summary in a notebook -----------------------------------------------------------------------

DRAWN_TICKS = 2000  # a run's map keeps at most about this many ticks (and every tick with an event)
Pictures = Callable[[Trace, bool], tuple[bytes, bytes]]  # (run, animation) -> (map PNG, GIF or b"")
PICTURES = "labsim.runtime.pictures.notebook:notebook_pictures"


class RunSummary(dict):  # the summary as `labsim run --json` writes it
    """What ``run`` returns: the summary dict (docs/summary-json.md), shown in Jupyter as a table
    of the run's figures with its map, and a short animation when ``animation`` (``html``)."""

    def __init__(self, summary: dict[str, Any], trace: str | None, animation: bool,
                 again: Callable[[], Trace] | None = None) -> None:
        super().__init__(summary)
        self._trace, self._animation, self._again = trace, animation, again
        self._drawn: Trace | None = None

    def __reduce__(self) -> tuple[Any, ...]:  # a copy or a pickle keeps the figures and the trace's path, not the run
        return (RunSummary, (dict(self), self._trace, self._animation))

    def _repr_html_(self) -> str:
        return self.html(self._animation)

    def html(self, animation: bool = False) -> str:
        """The summary as HTML: a table, then the map (and the animation when asked)."""
        return summary_table(self) + self._pictures(animation)

    def drawn(self) -> Trace | None:
        """The run the map draws, thinned (``_thinned``): read from its trace file, else run again
        on the embedded simulator (the same file and seed give the same run), once."""
        if self._drawn is None and self._trace is not None:
            self._drawn = _thinned(_read_trace(self._trace))
        elif self._drawn is None and self._again is not None:
            self._drawn = self._again()
        return self._drawn

    def _pictures(self, animation: bool) -> str:
        try:
            drawn = self.drawn()
        except TraceFormatError as e:
            return _note(f"no map: {e}")
        if drawn is None:
            return _note("no map: only a whole run on the embedded simulator is drawn again; "
                         "run it with trace='run.csv'")
        module, name = PICTURES.split(":")
        draw: Pictures = getattr(importlib.import_module(module), name)
        try:
            png, gif = draw(drawn, animation)
        except (ValueError, OverflowError, LabsimError) as e:  # what cannot be drawn: the table stands
            return _note(f"no map: {e}")
        out = _image("image/png", png, "the run's map")
        if gif:
            out += _image("image/gif", gif, "the run, played back")
        return f"<div>{out}</div>"


def summary_table(summary: dict[str, Any]) -> str:
    """The run's figures as HTML: the run, each robot's metrics and contacts (and the fleet's),
    how often each rule fired, and the warnings; every text from the file escaped."""
    e = html.escape
    given = summary.get("behaviour")
    about: dict[str, Any] = given if isinstance(given, dict) else {}
    ended = str(summary.get("stop_reason", ""))
    if summary.get("stop_condition"):
        ended += f": {summary['stop_condition']}"
    rows = [("behaviour", f"{about.get('name', '')} ({about.get('path', '')})"), ("world", summary.get("world", "")),
            ("seed", summary.get("seed", "")), ("ticks", summary.get("ticks", "")),
            ("simulated time", f"{_number(summary.get('sim_time_s'))} s"), ("ended by", ended)]
    params = summary.get("params") or {}
    if params:
        rows.append(("params", ", ".join(f"{k} = {_number(v)}" for k, v in params.items())))
    cells = (f"<tr><th style='text-align:left'>{e(str(k))}</th><td style='text-align:left'>{e(str(v))}</td></tr>"
             for k, v in rows)
    out = ["<div class='labsim-summary'><table>", *cells, "</table>"]
    robots = summary.get("robots") or {}
    metrics = list(dict.fromkeys(m for r in robots.values() for m in (r.get("metrics") or {})))
    lines = [[name, *(_number((r.get("metrics") or {}).get(m)) for m in metrics), r.get("contacts", "")]
             for name, r in robots.items()]
    if len(robots) > 1 and summary.get("fleet"):
        lines.append(["all robots", *(_number(summary["fleet"].get(m)) for m in metrics), ""])
    if lines:
        out.append(_table(["robot", *metrics, "contacts"], lines))
    rules = summary.get("rules") or []
    if rules:
        out.append(_table(["rule", "", "ticks it acted"], [[r.get("id", ""), r.get("text", ""), r.get("ticks", "")]
                                                            for r in rules]))
    warnings = summary.get("warnings") or []
    if warnings:
        out.append("<ul>" + "".join(f"<li>{e(str(w))}</li>" for w in warnings[:20]) + "</ul>")
    return "".join(out) + "</div>"


def _table(head: list[str], rows: list[list[object]]) -> str:
    e = html.escape
    return ("<table><thead><tr>" + "".join(f"<th style='text-align:left'>{e(str(c))}</th>" for c in head)
            + "</tr></thead><tbody>" + "".join("<tr>" + "".join(f"<td style='text-align:left'>{e(str(c))}</td>"
                                                                 for c in row) + "</tr>" for row in rows)
            + "</tbody></table>")


def _number(v: object) -> str:
    if isinstance(v, float):
        return f"{v:.4g}" if math.isfinite(v) else str(v)
    return "" if v is None else str(v)


def _note(text: str) -> str:
    return f"<p><em>{html.escape(text)}</em></p>"


def _image(mime: str, data: bytes, alt: str) -> str:
    return (f"<img src='data:{mime};base64,{base64.b64encode(data).decode('ascii')}' alt='{html.escape(alt)}' "
            "style='max-width:100%'>") if data else ""


def _again(compiled: Behaviour) -> Trace:
    """The compiled behaviour run again on the embedded simulator, recorded for its map (a
    mechanism's joints are read from a trace's columns: its run writes one to a scratch folder)."""
    if compiled.program.world.mechanism is None:
        recording = Recording()
        bound = compiled.bind(load_backend(DEFAULT), observers=[recording])
        try:
            bound.run()
        finally:
            bound.close()
        return _thinned(recording.trace(compiled.program.path, bound.header()))
    with tempfile.TemporaryDirectory(prefix="labsim-run-") as scratch:
        traced = Path(scratch) / "run.csv"
        bound = compiled.bind(load_backend(DEFAULT), trace=traced)
        try:
            bound.run()
        finally:
            bound.close()
        return _thinned(_read_trace(traced))


def _thinned(trace: Trace) -> Trace:
    """A recorded run kept for its map: every k-th tick when it has more than ``DRAWN_TICKS``,
    with its last tick and every row that has an event (what the map marks)."""
    ticks = trace.numbers.get("tick")
    if ticks is None:
        ticks = np.array([float(t) for t in trace.column("tick")])
    last = float(ticks[-1]) if len(ticks) else 0.0
    step = math.ceil((last + 1) / DRAWN_TICKS)
    if step <= 1:
        return trace
    keep = (ticks % step == 0) | (ticks == last)
    events = trace.columns.index("events") if "events" in trace.columns else None
    if events is not None:
        keep[[i for i, r in enumerate(trace.rows) if r[events]]] = True
    index = np.flatnonzero(keep)
    return Trace(trace.path, trace.header, trace.columns, [trace.rows[i] for i in index], trace.footer,
                 [trace.lines[i] for i in index] if trace.lines else [],
                 numbers={k: v[index] for k, v in trace.numbers.items()})


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


__all__ = ["Behaviour", "LabsimError", "OverBudget", "RunStopped", "RunSummary", "RunTimeout", "compile_behaviour",
           "load_backend", "read_trace", "run"]
