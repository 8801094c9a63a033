"""What the command line says about the ray caster: ``labsim --version`` names it (and the live
view's tick hook), and the first ``labsim run`` of an install without the C kernel says so once
(backends/pymunk/ray_cast.py)."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from helpers import BEHAVIOURS

from labsim.backends.pymunk import ray_cast
from labsim.runtime.cli import parser
from labsim.runtime.cli.main import main
from labsim.runtime.view import peaks

NOTE = ("note: the ray sensors cast without labsim's C kernel (no C compiler at install): the same readings, "
        "slower; `labsim --version` says which caster runs")


def test_version_names_the_caster_and_the_view_hook_that_run() -> None:
    result = subprocess.run([sys.executable, "-m", "labsim", "--version"], capture_output=True, text=True)
    caster = "C kernel" if ray_cast.KERNEL == "c" else "Python"
    hook = "C" if peaks.KERNEL == "c" else "Python"
    assert result.returncode == 0
    assert result.stdout.endswith(f" (ray caster: {caster}; live view's tick hook: {hook})\n")


def _run(capsys: pytest.CaptureFixture[str], *extra: str) -> str:
    code = main(["run", str(BEHAVIOURS / "wall_follow.yaml"), "--set", "minutes=0.01", "--quiet", *extra])
    assert code == 0
    return capsys.readouterr().err


def test_the_first_run_without_the_kernel_says_so_once(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("LABSIM_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(parser, "ray_caster", lambda: "Python")
    assert _run(capsys).splitlines() == [NOTE]
    assert NOTE not in _run(capsys)
    assert NOTE not in _run(capsys)


def test_no_note_with_the_kernel_nor_without_a_cache_folder(capsys: pytest.CaptureFixture[str], tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("LABSIM_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(parser, "ray_caster", lambda: "C kernel")
    assert NOTE not in _run(capsys)
    (tmp_path / "cache").write_text("a file where the folder would be")
    monkeypatch.setattr(parser, "ray_caster", lambda: "Python")
    assert NOTE not in _run(capsys)  # nowhere to remember it: silent, not on every run
