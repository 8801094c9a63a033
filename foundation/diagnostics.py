"""User-facing diagnostics: one format for every mistake a user can make.

Every stage (YAML loading, parsing, checking, world files, ``--set``) reports problems as
``Diagnostic`` values in the gcc style editors can jump to::

    behaviours/wall.yaml:14:12: error: unknown name 'sonr5' (did you mean 'sonar5'?)
       14 |   - if sonr5 <= front then arc(-2, 2)
          |        ^~~~~

Stages collect diagnostics in a ``Report`` so that all problems of a file are shown at once;
``LabsimError`` carries them to the command line, which prints them and exits with code 2.
Internal errors (bugs in labsim) are ordinary Python exceptions and never use this module.
"""
from __future__ import annotations

import difflib
from collections.abc import Iterable
from dataclasses import dataclass, field

from labsim.foundation.inert import Inert, inert


@dataclass(frozen=True)
class Diagnostic:
    path: str
    message: str
    line: int = 0  # 1-based; 0 when the problem has no position (a missing file, a --set)
    col: int = 0  # 1-based
    end_col: int = 0  # exclusive, same line; 0 for a single caret
    severity: str = "error"
    source_line: str = ""
    notes: tuple[str, ...] = ()

    def format(self) -> str:
        """The diagnostic as printed, every piece of file text in it inert (foundation/inert.py)."""
        where = f"{self.path}:{self.line}:{self.col}" if self.line else self.path
        out = [f"{inert(where)}: {self.severity}: {inert(self.message)}"]
        if self.line and self.source_line:
            gutter = f"{self.line:>5} | "
            raw = self.source_line.rstrip("\n").replace("\t", " ")
            # the caret's columns move with the escapes before and inside its span
            start = len(inert(raw[:self.col - 1])) + 1
            end = len(inert(raw[:self.end_col - 1])) + 1 if self.end_col > self.col else start + 1
            text, col = _window(inert(raw), start)
            width = min(max(1, end - start), max(1, len(text) - col + 2))
            out.append(gutter + text)
            out.append(" " * (len(gutter) - 2) + "| " + " " * (col - 1) + "^" + "~" * (width - 1))
        out.extend(f"      = {inert(note)}" for note in self.notes)
        return Inert("\n".join(out))  # its lines are labsim's; the file's text in them is inert


# At most this many columns of a source line are echoed, around the caret: a minified file's
# one long line is not printed whole under every mistake in it.
ECHO_COLUMNS = 200
# At most this many diagnostics are printed per file, then "... and K more": a file of 9000
# mistakes says so in a screenful. (LabsimError keeps them all, for tools.)
MAX_PER_FILE = 20


def _window(text: str, col: int) -> tuple[str, int]:
    """At most ECHO_COLUMNS of text around 1-based column col, marked '...' where cut, and
    the caret's column in what is shown."""
    if len(text) <= ECHO_COLUMNS:
        return text, col
    start = max(0, min(col - 1 - ECHO_COLUMNS // 2, len(text) - ECHO_COLUMNS))
    shown = text[start:start + ECHO_COLUMNS]
    head = "..." if start > 0 else ""
    tail = "..." if start + ECHO_COLUMNS < len(text) else ""
    return head + shown + tail, col - start + len(head)


def format_diagnostics(diagnostics: Iterable[Diagnostic], per_file: int = MAX_PER_FILE) -> list[str]:
    """Each diagnostic formatted, at most ``per_file`` a file, then one line for the rest."""
    out: list[str] = []
    shown: dict[str, int] = {}
    left: dict[str, int] = {}
    for d in diagnostics:
        if shown.get(d.path, 0) < per_file:
            shown[d.path] = shown.get(d.path, 0) + 1
            out.append(d.format())
        else:
            left[d.path] = left.get(d.path, 0) + 1
    out.extend(f"{inert(path)}: ... and {n} more (the first {per_file} are shown)" for path, n in left.items())
    return out


def diagnostic_dict(d: Diagnostic) -> dict[str, object]:
    """One diagnostic as plain data (``labsim check --json``, the grader's pages): every field, and
    its notes joined as the hint. Line and column are 1-based, 0 when it has no position; the
    text is as the file holds it (JSON escapes it; a page escapes it again)."""
    return {"file": d.path, "line": d.line, "column": d.col, "end_column": d.end_col, "severity": d.severity,
            "message": d.message, "hint": "; ".join(d.notes), "notes": list(d.notes), "source_line": d.source_line}


def diagnostics_json(files: Iterable[str], diagnostics: Iterable[Diagnostic]) -> dict[str, object]:
    """What ``labsim check --json`` prints: each file with its error and warning counts, then
    every diagnostic (none cut: ``MAX_PER_FILE`` is for terminals)."""
    found = [diagnostic_dict(d) for d in diagnostics]
    per_file = [{"file": f, "errors": sum(d["file"] == f and d["severity"] == "error" for d in found),
                 "warnings": sum(d["file"] == f and d["severity"] == "warning" for d in found)} for f in files]
    return {"format": "labsim-check/1", "files": per_file, "diagnostics": found}


class LabsimError(Exception):
    """A user's mistake, with every diagnostic found; the CLI prints them and exits 2."""

    def __init__(self, diagnostics: Iterable[Diagnostic]):
        self.diagnostics = list(diagnostics)
        super().__init__("\n".join(format_diagnostics(self.diagnostics)))


@dataclass
class Report:
    """Collects the diagnostics of one stage run so they can be reported together."""

    diagnostics: list[Diagnostic] = field(default_factory=list)

    def add(self, diagnostic: Diagnostic) -> None:
        self.diagnostics.append(diagnostic)

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.severity == "error"]

    def raise_if_errors(self) -> None:
        if self.errors:
            raise LabsimError(sorted(self.diagnostics, key=lambda d: (d.path, d.line, d.col)))


def did_you_mean(word: str, candidates: Iterable[str]) -> str:
    """' (did you mean 'x'?)' for the closest candidate, or '' when nothing is close."""
    matches = difflib.get_close_matches(word, list(candidates), n=1, cutoff=0.6)
    return f" (did you mean {quoted(matches[0])}?)" if matches else ""


def quoted(token: str) -> str:
    """A name as a message quotes it: a long one by its first 30 characters and its length
    (docs/language.md, "Mistakes"), so that a 5,000-character name does not fill the screen."""
    return f"'{token}'" if len(token) <= 40 else f"'{token[:30]}...' ({len(token):,} characters)"


def listed(names: Iterable[str]) -> str:
    """Names as a message's list gives them, 'a, b, c': a long one as ``quoted`` gives it."""
    return ", ".join(n if len(n) <= 40 else quoted(n) for n in names)
