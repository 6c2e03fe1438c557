"""Benchmark: brute-force enumeration vs the exact S-D assignment MILP (HiGHS).

Run as ``python benchmarks/bench_grouping.py [--quick]``. Everything is measured
in this run: for m = 3 sources and growing n, the wall time of
``group_bruteforce`` ((n!)^2 groupings) and of ``group_sd`` (n^3 binary
variables), their ratio, and whether both found the same grouping. Then the
target (m = 3, n = 20 solved exactly in under 5 s) and how far the MILP goes
(m = 3 and m = 4) before one solve exceeds the practicality limit.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from radarfusion_ref import grouping

LIMIT = 5.0          # seconds: "practical" for one exact grouping
TARGET = (3, 20)     # (m, n) that must be solved exactly within LIMIT


def scene(m, n, seed, noise=0.25):
    """One 2-D scene, one target per unit area, per-source error ellipses."""
    rng = np.random.default_rng(seed)
    thetas = np.arange(m) * np.pi / m
    rot = np.stack([[np.cos(thetas), -np.sin(thetas)], [np.sin(thetas), np.cos(thetas)]])
    rot = np.moveaxis(rot, -1, 0)                                  # (m, 2, 2)
    cov = rot @ np.diag([(2 * noise) ** 2, (noise / 2) ** 2]) @ np.swapaxes(rot, -1, -2)
    s = grouping.grouping_scene(n, m, cov=cov[:, None], layout="uniform", rng=rng)
    return s.reports[0], s.cov


def timed(fn, *args, repeat=1, **kw):
    best, out = math.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn(*args, **kw)
        best = min(best, time.perf_counter() - t0)
    return best, out


def main(quick: bool = False) -> int:
    print(f"python {sys.version.split()[0]}, numpy {np.__version__}")
    print("\nm = 3: brute force ((n!)^2 groupings) vs MILP (n^3 variables), ML cost, 2-D")
    print(f"{'n':>3} {'groupings':>12} {'brute [s]':>10} {'S-D [s]':>9} {'brute/S-D':>10} "
          f"{'B&B only [s]':>13} same")
    n_bf_max = 6 if quick else 7
    for n in range(2, n_bf_max + 1):
        x, cov = scene(3, n, seed=n)
        rep = 3 if n <= 5 else 1
        t_bf, bf = timed(grouping.group_bruteforce, x, cov, repeat=rep, max_groupings=10**8)
        t_sd, sd = timed(grouping.group_sd, x, cov, repeat=rep)
        t_bb, bb = timed(grouping.group_sd, x, cov, repeat=rep, relaxation=False)
        same = bool(np.array_equal(bf.groups, sd.groups) and np.array_equal(bf.groups, bb.groups))
        print(f"{n:>3} {grouping.n_groupings(n, 3):>12} {t_bf:>10.4f} {t_sd:>9.4f} "
              f"{t_bf / t_sd:>10.1f} {t_bb:>13.4f} {same}")
        if not same:
            print("MISMATCH between brute force and MILP")
            return 1
    n8 = grouping.n_groupings(8, 3)
    print(f"  n = 8 would need {n8:,} groupings ({n8 / grouping.n_groupings(7, 3):.0f}x n = 7): "
          "brute force stops being practical at n = 7")

    ok_target = None
    sizes = {3: [10, 15, 20, 25, 30, 40, 50, 60], 4: [6, 8, 10, 12, 14, 16, 18]}
    if quick:
        sizes = {3: [10, 20, 30], 4: [6, 8, 10]}
    for m, ns in sizes.items():
        print(f"\nS-D integer program alone, m = {m} (practical: < {LIMIT:.0f} s per scene)")
        print(f"{'n':>3} {'variables':>10} {'S-D [s]':>9} {'LP integral':>12} {'B&B only [s]':>13}")
        bb_on = True
        for n in ns:
            x, cov = scene(m, n, seed=100 * m + n)
            t_sd, sd = timed(grouping.group_sd, x, cov)
            if bb_on:
                t_bb, bb = timed(grouping.group_sd, x, cov, relaxation=False)
                if not np.array_equal(bb.groups, sd.groups):
                    print("MISMATCH between LP-first and branch and bound")
                    return 1
                bb_txt = f"{t_bb:>13.3f}"
                bb_on = t_bb < 4 * LIMIT
            else:
                bb_txt = f"{'(skipped)':>13}"
            print(f"{n:>3} {n**m:>10} {t_sd:>9.3f} {sd.relaxation_integral!s:>12} {bb_txt}")
            if (m, n) == TARGET:
                ok_target = t_sd < LIMIT
            if t_sd > 4 * LIMIT:
                print(f"  stopping: n = {n} took more than {4 * LIMIT:.0f} s")
                break

    print(f"\ntarget m = 3, n = 20 exactly in under {LIMIT:.0f} s: {'MET' if ok_target else 'NOT MET'}")
    return 0 if ok_target else 1


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="smaller sizes")
    sys.exit(main(ap.parse_args().quick))
