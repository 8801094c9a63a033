"""A scripted backend for runtime tests: readings from a table, every call recorded."""
from __future__ import annotations

import math
from typing import Callable, Sequence

from labsim.backends.protocol import BackendStateError, ContactStats, RobotRequest
from labsim.backends.scene.world import World

Script = Callable[[int, int, str], object]  # (tick, robot index, channel) -> value


class FakeBackend:
    name = "fake"

    def __init__(self, script: Script | dict[str, list[object]]):
        if isinstance(script, dict):
            table = script
            self.script: Script = lambda tick, robot, ch: table[ch][min(tick, len(table[ch]) - 1)] if ch in table else math.inf
        else:
            self.script = script
        self.tick = 0
        self.acts: list[tuple[int, int, float, float]] = []  # tick, robot, left, right
        self.robots: list[RobotRequest] = []
        self.opened = False
        self.closed = False

    def open(self, world: World, robots: Sequence[RobotRequest], dt_s: float, seed: int) -> None:
        self.robots = list(robots)
        self.dt = dt_s
        self.opened = True

    def sense(self) -> list[list[object]]:
        if not self.opened or self.closed:
            raise BackendStateError("sense before open")
        out = []
        for i, r in enumerate(self.robots):
            row = []
            for ch in r.channels:
                if ch in ("x", "y", "heading"):
                    row.append(float(self.tick) if ch == "x" else 0.0)
                elif ch == "collided":
                    row.append(bool(self.script(self.tick, i, ch)) if ch != "collided" else False)
                else:
                    row.append(self.script(self.tick, i, ch))
            out.append(row)
        return out

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        self.acts.append((self.tick, robot, left_rad_s, right_rad_s))

    def step(self) -> None:
        self.tick += 1

    def pose(self, robot: int) -> tuple[float, float, float]:
        return (float(self.tick), 0.0, 0.0)

    def contacts(self, robot: int) -> ContactStats:
        return ContactStats(0, 0.0)

    def close(self) -> None:
        self.closed = True
