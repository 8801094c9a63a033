"""What a bound run holds that its tick and its observers read: each robot's ``RobotRun``,
and ``RunState``, the part of a ``Run`` (``labsim.runtime.run``) they may touch.

Its own module so that the tick core (``labsim.runtime.tick``) and the observers
(``labsim.runtime.observers``) read a run without importing the module that builds it.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

from labsim.backends.scene.models import RobotModel
from labsim.backends.scene.world import Pose
from labsim.dsl.emit.program import Program, RobotProgram
from labsim.dsl.syntax.noise import Noise


@dataclass
class RobotRun:
    """A robot during a run: its compiled program and what the runtime tracks for it."""

    index: int
    name: str
    model: RobotModel | None  # None: the world's mechanism
    program: RobotProgram
    limit: float  # wheel speed limit, rad/s
    start: Pose  # where it was placed
    sent_left: float = math.nan  # the last command sent to the backend, rad/s
    sent_right: float = math.nan
    sent_joints: list[float] = field(default_factory=list)  # per Program.targets
    clamping: bool = False  # whether the command now held exceeds the limit
    clamped_ticks: int = 0
    paths: tuple[tuple[str, str], ...] = ()  # the behaviour file's scene names for it
    noise: Noise | None = None  # its declared noise (labsim.runtime.noise), None: none


class RunState(Protocol):
    """A bound run, as its tick and observers see it (``labsim.runtime.run.Run`` is one)."""

    program: Program
    robots: list[RobotRun]
    channels: tuple[str, ...]  # what each robot's readings hold: the program's, then the trace's
    dt_s: float
    tick_index: int
    finished: bool
    stopped_by: str | None
    stop_part: int
    fired: list[int]  # rule -> ticks it acted
    idle: int  # robot-ticks on which no rule held
    sense: Callable[[], list[list]]
    step: Callable[[], None]
    peers: list[tuple]  # format 1.3: what each robot reads of the others (Program.peer_start), last tick's

    def send(self, r: RobotRun, left: float, right: float, rule: int) -> None: ...
