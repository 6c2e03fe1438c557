"""Tracking one's own detections: any radar ids, reading and exporting a history, scoring
against a truth given as arrays, and the same decisions in any length unit.

The scene: three aircraft at constant velocity, two radars (every 4 s and every 5 s)
reporting each with probability 0.9, and uniform clutter. Reference values come from
closed forms or brute force typed in here, never from the function under test.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import tracemalloc
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from radarfusion_ref import tracking as trk
from radarfusion_ref.engine.errors import RadarFusionWarning

SIGMA = np.array([50.0, 50.0, 100.0])                     # m, each report's error
BOX = np.array([[-3e4, 3e4], [-3e4, 3e4], [0.0, 1.2e4]])  # m, where clutter falls
P0 = np.array([[-20e3, -10e3, 8e3], [-20e3, 10e3, 9e3], [0.0, -20e3, 10e3]])
V = np.array([[150.0, 20.0, 0.0], [140.0, -30.0, 0.0], [10.0, 130.0, 0.0]])
RADARS = ((10**9, 4.0, 0.0), (10**9 + 7, 5.0, 1.0))      # id, period (s), first scan (s)


def own_scene(*, rng, duration=300.0, clutter=5.0, radars=RADARS):
    """Reports (time, position, covariance, radar, scan) in metres and their truth
    (aircraft index, -1 for clutter)."""
    rng = np.random.default_rng(rng)
    t_, z_, r_, s_, a_ = [], [], [], [], []
    for rid, period, first in radars:
        for k, t in enumerate(np.arange(first, duration, period)):
            seen = rng.random(3) < 0.9
            n_c = rng.poisson(clutter)
            z = np.concatenate([P0[seen] + V[seen] * t
                                + SIGMA * rng.standard_normal((int(seen.sum()), 3)),
                                rng.uniform(BOX[:, 0], BOX[:, 1], (n_c, 3))])
            t_.append(np.full(len(z), t))
            z_.append(z)
            r_.append(np.full(len(z), rid, np.int64))
            s_.append(np.full(len(z), k, np.int64))
            a_.append(np.r_[np.flatnonzero(seen), np.full(n_c, -1)])
    t, z = np.concatenate(t_), np.concatenate(z_)
    R = np.broadcast_to(np.diag(SIGMA**2), (t.size, 3, 3)).copy()
    return (t, z, R, np.concatenate(r_), np.concatenate(s_)), np.concatenate(a_)


#: The scene's own settings: its clutter density (5 false reports per scan in the box),
#: everything else the defaults.
CLUTTER_DENSITY = 5.0 / np.prod(np.diff(BOX, axis=1))            # per m³ per scan
OWN = trk.TrackerSettings(clutter_density=CLUTTER_DENSITY)


def _same_history(a, b, scale=1.0):
    """Same rows, identities and decisions; states and covariances scaled."""
    assert a.track.tolist() == b.track.tolist()
    assert a.time.tolist() == b.time.tolist()
    assert a.confirmed.tolist() == b.confirmed.tolist()
    assert a.initiated == b.initiated
    s = np.r_[np.full(6, scale)]
    np.testing.assert_allclose(b.state * s, a.state, rtol=1e-6, atol=1e-6)
    np.testing.assert_allclose(b.covariance * scale**2, a.covariance, rtol=1e-6,
                               atol=1e-6)


# --------------------------------------------------------------------------- radar ids
def test_radar_ids_of_any_value_are_renumbered_without_memory():
    rep, _ = own_scene(rng=1, duration=120.0)
    small = (*rep[:3], np.where(rep[3] == 10**9, 0, 1), rep[4])
    tracemalloc.start()
    try:
        h = trk.track_reports(*rep, settings=OWN)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 50e6                     # it allocated 22 GiB: arrays indexed by id
    _same_history(trk.track_reports(*small, settings=OWN), h)


def test_radar_1e9_alone():
    rep, _ = own_scene(rng=2, duration=60.0, radars=((10**9, 4.0, 0.0),))
    h = trk.track_reports(*rep, settings=OWN)
    h0 = trk.track_reports(*rep[:3], np.zeros_like(rep[3]), rep[4], settings=OWN)
    _same_history(h0, h)
    for arch in (lambda r: trk.fuse_then_track(*r, window=4.0, settings=OWN),
                 lambda r: trk.track_then_fuse(*r, period=4.0, settings=OWN)):
        a, b = arch(rep), arch((*rep[:3], np.zeros_like(rep[3]), rep[4]))
        _same_history(b, a)


# --------------------------------------------------------------------------- the scene
def test_own_scene_three_aircraft_three_tracks():
    """With the scene's clutter density (stated above) each aircraft gets exactly one
    confirmed track, and each track follows one aircraft."""
    rep, truth = own_scene(rng=1)
    h = trk.track_reports(*rep, settings=OWN)
    assert h.n_confirmed == 3
    t, z = rep[0], rep[1]
    owners = set()
    for k in np.unique(h.track[h.confirmed]):
        sel = (h.track == k) & h.confirmed
        lab = [truth[np.flatnonzero(t == tt)[np.argmin(np.linalg.norm(
            z[t == tt] - x, axis=1))]] for tt, x in zip(h.time[sel], h.state[sel, :3],
                                                        strict=True)]
        assert len(set(lab)) == 1 and lab[0] >= 0
        owners.add(lab[0])
    assert owners == {0, 1, 2}


def test_default_clutter_density_is_the_capstone_airspace_not_this_scene():
    """The defaults assume ten false reports per scan in a 220 km coverage; this scene
    has 5 in a 60 km box (11.6 times denser), and the defaults then confirm clutter."""
    rep, _ = own_scene(rng=1)
    assert CLUTTER_DENSITY / trk.TrackerSettings().clutter_density > 10
    assert trk.track_reports(*rep).n_confirmed > 3


# --------------------------------------------------------------------------- reading
def _moved_on(rows, t, max_age):
    """Brute force: each track's latest confirmed row at or before t, moved on (of two
    rows at one instant, two radars' scans, the later one in the history)."""
    out = {}
    for k, tk, x in rows:
        if tk <= t and t - tk <= max_age and (k not in out or out[k][0] <= tk):
            out[k] = (tk, x)
    return {k: np.r_[x[:3] + (t - tk) * x[3:], x[3:]] for k, (tk, x) in out.items()}


def test_tracks_at_is_the_latest_row_moved_on():
    rep, _ = own_scene(rng=3, duration=100.0)
    h = trk.track_reports(*rep, settings=OWN)
    times = np.linspace(-5.0, 130.0, 41)
    s = trk.tracks_at(h, times, max_age=12.0)
    rows = [(int(k), float(tk), x) for k, tk, x, c in
            zip(h.track, h.time, h.state, h.confirmed, strict=True) if c]
    assert s.track.tolist() == sorted({r[0] for r in rows})
    for j, t in enumerate(times):
        want = _moved_on(rows, t, 12.0)
        assert set(s.track[s.present[:, j]].tolist()) == set(want)
        for k, x in want.items():
            np.testing.assert_allclose(s.state[s.track == k][0, j], x, rtol=1e-12)
    assert "present" in repr(s) and len(repr(s)) < 100


def test_tracks_at_refuses_by_name():
    rep, _ = own_scene(rng=3, duration=30.0)
    h = trk.track_reports(*rep, settings=OWN)
    for kw, exc, name in [(dict(history=None, times=[0.0]), TypeError, "history"),
                          (dict(history=h, times=[2.0, 1.0]), ValueError, "times"),
                          (dict(history=h, times=[]), ValueError, "times"),
                          (dict(history=h, times=[0.0], max_age=0.0), ValueError, "max_age")]:
        with pytest.raises(exc, match=f"`{name}`"):
            trk.tracks_at(**kw)


# --------------------------------------------------------------------------- history
def test_history_repr_is_short_and_dict_is_complete():
    rep, _ = own_scene(rng=1)
    h = trk.track_reports(*rep, settings=OWN)
    assert len(h) > 300 and len(repr(h)) < 120
    assert repr(h).startswith(f"TrackHistory({len(h)} rows, 3 tracks, 3 confirmed")
    d = h.to_dict()
    assert all(isinstance(v, np.ndarray) and v.shape == (len(h),) for v in d.values())
    np.testing.assert_array_equal(np.stack([d[k] for k in ("x", "y", "z", "vx", "vy", "vz")],
                                           axis=1), h.state)
    names = ("x", "y", "z", "vx", "vy", "vz")
    for (i, a), (j, b) in itertools.product(enumerate(names), repeat=2):
        key = f"cov_{a}_{b}" if i <= j else f"cov_{b}_{a}"
        np.testing.assert_array_equal(d[key], h.covariance[:, i, j])
    assert len(d) == 3 + 6 + 21
    d["x"][0] = np.nan                         # a copy: the history is untouched
    assert np.isfinite(h.state[0, 0])
    assert not hasattr(h, "seconds")


# --------------------------------------------------------------------------- scoring
def _brute_gospa(x, y, c, p=2.0):
    n, k = len(x), len(y)
    best = math.inf
    for r in range(min(n, k) + 1):
        for rows in itertools.combinations(range(n), r):
            for cols in itertools.permutations(range(k), r):
                d = sum(min(float(np.linalg.norm(np.subtract(x[i], y[j]))), c) ** p
                        for i, j in zip(rows, cols, strict=True))
                best = min(best, d + (n + k - 2 * r) * c**p / 2)
    return best ** (1 / p)


def test_evaluate_tracks_against_truth_arrays():
    rep, _ = own_scene(rng=1)
    h = trk.track_reports(*rep, settings=OWN)
    tt = np.arange(0.0, 301.0, 10.0)                     # truth every 10 s, ids any ints
    ids = np.array([71, 5, 900])
    truth_t = np.repeat(tt, 3)
    truth_id = np.tile(ids, tt.size)
    truth_p = np.tile(P0, (tt.size, 1)) + truth_t[:, None] * np.tile(V, (tt.size, 1))
    times = np.arange(30.0, 296.0, 7.0)                   # between the samples
    m = trk.evaluate_tracks(h, truth_t, truth_p, truth_id, c=1000.0, times=times)
    assert m.truth_id.tolist() == [5, 71, 900]
    s = trk.tracks_at(h, times)
    for j, t in enumerate(times):
        x = P0 + t * V                                    # closed form, not interpolated
        y = s.state[s.present[:, j], j, :3]
        assert m.gospa[j] == pytest.approx(_brute_gospa(x, y, 1000.0), rel=1e-9)
    assert m.switches == 0 and m.false_tracks == 0 and m.tracks_per_aircraft == 1.0
    assert m.nees is not None and m.nees.count == int(np.sum(h.confirmed & (h.time <= 300)))


def test_evaluate_tracks_is_the_ads_b_path_on_the_same_truth(tmp_path):
    """The ADS-B evaluation is an adapter of the array one: the traffic's truth sampled at
    the evaluation instants and at every row's instant gives the same metrics."""
    from test_tracking_realistic import _history, _two_aircraft

    from radarfusion_ref import capstone as cp
    traffic = _two_aircraft(tmp_path)
    times = np.arange(0.0, 101.0, 10.0)
    pos, ok, vel = cp.truth_at(traffic, times, return_velocity=True)
    rows = [(0 if t <= 50 else 1, t, pos[0, j] + [10.0, 0, 0], vel[0, j], 100.0)
            for j, t in enumerate(times)]
    rows += [(3, t, np.array([50e3, 50e3, 10e3]), np.zeros(3), 100.0) for t in times[3:]]
    h = _history(rows)
    a = trk.evaluate_tracks_over_time(h, traffic, times=times, c=2000.0, max_age=5.0)
    a_, j_ = np.nonzero(ok)
    b = trk.evaluate_tracks(h, times[j_], pos[a_, j_], a_, c=2000.0, times=times,
                            max_age=5.0)
    for f in ("gospa", "localisation", "missed", "false", "track_of", "latency"):
        np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
    assert (a.switches, a.false_tracks, a.n_tracks) == (b.switches, b.false_tracks,
                                                        b.n_tracks) == (1, 1, 3)
    assert a.nees.mean == pytest.approx(b.nees.mean) and a.nees.count == b.nees.count


def test_evaluate_tracks_interpolates_and_refuses_by_name():
    h = trk.TrackHistory(np.array([0]), np.array([10.0]), np.array([[5.0, 0, 0, 0, 0, 0]]),
                         np.eye(6)[None], np.array([True]))
    m = trk.evaluate_tracks(h, [0.0, 20.0], [[0.0, 0, 0], [20.0, 0, 0]], [3, 3], c=100.0,
                            times=[10.0, 20.0], max_age=5.0)
    assert m.gospa[0] == pytest.approx(5.0)               # truth at 10 s: (10, 0, 0)
    good = dict(truth_time=[0.0, 1.0], truth_position=np.zeros((2, 3)), truth_id=[1, 2],
                c=1.0, times=[0.0, 1.0])
    for kw, exc, name in [
        (dict(truth_time=[[0.0, 1.0]]), ValueError, "truth_time"),
        (dict(truth_position=np.zeros((2, 2))), ValueError, "truth_position"),
        (dict(truth_id=[1.0, 2.0]), TypeError, "truth_id"),
        (dict(truth_id=[1, 1], truth_time=[0.0, 0.0]), ValueError, "truth_id"),
        (dict(c=-1.0), ValueError, "c"),
        (dict(times=[0.0]), ValueError, "times"),
        (dict(truth_position=np.full((2, 3), np.nan)), ValueError, "truth_position"),
    ]:
        with pytest.raises(exc, match=f"`{name}`"):
            trk.evaluate_tracks(h, **{**good, **kw})
    with pytest.raises(TypeError, match="`history`"):
        trk.evaluate_tracks(None, **good)


# --------------------------------------------------------------------------- units
def _in_km(rep):
    t, z, R, radar, scan = rep
    return t, z / 1000.0, R / 1e6, radar, scan


SI_FIELDS = {"clutter_density": -3, "q": 2, "speed_max": 1,      # power of the metre
             "q_vertical": 2, "speed_max_vertical": 1}


@given(seed=st.integers(0, 10**6), clutter=st.sampled_from([0.0, 2.0, 8.0]),
       association=st.sampled_from(trk.ASSOCIATIONS),
       confirmation=st.sampled_from(trk.CONFIRMATIONS))
def test_metres_and_kilometres_give_the_same_tracks(seed, clutter, association,
                                                    confirmation):
    """The same scene in m and in km gives the same rows, identities and decisions, the
    states scaled: with `length_unit` = 1000, and with every dimensional setting
    converted by hand (which checks that no constant in metres hides in the tracker)."""
    rep, _ = own_scene(rng=seed, duration=80.0, clutter=clutter)
    si = trk.TrackerSettings(clutter_density=CLUTTER_DENSITY, association=association,
                             confirmation=confirmation)
    h_m = trk.track_reports(*rep, settings=si)
    km = _in_km(rep)
    h_km = trk.track_reports(*km, settings=dataclasses.replace(si, length_unit=1000.0))
    _same_history(h_m, h_km, scale=1000.0)
    by_hand = dataclasses.replace(si, **{f: getattr(si, f) * 1000.0 ** -e
                                         for f, e in SI_FIELDS.items()
                                         if getattr(si, f) is not None})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadarFusionWarning)   # 0.05 "m" reports
        _same_history(h_m, trk.track_reports(*km, settings=by_hand), scale=1000.0)


@pytest.mark.parametrize("motion", [
    {}, {"q_vertical": 2.0, "speed_max_vertical": 15.0},
    {"motion": "imm", "q_vertical": 2.0, "speed_max_vertical": 15.0}],
    ids=["cv", "cv-vertical", "imm-vertical"])
def test_other_architectures_in_kilometres(motion):
    """Architectures (b) and (c) use the motion model in the reports' unit themselves (the
    window's inflation, the prediction to the output instant, the cross-covariance): the
    vertical settings and the IMM's too."""
    rep, _ = own_scene(rng=4, duration=100.0)
    si = trk.TrackerSettings(clutter_density=CLUTTER_DENSITY, **motion)
    km, s_km = _in_km(rep), dataclasses.replace(si, length_unit=1000.0)
    runs = [lambda r, s: trk.track_reports(*r, settings=s),
            lambda r, s: trk.fuse_then_track(*r, window=5.0, settings=s),
            lambda r, s: trk.track_then_fuse(*r, period=5.0, settings=s)]
    if si.motion == "cv":        # Bar-Shalom-Campo needs the constant-velocity gains
        runs.append(lambda r, s: trk.track_then_fuse(*r, period=5.0, settings=s,
                                                     rule="bar_shalom_campo"))
    for run in runs:
        _same_history(run(rep, si), run(km, s_km), scale=1000.0)


def test_vertical_settings_differ_from_the_isotropic_run():
    """The km test above would pass vacuously if the vertical settings were ignored."""
    rep, _ = own_scene(rng=4, duration=100.0)
    iso = trk.TrackerSettings(clutter_density=CLUTTER_DENSITY)
    vert = dataclasses.replace(iso, q_vertical=2.0, speed_max_vertical=15.0)
    for run in (lambda s: trk.fuse_then_track(*rep, window=5.0, settings=s),
                lambda s: trk.track_then_fuse(*rep, period=5.0, settings=s)):
        a, b = run(iso), run(vert)
        assert len(a) and len(b)
        assert a.covariance.shape != b.covariance.shape or not np.allclose(
            a.covariance, b.covariance)


def test_kilometres_without_a_unit_are_warned_of():
    rep, _ = own_scene(rng=1, duration=40.0)
    with pytest.warns(RadarFusionWarning, match=r"0\.0[57].* m.*`length_unit`"):
        trk.track_reports(*_in_km(rep))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RadarFusionWarning)
        trk.track_reports(*rep)                                     # metres: silent
        trk.track_reports(*_in_km(rep), settings=trk.TrackerSettings(length_unit=1e3))


def test_length_unit_refused_by_name():
    for bad, exc in ((0.0, ValueError), (-1.0, ValueError), (np.inf, ValueError),
                     ("km", TypeError)):
        with pytest.raises(exc, match="`length_unit`"):
            trk.TrackerSettings(length_unit=bad)


# --------------------------------------------------------------------------- one M-of-N
@pytest.mark.parametrize(("m", "n", "pattern"), [
    (3, 4, [1, 0, 1, 1, 1, 1]), (2, 3, [1, 0, 0, 1, 1, 1]), (3, 5, [1, 1, 0, 0, 1, 1]),
    (4, 4, [1, 1, 1, 0, 1, 1, 1, 1, 1])])
def test_tracker_confirms_at_the_m_of_n_scan(m, n, pattern):
    """A lone aircraft seen at the scans of `pattern` by one radar, which reports one far
    decoy in every scan that misses it (a scan without reports is no scan): the aircraft's
    track is confirmed at the first update with m hits among the last n scans (a plain
    loop), and no decoy is."""
    scans = np.arange(len(pattern))
    hit = np.array(pattern, bool)
    t = 5.0 * scans
    z = np.c_[100.0 * t, np.zeros(scans.size), np.full(scans.size, 9000.0)]
    z[~hit] = np.c_[-5e4 - 1e4 * scans[~hit], np.full((~hit).sum(), 5e4), np.full((~hit).sum(), 9e3)]
    R = np.tile(np.eye(3) * 100.0, (scans.size, 1, 1))
    h = trk.track_reports(t, z, R, np.zeros(scans.size, np.int64), scans,
                          settings=trk.TrackerSettings(confirmation="m_of_n", m=m, n=n,
                                                       max_coast=100.0))
    first = next(k for k in scans if sum(pattern[max(0, k - n + 1):k + 1]) >= m)
    assert h.n_confirmed == 1 and np.unique(h.track).size == 1
    assert h.time[np.argmax(h.confirmed)] == 5.0 * first


def test_stonesoup_in_kilometres():
    """Stone Soup's tracker takes the same `length_unit`: the same tracks, scaled."""
    pytest.importorskip("stonesoup")
    rep, _ = own_scene(rng=5, duration=60.0, clutter=1.0)
    o = np.lexsort((rep[3], rep[0]))                      # in time order, as it needs
    rep = tuple(a[o] for a in rep)
    si = trk.TrackerSettings(clutter_density=CLUTTER_DENSITY)
    h_m = trk.stonesoup_track(*rep, settings=si)
    h_km = trk.stonesoup_track(*_in_km(rep), settings=dataclasses.replace(si, length_unit=1e3))
    assert h_m.n_confirmed >= 3
    _same_history(h_m, h_km, scale=1000.0)
