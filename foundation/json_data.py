"""JSON from a file, its nesting capped before it is parsed.

Python's ``json`` parser recurses once per level of nesting, so a trace header (or footer)
nested 100,000 deep is a RecursionError, which no reader expects. Every JSON labsim reads from
a file (a trace's header and footer, for ``plot``, ``view``, replay and goldens) comes through
``loads_json``: the text's brackets are counted first, outside strings, and a text deeper than
``MAX_JSON_DEPTH`` is refused as a ValueError, which the readers already report as a damaged
line.
"""
from __future__ import annotations

import json
import re

MAX_JSON_DEPTH = 64  # labsim's own headers nest 4 levels deep
_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.S)
_BRACKET = re.compile(r"[\[\]{}]")


def json_depth(text: str) -> int:
    """How deep the text's lists and objects nest (its brackets outside strings)."""
    depth = deepest = 0
    for bracket in _BRACKET.findall(_STRING.sub("", text)):
        if bracket in "[{":
            depth += 1
            deepest = max(deepest, depth)
        else:
            depth -= 1
    return deepest


def loads_json(text: str, max_depth: int = MAX_JSON_DEPTH) -> object:
    """``json.loads``, or ValueError for a text nested deeper than ``max_depth`` (or not JSON)."""
    if json_depth(text) > max_depth:
        raise ValueError(f"JSON nested more than {max_depth} levels deep")
    return json.loads(text)
