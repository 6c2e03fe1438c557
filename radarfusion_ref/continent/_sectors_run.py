"""One sector's run and the runs on a Dask cluster, for
:func:`~radarfusion_ref.continent.sectors.track_sectored` (trusted input).

:func:`run_sector` is the same function here and on a worker: it selects its sector's
reports from the whole set, tracks them, and returns the sector's summary and owned rows
(:func:`~radarfusion_ref.continent._sectors_merge.summarise`), so the two runs perform the
same floating-point operations in the same order and agree bit for bit.
"""

from __future__ import annotations

import warnings

import numpy as np

from ..engine.optional import require
from ..tracking import track_reports
from ._sectors_merge import empty_history, summarise


def run_sector(reports, sectors, k, settings):
    """Sector `k`'s tracker on its reports (those in its grown rectangle, selected from
    `reports`, the whole set ``(time, position, cov, radar, scan)``): ``(summary, part,
    warnings)``, the warnings as ``(category, message)`` pairs."""
    inside = sectors._in_grown(reports[1], k)
    data = tuple(a[inside] for a in reports)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        h = track_reports(*data, settings=settings) if data[0].size else empty_history()
    summary, part = summarise(sectors, k, h)
    return summary, part, [(w.category, str(w.message)) for w in caught]


def on_cluster(client, reports, sectors, settings, counts, max_lost, arrived):
    """One task per sector on the cluster: ``(runs, failures)``, the runs in sector order
    and the failures as ``{sector: exception}``; ``arrived(k, run)`` is called on each
    run as it arrives (while the others still run).

    The reports are scattered once, to every worker; each task selects its sector's rows
    there. The tasks are prioritised by decreasing report count (the largest first, so
    that the last to finish are short) and each result is fetched as soon as its task
    finishes, while the others run. A task whose worker dies is rerun by the scheduler
    (another worker holds the reports); a task cancelled because every copy of the
    reports was lost is submitted again with the reports scattered again, at most
    `max_lost` times per sector."""
    distributed = require("distributed", feature="track_sectored(client=...)")
    S = sectors.n_sectors
    rank = np.argsort(-counts, kind="stable")            # largest first
    priority = np.empty(S, np.int64)
    priority[rank] = np.arange(S, 0, -1)
    [data] = client.scatter([reports], broadcast=True, hash=False)
    scattered = [data]

    def submit(k):
        return client.submit(run_sector, scattered[-1], sectors, k, settings, pure=False,
                             priority=int(priority[k]))

    futures = {int(k): submit(int(k)) for k in rank}
    sector = {f.key: k for k, f in futures.items()}
    runs = [None] * S
    lost = np.zeros(S, np.int64)
    failed: dict[int, BaseException] = {}
    try:
        done = distributed.as_completed(list(futures.values()))
        for f in done:
            k = sector[f.key]
            if f.status == "finished":
                runs[k] = f.result()                     # fetched while the others run
                if not failed:
                    arrived(k, runs[k])
                continue
            if f.status == "error":
                failed[k] = f.exception()
                continue
            lost[k] += 1                                 # cancelled: the reports were lost
            if lost[k] > max_lost:
                failed[k] = RuntimeError(f"its task was cancelled {lost[k]} times (status "
                                         f"{f.status!r}: workers lost with the reports)")
                continue
            if scattered[-1].status != "finished":
                [again] = client.scatter([reports], broadcast=True, hash=False)
                scattered.append(again)
            futures[k] = submit(k)
            sector[futures[k].key] = k
            done.add(futures[k])
        return runs, failed
    finally:
        client.cancel(list(futures.values()) + scattered)
