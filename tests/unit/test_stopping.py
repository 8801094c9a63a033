"""Stopping: which part of the stop condition held, for which robot and when; the stopping tick
folded into metrics and traced in format 1.1, and not in format 1."""
from __future__ import annotations

import csv
import json
from pathlib import Path

from helpers import run_example

from labsim.backends import load_backend
from labsim.dsl.compile import compile_file
from labsim.runtime.cli.report import format_summary
from labsim.runtime.run import Run

MARK = """labsim: {version}
world: walls_lab4
stop: time >= 30 or (tick < 0 or reached >= 1)
robots:
  pioneer: {{model: pioneer_p3dx, at: random, count: {count}}}
let:
  reached: 1 if time >= 2 and index == {last} else 0
rules:
  - always move(2)
metrics:
  marks: final(reached)
  rises: count(reached >= 1)
  timed: duration(time >= 0)
"""


def run_mark(tmp_path: Path, version: str = "1.1", count: int = 1) -> tuple[Run, object, list[dict]]:
    path = tmp_path / "mark.yaml"
    path.write_text(MARK.format(version=version, count=count, last=count - 1))
    run = Run(compile_file(path), load_backend("pymunk"), trace_path=tmp_path / "t.csv")
    summary = run.run()
    with open(tmp_path / "t.csv") as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    return run, summary, rows


def test_the_summary_names_the_or_part_that_held_the_robot_and_the_time(tmp_path: Path) -> None:
    run, summary, _ = run_mark(tmp_path)
    assert summary.stopped_by == "pioneer"  # type: ignore[attr-defined]
    assert summary.stop_condition == "reached >= 1"  # type: ignore[attr-defined]
    status = format_summary(summary).splitlines()[1]  # type: ignore[arg-type]
    assert status.endswith("; stopped at tick 40 (2.00 s): 'reached >= 1' held for robot pioneer")


def test_a_stop_condition_without_or_is_named_whole(tmp_path: Path) -> None:
    path = tmp_path / "t.yaml"
    path.write_text(MARK.format(version="1.1", count=1, last=0).replace(
        "time >= 30 or (tick < 0 or reached >= 1)", "time >= 1.5"))
    run = Run(compile_file(path), load_backend("pymunk"))
    assert run.run().stop_condition == "time >= 1.5"


def test_format_1_1_folds_and_traces_the_stopping_tick(tmp_path: Path) -> None:
    _, summary, rows = run_mark(tmp_path)
    # the stopping tick is sampled but lasts no time: durations add up to the time simulated
    assert summary.robots["pioneer"].metrics == {"marks": 1, "rises": 1, "timed": 2.0}  # type: ignore[attr-defined]
    assert summary.ticks == 40  # type: ignore[attr-defined]
    last = rows[-1]
    assert (last["tick"], last["rule"], last["reached"], last["events"]) == ("40", "", "1", "rises")
    assert rows[-2]["rule"] == "main:1"


def test_format_1_neither_folds_nor_traces_the_stopping_tick(tmp_path: Path) -> None:
    _, summary, rows = run_mark(tmp_path, version="1")
    assert summary.robots["pioneer"].metrics == {"marks": 0, "rises": 0, "timed": 2.0}  # type: ignore[attr-defined]
    assert rows[-1]["tick"] == "39"


def test_a_fleet_stops_for_the_robot_whose_condition_held_and_every_robot_folds(tmp_path: Path) -> None:
    run, summary, rows = run_mark(tmp_path, count=3)
    assert summary.stopped_by == "pioneer[2]"  # type: ignore[attr-defined]
    assert [r["rule"] for r in rows if r["tick"] == "40"] == ["", "", ""]
    metrics = {name: r.metrics["marks"] for name, r in summary.robots.items()}  # type: ignore[attr-defined]
    assert metrics == {"pioneer[0]": 0, "pioneer[1]": 0, "pioneer[2]": 1}


def test_the_json_summary_names_the_condition_and_robot(tmp_path: Path) -> None:
    from labsim.runtime.summary_json import summary_dict
    run, summary, _ = run_mark(tmp_path)
    data = json.loads(json.dumps(summary_dict(summary)))  # type: ignore[arg-type]
    assert (data["stopped_by"], data["stop_condition"]) == ("pioneer", "reached >= 1")


def test_the_docs_example_reports_the_mark_that_stopped_it(tmp_path: Path) -> None:
    _, summary, _ = run_example("first_mark", tmp_path)
    assert summary.stop_condition == "reached >= 1"  # type: ignore[attr-defined]
    assert summary.robots["pioneer"].metrics["marks"] == 1  # type: ignore[attr-defined]
    assert summary.ticks == 146  # type: ignore[attr-defined]
