"""Trace rows written by the generated one-format path are the bytes the cell-by-cell path
(``fmt`` and ``csv.writer``) writes: for every lab, for texts that need quoting, for logs in
the events cell, for numbers "%.6g" writes otherwise than ``fmt`` (ints of 10**6 and more)."""
from __future__ import annotations

import csv
import io
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from labsim.runtime import observers
from labsim.runtime.api import run
from labsim.runtime.trace import csv_cell, fmt

ROOT = Path(__file__).resolve().parents[2]

LOGS = """labsim: 1.2
name: "quotes \\"and\\", commas"
world: walls_lab4
dt: 0.05
seed: 3
stop: time >= 60
robots:
  pioneer: {model: pioneer_p3dx, at: random}
let:
  big: 1234567
  r: randint(0, 2000000)
  near: sonar5 < 2
  turns: counter(r > 1000000)
rules:
  - when rising(near) then log('near, "said" the+sonar at {time:.1f}')
  - if near then arc(-2, 2)
  - always arc(4, 4 + r / 2000000)
"""


def _cell_by_cell(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every row the general way: no generated row, and a format that always defers."""
    monkeypatch.setattr(observers, "_fast_rows", lambda rows: rows.after_act)
    monkeypatch.setattr(observers, "_row_cells", lambda *_: lambda *args: "e+")


@pytest.mark.parametrize("behaviour", ["wall_follow", "road_follow", "crane", "logs"])
def test_generated_rows_are_the_cell_by_cell_bytes(behaviour: str, tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    path = ROOT / "behaviours" / f"{behaviour}.yaml"
    params: dict[str, float] = {}
    if behaviour == "logs":
        path = tmp_path / "logs.yaml"
        path.write_text(LOGS)
    elif behaviour == "wall_follow":
        params = {"minutes": 1}
    run(path, params=params, trace=tmp_path / "fast.csv")
    with monkeypatch.context() as m:
        _cell_by_cell(m)
        run(path, params=params, trace=tmp_path / "slow.csv")
    fast, slow = (tmp_path / "fast.csv").read_bytes(), (tmp_path / "slow.csv").read_bytes()
    assert fast.split(b"\n")[1:] == slow.split(b"\n")[1:]  # the header line names the file's path
    if behaviour == "logs":
        assert b'"log: near, ""said"" the+sonar' in fast


@given(st.text())
def test_a_text_cell_is_what_csv_writes(text: str) -> None:
    out = io.StringIO()
    csv.writer(out, lineterminator="\n").writerow(["a", text, "b"])
    assert out.getvalue() == f"a,{csv_cell(text)},b\n"


@given(st.one_of(st.floats(), st.booleans(), st.integers(-999_999, 999_999)))
def test_percent_g_writes_what_fmt_writes(value: float) -> None:
    assert "%.6g" % value == fmt(value)  # noqa: UP031 - the row's format is printf-style


@given(st.integers(min_value=10**6) | st.integers(max_value=-10**6))
def test_a_big_int_shows_where_the_two_differ(value: int) -> None:
    assert "e+" in "%.6g" % value  # noqa: UP031 - the row is then written cell by cell, as fmt() writes it
