"""Assignment files (runtime/grade/assignment.py): read with positions, their kind, their JSON Schema."""
from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import pytest
from helpers import FIXTURES

from labsim.foundation.diagnostics import LabsimError
from labsim.foundation.kinds import file_kind
from labsim.runtime.cli.schemas import schema_text
from labsim.runtime.grade.assignment import read_assignment
from labsim.runtime.grade.score import score_criterion

ASSIGNMENT = FIXTURES / "grading" / "assignment.yaml"


def test_the_fixture_reads_and_is_an_assignment() -> None:
    a = read_assignment(ASSIGNMENT)
    assert file_kind(ASSIGNMENT) == "assignment"
    assert (a.world, a.robots, dict(a.params), a.seeds, a.timeout_s) == ("walls_lab4", 1, {"minutes": "1"}, (1, 2), 30)
    assert a.metrics == ("near_misses", "closest", "following")  # the criteria's metrics are required too
    assert [c.name for c in a.criteria] == ["following", "closest", "ran_to_stop", "no_faults", "no_collisions"]
    assert a.weights == 6 and a.budgets.ticks == 5000 and a.reference == str(ASSIGNMENT.parent / "reference.yaml")


def test_the_schema_accepts_the_fixture_and_is_the_shipped_copy() -> None:
    schema = json.loads(schema_text("assignment"))
    import yaml

    jsonschema.validate(yaml.safe_load(ASSIGNMENT.read_text()), schema)
    assert (FIXTURES / "grading" / "assignment.schema.json").read_text() == schema_text("assignment")
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"labsim-assignment": 1, "world": "any", "robots": "any", "criteria": {"x": {"y": 1}}},
                            schema)


@pytest.mark.parametrize("text, where, message", [
    ("", "", "the file is empty"),
    ("labsim-assignment: 1\nworld: any\nrobots: any\n", "", "missing required key 'criteria:'"),
    ("labsim-assignment: 1\nworld: any\nrobots: lots\ncriteria: {no_faults: {}}\n", "3:9", "robots (a whole number"),
    ("labsim-assignment: 1\nworld: any\nrobots: 1\nparams: {minutes: five}\ncriteria: {no_faults: {}}\n", "4:19",
     "param 'minutes' takes the value the grader sets"),
    ("labsim-assignment: 1\nworld: any\nrobots: 1\ncriteria: {no_faults: {at_least: 1}}\n", "4:34",
     "the built-in criterion 'no_faults' takes a weight and required only"),
    ("labsim-assignment: 1\nworld: any\nrobots: 1\ncriteria: {x: {score: [1, 1]}}\n", "4:23",
     "score: [worst, best] needs two different values"),
    ("labsim-assignment: 1\nworld: any\nrobots: 1\nbudgets: {tiks: 5}\ncriteria: {no_faults: {}}\n", "4:11",
     "a budget's name is one of"),
])
def test_each_mistake_is_reported_where_it_is(tmp_path: Path, text: str, where: str, message: str) -> None:
    path = tmp_path / "a.yaml"
    path.write_text(text)
    with pytest.raises(LabsimError) as e:
        read_assignment(path)
    found = [f"{d.line}:{d.col}" if d.line else "" for d in e.value.diagnostics if message in d.message]
    assert where in found, [d.format() for d in e.value.diagnostics]


def test_a_scored_range_scores_linearly_either_way() -> None:
    a = read_assignment(ASSIGNMENT)
    following = a.criteria[0]  # 0 at 40, full at 55, weight 2
    assert [score_criterion(following, {"following": v}, []).points for v in (30, 47.5, 60)] == [0, 1, 2]
    lower = type(following)("overshoot", 1.0, worst=10.0, best=0.0)  # better lower
    assert score_criterion(lower, {"overshoot": 2.5}, []).points == 0.75
    assert score_criterion(lower, {"overshoot": float("nan")}, []).passed is False


HEAD = "labsim-assignment: 1\nworld: any\nrobots: 1\n"


@pytest.mark.parametrize("text, where, message", [
    (HEAD + "seeds: [1e300]\ncriteria: {no_faults: {}}\n", "4:9",
     "a seed is a whole number from 0 to 2**53 (9007199254740992), as labsim run --seed takes it"),
    (HEAD + "seeds: [-1]\ncriteria: {no_faults: {}}\n", "4:9", "a seed is a whole number from 0 to 2**53"),
    (HEAD + "timeout_s: 1e308\ncriteria: {no_faults: {}}\n", "4:12",
     "timeout_s is the wall time a run may take, at most 3600 s (an hour)"),
    (HEAD + "params: {minutes: 1e308}\ncriteria: {no_faults: {}}\n", "4:19",
     "param 'minutes' is a finite number from -2**53 to 2**53, not 1e308"),
    (HEAD + "params: {minutes: .nan}\ncriteria: {no_faults: {}}\n", "4:19",
     "param 'minutes' is a finite number from -2**53 to 2**53, not .nan"),
    (HEAD + "gate_score: 150\ncriteria: {no_faults: {}}\n", "4:13",
     "gate_score is the score (0 to 100) of a student who fails a required criterion"),
    (HEAD + "measure:\n  near: count(right < 0.3)\ncriteria: {near: {at_most: 1}}\n", "5:15",
     "measured metric 'near' reads 'right', which is not a sensor, the pose or a param of the grader's; a measured "
     "metric reads only what the student's file cannot write"),
    (HEAD + "measure:\n  s: maximum(steer(sonar1))\ncriteria: {s: {at_most: 1}}\n", "5:14",
     "measured metric 's' reads 'steer(...)', which is not a built-in function"),
    (HEAD + "measure:\n  s: maximum(len(sonar1..sonar4))\ncriteria: {s: {at_most: 1}}\n", "5:14",
     "measured metric 's' reads 'len(...)', which counts a list of a behaviour file (format 1.3); a measured metric "
     "has no lists, and a group's size is known as written"),
    (HEAD + "measure:\n  s: duration(state == follow)\ncriteria: {s: {at_most: 1}}\n", "5:15",
     "measured metric 's' reads 'state'"),
    (HEAD + "measure:\n  s: min(sonar1, sonar2)\ncriteria: {s: {at_most: 1}}\n", "5:6",
     "measured metric 's' must be an aggregate over the run"),
    (HEAD + "measure:\n  s: count(collided\ncriteria: {s: {at_most: 1}}\n", "5:11", "unclosed '('"),
    (HEAD + "measure:\n  hits: count(collided)\ncriteria: {hit: {at_most: 1}}\n", "6:12",
     "criterion 'hit' names no measured metric (did you mean 'hits'?)"),
    (HEAD + "measure:\n  hits: count(collided)\ncriteria: {mine: {at_most: 1, from: teacher}}\n", "6:37",
     "from: student is the one source a criterion names"),
    (HEAD + "criteria: {moved: {weight: 2}}\n", "4:12", "moved takes at_least: METRES"),
    (HEAD + "measure:\n  moved: final(x)\ncriteria: {no_faults: {}}\n", "5:3",
     "'moved' is the name of a built-in criterion; choose another name for the metric"),
    (HEAD + "criteria: {no_faults: {required: yes please}}\n", "4:34", "required is true or false"),
])
def test_each_value_mistake_is_reported_where_it_is(tmp_path: Path, text: str, where: str, message: str) -> None:
    path = tmp_path / "a.yaml"
    path.write_text(text)
    with pytest.raises(LabsimError) as e:
        read_assignment(path)
    found = [f"{d.line}:{d.col}" for d in e.value.diagnostics if message in d.message]
    assert found == [where], [d.format() for d in e.value.diagnostics]


def test_measured_metrics_gates_and_student_metrics_read() -> None:
    text = (HEAD + "params: {gain: 2}\nmeasure:\n  hits: count(collided)\n"
            "  closest: {value: minimum(min(sonar1..sonar16)), better: higher}\n"
            "  fast: mean(abs(forward_speed) * gain)\n"
            "criteria:\n  hits: {at_most: 0, required: true}\n  closest: {at_least: 0.2}\n"
            "  near_misses: {at_most: 3, from: student}\n  moved: {at_least: 1.5, required: true}\n"
            "gate_score: 10\n")
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "a.yaml"
        path.write_text(text)
        a = read_assignment(path)
    assert a.measured == ("hits", "closest", "fast") and a.metrics == ("near_misses",)
    assert a.definition("closest") == "minimum(min(sonar1..sonar16))" and a.gate_score == 10
    assert [(c.name, c.required, c.student) for c in a.criteria] == [
        ("hits", True, False), ("closest", False, False), ("near_misses", False, True), ("moved", True, False)]
    assert a.criteria[3].describe() == "every robot drove at least 1.5 m on every seed" and a.moves


def test_the_schema_accepts_the_worked_assignment() -> None:
    import yaml

    schema = json.loads(schema_text("assignment"))
    jsonschema.validate(yaml.safe_load((FIXTURES / "grading" / "measured" / "assignment.yaml").read_text()), schema)
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"labsim-assignment": 1, "world": "any", "robots": "any", "seeds": [1e300],
                             "criteria": {"x": {"at_least": 1}}}, schema)
