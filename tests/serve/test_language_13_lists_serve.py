"""Format 1.3's lists, per-robot starts and read-back mean the same on both backends: the worked examples
of docs/language.md ("Lists, starts and read-back"), traced on pymunk and through labsim serve
(CoppeliaSim's remote API), give identical rows, the read-back values included."""
from __future__ import annotations

from pathlib import Path

import pytest
from helpers import examples, serve_and_run


@pytest.mark.parametrize("name", ["patrol", "odometry"])
def test_the_worked_example_traces_the_same_through_serve(tmp_path: Path, name: str) -> None:
    lab = tmp_path / f"{name}.yaml"
    lab.write_text(examples()[name])
    ref, remote = serve_and_run(tmp_path, lab, "--for", str(lab))  # the scene the file needs
    assert remote == ref and len(ref) > 400
    header = ref[0].split(",")
    read = header.index("reached" if name == "patrol" else "ox")  # the estimate (its drift is 0 throughout)
    assert len({row.split(",")[read] for row in ref[1:]}) > 3  # it changed as the robot drove
