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
import sys

import yaml
from yaml.nodes import ScalarNode

FLOAT_MAX = sys.float_info.max  # about 1.8e308
WHOLE_LIMIT = 2 ** 53  # whole numbers up to this size are exact as floats: seeds, randint's bounds
MAX_DIGITS = 4300  # Python's own limit for reading an integer from text (sys.get_int_max_str_digits)
TOO_LARGE = f"number too large: labsim's numbers are 64-bit floats, at most about {FLOAT_MAX:.1e}"

_INFINITY = {"inf", "+inf", "-inf", "infinity", "+infinity", "-infinity", ".inf", "+.inf", "-.inf"}


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


def yaml_number_problem(node: ScalarNode) -> str | None:
    """Why a scalar that YAML reads as a number is no number labsim can hold, if it is not.

    The gate every number of a file passes as the file is composed
    (``labsim.foundation.source.loads``): an integer or float too large for a float, and
    the malformed scalars YAML 1.1's patterns let through but cannot convert (``0b_``, 5000
    digits), are refused where they are written, so that no reader meets them.
    """
    try:
        value = yaml.SafeLoader("").construct_object(node, deep=False)
    except ValueError:
        if len(node.value) > MAX_DIGITS:
            return f"{TOO_LARGE} ({len(node.value)} digits)"
        return f"'{node.value}' is not a number YAML can read: write digits, such as 10 or 0.5"
    if isinstance(value, float) and math.isinf(value):
        return None if node.value.lstrip("+-").lower() == ".inf" else TOO_LARGE
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
