"""engine.linalg: the one squared Mahalanobis distance, against independent routes.

References are computed per pair with ``np.linalg.solve`` (LU, a different
factorisation), with ``scipy.spatial.distance.mahalanobis`` (which takes the
inverse), in exact rational arithmetic, or in closed form — never with the
function under test. No timed assertions: the speed claim lives in
``benchmarks/bench_mahalanobis.py``.
"""

from __future__ import annotations

import importlib
import importlib.util
import subprocess
import sys
import tracemalloc
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import distance

from radarfusion_ref.engine import linalg


def _spd(rng, k, batch=(), cond_max=1.0):
    """Random SPD k x k matrices: random orientation, scale over 6 decades, condition <= cond_max."""
    q, _ = np.linalg.qr(rng.normal(size=(*batch, k, k)))
    scale = 10.0 ** rng.uniform(-3, 3, (*batch, 1))
    lam = scale * 10.0 ** (-rng.uniform(0, np.log10(cond_max), (*batch, k))) if cond_max > 1 \
        else np.broadcast_to(scale, (*batch, k))
    out = q * lam[..., None, :] @ np.swapaxes(q, -1, -2)
    return 0.5 * (out + np.swapaxes(out, -1, -2))


def _by_solve(d, s):
    """d^T S^-1 d per pair by np.linalg.solve (an independent route)."""
    return float(d @ np.linalg.solve(s, d))


# ---------------------------------------------------------------- pointwise
@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 6), n=st.integers(1, 30),
       log_cond=st.floats(0.0, 8.0))
def test_pointwise_against_solve_and_scipy(seed, k, n, log_cond):
    rng = np.random.default_rng(seed)
    s = _spd(rng, k, (n,), 10.0**log_cond)
    d = rng.normal(size=(n, k)) * np.sqrt(np.diagonal(s, axis1=-2, axis2=-1))
    got, logdet = linalg.mahalanobis_sq(d, s, return_logdet=True)
    got = np.atleast_1d(got)
    cond = np.linalg.cond(s)
    for i in range(n):
        ref = _by_solve(d[i], s[i])
        ref_sp = distance.mahalanobis(d[i], np.zeros(k), np.linalg.inv(s[i])) ** 2
        assert abs(got[i] - ref) <= 64 * k * 2.2e-16 * cond[i] * ref + 1e-300
        assert abs(got[i] - ref_sp) <= 64 * k * 2.2e-16 * cond[i] * ref + 1e-300
    # ln det S = sum_j ln D_j: each pivot carries a relative error up to about eps cond(S)
    np.testing.assert_allclose(logdet, np.linalg.slogdet(s)[1], rtol=0,
                               atol=64 * k * 2.2e-16 * cond.max() + 1e-12)


def test_pointwise_closed_forms_and_broadcasting():
    assert linalg.mahalanobis_sq([3.0], [[4.0]]) == 2.25
    assert linalg.mahalanobis_sq([1.0, 1.0], np.diag([4.0, 0.25])) == 4.25
    # d (5, 2) against one shared covariance, and one d against a stack of covariances
    rng = np.random.default_rng(1)
    s = _spd(rng, 2)
    d = rng.normal(size=(5, 2))
    got = linalg.mahalanobis_sq(d, s)
    assert got.shape == (5,)
    np.testing.assert_allclose(got, [_by_solve(x, s) for x in d], rtol=1e-13)
    stack = _spd(rng, 2, (4, 1))
    got = linalg.mahalanobis_sq(d, stack)                    # (5,) with (4, 1): (4, 5)
    assert got.shape == (4, 5)
    for i in range(4):
        np.testing.assert_allclose(got[i], [_by_solve(x, stack[i, 0]) for x in d], rtol=1e-12)


def test_near_singular_accepted_to_the_rule_and_refused_beyond():
    # correlation rho: 1 - rho^2 just above and below the rule's 1e-12
    for one_minus, ok in ((5e-12, True), (2e-13, False)):
        rho = np.sqrt(1 - one_minus)
        s = np.array([[1.0, rho], [rho, 1.0]]) * 1e4
        d = np.array([1.0, -1.0])
        if ok:
            # exact rational reference of the float matrix actually passed
            a, b, c = (Fraction(v) for v in (s[0, 0], s[0, 1], s[1, 1]))
            ref = (c + 2 * b + a) / (a * c - b * b)
            got = linalg.mahalanobis_sq(d, s)
            assert abs(got - float(ref)) <= 1e-3 * float(ref)   # cond(S) about 1e12
            assert bool(linalg.is_positive_definite(s))
        else:
            assert not linalg.is_positive_definite(s)
            with pytest.raises(ValueError, match="`cov` must be positive definite and not "
                                                 "singular to working precision"):
                linalg.mahalanobis_sq(d, s)


def test_is_positive_definite_agrees_with_eigenvalues_away_from_the_threshold():
    rng = np.random.default_rng(3)
    for k in (1, 2, 3, 5, 9, 12):                            # both the unrolled and LAPACK paths
        a = rng.normal(size=(300, k, k))
        c = a @ np.swapaxes(a, -1, -2) + 0.05 * np.eye(k)
        c[::2] -= 0.5 * np.eye(k) * np.abs(c[::2]).max(axis=(-2, -1))[:, None, None]
        ev = np.linalg.eigvalsh(c)
        outer = np.abs(np.einsum("...ii,...jj->...ij", c, c))   # c_ii c_jj
        corr_min = np.linalg.eigvalsh(c / np.sqrt(outer)).min(axis=-1)   # smallest eigenvalue of R
        got = np.asarray(linalg.is_positive_definite(c))
        clear = (ev.min(axis=-1) < 0) | (corr_min > 1e-9)
        assert np.array_equal(got[clear], (ev.min(axis=-1) > 0)[clear])
    assert not linalg.is_positive_definite([[1.0, 0.5], [0.4, 1.0]])           # not symmetric
    assert not linalg.is_positive_definite([[np.nan, 0.0], [0.0, 1.0]])
    np.testing.assert_allclose(linalg.cholesky([[4.0, 2.0], [2.0, 2.0]]), [[2.0, 0.0], [1.0, 1.0]])


def test_pointwise_domain_and_bad_input_name_the_argument():
    big = 2.0**150
    assert linalg.mahalanobis_sq([big], [[big]]) == big       # the domain's edge: exact
    cases = [
        (ValueError, "`d` must lie within the numeric domain", dict(d=[1e50, 0.0])),
        (ValueError, "`cov` must have every variance within", dict(cov=1e-50 * np.eye(2))),
        (ValueError, "`d` must be finite", dict(d=[np.nan, 0.0])),
        (ValueError, "`cov` must be symmetric", dict(cov=[[1.0, 0.5], [0.0, 1.0]])),
        (ValueError, r"`cov` must have shape \(\.\.\., 2, 2\)", dict(cov=np.eye(3))),
        (ValueError, "`d`, `cov` must have broadcastable", dict(d=np.zeros((3, 2)),
                                                                cov=np.stack([np.eye(2)] * 4))),
        (TypeError, "`d`", dict(d="x")),
        (TypeError, "`cov`", dict(cov=None)),
        (TypeError, "`return_logdet`", dict(return_logdet=1)),
    ]
    for exc, msg, kw in cases:
        args = dict(d=[1.0, 0.0], cov=np.eye(2)) | kw
        with pytest.raises(exc, match=msg):
            linalg.mahalanobis_sq(**args)
    with pytest.raises(TypeError, match="`name`"):
        linalg.cholesky(np.eye(2), name=3)
    with pytest.raises(ValueError, match="`P_pred` must be positive definite"):
        linalg.cholesky(-np.eye(2), name="P_pred")


# ---------------------------------------------------------------- pairwise
def _pairs_by_loop(x1, x2, c1, c2):
    """kappa_ij by np.linalg.solve, one pair at a time (the pure-Python reference)."""
    out = np.empty((len(x1), len(x2)))
    for i in range(len(x1)):
        for j in range(len(x2)):
            out[i, j] = _by_solve(x1[i] - x2[j], c1[i] + c2[j])
    return out


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.integers(1, 4),
       lead=st.sampled_from([(), (1,), (3,), (40,), (2, 3)]),
       n1=st.integers(1, 7), n2=st.integers(1, 40), log_cond=st.floats(0.0, 6.0),
       chunk=st.integers(1, 700))
def test_pairwise_against_solve_per_pair(seed, k, lead, n1, n2, log_cond, chunk):
    rng = np.random.default_rng(seed)
    x1, x2 = rng.normal(size=(*lead, n1, k)) * 10, rng.normal(size=(*lead, n2, k)) * 10
    c1 = _spd(rng, k, (*lead, n1), 10.0**log_cond)
    c2 = _spd(rng, k, (*lead, n2), 10.0**log_cond)
    got, logdet = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2, return_logdet=True)
    assert got.shape == logdet.shape == (*lead, n1, n2)
    assert np.array_equal(linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2, chunk_size=chunk), got)
    s = c1[..., :, None, :, :] + c2[..., None, :, :, :]
    cond = np.linalg.cond(s)
    flat = (-1, n1, n2)
    for t, (a, b, p, q) in enumerate(zip(x1.reshape(-1, n1, k), x2.reshape(-1, n2, k),
                                         c1.reshape(-1, n1, k, k), c2.reshape(-1, n2, k, k),
                                         strict=True)):
        ref = _pairs_by_loop(a, b, p, q)
        tol = 64 * k * 2.2e-16 * cond.reshape(flat)[t] * ref + 1e-300
        np.testing.assert_array_less(np.abs(got.reshape(flat)[t] - ref), tol)
    np.testing.assert_allclose(logdet, np.linalg.slogdet(s)[1], rtol=0,
                               atol=64 * k * 2.2e-16 * cond.max() + 1e-12)


def test_pairwise_2d_against_exact_rational_arithmetic_near_singular():
    rng = np.random.default_rng(9)
    x1, x2 = rng.normal(size=(4, 2)), rng.normal(size=(5, 2))
    c1, c2 = _spd(rng, 2, (4,), 1e9), _spd(rng, 2, (5,), 1e9)
    got = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)
    for i in range(4):
        for j in range(5):
            d = [Fraction(v) for v in x1[i] - x2[j]]
            s = c1[i] + c2[j]
            a, b, c = Fraction(s[0, 0]), Fraction(s[0, 1]), Fraction(s[1, 1])
            exact = (c * d[0] ** 2 - 2 * b * d[0] * d[1] + a * d[1] ** 2) / (a * c - b * b)
            cond = np.linalg.cond(s)
            assert abs(got[i, j] - float(exact)) <= 64 * 2.2e-16 * cond * float(exact)


def test_pairwise_shared_and_broadcast_covariances():
    rng = np.random.default_rng(11)
    x1, x2 = rng.normal(size=(5, 4, 3)), rng.normal(size=(1, 6, 3))
    c1 = _spd(rng, 3)                                        # one (k, k) for every report
    c2 = _spd(rng, 3, (5, 1), 100.0)                         # one per trial, shared by reports
    got = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)
    assert got.shape == (5, 4, 6)
    for t in range(5):
        ref = _pairs_by_loop(x1[t], x2[0], np.broadcast_to(c1, (4, 3, 3)),
                             np.broadcast_to(c2[t], (6, 3, 3)))
        np.testing.assert_allclose(got[t], ref, rtol=1e-11)
    # the trial-last layout (many trials, few reports) gives the same values
    xs1, xs2 = rng.normal(size=(300, 3, 2)), rng.normal(size=(300, 2, 2))
    cs1, cs2 = _spd(rng, 2, (300, 3), 10.0), _spd(rng, 2, (300, 2), 10.0)
    got = linalg.mahalanobis_sq_pairwise(xs1, xs2, cs1, cs2)
    for t in (0, 157, 299):
        np.testing.assert_allclose(got[t], _pairs_by_loop(xs1[t], xs2[t], cs1[t], cs2[t]),
                                   rtol=1e-11)


def test_pairwise_bad_input_names_the_argument():
    eye = np.eye(2)[None]
    x = np.zeros((1, 2))
    cases = [
        (ValueError, r"`x2` must have shape \(\.\.\., n, 2\)", dict(x2=np.zeros((1, 3)))),
        (ValueError, "`x1` must have at least 2", dict(x1=np.zeros(2))),
        (ValueError, "`x2` must be finite", dict(x2=np.array([[np.nan, 0.0]]))),
        (ValueError, "`x1` must lie within the numeric domain", dict(x1=np.array([[1e46, 0.0]]))),
        (ValueError, "`cov1` must be symmetric", dict(cov1=np.array([[[1.0, 0.5], [0.0, 1.0]]]))),
        (ValueError, r"`cov2` must be positive definite.*1 of 1", dict(cov2=-eye)),
        (ValueError, "`cov1` must have every variance within", dict(cov1=1e60 * eye)),
        (ValueError, "one 2x2 matrix per report of `x2`", dict(cov2=np.stack([eye[0]] * 3))),
        (ValueError, "broadcastable leading", dict(x1=np.zeros((3, 1, 2)),
                                                   x2=np.zeros((4, 1, 2)))),
        (TypeError, "`chunk_size`", dict(chunk_size=2.0)),
        (ValueError, "`chunk_size`", dict(chunk_size=0)),
        (TypeError, "`cov2`", dict(cov2="eye")),
        (TypeError, "`return_logdet`", dict(return_logdet="yes")),
    ]
    for exc, msg, kw in cases:
        args = dict(x1=x, x2=x, cov1=eye, cov2=eye) | kw
        with pytest.raises(exc, match=msg):
            linalg.mahalanobis_sq_pairwise(**args)
    k, ld = linalg.mahalanobis_sq_pairwise(np.zeros((3, 0, 2)), np.zeros((3, 2, 2)),
                                           np.zeros((3, 0, 2, 2)), np.eye(2),
                                           return_logdet=True)
    assert k.shape == ld.shape == (3, 0, 2)


def test_pairwise_refuses_before_allocating():
    big = np.broadcast_to(np.zeros(2), (200_000, 2))
    tracemalloc.start()
    with pytest.raises(ValueError, match=r"refused: \d+ bytes for 40000000000 pairs"):
        linalg.mahalanobis_sq_pairwise(big, big, np.eye(2), np.eye(2))
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 16 * 2**20


# ---------------------------------------------------------------- pairwise: layouts and chunks
# the shape families of the two loop orders: many trials of few reports (trials innermost,
# including the tiniest scenes) and few trials of many reports (radar-2 reports innermost)
_FAMILIES = [(400, 2, 2), (300, 3, 4), (200, 10, 10), (3, 40, 70), (1, 120, 90)]


def _pairs_by_solve(x1, x2, c1, c2):
    """kappa of every pair by batched np.linalg.solve (LU) on the materialised sums."""
    d = x1[..., :, None, :] - x2[..., None, :, :]
    s = c1[..., :, None, :, :] + c2[..., None, :, :, :]
    return np.einsum("...i,...i->...", d, np.linalg.solve(s, d[..., None])[..., 0]), s


@pytest.mark.parametrize("k", [2, 3])
@pytest.mark.parametrize(("trials", "n1", "n2"), _FAMILIES)
def test_pairwise_every_layout_against_solve_ill_conditioned(k, trials, n1, n2):
    rng = np.random.default_rng(100 * k + n1)
    x1, x2 = rng.normal(size=(trials, n1, k)) * 10, rng.normal(size=(trials, n2, k)) * 10
    c1 = _spd(rng, k, (trials, n1), 1e8)                  # condition numbers up to 1e8
    c2 = _spd(rng, k, (trials, n2), 1e8)
    got, logdet = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2, return_logdet=True)
    ref, s = _pairs_by_solve(x1, x2, c1, c2)
    cond = np.linalg.cond(s)
    assert got.shape == (trials, n1, n2) and cond.max() > 1e3
    assert np.all(np.abs(got - ref) <= 64 * k * 2.2e-16 * cond * ref + 1e-300)
    assert np.all(np.abs(logdet - np.linalg.slogdet(s)[1]) <= 64 * k * 2.2e-16 * cond + 1e-12)


@pytest.mark.parametrize("k", [1, 2, 3, 4])
@pytest.mark.parametrize(("trials", "n1", "n2"), [(150, 3, 2), (2, 20, 40)])
def test_pairwise_bit_for_bit_across_chunkings(k, trials, n1, n2):
    rng = np.random.default_rng(7 + k)
    x1, x2 = rng.normal(size=(trials, n1, k)), rng.normal(size=(trials, n2, k))
    c1, c2 = _spd(rng, k, (trials, n1), 1e6), _spd(rng, k, (trials, n2), 1e6)
    kappa, logdet = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2, return_logdet=True)
    assert np.all(np.isfinite(kappa)) and np.all(kappa > 0)
    for chunk in (1, 2, 7, 97, 1000, 4096, 65536, 10**7):
        got, ld = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2, return_logdet=True,
                                                 chunk_size=chunk)
        assert np.array_equal(got, kappa) and np.array_equal(ld, logdet), chunk
    # trial by trial (one trial: the radar-2 reports innermost) gives the same bits as the
    # batch, whichever loop order the batch took
    for t in (0, trials // 2, trials - 1):
        one = linalg.mahalanobis_sq_pairwise(x1[t], x2[t], c1[t], c2[t], chunk_size=5)
        assert np.array_equal(one, kappa[t])


def test_pairwise_covariance_rule_in_runs_keeps_the_whole_argument_message():
    """A long stack is checked run by run; a bad matrix in a later run gets the message (and
    count) the rule gives for the whole argument, as for a short stack."""
    from radarfusion_ref.engine import validation
    n = 3 * 32768 + 5                                       # more than two runs of the door
    x1, x2 = np.zeros((n, 2)), np.zeros((1, 2))
    good = np.broadcast_to(np.eye(2), (n, 2, 2))
    cases = {"be symmetric": [[1.0, 0.5], [0.0, 1.0]],
             "be positive definite": [[1.0, 2.0], [2.0, 1.0]],
             "variance within the numeric domain": [[1e-60, 0.0], [0.0, 1.0]]}
    for what, bad in cases.items():
        cov1 = good.copy()
        cov1[n - 2] = bad                                   # in the last run
        with pytest.raises(ValueError, match=f"`cov1` must .*{what}") as whole:
            validation.as_covariance(cov1, "cov1", dim=2)
        with pytest.raises(ValueError, match="`cov1`") as got:
            linalg.mahalanobis_sq_pairwise(x1, x2, cov1, np.eye(2))
        assert str(got.value) == str(whole.value)
    ok = linalg.mahalanobis_sq_pairwise(x1[:4], x2, np.ascontiguousarray(good[:4]), np.eye(2))
    assert np.array_equal(ok, np.zeros((4, 1)))


@pytest.mark.parametrize(("trials", "n1", "n2"), [(1, 50, 3), (3, 200, 70), (100, 9, 2)])
def test_pairwise_swapped_sides_give_the_transposed_bits(trials, n1, n2):
    """kappa_ij = kappa_ji with the sides exchanged, to the bit: the kernel may run either
    report axis innermost (the differences change sign exactly, the sums are the same)."""
    rng = np.random.default_rng(n1)
    x1, x2 = rng.normal(size=(trials, n1, 3)), rng.normal(size=(trials, n2, 3))
    c1, c2 = _spd(rng, 3, (trials, n1), 1e4), _spd(rng, 3, (trials, n2), 1e4)
    kappa, logdet = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2, return_logdet=True)
    back, ld = linalg.mahalanobis_sq_pairwise(x2, x1, c2, c1, return_logdet=True)
    assert kappa.shape == (trials, n1, n2) and np.all(kappa > 0)
    assert np.array_equal(back.swapaxes(-1, -2), kappa)
    assert np.array_equal(ld.swapaxes(-1, -2), logdet)
    ref, _ = _pairs_by_solve(x1[:1], x2[:1], c1[:1], c2[:1])
    np.testing.assert_allclose(kappa[:1], ref, rtol=1e-8)


@pytest.mark.parametrize("k", [2, 3])
@pytest.mark.parametrize(("trials", "n1", "n2"), [(300, 3, 5), (2, 40, 30)])
def test_pairwise_shared_covariances_give_the_bits_of_per_report_copies(k, trials, n1, n2):
    """A covariance shared by every report (or trial) is factorised once per block, not per
    pair: the values are those of the same matrices copied to every report, to the bit."""
    rng = np.random.default_rng(k + n1)
    x1, x2 = rng.normal(size=(trials, n1, k)), rng.normal(size=(trials, n2, k))
    shared = [(_spd(rng, k, (), 1e3), _spd(rng, k, (), 1e3)),                # one per side
              (_spd(rng, k, (trials, 1), 1e3), _spd(rng, k, (), 1e3)),       # one per trial
              (_spd(rng, k, (1, n1), 1e3), _spd(rng, k, (trials, n2), 1e3))]  # one per report
    for c1, c2 in shared:
        got, ld = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2, return_logdet=True)
        full1 = np.broadcast_to(c1, (trials, n1, k, k)).copy()
        full2 = np.broadcast_to(c2, (trials, n2, k, k)).copy()
        ref, ref_ld = linalg.mahalanobis_sq_pairwise(x1, x2, full1, full2, return_logdet=True)
        assert np.array_equal(got, ref) and np.array_equal(ld, ref_ld)
        by_solve, _ = _pairs_by_solve(x1[:2], x2[:2], full1[:2], full2[:2])
        np.testing.assert_allclose(got[:2], by_solve, rtol=1e-9)
        assert np.array_equal(linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2, chunk_size=7), got)


# ---------------------------------------------------------------- the compiled route (numba)
needs_numba = pytest.mark.skipif(
    importlib.util.find_spec("numba") is None,
    reason="numba (the `fast` extra) is not installed: no compiled route to test")


@pytest.fixture
def routes(monkeypatch):
    """Call mahalanobis_sq_pairwise by both routes: returns (compiled, numpy) results.

    Fails if the compiled route did not compute the result itself (fell back to numpy).
    """
    calls = []
    real = linalg._compiled_pairs

    def spy(*args, **kwargs):
        out = real(*args, **kwargs)
        calls.append(out is not None)
        return out

    monkeypatch.setattr(linalg, "_compiled_pairs", spy)

    def both(*args, **kwargs):
        monkeypatch.delenv(linalg.NO_COMPILED_ENV, raising=False)
        calls.clear()
        fast = linalg.mahalanobis_sq_pairwise(*args, **kwargs)
        assert calls[-1:] == [True], "the compiled route did not run"
        monkeypatch.setenv(linalg.NO_COMPILED_ENV, "1")
        calls.clear()
        slow = linalg.mahalanobis_sq_pairwise(*args, **kwargs)
        assert not calls, "the numpy route called the compiled kernels"
        monkeypatch.delenv(linalg.NO_COMPILED_ENV)
        return fast, slow

    return both


@needs_numba
@pytest.mark.parametrize("k", [2, 3])
@pytest.mark.parametrize(("trials", "n1", "n2"),
                         [(400, 2, 2), (300, 3, 2), (200, 1, 3), (150, 10, 10), (3, 40, 70),
                          (1, 120, 90), (2, 90, 5)])
def test_compiled_route_gives_the_numpy_bits(routes, k, trials, n1, n2):
    """Every layout (trials innermost, either report axis innermost), per-report, per-trial
    and shared covariances with condition numbers up to 1e8: the same bits as the numpy
    route, whatever the chunk, and close to np.linalg.solve."""
    rng = np.random.default_rng(1000 * k + 10 * n1 + n2)
    x1, x2 = rng.normal(size=(trials, n1, k)) * 10, rng.normal(size=(trials, n2, k)) * 10
    per_report = (_spd(rng, k, (trials, n1), 1e8), _spd(rng, k, (trials, n2), 1e8))
    for c1, c2 in [per_report,
                   (_spd(rng, k, (), 1e3), _spd(rng, k, (), 1e3)),                  # per radar
                   (_spd(rng, k, (trials, 1), 1e3), per_report[1]),                 # per trial
                   (per_report[0], _spd(rng, k, (1, n2), 1e3))]:                    # per report
        fast, slow = routes(x1, x2, c1, c2)
        assert fast.shape == (trials, n1, n2) and np.array_equal(fast, slow)
        fast7, _ = routes(x1, x2, c1, c2, chunk_size=7)
        assert np.array_equal(fast7, fast)
    ref, s = _pairs_by_solve(x1[:2], x2[:2], *(c[:2] for c in per_report))
    got = routes(x1[:2], x2[:2], *(c[:2] for c in per_report))[0]
    assert np.all(np.abs(got - ref) <= 64 * k * 2.2e-16 * np.linalg.cond(s) * ref)


@needs_numba
def test_compiled_route_other_forms_of_input(routes):
    """Lists, float32, non-contiguous views and partly broadcast trial axes: the same bits."""
    rng = np.random.default_rng(5)
    x1, x2 = rng.normal(size=(2, 1, 4, 3)), rng.normal(size=(1, 3, 5, 3))
    c1, c2 = _spd(rng, 3, (2, 1, 4), 1e4), _spd(rng, 3, (3, 5), 1e4)
    fast, slow = routes(x1, x2, c1, c2)
    assert fast.shape == (2, 3, 4, 5) and np.array_equal(fast, slow)
    for args in [(x1.tolist(), x2, c1, c2.tolist()),
                 (x1.astype(np.float32), x2, c1, c2),
                 (np.asfortranarray(x1), x2[..., ::-1][..., ::-1], c1.swapaxes(-1, -2), c2)]:
        fast, slow = routes(*args)
        assert np.array_equal(fast, slow)
    single = routes(x1[0, 0], x2[0, 0], c1[0, 0], c2[0])     # one trial, no leading axes
    assert single[0].shape == (4, 5) and np.array_equal(*single)


@needs_numba
@pytest.mark.parametrize("k", [2, 3])
def test_compiled_rule_is_the_covariance_rule(k):
    """The compiled covariance check accepts exactly the matrices as_covariance accepts:
    pivots of the correlation matrix on both sides of 1e-12 and of the kernels' 2e-3 short
    cut, asymmetry on both sides of 1e-9, variances at the ends of the domain, NaN, inf."""
    from radarfusion_ref.engine import _compiled, validation
    rng = np.random.default_rng(k)
    n = 3000
    # smallest eigenvalue 10**u: pivots around the rule's 1e-12 and the kernels' 2e-3
    q, _ = np.linalg.qr(rng.normal(size=(n, k, k)))
    lam = np.ones((n, k))
    lam[:, 0] = 10.0 ** np.concatenate([rng.uniform(-14.5, -11.5, n // 2),
                                        rng.uniform(-4, 0, n - n // 2)])
    c = q * lam[:, None, :] @ q.swapaxes(-1, -2)
    c = 0.5 * (c + c.swapaxes(-1, -2))
    r = rng.normal(size=(n, k))
    c *= np.exp(r[:, :, None] + r[:, None, :])                 # any scale per coordinate
    c[:200, 1, 0] += c[:200, 0, 0] * 10.0 ** rng.uniform(-10, -8, 200)     # near asymmetry
    c[200:300] *= 2.0 ** rng.choice([-150.5, -149.5, 149.5, 150.5], (100, 1, 1)) / np.max(
        np.diagonal(c[200:300], axis1=-2, axis2=-1), axis=-1)[:, None, None]
    # correlations whose first pivot 1 - r^2 lies within 0.1 % of 1e-12
    r = np.sqrt(1.0 - 1e-12 * (1.0 + rng.uniform(-1e-3, 1e-3, 400)))
    c[2600:] = np.eye(k)
    c[2600:, 1, 0] = c[2600:, 0, 1] = r * 3.0
    c[2600:, 0, 0], c[2600:, 1, 1] = 9.0, 1.0
    c[300, 0, 0], c[301, 1, 0], c[302, 0, 1], c[303, 1, 1] = np.nan, np.inf, 1e300, -1.0
    c[304, 1, 0] = c[304, 0, 1] = 1e200
    rule = _compiled.rule2 if k == 2 else _compiled.rule3
    got = np.array([rule(m.reshape(1, k * k)) for m in c])
    var = np.diagonal(c, axis1=-2, axis2=-1)
    with np.errstate(invalid="ignore"):
        want = (np.all(np.isfinite(c), axis=(-2, -1)) & validation._symmetric_mask(c)
                & validation._pd_mask(c) & np.all((var >= 2.0**-150) & (var <= 2.0**150), -1))
    assert 500 < np.count_nonzero(want) < n - 500          # both answers well represented
    assert 50 < np.count_nonzero(want[2600:]) < 350
    assert np.array_equal(got, want)
    for i in range(0, n, 97):                               # and as_covariance itself
        try:
            validation.as_covariance(c[i], "c")
            accepted = True
        except ValueError:
            accepted = False
        assert accepted == got[i], i
    assert rule(c[want].reshape(-1, k * k)) and not rule(c.reshape(-1, k * k))
    for bad in (np.nan, np.inf, -np.inf):                   # a non-finite entry anywhere
        for i in range(k * k):
            m = np.eye(k).reshape(1, k * k)
            m[0, i] = bad
            assert not rule(m), (bad, i)


@needs_numba
def test_compiled_route_refuses_bad_input_with_the_numpy_message(monkeypatch):
    rng = np.random.default_rng(3)
    trials, n = 400, 2                                      # several blocks of trials
    x = rng.normal(size=(trials, n, 3))
    c = _spd(rng, 3, (trials, n), 1e3)

    def bad(where, value):
        out = c.copy()
        out[where] = value
        return out

    sym = bad((350, 1, 0, 2), c[350, 1, 0, 2] + 1e-6 * c[350, 1, 0, 0])
    cases = [dict(cov1=sym), dict(cov2=bad((399, 0), -np.eye(3))),
             dict(cov2=bad((0, 1, 1, 1), np.nan)), dict(cov1=bad((5, 0), 1e-50 * np.eye(3))),
             dict(cov1=np.ones((3, 3))), dict(cov2=np.diag([1.0, 1.0, 0.0])),
             dict(cov2=c[:, :1].copy() * [1, 1, -1]), dict(x1=bad_x(x, (200, 1, 2), np.inf)),
             dict(x2=bad_x(x, (399, 0, 0), 1e46)), dict(cov1=c[..., :2, :2]),
             dict(cov2=c[:, :1].repeat(3, axis=1)), dict(x1=x[:3]),
             dict(chunk_size=0), dict(chunk_size=1.5)]
    for kw in cases:
        args = dict(x1=x, x2=x, cov1=c, cov2=c) | kw
        messages = []
        for env in ("0", "1"):
            monkeypatch.setenv(linalg.NO_COMPILED_ENV, env)
            with pytest.raises((ValueError, TypeError)) as err:
                linalg.mahalanobis_sq_pairwise(**args)
            messages.append((type(err.value), str(err.value)))
        assert messages[0] == messages[1], kw
        assert "`" in messages[0][1]


def bad_x(x, where, value):
    out = x.copy()
    out[where] = value
    return out


@needs_numba
def test_compiled_route_switch_and_missing_numba(monkeypatch):
    """RADARFUSION_NO_COMPILED=1 selects the numpy route; without numba the numpy route
    runs; both give the compiled route's values."""
    rng = np.random.default_rng(8)
    x1, x2 = rng.normal(size=(50, 3, 2)), rng.normal(size=(50, 4, 2))
    c1, c2 = _spd(rng, 2, (50, 3), 10.0), _spd(rng, 2, (50, 4), 10.0)
    monkeypatch.delenv(linalg.NO_COMPILED_ENV, raising=False)
    assert linalg._compiled_kernels() is not None
    fast = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)

    def refuse(*args, **kwargs):
        raise AssertionError("the compiled kernels were called")

    monkeypatch.setattr(linalg, "_compiled_pairs", refuse)
    for value in ("1", " 1 ", "yes"):
        monkeypatch.setenv(linalg.NO_COMPILED_ENV, value)
        assert linalg._compiled_kernels() is None
        assert np.array_equal(linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2), fast)
    monkeypatch.setenv(linalg.NO_COMPILED_ENV, "0")
    with pytest.raises(AssertionError, match="compiled kernels were called"):
        linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)
    # numba missing: the import fails once, the numpy route runs from then on
    monkeypatch.setattr(linalg, "_COMPILED", [])
    real_import = importlib.import_module

    def no_numba(name, package=None):
        if name.endswith("_compiled"):
            raise ImportError("No module named 'numba'", name="numba")
        return real_import(name, package)

    monkeypatch.setattr(linalg.importlib, "import_module", no_numba)
    assert linalg._compiled_kernels() is None and linalg._COMPILED == [None]
    assert np.array_equal(linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2), fast)


def test_without_numba_the_kernels_module_imports_and_the_numpy_route_runs():
    """numba blocked (importing it raises): the kernels' module still imports (doctests and
    tools walk every module), says so, and the function answers by the numpy route."""
    code = ("import sys\n"
            "sys.modules['numba'] = None\n"
            "import numpy as np\n"
            "from radarfusion_ref.engine import _compiled, linalg\n"
            "eye = np.eye(2)\n"
            "k = linalg.mahalanobis_sq_pairwise([[0.0, 0.0], [1.0, 0.0]], [[2.0, 0.0]],\n"
            "                                   [eye, 3 * eye], eye)\n"
            "print(_compiled.AVAILABLE, linalg._compiled_kernels(), k.ravel().tolist())\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parents[1], timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["False", "None", "[2.0,", "0.25]"]
