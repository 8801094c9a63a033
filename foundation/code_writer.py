"""The code writer: how labsim lays out the Python it generates.

The language's code generator (``labsim.dsl.emit.codegen``) and the trace's row writers
(``labsim.runtime.observers``) write lines through a ``Writer`` (``line``, ``indent``), as Jinja2's
CodeGenerator does, and never assembles indentation by hand or parses its own output back: a
piece of code comes out as a ``Body``, its lines and the slots its expressions read, as data.
A piece written once (a signal's expression registers its guards as it is generated) can go
into several functions with ``insert``. Every line carries its source mark: the line of the
behaviour file it comes from (0 for the plumbing around the rules), set by ``source`` around
what a rule, signal or metric compiles to. ``source`` also writes that part's marker comment
(``#@7``); ``render`` gives the module's source, its listing (each marker replaced by the
note it stands for: the file's line and text) and the line map.
"""
from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

INDENT = "    "


@dataclass(frozen=True)
class Note:
    """A marker comment: ``#@index`` in the source, ``# text`` in the listing."""

    index: int
    text: str
    mark: int  # the behaviour file's line the code under it comes from; 0 for none


@dataclass(frozen=True)
class Line:
    depth: int  # indentation levels
    text: str  # "" for a blank line
    mark: int  # the behaviour file's line this line comes from; 0 for none
    note: Note | None = None  # set on a marker comment


@dataclass(frozen=True)
class Body:
    """A piece of generated code: its lines, and the slots its expressions read."""

    lines: tuple[Line, ...]
    reads: frozenset[int]


class Notes:
    """The module's marker comments, numbered in the order they are made."""

    def __init__(self) -> None:
        self.texts: list[str] = []

    def add(self, text: str, mark: int = 0) -> Note:
        self.texts.append(text)
        return Note(len(self.texts) - 1, text, mark)


class Writer:
    """Lines at the current indentation, each with the source mark in force when it was written."""

    def __init__(self) -> None:
        self._lines: list[Line] = []
        self._reads: set[int] = set()
        self._depth = 0
        self._mark = 0

    def line(self, text: str = "") -> None:
        self._lines.append(Line(self._depth, text, self._mark))

    @contextmanager
    def indent(self) -> Iterator[None]:
        self._depth += 1
        try:
            yield
        finally:
            self._depth -= 1

    @contextmanager
    def source(self, note: Note) -> Iterator[None]:
        """The note's marker comment, then the lines written inside, marked with its file line."""
        self.comment(note)
        outer, self._mark = self._mark, note.mark
        try:
            yield
        finally:
            self._mark = outer

    def comment(self, note: Note) -> None:
        """The note's marker comment alone (the module's opening comments)."""
        self._lines.append(Line(self._depth, f"#@{note.index}", note.mark, note))

    def read(self, slot: int) -> None:
        """Record that the code being written reads slot ``slot`` (as the local ``v<slot>``)."""
        self._reads.add(slot)

    def insert(self, body: Body) -> None:
        """Another piece of code at the current indentation, with its marks and reads."""
        self._lines += [Line(self._depth + ln.depth, ln.text, ln.mark, ln.note) for ln in body.lines]
        self._reads |= body.reads

    def body(self) -> Body:
        return Body(tuple(self._lines), frozenset(self._reads))


def render(body: Body) -> tuple[str, str, tuple[int, ...]]:
    """The source, the listing (each marker comment as its note's text) and each line's mark."""
    source = []
    listing = []
    for ln in body.lines:
        text = INDENT * ln.depth + ln.text if ln.text else ""
        source.append(text)
        listing.append(text if ln.note is None else INDENT * ln.depth + "# " + ln.note.text)
    return "\n".join(source) + "\n", "\n".join(listing) + "\n", tuple(ln.mark for ln in body.lines)


# -- the text of comments ---------------------------------------------------------------------
def wrap(head: str, items: list[str], separator: str, width: int = 96) -> list[str]:
    """``head`` and the items, separated, in lines of at most ``width`` that break between items."""
    lines = [head.rstrip()]
    for k, item in enumerate(items):
        item += separator.rstrip() if k < len(items) - 1 else "."
        if len(lines[-1]) + 1 + len(item) > width:
            lines.append(item)
        else:
            lines[-1] += " " + item
    return lines


def one_line(value: str) -> str:
    """A rule's text on one line, for a comment: whitespace runs and control characters as one space."""
    if not value.isprintable():
        value = "".join(ch if ch.isprintable() else " " for ch in value)
    return " ".join(value.split())
