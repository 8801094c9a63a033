"""Every registered backend keeps the protocol, and the same inputs give the same readings.

The coppeliasim backend runs against ``labsim serve`` (a ``Server`` in a thread, started once
for this module), which simulates the same world with the pymunk backend: both backends must
then give the very same readings, float for float.
"""
from __future__ import annotations

import math

import pytest

from labsim.backends import REGISTRY, load_backend
from labsim.backends.scene.models import PIONEER_P3DX
from labsim.backends.protocol import Backend, BackendStateError, ContactStats, RobotRequest
from labsim.backends.scene.world import Pose, Wall, World

WORLD = World("box", "a 6 m box", (-3, -3, 3, 3), walls=(
    Wall((-3, -3), (3, -3), 0.1), Wall((3, -3), (3, 3), 0.1), Wall((3, 3), (-3, 3), 0.1), Wall((-3, 3), (-3, -3), 0.1)))
CHANNELS = ("sonar1", "sonar5", "sonar12", "x", "y", "heading", "collided")
ROBOTS = [RobotRequest("a", PIONEER_P3DX, Pose(2.2, 0, 0), CHANNELS),  # 0.55 m from the east wall
          RobotRequest("b", PIONEER_P3DX, Pose(-1.5, 1.5, math.pi / 2), CHANNELS)]


@pytest.fixture(scope="module")
def server():
    """labsim serve for WORLD with two robots, on a free port, for the coppeliasim backend."""
    pytest.importorskip("zmq")
    pytest.importorskip("cbor2")
    pytest.importorskip("coppeliasim_zmqremoteapi_client")
    from labsim.backends.coppeliasim.server import Server

    with Server(WORLD, 2, port=0) as srv:
        yield srv


@pytest.fixture(params=sorted(REGISTRY))
def make(request):
    """make() -> a new backend of each registered kind (coppeliasim: against the server)."""
    if request.param == "coppeliasim":
        srv = request.getfixturevalue("server")
        return lambda: load_backend("coppeliasim", port=srv.port, timeout_s=5.0)
    return lambda: load_backend(request.param)


def drive(backend: Backend, ticks: int = 100) -> list[list[list[object]]]:
    backend.open(WORLD, ROBOTS, 0.05, seed=7)
    out = []
    try:
        for t in range(ticks):
            out.append(backend.sense())
            backend.act(0, 3.0, 3.5)
            backend.act(1, 2.0 if t < 50 else -2.0, 2.0)
            backend.step()
    finally:
        backend.close()
    return out


def test_contract(make) -> None:
    backend = make()
    with pytest.raises(BackendStateError):
        backend.sense()
    backend.open(WORLD, ROBOTS, 0.05, seed=1)
    readings = backend.sense()
    assert len(readings) == 2 and all(len(r) == len(CHANNELS) for r in readings)
    sonar1, sonar5, sonar12, x, y, heading, collided = readings[0]
    # sonar5 sits at (0.2095, -0.0273) looking 10 degrees right; the wall's face is at x = 2.95
    assert sonar5 == pytest.approx((2.95 - 2.2 - 0.2095) / math.cos(math.radians(10)), abs=0.01)
    assert sonar1 == math.inf  # the north wall is 3 m away, beyond the 1 m range: not 0
    assert (x, y, heading, collided) == (2.2, 0.0, 0.0, False)
    assert backend.pose(1) == pytest.approx((-1.5, 1.5, math.pi / 2))
    backend.act(0, -5.0, -5.0)
    for _ in range(20):
        backend.step()
    x1, _, _ = backend.pose(0)
    assert 2.2 - x1 == pytest.approx(5.0 * PIONEER_P3DX.wheel_radius_m * 20 * 0.05, rel=0.02)
    assert backend.contacts(0) == ContactStats(0, 0.0)
    backend.close()
    backend.close()  # twice is fine
    with pytest.raises(BackendStateError):
        backend.step()


def test_same_inputs_same_readings(make) -> None:
    assert drive(make()) == drive(make())


def test_coppeliasim_reads_what_pymunk_computes(server) -> None:
    """Through labsim serve, every reading is the embedded backend's, bit for bit."""
    remote = drive(load_backend("coppeliasim", port=server.port))
    assert remote == drive(load_backend("pymunk"))
    assert any(r[1] != math.inf for tick in remote for r in tick)  # the sonars did see walls
