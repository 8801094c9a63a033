"""Goldens and worlds: the trace header records the world's hash (and a built-in world's
version), and a failing golden says when the world changed under it."""
from __future__ import annotations

import json
from pathlib import Path

from helpers import ROOT

from labsim.runtime.cli.main import main

WORLD = ROOT / "backends" / "scene" / "worlds" / "walls_lab4.yaml"
LAB = """labsim: 1
world: room.yaml
stop: time >= 1
robots:
  p: {model: pioneer_p3dx, at: [-6, 0, 0]}
let:
  ahead: sonar5
rules:
  - always move(2)
"""


def header(path: Path) -> dict:
    return json.loads(path.read_text().splitlines()[0].removeprefix("# labsim-trace "))


def test_a_changed_world_file_is_named_in_the_golden_failure(capsys, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    (tmp_path / "room.yaml").write_text(WORLD.read_text())
    (tmp_path / "lab.yaml").write_text(LAB)
    assert main(["test", "lab.yaml", "--update-goldens"]) == 0
    recorded = header(tmp_path / "lab.golden.csv")
    assert len(recorded["world_sha256"]) == 64 and "world_version" not in recorded
    room = (tmp_path / "room.yaml").read_text().replace("to: [-7.5, -7.5]}", "to: [-5.5, -7.5]}")
    (tmp_path / "room.yaml").write_text(room.replace("[-7.5, 7.5], to", "[-5.5, 7.5], to"))
    capsys.readouterr()
    assert main(["test", "lab.yaml"]) == 1
    out = capsys.readouterr().out
    assert "note: world 'walls_lab4' has changed since the golden was recorded" in out
    assert "note: the behaviour file has changed" not in out


def test_a_builtin_world_records_its_hash_and_version(capsys) -> None:
    golden = header(ROOT / "behaviours" / "wall_follow.golden.csv")
    assert golden["world_version"].startswith("built-in, labsim ")
    assert len(golden["world_sha256"]) == 64


def test_a_difference_in_the_rule_column_shows_that_column_once() -> None:
    from labsim.runtime.golden import compare
    from labsim.runtime.trace import Trace
    cols = ["tick", "time", "robot", "rule"]
    golden = Trace("g", {}, cols, [["0", "0", "p", "main:1"], ["1", "0.05", "p", "main:1"]])
    run = Trace("r", {}, cols, [["0", "0", "p", "main:1"], ["1", "0.05", "p", "main:2"]])
    difference = compare(golden, run)
    assert difference is not None
    table = str(difference).splitlines()[3:]
    assert table[0].split() == ["tick", "time", "rule"]
    assert table[2].split() == [">", "1", "0.05", "main:1", "|", "main:2"]
