"""GOSPA and track scoring at continental size: the sparse assignment against the dense
optimum, and the NEES of the paired rows against a brute-force computation."""

import tracemalloc

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from radarfusion_ref import tracking as trk
from radarfusion_ref.engine import metrics
from radarfusion_ref.engine.metrics import gospa


def dense_reference(x, y, c, p):
    """GOSPA (alpha = 2) by one assignment on the whole matrix of min(d, c)^p (scipy):
    (total, localisation, missed, false, n_assigned, pairs)."""
    n, k = len(x), len(y)
    if not (n and k):
        miss, false = n * c**p / 2, k * c**p / 2
        return (miss + false) ** (1 / p), 0.0, miss, false, 0, np.zeros((0, 2), int)
    d = cdist(x, y)
    r, col = linear_sum_assignment(np.minimum(d, c) ** p)
    close = d[r, col] < c
    loc = float(np.sum(d[r, col][close] ** p))
    a = int(close.sum())
    miss, false = (n - a) * c**p / 2, (k - a) * c**p / 2
    pairs = np.stack([r[close], col[close]], axis=-1)
    return (loc + miss + false) ** (1 / p), loc, miss, false, a, pairs


def scene(kind, rng):
    """Truth and estimates of one kind of scene, at least 60 x 60 (the sparse route)."""
    n, k = rng.integers(60, 110, size=2)
    if kind == "uniform":
        x = rng.uniform(0, 50, (n, 2))
        y = rng.uniform(0, 50, (k, 2))
    elif kind == "ties":                      # points on an integer grid, some repeated
        x = rng.integers(0, 12, (n, 2)).astype(float)
        y = rng.integers(0, 12, (k, 2)).astype(float)
        y[: min(n, k) // 3] = x[: min(n, k) // 3]
    elif kind == "clusters":                  # a few dense clusters: large components
        centres = rng.uniform(0, 200, (5, 3))
        x = centres[rng.integers(0, 5, n)] + rng.normal(0, 1.5, (n, 3))
        y = centres[rng.integers(0, 5, k)] + rng.normal(0, 1.5, (k, 3))
    else:                                     # tracks near the truth, plus false and missed
        x = rng.uniform(0, 300, (n, 3))
        y = np.vstack([x[: n // 2] + rng.normal(0, 1.0, (n // 2, 3)),
                       rng.uniform(0, 300, (k - n // 2, 3))])
    return x, y


@pytest.mark.parametrize("kind", ["uniform", "ties", "clusters", "tracks"])
@pytest.mark.parametrize("p", [1.0, 2.0, 3.0])
def test_sparse_gospa_equals_dense_optimum(kind, p):
    rng = np.random.default_rng([7, int(p), len(kind)])
    for _ in range(4):
        x, y = scene(kind, rng)
        c = float(rng.uniform(1.0, 4.0))
        assert len(x) * len(y) > metrics._SPARSE_ABOVE          # the sparse route is taken
        g = gospa(x, y, c=c, p=p)
        total, loc, miss, false, a, pairs = dense_reference(x, y, c, p)
        assert a > 0 and (len(x) - a) + (len(y) - a) > 0      # a scene that tests both
        assert g.total == pytest.approx(total, rel=1e-9)
        np.testing.assert_allclose(g.localisation + g.missed + g.false, g.total**p, rtol=1e-9)
        assert g.n_missed == len(x) - g.n_assigned and g.n_false == len(y) - g.n_assigned
        np.testing.assert_allclose([g.missed, g.false], np.array([g.n_missed, g.n_false]) * c**p / 2)
        if kind != "ties":      # ties: other optima may trade a pair for a miss and a false
            np.testing.assert_allclose([g.localisation, g.missed, g.false], [loc, miss, false],
                                       rtol=1e-9, atol=1e-12 * c**p)
            assert g.n_assigned == a
        a = g.n_assigned
        # the pairs: one-to-one, closer than c, their cost the localisation part
        i, j = g.pairs.T
        assert np.unique(i).size == i.size == a and np.unique(j).size == a
        assert np.all(np.diff(i) > 0)
        d = np.linalg.norm(x[i] - y[j], axis=1)
        assert np.all(d < c)
        np.testing.assert_allclose(np.sum(d**p), loc, rtol=1e-9, atol=1e-12 * c**p)
        if kind != "ties":                                    # no ties: the same pairs
            np.testing.assert_array_equal(g.pairs, pairs)


@pytest.mark.parametrize(("n", "k"), [(0, 5000), (5000, 0), (3000, 1), (1, 3000)])
def test_sparse_gospa_empty_and_one_sided(n, k):
    rng = np.random.default_rng(n + 2 * k)
    x, y = rng.uniform(0, 1e3, (n, 3)), rng.uniform(0, 1e3, (k, 3))
    c = 20.0
    g = gospa(x.reshape(n, 3), y.reshape(k, 3), c=c)
    total, loc, miss, false, a, _ = dense_reference(x, y, c, 2.0)
    np.testing.assert_allclose([g.total, g.localisation, g.missed, g.false],
                               [total, loc, miss, false], rtol=1e-9)
    assert g.n_assigned == a


def test_sparse_route_matches_dense_route_on_small_scenes():
    """The component-wise kernel alone, on scenes too small for `gospa` to choose it."""
    rng = np.random.default_rng(11)
    for _ in range(200):
        n, k = rng.integers(1, 12, size=2)
        x = np.round(rng.uniform(0, 8, (n, 2)))               # many ties and duplicates
        y = np.round(rng.uniform(0, 8, (k, 2)))
        c, p = float(rng.uniform(0.5, 4.0)), float(rng.choice([1.0, 2.0, 2.5]))
        loc, a, pairs = metrics._assign_sparse(x, y, c, p)       # loc in units of c**p
        total, *_ = dense_reference(x, y, c, p)
        assert c * (loc + (n + k - 2 * a) / 2) ** (1 / p) == pytest.approx(total, rel=1e-9)
        assert pairs.shape == (a, 2)
        d = np.linalg.norm(x[pairs[:, 0]] - y[pairs[:, 1]], axis=1)
        assert np.all(d < c) and np.sum((d / c) ** p) == pytest.approx(loc, rel=1e-9, abs=1e-12)


def test_large_scene_is_scored_exactly():
    """2 000 aircraft on a 10 km grid, 1 800 tracked within 300 m, 200 false tracks: the
    optimum pairs each track with its own aircraft (closed form)."""
    rng = np.random.default_rng(5)
    g1, g2 = np.meshgrid(np.arange(50), np.arange(40))
    x = np.column_stack([g1.ravel() * 1e4, g2.ravel() * 1e4, rng.uniform(0, 1e4, 2000)])
    off = rng.normal(0, 150.0, (1800, 3))
    false_tracks = x[rng.choice(2000, 200, replace=False)] + [5e3, 5e3, 0.0]
    y = np.vstack([x[:1800] + off, false_tracks])
    y = y[::-1]                                               # not in the truth's order
    c = 2000.0
    g = gospa(x, y, c=c)
    assert g.n_assigned == 1800 and g.n_missed == 200 and g.n_false == 200
    loc = float(np.sum(off**2))
    np.testing.assert_allclose([g.localisation, g.missed, g.false],
                               [loc, 200 * c**2 / 2, 200 * c**2 / 2], rtol=1e-9)
    np.testing.assert_array_equal(g.pairs[:, 0], np.arange(1800))
    np.testing.assert_array_equal(g.pairs[:, 1], 1999 - np.arange(1800))


def history_of(tracks):
    """A TrackHistory from {track: (times, positions (N, 3), velocity (3,), sigma)}."""
    tr, tm, st, cov = [], [], [], []
    for k, (times, pos, vel, sigma) in tracks.items():
        for t, q in zip(times, pos, strict=True):
            tr.append(k)
            tm.append(t)
            st.append([*q, *vel])
            cov.append(np.diag([sigma**2, (2 * sigma) ** 2, (0.5 * sigma) ** 2, 1, 1, 1]))
    order = np.argsort(tm, kind="stable")
    return trk.TrackHistory(np.array(tr)[order], np.array(tm, float)[order],
                            np.array(st)[order], np.array(cov)[order],
                            np.ones(len(tr), bool))


def test_nees_equals_brute_force_of_the_paired_rows():
    rng = np.random.default_rng(3)
    tt = np.arange(0.0, 101.0, 10.0)                          # truth samples every 10 s
    vel = {10: np.array([100.0, 0, 0]), 20: np.array([0, 80.0, 0]),
           30: np.array([-60.0, 60.0, 5.0])}
    start = {10: np.zeros(3), 20: np.array([5e3, 0, 1e3]), 30: np.array([2e4, -5e3, 2e3])}
    truth_t, truth_x, truth_i = [], [], []
    for a in (10, 20, 30):
        span = tt if a != 30 else tt[3:]                      # target 30 appears at 30 s
        truth_t.extend(span)
        truth_x.extend(start[a] + span[:, None] * vel[a] + rng.normal(0, 5.0, (span.size, 3)))
        truth_i.extend([a] * span.size)
    truth_t, truth_x, truth_i = np.array(truth_t), np.array(truth_x), np.array(truth_i)

    def truth_of(a, t):                                       # linear between the samples
        m = truth_i == a
        return np.array([np.interp(t, truth_t[m], truth_x[m, d]) for d in range(3)])

    rows = {}
    for k, a, t0 in ((1, 10, 2.0), (2, 20, 4.0), (3, 30, 33.0)):
        times = np.arange(t0, 100.0, 7.0)
        pos = np.array([truth_of(a, t) for t in times]) + rng.normal(0, 60.0, (times.size, 3))
        rows[k] = (times, pos, vel[a], 60.0)
    h = history_of(rows)
    m = trk.evaluate_tracks(h, truth_t, truth_x, truth_i, c=1000.0,
                            times=np.arange(10.0, 100.0, 5.0))
    main = {1: 10, 2: 20, 3: 30}
    err, cov = [], []
    for r in range(h.time.size):                              # history order
        a, t = main[int(h.track[r])], h.time[r]
        m_a = truth_i == a
        if not truth_t[m_a].min() <= t <= truth_t[m_a].max():
            continue
        err.append(h.state[r, :3] - truth_of(a, t))
        cov.append(h.covariance[r, :3, :3])
    err, cov = np.array(err), np.array(cov)
    brute = np.einsum("ni,ni->n", err, np.linalg.solve(cov, err[..., None])[..., 0])
    assert m.nees is not None and m.nees.count == brute.size > 20
    np.testing.assert_allclose(m.nees.values, brute, rtol=1e-10)


def test_nees_needs_no_truth_at_every_row_instant():
    """5 000 targets and a history of 20 000 row instants: the fleet at every row instant
    would be 3.2 GB; only the paired rows' truth is formed."""
    k = 20_000
    h = trk.TrackHistory(np.zeros(k, np.int64), np.arange(k, dtype=float), np.zeros((k, 6)),
                         np.broadcast_to(np.eye(6), (k, 6, 6)), np.ones(k, bool))
    ids = np.arange(5000)
    tracemalloc.start()
    try:
        m = trk.evaluate_tracks(h, np.zeros(ids.size), np.zeros((ids.size, 3)), ids, c=1.0,
                                times=[0.0, 1.0])
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50e6
    # at 0 s the one track sits on the 5 000 targets: one pair; at 1 s no target is left
    assert m.nees is not None and m.nees.count == 1 and m.nees.values[0] == 0.0
    assert np.sum(m.track_of >= 0) == 1
    np.testing.assert_allclose(m.gospa ** 2, [4999 / 2, 1 / 2])


def test_truth_at_pairs_in_blocks_is_the_fleet_truth(monkeypatch):
    from radarfusion_ref.capstone import load_traffic, truth_at
    from radarfusion_ref.tracking import _evaluation

    traffic = load_traffic()
    rng = np.random.default_rng(9)
    times = rng.choice(np.arange(0.0, 600.0, 0.5), 300)
    target = rng.integers(0, len(traffic.icao24), times.size)
    monkeypatch.setattr(_evaluation, "_TRUTH_BLOCK", 8 * 8 * len(traffic.icao24) * 7)
    pos, ok = _evaluation._truth_at_pairs(traffic, target, times)
    full, valid = truth_at(traffic, np.unique(times))
    j = np.searchsorted(np.unique(times), times)
    assert ok.any() and not ok.all()
    np.testing.assert_array_equal(ok, valid[target, j])
    np.testing.assert_array_equal(pos, full[target, j])
