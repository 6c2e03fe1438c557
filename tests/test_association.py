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
from radarfusion_ref.engine import assignment as asg
from radarfusion_ref.engine import scenes
from radarfusion_ref.engine.errors import RadarFusionWarning
from radarfusion_ref.engine.montecarlo import binomial_tolerance

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
    j = asg.assign_two_lists(cost, threshold=threshold, miss_cost=miss)
    b = asg.assign_two_lists_bruteforce(cost, threshold=threshold, miss_cost=miss)
    assert j.cost == pytest.approx(b.cost, rel=1e-9, abs=1e-9)
    assert j.n_assigned == b.n_assigned
    check_feasible(j, cost, threshold)


@given(cost_matrices(allow_inf=False))
def test_joint_complete_equals_itertools_enumeration(cost):
    best = min(t for _, t in enumerate_complete(cost))
    j = asg.assign_two_lists(cost)
    assert j.cost == pytest.approx(best, abs=1e-9)
    assert j.n_assigned == min(cost.shape)


@given(cost_matrices(), st.floats(-1.0, 6.0), st.one_of(st.none(), st.floats(0.1, 10.0)))
def test_miss_cost_equals_augmented_matrix(cost, miss, threshold):
    j = asg.assign_two_lists(cost, threshold=threshold, miss_cost=miss)
    assert j.cost == pytest.approx(augmented_optimum(cost, miss, threshold), abs=1e-9)


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
    assert asg.assign_two_lists(cost, threshold=threshold).n_assigned == best


def test_joint_batch_equals_loop():
    rng = np.random.default_rng(0)
    c = rng.random((4, 3, 5, 6))
    batch = asg.assign_two_lists(c, miss_cost=0.3)
    for idx in np.ndindex(4, 3):
        single = asg.assign_two_lists(c[idx], miss_cost=0.3)
        np.testing.assert_array_equal(batch.row_to_col[idx], single.row_to_col)
        assert batch.cost[idx] == pytest.approx(single.cost)


def test_bruteforce_square_n8_matches_joint():
    rng = np.random.default_rng(1)
    c = rng.random((3, 8, 8))
    np.testing.assert_array_equal(asg.assign_two_lists_bruteforce(c).row_to_col,
                                  asg.assign_two_lists(c).row_to_col)


def test_bruteforce_too_large():
    with pytest.raises(ValueError, match="`cost`"):
        asg.assign_two_lists_bruteforce(np.zeros((11, 11)))


def test_joint_large_rectangular_feasible():
    rng = np.random.default_rng(2)
    c = rng.random((60, 80))
    r = asg.assign_two_lists(c, threshold=0.5, miss_cost=0.2)
    check_feasible(r, c, 0.5)
    assert np.all(c[r.pairs[:, 0], r.pairs[:, 1]] < 0.4)


def test_result_fields():
    r = asg.assign_two_lists([[1.0, 9.0, 9.0], [9.0, 9.0, 2.0]], miss_cost=2.0)
    assert r.pairs.tolist() == [[0, 0], [1, 2]]
    assert r.unassigned_rows.tolist() == []
    assert r.unassigned_cols.tolist() == [1]
    assert r.cost == pytest.approx(1.0 + 2.0 + 2.0)
    np.testing.assert_array_equal(r.col_to_row, [0, -1, 1])
    with pytest.raises(AttributeError):
        r.cost = 0.0  # frozen
    batch = asg.assign_two_lists(np.zeros((2, 2, 2)))
    with pytest.raises(ValueError, match="`pairs`"):
        _ = batch.pairs


# ----------------------------------------------------------------------------- gating edge cases


def test_all_gated_out_returns_no_pairs():
    c = np.full((3, 4), 50.0)
    for r in (asg.assign_two_lists(c, threshold=1.0),
              asg.assign_two_lists(c, threshold=1.0, miss_cost=0.5),
              A.associate_pointwise(c, 1.0),
              A.associate_pointwise(c, 1.0, order="best_first"),
              asg.assign_two_lists_bruteforce(c, threshold=1.0)):
        assert r.n_assigned == 0
        assert r.unassigned_rows.tolist() == [0, 1, 2]
        assert r.unassigned_cols.tolist() == [0, 1, 2, 3]
    np.testing.assert_array_equal(asg.assign_two_lists(np.full((2, 2), np.inf)).row_to_col, [-1, -1])


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
    assert r.cost == pytest.approx(1.2)
    # best first: 0.1 at (0,2), 0.1 at (1,1) (first in row-major order), then 0.3 at (2,0)
    g = A.associate_pointwise(c, 1.5, order="best_first")
    np.testing.assert_array_equal(g.row_to_col, [2, 1, 0])
    # the joint optimum here happens to equal the greedy choice
    assert asg.assign_two_lists(c).cost == pytest.approx(0.5)


def test_pointwise_strict_inequality():
    # kappa* < kappa_th accepts; equality rejects (the paper's strict rule)
    r = A.associate_pointwise([[1.0]], 1.0)
    assert r.n_assigned == 0


def test_pointwise_order_matters_but_joint_does_not():
    c = np.array([[0.5, 0.1], [0.2, 3.0]])
    np.testing.assert_array_equal(A.associate_pointwise(c, 1.0).row_to_col, [0, -1])
    flipped = c[::-1]
    np.testing.assert_array_equal(A.associate_pointwise(flipped, 1.0).row_to_col, [0, 1])
    assert asg.assign_two_lists(c).cost == asg.assign_two_lists(flipped).cost


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
    assert A.associate_pointwise(c, np.inf, order="best_first").cost == 101.0
    assert asg.assign_two_lists(c).cost == 4.0


# ----------------------------------------------------------------------------- k best


@given(cost_matrices(max_n=5), st.integers(1, 130))
def test_murty_equals_sorted_bruteforce(cost, k):
    every = sorted(t for _, t in enumerate_complete(cost) if np.isfinite(t))
    r = asg.k_best_two_lists(cost, k)
    assert r.k == min(k, len(every))
    np.testing.assert_allclose(r.cost, every[:r.k], atol=1e-9)
    assert len({tuple(a) for a in r.row_to_col}) == r.k
    for a, total in zip(r.row_to_col, r.cost, strict=True):
        rows = np.flatnonzero(a >= 0)
        assert len(rows) == min(cost.shape)
        assert cost[rows, a[rows]].sum() == pytest.approx(total)


def test_murty_distinct_costs_same_assignments():
    rng = np.random.default_rng(4)
    c = rng.random((6, 6))
    every = sorted(enumerate_complete(c), key=lambda x: x[1])
    r = asg.k_best_two_lists(c, 40)
    for (a_ref, _), a in zip(every[:40], r.row_to_col, strict=True):
        np.testing.assert_array_equal(a, a_ref)


def test_murty_larger_costs_match_lower_bound_logic():
    rng = np.random.default_rng(5)
    c = rng.random((30, 30))
    r = asg.k_best_two_lists(c, 60)
    assert np.all(np.diff(r.cost) >= -1e-12)
    assert r.cost[0] == pytest.approx(asg.assign_two_lists(c).cost)
    assert len({tuple(a) for a in r.row_to_col}) == 60


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
    assert asg.assign_two_lists([[2 * m - 1e-6]], miss_cost=m).n_assigned == 1
    assert asg.assign_two_lists([[2 * m + 1e-6]], miss_cost=m).n_assigned == 0


# ----------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("func", [
    lambda c: asg.assign_two_lists(c),
    lambda c: asg.assign_two_lists_bruteforce(c),
    lambda c: A.associate_pointwise(c, 1.0),
    lambda c: asg.k_best_two_lists(c, 2),
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
        asg.assign_two_lists("abc")


@pytest.mark.parametrize("th", [0.0, -1.0, np.nan])
def test_bad_threshold(th):
    with pytest.raises(ValueError, match="`threshold`"):
        asg.assign_two_lists(np.eye(2), threshold=th)
    with pytest.raises(ValueError, match="`threshold`"):
        A.associate_pointwise(np.eye(2), th)


def test_bad_k_and_order_and_miss():
    with pytest.raises(ValueError, match="`k`"):
        asg.k_best_two_lists(np.eye(2), 0)
    with pytest.raises(TypeError, match="`k`"):
        asg.k_best_two_lists(np.eye(2), 2.5)
    with pytest.raises(ValueError, match="`order`"):
        A.associate_pointwise(np.eye(2), 1.0, order="random")
    with pytest.raises(ValueError, match="`miss_cost`"):
        asg.assign_two_lists(np.eye(2), miss_cost=np.nan)
    with pytest.raises(ValueError, match="`miss_cost`"):
        asg.assign_two_lists(np.eye(2), miss_cost=-np.inf)
    with pytest.raises(ValueError, match="`cost`"):
        asg.k_best_two_lists(np.zeros((2, 2, 2)), 1)


def test_miss_cost_inf_is_none():
    c = np.array([[0.1, 5.0], [5.0, 9.0]])
    a = asg.assign_two_lists(c, threshold=6.0, miss_cost=np.inf)
    b = asg.assign_two_lists(c, threshold=6.0)
    np.testing.assert_array_equal(a.row_to_col, b.row_to_col)


# ----------------------------------------------------------------------------- scenes and Monte Carlo


def test_clutter_scene_statistics():
    n, trials = 5, 20_000
    s = scenes.two_radar_clutter_scene(n, spacing=2.0, sigma1=0.1, sigma2=0.1, p_detect1=0.8,
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
    s = scenes.two_radar_clutter_scene(4, spacing=1.0, sigma1=0.1, sigma2=0.1, trials=10, rng=1)
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
    sc = scenes.two_radar_clutter_scene(5, spacing=1.0, sigma1=0.02, sigma2=0.02, trials=500, rng=3)
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


# ============================================================================= property and fuzz suite
# Every public function of the module: valid generated input gives finite results with
# the function's invariants; invalid generated input raises ValueError / TypeError naming
# the public argument. The example budget is the CI profile of tests/conftest.py.

PUBLIC = ("associate_pointwise", "association_probabilities", "non_assignment_cost",
          "proximity_matrix", "all_correct", "compare_decisions", "decision_outcome",
          "calibrate_gate", "outcome_by_gate")


def test_every_public_function_is_covered():
    functions = {n for n in A.__all__ if callable(getattr(A, n)) and n[0].islower()}
    assert functions == set(PUBLIC)


def inverse_of(row_to_col, n2):
    """col_to_row of one row_to_col vector, written out here (-1 for an unused column)."""
    out = np.full(n2, -1)
    for i, j in enumerate(row_to_col):
        if j >= 0:
            out[j] = i
    return out


def assert_matching(row_to_col, col_to_row, n2):
    """row_to_col is a valid (partial) matching and col_to_row its inverse."""
    r2c = np.asarray(row_to_col)
    assert r2c.dtype.kind == "i"
    assert np.all((r2c >= -1) & (r2c < n2))
    used = r2c[r2c >= 0]
    assert len(set(used.tolist())) == used.size                 # no column used twice
    c2r = np.asarray(col_to_row)
    for i, j in enumerate(r2c):
        if j >= 0:
            assert c2r[j] == i
    assert np.count_nonzero(c2r >= 0) == used.size


thresholds = st.one_of(st.none(), st.just(np.inf), st.floats(0.05, 12.0))


@given(cost_matrices(max_n=5), thresholds, st.sampled_from(["scan", "best_first"]))
def test_property_pointwise_is_a_gated_matching(cost, threshold, order):
    r = A.associate_pointwise(cost, threshold, order=order)
    assert_matching(r.row_to_col, r.col_to_row, cost.shape[1])
    th = np.inf if threshold is None else threshold
    vals = cost[r.pairs[:, 0], r.pairs[:, 1]]
    assert np.all(vals < th) and np.isfinite(r.cost)
    assert r.cost == pytest.approx(vals.sum())
    # maximal: no acceptable pair is left between two free reports
    free = np.ix_(r.unassigned_rows, r.unassigned_cols)
    assert not np.any(cost[free] < th)


@given(cost_matrices(max_n=5), thresholds, st.one_of(st.none(), st.floats(-1.0, 6.0)))
def test_property_joint_is_a_matching_and_the_brute_force_optimum(cost, threshold, miss):
    j = asg.assign_two_lists(cost, threshold=threshold, miss_cost=miss)
    b = asg.assign_two_lists_bruteforce(cost, threshold=threshold, miss_cost=miss)
    for r in (j, b):
        assert_matching(r.row_to_col, r.col_to_row, cost.shape[1])
        assert np.isfinite(r.cost)
    assert j.cost == pytest.approx(b.cost, rel=1e-9, abs=1e-9)


@given(cost_matrices(max_n=4), st.integers(1, 30))
def test_property_k_best_are_distinct_matchings_in_order(cost, k):
    r = asg.k_best_two_lists(cost, k)
    assert np.all(np.isfinite(r.cost)) and np.all(np.diff(r.cost) >= -1e-9)
    for a in r.row_to_col:
        assert_matching(a, inverse_of(a, cost.shape[1]), cost.shape[1])
    assert len({tuple(a) for a in r.row_to_col}) == r.k


@given(cost_matrices(max_n=4))
def test_property_association_probabilities_sum_to_one(cost):
    n1, n2 = cost.shape
    feasible = any(np.isfinite(t) for _, t in enumerate_complete(cost))
    if not feasible:
        with pytest.raises(ValueError, match="`cost`"):
            A.association_probabilities(cost)
        return
    for p in (A.association_probabilities(cost), A.association_probabilities(cost, k=30)):
        assert np.all(np.isfinite(p)) and np.all((p >= 0) & (p <= 1 + 1e-12))
        short = p.sum(axis=1) if n1 <= n2 else p.sum(axis=0)
        np.testing.assert_allclose(short, 1.0, rtol=1e-12)
        assert np.all(p[~np.isfinite(cost)] == 0)        # a forbidden pair has probability 0


@given(st.integers(1, 6), st.integers(1, 6), st.integers(1, 3),
       st.floats(0.01, 10.0), st.floats(0.01, 10.0))
def test_property_proximity_matrix(n1, n2, d, s1, s2):
    rng = np.random.default_rng(n1 * 100 + n2 * 10 + d)
    r1, r2 = rng.normal(size=(n1, d)), rng.normal(size=(n2, d))
    k = A.proximity_matrix(r1, r2, s1, s2)
    ref = ((r1[:, None, :] - r2[None, :, :]) ** 2).sum(-1) / (s1**2 + s2**2)
    np.testing.assert_allclose(k, ref, rtol=1e-12, atol=1e-300)
    assert k.shape == (n1, n2) and np.all(k >= 0)


@pytest.mark.filterwarnings("ignore::radarfusion_ref.engine.errors.RadarFusionWarning")
@given(st.floats(0.05, 1.0), st.floats(0.05, 1.0), st.floats(0.0, 5.0), st.floats(0.0, 5.0),
       st.floats(1e-3, 1e3), st.floats(1e-4, 1e2))
def test_property_non_assignment_cost_is_finite_and_matches_the_formula(p1, p2, f1, f2, rho, s):
    if (p1 == 1.0 and f2 == 0.0) or (p2 == 1.0 and f1 == 0.0):
        return                                                # documented +inf cases
    got = A.non_assignment_cost(p_detect1=p1, p_detect2=p2, false_density1=f1,
                                false_density2=f2, object_density=rho, innovation_cov=s)
    u1, u2 = f1 + rho * p1 * (1 - p2), f2 + rho * p2 * (1 - p1)
    ref = math.log(rho * p1 * p2 / (u1 * u2)) - 0.5 * math.log(2 * math.pi * s)
    assert math.isfinite(got) and got == pytest.approx(ref, rel=1e-10, abs=1e-10)


@given(st.integers(1, 5), st.integers(1, 4), st.floats(0.1, 3.0), st.floats(0.0, 0.5),
       st.floats(0.5, 1.0))
def test_property_clutter_scene_and_decision_helpers(n, trials, spacing, rho_f, pd):
    sc = scenes.two_radar_clutter_scene(n, spacing=spacing, sigma1=0.1, sigma2=0.2, p_detect1=pd,
                                   p_detect2=pd, false_density1=rho_f, false_density2=rho_f,
                                   trials=trials, rng=n + trials)
    t2c = sc.true_row_to_col
    for t in range(trials):
        assert_matching(t2c[t], inverse_of(t2c[t], sc.owner2.shape[1]),
                        sc.owner2.shape[1])
    assert np.all(A.all_correct(t2c, t2c))
    k = sc.mask_cost(A.proximity_matrix(sc.reports1, sc.reports2, 0.1, 0.2))
    if np.all(sc.valid1) and np.all(sc.valid2) and k.shape[-1] == k.shape[-2]:
        r = A.compare_decisions(k, t2c, threshold=None, joint_threshold=None)
        for p in (r.pointwise, r.greedy, r.joint, r.joint_ml):
            assert p.trials == trials and 0 <= p.estimate <= 1
    again = scenes.two_radar_clutter_scene(n, spacing=spacing, sigma1=0.1, sigma2=0.2, p_detect1=pd,
                                      p_detect2=pd, false_density1=rho_f, false_density2=rho_f,
                                      trials=trials, rng=n + trials)
    np.testing.assert_array_equal(again.reports1, sc.reports1)     # same seed, same scene


# ----------------------------------------------------------------------------- threshold None

def test_threshold_none_means_no_gate_everywhere():
    c = np.array([[0.5, 50.0, np.inf], [3.0, 0.2, 7.0]])
    for order in ("scan", "best_first"):
        a = A.associate_pointwise(c, None, order=order)
        b = A.associate_pointwise(c, np.inf, order=order)
        np.testing.assert_array_equal(a.row_to_col, b.row_to_col)
    np.testing.assert_array_equal(A.associate_pointwise(c).row_to_col,
                                  A.associate_pointwise(c, None).row_to_col)
    for f in (asg.assign_two_lists, asg.assign_two_lists_bruteforce):
        np.testing.assert_array_equal(f(c, threshold=None).row_to_col,
                                      f(c, threshold=np.inf).row_to_col)
    # the gate is strict everywhere: kappa == gamma is outside
    for r in (A.associate_pointwise([[1.0]], 1.0), asg.assign_two_lists([[1.0]], threshold=1.0),
              asg.assign_two_lists_bruteforce([[1.0]], threshold=1.0)):
        assert r.n_assigned == 0


# ----------------------------------------------------------------------------- numerical range

@pytest.mark.parametrize("scale", [1e-300, 1e-150, 1e150, 1e290, 1e300])
def test_extreme_costs_give_the_same_decisions_as_moderate_ones(scale):
    rng = np.random.default_rng(21)
    c = rng.uniform(1.0, 8.0, size=(5, 5))
    c[1, 3] = np.inf
    ref_j = asg.assign_two_lists(c)
    got_j = asg.assign_two_lists(c * scale)
    np.testing.assert_array_equal(got_j.row_to_col, ref_j.row_to_col)
    assert got_j.cost == pytest.approx(ref_j.cost * scale, rel=1e-12)
    for kw in ({"threshold": 6.0}, {"miss_cost": 2.5}, {"threshold": 6.0, "miss_cost": 2.0}):
        skw = {k: v * scale for k, v in kw.items()}
        ref = asg.assign_two_lists(c, **kw)
        for f in (asg.assign_two_lists, asg.assign_two_lists_bruteforce):
            got = f(c * scale, **skw)
            np.testing.assert_array_equal(got.row_to_col, ref.row_to_col)
            assert np.isfinite(got.cost)
            assert got.cost == pytest.approx(ref.cost * scale, rel=1e-12)
    np.testing.assert_array_equal(A.associate_pointwise(c * scale, 6.0 * scale).row_to_col,
                                  A.associate_pointwise(c, 6.0).row_to_col)
    kb_ref, kb = asg.k_best_two_lists(c, 10), asg.k_best_two_lists(c * scale, 10)
    np.testing.assert_array_equal(kb.row_to_col, kb_ref.row_to_col)
    np.testing.assert_allclose(kb.cost, kb_ref.cost * scale, rtol=1e-12)


def test_costs_near_the_float_maximum():
    big = np.finfo(float).max / 4                                  # ~4.5e307, finite
    c = np.array([[big, big / 2], [big / 2, big]])
    for f in (asg.assign_two_lists, asg.assign_two_lists_bruteforce):
        r = f(c)                                                   # used to claim infeasibility
        np.testing.assert_array_equal(r.row_to_col, [1, 0])
        assert r.cost == big
    c2 = np.array([[big, 1.0], [np.inf, big]])
    for f in (asg.assign_two_lists, asg.assign_two_lists_bruteforce):
        np.testing.assert_array_equal(f(c2, threshold=np.inf).row_to_col, [0, 1])
        np.testing.assert_array_equal(f(c2, miss_cost=big / 8).row_to_col, [1, -1])
    np.testing.assert_allclose(A.association_probabilities(c), [[0, 1], [1, 0]])
    np.testing.assert_allclose(A.association_probabilities(np.full((3, 3), 1e308)), 1 / 3)
    np.testing.assert_allclose(asg.k_best_two_lists(c, 2).cost, [big, 2 * big])


def test_a_total_beyond_the_float_range_is_refused_not_inf():
    c = np.full((3, 3), np.finfo(float).max / 2)
    for call in (lambda: asg.assign_two_lists(c), lambda: asg.assign_two_lists_bruteforce(c),
                 lambda: A.associate_pointwise(c), lambda: asg.k_best_two_lists(c, 1)):
        with pytest.raises(ValueError, match=r"`cost`.*float range"):
            call()


@pytest.mark.filterwarnings("ignore::radarfusion_ref.engine.errors.RadarFusionWarning")
def test_non_assignment_cost_extremes_against_mpmath():
    mp = pytest.importorskip("mpmath")
    mp.mp.dps = 50
    cases = [(0.9, 0.8, 1e300, 1e-300, 1e300, 1e-300), (0.5, 0.5, 1e-300, 1e-300, 1e-300, 1e300),
             (1e-300, 0.3, 0.0, 1e300, 1e300, 1e300), (0.9, 0.9, 1e308, 1e308, 1e308, 1e308)]
    for p1, p2, f1, f2, rho, s in cases:
        got = A.non_assignment_cost(p_detect1=p1, p_detect2=p2, false_density1=f1,
                                    false_density2=f2, object_density=rho, innovation_cov=s)
        P1, P2, F1, F2, R, S = (mp.mpf(v) for v in (p1, p2, f1, f2, rho, s))
        u1, u2 = F1 + R * P1 * (1 - P2), F2 + R * P2 * (1 - P1)
        ref = mp.log(R * P1 * P2 / (u1 * u2)) - mp.log(2 * mp.pi * S) / 2
        assert math.isfinite(got) and got == pytest.approx(float(ref), rel=1e-12)
    s = np.diag([1e300, 1e-300])                                    # det 1: log det exact
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadarFusionWarning)
        got = A.non_assignment_cost(p_detect1=0.9, p_detect2=0.9, false_density1=0.1,
                                    false_density2=0.1, object_density=1.0, innovation_cov=s)
    ref = math.log(0.81 / (0.1 + 0.09) ** 2) - math.log(2 * math.pi)
    assert got == pytest.approx(ref, rel=1e-12)


# ----------------------------------------------------------------------------- resource limits

def test_enumeration_limits_are_checked_before_allocation():
    with pytest.raises(ValueError, match=r"`cost`.*limit of 4000000.*assign_two_lists"):
        asg.assign_two_lists_bruteforce(np.zeros((11, 11)))
    with pytest.raises(ValueError, match=r"`cost`.*partial matchings.*assign_two_lists"):
        asg.assign_two_lists_bruteforce(np.zeros((8, 8)), threshold=1.0)
    with pytest.raises(ValueError, match=r"`cost`.*over a batch.*assign_two_lists"):
        asg.assign_two_lists_bruteforce(np.broadcast_to(np.zeros((9, 9)), (1000, 9, 9)))
    with pytest.raises(ValueError, match=r"`cost`.*k=\.\.\."):
        A.association_probabilities(np.zeros((11, 11)))
    with pytest.raises(ValueError, match=r"`k`.*limit"):
        asg.k_best_two_lists(np.eye(3), asg.MAX_K_BEST + 1)
    with pytest.raises(ValueError, match=r"`k`.*bytes of Murty"):
        asg.k_best_two_lists(np.zeros((1000, 1000)), 10_000)
    with pytest.raises(ValueError, match=r"`false_density1`.*bytes.*trials"):
        scenes.two_radar_clutter_scene(3, spacing=1.0, sigma1=0.1, sigma2=0.1,
                                  false_density1=1e12, trials=10)
    wide = np.broadcast_to(np.zeros(2), (100_000, 2))             # no memory behind it
    with pytest.raises(ValueError, match=r"`reports1`.*bytes.*split the batch"):
        A.proximity_matrix(wide, wide, 1.0, 1.0)


def test_exact_marginals_at_ten_objects_stay_within_memory():
    import resource
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    p = A.association_probabilities(np.random.default_rng(3).random((10, 10)))
    grown_mib = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before) / 1024
    np.testing.assert_allclose(p.sum(axis=1), 1.0)
    assert grown_mib < 600, f"exact marginals at n = 10 grew the process by {grown_mib:.0f} MiB"


# ----------------------------------------------------------------------------- generated bad input

BAD_NUMBERS = st.sampled_from([np.nan, -np.inf, "1.5", True, None, [1.0, 2.0], -1.0, 0.0])
BAD_COSTS = st.sampled_from([
    [[1.0, np.nan]], [[-np.inf, 1.0]], np.zeros((0, 2)), np.zeros((2, 0)), [1.0, 2.0], 3.0,
    "abc", [[True, False]], None, [["1", "2"]]])


@given(BAD_COSTS, st.sampled_from(["associate_pointwise", "assign_two_lists", "assign_two_lists_bruteforce",
                                   "k_best_two_lists", "association_probabilities"]))
def test_fuzz_bad_costs_name_the_argument(bad, name):
    call = {"k_best_two_lists": lambda c: asg.k_best_two_lists(c, 2), "assign_two_lists": asg.assign_two_lists,
            "assign_two_lists_bruteforce": asg.assign_two_lists_bruteforce}.get(name, getattr(A, name, None))
    with pytest.raises((ValueError, TypeError), match="`cost`"):
        call(bad)


@given(st.sampled_from([0.0, -1.0, np.nan, -np.inf, "1", True, [1.0, 2.0]]),
       st.sampled_from(["pointwise", "joint", "bruteforce", "compare"]))
def test_fuzz_bad_thresholds_name_the_argument(bad, where):
    c = np.eye(2)
    if where == "pointwise":
        call, arg = (lambda: A.associate_pointwise(c, bad)), "threshold"
    elif where == "joint":
        call, arg = (lambda: asg.assign_two_lists(c, threshold=bad)), "threshold"
    elif where == "bruteforce":
        call, arg = (lambda: asg.assign_two_lists_bruteforce(c, threshold=bad)), "threshold"
    else:
        call, arg = (lambda: A.compare_decisions(c[None], [[0, 1]], threshold=1.0,
                                                 joint_threshold=bad)), "joint_threshold"
    with pytest.raises((ValueError, TypeError), match=f"`{arg}`"):
        call()


@given(st.sampled_from([np.nan, -np.inf, "1", True, [1.0, 2.0]]))
def test_fuzz_bad_miss_cost(bad):
    with pytest.raises((ValueError, TypeError), match="`miss_cost`"):
        asg.assign_two_lists(np.eye(2), miss_cost=bad)


@given(st.sampled_from([0, -3, 2.5, "2", True, None]))
def test_fuzz_bad_k(bad):
    with pytest.raises((ValueError, TypeError), match="`k`"):
        asg.k_best_two_lists(np.eye(2), bad)
    if bad is not None:
        with pytest.raises((ValueError, TypeError), match="`k`"):
            A.association_probabilities(np.eye(2), k=bad)


NAC_OK = dict(p_detect1=0.9, p_detect2=0.9, false_density1=0.1, false_density2=0.1,
              object_density=1.0, innovation_cov=0.1)
NAC_BAD = {
    "p_detect1": [0.0, 1.5, -0.1, np.nan, "0.5", True],
    "p_detect2": [0.0, 2.0, np.inf],
    "false_density1": [-1.0, np.nan, np.inf, "x"],
    "false_density2": [-0.5, None],
    "object_density": [0.0, -1.0, np.inf, False],
    "innovation_cov": [0.0, -1.0, [[1.0, 2.0], [2.0, 1.0]], [[1.0, 0.5], [0.0, 1.0]],
                       [[-1.0, 0.0], [0.0, -1.0]], np.nan],
}


@given(st.sampled_from([(k, v) for k, vs in NAC_BAD.items() for v in vs]))
def test_fuzz_non_assignment_cost_bad_input(case):
    name, bad = case
    with pytest.raises((ValueError, TypeError), match=f"`{name}`"):
        A.non_assignment_cost(**dict(NAC_OK, **{name: bad}))


def test_non_assignment_cost_shape_mismatch():
    with pytest.raises(ValueError, match=r"`p_detect1`.*broadcast"):
        A.non_assignment_cost(**dict(NAC_OK, p_detect1=[0.9, 0.8], p_detect2=[0.9, 0.8, 0.7]))


SCENE_OK = dict(spacing=1.0, sigma1=0.1, sigma2=0.1)
SCENE_BAD = [("n_objects", 0), ("n_objects", 2.5), ("spacing", 0.0), ("sigma1", -1.0),
             ("sigma2", np.nan), ("p_detect1", 1.5), ("p_detect2", "1"), ("false_density1", -1.0),
             ("false_density2", np.inf), ("trials", 0), ("dim", 0), ("layout", "grid"),
             ("rng", "seed"), ("p_detect1", [0.5, 0.6])]


@given(st.sampled_from(SCENE_BAD))
def test_fuzz_clutter_scene_bad_input(case):
    name, bad = case
    kw = dict(SCENE_OK)
    n = 3
    if name == "n_objects":
        n = bad
    else:
        kw[name] = bad
    with pytest.raises((ValueError, TypeError), match=f"`{name}`"):
        scenes.two_radar_clutter_scene(n, **kw)


PM_BAD = [("reports1", [[np.nan, 0.0]]), ("reports1", [1.0, 2.0]), ("reports2", "x"),
          ("reports2", [[0.0, 1.0, 2.0]]), ("sigma1", 0.0), ("sigma2", -1.0), ("sigma1", True),
          ("reports1", np.zeros((2, 1, 2)))]


@given(st.sampled_from(PM_BAD))
def test_fuzz_proximity_matrix_bad_input(case):
    name, bad = case
    kw = dict(reports1=np.zeros((3, 1, 2)) if name != "reports2" else [[0.0, 1.0]],
              reports2=[[0.0, 1.0]] if name != "reports1" else np.zeros((4, 1, 2)),
              sigma1=0.1, sigma2=0.1)
    if name == "reports1" and np.shape(bad) == (2, 1, 2):
        kw["reports2"] = np.zeros((3, 1, 2))                          # batch axes 2 vs 3
    kw[name] = bad
    with pytest.raises((ValueError, TypeError), match=f"`{name}`"):
        A.proximity_matrix(**kw)


DEC_BAD = [[[0.5, 1.0]], [[True, False]], [["0", "1"]], None, [[-2, 0]], [], "01",
           [[0, 1, 2]]]


@given(st.sampled_from(DEC_BAD), st.sampled_from(["decided", "truth"]))
def test_fuzz_decision_helpers_bad_input(bad, which):
    good = [[0, 1]]
    args = {"decided": good, "truth": good, which: bad}
    with pytest.raises((ValueError, TypeError), match=f"`{which}`|`decided` and `truth`"):
        A.all_correct(args["decided"], args["truth"])
    if which == "truth":
        with pytest.raises((ValueError, TypeError), match="`truth`"):
            A.compare_decisions(np.eye(2)[None], bad, threshold=1.0, joint_threshold=2.0)


def test_compare_decisions_bad_shapes_and_indices():
    k = np.ones((3, 2, 2))
    with pytest.raises(ValueError, match="`kappa`"):
        A.compare_decisions(np.ones((2, 2)), [0, 1], threshold=1.0, joint_threshold=1.0)
    with pytest.raises(ValueError, match=r"`truth`.*shape"):
        A.compare_decisions(k, [[0, 1]], threshold=1.0, joint_threshold=1.0)
    with pytest.raises(ValueError, match=r"`truth`.*< n2"):
        A.compare_decisions(k, [[0, 5]] * 3, threshold=1.0, joint_threshold=1.0)
    with pytest.raises(ValueError, match="`decided` and `truth`"):
        A.all_correct([[0, 1]], [[0, 1], [1, 0]])
    np.testing.assert_array_equal(A.all_correct(np.array([[0.0, 1.0]]), [[0, 1]]), [True])


# ----------------------------------------------------------------------------- the full ML cost
# Oracle: -2 * scipy.stats.multivariate_normal.logpdf of each pair's difference, with the
# covariance S_ij = (sigma_1i^2 + sigma_2j^2) I built here; enumeration by itertools.


def full_cost_oracle(r1, r2, s1, s2):
    """-2 ln N(x1_i - x2_j; 0, S_ij) pair by pair, by scipy.stats."""
    n1, n2, d = len(r1), len(r2), r1.shape[-1]
    out = np.empty((n1, n2))
    for i in range(n1):
        for j in range(n2):
            cov = (s1[i] ** 2 + s2[j] ** 2) * np.eye(d)
            out[i, j] = -2 * stats.multivariate_normal(np.zeros(d), cov).logpdf(r1[i] - r2[j])
    return out


@given(st.integers(1, 4), st.integers(1, 4), st.integers(1, 3), st.integers(0, 2**31 - 1))
def test_proximity_matrix_logdet_equals_minus_two_log_gaussian(n1, n2, d, seed):
    g = np.random.default_rng(seed)
    r1, r2 = g.normal(size=(n1, d)), g.normal(size=(n2, d))
    s1, s2 = g.uniform(0.1, 3.0, n1), g.uniform(0.1, 3.0, n2)
    got = A.proximity_matrix(r1, r2, s1, s2, logdet=True)
    np.testing.assert_allclose(got, full_cost_oracle(r1, r2, s1, s2), rtol=1e-9, atol=1e-9)
    kappa = A.proximity_matrix(r1, r2, s1, s2)
    diff = r1[:, None, :] - r2[None, :, :]
    S = s1[:, None] ** 2 + s2[None, :] ** 2
    np.testing.assert_allclose(kappa, np.sum(diff**2, -1) / S, rtol=1e-12)


def test_proximity_matrix_per_report_sigmas_broadcast_over_a_batch():
    g = np.random.default_rng(4)
    r1, r2 = g.normal(size=(5, 3, 2)), g.normal(size=(5, 4, 2))
    s1, s2 = g.uniform(0.2, 1.0, (5, 3)), g.uniform(0.2, 1.0, 4)
    got = A.proximity_matrix(r1, r2, s1, s2, logdet=True)
    assert got.shape == (5, 3, 4)
    for t in range(5):
        np.testing.assert_allclose(got[t], full_cost_oracle(r1[t], r2[t], s1[t], s2),
                                   rtol=1e-9)
    # a scalar sigma and a constant per-report array give the same matrix
    np.testing.assert_allclose(A.proximity_matrix(r1, r2, 0.5, 0.7, logdet=True),
                               A.proximity_matrix(r1, r2, np.full(3, 0.5), np.full(4, 0.7),
                                                  logdet=True), rtol=1e-12)


def test_proximity_matrix_default_unchanged_and_scalar_logdet_is_a_constant():
    g = np.random.default_rng(5)
    r1, r2 = g.normal(size=(6, 2)), g.normal(size=(6, 2))
    k = A.proximity_matrix(r1, r2, 0.3, 0.4)
    full = A.proximity_matrix(r1, r2, 0.3, 0.4, logdet=True)
    np.testing.assert_allclose(full - k, 2 * math.log(2 * math.pi * 0.25), rtol=1e-12)
    best = min(itertools.permutations(range(6)), key=lambda p: sum(full[i, p[i]]
                                                                    for i in range(6)))
    np.testing.assert_array_equal(asg.assign_two_lists(k).row_to_col, best)


def test_logdet_changes_no_complete_pairing_when_variances_are_per_radar():
    """ln det(2 pi S_ij) is a row term plus a column term only if one side is constant."""
    g = np.random.default_rng(6)
    for _ in range(50):
        r1, r2 = g.normal(size=(5, 1)), g.normal(size=(5, 1))
        s1, s2 = g.uniform(0.1, 2.0, 5), np.full(5, 0.8)
        full = full_cost_oracle(r1, r2, s1, s2)
        kappa = A.proximity_matrix(r1, r2, s1, s2)
        perms = list(itertools.permutations(range(5)))
        ld = [sum(full[i, p[i]] - kappa[i, p[i]] for i in range(5)) for p in perms]
        assert max(ld) - min(ld) < 1e-9


def test_logdet_changes_the_joint_decision_with_per_report_variances():
    """A hand-built case: the kappa-optimal and the likelihood-optimal pairings differ."""
    r1 = np.array([[0.0], [0.05]])
    r2 = np.array([[0.1], [0.05]])
    s1, s2 = np.array([0.05, 1.0]), np.array([0.05, 1.0])
    kappa = A.proximity_matrix(r1, r2, s1, s2)
    full = A.proximity_matrix(r1, r2, s1, s2, logdet=True)
    oracle = full_cost_oracle(r1, r2, s1, s2)
    by_kappa = min(itertools.permutations(range(2)), key=lambda p: kappa[0, p[0]] + kappa[1, p[1]])
    by_ml = min(itertools.permutations(range(2)), key=lambda p: oracle[0, p[0]] + oracle[1, p[1]])
    assert by_kappa != by_ml
    np.testing.assert_array_equal(asg.assign_two_lists(kappa).row_to_col, by_kappa)
    np.testing.assert_array_equal(asg.assign_two_lists(full).row_to_col, by_ml)


@given(st.floats(0.05, 1.0), st.floats(0.05, 1.0), st.floats(0.0, 2.0), st.floats(0.0, 2.0),
       st.floats(0.1, 5.0), st.floats(1e-3, 10.0))
def test_non_assignment_cost_logdet_closed_form(p1, p2, l1, l2, rho, var):
    """c_0 with logdet=True is ln(rho_T P1 P2 / (u1 u2)), written out here."""
    u1 = l1 + rho * p1 * (1 - p2)
    u2 = l2 + rho * p2 * (1 - p1)
    kw = dict(p_detect1=p1, p_detect2=p2, false_density1=l1, false_density2=l2,
              object_density=rho)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadarFusionWarning)
        full = A.non_assignment_cost(**kw, logdet=True)
        part = A.non_assignment_cost(**kw, innovation_cov=var)
    if u1 * u2 == 0:
        assert full == np.inf and part == np.inf
        return
    expected = math.log(rho * p1 * p2 / (u1 * u2))
    assert full == pytest.approx(expected, rel=1e-9, abs=1e-9)
    assert full - part == pytest.approx(0.5 * math.log(2 * math.pi * var), rel=1e-9, abs=1e-9)


def test_full_costs_and_kappa_costs_decide_alike_with_one_covariance():
    """With one S for every pair, (kappa, c_0) and (kappa + ln det 2 pi S, c_0 full) agree."""
    sc = scenes.two_radar_clutter_scene(5, spacing=1.0, sigma1=0.3, sigma2=0.4, p_detect1=0.8,
                                   p_detect2=0.8, false_density1=0.3, false_density2=0.3,
                                   trials=200, dim=2, layout="uniform", rng=7)
    kw = dict(p_detect1=0.8, p_detect2=0.8, false_density1=0.3, false_density2=0.3,
              object_density=sc.object_density)
    c0 = A.non_assignment_cost(**kw, innovation_cov=0.25 * np.eye(2))
    c0_full = A.non_assignment_cost(**kw, logdet=True)
    k = sc.mask_cost(A.proximity_matrix(sc.reports1, sc.reports2, 0.3, 0.4))
    f = sc.mask_cost(A.proximity_matrix(sc.reports1, sc.reports2, 0.3, 0.4, logdet=True))
    a = asg.assign_two_lists(k, miss_cost=c0)
    b = asg.assign_two_lists(f, miss_cost=c0_full)
    np.testing.assert_array_equal(a.row_to_col, b.row_to_col)


@pytest.mark.parametrize(("kw", "name", "exc"), [
    (dict(logdet=1), "logdet", TypeError),
    (dict(logdet="yes"), "logdet", TypeError),
    (dict(sigma1=np.ones(3)), "sigma1", ValueError),          # 2 reports, 3 sigmas
    (dict(sigma2=np.ones((2, 2))), "sigma2", ValueError),     # batch 2 vs reports' batch
    (dict(sigma1=np.array([0.3, -1.0])), "sigma1", ValueError),
    (dict(sigma2=np.array([np.nan])), "sigma2", ValueError),
    (dict(sigma1=np.array([1e-200, 1.0])), "sigma1", ValueError),
])
def test_proximity_matrix_logdet_and_sigma_bad_input(kw, name, exc):
    args = dict(reports1=np.zeros((2, 2)), reports2=np.ones((1, 2)), sigma1=0.3, sigma2=0.4)
    args.update(kw)
    if name == "sigma2" and np.ndim(args["sigma2"]) == 2:
        args["reports2"] = np.ones((3, 1, 2))
    with pytest.raises(exc, match=f"`{name}`"):
        A.proximity_matrix(**args)


def test_non_assignment_cost_logdet_bad_input():
    kw = dict(p_detect1=0.9, p_detect2=0.9, false_density1=0.1, false_density2=0.1,
              object_density=1.0)
    with pytest.raises(TypeError, match="`innovation_cov`"):
        A.non_assignment_cost(**kw)
    with pytest.raises(TypeError, match="`logdet`"):
        A.non_assignment_cost(**kw, innovation_cov=0.1, logdet=0)
    with pytest.raises(ValueError, match="`innovation_cov`"):
        A.non_assignment_cost(**kw, innovation_cov=-0.1, logdet=True)
    # with logdet=True a given covariance only shapes the result
    out = A.non_assignment_cost(**kw, innovation_cov=np.stack([np.eye(2)] * 3), logdet=True)
    assert out.shape == (3,) and np.all(out == out[0])


# ============================================================ gated sparse association
from scipy import sparse  # noqa: E402

from radarfusion_ref import gating  # noqa: E402


def _dense_twin(sp_cost):
    """The same gated problem as a dense matrix: +inf where nothing is stored."""
    coo = sparse.coo_array(sp_cost)
    coo.sum_duplicates()
    out = np.full(coo.shape, np.inf)
    out[coo.row, coo.col] = coo.data
    return out


def _random_gated(rng, n1, n2, density, negative=False):
    mask = rng.random((n1, n2)) < density
    vals = rng.uniform(-3.0 if negative else 0.0, 10.0, size=(n1, n2))
    i, j = np.nonzero(mask)
    return sparse.csr_array((vals[i, j], (i, j)), shape=(n1, n2))


@given(seed=st.integers(0, 2**32 - 1), n1=st.integers(1, 7), n2=st.integers(1, 7),
       density=st.floats(0.0, 1.0), miss=st.one_of(st.none(), st.floats(-1.0, 8.0)),
       th=st.one_of(st.none(), st.floats(0.5, 12.0)), negative=st.booleans())
def test_sparse_joint_equals_dense_and_brute_force(seed, n1, n2, density, miss, th, negative):
    rng = np.random.default_rng(seed)
    sp_cost = _random_gated(rng, n1, n2, density, negative)
    dense = _dense_twin(sp_cost)
    got = asg.assign_two_lists(sp_cost, threshold=th, miss_cost=miss)
    ref = asg.assign_two_lists(dense, threshold=th, miss_cost=miss)
    assert np.array_equal(got.row_to_col, ref.row_to_col)
    assert np.array_equal(got.col_to_row, ref.col_to_row)
    assert got.cost == pytest.approx(ref.cost, rel=1e-12, abs=1e-12)
    brute = asg.assign_two_lists_bruteforce(dense, threshold=th, miss_cost=miss)
    assert got.cost == pytest.approx(brute.cost, rel=1e-12, abs=1e-12)
    assert np.array_equal(got.row_to_col, brute.row_to_col)


@pytest.mark.parametrize("fmt", ["csr", "csc", "coo", "lil", "matrix"])
def test_sparse_joint_formats_rectangular_and_explicit_zeros(fmt):
    rng = np.random.default_rng(4)
    base = _random_gated(rng, 30, 45, 0.15)
    base = base + sparse.csr_array(([0.0, 0.0], ([0, 5], [0, 7])), shape=(30, 45))  # explicit 0s
    assert base.nnz >= 2
    conv = {"csr": sparse.csr_array, "csc": sparse.csc_array, "coo": sparse.coo_array,
            "lil": sparse.lil_array, "matrix": sparse.csr_matrix}[fmt]
    cost = conv(base)
    dense = _dense_twin(base)
    for th, miss in ((None, None), (6.0, None), (None, 2.5), (8.0, 3.0)):
        got = asg.assign_two_lists(cost, threshold=th, miss_cost=miss)
        ref = asg.assign_two_lists(dense, threshold=th, miss_cost=miss)
        assert np.array_equal(got.row_to_col, ref.row_to_col), (th, miss)
        assert got.cost == pytest.approx(ref.cost, rel=1e-12)
    # a stored 0 is an allowed pair of cost 0, taken here
    got = asg.assign_two_lists(sparse.csr_array(([0.0], ([1], [2])), shape=(3, 4)))
    assert got.pairs.tolist() == [[1, 2]] and got.cost == 0.0
    # nothing stored: no pair, every report unassigned
    empty = asg.assign_two_lists(sparse.csr_array((3, 4)), miss_cost=1.5)
    assert empty.n_assigned == 0 and empty.cost == pytest.approx(1.5 * 7)
    # duplicates are summed (scipy's meaning of a repeated entry)
    dup = sparse.coo_array(([1.0, 2.0, 5.0], ([0, 0, 1], [0, 0, 1])), shape=(2, 2))
    assert asg.assign_two_lists(dup).cost == pytest.approx(8.0)


def test_sparse_joint_equals_dense_on_a_2000_report_geometric_scene():
    # one object per unit area, sigma = 0.3 per radar, gate at P_lo = 0.01
    rng = np.random.default_rng(2000)
    n = 2000
    sc = scenes.two_radar_scene(n, spacing=1.0, sigma1=0.3, sigma2=0.3, dim=2, layout="uniform",
                                rng=rng)
    x1, x2 = sc.reports1[0], sc.reports2[0]
    s = (0.3**2 + 0.3**2) * np.eye(2)
    gated = gating.gate_sparse(x1, x2, s, p_false_reject=0.01)
    th = gating.gate_threshold(0.01, 2)
    # the dense route: every pair's kappa, +inf outside the gate
    kappa = A.proximity_matrix(x1, x2, 0.3, 0.3)
    dense = np.where(kappa < th, kappa, np.inf)
    assert np.array_equal(np.isfinite(dense), _dense_twin(gated) < np.inf)
    for miss in (None, 0.5 * th, 2.0):
        got = asg.assign_two_lists(gated, threshold=th, miss_cost=miss)
        ref = asg.assign_two_lists(dense, threshold=th, miss_cost=miss)
        assert np.array_equal(got.row_to_col, ref.row_to_col), miss
        assert got.cost == pytest.approx(ref.cost, rel=1e-9)


@pytest.mark.parametrize(("bad", "exc", "msg"), [
    (sparse.csr_array(([np.nan], ([0], [0])), shape=(2, 2)), ValueError, "must not store NaN"),
    (sparse.csr_array(([np.inf], ([0], [1])), shape=(2, 2)), ValueError, "finite costs only"),
    (sparse.csr_array(([-np.inf], ([1], [1])), shape=(2, 2)), ValueError, "finite costs only"),
    (sparse.csr_array((0, 3)), ValueError, "at least one row and one column"),
    (sparse.csr_array(([1 + 1j], ([0], [0])), shape=(2, 2)), TypeError, "real numbers"),
    (sparse.csr_array(([True], ([0], [0])), shape=(2, 2)), TypeError, "real numbers"),
])
def test_sparse_joint_bad_input(bad, exc, msg):
    with pytest.raises(exc, match=f"`cost`.*{msg}|{msg}"):
        asg.assign_two_lists(bad)


def test_sparse_joint_other_arguments_validated():
    cost = sparse.csr_array(([1.0], ([0], [0])), shape=(2, 2))
    with pytest.raises(ValueError, match="`threshold`"):
        asg.assign_two_lists(cost, threshold=0.0)
    with pytest.raises(ValueError, match="`miss_cost`"):
        asg.assign_two_lists(cost, miss_cost=np.nan)
    with pytest.raises(ValueError, match="`miss_cost`"):
        asg.assign_two_lists(cost, miss_cost=[1.0, 2.0])


# ---------------------------------------------------------------- calibration (decision_outcome, calibrate_gate)
def _loop_outcome(kappa, truth, rule, gate):
    """Per-trial classes written out with loops: brute-force joint pairing, explicit scans."""
    T, n1, n2 = kappa.shape
    correct = np.zeros(T, bool)
    fa = np.zeros(T, bool)
    for t in range(T):
        k = kappa[t]
        if rule == "joint":
            best = min(itertools.permutations(range(n2), n1),
                       key=lambda p: sum(k[i, p[i]] for i in range(n1)))
            total = sum(k[i, best[i]] for i in range(n1))
            right = all(best[i] == truth[t, i] for i in range(n1))
            correct[t], fa[t] = right and total < gate, (not right) and total < gate
            continue
        dec = [-1] * n1
        used = set()
        if rule == "scan":
            for i in range(n1):
                for j in range(n2):
                    if j not in used and k[i, j] < gate:
                        dec[i] = j
                        used.add(j)
                        break
        else:
            pairs = sorted((k[i, j], i, j) for i in range(n1) for j in range(n2) if k[i, j] < gate)
            for _, i, j in pairs:
                if dec[i] < 0 and j not in used:
                    dec[i] = j
                    used.add(j)
        correct[t] = all(dec[i] == truth[t, i] for i in range(n1))
        fa[t] = any(dec[i] >= 0 and dec[i] != truth[t, i] for i in range(n1))
    return correct, fa


def _kappa_scene(trials, n, sig, seed):
    sc = scenes.two_radar_clutter_scene(n, spacing=1.0, sigma1=sig, sigma2=sig, trials=trials,
                                   rng=np.random.default_rng(seed))
    return A.proximity_matrix(sc.reports1, sc.reports2, sig, sig), sc.true_row_to_col


@pytest.mark.parametrize("rule", ["scan", "greedy", "joint"])
def test_decision_outcome_equals_a_loop_over_trials(rule):
    k, truth = _kappa_scene(300, 3, 0.4, 7)
    for gate in (0.5, 3.0, 12.0):
        o = A.decision_outcome(k, truth, rule, gate)
        c_ref, fa_ref = _loop_outcome(k, truth, rule, gate)
        assert np.array_equal(o.correct, c_ref) and np.array_equal(o.false_accept, fa_ref)
        assert np.array_equal(o.rejected, ~c_ref & ~fa_ref)
        assert o.correct.any() or o.false_accept.any() or o.rejected.any()


def test_calibrated_false_reject_gate_is_the_chi2_quantile_for_one_pair():
    """One object, known covariance: the true pair's kappa is chi2_d, so the narrowest gate
    with a false-reject rate <= alpha converges to the chi2_d quantile (eq-gate). With T trials
    the empirical CDF is within eps of the true one except with probability 2 exp(-2 T eps^2)
    (Dvoretzky-Kiefer-Wolfowitz), which brackets the quantile."""
    T, alpha, d = 20000, 0.05, 2
    g = np.random.default_rng(12)
    kappa = np.sum(g.standard_normal((T, d)) ** 2, axis=-1)[:, None, None]
    truth = np.zeros((T, 1), dtype=int)
    eps = math.sqrt(math.log(2 / 1e-9) / (2 * T))          # fails with probability 1e-9
    for rule in ("greedy", "joint"):
        gate = A.calibrate_gate(kappa, truth, rule, alpha, error="false_reject")
        assert stats.chi2.ppf(1 - alpha - eps, d) <= gate <= stats.chi2.ppf(1 - alpha + eps, d)
        # brute force: the empirical quantile, the smallest kappa with at most alpha*T above it
        srt = np.sort(kappa.ravel())
        k_ = math.ceil(T * (1 - alpha))                     # need #{kappa < gate} >= k_
        assert srt[k_ - 1] < gate <= np.nextafter(srt[k_ - 1], np.inf)
        assert np.mean(kappa.ravel() >= gate) <= alpha


@pytest.mark.parametrize("rule", ["greedy", "joint"])
def test_calibrated_false_accept_gate_is_the_widest_by_brute_force(rule):
    k, truth = _kappa_scene(200, 3, 0.45, 9)
    alpha = 0.05
    gate = A.calibrate_gate(k, truth, rule, alpha)
    fa = lambda g: _loop_outcome(k, truth, rule, g)[1].mean()   # noqa: E731
    assert fa(gate) <= alpha
    # every breakpoint just above the gate exceeds alpha: the next candidate value
    stat = (np.array([min(sum(k[t, i, p[i]] for i in range(3))
                          for p in itertools.permutations(range(3))) for t in range(200)])
            if rule == "joint" else k[np.isfinite(k)])
    nxt = np.sort(stat[stat >= gate])
    if nxt.size:
        assert fa(np.nextafter(nxt[0], np.inf)) > alpha
    # a grid: the widest grid gate meeting alpha, scored by the loop
    grid = np.geomspace(1e-5, 30, 30)
    ok = [g for g in grid if fa(g) <= alpha]
    assert A.calibrate_gate(k, truth, rule, alpha, gates=grid) == pytest.approx(max(ok))


def test_calibrate_gate_scan_needs_a_grid_and_refuses_unreachable_targets():
    k, truth = _kappa_scene(100, 3, 0.45, 3)
    grid = np.geomspace(1e-5, 30, 30)
    g = A.calibrate_gate(k, truth, "scan", 0.1, gates=grid)
    assert _loop_outcome(k, truth, "scan", g)[1].mean() <= 0.1
    with pytest.raises(ValueError, match="`gates`"):
        A.calibrate_gate(k, truth, "scan", 0.1)
    with pytest.raises(ValueError, match="`target`"):
        A.calibrate_gate(k, truth, "greedy", 0.0, error="false_reject", gates=[1e-3, 1e-2])
    with pytest.raises(ValueError, match="`target`"):
        A.calibrate_gate(k, truth, "greedy", 1.5)
    with pytest.raises(ValueError, match="`gates`"):
        A.calibrate_gate(k, truth, "greedy", 0.1, gates=[2.0, 1.0])
    with pytest.raises(ValueError, match="`error`"):
        A.calibrate_gate(k, truth, "greedy", 0.1, error="both")
    with pytest.raises(ValueError, match="`rule`"):
        A.decision_outcome(k, truth, "best", 1.0)
    with pytest.raises(ValueError, match="`gate`"):
        A.decision_outcome(k, truth, "greedy", 0.0)
    with pytest.raises(ValueError, match="`truth`"):
        A.decision_outcome(k, truth[:, :2], "greedy", 1.0)
    with pytest.raises(ValueError, match="`kappa`"):
        A.decision_outcome(np.full_like(k, np.nan), truth, "greedy", 1.0)


# ---------------------------------------------------------------- outcome_by_gate
def test_outcome_by_gate_is_decision_outcome_at_every_gate():
    sc = scenes.two_radar_clutter_scene(4, spacing=1.0, sigma1=0.4, sigma2=0.4, trials=200,
                                        rng=12)
    k = A.proximity_matrix(sc.reports1, sc.reports2, 0.4, 0.4)
    for rule in ("scan", "greedy", "joint"):
        f = A.outcome_by_gate(k, sc.true_row_to_col, rule)
        for gate in (0.5, 3.0, 20.0):
            a, b = f(gate), A.decision_outcome(k, sc.true_row_to_col, rule, gate)
            assert np.array_equal(a.correct, b.correct)
            assert np.array_equal(a.false_accept, b.false_accept)


def test_outcome_by_gate_joint_test_by_hand():
    """Joint rule, written out: right pairing, summed kappa 0.3 passes any gate above it."""
    f = A.outcome_by_gate([[0.1, 4.0], [5.0, 0.2]], [0, 1], "joint")
    assert bool(f(0.31).correct) and not bool(f(0.3).correct) and bool(f(0.3).rejected)
    g = A.outcome_by_gate([[0.1, 4.0], [5.0, 0.2]], [1, 0], "joint")     # the wrong truth
    assert bool(g(0.31).false_accept) and not bool(g(0.3).false_accept)


@pytest.mark.parametrize(("args", "name"), [
    (([[np.nan]], [0], "joint"), "kappa"), (([[1.0]], [2], "joint"), "truth"),
    (([[1.0]], [0], "best"), "rule"),
])
def test_outcome_by_gate_bad_input_names_its_argument(args, name):
    with pytest.raises((ValueError, TypeError), match=f"`{name}`"):
        A.outcome_by_gate(*args)
    with pytest.raises(ValueError, match="`gate`"):
        A.outcome_by_gate([[1.0]], [0], "scan")(-1.0)


# ------------------------------------------------------------------ joint outcome, by definition
def _outcome_by_definition(decided, truth, passed):
    """correct: every pair right and the test passed; false accept: a wrong pair accepted."""
    wrong = any(d >= 0 and d != t for d, t in zip(decided, truth, strict=True))
    return passed and list(decided) == list(truth), passed and wrong


def test_joint_outcome_with_only_forbidden_pairs_left_is_a_rejection():
    """Row 1 has only forbidden pairs: nothing wrong is accepted, so no false accept."""
    k = np.array([[0.1, np.inf], [np.inf, np.inf]])
    o = A.decision_outcome(k, [0, 1], "joint", 10.0)
    assert (bool(o.correct), bool(o.false_accept), bool(o.rejected)) == (False, False, True)


@given(seed=st.integers(0, 10**6), n1=st.integers(1, 4), n2=st.integers(1, 4),
       gate=st.sampled_from([0.5, 2.0, 6.0, np.inf]))
def test_joint_outcome_matches_the_definition_on_the_brute_force_pairing(seed, n1, n2, gate):
    g = np.random.default_rng(seed)
    k = g.exponential(1.0, (n1, n2))
    k[g.random((n1, n2)) < 0.4] = np.inf                           # forbidden pairs
    truth = g.permutation(max(n1, n2))[:n1]
    truth = np.where(truth < n2, truth, -1)
    truth = np.where(np.isfinite(k[np.arange(n1), np.maximum(truth, 0)]) | (truth < 0), truth,
                     g.integers(-1, n2, n1))
    best = asg.assign_two_lists_bruteforce(k)
    total = sum(k[i, j] for i, j in enumerate(best.row_to_col) if j >= 0)
    expect = _outcome_by_definition(best.row_to_col, truth, total < gate)
    o = A.decision_outcome(k, truth, "joint", gate)
    assert (bool(o.correct), bool(o.false_accept)) == expect


@pytest.mark.parametrize("call", [
    lambda k: A.decision_outcome(k, [[0, 1]], "joint", 1.0),
    lambda k: A.calibrate_gate(k, [[0, 1]], "joint", 0.1),
    lambda k: A.outcome_by_gate(k, [[0, 1]], "joint"),
    lambda k: A.decision_outcome(k, [[0, 1]], "greedy", np.inf),
    lambda k: A.calibrate_gate(k, [[0, 1]], "greedy", 0.1),
])
def test_joint_outcome_overflow_names_kappa_not_the_solver_arguments(call):
    """Each pair's kappa is finite but the pairing's sum is not: blame `kappa`."""
    k = np.array([[[1e308, np.inf], [np.inf, 1e308]]])
    with pytest.raises(ValueError, match=r"`kappa`.*1e\+308") as info:
        call(k)
    assert "cost`" not in str(info.value)
