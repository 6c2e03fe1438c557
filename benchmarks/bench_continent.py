"""Benchmark: the continental hour on one core and on Dask by sectors, and how its cost grows.

Run as ``python benchmarks/bench_continent.py [--scale 100] [--duration 3600]
[--sectors 3 3] [--overlap 30000] [--slope-scales 1 10 100] [--slope-duration 600]
[--no-dask]``. Everything is measured in this run, one thread per process
(``OPENBLAS_NUM_THREADS=1`` and friends are set before numpy is imported):

1. **The scene.** ``continent.continent_scenario(scale, rng=2026)`` (``40 * scale`` aircraft
   airborne at once over Europe, 36 radars with their own periods, phases, frames, noise,
   biases and clutter). The radars' biases are estimated from the first five minutes of
   reports (``continent.register_continent``) and the hour's reports are converted with that
   estimate (``simulate_continent(..., bias_estimate=...)``, rng 2027).
2. **One core.** ``tracking.track_reports`` over the whole continent (``TrackerSettings()``:
   constant velocity, GNN, the defaults tuned on the Swiss tuning hour), wall clock in this
   process.
3. **Sectors.** ``continent.track_sectored`` on ``sector_grid(position, *sectors,
   overlap=..., spacing="reports")`` (default 3 x 3 sectors whose columns and rows hold equal
   numbers of reports, 30 km overlap) in this process, and on a
   ``LocalCluster(n_workers=2, threads_per_worker=1, processes=True)`` started and warmed
   before the clock starts; "identical" is every field of the two answers equal bit for bit.
4. **Scores.** The one tracker's history and the sectored one are scored by
   ``tracking.evaluate_tracks`` against ``continent.truth_samples(sc, times)`` (the aircraft
   inside some radar's coverage) at ``times`` every 30 s from 60 s, GOSPA c = 2000 m, p = 2
   (its exact sparse assignment: the pairs closer than c split the instant into small
   independent problems). Printed: mean GOSPA; GOSPA per aircraft, the root of the mean over
   the instants of GOSPA^2 over the number of aircraft in the truth then (comparable across
   traffic levels, where GOSPA itself grows as the root of the aircraft count); tracks per
   aircraft; false tracks per hour; and the sectoring cost, the relative difference of the
   mean GOSPA, sectored against one tracker. For comparison, the same GOSPA per aircraft of
   the Swiss scored hour (the pipeline of ``bench_tracking.py``: seed 2018, ``TrackerSettings()``,
   ``tracking.evaluate_tracks_over_time`` every 10 s from 60 s in the radars' coverage).
5. **Slope.** For each scale of ``--slope-scales`` the same pipeline over the first
   ``--slope-duration`` seconds, one tracker on one core: seconds against reports, and the
   least-squares slope of log(seconds) against log(reports) (1: cost linear in the reports;
   2: in their square). The cost per report's own slope against the traffic is that slope
   minus 1 times the reports' slope against the scale, printed beside it.

The last line is exactly::

    continent hour: <aircraft> aircraft <radars> radars one core <s> s | dask 2 workers <s> s identical <yes|no> | slope <x> | GOSPA/aircraft <m> m (Swiss <m> m) tracks/aircraft <x> | sectoring <+x.x> %

with the aircraft airborne at the window's middle (``continent.airborne_count``), the one-core
time of step 2, the Dask time of step 3, the slope of step 5, and the one tracker's GOSPA per
aircraft (the Swiss hour's beside it), tracks per aircraft and the sectoring cost of step 4. The machine has 2 cores;
timings on a loaded machine are longer: read them with the load average printed first.
"""

from __future__ import annotations

import os

for _v in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_sectors as bs  # noqa: E402  (the sectored runs' helpers)

from radarfusion_ref import continent as ct  # noqa: E402
from radarfusion_ref import tracking as trk  # noqa: E402

SEED = 2026
WARMUP = 300.0                                      # s of reports for the registration
C_CUT, P_ORDER, STEP, FIRST = 2000.0, 2.0, 30.0, 60.0   # GOSPA (m) and the scored instants (s)


def scene(scale, duration):
    """The scenario and its reports over [0, duration), registered from the first minutes."""
    sc = ct.continent_scenario(scale, duration=max(duration, WARMUP), rng=SEED)
    first = ct.simulate_continent(sc, start=0.0, duration=WARMUP, rng=SEED + 1)
    est = ct.register_continent(sc, first).biases
    rep = ct.simulate_continent(sc, start=0.0, duration=duration, bias_estimate=est,
                                rng=SEED + 1)
    return sc, rep


def args_of(rep):
    return rep.time, rep.position, rep.cov, rep.radar, rep.scan


def gospa_per_aircraft(m):
    """Root of the mean over the instants with aircraft of GOSPA^2 / aircraft in the truth.

    The truth count at an instant is its assigned pairs plus its missed ones (each missed
    aircraft costs c^p / 2 of the missed part)."""
    assigned = np.sum(m.track_of >= 0, axis=0)
    n_truth = assigned + np.rint(2.0 * m.missed / m.c ** m.p).astype(int)
    ok = n_truth > 0
    return float(np.sqrt(np.mean(m.gospa[ok] ** 2 / n_truth[ok])))


def score(sc, history, duration):
    """``TrackingMetrics`` of a continental history against the visible truth."""
    times = np.arange(FIRST, duration, STEP)
    truth = ct.truth_samples(sc, times)
    return trk.evaluate_tracks(history, *truth, c=C_CUT, p=P_ORDER, times=times)


def swiss_gospa_per_aircraft():
    """GOSPA per aircraft of the Swiss scored hour (``bench_tracking.py``'s pipeline)."""
    import bench_tracking as bt

    s = bt._scene()
    _, reports = bt.detections(s["traffic"], s["radars"], 3600.0, bt.SEED)
    return gospa_per_aircraft(bt.score(bt.run_tracker("ours_cv", reports), 3600.0))


def slope(x, y):
    """Least-squares slope of log y against log x."""
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def main(scale=100.0, duration=3600.0, sectors=(3, 3), overlap=30e3,
         slope_scales=(1.0, 10.0, 100.0), slope_duration=600.0, dask=True):
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}; load average "
          f"{' '.join(f'{v:.2f}' for v in os.getloadavg())}")
    t0 = time.perf_counter()
    sc, rep = scene(scale, duration)
    n_air = int(ct.airborne_count(sc, [duration / 2])[0])
    n_false = int(np.sum(rep.aircraft < 0))
    print(f"scene: scale {scale:g}, {n_air} aircraft airborne at {duration / 2:.0f} s, "
          f"{len(sc.radars)} radars, {rep.time.size} reports ({n_false} false), "
          f"{time.perf_counter() - t0:.1f} s to simulate and register")

    one, s_one = bs.timed(lambda: trk.track_reports(*args_of(rep)))
    print(f"one core, one tracker: {s_one:.1f} s ({duration / s_one:.1f} x real time, "
          f"{1e6 * s_one / rep.time.size:.1f} us/report), {int(one.n_confirmed)} confirmed "
          "tracks")
    grid = ct.sector_grid(rep.position, *sectors, overlap=overlap, spacing="reports")
    sec, s_sec = bs.timed(lambda: ct.track_sectored(*args_of(rep), sectors=grid))
    print(f"sectored {sectors[0]} x {sectors[1]} ({overlap / 1e3:g} km overlap), one "
          f"process: {s_sec:.1f} s, {int(sec.handovers.sum())} hand-overs")
    (m_one, m_sec), s_score = bs.timed(lambda: (score(sc, one, duration),
                                                score(sc, sec.history, duration)))
    for name, m in (("one tracker", m_one), ("sectored", m_sec)):
        print(f"scores, {name}: mean GOSPA {m.mean_gospa:.0f} m, GOSPA/aircraft "
              f"{gospa_per_aircraft(m):.0f} m, tracks/aircraft {m.tracks_per_aircraft:.3f}, "
              f"false tracks/h {m.false_tracks_per_hour:.1f}")
    cost = 100.0 * (m_sec.mean_gospa - m_one.mean_gospa) / m_one.mean_gospa
    swiss = swiss_gospa_per_aircraft()
    print(f"sectoring cost {cost:+.1f} % of mean GOSPA; Swiss scored hour GOSPA/aircraft "
          f"{swiss:.0f} m; {s_score:.1f} s to score both")
    s_dask, identical = float("nan"), "no"
    if dask:
        cluster, client = bs.start_cluster()
        try:
            dsk, s_dask = bs.timed(lambda: ct.track_sectored(*args_of(rep), sectors=grid,
                                                             client=client))
        finally:
            client.close()
            cluster.close()
        identical = "yes" if bs.same(sec, dsk) else "no"
        print(f"sectored on Dask, 2 workers: {s_dask:.1f} s (x{s_sec / s_dask:.2f} over one "
              f"process, x{s_one / s_dask:.2f} over one tracker), identical {identical}")

    n_rep, secs = [], []
    for s in slope_scales:
        _, r = scene(s, slope_duration)
        _, sec_s = bs.timed(lambda r=r: trk.track_reports(*args_of(r)))
        n_rep.append(r.time.size)
        secs.append(sec_s)
        print(f"  scale {s:>6g}: {r.time.size:>9d} reports over {slope_duration:.0f} s, "
              f"{sec_s:7.2f} s, {1e6 * sec_s / r.time.size:6.1f} us/report")
    b = slope(n_rep, secs)
    per = (b - 1.0) * slope(slope_scales, n_rep)
    print(f"slope of seconds against reports {b:.2f}; of the cost per report against the "
          f"traffic {per:.2f}")
    print(f"continent hour: {n_air} aircraft {len(sc.radars)} radars one core {s_one:.1f} s "
          f"| dask 2 workers {s_dask:.1f} s identical {identical} | slope {b:.2f} "
          f"| GOSPA/aircraft {gospa_per_aircraft(m_one):.0f} m (Swiss {swiss:.0f} m) "
          f"tracks/aircraft {m_one.tracks_per_aircraft:.3f} | sectoring {cost:+.1f} %")
    return 0


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scale", type=float, default=100.0)
    p.add_argument("--duration", type=float, default=3600.0)
    p.add_argument("--sectors", type=int, nargs=2, default=(3, 3))
    p.add_argument("--overlap", type=float, default=30e3)
    p.add_argument("--slope-scales", type=float, nargs="+", default=(1.0, 10.0, 100.0))
    p.add_argument("--slope-duration", type=float, default=600.0)
    p.add_argument("--no-dask", action="store_true")
    a = p.parse_args()
    sys.exit(main(a.scale, a.duration, tuple(a.sectors), a.overlap, tuple(a.slope_scales),
                  a.slope_duration, not a.no_dask))
