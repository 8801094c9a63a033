"""The shipped labs by name: `labsim labs`, `labsim run NAME`, `labsim new NAME [DIR]`, and
what the package holds (the labs, py.typed; nothing test- or benchmark-only)."""
from __future__ import annotations

import importlib
from pathlib import Path

import pytest

import labsim
from labsim.runtime.cli.main import main
from labsim.runtime.labs import LABS_DIR, behaviour_path, labs

LAB_NAMES = ["crane", "line_follow", "road_follow", "wall_follow", "wall_follow_handout"]


def test_labs_lists_every_lab_with_its_title(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["labs"]) == 0
    out = capsys.readouterr().out
    for name in LAB_NAMES:
        assert name in out
    assert "Wall following" in out and "labsim run NAME" in out
    assert list(labs()) == LAB_NAMES
    titles = [line.index(labs()[line.split()[0]].title) for line in out.splitlines()[:len(LAB_NAMES)]]
    assert set(titles) == {len("wall_follow_handout") + 2}  # one column of titles, the longest name's


def test_a_lab_runs_and_checks_by_name(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["check", "wall_follow"]) == 0
    assert f"{LABS_DIR / 'wall_follow.yaml'}: ok" in capsys.readouterr().out
    assert main(["run", "crane", "-q"]) == 0


def test_a_misspelt_lab_name_is_a_clear_error(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "wal_follow"]) == 2
    err = capsys.readouterr().err
    assert "wal_follow: error: no such behaviour file or lab 'wal_follow' (did you mean 'wall_follow'?)" in err
    assert "labs: crane, line_follow, road_follow, wall_follow" in err and "Traceback" not in err


def test_a_file_always_wins_over_a_lab_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "crane").write_text("not a lab")
    assert behaviour_path("crane") == Path("crane")
    assert behaviour_path("missing.yaml") == Path("missing.yaml")  # the loader says it is missing


def test_new_copies_a_lab_and_its_golden_which_then_passes(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["new", "crane", str(tmp_path / "mine")]) == 0
    out = capsys.readouterr().out
    copied = sorted(p.name for p in (tmp_path / "mine").iterdir())
    assert copied == ["behaviour.schema.json", "crane.golden.csv", "crane.yaml"]  # docs/editors.md
    assert "labsim run" in out and "--update-goldens" in out
    assert main(["test", str(tmp_path / "mine")]) == 0
    assert "1 passed, 0 failed" in capsys.readouterr().out


def test_new_never_overwrites(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["new", "crane", str(tmp_path)]) == 0
    (tmp_path / "crane.yaml").write_text("# my edits\n")
    assert main(["new", "crane", str(tmp_path)]) == 2
    assert "already exists; labsim new does not overwrite" in capsys.readouterr().err
    assert (tmp_path / "crane.yaml").read_text() == "# my edits\n"
    assert main(["new", "cranes", str(tmp_path)]) == 2
    assert "(did you mean 'crane'?)" in capsys.readouterr().err


def test_the_package_is_typed_and_ships_the_labs() -> None:
    root = Path(labsim.__file__).parent
    assert (root / "py.typed").is_file()
    for name in LAB_NAMES:
        assert (root / "behaviours" / f"{name}.yaml").is_file()
        assert (root / "behaviours" / f"{name}.golden.csv").is_file()


@pytest.mark.parametrize("name", ["labsim.tests", "labsim.benchmarks", "labsim.docs"])
def test_nothing_test_or_benchmark_only_is_importable_as_labsim(name: str) -> None:
    # the repository root is the package root; an install (a wheel, or the strict editable
    # install the README's test command makes) exposes only the package's own subpackages
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(name)
