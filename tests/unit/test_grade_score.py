"""A student's grade from their runs (runtime/grade/score.py): measured metrics, gates, moved, the first fault."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from labsim.runtime.grade.assignment import read_assignment
from labsim.runtime.grade.contract import Submission
from labsim.runtime.grade.runs import RAN, SeedRun
from labsim.runtime.grade.score import first_fault, grade_of

ASSIGNMENT = """labsim-assignment: 1
world: any
robots: 1
measure:
  following: duration(sonar8 < 0.8)
  closest: minimum(sonar8)
criteria:
  following: {score: [0, 20], weight: 2}
  closest: {at_least: 0.2}
  no_faults: {required: true}
  moved: {at_least: 1}
  near_misses: {at_most: 1, from: student}
"""


def _grade(tmp_path: Path, runs: list[SeedRun], extra: str = ""):  # type: ignore[no-untyped-def]
    (tmp_path / "a.yaml").write_text(ASSIGNMENT + extra)
    a = read_assignment(tmp_path / "a.yaml")
    return grade_of(Submission("s", "s.yaml", "k", "src"), runs, a)


def _run(seed: int, following: float, closest: float, distance: float, faults: tuple[str, ...] = (),
         near_misses: float = 0) -> SeedRun:
    return SeedRun(seed, RAN, metrics={"near_misses": near_misses, "following": 300.0, "closest": 9.0},
                   measured={"following": following, "closest": closest}, stopped=True, faults=faults,
                   distance_m=distance)


def test_criteria_read_the_measured_metrics_not_the_students(tmp_path: Path) -> None:
    g = _grade(tmp_path, [_run(1, 10, 0.3, 5), _run(2, 20, math.inf, 6)])
    assert g.status == "graded" and g.measured == {"following": 15.0, "closest": math.inf}
    assert [(r.name, r.passed, r.points, r.source) for r in g.criteria] == [
        ("following", True, 1.5, "measured"), ("closest", True, 1.0, "measured"), ("no_faults", True, 1, "built-in"),
        ("moved", True, 1, "built-in"), ("near_misses", True, 1.0, "student")]
    assert g.score == round(5.5 / 6 * 100, 2)


def test_a_failed_gate_names_the_first_fault_and_scores_the_gate(tmp_path: Path) -> None:
    faults = ("rule follow:4: sqrt(): math domain error: 3 times (first at tick 80, robot pioneer)",
              "rule follow:2: nan wheel command (the wheel is stopped): 5 times (first at tick 12, robot pioneer)")
    g = _grade(tmp_path, [_run(1, 20, 0.3, 5), _run(2, 20, 0.3, 5, faults)], "gate_score: 20\n")
    assert (g.status, g.score, g.gate) == ("failed gate: no_faults", 20, "no_faults")
    assert g.reason == ("required criterion 'no_faults' failed: seed 2: rule follow:2: nan wheel command (the wheel "
                        "is stopped): 5 times (first at tick 12, robot pioneer)")
    low = _grade(tmp_path, [_run(1, 0, 0.1, 0, faults)], "gate_score: 20\n")
    assert low.score == 16.67  # failing a gate never raises a score: the criteria earned 1 of 6


def test_moved_catches_a_parked_robot(tmp_path: Path) -> None:
    g = _grade(tmp_path, [_run(1, 20, 0.3, 5), _run(2, 20, 0.3, 0.25)])
    moved = next(r for r in g.criteria if r.name == "moved")
    assert (moved.passed, moved.value, moved.why) == (False, 0.25, "seed 2: a robot drove 0.25 m, less than the 1 m "
                                                                   "asked")


@pytest.mark.parametrize("faults, first", [
    ((), None),
    (("a (first at tick 9, robot r)", "b (first at tick 3, robot r)"), (1, "b (first at tick 3, robot r)")),
])
def test_the_first_fault_is_the_earliest_tick(faults: tuple[str, ...], first: tuple[int, str] | None) -> None:
    assert first_fault([SeedRun(1, RAN, faults=faults)]) == first
