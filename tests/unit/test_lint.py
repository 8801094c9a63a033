"""The linter: each warning shown by a fixture, --strict, and the labs without a warning."""
from __future__ import annotations

from pathlib import Path

import pytest
from helpers import BEHAVIOURS, FIXTURES, examples, expectations

from labsim.dsl.compile import compile_file
from labsim.runtime.cli.main import main

WARNING_FIXTURES = sorted(FIXTURES.glob("*_with_warning.yaml"))


def warnings(path: Path) -> set[tuple[int, int, str]]:
    program = compile_file(path)
    assert all(d.severity == "warning" for d in program.warnings)
    return {(d.line, d.col, d.message) for d in program.warnings}


@pytest.mark.parametrize("path", WARNING_FIXTURES, ids=lambda p: p.name)
def test_fixture_gives_exactly_its_expected_warnings(path: Path) -> None:
    expected = expectations(path)
    assert expected, f"{path.name} declares no '# expect:' lines"
    assert warnings(path) == expected


@pytest.mark.parametrize("path", sorted(BEHAVIOURS.glob("*.yaml")), ids=lambda p: p.name)
def test_the_labs_give_no_warning(path: Path) -> None:
    assert warnings(path) == set()


def test_a_warning_has_a_caret_under_its_span() -> None:
    (first, *_) = compile_file(FIXTURES / "equality_with_warning.yaml").warnings
    assert first.format().splitlines()[1:3] == ["    8 | stop: time == 5.01", "      |       ^~~~~~~~~~~~"]


def test_an_override_can_raise_a_warning(tmp_path: Path) -> None:
    """--set front=12 on the wall lab compares its sonars with 12 m."""
    program = compile_file(BEHAVIOURS / "wall_follow.yaml", {"front": "12"})
    assert {d.message for d in program.warnings} == {
        "'front' (12 m) is beyond what 'ahead' reads: sonar2 and sonar5 see at most 1 m (the model's range_m)",
        *(f"'front' (12 m) is beyond the range of {s}: it sees at most 1 m (the model's range_m)"
          for s in ("sonar8", "sonar9", "sonar15"))}


def test_check_prints_warnings_and_exits_0(capsys: pytest.CaptureFixture[str]) -> None:
    path = str(FIXTURES / "unused_with_warning.yaml")
    assert main(["check", path]) == 0
    out, err = capsys.readouterr()
    assert out.strip() == f"{path}: ok (3 warnings)"
    assert f"{path}:12:10: warning: parameter 'spare' is never used" in err


@pytest.mark.parametrize("command", [["check"], ["run", "-q"], ["test"], ["view", "--no-browser"], ["sweep"]])
def test_strict_makes_warnings_errors(command: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    path = str(FIXTURES / "unused_with_warning.yaml")
    assert main([*command, "--strict", path]) == 2
    err = capsys.readouterr().err
    assert f"{path}:12:10: error: parameter 'spare' is never used" in err
    assert "= a warning, made an error by --strict" in err
    assert "Traceback" not in err


def test_run_prints_the_warnings_before_it_runs(capsys: pytest.CaptureFixture[str]) -> None:
    path = str(FIXTURES / "unused_with_warning.yaml")
    assert main(["run", "-q", path]) == 0
    assert f"{path}:14:3: warning: slider 'gain' is never used" in capsys.readouterr().err


def test_the_docs_worked_examples_give_no_warning(tmp_path: Path) -> None:
    for name, text in examples().items():
        path = tmp_path / f"{name}.yaml"
        path.write_text(text)
        assert warnings(path) == set(), name
