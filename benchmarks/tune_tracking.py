"""Tune ours and Stone Soup on the tuning hour (never on the scored hour): one protocol for all.

Run as ``python benchmarks/tune_tracking.py`` (two worker processes); it rewrites
``benchmarks/data/tracking_tuning.csv`` (one row per run: every knob, the metrics, whether the
setting is feasible, which search step ran it, ``chosen``) and prints the choice per tracker.
The chosen values must be the package's: ``TrackerSettings()``'s defaults for ours (constant
velocity), ``tracking.IMM_SETTINGS`` for ours with the interacting multiple model, and
``tracking.STONESOUP_SETTINGS`` (keyword arguments of ``tracking.stonesoup_track``) for Stone
Soup's GNN and JPDA. ``python benchmarks/tune_tracking.py gnn ours_cv`` runs those trackers'
searches only and keeps the other trackers' rows of the table. The committed table holds
all four searches (Stone Soup's take 1-2 minutes per tuning-hour run for the GNN and 2-5
for the JPDA on an idle machine; the whole script about an hour). The script exits with 1
if any run failed, and with 1 naming every difference between the chosen settings and the package's constants; a test checks the
committed table against the constants.

The protocol (fixed before any scored run; it is not changed after scored results are seen):

* Data: the tuning hour only (``capstone.load_traffic(hour="tuning")``, 2018-08-01
  09:00-10:00 UTC, the same day and extraction as the scored 11:00 hour), seed 2018, the whole
  hour, the scored benchmark's pipeline: realistic radars (``capstone.realistic_radars()``,
  ``simulate_detections(..., mode="realistic")``), registration from the first five minutes
  (``capstone.register_detections``), ``capstone.to_common``; scored by
  ``tracking.evaluate_tracks_over_time`` every 10 s from 60 s against the ADS-B truth inside
  the radars' coverage (GOSPA c = 2000 m, p = 2).
* Trackers tuned: ours with the constant-velocity model (GNN), ours with the interacting
  multiple model (GNN), Stone Soup's GNN, Stone Soup's JPDA (``JPDAwithEHM2``).
* Criterion, the same for every tracker: a setting is feasible if it has at most 1.05 tracks
  per aircraft and at most 12 false tracks per hour; among feasible settings the lowest mean
  GOSPA rounded to the metre wins, ties broken by fewer false tracks per hour, then by the
  lower mean confirmation latency. If no setting is feasible, the smallest sum of relative
  excesses wins, max(0, tracks per aircraft - 1.05) / 0.05 + max(0, false tracks per hour -
  12) / 12 (ties broken as among feasible settings). A run that failed is never chosen.
  Ties left after these go to the value listed first in the knob's grid.
* Search: coordinate-wise, one pass over the knobs in the fixed order listed below (motion
  knobs first, then track management); each knob is tried over its grid with every other knob
  at its current best value, and the best of those runs by the criterion sets the knob; a
  setting already run is not run again.
* Start point, shared: q = 50 m²/s³, vertical q = 2 m²/s³, vertical-velocity prior
  (``speed_max_vertical``) 15 m/s, gate ``p_false_reject`` = chi2.sf(64, 3) (Stone Soup's
  missed distance 8); ours' other settings at their previous defaults (SPRT p_false_confirm
  1e-3, p_false_delete 1e-2, relinking at p_relink 1e-20, IMM modes (5, 300)); Stone Soup's initiator
  ``min_points`` 3, deleter ``max_coast`` 40 s, hold 1.5 x the slowest radar's revisit
  (the adapter's rule without `hold`).
* Motion grids, shared: q in {20, 50, 120}; vertical q in {0.03, 0.3, 2}; vertical-velocity
  prior in {5, 15, 50}. Ours with the IMM has two modes, so one motion knob more: the quiet
  mode's q in {2, 5, 10} and the manoeuvre mode's q in {150, 300, 600} in place of the one q
  (``imm_q`` = (quiet, manoeuvre)), a vertical q in {0.03, 0.3, 2} for both modes
  (``imm_q_vertical``), and the vertical-velocity prior as above.
* Track-management grids, four knobs each. Ours: SPRT p_false_confirm in {1e-2, 1e-3, 1e-4}, p_false_delete in
  {1e-3, 1e-2, 1e-1}, relinking ``p_relink`` in {off, 1e-20, 1e-10}, gate ``p_false_reject``
  in {1e-4, 1e-6, chi2.sf(64, 3)}. Stone Soup: initiator ``min_points`` in {3, 4, 5}, hold in
  {1.0, 1.5, 2.5} x the slowest revisit, deleter ``max_coast`` in {20, 40, 60} s, gate /
  missed distance ``p_false_reject`` in {1e-4, 1e-6, chi2.sf(64, 3)}.
* Budget: at most 1 + 2 x (number of knobs) runs per tracker: 15 for ours (constant
  velocity) and each Stone Soup tracker (7 knobs), 17 for ours with the IMM (8 knobs).
* Failure: a grid point that raises is recorded (its row says failed, with the error) and the
  search goes on; the script then exits non-zero.
"""

from __future__ import annotations

import csv
import math
import os
import sys
import threading
import time
import traceback
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import numpy as np
from scipy import stats

from radarfusion_ref import capstone as cp
from radarfusion_ref import tracking as trk

SEED = 2018
WINDOW = 3600.0
C_CUT, P_ORDER, STEP = 2000.0, 2.0, 10.0
MAX_TRACKS_PER_AIRCRAFT, MAX_FALSE_PER_HOUR = 1.05, 12.0
#: chi2.sf(64, 3): a gate at Mahalanobis distance 8 (Stone Soup's missed distance 8)
GATE_8 = float(stats.chi2.sf(64.0, 3))
OUT = Path(__file__).resolve().parent / "data" / "tracking_tuning.csv"
TRACKERS = ("ours_cv", "ours_imm", "gnn", "jpda")

_MOTION = {"q": (20.0, 50.0, 120.0), "q_vertical": (0.03, 0.3, 2.0),
           "speed_max_vertical": (5.0, 15.0, 50.0)}
_IMM_MOTION = {"imm_q_quiet": (2.0, 5.0, 10.0), "imm_q_manoeuvre": (150.0, 300.0, 600.0),
               "imm_q_vertical": (0.03, 0.3, 2.0), "speed_max_vertical": (5.0, 15.0, 50.0)}
_GATES = (1e-4, 1e-6, GATE_8)
_OURS_TM = {"p_false_confirm": (1e-2, 1e-3, 1e-4), "p_false_delete": (1e-3, 1e-2, 1e-1),
            "p_relink": ("off", 1e-20, 1e-10), "p_false_reject": _GATES}
_SS_TM = {"min_points": (3, 4, 5), "hold": (1.0, 1.5, 2.5), "max_coast": (20.0, 40.0, 60.0),
          "p_false_reject": _GATES}
#: Each tracker's knobs, in the order the search visits them, with their grids.
GRIDS = {"ours_cv": {**_MOTION, **_OURS_TM}, "ours_imm": {**_IMM_MOTION, **_OURS_TM},
         "gnn": {**_MOTION, **_SS_TM}, "jpda": {**_MOTION, **_SS_TM}}
_START_SHARED = {"q": 50.0, "q_vertical": 2.0, "speed_max_vertical": 15.0,
                 "p_false_reject": GATE_8}
#: The shared start point.
START = {"ours_cv": {**_START_SHARED, "p_false_confirm": 1e-3, "p_false_delete": 1e-2, "p_relink": 1e-20},
         "ours_imm": {"imm_q_quiet": 5.0, "imm_q_manoeuvre": 300.0, "imm_q_vertical": 2.0,
                      "speed_max_vertical": 15.0, "p_false_reject": GATE_8, "p_false_confirm": 1e-3,
                      "p_false_delete": 1e-2, "p_relink": 1e-20},
         "gnn": {**_START_SHARED, "min_points": 3, "hold": 1.5, "max_coast": 40.0},
         "jpda": {**_START_SHARED, "min_points": 3, "hold": 1.5, "max_coast": 40.0}}
KNOBS = ("q", "q_vertical", "speed_max_vertical", "imm_q_quiet", "imm_q_manoeuvre",
         "imm_q_vertical", "p_false_confirm", "p_false_delete", "p_relink", "p_false_reject", "min_points", "hold",
         "max_coast")
FIELDS = ("tracker", "step", *KNOBS, "status", "error", "seconds", "mean_gospa",
          "localisation", "missed", "false", "tracks_per_aircraft", "n_tracks", "switches",
          "false_tracks_per_hour", "mean_latency", "nees", "feasible", "chosen")

for _t in TRACKERS:       # every start value is on its grid: the budget is 1 + 2 x knobs
    assert set(GRIDS[_t]) == set(START[_t]), _t
    assert all(START[_t][k] in g for k, g in GRIDS[_t].items()), _t

_DATA: dict = {}


def _data():
    """The tuning hour's registered reports (built once per process)."""
    if not _DATA:
        traffic = cp.load_traffic(hour="tuning")
        radars = cp.realistic_radars()
        det = cp.simulate_detections(traffic, radars, duration=WINDOW, mode="realistic",
                                     rng=SEED)
        pos, cov = cp.to_common(det, radars, cp.register_detections(det, radars).biases)
        _DATA.update(traffic=traffic, radars=radars,
                     reports=(det.time, pos, cov, det.radar, det.scan))
    return _DATA


def settings_of(tracker, knobs):
    """The run of `tracker` with `knobs`: ``stonesoup_track`` keyword arguments for Stone
    Soup (``settings``, ``hold``), a ``TrackerSettings`` for ours."""
    if tracker in ("gnn", "jpda"):
        m = int(knobs["min_points"])
        s = trk.TrackerSettings(q=knobs["q"], q_vertical=knobs["q_vertical"],
                                speed_max_vertical=knobs["speed_max_vertical"], m=m,
                                n=max(4, m), max_coast=knobs["max_coast"],
                                p_false_reject=knobs["p_false_reject"])
        return {"settings": s, "hold": knobs["hold"]}
    relink = knobs["p_relink"] != "off"
    common = {"p_false_confirm": knobs["p_false_confirm"], "p_false_delete": knobs["p_false_delete"], "relink": relink,
              "p_false_reject": knobs["p_false_reject"],
              "speed_max_vertical": knobs["speed_max_vertical"]}
    if relink:
        common["p_relink"] = knobs["p_relink"]
    if tracker == "ours_cv":
        return trk.TrackerSettings(q=knobs["q"], q_vertical=knobs["q_vertical"], **common)
    v = knobs["imm_q_vertical"]
    return trk.TrackerSettings(motion="imm", imm_q=(knobs["imm_q_quiet"],
                                                    knobs["imm_q_manoeuvre"]),
                               imm_q_vertical=(v, v), **common)


def _run(job):
    """One run of the search: (tracker, knobs, step) -> a row of the table."""
    tracker, knobs, step = job
    row = {"tracker": tracker, "step": step, **{k: "" for k in FIELDS[2:]}, **knobs,
           "status": "ok", "feasible": 0, "chosen": 0}
    try:
        d = _data()
        s = settings_of(tracker, knobs)
        t0 = time.perf_counter()
        if tracker in ("gnn", "jpda"):
            h = trk.stonesoup_track(*d["reports"], tracker=tracker, **s)
        else:
            h = trk.track_reports(*d["reports"], settings=s)
        seconds = time.perf_counter() - t0
        m = trk.evaluate_tracks_over_time(h, d["traffic"], c=C_CUT, p=P_ORDER,
                                          times=np.arange(60.0, WINDOW, STEP),
                                          radars=d["radars"])
    except Exception as exc:                                   # recorded, the search goes on
        row.update(status="failed", error=f"{type(exc).__name__}: {exc}"[:300])
        traceback.print_exc()
        return row
    record_scores(row, m, seconds, float(m.tracks_per_aircraft))
    row["feasible"] = int(_feasible(row))
    return row


def record_scores(row, m, seconds, tracks_per_aircraft):
    """Write a run's scores (``TrackingMetrics`` `m`, its run time, its tracks per aircraft)
    into its table `row`, rounded as the table keeps them."""
    parts = [float(np.sqrt(np.mean(v))) for v in (m.localisation, m.missed, m.false)]
    row.update(seconds=round(seconds, 2), mean_gospa=round(float(m.mean_gospa), 1),
               localisation=round(parts[0], 1), missed=round(parts[1], 1),
               false=round(parts[2], 1), tracks_per_aircraft=round(tracks_per_aircraft, 4),
               n_tracks=int(m.n_tracks), switches=int(m.switches),
               false_tracks_per_hour=round(float(m.false_tracks_per_hour), 2),
               mean_latency=round(float(m.mean_latency), 2),
               nees=round(float(m.nees.mean), 3) if m.nees is not None else "")


def _feasible(row):
    return (row["status"] == "ok"
            and float(row["tracks_per_aircraft"]) <= MAX_TRACKS_PER_AIRCRAFT
            and float(row["false_tracks_per_hour"]) <= MAX_FALSE_PER_HOUR)


def criterion(row):
    """The protocol's criterion as a sort key (smaller is better)."""
    if row["status"] != "ok":
        return (2, math.inf, math.inf, math.inf, math.inf)
    tpa, fth = float(row["tracks_per_aircraft"]), float(row["false_tracks_per_hour"])
    lat = float(row["mean_latency"])
    lat = lat if math.isfinite(lat) else math.inf
    rest = (round(float(row["mean_gospa"])), fth, lat)
    if _feasible(row):
        return (0, 0.0, *rest)
    excess = (max(0.0, tpa - MAX_TRACKS_PER_AIRCRAFT) / 0.05
              + max(0.0, fth - MAX_FALSE_PER_HOUR) / MAX_FALSE_PER_HOUR)
    return (1, excess, *rest)


def _search(tracker, pool, log):
    """The coordinate-wise pass of one tracker; returns its rows (chosen one marked)."""
    best = dict(START[tracker])
    done: dict[tuple, dict] = {}

    def key(knobs):
        return tuple(knobs[k] for k in GRIDS[tracker])

    def run_all(settings, step):
        todo = [s for s in settings if key(s) not in done]
        for s, row in zip(todo, pool.map(_run, [(tracker, s, step) for s in todo]),
                          strict=True):
            done[key(s)] = row
            log(row)
        return [done[key(s)] for s in settings]

    run_all([best], "start")
    for knob, grid in GRIDS[tracker].items():
        rows = run_all([{**best, knob: v} for v in grid], knob)
        winner = min(rows, key=criterion)
        best = {k: winner[k] for k in GRIDS[tracker]}
    rows = list(done.values())
    assert len(rows) <= 1 + 2 * len(GRIDS[tracker]), (tracker, len(rows))
    done[key(best)]["chosen"] = 1
    return rows


def chosen_knobs(path=OUT):
    """The chosen row's knobs per tracker of a tuning table, as numbers (``"off"`` kept)."""
    out = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            if row["chosen"] == "1":
                out[row["tracker"]] = {k: _number(row[k]) for k in GRIDS[row["tracker"]]}
    return out


def _number(text):
    return text if text == "off" else float(text)


def package_knobs():
    """The package's constants as knobs of the search, per tracker."""
    cv, imm = trk.TrackerSettings(), trk.IMM_SETTINGS
    out = {}
    for name, s in (("ours_cv", cv), ("ours_imm", imm)):
        k = {"p_false_confirm": s.p_false_confirm, "p_false_delete": s.p_false_delete, "p_relink": s.p_relink if s.relink else "off",
             "p_false_reject": s.p_false_reject, "speed_max_vertical": s.speed_max_vertical}
        if name == "ours_cv":
            k.update(q=s.q, q_vertical=s.q_vertical)
        else:
            qv = s.imm_q_vertical or (None, None)
            k.update(imm_q_quiet=s.imm_q[0], imm_q_manoeuvre=s.imm_q[-1],
                     imm_q_vertical=qv[0] if len(set(qv)) == 1 else qv,
                     motion=s.motion, modes=len(s.imm_q))
        out[name] = k
    for name in ("gnn", "jpda"):
        kw = trk.STONESOUP_SETTINGS[name]
        s = kw["settings"]
        out[name] = {"q": s.q, "q_vertical": s.q_vertical,
                     "speed_max_vertical": s.speed_max_vertical, "min_points": s.m,
                     "hold": kw.get("hold"), "max_coast": s.max_coast,
                     "p_false_reject": s.p_false_reject}
    return out


def package_mismatches(chosen):
    """Every difference between the chosen knobs and the package's constants, as text."""
    package = package_knobs()
    where = {"ours_cv": "TrackerSettings() defaults", "ours_imm": "IMM_SETTINGS",
             "gnn": "STONESOUP_SETTINGS['gnn']", "jpda": "STONESOUP_SETTINGS['jpda']"}
    out = []
    for tracker, knobs in chosen.items():
        pk = package[tracker]
        if tracker == "ours_imm" and (pk["motion"] != "imm" or pk["modes"] != 2):
            out.append(f"ours_imm: IMM_SETTINGS must be motion='imm' with two modes; has "
                       f"motion={pk['motion']!r}, {pk['modes']} modes")
        for k, v in knobs.items():
            if v != pk[k]:
                out.append(f"{tracker}: {k} tuned {v!r}, {where[tracker]} has {pk[k]!r}")
    return out


def _fmt(v):
    return f"{v:g}" if isinstance(v, float) else str(v)


def main(workers: int = 2) -> int:
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}; tuning hour, seed {SEED}, "
          f"{WINDOW / 60:.0f} min; feasible: tracks/aircraft <= {MAX_TRACKS_PER_AIRCRAFT}, "
          f"false tracks/h <= {MAX_FALSE_PER_HOUR:g}; then GOSPA", flush=True)
    t0 = time.perf_counter()
    lock = threading.Lock()

    def log(row):
        with lock:
            knobs = ", ".join(f"{k} {_fmt(row[k])}" for k in GRIDS[row["tracker"]])
            what = (f"FAILED {row['error']}" if row["status"] != "ok" else
                    f"GOSPA {row['mean_gospa']:.0f} m, trk/ac {row['tracks_per_aircraft']:.3f},"
                    f" false/h {row['false_tracks_per_hour']:.1f}, latency "
                    f"{row['mean_latency']:.1f} s, NEES {row['nees']}, {row['seconds']:.0f} s")
            print(f"[{time.perf_counter() - t0:5.0f} s] {row['tracker']:<8} ({row['step']}) "
                  f"{knobs}: {what}", flush=True)

    only = [a for a in sys.argv[1:] if a in TRACKERS] or list(TRACKERS)
    with ProcessPoolExecutor(max_workers=workers) as pool, \
            ThreadPoolExecutor(max_workers=len(only)) as searches:
        # the slow Stone Soup searches first, so that the pool is never idle
        order = sorted(only, key=lambda t: ("jpda", "gnn", "ours_imm", "ours_cv").index(t))
        futures = {t: searches.submit(_search, t, pool, log) for t in order}
        new = {t: f.result() for t, f in futures.items()}
    kept = []
    if set(only) != set(TRACKERS) and OUT.exists():  # a subset keeps the others' rows
        with open(OUT, newline="") as f:
            reader = csv.DictReader(f)
            if tuple(reader.fieldnames or ()) == FIELDS:
                kept = [r for r in reader if r["tracker"] not in only]
    rows = [r for t in TRACKERS
            for r in (new[t] if t in new else [k for k in kept if k["tracker"] == t])]
    OUT.parent.mkdir(exist_ok=True)
    with open(OUT, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    print(f"\nwrote {OUT}; total {time.perf_counter() - t0:.0f} s")
    failed = [r for r in rows if r["status"] != "ok"]      # kept rows too: the table is whole
    for r in failed:
        print(f"FAILED {r['tracker']} ({r['step']}): {r['error']}")
    chosen = chosen_knobs()
    for tracker, knobs in chosen.items():
        r = next(r for r in rows if r["tracker"] == tracker and int(r["chosen"]))
        print(f"chosen {tracker}: " + ", ".join(f"{k} {_fmt(v)}" for k, v in knobs.items())
              + f" -> GOSPA {float(r['mean_gospa']):.0f} m, "
              f"{float(r['tracks_per_aircraft']):.3f} tracks/aircraft, "
              f"{float(r['false_tracks_per_hour']):.1f} false tracks/h, feasible "
              f"{bool(int(r['feasible']))}")
    try:
        wrong = package_mismatches(chosen)
    except (AttributeError, KeyError, TypeError) as exc:
        wrong = [f"the package's constants cannot be read as the search's knobs ({exc!r})"]
    for line in wrong:
        print(f"MISMATCH {line}: update the package's constants")
    missing = [t for t in TRACKERS if t not in chosen]
    if missing:
        print(f"NOT RUN YET: {', '.join(missing)} (no rows in the table; their package "
              f"settings are the protocol's start point until `python "
              f"benchmarks/tune_tracking.py {' '.join(missing)}` runs)")
    return 1 if (wrong or failed) else 0


if __name__ == "__main__":
    sys.exit(main(workers=min(2, os.cpu_count() or 1)))
