"""Tune ours (constant velocity) on a continental tuning hour, by ``tune_tracking.py``'s protocol.

Run as ``python benchmarks/tune_continent.py [--scale 100] [--workers 2]``. It writes
``benchmarks/data/continent_tuning.csv`` (the columns of ``tracking_tuning.csv``) only if
every run of the search succeeded, and prints the choice; ``continent.CONTINENT_SETTINGS``
must hold it (a test checks the committed table against it; the script exits with 1 naming
every difference, or if a run failed).

The protocol is ``benchmarks/tune_tracking.py``'s for ours with the constant-velocity model,
unchanged but for the data and the false-track limit:

* Data: the continental tuning hour, never the scored one: ``continent.continent_scenario(
  scale, rng=2025)`` (the scored hour is seed 2026), the whole hour, ``bench_continent.py``'s
  pipeline (registration from the first five minutes, reports seed 2026, the truth
  ``continent.truth_samples`` every 30 s from 60 s, GOSPA c = 2000 m, p = 2, ``max_age``
  15 s), scored by ``bench_continent.score_visible``: ``tracking.evaluate_tracks`` with one target per
  stretch of an aircraft inside coverage, so that no instant outside every radar's
  coverage is scored (``evaluate_tracks`` interpolates a target between its first and last
  sample, across its gaps), and tracks per aircraft counted over the aircraft's stretches.
* Knobs, grids, start point, coordinate-wise single pass, budget (15 runs) and criterion:
  ``tune_tracking.GRIDS["ours_cv"]``, ``START["ours_cv"]``, ``criterion``; each run's
  settings are ``tune_tracking.settings_of`` with the scene's stated design values
  (``continent.CONTINENT_DESIGN``: clutter density and detection probability of the
  continental radars' draws) in place of the capstone's.
* Feasible: at most 1.05 tracks per aircraft and at most 12 false tracks per hour *per 40
  aircraft airborne* (the Swiss hour's limit per aircraft: ``12 * scale`` per hour here; a
  fixed 12 would be ten times stricter per aircraft at scale 10).
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import csv  # noqa: E402
import dataclasses  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import traceback  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_continent as bc  # noqa: E402
import tune_tracking as tt  # noqa: E402

from radarfusion_ref import continent as ct  # noqa: E402
from radarfusion_ref import tracking as trk  # noqa: E402

TUNING_SEED = 2025
WINDOW = 3600.0
OUT = Path(__file__).resolve().parent / "data" / "continent_tuning.csv"
TRACKER = "ours_cv"
GRIDS, START = tt.GRIDS[TRACKER], tt.START[TRACKER]
_DATA: dict = {}


def _data(scale):
    """The tuning hour's registered reports and truth (built once per process)."""
    if not _DATA:
        sc = ct.continent_scenario(scale, duration=WINDOW, rng=TUNING_SEED)
        first = ct.simulate_continent(sc, start=0.0, duration=bc.WARMUP, rng=bc.SEED)
        est = ct.register_continent(sc, first).biases
        rep = bc.simulate_pieces(sc, WINDOW, bias_estimate=est, rng=bc.SEED)
        times = np.arange(bc.FIRST, WINDOW, bc.STEP)
        _DATA.update(reports=bc.args_of(rep), times=times, truth=ct.truth_samples(sc, times))
    return _DATA


def settings_of(knobs):
    """The search's knobs on the continental design values."""
    return dataclasses.replace(tt.settings_of(TRACKER, knobs), **ct.CONTINENT_DESIGN)


def _run(job):
    knobs, step, scale = job
    row = {"tracker": TRACKER, "step": step, **{k: "" for k in tt.FIELDS[2:]}, **knobs,
           "status": "ok", "feasible": 0, "chosen": 0}
    try:
        d = _data(scale)
        t0 = time.perf_counter()
        h = trk.track_reports(*d["reports"], settings=settings_of(knobs))
        seconds = time.perf_counter() - t0
        m, per_aircraft = bc.score_visible(h, d["truth"], d["times"])
    except Exception as exc:                                   # recorded, the search goes on
        row.update(status="failed", error=f"{type(exc).__name__}: {exc}"[:300])
        traceback.print_exc()
        return row
    tt.record_scores(row, m, seconds, per_aircraft)
    row["gospa_per_aircraft"] = round(bc.gospa_per_aircraft(m), 1)
    return row


def per_scale(row, scale):
    """The row as ``tune_tracking.criterion`` reads it: false tracks per hour per 40
    aircraft airborne."""
    out = dict(row)
    if row["status"] == "ok":
        out["false_tracks_per_hour"] = float(row["false_tracks_per_hour"]) / scale
    return out


def search(scale, pool, log):
    """The coordinate-wise pass; returns its rows (chosen one marked)."""
    best = dict(START)
    done: dict[tuple, dict] = {}

    def key(knobs):
        return tuple(knobs[k] for k in GRIDS)

    def run_all(settings, step):
        todo = [s for s in settings if key(s) not in done]
        for s, row in zip(todo, pool.map(_run, [(s, step, scale) for s in todo]),
                          strict=True):
            done[key(s)] = row
            log(row)
        return [done[key(s)] for s in settings]

    def crit(row):
        return tt.criterion(per_scale(row, scale))

    run_all([best], "start")
    for knob, grid in GRIDS.items():
        rows = run_all([{**best, knob: v} for v in grid], knob)
        winner = min(rows, key=crit)
        best = {k: winner[k] for k in GRIDS}
    rows = list(done.values())
    if len(rows) > 1 + 2 * len(GRIDS):
        raise RuntimeError(f"the search ran {len(rows)} settings, over its budget")
    done[key(best)]["chosen"] = 1
    for r in rows:
        r["feasible"] = int(tt._feasible(per_scale(r, scale)))
    return rows


def chosen_knobs(path=OUT):
    """The chosen row's knobs, as numbers (``"off"`` kept)."""
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            if row["chosen"] == "1":
                return {k: tt._number(row[k]) for k in GRIDS}
    return None


def package_knobs():
    s = ct.CONTINENT_SETTINGS
    return {"q": s.q, "q_vertical": s.q_vertical, "speed_max_vertical": s.speed_max_vertical,
            "p_false_confirm": s.p_false_confirm, "p_false_delete": s.p_false_delete,
            "p_relink": s.p_relink if s.relink else "off", "p_false_reject": s.p_false_reject}


def main(scale, workers):
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}; continental tuning hour, "
          f"seed {TUNING_SEED}, scale {scale:g}; feasible: tracks/aircraft <= "
          f"{tt.MAX_TRACKS_PER_AIRCRAFT}, false tracks/h <= {tt.MAX_FALSE_PER_HOUR * scale:g}; "
          f"then mean GOSPA; load average {' '.join(f'{v:.2f}' for v in os.getloadavg())}",
          flush=True)
    t0 = time.perf_counter()

    def log(row):
        knobs = ", ".join(f"{k} {tt._fmt(row[k])}" for k in GRIDS)
        what = (f"FAILED {row['error']}" if row["status"] != "ok" else
                f"GOSPA {row['mean_gospa']:.0f} m ({row['gospa_per_aircraft']:.0f} m/aircraft),"
                f" trk/ac {row['tracks_per_aircraft']:.3f}, false/h "
                f"{row['false_tracks_per_hour']:.1f}, latency {row['mean_latency']:.1f} s, "
                f"{row['seconds']:.0f} s")
        print(f"[{time.perf_counter() - t0:5.0f} s] ({row['step']}) {knobs}: {what}", flush=True)

    with ProcessPoolExecutor(max_workers=workers) as pool:
        rows = search(scale, pool, log)
    failed = [r for r in rows if r["status"] != "ok"]
    for r in failed:
        print(f"FAILED ({r['step']}): {r['error']}")
    if failed:
        print("the table is not written: a run failed")
        return 1
    fields = (*tt.FIELDS, "gospa_per_aircraft", "scale")
    OUT.parent.mkdir(exist_ok=True)
    with open(OUT, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows({k: r.get(k, "") for k in tt.FIELDS} | {
            "gospa_per_aircraft": r["gospa_per_aircraft"], "scale": scale} for r in rows)
    print(f"\nwrote {OUT}; total {time.perf_counter() - t0:.0f} s")
    chosen = chosen_knobs()
    r = next(r for r in rows if r["chosen"])
    print("chosen: " + ", ".join(f"{k} {tt._fmt(v)}" for k, v in chosen.items())
          + f" -> GOSPA {r['mean_gospa']:.0f} m, {r['gospa_per_aircraft']:.0f} m/aircraft, "
          f"{r['tracks_per_aircraft']:.3f} tracks/aircraft, {r['false_tracks_per_hour']:.1f} "
          f"false tracks/h")
    pk = package_knobs()
    wrong = [f"{k} tuned {v!r}, CONTINENT_SETTINGS has {pk[k]!r}" for k, v in chosen.items()
             if v != pk[k]]
    for line in wrong:
        print(f"MISMATCH {line}: update continent.CONTINENT_SETTINGS")
    return 1 if wrong else 0


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scale", type=float, default=100.0)
    p.add_argument("--workers", type=int, default=min(2, os.cpu_count() or 1))
    a = p.parse_args()
    sys.exit(main(a.scale, a.workers))
