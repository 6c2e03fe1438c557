"""Diagnosis: where the continental hour's GOSPA per aircraft comes from, beside the Swiss hour.

Run as ``python benchmarks/diag_continent.py [--scale 10] [--duration 1200] [--seed 2026]
[--max-age 15 25] [--settings default continent] [--no-swiss] [--swiss-single]``. Everything is measured in
this run, one thread per process.

The continental scene, reports and scoring are ``bench_continent.py``'s (``scene``: seed
2026, registration from the first five minutes; truth ``continent.truth_samples`` every 30 s
from 60 s, GOSPA c = 2000 m, p = 2); the Swiss hour is ``bench_tracking.py``'s pipeline
(seed 2018, the scored 11:00 hour, truth in the radars' coverage every 10 s from 60 s). Each
is tracked by ``tracking.track_reports`` with each of ``--settings`` (``default``:
``TrackerSettings()``, tuned on the Swiss tuning hour; ``continent``:
``continent.CONTINENT_SETTINGS``) and scored with each of ``--max-age`` (the age, s, beyond
which a confirmed track's last update no longer stands for it at a scored instant:
``tracking.evaluate_tracks``' `max_age`, 15 s in the benchmarks).

Printed per run:

1. **Parts.** GOSPA per aircraft (the root of the mean over the instants of GOSPA^2 over the
   aircraft in the truth) and its localisation, missed and false parts: each the mean over
   the instants of that part over the aircraft in the truth (so the three sum to the
   square of GOSPA per aircraft), shown as its root (m) and its share (%).
2. **Missed, by cause.** Every (aircraft, instant) of the truth that GOSPA leaves unpaired,
   split by the number of radars whose coverage holds it (1, 2, 3+), by the time since it
   entered coverage (on a 10 s grid: < 60 s, 60-120 s, more), by its height (below 3 km),
   and whether it lies near the coverage's edge (every covering radar at more than 90 % of
   its range, or below 0.5 deg of elevation); each as the share of the truth samples in
   that class that are missed, and the class's contribution to the missed part.
3. **Missed because stale.** Missed samples for which a confirmed track whose last update
   is older than `max_age` (but at most 60 s) would have been closer than c: the track
   exists and is not deleted, only older than the scoring's window.
4. **Tracks per aircraft, split.** Each change of the track paired with an aircraft is a
   *gap* change (the aircraft was unpaired at the instant before: a coverage gap or a
   missed stretch; *outside* if it left every radar's coverage in between) or a direct
   *switch* (paired at the instant before with another track); a switch is a *hand-off*
   if the set of radars covering the aircraft changed between the two instants.
   *Duplicates*: confirmed tracks left unpaired at an instant while closer than c to an
   aircraft (the false part they cost).
   Tracks per aircraft among the aircraft inside coverage in one stretch and in several
   (an aircraft that leaves every radar's coverage and comes back gets a new track).
5. **Localisation.** The root mean square error of the paired tracks by the number of
   covering radars and by the slant range to the nearest covering radar; and the cost per
   truth sample (its squared error if paired, c^2 / 2 if missed: GOSPA per aircraft without
   the false part) by the same classes, so that the two scenes compare in the same
   conditions.
6. **Scored on the covered truth only** (continent): ``bench_continent.score_visible``, the
   same parts with no instant outside every coverage in the truth, and tracks per aircraft
   and per stretch in coverage.

``--swiss-single`` runs only the Swiss hour in the continent's commonest condition, one
radar: each radar's registered reports alone, scored against the aircraft in its coverage.

``--true-biases`` converts the continent's reports with the true biases removed (a perfect
registration), to isolate what the registration leaves. The realism checks printed first: the share of the truth samples (aircraft in some radar's
coverage) that no radar reports within the instant's +-30 s, and the airborne aircraft
outside every radar's coverage.

Findings (scale 100, the hour, seed 2026; ``TrackerSettings()`` unless said; max_age 15 s):

* GOSPA per aircraft 477 m = localisation 295 + missed 368 + false 70 (shares of the square
  38 / 60 / 2 %); the Swiss hour 255 m = 164 + 158 + 116 (41 / 38 / 21 %).
* Scoring bug: 3.8 % of the scored samples are aircraft outside every radar's coverage,
  which ``evaluate_tracks`` interpolates between the samples either side of a coverage gap;
  98 % of them are missed, 54 % of the missed part. Scored on the covered truth only: 402 m.
  What the radars report agrees with ``truth_samples``' coverage (no covered sample without
  a report within 30 s).
* The rest of the missed part: samples covered by one radar (65 % of the truth, 4.7 %
  missed; 2+ radars: 0.2 %); 41 % of the missed samples have a live confirmed track within
  c whose last update is 15-60 s old (a 12 s radar that misses one scan). Initiation (first
  minute in coverage) is 10 %, low aircraft 4.5 %, the coverage's edge 15 %.
* Tracks per aircraft 1.245: 1.072 for the aircraft inside coverage in one stretch, 2.10
  for the 17 % that leave every coverage and come back (a new track each time); no
  duplicates, no switches at hand-offs.
* Localisation: single-radar coverage at 100-300 km (330-360 m); in the Swiss hour's
  conditions (2+ radars within 200 km) the cost per truth sample is 215 m against the
  Swiss 222 m; the registration's residual costs 5 m of localisation (``--true-biases``).
  The Swiss hour with one radar alone: 347-564 m per aircraft.
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import itertools  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_continent as bc  # noqa: E402

from radarfusion_ref import capstone as cp  # noqa: E402
from radarfusion_ref import continent as ct  # noqa: E402
from radarfusion_ref import tracking as trk  # noqa: E402
from radarfusion_ref.continent import _reports  # noqa: E402  (the radars' own frames)
from radarfusion_ref.continent._frame import frame_of  # noqa: E402

GRID = 10.0          # s, the grid on which entering coverage is timed
STALE_MAX = 60.0     # s, oldest last update counted by the stale-track check


# ------------------------------------------------------------------------ coverage geometry
def continent_geometry(sc, pos):
    """Per position (n, 3) in the map frame: (covering radars as a bool (n, m), slant range
    (n, m) and elevation (n, m) about each radar; inf / -inf where out of reach)."""
    frame = frame_of(*sc.origin)
    m = len(sc.radars)
    cov = np.zeros((pos.shape[0], m), bool)
    rng = np.full((pos.shape[0], m), np.inf)
    elev = np.full((pos.shape[0], m), -np.inf)
    for i, rad in enumerate(sc.radars):
        site = frame.forward(rad.lat, rad.lon, rad.height)
        near = np.flatnonzero(np.hypot(pos[:, 0] - site[0], pos[:, 1] - site[1])
                              <= _reports.REACH[0] * rad.max_range + _reports.REACH[1])
        if near.size:
            p = _reports.polar(_reports.to_local(frame, rad, pos[near]))
            rng[near, i], elev[near, i] = p[:, 0], p[:, 2]
            cov[near, i] = (p[:, 0] <= rad.max_range) & (p[:, 2] >= rad.min_elevation)
    return cov, rng, elev


def swiss_geometry(radars, pos):
    cov = np.zeros((pos.shape[0], len(radars)), bool)
    rng = np.full(cov.shape, np.inf)
    elev = np.full(cov.shape, -np.inf)
    for i, rad in enumerate(radars):
        rel = pos - rad.enu
        r = np.linalg.norm(rel, axis=1)
        e = np.arctan2(rel[:, 2], np.hypot(rel[:, 0], rel[:, 1]))
        rng[:, i], elev[:, i] = r, e
        cov[:, i] = (r <= rad.max_range) & (e >= rad.min_elevation)
    return cov, rng, elev


def attributes(cov, rng, elev, radars, z):
    """Per sample: covering radars, range to the nearest covering one, near the edge, low."""
    max_range = np.array([r.max_range for r in radars])
    n_cov = cov.sum(axis=1)
    r_near = np.where(cov, rng, np.inf).min(axis=1)
    inner = cov & (rng <= 0.9 * max_range) & (elev >= np.radians(0.5))
    return {"n_cov": n_cov, "range": r_near, "edge": cov.any(axis=1) & ~inner.any(axis=1),
            "low": z < 3000.0}


def entered_since(visible_grid, grid_times, times):
    """(A, T) seconds since the aircraft's current stretch in coverage began (inf if it began
    before the grid's start), from its visibility (A, G) on the grid `grid_times`."""
    A, G = visible_grid.shape
    start = np.full((A, G), np.nan)
    run = np.full(A, -np.inf)
    for g in range(G):
        v = visible_grid[:, g]
        began = v & ((g == 0) | ~visible_grid[:, max(g - 1, 0)])
        run = np.where(began, grid_times[g] if g > 0 else -np.inf, run)
        start[:, g] = np.where(v, run, np.nan)
    gi = np.clip(np.searchsorted(grid_times, times, side="right") - 1, 0, G - 1)
    return times[None, :] - start[:, gi]


# ------------------------------------------------------------------------------- the runs
def continent_case(scale, duration, seed, true_biases=False):
    """Scene, reports and the truth on the scored grid and on the 10 s grid, with attributes."""
    t0 = time.perf_counter()
    sc = ct.continent_scenario(scale, duration=max(duration, bc.WARMUP), rng=seed)
    first = ct.simulate_continent(sc, start=0.0, duration=bc.WARMUP, rng=seed + 1)
    reg = ct.register_continent(sc, first)
    true_b = np.array([r.biases for r in sc.radars])
    err = reg.biases - true_b
    reach = np.array([r.max_range for r in sc.radars]) / 2
    print(f"  registration: radars informed by no pair {int(np.sum(reg.pairs == 0))}; residual "
          f"rms: range offset {np.sqrt(np.mean(err[:, 0] ** 2)):.0f} m, azimuth "
          f"{np.degrees(np.sqrt(np.mean(err[:, 2] ** 2))):.3f} deg (at half range "
          f"{np.sqrt(np.mean((err[:, 2] * reach) ** 2)):.0f} m); true biases rms azimuth "
          f"{np.degrees(np.sqrt(np.mean(true_b[:, 2] ** 2))):.3f} deg")
    rep = ct.simulate_continent(sc, start=0.0, duration=duration, rng=seed + 1,
                                bias_estimate="true" if true_biases else reg.biases)
    times = np.arange(bc.FIRST, duration, bc.STEP)
    tt, tx, tid = ct.truth_samples(sc, times)
    ids = np.unique(tid)
    A, T = ids.size, times.size
    ai, ti = np.searchsorted(ids, tid), np.searchsorted(times, tt)
    seen = np.zeros((A, T), bool)
    seen[ai, ti] = True
    # evaluate_tracks interpolates each aircraft between its first and last sample: its truth
    # set is every instant in that span, in coverage or not
    first, last = seen.argmax(axis=1), T - 1 - seen[:, ::-1].argmax(axis=1)
    jj = np.arange(T)[None, :]
    valid = (jj >= first[:, None]) & (jj <= last[:, None])
    allpos, _ = ct.truth_at(sc, times)
    truth = np.where(valid[..., None], allpos[ids], np.nan)
    flat = truth[valid]
    cov, rng, elev = continent_geometry(sc, flat)
    att = attributes(cov, rng, elev, sc.radars, flat[:, 2])
    if not np.array_equal(cov.any(axis=1), seen[valid]):
        raise RuntimeError("truth_samples' coverage and the radars' own disagree")
    # visibility on a 10 s grid, for the time since entering coverage
    grid = np.arange(0.0, duration, GRID)
    gt, _, gid = ct.truth_samples(sc, grid)
    vis = np.zeros((A, grid.size), bool)
    inside = np.isin(gid, ids)
    vis[np.searchsorted(ids, gid[inside]), np.searchsorted(grid, gt[inside])] = True
    since = entered_since(vis, grid, times)
    # realism: truth samples that no radar reports within +-30 s
    reported = np.zeros((A, T), bool)
    real = rep.aircraft >= 0
    ra, rt = rep.aircraft[real], rep.time[real]
    keep = np.isin(ra, ids)
    ra, rt = np.searchsorted(ids, ra[keep]), rt[keep]
    for j, t in enumerate(times):
        near = np.abs(rt - t) <= 30.0
        reported[ra[near], j] = True
    n_air = int(np.sum(ct.airborne_count(sc, times)))
    print(f"continent: scale {scale:g}, seed {seed}, {duration:.0f} s, "
          f"{int(ct.airborne_count(sc, [duration / 2])[0])} airborne, {len(sc.radars)} radars, "
          f"{rep.time.size} reports ({int(np.sum(rep.aircraft < 0))} false); "
          f"{time.perf_counter() - t0:.0f} s to build")
    print(f"  realism: airborne samples outside every coverage "
          f"{100 * (1 - tx.shape[0] / n_air):.1f} %; truth samples with no report within "
          f"+-30 s {100 * np.mean(~reported[seen]):.2f} %; scored samples outside every "
          f"coverage (interpolated across a gap) {int((valid & ~seen).sum())} "
          f"({100 * np.mean(~seen[valid]):.2f} %)")
    per = np.full((A, T), -1)
    per[valid] = np.arange(int(valid.sum()))
    return {"name": "continent", "reports": bc.args_of(rep), "times": times, "ids": ids,
            "truth": truth, "valid": valid, "row": per, "att": att, "cov": cov,
            "since": since, "score": lambda h, age: trk.evaluate_tracks(
                h, tt, tx, tid, c=bc.C_CUT, p=bc.P_ORDER, times=times, max_age=age),
            "visible": lambda h, age: bc.score_visible(h, (tt, tx, tid), times, max_age=age)}


def swiss_case(duration=3600.0):
    import bench_tracking as bt

    s = bt._scene()
    _, reports = bt.detections(s["traffic"], s["radars"], duration, bt.SEED)
    times = np.arange(60.0, duration, bt.STEP)
    truth, valid = cp.truth_at(s["traffic"], times)
    flat = truth[valid]
    cov, rng, elev = swiss_geometry(s["radars"], flat)
    inside = np.zeros(valid.shape, bool)
    inside[valid] = cov.any(axis=1)
    keep = cov.any(axis=1)
    att = attributes(cov[keep], rng[keep], elev[keep], s["radars"], flat[keep, 2])
    grid = np.arange(0.0, duration, GRID)
    gtruth, gvalid = cp.truth_at(s["traffic"], grid)
    gvis = np.zeros(gvalid.shape, bool)
    gvis[gvalid] = cp.coverage_count(gtruth[gvalid], s["radars"]) >= 1
    since = entered_since(gvis, grid, times)
    row = np.full(valid.shape, -1)
    row[inside] = np.arange(int(inside.sum()))
    print(f"Swiss: seed {bt.SEED}, {duration:.0f} s, {len(s['radars'])} radars, "
          f"{reports[0].size} reports")
    return {"name": "Swiss", "reports": reports, "times": times,
            "ids": np.arange(valid.shape[0]), "truth": np.where(inside[..., None], truth,
                                                                 np.nan),
            "valid": inside, "row": row, "att": att, "cov": cov[keep], "since": since,
            "score": lambda h, age: trk.evaluate_tracks_over_time(
                h, s["traffic"], c=bt.C_CUT, p=bt.P_ORDER, times=times, radars=s["radars"],
                max_age=age)}


# ---------------------------------------------------------------------------- decomposition
def _share(x, total):
    return f"{np.sqrt(x):5.0f} m ({100 * x / total:4.1f} %)" if total > 0 else "-"


def parts(m, n_truth, tracks_per_aircraft):
    """Print GOSPA per aircraft and its three parts; return the parts (m^2)."""
    ok = n_truth > 0
    L = np.mean(m.localisation[ok] / n_truth[ok])
    M = np.mean(m.missed[ok] / n_truth[ok])
    F = np.mean(m.false[ok] / n_truth[ok])
    tot = L + M + F
    print(f"  GOSPA/aircraft {np.sqrt(tot):.0f} m = loc {_share(L, tot)} + missed "
          f"{_share(M, tot)} + false {_share(F, tot)}; tracks/aircraft "
          f"{tracks_per_aircraft:.3f}, false tracks/h {m.false_tracks_per_hour:.1f}, "
          f"latency {m.mean_latency:.0f} s, mean GOSPA {m.mean_gospa:.0f} m")
    return L, M, F


def decompose(case, h, m, age):
    """Print the five tables of the module's docstring for one scored run."""
    times, valid, row, att = case["times"], case["valid"], case["row"], case["att"]
    if not np.array_equal(m.truth_id, case["ids"]):
        raise RuntimeError("the scored truth and the case's truth disagree")
    n_truth = valid.sum(axis=0)
    ok = n_truth > 0
    _, M, _ = parts(m, n_truth, m.tracks_per_aircraft)
    track_of = m.track_of                                # rows: the case's ids
    missed = valid & (track_of < 0)
    w = m.c ** m.p / 2.0 / np.where(ok, n_truth, 1)[None, :] / ok.sum()   # missed part share
    s_idx = row[valid]
    cls = {}
    n_cov = att["n_cov"][s_idx]
    since = case["since"][valid]
    cls["0 (interpolated)"] = n_cov == 0
    cls["1 radar"] = n_cov == 1
    cls["2 radars"] = n_cov == 2
    cls["3+ radars"] = n_cov >= 3
    cls["< 60 s in cover"] = since < 60
    cls["60-120 s in cover"] = (since >= 60) & (since < 120)
    cls[">= 120 s in cover"] = ~(since < 120)
    cls["below 3 km"] = att["low"][s_idx]
    cls["near the edge"] = att["edge"][s_idx]
    mv, wv = missed[valid], np.broadcast_to(w, valid.shape)[valid]
    print(f"  missed: {100 * mv.mean():.2f} % of {mv.size} truth samples; by class: share of "
          f"the truth, missed in it, its part of the missed part")
    for k, c in cls.items():
        part = np.sum(wv[c & mv]) / M if M > 0 else 0.0
        print(f"    {k:<18} {100 * c.mean():5.1f} % of truth, {100 * mv[c].mean() if c.any() else 0:5.2f} % "
              f"missed, {100 * part:5.1f} % of missed part")
    # stale tracks: a confirmed track, last updated between max_age and STALE_MAX ago,
    # within c of a missed aircraft
    old = trk.tracks_at(h, times, max_age=STALE_MAX)
    last = _last_update(h, old.track, times)
    stale = np.isfinite(old.state[..., 0]) & (last > age)
    n_stale = 0
    for j in range(times.size):
        a = np.flatnonzero(missed[:, j])
        k = np.flatnonzero(stale[:, j])
        if a.size and k.size:
            d = np.linalg.norm(case["truth"][a, j, None, :] - old.state[None, k, j, :3], axis=-1)
            n_stale += int(np.sum(d.min(axis=1) < m.c))
    print(f"  missed with a stale track (last update {age:g}-{STALE_MAX:g} s old) within c: "
          f"{n_stale} of {int(mv.sum())} ({100 * n_stale / max(mv.sum(), 1):.1f} %)")
    # tracks per aircraft split
    gap = gap_out = switch = handoff = 0
    cov_sets = case["cov"]
    for a in range(valid.shape[0]):
        seq = track_of[a]
        paired = np.flatnonzero(seq >= 0)
        for u, v in itertools.pairwise(paired):
            if seq[u] == seq[v]:
                continue
            if v - u > 1:
                gap += 1
                between = row[a, u + 1:v]
                gap_out += int(((between < 0) | (att["n_cov"][between] == 0)).any())
            else:
                switch += 1
                ru, rv = row[a, u], row[a, v]
                handoff += int(not np.array_equal(cov_sets[ru], cov_sets[rv]))
    n_pairs_ac = int(np.sum((track_of >= 0).any(axis=1)))
    # tracks per aircraft among the aircraft in coverage in one stretch, and in several
    inside = np.zeros(valid.shape, bool)
    inside[valid] = att["n_cov"][row[valid]] > 0
    stretches = np.sum(inside[:, 1:] & ~inside[:, :-1], axis=1) + inside[:, 0]
    distinct = np.array([np.unique(t[t >= 0]).size for t in track_of])
    for lab, c in (("one stretch in coverage", stretches == 1),
                   ("several stretches", stretches > 1)):
        c &= distinct > 0
        if c.any():
            print(f"  tracks/aircraft, aircraft with {lab}: {distinct[c].mean():.3f} "
                  f"({int(c.sum())} aircraft)")
    states = trk.tracks_at(h, times, max_age=age)
    dup = 0
    dup_tracks = set()
    for j in range(times.size):
        k = np.flatnonzero(np.isfinite(states.state[:, j, 0]))
        paired_ids = set(track_of[:, j][track_of[:, j] >= 0].tolist())
        free = np.array([i for i in k if states.track[i] not in paired_ids], dtype=int)
        a = np.flatnonzero(valid[:, j])
        if free.size and a.size:
            d = np.linalg.norm(states.state[free, j, None, :3] - case["truth"][None, a, j, :],
                               axis=-1)
            near = d.min(axis=1) < m.c
            dup += int(near.sum())
            dup_tracks.update(states.track[free[near]].tolist())
    print(f"  track changes per aircraft ({n_pairs_ac} paired aircraft): after a gap "
          f"{gap / n_pairs_ac:.3f} (of which across a coverage gap {gap_out / n_pairs_ac:.3f}), "
          f"direct switches {switch / n_pairs_ac:.3f} (at a hand-off {handoff / n_pairs_ac:.3f});"
          f" duplicate samples (unpaired track within c of an aircraft) {dup} "
          f"({100 * dup / valid.sum():.2f} % of truth), {len(dup_tracks)} tracks")
    # localisation by covering radars and range
    pair = track_of >= 0
    idx = {int(t): i for i, t in enumerate(states.track)}
    aa, jj = np.nonzero(pair)
    ki = np.array([idx[int(t)] for t in track_of[aa, jj]], dtype=int)
    err2 = np.sum((states.state[ki, jj, :3] - case["truth"][aa, jj]) ** 2, axis=-1)
    err2 = np.minimum(err2, m.c ** 2)
    r = att["range"][row[aa, jj]] / 1e3
    nc = att["n_cov"][row[aa, jj]]
    print("  localisation RMSE of paired tracks (m): by covering radars "
          + ", ".join(f"{lab} {np.sqrt(np.mean(err2[c])):.0f} ({100 * c.mean():.0f} %)"
                      for lab, c in (("0", nc == 0), ("1", nc == 1), ("2", nc == 2),
                                     ("3+", nc >= 3)) if c.any())
          + "; by range to the nearest (km) "
          + ", ".join(f"{lo}-{hi} {np.sqrt(np.mean(err2[c])):.0f} ({100 * c.mean():.0f} %)"
                      for lo, hi in ((0, 100), (100, 200), (200, 300), (300, 400))
                      if (c := (r >= lo) & (r < hi)).any()))
    # the cost per truth sample (its localisation error^2 if paired, c^p / 2 if missed):
    # GOSPA per aircraft without the false part, in the same conditions for both scenes
    cost = np.full(valid.shape, m.c ** m.p / 2.0)
    cost[aa, jj] = err2
    cv, ncv = cost[valid], att["n_cov"][row[valid]]
    rv = att["range"][row[valid]] / 1e3
    print("  cost per truth sample, root mean (m): all "
          f"{np.sqrt(cv.mean()):.0f}; by covering radars "
          + ", ".join(f"{lab} {np.sqrt(np.mean(cv[c])):.0f}" for lab, c in
                      (("0", ncv == 0), ("1", ncv == 1), ("2", ncv == 2), ("3+", ncv >= 3))
                      if c.any())
          + "; by range to the nearest (km) "
          + ", ".join(f"{lo}-{hi} {np.sqrt(np.mean(cv[c])):.0f}"
                      for lo, hi in ((0, 100), (100, 200), (200, 300), (300, 400))
                      if (c := (rv >= lo) & (rv < hi)).any())
          + "; 2+ radars within 200 km "
          + f"{np.sqrt(np.mean(cv[(ncv >= 2) & (rv < 200)])):.0f}")


def _last_update(h, track_ids, times):
    """(K, T) age of each confirmed track's latest confirmed row before each instant."""
    conf = h.confirmed
    tr, tm = h.track[conf], h.time[conf]
    out = np.full((track_ids.size, times.size), np.inf)
    order = np.lexsort((tm, tr))
    tr, tm = tr[order], tm[order]
    u, first = np.unique(tr, return_index=True)
    stops = np.append(first[1:], tr.size)
    where = np.searchsorted(u, track_ids)
    for k, w in enumerate(where):
        ts = tm[first[w]:stops[w]]
        j = np.searchsorted(ts, times, side="right") - 1
        out[k] = np.where(j >= 0, times - ts[np.maximum(j, 0)], np.inf)
    return out


def swiss_single(ages):
    """The Swiss scored hour in the continent's commonest condition, one radar: each radar's
    own registered reports alone, scored against the aircraft inside its coverage."""
    import bench_tracking as bt

    s = bt._scene()
    _, reports = bt.detections(s["traffic"], s["radars"], 3600.0, bt.SEED)
    times = np.arange(60.0, 3600.0, bt.STEP)
    for i, rad in enumerate(s["radars"]):
        # the scoring takes two radars or more: the other one covers 1 m about its site
        pair = [rad, dataclasses.replace(rad, name="none", max_range=1.0)]
        keep = reports[3] == i
        one = tuple(x[keep] for x in reports)
        h = trk.track_reports(*one[:3], np.zeros(int(keep.sum()), np.int64), one[4])
        for age in ages:
            m = trk.evaluate_tracks_over_time(h, s["traffic"], c=bt.C_CUT, p=bt.P_ORDER,
                                              times=times, radars=pair, max_age=age)
            n_truth = np.sum(m.track_of >= 0, axis=0) + np.rint(
                2 * m.missed / m.c ** m.p).astype(int)
            print(f"\nSwiss hour, {rad.name} alone (period {rad.period:g} s, P_D "
                  f"{rad.p_detect:g}), max_age {age:g} s:")
            parts(m, n_truth, m.tracks_per_aircraft)


def settings_named(name):
    if name == "default":
        return trk.TrackerSettings()
    return ct.CONTINENT_SETTINGS


def main(scale, duration, seed, ages, settings, swiss, single=False, true_biases=False):
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}; load average "
          f"{' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    if single:
        swiss_single(ages)
        return 0
    cases = [continent_case(scale, duration, seed, true_biases)]
    if swiss:
        cases.append(swiss_case())
    for case in cases:
        for name in settings:
            t0 = time.perf_counter()
            h = trk.track_reports(*case["reports"], settings=settings_named(name))
            s_track = time.perf_counter() - t0
            for age in ages:
                m = case["score"](h, age)
                print(f"\n{case['name']}, settings {name}, max_age {age:g} s "
                      f"(tracked in {s_track:.0f} s):")
                decompose(case, h, m, age)
                if "visible" in case:
                    mv, per = case["visible"](h, age)
                    print("  scored on the covered truth only (bench_continent.score_visible):")
                    parts(mv, np.sum(mv.track_of >= 0, axis=0)
                          + np.rint(2 * mv.missed / mv.c ** mv.p).astype(int), per)
                    print(f"  tracks per stretch in coverage {mv.tracks_per_aircraft:.3f}")
    return 0


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scale", type=float, default=10.0)
    p.add_argument("--duration", type=float, default=1200.0)
    p.add_argument("--seed", type=int, default=bc.SEED)
    p.add_argument("--max-age", type=float, nargs="+", default=(15.0, 25.0))
    p.add_argument("--settings", nargs="+", default=("default",),
                   choices=("default", "continent"))
    p.add_argument("--no-swiss", action="store_true")
    p.add_argument("--true-biases", action="store_true",
                   help="convert the continent's reports with the true biases removed")
    p.add_argument("--swiss-single", action="store_true",
                   help="only the Swiss hour with each radar alone")
    a = p.parse_args()
    sys.exit(main(a.scale, a.duration, a.seed, tuple(a.max_age), tuple(a.settings),
                  not a.no_swiss, a.swiss_single, a.true_biases))
