"""Hostile numbers and nesting: each is a positioned diagnostic and exit 2, never a traceback.

The numbers part of the catalogue of hostile files: 1e309, an integer of a million digits,
malformed scalars, YAML nested deeper than the cap, numbers that do not fit in a rule string,
a ``--set``, a world file and a replayed trace; and arithmetic that outgrows a float at run
time, which gives inf, not an exception. Times are bounded by generous timeouts only.
"""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import BEHAVIOURS, FIXTURES

from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.numbers import TOO_LARGE, WHOLE_LIMIT, NumberError, to_float
from labsim.foundation.source import MAX_DEPTH
from labsim.runtime.api import run
from labsim.runtime.run import compile_behaviour
from labsim.runtime.trace import Trace, TraceFormatError, slider_events

BASE = """labsim: 1
name: hostile
world: walls_lab4
stop: time >= 0.2
robots:
  r: {model: pioneer_p3dx, at: [0, 0, 0]}
params:
  front: 0.5
rules:
  - if sonar5 <= front then arc(-2, 2)
  - else move(2)
"""
MILLION = "9" * 1_000_000
PENDULUM = (FIXTURES / "pendulum_world.yaml").read_text()

# case: (behaviour text, world file text or None, (line, col), start of the message)
CASES = {
    "1e309 as a parameter": (BASE.replace("front: 0.5", "front: 1e309"), None, (8, 10), TOO_LARGE),
    "-1e309 as a parameter": (BASE.replace("front: 0.5", "front: -1e309"), None, (8, 10), TOO_LARGE),
    "a million-digit integer": (BASE.replace("front: 0.5", f"front: {MILLION}"), None, (8, 10), TOO_LARGE),
    "a 400-digit seed": (BASE + "seed: " + "1" * 400 + "\n", None, (12, 7), TOO_LARGE),
    "a seed beyond 2**53": (BASE + f"seed: {2 * WHOLE_LIMIT}\n", None, (12, 7), "seed must be a whole number from 0"),
    "1e309 in a rule": (BASE.replace("sonar5 <= front", "sonar5 <= 1e309"), None, (10, 18), TOO_LARGE),
    "a million digits in the stop condition": (BASE.replace("time >= 0.2", f"time >= {MILLION}"), None, (4, 15),
                                               TOO_LARGE),
    "a malformed binary scalar": (BASE.replace("front: 0.5", "front: 0b_"), None, (8, 10),
                                  "'0b_' is no number: labsim files read numbers as YAML 1.2 does"),
    "a malformed hex scalar": (BASE.replace("front: 0.5", "front: 0x_"), None, (8, 10),
                               "'0x_' is no number: labsim files read numbers as YAML 1.2 does"),
    "randint beyond 2**53": (BASE + "let:\n  n: randint(0, 1e300)\n", None, (13, 17), "randint() takes bounds"),
    "a flow list nested 100,000 deep": (BASE + "x: " + "[" * 100_000 + "]" * 100_000 + "\n", None,
                                        (12, 3 + MAX_DEPTH), f"YAML nested more than {MAX_DEPTH} levels"),
    "a block mapping nested 300 deep": (BASE + "x:\n" + "".join(" " * (i + 1) + f"k{i}:\n" for i in range(300)), None,
                                        (13 + MAX_DEPTH - 1, MAX_DEPTH + 1), f"YAML nested more than {MAX_DEPTH}"),
    "1e309 in a world file": (BASE.replace("walls_lab4", "w.yaml"),
                              PENDULUM.replace("gravity: 9.81", "gravity: 1e309"), (6, 12), TOO_LARGE),
    "a 5000-digit integer in a world file": (BASE.replace("walls_lab4", "w.yaml"),
                                             PENDULUM.replace("mass: 2", "mass: " + "2" * 5000), (10, 72), TOO_LARGE),
    "a world path the system refuses": (BASE.replace("walls_lab4", "a" * 5000 + ".yaml"), None, (3, 8),
                                        "world file 'aaaa"),
}


def _write(tmp_path: Path, behaviour: str, world: str | None) -> Path:
    if world is not None:
        (tmp_path / "w.yaml").write_text(world)
    path = tmp_path / "b.yaml"
    path.write_text(behaviour)
    return path


# the megabyte-sized cases take seconds each, so they wait for the whole suite
HEAVY = {"a million-digit integer", "a million digits in the stop condition", "a flow list nested 100,000 deep"}


@pytest.mark.parametrize("case", [pytest.param(c, marks=pytest.mark.slow) if c in HEAVY else c for c in CASES])
def test_a_hostile_file_is_a_positioned_error_from_the_library(tmp_path: Path, case: str) -> None:
    behaviour, world, (line, col), message = CASES[case]
    path = _write(tmp_path, behaviour, world)
    with pytest.raises(LabsimError) as e:
        compile_behaviour(path)
    first = e.value.diagnostics[0]
    assert (first.line, first.col) == (line, col), first.format()
    assert first.message.startswith(message), first.message
    assert len(first.message) < 200  # it quotes a little of the number, not a megabyte of it


@pytest.mark.slow
@pytest.mark.parametrize(("case", "command"), [
    ("1e309 as a parameter", "run"), ("a million-digit integer", "check"), ("a malformed binary scalar", "run"),
    ("a flow list nested 100,000 deep", "check"), ("1e309 in a world file", "run"),
    ("a world path the system refuses", "run")])
def test_a_hostile_file_exits_2_with_the_message_and_no_traceback(tmp_path: Path, case: str, command: str) -> None:
    behaviour, world, (line, col), message = CASES[case]
    path = _write(tmp_path, behaviour, world)
    done = subprocess.run([sys.executable, "-m", "labsim", command, str(path)], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path)
    assert done.returncode == 2, done.stderr[-2000:]
    assert "Traceback" not in done.stderr
    where = f"{path.name if world is None else ''}"
    assert f"{where}:{line}:{col}: error: {message}" in done.stderr


@pytest.mark.parametrize(("setting", "message"), [("front=1e309", TOO_LARGE), ("front=" + "9" * 5000, TOO_LARGE),
                                                  ("front=0x1p3", "is a number, not")])
def test_a_set_value_that_does_not_fit_is_refused(write, setting: str, message: str) -> None:
    done = subprocess.run([sys.executable, "-m", "labsim", "run", str(write(BASE)), "--set", setting],
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert message in done.stderr


@pytest.mark.parametrize(("cell", "message"), [("arm=1e999", TOO_LARGE), ("arm=x", "is not a number")])
def test_a_replayed_setting_that_does_not_fit_is_a_trace_format_error(cell: str, message: str) -> None:
    trace = Trace("t.csv", {}, ["tick", "events"], [["0", ""], ["1", cell]])
    with pytest.raises(TraceFormatError, match=re.escape(message)):
        slider_events(trace)


def test_a_replayed_tick_that_is_no_tick_is_a_trace_format_error() -> None:
    with pytest.raises(TraceFormatError, match="not a tick number"):
        slider_events(Trace("t.csv", {}, ["tick", "events"], [["1e300", "arm=1"]]))


def test_arithmetic_that_outgrows_a_float_gives_inf_not_an_exception(write) -> None:
    # randint's results and ticks are floats in generated code: no int grows past a float's range
    # (21 factors of 2**53 are about 1e335; as Python ints, '/ 3' raised OverflowError)
    product = " * ".join(["r"] * 21)
    ticks = " * ".join(["tick"] * 40)
    behaviour = BASE + (f"let:\n  r: randint(9007199254740990, 9007199254740992)\n  a: {product} / 3 + 0.5\n"
                        f"  t: {ticks} % 7 + {ticks} / 3\n"
                        "  c: pid(a, 1e308, 1e308, 1e308) + (a - a)\nmetrics:\n  top: maximum(a)\n  last: final(c)\n")
    summary = run(write(behaviour.replace("robots:\n  r: {model: pioneer_p3dx, at: [0, 0, 0]}",
                                          "robots:\n  r: {model: pioneer_p3dx, at: random, count: 2}")))
    assert summary["ticks"] > 0


def test_to_float_is_the_one_rule() -> None:
    assert to_float("1e308") == 1e308 and to_float(10 ** 300) == 1e300 and to_float("-inf") == float("-inf")
    for value in ("1e309", 10 ** 400, "9" * 400, "9" * 5000):
        with pytest.raises(NumberError, match="number too large"):
            to_float(value)
    with pytest.raises(NumberError, match="not a number"):
        to_float("0x10")


@pytest.mark.parametrize("seed", [-1, 2 ** 53 + 1, 10 ** 400])
def test_a_seed_given_to_the_library_is_checked_like_the_files(write, seed: int) -> None:
    with pytest.raises(LabsimError, match="the seed is a whole number from 0 to"):
        compile_behaviour(write(BASE), seed=seed)


@pytest.mark.parametrize("text", [f"0-{2 ** 53 + 1}", "9" * 5000])
def test_sweep_seeds_beyond_2_to_the_53_are_refused(text: str) -> None:
    from labsim.runtime.sweep.grid import parse_seeds

    with pytest.raises(LabsimError, match="seeds"):
        parse_seeds(text)


@pytest.mark.parametrize(("old", "new", "col"), [("at 6: hoist = 0,", "at 6: hoist = 1e309,", 11),
                                                 ("at 8: crab", "at 8e999: crab", 5)])
def test_a_timeline_number_that_does_not_fit_is_refused(write, old: str, new: str, col: int) -> None:
    crane = (BEHAVIOURS / "crane.yaml").read_text()
    assert old in crane
    with pytest.raises(LabsimError) as e:
        compile_behaviour(write(crane.replace(old, new)))
    first = e.value.diagnostics[0]
    assert first.message.startswith(TOO_LARGE) and first.col == col, first.format()
