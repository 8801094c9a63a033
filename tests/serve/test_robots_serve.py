"""The e-puck, bumpers and ground sensors through `labsim serve`: the embedded backend's trace.

Through labsim serve every reading is the pymunk backend's float, carried exactly by CBOR, so
the traces are identical row for row. The e-puck's objects carry the names of CoppeliaSim's
stock e-puck (``/ePuck``, ``ePuck_leftJoint``, ``ePuck_proxSensor1..8``, ``ePuck_camera``);
its ground sensors, which the stock model lacks, labsim's ``ePuck_groundSensor1..3``.
"""
from __future__ import annotations

import dataclasses
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


def test_labsim_scene_builds_the_line_lab_and_a_run_there_gives_the_embedded_trace(
        empty: int, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The tape as a textured plane, the stock e-puck (``e-puck.ttm``) with its script removed,
    and its three ground sensors built as 1 x 1 vision sensors looking down: the stand-in reads
    them back where they were put, so the run is the embedded one, row for row."""
    from helpers import embedded_and_served

    from labsim.runtime.cli.main import main

    lab = tmp_path / "line.yaml"
    lab.write_text((BEHAVIOURS / "line_follow.yaml").read_text().replace("minutes: 2 ", "minutes: 0.1667"))
    assert main(["scene", str(lab), "--port", str(empty)]) == 0
    assert "1 e-puck (3 ground sensors added), their scripts removed" in capsys.readouterr().out
    ref, remote = embedded_and_served(lab, empty, tmp_path)
    assert remote == ref and len(ref) > 500


def test_labsim_scene_refuses_a_model_it_has_no_file_for(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from labsim.backends.coppeliasim.connection import Connection
    from labsim.backends.protocol import BackendError, RobotRequest
    from labsim.backends.scene.models import EPUCK
    from labsim.backends.scene.world import Pose, World
    from labsim.runtime.builder.scene import build

    other = RobotRequest("k", dataclasses.replace(EPUCK, name="khepera"), Pose(0.0, 0.0, 0.0), ())
    with pytest.raises(BackendError, match="builds Pioneer P3DX and e-puck robots only, and robot 'k'"):
        build(Connection("127.0.0.1", 1, 1.0), World("w", "", (0, 0, 1, 1)), [other], 0.05)


def test_an_epucks_ground_sensor_answers_as_the_1x1_vision_sensor_it_is() -> None:
    """CoppeliaSim's ground sensors are vision sensors of one pixel: the image calls answer
    that pixel (its grey level the intensity readVisionSensor gives), as they do a camera's."""
    import math

    from coppeliasim_zmqremoteapi_client import RemoteAPIClient
    from helpers import serve, stop

    proc, port = serve("-q", "--for", str(BEHAVIOURS / "line_follow.yaml"))
    try:
        sim = RemoteAPIClient(port=port).require("sim")
        g = sim.getObject("/ePuck/ePuck_groundSensor1")
        assert sim.getVisionSensorResolution(g) == [1, 1]
        sim.setStepping(True)
        sim.startSimulation()
        sim.step()
        result, packet = sim.readVisionSensor(g)
        level = round(packet[10] * 255)
        assert result == 0 and 0 < level <= 255
        assert sim.getVisionSensorImg(g) == (bytes([level] * 3), [1, 1])
        assert sim.getVisionSensorImg(g, 1) == (bytes([level]), [1, 1])
        assert sim.getVisionSensorCharImage(g) == (bytes([level] * 3), 1, 1)
        assert all(math.isclose(v, level / 255) for v in sim.getVisionSensorImage(g))
        assert sim.handleVisionSensor(g) == (result, packet)
        with pytest.raises(Exception, match="a ground sensor's depth is not served"):
            sim.getVisionSensorDepth(g)
        sim.stopSimulation()
    finally:
        stop(proc)
