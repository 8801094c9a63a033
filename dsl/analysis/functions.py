"""User functions: ``functions:`` of a behaviour file, checked where they are called.

A function is a named expression with parameters (``steer(offset, gain): clamp(gain * offset,
-2, 2)``), defined once and used in any expression (docs/language.md, "Functions of your own").
It is pure: its body reads only its parameters, the file's ``params``, constants and ``dt``, and
calls no built-in with memory (``pid``, ``prev``, ...) and nothing random, so a call means the
same wherever it is written. The checker (``labsim.dsl.analysis.infer``) types each call: it gives the
body a fresh copy per call site, types the copy with the arguments' types (a parameter can be
a number, a boolean or a group), and keeps it in ``Expansion`` for the code generator, which
writes the body in place of the call (no Python call at run time: docs/decisions.md). A
function cannot call itself, directly or through others: ``check_definitions`` reports the
circle at the definition and at the call that closes it.
"""
from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from labsim.dsl.analysis.fold import PLACES, NotConstant, fold
from labsim.dsl.library.builtins import (
    ACTIONS,
    AGGREGATES,
    DETECTED,
    FUNCTIONS,
    KEYWORDS,
    READ_BACK,
    STATEFUL,
    TRACE_COLUMNS,
    Type,
)
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.read import FunctionDecl
from labsim.foundation.source import Place, Text

RANDOM = frozenset(f.name for f in FUNCTIONS.values() if f.uses_rng)
MAX_EXPANDED = 20_000  # nodes all calls of a file expand to: f calling g twice calling h twice ... grows fast
# names a function's body may read besides its parameters: the file's and the language's constants
READABLE_KINDS = frozenset({"parameter", "list parameter", "constant"})


class ExprChecker(Protocol):
    """What this module uses of the checker (``labsim.dsl.analysis.infer.ExprChecker``)."""

    types: dict[str, Type]
    kinds: dict[str, str]
    poisoned: set[str]
    scopes: list[tuple[FunctionDecl, dict[str, tuple[Type, int]], ast.Call | None, Text]]
    expansions: dict[int, Expansion]
    expanded: int
    expanded_reported: bool
    sizes: dict[int, int]
    version: float
    robot_counts: dict[str, int]

    def error(self, place: Place, message: str, notes: tuple[str, ...] = ()) -> None: ...

    def infer(self, e: ast.Expr, text: Text) -> Type | None: ...

    def name(self, e: ast.Name, text: Text) -> Type | None: ...

    def size(self, e: ast.Expr) -> int: ...


@dataclass(frozen=True)
class Expansion:
    """One call of a user function: its definition and the body's own copy, typed for this call."""

    decl: FunctionDecl
    body: ast.Expr


def copy(e: ast.Expr) -> ast.Expr:
    """A fresh copy of an expression tree: new nodes, so each call site's types are its own."""
    changes: dict[str, Any] = {}
    for name in ast.child_fields(type(e)):
        v = getattr(e, name)
        changes[name] = tuple(copy(x) for x in v) if isinstance(v, tuple) else None if v is None else copy(v)
    return dataclasses.replace(e, **changes)


nodes = ast.walk  # every node of an expression, e first, without recursion


# the names format 1.3 gave the language: a 1.3 file's own names may not take them (a 1.0-1.2 file's keep theirs)
NEW_IN_13 = {"heard": "a built-in function", "say": "a built-in action", "len": "a built-in function",
             **dict.fromkeys(READ_BACK, "a built-in variable")}


def claimed_in_13(c: ExprChecker, name: str) -> tuple[str, tuple[str, ...]] | None:
    """Why a name of the file's own (a signal, parameter, state, slider or function) is refused in a
    format 1.3 file, and a note; None if it is not. In 1.3 ``leader.x`` reads robot 'leader', and
    ``heard(c)`` the built-in: a name of the file's own taking either would silently change them."""
    if c.version < 1.3:
        return None
    if name in c.robot_counts:
        return "is the name of a robot", (f"{name}.x, {name}.state, ... read robot '{name}' in format 1.3",)
    if name in NEW_IN_13:
        return (f"is the name of {NEW_IN_13[name]} of format 1.3",
                ("a file of format 1.2 or earlier may keep it as its own name",))
    return None


def check_definitions(c: ExprChecker, decls: list[FunctionDecl]) -> dict[str, FunctionDecl]:
    """Each definition's name, purity and the circles of calls; the functions that may be called."""
    out: dict[str, FunctionDecl] = {}
    for d in decls:
        if d.name in KEYWORDS or d.name in FUNCTIONS or d.name in ACTIONS or d.name in AGGREGATES \
                or d.name == DETECTED or d.name in TRACE_COLUMNS:
            c.error(d.key, f"function '{d.name}' has the name of a built-in function, action or trace column; "
                           "choose another name")
            continue
        claimed = claimed_in_13(c, d.name)
        if claimed is not None:
            c.error(d.key, f"function '{d.name}' {claimed[0]}; choose another name", notes=claimed[1])
            continue
        if d.name in out:
            first = out[d.name].key.start_mark.line + 1
            c.error(d.key, f"function '{d.name}' is defined twice (first on line {first})")
            continue
        if _pure(c, d):
            out[d.name] = d
        else:
            c.poisoned.add(d.name)
    for name in _circles(c, out):
        c.poisoned.add(name)
        del out[name]
    return out


def _pure(c: ExprChecker, d: FunctionDecl) -> bool:
    """A body that calls nothing with memory and nothing random; reported at the call if it does."""
    for node in nodes(d.body.node):
        if isinstance(node, ast.Call) and (node.func in STATEFUL or node.func in RANDOM):
            what = "keeps memory from tick to tick" if node.func in STATEFUL else "draws random numbers"
            c.error(d.body.text.at(node.func_span), f"a function computes its value from its arguments alone, and "
                    f"{node.func}() {what}", notes=(f"compute {node.func}(...) in a 'let' signal and pass the signal "
                                                    f"to '{d.name}' as an argument",))
            return False
    return True


def _circles(c: ExprChecker, functions: dict[str, FunctionDecl]) -> list[str]:
    """Functions that call themselves, directly or through others: each circle reported once."""
    calls = {name: [(n.func, n) for n in nodes(d.body.node) if isinstance(n, ast.Call) and n.func in functions]
             for name, d in functions.items()}
    bad: list[str] = []
    for start in functions:
        path = _path_back(start, calls)
        if path is None or start in bad:
            continue
        bad.extend(name for name, _ in path if name not in bad)
        d = functions[start]
        callee, call = path[-1][0], path[-1][1]
        route = " -> ".join([start, *(name for name, _ in path[1:])] + [start])
        c.error(d.key, f"function '{start}' calls itself ({route}): a function cannot call itself, directly or "
                       "through others", notes=("work the repeated step out as a formula, or as a signal that reads "
                                                "its value on the previous tick with prev(...)",))
        c.error(functions[callee].body.text.at(call.func_span), f"this call of '{start}' closes the circle")
    return bad


def _path_back(start: str, calls: dict[str, list[tuple[str, ast.Call]]]) -> list[tuple[str, ast.Call]] | None:
    """A chain of calls from ``start`` back to it, as (caller, the call it makes next); None if there is none."""
    todo: list[tuple[str, list[tuple[str, ast.Call]]]] = [(start, [])]
    seen: set[str] = set()
    while todo:
        name, path = todo.pop()
        for callee, call in calls[name]:
            step = [*path, (name, call)]
            if callee == start:
                return [(caller, k) for caller, k in step]
            if callee not in seen:
                seen.add(callee)
                todo.append((callee, step))
    return None


def check_call(c: ExprChecker, e: ast.Call, text: Text, d: FunctionDecl) -> Type | None:
    """A call of a user function: its arguments, then a copy of its body typed with theirs."""
    if len(e.args) != len(d.params):
        plural = "argument" if len(d.params) == 1 else "arguments"
        c.error(text.at(e.span), f"{d.name}() takes {len(d.params)} {plural} ({', '.join(d.params)}), given "
                f"{len(e.args)}", notes=(f"'{d.name}' is defined on line {d.key.start_mark.line + 1}",))
        return None
    scope: dict[str, tuple[Type, int]] = {}
    ok = True
    for name, arg in zip(d.params, e.args):
        t = c.infer(arg, text)
        impure = next((n for n in nodes(arg) if isinstance(n, ast.Call) and (n.func in STATEFUL or n.func in RANDOM)),
                      None)
        if impure is not None:
            c.error(text.at(impure.func_span), f"an argument of {d.name}() cannot call {impure.func}(): the body "
                    f"may use '{name}' more than once", notes=(f"compute {impure.func}(...) in a 'let' signal and "
                                                               "pass the signal",))
            ok = False
        if t is Type.LIST:  # format 1.3: a list of rows is a parameter of the file, read where it is named
            c.error(text.at(arg.span), f"{d.name}() takes numbers, booleans or groups, not a list of rows: give it "
                    "a row, as in " + (f"{d.name}({text.value[arg.span[0]:arg.span[1]]}[i])"
                                       if isinstance(arg, ast.Name) else "waypoints[i]"))
            ok = False
        elif t is None:
            ok = False
        else:
            scope[name] = (t, c.size(arg) if t in (Type.NUMBERS, Type.BOOLS) else 0)
    if not ok:
        return None
    c.expanded += sum(1 for _ in nodes(d.body.node))
    if c.expanded > MAX_EXPANDED:
        _expanded_too_far(c, e, text)
        return None
    body = copy(d.body.node)
    c.scopes.append((d, scope, e, text))
    try:
        t = c.infer(body, d.body.text)
        if t in (Type.NUMBERS, Type.BOOLS):  # a call that is a group has its body's members
            c.sizes[id(e)] = c.size(body)
    finally:
        c.scopes.pop()
    if c.expanded > MAX_EXPANDED:  # crossed inside the body: said at this call, in the file's expression
        _expanded_too_far(c, e, text)
        return None
    if t is not None:
        c.expansions[id(e)] = Expansion(d, body)
    return t


def _expanded_too_far(c: ExprChecker, e: ast.Call, text: Text) -> None:
    """The limit of expansion, said once in the file: at the first call outside any body that goes
    past it (the calls inside the bodies it went through are that call's)."""
    if c.scopes or c.expanded_reported:
        return
    c.expanded_reported = True
    c.error(text.at(e.span), f"the calls of this file's functions expand to more than {MAX_EXPANDED:,} "
            "operations (a function's body, once per call)", notes=(
                "a function that calls another several times, which calls another several times, grows fast: "
                "compute shared parts once, in 'let' signals",))


def body_name(c: ExprChecker, e: ast.Name, text: Text) -> Type | bool | None:
    """A name inside a function's body: a parameter, the file's parameter or a constant; False when
    the name is none of the function's and the checker's own rules apply."""
    d, scope, call, call_text = c.scopes[-1]
    if e.id in scope:
        return scope[e.id][0]
    if e.id == "dt" or c.kinds.get(e.id) in READABLE_KINDS:
        return False
    if e.id in c.types:
        c.error(text.at(e.span), f"'{e.id}' is a {c.kinds[e.id]}, and a function reads only its parameters "
                f"({', '.join(d.params) or 'none'}), the file's params and constants",
                notes=(f"pass it as an argument: add a parameter to '{d.name}' and give {e.id} in the call",))
        return None
    return False


def known_value(e: ast.Expr, constants: dict[str, object],
                scopes: list[tuple[FunctionDecl, dict[str, tuple[Type, int]], ast.Call | None, Text]],
                lengths: Mapping[int, int] | None = None) -> object | None:
    """The value of e known before the run, as the code generator folds it; None if it is not.

    Inside a function's body, a parameter whose argument folds is that constant (and one that
    does not is known only while running), as ``labsim.dsl.emit.unroll`` writes the body."""
    for d, _, call, _ in scopes:
        inner = {k: v for k, v in constants.items() if k not in d.params}
        for name, arg in zip(d.params, call.args if call is not None else ()):
            with contextlib.suppress(NotConstant):  # known only while running
                inner[name] = fold(arg, constants)
        constants = inner
    try:
        return fold(e, constants, PLACES if lengths is not None else None, lengths)
    except NotConstant:
        return None


def body_note(c: ExprChecker) -> tuple[str, ...]:
    """Where the function whose body is being checked was called from, for its messages."""
    if not c.scopes:
        return ()
    d, _, call, text = c.scopes[-1]
    if call is None:
        return ()
    line, col = text.doc.position(text.index(call.span[0]))
    return (f"in the call of {d.name}() at {text.doc.path}:{line}:{col}",)


def check_bodies(c: ExprChecker, functions: dict[str, FunctionDecl]) -> None:
    """Names a body reads, checked where it is defined: a function never called is checked too."""
    for d in functions.values():
        c.scopes.append((d, {p: (Type.NUMBER, 0) for p in d.params}, None, d.body.text))
        try:
            # another robot's value and what a robot heard (format 1.3) are not a function's to read;
            # a channel is not a name in scope, nor is say()'s: say is an action, told so where it is
            channels = set()
            for node in nodes(d.body.node):
                if isinstance(node, ast.Peer) or (isinstance(node, ast.Call) and node.func in ("heard", "say")
                                                  and node.func not in functions):
                    c.infer(node, d.body.text)
                    channels |= {id(a) for a in node.args[:1]} if isinstance(node, ast.Call) else set()
            for node in nodes(d.body.node):
                if isinstance(node, ast.Name) and id(node) not in channels \
                        and body_name(c, node, d.body.text) is False and node.id not in c.types:
                    c.name(node, d.body.text)
        finally:
            c.scopes.pop()
