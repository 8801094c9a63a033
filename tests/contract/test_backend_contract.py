"""Every backend keeps the protocol, and the same inputs give the same readings.

The contract itself is ``labsim.backends.check_backend``, the function a backend's author runs
on their own backend; here it runs on each registered backend and on the scripted
``FakeBackend`` of the runtime tests, in three worlds: a box with two robots, the built-in
``crane`` (a mechanism that one agent reads and drives) and a road with a camera robot. The
fake's scripts play what the simulators do (robot a bumps into the east wall twice). The
coppeliasim backend runs against ``labsim serve`` (a ``Server`` in a thread per world, started
once for this module), which simulates the same world with the pymunk backend: both must then
give the same readings. What is left here is each simulator's own physics, and one backend
that breaks the contract, to show what its author would read.
"""
from __future__ import annotations

import contextlib
import dataclasses
import itertools
import math
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
from fake_backend import FakeBackend

from labsim.backends import REGISTRY, BackendContractError, check_backend, load_backend
from labsim.backends.protocol import Backend, ContactStats, RobotRequest
from labsim.backends.scene.models import PIONEER_P3DX, Camera
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

ROAD = load_world(builtin_worlds()["road_compact"], Report())
assert ROAD is not None
EYE = Camera("camera", 32, 24, fov_deg=60.0, height_m=0.4, pitch_deg=35.0)
DRIVER = [RobotRequest("driver", dataclasses.replace(PIONEER_P3DX, cameras=(EYE,)), ROAD.spawns[0],
                       ("camera", "road_offset", "on_road", "laps", "forward_speed", "x", "y", "heading", "collided"))]

SCENES = {"box": (WORLD, ROBOTS), "crane": (CRANE, AGENT), "road": (ROAD, DRIVER)}
# What the fake backend reads in each world: sonars see a wall 0.5 m off every third tick;
# robot a touches the wall on the ticks the simulators have it there (see drive_box).
FAKES: dict[str, Callable[[], FakeBackend]] = {
    "box": lambda: FakeBackend(lambda tick, robot, ch: 0.5 if tick % 3 == 0 else math.inf,
                               touching={0: [*range(23, 42), *range(79, 100)]}),
    "crane": lambda: FakeBackend(lambda tick, robot, ch: {
        SENSOR: (1962.0,), LOAD: (1.0, 0.3, 0.0)}.get(ch, (0.01 * tick, 0.2))),
    "road": lambda: FakeBackend({"camera": [np.zeros((24, 32, 3), np.uint8)], "road_offset": [0.1],
                                 "on_road": [True], "laps": [0.0], "forward_speed": [0.0]}),
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
                wheeled = [r for r in robots if r.model is not None]  # with their cameras
                ports[scene] = stack.enter_context(Server(world, wheeled or 0, port=0)).port
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
def test_every_backend_keeps_the_contract(make: Make, scene: str) -> None:
    world, robots = SCENES[scene]
    check_backend(lambda: make(scene), world, robots, dt_s=DT)


def test_robot_a_bumps_into_the_wall_twice(make: Make) -> None:
    """The box's drive, as the simulators simulate it and the fake plays it: collided turns
    True twice for robot a, never for b."""
    collided = [[row[-1] for row in rows] for rows in drive_box(make("box"))[0::2]]
    begun = [sum(c and (t == 0 or not seen[t - 1]) for t, c in enumerate(seen)) for seen in zip(*collided)]
    assert begun == [2, 0]


class ModelOrder(FakeBackend):
    """A broken backend: it reads each robot's channels in its model's order, whatever order
    the request gives (the box's requests happen to list them in that order)."""

    def sense(self) -> list[list[object]]:
        rows = super().sense()
        out = []
        for req, row in zip(self.robots, rows):
            assert req.model is not None
            read = dict(zip(req.channels, row))
            out.append([read[c] for c in req.model.channels() if c in read])
        return out


DRIFT = itertools.count()


def drifting() -> FakeBackend:
    """A broken backend: its readings depend on how many were made before it."""
    drift = next(DRIFT) / 1000
    return FakeBackend(lambda tick, robot, ch: 0.5 + drift)


@pytest.mark.parametrize(("broken", "said"), [
    (lambda: ModelOrder(FAKES["box"]().script, {0: range(23, 42)}),
     "asked for every robot's channels in reverse order, the backend read them otherwise: robot 'a' channel "
     "'sonar1' read 0.5 in the given order and False in reverse order at tick 0; sense() must return each "
     "robot's channels in the order its request lists them"),
    (drifting,
     "two backends given the same world, requests, dt_s, seed (7) and commands read differently: "
     "robot 'a' channel 'sonar1' read "),
], ids=["channels-in-its-own-order", "not-deterministic"])
def test_a_broken_backend_is_told_what_it_breaks(broken: Callable[[], Backend], said: str) -> None:
    with pytest.raises(BackendContractError) as caught:
        check_backend(broken, WORLD, ROBOTS, dt_s=DT)
    assert caught.value.failures[0].startswith(said) and len(caught.value.failures) == 1
    assert str(caught.value).startswith("backend 'fake' does not keep the backend contract "
                                        "(labsim.backends.protocol); 1 problem(s):\n  - " + said)


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


@pytest.mark.parametrize("scene", sorted(DRIVES))
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
