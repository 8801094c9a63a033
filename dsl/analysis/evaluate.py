"""The reference evaluator: an expression's value found by walking its tree, for tests and breakpoints.

The oracle the compiled code is checked against, as cel-python's InterpretedRunner is beside its
CompiledRunner. It follows docs/language.md ("Expressions", "Numbers", "Groups", "Functions of
your own", "Runtime faults") and none of the code generator's shortcuts: nothing is folded but a
group's place, ``min`` and ``max`` are calls, every division goes through the zero check, every
number is a float. The operators are written out here from the documentation; a built-in
function is its implementation in ``labsim.dsl.library.builtins``, whose exceptions become the
documented results. A fault gives its documented result and is recorded with the span of the
expression that faulted and the words of the warning the runtime prints.
tests/unit/test_differential.py checks constant folding (``labsim.dsl.analysis.fold``) and the generated
code (``labsim.dsl.emit.codegen``) against it; a breakpoint (``labsim.dsl.watch``) is evaluated by it.

The whole language: a group is a tuple of its members' values, an operator applies member by
member, a reduction takes the members as ``and``/``or`` do, lazily where the language is lazy
(``any``, ``all``); a user function's body is evaluated with each parameter standing for its
argument's expression, evaluated where the body reads it (as the generated code writes the body
in place of the call); a built-in with memory (``prev``, ``rising``, ...) keeps its state in a
``Memory`` that lives as long as the run, one per robot, and a ``log``'s text is ``log_text``.

Over 500 lines: it is the language's meaning in one walk, each construct beside the others, so that
the differential test compares the generated code with one reading of every node.
"""
from __future__ import annotations

import math
import random
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from labsim.dsl.analysis.fold import NotConstant, fold
from labsim.dsl.library.builtins import CONSTANTS, DETECTED, FIELDS, FUNCTIONS, REDUCTIONS, Type, argmax, argmin
from labsim.dsl.library.memory import PRIMED
from labsim.dsl.library.support import make_pid, show_field
from labsim.dsl.syntax import ast

INF = math.inf
NAN = math.nan


@dataclass(frozen=True)
class Fault:
    """A runtime fault: where (the span of the faulting expression in its text) and the warning's words."""

    span: ast.Span
    what: str
    within: tuple[str, ...] = ()  # the functions of the file's own whose body it is in (the span is the last's)


class Unsupported(Exception):
    """An expression the evaluator does not take: a built-in with memory of earlier ticks without a
    ``Memory``, a random one without a generator, a function of its own without its definition."""


@dataclass
class Memory:
    """The state of the built-ins with memory between ticks: one closure per call site, as the
    generated code keeps (``labsim.dsl.library.memory``); ``version`` is the file's format (``rising`` and
    ``counter`` prime from 1.2 on)."""

    dt_s: float
    version: float = 1.2
    # id(call), or (id(call), member) for a call given a group (format 1.3): a memory per member
    sites: dict[object, Callable[..., object]] = field(default_factory=dict)
    report: list[Callable[[str], None]] = field(default_factory=list)  # the evaluation's, while it runs


class Members(tuple):
    """A group's values, a member each (a plain tuple is a record: a joint's, a centroid's)."""

    __slots__ = ()


class Rows(tuple):
    """A list parameter of rows (format 1.3), each row a ``Members``: ``waypoints[i]`` is a row."""

    __slots__ = ()


Function = tuple[tuple[str, ...], ast.Expr]  # a function of the file's own: its parameters and body


def evaluate(e: ast.Expr, names: Mapping[str, object], rng: random.Random | None = None, *,
             functions: Mapping[str, Function] | None = None, memory: Memory | None = None,
             constants: Mapping[str, object] | None = None) -> tuple[object, tuple[Fault, ...]]:
    """The value of ``e`` and the faults met on the way, in the order they happened.

    ``names`` gives every name's value this tick (sensors, signals, parameters, ``time``,
    states as their indices, ``state``); ``pi`` and ``inf`` are known; a group signal is a tuple
    of its members. Records (a joint, a centroid) are tuples in FIELDS order. ``rng`` is the
    robot's generator, for ``random()`` and its kind, drawn in the order the language evaluates:
    left to right, lazily. ``functions`` are the file's own; ``memory`` the robot's built-ins
    with memory. ``constants`` are the names the code generator folds (the constants and ``dt``
    by default, and the parameters every robot shares): a group's place made of them picks its
    member alone, and the other members are not evaluated.
    """
    if constants is None:  # a list of rows is a list parameter (format 1.3), which folds
        constants = {**CONSTANTS, **({"dt": names["dt"]} if "dt" in names else {}),
                     **{k: v for k, v in names.items() if isinstance(v, Rows)}}
    walker = _Walker(names, rng, functions or {}, memory, constants)
    value = walker.visit(e)
    return value, tuple(walker.faults)


def log_text(text: tuple[str | tuple[ast.Expr, str], ...], names: Mapping[str, object],
             rng: random.Random | None = None, **options: Any) -> tuple[str, tuple[Fault, ...]]:
    """A log's text (``ast.Action.text``): its literal parts, and each field's value formatted with
    its spec as the runtime shows it (``labsim.dsl.library.support.show_field``); with the faults of the fields."""
    out: list[str] = []
    faults: list[Fault] = []
    for part in text:
        if isinstance(part, str):
            out.append(part)
            continue
        value, met = evaluate(part[0], names, rng, **options)
        faults += met
        out.append(show_field(value, part[1]))
    return "".join(out), tuple(faults)


# every field name has one index in every record type that has it (x is 0, found 2, ...)
_FIELD = {name: index for fields in FIELDS.values() for name, (index, _) in fields.items()}
# a parameter of a function of the file's own: its argument's expression, read in the caller's scope
# (its parameters, and the functions it is inside)
_Argument = tuple[ast.Expr, "dict[str, Any]", tuple[str, ...]]


class _Walker(ast.Visitor[Any]):
    """One evaluation: ``visit`` gives a node's value (a tuple for a group), ``member`` one member's."""

    def __init__(self, names: Mapping[str, object], rng: random.Random | None, functions: Mapping[str, Function],
                 memory: Memory | None, constants: Mapping[str, object]) -> None:
        self.names = names
        self.rng = rng
        self.functions = functions
        self.memory = memory
        self.constants = constants
        self.faults: list[Fault] = []
        self.env: dict[str, _Argument] = {}  # inside a function's body: its parameters
        self.missing_rows: set[int] = set()  # id(waypoints[i]) with no row i: its fault is recorded once
        self.within: tuple[str, ...] = ()

    def fault(self, e: ast.Expr, what: str) -> None:
        self.faults.append(Fault(e.span, what, self.within))

    # -- what is a group, and its members -------------------------------------------------------
    def size(self, e: ast.Expr) -> int:
        """How many members e has; 0 when it is one value."""
        if isinstance(e, ast.Group):
            return len(e.members)
        if isinstance(e, ast.Name):
            if e.id in self.env:
                return self.inside(self.env[e.id], self.size)
            value = self.names.get(e.id)
            return len(value) if isinstance(value, Members) else 0
        if isinstance(e, ast.Neg | ast.Not | ast.Binary | ast.Compare | ast.BoolOp | ast.IfExp):
            return max((self.size(c) for c in ast.children(e)), default=0)
        if isinstance(e, ast.Call) and e.func in self.functions:
            return self.inside(self.call_of(e), self.size)
        reduced = e.func in REDUCTIONS and len(e.args) == 1 if isinstance(e, ast.Call) else False
        if isinstance(e, ast.Call) and e.func not in (DETECTED, "len") and not reduced:
            return max((self.size(a) for a in e.args), default=0)  # a built-in given a group: member by member
        if isinstance(e, ast.Slice):
            lower, upper = self.bounds(e)
            return upper - lower
        rows = self.rows(e)
        return len(rows[0]) if rows is not None else 0

    def rows(self, e: ast.Expr) -> Rows | None:
        """The list of rows ``e`` picks a row of (``waypoints[i]``), or None if it is not such a pick."""
        if not isinstance(e, ast.Index) or not isinstance(e.value, ast.Name) or e.value.id in self.env:
            return None
        value = self.names.get(e.value.id)
        return value if isinstance(value, Rows) else None

    def row_member(self, e: ast.Index, rows: Rows, i: int) -> Any:
        """Value i of the row ``waypoints[k]``: nan, and one fault for the row, when there is no row k."""
        k: Any
        try:
            k = fold(e.index, {k: v for k, v in self.constants.items() if k not in self.env})
        except NotConstant:
            k = self.visit(e.index)
        if 0 <= k < len(rows) and k == int(k):
            return _number(rows[int(k)][i])
        if id(e) not in self.missing_rows:
            self.missing_rows.add(id(e))
            self.fault(e, f"no row at the place asked of a list of {len(rows)} rows (places count from 0)")
        return NAN

    def bounds(self, e: ast.Slice) -> tuple[int, int]:
        """A slice's places, from lower up to upper (not included); the checker made them whole numbers
        known before the run, within the group."""
        lower = 0 if e.lower is None else int(self.visit(e.lower))
        upper = self.size(e.value) if e.upper is None else int(self.visit(e.upper))
        return lower, upper

    def inside(self, where: _Argument, f: Callable[[ast.Expr], Any]) -> Any:
        """f of an expression in its scope: an argument in its caller's, a body in its call's."""
        e, env, within = where
        outer = self.env, self.within
        self.env, self.within = env, within
        try:
            return f(e)
        finally:
            self.env, self.within = outer

    def call_of(self, e: ast.Call) -> _Argument:
        """A call of the file's own function: its body, with each parameter its argument."""
        params, body = self.functions[e.func]
        return body, {p: (a, self.env, self.within) for p, a in zip(params, e.args)}, (*self.within, e.func)

    def members(self, e: ast.Expr) -> Members:
        return Members(self.member(e, i) for i in range(self.size(e)))

    def spread(self, e: ast.Expr, i: int) -> Any:
        """An operand of an operator on groups: its member i, or its value (again, for each member)."""
        return self.member(e, i) if self.size(e) else self.visit(e)

    def member(self, e: ast.Expr, i: int) -> Any:
        """Member i of a group-typed expression, computed as the generated code computes it alone."""
        if isinstance(e, ast.Group):
            return self.visit(e.members[i])
        if isinstance(e, ast.Name):
            if e.id in self.env:
                return self.inside(self.env[e.id], lambda a: self.member(a, i))
            return _number(self.names[e.id][i])  # type: ignore[index]
        if isinstance(e, ast.Neg):
            return -self.spread(e.operand, i)
        if isinstance(e, ast.Not):
            return not self.spread(e.operand, i)
        if isinstance(e, ast.Binary):
            x, y = self.spread(e.left, i), self.spread(e.right, i)
            return _ARITHMETIC[e.op](x, y, lambda what: self.fault(e, what))
        if isinstance(e, ast.Compare):
            return self.chain(e, lambda o: self.spread(o, i))
        if isinstance(e, ast.BoolOp):
            return self.either(e, lambda v: self.spread(v, i))
        if isinstance(e, ast.IfExp):  # member i's condition chooses member i (format 1.3)
            return self.spread(e.body, i) if self.spread(e.test, i) else self.spread(e.orelse, i)
        if isinstance(e, ast.Call) and e.func in self.functions:
            return self.inside(self.call_of(e), lambda b: self.member(b, i))
        rows = self.rows(e)
        if rows is not None:
            assert isinstance(e, ast.Index)
            return self.row_member(e, rows, i)
        if isinstance(e, ast.Call):  # a built-in given a group: this member's call, with a memory of its own
            return self.built_in(e, lambda a: self.spread(a, i), (id(e), i))
        if isinstance(e, ast.Slice):
            return self.member(e.value, self.bounds(e)[0] + i)
        raise Unsupported(f"no members in {e!r}")

    # -- the nodes ---------------------------------------------------------------------------------
    def visit_Number(self, e: ast.Number) -> Any:
        return float(e.value)

    def visit_Bool(self, e: ast.Bool) -> Any:
        return e.value

    def visit_Text(self, e: ast.Text) -> Any:
        return e.value

    def visit_Name(self, e: ast.Name) -> Any:
        if e.id in self.env:
            return self.inside(self.env[e.id], self.visit)
        value = self.names[e.id] if e.id in self.names else CONSTANTS[e.id]
        return Members(_number(v) for v in value) if isinstance(value, Members) else _number(value)

    def visit_Group(self, e: ast.Group) -> Any:
        return self.members(e)

    def visit_Slice(self, e: ast.Slice) -> Any:
        return self.members(e)

    def group_or(self, e: ast.Expr, one: Callable[[], Any]) -> Any:
        return self.members(e) if self.size(e) else one()

    def visit_Neg(self, e: ast.Neg) -> Any:
        return self.group_or(e, lambda: -self.visit(e.operand))

    def visit_Not(self, e: ast.Not) -> Any:
        return self.group_or(e, lambda: not self.visit(e.operand))

    def visit_Binary(self, e: ast.Binary) -> Any:
        def one() -> Any:
            x, y = self.visit(e.left), self.visit(e.right)
            return _ARITHMETIC[e.op](x, y, lambda what: self.fault(e, what))
        return self.group_or(e, one)

    def visit_Compare(self, e: ast.Compare) -> Any:
        return self.group_or(e, lambda: self.chain(e, self.visit))

    def chain(self, e: ast.Compare, value: Callable[[ast.Expr], Any]) -> bool:
        """A chain stops at the first pair that does not hold."""
        left = value(e.operands[0])
        for op, operand in zip(e.ops, e.operands[1:]):
            right = value(operand)
            if not _COMPARE[op](left, right):
                return False
            left = right
        return True

    def visit_BoolOp(self, e: ast.BoolOp) -> Any:
        return self.group_or(e, lambda: self.either(e, self.visit))

    def either(self, e: ast.BoolOp, value: Callable[[ast.Expr], Any]) -> bool:
        """'and'/'or' stop at the first part that decides them."""
        decides = e.op == "or"  # a true part decides an 'or', a false one an 'and'
        for part in e.values:
            if bool(value(part)) == decides:
                return decides
        return not decides

    def visit_IfExp(self, e: ast.IfExp) -> Any:
        return self.group_or(e, lambda: self.visit(e.body) if self.visit(e.test) else self.visit(e.orelse))

    def visit_Attribute(self, e: ast.Attribute) -> Any:
        return _number(self.visit(e.value)[_FIELD[e.attr]])

    def visit_Peer(self, e: ast.Peer) -> Any:
        """Another robot's value: ``names[robot]`` holds each of its group's robots' values as they
        were on the last tick, a mapping a robot; a place outside the group is as a group's."""
        robots = self.names[e.robot]
        assert isinstance(robots, tuple)
        n = len(robots)
        k: Any
        try:
            k = fold(e.member, {k: v for k, v in self.constants.items() if k not in self.env})
        except NotConstant:
            k = self.visit(e.member)
        if 0 <= k < n and k == int(k):
            return _number(robots[int(k)][e.attr])
        self.fault(e, f"no member at the place asked of a group of {n} (places count from 0)")  # as the run counts it
        return False if isinstance(robots[0][e.attr], bool) else NAN

    def visit_Index(self, e: ast.Index) -> Any:
        """A place that folds picks its member alone; any other is read after the members, and a
        place outside the group is nan (false among booleans) and a fault."""
        if self.rows(e) is not None:
            return self.members(e)
        n = self.size(e.value)
        try:
            k = fold(e.index, {k: v for k, v in self.constants.items() if k not in self.env})
        except NotConstant:
            k = None
        if isinstance(k, int | float) and not isinstance(k, bool) and float(k).is_integer() and 0 <= k < n:
            return self.member(e.value, int(k))
        values = self.members(e.value)
        k = self.visit(e.index)
        if 0 <= k < n and k == int(k):
            return values[int(k)]
        self.fault(e, f"no member at the place asked of a group of {n} (places count from 0)")  # as the run counts it
        return False if values and isinstance(values[0], bool) else NAN

    def visit_Call(self, e: ast.Call) -> Any:
        if e.func in self.functions:
            return self.inside(self.call_of(e), self.visit)
        if e.func in REDUCTIONS and len(e.args) == 1 and self.size(e.args[0]):
            return self.reduce(e.func, e.args[0])
        if e.func == "len" and e.func not in FUNCTIONS:  # a list's rows, a group's members (format 1.3)
            arg = e.args[0]
            value = self.names.get(arg.id) if isinstance(arg, ast.Name) and arg.id not in self.env else None
            return float(len(value)) if isinstance(value, Rows) else float(self.size(arg))
        if e.func == "heard" and e.args and isinstance(e.args[0], ast.Name) and f"heard({e.args[0].id})" in self.names:
            heard = self.names[f"heard({e.args[0].id})"]  # what the robot heard (format 1.3): nan until anything
            if heard == heard:
                return heard
            return self.visit(e.args[1]) if len(e.args) == 2 else 0.0
        if e.func == DETECTED:  # takes the sensor's name: it sees something when its reading is finite
            assert isinstance(e.args[0], ast.Name)
            return self.visit(e.args[0]) < INF
        if self.size(e):
            return self.members(e)
        return self.built_in(e, self.visit, id(e))

    def built_in(self, e: ast.Call, value: Callable[[ast.Expr], Any], site: object) -> Any:
        """A built-in's call, its arguments' values given by ``value``; one with memory keeps it at ``site``."""
        f = FUNCTIONS.get(e.func)
        if f is None:
            raise Unsupported(f"{e.func}() is a function of the file's own, and its definition was not given")
        if f.stateful:
            return self.remembered(e, value, site)
        args = [value(a) for a in e.args]
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
            self.fault(e, f"{e.func}(): overflow")
            return INF
        except (ValueError, ZeroDivisionError) as exc:  # sqrt(-1), log(-1), randint(3, 2): nan
            self.fault(e, f"{e.func}(): {exc}" if str(exc) else f"{e.func}() failed")
            return NAN

    def reduce(self, func: str, group: ast.Expr) -> Any:
        """A reduction of a group (docs/language.md, "Groups"): every member is computed first, so each
        member's memory and random draw runs on every tick, whatever the members before it decided."""
        n = self.size(group)
        values = self.members(group)
        if func in ("any", "all"):
            decides = func == "any"
            return decides if any(bool(v) == decides for v in values) else not decides
        if func == "count":
            return float(sum(1 for v in values if v))
        if func in ("min", "max"):
            if any(v != v for v in values):
                return NAN
            best = values[0]
            for v in values[1:]:  # the first of equals: -0.0 before 0.0 when it comes first
                if (v < best) if func == "min" else (v > best):
                    best = v
            return best
        if func in ("sum", "mean"):
            total = values[0]
            for v in values[1:]:  # left to right from the first member, as written out
                total = total + v
            return total if func == "sum" else total / float(n)
        return argmin(*values) if func == "argmin" else argmax(*values)

    def remembered(self, e: ast.Call, value: Callable[[ast.Expr], Any], site: object) -> Any:
        """A built-in with memory: this call site's state in the robot's ``Memory``."""
        memory = self.memory
        if memory is None:
            raise Unsupported(f"{e.func}() remembers earlier ticks; the evaluator sees one")
        args = [value(a) for a in e.args]
        step = memory.sites.get(site)
        if step is None:
            def report(what: str) -> None:
                memory.report[-1](what)
            if e.func == "pid":
                step = make_pid(report)
            else:
                factory: Callable[..., Callable[..., object]] = FUNCTIONS[e.func].resolve()  # type: ignore[assignment]
                primed = e.func in PRIMED and memory.version >= 1.2
                step = factory(memory.dt_s, report, primed=True) if primed else factory(memory.dt_s, report)
            memory.sites[site] = step
        memory.report.append(lambda what: self.fault(e, what))
        try:
            return _number(step(*args))
        finally:
            memory.report.pop()

    def image_call(self, e: ast.Call, impl: Callable[..., object], args: list) -> Any:
        """An image function: ``crop`` outside the image gives the empty image, ``centroid`` of
        one with no set pixel the image centre with ``.found`` false; each warns."""
        from labsim.dsl.library.images import EMPTY, EmptyCentroid  # numpy, only for behaviours with images

        try:
            result = impl(*args)
        except EmptyCentroid as empty:
            self.fault(e, "centroid of an image with no set pixel (the result is the image centre, .found false)")
            return empty.result
        except OverflowError:
            self.fault(e, f"{e.func}(): overflow")
            return INF if FUNCTIONS[e.func].returns is Type.NUMBER else EMPTY
        except (ValueError, ZeroDivisionError) as exc:
            self.fault(e, f"{e.func}(): {exc}" if str(exc) else f"{e.func}() failed")
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
