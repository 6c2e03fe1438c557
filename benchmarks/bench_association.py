"""Benchmark: joint association by enumeration, by assignment, and Murty's k best.

Run ``python benchmarks/bench_association.py``. Everything is measured in this
one run and reported both in seconds and as ratios against a baseline measured
alongside it:

1. brute-force enumeration of the n! joint hypotheses vs the linear assignment
   (``associate_joint``) for n = 4 ... 10 (n = 10 only if n = 9 took under 1.5 s);
2. the assignment alone for n = 100, 1000, 3000 (target: n = 1000 under 0.2 s);
3. Murty's k = 100 best assignments at n = 50 vs 100 separate assignments of
   the same size (target: within 10x).

Cost matrices are proximity measures of simulated 2-D scenes (objects uniform
with one per unit area, sigma1 = sigma2 = 0.3), the matrices the chapter uses.
Timings are the best of several repeats (the machine may be loaded).
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.optimize import linear_sum_assignment

from radarfusion_ref import association, scenes


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
        brute = association.associate_bruteforce(c)
        joint = association.associate_joint(c)
        if not np.array_equal(brute.row_to_col, joint.row_to_col):
            raise AssertionError(f"brute force and assignment disagree at n = {n}")
        reps = 3 if n >= 9 else 5
        tb = best_time(lambda c=c: association.associate_bruteforce(c), reps)
        ta = best_time(lambda c=c: association.associate_joint(c), 50)
        last_brute = tb
        print(f"{n:>4} {math.factorial(n):>9} "
              f"{tb:>16.5f} {ta:>15.6f} {tb / ta:>9.0f}")

    print("\n2. Linear assignment alone (scipy.optimize.linear_sum_assignment via associate_joint)")
    print(f"{'n':>6} {'time [s]':>10} {'x time(n=100)':>14} {'(n/100)^3':>10}")
    base = None
    for n in (100, 1000, 3000):
        c = kappa_matrix(n, rng)
        t = best_time(lambda c=c: association.associate_joint(c), 5 if n <= 1000 else 1)
        base = base or t
        flag = ""
        if n == 1000:
            flag = "  target < 0.2 s: " + ("met" if t < 0.2 else "NOT met")
        print(f"{n:>6} {t:>10.4f} {t / base:>14.1f} {(n / 100) ** 3:>10.0f}{flag}")

    print("\n3. Murty's k best (k = 100, n = 50) vs k separate assignments of the same size")
    c = kappa_matrix(50, rng)
    k = 100
    kb = association.k_best_assignments(c, k)
    t_murty = best_time(lambda: association.k_best_assignments(c, k), 5)

    def separate():
        for _ in range(k):
            linear_sum_assignment(c)

    t_sep = best_time(separate, 5)
    ratio = t_murty / t_sep
    print(f"  Murty: {t_murty:.4f} s ({kb.solved} sub-problems solved for {kb.k} hypotheses)")
    print(f"  {k} separate assignments: {t_sep:.4f} s")
    print(f"  ratio {ratio:.1f}  target <= 10x: {'met' if ratio <= 10 else 'NOT met'}")
    rnd = rng.random((50, 50))
    t_murty_r = best_time(lambda: association.k_best_assignments(rnd, k), 5)
    t_sep_r = best_time(lambda: [linear_sum_assignment(rnd) for _ in range(k)], 5)
    print(f"  (uniform random costs: Murty {t_murty_r:.4f} s, separate {t_sep_r:.4f} s, "
          f"ratio {t_murty_r / t_sep_r:.1f})")


if __name__ == "__main__":
    main()
