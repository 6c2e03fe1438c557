"""Benchmark: what the interacting multiple model buys over one constant-velocity model.

Run as ``python benchmarks/bench_imm.py [--hour tuning|scored] [--quick] [--variants ...]``.
The detections are those of ``bench_tracking.py`` (realistic radars, seed 2018, registered
from the first five minutes, in the common frame); every run is architecture (a) with GNN and
is scored by ``tracking.evaluate_tracks_over_time`` every 10 s (GOSPA c = 2000 m, p = 2).
Besides GOSPA and the mean position NEES (3 for a consistent filter), it prints the position
error of confirmed rows in turns and in straight flight: each row against the nearest aircraft
(within 2 km) at the row's instant, the aircraft turning when its heading changes by more than
1 deg/s between 5 s before and 5 s after.

Choose settings on the tuning hour (``--hour tuning``); the scored hour only reports them.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from radarfusion_ref import capstone as cp
from radarfusion_ref import tracking as trk

SEED = 2018
C_CUT, P_ORDER, STEP = 2000.0, 2.0, 10.0

#: The runs compared (TrackerSettings keywords). "cv" and "imm" are the package's tuned
#: settings (``TrackerSettings()`` and ``tracking.IMM_SETTINGS``, chosen on the tuning hour by
#: ``benchmarks/tune_tracking.py``); "cv isotropic" and "imm isotropic" set the vertical
#: process noise and prior equal to the horizontal ones (one q for x, y and z); "cv
#: vertical 2" is the vertical model an experienced Stone Soup user sets up (vertical noise
#: 2 m²/s³, vertical-velocity prior 15 m/s), the tuning protocol's start point.
_IMM_FIELDS = ("motion", "imm_q", "imm_q_vertical", "imm_sojourn", "imm_probability",
               "speed_max_vertical", "p_false_confirm", "p_false_delete", "relink", "p_relink", "p_false_reject")
VARIANTS = {
    "cv": {},
    "cv isotropic": {"q_vertical": None, "speed_max_vertical": None},
    "cv vertical 2": {"q_vertical": 2.0, "speed_max_vertical": 15.0},
    "imm": {f: getattr(trk.IMM_SETTINGS, f) for f in _IMM_FIELDS},
    "imm isotropic": {"motion": "imm", "q_vertical": None, "speed_max_vertical": None},
}


def turn_errors(h, traffic, chunk=500):
    """Position error (m) and turn rate (deg/s) of the truth of each confirmed row."""
    rows = np.flatnonzero(h.confirmed)
    t_all = h.time[rows]
    err = np.full(rows.size, np.nan)
    rate = np.full(rows.size, np.nan)
    ut, inv = np.unique(t_all, return_inverse=True)
    for a in range(0, ut.size, chunk):
        tt = ut[a:a + chunk]
        pos, ok = cp.truth_at(traffic, tt)
        _, ok0, v0 = cp.truth_at(traffic, tt - 5.0, return_velocity=True)
        _, ok1, v1 = cp.truth_at(traffic, tt + 5.0, return_velocity=True)
        sel = np.flatnonzero((inv >= a) & (inv < a + tt.size))
        j = inv[sel] - a
        d = np.linalg.norm(pos[:, j] - h.state[rows[sel], None, :3].swapaxes(0, 1), axis=-1)
        d = np.where(ok[:, j], d, np.inf)
        ac = np.argmin(d, 0)
        best = d[ac, np.arange(sel.size)]
        near = best < C_CUT
        h0 = np.arctan2(v0[ac, j, 1], v0[ac, j, 0])
        h1 = np.arctan2(v1[ac, j, 1], v1[ac, j, 0])
        turn = np.abs(np.rad2deg(np.angle(np.exp(1j * (h1 - h0))))) / 10.0
        good = near & ok0[ac, j] & ok1[ac, j]
        err[sel[good]] = best[good]
        rate[sel[good]] = turn[good]
    return err, rate


def main(hour="tuning", quick=False, variants=None):
    """Print one line per run; `variants` maps names to TrackerSettings keywords."""
    traffic = cp.load_traffic(hour=hour)
    radars = cp.realistic_radars()
    duration = 600.0 if quick else 3600.0
    det = cp.simulate_detections(traffic, radars, duration=duration, rng=SEED)
    pos, cov = cp.to_common(det, radars, cp.register_detections(det, radars).biases)
    n_scans = int(np.unique(np.c_[det.radar, det.scan], axis=0).shape[0])
    reports = (det.time, pos, cov, det.radar, det.scan)
    times = np.arange(60.0, duration, STEP)
    print(f"{hour} hour, {duration / 60:.0f} min, {len(det)} reports, seed {SEED}")
    print(f"{'run':<16}{'s':>7}{'GOSPA':>7}{'loc':>6}{'trk/ac':>8}{'switch':>7}{'false':>6}"
          f"{'NEES':>6}{'turn m':>8}{'n turn':>7}{'str m':>7}")
    for name, kw in (VARIANTS if variants is None else variants).items():
        s = trk.TrackerSettings(**kw)
        t0 = time.perf_counter()
        h = trk.track_reports(*reports, settings=s)
        sec = time.perf_counter() - t0
        m = trk.evaluate_tracks_over_time(h, traffic, c=C_CUT, p=P_ORDER, times=times,
                                          radars=radars, scans=n_scans)
        err, rate = turn_errors(h, traffic)
        turning, straight = rate > 1.0, rate < 0.2
        print(f"{name:<16}{sec:>7.1f}{m.mean_gospa:>7.0f}"
              f"{np.sqrt(np.mean(m.localisation)):>6.0f}{m.tracks_per_aircraft:>8.3f}"
              f"{m.switches:>7d}{m.false_tracks:>6d}{m.nees.mean:>6.2f}"
              f"{np.mean(err[turning]):>8.0f}{int(turning.sum()):>7d}"
              f"{np.mean(err[straight]):>7.0f}", flush=True)
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hour", choices=("tuning", "scored"), default="tuning")
    parser.add_argument("--quick", action="store_true", help="ten minutes instead of the hour")
    parser.add_argument("--variants", nargs="*", choices=list(VARIANTS))
    args = parser.parse_args()
    chosen = {k: VARIANTS[k] for k in args.variants} if args.variants else None
    sys.exit(main(args.hour, args.quick, chosen))
