"""Tests of radarfusion_ref.fusion: the ML fused estimate (Grachov & Korneev 2010, eqs. (1)-(3)).

Reference values come from independent routes: a sympy derivation written here, the paper's
printed estimate, the two-sensor covariance form, brute-force numerical maximisation of the
log-likelihood (scipy.optimize) and scipy.stats densities. Statistical tests use fixed seeds
and tolerances of 5 standard errors.
"""

from __future__ import annotations

from fractions import Fraction
from functools import reduce
from pathlib import Path

import mpmath
import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from scipy import optimize, stats

from radarfusion_ref.engine.montecarlo import binomial_tolerance
from radarfusion_ref.fusion import (
    VAR_DOMAIN,
    FusedEstimate,
    GaussianFusion,
    fuse,
    fuse_gaussian,
    log_likelihood,
    misweighted,
    sample_reports,
    sample_reports_gaussian,
)

ROOT = Path(__file__).resolve().parents[1]

# ----------------------------------------------------------------------------- strategies

reports_st = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
variances_st = st.floats(1e-3, 1e3, allow_nan=False, allow_infinity=False)


@st.composite
def scalar_problem(draw, *, k_min=1, k_max=6):
    k = draw(st.integers(k_min, k_max))
    x = draw(hnp.arrays(float, k, elements=reports_st))
    var = draw(hnp.arrays(float, k, elements=variances_st))
    return x, var


def random_spd(rng, shape, d, *, floor=0.05):
    a = rng.normal(size=(*shape, d, d))
    return a @ np.swapaxes(a, -1, -2) + floor * np.eye(d)


@st.composite
def gaussian_problem(draw, *, k_max=4, d_max=3):
    k = draw(st.integers(1, k_max))
    d = draw(st.integers(1, d_max))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    return rng.normal(scale=10.0, size=(k, d)), random_spd(rng, (k,), d)


# ----------------------------------------------------------------------------- sympy oracle


@pytest.fixture(scope="module")
def sympy_two_sensor():
    """Derive x~ and its variance from eq. (2) with sympy, independently of the package."""
    x = sp.Symbol("x", real=True)
    x1, x2 = sp.symbols("x1 x2", real=True)
    s1, s2 = sp.symbols("s1 s2", positive=True)

    def pdf(v, s):
        return sp.exp(-(v - x) ** 2 / (2 * s**2)) / (sp.sqrt(2 * sp.pi) * s)

    ell = sp.expand_log(sp.log(pdf(x1, s1) * pdf(x2, s2)), force=True)
    (root,) = sp.solve(sp.diff(ell, x), x)
    fisher = -sp.diff(ell, x, 2)
    return {
        "ell": sp.lambdify((x1, x2, s1, s2, x), ell, "numpy"),
        "estimate": sp.lambdify((x1, x2, s1, s2), root, "numpy"),
        "variance": sp.lambdify((s1, s2), 1 / fisher, "numpy"),
        "root": root,
        "symbols": (x1, x2, s1, s2),
    }


def test_estimate_matches_sympy_root_of_likelihood_equation(sympy_two_sensor):
    rng = np.random.default_rng(1)
    xs, sig = rng.normal(size=(500, 2)), rng.uniform(0.05, 5.0, size=(500, 2))
    r = fuse(xs, sig**2)
    np.testing.assert_allclose(r.estimate, sympy_two_sensor["estimate"](*xs.T, *sig.T),
                               rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(r.variance, sympy_two_sensor["variance"](*sig.T), rtol=1e-12)


def test_paper_printed_estimate_equals_derived_root(sympy_two_sensor):
    x1, x2, s1, s2 = sympy_two_sensor["symbols"]
    printed = (s2**2 * x1 + s1**2 * x2) / (s1**2 + s2**2)   # after eq. (3) of the paper
    assert sp.simplify(sympy_two_sensor["root"] - printed) == 0
    # and numerically with the package
    r = fuse([2.0, 5.0], [0.5**2, 1.5**2])
    assert r.estimate == pytest.approx((1.5**2 * 2.0 + 0.5**2 * 5.0) / (0.5**2 + 1.5**2))


def test_log_likelihood_matches_sympy_and_scipy(sympy_two_sensor):
    rng = np.random.default_rng(2)
    xs, sig, pos = rng.normal(size=(200, 2)), rng.uniform(0.1, 3, (200, 2)), rng.normal(size=200)
    got = log_likelihood(xs, sig**2, pos)
    np.testing.assert_allclose(got, sympy_two_sensor["ell"](*xs.T, *sig.T, pos), rtol=1e-12)
    ref = stats.norm.logpdf(xs, loc=pos[:, None], scale=sig).sum(axis=-1)
    np.testing.assert_allclose(got, ref, rtol=1e-12)


def test_k_sensor_closed_form_from_sympy():
    k = 4
    x = sp.Symbol("x", real=True)
    xs = sp.symbols(f"x1:{k + 1}", real=True)
    ss = sp.symbols(f"s1:{k + 1}", positive=True)
    ell = sum(-(xi - x) ** 2 / (2 * si**2) - sp.log(si) for xi, si in zip(xs, ss, strict=True))
    (root,) = sp.solve(sp.diff(ell, x), x)
    est = sp.lambdify((xs, ss), root, "numpy")
    var = sp.lambdify((ss,), -1 / sp.diff(ell, x, 2), "numpy")
    rng = np.random.default_rng(3)
    X, S = rng.normal(size=(300, k)), rng.uniform(0.1, 4.0, size=(300, k))
    r = fuse(X, S**2)
    np.testing.assert_allclose(r.estimate, est(X.T, S.T), rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.variance, var(S.T), rtol=1e-12)


def test_estimate_maximises_the_log_likelihood_numerically():
    rng = np.random.default_rng(4)
    xs, var = rng.normal(size=5) * 10, rng.uniform(0.1, 9.0, size=5)
    res = optimize.minimize_scalar(lambda p: -log_likelihood(xs, var, p), bracket=(-50, 50),
                                   options={"xtol": 1e-12})
    assert fuse(xs, var).estimate == pytest.approx(res.x, abs=1e-6)
    # curvature of ell = -Fisher information = -1/variance (central difference)
    h, e = 1e-3, fuse(xs, var).estimate
    curv = (log_likelihood(xs, var, e + h) - 2 * log_likelihood(xs, var, e)
            + log_likelihood(xs, var, e - h)) / h**2
    assert -curv == pytest.approx(1 / fuse(xs, var).variance, rel=1e-5)


def test_result_types_and_fields():
    r = fuse([1.0, 2.0], [1.0, 1.0])
    assert isinstance(r, FusedEstimate)
    assert np.ndim(r.estimate) == 0 and np.ndim(r.variance) == 0
    assert r.information == pytest.approx(2.0) and r.std == pytest.approx(np.sqrt(0.5))
    with pytest.raises(AttributeError):
        r.estimate = 0.0  # frozen
    g = fuse_gaussian(np.zeros((2, 3)), np.stack([np.eye(3)] * 2))
    assert isinstance(g, GaussianFusion)
    assert g.estimate.shape == (3,) and g.covariance.shape == (3, 3)
    np.testing.assert_allclose(g.information, 2 * np.eye(3))


def test_single_sensor_is_returned_unchanged():
    r = fuse([3.5], [2.0])
    assert r.estimate == 3.5 and r.variance == 2.0


# ----------------------------------------------------------------------------- properties


@settings(max_examples=100, deadline=None)
@given(scalar_problem(k_min=2))
def test_symmetric_under_permutation_of_sensors(problem):
    x, var = problem
    perm = np.random.default_rng(len(x)).permutation(len(x))
    a, b = fuse(x, var), fuse(x[perm], var[perm])
    assert a.estimate == pytest.approx(b.estimate, rel=1e-12, abs=1e-9)
    assert a.variance == pytest.approx(b.variance, rel=1e-12)
    np.testing.assert_allclose(a.weights[perm], b.weights, rtol=1e-12)


@settings(max_examples=100, deadline=None)
@given(scalar_problem())
def test_estimate_lies_between_reports_and_variance_below_each(problem):
    x, var = problem
    r = fuse(x, var)
    tol = 1e-12 * max(1.0, np.abs(x).max())
    assert x.min() - tol <= r.estimate <= x.max() + tol
    assert r.variance <= var.min() * (1 + 1e-12)
    assert np.all(r.weights > 0)
    assert r.weights.sum() == pytest.approx(1.0)


@settings(max_examples=60, deadline=None)
@given(scalar_problem(k_min=2))
def test_k_sensor_fuse_equals_sequential_pairwise_fusion(problem):
    x, var = problem

    def step(acc, item):
        r = fuse([acc[0], item[0]], [acc[1], item[1]])
        return float(r.estimate), float(r.variance)

    est, v = reduce(step, zip(x[1:], var[1:], strict=True), (x[0], var[0]))
    batch = fuse(x, var)
    assert est == pytest.approx(batch.estimate, rel=1e-9, abs=1e-9 * max(1, np.abs(x).max()))
    assert v == pytest.approx(batch.variance, rel=1e-9)


@settings(max_examples=30, deadline=None)
@given(st.integers(1, 5), st.integers(1, 4), st.integers(0, 2**32 - 1))
def test_scalar_vectorized_equals_loop(k, n, seed):
    rng = np.random.default_rng(seed)
    x, var = rng.normal(size=(n, 3, k)), rng.uniform(0.01, 10, size=(n, 3, k))
    r = fuse(x, var)
    assert r.estimate.shape == (n, 3) and r.weights.shape == (n, 3, k)
    for i in range(n):
        for j in range(3):
            one = fuse(x[i, j], var[i, j])
            assert r.estimate[i, j] == pytest.approx(one.estimate, rel=1e-13, abs=1e-15)
            assert r.variance[i, j] == pytest.approx(one.variance, rel=1e-13)


def test_scalar_broadcasting_of_variances():
    x = np.arange(12.0).reshape(4, 3)
    np.testing.assert_allclose(fuse(x, [1.0, 2.0, 3.0]).estimate,
                               [fuse(row, [1.0, 2.0, 3.0]).estimate for row in x])
    np.testing.assert_allclose(fuse(x, 2.0).estimate, x.mean(axis=-1))


@settings(max_examples=60, deadline=None)
@given(gaussian_problem())
def test_gaussian_agrees_with_brute_force_ml(problem):
    """Independent route: maximise the log-likelihood numerically and take its Hessian."""
    x, cov = problem
    d = x.shape[-1]
    r = fuse_gaussian(x, cov)

    def negll(p):
        return 0.5 * sum(float((xi - p) @ np.linalg.solve(ci, xi - p)) for xi, ci in zip(x, cov, strict=True))

    res = optimize.minimize(negll, x.mean(axis=0), method="BFGS", options={"gtol": 1e-10})
    scale = max(1.0, np.abs(x).max())
    np.testing.assert_allclose(r.estimate, res.x, atol=1e-4 * scale)
    # Fisher information = sum of the precisions (minus the Hessian of the log-likelihood):
    info = sum(np.linalg.solve(ci, np.eye(d)) for ci in cov)
    np.testing.assert_allclose(r.information, info, rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(r.covariance @ info, np.eye(d), atol=1e-8)


@settings(max_examples=60, deadline=None)
@given(gaussian_problem(k_max=2))
def test_gaussian_two_sensor_covariance_form_and_symmetry(problem):
    x, cov = problem
    if len(x) == 1:
        x, cov = np.concatenate([x, x + 1.0]), np.concatenate([cov, 2 * cov])
    r = fuse_gaussian(x, cov)
    s = cov[0] + cov[1]
    gain = np.linalg.solve(s, cov[0]).T                     # C1 (C1 + C2)^{-1}
    np.testing.assert_allclose(r.estimate, x[0] + gain @ (x[1] - x[0]), rtol=1e-7,
                               atol=1e-7 * max(1, np.abs(x).max()))
    np.testing.assert_allclose(r.covariance, cov[0] - gain @ cov[0], rtol=1e-7, atol=1e-9)
    swapped = fuse_gaussian(x[::-1], cov[::-1])
    np.testing.assert_allclose(swapped.estimate, r.estimate, rtol=1e-9,
                               atol=1e-9 * max(1, np.abs(x).max()))
    np.testing.assert_allclose(swapped.covariance, r.covariance, rtol=1e-9, atol=1e-12)
    # P is symmetric and below each C_i in the Loewner order
    np.testing.assert_array_equal(r.covariance, r.covariance.T)
    for c in cov:
        assert np.linalg.eigvalsh(c - r.covariance).min() > -1e-9 * np.abs(c).max()


@settings(max_examples=20, deadline=None)
@given(st.integers(1, 3), st.integers(1, 3), st.integers(0, 2**32 - 1))
def test_gaussian_vectorized_equals_loop_and_broadcasts(k, d, seed):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(4, 2, k, d))
    cov = random_spd(rng, (2, k), d)            # broadcast over the first batch axis
    r = fuse_gaussian(x, cov)
    assert r.estimate.shape == (4, 2, d) and r.covariance.shape == (4, 2, d, d)
    for i in range(4):
        for j in range(2):
            one = fuse_gaussian(x[i, j], cov[j])
            np.testing.assert_allclose(r.estimate[i, j], one.estimate, rtol=1e-12, atol=1e-13)
            np.testing.assert_allclose(r.covariance[i, j], one.covariance, rtol=1e-12)


def test_gaussian_reduces_to_scalar_fuse():
    rng = np.random.default_rng(5)
    x, var = rng.normal(size=(50, 3)), rng.uniform(0.1, 4, size=(50, 3))
    g = fuse_gaussian(x[..., None], var[..., None, None])
    s = fuse(x, var)
    np.testing.assert_allclose(g.estimate[..., 0], s.estimate, rtol=1e-12)
    np.testing.assert_allclose(g.covariance[..., 0, 0], s.variance, rtol=1e-12)
    # diagonal covariances fuse coordinate by coordinate
    xv, dv = rng.normal(size=(3, 2)), rng.uniform(0.1, 4, size=(3, 2))
    g2 = fuse_gaussian(xv, np.stack([np.diag(v) for v in dv]))
    np.testing.assert_allclose(g2.estimate, fuse(xv.T, dv.T).estimate, rtol=1e-12)


def test_gaussian_ill_conditioned_covariances_stay_accurate():
    # long thin ellipses at right angles: condition number 1e8 each
    c1 = np.diag([1e-4, 1e4])
    c2 = np.diag([1e4, 1e-4])
    r = fuse_gaussian([[1.0, 2.0], [3.0, 4.0]], [c1, c2])
    np.testing.assert_allclose(r.estimate, [1.0 + 2.0 * 1e-4 / (1e4 + 1e-4),
                                            4.0 - 2.0 * 1e-4 / (1e4 + 1e-4)], rtol=1e-10)
    np.testing.assert_allclose(np.diag(r.covariance), [1 / (1e4 + 1e-4)] * 2, rtol=1e-10)


# ----------------------------------------------------------------------------- mis-weighting


def test_misweighted_matches_sympy():
    s1, s2, a1, a2 = sp.symbols("s1 s2 a1 a2", positive=True)
    w1 = a2 / (a1 + a2)
    actual = sp.lambdify((s1, s2, a1, a2), w1**2 * s1**2 + (1 - w1) ** 2 * s2**2, "numpy")
    rng = np.random.default_rng(6)
    sig, a = rng.uniform(0.1, 3, size=(100, 2)), rng.uniform(0.01, 10, size=(100, 2))
    m = misweighted(sig**2, a)
    np.testing.assert_allclose(m.actual_variance, actual(*sig.T, *a.T), rtol=1e-12)
    np.testing.assert_allclose(m.reported_variance, a.prod(-1) / a.sum(-1), rtol=1e-12)


@settings(max_examples=100, deadline=None)
@given(hnp.arrays(float, st.integers(1, 5), elements=variances_st), st.floats(1e-3, 1e3),
       st.integers(0, 2**32 - 1))
def test_misweighting_efficiency_bounded_and_scale_invariant(var, scale, seed):
    m = misweighted(var, scale * var)                       # proportional: no loss
    assert m.efficiency == pytest.approx(1.0, rel=1e-9)
    assert m.consistency == pytest.approx(scale, rel=1e-9)
    wrong = np.random.default_rng(seed).uniform(1e-3, 1e3, size=var.shape)
    assert misweighted(var, wrong).efficiency <= 1.0 + 1e-12


def test_misweighted_estimate_is_fuse_with_assumed_variances():
    rng = np.random.default_rng(7)
    var, assumed = np.array([1.0, 4.0, 9.0]), np.array([2.0, 1.0, 30.0])
    x = rng.normal(size=3)
    np.testing.assert_allclose(misweighted(var, assumed).weights, fuse(x, assumed).weights)


# ----------------------------------------------------------------------------- Monte Carlo


def test_monte_carlo_unbiased_and_at_the_bound():
    trials = 200_000
    var = np.array([1.0, 4.0, 0.25])
    reports = sample_reports(2.0, var, trials=trials, rng=20101)
    err = fuse(reports, var).estimate - 2.0
    bound = 1.0 / np.sum(1.0 / var)
    se_mean = np.sqrt(bound / trials)
    assert abs(err.mean()) < 5 * se_mean
    se_var = bound * np.sqrt(2.0 / trials)                  # Var of a chi^2_1 mean
    assert abs(np.mean(err**2) - bound) < 5 * se_var
    inside = np.mean(np.abs(err) <= stats.norm.ppf(0.975) * np.sqrt(bound))
    assert abs(inside - 0.95) < binomial_tolerance(0.95, trials)


def test_monte_carlo_misweighted_variance():
    trials = 200_000
    var, assumed = np.array([1.0, 4.0]), np.array([1.0, 0.25])
    reports = sample_reports(0.0, var, trials=trials, rng=7)
    err = fuse(reports, assumed).estimate
    exact = misweighted(var, assumed).actual_variance
    assert abs(np.mean(err**2) - exact) < 5 * exact * np.sqrt(2.0 / trials)


def test_monte_carlo_gaussian_covariance_and_coverage():
    trials = 100_000
    rng = np.random.default_rng(8)
    cov = random_spd(rng, (3,), 2, floor=0.1)
    truth = np.array([10.0, -5.0])
    reports = sample_reports_gaussian(truth, cov, trials=trials, rng=rng)
    r = fuse_gaussian(reports, cov)
    err = r.estimate - truth
    P = r.covariance[0]
    emp = np.cov(err.T)
    se = np.sqrt((P**2 + np.outer(np.diag(P), np.diag(P))) / trials)  # Wishart entry s.e.
    np.testing.assert_array_less(np.abs(emp - P), 5 * se)
    q = np.einsum("ti,ij,tj->t", err, r.information[0], err)
    inside = np.mean(q <= stats.chi2.ppf(0.9, df=2))
    assert abs(inside - 0.9) < binomial_tolerance(0.9, trials)


def test_samplers_shapes_moments_and_determinism():
    a = sample_reports(np.zeros(4), [1.0, 9.0], trials=50_000, rng=3)
    assert a.shape == (50_000, 4, 2)
    np.testing.assert_allclose(a.var(axis=(0, 1)), [1.0, 9.0], rtol=0.03)
    np.testing.assert_array_equal(a, sample_reports(np.zeros(4), [1.0, 9.0], trials=50_000, rng=3))
    c = np.array([[2.0, 0.5], [0.5, 1.0]])
    b = sample_reports_gaussian([1.0, 2.0], c[None], trials=50_000, rng=4)
    assert b.shape == (50_000, 1, 2)
    np.testing.assert_allclose(np.cov(b[:, 0].T), c, atol=0.05)


# ----------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("var", [[1.0, 0.0], [1.0, -2.0], [1.0, np.nan], [np.inf, 1.0]])
def test_fuse_rejects_bad_variances(var):
    with pytest.raises(ValueError, match="`var`"):
        fuse([1.0, 2.0], var)


@pytest.mark.parametrize("x", [[1.0, np.nan], [np.inf, 0.0]])
def test_fuse_rejects_nonfinite_reports(x):
    with pytest.raises(ValueError, match="`x`"):
        fuse(x, [1.0, 1.0])


def test_fuse_rejects_shape_mismatch_and_empty_and_non_numeric():
    with pytest.raises(ValueError, match="`x`, `var`"):
        fuse([1.0, 2.0, 3.0], [1.0, 2.0])
    with pytest.raises(ValueError, match="`x`"):
        fuse(np.zeros((3, 0)), 1.0)
    with pytest.raises(ValueError, match="`x`"):
        fuse(1.0, 1.0)                                      # no sensor axis
    with pytest.raises(TypeError, match="`x`"):
        fuse("abc", 1.0)


def test_variances_too_small_to_invert_are_refused_not_nan():
    with pytest.raises(ValueError, match=r"`var` must have every variance within the numeric"):
        fuse([1.0, 2.0], [1e-320, 1.0])
    with pytest.raises(ValueError, match=r"`var_assumed` must have every variance within"):
        misweighted([1.0, 2.0], [1e-320, 1.0])
    # fuse_gaussian takes any variance a float holds (it rescales exactly): a fused
    # information that overflows is refused by name
    with pytest.raises(ValueError, match=r"`cov`.*singular"), np.errstate(over="ignore"):
        fuse_gaussian([[0.0, 0.0], [1.0, 1.0]], [1e-310 * np.eye(2), np.eye(2)])
    r = fuse([1.0, 2.0], [1e-300, 1.0])                     # tiny but invertible: fine
    assert np.isfinite(r.estimate) and r.estimate == pytest.approx(1.0)


def test_fuse_gaussian_rejects_bad_covariances():
    x = np.zeros((2, 2))
    good = np.stack([np.eye(2)] * 2)
    not_pd = good.copy()
    not_pd[1] = [[1.0, 2.0], [2.0, 1.0]]
    with pytest.raises(ValueError, match=r"`cov`.*positive definite"):
        fuse_gaussian(x, not_pd)
    asym = good.copy()
    asym[0, 0, 1] = 0.5
    with pytest.raises(ValueError, match=r"`cov`.*symmetric"):
        fuse_gaussian(x, asym)
    nan = good.copy()
    nan[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="`cov`"):
        fuse_gaussian(x, nan)
    with pytest.raises(ValueError, match="`cov`"):
        fuse_gaussian(x, np.zeros((2, 2, 2)))


def test_fuse_gaussian_rejects_shape_mismatch():
    with pytest.raises(ValueError, match="`cov`"):
        fuse_gaussian(np.zeros((2, 3)), np.stack([np.eye(2)] * 2))         # d mismatch
    with pytest.raises(ValueError, match=r"`x`.*`cov`"):
        fuse_gaussian(np.zeros((3, 2)), np.stack([np.eye(2)] * 2))         # k mismatch
    with pytest.raises(ValueError, match="`x`"):
        fuse_gaussian(np.zeros(2), np.eye(2)[None])                        # no sensor axis
    with pytest.raises(ValueError, match="`cov`"):
        fuse_gaussian(np.zeros((2, 2)), np.eye(2))                         # no sensor axis
    with pytest.raises(ValueError, match="`x`"):
        fuse_gaussian([[0.0, np.nan]], np.eye(2)[None])


def test_other_entry_points_reject_bad_input():
    with pytest.raises(ValueError, match="`var_assumed`"):
        misweighted([1.0, 2.0], [1.0, 0.0])
    with pytest.raises(ValueError, match="`var_true`"):
        misweighted([-1.0, 2.0], [1.0, 1.0])
    with pytest.raises(ValueError, match="`position`"):
        log_likelihood(np.zeros((3, 2)), 1.0, np.zeros(4))
    with pytest.raises(ValueError, match="`trials`"):
        sample_reports(0.0, [1.0], trials=0)
    with pytest.raises(ValueError, match="`var`"):
        sample_reports(0.0, [1.0, -1.0], trials=3)
    with pytest.raises(TypeError, match="`rng`"):
        sample_reports(0.0, [1.0], trials=3, rng=np.random.RandomState(0))
    with pytest.raises(ValueError, match=r"`cov`.*positive definite"):
        sample_reports_gaussian([0.0, 0.0], -np.eye(2)[None], trials=3)
    with pytest.raises(ValueError, match="`cov`"):
        sample_reports_gaussian([0.0, 0.0, 0.0], np.eye(2)[None], trials=3)


# ----------------------------------------------------------------------------- the chapter


# ============================================================================= issue 12: trust
# The whole float range, against independent routes (exact rational arithmetic with
# fractions.Fraction, and mpmath at 60 digits with an unbounded exponent), and a fuzz suite
# of invalid input: every public function refuses it with an error naming the argument.

EPS = np.finfo(float).eps
TINY = np.finfo(float).tiny
BIG = np.finfo(float).max


def wide_floats(lo_exp, hi_exp, *, signed=False):
    """Floats m * 10^e with m in [1, 10) and e in [lo_exp, hi_exp]: the whole float range."""
    mant = st.floats(1.0, 9.999, allow_nan=False, allow_infinity=False)
    sign = st.sampled_from([-1.0, 1.0]) if signed else st.just(1.0)
    return st.builds(lambda s, m, e: s * float(Fraction(m) * Fraction(10) ** e), sign, mant,
                     st.integers(lo_exp, hi_exp)).filter(lambda v: v != 0 and np.isfinite(v))


@st.composite
def wide_scalar_problem(draw, *, var_lo=-320, var_hi=307, x_hi=307):
    m = draw(st.integers(1, 5))
    x = np.array(draw(st.lists(st.one_of(wide_floats(-300, x_hi, signed=True), st.just(0.0)),
                               min_size=m, max_size=m)))
    var = np.array(draw(st.lists(wide_floats(var_lo, var_hi), min_size=m, max_size=m)))
    return x, var


def exact_fuse(x, var):
    """Eqs. (eq-fused-estimate), (eq-fused-variance) in exact rational arithmetic."""
    info = [1 / Fraction(float(v)) for v in var]
    total = sum(info)
    weights = [i / total for i in info]
    return (sum(w * Fraction(float(a)) for w, a in zip(weights, x, strict=True)),
            1 / total, weights)


@given(wide_scalar_problem())
def test_fuse_inside_its_domain_against_exact_arithmetic_refused_outside(problem):
    x, var = problem
    lo, hi = VAR_DOMAIN
    if var.min() < lo or var.max() > hi:
        with pytest.raises(ValueError, match="`var` must have every variance within"):
            fuse(x, var)
        return
    if np.abs(x).max() > hi:
        with pytest.raises(ValueError, match="`x` must have every report's magnitude within"):
            fuse(x, var)
        return
    est, variance, weights = exact_fuse(x, var)
    r = fuse(x, var)
    m = len(x)
    assert np.isfinite(r.estimate) and np.isfinite(r.variance) and np.all(np.isfinite(r.weights))
    assert abs(float(r.variance) - float(variance)) <= 4 * m * EPS * float(variance)
    assert abs(Fraction(float(r.estimate)) - est) <= Fraction(8 * m * EPS * np.abs(x).max())
    for got, want in zip(r.weights, weights, strict=True):
        assert abs(Fraction(float(got)) - want) <= Fraction(4 * m * EPS) * want + Fraction(1e-300)
    assert np.isfinite(r.information) and r.information > 0


@given(wide_scalar_problem(var_lo=-300, var_hi=300, x_hi=300))
def test_fuse_invariants_over_its_domain(problem):
    x, var = problem
    r = fuse(x, var)
    m = len(x)
    assert abs(r.weights.sum() - 1.0) <= 2 * m * EPS             # weights sum to 1
    assert np.all(r.weights >= 0)
    assert r.variance <= var.min() * (1 + 2 * EPS)               # 1 / (1 / v): two roundings
    spread = 8 * m * EPS * np.abs(x).max()
    assert x.min() - spread <= r.estimate <= x.max() + spread    # between the reports


@given(wide_scalar_problem(var_lo=-300, var_hi=300, x_hi=300), st.integers(-300, 300))
def test_fuse_is_equivariant_under_a_common_scale_of_the_variances(problem, e):
    x, var = problem
    c = 2.0 ** max(-900, min(900, int(e * 3.3)))                 # exact power of two
    with np.errstate(over="ignore", under="ignore"):
        scaled = var * c
    a = fuse(x, var)
    if not (scaled.min() >= VAR_DOMAIN[0] and scaled.max() <= VAR_DOMAIN[1]):
        with pytest.raises(ValueError, match="`var` must"):  # beyond the domain, inf or 0
            fuse(x, scaled)
        return
    b = fuse(x, scaled)
    np.testing.assert_array_equal(a.weights, b.weights)
    assert a.estimate == b.estimate
    assert b.variance == pytest.approx(a.variance * c, rel=4 * EPS)


def test_fuse_cases_near_the_domain_edges():
    for v in ([1e-300, 1e-300], [1e-300, 1e300], [1e300, 1e300], [2.0**-1000, 2.0**1000]):
        x = [1.0, 2.0]
        r = fuse(x, v)
        est, variance, _ = exact_fuse(x, v)
        assert float(r.variance) == pytest.approx(float(variance), rel=1e-15)
        assert float(r.estimate) == pytest.approx(float(est), rel=1e-15)
        assert r.weights.sum() == pytest.approx(1.0, rel=1e-15)
    # beyond the domain: refused with the argument's name, never a variance of 0 or inf
    for v in ([1e308, 1e308], [5e-308, 5e-308], [1e-308, 1e-308, 1e-308]):
        with pytest.raises(ValueError, match="`var` must have every variance within"):
            fuse(np.arange(len(v), dtype=float), v)
    with pytest.raises(ValueError, match="`x` must have every report's magnitude within"):
        fuse([1.5e308, 1.6e308], [1.0, 1.0])
    edge = fuse([2.0**1000, -(2.0**1000)], [1.0, 3.0])         # reports at the domain's edge
    assert edge.estimate == 2.0**999


def _mp_log_likelihood(x, var, position):
    with mpmath.workdps(60):
        return sum(-(mpmath.log(2 * mpmath.pi) + mpmath.log(mpmath.mpf(float(v)))
                     + (mpmath.mpf(float(a)) - mpmath.mpf(float(position))) ** 2
                     / mpmath.mpf(float(v))) / 2 for a, v in zip(x, var, strict=True))


@given(wide_scalar_problem(var_lo=-300), st.one_of(wide_floats(-300, 307, signed=True),
                                                 st.just(0.0)))
def test_log_likelihood_over_the_whole_float_range_against_mpmath(problem, position):
    x, var = problem
    exact = _mp_log_likelihood(x, var, position)
    if exact < -mpmath.mpf(BIG) * (1 + mpmath.mpf(1e-12)):
        with pytest.raises(ValueError, match="`position`"):
            log_likelihood(x, var, position)
        return
    if exact < -mpmath.mpf(BIG) * (1 - mpmath.mpf(1e-12)):
        return
    got = log_likelihood(x, var, position)
    assert np.isfinite(got)
    with mpmath.workdps(60):
        scale = sum(abs(mpmath.log(mpmath.mpf(float(v)))) + 2 for v in var) + abs(exact)
        assert abs(mpmath.mpf(float(got)) - exact) <= 16 * len(x) * EPS * scale


def _mp_fuse_gaussian(x, cov):
    with mpmath.workdps(60):
        mats = [mpmath.matrix(c.tolist()) for c in cov]
        precisions = [mpmath.inverse(c) for c in mats]
        info = precisions[0]
        for p in precisions[1:]:
            info = info + p
        y = precisions[0] * mpmath.matrix(x[0].tolist())
        for p, xi in zip(precisions[1:], x[1:], strict=True):
            y = y + p * mpmath.matrix(xi.tolist())
        cov_f = mpmath.inverse(info)
        est = cov_f * y
        return est, cov_f, info


@st.composite
def wide_gaussian_problem(draw):
    m, d = draw(st.integers(1, 3)), draw(st.integers(1, 3))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    scales = [10.0 ** draw(st.integers(-300, 300)) for _ in range(m)]
    x_scale = 10.0 ** draw(st.integers(-300, 300))
    base = random_spd(rng, (m,), d, floor=0.2)
    cov = np.stack([s * b for s, b in zip(scales, base, strict=True)])
    cov = (cov + np.swapaxes(cov, -1, -2)) / 2
    return rng.normal(size=(m, d)) * x_scale, cov


@given(wide_gaussian_problem())
def test_fuse_gaussian_over_the_whole_float_range_against_mpmath(problem):
    x, cov = problem
    r = fuse_gaussian(x, cov)
    est, cov_f, info = _mp_fuse_gaussian(x, cov)
    d = x.shape[-1]
    assert np.all(np.isfinite(r.estimate)) and np.all(np.isfinite(r.covariance))
    xmax = np.abs(x).max()
    for j in range(d):
        assert abs(r.estimate[j] - float(est[j])) <= 1e-9 * xmax + 1e-300
        for k in range(d):
            scale_p = float(mpmath.sqrt(cov_f[j, j] * cov_f[k, k]))
            scale_y = float(mpmath.sqrt(info[j, j] * info[k, k]))
            assert abs(r.covariance[j, k] - float(cov_f[j, k])) <= 1e-9 * scale_p
            assert abs(r.information[j, k] - float(info[j, k])) <= 1e-9 * scale_y
    # the fused covariance is below each sensor's, in the Loewner order (relative to scale)
    for c in cov:
        scale = np.abs(c).max()
        assert np.linalg.eigvalsh(c / scale - r.covariance / scale).min() > -1e-9


def test_fuse_gaussian_refuses_beyond_the_float_range():
    with pytest.raises(ValueError, match=r"`cov`.*singular"):
        fuse_gaussian(np.zeros((3, 2)), np.stack([1e-308 * np.eye(2)] * 3))
    r = fuse_gaussian(np.zeros((2, 2)), np.stack([1e-300 * np.eye(2), 1e300 * np.eye(2)]))
    np.testing.assert_allclose(r.covariance, 1e-300 * np.eye(2), rtol=1e-15)


@given(st.lists(wide_floats(-290, 290), min_size=1, max_size=5), st.integers(0, 2**32 - 1))
def test_misweighted_over_its_domain_against_exact_arithmetic(var_true, seed):
    var_true = np.array(var_true)
    rng = np.random.default_rng(seed)
    var_assumed = var_true * 10.0 ** rng.integers(-5, 6, size=var_true.shape)
    m = misweighted(var_true, var_assumed)
    info_a = [1 / Fraction(float(a)) for a in var_assumed]
    w = [i / sum(info_a) for i in info_a]
    actual = sum(wi**2 * Fraction(float(v)) for wi, v in zip(w, var_true, strict=True))
    bound = 1 / sum(1 / Fraction(float(v)) for v in var_true)
    n = len(var_true)
    assert float(m.actual_variance) == pytest.approx(float(actual), rel=8 * n * EPS)
    assert float(m.bound) == pytest.approx(float(bound), rel=8 * n * EPS)
    assert float(m.reported_variance) == pytest.approx(float(1 / sum(info_a)), rel=8 * n * EPS)
    assert abs(m.weights.sum() - 1.0) <= 2 * n * EPS
    assert m.efficiency <= 1.0 + 8 * n * EPS                      # no weighting beats the bound
    assert np.isfinite(m.consistency) and m.consistency > 0


def test_log_likelihood_refuses_below_the_float_range():
    with pytest.raises(ValueError, match="`position`"):
        log_likelihood([1e300, -1e300], [1e-300, 1e-300], 0.0)
    x, var = [1e308, -1e308], [1.7e308, 1.7e308]          # near the edge, still representable
    got = log_likelihood(x, var, 0.0)
    assert float(got) == pytest.approx(float(_mp_log_likelihood(x, var, 0.0)), rel=1e-14)


def test_misweighted_refuses_ratios_beyond_the_float_range():
    m = misweighted([1e-300, 1e300], [1e300, 1e-300])
    assert np.isfinite(m.actual_variance)
    with pytest.raises(ValueError, match="efficiency"):
        _ = m.efficiency


# ----------------------------------------------------------------------------- samplers: range,
# limits, reproducibility


def test_samplers_refuse_runaway_sizes_before_allocating():
    with pytest.raises(ValueError, match=r"refused.*`trials`"):
        sample_reports(0.0, [1.0, 1.0], trials=10**9)
    with pytest.raises(ValueError, match=r"refused.*`trials`"):
        sample_reports_gaussian([0.0, 0.0], np.eye(2)[None], trials=10**9)


def test_samplers_stay_finite_at_the_ends_of_the_float_range():
    a = sample_reports([1.7e308, -1.7e308, 1e-300], [1e308, 1e308, 1e-300], trials=1000, rng=0)
    assert np.all(np.isfinite(a))
    assert np.std(a[:, 2, 2]) == pytest.approx(1e-150, rel=0.1)
    b = sample_reports_gaussian([1.7e308, 0.0], 1e308 * np.eye(2)[None], trials=1000, rng=0)
    assert np.all(np.isfinite(b))
    c = sample_reports_gaussian([0.0, 0.0], 1e-300 * np.eye(2)[None], trials=1000, rng=0)
    assert np.std(c) == pytest.approx(1e-150, rel=0.1)


@given(st.integers(0, 2**32 - 1), st.integers(1, 50))
def test_samplers_are_reproducible_from_a_seed(seed, trials):
    a = sample_reports([0.0, 1.0], [1.0, 2.0], trials=trials, rng=seed)
    b = sample_reports([0.0, 1.0], [1.0, 2.0], trials=trials, rng=np.random.default_rng(seed))
    np.testing.assert_array_equal(a, b)
    assert np.all(np.isfinite(a)) and a.shape == (trials, 2, 2)
    c = sample_reports_gaussian([0.0, 0.0], np.eye(2)[None], trials=trials, rng=seed)
    np.testing.assert_array_equal(
        c, sample_reports_gaussian([0.0, 0.0], np.eye(2)[None], trials=trials, rng=seed))


# ----------------------------------------------------------------------------- bad-input fuzz

GOOD_CALLS = {
    "fuse": (fuse, {"x": [1.0, 2.0], "var": [1.0, 4.0]}),
    "log_likelihood": (log_likelihood, {"x": [1.0, 2.0], "var": [1.0, 4.0], "position": 0.5}),
    "misweighted": (misweighted, {"var_true": [1.0, 4.0], "var_assumed": [2.0, 1.0]}),
    "fuse_gaussian": (fuse_gaussian, {"x": [[0.0, 0.0], [1.0, 1.0]],
                                      "cov": [np.eye(2).tolist(), (2 * np.eye(2)).tolist()]}),
    "sample_reports": (sample_reports, {"truth": 0.0, "var": [1.0, 4.0], "trials": 3, "rng": 0}),
    "sample_reports_gaussian": (sample_reports_gaussian,
                                {"truth": [0.0, 0.0], "cov": [np.eye(2).tolist()], "trials": 3,
                                 "rng": 0}),
}
#: Arguments whose entries must be positive variances.
POSITIVE = {("fuse", "var"), ("log_likelihood", "var"), ("misweighted", "var_true"),
            ("misweighted", "var_assumed"), ("sample_reports", "var")}
ARRAY_ARGS = [(f, a) for f, (_, kw) in GOOD_CALLS.items() for a in kw
              if a not in ("trials", "rng")]
NOT_NUMBERS = [None, "1.5", "abc", True, np.bool_(False), object(), {"a": 1}, 1 + 2j]
NON_FINITE = [np.nan, np.inf, -np.inf]


def _expect_named_error(func, kwargs, name):
    with pytest.raises((ValueError, TypeError)) as info:
        func(**kwargs)
    assert f"`{name}`" in str(info.value), str(info.value)


@pytest.mark.parametrize(("fname", "arg"), ARRAY_ARGS)
@pytest.mark.parametrize("bad", NOT_NUMBERS, ids=repr)
def test_non_numbers_are_refused_naming_the_argument(fname, arg, bad):
    func, good = GOOD_CALLS[fname]
    _expect_named_error(func, {**good, arg: bad}, arg)


@given(st.sampled_from(ARRAY_ARGS), st.sampled_from([*NON_FINITE, 0.0, -1.0, -1e-300, -1e300]),
       st.integers(0, 100))
def test_poisoned_entries_are_refused_naming_the_argument(case, bad, where):
    """One entry of a valid array replaced by NaN/inf (anywhere) or a non-positive number
    (where a variance is expected, or on a covariance's diagonal)."""
    fname, arg = case
    func, good = GOOD_CALLS[fname]
    value = np.array(good[arg], dtype=float)
    finite_bad = np.isfinite(bad)
    if finite_bad and (fname, arg) not in POSITIVE and arg != "cov":
        return                                    # a negative report or position is valid
    if arg == "cov":
        flat = value.reshape(-1, value.shape[-1], value.shape[-1])
        i = where % flat.shape[0]
        j = (where // flat.shape[0]) % flat.shape[-1]
        flat[i, j, j] = bad                        # a diagonal entry: not positive definite
        value = flat.reshape(value.shape)
    else:
        flat = value.reshape(-1)
        flat[where % flat.size] = bad
        value = flat.reshape(value.shape)
    _expect_named_error(func, {**good, arg: value}, arg)


@pytest.mark.parametrize("bad", [0, -1, 1.5, True, "3", None, 10**12])
@pytest.mark.parametrize("fname", ["sample_reports", "sample_reports_gaussian"])
def test_bad_trials_are_refused(fname, bad):
    func, good = GOOD_CALLS[fname]
    _expect_named_error(func, {**good, "trials": bad}, "trials")


@pytest.mark.parametrize("bad", ["abc", 1.5, np.random.RandomState(0), [1.0, "a"]])
@pytest.mark.parametrize("fname", ["sample_reports", "sample_reports_gaussian"])
def test_bad_rng_is_refused(fname, bad):
    func, good = GOOD_CALLS[fname]
    _expect_named_error(func, {**good, "rng": bad}, "rng")


BAD_COVARIANCES = {
    "not symmetric": [[1.0, 0.5], [0.0, 1.0]],
    "negative definite": [[-1.0, 0.0], [0.0, -1.0]],
    "indefinite": [[1.0, 2.0], [2.0, 1.0]],
    "singular": [[1.0, 1.0], [1.0, 1.0]],
    "zero": [[0.0, 0.0], [0.0, 0.0]],
    "wrong size": np.eye(3).tolist(),
    "not square": [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
}


@pytest.mark.parametrize("fname", ["fuse_gaussian", "sample_reports_gaussian"])
@pytest.mark.parametrize("kind", sorted(BAD_COVARIANCES))
def test_bad_covariances_are_refused(fname, kind):
    func, good = GOOD_CALLS[fname]
    cov = [BAD_COVARIANCES[kind]] * len(good["cov"])
    _expect_named_error(func, {**good, "cov": cov}, "cov")


@pytest.mark.parametrize(("fname", "kwargs", "name"), [
    ("fuse", {"x": [], "var": []}, "x"),
    ("fuse", {"x": [1.0, 2.0, 3.0], "var": [1.0, 2.0]}, "var"),
    ("fuse", {"x": 1.0, "var": 1.0}, "x"),
    ("log_likelihood", {"x": np.zeros((3, 2)), "var": 1.0, "position": np.zeros(4)}, "position"),
    ("misweighted", {"var_true": [1.0, 2.0], "var_assumed": [1.0, 2.0, 3.0]}, "var_assumed"),
    ("misweighted", {"var_true": 1.0, "var_assumed": 1.0}, "var_true"),
    ("misweighted", {"var_true": [], "var_assumed": []}, "var_true"),
    ("fuse_gaussian", {"x": np.zeros((0, 2)), "cov": np.zeros((0, 2, 2))}, "x"),
    ("fuse_gaussian", {"x": np.zeros((3, 2)), "cov": np.stack([np.eye(2)] * 2)}, "x"),
    ("fuse_gaussian", {"x": np.zeros(2), "cov": np.eye(2)[None]}, "x"),
    ("sample_reports", {"truth": 0.0, "var": 1.0, "trials": 3}, "var"),
    ("sample_reports", {"truth": [0.0, 1.0, 2.0], "var": [[1.0], [2.0]], "trials": 3}, "truth"),
    ("sample_reports_gaussian", {"truth": [0.0, 0.0, 0.0], "cov": np.eye(2)[None],
                                 "trials": 3}, "cov"),
])
def test_shape_mismatches_and_empty_input_are_refused(fname, kwargs, name):
    _expect_named_error(GOOD_CALLS[fname][0], kwargs, name)


def test_good_calls_are_good():
    """The fuzz suite's templates are valid: each failure above is due to its one change."""
    for func, kwargs in GOOD_CALLS.values():
        func(**kwargs)
