"""The embedded 2D simulator, and labsim's default backend.

``PymunkBackend`` is the ``labsim.backends.protocol.Backend`` the runtime drives, and all it
does is choose a simulator when a world opens and pass every call on to it: a fleet of rovers
seen from above (``labsim.backends.pymunk.fleet``: walls, blocks, differential drive, sonars,
cameras, roads, contacts) for a world of robots, or the world's mechanism seen from the side
(``labsim.backends.pymunk.mechanism``: joints, force sensors, bodies, such as the tower crane).
Both need nothing but pymunk (and OpenCV for cameras), run in-process, and are deterministic:
the same world, requests, commands and dt give bit-identical readings in every run and process.
``space`` and ``bodies`` are public so that a benchmark can drive the very same scene by hand.
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import cast

import pymunk

from labsim.backends.protocol import BackendError, BackendStateError, ContactStats, RobotRequest
from labsim.backends.pymunk.fleet import FleetSimulator
from labsim.backends.pymunk.mechanism import MechanismSimulator
from labsim.backends.pymunk.simulator import Simulator
from labsim.backends.scene.world import World


class _Shut:
    """The simulator stand-in before ``open`` and after ``close``: every call raises
    BackendStateError, except that ``contacts`` after ``close`` still answers from the closed
    simulator (a run's summary reads it)."""

    def __init__(self, when: str, closed: Simulator | None = None) -> None:
        self._when = when  # "before open()" | "after close()"
        self._closed = closed

    def _error(self, call: str) -> BackendStateError:
        return BackendStateError(f"pymunk backend: {call}() called {self._when}; open() a world first")

    def sense(self) -> list[list[object]]:
        raise self._error("sense")

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        raise self._error("act")

    def command(self, robot: int, joint: str, mode: str, value: float) -> None:
        raise self._error("command")

    def step(self) -> None:
        raise self._error("step")

    def pose(self, robot: int) -> tuple[float, float, float]:
        raise self._error("pose")

    def contacts(self, robot: int) -> ContactStats:
        if self._closed is None:
            raise self._error("contacts")
        return self._closed.contacts(robot)


class PymunkBackend:
    """The ``Backend`` protocol on a pymunk ``Space``.

    Public attributes, valid between ``open`` and ``close`` (``None`` and ``[]`` otherwise):

    * ``space``: the ``pymunk.Space`` holding the scene.
    * ``bodies``: in a robot world, the robots' ``pymunk.Body`` objects, in the order of
      ``open``'s ``robots`` (a mechanism world has none). A body's position is the
      robot-frame origin (the middle of the wheel axle), its angle the heading. The wheel
      commands last given to ``act`` are applied by ``step`` (after each physics step for a
      free body, inside it through a chipmunk callback for a touching one:
      ``labsim.backends.pymunk.chipmunk.WheelDrives``), so code driving the scene by hand
      should call ``act`` and ``step``, or set its own ``velocity_func`` and step the space.
    """

    name = "pymunk"

    def __init__(self, substeps: int = 1) -> None:
        """``substeps``: physics steps per ``step()`` of a robot world, each dt_s / substeps long.

        The wheel commands are re-applied in every sub-step, so more sub-steps give steadier
        contacts and a finer arc when turning, at a proportional cost; sense() is unaffected.
        (A mechanism sets its own sub-steps: ``labsim.backends.pymunk.mechanism``.)
        """
        if not isinstance(substeps, int) or isinstance(substeps, bool) or substeps < 1:
            raise BackendError(
                f"pymunk backend: substeps must be a positive integer, not {substeps!r}"
            )
        self.substeps = substeps
        self.space: pymunk.Space | None = None
        self.bodies: list[pymunk.Body] = []
        self._sim: Simulator = _Shut("before open()")
        self._bind(self._sim)

    def open(self, world: World, robots: Sequence[RobotRequest], dt_s: float, seed: int) -> None:
        """Build the scene. ``seed`` is unused: nothing in this backend is random.

        A world with a mechanism opens a ``MechanismSimulator``, any other a ``FleetSimulator``.
        Either checks every request before it builds anything, so a bad one leaves no half
        scene and the backend can be opened again.
        """
        if self.space is not None:
            raise BackendStateError("pymunk backend: open() called twice; close() it first")
        if not dt_s > 0:
            raise BackendError(f"pymunk backend: dt_s must be positive, not {dt_s!r}")
        sim = (MechanismSimulator(world, world.mechanism, robots, dt_s) if world.mechanism is not None
               else FleetSimulator(world, robots, dt_s, self.substeps))
        self.space, self.bodies = sim.space, sim.bodies
        self._bind(sim)

    # --- the protocol's calls: the open simulator's own methods ---------------------------------
    # Bound straight to the simulator (or to the stand-in that raises before open and after
    # close), not wrapped: the runtime calls sense and step every tick, and a wrapping call
    # each would cost about 1% of a wall-lab tick.
    sense: Callable[[], list[list[object]]]
    act: Callable[[int, float, float], None]
    command: Callable[[int, str, str, float], None]  # a mechanism joint's target (see the protocol)
    step: Callable[[], None]
    pose: Callable[[int], tuple[float, float, float]]
    contacts: Callable[[int], ContactStats]  # still readable after close, for the run's summary

    def _bind(self, sim: Simulator) -> None:
        self._sim = sim
        self.sense, self.act, self.command = sim.sense, sim.act, sim.command
        self.step, self.pose, self.contacts = sim.step, sim.pose, sim.contacts

    def place(self, robot: int, x_m: float, y_m: float, heading_rad: float) -> str | None:
        """Put robot ``robot`` at a pose, at rest; None when done, or why it was refused
        (an overlap, or a world whose robots cannot be moved: a mechanism's)."""
        place = getattr(self._sim, "place", None)
        if place is None:
            return "this world has no robot to move"
        result: str | None = place(robot, x_m, y_m, heading_rad)
        return result

    def set_block(self, block: int, corners: tuple[tuple[float, float], ...] | None) -> str | None:
        """Put block ``block`` (a world's are numbered from 0 in file order; a new one takes the
        next number) at these corners, counter-clockwise, or remove it (None); None when done, or
        why it was refused (it would overlap a wall or a robot; a mechanism's world has none)."""
        set_block = getattr(self._sim, "set_block", None)
        if set_block is None:
            return "this world has no blocks to change"
        result: str | None = set_block(block, corners)
        return result

    def sonar_hit(self, robot: int, channel: str) -> tuple[float, float] | None:
        """Where a sonar robot ``robot`` reads detects something now: (distance m, direction of
        the ray of its cone that found it, rad counter-clockwise from its axis), or None
        (``labsim.backends.pymunk.fleet.FleetSimulator.sonar_hit``)."""
        hit = getattr(self._sim, "sonar_hit", None)
        return None if hit is None else cast("tuple[float, float] | None", hit(robot, channel))

    def close(self) -> None:
        if self.space is None:
            return
        # Freeing the space may fire separate callbacks; they only touch the simulator's lists.
        self._bind(_Shut("after close()", self._sim))
        self.space = None
        self.bodies = []
