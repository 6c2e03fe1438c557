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
from radarfusion_ref.montecarlo import binomial_tolerance

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
    s = F.typed_scene(1, type_means=means, type_vars=tvars, spacing=1.0, sigma1=1.0, sigma2=1.0,
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
    for model in F.FEATURE_MODELS:
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
    s = F.typed_scene(2, type_means=means, type_vars=tvars, priors=pri, spacing=1.0,
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
    a, b = F.typed_scene(3, rng=4, **kw), F.typed_scene(3, rng=4, **kw)
    np.testing.assert_array_equal(a.features2, b.features2)
    with pytest.raises(TypeError, match="`rng`"):
        F.typed_scene(3, rng=np.random.RandomState(0), **kw)


def test_association_costs_match_pairwise_loop():
    s = F.typed_scene(3, type_means=[0.0, 2.0], type_vars=[0.5, 0.5], spacing=1.0,
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

    s = F.typed_scene(4, type_means=[0.0, 4.0, 8.0], type_vars=[0.3, 0.3, 0.3], spacing=1.0,
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
    s = F.typed_scene(3, type_means=[0.0, 9.0], type_vars=[1.0, 1.0], spacing=5.0, sigma1=0.1,
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
        F.typed_scene(2, **{**kw, "feature_sigma1": -0.1})
    with pytest.raises(ValueError, match="`priors`"):
        F.typed_scene(2, priors=[0.9, 0.9], **kw)
    with pytest.raises(ValueError, match="`model`"):
        F.typed_scene(2, model="both", **kw)
    s = F.typed_scene(2, trials=3, rng=0, **kw)
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
