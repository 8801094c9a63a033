"""Other robots' values (format 1.3): ``leader.x``, ``pioneer[2].state``, ``leader.front``, typed.

The parser makes a ``Peer`` of ``NAME.attr`` when NAME is one of the file's robots
(``labsim.dsl.syntax.parse``); this module is the checker's half (``labsim.dsl.analysis.infer``
calls ``peer_type``): the robot and its member place, then the value read, which is the other
robot's ``x``, ``y``, ``heading``, ``state`` or one of its signals, as it was on the last tick
(docs/language.md, "Other robots and messages"). Every robot runs the same rules, so the
signals of another robot are this file's signals. What is read is gathered in ``fields``, in the
order first read: the code generator keeps each robot's values of them after every tick.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

from yaml.nodes import Node

from labsim.dsl.analysis.functions import known_value
from labsim.dsl.analysis.wording import literal
from labsim.dsl.library.builtins import READ_BACK, VARIABLES, Type
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.read import FunctionDecl
from labsim.foundation.diagnostics import did_you_mean, listed, quoted
from labsim.foundation.source import Place, Text

POSE = ("x", "y", "heading")  # readable of every robot, besides its state and signals


@dataclass(frozen=True)
class Received:
    """One value read of another robot at a place known before the run: ``pioneer[2].x`` is
    robot ``pioneer``'s member 2's x. The reading robot keeps it in a slot of its own for the tick,
    which the trace and the live view show under the name as written (``name``)."""

    name: str
    robot: str
    place: int
    attr: str


class PeerChecker(Protocol):
    """What this module uses of the checker (``labsim.dsl.analysis.infer.ExprChecker``)."""

    types: dict[str, Type]
    kinds: dict[str, str]
    used: set[str]
    poisoned: set[str]
    later: dict[str, Node]
    current_let: str
    scopes: list[tuple[FunctionDecl, dict[str, tuple[Type, int]], ast.Call | None, Text]]
    constants: dict[str, object]
    robot_constants: list[tuple[str, dict[str, object]]]
    overrides: dict[str, str]
    robot_counts: dict[str, int]
    signal_names: tuple[str, ...]
    peer_fields: dict[str, Type]
    peer_later: list[tuple[ast.Peer, Text]]
    received: dict[str, Received]
    received_at: dict[int, str]
    node_types: dict[int, Type]

    def error(self, place: Place, message: str, notes: tuple[str, ...] = ()) -> None: ...

    def infer(self, e: ast.Expr, text: Text) -> Type | None: ...


PEER_VALUES = (*POSE, "state")  # what every robot has for the others to read, besides its signals


def readable(c: PeerChecker) -> tuple[str, ...]:
    """What another robot's name reads: its pose, its state and the file's signals that are a number
    or a boolean (or not checked yet); a signal refused or of another type is left out."""
    return (*POSE, "state", *(n for n in c.signal_names if n not in c.poisoned
                               and c.types.get(n, Type.NUMBER) in (Type.NUMBER, Type.BOOL)))


def peer_type(c: PeerChecker, e: ast.Peer, text: Text) -> Type | None:
    """The type of ``robot.attr`` or ``robot[k].attr``; each mistake reported at its place."""
    if c.scopes:
        d = c.scopes[-1][0]
        c.error(text.at(e.span), f"a function reads only its parameters ({', '.join(d.params) or 'none'}), the "
                "file's params and constants, not another robot's values",
                notes=(f"read it in a signal (e.g. 'other: {e.robot}{'[0]' if e.indexed else ''}.{e.attr}') "
                       f"and pass the signal to '{d.name}'",))
        return None
    count = c.robot_counts.get(e.robot, 1)
    if not member_ok(c, e, text, count):
        return None
    t = field_type(c, e, text)
    if t is None:
        return None
    c.peer_fields.setdefault(e.attr, t)
    place = known_value(e.member, c.constants, c.scopes) if e.indexed else 0
    if isinstance(place, int | float) and not isinstance(place, bool):
        name = f"{e.robot}[{int(place)}].{e.attr}" if e.indexed else f"{e.robot}.{e.attr}"
        c.received.setdefault(name, Received(name, e.robot, int(place), e.attr))
        c.received_at[id(e)] = name
    return t


def member_ok(c: PeerChecker, e: ast.Peer, text: Text, count: int) -> bool:
    """Whether the robot is named as its group has it: alone, or by a place inside the group."""
    if count > 1 and not e.indexed:
        c.error(text.at(e.robot_span), f"'{e.robot}' is a group of {count} robots: name one by its place, "
                f"as in {e.robot}[0].{e.attr}", notes=(f"its robots are {e.robot}[0] to {e.robot}[{count - 1}]",))
        return False
    if count == 1 and e.indexed:
        c.error(text.at((e.robot_span[0], e.member.span[1] + 1)), f"'{e.robot}' is one robot, not a group: "
                f"write {e.robot}.{e.attr}")
        return False
    if not e.indexed:
        return True
    k = c.infer(e.member, text)
    if k is None:
        return False
    if k is not Type.NUMBER:
        c.error(text.at(e.member.span), f"a robot of a group is named by its place, a number from 0; this is {k.a}")
        return False
    place, who = known_value(e.member, c.constants, c.scopes), ""
    for robot, constants in c.robot_constants if place is None else ():  # a robot's own parameters
        value = known_value(e.member, constants, c.scopes)
        if isinstance(value, int | float) and not (float(value).is_integer() and 0 <= value < count):
            place, who = value, f" for robot {robot}"  # the first robot whose place is outside the group
            break
    if place is None or isinstance(place, bool) or not isinstance(place, int | float):
        return True  # known only while running: a place outside the group is a runtime fault
    if not (float(place).is_integer() and 0 <= place < count):
        source = text.value[e.member.span[0]:e.member.span[1]]
        given = f" (--set {source}={c.overrides[source]})" if source in c.overrides else ""
        if math.isfinite(place) and not float(place).is_integer():  # bot[0.5]: as gains[0.5] is told
            shown = f"not {place:g}" if literal(e.member) else f"{quoted(source)} is {place:g}"
            short = source if len(source) <= 30 else "k"
            c.error(text.at(e.member.span), f"a robot of a group is named by its place, a whole number from 0; "
                    f"{shown}{who}{given}", notes=(f"round it, as in {e.robot}[round({short})].{e.attr}, if a "
                                                   "fraction is meant to pick the nearest",))
            return False
        c.error(text.at(e.member.span), f"group '{e.robot}' has {count} robots, {e.robot}[0] to "
                f"{e.robot}[{count - 1}]; not {place:g}{who}{given}", notes=("places count from 0",))
        return False
    return True


def field_type(c: PeerChecker, e: ast.Peer, text: Text) -> Type | None:
    """The type of the value read: a pose's number, the state, or a signal's number or boolean."""
    if e.attr in POSE:
        c.used.add(e.attr)  # sensed by every robot, so that the others can read it
        return Type.NUMBER
    if e.attr == "state":
        return Type.STATE
    if e.attr in c.poisoned:
        return None
    if e.attr in c.signal_names:
        c.used.add(e.attr)
        if e.attr == c.current_let or e.attr in c.later:  # defined below: its type is checked after the lets
            c.peer_later.append((e, text))
            return Type.NUMBER
        t = c.types.get(e.attr)
        if t in (Type.NUMBER, Type.BOOL):
            return t
        if t is None:
            return None
        c.error(text.at(e.attr_span), f"another robot's '{e.attr}' is {t.a}: only its numbers, booleans and "
                "state can be read", notes=(f"give what you need a signal of its own, as in 'near: min({e.attr})', "
                                            f"and read {e.robot}{'[0]' if e.indexed else ''}.near",)
                if t in (Type.NUMBERS, Type.BOOLS) else ())
        return None
    names = readable(c)
    kind = c.kinds.get(e.attr, "")
    whose = f"{e.robot}{'[0]' if e.indexed else ''}"
    if e.attr in ("time", "tick", "dt"):
        c.error(text.at(e.attr_span), f"every robot has the same '{e.attr}': write {e.attr}")
        return None
    if kind == "parameter" or e.attr in VARIABLES or e.attr in READ_BACK:
        what = "parameter" if kind == "parameter" else "built-in variable"
        c.error(text.at(e.attr_span), f"'{e.attr}' is a {what}: give it a signal, as in 'my_{e.attr}: {e.attr}', "
                f"and read {whose}.my_{e.attr}",
                notes=("another robot's x, y, heading, state and signals can be read: " + ", ".join(names),))
        return None
    if "sensor" in kind or kind == "bumper":
        c.error(text.at(e.attr_span), f"another robot's sensors are not read directly: give '{e.attr}' a signal, "
                f"as in 'seen: {e.attr}', and read {whose}.seen",
                notes=("another robot's x, y, heading, state and signals can be read: " + ", ".join(names),))
        return None
    same = {n.lower(): n for n in names}.get(e.attr.lower())  # leader.X: leader.x
    hint = f" (did you mean '{same}'?)" if same else did_you_mean(e.attr, names)
    written = text.value[e.span[0]:e.attr_span[0] - 1].strip()  # pioneer[1], as written
    c.error(text.at(e.attr_span), f"robot {quoted(written)} has no value {quoted(e.attr)}{hint}",
            notes=("another robot's x, y, heading, state and signals can be read: " + listed(names),))
    return None


def check_later(c: PeerChecker) -> None:
    """A signal another robot's value is read of while the signal is being checked (it reads the
    signal that reads it, or itself): its type is not known there, and it must be a number."""
    for e, text in c.peer_later:
        t = c.types.get(e.attr)
        if t is not None and t is not Type.NUMBER:
            c.error(text.at(e.attr_span), f"'{e.attr}' is {t.a}, and another robot's value of it is read where "
                    f"'{e.attr}' is being worked out (it reads this signal): only a number can be read so",
                    notes=(f"read a number made of it instead, as in '{e.attr}_n: 1 if {e.attr} else 0'",))
        c.peer_fields[e.attr] = t if t is not None else Type.NUMBER
