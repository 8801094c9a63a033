"""Format 1.3's read-back: ``wheel_left``, ``wheel_right`` (last tick's wheel commands as the wheels were sent
them) and the start pose ``start_x``, ``start_y``, ``start_heading``; tick by tick, their mistakes, and a
grader's measured metric that reads the wheels."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from labsim.backends import load_backend
from labsim.backends.scene.models import PIONEER_P3DX
from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.run import Run

HEAD = "labsim: 1.3\nworld: walls_lab4\nstop: tick >= 5\nrobots:\n  p: {model: pioneer_p3dx, at: [1, 2, 270]}\n"


def diagnostics(path: Path) -> list[tuple[int, int, str]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    return [(d.line, d.col, d.message) for d in e.value.diagnostics]


def signal_rows(path: Path, names: tuple[str, ...]) -> list[tuple]:
    """Each tick's values of the signals ``names`` (of the first robot), as the run computed them."""
    program = compile_file(path)
    rows: list[tuple] = []
    run = Run(program, load_backend("pymunk"), warn=lambda _: None)
    slots = [program.slot_of[n] for n in names]
    while run.tick():
        rows.append(tuple(run.robots[0].program.slots[k] for k in slots))
    return rows


def test_the_wheels_read_last_ticks_command_clamped_as_sent_and_nan_as_stopped(write) -> None:
    path = write(HEAD + "let:\n  wl: wheel_left\n  wr: wheel_right\nrules:\n"
                 "  - if tick < 2 then arc(100, -3)\n  - if tick < 3 then arc(-inf, 2.5)\n"
                 "  - else arc(inf * 0, 1)\n")
    # tick 0 reads 0 (nothing sent yet); 100 rad/s was sent as the Pioneer's 12.3; -inf as -12.3; nan as 0
    assert signal_rows(path, ("wl", "wr")) == [(0.0, 0.0), (12.3, -3.0), (12.3, -3.0), (-12.3, 2.5), (0.0, 1.0)]


def test_drive_and_move_are_read_back_in_wheel_rad_s_and_stop_as_zero(write) -> None:
    path = write(HEAD + "let:\n  wl: wheel_left\n  wr: wheel_right\nrules:\n"
                 "  - if tick == 0 then drive(0.5, 1)\n  - if tick == 1 then move(4)\n  - else stop()\n")
    rows = signal_rows(path, ("wl", "wr"))
    radius, half = PIONEER_P3DX.wheel_radius_m, PIONEER_P3DX.axle_length_m / 2
    left, right = rows[1]
    assert (rows[0], rows[2], rows[3]) == ((0.0, 0.0), (4.0, 4.0), (0.0, 0.0))
    assert math.isclose(left, (0.5 - half) / radius) and math.isclose(right, (0.5 + half) / radius)


def test_the_start_pose_is_in_metres_and_radians_in_the_range_heading_reads(write) -> None:
    path = write(HEAD.replace("at: [1, 2, 270]}", "count: 2, at: [[1, 2, 270], [-1, 0.5, 180]]}")
                 + "let:\n  sx: start_x\n  sy: start_y\n  sh: start_heading\n  h: heading\n"
                 "rules:\n  - always move(1)\n")
    program = compile_file(path)
    run = Run(program, load_backend("pymunk"), warn=lambda _: None)
    run.tick()
    got = [tuple(r.program.slots[program.slot_of[n]] for n in ("sx", "sy", "sh", "h")) for r in run.robots]
    assert got[0][:3] == (1.0, 2.0, -math.pi / 2) and got[1][:3] == (-1.0, 0.5, math.pi)
    assert [math.isclose(sh, h, abs_tol=1e-9) for _, _, sh, h in got] == [True, True]  # the pose the run starts at


def test_a_random_start_is_read_back_as_placed(write) -> None:
    path = write(HEAD.replace("at: [1, 2, 270]", "at: random") + "let:\n  sx: start_x\n  sy: start_y\n"
                 "rules:\n  - always move(1)\n")
    program = compile_file(path)
    run = Run(program, load_backend("pymunk"), warn=lambda _: None)
    run.tick()
    slots = run.robots[0].program.slots
    pose = program.starts[0].pose
    assert (slots[program.slot_of["sx"]], slots[program.slot_of["sy"]]) == (pose.x_m, pose.y_m)


@pytest.mark.parametrize("name", ["wheel_left", "wheel_right", "start_x", "start_y", "start_heading"])
def test_read_back_is_format_1_3(write, name: str) -> None:
    path = write(HEAD.replace("labsim: 1.3", "labsim: 1.2") + f"rules:\n  - if {name} > 0 then move(1)\n")
    assert diagnostics(path) == [(7, 8, f"'{name}' is format 1.3: start the file with 'labsim: 1.3'")]


def test_a_mechanism_has_no_wheels_to_read_back(write) -> None:
    path = write("labsim: 1.3\nworld: crane\nstop: time >= 1\nbind:\n  Arm_Actuator.velocity: wheel_left\n")
    assert diagnostics(path) == [(5, 26, "'wheel_left' reads a robot's wheel command, and world 'crane' is a "
                                          "mechanism: there is no robot with wheels")]
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    assert e.value.diagnostics[0].notes == ("read-back is of robots with wheels: pioneer_p3dx, epuck",)


def test_a_file_of_1_2_keeps_its_own_start_x(write) -> None:
    path = write(HEAD.replace("labsim: 1.3", "labsim: 1.2") + "params: {start_x: 3}\n"
                 "let:\n  s: start_x\nrules:\n  - always move(1)\n")
    assert signal_rows(path, ("s",))[0] == (3,)


def test_a_file_of_1_2_may_name_its_own_start_heading_and_one_of_1_3_may_not(write) -> None:
    text = "let:\n  start_heading: 2\n  s: start_heading\nrules:\n  - always move(1)\n"
    path = write(HEAD.replace("1.3", "1.2") + text)
    assert signal_rows(path, ("s",))[0] == (2.0,)
    with pytest.raises(LabsimError) as e:
        compile_file(write(HEAD + text))
    assert [(d.line, d.col, d.message) for d in e.value.diagnostics] == [
        (7, 3, "signal 'start_heading' is the name of a built-in variable of format 1.3; choose another name")]


@pytest.mark.parametrize("name", ["start_x", "start_y", "start_heading"])
def test_a_start_name_read_above_the_signal_that_takes_it_is_used_before_it_is_defined(write, name: str) -> None:
    # format 1.2: the signal below has the name, and reading it above would read a value not yet computed
    text = f"let:\n  a: {name}\n  b: prev({name}, 0)\n  {name}: 5\nrules:\n  - always move(a + b)\n"
    message = f"signal '{name}' is used before it is defined (on line 9); 'let' signals are evaluated in order"
    assert diagnostics(write(HEAD.replace("1.3", "1.2") + text)) == [(7, 6, message), (8, 11, message)]
    # format 1.3: the name is the built-in's, refused once where the file takes it
    assert diagnostics(write(HEAD + text)) == [
        (9, 3, f"signal '{name}' is the name of a built-in variable of format 1.3; choose another name")]


@pytest.mark.parametrize("version", ["1.2", "1.3"])
def test_a_signal_or_parameter_named_as_a_wheel_is_one_message_at_its_name(write, version: str) -> None:
    path = write(HEAD.replace("1.3", version) + "params:\n  wheel_left: 2\n"
                 "let:\n  a: wheel_right + wheel_left\n  wheel_right: 5\n  b: wheel_right\n"
                 "rules:\n  - always move(a + b)\n")
    why = "a trace column" if version == "1.2" else "a built-in variable of format 1.3"
    assert diagnostics(path) == [
        (7, 3, f"parameter 'wheel_left' is the name of {why}; choose another name"),
        (10, 3, f"signal 'wheel_right' is the name of {why}; choose another name")]


def test_a_file_reading_none_of_it_computes_none_of_it(write) -> None:
    code = compile_file(write(HEAD + "rules:\n  - always move(1)\n")).code.source
    assert "cmd[0]\n" not in code and "_c = " not in code


def test_a_measured_metric_reads_the_wheels_of_a_file_of_any_format(write, tmp_path: Path) -> None:
    from labsim.runtime.grade.assignment import read_assignment
    from labsim.runtime.grade.measure import prepare_graded, split_metrics

    assignment = tmp_path / "a.yaml"
    assignment.write_text("labsim-assignment: 1\nworld: walls_lab4\nrobots: 1\nmeasure:\n"
                          "  spin: maximum(abs(wheel_left - wheel_right))\ncriteria: {spin: {at_most: 30}}\n")
    a = read_assignment(assignment)
    student = write(HEAD.replace("labsim: 1.3", "labsim: 1.2") + "rules:\n  - if tick < 3 then arc(2, 40)\n"
                    "  - else arc(1, 1)\n")
    program = prepare_graded(student, measure=a.measure).program()
    result = Run(program, load_backend("pymunk"), warn=lambda _: None).run()
    assert split_metrics(result.metric_values())[1] == {"spin": 12.3 - 2}  # 40 rad/s was sent as the Pioneer's 12.3


def test_a_measured_metric_may_not_read_a_students_signal_but_may_read_the_wheels(tmp_path: Path) -> None:
    from labsim.runtime.grade.assignment import read_assignment

    assignment = tmp_path / "a.yaml"
    assignment.write_text("labsim-assignment: 1\nworld: walls_lab4\nrobots: 1\nmeasure:\n"
                          "  spin: maximum(wheel_left + speed)\ncriteria: {spin: {at_most: 30}}\n")
    with pytest.raises(LabsimError) as e:
        read_assignment(assignment)
    [d] = e.value.diagnostics
    assert (d.line, d.col) == (5, 30) and "wheel_left" in d.notes[0]


def test_the_language_server_knows_the_read_back_names_and_len() -> None:
    from labsim.runtime.lsp.language import builtins

    known = builtins()
    assert known["wheel_left"].kind == "variable" and "clamped to the model's limit" in known["wheel_left"].doc
    assert known["start_heading"].doc == "the robot's heading at the start, radians in (-pi, pi] (format 1.3)"
    assert known["len"].kind == "function" and "rows a list parameter has" in known["len"].doc


def test_a_comparison_the_read_back_ranges_decide_warns_with_the_unit(write) -> None:
    path = write(HEAD + "rules:\n  - if wheel_left > 20 then move(1)\n  - if start_heading > 90 then move(1)\n"
                 "  - if start_x > 8 then move(1)\n  - if wheel_right <= 12.3 then move(2)\n  - else stop()\n")
    assert [(d.line, d.col, d.message) for d in compile_file(path).warnings] == [
        (7, 8, "'wheel_left > 20' never holds: wheel_left is in rad/s, at most 12.3 either way (pioneer_p3dx's "
               "max_wheel_speed: a command is held to it)"),
        (8, 8, "'start_heading > 90' never holds: start_heading is in radians, from -pi to pi (-180 to 180 degrees); "
               "did you mean start_heading > rad(90)?"),
        (9, 8, "'start_x > 8' never holds: start_x is in metres, from -7.5 to 7.5 (the walls around world "
               "'walls_lab4')")]


def test_each_robot_reads_its_own_models_limit_and_no_wheel_noise(write) -> None:
    path = write("labsim: 1.3\nworld: walls_lab4\nstop: tick >= 3\nrobots:\n"
                 "  e: {model: epuck, at: [0, 0, 0], noise: {wheels: {std_rad_s: 2, slip: 0.5}}}\n"
                 "  p: {model: pioneer_p3dx, at: [2, 2, 0]}\nlet:\n  wl: wheel_left\n  n: len([x, y, tick])\n"
                 "rules:\n  - always arc(50, -1)\n")
    program = compile_file(path)
    run = Run(program, load_backend("pymunk"), warn=lambda _: None)
    seen = []
    while run.tick():
        seen.append(tuple(r.program.slots[program.slot_of["wl"]] for r in run.robots))
    assert seen == [(0.0, 0.0), (6.24, 12.3), (6.24, 12.3)]  # the e-puck's limit and the Pioneer's; no noise
    assert run.robots[0].program.slots[program.slot_of["n"]] == 3.0  # len() of a group: its members


@pytest.mark.parametrize("version", ["1.2", "1.3"])
def test_a_breakpoint_on_a_read_back_name_the_file_does_not_read_says_how_to_watch_it(write, version: str) -> None:
    from labsim.dsl.watch import compile_watch

    program = compile_file(write(HEAD.replace("1.3", version) + "rules:\n  - always move(1)\n"))
    with pytest.raises(LabsimError) as e:
        compile_watch(program, "tick > 1 and start_y < wheel_left")
    got = [(d.path, d.line, d.col, d.message, d.notes) for d in e.value.diagnostics]
    if version == "1.2":
        assert got == [("--break", 1, 14, "'start_y' is format 1.3: start the file with 'labsim: 1.3'", ()),
                       ("--break", 1, 24, "'wheel_left' is format 1.3: start the file with 'labsim: 1.3'", ())]
        return
    assert got == [
        ("--break", 1, 14, "'start_y' (the robot's start pose) is read back only where the behaviour reads it: a "
                           "breakpoint sees what the behaviour reads",
         ("read it in a signal of the file (e.g. 'let: seen: start_y') and watch the signal",)),
        ("--break", 1, 24, "'wheel_left' (the robot's wheel command) is read back only where the behaviour reads it: "
                           "a breakpoint sees what the behaviour reads",
         ("read it in a signal of the file (e.g. 'let: seen: wheel_left') and watch the signal",))]
