"""The chart's samples of the ticks between two frames, with every peak kept.

At "as fast as it goes" a thousand ticks run between two frames and a frame carries a few
dozen chart rows. Picking evenly spread ticks aliases: the line lab's ``steer``, which flips
sign every tick or two, was drawn as slow pulses. ``Sampler`` keeps every tick's chart values
(the sensor readings and the numeric slots: ``read`` and ``keep``, or written out) and hands a
frame, per group of consecutive ticks, two rows: the group's first time with each column's
least value and its last time with the greatest (the min/max envelope that PlotJuggler and
uPlot draw per pixel column); a column that only fell over the group has its greatest first.
A tick's values are packed as doubles onto one ``bytearray`` per robot (``Kept``), in the live
view's generated tick hook, while they are fresh in the cache, and a frame reads them with
``numpy.frombuffer``: turning a frame's worth of Python floats into numpy's cost more than the
packing, and a list of per-tick tuples three times that.
The frame says, per pair and column, whether the column went both ways within the group
(``bands``): the page's chart draws such a pair as the band it spans (per pixel column the least
and greatest value of every row that covers it) and any other as the line between its two rows,
so that a signal that flips is a band and a step or a slow signal is a line.
"""
from __future__ import annotations

import math
import struct
from collections.abc import Callable, Sequence
from operator import itemgetter

import numpy as np

try:
    from labsim.runtime.view import _tap
except ImportError:  # no C compiler at install time: numpy's envelope, the Python hook and path
    _tap = None  # type: ignore[assignment]

# which does the view's work a tick and a frame: "c", the extension runtime/view/_tap.c (the
# tick hook and path of ``labsim.runtime.view.record``, the envelope here), else "python"; a test
# may set "python" before a session loads
KERNEL = "c" if _tap is not None else "python"

Row = list  # [time, value, ...]


def _getter(indices: Sequence[int]) -> Callable[[Sequence[object]], tuple]:
    """A function of a list giving the items at ``indices`` as a tuple, in C."""
    if not indices:
        return lambda _values: ()
    if len(indices) == 1:
        k = indices[0]
        return lambda values: (values[k],)
    return itemgetter(*indices)


class Kept:
    """One robot's chart values of the ticks since the last frame, flat: each tick's sensor
    channels' (``Sampler.read``) then its numeric slots' (``Sampler.keep``), ``width`` values a
    tick, one tick after the other. The ticks are consecutive from ``first`` (every robot acts on
    every tick) but for the first ``len(ticks)``, listed once thinned. One list extended twice a
    tick, and no tick noted, cost a tick a third less than three lists.

    ``packed``: the values as C doubles in ``data`` (``struct`` packed, a value that is no number
    as nan), made while the tick's values are fresh in the cache; else Python's objects in
    ``values`` (a joint's tuple among them). A frame turned a thousand ticks of Python floats into
    numpy's at 40 ns a value, read back from all over memory: more than the tick's packing costs."""

    __slots__ = ("data", "first", "ticks", "values", "width")

    def __init__(self, first: int = 0, width: int = 0, packed: bool = False) -> None:
        self.first = first
        self.width = width
        self.values: list = []
        self.data: bytearray | None = bytearray() if packed else None
        self.ticks: list[int] = []

    def __len__(self) -> int:
        if not self.width:
            return 0
        return len(self.data) // (8 * self.width) if self.data is not None else len(self.values) // self.width

    def tick_list(self) -> list[int]:
        """The tick of each kept row."""
        start = self.ticks[-1] + 1 if self.ticks else self.first
        return self.ticks + list(range(start, start + len(self) - len(self.ticks)))

    def thin(self) -> None:
        """Every other tick goes, the first and the last kept, so that the chart still spans
        every tick since the last frame (kept when no page takes them: none is ready)."""
        ticks, w = self.tick_list(), self.width
        rows = [*range(0, len(ticks) - 1, 2), len(ticks) - 1]
        self.ticks = [ticks[r] for r in rows]
        if self.data is not None:
            m = np.frombuffer(self.data, dtype=float).reshape(len(ticks), w)[rows]  # a copy: the buffer is free
            self.data[:] = m.tobytes()  # in place: the C hook holds this bytearray (runtime/view/_tap.c)
        else:
            self.values = [v for r in rows for v in self.values[r * w:(r + 1) * w]]

    def drop_last(self) -> Kept:
        """These ticks but the last (the frame itself shows it), in place."""
        n = len(self)
        if n:
            if self.data is not None:
                del self.data[len(self.data) - 8 * self.width:]
            else:
                del self.values[len(self.values) - self.width:]
            del self.ticks[n - 1:]
        return self

    def numbers(self, copy: bool = True) -> np.ndarray | None:
        """The packed values, one row a tick; None when they are Python's objects. ``copy`` False:
        a view of ``data``, which cannot grow or shrink while the view lives (for a caller that
        gathers the columns into an array of its own at once: a copy of a frame's 6,000 ticks
        touched 600 KB of fresh memory, a quarter of the frame's time)."""
        if self.data is None:
            return None
        n = len(self)
        view = np.frombuffer(self.data, dtype=float, count=n * self.width).reshape(n, self.width)
        return view.copy() if copy else view


PACK_ERRORS = (struct.error, OverflowError)  # what packing a value that is no number raises


def packed(pack: Callable[..., bytes], row: Sequence[object]) -> bytes:
    """``row`` packed as doubles, a value that is no number (None, an image, a text) as nan."""
    try:
        return pack(*row)
    except PACK_ERRORS:
        return pack(*(_float(v) for v in row))


class Sampler:
    """What a tick keeps for the chart and how a frame's rows are made of it.

    ``sensors`` are the table's sensor columns (column name, channel index, part: -1, or the
    index in a joint's or body's tuple); ``slots`` the slot of every signal and slider column in
    order, None for one that is not a number (an image, a record: nothing to chart).
    """

    def __init__(self, sensors: Sequence[tuple[str, int, int]], slots: Sequence[int | None]):
        channels = list(dict.fromkeys(i for _, i, _ in sensors))
        numeric_slots = [s for s in slots if s is not None]
        self.read = _getter(channels)
        self.keep = _getter(numeric_slots)
        self._numeric_slots = numeric_slots
        self._wr = len(channels)
        self.width = len(channels) + len(numeric_slots)  # values a tick keeps
        at = {c: k for k, c in enumerate(channels)}
        self._parts = [(at[i], part) for _, i, part in sensors]
        self._flat = all(part < 0 for _, _, part in sensors)
        # the channels and slots a tick keeps, when each is a column of its own (a recorder's hook writes them out)
        self.columns = (channels, numeric_slots) if self._flat else None
        # a tick's values packed as doubles (``Kept.data``) when each is a column of its own
        self.pack = struct.Struct(f"{self.width}d").pack if self._flat else None
        width = len(channels) if self._flat else len(sensors)
        # where each chart column sits in a kept row (sensors, then numeric slots); -1: not a number
        order, k = [], 0
        for s in slots:
            order.append(width + k if s is not None else -1)
            k += s is not None
        self._order = np.array(([at[i] for _, i, _ in sensors] if self._flat else list(range(len(sensors))))
                               + order, dtype=np.intp)
        nan = width + len(numeric_slots)  # the column of nans a missing number reads from
        self._gaps = bool((self._order < 0).any())
        self._c_columns = np.ascontiguousarray(self._order, dtype=np.intp)  # -1: no number (the C envelope's)
        self.kernel = KERNEL  # as the session's recorder was made
        self._columns = np.where(self._order >= 0, self._order, nan)
        self.paired = False  # whether the last ``rows`` were least/greatest pairs of groups of ticks
        self.bands: list[str] = []  # then per pair, per column "1": it went up and down within the group

    def _numbers(self, kept: Kept) -> np.ndarray:
        """The kept ticks' chart values, one row a column and one column a tick (the reductions
        below run along a row, several times faster than down a column)."""
        n, w, wr = len(kept), kept.width, self._wr
        m = kept.numbers(copy=False)
        if m is not None:
            return self._columns_of(m, n)  # its own array: the view goes with this call
        try:  # the common case: every value a number (an int, a bool, a float)
            if not self._flat:
                raise TypeError
            # fromiter: a quarter faster than numpy.array on a list of Python floats (no shape to find)
            m = np.fromiter(kept.values, dtype=float, count=n * w).reshape(n, w)
        except (TypeError, ValueError):  # a None, a record or a joint's tuple among them: each cell on its own
            rows = [kept.values[k * w:(k + 1) * w] for k in range(n)]
            if not self._flat:
                rows = [[r[c] if p < 0 else (r[c][p] if isinstance(r[c], tuple) and p < len(r[c]) else None)
                         for c, p in self._parts] + r[wr:] for r in rows]
            m = np.array([[_float(v) for v in row] for row in rows], dtype=float).reshape(n, -1)
        return self._columns_of(m, n)

    def _columns_of(self, m: np.ndarray, n: int) -> np.ndarray:
        """The chart's columns of the kept rows ``m`` (a tick a row), one row a column."""
        if self._gaps:
            m = np.concatenate((m, np.full((n, 1), math.nan)), axis=1)
        return np.ascontiguousarray(m[:, self._columns].T)  # columns gathered row by row: 5 times faster

    def as_of(self, kept: Kept, slots: list, tick: int) -> list:
        """``slots`` with the numeric signals and sliders of ``tick`` as ``kept`` has them, when its
        last row is that tick's. Once the stop condition held, the run's slots hold the stopping
        tick's signals (evaluated, never acted on), and a frame shows the last tick that acted."""
        n, w = len(kept), kept.width
        if not n or kept.tick_list()[-1] != tick:
            return slots
        row = np.frombuffer(kept.data, dtype=float, count=n * w)[-w:].tolist() if kept.data is not None \
            else kept.values[-w:]
        out = list(slots)
        for k, s in enumerate(self._numeric_slots):
            out[s] = row[self._wr + k]
        return out

    def rows(self, kept: Kept, dt_s: float, at_most: int) -> list[Row]:
        """At most ``at_most`` chart rows for the kept ticks: as they are when they fit, else
        least/greatest pairs of consecutive groups; four decimals, ``"inf"`` and None as sent.
        Packed ticks that do not fit go to the C extension's ``envelope`` where ``KERNEL`` was "c"
        when the sampler was made (the same rows as numpy's, without its copies of the ticks)."""
        n = len(kept)
        if not n:
            self.paired = False
            return []
        ticks = np.array(kept.tick_list(), dtype=float) if kept.ticks else \
            np.arange(kept.first, kept.first + n, dtype=float)
        times = np.round(ticks * dt_s, 9)
        if kept.data is not None and self.kernel == "c" and n > max(2, at_most):
            out, bands = packed_pairs(kept.data, kept.width, self._c_columns, times, at_most)
        else:
            out, bands = pairs(times, self._numbers(kept), at_most)
        self.paired, self.bands = bands is not None, bands or []
        return out


def groups_of(n: int, at_most: int) -> tuple[np.ndarray, np.ndarray]:
    """The first and last row of each of ``at_most // 2`` consecutive groups of ``n`` rows."""
    groups = max(1, at_most // 2)
    edges = np.linspace(0, n, groups + 1).astype(np.intp)
    return edges[:-1], edges[1:] - 1


def pairs(times: np.ndarray, m: np.ndarray, at_most: int) -> tuple[list[Row], list[str] | None]:
    """At most ``at_most`` rows ``[time, value, ...]`` of ``m`` (columns x rows, at ``times``): as
    they are when they fit (bands None), else each of ``at_most // 2`` consecutive groups as its
    least and greatest row, with per pair the columns that went both ways in it (``bands``);
    four decimals, ``"inf"`` and None as sent."""
    n = m.shape[1]
    if n <= max(2, at_most):
        return _table(times, m.T), None
    starts, ends = groups_of(n, at_most)
    # an inf or -inf tick (a gap on the page) is passed over as nan is: the group's finite values
    # make its pair, and only a group of nothing else is a gap
    m = np.where(np.isfinite(m), m, math.nan)
    with np.errstate(invalid="ignore"):
        low = np.fmin.reduceat(m, starts, axis=1).T
        high = np.fmax.reduceat(m, starts, axis=1).T
    rising, falling = _monotone(m, starts, ends)
    return paired_rows(times[starts], times[ends], low, high, rising, falling)


def packed_pairs(data: bytearray | bytes, width: int, columns: np.ndarray, times: np.ndarray,
                 at_most: int) -> tuple[list[Row], list[str] | None]:
    """``pairs`` of rows packed as doubles, ``width`` a row (``Kept.data``), by the C extension's
    ``envelope``: ``columns`` (intp) each chart column's place in a row, -1 for none (nan)."""
    n = len(times)
    if n <= max(2, at_most):
        m = np.frombuffer(data, dtype=float, count=n * width).reshape(n, width)
        return _table(times, np.where(columns >= 0, m[:, np.maximum(columns, 0)], math.nan)), None
    starts, ends = groups_of(n, at_most)
    low, high, fell, rose = _tap.envelope(data, width, columns, starts, n)
    shape = (len(starts), len(columns))
    return paired_rows(times[starts], times[ends], np.frombuffer(low).reshape(shape),
                       np.frombuffer(high).reshape(shape), np.frombuffer(fell, dtype=np.bool_).reshape(shape) == 0,
                       np.frombuffer(rose, dtype=np.bool_).reshape(shape) == 0)


def paired_rows(first: np.ndarray, last: np.ndarray, low: np.ndarray, high: np.ndarray, rising: np.ndarray,
                falling: np.ndarray) -> tuple[list[Row], list[str]]:
    """Each group's two rows (at its ``first`` and ``last`` time) from its least and greatest
    values and whether each column never fell (``rising``) and never rose (``falling``), groups x
    columns, and the bands (``pairs``)."""
    groups = len(first)
    values = np.empty((2 * groups, low.shape[1]))
    # a column that only fell over the group: its greatest first, so that the line falls
    down = falling & ~rising
    values[0::2], values[1::2] = np.where(down, high, low), np.where(down, low, high)
    picked = np.empty(2 * groups)
    picked[0::2], picked[1::2] = first, last
    # a column that went both ways within the group is a band over it; one way, a line
    return _table(picked, values), _flags(~(rising | falling))


def _table(times: np.ndarray, values: np.ndarray) -> list[Row]:
    """Rows ``[time, value, ...]``: four decimals (no -0.0), ``"inf"`` and None as sent. A value of
    1e15 or more is sent as it is (rounding it to four decimals changes nothing; beyond 1.8e304 it
    overflowed to inf)."""
    with np.errstate(over="ignore", invalid="ignore"):
        values = np.where(np.abs(values) < 1e15, np.round(values, 4), values) + 0.0
    table = np.hstack([times[:, None], values])
    if np.isfinite(values).all():
        return table.tolist()
    # "inf", "-inf" and None (nan) as sent, set by masks: a cell at a time cost a frame a tenth of its time
    cells = table.astype(object)
    body = cells[:, 1:]
    body[np.isnan(values)] = None
    body[values == math.inf] = "inf"
    body[values == -math.inf] = "-inf"
    return cells.tolist()


def _flags(both_ways: np.ndarray) -> list[str]:
    """Per group (a row of ``both_ways``, groups x columns) a text of "1" (the column went both
    ways in it) and "0", one character a column: made as bytes by numpy, a row at a time in
    Python cost the frame a third of its envelope's time."""
    groups, columns = both_ways.shape
    if not columns:
        return [""] * groups
    codes = np.where(both_ways, ord("1"), ord("0")).astype(np.uint8)
    return np.ascontiguousarray(codes).view(f"S{columns}").ravel().astype(f"U{columns}").tolist()


def _monotone(m: np.ndarray, starts: np.ndarray, ends: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per group of ticks (``starts``..``ends``) and column of ``m`` (columns x ticks), whether
    it never fell, and never rose (groups x columns)."""
    d = np.zeros_like(m)
    with np.errstate(invalid="ignore"):
        np.subtract(m[:, 1:], m[:, :-1], out=d[:, :-1])
    d[:, ends] = 0  # a group's last tick to the next group's first is no step of either
    fell = np.logical_or.reduceat(d < 0, starts, axis=1)
    rose = np.logical_or.reduceat(d > 0, starts, axis=1)
    return ~fell.T, ~rose.T


def _float(v: object) -> float:
    if isinstance(v, (bool, int, float, np.integer, np.floating)):
        try:
            return float(v)
        except OverflowError:  # an int beyond a double's range
            return math.inf if v > 0 else -math.inf
    return math.nan
