"""Every registered backend keeps the protocol, and the same inputs give the same readings."""
from __future__ import annotations

import math

import pytest

from labsim.backends import REGISTRY, load_backend
from labsim.backends.models import PIONEER_P3DX
from labsim.backends.protocol import BackendStateError, ContactStats, RobotRequest
from labsim.backends.world import Pose, Wall, World

WORLD = World("box", "a 6 m box", (-3, -3, 3, 3), walls=(
    Wall((-3, -3), (3, -3), 0.1), Wall((3, -3), (3, 3), 0.1), Wall((3, 3), (-3, 3), 0.1), Wall((-3, 3), (-3, -3), 0.1)))
CHANNELS = ("sonar1", "sonar5", "sonar12", "x", "y", "heading", "collided")
ROBOTS = [RobotRequest("a", PIONEER_P3DX, Pose(2.2, 0, 0), CHANNELS),  # 0.55 m from the east wall
          RobotRequest("b", PIONEER_P3DX, Pose(-1.5, 1.5, math.pi / 2), CHANNELS)]


@pytest.fixture(params=sorted(REGISTRY))
def backend_name(request) -> str:
    return request.param


def drive(name: str, ticks: int = 100) -> list[list[list[object]]]:
    backend = load_backend(name)
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


def test_contract(backend_name: str) -> None:
    backend = load_backend(backend_name)
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


def test_same_inputs_same_readings(backend_name: str) -> None:
    assert drive(backend_name) == drive(backend_name)
