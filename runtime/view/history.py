"""What a page that opens late is sent first: the run's history so far, bounded in size.

A frame carries the path points and chart samples of the ticks since the last frame; a tab
opened later, a reload or a reconnect would start from nothing (66 path points against the
first tab's 278). ``History`` keeps, per robot, every path point and chart row the frames sent,
and the server sends it whole as a ``history`` message before the first frame of a page
(docs/view.md). It stays bounded: past ``MAX_POINTS`` every other path point goes (a jump's
break stays), past ``MAX_ROWS`` each four chart rows become two, the first time with each
column's least value and the last time with its greatest (the greatest first where the column
only fell), so that a peak is never averaged away: the chart of a long run is an envelope of it,
a band where a column went both ways (``bands``), a line where it did not. The run's events (slider moves, the
timeline's, changes by hand, states entered, collisions, breakpoints: the page's Events list)
are kept too, the latest ``MAX_EVENTS``; a frame carries at most ``FRAME_EVENTS`` of its own
(the latest) and how many it left out, so that it stays small, and a page that opens later
gets them all. A replay builds the same rows from a trace's (``paired``, ``series_doc``) for
any tick it is asked to show, so that its chart is the same envelope.
"""
from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from labsim.runtime.view.frames import Json, message
from labsim.runtime.view.peaks import pairs

MAX_POINTS = 4000  # path points kept per robot
MAX_ROWS = 2000  # chart rows kept per robot (as least/greatest pairs once the run is long)
MAX_HITS = 2000  # collision marks a history sends per robot (the latest)
MAX_EVENTS = 1000  # events a history sends (the latest), [tick, time, robot, text] each
FRAME_MARKS = 6  # count metrics' marks a frame carries per robot (the latest)
FRAME_EVENTS = 4  # events a frame carries (the latest of those since the last frame)

Row = list  # [time, value, ...]: a value is a float, "inf", "-inf" or None


def _num(v: object) -> float | None:
    if type(v) is float:
        return v if v == v else None
    if v == "inf":
        return math.inf
    if v == "-inf":
        return -math.inf
    return None


def _out(v: float | None) -> float | str | None:
    if v is None:
        return None
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return v


def _merge(rows: Sequence[Row], spans: Sequence[float], bits: Sequence[str]) -> tuple[list, list, list]:
    """Rows of the history (each with its span and band bits) as one pair: per
    column the least and greatest value, the greatest first where the column only fell, and a band
    where it went both ways (or any row was a band already)."""
    if len(rows) <= 2:
        return list(rows), list(spans), list(bits)
    low: Row = [rows[0][0]]
    high: Row = [rows[-1][0]]
    band = []
    for k in range(1, len(rows[0])):
        nums = [n for n in (_num(r[k]) for r in rows if k < len(r)) if n is not None]
        ordered = sorted(nums)  # in C: a replay's seek pairs a whole trace's rows
        up = nums == ordered
        down = nums == ordered[::-1]
        lo, hi = (_out(min(nums)), _out(max(nums))) if nums else (None, None)
        low.append(hi if down and not up else lo)
        high.append(lo if down and not up else hi)
        band.append("1" if any(b[k - 1:k] == "1" for b in bits) or not (up or down) else "0")
    ends = [*spans, *(r[0] for r in rows)]
    bits_out = "".join(band)
    return [low, high], [max(ends), min(ends)], [bits_out, bits_out]


def paired(rows: Sequence[Row], at_most: int) -> tuple[list[Row], list[str] | None]:
    """At most ``at_most`` rows of a tick each (a trace's), and per least/greatest pair the columns
    that went both ways in its group (None: the rows fit, each as it is): made as a live frame's
    (``labsim.runtime.view.peaks.pairs``), so that a replay draws the same envelope."""
    if len(rows) <= at_most:
        return list(rows), None
    try:  # numbers, "inf" and "-inf" (numpy reads those two)
        m = np.array(rows, dtype=float)
    except (TypeError, ValueError):  # a None among them
        m = np.array([[math.nan if v is None else float(v) for v in r] for r in rows], dtype=float)
    return pairs(m[:, 0], np.ascontiguousarray(m[:, 1:].T), at_most)


def series_doc(rows: Sequence[Row], at_most: int) -> Json:
    """A history's ``samples``, ``spans`` and ``bands`` of one robot from rows of a tick each."""
    h = History(1)
    h.add(0, [], *paired(rows, at_most))
    return {k: v for k, v in h.doc(0)["robots"][0].items() if k in ("samples", "spans", "bands")}


class History:
    """Each robot's path points and chart rows as the frames sent them; see the module."""

    def __init__(self, robots: int):
        self.paths: list[list[list | None]] = [[] for _ in range(robots)]
        self.rows: list[list[Row]] = [[] for _ in range(robots)]
        # per chart row, the time at the other end of the group of ticks it stands for (a least/
        # greatest pair: each the other's time; a tick's own row: its time), for the page's bands
        self.spans: list[list[float]] = [[] for _ in range(robots)]
        self.bits: list[list[str]] = [[] for _ in range(robots)]  # per row: per column "1" a band; "" a tick's row
        self.hits: list[list] = [[] for _ in range(robots)]  # where each collision began
        self.marks: list[list] = [[] for _ in range(robots)]  # where a count metric rose: [k, x, y]
        self.events: list[list] = []
        self.events_before = 0  # events older than those kept

    def marked(self, robot: int, marks: list[list[list]], take: bool) -> list:
        """A frame's ``marks`` of ``robot`` (the latest ``FRAME_MARKS`` of those since the last
        frame; a history has all, the latest ``MAX_HITS``), taken from the recorder's ``marks``."""
        if not take:
            return []
        mine = [[k, round(x, 3), round(y, 3)] for k, x, y in marks[robot]
                if isinstance(x, float) and isinstance(y, float) and math.isfinite(x) and math.isfinite(y)]
        marks[robot] = []
        kept = self.marks[robot]
        kept += mine
        if len(kept) > MAX_HITS:
            del kept[: len(kept) - MAX_HITS]
        return mine[-FRAME_MARKS:]

    def frame_events(self, events: list[list]) -> Json:
        """A frame's ``events`` (the latest ``FRAME_EVENTS``) and ``events_more`` (how many of the
        events since the last frame it leaves out); all of them kept for the history."""
        self.events += events
        if len(self.events) > MAX_EVENTS:
            self.events_before += len(self.events) - MAX_EVENTS
            del self.events[: len(self.events) - MAX_EVENTS]
        return {"events": events[-FRAME_EVENTS:], "events_more": max(0, len(events) - FRAME_EVENTS)}

    def add(self, robot: int, path: list, rows: list[Row], bands: list[str] | None = None) -> None:
        """``bands``: the first rows are least/greatest pairs of groups of ticks, one string each
        (``labsim.runtime.view.peaks.Sampler.bands``); the rows after them are ticks' own."""
        p = self.paths[robot]
        for q in path:
            q = q if q is not None and isinstance(q[0], float) and isinstance(q[1], float) else None
            if not p or q != p[-1] or q is None:  # a pose shown by two frames is one point, as the page draws it
                p.append(q)
        if len(p) > MAX_POINTS:
            self.paths[robot] = [q for k, q in enumerate(p) if q is None or k % 2 == 0 or k == len(p) - 1]
        r, spans, bits = self.rows[robot], self.spans[robot], self.bits[robot]
        pairs = 2 * len(bands) if bands else 0
        spans += [rows[k ^ 1][0] if k < pairs else rows[k][0] for k in range(len(rows))]
        bits += [bands[k // 2] if bands and k < pairs else "" for k in range(len(rows))]
        r += rows
        if len(r) > MAX_ROWS:
            merged = [_merge(r[k:k + 4], spans[k:k + 4], bits[k:k + 4]) for k in range(0, len(r), 4)]
            self.rows[robot] = [e for m in merged for e in m[0]]
            self.spans[robot] = [e for m in merged for e in m[1]]
            self.bits[robot] = [e for m in merged for e in m[2]]

    def doc(self, tick: int) -> Json:
        return message("history", tick=tick, robots=[{"path": p, "samples": r, "hits": h[-MAX_HITS:], "marks": m,
                                                      "spans": [None if t == row[0] else t for t, row in zip(sp, r)],
                                                      "bands": [b or None for b in bs]}
                                                     for p, r, h, m, sp, bs in zip(self.paths, self.rows, self.hits,
                                                                                   self.marks, self.spans, self.bits)],
                       events=self.events, events_before=self.events_before)
