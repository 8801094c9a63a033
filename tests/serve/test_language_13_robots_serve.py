"""Language 1.3's other robots and messages mean the same on both backends: the worked examples of
docs/language.md ("Other robots and messages"), traced on pymunk and through labsim serve
(CoppeliaSim's remote API), give identical rows."""
from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("cbor2")
pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import examples, serve_and_run

pytestmark = pytest.mark.slow  # labsim serve processes, and runs through them


@pytest.mark.parametrize("name", ["leader_follower", "formation_of_three"])
def test_the_worked_example_traces_the_same_through_serve(tmp_path: Path, name: str) -> None:
    lab = tmp_path / f"{name}.yaml"
    lab.write_text(examples()[name].replace("stop: time >= 30", "stop: time >= 10"))
    ref, remote = serve_and_run(tmp_path, lab, "--for", str(lab))
    assert len(ref) == 1 + 201 * (3 if name == "formation_of_three" else 2)  # the header, 200 ticks and the stop
    assert remote == ref
    columns = ref[0].split(",")
    assert ("leader.x" in columns) if name == "leader_follower" else ("heard(pose_x)" in columns)
