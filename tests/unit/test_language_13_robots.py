"""Language 1.3, other robots and messages: ``leader.x``, ``pioneer[2].state``, ``say`` and ``heard``,
parsed at their columns, checked with the exact words, and run tick by tick with last tick's values."""
from __future__ import annotations

import csv
import math
from pathlib import Path

import pytest
from helpers import examples

from labsim.backends import load_backend
from labsim.dsl.analysis.evaluate import evaluate
from labsim.dsl.compile import compile_file
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.parse import parse_expr, parse_rule
from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.run import Run

ROBOTS = frozenset({"leader", "pioneer"})
HEAD = """labsim: 1.3
world: walls_lab4
stop: time >= 1
robots:
  leader: {model: pioneer_p3dx, at: [0, 0, 0]}
  pioneer: {model: pioneer_p3dx, count: 3, at: random}
"""


def diagnostics(path: Path) -> list[tuple[int, int, str, tuple[str, ...]]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    return [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics]


def rows(path: Path, tmp_path: Path) -> list[dict[str, str]]:
    """The trace of a run of PATH on pymunk, row by row."""
    trace = tmp_path / "t.csv"
    Run(compile_file(path), load_backend("pymunk"), trace_path=trace, warn=lambda _: None).run()
    return list(csv.DictReader(line for line in trace.open() if not line.startswith("#")))


# -- the parser ------------------------------------------------------------------------------------

def test_a_robot_name_and_a_value_parse_as_another_robots_value_with_their_columns() -> None:
    e = parse_expr("1 + leader.x", ROBOTS)
    assert isinstance(e, ast.Binary) and isinstance(e.right, ast.Peer)
    peer = e.right
    assert (peer.robot, peer.attr, peer.indexed) == ("leader", "x", False)
    assert (peer.span, peer.robot_span, peer.attr_span) == ((4, 12), (4, 10), (11, 12))


def test_a_group_member_parses_with_its_place_and_columns() -> None:
    peer = parse_expr("pioneer[k + 1].state", ROBOTS)
    assert isinstance(peer, ast.Peer) and peer.indexed and peer.attr == "state"
    assert peer.member == ast.Binary("+", ast.Name("k"), ast.Number(1.0))
    assert (peer.span, peer.robot_span, peer.member.span, peer.attr_span) == ((0, 20), (0, 7), (8, 13), (15, 20))


def test_without_the_robots_a_field_stays_a_field() -> None:
    """A 1.2 file's names are not robots: centroid(lane).x and Joint.position keep their meaning."""
    assert isinstance(parse_expr("leader.x"), ast.Attribute)
    assert isinstance(parse_expr("c.x", ROBOTS), ast.Attribute)


def test_say_and_heard_parse_as_an_action_and_a_call() -> None:
    rule = parse_rule("when lead then say(pose_x, x, 10), log('{heard(pose_x)} {leader.x}')", ROBOTS)
    say, log = rule.actions
    assert isinstance(say, ast.Action) and say.name == "say" and say.args[0] == ast.Name("pose_x")
    assert isinstance(log, ast.Action) and log.text is not None
    field = log.text[2]
    assert isinstance(field, tuple) and isinstance(field[0], ast.Peer) and field[0].span == (57, 65)


# -- the checker -----------------------------------------------------------------------------------

@pytest.mark.parametrize(("let", "col", "message", "notes"), [
    ("leadr.x", 6, "unknown robot 'leadr' (did you mean 'leader'?)", ("robots of this file: leader, pioneer",)),
    ("pioneer[3].x", 14, "group 'pioneer' has 3 robots, pioneer[0] to pioneer[2]; not 3", ("places count from 0",)),
    ("pioneer[-1].x", 14, "group 'pioneer' has 3 robots, pioneer[0] to pioneer[2]; not -1", ("places count from 0",)),
    ("pioneer[0.5].x", 14, "a robot of a group is named by its place, a whole number from 0; not 0.5",
     ("round it, as in pioneer[round(0.5)].x, if a fraction is meant to pick the nearest",)),
    ("pioneer.x", 6, "'pioneer' is a group of 3 robots: name one by its place, as in pioneer[0].x",
     ("its robots are pioneer[0] to pioneer[2]",)),
    ("leader[0].x", 6, "'leader' is one robot, not a group: write leader.x", ()),
    ("leader.spedd", 13, "robot 'leader' has no value 'spedd' (did you mean 'speed'?)",
     ("another robot's x, y, heading, state and signals can be read: x, y, heading, state, speed, a",)),
    ("leader.sonar5", 13, "another robot's sensors are not read directly: give 'sonar5' a signal, as in "
     "'seen: sonar5', and read leader.seen",
     ("another robot's x, y, heading, state and signals can be read: x, y, heading, state, speed, a",)),
    ("leader + 1", 6, "'leader' is a robot: read one of its values, as in leader.x",
     ("another robot's x, y, heading, state and signals can be read",)),
    ("pioneer[true].x", 14, "a robot of a group is named by its place, a number from 0; this is a boolean", ()),
    ("heard(nothing)", 12, "nothing says on channel 'nothing' (did you mean 'nothin'?)",
     ("channels said in this file: nothin",)),
])
def test_a_mistake_in_reading_another_robot_is_an_error_at_its_place(
        write, let: str, col: int, message: str, notes: tuple[str, ...]) -> None:
    path = write(HEAD + f"let:\n  speed: 1\n  a: {let}\nrules:\n  - if true then say(nothin, a)\n")
    assert diagnostics(path) == [(9, col, message, notes)]


@pytest.mark.parametrize(("rule", "col", "message"), [
    ("say(c, x), say(c, 1)", 30, "this rule says on channel 'c' already: a robot sends one value a tick on a channel"),
    ("say(c, x < 1)", 26, "say() sends a number; this is a boolean"),
    ("say(c, x, 0)", 29, "say()'s range is a distance in metres, more than 0; not 0"),
    ("say(c, x, -2 * r)", 29, "say()'s range is a distance in metres, more than 0; not -4"),
    ("say(3, x)", 23, "say() takes a channel's name first, as in say(target, x): a name of your choice, which "
     "heard(target) reads"),
    ("say(c)", 19, "say() takes 2 or 3 arguments (channel, value[, range_m]), given 1"),
])
def test_a_mistake_in_saying_is_an_error_at_its_place(write, rule: str, col: int, message: str) -> None:
    path = write(HEAD + f"params:\n  r: 2\nlet:\n  h: heard(c)\nrules:\n  - if h < 1 then {rule}\n  - else say(c, 0)\n")
    assert [(line, c, m) for line, c, m, _ in diagnostics(path)] == [(12, col, message)]


def test_a_place_made_of_a_robots_own_parameter_is_checked_for_each_robot(write) -> None:
    path = write(HEAD.replace("count: 3, at: random}", "count: 3, at: random, params: {ahead: [1, 2, 3]}}")
                 + "params:\n  ahead: 0\nlet:\n  a: pioneer[ahead].x\nrules:\n  - always move(a)\n")
    assert diagnostics(path) == [(10, 14, "group 'pioneer' has 3 robots, pioneer[0] to pioneer[2]; not 3 for robot "
                                          "pioneer[2]", ("places count from 0",))]


def test_what_every_robot_has_or_is_not_a_signal_is_told_where_to_read_it(write) -> None:
    path = write(HEAD + "params:\n  role: 0\nlet:\n  a: leader.role + pioneer[1].time + leader.state_time\n"
                 "  b: leader.state == 'main'\nrules:\n  - if a > 0 and b then stop()\n")
    readable = ("another robot's x, y, heading, state and signals can be read: x, y, heading, state, a, b",)
    assert diagnostics(path) == [
        (10, 13, "'role' is a parameter: give it a signal, as in 'my_role: role', and read leader.my_role", readable),
        (10, 31, "every robot has the same 'time': write time", ()),
        (10, 45, "'state_time' is a built-in variable: give it a signal, as in 'my_state_time: state_time', and "
                 "read leader.my_state_time", readable),
        (11, 22, "a state is compared with a state's name, without quotes: write 'leader.state == main'", ())]


def test_say_outside_a_rule_is_an_action_in_an_expression(write) -> None:
    path = write(HEAD + "let:\n  a: 1 + say(c, 1)\nrules:\n  - if heard(c) > a then say(c, 2)\n  - else stop()\n")
    assert diagnostics(path) == [(8, 10, "'say' is an action: it goes after 'then', not inside an expression", ())]


@pytest.mark.parametrize("let", ["", "let:\n  a: tell(1)\n"])
def test_say_in_a_function_body_is_an_action_in_an_expression_not_an_unknown_channel(write, let: str) -> None:
    path = write(HEAD + "functions:\n  tell(v): say(c, v)\n" + let + "rules:\n  - if heard(c) > 0 then say(c, 2)\n"
                 "  - else stop()\n")
    assert diagnostics(path) == [(8, 12, "'say' is an action: it goes after 'then', not inside an expression", ())]


WHEN = ("a 'when' rule only logs and says, and the rules below it go on; to drive, write an 'if' rule",
        ("e.g. 'when rising(collided) then log(\"hit\")', then 'if collided then move(-2)'",))


@pytest.mark.parametrize(("rule", "expected"), [
    ("when time > 0 then say(c, 1), move(2)", (9, 35, *WHEN)),
    ("if time > 0 then say(c)", (9, 22, "say() takes 2 or 3 arguments (channel, value[, range_m]), given 1", ())),
    ("if time > 0 then say(c, 1, 2, 3)",
     (9, 22, "say() takes 2 or 3 arguments (channel, value[, range_m]), given 4", ())),
])
def test_a_say_in_a_rule_with_an_error_still_counts_its_channel_as_said(write, rule: str,
                                                                       expected: tuple[object, ...]) -> None:
    path = write(HEAD + f"rules:\n  - if heard(c) > 0 then stop()\n  - {rule}\n  - always move(1)\n")
    assert diagnostics(path) == [expected]


def test_what_is_heard_is_no_sensor_reading_and_is_compared_exactly(write) -> None:
    """A channel named like a sensor reads no sensor (no pid() warning); == on what is heard is meant."""
    path = write(HEAD + "let:\n  p: pid(heard(sonar5) - 1, 1, 0, 0)\n  two: heard(sonar5) == 2\nrules:\n"
                 "  - when two then say(sonar5, sonar5 if detected(sonar5) else 0)\n  - if p > 0 then say(mode, 2)\n"
                 "  - else stop()\n")
    assert compile_file(path).warnings == ()


def test_another_robots_heading_is_judged_on_a_headings_range(write) -> None:
    path = write(HEAD + "let:\n  lost: sonar5 < 1\nrules:\n  - if leader.heading > 90 or leader.lost then stop()\n"
                 "  - else move(1)\n")
    assert [(d.line, d.col, d.message.split(":")[0]) for d in compile_file(path).warnings] == [
        (10, 8, "'leader.heading > 90' never holds")]


def test_a_mechanism_has_no_robots_to_say_to(write) -> None:
    path = write("labsim: 1.3\nworld: crane\nstop: time >= 1\nlet:\n  h: heard(c)\nrules:\n"
                 "  - always say(c, 1), set_velocity(Arm_Actuator, h)\n")
    assert diagnostics(path) == [(7, 12, "say() sends to the other robots, and this file has none",
                                  ("a mechanism's rules read its sensors and set its joints",))]


def test_a_log_shows_another_robots_state_and_nan_for_one_outside_the_group(write, tmp_path: Path) -> None:
    path = write(HEAD + "rules:\n  - when tick == 3 then log(\"{pioneer[index + 1].state} {leader.state}\")\n"
                 "  - always move(1)\n")
    logs = [(r["robot"], r["events"]) for r in rows(path, tmp_path) if r["events"]]
    assert logs == [("leader", "log: main main"), ("pioneer[0]", "log: main main"), ("pioneer[1]", "log: main main"),
                    ("pioneer[2]", "log: nan main")]


def test_a_signal_read_of_another_robot_in_a_signal_it_reads_must_be_a_number(write) -> None:
    path = write(HEAD + "let:\n  m: leader.near + 1\n  near: sonar5 < m\nrules:\n  - if m > 0 then stop()\n")
    assert diagnostics(path) == [(8, 13, "'near' is a boolean, and another robot's value of it is read where 'near' "
                                         "is being worked out (it reads this signal): only a number can be read so",
                                  ("read a number made of it instead, as in 'near_n: 1 if near else 0'",))]
    path = write(HEAD + "let:\n  m: leader.near + 1\n  near: sonar5 < 1\nrules:\n  - if m > 0 then stop()\n")
    assert diagnostics(path) == [(8, 6, "'+' needs a number, but this is a boolean", ())]  # its type is known


def test_a_function_does_not_read_another_robot_or_a_channel(write) -> None:
    path = write(HEAD + "functions:\n  f(a): a + leader.x\n  g(a): heard(c)\nlet:\n  v: f(1) + g(2)\nrules:\n"
                 "  - if v > 0 then say(c, 1)\n")
    found = diagnostics(path)
    assert [(line, col, m.split(",")[0]) for line, col, m, _ in found] == [
        (8, 13, "a function reads only its parameters (a)"), (9, 9, "a function reads only its parameters (a)")]
    assert found[1][3] == ("read it in a signal and pass the signal to 'g'",)


@pytest.mark.parametrize(("let", "col", "what"), [
    ("leader.x", 6, "reading another robot (leader.x)"),
    ("heard(c)", 6, "heard(channel)"),
])
def test_a_file_of_format_12_is_told_these_are_format_13(write, let: str, col: int, what: str) -> None:
    path = write(HEAD.replace("labsim: 1.3", "labsim: 1.2") + f"let:\n  a: {let}\nrules:\n  - if a > 0 then stop()\n")
    assert diagnostics(path) == [(8, col, f"{what} is format 1.3: start the file with 'labsim: 1.3'", ())]


def test_say_in_a_file_of_format_12_is_told_it_is_format_13(write) -> None:
    path = write(HEAD.replace("labsim: 1.3", "labsim: 1.2") + "rules:\n  - always say(c, 1), move(1)\n")
    assert diagnostics(path) == [(8, 12, "say(channel, value) is format 1.3: start the file with 'labsim: 1.3'", ())]


def test_a_file_that_reads_another_robot_checks_without_warnings(write) -> None:
    path = write(HEAD + "let:\n  lx: leader.x\n  ahead: pioneer[index].x - x\nrules:\n  - if lx > 1 then stop()\n"
                 "  - else move(ahead)\n")
    assert compile_file(path).warnings == ()


# -- the run ---------------------------------------------------------------------------------------

TWO = """labsim: 1.3
world: walls_lab4
stop: time >= 2
robots:
{robots}
params:
  speed: 1
let:
  fast: speed > 2
  ax: ra.x
  ah: ra.heading
  afast: ra.fast
  a_in_b: ra.state == b
  bx: rb.x
  bh: rb.heading
  bfast: rb.fast
  b_in_b: rb.state == b
rules:
  a:
    - if time >= speed / 4 then goto b
    - else move(speed)
  b:
    - else move(speed)
"""
ROBOT_A = "  ra: {model: pioneer_p3dx, at: [0, 0, 0], params: {speed: 6}}"
ROBOT_B = "  rb: {model: pioneer_p3dx, at: [0, 2, 450], params: {speed: 2}}"  # 90 degrees, as a heading reads


def by_robot(rows_: list[dict[str, str]]) -> dict[str, list[dict[str, str]]]:
    out: dict[str, list[dict[str, str]]] = {}
    for r in rows_:
        out.setdefault(r["robot"], []).append(r)
    return out


def test_another_robots_values_are_its_values_of_the_last_tick(write, tmp_path: Path) -> None:
    """Every robot reads each robot's row of the tick before; on the first tick, its start pose, its
    first state and 0 (false) for a signal."""
    by = by_robot(rows(write(TWO.format(robots=ROBOT_A + "\n" + ROBOT_B)), tmp_path))
    for reader in ("ra", "rb"):
        first = by[reader][0]
        assert [first[k] for k in ("ax", "ah", "afast", "a_in_b", "bx", "bh", "bfast", "b_in_b")] == [
            "0", "0", "0", "0", "0", "1.5708", "0", "0"]
        for t in range(1, len(by[reader])):
            row = by[reader][t]
            for other, prefix in (("ra", "a"), ("rb", "b")):
                before = by[other][t - 1]
                assert (row[prefix + "x"], row[prefix + "h"], row[prefix + "fast"]) == (
                    before["x"], before["heading"], before["fast"])
                assert row[prefix + "_in_b"] == ("1" if before["state"] == "b" else "0")
    assert by["ra"][1]["afast"] == "1" and by["ra"][1]["bfast"] == "0"  # ra's speed is 6, rb's 2
    switched = next(t for t, r in enumerate(by["rb"]) if r["state"] == "b")
    assert [r["b_in_b"] for r in by["ra"][switched:switched + 2]] == ["0", "1"]  # a tick later


def test_the_order_robots_are_stepped_in_changes_nothing(write, tmp_path: Path) -> None:
    """ra stepped first, and last: each robot's rows are the same."""
    first = write(TWO.format(robots=ROBOT_A + "\n" + ROBOT_B), "first.yaml")
    last = write(TWO.format(robots=ROBOT_B + "\n" + ROBOT_A), "last.yaml")
    one, two = by_robot(rows(first, tmp_path)), by_robot(rows(last, tmp_path))
    assert one["ra"] == two["ra"] and one["rb"] == two["rb"]
    assert one["ra"][20]["bx"] != one["ra"][0]["bx"]  # rb moved, and ra saw it


def test_a_place_known_only_while_running_is_a_runtime_fault_outside_the_group(write, tmp_path: Path) -> None:
    path = write(HEAD + "let:\n  nx: pioneer[index + 1].x\nrules:\n  - always move(1)\n")
    warned: list[str] = []
    run = Run(compile_file(path), load_backend("pymunk"), trace_path=tmp_path / "t.csv", warn=warned.append)
    run.run()
    by = by_robot(list(csv.DictReader(line for line in (tmp_path / "t.csv").open() if not line.startswith("#"))))
    assert by["pioneer[0]"][3]["nx"] == by["pioneer[1]"][2]["x"]
    assert {r["nx"] for r in by["pioneer[2]"]} == {"nan"}
    assert any("no member at place 3 of a group of 3 (places count from 0) in signal 'nx', robot pioneer[2], "
               "tick 0" in w for w in warned)


def test_a_value_read_at_a_known_place_is_a_column_of_the_reader(write, tmp_path: Path) -> None:
    path = write(HEAD + "let:\n  near: sonar5 < 1\n  ahead: pioneer[1].x - leader.x\n"
                 "  s: leader.state == main and pioneer[0].near\nrules:\n  - always move(1)\n")
    columns = list(rows(path, tmp_path)[0])
    assert columns[columns.index("s") + 1:columns.index("wheel_left")] == [
        "pioneer[1].x", "leader.x", "pioneer[0].near"]


# -- messages --------------------------------------------------------------------------------------

RADIO = """labsim: 1.3
world: walls_lab4
stop: time >= 1
robots:
  a: {model: pioneer_p3dx, at: [0, 0, 0], params: {k: 1}}
  b: {model: pioneer_p3dx, at: [2, 0, 0], params: {k: 2}}
  c: {model: pioneer_p3dx, at: [5, 0, 0], params: {k: 3}}
params:
  k: 0
let:
  h: heard(ch, -1)
  h0: heard(ch)
rules:
  - when RULE
  - always stop()
"""


@pytest.mark.parametrize(("rule", "a", "b", "c"), [
    # everyone says: each hears the nearest other robot
    ("true then say(ch, k * 10 + tick)", "2", "1", "2"),
    # only a says, within 3 m: b hears it, c (5 m away) does not
    ("k == 1 then say(ch, k * 10 + tick, 3)", "-1", "1", "-1"),
    # a and c say, b is 2 m from a and 3 m from c: the nearer; a and c hear each other
    ("k != 2 then say(ch, k * 10 + tick)", "3", "1", "1"),
    # b and a are 2 m from... a hears b, c hears b (3 m) rather than a (5 m)
    ("k <= 2 then say(ch, k * 10 + tick)", "2", "1", "2"),
])
def test_a_robot_hears_the_nearest_other_robot_a_tick_later(write, tmp_path: Path, rule: str, a: str, b: str,
                                                            c: str) -> None:
    path = write(RADIO.replace("RULE", rule))
    by = by_robot(rows(path, tmp_path))
    assert [by[r][0]["h"] for r in "abc"] == ["-1", "-1", "-1"]  # nothing heard yet: the default
    assert [by[r][0]["h0"] for r in "abc"] == ["0", "0", "0"]
    assert [by[r][0]["heard(ch)"] for r in "abc"] == ["nan", "nan", "nan"]
    said = {"1": 10, "2": 20, "3": 30, "-1": None}
    for t in (1, 5):  # what was said on the tick before
        want = [str(said[w] + t - 1) if said[w] is not None else "-1" for w in (a, b, c)]
        assert [by[r][t]["h"] for r in "abc"] == want


def test_two_robots_as_near_are_heard_in_the_files_order(write, tmp_path: Path) -> None:
    text = RADIO.replace("RULE", "k != 2 then say(ch, k)").replace("at: [5, 0, 0]", "at: [4, 0, 0]")
    by = by_robot(rows(write(text), tmp_path))
    assert by["b"][1]["h"] == "1"  # a and c both 2 m away: a, first in the file


def test_what_is_heard_is_kept_until_something_new_is_heard(write, tmp_path: Path) -> None:
    path = write(RADIO.replace("RULE", "k == 1 and tick == 2 then say(ch, 7)"))
    by = by_robot(rows(path, tmp_path))
    assert [r["h"] for r in by["b"][:6]] == ["-1", "-1", "-1", "7", "7", "7"]
    assert {r["h"] for r in by["a"]} == {"-1"}  # never itself


def test_of_two_rules_that_say_on_a_channel_in_a_tick_the_later_is_sent(write, tmp_path: Path) -> None:
    text = RADIO.replace("  - when RULE\n  - always stop()\n", "  - when k == 1 then say(ch, 5)\n"
                         "  - if k == 1 and tick % 2 == 0 then say(ch, 7), stop()\n  - always stop()\n")
    by = by_robot(rows(write(text), tmp_path))
    assert [r["h"] for r in by["b"][:5]] == ["-1", "7", "5", "7", "5"]


def test_a_value_that_is_not_finite_is_not_sent(write, tmp_path: Path) -> None:
    path = write(RADIO.replace("RULE", "k == 1 then say(ch, 1 / (tick - 2))"))
    warned: list[str] = []
    trace = tmp_path / "t.csv"
    Run(compile_file(path), load_backend("pymunk"), trace_path=trace, warn=warned.append).run()
    by = by_robot(list(csv.DictReader(line for line in trace.open() if not line.startswith("#"))))
    assert [r["h"] for r in by["b"][:5]] == ["-1", "-0.5", "-1", "-1", "1"]  # tick 2's inf was not sent
    assert any("say() of inf: not sent (only finite numbers are) in rule main:1, robot a, tick 2" in w for w in warned)


# -- the reference evaluator -----------------------------------------------------------------------

def test_the_reference_evaluator_reads_another_robot_as_the_generated_code_does() -> None:
    names = {"leader": ({"x": 1.5, "state": 1},), "pioneer": ({"x": 0.0}, {"x": 2.0}, {"x": 4.0}), "k": 1.0}
    assert evaluate(parse_expr("leader.x + pioneer[2].x", ROBOTS), names) == (5.5, ())
    assert evaluate(parse_expr("pioneer[k + 1].x", ROBOTS), names) == (4.0, ())
    value, faults = evaluate(parse_expr("pioneer[k + 2].x", ROBOTS), names)
    assert math.isnan(value) and [f.what for f in faults] == [  # type: ignore[arg-type]
        "no member at the place asked of a group of 3 (places count from 0)"]


# -- the worked examples ---------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["leader_follower", "formation_of_three"])
def test_the_worked_examples_check_without_warnings_and_run_the_same_twice(name: str, write, tmp_path: Path) -> None:
    path = write(examples()[name], f"{name}.yaml")
    assert compile_file(path).warnings == ()
    first = rows(path, tmp_path)
    assert rows(path, tmp_path) == first
    farthest = max(float(r["gap"]) for r in first if r["robot"] not in ("leader",) and int(r["tick"]) > 100)
    assert farthest < 2.5  # the others keep up with the leader


def test_a_breakpoint_on_another_robots_value_says_to_watch_a_signal(write) -> None:
    from labsim.dsl.watch import compile_watch

    program = compile_file(write(HEAD + "rules:\n  - always move(1)\n"))
    with pytest.raises(LabsimError) as e:
        compile_watch(program, "time > 1 or pioneer[1].y < 3")
    assert [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics] == [
        (1, 13, "a breakpoint sees one robot's own values, not pioneer[1].y",
         ("read it in a signal of the file (e.g. 'let: other: pioneer[1].y') and watch the signal",))]


def test_a_signal_named_heard_is_refused_once_at_its_name(write) -> None:
    path = write(HEAD + "let:\n  heard: 2\n  a: heard(target) + heard\nrules:\n  - when a > 0 then say(target, 1)\n"
                 "  - else stop()\n")
    assert diagnostics(path) == [(8, 3, "signal 'heard' is the name of a built-in function of format 1.3; choose "
                                        "another name",
                                  ("a file of format 1.2 or earlier may keep it as its own name",))]
