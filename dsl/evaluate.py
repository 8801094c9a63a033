"""The reference evaluator: an expression's value found by walking its tree, for tests.

The oracle the compiled code is checked against, as cel-python's InterpretedRunner is beside its
CompiledRunner. It follows docs/language.md ("Expressions", "Numbers", "Runtime faults") and
none of the code generator's shortcuts: nothing is folded, ``min`` and ``max`` are calls, every
division goes through the zero check, every number is a float. The operators are written out
here from the documentation; a built-in function is its implementation in ``labsim.dsl.builtins``,
whose exceptions become the documented results. A fault gives its documented result and is
recorded with the span of the expression that faulted and the words of the warning the runtime
prints. tests/unit/test_differential.py checks constant folding
(``labsim.dsl.fold``) and the generated code (``labsim.dsl.codegen``) against it. It sees one
tick: the built-ins that remember earlier ticks (``prev``, ``pid``, ...) are not for it.
"""
from __future__ import annotations

import math
import random
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from labsim.dsl import ast
from labsim.dsl.builtins import CONSTANTS, DETECTED, FIELDS, FUNCTIONS, Type

INF = math.inf
NAN = math.nan


@dataclass(frozen=True)
class Fault:
    """A runtime fault: where (the span of the faulting expression in its text) and the warning's words."""

    span: ast.Span
    what: str


class Unsupported(Exception):
    """An expression the evaluator does not take: a built-in with memory of earlier ticks, or
    a random one without a generator."""


def evaluate(e: ast.Expr, names: Mapping[str, object], rng: random.Random | None = None
             ) -> tuple[object, tuple[Fault, ...]]:
    """The value of ``e`` and the faults met on the way, in the order they happened.

    ``names`` gives every name's value this tick (sensors, signals, parameters, ``time``,
    states as their indices, ``state``); ``pi`` and ``inf`` are known. Records (a joint, a
    centroid) are tuples in FIELDS order. ``rng`` is the robot's generator, for ``random()``
    and its kind, drawn in the order the language evaluates: left to right, lazily.
    """
    walker = _Walker(names, rng)
    value = walker.value(e)
    return value, tuple(walker.faults)


# every field name has one index in every record type that has it (x is 0, found 2, ...)
_FIELD = {name: index for fields in FIELDS.values() for name, (index, _) in fields.items()}


class _Walker:
    def __init__(self, names: Mapping[str, object], rng: random.Random | None) -> None:
        self.names = names
        self.rng = rng
        self.faults: list[Fault] = []

    def value(self, e: ast.Expr) -> Any:
        if isinstance(e, ast.Number):
            return float(e.value)
        if isinstance(e, ast.Bool):
            return e.value
        if isinstance(e, ast.Name):
            return _number(self.names[e.id] if e.id in self.names else CONSTANTS[e.id])
        if isinstance(e, ast.Neg):
            return -self.value(e.operand)
        if isinstance(e, ast.Not):
            return not self.value(e.operand)
        if isinstance(e, ast.Binary):
            x, y = self.value(e.left), self.value(e.right)
            return _ARITHMETIC[e.op](x, y, lambda what: self.faults.append(Fault(e.span, what)))
        if isinstance(e, ast.Compare):  # a chain stops at the first pair that does not hold
            left = self.value(e.operands[0])
            for op, operand in zip(e.ops, e.operands[1:]):
                right = self.value(operand)
                if not _COMPARE[op](left, right):
                    return False
                left = right
            return True
        if isinstance(e, ast.BoolOp):  # stops at the first part that decides it
            decides = e.op == "or"  # a true part decides an 'or', a false one an 'and'
            for part in e.values:
                if bool(self.value(part)) == decides:
                    return decides
            return not decides
        if isinstance(e, ast.IfExp):
            return self.value(e.body) if self.value(e.test) else self.value(e.orelse)
        if isinstance(e, ast.Attribute):
            return _number(self.value(e.value)[_FIELD[e.attr]])
        if isinstance(e, ast.Call):
            return self.call(e)
        raise Unsupported(f"no value for {e!r}")

    def call(self, e: ast.Call) -> Any:
        if e.func == DETECTED:  # takes the sensor's name: it sees something when its reading is finite
            assert isinstance(e.args[0], ast.Name)
            return self.value(e.args[0]) < INF
        f = FUNCTIONS[e.func]
        if f.stateful:
            raise Unsupported(f"{e.func}() remembers earlier ticks; the evaluator sees one")
        args = [self.value(a) for a in e.args]
        impl = f.resolve()
        if f.uses_rng:
            if self.rng is None:
                raise Unsupported(f"{e.func}() needs the robot's random generator")
            args.insert(0, self.rng)
        if f.returns is Type.IMAGE or f.params[:1] == (Type.IMAGE,):
            return self.image_call(e, impl, args)
        try:
            return _number(impl(*args))
        except OverflowError:  # exp(1000): the number is too large
            self.faults.append(Fault(e.span, f"{e.func}(): overflow"))
            return INF
        except (ValueError, ZeroDivisionError) as exc:  # sqrt(-1), log(-1), randint(3, 2): nan
            self.faults.append(Fault(e.span, f"{e.func}(): {exc}" if str(exc) else f"{e.func}() failed"))
            return NAN

    def image_call(self, e: ast.Call, impl: Callable[..., object], args: list) -> Any:
        """An image function: ``crop`` outside the image gives the empty image, ``centroid`` of
        one with no set pixel the image centre with ``.found`` false; each warns."""
        from labsim.dsl.images import EMPTY, EmptyCentroid  # numpy, only for behaviours with images

        try:
            result = impl(*args)
        except EmptyCentroid as empty:
            self.faults.append(Fault(e.span, "centroid of an image with no set pixel "
                                             "(the result is the image centre, .found false)"))
            return empty.result
        except OverflowError:
            self.faults.append(Fault(e.span, f"{e.func}(): overflow"))
            return INF if FUNCTIONS[e.func].returns is Type.NUMBER else EMPTY
        except (ValueError, ZeroDivisionError) as exc:
            self.faults.append(Fault(e.span, f"{e.func}(): {exc}" if str(exc) else f"{e.func}() failed"))
            return EMPTY if FUNCTIONS[e.func].returns is Type.IMAGE else NAN
        return _number(result)


def _number(value: Any) -> Any:
    """Every number of the language is a float: a whole number from Python's side becomes one."""
    return float(value) if isinstance(value, int) and not isinstance(value, bool) else value


# -- the operators, as docs/language.md defines them ----------------------------------------------
Report = Callable[[str], None]


def _divide(x: float, y: float, fault: Report) -> float:
    """``x / 0`` is inf with the sign of x, ``0 / 0`` and ``nan / 0`` nan; each warns."""
    if y == 0:
        fault("division by zero")
        return NAN if x == 0 or x != x else math.copysign(INF, x)
    return x / y


def _modulo(x: float, y: float, fault: Report) -> float:
    """``x % 0`` is nan and warns; otherwise the remainder has the divisor's sign (Python's ``%``)."""
    if y == 0:
        fault("modulo by zero")
        return NAN
    return x % y


def _power(x: float, y: float, fault: Report) -> float:
    """``0 ** -1`` is inf, a negative number to a fractional power nan, a result beyond a float's
    range inf (-inf for a negative base to an odd power); each warns."""
    if x == 0 and -INF < y < 0:
        fault("zero to a negative power")
        return INF
    if -INF < x < 0 and -INF < y < INF and not y.is_integer():
        fault("a negative number to a fractional power")
        return NAN
    try:
        return x ** y
    except OverflowError:
        fault("overflow in '**'")
        return -INF if x < 0 and y % 2 == 1 else INF


_ARITHMETIC: dict[str, Callable[[float, float, Report], float]] = {
    "+": lambda x, y, _: x + y, "-": lambda x, y, _: x - y, "*": lambda x, y, _: x * y,
    "/": _divide, "%": _modulo, "**": _power,
}
# nan compared with anything is false, as IEEE 754 says
_COMPARE: dict[str, Callable[[Any, Any], bool]] = {
    "<": lambda a, b: a < b, "<=": lambda a, b: a <= b, ">": lambda a, b: a > b,
    ">=": lambda a, b: a >= b, "==": lambda a, b: a == b, "!=": lambda a, b: a != b,
}
