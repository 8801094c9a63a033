"""``labsim run --break COND``: the breakpoint language without a view, stopping a run.

The condition is compiled by ``labsim.dsl.watch`` exactly as a live view's breakpoint is (one
compiler, so ``min([sonar5, sonar2]) < 0.5`` and ``min(sonar5, sonar2) < 0.5`` stop on the
same tick). ``BreakObserver`` asks it after each robot acts, at the moment the view asks its
breakpoints (``after_act``: the tick's signals computed, its rule chosen, before a ``goto``
takes effect), and on the tick the stop condition held (``at_stop``, format 1.1 on: the tick
the trace's last row records, on which no rule acts): it sees every tick the trace has a row
for. On the first tick it holds for a robot it keeps that tick, the robot, its state and rule
and the values the condition read, and ends the run there. ``break_report`` is what the
command prints.
"""
from __future__ import annotations

from dataclasses import dataclass

from labsim.dsl.library.support import STATE
from labsim.dsl.watch import Watch
from labsim.foundation.inert import inert
from labsim.runtime.observers import Observer
from labsim.runtime.state import RobotRun, RunState


@dataclass(frozen=True)
class Hit:
    """The tick a breakpoint held on, and what it saw."""

    tick: int
    time_s: float
    robot: str
    state: str  # '' in a file without states
    rule: str | None  # the rule that fired on the tick, None when none held
    values: tuple[tuple[str, object], ...]  # each name the condition reads, and its value
    stopping: bool = False  # the tick the stop condition held on: no rule acts


class BreakObserver(Observer):
    """Ends the run on the first tick the condition holds for a robot, keeping that ``hit``."""

    def __init__(self, watch: Watch) -> None:
        self.watch = watch
        self.hit: Hit | None = None
        self.last: int | None = None  # the last tick it was asked on
        self._run: RunState | None = None

    def bind(self, run: RunState) -> None:
        self._run = run

    def after_act(self, robot: RobotRun, rule: int, values: list) -> None:
        self._ask(robot, rule, values, False)

    def at_stop(self, robot: RobotRun, values: list) -> None:
        self._ask(robot, -1, values, True)

    def _ask(self, robot: RobotRun, rule: int, values: list, stopping: bool) -> None:
        run = self._run
        if self.hit is not None or run is None:
            return
        t, dt, slots = run.tick_index, run.dt_s, robot.program.slots
        self.last = t
        if not self.watch.holds(t, dt, values, slots):
            return
        p = run.program
        self.hit = Hit(t, t * dt, robot.name, p.state_names[int(slots[STATE])] if p.state_names else "",
                       p.rules[rule].id if rule >= 0 else None, tuple(self.watch.values(t, dt, values, slots)),
                       stopping)
        run.finished = True  # the tick loop stops before the next tick


def break_report(condition: str, hit: Hit | None, last: int | None, dt_s: float) -> str:
    """What ``labsim run --break`` prints: where it stopped and what the condition read, or that it
    never held, on the ticks it was asked on (``last``: the last of them, None if none was)."""
    if hit is None:
        if last is None:
            return f"--break: '{inert(condition)}' was never asked: the run ended before a robot acted"
        return (f"--break: '{inert(condition)}' never held on ticks 0 to {last:,} "
                f"(0.00 s to {last * dt_s:.2f} s), where the run ended")
    if hit.stopping:
        rule = "  rule: none (the run's stop condition held on this tick: no rule acts on it)"
    else:
        rule = f"  rule: {hit.rule}" if hit.rule is not None else "  rule: none (no rule held on this tick)"
    lines = [f"--break: '{inert(condition)}' held at tick {hit.tick} ({hit.time_s:.2f} s) for robot {inert(hit.robot)}",
             f"  state: {inert(hit.state)}" if hit.state else "  state: (the file has no states)", rule]
    width = max((len(n) for n, _ in hit.values), default=0)
    lines += [f"  {n.ljust(width)} = {_shown(v)}" for n, v in hit.values]
    return "\n".join(lines)


def _shown(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, tuple):  # a group's members
        return "[" + ", ".join(_shown(v) for v in value) + "]"
    return inert(str(value))
