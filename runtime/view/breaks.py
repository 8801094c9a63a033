"""Breakpoints of a live view: the moments a run pauses on, from the page or ``--break``.

One written form for the page and the command line: ``state`` (a robot's state changes),
``state:follow`` (it changes to ``follow``), ``rule:r3`` (rule r3 fires), ``time:12.5`` (the
first tick at or after 12.5 s) or a condition of the language (``sonar5 < 0.3``), compiled and
checked by ``labsim.dsl.watch`` as the stop condition is, which pauses the run on the tick it
becomes true. ``TickRecorder`` (``labsim.runtime.view.record``) asks every ``Breakpoint.hit``
after every robot acts, so that a condition's "became true" is seen on its tick even when
another breakpoint holds on the same one; the live session stops ticking on the tick one holds,
and the pause names each that did. ``state:NAME`` holds on the first tick run in that state.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from labsim.dsl.emit.program import Program
from labsim.dsl.library.support import STATE
from labsim.dsl.watch import Watch, compile_watch
from labsim.foundation.diagnostics import Diagnostic, LabsimError, did_you_mean
from labsim.runtime.state import RobotRun

MAX_BREAKPOINTS = 20  # a page's list; more is a mistake (and a tick's cost)


@dataclass
class Breakpoint:
    """One breakpoint, bound to a compiled program. ``held`` is, per robot, whether its
    condition held on the last tick (a condition pauses when it becomes true); ``states`` its
    state on the last tick (a state breakpoint pauses on the first tick of a new one)."""

    spec: str  # as written
    kind: str  # "state", "rule", "when"
    target: int = -1  # the state's or rule's index; -1: any state
    watch: Watch | None = None
    held: list[bool] = field(default_factory=list)
    states: list[int | None] = field(default_factory=list)

    def hit(self, robot: RobotRun, rule: int, values: list, tick: int, dt_s: float) -> bool:
        """Whether the run pauses on this tick, for this robot (after it acted)."""
        if self.kind == "rule":
            return rule == self.target
        slots, i = robot.program.slots, robot.index
        if len(self.held) <= i:
            self.held += [False] * (i + 1 - len(self.held))
            self.states += [None] * (i + 1 - len(self.states))
        if self.kind == "state":  # the first tick run in the state (a goto on the tick before set it)
            state = int(slots[STATE])
            was, self.states[i] = self.states[i], state
            return was is not None and state != was and (self.target < 0 or state == self.target)
        assert self.watch is not None
        now = self.watch.holds(tick, dt_s, values, slots)
        was, self.held[i] = self.held[i], now
        return now and not was


def parse_break(program: Program, spec: str, where: str = "--break") -> Breakpoint:
    """A breakpoint from its written form (see the module docstring); LabsimError says why not."""
    spec = spec.strip()
    head, _, rest = spec.partition(":")
    head, rest = head.strip(), rest.strip()
    if spec == "state":
        return Breakpoint(spec, "state")
    if head == "state" and rest:
        return Breakpoint(spec, "state", _index(rest, program.state_names, "state", where))
    if head == "rule" and rest:
        return Breakpoint(spec, "rule", _index(rest, tuple(r.id for r in program.rules), "rule", where))
    if head == "time" and rest:
        try:
            at = float(rest)
        except ValueError:
            at = math.nan
        if not math.isfinite(at) or at < 0:
            raise LabsimError([Diagnostic(where, f"time:{rest[:40]}: a time in seconds, 0 or more")])
        return Breakpoint(spec, "when", watch=compile_watch(program, f"time >= {at!r}", where))
    return Breakpoint(spec, "when", watch=compile_watch(program, spec, where))


def _index(name: str, names: tuple[str, ...], what: str, where: str) -> int:
    if name in names:
        return names.index(name)
    hint = did_you_mean(name, names)
    raise LabsimError([Diagnostic(where, f"no {what} '{name[:60]}'{hint}",
                                  notes=(f"the {what}s: {', '.join(names) or '(none)'}",))])
