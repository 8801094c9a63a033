"""What ``labsim.run(...)`` returns, shown in a notebook: a table of the run with its map (and
its animation when asked), through ``_repr_html_``, called here as Jupyter calls it."""
from __future__ import annotations

import base64
import json
import re
import tempfile
from pathlib import Path

import pytest

import labsim
from labsim.runtime import api
from labsim.runtime.labs import LABS_DIR


def _images(page: str) -> dict[str, list[bytes]]:
    found: dict[str, list[bytes]] = {}
    for mime, data in re.findall(r"src='data:(image/\w+);base64,([A-Za-z0-9+/=]+)'", page):
        found.setdefault(mime, []).append(base64.b64decode(data))
    return found


@pytest.mark.slow
def test_a_run_shows_as_a_table_with_its_map(tmp_path: Path) -> None:
    summary = labsim.run("wall_follow", params={"minutes": 0.5})
    assert isinstance(summary, dict) and json.loads(json.dumps(summary)) == dict(summary)
    page = summary._repr_html_()
    assert "<th style='text-align:left'>behaviour</th><td style='text-align:left'>Wall following with sonars (" in page
    assert "<td style='text-align:left'>walls_lab4</td>" in page
    assert "<td style='text-align:left'>600</td>" in page  # ticks
    for metric in ("near_misses", "overshoot", "following", "closest"):
        assert f"<th style='text-align:left'>{metric}</th>" in page
    assert "<td style='text-align:left'>wander:1</td>" in page
    images = _images(page)
    assert list(images) == ["image/png"] and images["image/png"][0].startswith(b"\x89PNG\r\n\x1a\n")
    moving = _images(summary.html(animation=True))
    assert moving["image/gif"][0].startswith(b"GIF89a")


@pytest.mark.slow
def test_the_animation_when_asked_and_a_mechanism_drawn_from_a_trace_of_its_own() -> None:
    before = set(Path(tempfile.gettempdir()).glob("labsim-run-*"))
    summary = labsim.run("crane", animation=True)
    assert set(Path(tempfile.gettempdir()).glob("labsim-run-*")) == before  # its trace was removed
    images = _images(summary._repr_html_())
    assert images["image/png"][0].startswith(b"\x89PNG") and images["image/gif"][0].startswith(b"GIF89a")


@pytest.mark.slow
def test_a_long_run_keeps_a_thinned_recording_for_its_map() -> None:
    summary = labsim.run("wall_follow", params={"minutes": 4})
    assert summary._drawn is None  # nothing is recorded until the summary is shown
    kept = summary.drawn()
    assert summary["ticks"] == 4800 and kept is not None
    assert len(kept.rows) <= api.DRAWN_TICKS + sum(1 for r in kept.rows if r[-1])
    assert kept.numbers["tick"][-1] == 4800 and kept.numbers["tick"][0] == 0


@pytest.mark.slow
def test_file_text_is_escaped(tmp_path: Path) -> None:
    text = (LABS_DIR / "wall_follow.yaml").read_text(encoding="utf-8").replace(
        "name: Wall following with sonars", "name: \"<script>alert(1)</script> & co\"")
    f = tmp_path / "wall.yaml"
    f.write_text(text, encoding="utf-8")
    page = labsim.run(f, params={"minutes": 0.05})._repr_html_()
    assert "<script>" not in page and "&lt;script&gt;alert(1)&lt;/script&gt; &amp; co" in page


def test_a_summary_whose_trace_is_gone_says_so() -> None:
    summary = api.RunSummary({"schema": "labsim-summary", "robots": {}}, "/no/such/run.csv", False)
    assert "<em>no map: /no/such/run.csv: no such trace file</em>" in summary._repr_html_()


@pytest.mark.slow
def test_the_map_is_the_run_the_summary_reports(tmp_path: Path) -> None:
    traced = labsim.run("wall_follow", params={"minutes": 0.5}, trace=tmp_path / "run.csv")
    again = labsim.run("wall_follow", params={"minutes": 0.5})
    kept, made_again = traced.drawn(), again.drawn()
    assert kept is not None and made_again is not None and traced["ticks"] == again["ticks"] == 600
    assert len(kept.rows) == len(made_again.rows) == 601  # 600 ticks and the one the run stopped on
    for column in ("tick", "x", "y", "heading"):
        written = [float(v) for v in kept.column(column)]
        assert written == pytest.approx(list(made_again.numbers[column]), abs=1e-5), column


def test_a_copy_keeps_the_figures_not_the_run() -> None:
    import copy
    import pickle
    summary = api.RunSummary({"schema": "labsim-summary", "robots": {}}, None, False, lambda: None)  # type: ignore[arg-type,return-value]
    for copied in (copy.deepcopy(summary), pickle.loads(pickle.dumps(summary))):
        assert dict(copied) == dict(summary) and copied._again is None
