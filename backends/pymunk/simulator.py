"""What the pymunk backend's two simulators share: the calls they answer, and two helpers.

``labsim.backends.pymunk.backend.PymunkBackend`` opens one of two simulators for a world and
passes every protocol call on to it: ``labsim.backends.pymunk.fleet.FleetSimulator`` (rovers
seen from above: walls, blocks, sonars, cameras, roads, contacts) or
``labsim.backends.pymunk.mechanism.MechanismSimulator`` (a world's mechanism seen from the
side, such as the tower crane). ``Simulator`` is what both answer; the helpers are the heading
wrap both report poses with, and the contact slop both spaces use.
"""
from __future__ import annotations

from typing import Protocol

from labsim.backends.protocol import ContactStats

# Allowed overlap between shapes, metres. pymunk's default (0.1) assumes pixels; in metres it
# would let a robot sink 10 cm into a wall, or a load into the floor.
COLLISION_SLOP_M = 0.0005

class Simulator(Protocol):
    """An open scene: the protocol's calls after ``open`` (see ``labsim.backends.protocol``).

    A simulator is built open, by its constructor, and has no ``close``: the backend drops it.
    ``contacts`` must keep answering after that, for the run's summary.
    """

    def sense(self) -> list[list[object]]: ...

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None: ...

    def command(self, robot: int, joint: str, mode: str, value: float) -> None: ...

    def step(self) -> None: ...

    def pose(self, robot: int) -> tuple[float, float, float]: ...

    def contacts(self, robot: int) -> ContactStats: ...
