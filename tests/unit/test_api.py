"""The Python API (runtime/api.py, docs/api.md): importable from labsim, typed, and the
notebook example in docs/api.md runs as written."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import ROOT

import labsim


def test_the_notebook_example_in_docs_api_runs(capsys: pytest.CaptureFixture[str]) -> None:
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "api.md").read_text(encoding="utf-8"), re.S)
    assert blocks
    for block in blocks:
        exec(compile(block, "docs/api.md", "exec"), {})
    out = capsys.readouterr().out
    assert "stop condition" in out
    assert "bad.yaml:6:1: error: unknown key 'rulez'" in out


def test_every_name_docs_api_lists_is_importable_from_labsim() -> None:
    for name in labsim.__all__:
        assert getattr(labsim, name) is not None
    with pytest.raises(AttributeError):
        labsim.no_such_thing  # noqa: B018


def test_importing_labsim_loads_no_runtime() -> None:
    code = "import sys, labsim; print(any(m.startswith('labsim.runtime') for m in sys.modules))"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "False"


def test_read_trace_gives_numbers_and_the_header(tmp_path: Path) -> None:
    summary = labsim.run(ROOT / "tests" / "fixtures" / "minimal.yaml", params={"front": 0.7}, trace=tmp_path / "t.csv")
    df = labsim.read_trace(tmp_path / "t.csv")
    assert len(df) == summary["ticks"]
    assert df["time"].dtype.kind == "f" and df["tick"].dtype.kind == "i"
    assert df.attrs["params"]["front"] == 0.7
    assert summary["params"]["front"] == 0.7


def test_a_damaged_trace_is_a_labsim_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("tick,time\n1,2\n")
    with pytest.raises(labsim.LabsimError, match="not a labsim trace"):
        labsim.read_trace(bad)


def test_a_compiled_behaviour_takes_no_more_settings() -> None:
    behaviour = labsim.compile_behaviour(ROOT / "tests" / "fixtures" / "minimal.yaml")
    with pytest.raises(labsim.LabsimError, match="give them to compile_behaviour"):
        labsim.run(behaviour, seed=3)


def _grader() -> str:
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "docs" / "api.md").read_text(encoding="utf-8"), re.S)
    return next(b for b in blocks if b.startswith("# test_grade.py"))


@pytest.mark.slow  # seconds: a pytest session of its own, grading a folder; handed out first
def test_the_pytest_grader_in_docs_api_grades_a_folder(tmp_path: Path) -> None:
    submissions = tmp_path / "submissions"
    submissions.mkdir()
    good = (ROOT / "behaviours" / "wall_follow.yaml").read_text(encoding="utf-8")
    (submissions / "ana.yaml").write_text(good.replace("minutes: 25", "minutes: 0.2"), encoding="utf-8")
    (submissions / "bo.yaml").write_text(good.replace("rules:", "rulez:"), encoding="utf-8")
    (tmp_path / "test_grade.py").write_text(_grader(), encoding="utf-8")
    proc = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--noconftest",
                           f"--rootdir={tmp_path}", "test_grade.py"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    assert "1 failed, 1 passed" in proc.stdout, proc.stdout + proc.stderr
    assert "bo.yaml" in proc.stdout and "Traceback" not in proc.stdout
    assert "During handling" not in proc.stdout  # failed once, not chained to the LabsimError
    failure = proc.stdout.split("test_no_contact[bo] _", 1)[1].split("\n=", 1)[0].strip("_ \n")
    assert failure == "submissions/bo.yaml: error: missing required key 'rules:'", proc.stdout


def test_a_run_over_its_budget_or_timeout_raises_labsims_own_error() -> None:
    with pytest.raises(labsim.OverBudget, match="budget of 300 ticks") as over:
        labsim.run("wall_follow", budget={"ticks": 300})
    assert over.value.summary["ticks"] == 300
    with pytest.raises(labsim.RunTimeout, match=r"still going after 0\.001 s") as late:
        labsim.run("wall_follow", timeout=0.001)
    assert late.value.summary["ticks"] == 256  # checked between blocks of 256 ticks
    with pytest.raises(labsim.LabsimError, match="budget memory_mb=x"):
        labsim.run("wall_follow", budget={"memory_mb": "x"})  # type: ignore[dict-item]
