"""Defects a student found in the language core: each a wrong value, a misplaced caret or a
misleading message, now at its place with the exact words."""
from __future__ import annotations

import random
from pathlib import Path

import pytest

from labsim.dsl.compile import compile_file
from labsim.dsl.library.support import Faults
from labsim.foundation.diagnostics import LabsimError

HEAD = "labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"


def diagnostics(path: Path) -> list[tuple[int, int, str, tuple[str, ...]]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    return [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics]


# -- a function with memory or a random one paired with every member -------------------------------

@pytest.mark.parametrize(("expr", "col", "func", "what", "signal", "use"), [
    ("max(g * 0 + total(1))", 18, "total", "keeps memory from tick to tick", "total(1)", "g * 0 + p"),
    ("any(g < prev(sonar1, 0))", 14, "prev", "keeps memory from tick to tick", "prev(sonar1, 0)", "g < p"),
    ("any(g < random())", 14, "random", "draws a random number", "random()", "g < p"),
    ("count(g < uniform(0, 1))", 16, "uniform", "draws a random number", "uniform(0, 1)", "g < p"),
    ("max(g * counter(tick > 3))", 14, "counter", "keeps memory from tick to tick", "counter(tick > 3)", "g * p"),
    ("max(g + randint(1, 6))", 14, "randint", "draws a random number", "randint(1, 6)", "g + p"),
    ("any(g < 1 and rising(tick > 3))", 20, "rising", "keeps memory from tick to tick", "rising(tick > 3)",
     "g < 1 and p"),
    ("max(-g * (2 + total(1)))", 20, "total", "keeps memory from tick to tick", "total(1)", "-g * (2 + p)"),
])
def test_a_value_with_memory_or_random_paired_with_every_member_is_an_error(
        write, expr: str, col: int, func: str, what: str, signal: str, use: str) -> None:
    path = write(HEAD + f"let:\n  g: [tick, tick, tick, tick]\n  t: {expr}\nrules:\n  - if t > 0 then move(1)\n"
                 "  - else stop()\n")
    assert diagnostics(path) == [(8, col, f"{func}() {what}, but here it is paired with every member of a group, "
                                  "so it would run once per member",
                                  (f"give it a signal of its own: 'p: {signal}', then '{use}'",))]


def test_the_same_call_paired_twice_is_reported_once(write) -> None:
    path = write(HEAD + "let:\n  g: [tick, tick]\n  t: max(g * max(g + total(1)))\nrules:\n"
                 "  - if t > 0 then move(1)\n  - else stop()\n")
    assert [(line, col) for line, col, _, _ in diagnostics(path)] == [(8, 22)]


def test_the_signal_of_its_own_runs_once_a_tick(write) -> None:
    path = write(HEAD + "let:\n  g: [tick, tick, tick, tick]\n  p: total(1)\n  t4: max(g * 0 + p)\n"
                 "  q: random()\n  b: any(g < q)\nrules:\n  - if t4 > 0 and b then move(1)\n  - else stop()\n")
    program = compile_file(path)
    assert "t4" in program.let_names


# -- a missing member's place, counted once per place in the file -----------------------------------

def test_a_place_with_no_member_is_one_warning_and_one_count_however_many_values_it_takes(write) -> None:
    path = write(HEAD + "let:\n  g: sonar1..sonar8\n  h: tick / 3\n  j: tick % 10\n  w: g[h]\n  v: g[j]\n"
                 "rules:\n  - if w < v then stop()\n  - else move(1)\n")
    program = compile_file(path)
    printed: list[str] = []
    faults = Faults(printed.append)
    robot = program.robot("p", random.Random(0), faults)
    for tick in range(60):
        robot.signals(tick * 0.05, tick, [1.0] * len(program.channels))
    assert [p.splitlines()[0] for p in printed] == [
        f"{path}:10:6: warning: no member at place 0.333333 of a group of 8 (places count from 0) in signal 'w', "
        "robot p, tick 1",
        f"{path}:11:6: warning: no member at place 8 of a group of 8 (places count from 0) in signal 'v', "
        "robot p, tick 8"]
    assert sorted((site.where, what, n, faults.first[(site, what)]) for (site, what), n in faults.counts.items()) == [
        ("signal 'v'", "no member at the place asked of a group of 8 (places count from 0)", 12, (8, "p")),
        ("signal 'w'", "no member at the place asked of a group of 8 (places count from 0)", 52, (1, "p"))]


# -- a group written as YAML's list: each member at its own column ----------------------------------

@pytest.mark.parametrize(("group", "col", "end"), [
    ("[sonar4, [sonar5]]", 15, 23),
    ("[[sonar1, sonar2], sonar3]", 7, 23),
    ("[sonar4, 'a']", 15, 18),
])
def test_a_member_of_a_group_written_as_a_yaml_list_is_reported_at_its_column(write, group: str, col: int,
                                                                              end: int) -> None:
    path = write(HEAD + f"let:\n  g: {group}\nrules:\n  - if min(g) < 1 then stop()\n")
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    [d] = e.value.diagnostics
    assert (d.line, d.col, d.end_col) == (7, col, end)
    assert d.message.startswith("a group's members are all numbers or all booleans; this one is ")


# -- the smaller ones ----------------------------------------------------------------------------------

def test_functions_expanding_too_far_are_one_error_at_the_call_in_the_file_s_expression(write) -> None:
    chain = "".join(f"  f{i}(x): f{i - 1}(x) + f{i - 1}(x)\n" for i in range(1, 26))
    path = write(HEAD + "functions:\n  f0(x): x + 1\n" + chain + "let:\n  yy: f25(sonar1)\n"
                 "rules:\n  - if yy < 1 then stop()\n")
    assert diagnostics(path) == [(34, 7, "the calls of this file's functions expand to more than 20,000 operations "
                                  "(a function's body, once per call)",
                                  ("a function that calls another several times, which calls another several times, "
                                   "grows fast: compute shared parts once, in 'let' signals",))]


def test_a_place_that_is_infinite_is_not_told_to_round(write) -> None:
    path = write(HEAD + "let:\n  front: sonar1..sonar8\n  xx: front[inf]\n  yy: front[-inf]\n"
                 "rules:\n  - if xx < yy then stop()\n")
    assert diagnostics(path) == [
        (8, 13, "a member is picked by its place, a whole number from 0; 'inf' is inf",
         ("this group's places are 0 to 7",)),
        (9, 13, "a member is picked by its place, a whole number from 0; '-inf' is -inf",
         ("this group's places are 0 to 7",))]


def test_a_function_whose_definition_failed_leaves_its_calls_quiet(write) -> None:
    path = write(HEAD + "functions:\n  f(a, a): a\n  g(a, 1b): a\nlet:\n  yy: f(1, 2) + f(2, 3) + g(1, 2)\n"
                 "rules:\n  - if yy < 1 then stop()\n")
    assert [(line, col, message) for line, col, message, _ in diagnostics(path)] == [
        (7, 8, "function 'f' names its parameter 'a' twice"),
        (8, 8, "'1b' is not a valid parameter name: use letters, digits and '_', starting with a letter")]


def test_a_colon_in_an_expression_is_not_said_to_be_a_rule_s(write) -> None:
    path = write(HEAD + "let:\n  q: \"sonar1: 2\"\nrules:\n  - if q < 1 then stop()\n")
    assert diagnostics(path) == [(7, 13, "unexpected ':' in an expression", ())]


def test_the_hint_for_a_long_expression_stays_short(write) -> None:
    members = ", ".join(["tick"] * 40)
    path = write(HEAD + f"let:\n  t: max([{members}] + total(1))\nrules:\n  - if t > 0 then move(1)\n"
                 "  - else stop()\n")
    [(_, _, _, notes)] = diagnostics(path)
    assert notes == ("give it a signal of its own: 'p: total(1)', then 'p' in its place",)
