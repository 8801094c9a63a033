"""A stop condition that can never hold: an error, since the run it ends would never end.

What is seen before the run, and no more: a condition whose value is known (``stop: false``,
``stop: 1 > 2``, a parameter compared with a constant), and a comparison of ``time`` or
``tick`` (never negative) with a value known before the run that no time reaches
(``time < 0``, ``tick <= -1``, ``0 > time``); ``and`` fails when one part never holds, ``or``
when every part never holds. A condition that merely takes long (``time >= 1e9``) is left to
the tick budget (``labsim.foundation.limits.Budgets.ticks``). ``stop_horizon`` reads the
other side of it: when the condition surely holds, for the progress bar.
"""
from __future__ import annotations

from collections.abc import Mapping

from labsim.dsl.analysis.check import Checked
from labsim.dsl.analysis.fold import NotConstant, fold
from labsim.dsl.analysis.lint import Linter
from labsim.dsl.syntax import ast
from labsim.foundation.diagnostics import Report

CLOCKS = ("time", "tick")  # names that start at 0 and only grow
_FLIP = {"<": ">", "<=": ">=", ">": "<", ">=": "<=", "==": "==", "!=": "!="}


def check_stop(c: Checked, report: Report) -> None:
    """Report the stop condition as an error when it can never hold."""
    stop = c.file.stop
    if stop is None:
        return
    linter = Linter(c, Report())
    why = _never(stop.node, linter)
    if why is not None:
        report.add(c.file.doc.diagnostic(
            stop.text.at(stop.node.span), f"the stop condition never holds ({why}): the run would never end",
            notes=("e.g. 'stop: time >= 60' ends the run after a simulated minute",)))


def _never(e: ast.Expr, linter: Linter) -> str | None:
    """Why ``e`` is false on every tick, or None when it may hold."""
    value = linter.known(e)
    if value is not None:
        return None if value else "it is always false"
    if isinstance(e, ast.BoolOp):
        reasons = [_never(v, linter) for v in e.values]
        if e.op == "and":
            return next((r for r in reasons if r is not None), None)
        return "no part of it ever holds" if all(r is not None for r in reasons) else None
    if isinstance(e, ast.Compare):
        for op, left, right in zip(e.ops, e.operands, e.operands[1:]):
            why = _clock_never(op, left, right, linter)
            if why is not None:
                return why
    return None


def _clock_never(op: str, left: ast.Expr, right: ast.Expr, linter: Linter) -> str | None:
    """Why ``left op right`` never holds when one side is a clock and the other a known number."""
    if isinstance(right, ast.Name) and right.id in CLOCKS:
        left, right, op = right, left, _FLIP[op]
    if not (isinstance(left, ast.Name) and left.id in CLOCKS):
        return None
    bound = linter.known(right)
    if isinstance(bound, bool) or not isinstance(bound, (int, float)):
        return None
    never = (op == "<" and bound <= 0) or (op in ("<=", "==") and bound < 0)
    return f"'{left.id}' is never below 0" if never else None


def stop_horizon(c: Checked, constants: Mapping[str, object]) -> float | None:
    """Sim time at which the stop condition surely holds, when it says so plainly.

    ``time >= minutes * 60`` or ``... or tick >= 30000`` give a horizon for the progress bar;
    any other condition gives None (the bar then shows elapsed sim time only). ``constants``
    are the names the code generator folds (``labsim.dsl.analysis.fold``).
    """
    stop = c.file.stop
    if stop is None:
        return None
    best = None
    nodes = [stop.node]
    while nodes:
        e = nodes.pop()
        if isinstance(e, ast.BoolOp) and e.op == "or":
            nodes.extend(e.values)
        elif isinstance(e, ast.Compare) and len(e.ops) == 1 and e.ops[0] in (">=", ">"):
            left, right = e.operands
            if isinstance(left, ast.Name) and left.id in CLOCKS:
                try:
                    value = fold(right, constants)
                except NotConstant:
                    continue
                if isinstance(value, (int, float)) and not isinstance(value, bool):
                    seconds = float(value) * (c.file.dt_s if left.id == "tick" else 1.0)
                    best = seconds if best is None else min(best, seconds)
    return best
