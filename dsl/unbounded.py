"""A sonar's inf on its way into a pid(): a warning, after the linter.

``labsim.dsl.compile`` runs ``check_unbounded`` beside ``labsim.dsl.lint`` on a behaviour
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

from labsim.dsl import ast
from labsim.dsl.ast import LetMemo, children, walk
from labsim.dsl.check import Checked
from labsim.dsl.lint import Linter
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
        self.read_lets = LetMemo(self.lets, self.read, frozenset())
        self.sensor_lets: dict[tuple[str, frozenset[str]], str | None] = {}

    def pid_calls(self, e: ast.Expr, guarded: frozenset[str]) -> Iterator[tuple[ast.Call, frozenset[str]]]:
        """Each pid() call in e, with the sensors a test on the way to it reads (those are guarded)."""
        if isinstance(e, ast.Call) and e.func == "pid":
            yield e, guarded
        if isinstance(e, ast.IfExp):
            yield from self.pid_calls(e.test, guarded)
            inside = guarded | self.read(e.test)
            yield from self.pid_calls(e.body, inside)
            yield from self.pid_calls(e.orelse, inside)
            return
        if isinstance(e, ast.BoolOp):  # a later part runs only when the earlier ones let it
            for i, part in enumerate(e.values):
                yield from self.pid_calls(part, guarded.union(*(self.read(v) for v in e.values[:i])))
            return
        for sub in children(e):
            yield from self.pid_calls(sub, guarded)

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
        if isinstance(e, ast.Name):
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
        if isinstance(e, ast.IfExp):
            inside = guarded | self.read(e.test)
            return self.sensor(e.body, inside, depth) or self.sensor(e.orelse, inside, depth)
        if isinstance(e, ast.Binary) and e.op == "/":
            return self.sensor(e.left, guarded, depth)  # x / inf is 0
        if isinstance(e, ast.Call):
            return self.call(e, guarded, depth)
        if isinstance(e, ast.Compare | ast.BoolOp | ast.Not | ast.Attribute):
            return None  # booleans and records: not an error's number
        for sub in children(e):
            found = self.sensor(sub, guarded, depth)
            if found:
                return found
        return None

    def call(self, e: ast.Call, guarded: frozenset[str], depth: int) -> str | None:
        if e.func in _FINITE or len(e.args) == 0:
            return None
        found = [self.sensor(a, guarded, depth) for a in e.args]
        if e.func == "min" and not all(f or self.infinite(a) for f, a in zip(found, e.args)):
            return None  # an argument that is never inf bounds it
        if e.func == "clamp" and len(e.args) == 3:  # clamp(inf, lo, hi) is hi
            hi_unbounded = found[2] is not None or self.infinite(e.args[2])
            return found[0] if hi_unbounded and found[0] else found[1] or found[2]
        return next((f for f in found if f), None)

    def infinite(self, e: ast.Expr) -> bool:
        """Whether e is known before the run to be infinite or nan (a parameter set to inf)."""
        value = self.linter.known(e)
        return isinstance(value, int | float) and not isinstance(value, bool) and not math.isfinite(value)

