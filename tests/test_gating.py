"""Tests of radarfusion_ref.gating.

Reference values come from independent routes: the closed form of the
chi-square law for 1 and 2 degrees of freedom (normal quantiles, exponentials),
numerical integration of the noncentral density written as a Poisson mixture,
and Monte Carlo with tolerances from the binomial standard error.
"""

from __future__ import annotations

import math
import time
import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, special, stats

from radarfusion_ref import gating
from radarfusion_ref.engine.montecarlo import binomial_tolerance

probs = st.floats(min_value=1e-6, max_value=0.5)
dofs = st.integers(min_value=1, max_value=30)
ncs = st.floats(min_value=0.0, max_value=200.0)


# ---------------------------------------------------------------- thresholds
@pytest.mark.parametrize("p", [0.01, 0.005, 0.05, 1e-6])
def test_threshold_one_dof_is_squared_normal_quantile(p):
    # chi2(1) = Z^2, so P(Z^2 > t) = p  <=>  t = Phi^{-1}(1 - p/2)^2
    z = -special.ndtri(p / 2)
    assert gating.gate_threshold(p, 1) == pytest.approx(z**2, rel=1e-12)


@pytest.mark.parametrize("p", [0.01, 0.005, 0.05, 1e-9])
def test_threshold_two_dof_is_exponential(p):
    # chi2(2) is exponential with mean 2: P(kappa > t) = exp(-t/2)
    assert gating.gate_threshold(p, 2) == pytest.approx(-2 * math.log(p), rel=1e-12)


def test_threshold_table_values_from_printed_chi2_tables():
    # Standard printed chi-square tables (upper 1 % and 0.5 % points), 3 decimals.
    table_01 = [6.635, 9.210, 11.345, 13.277, 15.086]
    table_005 = [7.879, 10.597, 12.838, 14.860, 16.750]
    got = gating.gate_threshold(np.array([[0.01], [0.005]]), np.arange(1, 6))
    np.testing.assert_allclose(got, [table_01, table_005], atol=6e-4)


def test_threshold_even_dof_closed_form():
    # For m = 2r, P(chi2 > t) = exp(-t/2) sum_{i<r} (t/2)^i / i!
    for r in range(1, 6):
        t = gating.gate_threshold(0.005, 2 * r)
        tail = math.exp(-t / 2) * sum((t / 2) ** i / math.factorial(i) for i in range(r))
        assert tail == pytest.approx(0.005, rel=1e-10)


@settings(max_examples=60, deadline=None)
@given(p=probs, m=dofs)
def test_threshold_inverts_tail(p, m):
    t = gating.gate_threshold(p, m)
    assert t > 0
    assert stats.chi2.sf(t, m) == pytest.approx(p, rel=1e-8)


@settings(max_examples=40, deadline=None)
@given(p1=probs, p2=probs, m=dofs)
def test_threshold_monotone(p1, p2, m):
    lo, hi = sorted((p1, p2))
    assert gating.gate_threshold(lo, m) >= gating.gate_threshold(hi, m)
    assert gating.gate_threshold(lo, m + 1) > gating.gate_threshold(lo, m)


def test_threshold_broadcasts_like_loop():
    p = np.array([0.01, 0.005, 0.1])[:, None]
    m = np.arange(1, 8)[None, :]
    got = gating.gate_threshold(p, m)
    assert got.shape == (3, 7)
    for i in range(3):
        for j in range(7):
            assert got[i, j] == gating.gate_threshold(float(p[i, 0]), int(m[0, j]))


# ------------------------------------------------------------ false accept
def _ncx2_cdf_by_quadrature(t, m, v):
    """CDF of the noncentral chi-square as a Poisson mixture of chi-square CDFs,
    each central CDF by numerical integration of its density."""
    total = 0.0
    for j in range(400):
        w = stats.poisson.pmf(j, v / 2)
        if j > v / 2 and w < 1e-17:
            break
        k = m + 2 * j
        dens = lambda x, k=k: math.exp((k / 2 - 1) * math.log(x) - x / 2  # noqa: E731
                                       - (k / 2) * math.log(2) - math.lgamma(k / 2))
        total += w * integrate.quad(dens, 0, t, limit=200)[0]
    return total


@pytest.mark.parametrize(("v", "m", "p"), [(0.5, 1, 0.01), (4.0, 1, 0.005), (10.0, 1, 0.01),
                                           (9.0, 2, 0.01), (25.0, 3, 0.005)])
def test_p_false_accept_against_poisson_mixture(v, m, p):
    t = gating.gate_threshold(p, m)
    ref = _ncx2_cdf_by_quadrature(t, m, v)
    assert gating.p_false_accept(v, m, p) == pytest.approx(ref, rel=1e-7, abs=1e-12)


@pytest.mark.parametrize("v", [0.3, 2.0, 10.0, 30.0])
def test_p_false_accept_one_dof_normal_form(v):
    # For m = 1, kappa = (Z + sqrt(V))^2, so P(kappa < t) = Phi(c - mu) - Phi(-c - mu)
    t = gating.gate_threshold(0.01, 1)
    c, mu = math.sqrt(t), math.sqrt(v)
    ref = special.ndtr(c - mu) - special.ndtr(-c - mu)
    assert gating.p_false_accept(v, 1, 0.01) == pytest.approx(ref, rel=1e-9)


@settings(max_examples=40, deadline=None)
@given(p=probs, m=dofs)
def test_p_false_accept_at_zero_noncentrality(p, m):
    assert gating.p_false_accept(0.0, m, p) == pytest.approx(1 - p, rel=1e-10)


@settings(max_examples=40, deadline=None)
@given(v1=ncs, v2=ncs, m=dofs, p=probs)
def test_p_false_accept_decreasing_and_bounded(v1, v2, m, p):
    lo, hi = sorted((v1, v2))
    a, b = gating.p_false_accept(lo, m, p), gating.p_false_accept(hi, m, p)
    assert 0.0 <= b <= a + 1e-12 <= 1.0 + 1e-12


def test_p_false_accept_monte_carlo():
    rng = np.random.default_rng(1)
    n = 200_000
    for v, m in [(4.0, 1), (9.0, 2), (16.0, 3)]:
        mu = np.zeros(m)
        mu[0] = math.sqrt(v)
        kappa = np.sum((rng.standard_normal((n, m)) + mu) ** 2, axis=1)
        mc = np.mean(gating.in_gate(kappa, m, 0.01))
        exact = gating.p_false_accept(v, m, 0.01)
        assert abs(mc - exact) < binomial_tolerance(exact, n)


def test_gate_false_rejection_rate_monte_carlo():
    rng = np.random.default_rng(2)
    n = 400_000
    for m, p in [(1, 0.01), (2, 0.005), (5, 0.01)]:
        kappa = rng.chisquare(m, size=n)
        rejected = np.mean(~gating.in_gate(kappa, m, p))
        assert abs(rejected - p) < binomial_tolerance(p, n)


# ---------------------------------------------------------- required V
@pytest.mark.parametrize(("target", "m", "p"), [(0.5, 1, 0.01), (0.05, 1, 0.01),
                                                (0.01, 2, 0.005), (0.1, 4, 0.01)])
def test_required_noncentrality_roundtrip(target, m, p):
    v = gating.required_noncentrality(target, m, p)
    assert v > 0
    assert stats.ncx2.cdf(stats.chi2.isf(p, m), m, v) == pytest.approx(target, rel=1e-7)


def test_required_noncentrality_vectorized_equals_loop():
    t = np.array([0.5, 0.1, 0.01])
    got = gating.required_noncentrality(t[:, None], np.array([1, 2]), 0.01)
    for i in range(3):
        for j, m in enumerate([1, 2]):
            assert got[i, j] == pytest.approx(gating.required_noncentrality(t[i], m, 0.01),
                                              rel=1e-9)


# ---------------------------------------------------------- in_gate
@settings(max_examples=40, deadline=None)
@given(k=st.floats(min_value=0, max_value=100), m=dofs, p=probs)
def test_in_gate_matches_threshold(k, m, p):
    assert gating.in_gate(k, m, p) == (k < gating.gate_threshold(p, m))


# ---------------------------------------------------------- 2-D kernel
def test_gate_mahalanobis_2d_against_solve():
    rng = np.random.default_rng(3)
    n = 10_001
    a = rng.standard_normal((2, 2))
    s = a @ a.T + 0.5 * np.eye(2)
    x1, x2 = rng.standard_normal((n, 2)), rng.standard_normal((n, 2))
    d = x1 - x2
    ref = np.einsum("ni,ni->n", d, np.linalg.solve(s, d.T).T)
    acc, k = gating.gate_mahalanobis(x1, x2, s, chunk_size=1000, return_statistic=True)
    np.testing.assert_allclose(k, ref, rtol=1e-12)
    np.testing.assert_array_equal(acc, ref < stats.chi2.isf(0.01, 2))


def test_gate_mahalanobis_2d_chunk_size_irrelevant():
    rng = np.random.default_rng(4)
    x1, x2 = rng.standard_normal((999, 2)), rng.standard_normal((999, 2))
    s = np.array([[2.0, 0.3], [0.3, 1.0]])
    base = gating.gate_mahalanobis(x1, x2, s, return_statistic=True)[1]
    for c in (1, 7, 998, 999, 5000):
        np.testing.assert_array_equal(
            gating.gate_mahalanobis(x1, x2, s, chunk_size=c, return_statistic=True)[1], base)


# ---------------------------------------------------------- bad input
@pytest.mark.parametrize("p", [0.0, 1.0, -0.1, 1.5, np.nan])
def test_bad_probability(p):
    with pytest.raises(ValueError, match="`p_false_reject`"):
        gating.gate_threshold(p, 1)
    with pytest.raises(ValueError, match="`p_false_reject`"):
        gating.p_false_accept(1.0, 1, p)


@pytest.mark.parametrize("m", [0, -1, 1.5, np.inf, [1, 0]])
def test_bad_dof(m):
    with pytest.raises(ValueError, match="`dof`"):
        gating.gate_threshold(0.01, m)
    with pytest.raises(ValueError, match="`dof`"):
        gating.in_gate(1.0, m, 0.01)


def test_bad_dof_type():
    with pytest.raises(TypeError, match="`dof`"):
        gating.gate_threshold(0.01, True)
    with pytest.raises(TypeError, match="`dof`"):
        gating.gate_threshold(0.01, "two")


@pytest.mark.parametrize("v", [-1.0, np.nan, np.inf])
def test_bad_noncentrality(v):
    with pytest.raises(ValueError, match="`noncentrality`"):
        gating.p_false_accept(v, 1, 0.01)


@pytest.mark.parametrize("k", [-0.5, np.nan])
def test_bad_statistic(k):
    with pytest.raises(ValueError, match="`statistic`"):
        gating.in_gate(k, 1, 0.01)


def test_bad_required_target():
    with pytest.raises(ValueError, match="`p_accept`"):
        gating.required_noncentrality(0.995, 1, 0.01)
    with pytest.raises(ValueError, match="`p_accept`"):
        gating.required_noncentrality(0.0, 1, 0.01)


def test_mismatched_shapes():
    with pytest.raises(ValueError, match="`p_false_reject`, `dof`"):
        gating.gate_threshold([0.01, 0.02, 0.03], [1, 2])


def test_kernel_bad_input():
    with pytest.raises(ValueError, match="`x1`"):
        gating.gate_mahalanobis(np.zeros((3, 3)), np.zeros((3, 2)), np.eye(2))
    with pytest.raises(ValueError, match="`x1` and `x2`"):
        gating.gate_mahalanobis(np.zeros((3, 2)), np.zeros((4, 2)), np.eye(2))
    with pytest.raises(ValueError, match="`cov`"):
        gating.gate_mahalanobis(np.zeros((3, 2)), np.zeros((3, 2)), -np.eye(2))
    with pytest.raises(ValueError, match=r"`x2\[0:3\]` must be finite"):
        gating.gate_mahalanobis(np.zeros((3, 2)), np.full((3, 2), np.nan), np.eye(2))
    x = np.zeros((10, 2))
    x[7, 1] = np.inf
    with pytest.raises(ValueError, match=r"`x1\[4:8\]` must be finite"):
        gating.gate_mahalanobis(x, x.copy(), np.eye(2), chunk_size=4)


# ---------------------------------------------------------- performance claims
def test_kernel_memory_bounded_by_chunking():
    # Only the 1-byte-per-pair result may grow with N; the work buffers are fixed.
    rng = np.random.default_rng(5)
    n = 1_000_000
    x1, x2 = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    tracemalloc.start()
    gating.gate_mahalanobis(x1, x2, np.eye(2))
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < n * 1 + 2 * 2**20


def test_kernel_beats_python_loop():
    # A scaled-down version of the benchmark's claim (>= 20x the pure-Python loop),
    # with the margin a loaded 2-core machine needs: both timed here, best of 3.
    rng = np.random.default_rng(6)
    n = 100_000
    x1, x2 = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
    s = np.array([[1.3, 0.4], [0.4, 0.7]])
    th = gating.gate_threshold(0.01, 2)
    l11 = math.sqrt(s[0, 0])
    l21 = s[1, 0] / l11
    l22 = math.sqrt(s[1, 1] - l21 * l21)
    a, b = x1.tolist(), x2.tolist()

    def loop():
        out = []
        for (a0, a1), (b0, b1) in zip(a, b, strict=True):
            z1 = (a0 - b0) / l11
            z2 = ((a1 - b1) - l21 * z1) / l22
            out.append(z1 * z1 + z2 * z2 < th)
        return out

    def best(f):
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            f()
            times.append(time.perf_counter() - t0)
        return min(times)

    assert loop() == gating.gate_mahalanobis(x1, x2, s).tolist()
    ratio = best(loop) / best(lambda: gating.gate_mahalanobis(x1, x2, s))
    assert ratio >= 20, f"kernel only {ratio:.1f}x faster than the Python loop"


# ============================================================ trust: range, validation, fuzz
import mpmath  # noqa: E402
from hypothesis import assume  # noqa: E402


def _p_fa_one_dof_mpmath(v, p_lo):
    """P{(z + sqrt v)^2 < t}, t the 1-dof gate, with 50 digits (independent of scipy.ncx2)."""
    with mpmath.workdps(50):
        t = mpmath.mpf(stats.chi2.isf(p_lo, 1))
        c, mu = mpmath.sqrt(t), mpmath.sqrt(mpmath.mpf(v))
        return mpmath.ncdf(c - mu) - mpmath.ncdf(-c - mu)


def _p_fa_quadrature_mpmath(v, m, p_lo):
    """P{chi'^2_m(v) < t} by mpmath quadrature of the Bessel-form density (no Poisson sum)."""
    with mpmath.workdps(30):
        t, lam = mpmath.mpf(stats.chi2.isf(p_lo, m)), mpmath.mpf(v)

        def pdf(x):
            return (mpmath.exp(-(x + lam) / 2) / 2 * (x / lam) ** (mpmath.mpf(m) / 4 - 0.5)
                    * mpmath.besseli(mpmath.mpf(m) / 2 - 1, mpmath.sqrt(lam * x)))

        # the integrand rises steeply towards t: subdivide geometrically towards it
        return mpmath.quad(pdf, [0] + [t * (1 - mpmath.mpf(2) ** -i) for i in range(1, 12)] + [t])


@given(v=st.floats(min_value=0.0, max_value=1e300), p=st.floats(min_value=1e-12, max_value=0.5))
def test_p_false_accept_one_dof_whole_range_against_mpmath(v, p):
    got = gating.p_false_accept(v, 1, p)
    ref = _p_fa_one_dof_mpmath(v, p)
    assert math.isfinite(got) and 0.0 <= got <= 1.0
    if ref < mpmath.mpf("4.9e-324"):
        assert got == 0.0
    elif ref > mpmath.mpf(1e-300):
        assert got == pytest.approx(float(ref), rel=1e-9)


@pytest.mark.parametrize(("v", "m", "p"), [(800.0, 2, 0.01), (1500.0, 3, 0.01), (1000.0, 5, 0.005),
                                           (1700.0, 10, 0.01), (1000.0, 1, 1e-6)])
def test_p_false_accept_far_tail_against_quadrature(v, m, p):
    # scipy's ncx2.cdf returns 0 for all of these; the true values are 1e-140 ... 1e-300
    ref = _p_fa_quadrature_mpmath(v, m, p)
    got = gating.p_false_accept(v, m, p)
    assert 0 < got < 1e-140
    assert got == pytest.approx(float(ref), rel=1e-8)


@given(e=st.floats(min_value=1.0, max_value=323.0), p=st.sampled_from([0.01, 0.005, 0.1]))
def test_required_noncentrality_tiny_targets_not_clamped(e, p):
    target = 10.0**-e
    v = gating.required_noncentrality(target, 1, p)
    assert math.isfinite(v) and v > 0
    # independent check: the 50-digit one-dof acceptance at the root is the target
    assert float(_p_fa_one_dof_mpmath(v, p)) == pytest.approx(target, rel=1e-6)


def test_required_noncentrality_strictly_monotone_down_to_the_smallest_double():
    targets = np.array([1e-50, 1e-100, 1e-200, 1e-300, 5e-324])
    v = gating.required_noncentrality(targets, 1, 0.01)
    assert np.all(np.diff(v) > 1.0)                  # the old code returned 455.0 for all
    v3 = gating.required_noncentrality(targets[:4], 3, 0.01)
    assert np.all(np.diff(v3) > 1.0)
    back = gating.p_false_accept(v3, 3, 0.01)
    np.testing.assert_allclose(back, targets[:4], rtol=1e-6)


@given(k=st.floats(min_value=0, max_value=1e3), m=dofs, p1=probs, p2=probs)
def test_gate_monotone_in_threshold(k, m, p1, p2):
    # a smaller P_lo is a larger gate: it never rejects what a larger P_lo accepts
    lo, hi = sorted((p1, p2))
    assert gating.gate_threshold(lo, m) >= gating.gate_threshold(hi, m)
    assert gating.in_gate(k, m, lo) >= gating.in_gate(k, m, hi)


@given(seed=st.integers(0, 2**32 - 1), p1=probs, p2=probs)
def test_kernel_monotone_in_threshold_and_agrees_with_in_gate(seed, p1, p2):
    rng = np.random.default_rng(seed)
    x1, x2 = rng.normal(size=(50, 2)) * 3, rng.normal(size=(50, 2))
    s = np.array([[1.5, 0.4], [0.4, 0.8]])
    lo, hi = sorted((p1, p2))
    a_lo, k = gating.gate_mahalanobis(x1, x2, s, p_false_reject=lo, return_statistic=True)
    a_hi = gating.gate_mahalanobis(x1, x2, s, p_false_reject=hi)
    assert np.all(a_lo >= a_hi)
    np.testing.assert_array_equal(a_lo, gating.in_gate(k, 2, lo))


@given(p=st.floats(min_value=5e-324, max_value=1 - 1e-16, exclude_max=False), m=dofs,
       v=st.floats(min_value=0, max_value=1e300))
def test_valid_input_gives_finite_results(p, m, v):
    assume(0 < p < 1)
    t = gating.gate_threshold(p, m)
    pf = gating.p_false_accept(v, m, p)
    assert math.isfinite(t) and t > 0
    assert math.isfinite(pf) and 0.0 <= pf <= 1.0 - p + 1e-12


def test_kernel_chunk_limit_checked_before_allocation():
    x = np.zeros((3, 2))
    tracemalloc.start()
    with pytest.raises(ValueError, match=r"refused: 1000000000 pairs per chunk.*limit of 1048576"):
        gating.gate_mahalanobis(x, x, np.eye(2), chunk_size=10**9)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 2**20
    with pytest.raises(TypeError, match="`chunk_size`"):
        gating.gate_mahalanobis(x, x, np.eye(2), chunk_size=1e9)
    with pytest.raises(TypeError, match="`chunk_size`"):
        gating.gate_mahalanobis(x, x, np.eye(2), chunk_size=True)
    with pytest.raises(ValueError, match="`chunk_size`"):
        gating.gate_mahalanobis(x, x, np.eye(2), chunk_size=0)
    assert gating.MAX_CHUNK == 2**20
    gating.gate_mahalanobis(x, x, np.eye(2), chunk_size=gating.MAX_CHUNK)   # the limit is ok


def test_required_noncentrality_root_limit_checked_first():
    with pytest.raises(ValueError, match="refused: 100001 roots"):
        gating.required_noncentrality(np.full(gating.MAX_ROOTS + 1, 0.1))
    with pytest.raises(ValueError, match="`xtol`"):
        gating.required_noncentrality(0.1, xtol=0.0)
    with pytest.raises(ValueError, match="`xtol`"):
        gating.required_noncentrality(0.1, xtol=[1e-10, 1e-10])


def test_kernel_domain_exact_or_refused():
    big = np.array([[1e154, 0.0]])
    with pytest.raises(ValueError, match=r"`x1\[0:1\] - x2\[0:1\]` must lie within the numeric domain"):
        gating.gate_mahalanobis(big, -big, np.eye(2))
    with pytest.raises(ValueError, match="`cov` must have every variance within"):
        gating.gate_mahalanobis(np.zeros((1, 2)), np.zeros((1, 2)), 1e300 * np.eye(2))
    edge = np.array([[2.0**149, 0.0]])             # the domain's edge: exact, not refused
    acc, k = gating.gate_mahalanobis(edge, -edge, 2.0**150 * np.eye(2), return_statistic=True)
    assert k[0] == 2.0**150 and not acc[0]


def test_kernel_other_arguments_validated():
    x = np.zeros((3, 2))
    with pytest.raises(TypeError, match="`return_statistic`"):
        gating.gate_mahalanobis(x, x, np.eye(2), return_statistic=1)
    with pytest.raises(ValueError, match="`p_false_reject`"):
        gating.gate_mahalanobis(x, x, np.eye(2), p_false_reject=[0.01, 0.02])
    with pytest.raises(ValueError, match="`cov` must be symmetric"):
        gating.gate_mahalanobis(x, x, [[1.0, 0.5], [0.0, 1.0]])
    with pytest.raises(ValueError, match="`cov` must be positive definite"):
        gating.gate_mahalanobis(x, x, np.zeros((2, 2)))


def test_shape_errors_name_public_arguments():
    with pytest.raises(ValueError, match="`statistic`, `dof`, `p_false_reject`"):
        gating.in_gate([1.0, 2.0, 3.0], [1, 2], 0.01)
    with pytest.raises(ValueError, match="`noncentrality`, `dof`, `p_false_reject`"):
        gating.p_false_accept([1.0, 2.0, 3.0], [1, 2], 0.01)


GATING_VALID = {
    "gate_threshold": dict(p_false_reject=0.01, dof=2),
    "in_gate": dict(statistic=1.0, dof=2, p_false_reject=0.01),
    "p_false_accept": dict(noncentrality=3.0, dof=2, p_false_reject=0.01),
    "required_noncentrality": dict(p_accept=0.1, dof=2, p_false_reject=0.01),
    "gate_mahalanobis": dict(x1=np.zeros((2, 2)), x2=np.ones((2, 2)), cov=np.eye(2)),
    "gate_pairwise": dict(x1=np.zeros((2, 2)), x2=np.ones((2, 2)),
                             cov1=np.stack([np.eye(2)] * 2), cov2=np.stack([np.eye(2)] * 2)),
    "gate_sparse": dict(x1=np.zeros((2, 2)), x2=np.ones((2, 2)), cov=np.eye(2)),
}


def test_every_public_function_covered():
    assert sorted(GATING_VALID) == sorted(n for n in gating.__all__ if not n.startswith("MAX"))


@given(name=st.sampled_from(sorted(GATING_VALID)), data=st.data(),
       bad=st.sampled_from([math.nan, math.inf, -1.0, True, "0.5", None, 1 + 1j]))
def test_fuzz_bad_values_named(name, data, bad):
    kw = dict(GATING_VALID[name])
    arg = data.draw(st.sampled_from(sorted(kw)))
    kw[arg] = bad
    if arg in ("x1", "x2") and not isinstance(bad, (str, bool, complex)) and bad is not None:
        kw[arg] = np.full((2, 2), bad)               # a finite negative coordinate is fine
        if bad == -1.0:
            return
    with pytest.raises((ValueError, TypeError), match=f"`{arg}"):
        getattr(gating, name)(**kw)


@given(p=st.one_of(st.floats(max_value=0.0), st.floats(min_value=1.0)),
       name=st.sampled_from(["gate_threshold", "in_gate", "p_false_accept",
                             "required_noncentrality"]))
def test_fuzz_probabilities_outside_open_interval_named(p, name):
    assume(not math.isnan(p))
    kw = dict(GATING_VALID[name], p_false_reject=p)
    with pytest.raises(ValueError, match="`p_false_reject`"):
        getattr(gating, name)(**kw)


# ============================================================ per-report covariances (all pairs)
from fractions import Fraction  # noqa: E402

from radarfusion_ref import proximity  # noqa: E402


def _random_covs(rng, shape, cond_max=1.0):
    """SPD 2x2 matrices with random orientation, scale over 6 decades and condition up to cond_max."""
    theta = rng.uniform(0, np.pi, shape)
    scale = 10.0 ** rng.uniform(-3, 3, shape)
    cond = 10.0 ** rng.uniform(0, np.log10(cond_max), shape) if cond_max > 1 else np.ones(shape)
    c, s = np.cos(theta), np.sin(theta)
    rot = np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)
    lam = np.stack([scale, scale / cond], -1)
    out = rot * lam[..., None, :] @ np.swapaxes(rot, -1, -2)
    return 0.5 * (out + np.swapaxes(out, -1, -2))


def _kappa_exact(d, s):
    """d^T S^-1 d in exact rational arithmetic from the float inputs (an independent route)."""
    d0, d1 = Fraction(d[0]), Fraction(d[1])
    a, b, c = Fraction(s[0][0]), Fraction(s[0][1]), Fraction(s[1][1])
    return (c * d0 * d0 - 2 * b * d0 * d1 + a * d1 * d1) / (a * c - b * b)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n1=st.integers(1, 6), n2=st.integers(1, 6),
       log_cond=st.floats(0.0, 10.0), p=st.floats(1e-6, 0.5))
def test_gate_pairwise_against_exact_rational_arithmetic(seed, n1, n2, log_cond, p):
    rng = np.random.default_rng(seed)
    x1, x2 = rng.normal(size=(n1, 2)) * 10, rng.normal(size=(n2, 2)) * 10
    c1 = _random_covs(rng, (n1,), 10.0**log_cond)
    c2 = _random_covs(rng, (n2,), 10.0**log_cond)
    acc, kappa = gating.gate_pairwise(x1, x2, c1, c2, p_false_reject=p,
                                         return_statistic=True)
    exact = np.array([[float(_kappa_exact((x1[i] - x2[j]).tolist(), (c1[i] + c2[j]).tolist()))
                       for j in range(n2)] for i in range(n1)])
    cond = np.array([[np.linalg.cond(c1[i] + c2[j]) for j in range(n2)] for i in range(n1)])
    tol = 64 * 2.2e-16 * cond * np.abs(exact) + 1e-300
    np.testing.assert_array_less(np.abs(kappa - exact), tol)
    th = stats.chi2.isf(p, 2)
    clear = np.abs(exact - th) > tol                 # decisions away from the threshold
    assert np.array_equal(acc[clear], (exact < th)[clear])
    assert np.array_equal(gating.gate_pairwise(x1, x2, c1, c2, p_false_reject=p), acc)


def test_gate_pairwise_broadcasts_and_chunking_irrelevant():
    rng = np.random.default_rng(11)
    x1, x2 = rng.normal(size=(5, 4, 2)), rng.normal(size=(1, 3, 2))
    c1 = _random_covs(rng, (1, 1), 100.0)          # one covariance for every report and trial
    c2 = _random_covs(rng, (5, 3), 100.0)
    acc, k = gating.gate_pairwise(x1, x2, c1, c2, return_statistic=True)
    ref = proximity.proximity_gaussian(x1[:, :, None], x2[:, None], c1[:, :, None], c2[:, None])
    assert acc.shape == k.shape == (5, 4, 3)
    np.testing.assert_allclose(k, ref, rtol=1e-12)
    for chunk in (1, 7, 100):
        assert np.array_equal(gating.gate_pairwise(x1, x2, c1, c2, chunk_size=chunk,
                                                      return_statistic=True)[1], k)


def test_gate_pairwise_bad_input_named():
    eye = np.eye(2)[None]
    x = np.zeros((1, 2))
    cases = [
        (ValueError, r"`x2` must have shape \(\.\.\., n, 3\)", dict(x1=np.zeros((1, 3)))),
        (ValueError, "`x2` must be finite", dict(x2=np.array([[np.nan, 0.0]]))),
        (ValueError, "`cov2` must be finite", dict(cov2=np.full((1, 2, 2), np.inf))),
        (ValueError, "`cov1` must be symmetric", dict(cov1=np.array([[[1.0, 0.5], [0.0, 1.0]]]))),
        (ValueError, r"`cov2` must be positive definite.*1 of 1", dict(cov2=-eye)),
        (ValueError, "`cov1` must be positive definite",              # singular to precision
         dict(cov1=np.array([[[1.0, 1 - 1e-14], [1 - 1e-14, 1.0]]]))),
        (ValueError, "one 2x2 matrix per report of `x2`", dict(cov2=np.stack([eye[0]] * 3))),
        (ValueError, "broadcastable leading", dict(x1=np.zeros((3, 1, 2)),
                                                   x2=np.zeros((4, 1, 2)))),
        (ValueError, "`x1` must lie within the numeric domain", dict(x1=np.array([[1e200, 0.0]]))),
        (TypeError, "`chunk_size`", dict(chunk_size=2.0)),
        (ValueError, "`chunk_size`", dict(chunk_size=0)),
        (TypeError, "`x1`", dict(x1="a")),
    ]
    for exc, msg, kw in cases:
        args = dict(x1=x, x2=x, cov1=eye, cov2=eye) | kw
        with pytest.raises(exc, match=msg):
            gating.gate_pairwise(**args)
    assert gating.gate_pairwise(x, np.zeros((0, 2)), eye, np.zeros((0, 2, 2))).shape == (1, 0)
    with pytest.raises(TypeError, match="`return_statistic`"):
        gating.gate_pairwise(x, x, eye, eye, return_statistic="yes")
    with pytest.raises(ValueError, match="`p_false_reject`"):
        gating.gate_pairwise(x, x, eye, eye, p_false_reject=1.0)
    with pytest.raises(ValueError, match="`p_false_reject`"):
        gating.gate_pairwise(x, x, eye, eye, p_false_reject=[0.01, 0.02])
    # a bad covariance deep in a large batch is found
    rng = np.random.default_rng(2)
    c = _random_covs(rng, (500, 4))
    c[377, 2] = [[1.0, 2.0], [2.0, 1.0]]
    xs = rng.normal(size=(500, 4, 2))
    with pytest.raises(ValueError, match=r"`cov2` must be positive definite.*1 of 2000"):
        gating.gate_pairwise(xs, xs, _random_covs(rng, (500, 4)), c)


def test_gate_pairwise_limits_checked_before_allocation():
    eye = np.eye(2)
    # 2e5 x 2e5 pairs of one scene (320 GB of kappa): refused, with the alternative named
    big = np.broadcast_to(np.zeros(2), (200_000, 2))
    cov = np.broadcast_to(eye, (1, 2, 2))
    tracemalloc.start()
    with pytest.raises(ValueError, match=r"refused: \d+ bytes for 40000000000 pairs.*smaller "
                                         r"batches"):
        gating.gate_pairwise(big, big, cov, cov)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 16 * 2**20


def test_gate_pairwise_memory_bounded_by_chunking():
    # kappa (8 B/pair) and the decisions (1 B/pair); everything else per report or per chunk
    rng = np.random.default_rng(5)
    trials, n = 20_000, 10
    x1, x2 = rng.normal(size=(trials, n, 2)), rng.normal(size=(trials, n, 2))
    c1, c2 = _random_covs(rng, (trials, n)), _random_covs(rng, (trials, n))
    tracemalloc.start()
    acc = gating.gate_pairwise(x1, x2, c1, c2)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    pairs = trials * n * n
    assert acc.shape == (trials, n, n)
    # per-report copies: 10 parts x 2 sides x 8 B x trials x n; work: ~20 chunk buffers
    assert peak < 9 * pairs + 2 * 10 * 8 * trials * n + 20 * 8 * 32768 + 2**20, peak


# ============================================================ sparse gating (k-d tree)
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n1=st.integers(0, 60), n2=st.integers(0, 60),
       p=st.floats(1e-6, 0.5), rho=st.floats(-0.95, 0.95), log_scale=st.floats(-3, 3))
def test_gate_sparse_equals_dense_kernel_on_all_pairs(seed, n1, n2, p, rho, log_scale):
    rng = np.random.default_rng(seed)
    side = np.sqrt(max(n1, n2, 1)) * 10.0**(log_scale / 2)
    x1, x2 = rng.uniform(0, side, (n1, 2)), rng.uniform(0, side, (n2, 2))
    s = 10.0**log_scale * np.array([[1.0, rho * 0.7], [rho * 0.7, 0.49]])
    got = gating.gate_sparse(x1, x2, s, p_false_reject=p)
    assert got.shape == (n1, n2)
    # brute force: the dense kernel on every pair (an n1 n2 loop of pairs)
    ii, jj = np.meshgrid(np.arange(n1), np.arange(n2), indexing="ij")
    acc, k = gating.gate_mahalanobis(x1[ii.ravel()], x2[jj.ravel()], s, p_false_reject=p,
                                        return_statistic=True)
    dense = np.zeros((n1, n2), dtype=bool)
    dense[ii.ravel()[acc], jj.ravel()[acc]] = True
    got_coo = got.tocoo()
    mask = np.zeros((n1, n2), dtype=bool)
    mask[got_coo.row, got_coo.col] = True
    assert np.array_equal(mask, dense)
    assert got.nnz == np.count_nonzero(dense)              # explicit zeros included
    vals = np.zeros((n1, n2))
    vals[got_coo.row, got_coo.col] = got_coo.data
    assert np.array_equal(vals[dense], k.reshape(n1, n2)[dense])
    np.testing.assert_allclose(vals[dense], proximity.proximity_gaussian(
        x1[ii[dense]], x2[jj[dense]], s / 2, s / 2), rtol=1e-12)


def test_gate_sparse_explicit_zero_limits_and_errors():
    k = gating.gate_sparse([[1.0, 2.0]], [[1.0, 2.0], [50.0, 0.0]], np.eye(2))
    assert k.nnz == 1 and k.toarray().tolist() == [[0.0, 0.0]]    # coincident: stored 0
    assert gating.gate_sparse(np.zeros((0, 2)), np.zeros((3, 2)), np.eye(2)).shape == (0, 3)
    # all pairs of 12 000 coincident reports are candidates (1.44e8 pairs): counted, refused
    x = np.zeros((12_000, 2))
    tracemalloc.start()
    with pytest.raises(ValueError, match=r"refused: \d+ bytes for 144000000 candidate pairs"):
        gating.gate_sparse(x, x, np.eye(2))
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 64 * 2**20
    with pytest.raises(ValueError, match="`cov` must be positive definite"):
        gating.gate_sparse(np.zeros((2, 2)), np.zeros((2, 2)), -np.eye(2))
    with pytest.raises(ValueError, match="`cov` must have shape"):
        gating.gate_sparse(np.zeros((2, 2)), np.zeros((2, 2)), np.eye(3))
    with pytest.raises(ValueError, match="`x1` and `x2` must have shapes"):
        gating.gate_sparse(np.zeros((2, 2, 2)), np.zeros((2, 2)), np.eye(2))
    with pytest.raises(ValueError, match="`x1` must lie within the numeric domain"):
        gating.gate_sparse([[1e300, 0.0]], [[0.0, 0.0]], np.eye(2))
    with pytest.raises(ValueError, match="`cov` must have every variance within"):
        gating.gate_sparse([[1.0, 0.0]], [[0.0, 0.0]], 1e-300 * np.eye(2))
    with pytest.raises(ValueError, match="`p_false_reject`"):
        gating.gate_sparse(np.zeros((2, 2)), np.zeros((2, 2)), np.eye(2), p_false_reject=0.0)



@pytest.mark.parametrize("d", [1, 3, 4])
def test_gates_in_any_dimension_match_the_chi_square_rule(d):
    """The three gates in d dimensions: kappa by an explicit inverse, the threshold by
    scipy.stats.chi2 with d degrees of freedom (the reference is not the gate's kernel)."""
    rng = np.random.default_rng(30 + d)
    n1, n2, p = 7, 9, 0.05
    x1, x2 = rng.normal(size=(n1, d)) * 2.0, rng.normal(size=(n2, d)) * 2.0
    a = rng.normal(size=(d, d))
    S = a @ a.T + d * np.eye(d)
    c1 = np.stack([0.3 * S] * n1)
    c2 = np.stack([0.7 * S] * n2)
    diff = x1[:, None, :] - x2[None, :, :]
    kappa = np.einsum("ijk,kl,ijl->ij", diff, np.linalg.inv(S), diff)
    gamma = stats.chi2.isf(p, d)
    acc, k = gating.gate_pairwise(x1, x2, c1, c2, p_false_reject=p, return_statistic=True)
    np.testing.assert_allclose(k, kappa, rtol=1e-10)
    np.testing.assert_array_equal(acc, kappa < gamma)
    assert 0 < acc.sum() < acc.size                       # both decisions occur
    i, j = np.meshgrid(np.arange(n1), np.arange(n2), indexing="ij")
    acc2, k2 = gating.gate_mahalanobis(x1[i.ravel()], x2[j.ravel()], S, p_false_reject=p,
                                       return_statistic=True)
    np.testing.assert_allclose(k2, kappa.ravel(), rtol=1e-10)
    np.testing.assert_array_equal(acc2, kappa.ravel() < gamma)
    sp = gating.gate_sparse(x1, x2, S, p_false_reject=p).toarray()
    np.testing.assert_array_equal(sp > 0, (kappa < gamma) & (kappa > 0))
    np.testing.assert_allclose(sp[kappa < gamma], kappa[kappa < gamma], rtol=1e-10)


def test_gates_refuse_mixed_dimensions_by_name():
    with pytest.raises(ValueError, match=r"`x1` and `x2` must have shapes \(n1, d\)"):
        gating.gate_sparse(np.zeros((2, 3)), np.zeros((2, 2)), np.eye(3))
    with pytest.raises(ValueError, match=r"`x1` and `x2` must both have shape \(N, d\)"):
        gating.gate_mahalanobis(np.zeros((2, 3)), np.zeros((2, 2)), np.eye(3))
    with pytest.raises(ValueError, match=r"`cov` must have shape \(3, 3\)|`cov`"):
        gating.gate_mahalanobis(np.zeros((2, 3)), np.zeros((2, 3)), np.eye(2))
