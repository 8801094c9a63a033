"""``labsim grade`` with an assignment that measures what it grades (tests/fixtures/grading/measured, the
worked assignment of docs/grading.md): a forged parker, a NaN gain, two links out, names that collide,
a copy with its params and metrics renamed and its rules reordered, and honest followers."""
from __future__ import annotations

import csv
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import FIXTURES

MEASURED = FIXTURES / "grading" / "measured"
GOLDEN_CSV, GOLDEN_JSON = MEASURED / "gradebook.golden.csv", MEASURED / "gradebook.golden.json"
UPDATE = os.environ.get("LABSIM_UPDATE_GRADEBOOK") == "1"  # record the goldens anew, on purpose
LINK_OUT = "is a symbolic link to a file outside the behaviour's folder; a submission is read only inside its " \
           "submissions folder"
HONEST = ("honest_1", "honest_2", "honest_3", "alice.yaml", "alice.yml", "a b", "a_b")


@pytest.fixture(scope="module")
def graded(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, subprocess.CompletedProcess[str], dict]:
    folder = tmp_path_factory.mktemp("measured")
    shutil.copytree(MEASURED, folder, dirs_exist_ok=True)
    shutil.copyfile(FIXTURES / "grading" / "assignment.schema.json", folder.parent / "assignment.schema.json")
    (folder / "class" / "s22.yaml").symlink_to("/etc/passwd")
    (folder / "class" / "s23.yaml").symlink_to("../reference.yaml")
    done = subprocess.run([sys.executable, "-m", "labsim", "grade", "assignment.yaml", "class", "--out", "out",
                           "-j", "2", "--feedback-url", "https://lms.example.edu/lab4/grades"],
                          cwd=folder, capture_output=True, text=True, timeout=600)
    with open(folder / "out" / "gradebook.csv", newline="") as f:
        rows = {r["Student"]: r for r in csv.DictReader(f)}
    return folder, done, rows


@pytest.mark.slow
def test_every_row_is_right(graded) -> None:
    folder, done, rows = graded
    assert done.returncode == 1, done.stderr  # the links and the copy could not be graded
    assert done.stderr == ""
    assert {s: (r["Status"], r["Reason"]) for s, r in rows.items() if r["Status"] != "graded"} == {
        "copy_of_honest_3": ("contract mismatch", "missing param 'minutes' (did you mean 'run_minutes'?)"),
        "nan_gain": ("failed gate: no_faults", "required criterion 'no_faults' failed: seed 1: signal 'steer': "
                                               "division by zero: 541 times (first at tick 60, robot pioneer)"),
        "s22": ("hostile file", f"class/s22.yaml: {LINK_OUT}"),
        "s23": ("hostile file", f"class/s23.yaml: {LINK_OUT}"),
    }
    assert set(rows) - {"copy_of_honest_3", "nan_gain", "s22", "s23"} == {*HONEST, "forged_parker"}
    assert rows["nan_gain"]["Score"] == "0.0"


@pytest.mark.slow
def test_the_forged_parker_scores_below_every_honest_follower(graded) -> None:
    _, _, rows = graded
    parker = float(rows["forged_parker"]["Score"])
    assert parker < min(float(rows[s]["Score"]) for s in HONEST)
    # its own metrics said 300 s of following and no hits; the grader measured what it did
    assert (rows["forged_parker"]["pass following"], rows["forged_parker"]["pass moved"]) == ("fail", "fail")
    assert rows["forged_parker"]["pass near_misses"] == "pass"  # from: student, the one the assignment trusts
    assert float(rows["forged_parker"]["mean following"]) < 5


@pytest.mark.slow
def test_links_collisions_and_copies(graded) -> None:
    folder, done, rows = graded
    pages = {s: r["Feedback"] for s, r in rows.items()}
    assert len(set(pages.values())) == len(pages)
    assert all(p.startswith("https://lms.example.edu/lab4/grades/feedback/") for p in pages.values())
    for student in ("alice.yaml", "alice.yml", "a b", "a_b"):
        page = folder / "out" / pages[student].removeprefix("https://lms.example.edu/lab4/grades/")
        assert f": {student}</h1>" in page.read_text()
    book = json.loads((folder / "out" / "gradebook.json").read_text())
    assert book["name_collisions"] == [["alice.yaml", "alice.yml"]]
    assert book["likely_copies"] == [{"why": "the same program once names, comments and order are set aside",
                                      "students": ["copy_of_honest_3", "honest_3"]}]
    overview = (folder / "out" / "index.html").read_text()
    assert "Names that collide" in overview and "copy_of_honest_3, honest_3" in overview
    assert "likely copies (the same program once names, comments and order are set aside): copy_of_honest_3, " \
           "honest_3" in done.stdout
    # nothing of the files the links lead to is shown
    assert "root:" not in json.dumps(book) and "root:" not in overview
    canvas = (folder / "out" / "canvas.csv").read_text().splitlines()
    assert canvas[0].endswith(",Notes") and canvas[1].endswith("https://lms.example.edu/lab4/grades/feedback/"
                                                               "a_b-c8687a08.html")


@pytest.mark.slow
def test_the_pages_teach(graded) -> None:
    folder, _, rows = graded
    feedback = folder / "out" / "feedback"
    nan = (feedback / "nan_gain.html").read_text()
    assert "The required criterion no_faults failed" in nan
    assert "signal &#x27;steer&#x27;: division by zero: 541 times (first at tick 60, robot pioneer)" in nan
    for student, row in rows.items():
        if row["Status"] in ("graded", "failed gate: no_faults"):
            page = (feedback / row["Feedback"].rsplit("/", 1)[1]).read_text()
            name = Path(rows[student]["Feedback"]).name
            assert re.search(r"labsim run [^\n]+ --set minutes=0.5 --seed 1\nlabsim run [^\n]+ --set minutes=0.5 "
                             r"--seed 2</pre>", page), name
    copy = (feedback / "copy_of_honest_3.html").read_text()  # it did not run: how the grader would run it
    assert "labsim run copy_of_honest_3.yaml --set minutes=0.5 --seed 1\nlabsim run copy_of_honest_3.yaml --set " \
           "minutes=0.5 --seed 2</pre>" in copy
    assert "labsim run" not in (feedback / "s22.html").read_text()
    parker = (feedback / "forged_parker.html").read_text()
    assert "<code>duration(min(sonar7, sonar8, sonar9, sonar10) &lt; 0.8)</code>" in parker
    assert "the seconds during which the condition held (mean over the seeds)" in parker
    assert "a metric you defined in your file (from: student)" in parker
    assert "labsim run forged_parker.yaml --set minutes=0.5 --seed 2" in parker
    assert re.search(r"seed 1: a robot drove 0(\.00)? m, less than the 2 m asked", parker)
    spaced = (feedback / Path(rows["a b"]["Feedback"]).name).read_text()
    assert "labsim run &#x27;a b.yaml&#x27; --set minutes=0.5 --seed 1" in spaced  # quoted for a shell


@pytest.mark.slow
def test_the_gradebook_matches_its_golden(graded) -> None:
    folder, _, _ = graded
    for made, golden in (("gradebook.csv", GOLDEN_CSV), ("gradebook.json", GOLDEN_JSON)):
        text = (folder / "out" / made).read_text()
        if UPDATE:
            golden.write_text(text)
        assert text == golden.read_text(), f"{made} differs from {golden.name} (LABSIM_UPDATE_GRADEBOOK=1 records it)"


def test_a_file_the_measure_cannot_read_is_a_mismatch_and_its_own_mistakes_come_first(tmp_path: Path) -> None:
    from labsim.runtime.grade.assignment import read_assignment
    from labsim.runtime.grade.contract import check_submission

    text = (MEASURED / "assignment.yaml").read_text().replace("world: walls_lab4", "world: any")
    (tmp_path / "a.yaml").write_text(text.replace("reference: reference.yaml\n", ""))
    a = read_assignment(tmp_path / "a.yaml")
    epuck = check_submission("e", FIXTURES.parent.parent / "behaviours" / "line_follow.yaml", a)
    assert (epuck.status, epuck.reason) == ("contract mismatch", "the assignment's measured metrics cannot be measured "
                                            "on this file: a.yaml:11:24: sonar1..sonar16 names sonar1 .. sonar16, "
                                            "which do not exist")
    (tmp_path / "bad.yaml").write_text("- x\n")
    bad = check_submission("b", tmp_path / "bad.yaml", a)
    assert (bad.status, bad.reason) == ("compile error", "bad.yaml:1:1: a behaviour file is a YAML mapping of keys "
                                                         "such as 'world:', 'robots:' and 'rules:'")
    assert [d.path for d in bad.diagnostics] == [str(tmp_path / "bad.yaml")]


def test_the_docs_show_the_worked_assignment_as_it_is() -> None:
    docs = (FIXTURES.parent.parent / "docs" / "grading.md").read_text()
    shown = docs.split("### A worked assignment", 1)[1].split("```yaml\n", 1)[1].split("```", 1)[0]
    assert shown == (MEASURED / "assignment.yaml").read_text()


def test_a_robot_that_sets_its_own_value_of_a_graders_param_is_a_mismatch(tmp_path: Path) -> None:
    from labsim.runtime.grade.assignment import read_assignment
    from labsim.runtime.grade.contract import check_submission

    text = (MEASURED / "class" / "honest_1.yaml").read_text().replace("labsim: 1\n", "labsim: 1.2\n")
    sneaky = tmp_path / "sneaky.yaml"  # its robot runs 3 s, whatever the grader sets
    sneaky.write_text(text.replace("at: random}", "at: random, params: {minutes: 0.05}}"))
    (tmp_path / "a.yaml").write_text((MEASURED / "assignment.yaml").read_text().replace("reference: reference.yaml\n",
                                                                                        ""))
    s = check_submission("sneaky", sneaky, read_assignment(tmp_path / "a.yaml"))
    assert (s.status, s.reason) == ("contract mismatch", "robot 'pioneer' sets its own value of the grader's param "
                                                         "'minutes'")
