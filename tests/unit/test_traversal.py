"""One traversal of the expression tree: every analysis says what it does with every kind of node.

``labsim.dsl.syntax.ast`` derives each node's children from its dataclass fields and gives the
``Visitor`` base every analysis is written on. These tests fail when a node class is added
and an analysis (checking, inference, ranges, the linter, the unbounded-sonar check, folding,
unrolling, code generation, the reference evaluator, the breakpoint compiler) does not handle
it, so that a new construct cannot be forgotten by one of them, as groups were.
"""
from __future__ import annotations

import dataclasses
import importlib
import pkgutil

import pytest

import labsim.dsl
from labsim.dsl.syntax import ast
from labsim.dsl.syntax.parse import parse_expr

# every module of the language, imported so that each of its analyses is registered
for _module in pkgutil.walk_packages(labsim.dsl.__path__, "labsim.dsl."):
    importlib.import_module(_module.name)

ANALYSES = {  # the list of analyses, by the visitor that is each of them (module.class)
    "infer.ExprChecker": "inference", "check._Checker": "checking", "ranges.Ranges": "ranges",
    "lint._Continuous": "the linter's == on continuous values", "lint._SonarRange": "the linter's sonar thresholds",
    "lint._Stateful": "the linter's memory", "unbounded._PidCalls": "the unbounded-sonar check",
    "unbounded._Sensor": "the unbounded-sonar check", "fold._Folder": "folding", "unroll.MemberWriter": "unrolling",
    "codegen._Emit": "code generation", "evaluate._Walker": "the reference evaluator",
    "watch._Reads": "the breakpoint compiler",
}


def visitors() -> dict[str, type[ast.Visitor]]:
    return {f"{v.__module__.rsplit('.', 1)[1]}.{v.__qualname__}": v for v in ast.Visitor.registry
            if v.__module__.startswith("labsim.")}


def test_every_analysis_is_a_visitor_of_the_one_traversal() -> None:
    assert set(ANALYSES) <= set(visitors())


@pytest.mark.parametrize("name", sorted(ANALYSES))
def test_every_analysis_handles_every_node_class(name: str) -> None:
    assert visitors()[name].unhandled() == [], f"{ANALYSES[name]} ({name}) says nothing about these nodes"


def test_a_node_class_no_analysis_knows_is_reported_for_each(monkeypatch: pytest.MonkeyPatch) -> None:
    new = type("Lambda", (), {})  # a construct to come: no analysis has heard of it
    monkeypatch.setattr(ast, "node_classes", lambda: (*[c for c in _classes()], new))
    for name, v in visitors().items():
        assert v.unhandled() == [new], name


def _classes() -> tuple[type[ast.Expr], ...]:
    out, todo = [], list(ast.Expr.__subclasses__())
    while todo:
        cls = todo.pop(0)
        out.append(cls)
        todo.extend(cls.__subclasses__())
    return tuple(out)


def test_children_are_the_fields_that_hold_expressions() -> None:
    for cls in ast.node_classes():
        held = [f.name for f in dataclasses.fields(cls) if f.compare and "Expr" in str(f.type)]
        assert sorted(ast.child_fields(cls)) == sorted(held), cls


def test_walk_visits_every_node_in_evaluation_order() -> None:
    e = parse_expr("[a, -b][k] + f(c if not d else e.x, 'text', 1 < g <= 2, true or h, m[1:n], p[:q]) + r[s].y",
                   frozenset("r"))
    names = [n.id for n in ast.walk(e) if isinstance(n, ast.Name)]
    # the test of an 'if' before its branches
    assert names == ["a", "b", "k", "d", "c", "e", "g", "h", "m", "n", "p", "q", "s"]
    kinds = {type(n) for n in ast.walk(e)}
    assert kinds == set(ast.node_classes())  # this expression has one node of every kind


def test_walk_of_a_flat_group_of_1000_members_needs_no_stack() -> None:
    e = parse_expr("[" + ", ".join(f"s{k}" for k in range(1000)) + "]")
    assert sum(1 for _ in ast.walk(e)) == 1001
