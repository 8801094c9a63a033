"""Groups and user functions written out: the code generator's straight-line code for version 1.2.

``labsim.dsl.emit.codegen``'s generator takes these methods from ``Unroller``. A group-typed
expression (``sonar1..sonar8``, ``front < 0.5``) becomes one Python expression per member, an
operator applying to each member; a reduction (``min(front)``, ``any(...)``) joins them into
one expression with no loop and no list (``reduce``); ``front[2]`` is the member itself. A
call of a user function becomes its body, written with the arguments' Python in place of its
parameters (a parameter whose argument is a constant is folded into the body). So neither
costs a Python call or an allocation per tick beyond what the same expression written out by
hand would (docs/decisions.md §17).
"""
from __future__ import annotations

import re

from labsim.dsl.analysis.check import Checked
from labsim.dsl.analysis.fold import PLACES, NotConstant, fold
from labsim.dsl.emit.layout import Layout
from labsim.dsl.library.builtins import Type
from labsim.dsl.library.support import FIRST_CHANNEL, TICK
from labsim.dsl.syntax import ast
from labsim.foundation.code_writer import Writer
from labsim.foundation.source import Text


class Unroller:
    """The generator's methods for groups and user functions; the generator provides the rest."""

    c: Checked
    layout: Layout
    constants: dict[str, object]
    env: list[dict[str, str | list[str]]]  # inside a user function's body: its arguments' Python
    let_of: dict
    member_writer: MemberWriter

    def column(self, name: str, j: int | None) -> str:
        raise NotImplementedError

    def expr(self, w: Writer, e: ast.Expr, text: Text, where: str) -> str:
        raise NotImplementedError

    def emit(self, w: Writer, e: ast.Expr, text: Text, where: str) -> str:
        raise NotImplementedError

    def site(self, kind: str, text: Text, span: ast.Span, where: str) -> str:
        raise NotImplementedError

    def nonzero(self, e: ast.Expr) -> bool:
        raise NotImplementedError

    def members(self, w: Writer, e: ast.Expr, text: Text, where: str) -> list[str]:
        """Python for each member of a group-typed expression; an operator applies to each member,
        and a value it pairs with every member is written into each (the checker made it pure)."""
        return self.member_writer.visit(e, w, text, where)

    def sequence(self, w: Writer, e: ast.Expr) -> tuple[str, int] | None:
        """Python for a group that is a run of more than three of the tick's channel values, in
        order, as that sequence (``values``, or a slice of it), and its size; None for any other
        group (up to three members, ``extreme`` writes min and max without a call).

        A lidar's scan ``lidar1..lidar360`` is then reduced in one call on the list the backend
        gave, with no local per member: the writer records ``VALUES``, which the generator
        turns into ``values`` being there (it is signals()'s argument; decide() reads it from
        the slots)."""
        if isinstance(e, ast.Name) and not (self.env and e.id in self.env[-1]) and e.id in self.layout.members:
            if self.layout.members[e.id] is not None:
                return None  # a group with slots of its own
            e = self.let_of[e.id].node
        if isinstance(e, ast.Slice):  # lidar1..lidar360 sliced, scan[135:180]: a slice of that sequence
            return self.sequence_slice(w, e)
        if not isinstance(e, ast.Group) or not all(isinstance(m, ast.Name) for m in e.members):
            return None
        names = [m.id for m in e.members]  # type: ignore[attr-defined]  # all Names, just tested
        if self.env and any(name in self.env[-1] for name in names):
            return None
        slots = [self.layout.slot_of.get(name, -1) for name in names]
        first, end = slots[0], slots[0] + len(slots)
        if (len(slots) <= 3 or first < FIRST_CHANNEL or end > FIRST_CHANNEL + len(self.c.channels)
                or slots != list(range(first, end))):
            return None
        w.read(VALUES)
        if end - first == len(self.c.channels):
            return "values", len(slots)
        return f"values[{first - FIRST_CHANNEL}:{end - FIRST_CHANNEL}]", len(slots)

    def sequence_slice(self, w: Writer, e: ast.Slice) -> tuple[str, int] | None:
        inner = self.sequence(Writer(), e.value)
        if inner is None:
            return None
        code, n = inner
        lower, upper = self.bounds(e, n)
        if upper - lower <= 3:
            return None
        base = 0 if code == "values" else int(code[len("values["):code.index(":")])
        w.read(VALUES)
        return f"values[{base + lower}:{base + upper}]", upper - lower

    def bounds(self, e: ast.Slice, n: int) -> tuple[int, int]:
        """A slice's places in a group of n, from lower up to upper (the checker made them whole numbers
        known before the run, within the group)."""
        def place(bound: ast.Expr) -> int:
            value = fold(bound, self.constants, PLACES, self.c.lengths)
            assert isinstance(value, int | float)  # the checker made it a number
            return int(value)
        return 0 if e.lower is None else place(e.lower), n if e.upper is None else place(e.upper)

    def spread(self, w: Writer, e: ast.Expr, n: int, text: Text, where: str) -> list[str]:
        """An operand of an operator on groups: its members, or its value once per member."""
        if self.c.node_types.get(id(e)) in (Type.NUMBERS, Type.BOOLS):
            return self.members(w, e, text, where)
        return [self.expr(w, e, text, where)] * n

    def index(self, w: Writer, e: ast.Index, text: Text, where: str) -> str:
        """front[2]: the member itself; front[k] for a k known only at run time, through a guard.

        front[2] reads only that member's locals: a member of a scan picked alone must not load
        the other 359 beams."""
        base = e.value
        if isinstance(base, ast.Name) and base.id in self.c.lists and not (self.env and base.id in self.env[-1]):
            try:
                k = fold(e.index, self.constants)
            except NotConstant:  # a list parameter of numbers: its values bound once, not written at every read
                k_code = self.expr(w, e.index, text, where)
                return f"{self.site('[]', text, e.span, where)}({self.column(base.id, None)}, {k_code})"
            assert isinstance(k, (int, float)) and float(k).is_integer()  # the checker refused other numbers
            return number_literal(self.c.lists[base.id][int(k)])  # type: ignore[arg-type]
        scratch = Writer()
        members = self.members(scratch, e.value, text, where)
        try:
            k = fold(e.index, self.constants)
        except NotConstant:
            w.insert(scratch.body())
            kind = "[]?" if self.c.node_types.get(id(e)) is Type.BOOL else "[]"
            k_code = self.expr(w, e.index, text, where)
            return f"{self.site(kind, text, e.span, where)}(({', '.join(members)},), {k_code})"
        assert isinstance(k, (int, float)) and float(k).is_integer()  # the checker refused other numbers
        member = members[int(k)]
        for slot in LOCAL.findall(member):
            w.read(int(slot))
        if SEQUENCE_READ.search(member):  # [min(scan), lidar5][0]: the scan as one sequence
            w.read(VALUES)
        return member

    def built_in(self, e: ast.Call, parts: list[str], text: Text, where: str) -> str:
        raise NotImplementedError

    def member_call(self, w: Writer, e: ast.Call, text: Text, where: str) -> list[str]:
        """A built-in given a group (format 1.3): the call once per member, with that member of each
        group argument and the same value of each other one (the checker made those pure)."""
        n = self.c.sizes[id(e)]
        columns = [self.spread(w, a, n, text, where) for a in e.args]
        return [self.built_in(e, list(parts), text, where) for parts in zip(*columns)]

    def slice(self, w: Writer, e: ast.Slice, text: Text, where: str) -> list[str]:
        """front[0:4]: those members alone; the others' locals are not loaded (as for front[2])."""
        scratch = Writer()
        members = self.members(scratch, e.value, text, where)
        lower, upper = self.bounds(e, len(members))
        picked = members[lower:upper]
        for member in picked:
            for slot in LOCAL.findall(member):
                w.read(int(slot))
            if SEQUENCE_READ.search(member):
                w.read(VALUES)
        return picked

    def inline(self, w: Writer, e: ast.Call, text: Text, where: str) -> str | list[str]:
        """A user function's body in place of its call: a parameter whose argument folds is a
        constant of the body, any other is the argument's Python (a group's, member by member)."""
        expansion = self.c.expansions[id(e)]
        d = expansion.decl
        constants = {k: v for k, v in self.constants.items() if k not in d.params}
        env: dict[str, str | list[str]] = {}
        for name, arg in zip(d.params, e.args):
            if self.c.node_types.get(id(arg)) in (Type.NUMBERS, Type.BOOLS):
                env[name] = self.members(w, arg, text, where)
                continue
            try:
                constants[name] = fold(arg, self.constants)
            except NotConstant:
                env[name] = self.emit(w, arg, text, where)
        outer = self.constants
        self.constants = constants
        self.env.append(env)
        try:
            inside = f"{where}, in {d.name}()"
            if self.c.node_types.get(id(expansion.body)) in (Type.NUMBERS, Type.BOOLS):
                return self.members(w, expansion.body, d.body.text, inside)
            return self.expr(w, expansion.body, d.body.text, inside)
        finally:
            self.env.pop()
            self.constants = outer


class MemberWriter(ast.Visitor[list[str]]):
    """Python for each member of a group-typed expression, written into ``w``."""

    def __init__(self, g: Unroller) -> None:
        self.g = g

    def spread(self, e: ast.Expr, sub: ast.Expr, w: Writer, text: Text, where: str) -> list[str]:
        return self.g.spread(w, sub, self.g.c.sizes.get(id(e), 0), text, where)

    def visit_Group(self, e: ast.Group, w: Writer, text: Text, where: str) -> list[str]:
        return [self.g.expr(w, m, text, where) for m in e.members]

    def visit_Name(self, e: ast.Name, w: Writer, text: Text, where: str) -> list[str]:
        g = self.g
        if g.env and e.id in g.env[-1]:
            return list(g.env[-1][e.id])
        if e.id in g.c.lists:  # a list parameter of numbers (format 1.3): its values
            return [number_literal(v) for v in g.c.lists[e.id]]  # type: ignore[arg-type]
        slots = g.layout.members[e.id]
        if slots is None:  # a group of names: read them where it is used
            parsed = g.let_of[e.id]
            return self.visit(parsed.node, w, parsed.text, where)
        for k in slots:
            w.read(k)
        return [f"v{k}" for k in slots]

    def visit_Neg(self, e: ast.Neg, w: Writer, text: Text, where: str) -> list[str]:
        return [f"(-{m})" for m in self.spread(e, e.operand, w, text, where)]

    def visit_Not(self, e: ast.Not, w: Writer, text: Text, where: str) -> list[str]:
        return [f"(not {m})" for m in self.spread(e, e.operand, w, text, where)]

    def visit_Binary(self, e: ast.Binary, w: Writer, text: Text, where: str) -> list[str]:
        out = []
        for a, b in zip(self.spread(e, e.left, w, text, where), self.spread(e, e.right, w, text, where)):
            if e.op in ("+", "-", "*") or (e.op in ("/", "%") and self.g.nonzero(e.right)):
                out.append(f"({a} {e.op} {b})")
            else:
                out.append(f"{self.g.site(e.op, text, e.span, where)}({a}, {b})")
        return out

    def visit_Compare(self, e: ast.Compare, w: Writer, text: Text, where: str) -> list[str]:
        out = []
        for row in zip(*(self.spread(e, o, w, text, where) for o in e.operands)):
            parts = [row[0]]
            for op, operand in zip(e.ops, row[1:]):
                parts += [op, operand]
            out.append("(" + " ".join(parts) + ")")
        return out

    def visit_BoolOp(self, e: ast.BoolOp, w: Writer, text: Text, where: str) -> list[str]:
        return ["(" + f" {e.op} ".join(row) + ")" for row in zip(*(self.spread(e, v, w, text, where)
                                                                  for v in e.values))]

    def visit_IfExp(self, e: ast.IfExp, w: Writer, text: Text, where: str) -> list[str]:
        rows = zip(self.spread(e, e.test, w, text, where), self.spread(e, e.body, w, text, where),
                   self.spread(e, e.orelse, w, text, where))
        return [f"({a} if {c} else {b})" for c, a, b in rows]

    def visit_Call(self, e: ast.Call, w: Writer, text: Text, where: str) -> list[str]:
        if id(e) in self.g.c.self_prev:  # prev(g, initial) in group g's own definition: each member's slot
            assert isinstance(e.args[0], ast.Name)  # the checker made it the signal's name
            slots = self.g.layout.members[e.args[0].id]
            assert slots is not None  # a group computed by a call has slots of its own
            # the slots still hold the last tick's values: group_signal stores the members all at once
            return [f"(s[{k}] if v{TICK} else {start})" for k, start in
                    zip(slots, self.spread(e, e.args[1], w, text, where))]
        if id(e) not in self.g.c.expansions:
            return self.g.member_call(w, e, text, where)
        body = self.g.inline(w, e, text, where)
        assert isinstance(body, list)
        return body

    def visit_Index(self, e: ast.Index, w: Writer, text: Text, where: str) -> list[str]:
        """waypoints[i], a row of a list parameter (format 1.3): its literals for a place that folds; for
        a place read while running, each value picked from its column through one guard, which warns
        once a tick when there is no row at the place."""
        g = self.g
        assert isinstance(e.value, ast.Name) and e.value.id in g.c.lists, e
        rows = g.c.lists[e.value.id]
        try:
            k = fold(e.index, g.constants)
        except NotConstant:
            k_code = g.expr(w, e.index, text, where)
            site = g.site("[row]", text, e.span, where)
            return [f"{site}({g.column(e.value.id, j)}, {k_code})" for j in range(len(rows[0]))]  # type: ignore[arg-type]
        assert isinstance(k, int | float) and float(k).is_integer()  # the checker refused other places
        return [number_literal(v) for v in rows[int(k)]]  # type: ignore[union-attr]

    def visit_Slice(self, e: ast.Slice, w: Writer, text: Text, where: str) -> list[str]:
        return self.g.slice(w, e, text, where)

    # one value each, never a group (the checker's types)
    generic = frozenset({ast.Number, ast.Bool, ast.Text, ast.Attribute, ast.Peer})

    def generic_visit(self, e: ast.Expr, *args: object) -> list[str]:
        raise AssertionError(f"cannot compile the group {e!r}")


# What a writer records as read when code uses the tick's channel values as one sequence
# (``values``): no slot has this number.
VALUES = -1
# The reductions with a form on such a sequence (labsim.dsl.library.builtins.SEQUENCE_FUNCTIONS); mean
# is the sum's, divided.
ON_SEQUENCE = frozenset({"min", "max", "argmin", "argmax", "sum", "mean"})


def number_literal(value: float) -> str:
    """A list parameter's number in generated code: repr of the float (a list holds finite numbers only)."""
    return repr(value) if value >= 0 else f"({value!r})"


def reduce_sequence(func: str, sequence: str, n: int, extremes: dict[tuple[str, str], int]) -> tuple[str, str]:
    """A reduction of a group held as a sequence: the Python and the function it calls.

    ``extremes`` holds the signals already computed as the minimum or maximum of a sequence:
    argmin of the same values is then where that minimum is (``argmin_at``), without a second
    pass of C's min over a lidar's 360 beams (the scan's nearest point and its direction are
    the usual pair)."""
    if func == "mean":
        return f"(_sum_of({sequence}) / {float(n)!r})", "sum_of"
    slot = extremes.get((func[3:], sequence)) if func in ("argmin", "argmax") else None
    if slot is not None:
        return f"_{func}_at({sequence}, v{slot})", f"{func}_at"
    return f"_{func}_of({sequence})", f"{func}_of"


# A slot's local in generated Python, and the channel values as one sequence: what an
# expression reads.
LOCAL = re.compile(r"\bv(\d+)\b")
SEQUENCE_READ = re.compile(r"\bvalues\b")
# A slot's local or a plain literal: safe to name more than once in an expression.
PLAIN = re.compile(r"^(v\d+|\d+\.\d+(e[+-]?\d+)?|_inf)$")
# A call in generated Python: a guard or memory site (``_g3(``), a random draw, a helper.
CALL = re.compile(r"\b_\w+(\[\d+\])?\(")


def reduce(func: str, members: list[str]) -> str:
    """A reduction of a group as one expression: min(front), any(front < 0.5), ..."""
    n = len(members)
    if func in ("min", "max"):
        if n == 1:
            return members[0]
        if n <= 3 and all(PLAIN.match(m) for m in members):
            return extreme(func, members)
        return f"_{func}({', '.join(members)})"
    if func in ("sum", "mean"):
        total = "(" + " + ".join(members) + ")"
        return total if func == "sum" else f"({total} / {float(n)!r})"
    if func in ("argmin", "argmax"):
        return f"_{func}({', '.join(members)})"
    if func == "count":
        return "(0.0 + " + " + ".join(members) + ")"
    if any(CALL.search(m) for m in members):
        # a member with memory, a random draw or a checked operation runs on every tick, whatever
        # the members before it decided: the tuple holds them all before the test (members are bools)
        return f"({'True in' if func == 'any' else 'False not in'} ({''.join(m + ', ' for m in members)}))"
    return "(" + f" {'or' if func == 'any' else 'and'} ".join(members) + ")"




def extreme(func: str, parts: list[str]) -> str:
    """``min``/``max`` of two or three plain values as an expression, without a call.

    Exactly what ``labsim.dsl.library.builtins._min`` and ``_max`` compute, nan and the order of equal
    values included: nan if any value is nan, else the running extreme from the first value,
    replaced only by a strictly smaller (larger) one. The wall lab's rules take the minimum of
    sonar pairs 150,000 times in a run; the call was 5% of its tick.
    """
    op = "<" if func == "min" else ">"
    nan = " or ".join(f"{p} != {p}" for p in parts)
    a, b = parts[0], parts[1]
    m = f"({b} if {b} {op} {a} else {a})"
    if len(parts) == 3:
        c = parts[2]
        m = f"({c} if {c} {op} {m} else {m})"
    return f"(_nan if {nan} else {m})"
