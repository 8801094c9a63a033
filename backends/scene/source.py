"""YAML with source positions: the first stage of the pipeline.

A behaviour or world file is composed (never constructed) with PyYAML's safe loader, so every
node keeps its line and column and no tag can run code. This module refuses what a plain data
file has no use for — anchors and aliases, non-core tags such as ``!!python/object``, duplicate
keys, files over ``MAX_BYTES`` — and turns YAML's own errors (tabs, bad indentation) into
diagnostics a student can act on.

``Text`` maps a character of a scalar's *value* back to its line and column in the *file*,
through quotes, escapes and block scalars, so that an error inside a rule string points at
the right column of the YAML line.
"""
from __future__ import annotations

import bisect
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import yaml
from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from labsim.backends.scene.diagnostics import Diagnostic, LabsimError, Report

MAX_BYTES = 1 << 20  # a behaviour file is hand-written; anything larger is a mistake

_CORE = "tag:yaml.org,2002:"
_ALLOWED_TAGS = {_CORE + t for t in ("str", "int", "float", "bool", "null", "map", "seq")}


class _Loader(yaml.SafeLoader):
    """Safe composer that refuses anchors and aliases where they appear."""


    def compose_node(self, parent, index):  # type: ignore[no-untyped-def]
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent):
            raise yaml.composer.ComposerError(
                None, None,
                f"YAML aliases (*{event.anchor}) are not supported in labsim files: write the value out",
                event.start_mark,
            )
        if getattr(event, "anchor", None):
            raise yaml.composer.ComposerError(
                None, None,
                f"YAML anchors (&{event.anchor}) are not supported in labsim files: write the value out",
                event.start_mark,
            )
        return super().compose_node(parent, index)


# YAML 1.1 (PyYAML) reads 1e-3 and 1e6 as text; students write them as numbers, as YAML 1.2 does.
_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


@dataclass
class Document:
    """A loaded file: its text (for source lines) and its root node."""

    path: str
    text: str
    root: Node | None

    def __post_init__(self) -> None:
        self.lines = self.text.splitlines()
        self._line_starts = [0]
        for i, ch in enumerate(self.text):
            if ch == "\n":
                self._line_starts.append(i + 1)

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

    def diagnostic(self, node: Node, message: str, severity: str = "error",
                   notes: tuple[str, ...] = ()) -> Diagnostic:
        """A diagnostic underlining a node (a scalar whole, or the first line of a collection)."""
        start, end = node.start_mark.index, node.end_mark.index
        if not isinstance(node, ScalarNode):
            end = start + 1
        return self.diagnostic_at(start, message, end, severity, notes)

    def text_of(self, node: ScalarNode) -> "Text":
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

    @property
    def spans_lines(self) -> bool:
        return self.node.start_mark.line != self.node.end_mark.line and self.node.style is None


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
        j = text.find(ch, pos, end)
        if j < 0:
            out.append(min(pos, max(start, end - 1)))
        else:
            out.append(j)
            pos = j + 1
    return out


def load(path: str | Path, *, kind: str = "behaviour") -> Document:
    """Read and compose a YAML file; raise LabsimError with positions on any problem."""
    name = str(path)
    p = Path(path)
    try:
        size = p.stat().st_size
    except FileNotFoundError:
        raise LabsimError([Diagnostic(name, f"no such {kind} file")]) from None
    except OSError as e:
        raise LabsimError([Diagnostic(name, f"cannot read the {kind} file: {e.strerror}")]) from None
    if p.is_dir():
        raise LabsimError([Diagnostic(name, f"is a folder, not a {kind} file")])
    if size > MAX_BYTES:
        raise LabsimError([Diagnostic(
            name, f"file is {size / 1e6:.1f} MB; {kind} files are limited to {MAX_BYTES // 1024} KiB")])
    try:
        text = p.read_bytes().decode("utf-8")
    except UnicodeDecodeError as e:
        raise LabsimError([Diagnostic(name, f"not UTF-8 text (byte {e.start})")]) from None
    return loads(text, name)


def loads(text: str, path: str = "<string>") -> Document:
    """Compose YAML text; raise LabsimError with positions on any problem."""
    text = text.lstrip("\ufeff")
    doc = Document(path, text, None)
    try:
        doc.root = yaml.compose(text, Loader=_Loader)
    except yaml.MarkedYAMLError as e:
        raise LabsimError([_yaml_diagnostic(doc, e)]) from None
    except yaml.YAMLError as e:  # unmarked: rare (e.g. a reader error)
        raise LabsimError([Diagnostic(path, f"YAML error: {e}")]) from None
    problems = [d for node in _walk(doc.root) for d in _node_problems(doc, node)]
    if problems:
        raise LabsimError(problems)
    return doc


def _yaml_diagnostic(doc: Document, e: yaml.MarkedYAMLError) -> Diagnostic:
    mark = e.problem_mark or e.context_mark
    problem = (e.problem or "").strip()
    if "<stream end>" in problem and e.context_mark is not None:
        mark = e.context_mark  # the file ended inside a bracket or quote: point at where it opened
        problem = problem.replace("'<stream end>'", "the end of the file")
    notes: tuple[str, ...] = ()
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


def known_fields(doc: Document, report: "Report", node: Node, allowed: tuple[str, ...],
                 what: str) -> dict[str, Node] | None:
    """The values of a mapping's known keys; unknown keys (with did-you-mean) and a node that
    is not a mapping are reported, the latter giving None."""
    from labsim.backends.scene.diagnostics import did_you_mean

    if not isinstance(node, MappingNode):
        report.add(doc.diagnostic(node, f"{what} must be a mapping such as {{{allowed[0]}: ...}}"))
        return None
    out = {}
    for k, v in node.value:
        if k.value not in allowed:
            report.add(doc.diagnostic(k, f"unknown key '{k.value}' in {what}{did_you_mean(k.value, allowed)}"))
        else:
            out[k.value] = v
    return out


def scalar_value(node: ScalarNode) -> object:
    """The Python value of a core-schema scalar: str, int, float, bool or None."""
    return yaml.SafeLoader("").construct_object(node, deep=False)
