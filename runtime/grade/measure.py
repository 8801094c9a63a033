"""The grader's own metrics, compiled into each student's program: what ``labsim grade`` measures.

An assignment's ``measure:`` section (runtime/grade/assignment.py) defines metrics in the
behaviour language's metric syntax, read and checked against what a student's file can write
(a measured metric reads only sensors, the pose, ``collided``, ``forward_speed``, the wheel
commands, time and the grader's params). ``prepare_graded`` reads a student's file as ``labsim.dsl.compile.prepare``
does and adds the measured metrics to it under names no file can write (``MEASURED_SUFFIX``),
so they are folded on every tick of the student's own run, from the same readings, at no
cost of a second run; and a distance metric for the built-in ``moved`` criterion. The
contract check (contract.py) and the runs (runs.py) both compile through it.
"""
from __future__ import annotations

import re
from dataclasses import replace
from pathlib import Path

from labsim.dsl.analysis.budget import check_budgets
from labsim.dsl.analysis.check import check
from labsim.dsl.compile import Prepared, code_filename
from labsim.dsl.syntax.parse import parse_expr
from labsim.dsl.syntax.read import BehaviourFile, MetricDecl, Parsed, read
from labsim.foundation.diagnostics import Diagnostic, LabsimError, Report
from labsim.foundation.limits import DEFAULT_BUDGETS, Budgets
from labsim.foundation.source import load, loads
from labsim.runtime.grade.assignment import MEASURED_SUFFIX

# the mean forward speed (m/s, either way) of a robot; times the run's simulated time, the
# distance it drove: what the built-in criterion moved reads
SPEED_METRIC = "speed" + MEASURED_SUFFIX
_SPEED_TEXT = "mean(abs(forward_speed))"


SPEED_PATH = "<the grader's distance driven>"


def _speed_decl() -> MetricDecl:
    doc = loads(f'speed: "{_SPEED_TEXT}"\n', SPEED_PATH)
    assert doc.root is not None
    key, value = doc.root.value[0]
    return MetricDecl(SPEED_METRIC, Parsed(parse_expr(_SPEED_TEXT), doc.text_of(value)), key)


def graded_file(path: str | Path, report: Report, measure: tuple[MetricDecl, ...] = (), moved: bool = False,
                text: str | None = None) -> BehaviourFile:
    """The student's file read, with the measured metrics added under their measured names."""
    doc = load(path) if text is None else loads(text, str(path))
    bf = read(doc, report)
    if report.errors:  # the file's own mistakes are what its author reads first; none of the grader's
        return bf
    bf.metrics = [*bf.metrics, *(replace(m, name=m.name + MEASURED_SUFFIX) for m in measure),
                  *((_speed_decl(),) if moved else ())]
    return bf


def prepare_graded(path: str | Path, overrides: dict[str, str] | None = None, budgets: Budgets = DEFAULT_BUDGETS,
                   measure: tuple[MetricDecl, ...] = (), moved: bool = False) -> Prepared:
    """``labsim.dsl.compile.prepare`` with the grader's metrics added (see the module docstring).
    A measured metric the student's robots cannot be measured by (a sensor their model lacks)
    is an error at its place in the assignment file."""
    report = Report()
    return prepare_read(graded_file(path, report, measure, moved), report, overrides, budgets)


def prepare_read(bf: BehaviourFile, report: Report, overrides: dict[str, str] | None = None,
                 budgets: Budgets = DEFAULT_BUDGETS) -> Prepared:
    """The rest of ``prepare_graded`` for a file read already (``graded_file``) into ``report``."""
    checked = check(bf, report, overrides)
    if not report.errors:
        check_budgets(checked, budgets, report)
    report.raise_if_errors()
    return Prepared(checked, tuple(report.diagnostics), False, code_filename(bf.path, overrides))


def split_metrics(values: dict[str, float]) -> tuple[dict[str, float], dict[str, float]]:
    """A run's metric values as (the student's own, the grader's measured ones by their names)."""
    own = {k: v for k, v in values.items() if not k.endswith(MEASURED_SUFFIX)}
    measured = {k.removesuffix(MEASURED_SUFFIX): v for k, v in values.items()
                if k.endswith(MEASURED_SUFFIX) and k != SPEED_METRIC}
    return own, measured


def graders(d: Diagnostic, assignment_path: str) -> bool:
    """Whether a diagnostic is about the grader's metrics (the assignment's text), not the student's file."""
    return d.path in (assignment_path, SPEED_PATH)


def the_assignments(diagnostics: list[Diagnostic], assignment_path: str) -> bool:
    """Whether every error is in the grader's metrics: the file is fine, but cannot be measured so."""
    errors = [d for d in diagnostics if d.severity == "error"]
    return bool(errors) and all(graders(d, assignment_path) for d in errors)


def unmeasurable(e: LabsimError, assignment_path: str) -> str:
    """A gradebook cell: why the assignment's metrics cannot be measured on a student's file."""
    d = next(d for d in e.diagnostics if d.severity == "error")
    return (f"the assignment's measured metrics cannot be measured on this file: {Path(d.path).name}:{d.line}:"
            f"{d.col}: {d.message}")


_MEASURE_FAULT = re.compile(r"^metric '([A-Za-z_][A-Za-z0-9_]*)" + re.escape(MEASURED_SUFFIX) + "'")


def is_measure_fault(fault: str) -> bool:
    """Whether a run's fault is in one of the grader's measured metrics (the assignment's formula)."""
    return _MEASURE_FAULT.match(fault) is not None


def measure_fault_words(fault: str) -> str:
    """A measured metric's fault, naming the metric as the assignment does."""
    return _MEASURE_FAULT.sub(lambda m: f"measured metric '{m.group(1)}'", fault, count=1)


def measure_fault_metric(fault: str) -> str:
    """The measured metric a fault (``measure_fault_words``) is in."""
    m = re.match(r"^measured metric '([A-Za-z_][A-Za-z0-9_]*)'", fault)
    return m.group(1) if m else ""
