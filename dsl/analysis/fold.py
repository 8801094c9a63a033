"""Constant folding: the value of an expression that reads nothing at run time.

``labsim.dsl.emit.codegen`` folds parameters, constants and the arithmetic on them into literals
(``time >= minutes * 60`` becomes ``(v0 >= 1500.0)``), computed here once with the operations
the generated code would run each tick. An expression folds only when it reads no slot, calls
no random, stateful or fault-prone built-in, and raises nothing: ``1 / 0`` is left to run
time, where its guard gives the documented result and warns at its site. tests/unit/test_differential.py
checks folding against the generated code and the reference evaluator (``labsim.dsl.analysis.evaluate``).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from labsim.dsl.library.builtins import FUNCTIONS
from labsim.dsl.syntax import ast

# Functions that return a value for every argument (inf and nan included): generated code calls
# them directly. The others may raise (sqrt(-1), log(-1), exp(1000), randint(3, 2), crop outside
# the image) and go through a guard that turns the exception into a defined result and a
# warning; centroid and pid have guards of their own.
TOTAL = frozenset({"abs", "min", "max", "clamp", "hypot", "atan2",
                   "sign", "deg", "rad", "random", "uniform", "gauss",
                   "gray", "threshold", "invert", "area", "width", "height"})
FOLDABLE = frozenset(f for f in TOTAL if callable(FUNCTIONS[f].impl) and not FUNCTIONS[f].uses_rng)
# What a place or a slice's bound known before the run may call besides (format 1.3: front[round(k)],
# front[1:len(front)]): a rounding that raises (round(nan)) leaves the place to run time
PLACES = FOLDABLE | {"round", "floor", "ceil"}


class NotConstant(Exception):
    """The expression reads something at run time, or faults: it is computed at run time."""


def fold(e: ast.Expr, constants: Mapping[str, object], functions: frozenset[str] | None = None,
         lengths: Mapping[int, int] | None = None) -> object:
    """The value of ``e``, whose names other than ``constants`` are read at run time; NotConstant if it has one.

    ``functions`` are the built-ins computed here (FOLDABLE by default; the linter, which
    only reads the value, takes more of them); ``lengths`` the checker's sizes of ``len(...)``
    calls by id (``len(front)``: a group's size is known before the run)."""
    try:
        return _Folder(constants, FOLDABLE if functions is None else functions, lengths or {}).visit(e)
    except (ArithmeticError, ValueError, TypeError):
        raise NotConstant from None  # left to run time, where it warns at its site


class _Folder(ast.Visitor[Any]):
    """A constant expression's value; NotConstant at the first node that reads something at run time."""

    def __init__(self, constants: Mapping[str, object], functions: frozenset[str], lengths: Mapping[int, int]) -> None:
        self.constants = constants
        self.functions = functions
        self.lengths = lengths

    def visit_Number(self, e: ast.Number) -> object:
        return e.value

    visit_Bool = visit_Number

    def visit_Name(self, e: ast.Name) -> object:
        if e.id in self.constants:
            return self.constants[e.id]
        raise NotConstant

    def visit_Neg(self, e: ast.Neg) -> object:
        return -self.visit(e.operand)

    def visit_Not(self, e: ast.Not) -> object:
        return not self.visit(e.operand)

    def visit_Binary(self, e: ast.Binary) -> object:
        return _BINARY[e.op](self.visit(e.left), self.visit(e.right))

    def visit_Compare(self, e: ast.Compare) -> object:
        values = [self.visit(o) for o in e.operands]
        return all(_COMPARE[op](a, b) for op, a, b in zip(e.ops, values, values[1:]))

    def visit_BoolOp(self, e: ast.BoolOp) -> object:
        values = [self.visit(v) for v in e.values]
        return all(values) if e.op == "and" else any(values)

    def visit_IfExp(self, e: ast.IfExp) -> object:
        return self.visit(e.body) if self.visit(e.test) else self.visit(e.orelse)

    def visit_Call(self, e: ast.Call) -> object:
        if id(e) in self.lengths:
            return float(self.lengths[id(e)])
        if e.func == "len" and len(e.args) == 1 and isinstance(e.args[0], ast.Name):
            value = self.constants.get(e.args[0].id)
            if isinstance(value, tuple):  # a list parameter (format 1.3): its rows or numbers
                return float(len(value))
        if e.func not in self.functions:
            raise NotConstant
        return FUNCTIONS[e.func].resolve()(*(self.visit(a) for a in e.args))

    def visit_Index(self, e: ast.Index) -> object:
        value = self.picked(e)
        if isinstance(value, tuple):
            raise NotConstant  # a row of a list is a group: written out member by member
        return value

    def picked(self, e: ast.Index) -> object:
        """A list parameter's row or number at a place known before the run (format 1.3): ``waypoints[1][0]``."""
        base = self.picked(e.value) if isinstance(e.value, ast.Index) else (
            self.constants.get(e.value.id) if isinstance(e.value, ast.Name) else None)
        if not isinstance(base, tuple):
            raise NotConstant  # a group's member is read at run time
        k = self.visit(e.index)
        if isinstance(k, bool) or not isinstance(k, int | float) or not float(k).is_integer() or not 0 <= k < len(base):
            raise NotConstant  # the checker says why there is no such row
        return base[int(k)]

    # a record's field, text, a group and its members, another robot's value are computed at run time
    generic = frozenset({ast.Attribute, ast.Text, ast.Group, ast.Slice, ast.Peer})

    def generic_visit(self, e: ast.Expr, *args: Any) -> object:
        raise NotConstant


# folded values are numbers and booleans, which the checker has typed: Any, not object
_BINARY: dict[str, Callable[[Any, Any], Any]] = {
    "+": lambda a, b: a + b, "-": lambda a, b: a - b, "*": lambda a, b: a * b,
    "/": lambda a, b: a / b, "%": lambda a, b: a % b,
    "**": lambda a, b: _real(a ** b),
}
_COMPARE: dict[str, Callable[[Any, Any], bool]] = {
    "<": lambda a, b: a < b, "<=": lambda a, b: a <= b, ">": lambda a, b: a > b,
    ">=": lambda a, b: a >= b, "==": lambda a, b: a == b, "!=": lambda a, b: a != b,
}


def _real(value: object) -> object:
    if isinstance(value, complex):
        raise ValueError("complex result")
    return value
