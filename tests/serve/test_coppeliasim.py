"""The coppeliasim backend against ``labsim serve``: the wall lab, the CLI, and its failures.

Tolerance between backends: none. Through labsim serve every reading is the pymunk backend's
float, carried exactly by CBOR, so the wall lab's trace rows are identical to the embedded
backend's (docs/coppeliasim.md says why, and what a real CoppeliaSim changes).
"""
from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

pytest.importorskip("cbor2")
zmq = pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import BEHAVIOURS, PATH_ERROR, PATIENCE_S, inner_rows, serve, serve_and_run, stop  # noqa: E402

from labsim.backends import load_backend  # noqa: E402
from labsim.backends.protocol import BackendError, RobotRequest  # noqa: E402
from labsim.backends.scene.models import PIONEER_P3DX  # noqa: E402
from labsim.backends.scene.world import Pose, builtin_worlds  # noqa: E402
from labsim.backends.scene.world_file import load_world  # noqa: E402
from labsim.foundation.diagnostics import Report  # noqa: E402
from labsim.runtime.cli.main import main  # noqa: E402
from labsim.runtime.serve.server import STOPPED, Server  # noqa: E402

pytestmark = pytest.mark.slow  # labsim serve processes, and whole runs through them

LAB = BEHAVIOURS / "wall_follow.yaml"
WALLS = load_world(builtin_worlds()["walls_lab4"], Report())
ONE = [RobotRequest("pioneer", PIONEER_P3DX, Pose(-4.0, -4.0, 0.8), ("sonar5", "x", "collided"))]


@pytest.fixture(scope="module")
def served():
    """A `labsim serve` process (walls_lab4, one robot) on a free port; stopped afterwards."""
    proc, port = serve("-q")
    yield port
    stop(proc)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_wall_lab_gives_the_embedded_backends_trace(served: int, tmp_path: Path, capsys) -> None:
    ref, remote, sub = (tmp_path / f"{n}.csv" for n in ("pymunk", "coppeliasim", "subprocess"))
    assert main(["run", str(LAB), "--set", "minutes=1", "--trace", str(ref)]) == 0
    expected = capsys.readouterr().out
    assert main(["run", str(LAB), "--set", "minutes=1", "--trace", str(remote),
                 "--backend", "coppeliasim", "--port", str(served)]) == 0
    out = capsys.readouterr().out
    header = json.loads(remote.read_text().split("\n", 1)[0].removeprefix("# labsim-trace "))
    assert header["backend"] == "coppeliasim"
    assert inner_rows(remote) == inner_rows(ref) and len(inner_rows(ref)) == 1 + 1201  # + the stopping tick
    # the same summary (collisions, metrics, rules), and the round trips on top
    def body(text: str) -> list[str]:
        return [line for line in text.split("\n")[2:] if "trace:" not in line and "round trips" not in line]

    assert body(out) == body(expected) and "collision" in body(out)[1]
    trips = float(out.split("\n")[-2].split()[0])
    # labsim serve's scene carries the fleet script: 3 a tick, 4 when a wheel command changed
    assert "round trips per tick" in out and 3 <= trips <= 4.3
    # deterministic across processes too
    subprocess.run([sys.executable, "-m", "labsim", "run", str(LAB), "--set", "minutes=1", "-q",
                    "--trace", str(sub), "--backend", "coppeliasim", "--port", str(served)],
                   check=True, timeout=4 * PATIENCE_S)
    assert sub.read_bytes() == remote.read_bytes()


def test_labsim_test_compares_a_coppeliasim_run_with_the_golden(served: int, tmp_path: Path, capsys) -> None:
    lab = tmp_path / "lab.yaml"
    lab.write_text(LAB.read_text().replace("minutes: 25 ", "minutes: 0.5"))
    assert main(["test", str(lab), "--update-goldens"]) == 0  # recorded on pymunk
    assert main(["test", str(lab), "--backend", "coppeliasim", "--port", str(served)]) == 0
    assert "ok   " in capsys.readouterr().out
    assert main(["run", str(lab), "--port", "23000"]) == 2  # --port needs --backend coppeliasim
    assert "only --backend coppeliasim takes --port" in capsys.readouterr().err


def test_no_server_is_a_clear_error_not_a_hang() -> None:
    port = _free_port()
    out = subprocess.run([sys.executable, "-m", "labsim", "run", str(LAB), "-q", "--backend", "coppeliasim",
                          "--port", str(port), "--timeout", "0.5"], capture_output=True, text=True,
                         timeout=PATIENCE_S)  # a hang fails here
    assert out.returncode == 2, out.stderr
    assert f"no answer from CoppeliaSim at 127.0.0.1:{port} within 0.5 s" in out.stderr
    assert "Traceback" not in out.stderr


def test_a_server_killed_mid_run_keeps_the_trace_and_exits_2(tmp_path: Path) -> None:
    proc, port = serve("-q")
    trace = tmp_path / "t.csv"
    run = subprocess.Popen([sys.executable, "-m", "labsim", "run", str(LAB), "--set", "minutes=5", "-q",
                            "--trace", str(trace), "--backend", "coppeliasim", "--port", str(port),
                            "--timeout", "3"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + PATIENCE_S
        partial = Path(str(trace) + ".partial")  # its name until the run ends (docs/trace-format.md)
        while not (partial.exists() and partial.stat().st_size > 20_000):
            assert run.poll() is None, "the run ended before the server was killed"
            assert time.monotonic() < deadline, "the run wrote no trace"
            time.sleep(0.02)
        proc.kill()
        proc.wait(PATIENCE_S)
        _, err = run.communicate(timeout=PATIENCE_S)
    finally:
        for p in (proc, run):
            if p.poll() is None:
                p.kill()
                p.wait()
    assert run.returncode == 2, err
    assert f"CoppeliaSim at 127.0.0.1:{port} stopped answering" in err and "within 3 s" in err
    assert "Traceback" not in err
    lines = trace.read_text().split("\n")
    assert lines[0].startswith("# labsim-trace ") and lines[-1] == ""  # ends with a whole line
    assert lines[-2].startswith('# end {"interrupted": true')  # the footer says it was cut short
    width = len(lines[1].split(","))
    assert len(lines) > 100 and all(len(row.split(",")) == width for row in lines[2:-2])


def test_camera_robots_give_the_embedded_backends_trace(tmp_path: Path) -> None:
    """Five robots with 128 x 128 cameras (the road lab): images cross the wire bottom row
    first and come back as labsim's images, pixel for pixel."""
    lab = tmp_path / "road.yaml"
    lab.write_text((BEHAVIOURS / "road_follow.yaml").read_text().replace("seconds: 30 ", "seconds: 1.5"))
    ref, remote = serve_and_run(tmp_path, lab, "--for", str(lab))
    assert remote == ref and len(ref) == 1 + 5 * 30


def test_the_crane_through_labsim_serve(tmp_path: Path) -> None:
    """Joints, the force sensor and bodies in the plane: exact until the arm slews (t = 6 s);
    then the bodies' positions go through the slew's rotation and back, within rounding."""
    lab = tmp_path / "crane.yaml"
    lab.write_text((BEHAVIOURS / "crane.yaml").read_text().replace("stop: time >= 60", "stop: time >= 7")
                   .replace("world: crane", f"world: {builtin_worlds()['crane']}"))
    ref, remote = serve_and_run(tmp_path, lab, "crane")
    assert len(remote) == len(ref) == 1 + 141  # format 1.2 traces the stopping tick too
    slewing = next(i for i, row in enumerate(ref) if row.split(",")[1] == "6.05")
    assert remote[:slewing] == ref[:slewing]
    for a, b in zip(remote[slewing:], ref[slewing:]):
        for u, v in zip(_numbers(a), _numbers(b)):
            assert u == pytest.approx(v, rel=1e-12, abs=1e-12) or abs(u - v) <= 1e-5 * abs(v) + 1e-6


def _numbers(row: str) -> list[float]:
    """Every number in a trace row, tuples opened (a 6-digit cell may round the other way)."""
    import re

    return [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", row)]


@pytest.fixture
def server():
    with Server(WALLS, 1, port=0) as srv:
        yield srv


def test_unknown_function_and_wrong_path_with_the_real_client(server: Server) -> None:
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    saved = dict(sys.modules["__main__"].__dict__)
    client = RemoteAPIClient("127.0.0.1", server.port)
    client.socket.setsockopt(zmq.RCVTIMEO, int(PATIENCE_S * 1000))
    client.socket.setsockopt(zmq.LINGER, 0)
    try:
        sim = client.require("sim")
        with pytest.raises(Exception, match=r"^No such function: sim\.noSuchFunction$"):
            client.call("sim.noSuchFunction", [])
        with pytest.raises(Exception) as e:
            sim.getObject("/PioneerP3DX[5]/leftMotor")
        assert str(e.value).startswith(PATH_ERROR)
        assert sim.getObject("/PioneerP3DX[5]", {"noError": True}) == -1
    finally:
        client.socket.close(0)
        client.context.term()
        sys.modules["__main__"].__dict__.pop("require", None)
        sys.modules["__main__"].__dict__.update(saved)


def test_backend_reports_a_missing_robot_and_a_dt_mismatch(server: Server) -> None:
    two = ONE + [RobotRequest("other", PIONEER_P3DX, Pose(0.0, -2.0, 0.0), ("sonar5",))]
    backend = load_backend("coppeliasim", port=server.port)
    with pytest.raises(BackendError) as e:
        backend.open(WALLS, two, 0.05, 1)
    assert "'/PioneerP3DX[1]'" in str(e.value) and PATH_ERROR in str(e.value)
    assert f"127.0.0.1:{server.port}" in str(e.value)
    with pytest.raises(BackendError) as e:
        load_backend("coppeliasim", port=server.port).open(WALLS, ONE, 0.1, 1)
    assert "0.05" in str(e.value) and "0.1" in str(e.value) and "dt" in str(e.value)
    backend = load_backend("coppeliasim", port=server.port)
    backend.open(WALLS, ONE, 0.05, 1)  # the failed attempts left nothing behind
    assert backend.sense()[0][1:] == [-4.0, False]
    backend.close()


def test_an_old_coppeliasim_gets_a_friendly_explanation() -> None:
    """CoppeliaSim 4.5 and earlier do not know zmqRemoteApi.require (zmqRemoteApi issue #9)."""
    import cbor2

    ctx = zmq.Context()
    rep = ctx.socket(zmq.REP)
    rep.setsockopt(zmq.LINGER, 0)
    port = rep.bind_to_random_port("tcp://127.0.0.1")

    def old_server() -> None:
        if rep.poll(int(PATIENCE_S * 1000)):
            req = cbor2.loads(rep.recv())
            # a protocol-1 server (CoppeliaSim 4.5) answers {"success": false, "error": ...}
            rep.send(cbor2.dumps({"success": False, "error": f"No such function: {req['func']}"}))

    thread = threading.Thread(target=old_server)
    thread.start()
    try:
        with pytest.raises(BackendError) as e:
            load_backend("coppeliasim", port=port, timeout_s=5.0).open(WALLS, ONE, 0.05, 1)
    finally:
        thread.join(PATIENCE_S)
        rep.close()
        ctx.term()
    assert "older protocol" in str(e.value)
    assert "CoppeliaSim 4.6 or newer" in str(e.value)


def test_close_after_an_interrupted_call_still_stops_the_simulation(server: Server) -> None:
    import cbor2

    backend = load_backend("coppeliasim", port=server.port)
    backend.open(WALLS, ONE, 0.05, 1)
    # As if Ctrl-C struck between a request and its answer: the socket awaits a reply.
    client = backend._conn.client
    client.socket.send(cbor2.dumps({"func": "sim.getSimulationTime", "args": [], "uuid": client.uuid}))
    backend._conn.busy = True
    backend.close()
    assert server.simulation.state == STOPPED
    backend.close()


def test_round_trips_per_tick_for_sonars_only(server: Server) -> None:
    """6 sonars + collided + sim.step (2) + the simulation's state (a stop from outside) + changed
    wheels: what the wall lab costs a tick, object by object."""
    chans = tuple(f"sonar{k}" for k in (2, 5, 8, 9, 14, 15))
    backend = load_backend("coppeliasim", port=server.port)
    backend.open(WALLS, [RobotRequest("p", PIONEER_P3DX, Pose(-4.0, -4.0, 0.8), chans)], 0.05, 1)
    before = backend.round_trips
    backend.sense()
    backend.act(0, 1.0, 2.0)
    backend.step()
    assert backend.round_trips - before == 6 + 1 + 2 + 1 + 2
    before = backend.round_trips
    backend.sense()
    backend.act(0, 1.0, 2.0)  # unchanged: nothing sent
    backend.step()
    assert backend.round_trips - before == 6 + 1 + 2 + 1
    backend.close()


def test_the_embedded_path_never_imports_the_client() -> None:
    code = ("import sys, labsim.runtime.cli.main, labsim.backends.pymunk.backend, labsim.backends.coppeliasim; "
            "assert not {'zmq', 'cbor2', 'coppeliasim_zmqremoteapi_client'} & set(sys.modules)")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=PATIENCE_S)


def test_scene_paths_from_the_behaviour_file(served: int, tmp_path: Path, capsys) -> None:
    text = LAB.read_text().replace("minutes: 25 ", "minutes: 0.1")
    good = tmp_path / "good.yaml"
    good.write_text(text.replace("pioneer: {model: pioneer_p3dx, at: random}",
                                 'pioneer: {model: pioneer_p3dx, at: random, paths: {robot: "/PioneerP3DX[{i}]", '
                                 'sonar: "./ultrasonicSensor[{k}]"}}'))
    assert main(["run", str(good), "-q", "--backend", "coppeliasim", "--port", str(served)]) == 0
    bad = tmp_path / "bad.yaml"
    bad.write_text(text.replace("pioneer: {model: pioneer_p3dx, at: random}",
                                'pioneer: {model: pioneer_p3dx, at: random, paths: {robot: "/MyPioneer"}}'))
    capsys.readouterr()
    assert main(["run", str(bad), "-q", "--backend", "coppeliasim", "--port", str(served)]) == 2
    assert "/MyPioneer" in capsys.readouterr().err


@pytest.mark.parametrize("how", [(), ("--per-object",)], ids=["fleet-script", "per-object"])
def test_wheel_targets_a_client_left_in_the_scene_do_not_move_the_robot(how: tuple[str, ...], tmp_path: Path,
                                                                         capsys) -> None:
    """CoppeliaSim keeps the targets a client set while stopped: the backend sets them to 0
    before its first step, so the run is the embedded one from tick 0."""
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    proc, port = serve("-q", *how)
    try:
        sim = RemoteAPIClient(port=port).require("sim")
        sim.setJointTargetVelocity(sim.getObject("/PioneerP3DX/leftMotor"), 10)
        sim.setJointTargetVelocity(sim.getObject("/PioneerP3DX/rightMotor"), -10)
        ref, remote = tmp_path / "ref.csv", tmp_path / "remote.csv"
        assert main(["run", str(LAB), "-q", "--set", "minutes=0.05", "--trace", str(ref)]) == 0
        assert main(["run", str(LAB), "-q", "--set", "minutes=0.05", "--trace", str(remote),
                     "--backend", "coppeliasim", "--port", str(port)]) == 0
    finally:
        stop(proc)
    assert inner_rows(remote) == inner_rows(ref) and len(inner_rows(ref)) == 1 + 61


@pytest.mark.parametrize("fleet_script, seen", [
    (True, "after 3 steps (t = 0.15 s); the run cannot go on (seen at sim.callScriptFunction)"),  # the next sense
    (False, "after 4 steps (t = 0.20 s); the run cannot go on (seen at sim.step)"),  # the next step
], ids=["fleet-script", "per-object"])
def test_a_simulation_stopped_from_outside_mid_run_is_said_so(fleet_script: bool, seen: str) -> None:
    """Another client stops the simulation between two ticks: the next tick stops the run with
    that reason, on both paths (object by object the steps of a stopped simulation would do
    nothing, and every read would still answer: a run frozen in place, silently)."""
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    with Server(WALLS, 1, port=0, fleet_script=fleet_script) as server:
        backend = load_backend("coppeliasim", port=server.port)
        backend.open(WALLS, ONE, 0.05, 1)
        for _ in range(3):
            backend.sense()
            backend.act(0, 1.0, 1.0)
            backend.step()
        other = RemoteAPIClient(port=server.port)
        other.require("sim").stopSimulation()
        with pytest.raises(BackendError) as e:
            backend.sense()
            backend.step()
            backend.sense()
        backend.close()
        other.socket.close(0)
        other.context.term()
    assert str(e.value) == (f"CoppeliaSim at 127.0.0.1:{server.port}: the simulation was stopped from outside "
                            f"(another client, or the simulator's stop button), {seen}")


def test_joint_targets_a_client_left_in_the_crane_do_not_move_it(tmp_path: Path) -> None:
    """A mechanism's joints the behaviour does not bind keep the scene's targets in CoppeliaSim:
    the backend sets every motorised joint to 0 before the first step, as the embedded one starts."""
    import re

    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    text = (BEHAVIOURS / "crane.yaml").read_text().replace("stop: time >= 60", "stop: time >= 2") \
        .replace("world: crane", f"world: {builtin_worlds()['crane']}")
    lab = tmp_path / "crane.yaml"
    lab.write_text(re.sub(r"  (Arm|Crab)_Actuator\.velocity: [^\n]*\n", "", text))  # only the hoist bound
    proc, port = serve("-q", "--for", str(lab))
    try:
        sim = RemoteAPIClient(port=port).require("sim")
        for joint in ("/Arm_Actuator", "/Crab_Actuator"):
            sim.setJointTargetVelocity(sim.getObject(joint), 0.4)
        ref, remote = tmp_path / "ref.csv", tmp_path / "remote.csv"
        assert main(["run", str(lab), "-q", "--trace", str(ref)]) == 0
        assert main(["run", str(lab), "-q", "--trace", str(remote), "--backend", "coppeliasim",
                     "--port", str(port)]) == 0
    finally:
        stop(proc)
    assert inner_rows(remote) == inner_rows(ref) and len(inner_rows(ref)) == 1 + 41
