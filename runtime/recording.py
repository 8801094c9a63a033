"""A run recorded in memory: each robot's pose, state, rule and events a tick, for its pictures.

An observer of the tick loop (``labsim.runtime.observers``), beside the trace writer: where a
picture of a run is drawn in the process that ran it (a feedback page of ``labsim grade``), the
run need not write a CSV trace to be read back. ``Recording`` keeps one row of numbers a robot a tick
(the trace's pose columns, read for it as for a trace, and its state and rule; the rare events
apart) and gives them as a ``Trace`` whose tick, time and pose columns are numbers only (``Trace.numbers``),
which the pictures read as they read a trace file's. It records nothing a behaviour's own
columns hold, nor labels or sliders: a run that needs them (a mechanism's joints) is traced.
"""
from __future__ import annotations

import operator

import numpy as np

from labsim.dsl.library.support import STATE
from labsim.runtime.observers import TRACE_POSE, Observer, events_cell
from labsim.runtime.state import RobotRun, RunState
from labsim.runtime.trace import Trace

COLUMNS = ["tick", "time", "robot", *TRACE_POSE, "state", "rule", "events"]
WIDTH = 8  # numbers a row: tick, robot, x, y, heading, collided, state, rule


class Recording(Observer):
    """Every robot's row a tick, in memory; ``trace(path, header)`` once the run is over."""

    reads = TRACE_POSE

    def bind(self, run: RunState) -> None:
        self.run = run
        self._pose = operator.itemgetter(*(run.channels.index(c) for c in TRACE_POSE))  # x, y, heading, collided
        # one robot's tick: (tick, robot, x, y, heading, collided, state, rule), flat in one list of
        # numbers (one call a tick, and one array at the end), turned to names only when drawn
        self.numbers: list[float] = []
        self._put = self.numbers.extend
        self.events: dict[int, str] = {}  # row -> its events cell, for the rows that have one

    def after_act(self, robot: RobotRun, rule: int, values: list) -> None:
        prog = robot.program
        if prog.events:
            self.events[len(self.numbers) // WIDTH] = events_cell(self.run.program, prog.events)
        self._put((self.run.tick_index, robot.index, *self._pose(values), prog.slots[STATE], rule))

    def at_stop(self, robot: RobotRun, values: list) -> None:
        self.after_act(robot, -1, values)

    def trace(self, path: str, header: dict) -> Trace:
        """The rows so far as a trace of ``path`` with ``header`` (the run's): the tick, time and
        pose in ``Trace.numbers``, the robot, state, rule and events in its rows (whose number
        cells are left empty, as ``Trace.numbers`` says)."""
        p = self.run.program
        names = [r.name for r in self.run.robots]
        states = list(p.state_names) or [""]
        rules = [r.id for r in p.rules] + [""]  # [-1]: no rule held, or the stop row
        numbers = np.array(self.numbers, dtype=float).reshape(-1, WIDTH)
        time_s = np.round(numbers[:, 0] * self.run.dt_s, 9)
        robots, texts = numbers[:, 1].astype(int).tolist(), numbers[:, 6:8].astype(int).tolist()
        events = self.events
        rows = [["", "", names[k], "", "", "", "", states[state], rules[rule], ""]
                for k, (state, rule) in zip(robots, texts)]
        for i, cell in events.items():
            rows[i][-1] = cell
        columns = dict(zip(("tick", "time", *TRACE_POSE), (numbers[:, 0], time_s, *numbers[:, 2:6].T)))
        return Trace(path, header, list(COLUMNS), rows, numbers=columns)
