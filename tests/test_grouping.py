"""Tests of radarfusion_ref.grouping.

Reference values come from independent routes: enumeration of set partitions
and of report-to-track assignments with itertools (the counts), numerical
integration of the product of Gaussian densities over the unknown target
(the ML cost), scipy.stats.multivariate_normal with the stacked correlated
covariance (the exact binding likelihood), explicit loops over the paper's
eq. (6) (its product rule), scipy's linear_sum_assignment (m = 2), brute-force
enumeration (the MILP), and Monte Carlo with tolerances from the standard error.
"""

from __future__ import annotations

import itertools
import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate, stats
from scipy.optimize import linear_sum_assignment, linprog

from radarfusion_ref import grouping
from radarfusion_ref.montecarlo import binomial_tolerance


def rand_spd(rng, shape, d, *, floor=0.2):
    a = rng.standard_normal((*shape, d, d))
    return a @ np.swapaxes(a, -1, -2) / d + floor * np.eye(d)


def rand_problem(seed, m, n, d=2, *, noise=0.4):
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, n, size=(1, n, d)) + noise * rng.standard_normal((m, n, d))
    for i in range(m):
        x[i] = x[i][rng.permutation(n)]
    cov = rand_spd(rng, (m, n), d) * noise**2
    return x, cov


# ---------------------------------------------------------------- counting
def set_partitions_one_per_source(m, n):
    """Count partitions of the m*n reports into blocks of one report per source.

    A generic set-partition generator (each item joins an existing block or
    opens a new one), pruned only by 'no two reports of one source in a block'.
    """
    items = [(i, j) for i in range(m) for j in range(n)]
    count = 0

    def rec(k, blocks):
        nonlocal count
        if k == len(items):
            count += all(len(b) == m for b in blocks)
            return
        src = items[k][0]
        for b in blocks:
            if len(b) < m and src not in b:
                b.add(src)
                rec(k + 1, blocks)
                b.remove(src)
        if len(blocks) < n:
            blocks.append({src})
            rec(k + 1, blocks)
            blocks.pop()

    rec(0, [])
    return count


def assignments_to_tracks(m, n):
    """Count maps report -> track in which every track gets one report per source."""
    count = 0
    for labels in itertools.product(range(n), repeat=m * n):
        lab = np.array(labels).reshape(m, n)
        count += all(sorted(row) == list(range(n)) for row in lab.tolist())
    return count


@pytest.mark.parametrize(("m", "n"), [(2, 1), (2, 2), (2, 3), (2, 4), (3, 2), (3, 3), (4, 2)])
def test_count_without_binding_matches_enumeration(m, n):
    assert grouping.n_groupings(n, m) == set_partitions_one_per_source(m, n)


@pytest.mark.parametrize(("m", "n"), [(1, 3), (2, 2), (2, 3), (3, 2), (3, 3)])
def test_count_with_binding_matches_enumeration(m, n):
    assert grouping.n_groupings(n, m, binding=True) == assignments_to_tracks(m, n)


def test_count_paper_example_and_printed_formula():
    # Fig. 3 of the paper: m = 2, n = 3 gives 6 groupings; the printed (24),
    # (m-1)! n!, agrees for m = 2 and (m, n) = (3, 2) only.
    assert grouping.n_groupings(3, 2) == 6
    agree = {(m, n) for m in range(2, 7) for n in range(1, 7)
             if math.factorial(m - 1) * math.factorial(n) == grouping.n_groupings(n, m)}
    assert agree == {(2, n) for n in range(1, 7)} | {(3, 2)}


def test_binding_hypotheses_are_the_papers_four():
    hyp = grouping.binding_hypotheses(2, 2)
    assert hyp.shape == (grouping.n_groupings(2, 2, binding=True), 2, 2)
    got = {h.tobytes() for h in hyp}
    want = {h.astype(hyp.dtype).tobytes() for h in grouping.PAPER_HYPOTHESES.values()}
    assert got == want


# ---------------------------------------------------------------- costs
def test_ml_cost_is_minus_twice_log_marginal_likelihood_by_quadrature():
    rng = np.random.default_rng(3)
    for m in (2, 3, 4):
        a = rng.normal(size=m)
        s = rng.uniform(0.3, 1.5, size=m)

        def integrand(t, a=a, s=s):
            return np.prod(stats.norm.pdf(a, loc=t, scale=s))

        lik, _ = integrate.quad(integrand, -30, 30, points=list(a), limit=200)
        ref = -2 * np.log(lik) - (m - 1) * np.log(2 * np.pi)
        x = a.reshape(m, 1, 1)
        cov = (s**2).reshape(m, 1, 1, 1)
        got = grouping.group_costs(x, cov).reshape(())
        assert got == pytest.approx(ref, rel=1e-8)


def test_ml_cost_m2_is_gaussian_density_of_the_difference():
    rng = np.random.default_rng(4)
    x, cov = rand_problem(4, 2, 3, d=3)
    tensor = grouping.group_costs(x, cov)
    for j, k in itertools.product(range(3), repeat=2):
        s = cov[0, j] + cov[1, k]
        ref = -2 * stats.multivariate_normal(np.zeros(3), s).logpdf(x[0, j] - x[1, k])
        assert tensor[j, k] == pytest.approx(ref - 3 * np.log(2 * np.pi), rel=1e-10)
    del rng


def test_pairwise_cost_matches_loops():
    x, cov = rand_problem(5, 3, 2, d=2)
    tensor = grouping.group_costs(x, cov, cost="pairwise")
    for t in itertools.product(range(2), repeat=3):
        ref = 0.0
        for i, k in itertools.combinations(range(3), 2):
            dlt = x[i, t[i]] - x[k, t[k]]
            ref += dlt @ np.linalg.solve(cov[i, t[i]] + cov[k, t[k]], dlt)
        assert tensor[t] == pytest.approx(ref, rel=1e-12)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10**6), m=st.integers(2, 4), shift=st.floats(-1e4, 1e4))
def test_costs_translation_invariant_and_equal_cov_proportional(seed, m, shift):
    rng = np.random.default_rng(seed)
    n, d = 2, 2
    x = rng.normal(size=(m, n, d))
    c = rand_spd(rng, (), d)
    cov = np.broadcast_to(c, (m, n, d, d))
    ml = grouping.group_costs(x, cov)
    np.testing.assert_allclose(grouping.group_costs(x + shift, cov), ml, atol=1e-6 * (1 + abs(shift)))
    pw = grouping.group_costs(x, cov, cost="pairwise")
    # one shared covariance: ML quadratic = (2/m) * pairwise, log-det a constant
    diff = ml - 2 / m * pw
    np.testing.assert_allclose(diff, diff.flat[0], atol=1e-9)


def test_vectorised_costs_equal_loop():
    rng = np.random.default_rng(6)
    x = rng.normal(size=(4, 3, 2, 2))
    cov = rand_spd(rng, (4, 3, 2), 2)
    for kind in ("ml", "pairwise"):
        batch = grouping.group_costs(x, cov, cost=kind)
        for b in range(4):
            np.testing.assert_allclose(batch[b], grouping.group_costs(x[b], cov[b], cost=kind))


# ---------------------------------------------------------------- solvers
@pytest.mark.parametrize(("m", "n"), [(3, 2), (3, 3), (3, 4), (3, 5), (4, 2), (4, 3)])
@pytest.mark.parametrize("cost", ["ml", "pairwise"])
def test_milp_equals_bruteforce(m, n, cost):
    for seed in range(4):
        x, cov = rand_problem(100 * m + 10 * n + seed, m, n, noise=0.6)
        bf = grouping.group_bruteforce(x, cov, cost=cost)
        for relax in (True, False):    # LP relaxation first, and pure branch and bound
            sd = grouping.group_sd(x, cov, cost=cost, relaxation=relax)
            assert sd.cost == pytest.approx(bf.cost, rel=1e-9, abs=1e-9)
            np.testing.assert_array_equal(sd.groups, bf.groups)
        # the reported cost is the sum of the chosen groups' costs
        tensor = grouping.group_costs(x, cov, cost=cost)
        assert tensor[tuple(bf.groups.T)].sum() == pytest.approx(bf.cost, rel=1e-12)


def test_bruteforce_is_minimal_over_independent_enumeration():
    x, cov = rand_problem(7, 3, 3, noise=0.8)
    tensor = grouping.group_costs(x, cov)
    best = min(sum(tensor[k, p[k], q[k]] for k in range(3))
               for p in itertools.permutations(range(3)) for q in itertools.permutations(range(3)))
    assert grouping.group_bruteforce(x, cov).cost == pytest.approx(best, rel=1e-12)


def test_fractional_relaxation_falls_back_to_branch_and_bound():
    # m = 3, n = 2: the four even-parity tuples at z = 1/2 cover every report once.
    # Cost 0 for even parity, 1 for odd: the LP optimum is 0 (fractional), while
    # every grouping pairs a tuple with its complement (opposite parity): cost 1.
    idx = np.indices((2, 2, 2)).reshape(3, -1)
    parity_cost = (idx.sum(axis=0) % 2).astype(float)
    A, _ = grouping._sd_constraints(3, 2)
    lp = linprog(parity_cost, A_eq=A, b_eq=np.ones(6), bounds=(0, 1), method="highs")
    assert lp.fun == pytest.approx(0.0, abs=1e-9)
    chosen, integral = grouping._sd_solve(parity_cost, 3, 2)
    assert not integral
    assert parity_cost[chosen].sum() == pytest.approx(1.0)
    tuples = np.array(np.unravel_index(chosen, (2, 2, 2)))
    np.testing.assert_array_equal(np.sort(tuples, axis=1), [[0, 1]] * 3)


@pytest.mark.parametrize("seed", range(5))
def test_m2_equals_linear_assignment(seed):
    x, cov = rand_problem(seed, 2, 6, d=3, noise=0.8)
    c = np.empty((6, 6))
    for j, k in itertools.product(range(6), repeat=2):
        s = cov[0, j] + cov[1, k]
        c[j, k] = (x[0, j] - x[1, k]) @ np.linalg.solve(s, x[0, j] - x[1, k]) + np.linalg.slogdet(s)[1]
    rows, cols = linear_sum_assignment(c)
    for res in (grouping.group_sd(x, cov), grouping.group_bruteforce(x, cov)):
        np.testing.assert_array_equal(res.groups[:, 1], cols[np.argsort(rows)])
        assert res.cost == pytest.approx(c[rows, cols].sum(), rel=1e-9)


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 10**6))
def test_bruteforce_batch_equals_loop(seed):
    x, cov = rand_problem(seed, 3, 3, noise=0.7)
    rng = np.random.default_rng(seed)
    xb = x[None] + 0.3 * rng.normal(size=(3, *x.shape))
    res = grouping.group_bruteforce(xb, cov)
    for b in range(3):
        one = grouping.group_bruteforce(xb[b], cov)
        np.testing.assert_array_equal(res.groups[b], one.groups)
        assert res.cost[b] == pytest.approx(one.cost)


def test_result_is_frozen_and_normalised():
    x, cov = rand_problem(8, 3, 4)
    res = grouping.group_sd(x, cov)
    with pytest.raises(AttributeError):
        res.cost = 0.0
    np.testing.assert_array_equal(res.groups[:, 0], np.arange(4))
    assert res.method == "milp"
    assert res.cost_kind == "ml"


def test_milp_optimal_at_n20():
    # the benchmark's target size; correctness only (timing is in the benchmark)
    rng = np.random.default_rng(9)
    cov = np.broadcast_to(np.eye(2) * 0.05**2, (3, 1, 2, 2))
    s = grouping.grouping_scene(20, 3, cov=cov, layout="uniform", rng=rng)
    t0 = time.perf_counter()
    res = grouping.group_sd(s.reports[0], s.cov)
    elapsed = time.perf_counter() - t0
    tensor = grouping.group_costs(s.reports[0], s.cov)
    # optimal: never worse than the truth, and the cost is that of the groups returned
    assert res.cost <= tensor[tuple(s.true_groups[0].T)].sum() + 1e-9
    assert res.cost == pytest.approx(tensor[tuple(res.groups.T)].sum(), rel=1e-12)
    assert np.mean(np.all(res.groups == s.true_groups[0], axis=-1)) >= 0.8
    assert elapsed < 60  # sanity only; the 5 s figure is measured by the benchmark


# ---------------------------------------------------------------- binding
def test_binding_paper_cost_is_eq6():
    rng = np.random.default_rng(10)
    x = rng.normal(size=(2, 2, 6))
    cov = rand_spd(rng, (2, 1), 6)
    tracks = rng.normal(size=(2, 6))
    tcov = rand_spd(rng, (2,), 6)
    got = grouping.binding_costs(x, cov, tracks, tcov)
    hyp = grouping.binding_hypotheses(2, 2)
    for h, name in enumerate(["I", "IV", "III", "II"]):
        np.testing.assert_array_equal(hyp[h], grouping.PAPER_HYPOTHESES[name])
        # eq. (6): sum over (i, j, p) of Delta_{ij/p}^T (R_i + R_p)^{-1} Delta_{ij/p}
        ref = 0.0
        for i, p in itertools.product(range(2), repeat=2):
            j = hyp[h, i, p]
            dlt = x[i, j] - tracks[p]
            ref += dlt @ np.linalg.solve(cov[i, 0] + tcov[p], dlt)
        assert got[h] == pytest.approx(ref, rel=1e-12)


def test_binding_exact_cost_is_correlated_gaussian():
    rng = np.random.default_rng(11)
    d = 3
    x = rng.normal(size=(2, 2, d))
    cov = rand_spd(rng, (2, 2), d)
    tracks = rng.normal(size=(2, d))
    tcov = rand_spd(rng, (2,), d)
    got = grouping.binding_costs(x, cov, tracks, tcov, cost="ml")
    for h, hyp in enumerate(grouping.binding_hypotheses(2, 2)):
        ref = 0.0
        for p in range(2):
            j1, j2 = hyp[:, p]
            dlt = np.concatenate([x[0, j1] - tracks[p], x[1, j2] - tracks[p]])
            s = np.block([[cov[0, j1] + tcov[p], tcov[p]], [tcov[p], cov[1, j2] + tcov[p]]])
            ref += -2 * stats.multivariate_normal(np.zeros(2 * d), s).logpdf(dlt)
        assert got[h] == pytest.approx(ref - 2 * 2 * d * np.log(2 * np.pi), rel=1e-10)


def test_binding_batch_broadcast():
    rng = np.random.default_rng(12)
    x = rng.normal(size=(5, 2, 2, 2))
    cov = rand_spd(rng, (2, 1), 2)
    tracks = rng.normal(size=(5, 2, 2))
    tcov = rand_spd(rng, (2,), 2)
    for kind in ("paper", "ml"):
        batch = grouping.binding_costs(x, cov, tracks, tcov, cost=kind)
        assert batch.shape == (5, 4)
        for b in range(5):
            np.testing.assert_allclose(batch[b], grouping.binding_costs(x[b], cov, tracks[b], tcov,
                                                                        cost=kind))


# ---------------------------------------------------------------- scenes
def test_scene_errors_have_the_stated_covariance():
    rng = np.random.default_rng(13)
    c = np.stack([np.array([[1.0, 0.5], [0.5, 2.0]]), np.array([[0.3, -0.1], [-0.1, 0.2]])])
    s = grouping.grouping_scene(3, 2, cov=c[:, None], track_cov=np.eye(2) * 0.7, trials=40_000,
                                rng=rng)
    src = np.take_along_axis(s.truth[:, None], s.owner[..., None], axis=2)
    err = s.reports - src
    for i in range(2):
        e = err[:, i].reshape(-1, 2)
        emp = e.T @ e / len(e)
        # entry-wise tolerance: 5 standard errors of a second moment of Gaussians
        se = np.sqrt((np.outer(np.diag(c[i]), np.diag(c[i])) + c[i] ** 2) / len(e))
        np.testing.assert_array_less(np.abs(emp - c[i]), 5 * se)
    et = (s.tracks - s.truth).reshape(-1, 2)
    np.testing.assert_allclose(et.T @ et / len(et), np.eye(2) * 0.7, atol=5 * 0.7 * np.sqrt(2 / len(et)))


def test_scene_truth_bookkeeping():
    s = grouping.grouping_scene(4, 3, cov=np.eye(2)[None, None] * 1e-6, layout="uniform",
                                trials=50, rng=14)
    tg = s.true_groups
    for t in range(50):
        for k in range(4):
            owners = {int(s.owner[t, i, tg[t, k, i]]) for i in range(3)}
            assert len(owners) == 1
    assert np.all(s.is_correct(tg))
    res = grouping.group_bruteforce(s.reports, s.cov)
    assert np.all(s.is_correct(res.groups))


def test_ml_beats_pairwise_when_covariances_differ():
    # Statistical: the ML rule is right more often than the paper's pairwise
    # cost when the sources' error ellipses point in different directions.
    rng = np.random.default_rng(15)

    def rot(theta, sl, ss):
        c, s_ = np.cos(theta), np.sin(theta)
        r = np.array([[c, -s_], [s_, c]])
        return r @ np.diag([sl**2, ss**2]) @ r.T

    cov = np.stack([rot(k * np.pi / 3, 0.6, 0.1) for k in range(3)])[:, None]
    trials = 4000
    s = grouping.grouping_scene(3, 3, cov=cov, layout="uniform", trials=trials, rng=rng)
    ok_ml = s.is_correct(grouping.group_bruteforce(s.reports, s.cov).groups)
    ok_pw = s.is_correct(grouping.group_bruteforce(s.reports, s.cov, cost="pairwise").groups)
    diff = ok_ml.astype(float) - ok_pw
    se = diff.std(ddof=1) / np.sqrt(trials)
    assert diff.mean() > 5 * se
    # and the ML success rate is a proportion consistent with itself (sanity of the tolerance helper)
    assert binomial_tolerance(max(ok_ml.mean(), 1e-3), trials) > 0


def test_binding_exact_beats_paper_with_poor_tracks():
    rng = np.random.default_rng(16)
    r = np.eye(3)[None, None] * 0.3**2
    s = grouping.grouping_scene(2, 2, cov=r, spacing=1.0, track_cov=np.eye(3) * 1.0,
                                trials=6000, rng=rng)
    truth = s.true_hypothesis()
    paper = np.argmin(grouping.binding_costs(s.reports, s.cov, s.tracks, s.track_cov), -1) == truth
    exact = np.argmin(grouping.binding_costs(s.reports, s.cov, s.tracks, s.track_cov, cost="ml"),
                      -1) == truth
    diff = exact.astype(float) - paper
    assert diff.mean() > 5 * diff.std(ddof=1) / np.sqrt(len(diff))


# ---------------------------------------------------------------- bad input
def test_mismatched_report_counts():
    x = [np.zeros((3, 2)), np.zeros((2, 2))]
    with pytest.raises(ValueError, match=r"`x`.*same number n of reports"):
        grouping.group_sd(x, np.eye(2)[None, None])


def test_single_source_rejected():
    with pytest.raises(ValueError, match=r"`x`.*m >= 2"):
        grouping.group_bruteforce(np.zeros((1, 3, 2)), np.eye(2)[None, None])
    with pytest.raises(ValueError, match="`n_sources`"):
        grouping.n_groupings(3, 1)
    assert grouping.n_groupings(3, 1, binding=True) == 6


def test_singular_covariance_rejected():
    cov = np.broadcast_to(np.diag([1.0, 0.0]), (2, 2, 2, 2))
    with pytest.raises(ValueError, match="`cov` must be positive definite"):
        grouping.group_sd(np.zeros((2, 2, 2)), cov)
    with pytest.raises(ValueError, match="`track_cov` must be positive definite"):
        grouping.binding_costs(np.zeros((2, 2, 2)), np.eye(2)[None, None], np.zeros((2, 2)),
                               np.diag([1.0, 0.0])[None])


def test_other_bad_input():
    x = np.zeros((2, 3, 2))
    with pytest.raises(ValueError, match="`cov`"):
        grouping.group_costs(x, np.eye(3)[None, None])
    with pytest.raises(ValueError, match="`cov`"):
        grouping.group_costs(x, np.broadcast_to(np.eye(2), (2, 2, 2, 2)))
    with pytest.raises(ValueError, match="`cost`"):
        grouping.group_costs(x, np.eye(2)[None, None], cost="nearest")
    with pytest.raises(ValueError, match="`x` must be finite"):
        grouping.group_costs(np.full((2, 3, 2), np.nan), np.eye(2)[None, None])
    with pytest.raises(ValueError, match="`tracks`"):
        grouping.binding_costs(x, np.eye(2)[None, None], np.zeros((2, 2)), np.eye(2)[None])
    with pytest.raises(ValueError, match="`max_groupings`"):
        grouping.group_bruteforce(np.zeros((3, 6, 1)), np.ones((1, 1, 1, 1)), max_groupings=100)
    with pytest.raises(TypeError, match="`n_targets`"):
        grouping.n_groupings(2.0, 2)
    with pytest.raises(TypeError, match="`rng`"):
        grouping.grouping_scene(2, 2, cov=np.eye(2)[None, None], rng=np.random.RandomState(0))
