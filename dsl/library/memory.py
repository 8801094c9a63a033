"""Time and memory: the stateful functions generated code calls, one closure per call site.

``labsim.dsl.library.support.guard`` makes one of these for each call site of ``prev``, ``rising``,
``falling``, ``hold``, ``rate``, ``held``, ``remember``, ``counter`` and ``total`` in a robot's
generated code (as it does for ``pid``), so every call site keeps its own memory per robot.
Each factory takes the tick length in seconds and the site's fault report, and returns the
function the site calls once per tick it is reached: in a ``let`` signal, every tick
(docs/language.md, "Time and memory"). A non-finite number never stays in a memory that sums
or differences (``rate``, ``total``): it is reported once and left out.
"""
from __future__ import annotations

import math
from collections.abc import Callable

INF = math.inf
Report = Callable[[str], None]  # the site's fault report (support.Faults): the first at once, the rest counted

# Functions whose first tick changed in format 1.2: the first value only primes the memory, so
# no edge is seen on it. Code generated for a 1.2 file names their sites "rising@1.2" (codegen).
PRIMED = frozenset({"rising", "counter"})

# What the site reports when a number it would keep is inf or nan (one text per site: counted).
RATE_NOT_FINITE = "rate() of inf or nan (the result is 0; the next finite value starts afresh, as on a first tick)"
TOTAL_NOT_FINITE = "total() of inf or nan (not added: the result is the total so far)"
TOTAL_OVERFLOW = "total(): overflow (not added: the result is the total so far)"


def prev(dt_s: float, report: Report) -> Callable[[object, object], object]:
    """``prev(x, initial)``: the value x had when this site last ran; ``initial`` the first time."""
    last: list[object] = []

    def step(x: object, initial: object) -> object:
        out = last[0] if last else initial
        last[:] = [x]
        return out
    return step


def rising(dt_s: float, report: Report, primed: bool = False) -> Callable[[bool], bool]:
    """``rising(c)``: c holds now and did not the last time.

    Format 1 and 1.1: false before the first tick, so true on the first if c holds. Format 1.2
    (``primed``): the first value only primes the memory, and the first tick is never an edge.
    """
    last: list[bool | None] = [None if primed else False]  # None: no value yet, nothing to rise from

    def step(c: bool) -> bool:
        c = bool(c)
        out = c and last[0] is False
        last[0] = c
        return out
    return step


def falling(dt_s: float, report: Report) -> Callable[[bool], bool]:
    """``falling(c)``: c does not hold now and did the last time (never on the first tick)."""
    last = [False]

    def step(c: bool) -> bool:
        out = last[0] and not c
        last[0] = bool(c)
        return out
    return step


def hold(dt_s: float, report: Report) -> Callable[[bool, bool], bool]:
    """``hold(set, reset)``: a set/reset latch, false at first; reset wins when both hold."""
    on = [False]

    def step(set_: bool, reset: bool) -> bool:
        if reset:
            on[0] = False
        elif set_:
            on[0] = True
        return on[0]
    return step


def rate(dt_s: float, report: Report) -> Callable[[float], float]:
    """``rate(x)``: (x - x at the previous tick) / dt, in x's units per second; 0 the first time.

    A non-finite x gives 0 and forgets the previous value: the next finite x gives 0, as on a
    first tick, and the rate never carries an inf or nan into later ticks.
    """
    last = [math.nan]

    def step(x: float) -> float:
        before = last[0]
        if not -INF < x < INF:
            last[0] = math.nan
            report(RATE_NOT_FINITE)
            return 0.0
        last[0] = x
        return 0.0 if before != before else (x - before) / dt_s
    return step


def held(dt_s: float, report: Report) -> Callable[[bool], float]:
    """``held(c)``: seconds since c began to hold without a break: 0 on its first tick and while false."""
    ticks = [0]

    def step(c: bool) -> float:
        ticks[0] = ticks[0] + 1 if c else 0
        return (ticks[0] - 1) * dt_s if ticks[0] else 0.0
    return step


def remember(dt_s: float, report: Report) -> Callable[..., float]:
    """``remember(x, when[, initial])``: x at the last tick where ``when`` held; before, initial (nan)."""
    kept: list[float] = []

    def step(x: float, when: bool, initial: float = math.nan) -> float:
        if when:
            kept[:] = [x]
        return kept[0] if kept else initial
    return step


def counter(dt_s: float, report: Report, primed: bool = False) -> Callable[..., float]:
    """``counter(c[, reset])``: how many times c became true, the ticks ``rising(c)`` holds on.

    ``primed`` (format 1.2) as in ``rising``: a c that holds on the first tick is not counted.
    On a tick where ``reset`` holds the count is 0, and an edge on that tick is not counted.
    """
    # rising()'s memory, kept here rather than called: a counter runs every tick of a run
    state: list = [0.0, None if primed else False]  # the count; c on the last tick (None: none yet)

    def step(c: bool, reset: bool = False) -> float:
        c = bool(c)
        rose = c and state[1] is False
        state[1] = c  # the edge memory follows c on every tick, reset or not
        if reset:
            state[0] = 0.0
        elif rose:
            state[0] += 1.0
        return state[0]
    return step


def total(dt_s: float, report: Report) -> Callable[..., float]:
    """``total(x[, reset])``: the sum of x over the ticks this site ran; 0 on a tick where reset holds.

    A non-finite x is not added (and reported), nor is an x that would make the sum overflow:
    once x is finite again the total goes on as if those ticks had not been.
    """
    sum_ = [0.0]

    def step(x: float, reset: bool = False) -> float:
        if reset:
            sum_[0] = 0.0
        elif not -INF < x < INF:
            report(TOTAL_NOT_FINITE)
        else:
            after = sum_[0] + x
            if -INF < after < INF:
                sum_[0] = after
            else:
                report(TOTAL_OVERFLOW)
        return sum_[0]
    return step
