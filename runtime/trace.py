"""Trace files: one CSV row per robot per tick, after a commented JSON header.

The format (version 1, see docs/trace-format.md) is chosen to be read by people, diffed by
git and loaded by pandas without options beyond ``comment="#"``::

    # labsim-trace {"format": 1, "labsim": "0.1.0", "backend": "pymunk", "seed": 1, ...}
    tick,time,robot,x,y,heading,state,rule,sonar2,...,collided,r,left,right,events
    0,0.0,pioneer,-5.2,1.3,0.785398,wander,wander:3,inf,...,0,57,12.3,12.3,

Numbers are written with 6 significant digits (``inf`` when a sensor sees nothing), booleans
as 0/1, ``events`` as ``;``-separated names of count metrics that rose on that tick. Rows are
written as the run goes to ``PATH.partial``, flushed at least once a second of wall time, and
the file is renamed to ``PATH`` with a footer line (``# end {...}``) when the run ends in any
way labsim sees; a killed run leaves ``PATH.partial``, readable, without the footer.
"""
from __future__ import annotations

import collections
import contextlib
import csv
import io
import json
import math
import operator
import os
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

from labsim.backends.scene.world import World
from labsim.backends.scene.world_file import load_world
from labsim.backends.scene.world_names import builtin_worlds, find_world
from labsim.foundation.diagnostics import Diagnostic, LabsimError, Report
from labsim.foundation.files import Output, allowed_folders, read_input, write_error
from labsim.foundation.json_data import loads_json
from labsim.foundation.kinds import TRACE_MAGIC, is_golden_name, kind_of_text
from labsim.foundation.numbers import WHOLE_LIMIT, NumberError, to_float

if TYPE_CHECKING:
    import numpy as np

FORMAT = 1
MAGIC = TRACE_MAGIC  # a trace's first line starts so: the one rule for file kinds knows it too
FOOTER = "# end "  # the last line: {"interrupted": bool, "ticks": int}
FLUSH_S = 1.0  # rows reach the file at least this often (wall time)
PARTIAL = ".partial"  # the trace's name while the run goes
BATCH = 32  # rows formatted by TraceRows gathered before one write (a killed run loses these too)


def fmt(v: object) -> str:
    """A value as the trace writes it."""
    if v is True:
        return "1"
    if v is False:
        return "0"
    if isinstance(v, float):
        if v != v:
            return "nan"
        if v in (math.inf, -math.inf):
            return "inf" if v > 0 else "-inf"
        return f"{v:.6g}"
    return str(v)


def csv_cell(text: str) -> str:
    """A text cell as ``csv.writer`` writes it (QUOTE_MINIMAL, ``"`` doubled): the row writer of
    ``TraceRows`` builds lines itself, one format operation a row instead of a call per cell.
    A text with a character csv may quote is written by csv itself, whose rules vary a little
    between Python versions (a lone carriage return, for one)."""
    if "," in text or '"' in text or "\n" in text or "\r" in text:
        _CELL.seek(0)
        _CELL.truncate()
        _CELL_WRITER.writerow((text,))
        return _CELL.getvalue()[:-1]
    return text


_CELL = io.StringIO()
_CELL_WRITER = csv.writer(_CELL, lineterminator="\n")


class TraceWriteError(LabsimError):
    """The trace could not be written (a full disk, a read-only file system): the run stops."""


class TraceFull(Exception):
    """The trace reached its size budget (``max_chars``) with the row just written, the row of
    tick ``tick``: the run stops."""

    def __init__(self, chars: int, tick: int):
        super().__init__(chars)
        self.tick = tick


class TraceWriter:
    """Writes a trace as rows arrive to ``PATH.partial``; ``close`` adds the footer and renames it
    to ``PATH`` (also on errors, Ctrl-C and SIGTERM). A write the OS refuses is a TraceWriteError;
    a row that takes the trace past ``max_chars`` raises TraceFull once it is written."""

    def __init__(self, path: str | Path, header: dict, columns: list[str], max_chars: int | None = None):
        self.path = Path(path)
        self.columns = columns
        self._out = Output(self.path, partial=str(self.path) + PARTIAL)
        # open for the life of the writer (close() ends it), not for one block
        self._file: TextIO = io.TextIOWrapper(self._out.file, encoding="utf-8", newline="")
        self._writer = csv.writer(self._file, lineterminator="\n")
        self.rows = 0
        self._chars = 0
        self.pending: list[str] = []  # rows formatted but not yet written: at most BATCH - 1
        self.max_chars = max_chars if max_chars is not None else math.inf
        self._flushed = time.monotonic()
        self.failed = False
        try:
            self._guard(lambda: self._file.write(MAGIC + json.dumps(header, sort_keys=True) + "\n"))
            self._guard(lambda: self._writer.writerow(columns))
        except TraceWriteError:
            self._out.discard()
            raise

    def _guard(self, write: object) -> None:
        try:
            self._chars += write() or 0  # type: ignore[operator]
        except OSError as e:
            self.failed = True
            raise TraceWriteError(write_error(self.path, e).diagnostics) from None

    @property
    def chars(self) -> int:
        """Characters written so far, header and rows: what the trace-size budget counts."""
        self.drain()
        return self._chars

    def write(self, row: list[object]) -> None:
        self.drain()
        self._guard(lambda: self._writer.writerow([fmt(v) for v in row]))
        self._wrote(1, row[0])

    def write_line(self, line: str) -> None:
        """A row already formatted as ``write`` would format it, newline included (TraceRows'
        hot path appends to ``pending`` itself and drains every BATCH rows)."""
        self.pending.append(line)
        if len(self.pending) >= BATCH:
            self.drain()

    def drain(self) -> None:
        """Write the rows gathered in ``pending``; where the size budget ends among them, up to
        the row that reaches it (TraceFull), and the rows after it are dropped."""
        if not self.pending:
            return
        lines, text = list(self.pending), "".join(self.pending)
        self.pending.clear()
        if self._chars + len(text) <= self.max_chars:
            self._guard(lambda: self._file.write(text))
            self._wrote(len(lines), None)
            return
        for line in lines:
            self._guard(lambda: self._file.write(line))  # noqa: B023 - called at once
            self._wrote(1, line[:line.index(",")])

    def _wrote(self, rows: int, tick: object) -> None:
        self.rows += rows
        if self._chars > self.max_chars:  # checked by the row, so the file ends within a row of its budget
            self.pending.clear()
            raise TraceFull(self._chars, int(str(tick)))
        now = time.monotonic()
        if now - self._flushed >= FLUSH_S:  # a killed run loses at most a second of rows
            self._flushed = now
            self._guard(self._file.flush)

    def _ticks_written(self, counted: int | None) -> int | None:
        """The ticks the file holds rows of, read from its last row: exact whatever the moment
        an interrupt came; ``counted`` if the file cannot say."""
        try:
            self.drain()
            self._file.flush()
            with open(self._out.partial, "rb") as f:
                f.seek(max(0, f.seek(0, os.SEEK_END) - 65_536))
                last = f.read().rstrip(b"\n").rsplit(b"\n", 1)[-1]
            first = last.split(b",", 1)[0]
            return int(first) + 1 if first.isdigit() else 0  # else the columns line: no row yet
        except (OSError, ValueError, TraceWriteError, TraceFull):
            return counted

    def close(self, ticks: int | None = None, interrupted: bool = True) -> None:
        """Write the footer and rename the trace into place; an unwritable footer leaves the rows."""
        if self._file.closed:
            return
        with contextlib.suppress(TraceWriteError, TraceFull):  # failed or full: the rows written stay
            self.drain()
        if interrupted and not self.failed:  # a signal may land between a row and the count of it
            ticks = self._ticks_written(ticks)
        footer = {"interrupted": interrupted, "ticks": ticks if ticks is not None else -1}
        try:
            if not self.failed:
                self._guard(lambda: self._file.write(FOOTER + json.dumps(footer, sort_keys=True) + "\n"))
        finally:
            error = None
            try:
                self._file.close()
            except OSError as e:  # the last rows did not reach the disk
                error = None if self.failed else e
            self._out.commit()  # what was written stays, under the trace's own name
            if error is not None:
                self.failed = True
                raise TraceWriteError(write_error(self.path, error).diagnostics)


@dataclass
class Trace:
    path: str
    header: dict
    columns: list[str]
    rows: list[list[str]]
    footer: dict | None = None  # the ``# end`` line; None for a cut-off trace or a golden
    lines: list[int] = field(default_factory=list)  # each row's line in the file
    # the behaviour file a reader was told made the trace (``labsim plot --behaviour``), which
    # pictures read before the one the header names
    behaviour_given: str = ""
    # columns already numbers, which the pictures read instead of the rows' cells (left empty):
    # a run recorded in memory (labsim.runtime.recording) is drawn without a text round trip
    numbers: dict[str, np.ndarray] = field(default_factory=dict)

    def column(self, name: str) -> list[str]:
        i = self.columns.index(name)
        return [r[i] for r in self.rows]

    def cut_short(self) -> str:
        """Why the run this trace records did not end by itself, or '' when it did (or when the
        trace is a golden, which is stored without its footer)."""
        if self.footer is None:
            return "" if is_golden_name(self.path) else \
                "the trace has no '# end' line: the run was killed, or it is still going"
        if self.footer.get("interrupted"):
            return f"the run was interrupted after {self.footer.get('ticks', '?')} ticks"
        return ""


class TraceFormatError(Exception):
    """The file is not a labsim trace (or a damaged one): ``path[:line]: message``."""

    def __init__(self, message: str, path: str = "", line: int = 0, notes: tuple[str, ...] = ()):
        super().__init__(message)
        self.path, self.line, self.notes = path, line, notes  # notes: what to try (a missing file's)

    def diagnostic(self, path: str) -> Diagnostic:
        """As a diagnostic: the trace's name and line, then what is wrong."""
        text = str(self)
        for prefix in (f"{self.path}:{self.line}: " if self.line else "", f"{self.path}: ", f"{path}: "):
            if prefix and text.startswith(prefix):
                text = text[len(prefix):]
                break
        return Diagnostic(path, text, self.line, 1 if self.line else 0, notes=self.notes)


# the columns every labsim trace has, and how each is read
_WHOLE, _NUMBER = ("tick",), ("time", "x", "y", "heading")


def _bad(path: str | Path, line: int, message: str) -> TraceFormatError:
    return TraceFormatError(f"{path}:{line}: {message}", str(path), line)


def read_trace(path: str | Path) -> Trace:
    """A trace, its rows checked as they are read: TraceFormatError names the line of a bad cell."""
    try:
        text = read_input(path, "trace").decode("utf-8")
    except LabsimError as e:
        raise TraceFormatError(f"{path}: {e.diagnostics[0].message}", str(path), notes=e.diagnostics[0].notes) from None
    except UnicodeDecodeError as e:
        raise TraceFormatError(f"{path}: not UTF-8 text (byte {e.start}): not a labsim trace", str(path)) from None
    first, _, rest = text.partition("\n")
    header = parse_header(path, first, text[:4096])
    rest, footer = footer_of(rest)
    reader = csv.reader(io.StringIO(rest))
    columns = read_columns(path, reader)
    rows: list[list[str]] = []
    lines: list[int] = []
    try:
        for r in reader:
            if r:
                rows.append(r)
                lines.append(reader.line_num + 1)  # +1: the header line is not in ``rest``
    except csv.Error as e:  # a cell past the csv module's limit (131,072 characters), a NUL
        raise _bad(path, reader.line_num + 1, f"damaged row: {e}") from None
    if rows and len(rows[-1]) < len(columns) and not text.endswith("\n"):
        rows.pop()  # a run killed mid-write leaves half a line: the ticks before it still stand
        lines.pop()
    check_rows(path, columns, rows, lines)
    return Trace(str(path), header, columns, rows, footer, lines)


def parse_header(path: str | Path, first: str, start: str) -> dict:
    """The trace's header from its first line (``start``: the file's first characters, to say
    what else it is when it is no trace)."""
    if not first.startswith(MAGIC):
        what = kind_of_text(start, str(path))
        hint = ""
        if what == "behaviour":  # labsim plot wall.yaml: the trace is what a run of it writes
            hint = (f": it is a behaviour file; run it with --trace first (labsim run {path} --trace run.csv), "
                    "then give run.csv")
        elif what == "world":
            hint = ": it is a world file; a behaviour runs in it (labsim run BEHAVIOUR --trace run.csv)"
        raise TraceFormatError(f"{path}: not a labsim trace (no '{MAGIC.strip()}' header line){hint}", str(path))
    try:
        header = loads_json(first[len(MAGIC):])
    except ValueError as e:  # JSONDecodeError is one; so is a header nested too deep
        raise _bad(path, 1, f"damaged trace header: {e}") from None
    if not isinstance(header, dict):
        raise _bad(path, 1, "damaged trace header: not a JSON object")
    if header.get("format") != FORMAT:
        raise TraceFormatError(f"{path}: trace format {str(header.get('format'))[:20]} is not {FORMAT}", str(path))
    for key, kind in (("world", str), ("world_file", str), ("name", str), ("behaviour", str),
                      ("robots", dict), ("metrics", dict), ("params", dict)):
        if key in header and not isinstance(header[key], kind):
            raise _bad(path, 1, f"damaged trace header: '{key}' should be a {'mapping' if kind is dict else 'text'}")
    return header


def read_columns(path: str | Path, reader: Iterator[list[str]]) -> list[str]:
    """The column line, the first the reader gives."""
    try:
        return next(reader)
    except csv.Error as e:
        raise _bad(path, 2, f"damaged column line: {e}") from None
    except StopIteration:
        raise TraceFormatError(f"{path}: the trace has no column line", str(path)) from None


def trace_world(trace: Trace) -> tuple[World | None, str]:
    """The world a finished run used, for drawing it, and a note for the title when it can't be.

    The recorded file comes first (it is exactly what ran), relative to the current folder, then
    to the trace's; a built-in of the same name is the fallback, as a trace copied to another
    machine names a path that isn't there. docs/security.md: a world file a trace names is read
    only inside the trace's folder, the current one, or an ``--allow-path`` folder (a trace is a
    file someone may have sent).
    """
    name = str(trace.header.get("world") or "")
    recorded = str(trace.header.get("world_file") or "")
    folder = Path(trace.path).parent.resolve()
    found = [find_world(recorded, Path("."), look_in=(folder,), allowed=[folder, *allowed_folders()])] \
        if recorded else []
    if name in builtin_worlds():
        found.append(find_world(name))
    broken = ""
    for ref in found:
        if ref.path is None:
            broken = f" ({ref.problem}; --allow-path DIR reads it)" if ref.refused else broken
            continue
        world = load_world(ref.path, Report())
        if world is not None:
            return world, ""
        broken = f" ({ref.path} has errors)"
    if not name and not recorded:
        return None, "the trace names no world: drawn without walls"
    what = f"world '{name}'" if name else f"world file {recorded}"
    return None, f"{what} not found{broken}: drawn without walls"


def footer_of(rest: str) -> tuple[str, dict | None]:
    """The rows without the ``# end`` line, and that line's values (None when there is none)."""
    body = rest.rstrip("\n")
    head, _, last = body.rpartition("\n")
    if not last.startswith(FOOTER):
        return rest, None
    try:
        footer = loads_json(last[len(FOOTER):])
    except ValueError:  # not JSON, or nested too deep: no footer
        return head + "\n", None
    return head + "\n", footer if isinstance(footer, dict) else None


def check_rows(path: str | Path, columns: list[str], rows: list[list[str]], lines: list[int]) -> None:
    """Every row has every field; ticks are whole numbers and times and poses numbers."""
    if _rows_ok(columns, rows):
        return
    # something is wrong: found row by row, so that the message names the first bad cell
    whole = [(columns.index(c), c) for c in _WHOLE if c in columns]
    numbers = [(columns.index(c), c) for c in _NUMBER if c in columns]
    for r, line in zip(rows, lines):
        if len(r) != len(columns):
            raise _bad(path, line, f"{len(r)} fields where the header has {len(columns)} "
                                   "(a damaged or truncated trace)")
        for i, name in whole:
            if not (r[i].isascii() and r[i].isdigit()):
                raise _bad(path, line, f"column '{name}' holds '{r[i][:40]}', not a whole number")
        for i, name in numbers:
            try:
                float(r[i])
            except ValueError:
                raise _bad(path, line, f"column '{name}' holds '{r[i][:40]}', not a number") from None


def _rows_ok(columns: list[str], rows: list[list[str]]) -> bool:
    """``check_rows``'s checks a column at a time, in C loops (map, join, all): a picture of a
    long trace reads hundreds of thousands of rows, and the row-by-row loop was a third of it."""
    if any(n != len(columns) for n in set(map(len, rows))):
        return False
    for name in _WHOLE:
        if name in columns:
            cells = list(map(operator.itemgetter(columns.index(name)), rows))
            joined = "".join(cells)  # all digits, and no cell empty: each cell is a whole number
            if not (all(cells) and joined.isascii() and (joined.isdigit() or not joined)):
                return False
    for name in _NUMBER:
        if name in columns:
            try:
                collections.deque(map(float, map(operator.itemgetter(columns.index(name)), rows)), maxlen=0)
            except ValueError:
                return False
    return True


def slider_events(trace: Trace) -> dict[int, list[tuple[str, float]]]:
    """The slider moves a trace recorded (its events column), by tick, for a replay."""
    out: dict[int, list[tuple[str, float]]] = {}
    if "tick" not in trace.columns or "events" not in trace.columns:
        raise TraceFormatError(f"{trace.path}: the trace has no 'tick' and 'events' columns to replay", trace.path)
    ticks, events = trace.column("tick"), trace.column("events")
    lines = trace.lines or range(3, 3 + len(trace.rows))  # a trace made in code: rows from line 3
    for tick, text, line in zip(ticks, events, lines):
        for event in text.split(";") if text else ():
            name, eq, value = event.partition("=")
            if eq and not event.startswith("log: "):
                try:  # the one rule for numbers (labsim.foundation.numbers), as for a file's
                    number = to_float(value)
                except NumberError as e:
                    why = f"is a {e}" if str(e).startswith("number too large") else str(e)
                    raise _bad(trace.path, line, f"event '{event[:60]}': a slider's value {why}") from None
                if not math.isfinite(number):
                    raise _bad(trace.path, line, f"event '{event[:60]}': a slider's value is {value}")
                try:
                    at = to_float(tick)
                except NumberError:
                    at = math.nan
                if not (at.is_integer() and 0 <= at <= WHOLE_LIMIT):
                    raise _bad(trace.path, line, f"tick '{tick[:20]}' is not a tick number")
                settings = out.setdefault(int(at), [])
                if (name, number) not in settings:  # one row per robot repeats them
                    settings.append((name, number))
    return out
