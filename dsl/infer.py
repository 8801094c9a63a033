"""Expression types: the half of the checker that resolves names and types expressions.

``labsim.dsl.check`` declares what is in scope (sensors, parameters, ``let`` signals, states,
sliders, built-ins) and asks ``ExprChecker.infer`` and ``ExprChecker.expect`` for the type of
each expression of the file. Each unknown name, each operand of the wrong type and each wrong
call is reported here, with a did-you-mean where one helps; an expression that has no type
gives None, and its uses say nothing more.
"""
from __future__ import annotations

import difflib

from yaml.nodes import Node

from labsim.dsl import ast
from labsim.dsl.builtins import ACTIONS, AGGREGATES, DETECTED, FIELDS, FUNCTIONS, Type
from labsim.dsl.read import Parsed
from labsim.foundation.diagnostics import Report, did_you_mean
from labsim.foundation.numbers import WHOLE_LIMIT
from labsim.foundation.source import Document, Place, Text


class ExprChecker:
    """The names in scope, their types, and the checks of expressions against them."""

    def __init__(self, doc: Document, report: Report) -> None:
        self.doc = doc
        self.report = report
        self.types: dict[str, Type] = {}  # every name in scope
        self.kinds: dict[str, str] = {}  # name -> what it is, for messages
        self.used: set[str] = set()
        self.later: dict[str, Node] = {}  # lets not yet defined while checking one, for messages
        self.node_types: dict[int, Type] = {}  # id(AST node) -> its type
        self.distance: set[str] = set()  # distance sensors, for detected()
        self.poisoned: set[str] = set()  # names whose definition failed: no follow-on errors
        self.world_failed = False  # names the world would have given are not reported unknown
        self.metric_names: set[str] = set()  # the file's metrics: not names an expression can read

    def error(self, place: Place, message: str, notes: tuple[str, ...] = ()) -> None:
        """Report a problem at a place of the file: a YAML node, characters of an expression's
        text (``text.at(span)``), or None for the file as a whole."""
        self.report.add(self.doc.diagnostic(place, message, notes=notes))

    def declare(self, name: str, t: Type, kind: str) -> None:
        self.types[name] = t
        self.kinds[name] = kind

    def expect(self, parsed: Parsed, e: ast.Expr, want: Type, what: str) -> bool:
        t = self.infer(e, parsed.text)
        if t is None:
            return False
        if t is not want:
            hint: tuple[str, ...] = ()
            if want is Type.BOOL and t is Type.NUMBER:
                hint = ("compare it with something, e.g. 'sonar5 <= 0.5'",)
            self.error(parsed.text.at(e.span), f"{what} must be {want.a}, but this is {t.a}", notes=hint)
            return False
        return True

    def infer(self, e: ast.Expr, text: Text) -> Type | None:
        """The type of an expression, or None after reporting why it has none."""
        t = self._infer(e, text)
        if t is not None:
            self.node_types[id(e)] = t
        return t

    def _infer(self, e: ast.Expr, text: Text) -> Type | None:
        if isinstance(e, ast.Number):
            return Type.NUMBER
        if isinstance(e, ast.Bool):
            return Type.BOOL
        if isinstance(e, ast.Name):
            return self.name(e, text)
        if isinstance(e, ast.Neg):
            return self.operands(text, "-", [e.operand], Type.NUMBER, Type.NUMBER)
        if isinstance(e, ast.Not):
            return self.operands(text, "not", [e.operand], Type.BOOL, Type.BOOL)
        if isinstance(e, ast.Binary):
            return self.operands(text, e.op, [e.left, e.right], Type.NUMBER, Type.NUMBER)
        if isinstance(e, ast.BoolOp):
            return self.operands(text, e.op, list(e.values), Type.BOOL, Type.BOOL)
        if isinstance(e, ast.Compare):
            return self.compare(e, text)
        if isinstance(e, ast.IfExp):
            self.expect(Parsed(e.test, text), e.test, Type.BOOL, "the condition of 'a if condition else b'")
            a, b = self.infer(e.body, text), self.infer(e.orelse, text)
            if a is not None and b is not None and a is not b:
                self.error(text.at(e.span), "both sides of 'a if condition else b' must have one type, "
                           f"not {a.a} and {b.a}")
                return None
            return a if a is not None else b
        if isinstance(e, ast.Call):
            return self.call(e, text)
        if isinstance(e, ast.Attribute):
            t = self.infer(e.value, text)
            if t is None:
                return None
            fields = FIELDS.get(t)
            if fields is None:
                self.error(text.at(e.attr_span), f"{t.a} has no field '.{e.attr}'")
                return None
            if e.attr not in fields:
                names = ", ".join("." + f for f in fields)
                self.error(text.at(e.attr_span), f"{t.a} has the fields {names}; not '.{e.attr}'"
                           f"{did_you_mean(e.attr, fields)}")
                return None
            return fields[e.attr][1]
        raise AssertionError(f"unknown node {e!r}")

    def name(self, e: ast.Name, text: Text) -> Type | None:
        if e.id in self.types:
            self.used.add(e.id)
            return self.types[e.id]
        if e.id in self.poisoned or self.world_failed:
            return None  # its definition (or the world) is already reported: say nothing more
        if e.id in self.later:
            line = self.later[e.id].start_mark.line + 1
            self.error(text.at(e.span), f"signal '{e.id}' is used before it is defined (on line {line}); "
                       "'let' signals are evaluated in order")
            return None
        if e.id in FUNCTIONS or e.id in ACTIONS:
            self.error(text.at(e.span), f"'{e.id}' is a function: call it as {e.id}(...)")
            return None
        if e.id in self.metric_names:
            self.error(text.at(e.span), f"'{e.id}' is a metric: metrics are summed up over the run for the "
                       "summary, and expressions cannot read them",
                       notes=("to use it here, compute it as a signal under 'let:' (e.g. 'held(...)' for a "
                              "duration, 'counter(...)' for a count, 'total(...)' for a sum; docs/language.md, "
                              "Time and memory)",))
            return None
        hint = did_you_mean(e.id, self.types)
        notes: tuple[str, ...] = ()
        if e.id.startswith("sonar") and e.id[5:].isdigit():
            notes = ("the robot's sonars are sonar1 .. sonar16, numbered as in CoppeliaSim",)
        elif e.id == "camera":
            notes = ("this robot has no camera: add one to it, e.g. "
                     "camera: {resolution: [128, 128], fov_deg: 60, height_m: 0.3, pitch_deg: 45}",)
        elif e.id in ("road_offset", "on_road", "laps"):
            notes = ("this world has no road",)
        self.error(text.at(e.span), f"unknown name '{e.id}'{hint}", notes=notes)
        return None

    def operands(self, text: Text, op: str, args: list[ast.Expr], want: Type, result: Type) -> Type | None:
        ok = True
        for arg in args:
            t = self.infer(arg, text)
            if t is None:
                ok = False
            elif t is not want:
                self.error(text.at(arg.span), f"'{op}' needs {want.a}, but this is {t.a}")
                ok = False
        return result if ok else None

    def compare(self, e: ast.Compare, text: Text) -> Type | None:
        inferred = [self.infer(o, text) for o in e.operands]
        types = [t for t in inferred if t is not None]
        if len(types) != len(inferred):
            return None
        if Type.STATE in types:
            if len(e.operands) != 2 or e.ops[0] not in ("==", "!=") or types[0] is not types[1]:
                self.error(text.at(e.span), "a state can only be compared with ==/!= to another state, "
                           "as in 'state == follow'")
                return None
            return Type.BOOL
        for (a, b, op, ta, tb) in zip(e.operands, e.operands[1:], e.ops, types, types[1:]):
            if op in ("==", "!=") and ta is tb is Type.BOOL:
                continue
            for node, t in ((a, ta), (b, tb)):
                if t is not Type.NUMBER:
                    self.error(text.at(node.span), f"'{op}' compares numbers, but this is {t.a}")
                    return None
        return Type.BOOL

    def call(self, e: ast.Call, text: Text) -> Type | None:
        if e.func == DETECTED:
            if len(e.args) != 1 or not isinstance(e.args[0], ast.Name):
                self.error(text.at(e.span), "detected() takes one distance sensor's name, as in detected(sonar5)")
                return None
            sensor = e.args[0]
            t = self.name(sensor, text)
            if t is not None and sensor.id not in self.distance:
                self.error(text.at(sensor.span), f"detected() takes a distance sensor's name (sonar1 .. sonar16), "
                           f"and '{sensor.id}' is not one")
                return None
            return Type.BOOL if t is not None else None
        if e.func == "prev" and len(e.args) == 2:
            return self.prev(e, text)
        f = FUNCTIONS.get(e.func)
        if f is None:
            notes: tuple[str, ...] = ()
            if e.func in AGGREGATES:
                message = f"'{e.func}' is a metric aggregate: it can only be the outer call of a 'metrics:' entry"
                if e.func == "count":
                    notes = ("to count inside an expression, counter(c) counts the ticks c became true",)
            elif e.func in ACTIONS:
                message = f"'{e.func}' is an action: it goes after 'then', not inside an expression"
            elif e.func in _MEANT:
                message = f"unknown function '{e.func}' (did you mean {_MEANT[e.func]}?)"
                notes = function_notes(e.func, nearest=False)
            else:
                message = f"unknown function '{e.func}'{did_you_mean(e.func, list(FUNCTIONS) + [DETECTED])}"
                notes = function_notes(e.func)
            self.error(text.at(e.func_span), message, notes)
            for arg in e.args:
                self.infer(arg, text)
            return None
        n = len(e.args)
        fixed = len(f.params) - f.optional
        if (not fixed <= n <= len(f.params) and not f.variadic) or (f.variadic and n < len(f.params)):
            self.error(text.at(e.span),
                       arity_message(f.name, tuple(str(p) for p in f.params), n, f.variadic, f.optional))
            return None
        ok = True
        for i, arg in enumerate(e.args):
            want = f.params[min(i, len(f.params) - 1)]
            ok = self.expect(Parsed(arg, text), arg, want, f"argument {i + 1} of {f.name}()") and ok
        if f.name == "randint":
            ok = self.whole_bounds(e, text) and ok
        return f.returns if ok else None

    def whole_bounds(self, e: ast.Call, text: Text) -> bool:
        """randint's bounds, where written as numbers, are within +-WHOLE_LIMIT: exact as floats."""
        for arg in e.args:
            value = -arg.operand.value if isinstance(arg, ast.Neg) and isinstance(arg.operand, ast.Number) else (
                arg.value if isinstance(arg, ast.Number) else None)
            if value is not None and not abs(value) <= WHOLE_LIMIT:
                self.error(text.at(arg.span), f"randint() takes bounds between -{WHOLE_LIMIT} and {WHOLE_LIMIT} "
                           "(2**53: whole numbers a float holds exactly)")
                return False
        return True

    def prev(self, e: ast.Call, text: Text) -> Type | None:
        """prev(x, initial) takes a number or a boolean, and an initial value of the same type."""
        a, b = (self.infer(arg, text) for arg in e.args)
        if a is None or b is None:
            return None
        if a not in (Type.NUMBER, Type.BOOL):
            self.error(text.at(e.args[0].span), f"prev() keeps a number or a boolean, not {a.a}")
            return None
        if b is not a:
            self.error(text.at(e.args[1].span), f"prev()'s initial value must be {a.a} like its first "
                       f"argument, but this is {b.a}")
            return None
        return a


def arity_message(name: str, params: tuple[str, ...], given: int, variadic: bool = False,
                  optional: int = 0) -> str:
    """'f() takes 2 arguments (x, y), given 3', and its variants."""
    n = len(params)
    if variadic:
        return f"{name}() takes at least {n} arguments, given {given}"
    if optional:
        return f"{name}() takes {n - optional} to {n} arguments, given {given}"
    plural = "argument" if n == 1 else "arguments"
    listed = f" ({', '.join(params)})" if params and not all(p in ('number', 'boolean') for p in params) else ""
    return f"{name}() takes {n} {plural}{listed}, given {given}"


# Functions students reach for under another name: what to write instead.
_MEANT = {
    "distance": "hypot(dx, dy)", "dist": "hypot(dx, dy)",
    "norm": "hypot(dx, dy)", "sqr": "x ** 2", "pow": "x ** y", "power": "x ** y",
    "average": "mean(...)", "avg": "mean(...)", "atan": "atan2(y, x)", "arctan": "atan2(y, x)",
    "absolute": "abs(x)", "limit": "clamp(x, lo, hi)", "constrain": "clamp(x, lo, hi)",
    "print": 'the action log("...")', "delay": "state_time or held(...)", "wait": "state_time or held(...)",
    "previous": "prev(x, initial)", "sum": "total(x)", "integral": "total(x * dt)", "integrate": "total(x * dt)",
    "accumulate": "total(x)", "edges": "counter(c)", "tally": "counter(c)",
}


def function_notes(name: str, nearest: bool = True) -> tuple[str, ...]:
    """What an unknown function's message lists: the nearest functions, and where they are all."""
    names = sorted([*FUNCTIONS, DETECTED])
    close = difflib.get_close_matches(name, names, n=3, cutoff=0.4) if nearest else []
    return ((f"the nearest: {', '.join(close)}; " if close else "")
            + "functions: " + ", ".join(names),
            "each is described in docs/language.md, under 'Functions'")
