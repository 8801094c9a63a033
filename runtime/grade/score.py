"""A student's grade from their runs: the criteria applied, the score, and the class's likely copies.

The third stage of ``labsim grade``: a ``Submission`` (runtime/grade/contract.py) and the
``SeedRun`` of each seed (runtime/grade/runs.py) become one frozen ``Grade``, the row every
renderer reads (the gradebook CSV and JSON, the feedback page, the overview). A submission the
contract refused, or whose run timed out, went over a budget or crashed, has no score: its
status says why. A graded one scores each criterion on the mean of its metric over the seeds
(the assignment's measured metric, or with ``from: student`` the file's own; a built-in
criterion on every seed's run) and its score is the weighted share, 0 to 100, unless it failed
a required criterion (a gate): then its status names the gate and its score is the
assignment's ``gate_score``, or what the criteria earned if that is less.
"""
from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace

from labsim.foundation.diagnostics import Diagnostic
from labsim.runtime.grade.assignment import NO_COLLISIONS, NO_FAULTS, RAN_TO_STOP, Assignment, Criterion
from labsim.runtime.grade.contract import BUDGET, COMPILE_ERROR, CRASH, FAILED_GATE, GRADED, TIMEOUT, Submission
from labsim.runtime.grade.runs import CRASHED, NOT_COMPILED, OVER_BUDGET, RAN, TIMED_OUT, SeedRun

_STATUS_OF_RUN = {NOT_COMPILED: COMPILE_ERROR, TIMED_OUT: TIMEOUT, OVER_BUDGET: BUDGET, CRASHED: CRASH}


@dataclass(frozen=True)
class CriterionResult:
    name: str
    description: str
    value: float | None  # the metric's mean over the seeds (a built-in's own value: moved's distance); or None
    passed: bool
    points: float  # of ``weight``
    weight: float
    required: bool = False  # a gate
    why: str = ""  # what failed it, in words (a fault with its rule, tick and robot; a distance)
    source: str = "measured"  # "measured" (the assignment's), "student" (the file's own) or "built-in"


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
    measured: Mapping[str, float] = field(default_factory=dict)  # measured metric -> mean over the seeds
    structure: tuple[str, str] = ("", "")  # the file's fingerprints (runtime/grade/copies.py)
    gate: str = ""  # the required criterion it failed ("" when none)

    @property
    def scored(self) -> bool:
        """Whether the row has a score: graded, or failed a gate (and has the gate's score)."""
        return self.score is not None

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
    # what was passed over in the submissions folders, with why (a world file, the same file twice)
    skipped: list[tuple[str, str]] = field(default_factory=list)
    # the assignment's own problems met while grading (its reference fails it, a measured
    # metric's fault): said on stderr, in the JSON and atop the overview
    warnings: list[str] = field(default_factory=list)


def grade_of(submission: Submission, runs: list[SeedRun], assignment: Assignment) -> Grade:
    """The grade of a submission from its runs, one per seed in the assignment's order."""
    base = Grade(submission.student, submission.path, submission.status, submission.reason, None,
                 submission.diagnostics, tuple(runs), source=submission.source, structure=submission.structure)
    if submission.status != GRADED:
        return base
    failed = next((r for r in runs if r.status != RAN), None)
    means = metric_means(runs)
    measured = metric_means(runs, measured=True)
    if failed is not None:
        reason = " ".join(f"seed {failed.seed}: {failed.message}".split())  # one line: a gradebook cell
        return replace(base, status=_STATUS_OF_RUN[failed.status], reason=reason, means=means, measured=measured,
                       diagnostics=base.diagnostics + failed.diagnostics)
    own = bool(assignment.measure)  # with measure:, a criterion reads the student's metric only when it says so
    results = tuple(score_criterion(c, measured if own and not c.student else means, runs,
                                    "built-in" if c.builtin else "measured" if own and not c.student else "student")
                    for c in assignment.criteria)
    total = sum(r.points for r in results) / assignment.weights * 100 if assignment.weights else 0.0
    gate = next((r for r in results if r.required and not r.passed), None)
    if gate is not None:  # a gate failed: the assignment's score for it, whatever the rest earned
        # never more than the criteria earned: failing a gate cannot raise a score
        return replace(base, status=f"{FAILED_GATE}: {gate.name}", score=min(round(total, 2), assignment.gate_score),
                       reason=" ".join(f"required criterion '{gate.name}' failed: {gate.why}".split()),
                       means=means, measured=measured, criteria=results, gate=gate.name)
    return replace(base, score=round(total, 2), means=means, measured=measured, criteria=results)


def metric_means(runs: list[SeedRun], measured: bool = False) -> dict[str, float]:
    """Each metric's mean over the runs that have a value of it (nan where none has): the
    student's own metrics, or with ``measured`` the assignment's."""
    def of(r: SeedRun) -> Mapping[str, float]:
        return r.measured if measured else r.metrics

    names = list(dict.fromkeys(n for r in runs for n in of(r)))
    out = {}
    for name in names:
        # a nan is no value; an inf is one (the closest approach of a robot no sonar ever saw a wall from)
        values = [of(r)[name] for r in runs if name in of(r) and not math.isnan(of(r)[name])]
        out[name] = sum(values) / len(values) if values else math.nan
    return out


def first_fault(runs: list[SeedRun] | tuple[SeedRun, ...]) -> tuple[int, str] | None:
    """The first fault of the runs: (seed, its text with its rule, first tick and robot)."""
    found = [(r.seed, f) for r in runs for f in r.faults]
    if not found:
        return None
    seeds = [r.seed for r in runs]

    def tick(item: tuple[int, str]) -> tuple[int, int]:
        m = _TICK.search(item[1])
        return seeds.index(item[0]), int(m.group(1)) if m else 0
    return min(found, key=tick)


_TICK = re.compile(r"first at tick (\d+)")


def _builtin(c: Criterion, runs: list[SeedRun]) -> tuple[bool, float | None, str]:
    """A built-in criterion on the runs: passed, its value (moved's distance) and why it failed."""
    if c.name == RAN_TO_STOP:
        late = next((r for r in runs if not r.stopped), None)
        return late is None, None, f"seed {late.seed} did not reach its stop condition" if late else ""
    if c.name == NO_FAULTS:
        fault = first_fault(runs)
        return fault is None, None, f"seed {fault[0]}: {fault[1]}" if fault else ""
    if c.name == NO_COLLISIONS:
        hit = next((r for r in runs if r.collisions), None)
        return hit is None, None, (f"seed {hit.seed}: {hit.collisions} collision{'s' * (hit.collisions != 1)}"
                                   if hit else "")
    distances = [(r.seed, r.distance_m if r.distance_m is not None else math.nan) for r in runs]
    least = min(distances, key=lambda d: d[1] if math.isfinite(d[1]) else -1.0, default=(0, math.nan))
    at_least = c.at_least or 0.0
    passed = bool(distances) and all(math.isfinite(d) and d >= at_least for _, d in distances)
    return passed, least[1], "" if passed else (f"seed {least[0]}: a robot drove {least[1]:.2f} m, less than the "
                                                f"{at_least:g} m asked")


def score_criterion(c: Criterion, means: Mapping[str, float], runs: list[SeedRun],
                    source: str = "measured") -> CriterionResult:
    if c.builtin:
        passed, value, why = _builtin(c, runs)
        return CriterionResult(c.name, c.describe(), value, passed, c.weight * passed, c.weight, c.required, why,
                               "built-in")
    value = means.get(c.name, math.nan)
    fraction = c.fraction(value)
    passed = fraction > 0 if c.worst is not None else fraction == 1
    why = "" if passed else (f"{c.name} is {value:.4g}; " if math.isfinite(value) else f"{c.name} has no value; ") \
        + f"the criterion is {c.describe()}"
    return CriterionResult(c.name, c.describe(), value, passed, round(c.weight * fraction, 6), c.weight, c.required,
                           "" if passed else why, source)


def likely_copies(grades: list[Grade]) -> list[tuple[str, tuple[str, ...]]]:
    """Groups of students whose submissions look copied, for the teacher to look at, each with
    what matched, strongest first: the same normalised source; the same program once the names
    its author chose, comments and order are set aside (runtime/grade/copies.py: a renamed
    param, renamed metrics, reordered rules); the same with other numbers too, unless a
    quarter of the class shares it (then it is the lab's own template, not a copy); or the
    same metrics to the last digit, and the same ticks, on every seed."""
    by_source: dict[str, list[str]] = {}
    by_names: dict[str, list[str]] = {}
    by_numbers: dict[str, list[str]] = {}
    by_metrics: dict[str, list[str]] = {}
    for g in grades:
        if g.source:
            by_source.setdefault(g.source, []).append(g.student)
        if g.structure[0]:
            by_names.setdefault(g.structure[0], []).append(g.student)
            by_numbers.setdefault(g.structure[1], []).append(g.student)
        finished = [r for r in g.runs if r.status == RAN and (r.metrics or r.measured)]
        if finished and len(finished) == len(g.runs):
            fingerprint = repr([(r.seed, sorted(r.metrics.items()), sorted(r.measured.items()), r.ticks)
                                for r in finished])
            by_metrics.setdefault(fingerprint, []).append(g.student)
    template = max(2, sum(bool(g.structure[1]) for g in grades) // 4)  # a group this large is the lab's own
    by_numbers = {k: v for k, v in by_numbers.items() if len(v) <= template}
    out: list[tuple[str, tuple[str, ...]]] = []
    seen: list[set[str]] = []
    for reason, groups in (("the same source, comments and spacing aside", by_source),
                           ("the same program once names, comments and order are set aside", by_names),
                           ("the same program with other numbers (names, comments and order aside)", by_numbers),
                           ("the same metrics to the last digit on every seed", by_metrics)):
        for students in groups.values():
            group = tuple(sorted(students))
            if len(group) > 1 and not any(set(group) <= other for other in seen):
                seen.append(set(group))
                out.append((reason, group))
    return out
