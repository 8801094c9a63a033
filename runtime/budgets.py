"""The tick loop's budgets: ticks and trace size, and a warning for a run that will take long.

``labsim.runtime.run.Run.run`` asks ``RunWatch.check`` every 256 ticks (never per tick: the
loop is the hot path); the trace writer also counts every row against the trace budget and
stops the run at the row that reaches it (``labsim.runtime.trace.TraceFull``), and a run that
runs out of memory under its cap (``labsim.foundation.memory``) stops too. A run past a budget
stops there, its trace closed and kept, and the summary's ``over_budget`` says why; the
command line prints the summary and exits 2. The budgets of a behaviour's size (robots,
cameras, world, image memory) are checked when it compiles (``labsim.dsl.analysis.budget``). Defaults
and flags: docs/security.md, "Budgets".
"""
from __future__ import annotations

import math
import time as clock
from collections.abc import Callable

from labsim.foundation.limits import Budgets
from labsim.foundation.memory import HEADROOM_MB

ESTIMATE_AFTER_S = 2.0  # wall time measured before the rate is trusted for an estimate


class RunWatch:
    """One run's budgets, checked between chunks of ticks."""

    def __init__(self, budgets: Budgets, dt_s: float, horizon_s: float | None, start: float,
                 warn: Callable[[str], None] | None) -> None:
        self.budgets = budgets
        self.dt_s = dt_s
        self.start = start
        self.warn = warn
        # the ticks the run will take: to its stop time when the stop condition says one, else the budget
        ticks = budgets.ticks
        if horizon_s is not None and horizon_s / dt_s < ticks:  # 1e308 / dt is inf: the budget
            ticks = max(1, math.ceil(horizon_s / dt_s))
        self.expected_ticks = ticks
        self.warned = warn is None

    def check(self, ticks: int, trace: object | None) -> str:
        """'' while the run is within its budgets; else why it must stop now. ``trace`` is the
        run's trace writer, if it has one."""
        b = self.budgets
        if ticks >= b.ticks:
            return (f"the run reached its budget of {b.ticks:,} ticks ({b.ticks * self.dt_s:g} s simulated) "
                    f"before its stop condition held; raise it with --budget ticks=N")
        if trace is not None and trace_bytes(trace) > b.trace_mb * 1_000_000:
            return trace_full_message(trace, b.trace_mb, ticks)
        if not self.warned:
            self._estimate(ticks)
        return ""

    def _estimate(self, ticks: int) -> None:
        """Warn once when the run is on course to take longer than ``warn_wall_s`` of wall time."""
        elapsed = clock.perf_counter() - self.start
        if ticks <= 0 or elapsed < min(ESTIMATE_AFTER_S, self.budgets.warn_wall_s / 10):
            return
        self.warned = True
        rate = ticks / elapsed if elapsed > 0 else math.inf
        total_s = self.expected_ticks / rate
        if total_s > self.budgets.warn_wall_s and self.warn is not None:
            what = "its stop time" if self.expected_ticks < self.budgets.ticks else "its tick budget"
            self.warn(f"labsim: warning: this run may take about {_duration(total_s)} of wall time "
                      f"({self.expected_ticks:,} ticks to {what} at {rate:,.0f} ticks a second; "
                      f"the warning is for runs over {self.budgets.warn_wall_s:,} s, --budget warn_wall_s=N)")


def trace_full_message(trace: object, trace_mb: int, ticks: int) -> str:
    """Why a run whose trace reached its size budget stopped (the writer counts every row)."""
    return (f"the trace {getattr(trace, 'path', '')} reached its budget of {trace_mb:,} MB after "
            f"{ticks:,} ticks; raise it with --budget trace_mb=N")


def out_of_memory_message(memory_mb: int, ticks: int) -> str:
    """Why a run that ran out of memory stopped (labsim.foundation.memory caps it)."""
    return (f"the run ran out of memory after {ticks:,} ticks (labsim lets a run map its memory budget of "
            f"{memory_mb:,} MB and a headroom of {HEADROOM_MB:,} MB; the system may allow less); raise the "
            f"budget with --budget memory_mb=N")


def trace_bytes(trace: object) -> int:
    """How much a trace writer has written, in characters (bytes, but for non-ASCII labels)."""
    return int(getattr(trace, "chars", 0))


def _duration(seconds: float) -> str:
    if seconds < 10:
        return f"{seconds:.1f} s"
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"
