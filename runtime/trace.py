"""Trace files: one CSV row per robot per tick, after a commented JSON header.

The format (version 1, see docs/trace-format.md) is chosen to be read by people, diffed by
git and loaded by pandas without options beyond ``comment="#"``::

    # labsim-trace {"format": 1, "labsim": "0.1.0", "backend": "pymunk", "seed": 1, ...}
    tick,time,robot,x,y,heading,state,rule,sonar2,...,collided,r,left,right,events
    0,0.0,pioneer,-5.2,1.3,0.785398,wander,wander:3,inf,...,0,57,12.3,12.3,

Numbers are written with 6 significant digits (``inf`` when a sensor sees nothing), booleans
as 0/1, ``events`` as ``;``-separated names of count metrics that rose on that tick. Rows are
written as the run goes, so an interrupted run keeps every tick it made.
"""
from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from labsim.backends.scene.numbers import WHOLE_LIMIT, NumberError, to_float

FORMAT = 1
MAGIC = "# labsim-trace "


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


class TraceWriter:
    """Writes a trace as rows arrive; ``close`` flushes it (also on errors and Ctrl-C)."""

    def __init__(self, path: str | Path, header: dict, columns: list[str]):
        self.path = Path(path)
        self.columns = columns
        # open for the life of the writer (close() ends it), not for one block
        self._file: TextIO = open(self.path, "w", newline="", encoding="utf-8")  # noqa: SIM115
        self._file.write(MAGIC + json.dumps(header, sort_keys=True) + "\n")
        self._writer = csv.writer(self._file, lineterminator="\n")
        self._writer.writerow(columns)
        self.rows = 0

    def write(self, row: list[object]) -> None:
        self._writer.writerow([fmt(v) for v in row])
        self.rows += 1

    def close(self) -> None:
        if not self._file.closed:
            self._file.close()


@dataclass
class Trace:
    path: str
    header: dict
    columns: list[str]
    rows: list[list[str]]

    def column(self, name: str) -> list[str]:
        i = self.columns.index(name)
        return [r[i] for r in self.rows]


class TraceFormatError(Exception):
    """The file is not a labsim trace (or a damaged one)."""


def read_trace(path: str | Path) -> Trace:
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise TraceFormatError(f"{path}: no such trace file") from None
    except (OSError, UnicodeDecodeError) as e:
        raise TraceFormatError(f"{path}: cannot read the trace: {e}") from None
    first, _, rest = text.partition("\n")
    if not first.startswith(MAGIC):
        raise TraceFormatError(f"{path}: not a labsim trace (no '{MAGIC.strip()}' header line)")
    try:
        header = json.loads(first[len(MAGIC):])
    except json.JSONDecodeError as e:
        raise TraceFormatError(f"{path}:1: damaged trace header: {e}") from None
    if not isinstance(header, dict):
        raise TraceFormatError(f"{path}:1: damaged trace header: not a JSON object")
    if header.get("format") != FORMAT:
        raise TraceFormatError(f"{path}: trace format {header.get('format')} is not {FORMAT}")
    for key, kind in (("world", str), ("world_file", str), ("name", str), ("behaviour", str),
                      ("robots", dict), ("metrics", dict), ("params", dict)):
        if key in header and not isinstance(header[key], kind):
            raise TraceFormatError(f"{path}:1: damaged trace header: '{key}' should be a "
                                   f"{'mapping' if kind is dict else 'text'}")
    reader = csv.reader(io.StringIO(rest))
    try:
        columns = next(reader)
    except StopIteration:
        raise TraceFormatError(f"{path}: the trace has no column line") from None
    rows = [r for r in reader if r]
    if rows and len(rows[-1]) < len(columns) and not text.endswith("\n"):
        rows.pop()  # a run killed mid-write leaves half a line: the ticks before it still stand
    for n, r in enumerate(rows, 3):
        if len(r) != len(columns):
            raise TraceFormatError(f"{path}:{n}: {len(r)} fields where the header has {len(columns)} "
                                   "(a damaged or truncated trace)")
    return Trace(str(path), header, columns, rows)


def slider_events(trace: Trace) -> dict[int, list[tuple[str, float]]]:
    """The slider moves a trace recorded (its events column), by tick, for a replay."""
    out: dict[int, list[tuple[str, float]]] = {}
    ticks, events = trace.column("tick"), trace.column("events")
    for n, (tick, text) in enumerate(zip(ticks, events), 3):
        for event in text.split(";") if text else ():
            name, eq, value = event.partition("=")
            if eq and not event.startswith("log: "):
                try:  # the one rule for numbers (labsim.backends.scene.numbers), as for a file's
                    number, at = to_float(value), to_float(tick)
                except NumberError as e:
                    raise TraceFormatError(f"{trace.path}:{n}: slider setting '{event[:60]}' at tick "
                                           f"'{tick[:20]}': {e}") from None
                if not (at.is_integer() and 0 <= at <= WHOLE_LIMIT):
                    raise TraceFormatError(f"{trace.path}:{n}: tick '{tick[:20]}' is not a tick number")
                settings = out.setdefault(int(at), [])
                if (name, number) not in settings:  # one row per robot repeats them
                    settings.append((name, number))
    return out
