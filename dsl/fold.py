"""Constant folding: the value of an expression that reads nothing at run time.

``labsim.dsl.codegen`` folds parameters, constants and the arithmetic on them into literals
(``time >= minutes * 60`` becomes ``(v0 >= 1500.0)``), computed here once with the operations
the generated code would run each tick. An expression folds only when it reads no slot, calls
no random, stateful or fault-prone built-in, and raises nothing: ``1 / 0`` is left to run
time, where its guard gives the documented result and warns at its site. tests/unit/test_differential.py
checks folding against the generated code and the reference evaluator (``labsim.dsl.evaluate``).
"""
from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from labsim.dsl import ast
from labsim.dsl.builtins import FUNCTIONS

# Functions that return a value for every argument (inf and nan included): generated code calls
# them directly. The others may raise (sqrt(-1), log(-1), exp(1000), randint(3, 2), crop outside
# the image) and go through a guard that turns the exception into a defined result and a
# warning; centroid and pid have guards of their own.
TOTAL = frozenset({"abs", "min", "max", "clamp", "hypot", "atan2",
                   "sign", "deg", "rad", "random", "uniform", "gauss",
                   "gray", "threshold", "invert", "area", "width", "height"})
FOLDABLE = frozenset(f for f in TOTAL if callable(FUNCTIONS[f].impl) and not FUNCTIONS[f].uses_rng)


class NotConstant(Exception):
    """The expression reads something at run time, or faults: it is computed at run time."""


def fold(e: ast.Expr, constants: Mapping[str, object]) -> object:
    """The value of ``e``, whose names other than ``constants`` are read at run time; NotConstant if it has one."""
    if isinstance(e, (ast.Number, ast.Bool)):
        return e.value
    if isinstance(e, ast.Name):
        if e.id in constants:
            return constants[e.id]
        raise NotConstant
    try:
        if isinstance(e, ast.Neg):
            operand: Any = fold(e.operand, constants)
            return -operand
        if isinstance(e, ast.Not):
            return not fold(e.operand, constants)
        if isinstance(e, ast.Binary):
            return _BINARY[e.op](fold(e.left, constants), fold(e.right, constants))
        if isinstance(e, ast.Compare):
            values = [fold(o, constants) for o in e.operands]
            return all(_COMPARE[op](a, b) for op, a, b in zip(e.ops, values, values[1:]))
        if isinstance(e, ast.BoolOp):
            values = [fold(v, constants) for v in e.values]
            return all(values) if e.op == "and" else any(values)
        if isinstance(e, ast.IfExp):
            return fold(e.body, constants) if fold(e.test, constants) else fold(e.orelse, constants)
        if isinstance(e, ast.Call) and e.func in FOLDABLE:
            return FUNCTIONS[e.func].resolve()(*(fold(a, constants) for a in e.args))
    except (ArithmeticError, ValueError, TypeError):
        raise NotConstant from None  # left to run time, where it warns at its site
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
