"""The README's showcase file (under "The language") checks and runs clean when a user copies it.

It shows most of the language in one file; a reader copies it first, so it must compile without
a warning and run without labsim correcting it (no wheel command clamped, no fault).
"""
from __future__ import annotations

import re
from pathlib import Path

from helpers import ROOT

from labsim.runtime.cli.main import main


def showcase() -> str:
    """The first YAML block after the README's "## The language" heading."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    found = re.search(r"```yaml\n(.*?)```", text[text.index("\n## The language\n"):], re.S)
    assert found is not None, "the README's language section has no yaml block"
    return found.group(1)


def test_the_showcase_checks_without_a_warning(capsys, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    (tmp_path / "showcase.yaml").write_text(showcase(), encoding="utf-8")
    assert main(["check", str(tmp_path / "showcase.yaml")]) == 0
    out, err = capsys.readouterr()
    assert (out, err) == (f"{tmp_path / 'showcase.yaml'}: ok\n", "")


def test_the_showcase_runs_without_a_warning_a_fault_or_a_clamped_wheel(capsys, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    (tmp_path / "showcase.yaml").write_text(showcase(), encoding="utf-8")
    assert main(["run", str(tmp_path / "showcase.yaml"), "--set", "minutes=5", "--no-progress"]) == 0
    out, err = capsys.readouterr()
    assert "robot pioneer: 0 collisions\n" in out  # nothing after it: no clamped wheel command, no fault
    assert "warning" not in out + err and "clamped" not in out + err and "fault" not in out + err
    assert re.search(r"wander:1 +when wall_seen then log.* +1\n", out)  # its when rule logged the wall it met
