"""The e-puck, bumpers and ground sensors through `labsim serve`: the embedded backend's trace.

Through labsim serve every reading is the pymunk backend's float, carried exactly by CBOR, so
the traces are identical row for row. The e-puck's objects carry the names of CoppeliaSim's
stock e-puck (``/ePuck``, ``ePuck_leftJoint``, ``ePuck_proxSensor1..8``, ``ePuck_camera``);
its ground sensors, which the stock model lacks, labsim's ``ePuck_groundSensor1..3``.
"""
from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("cbor2")
pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import BEHAVIOURS, serve_and_run

pytestmark = pytest.mark.slow  # labsim serve processes, and runs through them


def test_the_line_following_lab_gives_the_embedded_backends_trace(tmp_path: Path) -> None:
    """Ground sensors (sim.readVisionSensor) and the e-puck's joints, for 10 s of the lab."""
    lab = tmp_path / "line.yaml"
    lab.write_text((BEHAVIOURS / "line_follow.yaml").read_text().replace("minutes: 2 ", "minutes: 0.1667"))
    ref, remote = serve_and_run(tmp_path, lab, "--for", str(lab))
    assert remote == ref and len(ref) > 500
    assert {row.split(",")[2] for row in ref[1:]} == {"epuck"}


EPUCK_IR = """labsim: 1.2
world: walls_lab4
seed: 4
stop: time >= 8
robots:
  e: {model: epuck, at: [0, -7.2, -30]}
let:
  front: min(prox3, prox4)
  side: min(prox1, prox6)
  near: count([prox1, prox2, prox3, prox4, prox5, prox6] < 0.05)
rules:
  - if front < 0.04 then arc(-3, 3)
  - else move(6)
"""

BUMPERS = """labsim: 1.2
world: walls_lab4
seed: 4
stop: time >= 6
robots:
  p: {model: pioneer_p3dx, at: [6.0, 0, 0]}
let:
  pressed: bump_front_left or bump_front_right
  backing: bump_back_left or bump_back_right
rules:
  - if pressed then arc(-3, -2)
  - else move(6)
"""


@pytest.mark.parametrize("text", [EPUCK_IR, BUMPERS], ids=["epuck_ir", "bumpers"])
def test_ir_sensors_and_bumpers_give_the_embedded_backends_trace(tmp_path: Path, text: str) -> None:
    lab = tmp_path / "b.yaml"
    lab.write_text(text)
    ref, remote = serve_and_run(tmp_path, lab, "--for", str(lab))
    assert remote == ref
    columns = ref[0].split(",")
    values = [row.split(",") for row in ref[1:]]
    sensor = "front" if "front" in columns else "pressed"
    seen = {v[columns.index(sensor)] for v in values}
    assert len(seen) > 1, seen  # the sensor read something, not only its idle value


def test_labsim_scene_refuses_an_epuck_before_it_builds_anything(capsys: pytest.CaptureFixture[str]) -> None:
    from labsim.runtime.cli.main import main

    assert main(["scene", str(BEHAVIOURS / "line_follow.yaml"), "--port", "1"]) == 2
    err = capsys.readouterr().err
    assert "builds Pioneer P3DX robots only, and robot 'epuck' has model 'epuck'" in err and "Traceback" not in err
