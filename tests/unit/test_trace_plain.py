"""Reading a trace for an animation only as far as its columns (runtime/pictures/trace_plain.py):
the cells, lines and numbers are the csv module's, and anything not plain is read by it."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from helpers import BEHAVIOURS

from labsim.runtime import trace as trace_module
from labsim.runtime.pictures.animate import MOVIE_COLUMNS, movie_columns
from labsim.runtime.pictures.trace_sample import CHECKED, read_for_picture
from labsim.runtime.trace import Trace, TraceFormatError

GOLDEN = BEHAVIOURS / "wall_follow.golden.csv"


def cut(trace: Trace, columns: list[str]) -> list[list[str]]:
    idx = [trace.columns.index(c) for c in columns]
    return [[r[i] for i in idx] for r in trace.rows]


def assert_same_as_csv(path: Path) -> Trace:
    """The narrow read holds what the csv module's read holds in those columns."""
    whole, _ = read_for_picture(str(path))
    narrow, note = read_for_picture(str(path), wanted=movie_columns)
    assert note == "" and narrow.rows == cut(whole, narrow.columns)
    assert narrow.lines == whole.lines and narrow.footer == whole.footer and narrow.header == whole.header
    assert narrow.numbers.keys() == whole.numbers.keys()
    assert all(np.array_equal(narrow.numbers[k], whole.numbers[k]) for k in whole.numbers)
    return narrow


def test_an_animation_reads_its_columns_only_and_the_same_cells() -> None:
    narrow = assert_same_as_csv(GOLDEN)
    assert narrow.columns == ["tick", "time", "robot", "x", "y", "heading", "collided", "state", "rule", "events"]


def test_the_columns_checked_are_always_read() -> None:
    assert CHECKED == trace_module._WHOLE + trace_module._NUMBER
    assert set(CHECKED) <= set(MOVIE_COLUMNS)


def test_a_mechanism_s_animation_reads_every_column() -> None:
    crane = BEHAVIOURS / "crane.golden.csv"
    whole, _ = read_for_picture(str(crane))
    assert read_for_picture(str(crane), wanted=movie_columns)[0].columns == whole.columns


def edited(tmp_path: Path, change: str) -> Path:
    lines = GOLDEN.read_text().splitlines(keepends=True)
    state = lines[1].split(",").index("state")
    cells = lines[5].split(",")
    if change == "quoted":
        cells[state] = '"two\nlines, and a comma"'
    elif change == "short":
        del cells[state]
    elif change == "bad x":
        cells[3] = "x"
    lines[5] = ",".join(cells)
    if change == "blank":
        lines.insert(9, "\n")
    if change == "half":
        lines[-1] = lines[-1][:20]
    if change == "no newline":
        lines[-1] = lines[-1].rstrip("\n")
    path = tmp_path / "edited.csv"
    path.write_text("".join(lines))
    return path


@pytest.mark.parametrize("change", ["quoted", "blank", "half", "no newline"])
def test_what_is_not_plain_is_read_as_the_csv_module_reads_it(tmp_path: Path, change: str) -> None:
    assert_same_as_csv(edited(tmp_path, change))


@pytest.mark.parametrize("change", ["short", "bad x"])
def test_a_damaged_row_has_the_csv_reader_s_message(tmp_path: Path, change: str) -> None:
    path = str(edited(tmp_path, change))
    with pytest.raises(TraceFormatError) as whole:
        read_for_picture(path)
    with pytest.raises(TraceFormatError) as narrow:
        read_for_picture(path, wanted=movie_columns)
    assert str(narrow.value) == str(whole.value) and narrow.value.line == whole.value.line == 6


def test_numpy_reads_a_number_cell_as_float_does() -> None:
    # the plain read checks its number columns by converting them with numpy (Trace.numbers)
    for cell in ["1.5", " 2 ", "1_0", "\u0661\u0662", "inf", "-Infinity", "nan", "1e400", "0x10", "", "1,5", "--1"]:
        try:
            expected: float | None = float(cell)
        except ValueError:
            expected = None
        try:
            got: float | None = float(np.array([cell], dtype=float)[0])
        except ValueError:
            got = None
        assert got == expected or (got != got and expected != expected), cell


def test_a_bad_tick_has_the_csv_reader_s_message(tmp_path: Path) -> None:
    lines = GOLDEN.read_text().splitlines(keepends=True)
    lines[7] = "7a" + lines[7][lines[7].index(","):]
    path = tmp_path / "tick.csv"
    path.write_text("".join(lines))
    with pytest.raises(TraceFormatError) as whole:
        read_for_picture(str(path))
    with pytest.raises(TraceFormatError) as narrow:
        read_for_picture(str(path), wanted=movie_columns)
    assert str(narrow.value) == str(whole.value) and "column 'tick' holds '7a'" in str(whole.value)


def test_the_first_pose_far_outside_the_world_is_found_from_the_numbers(tmp_path: Path) -> None:
    from labsim.foundation.diagnostics import LabsimError
    from labsim.runtime.pictures.driver import _check_in_world

    lines = GOLDEN.read_text().splitlines(keepends=True)
    columns = lines[1].rstrip("\n").split(",")
    for at, x, y in ((5, "nan", "1e308"), (9, "-1e300", "0")):  # a row with x nan is drawn without it
        cells = lines[at].split(",")
        cells[columns.index("x")], cells[columns.index("y")] = x, y
        lines[at] = ",".join(cells)
    path = tmp_path / "far.csv"
    path.write_text("".join(lines))
    trace, _ = read_for_picture(str(path), wanted=movie_columns)
    with pytest.raises(LabsimError) as far:
        _check_in_world(trace)
    assert far.value.diagnostics[0].line == 10 and "(-1e+300, 0)" in far.value.diagnostics[0].message
