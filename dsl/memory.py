"""Time and memory: the stateful functions generated code calls, one closure per call site.

``labsim.dsl.support.guard`` makes one of these for each call site of ``prev``, ``rising``,
``falling``, ``hold``, ``rate``, ``held`` and ``remember`` in a robot's generated code (as it
does for ``pid``), so every call site keeps its own memory per robot. Each factory takes the
tick length in seconds and returns the function the site calls once per tick it is reached:
in a ``let`` signal, every tick (docs/language.md, "Time and memory").
"""
from __future__ import annotations

import math
from collections.abc import Callable


def prev(dt_s: float) -> Callable[[object, object], object]:
    """``prev(x, initial)``: the value x had when this site last ran; ``initial`` the first time."""
    last: list[object] = []

    def step(x: object, initial: object) -> object:
        out = last[0] if last else initial
        last[:] = [x]
        return out
    return step


def rising(dt_s: float) -> Callable[[bool], bool]:
    """``rising(c)``: c holds now and did not the last time (false before the first tick)."""
    last = [False]

    def step(c: bool) -> bool:
        out = bool(c) and not last[0]
        last[0] = bool(c)
        return out
    return step


def falling(dt_s: float) -> Callable[[bool], bool]:
    """``falling(c)``: c does not hold now and did the last time."""
    last = [False]

    def step(c: bool) -> bool:
        out = last[0] and not c
        last[0] = bool(c)
        return out
    return step


def hold(dt_s: float) -> Callable[[bool, bool], bool]:
    """``hold(set, reset)``: a set/reset latch, false at first; reset wins when both hold."""
    on = [False]

    def step(set_: bool, reset: bool) -> bool:
        if reset:
            on[0] = False
        elif set_:
            on[0] = True
        return on[0]
    return step


def rate(dt_s: float) -> Callable[[float], float]:
    """``rate(x)``: (x - x at the previous tick) / dt, in x's units per second; 0 the first time."""
    last = [math.nan]

    def step(x: float) -> float:
        before = last[0]
        last[0] = x
        return 0.0 if before != before else (x - before) / dt_s
    return step


def held(dt_s: float) -> Callable[[bool], float]:
    """``held(c)``: seconds since c began to hold without a break: 0 on its first tick and while false."""
    ticks = [0]

    def step(c: bool) -> float:
        ticks[0] = ticks[0] + 1 if c else 0
        return (ticks[0] - 1) * dt_s if ticks[0] else 0.0
    return step


def remember(dt_s: float) -> Callable[..., float]:
    """``remember(x, when[, initial])``: x at the last tick where ``when`` held; before, initial (nan)."""
    kept: list[float] = []

    def step(x: float, when: bool, initial: float = math.nan) -> float:
        if when:
            kept[:] = [x]
        return kept[0] if kept else initial
    return step
