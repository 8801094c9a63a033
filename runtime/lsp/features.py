"""Completion, hover, go to definition and rename: the requests ``labsim lsp`` answers from a
document's outline (``labsim.runtime.lsp.outline``), the schemas and the language's tables.

Completion offers what fits where the cursor is: the schema's keys where a key goes, models
after ``model:``, worlds after ``world:``, states after ``goto``, distance sensors in
``detected(...)``, and elsewhere in an expression every sensor of the file's robots, its
signals, params, states, functions and sliders, and the built-ins with their signatures.
"""
from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from lsprotocol import types as lsp

from labsim.foundation.kinds import file_kind, kind_of_text
from labsim.foundation.source import MAX_BYTES
from labsim.runtime.lsp import language
from labsim.runtime.lsp.outline import NAME, Outline, Span, outline
from labsim.runtime.lsp.positions import Lines
from labsim.runtime.lsp.session import LabsimServer, Refused, uri_path

RENAMEABLE = ("signal", "state", "param", "slider")
DEFINED = ("signal", "param", "function", "state", "slider", "robot", "metric")


def to_range(lines: Lines, span: Span) -> tuple[lsp.Position, lsp.Position]:
    a, b = lines.position(span.start), lines.position(span.end)
    return lsp.Position(*a), lsp.Position(*b)


# -- what the features share ----------------------------------------------------------------------

def encoding(ls: LabsimServer) -> str:
    """The columns' code units, as agreed with the client at initialization (UTF-16 by default)."""
    return str(ls.workspace.position_encoding or "utf-16")


class NotOpen(Exception):
    """A request about a document the editor has not opened: answered with nothing, as no file
    is read behind the editor's back."""


def document(ls: LabsimServer, uri: str) -> tuple[str, Lines]:
    if uri not in ls.workspace.text_documents:
        raise NotOpen(uri)
    text = ls.workspace.get_text_document(uri).source
    return text, Lines(text, encoding(ls))


def _outline(ls: LabsimServer, uri: str, text: str) -> Outline | None:
    """The document's outline now, or None while its YAML does not compose (or it is too large)."""
    if len(text) > MAX_BYTES:
        return None
    found = outline(text, uri_path(uri))
    if found is not None:
        ls.outlines[uri] = found
    return found


def _word_at(text: str, index: int) -> tuple[str, Span] | None:
    end = text.find("\n", index)
    for m in NAME.finditer(text, text.rfind("\n", 0, index) + 1, len(text) if end < 0 else end):
        if m.start() <= index <= m.end():
            return m.group(), Span(m.start(), m.end())
    return None


def _sensors(found: Outline | None) -> Iterator[tuple[str, language.Sensor]]:
    """(robot, sensor) for every robot of the file, in its model's order."""
    for robot in found.robots if found is not None else ():
        for sensor in language.sensors(robot.model, robot.lidar):
            yield robot.name, sensor


# -- completion ------------------------------------------------------------------------------------

KIND_ICONS = {"signal": lsp.CompletionItemKind.Variable, "param": lsp.CompletionItemKind.Constant,
              "state": lsp.CompletionItemKind.EnumMember, "function": lsp.CompletionItemKind.Function,
              "slider": lsp.CompletionItemKind.Variable, "robot": lsp.CompletionItemKind.Class,
              "metric": lsp.CompletionItemKind.Value, "action": lsp.CompletionItemKind.Method,
              "variable": lsp.CompletionItemKind.Variable, "constant": lsp.CompletionItemKind.Constant,
              "keyword": lsp.CompletionItemKind.Keyword, "aggregate": lsp.CompletionItemKind.Function,
              "sensor": lsp.CompletionItemKind.Field, "key": lsp.CompletionItemKind.Property,
              "world": lsp.CompletionItemKind.File, "model": lsp.CompletionItemKind.Class}


def _item(label: str, kind: str, detail: str, doc: str = "") -> lsp.CompletionItem:
    return lsp.CompletionItem(label=label, kind=KIND_ICONS.get(kind), detail=detail,
                              documentation=lsp.MarkupContent(lsp.MarkupKind.Markdown, doc) if doc else None)


def completion(ls: LabsimServer, uri: str, position: lsp.Position) -> lsp.CompletionList:
    text, lines = document(ls, uri)
    line = lines.line(position.line)
    before = line[:lines.index(position.line, position.character) - lines.starts[min(position.line,
                                                                                      len(lines.starts) - 1)]]
    found = _outline(ls, uri, text) or ls.outlines.get(uri)
    kind = found.kind if found is not None else kind_of_text(text)
    stripped = before.lstrip(" -")
    if ":" not in stripped and not stripped.startswith(("#", '"', "'")) and re.fullmatch(r"[A-Za-z_]*", stripped):
        keys = _schema_keys(ls, kind, lines, position.line, len(before) - len(before.lstrip(" ")))
        if keys:
            return lsp.CompletionList(is_incomplete=False, items=keys)
    key = re.match(r"\s*(?:-\s*)?([A-Za-z_]+)\s*:\s*[\w./-]*$", before)
    if key and key.group(1) == "world" and kind == "behaviour":
        return lsp.CompletionList(False, [_item(w, "world", "built-in world") for w in language.world_names()]
                                  + _world_files(uri))
    if key and key.group(1) == "model":
        return lsp.CompletionList(False, [_item(m, "model", "robot model") for m in language.model_names()])
    if kind != "behaviour":
        return lsp.CompletionList(False, [])
    if re.search(r"\bgoto\s+\w*$", before):  # only a state can follow
        return lsp.CompletionList(False, [i for i in _names(ls, found) if i.kind == KIND_ICONS["state"]])
    robot = re.search(r"\b([A-Za-z_]\w*)(?:\[[^\]]*\])?\.\w*$", before)
    if robot and found is not None and any(d.kind == "robot" for d in found.definitions.get(robot.group(1), ())):
        return lsp.CompletionList(False, _peer_values(found, robot.group(1)))  # leader.x: what it can read
    if re.search(r"\bdetected\(\s*\w*$", before):  # a distance sensor's name
        return lsp.CompletionList(False, [_item(s.name, "sensor", f"sensor of {robot}", s.doc)
                                          for robot, s in _sensors(found) if "`inf`" in s.doc])
    return lsp.CompletionList(False, _names(ls, found))


def _names(ls: LabsimServer, found: Outline | None) -> list[lsp.CompletionItem]:
    items: dict[str, lsp.CompletionItem] = {}
    for robot, sensor in _sensors(found):
        items.setdefault(sensor.name, _item(sensor.name, "sensor", f"sensor of {robot}", sensor.doc))
    for name, defs in (found.definitions.items() if found is not None else ()):
        d = defs[0]
        if d.kind != "metric":
            items.setdefault(name, _item(name, d.kind, f"{d.kind}: {d.text.splitlines()[0] if d.text else ''}"[:120],
                                         f"```\n{d.text}\n```" if d.text else ""))
    for b in ls.builtins.values():
        items.setdefault(b.name, _item(b.name, b.kind, b.signature, b.doc))
    return list(items.values())


def _peer_values(found: Outline, robot: str) -> list[lsp.CompletionItem]:
    """What a name of a robot reads (format 1.3): its pose, its state and the file's signals, last tick's."""
    pose = {"x": "its x, metres", "y": "its y, metres", "heading": "its heading, radians", "state": "its state"}
    items = [_item(name, "variable", f"{robot}.{name}", f"{doc}, as on the last tick") for name, doc in pose.items()]
    items += [_item(name, "signal", f"{robot}.{name}", f"its signal '{name}', as on the last tick")
              for name, defs in found.definitions.items() if defs[0].kind == "signal"]
    return items


def _world_files(uri: str) -> list[lsp.CompletionItem]:
    """The world files in the behaviour's folder, by the name ``world:`` gives them: each told by
    its first bytes through the one way in (a FIFO or a folder named .yaml is no world, and is
    never waited on)."""
    if not uri.startswith("file:"):
        return []
    folder = Path(uri_path(uri)).parent
    try:
        candidates = sorted(folder.glob("*.y*ml"))[:200]
    except OSError:
        return []
    return [_item(f.name, "world", "world file") for f in candidates if file_kind(f) == "world"]


def _schema_keys(ls: LabsimServer, kind: str, lines: Lines, line: int, indent: int) -> list[lsp.CompletionItem]:
    """The keys the schema allows where a key of this indent goes, under the keys above it."""
    make = ls.checkers.schema.get(kind)
    if make is None:
        return []
    chain: list[str] = []
    want = indent
    for n in range(line - 1, -1, -1):
        if want == 0:
            break
        text = lines.line(n)
        m = re.match(r"(\s*)(?:-\s+)?([A-Za-z_][\w.-]*)\s*:", text)
        if m and not text.lstrip().startswith("#") and len(m.group(1)) < want:
            chain.insert(0, m.group(2))
            want = len(m.group(1))
    node: Any = make()
    for name in chain:
        node = _child(node, name)
        if node is None:
            return []
    props = node.get("properties", {}) if isinstance(node, dict) else {}
    return [_item(name, "key", _type_words(spec.get("type", "")) if isinstance(spec, dict) else "",
                  spec.get("description", "") if isinstance(spec, dict) else "")
            for name, spec in props.items()]


def _type_words(t: object) -> str:
    """A schema's type as words: 'string or number'; a mapping is what a YAML reader calls it."""
    names = t if isinstance(t, list) else [t] if t else []
    return " or ".join({"object": "mapping", "array": "list"}.get(str(n), str(n)) for n in names)


def _child(node: Any, name: str) -> Any:
    """The schema of key ``name`` inside ``node``: a property, or any key of a mapping of names."""
    if not isinstance(node, dict):
        return None
    for option in [node, *node.get("anyOf", []), *node.get("oneOf", [])]:
        if not isinstance(option, dict):
            continue
        if name in option.get("properties", {}):
            return option["properties"][name]
        extra = option.get("additionalProperties")
        if isinstance(extra, dict):
            return extra
        items = option.get("items")
        if isinstance(items, dict):
            found = _child(items, name)
            if found is not None:
                return found
    return None


# -- hover, definition, rename -----------------------------------------------------------------------

def _at(ls: LabsimServer, uri: str, position: lsp.Position) -> tuple[str, Span, Outline | None, Lines]:
    text, lines = document(ls, uri)
    index = lines.index(position.line, position.character)
    found = _outline(ls, uri, text)
    hit = found.name_at(index) if found is not None else None
    hit = hit or _word_at(text, index)
    if hit is None:
        raise LookupError("no name here")
    return hit[0], hit[1], found or ls.outlines.get(uri), lines


def hover(ls: LabsimServer, uri: str, position: lsp.Position) -> lsp.Hover | None:
    try:
        name, span, found, lines = _at(ls, uri, position)
    except LookupError:
        return None
    parts: list[str] = []
    line_no, start_units = to_range(lines, span)[0].line, to_range(lines, span)[0].character
    line = lines.line(line_no)
    at = lines.index(line_no, start_units) - lines.starts[line_no]
    if re.fullmatch(r"\s*(?:-\s+)?", line[:at]) and re.match(r"\s*:", line[at + len(name):]):
        kind = found.kind if found is not None else kind_of_text(lines.text)
        keys = _schema_keys(ls, kind, lines, line_no, len(line) - len(line.lstrip(" ")))
        described = next((k for k in keys if k.label == name), None)
        if described is not None and described.documentation is not None and not (
                found is not None and name in found.definitions):
            doc = described.documentation
            text = doc.value if isinstance(doc, lsp.MarkupContent) else str(doc)
            parts.append(f"**key** `{name}` ({described.detail}): {text}")
    for d in (found.definitions.get(name, []) if found is not None and not parts else []):
        if d.kind == "state":
            rules = "\n".join(f"{k}. {r}" for k, r in enumerate(d.text.splitlines(), 1))
            parts.append(f"**state** `{name}`: its rules, in order\n```\n{rules}\n```")
        else:
            parts.append(f"**{d.kind}** `{name}`\n```\n{d.text}\n```")
    for robot, sensor in (_sensors(found) if not parts else ()):
        if sensor.name == name:
            parts.append(f"**sensor** of `{robot}`: {sensor.doc}")
            break
    b = ls.builtins.get(name)
    if b is not None and not parts:
        parts.append(f"**{b.kind}** `{b.signature}`\n\n{b.doc}")
    if not parts:
        return None
    start, end = to_range(lines, span)
    return lsp.Hover(lsp.MarkupContent(lsp.MarkupKind.Markdown, "\n\n".join(parts)), lsp.Range(start, end))


def definition(ls: LabsimServer, uri: str, position: lsp.Position) -> list[lsp.Location] | None:
    try:
        name, _, found, lines = _at(ls, uri, position)
    except LookupError:
        return None
    defs = [d for d in (found.definitions.get(name, []) if found is not None else []) if d.kind in DEFINED]
    return [lsp.Location(uri, lsp.Range(*to_range(lines, d.span))) for d in defs] or None


def _renameable(ls: LabsimServer, uri: str, position: lsp.Position) -> tuple[str, Span, Outline, Lines]:
    name, span, found, lines = _at(ls, uri, position)
    text = lines.text
    if found is None or _outline(ls, uri, text) is None:
        raise ValueError("the file's YAML does not parse: fix it before renaming")
    kinds = {d.kind for d in found.definitions.get(name, [])}
    if not kinds & set(RENAMEABLE):
        raise ValueError(f"'{name}' is not a signal, param, slider or state of this file")
    return name, span, found, lines


def prepare_rename(ls: LabsimServer, uri: str, position: lsp.Position) -> lsp.Range | None:
    try:
        _, span, _, lines = _renameable(ls, uri, position)
    except (LookupError, ValueError):
        return None
    return lsp.Range(*to_range(lines, span))


def rename(ls: LabsimServer, uri: str, position: lsp.Position, new: str) -> lsp.WorkspaceEdit:
    """Every declaration and use of the name in this file, renamed; an error the editor shows
    when the name is no signal, param, slider or state, or the new name cannot be one."""
    try:
        name, _, found, lines = _renameable(ls, uri, position)
    except LookupError:
        raise Refused("no name to rename here") from None
    except ValueError as e:
        raise Refused(str(e)) from None
    if not NAME.fullmatch(new):
        raise Refused(f"'{new}' is not a name: a letter or _, then letters, digits and _")
    sensor_names = {s.name for _, s in _sensors(found)}
    if new in ls.builtins or new in sensor_names:
        raise Refused(f"'{new}' is a built-in or sensor name")
    if new in found.definitions:
        raise Refused(f"'{new}' is already declared in this file")
    kinds = tuple({d.kind for d in found.definitions[name]} & set(RENAMEABLE))
    edits = [lsp.TextEdit(lsp.Range(*to_range(lines, span)), new) for span in found.occurrences(name, kinds)]
    return lsp.WorkspaceEdit(changes={uri: edits})
