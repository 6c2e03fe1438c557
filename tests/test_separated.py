"""Tests of radarfusion_ref.separated (two separated radars, Prosov's Table 1).

Reference values come from independent routes:

* geometry: plane trigonometry written out here;
* the quadratic form: ``np.linalg.solve`` / ``np.linalg.slogdet`` on each
  matrix, against the package's batched hand-written Cholesky;
* decisions: a per-trial Python loop that applies the definitions of Table 1
  with ``if`` statements and enumerates joint pairings one by one, on the very
  same draws as the vectorized experiment (exact equality of counts);
* distributions: ``scipy.stats.chi2`` / ``scipy.stats.ncx2`` for the law of
  :math:`S` when conversion errors are small (nearly linear, Gaussian), with
  tolerances from the binomial standard error.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from radarfusion_ref import conversion
from radarfusion_ref import separated as sep
from radarfusion_ref.montecarlo import binomial_tolerance

DEG = math.pi / 180
P = sep.PAPER


# ---------------------------------------------------------------- helpers (independent)
def lin_cov(r, beta, sr, sb):
    """Prosov (2a–c), written out by hand."""
    c, s = math.cos(beta), math.sin(beta)
    c11 = r**2 * sb**2 * s**2 + sr**2 * c**2
    c22 = r**2 * sb**2 * c**2 + sr**2 * s**2
    c12 = (sr**2 - r**2 * sb**2) * s * c
    return np.array([[c11, c12], [c12, c22]])


def spd(draw_floats):
    """A random symmetric positive-definite 2x2 matrix from three numbers."""
    a, b, c = draw_floats
    L = np.array([[a, 0.0], [b, c]])
    return L @ L.T + 1e-3 * np.eye(2)


def loop_outcomes(rep, method, th, th_joint):
    """Per-trial reference: convert, solve, decide with if statements."""
    geo = rep.geometry
    n = geo.targets.shape[0]
    p2 = geo.radar2
    per = np.zeros((n, 3), dtype=int)
    all_ok = 0
    joint = np.zeros(3, dtype=int)
    joint_ug = np.zeros(3, dtype=int)
    for t in range(rep.trials):
        c1 = conversion.polar_to_cartesian(rep.r1[t], rep.beta1[t], rep.sigma_r,
                                           rep.sigma_beta, method=method)
        c2 = conversion.polar_to_cartesian(rep.r2[t], rep.beta2[t], rep.sigma_r,
                                           rep.sigma_beta, method=method)
        S = np.empty((n, n))
        LD = np.empty((n, n))
        for i in range(n):
            for j in range(n):
                d = c1.xy[i] - (c2.xy[j] + p2)
                C = c1.cov[i] + c2.cov[j]
                S[i, j] = d @ np.linalg.solve(C, d)
                LD[i, j] = np.linalg.slogdet(C)[1]
        n_ok = 0
        for i in range(n):
            passing = [j for j in range(n) if S[i, j] < th]
            if len(passing) == 1 and passing[0] == i:
                per[i, 0] += 1
                n_ok += 1
            elif len(passing) == 1:
                per[i, 1] += 1
            else:
                per[i, 2] += 1
        all_ok += n_ok == n
        best, best_cost, best_s = None, math.inf, None
        for perm in itertools.permutations(range(n)):
            cost = sum(S[i, perm[i]] + LD[i, perm[i]] for i in range(n))
            if cost < best_cost:
                best, best_cost = perm, cost
                best_s = sum(S[i, perm[i]] for i in range(n))
        correct = best == tuple(range(n))
        joint_ug[0 if correct else 1] += 1
        if best_s >= th_joint:
            joint[2] += 1
        else:
            joint[0 if correct else 1] += 1
    return per, joint, joint_ug, all_ok


# ---------------------------------------------------------------- geometry
def test_radar2_position_is_base_at_its_azimuth():
    p = sep.radar2_position(30.0, 0.0)
    np.testing.assert_allclose(p, [30.0, 0.0])
    p = sep.radar2_position(10.0, math.pi / 3)
    np.testing.assert_allclose(p, [5.0, 10.0 * math.sqrt(3) / 2])


@settings(max_examples=40, deadline=None)
@given(st.floats(1.0, 500.0), st.floats(-math.pi + 1e-6, math.pi),
       st.floats(-50, 50), st.floats(-50, 50))
def test_polar_from_inverts_the_polar_map(r, beta, ox, oy):
    xy = np.array([ox + r * math.cos(beta), oy + r * math.sin(beta)])
    rr, bb = sep.polar_from(xy, (ox, oy))
    assert rr == pytest.approx(r, rel=1e-9)
    assert math.cos(bb - beta) == pytest.approx(1.0, abs=1e-9)


def test_paper_geometry_places_targets_as_stated():
    g = sep.paper_geometry(0.7, -4.0)
    r1, b1 = g.polar1
    assert r1[0] == pytest.approx(150.0)
    assert b1[0] == pytest.approx(45 * DEG)
    # the offset is (along, across) radar 1's line of sight to target 1
    u = np.array([math.cos(45 * DEG), math.sin(45 * DEG)])
    v = np.array([-u[1], u[0]])
    d = g.targets[1] - g.targets[0]
    assert d @ u == pytest.approx(0.7)
    assert d @ v == pytest.approx(-4.0)
    # radar 2 sees target 1 from (30, 0)
    r2, _ = g.polar2
    assert r2[0] == pytest.approx(math.hypot(150 * u[0] - 30, 150 * u[1]))
    assert sep.paper_geometry().targets.shape == (1, 2)


def test_simulated_errors_have_the_stated_spread():
    g = sep.paper_geometry(0.0, -5.0)
    rep = sep.simulate_polar(g, sigma_r=0.1, sigma_beta=DEG, trials=40_000, rng=3)
    r_true, b_true = g.polar2
    er = (rep.r2 - r_true).ravel()
    eb = (rep.beta2 - b_true).ravel()
    # sample standard deviation of 80 000 normals: relative s.e. 1/sqrt(2N) = 0.25 %
    assert er.std() == pytest.approx(0.1, rel=0.0125)
    assert eb.std() == pytest.approx(DEG, rel=0.0125)
    assert abs(er.mean()) < 5 * 0.1 / math.sqrt(er.size)


def test_common_frame_brings_both_radars_to_the_truth():
    g = sep.paper_geometry(1.0, 3.0)
    rep = sep.simulate_polar(g, sigma_r=1e-6, sigma_beta=1e-9, trials=3, rng=0)
    cart = sep.to_common_frame(rep, method="linearized")
    np.testing.assert_allclose(cart.xy1, np.broadcast_to(g.targets, cart.xy1.shape), atol=1e-4)
    np.testing.assert_allclose(cart.xy2, np.broadcast_to(g.targets, cart.xy2.shape), atol=1e-4)


def test_mixed_methods_take_positions_and_covariances_from_different_conversions():
    g = sep.paper_geometry(0.0, -5.0)
    rep = sep.simulate_polar(g, sigma_r=0.1, sigma_beta=DEG, trials=4, rng=1)
    mix = sep.to_common_frame(rep, method="additive", cov_method="linearized")
    a = sep.to_common_frame(rep, method="additive")
    lin = sep.to_common_frame(rep, method="linearized")
    np.testing.assert_array_equal(mix.xy1, a.xy1)
    np.testing.assert_array_equal(mix.cov2, lin.cov2)


# ---------------------------------------------------------------- the quadratic form
@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(-3, 3), min_size=12, max_size=12),
       st.lists(st.floats(0.2, 3.0), min_size=6, max_size=6))
def test_pair_statistic_equals_solve_and_slogdet(xs, ls):
    xy1 = np.array(xs[:4]).reshape(2, 2)
    xy2 = np.array(xs[4:10]).reshape(3, 2)
    cov1 = np.stack([spd((ls[0], xs[10], ls[1])), spd((ls[2], xs[11], ls[3]))])
    cov2 = np.stack([spd((ls[4], 0.3, ls[5])), np.eye(2) * ls[0], spd((1.0, -0.5, ls[1]))])
    S, LD = sep.pair_statistic(xy1, cov1, xy2, cov2, return_logdet=True)
    for i in range(2):
        for j in range(3):
            d = xy1[i] - xy2[j]
            C = cov1[i] + cov2[j]
            assert S[i, j] == pytest.approx(d @ np.linalg.solve(C, d), rel=1e-9, abs=1e-12)
            assert LD[i, j] == pytest.approx(np.linalg.slogdet(C)[1], rel=1e-9, abs=1e-12)


def test_pair_statistic_broadcasts_over_trials():
    rng = np.random.default_rng(5)
    xy1, xy2 = rng.normal(size=(7, 2, 2)), rng.normal(size=(7, 2, 2))
    cov = np.eye(2) * np.array([1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])[:, None, None, None]
    cov = np.broadcast_to(cov, (7, 2, 2, 2))
    S = sep.pair_statistic(xy1, cov, xy2, cov)
    for t in range(7):
        np.testing.assert_allclose(S[t], sep.pair_statistic(xy1[t], cov[t], xy2[t], cov[t]))


def test_pair_statistic_refuses_singular_sum():
    cov = np.array([[[1.0, 1.0], [1.0, 1.0]]])
    with pytest.raises(ValueError, match="positive definite"):
        sep.pair_statistic([[0.0, 0.0]], cov, [[1.0, 0.0]], cov)


# ---------------------------------------------------------------- decisions
@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(0.0, 20.0), min_size=9, max_size=9), st.floats(1.0, 15.0))
def test_per_report_outcome_matches_definition(vals, th):
    S = np.array(vals).reshape(3, 3)
    out = sep.per_report_outcome(S, th)
    for i in range(3):
        passing = [j for j in range(3) if S[i, j] < th]
        want = (sep.NO_DECISION if len(passing) != 1
                else sep.CORRECT if passing[0] == i else sep.WRONG)
        assert out[i] == want


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(0.0, 20.0), min_size=9, max_size=9),
       st.lists(st.floats(-2.0, 2.0), min_size=9, max_size=9))
def test_joint_outcome_is_brute_force_minimum(vals, lds):
    S, LD = np.array(vals).reshape(3, 3), np.array(lds).reshape(3, 3)
    costs = {p: sum(S[i, p[i]] + LD[i, p[i]] for i in range(3))
             for p in itertools.permutations(range(3))}
    best = min(costs, key=costs.get)
    want = sep.CORRECT if best == (0, 1, 2) else sep.WRONG
    if sorted(costs.values())[1] - costs[best] > 1e-9:   # skip ties
        assert sep.joint_outcome(S, LD) == want


@pytest.mark.parametrize("methods", [("linearized", "additive"),
                                     (("additive", "linearized"), "first_order_printed")])
def test_vectorized_experiment_equals_per_trial_loop(methods):
    g = sep.paper_geometry(-0.5, -5.0)
    n = 400
    res = sep.association_experiment(g, methods=methods, trials=n, rng=11)
    rep = sep.simulate_polar(g, sigma_r=P["sigma_r"], sigma_beta=P["sigma_beta"],
                             trials=n, rng=11)            # the very same draws
    for m in methods:
        pm, cm = (m, m) if isinstance(m, str) else m
        label = pm if pm == cm else f"{pm}/{cm}"
        if pm != cm:
            continue    # the loop reference converts with one method
        per, joint, joint_ug, all_ok = loop_outcomes(rep, pm, res.threshold,
                                                     res.joint_threshold)
        np.testing.assert_array_equal(res[label].per_report.successes, per)
        np.testing.assert_array_equal(res[label].joint.successes, joint)
        np.testing.assert_array_equal(res[label].joint_ungated.successes, joint_ug)
        assert res[label].all_correct.successes == all_ok


def test_chunking_does_not_change_the_result_for_one_chunk():
    g = sep.paper_geometry(-0.5, -5.0)
    a = sep.association_experiment(g, trials=3000, rng=4, chunk_size=3000)
    b = sep.association_experiment(g, trials=3000, rng=4, chunk_size=10_000)
    np.testing.assert_array_equal(a["additive"].per_report.successes,
                                  b["additive"].per_report.successes)


def test_outcomes_partition_the_trials():
    g = sep.paper_geometry(0.3, 2.0)
    res = sep.association_experiment(g, trials=5000, rng=2, chunk_size=1234)
    for r in res.results.values():
        np.testing.assert_array_equal(np.asarray(r.per_report.successes).sum(axis=-1), 5000)
        assert int(np.sum(r.joint.successes)) == 5000
        assert r.joint_ungated.successes[2] == 0


# ---------------------------------------------------------------- distributions
def test_true_pair_statistic_is_chi2_2_when_conversion_is_nearly_linear():
    # tiny azimuth error: the conversion is linear to O(sigma_beta^2) and S ~ chi2(2)
    g = sep.paper_geometry(0.0, 20.0)
    sr, sb = 0.1, 0.05 * DEG
    n = 60_000
    rep = sep.simulate_polar(g, sigma_r=sr, sigma_beta=sb, trials=n, rng=21)
    cart = sep.to_common_frame(rep)
    S = sep.pair_statistic(cart.xy1, cart.cov1, cart.xy2, cart.cov2)
    true_s = S[:, 0, 0]
    ks = stats.kstest(true_s, stats.chi2(2).cdf)
    assert ks.pvalue > 1e-4
    th = stats.chi2.isf(0.01, 2)
    p = np.mean(true_s >= th)
    assert abs(p - 0.01) < binomial_tolerance(0.01, n)


def test_false_pair_pass_rate_is_noncentral_chi2():
    # independent route: lambda from hand-written (2a-c) and np.linalg.solve, then ncx2
    g = sep.paper_geometry(0.3, 0.5)
    sr, sb = 0.1, 0.05 * DEG
    (r1, b1), (r2, b2) = g.polar1, g.polar2
    d = g.targets[0] - g.targets[1]
    C = lin_cov(r1[0], b1[0], sr, sb) + lin_cov(r2[1], b2[1], sr, sb)
    lam = d @ np.linalg.solve(C, d)
    th = stats.chi2.isf(0.01, 2)
    exact = stats.ncx2.cdf(th, 2, lam)
    assert 0.05 < exact < 0.95      # an informative case
    n = 60_000
    res = sep.association_experiment(g, sigma_r=sr, sigma_beta=sb, methods=("linearized",),
                                     trials=n, rng=8)
    got = res["linearized"].false_pass.estimate[0]
    assert abs(got - exact) < binomial_tolerance(exact, n)
    assert sep.false_pair_noncentrality(g, sigma_r=sr, sigma_beta=sb)[0, 1] == pytest.approx(lam)


def test_approximate_outcomes_formula():
    lam = np.array([[0.0, 7.0], [4.0, 0.0]])
    th = stats.chi2.isf(0.01, 2)
    a = stats.chi2.cdf(th, 2)
    b = stats.ncx2.cdf(th, 2, [7.0, 4.0])
    want = np.stack([a * (1 - b), (1 - a) * b, a * b + (1 - a) * (1 - b)], axis=-1)
    np.testing.assert_allclose(sep.approximate_outcomes(lam), want, rtol=1e-10)


def test_paper_table_rows_sum_to_one():
    for rows in sep.PAPER_TABLE1.values():
        np.testing.assert_allclose(rows.sum(axis=1), 1.0, atol=1e-12)


def test_sweep_uses_common_random_numbers_and_fit_picks_closest():
    sw = sep.offset_sweep([-0.5, 1.0], [-6.0, -5.0], methods=("linearized",), trials=2000,
                          rng=7)
    single = sep.association_experiment(sep.paper_geometry(1.0, -6.0),
                                        methods=("linearized",), trials=2000,
                                        rng=np.random.default_rng(
                                            int(np.random.default_rng(7).integers(2**63))))
    np.testing.assert_array_equal(sw.per_report["linearized"].successes[1, 0],
                                  single["linearized"].per_report.successes)
    _, _, miss = sep.fit_target2_offset(sw)
    none = sw.per_report["linearized"].estimate[..., 2]
    dist = np.linalg.norm(none - [0.316, 0.650], axis=-1)
    assert miss == pytest.approx(dist.min())


# ---------------------------------------------------------------- speed (robust ratio)
def test_vectorized_is_far_faster_than_a_per_trial_loop():
    g = sep.paper_geometry(-0.5, -5.0)
    t0 = time.perf_counter()
    sep.association_experiment(g, trials=100_000, rng=1)
    per_trial_vec = (time.perf_counter() - t0) / 100_000
    rep = sep.simulate_polar(g, sigma_r=P["sigma_r"], sigma_beta=P["sigma_beta"], trials=40,
                             rng=1)
    t0 = time.perf_counter()
    for m in ("linearized", "additive"):
        loop_outcomes(rep, m, 9.21, 13.28)
    per_trial_loop = (time.perf_counter() - t0) / 40
    assert per_trial_loop / per_trial_vec > 20


# ---------------------------------------------------------------- bad input
def test_bad_input_names_the_argument():
    g = sep.paper_geometry(0.0, -5.0)
    with pytest.raises(ValueError, match="`base`"):
        sep.radar2_position(-1.0, 0.0)
    with pytest.raises(ValueError, match="`sigma_r`"):
        sep.simulate_polar(g, sigma_r=-0.1, sigma_beta=DEG)
    with pytest.raises(ValueError, match="`sigma_r`"):
        sep.simulate_polar(g, sigma_r=20.0, sigma_beta=DEG)     # ranges would go negative
    with pytest.raises(ValueError, match="`sigma_beta`"):
        sep.simulate_polar(g, sigma_r=0.1, sigma_beta=1.0)      # degrees passed as radians
    with pytest.raises(ValueError, match="`sigma_beta`"):
        sep.association_experiment(g, sigma_beta=0.0)
    with pytest.raises(ValueError, match="`trials`"):
        sep.association_experiment(g, trials=0)
    with pytest.raises(ValueError, match="`method`"):
        sep.association_experiment(g, methods=("debiased",))
    with pytest.raises(ValueError, match="`cov_method`"):
        sep.association_experiment(g, methods=(("additive", "exact"),))
    with pytest.raises(ValueError, match="`methods`"):
        sep.association_experiment(g, methods=())
    with pytest.raises(ValueError, match="`p_false_reject`"):
        sep.association_experiment(g, p_false_reject=1.5)
    with pytest.raises(ValueError, match="`geometry`"):
        sep.association_experiment(sep.paper_geometry())        # one target
    with pytest.raises(TypeError, match="`geometry`"):
        sep.association_experiment("paper")
    with pytest.raises(ValueError, match="`xy`"):
        sep.polar_from([[30.0, 0.0]], (30.0, 0.0))
    with pytest.raises(ValueError, match="`xy1`"):
        sep.pair_statistic([[0.0, 0.0, 0.0]], np.eye(2)[None], [[0.0, 0.0]], np.eye(2)[None])
    with pytest.raises(ValueError, match="`cov1`"):
        sep.pair_statistic([[0.0, 0.0]], np.eye(2)[None].repeat(2, 0), [[0.0, 0.0]],
                           np.eye(2)[None])
    with pytest.raises(ValueError, match="must have broadcastable leading axes"):
        sep.pair_statistic(np.zeros((3, 1, 2)), np.eye(2)[None], np.zeros((4, 1, 2)),
                           np.eye(2)[None])
    with pytest.raises(ValueError, match="`statistic`"):
        sep.per_report_outcome(np.zeros((2, 3)), 9.2)
    with pytest.raises(ValueError, match="`threshold`"):
        sep.per_report_outcome(np.zeros((2, 2)), -1.0)
    with pytest.raises(ValueError, match="`logdet`"):
        sep.joint_outcome(np.zeros((2, 2)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="`offsets_range`"):
        sep.offset_sweep([0.0, 1.0], [0.0], trials=10)
    sw = sep.offset_sweep([1.0], [-5.0], methods=("linearized",), trials=10, rng=0)
    with pytest.raises(ValueError, match="`target`"):
        sep.fit_target2_offset(sw, (0.3, 0.5, 0.2))
    with pytest.raises(ValueError, match="`noncentrality`"):
        sep.approximate_outcomes(np.zeros((3, 3)))
