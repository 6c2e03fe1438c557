"""The reports' scalar feature in the tracker: its likelihood ratio, its estimate, its input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from radarfusion_ref import capstone as cp
from radarfusion_ref.engine.tracker import kalman_predict, kalman_update
from radarfusion_ref.tracking import TrackerSettings, track_reports

SIGMA = 150.0


def _line(scans=8, period=5.0, seed=3):
    """One aircraft in a straight line, one report per scan of one radar."""
    rng = np.random.default_rng(seed)
    t = np.arange(scans) * period
    z = np.array([0.0, 0.0, 9000.0]) + np.array([220.0, 10.0, 0.0]) * t[:, None]
    z = z + SIGMA * rng.standard_normal(z.shape)
    R = np.tile(np.eye(3) * SIGMA**2, (scans, 1, 1))
    return (t, z, R, np.zeros(scans, int), np.arange(scans)), rng


def test_jpda_with_a_feature_is_the_mixture_by_hand():
    """One track, one report a scan, JPDA: the miss and the report weighed by the position
    and feature likelihoods (scipy.stats), the state and the feature mixed over the two
    events by hand, equal the tracker's rows. The feature moves the weights: a report 50 kt
    off the track's feature weighs less than its position alone would make it, and a
    doubtful position with the track's feature weighs more."""
    inputs, rng = _line()
    t, z, R = inputs[:3]
    f = 450.0 + 10.0 * rng.standard_normal(t.size)
    f[4] += 50.0                                     # one report whose feature disagrees
    fv = np.full(t.size, 100.0)
    s = TrackerSettings(association="jpda", p_false_confirm=0.1, clutter_density=1e-11,
                        q_vertical=None, speed_max_vertical=None)
    h = track_reports(*inputs, feature=f, feature_var=fv, settings=s)
    plain = track_reports(*inputs, settings=s)
    assert np.unique(h.track).size == 1 and len(h) == t.size
    x = np.r_[z[0], 0.0, 0.0, 0.0]
    P = np.zeros((6, 6))
    P[:3, :3], P[3:, 3:] = R[0], s.speed_max**2 * np.eye(3)
    fh, pf = f[0], fv[0]
    w_miss = 1 - s.p_detection * (1 - s.p_false_reject)
    betas, alone = [], []
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        pred = kalman_predict(x, P, dt, s.q)
        x, P = pred.state, pred.covariance
        pf = pf + s.q_feature * dt
        upd = kalman_update(x, P, z[k], R[k])
        lik = stats.multivariate_normal.pdf(z[k], x[:3], P[:3, :3] + R[k])
        lik_f = stats.norm.pdf(f[k], fh, math.sqrt(pf + fv[k])) / s.feature_density
        ratio = s.p_detection * lik / s.clutter_density * lik_f
        beta = ratio / (ratio + w_miss)
        alone.append(ratio / lik_f / (ratio / lik_f + w_miss))   # position alone
        gain = pf / (pf + fv[k])
        fu, pu = fh + gain * (f[k] - fh), (1 - gain) * pf
        mean = (1 - beta) * x + beta * upd.state
        dx0, dx1 = x - mean, upd.state - mean
        P = ((1 - beta) * (P + np.outer(dx0, dx0))
             + beta * (upd.covariance + np.outer(dx1, dx1)))
        fm = (1 - beta) * fh + beta * fu
        pf = (1 - beta) * (pf + (fh - fm) ** 2) + beta * (pu + (fu - fm) ** 2)
        x, fh = mean, fm
        betas.append(beta)
        np.testing.assert_allclose(h.state[k], x, rtol=1e-9, atol=1e-6)
        np.testing.assert_allclose(h.covariance[k], P, rtol=1e-7, atol=1e-6)
    # the disagreeing report weighs less than its position alone would make it
    assert min(betas) > 0.5 and betas[3] < alone[3] - 0.05
    assert alone[2] < 0.5 < betas[2]
    assert not np.allclose(h.state[4], plain.state[4])


def test_a_matching_feature_wins_the_assignment():
    """A track followed for five scans meets two reports in its gate: the nearer one with a
    feature 60 kt off (about six standard deviations) and one 2.5 sigma farther with the
    track's feature. Without features GNN takes the nearer; with them, the other."""
    inputs, rng = _line(scans=6)
    t, z, R, radar, scan = inputs
    near, far = z[-1] + 0.3 * SIGMA, z[-1] + np.array([2.5 * SIGMA, 0.0, 0.0])
    t = np.r_[t, t[-1]]
    z = np.r_[z[:-1], near[None], far[None]]
    R = np.r_[R, R[:1]]
    radar, scan = np.r_[radar, 0], np.r_[scan, scan[-1]]
    f = np.r_[np.full(5, 450.0) + rng.normal(0, 3, 5), 510.0, 450.0]
    fv = np.full(t.size, 100.0)
    s = TrackerSettings(p_false_confirm=0.1, clutter_density=1e-14)
    last = {}
    for name, kw in (("plain", {}), ("feature", dict(feature=f, feature_var=fv))):
        h = track_reports(t, z, R, radar, scan, settings=s, **kw)
        first = h.track[h.time == 0.0][0]
        row = (h.track == first) & (h.time == t[-1])
        last[name] = h.state[row, 0][0]
    assert abs(last["plain"] - near[0]) < abs(last["plain"] - far[0])
    assert abs(last["feature"] - far[0]) < abs(last["feature"] - near[0])


def test_the_feature_term_is_the_normal_log_likelihood_ratio():
    from radarfusion_ref.tracking._feature import increments
    est, var = np.array([400.0, 450.0]), np.array([50.0, 120.0])
    f, fv = np.array([410.0, 300.0]), np.array([100.0, 100.0])
    want = stats.norm.logpdf(f, est, np.sqrt(var + fv)) - math.log(1 / 300)
    np.testing.assert_allclose(increments(est, var, f, fv, 1 / 300), want, rtol=1e-13)


def test_gnn_states_do_not_depend_on_the_feature():
    """GNN with one report a scan takes the same reports with or without features here,
    and the feature never enters the kinematic update: the rows' states and covariances
    are the same bit for bit, only the track's score (its confirmation) differs."""
    inputs, rng = _line(scans=10)
    f = 450.0 + 10.0 * rng.standard_normal(10)
    s = TrackerSettings(p_false_confirm=1e-10)
    a = track_reports(*inputs, settings=s)
    b = track_reports(*inputs, feature=f, feature_var=np.full(10, 100.0), settings=s)
    for name in ("track", "time", "state", "covariance"):
        assert np.array_equal(getattr(a, name), getattr(b, name))
    # a feature that agrees adds evidence: confirmed at an earlier report
    assert np.argmax(b.confirmed) < np.argmax(a.confirmed)


def test_default_feature_walk_is_the_tuning_hour_s():
    """`q_feature`'s default, 0.05 kt²/s, is the tuning hour's mean squared change of the
    ADS-B ground speed per second (sum of squared changes over the summed intervals), to
    one significant figure."""
    tr = cp.load_traffic(hour="tuning")
    o = np.lexsort((tr.t, tr.aircraft))
    same = np.diff(tr.aircraft[o]) == 0
    dv, dt = np.diff(tr.speed[o])[same], np.diff(tr.t[o])[same]
    rate = float(np.sum(dv**2) / np.sum(dt))
    assert float(f"{rate:.1g}") == TrackerSettings().q_feature


def test_feature_density_default_is_the_capstone_s_false_feature_spread():
    from radarfusion_ref.capstone.radars import _FEATURE_SPAN
    assert TrackerSettings().feature_density == 1 / (_FEATURE_SPAN[1] - _FEATURE_SPAN[0])


@pytest.mark.parametrize(("kw", "match"), [
    (dict(feature=np.zeros(8)), "`feature_var`"),
    (dict(feature_var=np.ones(8)), "`feature`"),
    (dict(feature=np.zeros(7), feature_var=np.ones(8)), r"`feature` must have shape \(8,\)"),
    (dict(feature=np.zeros(8), feature_var=np.ones((8, 1))), "`feature_var` must have shape"),
    (dict(feature=np.zeros(8), feature_var=np.r_[np.ones(7), 0.0]), "`feature_var` must be > 0"),
    (dict(feature=np.r_[np.zeros(7), np.nan], feature_var=np.ones(8)), "`feature`"),
    (dict(feature=np.zeros(8), feature_var=np.r_[np.ones(7), np.inf]), "`feature_var`"),
])
def test_bad_features_are_refused_by_name(kw, match):
    inputs, _ = _line()
    with pytest.raises(ValueError, match=match):
        track_reports(*inputs, **kw)


def test_bad_feature_strings_are_refused_by_name():
    inputs, _ = _line()
    with pytest.raises(TypeError, match="`feature`"):
        track_reports(*inputs, feature=["a"] * 8, feature_var=np.ones(8))


@pytest.mark.parametrize("field", ["feature_density", "q_feature"])
@pytest.mark.parametrize("value", [0.0, -1.0, np.nan, np.inf])
def test_bad_feature_settings_are_refused_by_name(field, value):
    with pytest.raises(ValueError, match=f"`{field}`"):
        TrackerSettings(**{field: value})
