"""``labsim grade`` gives no wrong grade confidently: no student silently dropped, no world swapped
under the assignment's name, no grade that depends on the file's format version, on a student's
noise or on a fault of the assignment's own formula; assignment mistakes at their place; pages,
links and ids that hold (runtime/grade)."""
from __future__ import annotations

import csv
import json
import shutil
from pathlib import Path

import pytest
from helpers import FIXTURES

from labsim.foundation.diagnostics import LabsimError
from labsim.runtime.grade.assignment import budget_words, read_assignment
from labsim.runtime.grade.contract import check_submission, find_submissions
from labsim.runtime.grade.copies import structures
from labsim.runtime.grade.gradebook import page_names
from labsim.runtime.grade.pages import run_command
from labsim.runtime.grade.score import Grade

GRADING = FIXTURES / "grading"
V1 = GRADING / "class" / "valid_01.yaml"  # format 1, the lab's template
WORLD = Path(__file__).parents[2] / "backends" / "scene" / "worlds" / "walls_lab4.yaml"
ASSIGNMENT = """labsim-assignment: 1
world: walls_lab4
robots: 1
params: {minutes: 0.1}
measure:
  hits: count(collided)
  ran_for: final(time)
seeds: [1]
criteria:
  hits: {at_most: 5}
  ran_for: {at_least: 6, required: true}
"""


def _main(args: list[str]) -> int:
    from labsim.runtime.cli.main import main

    return main(args)


def _rows(out: Path) -> dict[str, dict[str, str]]:
    with open(out / "gradebook.csv", newline="") as f:
        return {r["Student"]: r for r in csv.DictReader(f)}


# -- 1. nobody vanishes ---------------------------------------------------------------------------

def test_loose_files_beside_student_folders_are_all_students_and_the_rest_is_listed(tmp_path: Path) -> None:
    c = tmp_path / "c"
    for d in ("alice", "bob", "x.yaml", "worlds"):
        (c / d).mkdir(parents=True)
    shutil.copyfile(V1, c / "alice" / "lab.yaml")
    shutil.copyfile(V1, c / "bob" / "lab.yaml")
    shutil.copyfile(V1, c / "x.yaml" / "lab.yaml")  # a folder named like a file
    shutil.copyfile(V1, c / "template.yaml")
    shutil.copyfile(V1, c / "amy.YAML")
    (c / "stray.yaml").write_text("labsim-world: 1\n" + V1.read_text())
    (c / "asg.yaml").write_text("labsim-assignment: 1\n" + V1.read_text())
    shutil.copyfile(WORLD, c / "worlds" / "mine.yaml")  # a folder is a student's: a row, whatever it holds
    shutil.copyfile(WORLD, c / "arena.yaml")
    (c / "notes.txt").write_text("hi")
    (c / "alink").symlink_to("alice")  # a link inside: a name of its own
    (c / "__MACOSX").mkdir()  # what a zip made on macOS holds beside the class
    (c / "__MACOSX" / "._template.yaml").write_bytes(b"\0\5\26\7")
    (c / "._template.yaml").write_bytes(b"\0\5\26\7")
    (c / "alice" / "._lab.yaml").write_bytes(b"\0\5\26\7")
    found, collisions, skipped = find_submissions([str(c)])
    assert {f.student: (f.status, str(f.path)) for f in found} == {
        "alice": ("graded", f"{c}/alice/lab.yaml"), "bob": ("graded", f"{c}/bob/lab.yaml"),
        "x.yaml": ("graded", f"{c}/x.yaml/lab.yaml"), "template": ("graded", f"{c}/template.yaml"),
        "amy": ("graded", f"{c}/amy.YAML"), "stray": ("graded", f"{c}/stray.yaml"),
        "asg": ("graded", f"{c}/asg.yaml"), "alink": ("graded", f"{c}/alink/lab.yaml"),
        "worlds": ("contract mismatch", "None")}
    assert next(f.reason for f in found if f.student == "worlds") == (f"the folder {c}/worlds holds 0 behaviour "
                                                                       "files; a student's folder holds one")
    assert collisions == []
    assert skipped == [(f"{c}/._template.yaml", "a hidden file or folder"), (f"{c}/__MACOSX", "macOS archive metadata"),
                       (f"{c}/arena.yaml", "a world file"), (f"{c}/notes.txt", "not a .yaml or .yml file")]


@pytest.mark.slow
def test_a_mixed_folder_grades_every_student_and_says_what_it_passed_over(tmp_path: Path, capsys) -> None:
    (tmp_path / "a.yaml").write_text(ASSIGNMENT)
    c = tmp_path / "c"
    (c / "alice").mkdir(parents=True)
    shutil.copyfile(V1, c / "alice" / "lab.yaml")
    shutil.copyfile(V1, c / "template.yaml")
    (c / "stray.yaml").write_text("labsim-world: 1\n" + V1.read_text())
    (c / "notes.txt").write_text("hi")
    out = tmp_path / "g"
    assert _main(["grade", str(tmp_path / "a.yaml"), str(c), "--out", str(out), "-j", "1", "--no-pages"]) == 1
    printed = capsys.readouterr().out
    assert f"passed over: {c}/notes.txt: not a .yaml or .yml file" in printed
    rows = _rows(out)
    assert {s: r["Status"] for s, r in rows.items()} == {"alice": "graded", "template": "graded",
                                                          "stray": "compile error"}
    assert rows["stray"]["Reason"].startswith("stray.yaml:1:1: ")
    book = json.loads((out / "gradebook.json").read_text())
    assert book["passed_over"] == [{"path": f"{c}/notes.txt", "why": "not a .yaml or .yml file"}]


def test_the_same_file_twice_is_one_student(tmp_path: Path) -> None:
    g1 = tmp_path / "g1"
    g1.mkdir()
    shutil.copyfile(V1, g1 / "ann.yaml")
    found, _, skipped = find_submissions([str(g1), str(g1), str(g1 / "ann.yaml")])
    assert [f.student for f in found] == ["ann"]
    assert skipped == [(f"{g1}/ann.yaml", f"the same file as {g1}/ann.yaml: one row")]
    (g1 / "leak.yaml").symlink_to("/etc/passwd")  # a refused file given twice is one row too
    found, _, skipped = find_submissions([str(g1), str(g1 / "leak.yaml")])
    assert [(f.student, f.status) for f in found] == [("ann", "graded"), ("leak", "hostile file")]
    assert skipped == [(f"{g1}/leak.yaml", f"the same file as {g1}/leak.yaml: one row")]


def test_a_file_named_one_by_one_that_links_out_is_hostile(tmp_path: Path) -> None:
    s = tmp_path / "s"
    s.mkdir()
    (s / "leak.yaml").symlink_to("/etc/passwd")
    found, _, _ = find_submissions([str(s / "leak.yaml")])
    assert [(f.student, f.status, f.reason) for f in found] == [
        ("leak", "hostile file", f"{s}/leak.yaml: is a symbolic link to a file outside the behaviour's folder; a "
                                 "submission is read only inside its submissions folder")]


def test_a_folder_named_through_a_link_is_the_teachers(tmp_path: Path) -> None:
    (tmp_path / "export" / "ann").mkdir(parents=True)
    shutil.copyfile(V1, tmp_path / "export" / "ann" / "lab.yaml")
    (tmp_path / "here").mkdir()
    (tmp_path / "here" / "class").symlink_to(tmp_path / "export")
    found, _, _ = find_submissions([str(tmp_path / "here" / "class")])
    assert [(f.student, f.status) for f in found] == [("ann", "graded")]


def test_ids_that_differ_in_case_are_their_relative_paths_and_pages_differ_by_a_hash(tmp_path: Path) -> None:
    c3 = tmp_path / "c3"
    c3.mkdir()
    shutil.copyfile(V1, c3 / "Bob.yaml")
    shutil.copyfile(V1, c3 / "bob.yaml")
    found, collisions, _ = find_submissions([str(c3)])
    assert [f.student for f in found] == ["Bob.yaml", "bob.yaml"]
    assert collisions == [("Bob.yaml", "bob.yaml")]
    pages = page_names(["Bob.yaml", "bob.yaml"])
    assert pages["Bob.yaml"].casefold() != pages["bob.yaml"].casefold()


# -- 2, 5, 6. the world, noise, the assignment's own mistakes ------------------------------------

def test_a_world_of_its_own_under_the_assignments_name_is_another_world(tmp_path: Path) -> None:
    (tmp_path / "a.yaml").write_text(ASSIGNMENT)
    f = tmp_path / "f"
    f.mkdir()
    (f / "easy.yaml").write_text("labsim-world: 1\nname: walls_lab4\nbounds: [-5, -5, 5, 5]\n")
    (f / "forged.yaml").write_text(V1.read_text().replace("world: walls_lab4", "world: easy.yaml"))
    got = check_submission("forged", f / "forged.yaml", read_assignment(tmp_path / "a.yaml"))
    assert (got.status, got.reason) == ("contract mismatch", "another world: it uses 'easy.yaml' (named "
                                                             "'walls_lab4'), not the assignment's world 'walls_lab4'")


def test_a_world_beside_the_assignment_is_named_by_its_name_and_held_to_its_content(tmp_path: Path) -> None:
    world = WORLD.read_text().replace("name: walls_lab4", "name: mylab")
    assert "name: mylab" in world
    (tmp_path / "mylab_world.yaml").write_text(world)
    (tmp_path / "a.yaml").write_text(ASSIGNMENT.replace("world: walls_lab4", "world: mylab"))
    assignment = read_assignment(tmp_path / "a.yaml")
    assert assignment.world_file == str(tmp_path / "mylab_world.yaml")
    for name, text, expected in (("same", world, ("graded", "")),
                                 ("changed", world + "\n# moved a wall\n",
                                  ("contract mismatch", "another world: it uses 'mylab.yaml' (named 'mylab'), not "
                                                        "the assignment's world 'mylab'"))):
        folder = tmp_path / name
        folder.mkdir()
        (folder / "mylab.yaml").write_text(text)
        (folder / "lab.yaml").write_text(V1.read_text().replace("world: walls_lab4", "world: mylab.yaml"))
        got = check_submission(name, folder / "lab.yaml", assignment)
        assert (got.status, got.reason) == expected


def test_a_students_noise_is_a_contract_mismatch(tmp_path: Path) -> None:
    (tmp_path / "a.yaml").write_text(ASSIGNMENT)
    noisy = V1.read_text().replace("at: random}", "at: random, noise: {sonar: {std_m: 0.3}}}")
    assert "noise" in noisy
    (tmp_path / "noisy.yaml").write_text(noisy)
    got = check_submission("noisy", tmp_path / "noisy.yaml", read_assignment(tmp_path / "a.yaml"))
    assert (got.status, got.reason) == ("contract mismatch", "robot 'pioneer' sets its own noise: the grader "
                                                             "measures every run without noise (remove noise: to "
                                                             "be graded)")


@pytest.mark.parametrize("world, message", [
    ("walls_lab5", "unknown world 'walls_lab5' (did you mean 'walls_lab4'?)"),
    ("/etc/passwd", "world file '/etc/passwd' lies outside the assignment's folder: the grader reads a built-in "
                    "world or a world file beside the assignment (docs/grading.md)")])
def test_a_wrong_world_or_reference_is_an_assignment_error_at_its_place(tmp_path: Path, world: str,
                                                                        message: str) -> None:
    (tmp_path / "a.yaml").write_text(ASSIGNMENT.replace("world: walls_lab4", f"world: {world}")
                                     + "reference: nope.yaml\n")
    with pytest.raises(LabsimError) as e:
        read_assignment(tmp_path / "a.yaml")
    assert [(d.line, d.col, d.message) for d in e.value.diagnostics] == [
        (2, 8, message), (12, 12, f"no reference behaviour 'nope.yaml' (looked for {tmp_path}/nope.yaml)")]


# -- 3, 4. what is measured does not depend on the student; the assignment's faults are its own --

@pytest.mark.slow
def test_final_time_is_the_same_for_format_1_and_a_failing_reference_is_said(tmp_path: Path, capsys) -> None:
    s = tmp_path / "s"
    s.mkdir()
    shutil.copyfile(V1, s / "v1.yaml")
    (s / "v11.yaml").write_text(V1.read_text().replace("labsim: 1\n", "labsim: 1.1\n"))
    (tmp_path / "early.yaml").write_text(V1.read_text().replace("stop: time >= minutes * 60", "stop: time >= 2"))
    (tmp_path / "a.yaml").write_text(ASSIGNMENT + "reference: early.yaml\n")
    out = tmp_path / "g"
    assert _main(["grade", str(tmp_path / "a.yaml"), str(s), "--out", str(out), "-j", "1"]) == 0
    err = capsys.readouterr().err
    rows = _rows(out)
    assert (rows["v1"]["Score"], rows["v1"]["Status"], rows["v1"]["mean ran_for"]) == ("100.0", "graded", "6.0")
    assert (rows["v11"]["Score"], rows["v11"]["mean ran_for"]) == ("100.0", "6.0")
    warning = (f"the reference behaviour {tmp_path}/early.yaml does not pass the assignment: failed gate: ran_for, "
               "it fails ran_for (required criterion 'ran_for' failed: ran_for is 2; the criterion is ran_for >= 6); "
               "check the assignment's criteria before sending grades")
    assert f"labsim grade: warning: {warning}\n" in err
    assert "The assignment: the reference behaviour" in (out / "index.html").read_text()
    assert json.loads((out / "gradebook.json").read_text())["assignment_warnings"] == [warning]


RATE = ASSIGNMENT.replace("  ran_for: final(time)\n", "  ran_for: final(time)\n  rate: mean(hypot(x, y) / time)\n") \
    .replace("criteria:\n", "criteria:\n  no_faults: {required: true}\n")


@pytest.mark.slow
def test_a_fault_in_a_measured_metric_is_the_assignments_not_the_students(tmp_path: Path, capsys) -> None:
    s = tmp_path / "s"
    s.mkdir()
    shutil.copyfile(V1, s / "ann.yaml")
    (tmp_path / "a.yaml").write_text(RATE)
    out = tmp_path / "g"
    assert _main(["grade", str(tmp_path / "a.yaml"), str(s), "--out", str(out), "-j", "1"]) == 0
    err = capsys.readouterr().err
    assert (_rows(out)["ann"]["Score"], _rows(out)["ann"]["Status"]) == ("100.0", "graded")
    assert (f"labsim grade: warning: {tmp_path}/a.yaml:8:3: the measured metric 'rate' faulted on the runs of 1 "
            "student (first ann: measured metric 'rate': division by zero: 1 time (first at tick 0, robot "
            "pioneer)); that is the assignment's formula, not a student's fault: no_faults does not count it") in err
    assert "The assignment: " in (out / "index.html").read_text()
    shutil.copyfile(V1, tmp_path / "ref.yaml")
    (tmp_path / "a.yaml").write_text(RATE + "reference: ref.yaml\n")
    assert _main(["grade", str(tmp_path / "a.yaml"), str(s), "--out", str(tmp_path / "g2"), "-j", "1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{tmp_path}/a.yaml:8:3: error: the measured metric 'rate' faults on the reference "
                          "behaviour's run (seed 1: measured metric 'rate': division by zero: 1 time (first at tick "
                          "0, robot pioneer)); fix its formula before grading")
    assert not (tmp_path / "g2" / "gradebook.csv").exists()


# -- 9. pages ------------------------------------------------------------------------------------

@pytest.mark.slow
def test_no_pages_links_no_page_and_removes_only_the_graders_stale_pages(tmp_path: Path) -> None:
    (tmp_path / "a.yaml").write_text(ASSIGNMENT)
    s = tmp_path / "s"
    s.mkdir()
    shutil.copyfile(V1, s / "ann.yaml")
    shutil.copyfile(V1, s / "bob.yaml")
    out = tmp_path / "g"
    base = ["grade", str(tmp_path / "a.yaml"), "--out", str(out), "-j", "1"]
    assert _main([*base, str(s)]) == 0
    assert (out / "feedback" / "bob.html").is_file() and (out / "feedback" / "bob.png").is_file()
    (out / "feedback" / "mine.html").write_text("<p>the teacher's own</p>")
    (out / "notes.txt").write_text("mine")
    (s / "bob.yaml").unlink()
    assert _main([*base, str(s)]) == 0  # bob left the class: his page goes
    assert sorted(p.name for p in (out / "feedback").iterdir()) == ["ann.gif", "ann.html", "ann.png", "mine.html"]
    assert _main([*base, str(s), "--no-pages"]) == 0
    assert _rows(out)["ann"]["Feedback"] == ""
    assert sorted(p.name for p in (out / "feedback").iterdir()) == ["mine.html"]
    assert not (out / "index.html").exists() and (out / "notes.txt").read_text() == "mine"


# -- 11 to 16 --------------------------------------------------------------------------------------

@pytest.mark.parametrize("name, shown", [("--help.yaml", "./--help.yaml"), ("a b.yaml", "'a b.yaml'"),
                                         ("-x; rm.yaml", "'./-x; rm.yaml'")])
def test_the_run_command_is_safe_for_the_shell(tmp_path: Path, name: str, shown: str) -> None:
    (tmp_path / "a.yaml").write_text(ASSIGNMENT)
    grade = Grade("s", f"class/{name}", "graded")
    assert run_command(grade, read_assignment(tmp_path / "a.yaml"), 2) == f"labsim run {shown} --set minutes=0.1 " \
                                                                         "--seed 2"


def test_a_budget_stop_names_the_assignments_budgets() -> None:
    assert budget_words("reached its tick budget of 5,000 ticks before its stop condition held; raise it with "
                        "--budget ticks=N") == ("reached its tick budget of 5,000 ticks before its stop condition "
                                                "held; raise it with the assignment's budgets: {ticks: N}")


@pytest.mark.parametrize("url", ["https://x.edu/g/?course=4", "https://x.edu/g/#top"])
def test_a_feedback_url_with_a_query_or_fragment_is_refused(tmp_path: Path, capsys, url: str) -> None:
    assert _main(["grade", str(GRADING / "assignment.yaml"), str(V1), "--out", str(tmp_path / "o"),
                  "--feedback-url", url]) == 2
    assert capsys.readouterr().err == (f"--feedback-url: error: give the folder's address without a query or a "
                                       f"fragment ('?' or '#'): each page's link is the address followed by "
                                       f"feedback/NAME.html, not {url!r}\n")


LAB = """labsim: 1.2
world: walls_lab4
stop: time > 5
robots:
  r: {model: pioneer_p3dx, at: [0, 0, 0]}
params: {spd: 1, turnamt: 0.5}
let:
  near: sonar5 < 0.5
rules:
  - if near then arc(spd - turnamt, spd + turnamt)
  - else move(spd)
"""


def _structure(tmp_path: Path, name: str, text: str) -> tuple[str, str]:
    from labsim.dsl.syntax.read import read
    from labsim.foundation.diagnostics import Report
    from labsim.foundation.source import loads

    report = Report()
    out = structures(read(loads(text, str(tmp_path / name)), report))
    assert not report.errors and out[0]
    return out


@pytest.mark.parametrize("change", [
    lambda t: t.replace("let:\n", "let:\n  junk: 1\n"),  # a signal nothing reads
    lambda t: t.replace("arc(spd - turnamt,", "arc(spd + -turnamt,"),
    lambda t: t.replace("spd + turnamt)", "turnamt + spd)"),
    lambda t: t.replace("sonar5 < 0.5", "0.5 > sonar5"),
    lambda t: t.replace("params: {spd: 1, turnamt: 0.5}", "params: {spd: 1, turnamt: 0.5, unused: 3}")])
def test_copies_are_found_through_trivial_rewrites(tmp_path: Path, change) -> None:
    changed = change(LAB)
    assert changed != LAB
    assert _structure(tmp_path, "a.yaml", LAB) == _structure(tmp_path, "b.yaml", changed)


def test_a_changed_rule_is_no_copy(tmp_path: Path) -> None:
    assert _structure(tmp_path, "a.yaml", LAB)[0] != _structure(
        tmp_path, "b.yaml", LAB.replace("arc(spd - turnamt,", "arc(spd * turnamt,"))[0]



# -- 17, 18 ----------------------------------------------------------------------------------------

@pytest.mark.slow
def test_a_file_too_slow_to_compile_is_stopped_at_the_students_time_limit(tmp_path: Path) -> None:
    (tmp_path / "a.yaml").write_text(ASSIGNMENT.replace("seeds: [1]", "seeds: [1]\ntimeout_s: 0.2"))
    s = tmp_path / "s"
    s.mkdir()
    rules = "".join(f"  - if sonar1 < {i} then arc({i % 3}, 1)\n" for i in range(20000))
    (s / "huge.yaml").write_text(LAB.split("rules:")[0] + "rules:\n" + rules)
    out = tmp_path / "g"
    assert _main(["grade", str(tmp_path / "a.yaml"), str(s), "--out", str(out), "-j", "1", "--no-pages"]) == 1
    row = _rows(out)["huge"]
    assert (row["Status"], row["Reason"]) == ("timeout", "compiling it took longer than the student's time limit "
                                                         "of 5.2 s (1 seed of 0.2 s, and 5 s), and it was stopped")


@pytest.mark.parametrize("change, where, message", [
    ("seeds: [1]", (8, 8), "seeds is a list of 1 to 100 seeds, e.g. [1, 2, 3]"),
    ("hits: {at_most: 5}", (10, 19), "'hits' is a count, never below 0: at_most: -1 fails every run"),
    ("ran_for: {at_least: 6, required: true}", (11, 23),
     "'ran_for' is a duration, never below 0: at_least: -0.15 passes every run")])
def test_one_mistake_one_message_and_thresholds_a_count_can_never_meet(tmp_path: Path, change: str,
                                                                       where: tuple[int, int], message: str) -> None:
    text = ASSIGNMENT.replace("seeds: [1]", "seeds: 1-3") if change.startswith("seeds") else \
        ASSIGNMENT.replace("hits: {at_most: 5}", "hits: {at_most: -1}") if change.startswith("hits") else \
        ASSIGNMENT.replace("ran_for: final(time)", "ran_for: duration(x > 0)").replace(
            "ran_for: {at_least: 6, required: true}", "ran_for: {at_least: -0.15, required: true}")
    (tmp_path / "a.yaml").write_text(text)
    with pytest.raises(LabsimError) as e:
        read_assignment(tmp_path / "a.yaml")
    assert [(d.line, d.col, d.message) for d in e.value.diagnostics] == [(*where, message)]


def test_a_warning_says_warning_once_and_final_time_is_in_seconds(tmp_path: Path) -> None:
    from labsim.runtime.grade.gradebook import messages
    from labsim.runtime.grade.pages import metric_words
    from labsim.runtime.grade.runs import SeedRun

    grade = Grade("s", "s.yaml", "graded", runs=(SeedRun(1, "ran", warnings=("s.yaml:3:1: warning: unused\n  x",
                                                                             "a plain one")),))
    assert messages(grade) == ["s.yaml:3:1: warning: unused", "warning: a plain one"]
    (tmp_path / "a.yaml").write_text(ASSIGNMENT)
    assert metric_words(read_assignment(tmp_path / "a.yaml"), "ran_for") == (
        "the value of the expression at the end of the run", "final(time)", "s")


def test_a_budget_refused_at_compile_names_the_assignments_budgets(tmp_path: Path) -> None:
    (tmp_path / "a.yaml").write_text(ASSIGNMENT.replace("robots: 1", "robots: any\nbudgets: {robots: 5}"))
    (tmp_path / "many.yaml").write_text(V1.read_text().replace("at: random}", "at: random, count: 20}"))
    got = check_submission("many", tmp_path / "many.yaml", read_assignment(tmp_path / "a.yaml"))
    assert got.status == "budget stop"
    assert got.diagnostics[0].notes == ("if the file is right, raise the budget where it runs: the assignment's "
                                        "budgets: {robots: 20}",)
