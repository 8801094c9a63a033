"""Positions between labsim's diagnostics and the Language Server Protocol.

labsim counts lines and columns from 1, in characters (code points); the protocol counts both
from 0, and columns in the code units the client and server agreed on at initialization:
UTF-16 unless the client offers another (Neovim prefers UTF-8), so a character beyond the
Basic Multilingual Plane (an emoji in a comment) is two UTF-16 columns to VS Code and four
UTF-8 columns to Neovim. Every conversion of the server goes through here.
"""
from __future__ import annotations

import bisect
import re
from collections.abc import Callable

UTF16, UTF8, UTF32 = "utf-16", "utf-8", "utf-32"


def _utf16_width(ch: str) -> int:
    return 2 if ord(ch) > 0xFFFF else 1


def _utf8_width(ch: str) -> int:
    n = ord(ch)
    return 1 if n < 0x80 else 2 if n < 0x800 else 3 if n < 0x10000 else 4


_WIDTHS: dict[str, Callable[[str], int]] = {UTF16: _utf16_width, UTF8: _utf8_width, UTF32: lambda ch: 1}


def units(text: str, encoding: str = UTF16) -> int:
    """How many code units of ``encoding`` ``text`` is."""
    if text.isascii() or encoding == UTF32:
        return len(text)
    width = _WIDTHS.get(encoding, _utf16_width)
    return sum(width(ch) for ch in text)


def utf16_len(text: str) -> int:
    return units(text, UTF16)


def units_to_index(line: str, count: int, encoding: str = UTF16) -> int:
    """The character index in ``line`` at ``count`` code units (clamped to the line)."""
    width = _WIDTHS.get(encoding, _utf16_width)
    seen = 0
    for i, ch in enumerate(line):
        if seen >= count:
            return i
        seen += width(ch)
    return len(line)


class Lines:
    """A document's text, to turn character indices into (line, column in code units) and back."""

    def __init__(self, text: str, encoding: str = UTF16) -> None:
        self.text = text
        self.encoding = encoding if encoding in _WIDTHS else UTF16
        self.starts = [0] + [m.end() for m in re.finditer("\n", text)]

    def line(self, n: int) -> str:
        """Line n (0-based) without its line break; '' past the end."""
        if not 0 <= n < len(self.starts):
            return ""
        end = self.starts[n + 1] - 1 if n + 1 < len(self.starts) else len(self.text)
        return self.text[self.starts[n]:end].removesuffix("\r")

    def position(self, index: int) -> tuple[int, int]:
        """(0-based line, column in code units) of a character index into the text."""
        index = max(0, min(index, len(self.text)))
        n = bisect.bisect_right(self.starts, index) - 1
        return n, units(self.text[self.starts[n]:index], self.encoding)

    def index(self, line: int, column: int) -> int:
        """The character index of a protocol position (clamped to the text)."""
        if line >= len(self.starts):
            return len(self.text)
        if line < 0:
            return 0
        return self.starts[line] + units_to_index(self.line(line), column, self.encoding)

    def column(self, line: int, col: int) -> int:
        """The protocol's column of labsim's 1-based character column ``col`` on 0-based ``line``."""
        return units(self.line(line)[:max(0, col - 1)], self.encoding)
