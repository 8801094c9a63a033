"""A run recorded in memory: each robot's pose, state, rule and events a tick, for its pictures.

An observer of the tick loop (``labsim.runtime.observers``), beside the trace writer: where a
picture of a run is drawn in the process that ran it (a feedback page of ``labsim grade``), the
run need not write a CSV trace to be read back. ``Recording`` keeps one tuple a robot a tick
(the trace's pose columns, read for it as for a trace, and its state, rule and events) and
gives them as a ``Trace`` whose pose and time columns are already numbers (``Trace.numbers``),
which the pictures read as they read a trace file's. It records nothing a behaviour's own
columns hold, nor labels or sliders: a run that needs them (a mechanism's joints) is traced.
"""
from __future__ import annotations

import numpy as np

from labsim.dsl.support import STATE
from labsim.runtime.observers import TRACE_POSE, Observer, events_cell
from labsim.runtime.state import RobotRun, RunState
from labsim.runtime.trace import Trace

COLUMNS = ["tick", "time", "robot", *TRACE_POSE, "state", "rule", "events"]


class Recording(Observer):
    """Every robot's row a tick, in memory; ``trace(path, header)`` once the run is over."""

    reads = TRACE_POSE

    def bind(self, run: RunState) -> None:
        self.run = run
        self.at = [run.channels.index(c) for c in TRACE_POSE]
        # one robot's tick: (tick, robot, x, y, heading, collided) into ``numbers``, flat (one list
        # of floats makes one array at the end at once), and (state, rule) into ``texts``
        self.numbers: list[float] = []
        self.texts: list[tuple[int, int]] = []
        self.events: dict[int, str] = {}  # row -> its events cell, for the rows that have one

    def after_act(self, robot: RobotRun, rule: int, values: list) -> None:
        x, y, heading, collided = self.at
        prog = robot.program
        if prog.events:
            self.events[len(self.texts)] = events_cell(self.run.program, prog.events)
        self.numbers.extend((self.run.tick_index, robot.index, values[x], values[y], values[heading],
                             values[collided]))
        self.texts.append((int(prog.slots[STATE]), rule))

    def at_stop(self, robot: RobotRun, values: list) -> None:
        self.after_act(robot, -1, values)

    def trace(self, path: str, header: dict) -> Trace:
        """The rows so far as a trace of ``path`` with ``header`` (the run's): the numbers in
        ``Trace.numbers``, the texts (robot, state, rule, events, and the time) in its rows."""
        p = self.run.program
        names = [r.name for r in self.run.robots]
        states = list(p.state_names) or [""]
        rules = [r.id for r in p.rules] + [""]  # [-1]: no rule held, or the stop row
        numbers = np.array(self.numbers, dtype=float).reshape(-1, 6)
        time_s = np.round(numbers[:, 0] * self.run.dt, 9)
        ticks, robots = numbers[:, 0].astype(int).tolist(), numbers[:, 1].astype(int).tolist()
        events = self.events
        rows = [[str(t), repr(s), names[k], "", "", "", "", states[state], rules[rule], events.get(i, "")]
                for i, (t, s, k, (state, rule)) in enumerate(zip(ticks, time_s.tolist(), robots, self.texts))]
        columns = dict(zip(("tick", "time", *TRACE_POSE), (numbers[:, 0], time_s, *numbers[:, 2:6].T)))
        return Trace(path, header, list(COLUMNS), rows, numbers=columns)
