"""foundation/inert.py and the diagnostic's caret over escaped text: what each character becomes."""
from __future__ import annotations

import pytest

from labsim.foundation.diagnostics import Diagnostic
from labsim.foundation.inert import inert, spreadsheet_cell


@pytest.mark.parametrize(("text", "shown"), [
    ("plain text, C:\\path\\x1b and é", "plain text, C:\\path\\x1b and é"),  # unchanged, backslash too
    ("tab\tstays", "tab\tstays"),
    ("\x1b[2J\x1b]52;c;aGk=\x07", "\\x1b[2J\\x1b]52;c;aGk=\\x07"),
    ("a\nb\rc\x00\x7f", "a\\x0ab\\x0dc\\x00\\x7f"),
    ("\x9b31m \x85", "\\x9b31m \\x85"),  # C1: CSI and NEL
    ("\u202aa\u202e\u2066b\u2069", "\\u202aa\\u202e\\u2066b\\u2069"),
    ("\u200e\u2028", "\u200e\u2028"),  # a mark and a separator reorder nothing; left alone
])
def test_inert(text: str, shown: str) -> None:
    assert inert(text) == shown
    assert inert(inert(text)) == inert(text)


@pytest.mark.parametrize(("value", "cell"), [
    ("=HYPERLINK(\"x\")", "'=HYPERLINK(\"x\")"),
    ("+cmd|' /C calc'!A0", "'+cmd|' /C calc'!A0"),
    ("-2+3", "'-2+3"),
    ("@SUM(A1)", "'@SUM(A1)"),
    ("-0.5", "-0.5"),  # text that is a number stays one
    ("1e5", "1e5"),
    (-3, -3),
    (2.5, 2.5),
    ("wall\x1b[2J", "wall\\x1b[2J"),
    ("=\x1b", "'=\\x1b"),
])
def test_spreadsheet_cell(value: object, cell: object) -> None:
    assert spreadsheet_cell(value) == cell


def test_the_caret_stays_under_the_span_after_escapes() -> None:
    line = "x \u202e\x1b = nosuch + 1"
    col = line.index("nosuch") + 1
    text = Diagnostic("b.yaml", "unknown name 'nosuch'", 3, col, col + 6, source_line=line).format()
    shown, caret = text.splitlines()[1:]
    at = caret.index("^")
    assert shown[at:at + 6] == "nosuch" and caret[at:] == "^~~~~~"
    escaped = Diagnostic("b.yaml", "unexpected character", 3, 3, 4, source_line=line).format().splitlines()
    at = escaped[2].index("^")
    assert escaped[1][at:at + 6] == "\\u202e" and escaped[2][at:] == "^~~~~~"
