"""The wall-following lab keeps its handout's promises: the six sonars, every wheel command
within -2..2, 25 minutes at both threshold sets (front 0.5 m and 1.0 m) without a contact on
seeds 1-5, and the handout's program with its thresholds written one by one
(wall_follow_handout.yaml) drives exactly as the shipped lab does."""
from __future__ import annotations

import csv
import re
from pathlib import Path

import pytest
from helpers import BEHAVIOURS, LabRun

from labsim.backends import load_backend
from labsim.dsl.compile import compile_file
from labsim.runtime.cli.main import main
from labsim.runtime.run import compile_behaviour

# 25-minute runs; the fast loop runs the lab for 2 minutes (tests/contract/test_determinism.py)
pytestmark = pytest.mark.slow

LAB = BEHAVIOURS / "wall_follow.yaml"
HANDOUT = BEHAVIOURS / "wall_follow_handout.yaml"
# the handout's two threshold sets, as the handout's program writes them
SIMULATION_1 = {"front": "1", "side": "1", "back": "2"}
SIMULATION_2 = {"front": "0.5", "side": "0.5", "back": "0.5"}


def run_lab(path: Path, params: dict[str, str], seed: int | None = None, trace: Path | None = None):
    behaviour = compile_behaviour(path, params, seed=seed)
    run = behaviour.bind(load_backend("pymunk"), trace=trace, warn=lambda m: None)
    try:
        return run.run()
    finally:
        run.close()


@pytest.mark.parametrize("front", ["0.5", "1.0"])
@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_25_minutes_without_a_contact_at_both_thresholds(front: str, seed: int) -> None:
    summary = run_lab(LAB, {"front": front}, seed)
    assert summary.ticks == 30_000 and summary.sim_time_s == 1500.0 and summary.faults == ()
    robot = summary.robots["pioneer"]
    assert robot.contacts == 0 and robot.contact_time_s == 0
    assert robot.metrics["following"] > 1300  # it found a wall and followed it
    assert robot.clamped_ticks == 0


def test_the_lab_reads_the_handouts_six_sonars_and_drives_within_two() -> None:
    program = compile_file(LAB)
    text = LAB.read_text()
    read = set(re.findall(r"\bsonar\d+\b", text))
    assert read == {"sonar2", "sonar5", "sonar8", "sonar9", "sonar14", "sonar15"}
    assert program.params["front"] == 0.5 and program.params["cruise"] == 2


def test_the_handouts_program_drives_as_the_lab_does_at_both_sets(tmp_path: Path) -> None:
    for lab_params, handout_params in (({"front": "0.5"}, SIMULATION_2), ({"front": "1.0"}, SIMULATION_1)):
        lab, handout = tmp_path / "lab.csv", tmp_path / "handout.csv"
        run_lab(LAB, lab_params, 3, lab)
        run_lab(HANDOUT, handout_params, 3, handout)
        assert _drive(lab) == _drive(handout)


def _drive(trace: Path) -> list[tuple[str, ...]]:
    """Each tick's pose, contact, state and wheel commands."""
    lines = trace.read_text().splitlines()[1:-1]
    rows = list(csv.DictReader(lines))
    keys = ("tick", "x", "y", "heading", "collided", "state", "wheel_left", "wheel_right")
    assert rows and all(k in rows[0] for k in keys)
    return [tuple(r[k] for k in keys) for r in rows]


def test_the_handouts_answer_the_smaller_threshold_overshoots_less(lab_run: LabRun) -> None:
    near = lab_run(LAB, front="0.5").robots["pioneer"].metrics
    far = lab_run(LAB, front="1.0").robots["pioneer"].metrics
    assert near["overshoot"] < far["overshoot"] / 10  # the wide turns at corner walls of simulation 1
    assert near["following"] > far["following"]
    assert far["closest"] > near["closest"] > 0.25  # no near miss at either
    assert near["near_misses"] == far["near_misses"] == 0


def test_the_golden_traces_hold(capsys) -> None:
    assert main(["test", str(LAB), str(HANDOUT)]) == 0
    assert "2 passed, 0 failed" in capsys.readouterr().out
