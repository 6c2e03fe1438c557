"""Benchmark: the capstone's fusion centre on one full hour of real traffic.

Run as ``python benchmarks/bench_capstone.py [--quick]``. Everything is measured in
this run: the committed hour (2018-08-01 11:00–12:00 UTC over Switzerland, 360 scans
at 10 s) is simulated for the three default radars and run through the whole pipeline
(registration over the first 30 scans, debiased 3-D conversion, gate, S-D grouping with
dummies by the exact MILP, ML fusion, recognition; ``cp.PipelineSettings()``), then scored
(GOSPA, association, NEES, recognition); then the realistic radars (each its own period, phase and frame) over the same
window are simulated, registered and converted, printing the bias estimates against the
true biases and the reports' NEES before and after. It prints the per-stage wall times and
two ratios:

* the mean time per scan against the real-time budget of one scan period (10 s);
* the total against a baseline measured in the same run on the first scans: the same
  pipeline with the Lagrangian S-D solver (``PipelineSettings(method="lagrangian")``),
  per scan.

The target is the whole hour in under 60 s on a 2-core machine (printed as PASS/FAIL;
the exit code is 1 on FAIL). ``--quick`` runs 10 minutes instead of the hour.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from radarfusion_ref import capstone as cp

TARGET = 60.0          # seconds for the full hour
BASELINE_SCANS = 12    # scans timed with the Lagrangian solver


def main(quick: bool = False) -> int:
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}")
    duration = 600.0 if quick else 3600.0
    t0 = time.perf_counter()
    truth = cp.truth_scans(cp.load_traffic(), period=10.0, duration=duration)
    radars = cp.default_radars()
    reports = cp.simulate_reports(truth, radars, rng=2018)
    t_sim = time.perf_counter() - t0
    t1 = time.perf_counter()
    result = cp.run_pipeline(reports, radars)
    ev = cp.evaluate(result, truth, c=2000.0, p=2.0)
    total = time.perf_counter() - t1
    S = truth.n_scans
    print(f"\n{S} scans ({duration / 60:.0f} min), {truth.scan.size} aircraft positions, "
          f"{reports.r.size} reports ({int(np.sum(reports.source < 0))} false); "
          f"load + truth + simulation {t_sim:.2f} s")
    print(f"\n{'stage':<14}{'seconds':>9}{'share':>8}")
    for stage in (*cp.STAGES, "metrics"):
        print(f"{stage:<14}{ev.timings[stage]:>9.2f}{ev.timings[stage] / total:>8.1%}")
    print(f"{'total':<14}{total:>9.2f}")
    per_scan = total / S
    print(f"\nper scan {1000 * per_scan:.1f} ms; real-time budget {truth.period:.0f} s per scan: "
          f"ratio {per_scan / truth.period:.4f}")

    # baseline: the same pipeline, Lagrangian solver, on the first scans
    sub_truth = cp.truth_scans(cp.load_traffic(), period=10.0,
                               duration=BASELINE_SCANS * truth.period)
    sub = cp.simulate_reports(sub_truth, radars, rng=2018)
    times = {}
    for method in ("milp", "lagrangian"):
        t = time.perf_counter()
        cp.run_pipeline(sub, radars, cp.PipelineSettings(method=method, warmup=BASELINE_SCANS))
        times[method] = (time.perf_counter() - t) / BASELINE_SCANS
    print(f"baseline on the first {BASELINE_SCANS} scans: Lagrangian "
          f"{1000 * times['lagrangian']:.0f} ms/scan, MILP {1000 * times['milp']:.0f} ms/scan "
          f"(Lagrangian / MILP = {times['lagrangian'] / times['milp']:.1f}); the hour by the "
          f"Lagrangian would take about {times['lagrangian'] * S:.0f} s")

    parts = ev.parts_rms()
    print(f"\nGOSPA (c = {ev.c:g} m, p = {ev.p:g}, alpha = 2), mean over scans "
          f"{ev.mean_gospa:.0f} m; root-mean parts: localisation {parts['localisation']:.0f} m, "
          f"missed {parts['missed']:.0f} m, false {parts['false']:.0f} m")
    print(f"association: purity {ev.purity}, completeness {ev.completeness}")
    ne = ev.nees
    print(f"NEES (3 dof) mean {ne.mean:.3f} over {ne.count} objects, 95 % interval "
          f"[{ne.low:.3f}, {ne.high:.3f}]")
    print(f"recognition {ev.recognition}")
    b = result.biases
    est = ", ".join(f"{r.name} {b[i, 0]:+.1f} m / {np.degrees(b[i, 2]):+.3f} deg "
                    f"(true {r.bias_range:+.0f} / {np.degrees(r.bias_azimuth):+.2f})"
                    for i, r in enumerate(radars))
    print(f"registration: {est}")
    print("tracks over time: benchmarks/bench_tracking.py")
    realistic(duration, t_sim)
    if quick:
        return 0
    ok = total < TARGET
    print(f"\ntarget: the hour in < {TARGET:.0f} s: {total:.1f} s -> {'PASS' if ok else 'FAIL'}")
    return 0 if ok else 1


def realistic(duration: float, t_simple: float) -> None:
    """The realistic radars over the same window: detections, registration, conversion."""
    from radarfusion_ref.engine.metrics import nees

    traffic = cp.load_traffic()
    radars = cp.realistic_radars()
    t = time.perf_counter()
    det = cp.simulate_detections(traffic, radars, duration=duration, rng=2018)
    t_det = time.perf_counter() - t
    t = time.perf_counter()
    est = cp.register_detections(det, radars, warmup=300.0)
    t_reg = time.perf_counter() - t
    t = time.perf_counter()
    x, P = cp.to_common(det, radars, est.biases)
    t_conv = time.perf_counter() - t
    print(f"\nrealistic radars (own periods {[r.period for r in radars]} s, own frames): "
          f"{len(det)} reports simulated in {t_det:.2f} s ({t_det / t_simple:.2f} x the "
          f"simple mode's load + truth + simulation above), registered in {t_reg:.2f} s, "
          f"converted in {t_conv:.2f} s")
    for i, r in enumerate(radars):
        b, s = est.biases[i], est.crlb[i]
        print(f"  {r.name:<11} range offset {b[0]:+7.1f} +- {s[0]:4.1f} m (true "
              f"{r.bias_range:+.0f}), scale {1e6 * b[1]:+6.0f} +- {1e6 * s[1]:3.0f} ppm (true "
              f"{1e6 * r.bias_scale:+.0f}), azimuth {1e3 * b[2]:+6.3f} +- {1e3 * s[2]:.3f} mrad "
              f"(true {1e3 * r.bias_azimuth:+.3f})")
    real = det.aircraft >= 0
    times, inv = np.unique(det.time[real], return_inverse=True)
    pos, _ = cp.truth_at(traffic, times)
    truth = pos[det.aircraft[real], inv]
    x0, P0 = cp.to_common(det.subset(real), radars)
    print(f"  NEES (3 dof) of the converted reports: uncorrected "
          f"{nees(x0 - truth, P0).mean:.2f}, registered {nees(x[real] - truth, P[real]).mean:.2f}"
          f" over {int(real.sum())} reports")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="10 minutes instead of the hour")
    sys.exit(main(**vars(ap.parse_args())))
