"""Benchmark: what the radars' speed feature buys the tracker, with and without it.

Run as ``python benchmarks/bench_tracking_feature.py [--seeds N] [--quick]``. On the scored
hour (the detections of ``bench_tracking.py``: realistic radars, seeds 2018, 2019, ...,
registered from the first five minutes, in the common frame), ours with constant velocity
(``TrackerSettings()``) and ours with the IMM (``tracking.IMM_SETTINGS``) run at their tuned
settings twice: on the positions alone, and with each report's speed feature
(``track_reports(..., feature=, feature_var=)``, the radar's ``sigma_feature`` squared as its
variance; ``feature_density`` and ``q_feature`` at their defaults, which no scored run set).
Each run is scored by ``tracking.evaluate_tracks_over_time`` as in ``bench_tracking.py``.

It writes ``benchmarks/data/tracking_feature.csv`` (full hour only; one row per tracker,
feature use (``feature`` 0 or 1) and seed: the columns of ``tracking_scored.csv`` and
``feature``; and per tracker and seed a row ``feature`` ``1-0`` of the paired differences,
with minus without, for ``tracking.load_scored_runs``) and prints,
per tracker, the mean over the seeds of each metric without and with the feature and the
mean paired difference (with - without) with its 95 % Student-t interval. Stone Soup is
given no feature, so the tracking benchmark's comparison stays on positions alone.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_tracking as bt  # the scored benchmark's data, scoring and table

from radarfusion_ref import tracking as trk
from radarfusion_ref.engine.montecarlo import mean as mc_mean

OUT = Path(__file__).resolve().parent / "data" / "tracking_feature.csv"
COLUMNS = (*bt.COLUMNS, "feature")
SETTINGS = {"ours_cv": trk.TrackerSettings(), "ours_imm": trk.IMM_SETTINGS}
METRICS = ("mean_gospa", "false_tracks_per_hour", "mean_latency", "tracks_per_aircraft",
           "switches", "nees", "seconds")


def _job(job):
    tracker, seed, duration, use, reports, feature = job
    kw = dict(feature=feature[0], feature_var=feature[1]) if use else {}
    t0 = time.process_time()
    h = trk.track_reports(*reports, settings=SETTINGS[tracker], **kw)
    seconds = time.process_time() - t0
    row = bt.row_of(tracker, seed, seconds, bt.score(h, duration))
    row["feature"] = int(use)
    return row


def differences(rows):
    """Per tracker and seed, a row of the paired differences (with - without): ``feature``
    ``"1-0"``, so ``tracking.load_scored_runs(..., by=("tracker", "feature"))`` gives their
    means and intervals beside the two runs'."""
    by = {(r["tracker"], r["seed"], r["feature"]): r for r in rows}
    out = []
    for (tracker, seed, use), on in by.items():
        if use == 1:
            off = by[tracker, seed, 0]
            out.append({"tracker": tracker, "seed": seed, "feature": "1-0",
                        **{c: round(on[c] - off[c], 6) for c in bt.COLUMNS[2:]}})
    return out


def main(seeds=5, quick=False, out=None, workers=2) -> int:
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}")
    duration = 600.0 if quick else 3600.0
    seed_list = [bt.SEED + k for k in range(max(1, seeds))]
    scene = bt._scene()
    fvar = np.array([r.sigma_feature for r in scene["radars"]]) ** 2
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers) as pool:
        futures = []
        for seed in seed_list:
            det, reports = bt.detections(scene["traffic"], scene["radars"], duration, seed)
            feature = (det.feature, fvar[det.radar])
            futures += [pool.submit(_job, (t, seed, duration, use, reports, feature))
                        for t in SETTINGS for use in (False, True)]
        rows = bt.gather(futures, lambda r: (
            f"  {r['tracker']:<9}{r['seed']:>5} feature {r['feature']}  GOSPA "
            f"{r['mean_gospa']:6.0f} m  false/h {r['false_tracks_per_hour']:5.1f}  latency "
            f"{r['mean_latency']:5.2f} s  {r['seconds']:.1f} s"))
    rows += differences(rows)
    bt.write_unless_quick(rows, COLUMNS, out, quick, OUT)
    print(f"\nmeans over {len(seed_list)} seeds (total {time.perf_counter() - t0:.0f} s); "
          f"difference = with - without, mean [95 % interval]:")
    last = []
    for tracker in SETTINGS:
        print(f"{tracker}:")
        runs = {(use, c): [r[c] for r in rows if (r["tracker"], r["feature"]) == (tracker, use)]
                for use in (0, 1, "1-0") for c in METRICS}
        for col in METRICS:
            off, on = np.mean(runs[0, col]), np.mean(runs[1, col])
            d = mc_mean(runs["1-0", col])
            print(f"  {col:<22} {off:9.4g} -> {on:9.4g}   {d.estimate:+.4g} "
                  f"[{d.low:+.4g}, {d.high:+.4g}]")
        g_off, g = np.mean(runs[0, "mean_gospa"]), mc_mean(runs["1-0", "mean_gospa"])
        last.append(f"{tracker} GOSPA {100 * g.estimate / g_off:+.1f} % "
                    f"[{100 * g.low / g_off:+.1f}, {100 * g.high / g_off:+.1f}] false "
                    f"tracks/h {np.mean(runs[0, 'false_tracks_per_hour']):.1f} -> "
                    f"{np.mean(runs[1, 'false_tracks_per_hour']):.1f} latency "
                    f"{np.mean(runs[0, 'mean_latency']):.2f} -> "
                    f"{np.mean(runs[1, 'mean_latency']):.2f} s")
    print("speed feature: " + " | ".join(last))
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=5, help="seeds 2018, 2019, ... (default 5)")
    parser.add_argument("--quick", action="store_true", help="ten minutes instead of the hour")
    parser.add_argument("--out", default=None, help="the table's path")
    args = parser.parse_args()
    sys.exit(main(seeds=args.seeds, quick=args.quick, out=args.out,
                  workers=min(2, os.cpu_count() or 1)))
