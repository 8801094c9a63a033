"""What a live view sees of a run: a backend wrapped to keep each tick's readings.

``labsim view`` binds a compiled behaviour to an ``ObservedBackend`` instead of the backend
itself. The run cannot tell the difference: every call goes through to the real backend
(``sense``, ``act`` and ``step`` are the backend's own, unwrapped: they are called every
tick). The wrapper adds what the page draws and the behaviour may not read (a robot's pose, a
mechanism's every moving body and joint) to the channels the run asks for, holds each robot's
readings of the last tick run (``last``, written by the view's recorder as each robot acts,
``labsim.runtime.view.record``) and the joint targets the run last commanded. The added
channels sit between the behaviour's own channels and the ones a trace asks for, so the
run's view of its readings (the first ``len(program.channels)`` values, and the trace's
last four) is unchanged.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

from labsim.backends.protocol import Backend, ContactStats, RobotRequest
from labsim.backends.scene.world import World

ROBOT_EXTRA = ("x", "y", "heading", "collided")  # a robot's pose, drawn on the canvas


def mechanism_extra(world: World) -> tuple[str, ...]:
    """A mechanism's channels the view draws: every joint but the fixed ones, every force
    sensor and every moving body (see ``Mechanism.channels``)."""
    return tuple(world.mechanism.channels()) if world.mechanism is not None else ()


class ObservedBackend:
    """A backend that remembers what the run read and commanded; see the module docstring.

    ``index[i][name]`` is where channel ``name`` sits in robot i's readings.
    """

    def __init__(self, inner: Backend, program_channels: Sequence[str]):
        self.inner = inner
        self.name = getattr(inner, "name", "?")
        self._n = len(program_channels)
        self.last: list[list[object] | None] = []  # per robot; None before its first tick
        self.index: list[dict[str, int]] = []
        self.targets: dict[str, tuple[str, float]] = {}  # joint -> (mode, value) last commanded

    def open(self, world: World, robots: Sequence[RobotRequest], dt_s: float, seed: int) -> None:
        out = []
        self.index = []
        for req in robots:
            # what the view draws goes after everything the run asked for, so that the run
            # finds its channels (the behaviour's, then the trace's) where it put them;
            # a channel asked twice would be read twice
            wanted = ROBOT_EXTRA if req.model is not None else mechanism_extra(world)
            channels = list(req.channels) + [c for c in wanted if c not in req.channels]
            self.index.append({c: i for i, c in enumerate(channels)})
            out.append(replace(req, channels=tuple(channels)))
        self.inner.open(world, out, dt_s, seed)
        self.last = [None] * len(robots)
        # called every tick and nothing to keep of them: the backend's own, without a wrapping call
        self.sense, self.act, self.step = self.inner.sense, self.inner.act, self.inner.step  # type: ignore[method-assign]

    def sense(self) -> list[list[object]]:
        return self.inner.sense()

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        self.inner.act(robot, left_rad_s, right_rad_s)

    def command(self, robot: int, joint: str, mode: str, value: float) -> None:
        self.targets[joint] = (mode, value)
        self.inner.command(robot, joint, mode, value)

    def step(self) -> None:
        self.inner.step()

    def pose(self, robot: int) -> tuple[float, float, float]:
        return self.inner.pose(robot)

    def place(self, robot: int, x_m: float, y_m: float, heading_rad: float) -> str | None:
        """Put a robot at a pose (a drag); why not, when the backend refuses or cannot."""
        place = getattr(self.inner, "place", None)
        if place is None:
            return f"the {self.name} backend cannot move a robot"
        result: str | None = place(robot, x_m, y_m, heading_rad)
        row = self.last[robot] if self.last else None
        if result is None and row is not None:  # the page draws it there before the next tick senses
            at = self.index[robot]
            row = self.last[robot] = list(row)  # a copy: the tick's own readings stay as they were read
            for channel, value in zip(("x", "y", "heading"), self.inner.pose(robot)):
                if channel in at:
                    row[at[channel]] = value
        return result

    def set_block(self, block: int, corners: tuple[tuple[float, float], ...] | None) -> str | None:
        """Move, add or remove a block (a drag); why not, when the backend refuses or cannot."""
        set_block = getattr(self.inner, "set_block", None)
        if set_block is None:
            return f"the {self.name} backend cannot move, add or remove blocks"
        result: str | None = set_block(block, corners)
        return result

    def contacts(self, robot: int) -> ContactStats:
        return self.inner.contacts(robot)

    def close(self) -> None:
        self.inner.close()

    def reading(self, robot: int, channel: str) -> object:
        """The last value of a channel for a robot, or None before the first tick."""
        row = self.last[robot] if self.last else None
        i = self.index[robot].get(channel)
        return None if i is None or row is None else row[i]
