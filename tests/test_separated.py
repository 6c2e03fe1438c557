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
from radarfusion_ref.engine import geometry, scenes
from radarfusion_ref.engine.montecarlo import binomial_tolerance

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
    p = geometry.radar2_position(30.0, 0.0)
    np.testing.assert_allclose(p, [30.0, 0.0])
    p = geometry.radar2_position(10.0, math.pi / 3)
    np.testing.assert_allclose(p, [5.0, 10.0 * math.sqrt(3) / 2])


@settings(max_examples=40, deadline=None)
@given(st.floats(1.0, 500.0), st.floats(-math.pi + 1e-6, math.pi),
       st.floats(-50, 50), st.floats(-50, 50))
def test_polar_from_inverts_the_polar_map(r, beta, ox, oy):
    xy = np.array([ox + r * math.cos(beta), oy + r * math.sin(beta)])
    rr, bb = geometry.polar_from(xy, (ox, oy))
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
    rep = scenes.polar_scene(g, sigma_r=0.1, sigma_beta=DEG, trials=40_000, rng=3)
    r_true, b_true = g.polar2
    er = (rep.r2 - r_true).ravel()
    eb = (rep.beta2 - b_true).ravel()
    # sample standard deviation of 80 000 normals: relative s.e. 1/sqrt(2N) = 0.25 %
    assert er.std() == pytest.approx(0.1, rel=0.0125)
    assert eb.std() == pytest.approx(DEG, rel=0.0125)
    assert abs(er.mean()) < 5 * 0.1 / math.sqrt(er.size)


def test_common_frame_brings_both_radars_to_the_truth():
    g = sep.paper_geometry(1.0, 3.0)
    rep = scenes.polar_scene(g, sigma_r=1e-6, sigma_beta=1e-9, trials=3, rng=0)
    cart = sep.to_common_frame(rep, method="linearized")
    np.testing.assert_allclose(cart.xy1, np.broadcast_to(g.targets, cart.xy1.shape), atol=1e-4)
    np.testing.assert_allclose(cart.xy2, np.broadcast_to(g.targets, cart.xy2.shape), atol=1e-4)


def test_mixed_methods_take_positions_and_covariances_from_different_conversions():
    g = sep.paper_geometry(0.0, -5.0)
    rep = scenes.polar_scene(g, sigma_r=0.1, sigma_beta=DEG, trials=4, rng=1)
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
    rep = scenes.polar_scene(g, sigma_r=P["sigma_r"], sigma_beta=P["sigma_beta"],
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
    rep = scenes.polar_scene(g, sigma_r=sr, sigma_beta=sb, trials=n, rng=21)
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
                                        methods=("linearized",), trials=2000, rng=7)
    np.testing.assert_array_equal(sw.per_report["linearized"].successes[1, 0],
                                  single["linearized"].per_report.successes)
    _, _, miss = sep.fit_target2_offset(sw)
    none = sw.per_report["linearized"].estimate[..., 2]
    dist = np.linalg.norm(none - [0.316, 0.650], axis=-1)
    assert miss == pytest.approx(dist.min())


def test_sweep_point_does_not_depend_on_the_other_points_of_the_grid():
    """One seed recipe (the engine's as_seed_sequence): a point's counts are those of the
    point alone, whatever grid surrounds it and in whatever order the grid lists it."""
    kw = dict(methods=("linearized",), trials=3000)
    alone = sep.offset_sweep([1.0], [-5.0], rng=11, **kw).per_report["linearized"]
    wide = sep.offset_sweep([1.5, -0.5, 1.0], [-7.0, -5.0], rng=11, **kw)
    wide = wide.per_report["linearized"]
    np.testing.assert_array_equal(wide.successes[2, 1], alone.successes[0, 0])
    # a SeedSequence and a Generator seed it through the same conversion
    ss = sep.offset_sweep([1.0], [-5.0], rng=np.random.SeedSequence(11), **kw)
    np.testing.assert_array_equal(ss.per_report["linearized"].successes, alone.successes)
    g1, g2 = np.random.default_rng(3), np.random.default_rng(3)
    a = sep.offset_sweep([1.0, 0.5], [-5.0], rng=g1, **kw).per_report["linearized"]
    b = sep.offset_sweep([0.5], [-5.0], rng=g2, **kw).per_report["linearized"]
    np.testing.assert_array_equal(a.successes[1, 0], b.successes[0, 0])
    # the seed matters: another seed gives other counts at the same point
    other = sep.offset_sweep([1.0], [-5.0], rng=12, **kw).per_report["linearized"]
    assert not np.array_equal(other.successes, alone.successes)


# ---------------------------------------------------------------- speed (robust ratio)
def test_vectorized_is_far_faster_than_a_per_trial_loop():
    g = sep.paper_geometry(-0.5, -5.0)
    t0 = time.perf_counter()
    sep.association_experiment(g, trials=100_000, rng=1)
    per_trial_vec = (time.perf_counter() - t0) / 100_000
    rep = scenes.polar_scene(g, sigma_r=P["sigma_r"], sigma_beta=P["sigma_beta"], trials=40,
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
        geometry.radar2_position(-1.0, 0.0)
    with pytest.raises(ValueError, match="`sigma_r`"):
        scenes.polar_scene(g, sigma_r=-0.1, sigma_beta=DEG)
    with pytest.raises(ValueError, match="`sigma_r`"):
        scenes.polar_scene(g, sigma_r=20.0, sigma_beta=DEG)     # ranges would go negative
    with pytest.raises(ValueError, match="`sigma_beta`"):
        scenes.polar_scene(g, sigma_r=0.1, sigma_beta=1.0)      # degrees passed as radians
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
        geometry.polar_from([[30.0, 0.0]], (30.0, 0.0))
    with pytest.raises(ValueError, match="`xy1`"):
        sep.pair_statistic([[0.0, 0.0, 0.0]], np.eye(2)[None], [[0.0, 0.0]], np.eye(2)[None])
    with pytest.raises(ValueError, match="`cov1`"):
        sep.pair_statistic([[0.0, 0.0]], np.eye(2)[None].repeat(2, 0), [[0.0, 0.0]],
                           np.eye(2)[None])
    with pytest.raises(ValueError, match="broadcastable leading"):
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


# ================================================================ trust: validation, limits,
# reproducibility, and a property + fuzz suite over every public function
PUBLIC = ["paper_geometry",
          "to_common_frame", "pair_statistic", "per_report_outcome", "joint_outcome",
          "association_experiment", "false_pair_noncentrality", "approximate_outcomes",
          "collect", "offset_sweep", "fit_target2_offset"]
GEO = sep.paper_geometry(-0.5, -5.0)


def test_every_public_function_is_covered_here():
    funcs = {n for n in sep.__all__ if callable(getattr(sep, n))
             and not isinstance(getattr(sep, n), type)}
    assert funcs == set(PUBLIC)


# ---------------------------------------------------------------- issue-12 defects, reproduced
def test_pair_statistic_refuses_non_symmetric_and_negative_definite_covariances():
    eye = np.eye(2)[None]
    nonsym = np.array([[[1.0, 0.5], [-0.5, 1.0]]])
    negdef = -np.eye(2)[None]
    # the sum with a large positive covariance would be positive definite: the defect
    big = 10 * eye
    for bad in (nonsym, negdef):
        with pytest.raises(ValueError, match="`cov1`"):
            sep.pair_statistic([[0.0, 0.0]], bad, [[1.0, 0.0]], big)
        with pytest.raises(ValueError, match="`cov2`"):
            sep.pair_statistic([[0.0, 0.0]], big, [[1.0, 0.0]], bad)
    with pytest.raises(ValueError, match="symmetric"):
        sep.pair_statistic([[0.0, 0.0]], nonsym, [[1.0, 0.0]], eye)


def test_sigma_beta_limit_is_the_engines_one_limit():
    lim = geometry.SIGMA_BETA_MAX
    rep = scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=lim, trials=2, rng=0)
    assert rep.sigma_beta == lim
    with pytest.raises(ValueError, match="SIGMA_BETA_MAX"):
        scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=np.nextafter(lim, 1.0), trials=2)
    with pytest.raises(ValueError, match="`sigma_beta`"):
        sep.association_experiment(GEO, sigma_beta=0.6, trials=10)
    with pytest.raises(ValueError, match="`sigma_beta`"):
        sep.false_pair_noncentrality(GEO, sigma_beta=0.7)


@pytest.mark.parametrize("chunks", [(61, 4096), (4099, 65_536), (999, 1 << 17)])
def test_result_of_a_seed_does_not_depend_on_chunk_size(chunks):
    n = 65_536 + 300                             # crosses a block boundary (65 536)
    a, b = (sep.association_experiment(GEO, trials=n, rng=5, chunk_size=c) for c in chunks)
    for lab in a.results:
        for field in ("per_report", "joint", "joint_ungated", "true_reject", "false_pass",
                      "all_correct"):
            np.testing.assert_array_equal(getattr(a[lab], field).successes,
                                          getattr(b[lab], field).successes)


def test_polar_scene_has_the_experiments_draws_across_blocks():
    n = geometry.BLOCK_TRIALS + 5
    rep = scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=DEG, trials=n, rng=9)
    res = sep.association_experiment(GEO, methods=("linearized",), trials=n, rng=9,
                                     chunk_size=4099)
    cart = sep.to_common_frame(rep)
    k = sep.pair_statistic(cart.xy1, cart.cov1, cart.xy2, cart.cov2)
    passed = k < res.threshold
    np.testing.assert_array_equal(res["linearized"].true_reject.successes,
                                  n - passed[:, [0, 1], [0, 1]].sum(axis=0))
    np.testing.assert_array_equal(res["linearized"].false_pass.successes,
                                  passed[:, [0, 1], [1, 0]].sum(axis=0))
    head = scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=DEG, trials=10, rng=9)
    # a SeedSequence and the int seed it wraps give the same draws
    ss = scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=DEG, trials=10,
                         rng=np.random.SeedSequence(9))
    np.testing.assert_array_equal(ss.beta2, head.beta2)
    # a Generator is advanced: two calls differ, a re-seeded one repeats
    g = np.random.default_rng(1)
    x, y = (scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=DEG, trials=3, rng=g).r1
            for _ in range(2))
    assert not np.array_equal(x, y)
    z = scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=DEG, trials=3,
                        rng=np.random.default_rng(1)).r1
    np.testing.assert_array_equal(x, z)


def test_sizes_are_refused_before_allocation():
    with pytest.raises(ValueError, match="`trials`"):
        sep.association_experiment(GEO, trials=geometry.MAX_TRIALS + 1)
    with pytest.raises(ValueError, match="`chunk_size`"):
        sep.association_experiment(GEO, trials=10**7, chunk_size=10**9)
    with pytest.raises(ValueError, match="bytes of polar reports"):
        scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=DEG, trials=10**8)
    eight = geometry.Geometry(30.0, 0.0, np.array([[100.0 + 3 * k, 100.0] for k in range(8)]))
    t0 = time.perf_counter()
    with pytest.raises(ValueError, match=r"engine\.assignment\.assign_two_lists"):
        sep.association_experiment(eight, trials=10)
    with pytest.raises(ValueError, match=r"engine\.assignment\.assign_two_lists"):
        sep.joint_outcome(np.zeros((8, 8)))
    with pytest.raises(ValueError, match="bytes of pairing costs"):
        sep.joint_outcome(np.zeros((40_000, 7, 7)))
    with pytest.raises(ValueError, match="grid points"):
        sep.offset_sweep(np.arange(1, 200.0), np.arange(1, 100.0), trials=10)
    assert time.perf_counter() - t0 < 1.0


def test_zero_and_negative_sigmas_name_the_argument():
    for kw, name in ((dict(sigma_r=0.0, sigma_beta=DEG), "sigma_r"),
                     (dict(sigma_r=-0.1, sigma_beta=DEG), "sigma_r"),
                     (dict(sigma_r=0.1, sigma_beta=0.0), "sigma_beta"),
                     (dict(sigma_r=0.1, sigma_beta=-DEG), "sigma_beta"),
                     (dict(sigma_r=[0.1, 0.2], sigma_beta=DEG), "sigma_r")):
        with pytest.raises(ValueError, match=f"`{name}`"):
            scenes.polar_scene(GEO, trials=2, **kw)
        with pytest.raises(ValueError, match=f"`{name}`"):
            sep.association_experiment(GEO, trials=2, **kw)
        with pytest.raises(ValueError, match=f"`{name}`"):
            sep.false_pair_noncentrality(GEO, **kw)


def test_hand_written_bad_input_cases():
    cases = [
        (TypeError, "`base`", lambda: geometry.radar2_position("30", 0.0)),
        (TypeError, "`base_azimuth`", lambda: geometry.radar2_position(30.0, True)),
        (ValueError, "`base`", lambda: geometry.radar2_position(0.0, 0.0)),
        (ValueError, "`xy`", lambda: geometry.polar_from([[np.nan, 1.0]])),
        (ValueError, "`xy`", lambda: geometry.polar_from([[1e308, 0.0]], (-1e308, 0.0))),
        (ValueError, "`origin`", lambda: geometry.polar_from([[1.0, 1.0]], (0.0, 0.0, 0.0))),
        (ValueError, "`offset_range`", lambda: sep.paper_geometry([1.0, 2.0], 3.0)),
        (ValueError, "`offset_cross`", lambda: sep.paper_geometry(0.0, np.inf)),
        (ValueError, "`range1`", lambda: sep.paper_geometry(0.0, 1.0, range1=-5.0)),
        (ValueError, "`offset_range`", lambda: sep.paper_geometry(1.7e308, -1.7e308)),
        (ValueError, "`targets`", lambda: geometry.Geometry(30.0, 0.0, np.zeros((0, 2)))),
        (ValueError, "`targets`", lambda: geometry.Geometry(30.0, 0.0, np.zeros((2, 3)))),
        (ValueError, "`base`", lambda: geometry.Geometry(-1.0, 0.0, np.ones((2, 2)))),
        (TypeError, "`geometry`", lambda: scenes.polar_scene(None, sigma_r=0.1, sigma_beta=DEG)),
        (TypeError, "`trials`", lambda: scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=DEG,
                                                        trials=2.0)),
        (TypeError, "`trials`", lambda: sep.association_experiment(GEO, trials=True)),
        (TypeError, "`rng`", lambda: sep.association_experiment(
            GEO, trials=2, rng=np.random.RandomState(0))),
        (TypeError, "`reports`", lambda: sep.to_common_frame(GEO)),
        (ValueError, "`method`", lambda: sep.to_common_frame(
            scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=DEG, rng=0), method="exact")),
        (TypeError, "`xy1`", lambda: sep.pair_statistic("a", np.eye(2)[None], [[0.0, 0.0]],
                                                        np.eye(2)[None])),
        (ValueError, "`cov2`", lambda: sep.pair_statistic([[0.0, 0.0]], np.eye(2)[None],
                                                          [[0.0, 0.0]], [[[1.0, 0.0],
                                                                          [0.0, np.nan]]])),
        (ValueError, "`xy1`.*numeric domain",
         lambda: sep.pair_statistic([[1e200, 0.0]], np.eye(2)[None], [[-1e200, 0.0]],
                                    np.eye(2)[None])),
        (ValueError, "`statistic`", lambda: sep.per_report_outcome([[-1.0, 2.0], [3.0, 4.0]], 9.2)),
        (ValueError, "`statistic`", lambda: sep.per_report_outcome(np.zeros((2, 0, 0)), 9.2)),
        (ValueError, "`threshold`", lambda: sep.per_report_outcome(np.eye(2), [9.0, 9.0])),
        (ValueError, "`threshold`", lambda: sep.joint_outcome(np.eye(2), threshold=0.0)),
        (ValueError, "`logdet`", lambda: sep.joint_outcome(np.eye(2), [[0.0, np.inf],
                                                                       [0.0, 0.0]])),
        (ValueError, "`geometry`", lambda: sep.association_experiment(sep.paper_geometry())),
        (ValueError, "`chunk_size`", lambda: sep.association_experiment(GEO, chunk_size=0)),
        (ValueError, "`p_false_reject`", lambda: sep.association_experiment(
            GEO, trials=2, p_false_reject=0.0)),
        (TypeError, "`methods`", lambda: sep.association_experiment(GEO, methods=5)),
        (ValueError, "`bias_method`", lambda: sep.false_pair_noncentrality(
            GEO, bias_method="none")),
        (ValueError, "`noncentrality`", lambda: sep.approximate_outcomes(-np.ones((2, 2)))),
        (ValueError, "`p_false_reject`", lambda: sep.approximate_outcomes(np.zeros((2, 2)),
                                                                           1.0)),
        (ValueError, "`experiments`", lambda: sep.collect([], "linearized")),
        (TypeError, "`experiments`", lambda: sep.collect([GEO], "linearized")),
        (TypeError, "`label`", lambda: sep.collect([_tiny_run()], 3)),
        (ValueError, "`field`", lambda: sep.collect([_tiny_run()], "linearized", "nope")),
        (ValueError, "`offsets_cross`", lambda: sep.offset_sweep([1.0], [[1.0]], trials=10)),
        (TypeError, "`trials`", lambda: sep.offset_sweep([1.0], [1.0], trials=10.5)),
        (TypeError, "`sweep`", lambda: sep.fit_target2_offset(_tiny_run())),
        (ValueError, "`target`", lambda: sep.fit_target2_offset(_tiny_sweep(), (0.5, 1.5))),
        (ValueError, "`method`", lambda: sep.fit_target2_offset(_tiny_sweep(),
                                                                method="additive")),
    ]
    for err, name, call in cases:
        with pytest.raises(err, match=name):
            call()
    assert len(cases) >= 40


def _tiny_run(**kw):
    return sep.association_experiment(GEO, trials=50, rng=0, **kw)


def _tiny_sweep():
    return sep.offset_sweep([1.0], [-5.0], methods=("linearized",), trials=20, rng=0)


# ---------------------------------------------------------------- properties (valid input)
finite = st.floats(-1e3, 1e3, allow_nan=False)
offsets = st.tuples(st.floats(-3.0, 3.0), st.floats(-12.0, 12.0)).filter(
    lambda o: abs(o[0]) + abs(o[1]) > 0.05)


@given(st.floats(1e-3, 1e6), st.floats(-10.0, 10.0))
def test_property_radar2_position_has_length_base(b, a):
    p = geometry.radar2_position(b, a)
    assert np.isfinite(p).all() and math.hypot(*p) == pytest.approx(b, rel=1e-12)


@given(st.tuples(finite, finite), st.tuples(finite, finite))
def test_property_polar_from_is_finite_and_inverts(xy, o):
    if math.hypot(xy[0] - o[0], xy[1] - o[1]) == 0:           # only range 0 is undefined
        with pytest.raises(ValueError, match="`xy`"):
            geometry.polar_from([xy], o)
        return
    r, b = geometry.polar_from([xy], o)
    assert r[0] > 0 and -math.pi <= b[0] <= math.pi
    np.testing.assert_allclose([o[0] + r[0] * math.cos(b[0]), o[1] + r[0] * math.sin(b[0])],
                               xy, atol=1e-9 * (1 + r[0]))


@given(offsets, st.floats(20.0, 1e4), st.floats(1.0, 200.0))
def test_property_paper_geometry_places_target2_at_its_offset(off, r1, base):
    g = sep.paper_geometry(*off, range1=r1, base=base)
    d = g.targets[1] - g.targets[0]
    assert math.hypot(*d) == pytest.approx(math.hypot(*off), rel=1e-6, abs=1e-9)
    assert np.isfinite(g.polar2[0]).all()


@given(offsets, st.floats(0.01, 1.0), st.floats(1e-4, 0.5), st.integers(1, 50),
       st.integers(0, 2**32))
def test_property_simulation_conversion_and_statistic_are_finite(off, sr, sb, n, seed):
    g = sep.paper_geometry(*off)
    rep = scenes.polar_scene(g, sigma_r=sr, sigma_beta=sb, trials=n, rng=seed)
    assert rep.r1.shape == (n, 2) and np.isfinite(rep.beta2).all()
    for m in ("linearized", "additive"):
        cart = sep.to_common_frame(rep, method=m)
        k, ld = sep.pair_statistic(cart.xy1, cart.cov1, cart.xy2, cart.cov2, return_logdet=True)
        assert k.shape == (n, 2, 2) and (k >= 0).all() and np.isfinite(ld).all()


@given(st.lists(st.floats(-1e3, 1e3), min_size=4, max_size=4),
       st.lists(st.floats(1e-3, 1e3), min_size=6, max_size=6), st.floats(-0.9, 0.9),
       st.floats(1e-15, 1e15))
def test_property_pair_statistic_is_scale_invariant_and_agrees_with_solve(xs, sd, rho, scale):
    # scaling positions by s and covariances by s^2 leaves kappa unchanged, over a wide
    # range inside the engine's numeric domain (variances within 2**-150 .. 2**150)
    def cov(a, b):
        return np.array([[a * a, rho * a * b], [rho * a * b, b * b]])
    xy1, xy2 = np.array([xs[:2]]), np.array([xs[2:]])
    c1, c2 = cov(sd[0], sd[1])[None], cov(sd[2], sd[3])[None]
    d, S = xy1[0] - xy2[0], c1[0] + c2[0]
    want = d @ np.linalg.solve(S, d)
    k = sep.pair_statistic(xy1, c1, xy2, c2)[0, 0]
    assert k == pytest.approx(want, rel=1e-6, abs=1e-9)
    ks = sep.pair_statistic(scale * xy1, scale**2 * c1, scale * xy2, scale**2 * c2)[0, 0]
    assert ks == pytest.approx(k, rel=1e-6, abs=1e-9)


@given(st.integers(1, 5), st.lists(st.floats(0.0, 30.0), min_size=25, max_size=25),
       st.floats(0.5, 20.0), st.floats(0.5, 20.0))
def test_property_outcomes_are_codes_and_gates_monotone(n, vals, t1, t2):
    s = np.array(vals[: n * n]).reshape(n, n)
    lo, hi = sorted((t1, t2))
    out_lo, out_hi = sep.per_report_outcome(s, lo), sep.per_report_outcome(s, hi)
    assert set(np.unique(out_lo)) <= {sep.CORRECT, sep.WRONG, sep.NO_DECISION}
    # a wider gate only lets more pairs pass: a report with two or more passing pairs at
    # the narrow gate stays undecided at the wide one
    ambiguous = (s < lo).sum(axis=-1) >= 2
    assert (out_hi[ambiguous] == sep.NO_DECISION).all()
    assert ((s < lo) <= (s < hi)).all()
    j = sep.joint_outcome(s, threshold=lo)
    j_hi = sep.joint_outcome(s, threshold=hi)
    assert not (j_hi == sep.NO_DECISION and j != sep.NO_DECISION)       # monotone gate
    assert sep.joint_outcome(s) in (sep.CORRECT, sep.WRONG)


@given(offsets, st.sampled_from(["linearized", "additive", "multiplicative"]),
       st.integers(1, 400), st.integers(0, 2**32))
def test_property_experiment_counts_partition_and_bound(off, m, n, seed):
    res = sep.association_experiment(sep.paper_geometry(*off), methods=(m,), trials=n,
                                     rng=seed, chunk_size=97)
    r = res[m]
    per = np.asarray(r.per_report.successes)
    assert (per.sum(axis=-1) == n).all()
    assert (per[:, 1] <= np.asarray(r.true_reject.successes)).all()   # wrong needs a miss
    assert int(np.sum(r.joint.successes)) == n
    assert np.isfinite(r.per_report.estimate).all()


@given(offsets, st.floats(0.02, 0.5), st.floats(1e-4, 0.3), st.floats(1e-6, 0.5))
def test_property_noncentrality_and_approximation(off, sr, sb, p_lo):
    g = sep.paper_geometry(*off)
    lam = sep.false_pair_noncentrality(g, sigma_r=sr, sigma_beta=sb)
    assert np.isfinite(lam).all() and (lam >= 0).all() and (np.diag(lam) == 0).all()
    pr = sep.approximate_outcomes(lam, p_lo)
    assert np.isfinite(pr).all() and (pr >= -1e-12).all()
    np.testing.assert_allclose(pr.sum(axis=-1), 1.0, atol=1e-12)


@given(st.integers(1, 4), st.integers(1, 3), st.integers(0, 2**16))
def test_property_sweep_collect_and_fit(k_r, k_c, seed):
    ar = np.linspace(-1.0, 1.0, k_r) + 0.1
    ac = np.linspace(-6.0, -4.0, k_c)
    sw = sep.offset_sweep(ar, ac, methods=("linearized",), trials=30, rng=seed)
    a, c, miss = sep.fit_target2_offset(sw)
    assert a in ar and c in ac and 0 <= miss <= 2
    runs = [_tiny_run(), _tiny_run()]
    assert sep.collect(runs, "linearized").estimate.shape == (2, 2, 3)


# ---------------------------------------------------------------- fuzz (invalid input)
bad_numbers = st.sampled_from([np.nan, np.inf, -np.inf, "1.0", True, None, [1.0, "x"]])


@given(bad_numbers, st.sampled_from(["base", "base_azimuth"]))
def test_fuzz_radar2_position(bad, which):
    kw = {"base": 30.0, "base_azimuth": 0.0, which: bad}
    with pytest.raises((ValueError, TypeError), match=f"`{which}`"):
        geometry.radar2_position(**kw)


@given(bad_numbers, st.sampled_from(["offset_range", "offset_cross", "range1", "azimuth1",
                                     "base", "base_azimuth"]))
def test_fuzz_paper_geometry(bad, which):
    args = {"offset_range": 0.1, "offset_cross": -5.0}
    args[which] = bad
    with pytest.raises((ValueError, TypeError), match=f"`{which}`"):
        sep.paper_geometry(**args)


@given(st.sampled_from([np.nan, np.inf, 0.0, -1.0, "0.1", True, None, [0.1, 0.2], 1.0]),
       st.sampled_from(["sigma_r", "sigma_beta"]),
       st.sampled_from(["polar_scene", "association_experiment", "false_pair_noncentrality"]))
def test_fuzz_sigmas(bad, which, func):
    kw = {"sigma_r": 0.1, "sigma_beta": DEG, which: bad}
    if which == "sigma_r" and bad == 1.0:
        kw["sigma_r"] = 100.0                        # above a tenth of the shortest range
    extra = {"trials": 2} if func != "false_pair_noncentrality" else {}
    home = scenes if func == "polar_scene" else sep
    with pytest.raises((ValueError, TypeError), match=f"`{which}`"):
        getattr(home, func)(GEO, **kw, **extra)


@given(st.sampled_from(["cov1", "cov2"]),
       st.sampled_from(["nonsym", "negdef", "singular", "nan", "shape", "str"]),
       st.floats(0.1, 10.0))
def test_fuzz_pair_statistic_covariances(which, kind, s):
    bad = {"nonsym": [[[s, 0.3 * s], [-0.3 * s, s]]], "negdef": [[[-s, 0.0], [0.0, -s]]],
           "singular": [[[s, s], [s, s]]], "nan": [[[s, 0.0], [0.0, np.nan]]],
           "shape": [[[s, 0.0, 0.0], [0.0, s, 0.0], [0.0, 0.0, s]]],
           "str": [[["a", "b"], ["c", "d"]]]}[kind]
    kw = {"xy1": [[0.0, 0.0]], "cov1": np.eye(2)[None], "xy2": [[1.0, 0.0]],
          "cov2": 100 * np.eye(2)[None], which: bad}
    with pytest.raises((ValueError, TypeError), match=f"`{which}`"):
        sep.pair_statistic(**kw)


@given(st.sampled_from([np.nan, -1.0, "x", None]), st.sampled_from([np.nan, 0.0, -2.0, "9"]))
def test_fuzz_outcome_rules(bad_s, bad_t):
    s = np.array([[1.0, 20.0], [3.0, 5.0]])
    with pytest.raises((ValueError, TypeError), match="`threshold`"):
        sep.per_report_outcome(s, bad_t)
    with pytest.raises((ValueError, TypeError), match="`threshold`"):
        sep.joint_outcome(s, threshold=bad_t)
    s_bad = s.astype(object)
    s_bad[0, 1] = bad_s
    with pytest.raises((ValueError, TypeError), match="`statistic`"):
        sep.per_report_outcome(s_bad, 9.2)
    with pytest.raises((ValueError, TypeError), match="`statistic`"):
        sep.joint_outcome(s_bad)


@given(st.sampled_from([("trials", 0), ("trials", 2.5), ("trials", True),
                        ("chunk_size", 0), ("chunk_size", 10**12), ("chunk_size", "1"),
                        ("p_false_reject", 0.0), ("p_false_reject", 1.0),
                        ("p_false_reject", np.nan), ("methods", ()), ("methods", ("x",)),
                        ("methods", (("linearized", "y"),)), ("rng", "seed"),
                        ("geometry", "paper")]))
def test_fuzz_association_experiment(case):
    name, bad = case
    kw = {"trials": 10, name: bad}
    geo = kw.pop("geometry", GEO)
    match = {"methods": "`methods`|`method`|`cov_method`"}.get(name, f"`{name}`")
    with pytest.raises((ValueError, TypeError), match=match):
        sep.association_experiment(geo, **kw)


@given(st.sampled_from([np.nan, -0.5, "a"]), st.integers(0, 3))
def test_fuzz_approximate_outcomes_and_sweep(bad, pos):
    lam = np.zeros((2, 2)).astype(object)
    lam.flat[pos] = bad
    with pytest.raises((ValueError, TypeError), match="`noncentrality`"):
        sep.approximate_outcomes(lam)
    if not (isinstance(bad, float) and np.isfinite(bad)):
        with pytest.raises((ValueError, TypeError), match="`offsets_range`"):
            sep.offset_sweep([0.5, bad], [-5.0], trials=5)


# ------------------------------------------------------------------ the full ML cost (logdet)
# Oracle: -2 * scipy.stats.multivariate_normal.logpdf of each pair's difference, pair by pair.


@given(st.integers(1, 3), st.integers(1, 3), st.integers(0, 2**31 - 1))
def test_pair_statistic_logdet_is_minus_two_log_gaussian(n1, n2, seed):
    g = np.random.default_rng(seed)
    xy1, xy2 = g.normal(size=(n1, 2)), g.normal(size=(n2, 2))

    def covs(n):
        a = g.normal(size=(n, 2, 2))
        return a @ np.swapaxes(a, -1, -2) + 0.1 * np.eye(2)

    cov1, cov2 = covs(n1), covs(n2)
    cost, ld = sep.pair_statistic(xy1, cov1, xy2, cov2, logdet=True, return_logdet=True)
    for i in range(n1):
        for j in range(n2):
            law = stats.multivariate_normal(np.zeros(2), cov1[i] + cov2[j])
            assert cost[i, j] == pytest.approx(-2 * law.logpdf(xy1[i] - xy2[j]), rel=1e-9,
                                               abs=1e-9)
            assert ld[i, j] == pytest.approx(np.linalg.slogdet(cov1[i] + cov2[j])[1],
                                             rel=1e-9, abs=1e-12)
    np.testing.assert_array_equal(sep.pair_statistic(xy1, cov1, xy2, cov2),
                                  sep.pair_statistic(xy1, cov1, xy2, cov2, logdet=False))


def test_pair_statistic_logdet_matches_association_proximity_matrix():
    """One cost for one concept: isotropic covariances give association's full cost."""
    from radarfusion_ref import association

    g = np.random.default_rng(11)
    xy1, xy2 = g.normal(size=(4, 2)), g.normal(size=(3, 2))
    s1, s2 = g.uniform(0.2, 1.5, 4), g.uniform(0.2, 1.5, 3)
    cov1 = s1[:, None, None] ** 2 * np.eye(2)
    cov2 = s2[:, None, None] ** 2 * np.eye(2)
    np.testing.assert_allclose(sep.pair_statistic(xy1, cov1, xy2, cov2, logdet=True),
                               association.proximity_matrix(xy1, xy2, s1, s2, logdet=True),
                               rtol=1e-10)


def test_pair_statistic_logdet_bad_input():
    eye = np.eye(2)[None]
    for bad in (1, "yes", None):
        with pytest.raises(TypeError, match="`logdet`"):
            sep.pair_statistic([[0.0, 0.0]], eye, [[1.0, 0.0]], eye, logdet=bad)


# ---------------------------------------------------------------- the experiment's pair kernel
def test_pair_kernel_equals_linalg_pair_by_pair():
    """`_pair_kernel` (the experiment's gating of polar reports, trial axis last)
    equals an independent route, `np.linalg.solve` and `slogdet` pair by pair."""
    from radarfusion_ref.separated._experiment import _pair_kernel

    g = np.random.default_rng(11)
    n, m = 3, 7
    xy = g.normal(size=(2, n, m, 2)) * 50.0
    M = g.normal(size=(2, n, m, 2, 2))
    cov = M @ np.swapaxes(M, -1, -2) + 0.2 * np.eye(2)
    radar2 = np.array([40.0, -12.0])
    s, ld = _pair_kernel(xy, cov, radar2)
    assert s.shape == ld.shape == (n, n, m)
    # np.linalg, pair by pair
    for i in range(n):
        for j in range(n):
            for t in range(m):
                d = xy[0, i, t] - (xy[1, j, t] + radar2)
                C = cov[0, i, t] + cov[1, j, t]
                assert s[i, j, t] == pytest.approx(d @ np.linalg.solve(C, d), rel=1e-9)
                assert ld[i, j, t] == pytest.approx(np.linalg.slogdet(C)[1], rel=1e-9, abs=1e-12)


def test_the_full_ml_pair_cost_is_one_cost_in_association_separated_and_grouping():
    """kappa + ln det(2 pi S): association.proximity_matrix(logdet=True),
    pair_statistic(logdet=True) and group_costs (m = 2) + 2 ln 2 pi all equal
    -2 ln N(x1 - x2; 0, S) from scipy.stats.multivariate_normal."""
    from radarfusion_ref import association, grouping

    g = np.random.default_rng(21)
    x1, x2 = g.normal(size=(3, 2)) * 2.0, g.normal(size=(4, 2)) * 2.0
    s1, s2 = g.uniform(0.3, 2.0, size=3), g.uniform(0.3, 2.0, size=4)
    cov1 = s1[:, None, None] ** 2 * np.eye(2)
    cov2 = s2[:, None, None] ** 2 * np.eye(2)
    a = association.proximity_matrix(x1, x2, s1, s2, logdet=True)
    p = sep.pair_statistic(x1, cov1, x2, cov2, logdet=True)
    for i in range(3):
        for j in range(4):
            S = cov1[i] + cov2[j]
            ref = -2.0 * stats.multivariate_normal(np.zeros(2), S).logpdf(x1[i] - x2[j])
            grp = grouping.group_costs(np.stack([x1[i:i + 1], x2[j:j + 1]]),
                                       np.stack([cov1[i:i + 1], cov2[j:j + 1]])).item()
            assert a[i, j] == pytest.approx(ref, rel=1e-12)
            assert p[i, j] == pytest.approx(ref, rel=1e-12)
            assert grp + 2 * np.log(2 * np.pi) == pytest.approx(ref, rel=1e-10)


def test_one_sigma_beta_rule_one_message():
    """The limit on sigma_beta is checked in one place (the engine's geometry): the
    conversion, the separated radars and the registration refuse 1 rad (degrees passed
    by mistake) with the same message."""
    from radarfusion_ref import registration

    calls = (lambda: conversion.polar_to_cartesian(100.0, 0.0, 0.1, 1.0),
             lambda: conversion.spherical_to_cartesian(100.0, 0.0, 0.0, 0.1, 0.01, 1.0),
             lambda: scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=1.0),
             lambda: registration.draw_biased_reports([[0, 0], [10, 0]], [[5.0, 50.0]],
                                                      [[0, 0, 0]] * 2, 0.05, 1.0))
    tails = set()
    for call in calls:
        with pytest.raises(ValueError, match="must be an angle standard deviation") as info:
            call()
        tails.add(str(info.value).split("0.5]", 1)[1])
    assert tails == {" (SIGMA_BETA_MAX); received largest entry 1 — did you pass degrees? "
                     "Use np.deg2rad."}
