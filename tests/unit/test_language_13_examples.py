"""The worked examples of docs/language.md's "Lists, starts and read-back": each checks without a warning
and does what the text says it does."""
from __future__ import annotations

import csv
import itertools
import math
from pathlib import Path

from helpers import examples, run_example

from labsim.dsl.compile import compile_file
from labsim.dsl.library.builtins import Better


def test_the_examples_check_without_a_warning(tmp_path: Path) -> None:
    for name in ("patrol", "odometry"):
        path = tmp_path / f"{name}.yaml"
        path.write_text(examples()[name])
        assert compile_file(path).warnings == (), name


def test_the_patrol_drives_to_each_waypoint_in_turn(tmp_path: Path) -> None:
    _, summary, warned = run_example("patrol", tmp_path, trace=True)
    rows = list(csv.DictReader(line for line in (tmp_path / "t.csv").open() if not line.startswith("#")))
    reached = [int(float(r["reached"])) for r in rows]
    assert reached[-1] >= 5 and sorted(reached) == reached  # round the four once, and on
    assert warned == [] and summary.robots["pioneer"].metrics["laps"] >= 1  # type: ignore[attr-defined]
    waypoints = [(-4, -1), (-4, -5), (0, -5), (0, -1)]
    for before, after in itertools.pairwise(rows):
        if after["reached"] != before["reached"]:  # counted within 0.3 m of the waypoint it drove to
            wx, wy = waypoints[int(float(before["reached"])) % 4]
            assert (float(after["x"]) - wx) ** 2 + (float(after["y"]) - wy) ** 2 < 0.35 ** 2


def test_odometry_starts_each_robot_at_its_pose_and_stays_near_the_true_pose(tmp_path: Path) -> None:
    run, summary, warned = run_example("odometry", tmp_path, trace=True)
    rows = list(csv.DictReader(line for line in (tmp_path / "t.csv").open() if not line.startswith("#")))
    first = {r["robot"]: (float(r["ox"]), float(r["oy"]), float(r["x"]), float(r["y"])) for r in rows[:2]}
    assert first == {"pioneer[0]": (-3.0, -3.0, -3.0, -3.0), "pioneer[1]": (2.0, -3.0, 2.0, -3.0)}
    metrics = summary.robots  # type: ignore[attr-defined]
    # the estimate moves along the heading the commands drove at: no drift in a simulator without slip
    assert warned == [] and all(metrics[r].metrics["worst_drift"] < 1e-9 for r in metrics)
    turned = [float(r["th"]) - float(r["heading"]) for r in rows]  # the trace's 6 digits; th is not wrapped
    assert len(rows) == 802 and max(abs(math.atan2(math.sin(d), math.cos(d))) for d in turned) < 1e-4
    # less drift is better: a sweep of a calibration marks the least
    program = run.program
    assert dict(zip(program.metric_names, program.metric_better)) == {"final_drift": Better.LOWER,
                                                                     "worst_drift": Better.LOWER}


def test_the_schema_takes_lists_and_poses_and_refuses_an_empty_list() -> None:
    import json

    import jsonschema
    import yaml

    from labsim.runtime.cli.schemas import schema_text

    schema = json.loads(schema_text("behaviour"))
    for name in ("patrol", "odometry"):
        jsonschema.validate(yaml.safe_load(examples()[name]), schema)
    for wrong in ({"w": []}, {"w": [[1], "a"]}, {"w": ["a"]}):
        data = yaml.safe_load(examples()["patrol"]) | {"params": wrong}
        try:
            jsonschema.validate(data, schema)
        except jsonschema.ValidationError:
            continue
        raise AssertionError(f"the schema takes {wrong}")
