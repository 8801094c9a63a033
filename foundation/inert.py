"""Text from a file made inert before it reaches a terminal or a spreadsheet.

A behaviour file is written by a student and run by a teacher: its ``name:``, its ``log(...)``
and label texts, the names a diagnostic quotes and the source line it echoes all end on the
teacher's terminal. Every sink that prints such text (``Diagnostic.format``, the run's summary,
log lines during a run, the sweep's table) passes it through ``inert``, which shows control
characters and bidirectional overrides as escapes (``\\x1b``, ``\\u202e``) instead of letting
the terminal obey them: no clearing the screen, hiding rows, retitling the window or setting
the clipboard (OSC 52). ``spreadsheet_cell`` does the same for a CSV cell and also keeps a
text cell from being read as a formula. docs/security.md, "What is shown".
"""
from __future__ import annotations

import re

# C0 controls but tab, DEL, C1 controls, and the Unicode bidi embeddings, overrides and isolates
# (U+202A-202E, U+2066-2069), which reorder what a line shows ("Trojan Source"). Tab stays: a
# terminal only moves the cursor right for it, and a log that aligns with tabs reads as meant.
_UNSAFE = re.compile("[\x00-\x08\x0a-\x1f\x7f-\x9f\u202a-\u202e\u2066-\u2069]")

# A spreadsheet reads a cell starting with one of these as a formula (=HYPERLINK, =cmd|...).
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def _escape(code: int) -> str:
    return f"\\x{code:02x}" if code <= 0xFF else f"\\u{code:04x}"


# every character _UNSAFE matches, mapped to its escape: ``str.translate`` swaps them in C, where
# ``_UNSAFE.sub`` with a Python callback cost a call a character (a log of 600 overrides, 500
# times a tick, spent most of its run there)
_ESCAPES = {code: _escape(code) for code in range(0x2070) if _UNSAFE.match(chr(code))}


class Inert(str):
    """Text already made inert, piece by piece, whose own line breaks are meant: a formatted
    diagnostic (``Diagnostic.format``). ``inert`` gives it back as it is, so a runtime warning
    printed through a sink that makes everything inert shows its lines, not ``\\x0a``."""

    __slots__ = ()


def inert(text: str) -> str:
    """``text`` with every control character (but tab) and bidi override shown as an escape.

    Text without them comes back unchanged (the same object), so a normal name, log or source
    line prints as before; a backslash is left alone, so ``\\x1b`` typed by a student and an
    escaped ESC look the same, which is harmless on a terminal.
    """
    if isinstance(text, Inert) or _UNSAFE.search(text) is None:
        return text
    return text.translate(_ESCAPES)


def spreadsheet_cell(value: object) -> object:
    """A CSV cell: text made inert and, when it would start a formula, led by ``'``; numbers
    (and text that reads as one, such as ``-0.5``) as they are."""
    if not isinstance(value, str):
        return value
    text = inert(value)
    if text.startswith(_FORMULA_START) and not _is_number(text):
        return "'" + text
    return text


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


__all__ = ["inert", "spreadsheet_cell"]
