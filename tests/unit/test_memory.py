"""Time and memory, per-robot settings, log() and stopping: the worked examples of docs/language.md run."""
from __future__ import annotations

import csv
from pathlib import Path

import pytest
from helpers import BEHAVIOURS, examples, run_example

from labsim.backends import load_backend
from labsim.dsl.compile import compile_file
from labsim.dsl.library import memory
from labsim.runtime.run import Run


def test_the_docs_have_the_worked_examples() -> None:
    assert set(examples()) == {"bump_and_turn", "remember_hit", "wait_until_calm", "three_thresholds",
                               "first_mark", "back_on_road", "walls_ahead", "distance_driven", "nearest_sonar",
                               "log_and_drive", "keep_right", "patrol", "odometry", "lidar_sectors",
                               "leader_follower", "formation_of_three"}


def test_bump_and_turn_backs_up_for_one_second(tmp_path: Path) -> None:
    run, summary, warned = run_example("bump_and_turn", tmp_path, trace=True)
    rows = list(csv.DictReader(line for line in (tmp_path / "t.csv").open() if not line.startswith("#")))
    states = [r["state"] for r in rows]
    first = states.index("back")
    backing = states[first:].index("turn")
    assert backing == 21  # 20 ticks of move(-4), and the tick whose state_time is 1.0 moves on
    assert states[first + backing:].index("forward") == 17  # 0.8 s / 0.05 s, and the goto tick
    assert summary.robots["pioneer"].metrics["bumps"] >= 1  # type: ignore[attr-defined]
    assert any(line.endswith(f"pioneer: hit at {float(rows[first - 1]['time']):.2f} s") for line in warned)
    assert rows[first - 1]["events"].startswith("log: hit at")


def test_remember_hit_keeps_the_time_of_the_last_bump(tmp_path: Path) -> None:
    _, summary, _ = run_example("remember_hit", tmp_path)
    last = summary.robots["pioneer"].metrics["last_hit"]  # type: ignore[attr-defined]
    assert 0 < last < 30


def test_wait_until_calm_stops_on_a_calm_load(tmp_path: Path) -> None:
    _, summary, _ = run_example("wait_until_calm", tmp_path)
    assert summary.stopped_by is not None  # type: ignore[attr-defined]
    assert 5 <= summary.sim_time_s < 40  # type: ignore[attr-defined]


def test_three_thresholds_each_robot_has_its_own(tmp_path: Path) -> None:
    _, summary, _ = run_example("three_thresholds", tmp_path)
    robots = summary.robots  # type: ignore[attr-defined]
    assert [robots[f"pioneer[{k}]"].metrics["threshold"] for k in range(3)] == [0.3, 0.5, 0.8]
    assert summary.stopped_by == "pioneer[0]"  # type: ignore[attr-defined]


def test_back_on_road_logs_no_edge_at_the_start(tmp_path: Path) -> None:
    _, _, warned = run_example("back_on_road", tmp_path)
    logged = [line for line in warned if "back on the road" in line]
    assert logged and logged[0].endswith("pioneer: back on the road at 16.05 s")
    path = tmp_path / "v11.yaml"  # the same file in format 1.1: rising() holds on the first tick
    path.write_text(examples()["back_on_road"].replace("labsim: 1.2", "labsim: 1.1"))
    earlier: list[str] = []
    Run(compile_file(path), load_backend("pymunk"), warn=earlier.append).run()
    assert next(line for line in earlier if "back on the road" in line).endswith("back on the road at 0.00 s")


def test_walls_ahead_stops_at_the_fifth_wall(tmp_path: Path) -> None:
    _, summary, _ = run_example("walls_ahead", tmp_path)
    assert summary.stopped_by is not None  # type: ignore[attr-defined]
    assert summary.robots["pioneer"].metrics["walls_seen"] == 5  # type: ignore[attr-defined]


def test_distance_driven_is_the_distance_from_the_start(tmp_path: Path) -> None:
    _, summary, _ = run_example("distance_driven", tmp_path)
    metrics = summary.robots["pioneer"].metrics  # type: ignore[attr-defined]
    assert 3 <= metrics["distance"] < 3.05  # stopped on the tick it passed 3 m
    assert metrics["from_start"] == pytest.approx(metrics["distance"], rel=0.01)


@pytest.mark.parametrize(("name", "calls", "expected"), [
    ("prev", [(1.0, 0.0), (2.0, 0.0), (3.0, 0.0)], [0.0, 1.0, 2.0]),
    ("rising", [(False,), (True,), (True,), (False,), (True,)], [False, True, False, False, True]),
    ("falling", [(True,), (False,), (False,), (True,)], [False, True, False, False]),
    ("hold", [(False, False), (True, False), (False, False), (True, True), (False, False)],
     [False, True, True, False, False]),
    ("rate", [(1.0,), (1.5,), (1.5,)], [0.0, 10.0, 0.0]),
    ("held", [(True,), (True,), (True,), (False,), (True,)], [0.0, 0.05, 0.1, 0.0, 0.0]),
    ("remember", [(1.0, False, -1.0), (2.0, True, -1.0), (3.0, False, -1.0)], [-1.0, 2.0, 2.0]),
])
def test_each_memory_function_tick_by_tick(name: str, calls: list[tuple], expected: list) -> None:
    step = getattr(memory, name)(0.05, lambda what: None)
    assert [pytest.approx(step(*args)) for args in calls] == expected


def test_printf_label_shows_the_slider(tmp_path: Path) -> None:
    crane = BEHAVIOURS / "crane.yaml"
    path = tmp_path / "crane.yaml"
    path.write_text(crane.read_text().replace('"Arm Speed: {0.02 * arm:.2f}", label_name: speed', '"Arm: %.1f %%"'))
    program = compile_file(path)
    slots = [0.0] * program.slot_count
    (field,) = [part for slider, parts in program.labels if slider == "arm"
                for part in parts if isinstance(part, tuple)]
    slots[field[0]] = 5.0  # the label's field: the slider's value, as signals() copies it each tick
    assert program.label_text(slots)["arm"] == "Arm: 5.0 %"


def test_version_1_names_still_win(tmp_path: Path) -> None:
    # the wall-following lab has a parameter named 'hold'; a v1 file may have an 'index' signal
    path = tmp_path / "v1.yaml"
    path.write_text("labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots: {p: {model: pioneer_p3dx}}\n"
                    "params: {hold: 2}\nlet: {index: hold + 1}\nrules: ['always move(index)']\n")
    assert compile_file(path).params == {"hold": 2.0}
