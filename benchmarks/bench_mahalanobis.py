"""Benchmark: the package's one squared Mahalanobis distance, every pair of a T x n x n scene.

Run ``python benchmarks/bench_mahalanobis.py [--quick] [--repeats R]``. Everything
is measured in this one run, on one core where the OS allows pinning (numpy's
element-wise ufuncs are single-threaded anyway):

1. ``engine.linalg.mahalanobis_sq_pairwise`` in every layout, for 2-D and 3-D
   reports, every report with its own covariance: many trials of small scenes
   (10^5 x 10 x 10, the book's commonest; 10^4 x 3 x 3; 10^6 x 2 x 2) and few
   trials of large ones (1000 x 100 x 100, 10 x 1000 x 1000);
2. in each layout, the straightforward route: the pairs' sums of covariances
   materialised and ``np.linalg.solve`` on them (on the first trials only, up to
   about 2 x 10^5 pairs: its rate does not depend on their number, its memory
   does), which also checks the kernel's values;
3. in each layout, the rate the door alone would allow: the covariance rule
   (``engine.validation.as_covariance``, in the door's runs of 32768 matrices)
   and the coordinates' domain check, which every call runs once per report;
4. the same layouts with one covariance per radar (the factorisation then runs
   once per block, and the door checks two matrices);
5. a pure-Python loop over pairs (the same LDL^T closed form with floats) on a
   few trials, as an independent check of the k = 2 values.

Items 1 and 4 run both routes of the function: the compiled one (numba, the ``fast``
extra; the door's checks fused with the pairs) and the numpy one (in-place ufuncs),
selected with the ``RADARFUSION_NO_COMPILED`` environment variable; their results are
compared bit for bit. The compiled route's first call (compiling, or loading numba's
cache) is timed apart, outside the repeats.

Target (issue 20): at least 60 M pairs/s in every layout, for the route the package
takes by default. Timings are the best of several repeats, by wall clock and by CPU
time (the machine may be shared); the spread (slowest repeat / best) of each layout is
printed as a measure of noise.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from bench_gating import pin_one_core  # the same pinning as the gating benchmark

from radarfusion_ref.engine import linalg, validation

#: Layouts (trials, reports per radar); each scene is also run with 3-D reports.
LAYOUTS = [(1000, 100), (10, 1000), (100_000, 10), (10_000, 3), (1_000_000, 2)]
#: Largest number of pairs of the solve route per layout (it materialises them all).
SOLVE_PAIRS = 200_000
#: Covariances per run of the door's check (as engine.linalg's door).
RULE_RUN = 32768


def timings(func, repeats):
    """Best wall-clock and CPU time of `repeats` calls, and the spread (slowest / best wall)."""
    wall, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        func()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return min(wall), min(cpu), max(wall) / min(wall)


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


def by_solve(x1, x2, c1, c2):
    """The straightforward route: every pair's S and difference materialised, then LAPACK solve."""
    d = x1[..., :, None, :] - x2[..., None, :, :]
    s = c1[..., :, None, :, :] + c2[..., None, :, :, :]
    return np.einsum("...i,...i->...", d, np.linalg.solve(s, d[..., None])[..., 0])


def door_only(x1, x2, c1, c2):
    """The checks the door runs once per report: the covariance rule and the domain."""
    k = x1.shape[-1]
    for x, c in ((x1, c1), (x2, c2)):
        flat = c.reshape(-1, k, k)
        for r0 in range(0, len(flat), RULE_RUN):
            validation.as_covariance(flat[r0:r0 + RULE_RUN], "cov", dim=k)
        validation.check_domain(x, "x")


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


def route(name):
    """Select a route of mahalanobis_sq_pairwise: "compiled" or "numpy"."""
    if name == "numpy":
        os.environ[linalg.NO_COMPILED_ENV] = "1"
    else:
        os.environ.pop(linalg.NO_COMPILED_ENV, None)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="a tenth of the trials in every layout (at least one)")
    parser.add_argument("--repeats", type=int, default=5, help="repeats per layout (best kept)")
    args = parser.parse_args(argv)
    print(pin_one_core())
    user_choice = os.environ.get(linalg.NO_COMPILED_ENV)
    default = "numpy" if linalg._compiled_kernels() is None else "compiled"
    route("compiled")
    routes = ["compiled", "numpy"] if linalg._compiled_kernels() is not None else ["numpy"]
    if "compiled" in routes:
        t0 = time.perf_counter()
        for k in (2, 3):                        # compiles, or loads numba's cache
            x1, x2, c1, c2 = scene(np.random.default_rng(1), 300, 2, k)
            linalg.mahalanobis_sq_pairwise(x1[:1], x2[:1], c1[:1], c2[:1])
            linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)
        print(f"compiled route: first calls (compile or cache load) {time.perf_counter() - t0:.2f} s")
    rng = np.random.default_rng(2026)
    rows, rates = [], {}
    for k in (2, 3):
        for trials, n in LAYOUTS:
            t = max(1, trials // 10) if args.quick else trials
            pairs = t * n * n
            x1, x2, c1, c2 = scene(rng, t, n, k)

            def run(x1=x1, x2=x2, c1=c1, c2=c2):
                return linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)

            sub = max(1, min(t, SOLVE_PAIRS // (n * n)))
            part = [v[:sub] for v in (x1, x2, c1, c2)]
            ref = by_solve(*part)
            cpu_solve = timings(lambda part=part: by_solve(*part), 2)[1]
            route("numpy")
            door = timings(lambda run_args=(x1, x2, c1, c2): door_only(*run_args), 2)[1]
            results = {}
            for name in routes:
                route(name)
                kappa = results[name] = run()
                wall, cpu, spread = timings(run, args.repeats)
                rel = float(np.max(np.abs(kappa[:sub] - ref) / ref))
                rates[(k, t, n, name)] = pairs / wall
                rows.append((k, f"{t} x {n} x {n}", name, pairs / wall, pairs / cpu, spread,
                             sub * n * n / cpu_solve, pairs / door, rel))
            same = all(np.array_equal(v, results["numpy"]) for v in results.values())
            print(f"  measured k = {k}, {t} x {n} x {n}; routes equal bit for bit: {same}",
                  flush=True)
    print("mahalanobis_sq_pairwise, every report with its own covariance (M pairs/s; "
          f"best of {args.repeats} repeats)")
    print(f"{'k':>2} {'layout T x n x n':<20} {'route':<9} {'wall':>7} {'CPU':>7} {'spread':>7} "
          f"{'solve':>7} {'ratio':>6} {'door-only':>10} {'max rel diff':>13}")
    for k, name, path, wall, cpu, spread, solve, door, rel in rows:
        print(f"{k:>2} {name:<20} {path:<9} {wall / 1e6:7.1f} {cpu / 1e6:7.1f} {spread:7.2f} "
              f"{solve / 1e6:7.2f} {cpu / solve:5.0f}x {door / 1e6:10.1f} {rel:13.1e}")
    print("wall, CPU: the public function by wall clock and by CPU time; spread: slowest "
          "repeat / best, by wall clock (noise); solve: the np.linalg.solve route (CPU); "
          "ratio: CPU / solve; door-only: the rate if the numpy route's kernel took no time "
          "(the covariance rule and the domain check of every report, CPU); max rel diff: "
          "against solve")
    # the same layouts with one covariance per radar: the door checks two matrices and the
    # kernel factorises S once per block (numpy) or once per report row (compiled)
    for name in routes:
        route(name)
        shared = []
        for k in (2, 3):
            for trials, n in LAYOUTS:
                t = max(1, trials // 10) if args.quick else trials
                x1 = rng.uniform(0, 10, (t, n, k))
                x2 = x1 + rng.normal(scale=0.3, size=x1.shape)
                c1, c2 = report_covariances(rng, (), k), report_covariances(rng, (), k)
                cpu = timings(lambda run_args=(x1, x2, c1, c2):
                              linalg.mahalanobis_sq_pairwise(*run_args), args.repeats)[1]
                shared.append(f"k{k} {t}x{n}x{n} {t * n * n / cpu / 1e6:.0f}")
        print(f"one covariance per radar, {name} route, M pairs/s (CPU): {', '.join(shared)}")
    # the pure-Python loop on the first trials of a 2-D scene (k = 2 values, independently)
    x1, x2, c1, c2 = scene(rng, 20, 10, 2)
    loop = np.array(python_loop(*(v.tolist() for v in (x1, x2, c1, c2)))).reshape(20, 10, 10)
    for name in routes:
        route(name)
        kappa = linalg.mahalanobis_sq_pairwise(x1, x2, c1, c2)
        print(f"pure-Python loop == {name} route (k = 2): max relative difference "
              f"{float(np.max(np.abs(loop - kappa) / kappa)):.1e}")
    if user_choice is None:
        os.environ.pop(linalg.NO_COMPILED_ENV, None)
    else:
        os.environ[linalg.NO_COMPILED_ENV] = user_choice
    # CPU time: on a shared machine the wall clock also counts the other jobs' turns
    mine = [r for r in rows if r[2] == default]
    slowest = min(mine, key=lambda r: r[4])
    listing = ", ".join(f"k{k} {name.replace(' ', '')} {cpu / 1e6:.0f}"
                        for k, name, _, _, cpu, *_ in mine)
    print(f"M pairs/s (CPU, {default} route, the default here): {listing}; slowest "
          f"k{slowest[0]} {slowest[1].replace(' ', '')} {slowest[4] / 1e6:.0f} "
          f"(target >= 60: {'met' if slowest[4] >= 60e6 else 'NOT met'})")
    return rates


if __name__ == "__main__":
    main()
