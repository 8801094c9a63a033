"""List parameters (format 1.3): ``waypoints: [[0, -1], [3, -1]]`` read, and their shape checked.

A list parameter is a list of numbers (``gains: [0.5, 1, 2]``, which reads as a group), or a list of
rows of numbers, all of one length (``waypoints[i]`` is a row, ``waypoints[i][0]`` a number). The
reader (``labsim.dsl.syntax.read``) reads a ``params:`` entry written as a YAML list with
``list_value``, and the checker (``labsim.dsl.analysis.check``) a ``--set NAME=[...]`` with
``list_setting``: one shape rule, each mistake reported at the value it is about (in the file) or
naming the ``--set`` (on the command line).
"""
from __future__ import annotations

import math
from collections.abc import Callable

from yaml.nodes import Node, ScalarNode, SequenceNode

from labsim.dsl.syntax.parse import MAX_RANGE
from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.source import loads, scalar_value, shape_of

Row = tuple[float, ...]
ListValue = tuple[float, ...] | tuple[Row, ...]  # numbers, or rows of numbers of one length
MAX_LIST_NUMBERS = 10_000  # in one list: a table of waypoints has dozens; each is a literal of the generated code
EXAMPLE = "e.g. waypoints: [[0, -1], [3, -1], [3, -4]], or gains: [0.5, 1, 2]"

Report = Callable[[Node, str, tuple[str, ...]], None]


def is_table(value: ListValue) -> bool:
    """Whether a list's values are rows (a table), not numbers."""
    return isinstance(value[0], tuple)


def list_value(node: SequenceNode, name: str, error: Report) -> ListValue | None:
    """The value of a list parameter written in YAML; None, after reporting each mistake, if its shape is wrong."""
    items = node.value
    if not items:
        error(node, f"list '{name}' is empty: a list parameter holds at least one value", (EXAMPLE,))
        return None
    if not isinstance(items[0], SequenceNode):
        if len(items) > MAX_RANGE:  # a list of numbers is a group, written out member by member
            error(node, f"list '{name}' holds {len(items):,} numbers, and a list of numbers (a group) at most "
                        f"{MAX_RANGE:,}", ("a longer table is a list of rows, as in [[x, y], ...]",))
            return None
        numbers = [_number(item, name, error) for item in items]
        if None in numbers:
            return None
        return _small(tuple(n for n in numbers if n is not None), node, name, error)
    rows: list[Row] = []
    width = len(items[0].value)
    if width > MAX_RANGE:  # a row is a group
        error(items[0], f"row 0 of list '{name}' has {width:,} values, and a row (a group) at most {MAX_RANGE:,}", ())
        return None
    for k, item in enumerate(items):
        if not isinstance(item, SequenceNode):
            error(item, f"list '{name}' is a list of rows, and this is not a row: write it as [a, b, ...]", ())
            return None
        if not item.value:
            error(item, f"row {k} of list '{name}' is empty", ())
            return None
        if len(item.value) != width:
            error(item, f"row {k} of list '{name}' has {len(item.value)} value{_s(len(item.value))}, and row 0 "
                        f"has {width}: the rows of a list have one length",
                  (f"give every row {width} value{_s(width)}, as row 0 has",))
            return None
        row = [_number(v, name, error, in_row=True) for v in item.value]
        if None in row:
            return None
        rows.append(tuple(v for v in row if v is not None))
    return _small(tuple(rows), node, name, error)


def _number(node: Node, name: str, error: Report, in_row: bool = False) -> float | None:
    """A list's value, or a value of one of its rows: a finite number."""
    if isinstance(node, SequenceNode):
        said = (f"a row of list '{name}' holds numbers, and this is a list in it" if in_row else
                f"list '{name}' starts with a number, so it is a list of numbers, and this is a list in it")
        error(node, said, ("a list holds numbers, or rows of numbers (then every value is a row), " + EXAMPLE,))
        return None
    value = scalar_value(node) if isinstance(node, ScalarNode) else None
    if isinstance(value, bool) or not isinstance(value, int | float):
        shown = f"'{node.value}'" if isinstance(node, ScalarNode) and node.value else f"a {shape_of(node)}"
        error(node, f"list '{name}' holds numbers, not {shown}",
              ("a list's values are numbers written out, as in [0.5, 1, 2]; computed values belong under 'let:'",))
        return None
    if not math.isfinite(value):
        error(node, f"list '{name}' holds finite numbers, not '{node.value}'", ())
        return None
    return float(value)


def _small(value: ListValue, node: Node, name: str, error: Report) -> ListValue | None:
    count = sum(len(v) if isinstance(v, tuple) else 1 for v in value)
    if count > MAX_LIST_NUMBERS:
        error(node, f"list '{name}' holds {count:,} numbers, more than the {MAX_LIST_NUMBERS:,} a list may", ())
        return None
    return value


def list_setting(raw: str, name: str, current: ListValue) -> tuple[ListValue | None, str, tuple[str, ...]]:
    """A list parameter's value given by ``--set NAME=[...]``: (value, "", ()) or (None, problem, notes).

    A list is set whole, and its new value follows the shape rule of the file's (a table stays a
    table, numbers stay numbers; the number of rows may change)."""
    how = (f"set it whole, as in --set {name}='{list_text(current)}'",)
    text = raw.strip()
    if not text.startswith("["):
        return None, f"parameter '{name}' is a list: give a whole list, not '{raw[:40]}'", how
    try:
        doc = loads(text, f"--set {name}")
    except LabsimError as e:  # YAML's own words: a number too large, nesting too deep, an anchor
        said = e.diagnostics[0].message if e.diagnostics else "not a list written as [a, b, ...]"
        return None, f"parameter '{name}': {said}", how
    if not isinstance(doc.root, SequenceNode):
        return None, f"parameter '{name}': '{raw[:40]}' is not a list written as [a, b, ...]", how
    problems: list[tuple[str, tuple[str, ...]]] = []
    value = list_value(doc.root, name, lambda _node, message, notes: problems.append((message, notes)))
    if value is None:
        return None, problems[0][0], problems[0][1]
    if is_table(value) != is_table(current):
        want = "rows of numbers" if is_table(current) else "numbers"
        return None, f"parameter '{name}' is a list of {want} in the file, and so must be its --set", how
    width = len(current[0]) if is_table(current) else 0  # type: ignore[arg-type]
    if width and len(value[0]) != width:  # type: ignore[arg-type]
        return None, (f"parameter '{name}' has rows of {width} number{_s(width)} in the file, and so must its --set; "
                      f"these have {len(value[0])}"), how  # type: ignore[arg-type]
    return value, "", ()


def list_text(value: ListValue, limit: int = 60) -> str:
    """A list as it is written: [[0, -1], [3, -1]]; cut with '...' past ``limit`` characters."""
    text = "[" + ", ".join(("[" + ", ".join(f"{n:g}" for n in v) + "]") if isinstance(v, tuple) else f"{v:g}"
                           for v in value) + "]"
    return text if len(text) <= limit else text[:limit - 4] + "...]"


def _s(n: int) -> str:
    return "" if n == 1 else "s"
