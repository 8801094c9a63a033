"""Language 1.2: groups, functions of your own, 'when' rules, text in logs, prev() of a signal in itself."""
from __future__ import annotations

import itertools
import math
import random
from pathlib import Path

import pytest
from helpers import Run, load_backend, run_example, trace_rows

from labsim.dsl.compile import compile_file
from labsim.dsl.emit.program import Program
from labsim.dsl.library.support import Faults
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.parse import ParseError, parse_expr, parse_rule
from labsim.foundation.diagnostics import LabsimError

HEAD = ("labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx, at: [0, 0, 0]}\n")


def errors(path: Path) -> set[tuple[int, int, str]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    return {(d.line, d.col, d.message) for d in e.value.diagnostics if d.severity == "error"}


def signals(program: Program, ticks: list[dict[str, float]]) -> list[dict[str, object]]:
    """Each tick's signal values for one robot given its channel readings (others read inf)."""
    faults = Faults()
    robot = program.robot("p", random.Random(0), faults)
    out = []
    for tick, reading in enumerate(ticks):
        values = [reading.get(ch, False if ch == "collided" else math.inf) for ch in program.channels]
        robot.signals(tick * program.dt_s, tick, values)
        out.append({n: robot.slots[program.slot_of[n]] for n in program.let_names})
    return out


# -- parsing --------------------------------------------------------------------------------------

def test_a_range_of_names_is_a_group_of_its_names_with_the_ends_placed() -> None:
    e = parse_expr("min(sonar1..sonar3)")
    assert isinstance(e, ast.Call)
    group = e.args[0]
    assert group == ast.Group((ast.Name("sonar1"), ast.Name("sonar2"), ast.Name("sonar3")), True)
    assert isinstance(group, ast.Group)
    assert [m.span for m in group.members] == [(4, 10), (4, 18), (12, 18)]
    assert parse_expr("sonar8..5") == ast.Group(tuple(ast.Name(f"sonar{k}") for k in (8, 7, 6, 5)), True)


@pytest.mark.parametrize(("text", "start", "end", "message"), [
    ("sonar1..abc", 8, 11, "a range of names runs between two numbered names of one kind, as in sonar1..sonar8; "
                           "not 'abc'"),
    ("ahead..sonar3", 0, 5, "a range of names runs between two numbered names, as in sonar1..sonar8; 'ahead' ends "
                            "in no number"),
    ("[]", 0, 2, "a group needs at least one member, as in [sonar4, sonar5]"),
    ("s1..s5000", 0, 9, "a range of names holds at most 1000 members, and this one has 5000"),
])
def test_range_mistakes_are_placed(text: str, start: int, end: int, message: str) -> None:
    with pytest.raises(ParseError) as e:
        parse_expr(text)
    assert (e.value.start, e.value.end, e.value.message) == (start, end, message)


def test_when_is_a_rule_and_still_a_name() -> None:
    rule = parse_rule('when collided then log("hit")')
    assert rule.kind == "when" and rule.condition == ast.Name("collided")
    assert parse_expr("when + 1") == ast.Binary("+", ast.Name("when"), ast.Number(1.0))
    with pytest.raises(ParseError) as e:
        parse_rule("move(2)")
    assert e.value.message == "a rule starts with 'if', 'else', 'always' or 'when', not 'move'"


# -- checking -------------------------------------------------------------------------------------

@pytest.mark.parametrize(("body", "line", "col", "message"), [
    ("let:\n  a: min(sonar10..sonar20)\n", 7, 10,
     "sonar10..sonar20 names sonar17 .. sonar20, which do not exist"),
    ("let:\n  a: [sonar1, collided]\n", 7, 15,
     "a group's members are all numbers or all booleans; this one is a boolean, and the first is a number"),
    ("let:\n  a: sonar1..sonar8\n  b: a[8]\n", 8, 8, "this group has 8 members, at places 0 to 7; not 8"),
    ("let:\n  a: sonar1..sonar8\n  b: a - [sonar1, sonar2]\n", 8, 10,
     "'-' pairs the members of two groups, which need one size: this has 2 members and the first 8"),
    ("let:\n  a: argmin(sonar5)\n", 7, 13, "argmin() takes a group, as in argmin(sonar1..sonar8); this is a number"),
    ("let:\n  a: any(sonar1..sonar8)\n", 7, 10,
     "any() takes a group of booleans, but this is a group of numbers"),
    ("rules:\n  - if state == \"main\" then stop()\n", 7, 17,
     "a state is compared with a state's name, without quotes: write 'state == main'"),
    ("let:\n  n: prev(n, 0) > 1\n", 7, 14, "signal 'n' is a boolean, so prev(n, ...) starts from a boolean too; "
                                          "this is a number"),
    ("let:\n  n: n + 1\n", 7, 6, "signal 'n' reads itself: it is being computed; its value on the previous "
                                 "tick is prev(n, initial)"),
    ("rules:\n  - when collided then move(2)\n", 7, 24,
     "a 'when' rule only logs, and the rules below it go on; to drive, write an 'if' rule"),
])
def test_mistakes_with_the_new_parts_are_placed(write, body: str, line: int, col: int, message: str) -> None:
    rules = "" if "rules:" in body else "rules:\n  - always stop()\n"
    path = write(HEAD + body + rules)
    assert (line, col, message) in errors(path)


def test_a_group_where_a_condition_belongs_says_how_to_reduce_it(write) -> None:
    path = write(HEAD + "rules:\n  - if sonar1..sonar8 < 0.5 then stop()\n")
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    [d] = e.value.diagnostics
    assert d.message == "a rule's condition must be a boolean, but this is a group of booleans"
    assert d.notes == ("a group holds one value per member: take any(...), all(...) or count(...) of it",)


FUNCTIONS = """functions:
  steer(offset, gain): clamp(gain * offset, -2, 2)
  wrong(a): a + sonar5
  loop(a): again(a) + 1
  again(a): loop(a)
  noisy(a): a + random()
"""


def test_function_mistakes_point_at_the_definition_and_the_call(write) -> None:
    path = write(HEAD + FUNCTIONS + "let:\n  s: steer(sonar5)\n  t: steer(sonar5 - 0.5, 2)\n"
                 "rules:\n  - always stop()\n")
    found = errors(path)
    assert (8, 17, "'sonar5' is a sensor, and a function reads only its parameters (a), the file's params and "
                   "constants") in found
    assert (9, 3, "function 'loop' calls itself (loop -> again -> loop): a function cannot call itself, directly "
                  "or through others") in found
    assert (10, 13, "this call of 'loop' closes the circle") in found
    assert (11, 17, "a function computes its value from its arguments alone, and random() draws random numbers") \
        in found
    assert (13, 6, "steer() takes 2 arguments (offset, gain), given 1") in found
    assert len(found) == 5


def test_a_function_typed_at_each_call_with_its_arguments(write) -> None:
    path = write(HEAD + "functions:\n  pick(c, a, b): a if c else b\n"
                 "let:\n  n: pick(collided, sonar4, sonar5)\n  c: pick(true, collided, false)\n"
                 "rules:\n  - if c then stop()\n  - else move(n)\n")
    program = compile_file(path)
    assert [row["n"] for row in signals(program, [{"sonar4": 0.3, "sonar5": 0.7, "collided": True},
                                                  {"sonar4": 0.3, "sonar5": 0.7, "collided": False}])] == [0.3, 0.7]
    assert "def " not in program.code.source.split("def make", 1)[1].split("def signals")[0]


# -- running --------------------------------------------------------------------------------------

def test_groups_reduce_member_by_member(write) -> None:
    path = write(HEAD + "let:\n  front: sonar3..sonar6\n  near: min(front)\n  at: argmin(front)\n"
                 "  far: argmax([sonar1, sonar8])\n  n: count(front < 0.5)\n  some: any(front < 0.4)\n"
                 "  every: all(front < 0.9)\n  total_: sum(front - 0.1)\n  avg: mean(front)\n  second: front[1]\n"
                 "  k: front[n]\n"
                 "rules:\n  - if some or every then stop()\n  - else move(near + at + far + total_ + avg + "
                 "second + k)\n")
    program = compile_file(path)
    [row] = signals(program, [{"sonar3": 0.8, "sonar4": 0.45, "sonar5": 0.3, "sonar6": 0.6, "sonar1": 0.2}])
    assert row["near"] == 0.3 and row["at"] == 2.0 and row["far"] == 1.0 and row["n"] == 2.0
    assert row["some"] is True and row["every"] is True
    assert row["total_"] == pytest.approx(2.15 - 0.4) and row["avg"] == pytest.approx(2.15 / 4)
    assert row["second"] == 0.45 and row["k"] == 0.3
    assert "front" in program.let_names and "front" not in program.single_signals  # the view shows no group


def test_a_member_picked_outside_the_group_is_nan_and_warns(write) -> None:
    path = write(HEAD + "let:\n  front: sonar3..sonar6\n  k: front[tick + 3]\nrules:\n  - always move(k)\n")
    program = compile_file(path)
    warned: list[str] = []
    robot = program.robot("p", random.Random(0), Faults(warned.append))
    robot.signals(0.0, 0, [0.5] * len(program.channels))
    assert robot.slots[program.slot_of["k"]] == 0.5
    robot.signals(0.05, 1, [0.5] * len(program.channels))
    assert math.isnan(robot.slots[program.slot_of["k"]])
    assert "no member at place 4 of a group of 4 (places count from 0)" in warned[0]


def test_a_signal_reads_itself_on_the_previous_tick(write) -> None:
    path = write(HEAD + "let:\n  n: prev(n, 10) + 1\n  seen: prev(seen, false) or collided\n"
                 "rules:\n  - if seen then stop()\n  - else move(n)\n")
    rows = signals(compile_file(path), [{}, {"collided": True}, {}, {}])
    assert [r["n"] for r in rows] == [11.0, 12.0, 13.0, 14.0]
    assert [r["seen"] for r in rows] == [False, True, True, True]


def test_when_rules_log_and_the_rules_below_still_drive(write, tmp_path: Path) -> None:
    path = write(HEAD.replace("time >= 1", "time >= 0.2") + "rules:\n  main:\n"
                 "    - when tick == 1 then log(\"side {'left' if x > 0 else 'right'} in {state}\")\n"
                 "    - always move(3)\n")
    warned: list[str] = []
    run = Run(compile_file(path), load_backend("pymunk"), trace_path=tmp_path / "t.csv", warn=warned.append)
    run.run()
    rows = [line.split(",") for line in (tmp_path / "t.csv").read_text().splitlines() if not line.startswith("#")]
    assert [r[8] for r in rows[1:-1]] == ["main:2"] * 4  # the stopping tick acts on no rule
    assert rows[2][-1] == "log: side left in main"
    assert any(line.endswith("p: side left in main") for line in warned)


# -- the worked examples of docs/language.md --------------------------------------------------------

def test_nearest_sonar_keeps_off_the_walls(tmp_path: Path) -> None:
    _, summary, _ = run_example("nearest_sonar", tmp_path, trace=True)
    rows = trace_rows(tmp_path / "t.csv")
    assert 0.2 < summary.robots["pioneer"].metrics["closest"] < 0.5  # type: ignore[attr-defined]
    assert "side" in rows[0] and "front" not in rows[0].split(",")  # a group is not traced


def test_log_and_drive_logs_each_wall_and_still_turns(tmp_path: Path) -> None:
    run, summary, warned = run_example("log_and_drive", tmp_path, trace=True)
    walls = summary.robots["pioneer"].metrics["walls"]  # type: ignore[attr-defined]
    logged = [row for row in trace_rows(tmp_path / "t.csv") if "log: wall on the " in row]
    assert walls >= 2 and len(logged) == walls  # the trace has every line; the summary at most 5 a second
    counts = summary.rule_counts  # type: ignore[attr-defined]
    assert counts["main:1"] == len(logged) and counts["main:2"] > 0  # a 'when' rule counts the ticks it logged


def test_keep_right_follows_with_its_own_function(tmp_path: Path) -> None:
    _, summary, _ = run_example("keep_right", tmp_path, trace=True)
    rows = trace_rows(tmp_path / "t.csv")
    columns = rows[0].split(",")
    seen = [float(r.split(",")[columns.index("seen_for")]) for r in rows[1:]]
    assert max(seen) > 20 and all(b in (a + 1, 0) for a, b in itertools.pairwise(seen))  # counts up, or restarts
    assert summary.robots["pioneer"].metrics["longest_follow"] == pytest.approx(max(seen) * 0.05)  # type: ignore


def test_every_worked_example_checks_without_a_warning(tmp_path: Path) -> None:
    from helpers import examples

    for name, text in examples().items():
        path = tmp_path / f"{name}.yaml"
        path.write_text(text)
        assert compile_file(path).warnings == (), name


def test_log_lines_are_reported_apart_from_warnings_and_faults(tmp_path: Path) -> None:
    from labsim.runtime.cli.report import format_summary
    from labsim.runtime.summary_json import summary_dict
    from labsim.runtime.sweep.grid import Row, Task, flat

    _, summary, _ = run_example("log_and_drive", tmp_path)
    data = summary_dict(summary)  # type: ignore[arg-type]
    assert data["logs"] and data["warnings"] == [] and data["faults"] == []
    row = flat(Row(Task(0, "log_and_drive.yaml", (), 3), "ok", result=summary))  # type: ignore[arg-type]
    assert row["logs"] == len(data["logs"]) and row["faults"] == 0
    text = format_summary(summary)  # type: ignore[arg-type]
    assert f"logs: {len(data['logs'])} lines printed" in text and "runtime warnings" not in text
