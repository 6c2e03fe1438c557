"""Benchmark: the fusion centre by sectors against one tracker, in one process and on Dask.

Run as ``python benchmarks/bench_sectors.py [--quick] [--tiles 1 4] [--per-tile 2]
[--overlap 20000] [--no-dask]``. Everything is measured in this run. The scene is the
capstone's scored hour (2018-08-01 11:00-12:00 UTC over Switzerland, ``--quick``: its first
ten minutes) as ``benchmarks/bench_tracking.py`` builds it: ``capstone.load_traffic()``,
``capstone.realistic_radars()``, ``simulate_detections(..., mode="realistic", rng=2018)``,
``register_detections`` (from the first five minutes) and ``to_common``. To give the sectors
real work the hour is also tiled K times side by side (``--tiles``, default 1 and 4): tile k
is the hour's reports shifted east by k x 600 km, its radars numbered after the previous
tiles' and its aircraft likewise (the truth shifted and renumbered the same way); the tiles'
outer reports meet at their edges.

For each K the reports are tracked

* by one tracker over the whole area (``tracking.track_reports``, default settings);
* by ``continent.track_sectored`` over ``sector_grid(position, per_tile * K, 1,
  overlap=...)`` (default two sectors per tile, 20 km overlap), in this process;
* the same on ``LocalCluster(n_workers=2, threads_per_worker=1, processes=True)``, started
  and warmed (every worker has imported the package) before the clock starts;

and the run times (wall clock, each run once: the machine has 2 cores shared with other
programs, so the speed-ups are noisy — read them as orders of magnitude), the speed-ups over
the single tracker, whether the Dask answer equals the in-process sectored answer bit for
bit (every field of the history and the diagnostics), the hand-overs, and the GOSPA cost of
sectoring are printed. GOSPA: ``tracking.evaluate_tracks`` every 10 s from 60 s (c = 2000 m,
p = 2) against the traffic's truth (``capstone.truth_at``) inside the radars' coverage
(``capstone.coverage_count`` >= 1), an aircraft's stretches in coverage counted as separate
targets; the cost is the relative difference of the mean GOSPA, sectored against single
(target: at most 1 %). The last line is exactly::

    sectors: K=<k> <n> sectors | single <s> s | sectored <s> s (x<r>) | dask 2 workers <s> s (x<r>) identical <yes|no> | GOSPA single <m> m sectored <m> m (<d> %)

for the largest K.

Why sectoring can cost time: much of the tracker's cost is per scan (one radar at one
instant), and a scan whose reports fall in several sectors is processed once by each; what
it saves is the one tracker's work over all live tracks at every scan, which grows with the
scene. Which wins depends on the scene's size: the printed times say it for this run.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from radarfusion_ref import capstone as cp
from radarfusion_ref import tracking as trk
from radarfusion_ref.continent import sector_grid, track_sectored

SEED = 2018
SHIFT = 600e3                     # m between tiles
C_CUT, P_ORDER, STEP = 2000.0, 2.0, 10.0
FIELDS = ("track", "time", "state", "covariance", "confirmed")


def hour(duration):
    """The scored hour's reports in the common frame, the traffic and the radars."""
    traffic, radars = cp.load_traffic(), cp.realistic_radars()
    det = cp.simulate_detections(traffic, radars, duration=duration, mode="realistic",
                                 rng=SEED)
    pos, cov = cp.to_common(det, radars, cp.register_detections(det, radars).biases)
    return (det.time, pos, cov, det.radar, det.scan), traffic, radars


def truth(traffic, radars, times):
    """The truth at `times` inside the coverage: (time, position, id), each stretch of an
    aircraft in coverage its own id (no interpolation across a gap)."""
    pos, valid = cp.truth_at(traffic, times)
    seen = np.zeros(valid.shape, bool)
    seen[valid] = cp.coverage_count(pos[valid], radars) >= 1
    start = np.diff(np.c_[np.zeros((seen.shape[0], 1), bool), seen].astype(np.int8), axis=1) == 1
    stretch = np.cumsum(start, axis=1)
    a, j = np.nonzero(seen)
    return times[j], pos[a, j], a.astype(np.int64) * 1000 + stretch[a, j]


def tile(reports, truth_samples, k_tiles):
    """The reports and the truth tiled `k_tiles` times east, radars and aircraft renumbered."""
    t, z, R, radar, scan = reports
    tt, tp, ti = truth_samples
    n_radar, n_id = int(radar.max()) + 1, int(ti.max()) + 1
    shift = np.array([SHIFT, 0.0, 0.0])
    rep = tuple(np.concatenate(v) for v in zip(*(
        (t, z + k * shift, R, radar + k * n_radar, scan) for k in range(k_tiles)), strict=True))
    tru = tuple(np.concatenate(v) for v in zip(*(
        (tt, tp + k * shift, ti + k * n_id) for k in range(k_tiles)), strict=True))
    return rep, tru


def mean_gospa(history, tru, times):
    return float(trk.evaluate_tracks(history, *tru, c=C_CUT, p=P_ORDER, times=times).mean_gospa)


def timed(f):
    t0 = time.perf_counter()
    out = f()
    return out, time.perf_counter() - t0


def same(a, b):
    ok = all(np.array_equal(getattr(a.history, f), getattr(b.history, f)) for f in FIELDS)
    ok &= a.history.initiated == b.history.initiated
    return ok and all(np.array_equal(getattr(a, f), getattr(b, f))
                      for f in ("reports", "tracks", "handovers", "links", "link_cost"))


def start_cluster():
    """A warmed ``LocalCluster`` of two one-thread worker processes and its client.

    The workers keep glibc's own memory-trimming rule: Dask's default
    ``MALLOC_TRIM_THRESHOLD_=65536`` (set for the workers before they start) fixes the
    thresholds, so every array above 128 KiB is mapped and unmapped afresh, and a
    tracker's many short-lived arrays then cost it 5 to 20 % more CPU time on a worker
    than in this process (measured on the continental sectors)."""
    import dask
    import distributed

    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
        cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                           dashboard_address=None,
                                           scheduler_kwargs={"dashboard_address": ":0"})
    client = distributed.Client(cluster)
    client.wait_for_workers(2)
    client.run(lambda: __import__("radarfusion_ref.continent.sectors"))   # warm the workers
    return cluster, client


def main(quick=False, tiles=(1, 4), per_tile=2, overlap=20e3, dask=True):
    duration = 600.0 if quick else 3600.0
    reports, traffic, radars = hour(duration)
    times = np.arange(60.0, duration, STEP)
    base_truth = truth(traffic, radars, times)
    cluster, client = start_cluster() if dask else (None, None)
    print(f"scene: {'first 10 min' if quick else 'hour'}, {reports[0].size} reports per tile, "
          f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    line = ""
    try:
        for k in tiles:
            rep, tru = tile(reports, base_truth, k)
            grid = sector_grid(rep[1], per_tile * k, 1, overlap=overlap)
            single, t_single = timed(lambda rep=rep: trk.track_reports(*rep))
            sect, t_sect = timed(lambda rep=rep, grid=grid: track_sectored(*rep, sectors=grid))
            if dask:
                on, t_dask = timed(lambda rep=rep, grid=grid: track_sectored(
                    *rep, sectors=grid, client=client))
                ident = "yes" if same(on, sect) else "no"
            else:
                t_dask, ident = float("nan"), "n/a"
            g1, g2 = mean_gospa(single, tru, times), mean_gospa(sect.history, tru, times)
            rel = 100.0 * (g2 - g1) / g1
            print(f"K={k}: {rep[0].size} reports, {grid.n_sectors} sectors, overlap "
                  f"{overlap / 1e3:g} km, copies {int(sect.reports.sum())}, hand-overs "
                  f"{sect.links.shape[0]}, tracks single {single.n_confirmed} merged "
                  f"{sect.history.n_confirmed}")
            print(f"    single {t_single:.2f} s, sectored {t_sect:.2f} s "
                  f"(x{t_single / t_sect:.2f}), dask 2 workers {t_dask:.2f} s "
                  f"(x{t_single / t_dask:.2f}), identical {ident}; mean GOSPA single "
                  f"{g1:.2f} m, sectored {g2:.2f} m ({rel:+.3f} %, target <= 1 %: "
                  f"{'PASS' if abs(rel) <= 1.0 else 'MISS'})")
            line = (f"sectors: K={k} {grid.n_sectors} sectors | single {t_single:.2f} s | "
                    f"sectored {t_sect:.2f} s (x{t_single / t_sect:.2f}) | dask 2 workers "
                    f"{t_dask:.2f} s (x{t_single / t_dask:.2f}) identical {ident} | GOSPA "
                    f"single {g1:.2f} m sectored {g2:.2f} m ({rel:+.3f} %)")
    finally:
        if client is not None:
            client.close()
            cluster.close()
    print(line)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the first ten minutes only")
    ap.add_argument("--tiles", type=int, nargs="+", default=[1, 4])
    ap.add_argument("--per-tile", type=int, default=2, help="sector columns per tile")
    ap.add_argument("--overlap", type=float, default=20e3, help="m")
    ap.add_argument("--no-dask", action="store_true")
    a = ap.parse_args()
    main(a.quick, tuple(a.tiles), a.per_tile, a.overlap, not a.no_dask)
