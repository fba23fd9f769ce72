"""Appendix A statistics against independent identities and SciPy."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from snakeplan.bench.statistics import games_howell, levene_p, shapiro_p, welch_anova
from scipy import stats

sample = st.lists(st.floats(-100, 100, allow_nan=False), min_size=3, max_size=12).filter(lambda x: np.ptp(x) > 1e-3)


@settings(max_examples=40, deadline=None)
@given(sample, sample)
def test_two_group_welch_anova_is_welch_t_squared(a, b):
    res = welch_anova([a, b])
    t = stats.ttest_ind(a, b, equal_var=False)
    assert res.f == pytest.approx(t.statistic**2, rel=1e-9)
    assert res.p == pytest.approx(t.pvalue, rel=1e-6, abs=1e-12)


@settings(max_examples=30, deadline=None)
@given(sample, sample)
def test_two_group_games_howell_equals_welch_t_test(a, b):
    (cmp,) = games_howell({"a": a, "b": b})
    t = stats.ttest_ind(a, b, equal_var=False)
    assert cmp.t == pytest.approx(t.statistic, rel=1e-9)
    assert cmp.p_adjusted == pytest.approx(t.pvalue, rel=1e-4, abs=1e-9)


def test_games_howell_adjusts_for_more_groups_and_reference():
    rng = np.random.default_rng(0)
    groups = {"ref": rng.normal(0, 1, 10), "x": rng.normal(1, 2, 10), "y": rng.normal(0.2, 0.5, 10)}
    all_pairs = games_howell(groups)
    assert len(all_pairs) == 3
    vs_ref = games_howell(groups, reference="ref")
    assert [(c.a, c.b) for c in vs_ref] == [("ref", "x"), ("ref", "y")]
    # With three groups the adjusted p-value exceeds the unadjusted Welch t-test's.
    t = stats.ttest_ind(groups["ref"], groups["x"], equal_var=False)
    assert vs_ref[0].p_adjusted > t.pvalue


def test_degenerate_groups_give_nan_not_errors():
    assert math.isnan(welch_anova([[1, 1, 1], [2, 3, 4]]).f)
    assert math.isnan(games_howell({"a": [1.0], "b": [2.0, 3.0]})[0].p_adjusted)
    assert math.isnan(shapiro_p([1, 1, 1, 1]))
    assert math.isnan(levene_p([[1, 1], [2, 2]]))
    assert 0 <= shapiro_p(np.arange(10.0)) <= 1
    assert 0 <= levene_p([[1, 2, 3], [1, 5, 9]]) <= 1
