"""Tests of radarfusion_ref.engine.assignment (the 2-D and S-D assignment solvers).

Reference values come from independent routes:

* 2-D: the dense solver, the sparse solver and enumeration of every (partial)
  matching must agree on the same gated problem; the plain complete problem is
  also checked against ``scipy.optimize.linear_sum_assignment`` directly;
* S-D: enumeration of all :math:`(n!)^{m-1}` groupings (``itertools`` here, not
  the package's enumeration) and an exact-cover search over explicit
  candidate groups written out in this file; the Lagrangian's bound must lie
  below that optimum and its gap must be the proved one;
* the result vocabulary: every result type satisfies the ``AssignmentResult``
  protocol with the same meanings.
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import sparse
from scipy.optimize import linear_sum_assignment, linprog

from radarfusion_ref import grouping
from radarfusion_ref.engine import assignment as asg


# ---------------------------------------------------------------- independent references
def brute_2d(c, miss=None):
    """Best partial matching (fewest forbidden pairs) by enumeration; +inf = forbidden."""
    n1, n2 = c.shape
    best_v = (np.inf, np.inf)
    for k in range(min(n1, n2) + 1):
        for rows in itertools.combinations(range(n1), k):
            for cols in itertools.permutations(range(n2), k):
                vals = [c[r, q] for r, q in zip(rows, cols, strict=True)]
                if not np.all(np.isfinite(vals)):
                    continue
                total = float(sum(vals))
                key = (-k, total) if miss is None else (0, total + miss * (n1 + n2 - 2 * k))
                best_v = min(best_v, key)
    return best_v[1]


def brute_sd_tensor(c):
    """Optimal total of a full S-D tensor by enumerating (n!)^(m-1) groupings."""
    m, n = c.ndim, c.shape[0]
    best = np.inf
    for perms in itertools.product(itertools.permutations(range(n)), repeat=m - 1):
        total = sum(c[(j, *(p[j] for p in perms))] for j in range(n))
        best = min(best, total)
    return best


def exact_cover(T, c, counts):
    """Optimal total of explicit candidate groups by a depth-first exact-cover search."""
    m = T.shape[1]
    nodes = [(i, j) for i in range(m) for j in range(counts[i])]
    holds = {nd: [k for k in range(T.shape[0]) if T[k, nd[0]] == nd[1]] for nd in nodes}
    best = [np.inf]

    def go(covered, total):                      # no pruning: costs may be negative
        free = [nd for nd in nodes if nd not in covered]
        if not free:
            best[0] = min(best[0], total)
            return
        nd = free[0]
        for k in holds[nd]:
            mine = {(i, int(T[k, i])) for i in range(m) if T[k, i] >= 0}
            if mine & covered:
                continue
            go(covered | mine, total + c[k])

    go(frozenset(), 0.0)
    return best[0]


def gated(rng, n1, n2, p_keep):
    c = rng.uniform(0.0, 10.0, size=(n1, n2))
    keep = rng.random((n1, n2)) < p_keep
    return np.where(keep, c, np.inf)


def to_sparse(c):
    r, q = np.nonzero(np.isfinite(c))
    return sparse.csr_array((c[r, q], (r, q)), shape=c.shape)


# ---------------------------------------------------------------- 2-D
@settings(max_examples=60, deadline=None)
@given(st.integers(1, 6), st.integers(1, 6), st.floats(0.2, 1.0), st.integers(0, 2**31),
       st.sampled_from([None, 1.5, 4.0]))
def test_dense_equals_sparse_equals_bruteforce_on_gated_problems(n1, n2, p_keep, seed, miss):
    c = gated(np.random.default_rng(seed), n1, n2, p_keep)
    dense = asg.assign_two_lists(c, miss_cost=miss)
    sp = asg.assign_two_lists(to_sparse(c), miss_cost=miss)
    ref = brute_2d(c, miss)
    assert np.array_equal(dense.row_to_col, sp.row_to_col)
    assert dense.cost == pytest.approx(ref, rel=1e-12, abs=1e-12)
    assert sp.cost == pytest.approx(ref, rel=1e-12, abs=1e-12)
    if n1 * n2 <= 25:
        bf = asg.assign_two_lists_bruteforce(c, miss_cost=miss)
        assert bf.cost == pytest.approx(ref, rel=1e-12, abs=1e-12)
        assert np.array_equal(bf.row_to_col, dense.row_to_col)   # continuous costs: no ties


def test_plain_dense_equals_scipy_and_threshold_equals_forbidden():
    rng = np.random.default_rng(3)
    c = rng.uniform(0, 5, size=(7, 9))
    r, q = linear_sum_assignment(c)
    res = asg.assign_two_lists(c)
    assert np.array_equal(res.row_to_col[r], q) and res.cost == pytest.approx(c[r, q].sum())
    gate = 2.0
    a = asg.assign_two_lists(c, threshold=gate)
    b = asg.assign_two_lists(np.where(c < gate, c, np.inf))
    assert np.array_equal(a.row_to_col, b.row_to_col)
    assert np.all(c[np.flatnonzero(a.row_to_col >= 0), a.row_to_col[a.row_to_col >= 0]] < gate)


def test_k_best_ranks_every_assignment_in_order():
    c = np.random.default_rng(5).uniform(0, 3, size=(4, 4))
    kb = asg.k_best_two_lists(c, 24)
    brute = sorted(sum(c[i, p[i]] for i in range(4)) for p in itertools.permutations(range(4)))
    np.testing.assert_allclose(kb.cost, brute, rtol=1e-12)
    assert kb.k == 24 and len({tuple(a) for a in kb.row_to_col.tolist()}) == 24


# ---------------------------------------------------------------- S-D
@settings(max_examples=25, deadline=None)
@given(st.integers(2, 4), st.integers(0, 2**31))
def test_sd_milp_lagrangian_and_bruteforce_agree_on_small_tensors(n, seed):
    rng = np.random.default_rng(seed)
    c = rng.uniform(0.0, 10.0, size=(n, n, n))
    opt = brute_sd_tensor(c)
    milp = asg.assign_s_lists(c)
    bf = asg.assign_s_lists_bruteforce(c)
    assert milp.cost == pytest.approx(opt, rel=1e-9) and bf.cost == pytest.approx(opt, rel=1e-9)
    assert milp.exact and bf.exact and milp.gap == 0.0
    lag = asg.assign_s_lists(c, method="lagrangian", gap=0.05)
    # a proved bound: below the true optimum; the gap is the one proved
    assert lag.lower_bound <= opt + 1e-9 * max(1.0, abs(opt))
    assert lag.cost >= opt - 1e-9 * max(1.0, abs(opt))
    assert lag.gap == pytest.approx(max(0.0, (lag.cost - lag.lower_bound)
                                        / max(abs(lag.cost), 1.0)))
    assert lag.gap <= 0.05
    tight = asg.assign_s_lists(c, method="lagrangian", gap=1e-9)
    assert tight.cost == pytest.approx(opt, rel=1e-9)
    for r in (milp, bf, lag):      # a grouping: one report of each source per group
        assert np.array_equal(np.sort(r.groups, axis=0), np.tile(np.arange(n)[:, None],
                                                                     (1, 3)))
        assert r.cost == pytest.approx(sum(c[tuple(g)] for g in r.groups), rel=1e-12)


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31), st.floats(0.3, 0.9))
def test_sd_gated_candidates_with_missing_reports_match_exact_cover(seed, p_keep):
    rng = np.random.default_rng(seed)
    counts = [3, 2, 3]
    full = [t for t in itertools.product(*[range(-1, k) for k in counts]) if max(t) >= 0]
    lone = [t for t in full if sum(v >= 0 for v in t) == 1]       # every report may stay alone
    rest = [t for t in full if sum(v >= 0 for v in t) > 1 and rng.random() < p_keep]
    T = np.array(lone + rest)
    c = np.where(np.sum(T >= 0, axis=1) == 1, 2.0, rng.uniform(-6.0, 3.0, size=len(T)))
    opt = exact_cover(T, c, counts)
    for method in ("milp", "lagrangian"):
        r = asg.assign_s_lists(c, T, method=method, gap=0.02)
        assert r.lower_bound <= opt + 1e-9 * max(1.0, abs(opt))
        assert opt - 1e-9 * max(1.0, abs(opt)) <= r.cost
        assert r.gap <= 0.02
        assert r.cost == pytest.approx(c[r.chosen].sum())
        used = np.concatenate([np.flatnonzero(np.isin(np.arange(k), r.groups[:, i]))
                               for i, k in enumerate(counts)])
        assert used.size == sum(counts)                        # every report exactly once
    assert asg.assign_s_lists(c, T).cost == pytest.approx(opt, rel=1e-9, abs=1e-9)


def test_sd_full_tensor_with_forbidden_groups_equals_bruteforce():
    rng = np.random.default_rng(8)
    c = rng.uniform(0, 4, size=(3, 3, 3))
    c[rng.random(c.shape) < 0.5] = np.inf
    c[0, 0, 0] = c[1, 1, 1] = c[2, 2, 2] = 5.0               # one grouping always exists
    opt = brute_sd_tensor(c)
    assert asg.assign_s_lists(c).cost == pytest.approx(opt)
    assert asg.assign_s_lists(c, method="lagrangian", gap=1e-6).cost == pytest.approx(opt)
    assert asg.assign_s_lists_bruteforce(c).cost == pytest.approx(opt)


def test_group_sd_and_group_bruteforce_go_through_the_solvers():
    x = np.array([[[0.0], [5.0], [9.0]], [[5.3], [0.1], [9.2]], [[0.2], [4.9], [8.7]]])
    cov = np.ones((3, 3, 1, 1))
    tensor = grouping.group_costs(x, cov)
    g = grouping.group_sd(x, cov)
    s = asg.assign_s_lists(tensor)
    assert np.array_equal(g.groups, s.groups) and g.cost == pytest.approx(s.cost)
    b = grouping.group_bruteforce(x, cov)
    assert np.array_equal(b.groups, asg.assign_s_lists_bruteforce(tensor).groups)


def test_sd_fractional_relaxation_falls_back_to_branch_and_bound():
    # m = 3, n = 2: the four even-parity tuples at z = 1/2 cover every report once.
    # Cost 0 for even parity, 1 for odd: the LP optimum is 0 (fractional), while
    # every grouping pairs a tuple with its complement (opposite parity): cost 1.
    idx = np.indices((2, 2, 2)).reshape(3, -1)
    parity_cost = (idx.sum(axis=0) % 2).astype(float)
    A = np.zeros((6, 8))                         # each report in exactly one tuple, built here
    for t in range(8):
        for i in range(3):
            A[2 * i + idx[i, t], t] = 1.0
    np.testing.assert_array_equal(asg.sd_constraint_matrix(3, 2).toarray(), A)
    lp = linprog(parity_cost, A_eq=A, b_eq=np.ones(6), bounds=(0, 1), method="highs")
    assert lp.fun == pytest.approx(0.0, abs=1e-9)
    r = asg.assign_s_lists(parity_cost.reshape(2, 2, 2))
    assert r.relaxation_integral is False and r.exact
    assert r.cost == pytest.approx(1.0) == brute_sd_tensor(parity_cost.reshape(2, 2, 2))
    np.testing.assert_array_equal(np.sort(r.groups, axis=0), [[0, 0, 0], [1, 1, 1]])


@pytest.mark.parametrize(("m", "n"), [(2, 1), (2, 3), (3, 3), (4, 2)])
def test_sd_constraint_matrix_is_one_row_per_report(m, n):
    A = asg.sd_constraint_matrix(m, n).toarray()
    groups = list(itertools.product(range(n), repeat=m))       # C order, as the columns
    ref = np.array([[float(t[i] == j) for t in groups] for i in range(m) for j in range(n)])
    np.testing.assert_array_equal(A, ref)


@pytest.mark.parametrize(("m", "n", "name"), [(1, 2, "m"), (2, 0, "n"), (2.5, 2, "m"),
                                              (2, "3", "n"), (10**9, 2, "n"), (7, 10, "n")])
def test_sd_constraint_matrix_bad_input_names_its_argument(m, n, name):
    with pytest.raises((ValueError, TypeError), match=f"`{name}`"):
        asg.sd_constraint_matrix(m, n)


def test_sd_huge_costs_keep_the_optimum():
    # costs up to ~1e35 are capped (never changing the optimum) and rescaled before HiGHS
    rng = np.random.default_rng(21)
    for _ in range(20):
        c = np.exp(rng.uniform(0, 80, size=(3, 3, 3)))
        assert asg.assign_s_lists(c).cost == pytest.approx(brute_sd_tensor(c), rel=1e-9)


# ---------------------------------------------------------------- S-D: the dense Lagrangian
def lp_bound(c):
    """The LP relaxation's optimum of a full S-D tensor (HiGHS), constraints written out here.

    Every Lagrangian dual value of the S-D problem with an integral 2-D sub-problem is at
    most this value (Geoffrion 1974), and every grouping costs at least this much.
    """
    m, n = c.ndim, c.shape[0]
    idx = np.indices(c.shape).reshape(m, -1)
    rows = (np.arange(m)[:, None] * n + idx).ravel()
    cols = np.tile(np.arange(c.size), m)
    A = sparse.csc_array((np.ones(rows.size), (rows, cols)), shape=(m * n, c.size))
    lp = linprog(c.ravel(), A_eq=A, b_eq=np.ones(m * n), bounds=(0, 1), method="highs")
    assert lp.status == 0
    return lp.fun


def scene_tensor(n, seed, m=3, noise=0.25):
    """ML group costs of a 2-D scene of n targets seen by m sources with rotated ellipses."""
    from radarfusion_ref.engine import scenes

    rng = np.random.default_rng(seed)
    th = np.arange(m) * np.pi / m
    rot = np.moveaxis(np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]]), -1, 0)
    cov = rot @ np.diag([(2 * noise) ** 2, (noise / 2) ** 2]) @ np.swapaxes(rot, -1, -2)
    s = scenes.grouping_scene(n, m, cov=cov[:, None], layout="uniform", rng=rng)
    return grouping.group_costs(s.reports[0], s.cov)


def assert_grouping(groups, m, n):
    assert groups.shape == (n, m)
    np.testing.assert_array_equal(np.sort(groups, axis=0), np.tile(np.arange(n)[:, None], (1, m)))


def test_dense_lagrangian_is_within_half_a_percent_at_n50():
    # a seeded 50**3 scene tensor whose LP relaxation is fractional (a true duality gap)
    c = scene_tensor(50, seed=5050)
    lp = lp_bound(c)
    r = asg.assign_s_lists(c, method="lagrangian", gap=0.005)
    assert_grouping(r.groups, 3, 50)
    assert r.cost == pytest.approx(sum(c[tuple(g)] for g in r.groups), rel=1e-12)
    scale = max(abs(r.cost), 1.0)
    assert r.gap <= 0.005                                 # proved by our own bound ...
    assert (r.cost - lp) / scale <= 0.005                 # ... and by the LP's, independently
    assert r.lower_bound <= lp + 1e-9 * scale             # a dual value cannot pass the LP
    assert r.lower_bound <= r.cost
    assert r.history.shape[1] == 2 and np.all(r.history[:, 0] <= r.history[:, 1])


@pytest.mark.parametrize(("m", "n"), [(3, 4), (3, 5), (4, 3), (4, 4), (5, 3)])
@pytest.mark.parametrize("kind", ["uniform", "inf"])
def test_dense_lagrangian_against_enumeration(m, n, kind):
    rng = np.random.default_rng(100 * m + n)
    c = rng.uniform(-3.0, 10.0, size=(n,) * m)
    if kind == "inf":                                     # a third forbidden: still dense
        c[rng.random(c.shape) < 1 / 3] = np.inf
        c[tuple(np.tile(np.arange(n), (m, 1)))] = 20.0    # one grouping always exists
    opt = brute_sd_tensor(c)
    tol = 1e-9 * max(1.0, abs(opt))
    for gap in (0.3, 0.05):
        r = asg.assign_s_lists(c, method="lagrangian", gap=gap)
        assert_grouping(r.groups, m, n)
        assert r.lower_bound <= opt + tol <= r.cost + 2 * tol
        assert r.gap <= gap
        assert r.cost == pytest.approx(sum(c[tuple(g)] for g in r.groups), rel=1e-12)
    assert asg.assign_s_lists(c, method="lagrangian", gap=1e-9).cost == pytest.approx(opt, rel=1e-9)


def test_dense_relaxed_minimum_is_exact_with_the_shortlist():
    from radarfusion_ref.engine.assignment._dense import _Dense

    rng = np.random.default_rng(3)
    for m, n in [(3, 30), (4, 9)]:
        c = rng.uniform(0, 1, size=(n,) * m)
        c[rng.random(c.shape) < 0.2] = np.inf
        s = _Dense(c)
        assert s.top is not None                        # the shortlist is in use
        for spread in (0.0, 1e-3, 0.05, 3.0):            # from all-listed to the full pass
            s.u = rng.uniform(-spread, spread, size=s.u.shape)
            U = sum(s.u[i][idx] for i, idx in enumerate(np.indices((n,) * (m - 2))))
            ref = np.min(c - U[(...,) + (None,) * 2], axis=tuple(range(m - 2)))
            np.testing.assert_array_equal(s._relaxed_matrix(s._offsets()), ref)


def test_dense_lagrangian_huge_costs_are_scaled_exactly():
    rng = np.random.default_rng(4)
    c = rng.uniform(1.0, 2.0, size=(4, 4, 4))
    opt = brute_sd_tensor(c)
    r = asg.assign_s_lists(c * 2.0**1000, method="lagrangian", gap=1e-9)
    assert r.cost == pytest.approx(opt * 2.0**1000, rel=1e-12)
    assert r.lower_bound <= r.cost and np.all(np.isfinite(r.history))


def test_dense_lagrangian_stall_warns_with_the_proved_gap():
    from radarfusion_ref.engine.assignment._dense import sd_dense_lagrangian_kernel
    from radarfusion_ref.engine.errors import RadarFusionWarning

    c = np.random.default_rng(5).uniform(size=(5, 5, 5))     # a true duality gap
    opt = brute_sd_tensor(c)
    with pytest.warns(RadarFusionWarning, match=r"`gap`.*stalled at a proved gap"):
        groups, total, lb, hist = sd_dense_lagrangian_kernel(c, gap=1e-9, max_iter=20,
                                                             exact_limit=0)
    assert hist.shape[1] == 2 and np.all(hist[:, 0] <= hist[:, 1])
    assert_grouping(groups, 3, 5)
    assert lb <= opt + 1e-12 <= total + 2e-12
    assert (total - lb) / max(abs(total), 1.0) > 1e-9


def test_dense_lagrangian_no_grouping_names_the_argument():
    c = np.full((3, 3, 3), 1.0)
    c[:, 0, :] = np.inf                                   # source 1's report 0 never grouped
    with pytest.raises(ValueError, match=r"`cost`.*no grouping"):
        asg.assign_s_lists(c, method="lagrangian")


def test_full_tensor_limits_are_bytes_for_the_lagrangian():
    from radarfusion_ref.engine.assignment._dense import dense_bytes
    from radarfusion_ref.engine.validation import MEMORY_LIMIT

    assert dense_bytes(3, 200) < MEMORY_LIMIT < dense_bytes(3, 500)
    big = np.broadcast_to(0.0, (500, 500, 500))           # a view: nothing allocated
    with pytest.raises(ValueError, match="refused") as info:
        asg.assign_s_lists(big, method="lagrangian")
    text = str(info.value)
    for w in ("`cost`", "bytes", str(dense_bytes(3, 500)), f"limit of {MEMORY_LIMIT}",
              "`candidates`"):
        assert w in text
    with pytest.raises(ValueError, match="refused") as info:
        asg.assign_s_lists(np.broadcast_to(0.0, (101, 101, 101)))          # the integer program
    for w in ("`cost`", "binary variables", "limit of 1000000", "method='lagrangian'"):
        assert w in str(info.value)


# ---------------------------------------------------------------- one vocabulary
def test_every_result_speaks_the_same_vocabulary():
    c = np.array([[1.0, 2.0], [2.0, 5.0]])
    x = np.array([[[0.0], [5.0]], [[5.3], [0.1]], [[0.2], [4.9]]])
    results = [asg.assign_two_lists(c), asg.k_best_two_lists(c, 2), asg.assign_s_lists(np.ones((2, 2, 2))),
               grouping.group_sd(x, np.ones((3, 2, 1, 1))),
               grouping.group_sd(x, np.ones((3, 2, 1, 1)), method="lagrangian",
                                 p_false_reject=1e-3)]
    for r in results:
        assert isinstance(r, asg.AssignmentResult), type(r)
        assert np.all(np.asarray(r.lower_bound) <= np.asarray(r.cost) + 1e-12)
        assert r.exact == bool(np.all(np.asarray(r.gap) == 0.0))
    a, kb, sd, gm, gl = results
    for r in results:             # one kind of attribute: plain dataclass fields
        names = {f.name for f in dataclasses.fields(r)}
        assert {"cost", "lower_bound", "gap", "history", "exact"} <= names, type(r)
        assert not {"assignment", "total_cost", "assignments", "costs"} & set(dir(r)), type(r)
    assert a.row_to_col.tolist() == [1, 0] and a.cost == 4.0 and a.history is None
    assert kb.row_to_col.tolist() == [[1, 0], [0, 1]] and kb.cost.tolist() == [4.0, 6.0]
    assert sd.cost == 2.0 and sd.method == "milp"
    assert gm.exact and gm.groups.shape == (2, 3)
    assert gl.history is not None and gl.history.shape[1] == 2


# ---------------------------------------------------------------- bad input
@pytest.mark.parametrize("g", [0.0, 1.0, -0.1, 1.5, np.nan, [0.1, 0.2]])
def test_gap_outside_the_open_unit_interval_is_refused(g):
    with pytest.raises(ValueError, match="`gap`"):
        asg.assign_s_lists(np.ones((2, 2, 2)), method="lagrangian", gap=g)
    x = np.array([[[0.0], [5.0]], [[5.3], [0.1]], [[0.2], [4.9]]])
    with pytest.raises(ValueError, match="`gap`"):
        grouping.group_sd(x, np.ones((3, 2, 1, 1)), method="lagrangian", gap=g)


def test_sparse_costs_with_nan_or_infinite_stored_entries_are_refused():
    for bad, what in ((np.nan, "NaN"), (np.inf, "finite"), (-np.inf, "finite")):
        m = sparse.csr_array(([1.0, bad], ([0, 1], [0, 1])), shape=(2, 2))
        with pytest.raises(ValueError, match=rf"`cost`.*{what}"):
            asg.assign_two_lists(m)
    with pytest.raises(TypeError, match="`cost`"):
        asg.assign_two_lists(sparse.csr_array(np.array([[1 + 1j]])))


@pytest.mark.parametrize(("call", "exc", "name"), [
    (lambda: asg.assign_two_lists([[np.nan, 1.0]]), ValueError, "cost"),
    (lambda: asg.assign_two_lists([[-np.inf, 1.0]]), ValueError, "cost"),
    (lambda: asg.assign_two_lists([[1.0]], threshold=0.0), ValueError, "threshold"),
    (lambda: asg.assign_two_lists([[1.0]], miss_cost=np.nan), ValueError, "miss_cost"),
    (lambda: asg.k_best_two_lists([[1.0]], 0), ValueError, "k"),
    (lambda: asg.k_best_two_lists([[1.0]], 1.5), TypeError, "k"),
    (lambda: asg.assign_two_lists_bruteforce(np.ones((11, 11))), ValueError, "cost"),
    (lambda: asg.assign_s_lists(np.ones((2, 3, 2))), ValueError, "cost"),
    (lambda: asg.assign_s_lists(np.full((2, 2, 2), np.nan)), ValueError, "cost"),
    (lambda: asg.assign_s_lists(np.ones((2, 2, 2)), method="greedy"), ValueError, "method"),
    (lambda: asg.assign_s_lists(np.ones((2, 2, 2)), max_iter=0), ValueError, "max_iter"),
    (lambda: asg.assign_s_lists(np.ones((2, 2, 2)), relaxation="yes"), TypeError, "relaxation"),
    (lambda: asg.assign_s_lists(np.ones((2, 2, 2)), time_limit=[1.0, 2.0]), ValueError, "time_limit"),
    (lambda: asg.assign_s_lists(np.ones((2, 2, 2)), counts=[2, 2, 2]), ValueError, "counts"),
    (lambda: asg.assign_s_lists([1.0], [[0, -2]]), ValueError, "candidates"),
    (lambda: asg.assign_s_lists([1.0], [[-1, -1]]), ValueError, "candidates"),
    (lambda: asg.assign_s_lists([1.0], [[0.5, 1]]), TypeError, "candidates"),
    (lambda: asg.assign_s_lists([1.0, 2.0], [[0, 0]]), ValueError, "cost"),
    (lambda: asg.assign_s_lists([np.inf], [[0, 0]]), ValueError, "cost"),
    (lambda: asg.assign_s_lists([1.0], [[0, 0]], counts=[0, 1]), ValueError, "counts"),
    (lambda: asg.assign_s_lists(np.ones((12,) * 6)), ValueError, "cost"),
    (lambda: asg.assign_s_lists_bruteforce(np.ones((6,) * 5)), ValueError, "cost"),
    (lambda: asg.assign_s_lists_bruteforce(np.full((2, 2), np.inf)), ValueError, "cost"),
])
def test_bad_input_names_the_argument(call, exc, name):
    with pytest.raises(exc, match=f"`{name}`"):
        call()


def test_infeasible_gated_sd_names_the_source():
    # source 2's report 1 is in no candidate group
    T = np.array([[0, 0, 0], [1, 1, 0], [0, 1, 0]])
    with pytest.raises(ValueError, match=r"`candidates`.*report\(s\) \[1\] of source 2"):
        asg.assign_s_lists([1.0, 1.0, 1.0], T, counts=[2, 2, 2])
    # every report is covered, but no exact cover exists: a cluster lacks a report of source 1
    T = np.array([[0, 0, 0], [1, 0, 1]])
    with pytest.raises(ValueError, match=r"`candidates`.*source \d"):
        asg.assign_s_lists([1.0, 1.0], T, counts=[2, 1, 2])
    c = np.full((2, 2, 2), np.inf)
    c[0, 0, 0] = c[1, 0, 1] = 1.0                       # source 1's report 1 never grouped
    for method in ("milp", "lagrangian"):
        with pytest.raises(ValueError, match=r"`cost`.*source 1"):
            asg.assign_s_lists(c, method=method)


def test_sd_with_two_sources_is_the_linear_assignment():
    c = np.random.default_rng(0).uniform(size=(6, 6))
    r, q = linear_sum_assignment(c)
    for method in ("milp", "lagrangian"):
        s = asg.assign_s_lists(c, method=method)
        assert s.cost == pytest.approx(c[r, q].sum(), rel=1e-12) and s.exact
        assert np.array_equal(s.groups[:, 1], q)
    assert asg.assign_s_lists_bruteforce(c).cost == pytest.approx(c[r, q].sum(), rel=1e-12)
