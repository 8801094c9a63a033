"""Likely copies through renames: a behaviour file's structure, with everything a copier changes set aside.

The contract check (runtime/grade/contract.py) reads every submission that parses, whatever
becomes of it after, and ``structures`` turns what was read into two fingerprints: the file's
program with every name its author chose (params, signals, states, functions and their
arguments, metrics, robots) replaced by what kind of name it is, comments, spacing and the
order of keys, rules, signals and metrics set aside; and the same with every number set aside
too. The grader (runtime/grade/score.py) lists the students who share one as likely copies,
for the teacher to look at: a copy with its params, signals or metrics renamed, or its rules
reordered, has the first of its original; one that also changed its gains, the second.
"""
from __future__ import annotations

import hashlib
from dataclasses import is_dataclass

from labsim.dsl.syntax import ast
from labsim.dsl.syntax.read import BehaviourFile, RobotDecl
from labsim.runtime.grade.assignment import MEASURED_SUFFIX


def structures(bf: BehaviourFile) -> tuple[str, str]:
    """The file's two fingerprints (numbers kept, numbers set aside), or empty ones for a file
    with no rules (an empty file, a YAML list: nothing a copy would share); see the module docstring."""
    if not bf.states:
        return "", ""
    used = _used(bf)
    kinds: dict[str, str] = {}
    for name in bf.params:
        kinds[name] = "param"
    for name, _, _ in bf.lets:
        kinds[name] = "signal"
    for name in bf.states:
        kinds[name] = "state"
    for f in bf.functions:
        kinds[f.name] = "function"
        kinds.update({p: "argument" for p in f.params})
    for m in bf.metrics:
        kinds[m.name] = "metric"
    for r in bf.robots:
        kinds[r.name] = "robot"
    return _fingerprint(bf, kinds, used, numbers=True), _fingerprint(bf, kinds, used, numbers=False)


def _names_in(node: object) -> set[str]:
    """Every name an expression, rule or action reads or calls."""
    out: set[str] = set()
    if isinstance(node, ast.Name):
        out.add(node.id)
    elif isinstance(node, ast.Call):
        out.add(node.func)
    elif isinstance(node, ast.Action):
        out.add(node.name)
    if isinstance(node, tuple):
        for item in node:
            out |= _names_in(item)
    elif is_dataclass(node):
        for value in vars(node).values():
            if isinstance(value, (tuple, ast.Expr, ast.Rule, ast.Action)) or is_dataclass(value):
                out |= _names_in(value)
    return out


def _used(bf: BehaviourFile) -> set[str]:
    """The names the program reads, from its stop condition, rules and metrics through the
    signals and functions they read: a definition nothing reads (``let: junk: 1``) is no part
    of the program, and a copy that adds one is still the copy."""
    lets = {name: parsed.node for name, parsed, _ in bf.lets}
    functions = {f.name: f.body.node for f in bf.functions}
    todo = set(_names_in(bf.stop.node)) if bf.stop else set()
    for rules, _ in bf.states.values():
        for r in rules:
            todo |= _names_in(r.rule)
    for m in bf.metrics:
        todo |= _names_in(m.value.node)
    todo |= {name for name in bf.params if name in repr(bf.robots)}  # a robot's own values, its noise
    used: set[str] = set()
    while todo:
        name = todo.pop()
        if name in used:
            continue
        used.add(name)
        if name in lets:
            todo |= _names_in(lets[name])
        if name in functions:
            todo |= _names_in(functions[name])
    return used


def _fingerprint(bf: BehaviourFile, kinds: dict[str, str], used: set[str], numbers: bool) -> str:
    def shape(node: object) -> str:
        return _shape(node, kinds, numbers)

    def value(v: object) -> str:
        return repr(v) if numbers else "N"

    parts = [f"world {bf.world} dt {value(bf.dt_s)}", f"stop {shape(bf.stop.node) if bf.stop else ''}"]
    parts.append("robots " + " ".join(sorted(f"{r.model}*{r.count}@{value(r.at)} {_gear(r, numbers)}"
                                             for r in bf.robots)))
    parts.append("params " + " ".join(sorted(value(v) for n, (v, _) in bf.params.items() if n in used)))
    parts.append("functions " + " ".join(sorted(f"{len(f.params)}:{shape(f.body.node)}" for f in bf.functions
                                                if f.name in used)))
    parts.append("signals " + " ".join(sorted(shape(p.node) for n, p, _ in bf.lets if n in used)))
    parts.append("states " + " ".join(sorted("[" + " ".join(sorted(shape(r.rule) for r in rules)) + "]"
                                             for rules, _ in bf.states.values())))
    parts.append("metrics " + " ".join(sorted(f"{m.better}:{shape(m.value.node)}" for m in bf.metrics
                                              if not m.name.endswith(MEASURED_SUFFIX))))
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def _gear(robot: RobotDecl, numbers: bool) -> str:
    """What a robot carries beyond its model: its camera (its settings with ``numbers``), lidar and noise."""
    camera = robot.camera
    out = [f"camera={camera!r}" if numbers else "camera"] if camera is not None else []
    out += [name for name, value in (("lidar", robot.lidar), ("noise", robot.noise)) if value is not None]
    return " ".join(out)


def _shape(node: object, kinds: dict[str, str], numbers: bool) -> str:
    """An expression, rule or action as text, its author's names replaced by their kinds."""
    if isinstance(node, ast.Number):
        return repr(node.value) if numbers else "N"
    if isinstance(node, ast.Name):
        return kinds.get(node.id, node.id)
    if isinstance(node, ast.Binary) and node.op in "+-" and isinstance(node.right, ast.Neg):
        # a + -b is a - b, a - -b is a + b
        flipped = ast.Binary("-" if node.op == "+" else "+", node.left, node.right.operand)
        return _shape(flipped, kinds, numbers)
    if isinstance(node, ast.Binary) and node.op in ("+", "*"):  # the order of a sum's or a product's terms
        terms = sorted((_shape(node.left, kinds, numbers), _shape(node.right, kinds, numbers)))
        return f"Binary({node.op},{terms[0]},{terms[1]})"
    if isinstance(node, ast.Compare) and len(node.ops) == 1 and node.ops[0] in (">", ">="):  # b > a is a < b
        swapped = ast.Compare((node.operands[1], node.operands[0]), ("<" if node.ops[0] == ">" else "<=",))
        return _shape(swapped, kinds, numbers)
    if isinstance(node, (ast.Call, ast.Action)):
        name = node.func if isinstance(node, ast.Call) else node.name
        return f"{kinds.get(name, name)}({','.join(_shape(a, kinds, numbers) for a in node.args)})"
    if isinstance(node, ast.Goto):
        return "goto state"
    if isinstance(node, str):
        return node
    if isinstance(node, tuple):
        return "(" + ",".join(_shape(item, kinds, numbers) for item in node) + ")"
    if is_dataclass(node):
        inner = ",".join(_shape(value, kinds, numbers) for name, value in vars(node).items()
                         if not name.endswith("span"))
        return f"{type(node).__name__}({inner})"
    return repr(node)
