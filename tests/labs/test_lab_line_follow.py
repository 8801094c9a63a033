"""The line-following lab: an e-puck keeps its ground sensors on the tape, lap after lap."""
from __future__ import annotations

from helpers import BEHAVIOURS, LabRun

from labsim.runtime.cli.main import main

LAB = BEHAVIOURS / "line_follow.yaml"


def test_with_the_lab_constants_the_epuck_stays_on_the_tape_for_two_minutes(lab_run: LabRun) -> None:
    summary = lab_run(LAB)
    assert summary.ticks == 6000 and summary.sim_time_s == 120.0
    robot = summary.robots["epuck"]
    m = robot.metrics
    assert robot.contacts == 0 and summary.faults == ()
    assert m["laps"] >= 3 and m["time_lost"] == 0 and m["on_tape"] == 120.0
    assert m["worst_offset"] < 0.0095  # the tape's half width: its centre never left the tape


def test_too_little_gain_loses_the_tape_in_the_tight_curve(lab_run: LabRun) -> None:
    m = lab_run(LAB, gain="0.3").robots["epuck"].metrics
    assert m["time_lost"] > 1 and m["worst_offset"] > 0.0095


def test_the_golden_passes(capsys) -> None:
    assert main(["test", str(LAB)]) == 0
    assert "1 passed, 0 failed" in capsys.readouterr().out
