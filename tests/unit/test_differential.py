"""Constant folding, the generated code and the reference evaluator agree on every expression.

Three ways to compute an expression: ``labsim.dsl.analysis.fold`` (at compile time, on the constants),
the Python ``labsim.dsl.emit.codegen`` writes (at run time), and the tree-walking evaluator
``labsim.dsl.analysis.evaluate``, which follows docs/language.md without the generator's shortcuts.
Each generated expression over numbers and booleans (operators, comparisons and their chains,
``and``/``or``/``not``, conditionals, the built-in functions of numbers, random ones included,
``detected``; groups of three, as signals and lists, operators member by member, reductions,
members picked at places that fold or are read while running, slices, built-ins and 'a if c else
b' given groups member by member (format 1.3), and functions of the file's own over groups) becomes a signal of
a behaviour file, its names ``p0`` .. ``p7`` either signals read from sensors, so that they do
not fold, or (every other expression) written out as
constants, so that what can fold does. The file runs one tick; each signal's value must equal
the evaluator's (nan equal to nan, zeros of the same sign, booleans apart from numbers), and
so must its warnings, site by site; where folding gives a value, so must it, and the evaluator
must have met no fault. The names' values come from the edges of a float: 0, -0.0, the
infinities, nan, the largest and the smallest numbers.

Speed: a hypothesis example draws the names' values and a seed, and a batch of expressions
comes from the seed (hypothesis draws would cost a hundred times more); a failure names the
first expression that disagrees, with the values. Derandomized, as tests/hostile/test_fuzz.py.
"""
from __future__ import annotations

import math
import random
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from labsim.dsl.analysis.evaluate import Members, Rows, evaluate
from labsim.dsl.analysis.fold import NotConstant, fold
from labsim.dsl.compile import compile_file
from labsim.dsl.emit.program import Program
from labsim.dsl.library.builtins import CONSTANTS, DETECTED, FUNCTIONS, Type
from labsim.dsl.library.support import Faults
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.parse import parse_expr

INF, NAN = math.inf, math.nan
EXAMPLES = 50
BATCH = 200  # expressions per example, EXAMPLES * BATCH in all, each compiled once: the cost of the test
NAMES = tuple(f"p{i}" for i in range(8))  # the names whose values an example draws
SENSORS = tuple(f"sonar{i}" for i in range(9, 13))  # read directly, and by detected()
VALUES = (0.0, -0.0, 1.0, -1.0, 0.5, -2.5, 3.0, 7.0, 0.1, 1e308, -1e308, 1e300, 5e-324, -5e-324, 1e-300,
          INF, -INF, NAN)
# numbers, and the names of constants and variables
LITERALS = ("0", "1", "2", "3", "0.5", "10", "1e308", "5e-324", "1e-300", "inf", "pi", "dt", "time", "tick")
TIME_S, TICK, DT_S = 12.5, 250, 0.05
# the functions of numbers: name -> how many arguments
FUNCTIONS_OF_NUMBERS = {f.name: len(f.params) for f in FUNCTIONS.values()
                        if f.returns is Type.NUMBER and all(p is Type.NUMBER for p in f.params) and not f.stateful}
COMPARISONS = ("<", "<=", ">", ">=", "==", "!=")
PURE_FUNCTIONS = ("abs", "sqrt", "floor", "sign", "exp", "log")
GROUP = 3  # members of every generated group, so that any two pair
GROUPS = ("ga", "gb")  # signals that are groups: a list of signals, a range of sensors
# list parameters (format 1.3): rows of GROUP numbers, and GROUP numbers (a group)
ROWS = ((1.0, -2.5, 0.5), (3.0, 7.0, -1.0), (0.1, 2.0, 4.0))
LISTED = (0.5, -1.0, 2.0)
READ_BACK = ("wheel_left", "wheel_right", "start_x", "start_heading")  # 0 on a first tick, and without a start
ROBOT = "r"  # the behaviour's robot, which reads its own values by name (format 1.3: r.x, r.p0)
# functions of the file's own, over groups and numbers: their parameters stand for the arguments
OWN_FUNCTIONS = {"scaled": (("g", "k"), "g * k - k"), "nearest": (("g", "d"), "min(g - d)"),
                 "within": (("g", "d"), "count(g < d) + g[1] / d"), "limited": (("g", "k"), "clamp(g, -k, k)"),
                 "head": (("g",), "sum(g[:2]) - g[1:][0]")}
# the built-ins a group may be given, member by member (format 1.3): all of numbers but random(), which takes none
MEMBER_WISE = tuple(sorted(name for name, n in FUNCTIONS_OF_NUMBERS.items() if n))
# no shrinking: a batch comes from a seed, and the failure names the expression and its values
SHORT = settings(max_examples=EXAMPLES, derandomize=True, database=None, deadline=None,
                 phases=(Phase.explicit, Phase.generate),
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


class Expressions:
    """Well-typed expression trees drawn from ``rng``: numbers and conditions, nested a few levels."""

    def __init__(self, rng: random.Random) -> None:
        self.rng = rng

    def number(self, depth: int, pure: bool = False) -> ast.Expr:
        r, pick = self.rng.random(), self.rng.choice
        if pure:  # where a group's operator pairs it with every member: nothing random
            if depth <= 0 or r < 0.4:
                literal = pick(LITERALS)
                return ast.Number(float(literal)) if literal[0].isdigit() else ast.Name(literal)
            if r < 0.8:
                op = pick(("+", "-", "*", "/", "%", "**"))
                return ast.Binary(op, self.number(depth - 1, True), self.number(depth - 1, True))
            return ast.Call(pick(PURE_FUNCTIONS), (self.number(depth - 1, True),))
        if r < 0.4 and depth > 0 and self.rng.random() < 0.35:
            return self.of_group(depth)
        if depth == 0 or r < 0.3:
            if self.rng.random() < 0.35:
                literal = pick(LITERALS)
                return ast.Number(float(literal)) if literal[0].isdigit() else ast.Name(literal)
            if self.rng.random() < 0.1:  # format 1.3: read-back, a list's length, a number of a row
                return pick((ast.Name(pick(READ_BACK)), ast.Call("len", (ast.Name(pick(("wp", "gl"))),)),
                             ast.Index(ast.Index(ast.Name("wp"), self.place()), self.place())))
            if self.rng.random() < 0.1:  # the robot's own values of the last tick, read by its name (1.3)
                return ast.Peer(ROBOT, ast.Number(0.0), pick(("x", "y", "heading", *NAMES)))
            return ast.Name(pick(NAMES + NAMES + SENSORS))
        if r < 0.55:
            op = pick(("+", "-", "*", "/", "/", "%", "%", "**", "**"))
            return ast.Binary(op, self.number(depth - 1), self.number(depth - 1))
        if r < 0.62:
            return ast.Neg(self.number(depth - 1))
        if r < 0.9:
            return self.call(depth)
        return ast.IfExp(self.number(depth - 1), self.condition(depth - 1), self.number(depth - 1))

    def group(self, depth: int, pure: bool = False) -> ast.Expr:
        """A group of GROUP numbers: a signal, a list, or an operator applied member by member; ``pure``:
        nothing random (an argument of a function of the file's own)."""
        r, pick = self.rng.random(), self.rng.choice
        if depth <= 0 or r < 0.3:
            if self.rng.random() < 0.15:  # a list parameter's row, or the list of numbers itself
                return ast.Index(ast.Name("wp"), self.place()) if self.rng.random() < 0.7 else ast.Name("gl")
            if self.rng.random() < 0.5:
                return ast.Name(pick(GROUPS))
            return self.listed(GROUP)
        if r < 0.38:
            return ast.Neg(self.group(depth - 1, pure))
        if r < 0.68:
            op = pick(("+", "-", "*", "/", "%", "**"))
            sides = [self.group(depth - 1, pure), self.group(depth - 1, pure) if self.rng.random() < 0.4 else
                     self.number(depth - 1, True)]
            self.rng.shuffle(sides)
            return ast.Binary(op, *sides)
        if r < 0.78:
            return self.member_wise(depth, pure)
        if r < 0.83:  # a choice member by member: by a group of conditions, or by one
            # one condition is paired with every member: pure, as any value paired
            test = (self.bools(depth - 1, pure) if self.rng.random() < 0.7 else
                    ast.Compare((self.number(depth - 1, True), self.number(depth - 1, True)), ("<",)))
            sides = [self.group(depth - 1, pure), self.group(depth - 1, pure) if self.rng.random() < 0.5 else
                     self.number(depth - 1, True)]
            self.rng.shuffle(sides)
            return ast.IfExp(sides[0], test, sides[1])
        if r < 0.92:  # a slice of GROUP members: of a longer list, or the whole of a group
            if self.rng.random() < 0.5:
                k = self.rng.randrange(3)
                return ast.Slice(self.listed(GROUP + 2), ast.Number(float(k)), ast.Number(float(k + GROUP)))
            return ast.Slice(self.group(depth - 1, pure), pick((None, ast.Number(0.0))), pick((None, ast.Number(3.0))))
        return ast.Call(pick(("scaled", "limited")), (self.group(depth - 1, True), self.number(depth - 1, True)))

    def listed(self, n: int) -> ast.Group:
        return ast.Group(tuple(self.number(0, True) if self.rng.random() < 0.3 else ast.Name(self.rng.choice(NAMES))
                               for _ in range(n)))

    def member_wise(self, depth: int, pure: bool) -> ast.Call:
        """A built-in given a group: one argument a group at least, the others groups or values
        (paired with every member, so nothing random)."""
        name = self.rng.choice([f for f in MEMBER_WISE if not (pure and FUNCTIONS[f].uses_rng)])
        n = FUNCTIONS_OF_NUMBERS[name] + (self.rng.randrange(2) if FUNCTIONS[name].variadic else 0)
        grouped = self.rng.randrange(n)
        args = [self.group(depth - 1, pure) if k == grouped or self.rng.random() < 0.3 else self.number(depth - 1, True)
                for k in range(n)]
        if name == "randint":  # a bound written as a number must be within 2**53: the checker says so
            args = [a if not isinstance(a, ast.Number) or a.value <= 10 else ast.Binary("*", a, ast.Number(1.0))
                    for a in args]
        return ast.Call(name, tuple(args))

    def bools(self, depth: int, pure: bool = False) -> ast.Expr:
        """A group of GROUP booleans: a comparison member by member, and and/or/not of them."""
        r = self.rng.random()
        if depth <= 1 or r < 0.6:
            sides = [self.group(depth - 1, pure), self.number(depth - 1, True) if self.rng.random() < 0.6 else
                     self.group(depth - 1, pure)]
            self.rng.shuffle(sides)
            return ast.Compare(tuple(sides), (self.rng.choice(COMPARISONS),))
        if r < 0.75:
            return ast.Not(self.bools(depth - 1, pure))
        return ast.BoolOp(self.rng.choice(("and", "or")), (self.bools(depth - 1, pure), self.bools(depth - 1, pure)))

    def of_group(self, depth: int) -> ast.Expr:
        """A number from a group: a reduction, a member, a function of the file's own."""
        r, pick = self.rng.random(), self.rng.choice
        if r < 0.35:
            return ast.Call(pick(("min", "max", "sum", "mean", "argmin", "argmax")), (self.group(depth - 1),))
        if r < 0.45:  # a reduction of part of a group
            lower = self.rng.randrange(GROUP)
            upper = self.rng.randrange(lower + 1, GROUP + 1)
            bounds = (None if lower == 0 and self.rng.random() < 0.5 else ast.Number(float(lower)),
                      None if upper == GROUP and self.rng.random() < 0.5 else ast.Number(float(upper)))
            return ast.Call(pick(("min", "max", "sum", "mean", "argmin", "argmax")),
                            (ast.Slice(self.group(depth - 1), *bounds),))
        if r < 0.6:
            return ast.Call("count", (self.bools(depth - 1),))
        if r < 0.8:
            return ast.Index(self.group(depth - 1), self.place())
        if r < 0.87:
            return ast.Call("nearest", (self.group(depth - 1, True), self.number(depth - 1, True)))
        if r < 0.94:
            return ast.Call("within", (self.group(depth - 1, True), self.number(depth - 1, True)))
        return ast.Call("head", (self.group(depth - 1, True),))

    def place(self) -> ast.Expr:
        """A place in a group (or a list of GROUP rows): one that folds is one of the group's (the checker
        refuses others); one read while running may be anywhere, a fraction, inf or nan."""
        pick = self.rng.choice
        sensor = ast.Name(pick(SENSORS))
        return pick((ast.Number(float(self.rng.randrange(GROUP))), sensor, ast.Binary("*", sensor, ast.Number(3.0)),
                     ast.Binary("%", ast.Name("tick"), ast.Number(4.0)), ast.Binary("-", ast.Name("time"),
                                                                                      ast.Number(11.5)),
                     ast.Binary("-", ast.Call("len", (ast.Name("wp"),)), ast.Number(1.0))))

    def call(self, depth: int) -> ast.Call:
        name = self.rng.choice(sorted(FUNCTIONS_OF_NUMBERS))
        n = FUNCTIONS_OF_NUMBERS[name] + (self.rng.randrange(3) if FUNCTIONS[name].variadic else 0)
        args = [self.number(depth - 1) for _ in range(n)]
        if name == "randint":  # a bound written as a number must be within 2**53: the checker says so
            args = [a if isinstance(a, ast.Number) and a.value <= 10 else ast.Binary("*", a, ast.Number(1.0))
                    for a in args]
        return ast.Call(name, tuple(args))

    def condition(self, depth: int) -> ast.Expr:
        r, pick = self.rng.random(), self.rng.choice
        if depth == 0 or r < 0.15:
            if self.rng.random() < 0.4:
                return ast.Bool(self.rng.random() < 0.5)
            return ast.Call(DETECTED, (ast.Name(pick(SENSORS)),))
        if r < 0.22 and self.rng.random() < 0.5:
            return ast.Call(pick(("any", "all")), (self.bools(depth - 1),))
        if r < 0.5:
            links = 1 if self.rng.random() < 0.7 else 2  # a chain: a < b <= c
            return ast.Compare(tuple(self.number(depth - 1) for _ in range(links + 1)),
                               tuple(pick(COMPARISONS) for _ in range(links)))
        if r < 0.6:
            return ast.Not(self.condition(depth - 1))
        if r < 0.9:
            parts = tuple(self.condition(depth - 1) for _ in range(self.rng.randrange(2, 4)))
            return ast.BoolOp(pick(("and", "or")), parts)
        return ast.IfExp(self.condition(depth - 1), self.condition(depth - 1), self.condition(depth - 1))

    def any(self) -> ast.Expr:
        depth = self.rng.choice((1, 1, 2, 2, 2, 3, 3, 4))  # mostly small: each costs its parse
        return self.number(depth) if self.rng.random() < 0.7 else self.condition(depth)


def written(e: ast.Expr, constants: Mapping[str, float] | None = None) -> tuple[str, ast.Expr]:
    """The text of ``e``, in parentheses only where the grammar's precedence needs them, and ``e``
    with the spans of that text, as the parser gives them; the names of ``constants`` are written
    as their values."""
    out: list[str] = []

    def write(e: ast.Expr, level: int = 0) -> ast.Expr:
        """``e`` where the grammar wants an expression of ``level`` or higher (_LEVEL)."""
        inner = _level(e) < level
        out.append("(" if inner else "")
        start = sum(map(len, out))
        e = form(e)
        span = (start, sum(map(len, out)))
        out.append(")" if inner else "")
        return replace(e, span=span)

    def form(e: ast.Expr) -> ast.Expr:
        if isinstance(e, ast.Number):
            out.append(repr(e.value))
        elif isinstance(e, ast.Bool):
            out.append("true" if e.value else "false")
        elif isinstance(e, ast.Name):
            out.append(constant_text(constants[e.id]) if constants and e.id in constants else e.id)
        elif isinstance(e, ast.Peer):  # r.x: the member's span is the robot's name
            start = sum(map(len, out))
            out.append(f"{e.robot}.{e.attr}")
            return replace(e, member=replace(e.member, span=(start, start + len(e.robot))))
        elif isinstance(e, ast.Group):
            out.append("[")
            members = []
            for k, m in enumerate(e.members):
                out.append(", " if k else "")
                members.append(write(m))
            out.append("]")
            return replace(e, members=tuple(members))
        elif isinstance(e, ast.Index):
            value = write(e.value, 9)
            out.append("[")
            index = write(e.index)
            out.append("]")
            return replace(e, value=value, index=index)
        elif isinstance(e, ast.Slice):
            value = write(e.value, 9)
            out.append("[")
            lower = None if e.lower is None else write(e.lower)
            out.append(":")
            upper = None if e.upper is None else write(e.upper)
            out.append("]")
            return replace(e, value=value, lower=lower, upper=upper)
        elif isinstance(e, ast.Call):
            out.append(e.func + "(")
            args = []
            for k, a in enumerate(e.args):
                out.append(", " if k else "")
                args.append(write(a))
            out.append(")")
            return replace(e, args=tuple(args))
        elif isinstance(e, ast.Neg):
            out.append("-")
            return replace(e, operand=write(e.operand, 7))
        elif isinstance(e, ast.Not):
            out.append("not ")
            return replace(e, operand=write(e.operand, 3))
        elif isinstance(e, ast.Binary):  # left-associative but for **, which takes an atom on its left
            level = _level(e)
            left = write(e.left, 9 if e.op == "**" else level)
            out.append(f" {e.op} ")
            return replace(e, left=left, right=write(e.right, 7 if e.op == "**" else level + 1))
        elif isinstance(e, ast.Compare):
            operands = [write(e.operands[0], 5)]
            for op, operand in zip(e.ops, e.operands[1:]):
                out.append(f" {op} ")
                operands.append(write(operand, 5))
            return replace(e, operands=tuple(operands))
        elif isinstance(e, ast.BoolOp):
            values = []
            for k, v in enumerate(e.values):
                out.append(f" {e.op} " if k else "")
                values.append(write(v, _level(e) + 1))
            return replace(e, values=tuple(values))
        else:
            assert isinstance(e, ast.IfExp)
            body = write(e.body, 1)
            out.append(" if ")
            test = write(e.test, 1)
            out.append(" else ")
            return replace(e, body=body, test=test, orelse=write(e.orelse, 0))
        return e

    node = write(e)
    return "".join(out), node


# The grammar's precedence, lowest first: a if c else b, or, and, not, comparisons, + -, * / %,
# unary -, **, and atoms (numbers, names, calls, parentheses).
_LEVEL = {ast.IfExp: 0, ast.Not: 3, ast.Compare: 4, ast.Neg: 7}
_BINARY_LEVEL = {"or": 1, "and": 2, "+": 5, "-": 5, "*": 6, "/": 6, "%": 6, "**": 8}


def _level(e: ast.Expr) -> int:
    if isinstance(e, (ast.Binary, ast.BoolOp)):
        return _BINARY_LEVEL[e.op]
    return _LEVEL.get(type(e), 9)


def spans(e: ast.Expr) -> list[ast.Span]:
    """The spans of ``e`` and of every node under it, in a fixed order."""
    out = [e.span]
    for value in vars(e).values():
        for item in value if isinstance(value, tuple) else (value,):
            if isinstance(item, ast.Expr):
                out += spans(item)
    return out


def constant_text(value: float) -> str:
    """A number written as an expression that folds to it exactly: nan is inf - inf."""
    if value != value:
        return "(inf - inf)"
    if value in (INF, -INF):
        return "inf" if value > 0 else "(-inf)"
    return repr(value) if math.copysign(1.0, value) > 0 else f"(-{-value!r})"


def same(a: object, b: object) -> bool:
    """Equal as the language's values: nan equals nan, 0.0 is not -0.0, a boolean is no number."""
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    if type(a) is not type(b):
        return False
    assert isinstance(a, float) and isinstance(b, float)
    if a != a or b != b:
        return a != a and b != b
    return a == b and math.copysign(1.0, a) == math.copysign(1.0, b)


def behaviour(path: Path, lets: list[tuple[str, str]]) -> Program:
    functions = "".join(f"  {name}({', '.join(params)}): '{body}'\n" for name, (params, body) in OWN_FUNCTIONS.items())
    text = ("labsim: 1.3\nworld: walls_lab4\ndt: 0.05\nstop: time >= 1\nrobots:\n  r: {model: pioneer_p3dx}\n"
            f"params:\n  wp: {[list(row) for row in ROWS]}\n  gl: {list(LISTED)}\n"
            "functions:\n" + functions + "let:\n" + "".join(f"  {name}: '{expr}'\n" for name, expr in lets)
            + "rules:\n  - always stop()\n")
    path.write_text(text)
    return compile_file(path)


def run_tick(p: Program, sensors: dict[str, float]) -> tuple[dict[str, object], dict[str, set[tuple[str, str]]]]:
    """Each signal's value after one tick, and each signal's warnings as (faulting text, words)."""
    faults = Faults()
    robot = p.robot("r", random.Random(1), faults, p.models["r"])
    robot.signals(TIME_S, TICK, [sensors[ch] for ch in p.channels])
    values = {name: robot.slots[p.slot_of[name]] for name in p.let_names if name in p.single_signals}
    warnings: dict[str, set[tuple[str, str]]] = {name: set() for name in p.let_names}
    for site, what in faults.counts:
        d = site.diagnostic
        signal = site.where.removeprefix("signal ").split("'")[1]
        if ", in " in site.where:  # in a function's body: the body's text
            warnings[signal].add((site.where.split(", in ")[1], d.source_line[d.col - 1:d.end_col - 1], what))
        else:
            warnings[signal].add(("", d.source_line[d.col - 1:d.end_col - 1], what))
    return values, warnings


def check_batch(folder: Path, values: tuple[float, ...], sensors: tuple[float, ...], seed: int) -> tuple[int, int]:
    """One batch of expressions in one behaviour file, every other one with its names written as
    constants: each one's value and warnings after a tick against the evaluator's, and its
    folding where it folds. Returns (expressions checked, expressions folded)."""
    gen = Expressions(random.Random(seed))
    p_values = dict(zip(NAMES, values))
    names: dict[str, object] = {**p_values, **dict(zip(SENSORS, sensors)), "time": TIME_S, "tick": TICK, "dt": DT_S,
                                "ga": Members(values[:3]), "gb": Members(values[3:6]),
                                "wp": Rows(Members(row) for row in ROWS), "gl": Members(LISTED),
                                **dict.fromkeys(READ_BACK, 0.0)}
    functions = {name: (params, parse_expr(body)) for name, (params, body) in OWN_FUNCTIONS.items()}
    exprs = [written(gen.any(), p_values if k % 2 else None) for k in range(BATCH)]
    for text, node in exprs[:6:2]:  # the texts say what the trees are, with the parser's spans
        parsed = parse_expr(text, frozenset({ROBOT}))
        assert parsed == node and spans(parsed) == spans(node), text
    lets = [(n, f"sonar{i + 1}") for i, n in enumerate(NAMES)] + [("ga", "[p0, p1, p2]"), ("gb", "sonar4..sonar6")]
    lets += [(f"e{k}", text) for k, (text, _) in enumerate(exprs)]
    program = behaviour(folder / "b.yaml", lets)
    pose = {"x": 1.25, "y": -0.5, "heading": 0.75}  # sensed by a robot whose name an expression reads
    got, warned = run_tick(program, {f"sonar{i + 1}": v for i, v in enumerate(values)} | dict(zip(SENSORS, sensors))
                           | pose)
    names[ROBOT] = (dict(zip(program.peer_fields, program.peer_start()[0])),)  # its values before a tick: the start
    rng = random.Random(1)  # as the robot's, drawn in the same order
    listed = {**CONSTANTS, "dt": DT_S, "wp": ROWS, "gl": LISTED}  # the lists, which the code generator folds
    constants = {**listed, **p_values}
    folded = 0
    for k, (text, node) in enumerate(exprs):
        value, faults = evaluate(node, names, rng, functions=functions, constants=listed)
        where = f"e{k}: {text}\nwith {p_values}, sensors {dict(zip(SENSORS, sensors))}\n"
        assert same(got[f"e{k}"], value), f"{where}generated {got[f'e{k}']!r}, evaluator {value!r}"
        at = {(", in ".join(f"{n}()" for n in f.within),
               (OWN_FUNCTIONS[f.within[-1]][1] if f.within else text)[f.span[0]:f.span[1]], f.what) for f in faults}
        assert warned[f"e{k}"] == at, f"{where}generated warns {warned[f'e{k}']}, evaluator {at}"
        try:
            constant = fold(node, constants)
        except NotConstant:
            continue
        folded += 1
        assert same(constant, value) and not faults, f"{where}folding gives {constant!r}, evaluator {value!r}, {faults}"
    return len(exprs), folded


@pytest.mark.slow
@pytest.mark.long
def test_folding_generated_code_and_evaluator_agree(tmp_path: Path) -> None:
    counts: list[tuple[int, int]] = []

    @SHORT
    @given(values=st.tuples(*[st.sampled_from(VALUES)] * len(NAMES)),
           sensors=st.tuples(*[st.sampled_from((0.3, 1.0, INF, 0.0))] * len(SENSORS)),
           seed=st.integers(0, 2**32 - 1))
    def agree(values: tuple[float, ...], sensors: tuple[float, ...], seed: int) -> None:
        counts.append(check_batch(tmp_path, values, sensors, seed))

    agree()
    checked, folded = map(sum, zip(*counts))
    assert checked >= 10_000
    assert folded >= checked // 10  # folding is checked too, not only the generated code


def test_the_evaluator_follows_the_documented_faults() -> None:
    """docs/language.md's "Runtime faults", one by one, and nan's propagation."""
    cases = {
        "1 / 0": (INF, ["division by zero"]), "-1 / 0": (-INF, ["division by zero"]),
        "0 / 0": (NAN, ["division by zero"]), "(inf - inf) / 0": (NAN, ["division by zero"]),
        "5 % 0": (NAN, ["modulo by zero"]), "0 ** -1": (INF, ["zero to a negative power"]),
        "10 ** 400": (INF, ["overflow in '**'"]), "(-10) ** 401": (-INF, ["overflow in '**'"]),
        "(-8) ** 0.5": (NAN, ["a negative number to a fractional power"]),
        "sqrt(-1)": (NAN, ["sqrt(): math domain error"]), "log(-1)": (NAN, ["log(): math domain error"]),
        "log(0)": (-INF, []), "exp(1000)": (INF, ["exp(): overflow"]),
        "min(1, inf - inf, 0)": (NAN, []), "max(inf - inf, 1)": (NAN, []),
        "1e308 * 10": (INF, []), "inf * 0": (NAN, []), "-0 * 1": (-0.0, []),
        "sign(-0)": (0.0, []), "-sign(0)": (-0.0, []), "floor(-inf)": (-INF, []),
        "floor(inf - inf)": (NAN, ["floor(): cannot convert float NaN to integer"]),
    }
    for text, (want, warnings) in cases.items():
        value, faults = evaluate(parse_expr(text), {})
        assert same(value, want), (text, value)
        assert [f.what for f in faults] == warnings, (text, faults)
    value, faults = evaluate(parse_expr("1 > 2 > 1 / 0 or true and (false or 0 < 1)"), {})
    assert value is True and faults == ()  # a chain and 'and'/'or' stop where they are decided


# -- every member runs on every tick under a reduction (memory and random draws) -----------------
TICKS = 9
REDUCTIONS_OF_BOOLS = ("any", "all", "count")


def _bools(rng: random.Random) -> str:
    """A group of three conditions on the tick, each its own pattern of ticks."""
    return "[" + ", ".join(rng.choice((f"tick % {rng.randrange(2, 5)} == {rng.randrange(2)}",
                                       f"tick >= {rng.randrange(5)}", f"tick < {rng.randrange(1, 6)}"))
                           for _ in range(GROUP)) + "]"


def _remembering(rng: random.Random) -> str:
    """A group of booleans made member by member by built-ins with memory or random draws, and/or'ed."""
    b, n = _bools(rng), "[tick % 3, tick * 0.5, 2 - tick]"
    part = rng.choice((f"rising({b})", f"falling({b})", f"held({b}) > 0.1", f"total({n}) > {rng.randrange(6)}",
                       f"rate({n}) > 0", f"prev({n}, 1) > 0.5", f"counter({b}, {b}) > 1", f"uniform({n}, 3) > 1.5",
                       f"gauss({n}, 1) > 0.5", f"hold({b}, {b})"))
    if rng.random() < 0.4:  # member by member: and/or stop where decided, as for single values
        op = rng.choice(("and", "or"))
        part = f"{b} {op} {part}" if rng.random() < 0.5 else f"{part} {op} {b}"
    return part


def test_every_member_of_a_reduction_runs_on_every_tick(tmp_path: Path) -> None:
    """any(rising(c)) and its kind over ticks: a member's memory or random draw after the member that
    decides still runs. The generated code agrees tick by tick with the evaluator (its memory kept
    between ticks, the same random generator), and, without random draws (the signal draws its own),
    with the reduction of a signal holding the same members (which computes every member before any
    reduction sees them)."""
    from labsim.dsl.analysis.evaluate import Memory

    rng = random.Random(42)
    lets: list[tuple[str, str]] = []
    checked: list[str] = []
    for k in range(60):
        inner = _remembering(rng)
        red = rng.choice(REDUCTIONS_OF_BOOLS)
        lets += [(f"e{k}", f"{red}({inner})"), (f"m{k}", inner), (f"n{k}", f"{red}(m{k})")]
        checked.append(f"e{k}")
        if rng.random() < 0.3:  # a single and/or of two reductions stops where decided, as documented
            op = rng.choice(("and", "or"))
            lets.append((f"o{k}", f"any({_remembering(rng)}) {op} all({_remembering(rng)})"))
            checked.append(f"o{k}")
    program = behaviour(tmp_path / "b.yaml", lets)
    robot = program.robot("r", random.Random(7), Faults(), program.models["r"])
    memory, draws = Memory(dt_s=DT_S, version=1.3), random.Random(7)
    nodes = {name: parse_expr(text) for name, text in lets}
    for tick in range(TICKS):
        time_s = tick * DT_S
        robot.signals(time_s, tick, [0.5] * len(program.channels))
        names: dict[str, object] = {"tick": float(tick), "time": time_s, "dt": DT_S}
        for name, _ in lets:  # in the file's order: the random draws come in the same order
            names[name], faults = evaluate(nodes[name], names, draws, memory=memory)
            assert faults == ()
        for name in checked:
            got = robot.slots[program.slot_of[name]]
            assert same(got, names[name]), f"tick {tick}, {name}: {dict(lets)[name]}: generated {got!r}, " \
                                           f"evaluator {names[name]!r}"
            if name[0] == "e" and "uniform" not in dict(lets)[name] and "gauss" not in dict(lets)[name]:
                signal = robot.slots[program.slot_of["n" + name[1:]]]
                assert same(got, signal), f"tick {tick}, {name}: {dict(lets)[name]}: {got!r}, through a signal " \
                                          f"{signal!r}"
