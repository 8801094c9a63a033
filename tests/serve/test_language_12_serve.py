"""Language 1.2 means the same on both backends: one behaviour using every part of it, traced on
pymunk and through labsim serve (CoppeliaSim's remote API), gives identical rows."""
from __future__ import annotations

from pathlib import Path

from helpers import FIXTURES, serve_and_run


def test_every_part_of_language_12_traces_the_same_through_serve(tmp_path: Path) -> None:
    ref, remote = serve_and_run(tmp_path, FIXTURES / "language_12.yaml")
    assert len(ref) == 402  # the header, 400 ticks and the stopping tick
    assert remote == ref
    assert any("log: wall " in row for row in ref)  # the 'when' rule logged, and the rules below drove
