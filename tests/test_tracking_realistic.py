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
from radarfusion_ref.engine.metrics import gospa, nees

_KT = 1852.0 / 3600.0


@pytest.fixture(scope="module")
def traffic():
    return cp.load_traffic()


@pytest.fixture(scope="module")
def realistic(traffic):
    radars = cp.realistic_radars()
    return radars, cp.simulate_detections(traffic, radars, start=600.0, duration=240.0, rng=3)


# ----------------------------------------------------------------------------- the tuning hour
def test_tuning_hour_is_committed_and_distinct():
    import hashlib
    raw = cp.TUNING_FILE.read_bytes()
    assert hashlib.sha256(raw).hexdigest() == (
        "3f0708558ee935a9d64ed7a6e95f6a2a1a9cbc1a56e0d27b52644176bbd79f01")
    tune, scored = cp.load_traffic(hour="tuning"), cp.load_traffic()
    assert len(tune.icao24) == 128 and tune.t.size == 11_491
    assert len(tune.icao24) < len(scored.icao24)             # the second busiest hour
    total = sum(f.stat().st_size for f in
                __import__("pathlib").Path(str(cp.DATA_FILE)).parent.iterdir()
                if f.is_file())
    assert total < 1_000_000                                  # all the data under 1 MB
    with pytest.raises(ValueError, match="`hour`"):
        cp.load_traffic(hour="noon")


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


# ----------------------------------------------------------------------------- evaluation
from radarfusion_ref import tracking as tk  # noqa: E402


def _brute_gospa_p(x, y, c, p):
    """min over partial matchings of sum d^p over pairs + c^p/2 per point left out."""
    import itertools
    n, k = len(x), len(y)
    best = math.inf
    for r in range(min(n, k) + 1):
        for rows in itertools.combinations(range(n), r):
            for cols in itertools.permutations(range(k), r):
                d = sum(min(np.linalg.norm(np.subtract(x[i], y[j])), c) ** p
                        for i, j in zip(rows, cols, strict=True))
                best = min(best, d + (n - r + k - r) * c**p / 2)
    return best


@pytest.mark.parametrize("seed", range(6))
def test_gospa_pairs_are_an_optimal_assignment(seed):
    gen = np.random.default_rng(seed)
    x = gen.uniform(0, 10, (gen.integers(0, 5), 2))
    y = gen.uniform(0, 10, (gen.integers(0, 5), 2))
    c, p = 3.0, float(gen.choice([1.0, 2.0]))
    g = gospa(x, y, c=c, p=p)
    i, j = g.pairs.T
    assert g.pairs.shape == (g.n_assigned, 2)
    assert np.unique(i).size == i.size and np.unique(j).size == j.size   # one to one
    d = np.linalg.norm(x[i] - y[j], axis=1) if i.size else np.zeros(0)
    assert np.all(d < c)
    cost = np.sum(d**p) + (len(x) - i.size + len(y) - i.size) * c**p / 2
    assert cost == pytest.approx(_brute_gospa_p(x, y, c, p), rel=1e-9, abs=1e-12)


def _two_aircraft(tmp_path):
    """Aircraft A flies east from 0 s, B north from 20 s, records every 10 s for 100 s."""
    head = ",".join(cp.COLUMNS)
    rows = []
    for k in range(11):
        rows.append(f"{10 * k},aaaaaa,A,4680000,{820000 + 3035 * k},35000,450,90")
    for k in range(2, 11):
        rows.append(f"{10 * k},bbbbbb,B,{4690000 + 2083 * (k - 2)},830000,35000,450,0")
    path = tmp_path / "two.csv.gz"
    path.write_bytes(gzip.compress(("\n".join([head, *rows]) + "\n").encode()))
    return cp.load_traffic(path)


def _history(rows):
    """TrackHistory from (track, time, position (3,), velocity (3,), variance) rows."""
    rows = sorted(rows, key=lambda r: (r[1], r[0]))
    return tk.TrackHistory(
        track=np.array([r[0] for r in rows]), time=np.array([float(r[1]) for r in rows]),
        state=np.array([np.concatenate([r[2], r[3]]) for r in rows]),
        covariance=np.array([np.diag([r[4]] * 3 + [1.0] * 3) for r in rows]),
        confirmed=np.ones(len(rows), dtype=bool))


def test_evaluation_on_a_hand_made_scene(tmp_path):
    """Track 0 follows A to 50 s, track 1 takes A over from 60 s (one switch), track 2
    follows B from 40 s, track 3 is 50 km from everything (false). Rows sit 10 m east of
    the truth with variance 100 m^2 per axis: each row's NEES is exactly 1."""
    traffic = _two_aircraft(tmp_path)
    times = np.arange(0.0, 101.0, 10.0)
    pos, ok, vel = cp.truth_at(traffic, times, return_velocity=True)
    off = np.array([10.0, 0.0, 0.0])
    rows = []
    for j, t in enumerate(times):
        rows.append((0 if t <= 50 else 1, t, pos[0, j] + off, vel[0, j], 100.0))
        if t >= 40:
            rows.append((2, t, pos[1, j] + off, vel[1, j], 100.0))
        if t >= 30:
            rows.append((3, t, np.array([50e3, 50e3, 10e3]), np.zeros(3), 100.0))
    h = _history(rows)
    m = tk.evaluate_tracks_over_time(h, traffic, times=times, c=2000.0, max_age=5.0)
    assert m.switches == 1
    assert m.tracks_per_aircraft == pytest.approx((2 + 1) / 2)
    assert m.n_tracks == 4 and m.false_tracks == 1
    assert m.false_tracks_per_hour == pytest.approx(1 / (100 / 3600))
    assert m.latency.tolist() == [0.0, 20.0]                 # B seen from 20 s, tracked at 40
    assert m.nees.mean == pytest.approx(1.0) and m.nees.count == len(h) - 8
    # GOSPA at every instant by brute force over the present estimates
    for j, t in enumerate(times):
        x = pos[ok[:, j], j]
        y = [r[2] for r in rows if r[1] == t]
        want = _brute_gospa_p(x, y, 2000.0, 2.0) ** 0.5
        assert m.gospa[j] == pytest.approx(want, rel=1e-9)
    assert m.track_of[0].tolist() == [0] * 6 + [1] * 5


def test_tracks_are_moved_on_and_forgotten_after_max_age(tmp_path):
    traffic = _two_aircraft(tmp_path)
    times = np.arange(0.0, 101.0, 10.0)
    pos, _, vel = cp.truth_at(traffic, times, return_velocity=True)
    # one row at 0 s: moved on at its velocity it stays on A for max_age, then is gone
    h = _history([(0, 0.0, pos[0, 0], vel[0, 0], 100.0)])
    m = tk.evaluate_tracks_over_time(h, traffic, times=times, max_age=25.0)
    assert m.track_of[0].tolist() == [0, 0, 0] + [-1] * 8
    assert m.localisation[:3] == pytest.approx([0.0, 0.0, 0.0], abs=25.0)     # m^2


def test_summarise_runs_is_the_student_t_interval(tmp_path):
    traffic = _two_aircraft(tmp_path)
    times = np.arange(0.0, 101.0, 10.0)
    pos, _, vel = cp.truth_at(traffic, times, return_velocity=True)
    runs = []
    for shift in (5.0, 20.0, 40.0):
        h = _history([(0, t, pos[0, j] + [shift, 0, 0], vel[0, j], 100.0)
                      for j, t in enumerate(times)])
        runs.append(tk.evaluate_tracks_over_time(h, traffic, times=times))
    s = tk.summarise_runs(runs)
    g = [r.mean_gospa for r in runs]
    lo, hi = stats.t.interval(0.95, df=2, loc=np.mean(g), scale=stats.sem(g))
    assert (s["mean_gospa"].low, s["mean_gospa"].high) == pytest.approx((lo, hi))
    assert s["nees"].estimate == pytest.approx(np.mean([(d / 10.0) ** 2
                                                         for d in (5.0, 20.0, 40.0)]))
    with pytest.raises(ValueError, match="`runs`"):
        tk.summarise_runs(runs[:1])


def test_load_scored_runs_is_the_student_t_interval_per_group(tmp_path):
    table = tmp_path / "runs.csv"
    table.write_text("tracker,seed,threshold_name,threshold,gospa,false\n"
                     "b,1,alpha,0.1,9.0,2\nb,2,alpha,0.1,10.0,1\nb,3,alpha,0.1,14.0,0\n"
                     "a,1,alpha,0.1,1.0,0\na,2,alpha,0.1,2.0,0\n"
                     "a,1,alpha,0.2,5.0,1\na,2,alpha,0.2,6.0,3\n", encoding="utf-8")
    runs = tk.load_scored_runs(table, by=("tracker", "threshold"))
    assert list(runs) == [("b", "0.1"), ("a", "0.1"), ("a", "0.2")]     # the table's order
    assert set(runs["b", "0.1"]) == {"gospa", "false"}     # labels and the seed left out
    g = [9.0, 10.0, 14.0]
    lo, hi = stats.t.interval(0.95, df=2, loc=np.mean(g), scale=stats.sem(g))
    b = runs["b", "0.1"]["gospa"]
    assert (b.estimate, b.low, b.high, b.trials) == pytest.approx((11.0, lo, hi, 3))
    assert runs["a", "0.2"]["false"].estimate == pytest.approx(2.0)
    assert tk.load_scored_runs(str(table), by=("tracker", "threshold")).keys() == runs.keys()
    with pytest.raises(ValueError, match=r"`path`: 'alpha' must have at least two rows, one "
                                         r"per seed; received seeds \['1', '2', '3', '1'"):
        tk.load_scored_runs(table, by="threshold_name")


@pytest.mark.parametrize(("text", "kw", "exc", "match"), [
    (None, dict(), ValueError, "`path` must name an existing CSV file"),
    ("tracker,seed,g\na,1,1\n", dict(), ValueError, "'a' must have at least two rows"),
    ("tracker,seed,g\na,1,1\na,1,2\n", dict(), ValueError, r"received seeds \['1', '1'\]"),
    ("tracker,g\na,1\na,2\n", dict(), ValueError, r"lacks \['seed'\]"),
    ("tracker,seed,g\na,1,1\na,2,nan\n", dict(), ValueError, "'g' of 'a' must be finite; "
                                                             "line 3 holds 'nan'"),
    ("tracker,seed,g\na,1,1\na,2,\n", dict(), ValueError, "'g' must be numeric in every "
                                                          "row; line 3 holds ''"),
    ("tracker,seed,g\na,1,1\na,2,2\n", dict(by=["tracker"]), TypeError, "`by`"),
    ("tracker,seed,g\na,1,1\na,2,2\n", dict(by="radar"), ValueError, r"lacks \['radar'\]"),
])
def test_load_scored_runs_bad_input(tmp_path, text, kw, exc, match):
    path = tmp_path / "t.csv"
    if text is not None:
        path.write_text(text, encoding="utf-8")
    with pytest.raises(exc, match=match):
        tk.load_scored_runs(path, **kw)
    with pytest.raises(TypeError, match="`path`"):
        tk.load_scored_runs(3.0)


def test_evaluation_bad_input(tmp_path):
    traffic = _two_aircraft(tmp_path)
    h = _history([(0, 0.0, np.zeros(3), np.zeros(3), 1.0)])
    for kw, exc, match in [
        (dict(times=[0.0]), ValueError, "`times`"),
        (dict(times=[10.0, 0.0]), ValueError, "`times`"),
        (dict(times=[0.0, 10.0], c=0.0), ValueError, "`c`"),
        (dict(times=[0.0, 10.0], p=0.5), ValueError, "`p`"),
        (dict(times=[0.0, 10.0], max_age=-1.0), ValueError, "`max_age`"),
        (dict(times=[0.0, 10.0], radars="radars"), TypeError, "`radars`"),
    ]:
        with pytest.raises(exc, match=match):
            tk.evaluate_tracks_over_time(h, traffic, **kw)
    with pytest.raises(TypeError, match="`history`"):
        tk.evaluate_tracks_over_time(None, traffic, times=[0.0, 1.0])
    times = np.arange(0.0, 101.0, 10.0)
    pos, _, vel = cp.truth_at(traffic, times, return_velocity=True)
    bad = _history([(0, t, pos[0, j], vel[0, j], 100.0 if j else -1.0)
                    for j, t in enumerate(times)])
    with pytest.raises(ValueError, match=r"^`history`: the position covariances.*positive"):
        tk.evaluate_tracks_over_time(bad, traffic, times=times)
    with pytest.raises(TypeError, match="`traffic`"):
        tk.evaluate_tracks_over_time(h, None, times=[0.0, 1.0])


# ----------------------------------------------------------------------------- Stone Soup
def test_stonesoup_bad_input_and_missing_package(monkeypatch):
    t = np.array([0.0, 1.0])
    x = np.zeros((2, 3))
    P = np.broadcast_to(np.eye(3), (2, 3, 3))
    r = np.array([0, 1])
    with pytest.raises(ValueError, match=r"`time` must be in time order.*time\[0\] = 1\.0 >"):
        tk.stonesoup_track(t[::-1], x, P, r, r)
    with pytest.raises(ValueError, match="`tracker`"):
        tk.stonesoup_track(t, x, P, r, r, tracker="mht")
    with pytest.raises(TypeError, match="`settings`"):
        tk.stonesoup_track(t, x, P, r, r, settings={"q": 1.0})
    with pytest.raises(ValueError, match="`position`"):
        tk.stonesoup_track(t, x[:1], P, r, r)
    with pytest.raises(ValueError, match="`position`"):
        tk.stonesoup_track(t, np.full((2, 3), np.nan), P, r, r)
    with pytest.raises(ValueError, match="`scan`"):
        tk.stonesoup_track(t, x, P, r, [0.5, 1.5])
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="`hold`"):
            tk.stonesoup_track(t, x, P, r, r, hold=bad)
    for bad in ("1.5", True, [1.5]):
        with pytest.raises(TypeError, match=r"`hold` must be a number of revisits"):
            tk.stonesoup_track(t, x, P, r, r, hold=bad)
    monkeypatch.setitem(__import__("sys").modules, "stonesoup", None)
    with pytest.raises(ImportError,
                       match=r"stonesoup_track needs stonesoup.*'radarfusion-ref\[stonesoup\]'"):
        tk.stonesoup_track(t, x, P, r, r)


def test_stonesoup_state_order_and_a_lone_target():
    """One noise-free target at constant velocity seen every second: Stone Soup's GNN
    track, mapped to [x y z vx vy vz], converges on the true state."""
    v = np.array([200.0, -100.0, 5.0])
    t = np.arange(0.0, 30.0)
    x = np.array([1e4, 2e4, 9e3]) + t[:, None] * v
    P = np.broadcast_to(np.diag([50.0**2] * 3), (t.size, 3, 3))
    h = tk.stonesoup_track(t, x, P, np.zeros(t.size, dtype=np.int64),
                           np.arange(t.size), settings=tk.TrackerSettings(m=3))
    assert np.unique(h.track).size == 1 and h.n_confirmed == 1
    assert not h.confirmed[:2].any() and h.confirmed[2:].all()      # released at m = 3
    assert np.allclose(h.time, t)
    assert np.allclose(h.state[-1, :3], x[-1], atol=20.0)
    assert np.allclose(h.state[-1, 3:], v, atol=5.0)
    assert h.initiated == 1
    np.testing.assert_array_equal(h.covariance, np.swapaxes(h.covariance, 1, 2))


def test_stonesoup_hold_is_the_initiators_patience_in_revisits():
    """One radar scanning every second sees a target at 0 and 1 s, misses it at 2 and 3 s
    (a far-away report keeps the scans going), then sees it from 4 s on; min_points 3.
    Stone Soup's initiator forgets a tentative track with no update in the last `hold`
    revisits: 2.5 s keeps the track started at 0 s (confirmed at its third update, 4 s);
    1.5 s (the default rule) drops it at 3 s, and the track confirmed is the one started
    at 4 s (confirmed at 6 s)."""
    v = np.array([200.0, -100.0, 0.0])
    t = np.arange(0.0, 12.0)
    x = np.array([1e4, 2e4, 9e3]) + t[:, None] * v
    away = np.isin(t, (2.0, 3.0))
    x[away] = [-5e5, -5e5, 9e3]
    P = np.broadcast_to(np.diag([50.0**2] * 3), (t.size, 3, 3))
    args = (t, x, P, np.zeros(t.size, dtype=np.int64), np.arange(t.size))
    s = tk.TrackerSettings(m=3, max_coast=10.0)
    first_confirmed = {}
    for hold in (None, 1.5, 2.5):
        h = tk.stonesoup_track(*args, settings=s, hold=hold)
        assert h.n_confirmed == 1, hold
        ident = h.track[h.confirmed][0]
        first_confirmed[hold] = (h.time[h.track == ident].min(),
                                 h.time[(h.track == ident) & h.confirmed].min())
    assert first_confirmed[2.5] == (0.0, 4.0)
    assert first_confirmed[1.5] == first_confirmed[None] == (4.0, 6.0)


@pytest.fixture(scope="module")
def side_by_side(traffic):
    """40 s of the realistic radars (registered on the first 300 s), tracked by ours and by
    Stone Soup's GNN and JPDA on the same converted reports; scored every 2 s from 15 s."""
    radars = cp.realistic_radars()
    det = cp.simulate_detections(traffic, radars, start=600.0, duration=300.0, rng=1)
    est = cp.register_detections(det, radars, warmup=300.0)
    det = det.subset(det.time < 640.0)
    x, P = cp.to_common(det, radars, est.biases)
    times = np.arange(615.0, 640.0, 2.0)
    out = {"ours": tk.track_reports(det.time, x, P, det.radar, det.scan,
                                    settings=tk.TrackerSettings())}
    for name in ("gnn", "jpda"):
        out[name] = tk.stonesoup_track(det.time, x, P, det.radar, det.scan, tracker=name)
    return {k: tk.evaluate_tracks_over_time(h, traffic, times=times, radars=radars)
            for k, h in out.items()}


def test_side_by_side_with_stone_soup_on_a_short_window(side_by_side):
    for name, m in side_by_side.items():
        assert m.tracks_per_aircraft <= 1.1, name
        assert m.false_tracks <= 1, name
        assert m.switches <= 1, name
        assert 2.0 < m.nees.mean < 4.5, name                 # position NEES, 3 dof
        paired = np.sum(m.track_of >= 0, axis=0)
        missed = m.missed / (m.c**m.p / 2)                   # c^p/2 per missed aircraft
        assert np.all(paired / (paired + missed) > 0.8), name
    best = min(side_by_side["gnn"].mean_gospa, side_by_side["jpda"].mean_gospa)
    assert side_by_side["ours"].mean_gospa <= 1.05 * best
    assert abs(side_by_side["ours"].n_tracks - side_by_side["gnn"].n_tracks) <= 3


def test_stonesoup_kept_transition_matrices_change_nothing_but_the_work(traffic, monkeypatch):
    """The adapter's combined model that keeps F(dt) and Q(dt) per interval gives the very
    same tracks, bit for bit, as Stone Soup's own CombinedLinearGaussianTransitionModel
    (GNN and JPDA, a 20 s window of the realistic radars), and it does keep them."""
    from radarfusion_ref.tracking import stonesoup as ss

    radars = cp.realistic_radars()
    det = cp.simulate_detections(traffic, radars, start=1200.0, duration=20.0, rng=4)
    x, P = cp.to_common(det, radars, np.array([r.biases for r in radars]))
    made = []
    original = ss._transition_model

    def spy(settings, cached=True):
        made.append(original(settings, cached=cached))
        return made[-1]

    for name in ("gnn", "jpda"):
        monkeypatch.setattr(ss, "_transition_model", spy)
        a = tk.stonesoup_track(det.time, x, P, det.radar, det.scan, tracker=name)
        assert len(made[-1].__dict__.get("_kept_matrices", {})) > 2      # it keeps them
        monkeypatch.setattr(ss, "_transition_model",
                            lambda settings: original(settings, cached=False))
        b = tk.stonesoup_track(det.time, x, P, det.radar, det.scan, tracker=name)
        assert len(a) == len(b) > 0
        for f in ("track", "time", "state", "covariance", "confirmed"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f), err_msg=f)


def test_stonesoup_pregate_changes_nothing_but_the_work(traffic):
    """Dropping detections outside the gate before Stone Soup's hypothesiser gives the very
    same tracks as Stone Soup's configuration alone."""
    radars = cp.realistic_radars()
    det = cp.simulate_detections(traffic, radars, start=1200.0, duration=20.0, rng=4)
    x, P = cp.to_common(det, radars, np.array([r.biases for r in radars]))
    for name in ("gnn", "jpda"):
        a, b = (tk.stonesoup_track(det.time, x, P, det.radar, det.scan, tracker=name,
                                   pregate=pg) for pg in (True, False))
        assert len(a) == len(b) > 0
        for f in ("track", "time", "state", "covariance", "confirmed"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f), err_msg=f)
