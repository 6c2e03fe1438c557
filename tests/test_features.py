"""Tests of radarfusion_ref.features against independent routes.

Oracles: scipy.integrate.quad (type likelihoods and posteriors by numerical
integration over the unknown feature value), sympy (the fused feature and the
proximity measure from the likelihood (9)), explicit matrix inverses and loops
(vector coordinates), scipy.stats chi-square laws (Monte Carlo with binomial
tolerances), and brute-force enumeration.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, stats

from radarfusion_ref import features as F
from radarfusion_ref.engine.montecarlo import binomial_tolerance
from radarfusion_ref.engine.scenes import FEATURE_MODELS, typed_scene

finite = st.floats(-50, 50, allow_nan=False)
pos = st.floats(0.05, 20, allow_nan=False)


def _npdf(x, m, v):
    return np.exp(-0.5 * (x - m) ** 2 / v) / np.sqrt(2 * np.pi * v)


# ----------------------------------------------------------------------------- posterior
@settings(max_examples=60, deadline=None)
@given(f=st.lists(finite, min_size=1, max_size=5), v=st.floats(0, 5),
       means=st.lists(finite, min_size=1, max_size=4), shift=finite, data=st.data())
def test_posterior_sums_to_one_and_is_shift_invariant(f, v, means, shift, data):
    L = len(means)
    tv = data.draw(st.lists(pos, min_size=L, max_size=L))
    w = np.asarray(data.draw(st.lists(st.floats(0.05, 1), min_size=L, max_size=L)))
    priors = w / w.sum()
    p = F.type_posterior(f, v, means, tv, priors)
    assert p.shape == (len(f), L)
    np.testing.assert_allclose(p.sum(axis=-1), 1.0, rtol=1e-12)
    assert np.all((p >= 0) & (p <= 1))
    q = F.type_posterior(np.asarray(f) + shift, v, np.asarray(means) + shift, tv, priors)
    np.testing.assert_allclose(q, p, atol=1e-7)


def test_posterior_far_out_feature_is_clean():
    p = F.type_posterior([-1e6, 1e6], 0.0, [0.0, 1.0], [1.0, 1.0])
    np.testing.assert_array_equal(p, [[1.0, 0.0], [0.0, 1.0]])
    lp = F.type_posterior(1e6, 0.0, [0.0, 1.0], [1.0, 1.0], log=True)
    assert np.all(np.isfinite(lp))


@pytest.mark.parametrize(("f1", "f2", "s1", "s2", "means", "tvars", "priors"), [
    (0.3, 0.9, 0.2, 0.5, [0.0, 1.0, 2.5], [0.3, 0.5, 1.0], [0.2, 0.5, 0.3]),
    (-1.0, 2.0, 1.0, 1.5, [0.0, 1.0], [0.1, 2.0], None),
    (4.0, 4.2, 0.1, 0.1, [3.0, 5.0], [1.0, 1.0], [0.9, 0.1]),
])
def test_two_report_posterior_equals_numerical_integration(f1, f2, s1, s2, means, tvars, priors):
    """P(T_k | Π̂1, Π̂2) ∝ p_k ∫ N(Π̂1; Π, s1²) N(Π̂2; Π, s2²) N(Π; Π_k, σ_k²) dΠ."""
    L = len(means)
    pri = np.full(L, 1 / L) if priors is None else np.asarray(priors)
    lik = np.array([integrate.quad(
        lambda x, m=m, tv=tv: _npdf(f1, x, s1**2) * _npdf(f2, x, s2**2) * _npdf(x, m, tv),
        -np.inf, np.inf)[0] for m, tv in zip(means, tvars, strict=True)])
    want = pri * lik / np.sum(pri * lik)
    fused = F.fused_feature(f1, s1**2, f2, s2**2)
    got = F.type_posterior(fused.value, fused.var, means, tvars, priors)
    np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-12)


def test_pair_posterior_both_models_by_integration():
    """Model 2: P(T_k | Π̂1, Π̂2) ∝ p_k ∫N(Π̂1;Π,v1)N(Π;Π_k,σ_k²)dΠ ∫N(Π̂2;Π',v2)N(Π';Π_k,σ_k²)dΠ'."""
    means, tvars, pri = [0.0, 1.5, 2.0], [0.3, 0.6, 0.2], np.array([0.5, 0.2, 0.3])
    f1, f2, v1, v2 = 0.7, 1.9, 0.2, 0.05

    def g(f, v, m, tv):
        return integrate.quad(lambda x: _npdf(f, x, v) * _npdf(x, m, tv), -np.inf, np.inf)[0]

    lik = np.array([g(f1, v1, m, t) * g(f2, v2, m, t) for m, t in zip(means, tvars, strict=True)])
    want = pri * lik / np.sum(pri * lik)
    got = F.pair_type_posterior(f1, v1, f2, v2, means, tvars, pri, model="spread")
    np.testing.assert_allclose(got, want, rtol=1e-7)
    ff = F.fused_feature(f1, v1, f2, v2)
    np.testing.assert_allclose(F.pair_type_posterior(f1, v1, f2, v2, means, tvars, pri),
                               F.type_posterior(ff.value, ff.var, means, tvars, pri))
    with pytest.raises(ValueError, match="`model`"):
        F.pair_type_posterior(f1, v1, f2, v2, means, tvars, model="one")
    with pytest.raises(ValueError, match="`feature_var1`"):
        F.pair_type_posterior(f1, -v1, f2, v2, means, tvars, model="spread")


@pytest.mark.parametrize(("f", "v", "m", "tv"), [(0.4, 0.3, 1.0, 0.5), (-2.0, 0.0, 0.0, 2.0)])
def test_type_likelihood_equals_convolution(f, v, m, tv):
    if v == 0:
        want = _npdf(f, m, tv)
    else:
        want = integrate.quad(lambda x: _npdf(f, x, v) * _npdf(x, m, tv), -np.inf, np.inf)[0]
    got = F.type_likelihood(f, v, [m], [tv])
    np.testing.assert_allclose(got, [want], rtol=1e-8)
    np.testing.assert_allclose(F.type_likelihood(f, v, [m], [tv], log=True), np.log([want]),
                               rtol=1e-8)


def test_plugin_rule_is_paper_eq13():
    """feature_var=0, uniform priors: P_k = f(Π̃|Π_k) / Σ f(Π̃|Π_l) with f the corrected (8)."""
    means, tvars, f = np.array([0.0, 1.0, 3.0]), np.array([0.5, 1.0, 2.0]), 1.7
    dens = stats.norm.pdf(f, means, np.sqrt(tvars))
    np.testing.assert_allclose(F.type_posterior(f, 0.0, means, tvars), dens / dens.sum())


def test_printed_eq8_makes_eq13_uniform():
    """With the printed (8) (sum over k inside f(Π|T_k)) every type gets 1/L."""
    means, tvars, f = np.array([0.0, 1.0, 3.0]), np.array([0.5, 1.0, 2.0]), 1.7
    printed = np.sum(stats.norm.pdf(f, means, np.sqrt(tvars)))  # the same for every k
    p = np.full(3, printed) / (3 * printed)
    np.testing.assert_allclose(p, 1 / 3)
    assert not np.allclose(F.type_posterior(f, 0.0, means, tvars), 1 / 3)


def test_exact_posterior_is_calibrated_and_plugin_is_not():
    """A calibrated forecaster has E[P_T] = E[Σ_k P_k²]; the plug-in with large v does not."""
    means, tvars = [0.0, 1.0, 2.0], [0.1, 0.1, 0.1]
    s = typed_scene(1, type_means=means, type_vars=tvars, spacing=1.0, sigma1=1.0, sigma2=1.0,
                      feature_sigma1=0.6, feature_sigma2=0.6, trials=40_000, rng=5)
    ff = F.fused_feature(s.features1[:, 0], 0.36, s.features2[:, 0], 0.36)
    t = s.types[:, 0]
    for v, calibrated in ((ff.var, True), (0.0, False)):
        p = F.type_posterior(ff.value, v, means, tvars)
        hit = p[np.arange(t.size), t]
        gap = hit - np.sum(p**2, axis=-1)
        se = gap.std(ddof=1) / np.sqrt(gap.size)
        if calibrated:
            assert abs(gap.mean()) < 5 * se
        else:
            assert gap.mean() < -10 * se


# ----------------------------------------------------------------------------- fusion, proximity
def test_fused_feature_matches_sympy_ml_estimate():
    P, p1, p2 = sp.symbols("Pi Pihat_1 Pihat_2", real=True)
    s1, s2 = sp.symbols("s1 s2", positive=True)
    loglik = -(p1 - P) ** 2 / (2 * s1**2) - (p2 - P) ** 2 / (2 * s2**2)
    est = sp.solve(sp.diff(loglik, P), P)[0]
    var = sp.simplify(sp.diff(est, p1) ** 2 * s1**2 + sp.diff(est, p2) ** 2 * s2**2)
    fe, fv = sp.lambdify((p1, p2, s1, s2), est), sp.lambdify((s1, s2), var)
    rng = np.random.default_rng(0)
    a, b, u, w = rng.normal(size=4), rng.normal(size=4), rng.uniform(0.1, 2, 4), rng.uniform(0.1, 2, 4)
    got = F.fused_feature(a, u**2, b, w**2)
    np.testing.assert_allclose(got.value, fe(a, b, u, w))
    np.testing.assert_allclose(got.var, fv(u, w))


def test_scalar_proximity_is_minus_two_log_profile_likelihood():
    """κ = −2 ln f*(10) + 2 ln(const): derived from (9) with sympy, with the squares."""
    x, P = sp.symbols("x Pi", real=True)
    x1, x2, p1, p2 = sp.symbols("x1 x2 p1 p2", real=True)
    sx1, sx2, sp1, sp2 = sp.symbols("sx1 sx2 sp1 sp2", positive=True)

    def g(z, m, s):
        return sp.exp(-(z - m) ** 2 / (2 * s**2)) / (sp.sqrt(2 * sp.pi) * s)

    lik = g(x1, x, sx1) * g(x2, x, sx2) * g(p1, P, sp1) * g(p2, P, sp2)
    logl = sp.expand_log(sp.log(lik), force=True)
    xt = sp.solve(sp.diff(logl, x), x)[0]
    pt = sp.solve(sp.diff(logl, P), P)[0]
    const = sp.log(1 / (4 * sp.pi**2 * sx1 * sx2 * sp1 * sp2))
    kappa = sp.simplify(-2 * (logl.subs({x: xt, P: pt}) - const))
    f = sp.lambdify((x1, x2, p1, p2, sx1, sx2, sp1, sp2), kappa)
    rng = np.random.default_rng(1)
    a, b, c, d = rng.normal(size=(4, 6))
    s = rng.uniform(0.2, 2, size=(4, 6))
    got = F.combined_proximity(a[:, None], b[:, None], (s[0] ** 2)[:, None, None],
                               (s[1] ** 2)[:, None, None], c, d, s[2] ** 2, s[3] ** 2)
    np.testing.assert_allclose(got.total, f(a, b, c, d, *s), rtol=1e-10)


@settings(max_examples=40, deadline=None)
@given(d=st.integers(1, 3), batch=st.integers(1, 4), seed=st.integers(0, 2**16))
def test_combined_proximity_is_sum_of_parts_and_vectorized_equals_loop(d, batch, seed):
    rng = np.random.default_rng(seed)
    x1, x2 = rng.normal(size=(2, batch, d))
    A = rng.normal(size=(2, batch, d, d))
    cov = A @ np.swapaxes(A, -1, -2) + 0.5 * np.eye(d)
    f1, f2 = rng.normal(size=(2, batch))
    v1, v2 = rng.uniform(0.1, 2, size=(2, batch))
    k = F.combined_proximity(x1, x2, cov[0], cov[1], f1, f2, v1, v2)
    np.testing.assert_allclose(k.total, k.coordinate + k.feature)
    assert k.dof == d + 1
    for b in range(batch):
        diff = x1[b] - x2[b]
        kx = diff @ np.linalg.inv(cov[0, b] + cov[1, b]) @ diff
        kf = (f1[b] - f2[b]) ** 2 / (v1[b] + v2[b])
        np.testing.assert_allclose(k.coordinate[b], kx, rtol=1e-9)
        np.testing.assert_allclose(k.feature[b], kf, rtol=1e-12)
        np.testing.assert_allclose(k.total[b], kx + kf, rtol=1e-9)
    for model in FEATURE_MODELS:
        ks = F.combined_proximity(x1, x2, cov[0], cov[1], f1, f2, v1, v2, model=model,
                                  kind="marginal", type_means=[0.0, 1.0], type_vars=[0.5, 0.5])
        np.testing.assert_allclose(ks.total, ks.coordinate + ks.feature)
        np.testing.assert_allclose(ks.coordinate, k.coordinate)
        assert ks.dof is None
    k0 = F.combined_proximity(x1, x2, cov[0], cov[1], f1, f2, v1, v2, model="spread")
    np.testing.assert_array_equal(k0.feature, 0.0)
    assert k0.dof == d


@pytest.mark.parametrize("model", ["shared", "spread"])
def test_marginal_feature_term_equals_numerical_integration(model):
    """-2 ln [p(Π̂1, Π̂2 | one object) / (p(Π̂1) p(Π̂2))], every density by quad."""
    means, tvars, pri = [0.0, 2.0], [0.4, 0.9], np.array([0.3, 0.7])
    f1, f2, v1, v2 = 0.5, 1.4, 0.1, 0.3

    def g(f, v, m, tv):
        return integrate.quad(lambda x: _npdf(f, x, v) * _npdf(x, m, tv), -np.inf, np.inf)[0]

    g1 = np.array([g(f1, v1, m, t) for m, t in zip(means, tvars, strict=True)])
    g2 = np.array([g(f2, v2, m, t) for m, t in zip(means, tvars, strict=True)])
    if model == "spread":
        same = np.sum(pri * g1 * g2)
    else:  # one shared value Π ~ Σ p_k N(Π_k, σ_k²), seen by both radars
        same = sum(p * integrate.quad(
            lambda x, m=m, t=t: _npdf(f1, x, v1) * _npdf(f2, x, v2) * _npdf(x, m, t),
            -np.inf, np.inf)[0] for p, m, t in zip(pri, means, tvars, strict=True))
    want = -2 * np.log(same / (np.sum(pri * g1) * np.sum(pri * g2)))
    k = F.combined_proximity([0.0], [0.0], [[1.0]], [[1.0]], f1, f2, v1, v2, model=model,
                             kind="marginal", type_means=means, type_vars=tvars, priors=pri)
    np.testing.assert_allclose(k.feature, want, rtol=1e-8)


def test_marginal_term_approaches_profile_term_for_small_noise():
    """σ_Πi ≪ σ_Πk: the model-1 marginal term differs from (12) by report-only terms."""
    rng = np.random.default_rng(3)
    f1, f2 = rng.normal(0, 1, size=(2, 5))
    kw = dict(type_means=[0.0], type_vars=[1.0])
    prof = F.combined_proximity([0.0], [0.0], [[1.0]], [[1.0]], f1[:, None], f2[None, :],
                                1e-4, 1e-4).feature
    marg = F.combined_proximity([0.0], [0.0], [[1.0]], [[1.0]], f1[:, None], f2[None, :],
                                1e-4, 1e-4, kind="marginal", **kw).feature
    diff = marg - prof
    # pairing-dependent part of the difference vanishes: diff ≈ a_i + b_j
    resid = diff - diff.mean(1, keepdims=True) - diff.mean(0, keepdims=True) + diff.mean()
    assert np.max(np.abs(resid)) < 1e-3 * np.max(np.abs(prof))


def test_proximity_laws_by_monte_carlo():
    """χ²(d+1) under a true pair; χ'²(d+1, Vx+VΠ) under a false one (fixed truth)."""
    rng = np.random.default_rng(7)
    n, d = 40_000, 2
    C1, C2 = np.diag([0.3, 0.5]), np.diag([0.4, 0.2])
    e1 = rng.multivariate_normal(np.zeros(d), C1, size=n)
    e2 = rng.multivariate_normal(np.zeros(d), C2, size=n)
    fv1, fv2 = 0.2, 0.3
    g1, g2 = rng.normal(0, np.sqrt(fv1), n), rng.normal(0, np.sqrt(fv2), n)
    true = F.combined_proximity(e1, e2, C1, C2, 1.0 + g1, 1.0 + g2, fv1, fv2)
    dx, dpi = np.array([1.0, -0.5]), 0.8
    false = F.combined_proximity(dx + e1, e2, C1, C2, dpi + g1, g2, fv1, fv2)
    V = dx @ np.linalg.solve(C1 + C2, dx) + dpi**2 / (fv1 + fv2)
    for q in (0.5, 0.9, 0.99):
        th = stats.chi2.ppf(q, d + 1)
        assert abs(np.mean(true.total < th) - q) < binomial_tolerance(q, n)
        pf = stats.ncx2.cdf(th, d + 1, V)
        assert abs(np.mean(false.total < th) - pf) < binomial_tolerance(pf, n)


# ----------------------------------------------------------------------------- scenes, triune
@pytest.mark.parametrize("model", ["shared", "spread"])
def test_typed_scene_statistics(model):
    means, tvars, pri = np.array([0.0, 3.0]), np.array([0.5, 2.0]), np.array([0.25, 0.75])
    s = typed_scene(2, type_means=means, type_vars=tvars, priors=pri, spacing=1.0,
                      sigma1=0.1, sigma2=0.2, feature_sigma1=0.3, feature_sigma2=0.4,
                      model=model, trials=30_000, rng=11)
    n = s.types.size
    share = np.mean(s.types == 1)
    assert abs(share - 0.75) < binomial_tolerance(0.75, n)
    diff = s.features1 - np.take_along_axis(s.features2, s.true_match, axis=1)
    for k in range(2):
        dk = diff[s.types == k]
        want = 0.09 + 0.16 + (2 * tvars[k] if model == "spread" else 0.0)
        # variance of a sample variance: 2σ⁴/(n-1) for Gaussian data
        assert abs(dk.var() - want) < 5 * want * np.sqrt(2 / dk.size)
    # radar 2's coordinates and features follow the same owner
    np.testing.assert_array_equal(
        np.take_along_axis(s.coords.reports2, s.true_match[..., None], axis=1).shape,
        s.coords.reports1.shape)


def test_typed_scene_reproducible_and_rng_checked():
    kw = dict(type_means=[0.0, 1.0], type_vars=[1.0, 1.0], spacing=1.0, sigma1=0.1,
              sigma2=0.1, feature_sigma1=0.1, feature_sigma2=0.1, trials=3)
    a, b = typed_scene(3, rng=4, **kw), typed_scene(3, rng=4, **kw)
    np.testing.assert_array_equal(a.features2, b.features2)
    with pytest.raises(TypeError, match="`rng`"):
        typed_scene(3, rng=np.random.RandomState(0), **kw)


def test_association_costs_match_pairwise_loop():
    s = typed_scene(3, type_means=[0.0, 2.0], type_vars=[0.5, 0.5], spacing=1.0,
                      sigma1=0.3, sigma2=0.4, feature_sigma1=0.2, feature_sigma2=0.1,
                      trials=2, dim=2, rng=3)
    c = s.coords
    for feats in ("none", "shared", "spread"):
        cost = F.association_costs(s, features=feats, kind="marginal")
        for t in range(2):
            for i in range(3):
                for j in range(3):
                    dx = c.reports1[t, i] - c.reports2[t, j]
                    kx = dx @ dx / (0.09 + 0.16)
                    k = F.combined_proximity(c.reports1[t, i], c.reports2[t, j],
                                             0.09 * np.eye(2), 0.16 * np.eye(2),
                                             s.features1[t, i], s.features2[t, j], 0.04, 0.01,
                                             model="shared" if feats == "none" else feats,
                                             kind="marginal", type_means=[0.0, 2.0],
                                             type_vars=[0.5, 0.5])
                    want = kx if feats == "none" else float(k.total)
                    np.testing.assert_allclose(cost[t, i, j], want, rtol=1e-10)


def test_features_sharpen_joint_association_under_model_1():
    """Brute-force joint association (all n! pairings) with and without features."""
    from itertools import permutations

    s = typed_scene(4, type_means=[0.0, 4.0, 8.0], type_vars=[0.3, 0.3, 0.3], spacing=1.0,
                      sigma1=0.5, sigma2=0.5, feature_sigma1=0.1, feature_sigma2=0.1,
                      trials=2000, rng=21)
    perms = np.array(list(permutations(range(4))))

    def brute(cost):
        tot = cost[:, np.arange(4), perms].sum(-1)  # (trials, n!)
        return perms[np.argmin(tot, axis=-1)]

    acc = {f: F.triune(s, brute(F.association_costs(s, features=f))).all_correct()
           for f in ("none", "shared")}
    assert acc["shared"].low > acc["none"].high


def test_triune_true_match_and_unpaired():
    s = typed_scene(3, type_means=[0.0, 9.0], type_vars=[1.0, 1.0], spacing=5.0, sigma1=0.1,
                      sigma2=0.2, feature_sigma1=0.1, feature_sigma2=0.1, trials=20, rng=2)
    r = F.triune(s, s.true_match)
    assert r.all_correct().estimate == 1.0
    c = s.coords
    x2 = np.take_along_axis(c.reports2, s.true_match[..., None], axis=1)
    np.testing.assert_allclose(r.fused, (0.04 * c.reports1 + 0.01 * x2) / 0.05)
    np.testing.assert_allclose(r.posterior.sum(-1), 1.0)
    conf = r.confusion()
    assert conf.counts.sum() == 60
    np.testing.assert_array_equal(conf.support, np.bincount(s.types.ravel(), minlength=2))
    m = s.true_match.copy()
    m[:, 0] = -1
    r2 = F.triune(s, m, rule="plugin")
    np.testing.assert_allclose(r2.fused[:, 0], c.reports1[:, 0])
    assert not r2.correct[:, 0].any()
    lo_est, lo, hi = r.rmse()
    assert lo <= lo_est <= hi


def test_reliability_curve_counts():
    rng = np.random.default_rng(0)
    p = rng.uniform(size=20_000)
    o = rng.uniform(size=p.size) < p  # calibrated by construction
    r = F.reliability_curve(p, o, bins=5)
    assert r.counts.sum() == p.size
    assert np.all((r.low <= r.predicted + 0.02) & (r.predicted - 0.02 <= r.high))


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(("kwargs", "arg"), [
    (dict(feature_var=-1.0), "feature_var"),
    (dict(type_vars=[1.0, -1.0]), "type_vars"),
    (dict(type_vars=[1.0, 0.0]), "type_vars"),
    (dict(type_means=[], type_vars=[]), "type_means"),
    (dict(type_means=[[0.0, 1.0]], type_vars=[1.0, 1.0]), "type_means"),
    (dict(type_vars=[1.0, 1.0, 1.0]), "type_vars"),
    (dict(priors=[0.5, 0.6]), "priors"),
    (dict(priors=[1.2, -0.2]), "priors"),
    (dict(priors=[1.0]), "priors"),
    (dict(feature=[0.0, 1.0], feature_var=[1.0, 1.0, 1.0]), "feature"),
    (dict(feature=[0.0, float("nan")]), "feature"),
])
def test_posterior_bad_input(kwargs, arg):
    base = dict(feature=0.0, feature_var=0.1, type_means=[0.0, 1.0], type_vars=[1.0, 1.0],
                priors=None)
    base.update(kwargs)
    with pytest.raises(ValueError, match=f"`{arg}`"):
        F.type_posterior(**base)


def test_likelihood_and_fusion_bad_input():
    with pytest.raises(ValueError, match="`type_means`"):
        F.type_likelihood(0.0, 0.1, [], [])
    with pytest.raises(ValueError, match="`feature_var2`"):
        F.fused_feature(0.0, 1.0, 1.0, -1.0)
    with pytest.raises(TypeError, match="`feature1`"):
        F.fused_feature("a", 1.0, 1.0, 1.0)


@pytest.mark.parametrize(("kwargs", "arg"), [
    (dict(x2=[0.0, 1.0]), "x1"),
    (dict(cov1=[[-1.0]]), "cov1"),
    (dict(cov2=np.eye(2)), "cov2"),
    (dict(feature_var1=0.0), "feature_var1"),
    (dict(feature_var2=-1.0), "feature_var2"),
    (dict(feature1=[0.0, 1.0], feature2=[0.0, 1.0, 2.0]), "feature1"),
    (dict(model="other"), "model"),
    (dict(kind="marginal"), "type_means"),
    (dict(kind="exact"), "kind"),
    (dict(kind="marginal", type_means=[0.0], type_vars=[1.0], priors=[0.5]), "priors"),
    (dict(kind="marginal", type_means=[0.0], type_vars=[-1.0]), "type_vars"),
    (dict(x1=np.zeros((3, 1)), x2=np.zeros((2, 1))), "x1"),
])
def test_combined_proximity_bad_input(kwargs, arg):
    base = dict(x1=[0.0], x2=[1.0], cov1=[[1.0]], cov2=[[1.0]], feature1=0.0, feature2=1.0,
                feature_var1=1.0, feature_var2=1.0)
    base.update(kwargs)
    with pytest.raises(ValueError, match=f"`{arg}`"):
        F.combined_proximity(**base)


def test_scene_triune_and_reliability_bad_input():
    kw = dict(type_means=[0.0, 1.0], type_vars=[1.0, 1.0], spacing=1.0, sigma1=0.1,
              sigma2=0.1, feature_sigma1=0.1, feature_sigma2=0.1)
    with pytest.raises(ValueError, match="`feature_sigma1`"):
        typed_scene(2, **{**kw, "feature_sigma1": -0.1})
    with pytest.raises(ValueError, match="`priors`"):
        typed_scene(2, priors=[0.9, 0.9], **kw)
    with pytest.raises(ValueError, match="`model`"):
        typed_scene(2, model="both", **kw)
    s = typed_scene(2, trials=3, rng=0, **kw)
    with pytest.raises(ValueError, match="`match`"):
        F.triune(s, np.zeros((3, 3), dtype=int))
    with pytest.raises(ValueError, match="`match`"):
        F.triune(s, np.full((3, 2), 5))
    with pytest.raises(ValueError, match="`rule`"):
        F.triune(s, s.true_match, rule="map")
    with pytest.raises(TypeError, match="`scene`"):
        F.association_costs(s.coords)
    with pytest.raises(ValueError, match="`features`"):
        F.association_costs(s, features="model1")
    with pytest.raises(ValueError, match="`kind`"):
        F.association_costs(s, kind="bayes")
    with pytest.raises(ValueError, match="`outcome`"):
        F.reliability_curve([0.5], [1])
    with pytest.raises(ValueError, match="`prob`"):
        F.reliability_curve([1.5], [True])


# ----------------------------------------------------------------------------- numerical range
def _mp_log_posterior(features, variances, means, tvars, priors=None):
    """Log type posterior by mpmath at 1400 digits: the float inputs taken exactly.

    ``features`` and ``variances`` list the independent reports of the object
    (one for the fused feature, two for model 2). 1400 digits span the whole
    double range (1e-324 to 1e308, squared), so the differences of the squares
    are exact.
    """
    import mpmath

    mpmath.mp.dps = 1400
    L = len(means)
    pri = [mpmath.mpf(1) / L] * L if priors is None else [mpmath.mpf(float(p)) for p in priors]
    lj = []
    for k in range(L):
        if pri[k] == 0:
            lj.append(None)
            continue
        s = mpmath.log(pri[k])
        for f, v in zip(features, variances, strict=True):
            var = mpmath.mpf(float(tvars[k])) + mpmath.mpf(float(v))
            s -= (mpmath.log(var) + (mpmath.mpf(float(f)) - mpmath.mpf(float(means[k]))) ** 2
                  / var) / 2
        lj.append(s)
    top = max(x for x in lj if x is not None)
    norm = top + mpmath.log(mpmath.fsum(mpmath.exp(x - top) for x in lj if x is not None))
    return lj, norm


def _mp_posterior(*args, **kw):
    import mpmath

    lj, norm = _mp_log_posterior(*args, **kw)
    return np.array([0.0 if x is None else float(mpmath.exp(x - norm)) for x in lj])


EXTREMES = [
    # feature far from every type: the heavier tail wins
    (1e200, 0.0, [0.0, 2.0, 4.0], [0.36, 0.64, 0.49]),
    (-1e300, 0.0, [0.0, 1.0], [1.0, 1.0]),
    (1e308, 0.0, [-1e308, 1e308], [1.0, 1.0]),
    (1.7e308, 1e300, [-1.7e308, 0.0], [1e308, 1e308]),
    # tiny variances: squares overflow, densities underflow
    (0.6, 0.0, [0.0, 1.0], [1e-310, 1e-310]),
    (0.4, 1e-320, [0.0, 1.0], [1e-320, 1e-320]),
    (1e-160, 0.0, [0.0, 3e-160], [1e-320, 1e-320]),
    # means closer than the feature's rounding: 1 - 1e-18 == 1 in floats
    (1.0, 0.0, [0.0, 1e-18], [1e-20, 1e-20]),
    (1e300, 0.0, [0.0, 1e-300], [1e-300, 1e-300]),
    # huge variances
    (0.5, 1e308, [0.0, 1.0], [1e308, 1e308]),
    (3.0, 0.0, [0.0, 1.0], [1e300, 1e-300]),
    # moderate, unequal variances and priors
    (0.7, 0.2, [0.0, 1.5, 2.0], [0.3, 0.6, 0.2]),
]


@pytest.mark.parametrize(("f", "v", "means", "tvars"), EXTREMES)
def test_posterior_at_extremes_equals_mpmath(f, v, means, tvars):
    """The issue-12 defects: NaN far from every type, wrong type at tiny variances."""
    got = F.type_posterior(f, v, means, tvars)
    want = _mp_posterior([f], [v], means, tvars)
    assert np.all(np.isfinite(got))
    np.testing.assert_allclose(got.sum(), 1.0, rtol=1e-14)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-300)
    assert np.argmax(got) == np.argmax(want)
    lp = F.type_posterior(f, v, means, tvars, log=True)
    assert not np.any(np.isnan(lp)) and not np.any(lp == np.inf)


def test_tiny_variances_pick_the_right_type_with_priors():
    """Priors 0.6/0.4 and a feature nearer type 2 by 200 nats: type 2, not a 0.5/0.5 tie."""
    p = F.type_posterior(1.0, 0.0, [0.0, 1e-18], [1e-20, 1e-20], [0.6, 0.4])
    assert np.argmax(p) == 1
    np.testing.assert_allclose(p, _mp_posterior([1.0], [0.0], [0.0, 1e-18], [1e-20, 1e-20],
                                                [0.6, 0.4]), rtol=1e-9, atol=1e-300)


@pytest.mark.parametrize(("f1", "v1", "f2", "v2", "means", "tvars"), [
    (1e200, 1.0, 1e200, 1.0, [0.0, 1.0], [1.0, 1.0]),
    (0.6, 1e-320, 0.61, 1e-320, [0.0, 1.0], [1e-310, 1e-310]),
    (1e150, 1e-10, -1e150, 1e10, [0.0, 1.0, 5.0], [1.0, 4.0, 1.0]),
    (0.9, 0.1, 1.1, 0.1, [0.0, 1.0], [0.2, 0.2]),
])
def test_spread_pair_posterior_at_extremes_equals_mpmath(f1, v1, f2, v2, means, tvars):
    got = F.pair_type_posterior(f1, v1, f2, v2, means, tvars, model="spread")
    want = _mp_posterior([f1, f2], [v1, v2], means, tvars)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-300)


def test_shared_pair_posterior_with_extreme_variances():
    """The fused feature itself must not collapse: 1e-300 and 1e300 variances."""
    for v in (1e-300, 1e-320, 1e300):
        ff = F.fused_feature(1.0, v, 3.0, v)
        assert ff.value == 2.0 and np.isclose(ff.var, v / 2, rtol=1e-12)
        got = F.pair_type_posterior(1.0, v, 3.0, v, [1.0, 2.0, 3.0], [1.0, 1.0, 1.0])
        np.testing.assert_allclose(got, _mp_posterior([2.0], [v / 2], [1.0, 2.0, 3.0],
                                                      [1.0] * 3), rtol=1e-9)
    assert F.fused_feature(1e308, 1.0, -1e308, 1.0).value == 0.0
    ff = F.fused_feature(1.0, 1e-320, 3.0, 1.0)
    assert ff.value == 1.0 and ff.var > 0


def test_fused_feature_is_the_fusion_module_rule():
    """Same rule as radarfusion_ref.fusion.fuse (eq-fused-estimate) on ordinary inputs."""
    from radarfusion_ref.fusion import fuse

    rng = np.random.default_rng(3)
    f, v = rng.normal(size=(2, 50)), rng.uniform(0.01, 10, size=(2, 50))
    ff = F.fused_feature(f[0], v[0], f[1], v[1])
    fe = fuse(f.T, v.T)
    np.testing.assert_allclose(ff.value, fe.estimate, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(ff.var, fe.variance, rtol=1e-12)


def test_log_likelihood_beyond_the_float_range_is_refused():
    assert np.all(F.type_likelihood(1e200, 0.0, [0.0], [1.0]) == 0.0)
    with pytest.raises(ValueError, match="`feature`"):
        F.type_likelihood(1e200, 0.0, [0.0], [1.0], log=True)
    np.testing.assert_allclose(F.type_likelihood(1e150, 0.0, [0.0], [1.0], log=True),
                               [-0.5 * (np.log(2 * np.pi) + 1e300)], rtol=1e-14)


def test_profile_feature_term_does_not_overflow_when_representable():
    k = F.combined_proximity([0.0], [0.0], [[1.0]], [[1.0]], 1e200, -1e200, 1e300, 1e300)
    np.testing.assert_allclose(k.feature, 2e100, rtol=1e-12)
    with pytest.raises(ValueError, match="`feature1`"):
        F.combined_proximity([0.0], [0.0], [[1.0]], [[1.0]], 1e200, -1e200, 1.0, 1.0)


def test_marginal_term_far_from_every_type():
    """Model 2: the term is built from the (robust) single-report posteriors."""
    k = F.combined_proximity([0.0], [0.0], [[1.0]], [[1.0]], 1e200, 1e200, 1.0, 1.0,
                             model="spread", kind="marginal", type_means=[0.0, 1.0],
                             type_vars=[1.0, 1.0], priors=[0.5, 0.5])
    np.testing.assert_allclose(k.feature, -2 * np.log(2.0), rtol=1e-12)   # both surely T_2
    with pytest.raises(ValueError, match="`feature1`"):
        F.combined_proximity([0.0], [0.0], [[1.0]], [[1.0]], 1e200, 1e200, 1.0, 1.0,
                             kind="marginal", type_means=[0.0], type_vars=[1.0])


# ----------------------------------------------------------------------------- resource limits
def test_bins_limit_is_checked_before_allocation():
    with pytest.raises(ValueError, match=r"10000"):
        F.reliability_curve([0.5], [True], bins=10**9)
    with pytest.raises(TypeError, match="`bins`"):
        F.reliability_curve([0.5], [True], bins=1e9)
    r = F.reliability_curve([0.5], [True], bins=F.MAX_BINS)
    assert r.counts.tolist() == [1]


def test_memory_limit_names_the_alternative():
    with pytest.raises(ValueError, match="chunks"):
        F.type_posterior(np.broadcast_to(0.0, (10**6,)), 0.0, np.zeros(1000), np.ones(1000))


# ----------------------------------------------------------------------------- properties
wide = st.floats(-1e308, 1e308, allow_nan=False, allow_infinity=False)
wide_pos = st.floats(1e-320, 1e308, allow_nan=False, allow_infinity=False, exclude_min=True)


@given(f=st.lists(wide, min_size=1, max_size=4), v=st.one_of(st.just(0.0), wide_pos),
       data=st.data())
def test_posterior_is_finite_and_sums_to_one_over_the_float_range(f, v, data):
    L = data.draw(st.integers(1, 4))
    means = data.draw(st.lists(wide, min_size=L, max_size=L))
    tv = data.draw(st.lists(wide_pos, min_size=L, max_size=L))
    w = np.asarray(data.draw(st.lists(st.floats(0.0, 1.0), min_size=L, max_size=L)))
    priors = None if w.sum() < 1e-3 else w / w.sum()
    p = F.type_posterior(f, v, means, tv, priors)
    assert p.shape == (len(f), L)
    assert np.all(np.isfinite(p)) and np.all((p >= 0) & (p <= 1))
    np.testing.assert_allclose(p.sum(axis=-1), 1.0, rtol=1e-12)
    if priors is not None:
        assert np.all(p[:, priors == 0] == 0)
    lp = F.type_posterior(f, v, means, tv, priors, log=True)
    assert not np.any(np.isnan(lp)) and not np.any(lp == np.inf)


@given(f=wide, v=st.one_of(st.just(0.0), wide_pos), data=st.data())
def test_posterior_agrees_with_mpmath_wherever_the_answer_is_well_conditioned(f, v, data):
    """Against 60-digit mpmath on the same float inputs, except within rounding of a tie.

    The log-joint differences are exact to double precision relative to the
    squares they come from; where the two best types differ by less than that
    (a decision boundary of a huge quadratic) the input's own rounding decides.
    """
    import mpmath

    L = data.draw(st.integers(1, 3))
    means = data.draw(st.lists(wide, min_size=L, max_size=L))
    tv = data.draw(st.lists(wide_pos, min_size=L, max_size=L))
    got = F.type_posterior(f, v, means, tv)
    lj, norm = _mp_log_posterior([f], [v], means, tv)
    want = np.array([float(mpmath.exp(x - norm)) for x in lj])
    scale = max(abs(float((mpmath.mpf(f) - m) ** 2 / (mpmath.mpf(t) + v)))
                for m, t in zip(means, tv, strict=True))
    gaps = sorted((float(lj[0] - x) for x in lj), reverse=True)
    top2 = sorted(lj, reverse=True)
    tie = L > 1 and float(top2[0] - top2[1]) < 1e-9 * scale + 1e-6
    if not tie or L == 1:
        np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-12)
        assert np.argmax(got) == np.argmax(want)
    del gaps


@given(f1=wide, f2=wide, v1=wide_pos, v2=wide_pos, model=st.sampled_from(FEATURE_MODELS),
       data=st.data())
def test_pair_posterior_is_finite_and_sums_to_one(f1, f2, v1, v2, model, data):
    L = data.draw(st.integers(1, 3))
    means = data.draw(st.lists(wide, min_size=L, max_size=L))
    tv = data.draw(st.lists(wide_pos, min_size=L, max_size=L))
    p = F.pair_type_posterior(f1, v1, f2, v2, means, tv, model=model)
    assert np.all(np.isfinite(p)) and np.all(p >= 0)
    np.testing.assert_allclose(p.sum(), 1.0, rtol=1e-12)


@given(f1=wide, f2=wide, v1=wide_pos, v2=wide_pos)
def test_fused_feature_between_reports_and_below_both_variances(f1, f2, v1, v2):
    ff = F.fused_feature(f1, v1, f2, v2)
    assert np.isfinite(ff.value) and np.isfinite(ff.var)
    assert min(f1, f2) <= ff.value <= max(f1, f2)
    assert 0 <= ff.var <= min(v1, v2)


@given(f=wide, v=st.one_of(st.just(0.0), wide_pos), m=wide, tv=wide_pos)
def test_likelihood_is_finite_and_at_most_the_peak(f, v, m, tv):
    lik = F.type_likelihood(f, v, [m], [tv])
    peak = 1 / np.sqrt(2 * np.pi) * np.exp(-0.5 * np.logaddexp(np.log(tv), np.log(v)
                                                                if v > 0 else -np.inf))
    assert np.isfinite(lik).all() and 0 <= lik[0] <= peak * (1 + 1e-12)


@given(x=st.lists(finite, min_size=2, max_size=2), f=st.lists(finite, min_size=2, max_size=2),
       s=st.lists(pos, min_size=4, max_size=4), model=st.sampled_from(FEATURE_MODELS),
       kind=st.sampled_from(["profile", "marginal"]))
def test_combined_proximity_is_finite_nonnegative_and_symmetric(x, f, s, model, kind):
    kw = dict(model=model, kind=kind, type_means=[0.0, 3.0], type_vars=[1.0, 2.0])
    k = F.combined_proximity([x[0]], [x[1]], [[s[0]]], [[s[1]]], f[0], f[1], s[2], s[3], **kw)
    r = F.combined_proximity([x[1]], [x[0]], [[s[1]]], [[s[0]]], f[1], f[0], s[3], s[2], **kw)
    assert np.isfinite(k.total) and k.coordinate >= 0
    if kind == "profile":
        assert k.feature >= 0
    np.testing.assert_allclose(k.total, r.total, rtol=1e-9, atol=1e-12)


@given(n=st.integers(1, 4), trials=st.integers(1, 5), seed=st.integers(0, 2**32 - 1),
       model=st.sampled_from(FEATURE_MODELS), dim=st.integers(1, 2))
def test_scene_costs_and_triune_invariants(n, trials, seed, model, dim):
    kw = dict(type_means=[0.0, 2.0], type_vars=[1.0, 0.5], priors=[0.3, 0.7], spacing=1.0,
              sigma1=0.2, sigma2=0.3, feature_sigma1=0.1, feature_sigma2=0.2, model=model,
              trials=trials, dim=dim)
    s = typed_scene(n, rng=seed, **kw)
    again = typed_scene(n, rng=seed, **kw)
    np.testing.assert_array_equal(s.features2, again.features2)
    for features in ("none", *FEATURE_MODELS):
        c = F.association_costs(s, features=features)
        assert c.shape == (trials, n, n) and np.all(np.isfinite(c)) and np.all(c >= 0)
    r = F.triune(s, s.true_match)
    assert np.all(r.correct)
    np.testing.assert_allclose(r.posterior.sum(-1), 1.0, rtol=1e-12)
    conf = r.confusion()
    assert conf.counts.sum() == trials * n
    assert np.all((conf.low <= conf.rate + 1e-12) & (conf.rate <= conf.high + 1e-12))


@given(p=st.lists(st.floats(0, 1), min_size=1, max_size=50), bins=st.integers(1, 40),
       data=st.data())
def test_reliability_curve_invariants(p, bins, data):
    o = data.draw(st.lists(st.booleans(), min_size=len(p), max_size=len(p)))
    r = F.reliability_curve(p, o, bins=bins)
    assert r.counts.sum() == len(p) and len(r.counts) <= bins
    assert np.all((r.predicted >= 0) & (r.predicted <= 1))
    assert np.all((r.low <= r.observed) & (r.observed <= r.high))


# ----------------------------------------------------------------------------- generated bad input
BAD_NUMBERS = st.sampled_from([float("nan"), float("inf"), -float("inf"), "1.5", True, None,
                               [1.0, "a"], 1 + 2j])
BAD_VARIANCES = st.one_of(BAD_NUMBERS, st.floats(-1e308, 0.0, allow_nan=False))


def _call(fn, base, arg, value):
    kwargs = dict(base, **{arg: value})
    with pytest.raises((ValueError, TypeError), match=f"`{arg}`"):
        fn(**kwargs)


POSTERIOR_BASE = dict(feature=0.3, feature_var=0.1, type_means=[0.0, 1.0], type_vars=[1.0, 2.0],
                      priors=[0.4, 0.6])


@given(arg=st.sampled_from(["feature", "type_means", "priors"]), value=BAD_NUMBERS)
def test_posterior_rejects_bad_numbers(arg, value):
    if not (arg == "priors" and value is None):           # None: uniform priors
        _call(F.type_posterior, POSTERIOR_BASE, arg, value)


@given(arg=st.sampled_from(["type_vars"]), value=BAD_VARIANCES)
def test_posterior_rejects_bad_variances(arg, value):
    _call(F.type_posterior, POSTERIOR_BASE, arg, [value, value])


@given(value=st.one_of(BAD_NUMBERS, st.floats(-1e308, -1e-300)))
def test_posterior_and_likelihood_reject_bad_feature_var(value):
    _call(F.type_posterior, POSTERIOR_BASE, "feature_var", value)
    base = {k: v for k, v in POSTERIOR_BASE.items() if k != "priors"}
    _call(F.type_likelihood, base, "feature_var", value)


@given(value=st.sampled_from(["yes", 1, 0, None, 1.0]))
def test_log_flag_must_be_a_bool(value):
    _call(F.type_posterior, POSTERIOR_BASE, "log", value)
    base = {k: v for k, v in POSTERIOR_BASE.items() if k != "priors"}
    _call(F.type_likelihood, base, "log", value)
    _call(F.pair_type_posterior, PAIR_BASE, "log", value)


PAIR_BASE = dict(feature1=0.3, feature_var1=0.1, feature2=0.5, feature_var2=0.2,
                 type_means=[0.0, 1.0], type_vars=[1.0, 2.0], priors=None)


@given(arg=st.sampled_from(["feature1", "feature2"]), value=BAD_NUMBERS,
       model=st.sampled_from(FEATURE_MODELS))
def test_pair_posterior_rejects_bad_features(arg, value, model):
    _call(F.pair_type_posterior, dict(PAIR_BASE, model=model), arg, value)


@given(arg=st.sampled_from(["feature_var1", "feature_var2"]), value=BAD_VARIANCES,
       model=st.sampled_from(FEATURE_MODELS))
def test_pair_posterior_and_fusion_reject_bad_variances(arg, value, model):
    _call(F.pair_type_posterior, dict(PAIR_BASE, model=model), arg, value)
    base = {k: PAIR_BASE[k] for k in ("feature1", "feature_var1", "feature2", "feature_var2")}
    _call(F.fused_feature, base, arg, value)


PROX_BASE = dict(x1=[0.0], x2=[1.0], cov1=[[1.0]], cov2=[[1.0]], feature1=0.0, feature2=1.0,
                 feature_var1=1.0, feature_var2=1.0, model="shared", kind="marginal",
                 type_means=[0.0, 1.0], type_vars=[1.0, 1.0])


@given(arg=st.sampled_from(["x1", "x2", "feature1", "feature2", "type_means"]),
       value=BAD_NUMBERS)
def test_combined_proximity_rejects_bad_numbers(arg, value):
    _call(F.combined_proximity, PROX_BASE, arg, value)


@given(arg=st.sampled_from(["feature_var1", "feature_var2"]), value=BAD_VARIANCES)
def test_combined_proximity_rejects_bad_variances(arg, value):
    _call(F.combined_proximity, PROX_BASE, arg, value)


@given(arg=st.sampled_from(["cov1", "cov2"]),
       value=st.sampled_from([[[-1.0]], [[0.0]], [[float("nan")]], [[1.0, 0.0], [0.5, 1.0]],
                              "1", None, [[True]]]))
def test_combined_proximity_rejects_bad_covariances(arg, value):
    _call(F.combined_proximity, PROX_BASE, arg, value)


@given(arg=st.sampled_from(["model", "kind"]), value=st.sampled_from(["", "other", None, 1]))
def test_combined_proximity_rejects_bad_options(arg, value):
    _call(F.combined_proximity, PROX_BASE, arg, value)


SCENE_BASE = dict(n_objects=2, type_means=[0.0, 1.0], type_vars=[1.0, 1.0], spacing=1.0,
                  sigma1=0.1, sigma2=0.1, feature_sigma1=0.1, feature_sigma2=0.1, rng=0)


@given(arg=st.sampled_from(["feature_sigma1", "feature_sigma2", "spacing", "sigma1",
                            "sigma2"]), value=BAD_VARIANCES)
def test_typed_scene_rejects_bad_numbers(arg, value):
    _call(typed_scene, SCENE_BASE, arg, value)


@given(arg=st.sampled_from(["n_objects", "trials", "dim"]),
       value=st.sampled_from([0, -1, 1.5, "2", None, True]))
def test_typed_scene_rejects_bad_counts(arg, value):
    _call(typed_scene, SCENE_BASE, arg, value)


@given(match=st.one_of(
    st.lists(st.integers(-5, 5), min_size=1, max_size=6).map(np.array),
    st.sampled_from([None, "0", np.zeros((3, 2)), np.zeros((3, 2), dtype=bool),
                     np.full((3, 2), 2), np.full((3, 2), -2)])))
def test_triune_rejects_bad_matches(match):
    s = typed_scene(**dict(SCENE_BASE, trials=3))
    _call(F.triune, dict(scene=s), "match", match)


@given(bins=st.one_of(st.integers(-5, 0), st.integers(F.MAX_BINS + 1, 10**18),
                      st.sampled_from([1.5, "10", None, True])))
def test_reliability_curve_rejects_bad_bins(bins):
    _call(F.reliability_curve, dict(prob=[0.2], outcome=[True]), "bins", bins)


@given(prob=st.one_of(BAD_NUMBERS, st.just([]), st.floats(1.0, 1e308, exclude_min=True),
                      st.floats(-1e308, 0.0, exclude_max=True)))
def test_reliability_curve_rejects_bad_probabilities(prob):
    _call(F.reliability_curve, dict(prob=prob, outcome=[True]), "prob", prob)


def test_type_agreement_equals_the_likelihood_ratio_of_the_densities():
    # independent route: the first form, sum_k p_k g1k g2k / (sum_k p_k g1k sum_j p_j g2j),
    # with g_ik the normal densities from scipy
    rng = np.random.default_rng(4)
    means, tvars, priors = np.array([0.0, 2.0, 5.0]), np.array([0.5, 1.0, 2.0]), [0.2, 0.3, 0.5]
    f1, f2 = rng.normal(2.0, 2.0, size=(2, 50))
    v1, v2 = rng.uniform(0.05, 0.5, size=(2, 50))
    g1 = stats.norm.pdf(f1[:, None], means, np.sqrt(tvars + v1[:, None]))
    g2 = stats.norm.pdf(f2[:, None], means, np.sqrt(tvars + v2[:, None]))
    p = np.array(priors)
    want = -2 * np.log(np.sum(p * g1 * g2, axis=1) / (np.sum(p * g1, axis=1)
                                                         * np.sum(p * g2, axis=1)))
    got = F.type_agreement(f1, v1, f2, v2, means, tvars, priors)
    np.testing.assert_allclose(got, want, rtol=1e-12)
    k = F.combined_proximity(np.zeros((50, 1)), np.zeros((50, 1)), [[1.0]], [[1.0]], f1, f2,
                             v1, v2, model="spread", kind="marginal", type_means=means,
                             type_vars=tvars, priors=priors)
    np.testing.assert_array_equal(k.feature, got)
    with pytest.raises(ValueError, match="`feature_var2`"):
        F.type_agreement(0.0, 1.0, 0.0, -1.0, means, tvars)
    with pytest.raises(TypeError, match="`feature1`"):
        F.type_agreement("a", 1.0, 0.0, 1.0, means, tvars)
