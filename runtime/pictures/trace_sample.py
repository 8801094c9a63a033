"""A trace read for a picture in bounded memory: its rows streamed from the file, a long one thinned.

The first step of ``labsim plot`` (``labsim.runtime.pictures.driver``). ``labsim.runtime.trace``'s
``read_trace`` holds the whole file and every row as text, some sixteen times the file's size: a
picture of a 1 GiB trace would need about 18 GB. Here the file is read a few megabytes at a time
(``labsim.foundation.files.read_chunks``), every row is checked as ``read_trace`` checks it, and
at most about ``MAX_KEPT`` bytes of rows are kept: when the trace holds more, each robot keeps every
k-th of its rows, its last one, and every row where something happens that a picture marks
(an event or a slider move, the start of a collision, a new state), up to as many again. A
picture of a trace that fits (the labs' 25-minute runs hold about a million cells) is drawn from
every row, as before; a thinned one says so on stderr. Memory is then bounded by ``MAX_KEPT``
whatever the file's size: within twice that for rows as a run writes them, and past it (a file
made to defeat the estimate, with long cells on the rows kept) the kept rows' long cells are
cut short, so that a few times ``MAX_KEPT`` is the worst (docs/pictures.md gives the figures).
"""
from __future__ import annotations

import codecs
import contextlib
import csv
import gc
import itertools
import math
import operator
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.files import read_chunks, read_head
from labsim.runtime.pictures.trace_plain import NotPlain, narrow, plain_rows
from labsim.runtime.trace import (
    FOOTER,
    MAGIC,
    Trace,
    TraceFormatError,
    check_rows,
    footer_of,
    parse_header,
    read_columns,
)

MAX_KEPT = 128 * 1024 * 1024  # bytes of kept rows as Python holds them (an estimate, ``_cost``)
CELL_BYTES = 57  # a short str and its place in the row's list
LONG_CELL = 64  # past twice MAX_KEPT, a kept row's longer cells are cut to this many characters
BATCH = 20_000  # rows checked at a time
CHECKED = ("tick", "time", "x", "y", "heading")  # the columns ``check_rows`` reads: always read
Wanted = Callable[[str, dict, list[str]], "list[str] | None"]  # (path, header, columns) -> names


@dataclass
class _Lines:
    """The file's lines after the header, the footer held back; what the last line was."""

    path: str
    chunks: Iterator[bytes]
    header: str = ""
    footer: str = ""
    newline_at_end: bool = True
    _rest: list[str] = field(default_factory=list)

    def first(self) -> str:
        """The header line (and the file's start, for a message when it is no trace)."""
        it = self._all()
        block, footer_in = next(it, ("", False))
        while not block:  # a first chunk without a whole line: the header is longer than a chunk
            more = next(it, None)
            if more is None:
                break
            block, footer_in = more
        head, newline, rest = block.partition("\n")
        self.header = head + newline
        self._it = itertools.chain([(rest, footer_in)], it)
        return self.header

    def blocks(self) -> Iterator[str]:
        """The lines after the header, whole lines a chunk at a time, the footer held back
        (``self.footer``)."""
        held = ""
        for block, footer_in in self._it:
            if not held and not footer_in:  # most chunks: no line to look at one by one
                yield block
                continue
            out = []
            for line in lines_of(block):
                if line.startswith(FOOTER):  # the footer, if nothing but blank lines follows it
                    if held:
                        out.append(held)
                    held = line
                    continue
                if held and line.strip():
                    out.append(held)
                    held = ""
                out.append(line)
            yield "".join(out)
        self.footer = held

    def _all(self) -> Iterator[tuple[str, bool]]:
        """The file's text a chunk at a time, cut after a newline (but for the file's last line), and
        whether a line in it may be the footer."""
        decoder = codecs.getincrementaldecoder("utf-8")()
        tail = ""
        done = 0
        try:
            for chunk in self.chunks:
                text = tail + decoder.decode(chunk)
                done += len(chunk)
                cut = text.rfind("\n") + 1
                tail = text[cut:]
                yield text[:cut], FOOTER in text
            tail += decoder.decode(b"", final=True)
        except UnicodeDecodeError as e:
            raise TraceFormatError(f"{self.path}: not UTF-8 text (byte {done + e.start}): not a labsim trace",
                                   self.path) from None
        self.newline_at_end = not tail
        if tail:
            yield tail, FOOTER in tail


def lines_of(block: str) -> list[str]:
    """A block's lines, each with its newline (the file's last line may have none)."""
    lines = block.split("\n")
    last = lines.pop()
    return [line + "\n" for line in lines] + ([last] if last else [])


def count_lines(path: str) -> tuple[int, int]:
    """The file's lines and bytes, counted without keeping them."""
    lines = size = 0
    for chunk in read_chunks(path, "trace"):
        lines += chunk.count(b"\n")
        size += len(chunk)
    return lines + 1, size


def read_for_picture(path: str, max_kept: int = MAX_KEPT, wanted: Wanted | None = None) -> tuple[Trace, str]:
    """The trace, thinned to about ``max_kept`` bytes of rows when it holds more, and a note
    saying how it was thinned ('' when it was not). Errors are ``read_trace``'s. ``wanted``, given
    the path, the header and the columns, names the columns the picture reads (None: all); a trace that is
    not thinned is then read only as far as those (``labsim.runtime.pictures.trace_plain``), and
    its ``columns`` are the ones read, in the file's order."""
    try:
        with _no_gc():
            return _read(path, max_kept, wanted)
    except LabsimError as e:
        raise TraceFormatError(f"{path}: {e.diagnostics[0].message}", str(path), notes=e.diagnostics[0].notes) from None


@contextlib.contextmanager
def _no_gc() -> Iterator[None]:
    """The cyclic garbage collector off while the rows are made: every row is a new list, and the
    collector walked all those read so far again and again (a fifth of reading an hour's trace);
    lists of strings make no cycles for it to find."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def _read(path: str, max_kept: int, wanted: Wanted | None) -> tuple[Trace, str]:
    lines = _Lines(path, read_chunks(path, "trace"))
    first = lines.first()
    # what else the file is, when it is no trace, is told from its start
    start = first if first.startswith(MAGIC) else read_head(path, 4096, "trace").decode("utf-8", "replace")
    header = parse_header(path, first.rstrip("\n"), start)
    cursor = _Cursor(lines.blocks())
    columns = read_columns(path, csv.reader(cursor))
    lines_in, size = count_lines(path)
    every = max(1, math.ceil((size + max(lines_in - 2, 1) * (len(columns) * CELL_BYTES + 64)) / max_kept))
    names = wanted(path, header, columns) if wanted is not None and every == 1 else None
    if names is not None:
        try:
            return _read_plain(path, header, lines, cursor, columns, names), ""
        except (NotPlain, TraceFormatError):  # read again by the csv module: its rows, or its message
            return _read(path, max_kept, None)
    reader = csv.reader(itertools.chain.from_iterable(map(lines_of, cursor.rest())))
    keep = _Keep(columns, every, max_kept)
    try:
        batch, at = _rows_by_batch(path, reader, keep, cursor.taken)
    except csv.Error as e:
        line = cursor.taken + reader.line_num + 1
        raise TraceFormatError(f"{path}:{line}: damaged row: {e}", path, line) from None
    if batch and len(batch[-1]) < len(columns) and not lines.newline_at_end:
        batch.pop()  # a run killed mid-write leaves half a line: the ticks before it still stand
        at.pop()
    keep.add(path, batch, at)
    rows, where = keep.rows()
    _, footer = footer_of(lines.footer or "\n")
    trace = Trace(path, header, columns, rows, footer, where, numbers=_numbers(columns, rows))
    if every == 1:
        return trace, ""
    return trace, (f"{keep.seen:,} rows are more than a picture keeps in memory ({max_kept // 2 ** 20} MiB): "
                   f"drawn from {len(rows):,} of them (one in {every} of each robot's, and every row with an event, "
                   "a collision or a new state)")


def _read_plain(path: str, header: dict, lines: _Lines, cursor: _Cursor, columns: list[str],
                wanted: list[str]) -> Trace:
    """The rows cut to the wanted columns (``trace_plain``), checked as ``read_trace`` checks them."""
    names, upto = narrow(columns, [*wanted, *CHECKED])
    rows, at = plain_rows(cursor.rest(), len(columns), upto, cursor.taken + 2)
    numbers = _numbers(names, rows)
    # a number column converted (by float(), as check_rows reads it) needs no check of its own
    if not (_ticks_ok(names, rows) and all(c in numbers for c in CHECKED[1:] if c in names)):
        check_rows(path, names, rows, at)
    _, footer = footer_of(lines.footer or "\n")
    return Trace(path, header, names, rows, footer, at, numbers=numbers)


def _ticks_ok(columns: list[str], rows: list[list[str]]) -> bool:
    """Every tick cell is a whole number, as ``check_rows`` has it: digits, none empty."""
    if "tick" not in columns:
        return True
    cells = list(map(operator.itemgetter(columns.index("tick")), rows))
    joined = "".join(cells)
    return all(cells) and joined.isascii() and (joined.isdigit() or not joined)


class _Cursor:
    """The lines after the header: one at a time for the csv module to read the column line, then
    the rest a block at a time; ``taken``: the lines given one at a time."""

    def __init__(self, blocks: Iterator[str]):
        self._blocks = blocks
        self._lines: list[str] = []
        self._at = 0
        self.taken = 0

    def __iter__(self) -> _Cursor:
        return self

    def __next__(self) -> str:
        while self._at == len(self._lines):
            self._lines, self._at = lines_of(next(self._blocks)), 0
        self._at += 1
        self.taken += 1
        return self._lines[self._at - 1]

    def rest(self) -> Iterator[str]:
        """The text not given yet, whole lines a block at a time."""
        yield "".join(self._lines[self._at:])
        yield from self._blocks


Rows = tuple[list[list[str]], list[int]]


class CsvReader(Protocol):
    """What ``csv.reader`` gives: rows, and the lines read so far."""

    line_num: int

    def __iter__(self) -> Iterator[list[str]]: ...

    def __next__(self) -> list[str]: ...


def _rows_by_batch(path: str, reader: CsvReader, keep: _Keep, before: int) -> Rows:
    """The rows given to ``keep`` a batch at a time, each with its line in the file (``before``:
    the lines after the header the reader did not see); the last batch is returned, not given (a
    half-written last row may have to go first). The rows are
    taken from the reader in C (``islice``) and their lines counted after, instead of a Python
    step per row, which was half of reading an hour-long trace: a row ends as many lines after
    the one before as the newlines in its quoted cells, plus one (blank lines give no row)."""
    batch: list[list[str]] = []
    at: list[int] = []
    while True:
        start = before + reader.line_num
        got = list(itertools.islice(reader, BATCH - len(batch)))
        if not got:
            return batch, at
        if before + reader.line_num - start == len(got) and all(got):  # each row one line: most files
            batch += got
            at += range(start + 2, start + 2 + len(got))
        else:
            ends = itertools.accumulate(1 + sum(c.count("\n") for c in r) for r in got)
            for r, end in zip(got, ends):
                if r:
                    batch.append(r)
                    at.append(start + 1 + end)
        if len(batch) >= BATCH:
            keep.add(path, batch, at)
            batch, at = [], []


def _numbers(columns: list[str], rows: list[list[str]]) -> dict[str, np.ndarray]:
    """The pose, time and collision columns as floats, converted once here for every picture that
    reads them (``Trace.numbers``): the map and the animation each converted them again, a few
    tenths of a second on an hour-long trace. A column with a cell that is no number (a cell cut
    short, a damaged collision flag) is left to the reader, which says so or reads nan as before."""
    out: dict[str, np.ndarray] = {}
    for name in ("time", "x", "y", "heading", "collided"):
        if name in columns:
            try:  # float() of each cell, as the readers' numpy conversion and check_rows read it
                cells = map(operator.itemgetter(columns.index(name)), rows)
                out[name] = np.fromiter(map(float, cells), float, len(rows))
            except ValueError:
                continue
    return out


class _Keep:
    """Which rows a thinned trace keeps, decided row by row, robot by robot."""

    def __init__(self, columns: list[str], every: int, max_kept: int):
        self.columns, self.every, self.max_kept = columns, every, max_kept
        self.extra = max_kept  # bytes the rows kept for what happens on them may take
        self.bytes = 0
        self.index = {c: columns.index(c) for c in ("robot", "events", "collided", "state") if c in columns}
        self.count: dict[str, int] = {}
        self.last: dict[str, tuple[str, str]] = {}  # robot -> (collided, state) of its previous row
        self.pending: dict[str, tuple[int, list[str]]] = {}  # robot -> its latest row not kept
        self.kept: list[list[str]] = []
        self.lines: list[int] = []
        self.seen = 0

    def add(self, path: str, batch: list[list[str]], at: list[int]) -> None:
        check_rows(path, self.columns, batch, at)
        if self.every == 1:  # every row kept: no decision to make row by row
            self.seen += len(batch)
            self.kept += batch
            self.lines += at
            return
        for row, line in zip(batch, at):
            self.seen += 1
            robot = row[self.index["robot"]] if "robot" in self.index else ""
            j = self.count.get(robot, 0)
            self.count[robot] = j + 1
            if j % self.every == 0 or (self.extra > 0 and self._marked(robot, row)):
                self.bytes += _cost(row)
                if self.bytes > 2 * self.max_kept:
                    row = [c[:LONG_CELL] for c in row]
                self.kept.append(row)
                self.lines.append(line)
                self.pending.pop(robot, None)
            else:
                self.pending[robot] = (line, row)
            if "collided" in self.index or "state" in self.index:
                self.last[robot] = (self._cell(row, "collided"), self._cell(row, "state"))

    def _cell(self, row: list[str], name: str) -> str:
        return row[self.index[name]] if name in self.index else ""

    def _marked(self, robot: str, row: list[str]) -> bool:
        """Something a picture marks happens on this row: an event, a collision's start, a new state."""
        before = self.last.get(robot, ("0", ""))
        hit = self._cell(row, "collided") not in ("", "0") and before[0] in ("", "0")
        marked = bool(self._cell(row, "events")) or hit or self._cell(row, "state") != before[1]
        if marked:
            self.extra -= _cost(row)
        return marked

    def rows(self) -> tuple[list[list[str]], list[int]]:
        """The kept rows in the file's order, each robot's last row among them."""
        if not self.pending:
            return self.kept, self.lines
        tail = sorted(self.pending.values())
        pairs = sorted([*zip(self.lines, self.kept), *tail], key=lambda p: p[0])
        return [r for _, r in pairs], [ln for ln, _ in pairs]


def _cost(row: list[str]) -> int:
    """About the bytes a row of text takes in Python."""
    return 64 + sum(len(c) for c in row) + CELL_BYTES * len(row)
