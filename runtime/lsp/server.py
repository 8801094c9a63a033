"""``labsim lsp``: the Language Server Protocol over stdio, with pygls.

The editor sends the text as the student types; the server answers with:

- diagnostics: ``labsim check``'s errors and warnings (the same message, hint and severity),
  checked ``DEBOUNCE_S`` after the last keystroke (at once on open and save), on the unsaved
  text, at 0-based lines and UTF-16 columns (or the units the client chose: ``positions``);
  a world file's problems are shown on the behaviour's ``world:`` line too. Text over the
  checker's limit (``MAX_BYTES``) is not checked: one diagnostic says so, as ``labsim check``;
- completion, hover, go to definition, and rename of a signal, param, slider or state
  (``labsim.runtime.lsp.features``).

Checks run one at a time on a worker thread, so the server keeps reading requests while one runs;
a request that fails (a bug, a malformed position) answers nothing rather than ending the server.
The checker of each kind of file comes from the caller (``serve``): the command line hands in
the assignment reader, which belongs to the grader.
"""
from __future__ import annotations

import asyncio
import logging
from collections.abc import Callable
from typing import TypeVar

from lsprotocol import types as lsp

from labsim.foundation.diagnostics import Diagnostic
from labsim.foundation.files import _size
from labsim.foundation.kinds import kind_of_text
from labsim.foundation.source import MAX_BYTES
from labsim.runtime.lsp import features
from labsim.runtime.lsp.outline import Outline, outline
from labsim.runtime.lsp.positions import Lines
from labsim.runtime.lsp.session import Checkers, LabsimServer, default_checkers, uri_path

DEBOUNCE_S = 0.3  # after the last keystroke: a check is tens of milliseconds, typing is faster
SOURCE = "labsim"
log = logging.getLogger("labsim.lsp")
T = TypeVar("T")


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
        return _guarded(lambda: features.completion(ls, params.text_document.uri, params.position))

    @server.feature(lsp.TEXT_DOCUMENT_HOVER)
    def hover(ls: LabsimServer, params: lsp.HoverParams) -> lsp.Hover | None:
        return _guarded(lambda: features.hover(ls, params.text_document.uri, params.position))

    @server.feature(lsp.TEXT_DOCUMENT_DEFINITION)
    def definition(ls: LabsimServer, params: lsp.DefinitionParams) -> list[lsp.Location] | None:
        return _guarded(lambda: features.definition(ls, params.text_document.uri, params.position))

    @server.feature(lsp.TEXT_DOCUMENT_PREPARE_RENAME)
    def prepare_rename(ls: LabsimServer, params: lsp.PrepareRenameParams) -> lsp.Range | None:
        return _guarded(lambda: features.prepare_rename(ls, params.text_document.uri, params.position))

    @server.feature(lsp.TEXT_DOCUMENT_RENAME)
    def rename(ls: LabsimServer, params: lsp.RenameParams) -> lsp.WorkspaceEdit | None:
        return features.rename(ls, params.text_document.uri, params.position, params.new_name)

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
    except features.NotOpen:  # asked about a file the editor has not opened: nothing to say
        return None
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
    lines = Lines(text, features.encoding(ls))
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
        start, end = features.to_range(lines, found.world[1])
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
