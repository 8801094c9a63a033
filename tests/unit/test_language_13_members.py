"""Language 1.3, member by member: a built-in given a group applies to each member (a memory per
member for one with memory), slices ``g[a:b]``, and the same files refused in format 1.2
(docs/language.md, "Member by member")."""
from __future__ import annotations

import math
import random
from pathlib import Path

import pytest
from helpers import examples, run_example

from labsim.dsl.analysis.evaluate import Members, Memory, evaluate
from labsim.dsl.compile import compile_file
from labsim.dsl.emit.program import Program
from labsim.dsl.library.support import Faults
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.parse import ParseError, parse_expr
from labsim.foundation.diagnostics import LabsimError

HEAD = ("labsim: {v}\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {{model: pioneer_p3dx, at: [0, 0, 0]}}\n"
        "params: {{k: 2, half: 0.5}}\nfunctions:\n  near(d): d < 0.4\n  nearer(a, b): a if a < b else b\n"
        "let:\n  front: sonar1..sonar8\n"
        "  side: [sonar8, sonar9]\n")
RULES = "rules:\n  - if count(front < 1) > 0 then move(1)\n  - else stop()\n"
SPAN = "a slice [a:b] takes the places from a up to b, not including b: this group's [0:8] is all of its 8 members"
GROUP_HINT = ("a group holds one value per member: take min(...), max(...), mean(...), sum(...), argmin(...) or "
              "argmax(...) of it, or one member, as in front[0]")


def diagnostics(path: Path) -> list[tuple[int, int, str, tuple[str, ...]]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    return [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics]


def later(what: str) -> str:
    return f"{what} is format 1.3: start the file with 'labsim: 1.3'"


# -- the parser: a slice's spans ---------------------------------------------------------------------

def test_a_slice_parses_with_its_spans() -> None:
    e = parse_expr("min(front[2:k + 1])")
    assert isinstance(e, ast.Call)
    s = e.args[0]
    assert s == ast.Slice(ast.Name("front"), ast.Number(2.0), ast.Binary("+", ast.Name("k"), ast.Number(1.0)))
    assert isinstance(s, ast.Slice) and s.lower is not None and s.upper is not None
    assert (s.span, s.value.span, s.lower.span, s.upper.span) == ((4, 18), (4, 9), (10, 11), (12, 17))


@pytest.mark.parametrize(("text", "lower", "upper"), [
    ("g[:3]", None, ast.Number(3.0)), ("g[3:]", ast.Number(3.0), None), ("g[:]", None, None),
    ("g[ 1 : 2 ]", ast.Number(1.0), ast.Number(2.0)),
])
def test_a_bound_may_be_left_out(text: str, lower: ast.Expr | None, upper: ast.Expr | None) -> None:
    assert parse_expr(text) == ast.Slice(ast.Name("g"), lower, upper)


def test_slices_and_places_chain() -> None:
    e = parse_expr("(front - 1)[1:5][0:2][1]")
    assert isinstance(e, ast.Index) and isinstance(e.value, ast.Slice) and isinstance(e.value.value, ast.Slice)
    assert (e.span, e.value.span, e.value.value.span) == ((0, 24), (0, 21), (0, 16))


@pytest.mark.parametrize(("text", "start", "message"), [
    ("g[1:2:3]", 5, "expected an operator or ']', found ':'"),
    ("sonar1: 2", 6, "unexpected ':' in an expression"),  # outside brackets, as before slices
    ("g[1:2", 5, "expected an operator or ']', found the end of the text"),
    ("g[1 2]", 4, "expected an operator or ']', found '2'"),
    ("[g[0:1], 2 3]", 11, "expected an operator, ',' or ']', found '3'"),
])
def test_a_misplaced_colon_is_said_where_it_is(text: str, start: int, message: str) -> None:
    with pytest.raises(ParseError) as e:
        parse_expr(text)
    assert (e.value.start, e.value.message) == (start, message)


# -- the checker: what each mistake says, where ------------------------------------------------------

@pytest.mark.parametrize(("expr", "col", "message", "notes"), [
    ("min(front, side)[0]", 17,
     "'min()' pairs the members of two groups, which need one size: this has 2 members and the first 8",
     ("to pair the first 2 members of each, slice the larger: front[0:2]",)),
    ("clamp(side, front - 1, 1)[0]", 18,
     "'clamp()' pairs the members of two groups, which need one size: this has 8 members and the first 2",
     ("to pair the first 2 members of each, slice the larger: (front - 1)[0:2]",)),
    ("front[0:9][0]", 14, "this group has 8 members, so a slice's bound is at most 8; not 9", (SPAN,)),
    ("front[-1:2][0]", 12, "a slice's bound is a place from 0, and a slice does not count from the end; not -1",
     (SPAN,)),
    ("front[0.5:2][0]", 12, "a slice's bound is a whole number; not 0.5", (SPAN,)),
    ("front[k:half][0]", 14, "a slice's bound is a whole number; 'half' is 0.5", (SPAN,)),
    ("front[k * 5:][0]", 12, "this group has 8 members, so a slice's bound is at most 8; 'k * 5' is 10", (SPAN,)),
    ("front[3:3][0]", 6, "this slice is empty: [3:3] takes the places from 3 up to 3, not including 3",
     ("[0:4] takes places 0, 1, 2 and 3",)),
    ("front[5:2][0]", 6, "this slice is empty: [5:2] takes the places from 5 up to 2, not including 2",
     ("[0:4] takes places 0, 1, 2 and 3",)),
    ("side[1:1][0]", 6, "this slice is empty: [1:1] takes the places from 1 up to 1, not including 1",
     ("[1:2] takes place 1",)),
    ("side[2:2][0]", 6, "this slice is empty: [2:2] takes the places from 2 up to 2, not including 2",
     ("[1:2] takes place 1",)),
    ("front[sonar1:3][0]", 12, "a slice's bounds are known before the run, the same for every robot: 'sonar1' is "
     "known only while running",
     ("a group's size is fixed when the file is compiled: write numbers or parameters every robot shares; to pick "
      "one member while running, use front[k]",)),
    ("front[true:3][0]", 12, "a slice's bound is a place, a number from 0; this is a boolean", ()),
    ("sonar5[0:1][0]", 6, "only a group has members to slice with [a:b]; this is a number",
     ("a slice takes a run of a group's members, as in front[0:4] of front: sonar1..sonar8",)),
    ("clamp(front, 0, prev(sonar1, 0))[0]", 22,
     "prev() keeps memory from tick to tick, but here it is paired with every member of a group, so it would run "
     "once per member", ("give it a signal of its own: 'p: prev(sonar1, 0)', then 'clamp(front, 0, p)'",)),
    ("max(front, uniform(0, 1))[0]", 17,
     "uniform() draws a random number, but here it is paired with every member of a group, so it would run once "
     "per member", ("give it a signal of its own: 'p: uniform(0, 1)', then 'max(front, p)'",)),
    ("prev(front, true)[0]", 18,
     "prev()'s initial value must be a number like each member of its first argument, but this is a boolean", ()),
    ("abs(near(front))[0]", 10, "argument 1 of abs() must be a number, but this is a group of booleans",
     ("a group holds one value per member: take any(...), all(...) or count(...) of it",)),
    ("count(detected(front))", 21, "detected() takes a distance sensor's name (sonar1 .. sonar16), and 'front' is "
     "not one", ("which members of a group see something: compare them, as in front < inf",)),
    ("count(detected(sonar1..sonar3))", 12, "detected() takes one distance sensor's name, as in detected(sonar5)",
     ("which members of a group see something: compare them, as in sonar1..sonar3 < inf",)),
    ("(front if side < 1 else 0)[0]", 7, "'a if condition else b' pairs the members of two groups, which need one "
     "size: this has 8 members and the first 2",
     ("to pair the first 2 members of each, slice the larger: front[0:2]",)),
    ("(front if front else 0)[0]", 16, "the condition of 'a if condition else b' must be a boolean or a group of "
     "them, but this is a group of numbers", ()),
    ("(front if front < 1 else true)[0]", 7, "both sides of 'a if condition else b' must have one type, member by "
     "member, not a group of numbers and a boolean", ()),
    ("(front if front < 1 else prev(sonar1, 0))[0]", 31,
     "prev() keeps memory from tick to tick, but here it is paired with every member of a group, so it would run "
     "once per member", ("give it a signal of its own: 'p: prev(sonar1, 0)', then 'front if front < 1 else p'",)),
])
def test_a_mistake_member_by_member_is_said_at_its_place(write, expr: str, col: int, message: str,
                                                         notes: tuple[str, ...]) -> None:
    path = write(HEAD.format(v="1.3") + f"  t: {expr}\n" + RULES)
    assert diagnostics(path) == [(13, col, message, notes)]


@pytest.mark.parametrize(("rule", "col", "message", "notes"), [
    ("if near(front) then stop()", 8, "a rule's condition must be a boolean, but this is a group of booleans",
     ("a group holds one value per member: take any(...), all(...) or count(...) of it",)),
    ("if clamp(front, 0, 1) > 0.5 then stop()", 8,
     "a rule's condition must be a boolean, but this is a group of booleans",
     ("a group holds one value per member: take any(...), all(...) or count(...) of it",)),
    ("always arc(clamp(front, 0, 1), 1)", 16, "an argument of arc() must be a number, but this is a group of numbers",
     (GROUP_HINT,)),
    ("always arc(front[0:2], 1)", 16, "an argument of arc() must be a number, but this is a group of numbers",
     (GROUP_HINT,)),
])
def test_a_group_where_one_value_is_needed_says_how_to_reduce_it(write, rule: str, col: int, message: str,
                                                                 notes: tuple[str, ...]) -> None:
    path = write(HEAD.format(v="1.3") + f"rules:\n  - {rule}\n")
    assert diagnostics(path) == [(14, col, message, notes)]


def test_what_is_right_checks(write) -> None:
    path = write(HEAD.format(v="1.3") + "  t: min(front[:k]) + max(front[k * 3:]) + front[:][7] + sum(prev(front, 0))\n"
                 "  u: near(front)\n  v: min(front, 1)\n  w: clamp(front, side[0], 1)\n  up: rising(front < 1)\n"
                 "  last: prev(front < 1, false)\n  z: max(front[0:2], side)\n  c: front if front < 1 else 1\n"
                 "  d: nearer(front, side[1]) if k > 1 else -front\n" + RULES)
    program = compile_file(path)
    assert {g.name: g.size for g in program.group_signals} == {"front": 8, "side": 2, "u": 8, "v": 8, "w": 8,
                                                                "up": 8, "last": 8, "z": 2, "c": 8,
                                                                "d": 8}


@pytest.mark.parametrize(("expr", "col", "message", "notes"), [
    ("clamp(front, 0, 1)[0]", 12, "argument 1 of clamp() must be a number, but this is a group of numbers",
     (GROUP_HINT, later("applying clamp() to each member of a group"))),
    ("min(front, 1)[0]", 10, "argument 1 of min() must be a number, but this is a group of numbers",
     (GROUP_HINT, later("applying min() to each member of a group"))),
    ("rising(front < 1)[0]", 13, "argument 1 of rising() must be a boolean, but this is a group of booleans",
     ("a group holds one value per member: take any(...), all(...) or count(...) of it",
      later("applying rising() to each member of a group"))),
    ("prev(front, 0)[0]", 11, "prev() keeps a number or a boolean, not a group of numbers",
     (later("applying prev() to each member of a group"),)),
    ("front[0:4][0]", 6, later("a slice [a:b]"), ()),
    ("(front if front < 1 else 1)[0]", 16, "the condition of 'a if condition else b' must be a boolean, but this is "
     "a group of booleans", ("a group holds one value per member: take any(...), all(...) or count(...) of it",
                             later("choosing member by member"))),
    ("(front if k > 1 else 1)[0]", 7, "'a if condition else b' chooses between two values, not groups: choose "
     "between members or reductions of them", (later("choosing member by member"),)),
])
def test_format_12_refuses_what_13_added(write, expr: str, col: int, message: str, notes: tuple[str, ...]) -> None:
    path = write(HEAD.format(v="1.2") + f"  t: {expr}\n" + RULES)
    assert diagnostics(path) == [(13, col, message, notes)]


# -- tick by tick: the generated code, and the reference evaluator beside it ------------------------

MEMORY_LETS = {  # name -> expression; every one member by member over g, a memory per member
    "up": "rising(g > 0.5)", "down": "falling(g > 0.5)", "n": "counter(g > 0.5)", "sum_": "total(g)",
    "last": "prev(g, -1)", "latch": "hold(g > 0.5, g < 0.2)", "since": "held(g > 0.5)", "kept": "remember(g, g > 0.5)",
    "ctl": "pid(g - 0.5, 1, 0.5, 0.25)", "noisy": "gauss(g, 1)", "lim": "clamp(g, 0.3, 0.7)", "low": "min(g, 0.4)",
    "pair": "max(g, [0.45, 0.45, 0.45])",
    "mid": "g[1:]", "rounded": "round(g[1:] * 3) / 3", "chosen": "g if g < 0.5 else [1, 2, 3]",
}
# the three sonars' readings, tick by tick: each member rises and falls at ticks of its own
READINGS = [(0.9, 0.1, 0.3), (0.1, 0.9, 0.3), (0.9, 0.9, 0.6), (0.6, 0.1, 0.1), (0.1, 0.6, 0.9), (0.9, 0.9, 0.9)]


def _program(write) -> Program:
    lets = "".join(f"  {name}: {expr}\n" for name, expr in MEMORY_LETS.items())
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"
                 "let:\n  g: sonar1..sonar3\n" + lets + "rules:\n  - always stop()\n")
    return compile_file(path)


def _members(program: Program, slots: list[float], name: str, readings: tuple[float, ...]) -> tuple[object, ...]:
    """A group signal's members after a tick: from its slots, or (a group of names, or a slice of
    one, which has none: its uses read the names) from the readings it names."""
    signal = next(g for g in program.group_signals if g.name == name)
    if signal.slots is None:
        assert signal.expr == "g[1:]"
        return readings[1:]
    return tuple(slots[k] for k in signal.slots)


def test_each_member_keeps_its_own_memory_tick_by_tick(write) -> None:
    program = _program(write)
    robot = program.robot("p", random.Random(7), Faults())
    got: dict[str, list[tuple[object, ...]]] = {name: [] for name in MEMORY_LETS}
    for tick, readings in enumerate(READINGS):
        robot.signals(tick * 0.05, tick, [*readings, *[math.inf] * (len(program.channels) - 3)])
        for name in MEMORY_LETS:
            got[name].append(_members(program, robot.slots, name, readings))
    assert got["up"] == [(False, False, False), (False, True, False), (True, False, True), (False, False, False),
                         (False, True, True), (True, False, False)]  # format 1.2 on: the first tick only primes
    assert got["down"] == [(False, False, False), (True, False, False), (False, False, False), (False, True, True),
                           (True, False, False), (False, False, False)]
    assert got["n"] == [(0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (1.0, 1.0, 1.0), (1.0, 1.0, 1.0), (1.0, 2.0, 2.0),
                        (2.0, 2.0, 2.0)]
    assert got["last"][:3] == [(-1.0, -1.0, -1.0), (0.9, 0.1, 0.3), (0.1, 0.9, 0.3)]
    assert got["latch"] == [(True, False, False), (False, True, False), (True, True, True), (True, False, False),
                            (False, True, True), (True, True, True)]  # reset below 0.2
    assert got["since"][2] == (0.0, 0.05, 0.0) and got["since"][3] == (0.05, 0.0, 0.0)
    assert got["kept"][3] == (0.6, 0.9, 0.6)
    assert got["lim"][0] == (0.7, 0.3, 0.3) and got["low"][0] == (0.4, 0.1, 0.3)
    assert got["mid"][4] == (0.6, 0.9) and got["rounded"][0] == (0.0, 1 / 3)
    assert got["chosen"][0] == (1.0, 0.1, 0.3) and got["chosen"][2] == (1.0, 2.0, 3.0)
    assert len(set(got["noisy"][0])) == 3  # a draw a member


def test_the_evaluator_gives_what_the_generated_code_gives_tick_by_tick(write) -> None:
    program = _program(write)
    robot = program.robot("p", random.Random(7), Faults())
    memory = Memory(0.05, 1.3)
    rng = random.Random(7)
    nodes = {name: parse_expr(expr) for name, expr in MEMORY_LETS.items()}
    for tick, readings in enumerate(READINGS):
        robot.signals(tick * 0.05, tick, [*readings, *[math.inf] * (len(program.channels) - 3)])
        names = {"g": Members(readings), "time": tick * 0.05, "tick": tick, "dt": 0.05}
        for name, node in nodes.items():  # in the file's order, as the robot draws its numbers
            value, faults = evaluate(node, names, rng, memory=memory)
            assert value == _members(program, robot.slots, name, readings), (tick, name)
            assert faults == ()


# -- the worked example ------------------------------------------------------------------------------

def test_the_lidar_sectors_example_checks_without_warnings_and_runs(tmp_path: Path) -> None:
    path = tmp_path / "sectors.yaml"
    path.write_text(examples()["lidar_sectors"])
    assert compile_file(path).warnings == ()
    _, summary, warned = run_example("lidar_sectors", tmp_path)
    metrics = summary.robots["pioneer"].metrics  # type: ignore[attr-defined]
    assert warned == []
    assert 0.3 < metrics["closest"] < 0.6 and metrics["came_near"] >= 2


def test_a_robot_s_own_parameter_is_no_slice_bound(write) -> None:
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: random, "
                 "count: 2, params: {k: [2, 3]}}\nparams:\n  k: 2\nlet:\n  front: sonar1..sonar8\n"
                 "  t: min(front[0:k + 1])\nrules:\n  - if t < 1 then stop()\n  - else move(1)\n")
    assert diagnostics(path) == [(10, 18, "a slice's bounds are known before the run, the same for every robot: "
                                  "'k + 1' reads a parameter each robot sets for itself",
                                  ("a group's size is fixed when the file is compiled: write numbers or parameters "
                                   "every robot shares; to pick one member while running, use front[k]",))]


def test_a_log_field_may_slice_and_still_take_a_format(write) -> None:
    path = write(HEAD.format(v="1.3") + "rules:\n  - when rising(sonar1 < 1) then log(\"near {min(front[0:2]):.2f} "
                 "{front[1:][0]}\")\n  - else stop()\n")
    [(_, parts)] = compile_file(path).logs
    assert parts[0] == "near " and parts[1][1] == ".2f" and parts[3][1] == ""


def test_a_breakpoint_slices_with_the_file_s_shared_parameters(write) -> None:
    from labsim.dsl.watch import compile_watch

    path = write(HEAD.format(v="1.3") + RULES)
    watch = compile_watch(compile_file(path), "min(front[k:k * 3]) < 1 and any(near(side[0:1]))")
    assert watch.reads == ("front", "k", "side")
    with pytest.raises(LabsimError) as e:
        compile_watch(compile_file(path), "min(front[0:sonar1]) < 1")
    assert [(d.line, d.col, d.message) for d in e.value.diagnostics] == [
        (1, 13, "a slice's bounds are known before the run, the same for every robot: 'sonar1' is known only while "
                "running")]


def test_the_lidar_sectors_example_in_format_12_is_refused_saying_it_is_13(tmp_path: Path) -> None:
    path = tmp_path / "sectors.yaml"
    path.write_text(examples()["lidar_sectors"].replace("labsim: 1.3", "labsim: 1.2"))
    found = diagnostics(path)  # each slice, where it is; what uses the slices says nothing more
    assert {(message, notes) for _, _, message, notes in found} == {(later("a slice [a:b]"), ())}
    assert [(line, col) for line, col, _, _ in found][:2] == [(13, 18), (13, 35)] and len(found) == 11


def test_a_signal_that_slices_a_scan_is_read_where_it_is_used(write) -> None:
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0], "
                 "lidar: {beams: 360}}\nlet:\n  scan: lidar1..lidar360\n  ahead: scan[135:225]\n"
                 "  middle: ahead[40:50]\n  m: min(ahead)\n  a: argmin(ahead)\n  n: mean(middle)\nrules:\n"
                 "  - if m + a + n < 1 then stop()\n"
                 "  - else move(1)\n")
    program = compile_file(path)
    assert {g.name: g.slots for g in program.group_signals} == {"scan": None, "ahead": None, "middle": None}
    source = program.code.source  # one call on the backend's list of beams, and no local per beam
    assert "_min_of(values[135:225])" in source and "_argmin_at(values[135:225], " in source
    assert "_sum_of(values[175:185]) / 10.0" in source and "v200" not in source


@pytest.mark.parametrize(("expr", "col", "message"), [
    ("front[1:2:3][0]", 15, "expected an operator or ']', found ':'"),
    ("front[1 2][0]", 14, "expected an operator or ']', found '2'"),
    ("min([front[0:1], 2 3])", 25, "expected an operator, ',' or ']', found '3'"),
])
def test_a_slice_s_syntax_error_is_at_its_line_and_column(write, expr: str, col: int, message: str) -> None:
    path = write(HEAD.format(v="1.3") + f"  t: {expr}\n" + RULES)
    assert [(line, c, m) for line, c, m, _ in diagnostics(path)] == [(13, col, message)]


def test_a_reduction_runs_every_member_s_memory_and_draw_on_every_tick(write) -> None:
    """any(rising(c)): the second member's rising() runs on tick 3 though the first decided, so it
    does not rise again on tick 4; all() likewise; every member draws its random number."""
    path = write("labsim: 1.3\nworld: walls_lab4\nseed: 2\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 "let:\n  c: '[tick >= 3, tick >= 3]'\n  inline: any(rising(c))\n  both: all(rising(c))\n"
                 "  first: any(uniform([0, 0, 0], 1) > -1)\n  after: random()\n"
                 "rules:\n  - always stop()\n")
    program = compile_file(path)
    robot = program.robot("p", random.Random(2), Faults())
    seen = []
    for tick in range(6):
        robot.signals(tick * 0.05, tick, [math.inf] * len(program.channels))
        seen.append(tuple(robot.slots[program.slot_of[n]] for n in ("inline", "both", "first", "after")))
    assert [s[:3] for s in seen] == [(False, False, True)] * 3 + [(True, True, True)] + [(False, False, True)] * 2
    draws = random.Random(2)
    for s in seen:  # three draws for the group, then random()'s: the fourth of the tick
        for _ in range(3):
            draws.uniform(0, 1)
        assert s[3] == draws.random()


def _self_reading(write, lets: str) -> tuple[Program, object]:
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n"
                 "let:\n  g: sonar1..sonar3\n" + lets + "rules:\n  - if min(smooth) < 0.3 then stop()\n"
                 "  - else move(1)\n")
    program = compile_file(path)
    return program, program.robot("p", random.Random(7), Faults())


def test_a_group_signal_reads_each_member_s_own_last_value(write) -> None:
    """smooth: 0.5 * prev(smooth, g) + 0.5 * g, member by member, from the first tick's readings; and one
    reading all of its last members (the largest of them): every member is computed from the last tick's."""
    program, robot = _self_reading(write, "  smooth: 0.5 * prev(smooth, g) + 0.5 * g\n"
                                          "  top: prev(top, [0, 0, 0]) + max(prev(top, [0, 0, 0])) + 1\n"
                                          "  one: 0.5 * prev(one, 1) + 0.5 * g\n")  # every member from 1
    seen: dict[str, list[tuple[object, ...]]] = {"smooth": [], "top": [], "one": []}
    for tick, readings in enumerate(READINGS[:4]):
        robot.signals(tick * 0.05, tick, [*readings, *[math.inf] * (len(program.channels) - 3)])  # type: ignore
        for name in seen:
            seen[name].append(_members(program, robot.slots, name, readings))  # type: ignore[attr-defined]
    last = READINGS[0]
    for tick, readings in enumerate(READINGS[:4]):  # each member from its own: 0.5 * last + 0.5 * reading
        last = tuple(0.5 * a + 0.5 * b for a, b in zip(last, readings))
        assert seen["smooth"][tick] == last
    assert seen["smooth"][:2] == [(0.9, 0.1, 0.3), (0.5, 0.5, 0.3)]
    assert seen["one"][0] == (0.5 * 1.0 + 0.5 * 0.9, 0.5 * 1.0 + 0.5 * 0.1, 0.5 * 1.0 + 0.5 * 0.3)
    assert seen["one"][1] == tuple(0.5 * a + 0.5 * b for a, b in zip(seen["one"][0], READINGS[1]))
    assert seen["top"] == [(1.0, 1.0, 1.0), (3.0, 3.0, 3.0), (7.0, 7.0, 7.0), (15.0, 15.0, 15.0)]


@pytest.mark.parametrize(("let", "col", "message", "notes"), [
    ("[prev(smooth, 1) + 1, 2, 3]", 25, "signal 'smooth' is a group of 3 numbers, so prev(smooth, ...) starts "
     "from a group of 3 too, a value for each member; this is a number",
     ("start each member from its own value, as in prev(smooth, [1, 1, 1])",)),
    ("prev(smooth, [0, 0, 0])[0:2]", 24, "signal 'smooth' has 2 members, so prev(smooth, ...) starts from as many; "
     "this has 3", ()),
    ("prev(smooth, g) < 1", 24, "signal 'smooth' is a group of booleans, so prev(smooth, ...) starts from a group "
     "of booleans too; this is a group of numbers", ()),
])
def test_a_group_signal_reading_itself_from_the_wrong_start_is_said_at_the_start(write, let: str, col: int,
                                                                                 message: str,
                                                                                 notes: tuple[str, ...]) -> None:
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 f"let:\n  g: sonar1..sonar3\n  smooth: {let}\nrules:\n  - if any(smooth < 1) then stop()\n")
    assert diagnostics(path) == [(8, col, message, notes)]


def test_a_group_signal_reading_itself_is_format_1_3(write) -> None:
    path = write("labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 "let:\n  g: sonar1..sonar3\n  smooth: prev(smooth, g) + g\n"
                 "rules:\n  - if min(smooth) < 1 then stop()\n")
    assert diagnostics(path) == [(8, 24, "prev() keeps a number or a boolean, not a group of numbers",
                                  (later("a group signal reading its own members"),))]


def test_len_of_a_group_and_a_rounding_of_what_is_known_are_known_before_the_run(write) -> None:
    """front[1:len(front)], a function's d[1:len(d)] for groups of two sizes, front[round(k)]: sliced and
    picked by the places they fold to; each sonar reads its number, so the values say which members."""
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 "params:\n  k: 2.2\n  wp: [[1, 2], [3, 4], [5, 6]]\nfunctions:\n  tail(d): d[1:len(d)]\n"
                 "  last(d): d[len(d) - 1]\nlet:\n  front: sonar1..sonar8\n  side: [sonar8, sonar9]\n"
                 "  a: min(front[1:len(front)])\n  b: sum(tail(front)) + 100 * min(tail(side)) + 1000 * last(side)\n"
                 "  c: front[round(k)] + 10 * front[floor(k):ceil(k)][0] + 100 * wp[round(k)][1]\n"
                 "  d: min(front[round(k + 3):])\nrules:\n  - if a + b + c + d > 1 then stop()\n")
    program = compile_file(path)
    robot = program.robot("p", random.Random(1), Faults())
    robot.signals(0.0, 0, [float(ch[5:]) if ch.startswith("sonar") else 0.0 for ch in program.channels])
    assert [robot.slots[program.slot_of[n]] for n in "abcd"] == [2.0, 35.0 + 900.0 + 9000.0, 3.0 + 30.0 + 600.0, 6.0]


@pytest.mark.parametrize(("expr", "col", "message"), [
    ("front[len(front)]", 12, "this group has 8 members, at places 0 to 7; 'len(front)' is 8"),
    ("front[round(k)]", 12, "this group has 8 members, at places 0 to 7; 'round(k)' is 9"),
    ("min(front[2:len(front) + 1])", 18, "this group has 8 members, so a slice's bound is at most 8; "
                                         "'len(front) + 1' is 9"),
])
def test_a_place_from_len_or_a_rounding_outside_the_group_is_an_error_before_the_run(write, expr: str, col: int,
                                                                                   message: str) -> None:
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 f"params:\n  k: 9.2\nlet:\n  front: sonar1..sonar8\n  a: {expr}\nrules:\n  - if a > 1 then stop()\n")
    assert [d[:3] for d in diagnostics(path)] == [(10, col, message)]


@pytest.mark.parametrize(("expr", "message", "notes"), [
    ("sum(front, 1)", "sum() takes 1 argument, a group of numbers, given 2",
     ("sum() of a group: sum(front) is the members added up", "to add values, write a + b")),
    ("any(a, b)", "any() takes 1 argument, a group of booleans, given 2",
     ("any() of a group: any(front < 0.5) is true if a member is true", "of two conditions, write a or b")),
    ("argmin(front, 1)", "argmin() takes 1 argument, a group of numbers, given 2",
     ("argmin() of a group: argmin(front) is where the smallest member is, counted from 0 (the first of equals)",
      "to pick the smaller of values, write min(a, b)")),
    ("mean(front, front)", "mean() takes 1 argument, a group of numbers or an image, given 2",
     ("mean() of a group: mean(front) is the members' mean",)),
    ("min()", "min() takes a group, or at least 2 numbers, given 0",
     ("min() of a group: min(front) is the smallest member; nan if one is nan",)),
    ("count(front < 1, 2)", "count() takes 1 argument, a group of booleans, given 2",
     ("count() of a group: count(front < 0.5) is how many members are true",
      "counter(c) counts the ticks c became true on")),
])
def test_a_reduction_given_other_than_one_group_says_what_it_takes(write, expr: str, message: str,
                                                                   notes: tuple[str, ...]) -> None:
    path = write(HEAD.format(v="1.3") + f"  a: sonar1 < 1\n  b: sonar2 < 1\n  v: {expr}\n{RULES}")
    assert diagnostics(path) == [(15, 6, message, notes)]


def test_an_unknown_function_is_told_the_names_len_and_the_reductions_among_them(write) -> None:
    path = write(HEAD.format(v="1.3") + f"  v: lenx(front)\n{RULES}")
    [(line, col, message, notes)] = diagnostics(path)
    assert (line, col, message) == (13, 6, "unknown function 'lenx' (did you mean 'len'?)")
    assert notes[0].startswith("the nearest: len, exp, mean; functions: abs, all, any, area, argmax, argmin, ")
    assert ", len, " in notes[0] and ", sum, " in notes[0] and ", count, " in notes[0]


@pytest.mark.parametrize("name", ["wheel_left", "start_heading"])
def test_a_breakpoint_reading_back_in_a_format_12_file_says_it_is_13(write, name: str) -> None:
    from labsim.dsl.watch import compile_watch

    program = compile_file(write(HEAD.format(v="1.2") + RULES))
    with pytest.raises(LabsimError) as e:
        compile_watch(program, f"sonar1 < 1 and {name} >= 0")
    assert [(d.path, d.line, d.col, d.message) for d in e.value.diagnostics] == [
        ("--break", 1, 16, later(f"'{name}'"))]


def test_a_memory_for_each_of_many_members_is_kept_past_the_guards_named_one_by_one(write) -> None:
    """300 beams through total() and rising(): 600 memories, past the guards bound by name (the rest are
    read from one tuple); each member's memory is its own, tick by tick."""
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, "
                 "lidar: {beams: 300, fov_deg: 360, range_m: 3}}\nlet:\n  scan: lidar1..lidar300\n"
                 "  sums: total(scan)\n  up: rising(scan < 1)\n  last: sums[299] + 1000 * count(up)\n"
                 "  early: any(rising(scan < 2))\nrules:\n  - if last > 1 or early then stop()\n")
    program = compile_file(path)
    assert "_G[599](" in program.code.source and "_g255(" in program.code.source and "_g256" not in program.code.source
    robot = program.robot("p", random.Random(1), Faults())
    seen = []
    for tick in range(3):
        beams = [0.5 + 0.01 * k if (k + tick) % 2 else 2.5 for k in range(300)]
        robot.signals(tick * 0.05, tick, [*beams, *[math.inf] * (len(program.channels) - 300)])
        seen.append(tuple(robot.slots[program.slot_of[n]] for n in ("last", "early")))
    # beam 299: 3.49 (tick 0: odd), then 2.5, then 3.49; beams 0..49 are the near ones: the 25 even ones
    # come near on tick 1, the 25 odd ones on tick 2
    assert seen == [(3.49, False), (3.49 + 2.5 + 25_000, True), (3.49 + 2.5 + 3.49 + 25_000, True)]


def test_the_operation_budget_counts_each_member_s_memory(write) -> None:
    lets = "".join(f"  v{k}: total(clamp(scan, 0, {k}))\n" for k in range(26))
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, "
                 "lidar: {beams: 1000, fov_deg: 360, range_m: 3}}\nlet:\n  scan: lidar1..lidar1000\n" + lets
                 + "rules:\n  - if v0 > 1 then stop()\n")
    assert diagnostics(path) == [(30, 14, "the groups of this file are written out to more than 200,000 operations, "
                                          "one per member of each (a call of a function, once per call; a function "
                                          "with memory, 5 per member)",
                                  ("reduce a group once, in a 'let' signal, and use the signal; a function called "
                                   "many times on a large group is written out for each call",))]


def test_a_place_out_of_the_group_because_of_a_set_names_the_set(write) -> None:
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\nparams:\n"
                 "  k: 2\nlet:\n  front: sonar1..sonar8\n  a: min(front[0:k + 2])\n  b: front[k]\n"
                 "rules:\n  - if a < b then stop()\n")
    with pytest.raises(LabsimError) as e:
        compile_file(path, {"k": "7"})
    assert [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics] == [
        (10, 18, "this group has 8 members, so a slice's bound is at most 8; 'k + 2' is 9",
         (SPAN, "with --set k=7 of the command line"))]
    with pytest.raises(LabsimError) as e:
        compile_file(path, {"k": "7" + "0" * 20_000})
    [d] = e.value.diagnostics
    assert d.path == "--set k=7" + "0" * 59 + "..." and len(d.message) < 200


def test_a_group_signal_reading_itself_from_one_start_is_refused_in_format_12_as_before(write) -> None:
    path = write("labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 "let:\n  g: sonar1..sonar3\n  smooth: 0.8 * prev(smooth, 1) + 0.2 * g\n"
                 "rules:\n  - if min(smooth) < 1 then stop()\n")
    assert [d[:3] for d in diagnostics(path)] == [(8, 17, "prev() keeps memory from tick to tick, but here it is "
                                                          "paired with every member of a group, so it would run once "
                                                          "per member")]
