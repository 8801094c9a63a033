"""The words of the checker's messages that more than one check says.

How many arguments a function takes, the log() an action that prints meant, the functions an
unknown one may have meant, the names of a kind: ``labsim.dsl.analysis.infer`` and ``labsim.dsl.analysis.check``
say them.
"""
from __future__ import annotations

import difflib
from collections.abc import Iterable

from labsim.dsl.library.builtins import DETECTED, FUNCTIONS, REDUCTIONS, Type
from labsim.dsl.syntax import ast
from labsim.foundation.source import Text


def arity_message(name: str, params: tuple[str, ...], given: int, variadic: bool = False,
                  optional: int = 0) -> str:
    """'f() takes 2 arguments (x, y), given 3', and its variants: 'pid() takes 4 or 5 arguments
    (error, kp, ki, kd[, limit]), given 2'. Parameters named only by their type are not listed."""
    n = len(params)
    named = bool(params) and not all(p in ("number", "boolean") for p in params)
    required = ", ".join(params[:n - optional])
    listed = required + (f"[, {', '.join(params[n - optional:])}]" if optional else "") + (", ..." if variadic else "")
    shown = f" ({listed})" if named else ""
    if variadic:
        return f"{name}() takes at least {n} arguments{shown}, given {given}"
    if optional:
        counts = f"{n - optional} or {n}" if optional == 1 else f"{n - optional} to {n}"
        return f"{name}() takes {counts} arguments{shown}, given {given}"
    if n == 0:
        return f"{name}() takes no arguments, given {given}"
    return f"{name}() takes {n} {'argument' if n == 1 else 'arguments'}{shown}, given {given}"




def log_example(action: ast.Action, text: Text) -> str:
    """The log() an action that prints meant: its text, and its values as fields after it.

    print("wall!", x) -> log("wall! {x:.2f}"); with no text of its own, log("hit at {time:.1f} s")."""
    source = text.value
    def field(e: ast.Expr, spec: str) -> str:
        return "{" + source[e.span[0]:e.span[1]] + (f":{spec}" if spec else "") + "}"
    if action.text is None and not action.args:
        return 'log("hit at {time:.1f} s")'
    words = "".join(p.replace("{", "{{").replace("}", "}}") if isinstance(p, str) else field(*p)
                    for p in action.text or ())
    fields = " ".join(field(arg, ".2f") for arg in action.args)
    return 'log("' + " ".join(w for w in (words.rstrip(), fields) if w) + '")'


def say_example(action: ast.Action, text: Text) -> str:
    """say("pos", 2) as it is written: its channel a name without quotes, say(pos, 2)."""
    words = "".join(p for p in action.text or () if isinstance(p, str)).strip()
    channel = words if words.isidentifier() and len(words) <= 40 and len(action.text or ()) == 1 else "channel"
    values = [text.value[a.span[0]:a.span[1]] for a in action.args] or ["value"]
    values = [v if len(v) <= 40 else "value" for v in values]
    return f"say({channel}, {', '.join(values)})"


# every function a file may call: the built-ins of values, detected(), len() and a group's reductions
FUNCTION_NAMES = sorted({*FUNCTIONS, DETECTED, "len", *REDUCTIONS})


def reduction_arity(name: str, given: int) -> tuple[str, tuple[str, ...]]:
    """The message and hint for a group's reduction given other than its one group (sum(front, 1),
    any(a, b)); min, max and mean, which also take values, say both."""
    r = REDUCTIONS[name]
    takes = {"min": "a group, or at least 2 numbers", "max": "a group, or at least 2 numbers",
             "mean": "a group of numbers or an image"}.get(name, r.takes.a)
    example = f"{name}(front < 0.5)" if r.takes is Type.BOOLS else f"{name}(front)"
    hints = {"sum": "to add values, write a + b", "any": "of two conditions, write a or b",
             "all": "of two conditions, write a and b", "count": "counter(c) counts the ticks c became true on",
             "argmin": "to pick the smaller of values, write min(a, b)",
             "argmax": "to pick the larger of values, write max(a, b)"}
    count = f"1 argument, {takes}" if name not in ("min", "max") else takes
    notes = (f"{name}() of a group: {example} is {r.doc}",) + ((hints[name],) if name in hints else ())
    return f"{name}() takes {count}, given {given}", notes


def function_notes(name: str, nearest: bool = True, extra: tuple[str, ...] = ()) -> tuple[str, ...]:
    """What an unknown function's message lists: the nearest functions, and where they are all;
    ``extra``: the file's version's functions the table of built-ins does not hold (heard, format 1.3)."""
    names = sorted([*FUNCTION_NAMES, *extra])
    close = difflib.get_close_matches(name, names, n=3, cutoff=0.4) if nearest else []
    return ((f"the nearest: {', '.join(close)}; " if close else "")
            + "functions: " + ", ".join(names),
            "each is described in docs/language.md, under 'Functions'")


def text_note(t: Type) -> tuple[str, ...]:
    if t is Type.TEXT:
        return ('text is for a log\'s fields only, as in log("turning {\'left\' if s > 0 else \'right\'}")',)
    return ()


def range_text(names: list[str]) -> str:
    """'sonar1 .. sonar16' for numbered names, else the names listed."""
    numbered = sorted(names, key=lambda n: int(n[len(n.rstrip("0123456789")):] or 0))
    return f"{numbered[0]} .. {numbered[-1]}" if len(numbered) > 2 else ", ".join(numbered)


def unknown_name_notes(name: str, types: Iterable[str], distance: Iterable[str]) -> tuple[str, ...]:
    """What an unknown name's message adds: the names of its kind the robot has (its sonars, or
    the distance sensors of a model without sonars), a camera or a road that is not there."""
    notes: tuple[str, ...] = ()
    stem = name.rstrip("0123456789")
    numbered = stem not in ("", name)
    kin = [n for n in types if n != stem and n.rstrip("0123456789") == stem] if numbered else []
    if numbered and stem == "sonar" and not kin:  # a model with other distance sensors (an e-puck's prox1 .. prox8)
        others = sorted(distance)
        notes = (f"this robot has no sonars; its distance sensors are {range_text(others)}" if others else
                 "this robot has no sonars",)
    elif numbered and stem == "sonar":
        notes = (f"the robot's sonars are {range_text(kin)}, numbered as in CoppeliaSim",)
    elif kin:
        notes = (f"names of this kind: {range_text(kin)}",)
    elif name == "camera":
        notes = ("this robot has no camera: add one to it, e.g. "
                 "camera: {resolution: [128, 128], fov_deg: 60, height_m: 0.3, pitch_deg: 45}",)
    elif name in ("road_offset", "on_road", "laps"):
        notes = ("this world has no road",)
    return notes


def literal(e: ast.Expr) -> bool:
    """A number written as one, or its negative (``-1`` is ``Neg(1)``): shown as written."""
    return isinstance(e, ast.Number) or (isinstance(e, ast.Neg) and isinstance(e.operand, ast.Number))


def shown_setting(name: str, raw: str, at_most: int = 60) -> str:
    """'--set NAME=VALUE' as a message shows it: a value of thousands of characters by its start."""
    return f"--set {name}={raw if len(raw) <= at_most else raw[:at_most] + '...'}"
