"""labsim serve keeps serving: a scene edit it cannot honour is that request's error, shapes a
script adds to a lab's scene are obstacles, and clients come, step side by side, say
``_*end*_`` or vanish, as CoppeliaSim's ZMQ remote API add-on lets them."""
from __future__ import annotations

import cbor2
import pytest

zmq = pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from coppeliasim_zmqremoteapi_client import RemoteAPIClient  # noqa: E402

from labsim.backends.coppeliasim.connection import Connection  # noqa: E402
from labsim.backends.protocol import BackendError, RobotRequest  # noqa: E402
from labsim.backends.scene.models import PIONEER_P3DX  # noqa: E402
from labsim.backends.scene.world import Pose, World, builtin_worlds  # noqa: E402
from labsim.backends.scene.world_file import load_world  # noqa: E402
from labsim.foundation.diagnostics import Report  # noqa: E402
from labsim.runtime.builder.scene import build  # noqa: E402
from labsim.runtime.serve.server import Server  # noqa: E402

LAB = load_world(builtin_worlds()["walls_lab4"], Report())
NONE = World("none", "", (0, 0, 1, 1))


def request(server: Server, uuid: str, func: str, *args: object) -> dict:
    return cbor2.loads(server.handle(cbor2.dumps({"func": func, "args": list(args), "argsL": len(args),
                                                  "uuid": uuid})))


@pytest.fixture
def built() -> Server:
    """labsim serve --empty in a thread, with the wall lab built in it by labsim scene."""
    with Server(NONE, 0, port=0, empty=True) as srv:
        build(Connection("127.0.0.1", srv.port, 5.0), LAB, [RobotRequest("p", PIONEER_P3DX, Pose(0, 0, 0), ())],
              0.05)
        yield srv


def test_a_box_added_to_a_built_lab_is_an_obstacle_and_wedges_nothing(built: Server) -> None:
    sim = RemoteAPIClient("127.0.0.1", built.port).require("sim")
    box = sim.createPrimitiveShape(sim.primitiveshape_cuboid, [0.4, 0.4, 0.3], 8)  # respondable
    sim.setObjectAlias(box, "box")
    sim.setObjectPosition(box, [1.0, 0.0, 0.15], sim.handle_world)
    robot = sim.getObject("/PioneerP3DX")  # the request that used to fail, and every one after it
    assert sim.getObjectAlias(robot) == "PioneerP3DX"
    left, right = sim.getObject("/PioneerP3DX/leftMotor"), sim.getObject("/PioneerP3DX/rightMotor")
    sim.setStepping(True)
    sim.startSimulation()
    for _ in range(100):
        sim.setJointTargetVelocity(left, 5.0)
        sim.setJointTargetVelocity(right, 5.0)
        sim.step()
    x, _, _ = sim.getObjectPosition(robot, sim.handle_world)
    collided, _ = sim.checkCollision(robot, sim.handle_all)
    sim.stopSimulation()
    assert 0.4 < x < 0.8 and collided == 1  # stopped by the box's near face (0.8), not through it


def test_a_joint_in_a_scene_with_robots_is_that_requests_error(built: Server) -> None:
    sim = RemoteAPIClient("127.0.0.1", built.port).require("sim")
    with pytest.raises(Exception, match="holds robots"):
        sim.createJoint(sim.joint_revolute_subtype, sim.jointmode_dynamic, 0)
    assert sim.getObject("/PioneerP3DX") > 0


def test_a_scene_that_cannot_be_simulated_is_that_requests_error_and_is_undone(monkeypatch) -> None:
    srv = Server(NONE, 0, port=0, empty=True)
    (box,) = request(srv, "a", "sim.createPrimitiveShape", 3, [0.4, 0.4, 0.3], 24)["ret"]
    assert request(srv, "a", "sim.getSimulationState") == {"ret": [0]}  # rebuilt with the box: the good scene
    request(srv, "a", "sim.createPrimitiveShape", 3, [0.4, 0.4, 0.3], 24)

    def refuse(*args: object) -> None:  # any rebuild the simulation refuses
        raise BackendError("world 'scene' is a mechanism; it has no place for robots")
    monkeypatch.setattr(srv, "rebuild", refuse)
    assert "cannot be simulated" in request(srv, "a", "sim.getObject", "/PioneerP3DX")["err"]
    monkeypatch.undo()
    assert request(srv, "a", "sim.getSimulationState") == {"ret": [0]}  # and every request after it answers
    assert srv.editor is not None and list(srv.editor.shapes) == [box]  # the scene that could be simulated


def test_end_is_answered_with_an_empty_map_and_the_client_forgotten() -> None:
    srv = Server(LAB, 1, port=0)
    assert request(srv, "cpp-1", "sim.setStepping", True) == {"ret": [0]}
    assert "cpp-1" in srv.simulation.clients and srv.simulation.stepping()
    assert request(srv, "cpp-1", "_*end*_") == {}
    assert "cpp-1" not in srv.simulation.clients and not srv.simulation.stepping()
    assert request(srv, "never-seen", "_*end*_") == {}  # no client is made for it
    assert "never-seen" not in srv.simulation.clients


def test_two_clients_step_side_by_side_and_each_sees_the_same_scene() -> None:
    srv = Server(LAB, 1, port=0)
    for uuid in ("a", "b"):
        request(srv, uuid, "sim.setStepping", True)
    request(srv, "a", "sim.startSimulation")
    for uuid in ("a", "b", "a"):
        assert request(srv, uuid, "sim.step") == {"func": "_*wait*_", "args": []}
        assert request(srv, uuid, "_*executed*_") == {"ret": []}
    assert request(srv, "b", "sim.getSimulationTime")["ret"] == [pytest.approx(0.15)]
    request(srv, "a", "_*end*_")
    assert request(srv, "b", "sim.getSimulationTime")["ret"] == [pytest.approx(0.15)]  # still stepped by b


def test_a_client_that_vanishes_mid_run_leaves_a_stopped_simulation_to_the_next() -> None:
    with Server(LAB, 1, port=0, takeover_s=0.0) as srv:
        ctx = zmq.Context()
        sock = ctx.socket(zmq.REQ)
        sock.setsockopt(zmq.LINGER, 0)
        sock.connect(f"tcp://127.0.0.1:{srv.port}")
        for func, args in (("sim.setStepping", [True]), ("sim.startSimulation", []), ("sim.step", [])):
            sock.send(cbor2.dumps({"func": func, "args": args, "uuid": "gone", "ver": 2}))
            sock.recv()
        sock.close()  # killed between sim.step's wait and its _*executed*_
        ctx.term()
        sim = RemoteAPIClient("127.0.0.1", srv.port).require("sim")
        assert sim.getSimulationState() == sim.simulation_stopped
        sim.setStepping(True)
        sim.startSimulation()
        sim.step()
        assert sim.getSimulationTime() == pytest.approx(0.05)
        sim.stopSimulation()


# --- answered as CoppeliaSim answers ------------------------------------------------------------

def test_a_wheel_target_set_while_stopped_is_the_scenes_and_drives_from_the_start() -> None:
    srv = Server(LAB, 1, port=0)
    (left,) = request(srv, "a", "sim.getObject", "/PioneerP3DX/leftMotor")["ret"]
    (right,) = request(srv, "a", "sim.getObject", "/PioneerP3DX/rightMotor")["ret"]
    (robot,) = request(srv, "a", "sim.getObject", "/PioneerP3DX")["ret"]
    for motor in (left, right):
        request(srv, "a", "sim.setJointTargetVelocity", motor, 2.0)
    request(srv, "a", "sim.setStepping", True)
    request(srv, "a", "sim.startSimulation")
    assert request(srv, "a", "sim.getJointTargetVelocity", left) == {"ret": [2.0]}
    for _ in range(10):
        request(srv, "a", "sim.step")
        request(srv, "a", "_*executed*_")
    (x, y, _), = request(srv, "a", "sim.getObjectPosition", robot, -1)["ret"]
    assert x == pytest.approx(LAB.spawns[0].x_m + 10 * 0.05 * 2.0 * PIONEER_P3DX.wheel_radius_m, rel=0.02)
    request(srv, "a", "sim.stopSimulation")
    assert request(srv, "a", "sim.getJointTargetVelocity", left) == {"ret": [2.0]}  # still the scene's


def test_scripts_meet_the_wheel_limit_behaviours_meet() -> None:
    srv = Server(LAB, 1, port=0)
    (left,) = request(srv, "a", "sim.getObject", "/PioneerP3DX/leftMotor")["ret"]
    (right,) = request(srv, "a", "sim.getObject", "/PioneerP3DX/rightMotor")["ret"]
    request(srv, "a", "sim.setStepping", True)
    request(srv, "a", "sim.startSimulation")
    for motor in (left, right):
        request(srv, "a", "sim.setJointTargetVelocity", motor, 94.0)
    for _ in range(20):
        request(srv, "a", "sim.step")
        request(srv, "a", "_*executed*_")
    assert request(srv, "a", "sim.getJointTargetVelocity", left) == {"ret": [94.0]}  # what was asked
    (rate,) = request(srv, "a", "sim.getJointVelocity", left)["ret"]
    assert rate == pytest.approx(PIONEER_P3DX.max_wheel_speed_rad_s, rel=1e-6)  # what the wheel does


def test_the_scene_calls_take_wrong_arguments_cleanly() -> None:
    from hostile_serve import WRONG_ARGS

    srv = Server(LAB, 1, port=0)
    for func in ("sim.loadScene", "sim.closeScene"):
        for args in WRONG_ARGS:
            reply = request(srv, "h", func, *args)
            assert "internal error" not in reply.get("err", ""), (func, args, reply)
    assert request(srv, "h", "sim.startSimulation") == {"ret": []}
    assert request(srv, "h", "sim.loadScene", "wall_follow")["err"].startswith("simulation is not stopped.")


def test_a_lab_loaded_by_name_in_an_empty_server_keeps_its_walls_when_a_box_is_added() -> None:
    srv = Server(NONE, 0, port=0, empty=True)
    assert request(srv, "a", "sim.loadScene", "wall_follow") == {"ret": []}
    assert srv.world.walls == LAB.walls and len(srv.simulation.robots) == 1
    (box,) = request(srv, "a", "sim.createPrimitiveShape", 3, [0.4, 0.4, 0.3], 24)["ret"]
    request(srv, "a", "sim.setObjectPosition", box, [1.0, 1.0, 0.15], -1)
    assert request(srv, "a", "sim.getSimulationState") == {"ret": [0]}  # rebuilt: the lab and the box
    assert srv.world.walls == LAB.walls and len(srv.world.blocks) == len(LAB.blocks) + 1
    assert len(srv.simulation.robots) == 1
    assert "file not found." in request(srv, "a", "sim.loadScene", "/scenes/lab4.ttt")["err"]
    assert request(srv, "a", "sim.closeScene") == {"ret": [0]}
    assert srv.world.walls == () and srv.simulation.robots == []
