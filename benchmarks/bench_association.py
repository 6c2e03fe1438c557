"""Benchmark: joint association by enumeration, by assignment, and Murty's k best.

Run ``python benchmarks/bench_association.py [--sparse-only] [--quick]``. Everything is measured in this
one run and reported both in seconds and as ratios against a baseline measured
alongside it:

1. brute-force enumeration of the n! joint hypotheses vs the linear assignment
   (``assign_two_lists``) for n = 4 ... 10 (n = 10 only if n = 9 took under 1.5 s);
2. the assignment alone for n = 100, 1000, 3000 (target: n = 1000 under 0.2 s);
3. Murty's k = 100 best assignments at n = 50 vs 100 separate assignments of
   the same size (target: within 10x);
4. (issue 13) gated sparse association: ``gating.gate_sparse`` (k-d tree)
   plus ``assign_two_lists`` on the sparse matrix of gated pairs, for n up to
   10 000 reports per radar (target: gating plus assignment of n = 10 000 in
   under 2 s), against the dense route (``proximity_matrix``, gate, dense
   ``assign_two_lists``) at the largest n whose dense working memory fits in
   ``MEMORY_LIMIT`` (peak measured with ``tracemalloc`` at a small n and
   scaled by n^2); decisions compared wherever both run.

Cost matrices are proximity measures of simulated 2-D scenes (objects uniform
with one per unit area, sigma1 = sigma2 = 0.3), the matrices the chapter uses.
Timings are the best of several repeats (the machine may be loaded).
"""

from __future__ import annotations

import math
import sys
import time
import tracemalloc

import numpy as np
from scipy.optimize import linear_sum_assignment

from radarfusion_ref import association, gating
from radarfusion_ref.engine import assignment, scenes
from radarfusion_ref.engine.validation import MEMORY_LIMIT

P_LO = 0.01
SIGMA = 0.3


def kappa_matrix(n, rng):
    sc = scenes.two_radar_scene(n, spacing=1.0, sigma1=0.3, sigma2=0.3, dim=2, layout="uniform",
                                rng=rng)
    return association.proximity_matrix(sc.reports1[0], sc.reports2[0], 0.3, 0.3)


def best_time(func, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - t0)
    return best


def main():
    rng = np.random.default_rng(2024)
    print("1. Joint ML: brute force over n! hypotheses vs linear assignment")
    print(f"{'n':>4} {'n!':>9} {'brute force [s]':>16} {'assignment [s]':>15} {'ratio':>9}")
    last_brute = 0.0
    for n in range(4, 11):
        if n == 10 and last_brute > 1.5:
            print(f"{n:>4} {'skipped':>9} (n = 9 took {last_brute:.2f} s)")
            break
        c = kappa_matrix(n, rng)
        brute = assignment.assign_two_lists_bruteforce(c)
        joint = assignment.assign_two_lists(c)
        if not np.array_equal(brute.row_to_col, joint.row_to_col):
            raise AssertionError(f"brute force and assignment disagree at n = {n}")
        reps = 3 if n >= 9 else 5
        tb = best_time(lambda c=c: assignment.assign_two_lists_bruteforce(c), reps)
        ta = best_time(lambda c=c: assignment.assign_two_lists(c), 50)
        last_brute = tb
        print(f"{n:>4} {math.factorial(n):>9} "
              f"{tb:>16.5f} {ta:>15.6f} {tb / ta:>9.0f}")

    print("\n2. Linear assignment alone (scipy.optimize.linear_sum_assignment via assign_two_lists)")
    print(f"{'n':>6} {'time [s]':>10} {'x time(n=100)':>14} {'(n/100)^3':>10}")
    base = None
    for n in (100, 1000, 3000):
        c = kappa_matrix(n, rng)
        t = best_time(lambda c=c: assignment.assign_two_lists(c), 5 if n <= 1000 else 1)
        base = base or t
        flag = ""
        if n == 1000:
            flag = "  target < 0.2 s: " + ("met" if t < 0.2 else "NOT met")
        print(f"{n:>6} {t:>10.4f} {t / base:>14.1f} {(n / 100) ** 3:>10.0f}{flag}")

    print("\n3. Murty's k best (k = 100, n = 50) vs k separate assignments of the same size")
    c = kappa_matrix(50, rng)
    k = 100
    kb = assignment.k_best_two_lists(c, k)
    t_murty = best_time(lambda: assignment.k_best_two_lists(c, k), 5)

    def separate():
        for _ in range(k):
            linear_sum_assignment(c)

    t_sep = best_time(separate, 5)
    ratio = t_murty / t_sep
    print(f"  Murty: {t_murty:.4f} s ({kb.solved} sub-problems solved for {kb.k} hypotheses)")
    print(f"  {k} separate assignments: {t_sep:.4f} s")
    print(f"  ratio {ratio:.1f}  target <= 10x: {'met' if ratio <= 10 else 'NOT met'}")
    rnd = rng.random((50, 50))
    t_murty_r = best_time(lambda: assignment.k_best_two_lists(rnd, k), 5)
    t_sep_r = best_time(lambda: [linear_sum_assignment(rnd) for _ in range(k)], 5)
    print(f"  (uniform random costs: Murty {t_murty_r:.4f} s, separate {t_sep_r:.4f} s, "
          f"ratio {t_murty_r / t_sep_r:.1f})")


def gated_scene(n, rng):
    sc = scenes.two_radar_scene(n, spacing=1.0, sigma1=SIGMA, sigma2=SIGMA, dim=2,
                                layout="uniform", rng=rng)
    return sc.reports1[0], sc.reports2[0]


def sparse_route(x1, x2, th):
    """Gating (k-d tree) plus the sparse assignment."""
    gated = gating.gate_sparse(x1, x2, 2 * SIGMA**2 * np.eye(2), p_false_reject=P_LO)
    return assignment.assign_two_lists(gated, threshold=th), gated.nnz


def dense_route(x1, x2, th):
    """Every pair's kappa, the gate as +inf, the dense assignment."""
    kappa = association.proximity_matrix(x1, x2, SIGMA, SIGMA)
    return assignment.assign_two_lists(np.where(kappa < th, kappa, np.inf), threshold=th)


def dense_peak_bytes_per_pair(rng, n=500):
    x1, x2 = gated_scene(n, rng)
    th = gating.gate_threshold(P_LO, 2)
    tracemalloc.start()
    dense_route(x1, x2, th)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / n**2


def largest_dense_n(rng, start):
    """The largest n <= `start` (a multiple of 500) whose dense route is not refused: the
    guard refuses before allocating, so a refused n costs nothing."""
    for n in range(start, 0, -500):
        x1, x2 = gated_scene(n, rng)
        try:
            association.proximity_matrix(x1, x2, SIGMA, SIGMA)
        except ValueError:
            continue
        return n
    raise RuntimeError("the dense route refuses even n = 500")


def sparse_section(rng, quick=False):
    th = gating.gate_threshold(P_LO, 2)
    per_pair = dense_peak_bytes_per_pair(rng)
    n_fit = int(math.sqrt(MEMORY_LIMIT / per_pair))
    n_dense_max = largest_dense_n(rng, (n_fit // 500) * 500)
    print(f"\n4. Gated sparse association (one object per unit area, sigma = {SIGMA}, "
          f"gate P_lo = {P_LO}, gamma = {th:.3f})")
    print(f"  dense route peak memory: {per_pair:.0f} bytes per pair -> largest n within "
          f"MEMORY_LIMIT = {MEMORY_LIMIT / 2**30:.0f} GiB: {n_fit}; the largest multiple of "
          f"500 the dense route accepts (its guard counts its work buffers): {n_dense_max}")
    ns = (1000, 2000, 10_000) if quick else (1000, 2000, 5000, 10_000)
    ns = tuple(sorted(set(ns) | {n_dense_max}))
    print(f"{'n':>7} {'gated pairs':>12} {'per report':>11} {'sparse [s]':>11} "
          f"{'dense [s]':>10} {'dense/sparse':>13} {'same decisions':>15}")
    out = {}
    for n in ns:
        x1, x2 = gated_scene(n, rng)
        res, nnz = sparse_route(x1, x2, th)
        t_sparse = best_time(lambda x1=x1, x2=x2: sparse_route(x1, x2, th), 3)
        t_dense, same = math.nan, "-"
        if n <= n_dense_max and (n == n_dense_max or n <= 2000):
            ref = dense_route(x1, x2, th)
            same = "yes" if np.array_equal(ref.row_to_col, res.row_to_col) else "NO"
            t_dense = best_time(lambda x1=x1, x2=x2: dense_route(x1, x2, th), 1)
        out[n] = (t_sparse, t_dense)
        ratio = f"{t_dense / t_sparse:13.0f}" if math.isfinite(t_dense) else f"{'-':>13}"
        dense_txt = f"{t_dense:10.3f}" if math.isfinite(t_dense) else f"{'(not run)':>10}"
        print(f"{n:>7} {nnz:>12} {nnz / n:>11.1f} {t_sparse:>11.3f} {dense_txt} {ratio} "
              f"{same:>15}")
    t10 = out[10_000][0]
    print(f"  target: n = 10 000 gating + assignment < 2 s: {t10:.3f} s -> "
          f"{'met' if t10 < 2 else 'NOT met'}; at n = {n_dense_max} (the largest dense n "
          f"within memory) the sparse route is {out[n_dense_max][1] / out[n_dense_max][0]:.0f}x "
          "faster than the dense route")
    return out


if __name__ == "__main__":
    if "--sparse-only" in sys.argv:
        sparse_section(np.random.default_rng(2024), quick="--quick" in sys.argv)
    else:
        main()
        sparse_section(np.random.default_rng(2025), quick="--quick" in sys.argv)
