"""Messages between robots (format 1.3): what each robot said this tick, delivered after the tick.

A rule's ``say(channel, value[, range_m])`` writes the robot's outbox (``RobotProgram.outbox``);
once every robot has acted, ``make_delivery``'s ``deliver`` hands each channel's values to every
other robot within range, into its inbox, which ``heard(channel)`` reads on the next tick
(docs/language.md, "Other robots and messages"). What is delivered depends on this tick's
values only, never on the order the robots acted in: a robot hearing several robots on one
channel hears the nearest, and of two as near the first in the file's order. A robot does not
hear itself. The outboxes are emptied after each delivery, so a value is heard once and then
kept by the listener until something new is heard.
"""
from __future__ import annotations

import math
from collections.abc import Callable

from labsim.runtime.state import RobotRun, RunState


def make_delivery(run: RunState) -> Callable[[], None] | None:
    """``deliver()`` for a run whose behaviour says something; None (and no cost) for any other."""
    p = run.program
    if not p.said:
        return None
    robots: list[RobotRun] = run.robots
    x, y = p.slot_of["x"], p.slot_of["y"]  # the checker reads the pose when a rule says something
    outs = [r.program.outbox for r in robots]
    reaches = [r.program.reach for r in robots]
    ins = [r.program.inbox for r in robots]
    slots = [r.program.slots for r in robots]
    channels = range(len(p.said))
    nan = math.nan

    def deliver() -> None:
        for k in channels:
            sayers = [j for j, out in enumerate(outs) if out[k] == out[k]]
            if not sayers:
                continue
            for i, inbox in enumerate(ins):
                xi, yi = slots[i][x], slots[i][y]
                best, nearest = -1, math.inf
                for j in sayers:
                    if j != i:
                        d = math.hypot(slots[j][x] - xi, slots[j][y] - yi)
                        if d <= reaches[j][k] and (best < 0 or d < nearest):
                            best, nearest = j, d
                if best >= 0:
                    inbox[k] = outs[best][k]
            for j in sayers:
                outs[j][k] = nan

    return deliver
