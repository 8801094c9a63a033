"""runtime/sweep/student_t.py against scipy.stats, which it replaces in a sweep's comparison: the
95% quantile for every df a sweep of up to 1,000 seeds meets, fractional df, the upper tail, and
Welch's p."""
from __future__ import annotations

import math
import random

import pytest

from labsim.runtime.sweep import student_t
from labsim.runtime.sweep.stats import welch_p


@pytest.fixture(scope="module")
def st():
    """scipy.stats, imported by the first test that asks (in one worker), not at collection in every one:
    its import is a second of CPU."""
    return pytest.importorskip("scipy.stats")


@pytest.mark.parametrize("df", [*range(1, 40), 57, 99, 100, 250, 999, 1000, 0.5, 1.5, 2.7, 13.33, 57.9])
def test_the_quantile_is_scipys(df: float, st) -> None:
    assert student_t.quantile(0.975, df) == pytest.approx(float(st.t.ppf(0.975, df)), rel=1e-12, abs=0)


def test_the_upper_tail_is_scipys(st) -> None:
    for df in (1, 2, 3, 5.5, 9.7, 19, 40.2, 100, 999):
        for t in (0.0, 0.01, 0.5, 1.0, 1.96, 2.5, 4.0, 8.0, 20.0, 100.0, -1.0, -3.0, math.inf):
            assert student_t.sf(t, df) == pytest.approx(float(st.t.sf(t, df)), rel=1e-11, abs=1e-300), (t, df)
    assert math.isnan(student_t.sf(math.nan, 3))


def test_welchs_p_is_scipys(st) -> None:
    rng = random.Random(7)
    for _ in range(200):
        xs = [rng.gauss(0, rng.uniform(0.1, 3)) for _ in range(rng.randint(2, 30))]
        ys = [rng.gauss(rng.uniform(-2, 2), rng.uniform(0.1, 3)) for _ in range(rng.randint(2, 30))]
        expected = float(st.ttest_ind(ys, xs, equal_var=False).pvalue)
        assert welch_p(xs, ys) == pytest.approx(expected, rel=1e-9, abs=1e-300)


def test_a_sweep_imports_no_scipy() -> None:
    import subprocess
    import sys

    code = ("import sys\nfrom labsim.runtime.sweep import driver, pool, stats, output\n"
            "stats.describe([1.0, 2.0, 4.0]); stats.welch('f', 'm', 'a', 'b', [1, 2, 3], [2, 5, 9])\n"
            "print(sorted(m for m in sys.modules if m.split('.')[0] == 'scipy'))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.stdout.strip() == "[]", done.stderr
