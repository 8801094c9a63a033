"""``labsim scene --save``: CoppeliaSim writes the file; the stand-in says it cannot, clearly."""
from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import BEHAVIOURS

from labsim.runtime.cli.main import main

pytestmark = pytest.mark.slow  # a labsim serve process and labsim scene per test

LAB = BEHAVIOURS / "wall_follow.yaml"


def test_the_stand_in_builds_the_scene_and_says_it_cannot_save_it(empty: int, tmp_path: Path, capsys) -> None:
    target = tmp_path / "lab4.ttt"
    assert main(["scene", str(LAB), "--port", str(empty), "--save", str(target)]) == 2
    captured = capsys.readouterr()
    assert "1 Pioneer P3DX" in captured.out  # built
    assert f"the scene is built, but saving it as {target} failed" in captured.err
    assert "the stand-in writes no .ttt files" in captured.err and "Traceback" not in captured.err
    assert not target.exists()


def test_a_save_path_in_no_folder_is_refused_before_anything_is_built(empty: int, tmp_path: Path, capsys) -> None:
    target = tmp_path / "missing" / "lab4.ttt"
    assert main(["scene", str(LAB), "--port", str(empty), "--save", str(target)]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and f"{target}: error: cannot save the scene there: no folder" in captured.err


def test_a_relative_save_path_is_made_absolute_for_coppeliasim(empty: int, tmp_path: Path, capsys,
                                                               monkeypatch) -> None:
    """CoppeliaSim writes from its own working folder: it gets the path the user meant."""
    monkeypatch.chdir(tmp_path)
    assert main(["scene", str(LAB), "--port", str(empty), "--save", "lab4.ttt"]) == 2
    assert f"saving it as {tmp_path / 'lab4.ttt'} failed" in capsys.readouterr().err
