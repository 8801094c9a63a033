"""Positions between labsim's diagnostics and the Language Server Protocol.

labsim counts lines and columns from 1, in characters (code points); the protocol counts both
from 0, and columns in UTF-16 code units, so a character beyond the Basic Multilingual Plane
(an emoji in a comment) is two columns to an editor. Every conversion of the server goes
through here.
"""
from __future__ import annotations

import bisect
import re


def utf16_len(text: str) -> int:
    """How many UTF-16 code units ``text`` is."""
    return len(text) + sum(1 for ch in text if ord(ch) > 0xFFFF)


def utf16_to_index(line: str, units: int) -> int:
    """The character index in ``line`` at ``units`` UTF-16 code units (clamped to the line)."""
    count = 0
    for i, ch in enumerate(line):
        if count >= units:
            return i
        count += 2 if ord(ch) > 0xFFFF else 1
    return len(line)


class Lines:
    """A document's text, to turn character indices into (line, UTF-16 column) and back."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.starts = [0] + [m.end() for m in re.finditer("\n", text)]

    def line(self, n: int) -> str:
        """Line n (0-based) without its line break; '' past the end."""
        if not 0 <= n < len(self.starts):
            return ""
        end = self.starts[n + 1] - 1 if n + 1 < len(self.starts) else len(self.text)
        return self.text[self.starts[n]:end].removesuffix("\r")

    def position(self, index: int) -> tuple[int, int]:
        """(0-based line, UTF-16 column) of a character index into the text."""
        index = max(0, min(index, len(self.text)))
        n = bisect.bisect_right(self.starts, index) - 1
        return n, utf16_len(self.text[self.starts[n]:index])

    def index(self, line: int, units: int) -> int:
        """The character index of a protocol position (clamped to the text)."""
        if line >= len(self.starts):
            return len(self.text)
        if line < 0:
            return 0
        return self.starts[line] + utf16_to_index(self.line(line), units)

    def column(self, line: int, col: int) -> int:
        """The UTF-16 column of labsim's 1-based character column ``col`` on 0-based ``line``."""
        return utf16_len(self.line(line)[:max(0, col - 1)])
