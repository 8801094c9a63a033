"""Format 1.3: a list of rows is read only where it is named (``wp[i]``, ``wp[i][0]``, ``len(wp)``); one
held by a signal, chosen by 'if ... else' or given by a function of the file's own is an error at its
place, not a failure of the compiler."""
from __future__ import annotations

import random

import pytest

from labsim.dsl.compile import compile_file
from labsim.dsl.library.support import Faults
from labsim.foundation.diagnostics import LabsimError

HEAD = ("labsim: 1.3\nworld: walls_lab4\nstop: time >= 0.2\nrobots:\n  pioneer: {model: pioneer_p3dx}\n"
        "params:\n  wp: [[1, 2], [3, 4]]\nfunctions:\n  whole(a): wp\n  row(a): wp[a]\nlet:\n")
NOTE = ("a signal, an 'if ... else' or a function's result is a number, a boolean or a group",)
BY_NAME = "which is read only where it is named: write wp[i] for a row, wp[i][0] for a number of it, or len(wp)"


@pytest.mark.parametrize(("expr", "col", "message", "notes"), [
    ("wp", 6, "a signal cannot hold the list of rows 'wp': name 'wp' where it is used, as in wp[i], wp[i][0] or "
              "len(wp)", ()),
    ("len(whole(1))", 10, f"whole() gives the list of rows 'wp', {BY_NAME}", NOTE),
    ("whole(1)[0][1]", 6, f"whole() gives the list of rows 'wp', {BY_NAME}", NOTE),
    ("wp if tick > 1 else wp", 6, f"this is a list of rows 'wp', {BY_NAME}", NOTE),
    ("min(whole(0)[1])", 10, f"whole() gives the list of rows 'wp', {BY_NAME}", NOTE),
    ("1 + (wp if tick > 1 else wp)[0][0]", 11, f"this is a list of rows 'wp', {BY_NAME}", NOTE),
])
def test_a_list_used_as_a_value_is_an_error_at_its_place(write, expr: str, col: int, message: str,
                                                          notes: tuple[str, ...]) -> None:
    path = write(HEAD + f"  v: {expr}\nrules:\n  - always stop()\n")
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    assert [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics] == [(12, col, message, notes)]


def test_a_function_giving_a_row_of_a_list_is_a_group(write) -> None:
    path = write(HEAD + "  v: row(1)[0] + len(wp)\nrules:\n  - always stop()\n")
    program = compile_file(path)
    robot = program.robot("pioneer", random.Random(1), Faults())
    robot.signals(0.0, 0, [0.0] * len(program.channels))
    assert robot.slots[program.slot_of["v"]] == 5.0
