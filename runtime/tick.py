"""The tick core: one tick of a bound run, built once from the run and its observers.

A tick is, for every robot at once:

1. ``before_tick`` observers (inputs move sliders);
2. sense: the backend returns one consistent snapshot of every channel the behaviour reads;
3. the ``let`` signals are evaluated in order;
4. the stop condition: when it holds for any robot, the run ends before acting (in format 1.1
   the stopping tick is still folded into metrics and shown to ``at_stop`` observers);
5. decide: the first rule of the robot's current state whose condition holds;
6. act: wheel commands are clamped to the model's limit (and counted) and sent only when they
   change; ``after_act`` observers (joint commands, the trace, the log printer, a watcher);
7. the robot's events are cleared and its ``goto`` takes effect (the next tick uses the new
   state); the backend steps ``dt``. When robots read each other (format 1.3), what they read
   next tick (``RunState.peers``) is kept before anyone acts and replaced once all have, and what
   they said is delivered (``labsim.runtime.radio``): such a run takes the fleet's path even
   with one robot.

The tick is a closure over locals, as the hot path: an attribute lookup per robot per tick
costs as much as a rule. A fleet senses and evaluates every robot's signals before any robot
acts, so that the stop condition can end the run before anyone acts; a single robot does
both in one generated function, and a robot with wheels runs its common tick (a rule acted,
no events) inline: ``act``'s steps written out in its order, the ``after_act`` observers
included, so that an observer costs its own call and not also one of ``act``.
"""
from __future__ import annotations

from collections.abc import Callable

from labsim.dsl.library.support import STATE
from labsim.runtime.observers import Hooks
from labsim.runtime.radio import make_delivery
from labsim.runtime.state import RobotRun, RunState

Hook = Callable[..., None]
Act = Callable[["RobotRun", list, list, list, int, list], None]


def make_tick(run: RunState, hooks: Hooks) -> Callable[[], bool]:
    """``tick()`` for ``run``: one tick, False once the stop condition has held (or had)."""
    before, after, at_stop = hooks.before_tick, hooks.after_act, hooks.at_stop
    act = _make_act(run, after)
    fold_stop = run.program.fold_stop
    n = len(run.program.channels)

    def stop(robots: list[RobotRun], readings: list[list]) -> bool:
        """The stopping tick (format 1.1): sensed, folded into metrics, shown; no rule acts."""
        run.finished = True
        if fold_stop:
            t = run.tick_index
            for r in robots:
                values = readings[r.index]
                r.program.fold(t * run.dt_s, t, values if len(values) == n else values[:n])
                for h in at_stop:
                    h(r, values)
                r.program.events.clear()
        return False

    if len(run.robots) == 1 and not run.program.peer_fields and not run.program.said:
        return _single(run, before, act, stop, after, inline=run.robots[0].model is not None)
    return _fleet(run, before, act, stop)


def _make_act(run: RunState, after: tuple[Hook, ...]) -> Act:
    fired, send = run.fired, run.send

    def act(r: RobotRun, s: list, cmd: list, events: list, rule: int, values: list) -> None:
        if rule >= 0:
            fired[rule] += 1
        else:
            run.idle += 1
        if r.model is not None and (cmd[0] != r.sent_left or cmd[1] != r.sent_right):
            send(r, cmd[0], cmd[1], rule)
        if r.clamping:
            r.clamped_ticks += 1
        for h in after:
            h(r, rule, values)
        if events:
            events.clear()
        s[STATE] = cmd[2]  # a goto takes effect from the next tick

    return act


def _single(run: RunState, before: tuple[Hook, ...], act: Act, stop: Callable[[list, list], bool],
            after: tuple[Hook, ...], *, inline: bool) -> Callable[[], bool]:
    """One robot: signals, stop and decision in one generated call (``both``); the common tick (a
    rule acted, no events) inline, ``act``'s steps in its order, so that an observer (a feedback
    page's recording) does not also cost a call of ``act`` a tick."""
    r1 = run.robots[0]
    s1, cmd1, events1, both = r1.program.slots, r1.program.command, r1.program.events, r1.program.both
    sense, step, send, fired = run.sense, run.step, run.send, run.fired
    n, dt = len(run.program.channels), run.dt_s
    # a single hook of a kind (a live view's inputs, its recorder) called as it is, not through a loop
    before1 = before[0] if len(before) == 1 else None
    after1 = after[0] if len(after) == 1 else None

    def tick_one() -> bool:
        if run.finished:
            return False
        t = run.tick_index
        if before1 is not None:
            before1(t)
        else:
            for h in before:
                h(t)
        values = sense()[0]
        rule = both(t * dt, t, values if len(values) == n else values[:n])
        if rule == -2:
            run.stopped_by = r1.name
            run.stop_part = r1.program.stop_part[0]
            return stop(run.robots, [values])
        if rule >= 0 and inline and not events1:
            fired[rule] += 1  # the common case, as act() does it
            if cmd1[0] != r1.sent_left or cmd1[1] != r1.sent_right:
                send(r1, cmd1[0], cmd1[1], rule)
            if r1.clamping:
                r1.clamped_ticks += 1
            if after1 is not None:
                after1(r1, rule, values)
            else:
                for h in after:
                    h(r1, rule, values)
            s1[STATE] = cmd1[2]
        else:
            act(r1, s1, cmd1, events1, rule, values)
        step()
        run.tick_index = t + 1
        return True

    return tick_one


def _fleet(run: RunState, before: tuple[Hook, ...], act: Act, stop: Callable[[list, list], bool]) -> Callable[[], bool]:
    """Several robots: every robot's signals (and the stop condition) before anyone acts."""
    robots = [(r.program.slots, r.program.signals, r.program.decide, r.program.command, r.program.events, r)
              for r in run.robots]
    sense, step = run.sense, run.step
    n, dt = len(run.program.channels), run.dt_s
    peers, kept = run.peers, run.program.peer_slots
    deliver = make_delivery(run)

    def tick() -> bool:
        if run.finished:
            return False
        t = run.tick_index
        for h in before:
            h(t)
        now = t * dt
        readings = sense()
        held: RobotRun | None = None
        for _, signals, _, _, _, r in robots:
            values = readings[r.index]
            if signals(now, t, values if len(values) == n else values[:n]) and held is None:
                held = r
        if held is not None:
            run.stopped_by = held.name
            run.stop_part = held.program.stop_part[0]
            return stop(run.robots, readings)
        # what the others read of each robot next tick (format 1.3): its values of this tick, before
        # any robot acts or its goto takes effect, so that the order robots act in does not matter
        now_kept = [tuple([r[0][i] for i in kept]) for r in robots] if kept else None
        for s, _, decide, cmd, events, r in robots:
            act(r, s, cmd, events, decide(), readings[r.index])
        if now_kept is not None:
            peers[:] = now_kept
        if deliver is not None:
            deliver()
        step()
        run.tick_index = t + 1
        return True

    return tick
