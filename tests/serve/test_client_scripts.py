"""Client compatibility: scripts written as students and CoppeliaSim's own examples write them
(tests/serve/clients/, written for this suite) run unmodified against labsim serve, each a
process of its own with the real client; checked for what they print and where robots end.
Between them they make every call docs/coppeliasim.md's compatibility table lists as added for
student scripts (``CALLS`` below is checked against what they contain)."""
from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import PATIENCE_S

from labsim.backends.protocol import RobotRequest
from labsim.backends.scene.models import PIONEER_P3DX, Camera
from labsim.backends.scene.world import Pose, World, builtin_worlds
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import Report
from labsim.runtime.serve.server import Server

CLIENTS = Path(__file__).parent / "clients"
LAB = load_world(builtin_worlds()["walls_lab4"], Report())
CALLS = (
    "loadScene", "getStringParam", "createDummy", "addLog", "verbosity_scriptinfos", "getObjectQuaternion",
    "getObjectMatrix", "buildMatrix", "setObjectMatrix", "handleProximitySensor", "setObjectPosition",
    "getInt32Param", "setInt32Param", "setJointPosition", "setJointTargetForce", "getJointForce",
    "getObjectFloatParam", "jointfloatparam_velocity", "getVisionSensorCharImage", "readVisionSensor",
    "handleVisionSensor", "getVisionSensorDepth", "getObjectsInTree", "setShapeColor", "setObjectParent",
    "removeObject", "getSystemTime", "wait", "callScriptFunction", "getScript", "saveScene", "closeScene",
    "getObjectChild", "checkProximitySensor", "getVisionSensorImage", "setJointForce", "setInt32Signal",
    "getInt32Signal", "clearInt32Signal", "setFloatSignal", "getFloatSignal",
)


def run(script: str, server: Server) -> subprocess.CompletedProcess[str]:
    with server:
        return subprocess.run([sys.executable, str(CLIENTS / script), str(server.port)], capture_output=True,
                              text=True, timeout=PATIENCE_S)


def lines(done: subprocess.CompletedProcess[str]) -> list[str]:
    assert done.returncode == 0, done.stderr
    return done.stdout.splitlines()


def test_the_scripts_between_them_make_every_call() -> None:
    text = "".join(p.read_text() for p in CLIENTS.glob("*.py"))
    assert [c for c in CALLS if f"sim.{c}" not in text] == []


def test_the_simple_example_runs_free_then_stepped_and_cleans_up() -> None:
    assert lines(run("dummies_simple.py", Server(LAB, 1, port=0))) == [
        "Program started", "steps 20", "last dummy at [0.9, 0.45, 0.09]", "dummies left 0", "Program ended"]


def test_the_asyncio_example_with_requests_in_flight_ends() -> None:
    assert lines(run("dummies_asyncio.py", Server(LAB, 1, port=0))) == [
        "Program started", "last dummy at 0.19 0.38", "Program ended"]


def test_a_students_wall_follower_runs_and_ends_where_it_did() -> None:
    out = lines(run("wall_student.py", Server(LAB, 1, port=0)))
    assert out == [
        "CoppeliaSim 40600", "objects in the robot 23 sonars 16", "script -1",
        "no script: script function does not exist.",
        "at -4.121 -4.208 heading 1.275 quaternion w 0.804", "left wheel 4.0 rad/s force 0.0",
        "built matches True", "system time advanced True"]


def test_a_script_that_builds_its_own_scene_stops_at_its_wall() -> None:
    out = lines(run("builds_own_scene.py", Server(World("none", "", (0, 0, 1, 1)), 0, port=0, empty=True)))
    assert out == [
        "goal found True tag parent is the robot True", "shapes 3",
        "not saved: labsim serve: the stand-in writes no .tt",
        "robot to goal: -1.31 0.01", "collided 1", "scene closed 0"]  # its front on the wall's face, 1.9 m


def test_a_script_loading_a_ttt_scene_stops_there_with_the_clear_error() -> None:
    done = run("loads_ttt.py", Server(LAB, 1, port=0))
    assert done.returncode == 1 and done.stdout.splitlines() == ["Program started"]
    assert "labsim cannot read .ttt scenes; load the lab by name" in done.stderr
    assert "AttributeError" not in done.stderr


def test_a_camera_script_loads_the_road_lab_by_name_and_reads_its_camera_every_way() -> None:
    out = lines(run("road_camera.py", Server(LAB, 1, port=0)))
    assert out[:4] == ["scene road_loop", "4.8 name refused True", "before a step -1", "packet 15 mean intensity 0.44"]
    assert out[4] == "nearest floor 3.69 m; farthest 10.0 m"  # the floor through the camera's optics; the far plane
    assert out[5] == "robot at -11.37 -62.78"


def test_a_tutorial_script_with_relative_paths_float_handles_and_older_calls() -> None:
    """./x with no proxy, numpy float handles, getObjectChild, checkProximitySensor, signals."""
    camera = dataclasses.replace(PIONEER_P3DX, cameras=(Camera("camera", 32, 24, 60.0, 0.3, 30.0),))
    robots = [RobotRequest("pioneer", camera, Pose(-6.0, -6.2, -1.5708), ())]  # 1.3 m from the south wall
    result = run("pioneer_tutorial.py", Server(LAB, robots, port=0))
    assert result.returncode == 0, result.stderr
    out = lines(result)
    assert out[0] == "children 23 sonars 16"  # two motors, 16 sonars, the camera, four bumpers
    assert out[1:] == ["image 2304 values in [0, 1] True", "turning steps True state True", "cleared None",
                       "done at 0.0"]
