"""The lidar through `labsim serve`: the string signals CoppeliaSim's laser scanners publish.

A script reads ``measuredDataAtThisTime`` (x, y, z of each beam that detects, packed float32)
with ``sim.getStringSignal`` and ``sim.unpackFloatTable``, as for CoppeliaSim's Hokuyo; the
coppeliasim backend reads every beam's range in doubles, so a behaviour's trace through the
stand-in is the embedded backend's, row for row.
"""
from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import pytest

pytest.importorskip("cbor2")
zmq = pytest.importorskip("zmq")
pytest.importorskip("coppeliasim_zmqremoteapi_client")

from helpers import PATIENCE_S, examples, serve, serve_and_run, stop  # noqa: E402

from labsim.backends.protocol import RobotRequest  # noqa: E402
from labsim.backends.pymunk.backend import PymunkBackend  # noqa: E402
from labsim.backends.scene.models import PIONEER_P3DX, Lidar  # noqa: E402
from labsim.backends.scene.world import Pose, builtin_worlds  # noqa: E402
from labsim.backends.scene.world_file import load_world  # noqa: E402
from labsim.foundation.diagnostics import Report  # noqa: E402
from labsim.runtime.serve.server import Server  # noqa: E402

pytestmark = pytest.mark.slow  # labsim serve processes, and runs through them

WALLS = load_world(builtin_worlds()["walls_lab4"], Report())
LIDAR = Lidar(90, 270, 6.0, x_m=0.1)
MODEL = dataclasses.replace(PIONEER_P3DX, lidars=(LIDAR,))
POSE = Pose(4.0, 3.5, 0.6)  # near the box and the room's corner: some beams in range, some not


def test_the_docs_lidar_example_gives_the_embedded_backends_trace(tmp_path: Path) -> None:
    lab = tmp_path / "lidar.yaml"
    lab.write_text(examples("worlds.md")["lidar_avoid"].replace("stop: time >= 60", "stop: time >= 12"))
    ref, remote = serve_and_run(tmp_path, lab, "--for", str(lab))
    assert remote == ref and len(ref) > 200
    nearest = ref[0].split(",").index("nearest")
    assert len({row.split(",")[nearest] for row in ref[1:]}) > 50  # the scan changed as it drove


def _embedded() -> list[float]:
    b = PymunkBackend()
    b.open(WALLS, [RobotRequest("p", MODEL, POSE, tuple(f"lidar{k + 1}" for k in range(LIDAR.beams)))], 0.05, 1)
    out = [float(v) for v in b.sense()[0]]  # type: ignore[arg-type]
    b.close()
    return out


def test_a_script_reads_the_scan_as_from_coppeliasims_hokuyo() -> None:
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    want = _embedded()
    assert 10 < sum(math.isfinite(d) for d in want) < LIDAR.beams
    saved = dict(sys.modules["__main__"].__dict__)
    with Server(WALLS, [RobotRequest("p", MODEL, POSE, ())], port=0) as server:
        client = RemoteAPIClient("127.0.0.1", server.port)
        client.socket.setsockopt(zmq.RCVTIMEO, int(PATIENCE_S * 1000))
        client.socket.setsockopt(zmq.LINGER, 0)
        try:
            sim = client.require("sim")
            assert sim.getStringSignal("measuredDataAtThisTime") is None  # stopped: no scan yet
            sim.setStepping(True)
            sim.startSimulation()
            sim.step()
            data = sim.getStringSignal("measuredDataAtThisTime")
            points = sim.unpackFloatTable(data)
            ranges = sim.unpackDoubleTable(sim.getStringSignal("labsimLidarRanges"))
            mine = sim.packFloatTable([1.5, -2.25, 3.0])
            sim.setStringSignal("mine", mine)
            assert sim.unpackFloatTable(sim.getStringSignal("mine")) == [1.5, -2.25, 3.0]
            sim.clearStringSignal("mine")
            assert sim.getStringSignal("mine") is None
            sim.stopSimulation()
        finally:
            client.socket.close(0)
            client.context.term()
            sys.modules["__main__"].__dict__.pop("require", None)
            sys.modules["__main__"].__dict__.update(saved)
    assert ranges == want  # doubles: the ranges the behaviour sees, exactly
    # float32 points, in the sensor's frame, of the beams that detect: their distances and
    # directions are the beams', to float32's precision
    assert len(points) == 3 * sum(math.isfinite(d) for d in want)
    hits = [(a, d) for a, d in zip(LIDAR.angles_rad(), want) if math.isfinite(d)]
    for (a, d), k in zip(hits, range(0, len(points), 3)):
        x, y, z = points[k:k + 3]
        assert math.hypot(x, y) == pytest.approx(d, rel=1e-6) and z == 0.0
        assert math.atan2(y, x) == pytest.approx(a, abs=1e-6)


def test_labsim_scene_refuses_a_lidar_it_cannot_build_and_a_run_without_a_scanner_stops(tmp_path: Path,
                                                                                         capsys) -> None:
    """Never a silent scene: labsim scene names the lidar before building anything, and a run
    on a scene with no scanner stops at its first step rather than driving blind."""
    from labsim.runtime.cli.main import main

    lab = tmp_path / "lidar.yaml"
    lab.write_text(examples("worlds.md")["lidar_avoid"].replace("stop: time >= 60", "stop: time >= 3"))
    proc, port = serve("-q", "--empty")
    try:
        assert main(["scene", str(lab), "--port", str(port), "-q"]) == 2
        err = capsys.readouterr().err
        assert "labsim scene: robot 'pioneer' has a lidar (lidar1..lidar180), and labsim scene builds no laser " \
               "scanner" in err and "'labsimLidarRanges'" in err
        # the world and the Pioneer built without it (as by hand): the run names what is missing
        walls = tmp_path / "walls.yaml"
        walls.write_text("labsim: 1.2\nworld: walls_lab4\nseed: 5\nstop: time >= 1\nrobots:\n"
                         "  pioneer: {model: pioneer_p3dx, at: random}\nrules:\n  - always move(0)\n")
        assert main(["scene", str(walls), "--port", str(port), "-q"]) == 0
        trace = tmp_path / "t.csv"
        assert main(["run", str(lab), "-q", "--backend", "coppeliasim", "--port", str(port),
                     "--trace", str(trace)]) == 2
        err = capsys.readouterr().err
        assert f"robot 'pioneer': CoppeliaSim at 127.0.0.1:{port} publishes no signal 'labsimLidarRanges' after " \
               "a step, so the scene has no laser scanner for the behaviour's lidar" in err
        assert "Traceback" not in err
    finally:
        stop(proc)


@pytest.mark.parametrize("ranges, says", [
    ([math.nan] * 180, ": beam 1 reads nan, not a range in 0..4 m or inf"),
    ([-5.0] * 180, ": beam 1 reads -5.0, not a range in 0..4 m or inf"),
    ([1.0] * 90 + [4.5] + [1.0] * 89, ": beam 91 reads 4.5, not a range in 0..4 m or inf"),
    ([1.0] * 100_000, " has 100000 ranges; the robot's lidar has 180 beams"),
    ([1.0] * 179, " has 179 ranges; the robot's lidar has 180 beams"),
], ids=["nan", "negative", "beyond-range", "too-many", "too-few"])
def test_a_lidar_signal_a_client_set_is_checked_as_every_reply(ranges: list[float], says: str, tmp_path: Path,
                                                               capsys) -> None:
    """No scanner in the scene, and a client publishing 'labsimLidarRanges' itself: what is no
    range of the robot's lidar stops the run, naming the signal, rather than being driven on."""
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    from labsim.runtime.cli.main import main

    lab = tmp_path / "lidar.yaml"
    lab.write_text(examples("worlds.md")["lidar_avoid"].replace("stop: time >= 60", "stop: time >= 1"))
    walls = tmp_path / "walls.yaml"
    walls.write_text("labsim: 1.2\nworld: walls_lab4\nseed: 5\nstop: time >= 1\nrobots:\n"
                     "  pioneer: {model: pioneer_p3dx, at: random}\nrules:\n  - always move(0)\n")
    proc, port = serve("-q", "--empty")
    try:
        assert main(["scene", str(walls), "--port", str(port), "-q"]) == 0
        sim = RemoteAPIClient(port=port).require("sim")
        sim.setStringSignal("labsimLidarRanges", sim.packDoubleTable(ranges))
        assert main(["run", str(lab), "-q", "--backend", "coppeliasim", "--port", str(port),
                     "--trace", str(tmp_path / "t.csv")]) == 2
    finally:
        stop(proc)
    err = capsys.readouterr().err
    assert f"robot 'pioneer': signal 'labsimLidarRanges' of CoppeliaSim at 127.0.0.1:{port}{says}" in err, err
    assert "Traceback" not in err


def test_a_lidar_signal_of_the_stand_in_is_neither_set_nor_cleared_by_a_client() -> None:
    from coppeliasim_zmqremoteapi_client import RemoteAPIClient

    with Server(WALLS, [RobotRequest("p", MODEL, POSE, ())], port=0) as server:
        client = RemoteAPIClient("127.0.0.1", server.port)
        client.socket.setsockopt(zmq.RCVTIMEO, int(PATIENCE_S * 1000))
        client.socket.setsockopt(zmq.LINGER, 0)
        try:
            sim = client.require("sim")
            for call in (lambda: sim.setStringSignal("labsimLidarRanges", b"\0" * 8),
                         lambda: sim.clearStringSignal("labsimLidarRanges")):
                with pytest.raises(Exception, match="signal 'labsimLidarRanges' is a lidar's, published by the "
                                                    "stand-in"):
                    call()
        finally:
            client.socket.close(0)
            client.context.term()
