"""The coppeliasim backend finds a robot's camera under each alias CoppeliaSim gives a new
vision sensor (``visionSensor`` from 4.8, ``Vision_sensor`` before), or where ``paths:`` says."""
from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import BEHAVIOURS

from labsim.backends.protocol import RobotRequest
from labsim.dsl.compile import compile_file
from labsim.runtime.cli.main import main
from labsim.runtime.serve import scene_tree
from labsim.runtime.serve.server import Server

pytestmark = pytest.mark.slow  # road-lab runs through a labsim serve in a thread


def _lab(tmp_path: Path, paths: str = "") -> Path:
    text = (BEHAVIOURS / "road_follow.yaml").read_text().replace("seconds: 30 ", "seconds: 0.2")
    if paths:
        text = text.replace("    model: pioneer_p3dx\n", f"    model: pioneer_p3dx\n    paths: {paths}\n", 1)
    lab = tmp_path / "road.yaml"
    lab.write_text(text)
    return lab


def _run(lab: Path, alias: str, monkeypatch: pytest.MonkeyPatch) -> int:
    monkeypatch.setattr(scene_tree, "camera_alias", lambda model, channel: alias)
    program = compile_file(lab)
    models = [group.model for group in program.robots for _ in range(group.count)]
    poses = [pose for _, pose in Server.robot_specs(program.world, len(models))]
    robots = [RobotRequest(f"r{i}", m, p, ()) for i, (m, p) in enumerate(zip(models, poses))]
    with Server(program.world, robots, port=0, dt_s=program.dt_s) as srv:
        return main(["run", str(lab), "-q", "--backend", "coppeliasim", "--port", str(srv.port)])


@pytest.mark.parametrize("alias", ["visionSensor", "Vision_sensor"])
def test_a_camera_is_found_under_either_alias(alias: str, tmp_path: Path, monkeypatch) -> None:
    assert _run(_lab(tmp_path), alias, monkeypatch) == 0


def test_paths_name_the_camera(tmp_path: Path, monkeypatch, capsys) -> None:
    assert _run(_lab(tmp_path, "{camera: ./frontCam}"), "frontCam", monkeypatch) == 0
    assert _run(_lab(tmp_path), "frontCam", monkeypatch) == 2
    err = capsys.readouterr().err
    assert "tried ./visionSensor, ./Vision_sensor, ./camera" in err and "paths: {camera: ...}" in err
