"""Shell completion: what `labsim <Tab>` offers, asked the way bash asks argcomplete."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from helpers import BEHAVIOURS

pytestmark = pytest.mark.slow  # each test asks a labsim process, as bash does


def complete(line: str, tmp_path: Path, cwd: Path | None = None) -> list[str]:
    """The completions of a command line, as the shell would receive them."""
    out = tmp_path / "completions"
    env = {**os.environ, "_ARGCOMPLETE": "1", "_ARGCOMPLETE_IFS": "\n", "COMP_LINE": line,
           "COMP_POINT": str(len(line)), "_ARGCOMPLETE_STDOUT_FILENAME": str(out),
           "_ARGCOMPLETE_SHELL": "bash"}
    done = subprocess.run([sys.executable, "-m", "labsim"], env=env, cwd=cwd, capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    return [w.strip() for w in out.read_text().split("\n") if w.strip()]


def test_commands_and_options(tmp_path: Path) -> None:
    assert {"run", "view", "sweep", "labs", "new"} <= set(complete("labsim ", tmp_path))
    assert "--seed" in complete("labsim run wall_follow --se", tmp_path)


def test_lab_names_and_behaviour_files(tmp_path: Path) -> None:
    assert complete("labsim run wa", tmp_path) == ["wall_follow", "wall_follow_handout"]
    (tmp_path / "mine.yaml").write_text("labsim: 1\n")
    (tmp_path / "notes.txt").write_text("")
    assert complete("labsim check m", tmp_path, cwd=tmp_path) == ["mine.yaml"]
    assert complete("labsim check n", tmp_path, cwd=tmp_path) == []


def test_parameter_names_of_the_file_on_the_line(tmp_path: Path) -> None:
    assert set(complete("labsim run wall_follow --set ", tmp_path)) == {
        "minutes=", "front=", "side=", "cruise="}
    lab = BEHAVIOURS / "wall_follow.yaml"
    assert complete(f"labsim view {lab} --set fr", tmp_path) == ["front="]


def test_built_in_worlds_for_serve(tmp_path: Path) -> None:
    assert complete("labsim serve road", tmp_path) == ["road_compact", "road_loop"]
