"""The abstract syntax of rule and expression strings.

``labsim.dsl.parse`` builds these frozen dataclasses from lark's tree; nothing of lark leaks
past it. Every node carries ``span``, the (start, end) character offsets of its text inside
the string it came from; spans are excluded from equality and repr so tests can compare trees
by structure. ``labsim.foundation.source.Text`` maps a span back to the file's line and column.
"""
from __future__ import annotations

from dataclasses import dataclass, field

Span = tuple[int, int]

# Every span field is written out as ``field(default=(0, 0), compare=False, repr=False,
# kw_only=True)``: type checkers only see through ``field`` called in the class body.


@dataclass(frozen=True)
class Expr:
    span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)


@dataclass(frozen=True)
class Number(Expr):
    value: float


@dataclass(frozen=True)
class Bool(Expr):
    value: bool


@dataclass(frozen=True)
class Name(Expr):
    id: str


@dataclass(frozen=True)
class Neg(Expr):
    operand: Expr


@dataclass(frozen=True)
class Not(Expr):
    operand: Expr


@dataclass(frozen=True)
class Binary(Expr):
    op: str  # + - * / % **
    left: Expr
    right: Expr


@dataclass(frozen=True)
class Compare(Expr):
    """``a < b <= c``: operands and the operators between them; true when every pair holds."""

    operands: tuple[Expr, ...]
    ops: tuple[str, ...]


@dataclass(frozen=True)
class BoolOp(Expr):
    op: str  # and, or
    values: tuple[Expr, ...]


@dataclass(frozen=True)
class IfExp(Expr):
    """``body if test else orelse``."""

    body: Expr
    test: Expr
    orelse: Expr


@dataclass(frozen=True)
class Call(Expr):
    func: str
    args: tuple[Expr, ...]
    func_span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)


@dataclass(frozen=True)
class Attribute(Expr):
    value: Expr
    attr: str
    attr_span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)


@dataclass(frozen=True)
class Text(Expr):
    """``"left"``: text, which only a log's field shows (version 1.2)."""

    value: str


@dataclass(frozen=True)
class Group(Expr):
    """``[sonar4, sonar5]`` or ``sonar1..sonar8``: values taken together (version 1.2).

    A range is read into its member names; ``ranged`` keeps that it was written as one, so
    that the checker can name the members that do not exist in one message.
    """

    members: tuple[Expr, ...]
    ranged: bool = False


@dataclass(frozen=True)
class Index(Expr):
    """``front[2]``: one member of a group, counted from 0."""

    value: Expr
    index: Expr


@dataclass(frozen=True)
class Action:
    """``arc(l, r)`` in a rule's action list."""

    name: str
    args: tuple[Expr, ...]
    span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)
    name_span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)
    # log("text {expr:.2f}"): literal text and (expression, format spec) fields; None without text
    text: tuple[str | tuple[Expr, str], ...] | None = field(default=None, kw_only=True)


@dataclass(frozen=True)
class Goto:
    """``goto follow``: switch the robot's rule state from the next tick on."""

    state: str
    span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)
    state_span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)


@dataclass(frozen=True)
class Rule:
    kind: str  # "if", "else", "always", or "when" (logs, and the rules below go on: version 1.2)
    condition: Expr | None
    actions: tuple[Action | Goto, ...]
    span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)
