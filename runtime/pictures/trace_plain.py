"""A plain trace's rows split without the csv module, only as far as the columns a picture reads.

A step of reading a trace for a picture (``labsim.runtime.pictures.trace_sample``): the csv module
makes a string of every cell, 1.6 million of them for the wall lab's hour, where an animation
reads ten columns. A trace as a run writes it is plain: no quotes, carriage returns or NULs, no
blank lines, every line a row with one comma fewer than the columns. Its lines are split with
``str.split`` up to the last column read (all before it come along: a split cannot skip them), and
the last column (``events``) is taken from the rest of the line. For these lines the cells are
those the csv module gives. A batch that is not plain (a quote, a blank line, a row of another
length, a line near the csv module's field limit) raises ``NotPlain``, and the caller reads the
file again with the csv module, whose rows, lines and messages stay the reference.
"""
from __future__ import annotations

import collections
import csv
import itertools
import operator
from collections.abc import Iterable

_REST, _AFTER = operator.itemgetter(-1), operator.itemgetter(2)


class NotPlain(Exception):
    """Lines the plain split would not read as the csv module does."""


def narrow(columns: list[str], wanted: Iterable[str]) -> tuple[list[str], int]:
    """The columns read: every one up to the last wanted one, and the last column; and how many
    come before the last."""
    names = set(wanted)
    upto = max((i + 1 for i, c in enumerate(columns[:-1]) if c in names), default=0)
    return columns[:upto] + columns[-1:], upto


def plain_rows(blocks: Iterable[str], fields: int, upto: int, first_line: int) -> tuple[list[list[str]], list[int]]:
    """The rows of these blocks of whole lines (each ending in a newline but perhaps the file's
    last), cut to ``narrow``'s columns, and each row's line in the file (the first is
    ``first_line``). A last line without a newline and with too few fields is a row a killed run
    left half written: dropped, as ``read_trace`` drops it."""
    rows: list[list[str]] = []
    lines: list[int] = []
    limit = csv.field_size_limit()
    line = first_line
    for text in blocks:
        if '"' in text or "\r" in text or "\0" in text:
            raise NotPlain
        parts = text.split("\n")
        ends = not parts[-1]
        if ends:
            parts.pop()  # the "" after the last newline
        count = len(parts)
        if not ends and parts[-1].count(",") < fields - 1:
            parts.pop()  # the half-written row
        if parts and (not all(parts) or max(map(len, parts)) >= limit
                      or set(map(str.count, parts, itertools.repeat(","))) != {fields - 1}):
            raise NotPlain
        if upto + 1 >= fields:
            got = list(map(str.split, parts, itertools.repeat(",")))
        else:  # the rest of each line holds the columns not read, then the last one: that one only
            got = list(map(str.split, parts, itertools.repeat(","), itertools.repeat(upto)))
            last = map(_AFTER, map(str.rpartition, map(_REST, got), itertools.repeat(",")))
            collections.deque(map(operator.setitem, got, itertools.repeat(-1), last), maxlen=0)  # in C
        rows += got
        lines += range(line, line + len(parts))
        line += count
    return rows, lines
