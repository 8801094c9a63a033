"""``labsim lsp``: the Language Server Protocol over stdio, with pygls.

The editor sends the text as the student types; the server answers with:

- diagnostics: ``labsim check``'s errors and warnings (the same message, hint and severity),
  checked ``DEBOUNCE_S`` after the last keystroke (at once on open and save), on the unsaved
  text, at 0-based lines and UTF-16 columns (or the units the client chose: ``positions``);
  a world file's problems are shown on the behaviour's ``world:`` line too. Text over the checker's limit
  (``MAX_BYTES``) is not checked: one diagnostic says so, as ``labsim check`` would;
- completion: the sensors of each robot's model, the file's signals, params, states, functions
  and sliders, the built-ins with their signatures, the models and worlds after ``model:`` and
  ``world:``, and the schema's keys where a key goes;
- hover, go to definition, and rename of a signal, param, slider or state (``outline``).

Checks run one at a time on a worker thread, so the server keeps reading requests while one runs;
a request that fails (a bug, a malformed position) answers nothing rather than ending the server.
The checker of each kind of file comes from the caller (``serve``): the command line hands in
the assignment reader, which belongs to the grader.
"""
from __future__ import annotations

import asyncio
import logging
import re
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar
from urllib.parse import unquote, urlparse

from lsprotocol import types as lsp
from pygls.exceptions import JsonRpcException
from pygls.lsp.server import LanguageServer
from pygls.protocol import LanguageServerProtocol

from labsim import __version__
from labsim.foundation.diagnostics import Diagnostic
from labsim.foundation.files import _size
from labsim.foundation.kinds import kind_of_text
from labsim.foundation.source import MAX_BYTES
from labsim.runtime.lsp import language
from labsim.runtime.lsp.outline import NAME, Outline, Span, outline
from labsim.runtime.lsp.positions import Lines

DEBOUNCE_S = 0.3  # after the last keystroke: a check is tens of milliseconds, typing is faster
SOURCE = "labsim"
RENAMEABLE = ("signal", "state", "param", "slider")
DEFINED = ("signal", "param", "function", "state", "slider", "robot", "metric")
log = logging.getLogger("labsim.lsp")
T = TypeVar("T")


class Refused(JsonRpcException):
    """A request the server understood and declines, with the reason the editor shows (the
    protocol's RequestFailed)."""

    CODE = -32803


class _Protocol(LanguageServerProtocol):
    """pygls's protocol, answering a request whose parameters it cannot read (a negative line,
    a missing position) with an error rather than leaving the editor waiting."""

    def structure_message(self, data: dict[str, Any]) -> Any:
        try:
            return super().structure_message(data)
        except JsonRpcException as e:
            if isinstance(data, dict) and "id" in data and "method" in data:
                self._send_response(data["id"], error=e.to_response_error())
            raise


@dataclass
class Checkers:
    """The checker and the schema of each kind of file the server knows."""

    check: dict[str, language.Checker]
    schema: dict[str, Callable[[], dict[str, Any]]]


def default_checkers() -> Checkers:
    return Checkers({"behaviour": language.check_behaviour, "world": language.check_world},
                    {"behaviour": language.behaviour_keys, "world": language.world_keys})


class LabsimServer(LanguageServer):
    def __init__(self, checkers: Checkers) -> None:
        super().__init__("labsim", __version__, protocol_cls=_Protocol)
        self.checkers = checkers
        self.pending: dict[str, asyncio.Task[None]] = {}
        self.outlines: dict[str, Outline] = {}  # the last outline of each document that composed
        self.worker = ThreadPoolExecutor(1, thread_name_prefix="labsim-check")
        self.builtins = language.builtins()


def uri_path(uri: str) -> str:
    """The file a document URI names, or the URI itself for an unsaved buffer (untitled:)."""
    parsed = urlparse(uri)
    return unquote(parsed.path) if parsed.scheme == "file" else uri


def build(checkers: Checkers | None = None) -> LabsimServer:
    server = LabsimServer(checkers or default_checkers())

    @server.feature(lsp.TEXT_DOCUMENT_DID_OPEN)
    async def did_open(ls: LabsimServer, params: lsp.DidOpenTextDocumentParams) -> None:
        await _schedule(ls, params.text_document.uri, 0.0)

    @server.feature(lsp.TEXT_DOCUMENT_DID_CHANGE)
    async def did_change(ls: LabsimServer, params: lsp.DidChangeTextDocumentParams) -> None:
        await _schedule(ls, params.text_document.uri, DEBOUNCE_S)

    @server.feature(lsp.TEXT_DOCUMENT_DID_SAVE)
    async def did_save(ls: LabsimServer, params: lsp.DidSaveTextDocumentParams) -> None:
        # a saved world file changes what the behaviours open beside it say: all are checked again
        for uri in [params.text_document.uri, *ls.workspace.text_documents]:
            if uri == params.text_document.uri or uri not in ls.pending:
                await _schedule(ls, uri, 0.0)

    @server.feature(lsp.TEXT_DOCUMENT_DID_CLOSE)
    def did_close(ls: LabsimServer, params: lsp.DidCloseTextDocumentParams) -> None:
        uri = params.text_document.uri
        task = ls.pending.pop(uri, None)
        if task is not None:
            task.cancel()
        ls.outlines.pop(uri, None)
        ls.text_document_publish_diagnostics(lsp.PublishDiagnosticsParams(uri=uri, diagnostics=[]))

    @server.feature(lsp.TEXT_DOCUMENT_COMPLETION,
                    lsp.CompletionOptions(trigger_characters=[":", " ", "(", ","]))
    def completion(ls: LabsimServer, params: lsp.CompletionParams) -> lsp.CompletionList | None:
        return _guarded(lambda: _completion(ls, params.text_document.uri, params.position))

    @server.feature(lsp.TEXT_DOCUMENT_HOVER)
    def hover(ls: LabsimServer, params: lsp.HoverParams) -> lsp.Hover | None:
        return _guarded(lambda: _hover(ls, params.text_document.uri, params.position))

    @server.feature(lsp.TEXT_DOCUMENT_DEFINITION)
    def definition(ls: LabsimServer, params: lsp.DefinitionParams) -> list[lsp.Location] | None:
        return _guarded(lambda: _definition(ls, params.text_document.uri, params.position))

    @server.feature(lsp.TEXT_DOCUMENT_PREPARE_RENAME)
    def prepare_rename(ls: LabsimServer, params: lsp.PrepareRenameParams) -> lsp.Range | None:
        return _guarded(lambda: _prepare_rename(ls, params.text_document.uri, params.position))

    @server.feature(lsp.TEXT_DOCUMENT_RENAME)
    def rename(ls: LabsimServer, params: lsp.RenameParams) -> lsp.WorkspaceEdit | None:
        return _rename(ls, params.text_document.uri, params.position, params.new_name)

    return server


class _LogLine(logging.Formatter):
    """One line a problem on stderr, the editor's log: what a client sent wrong (pygls says so)
    without pygls's traceback; a failure of labsim's own keeps its traceback, for a bug report."""

    def format(self, record: logging.LogRecord) -> str:
        if record.name.startswith("pygls"):
            record.exc_info, record.exc_text = None, None
        return super().format(record)


def serve(checkers: Checkers | None = None) -> None:
    """Answer an editor on stdin and stdout until it says exit."""
    handler = logging.StreamHandler()
    handler.setFormatter(_LogLine("labsim lsp: %(message)s"))
    logging.basicConfig(level=logging.WARNING, handlers=[handler], force=True)
    build(checkers).start_io()


def _guarded(answer: Callable[[], T]) -> T | None:
    """A request's answer, or nothing when answering it failed: the server stays up."""
    try:
        return answer()
    except Exception:  # a bug in a feature must not end the student's session
        log.exception("labsim lsp: a request failed")
        return None


# -- diagnostics ---------------------------------------------------------------------------------

async def _schedule(ls: LabsimServer, uri: str, delay: float) -> None:
    """Check the document ``delay`` seconds from now, replacing a check not yet started."""
    task = ls.pending.pop(uri, None)
    if task is not None:
        task.cancel()
    ls.pending[uri] = asyncio.get_running_loop().create_task(_check_later(ls, uri, delay))


async def _check_later(ls: LabsimServer, uri: str, delay: float) -> None:
    try:
        await asyncio.sleep(delay)
        doc = ls.workspace.get_text_document(uri)
        text, version = doc.source, doc.version
        loop = asyncio.get_running_loop()
        found = await loop.run_in_executor(ls.worker, _diagnose, ls, uri, text)
        current = ls.workspace.get_text_document(uri)
        if current.version == version:  # else a newer check is on its way
            ls.text_document_publish_diagnostics(
                lsp.PublishDiagnosticsParams(uri=uri, diagnostics=found, version=version))
    except asyncio.CancelledError:
        pass
    except Exception:
        log.exception("labsim lsp: checking %s failed", uri)
    finally:
        if ls.pending.get(uri) is asyncio.current_task():
            del ls.pending[uri]


def _diagnose(ls: LabsimServer, uri: str, text: str) -> list[lsp.Diagnostic]:
    """The document's diagnostics, as the protocol's; its outline kept for completion."""
    path = uri_path(uri)
    lines = Lines(text, _encoding(ls))
    size = len(text.encode("utf-8", "surrogatepass"))
    if size > MAX_BYTES:  # the limit `labsim check` reads a file with, in its words
        kind = "behaviour"
        message = f"file is {size / 1e6:.1f} MB; {kind} files are limited to {_size(MAX_BYTES)}"
        return [_to_lsp(Diagnostic(path, message), path, lines, None)]
    found = outline(text, path)
    if found is not None:
        ls.outlines[uri] = found
    kind = kind_of_text(text, path)
    check = ls.checkers.check.get("behaviour" if kind == "unknown" else kind)
    if check is None or (kind == "unknown" and not _looks_like_labsim(path, text)):
        return []
    return [_to_lsp(d, path, lines, found) for d in check(path, text)]


def _looks_like_labsim(path: str, text: str) -> bool:
    """A YAML file with none of labsim's keys is checked only if its first line points at a
    labsim schema: a CI workflow in the same folder gets no labsim errors."""
    first = text.lstrip("\ufeff").split("\n", 1)[0]
    return "schema.json" in first and any(k in first for k in ("behaviour", "world", "assignment"))


def _to_lsp(d: Diagnostic, path: str, lines: Lines, found: Outline | None) -> lsp.Diagnostic:
    """One of labsim's diagnostics as the protocol's. Lines and columns become 0-based, the
    columns UTF-16; a span of nothing is one character wide, as the caret under it. A problem
    in another file (the world file a behaviour names) is shown at the ``world:`` value, its
    own place at the front of the message."""
    message, line, col, end_col = d.message, d.line, d.col, d.end_col
    if d.path != path and d.line:
        message = f"{d.path}:{d.line}:{d.col}: {d.message}"
        line = col = end_col = 0
    if d.path != path and found is not None and found.world is not None:
        start, end = _range(lines, found.world[1])
        rng = lsp.Range(start, end)
    elif line:
        shift = 1 if line == 1 and lines.text.startswith("\ufeff") else 0  # the reader dropped it
        n = line - 1
        start_units = lines.column(n, col + shift)
        end_units = lines.column(n, end_col + shift) if end_col > col else start_units + 1
        rng = lsp.Range(lsp.Position(n, start_units), lsp.Position(n, max(start_units, end_units)))
    else:
        rng = lsp.Range(lsp.Position(0, 0), lsp.Position(0, 0))
    hint = "; ".join(d.notes)
    return lsp.Diagnostic(
        range=rng, message=message + "".join(f"\n= {note}" for note in d.notes),
        severity=lsp.DiagnosticSeverity.Error if d.severity == "error" else lsp.DiagnosticSeverity.Warning,
        source=SOURCE, data={"message": d.message, "hint": hint, "notes": list(d.notes), "file": d.path,
                             "line": d.line, "column": d.col})


def _range(lines: Lines, span: Span) -> tuple[lsp.Position, lsp.Position]:
    a, b = lines.position(span.start), lines.position(span.end)
    return lsp.Position(*a), lsp.Position(*b)


# -- what the features share ----------------------------------------------------------------------

def _encoding(ls: LabsimServer) -> str:
    """The columns' code units, as agreed with the client at initialization (UTF-16 by default)."""
    return str(ls.workspace.position_encoding or "utf-16")


def _document(ls: LabsimServer, uri: str) -> tuple[str, Lines]:
    text = ls.workspace.get_text_document(uri).source
    return text, Lines(text, _encoding(ls))


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


def _completion(ls: LabsimServer, uri: str, position: lsp.Position) -> lsp.CompletionList:
    text, lines = _document(ls, uri)
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


def _world_files(uri: str) -> list[lsp.CompletionItem]:
    """The world files in the behaviour's folder, by the name ``world:`` gives them."""
    folder = Path(uri_path(uri)).parent
    out = []
    try:
        candidates = sorted(folder.glob("*.y*ml"))[:200]
    except OSError:
        return []
    for f in candidates:
        try:
            head = f.read_text("utf-8", "replace")[:4096] if f.stat().st_size < MAX_BYTES else ""
        except OSError:
            continue
        if kind_of_text(head) == "world":
            out.append(_item(f.name, "world", "world file"))
    return out


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
    text, lines = _document(ls, uri)
    index = lines.index(position.line, position.character)
    found = _outline(ls, uri, text)
    hit = found.name_at(index) if found is not None else None
    hit = hit or _word_at(text, index)
    if hit is None:
        raise LookupError("no name here")
    return hit[0], hit[1], found or ls.outlines.get(uri), lines


def _hover(ls: LabsimServer, uri: str, position: lsp.Position) -> lsp.Hover | None:
    try:
        name, span, found, lines = _at(ls, uri, position)
    except LookupError:
        return None
    parts: list[str] = []
    line_no, start_units = _range(lines, span)[0].line, _range(lines, span)[0].character
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
    start, end = _range(lines, span)
    return lsp.Hover(lsp.MarkupContent(lsp.MarkupKind.Markdown, "\n\n".join(parts)), lsp.Range(start, end))


def _definition(ls: LabsimServer, uri: str, position: lsp.Position) -> list[lsp.Location] | None:
    try:
        name, _, found, lines = _at(ls, uri, position)
    except LookupError:
        return None
    defs = [d for d in (found.definitions.get(name, []) if found is not None else []) if d.kind in DEFINED]
    return [lsp.Location(uri, lsp.Range(*_range(lines, d.span))) for d in defs] or None


def _renameable(ls: LabsimServer, uri: str, position: lsp.Position) -> tuple[str, Span, Outline, Lines]:
    name, span, found, lines = _at(ls, uri, position)
    text = lines.text
    if found is None or _outline(ls, uri, text) is None:
        raise ValueError("the file's YAML does not parse: fix it before renaming")
    kinds = {d.kind for d in found.definitions.get(name, [])}
    if not kinds & set(RENAMEABLE):
        raise ValueError(f"'{name}' is not a signal, param, slider or state of this file")
    return name, span, found, lines


def _prepare_rename(ls: LabsimServer, uri: str, position: lsp.Position) -> lsp.Range | None:
    try:
        _, span, _, lines = _renameable(ls, uri, position)
    except (LookupError, ValueError):
        return None
    return lsp.Range(*_range(lines, span))


def _rename(ls: LabsimServer, uri: str, position: lsp.Position, new: str) -> lsp.WorkspaceEdit:
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
    edits = [lsp.TextEdit(lsp.Range(*_range(lines, span)), new) for span in found.occurrences(name, kinds)]
    return lsp.WorkspaceEdit(changes={uri: edits})
