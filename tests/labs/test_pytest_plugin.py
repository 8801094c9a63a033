"""The pytest plugin (runtime/cli/pytest_plugin.py): golden traces collected and run as pytest items."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from helpers import BEHAVIOURS, FIXTURES

from labsim.runtime.cli import main as cli

pytest_plugins = ["pytester"]



@pytest.fixture
def lab(pytester: pytest.Pytester) -> Path:
    """A folder with one small behaviour and its golden, recorded by labsim test."""
    behaviour = pytester.path / "small.yaml"
    shutil.copyfile(FIXTURES / "minimal.yaml", behaviour)
    assert cli.main(["test", str(behaviour), "--update-goldens"]) == 0
    return behaviour


def test_a_behaviour_with_its_golden_passes(pytester: pytest.Pytester, lab: Path) -> None:
    result = pytester.runpytest("-p", "no:cacheprovider", "-v")
    result.assert_outcomes(passed=1)
    result.stdout.fnmatch_lines(["small.yaml::small PASSED*"])


def test_a_changed_threshold_fails_with_the_first_difference(pytester: pytest.Pytester,
                                                              capsys: pytest.CaptureFixture[str]) -> None:
    # the wall lab cut to 6 simulated seconds, its golden recorded here: the threshold's change
    # shows at tick 45 (2.25 s), and three runs of its 25 minutes cost seconds each; that the
    # lab's own golden holds is tests/labs/test_lab_wall_follow.py's test
    lab = pytester.path / "wall_follow.yaml"
    lab.write_text((BEHAVIOURS / "wall_follow.yaml").read_text().replace("minutes: 25 ", "minutes: 0.1 "))
    assert cli.main(["test", str(lab), "--update-goldens"]) == 0
    pytester.runpytest("-p", "no:cacheprovider").assert_outcomes(passed=1)
    lab.write_text(lab.read_text().replace("front: 0.5 ", "front: 0.6 "))
    capsys.readouterr()
    cli.main(["test", "wall_follow.yaml"])
    expected = capsys.readouterr().out.splitlines()[:-1]  # less the "0 passed, 1 failed" line
    assert expected[0] == "FAIL wall_follow.yaml (golden wall_follow.golden.csv)"
    assert expected[1].startswith("  first difference at tick ")
    result = pytester.runpytest("-p", "no:cacheprovider")
    result.assert_outcomes(failed=1)
    out = result.stdout.lines
    start = out.index(expected[0])
    assert out[start:start + len(expected)] == expected  # the same text as labsim test


def test_a_folder_collects_every_behaviour_as_labsim_test_does(pytester: pytest.Pytester, lab: Path) -> None:
    shutil.copyfile(FIXTURES / "minimal.yaml", pytester.path / "other.yaml")
    shutil.copyfile(FIXTURES / "pendulum_world.yaml", pytester.path / "world.yaml")
    pytester.makefile(".yaml", notes="just: yaml\n")
    result = pytester.runpytest("-p", "no:cacheprovider", "--collect-only", "-q")
    result.stdout.fnmatch_lines(["other.yaml::other", "small.yaml::small", "2 tests collected*"])


def test_a_behaviour_without_a_golden_in_a_folder_fails_as_labsim_test_fails_it(
        pytester: pytest.Pytester, lab: Path, capsys: pytest.CaptureFixture[str]) -> None:
    shutil.copyfile(FIXTURES / "minimal.yaml", pytester.path / "other.yaml")
    capsys.readouterr()
    assert cli.main(["test", str(pytester.path)]) == 1
    said = capsys.readouterr().out
    assert "FAIL" in said and "other.golden.csv" in said and "1 passed, 1 failed" in said
    for args in ((), (str(pytester.path),), ()):  # no argument, the folder, and again: the same verdict
        result = pytester.runpytest("-p", "no:cacheprovider", *args)
        result.assert_outcomes(passed=1, failed=1)
        result.stdout.fnmatch_lines(["FAIL other.yaml: no golden trace other.golden.csv; *"])


def test_a_behaviour_without_a_golden_in_a_deeper_folder_is_not_collected(pytester: pytest.Pytester,
                                                                         lab: Path) -> None:
    (pytester.path / "deeper").mkdir()
    shutil.copyfile(FIXTURES / "minimal.yaml", pytester.path / "deeper" / "other.yaml")
    result = pytester.runpytest("-p", "no:cacheprovider", "--collect-only", "-q")
    result.stdout.fnmatch_lines(["small.yaml::small", "1 test collected*"])


def test_a_named_behaviour_without_a_golden_fails_as_labsim_test_says(pytester: pytest.Pytester) -> None:
    shutil.copyfile(FIXTURES / "minimal.yaml", pytester.path / "fresh.yaml")
    result = pytester.runpytest("-p", "no:cacheprovider", "fresh.yaml")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["FAIL fresh.yaml: no golden trace fresh.golden.csv; "
                                 "record one with: pytest fresh.yaml --update-goldens"])


def test_update_goldens_records_and_then_passes(pytester: pytest.Pytester) -> None:
    shutil.copyfile(FIXTURES / "minimal.yaml", pytester.path / "fresh.yaml")
    result = pytester.runpytest("-p", "no:cacheprovider", "fresh.yaml", "--update-goldens")
    result.assert_outcomes(passed=1)
    assert (pytester.path / "fresh.golden.csv").exists()
    pytester.runpytest("-p", "no:cacheprovider").assert_outcomes(passed=1)


def test_a_broken_behaviour_fails_with_its_diagnostics(pytester: pytest.Pytester, lab: Path) -> None:
    lab.write_text(lab.read_text().replace("sonar5", "sonr5"))
    result = pytester.runpytest("-p", "no:cacheprovider")
    result.assert_outcomes(failed=1)
    result.stdout.fnmatch_lines(["FAIL *small.yaml: it does not compile", "*unknown*sonr5*"])


@pytest.mark.slow
def test_xdist_runs_them_in_parallel(pytester: pytest.Pytester, lab: Path) -> None:
    pytest.importorskip("xdist")
    shutil.copyfile(lab, pytester.path / "twin.yaml")
    shutil.copyfile(lab.with_name("small.golden.csv"), pytester.path / "twin.golden.csv")
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-n", "2")
    result.assert_outcomes(passed=2)


PROBE = '''
import sys


def pytest_unconfigure(config):
    with open("hypothesis_imported.txt", "w") as f:
        f.write(str("hypothesis" in sys.modules))
'''


@pytest.mark.slow
def test_goldens_alone_do_not_import_hypothesis_for_its_summary(pytester: pytest.Pytester, lab: Path) -> None:
    pytest.importorskip("_hypothesis_pytestplugin")
    pytester.makepyfile(probe=PROBE)
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-p", "probe")
    result.assert_outcomes(passed=1)
    assert (pytester.path / "hypothesis_imported.txt").read_text() == "False"
    # asked for its statistics, the hypothesis plugin says what it says as before
    result = pytester.runpytest_subprocess("-p", "no:cacheprovider", "-p", "probe", "--hypothesis-show-statistics")
    result.assert_outcomes(passed=1)
    result.stdout.fnmatch_lines(["*Hypothesis Statistics*"])
    assert (pytester.path / "hypothesis_imported.txt").read_text() == "True"
