"""Tests of radarfusion_ref.proximity.

Oracles: a sympy derivation of eq. (4) written here (the ML estimate
substituted into the likelihood (2)), scipy.stats.multivariate_normal log
densities, scipy.spatial.distance.mahalanobis, numerical integration of the
likelihood over x (the marginal), and Monte Carlo with standard-error
tolerances.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, stats
from scipy.spatial import distance

from radarfusion_ref import proximity as px
from radarfusion_ref.engine.montecarlo import binomial_tolerance

coords = st.floats(min_value=-1e3, max_value=1e3)
variances = st.floats(min_value=1e-3, max_value=1e3)


def _random_spd(rng, d, batch=()):
    a = rng.standard_normal((*batch, d, d))
    return a @ np.swapaxes(a, -1, -2) + 0.3 * np.eye(d)


# ------------------------------------------------------------ sympy oracle
@pytest.fixture(scope="module")
def sympy_profile():
    """ln f*_k derived from (2) by solving the likelihood equation (3)."""
    x, x1, x2 = sp.symbols("x x1 x2", real=True)
    s1, s2 = sp.symbols("s1 s2", positive=True)
    f = (sp.exp(-(x1 - x) ** 2 / (2 * s1**2)) / (sp.sqrt(2 * sp.pi) * s1)
         * sp.exp(-(x2 - x) ** 2 / (2 * s2**2)) / (sp.sqrt(2 * sp.pi) * s2))
    logf = sp.expand_log(sp.log(f), force=True)
    (xt,) = sp.solve(sp.diff(logf, x), x)
    prof = sp.simplify(logf.subs(x, xt))
    return sp.lambdify((x1, x2, s1, s2), prof, "numpy")


def test_profile_matches_sympy_substitution(sympy_profile):
    rng = np.random.default_rng(10)
    x1, x2 = rng.normal(0, 3, 50), rng.normal(0, 3, 50)
    s1, s2 = rng.uniform(0.1, 3, 50), rng.uniform(0.1, 3, 50)
    got = px.log_likelihood_measure(x1, x2, s1**2, s2**2, kind="profile")
    np.testing.assert_allclose(got, sympy_profile(x1, x2, s1, s2), rtol=1e-12, atol=1e-12)


def test_profile_is_paper_eq4_evaluated_at_fused_estimate():
    # eq. (4): product of the two normal densities at x~ = (s2^2 x1 + s1^2 x2)/(s1^2 + s2^2)
    rng = np.random.default_rng(11)
    x1, x2 = rng.normal(size=20), rng.normal(size=20)
    v1, v2 = rng.uniform(0.1, 2, 20), rng.uniform(0.1, 2, 20)
    xt = (v2 * x1 + v1 * x2) / (v1 + v2)
    ref = (stats.norm.logpdf(x1, xt, np.sqrt(v1)) + stats.norm.logpdf(x2, xt, np.sqrt(v2)))
    np.testing.assert_allclose(px.log_likelihood_measure(x1, x2, v1, v2), ref, rtol=1e-12)


def test_marginal_by_numerical_integration():
    for x1, x2, v1, v2 in [(0.3, -0.4, 0.5, 1.2), (2.0, 1.0, 0.01, 4.0), (0.0, 0.0, 1.0, 1.0)]:
        def integrand(x, x1=x1, x2=x2, v1=v1, v2=v2):
            return stats.norm.pdf(x1, x, math.sqrt(v1)) * stats.norm.pdf(x2, x, math.sqrt(v2))
        ref = integrate.quad(integrand, -np.inf, np.inf, epsabs=0, epsrel=1e-12)[0]
        got = px.log_likelihood_measure(x1, x2, v1, v2, kind="marginal")
        assert got == pytest.approx(math.log(ref), rel=1e-9)


def test_vector_profile_minimum_is_mahalanobis_symbolic():
    # Fully symbolic 2x2 covariances: minimising the two-sensor quadratic form over x
    # gives (x1 - x2)' (C1 + C2)^-1 (x1 - x2), the quantity proximity_gaussian computes.
    a1, c1, a2, c2 = sp.symbols("a1 c1 a2 c2", positive=True)
    b1, b2 = sp.symbols("b1 b2", real=True)
    C1 = sp.Matrix([[a1, b1], [b1, c1]])
    C2 = sp.Matrix([[a2, b2], [b2, c2]])
    p1 = sp.Matrix(sp.symbols("p1 q1", real=True))
    p2 = sp.Matrix(sp.symbols("p2 q2", real=True))
    xv = sp.Matrix(sp.symbols("x y", real=True))
    Q = (((p1 - xv).T * C1.inv() * (p1 - xv))[0]
         + ((p2 - xv).T * C2.inv() * (p2 - xv))[0])
    sol = sp.solve([sp.diff(Q, v) for v in xv], list(xv), dict=True)[0]
    d = p1 - p2
    kappa = (d.T * (C1 + C2).LUsolve(d))[0]
    assert sp.simplify(sp.together(Q.subs(sol) - kappa)) == 0
    # and numerically against the package for one admissible set of values
    vals = {a1: 2.0, b1: 0.3, c1: 1.0, a2: 0.5, b2: -0.2, c2: 1.5,
            p1[0]: 0.4, p1[1]: -1.0, p2[0]: 1.1, p2[1]: 0.2}
    got = px.proximity_gaussian([0.4, -1.0], [1.1, 0.2], np.array(C1.subs(vals), dtype=float),
                            np.array(C2.subs(vals), dtype=float))
    assert got == pytest.approx(float(kappa.subs(vals)), rel=1e-12)


def test_paper_eq7_printed_factor_is_wrong():
    # The printed (7): exp(-kappa/2) / (2 pi (s1^2 + s2^2)). It differs from the
    # derived profile measure unless s1 s2 = s1^2 + s2^2, which is impossible.
    v1, v2 = 0.7, 1.3
    printed = -0.5 * px.proximity(1.0, 0.0, v1, v2) - math.log(2 * math.pi * (v1 + v2))
    derived = px.log_likelihood_measure(1.0, 0.0, v1, v2)
    assert derived - printed == pytest.approx(math.log((v1 + v2) / math.sqrt(v1 * v2)))
    assert derived > printed


# ------------------------------------------------------------ proximity
@settings(max_examples=80, deadline=None)
@given(x1=coords, x2=coords, v1=variances, v2=variances)
def test_proximity_symmetric_nonnegative(x1, x2, v1, v2):
    k = px.proximity(x1, x2, v1, v2)
    assert k >= 0
    assert k == px.proximity(x2, x1, v2, v1)
    assert k == pytest.approx((x1 - x2) ** 2 / (v1 + v2), rel=1e-12)


@settings(max_examples=40, deadline=None)
@given(x1=coords, x2=coords, v1=variances, v2=variances, t=coords)
def test_likelihood_symmetric_and_translation_invariant(x1, x2, v1, v2, t):
    for kind in ("profile", "marginal"):
        a = px.log_likelihood_measure(x1, x2, v1, v2, kind=kind)
        assert a == px.log_likelihood_measure(x2, x1, v2, v1, kind=kind)
        assert a == pytest.approx(px.log_likelihood_measure(x1 + t, x2 + t, v1, v2, kind=kind),
                                  rel=1e-6, abs=1e-6)


@settings(max_examples=40, deadline=None)
@given(v1=variances, v2=variances)
def test_profile_minus_marginal_depends_only_on_variances(v1, v2):
    diff = (px.log_likelihood_measure(0.0, 1.0, v1, v2)
            - px.log_likelihood_measure(0.0, 1.0, v1, v2, kind="marginal"))
    ref = 0.5 * math.log((v1 + v2) / (2 * math.pi * v1 * v2))
    assert diff == pytest.approx(ref, rel=1e-9, abs=1e-9)


def test_proximity_vectorized_equals_loop():
    rng = np.random.default_rng(12)
    x1, x2 = rng.normal(size=(4, 5)), rng.normal(size=5)
    v1, v2 = rng.uniform(0.1, 1, (4, 1)), rng.uniform(0.1, 1, 5)
    got = px.proximity(x1, x2, v1, v2)
    for i in range(4):
        for j in range(5):
            assert got[i, j] == px.proximity(x1[i, j], x2[j], v1[i, 0], v2[j])


# ------------------------------------------------------------ Mahalanobis
@pytest.mark.parametrize("d", [1, 2, 3, 5])
def test_mahalanobis_against_scipy_distance(d):
    rng = np.random.default_rng(13 + d)
    c1, c2 = _random_spd(rng, d, (30,)), _random_spd(rng, d, (30,))
    x1, x2 = rng.normal(size=(30, d)), rng.normal(size=(30, d))
    got = px.proximity_gaussian(x1, x2, c1, c2)
    for i in range(30):
        vi = np.linalg.inv(c1[i] + c2[i])          # scipy's API takes the inverse
        assert got[i] == pytest.approx(distance.mahalanobis(x1[i], x2[i], vi) ** 2, rel=1e-9)


@pytest.mark.parametrize("d", [1, 2, 4])
def test_gaussian_likelihoods_against_multivariate_normal(d):
    rng = np.random.default_rng(20 + d)
    c1, c2 = _random_spd(rng, d, (10,)), _random_spd(rng, d, (10,))
    x1, x2 = rng.normal(size=(10, d)), rng.normal(size=(10, d))
    prof = px.log_likelihood_measure_gaussian(x1, x2, c1, c2)
    marg = px.log_likelihood_measure_gaussian(x1, x2, c1, c2, kind="marginal")
    for i in range(10):
        # information-form fused estimate, computed independently
        info = np.linalg.solve(c1[i], np.eye(d)) + np.linalg.solve(c2[i], np.eye(d))
        rhs = np.linalg.solve(c1[i], x1[i]) + np.linalg.solve(c2[i], x2[i])
        xt = np.linalg.solve(info, rhs)
        ref_p = (stats.multivariate_normal.logpdf(x1[i], xt, c1[i])
                 + stats.multivariate_normal.logpdf(x2[i], xt, c2[i]))
        ref_m = stats.multivariate_normal.logpdf(x1[i] - x2[i], np.zeros(d), c1[i] + c2[i])
        assert prof[i] == pytest.approx(ref_p, rel=1e-9)
        assert marg[i] == pytest.approx(ref_m, rel=1e-9)


def test_gaussian_d1_reduces_to_scalar():
    rng = np.random.default_rng(30)
    x1, x2 = rng.normal(size=8), rng.normal(size=8)
    v1, v2 = rng.uniform(0.1, 2, 8), rng.uniform(0.1, 2, 8)
    for kind in ("profile", "marginal"):
        np.testing.assert_allclose(
            px.log_likelihood_measure_gaussian(x1[:, None], x2[:, None], v1[:, None, None],
                                               v2[:, None, None], kind=kind),
            px.log_likelihood_measure(x1, x2, v1, v2, kind=kind), rtol=1e-12)
    np.testing.assert_allclose(px.proximity_gaussian(x1[:, None], x2[:, None], v1[:, None, None],
                                                 v2[:, None, None]),
                               px.proximity(x1, x2, v1, v2), rtol=1e-12)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), d=st.integers(1, 4))
def test_mahalanobis_symmetric_nonnegative_loop(seed, d):
    rng = np.random.default_rng(seed)
    c1, c2 = _random_spd(rng, d, (3,)), _random_spd(rng, d)
    x1, x2 = rng.normal(size=(3, d)), rng.normal(size=(3, d))
    k = px.proximity_gaussian(x1, x2, c1, c2)
    assert np.all(k >= 0)
    np.testing.assert_allclose(k, px.proximity_gaussian(x2, x1, c2, c1), rtol=1e-10)
    loop = [px.proximity_gaussian(x1[i], x2[i], c1[i], c2) for i in range(3)]
    np.testing.assert_allclose(k, loop, rtol=1e-12)


def test_mahalanobis_broadcasting_shapes():
    rng = np.random.default_rng(31)
    x1 = rng.normal(size=(4, 1, 2))
    x2 = rng.normal(size=(5, 2))
    c = _random_spd(rng, 2)
    assert px.proximity_gaussian(x1, x2, c, c).shape == (4, 5)
    assert px.proximity_gaussian(x1[0, 0], x2[0], c, _random_spd(rng, 2, (6, 1))).shape == (6, 1)


# ------------------------------------------------------------ laws (Monte Carlo)
def test_kappa_chi2_under_true_and_ncx2_under_false():
    rng = np.random.default_rng(40)
    n = 200_000
    v1, v2 = 0.4, 0.9
    # true hypothesis: one object at x = 3
    k_true = px.proximity(3 + rng.normal(0, math.sqrt(v1), n), 3 + rng.normal(0, math.sqrt(v2), n),
                          v1, v2)
    # false: two objects at 0 and 2.5
    k_false = px.proximity(rng.normal(0, math.sqrt(v1), n), 2.5 + rng.normal(0, math.sqrt(v2), n),
                           v1, v2)
    vnc = 2.5**2 / (v1 + v2)
    for q in (0.5, 2.0, 6.0):
        p = stats.chi2.cdf(q, 1)
        assert abs(np.mean(k_true < q) - p) < binomial_tolerance(p, n)
        p = stats.ncx2.cdf(q, 1, vnc)
        assert abs(np.mean(k_false < q) - p) < binomial_tolerance(p, n)


def test_mahalanobis_chi2_d_dof():
    rng = np.random.default_rng(41)
    n, d = 100_000, 3
    c1, c2 = _random_spd(rng, d), _random_spd(rng, d)
    l1, l2 = np.linalg.cholesky(c1), np.linalg.cholesky(c2)
    x = rng.normal(size=d)
    r1 = x + rng.standard_normal((n, d)) @ l1.T
    r2 = x + rng.standard_normal((n, d)) @ l2.T
    k = px.proximity_gaussian(r1, r2, c1, c2)
    for q in (1.0, 3.0, 7.8):
        p = stats.chi2.cdf(q, d)
        assert abs(np.mean(k < q) - p) < binomial_tolerance(p, n)


def test_proximity_pdf_integrates_to_one_and_matches_scipy():
    for v in (0.0, 3.0):
        total = integrate.quad(lambda k, v=v: px.proximity_pdf(k, dof=2, noncentrality=v),
                               0, np.inf)[0]
        assert total == pytest.approx(1.0, abs=1e-8)
    assert px.proximity_pdf(2.0, dof=1, noncentrality=4.0) == pytest.approx(
        stats.ncx2.pdf(2.0, 1, 4.0))


def test_best_partner_kinds_differ_with_unequal_variances():
    # candidate 0 from a precise sensor a little farther (in kappa), candidate 1 from a coarse one
    x1, var1 = 0.0, 1.0
    cands, cvars = np.array([1.5, 1.0]), np.array([0.01, 1.0])
    k = px.proximity(x1, cands, var1, cvars)
    assert k[0] > k[1]                                  # nearest in kappa is candidate 1
    assert px.best_partner(x1, cands, var1, cvars, kind="marginal") == 1
    assert px.best_partner(x1, cands, var1, cvars, kind="profile") == 0
    assert px.best_partner(x1, cands, var1, [1.0, 1.0], kind="profile") == 1


# ------------------------------------------------------------ bad input
@pytest.mark.parametrize(("args", "name"), [((0, 1, 0.0, 1), "var1"), ((0, 1, 1, -2), "var2"),
                                            ((np.nan, 1, 1, 1), "x1"), ((0, np.inf, 1, 1), "x2")])
def test_scalar_bad_input(args, name):
    with pytest.raises(ValueError, match=f"`{name}`"):
        px.proximity(*args)
    with pytest.raises(ValueError, match=f"`{name}`"):
        px.log_likelihood_measure(*args)


def test_bad_kind():
    with pytest.raises(ValueError, match="`kind`"):
        px.log_likelihood_measure(0, 1, 1, 1, kind="exact")


def test_mismatched_shapes():
    with pytest.raises(ValueError, match="`x1`, `x2`"):
        px.proximity([0, 1, 2], [0, 1], 1, 1)
    with pytest.raises(ValueError, match="`x2`"):
        px.proximity_gaussian(np.zeros(2), np.zeros(3), np.eye(2), np.eye(2))
    with pytest.raises(ValueError, match="`cov2`"):
        px.proximity_gaussian(np.zeros(2), np.zeros(2), np.eye(2), np.eye(3))
    with pytest.raises(ValueError, match="leading"):
        px.proximity_gaussian(np.zeros((3, 2)), np.zeros((4, 2)), np.eye(2), np.eye(2))


def test_not_positive_definite():
    bad = np.array([[1.0, 2.0], [2.0, 1.0]])
    with pytest.raises(ValueError, match=r"`cov1`.*positive definite"):
        px.proximity_gaussian(np.zeros(2), np.zeros(2), bad, np.eye(2))
    with pytest.raises(ValueError, match=r"`cov2`.*symmetric"):
        px.log_likelihood_measure_gaussian(np.zeros(2), np.zeros(2), np.eye(2),
                                           np.array([[1.0, 0.5], [0.0, 1.0]]))


def test_pdf_bad_input():
    with pytest.raises(ValueError, match="`kappa`"):
        px.proximity_pdf(-1.0)
    with pytest.raises(ValueError, match="`dof`"):
        px.proximity_pdf(1.0, dof=0)
    with pytest.raises(ValueError, match="`noncentrality`"):
        px.proximity_pdf(1.0, noncentrality=-1.0)


# ============================================================ trust: range, validation, fuzz
import mpmath  # noqa: E402
from hypothesis import assume  # noqa: E402

PUBLIC = ["proximity", "proximity_gaussian", "log_likelihood_measure",
          "log_likelihood_measure_gaussian", "best_partner", "proximity_pdf"]
wide_coords = st.floats(min_value=-1e300, max_value=1e300, allow_nan=False)
wide_vars = st.floats(min_value=1e-300, max_value=1e300)


def _kappa_exact(x1, x2, v1, v2):
    """(x1 - x2)^2 / (v1 + v2) with 60 significant digits and an unbounded exponent."""
    with mpmath.workdps(60):
        return (mpmath.mpf(x1) - mpmath.mpf(x2)) ** 2 / (mpmath.mpf(v1) + mpmath.mpf(v2))


#: The numeric domain of engine.linalg: coordinates up to 2**150, variances in [2**-150, 2**150].
_BIG = 2.0 ** 150


@given(x1=wide_coords, x2=wide_coords, v1=wide_vars, v2=wide_vars)
def test_proximity_inside_domain_exact_outside_refused(x1, x2, v1, v2):
    outside = [name for name, ok in (("var1", 1 / _BIG <= v1 <= _BIG),
                                     ("var2", 1 / _BIG <= v2 <= _BIG),
                                     ("x1", abs(x1) <= _BIG), ("x2", abs(x2) <= _BIG)) if not ok]
    if outside:                                      # refused, naming the first bad argument
        with pytest.raises(ValueError, match=f"`{outside[0]}`.*numeric domain"):
            px.proximity(x1, x2, v1, v2)
        with pytest.raises(ValueError, match=f"`{outside[0]}`.*numeric domain"):
            px.log_likelihood_measure(x1, x2, v1, v2)
        return
    ref = _kappa_exact(x1, x2, v1, v2)
    got = px.proximity(x1, x2, v1, v2)
    assert math.isfinite(got) and got >= 0
    if ref > mpmath.mpf(1e-290):                     # away from subnormal rounding
        assert got == pytest.approx(float(ref), rel=1e-13)
    assert math.isfinite(px.log_likelihood_measure(x1, x2, v1, v2))


def test_domain_edges_exact_and_beyond_refused():
    # beyond the domain: refused with the argument's name, never inf or a rescaled answer
    with pytest.raises(ValueError, match=r"`x1` must lie within the numeric domain"):
        px.proximity(1e154, -1e154, 1.0, 1.0)
    with pytest.raises(ValueError, match=r"`x2` must lie within the numeric domain"):
        px.proximity_gaussian([0.0, 0.0], [-1e154, 0.0], np.eye(2), np.eye(2))
    with pytest.raises(ValueError, match=r"`var1` must have every variance within"):
        px.proximity(1.0, 0.0, 1e300, 1.0)
    with pytest.raises(ValueError, match=r"`cov2` must have every variance within"):
        px.log_likelihood_measure_gaussian([0.0, 0.0], [1.0, 1.0], np.eye(2),
                                           1e-300 * np.eye(2), kind="marginal")
    # at the edges of the domain: exact (closed forms)
    assert px.proximity(_BIG, -_BIG, _BIG, _BIG) == 2 * _BIG
    assert px.proximity(2.0**-140, 0.0, 2.0**-150, 2.0**-150) == 2.0**-131
    assert px.proximity_gaussian([_BIG, 0.0], [0.0, 0.0], _BIG * np.eye(2),
                                 _BIG * np.eye(2)) == _BIG / 2
    lm = px.log_likelihood_measure_gaussian([0.0, 0.0], [1.0, 1.0], 1e45 * np.eye(2),
                                            1e45 * np.eye(2), kind="marginal")
    log_det_s = 2 * (math.log(2.0) + 45 * math.log(10.0))            # S = 2e45 I
    assert lm == pytest.approx(-math.log(2 * math.pi) - 0.5 * log_det_s, rel=1e-12)


@st.composite
def spd_pairs(draw):
    d = draw(st.integers(1, 3))
    seed = draw(st.integers(0, 2**32 - 1))
    e1, e2, ex = draw(st.integers(-40, 40)), draw(st.integers(-40, 40)), draw(
        st.integers(-40, 40))                       # inside the numeric domain
    rng = np.random.default_rng(seed)
    c1 = _random_spd(rng, d) * 10.0**e1
    c2 = _random_spd(rng, d) * 10.0**e2
    x1, x2 = rng.normal(size=d) * 10.0**ex, rng.normal(size=d) * 10.0**ex
    return x1, x2, c1, c2


@given(spd_pairs())
def test_mahalanobis_against_mpmath_over_scales(args):
    x1, x2, c1, c2 = args
    with mpmath.workdps(40):
        S = mpmath.matrix(c1.tolist()) + mpmath.matrix(c2.tolist())
        delta = mpmath.matrix((x1 - x2).tolist()) if x1.size > 1 else mpmath.matrix(
            [float(x1[0] - x2[0])])
        ref = (delta.T * mpmath.lu_solve(S, delta))[0]
    assume(ref > mpmath.mpf(1e-290))
    got = px.proximity_gaussian(x1, x2, c1, c2)
    assert math.isfinite(got) and got == pytest.approx(float(ref), rel=1e-8)
    for kind in ("profile", "marginal"):
        assert math.isfinite(px.log_likelihood_measure_gaussian(x1, x2, c1, c2, kind=kind))


@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 5),
       v=st.floats(min_value=1e-6, max_value=1e6))
def test_best_partner_valid_index_and_nearest_when_variances_equal(seed, k, v):
    rng = np.random.default_rng(seed)
    x1, cands = rng.normal(size=4), rng.normal(size=(4, k)) * 3
    for kind in ("profile", "marginal"):
        idx = px.best_partner(x1, cands, v, np.full(k, v), kind=kind)
        assert idx.shape == (4,) and np.all((idx >= 0) & (idx < k))
        np.testing.assert_array_equal(idx, np.argmin(np.abs(cands - x1[:, None]), axis=1))


def _ncx2_pdf_mpmath(k, nu, lam):
    with mpmath.workdps(30):
        k, lam = mpmath.mpf(k), mpmath.mpf(lam)
        return (mpmath.exp(-(k + lam) / 2) / 2 * (k / lam) ** (mpmath.mpf(nu) / 4 - 0.5)
                * mpmath.besseli(mpmath.mpf(nu) / 2 - 1, mpmath.sqrt(lam * k)))


@given(nu=st.integers(1, 12), lam=st.floats(min_value=1e-3, max_value=1e300),
       z=st.floats(min_value=-8, max_value=8))
def test_pdf_finite_and_matches_mpmath_over_the_float_range(nu, lam, z):
    # kappa near the bulk of the law (mean nu + lam, sd sqrt(2 (nu + 2 lam))), and positive
    k = max(1e-6, nu + lam + z * math.sqrt(2 * (nu + 2 * lam)))
    got = px.proximity_pdf(k, dof=nu, noncentrality=lam)
    ref = _ncx2_pdf_mpmath(k, nu, lam)
    assert math.isfinite(got) and got >= 0
    if ref > mpmath.mpf(1e-300):
        assert got == pytest.approx(float(ref), rel=1e-6)


@pytest.mark.parametrize(("k", "nu", "lam"), [(1e15, 1, 1e15), (1e15, 3, 1e15), (1e250, 2, 1e250),
                                              (4.0, 2, 3000.0), (1e-3, 6, 50.0)])
def test_pdf_extremes_against_mpmath(k, nu, lam):
    got = px.proximity_pdf(k, dof=nu, noncentrality=lam)
    ref = float(_ncx2_pdf_mpmath(k, nu, lam))
    assert math.isfinite(got)
    assert got == pytest.approx(ref, rel=1e-6, abs=1e-300)


def test_pdf_limits_at_zero():
    assert px.proximity_pdf(0.0, dof=2, noncentrality=3.0) == pytest.approx(0.5 * math.exp(-1.5))
    assert px.proximity_pdf(0.0, dof=3, noncentrality=3.0) == 0.0
    assert px.proximity_pdf(0.0, dof=1, noncentrality=3.0) == math.inf     # documented


# ------------------------------------------------------------ bad input, named
VALID = {
    "proximity": dict(x1=0.5, x2=-0.3, var1=1.0, var2=2.0),
    "log_likelihood_measure": dict(x1=0.5, x2=-0.3, var1=1.0, var2=2.0),
    "proximity_gaussian": dict(x1=[0.5, 0.1], x2=[0.0, 0.0], cov1=np.eye(2), cov2=2 * np.eye(2)),
    "log_likelihood_measure_gaussian": dict(x1=[0.5, 0.1], x2=[0.0, 0.0], cov1=np.eye(2),
                                            cov2=2 * np.eye(2)),
    "best_partner": dict(x1=0.0, candidates=[0.5, -0.2], var1=1.0, candidate_vars=[1.0, 2.0]),
    "proximity_pdf": dict(kappa=1.0, dof=2, noncentrality=3.0),
}
NOT_POSITIVE = {"var1", "var2", "candidate_vars"}
NOT_NEGATIVE = {"kappa", "noncentrality"}
bad_values = st.sampled_from([math.nan, math.inf, -math.inf, True, "1.5", None, b"x", 1 + 2j])


def _call(name, **kw):
    return getattr(px, name)(**kw)


def test_every_public_function_has_valid_example():
    assert sorted(VALID) == sorted(PUBLIC) == sorted(px.__all__)
    for name, kw in VALID.items():
        out = np.asarray(_call(name, **kw))
        assert np.all(np.isfinite(out))


@given(name=st.sampled_from(sorted(VALID)), data=st.data())
def test_fuzz_bad_values_named(name, data):
    kw = dict(VALID[name])
    arg = data.draw(st.sampled_from(sorted(kw)))
    bad = data.draw(bad_values)
    kw[arg] = bad
    with pytest.raises((ValueError, TypeError), match=f"`{arg}`"):
        _call(name, **kw)


@given(name=st.sampled_from(sorted(VALID)), data=st.data())
def test_fuzz_out_of_domain_named(name, data):
    kw = dict(VALID[name])
    args = sorted(set(kw) & (NOT_POSITIVE | NOT_NEGATIVE))
    assume(args)
    arg = data.draw(st.sampled_from(args))
    hi = 0.0 if arg in NOT_POSITIVE else -1e-300
    kw[arg] = data.draw(st.floats(min_value=-1e300, max_value=hi))
    with pytest.raises(ValueError, match=f"`{arg}`"):
        _call(name, **kw)


@st.composite
def bad_covariances(draw):
    d = draw(st.integers(1, 3))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    spd = _random_spd(rng, d)
    kind = draw(st.sampled_from(["negative", "zero", "asym"] if d > 1 else ["negative", "zero"]))
    if kind == "negative":
        return -spd
    if kind == "zero":
        return np.zeros((d, d))
    a = spd.copy()
    a[0, 1] += 0.5 + abs(a[0, 1])
    return a


@given(cov=bad_covariances(), which=st.sampled_from(["cov1", "cov2"]),
       name=st.sampled_from(["proximity_gaussian", "log_likelihood_measure_gaussian"]))
def test_fuzz_bad_covariances_named(cov, which, name):
    d = cov.shape[-1]
    kw = dict(x1=np.zeros(d), x2=np.ones(d), cov1=np.eye(d), cov2=np.eye(d))
    kw[which] = cov
    with pytest.raises(ValueError, match=f"`{which}` must be (symmetric|positive definite)"):
        _call(name, **kw)


def test_negative_definite_rejected_even_when_the_sum_is_positive_definite():
    # S = cov1 + cov2 = I is fine, but cov1 itself is not a covariance
    with pytest.raises(ValueError, match=r"`cov1`.*positive definite"):
        px.proximity_gaussian([1.0, 0.0], [0.0, 0.0], -np.eye(2), 2 * np.eye(2))
    with pytest.raises(ValueError, match=r"`cov2`.*symmetric"):
        px.proximity_gaussian([1.0, 0.0], [0.0, 0.0], np.eye(2), [[1.0, 0.3], [-0.3, 1.0]])


def test_zero_sigma_names_the_public_argument():
    with pytest.raises(ValueError, match="`candidate_vars` must be > 0"):
        px.best_partner(0.0, [0.5, -0.2], 1.0, [1.0, 0.0])
    with pytest.raises(ValueError, match="`var1` must be > 0"):
        px.best_partner(0.0, [0.5, -0.2], 0.0, [1.0, 1.0])
    with pytest.raises(ValueError, match="`cov1` must be positive definite"):
        px.proximity_gaussian([0.0, 0.0], [1.0, 1.0], np.zeros((2, 2)), np.eye(2))
    with pytest.raises(ValueError, match=r"`x1`, `candidates`, `var1`, `candidate_vars`"):
        px.best_partner([0.0, 1.0, 2.0], [[0.5, -0.2]] * 2, 1.0, [1.0, 1.0])
    with pytest.raises(ValueError, match="`candidates` must hold at least one"):
        px.best_partner(0.0, np.zeros((3, 0)), 1.0, np.zeros((3, 0)) + 1)
    with pytest.raises(TypeError, match="`dof`"):
        px.proximity_pdf(1.0, dof=2.0)
