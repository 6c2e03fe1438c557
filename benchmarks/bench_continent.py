"""Benchmark: the continental hour on one core and on Dask by sectors, and how its cost grows.

Run as ``python benchmarks/bench_continent.py [--scale 100] [--duration 3600]
[--sectors 3 3] [--overlap 30000] [--slope-scales 1 10 100] [--slope-duration 600]
[--no-dask] [--csv DIR]``. Everything is measured in this run, one thread per process
(``OPENBLAS_NUM_THREADS=1`` and friends are set before numpy is imported). Every tracker
of the run (one core, sectors, slope) uses the settings :data:`SETTINGS`:

1. **The scene.** ``continent.continent_scenario(scale, rng=2026)`` (``40 * scale`` aircraft
   airborne at once over Europe, 60 radars at the sites planned for double coverage of the
   traffic, with their own periods, phases, frames, noise, biases and clutter). The radars'
   biases are estimated from the first five minutes of reports
   (``continent.register_continent``) and the hour's reports are converted with that
   estimate (``simulate_continent(..., bias_estimate=...)``, rng 2027), simulated in windows
   of 15 minutes (``simulate_pieces``: the same reports as one call, each window under the
   memory limit).
2. **One core.** ``tracking.track_reports`` over the whole continent (:data:`SETTINGS`,
   ``continent.CONTINENT_SETTINGS``: constant velocity, GNN, the continental radars' design
   values and the knobs chosen by the tuning protocol on the continental tuning hour,
   ``tune_continent.py``), wall clock in this process.
3. **Sectors.** ``continent.track_sectored`` on ``sector_grid(position, *sectors,
   overlap=..., spacing="reports")`` (default 3 x 3 sectors whose columns and rows hold equal
   numbers of reports, 30 km overlap) in this process, and on a
   ``LocalCluster(n_workers=2, threads_per_worker=1, processes=True)`` started and warmed
   before the clock starts (``bench_sectors.start_cluster``: its workers keep glibc's
   memory-trimming rule); "identical" is every field of the two answers equal bit for bit.
   Printed with them: the speed-ups of the Dask run over the in-process sectored run and
   over the one tracker, and the **serial fraction** of the in-process sectored run (its
   time outside the sectors' own runs, which are timed one by one: validation, the split
   counts and the hand-over), with the time Amdahl's law then allows on 2 workers, the
   serial part plus the longest-first schedule of the measured sector runs on 2 workers.
4. **Scores.** The one tracker's history and the sectored one are scored by
   ``tracking.evaluate_tracks`` against ``continent.truth_samples(sc, times)`` (the aircraft
   inside some radar's coverage) at ``times`` every 30 s from 60 s, GOSPA c = 2000 m, p = 2
   (its exact sparse assignment: the pairs closer than c split the instant into small
   independent problems), by ``score_visible``: each stretch an aircraft spends in coverage
   is a target of its own, because ``evaluate_tracks`` interpolates a target between its
   first and last samples and would otherwise score an aircraft across a gap in coverage,
   where the Swiss scoring (the truth of each instant in coverage) has none. Printed: mean
   GOSPA; GOSPA per aircraft, the root of the mean over
   the instants of GOSPA^2 over the number of aircraft in the truth then (comparable across
   traffic levels, where GOSPA itself grows as the root of the aircraft count); tracks per
   aircraft (the distinct tracks over all the stretches of an aircraft, so an aircraft that
   leaves every coverage and comes back counts its new track); false tracks per hour; the
   tracks beyond an aircraft's first per hour of aircraft followed (``new_tracks_per_hour``:
   tracks per aircraft grow with how long each aircraft is followed, and a continental
   aircraft is followed over its whole flight); and the sectoring cost, the relative
   difference of the mean GOSPA, sectored against one tracker. For comparison, the same
   GOSPA per aircraft, tracks per aircraft and tracks beyond the first per hour of the Swiss
   scored hour (the pipeline of ``bench_tracking.py``: seed 2018, ``TrackerSettings()``, the
   settings the same protocol chose on the Swiss tuning hour,
   ``tracking.evaluate_tracks_over_time`` every 10 s from 60 s in the radars' coverage).
5. **Slope.** For each scale of ``--slope-scales`` the same pipeline over the first
   ``--slope-duration`` seconds, one tracker on one core: seconds against reports, and the
   least-squares slope of log(seconds) against log(reports) (1: cost linear in the reports;
   2: in their square). The cost per report's own slope against the traffic is that slope
   minus 1 times the reports' slope against the scale, printed beside it.

The last line is exactly::

    continent hour: <aircraft> aircraft <radars> radars one core <s> s | dask 2 workers <s> s identical <yes|no> | slope <x> | GOSPA/aircraft <m> m (Swiss <m> m) tracks/aircraft <x> (Swiss <x>) | sectoring <+x.x> %

with the aircraft airborne at the window's middle (``continent.airborne_count``), the one-core
time of step 2, the Dask time of step 3, the slope of step 5, and the one tracker's GOSPA per
aircraft and tracks per aircraft (the Swiss hour's beside each) and the sectoring cost of step 4. The machine has 2 cores;
timings on a loaded machine are longer: read them with the load average printed first (at
the start, and again after the Dask run). Linux shares the cores between sessions first
(``/proc/sys/kernel/sched_autogroup_enabled``): while another session keeps a core busy,
this run's session gets its share however many processes it has, so the two workers then
run hardly faster than one process; the Dask speed-up is measured on an idle machine only.

With ``--csv DIR`` two files are written for the book: ``DIR/continent_hour.csv``
(columns ``quantity,value``; rows ``aircraft, radars, reports, one_core_s, sectored_s,
dask_s, identical, slope, gospa_per_aircraft_m, swiss_gospa_per_aircraft_m,
tracks_per_aircraft, swiss_tracks_per_aircraft, new_tracks_per_aircraft_hour,
swiss_new_tracks_per_aircraft_hour, sectoring_pct, load_average, duration_s``: ``identical`` yes or no,
``load_average`` the 1-minute load at the start, ``duration_s`` the window) and
``DIR/continent_scaling.csv`` (columns ``scale,aircraft,reports,seconds``: the slope's
runs, aircraft airborne at the middle of their window).
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
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_sectors as bs  # noqa: E402  (the sectored runs' helpers)

from radarfusion_ref import continent as ct  # noqa: E402
from radarfusion_ref import tracking as trk  # noqa: E402
from radarfusion_ref.continent import sectors as ct_sectors  # noqa: E402

#: The tracker settings of every run (one core, sectors, slope): change them here.
SETTINGS = ct.CONTINENT_SETTINGS

SEED = 2026
PIECE = 900.0                                       # s of reports simulated at a time
WARMUP = 300.0                                      # s of reports for the registration
C_CUT, P_ORDER, STEP, FIRST = 2000.0, 2.0, 30.0, 60.0   # GOSPA (m) and the scored instants (s)


def scene(scale, duration):
    """The scenario and its reports over [0, duration), registered from the first minutes."""
    sc = ct.continent_scenario(scale, duration=max(duration, WARMUP), rng=SEED)
    first = ct.simulate_continent(sc, start=0.0, duration=WARMUP, rng=SEED + 1)
    est = ct.register_continent(sc, first).biases
    return sc, simulate_pieces(sc, duration, bias_estimate=est, rng=SEED + 1)


def simulate_pieces(sc, duration, *, piece=PIECE, **kwargs):
    """``simulate_continent`` over [0, duration) in windows of `piece` seconds, joined:
    every scan draws from its own stream, so the reports equal one whole-window call's
    (each window stays under the memory limit; the joined arrays are the tracker's)."""
    parts = [ct.simulate_continent(sc, start=a, duration=min(piece, duration - a), **kwargs)
             for a in np.arange(0.0, duration, piece)]
    if len(parts) == 1:
        return parts[0]
    cols = {f.name: np.concatenate([getattr(p, f.name) for p in parts])
            for f in dataclasses.fields(parts[0]) if f.name not in ("start", "duration")}
    return dataclasses.replace(parts[0], duration=duration, **cols)


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
    """``(TrackingMetrics, tracks per aircraft)`` of a continental history against the truth
    some radar covers at each instant (``score_visible``)."""
    times = np.arange(FIRST, duration, STEP)
    return score_visible(history, ct.truth_samples(sc, times), times)


def visible_stretches(truth_time, truth_id, times):
    """A new identity for each stretch of an aircraft's samples at consecutive `times`
    (``truth_samples`` leaves out the instants it is outside every coverage, and
    ``evaluate_tracks`` interpolates a target between its first and last sample: one
    identity per stretch keeps its truth set to the aircraft some radar covers)."""
    ti = np.searchsorted(times, truth_time)
    order = np.lexsort((ti, truth_id))
    new = np.ones(truth_id.size, bool)
    same = truth_id[order][1:] == truth_id[order][:-1]
    new[1:] = ~same | (np.diff(ti[order]) > 1)
    stretch = np.empty(truth_id.size, np.int64)
    stretch[order] = np.cumsum(new) - 1
    return stretch


def score_visible(history, truth, times, *, max_age=15.0):
    """Score a history against the truth some radar covers at each instant, never
    interpolated across a coverage gap: ``(metrics, tracks per aircraft)``, the metrics of
    ``evaluate_tracks`` with one target per stretch in coverage (GOSPA and its parts
    exact), and the distinct tracks per aircraft over all its stretches."""
    tt, tx, tid = truth
    stretch = visible_stretches(tt, tid, times)
    m = trk.evaluate_tracks(history, tt, tx, stretch, c=C_CUT, p=P_ORDER,
                            times=times, max_age=max_age)
    pairs = aircraft_track_pairs(m, aircraft_of_targets(m, truth, times))
    per = np.unique(pairs[:, 0], return_counts=True)[1]
    return m, float(per.mean()) if per.size else float("nan")


def aircraft_of_targets(m, truth, times):
    """The aircraft of each target (stretch) of ``score_visible``'s metrics `m`."""
    _, _, tid = truth
    stretch = visible_stretches(truth[0], tid, times)
    owner = np.zeros(int(stretch.max()) + 1, np.int64)
    owner[stretch] = tid
    return owner[m.truth_id]


def aircraft_track_pairs(m, aircraft):
    """The distinct (aircraft, track) pairs GOSPA's assignment made at some instant."""
    a, j = np.nonzero(m.track_of >= 0)
    return np.unique(np.stack([aircraft[a], m.track_of[a, j]], -1), axis=0)


def new_tracks_per_hour(m, aircraft=None):
    """Tracks beyond an aircraft's first, per hour of aircraft paired with a track: the
    tracks per aircraft made independent of how long each aircraft is followed (an aircraft
    of the continent is followed over its whole flight, one of the Swiss hour while it
    crosses the country). `aircraft`: the aircraft of each target (default: the targets)."""
    rows = np.arange(m.track_of.shape[0]) if aircraft is None else aircraft
    pairs = aircraft_track_pairs(m, rows)
    extra = pairs.shape[0] - np.unique(pairs[:, 0]).size
    hours = np.count_nonzero(m.track_of >= 0) * float(np.median(np.diff(m.times))) / 3600.0
    return extra / hours


def swiss_scores():
    """GOSPA per aircraft and tracks per aircraft of the Swiss scored hour
    (``bench_tracking.py``'s pipeline)."""
    import bench_tracking as bt

    s = bt._scene()
    _, reports = bt.detections(s["traffic"], s["radars"], 3600.0, bt.SEED)
    m = bt.score(bt.run_tracker("ours_cv", reports), 3600.0)
    return gospa_per_aircraft(m), m.tracks_per_aircraft, new_tracks_per_hour(m)


def slope(x, y):
    """Least-squares slope of log y against log x."""
    return float(np.polyfit(np.log(x), np.log(y), 1)[0])


def sectored_timed(rep, grid):
    """The in-process sectored run, its wall clock, and each sector's own run time (the
    sectors' runs wrapped by a timer for this call only)."""
    inner, seconds = ct_sectors.run_sector, []

    def timed_run(*a, **k):
        out, s = bs.timed(lambda: inner(*a, **k))
        seconds.append(s)
        return out

    ct_sectors.run_sector = timed_run
    try:
        sec, total = bs.timed(lambda: ct.track_sectored(*args_of(rep), sectors=grid,
                                                        settings=SETTINGS))
    finally:
        ct_sectors.run_sector = inner
    return sec, total, np.array(seconds)


def longest_first(seconds, workers=2):
    """Makespan of the jobs `seconds` on `workers`, each next longest job on the first free."""
    load = np.zeros(workers)
    for s in np.sort(seconds)[::-1]:
        load[np.argmin(load)] += s
    return float(load.max())


def write_csv(directory, hour, scaling):
    """``continent_hour.csv`` (quantity, value) and ``continent_scaling.csv``."""
    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    with open(d / "continent_hour.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(("quantity", "value"))
        w.writerows(hour)
    with open(d / "continent_scaling.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(("scale", "aircraft", "reports", "seconds"))
        w.writerows(scaling)
    print(f"wrote {d / 'continent_hour.csv'} and {d / 'continent_scaling.csv'}")


def main(scale=100.0, duration=3600.0, sectors=(3, 3), overlap=30e3,
         slope_scales=(1.0, 10.0, 100.0), slope_duration=600.0, dask=True, csv_dir=None):
    load = os.getloadavg()
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}; load average "
          f"{' '.join(f'{v:.2f}' for v in load)}")
    t0 = time.perf_counter()
    sc, rep = scene(scale, duration)
    n_air = int(ct.airborne_count(sc, [duration / 2])[0])
    n_false = int(np.sum(rep.aircraft < 0))
    print(f"scene: scale {scale:g}, {n_air} aircraft airborne at {duration / 2:.0f} s, "
          f"{len(sc.radars)} radars, {rep.time.size} reports ({n_false} false), "
          f"{time.perf_counter() - t0:.1f} s to simulate and register")

    one, s_one = bs.timed(lambda: trk.track_reports(*args_of(rep), settings=SETTINGS))
    print(f"one core, one tracker: {s_one:.1f} s ({duration / s_one:.1f} x real time, "
          f"{1e6 * s_one / rep.time.size:.1f} us/report), {int(one.n_confirmed)} confirmed "
          "tracks")
    grid = ct.sector_grid(rep.position, *sectors, overlap=overlap, spacing="reports")
    sec, s_sec, s_k = sectored_timed(rep, grid)
    serial = s_sec - s_k.sum()
    amdahl = serial + longest_first(s_k)
    print(f"sectored {sectors[0]} x {sectors[1]} ({overlap / 1e3:g} km overlap), one "
          f"process: {s_sec:.1f} s, {int(sec.handovers.sum())} hand-overs; sector runs "
          f"{' '.join(f'{v:.1f}' for v in s_k)} s (sum {s_k.sum():.1f} s), serial part "
          f"{serial:.1f} s = {100 * serial / s_sec:.1f} %; Amdahl on 2 workers (serial + "
          f"longest-first schedule) {amdahl:.1f} s = x{s_sec / amdahl:.2f}")
    (r_one, r_sec), s_score = bs.timed(lambda: (score(sc, one, duration),
                                                score(sc, sec.history, duration)))
    (m_one, tpa_one), (m_sec, tpa_sec) = r_one, r_sec
    for name, m, tpa in (("one tracker", m_one, tpa_one), ("sectored", m_sec, tpa_sec)):
        print(f"scores, {name}: mean GOSPA {m.mean_gospa:.0f} m, GOSPA/aircraft "
              f"{gospa_per_aircraft(m):.0f} m, tracks/aircraft {tpa:.3f}, "
              f"false tracks/h {m.false_tracks_per_hour:.1f}")
    cost = 100.0 * (m_sec.mean_gospa - m_one.mean_gospa) / m_one.mean_gospa
    swiss, swiss_tpa, swiss_new = swiss_scores()
    cont_new = new_tracks_per_hour(m_one, aircraft_of_targets(
        m_one, ct.truth_samples(sc, m_one.times), m_one.times))
    print(f"sectoring cost {cost:+.1f} % of mean GOSPA; Swiss scored hour GOSPA/aircraft "
          f"{swiss:.0f} m, tracks/aircraft {swiss_tpa:.4f}; {s_score:.1f} s to score both")
    print(f"tracks beyond an aircraft's first per hour of aircraft followed: continent "
          f"{cont_new:.4f}, Swiss hour {swiss_new:.4f}")
    s_dask, identical = float("nan"), "no"
    if dask:
        cluster, client = bs.start_cluster()
        try:
            dsk, s_dask = bs.timed(lambda: ct.track_sectored(*args_of(rep), sectors=grid,
                                                             settings=SETTINGS, client=client))
        finally:
            client.close()
            cluster.close()
        identical = "yes" if bs.same(sec, dsk) else "no"
        print(f"sectored on Dask, 2 workers: {s_dask:.1f} s (x{s_sec / s_dask:.2f} over one "
              f"process, x{s_one / s_dask:.2f} over one tracker; Amdahl's {amdahl:.1f} s "
              f"plus {s_dask - amdahl:.1f} s of transfer and scheduling), identical "
              f"{identical}; load average now {os.getloadavg()[0]:.2f}")

    n_rep, secs, scaling = [], [], []
    for s in slope_scales:
        sc_s, r = scene(s, slope_duration)
        _, sec_s = bs.timed(lambda r=r: trk.track_reports(*args_of(r), settings=SETTINGS))
        n_rep.append(r.time.size)
        secs.append(sec_s)
        scaling.append((f"{s:g}", int(ct.airborne_count(sc_s, [slope_duration / 2])[0]),
                        r.time.size, f"{sec_s:.3f}"))
        print(f"  scale {s:>6g}: {r.time.size:>9d} reports over {slope_duration:.0f} s, "
              f"{sec_s:7.2f} s, {1e6 * sec_s / r.time.size:6.1f} us/report")
    b = slope(n_rep, secs)
    per = (b - 1.0) * slope(slope_scales, n_rep)
    print(f"slope of seconds against reports {b:.2f}; of the cost per report against the "
          f"traffic {per:.2f}")
    print(f"continent hour: {n_air} aircraft {len(sc.radars)} radars one core {s_one:.1f} s "
          f"| dask 2 workers {s_dask:.1f} s identical {identical} | slope {b:.2f} "
          f"| GOSPA/aircraft {gospa_per_aircraft(m_one):.0f} m (Swiss {swiss:.0f} m) "
          f"tracks/aircraft {tpa_one:.4f} (Swiss {swiss_tpa:.4f}) | sectoring {cost:+.1f} %")
    if csv_dir is not None:
        write_csv(csv_dir, [
            ("aircraft", n_air), ("radars", len(sc.radars)), ("reports", rep.time.size),
            ("one_core_s", f"{s_one:.2f}"), ("sectored_s", f"{s_sec:.2f}"),
            ("dask_s", f"{s_dask:.2f}"), ("identical", identical), ("slope", f"{b:.3f}"),
            ("gospa_per_aircraft_m", f"{gospa_per_aircraft(m_one):.1f}"),
            ("swiss_gospa_per_aircraft_m", f"{swiss:.1f}"),
            ("tracks_per_aircraft", f"{tpa_one:.4f}"),
            ("swiss_tracks_per_aircraft", f"{swiss_tpa:.4f}"),
            ("new_tracks_per_aircraft_hour", f"{cont_new:.4f}"),
            ("swiss_new_tracks_per_aircraft_hour", f"{swiss_new:.4f}"),
            ("sectoring_pct", f"{cost:.3f}"), ("load_average", f"{load[0]:.2f}"),
            ("duration_s", f"{duration:g}")], scaling)
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
    p.add_argument("--csv", metavar="DIR", default=None,
                   help="write continent_hour.csv and continent_scaling.csv into DIR")
    a = p.parse_args()
    if len(set(a.slope_scales)) < 2:
        p.error(f"--slope-scales needs at least two different scales for a slope; "
                f"received {a.slope_scales}")
    sys.exit(main(a.scale, a.duration, tuple(a.sectors), a.overlap, tuple(a.slope_scales),
                  a.slope_duration, not a.no_dask, a.csv))
