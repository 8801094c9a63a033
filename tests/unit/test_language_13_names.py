"""Language 1.3: the names a file's own may not take (a robot's, and the built-ins 1.3 added), and
what 1.0-1.2 files keep: ``leader.x`` reads robot 'leader' in 1.3, a field of signal 'leader' in 1.2."""
from __future__ import annotations

from pathlib import Path

import pytest

from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import LabsimError

HEAD = """labsim: 1.3
world: walls_lab4
stop: time >= 1
robots:
  leader: {model: pioneer_p3dx, at: [0, 0, 0]}
  pioneer: {model: pioneer_p3dx, count: 2, at: random}
"""
ROBOT = ("is the name of a robot; choose another name",
         ("leader.x, leader.state, ... read robot 'leader' in format 1.3",))
OLDER = ("a file of format 1.2 or earlier may keep it as its own name",)


def diagnostics(path: Path) -> list[tuple[int, int, str, tuple[str, ...]]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    return [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics]


@pytest.mark.parametrize(("part", "line", "what"), [
    ("let:\n  leader: x + 1\n  a: leader.x\n", 8, "signal"),
    ("params:\n  leader: 2\nlet:\n  a: leader.x\n", 8, "parameter"),
    ("sliders:\n  leader: {min: 0, max: 1}\nlet:\n  a: leader.x\n", 8, "slider"),
    ("functions:\n  leader(v): v + 1\nlet:\n  a: leader.x\n", 8, "function"),
])
def test_a_name_of_the_file_s_own_that_is_a_robot_s_is_an_error_in_1_3(write, part: str, line: int,
                                                                         what: str) -> None:
    path = write(HEAD + part + "rules:\n  - if a > 0 then stop()\n")
    assert diagnostics(path) == [(line, 3, f"{what} 'leader' {ROBOT[0]}", ROBOT[1])]


def test_a_state_named_like_a_robot_is_an_error_in_1_3(write) -> None:
    path = write(HEAD + "rules:\n  main:\n    - always goto leader\n  leader:\n    - always stop()\n")
    assert diagnostics(path) == [(10, 3, f"state 'leader' {ROBOT[0]}", ROBOT[1])]


def test_in_1_2_leader_x_stays_a_field_of_the_signal(write) -> None:
    path = write("labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  leader: {model: pioneer_p3dx, at: "
                 "[0, 0, 0]}\n  b: {model: pioneer_p3dx, at: [2, 0, 0]}\nlet:\n  leader: centroid(threshold("
                 "gray(camera), 20))\n  cx: leader.x\nrules:\n  - if cx > 0 then stop()\n"
                 .replace("pioneer_p3dx,", "pioneer_p3dx, camera: {resolution: [32, 24]},"))
    assert compile_file(path).signal_types["cx"].name == "NUMBER"


@pytest.mark.parametrize(("part", "line", "col", "message"), [
    ("functions:\n  heard(c): c + 1\nlet:\n  a: heard(ch)\n", 8, 3,
     "function 'heard' is the name of a built-in function of format 1.3; choose another name"),
    ("let:\n  heard: 5\n  say: 4\n  a: heard + say + heard(ch)\n", 8, 3,
     "signal 'heard' is the name of a built-in function of format 1.3; choose another name"),
    ("params:\n  len: 2\nlet:\n  a: heard(ch) + len\n", 8, 3,
     "parameter 'len' is the name of a built-in function of format 1.3; choose another name"),
    ("sliders:\n  start_x: {min: 0, max: 1}\nlet:\n  a: heard(ch)\n", 8, 3,
     "slider 'start_x' is the name of a built-in variable of format 1.3; choose another name"),
    ("let:\n  wheel_left: 1\n  a: heard(ch)\n", 8, 3,
     "signal 'wheel_left' is the name of a built-in variable of format 1.3; choose another name"),
    ("functions:\n  say(v): v\nlet:\n  a: heard(ch)\n", 8, 3,
     "function 'say' is the name of a built-in action of format 1.3; choose another name"),
])
def test_a_name_of_the_file_s_own_that_1_3_gave_the_language_is_an_error(write, part: str, line: int, col: int,
                                                                        message: str) -> None:
    path = write(HEAD + part + "rules:\n  - if a > 0 then say(ch, 1)\n  - else stop()\n")
    found = diagnostics(path)
    assert found[0] == (line, col, message, OLDER)
    if "say: 4" in part:  # each refused name once; its uses say nothing more
        assert found[1:] == [(9, 3, "signal 'say' is the name of a built-in action of format 1.3; choose another name",
                              OLDER)]
    else:
        assert found[1:] == []


def test_a_state_named_heard_is_an_error_in_1_3(write) -> None:
    path = write(HEAD + "let:\n  a: heard(ch)\nrules:\n  main:\n    - if a > 0 then goto heard\n    - else say(ch, 1)\n"
                 "  heard:\n    - always stop()\n")
    assert diagnostics(path) == [(13, 3, "state 'heard' is the name of a built-in function of format 1.3; choose "
                                         "another name", OLDER)]


FUNCTIONS_13 = ("functions: abs, all, any, area, argmax, argmin, atan2, ceil, centroid, clamp, cos, count, counter, "
                "crop, deg, detected, exp, falling, floor, gauss, gray, heard, height, held, hold, hypot, invert, len, "
                "log, max, mean, min, pid, prev, rad, randint, random, rate, remember, rising, round, sign, sin, sqrt, "
                "sum, tan, threshold, total, uniform, width")
ACTIONS_13 = ("actions: arc(left, right), wheels(left, right), move(speed), drive(v, w), stop(), set_velocity(joint, "
              "velocity), set_position(joint, position), say(channel, value[, range_m]), log(text), goto STATE")


@pytest.mark.parametrize(("condition", "message", "nearest"), [
    ("hear(ch) > 0", "unknown function 'hear' (did you mean 'heard'?)", "the nearest: heard, mean, held; "),
    ("heared(ch, 1) > 0", "unknown function 'heared' (did you mean 'heard'?)", "the nearest: heard, held, area; "),
])
def test_a_mistyped_heard_is_told_and_its_channel_is_not_an_unknown_name(write, condition: str, message: str,
                                                                        nearest: str) -> None:
    path = write(HEAD + f"rules:\n  - if {condition} then stop()\n  - else say(ch, 1)\n")
    assert diagnostics(path) == [(8, 8, message, (nearest + FUNCTIONS_13,
                                                  "each is described in docs/language.md, under 'Functions'"))]


@pytest.mark.parametrize("action", ["sey", "Say"])
def test_a_mistyped_say_is_told_and_what_hears_on_its_channel_is_not_reported(write, action: str) -> None:
    path = write(HEAD + f"let:\n  h: heard(ch)\nrules:\n  - if h > 0 then stop()\n  - else {action}(ch, 1)\n")
    assert diagnostics(path) == [(11, 10, f"unknown action '{action}' (did you mean 'say'?)", (ACTIONS_13,))]


@pytest.mark.parametrize(("action", "example"), [
    ('say("ch", 2)', "say(ch, 2)"), ('say("ch")', "say(ch, value)"), ('say("ch", x + 1, 3)', "say(ch, x + 1, 3)"),
])
def test_a_quoted_channel_is_told_to_be_a_name_and_what_hears_on_it_is_not_reported(write, action: str,
                                                                                   example: str) -> None:
    path = write(HEAD + f"let:\n  h: heard(ch)\nrules:\n  - if h > 0 then stop()\n  - else {action}\n")
    assert diagnostics(path) == [(11, 10, f"a channel is a name written without quotes: {example}", ())]


def test_a_quoted_channel_in_1_2_is_an_unknown_action_as_print_is(write) -> None:
    path = write(HEAD.replace("1.3", "1.2") + 'rules:\n  - always say("hi", 2)\n')
    assert diagnostics(path) == [(8, 12, "unknown action 'say' (to print text, use log(\"...\"))",
                                  ('e.g. log("hi {2:.2f}"): printed with the time and the robot, and recorded in the '
                                   "trace",))]


def test_a_1_2_file_is_not_told_of_heard(write) -> None:
    path = write(HEAD.replace("1.3", "1.2") + "rules:\n  - if hear(ch) > 0 then stop()\n")
    [(line, col, message, notes), unknown] = diagnostics(path)
    assert (line, col, message) == (8, 8, "unknown function 'hear'")
    assert "heard" not in notes[0] and unknown[2] == "unknown name 'ch'"


SWARM = """labsim: 1.3
world: walls_lab4
stop: time >= 0.5
robots:
  bot: {model: pioneer_p3dx, count: 3, at: [[0, 0, 0], [2, 0, 0], [4, 0, 0]]ROBOT}
"""


def test_a_say_range_of_a_robot_s_own_parameter_is_checked_for_each_robot(write) -> None:
    path = write(SWARM.replace("ROBOT", ", params: {r: [1, 0, -2]}") + "params:\n  r: 5\nlet:\n  h: heard(ch)\n"
                 "rules:\n  - when h >= 0 then say(ch, index, r)\n  - always stop()\n")
    assert diagnostics(path) == [(11, 37, "say()'s range is a distance in metres, more than 0; not 0 for robot bot[1]",
                                  ("leave it out to be heard at any distance",))]


def test_a_say_range_that_can_be_0_or_less_is_warned_about_before_and_while_running(write, tmp_path: Path) -> None:
    from labsim.backends import load_backend
    from labsim.runtime.run import Run

    path = write(SWARM.replace("ROBOT", "") + "sliders:\n  r: {min: -5, max: 5, value: 1}\nlet:\n  h: heard(ch)\n"
                 "  g: heard(ch2)\nrules:\n  - when true then say(ch, index, r), say(ch2, 1, tick - 2), "
                 "say(ch3, 1, sqrt(-1))\n  - if h + g > 5 then stop()\n")
    program = compile_file(path)
    assert [(d.line, d.col, d.message) for d in program.warnings if "range" in d.message] == [
        (12, 35, "say()'s range can be -5 (slider 'r' goes from -5 to 5): a message said with a range that is not "
                 "more than 0 metres is heard by no one"),
        (12, 51, "say()'s range can be -2 (tick counts ticks from 0): a message said with a range that is not more "
                 "than 0 metres is heard by no one")]
    warned: list[str] = []
    result = Run(program, load_backend("pymunk"), trace_path=tmp_path / "t.csv", warn=warned.append).run()
    firsts = [w.splitlines()[0].split(": warning: ", 1) for w in warned]
    assert [(where.split(":", 1)[1], what) for where, what in firsts if "range" in what] == [
        ("12:51", "say()'s range of -2 m: heard by no one (a range is more than 0 metres) in rule main:1, robot "
                  "bot[0], tick 0"),
        ("12:74", "say()'s range of nan m: heard by no one (a range is more than 0 metres) in rule main:1, robot "
                  "bot[0], tick 0")]
    counts = [f for f in result.faults if "range" in f]
    assert [f.split(": ", 1)[1] for f in counts] == [
        "say()'s range not more than 0: heard by no one: 9 times (first at tick 0, robot bot[0])",
        "say()'s range not more than 0: heard by no one: 30 times (first at tick 0, robot bot[0])"]


def test_another_robot_s_boolean_signal_reads_whatever_the_order_of_the_signals(write, tmp_path: Path) -> None:
    """Values are the last tick's: a signal read of another robot above its definition is checked first
    (with what it reads by name), so its type is known; the trace is the same as in the file's order."""
    import csv

    from labsim.backends import load_backend
    from labsim.runtime.run import Run

    below = ("  lb: 1 if leader.flag else 0\n  lz: leader.z + 1\n  base: tick\n  mid: base + 1\n"
             "  flag: mid >= 2 and leader.ok\n  z: tick * 10\n  ok: leader.mid < 3\n")
    above = ("  base: tick\n  mid: base + 1\n  ok: leader.mid < 3\n  flag: mid >= 2 and leader.ok\n  z: tick * 10\n"
             "  lb: 1 if leader.flag else 0\n  lz: leader.z + 1\n")
    head = HEAD.replace("count: 2", "count: 1").replace("stop: time >= 1", "stop: time >= 0.25")
    columns = ("tick", "robot", "lb", "lz", "flag", "ok")
    found, headers = [], []
    for i, lets in enumerate((below, above)):
        path = write(head + "let:\n" + lets + "rules:\n  - if lb > 0 and ok and lz > 0 then stop()\n", f"o{i}.yaml")
        trace = tmp_path / f"o{i}.csv"
        Run(compile_file(path), load_backend("pymunk"), trace_path=trace, warn=lambda _: None).run()
        with trace.open() as f:
            reader = csv.DictReader(x for x in f if x[0] != "#")
            found.append([tuple(r[c] for c in columns) for r in reader])
            headers.append([c for c in reader.fieldnames or () if c.startswith("leader.")])
    assert found[0] == found[1]
    # the columns of what is read of the other robot follow the signals reading them, in the file's order
    assert headers == [["leader.flag", "leader.z", "leader.ok", "leader.mid"],
                       ["leader.mid", "leader.ok", "leader.flag", "leader.z"]]
    assert [r[2:] for r in found[0] if r[1] == "leader"] == [
        ("0", "1", "0", "1"), ("0", "1", "1", "1"), ("1", "11", "1", "1"), ("1", "21", "1", "0"), ("1", "31", "0", "0"),
        ("0", "41", "0", "0")]


@pytest.mark.parametrize("name", ["and", "if", "not", "else", "then", "goto", "true"])
def test_a_robot_named_after_a_keyword_is_refused_in_1_3_where_it_is_declared(write, name: str) -> None:
    robots = f"robots:\n  {name}: {{model: pioneer_p3dx, at: [0, 0, 0]}}\nrules:\n  - always stop()\n"
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\n" + robots)
    assert diagnostics(path) == [(5, 3, f"robot '{name}' is a keyword of the language, and a robot is read by its "
                                        f"name ({name}.x) in format 1.3; choose another name",
                                  ("the language's reserved words: always, and, else, false, goto, if, not, or, "
                                   "then, true",))]
    assert compile_file(write("labsim: 1.2\nworld: walls_lab4\nstop: time >= 1\n" + robots, "old.yaml")).robots


def test_eq_on_another_robot_s_continuous_value_is_warned_about_as_on_one_s_own(write) -> None:
    path = write(HEAD + "let:\n  s5: sonar5\n  m: heard(mode, 0)\nrules:\n  - when true then say(mode, 2)\n"
                 "  - if leader.x == 2 or pioneer[1].s5 != 0.5 then stop()\n  - if s5 == 0.5 then stop()\n"
                 "  - if leader.m == 2 or heard(mode) == 2 or pioneer[0].state == main then stop()\n")
    program = compile_file(path)
    hint = "compare with '<=' or '>=' instead, e.g. 'time >= 5' rather than 'time == 5'"
    assert [(d.line, d.col, d.message, d.notes) for d in program.warnings] == [
        (12, 8, "'==' on 'leader.x', another robot's pose, which changes continuously: it may never be exactly "
                "equal, and then this would never hold", (hint,)),
        (12, 25, "'!=' on 'pioneer[1].s5', which reads 'sonar5', which changes continuously: it may never be "
                 "exactly equal, and then this would always hold", (hint,)),
        (13, 8, "'==' on 's5', which reads 'sonar5', which changes continuously: it may never be exactly equal, "
                "and then this would never hold", (hint,))]


def test_a_long_channel_or_name_is_quoted_by_its_start_and_length(write) -> None:
    long = "c" * 5000
    path = write(HEAD + f"let:\n  h: heard({long}x) + {long}\nrules:\n  - when true then say({long}, 1)\n"
                 "  - if h > 0 then stop()\n")
    start = "'" + "c" * 30 + "...'"
    assert diagnostics(path) == [
        (8, 12, f"nothing says on channel {start} (5,001 characters) (did you mean {start} (5,000 characters)?)",
         (f"channels said in this file: {start} (5,000 characters)",)),
        (8, 5017, f"unknown name {start} (5,000 characters)", ())]


def test_the_same_fault_at_several_places_of_a_rule_is_told_apart_in_the_summary(write, tmp_path: Path) -> None:
    from labsim.backends import load_backend
    from labsim.runtime.run import Run

    path = write(HEAD.replace("stop: time >= 1", "stop: time >= 0.1") + "let:\n  v: heard(n) + heard(i)\nrules:\n"
                 "  - when v >= 0 then say(n, 0/0), say(i, 1 / (tick - tick))\n  - if sqrt(-1) + 1/0 > 0 then stop()\n"
                 "  - else move(1 / 0)\n")
    result = Run(compile_file(path), load_backend("pymunk"), trace_path=tmp_path / "t.csv", warn=lambda _: None).run()
    assert list(result.faults) == [
        "rule main:1 at 10:29 (0/0): division by zero: 6 times (first at tick 0, robot leader)",
        "rule main:1 at 10:29 (0/0): say() of a value that is not finite: not sent: 6 times (first at tick 0, robot "
        "leader)",
        "rule main:1 at 10:42 (1 / (tick - tick)): division by zero: 6 times (first at tick 0, robot leader)",
        "rule main:1 at 10:42 (1 / (tick - tick)): say() of a value that is not finite: not sent: 6 times (first at "
        "tick 0, robot leader)",
        "rule main:2: sqrt(): math domain error: 6 times (first at tick 0, robot leader)",  # one place each: as before
        "rule main:2: division by zero: 6 times (first at tick 0, robot leader)",
        "rule main:3: division by zero: 6 times (first at tick 0, robot leader)",
        "rule main:3: infinite wheel command (clamped to the speed limit): 6 times (first at tick 0, robot leader)"]


READABLE = ("another robot's x, y, heading, state and signals can be read: x, y, heading, state, st, a",)
GROUP = ("a slice or a reduction of robots (pioneer[0:2].x, min(pioneer), len(pioneer)) is not a value: name each "
         "robot, as in min(pioneer[0].x, pioneer[1].x)",)


@pytest.mark.parametrize(("let", "col", "message", "notes"), [
    ("pioneer[0:2].x", 6, "'pioneer' is a group of 2 robots: read one robot's value, as in pioneer[0].x", GROUP),
    ("min(pioneer)", 10, "'pioneer' is a group of 2 robots: read one robot's value, as in pioneer[0].x", GROUP),
    ("len(pioneer)", 10, "'pioneer' is a group of 2 robots: read one robot's value, as in pioneer[0].x", GROUP),
    ("leader.X", 13, "robot 'leader' has no value 'X' (did you mean 'x'?)", READABLE),
    ("leader.start_x", 13, "'start_x' is a built-in variable: give it a signal, as in 'my_start_x: start_x', and "
                           "read leader.my_start_x", READABLE),
    ("leader.wheel_left", 13, "'wheel_left' is a built-in variable: give it a signal, as in 'my_wheel_left: "
                              "wheel_left', and read leader.my_wheel_left", READABLE),
    ("pioneer[1].stat", 17, "robot 'pioneer[1]' has no value 'stat' (did you mean 'state'?)", READABLE),
])
def test_what_cannot_be_read_of_other_robots_says_what_can(write, let: str, col: int, message: str,
                                                          notes: tuple[str, ...]) -> None:
    path = write(HEAD + f"let:\n  st: 1\n  a: {let}\nrules:\n  - if a > 0 then stop()\n")
    assert diagnostics(path) == [(9, col, message, notes)]


def test_the_values_listed_as_readable_leave_out_a_signal_that_cannot_be_read(write) -> None:
    path = write("labsim: 1.3\nworld: road_compact\nstop: time >= 0.1\nrobots:\n  leader: {model: pioneer_p3dx, "
                 "camera: {resolution: [32, 24]}}\n  b: {model: pioneer_p3dx, camera: {resolution: [32, 24]}}\nlet:\n"
                 "  blob: centroid(invert(threshold(gray(camera), 20)))\n  cx: blob.x\n  fd: 1 if leader.found else 0\n"
                 "rules:\n  - if fd > cx then stop()\n")
    assert diagnostics(path) == [(10, 19, "robot 'leader' has no value 'found'", (
        "another robot's x, y, heading, state and signals can be read: x, y, heading, state, cx, fd",))]


def test_another_robot_read_in_a_file_without_robots_says_so(write) -> None:
    path = write("labsim: 1.3\nworld: crane\nstop: time >= 1\nlet:\n  a: leader.x\nbind:\n"
                 "  Hoist_Actuator.position: a\n")
    assert diagnostics(path) == [(5, 6, "leader.x would read another robot's x, and this file has no robots",
                                  ("another robot is read by its name in a file of robots, as in leader.x",))]


def test_a_place_outside_the_group_from_a_set_names_the_set(write) -> None:
    path = write(HEAD + "params:\n  j: 1\nlet:\n  b: pioneer[j].x\nrules:\n  - if b > 0 then stop()\n")
    with pytest.raises(LabsimError) as e:
        compile_file(path, {"j": "3"})
    assert [(d.line, d.col, d.message) for d in e.value.diagnostics] == [
        (10, 14, "group 'pioneer' has 2 robots, pioneer[0] to pioneer[1]; not 3 (--set j=3)")]


def test_a_fractional_place_from_a_set_is_told_a_place_is_a_whole_number(write) -> None:
    path = write(HEAD + "params:\n  j: 1\nlet:\n  b: pioneer[j].heading\nrules:\n  - if b > 0 then stop()\n")
    with pytest.raises(LabsimError) as e:
        compile_file(path, {"j": "1.5"})
    assert [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics] == [
        (10, 14, "a robot of a group is named by its place, a whole number from 0; 'j' is 1.5 (--set j=1.5)",
         ("round it, as in pioneer[round(j)].heading, if a fraction is meant to pick the nearest",))]


def test_a_robot_outside_the_group_compares_as_nan_does(write, tmp_path: Path) -> None:
    """docs/language.md: its state is no state (== false, != true, as for a nan number); its boolean false."""
    import csv

    from labsim.backends import load_backend
    from labsim.runtime.run import Run

    path = write("labsim: 1.3\nworld: walls_lab4\nstop: time >= 0.1\nrobots:\n  bot: {model: pioneer_p3dx, count: 2, "
                 "at: [[0, 0, 0], [2, 0, 0]]}\nlet:\n  f: tick >= 0\n  nf: 1 if bot[index + 1].f else 0\n"
                 "  nnf: 1 if not bot[index + 1].f else 0\n  ns: 1 if bot[index + 1].state == main else 0\n"
                 "  nns: 1 if bot[index + 1].state != main else 0\n  nx: 1 if bot[index + 1].x != 5 else 0\n"
                 "  ex: 1 if bot[index + 1].x == 5 else 0\nrules:\n  - always stop()\n")
    trace = tmp_path / "t.csv"
    Run(compile_file(path), load_backend("pymunk"), trace_path=trace, warn=lambda _: None).run()
    with trace.open() as f:
        rows = [r for r in csv.DictReader(x for x in f if x[0] != "#") if r["tick"] == "1"]
    columns = ("nf", "nnf", "ns", "nns", "nx", "ex")
    assert [tuple(r[c] for c in columns) for r in rows] == [("1", "0", "1", "0", "1", "0"),
                                                            ("0", "1", "0", "1", "1", "0")]
