"""Benchmark: the operating characteristic, false tracks per hour against confirmation latency.

Run as ``python benchmarks/bench_operating.py [--seeds N] [--stonesoup gnn|jpda] [--quick]``.
A confirmation rule trades false tracks against latency: a stricter threshold confirms fewer
tracks of clutter and confirms aircraft later. Comparing two trackers at one threshold each
compares two points of two curves; this benchmark draws the curves. On the scored hour (the
detections of ``bench_tracking.py``: realistic radars, seeds 2018, 2019, ..., registered from
the first five minutes, in the common frame), every tracker runs with everything at its tuned
value (``benchmarks/tune_tracking.py``) but its confirmation threshold, swept:

* ours with the IMM (``tracking.IMM_SETTINGS``) and ours with constant velocity
  (``TrackerSettings()``): the sequential test's ``p_false_confirm`` (the probability of confirming a
  track of clutter) in {1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6};
* Stone Soup's better tuned tracker (lower mean GOSPA in ``benchmarks/data/
  tracking_scored.csv``, or ``--stonesoup``), with ``tracking.STONESOUP_SETTINGS``: the
  initiator's ``min_points`` in {2, 3, 4, 5, 6}.

Each run is scored by ``tracking.evaluate_tracks_over_time`` every 10 s from 60 s (GOSPA
c = 2000 m, p = 2), and written to ``benchmarks/data/tracking_operating.csv`` (full hour only)
with the columns ``tracker,seed,threshold_name,threshold,false_tracks_per_hour,mean_latency,
mean_gospa``.

The rule for "ours' curve lies below Stone Soup's", stated before the runs: each curve is its
thresholds' points (false tracks per hour, mean latency), each the mean over the seeds, joined
by straight segments in the order of the threshold. A Stone Soup point (f, l) is reached by
ours if some point of ours' polyline, vertices or on a segment by linear interpolation, has
latency <= l and false tracks per hour <= f; ours' curve lies below Stone Soup's if it reaches
every Stone Soup point. The script prints, per Stone Soup point, the fewest false tracks per
hour ours has at no more latency (or that ours never confirms that fast), and the verdict;
the exit code is 0 either way (a benchmark, not a test).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import itertools
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_tracking as bt  # the scored benchmark's data and scoring

from radarfusion_ref import tracking as trk

OUT = Path(__file__).resolve().parent / "data" / "tracking_operating.csv"
COLUMNS = ("tracker", "seed", "threshold_name", "threshold", "false_tracks_per_hour",
           "mean_latency", "mean_gospa")
ALPHAS = (1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6)
MIN_POINTS = (2, 3, 4, 5, 6)


def better_stonesoup(path=bt.OUT):
    """Stone Soup's tracker with the lower mean GOSPA in the scored table (None: no table)."""
    if not Path(path).exists():
        return None
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["tracker"] in ("gnn", "jpda")]
    means = {t: np.mean([float(r["mean_gospa"]) for r in rows if r["tracker"] == t])
             for t in {r["tracker"] for r in rows}}
    return min(means, key=means.get) if means else None


def _job(job):
    tracker, seed, duration, name, value, reports = job
    if tracker in ("gnn", "jpda"):
        kw = dict(trk.STONESOUP_SETTINGS[tracker])
        s = kw["settings"]
        kw["settings"] = dataclasses.replace(s, m=int(value), n=max(s.n, int(value)))
        h = trk.stonesoup_track(*reports, tracker=tracker, **kw)
    else:
        base = trk.IMM_SETTINGS if tracker == "ours_imm" else trk.TrackerSettings()
        h = trk.track_reports(*reports, settings=dataclasses.replace(base, p_false_confirm=value))
    m = bt.score(h, duration)
    return {"tracker": tracker, "seed": seed, "threshold_name": name, "threshold": value,
            "false_tracks_per_hour": round(float(m.false_tracks_per_hour), 3),
            "mean_latency": round(float(m.mean_latency), 3),
            "mean_gospa": round(float(m.mean_gospa), 2)}


def curve(rows, tracker):
    """The tracker's curve: (threshold, mean false tracks/h, mean latency) per threshold,
    means over the seeds, in the sweep's order."""
    values = list(dict.fromkeys(r["threshold"] for r in rows if r["tracker"] == tracker))
    out = []
    for v in values:
        mine = [r for r in rows if r["tracker"] == tracker and r["threshold"] == v]
        out.append((v, float(np.mean([r["false_tracks_per_hour"] for r in mine])),
                    float(np.mean([r["mean_latency"] for r in mine]))))
    return out


def fewest_false_within(points, latency):
    """The fewest false tracks/h on the polyline through `points` ((f, l) in order) at
    latency <= `latency`, interpolating linearly along each segment; None if the polyline
    never has a latency that small."""
    best = None
    cands = [f for f, lat in points if lat <= latency]
    for (f0, l0), (f1, l1) in itertools.pairwise(points):
        if (l0 - latency) * (l1 - latency) < 0:             # the segment crosses `latency`
            cands.append(f0 + (f1 - f0) * (latency - l0) / (l1 - l0))
    if cands:
        best = min(cands)
    return best


def main(seeds=5, stonesoup=None, quick=False, out=None, workers=2, ours_only=False) -> int:
    """Run the sweep; `ours_only`: ours' curves only (no Stone Soup runs, no verdict)."""
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}")
    stonesoup = stonesoup or better_stonesoup() or "gnn"
    duration = 600.0 if quick else 3600.0
    seed_list = [bt.SEED + k for k in range(max(1, seeds))]
    print(f"scored hour{' (first 10 min)' if quick else ''}, seeds {seed_list}; Stone Soup's "
          f"tracker: {stonesoup}", flush=True)
    scene = bt._scene()
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = []
        for seed in seed_list:
            _, reports = bt.detections(scene["traffic"], scene["radars"], duration, seed)
            print(f"seed {seed} simulated at {time.perf_counter() - t0:.0f} s", flush=True)
            jobs = [] if ours_only else [(stonesoup, seed, duration, "min_points", k, reports)
                                         for k in MIN_POINTS]
            jobs += [(t, seed, duration, "p_false_confirm", a, reports) for t in ("ours_imm", "ours_cv")
                     for a in ALPHAS]
            futures += [pool.submit(_job, j) for j in jobs]
        rows = bt.gather(futures, lambda r: (
            f"  {r['tracker']:<9}{r['seed']:>5} {r['threshold_name']} {r['threshold']:<8g} "
            f"false/h {r['false_tracks_per_hour']:6.1f}  latency {r['mean_latency']:5.1f} s  "
            f"GOSPA {r['mean_gospa']:6.0f} m"))
    bt.write_unless_quick(rows, COLUMNS, out, quick, OUT)
    print(f"\ncurves (means over {len(seed_list)} seed{'s' * (len(seed_list) > 1)}; total "
          f"{time.perf_counter() - t0:.0f} s):")
    curves = {t: curve(rows, t) for t in ("ours_imm", "ours_cv", stonesoup)}
    for t, c in curves.items():
        print(f"  {t}: " + "; ".join(f"{v:g}: {f:.1f}/h {lat:.1f} s" for v, f, lat in c))
    if ours_only:
        print("(ours only: no Stone Soup curve, no verdict)")
        return 0
    for ours in ("ours_imm", "ours_cv"):
        points = [(f, lat) for _, f, lat in curves[ours]]
        below = True
        print(f"\n{ours} against Stone Soup {stonesoup} (each Stone Soup point: ours' fewest "
              f"false tracks/h at no more latency):")
        for v, f, lat in curves[stonesoup]:
            best = fewest_false_within(points, lat)
            ok = best is not None and best <= f
            below &= ok
            reach = "never that fast" if best is None else f"{best:.1f}/h"
            print(f"  min_points {v:g}: Stone Soup {f:.1f}/h at {lat:.1f} s; ours {reach} "
                  f"-> {'reached' if ok else 'NOT reached'}")
        print(f"{'PASS' if below else 'MISS'}  {ours}'s curve lies below Stone Soup "
              f"{stonesoup}'s")
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5,
                        help="seeds 2018, 2019, ... (default 5)")
    parser.add_argument("--stonesoup", choices=("gnn", "jpda"), default=None,
                        help="Stone Soup's tracker (default: the better in the scored table)")
    parser.add_argument("--quick", action="store_true", help="ten minutes instead of the hour")
    parser.add_argument("--out", default=None, help="the table's path")
    parser.add_argument("--ours-only", action="store_true",
                        help="ours' curves only (Stone Soup not run, no verdict)")
    args = parser.parse_args()
    sys.exit(main(seeds=args.seeds, stonesoup=args.stonesoup, quick=args.quick, out=args.out,
                  workers=min(2, os.cpu_count() or 1), ours_only=args.ours_only))
