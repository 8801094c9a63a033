"""A student's grade from their runs: the criteria applied, the score, and the class's likely copies.

The third stage of ``labsim grade``: a ``Submission`` (runtime/grade/contract.py) and the
``SeedRun`` of each seed (runtime/grade/runs.py) become one frozen ``Grade``, the row every
renderer reads (the gradebook CSV and JSON, the feedback page, the overview). A submission the
contract refused, or whose run timed out, went over a budget or crashed, has no score: its
status says why. A graded one scores each criterion on the mean of its metric over the seeds
(a built-in criterion on every seed's run) and its score is the weighted share, 0 to 100.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from labsim.foundation.diagnostics import Diagnostic
from labsim.runtime.grade.assignment import NO_COLLISIONS, NO_FAULTS, RAN_TO_STOP, Assignment, Criterion
from labsim.runtime.grade.contract import BUDGET, COMPILE_ERROR, CRASH, GRADED, TIMEOUT, Submission
from labsim.runtime.grade.runs import CRASHED, NOT_COMPILED, OVER_BUDGET, RAN, TIMED_OUT, SeedRun

_STATUS_OF_RUN = {NOT_COMPILED: COMPILE_ERROR, TIMED_OUT: TIMEOUT, OVER_BUDGET: BUDGET, CRASHED: CRASH}


@dataclass(frozen=True)
class CriterionResult:
    name: str
    description: str
    value: float | None  # the metric's mean over the seeds; None for a built-in
    passed: bool
    points: float  # of ``weight``
    weight: float


@dataclass(frozen=True)
class Grade:
    """One student's row: see the module docstring."""

    student: str
    path: str
    status: str
    reason: str = ""
    score: float | None = None  # 0..100, None when not graded
    diagnostics: tuple[Diagnostic, ...] = ()
    runs: tuple[SeedRun, ...] = ()
    means: Mapping[str, float] = field(default_factory=dict)  # metric -> mean over the seeds
    criteria: tuple[CriterionResult, ...] = ()
    source: str = ""  # the normalised source (likely copies)

    @property
    def graded(self) -> bool:
        return self.status == GRADED


@dataclass(frozen=True)
class Graded:
    """A class graded: every student's grade, the likely copies, and how much was run."""

    assignment: Assignment
    grades: list[Grade]
    copies: list[tuple[str, tuple[str, ...]]]
    reference: Grade | None
    ran: int  # runs made now
    reused: int  # runs taken from the cache
    ended_by: int  # the signal that stopped the grading before every run was done (0: none)
    # student -> the pictures of seed 1's run: its map (PNG) and its animation (GIF, or b"")
    pictures: dict[str, tuple[bytes, bytes]] = field(default_factory=dict)
    # the groups of students whose names alone would have been one (alice.yaml and alice.yml)
    collisions: list[tuple[str, ...]] = field(default_factory=list)


def grade_of(submission: Submission, runs: list[SeedRun], assignment: Assignment) -> Grade:
    """The grade of a submission from its runs, one per seed in the assignment's order."""
    base = Grade(submission.student, submission.path, submission.status, submission.reason, None,
                 submission.diagnostics, tuple(runs), source=submission.source)
    if submission.status != GRADED:
        return base
    failed = next((r for r in runs if r.status != RAN), None)
    means = metric_means(runs)
    if failed is not None:
        reason = " ".join(f"seed {failed.seed}: {failed.message}".split())  # one line: a gradebook cell
        return replace(base, status=_STATUS_OF_RUN[failed.status], reason=reason, means=means,
                       diagnostics=base.diagnostics + failed.diagnostics)
    results = tuple(score_criterion(c, means, runs) for c in assignment.criteria)
    total = sum(r.points for r in results) / assignment.weights * 100 if assignment.weights else 0.0
    return replace(base, score=round(total, 2), means=means, criteria=results)


def metric_means(runs: list[SeedRun]) -> dict[str, float]:
    """Each metric's mean over the runs that have it (nan where none has a finite value)."""
    names = list(dict.fromkeys(n for r in runs for n in r.metrics))
    out = {}
    for name in names:
        values = [r.metrics[name] for r in runs if name in r.metrics and math.isfinite(r.metrics[name])]
        out[name] = sum(values) / len(values) if values else math.nan
    return out


def score_criterion(c: Criterion, means: Mapping[str, float], runs: list[SeedRun]) -> CriterionResult:
    if c.builtin:
        passed = {RAN_TO_STOP: all(r.stopped for r in runs),
                  NO_FAULTS: not any(r.faults for r in runs),
                  NO_COLLISIONS: not any(r.collisions for r in runs)}[c.name]
        return CriterionResult(c.name, c.describe(), None, passed, c.weight * passed, c.weight)
    value = means.get(c.name, math.nan)
    fraction = c.fraction(value)
    return CriterionResult(c.name, c.describe(), value, fraction > 0 if c.worst is not None else fraction == 1,
                           round(c.weight * fraction, 6), c.weight)


def likely_copies(grades: list[Grade]) -> list[tuple[str, tuple[str, ...]]]:
    """Groups of students whose submissions look copied, for the teacher to look at: the same
    normalised source, or the same metrics to the last digit on every seed (a copy with its
    params renamed runs the same)."""
    out: list[tuple[str, tuple[str, ...]]] = []
    by_source: dict[str, list[str]] = {}
    by_metrics: dict[str, list[str]] = {}
    for g in grades:
        if g.source:
            by_source.setdefault(g.source, []).append(g.student)
        finished = [r for r in g.runs if r.status == RAN and r.metrics]
        if finished and len(finished) == len(g.runs):
            fingerprint = repr([(r.seed, sorted(r.metrics.items()), r.ticks) for r in finished])
            by_metrics.setdefault(fingerprint, []).append(g.student)
    seen: set[tuple[str, ...]] = set()
    for reason, groups in (("the same source, comments and spacing aside", by_source),
                           ("the same metrics to the last digit on every seed", by_metrics)):
        for students in groups.values():
            group = tuple(sorted(students))
            if len(group) > 1 and not any(set(group) <= set(other) for other in seen):
                seen.add(group)
                out.append((reason, group))
    return out
