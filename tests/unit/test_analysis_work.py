"""No analysis of the language is exponential in the file: the work of checking grows with its size.

A signal that read itself in both branches of an ``if``, compared with ``==``, made the linter
follow it 2**100 times (``labsim check`` hung). The checker, the linter and the other analyses
now work each signal out once (``labsim.dsl.syntax.ast.LetMemo``). These tests grow families of files
(self-reading signals, nested ifs, long chains of signals) and count the work done: the calls
of the language's own functions while a file is checked and compiled, not the time it takes.
"""
from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path
from types import FrameType
from typing import Any

import pytest

from labsim.dsl.compile import compile_file

HEAD = "labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"
DSL = str(Path(compile_file.__code__.co_filename).parent)  # labsim/dsl: the language's own functions
RULES = "rules:\n  - if e and pid({x}, 1, 0, 0) > 0 then arc(-2, 2)\n  - else move(5)\n"


def self_reading(n: int) -> str:
    """n signals, each reading itself in both branches of an if and the one above it."""
    lets = "  w0: sonar5\n" + "".join(
        f"  w{i}: prev(w{i}, 0) + w{i - 1} if w{i - 1} < 0.5 else prev(w{i}, 0) - w{i - 1}\n" for i in range(1, n))
    return HEAD + "let:\n" + lets + f"  e: w{n - 1} == 3\n" + RULES.format(x=f"w{n - 1}")


def nested_ifs(n: int) -> str:
    """n signals, each three ifs deep with the signal read by itself in every branch."""
    lets = []
    for i in range(n):
        e = "sonar5" if i == 0 else f"s{i - 1}"
        for level in range(3):
            e = f"(prev(s{i}, 0) + {e} if {e} < {level} else prev(s{i}, {level}))"
        lets.append(f"  s{i}: {e}\n")
    return HEAD + "let:\n" + "".join(lets) + f"  e: s{n - 1} != 3\n" + RULES.format(x=f"s{n - 1}")


def chain(n: int) -> str:
    """n signals, each reading the one above three times."""
    lets = "  a0: sonar5\n" + "".join(f"  a{i}: a{i - 1} + a{i - 1} if a{i - 1} < 1 else a{i - 1}\n"
                                      for i in range(1, n))
    return HEAD + "let:\n" + lets + f"  e: a{n - 1} == 3\n" + RULES.format(x=f"a{n - 1}")


LIMIT = 3_000_000


class Exhausted(Exception):
    pass


def work(path: Path, text: str) -> int:
    """The calls of labsim.dsl's functions while ``text`` is checked, linted and compiled."""
    path.write_text(text)
    calls = 0

    def count(frame: FrameType, event: str, arg: Any) -> None:
        nonlocal calls
        if event == "call" and DSL in frame.f_code.co_filename:
            calls += 1
            if calls > LIMIT:  # far more than any of these files needs: stop here rather than hang
                raise Exhausted(f"more than {LIMIT:,} calls")

    sys.setprofile(count)
    try:
        compile_file(path)
    finally:
        sys.setprofile(None)
    return calls


@pytest.mark.parametrize("family", [self_reading, nested_ifs, chain])
def test_work_grows_linearly(tmp_path: Path, family: Callable[[int], str]) -> None:
    sizes = (8, 16, 32)
    counts = [work(tmp_path / f"{family.__name__}{n}.yaml", family(n)) for n in sizes]
    for n, a, b in zip(sizes, counts, counts[1:]):
        # twice the signals, at most about twice the work (plus what every file costs)
        assert b <= 2.2 * a, f"{family.__name__}: {n} signals cost {a} calls, {2 * n} cost {b}"


def test_the_waypoint_patrol_checks_with_its_warning(tmp_path: Path) -> None:
    """The file that hung: a signal reading itself in both branches, compared with ==."""
    path = tmp_path / "patrol.yaml"
    text = HEAD + ("let:\n  wp: prev(wp, 0) + sonar5 if sonar5 < 0.5 else prev(wp, 0)\n  at_end: wp == 3\n"
                   "rules:\n  - if at_end then arc(-2, 2)\n  - else move(5)\n")
    assert work(path, text) < 20_000
    messages = [d.message for d in compile_file(path).warnings]
    assert messages == ["'==' on 'wp', which reads 'sonar5', which changes continuously: it may never be exactly "
                        "equal, and then this would never hold"]
