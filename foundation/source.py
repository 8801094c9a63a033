"""YAML with source positions: the first stage of the pipeline.

A behaviour or world file is composed (never constructed) with PyYAML's safe loader, so every
node keeps its line and column and no tag can run code. This module refuses what a plain data
file has no use for — anchors and aliases, non-core tags such as ``!!python/object``, duplicate
keys, files over ``MAX_BYTES`` — and turns YAML's own errors (tabs, bad indentation) into
diagnostics a student can act on.

``Text`` maps a character of a scalar's *value* back to its line and column in the *file*,
through quotes, escapes and block scalars, so that an error inside a rule string points at
the right column of the YAML line.

``Reader`` is the base of every reader that turns a composed file into labsim's values (the
behaviour file, world files, a world's mechanism): one way to report a problem, and the value
readers they share, with one contract.
"""
from __future__ import annotations

import bisect
import math
import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TypeAlias

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from labsim.foundation.diagnostics import Diagnostic, LabsimError, Report, did_you_mean
from labsim.foundation.files import read_text
from labsim.foundation.numbers import NumberError, scalar_problem, to_float, yaml12_numbers, yaml_scalar

MAX_BYTES = 1 << 20  # a behaviour file is hand-written; anything larger is a mistake
# Lists and mappings nested deeper than this are refused as they are composed, before PyYAML's
# recursive composer could exhaust Python's stack (about 300 levels); labsim's files use 6.
MAX_DEPTH = 100

_CORE = "tag:yaml.org,2002:"
_ALLOWED_TAGS = {_CORE + t for t in ("str", "int", "float", "bool", "null", "map", "seq")}


class _Loader(yaml.SafeLoader):
    """Safe composer that refuses anchors and aliases where they appear, and deep nesting."""

    depth = 0  # lists and mappings open around the node being composed

    def compose_node(self, parent: Node | None, index: int) -> Node | None:
        event = self.peek_event()
        if isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
            if self.depth >= MAX_DEPTH:
                raise yaml.composer.ComposerError(
                    None, None, f"YAML nested more than {MAX_DEPTH} levels deep: labsim files are not nested "
                    "that far", event.start_mark)  # type: ignore[arg-type]  # as below
            self.depth += 1
            try:
                return self._compose_checked(parent, index)
            finally:
                self.depth -= 1
        return self._compose_checked(parent, index)

    def _compose_checked(self, parent: Node | None, index: int) -> Node | None:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent):
            raise yaml.composer.ComposerError(
                None, None,
                f"YAML aliases (*{event.anchor}) are not supported in labsim files: write the value out",
                event.start_mark,  # type: ignore[arg-type]  # the stubs' Mark of the C loader is another class
            )
        if getattr(event, "anchor", None):
            raise yaml.composer.ComposerError(
                None, None,
                f"YAML anchors (&{event.anchor}) are not supported in labsim files: write the value out",
                event.start_mark,
            )
        return super().compose_node(parent, index)


yaml12_numbers(_Loader)  # 017 is 17, 1:30 text, 1e-3 a number (labsim.foundation.numbers)


@dataclass
class Document:
    """A loaded file: its text (for source lines) and its root node."""

    path: str
    text: str
    root: Node | None

    def __post_init__(self) -> None:
        self.lines = [ln.removesuffix("\r") for ln in self.text.split("\n")]  # as _line_starts: not at \x0b
        self._line_starts = [0] + [m.end() for m in re.finditer("\n", self.text)]

    def position(self, index: int) -> tuple[int, int]:
        """1-based (line, column) of a character index into the file."""
        line = bisect.bisect_right(self._line_starts, index) - 1
        return line + 1, index - self._line_starts[line] + 1

    def source_line(self, line: int) -> str:
        return self.lines[line - 1] if 0 < line <= len(self.lines) else ""

    def diagnostic_at(self, index: int, message: str, end_index: int | None = None,
                      severity: str = "error", notes: tuple[str, ...] = ()) -> Diagnostic:
        line, col = self.position(index)
        end_col = 0
        if end_index is not None and end_index > index:
            end_line, end = self.position(end_index)
            end_col = end if end_line == line else len(self.source_line(line)) + 1
        return Diagnostic(self.path, message, line, col, end_col, severity, self.source_line(line), notes)

    def diagnostic(self, place: Place, message: str, severity: str = "error",
                   notes: tuple[str, ...] = ()) -> Diagnostic:
        """A diagnostic at a place of this file (see ``Place``).

        A node is underlined whole if it is a scalar, by its first character if a collection.
        """
        if place is None:
            return Diagnostic(self.path, message, severity=severity, notes=notes)
        if isinstance(place, int):
            return self.diagnostic_at(place, message, None, severity, notes)
        if isinstance(place, TextSpan):
            return place.text.diagnostic(place.start, place.end, message, severity, notes)
        start, end = place.start_mark.index, place.end_mark.index
        if not isinstance(place, ScalarNode):
            end = start + 1
        return self.diagnostic_at(start, message, end, severity, notes)

    def text_of(self, node: ScalarNode) -> Text:
        return Text(self, node)


class Text:
    """A scalar's value with the file position of each of its characters."""

    def __init__(self, doc: Document, node: ScalarNode):
        self.doc = doc
        self.node = node
        self.value: str = node.value
        self.offsets = _align(doc.text, node)

    def index(self, i: int) -> int:
        """File character index of value character i (i may be len(value): just past the end)."""
        if not self.offsets:
            return self.node.start_mark.index
        if i >= len(self.offsets):
            return self.offsets[-1] + 1
        return self.offsets[max(0, i)]

    def diagnostic(self, start: int, end: int, message: str, severity: str = "error",
                   notes: tuple[str, ...] = ()) -> Diagnostic:
        s = self.index(start)
        e = self.index(end - 1) + 1 if end > start else None
        return self.doc.diagnostic_at(s, message, e, severity, notes)

    def at(self, span: tuple[int, int]) -> TextSpan:
        """Value characters span[0] up to span[1], as a place for a diagnostic."""
        return TextSpan(self, span[0], span[1])

    @property
    def spans_lines(self) -> bool:
        return self.node.start_mark.line != self.node.end_mark.line and self.node.style is None


@dataclass(frozen=True)
class TextSpan:
    """Characters start up to end of a scalar's value: where inside a rule string a problem is."""

    text: Text
    start: int
    end: int


# Where a diagnostic points: a YAML node, characters of a scalar's value, a character index of
# the file (0: its start), or None for the file as a whole (no line, no caret).
Place: TypeAlias = Node | TextSpan | int | None


# How far ahead _align looks for a value character: far enough for any escape (\U0001F600 is
# 10 characters) and for folded indentation, and it keeps the walk linear: looking to the end of
# the scalar for every escaped character was quadratic (150,000 escapes took seconds).
_ALIGN_REACH = 256


def _align(text: str, node: ScalarNode) -> list[int]:
    """File index of every character of the node's value.

    A greedy walk over the raw scalar: each non-blank value character is matched to the next
    equal character of the source; blanks (from folded lines, escapes) map to where the walk
    is. Plain, quoted and block scalars all keep their characters in order, so this is exact
    for everything but escapes, where it stays close.
    """
    start, end = node.start_mark.index, node.end_mark.index
    pos = start
    if node.style in ("'", '"'):
        pos += 1
    elif node.style in ("|", ">"):
        newline = text.find("\n", start, end)
        pos = newline + 1 if newline >= 0 else end
    out = []
    for ch in node.value:
        if ch.isspace():
            out.append(min(pos, max(start, end - 1)))
            if pos < end and text[pos] == ch:
                pos += 1
            continue
        j = text.find(ch, pos, min(end, pos + _ALIGN_REACH))
        if j < 0:
            out.append(min(pos, max(start, end - 1)))
        else:
            out.append(j)
            pos = j + 1
    return out


def load(path: str | Path, *, kind: str = "behaviour") -> Document:
    """Read and compose a YAML file; raise LabsimError with positions on any problem.

    The file comes in through ``files.read_text``: a regular file of at most ``MAX_BYTES``."""
    return loads(read_text(path, kind, MAX_BYTES), str(path))


def loads(text: str, path: str = "<string>") -> Document:
    """Compose YAML text; raise LabsimError with positions on any problem."""
    text = text.lstrip("\ufeff")
    doc = Document(path, text, None)
    try:
        doc.root = yaml.compose(text, Loader=_Loader)
    except yaml.MarkedYAMLError as e:
        raise LabsimError([_yaml_diagnostic(doc, e)]) from None
    except yaml.reader.ReaderError as e:  # a character YAML refuses (an ESC, a NUL): say where
        code = e.character if isinstance(e.character, int) else ord(e.character)
        raise LabsimError([doc.diagnostic_at(e.position, f"a YAML file may not hold the control character "
                                             f"U+{code:04X}", e.position + 1)]) from None
    except yaml.YAMLError as e:  # unmarked: rare
        raise LabsimError([Diagnostic(path, f"YAML error: {' '.join(str(e).split())}")]) from None
    problems = [d for node in _walk(doc.root) for d in _node_problems(doc, node)]
    if problems:
        raise LabsimError(problems)
    return doc


def _yaml_diagnostic(doc: Document, e: yaml.MarkedYAMLError) -> Diagnostic:
    mark = e.problem_mark or e.context_mark
    problem = (e.problem or "").strip()
    notes: tuple[str, ...] = ()
    if "<stream end>" in problem and e.context_mark is not None:
        mark = e.context_mark  # the file ended inside a bracket or quote: point at where it opened
        problem = problem.replace("'<stream end>'", "the end of the file")
        closing = {"[": "]", "{": "}"}.get(doc.text[mark.index] if mark.index < len(doc.text) else "")
        if closing:
            notes = (f"hint: this '{doc.text[mark.index]}' is never closed: close it with '{closing}'",)
    elif "end of stream" in problem and e.context_mark is not None and "quoted" in (e.context or ""):
        # an unclosed quote: the end of the file has no line to show; the quote that opened it has
        opened = doc.text[e.context_mark.index] if e.context_mark.index < len(doc.text) else '"'
        return doc.diagnostic_at(e.context_mark.index, f"YAML syntax error: this {opened} is never closed "
                                 "(the file ends inside the quoted text)", None,
                                 notes=(f"hint: end the text with {opened} on the same line",))
    index = mark.index if mark else 0
    if "'\\t'" in problem or (mark and 0 <= index < len(doc.text) and doc.text[index] == "\t"):
        message = "tab character: YAML indentation must use spaces"
        notes = ("hint: set your editor to insert spaces for the Tab key",)
    elif problem.startswith("YAML "):
        message = problem  # ours, from _Loader
    else:
        message = f"YAML syntax error: {problem}"
        if e.context:
            message += f" ({e.context.strip()})"
        if "mapping values are not allowed" in problem:
            notes = ("hint: a ': ' inside a value starts a mapping; quote the value, or remove the colon",)
        elif "expected <block end>" in problem or "did not find expected" in problem:
            notes = ("hint: check the indentation of this line and the one before it",)
        if (e.context and "flow" in e.context and e.context_mark is not None and mark is not None
                and e.context_mark.line != mark.line):
            opened = doc.text[e.context_mark.index] if e.context_mark.index < len(doc.text) else "bracket"
            notes += (f"hint: the '{opened}' on line {e.context_mark.line + 1}, column "
                      f"{e.context_mark.column + 1} is never closed",)
    if mark is None:
        return Diagnostic(doc.path, message, notes=notes)
    return doc.diagnostic_at(index, message, None, notes=notes)


def _walk(node: Node | None) -> Iterator[Node]:
    stack = [node] if node is not None else []
    while stack:
        n = stack.pop()
        yield n
        if isinstance(n, MappingNode):
            for k, v in reversed(n.value):
                stack.extend((v, k))
        elif isinstance(n, SequenceNode):
            stack.extend(reversed(n.value))


def _node_problems(doc: Document, node: Node) -> Iterator[Diagnostic]:
    if node.tag not in _ALLOWED_TAGS:
        tag = node.tag.replace(_CORE, "!!")
        yield doc.diagnostic(node, f"YAML tag '{tag}' is not allowed: labsim files hold plain data")
    elif isinstance(node, ScalarNode) and (problem := scalar_problem(node)) is not None:
        yield doc.diagnostic(node, problem[0], notes=problem[1])
    if isinstance(node, MappingNode):
        seen: dict[str, Node] = {}
        for key, _ in node.value:
            if not isinstance(key, ScalarNode):
                yield doc.diagnostic(key, "a key must be a plain name, not a list or mapping")
                continue
            if key.value in seen:
                first = seen[key.value].start_mark.line + 1
                yield doc.diagnostic(key, f"duplicate key '{key.value}' (first given on line {first})")
            else:
                seen[key.value] = key


def scalar_value(node: ScalarNode) -> object:
    """The Python value of a core-schema scalar: str, int, float, bool or None.

    ``loads`` has refused every number that does not fit a float, so a number read here
    converts to a float without loss of range; a node made some other way that holds one
    reads as its text, which every reader refuses as no number.
    """
    try:
        value = yaml_scalar(node)
    except ValueError:
        return str(node.value)
    if isinstance(value, int) and not isinstance(value, bool):
        try:
            to_float(value)
        except NumberError:
            return str(node.value)
    return value


def shape_of(node: Node | None) -> str:
    """What a node is, for messages: 'mapping', 'list', 'empty value' or 'value'."""
    if isinstance(node, MappingNode):
        return "mapping"
    if isinstance(node, SequenceNode):
        return "list"
    if isinstance(node, ScalarNode) and node.tag.endswith(":null"):
        return "empty value"
    return "value"


class Reader:
    """The base of the readers that turn a composed file into labsim's values.

    A reader reports every problem it finds into the ``Report`` and keeps going, so that one
    ``labsim check`` shows them all; ``error`` is the one way it does so. The value readers
    below share one contract: each returns the value and reports nothing, or reports what is
    wrong and returns None — one diagnostic for the value, or, for a list of numbers, one for
    each item that is no number. ``fields`` is the one exception: it reports unknown keys and
    still gives the known ones, so that their values are checked too. ``what`` names the value
    in messages ("dt", "a road's width").
    """

    def __init__(self, doc: Document, report: Report) -> None:
        self.doc = doc
        self.report = report

    def error(self, place: Place, message: str, notes: tuple[str, ...] = ()) -> None:
        self.report.add(self.doc.diagnostic(place, message, notes=notes))

    @property
    def error_count(self) -> int:
        """How many errors the report holds: compare two counts to learn whether a part failed."""
        return len(self.report.errors)

    # -- single values ------------------------------------------------------------------------

    def scalar(self, node: Node, what: str) -> ScalarNode | None:
        """A single value, not a list or a mapping."""
        if not isinstance(node, ScalarNode):
            self.error(node, f"{what} must be a single value, not a {shape_of(node)}")
            return None
        return node

    def string(self, node: Node, what: str) -> str | None:
        """Text as it is written (a number reads as its digits); an empty value is ''."""
        scalar = self.scalar(node, what)
        if scalar is None:
            return None
        value = scalar_value(scalar)
        if isinstance(value, bool):
            self.error(node, f"{what} must be text")
            return None
        return "" if value is None else str(scalar.value)

    def name(self, node: Node, what: str) -> str | None:
        """A name: text that is not empty."""
        value = scalar_value(node) if isinstance(node, ScalarNode) else None
        if not isinstance(value, str) or not value:
            self.error(node, f"{what} must be a name")
            return None
        return value

    def flag(self, node: Node, what: str) -> bool | None:
        value = scalar_value(node) if isinstance(node, ScalarNode) else None
        if not isinstance(value, bool):
            self.error(node, f"{what} must be true or false")
            return None
        return value

    def number(self, node: Node, what: str, *, integer: bool = False) -> float | None:
        """A finite number, as a float; with integer=True a whole one, as written (3 or 3.0)."""
        value = scalar_value(node) if isinstance(node, ScalarNode) else None
        if (isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value)
                or (integer and value != int(value))):
            self.error(node, *self.number_problem(node, what, integer))
            return None
        return value if integer else float(value)

    def number_problem(self, node: Node, what: str, integer: bool) -> tuple[str, tuple[str, ...]]:
        """The message and notes for a value that is not the number asked for.

        Each kind of file words this its own way; this is the plainest.
        """
        return f"{what} must be {'a whole number' if integer else 'a number'}", ()

    def positive(self, node: Node, what: str) -> float | None:
        value = self.number(node, what)
        if value is not None and not value > 0:
            self.error(node, f"{what} must be positive")
            return None
        return value

    # -- lists and mappings -------------------------------------------------------------------

    def number_list(self, node: Node, what: str, counts: tuple[int, ...] = (2,)) -> list[Node] | None:
        """The items of a list that should hold one of ``counts`` numbers (not read yet)."""
        if not isinstance(node, SequenceNode) or len(node.value) not in counts:
            self.error(node, f"{what} must be a list of {' or '.join(str(n) for n in counts)} numbers")
            return None
        return list(node.value)

    def numbers(self, node: Node, what: str, counts: tuple[int, ...] = (2,)) -> list[float] | None:
        """A list of one of ``counts`` numbers, each reported if it is no number."""
        items = self.number_list(node, what, counts)
        if items is None:
            return None
        values = [self.number(item, what) for item in items]
        out = [v for v in values if v is not None]
        return out if len(out) == len(values) else None

    def pair(self, node: Node, what: str) -> tuple[float, float] | None:
        values = self.numbers(node, what, (2,))
        return None if values is None else (values[0], values[1])

    def colour(self, node: Node, what: str) -> tuple[int, int, int] | None:
        """[red, green, blue], each 0..255 (rounded to whole numbers)."""
        message = f"{what} must be three numbers 0..255: [red, green, blue]"
        if not isinstance(node, SequenceNode) or len(node.value) != 3:
            self.error(node, message)
            return None
        out = []
        for item in node.value:
            value = scalar_value(item) if isinstance(item, ScalarNode) else None
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value <= 255:
                self.error(item, message)
                return None
            out.append(round(value))
        return (out[0], out[1], out[2])

    def items(self, node: Node, what: str) -> list[Node] | None:
        """The items of a list."""
        if not isinstance(node, SequenceNode):
            self.error(node, f"'{what}' must be a list")
            return None
        return list(node.value)

    def entries(self, node: Node, what: str) -> list[tuple[ScalarNode, Node]] | None:
        """The (key, value) pairs of a mapping from names to descriptions."""
        if not isinstance(node, MappingNode):
            self.error(node, f"'{what}' must be a mapping of names to their descriptions")
            return None
        return list(node.value)

    def fields(self, node: Node, allowed: tuple[str, ...], what: str) -> dict[str, Node] | None:
        """The values of a mapping's known keys, by key.

        Each unknown key is reported (with the closest known one), and the others still read:
        the mapping fails only if it is no mapping.
        """
        if not isinstance(node, MappingNode):
            self.error(node, f"{what} must be a mapping such as {{{allowed[0]}: ...}}")
            return None
        out = {}
        for key, value in node.value:
            if key.value not in allowed:
                self.error(key, f"unknown key '{key.value}' in {what}{did_you_mean(key.value, allowed)}")
            else:
                out[key.value] = value
        return out
