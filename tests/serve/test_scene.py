"""``labsim scene`` builds a lab's scene through the ZMQ remote API, here in ``labsim serve
--empty``; a run in the built scene gives the embedded backend's trace."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import BEHAVIOURS, embedded_and_served

from labsim.backends.scene.models import Camera
from labsim.backends.scene.world import World, builtin_worlds
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import Report
from labsim.runtime.builder.scene import camera_matrix
from labsim.runtime.cli.main import main
from labsim.runtime.serve.server import Server

pytestmark = pytest.mark.slow  # labs built in a labsim serve process, and run there


def test_the_wall_lab_built_by_labsim_scene_gives_the_embedded_trace(empty: int, tmp_path: Path, capsys) -> None:
    lab = BEHAVIOURS / "wall_follow.yaml"
    assert main(["scene", str(lab), "--port", str(empty)]) == 0
    out = capsys.readouterr().out
    assert "the floor, 6 walls and 1 block\n" in out and "1 Pioneer P3DX, their scripts removed" in out
    ref, remote = embedded_and_served(lab, empty, tmp_path, "--set", "minutes=1")
    assert remote == ref and len(ref) == 1 + 1201  # the header, 1,200 ticks and the stopping one (format 1.2)


def test_the_stand_in_rebuilds_the_world_it_was_given() -> None:
    """Walls (rounded ends), a box and the bounds come back exactly from the cuboids and plane."""
    from labsim.backends.coppeliasim.connection import Connection
    from labsim.runtime.builder.scene import build

    world = load_world(builtin_worlds()["walls_lab4"], Report())
    with Server(World("none", "", (0, 0, 1, 1)), 0, port=0, empty=True) as srv:
        build(Connection("127.0.0.1", srv.port, 5.0), world, [], 0.05)
        assert srv.editor is not None
        built = srv.editor.world()
        assert srv.dt_s == 0.05
    assert built.walls == world.walls and built.blocks == world.blocks and built.bounds == world.bounds


def test_the_road_lab_built_by_labsim_scene_gives_the_embedded_trace(empty: int, tmp_path: Path, capsys) -> None:
    """The ground as a textured plane, five Pioneers with rolled 128 x 128 vision sensors:
    the stand-in renders from the texture and the sensors' matrices, pixel for pixel."""
    lab = tmp_path / "road.yaml"
    lab.write_text((BEHAVIOURS / "road_follow.yaml").read_text().replace("seconds: 30 ", "seconds: 3"))
    assert main(["scene", str(lab), "--port", str(empty)]) == 0
    assert "5 Pioneer P3DX" in capsys.readouterr().out
    ref, remote = embedded_and_served(lab, empty, tmp_path)
    assert remote == ref and len(ref) == 1 + 5 * 60


def test_what_the_stand_in_cannot_build_is_a_clear_error(empty: int, tmp_path: Path, capsys) -> None:
    assert main(["scene", str(BEHAVIOURS / "wall_follow.yaml"), "--port", str(empty), "--save", "x.ttt"]) == 2
    assert "the stand-in writes no .ttt files" in capsys.readouterr().err
    assert main(["scene", str(BEHAVIOURS / "wall_follow.yaml"), "--port", str(empty), "--save", "x.txt"]) == 2
    assert "--save" in capsys.readouterr().err


def test_a_camera_matrix_looks_forward_and_down() -> None:
    m = camera_matrix(Camera("camera", 128, 128, 40, 3.0, 30, 0.2, 0.0), robot_z=0.1)
    z_axis = (m[2], m[6], m[10])
    assert z_axis == pytest.approx((math.cos(math.radians(30)), 0.0, -0.5))
    assert (m[3], m[7], m[11]) == pytest.approx((0.2, 0.0, 2.9))
    rolled = camera_matrix(Camera("camera", 128, 128, 40, 3.0, 30, 0.2, 90.0), robot_z=0.1)
    assert (rolled[1], rolled[5], rolled[9]) == pytest.approx((0.0, -1.0, 0.0))  # image up: the robot's right


def test_a_pioneer_loaded_with_its_script_is_logged_and_other_models_refused() -> None:
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    lines: list[str] = []
    with Server(World("none", "", (0, 0, 1, 1)), 0, port=0, empty=True, log=lines.append) as srv:
        client = RemoteAPIClient("127.0.0.1", srv.port)
        sim = client.require("sim")
        models = sim.getStringParam(sim.stringparam_resourcesdir) + "/models/robots/mobile/"
        with pytest.raises(Exception, match="loads only CoppeliaSim"):
            sim.loadModel(models + "KheperaIV.ttm")
        robot = sim.loadModel(models + "pioneer p3dx.ttm")
        assert sim.getObject("/PioneerP3DX") == robot
        # what the stock model has: two motors and 16 sonars; labsim's bumpers are not in it
        aliases = [sim.getObjectAlias(h) for h in sim.getObjectsInTree(robot, sim.handle_all, 1)]
        assert sorted(set(aliases)) == ["leftMotor", "rightMotor", "ultrasonicSensor"] and len(aliases) == 18
        assert sim.getObject("/PioneerP3DX/bumper_front_left", {"noError": True}) == -1
        assert sim.getScript(sim.scripttype_childscript, robot) >= 0  # the stock model's script
        sim.startSimulation()
        sim.stopSimulation()
        assert any("still has its script" in line for line in lines)
        client.socket.close(0)
        client.context.term()


def test_an_epucks_ground_sensors_are_the_vision_sensors_built_as_them() -> None:
    """Read back where their matrices put them, in the model's order; one looking up, or a
    camera of the builder's own on an e-puck (whose camera is its model's), is refused."""
    from labsim.backends.protocol import BackendError
    from labsim.backends.scene.models import EPUCK, PIONEER_P3DX
    from labsim.runtime.serve.built import Sensor, robot_model

    def down(alias: str, x: float, y: float, z_axis_z: float = -1.0) -> Sensor:
        return Sensor((1, 1), 0.17, 0, [1.0, 0.0, 0.0, x, 0.0, -1.0, 0.0, y, 0.0, 0.0, z_axis_z, -0.015], alias)

    built = robot_model(EPUCK, [down("ePuck_groundSensor3", 0.03, -0.01), down("ePuck_groundSensor1", 0.03, 0.01)])
    assert [(g.name, g.x_m, g.y_m) for g in built.ground_sensors] == [("ground1", 0.03, 0.01), ("ground3", 0.03, -0.01)]
    assert built.cameras == EPUCK.cameras
    assert robot_model(EPUCK, []).ground_sensors == ()  # the stock e-puck has none
    with pytest.raises(BackendError, match="ePuck_groundSensor2 is a 1 x 1 vision sensor looking down"):
        robot_model(EPUCK, [down("ePuck_groundSensor2", 0.03, 0.0, z_axis_z=1.0)])
    with pytest.raises(BackendError, match="keeps its model's camera"):
        robot_model(EPUCK, [down("Vision_sensor", 0.03, 0.0)])
    assert robot_model(PIONEER_P3DX, []) == PIONEER_P3DX


def test_a_sensor_labsim_scene_cannot_build_is_refused_before_anything_is_built() -> None:
    from labsim.backends.coppeliasim.connection import Connection
    from labsim.backends.protocol import BackendError, RobotRequest
    from labsim.backends.scene.models import PIONEER_P3DX
    from labsim.backends.scene.world import Pose
    from labsim.runtime.builder.scene import build

    world = load_world(builtin_worlds()["walls_lab4"], Report())
    robot = RobotRequest("pioneer", PIONEER_P3DX, Pose(0.0, 0.0, 0.0), ("sonar5", "bump_front_left"))
    with pytest.raises(BackendError) as refused:  # no server at port 1: nothing is sent
        build(Connection("127.0.0.1", 1, 1.0), world, [robot], 0.05)
    assert str(refused.value).startswith("labsim scene: robot 'pioneer' reads bump_front_left, and CoppeliaSim's "
                                         "Pioneer P3DX has no bumpers: labsim scene builds none.")


@pytest.mark.parametrize("lab, paths", [
    ("wall_follow.yaml", ["/wall", "/wall[1]", "/block", "/labsimFloor", "./wall[5]", ":/block"]),
    ("road_follow.yaml", ["/labsimGround"]),
], ids=["walls", "ground"])
def test_no_error_finds_the_built_shapes_as_the_plain_call_does(lab: str, paths: list[str], empty: int,
                                                                capsys) -> None:
    """In CoppeliaSim {noError: true} only silences the error: what exists keeps its handle."""
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    assert main(["scene", str(BEHAVIOURS / lab), "--port", str(empty)]) == 0
    sim = RemoteAPIClient(port=empty).require("sim")
    for path in paths:
        h = sim.getObject(path)
        assert h >= 0 and sim.getObject(path, {"noError": True}) == h, path
    assert sim.getObject("/wall[999]", {"noError": True}) == -1
    assert sim.getObject("/nothing", {"noError": True}) == -1


def test_an_epuck_built_by_labsim_scene_answers_its_names_from_before_4_3(empty: int) -> None:
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    assert main(["scene", str(BEHAVIOURS / "line_follow.yaml"), "--port", str(empty), "-q"]) == 0
    sim = RemoteAPIClient(port=empty).require("sim")
    assert sim.getObjectHandle("ePuck") == sim.getObject("/ePuck")
    for name in ("ePuck_leftJoint", "ePuck_proxSensor1", "ePuck_camera"):
        assert sim.getObjectHandle(name) == sim.getObject(f"/ePuck/{name}"), name
