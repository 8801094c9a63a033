"""Groups read as a run of the tick's channel values (dsl/emit/unroll.py ``sequence``).

A group that is consecutive channels in order (a lidar's ``lidar1..lidar360``, ``sonar3..sonar6``)
is reduced by one call on the list the backend gave, or a slice of it, instead of one local
and one argument per member. The answers must be those of the member-by-member code, bit for
bit, nan, infinities and signed zeros included: each behaviour here is compiled both ways
(the member-by-member way by emptying ``ON_SEQUENCE``) and run on the same random readings.
"""
from __future__ import annotations

import math
import random
import re
import struct
from pathlib import Path

import pytest

from labsim.dsl.compile import compile_file
from labsim.dsl.emit import codegen
from labsim.dsl.emit.program import Program
from labsim.dsl.library.builtins import (
    _max,
    _min,
    argmax,
    argmax_at,
    argmax_of,
    argmin,
    argmin_at,
    argmin_of,
    max_of,
    min_of,
    sum_of,
)
from labsim.dsl.library.support import Faults

POOL = [0.0, -0.0, 1.0, -1.0, math.inf, -math.inf, math.nan, 0.5, 2.5, 1e308, -1e308]
LIDAR = ("labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\nrobots:\n"
         "  p: {model: pioneer_p3dx, at: [0, 0, 0], lidar: {beams: 360, fov_deg: 360, range_m: 5}}\n")
SONARS = "labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"


def _bits(x: object) -> object:
    """A float's bits (-0.0 is not 0.0), but every nan the same: the sign of a nan made by
    inf - inf is not the language's (CPython's own float addition and the one its
    interpreter specializes to after a few ticks give nans of either sign)."""
    if isinstance(x, float):
        return "nan" if x != x else struct.pack("<d", x)
    return x


def _reading(rng: random.Random, n: int) -> list[float]:
    """n channel values: mostly ordinary distances, some special values, now and then all equal."""
    if rng.random() < 0.1:
        return [rng.choice(POOL)] * n
    return [rng.choice(POOL) if rng.random() < 0.2 else rng.choice([rng.uniform(0.0, 5.0), math.inf])
            for _ in range(n)]


@pytest.mark.parametrize("seed", range(200))
def test_each_sequence_form_gives_the_member_by_member_answer(seed: int) -> None:
    rng = random.Random(seed)
    values = _reading(rng, rng.choice([4, 5, 16, 360]))
    assert _bits(min_of(values)) == _bits(_min(*values))
    assert _bits(max_of(values)) == _bits(_max(*values))
    assert _bits(argmin_of(values)) == _bits(argmin(*values))
    assert _bits(argmax_of(values)) == _bits(argmax(*values))
    assert _bits(argmin_at(values, min_of(values))) == _bits(argmin(*values))
    assert _bits(argmax_at(values, max_of(values))) == _bits(argmax(*values))
    unrolled = eval("(" + " + ".join(f"v[{k}]" for k in range(len(values))) + ")", {"v": values})
    assert _bits(sum_of(values)) == _bits(unrolled)


def test_a_sum_keeps_a_first_negative_zero() -> None:
    assert _bits(sum_of([-0.0, -0.0, -0.0, -0.0])) == _bits(-0.0)  # Python's sum() would give 0.0


def _both_ways(write, monkeypatch: pytest.MonkeyPatch, text: str) -> tuple[Program, Program]:
    """The behaviour compiled with groups read as sequences, and member by member."""
    fast = compile_file(write(text, "fast.yaml"))
    with monkeypatch.context() as m:
        m.setattr(codegen, "ON_SEQUENCE", frozenset())
        plain = compile_file(write(text, "plain.yaml"))
    assert "_of(values" not in plain.code.source
    return fast, plain


def _run(program: Program, readings: list[list[float]]) -> list[tuple[object, ...]]:
    """Each tick's slots and rule, through signals() and decide() (as a fleet runs them) and
    through both() (as a single robot does)."""
    out = []
    for call_both in (False, True):
        robot = program.robot("p", random.Random(0), Faults())
        for tick, values in enumerate(readings):
            if call_both:
                rule = robot.both(tick * program.dt_s, tick, values)
            else:
                robot.signals(tick * program.dt_s, tick, values)
                rule = robot.decide()
            out.append((rule, *(_bits(v) for v in robot.slots), *(_bits(c) for c in robot.command)))
    return out


def _same_runs(fast: Program, plain: Program, seed: int = 1, ticks: int = 60) -> None:
    rng = random.Random(seed)
    readings = [_reading(rng, len(fast.channels)) for _ in range(ticks)]
    assert fast.channels == plain.channels
    assert _run(fast, readings) == _run(plain, readings)


def test_a_scan_is_reduced_over_the_values_with_no_local_per_beam(write, monkeypatch: pytest.MonkeyPatch) -> None:
    fast, plain = _both_ways(write, monkeypatch, LIDAR + (
        "let:\n  scan: lidar1..lidar360\n  nearest: min(scan)\n  where: argmin(scan)\n  far: max(scan)\n"
        "  away: argmax(scan)\n  total_: sum(scan)\n  avg: mean(scan)\n"
        "rules:\n  - if nearest < 0.6 and where >= 180 then arc(3, -3)\n"
        "  - if min(lidar1..lidar90) < 1 then arc(-3, 3)\n"
        "  - else move(far + away + total_ + avg)\n"))
    source = fast.code.source
    assert "_min_of(values)" in source and "_min_of(values[0:90])" in source
    # the direction of the nearest beam and of the farthest: where the signals above found them
    assert "_argmin_at(values, v364)" in source and "_argmax_at(values, v366)" in source
    assert not re.search(r"\bv3\b", source.split("def make")[1])  # neither unpacked nor loaded
    assert "values = s[3:363]" in source  # decide() takes them from the slots
    _same_runs(fast, plain)


def test_a_member_used_alone_keeps_its_local(write, monkeypatch: pytest.MonkeyPatch) -> None:
    fast, plain = _both_ways(write, monkeypatch, LIDAR + (
        "let:\n  scan: lidar1..lidar360\n  nearest: min(scan)\n  ahead: scan[180]\n"
        "rules:\n  - if lidar90 < nearest + 0.1 or ahead < 0.5 then arc(3, -3)\n"
        "  - if [min(lidar1..lidar90), lidar5][0] < 0.3 then arc(-3, 3)\n  - else move(nearest)\n"))
    source = fast.code.source
    assert "_min_of(values)" in source
    assert "v183 = values[180]" in source and "v92 = values[89]" in source
    _same_runs(fast, plain, seed=2)


def test_sonar_groups_read_slices_and_other_groups_their_members(write, monkeypatch: pytest.MonkeyPatch) -> None:
    fast, plain = _both_ways(write, monkeypatch, SONARS + (
        "let:\n  front: sonar3..sonar6\n  near: min(front)\n  at: argmin(front)\n  far: argmax([sonar1, sonar8])\n"
        "  odd: max([sonar1, sonar3, sonar5, sonar7])\n  second: front[1]\n  avg: mean(sonar1..sonar16)\n"
        "  back: min(sonar9..sonar16)\n  pair: min(sonar9..sonar11)\n"
        "rules:\n  - if min(sonar1..sonar8) < 0.3 then stop()\n"
        "  - else move(near + at + far + odd + second + avg + back + pair)\n"))
    source = fast.code.source
    assert "_sum_of(values)" in source and "_min_of(values[0:8])" in source
    assert "_max(" in source  # sonar1, 3, 5, 7 are no run of the values
    assert "_min_of(values[8:11])" not in source  # three members: written out without a call
    _same_runs(fast, plain, seed=3)


def test_the_lidar_benchmark_compiles_to_two_calls_on_the_values() -> None:
    program = compile_file(Path(__file__).resolve().parents[2] / "benchmarks" / "lidar_wander.yaml")
    both = program.code.source.split("def both")[1]
    assert "s[364] = v364 = _min_of(values)" in both and "s[365] = v365 = _argmin_at(values, v364)" in both
    assert "= values" not in both.split("s[364]")[0]  # no unpacking before the reductions
