"""Student's t distribution for a sweep's comparison (runtime/sweep/stats.py), in plain Python.

The comparison needs two things of it: the quantile that makes a 95% confidence interval
(``quantile(0.975, n - 1)``) and the upper tail of Welch's test (``sf(t, df)``, any df > 0).
scipy.stats, which gave both, costs a third of a second to import, more than a short sweep's
runs; here they come from the regularized incomplete beta function (a continued fraction,
Numerical Recipes' ``betacf``, evaluated by Lentz's method), within 1e-12 of scipy's figures
(tests/unit/test_student_t.py compares them over df from 1 to 1,000, and fractional df).
"""
from __future__ import annotations

import math
from functools import lru_cache

_EPS = 1e-16  # the continued fraction stops when a step changes it by less than this
_TINY = 1e-300  # Lentz's guard against a zero denominator
_STEPS = 400  # enough for every a, b and x a sweep meets (a = df/2, b = 1/2)


def _betacf(a: float, b: float, x: float) -> float:
    """The continued fraction of I_x(a, b) (Numerical Recipes, 6.4)."""
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > _TINY else _TINY)
    h = d
    for m in range(1, _STEPS + 1):
        m2 = 2 * m
        for aa in (m * (b - m) * x / ((qam + m2) * (a + m2)), -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))):
            d = 1.0 + aa * d
            d = 1.0 / (d if abs(d) > _TINY else _TINY)
            c = 1.0 + aa / c
            c = c if abs(c) > _TINY else _TINY
            h *= d * c
        if abs(d * c - 1.0) < _EPS:
            break
    return h


def betainc(a: float, b: float, x: float) -> float:
    """The regularized incomplete beta function I_x(a, b), for a, b > 0 and 0 <= x <= 1."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    log_front = math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log1p(-x)
    if x < (a + 1.0) / (a + b + 2.0):  # where the fraction converges fast; else by symmetry
        return math.exp(log_front) * _betacf(a, b, x) / a
    return 1.0 - math.exp(log_front) * _betacf(b, a, 1.0 - x) / b


def sf(t: float, df: float) -> float:
    """P(T > t) for Student's t with df degrees of freedom (df > 0, any real)."""
    if math.isnan(t) or math.isnan(df):
        return math.nan
    tail = 0.5 * betainc(df / 2.0, 0.5, df / (df + t * t)) if math.isfinite(t) else 0.0
    return tail if t >= 0 else 1.0 - tail


@lru_cache(maxsize=256)
def quantile(p: float, df: float) -> float:
    """The t with P(T <= t) = p, for 0.5 <= p < 1 (a sweep asks for 0.975): bisection on ``sf``
    to the last bit of the float; cached, as a sweep asks for few df."""
    target = 1.0 - p
    lo, hi = 0.0, 1.0
    while sf(hi, df) > target:
        lo, hi = hi, hi * 2.0
    while True:
        mid = (lo + hi) / 2.0
        if mid in (lo, hi):
            return hi if abs(sf(hi, df) - target) <= abs(sf(lo, df) - target) else lo
        if sf(mid, df) > target:
            lo = mid
        else:
            hi = mid
