"""The fusion centre split by sectors (radarfusion_ref.continent.sectors)."""

from __future__ import annotations

import dataclasses
import os
import threading
import time

import numpy as np
import pytest

from radarfusion_ref import tracking as trk
from radarfusion_ref.continent import (
    MAX_SECTORS,
    SectorError,
    Sectors,
    sector_grid,
    sector_settings,
    track_sectored,
)
from radarfusion_ref.engine.validation import MEMORY_LIMIT

#: The scene's grid: two sectors side by side, the border at east 0, a 10 km overlap.
GRID = Sectors([-60e3, 0.0, 60e3], [-30e3, 30e3], overlap=10e3)
SIGMA = 50.0                                             # report standard deviation (m)


def flights(duration):
    """Start position and velocity of each aircraft: A and D cross the border (A west to
    east at t = 250 s, D east to west at t = 200 s); B stays in the west and C in the east,
    more than 40 km from the border."""
    start = np.array([[-50e3, 0.0, 9e3], [-50e3, 20e3, 10e3], [50e3, -20e3, 11e3],
                      [40e3, -15e3, 8e3]])
    speed = np.array([[200.0, 0, 0], [0, -80.0, 0], [0, 80.0, 0], [-200.0, 0, 0]])
    return start, speed


def scene(duration=400.0, periods=(4.0, 5.0), seed=7):
    """Two radars (periods in s, second phase 2 s), every aircraft reported every scan
    (no clutter, no miss), Gaussian errors of SIGMA: every scan has reports in both
    sectors. Returns the reports and the truth (time, position, id) at the reports."""
    rng = np.random.default_rng(seed)
    start, speed = flights(duration)
    t, r, s, truth_id = [], [], [], []
    for radar, (period, phase) in enumerate(zip(periods, (0.0, 2.0), strict=True)):
        ticks = np.arange(phase, duration, period)
        n = start.shape[0]
        t.append(np.repeat(ticks, n))
        r.append(np.full(ticks.size * n, radar))
        s.append(np.repeat(np.arange(ticks.size), n))
        truth_id.append(np.tile(np.arange(n), ticks.size))
    t, r, s, ident = (np.concatenate(v) for v in (t, r, s, truth_id))
    truth = start[ident] + speed[ident] * t[:, None]
    z = truth + rng.normal(0.0, SIGMA, truth.shape)
    cov = np.tile(np.eye(3) * SIGMA**2, (t.size, 1, 1))
    return (t, z, cov, r, s), (t, truth, ident)


@pytest.fixture(scope="module")
def reports():
    return scene()


@pytest.fixture(scope="module")
def local(reports):
    return track_sectored(*reports[0], sectors=GRID)


def _rows_near(history, truth, which, radius=1000.0):
    """Confirmed rows of `history` within `radius` of aircraft `which` at the row's time."""
    t, pos, tid = truth
    keep = tid == which
    tt, pp = t[keep], pos[keep]
    o = np.argsort(tt)
    at = np.column_stack([np.interp(history.time, tt[o], pp[o, k]) for k in range(3)])
    near = np.linalg.norm(history.state[:, :3] - at, axis=1) < radius
    return np.flatnonzero(history.confirmed & near)


def test_crossing_aircraft_keeps_one_identity(reports, local):
    truth = reports[1]
    h = local.history
    assert local.tracks.tolist() == [3, 3]               # A, B, D west; A, C, D east
    assert local.handovers.tolist() == [2, 2] and local.links.shape == (2, 4)
    for which in (0, 3):                                 # A and D cross
        rows = _rows_near(h, truth, which)
        east = h.state[rows, 0]
        assert (east < -15e3).sum() > 20 and (east > 15e3).sum() > 20   # both sides
        assert np.unique(h.track[rows]).size == 1
    # the four aircraft, four identities, every confirmed row near one of them
    ids = [np.unique(h.track[_rows_near(h, truth, a)]) for a in range(4)]
    assert all(i.size == 1 for i in ids) and np.unique(np.concatenate(ids)).size == 4
    assert np.unique(h.track[h.confirmed]).size == 4
    # sorted by (time, track)
    assert np.all((np.diff(h.time) > 0) | ((np.diff(h.time) == 0) & (np.diff(h.track) >= 0)))


def test_far_from_borders_the_single_trackers_tracks(reports, local):
    """B and C never come within 40 km of the border: their merged rows are the single
    tracker's (one tracker over the whole area) rows, bit for bit."""
    rep, truth = reports
    single = trk.track_reports(*rep, settings=sector_settings())
    for which in (1, 2):
        mine, ref = _rows_near(local.history, truth, which), _rows_near(single, truth, which)
        assert ref.size > 100 and mine.size == ref.size
        for f in ("time", "state", "covariance"):
            assert np.array_equal(getattr(local.history, f)[mine], getattr(single, f)[ref])


def test_imm_sectors_keep_the_mode_probabilities(reports):
    """With the IMM the merged rows of B and C (far from the borders) carry the single
    tracker's mode probabilities, bit for bit, like their states."""
    rep, truth = reports
    st = sector_settings(dataclasses.replace(sector_settings(), motion="imm"))
    merged = track_sectored(*rep, sectors=GRID, settings=st).history
    single = trk.track_reports(*rep, settings=st)
    for which in (1, 2):
        mine, ref = _rows_near(merged, truth, which), _rows_near(single, truth, which)
        assert ref.size > 100 and mine.size == ref.size
        assert np.array_equal(merged.mode_probability[mine], single.mode_probability[ref])


def test_sector_settings_turn_relinking_off_and_nothing_else():
    """Every field but ``relink`` is the caller's; settings that do not relink come back
    as they are; anything but TrackerSettings is refused by name."""
    s = trk.TrackerSettings(q=7.0, max_coast=60.0, p_relink=1e-10)
    inner = sector_settings(s)
    assert s.relink and not inner.relink
    assert dataclasses.replace(inner, relink=True) == s
    off = trk.TrackerSettings(relink=False)
    assert sector_settings(off) is off
    with pytest.raises(TypeError, match="`settings`"):
        sector_settings({"relink": True})


def test_link_cost_is_the_documented_mean_distance(reports, local):
    """The hand-over's mean squared distance, recomputed from each sector's own tracker
    run on its own reports, by a loop over the common instants."""
    rep, _ = reports
    z = rep[1]
    inner = sector_settings()                 # each sector's tracker: no relinking
    west = trk.track_reports(*(a[z[:, 0] <= 10e3] for a in rep), settings=inner)
    east = trk.track_reports(*(a[z[:, 0] >= -10e3] for a in rep), settings=inner)
    for (sa, a, sb, b), cost in zip(local.links, local.link_cost, strict=True):
        assert (sa, sb) == (0, 1)
        ra = np.flatnonzero((west.track == a) & west.confirmed
                            & (np.abs(west.state[:, 0]) <= 10e3))
        rb = np.flatnonzero((east.track == b) & east.confirmed
                            & (np.abs(east.state[:, 0]) <= 10e3))
        d2 = []
        for i in ra:
            for j in rb[east.time[rb] == west.time[i]]:
                d = west.state[i, :3] - east.state[j, :3]
                S = west.covariance[i, :3, :3] + east.covariance[j, :3, :3]
                d2.append(d @ np.linalg.solve(S, d))
        assert len(d2) >= 5
        assert cost == pytest.approx(np.mean(d2), rel=1e-9, abs=1e-12)


def test_the_answer_depends_on_the_reports_not_their_order(reports, local):
    order = np.random.default_rng(3).permutation(reports[0][0].size)
    r = track_sectored(*(a[order] for a in reports[0]), sectors=GRID)
    for f in ("track", "time", "state", "covariance", "confirmed"):
        assert np.array_equal(getattr(r.history, f), getattr(local.history, f))
    assert np.array_equal(r.links, local.links)


def test_a_sector_without_reports_yields_no_tracks(reports, local):
    """A second row of sectors far north, with no report: no tracks there, and the
    answer of the two southern sectors unchanged."""
    g = Sectors(GRID.east, [-30e3, 30e3, 200e3], overlap=GRID.overlap)
    r = track_sectored(*reports[0], sectors=g)
    assert r.reports[2:].tolist() == [0, 0] and r.tracks[2:].tolist() == [0, 0]
    assert r.handovers.tolist() == [2, 2, 0, 0]
    for f in ("track", "time", "state", "covariance", "confirmed", "initiated"):
        assert np.array_equal(getattr(r.history, f), getattr(local.history, f))


def test_sector_grid_spans_the_reports():
    p = np.array([[-5.0, 2.0, 0.0], [7.0, -4.0, 1.0], [1.0, 8.0, 2.0]])
    g = sector_grid(p, 3, 2, overlap=0.5)
    assert np.allclose(g.east, [-5.0, -1.0, 3.0, 7.0]) and np.allclose(g.north, [-4, 2, 8])
    assert g.n_sectors == 6 and g.shape == (2, 3)
    assert g.owner(p).tolist() == [3, 2, 4]      # an inner edge opens the next, the last closed
    assert g.bounds(5) == (3.0, 7.0, 2.0, 8.0)


@pytest.mark.parametrize(("args", "match"), [
    (([0.0, 0.0, 1.0], [0.0, 1.0], 1.0), "`east` must be strictly increasing"),
    (([0.0, 1.0], [1.0, -1.0], 1.0), "`north` must be strictly increasing"),
    (([0.0], [0.0, 1.0], 1.0), "`east` must be a 1-D array of at least 2 edges"),
    (([0.0, 1.0], [0.0, 1.0], -1.0), "`overlap` must be a finite width >= 0"),
    (([0.0, 1.0], [0.0, 1.0], np.nan), "`overlap` must be finite"),
    (([0.0, 1.0], [0.0, 1.0], np.inf), "`overlap` must be finite"),
    ((np.arange(300.0), np.arange(300.0), 1.0), "exceed MAX_SECTORS"),
])
def test_bad_sectors_are_refused(args, match):
    with pytest.raises(ValueError, match=match):
        Sectors(*args)


def test_bad_grid_requests_are_refused():
    p = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match="`n_east` must be an integer >= 1; received 0"):
        sector_grid(p, 0, 1, overlap=0.1)
    with pytest.raises(ValueError, match="`n_north` must be an integer >= 1; received -2"):
        sector_grid(p, 1, -2, overlap=0.1)
    with pytest.raises(TypeError, match="`n_east` must be an integer"):
        sector_grid(p, 2.0, 1, overlap=0.1)
    with pytest.raises(ValueError, match="north extent is zero"):
        sector_grid([[0.0, 3.0, 0.0], [1.0, 3.0, 0.0]], 2, 2, overlap=0.1)
    with pytest.raises(ValueError, match="at least one report"):
        sector_grid(np.zeros((0, 3)), 2, 2, overlap=0.1)
    with pytest.raises(ValueError, match="exceed MAX_SECTORS"):
        sector_grid(p, MAX_SECTORS, 2, overlap=0.1)


def test_bad_runs_are_refused_before_work(reports):
    rep = reports[0]
    t, z, cov, r, s = rep
    out = z.copy()
    out[[5, 9], 0] = [70e3, -61e3]
    with pytest.raises(ValueError, match=r"`position`: 2 reports lie outside every sector "
                                         r"\(a gap in coverage.*e\.g\. report 5 at east 70000"):
        track_sectored(t, out, cov, r, s, sectors=GRID)
    # the 720 reports in each of 150 x 100 grown rectangles: 1.08e7 copies of 120 bytes
    wide = Sectors(np.linspace(-60e3, 60e3, 151), np.linspace(-30e3, 30e3, 101),
                   overlap=1e6)
    assert t.size == 720 and t.size * wide.n_sectors * 120 > MEMORY_LIMIT
    with pytest.raises(ValueError, match=r"`sectors`: refused: 1296000000 bytes of per-sector "
                                         r"copies.*limit of 1073741824; use a smaller `overlap`"):
        track_sectored(*rep, sectors=wide)
    with pytest.raises(TypeError, match="`sectors` must be a Sectors"):
        track_sectored(*rep, sectors=[-60e3, 0.0, 60e3])
    with pytest.raises(TypeError, match="`settings` must be a TrackerSettings"):
        track_sectored(*rep, sectors=GRID, settings={"q": 50.0})
    with pytest.raises(TypeError, match=r"`client` must be None .* or a distributed\.Client"):
        track_sectored(*rep, sectors=GRID, client="tcp://127.0.0.1:8786")
    with pytest.raises(ValueError, match="`cov` must"):
        track_sectored(t, z, -cov, r, s, sectors=GRID)


def _failing(reports):
    """The scene with one more report in the east sector 1e40 s later: its tracker's
    prediction over that gap leaves the numeric domain, the west's is untouched."""
    t, z, cov, r, s = reports[0]
    return (np.r_[t, 1e40], np.r_[z, [[45e3, 0.0, 9e3]]], np.r_[cov, cov[:1]], np.r_[r, 0],
            np.r_[s, s.max() + 1])


def test_a_failing_sector_is_named(reports):
    with pytest.raises(SectorError, match=r"the tracker of sector 1 \(east \[0, 60000\], north "
                                          r"\[-30000, 30000\].*ValueError.*numeric domain"):
        track_sectored(*_failing(reports), sectors=GRID)


# ----------------------------------------------------------------------- on a Dask cluster

@pytest.fixture(scope="module")
def client():
    """One LocalCluster of two worker processes for the module's Dask tests."""
    distributed = pytest.importorskip("distributed")
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                       dashboard_address=None,
                                       scheduler_kwargs={"dashboard_address": ":0"})
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


def _same(a, b):
    for f in ("track", "time", "state", "covariance", "confirmed"):
        x, y = getattr(a.history, f), getattr(b.history, f)
        assert x.dtype == y.dtype and np.array_equal(x, y), f
    assert a.history.initiated == b.history.initiated
    for f in ("reports", "tracks", "handovers", "links", "link_cost"):
        assert np.array_equal(getattr(a, f), getattr(b, f)), f


def test_dask_gives_the_same_answer_bit_for_bit(reports, local, client):
    _same(track_sectored(*reports[0], sectors=GRID, client=client), local)
    with pytest.raises(SectorError, match=r"sector 1 \(east \[0, 60000\]"):
        track_sectored(*_failing(reports), sectors=GRID, client=client)


def _sectored_while_killing(client, rep, kill, join=60):
    """track_sectored on `client` in a thread, and ``kill()`` called as soon as the scheduler
    shows a sector processing (it returns what it killed); the killed list and the answer."""
    out, killed = {}, []

    def run():
        try:
            out["result"] = track_sectored(*rep, sectors=GRID, client=client)
        except Exception as exc:                         # shown by the assertion below
            out["error"] = exc

    worker = threading.Thread(target=run)
    worker.start()
    deadline = time.monotonic() + 30
    while not killed and worker.is_alive() and time.monotonic() < deadline:
        busy = sorted(a for a, keys in client.processing().items() if keys)
        if busy:
            killed.append(kill(busy))
        time.sleep(0.005)
    worker.join(join)
    assert killed, "no sector was seen running on a worker"
    assert "error" not in out, out.get("error")
    return killed, out["result"]


def test_a_killed_worker_changes_nothing(client):
    """A worker killed while it tracks a sector: the nanny restarts it; the scheduler
    reruns the task, or, its scattered input lost with the worker, track_sectored scatters
    and submits it again; the answer is the same."""
    rep, _ = scene(duration=400.0, periods=(2.0, 3.0))    # about a second per sector
    ref = track_sectored(*rep, sectors=GRID)

    def kill_one(busy):                                  # the worker dies before it answers
        client.run(os._exit, 1, workers=busy[:1], on_error="ignore")
        return busy[0]

    killed, result = _sectored_while_killing(client, rep, kill_one)
    _same(result, ref)
    deadline = time.monotonic() + 30
    while killed[0] in client.nthreads() and time.monotonic() < deadline:
        time.sleep(0.05)
    assert killed[0] not in client.nthreads()            # it died ...
    client.wait_for_workers(2, timeout=30)               # ... and a new one took over


def _history(track, t, east, initiated):
    n = len(t)
    state = np.zeros((n, 6))
    state[:, 0] = east
    return trk.TrackHistory(np.full(n, track), np.asarray(t, float), state,
                            np.tile(np.eye(6) * 0.01, (n, 1, 1)), np.ones(n, bool), initiated)


@pytest.mark.parametrize("switch", [False, True])
def test_hand_over_rule_on_handmade_histories(switch):
    """Aircraft X crosses east over the border at 0 (overlap 2) between instants 3 and 4,
    seen by track 5 of sector 0 and track 2 of sector 1 in the band; at instant 3 the two
    trackers place it on either side. With `switch`, sector 0's track then carries on to
    another aircraft far west: the tracks disagree at common instants out of the band and
    are not joined, so no row of either is lost."""
    from radarfusion_ref.continent._sectors_merge import merge_histories

    g = Sectors([-10.0, 0.0, 10.0], [-10.0, 10.0], overlap=2.0)
    x = -1.5 + 0.5 * np.arange(10.0)                    # X: -1.5 ... 3.0
    west_x = x[:5].copy()
    west_x[3] = -0.01
    east_x = x.copy()
    east_x[3] = 0.01
    t0 = np.arange(10.0) if switch else np.arange(5.0)
    e0 = np.r_[west_x, np.full(5, -8.0)] if switch else west_x
    h0, h1 = _history(5, t0, e0, 6), _history(2, np.arange(10.0), east_x, 3)
    h, links, handovers = merge_histories(g, [h0, h1], 96.0)
    if not switch:
        assert [v.tolist() for v in links[:4]] == [[0], [5], [1], [2]]
        assert handovers.tolist() == [1, 1]
        assert h.track.tolist() == [5] * 10                   # the provisional id of track 5
        assert h.time.tolist() == list(range(10))
        assert h.state[:, 0].tolist() == [-1.5, -1.0, -0.5, -0.01, *x[4:].tolist()]
    else:
        assert links[0].size == 0 and handovers.tolist() == [0, 0]
        assert sorted(np.unique(h.track).tolist()) == [5, 6 + 2]
        assert np.array_equal(h.state[h.track == 8, 0], east_x[3:])   # all of X's east rows
        assert np.array_equal(h.state[h.track == 5, 0], np.r_[west_x[:4], np.full(5, -8.0)])
    assert h.initiated == 9


def test_sectors_spaced_by_reports_hold_equal_counts():
    """spacing='reports': each column and row holds the same number of reports (to one),
    counted directly; coinciding quantiles and an unknown spacing are refused by name."""
    rng = np.random.default_rng(5)
    p = np.c_[rng.exponential(50e3, 999), rng.normal(0.0, 20e3, 999), np.full(999, 9e3)]
    g = sector_grid(p, 3, 3, overlap=0.0, spacing="reports")
    assert g.east[0] == p[:, 0].min() and g.east[-1] == p[:, 0].max()
    for axis, edges in ((0, g.east), (1, g.north)):
        counts = np.histogram(p[:, axis], bins=edges)[0]
        assert counts.sum() == 999 and counts.max() - counts.min() <= 1, counts
    equal = sector_grid(p, 3, 3, overlap=0.0)
    assert np.ptp(np.diff(equal.east)) < 1e-6 * np.ptp(p[:, 0])
    assert np.ptp(np.histogram(p[:, 0], bins=equal.east)[0]) > 100     # uneven traffic
    with pytest.raises(ValueError, match="`n_east`: with spacing='reports'"):
        sector_grid(np.r_[np.zeros((50, 3)), [[1.0, 1.0, 0.0]]], 3, 1, overlap=0.0,
                    spacing="reports")
    with pytest.raises(ValueError, match="`spacing` must be 'equal' or 'reports'"):
        sector_grid(p, 2, 2, overlap=0.0, spacing="even")


def test_report_counts_per_sector_match_a_direct_count():
    """The per-sector counts of the grown rectangles (one pass over the reports) equal a
    direct count, rectangle by rectangle, with reports exactly on grown edges."""
    g = Sectors([0.0, 3.0, 4.0, 9.0, 10.0], [-2.0, 1.0, 6.0], overlap=0.5)
    rng = np.random.default_rng(11)
    p = np.c_[rng.uniform(0.0, 10.0, 400), rng.uniform(-2.0, 6.0, 400)]
    p[:8] = [[2.5, 0.0], [3.5, 0.5], [4.5, 1.5], [0.0, -2.0], [10.0, 6.0], [8.5, 0.5],
             [9.5, 6.0], [3.5, 1.5]]                      # on grown edges and corners
    want = []
    for j in range(2):
        for i in range(4):
            e0, e1 = g.east[i] - 0.5, g.east[i + 1] + 0.5
            n0, n1 = g.north[j] - 0.5, g.north[j + 1] + 0.5
            want.append(sum(e0 <= e <= e1 and n0 <= n <= n1 for e, n in p.tolist()))
    got = g._counts(p)
    assert min(want) > 0 and got.tolist() == want


def test_hand_over_costs_skip_only_pairs_beyond_the_gate():
    """The hand-over's pair costs leave out pairs of tracks far apart before reading their
    covariances: the pairs they keep below the gate, and their means, are those of a
    brute-force mean over every common instant of every pair (correlated covariances
    whose largest eigenvalue is near their trace, so the bound is tight)."""
    from radarfusion_ref.continent._sectors_merge import Edge, pair_costs

    rng = np.random.default_rng(7)
    gamma = 11.34
    track = np.repeat(np.arange(6), 5)
    t = np.tile(np.arange(5.0), 6)
    u = rng.normal(0.0, 1.0, (30, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    P = 4.0 * u[:, :, None] * u[:, None, :] + 0.05 * np.eye(3)   # long along u
    xa = rng.normal(0.0, 30.0, (6, 3))[track] + rng.normal(0.0, 0.5, (30, 3))
    # track k of b follows track k of a, off along u by a squared distance of 0.93 to 1.07
    # gamma (S = 8 u u' + 0.1 I: |d|^2 = 8.1 kappa, 0.976 gamma tr S at kappa = gamma, so
    # a bound tighter by 10 % leaves every pair out); track 6 of b is far from all
    r = np.sqrt(rng.uniform(0.93, 1.07, 30) * gamma * 8.1)
    xb = np.r_[xa + r[:, None] * u, rng.normal(0.0, 30.0, (5, 3))]
    Pb = np.r_[P, np.tile(np.eye(3), (5, 1, 1))]
    ha = Edge(track, t, xa, P, np.ones(30, bool), np.trace(P, axis1=1, axis2=2))
    hb = Edge(np.repeat(np.arange(7), 5), np.tile(np.arange(5.0), 7), xb, Pb,
              np.ones(35, bool), np.trace(Pb, axis1=1, axis2=2))
    rows_a, rows_b = np.arange(ha.track.size), np.arange(hb.track.size)
    ka, kb, kappa = pair_costs(ha, hb, rows_a, rows_b, gamma)
    want = {}
    for a in range(6):
        for b in range(7):
            d2 = []
            for m in range(5):
                i, j = a * 5 + m, b * 5 + m
                d = ha.state[i] - hb.state[j]
                d2.append(d @ np.linalg.solve(ha.covariance[i] + hb.covariance[j], d))
            want[a, b] = np.mean(d2)
    below = {k: v for k, v in want.items() if v < gamma}
    assert len(below) == 3 and len(want) == 42
    assert len(ka) < len(want)                           # some pairs were left out
    got = {(a, b): v for a, b, v in zip(ka.tolist(), kb.tolist(), kappa.tolist(), strict=True)
           if v < gamma}
    assert got.keys() == below.keys()
    for k, v in below.items():
        assert got[k] == pytest.approx(v, rel=1e-12)


def test_dask_with_more_sectors_than_workers(reports, client):
    """Six sectors (three without reports) on two workers, the largest first: the same
    answer bit for bit as in this process."""
    g = Sectors([-60e3, -20e3, 20e3, 60e3], [-30e3, 30e3, 200e3], overlap=10e3)
    here = track_sectored(*reports[0], sectors=g)
    assert here.reports[3:].tolist() == [0, 0, 0] and here.reports[:3].min() > 0
    assert here.links.shape[0] >= 2
    _same(track_sectored(*reports[0], sectors=g, client=client), here)


def test_reports_lost_with_every_worker_are_scattered_again(client):
    """Every worker killed while a sector runs: the reports scattered to them are lost
    and the tasks cancelled; track_sectored scatters the reports to the new workers and
    submits the tasks again; the answer is the same."""
    rep, _ = scene(duration=400.0, periods=(2.0, 3.0))
    ref = track_sectored(*rep, sectors=GRID)
    before = set(client.nthreads())

    def kill_all(busy):                                  # every worker dies
        client.run(os._exit, 1, on_error="ignore")
        return True

    _, result = _sectored_while_killing(client, rep, kill_all, join=90)
    _same(result, ref)
    client.wait_for_workers(2, timeout=30)
    assert not before & set(client.nthreads())           # two new workers took over
