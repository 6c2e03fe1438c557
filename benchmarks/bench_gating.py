"""Benchmark: the 2-D squared-Mahalanobis + chi-square gate kernel.

Run ``python benchmarks/bench_gating.py [--quick]``. Everything is measured in
this one run, on one core (the process is pinned to one CPU where the OS
allows it; numpy's element-wise ufuncs are single-threaded anyway):

1. ``gating.gate_mahalanobis`` — chunked, in-place ufuncs, the 2x2
   LDL^T kernel of ``engine.linalg`` — for 10^6 and 10^7 pairs sharing one S = C1 + C2;
2. plain numpy broadcasting: ``proximity.proximity_gaussian`` (the same
   kernel, no chunking) and the textbook ``einsum`` + ``np.linalg.solve``;
3. a pure-Python loop over pairs (the same closed form with ``math``);
4. a loop calling ``scipy.spatial.distance.mahalanobis`` (which takes S^-1);
5. the machine's memory bandwidth, from a large ``np.add`` (2 reads + 1 write),
   and the kernel's rate as a fraction of the bandwidth bound (the kernel must
   read 32 bytes and write 1 byte per pair);
6. peak memory allocated (``tracemalloc``, which sees numpy's allocations)
   by the chunked kernel and by plain broadcasting, per pair;
7. per-report covariances in the Monte-Carlo layout of chapter 07 (issue 13):
   T = 10^5 trials, n = 10 reports per radar, all n^2 pairs, every report
   with its own 2x2 covariance — ``linalg.mahalanobis_sq_pairwise`` and
   ``gating.gate_pairwise`` against ``proximity.proximity_gaussian`` with the
   covariances broadcast per report (the baseline) and
   ``separated.pair_statistic``; rates by wall clock and by CPU time (the
   machine is shared), and the ratio against the baseline.

The loops run on fewer pairs (their rate does not depend on the count) and
their rates are reported per second. Timings are the best of several repeats,
since the machine may be busy with other work. Targets (issue 3): at least
30 M pairs/s on one core for 10^6-10^7 pairs, at least 20x the pure-Python loop
and 100x the scipy loop, memory bounded by chunking; (issue 13) at least
60 M pairs/s for per-report covariances in the layout of item 7.
"""

from __future__ import annotations

import argparse
import math
import os
import time
import tracemalloc

import numpy as np
from scipy.spatial import distance

from radarfusion_ref import gating, proximity, separated
from radarfusion_ref.engine import linalg

P_LO = 0.01
S = np.array([[1.3, 0.4], [0.4, 0.7]])      # S = C1 + C2, shared by all pairs
C1 = np.array([[0.8, 0.3], [0.3, 0.4]])
C2 = S - C1
KERNEL = "chunked kernel (gate_mahalanobis)"


def pin_one_core() -> str:
    try:
        cpu = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpu})
        return f"pinned to CPU {cpu}"
    except (AttributeError, OSError):
        return "not pinned (no sched_setaffinity)"


def best_time(func, repeats):
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        func()
        best = min(best, time.perf_counter() - t0)
    return best


def python_loop(x1, x2, s, threshold):
    """Pure Python: the closed-form 2x2 Cholesky, one pair at a time."""
    l11 = math.sqrt(s[0][0])
    l21 = s[1][0] / l11
    l22 = math.sqrt(s[1][1] - l21 * l21)
    out = []
    for (a0, a1), (b0, b1) in zip(x1, x2, strict=True):
        z1 = (a0 - b0) / l11
        z2 = ((a1 - b1) - l21 * z1) / l22
        out.append(z1 * z1 + z2 * z2 < threshold)
    return out


def scipy_loop(x1, x2, s_inv, threshold):
    """A loop calling scipy.spatial.distance.mahalanobis (which returns the root)."""
    return [distance.mahalanobis(a, b, s_inv) ** 2 < threshold
            for a, b in zip(x1, x2, strict=True)]


def numpy_einsum(x1, x2, s, threshold):
    """The textbook broadcast: solve for S^-1 d, then a row-wise dot product."""
    d = x1 - x2
    return np.einsum("ni,ni->n", d, np.linalg.solve(s, d.T).T) < threshold


def numpy_plain(x1, x2, threshold):
    """The package's unchunked closed form, then the gate."""
    return proximity.proximity_gaussian(x1, x2, C1, C2) < threshold


def memory_bandwidth(repeats, n=2**24):
    """Bytes per second moved by np.add on three n-float arrays (2 reads + 1 write)."""
    a, b, c = np.ones(n), np.full(n, 2.0), np.empty(n)
    return 3 * 8 * n / best_time(lambda: np.add(a, b, out=c), repeats), n


def best_cpu_time(func, repeats):
    best = math.inf
    for _ in range(repeats):
        t0 = time.process_time()
        func()
        best = min(best, time.process_time() - t0)
    return best


def report_covariances(rng, shape):
    """Per-report SPD covariances: random orientation, sigmas 0.05-0.5, ratio up to 10."""
    theta = rng.uniform(0, np.pi, shape)
    s1, s2 = rng.uniform(0.05, 0.5, shape), rng.uniform(0.05, 0.5, shape)
    c, s = np.cos(theta), np.sin(theta)
    out = np.empty((*shape, 2, 2))
    out[..., 0, 0] = c * c * s1**2 + s * s * s2**2
    out[..., 1, 1] = s * s * s1**2 + c * c * s2**2
    out[..., 0, 1] = out[..., 1, 0] = c * s * (s1**2 - s2**2)
    return out


def per_report_section(rng, trials, n, repeats):
    """Item 7: the per-report-covariance kernel in the Monte-Carlo layout."""
    pairs = trials * n * n
    truth = rng.uniform(0, 10, size=(trials, n, 2))
    c1, c2 = report_covariances(rng, (trials, n)), report_covariances(rng, (trials, n))
    x1 = truth + np.einsum("...ij,...j->...i", np.linalg.cholesky(c1), rng.normal(size=truth.shape))
    x2 = truth + np.einsum("...ij,...j->...i", np.linalg.cholesky(c2), rng.normal(size=truth.shape))
    th = gating.gate_threshold(P_LO, 2)

    def baseline():
        return proximity.proximity_gaussian(x1[:, :, None], x2[:, None], c1[:, :, None],
                                            c2[:, None])

    kappa = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)
    ref = baseline()
    rel = float(np.max(np.abs(kappa - ref) / ref))
    same_sep = np.array_equal(kappa, separated.pair_statistic(x1, c1, x2, c2))
    if not np.array_equal(gating.gate_pairwise(x1, x2, c1, c2), ref < th) and rel > 1e-12:
        raise AssertionError("per-report kernel disagrees with proximity_gaussian")
    methods = {
        "gate_pairwise": lambda: gating.gate_pairwise(x1, x2, c1, c2),
        "mahalanobis_sq_pairwise (kappa)": lambda: linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2),
        "separated.pair_statistic": lambda: separated.pair_statistic(x1, c1, x2, c2),
        "proximity_gaussian, broadcast (baseline)": lambda: baseline() < th,
    }
    print(f"\n7. per-report covariances: T = {trials} trials x n^2 = {n * n} pairs "
          f"({pairs / 1e6:.0f} M pairs); kernel vs proximity_gaussian: max rel. difference "
          f"{rel:.1e}; kernel == separated.pair_statistic bit for bit: {same_sep}")
    print(f"{'method':<38} {'wall M pairs/s':>15} {'CPU M pairs/s':>14} {'x baseline':>11}")
    rates = {}
    for name, func in methods.items():
        reps = 1 if name.startswith("proximity_gaussian") else repeats
        wall = pairs / best_time(func, reps)
        cpu = pairs / max(best_cpu_time(func, reps), 1e-9)
        rates[name] = (wall, cpu)
    base_wall = rates["proximity_gaussian, broadcast (baseline)"][0]
    for name, (wall, cpu) in rates.items():
        print(f"{name:<38} {wall / 1e6:15.1f} {cpu / 1e6:14.1f} {wall / base_wall:11.1f}")
    return rates


def peak_bytes(func):
    tracemalloc.start()
    tracemalloc.reset_peak()
    func()
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="10^5 and 10^6 pairs instead of 10^6 and 10^7")
    args = parser.parse_args(argv)
    sizes = (10**5, 10**6) if args.quick else (10**6, 10**7)
    repeats = 5
    print(f"gate kernel benchmark ({pin_one_core()}; best of {repeats} repeats)")
    rng = np.random.default_rng(3)
    th = gating.gate_threshold(P_LO, 2)

    # --- memory bandwidth ---------------------------------------------------
    bandwidth, n_bw = memory_bandwidth(repeats)
    bound = bandwidth / 33.0                      # pairs/s if limited by memory traffic
    print(f"\nmemory bandwidth (np.add on 3 x {8 * n_bw / 2**20:.0f} MiB): "
          f"{bandwidth / 1e9:.1f} GB/s -> bandwidth bound for the kernel "
          f"(33 bytes per pair): {bound / 1e6:.0f} M pairs/s")

    # --- loops (rate independent of N) --------------------------------------
    n_py, n_sp = 200_000, 20_000
    y1 = rng.normal(size=(n_py, 2))
    y2 = y1 + rng.normal(size=(n_py, 2)) * 1.5
    ref = gating.gate_mahalanobis(y1, y2, S)
    l1, l2, sl = y1.tolist(), y2.tolist(), S.tolist()
    if python_loop(l1, l2, sl, th) != ref.tolist():
        raise AssertionError("pure-Python loop disagrees with the kernel")
    s_inv = np.linalg.inv(S)                      # scipy's API takes the inverse
    z1, z2 = y1[:n_sp], y2[:n_sp]
    if scipy_loop(z1, z2, s_inv, th) != ref[:n_sp].tolist():
        raise AssertionError("scipy loop disagrees with the kernel")
    rate_py = n_py / best_time(lambda: python_loop(l1, l2, sl, th), 3)
    rate_sp = n_sp / best_time(lambda: scipy_loop(z1, z2, s_inv, th), 3)
    print(f"\npure-Python loop ({n_py} pairs):  {rate_py / 1e6:8.2f} M pairs/s")
    print(f"scipy mahalanobis loop ({n_sp} pairs): {rate_sp / 1e6:8.3f} M pairs/s")

    # --- vectorized ----------------------------------------------------------
    header = (f"\n{'pairs':>10} {'method':<34} {'M pairs/s':>10} {'x Python':>9} "
              f"{'x scipy':>9} {'% of BW bound':>14}")
    print(header)
    results = {}
    for n in sizes:
        x1 = rng.normal(size=(n, 2))
        x2 = x1 + rng.normal(size=(n, 2)) * 1.5
        kern = gating.gate_mahalanobis(x1, x2, S)
        if not (np.array_equal(kern, numpy_plain(x1, x2, th))
                and np.array_equal(kern, numpy_einsum(x1, x2, S, th))):
            raise AssertionError("vectorized methods disagree")
        methods = {
            KERNEL: lambda a=x1, b=x2: gating.gate_mahalanobis(a, b, S),
            "plain numpy (proximity_gaussian)": lambda a=x1, b=x2: numpy_plain(a, b, th),
            "numpy einsum + linalg.solve": lambda a=x1, b=x2: numpy_einsum(a, b, S, th),
        }
        for name, func in methods.items():
            rate = n / best_time(func, repeats)
            results[(n, name)] = rate
            print(f"{n:>10} {name:<34} {rate / 1e6:10.1f} {rate / rate_py:9.0f} "
                  f"{rate / rate_sp:9.0f} {100 * rate / bound:13.0f}%")
        mem_k = peak_bytes(methods[KERNEL])
        mem_p = peak_bytes(methods["plain numpy (proximity_gaussian)"])
        results[(n, "mem_kernel")], results[(n, "mem_plain")] = mem_k, mem_p
        print(f"{'':>10} peak memory allocated: kernel {mem_k / 2**20:.1f} MiB "
              f"({mem_k / n:.2f} B/pair; the boolean result alone is 1 B/pair), "
              f"plain numpy {mem_p / 2**20:.1f} MiB ({mem_p / n:.1f} B/pair)")

    print("\ntargets:")
    for n in sizes:
        r = results[(n, KERNEL)]
        print(f"  {n:>9} pairs: {r / 1e6:6.1f} M pairs/s >= 30: {'yes' if r >= 30e6 else 'NO'}; "
              f"{r / rate_py:5.0f}x Python >= 20: {'yes' if r >= 20 * rate_py else 'NO'}; "
              f"{r / rate_sp:6.0f}x scipy >= 100: {'yes' if r >= 100 * rate_sp else 'NO'}")
    grow = results[(sizes[1], "mem_kernel")] / results[(sizes[0], "mem_kernel")]
    print(f"  kernel memory grows {grow:.1f}x for {sizes[1] // sizes[0]}x the pairs: only "
          "the 1-byte-per-pair result grows; the chunk buffers are fixed")

    trials = 10**4 if args.quick else 10**5
    rates = per_report_section(rng, trials, 10, repeats)
    results["per_report"] = rates
    print("\ntargets (issue 13, per-report covariances):")
    base = rates["proximity_gaussian, broadcast (baseline)"][0]
    for name in ("gate_pairwise", "mahalanobis_sq_pairwise (kappa)"):
        wall, cpu = rates[name]
        print(f"  {name}: {wall / 1e6:.1f} M pairs/s wall ({cpu / 1e6:.1f} by CPU time) "
              f">= 60: {'yes' if wall >= 60e6 else 'NO'} (by CPU time: "
              f"{'yes' if cpu >= 60e6 else 'NO'}); {wall / base:.0f}x proximity_gaussian")
    return results


if __name__ == "__main__":
    main()
