"""Benchmark: one of the book's heavier sweeps, in one process and on a local Dask cluster.

Run as ``python benchmarks/bench_montecarlo.py [--trials N] [--block B] [--workers 1 2]``.

The sweep is the 3-D conversion study of chapter 6 ("In three dimensions" on the
modern-conversions page): a target at range 100 (range error 1), azimuth 0.6 and
elevation 0.2 or 0.4 rad, with equal azimuth and elevation errors swept over the page's
nine values, and every 3-D conversion method's NEES per trial
(:func:`radarfusion_ref.conversion.spherical_monte_carlo`, about 45 ms per seed unit of
1024 trials on one core). It runs through :func:`radarfusion_ref.engine.montecarlo.sweep`:

* in this process (``client=None``), the baseline;
* on ``LocalCluster(n_workers=W, threads_per_worker=1)`` for each W of ``--workers``
  (default 2), after the cluster has started and each worker has imported the package
  (both timed separately);

and prints every wall time, the speed-up against the baseline measured in the same run,
the CPU seconds spent (the baseline process; the workers and the client on the cluster),
whether the results are identical bit for bit, the per-task overhead of the cluster (a
sweep of empty tasks) and the machine's load average, which bounds what two workers can
gain on a 2-core machine shared with other programs. Numerical libraries are pinned to
one thread per process.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from radarfusion_ref import conversion as cv  # noqa: E402
from radarfusion_ref.engine.montecarlo import SEED_BLOCK, sweep  # noqa: E402

R, SIGMA_R, BETA = 100.0, 1.0, 0.6
SIGMA_GRID = [0.01, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5]      # the page's SB_GRID
GRID = {"epsilon": [0.2, 0.4], "sigma": SIGMA_GRID}                 # 18 points


def conversion_3d(params, n, rng):
    """NEES of every 3-D conversion method for n measurements of one target."""
    out = cv.spherical_monte_carlo(R, BETA, params["epsilon"], SIGMA_R, params["sigma"],
                                   params["sigma"], trials=n, rng=rng)
    return {m: trials.nees for m, trials in out.items()}


def nothing(params, n, rng):
    """No work: a sweep of it times the per-task overhead."""
    return np.zeros(n, dtype=bool)


def cpu_seconds() -> float:
    """CPU time of the calling process (run in each worker by ``client.run``)."""
    return time.process_time()


def warm_up():
    """Import the package in a worker before timing."""
    import radarfusion_ref.conversion  # noqa: F401


def main(trials: int, block: int, workers: list[int]) -> None:
    from distributed import Client, LocalCluster

    points = len(GRID["epsilon"]) * len(GRID["sigma"])
    print(f"sweep: chapter 6's 3-D conversion NEES, {points} points x {trials:,} trials, "
          f"block {block:,} ({points * -(-trials // block)} tasks), "
          f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}")
    cpu = time.process_time()
    base = sweep(conversion_3d, GRID, trials=trials, rng=2026, block=block)
    cpu = time.process_time() - cpu
    print(f"  local (1 process)           {base.wall_time:7.2f} s   baseline   "
          f"(CPU {cpu:.1f} s)")
    means = {m: float(np.mean(base[m][0])) for m in base.outputs}
    print("  mean NEES at sigma = 0.01 rad, elevation 0.2 (3 if consistent): "
          + ", ".join(f"{m} {v:.3f}" for m, v in means.items()))
    for w in workers:
        start = time.perf_counter()
        cluster = LocalCluster(n_workers=w, threads_per_worker=1, processes=True,
                               dashboard_address=None,
                               scheduler_kwargs={"dashboard_address": ":0"})
        client = Client(cluster)
        client.run(warm_up)
        startup = time.perf_counter() - start
        try:
            before, own = client.run(cpu_seconds), time.process_time()
            res = sweep(conversion_3d, GRID, trials=trials, rng=2026, block=block,
                        client=client)
            own = time.process_time() - own
            work = sum(client.run(cpu_seconds).values()) - sum(before.values())
            empty = sweep(nothing, {"k": list(range(64))}, trials=SEED_BLOCK, rng=1,
                          block=SEED_BLOCK, client=client)
        finally:
            client.close()
            cluster.close()
        print(f"  LocalCluster(n_workers={w})   {res.wall_time:7.2f} s   speed-up "
              f"{base.wall_time / res.wall_time:5.2f}   identical bit for bit: "
              f"{base.identical(res)}   (CPU: workers {work:.1f} s, client {own:.1f} s; "
              f"start + warm-up {startup:.1f} s, overhead "
              f"{empty.wall_time / empty.tasks * 1e3:.1f} ms per task, load average "
              f"{os.getloadavg()[0]:.1f})")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=1 << 15, help="trials per grid point")
    ap.add_argument("--block", type=int, default=1 << 14,
                    help="trials per task (a multiple of 1024)")
    ap.add_argument("--workers", type=int, nargs="+", default=[2],
                    help="worker counts of the local clusters to compare")
    args = ap.parse_args()
    main(args.trials, args.block, args.workers)
