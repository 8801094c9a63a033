"""What a behaviour file declares and where it uses each name: the server's map of a file.

Read from the YAML the editor holds (``labsim.foundation.source.loads``, so positions are the
file's): the robots and their models, the params, ``let`` signals, functions, rule states,
metrics and sliders, each with the span of its key; and every use of a name inside the file's
expressions (rules, signals, the stop condition, metrics, functions, bind, timeline, the
``{...}`` fields of labels and logs), mapped back from the string's value to the file through
quotes and block scalars (``Text``). Words inside an expression's string literals are text,
not names, except in their ``{...}`` fields. Go to definition, rename and hover all read this.
"""
from __future__ import annotations

import contextlib
import re
from dataclasses import dataclass, field

from yaml.nodes import MappingNode, Node, ScalarNode, SequenceNode

from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.source import Document, Text, loads

NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
EXPRESSION_SECTIONS = ("stop", "let", "rules", "metrics", "functions", "bind", "timeline")


@dataclass(frozen=True)
class Span:
    """Characters start up to end of the file's text."""

    start: int
    end: int


@dataclass(frozen=True)
class Definition:
    name: str
    kind: str  # "signal", "param", "function", "state", "robot", "metric", "slider"
    span: Span  # the name in its key
    text: str  # what it is defined as: an expression, a value, a state's rules one a line


@dataclass(frozen=True)
class Robot:
    name: str
    model: str
    lidar: dict[str, float] | None
    span: Span


@dataclass
class Outline:
    kind: str  # "behaviour", "world", "assignment" or "unknown"
    definitions: dict[str, list[Definition]] = field(default_factory=dict)
    references: list[tuple[str, Span]] = field(default_factory=list)
    robots: list[Robot] = field(default_factory=list)
    world: tuple[str, Span] | None = None

    def define(self, d: Definition) -> None:
        self.definitions.setdefault(d.name, []).append(d)

    def name_at(self, index: int) -> tuple[str, Span] | None:
        """The name (declared or used) whose characters hold ``index`` (or end there)."""
        for defs in self.definitions.values():
            for d in defs:
                if d.span.start <= index <= d.span.end:
                    return d.name, d.span
        for name, span in self.references:
            if span.start <= index <= span.end:
                return name, span
        return None

    def occurrences(self, name: str, kinds: tuple[str, ...]) -> list[Span]:
        """Every span of ``name``: its declarations of these kinds and its uses."""
        spans = [d.span for d in self.definitions.get(name, []) if d.kind in kinds]
        spans += [span for n, span in self.references if n == name]
        return sorted(set(spans), key=lambda s: s.start)


def outline(text: str, path: str = "<editor>") -> Outline | None:
    """The outline of a behaviour file's text; None when its YAML does not compose."""
    bom = 1 if text.startswith("\ufeff") else 0
    try:
        doc = loads(text, path)
    except LabsimError:
        return None
    out = Outline("unknown")
    root = doc.root
    if not isinstance(root, MappingNode):
        return out
    keys = {k.value: (k, v) for k, v in root.value if isinstance(k, ScalarNode)}
    out.kind = ("world" if "labsim-world" in keys else "assignment" if "labsim-assignment" in keys
                else "behaviour")
    if out.kind != "behaviour":
        return _shift(out, bom)
    if "world" in keys and isinstance(keys["world"][1], ScalarNode):
        node = keys["world"][1]
        out.world = (node.value, _span(node))
    if "robots" in keys:
        _robots(keys["robots"][1], out)
    for section, kind in (("params", "param"), ("let", "signal"), ("functions", "function"),
                          ("metrics", "metric"), ("sliders", "slider")):
        if section in keys and isinstance(keys[section][1], MappingNode):
            for k, v in keys[section][1].value:
                if isinstance(k, ScalarNode):
                    _declare(out, doc, k, v, kind)
    if "rules" in keys and isinstance(keys["rules"][1], MappingNode):
        for k, v in keys["rules"][1].value:
            if isinstance(k, ScalarNode):
                rules = [n.value for n in v.value if isinstance(n, ScalarNode)] if isinstance(v, SequenceNode) else []
                out.define(Definition(k.value, "state", _span(k), "\n".join(rules)))
    for section in EXPRESSION_SECTIONS:
        if section in keys:
            _uses(doc, keys[section][1], out, section)
    if "sliders" in keys and isinstance(keys["sliders"][1], MappingNode):
        for _, v in keys["sliders"][1].value:
            if isinstance(v, MappingNode):
                for k2, v2 in v.value:
                    if isinstance(k2, ScalarNode) and k2.value == "label" and isinstance(v2, ScalarNode):
                        _names(doc, v2, out, fields_only=True)
    return _shift(out, bom)


def _shift(out: Outline, bom: int) -> Outline:
    """Spans in the editor's text: the reader drops a leading byte-order mark, the editor keeps it."""
    if not bom:
        return out
    def moved(s: Span) -> Span:
        return Span(s.start + bom, s.end + bom)
    out.definitions = {n: [Definition(d.name, d.kind, moved(d.span), d.text) for d in ds]
                       for n, ds in out.definitions.items()}
    out.references = [(n, moved(s)) for n, s in out.references]
    out.robots = [Robot(r.name, r.model, r.lidar, moved(r.span)) for r in out.robots]
    out.world = (out.world[0], moved(out.world[1])) if out.world else None
    return out


def _span(node: Node) -> Span:
    return Span(node.start_mark.index, node.end_mark.index)


def _declare(out: Outline, doc: Document, key: ScalarNode, value: Node, kind: str) -> None:
    name, span, text = key.value, _span(key), _value_text(doc, value)
    if kind == "function":  # steer(offset, gain): the name before its parameters
        m = NAME.match(key.value)
        if m is None:
            return
        name, span = m.group(), Span(key.start_mark.index, key.start_mark.index + m.end())
        text = f"{key.value}: {text}"
    if NAME.fullmatch(name):
        out.define(Definition(name, kind, span, text))


def _value_text(doc: Document, node: Node) -> str:
    if isinstance(node, ScalarNode):
        return node.value
    return doc.text[node.start_mark.index:node.end_mark.index].strip()


def _robots(node: Node, out: Outline) -> None:
    if not isinstance(node, MappingNode):
        return
    for k, v in node.value:
        if not isinstance(k, ScalarNode):
            continue
        model, lidar = "", None
        if isinstance(v, MappingNode):
            for k2, v2 in v.value:
                if isinstance(k2, ScalarNode) and k2.value == "model" and isinstance(v2, ScalarNode):
                    model = v2.value
                elif isinstance(k2, ScalarNode) and k2.value == "lidar":
                    lidar = _numbers(v2)
        out.robots.append(Robot(k.value, model, lidar, _span(k)))
        out.define(Definition(k.value, "robot", _span(k), f"model: {model or '?'}"))


def _numbers(node: Node) -> dict[str, float]:
    """A lidar's settings as far as they are numbers (the checker reports the rest)."""
    found: dict[str, float] = {}
    if isinstance(node, MappingNode):
        for k, v in node.value:
            if isinstance(k, ScalarNode) and isinstance(v, ScalarNode):
                with contextlib.suppress(ValueError):
                    found[k.value] = float(v.value)
    return found


def _uses(doc: Document, node: Node, out: Outline, section: str) -> None:
    """Every name used in the expressions under a section's node (not its keys, which declare)."""
    if isinstance(node, ScalarNode):
        _names(doc, node, out)
    elif isinstance(node, SequenceNode):
        for item in node.value:
            _uses(doc, item, out, section)
    elif isinstance(node, MappingNode):
        for k, v in node.value:
            if section == "metrics" and isinstance(k, ScalarNode) and k.value == "better":
                continue
            if section == "timeline" and isinstance(k, ScalarNode):
                _names(doc, k, out)  # "at 2: arm = 0": the slider names are on both sides
            if section == "bind" and isinstance(k, ScalarNode):
                continue  # Arm_Actuator.velocity: a joint of the scene
            if section == "functions" and isinstance(k, ScalarNode):
                # a function's parameters are its own names in its body, not the file's signals
                own = set(NAME.findall(k.value)[1:])
                before = len(out.references)
                _uses(doc, v, out, section)
                out.references[before:] = [(n, s) for n, s in out.references[before:] if n not in own]
                continue
            _uses(doc, v, out, section)


def _names(doc: Document, node: ScalarNode, out: Outline, fields_only: bool = False) -> None:
    """The names in one scalar's value, each mapped to its characters in the file."""
    if node.tag != "tag:yaml.org,2002:str" and node.style is None and not NAME.search(node.value):
        return
    text = Text(doc, node)
    for start, end in _name_spans(node.value, fields_only):
        a, b = text.index(start), text.index(end - 1) + 1
        out.references.append((node.value[start:end], Span(a, b)))


def _name_spans(value: str, fields_only: bool) -> list[tuple[int, int]]:
    """Where the names are in an expression: not in string literals (but in their {...} fields),
    not after a '.' (a record's field), not inside numbers (1e5)."""
    spans: list[tuple[int, int]] = []
    quote: str | None = '"' if fields_only else None
    depth = 0
    i = 0
    while i < len(value):
        ch = value[i]
        if quote is not None and depth == 0:
            if ch == quote and not fields_only:
                quote = None
            elif ch == "{":
                depth = 1
            i += 1
            continue
        if quote is not None and ch == "}":
            depth = 0
            i += 1
            continue
        if quote is None and ch in "\"'":
            quote = ch
            i += 1
            continue
        m = NAME.match(value, i)
        if m is None:
            i += 1
            continue
        before = value[i - 1] if i else ""
        field_of = before == "." and value[i - 2:i] != ".."  # centroid(img).x; sonar1..sonar8 is a range
        if not field_of and not before.isdigit():
            spans.append((m.start(), m.end()))
        i = m.end()
    return spans
