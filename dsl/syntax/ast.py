"""The abstract syntax of rule and expression strings.

``labsim.dsl.syntax.parse`` builds these frozen dataclasses from lark's tree; nothing of lark leaks
past it. Every node carries ``span``, the (start, end) character offsets of its text inside
the string it came from; spans are excluded from equality and repr so tests can compare trees
by structure. ``labsim.foundation.source.Text`` maps a span back to the file's line and column.

The one traversal of the tree is here too: ``children`` and ``walk`` are derived from each node's
dataclass fields (as CPython's ``ast.iter_child_nodes`` is), and ``Visitor`` is the base of every
analysis that dispatches on the kind of node (``labsim.dsl.analysis.check``, ``.infer``, ``.ranges``,
``.lint``, ``.unbounded``, ``.fold``, ``.unroll``, ``.evaluate``, ``.watch``): each declares what
it does for every node class, so a new construct cannot be forgotten by one of them
(tests/unit/test_traversal.py).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, ClassVar, Generic, TypeVar

Span = tuple[int, int]

# Every span field is written out as ``field(default=(0, 0), compare=False, repr=False,
# kw_only=True)``: type checkers only see through ``field`` called in the class body.


@dataclass(frozen=True)
class Expr:
    span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)
    # The fields that hold sub-expressions, in the order the language evaluates them; derived
    # from the dataclass fields when None (only 'a if c else b' evaluates out of source order).
    evaluation_order: ClassVar[tuple[str, ...] | None] = None


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

    evaluation_order = ("test", "body", "orelse")
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
class Slice(Expr):
    """``front[0:4]``: the members from place ``lower`` up to, not including, place ``upper``, as a
    group (version 1.3); a bound left out is the group's first place or its end."""

    value: Expr
    lower: Expr | None
    upper: Expr | None


@dataclass(frozen=True)
class Peer(Expr):
    """``leader.x`` or ``pioneer[2].state``: a value of another robot as it was on the last tick
    (version 1.3). ``member`` is the place in the robot's group (``Number(0)`` for a robot named
    alone, when ``indexed`` is false); ``attr`` is x, y, heading, state or one of its signals."""

    robot: str
    member: Expr
    attr: str
    indexed: bool = False
    robot_span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)
    attr_span: Span = field(default=(0, 0), compare=False, repr=False, kw_only=True)


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


# -- the traversal ---------------------------------------------------------------------------
def node_classes() -> tuple[type[Expr], ...]:
    """Every concrete kind of expression node, in the order defined."""
    out: list[type[Expr]] = []
    todo = list(Expr.__subclasses__())
    while todo:
        cls = todo.pop(0)
        out.append(cls)
        todo.extend(cls.__subclasses__())
    return tuple(out)


_CHILD_FIELDS: dict[type, tuple[str, ...]] = {}
# the annotations of the fields that hold sub-expressions (a slice's bound may be left out: None)
_EXPR_HINTS = ("Expr", "tuple[Expr, ...]", "Expr | None")


def child_fields(cls: type[Expr]) -> tuple[str, ...]:
    """The names of the fields of a node class that hold sub-expressions (one, or a tuple of them)."""
    names = _CHILD_FIELDS.get(cls)
    if names is None:
        derived = tuple(f.name for f in dataclasses.fields(cls) if f.compare and str(f.type) in _EXPR_HINTS)
        if cls.evaluation_order is not None:
            assert sorted(cls.evaluation_order) == sorted(derived), cls
            derived = cls.evaluation_order
        names = _CHILD_FIELDS[cls] = derived
    return names


def children(e: Expr) -> tuple[Expr, ...]:
    """The sub-expressions of a node, in the order the language evaluates them."""
    out: list[Expr] = []
    for name in child_fields(type(e)):
        value = getattr(e, name)
        if isinstance(value, tuple):
            out.extend(value)
        elif value is not None:
            out.append(value)
    return tuple(out)


def walk(e: Expr) -> Iterator[Expr]:
    """Every node of an expression, e first, in evaluation order; without recursion, so a long
    flat sum or a group of 100,000 members costs no stack."""
    todo = [e]
    while todo:
        node = todo.pop()
        yield node
        todo.extend(reversed(children(node)))


T = TypeVar("T")


class Visitor(Generic[T]):
    """An analysis of expressions: ``visit`` calls the method ``visit_<Class>`` for the node's class.

    Each analysis says what it does with every kind of node: a method of its own, or the node's
    class in ``generic``, for which ``generic_visit`` (visit the children; None) is what it
    means. tests/unit/test_traversal.py fails for a node class an analysis says nothing about.
    An analysis whose other methods take more than the node passes them on through ``visit``.
    """

    generic: ClassVar[frozenset[type[Expr]]] = frozenset()
    registry: ClassVar[list[type[Visitor[Any]]]] = []
    _methods: ClassVar[dict[type[Expr], str]]

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        Visitor.registry.append(cls)
        cls._methods = {}

    @classmethod
    def unhandled(cls) -> list[type[Expr]]:
        """The node classes this analysis says nothing about (the test wants none)."""
        return [n for n in node_classes() if not hasattr(cls, f"visit_{n.__name__}") and n not in cls.generic]

    def visit(self, e: Expr, *args: Any) -> T:
        cls = type(e)
        method = type(self)._methods.get(cls)
        if method is None:
            name = f"visit_{cls.__name__}"
            if hasattr(self, name):
                method = name
            elif cls in self.generic:
                method = "generic_visit"
            else:
                raise TypeError(f"{type(self).__name__} does not handle {cls.__name__}")
            type(self)._methods[cls] = method
        return getattr(self, method)(e, *args)

    def generic_visit(self, e: Expr, *args: Any) -> T:
        for child in children(e):
            self.visit(child, *args)
        return None  # type: ignore[return-value]


class LetMemo(Generic[T]):
    """A per-signal result of an analysis that follows ``let`` signals through their definitions.

    A signal reads only the signals above it, and itself only through ``prev(name, initial)``; so
    each is worked out once, in the file's order, the signals above first: following a signal
    costs one look-up, a chain of signals no deep recursion, and a signal read in both branches
    of an ``if`` (or by itself) no repeated work. While a signal is being worked out, reading it
    gives ``pending``.
    """

    def __init__(self, lets: dict[str, Expr], compute: Callable[[Expr], T], pending: T) -> None:
        self.lets = lets
        self.compute = compute
        self.pending = pending
        self.done: dict[str, T] = {}

    def __contains__(self, name: str) -> bool:
        return name in self.lets

    def __call__(self, name: str) -> T:
        if name not in self.done:
            for let, e in self.lets.items():
                if let not in self.done:
                    self.done[let] = self.pending
                    self.done[let] = self.compute(e)
                if let == name:
                    break
        return self.done[name]
