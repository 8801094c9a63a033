"""Messages between robots (format 1.3): ``say(channel, value[, range_m])`` and ``heard(channel[, default])``.

The checker's half (``labsim.dsl.analysis.check`` and ``.infer`` call it): a rule's ``say`` sends a
number on a named channel, and every other robot within range hears it after the tick, so
``heard`` reads it on the next (docs/language.md, "Other robots and messages"). A channel is a
name of its own, not a value: it is declared by the ``say`` actions of the file, and one heard
but said nowhere is an error with the channels that are said. The runtime's half is
``labsim.runtime.radio``.
"""
from __future__ import annotations

from typing import Protocol

from labsim.dsl.analysis.functions import known_value
from labsim.dsl.analysis.wording import arity_message
from labsim.dsl.library.builtins import Type
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.read import FunctionDecl, Parsed, later_format
from labsim.foundation.diagnostics import did_you_mean, listed, quoted
from labsim.foundation.source import Place, Text

SAY, HEARD = "say", "heard"


def heard_slot(channel: str) -> str:
    """The name of the slot, and of the trace's column, holding what a robot heard on a channel."""
    return f"heard({channel})"


class MessageChecker(Protocol):
    """What this module uses of the checker (``labsim.dsl.analysis.infer.ExprChecker``)."""

    version: float
    robot_counts: dict[str, int]
    robot_constants: list[tuple[str, dict[str, object]]]
    used: set[str]
    constants: dict[str, object]
    scopes: list[tuple[FunctionDecl, dict[str, tuple[Type, int]], ast.Call | None, Text]]
    said: dict[str, None]
    heard: dict[str, list[tuple[ast.Name, Text]]]

    def error(self, place: Place, message: str, notes: tuple[str, ...] = ()) -> None: ...

    def infer(self, e: ast.Expr, text: Text) -> Type | None: ...

    def expect(self, parsed: Parsed, e: ast.Expr, want: Type, what: str) -> bool: ...


def check_say(c: MessageChecker, action: ast.Action, text: Text, said_here: set[str]) -> None:
    """``say(channel, value)`` or ``say(channel, value, range_m)`` in a rule."""
    if c.version < 1.3:
        c.error(text.at(action.name_span), later_format("say(channel, value)", 1.3))
        return
    if not 2 <= len(action.args) <= 3:
        c.error(text.at(action.span), arity_message(SAY, ("channel", "value", "range_m"), len(action.args),
                                                    optional=1))
        if action.args and isinstance(action.args[0], ast.Name):
            c.said.setdefault(action.args[0].id, None)  # its heard() says nothing more
        return
    channel, value = action.args[0], action.args[1]
    if not c.robot_counts:
        c.error(text.at(action.name_span), "say() sends to the other robots, and this file has none",
                notes=("a mechanism's rules read its sensors and set its joints",))
        if isinstance(channel, ast.Name):
            c.said.setdefault(channel.id, None)  # its heard() says nothing more
        return
    if not isinstance(channel, ast.Name):
        c.error(text.at(channel.span), "say() takes a channel's name first, as in say(target, x): a name of "
                "your choice, which heard(target) reads")
        return
    if channel.id in said_here:
        c.error(text.at(action.span), f"this rule says on channel {quoted(channel.id)} already: a robot sends one "
                "value a tick on a channel")
        return
    said_here.add(channel.id)
    c.said.setdefault(channel.id, None)
    c.used.update(("x", "y"))  # who hears is decided by where the robots are
    t = c.infer(value, text)
    if t is Type.BOOL:
        c.error(text.at(value.span), "say() sends a number; this is a boolean",
                notes=("send 1 or 0, as in say(alarm, 1 if near else 0), and compare what is heard: "
                       "heard(alarm) == 1",))
    elif t is not None and t is not Type.NUMBER:
        c.error(text.at(value.span), f"say() sends a number; this is {t.a}")
    if len(action.args) == 3:
        reach = action.args[2]
        if c.expect(Parsed(reach, text), reach, Type.NUMBER, "the range of say()"):
            _check_reach(c, reach, text)


def _check_reach(c: MessageChecker, reach: ast.Expr, text: Text) -> None:
    """A range known before the run is more than 0: for every robot, when made of a robot's own
    parameters (what only the run knows is warned about while running)."""
    for robot, constants in [("", c.constants), *c.robot_constants]:
        known = known_value(reach, constants, c.scopes)
        if isinstance(known, int | float) and not isinstance(known, bool) and not known > 0:
            c.error(text.at(reach.span), f"say()'s range is a distance in metres, more than 0; not {known:g}"
                    + (f" for robot {robot}" if robot else ""), notes=("leave it out to be heard at any distance",))
            return


def heard_type(c: MessageChecker, e: ast.Call, text: Text) -> Type | None:
    """``heard(channel)`` or ``heard(channel, default)``: a number."""
    if c.version < 1.3:
        c.error(text.at(e.func_span), later_format("heard(channel)", 1.3))
        return None
    if c.scopes:
        d = c.scopes[-1][0]
        c.error(text.at(e.span), f"a function reads only its parameters ({', '.join(d.params) or 'none'}), the "
                "file's params and constants, not what a robot heard",
                notes=(f"read it in a signal and pass the signal to '{d.name}'",))
        return None
    if not 1 <= len(e.args) <= 2:
        c.error(text.at(e.span), arity_message(HEARD, ("channel", "default"), len(e.args), optional=1))
        return None
    channel = e.args[0]
    if not isinstance(channel, ast.Name):
        c.error(text.at(channel.span), "heard() takes a channel's name, as in heard(target), which a say(target, "
                "...) sends on")
        return None
    c.heard.setdefault(channel.id, []).append((channel, text))
    if len(e.args) == 2 and not c.expect(Parsed(e.args[1], text), e.args[1], Type.NUMBER, "heard()'s default"):
        return None
    return Type.NUMBER


def check_channels(c: MessageChecker) -> None:
    """Every channel heard is said somewhere: else it would read its default for ever."""
    for name, places in c.heard.items():
        if name in c.said:
            continue
        said = list(c.said)
        for channel, text in places:
            c.error(text.at(channel.span), f"nothing says on channel {quoted(name)}{did_you_mean(name, said)}",
                    notes=("channels said in this file: " + listed(said) if said else
                           "a channel is said by an action of a rule, as in say(target, x)",))
