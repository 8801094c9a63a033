"""CoppeliaSim as a labsim backend, through its ZeroMQ remote API.

Where it sits: the runtime drives ``CoppeliaSimBackend`` through
``labsim.backends.protocol.Backend`` exactly as it drives the embedded pymunk backend; the
backend turns each call into remote API calls of the unmodified client
``coppeliasim_zmqremoteapi_client``, sent to a CoppeliaSim 4.6+ with the ZMQ remote API
add-on, or to ``labsim serve`` (``server.py``), which answers the same protocol without
CoppeliaSim.

This module is the lifecycle and the routing. What it drives is in two parts, each given
the robots of its kind: ``fleet.Fleet`` (wheeled robots) and ``mechanism.MechanismDriver``
(a world's mechanism, such as the tower crane). Both share one ``connection.Connection``:
the client, the call wrapper, round-trip counting and the explanations of failures.

* ``open`` checks every channel (before connecting), connects, stops a simulation someone
  left running, checks the simulation time step against the behaviour's ``dt`` (a mismatch
  is an error saying both and how to fix it), finds the objects, moves each robot to the
  start pose the behaviour asks for, sets every joint it drives to a target velocity of 0 (a
  scene keeps the targets a client left in it, and a robot would move in the first step), and
  starts the simulation in stepping mode, with one step (robots at rest) when a part needs its
  sensors read once (CoppeliaSim handles sensors at the end of a step).
* ``sense``, ``act``, ``command``, ``pose`` and ``contacts`` go to the part that drives the
  robot; ``step`` is one ``sim.step`` (two round trips). It is never retried: a retry could
  step twice.
* ``close`` stops the simulation and closes the socket, also after an interrupted call.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Protocol

from labsim.backends.coppeliasim import DEFAULT_PORT
from labsim.backends.coppeliasim.connection import Connection
from labsim.backends.coppeliasim.fleet import Fleet
from labsim.backends.coppeliasim.mechanism import MechanismDriver
from labsim.backends.protocol import BackendError, BackendStateError, ContactStats, RobotRequest
from labsim.backends.scene.world import World


class _Driver(Protocol):
    """A part of the backend: it drives some of the run's robots, numbered from 0 among its own."""

    @property
    def primes(self) -> bool:
        """Whether its sensors need one step before the first tick."""

    def find(self) -> None:
        """Look up the objects (the connection is open and the time step checked)."""

    def place(self) -> None:
        """Put the robots at their start poses (the simulation is stopped)."""

    def rest(self) -> None:
        """Set every joint it drives to its first command (0), before the first step: the
        scene keeps the targets it was left with (a client may have set them while stopped)."""

    def sense(self, first: bool) -> list[list[object]]: ...

    def act(self, k: int, left_rad_s: float, right_rad_s: float) -> None: ...

    def command(self, k: int, joint: str, mode: str, value: float) -> None: ...

    def before_step(self) -> None:
        """Send what act() and command() held back, just before the step."""

    def pose(self, k: int) -> tuple[float, float, float]: ...

    def contacts(self, k: int) -> ContactStats: ...


class CoppeliaSimBackend:
    """The ``Backend`` protocol on CoppeliaSim's ZMQ remote API (protocol 2, CoppeliaSim 4.6+).

    ``paths`` overrides entries of ``MODEL_PATHS[model]`` (e.g. ``{"robot": "/Pioneer[{i}]"}``);
    ``place_robots=False`` keeps the robots where the scene has them instead of moving them to
    the behaviour's start poses.
    """

    name = "coppeliasim"

    def __init__(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT, timeout_s: float = 5.0,
                 paths: dict[str, object] | None = None, place_robots: bool = True) -> None:
        if not (isinstance(timeout_s, (int, float)) and math.isfinite(timeout_s) and timeout_s > 0):
            raise BackendError(f"coppeliasim backend: timeout_s must be a positive number of seconds, "
                               f"not {timeout_s!r}")
        if not isinstance(port, int) or not 0 < port < 65536:
            raise BackendError(f"coppeliasim backend: port must be 1..65535, not {port!r}")
        self.paths = dict(paths or {})
        self.place_robots = place_robots
        self.round_trips_open = 0  # requests open() sent
        self._conn = Connection(host, port, float(timeout_s))
        self._drivers: list[tuple[_Driver, list[int]]] = []  # each part, and the robots it drives
        self._robots: list[tuple[_Driver, int]] = []  # robot -> (its part, its number there)
        self._sensed = 0  # sense() calls since open
        self._opened = False

    @property
    def host(self) -> str:
        return self._conn.host

    @property
    def port(self) -> int:
        return self._conn.port

    @property
    def timeout_s(self) -> float:
        return self._conn.timeout_s

    @property
    def where(self) -> str:
        return self._conn.where

    @property
    def round_trips(self) -> int:
        """Requests sent since open (each is one round trip)."""
        return self._conn.round_trips

    @property
    def steps(self) -> int:
        """sim.step calls since open, the priming step not counted."""
        return self._conn.steps

    # --- protocol ----------------------------------------------------------------------------

    def open(self, world: World, robots: Sequence[RobotRequest], dt_s: float, seed: int) -> None:
        """Check the channels, connect, check dt, find the objects, place the robots, start stepping."""
        if self._conn.client is not None:
            raise BackendStateError("coppeliasim backend: open() called twice; close() it first")
        if not dt_s > 0:
            raise BackendError(f"coppeliasim backend: dt_s must be positive, not {dt_s!r}")
        drivers = self._plan(world, robots)  # every channel checked before connecting
        self._sensed = 0
        self._conn.open(float(dt_s))
        try:
            self._start(drivers, len(robots))
        except BaseException:
            self.close()
            raise
        self._opened = True
        self.round_trips_open = self._conn.round_trips

    def _plan(self, world: World, robots: Sequence[RobotRequest]) -> list[tuple[_Driver, list[int]]]:
        """The parts, each with the robots it drives: the wheeled ones, and the mechanism."""
        wheeled = [i for i, req in enumerate(robots) if req.model is not None]
        mechanism = [i for i, req in enumerate(robots) if req.model is None]
        conn = self._conn
        drivers: list[tuple[_Driver, list[int]]] = []
        if wheeled:
            drivers.append((Fleet(conn, world, [robots[i] for i in wheeled], self.paths), wheeled))
        if mechanism:
            drivers.append((MechanismDriver(conn, world, [robots[i] for i in mechanism]), mechanism))
        return drivers

    def _start(self, drivers: list[tuple[_Driver, list[int]]], count: int) -> None:
        conn = self._conn
        conn.require_sim()
        conn.stop_running()
        conn.check_dt()
        for driver, _ in drivers:
            driver.find()
        self._drivers = drivers
        where = {i: (driver, k) for driver, indices in drivers for k, i in enumerate(indices)}
        self._robots = [where[i] for i in range(count)]
        if self.place_robots:
            for driver, _ in drivers:
                driver.place()
        for driver, _ in drivers:
            driver.rest()
        conn.start_stepping()
        if any(driver.primes for driver, _ in drivers):
            # One step with the wheels still, so that the sensors have been handled once:
            # CoppeliaSim reads proximity and vision sensors at the end of a step.
            conn.call("sim.step")

    def sense(self) -> list[list[object]]:
        if not self._opened:
            raise self._state_error("sense")
        first = self._sensed == 0
        self._sensed += 1
        out: list[list[object]] = [[] for _ in self._robots]
        for driver, indices in self._drivers:
            for i, values in zip(indices, driver.sense(first)):
                out[i] = values
        return out

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        if not self._opened:
            raise self._state_error("act")
        driver, k = self._robots[robot]
        driver.act(k, left_rad_s, right_rad_s)

    def command(self, robot: int, joint: str, mode: str, value: float) -> None:
        if not self._opened:
            raise self._state_error("command")
        driver, k = self._robots[robot]
        driver.command(k, joint, mode, value)

    def step(self) -> None:
        if not self._opened:
            raise self._state_error("step")
        for driver, _ in self._drivers:
            driver.before_step()
        self._conn.step()

    def pose(self, robot: int) -> tuple[float, float, float]:
        if not self._opened:
            raise self._state_error("pose")
        driver, k = self._robots[robot]
        return driver.pose(k)

    def contacts(self, robot: int) -> ContactStats:
        """Contacts so far, counted from ``collided`` once a tick; readable after ``close``."""
        if not self._robots:
            raise BackendStateError("coppeliasim backend: contacts() called before open()")
        driver, k = self._robots[robot]
        return driver.contacts(k)

    def close(self) -> None:
        """Stop the simulation if it can, close the socket; safe to call twice, never raises
        for a lost connection (the error that ended the run has been reported already)."""
        self._opened = False
        self._conn.close()

    def _state_error(self, call: str) -> BackendStateError:
        when = "after close()" if self._robots else "before open()"
        return BackendStateError(f"coppeliasim backend: {call}() called {when}; open() a world first")
