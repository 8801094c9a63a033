"""Built-ins with memory in language 1.2: counter, total, rising's first tick, and inf and nan.

Each function is stepped tick by tick with its expected sequence written out; the format
versions are told apart on compiled files (a 1.1 file's rising holds on tick 0, a 1.2 file's
does not); a hypothesis test feeds inf, -inf and nan into every built-in with memory and shows
each recovers; and a pid() given inf warns once, naming its signal, robot and tick, and counts
the rest.
"""
from __future__ import annotations

import math
import random
from collections.abc import Callable
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from labsim.dsl.compile import compile_file
from labsim.dsl.emit.program import Program
from labsim.dsl.library.support import PID_NOT_FINITE, Faults, FaultSite, Slots, guard
from labsim.foundation.diagnostics import Diagnostic, LabsimError

INF, NAN = math.inf, math.nan
DT = 0.05
HEAD = "world: walls_lab4\nstop: time >= 100\nrobots: {p: {model: pioneer_p3dx, at: [0, 0, 0]}}\n"


def site(kind: str) -> tuple[Callable[..., object], Faults, list[str]]:
    """A fresh call site of ``kind`` for one robot, its faults and what they printed."""
    printed: list[str] = []
    faults = Faults(printed.append)
    where = FaultSite("signal 'v'", Diagnostic("b.yaml", "", 4, 6, 9))
    slots = Slots([0.0, 0, 0])
    return guard(kind, where, faults, slots, "p", random.Random(0), DT), faults, printed


def steps(kind: str, calls: list[tuple]) -> list[object]:
    f, _, _ = site(kind)
    return [f(*args) for args in calls]


# -- each function, tick by tick -------------------------------------------------------------
@pytest.mark.parametrize(("kind", "calls", "expected"), [
    # format 1 and 1.1: rising holds on tick 0 when c does; 1.2 (rising@1.2) it only primes
    ("rising", [(True,), (True,), (False,), (True,)], [True, False, False, True]),
    ("rising@1.2", [(True,), (True,), (False,), (True,)], [False, False, False, True]),
    ("rising@1.2", [(False,), (True,), (True,)], [False, True, False]),
    ("falling", [(False,), (True,), (False,)], [False, False, True]),
    ("falling", [(True,), (False,)], [False, True]),
    ("counter", [(True,), (False,), (True,), (True,), (False,), (True,)], [1.0, 1.0, 2.0, 2.0, 2.0, 3.0]),
    ("counter@1.2", [(True,), (False,), (True,), (True,), (False,), (True,)], [0.0, 0.0, 1.0, 1.0, 1.0, 2.0]),
    # reset wins, and an edge on a reset tick is not counted
    ("counter@1.2", [(False, False), (True, False), (False, True), (True, True), (True, False), (False, False),
                     (True, False)], [0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]),
    ("total", [(1.0,), (2.5,), (-0.5,)], [1.0, 3.5, 3.0]),
    ("total", [(1.0, False), (2.0, True), (4.0, False), (INF, False), (NAN, False), (1.0, False)],
     [1.0, 0.0, 4.0, 4.0, 4.0, 5.0]),
    ("total", [(1e308,), (1e308,), (-1.0,)], [1e308, 1e308, 1e308 - 1.0]),  # no overflow to inf
    ("rate", [(1.0,), (1.5,), (INF,), (2.0,), (2.5,), (NAN,), (-INF,), (0.0,), (1.0,)],
     [0.0, 10.0, 0.0, 0.0, 10.0, 0.0, 0.0, 0.0, 20.0]),
    # pid(e, kp=1, ki=1, kd=1): out = e + integral + (e - previous e)
    ("pid", [(1.0, 1, 1, 1), (INF, 1, 1, 1), (NAN, 1, 1, 1), (2.0, 1, 1, 1)], [3.0, 3.0, 3.0, 6.0]),
    ("pid", [(NAN, 1, 1, 1), (1.0, 1, 1, 1)], [0.0, 3.0]),  # 0 before any finite output
    ("pid", [(1.0, 1, 0, 0), (1.0, NAN, 0, 0), (1.0, 1, INF, 0), (2.0, 1, 0, 0)], [1.0, 1.0, 1.0, 2.0]),
    ("pid", [(1e308, 10, 0, 0), (1.0, 10, 0, 0)], [0.0, 10.0]),  # an overflowing output is not kept
    ("pid", [(10.0, 1, 1, 0, 5), (-INF, 1, 1, 0, 5), (-1.0, 1, 1, 0, 5)], [5.0, 5.0, -2.0]),
])
def test_each_function_tick_by_tick(kind: str, calls: list[tuple], expected: list) -> None:
    assert steps(kind, calls) == expected


def test_prev_and_remember_keep_what_they_are_given() -> None:
    """A non-finite value stays one tick in prev(), and until the next 'when' in remember()."""
    out = steps("prev", [(INF, 0.0), (1.0, 0.0), (2.0, 0.0)])
    assert out == [0.0, INF, 1.0]
    out = steps("remember", [(NAN, True), (5.0, False), (6.0, True), (7.0, False)])
    assert [x if x == x else "nan" for x in out] == ["nan", "nan", 6.0, 6.0]


def test_one_warning_then_counted() -> None:
    pid, faults, printed = site("pid")
    for e in (1.0, INF, NAN, -INF, 2.0):
        pid(e, 1.0, 0.0, 0.0)
    (line,) = printed
    assert f"warning: {PID_NOT_FINITE} in signal 'v', robot p, tick 0" in line
    assert list(faults.counts.values()) == [3]
    rate, faults, printed = site("rate")
    for x in (1.0, NAN, NAN, 2.0):
        rate(x)
    assert len(printed) == 1 and list(faults.counts.values()) == [2]


# -- the format version, on compiled files ------------------------------------------------------
def program(write: Callable[..., Path], version: str, let: str) -> Program:
    return compile_file(write(f"labsim: {version}\n{HEAD}let:\n{let}rules: ['always stop()']\n"))


def signal_values(p: Program, name: str, readings: list[dict[str, object]]) -> list[object]:
    """The signal's value on each tick, the channels read from ``readings`` (inf for a sonar not given)."""
    robot = p.robot("p", random.Random(0), Faults())
    out = []
    for tick, reading in enumerate(readings):
        values = [reading.get(ch, False if ch == "collided" else INF) for ch in p.channels]
        robot.signals(tick * p.dt_s, tick, values)
        out.append(robot.slots[p.slot_of[name]])
    return out


@pytest.mark.parametrize(("version", "expected"), [
    ("1", [True, False, False, True]), ("1.1", [True, False, False, True]), ("1.2", [False, False, False, True])])
def test_rising_on_the_first_tick_by_version(write, version: str, expected: list[bool]) -> None:
    p = program(write, version, "  up: rising(collided)\n  n: counter(collided)\n")
    bumps = [{"collided": c} for c in (True, True, False, True)]
    assert signal_values(p, "up", bumps) == expected
    assert signal_values(p, "n", bumps) == [float(sum(expected[:k + 1])) for k in range(4)]


def test_counter_and_total_on_a_compiled_file(write) -> None:
    p = program(write, "1.2", "  d: total(sonar1 * dt, sonar2 < 1)\n  walls: counter(sonar5 < 0.5)\n")
    readings = [{"sonar1": 1.0, "sonar5": 0.4}, {"sonar1": 2.0, "sonar5": 0.9}, {"sonar5": 0.3},
                {"sonar1": 4.0, "sonar2": 0.5, "sonar5": 0.2}, {"sonar1": 1.0, "sonar5": 0.8}]
    assert signal_values(p, "d", readings) == pytest.approx([0.05, 0.15, 0.15, 0.0, 0.05])
    assert signal_values(p, "walls", readings) == [0.0, 0.0, 1.0, 1.0, 1.0]


def test_1_1_names_still_win(write) -> None:
    """A file of 1.1 with its own 'total' and 'counter' keeps them; the calls are the built-ins."""
    p = program(write, "1.1", "  total: 2 * x\n  counter: total + counter(collided)\n")
    assert signal_values(p, "counter", [{"x": 1.0, "collided": True}]) == [3.0]


def errors(write: Callable[..., Path], let: str, rule: str = "always stop()", metrics: str = ""
           ) -> list[tuple[str, tuple[str, ...]]]:
    with pytest.raises(LabsimError) as e:
        compile_file(write(f"labsim: 1.2\n{HEAD}let:\n{let}rules: ['{rule}']\n{metrics}"))
    return [(d.message, d.notes) for d in e.value.diagnostics if d.severity == "error"]


@pytest.mark.parametrize(("let", "message", "note"), [
    ("  n: counter(sonar1)\n", "argument 1 of counter() must be a boolean, but this is a number", ""),
    ("  n: counter(collided, 1)\n", "argument 2 of counter() must be a boolean, but this is a number", ""),
    ("  n: total(collided)\n", "argument 1 of total() must be a number, but this is a boolean", ""),
    ("  n: total(1, collided, 2)\n", "total() takes 1 or 2 arguments (x[, reset]), given 3", ""),
    ("  n: sum(x)\n", "sum() takes a group, as in sum(sonar1..sonar8); this is a number",
     "for a running sum over the ticks, use total(x)"),
    ("  n: count(collided)\n", "'count' is a metric aggregate: it can only be the outer call of a 'metrics:' "
     "entry", "in a signal, counter(c) counts how many times c became true; count(...) of a group of booleans, "
     "as in count(front < 0.5), counts the members that hold"),
])
def test_checker_messages(write, let: str, message: str, note: str) -> None:
    ((got, notes),) = errors(write, let)
    assert got == message
    assert not note or note in notes


def test_reading_a_metric_points_at_counter_and_total(write) -> None:
    ((message, notes),) = errors(write, "  n: 1\n", "if bumps > 1 then stop()", "metrics:\n  bumps: count(collided)\n")
    assert message.startswith("'bumps' is a metric")
    assert "'counter(...)' for a count, 'total(...)' for a sum" in notes[0]


# -- inf and nan into every built-in with memory --------------------------------------------------
FINITE = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)
BAD = st.sampled_from([INF, -INF, NAN])
# a run: finite values with stretches of inf, -inf and nan, ending on finite ones
RUNS = st.lists(st.one_of(FINITE, FINITE, BAD), max_size=30).flatmap(
    lambda xs: st.lists(FINITE, min_size=2, max_size=5).map(lambda tail: xs + tail))
QUICK = settings(max_examples=60, derandomize=True, database=None, deadline=None,
                 suppress_health_check=[HealthCheck.too_slow])


def finite(x: object) -> bool:
    return isinstance(x, float) and math.isfinite(x)


@QUICK
@given(RUNS, st.sampled_from([None, 5.0]))
def test_pid_and_total_recover_as_if_the_bad_ticks_had_not_been(xs: list[float], limit: float | None) -> None:
    pid, _, _ = site("pid")
    skipping, _, _ = site("pid")
    total, _, _ = site("total")
    skipping_total, _, _ = site("total")
    last = 0.0
    for x in xs:
        args = (x, 0.5, 0.1, 0.2) if limit is None else (x, 0.5, 0.1, 0.2, limit)
        out, sum_ = pid(*args), total(x)
        assert finite(out) and finite(sum_)
        if finite(x):
            last = skipping(*args)
            assert out == last and sum_ == skipping_total(x)
        else:
            assert out == last  # the last finite output, repeated


@QUICK
@given(RUNS)
def test_rate_starts_afresh_after_a_bad_tick(xs: list[float]) -> None:
    rate, _, _ = site("rate")
    fresh, _, _ = site("rate")
    for x in xs:
        out = rate(x)
        assert finite(out)
        if finite(x):
            assert out == fresh(x)
        else:
            assert out == 0.0
            fresh, _, _ = site("rate")  # the next finite value is a first tick


@QUICK
@given(RUNS, st.lists(st.booleans(), min_size=40, max_size=40))
def test_functions_of_conditions_read_nan_as_false(xs: list[float], other: list[bool]) -> None:
    """c = x > 0: a nan compares false, so each gives what it gives for a false c, and stays finite."""
    for kind, args in (("counter", lambda c, r: (c,)), ("counter@1.2", lambda c, r: (c, r)),
                       ("held", lambda c, r: (c,)), ("hold", lambda c, r: (c, r)),
                       ("rising", lambda c, r: (c,)), ("rising@1.2", lambda c, r: (c,)),
                       ("falling", lambda c, r: (c,))):
        f, _, _ = site(kind)
        g, _, _ = site(kind)
        for x, r in zip(xs, other):
            out = f(*args(x > 0, r))
            assert out == g(*args(x > 0 if x == x else False, r))
            assert isinstance(out, bool) or finite(out)


@QUICK
@given(RUNS)
def test_prev_and_remember_are_finite_again_once_their_input_is(xs: list[float]) -> None:
    prev, _, _ = site("prev")
    remember, _, _ = site("remember")
    outs = [(prev(x, 0.0), remember(x, True)) for x in xs]
    assert finite(outs[-1][0]) and finite(outs[-1][1])  # the last two inputs are finite


# -- warnings: before the run, and while it runs ------------------------------------------------
def test_counter_and_total_warn_where_they_miss_ticks(write) -> None:
    path = write(f"labsim: 1.2\n{HEAD}rules:\n  - if time > 1 and counter(collided) > 2 then stop()\n"
                 "  - always move(total(1))\n")
    messages = [d.message for d in compile_file(path).warnings]
    assert "counter() is after 'and', evaluated only on the ticks what comes before it holds: its memory " \
           "misses the other ticks" in messages
    assert "total() is in a rule's action, evaluated only on the ticks the rule fires: its memory misses the " \
           "other ticks" in messages


def test_a_pid_under_detected_is_not_warned_about_inf(write) -> None:
    path = write(f"labsim: 1.2\n{HEAD}let:\n  out: pid(sonar8 - 0.5, 1, 0, 0) if detected(sonar8) else 0\n"
                 "  far: pid(max(sonar2, 1) - 0.5, 1, 0, 0)\nrules:\n  - always arc(out, far)\n")
    messages = [d.message for d in compile_file(path).warnings]
    assert not any("sonar8, which is inf" in m for m in messages)
    assert any(m.startswith("pid()'s error reads sonar2, which is inf") for m in messages)


def test_a_pid_given_inf_warns_once_with_its_signal_robot_and_tick(write) -> None:
    p = program(write, "1.2", "  out: pid(sonar1, 1, 0, 0)\n")
    printed: list[str] = []
    faults = Faults(printed.append)
    robot = p.robot("p", random.Random(0), faults)
    outs = []
    for tick, reading in enumerate((1.0, 2.0, INF, NAN, INF, 0.5)):
        robot.signals(tick * p.dt_s, tick, [reading if ch == "sonar1" else False for ch in p.channels])
        outs.append(robot.slots[p.slot_of["out"]])
    assert outs == [1.0, 2.0, 2.0, 2.0, 2.0, 0.5]
    (line,) = printed
    assert "b.yaml:6:8: warning: " + PID_NOT_FINITE + " in signal 'out', robot p, tick 2\n" in line
    assert list(faults.counts.values()) == [3]


def test_memory_in_a_log_field_warns_as_in_an_action(write) -> None:
    """log("{count(rising(g > 1))}") runs its fields only on the ticks the rule fires, as an action's arguments."""
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 0.3\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 "let:\n  g: '[tick, tick * 2]'\nrules:\n"
                 '  - when tick == 3 then log("edges={count(rising(g > 1))} sum={sum(total(g))} {prev(tick, 0)}")\n'
                 '  - always log("{rising(tick > 2)}")\n')
    warned = [(d.line, d.col, d.message) for d in compile_file(path).warnings]
    assert warned == [(9, 43, "rising() is in a rule's action, evaluated only on the ticks the rule fires: its memory "
                              "misses the other ticks"),
                      (9, 68, "total() is in a rule's action, evaluated only on the ticks the rule fires: its memory "
                              "misses the other ticks"),
                      (9, 80, "prev() is in a rule's action, evaluated only on the ticks the rule fires: its memory "
                              "misses the other ticks")]
