"""Checked behaviour to plain Python callables: the last stage of the language.

``compile_file`` runs the whole front end (load, read, check) and returns a ``Program``: the
behaviour's settings plus everything needed to build one robot's callables. ``Program.robot``
builds them for one robot, bound to that robot's ``Slots`` (its snapshot of sensor values,
signals, time and state), its random generator and its fault sink, so that each robot has its
own state and the callables take no arguments.

The compiler generates Python source from the checked AST, as Jinja2's compiler does, and
compiles it once per robot: a run evaluates the rules tens of thousands of times, and one
generated function per tick phase costs almost nothing over a hand-written loop (a tree of
closures cost 1.45x; see docs/decisions.md, section 3). No user text reaches ``exec``: names become slot
indices, numbers ``repr`` literals, operators come from the grammar's fixed set. What the
generated code calls as it runs (guards, faults, metric accumulators) is in ``labsim.dsl.support``.
"""
from __future__ import annotations

import math
import random
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from labsim.backends.scene.models import RobotModel
from labsim.backends.scene.world import World
from labsim.dsl import ast
from labsim.dsl.builtins import ACTIONS, CONSTANTS, DETECTED, FIELDS, FUNCTIONS, JOINT_ACTIONS, Aggregate, Type
from labsim.dsl.check import Checked, check
from labsim.backends.scene.diagnostics import Diagnostic, Report
from labsim.dsl.read import RobotDecl, read
from labsim.backends.scene.source import Text, load
from labsim.dsl.support import (FIRST_CHANNEL, INF, STATE, TICK, TIME, Faults, FaultSite, Slots, guard,
                                initial_accumulator, namespace)

Fn = Callable[[], object]


def compile_file(path: str | Path, overrides: dict[str, str] | None = None) -> Program:
    """Load, read, check and compile a behaviour file; LabsimError lists every problem."""
    doc = load(path)
    report = Report()
    bf = read(doc, report)
    checked = check(bf, report, overrides)
    report.raise_if_errors()
    return Program(checked, [d for d in report.diagnostics if d.severity == "warning"])


@dataclass(frozen=True)
class RuleLabel:
    """A rule as the summary and the trace name it: ``wander:2``."""

    state: str
    number: int
    text: str
    line: int

    @property
    def id(self) -> str:
        return f"{self.state}:{self.number}"


@dataclass
class RobotProgram:
    """One robot's compiled behaviour: functions bound to its slots, generator and faults.

    ``signals(time_s, tick, values)`` takes the tick's channel values (in ``channels``
    order), evaluates the ``let`` signals into the slots and returns whether the stop
    condition holds; ``decide()`` runs the first rule that holds (writing ``command``: left
    and right wheel rad/s and the next state) and folds the metrics, returning the index of
    the rule that fired, or -1. ``both(time_s, tick, values)`` does the two in one call and
    returns -2 when the stop condition holds; a run with a single robot uses it.
    """

    slots: Slots
    command: list  # [left rad/s, right rad/s, next state index]
    signals: Callable[[float, int, list], bool]
    decide: Callable[[], int]
    both: Callable[[float, int, list], int]
    metric_values: list[list[float]]  # per metric accumulator, read by metric_result
    events: list[str]  # names of count metrics that rose this tick (cleared by the runtime)
    source: str  # the generated Python, for debugging
    joint_command: list[float] = field(default_factory=list)  # per Program.targets, nan: none yet


@dataclass
class Program:
    checked: Checked
    warnings: list[Diagnostic] = field(default_factory=list)

    def __post_init__(self) -> None:
        c = self.checked
        bf = c.file
        self.name: str = bf.name
        self.path: str = bf.path
        self.sha256: str = bf.sha256
        self.dt_s: float = bf.dt_s
        self.seed: int = bf.seed
        self.world: World = c.world  # type: ignore[assignment]
        self.params = dict(c.params)
        self.channels: tuple[str, ...] = c.channels
        self.let_names: tuple[str, ...] = tuple(name for name, _ in c.lets)
        self.state_names: tuple[str, ...] = tuple(c.states)
        self.rules: list[RuleLabel] = [
            RuleLabel(r.state, r.number, r.text.value.strip().replace("\n", " "), r.text.node.start_mark.line + 1)
            for rules in c.states.values() for r in rules]
        self.metric_names: tuple[str, ...] = tuple(m.name for m in c.metrics)
        self.metric_aggregates: tuple[Aggregate, ...] = tuple(m.aggregate for m in c.metrics)
        self.robot_decls: list[RobotDecl] = list(bf.robots)
        self.models: dict[str, RobotModel] = dict(c.models)
        self.slot_of = {"time": TIME, "tick": TICK, "state": STATE}
        self.slot_of.update({name: FIRST_CHANNEL + i for i, name in enumerate(self.channels)})
        for i, name in enumerate(self.let_names):
            self.slot_of[name] = FIRST_CHANNEL + len(self.channels) + i
        # sliders, then the fields of their labels, after the signals
        self.slider_names: tuple[str, ...] = tuple(sl.name for sl in c.sliders)
        self.slider_ranges = {sl.name: (sl.lo, sl.hi) for sl in c.sliders}
        self.slider_start = {sl.name: sl.value for sl in c.sliders}
        base = FIRST_CHANNEL + len(self.channels) + len(self.let_names) + len(self.slider_names)
        for k, name in enumerate(self.slider_names):
            self.slot_of[name] = base - len(self.slider_names) + k
        self.labels: list[tuple[str, list[str | tuple[int, str]]]] = []  # slider -> text and (slot, format)
        self.label_fields: list[tuple[int, object]] = []  # slot, parsed expression
        for slider, parts in c.labels:
            compiled: list[str | tuple[int, str]] = []
            for part in parts:
                if isinstance(part, tuple):
                    slot = base + len(self.label_fields)
                    self.label_fields.append((slot, part[0]))
                    compiled.append((slot, part[1]))
                else:
                    compiled.append(part)
            self.labels.append((slider, compiled))
        self.slot_count = base + len(self.label_fields)
        # joint targets set by bind: and by set_velocity/set_position, in a fixed order
        self.targets: list[tuple[str, str]] = []
        for b in c.binds:
            if (b.joint, b.mode) not in self.targets:
                self.targets.append((b.joint, b.mode))
        for rules in c.states.values():
            for r in rules:
                for a in r.rule.actions:
                    if isinstance(a, ast.Action) and a.name in JOINT_ACTIONS:
                        target = (a.args[0].id, JOINT_ACTIONS[a.name])  # type: ignore[union-attr]
                        if target not in self.targets:
                            self.targets.append(target)
        self._source: tuple[str, list[tuple[str, object]]] | None = None
        self._generated_functions: tuple[str, ...] = ()

    def checked_type(self, e: ast.Expr) -> Type:
        """The type the checker gave an expression."""
        return self.checked.node_types[id(e)]

    def source(self) -> tuple[str, list[tuple[str, object]]]:
        """The generated module (shared by every robot) and the fault sites it refers to."""
        if self._source is None:
            self._source = _Generator(self).module()
        return self._source

    def robot(self, name: str, rng: random.Random, faults: Faults, model: RobotModel | None = None) -> RobotProgram:
        """Bind the generated functions to one robot's slots, generator, model and fault sink."""
        source, sites = self.source()
        slots = Slots([0.0] * self.slot_count)
        slots[STATE] = 0
        for slider in self.slider_names:
            slots[self.slot_of[slider]] = self.slider_start[slider]
        command = [0.0, 0.0, 0]
        joint_command = [math.nan] * len(self.targets)
        events: list[str] = []
        metric_values = [initial_accumulator(a) for a in self.metric_aggregates]
        bindings = namespace(rng, model or next(iter(self.models.values()), None), self._functions)
        bindings.update(s=slots, cmd=command, events=events, m=metric_values, jc=joint_command)
        for i, (kind, site) in enumerate(sites):
            bindings[f"_g{i}"] = guard(kind, site, faults, slots, name, rng)  # type: ignore[arg-type]
        # Only generated text reaches exec: user names became slot indices, numbers are
        # repr(float), operators come from a fixed table (see _Generator). The functions are
        # made by a factory so that everything they use is a closure cell, not a global.
        scope: dict[str, object] = {"__builtins__": {}}
        exec(compile(source, f"<behaviour {self.path}>", "exec"), scope)
        signals, decide, both = scope["make"](**bindings)  # type: ignore[operator]
        return RobotProgram(slots, command, signals, decide, both, metric_values, events, source, joint_command)

    def label_text(self, slots: list) -> dict[str, str]:
        """Each slider's label, formatted from the label fields' values in the slots."""
        out = {}
        for slider, parts in self.labels:
            text = []
            for part in parts:
                if isinstance(part, tuple):
                    slot, spec = part
                    value = slots[slot]
                    if spec.endswith("d") and isinstance(value, float) and value.is_integer():
                        value = int(value)  # sliders hold floats; {arm:d} shows 5, not 5.0
                    try:
                        text.append(format(value, spec))
                    except (ValueError, TypeError):
                        text.append(str(value))
                else:
                    text.append(part)
            out[slider] = "".join(text)
        return out

    @property
    def _functions(self) -> tuple[str, ...]:
        return self._generated_functions


# Functions that return a value for every argument (inf and nan included): called directly.
# The others may raise (sqrt(-1), log(-1), floor(inf), exp(1000), randint(3, 2), crop outside
# the image) and go through a guard that turns the exception into a defined result and a
# warning; centroid and pid have guards of their own.
_TOTAL = frozenset({"abs", "min", "max", "clamp", "hypot", "atan2",
                    "sign", "deg", "rad", "random", "uniform", "gauss",
                    "gray", "threshold", "invert", "area", "width", "height"})
_FOLDABLE = frozenset(f for f in _TOTAL if callable(FUNCTIONS[f].impl) and not FUNCTIONS[f].uses_rng)


class _NotConstant(Exception):
    pass


def constant_value(program: Program, e: ast.Expr) -> object | None:
    """The value of an expression that reads nothing at run time (params folded), else None."""
    try:
        return _Generator(program).fold(e)
    except _NotConstant:
        return None


class _Generator:
    """Checked AST to the Python source of ``signals()`` and ``decide()``.

    Every expression is emitted fully parenthesised from a fixed set of forms: ``vN`` (slot N,
    read into a local once per function) for a sensor, signal or built-in variable, a literal made by ``repr`` of a number, an operator
    from the grammar's fixed set, ``_name(...)`` for a built-in function (the namespace maps
    it), and ``_gN(...)`` for an operation that can fault, bound to its site. Parameters and
    other constants are folded, so ``time >= minutes * 60`` becomes ``(s[0] >= 1500)``.
    """

    def __init__(self, program: Program):
        self.p = program
        self.sites: list[tuple[str, FaultSite]] = []
        self.used: set[int] = set()  # slots the function being generated reads
        self.functions: set[str] = set()  # built-ins called directly

    def module(self) -> tuple[str, list[tuple[str, FaultSite]]]:
        """The source of ``make(...)``, which returns ``signals``, ``decide`` and ``both``.

        ``signals(time, tick, values)`` evaluates the signals and returns the stop condition;
        ``decide()`` picks and runs the rule and folds the metrics; ``both`` is the two in one
        function for a run with a single robot, returning -2 when the run stops. Each reads
        the values it uses into locals (v<slot>) once: the same rule reads the same sensor
        several times, and a local costs a third of a slot read.
        """
        c = self.p.checked
        n = len(self.p.channels)
        channel_slots = set(range(FIRST_CHANNEL, FIRST_CHANNEL + n))
        let_slots = {self.p.slot_of[name] for name, _ in c.lets}
        unpack = [", ".join(f"v{i}" for i in sorted(channel_slots)) + ", = values"] if n else []
        self.used = set()
        lets = [f"s[{self.p.slot_of[name]}] = v{self.p.slot_of[name]} = "
                + self.expr(parsed.node, parsed.text, "signal " + repr(name)) for name, parsed in c.lets]
        lets += [f"s[{slot}] = {self.expr(parsed.node, parsed.text, 'a label')}"
                 for slot, parsed in self.p.label_fields]
        assert c.file.stop is not None
        stop = self.expr(c.file.stop.node, c.file.stop.text, "the stop condition")
        signal_loads = self.loads(self.used - channel_slots - let_slots - {TIME, TICK})
        self.used = set()
        rules = self.decide(c)
        decide_used = self.used
        out = (["def signals(v0, v1, values):", "    s[0] = v0", "    s[1] = v1"]
               + ([f"    s[{FIRST_CHANNEL}:{FIRST_CHANNEL + n}] = values"] if n else [])
               + ["    " + line for line in unpack] + signal_loads
               + ["    " + line for line in lets] + [f"    return {stop}", ""])
        out += ["def decide():"] + self.loads(decide_used) + ["    " + line for line in rules] + [""]
        out += (["def both(v0, v1, values):"] + ["    " + line for line in unpack] + signal_loads
                + ["    " + line for line in lets] + [f"    if {stop}:", "        return -2"]
                + self.loads(decide_used - channel_slots - let_slots - {TIME, TICK} - self.loaded(signal_loads))
                + ["    " + line for line in rules])
        params = ["s", "cmd", "jc", "events", "m", "_inf", "_nan", "_randint", "_random", "_uniform", "_gauss",
                  "_radius", "_half_axle"]
        self.p._generated_functions = tuple(sorted(self.functions))
        params += ["_" + f for f in self.p._generated_functions]
        params += [f"_g{i}" for i in range(len(self.sites))]
        text = "\n".join("    " + line if line else "" for line in out)
        return f"def make({', '.join(params)}):\n{text}\n    return signals, decide, both\n", self.sites

    @staticmethod
    def loaded(loads: list[str]) -> set[int]:
        return {int(line.split("=")[0].strip()[1:]) for line in loads}

    @staticmethod
    def loads(slots: set[int]) -> list[str]:
        return [f"    v{i} = s[{i}]" for i in sorted(slots)]

    def decide(self, c: Checked) -> list[str]:
        out = []
        # bindings first: a rule's set_velocity/set_position can override one for a tick
        for b in c.binds:
            k = self.p.targets.index((b.joint, b.mode))
            out.append(f"jc[{k}] = {self.expr(b.expr.node, b.expr.text, 'the binding of ' + b.joint)}")
        states = list(c.states.values())
        index = 0
        if not states:
            out.append("rule = -1")
        for k, rules in enumerate(states):
            indent = ""
            if len(states) > 1:
                self.used.add(STATE)
                out.append(f"{'if' if k == 0 else 'elif'} v{STATE} == {k}:")
                indent = "    "
            has_default = False
            for n, r in enumerate(rules):
                where = f"rule {r.state}:{r.number}"
                if r.rule.condition is None:
                    out.append(f"{indent}{'else:' if n else 'if True:'}")
                    has_default = True
                else:
                    test = self.expr(r.rule.condition, r.text, where)
                    out.append(f"{indent}{'elif' if n else 'if'} {test}:")
                out += [f"{indent}    {line}" for line in self.actions(r.rule.actions, r.text, where)]
                out.append(f"{indent}    rule = {index}")
                index += 1
                if has_default:
                    index += len(rules) - n - 1  # the checker refused rules after it
                    break
            if not has_default:
                out.append(f"{indent}else:")
                out.append(f"{indent}    rule = -1")
        if len(states) > 1:
            out.append("else:")
            out.append("    rule = -1")
        for i, metric in enumerate(c.metrics):
            e = self.expr(metric.expr, metric.text, f"metric {metric.name!r}")
            out += _METRIC_CODE[metric.aggregate].format(e=e, i=i).splitlines()
        out.append("return rule")
        return out

    def actions(self, actions: tuple, text: Text, where: str) -> list[str]:
        lines = []
        for action in actions:
            if isinstance(action, ast.Goto):
                lines.append(f"cmd[2] = {self.p.state_names.index(action.state)}")
            elif action.name in JOINT_ACTIONS:
                joint = action.args[0]
                assert isinstance(joint, ast.Name)
                k = self.p.targets.index((joint.id, JOINT_ACTIONS[action.name]))
                lines.append(f"jc[{k}] = {self.expr(action.args[1], text, where)}")
            elif action.name == "stop":
                lines.append("cmd[0] = cmd[1] = 0.0")
            elif action.name == "move":
                lines.append(f"cmd[0] = cmd[1] = {self.expr(action.args[0], text, where)}")
            elif action.name == "drive":
                # v m/s and w rad/s to wheel rad/s: (v -/+ w * axle / 2) / wheel radius
                lines.append(f"_v = {self.expr(action.args[0], text, where)}")
                lines.append(f"_w = {self.expr(action.args[1], text, where)}")
                lines.append("cmd[0] = (_v - _w * _half_axle) / _radius")
                lines.append("cmd[1] = (_v + _w * _half_axle) / _radius")
            else:
                assert action.name in ("arc", "wheels")
                lines.append(f"cmd[0] = {self.expr(action.args[0], text, where)}")
                lines.append(f"cmd[1] = {self.expr(action.args[1], text, where)}")
        return lines

    def site(self, kind: str, text: Text, span: ast.Span, where: str) -> str:
        self.sites.append((kind, FaultSite(where, text.diagnostic(span[0], span[1], ""))))
        return f"_g{len(self.sites) - 1}"

    # -- expressions -------------------------------------------------------------------------
    def expr(self, e: ast.Expr, text: Text, where: str) -> str:
        try:
            return _literal(self.fold(e))
        except _NotConstant:
            return self.emit(e, text, where)

    def fold(self, e: ast.Expr) -> object:
        """The value of a subtree that reads nothing at run time; _NotConstant otherwise."""
        p = self.p
        if isinstance(e, (ast.Number, ast.Bool)):
            return e.value
        if isinstance(e, ast.Name):
            if e.id in p.params:
                return p.params[e.id]
            if e.id in CONSTANTS:
                return CONSTANTS[e.id]
            if e.id == "dt":
                return p.dt_s
            if e.id in p.state_names and e.id not in p.slot_of:
                return p.state_names.index(e.id)
            raise _NotConstant
        try:
            if isinstance(e, ast.Neg):
                return -self.fold(e.operand)  # type: ignore[operator]
            if isinstance(e, ast.Not):
                return not self.fold(e.operand)
            if isinstance(e, ast.Binary):
                return _BINARY[e.op](self.fold(e.left), self.fold(e.right))
            if isinstance(e, ast.Compare):
                values = [self.fold(o) for o in e.operands]
                return all(_COMPARE[op](a, b) for op, a, b in zip(e.ops, values, values[1:]))
            if isinstance(e, ast.BoolOp):
                values = [self.fold(v) for v in e.values]
                return all(values) if e.op == "and" else any(values)
            if isinstance(e, ast.IfExp):
                return self.fold(e.body) if self.fold(e.test) else self.fold(e.orelse)
            if isinstance(e, ast.Call) and e.func in _FOLDABLE:
                return FUNCTIONS[e.func].impl(*(self.fold(a) for a in e.args))  # type: ignore[operator]
        except (ArithmeticError, ValueError, TypeError):
            raise _NotConstant from None  # leave it to run time, where it warns at its site
        raise _NotConstant

    def emit(self, e: ast.Expr, text: Text, where: str) -> str:
        x = lambda sub: self.expr(sub, text, where)  # noqa: E731
        if isinstance(e, ast.Name):
            slot = self.p.slot_of[e.id]
            self.used.add(slot)
            return f"v{slot}"
        if isinstance(e, ast.Neg):
            return f"(-{x(e.operand)})"
        if isinstance(e, ast.Not):
            return f"(not {x(e.operand)})"
        if isinstance(e, ast.Binary):
            a, b = x(e.left), x(e.right)
            if e.op in ("+", "-", "*"):
                return f"({a} {e.op} {b})"
            try:
                divisor = self.fold(e.right)
                if e.op in ("/", "%") and isinstance(divisor, (int, float)) and divisor != 0:
                    return f"({a} {e.op} {b})"
            except _NotConstant:
                pass
            return f"{self.site(e.op, text, e.span, where)}({a}, {b})"
        if isinstance(e, ast.Compare):
            parts = [x(e.operands[0])]
            for op, operand in zip(e.ops, e.operands[1:]):
                parts += [op, x(operand)]
            return "(" + " ".join(parts) + ")"
        if isinstance(e, ast.BoolOp):
            return "(" + f" {e.op} ".join(x(v) for v in e.values) + ")"
        if isinstance(e, ast.IfExp):
            return f"({x(e.body)} if {x(e.test)} else {x(e.orelse)})"
        if isinstance(e, ast.Attribute):
            value_type = self.p.checked_type(e.value)
            index = FIELDS[value_type][e.attr][0]
            return f"{x(e.value)}[{index}]"
        if isinstance(e, ast.Call):
            if e.func == DETECTED:
                assert isinstance(e.args[0], ast.Name)
                return f"({self.emit(e.args[0], text, where)} < _inf)"
            args = ", ".join(x(a) for a in e.args)
            if e.func == "randint":
                try:
                    lo, hi = (self.fold(a) for a in e.args)
                    if all(isinstance(v, (int, float)) and float(v).is_integer() for v in (lo, hi)) and lo <= hi:
                        return f"_randint({int(lo)}, {int(hi)})"  # type: ignore[arg-type]
                except _NotConstant:
                    pass
            if e.func in _TOTAL and not FUNCTIONS[e.func].uses_rng:
                self.functions.add(e.func)
                return f"_{e.func}({args})"
            if e.func in ("random", "uniform", "gauss"):
                return f"_{e.func}({args})"
            return f"{self.site(e.func, text, e.span, where)}({args})"
        raise AssertionError(f"cannot compile {e!r}")


def _literal(value: object) -> str:
    if isinstance(value, bool):
        return "True" if value else "False"
    if isinstance(value, int):
        return repr(value)
    assert isinstance(value, float)
    if value != value:
        return "_nan"
    if value in (INF, -INF):
        return "_inf" if value > 0 else "(-_inf)"
    return repr(value) if value >= 0 else f"({value!r})"


_BINARY: dict[str, Callable[[object, object], object]] = {
    "+": lambda a, b: a + b, "-": lambda a, b: a - b, "*": lambda a, b: a * b,  # type: ignore[operator]
    "/": lambda a, b: a / b, "%": lambda a, b: a % b,  # type: ignore[operator]
    "**": lambda a, b: _real(a ** b),  # type: ignore[operator]
}
_COMPARE: dict[str, Callable[[object, object], bool]] = {
    "<": lambda a, b: a < b, "<=": lambda a, b: a <= b, ">": lambda a, b: a > b,  # type: ignore[operator]
    ">=": lambda a, b: a >= b, "==": lambda a, b: a == b, "!=": lambda a, b: a != b,  # type: ignore[operator]
}


def _real(value: object) -> object:
    if isinstance(value, complex):
        raise ValueError("complex result")
    return value


# How each aggregate folds its value in decide(); `events` gets the metric's index.
_METRIC_CODE = {
    Aggregate.COUNT: "v = {e}\nif v and not m[{i}][1]:\n    m[{i}][0] += 1\n    events.append({i})\nm[{i}][1] = v",
    Aggregate.DURATION: "if {e}:\n    m[{i}][0] += 1",
    Aggregate.MEAN: "v = {e}\nif -_inf < v < _inf:\n    m[{i}][0] += v\n    m[{i}][1] += 1",
    Aggregate.MAXIMUM: "v = {e}\nif m[{i}][0] < v < _inf:\n    m[{i}][0] = v",
    Aggregate.MINIMUM: "v = {e}\nif -_inf < v < m[{i}][0]:\n    m[{i}][0] = v",
    Aggregate.RMS: "v = {e}\nif -_inf < v < _inf:\n    m[{i}][0] += v * v\n    m[{i}][1] += 1",
    Aggregate.FINAL: "m[{i}][0] = {e}",
}
