"""Checked behaviour to Python source: the code generator, after the checker.

``generate`` lays out a robot's slots (``labsim.dsl.emit.layout``) and writes one factory,
``make(...)``, which returns ``signals``, ``decide``, ``both`` and ``fold`` for one robot; it
compiles that source once, and ``labsim.dsl.emit.program`` runs the code object for each robot. A
run evaluates the rules tens of thousands of times, and one generated function per tick phase
costs almost nothing over a hand-written loop (a tree of closures cost 1.45x; see
docs/decisions.md, section 3).

No user text reaches ``compile``: names become slot indices, numbers ``repr`` literals,
operators come from the grammar's fixed set; constants are folded (``labsim.dsl.analysis.fold``). The
code is written through ``labsim.foundation.code_writer``, which keeps the indentation, the slots each
piece reads and each line's source mark. Where a rule, signal or metric begins, the source has
a marker comment (``#@7``); the ``listing`` is the same text with each marker replaced by the
file's line and text (``# behaviours/wall_follow.yaml:23: if ahead <= front then ...``), so it
lines up with the compiled code line for line: ``labsim check --show-code`` prints it, and
tracebacks through generated functions show it.

Over 500 lines: one generator writes the whole module top to bottom, and its parts share the
slots each piece reads; what version 1.2 added (groups, user functions) is apart, in
``labsim.dsl.emit.unroll``.
"""
from __future__ import annotations

import math
import re
from collections.abc import Mapping
from contextlib import nullcontext
from dataclasses import dataclass
from typing import Any

from labsim.dsl.analysis.check import Checked
from labsim.dsl.analysis.fold import TOTAL, NotConstant, fold
from labsim.dsl.analysis.image_memory import lifetimes
from labsim.dsl.analysis.messages import HEARD, SAY, heard_slot
from labsim.dsl.analysis.stop import stop_horizon
from labsim.dsl.emit.layout import Layout, layout
from labsim.dsl.emit.program import NAMED_SITES, Code, LabelPart
from labsim.dsl.emit.unroll import (
    LOCAL,
    ON_SEQUENCE,
    PLAIN,
    VALUES,
    MemberWriter,
    Unroller,
    extreme,
    reduce,
    reduce_sequence,
)
from labsim.dsl.library.builtins import (
    CONSTANTS,
    DETECTED,
    FIELDS,
    FUNCTIONS,
    JOINT_ACTIONS,
    STATE_CLOCK,
    WHEELS,
    Aggregate,
    Type,
)
from labsim.dsl.library.support import FIRST_CHANNEL, STATE, TICK, TIME, FaultSite, site_kind
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.read import Parsed, RuleDecl
from labsim.foundation.code_writer import Body, Note, Notes, Writer, one_line, render, wrap
from labsim.foundation.numbers import WHOLE_LIMIT
from labsim.foundation.source import Text

INF = math.inf
# A signal that is the minimum or maximum of a run of the channel values, as generated
EXTREME_OF = re.compile(r"^_(min|max)_of\((values(?:\[\d+:\d+\])?)\)$")
CHAIN = 64  # the longest if/elif chain generated: Python's compiler recurses once per elif


@dataclass(frozen=True)
class Generated:
    layout: Layout
    code: Code
    stop_horizon_s: float | None
    logs: tuple[tuple[int, tuple[LabelPart, ...]], ...] = ()  # each log(): its line, and its text's parts
    stop_parts: tuple[str, ...] = ()  # the stop condition's top-level 'or' parts, as written
    texts: tuple[str, ...] = ()  # Program.texts: the state names, then the text values, as _texts[k] reads them
    when_rules: tuple[int, ...] = ()  # Program.when_rules


def generate(checked: Checked, filename: str) -> Generated:
    """The behaviour's Python, compiled under ``filename``, with the layout it assumes."""
    slots = layout(checked)
    g = _Generator(checked, slots)
    source, listing, marks = render(g.module())
    code = Code(source, listing, filename, compile(source, filename, "exec"), tuple(g.sites),
                tuple(sorted(g.functions)), marks, bool(g.image_drops or g.image_kept), tuple(g.columns.values()))
    return Generated(slots, code, stop_horizon(checked, g.constants), tuple(g.logs), g.stop_parts, tuple(g.texts),
                     tuple(g.when_rules))


class _Generator(Unroller):
    """Checked AST to the Python source of ``signals()``, ``decide()``, ``fold()`` and ``both()``.

    Every expression is emitted fully parenthesised from a fixed set of forms: ``vN`` (slot N,
    read into a local once per function) for a sensor, signal or built-in variable, a literal
    made by ``repr`` of a number, an operator from the grammar's fixed set, ``_name(...)`` for
    a built-in function (the namespace maps it), and ``_gN(...)`` for an operation that can
    fault, bound to its site. Parameters and other constants are folded, so
    ``time >= minutes * 60`` becomes ``(v0 >= 1500.0)``. An expression records the slots it
    reads in the writer it is written to.
    """

    def __init__(self, checked: Checked, slots: Layout):
        self.c = checked
        self.layout = slots
        self.slot_of = slots.slot_of
        self.state_names = tuple(checked.states)
        self.constants = _constants(checked, slots.slot_of)
        self.emitter = _Emit(self)
        self.member_writer = MemberWriter(self)
        self.sites: list[tuple[str, FaultSite]] = []
        # (list, column or None for a list of numbers) read while running -> its values, bound as _L<n> in this order
        self.columns: dict[tuple[str, int | None], tuple[float, ...]] = {}
        self.functions: set[str] = set()  # built-ins called directly
        # ("min" | "max", a sequence's Python) -> the slot of a signal that is that reduction
        self.extremes: dict[tuple[str, str], int] = {}
        self.notes = Notes()  # the marker comments, in the order they are made
        self.logs: list[tuple[int, tuple[LabelPart, ...]]] = []  # each log(): its line, text and (value, format)
        self.stop_parts: tuple[str, ...] = ()  # the stop condition's top-level 'or' parts, as written
        self.env: list[dict[str, str | list[str]]] = []  # inside a user function's body: its arguments' code
        self.texts: list[str] = list(self.state_names)  # _texts: state names (by index), then text values
        self.let_of = {name: parsed for name, parsed in checked.lets}
        self.peer_robots: dict[str, tuple[int, int]] = {}  # robot group -> its first robot's index, its count
        for decl in checked.file.robots:
            self.peer_robots[decl.name] = (sum(n for _, n in self.peer_robots.values()), decl.count)
        self.when_rules: list[int] = []  # the index of each 'when' rule: _wf[j] counts the ticks it logged
        life = lifetimes(checked)
        self.image_drops = life.drops  # signal index -> image signals freed after it
        self.image_kept = [slots.slot_of[name] for name in life.images if name in life.kept]

    def module(self) -> Body:
        """``make(...)``, which returns ``signals``, ``decide``, ``both`` and ``fold``.

        ``signals(time, tick, values)`` evaluates the signals and returns the stop condition;
        ``decide()`` picks and runs the rule and folds the metrics; ``both`` is the two in one
        function for a run with a single robot, returning -2 when the run stops; ``fold``
        folds the metrics on the stopping tick. Each reads the values it uses into locals
        (v<slot>) once: the same rule reads the same sensor several times, and a local costs a
        third of a slot read. Each piece is generated once, and guards and marker comments are
        numbered in the order they are made: signals, stop condition, rules, metrics.

        Over 60 lines: it writes the generated module top to bottom, four functions that share
        their loads, and reads as the module it makes; split, the order of the output is lost.
        """
        c = self.c
        n = len(c.channels)
        # the channels' slots, and VALUES (all of them as one sequence): signals(), fold() and
        # both() have them as their argument ``values``, decide() reads them from the slots
        channels = frozenset(range(FIRST_CHANNEL, FIRST_CHANNEL + n)) | {VALUES}
        computed = {self.slot_of[name] for name, _ in c.lets}
        computed |= {self.slot_of[name] for name in (*STATE_CLOCK, *WHEELS) if name in self.slot_of}
        computed |= {self.slot_of[r.name] for r in c.received}
        computed |= {self.slot_of[heard_slot(h)] for h in c.heard}
        signals, stop_note, stop = self.signals()
        rules, metrics = self.decide()
        metric_reads = frozenset().union(*(m.reads for m in metrics))
        decide_reads = rules.reads | metric_reads
        signal_loads = signals.reads - channels - computed - {TIME, TICK}
        w = Writer()
        for text in self.header():
            w.comment(self.notes.add(one_line(text)))
        w.line(f"def make({', '.join(self.params())}):")
        with w.indent():
            w.line("def signals(v0, v1, values):")
            with w.indent():
                w.line("s[0] = v0")
                w.line("s[1] = v1")
                if n:
                    w.line(f"s[{FIRST_CHANNEL}:{FIRST_CHANNEL + n}] = values")
                _unpack(w, signals.reads & channels, n)
                _loads(w, signal_loads)
                w.insert(signals)
                with w.source(stop_note):
                    w.line(f"return {stop}")
            w.line()
            w.line("def decide():")
            with w.indent():
                _loads(w, decide_reads, n)
                w.insert(rules)
                for metric in metrics:
                    w.insert(metric)
                w.line("return rule")
            w.line()
            w.line("def fold(v0, v1, values):")
            with w.indent():
                _unpack(w, metric_reads & channels, n)
                _loads(w, metric_reads - channels - {TIME, TICK})
                for metric, m in zip(metrics, c.metrics):
                    if m.aggregate is not Aggregate.DURATION:  # the stopping tick lasts no time
                        w.insert(metric)
                w.line("return None")
            w.line()
            w.line("def both(v0, v1, values):")
            with w.indent():
                _unpack(w, (signals.reads | decide_reads) & channels, n)
                _loads(w, signal_loads)
                w.insert(signals)
                with w.source(stop_note):
                    w.line(f"if {stop}:")
                    with w.indent():
                        w.line("return -2")
                _loads(w, decide_reads - channels - computed - {TIME, TICK} - signal_loads)
                w.insert(rules)
                for metric in metrics:
                    w.insert(metric)
                w.line("return rule")
            w.line("return signals, decide, both, fold")
        return w.body()

    def params(self) -> list[str]:
        """What ``make`` takes: the robot's slots and outputs, the namespace, the guards."""
        return ["s", "cmd", "jc", "events", "m", "_inf", "_nan", "_randint", "_random", "_uniform", "_gauss",
                "_radius", "_half_axle", "_limit", "_st", "_held", "_texts", "_argmin", "_argmax", "_wf",
                *(["_P"] if self.c.peer_fields else []), *(["_out", "_reach", "_in"] if self.c.said else []),
                *(["_drop"] if self.image_drops or self.image_kept else []),
                *("_" + f for f in sorted(self.functions)),
                *(f"_g{i}" for i in range(min(len(self.sites), NAMED_SITES))),
                *(["_G"] if len(self.sites) > NAMED_SITES else []), *(f"_L{i}" for i in range(len(self.columns)))]

    def signals(self) -> tuple[Body, Note, str]:
        """The state clock, the signals and the label fields; the stop condition's note and expression.

        The body's reads include the stop condition's: signals() and both() load them before it.
        """
        c = self.c
        w = Writer()
        if self.image_kept:  # the last tick's images go before this tick's are made
            w.line("if _drop:")
            with w.indent():
                w.line(" = ".join([*(f"s[{k}]" for k in self.image_kept), "None"]))
        self.state_clock(w)
        self.wheels(w)
        for r in c.received:  # what this robot reads of the others, as they were on the last tick
            first, _ = self.peer_robots[r.robot]
            k = self.slot_of[r.name]
            w.line(f"s[{k}] = v{k} = _P[{first + r.place}][{c.peer_fields.index(r.attr)}]")
        for h in c.heard:  # what it heard after the last tick, nan when nothing yet (labsim.runtime.radio)
            k = self.slot_of[heard_slot(h)]
            w.line(f"s[{k}] = v{k} = _in[{c.said.index(h)}]")
        for j, (name, parsed) in enumerate(c.lets):
            slot = self.slot_of[name]
            if name in c.group_sizes:
                self.group_signal(w, name, parsed)
                self.drop_images(w, j)
                continue
            with w.source(self.note(parsed.text, f"{name}: ")):
                code = self.expr(w, parsed.node, parsed.text, "signal " + repr(name))
                w.line(f"s[{slot}] = v{slot} = " + code)
                self.drop_images(w, j)
            extreme_of = EXTREME_OF.match(code)
            if extreme_of:  # argmin of the same values, later, is where this is (unroll.reduce_sequence)
                self.extremes.setdefault((extreme_of[1], extreme_of[2]), slot)
        for shared in self.layout.shared_labels:  # the slider whose value changed last shows its text
            for k, (slot, last) in enumerate(shared.sliders):
                w.line(f"if s[{slot}] != s[{last}]: s[{shared.choice}] = {k}; s[{last}] = s[{slot}]")
        for slot, slider, parsed in self.layout.label_fields:
            with w.source(self.note(parsed.text, f"label of {slider}: ")):
                w.line(f"s[{slot}] = {self.expr(w, parsed.node, parsed.text, 'a label')}")
        assert c.file.stop is not None
        note = self.note(c.file.stop.text, "stop: ")
        stop = self.stop_condition(w)
        return w.body(), note, stop

    def drop_images(self, w: Writer, j: int) -> None:
        """Free the image signals signal j read for the last time (``labsim.dsl.analysis.image_memory``):
        a chain of image signals then holds one or two images, not all. ``_drop`` is false for a
        live view, which shows every image signal after the tick."""
        dropped = [self.slot_of[name] for name in self.image_drops.get(j, ())]
        if dropped:
            w.line("if _drop:")
            with w.indent():
                w.line(" = ".join([*(f"s[{k}] = v{k}" for k in dropped), "None"]))

    def group_signal(self, w: Writer, name: str, parsed: Parsed) -> None:
        """A group signal's members into their slots; a group of names alone has none (its uses read them)."""
        slots = self.layout.members[name]
        if slots is None:
            return
        with w.source(self.note(parsed.text, f"{name}: ")):
            codes = self.members(w, parsed.node, parsed.text, "signal " + repr(name))
            if any(id(n) in self.c.self_prev for n in ast.walk(parsed.node)):
                # it reads its own members' last values (any of them, as in min(prev(g, ...))): all are
                # computed before one is stored
                w.line(f"{''.join(f's[{k}], ' for k in slots)}= {''.join(f'v{k}, ' for k in slots)}= "
                       f"{', '.join(codes)},")
                return
            for k, code in zip(slots, codes):
                w.line(f"s[{k}] = v{k} = {code}")

    def state_clock(self, w: Writer) -> None:
        """``state_time`` and ``entered``, when read: _st holds the state and the tick it was entered on."""
        if not any(name in self.slot_of for name in STATE_CLOCK):
            return
        w.line(f"if s[{STATE}] != _st[0]:")
        with w.indent():
            w.line(f"_st[0] = s[{STATE}]")
            w.line(f"_st[1] = v{TICK}")
        if "state_time" in self.slot_of:
            k = self.slot_of["state_time"]
            w.line(f"s[{k}] = v{k} = (v{TICK} - _st[1]) * {self.c.file.dt_s!r}")
        if "entered" in self.slot_of:
            k = self.slot_of["entered"]
            w.line(f"s[{k}] = v{k} = v{TICK} == _st[1]")

    def wheels(self, w: Writer) -> None:
        """``wheel_left`` and ``wheel_right``, when read (format 1.3): last tick's commands as the wheels
        were sent them (labsim.runtime.run.send): clamped to the model's limit, nan as 0; 0 on the first tick."""
        for k, name in enumerate(WHEELS):
            if name in self.slot_of:
                slot = self.slot_of[name]
                w.line(f"_c = cmd[{k}]")
                w.line(f"s[{slot}] = v{slot} = _c if -_limit <= _c <= _limit else "
                       "(_limit if _c > 0 else -_limit) if _c == _c else 0.0")

    def decide(self) -> tuple[Body, list[Body]]:
        """The bindings and the rules, which set ``rule``; each metric's folding of the tick."""
        c = self.c
        w = Writer()
        # bindings first: a rule's set_velocity/set_position can override one for a tick
        for b in c.binds:
            k = self.layout.targets.index((b.joint, b.mode))
            with w.source(self.note(b.expr.text, f"{b.joint}.{b.mode}: ")):
                w.line(f"jc[{k}] = {self.expr(w, b.expr.node, b.expr.text, 'the binding of ' + b.joint)}")
        states = list(c.states.values())
        if not states:
            w.line("rule = -1")
        elif len(states) == 1:
            self.state_rules(w, states[0], 0)
        else:
            w.read(STATE)
            firsts = [0]
            for rules in states:
                firsts.append(firsts[-1] + len(rules))
            self.dispatch(w, states, firsts, 0, len(states))
        metrics = []
        for i, metric in enumerate(c.metrics):
            m = Writer()
            with m.source(self.note(metric.text, f"{metric.name}: ")):
                _fold_metric(m, metric.aggregate, self.expr(m, metric.expr, metric.text, f"metric {metric.name!r}"), i)
            metrics.append(m.body())
        return w.body(), metrics

    def dispatch(self, w: Writer, states: list[list[RuleDecl]], firsts: list[int], lo: int, hi: int) -> None:
        """States ``lo`` to ``hi - 1`` by the state's index: an if/elif chain of at most ``CHAIN``.

        Python's compiler recurses once per ``elif``, and a few thousand overflow its stack; more
        states than ``CHAIN`` are split into ranges (``if vS < 64: ... elif vS < 128: ...``), a
        tree whose depth grows with the logarithm of the count. A file of up to ``CHAIN`` states
        gets the plain chain it always had, and its speed."""
        if hi - lo <= CHAIN:
            for k in range(lo, hi):
                w.line(f"{'if' if k == lo else 'elif'} v{STATE} == {k}:")
                with w.indent():
                    self.state_rules(w, states[k], firsts[k])
            w.line("else:")
            with w.indent():
                w.line("rule = -1")
            return
        step = CHAIN
        while (hi - lo + step - 1) // step > CHAIN:
            step *= CHAIN
        bounds = list(range(lo, hi, step))
        for n, start in enumerate(bounds):
            end = min(start + step, hi)
            if n == 0:
                w.line(f"if v{STATE} < {end}:")
            else:
                w.line(f"elif v{STATE} < {end}:" if n < len(bounds) - 1 else "else:")
            with w.indent():
                self.dispatch(w, states, firsts, start, end)

    def state_rules(self, w: Writer, rules: list[RuleDecl], index: int) -> int:
        """One state's rules, an if/elif chain that sets ``rule``; the index of the next state's first rule.

        A state with ``when`` rules is a sequence of ifs instead: each rule is tried while no rule
        has fired (``rule == -1``), and a ``when`` rule logs without firing. So is a state of more
        than ``CHAIN`` rules, in chains of ``CHAIN`` (see ``dispatch``)."""
        if any(r.rule.kind == "when" for r in rules):
            return self.rules_with_when(w, rules, index)
        if len(rules) > CHAIN:
            w.line("rule = -1")
            for start in range(0, len(rules), CHAIN):
                if start:
                    w.line("if rule == -1:")
                with w.indent() if start else nullcontext():
                    self.rule_chain(w, rules[start:start + CHAIN], index + start)
            return index + len(rules)
        self.rule_chain(w, rules, index)
        return index + len(rules)

    def rule_chain(self, w: Writer, rules: list[RuleDecl], index: int) -> None:
        """Rules as an if/elif chain that sets ``rule`` (to -1 when none fires)."""
        for n, r in enumerate(rules):
            where = f"rule {r.state}:{r.number}"
            with w.source(self.note(r.text, f"{where}: ")):
                if r.rule.condition is None:
                    w.line("else:" if n else "if True:")
                else:
                    w.line(f"{'elif' if n else 'if'} {self.expr(w, r.rule.condition, r.text, where)}:")
                with w.indent():
                    self.actions(w, r.rule.actions, r.text, where)
                    w.line(f"rule = {index + n}")
            if r.rule.condition is None:
                return  # the checker refused rules after it
        w.line("else:")
        with w.indent():
            w.line("rule = -1")

    def rules_with_when(self, w: Writer, rules: list[RuleDecl], index: int) -> int:
        w.line("rule = -1")
        for n, r in enumerate(rules):
            where = f"rule {r.state}:{r.number}"
            with w.source(self.note(r.text, f"{where}: ")):
                if r.rule.condition is None:
                    w.line("if rule == -1:")
                else:
                    w.line(f"if rule == -1 and {self.expr(w, r.rule.condition, r.text, where)}:")
                with w.indent():
                    self.actions(w, r.rule.actions, r.text, where)
                    if r.rule.kind != "when":
                        w.line(f"rule = {index + n}")
                    else:
                        w.line(f"_wf[{len(self.when_rules)}] += 1")
                        self.when_rules.append(index + n)
        return index + len(rules)

    def stop_condition(self, w: Writer) -> str:
        """The stop condition, each of its top-level ``or`` parts reporting itself when it holds.

        ``_held(k)`` records part k and returns True; it runs only on the tick the run stops.
        """
        stop = self.c.file.stop
        assert stop is not None
        parts = _or_parts(stop.node)
        if len(parts) == 1:  # the summary names the whole condition
            return self.expr(w, stop.node, stop.text, "the stop condition")
        self.stop_parts = tuple(" ".join(stop.text.value[p.span[0]:p.span[1]].split()) for p in parts)
        return " or ".join(f"({self.expr(w, p, stop.text, 'the stop condition')} and _held({k}))"
                           for k, p in enumerate(parts))

    def actions(self, w: Writer, actions: tuple, text: Text, where: str) -> None:
        x = lambda arg: self.expr(w, arg, text, where)  # noqa: E731
        for action in actions:
            if isinstance(action, ast.Goto):
                w.line(f"cmd[2] = {self.state_names.index(action.state)}")
            elif action.name == "log":
                # the runtime formats, prints and traces it (events: ints are metrics, tuples logs)
                assert action.text is not None
                parts: list[LabelPart] = []
                values: list[str] = []
                for part in action.text:
                    if isinstance(part, tuple):
                        parts.append((len(values), part[1]))
                        value = x(part[0])
                        if self.c.node_types.get(id(part[0])) is Type.STATE:
                            # another robot's state at a place outside its group is nan (format 1.3)
                            peer = any(isinstance(n, ast.Peer) for n in ast.walk(part[0]))
                            value = f"(_texts[{value}] if {value} == {value} else _nan)" if peer else f"_texts[{value}]"
                        values.append(value)
                    else:
                        parts.append(part)
                self.logs.append((text.doc.position(text.index(action.span[0]))[0], tuple(parts)))
                w.line(f"events.append(({len(self.logs) - 1}, ({''.join(v + ', ' for v in values)})))")
            elif action.name == SAY:  # sent after the tick, to every robot in range (labsim.runtime.radio)
                channel = action.args[0]
                assert isinstance(channel, ast.Name)
                k = self.c.said.index(channel.id)
                w.line(f"_out[{k}] = {self.site(SAY, text, action.args[1].span, where)}({x(action.args[1])})")
                reach = action.args[2] if len(action.args) == 3 else None
                if reach is None:
                    w.line(f"_reach[{k}] = _inf")
                elif isinstance(reach, ast.Number):  # checked: more than 0
                    w.line(f"_reach[{k}] = {x(reach)}")
                else:  # known only while running: one not more than 0 is warned about where it is
                    w.line(f"_reach[{k}] = {self.site('say range', text, reach.span, where)}({x(reach)})")
            elif action.name in JOINT_ACTIONS:
                joint = action.args[0]
                assert isinstance(joint, ast.Name)
                k = self.layout.targets.index((joint.id, JOINT_ACTIONS[action.name]))
                w.line(f"jc[{k}] = {x(action.args[1])}")
            elif action.name == "stop":
                w.line("cmd[0] = cmd[1] = 0.0")
            elif action.name == "move":
                w.line(f"cmd[0] = cmd[1] = {x(action.args[0])}")
            elif action.name == "drive":
                # v m/s and w rad/s to wheel rad/s: (v -/+ w * axle / 2) / wheel radius
                w.line(f"_v = {x(action.args[0])}")
                w.line(f"_w = {x(action.args[1])}")
                w.line("cmd[0] = (_v - _w * _half_axle) / _radius")
                w.line("cmd[1] = (_v + _w * _half_axle) / _radius")
            else:
                assert action.name in ("arc", "wheels")
                w.line(f"cmd[0] = {x(action.args[0])}")
                w.line(f"cmd[1] = {x(action.args[1])}")

    def site(self, kind: str, text: Text, span: ast.Span, where: str) -> str:
        self.sites.append((kind, FaultSite(where, text.diagnostic(span[0], span[1], ""))))
        k = len(self.sites) - 1
        return f"_g{k}" if k < NAMED_SITES else f"_G[{k}]"

    def column(self, name: str, j: int | None) -> str:
        """The name make() binds column ``j`` of the list parameter ``name`` to (the list itself when it is of
        numbers, j None): made once however often it is read."""
        key = (name, j)
        if key not in self.columns:
            rows = self.c.lists[name]
            self.columns[key] = (tuple(rows) if j is None  # type: ignore[arg-type]
                                 else tuple(row[j] for row in rows))  # type: ignore[index]
        return f"_L{list(self.columns).index(key)}"

    # -- the listing's comments --------------------------------------------------------------
    def note(self, text: Text, label: str) -> Note:
        """The marker comment for a rule, signal or metric: the file's line and its text."""
        line = text.doc.position(text.index(0))[0]
        return self.notes.add(one_line(f"{text.doc.path}:{line}: {label}{one_line(text.value)}"), line)

    def header(self) -> list[str]:
        """The listing's opening comments: what this is, and which slot holds which name."""
        names = sorted(self.slot_of.items(), key=lambda item: item[1])
        slots = [f"v{slot} {name}" for name, slot in names]
        slots += [f"v{slot} label of {slider}" for slot, slider, _ in self.layout.label_fields]
        guards = [f"_g{i} {kind} in {site.where}" for i, (kind, site) in enumerate(self.sites)]
        out = [f"Python compiled from {self.c.file.path} by labsim: make() binds it to one robot,",
               "signals() and decide() (or both() for a single robot) run each tick.",
               *wrap("Slots s[N], read into locals vN: ", slots, ", ")]
        if guards:
            out += wrap("Checked operations: ", guards, "; ")
        return out

    # -- expressions -------------------------------------------------------------------------
    def expr(self, w: Writer, e: ast.Expr, text: Text, where: str) -> str:
        """Python for ``e``, written into ``w``: its slots are recorded there."""
        try:
            return _literal(fold(e, self.constants))
        except NotConstant:
            return self.emit(w, e, text, where)

    def emit(self, w: Writer, e: ast.Expr, text: Text, where: str) -> str:
        return self.emitter.visit(e, w, text, where)

    def nonzero(self, e: ast.Expr) -> bool:
        """Whether an expression is a constant number other than zero (a divisor needing no guard)."""
        try:
            value = fold(e, self.constants)
        except NotConstant:
            return False
        return isinstance(value, (int, float)) and value != 0

    def call(self, w: Writer, e: ast.Call, text: Text, where: str) -> str:
        if id(e) in self.c.lengths:  # len(...) is known before the run
            return _literal(float(self.c.lengths[id(e)]))
        if id(e) in self.c.expansions:
            body = self.inline(w, e, text, where)
            assert isinstance(body, str)
            return body
        if e.func == HEARD and e.args and isinstance(e.args[0], ast.Name) and e.args[0].id in self.c.heard:
            k = self.slot_of[heard_slot(e.args[0].id)]  # nan until something is heard
            w.read(k)
            default = self.expr(w, e.args[1], text, where) if len(e.args) == 2 else "0.0"
            return f"(v{k} if v{k} == v{k} else {default})"
        if id(e) in self.c.self_prev:  # prev(n, initial) in n's own definition: n's slot, last tick's
            slot = self.slot_of[e.args[0].id]  # type: ignore[attr-defined]  # the checker made it a Name
            # the slot still holds the last tick's value while this tick's is computed; the
            # run's first tick (v1, the tick, is 0) takes the initial value
            return f"(s[{slot}] if v{TICK} else {self.expr(w, e.args[1], text, where)})"
        if len(e.args) == 1 and self.c.node_types.get(id(e.args[0])) in (Type.NUMBERS, Type.BOOLS):
            sequence = self.sequence(w, e.args[0]) if e.func in ON_SEQUENCE else None
            if sequence is not None:  # a run of the channel values: one call on them (unroll.VALUES)
                code, function = reduce_sequence(e.func, *sequence, self.extremes)
                for slot in LOCAL.findall(code):  # argmin_at reads the minimum's signal
                    w.read(int(slot))
                self.functions.add(function)
                return code
            if e.func in ("min", "max"):
                self.functions.add(e.func)
            return reduce(e.func, self.members(w, e.args[0], text, where))
        if e.func == DETECTED:
            assert isinstance(e.args[0], ast.Name)
            return f"({self.emit(w, e.args[0], text, where)} < _inf)"
        return self.built_in(e, [self.expr(w, a, text, where) for a in e.args], text, where)

    def built_in(self, e: ast.Call, parts: list[str], text: Text, where: str) -> str:
        """A call of a built-in with its arguments' Python; called once per member when it applies member
        by member, and then each member's call with memory has its own site, so its own memory."""
        if e.func in ("min", "max") and len(parts) <= 3 and all(PLAIN.match(p) for p in parts):
            return extreme(e.func, parts)
        args = ", ".join(parts)
        if e.func == "randint":
            try:
                lo, hi = (fold(a, self.constants) for a in e.args)
            except NotConstant:
                pass
            else:
                if (isinstance(lo, (int, float)) and isinstance(hi, (int, float)) and abs(lo) <= WHOLE_LIMIT
                        and abs(hi) <= WHOLE_LIMIT and float(lo).is_integer() and float(hi).is_integer() and lo <= hi):
                    return f"_randint({int(lo)}, {int(hi)})"
        if e.func in TOTAL and not FUNCTIONS[e.func].uses_rng:
            self.functions.add(e.func)
            return f"_{e.func}({args})"
        if e.func in ("random", "uniform", "gauss"):
            return f"_{e.func}({args})"
        return f"{self.site(site_kind(e.func, self.c.file.version), text, e.span, where)}({args})"


def _constants(c: Checked, slot_of: Mapping[str, int]) -> dict[str, object]:
    """The names folded into literals: parameters every robot shares, constants, dt, states."""
    out: dict[str, object] = {}
    for name, value in c.params.items():
        if name not in slot_of:  # a robot's own value has a slot
            out[name] = value
    for name, number in CONSTANTS.items():
        out.setdefault(name, number)
    out.update(c.lists)  # list parameters (format 1.3): a place that folds picks a literal
    out.setdefault("dt", c.file.dt_s)
    for k, name in enumerate(c.states):
        if name not in slot_of:
            out.setdefault(name, k)
    return out


def _unpack(w: Writer, read: frozenset[int], n: int) -> None:
    """The channel values the code reads one by one into their locals: all n in one unpacking
    when it reads half of them or more, else each by its index (a lidar's scan reduced as one
    sequence needs no local per beam)."""
    read = read - {VALUES}
    if 2 * len(read) >= n:
        if read:
            w.line(", ".join(f"v{i}" for i in range(FIRST_CHANNEL, FIRST_CHANNEL + n)) + ", = values")
        return
    for i in sorted(read):
        w.line(f"v{i} = values[{i - FIRST_CHANNEL}]")


def _loads(w: Writer, slots: frozenset[int] | set[int], n: int = 0) -> None:
    """Slots into their locals, once per function; VALUES (all n channels) as ``values``."""
    for i in sorted(slots):
        w.line(f"values = s[{FIRST_CHANNEL}:{FIRST_CHANNEL + n}]" if i == VALUES else f"v{i} = s[{i}]")


def _fold_metric(w: Writer, aggregate: Aggregate, e: str, i: int) -> None:
    """How a metric folds its value ``e`` into its accumulator ``m[i]`` (support.initial_accumulator)."""
    m = f"m[{i}]"
    if aggregate is Aggregate.DURATION:
        w.line(f"if {e}:")
        with w.indent():
            w.line(f"{m}[0] += 1")
        return
    if aggregate is Aggregate.FINAL:
        w.line(f"{m}[0] = {e}")
        return
    w.line(f"v = {e}")
    if aggregate is Aggregate.COUNT:  # rising edges; `events` gets the metric's index
        w.line(f"if v and not {m}[1]:")
        with w.indent():
            w.line(f"{m}[0] += 1")
            w.line(f"events.append({i})")
        w.line(f"{m}[1] = v")
        return
    test, update = {
        Aggregate.MEAN: ("-_inf < v < _inf", (f"{m}[0] += v", f"{m}[1] += 1")),
        Aggregate.RMS: ("-_inf < v < _inf", (f"{m}[0] += v * v", f"{m}[1] += 1")),
        Aggregate.MAXIMUM: (f"{m}[0] < v < _inf", (f"{m}[0] = v",)),
        Aggregate.MINIMUM: (f"-_inf < v < {m}[0]", (f"{m}[0] = v",)),
    }[aggregate]
    w.line(f"if {test}:")
    with w.indent():
        for line in update:
            w.line(line)


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


def _or_parts(e: ast.Expr) -> list[ast.Expr]:
    """``a or (b or c)`` as [a, b, c]: the conditions a summary can name as the one that held."""
    if isinstance(e, ast.BoolOp) and e.op == "or":
        return [part for value in e.values for part in _or_parts(value)]
    return [e]


class _Emit(ast.Visitor[str]):
    """Python for one expression that is one value, written into ``w``; ``where`` names it for
    its fault sites. Numbers fold before they get here (``Generator.expr``), groups are written
    member by member (``Unroller.members``)."""

    def __init__(self, g: _Generator) -> None:
        self.g = g

    def visit_Name(self, e: ast.Name, w: Writer, text: Text, where: str) -> str:
        g = self.g
        if g.env and e.id in g.env[-1]:
            code = g.env[-1][e.id]
            assert isinstance(code, str)  # a group argument is read through members()
            return code
        slot = g.slot_of[e.id]
        w.read(slot)
        # the runtime counts ticks in ints; the language's numbers are floats, so that
        # tick * tick * ... overflows to inf rather than to an int no float can hold
        return f"(v{slot} + 0.0)" if slot == TICK else f"v{slot}"

    def visit_Neg(self, e: ast.Neg, w: Writer, text: Text, where: str) -> str:
        return f"(-{self.g.expr(w, e.operand, text, where)})"

    def visit_Not(self, e: ast.Not, w: Writer, text: Text, where: str) -> str:
        return f"(not {self.g.expr(w, e.operand, text, where)})"

    def visit_Binary(self, e: ast.Binary, w: Writer, text: Text, where: str) -> str:
        g = self.g
        a, b = g.expr(w, e.left, text, where), g.expr(w, e.right, text, where)
        if e.op in ("+", "-", "*") or (e.op in ("/", "%") and g.nonzero(e.right)):
            return f"({a} {e.op} {b})"
        return f"{g.site(e.op, text, e.span, where)}({a}, {b})"

    def visit_Compare(self, e: ast.Compare, w: Writer, text: Text, where: str) -> str:
        parts = [self.g.expr(w, e.operands[0], text, where)]
        for op, operand in zip(e.ops, e.operands[1:]):
            parts += [op, self.g.expr(w, operand, text, where)]
        return "(" + " ".join(parts) + ")"

    def visit_BoolOp(self, e: ast.BoolOp, w: Writer, text: Text, where: str) -> str:
        return "(" + f" {e.op} ".join(self.g.expr(w, v, text, where) for v in e.values) + ")"

    def visit_IfExp(self, e: ast.IfExp, w: Writer, text: Text, where: str) -> str:
        x = lambda sub: self.g.expr(w, sub, text, where)  # noqa: E731
        return f"({x(e.body)} if {x(e.test)} else {x(e.orelse)})"

    def visit_Attribute(self, e: ast.Attribute, w: Writer, text: Text, where: str) -> str:
        index = FIELDS[self.g.c.node_types[id(e.value)]][e.attr][0]
        return f"{self.g.expr(w, e.value, text, where)}[{index}]"

    def visit_Call(self, e: ast.Call, w: Writer, text: Text, where: str) -> str:
        return self.g.call(w, e, text, where)

    def visit_Text(self, e: ast.Text, w: Writer, text: Text, where: str) -> str:
        g = self.g
        if e.value not in g.texts[len(g.state_names):]:
            g.texts.append(e.value)
        return f"_texts[{len(g.state_names) + g.texts[len(g.state_names):].index(e.value)}]"

    def visit_Index(self, e: ast.Index, w: Writer, text: Text, where: str) -> str:
        return self.g.index(w, e, text, where)

    def visit_Peer(self, e: ast.Peer, w: Writer, text: Text, where: str) -> str:
        """Another robot's value on the last tick: ``_P[robot][field]``, the run's list of every robot's
        values kept after each tick (format 1.3); a place known only while running, through a guard."""
        g = self.g
        if id(e) in g.c.received_at:  # at a known place: read into a slot of its own when signals() starts
            slot = g.slot_of[g.c.received_at[id(e)]]
            w.read(slot)
            return f"v{slot}"
        first, count = g.peer_robots[e.robot]
        k = g.c.peer_fields.index(e.attr)
        members = ", ".join(f"_P[{first + j}][{k}]" for j in range(count))
        kind = "[]?" if g.c.node_types.get(id(e)) is Type.BOOL else "[]"
        return f"{g.site(kind, text, e.span, where)}(({members},), {g.expr(w, e.member, text, where)})"

    # numbers and booleans are folded before they get here; a group is written by members()
    generic = frozenset({ast.Number, ast.Bool, ast.Group, ast.Slice})

    def generic_visit(self, e: ast.Expr, *args: Any) -> str:
        raise AssertionError(f"cannot compile {e!r}")
