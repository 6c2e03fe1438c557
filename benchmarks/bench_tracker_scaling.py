"""Benchmark: how the tracker's cost grows with the traffic (architecture (a), one process).

Run as ``OPENBLAS_NUM_THREADS=1 python benchmarks/bench_tracker_scaling.py [--max-tiles K]
[--trackers cv imm jpda] [--profile TRACKER]`` (one thread: the target is one core). The scene is the scored Swiss hour (``capstone.load_traffic()``, the
default realistic radars ``capstone.realistic_radars()``, ``simulate_detections(...,
rng=2018)``, registered from the first five minutes by ``capstone.register_detections`` and
converted by ``capstone.to_common``, as ``benchmarks/bench_tracking.py`` does) **tiled** K
times side by side: tile k's reports are shifted east by k x 700 km (beyond any radar's
range, so no gate links two tiles) and its radar numbers offset by 3k (the hour's three
radars), scans and instants unchanged. K tiles hold K times the aircraft, the radars and
the reports at the Swiss density, which is how a continent's traffic grows.

For K = 1, 2, 4, ... up to ``--max-tiles`` (default 32) and each tracker

* ``cv``: ``tracking.track_reports`` with ``TrackerSettings()`` (GNN, constant velocity);
* ``imm``: with ``tracking.IMM_SETTINGS`` (GNN, interacting multiple model);
* ``jpda``: with ``TrackerSettings(association="jpda")`` (constant velocity);

it prints the reports, the processor seconds of one call (``time.process_time``: this
process's own, which other jobs on a shared machine disturb far less than the wall clock;
the wall-clock seconds are printed beside them), the microseconds per report, and the
least-squares slope of log(seconds) against log(reports) over K >= 2 (1: the cost per
report does not grow with the traffic, the cost is linear in the reports; 2: the cost per
report grows like the traffic). Timings are of one run: compare the slope and the ratios,
not single numbers. ``--profile cv`` (or ``imm``, ``jpda``) runs that tracker once more at the largest
K under ``cProfile`` and prints the 25 most expensive functions (cumulative time).

The last line is exactly::

    tracker scaling: K <max> reports <n> cv <us>/report slope <x> | imm ... | jpda ...

The exit code is 0 (a benchmark, not a test).
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import sys
import time

import numpy as np

from radarfusion_ref import capstone as cp
from radarfusion_ref import tracking as trk

SEED = 2018
#: East shift between tiles (m): beyond any radar's range, so tiles never interact.
SHIFT = 700e3
#: Radars of one tile (the hour's three).
RADARS_PER_TILE = 3
SETTINGS = {"cv": trk.TrackerSettings(), "imm": trk.IMM_SETTINGS,
            "jpda": trk.TrackerSettings(association="jpda")}


def swiss_reports(seed=SEED):
    """The scored hour's reports in the common frame: (time, position, cov, radar, scan)."""
    radars = cp.realistic_radars()
    det = cp.simulate_detections(cp.load_traffic(), radars, duration=3600.0,
                                 mode="realistic", rng=seed)
    pos, cov = cp.to_common(det, radars, cp.register_detections(det, radars).biases)
    return det.time, pos, cov, det.radar, det.scan


def tile(reports, k_tiles, shift=SHIFT, radars=RADARS_PER_TILE):
    """`k_tiles` copies of `reports` side by side: copy k shifted east by ``k shift`` (m),
    its radar numbers offset by ``k radars``."""
    t, z, R, rad, sc = reports
    k = np.repeat(np.arange(k_tiles), t.size)
    zk = np.tile(z, (k_tiles, 1))
    zk[:, 0] += k * shift
    return (np.tile(t, k_tiles), zk, np.tile(R, (k_tiles, 1, 1)),
            np.tile(rad, k_tiles) + radars * k, np.tile(sc, k_tiles))


def slope(n, seconds):
    """Least-squares slope of log(seconds) against log(n) (nan with fewer than two points)."""
    n, s = np.asarray(n, float), np.asarray(seconds, float)
    if n.size < 2:
        return float("nan")
    return float(np.polyfit(np.log(n), np.log(s), 1)[0])


def main(max_tiles=32, trackers=("cv", "imm", "jpda"), profile=None) -> int:
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}")
    base = swiss_reports()
    ks = [1 << i for i in range(max(0, int(np.log2(max_tiles))) + 1)]
    print(f"the Swiss hour: {base[0].size} reports; tiles {ks}")
    print(f"{'tracker':<8}{'K':>4}{'reports':>10}{'s':>9}{'us/report':>11}{'wall s':>9}"
          f"{'tracks':>9}")
    result = {}
    for name in trackers:
        n_rep, secs = [], []
        for k in ks:
            rep = tile(base, k)
            t0, w0 = time.process_time(), time.perf_counter()
            h = trk.track_reports(*rep, settings=SETTINGS[name])
            s, wall = time.process_time() - t0, time.perf_counter() - w0
            n_rep.append(rep[0].size)
            secs.append(s)
            print(f"{name:<8}{k:>4}{rep[0].size:>10}{s:>9.2f}{1e6 * s / rep[0].size:>11.2f}"
                  f"{wall:>9.2f}{h.initiated:>9}", flush=True)
        big = [i for i, k in enumerate(ks) if k >= 2]
        sl = slope([n_rep[i] for i in big], [secs[i] for i in big])
        result[name] = (1e6 * secs[-1] / n_rep[-1], sl)
        print(f"{name}: slope of log(seconds) vs log(reports) over K >= 2: {sl:.3f}")
    if profile:
        rep = tile(base, ks[-1])
        prof = cProfile.Profile()
        prof.enable()
        trk.track_reports(*rep, settings=SETTINGS[profile])
        prof.disable()
        print(f"\nprofile of {profile} at K = {ks[-1]} ({rep[0].size} reports):")
        pstats.Stats(prof).sort_stats("cumulative").print_stats(25)
    parts = [f"{n} {result[n][0]:.2f}/report slope {result[n][1]:.2f}" for n in trackers]
    print(f"tracker scaling: K {ks[-1]} reports {base[0].size * ks[-1]} " + " | ".join(parts))
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-tiles", type=int, default=32,
                        help="largest number of tiles (powers of two up to it; default 32)")
    parser.add_argument("--trackers", nargs="+", choices=tuple(SETTINGS),
                        default=list(SETTINGS), help="trackers to run (default all three)")
    parser.add_argument("--profile", choices=tuple(SETTINGS), default=None,
                        help="profile this tracker at the largest K")
    args = parser.parse_args()
    sys.exit(main(args.max_tiles, tuple(args.trackers), args.profile))
