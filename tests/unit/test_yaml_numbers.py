"""Numbers in labsim's YAML files as YAML 1.2's core schema reads them (labsim.foundation.source): 017 is
17, 0o17 octal, 0x10 hexadecimal; YAML 1.1's base 60, '_' between digits and 0b are errors at their place."""
from __future__ import annotations

from pathlib import Path

import pytest

from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.source import loads
from labsim.foundation.yaml_data import plain


def test_integers_and_floats_read_as_yaml_12_core() -> None:
    root = loads("a: [017, 0o17, 0x10, -3, +4, 1e6, 1e-3, .5, 5., -.inf, 1.5e+3, 1.0, '1:30', true]", "x.yaml")
    assert plain(root.root) == {"a": [17, 15, 16, -3, 4, 1e6, 1e-3, 0.5, 5.0, -float("inf"), 1500.0, 1.0, "1:30", True]}


@pytest.mark.parametrize(("value", "col", "read_as"), [
    ("1:30", 6, "90"), ("1_000", 6, "1000"), ("-0b101", 6, "-5"), ("1:30:00.5", 6, "5400.5"),
])
def test_a_yaml_11_number_is_an_error_saying_what_it_was_read_as(tmp_path: Path, value: str, col: int,
                                                                 read_as: str) -> None:
    path = tmp_path / "b.yaml"
    path.write_text("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                    f"params:\n  k: {value}\nrules:\n  - if k > 1 then stop()\n")
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    assert [(d.line, d.col, d.message, d.notes) for d in e.value.diagnostics] == [
        (7, col, f"'{value}' is no number: labsim files read numbers as YAML 1.2 does, without base 60 (1:30), "
                 "'_' between digits or 0b", (f"YAML 1.1 read it as {read_as}: write {read_as} if that is meant",))]


def test_a_leading_zero_is_decimal_in_a_list(tmp_path: Path) -> None:
    path = tmp_path / "b.yaml"
    path.write_text("labsim: 1.3\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                    "params:\n  wp: [[0, 017], [0o17, 0x10]]\nrules:\n  - if wp[0][1] > 1 then stop()\n")
    assert compile_file(path).lists["wp"] == ((0.0, 17.0), (15.0, 16.0))
