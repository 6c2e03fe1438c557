"""Architecture (c), track then fuse: identities across fusion instants (constructed scene)."""

from __future__ import annotations

import numpy as np
import pytest

from radarfusion_ref import capstone as cp
from radarfusion_ref import trackfusion as tf
from radarfusion_ref.tracking import (
    TrackerSettings,
    TrackHistory,
    evaluate_tracks_over_time,
    track_reports,
    track_then_fuse,
)
from radarfusion_ref.tracking import _architectures as arch
from radarfusion_ref.tracking._motion import axis_q

SEP = 300.0                                      # lateral separation of the two aircraft, m
SPEED = 200.0
RADARS = ((5.0, 0.5), (4.0, 1.0), (3.0, 1.5))    # (scan period, first scan) per radar, s
DURATION = 120.0
GLITCH = 50.5                                    # radar 0's scan with a 0.6 SEP error


def _truth(t):
    """Positions (2, T, 3) of two aircraft flying in parallel, SEP apart."""
    t = np.asarray(t, float)
    x = np.stack([SPEED * t, np.zeros_like(t), np.full_like(t, 8000.0)], -1)
    return np.stack([x, x + np.array([0.0, SEP, 0.0])])


def _local_tracks(radar, *, b_first):
    """Exact local tracks of one radar; radar 0 pulls both tracks 0.6 SEP towards each
    other at one scan (its tracks then sit on the wrong side of each other).
    `b_first`: radar 0 numbers aircraft B's track first."""
    per, ph = RADARS[radar]
    t = np.arange(ph, DURATION, per)
    pos = _truth(t)                                                    # (2, T, 3)
    if radar == 0:
        k = np.flatnonzero(np.isclose(t, GLITCH))[0]
        pos[0, k, 1] += 0.6 * SEP
        pos[1, k, 1] -= 0.6 * SEP
    vel = np.broadcast_to([SPEED, 0.0, 0.0], pos.shape)
    state = np.concatenate([pos, vel], -1).reshape(-1, 6)
    ids = np.repeat([1, 0] if (b_first and radar == 0) else [0, 1], t.size)
    time = np.tile(t, 2)
    var = 4e4 if radar == 0 else 1e4                   # radar 0: the least accurate
    cov = np.broadcast_to(np.diag([var, var, var, 25.0, 25.0, 25.0]), (time.size, 6, 6))
    o = np.lexsort((ids, time))
    return TrackHistory(ids[o], time[o], state[o], cov[o].copy(), np.ones(time.size, bool))


def _reports():
    """One report per radar scan (the local tracks are given; only the scan instants count)."""
    rows = [(t, r, k) for r, (per, ph) in enumerate(RADARS)
            for k, t in enumerate(np.arange(ph, DURATION, per))]
    t, r, k = (np.array(c) for c in zip(*sorted(rows), strict=True))
    z = _truth(t)[0]
    return t, z, np.broadcast_to(np.eye(3) * 1e4, (t.size, 3, 3)).copy(), r, k


@pytest.mark.parametrize("rule", ["ci", "naive"])
@pytest.mark.parametrize("b_first", [False, True])
def test_track_then_fuse_keeps_identities_through_a_one_scan_glitch(monkeypatch, rule,
                                                                    b_first):
    # radar 0's tracks are swapped in position at one scan: a memoryless association pairs
    # them with the other radars' tracks of the other aircraft at that instant; the fused
    # tracks must still follow one aircraft each, at every instant
    def fake(time, position, covariance, radar, scan, *, settings=None):
        return _local_tracks(int(radar[0]), b_first=b_first)

    monkeypatch.setattr(arch, "track_reports", fake)
    h = track_then_fuse(*_reports(), period=5.0, rule=rule)
    assert np.unique(h.track).size == 2
    truth = _truth(h.time)                                             # (2, K, 3)
    d = np.linalg.norm(h.state[None, :, :3] - truth, axis=-1)           # (2, K)
    near = d.argmin(0)
    for k in np.unique(h.track):
        rows = h.track == k
        assert np.unique(near[rows]).size == 1, (k, h.time[rows][near[rows] != near[rows][0]])
    # and every fused row lies within its own aircraft's half of the separation
    assert np.all(d.min(0) < SEP / 2)


def test_identities_majority_vote():
    # the identity most of a group's local tracks carried wins, one identity per group
    ident = {(0, 1): 5, (1, 7): 2, (2, 3): 2, (0, 4): 2, (1, 8): 5, (2, 9): 5}
    gid, nxt = arch._identities([[(0, 1), (1, 7), (2, 3)], [(0, 4), (1, 8), (2, 9)],
                                 [(1, 99)]], ident, 6)
    assert gid.tolist() == [2, 5, 6] and nxt == 7


# --------------------------------------------------------------------------- Bar-Shalom–Campo
# The cross-covariance of two asynchronous local tracks, from their histories alone, against
# an independent simulation: a small Kalman-filter loop written here (not the package's).
Q_INT = 20.0                                     # process-noise intensity, m²/s³
H3 = np.hstack([np.eye(3), np.zeros((3, 3))])
R_A = np.diag([100.0, 400.0, 900.0])
R_B = np.array([[300.0, 120.0, 0.0], [120.0, 200.0, -50.0], [0.0, -50.0, 600.0]])


def _cv(dt, q):
    """Constant velocity in 3-D with continuous white-noise acceleration: F, Q."""
    f = np.array([[1.0, dt], [0.0, 1.0]])
    qq = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    return np.kron(f, np.eye(3)), np.kron(qq, np.eye(3))


def _p0(R):
    """A fresh track's covariance: its first report, and a velocity prior of 50 m/s."""
    P = np.zeros((6, 6))
    P[:3, :3], P[3:, 3:] = R, 50.0**2 * np.eye(3)
    return P


def _two_filters(times, restarts, instants, q, trials, rng):
    """Two Kalman filters (radars A, B at their own instants) on one simulated target.

    A filter starts (and restarts, at `restarts`) with an error drawn from its covariance,
    independent of the other's. Returns the histories (one trial's states; covariances are
    the same in every trial) and the errors of both filters predicted to each of `instants`.
    """
    R = (R_A, R_B)
    x = np.zeros((trials, 6))
    x[:, 3:] = rng.normal(0.0, 100.0, (trials, 3))
    est, cov, last, rows, errors = [None, None], [None, None], [0.0, 0.0], ([], []), []
    t_prev = 0.0
    for t in sorted({*times[0], *times[1], *instants}):
        F, Q = _cv(t - t_prev, q)
        x = x @ F.T + rng.multivariate_normal(np.zeros(6), Q, trials)
        t_prev = t
        for i in (0, 1):
            if t not in times[i]:
                continue
            z = x[:, :3] + rng.multivariate_normal(np.zeros(3), R[i], trials)
            if est[i] is None or (i, t) in restarts:
                cov[i] = _p0(R[i])
                est[i] = x + rng.multivariate_normal(np.zeros(6), cov[i], trials)
            else:
                F, Q = _cv(t - last[i], q)
                Pp = F @ cov[i] @ F.T + Q
                K = Pp @ H3.T @ np.linalg.inv(H3 @ Pp @ H3.T + R[i])
                xp = est[i] @ F.T
                est[i] = xp + (z - xp[:, :3]) @ K.T
                cov[i] = (np.eye(6) - K @ H3) @ Pp
                cov[i] = 0.5 * (cov[i] + cov[i].T)
            last[i] = t
            rows[i].append((t, est[i][0].copy(), cov[i].copy()))
        if t in instants:
            errors.append([est[i] @ _cv(t - last[i], q)[0].T - x for i in (0, 1)])
    hist = {}
    for i in (0, 1):
        tt, xs, Ps = (np.array(c) for c in zip(*rows[i], strict=True))
        hist[i] = TrackHistory(np.full(tt.size, 5 + i), tt, xs, Ps, np.ones(tt.size, bool))
    return hist, errors


def test_cross_covariance_of_asynchronous_tracks_matches_monte_carlo():
    # radar A every 3 s from 1 s, B every 5 s from 2.5 s; A's track restarts at 22 s (a
    # relinked identity); P_ab asked at four instants in turn (the running cache)
    rng = np.random.default_rng(7)
    times = (set(1.0 + 3.0 * np.arange(14)), set(2.5 + 5.0 * np.arange(9)))
    instants, trials = (12.2, 22.5, 30.7, 41.0), 20_000
    hist, errors = _two_filters(times, {(0, 22.0)}, instants, Q_INT, trials, rng)
    loc = arch._Local(hist, np.full(3, Q_INT), gains=True)
    starts = loc.t[np.unique(loc.last_restart)]
    assert starts.tolist() == [1.0, 22.0, 2.5]        # A's first row, its restart, B's first row
    cross = arch._Cross(loc, np.full(3, Q_INT))
    for tg, (ea, eb) in zip(instants, errors, strict=True):
        P12 = cross.at(loc.latest(0, tg, 1e9), loc.latest(1, tg, 1e9), tg)[0]
        emp = ea.T @ eb / trials
        # standard error of a Gaussian product moment: sqrt((P_a,ii P_b,jj + P_ab,ij²) / N)
        se = np.sqrt((np.mean(ea**2, 0)[:, None] * np.mean(eb**2, 0) + P12**2) / trials)
        assert np.all(np.abs(emp - P12) < 4.5 * se), (tg, ((emp - P12) / se).round(1))
        if tg != 22.5:                                 # just after the restart: nearly 0
            assert np.abs(P12 / se).max() > 50          # a zero cross-covariance fails here


def test_cross_covariance_of_synchronous_tracks_is_chapter_10s_recursion():
    # same instants and a common start: the recursion is trackfusion.cross_covariance's
    dt, steps = 4.0, 12
    m = tf.constant_velocity(dt, Q_INT, dim=3)
    cc = tf.cross_covariance(m.F, m.Q, H3, R_A, H3, R_B, steps=steps, P1_0=_p0(R_A),
                             P2_0=_p0(R_B))
    t = dt * np.arange(steps + 1)
    hist = {i: TrackHistory(np.zeros(steps + 1, np.int64), t, np.zeros((steps + 1, 6)),
                            np.concatenate([[_p0(R)], P]), np.ones(steps + 1, bool))
            for i, (R, P) in enumerate(((R_A, cc.P1), (R_B, cc.P2)))}
    loc = arch._Local(hist, np.full(3, Q_INT), gains=True)
    cross = arch._Cross(loc, np.full(3, Q_INT))
    for k in range(1, steps + 1):
        P12 = cross.at(np.array([k]), np.array([steps + 1 + k]), t[k])[0]
        np.testing.assert_allclose(P12, cc.P12[k - 1], rtol=1e-7, atol=1e-9 * np.abs(
            cc.P12[k - 1]).max())


# three radars of their own periods, phases and accuracies: (period s, first scan s, R m²)
SCENE_RADARS = ((12.0, 5.0, np.diag([150.0, 150.0, 300.0]) ** 2),
                (8.0, 2.5, np.diag([100.0, 250.0, 200.0]) ** 2),
                (5.0, 1.0, np.diag([200.0, 120.0, 250.0]) ** 2))


def _model_scene(n_targets, duration, q, rng):
    """Reports of targets that move exactly as the trackers' model says: constant velocity
    with white-noise acceleration of intensity `q`, initial velocities drawn from the
    trackers' prior (0 ± 250 m/s per axis), 50 km apart, every radar detecting every target.
    Returns the reports, the truth's instants (every second and every scan) and states."""
    scans = [(ph + per * k, r, k, R) for r, (per, ph, R) in enumerate(SCENE_RADARS)
             for k in range(int((duration - ph) / per) + 1)]
    grid = np.union1d(np.arange(0.0, duration + 0.5), [s[0] for s in scans])
    x = np.zeros((n_targets, 6))
    x[:, 0], x[:, 2] = 50_000.0 * np.arange(n_targets), 9000.0
    x[:, 3:] = rng.normal(0.0, 250.0, (n_targets, 3))
    truth = np.empty((grid.size, n_targets, 6))
    for k, dt in enumerate(np.diff(grid, prepend=0.0)):
        F, Q = _cv(dt, q)
        x = x @ F.T + rng.multivariate_normal(np.zeros(6), Q, n_targets)
        truth[k] = x
    rows = []
    for t, r, k, R in sorted(scans, key=lambda s: (s[0], s[1])):
        z = truth[np.searchsorted(grid, t), :, :3] + rng.multivariate_normal(
            np.zeros(3), R, n_targets)
        rows += [(t, r, k, zi, R) for zi in z]
    t, r, k, z, R = (np.array(c) for c in zip(*rows, strict=True))
    return (t, z, R, r, k), grid, truth


def test_bar_shalom_campo_is_consistent_where_the_model_holds():
    # 40 targets, 300 s, seed 11: the position NEES of the fused rows from 60 s on, each
    # row against its nearest target; one mean per target (rows of one target are
    # correlated), then the mean over targets with its 95 % normal interval
    rng = np.random.default_rng(11)
    q = 50.0
    reports, grid, truth = _model_scene(40, 300.0, q, rng)
    settings = TrackerSettings(q=q, q_vertical=None, speed_max_vertical=None)  # the scene's model
    out = {}
    for rule in arch.T2T_RULES:
        h = track_then_fuse(*reports, period=5.0, settings=settings, rule=rule)
        keep = h.time >= 60.0
        pos = truth[np.searchsorted(grid, h.time[keep]), :, :3]          # (K, targets, 3)
        near = np.linalg.norm(h.state[keep, None, :3] - pos, axis=-1).argmin(1)
        e = h.state[keep, :3] - pos[np.arange(near.size), near]
        nees = np.einsum("ki,ki->k", e, np.linalg.solve(h.covariance[keep, :3, :3],
                                                        e[..., None])[..., 0])
        per_target = np.array([nees[near == j].mean() for j in np.unique(near)])
        assert per_target.size == 40 and np.unique(h.track).size == 40
        half = 1.96 * per_target.std(ddof=1) / np.sqrt(per_target.size)
        out[rule] = (per_target.mean() - half, per_target.mean(), per_target.mean() + half)
    lo, mean, hi = out["bar_shalom_campo"]
    assert lo < 3.0 < hi, out                               # consistent
    assert out["naive"][0] > 3.0, out                       # over-confident
    assert abs(mean - 3.0) < abs(out["naive"][1] - 3.0), out
    assert out["ci"][1] < 3.0, out                          # conservative


@pytest.fixture(scope="module")
def realistic_window():
    traffic = cp.load_traffic()
    radars = cp.realistic_radars()
    det = cp.simulate_detections(traffic, radars, duration=300.0, rng=2018)
    pos, cov = cp.to_common(det, radars, cp.register_detections(det, radars).biases)
    return traffic, radars, (det.time, pos, cov, det.radar, det.scan)


def test_bar_shalom_campo_covariance_is_below_ci_on_the_same_groups(realistic_window):
    # the fused groups of the realistic window every 5 s: the BLUE's covariance is below
    # (Loewner) both the sequential covariance intersection of the same tracks and every
    # single track's own
    *_, reports = realistic_window
    settings = TrackerSettings()
    t, z, R, rad, sc = reports
    hist = {r: track_reports(t[rad == r], z[rad == r], R[rad == r], rad[rad == r],
                             sc[rad == r], settings=settings) for r in range(3)}
    loc = arch._Local(hist, axis_q(settings), gains=True)     # as track_then_fuse does
    cross = arch._Cross(loc, axis_q(settings))
    fused = 0
    for tg in np.arange(t.min() + 5.0, t.max(), 5.0):
        _, gP, _, rows = arch._fuse_at(loc, cross, tg, settings, "bar_shalom_campo", {})
        for n in (2, 3):
            sel = [i for i, m in enumerate(rows) if len(m) == n]
            if not sel:
                continue
            fused += len(sel)
            members = np.array([rows[i] for i in sel])                  # (G, n), radar order
            ci = tf.TrackEstimate(loc.px[members[:, 0]], loc.pP[members[:, 0]])
            for j in range(1, n):                                       # as rule="ci" fuses
                ci = tf.covariance_intersection(ci.estimate, ci.covariance,
                                                loc.px[members[:, j]], loc.pP[members[:, j]])
            for other in (ci.covariance, *np.swapaxes(loc.pP[members], 0, 1)):
                low = np.linalg.eigvalsh(other - gP[sel])[:, 0]
                assert np.all(low > -1e-9 * np.linalg.eigvalsh(other)[:, -1]), (tg, low.min())
    assert fused > 500


def test_bar_shalom_campo_nees_lies_between_ci_and_naive(realistic_window):
    # on real traffic the local trackers' model is not exact (manoeuvres; q tuned on the
    # tuning hour): the position NEES of (c), seed 2018, 300 s, every 10 s from 60 s, orders
    # covariance intersection < Bar-Shalom–Campo < naive, and Bar-Shalom–Campo's mean GOSPA
    # is below covariance intersection's
    traffic, radars, reports = realistic_window
    m = {rule: evaluate_tracks_over_time(
             track_then_fuse(*reports, period=5.0, rule=rule), traffic, c=2000.0, p=2.0,
             times=np.arange(60.0, 300.0, 10.0), radars=radars)
         for rule in arch.T2T_RULES}
    nees = {k: v.nees.mean for k, v in m.items()}
    assert nees["ci"] < nees["bar_shalom_campo"] < nees["naive"], nees
    assert m["bar_shalom_campo"].mean_gospa < m["ci"].mean_gospa, nees


def test_unknown_rule_is_refused_by_name():
    t, z, R, r, k = _reports()
    with pytest.raises(ValueError, match=r"`rule`.*'bar_shalom_campo'.*received 'bsc'"):
        track_then_fuse(t, z, R, r, k, period=5.0, rule="bsc")
    with pytest.raises(ValueError, match=r"`rule` 'bar_shalom_campo'.*`settings`.*'jpda'"):
        track_then_fuse(t, z, R, r, k, period=5.0, rule="bar_shalom_campo",
                        settings=TrackerSettings(association="jpda"))
