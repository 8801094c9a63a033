"""The holes language 1.2 left in the checker: each was a traceback or a wrong message, now each is
a diagnostic at its place (or a runtime fault naming where, when and which robot)."""
from __future__ import annotations

import math
import random
import subprocess
import sys
from pathlib import Path

import pytest

from labsim.dsl.compile import compile_file
from labsim.dsl.library.support import Faults
from labsim.foundation.diagnostics import LabsimError

HEAD = "labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"
PICK = HEAD + "params:\n  k: 8\nlet:\n  front: sonar1..sonar8\n  pick: front[{index}]\n" \
    "rules:\n  - if pick < 0.5 then arc(-2, 2)\n  - else move(5)\n"


def diagnostics(path: Path, overrides: dict[str, str] | None = None) -> list[tuple[int, int, str, tuple[str, ...]]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path, overrides)
    return [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics]


# -- indexes known before the run ------------------------------------------------------------------

@pytest.mark.parametrize(("index", "overrides", "message", "note"), [
    ("k", None, "this group has 8 members, at places 0 to 7; 'k' is 8", "places count from 0: the first member is [0]"),
    ("k", {"k": "12"}, "this group has 8 members, at places 0 to 7; 'k' is 12",
     "places count from 0: the first member is [0]"),
    ("k", {"k": "0.5"}, "a member is picked by its place, a whole number from 0; 'k' is 0.5",
     "round it, as in front[round(x)], if a fraction is meant to pick the nearest"),
    ("pi", None, "a member is picked by its place, a whole number from 0; 'pi' is 3.14159",
     "round it, as in front[round(x)], if a fraction is meant to pick the nearest"),
    ("dt", None, "a member is picked by its place, a whole number from 0; 'dt' is 0.05",
     "round it, as in front[round(x)], if a fraction is meant to pick the nearest"),
    ("k - 9", None, "this group has 8 members, at places 0 to 7; 'k - 9' is -1",
     "places count from 0: the first member is [0], the last [7]"),
    ("-1", None, "this group has 8 members, at places 0 to 7; not -1",
     "places count from 0: the first member is [0], the last [7]"),
    ("8", None, "this group has 8 members, at places 0 to 7; not 8", "places count from 0: the first member is [0]"),
    ("2.5", None, "a member is picked by its place, a whole number from 0; not 2.5",
     "round it, as in front[round(x)], if a fraction is meant to pick the nearest"),
])
def test_an_index_known_before_the_run_is_checked_at_its_place(write, index: str, overrides: dict[str, str] | None,
                                                               message: str, note: str) -> None:
    path = write(PICK.replace("{index}", index))
    named = tuple(f"with --set {k}={v} of the command line" for k, v in (overrides or {}).items())
    assert diagnostics(path, overrides) == [(10, 15, message, (note, *named))]


def test_an_index_that_is_a_place_runs(write) -> None:
    program = compile_file(write(PICK.replace("{index}", "k - 1")))
    assert "front" in program.let_names
    program = compile_file(write(PICK.replace("{index}", "k")), {"k": "3"})
    assert program.params["k"] == 3


def test_an_index_through_a_function_is_checked_with_the_call_named(write) -> None:
    path = write(HEAD + "functions:\n  pick(g, i): g[i]\n  later(g, i): pick(g, i + 1)\n"
                 "let:\n  front: sonar1..sonar8\n  a: pick(front, 7)\n  b: later(front, 7)\n"
                 "rules:\n  - if a < b then stop()\n")
    assert diagnostics(path) == [(7, 17, "this group has 8 members, at places 0 to 7; 'i' is 8", (
        "places count from 0: the first member is [0]", f"in the call of pick() at {path}:8:16"))]


def test_an_index_known_only_while_running_is_a_fault_naming_rule_tick_and_robot(write) -> None:
    """...and its first print shows its lines, not the escape of a newline (\\x0a)."""
    path = write(HEAD + "let:\n  front: sonar1..sonar8\nrules:\n  - if front[tick + 6] < 0.5 then stop()\n"
                 "  - else move(1)\n")
    proc = subprocess.run([sys.executable, "-m", "labsim", "run", str(path)], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.replace("\r", "").lstrip("\n").splitlines()[:4] == [
        f"{path}:9:8: warning: no member at place 8 of a group of 8 (places count from 0) in rule main:1, robot p, "
        "tick 2",
        "    9 |   - if front[tick + 6] < 0.5 then stop()",
        "      |        ^~~~~~~~~~~~~~~",
        "      = the run goes on with the result above; later occurrences are counted in the summary"]


# -- functions over groups -------------------------------------------------------------------------

def test_a_function_over_a_group_counts_its_members(write) -> None:
    path = write(HEAD + "functions:\n  near(g): count(g < 1)\n  closest(g, d): min(g - d)\n"
                 "let:\n  n: near(sonar1..sonar8)\n  m: closest([sonar2, sonar5], 0.25)\n"
                 "rules:\n  - if n > 2 then stop()\n  - else move(m)\n")
    program = compile_file(path)
    robot = program.robot("p", random.Random(0), Faults())
    values = [math.inf] * len(program.channels)
    for name, v in (("sonar1", 0.5), ("sonar2", 0.9), ("sonar5", 0.4), ("sonar7", 2.0)):
        values[program.channels.index(name)] = v
    robot.signals(0.0, 0, values)
    assert robot.slots[program.slot_of["n"]] == 3.0
    assert robot.slots[program.slot_of["m"]] == pytest.approx(0.15)


# -- large groups ----------------------------------------------------------------------------------

def test_a_group_of_1000_members_checks_and_a_larger_one_is_refused_by_its_limit(write) -> None:
    members = ", ".join(["sonar1", "sonar2"] * 500)
    program = compile_file(write(HEAD + f"let:\n  g: [{members}]\n  s: sum([{members}] * 2)\n  c: count(g < 0.5)\n"
                                 "rules:\n  - if s < c then stop()\n"))
    assert "g" in program.let_names
    path = write(HEAD + f"let:\n  g: [{members}, sonar3]\n" + "rules:\n  - if min(g) < 1 then stop()\n")
    [(line, col, message, notes)] = diagnostics(path)
    assert (line, col, message) == (7, 6, "a group holds at most 1,000 members, and this one has 1,001")


@pytest.mark.slow
def test_a_group_of_100000_members_is_refused_not_a_recursion_error(tmp_path: Path) -> None:
    path = tmp_path / "big.yaml"
    path.write_text(HEAD + "let:\n  a: sonar1\n  g: [" + ", ".join(["a"] * 100_000) + "]\n"
                    "rules:\n  - if min(g) < 1 then stop()\n")
    proc = subprocess.run([sys.executable, "-m", "labsim", "check", str(path)], capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 2
    assert "a group holds at most 1,000 members, and this one has 100,000" in proc.stderr
    assert "Traceback" not in proc.stderr


# -- warnings that see groups ----------------------------------------------------------------------

@pytest.mark.parametrize("error", ["max(sonar8, sonar9)", "max(sonar8..sonar9)", "max([sonar8, sonar9])"])
def test_a_sonar_s_inf_into_pid_is_warned_written_out_or_as_a_group(write, error: str) -> None:
    program = compile_file(write(HEAD + f"rules:\n  - always arc(pid({error} - 0.5, 1, 0, 0), 1)\n"))
    assert [w.message for w in program.warnings] == [
        "pid()'s error reads sonar8, which is inf when nothing is within its range (1 m, the model's range_m): on "
        "those ticks pid() gives its last output again and its state does not change"]


def test_a_group_bounded_by_a_number_keeps_the_inf_out(write) -> None:
    program = compile_file(write(HEAD + "rules:\n  - always arc(pid(min([sonar8, 0.5]) - 0.5, 1, 0, 0), 1)\n"))
    assert program.warnings == ()


# -- the small defects -----------------------------------------------------------------------------

def test_a_whole_number_field_of_a_fraction_shows_the_number_not_its_float_digits(write) -> None:
    path = write(HEAD.replace("time >= 1", "time >= 0.2") + 'rules:\n  - when tick == 3 then log("at {time:d} s, '
                 'tick {tick:d}, {dt * 3:d}")\n  - always move(1)\n')
    proc = subprocess.run([sys.executable, "-m", "labsim", "run", str(path), "-q"], capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.replace("\r", "").strip() == "[0.15 s] p: at 0.15 s, tick 3, 0.15"


def test_an_e_puck_reading_a_sonar_is_told_its_distance_sensors(write) -> None:
    path = write(HEAD.replace("pioneer_p3dx", "epuck") + "rules:\n  - if sonar5 < 0.5 then move(1)\n")
    assert diagnostics(path) == [(7, 8, "unknown name 'sonar5'", (
        "this robot has no sonars; its distance sensors are prox1 .. prox8",))]
    path = write(HEAD + "rules:\n  - if sonar17 < 0.5 then move(1)\n")
    assert diagnostics(path) == [(7, 8, "unknown name 'sonar17' (did you mean 'sonar7'?)", (
        "the robot's sonars are sonar1 .. sonar16, numbered as in CoppeliaSim",))]


ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("change", "errors"), [
    (("model: pioneer_p3dx", "model: pioneer_p3xd"),
     [(17, 20, "unknown robot model 'pioneer_p3xd' (did you mean 'pioneer_p3dx'?)")]),
    (("model: pioneer_p3dx", "modl: pioneer_p3dx"),
     [(17, 3, "robot 'pioneer' needs a 'model:' (e.g. model: pioneer_p3dx)"),
      (17, 13, "unknown robot key 'modl' (did you mean 'model'?)")]),
    (("robots:", "robot:"), [(0, 0, "missing required key 'robots:'"),
                             (16, 1, "unknown key 'robot' (did you mean 'robots'?)")]),
])
def test_a_mistyped_robot_is_one_error_not_one_per_sensor_read(tmp_path: Path, change: tuple[str, str],
                                                             errors: list[tuple[int, int, str]]) -> None:
    path = tmp_path / "wall.yaml"
    path.write_text((ROOT / "behaviours" / "wall_follow.yaml").read_text().replace(*change))
    assert [(line, col, message) for line, col, message, _ in diagnostics(path)] == errors


def test_a_function_called_many_times_on_a_large_group_is_refused_by_a_stated_limit(write) -> None:
    """60 calls of a body of 40 products on a group of 1,000: 4.8 million operations written out
    took the compiler 100 s and 12 GB; now an error, as soon as the count passes the limit."""
    members = ", ".join(["sonar1", "sonar2"] * 500)
    body = " + ".join(["g * k"] * 40)
    calls = " + ".join(f"f(g, {i})" for i in range(60))
    path = write(HEAD + f"functions:\n  f(g, k): sum({body})\nlet:\n  g: [{members}]\n  t: {calls}\n"
                 "rules:\n  - if t > 0 then stop()\n")
    [(line, col, message, notes)] = diagnostics(path)
    assert message == ("the groups of this file are written out to more than 200,000 operations, one per member of "
                       "each (a call of a function, once per call)")
    assert line == 7 and notes[0].startswith("reduce a group once, in a 'let' signal")


def test_the_mean_of_a_group_is_not_an_image_s(write) -> None:
    program = compile_file(write(HEAD + "let:\n  m: mean(sonar1..sonar8)\nrules:\n  - if m < 0 then stop()\n"))
    assert program.warnings == ()  # not "'m < 0' never holds: ... mean() of an image is from 0 to 255"


def test_a_place_from_a_robot_s_own_parameter_is_checked_for_each_robot(write) -> None:
    fleet = HEAD.replace("p: {model: pioneer_p3dx, at: [0, 0, 0]}", "p: {model: pioneer_p3dx, at: random, count: 3, "
                         "params: {k: [0, 5, K]}}")
    body = "params:\n  k: 1\nlet:\n  front: sonar1..sonar8\n  near: front[k]\nrules:\n  - if near < 0.5 then stop()\n"
    assert diagnostics(write(fleet.replace("K", "9") + body)) == [
        (10, 15, "this group has 8 members, at places 0 to 7; 'k' is 9 for robot p[2]",
         ("places count from 0: the first member is [0]",))]
    assert compile_file(write(fleet.replace("K", "7") + body)).warnings == ()
