"""``labsim grade``: hostile submissions are their own rows and nothing is read through them; every
student is one identity, whose row, page and pictures no other student shares (runtime/grade)."""
from __future__ import annotations

import csv
import json
import os
import shutil
from pathlib import Path

import pytest
from helpers import FIXTURES

from labsim.runtime.grade.contract import find_submissions
from labsim.runtime.grade.driver import Options, grade_class, write_class
from labsim.runtime.grade.gradebook import page_names

GRADING = FIXTURES / "grading"
VALID_01, VALID_03 = GRADING / "class" / "valid_01.yaml", GRADING / "class" / "valid_03.yaml"


def _assignment(folder: Path) -> None:
    text = (GRADING / "assignment.yaml").read_text().replace("seeds: [1, 2]", "seeds: [1]")
    text = text.replace("reference: reference.yaml\n", "").replace("minutes: 1 ", "minutes: 0.2 ")
    (folder / "assignment.yaml").write_text(text)


def test_links_out_fifos_and_links_to_folders_out_are_hostile_rows(tmp_path: Path) -> None:
    cls = tmp_path / "class"
    cls.mkdir()
    shutil.copyfile(VALID_01, cls / "honest.yaml")
    shutil.copyfile(VALID_01, tmp_path / "reference.yaml")
    (cls / "s22.yaml").symlink_to("/etc/passwd")
    (cls / "s23.yaml").symlink_to("../reference.yaml")
    (cls / "inside.yaml").symlink_to("honest.yaml")  # a link inside the folder is the folder's
    os.mkfifo(cls / "pipe.yaml")
    found, collisions, skipped = find_submissions([str(cls)])
    rows = {f.student: (f.status, f.reason) for f in found}
    assert rows == {
        "honest": ("graded", ""), "inside": ("graded", ""),
        "pipe": ("hostile file", f"{cls}/pipe.yaml: is a FIFO (named pipe), not a regular file"),
        "s22": ("hostile file", f"{cls}/s22.yaml: is a symbolic link to a file outside the behaviour's folder; "
                                "a submission is read only inside its submissions folder"),
        "s23": ("hostile file", f"{cls}/s23.yaml: is a symbolic link to a file outside the behaviour's folder; "
                                "a submission is read only inside its submissions folder"),
    }
    assert collisions == [] and skipped == []


def test_a_student_folder_that_is_a_link_out_or_holds_one_is_hostile(tmp_path: Path) -> None:
    cls, outside = tmp_path / "class", tmp_path / "outside"
    for d in (cls / "ann", cls / "bea", outside):
        d.mkdir(parents=True)
    shutil.copyfile(VALID_01, cls / "ann" / "lab.yaml")
    shutil.copyfile(VALID_01, outside / "lab.yaml")
    (cls / "bea" / "lab.yaml").symlink_to(outside / "lab.yaml")
    (cls / "cid").symlink_to(outside)
    rows = {f.student: (f.status, f.reason) for f in find_submissions([str(cls)])[0]}
    assert rows["ann"] == ("graded", "")
    assert rows["bea"] == ("hostile file", f"{cls}/bea/lab.yaml: is a symbolic link to a file outside the "
                                           "behaviour's folder; a submission is read only inside its submissions "
                                           "folder")
    assert rows["cid"] == ("hostile file", f"{cls}/cid: is a symbolic link to a file outside the behaviour's "
                                           "folder; a submission is read only inside its submissions folder")


def test_names_that_would_collide_get_ids_of_their_own() -> None:
    pages = page_names(["a b", "a_b", ".c", "c", "Bob", "bob", "alice.yaml", "alice.yml", "x/../y", "ok"])
    assert len(set(pages.values())) == len(pages)
    assert len({p.casefold() for p in pages.values()}) == len(pages)  # a disk blind to case too
    assert pages["ok"] == "ok.html" and pages["alice.yml"] == "alice.yml.html"
    assert pages["a b"].startswith("a_b-") and pages["a_b"].startswith("a_b-") and "/" not in pages["x/../y"]


@pytest.mark.slow
def test_colliding_students_each_get_their_own_row_result_and_page(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    _assignment(tmp_path)
    cls, other = tmp_path / "class", tmp_path / "other"
    cls.mkdir()
    other.mkdir()
    for name, source in (("alice.yaml", VALID_01), ("alice.yml", VALID_03), ("a b.yaml", VALID_01),
                         ("a_b.yaml", VALID_03)):
        shutil.copyfile(source, cls / name)
    shutil.copyfile(VALID_03, other / "alice.yaml")
    options = Options("assignment.yaml", ["class", "other"], Path("out"), jobs=2)
    graded = grade_class(options)
    assert write_class(graded, options) == 0
    assert graded.collisions == [("class/alice.yaml", "alice.yml", "other/alice.yaml")]
    with open("out/gradebook.csv", newline="") as f:
        rows = {r["Student"]: r for r in csv.DictReader(f)}
    assert set(rows) == {"class/alice.yaml", "alice.yml", "other/alice.yaml", "a b", "a_b"}
    # each row has its own file's result: valid_01 and valid_03 differ in their closest approach
    closest = {s: rows[s]["mean closest"] for s in rows}
    assert closest["class/alice.yaml"] == closest["a b"] != closest["alice.yml"] == closest["a_b"] == \
        closest["other/alice.yaml"]
    feedback = {r["Feedback"] for r in rows.values()}
    assert len(feedback) == 5 and all((tmp_path / "out" / f).is_file() for f in feedback)
    book = json.loads(Path("out/gradebook.json").read_text())
    assert book["name_collisions"] == [["class/alice.yaml", "alice.yml", "other/alice.yaml"]]
    assert "Names that collide" in Path("out/index.html").read_text()
    page = (tmp_path / "out" / rows["a b"]["Feedback"]).read_text()
    assert "a b" in page and "a_b</h1>" not in page


@pytest.mark.parametrize("url", ["javascript:alert(1)", "lms.example.edu/grades", "https://x.edu/a b/", "file:///etc/"])
def test_a_feedback_url_is_an_http_address(tmp_path: Path, capsys, url: str) -> None:
    from labsim.runtime.cli.main import main

    assert main(["grade", str(GRADING / "assignment.yaml"), str(VALID_01), "--out", str(tmp_path / "o"),
                 "--feedback-url", url]) == 2
    assert "--feedback-url: error: give the http(s) address the --out folder will have online" in \
        capsys.readouterr().err
    assert not (tmp_path / "o" / "gradebook.csv").exists()


def test_a_measure_that_reads_a_students_signal_grades_no_one(tmp_path: Path, capsys) -> None:
    from labsim.runtime.cli.main import main

    bad = tmp_path / "a.yaml"
    bad.write_text("labsim-assignment: 1\nworld: any\nrobots: 1\nmeasure:\n  x: count(steer > 1)\n"
                   "criteria: {x: {at_most: 0}}\n")
    assert main(["grade", str(bad), str(VALID_01), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "a.yaml:5:12: error: measured metric 'x' reads 'steer', which is not a sensor" in err
    assert "Traceback" not in err and not (tmp_path / "o" / "gradebook.csv").exists()
