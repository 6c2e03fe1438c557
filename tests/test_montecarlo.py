"""Monte-Carlo helpers against scipy's independent implementations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from radarfusion_ref.montecarlo import binomial_tolerance, mean, proportion


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 5000), frac=st.floats(0, 1), conf=st.sampled_from([0.8, 0.9, 0.95, 0.99]))
def test_wilson_matches_scipy(n, frac, conf):
    k = round(frac * n)
    ours = proportion(k, n, confidence=conf)
    ref = stats.binomtest(k, n).proportion_ci(confidence_level=conf, method="wilson")
    np.testing.assert_allclose([ours.low, ours.high], [ref.low, ref.high], atol=1e-10)
    assert ours.low <= ours.estimate <= ours.high


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 5000), frac=st.floats(0, 1))
def test_clopper_pearson_matches_scipy(n, frac):
    k = round(frac * n)
    ours = proportion(k, n, method="clopper-pearson")
    ref = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
    np.testing.assert_allclose([ours.low, ours.high], [ref.low, ref.high], atol=1e-10)


def test_vectorised_counts_equal_loop():
    k = np.array([0, 3, 50, 100])
    vec = proportion(k, 100)
    for i, ki in enumerate(k):
        one = proportion(int(ki), 100)
        assert vec.low[i] == pytest.approx(one.low) and vec.high[i] == pytest.approx(one.high)


def test_boolean_trials_on_last_axis():
    hits = np.array([[True, False, True, True], [False, False, False, True]])
    p = proportion(hits, None)
    np.testing.assert_allclose(p.estimate, [0.75, 0.25])
    assert p.trials == 4


def test_wilson_coverage_is_close_to_nominal():
    """Coverage of the 95 % interval over 4000 replications, p = 0.3, n = 200."""
    rng = np.random.default_rng(5)
    reps, n, p = 4000, 200, 0.3
    k = rng.binomial(n, p, size=reps)
    covered = proportion(k, n).contains(p)
    cover = covered.mean()
    tol = binomial_tolerance(0.95, reps)
    assert abs(cover - 0.95) < tol + 0.01


def test_mean_interval_matches_t_distribution():
    x = np.array([1.0, 2.0, 4.0, 7.0, 11.0])
    m = mean(x)
    lo, hi = stats.t.interval(0.95, df=4, loc=x.mean(), scale=stats.sem(x))
    assert (m.low, m.high) == pytest.approx((lo, hi))


def test_mean_along_axis():
    x = np.arange(12.0).reshape(3, 4)
    np.testing.assert_allclose(mean(x, axis=1).estimate, x.mean(axis=1))
    np.testing.assert_allclose(mean(x, axis=0).estimate, x.mean(axis=0))


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((5, 4), {}, "`successes`"),
        ((-1, 4), {}, "`successes`"),
        ((1.5, 4), {}, "`successes`"),
        ((1, 0), {}, "`trials`"),
        ((1, 4), {"confidence": 1.0}, "`confidence`"),
        ((1, 4), {"method": "exact"}, "`method`"),
        ((np.array([1, 2]), None), {}, "`successes`"),
    ],
)
def test_bad_input(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        proportion(*args, **kwargs)


def test_mean_needs_two_samples():
    with pytest.raises(ValueError, match="`samples`"):
        mean([1.0])
    with pytest.raises(ValueError, match="`samples`"):
        mean([1.0, np.nan])


def test_agrees_uses_the_standard_error_of_the_exact_value():
    p = proportion(5_300, 10_000)                # 0.53
    # binomial standard error at 0.5 with n = 10 000 is 0.005: 0.03 is 6 of them
    assert not p.agrees(0.5)
    assert p.agrees(0.5, sigmas=7.0)
    assert proportion(0, 100).agrees(0.0)
    assert not proportion(1, 100).agrees(0.0)


def test_mean_agrees_and_require():
    m = mean(np.array([1.0, 2.0, 3.0, 4.0]))    # 2.5, standard error 0.6455
    assert m.agrees(2.5 + 3 * 0.6455)
    assert not m.agrees(2.5 + 6 * 0.6455)
    from radarfusion_ref.montecarlo import MonteCarloCheckError, require

    require(m, 2.0, "close")
    with pytest.raises(MonteCarloCheckError, match="far: Monte Carlo"):
        require(m, 10.0, "far")
    with pytest.raises(TypeError, match="`estimate`"):
        require(0.5, 0.5, "not an estimate")


def test_format_for_prose():
    p = proportion(np.array([627, 100]), 1000)
    assert p.format(0) == f"0.627 [{p.low[0]:.3f}, {p.high[0]:.3f}]"
    assert proportion(1, 4).format(digits=2).startswith("0.25 [")
