"""A sonar's inf on its way into a pid(): a warning, after the linter.

``labsim.dsl.compile`` runs ``check_unbounded`` beside ``labsim.dsl.analysis.lint`` on a behaviour
without errors. A distance sensor reads ``inf`` when nothing is within its range, and a
``pid(error, ...)`` given an inf error repeats its last output and holds its state
(docs/language.md, "PID"): the robot steers blind while the sonar sees nothing. The warning is
at each pid() whose error reads such a sensor, directly or through ``let`` signals, with
nothing on the way that keeps the inf out: a ``detected(...)`` (or any test that reads the
sensor) choosing the branch, ``clamp(x, lo, hi)`` with a finite ``hi``, ``min(...)`` with a
finite argument, a division by it, or a function whose result is finite whatever it is given.
It reads the checked file only, and errs towards silence: a test that reads the sensor counts
as a guard whatever it tests.
"""
from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

from labsim.dsl.analysis.check import Checked
from labsim.dsl.analysis.lint import Linter
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.ast import LetMemo, walk
from labsim.foundation.diagnostics import Report

# Functions whose result is finite whatever they are given (pid, rate and total leave inf out).
_FINITE = frozenset({"sign", "atan2", "pid", "rate", "total", "counter", "held"})
_DEPTH = 100  # signals read through signals: as deep as the linter follows them


def check_unbounded(c: Checked, report: Report) -> None:
    """Warn at each pid() whose error can be a distance sensor's inf."""
    linter = Linter(c, report)
    reach = _Reach(linter)
    for e, text in linter.every_expression():
        for call, guarded in reach.pid_calls(e, frozenset()):
            if not call.args:
                continue
            sensor = reach.sensor(call.args[0], guarded)
            if sensor is None:
                continue
            ranges = [s.range_m for m in c.models.values() for s in m.rays() if s.name == sensor]
            within = f"within its range ({max(ranges):g} m, the model's range_m)" if ranges else "in range"
            bound = f"{max(ranges):g}" if ranges else "1"
            linter.warn(text.at(call.func_span),
                        f"pid()'s error reads {sensor}, which is inf when nothing is {within}: on those ticks "
                        "pid() gives its last output again and its state does not change",
                        f"keep the inf out before it reaches pid(): bound the reading, as in "
                        f"'clamp({sensor}, 0, {bound}) - 0.5', or compute the error in a signal that says what "
                        f"to do when nothing is seen, as in 'err: {sensor} - 0.5 if detected({sensor}) else 0', "
                        "and write pid(err, ...)")


class _Reach:
    """Where a distance sensor's inf can go in an expression, and where it is kept out."""

    def __init__(self, linter: Linter) -> None:
        self.linter = linter
        self.distance = linter.c.distance_channels
        self.lets = linter.let_exprs
        # each signal followed once: the sensors it reads, and (for each set of guarded sensors)
        # the sensor whose inf it can be; a signal read twice is not followed twice
        self.read_lets: LetMemo[frozenset[str]] = LetMemo(self.lets, self.read, frozenset())
        self.sensor_lets: dict[tuple[str, frozenset[str]], str | None] = {}
        self.sensors = _Sensor(self)

    def pid_calls(self, e: ast.Expr, guarded: frozenset[str]) -> Iterator[tuple[ast.Call, frozenset[str]]]:
        """Each pid() call in e, with the sensors a test on the way to it reads (those are guarded)."""
        found: list[tuple[ast.Call, frozenset[str]]] = []
        _PidCalls(self, found).visit(e, guarded)
        return iter(found)

    def read(self, e: ast.Expr) -> frozenset[str]:
        """The distance sensors e reads, directly or through signals."""
        out: set[str] = set()
        for node in walk(e):
            if isinstance(node, ast.Name):
                if node.id in self.distance:
                    out.add(node.id)
                elif node.id in self.lets:
                    out |= self.read_lets(node.id)
        return frozenset(out)

    def sensor(self, e: ast.Expr, guarded: frozenset[str], depth: int = 0) -> str | None:
        """A distance sensor whose inf can be e's value, none of ``guarded``; None if there is none."""
        return self.sensors.visit(e, guarded, depth)

    def name(self, e: ast.Name, guarded: frozenset[str], depth: int) -> str | None:
        if e.id in self.distance:
            return None if e.id in guarded else e.id
        if e.id not in self.lets:
            return None
        key = (e.id, guarded)
        if key not in self.sensor_lets:
            if depth >= _DEPTH:
                return None
            self.sensor_lets[key] = None  # while it is followed: prev(s, 0) inside s adds nothing
            self.sensor_lets[key] = self.sensor(self.lets[e.id], guarded, depth + 1)
        return self.sensor_lets[key]

    def call(self, e: ast.Call, guarded: frozenset[str], depth: int) -> str | None:
        if e.func in _FINITE or len(e.args) == 0:
            return None
        args = e.args[0].members if len(e.args) == 1 and isinstance(e.args[0], ast.Group) else e.args
        if e.func == "heard":  # a channel's name, not a reading: what is heard is finite, its default may not be
            args = e.args[1:]
        found = [self.sensor(a, guarded, depth) for a in args]
        if e.func == "min" and not all(f or self.infinite(a) for f, a in zip(found, args)):
            return None  # an argument that is never inf bounds it
        if e.func == "clamp" and len(args) == 3:  # clamp(inf, lo, hi) is hi
            hi_unbounded = found[2] is not None or self.infinite(e.args[2])
            return found[0] if hi_unbounded and found[0] else found[1] or found[2]
        return next((f for f in found if f), None)

    def infinite(self, e: ast.Expr) -> bool:
        """Whether e is known before the run to be infinite or nan (a parameter set to inf)."""
        value = self.linter.known(e)
        return isinstance(value, int | float) and not isinstance(value, bool) and not math.isfinite(value)



class _PidCalls(ast.Visitor[None]):
    """Each pid() call of an expression, with the sensors a test on the way to it reads."""

    def __init__(self, reach: _Reach, found: list[tuple[ast.Call, frozenset[str]]]) -> None:
        self.reach = reach
        self.found = found

    def visit_Call(self, e: ast.Call, guarded: frozenset[str]) -> None:
        if e.func == "pid":
            self.found.append((e, guarded))
        self.generic_visit(e, guarded)

    def visit_IfExp(self, e: ast.IfExp, guarded: frozenset[str]) -> None:
        self.visit(e.test, guarded)
        inside = guarded | self.reach.read(e.test)
        self.visit(e.body, inside)
        self.visit(e.orelse, inside)

    def visit_BoolOp(self, e: ast.BoolOp, guarded: frozenset[str]) -> None:
        for i, part in enumerate(e.values):  # a later part runs only when the earlier ones let it
            self.visit(part, guarded.union(*(self.reach.read(v) for v in e.values[:i])))

    generic = frozenset(set(ast.node_classes()) - {ast.Call, ast.IfExp, ast.BoolOp})


class _Sensor(ast.Visitor["str | None"]):
    """A distance sensor whose inf can be an expression's value, none of the guarded ones."""

    def __init__(self, reach: _Reach) -> None:
        self.reach = reach

    def visit_Name(self, e: ast.Name, guarded: frozenset[str], depth: int) -> str | None:
        return self.reach.name(e, guarded, depth)

    def visit_IfExp(self, e: ast.IfExp, guarded: frozenset[str], depth: int) -> str | None:
        inside = guarded | self.reach.read(e.test)
        return self.visit(e.body, inside, depth) or self.visit(e.orelse, inside, depth)

    def visit_Binary(self, e: ast.Binary, guarded: frozenset[str], depth: int) -> str | None:
        if e.op == "/":
            return self.visit(e.left, guarded, depth)  # x / inf is 0
        return self.generic_visit(e, guarded, depth)

    def visit_Call(self, e: ast.Call, guarded: frozenset[str], depth: int) -> str | None:
        return self.reach.call(e, guarded, depth)

    def visit_Compare(self, e: ast.Expr, guarded: frozenset[str], depth: int) -> str | None:
        return None  # booleans, records and text: not an error's number

    def visit_Index(self, e: ast.Index, guarded: frozenset[str], depth: int) -> str | None:
        return self.visit(e.value, guarded, depth)  # any member may be the one picked

    def visit_Slice(self, e: ast.Slice, guarded: frozenset[str], depth: int) -> str | None:
        return self.visit(e.value, guarded, depth)  # its bounds are places, known before the run

    visit_BoolOp = visit_Not = visit_Attribute = visit_Text = visit_Bool = visit_Number = visit_Compare
    visit_Peer = visit_Compare  # another robot's value: the pid warning follows this robot's sensors
    # a number made of others (a group of them) can be inf when one of them is
    generic = frozenset({ast.Neg, ast.Group})

    def generic_visit(self, e: ast.Expr, *args: Any) -> str | None:
        for sub in ast.children(e):
            found = self.visit(sub, *args)
            if found:
                return found
        return None
