"""Every backend keeps the protocol, and the same inputs give the same readings.

Two worlds: a box with two robots, and the built-in ``crane`` (a mechanism that one agent
reads and drives). Every test that says "every backend" runs on each registered backend and on
the scripted ``FakeBackend`` of the runtime tests, whose scripts play what the simulators do
(robot a bumps into the east wall twice). The coppeliasim backend runs against ``labsim
serve`` (a ``Server`` in a thread per world, started once for this module), which simulates
the same world with the pymunk backend: both must then give the same readings.
"""
from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from fake_backend import FakeBackend

from labsim.backends import REGISTRY, load_backend
from labsim.backends.protocol import Backend, BackendError, BackendStateError, ContactStats, RobotRequest
from labsim.backends.scene.models import PIONEER_P3DX
from labsim.backends.scene.world import Pose, Wall, World, builtin_worlds
from labsim.backends.scene.world_file import load_world
from labsim.foundation.diagnostics import Report

DT = 0.05
WORLD = World("box", "a 6 m box", (-3, -3, 3, 3), walls=(
    Wall((-3, -3), (3, -3), 0.1), Wall((3, -3), (3, 3), 0.1), Wall((3, 3), (-3, 3), 0.1), Wall((-3, 3), (-3, -3), 0.1)))
CHANNELS = ("sonar1", "sonar5", "sonar12", "x", "y", "heading", "collided")
ROBOTS = [RobotRequest("a", PIONEER_P3DX, Pose(2.2, 0, 0), CHANNELS),  # 0.55 m from the east wall
          RobotRequest("b", PIONEER_P3DX, Pose(-1.5, 1.5, math.pi / 2), CHANNELS)]


def _crane() -> World:
    world = load_world(builtin_worlds()["crane"], Report())
    assert world is not None and world.mechanism is not None
    return world


CRANE = _crane()
CRAB, HOIST, SLEW, SENSOR, LOAD = "Crab_Actuator", "Hoist_Actuator", "Arm_Actuator", "Force_sensor", "Load"
CRANE_CHANNELS = (CRAB, HOIST, SLEW, SENSOR, LOAD, "x", "y", "heading", "collided")
AGENT = [RobotRequest("crane", None, Pose(0.0, 0.0, 0.0), CRANE_CHANNELS)]

SCENES = {"box": (WORLD, ROBOTS), "crane": (CRANE, AGENT)}
# What the fake backend reads in each world: sonars see a wall 0.5 m off every third tick;
# robot a touches the wall on the ticks the simulators have it there (see drive_box).
FAKES: dict[str, Callable[[], FakeBackend]] = {
    "box": lambda: FakeBackend(lambda tick, robot, ch: 0.5 if tick % 3 == 0 else math.inf,
                               touching={0: [*range(23, 42), *range(79, 100)]}),
    "crane": lambda: FakeBackend(lambda tick, robot, ch: {
        SENSOR: (1962.0,), LOAD: (1.0, 0.3, 0.0)}.get(ch, (0.01 * tick, 0.2))),
}
BACKENDS = [*sorted(REGISTRY), "fake"]

Make = Callable[[str], Backend]  # a world's name in SCENES -> a new backend for it


@pytest.fixture(scope="module")
def serve() -> Iterator[Callable[[str], int]]:
    """serve(scene) -> the port of labsim serve for that world (started on first use)."""
    with contextlib.ExitStack() as stack:
        ports: dict[str, int] = {}

        def port(scene: str) -> int:
            if scene not in ports:
                pytest.importorskip("zmq")
                pytest.importorskip("cbor2")
                pytest.importorskip("coppeliasim_zmqremoteapi_client")
                from labsim.runtime.serve.server import Server

                world, robots = SCENES[scene]
                robot_count = sum(r.model is not None for r in robots)
                ports[scene] = stack.enter_context(Server(world, robot_count, port=0)).port
            return ports[scene]

        yield port


def maker(name: str, serve: Callable[[str], int]) -> Make:
    if name == "fake":
        return lambda scene: FAKES[scene]()
    if name == "coppeliasim":
        return lambda scene: load_backend("coppeliasim", port=serve(scene), timeout_s=5.0)
    return lambda scene: load_backend(name)


@pytest.fixture(params=BACKENDS)
def make(request: pytest.FixtureRequest, serve: Callable[[str], int]) -> Make:
    """make(scene) -> a new backend of each kind, the scripted one included."""
    return maker(request.param, serve)


@pytest.fixture(params=sorted(REGISTRY))
def simulator(request: pytest.FixtureRequest, serve: Callable[[str], int]) -> Make:
    """make(scene) -> a new backend of each registered kind: the ones that simulate."""
    return maker(request.param, serve)


def drive_box(backend: Backend, ticks: int = 100) -> list[Any]:
    """Robot a bumps into the east wall, backs off at tick 40, bumps again from tick 60; b
    turns. Every tick: the readings, then each robot's contacts and pose."""
    backend.open(WORLD, ROBOTS, DT, seed=7)
    out: list[Any] = []
    try:
        for t in range(ticks):
            out.append(backend.sense())
            out.append([(backend.contacts(i), backend.pose(i)) for i in range(len(ROBOTS))])
            a = -5.0 if 40 <= t < 60 else 5.0
            backend.act(0, a, a)
            backend.act(1, 2.0 if t < 50 else -2.0, 2.0)
            backend.step()
    finally:
        backend.close()
    return out


def drive_crane(backend: Backend, ticks: int = 60) -> list[Any]:
    """The crab runs out and the arm slews; from tick 20 the hoist lifts to 4 m of rope."""
    backend.open(CRANE, AGENT, DT, seed=7)
    out: list[Any] = []
    try:
        for t in range(ticks):
            out.append(backend.sense())
            if t == 0:
                backend.command(0, CRAB, "velocity", 0.5)
                backend.command(0, SLEW, "velocity", 0.2)
            if t == 20:
                backend.command(0, HOIST, "position", 4.0)
            backend.step()
        out.append([backend.pose(0), backend.contacts(0)])
    finally:
        backend.close()
    return out


DRIVES = {"box": drive_box, "crane": drive_crane}


def numbers(value: object) -> list[float]:
    """Every number in nested readings, in order (bools as 0 and 1, contacts as two)."""
    if isinstance(value, ContactStats):
        return [value.count, value.time_s]
    if isinstance(value, (list, tuple)):
        return [n for v in value for n in numbers(v)]
    assert isinstance(value, (int, float)), value
    return [float(value)]


# --- the protocol, on every backend -----------------------------------------------------------

@pytest.mark.parametrize("scene", sorted(SCENES))
def test_calls_in_the_wrong_order_raise(make: Make, scene: str) -> None:
    backend = make(scene)
    world, robots = SCENES[scene]
    calls: tuple[Callable[[], object], ...] = (backend.sense, backend.step, lambda: backend.contacts(0))
    for call in calls:
        with pytest.raises(BackendStateError):
            call()
    backend.open(world, robots, DT, seed=1)
    readings = backend.sense()
    assert len(readings) == len(robots) and all(len(r) == len(req.channels) for r, req in zip(readings, robots))
    backend.step()
    backend.close()
    backend.close()  # twice is fine
    for call in (backend.sense, backend.step, lambda: backend.pose(0), lambda: backend.act(0, 1.0, 1.0)):
        with pytest.raises(BackendStateError):
            call()
    assert isinstance(backend.contacts(0), ContactStats)  # still readable, for the summary


def test_robot_readings_and_contacts(make: Make) -> None:
    """Every channel has its type, pose() agrees with x, y, heading, and contacts follow
    collided: each tick after the first that reads True adds dt of contact time, and a tick
    on which it turns True is a new contact (a simulator may also count one that began and
    ended within a step)."""
    history = drive_box(make("box"))
    seen = [[0, 0.0, False] for _ in ROBOTS]  # per robot: contacts seen to begin, time, touching
    for tick, (rows, robots) in enumerate(zip(history[0::2], history[1::2])):
        for r, (row, (stats, pose)) in enumerate(zip(rows, robots)):
            *sonars, x, y, heading, collided = row
            assert all(isinstance(s, float) and s >= 0 for s in sonars)  # inf: nothing in range
            assert all(isinstance(v, float) for v in (x, y, heading)) and -math.pi < heading <= math.pi
            assert pose == (x, y, heading)
            assert isinstance(collided, bool)
            if collided and not seen[r][2]:
                seen[r][0] += 1
            if collided and tick > 0:
                seen[r][1] += DT
            seen[r][2] = collided
            assert stats.count >= seen[r][0] and stats.time_s == pytest.approx(seen[r][1], abs=1e-9)
    assert [count for count, _, _ in seen] == [2, 0]  # a bumped into the wall twice, b never


def test_mechanism_readings_and_commands(make: Make) -> None:
    backend = make("crane")
    backend.open(CRANE, AGENT, DT, seed=1)
    backend.command(0, CRAB, "velocity", 0.5)
    backend.command(0, HOIST, "position", 4.0)
    with pytest.raises(BackendError):
        backend.command(0, "Crab_Actuatr", "velocity", 1.0)
    for _ in range(10):
        backend.step()
    (crab, hoist, slew, sensor, load, x, y, heading, collided), = backend.sense()
    for joint in (crab, hoist, slew):
        assert isinstance(joint, tuple) and len(joint) == 2 and all(isinstance(v, float) for v in joint)
    assert isinstance(sensor, tuple) and len(sensor) == 1 and sensor[0] >= 0  # tension, N
    assert isinstance(load, tuple) and len(load) == 3  # x, z, angle in the plane
    assert backend.pose(0) == pytest.approx((x, y, heading)) and collided is False
    assert backend.contacts(0) == ContactStats(0, 0.0)  # a mechanism's parts touch by design
    backend.close()


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_same_inputs_same_readings(make: Make, scene: str) -> None:
    assert DRIVES[scene](make(scene)) == DRIVES[scene](make(scene))


# --- what the simulators simulate -------------------------------------------------------------

def test_readings_follow_the_geometry(simulator: Make) -> None:
    backend = simulator("box")
    backend.open(WORLD, ROBOTS, DT, seed=1)
    readings = backend.sense()
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
    assert 2.2 - x1 == pytest.approx(5.0 * PIONEER_P3DX.wheel_radius_m * 20 * DT, rel=0.02)
    assert backend.contacts(0) == ContactStats(0, 0.0)
    backend.close()


def test_the_crane_follows_its_commands(simulator: Make) -> None:
    history = drive_crane(simulator("crane"))
    (crab0, hoist0, slew0, *_), = history[0]
    (crab, hoist, slew, (tension,), load, *_), = history[59]
    assert crab0 == (3.0, 0.0) and hoist0 == (5.15, 0.0) and slew0 == (0.0, 0.0)
    assert crab[1] == pytest.approx(0.5) and crab[0] > 4.0  # 0.5 m/s, after 1 s of acceleration
    assert slew[1] == pytest.approx(0.2) and hoist[0] < 4.5 and hoist[1] < 0  # lifting
    assert tension == pytest.approx(200 * 9.81, rel=0.1) and load[1] > 0.3  # the load is off the floor


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_coppeliasim_reads_what_pymunk_computes(serve: Callable[[str], int], scene: str) -> None:
    """Through labsim serve, every reading is the embedded backend's: bit for bit for robots;
    to the last bits for a mechanism, whose bodies go through a 3D pose and back."""
    remote = DRIVES[scene](load_backend("coppeliasim", port=serve(scene)))
    local = DRIVES[scene](load_backend("pymunk"))
    if scene == "box":
        assert remote == local
        assert any(r[1] != math.inf for tick in remote[0::2] for r in tick)
    else:
        assert numbers(remote) == pytest.approx(numbers(local), rel=1e-12, abs=1e-12)
