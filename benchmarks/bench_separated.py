"""Benchmark: Prosov's Table 1 experiment, vectorized vs a per-trial loop.

Run as ``python benchmarks/bench_separated.py [trials]``. It measures, in one run:

* the vectorized Monte Carlo :func:`radarfusion_ref.separated.association_experiment`
  on 10**6 trials (both targets, both methods — linearized and bias-corrected
  conversion — per-report gating and joint assignment), best of 3 runs;
* how that time splits between the conversion calls
  (:func:`radarfusion_ref.conversion.polar_to_cartesian`) and the rest;
* a straightforward per-trial Python loop doing the same work (conversion of
  the four reports, ``np.linalg.solve`` per pair, ``if`` decisions), timed on
  a small number of trials and scaled to 10**6;

and prints the absolute figures and the ratio. Target: < 2 s for 10**6 trials
on one core. Numerical libraries are pinned to one thread.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import itertools  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from radarfusion_ref import conversion, gating  # noqa: E402
from radarfusion_ref import separated as sep  # noqa: E402

METHODS = ("linearized", "additive")
OFFSET = (-0.5, -5.0)          # target 2's placement (km), near the fitted one of the chapter


def loop_experiment(geo, trials, rng):
    """The same experiment, one trial at a time in Python."""
    P = sep.PAPER
    sr, sb = P["sigma_r"], P["sigma_beta"]
    th = gating.gate_threshold(0.01, 2)
    th_joint = gating.gate_threshold(0.01, 4)
    (r1t, b1t), (r2t, b2t) = geo.polar1, geo.polar2
    p2 = geo.radar2
    n = len(r1t)
    per = np.zeros((len(METHODS), n, 3), dtype=int)
    joint = np.zeros((len(METHODS), 3), dtype=int)
    for _ in range(trials):
        r1 = r1t + sr * rng.standard_normal(n)
        b1 = b1t + sb * rng.standard_normal(n)
        r2 = r2t + sr * rng.standard_normal(n)
        b2 = b2t + sb * rng.standard_normal(n)
        for q, m in enumerate(METHODS):
            c1 = conversion.polar_to_cartesian(r1, b1, sr, sb, method=m)
            c2 = conversion.polar_to_cartesian(r2, b2, sr, sb, method=m)
            S = np.empty((n, n))
            LD = np.empty((n, n))
            for i in range(n):
                for j in range(n):
                    d = c1.xy[i] - (c2.xy[j] + p2)
                    C = c1.cov[i] + c2.cov[j]
                    S[i, j] = d @ np.linalg.solve(C, d)
                    LD[i, j] = np.linalg.slogdet(C)[1]
            for i in range(n):
                passing = [j for j in range(n) if S[i, j] < th]
                code = 2 if len(passing) != 1 else (0 if passing[0] == i else 1)
                per[q, i, code] += 1
            best, best_cost = None, math.inf
            for perm in itertools.permutations(range(n)):
                cost = sum(S[i, perm[i]] + LD[i, perm[i]] for i in range(n))
                if cost < best_cost:
                    best, best_cost = perm, cost
            if sum(S[i, best[i]] for i in range(n)) >= th_joint:
                joint[q, 2] += 1
            else:
                joint[q, 0 if best == tuple(range(n)) else 1] += 1
    return per, joint


def conversion_share(geo, trials, rng):
    """Time spent inside conversion.polar_to_cartesian during one experiment run.

    The function is wrapped with a timer for the run (and restored after), so
    the share is measured in place, with the experiment's own memory traffic.
    """
    original = conversion.polar_to_cartesian
    spent = [0.0]

    def timed(*args, **kwargs):
        t0 = time.perf_counter()
        try:
            return original(*args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - t0

    conversion.polar_to_cartesian = timed
    try:
        t0 = time.perf_counter()
        sep.association_experiment(geo, trials=trials, methods=METHODS, rng=rng)
        total = time.perf_counter() - t0
    finally:
        conversion.polar_to_cartesian = original
    return spent[0], total


def main(trials: int = 1_000_000, loop_trials: int = 1_000) -> None:
    geo = sep.paper_geometry(*OFFSET)
    rng = np.random.default_rng(2024)
    sep.association_experiment(geo, trials=10_000, rng=rng)          # warm-up
    runs = []
    for _ in range(3):
        t0 = time.perf_counter()
        res = sep.association_experiment(geo, trials=trials, methods=METHODS, rng=rng)
        runs.append(time.perf_counter() - t0)
    t_vec = min(runs)
    t_conv, t_total = conversion_share(geo, trials, rng)

    t0 = time.perf_counter()
    per, _ = loop_experiment(geo, loop_trials, rng)
    t_loop = (time.perf_counter() - t0) * trials / loop_trials

    print(f"Table 1 experiment, {trials:,} trials x 2 targets x {len(METHODS)} methods "
          f"(per-report gating + joint assignment), one core")
    print(f"  vectorized  : {t_vec:8.3f} s  (best of 3: {', '.join(f'{t:.3f}' for t in runs)})"
          f"  = {trials / t_vec / 1e6:.2f} M trials/s")
    print(f"     split, from one more timed run of {t_total:.3f} s: "
          f"conversion.polar_to_cartesian {t_conv:.3f} s ({t_conv / t_total:.0%}), "
          f"the rest (draws, S, decisions) {t_total - t_conv:.3f} s")
    print(f"  per-trial loop: {t_loop:8.1f} s  (measured on {loop_trials:,} trials, scaled)")
    print(f"  speed-up vectorized / loop: {t_loop / t_vec:,.0f}x")
    print(f"  target < 2 s: {'met' if t_vec < 2.0 else 'NOT met'}")
    lin = res["linearized"].per_report
    print(f"  (check) P_correct linearized, target 1: {lin.estimate[0, 0]:.4f} vectorized, "
          f"{per[0, 0, 0] / loop_trials:.4f} loop ({loop_trials} trials)")
    print(f"  load average at the end: {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000)
