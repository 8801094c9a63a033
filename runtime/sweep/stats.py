"""The comparison a sweep prints: per setting (and per file), per metric, the spread over seeds.

For each group of runs (one file, one combination of settings) and each metric: n, mean,
sample standard deviation, a 95% confidence interval for the mean (Student's t with n - 1
degrees of freedom), min and max; the best group per metric is marked by the way the metric
is better (its ``better:``, else its aggregate's default; ``--maximize`` makes it higher): the
highest or the lowest mean, and none for a metric without a direction (a ``duration`` that
declares none) or one the files disagree on. When a file is run with exactly two settings,
each metric gets Welch's unequal-variances t-test of the two means: the difference counts as
larger than the seeds' noise when p < 0.05 (docs/sweep.md says what that does and does not
mean). The t distribution is runtime/sweep/student_t.py (plain Python: scipy.stats's import
alone cost more than a short sweep's runs).

Only rows with status ok count; non-finite values (a ``minimum`` over nothing is ``inf``)
are left out of n and noted.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from labsim.dsl.library.builtins import Better
from labsim.runtime.sweep import student_t
from labsim.runtime.sweep.grid import Row

ALPHA = 0.05  # the test's level, and 1 - the confidence of the intervals


@dataclass(frozen=True)
class Stat:
    """A metric over the seeds of one group."""

    n: int
    mean: float
    sd: float  # sample standard deviation (n - 1); nan for n < 2
    ci_low: float  # 95% confidence interval of the mean; nan for n < 2
    ci_high: float
    min: float
    max: float
    left_out: int = 0  # non-finite values not counted


@dataclass(frozen=True)
class Test:
    """Welch's t-test of two groups' means for one metric."""

    file: str
    metric: str
    a: str
    b: str
    difference: float  # mean of b - mean of a
    p: float  # two-sided; nan when it cannot be computed
    verdict: str


def describe(values: list[float]) -> Stat:
    finite = [float(v) for v in values if isinstance(v, (int, float)) and math.isfinite(v)]
    left_out = len(values) - len(finite)
    n = len(finite)
    if n == 0:
        return Stat(0, math.nan, math.nan, math.nan, math.nan, math.nan, math.nan, left_out)
    mean = math.fsum(finite) / n
    if n < 2:
        return Stat(1, mean, math.nan, math.nan, math.nan, mean, mean, left_out)
    sd = math.sqrt(math.fsum((v - mean) ** 2 for v in finite) / (n - 1))
    half = student_t.quantile(1 - ALPHA / 2, n - 1) * sd / math.sqrt(n)
    return Stat(n, mean, sd, mean - half, mean + half, min(finite), max(finite), left_out)


def welch(file: str, metric: str, a: str, b: str, xs: list[float], ys: list[float]) -> Test:
    """Welch's t-test (two-sided, unequal variances) of the means of xs and ys."""
    xs = [v for v in xs if math.isfinite(v)]
    ys = [v for v in ys if math.isfinite(v)]
    if len(xs) < 2 or len(ys) < 2:
        return Test(file, metric, a, b, math.nan, math.nan, "too few runs to test (need 2 or more seeds each)")
    diff = math.fsum(ys) / len(ys) - math.fsum(xs) / len(xs)
    if max(xs) == min(xs) and max(ys) == min(ys):  # no spread at all: the t statistic is undefined
        verdict = "the same in every run" if diff == 0 else "different, and no spread over seeds in either"
        return Test(file, metric, a, b, diff, math.nan, verdict)
    p = welch_p(xs, ys)
    verdict = "larger than the seeds' noise" if p < ALPHA else "within the seeds' noise"
    return Test(file, metric, a, b, diff, p, verdict)


def welch_p(xs: list[float], ys: list[float]) -> float:
    """The two-sided p of Welch's t statistic, as scipy.stats.ttest_ind(equal_var=False) gives it:
    sample variances (n - 1), the Welch-Satterthwaite degrees of freedom."""
    vx, vy = _variance(xs) / len(xs), _variance(ys) / len(ys)
    t = (math.fsum(ys) / len(ys) - math.fsum(xs) / len(xs)) / math.sqrt(vx + vy)
    df = (vx + vy) ** 2 / (vx * vx / (len(xs) - 1) + vy * vy / (len(ys) - 1))
    return min(1.0, 2.0 * student_t.sf(abs(t), df))


def _variance(values: list[float]) -> float:
    mean = math.fsum(values) / len(values)
    return math.fsum((v - mean) ** 2 for v in values) / (len(values) - 1)


# -- grouping ---------------------------------------------------------------------------------

@dataclass
class Group:
    file: str
    label: str  # the settings, 'front=0.5'
    values: dict[str, list[float]]  # metric -> one value per ok run
    runs: int = 0
    failed: int = 0


def groups(rows: list[Row]) -> list[Group]:
    """Rows grouped by file and settings, in the grid's order; a group is named by the settings
    that vary (a ``--set minutes=2`` with one value is the same in every group), or, when none
    varies, by those set (a single group is still not the file's own settings)."""
    seen: dict[str, set[str]] = {}
    for row in rows:
        for k, v in row.task.settings:
            seen.setdefault(k, set()).add(v)
    out: dict[tuple[str, str], Group] = {}
    for row in sorted(rows, key=lambda r: r.task.index):
        varying = any(len(seen[k]) > 1 for k, _ in row.task.settings)
        label = " ".join(f"{k}={v}" for k, v in row.task.settings if len(seen[k]) > 1 or not varying)
        g = out.setdefault((row.task.file, label), Group(row.task.file, label, {}))
        g.runs += 1
        if row.failed or row.result is None:
            g.failed += 1
            continue
        for name, value in row.result.metric_values().items():
            g.values.setdefault(name, []).append(_float(value))
    return list(out.values())


def _float(value: Any) -> float:
    return float(value) if isinstance(value, (int, float, str)) else math.nan


def directions(rows: list[Row], maximize: tuple[str, ...] = ()) -> tuple[dict[str, Better | None], set[str]]:
    """Which way each metric is better, as the files say; ``--maximize`` makes it higher. A
    metric the files disagree on has none, and is in the second set."""
    said: dict[str, set[Better | None]] = {}
    for row in rows:
        if row.result is not None:
            for m, b in row.result.metric_better.items():
                said.setdefault(m, set()).add(b)
    out = {m: next(iter(bs)) if len(bs) == 1 else None for m, bs in said.items()}
    out.update({m: Better.HIGHER for m in maximize})
    return out, {m for m, bs in said.items() if len(bs) > 1 and m not in maximize}


def comparison(rows: list[Row], maximize: tuple[str, ...] = ()) -> dict[str, Any]:
    """The comparison as data: per metric, each group's Stat, its direction and which is best; the tests."""
    better, disagree = directions(rows, maximize)
    gs = groups(rows)
    metrics: list[str] = []
    for g in gs:
        metrics += [m for m in g.values if m not in metrics]
    table: dict[str, list[tuple[Group, Stat]]] = {m: [(g, describe(g.values.get(m, []))) for g in gs] for m in metrics}
    best: dict[str, list[int]] = {}
    for m, entries in table.items():
        means = [s.mean for _, s in entries if s.n]
        if means and better.get(m) is not None:
            target = max(means) if better[m] is Better.HIGHER else min(means)
            best[m] = [i for i, (_, s) in enumerate(entries) if s.n and s.mean == target]
    tests: list[Test] = []
    for f in dict.fromkeys(g.file for g in gs):
        pair = [g for g in gs if g.file == f]
        if len(pair) == 2 and pair[0].label != pair[1].label:
            a, b = pair
            tests += [welch(f, m, a.label, b.label, a.values.get(m, []), b.values.get(m, [])) for m in metrics]
    return {"groups": gs, "metrics": metrics, "table": table, "best": best, "tests": tests,
            "better": {m: better.get(m) for m in metrics}, "disagree": disagree}
