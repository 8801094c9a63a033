"""The reductions of a group (dsl/library/builtins.py): the C fast path against the plain loop.

``min``, ``max``, ``argmin`` and ``argmax`` of a long group (a lidar's 360 beams) take C's
min and index once a sum shows no member is nan; the answers must be those of the loop the
language defines, the first of equals kept, nan and infinities and signed zeros included.
"""
from __future__ import annotations

import math
import random
import struct

import pytest

from labsim.dsl.library.builtins import _max, _min, argmax, argmin


def _loop_min(*values: float) -> float:
    if any(v != v for v in values):
        return math.nan
    m = values[0]
    for x in values[1:]:
        if x < m:
            m = x
    return m


def _loop_max(*values: float) -> float:
    if any(v != v for v in values):
        return math.nan
    m = values[0]
    for x in values[1:]:
        if x > m:
            m = x
    return m


def _loop_arg(values: tuple[float, ...], better: float, less: bool) -> float:
    best, at = better, math.nan
    for k, v in enumerate(values):
        if (v < best if less else v > best) or (v == best and at != at):
            best, at = v, float(k)
    return at


def _bits(x: float) -> bytes:
    return struct.pack("<d", x)  # tells -0.0 from 0.0 and keeps nan comparable


@pytest.mark.parametrize("seed", range(300))
def test_the_fast_path_gives_the_loops_answer(seed: int) -> None:
    rng = random.Random(seed)
    pool = [0.0, -0.0, 1.0, -1.0, math.inf, -math.inf, math.nan, 0.5, 2.5]
    size = rng.choice([2, 3, 5, 16, 360])
    values = tuple(rng.choice(pool) if rng.random() < 0.3 else rng.choice([rng.uniform(-3, 3), 5.0])
                   for _ in range(size))
    assert _bits(_min(*values)) == _bits(_loop_min(*values))
    assert _bits(_max(*values)) == _bits(_loop_max(*values))
    assert _bits(argmin(*values)) == _bits(_loop_arg(values, math.inf, True))
    assert _bits(argmax(*values)) == _bits(_loop_arg(values, -math.inf, False))


def test_the_first_of_equals_is_kept_among_signed_zeros() -> None:
    assert _bits(_min(1.0, 0.0, 2.0, -0.0)) == _bits(0.0)
    assert argmin(1.0, 0.0, 2.0, -0.0) == 1.0
    assert argmax(math.inf, 1.0, math.inf) == 0.0
    assert argmin(math.inf, math.inf, math.inf) == 0.0
    assert math.isnan(argmin(math.nan, math.nan))
    assert argmin(math.nan, 3.0, 1.0, math.inf, -math.inf) == 4.0
