"""Checked behaviour to Python source: the code generator, after the checker.

``generate`` lays out a robot's slots (``layout``) and writes one factory, ``make(...)``,
which returns ``signals``, ``decide`` and ``both`` for one robot; it compiles that source once,
and ``labsim.dsl.program`` runs the code object for each robot. A run evaluates the rules tens
of thousands of times, and one generated function per tick phase costs almost nothing over a
hand-written loop (a tree of closures cost 1.45x; see docs/decisions.md, section 3).

No user text reaches ``compile``: names become slot indices, numbers ``repr`` literals,
operators come from the grammar's fixed set. Where a rule, signal or metric begins, the source
has a marker comment (``#@7``); the ``listing`` is the same text with each marker replaced by
the file's line and text (``# behaviours/wall_follow.yaml:23: if ahead <= front then ...``),
so it lines up with the compiled code line for line: ``labsim check --show-code`` prints it,
and tracebacks through generated functions show it.

Over 500 lines: one generator class emits every form of the language (expressions, rules,
metrics, bindings, the stop condition, memory) from one table of slots; split, each part
would reach into the others' state.
"""
from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

from labsim.dsl import ast
from labsim.dsl.builtins import CONSTANTS, DETECTED, FIELDS, FUNCTIONS, JOINT_ACTIONS, STATE_CLOCK, Aggregate
from labsim.dsl.check import Checked
from labsim.dsl.program import Code, LabelPart
from labsim.dsl.read import Parsed
from labsim.dsl.support import FIRST_CHANNEL, STATE, TICK, TIME, FaultSite
from labsim.foundation.numbers import WHOLE_LIMIT
from labsim.foundation.source import Text

INF = math.inf


@dataclass(frozen=True)
class Layout:
    """Where each value lives in a robot's slots, and the joint targets in command order."""

    slot_of: Mapping[str, int]  # time, tick, state, channels, signals, sliders -> slot
    slot_count: int
    labels: tuple[tuple[str, tuple[LabelPart, ...]], ...]  # slider -> text and (slot, format spec)
    label_fields: tuple[tuple[int, str, Parsed], ...]  # slot, slider, the field's expression
    targets: tuple[tuple[str, str], ...]  # (joint, "velocity" | "position")


@dataclass(frozen=True)
class Generated:
    layout: Layout
    code: Code
    stop_horizon_s: float | None
    logs: tuple[tuple[int, tuple[LabelPart, ...]], ...] = ()  # each log(): its line, and its text's parts
    stop_parts: tuple[str, ...] = ()  # the stop condition's top-level 'or' parts, as written


def generate(checked: Checked, filename: str) -> Generated:
    """The behaviour's Python, compiled under ``filename``, with the layout it assumes."""
    slots = layout(checked)
    g = _Generator(checked, slots)
    source, listing = g.module()
    code = Code(source, listing, filename, compile(source, filename, "exec"), tuple(g.sites),
                tuple(sorted(g.functions)))
    return Generated(slots, code, g.stop_horizon(), tuple(g.logs), g.stop_parts)


def layout(c: Checked) -> Layout:
    """Slots: time, tick, state, the channels, the signals, the sliders, then the label fields."""
    slot_of = {"time": TIME, "tick": TICK, "state": STATE}
    slot_of.update({name: FIRST_CHANNEL + i for i, name in enumerate(c.channels)})
    for i, (name, _) in enumerate(c.lets):
        slot_of[name] = FIRST_CHANNEL + len(c.channels) + i
    sliders = [sl.name for sl in c.sliders]
    base = FIRST_CHANNEL + len(c.channels) + len(c.lets) + len(sliders)
    for k, name in enumerate(sliders):
        slot_of[name] = base - len(sliders) + k
    labels: list[tuple[str, tuple[LabelPart, ...]]] = []
    fields: list[tuple[int, str, Parsed]] = []
    for slider, parts in c.labels:
        compiled: list[LabelPart] = []
        for part in parts:
            if isinstance(part, tuple):
                slot = base + len(fields)
                fields.append((slot, slider, part[0]))
                compiled.append((slot, part[1]))
            else:
                compiled.append(part)
        labels.append((slider, tuple(compiled)))
    # joint targets set by bind: and by set_velocity/set_position, in a fixed order
    targets: list[tuple[str, str]] = []
    for b in c.binds:
        if (b.joint, b.mode) not in targets:
            targets.append((b.joint, b.mode))
    for rules in c.states.values():
        for r in rules:
            for a in r.rule.actions:
                if isinstance(a, ast.Action) and a.name in JOINT_ACTIONS:
                    joint = a.args[0]
                    assert isinstance(joint, ast.Name)
                    if (joint.id, JOINT_ACTIONS[a.name]) not in targets:
                        targets.append((joint.id, JOINT_ACTIONS[a.name]))
    # per-tick variables and per-robot constants, only for behaviours that read them
    count = base + len(fields)
    per_robot = {name for own in c.robot_params.values() for name, _ in own}
    for name in (*STATE_CLOCK, "index", *sorted(per_robot)):
        if name in c.used and name not in slot_of:
            slot_of[name] = count
            count += 1
    return Layout(MappingProxyType(slot_of), count, tuple(labels), tuple(fields), tuple(targets))


class _NotConstant(Exception):
    pass


class _Generator:
    """Checked AST to the Python source of ``signals()`` and ``decide()``.

    Every expression is emitted fully parenthesised from a fixed set of forms: ``vN`` (slot N,
    read into a local once per function) for a sensor, signal or built-in variable, a literal
    made by ``repr`` of a number, an operator from the grammar's fixed set, ``_name(...)`` for
    a built-in function (the namespace maps it), and ``_gN(...)`` for an operation that can
    fault, bound to its site. Parameters and other constants are folded, so
    ``time >= minutes * 60`` becomes ``(v0 >= 1500.0)``.
    """

    def __init__(self, checked: Checked, slots: Layout):
        self.c = checked
        self.layout = slots
        self.slot_of = slots.slot_of
        self.state_names = tuple(checked.states)
        self.sites: list[tuple[str, FaultSite]] = []
        self.used: set[int] = set()  # slots the function being generated reads
        self.functions: set[str] = set()  # built-ins called directly
        self.notes: list[str] = []  # what each marker comment stands for in the listing
        self.logs: list[tuple[int, tuple[LabelPart, ...]]] = []  # each log(): its line, text and (value, format)
        self.metric_lines: list[str] = []  # the metrics' folding, in decide()
        self.fold_lines: list[str] = []  # and on the stopping tick, in fold(): all but durations
        self.metric_used: set[int] = set()  # the slots it reads
        self.stop_parts: tuple[str, ...] = ()  # the stop condition's top-level 'or' parts, as written

    def module(self) -> tuple[str, str]:
        """The source of ``make(...)``, which returns ``signals``, ``decide`` and ``both``, and its listing.

        ``signals(time, tick, values)`` evaluates the signals and returns the stop condition;
        ``decide()`` picks and runs the rule and folds the metrics; ``both`` is the two in one
        function for a run with a single robot, returning -2 when the run stops. Each reads
        the values it uses into locals (v<slot>) once: the same rule reads the same sensor
        several times, and a local costs a third of a slot read.
        """
        c = self.c
        n = len(c.channels)
        channel_slots = set(range(FIRST_CHANNEL, FIRST_CHANNEL + n))
        let_slots = {self.slot_of[name] for name, _ in c.lets}
        unpack = [", ".join(f"v{i}" for i in sorted(channel_slots)) + ", = values"] if n else []
        self.used = set()
        lets: list[str] = self.state_clock()
        clock_slots = {self.slot_of[name] for name in STATE_CLOCK if name in self.slot_of}
        let_slots |= clock_slots
        for name, parsed in c.lets:
            slot = self.slot_of[name]
            lets += [self.note(parsed.text, f"{name}: "),
                     f"s[{slot}] = v{slot} = " + self.expr(parsed.node, parsed.text, "signal " + repr(name))]
        for slot, slider, parsed in self.layout.label_fields:
            lets += [self.note(parsed.text, f"label of {slider}: "),
                     f"s[{slot}] = {self.expr(parsed.node, parsed.text, 'a label')}"]
        assert c.file.stop is not None
        stop_note = self.note(c.file.stop.text, "stop: ")
        stop = self.stop_condition()
        signal_loads = self.loads(self.used - channel_slots - let_slots - {TIME, TICK})
        self.used = set()
        rules = self.decide()
        decide_used = self.used
        out = (["def signals(v0, v1, values):", "    s[0] = v0", "    s[1] = v1"]
               + ([f"    s[{FIRST_CHANNEL}:{FIRST_CHANNEL + n}] = values"] if n else [])
               + ["    " + line for line in unpack] + signal_loads
               + ["    " + line for line in lets] + ["    " + stop_note, f"    return {stop}", ""])
        out += ["def decide():"] + self.loads(decide_used) + ["    " + line for line in rules] + [""]
        out += (["def fold(v0, v1, values):"] + ["    " + line for line in unpack]
                + self.loads(self.metric_used - channel_slots - {TIME, TICK})
                + ["    " + line for line in self.fold_lines] + ["    return None", ""])
        out += (["def both(v0, v1, values):"] + ["    " + line for line in unpack] + signal_loads
                + ["    " + line for line in lets] + ["    " + stop_note, f"    if {stop}:", "        return -2"]
                + self.loads(decide_used - channel_slots - let_slots - {TIME, TICK} - self.loaded(signal_loads))
                + ["    " + line for line in rules])
        params = ["s", "cmd", "jc", "events", "m", "_inf", "_nan", "_randint", "_random", "_uniform", "_gauss",
                  "_radius", "_half_axle", "_st", "_held"]
        params += ["_" + f for f in sorted(self.functions)]
        params += [f"_g{i}" for i in range(len(self.sites))]
        text = "\n".join("    " + line if line else "" for line in out)
        header = [self.mark(note) for note in self.header()]
        source = ("\n".join(header) + f"\ndef make({', '.join(params)}):\n{text}\n"
                  "    return signals, decide, both, fold\n")
        return source, _MARKER.sub(lambda m: m.group(1) + "# " + self.notes[int(m.group(2))], source)

    def state_clock(self) -> list[str]:
        """``state_time`` and ``entered``, when read: _st holds the state and the tick it was entered on."""
        if not any(name in self.slot_of for name in STATE_CLOCK):
            return []
        out = [f"if s[{STATE}] != _st[0]:", f"    _st[0] = s[{STATE}]", f"    _st[1] = v{TICK}"]
        if "state_time" in self.slot_of:
            k = self.slot_of["state_time"]
            out.append(f"s[{k}] = v{k} = (v{TICK} - _st[1]) * {self.c.file.dt_s!r}")
        if "entered" in self.slot_of:
            k = self.slot_of["entered"]
            out.append(f"s[{k}] = v{k} = v{TICK} == _st[1]")
        return out

    @staticmethod
    def loaded(loads: list[str]) -> set[int]:
        return {int(line.split("=")[0].strip()[1:]) for line in loads}

    @staticmethod
    def loads(slots: set[int]) -> list[str]:
        return [f"    v{i} = s[{i}]" for i in sorted(slots)]

    def decide(self) -> list[str]:
        c = self.c
        out = []
        # bindings first: a rule's set_velocity/set_position can override one for a tick
        for b in c.binds:
            k = self.layout.targets.index((b.joint, b.mode))
            out.append(self.note(b.expr.text, f"{b.joint}.{b.mode}: "))
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
                out.append(indent + self.note(r.text, f"{where}: "))
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
        used, self.used = self.used, set()
        for i, metric in enumerate(c.metrics):
            e = self.expr(metric.expr, metric.text, f"metric {metric.name!r}")
            lines = [self.note(metric.text, f"{metric.name}: ")]
            lines += METRIC_CODE[metric.aggregate].format(e=e, i=i).splitlines()
            self.metric_lines += lines
            if metric.aggregate is not Aggregate.DURATION:  # the stopping tick lasts no time
                self.fold_lines += lines
        self.metric_used = set(self.used)
        self.used |= used
        out += self.metric_lines
        out.append("return rule")
        return out

    def stop_condition(self) -> str:
        """The stop condition, each of its top-level ``or`` parts reporting itself when it holds.

        ``_held(k)`` records part k and returns True; it runs only on the tick the run stops.
        """
        stop = self.c.file.stop
        assert stop is not None
        parts = _or_parts(stop.node)
        if len(parts) == 1:  # the summary names the whole condition
            return self.expr(stop.node, stop.text, "the stop condition")
        self.stop_parts = tuple(" ".join(stop.text.value[p.span[0]:p.span[1]].split()) for p in parts)
        return " or ".join(f"({self.expr(p, stop.text, 'the stop condition')} and _held({k}))"
                           for k, p in enumerate(parts))

    def actions(self, actions: tuple, text: Text, where: str) -> list[str]:
        lines = []
        for action in actions:
            if isinstance(action, ast.Goto):
                lines.append(f"cmd[2] = {self.state_names.index(action.state)}")
            elif action.name == "log":
                # the runtime formats, prints and traces it (events: ints are metrics, tuples logs)
                assert action.text is not None
                parts: list[LabelPart] = []
                values: list[str] = []
                for part in action.text:
                    if isinstance(part, tuple):
                        parts.append((len(values), part[1]))
                        values.append(self.expr(part[0], text, where))
                    else:
                        parts.append(part)
                self.logs.append((text.doc.position(text.index(action.span[0]))[0], tuple(parts)))
                lines.append(f"events.append(({len(self.logs) - 1}, ({''.join(v + ', ' for v in values)})))")
            elif action.name in JOINT_ACTIONS:
                joint = action.args[0]
                assert isinstance(joint, ast.Name)
                k = self.layout.targets.index((joint.id, JOINT_ACTIONS[action.name]))
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

    # -- the listing's comments --------------------------------------------------------------
    def mark(self, note: str) -> str:
        """A marker comment for the source; the listing shows ``note`` in its place."""
        self.notes.append(_one_line(note))
        return f"#@{len(self.notes) - 1}"

    def note(self, text: Text, label: str) -> str:
        """A marker for the file's line and text of a rule, signal or metric."""
        line = text.doc.position(text.index(0))[0]
        return self.mark(f"{text.doc.path}:{line}: {label}{_one_line(text.value)}")

    def header(self) -> list[str]:
        """The listing's opening comments: what this is, and which slot holds which name."""
        names = sorted(self.slot_of.items(), key=lambda item: item[1])
        slots = [f"v{slot} {name}" for name, slot in names]
        slots += [f"v{slot} label of {slider}" for slot, slider, _ in self.layout.label_fields]
        guards = [f"_g{i} {kind} in {site.where}" for i, (kind, site) in enumerate(self.sites)]
        out = [f"Python compiled from {self.c.file.path} by labsim: make() binds it to one robot,",
               "signals() and decide() (or both() for a single robot) run each tick.",
               *_wrap("Slots s[N], read into locals vN: ", slots, ", ")]
        if guards:
            out += _wrap("Checked operations: ", guards, "; ")
        return out

    # -- the stop condition's horizon -------------------------------------------------------
    def stop_horizon(self) -> float | None:
        """Sim time at which the stop condition surely holds, when it says so plainly.

        ``time >= minutes * 60`` or ``... or tick >= 30000`` give a horizon for the progress
        bar; any other condition gives None (the bar then shows elapsed sim time only).
        """
        stop = self.c.file.stop
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
                if isinstance(left, ast.Name) and left.id in ("time", "tick"):
                    try:
                        value = self.fold(right)
                    except _NotConstant:
                        continue
                    if isinstance(value, (int, float)) and not isinstance(value, bool):
                        seconds = float(value) * (self.c.file.dt_s if left.id == "tick" else 1.0)
                        best = seconds if best is None else min(best, seconds)
        return best

    # -- expressions -------------------------------------------------------------------------
    def expr(self, e: ast.Expr, text: Text, where: str) -> str:
        try:
            return _literal(self.fold(e))
        except _NotConstant:
            return self.emit(e, text, where)

    def fold(self, e: ast.Expr) -> object:
        """The value of a subtree that reads nothing at run time; _NotConstant otherwise."""
        if isinstance(e, (ast.Number, ast.Bool)):
            return e.value
        if isinstance(e, ast.Name):
            if e.id in self.c.params and e.id not in self.slot_of:  # a robot's own value has a slot
                return self.c.params[e.id]
            if e.id in CONSTANTS:
                return CONSTANTS[e.id]
            if e.id == "dt":
                return self.c.file.dt_s
            if e.id in self.state_names and e.id not in self.slot_of:
                return self.state_names.index(e.id)
            raise _NotConstant
        try:
            if isinstance(e, ast.Neg):
                operand: Any = self.fold(e.operand)
                return -operand
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
                return FUNCTIONS[e.func].resolve()(*(self.fold(a) for a in e.args))
        except (ArithmeticError, ValueError, TypeError):
            raise _NotConstant from None  # leave it to run time, where it warns at its site
        raise _NotConstant

    def emit(self, e: ast.Expr, text: Text, where: str) -> str:
        x = lambda sub: self.expr(sub, text, where)  # noqa: E731
        if isinstance(e, ast.Name):
            slot = self.slot_of[e.id]
            self.used.add(slot)
            # the runtime counts ticks in ints; the language's numbers are floats, so that
            # tick * tick * ... overflows to inf rather than to an int no float can hold
            return f"(v{slot} + 0.0)" if slot == TICK else f"v{slot}"
        if isinstance(e, ast.Neg):
            return f"(-{x(e.operand)})"
        if isinstance(e, ast.Not):
            return f"(not {x(e.operand)})"
        if isinstance(e, ast.Binary):
            a, b = x(e.left), x(e.right)
            if e.op in ("+", "-", "*") or (e.op in ("/", "%") and self.nonzero(e.right)):
                return f"({a} {e.op} {b})"
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
            index = FIELDS[self.c.node_types[id(e.value)]][e.attr][0]
            return f"{x(e.value)}[{index}]"
        if isinstance(e, ast.Call):
            return self.call(e, text, where)
        raise AssertionError(f"cannot compile {e!r}")

    def nonzero(self, e: ast.Expr) -> bool:
        """Whether an expression is a constant number other than zero (a divisor needing no guard)."""
        try:
            value = self.fold(e)
        except _NotConstant:
            return False
        return isinstance(value, (int, float)) and value != 0

    def call(self, e: ast.Call, text: Text, where: str) -> str:
        if e.func == DETECTED:
            assert isinstance(e.args[0], ast.Name)
            return f"({self.emit(e.args[0], text, where)} < _inf)"
        parts = [self.expr(a, text, where) for a in e.args]
        if e.func in ("min", "max") and len(parts) <= 3 and all(_PLAIN.match(p) for p in parts):
            return _extreme(e.func, parts)
        args = ", ".join(parts)
        if e.func == "randint":
            try:
                lo, hi = (self.fold(a) for a in e.args)
            except _NotConstant:
                pass
            else:
                if (isinstance(lo, (int, float)) and isinstance(hi, (int, float)) and abs(lo) <= WHOLE_LIMIT
                        and abs(hi) <= WHOLE_LIMIT and float(lo).is_integer() and float(hi).is_integer() and lo <= hi):
                    return f"_randint({int(lo)}, {int(hi)})"
        if e.func in _TOTAL and not FUNCTIONS[e.func].uses_rng:
            self.functions.add(e.func)
            return f"_{e.func}({args})"
        if e.func in ("random", "uniform", "gauss"):
            return f"_{e.func}({args})"
        return f"{self.site(e.func, text, e.span, where)}({args})"


_MARKER = re.compile(r"^( *)#@(\d+)$", re.MULTILINE)
# A slot's local or a plain literal: safe to name more than once in an expression.
_PLAIN = re.compile(r"^(v\d+|\d+\.\d+(e[+-]?\d+)?|_inf)$")


def _extreme(func: str, parts: list[str]) -> str:
    """``min``/``max`` of two or three plain values as an expression, without a call.

    Exactly what ``labsim.dsl.builtins._min`` and ``_max`` compute, nan and the order of equal
    values included: nan if any value is nan, else the running extreme from the first value,
    replaced only by a strictly smaller (larger) one. The wall lab's rules take the minimum of
    sonar pairs 150,000 times in a run; the call was 5% of its tick.
    """
    op = "<" if func == "min" else ">"
    nan = " or ".join(f"{p} != {p}" for p in parts)
    a, b = parts[0], parts[1]
    m = f"({b} if {b} {op} {a} else {a})"
    if len(parts) == 3:
        c = parts[2]
        m = f"({c} if {c} {op} {m} else {m})"
    return f"(_nan if {nan} else {m})"


def _wrap(head: str, items: list[str], separator: str, width: int = 96) -> list[str]:
    """``head`` and the items, separated, in lines of at most ``width`` that break between items."""
    lines = [head.rstrip()]
    for k, item in enumerate(items):
        item += separator.rstrip() if k < len(items) - 1 else "."
        if len(lines[-1]) + 1 + len(item) > width:
            lines.append(item)
        else:
            lines[-1] += " " + item
    return lines


def _one_line(value: str) -> str:
    """A rule's text on one line, for a comment: whitespace runs and control characters as one space."""
    return " ".join("".join(ch if ch.isprintable() else " " for ch in value).split())


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


# folded values are numbers and booleans, which the checker has typed: Any, not object
_BINARY: dict[str, Callable[[Any, Any], Any]] = {
    "+": lambda a, b: a + b, "-": lambda a, b: a - b, "*": lambda a, b: a * b,
    "/": lambda a, b: a / b, "%": lambda a, b: a % b,
    "**": lambda a, b: _real(a ** b),
}
_COMPARE: dict[str, Callable[[Any, Any], bool]] = {
    "<": lambda a, b: a < b, "<=": lambda a, b: a <= b, ">": lambda a, b: a > b,
    ">=": lambda a, b: a >= b, "==": lambda a, b: a == b, "!=": lambda a, b: a != b,
}


def _real(value: object) -> object:
    if isinstance(value, complex):
        raise ValueError("complex result")
    return value


# How each aggregate folds its value in decide() (accumulators: support.initial_accumulator);
# `events` gets the metric's index.
def _or_parts(e: ast.Expr) -> list[ast.Expr]:
    """``a or (b or c)`` as [a, b, c]: the conditions a summary can name as the one that held."""
    if isinstance(e, ast.BoolOp) and e.op == "or":
        return [part for value in e.values for part in _or_parts(value)]
    return [e]


METRIC_CODE = {
    Aggregate.COUNT: "v = {e}\nif v and not m[{i}][1]:\n    m[{i}][0] += 1\n    events.append({i})\nm[{i}][1] = v",
    Aggregate.DURATION: "if {e}:\n    m[{i}][0] += 1",
    Aggregate.MEAN: "v = {e}\nif -_inf < v < _inf:\n    m[{i}][0] += v\n    m[{i}][1] += 1",
    Aggregate.MAXIMUM: "v = {e}\nif m[{i}][0] < v < _inf:\n    m[{i}][0] = v",
    Aggregate.MINIMUM: "v = {e}\nif -_inf < v < m[{i}][0]:\n    m[{i}][0] = v",
    Aggregate.RMS: "v = {e}\nif -_inf < v < _inf:\n    m[{i}][0] += v * v\n    m[{i}][1] += 1",
    Aggregate.FINAL: "m[{i}][0] = {e}",
}

# Functions that return a value for every argument (inf and nan included): called directly.
# The others may raise (sqrt(-1), log(-1), floor(inf), exp(1000), randint(3, 2), crop outside
# the image) and go through a guard that turns the exception into a defined result and a
# warning; centroid and pid have guards of their own.
_TOTAL = frozenset({"abs", "min", "max", "clamp", "hypot", "atan2",
                    "sign", "deg", "rad", "random", "uniform", "gauss",
                    "gray", "threshold", "invert", "area", "width", "height"})
_FOLDABLE = frozenset(f for f in _TOTAL if callable(FUNCTIONS[f].impl) and not FUNCTIONS[f].uses_rng)
