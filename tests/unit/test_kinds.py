"""One rule each: what kind of file a path holds (foundation/kinds.py) and what a world's name
means (backends/scene/world_names.py), for every command that asks."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from helpers import BEHAVIOURS

from labsim.backends.scene import world_file
from labsim.backends.scene.world_names import BUILTIN_DIR, builtin_copy, builtin_name, builtin_worlds, find_world
from labsim.dsl.syntax import read
from labsim.foundation.files import ALLOW_ENV
from labsim.foundation.kinds import (
    BEHAVIOUR_ONLY_KEYS,
    WORLD_ONLY_KEYS,
    file_kind,
    golden_path,
    kind_of_keys,
    kind_of_text,
    top_level_keys,
)


def test_the_key_sets_are_the_readers_own() -> None:
    assert set(world_file.KEYS) - set(read.TOP_KEYS) == WORLD_ONLY_KEYS
    assert set(read.TOP_KEYS) - set(world_file.KEYS) >= BEHAVIOUR_ONLY_KEYS


def test_every_shipped_file_is_of_its_kind() -> None:
    for path in sorted(BEHAVIOURS.glob("*.yaml")):
        assert file_kind(path) == "behaviour", path
        assert file_kind(golden_path(path)) == "golden", path
    for path in builtin_worlds().values():
        assert file_kind(path) == "world", path


def test_a_file_says_what_it_is_by_its_keys_not_their_order(tmp_path: Path) -> None:
    assert kind_of_text("# a comment\nname: late\nlabsim: 1\nworld: walls_lab4\n") == "behaviour"
    assert kind_of_text("name: w\n\"labsim-world\": 1\n") == "world"
    assert kind_of_text("name: w\nwalls: []\n") == "world"  # no version key: its keys still say so
    assert kind_of_text("rules: []\nwalls: []\n") == "behaviour"
    assert kind_of_text("name: x\nitems:\n  labsim: 1\n") == "unknown"  # nested keys are no top-level keys
    assert kind_of_text("# labsim-trace {}\ntick\n", "a.csv") == "trace"
    assert kind_of_text("# labsim-trace {}\ntick\n", "a.golden.csv") == "golden"
    assert kind_of_keys(set()) == "unknown"
    assert top_level_keys("---\n- item\nkey: 1\n  nested: 2\n'quoted': 3\n") == {"key", "quoted"}


def test_what_cannot_be_read_is_of_no_kind_and_is_not_waited_on(tmp_path: Path) -> None:
    assert file_kind(tmp_path / "missing.yaml") == "unknown"
    assert file_kind(tmp_path) == "unknown"
    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "pipe.yaml")
        assert file_kind(tmp_path / "pipe.yaml") == "unknown"


def test_world_names_by_one_rule(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(ALLOW_ENV, raising=False)
    lab, other = tmp_path / "lab", tmp_path / "other"
    lab.mkdir()
    other.mkdir()
    (lab / "room.yaml").write_text("labsim-world: 1\n")
    (lab / "room").write_text("labsim-world: 1\n")  # no suffix: a path since it is there
    (other / "w.yaml").write_text("labsim-world: 1\n")

    assert find_world("walls_lab4", lab).path == builtin_worlds()["walls_lab4"]
    assert find_world("room.yaml", lab).path == lab / "room.yaml"
    assert find_world("room", lab).path == lab / "room"
    unknown = find_world("walls_lab5", lab)
    assert unknown.path is None and unknown.problem == "unknown world 'walls_lab5' (did you mean 'walls_lab4'?)"
    assert "built-in worlds: " in unknown.notes[0]
    missing = find_world("gone.yaml", lab)
    assert missing.problem == f"world file 'gone.yaml' not found (looked for {lab / 'gone.yaml'})"
    assert find_world(" ", lab).problem == "'world' needs a built-in world's name or a path to a world file"

    refused = find_world("../other/w.yaml", lab)
    assert refused.path is None and refused.refused and "leads out of the behaviour's folder" in refused.problem
    assert find_world("../other/w.yaml", lab, allowed=[other.resolve()]).path is not None  # --allow-path
    assert find_world(str(other / "w.yaml")).path == other / "w.yaml"  # typed by the person: any file
    builtin_file = str(builtin_worlds()["crane"].resolve())
    assert find_world(builtin_file, lab).path is not None  # a built-in's own file, by any path
    found_in_second = find_world("w.yaml", lab, look_in=(other,), allowed=[other.resolve()])
    assert found_in_second.path == other / "w.yaml"


@pytest.mark.parametrize("name", ["walls_lab4.yaml", "walls_lab4.yml", "worlds/walls_lab4.yaml"])
def test_a_built_in_world_named_as_a_file_points_at_its_name(tmp_path: Path, name: str) -> None:
    found = find_world(name, tmp_path)
    assert found.path is None
    assert found.problem == (f"no file '{name}' beside this behaviour; the built-in world is named "
                             "'walls_lab4' (write world: walls_lab4)")
    typed = find_world(str(tmp_path / "walls_lab4.yaml"))  # typed on the command line
    assert typed.problem == (f"no file '{tmp_path / 'walls_lab4.yaml'}' here; the built-in world is named "
                             "'walls_lab4' (write walls_lab4)")
    (tmp_path / "walls_lab4.yaml").write_text("labsim-world: 1\n")  # a file of that name is the one meant
    assert find_world("walls_lab4.yaml", tmp_path).path == tmp_path / "walls_lab4.yaml"


def test_built_in_worlds_are_known_by_their_files(tmp_path: Path) -> None:
    crane = builtin_worlds()["crane"]
    assert builtin_name(crane) == "crane" and builtin_name(crane.resolve()) == "crane"
    assert builtin_name(tmp_path / "crane.yaml") == ""
    copy = tmp_path / "crane.yaml"
    copy.write_text(crane.read_text())
    assert builtin_copy(copy, copy.read_text()) == "crane"
    assert builtin_copy(copy, copy.read_text() + "\n# edited\n") == ""
    assert builtin_copy(tmp_path / "mine.yaml", "") == ""
    assert crane.parent == BUILTIN_DIR
