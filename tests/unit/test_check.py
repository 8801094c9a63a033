"""The checker: every problem of a file at once, each with its exact line and column."""
from __future__ import annotations

from pathlib import Path

import pytest
from helpers import FIXTURES, expectations

from labsim.dsl.compile import compile_file
from labsim.foundation.diagnostics import LabsimError

ERROR_FIXTURES = sorted(FIXTURES.glob("*_with_error.yaml"))


def diagnostics(path: Path, overrides: dict[str, str] | None = None) -> set[tuple[int, int, str]]:
    with pytest.raises(LabsimError) as e:
        compile_file(path, overrides)
    return {(d.line, d.col, d.message) for d in e.value.diagnostics if d.severity == "error"}


@pytest.mark.parametrize("path", ERROR_FIXTURES, ids=lambda p: p.name)
def test_fixture_reports_exactly_its_expected_errors(path: Path) -> None:
    expected = expectations(path)
    assert expected, f"{path.name} declares no '# expect:' lines"
    assert diagnostics(path) == expected


def test_good_fixture_compiles() -> None:
    program = compile_file(FIXTURES / "minimal.yaml")
    assert program.channels == ("sonar5",)
    assert program.params == {"front": 0.5}


def test_every_behaviour_shipped_compiles() -> None:
    for path in sorted((FIXTURES.parent.parent / "behaviours").glob("*.yaml")):
        compile_file(path)


def test_diagnostic_shows_line_and_caret_under_the_span() -> None:
    with pytest.raises(LabsimError) as e:
        compile_file(FIXTURES / "unknown_sensor_with_error.yaml")
    text = str(e.value)
    assert "unknown_sensor_with_error.yaml:13:8: error: unknown name 'sonr5' (did you mean 'sonar5'?)" in text
    assert "   13 |   - if sonr5 <= front then arc(-2, 2)\n      |        ^~~~~" in text


def test_set_overrides_are_type_checked(tmp_path: Path) -> None:
    path = FIXTURES / "minimal.yaml"
    assert compile_file(path, {"front": "1.0"}).params["front"] == 1.0
    with pytest.raises(LabsimError) as e:
        compile_file(path, {"fron": "1.0"})
    (d,) = e.value.diagnostics
    assert d.path == "--set fron=1.0"
    assert d.message == "unknown parameter 'fron' (did you mean 'front'?)"
    with pytest.raises(LabsimError) as e:
        compile_file(path, {"front": "far"})
    assert e.value.diagnostics[0].message == "parameter 'front' is a number, not 'far'"


@pytest.mark.parametrize("rules, message", [
    ("  - if time > 1 then goto chase\n  - else stop()",
     "no state named 'chase'"),
    ("  - always stop()\n  - if time > 1 then move(1)",
     "this rule can never fire: the 'always' rule on line 7 fires first, every tick"),
    ("  - if time > 1 then arc(1, 1), move(2)\n  - else stop()",
     "a rule can drive the wheels once: this action would override 'arc(...)'"),
    ("  - if time > 1 then fly(1)\n  - else stop()", "unknown action 'fly'"),
    ("  - if state == 3 then stop()\n  - else stop()",
     "a state can only be compared with ==/!= to another state, as in 'state == follow'"),
    ("  - if detected(time) then stop()\n  - else stop()",
     "detected() takes a distance sensor's name (sonar1 .. sonar16), and 'time' is not one"),
    ("  - if count(time > 1) then stop()\n  - else stop()",
     "'count' is a metric aggregate: it can only be the outer call of a 'metrics:' entry"),
])
def test_rule_errors(write, rules: str, message: str) -> None:
    path = write("labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 f"rules:\n{rules}\n")
    assert message in {m for _, _, m in diagnostics(path)}


def test_lets_are_ordered_and_typed(write) -> None:
    path = write("labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 "let:\n  a: b + 1\n  b: sonar1\n  c: sonar1 < 1\n  d: c + 1\nrules:\n  - always stop()\n")
    assert diagnostics(path) == {
        (7, 6, "signal 'b' is used before it is defined (on line 8); 'let' signals are evaluated in order"),
        (10, 6, "'+' needs a number, but this is a boolean"),
    }


def test_metrics_must_be_aggregates(write) -> None:
    path = write("labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 "rules:\n  - always stop()\nmetrics:\n  closest: max(sonar1)\n  hits: count(sonar1)\n")
    assert diagnostics(path) == {
        (9, 12, "metric 'closest' must be an aggregate over the run (did you mean 'maximum'?)"),
        (10, 15, "count() needs a condition: its argument must be a boolean, but this is a number"),
    }


def test_print_with_values_is_shown_the_log_it_means(write) -> None:
    path = write("labsim: 1\nworld: walls_lab4\nstop: time >= 1\nrobots:\n  p: {model: pioneer_p3dx}\n"
                 'rules:\n  - if sonar5 < 1 then print("wall!", x)\n  - else move(1)\n')
    with pytest.raises(LabsimError) as e:
        compile_file(path)
    (d,) = e.value.diagnostics
    assert (d.line, d.col, d.end_col) == (7, 24, 29)
    assert d.notes == ('e.g. log("wall! {x:.2f}"): printed with the time and the robot, and recorded in the trace',)
