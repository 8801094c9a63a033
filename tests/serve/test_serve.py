"""labsim serve: CoppeliaSim's ZMQ remote API (protocol 2) answered from the pymunk backend.

Most tests call ``Server.handle`` with CBOR bytes, as the socket would (fast, no ports); the
rest talk to a server in a thread, or a ``labsim serve`` process, with the real client
``coppeliasim_zmqremoteapi_client`` 2.0.4.

No test measures how long something takes: on a loaded machine anything can be slow.
``PATIENCE_S`` only keeps a broken test from hanging forever.
"""
from __future__ import annotations

import dataclasses
import math
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

cbor2 = pytest.importorskip("cbor2")
zmq = pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import PATH_ERROR, PATIENCE_S, serve  # noqa: E402

from labsim.backends.protocol import RobotRequest  # noqa: E402
from labsim.backends.scene.models import EPUCK, PIONEER_P3DX, Camera  # noqa: E402
from labsim.backends.scene.world import Pose, builtin_worlds  # noqa: E402
from labsim.backends.scene.world_file import load_world  # noqa: E402
from labsim.foundation.diagnostics import Report  # noqa: E402
from labsim.runtime.serve.server import Server  # noqa: E402

LAB = load_world(builtin_worlds()["walls_lab4"], Report())


class Wire:
    """A client speaking to Server.handle directly: CBOR maps in, CBOR maps out."""

    def __init__(self, server: Server, uuid: str = "student-1"):
        self.server, self.uuid, self.sent = server, uuid, 0

    def raw(self, func: str, *args: object) -> dict:
        req = {"func": func, "args": list(args), "argsL": len(args), "uuid": self.uuid}
        if self.sent == 0:
            req.update(ver=2, lang="python", timeout=600)
        self.sent += 1
        return cbor2.loads(self.server.handle(cbor2.dumps(req)))

    def __call__(self, func: str, *args: object) -> object:
        reply = self.raw(func, *args)
        while reply.get("func") == "_*wait*_":
            reply = self.raw("_*executed*_")
        assert "err" not in reply, reply["err"]
        ret = reply["ret"]
        return ret[0] if len(ret) == 1 else (tuple(ret) if ret else None)


@pytest.fixture
def wire() -> Wire:
    return Wire(Server(LAB, 2, port=0))


# --- the wire protocol --------------------------------------------------------------------------

def test_require_and_info_describe_the_sim_namespace(wire: Wire) -> None:
    assert wire.raw("zmqRemoteApi.require", "sim") == {"ret": []}
    (info,) = wire.raw("zmqRemoteApi.info", "sim")["ret"]
    for f in ("getObject", "readProximitySensor", "setJointTargetVelocity", "setStepping", "step",
              "getSimulationTime", "getVisionSensorImg", "getObjectPose", "checkCollision"):
        assert info[f] == {"func": {}}
    assert info["handle_world"] == {"const": -1} and info["handle_all"] == {"const": -2}
    assert info["simulation_stopped"] == {"const": 0}
    assert info["floatparam_simulation_time_step"] == {"const": 1}
    assert all(isinstance(v, dict) and v for v in info.values())  # the client refuses anything else


def test_errors_carry_coppeliasim_texts(wire: Wire) -> None:
    assert wire.raw("sim.noSuchThing") == {"err": "No such function: sim.noSuchThing"}
    assert wire.raw("zmqRemoteApi.require", "simIK")["err"].startswith("module 'simIK' not found")
    err = wire.raw("sim.getObject", "/PioneerP3DX[2]")["err"]
    assert err.startswith(PATH_ERROR) and "(in function 'sim.getObject'" in err
    assert "/PioneerP3DX[0], /PioneerP3DX[1]" in err  # labsim's hint: what the scene has
    assert wire.raw("sim.readProximitySensor", 9999)["err"].startswith("object does not exist.")
    left = wire("sim.getObject", "/PioneerP3DX[0]/leftMotor")
    assert wire.raw("sim.readProximitySensor", left)["err"].startswith("object is not a proximity sensor.")
    assert "not supported" in wire.raw("sim.executeScriptString", "print(1)")["err"]
    assert wire.raw("sim.addLog", 450, "hello") == {"ret": []}  # answered since scripts call it first
    # a protocol-1 client (no uuid) gets what CoppeliaSim answers it
    old = cbor2.loads(wire.server.handle(cbor2.dumps({"func": "sim.getObject", "args": ["/x"]})))
    assert old == {"success": False,
                   "error": "The client ZeroMQ remote API version does not match CoppeliaSim's version"}
    assert "err" in cbor2.loads(wire.server.handle(b"\xff\x00 not cbor"))


def test_an_epucks_names_from_before_4_3_are_answered_as_the_pioneers_are() -> None:
    """The stock e-puck's old names (V-REP scripts' simxGetObjectHandle('ePuck_leftJoint')),
    #0 for the second e-puck; sim.getObject wants the path, as for the Pioneer."""
    robots = [RobotRequest(f"e{k}", EPUCK, Pose(0.5 * k, 0.0, 0.0), ()) for k in range(2)]
    wire = Wire(Server(LAB, robots, port=0))
    for k, suffix in enumerate(("", "#0")):
        base = wire("sim.getObject", f"/ePuck[{k}]")
        assert wire("sim.getObjectHandle", f"ePuck{suffix}") == base
        for name in ("ePuck_leftJoint", "ePuck_rightJoint", "ePuck_proxSensor1", "ePuck_proxSensor8",
                     "ePuck_camera"):
            assert wire("sim.getObjectHandle", f"{name}{suffix}") == wire("sim.getObject", f"/ePuck[{k}]/{name}")
    err = wire.raw("sim.getObject", "ePuck_leftJoint")["err"]
    assert "before CoppeliaSim 4.3" in err and "'/ePuck[0]/ePuck_leftJoint'" in err
    assert "object does not exist" in wire.raw("sim.getObjectHandle", "ePuck#1")["err"]


def test_a_sonars_matrix_maps_its_detected_point_to_where_it_met_the_wall(wire: Wire) -> None:
    """readProximitySensor's point is in the sensor's frame (z along the beam, x to its left,
    y up, as the stock Pioneer's sensors): the sensor's orientation is that frame, so a mapping
    script's M * point lands on the wall, at the sonar's height."""
    robot = wire("sim.getObject", "/PioneerP3DX[0]")
    wire("sim.setObjectPosition", robot, [6.8, 0.0, 0.0975], -1)
    wire("sim.setObjectOrientation", robot, [0.0, 0.0, 0.0], -1)
    wire("sim.setStepping", True)
    wire("sim.startSimulation")
    wire("sim.step")
    hits = 0
    for k in range(16):
        s = wire("sim.getObject", f"/PioneerP3DX[0]/ultrasonicSensor[{k}]")
        res, d, pt, _, _ = wire("sim.readProximitySensor", s)
        m = np.array(wire("sim.getObjectMatrix", s, -1)).reshape(3, 4)
        assert np.allclose(m[:, :3].T @ m[:, :3], np.eye(3)) and m[2, 1] == pytest.approx(1.0)  # y up
        if res != 1:
            continue
        hits += 1
        world = m[:, :3] @ np.array(pt) + m[:, 3]
        assert np.linalg.norm(world - m[:, 3]) == pytest.approx(d)
        assert world[2] == pytest.approx(m[2, 3], abs=1e-12)  # at the sonar's height, not above the robot
        if k in (3, 4):  # the two front sonars face the wall at x = 7.45
            assert world[0] == pytest.approx(7.45, abs=1e-6)
        # the pose calls agree with the matrix; the robot seen from the sensor is behind it (-z)
        pose = wire("sim.getObjectPose", s, -1)
        assert np.allclose(np.array(wire("sim.buildMatrix", pose[:3], wire("sim.getObjectOrientation", s, -1)))
                           .reshape(3, 4), m)
        assert wire("sim.getObjectPosition", robot, s)[2] < 0
    assert hits >= 2
    wire("sim.stopSimulation")


def test_object_paths_follow_getobject_rules(wire: Wire) -> None:
    h = {p: wire("sim.getObject", p) for p in (
        "/PioneerP3DX[0]", "/PioneerP3DX[1]", "/PioneerP3DX[1]/leftMotor", "/PioneerP3DX[0]/ultrasonicSensor[4]")}
    assert all(isinstance(v, int) and v >= 0 for v in h.values()) and len(set(h.values())) == 4
    assert wire("sim.getObject", "/PioneerP3DX") == h["/PioneerP3DX[0]"]  # first at that level
    assert wire("sim.getObject", "/PioneerP3DX{1}") == h["/PioneerP3DX[1]"]  # n-th in the scene
    assert wire("sim.getObject", "/PioneerP3DX", {"index": 1}) == h["/PioneerP3DX[1]"]
    assert wire("sim.getObject", "/Pioneer*[1]") == h["/PioneerP3DX[1]"]  # wildcards
    robot1 = h["/PioneerP3DX[1]"]
    assert wire("sim.getObject", "./leftMotor", {"proxy": robot1}) == h["/PioneerP3DX[1]/leftMotor"]
    assert wire("sim.getObject", ".", {"proxy": robot1}) == robot1
    sonar5 = h["/PioneerP3DX[0]/ultrasonicSensor[4]"]
    assert wire("sim.getObject", "./ultrasonicSensor", {"proxy": h["/PioneerP3DX[0]"], "index": 4}) == sonar5
    assert wire("sim.getObject", "/ultrasonicSensor[4]") == sonar5  # descends when not at the top
    # pre-4.3 names: the deprecated sim.getObjectHandle takes them; sim.getObject wants a path
    assert wire("sim.getObjectHandle", "Pioneer_p3dx_ultrasonicSensor5") == sonar5
    assert wire("sim.getObjectHandle", "Pioneer_p3dx_leftMotor#0") == h["/PioneerP3DX[1]/leftMotor"]
    err = wire.raw("sim.getObject", "Pioneer_p3dx_leftMotor#0")["err"]
    assert "object does not exist" in err and "before CoppeliaSim 4.3" in err and "/PioneerP3DX[1]/leftMotor" in err
    assert wire("sim.getObject", "Pioneer_p3dx_leftMotor#0", {"noError": True}) == -1
    assert wire("sim.getObject", "/PioneerP3DX[7]", {"noError": True}) == -1
    # a remote client has no emitting object: ./x and :/x search from the top, as /x does
    assert wire("sim.getObject", "./leftMotor") == wire("sim.getObject", "/leftMotor") == \
        wire("sim.getObject", ":/leftMotor") == wire("sim.getObject", "/PioneerP3DX[0]/leftMotor")
    assert wire("sim.getObject", ".", {"noError": True}) == wire("sim.getObject", "..", {"noError": True}) == -1
    assert wire("sim.getObjectAlias", sonar5) == "ultrasonicSensor"
    assert wire("sim.getObjectAlias", sonar5, 0) == "ultrasonicSensor[4]"
    assert wire("sim.getObjectAlias", sonar5, 2) == "/PioneerP3DX[0]/ultrasonicSensor[4]"
    assert wire("sim.getObjectParent", sonar5) == h["/PioneerP3DX[0]"]


def test_wait_takes_its_steps_at_once_within_its_limits(wire: Wire) -> None:
    """sim.wait's limits as docs/coppeliasim.md gives them: 60 s of simulation time a call,
    the overshoot returned; real time at most 2 s a call, the time not waited returned."""
    assert wire("sim.wait", 0.5) == 0.0  # stopped: nothing to wait for
    wire("sim.setStepping", True)
    wire("sim.startSimulation")
    assert wire("sim.wait", 0.12) == pytest.approx(0.12 - 0.15)
    assert wire("sim.getSimulationTime") == pytest.approx(0.15)
    assert "sim.wait takes at most 60 s of simulation time a call" in wire.raw("sim.wait", 61.0)["err"]
    assert wire("sim.wait", 2.25, False) == pytest.approx(0.25)  # 2 s slept, 0.25 s left to wait
    assert wire("sim.getSimulationTime") == pytest.approx(0.15)
    wire("sim.stopSimulation")


def test_step_waits_then_advances_one_step(wire: Wire) -> None:
    assert wire("sim.getSimulationTimeStep") == 0.05 == wire("sim.getFloatParam", 1)
    assert wire("sim.setStepping", True) == 0 and wire("sim.setStepping", True) == 1
    wire("sim.setStepping", False)
    robot = wire("sim.getObject", "/PioneerP3DX[1]")
    wire("sim.setObjectPose", robot, [-2.0, 0.8, 0.0, 0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)])
    wire("sim.startSimulation")
    assert wire("sim.getSimulationState") == 0x11
    sonar5 = wire("sim.getObject", "/PioneerP3DX[1]/ultrasonicSensor[4]")
    # sensors are handled at the end of a step: before the first one, nothing is detected
    assert wire("sim.readProximitySensor", sonar5) == (0, 0.0, [0.0, 0.0, 0.0], -1, [0.0, 0.0, 0.0])
    assert wire.raw("sim.step") == {"func": "_*wait*_", "args": []}
    assert wire.raw("_*executed*_") == {"ret": []}
    assert wire("sim.getSimulationTime") == pytest.approx(0.05)
    res, dist, point, obj, normal = wire("sim.readProximitySensor", sonar5)
    # robot 1 faces the 8 m wall squarely, 0.65 m away; sonar5 looks 10 degrees right of that,
    # and the ray of its cone 7.5 degrees left of its axis (nearest the wall's normal) finds
    # the wall: the detected point, in the sensor's frame (z its axis, x its left), lies there
    a = math.radians(7.5)
    assert res == 1 and 0 < dist < 1
    assert point == pytest.approx([dist * math.sin(a), 0.0, dist * math.cos(a)], abs=1e-12)
    wire("sim.stopSimulation")
    assert wire("sim.getSimulationState") == 0 and wire("sim.getSimulationTime") == 0.0
    assert wire.raw("sim.step") == {"func": "_*wait*_", "args": []}  # stopped: one wait, no step
    wire.raw("_*executed*_")
    assert wire("sim.getSimulationTime") == 0.0


def test_wheels_drive_the_robot_and_turn_their_joints(wire: Wire) -> None:
    robot = wire("sim.getObject", "/PioneerP3DX[0]")
    left, right = (wire("sim.getObject", f"./{m}", {"proxy": robot}) for m in ("leftMotor", "rightMotor"))
    wire("sim.setObjectPosition", robot, [0.0, -6.0, 0.3], -1)  # 4.5+ order: (h, position, frame)
    wire("sim.setObjectOrientation", robot, -1, [0.0, 0.0, 0.0])  # pre-4.5 order: (h, frame, angles)
    assert wire("sim.getObjectPosition", robot, -1)[:2] == [0.0, -6.0]
    wire("sim.setStepping", True)
    wire("sim.startSimulation")
    assert "stopped" in wire.raw("sim.setObjectPosition", robot, [1.0, 1.0, 0.0], -1)["err"]
    wire("sim.setJointTargetVelocity", left, 4.0)
    wire("sim.setJointTargetVelocity", right, 4.0)
    for _ in range(20):
        wire("sim.step")
    x, y, _ = wire("sim.getObjectPosition", robot, -1)
    assert x == pytest.approx(4.0 * PIONEER_P3DX.wheel_radius_m * 1.0, rel=0.01) and y == pytest.approx(-6.0)
    assert wire("sim.getObjectOrientation", robot, -1) == [0.0, 0.0, 0.0]
    assert wire("sim.getJointVelocity", left) == pytest.approx(4.0)
    assert wire("sim.getJointPosition", right) == pytest.approx(math.remainder(4.0, 2 * math.pi))
    pose = wire("sim.getObjectPose", robot, -1)
    assert len(pose) == 7 and pose[6] == pytest.approx(1.0)
    assert wire("sim.checkCollision", robot, -2) == (0, [-1, -1])
    assert wire.raw("sim.setJointTargetPosition", left, 1.0) == {"ret": []}  # kept and ignored, as CoppeliaSim
    assert wire("sim.getJointTargetPosition", left) == 1.0 and wire("sim.getJointVelocity", left) == pytest.approx(4.0)
    # a sonar's pose is its mount on the robot, relative to the robot
    sonar1 = wire("sim.getObject", "./ultrasonicSensor[0]", {"proxy": robot})
    assert wire("sim.getObjectPosition", sonar1, robot)[:2] == pytest.approx([0.1067, 0.1382])
    wire("sim.stopSimulation")
    assert wire("sim.getObjectPosition", robot, -1)[:2] == [0.0, -6.0]  # the scene is restored


def test_camera_images_are_rgb_bottom_row_first() -> None:
    world = load_world(builtin_worlds()["road_compact"], Report())
    cam = Camera("camera", 32, 24, 60.0, 0.3, 45.0)
    model = dataclasses.replace(PIONEER_P3DX, cameras=(cam,))
    pose = Pose(-6.0, -14.6, 1.0)  # on the road near its left edge, looking off it to the left
    wire = Wire(Server(world, [RobotRequest("r", model, pose, ())], port=0))
    v = wire("sim.getObject", "/PioneerP3DX[0]/Vision_sensor")
    assert wire("sim.getVisionSensorResolution", v) == [32, 24]
    wire("sim.setStepping", True)
    wire("sim.startSimulation")
    wire("sim.step")
    img, res = wire("sim.getVisionSensorImg", v)
    assert res == [32, 24] and isinstance(img, bytes) and len(img) == 32 * 24 * 3
    from labsim.backends.pymunk.backend import PymunkBackend

    direct = PymunkBackend()
    direct.open(world, [RobotRequest("r", model, pose, ("camera",))], 0.05, 0)
    direct.step()
    (expected,), = direct.sense()
    direct.close()
    # CoppeliaSim's order, which is labsim's: bottom row first, so the same bytes, no flip
    assert img == np.ascontiguousarray(expected).tobytes()
    road = np.frombuffer(img, np.uint8).reshape(24, 32, 3).sum(axis=2) < 300
    assert road[0].all() and road[-1].sum() < 8  # the near edge all road; the far one leaves it
    grey, _ = wire("sim.getVisionSensorImg", v, 1)
    assert len(grey) == 32 * 24
    # as CoppeliaSim: option 3 is grey and alpha, two bytes a pixel; a portion's reply still
    # carries the sensor's resolution
    grey_alpha, _ = wire("sim.getVisionSensorImg", v, 3)
    assert len(grey_alpha) == 32 * 24 * 2 and grey_alpha[1::2] == b"\xff" * (32 * 24)
    part, res = wire("sim.getVisionSensorImg", v, 0, 0.0, [4, 2], [8, 6])
    assert len(part) == 8 * 6 * 3 and res == [32, 24]
    # a part outside the image is CoppeliaSim's "wrong position/size parameters", from every
    # image call alike (inf and nan included); a part that is not numbers, the type error
    inf, nan = float("inf"), float("nan")
    for pos, size in (([0, 0], [inf, 4]), ([inf, 0], [1, 1]), ([nan, 0], [1, 1]), ([0, 0], [-1, 4]),
                      ([0, 0], [33, 1]), ([31, 0], [2, 1]), ([0, 0], [1e300, 1])):
        for call in (("sim.getVisionSensorImg", v, 0, 0.0, pos, size), ("sim.getVisionSensorDepth", v, 0, pos, size),
                     ("sim.getVisionSensorImage", v, *pos, *size), ("sim.getVisionSensorCharImage", v, *pos, *size)):
            assert wire.raw(*call)["err"].startswith("wrong position/size parameters."), call
    for call in (("sim.getVisionSensorImg", v, 0, 0.0, [0, 0], ["a", 1]),
                 ("sim.getVisionSensorDepth", v, 0, [0], [1, 1]), ("sim.getVisionSensorImage", v, 0, 0, "a", 1)):
        assert wire.raw(*call)["err"].startswith("one of the function's argument type is not correct."), call


def test_serve_camera_sees_the_robot_ahead_as_the_backend_does() -> None:
    world = load_world(builtin_worlds()["road_compact"], Report())
    cam = Camera("camera", 64, 48, 50.0, 1.0, 15.0)
    model = dataclasses.replace(PIONEER_P3DX, cameras=(cam,))
    poses = [Pose(-6.0, -15.0, 0.0), Pose(-3.0, -15.2, 0.4)]  # the second 3 m ahead of the first
    wire = Wire(Server(world, [RobotRequest(f"r{i}", model, p, ()) for i, p in enumerate(poses)], port=0))
    v = wire("sim.getObject", "/PioneerP3DX[0]/Vision_sensor")
    wire("sim.setStepping", True)
    wire("sim.startSimulation")
    wire("sim.step")
    img, _ = wire("sim.getVisionSensorImg", v)
    from labsim.backends.pymunk.backend import PymunkBackend

    direct = PymunkBackend()
    direct.open(world, [RobotRequest(f"r{i}", model, p, ("camera",)) for i, p in enumerate(poses)], 0.05, 0)
    direct.step()
    expected = direct.sense()[0][0]
    direct.close()
    assert img == np.ascontiguousarray(expected).tobytes()
    seen = np.frombuffer(img, np.uint8).reshape(48, 64, 3)
    assert ((seen[..., 0] > 120) & (seen[..., 1] < 60)).sum() > 20  # the red robot ahead


def test_mechanism_joints_by_alias() -> None:
    crane = load_world(builtin_worlds()["crane"], Report())
    with pytest.raises(Exception, match="mechanism"):
        Server(crane, 1, port=0)
    wire = Wire(Server(crane, 0, port=0))
    crab = wire("sim.getObject", "/Crab_Actuator")
    sensor = wire("sim.getObject", "/Force_sensor")
    load = wire("sim.getObject", "/Load")
    assert wire("sim.getJointPosition", crab) == pytest.approx(3.0)  # the crab starts 3 m from the tower
    assert "fixed" not in str(wire.raw("sim.getObject", "/guide_mount"))  # fixed joints are not objects
    wire("sim.setStepping", True)
    wire("sim.startSimulation")
    assert wire("sim.readForceSensor", sensor)[0] == 0  # not measured before a step
    wire("sim.setJointTargetVelocity", crab, 0.5)
    for _ in range(20):
        wire("sim.step")
    assert wire("sim.getJointPosition", crab) > 3.1 and wire("sim.getJointVelocity", crab) > 0.1
    res, force, torque = wire("sim.readForceSensor", sensor)
    assert res == 1 and force[2] == pytest.approx(200 * 9.81, rel=0.2)
    x, y, z = wire("sim.getObjectPosition", load, -1)
    assert y == 0.0 and z == pytest.approx(0.3, abs=0.05)  # the load stands on the floor
    wire("sim.setJointTargetPosition", crab, 2.0)
    assert wire("sim.getJointTargetPosition", crab) == 2.0
    for _ in range(60):
        wire("sim.step")
    assert wire("sim.getJointPosition", crab) < 3.0  # on its way back towards the tower


# --- over the network, with the real client ------------------------------------------------------

STUDENT_SCRIPT = '''\
"""Lab 2: Braitenberg obstacle avoidance for two Pioneers, CoppeliaSim ZMQ remote API."""
import math
import sys

from coppeliasim_zmqremoteapi_client import RemoteAPIClient


class Pioneer:
    NO_DETECTION, MAX_DETECTION, V0 = 0.5, 0.2, 2.0
    BRAITENBERG_L = [-0.2, -0.4, -0.6, -0.8, -1, -1.2, -1.4, -1.6] + [0.0] * 8
    BRAITENBERG_R = [-1.6, -1.4, -1.2, -1, -0.8, -0.6, -0.4, -0.2] + [0.0] * 8

    def __init__(self, sim, i):
        self.sim = sim
        self.body = sim.getObject(f"/PioneerP3DX[{i}]")
        self.left = sim.getObject(f"/PioneerP3DX[{i}]/leftMotor")
        self.right = sim.getObject(f"/PioneerP3DX[{i}]/rightMotor")
        self.sonars = [sim.getObject(f"/PioneerP3DX[{i}]/ultrasonicSensor[{k}]") for k in range(16)]

    def update(self):
        detect = [0.0] * 16
        for k, sonar in enumerate(self.sonars):
            res, dist, point, obj, normal = self.sim.readProximitySensor(sonar)
            if res > 0 and dist < self.NO_DETECTION:
                dist = max(dist, self.MAX_DETECTION)
                detect[k] = 1 - (dist - self.MAX_DETECTION) / (self.NO_DETECTION - self.MAX_DETECTION)
        v_left, v_right = self.V0, self.V0
        for k in range(16):
            v_left += self.BRAITENBERG_L[k] * detect[k]
            v_right += self.BRAITENBERG_R[k] * detect[k]
        self.sim.setJointTargetVelocity(self.left, v_left)
        self.sim.setJointTargetVelocity(self.right, v_right)


client = RemoteAPIClient("localhost", int(sys.argv[1]) if len(sys.argv) > 1 else 23000)
sim = client.require("sim")
robots = [Pioneer(sim, i) for i in range(2)]
start = [sim.getObjectPosition(r.body, sim.handle_world) for r in robots]
sim.setStepping(True)
sim.startSimulation()
while sim.getSimulationTime() < 5:
    for r in robots:
        r.update()
    sim.step()
end = [sim.getObjectPosition(r.body, sim.handle_world) for r in robots]
t = sim.getSimulationTime()
sim.stopSimulation()
for a, b in zip(start, end):
    print(f"moved {math.dist(a[:2], b[:2]):.3f}")
print(f"done at {t:.2f} s")
'''


@pytest.mark.slow
def test_a_student_script_runs_unmodified(tmp_path: Path) -> None:
    script = tmp_path / "lab2.py"
    script.write_text(STUDENT_SCRIPT)
    with Server(LAB, 2, port=0) as server:
        out = subprocess.run([sys.executable, str(script), str(server.port)], capture_output=True,
                             text=True, timeout=2 * PATIENCE_S)
        assert out.returncode == 0, out.stderr
        again = subprocess.run([sys.executable, str(script), str(server.port)], capture_output=True,
                               text=True, timeout=2 * PATIENCE_S)  # clients one after another
    lines = out.stdout.split("\n")
    assert lines[-2] == "done at 5.00 s"
    for line in lines[:2]:  # 2 rad/s for 5 s is 0.98 m; the sonars may turn them a little
        assert 0.6 < float(line.split()[1]) < 1.0, out.stdout
    assert again.stdout == out.stdout  # the same scene, the same run


@pytest.mark.slow
def test_free_running_follows_the_clock_and_survives_a_vanished_client() -> None:
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    with Server(LAB, 1, port=0, takeover_s=0.2) as server:
        main = sys.modules["__main__"].__dict__
        had = dict(main)
        a = RemoteAPIClient("127.0.0.1", server.port)
        a.socket.setsockopt(zmq.RCVTIMEO, int(PATIENCE_S * 1000))
        a.socket.setsockopt(zmq.LINGER, 0)
        sim = a.require("sim")
        began = time.perf_counter()
        sim.startSimulation()  # no stepping: it runs on its own, following the clock
        t = sim.getSimulationTime()
        while t == 0.0 and time.perf_counter() - began < PATIENCE_S:
            time.sleep(0.01)
            t = sim.getSimulationTime()
        # it advances, and never ahead of real time (a slow machine only holds it back)
        assert 0.0 < t <= time.perf_counter() - began, t
        sim.stopSimulation()
        sim.setStepping(True)
        sim.startSimulation()
        sim.step()
        time.sleep(0.1)
        assert sim.getSimulationTime() == pytest.approx(0.05)  # stepping: it waits for sim.step, however long
        # A client that asks and vanishes without reading the answer...
        ctx = zmq.Context()
        ghost = ctx.socket(zmq.REQ)
        ghost.setsockopt(zmq.LINGER, 0)
        ghost.connect(f"tcp://127.0.0.1:{server.port}")
        ghost.send(cbor2.dumps({"func": "sim.getSimulationTime", "args": [], "uuid": "ghost"}))
        ghost.close()
        ctx.term()
        # ... and client a, stepping, goes silent (longer than takeover_s): the next client
        # finds a fresh scene.
        time.sleep(0.3)
        b = RemoteAPIClient("127.0.0.1", server.port)
        b.socket.setsockopt(zmq.RCVTIMEO, int(PATIENCE_S * 1000))
        b.socket.setsockopt(zmq.LINGER, 0)
        sim_b = b.require("sim")
        assert sim_b.getSimulationState() == sim_b.simulation_stopped
        for c in (a, b):
            c.socket.close(0)
            c.context.term()
        main.pop("require", None)  # the client puts its require() into __main__
        main.update(had)
        assert server.messages > 10


@pytest.mark.slow
def test_labsim_serve_stops_cleanly_on_ctrl_c() -> None:
    proc, port = serve("--robots", "2", "-q")
    try:
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=PATIENCE_S)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0 and "stopped" in out
    # the port is free again
    ctx = zmq.Context()
    sock = ctx.socket(zmq.REP)
    sock.setsockopt(zmq.LINGER, 0)
    sock.bind(f"tcp://127.0.0.1:{port}")
    sock.close()
    ctx.term()


@pytest.mark.slow
def test_labsim_serve_refuses_a_busy_port_and_an_unknown_world() -> None:
    with Server(LAB, 1, port=0) as server:
        out = subprocess.run([sys.executable, "-m", "labsim", "serve", "--port", str(server.port)],
                             capture_output=True, text=True, timeout=PATIENCE_S)
    assert out.returncode == 2 and "already uses it" in out.stderr
    out = subprocess.run([sys.executable, "-m", "labsim", "serve", "walls_lab5", "--port", "0"],
                         capture_output=True, text=True, timeout=PATIENCE_S)
    assert out.returncode == 2 and "did you mean 'walls_lab4'" in out.stderr


def test_student_script_text_is_plain_coppeliasim() -> None:
    """The script uses nothing of labsim: it would run on CoppeliaSim as it is."""
    assert "labsim" not in STUDENT_SCRIPT.split('"""', 2)[2]
    compile(textwrap.dedent(STUDENT_SCRIPT), "lab2.py", "exec")


@pytest.mark.slow
def test_more_robots_than_a_world_has_room_for_is_a_clear_error() -> None:
    proc = subprocess.run([sys.executable, "-m", "labsim", "serve", "walls_lab4", "--robots", "400", "-q",
                           "--port", "0"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "world 'walls_lab4' has no free place for robot" in proc.stderr and "ask for fewer" in proc.stderr


# --- what the stand-in keeps for a client, and what it decodes, is bounded --------------------

def test_signals_are_bounded_by_count_and_bytes(wire: Wire, monkeypatch: pytest.MonkeyPatch) -> None:
    from labsim.runtime.serve import sim_signals

    for k in range(sim_signals.MAX_SIGNALS):
        wire("sim.setInt32Signal", f"s{k}", k)
    err = wire.raw("sim.setFloatSignal", "one more", 1.5)["err"]
    assert err == ("labsim serve: 10000 signals are set, the most it keeps; clear some (sim.clearFloatSignal) "
                   "before setting 'one more' (in function 'sim.setFloatSignal')")
    wire("sim.setInt32Signal", "s7", -7)  # replacing one is no new signal
    assert wire("sim.getInt32Signal", "s7") == -7
    wire("sim.clearInt32Signal", "s0")
    wire("sim.setFloatSignal", "one more", 1.5)
    assert wire("sim.getFloatSignal", "one more") == 1.5 and wire("sim.getInt32Signal", "one more") is None
    for k in range(1, sim_signals.MAX_SIGNALS):
        wire("sim.clearInt32Signal", f"s{k}")
    monkeypatch.setattr(sim_signals, "MAX_SIGNALS_BYTES", 1000)
    wire("sim.setStringSignal", "a", b"x" * 900)
    err = wire.raw("sim.setStringSignal", "b", b"x" * 200)["err"]
    assert "the signals set would hold more than 0 MiB; clear some (sim.clearStringSignal) before setting 'b'" in err
    wire("sim.setStringSignal", "a", b"x" * 10)  # a smaller value in its place frees the rest
    wire("sim.setStringSignal", "b", b"x" * 200)
    assert wire("sim.getStringSignal", "b") == b"x" * 200


def test_int32_and_float_signals_take_numbers_as_coppeliasim_does(wire: Wire) -> None:
    wire("sim.setInt32Signal", "state", 4.0)  # a numpy float, as a script's array holds it
    assert wire("sim.getInt32Signal", "state") == 4 and isinstance(wire("sim.getInt32Signal", "state"), int)
    wire("sim.setInt32Signal", "state", 4.7)  # cast as CoppeliaSim casts a number to an int
    assert wire("sim.getInt32Signal", "state") == 4
    wire("sim.setFloatSignal", "speed", 2.0)
    assert wire("sim.getFloatSignal", "speed") == 2.0 and isinstance(wire("sim.getFloatSignal", "speed"), float)
    assert wire("sim.getStringSignal", "state") is None  # each kind its own names
    wire("sim.clearFloatSignal", "speed")
    assert wire("sim.getFloatSignal", "speed") is None


def test_unpacking_decodes_only_what_is_asked(wire: Wire) -> None:
    data = wire("sim.packDoubleTable", [float(k) for k in range(10)])
    assert wire("sim.unpackDoubleTable", data, 2, 3) == [2.0, 3.0, 4.0]
    assert wire("sim.unpackDoubleTable", data, 8, 100) == [8.0, 9.0]
    assert wire("sim.unpackDoubleTable", data, 0, 0, 16) == [2.0 + k for k in range(8)]
    big = b"\0" * (8 * (1 << 20) + 8)
    assert "an unpack returns at most 1048576 values; this one would return 1048577" in \
        wire.raw("sim.unpackDoubleTable", big)["err"]
    assert len(wire("sim.unpackDoubleTable", big, 1)) == 1 << 20  # taken in parts, it is answered


def test_numbers_are_handles_wherever_coppeliasim_takes_them(wire: Wire) -> None:
    motor = wire("sim.getObject", "/PioneerP3DX[0]/leftMotor")
    handles = np.zeros(2)
    handles[0] = motor
    assert wire("sim.getObjectAlias", handles[0]) == "leftMotor"  # 4.0 from an array
    assert wire("sim.getObjectAlias", float(motor) + 0.7) == "leftMotor"  # cast, as CoppeliaSim casts it
    wire("sim.setJointTargetVelocity", handles[0], 2.0)
    assert wire("sim.getJointTargetVelocity", motor) == 2.0
    robot = wire("sim.getObject", "/PioneerP3DX[1]")
    assert wire("sim.getObject", "./leftMotor", {"proxy": float(robot)}) == \
        wire("sim.getObject", "/PioneerP3DX[1]/leftMotor")
    assert wire("sim.getObjectChild", float(robot), 0.0) == wire("sim.getObject", "/PioneerP3DX[1]/leftMotor")
    assert wire("sim.getObjectChild", robot, 1000) == -1
    assert wire.raw("sim.getObjectAlias", "4")["err"].startswith("one of the function's argument type is not correct")
    assert wire.raw("sim.getObjectAlias", True)["err"].startswith("one of the function's argument type")


def test_check_proximity_sensor_and_the_older_image_call() -> None:
    camera = dataclasses.replace(PIONEER_P3DX, cameras=(Camera("camera", 8, 6, 60.0, 0.3, 30.0),))
    srv = Server(LAB, [RobotRequest("p", camera, Pose(-6.0, -6.9, -1.5708), ())], port=0)
    wire = Wire(srv)
    sonar5 = wire("sim.getObject", "/PioneerP3DX/ultrasonicSensor[4]")
    camera_h = wire("sim.getObject", "/PioneerP3DX/Vision_sensor")
    wire("sim.setStepping", True)
    wire("sim.startSimulation")
    wire("sim.step")
    result, distance, point = wire("sim.checkProximitySensor", sonar5, -2)  # sim.handle_all
    assert (result, distance, point) == wire("sim.readProximitySensor", sonar5)[:3] and result == 1
    assert 0.3 < distance < 0.45
    assert "answers for sim.handle_all only" in wire.raw("sim.checkProximitySensor", sonar5, 5)["err"]
    img, _ = wire("sim.getVisionSensorImg", camera_h)
    floats = wire("sim.getVisionSensorImage", camera_h)
    assert floats == [b / 255.0 for b in img] and len(floats) == 8 * 6 * 3
    assert wire("sim.getVisionSensorImage", camera_h, 0, 0, 0, 0, 1) == img
    wire("sim.setJointForce", wire("sim.getObject", "/PioneerP3DX/leftMotor"), 20.0)
    assert "Vision_sensor" in wire.raw("sim.getObject", "/PioneerP3DX/visionSensor")["err"]
    assert wire.raw("sim.setSimulationTimeStep", 0.01)["err"] == "No such function: sim.setSimulationTimeStep"


def test_a_built_shape_answers_to_one_handle() -> None:
    from labsim.runtime.serve.scene_edit import EMPTY

    wire = Wire(Server(EMPTY, 0, port=0, empty=True))
    box = wire("sim.createPrimitiveShape", 3, [0.5, 0.5, 0.5], 0)
    wire("sim.setObjectAlias", box, "box")  # a mechanism's body
    assert wire("sim.getObject", "/box") == box and wire("sim.getObjectAlias", box) == "box"
    wall = wire("sim.createPrimitiveShape", 3, [1.0, 0.1, 0.5], 8)
    wire("sim.setObjectAlias", wall, "wall")
    assert wire("sim.getObject", "/wall") == wall and wire("sim.getObjectAlias", float(wall), 2) == "/wall[0]"
    assert wire("sim.getObjectsInTree", -12) == [box, wall]
    for sizes in ([float("nan"), 1, 1], [-1, 1, 1], [1, float("inf"), 1], [0, 1, 1], [1e5, 1, 1]):
        err = wire.raw("sim.createPrimitiveShape", 3, sizes, 0)["err"]
        assert err.startswith("labsim serve: a cuboid's sizes are finite numbers of metres, greater than 0 and at "
                              "most 10000, not "), err
    assert wire("sim.createPrimitiveShape", 1, [2.0, 2.0, 0.0], 0) > wall  # a plane is flat


def test_a_texture_is_sent_as_data_and_written_where_it_is_asked() -> None:
    from labsim.runtime.serve.scene_edit import EMPTY

    server = Server(EMPTY, 0, port=0, empty=True)
    wire = Wire(server)
    plane, texture, res = wire("sim.createTexture", "", 0, [2.0, 1.0], [2.0, 1.0], [0.0, 0.0, 0.0], 0, [4, 2])
    assert texture == plane and res == [4, 2]
    assert wire("sim.writeTexture", texture, 0, bytes(range(24))) == 1
    assert wire("sim.writeTexture", float(texture), 0, b"\xff" * 3, 3, 1, 1, 1) == 1  # one pixel, bottom right
    import cv2

    shape = server.editor.shapes[plane]
    rgb = cv2.cvtColor(cv2.imdecode(np.frombuffer(shape.png, np.uint8), cv2.IMREAD_COLOR), cv2.COLOR_BGR2RGB)
    assert rgb[0].tolist() == [[0, 1, 2], [3, 4, 5], [6, 7, 8], [9, 10, 11]]  # the first row written first
    assert rgb[1].tolist() == [[12, 13, 14], [15, 16, 17], [18, 19, 20], [255, 255, 255]]
    assert "needs 24 bytes of RGB, was given 3" in wire.raw("sim.writeTexture", texture, 0, b"abc")["err"]
    assert wire.raw("sim.writeTexture", 5, 0, b"abc")["err"].startswith("texture does not exist.")
    assert "1 to 4096 pixels a side, not 100000 x 2" in wire.raw(
        "sim.createTexture", "", 0, [1.0, 1.0], None, None, 0, [100_000, 2])["err"]
    assert "plane sizes are finite" in wire.raw("sim.createTexture", "", 0, [float("nan"), 1.0])["err"]
