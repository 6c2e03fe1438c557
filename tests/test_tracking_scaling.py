"""The tracker's work stays local to each scan: far-apart copies of a scene are tracked as
copies, the local gate finds every gated pair, the clusters are the graph's components."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.stats import chi2

from radarfusion_ref import capstone as cp
from radarfusion_ref import tracking as trk
from radarfusion_ref.tracking import _centralised as central

SHIFT = 700e3          # m east between copies: beyond any radar's range
FIELDS = ("time", "state", "covariance", "confirmed")


@pytest.fixture(scope="module")
def swiss():
    """Ten minutes of the scored hour's reports, registered and in the common frame."""
    radars = cp.realistic_radars()
    det = cp.simulate_detections(cp.load_traffic(), radars, duration=600.0,
                                 mode="realistic", rng=2018)
    pos, cov = cp.to_common(det, radars, cp.register_detections(det, radars).biases)
    return det.time, pos, cov, det.radar, det.scan


def _tile(reports, k_tiles):
    t, z, R, rad, sc = reports
    n_rad = int(rad.max()) + 1
    parts = [(t, z + np.array([k * SHIFT, 0.0, 0.0]), R, rad + n_rad * k, sc)
             for k in range(k_tiles)]
    return tuple(np.concatenate(c) for c in zip(*parts, strict=True))


def _rows(h):
    """The history's rows in an order that does not depend on the track numbers."""
    o = np.lexsort((h.state[:, 2], h.state[:, 1], h.state[:, 0], h.time))
    return {f: getattr(h, f)[o] for f in FIELDS}, h.track[o]


@pytest.mark.parametrize("name", ["cv", "imm", "jpda"])
def test_far_copies_are_tracked_as_copies(swiss, name):
    # copies 700 km apart tracked at once give the tracks of one copy tracked alone,
    # shifted, in every copy (track numbers aside), and as many times the tracks started
    settings = {"cv": trk.TrackerSettings(), "imm": trk.IMM_SETTINGS,
                "jpda": trk.TrackerSettings(association="jpda")}[name]
    k_tiles = 2 if name == "jpda" else 3                # (JPDA is the slowest)
    one = trk.track_reports(*swiss, settings=settings)
    assert one.n_confirmed > 10 and len(one) > 1000
    many = trk.track_reports(*_tile(swiss, k_tiles), settings=settings)
    assert many.initiated == k_tiles * one.initiated
    tile_of = np.floor(many.state[:, 0] / SHIFT + 0.5).astype(int)
    assert np.abs(one.state[:, 0]).max() < SHIFT / 2
    ref, ref_ids = _rows(one)
    for k in range(k_tiles):
        sel = tile_of == k
        got = trk.TrackHistory(many.track[sel], many.time[sel], many.state[sel].copy(),
                               many.covariance[sel], many.confirmed[sel])
        got.state[:, 0] -= k * SHIFT
        rows, ids = _rows(got)
        assert rows["time"].size == ref["time"].size, k
        # instants and confirmations exact; states and covariances to the rounding of the
        # shifted coordinates (about 1e-10 m at 1000 km; JPDA's mixtures carry it further)
        np.testing.assert_array_equal(rows["time"], ref["time"])
        np.testing.assert_array_equal(rows["confirmed"], ref["confirmed"])
        np.testing.assert_allclose(rows["state"], ref["state"], rtol=0, atol=1e-5)
        np.testing.assert_allclose(rows["covariance"], ref["covariance"], rtol=1e-6)
        # the same partition of rows into tracks
        _, a = np.unique(ids, return_inverse=True)
        _, b = np.unique(ref_ids, return_inverse=True)
        pairs = np.unique(np.c_[a, b], axis=0)
        assert pairs.shape[0] == np.unique(a).size == np.unique(b).size


def _brute_gate(x, P, z, R, gamma):
    """Every (track, report) pair with d² < gamma, by a solve per pair."""
    nu = z[None, :, :] - x[:, None, :3]
    S = P[:, None, :3, :3] + R[None]
    d2 = np.einsum("tmi,tmi->tm", nu, np.linalg.solve(S, nu[..., None])[..., 0])
    return d2


def test_local_gate_finds_every_gated_pair():
    # tracks with large, random covariances spread over a wide area, and a scan's reports
    # in a corner of it: the local gate returns exactly the brute-force all-pairs gate
    rng = np.random.default_rng(7)
    T, M = 400, 60
    settings = trk.TrackerSettings()
    tracker = central._Tracker(settings)
    lv = tracker.live
    lv.x = np.zeros((T, 6))
    lv.x[:, :3] = rng.uniform(-500e3, 500e3, (T, 3)) * [1, 1, 0.03]
    A = rng.normal(size=(T, 6, 6)) * rng.uniform(200, 4e3, (T, 1, 1))
    lv.P = A @ np.swapaxes(A, 1, 2) + 1e4 * np.eye(6)
    lv.ids = np.arange(T)
    z = rng.uniform(-100e3, 0.0, (M, 3)) * [1, 1, 0.03]
    B = rng.normal(size=(M, 3, 3)) * rng.uniform(20, 300, (M, 1, 1))
    R = B @ np.swapaxes(B, 1, 2) + 100 * np.eye(3)
    gamma = chi2.isf(settings.p_false_reject, 3)
    # ten tracks elongated east-west, each just inside the gate of a report on the box's
    # western edge, outside the box by 98 % of the gate's half-length: the prefilter's
    # search radius is tight for them
    lam, edge = 20e3**2, np.arange(10)
    z[edge] = np.c_[np.full(10, z[:, 0].min() - 5e3), np.linspace(-90e3, -10e3, 10),
                    np.zeros(10)]
    R[edge] = 100.0 * np.eye(3)
    lv.P[edge] = np.diag([lam, 1.0, 1.0, 1e4, 1e4, 1e4])
    lv.x[edge] = 0.0
    lv.x[edge, :3] = z[edge] - [0.98 * np.sqrt(gamma * (lam + 101.0)), 0.0, 0.0]
    ti, rj, d2, ld = tracker._gate(z, R)
    ref = _brute_gate(lv.x, lv.P, z, R, gamma)
    want = np.argwhere(ref < gamma)
    assert 50 < want.shape[0] < T * M / 4                # some pairs in, most out
    assert not np.any(np.abs(ref / gamma - 1) < 1e-9)   # no pair on the edge
    assert np.all(ref[edge, edge] < gamma)
    np.testing.assert_array_equal(np.c_[ti, rj], want)  # track order, then report order
    np.testing.assert_allclose(d2, ref[ti, rj], rtol=1e-9)
    S = lv.P[ti, :3, :3] + R[rj]
    np.testing.assert_allclose(ld, np.linalg.slogdet(S)[1], rtol=1e-12)


def test_near_box_keeps_every_point_within_its_radius():
    rng = np.random.default_rng(11)
    x = rng.normal(size=(3000, 3)) * 10.0
    z = rng.normal(size=(50, 3)) * 3.0
    radius = rng.uniform(0.0, 8.0, 3000)
    near = set(central._near_box(x, radius, z).tolist())
    dist = np.linalg.norm(x[:, None] - z[None], axis=-1).min(1)
    must = set(np.flatnonzero(dist <= radius).tolist())
    assert len(must) > 100 and must <= near and len(near) < 3000


def test_clusters_are_the_graphs_components():
    # random bipartite graphs, chains included: the clusters are scipy's components
    # and their labels increase with the cluster's first track
    rng = np.random.default_rng(3)
    for trial in range(200):
        T, M = rng.integers(1, 40, 2)
        n = int(rng.integers(1, 3 * (T + M)))
        ti, rj = rng.integers(0, T, n), rng.integers(0, M, n)
        if trial % 4 == 0:                              # a long chain of overlapping gates
            k = min(T, M)
            ti = np.r_[np.arange(k), np.arange(1, k)]
            rj = np.r_[np.arange(k), np.arange(k - 1)]
        key = np.unique(np.c_[ti, rj], axis=0)
        ti, rj = key[:, 0], key[:, 1]
        lab = central._clusters(ti, rj, int(M))
        _, ref = connected_components(
            coo_matrix((np.ones(ti.size), (ti, T + rj)), shape=(T + M, T + M)),
            directed=False)
        ref = ref[ti]
        # the same partition, in the same order of clusters
        assert np.array_equal(np.unique(np.c_[lab, ref], axis=0)[:, 0],
                              np.unique(lab)), trial
        assert np.array_equal(np.argsort(lab, kind="stable"), np.argsort(ref, kind="stable"))
        # a label is its cluster's first track
        for c in np.unique(lab):
            assert c == ti[lab == c].min()


def test_pending_rows_sorted_out_in_any_batch(swiss, monkeypatch):
    # the tentative tracks' rows, sorted out after every scan or only at the end, give the
    # same history
    settings = trk.TrackerSettings()
    monkeypatch.setattr(central._Rows, "MIN_BATCH", 0)
    every = trk.track_reports(*swiss, settings=settings)
    monkeypatch.setattr(central._Rows, "MIN_BATCH", 1 << 60)
    at_end = trk.track_reports(*swiss, settings=settings)
    assert every.n_confirmed > 10
    for f in ("track", *FIELDS):
        assert np.array_equal(getattr(every, f), getattr(at_end, f)), f


def test_pair_distances_in_blocks(monkeypatch):
    # every pair's κ by a solve per pair, whatever the blocks
    rng = np.random.default_rng(5)
    x1, x2 = rng.normal(size=(23, 3)) * 1e3, rng.normal(size=(17, 3)) * 1e3
    A, B = rng.normal(size=(23, 3, 3)) * 30, rng.normal(size=(17, 3, 3)) * 30
    P1, P2 = A @ np.swapaxes(A, 1, 2) + np.eye(3), B @ np.swapaxes(B, 1, 2) + np.eye(3)
    d = x1[:, None] - x2[None]
    ref = np.einsum("abi,abi->ab", d, np.linalg.solve(P1[:, None] + P2[None], d[..., None])[..., 0])
    for block in (1, 17, 40, 1 << 16):
        monkeypatch.setattr(central, "_PAIR_BLOCK", block)
        got = central._kappa_pairs(x1, x2, P1, P2)
        assert got.shape == (23, 17)
        np.testing.assert_allclose(got, ref, rtol=1e-10)
    assert central._kappa_pairs(x1[:0], x2, P1[:0], P2).shape == (0, 17)
    monkeypatch.setattr(central, "MEMORY_LIMIT", 1000)
    with pytest.raises(ValueError, match="limit"):
        central._kappa_pairs(x1, x2, P1, P2)


def test_a_window_whose_prediction_leaves_the_numeric_domain_is_refused_by_name():
    """A track predicted across the window would pass 2**150 m² of variance: refused naming
    `time` (the trusted kernels in the loop do not check the domain), a day is accepted."""
    import pytest

    from radarfusion_ref import tracking as trk

    z = np.c_[[0.0, 1000.0, 2000.0], np.zeros(3), np.full(3, 9e3)]
    cov = np.tile(np.eye(3) * 100.0, (3, 1, 1))
    args = (z, cov, np.zeros(3, int), np.arange(3))
    with pytest.raises(ValueError, match=r"`time` spans 1e\+20 s.*numeric domain"):
        trk.track_reports(np.array([0.0, 5.0, 1e20]), *args)
    assert trk.track_reports(np.array([0.0, 5.0, 86400.0]), *args).state.size
