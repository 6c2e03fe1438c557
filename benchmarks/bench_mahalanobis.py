"""Benchmark: the package's one squared Mahalanobis distance, every pair of a T x n x n scene.

Run ``python benchmarks/bench_mahalanobis.py [--quick]``. Everything is measured
in this one run, on one core where the OS allows pinning (numpy's element-wise
ufuncs are single-threaded anyway):

1. ``engine.linalg.mahalanobis_sq_pairwise`` on T = 1000 trials of n = 100
   reports per radar (10^7 pairs), every report with its own 2x2 covariance;
2. the same for 3-D reports (3x3 covariances);
3. a pure-Python loop over pairs (the same LDL^T closed form with floats), run
   on a subset of the pairs: its rate does not depend on their number;
4. ``proximity.proximity_gaussian`` broadcast over all pairs (the chapter's
   pointwise form), for comparison;
5. item 1 in every layout of 10^7 pairs: many trials of small scenes (10^5 x 10 x 10,
   the book's commonest), 1000 x 100 x 100 and few trials of large ones (10 x 1000 x 1000).

Before the computation had one home, the public ``proximity.mahalanobis_sq``
broadcast over all pairs ran at about 2-7 M pairs/s on this layout. Target
(issue 20): at least 60 M pairs/s for item 1. Timings are the best of several
repeats, by wall clock and by CPU time (the machine may be shared).
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from bench_gating import pin_one_core  # the same pinning as the gating benchmark

from radarfusion_ref import proximity
from radarfusion_ref.engine import linalg


def best(func, repeats, clock=time.perf_counter):
    out = math.inf
    for _ in range(repeats):
        t0 = clock()
        func()
        out = min(out, clock() - t0)
    return out


def report_covariances(rng, shape, k):
    """Per-report SPD covariances: random orientation, standard deviations 0.05-0.5."""
    q, _ = np.linalg.qr(rng.normal(size=(*shape, k, k)))
    lam = rng.uniform(0.05, 0.5, (*shape, k)) ** 2
    out = q * lam[..., None, :] @ np.swapaxes(q, -1, -2)
    return 0.5 * (out + np.swapaxes(out, -1, -2))


def scene(rng, trials, n, k):
    x1 = rng.uniform(0, 10, (trials, n, k))
    x2 = x1 + rng.normal(scale=0.3, size=x1.shape)
    return x1, x2, report_covariances(rng, (trials, n), k), report_covariances(rng, (trials, n), k)


def python_loop(x1, x2, c1, c2):
    """kappa_ij of every pair with floats: d (d / s11) + w (w / D2), w = d2 - u d1 (k = 2)."""
    out = []
    for t in range(len(x1)):
        for i in range(len(x1[t])):
            (a1, a2), ((p11, p12), (_, p22)) = x1[t][i], c1[t][i]
            for j in range(len(x2[t])):
                (b1, b2), ((q11, q12), (_, q22)) = x2[t][j], c2[t][j]
                s11, s12, s22 = p11 + q11, p12 + q12, p22 + q22
                u = s12 / s11
                d1, d2 = a1 - b1, a2 - b2
                w = d2 - u * d1
                out.append(d1 * (d1 / s11) + w * (w / (s22 - u * s12)))
    return out


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="T = 200 instead of 1000")
    args = parser.parse_args(argv)
    print(pin_one_core())
    rng = np.random.default_rng(2026)
    trials, n, repeats = (200 if args.quick else 1000), 100, 5
    pairs = trials * n * n
    rates = {}
    for k in (2, 3):
        x1, x2, c1, c2 = scene(rng, trials, n, k)
        kappa = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)

        def run(x1=x1, x2=x2, c1=c1, c2=c2):
            return linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)

        rates[k] = (pairs / best(run, repeats), pairs / best(run, repeats, time.process_time))
        if k == 2:
            # the loop on the first trials (its rate does not depend on their number)
            sub = max(1, trials // 100)
            lists = [v[:sub].tolist() for v in (x1, x2, c1, c2)]
            loop = np.array(python_loop(*lists)).reshape(sub, n, n)
            rel = float(np.max(np.abs(loop - kappa[:sub]) / kappa[:sub]))
            rate_py = sub * n * n / best(lambda lists=lists: python_loop(*lists), 2)
            t_small = trials // 10                    # broadcasting needs (T, n, n, k, k) memory

            def broadcast(x1=x1, x2=x2, c1=c1, c2=c2, t=t_small):
                return proximity.proximity_gaussian(x1[:t, :, None], x2[:t, None],
                                                    c1[:t, :, None], c2[:t, None])

            rate_bc = t_small * n * n / best(broadcast, 2)
    wall2, cpu2 = rates[2]
    print(f"scene: T = {trials} trials x n = {n} reports per radar -> {pairs / 1e6:.0f} M pairs, "
          "each report with its own covariance")
    print(f"pure-Python loop == kernel: max relative difference {rel:.1e}")
    print(f"{'method':<46} {'M pairs/s':>10}")
    print(f"{'linalg.mahalanobis_sq_pairwise, k = 2 (wall)':<46} {wall2 / 1e6:10.1f}")
    print(f"{'linalg.mahalanobis_sq_pairwise, k = 2 (CPU)':<46} {cpu2 / 1e6:10.1f}")
    print(f"{'linalg.mahalanobis_sq_pairwise, k = 3 (wall)':<46} {rates[3][0] / 1e6:10.1f}")
    print(f"{'proximity.proximity_gaussian, broadcast, k = 2':<46} {rate_bc / 1e6:10.1f}")
    print(f"{'pure-Python loop, k = 2':<46} {rate_py / 1e6:10.2f}")
    print(f"ratio kernel / pure-Python loop (k = 2): {wall2 / rate_py:.0f}x")
    print(f"target >= 60 M pairs/s (k = 2): {'yes' if wall2 >= 60e6 else 'NO'} by wall clock, "
          f"{'yes' if cpu2 >= 60e6 else 'NO'} by CPU time")
    # every layout of the same number of pairs (k = 2): trials x reports per radar
    total = pairs
    layouts = [(total // 100, 10), (total // 10_000, 100), (max(1, total // 10**6), 1000)]
    print(f"{'layout T x n x n (k = 2)':<30} {'M pairs/s wall':>15} {'CPU':>8}")
    worst = math.inf
    for t, m in layouts:
        x1, x2, c1, c2 = scene(rng, t, m, 2)

        def run(x1=x1, x2=x2, c1=c1, c2=c2):
            return linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)

        wall, cpu = (t * m * m / best(run, repeats), t * m * m / best(run, repeats,
                                                                        time.process_time))
        worst = min(worst, cpu)
        print(f"{f'{t} x {m} x {m}':<30} {wall / 1e6:15.1f} {cpu / 1e6:8.1f}")
        rates[("layout", t, m)] = (wall, cpu)
    print(f"every layout >= 60 M pairs/s by CPU time: {'yes' if worst >= 60e6 else 'NO'} "
          f"(slowest {worst / 1e6:.1f})")
    return rates


if __name__ == "__main__":
    main()
