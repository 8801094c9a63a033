"""What an assignment's measured metric may read, and what it may not.

The robots' sensors and pose, ``collided``, ``forward_speed``, the wheel commands as sent
(``wheel_left``, ``wheel_right``), the world's channels, time, and the grader's params; never
what a student's file writes (its signals, states, functions or metrics).

``labsim.runtime.grade.assignment`` checks each ``measure:`` formula with ``unreadable``, which
walks the formula with the language's own traversal (``labsim.dsl.syntax.ast.children``).
"""
from __future__ import annotations

from labsim.backends.scene.ground import ROAD_CHANNELS
from labsim.backends.scene.models import MODELS, Kind
from labsim.dsl.library.builtins import AGGREGATES, CONSTANTS, DETECTED, FUNCTIONS, WHEELS
from labsim.dsl.syntax import ast as dsl_ast

MEASURE_VARIABLES = ("time", "tick", "dt")
# len() counts a list's rows or a group's members in a behaviour file of format 1.3; a measured metric has no lists
LEN_WORDS = "'len(...)', which counts a list of a behaviour file (format 1.3)"


def measurable_names() -> set[str]:
    """The names a measured metric may read: every robot model's sensors and pose, ``collided``
    and ``forward_speed``, the wheel commands, the world's channels, ``MEASURE_VARIABLES`` and the constants."""
    names: set[str] = set(MEASURE_VARIABLES) | set(CONSTANTS) | set(ROAD_CHANNELS) | set(WHEELS)
    for model in MODELS.values():
        names |= {n for n, kind in model.channels().items() if kind is not Kind.IMAGE}
    return names


def unreadable(e: dsl_ast.Expr, readable: set[str]) -> list[tuple[str, tuple[int, int]]]:
    """What an expression reads that a measured metric may not: (words, span) each."""
    out: list[tuple[str, tuple[int, int]]] = []
    todo = [e]
    while todo:
        node = todo.pop()
        if isinstance(node, dsl_ast.Name) and node.id not in readable:
            out.append((f"'{node.id}', which is not a sensor, the pose or a param of the grader's", node.span))
        elif isinstance(node, dsl_ast.Call) and node.func == "len":  # behaviours' len() of a list (format 1.3)
            out.append((LEN_WORDS, node.func_span))
        elif isinstance(node, dsl_ast.Call) and node.func not in (*FUNCTIONS, *AGGREGATES, DETECTED):
            out.append((f"'{node.func}(...)', which is not a built-in function", node.func_span))
        elif isinstance(node, dsl_ast.Attribute):
            out.append((f"'.{node.attr}' of a robot the student names", node.span))
            continue  # the robot's name under it is the same mistake
        todo.extend(reversed(dsl_ast.children(node)))
    out.sort(key=lambda found: found[1])
    return out
