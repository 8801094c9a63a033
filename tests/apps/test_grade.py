"""``labsim grade`` (runtime/grade/): a synthetic class of 34 submissions, each the right row with
the right reason, the gradebook against its golden, the cache, and Dask giving the same gradebook."""
from __future__ import annotations

import contextlib
import csv
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import FIXTURES, local_cluster

from labsim.runtime.grade.driver import Options, grade_class, write_class

GRADING = FIXTURES / "grading"
GOLDEN_CSV = GRADING / "gradebook.golden.csv"
GOLDEN_JSON = GRADING / "gradebook.golden.json"
UPDATE = os.environ.get("LABSIM_UPDATE_GRADEBOOK") == "1"  # record the goldens anew, on purpose

# every student of the class, and the status and the start of the reason their row must have
EXPECTED = {
    "compile_arity": ("compile error", "compile_arity.yaml:44:12: arc() takes 2 arguments"),
    "compile_many_errors": ("compile error", "compile_many_errors.yaml:29:22: unknown name 'sonar99'"),
    "compile_missing_then": ("compile error", "compile_missing_then.yaml:39:25: expected 'then'"),
    "compile_unknown_sensor": ("compile error", "compile_unknown_sensor.yaml:27:14: unknown name 'sonr5'"),
    "compile_yaml_tab": ("compile error", "compile_yaml_tab.yaml:19:1: tab character"),
    "empty": ("compile error", "empty.yaml:1:1: the file is empty"),
    "not_yaml_mapping": ("compile error", "not_yaml_mapping.yaml:1:1: a behaviour file is a YAML mapping"),
    "huge_cameras": ("budget stop", "huge_cameras.yaml:16:3: the cameras render 4,194,304 pixels"),
    "robots_80": ("budget stop", "robots_80.yaml:16:3: 80 robots in all"),
    "never_stopping": ("budget stop", "seed 1: the run reached its budget of 5,000 ticks"),
    "passwd_world": ("hostile file", "passwd_world.yaml:10:8: world file '/etc/passwd' is an absolute path"),
    "renamed_param": ("contract mismatch", "missing param 'minutes' (did you mean 'run_minutes'?)"),
    "renamed_metric": ("contract mismatch", "missing metric 'closest'; missing metric 'following' (did you mean "
                                            "'follow_time'?)"),
    "wrong_world": ("contract mismatch", "another world: it uses 'road_loop', not the assignment's world 'walls_lab4'"),
    "two_robots": ("contract mismatch", "it runs 2 robots, not 1"),
    "nan_wheels": ("graded", ""),
    "copy_comments": ("graded", ""),
    "copy_renamed_param": ("graded", ""),
    **{f"valid_{i:02d}": ("graded", "") for i in range(1, 17)},
}


def grade_cli(folder: Path, *args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "labsim", "grade", "assignment.yaml", "class", "--out", "out",
                           "-j", "2", *args], cwd=folder, capture_output=True, text=True, timeout=900)


@pytest.fixture(scope="module")
def graded_class(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str]]:
    """The class graded once for the module, in a copy of the fixtures (paths relative to it)."""
    folder = tmp_path_factory.mktemp("class")
    shutil.copytree(GRADING, folder, dirs_exist_ok=True)
    return folder, grade_cli(folder)


@pytest.mark.slow
def test_every_submission_is_the_right_row_with_the_right_reason(graded_class) -> None:
    folder, done = graded_class
    assert done.returncode == 1, done.stderr  # some could not be graded
    assert "34 submissions" in done.stdout
    with open(folder / "out" / "gradebook.csv", newline="") as f:
        rows = {r["Student"]: r for r in csv.DictReader(f)}
    assert set(rows) == set(EXPECTED)
    for student, (status, reason) in EXPECTED.items():
        assert rows[student]["Status"] == status, (student, rows[student])
        assert rows[student]["Reason"].startswith(reason), (student, rows[student]["Reason"])
        assert (rows[student]["Score"] != "") == (status == "graded")
    # the NaN wheels stood still beside the wall: the faults criterion caught it
    assert rows["nan_wheels"]["pass no_faults"] == "fail" and "nan wheel command" in rows["nan_wheels"]["Messages"]
    assert float(rows["nan_wheels"]["Score"]) < 100


@pytest.mark.slow
def test_a_compile_error_row_keeps_every_diagnostic(graded_class) -> None:
    folder, _ = graded_class
    book = json.loads((folder / "out" / "gradebook.json").read_text())
    row = next(s for s in book["students"] if s["student"] == "compile_many_errors")
    assert [(d["line"], d["column"]) for d in row["diagnostics"] if d["severity"] == "error"] == \
        [(29, 22), (36, 53), (43, 57)]


@pytest.mark.slow
def test_likely_copies_are_listed(graded_class) -> None:
    folder, done = graded_class
    book = json.loads((folder / "out" / "gradebook.json").read_text())
    assert {tuple(c["students"]) for c in book["likely_copies"]} == \
        {("copy_comments", "valid_02"), ("copy_renamed_param", "valid_01"), ("renamed_metric", "renamed_param")}
    whys = {tuple(c["students"]): c["why"] for c in book["likely_copies"]}
    assert whys[("copy_renamed_param", "valid_01")] == "the same program once names, comments and order are set aside"
    assert "likely copies" in done.stdout


@pytest.mark.slow
def test_the_gradebook_matches_its_golden(graded_class) -> None:
    folder, _ = graded_class
    for made, golden in (("gradebook.csv", GOLDEN_CSV), ("gradebook.json", GOLDEN_JSON)):
        text = (folder / "out" / made).read_text()
        if UPDATE:
            golden.write_text(text)
        assert text == golden.read_text(), f"{made} differs from {golden.name} (LABSIM_UPDATE_GRADEBOOK=1 records it)"


@pytest.mark.slow
def test_the_canvas_file_has_canvas_columns(graded_class) -> None:
    folder, _ = graded_class
    header = (folder / "out" / "canvas.csv").read_text().splitlines()[0]
    assert header == "Student,ID,SIS User ID,SIS Login ID,Section,\"Lab 4, wall following\""


def _small_class(folder: Path) -> Path:
    """Two valid submissions and a broken one, one seed, no reference: quick to grade."""
    text = (GRADING / "assignment.yaml").read_text().replace("seeds: [1, 2]", "seeds: [1]")
    (folder / "assignment.yaml").write_text(text.replace("reference: reference.yaml\n", ""))
    (folder / "class").mkdir()
    for name in ("valid_01", "valid_03", "compile_arity"):
        shutil.copyfile(GRADING / "class" / f"{name}.yaml", folder / "class" / f"{name}.yaml")
    return folder / "assignment.yaml"


def test_a_second_grading_runs_only_the_changed_submission(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    _small_class(tmp_path)
    options = Options("assignment.yaml", ["class"], Path("out"), jobs=2)
    first = grade_class(options)
    assert (first.ran, first.reused) == (2, 0)
    again = grade_class(options)
    assert (again.ran, again.reused) == (0, 2)
    changed = tmp_path / "class" / "valid_03.yaml"
    changed.write_text(changed.read_text().replace("front: 0.6 ", "front: 0.55 "))
    third = grade_class(options)
    assert (third.ran, third.reused) == (1, 1)  # only valid_03 ran again
    write_class(third, options, pages=False)
    fresh = Options("assignment.yaml", ["class"], Path("fresh"), jobs=1, cache=False)
    Path("fresh").mkdir()
    graded = grade_class(fresh)
    assert graded.ran == 2
    write_class(graded, fresh, pages=False)
    for name in ("gradebook.csv", "gradebook.json"):
        assert (tmp_path / "out" / name).read_text() == (tmp_path / "fresh" / name).read_text()


def test_a_changed_assignment_grades_everything_anew(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    assignment = _small_class(tmp_path)
    options = Options("assignment.yaml", ["class"], Path("out"), jobs=1)
    assert grade_class(options).ran == 2
    assignment.write_text(assignment.read_text().replace("closest: {at_least: 0.2}", "closest: {at_least: 0.1}"))
    assert grade_class(options).ran == 2


def test_a_run_past_its_timeout_is_that_students_row(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    assignment = _small_class(tmp_path)
    text = assignment.read_text().replace("timeout_s: 30", "timeout_s: 0.2").replace("ticks: 5000", "ticks: 10000000")
    assignment.write_text(text.replace("minutes: 1 ", "minutes: 10000 "))
    graded = grade_class(Options("assignment.yaml", ["class"], Path("out"), jobs=2))
    rows = {g.student: g for g in graded.grades}
    assert rows["valid_01"].status == "timeout" and "time limit of 0.2 s" in rows["valid_01"].reason
    assert rows["compile_arity"].status == "compile error"


def test_a_bad_assignment_exits_2_with_every_mistake(tmp_path: Path, capsys) -> None:
    from labsim.runtime.cli.main import main

    bad = tmp_path / "a.yaml"
    bad.write_text("labsim-assignment: 1\nworld: any\nrobots: any\nseeds: [1, 1]\n"
                   "criteria:\n  no_fault: {}\n  closest: {at_least: 1, at_most: 2}\n")
    assert main(["grade", str(bad), str(GRADING / "class" / "valid_01.yaml"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "a.yaml:4:8: error: each seed once" in err
    assert "a.yaml:6:3: error: unknown built-in criterion 'no_fault' (did you mean 'no_faults'?)" in err
    assert "a.yaml:7:12: error: criterion 'closest' takes one of at_least, at_most or score" in err


@pytest.mark.slow  # seconds: in the plain command, not in -m "not slow"
def test_dask_in_threads_gives_the_same_gradebook(tmp_path: Path, monkeypatch) -> None:
    """The quick check of the Dask path; the whole class on worker processes is in ``-m long``."""
    monkeypatch.chdir(tmp_path)
    _small_class(tmp_path)
    for name, scheduler in (("local", None), ("dask", "threads")):
        with local_cluster(processes=False) if scheduler else contextlib.nullcontext() as c:
            options = Options("assignment.yaml", ["class"], Path(name), jobs=2, cache=False,
                              scheduler=c.scheduler_address if c else None)
            options.out.mkdir()
            graded = grade_class(options)
            write_class(graded, options, pages=False)
        assert graded.ran == 2
    for name in ("gradebook.csv", "gradebook.json"):
        assert (tmp_path / "dask" / name).read_text() == (tmp_path / "local" / name).read_text()


@pytest.mark.slow
@pytest.mark.long  # a cluster of worker processes grading the whole class
def test_dask_gives_the_same_gradebook(graded_class, tmp_path: Path, monkeypatch) -> None:
    folder, _ = graded_class
    monkeypatch.chdir(folder)
    with local_cluster() as c:
        options = Options("assignment.yaml", ["class"], tmp_path / "dask", scheduler=c.scheduler_address,
                          cache=False)
        options.out.mkdir()
        graded = grade_class(options)
        write_class(graded, options, pages=True)  # the gradebook links each student's page
    for name in ("gradebook.csv", "gradebook.json"):
        assert (tmp_path / "dask" / name).read_text() == (folder / "out" / name).read_text()


def test_a_submission_that_is_not_there_is_a_mistake_on_the_command_line(tmp_path: Path, capsys) -> None:
    from labsim.runtime.cli.main import main

    assert main(["grade", str(GRADING / "assignment.yaml"), str(tmp_path / "nothere.yaml"),
                 "--out", str(tmp_path / "o")]) == 2
    assert "nothere.yaml: error: no such file or folder" in capsys.readouterr().err
