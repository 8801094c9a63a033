"""Where each of a robot's values lives: the slot layout, between the checker and the code generator.

A robot's values for a tick are one list, its ``Slots`` (``labsim.dsl.library.support``): time, tick
and state, then the channels the behaviour reads, its signals, its sliders and its sliders'
label fields, then the per-tick variables and per-robot constants it reads. ``layout`` numbers
them for a checked behaviour; ``labsim.dsl.emit.codegen`` writes code that reads slot N as the
local ``vN``, and ``labsim.dsl.emit.program`` fills the slots a robot starts with.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

from labsim.dsl.analysis.check import Checked
from labsim.dsl.analysis.messages import heard_slot
from labsim.dsl.emit.program import LabelPart, SharedLabel
from labsim.dsl.library.builtins import JOINT_ACTIONS, READ_BACK, STATE_CLOCK
from labsim.dsl.library.support import FIRST_CHANNEL, STATE, TICK, TIME
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.read import Parsed


@dataclass(frozen=True)
class Layout:
    """Where each value lives in a robot's slots, and the joint targets in command order."""

    slot_of: Mapping[str, int]  # time, tick, state, channels, signals, sliders -> slot
    slot_count: int
    labels: tuple[tuple[str, tuple[LabelPart, ...]], ...]  # label -> text and (slot, format spec)
    label_fields: tuple[tuple[int, str, Parsed], ...]  # slot, slider, the field's expression
    targets: tuple[tuple[str, str], ...]  # (joint, "velocity" | "position")
    shared_labels: tuple[SharedLabel, ...] = ()  # labels several sliders write, and their slots
    # a group signal's members: their slots, or None when the group only names values that have
    # slots or are constants (sonar1..sonar8), which its uses read directly
    members: Mapping[str, tuple[int, ...] | None] = field(default_factory=lambda: MappingProxyType({}))


def layout(c: Checked) -> Layout:
    """Slots: time, tick, state, the channels, the signals, the sliders, then the label fields."""
    slot_of = {"time": TIME, "tick": TICK, "state": STATE}
    slot_of.update({name: FIRST_CHANNEL + i for i, name in enumerate(c.channels)})
    for i, (name, _) in enumerate(c.lets):
        slot_of[name] = FIRST_CHANNEL + len(c.channels) + i
    sliders = [sl.name for sl in c.sliders]
    base = FIRST_CHANNEL + len(c.channels) + len(c.lets) + len(sliders)
    for k, name in enumerate(sliders):
        slot_of[name] = base - len(sliders) + k
    texts: dict[str, list[tuple[str, tuple[LabelPart, ...]]]] = {}  # label -> its sliders and texts
    fields: list[tuple[int, str, Parsed]] = []
    for label, slider, parts in c.labels:
        compiled: list[LabelPart] = []
        for part in parts:
            if isinstance(part, tuple):
                slot = base + len(fields)
                fields.append((slot, slider, part[0]))
                compiled.append((slot, part[1]))
            else:
                compiled.append(part)
        texts.setdefault(label, []).append((slider, tuple(compiled)))
    labels = tuple((label, written[0][1]) for label, written in texts.items())
    # joint targets set by bind: and by set_velocity/set_position, in a fixed order
    targets: list[tuple[str, str]] = []
    for b in c.binds:
        if (b.joint, b.mode) not in targets:
            targets.append((b.joint, b.mode))
    for rules in c.states.values():
        for r in rules:
            for a in r.rule.actions:
                if isinstance(a, ast.Action) and a.name in JOINT_ACTIONS:
                    joint = a.args[0]
                    assert isinstance(joint, ast.Name)
                    if (joint.id, JOINT_ACTIONS[a.name]) not in targets:
                        targets.append((joint.id, JOINT_ACTIONS[a.name]))
    # per-tick variables and per-robot constants, only for behaviours that read them
    count = base + len(fields)
    shared: list[SharedLabel] = []
    for label, written in texts.items():
        if len(written) > 1:  # a slot for the slider showing, and one per slider for its last value
            watched = tuple((slot_of[slider], count + 1 + k) for k, (slider, _) in enumerate(written))
            shared.append(SharedLabel(label, count, watched, tuple(parts for _, parts in written),
                                      tuple(slider for slider, _ in written)))
            count += 1 + len(written)
    members: dict[str, tuple[int, ...] | None] = {}
    for name, parsed in c.lets:
        if name in c.group_sizes:
            if _names_only(parsed.node, members):
                members[name] = None
            else:
                members[name] = tuple(range(count, count + c.group_sizes[name]))
                count += c.group_sizes[name]
    count = _per_robot(c, slot_of, count)
    return Layout(MappingProxyType(slot_of), count, labels, tuple(fields), tuple(targets),
                  members=MappingProxyType(members), shared_labels=tuple(shared))


def _per_robot(c: Checked, slot_of: dict[str, int], count: int) -> int:
    """Slots for the per-tick variables and per-robot values a behaviour reads, from slot ``count`` on,
    then (format 1.3) each value read of another robot at a known place ('leader.x') and each channel
    heard ('heard(target)'); the next free slot."""
    per_robot = {name for own in c.robot_params.values() for name, _ in own}
    # a file's own name hides a read-back one (a parameter or a state is folded, a signal has its slot)
    read_back = [name for name in READ_BACK if name not in c.params and name not in c.states]
    for name in (*STATE_CLOCK, "index", *read_back, *sorted(per_robot)):
        if name in c.used and name not in slot_of:
            slot_of[name] = count
            count += 1
    for name in (*(r.name for r in c.received), *(heard_slot(channel) for channel in c.heard)):
        slot_of[name] = count
        count += 1
    return count


def _names_only(e: ast.Expr, members: dict[str, tuple[int, ...] | None]) -> bool:
    """Whether a group is written with names and numbers only (or names another such group, or
    slices one: ``ahead: scan[135:225]`` is read where it is used, as scan is)."""
    if isinstance(e, ast.Name):
        return e.id in members and members[e.id] is None
    if isinstance(e, ast.Slice):
        return _names_only(e.value, members)
    return isinstance(e, ast.Group) and all(isinstance(m, ast.Name | ast.Number) for m in e.members)

