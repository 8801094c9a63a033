"""Warnings: the silent mistakes of a behaviour that checks, after the checker.

``labsim.dsl.compile`` runs ``lint`` on a ``Checked`` behaviour that has no errors. Each
finding is a ``warning`` diagnostic at its place in the file, with a caret; ``labsim check``
and ``labsim run`` print them and go on (``--strict`` makes them errors). What is warned
about (docs/language.md, "Warnings"): states no ``goto`` reaches and rules after one that
always holds; ``==``/``!=`` on time or a continuous reading; a start pose in a wall; a
stateful function (``pid``, ``prev``, ...) where it is not evaluated every tick; a binding or
command beyond a motor's limit; a threshold beyond a sonar's range; comparisons a value's
range decides and trig functions given degrees (``labsim.dsl.analysis.ranges``); and ``let`` signals,
parameters and sliders that nothing reads. Every check reads the checked file only: nothing here runs a behaviour.
"""
from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from typing import Any

from labsim.backends.scene.mechanism import JointSpec
from labsim.backends.scene.models import Kind
from labsim.dsl.analysis.check import Checked
from labsim.dsl.analysis.fold import NotConstant, fold
from labsim.dsl.analysis.ranges import Ranges
from labsim.dsl.library.builtins import CONSTANTS, STATEFUL
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.ast import LetMemo, walk
from labsim.foundation.diagnostics import Report
from labsim.foundation.source import Place, Text

# Names whose value changes continuously, for ==/!= (channels of these kinds join them).
CONTINUOUS_VARIABLES = frozenset({"time", "state_time"})
_CONTINUOUS_KINDS = (Kind.DISTANCE, Kind.NUMBER, Kind.JOINT, Kind.FORCE, Kind.BODY, Kind.REFLECTANCE)
# Functions whose result is a whole number or a sign, whatever their arguments.
# (heard: a channel carries what was said exactly, often a code: heard(mode) == 2 is meant)
_DISCRETE = frozenset({"floor", "ceil", "round", "sign", "randint", "heard"})
_FOLDABLE = frozenset({"abs", "min", "max", "clamp", "sqrt", "hypot", "sin", "cos", "tan", "exp",
                       "floor", "ceil", "round", "sign", "deg", "rad"})
# Wheel actions whose every argument is a wheel speed, rad/s (drive(v, w) is turned into them).
_WHEELS = ("arc", "wheels", "move")
_DISCRETE_CHANNELS = frozenset({"laps"})  # whole laps: == is meant


class _Unknown(Exception):
    """An expression whose value is not known before the run."""


def lint(c: Checked, report: Report) -> None:
    """Add the warnings of a checked behaviour to ``report``."""
    Linter(c, report).run()


class Linter:
    """One behaviour's warnings: each method below is one kind of silent mistake."""

    def __init__(self, c: Checked, report: Report) -> None:
        self.c = c
        self.report = report
        varying: set[str] = set()  # parameters a robot sets for itself: not one value
        for pairs in c.robot_params.values():
            varying.update(name for name, _ in pairs)
        self.constants: dict[str, Any] = {k: v for k, v in c.params.items() if k not in varying}
        self.constants.update(CONSTANTS)
        self.constants.update(c.lists)  # len(g), g[0] and waypoints[1][0] are known before the run (format 1.3)
        self.constants["dt"] = c.file.dt_s
        self.let_exprs = {name: p.node for name, p in c.lets}
        self.sliders = {sl.name: (sl.lo, sl.hi) for sl in c.sliders}
        self.ranges = Ranges(c, self.known, self.warn)
        # what a signal is, worked out once per signal (a signal read in both branches of an 'if',
        # or by itself through prev(), would otherwise be followed again at every read)
        self.continuity = _Continuous(self)
        self.sonars = _SonarRange(self)
        self.continuous_lets = LetMemo(self.let_exprs, self.continuous, "")
        self.sonar_lets: LetMemo[tuple[float, tuple[str, ...]] | None] = LetMemo(self.let_exprs, self.sonar_range,
                                                                                  None)

    def warn(self, place: Place, message: str, *notes: str) -> None:
        self.report.add(self.c.file.doc.diagnostic(place, message, "warning", tuple(notes)))

    def run(self) -> None:
        self.states()
        self.expressions()
        self.start_poses()
        self.motor_limits()
        self.unused()

    def every_expression(self) -> Iterator[tuple[ast.Expr, Text]]:
        """Each top-level expression of the file with the text it came from."""
        c = self.c
        if c.file.stop is not None:
            yield c.file.stop.node, c.file.stop.text
        for _, p in c.lets:
            yield p.node, p.text
        for rules in c.states.values():
            for decl in rules:
                if decl.rule.condition is not None:
                    yield decl.rule.condition, decl.text
                for action in decl.rule.actions:
                    if isinstance(action, ast.Action):
                        for arg in action.args:
                            yield arg, decl.text
        for m in c.metrics:
            yield m.expr, m.text
        for b in c.binds:
            yield b.expr.node, b.expr.text

    # -- values known before the run ---------------------------------------------------------
    def value(self, e: ast.Expr, env: dict[str, Any] | None = None) -> Any:
        """The value of an expression made of parameters, constants and ``env``; else _Unknown."""
        try:
            return fold(e, {**self.constants, **env} if env else self.constants, _FOLDABLE)
        except NotConstant:
            raise _Unknown from None

    def known(self, e: ast.Expr) -> Any:
        """The expression's value, or None when it is not known before the run."""
        try:
            return self.value(e)
        except _Unknown:
            return None

    def extremes(self, e: ast.Expr) -> list[tuple[float, dict[str, float]]]:
        """The values of e at every corner of the sliders it reads, with the slider settings;
        [] when e reads anything else that is not known before the run."""
        names = sorted({n.id for n in walk(e) if isinstance(n, ast.Name) and n.id in self.sliders})[:6]
        out = []
        for corner in itertools.product(*(self.sliders[n] for n in names)):
            env = dict(zip(names, corner))
            try:
                out.append((float(self.value(e, env)), env))
            except (_Unknown, TypeError, ValueError, ArithmeticError):
                return []
        return out


    # -- states and rules --------------------------------------------------------------------
    def states(self) -> None:
        """States no ``goto`` reaches from the first one; rules after one that always holds."""
        states = self.c.states
        if not states:
            return
        targets = {name: {a.state for d in rules for a in d.rule.actions if isinstance(a, ast.Goto)}
                   for name, rules in states.items()}
        start = next(iter(states))
        seen, todo = {start}, [start]
        while todo:
            for t in targets[todo.pop()] - seen:
                if t in targets:
                    seen.add(t)
                    todo.append(t)
        for name, (_, key) in self.c.file.states.items():
            if name not in seen and key is not None:
                self.warn(key, f"state '{name}' is never reached: no 'goto {name}' leads to it from "
                               f"'{start}', the state a run starts in", "a run starts in the first state of 'rules:'")
        for rules in states.values():
            for i, decl in enumerate(rules):
                condition = decl.rule.condition
                holds = self.known(condition) if condition is not None else None
                if holds is False and condition is not None:
                    self.warn(decl.text.at(condition.span), "this condition never holds: the rule never fires")
                if holds is not True or decl.rule.kind == "when":  # a 'when' rule logs, and the rules below go on
                    continue
                line = decl.text.node.start_mark.line + 1
                for later in rules[i + 1:]:
                    self.warn(later.text.at(later.rule.span), f"this rule can never fire: the condition of the "
                              f"rule on line {line} always holds, and that rule fires first")
                break

    # -- expressions -------------------------------------------------------------------------
    def expressions(self) -> None:
        for e, text in self.every_expression():
            for node in walk(e):
                if isinstance(node, ast.Compare):
                    self.compare(node, text)
                elif isinstance(node, ast.Call):
                    self.ranges.trig(node, text)
        self.stateful()

    def compare(self, node: ast.Compare, text: Text) -> None:
        for op, a, b in zip(node.ops, node.operands, node.operands[1:]):
            if op not in ("==", "!="):
                self.threshold(a, b, text)
                self.threshold(b, a, text)
                self.ranges.compare(op, a, b, text)
                continue
            what = self.continuous(a) or self.continuous(b)
            if not what:  # a continuous value has its own warning for == and !=
                self.ranges.compare(op, a, b, text)
            if not what or any(self.known(x) in (math.inf, -math.inf) for x in (a, b)):
                continue
            never = "never hold" if op == "==" else "always hold"
            step = f" (time moves in steps of dt = {self.c.file.dt_s:g} s)" if "time" in what else ""
            self.warn(text.at(node.span), f"'{op}' on {what}, which changes continuously{step}: it may never "
                      f"be exactly equal, and then this would {never}", "compare with '<=' or '>=' instead, "
                      "e.g. 'time >= 5' rather than 'time == 5'")

    def continuous(self, e: ast.Expr) -> str:
        """What makes e a continuous number ('time', a reading, a signal of them), or ''."""
        return self.continuity.visit(e)

    def threshold(self, reading: ast.Expr, limit: ast.Expr, text: Text) -> None:
        """A sonar compared with a distance it cannot see."""
        seen = self.sonar_range(reading)
        value = self.known(limit)
        if seen is None or isinstance(value, bool) or not isinstance(value, int | float):
            return
        range_m, sonars = seen
        if math.isfinite(value) and value > range_m:
            source = text.value[limit.span[0]:limit.span[1]]
            shown = f"{value:g} m" if isinstance(limit, ast.Number) else f"'{source}' ({value:g} m)"
            if isinstance(reading, ast.Name) and reading.id == sonars[0]:
                what = f"the range of {sonars[0]}: it sees"
            else:
                read = text.value[reading.span[0]:reading.span[1]]
                what = f"what '{read}' reads: {' and '.join(sonars)} {'see' if len(sonars) > 1 else 'sees'}"
            self.warn(text.at(limit.span), f"{shown} is beyond {what} at most {range_m:g} m (the model's range_m)",
                      "beyond its range a sonar reads inf (nothing detected); to ask whether it sees anything "
                      "at all, use detected(...)")

    def sonar_range(self, e: ast.Expr) -> tuple[float, tuple[str, ...]] | None:
        """(the farthest distance e can read, the sonar) when e is a sonar or the nearest of sonars."""
        return self.sonars.visit(e)

    def stateful(self) -> None:
        """pid(), prev() and the like where they are not evaluated every tick."""
        c = self.c
        single = len(c.states) == 1
        for rules in c.states.values():
            for decl in rules:
                rule = decl.rule
                # reached on every tick: the first rule of a single state, or one below 'when' rules only
                every_tick = single and all(r.rule.kind == "when" for r in rules[:decl.number - 1])
                if rule.condition is not None:
                    in_state = "" if single else f" in state '{decl.state}'"
                    where = None if every_tick else ("is in a rule's condition, evaluated only on the ticks no "
                                                     f"earlier rule fires{in_state}")
                    self.stateful_in(rule.condition, decl.text, where)
                fires_always = every_tick and rule.condition is None
                for action in rule.actions:
                    if isinstance(action, ast.Action):
                        fields = [part[0] for part in action.text or () if isinstance(part, tuple)]  # log("{...}")
                        for arg in [*action.args, *fields]:
                            self.stateful_in(arg, decl.text, None if fires_always else
                                             "is in a rule's action, evaluated only on the ticks the rule fires")
        for e, text in [(p.node, p.text) for _, p in c.lets] + [(m.expr, m.text) for m in c.metrics]:
            self.stateful_in(e, text, None)
        if c.file.stop is not None:  # 'a or b': b runs on every tick the run goes on, which is what counts
            stop = c.file.stop.node
            for e in stop.values if isinstance(stop, ast.BoolOp) and stop.op == "or" else (stop,):
                self.stateful_in(e, c.file.stop.text, None)

    def stateful_in(self, e: ast.Expr, text: Text, where: str | None) -> None:
        """Warn at each stateful call of e; ``where`` says why e runs only on some ticks (None: every tick)."""
        _Stateful(self).visit(e, text, where)

    # -- the world ---------------------------------------------------------------------------
    def start_poses(self) -> None:
        """Start poses given as [x, y, heading_deg] inside a wall or overlapping one. (A pose
        outside the world, and robots the world has no place for, are the checker's errors.)"""
        world = self.c.world
        if world is None or self.c.mechanism_agent:
            return
        for decl in self.c.file.robots:
            model = self.c.models.get(decl.name)
            if model is None:
                continue
            reach = max((math.hypot(x, y) for x, y in model.footprint), default=0.0)
            for (x, y, _), where in decl.fixed():
                clearance = world.clearance(x, y)
                if clearance >= reach:
                    continue
                what = ("is inside a wall" if clearance <= 0 else
                        f"overlaps a wall: the nearest is {clearance:.2f} m from its centre, and the robot "
                        f"reaches {reach:.2f} m")
                self.warn(where, f"the start pose ({x:g}, {y:g}) {what}",
                          "the robot starts in collision; move it into the open")

    # -- motors ------------------------------------------------------------------------------
    def motor_limits(self) -> None:
        """Joint bindings and commands, and wheel commands, beyond what the motor can do."""
        c = self.c
        mechanism = c.world.mechanism if c.world is not None else None
        if mechanism is not None:
            for b in c.binds:
                self.joint_target(mechanism.joint(b.joint), b.mode, b.expr.node, b.expr.text)
        wheel_max = min((m.max_wheel_speed_rad_s for m in c.models.values()), default=math.inf)
        for rules in c.states.values():
            for decl in rules:
                for action in decl.rule.actions:
                    if not isinstance(action, ast.Action):
                        continue
                    if action.name in ("set_velocity", "set_position") and mechanism is not None:
                        joint = action.args[0]
                        if isinstance(joint, ast.Name):
                            mode = action.name.removeprefix("set_")
                            self.joint_target(mechanism.joint(joint.id), mode, action.args[1], decl.text)
                    elif action.name in _WHEELS:
                        for arg in action.args:
                            self.wheel_speed(arg, decl.text, wheel_max)
                    elif action.name == "drive" and len(action.args) == 2:
                        self.drive(action, decl.text, wheel_max)
                    elif action.name == "say" and len(action.args) == 3:
                        self.reach(action.args[2], decl.text)

    def wheel_speed(self, e: ast.Expr, text: Text, wheel_max: float) -> None:
        values = self.extremes(e)
        if not values:
            return
        v, env = max(values, key=lambda p: abs(p[0]))
        if abs(v) > wheel_max:
            model = ", ".join(sorted({m.name for m in self.c.models.values()}))
            self.warn(text.at(e.span), f"{v:g} rad/s{_with(env)} is beyond the wheels' limit of {wheel_max:g} rad/s "
                      f"({model}'s max_wheel_speed): the wheels are held to it")

    def reach(self, e: ast.Expr, text: Text) -> None:
        """say()'s range, when it can go below 0 (a slider from -5): no one hears it then. A range
        known before the run is checked (labsim.dsl.analysis.messages); the run warns of the rest."""
        if self.known(e) is not None:
            return
        r = self.ranges.of(e)
        if -math.inf < r.lo < 0 or (r.hi <= 0 and not r.nan):
            because = f" ({'; '.join(r.facts)})" if r.facts else ""
            self.warn(text.at(e.span), f"say()'s range can be {r.lo:g}{because}: a message said with a range "
                      "that is not more than 0 metres is heard by no one")

    def drive(self, action: ast.Action, text: Text, wheel_max: float) -> None:
        """drive(v, w): the wheel speeds it asks for, (v -+ w * axle / 2) / radius."""
        v, w = (self.known(a) for a in action.args)
        if not all(isinstance(a, int | float) and not isinstance(a, bool) for a in (v, w)):
            return
        speeds = [abs(v - side * w * m.axle_length_m / 2) / m.wheel_radius_m
                  for m in self.c.models.values() for side in (1, -1)]
        fastest = max(speeds, default=0.0)
        if fastest > wheel_max:
            self.warn(text.at(action.span), f"drive({v:g}, {w:g}) asks a wheel for {fastest:.3g} rad/s, beyond the "
                      f"wheels' limit of {wheel_max:g} rad/s: the wheels are held to it")

    def joint_target(self, joint: JointSpec, mode: str, e: ast.Expr, text: Text) -> None:
        values = self.extremes(e)
        if not values or joint.motor is None:
            return
        unit = "rad" if joint.angular else "m"
        v, env = max(values, key=lambda p: abs(p[0]))
        if mode == "velocity" and abs(v) > joint.motor.max_speed:
            self.warn(text.at(e.span), f"{v:g} {unit}/s{_with(env)} is beyond the max_speed of {joint.name}'s motor, "
                      f"{joint.motor.max_speed:g} {unit}/s: the motor is held to it")
        if mode == "position" and joint.limits is not None:
            lo, hi = joint.limits
            for v, env in values:
                if not lo <= v <= hi:
                    self.warn(text.at(e.span), f"{v:g} {unit}{_with(env)} is outside the limits of {joint.name}, "
                              f"{lo:g} .. {hi:g} {unit}: the joint stops at its limit")
                    return

    # -- what nothing reads ------------------------------------------------------------------
    def unused(self) -> None:
        """Parameters, sliders and computed ``let`` signals that no expression reads.

        A signal that only names a reading (``rope: Hoist_Actuator.position``) is there to put
        that reading in the trace, and is not warned about."""
        used = self.c.used
        f = self.c.file
        for name, (_, node) in (*f.params.items(), *f.lists.items()):  # a list parameter too (format 1.3)
            if name not in used:
                self.warn(node, f"parameter '{name}' is never used", "no expression reads it, so setting it "
                          "(or '--set') changes nothing")
        for sl in f.sliders:
            if sl.name not in used:
                self.warn(sl.key, f"slider '{sl.name}' is never used", "no expression reads it, so moving it "
                          "changes nothing; bind it, as in 'bind: Joint.velocity: 0.1 * " + sl.name + "'")
        for name, parsed, node in f.lets:
            if name not in used and not isinstance(parsed.node, ast.Name | ast.Attribute | ast.Peer):
                self.warn(node, f"signal '{name}' is computed but never used", "only the trace records it; "
                          "a signal that just names a reading (like 'rope: Hoist_Actuator.position') is not "
                          "warned about")


class _Continuous(ast.Visitor[str]):
    """What makes an expression a continuous number ('time', a reading, a signal of them), or ''."""

    def __init__(self, linter: Linter) -> None:
        self.linter = linter

    def visit_Name(self, e: ast.Name) -> str:
        c = self.linter.c
        if e.id in CONTINUOUS_VARIABLES:
            return f"'{e.id}'"
        kind = c.channel_kinds.get(e.id)
        if kind in _CONTINUOUS_KINDS and e.id not in _DISCRETE_CHANNELS:
            return f"'{e.id}', a sensor reading"
        if e.id in self.linter.let_exprs:
            inner = self.linter.continuous_lets(e.id)
            return f"'{e.id}', which reads {inner.split(',')[0]}" if inner else ""
        return ""

    def visit_Call(self, e: ast.Call) -> str:
        return "" if e.func in _DISCRETE else self.first(ast.children(e))

    def visit_Peer(self, e: ast.Peer) -> str:
        """Another robot's pose, or a signal of it that is continuous, as this robot's would be."""
        member = e.member.value if isinstance(e.member, ast.Number) else None
        whose = e.robot + (("[...]" if member is None else f"[{member:g}]") if e.indexed else "")
        if e.attr in ("x", "y", "heading"):
            return f"'{whose}.{e.attr}', another robot's pose"
        inner = self.linter.continuous_lets(e.attr) if e.attr in self.linter.let_exprs else ""
        return f"'{whose}.{e.attr}', which reads {inner.split(',')[0]}" if inner else ""

    def visit_IfExp(self, e: ast.IfExp) -> str:
        return self.first((e.body, e.orelse))  # the test only chooses

    def first(self, parts: tuple[ast.Expr, ...]) -> str:
        for sub in parts:
            found = self.visit(sub)
            if found:
                return found
        return ""

    # booleans and text are not numbers; a number of numbers is continuous when one of them is
    def visit_Compare(self, e: ast.Expr) -> str:
        return ""

    visit_BoolOp = visit_Not = visit_Text = visit_Number = visit_Bool = visit_Compare
    generic = frozenset({ast.Neg, ast.Binary, ast.Attribute, ast.Group, ast.Index, ast.Slice})

    def generic_visit(self, e: ast.Expr, *args: Any) -> str:
        return self.first(ast.children(e))


class _SonarRange(ast.Visitor["tuple[float, tuple[str, ...]] | None"]):
    """(the farthest distance an expression can read, the sonars) when it is a sonar, a signal
    that is one, or the nearest (or farthest) of sonars; None for anything else."""

    def __init__(self, linter: Linter) -> None:
        self.linter = linter

    def visit_Name(self, e: ast.Name) -> tuple[float, tuple[str, ...]] | None:
        c = self.linter.c
        if e.id in c.distance_channels:
            ranges = [s.range_m for m in c.models.values() for s in m.rays() if s.name == e.id]
            return (max(ranges), (e.id,)) if ranges else None
        if e.id in self.linter.let_exprs:
            return self.linter.sonar_lets(e.id)
        return None

    def visit_Call(self, e: ast.Call) -> tuple[float, tuple[str, ...]] | None:
        if e.func not in ("min", "max") or not e.args:
            return None
        args = e.args[0].members if len(e.args) == 1 and isinstance(e.args[0], ast.Group) else e.args
        seen = [self.visit(a) for a in args]
        found = [s for s in seen if s is not None]
        if len(found) == len(seen):
            return max(r for r, _ in found), tuple(sorted({n for _, names in found for n in names}))
        return None

    generic = frozenset(set(ast.node_classes()) - {ast.Name, ast.Call})

    def generic_visit(self, e: ast.Expr, *args: Any) -> None:
        return None


class _Stateful(ast.Visitor[None]):
    """pid(), prev() and the like where they are not evaluated every tick: ``where`` says why an
    expression runs only on some ticks (None: every tick)."""

    def __init__(self, linter: Linter) -> None:
        self.linter = linter

    def visit_Call(self, e: ast.Call, text: Text, where: str | None) -> None:
        if e.func in STATEFUL and where is not None and id(e) not in self.linter.c.self_prev:
            self.linter.warn(text.at(e.func_span), f"{e.func}() {where}: its memory misses the other ticks",
                             "compute it in a 'let' signal, which runs every tick, and use the signal here")
        self.generic_visit(e, text, where)

    def visit_BoolOp(self, e: ast.BoolOp, text: Text, where: str | None) -> None:
        self.visit(e.values[0], text, where)
        for v in e.values[1:]:
            self.visit(v, text, where or f"is after '{e.op}', evaluated only on the ticks what comes before it "
                                         f"{'holds' if e.op == 'and' else 'does not hold'}")

    def visit_IfExp(self, e: ast.IfExp, text: Text, where: str | None) -> None:
        self.visit(e.test, text, where)
        for branch in (e.body, e.orelse):
            self.visit(branch, text, where or "is in a branch of 'if ... else', evaluated only on the ticks that "
                                              "branch is taken")

    # the others run their parts whenever they run (a group's members, each of them)
    generic = frozenset(set(ast.node_classes()) - {ast.Call, ast.BoolOp, ast.IfExp})

    def generic_visit(self, e: ast.Expr, *args: Any) -> None:
        for child in ast.children(e):
            self.visit(child, *args)


def _with(env: dict[str, float]) -> str:
    """' (with arm = 10)': the slider settings a value was found at."""
    return f" (with {', '.join(f'{k} = {v:g}' for k, v in env.items())})" if env else ""
