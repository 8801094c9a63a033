"""One rule for numbers: every number labsim reads becomes a float here, or a clear refusal.

A number enters labsim from a file (YAML scalars, and number literals in rule strings), from
``--set NAME=VALUE``, from a trace being replayed, or from the wire. Whatever its source, it
becomes a 64-bit float through ``to_float``, and one that does not fit (an integer of more
than 309 digits, ``1e309``) is refused with ``TOO_LARGE`` rather than becoming ``inf``
silently or raising ``OverflowError`` later, deep in a computation. Arithmetic on floats then
overflows to ``inf`` as IEEE 754 says, and never raises (docs/language.md, "Numbers").

The language keeps a few values as whole numbers (a robot's ``count``, the ``seed``,
``randint``'s bounds): ``WHOLE_LIMIT`` bounds those, so that each is exact as a float too.
"""
from __future__ import annotations

import math
import re
import sys

import yaml
from yaml.nodes import ScalarNode

FLOAT_MAX = sys.float_info.max  # about 1.8e308
WHOLE_LIMIT = 2 ** 53  # whole numbers up to this size are exact as floats: seeds, randint's bounds
MAX_DIGITS = 4300  # Python's own limit for reading an integer from text (sys.get_int_max_str_digits)
TOO_LARGE = f"number too large: labsim's numbers are 64-bit floats, at most about {FLOAT_MAX:.1e}"

_INFINITY = {"inf", "+inf", "-inf", "infinity", "+infinity", "-infinity", ".inf", "+.inf", "-.inf"}


# YAML 1.2's core schema: an integer is decimal (017 is 17), 0o17 octal or 0x1f hexadecimal; a float has a
# point or an exponent (1e-3), or is .inf or .nan. PyYAML reads YAML 1.1, where 017 is octal 15, 1:30 is 90
# (base 60) and 1e-3 is text: labsim.foundation.source gives its reader these instead.
YAML12_INT = re.compile(r"^(?:[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+)$")
YAML12_FLOAT = re.compile(r"^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?|[-+]?\.(?:inf|Inf|INF)"
                          r"|\.(?:nan|NaN|NAN))$")


def yaml12_numbers(loader: type[yaml.SafeLoader]) -> None:
    """Make ``loader`` tag numbers as YAML 1.2's core schema does (YAML12_INT, YAML12_FLOAT)."""
    core = "tag:yaml.org,2002:"
    loader.yaml_implicit_resolvers = {
        first: [(tag, regexp) for tag, regexp in resolvers if tag not in (core + "int", core + "float")]
        for first, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()}
    loader.add_implicit_resolver(core + "int", YAML12_INT, list("-+0123456789"))  # before the float's: 17 is both
    loader.add_implicit_resolver(core + "float", YAML12_FLOAT, list("-+0123456789."))


class NumberError(ValueError):
    """A number that does not fit a float, or a text that is no number; str() is the message."""


def to_float(value: int | float | str) -> float:
    """The float of a number, or of a number's text; ``NumberError`` if it does not fit.

    Infinity written as such (``inf``, ``.inf``) is a float like any other: whether it is
    allowed is the reader's business. A finite number that would round to infinity is not.
    """
    if isinstance(value, float):
        return value
    if isinstance(value, int):
        try:
            return float(value)
        except OverflowError:
            raise NumberError(TOO_LARGE) from None
    text = value.strip()
    if len(text) > MAX_DIGITS:
        raise NumberError(f"{TOO_LARGE} ({len(text)} characters)")
    try:
        number = float(text)
    except ValueError:
        raise NumberError(f"'{text[:40]}' is not a number") from None
    if math.isinf(number) and text.lower() not in _INFINITY:
        raise NumberError(TOO_LARGE)
    return number


def yaml_scalar(node: ScalarNode) -> object:
    """A scalar's Python value as YAML 1.2's core schema reads it (the composer's resolvers,
    ``labsim.foundation.source``, tag it so): an integer is decimal (``017`` is 17), ``0o17`` octal or
    ``0x1f`` hexadecimal, where YAML 1.1 read ``017`` as octal 15; ValueError if it is none."""
    if node.tag == "tag:yaml.org,2002:int":
        text = node.value
        sign, body = (-1, text[1:]) if text[:1] == "-" else (1, text.lstrip("+"))
        if len(body) > MAX_DIGITS:
            raise ValueError(TOO_LARGE)
        base = {"0o": 8, "0x": 16}.get(body[:2], 10)
        return sign * int(body[2:] if base != 10 else body, base)
    return yaml.SafeLoader("").construct_object(node, deep=False)


def yaml_number_problem(node: ScalarNode) -> str | None:
    """Why a scalar that YAML reads as a number is no number labsim can hold, if it is not.

    The gate every number of a file passes as the file is composed
    (``labsim.foundation.source.loads``): an integer or float too large for a float, and
    the malformed scalars YAML 1.1's patterns let through but cannot convert (``0b_``, 5000
    digits), are refused where they are written, so that no reader meets them.
    """
    try:
        value = yaml_scalar(node)
    except ValueError:
        if len(node.value) > MAX_DIGITS:
            return f"{TOO_LARGE} ({len(node.value)} digits)"
        return f"'{node.value}' is not a number YAML can read: write digits, such as 10 or 0.5"
    if isinstance(value, float) and math.isinf(value):
        return None if node.value.lstrip("+-").lower() == ".inf" else TOO_LARGE
    if not isinstance(value, int | float):  # an int or float tag gives one of them
        return None
    try:
        to_float(value)
    except NumberError as e:
        return str(e)
    return None


def place_text(k: float) -> str:
    """A place asked of a group or a list, as a message shows it: ``:g``, unless that rounds a fraction to a
    whole place (2.9999999999999996 is no place 3), which is shown in full."""
    shown = f"{k:g}"
    if math.isfinite(k) and not float(k).is_integer() and float(shown).is_integer():
        return repr(float(k))
    return shown


# What YAML 1.1 read as a number and YAML 1.2 reads as text: base 60 (1:30), digits with '_' (1_000),
# binary (0b101), and malformed hexadecimal or octal; none is an expression's text either
_YAML11_NUMBER = re.compile(r"^[-+]?(?:[0-9][0-9_]*(?::[0-5]?[0-9])+(?:\.[0-9_]*)?|[0-9][0-9]*_[0-9_]*(?:\.[0-9_]*)?"
                            r"|0b[01_]+|0x[0-9a-fA-F_]*|0o[0-7_]*)$")


def yaml11_number(node: ScalarNode) -> tuple[str, str] | None:
    """For a plain scalar YAML 1.1 read as a number and YAML 1.2 as text (1:30): the message, and a hint
    with what YAML 1.1 read it as (90); None for any other."""
    if not _YAML11_NUMBER.match(node.value):
        return None
    message = (f"'{node.value}' is no number: labsim files read numbers as YAML 1.2 does, without base 60 (1:30), "
               "'_' between digits or 0b")
    tag = "tag:yaml.org,2002:" + ("float" if "." in node.value else "int")
    try:
        value = yaml.SafeLoader("").construct_object(ScalarNode(tag, node.value), deep=False)
    except ValueError:
        return message, "write the number in decimal digits"
    return message, f"YAML 1.1 read it as {value!r}: write {value!r} if that is meant"


def scalar_problem(node: ScalarNode) -> tuple[str, tuple[str, ...]] | None:
    """Why a scalar of a file is refused as it is composed, with a hint: a number no float holds, or a
    plain scalar YAML 1.1 read as a number (1:30); None for any other."""
    if node.tag in ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float"):
        problem = yaml_number_problem(node)
        return (problem, ()) if problem else None
    old = yaml11_number(node) if node.tag == "tag:yaml.org,2002:str" and node.style is None else None
    return (old[0], (old[1],)) if old else None
