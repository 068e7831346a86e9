"""The batch tables' confidence intervals without SciPy: Student's t (aamsim.metrics.stats) in aggregate.describe."""

from __future__ import annotations

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from aamsim.batch.aggregate import describe
from aamsim.metrics.stats import _central_probability, t_critical

# Two-sided 95 % critical values, from printed tables of Student's t (6 significant digits and more).
TABLE = {1: 12.7062047, 2: 4.30265273, 3: 3.18244631, 4: 2.77644511, 5: 2.57058184, 9: 2.26215716,
         10: 2.22813885, 29: 2.04522964, 30: 2.04227246, 100: 1.98397152}


@pytest.mark.parametrize("df", sorted(TABLE))
def test_975_quantiles_match_the_tables(df):
    assert t_critical(df) == pytest.approx(TABLE[df], abs=5e-8)


def test_closed_forms_by_hand():
    # df = 1 is the Cauchy distribution: P(|T| < t) = 2 atan(t) / pi; df = 2: t / sqrt(2 + t^2).
    assert _central_probability(1.0, 1) == pytest.approx(0.5, abs=1e-15)
    assert _central_probability(3.0, 2) == pytest.approx(3.0 / math.sqrt(11.0), abs=1e-15)
    assert t_critical(1, 0.5) == pytest.approx(1.0, abs=1e-12)  # tan(pi/4)


@given(st.integers(1, 400), st.floats(0.55, 0.9995))
def test_quantile_inverts_the_distribution(df, q):
    t = t_critical(df, 2 * q - 1)
    assert _central_probability(t, df) == pytest.approx(2 * q - 1, abs=1e-12)


def test_large_df_tends_to_the_normal_quantile():
    assert t_critical(100000) == pytest.approx(1.959964, abs=1e-4)


def test_describe_uses_it_and_bad_arguments_are_refused():
    st3 = describe([1.0, 2.0, 3.0])
    assert st3.ci95_high == pytest.approx(2.0 + TABLE[2] * 1.0 / math.sqrt(3.0), abs=1e-7)
    with pytest.raises(ValueError):
        t_critical(3, 1.0)
    with pytest.raises(ValueError):
        t_critical(0)


def test_the_batch_tables_need_no_scipy():
    """With SciPy hidden (as in a base install, which has none), the tables are still made."""
    import subprocess
    import sys

    code = ("import sys\nsys.modules['scipy'] = None\nfrom aamsim.batch.aggregate import describe\n"
            "print(round(describe([1.0, 2.0, 3.0]).ci95_high, 6))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == f"{2.0 + TABLE[2] / math.sqrt(3.0):.6f}"
