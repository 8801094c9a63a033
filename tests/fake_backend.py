"""A scripted backend for runtime tests: readings from a table, collisions at given ticks, every
call recorded."""
from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence

from labsim.backends.protocol import BackendError, BackendStateError, ContactStats, RobotRequest
from labsim.backends.scene.world import World

Script = Callable[[int, int, str], object]  # (tick, robot index, channel) -> value


class FakeBackend:
    """Readings come from ``script``; nothing moves.

    * ``x`` reads the tick number, ``y`` and ``heading`` 0, and ``pose()`` agrees.
    * ``collided`` reads True at the ticks ``touching[robot]`` lists, and ``contacts()``
      counts as the simulators do: a contact begins at a touching tick that follows a free one
      (or is tick 0), and each step that ends on a touching tick adds dt to the contact time.
    * every other channel is ``script(tick, robot, channel)``, or, for a table, the channel's
      list at the tick (its last value once the list runs out; ``math.inf`` if not in the table).

    ``acts`` and ``commands`` record what the runtime sent, with the tick it was sent at; a
    command must name a motorised joint of the world's mechanism, in a mode it accepts.
    """

    name = "fake"

    def __init__(self, script: Script | dict[str, list[object]],
                 touching: Mapping[int, Iterable[int]] | None = None):
        if isinstance(script, dict):
            table = script
            self.script: Script = lambda tick, robot, ch: (
                table[ch][min(tick, len(table[ch]) - 1)] if ch in table else math.inf)
        else:
            self.script = script
        self.touching = {robot: frozenset(ticks) for robot, ticks in (touching or {}).items()}
        self.tick = 0
        self.acts: list[tuple[int, int, float, float]] = []  # tick, robot, left, right
        self.commands: list[tuple[int, int, str, str, float]] = []  # tick, robot, joint, mode, value
        self.robots: list[RobotRequest] = []
        self.joints: dict[str, frozenset[str]] = {}  # the mechanism's motorised joints and their modes
        self.dt = 0.0
        self.opened = False
        self.closed = False

    def _check(self, call: str) -> None:
        if not self.opened or self.closed:
            raise BackendStateError(f"fake backend: {call}() called before open() or after close()")

    def _touches(self, robot: int, tick: int) -> bool:
        return tick in self.touching.get(robot, ())

    def open(self, world: World, robots: Sequence[RobotRequest], dt_s: float, seed: int) -> None:
        self.robots = list(robots)
        self.joints = world.mechanism.motor_modes() if world.mechanism is not None else {}
        self.dt = dt_s
        self.tick = 0
        self.opened = True
        self.closed = False

    def sense(self) -> list[list[object]]:
        self._check("sense")
        out = []
        for i, r in enumerate(self.robots):
            row: list[object] = []
            for ch in r.channels:
                if ch in ("x", "y", "heading"):
                    row.append(float(self.tick) if ch == "x" else 0.0)
                elif ch == "collided":
                    row.append(self._touches(i, self.tick))
                else:
                    row.append(self.script(self.tick, i, ch))
            out.append(row)
        return out

    def act(self, robot: int, left_rad_s: float, right_rad_s: float) -> None:
        self._check("act")
        self.acts.append((self.tick, robot, left_rad_s, right_rad_s))

    def command(self, robot: int, joint: str, mode: str, value: float) -> None:
        self._check("command")
        if self.robots[robot].model is not None or mode not in self.joints.get(joint, ()):
            raise BackendError(f"fake backend: '{self.robots[robot].name}' has no joint '{joint}' "
                               f"that takes {mode} targets")
        self.commands.append((self.tick, robot, joint, mode, value))

    def step(self) -> None:
        self._check("step")
        self.tick += 1

    def pose(self, robot: int) -> tuple[float, float, float]:
        self._check("pose")
        return (float(self.tick), 0.0, 0.0)

    def contacts(self, robot: int) -> ContactStats:
        if not self.opened:
            raise BackendStateError("fake backend: contacts() called before open()")
        ticks = range(self.tick + 1)
        begun = sum(1 for t in ticks if self._touches(robot, t) and (t == 0 or not self._touches(robot, t - 1)))
        touched = sum(1 for t in ticks if t > 0 and self._touches(robot, t))
        return ContactStats(begun, touched * self.dt)

    def close(self) -> None:
        self.closed = True
