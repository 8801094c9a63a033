"""The boundary between the runtime and a simulator.

The runtime drives a backend through this protocol and nothing else: it never imports pymunk
or the ZMQ client, and backends never import the language. A tick is::

    readings = backend.sense()          # one consistent snapshot, every robot
    backend.act(i, left, right)         # for each robot whose command changed
    backend.step()                      # advance dt_s

Units: metres, radians, seconds, wheel velocities in rad/s. The runtime clamps wheel commands
to the model's limit before ``act``, so every backend receives commands it can carry out.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from labsim.backends.scene.models import RobotModel
from labsim.backends.scene.world import Pose, World


class BackendError(Exception):
    """A backend could not do what was asked (unreachable server, broken world, ...).

    The message is for the user: it says what failed and what to do about it.
    """


class BackendStateError(BackendError):
    """A call in the wrong order, such as ``step`` before ``open`` or after ``close``."""


@dataclass(frozen=True)
class RobotRequest:
    """One robot the runtime wants in the world."""

    name: str  # as in traces: "pioneer", or "pioneer[2]" in a fleet; the world's name for a mechanism
    model: RobotModel | None  # None: the world's mechanism (its joints, force sensors and bodies)
    pose: Pose  # where it starts (unused for a mechanism)
    channels: tuple[str, ...]  # what sense() returns for it, in this order
    # Names of the robot's objects in a simulator's scene, overriding the backend's defaults
    # for the model (CoppeliaSim: {"robot": "/MyPioneer", "left_motor": "./leftMotor", ...}).
    paths: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        # one slot per channel: a name asked twice would leave one of its slots unread
        twice = sorted({c for c in self.channels if self.channels.count(c) > 1})
        if twice:
            raise ValueError(f"robot '{self.name}' asks for channel(s) {', '.join(twice)} twice")


@dataclass(frozen=True)
class ContactStats:
    count: int  # contacts begun with walls, blocks or other robots
    time_s: float  # simulated time spent touching something


class Backend(Protocol):
    name: str

    def open(self, world: World, robots: Sequence[RobotRequest], dt_s: float, seed: int) -> None:
        """Build the scene. ``seed`` seeds any randomness the backend itself has."""

    def sense(self) -> list[list[object]]:
        """One list per robot, the values of its requested channels in order.

        Distances read ``math.inf`` when nothing is detected; ``collided`` is a bool that is
        true while the robot touches something; ``x``, ``y``, ``heading`` are its pose. For a
        mechanism: a joint reads (position, velocity), a force sensor (tension N,), a body
        (x, z, angle) in the mechanism's plane; ``x``, ``y`` are the last body's position in the
        plane (x along, y up) and ``heading`` the slew angle, so that a trace can follow it.
        """

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        """Set the wheels' target velocities; they hold until the next ``act``."""

    def command(self, robot: int, joint: str, mode: str, value: float) -> None:
        """Set a mechanism joint's target: mode "velocity" (m/s or rad/s) or "position" (m or rad).

        The target holds until the next command for the same joint.
        """

    def step(self) -> None:
        """Advance the simulation by dt_s."""

    def pose(self, robot: int) -> tuple[float, float, float]:
        """x_m, y_m, heading_rad of a robot now."""

    def contacts(self, robot: int) -> ContactStats:
        """Contacts so far."""

    def close(self) -> None:
        """Release the scene; safe to call twice."""
