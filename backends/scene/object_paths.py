"""Object path templates: a behaviour's ``paths:`` entries and the models' default paths.

Where it sits: the reader (dsl/syntax/read.py) checks each ``paths:`` entry with ``problem`` so that
``labsim check`` reports a bad one at its position; the CoppeliaSim backend fills them with
``fill`` when it looks the robots up. Both sides share this one definition.

A template is CoppeliaSim path text plus placeholders, replaced literally (docs/language.md):

* ``{i}``, in ``robot``: the robot's index among the robots of its model, from 0;
* ``{k}``, in ``sonar``: the sonar's index, from 0 (channel sonar1 is ``{k}`` = 0); ``{n}`` its
  number, from 1 (the e-puck's ``./ePuck_proxSensor{n}``).

Nothing else in braces is a placeholder: ``{3}`` (digits) is CoppeliaSim's own "the n-th match
anywhere below" and passes through unchanged; any other ``{...}`` is an error. Templates are
never given to ``str.format``, which would let a file's text reach Python attributes
(``{i.__class__}``) or pad a value to hundreds of megabytes (``{i:>300000000}``).

The robot's path starts with ``/`` (it is looked up from the top of the scene); the others are
usually relative to the robot (``./leftMotor``). Charset and length: ASCII letters, digits and
``_ - . / : [ ] { } * ? #``, at most ``MAX_CHARS`` characters. CoppeliaSim's aliases allow
these; spaces, quotes and control characters only ever come from a mistake.
"""
from __future__ import annotations

import string

MAX_CHARS = 200
ALLOWED = frozenset(string.ascii_letters + string.digits + "_-./:[]{}*?#")
PLACEHOLDERS: dict[str, tuple[str, ...]] = {
    "robot": ("i",),
    "sonar": ("k", "n"),
    "left_motor": (),
    "right_motor": (),
    "camera": (),
}


def problem(key: str, template: str) -> tuple[int, str] | None:
    """(offset in ``template``, message) of the first thing wrong with it, or None."""
    if not template:
        return 0, f"the {key} path is empty"
    if len(template) > MAX_CHARS:
        return MAX_CHARS, f"the {key} path is {len(template)} characters long; at most {MAX_CHARS}"
    for at, ch in enumerate(template):
        if ch not in ALLOWED:
            shown = ch if ch.isprintable() and ch.isascii() else f"U+{ord(ch):04X}"
            return at, (f"'{shown}' cannot be part of a CoppeliaSim path; use letters, digits and "
                        f"_ - . / : [ ] {{ }} * ? #")
    if key == "robot" and not template.startswith("/"):
        return 0, "the robot path is looked up from the scene's top: it starts with '/', e.g. /PioneerP3DX[{i}]"
    allowed = PLACEHOLDERS.get(key, ())
    at = template.find("{")
    while at >= 0:
        end = template.find("}", at)
        if end < 0:
            return at, f"unclosed '{{' in the {key} path"
        name = template[at + 1:end]
        if not name.isdigit() and name not in allowed:
            offer = " or ".join(f"{{{p}}}" for p in allowed) if allowed else "no placeholder"
            return at, (f"'{{{name}}}' is not a placeholder of the {key} path (it takes {offer}; "
                        f"{{n}} with digits is CoppeliaSim's n-th match)")
        at = template.find("{", end)
    return None


def fill(template: str, **values: int) -> str:
    """``template`` with each ``{name}`` of ``values`` replaced by the number, literally."""
    out = template
    for name, value in values.items():
        out = out.replace("{" + name + "}", str(int(value)))
    return out
