"""Tests of the realistic radars and the truth at any instant (capstone.detections, truth_at).

Detections in simple and realistic mode, each radar's own frame and timing, to_common with a
registration estimate, the interpolated truth's freshness rule, bad input.
"""

from __future__ import annotations

import dataclasses
import gzip
import math

import numpy as np
import pytest
from scipy import stats

from radarfusion_ref import capstone as cp
from radarfusion_ref.engine.geodesy import geodetic_to_enu
from radarfusion_ref.engine.metrics import nees

_KT = 1852.0 / 3600.0


@pytest.fixture(scope="module")
def traffic():
    return cp.load_traffic()


@pytest.fixture(scope="module")
def realistic(traffic):
    radars = cp.realistic_radars()
    return radars, cp.simulate_detections(traffic, radars, start=600.0, duration=240.0, rng=3)


# ----------------------------------------------------------------------------- simple mode
def test_simple_mode_is_the_capstone_simulation(traffic):
    """Same seed, same draws: the rows of simulate_reports on truth_scans, in its order."""
    radars = cp.default_radars()
    det = cp.simulate_detections(traffic, radars, start=600.0, duration=120.0, mode="simple",
                                 rng=7)
    truth = cp.truth_scans(traffic, period=10.0, start=600.0, duration=120.0)
    rep = cp.simulate_reports(truth, radars, rng=7)
    assert det.frame == "common"
    assert np.array_equal(det.polar, np.stack([rep.r, rep.beta, rep.epsilon], -1))
    for a, b in ((det.radar, rep.radar), (det.scan, rep.scan), (det.aircraft, rep.source),
                 (det.feature, rep.feature), (det.time, truth.times[rep.scan])):
        assert np.array_equal(a, b)
    sig = np.array([[r.sigma_r, r.sigma_beta, r.sigma_epsilon] for r in radars])[rep.radar]
    assert np.array_equal(np.diagonal(det.polar_cov, axis1=1, axis2=2), sig**2)
    # to_common is the pipeline's conversion (its stage 1) on the same reports
    res = cp.run_pipeline(rep, radars, cp.PipelineSettings(register=False))
    x, P = cp.to_common(det, radars)
    assert np.array_equal(x, res.report_position)
    assert np.array_equal(P, res.report_covariance)


def test_simple_mode_refuses_radars_of_different_timing(traffic):
    with pytest.raises(ValueError, match=r"`radars`.*share one `period`"):
        cp.simulate_detections(traffic, cp.realistic_radars(), mode="simple", duration=60.0)


# ----------------------------------------------------------------------------- realistic mode
def test_each_radar_scans_at_its_own_instants(realistic):
    radars, det = realistic
    assert det.frame == "local"
    assert np.all(np.diff(det.time) >= 0)
    key = det.time * 10 + det.radar                         # sorted by (time, radar)
    assert np.all(np.diff(key) >= 0)
    for i, r in enumerate(radars):
        mine = det.radar == i
        t, k = det.time[mine], det.scan[mine]
        assert np.allclose(t, r.phase + r.period * k, rtol=0, atol=1e-9)
        ks = np.unique(k)
        # every scan of the window is present (clutter alone fills it) and none outside
        first = math.ceil((600.0 - r.phase) / r.period)
        assert ks.tolist() == list(range(first, first + ks.size))
        assert t.min() >= 600.0
        assert t.max() < 840.0
        assert ks.size == pytest.approx(240 / r.period, abs=1)


def test_local_frame_is_the_radar_s_own_enu(traffic):
    """Noise-free, unbiased reports are the polar coordinates of the truth in the radar's
    ENU frame computed directly from the geodetic records (an independent route)."""
    radars = cp.realistic_radars(sigma_r=1e-6, sigma_beta=1e-12, sigma_epsilon=1e-12,
                                 p_detect=1.0, clutter_rate=0.0, bias_range=0.0,
                                 bias_azimuth=0.0, bias_scale=0.0, period=10.0, phase=0.0)
    det = cp.simulate_detections(traffic, radars, start=1200.0, duration=30.0, rng=0)
    enu_by = {}
    for k in range(traffic.t.size):
        enu_by[(int(traffic.aircraft[k]), float(traffic.t[k]))] = k
    times, inv = np.unique(det.time, return_inverse=True)
    pos_all, _ = cp.truth_at(traffic, times)
    checked = 0
    for row in range(len(det)):
        key = (int(det.aircraft[row]), float(det.time[row]))
        rec = enu_by.get(key)
        if rec is None:
            continue
        r = radars[det.radar[row]]
        d = geodetic_to_enu(traffic.lat[rec], traffic.lon[rec], traffic.alt[rec],
                            origin=(r.lat, r.lon, r.height))
        rng_ = np.linalg.norm(d)
        want = (rng_, math.atan2(d[1], d[0]), math.asin(d[2] / rng_))
        if not np.allclose(pos_all[det.aircraft[row], inv[row]],
                           geodetic_to_enu(traffic.lat[rec], traffic.lon[rec],
                                           traffic.alt[rec], origin=cp.ORIGIN), atol=1e-6):
            continue                                   # a stale record: the truth skips it
        assert det.polar[row] == pytest.approx(want, abs=1e-5, rel=1e-9)
        checked += 1
    assert checked > 100
    # the local frames are tilted against the common one: elevations differ from the
    # common-frame ones by up to the angle between the verticals
    A = cp.local_rotation(radars[0])
    tilt = math.degrees(math.acos(A[2, 2]))
    assert 1.0 < tilt < 2.5                               # La Dole, 1.6 deg from the origin


def test_to_common_undoes_the_frames_and_the_biases(traffic):
    """With the radars' true biases to_common recovers the truth to the noise; without,
    reports are off by the bias displacement."""
    radars = cp.realistic_radars(sigma_r=0.01, sigma_beta=1e-8, sigma_epsilon=1e-8,
                                 p_detect=1.0, clutter_rate=0.0)
    det = cp.simulate_detections(traffic, radars, start=300.0, duration=60.0, rng=1)
    pos, ok = cp.truth_at(traffic, det.time)
    truth = pos[det.aircraft, np.arange(len(det))]
    assert ok[det.aircraft, np.arange(len(det))].all()
    b = np.array([[r.bias_range, r.bias_scale, r.bias_azimuth] for r in radars])
    x, _ = cp.to_common(det, radars, b, debias=False)
    assert np.max(np.linalg.norm(x - truth, axis=1)) < 0.1
    x0, _ = cp.to_common(det, radars, debias=False)
    off = np.linalg.norm(x0 - truth, axis=1)
    assert off.min() > 50.0                               # every report carries its bias


def test_to_common_covariance_is_consistent(realistic, traffic):
    """NEES of the corrected detections: mean within the chi2_3 range of its count."""
    radars, det = realistic
    real = det.aircraft >= 0
    sub = det.subset(real)
    b = np.array([[r.bias_range, r.bias_scale, r.bias_azimuth] for r in radars])
    x, P = cp.to_common(sub, radars, b)
    times, inv = np.unique(sub.time, return_inverse=True)
    pos, _ = cp.truth_at(traffic, times)
    err = x - pos[sub.aircraft, inv]
    res = nees(err, P)
    lo, hi = res.low, res.high
    assert lo <= res.mean <= hi, (res.mean, res.interval, res.count)
    # the coverage, range scale and detection model: per radar the detected share of the
    # covered (aircraft, scan) pairs is P_D within a 99.9 % binomial interval
    for i, r in enumerate(radars):
        k = np.unique(det.scan[det.radar == i])
        t = r.phase + r.period * k
        p, valid = cp.truth_at(traffic, t)
        d = (p[valid] - r.enu) @ cp.local_rotation(r).T
        rr = np.linalg.norm(d, axis=1)
        covered = (rr <= r.max_range) & (np.arcsin(d[:, 2] / rr) >= r.min_elevation)
        n = int(covered.sum())
        hits = int(np.sum((det.radar == i) & (det.aircraft >= 0)))
        lo_, hi_ = stats.binom.interval(0.999, n, r.p_detect)
        assert lo_ <= hits <= hi_


def test_realistic_reproducible_and_seeded(traffic):
    radars = cp.realistic_radars()
    a = cp.simulate_detections(traffic, radars, duration=60.0, rng=5)
    b = cp.simulate_detections(traffic, radars, duration=60.0, rng=np.random.default_rng(5))
    c = cp.simulate_detections(traffic, radars, duration=60.0, rng=6)
    assert np.array_equal(a.polar, b.polar) and np.array_equal(a.aircraft, b.aircraft)
    assert not np.array_equal(a.polar[:20], c.polar[:20])


@pytest.mark.parametrize(("field", "value", "match"), [
    ("period", 0.0, r"`radars\[1\]\.period`.*> 0"),
    ("period", -3.0, r"`radars\[1\]\.period`"),
    ("period", math.nan, r"`radars\[1\]\.period`.*finite"),
    ("phase", 8.0, r"`radars\[1\]\.phase`.*< its period \(8\.0 s\).*8\.0"),
    ("phase", -0.5, r"`radars\[1\]\.phase`"),
    ("bias_scale", 0.7, r"`radars\[1\]\.bias_scale`"),
])
def test_bad_radar_timing_is_refused_by_name(traffic, field, value, match):
    radars = list(cp.realistic_radars())
    radars[1] = dataclasses.replace(radars[1], **{field: value})
    with pytest.raises(ValueError, match=match):
        cp.simulate_detections(traffic, radars, duration=60.0)


def test_bad_input_is_refused_by_name(traffic, realistic):
    radars, det = realistic
    with pytest.raises(TypeError, match="`radars\\[0\\]\\.period`"):
        cp.simulate_detections(traffic, [dataclasses.replace(radars[0], period="8"),
                                         *radars[1:]])
    with pytest.raises(ValueError, match="`mode`"):
        cp.simulate_detections(traffic, radars, mode="fast")
    with pytest.raises(ValueError, match="`duration`"):
        cp.simulate_detections(traffic, radars, duration=0.0)
    with pytest.raises(TypeError, match="`traffic`"):
        cp.simulate_detections(None, radars)
    with pytest.raises(TypeError, match="`detections`"):
        cp.to_common("reports", radars)
    with pytest.raises(ValueError, match=r"`biases`.*\(3, 3\)"):
        cp.to_common(det, radars, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="`biases`"):
        cp.to_common(det, radars, np.full((3, 3), np.nan))
    with pytest.raises(ValueError, match="`detections` name radar 2"):
        cp.to_common(det, radars[:2])
    with pytest.raises(ValueError, match="`radars\\[0\\]\\.clutter_rate`"):
        cp.simulate_detections(traffic, cp.realistic_radars(clutter_rate=1e9), duration=60.0)


# ----------------------------------------------------------------------------- registration
def test_registration_estimates_offset_scale_and_azimuth_without_bias(traffic):
    """Over seeds, each radar's three biases are estimated without bias, within the stated
    bound (the bound is conservative: the aligned reports are less noisy than stated)."""
    radars = cp.realistic_radars()
    true = np.array([r.biases for r in radars])
    z = []
    for seed in range(10):
        det = cp.simulate_detections(traffic, radars, duration=600.0, rng=100 + seed)
        est = cp.register_detections(det, radars)
        assert est.biases.shape == (3, 3)
        z.append((est.biases - true) / est.crlb)
    z = np.array(z)                                              # (10, 3, 3)
    assert np.all(np.abs(z) < 4.0)
    # mean standardised error over 10 seeds: standard error at most 1/sqrt(10)
    assert np.all(np.abs(z.mean(axis=0)) < 4.0 / math.sqrt(10))
    assert np.all(z.std(axis=0, ddof=1) < 1.6)


def test_registration_estimate_makes_to_common_consistent(traffic):
    radars = cp.realistic_radars()
    det = cp.simulate_detections(traffic, radars, start=0.0, duration=900.0, rng=11)
    est = cp.register_detections(det, radars, warmup=300.0)
    late = det.subset((det.time >= 300.0) & (det.aircraft >= 0))
    times, inv = np.unique(late.time, return_inverse=True)
    pos, _ = cp.truth_at(traffic, times)
    truth = pos[late.aircraft, inv]
    raw = nees(cp.to_common(late, radars)[0] - truth, cp.to_common(late, radars)[1]).mean
    x, P = cp.to_common(late, radars, est.biases)
    fixed = nees(x - truth, P).mean
    assert raw > 6.0                          # the biases dominate the noise
    assert fixed < 3.6                        # corrected to about the noise alone (3)


def test_registration_needs_enough_common_instants(traffic):
    radars = cp.realistic_radars()
    det = cp.simulate_detections(traffic, radars, duration=60.0, rng=0)
    with pytest.raises(ValueError, match=r"`warmup`.*a longer `warmup`"):
        cp.register_detections(det, radars, warmup=5.0)
    with pytest.raises(ValueError, match="`warmup`"):
        cp.register_detections(det, radars, warmup=-1.0)
    with pytest.raises(TypeError, match="`detections`"):
        cp.register_detections(None, radars)


# ----------------------------------------------------------------------------- truth_at
def _bad_step_share(traffic, fresh_only):
    """Share of 10-s steps (both ends valid) whose horizontal move is outside 0.5–1.5 times
    what the mean ground speed of the records allows."""
    times = np.arange(0.0, 3600.0, 10.0)
    pos, ok = cp.truth_at(traffic, times, fresh_only=fresh_only)
    speed = np.zeros(ok.shape)
    for a in range(len(traffic.icao24)):
        m = traffic.aircraft == a
        speed[a] = np.interp(times, traffic.t[m], traffic.speed[m])
    both = ok[:, 1:] & ok[:, :-1]
    move = np.linalg.norm(np.diff(pos[..., :2], axis=1), axis=-1)[both]
    allowed = 0.5 * (speed[:, 1:] + speed[:, :-1])[both] * _KT * 10.0
    ratio = move / allowed
    return float(np.mean((ratio < 0.5) | (ratio > 1.5))), int(both.sum())


def test_fresh_records_remove_the_stop_and_jump_steps(traffic):
    before, n_before = _bad_step_share(traffic, False)
    after, n_after = _bad_step_share(traffic, True)
    # all records interpolated reproduce the capstone's scan truth and its 1.8 %
    tr = cp.truth_scans(traffic, duration=3600.0)
    rows = set(zip(tr.aircraft.tolist(), tr.scan.tolist(), strict=True))
    assert n_before == sum((a, s + 1) in rows for a, s in rows)
    assert 0.015 < before < 0.021
    # the freshness rule: at most one step in ten thousand is left, and the truth loses
    # at most 1 % of its steps to unbridgeable gaps
    assert after <= 1e-4
    assert n_after >= 0.99 * n_before


def test_truth_at_equals_truth_scans_without_the_rule(traffic):
    """fresh_only=False is the capstone's interpolation: the same positions at scan times."""
    tr = cp.truth_scans(traffic, period=10.0, start=0.0, duration=600.0)
    pos, ok = cp.truth_at(traffic, tr.times, fresh_only=False)
    assert ok.sum() == tr.scan.size
    assert np.allclose(pos[tr.aircraft, tr.scan], tr.position, rtol=0, atol=1e-6)


def test_truth_at_velocity_is_the_segment_slope(tmp_path):
    head = ",".join(cp.COLUMNS)
    rows = ["0,aaaaaa,A,4680000,820000,35000,450,0", "10,aaaaaa,A,4682083,820000,35000,450,0",
            "20,aaaaaa,A,4682083,820000,35000,450,0",          # stale: a repeated position
            "30,aaaaaa,A,4686250,820000,35000,450,0", "100,aaaaaa,A,4700830,820000,35000,450,0"]
    p = tmp_path / "stale.csv.gz"
    p.write_bytes(gzip.compress(("\n".join([head, *rows]) + "\n").encode()))
    tr = cp.load_traffic(p)
    times = [0.0, 5.0, 20.0, 25.0, 30.0, 60.0, 100.0]
    pos, ok, vel = cp.truth_at(tr, times, return_velocity=True)
    assert ok[0].tolist() == [True, True, True, True, True, False, True]
    enu = geodetic_to_enu(np.array([46.8, 46.82083, 46.8625]), 8.2, 35000 * 0.3048,
                          origin=cp.ORIGIN)
    # the stale record at 20 s is skipped: 20 s lies between the fresh 10 s and 30 s
    assert pos[0, 2] == pytest.approx(0.5 * (enu[1] + enu[2]), abs=1e-6)
    assert vel[0, 2] == pytest.approx((enu[2] - enu[1]) / 20.0, abs=1e-9)
    assert vel[0, 1] == pytest.approx((enu[1] - enu[0]) / 10.0, abs=1e-9)
    # 450 kt = 231.5 m/s: the fresh segment's speed is what the ground speed allows
    assert np.linalg.norm(vel[0, 2, :2]) == pytest.approx(450 * _KT, rel=0.02)
    # without the rule the stale record stays: a stop, then a jump
    pos_all, _ = cp.truth_at(tr, times, fresh_only=False)
    assert pos_all[0, 2] == pytest.approx(enu[1], abs=1e-6)
    assert np.isnan(pos[0, 5]).all() and np.isnan(vel[0, 6]).all()   # gap; a lone record


@pytest.mark.parametrize(("kw", "exc", "match"), [
    (dict(times=[[0.0]]), ValueError, "`times`"),
    (dict(times=[np.nan]), ValueError, "`times`"),
    (dict(times=["a"]), TypeError, "`times`"),
    (dict(times=[0.0], max_gap=0.0), ValueError, "`max_gap`"),
    (dict(times=np.zeros(10**7)), ValueError, "`times`.*windows"),
])
def test_truth_at_bad_input(traffic, kw, exc, match):
    with pytest.raises(exc, match=match):
        cp.truth_at(traffic, **kw)
    with pytest.raises(TypeError, match="`traffic`"):
        cp.truth_at("traffic", [0.0])
