"""Tests of radarfusion_ref.association.

Oracles are independent of the code under test: enumeration written here with
itertools, the standard augmented (n1 + n2) assignment matrix, hand-worked
cases of the paper's pointwise rule, a sympy derivation of the likelihood
ratio, and scipy.stats closed forms for the Monte-Carlo checks.
"""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np
import pytest
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats
from scipy.optimize import linear_sum_assignment

from radarfusion_ref import association as A
from radarfusion_ref import scenes
from radarfusion_ref.errors import RadarFusionWarning
from radarfusion_ref.montecarlo import binomial_tolerance

# ----------------------------------------------------------------------------- helpers


def enumerate_complete(cost):
    """All complete assignments of the shorter side, as (row_to_col, total), by itertools."""
    c = np.asarray(cost, dtype=float)
    n1, n2 = c.shape
    out = []
    if n1 <= n2:
        for perm in itertools.permutations(range(n2), n1):
            out.append((np.array(perm), sum(c[i, j] for i, j in enumerate(perm))))
    else:
        for perm in itertools.permutations(range(n1), n2):
            r2c = -np.ones(n1, dtype=int)
            r2c[list(perm)] = np.arange(n2)
            out.append((r2c, sum(c[i, j] for j, i in enumerate(perm))))
    return out


def augmented_optimum(cost, miss, threshold=None):
    """The textbook augmented matrix: [[C, m*I-ish], [m*I-ish, 0]], solved by LSA."""
    c = np.asarray(cost, dtype=float)
    n1, n2 = c.shape
    big = np.inf
    cc = c.copy()
    if threshold is not None:
        cc[cc >= threshold] = big      # the gate is strict: kappa < gamma
    top_right = np.full((n1, n1), big)
    np.fill_diagonal(top_right, miss)
    bottom_left = np.full((n2, n2), big)
    np.fill_diagonal(bottom_left, miss)
    aug = np.block([[cc, top_right], [bottom_left, np.zeros((n2, n1))]])
    r, k = linear_sum_assignment(aug)
    return float(aug[r, k].sum())


def check_feasible(result, cost, threshold=None):
    """Pairs are a matching of allowed entries and total_cost adds up."""
    pairs = result.pairs
    assert len(set(pairs[:, 0])) == len(pairs)
    assert len(set(pairs[:, 1])) == len(pairs)
    vals = np.asarray(cost)[pairs[:, 0], pairs[:, 1]] if len(pairs) else np.zeros(0)
    assert np.all(np.isfinite(vals))
    if threshold is not None:
        assert np.all(vals < threshold)


cost_values = st.one_of(st.integers(0, 4).map(float),
                        st.floats(0.0, 10.0, allow_nan=False, allow_infinity=False))


@st.composite
def cost_matrices(draw, max_n=5, allow_inf=True):
    n1 = draw(st.integers(1, max_n))
    n2 = draw(st.integers(1, max_n))
    vals = draw(st.lists(cost_values, min_size=n1 * n2, max_size=n1 * n2))
    c = np.array(vals).reshape(n1, n2)
    if allow_inf:
        mask = draw(st.lists(st.booleans(), min_size=n1 * n2, max_size=n1 * n2))
        if draw(st.booleans()):
            c[np.array(mask).reshape(n1, n2)] = np.inf
    return c


# ----------------------------------------------------------------------------- joint == brute force


@given(cost_matrices(),
       st.one_of(st.none(), st.floats(0.1, 10.0)),
       st.one_of(st.none(), st.floats(-1.0, 6.0)))
def test_joint_equals_bruteforce(cost, threshold, miss):
    j = A.associate_joint(cost, threshold=threshold, miss_cost=miss)
    b = A.associate_bruteforce(cost, threshold=threshold, miss_cost=miss)
    assert j.total_cost == pytest.approx(b.total_cost, rel=1e-9, abs=1e-9)
    assert j.n_assigned == b.n_assigned
    check_feasible(j, cost, threshold)


@given(cost_matrices(allow_inf=False))
def test_joint_complete_equals_itertools_enumeration(cost):
    best = min(t for _, t in enumerate_complete(cost))
    j = A.associate_joint(cost)
    assert j.total_cost == pytest.approx(best, abs=1e-9)
    assert j.n_assigned == min(cost.shape)


@given(cost_matrices(), st.floats(-1.0, 6.0), st.one_of(st.none(), st.floats(0.1, 10.0)))
def test_miss_cost_equals_augmented_matrix(cost, miss, threshold):
    j = A.associate_joint(cost, threshold=threshold, miss_cost=miss)
    assert j.total_cost == pytest.approx(augmented_optimum(cost, miss, threshold), abs=1e-9)


@given(cost_matrices(max_n=4), st.floats(0.1, 10.0))
def test_threshold_only_is_maximum_cardinality(cost, threshold):
    allowed = np.isfinite(cost) & (cost < threshold)
    n1, n2 = cost.shape
    best = 0
    for k in range(min(n1, n2), 0, -1):
        found = any(all(allowed[i, j] for i, j in zip(rows, cols, strict=True))
                    for rows in itertools.combinations(range(n1), k)
                    for cols in itertools.permutations(range(n2), k))
        if found:
            best = k
            break
    assert A.associate_joint(cost, threshold=threshold).n_assigned == best


def test_joint_batch_equals_loop():
    rng = np.random.default_rng(0)
    c = rng.random((4, 3, 5, 6))
    batch = A.associate_joint(c, miss_cost=0.3)
    for idx in np.ndindex(4, 3):
        single = A.associate_joint(c[idx], miss_cost=0.3)
        np.testing.assert_array_equal(batch.row_to_col[idx], single.row_to_col)
        assert batch.total_cost[idx] == pytest.approx(single.total_cost)


def test_bruteforce_square_n8_matches_joint():
    rng = np.random.default_rng(1)
    c = rng.random((3, 8, 8))
    np.testing.assert_array_equal(A.associate_bruteforce(c).row_to_col,
                                  A.associate_joint(c).row_to_col)


def test_bruteforce_too_large():
    with pytest.raises(ValueError, match="`cost`"):
        A.associate_bruteforce(np.zeros((11, 11)))


def test_joint_large_rectangular_feasible():
    rng = np.random.default_rng(2)
    c = rng.random((60, 80))
    r = A.associate_joint(c, threshold=0.5, miss_cost=0.2)
    check_feasible(r, c, 0.5)
    assert np.all(c[r.pairs[:, 0], r.pairs[:, 1]] < 0.4)


def test_result_fields():
    r = A.associate_joint([[1.0, 9.0, 9.0], [9.0, 9.0, 2.0]], miss_cost=2.0)
    assert r.pairs.tolist() == [[0, 0], [1, 2]]
    assert r.unassigned_rows.tolist() == []
    assert r.unassigned_cols.tolist() == [1]
    assert r.total_cost == pytest.approx(1.0 + 2.0 + 2.0)
    np.testing.assert_array_equal(r.col_to_row, [0, -1, 1])
    with pytest.raises(AttributeError):
        r.total_cost = 0.0  # frozen
    batch = A.associate_joint(np.zeros((2, 2, 2)))
    with pytest.raises(ValueError, match="`pairs`"):
        _ = batch.pairs


# ----------------------------------------------------------------------------- gating edge cases


def test_all_gated_out_returns_no_pairs():
    c = np.full((3, 4), 50.0)
    for r in (A.associate_joint(c, threshold=1.0),
              A.associate_joint(c, threshold=1.0, miss_cost=0.5),
              A.associate_pointwise(c, 1.0),
              A.associate_pointwise(c, 1.0, order="best_first"),
              A.associate_bruteforce(c, threshold=1.0)):
        assert r.n_assigned == 0
        assert r.unassigned_rows.tolist() == [0, 1, 2]
        assert r.unassigned_cols.tolist() == [0, 1, 2, 3]
    np.testing.assert_array_equal(A.associate_joint(np.full((2, 2), np.inf)).row_to_col, [-1, -1])


# ----------------------------------------------------------------------------- pointwise rule


def test_pointwise_scan_hand_worked():
    # Paper's rule: scan hypotheses in list order, accept the first with kappa < threshold,
    # remove both reports, continue.
    #   row 0: (0,0)=2.0 >= 1.5 rejected, (0,1)=1.0 accepted -> remove row 0, column 1
    #   row 1: (1,0)=0.2 accepted -> remove column 0
    #   row 2: (2,0) taken, (2,1) taken, (2,2)=1.6 rejected -> row 2 unassigned
    c = np.array([[2.0, 1.0, 0.1],
                  [0.2, 0.1, 3.0],
                  [0.3, 0.4, 1.6]])
    r = A.associate_pointwise(c, 1.5)
    np.testing.assert_array_equal(r.row_to_col, [1, 0, -1])
    assert r.total_cost == pytest.approx(1.2)
    # best first: 0.1 at (0,2), 0.1 at (1,1) (first in row-major order), then 0.3 at (2,0)
    g = A.associate_pointwise(c, 1.5, order="best_first")
    np.testing.assert_array_equal(g.row_to_col, [2, 1, 0])
    # the joint optimum here happens to equal the greedy choice
    assert A.associate_joint(c).total_cost == pytest.approx(0.5)


def test_pointwise_strict_inequality():
    # kappa* < kappa_th accepts; equality rejects (the paper's strict rule)
    r = A.associate_pointwise([[1.0]], 1.0)
    assert r.n_assigned == 0


def test_pointwise_order_matters_but_joint_does_not():
    c = np.array([[0.5, 0.1], [0.2, 3.0]])
    np.testing.assert_array_equal(A.associate_pointwise(c, 1.0).row_to_col, [0, -1])
    flipped = c[::-1]
    np.testing.assert_array_equal(A.associate_pointwise(flipped, 1.0).row_to_col, [0, 1])
    assert A.associate_joint(c).total_cost == A.associate_joint(flipped).total_cost


def greedy_reference(c, th):
    c = np.array(c, dtype=float)
    out = -np.ones(c.shape[0], dtype=int)
    entries = sorted((c[i, j], i, j) for i in range(c.shape[0]) for j in range(c.shape[1]))
    rows, cols = set(), set()
    for v, i, j in entries:
        if v < th and i not in rows and j not in cols:
            out[i] = j
            rows.add(i)
            cols.add(j)
    return out


def scan_reference(c, th):
    c = np.array(c, dtype=float)
    out = -np.ones(c.shape[0], dtype=int)
    used = set()
    for i in range(c.shape[0]):
        for j in range(c.shape[1]):
            if j not in used and c[i, j] < th:
                out[i] = j
                used.add(j)
                break
    return out


@given(cost_matrices(max_n=6), st.floats(0.1, 12.0))
def test_pointwise_against_plain_python(cost, th):
    np.testing.assert_array_equal(A.associate_pointwise(cost, th).row_to_col,
                                  scan_reference(cost, th))
    np.testing.assert_array_equal(A.associate_pointwise(cost, th, order="best_first").row_to_col,
                                  greedy_reference(cost, th))


def test_pointwise_batch_equals_loop():
    rng = np.random.default_rng(3)
    c = rng.random((50, 6, 7)) * 4
    for order in ("scan", "best_first"):
        batch = A.associate_pointwise(c, 1.0, order=order)
        for t in range(50):
            np.testing.assert_array_equal(batch.row_to_col[t],
                                          A.associate_pointwise(c[t], 1.0, order=order).row_to_col)


def test_greedy_is_not_joint_ml():
    # the counterexample used in the chapter's erratum
    c = np.array([[1.0, 2.0], [2.0, 100.0]])
    assert A.associate_pointwise(c, np.inf, order="best_first").total_cost == 101.0
    assert A.associate_joint(c).total_cost == 4.0


# ----------------------------------------------------------------------------- k best


@given(cost_matrices(max_n=5), st.integers(1, 130))
def test_murty_equals_sorted_bruteforce(cost, k):
    every = sorted(t for _, t in enumerate_complete(cost) if np.isfinite(t))
    r = A.k_best_assignments(cost, k)
    assert r.k == min(k, len(every))
    np.testing.assert_allclose(r.costs, every[:r.k], atol=1e-9)
    assert len({tuple(a) for a in r.assignments}) == r.k
    for a, total in zip(r.assignments, r.costs, strict=True):
        rows = np.flatnonzero(a >= 0)
        assert len(rows) == min(cost.shape)
        assert cost[rows, a[rows]].sum() == pytest.approx(total)


def test_murty_distinct_costs_same_assignments():
    rng = np.random.default_rng(4)
    c = rng.random((6, 6))
    every = sorted(enumerate_complete(c), key=lambda x: x[1])
    r = A.k_best_assignments(c, 40)
    for (a_ref, _), a in zip(every[:40], r.assignments, strict=True):
        np.testing.assert_array_equal(a, a_ref)


def test_murty_larger_costs_match_lower_bound_logic():
    rng = np.random.default_rng(5)
    c = rng.random((30, 30))
    r = A.k_best_assignments(c, 60)
    assert np.all(np.diff(r.costs) >= -1e-12)
    assert r.costs[0] == pytest.approx(A.associate_joint(c).total_cost)
    assert len({tuple(a) for a in r.assignments}) == 60


# ----------------------------------------------------------------------------- marginals


def test_marginals_two_by_two_closed_form():
    a, b = 0.3, 1.7
    c = np.array([[0.0, a], [b, 0.0]])
    p = A.association_probabilities(c)
    # P(identity) = 1 / (1 + exp(-(a + b)))
    p_id = 1.0 / (1.0 + math.exp(-(a + b)))
    np.testing.assert_allclose(p, [[p_id, 1 - p_id], [1 - p_id, p_id]])


def test_marginals_k_best_all_equals_exact():
    rng = np.random.default_rng(6)
    c = rng.random((5, 5)) * 3
    exact = A.association_probabilities(c)
    np.testing.assert_allclose(A.association_probabilities(c, k=120), exact, atol=1e-12)
    np.testing.assert_allclose(exact.sum(axis=1), 1.0)
    np.testing.assert_allclose(exact.sum(axis=0), 1.0)
    # exact against a direct itertools computation
    ref = np.zeros((5, 5))
    for perm in itertools.permutations(range(5)):
        w = math.exp(-sum(c[i, j] for i, j in enumerate(perm)))
        for i, j in enumerate(perm):
            ref[i, j] += w
    np.testing.assert_allclose(exact, ref / ref.sum(axis=1, keepdims=True))


def test_marginals_rectangular():
    rng = np.random.default_rng(7)
    c = rng.random((3, 5))
    p = A.association_probabilities(c)
    np.testing.assert_allclose(p.sum(axis=1), 1.0)
    np.testing.assert_allclose(A.association_probabilities(c.T), p.T)


# ----------------------------------------------------------------------------- non-assignment cost


def test_non_assignment_cost_from_sympy():
    beta, p1, p2, l1, l2, s2, kap = sp.symbols("beta P_1 P_2 lambda_1 lambda_2 S kappa",
                                               positive=True)
    u1 = l1 + beta * p1 * (1 - p2)
    u2 = l2 + beta * p2 * (1 - p1)
    g = sp.exp(-kap / 2) / sp.sqrt(2 * sp.pi * s2)          # N(x1 - x2; 0, S), kappa = diff^2/S
    boundary = sp.solve(sp.Eq(beta * p1 * p2 * g, u1 * u2), kap)[0]
    m = sp.lambdify((beta, p1, p2, l1, l2, s2), boundary / 2)
    rng = np.random.default_rng(8)
    for _ in range(20):
        vals = (rng.uniform(0.5, 2), rng.uniform(0.6, 0.99), rng.uniform(0.6, 0.99),
                rng.uniform(0.01, 0.1), rng.uniform(0.01, 0.1), rng.uniform(0.001, 0.05))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RadarFusionWarning)
            got = A.non_assignment_cost(p_detect1=vals[1], p_detect2=vals[2],
                                        false_density1=vals[3], false_density2=vals[4],
                                        object_density=vals[0], innovation_cov=vals[5])
        assert got == pytest.approx(m(*vals), rel=1e-12)


def test_non_assignment_cost_matrix_form():
    kw = dict(p_detect1=0.9, p_detect2=0.8, false_density1=0.05, false_density2=0.02,
              object_density=0.3)
    s = np.diag([0.04, 0.09])
    two_d = A.non_assignment_cost(innovation_cov=s, **kw)
    # a diagonal S factorises: log det(2 pi S) = sum of the 1-D terms
    one_a = A.non_assignment_cost(innovation_cov=0.04, **kw)
    expected = one_a - 0.5 * math.log(2 * math.pi * 0.09)
    assert two_d == pytest.approx(expected)


def test_non_assignment_cost_infinite_and_warning():
    assert A.non_assignment_cost(p_detect1=1.0, p_detect2=1.0, false_density1=0.0,
                                 false_density2=0.0, object_density=1.0,
                                 innovation_cov=0.1) == np.inf
    with pytest.warns(RadarFusionWarning, match="non-assignment cost"):
        A.non_assignment_cost(p_detect1=0.5, p_detect2=0.5, false_density1=100.0,
                              false_density2=100.0, object_density=0.01, innovation_cov=1.0)


def test_non_assignment_cost_bad_input():
    kw = dict(p_detect2=0.9, false_density1=0.1, false_density2=0.1, object_density=1.0,
              innovation_cov=0.1)
    with pytest.raises(ValueError, match="`p_detect1`"):
        A.non_assignment_cost(p_detect1=0.0, **kw)
    with pytest.raises(ValueError, match="`p_detect1`"):
        A.non_assignment_cost(p_detect1=1.2, **kw)
    kw2 = dict(kw, false_density1=-1.0)
    with pytest.raises(ValueError, match="`false_density1`"):
        A.non_assignment_cost(p_detect1=0.9, **kw2)
    kw3 = dict(kw, innovation_cov=[[1.0, 2.0], [2.0, 1.0]])
    with pytest.raises(ValueError, match="`innovation_cov`"):
        A.non_assignment_cost(p_detect1=0.9, **kw3)


def test_miss_cost_rule_pair_iff_below_twice_miss():
    # one report each: paired iff kappa < 2m (the likelihood-ratio boundary)
    m = 1.3
    assert A.associate_joint([[2 * m - 1e-6]], miss_cost=m).n_assigned == 1
    assert A.associate_joint([[2 * m + 1e-6]], miss_cost=m).n_assigned == 0


# ----------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("func", [
    lambda c: A.associate_joint(c),
    lambda c: A.associate_bruteforce(c),
    lambda c: A.associate_pointwise(c, 1.0),
    lambda c: A.k_best_assignments(c, 2),
    lambda c: A.association_probabilities(c),
])
@pytest.mark.parametrize("bad", [
    [[1.0, np.nan], [0.0, 1.0]],
    [[1.0, -np.inf], [0.0, 1.0]],
    np.zeros((0, 3)),
    np.zeros((2, 0)),
    [1.0, 2.0],
])
def test_bad_cost(func, bad):
    with pytest.raises(ValueError, match="`cost`"):
        func(bad)


def test_bad_cost_type():
    with pytest.raises(TypeError, match="`cost`"):
        A.associate_joint("abc")


@pytest.mark.parametrize("th", [0.0, -1.0, np.nan])
def test_bad_threshold(th):
    with pytest.raises(ValueError, match="`threshold`"):
        A.associate_joint(np.eye(2), threshold=th)
    with pytest.raises(ValueError, match="`threshold`"):
        A.associate_pointwise(np.eye(2), th)


def test_bad_k_and_order_and_miss():
    with pytest.raises(ValueError, match="`k`"):
        A.k_best_assignments(np.eye(2), 0)
    with pytest.raises(TypeError, match="`k`"):
        A.k_best_assignments(np.eye(2), 2.5)
    with pytest.raises(ValueError, match="`order`"):
        A.associate_pointwise(np.eye(2), 1.0, order="random")
    with pytest.raises(ValueError, match="`miss_cost`"):
        A.associate_joint(np.eye(2), miss_cost=np.nan)
    with pytest.raises(ValueError, match="`miss_cost`"):
        A.associate_joint(np.eye(2), miss_cost=-np.inf)
    with pytest.raises(ValueError, match="`cost`"):
        A.k_best_assignments(np.zeros((2, 2, 2)), 1)


def test_miss_cost_inf_is_none():
    c = np.array([[0.1, 5.0], [5.0, 9.0]])
    a = A.associate_joint(c, threshold=6.0, miss_cost=np.inf)
    b = A.associate_joint(c, threshold=6.0)
    np.testing.assert_array_equal(a.row_to_col, b.row_to_col)


# ----------------------------------------------------------------------------- scenes and Monte Carlo


def test_clutter_scene_statistics():
    n, trials = 5, 20_000
    s = A.two_radar_clutter_scene(n, spacing=2.0, sigma1=0.1, sigma2=0.1, p_detect1=0.8,
                                  p_detect2=0.6, false_density1=0.1, false_density2=0.3,
                                  trials=trials, rng=11)
    assert s.volume == pytest.approx(n * 2.0)
    det1 = np.count_nonzero(s.owner1 >= 0) / (n * trials)
    det2 = np.count_nonzero(s.owner2 >= 0) / (n * trials)
    assert abs(det1 - 0.8) < binomial_tolerance(0.8, n * trials)
    assert abs(det2 - 0.6) < binomial_tolerance(0.6, n * trials)
    # Poisson false-report counts: mean = variance = lambda V
    for own, lam in ((s.owner1, 0.1), (s.owner2, 0.3)):
        counts = np.count_nonzero(own == -1, axis=1)
        mu = lam * s.volume
        assert abs(counts.mean() - mu) < 5 * math.sqrt(mu / trials)
    # false reports inside the box; true pairs map object to object
    f = s.reports1[s.owner1 == -1]
    assert np.all((f >= s.region_low) & (f <= s.region_high))
    t2c = s.true_row_to_col
    rows = np.nonzero(t2c >= 0)
    np.testing.assert_array_equal(s.owner1[rows], s.owner2[rows[0], t2c[rows]])
    both = np.count_nonzero(t2c >= 0) / (n * trials)
    assert abs(both - 0.48) < binomial_tolerance(0.48, n * trials)


def test_clutter_scene_defaults_reduce_to_base_scene():
    s = A.two_radar_clutter_scene(4, spacing=1.0, sigma1=0.1, sigma2=0.1, trials=10, rng=1)
    assert s.reports1.shape == (10, 4, 1) and s.reports2.shape == (10, 4, 1)
    assert np.all(s.true_row_to_col >= 0)
    k = s.mask_cost(A.proximity_matrix(s.reports1, s.reports2, 0.1, 0.1))
    assert np.all(np.isfinite(k))


def test_joint_statistic_noncentral_chi2():
    # One adjacent swap among n objects on a line: kappa_n ~ chi2'(n, 2V), V = s^2/(s1^2+s2^2).
    n, trials, sig = 6, 40_000, 0.5
    sc = scenes.two_radar_scene(n, spacing=1.0, sigma1=sig, sigma2=sig, trials=trials, rng=12)
    kap = A.proximity_matrix(sc.reports1, sc.reports2, sig, sig)
    hyp = sc.true_match.copy()                      # radar-1 rows are in object order
    hyp[:, [2, 3]] = hyp[:, [3, 2]]
    stat = np.take_along_axis(kap, hyp[..., None], axis=-1)[..., 0].sum(-1)
    lam = 2 * 1.0 / (2 * sig**2)
    th = stats.chi2.ppf(0.99, n)
    p_exact = stats.ncx2.cdf(th, n, lam)
    p_mc = np.mean(stat < th)
    assert abs(p_mc - p_exact) < binomial_tolerance(p_exact, trials)
    assert abs(stat.mean() - (n + lam)) < 5 * math.sqrt(2 * (n + 2 * lam) / trials)


def test_compare_decisions_separated_and_hand_case():
    sc = A.two_radar_clutter_scene(5, spacing=1.0, sigma1=0.02, sigma2=0.02, trials=500, rng=3)
    kap = A.proximity_matrix(sc.reports1, sc.reports2, 0.02, 0.02)
    r = A.compare_decisions(kap, sc.true_row_to_col, threshold=stats.chi2.ppf(0.999, 1),
                            joint_threshold=stats.chi2.ppf(0.999, 5))
    for p in (r.pointwise, r.greedy, r.joint_ml):
        assert p.estimate > 0.98
    # joint test can only lose decisions
    assert r.joint.estimate <= r.joint_ml.estimate
    with pytest.raises(ValueError, match="`kappa`"):
        A.compare_decisions(kap[0], sc.true_row_to_col[0], threshold=1.0, joint_threshold=1.0)


def test_all_correct():
    np.testing.assert_array_equal(A.all_correct([[0, -1], [0, 1]], [[0, -1], [0, -1]]),
                                  [True, False])
