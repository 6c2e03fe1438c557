r"""Tracks against the ADS-B truth over time: GOSPA, identity, fragmentation, latency, NEES.

:func:`evaluate_tracks_over_time` scores a :class:`~radarfusion_ref.tracking.TrackHistory`
(the book's tracker or Stone Soup's) against the interpolated truth
(:func:`radarfusion_ref.capstone.truth_at`) at chosen instants;
:func:`summarise_runs` gives each metric's mean over seeds with its Student-t interval.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..capstone.evaluation import gospa_parameters
from ..capstone.radars import as_radars, coverage_count
from ..capstone.traffic import Traffic, truth_at
from ..engine._validation import (
    MEMORY_LIMIT,
    _describe,
    as_float,
    as_float_array,
    as_int,
    as_positive,
    check_size,
)
from ..engine.metrics import NeesResult, gospa, nees
from ..engine.montecarlo import MeanEstimate, mean
from ._settings import TrackHistory

__all__ = ["TrackingMetrics", "evaluate_tracks_over_time", "gospa_pairs", "summarise_runs"]


@dataclass(frozen=True)
class TrackingMetrics:
    r"""Scores of one tracking run against the truth at the instants `times`.

    Attributes
    ----------
    times : numpy.ndarray, shape (T,)
    gospa, localisation, missed, false : numpy.ndarray, shape (T,)
        GOSPA (m) at each instant and its three parts (m^p; they sum to ``gospa**p``).
    c, p : float
        GOSPA cut-off (m) and order; :math:`\alpha = 2`.
    track_of : numpy.ndarray of int, shape (A, T)
        The confirmed track GOSPA's assignment pairs with aircraft ``a`` at ``times[j]``
        (closer than `c`), -1 for none.
    switches : int
        Track switches: the times an aircraft's paired track differs from the track it
        was last paired with (gaps between pairings do not count).
    tracks_per_aircraft : float
        Mean over the aircraft ever paired of the number of distinct tracks paired with it
        (1 = one identity from first sight to last).
    n_tracks, false_tracks : int
        Confirmed tracks present at some instant, and those of them never paired with an
        aircraft.
    false_tracks_per_hour : float
        `false_tracks` over the evaluated span (``times[-1] - times[0]``, at least one
        step), in hours.
    latency : numpy.ndarray, shape (A,)
        Confirmation latency of each aircraft: its first pairing's instant minus the first
        instant it is in the truth set (s); NaN if never in it or never paired.
    nees : NeesResult or None
        Position NEES (3 dof) of the confirmed rows of paired tracks, each row against the
        truth of the aircraft its track is paired with most often, at the row's own time
        (None without such rows).
    seconds_per_scan : float or None
        The run's wall time over `scans`, when given.
    """

    times: np.ndarray
    gospa: np.ndarray
    localisation: np.ndarray
    missed: np.ndarray
    false: np.ndarray
    c: float
    p: float
    track_of: np.ndarray = field(repr=False)
    switches: int
    tracks_per_aircraft: float
    n_tracks: int
    false_tracks: int
    false_tracks_per_hour: float
    latency: np.ndarray = field(repr=False)
    nees: NeesResult | None
    seconds_per_scan: float | None

    @property
    def mean_gospa(self) -> float:
        """Mean over the instants of GOSPA (m)."""
        return float(np.mean(self.gospa))

    @property
    def mean_latency(self) -> float:
        """Mean confirmation latency over the aircraft that got a track (s; NaN if none)."""
        ok = np.isfinite(self.latency)
        return float(np.mean(self.latency[ok])) if ok.any() else float("nan")


def gospa_pairs(x, y, *, c, p=2.0):
    r"""The pairs of an optimal GOSPA assignment (:math:`\alpha = 2`) closer than `c`.

    Parameters
    ----------
    x, y : array_like, shape (n, d) and (k, d)
        Truth and estimated points.
    c : float
        Cut-off (> 0).
    p : float, optional
        Order (>= 1, default 2).

    Returns
    -------
    numpy.ndarray of int, shape (n,)
        For each truth point, the estimate it is paired with, -1 for none.

    Raises
    ------
    ValueError, TypeError
        As :func:`radarfusion_ref.engine.metrics.gospa`.

    Notes
    -----
    With :math:`\alpha = 2` a pair at distance :math:`d \ge c` costs as much as leaving
    both points out (:math:`c^p/2 + c^p/2`), so the optimal assignment minimises
    :math:`\sum \min(d, c)^p` over complete matchings and keeps its pairs with
    :math:`d < c`; their :math:`d^p` plus :math:`c^p/2` per point left out is
    ``gospa(x, y).total ** p``.

    Examples
    --------
    >>> gospa_pairs([[0.0, 0.0], [10.0, 0.0]], [[9.0, 0.0]], c=5.0).tolist()
    [-1, 0]
    """
    g = gospa(x, y, c=c, p=p)                 # validates, and refuses oversize sets
    x = np.asarray(x, dtype=float).reshape(len(x), -1) if len(x) else np.zeros((0, 1))
    y = np.asarray(y, dtype=float).reshape(len(y), -1) if len(y) else np.zeros((0, 1))
    out = np.full(x.shape[0], -1, dtype=np.int64)
    if not (x.shape[0] and y.shape[0]) or g.n_assigned == 0:
        return out
    d = np.linalg.norm(x[:, None, :] - y[None, :, :], axis=-1) / c
    cost = np.minimum(d, 1.0) ** p
    rows, cols = linear_sum_assignment(cost)
    keep = d[rows, cols] < 1.0
    out[rows[keep]] = cols[keep]
    return out


def _estimates_at(history, times, max_age):
    """Each confirmed track's position at each instant: its latest confirmed row at most
    `max_age` s before, moved on at its velocity. Returns (tracks (K,), pos (K, T, 3))."""
    conf = history.confirmed
    tr, tm, st = history.track[conf], history.time[conf], history.state[conf]
    order = np.lexsort((tm, tr))
    tr, tm, st = tr[order], tm[order], st[order]
    ids, first = np.unique(tr, return_index=True)
    stops = np.append(first[1:], tr.size)[:ids.size]      # no confirmed row: no track
    pos = np.full((ids.size, times.size, 3), np.nan)
    for k, (a, b) in enumerate(zip(first, stops, strict=True)):
        j = np.searchsorted(tm[a:b], times, side="right") - 1
        ok = j >= 0
        jj = a + np.maximum(j, 0)
        age = times - tm[jj]
        ok &= age <= max_age
        pos[k, ok] = st[jj[ok], :3] + age[ok, None] * st[jj[ok], 3:]
    return ids, pos


def _evaluate_iv(history, traffic, c, p, times, radars, min_radars, max_age, scans):
    if not isinstance(history, TrackHistory):
        raise TypeError(f"`history` must be a TrackHistory (from track_reports or "
                        f"stonesoup_track); received {_describe(history)}")
    if not isinstance(traffic, Traffic):
        raise TypeError(f"`traffic` must be a Traffic (from load_traffic); received "
                        f"{_describe(traffic)}")
    c, p = gospa_parameters(c, p)
    t = as_float_array(times, "times")
    if t.ndim != 1 or t.size < 2 or np.any(np.diff(t) <= 0):
        raise ValueError(f"`times` must be at least two increasing instants (s); received "
                         f"{_describe(times)}")
    if radars is not None:
        radars = as_radars(radars)
        min_radars = as_int(min_radars, "min_radars", minimum=1, maximum=len(radars))
    max_age = as_float(as_positive(max_age, "max_age"), "max_age")
    if scans is not None:
        scans = as_int(scans, "scans", minimum=1)
    n_tracks = np.unique(history.track).size
    check_size(8 * 4 * max(n_tracks, len(traffic.icao24)) * t.size, MEMORY_LIMIT,
               what=f"bytes of track and truth positions ({n_tracks} tracks, "
                    f"{len(traffic.icao24)} aircraft x {t.size} `times`)",
               alternative="fewer `times` (a coarser grid, or windows)")
    return c, p, t, radars, min_radars, max_age, scans


def evaluate_tracks_over_time(history, traffic, *, c=2000.0, p=2.0, times, radars=None,
                              min_radars=1, max_age=15.0, scans=None) -> TrackingMetrics:
    r"""Score confirmed tracks against the ADS-B truth at the given instants.

    Parameters
    ----------
    history : TrackHistory
        A tracking run (:func:`~radarfusion_ref.tracking.track_reports`,
        :func:`~radarfusion_ref.tracking.stonesoup.stonesoup_track`, ...).
    traffic : Traffic
        The truth (:func:`radarfusion_ref.capstone.load_traffic`), interpolated by
        :func:`radarfusion_ref.capstone.truth_at`.
    c, p : float, optional
        GOSPA cut-off (m, default 2000) and order (default 2); :math:`\alpha = 2`.
    times : array_like, shape (T,)
        Increasing instants of evaluation (s), at least two.
    radars : sequence of Radar, optional
        If given, the truth at an instant is the aircraft inside the coverage of at least
        `min_radars` of them (range and elevation about each site in the common frame);
        otherwise every aircraft the truth knows then.
    min_radars : int, optional
        Default 1.
    max_age : float, optional
        A confirmed track is present at an instant if its latest confirmed row is at most
        this old (s, default 15: longer than the slowest radar's revisit); its position
        there is that row's moved on at the row's velocity.
    scans : int, optional
        Number of radar scans the run processed: `seconds_per_scan` is the history's wall
        time over it.

    Returns
    -------
    TrackingMetrics

    Raises
    ------
    TypeError
        Wrong types of `history`, `traffic` or `radars`.
    ValueError
        Bad `c`, `p`, `times`, `min_radars`, `max_age` or `scans`, tracks x truth x times
        beyond the memory limit, or confirmed rows whose position covariance is not
        symmetric positive definite (named `history`).

    Notes
    -----
    At each instant the present confirmed tracks are compared with the truth by GOSPA
    (:func:`radarfusion_ref.engine.metrics.gospa`) and paired by its optimal assignment
    (:func:`gospa_pairs`). Identity metrics follow the pairs: a switch is an aircraft paired
    with another track than at its previous pairing; a false track is a confirmed track
    never paired; latency is from an aircraft's first instant in the truth set to its first
    pairing (so it is resolved to the spacing of `times`).

    Examples
    --------
    >>> from radarfusion_ref.capstone import load_traffic
    >>> h = TrackHistory(track=np.zeros(0, dtype=int), time=np.zeros(0),
    ...                  state=np.zeros((0, 6)), covariance=np.zeros((0, 6, 6)),
    ...                  confirmed=np.zeros(0, dtype=bool))
    >>> m = evaluate_tracks_over_time(h, load_traffic(), times=[0.0, 10.0])
    >>> m.n_tracks, m.false_tracks
    (0, 0)
    """
    c, p, t, radars, min_radars, max_age, scans = _evaluate_iv(
        history, traffic, c, p, times, radars, min_radars, max_age, scans)
    truth, valid = truth_at(traffic, t)
    if radars is not None:
        cov = np.zeros(valid.shape, dtype=bool)
        cov[valid] = coverage_count(truth[valid], radars) >= min_radars
        valid = cov
    ids, est = _estimates_at(history, t, max_age)
    A, T = valid.shape
    parts = np.zeros((T, 4))
    track_of = np.full((A, T), -1, dtype=np.int64)
    for j in range(T):
        a_idx = np.flatnonzero(valid[:, j])
        k_idx = np.flatnonzero(np.isfinite(est[:, j, 0]))
        x, y = truth[a_idx, j], est[k_idx, j]
        g = gospa(x, y, c=c, p=p)
        parts[j] = g.total, g.localisation, g.missed, g.false
        if a_idx.size and k_idx.size:
            pair = gospa_pairs(x, y, c=c, p=p)
            hit = pair >= 0
            track_of[a_idx[hit], j] = ids[k_idx[pair[hit]]]
    switches, per_aircraft, latency = 0, [], np.full(A, np.nan)
    for a in range(A):
        seq = track_of[a][track_of[a] >= 0]
        if not seq.size:
            continue
        switches += int(np.sum(seq[1:] != seq[:-1]))
        per_aircraft.append(np.unique(seq).size)
        first_seen = t[np.argmax(valid[a])]
        latency[a] = t[np.argmax(track_of[a] >= 0)] - first_seen
    present = np.isfinite(est[:, :, 0]).any(axis=1)
    paired = np.isin(ids, track_of[track_of >= 0])
    n_false = int(np.sum(present & ~paired))
    hours = (t[-1] - t[0]) / 3600.0
    return TrackingMetrics(
        times=t, gospa=parts[:, 0], localisation=parts[:, 1], missed=parts[:, 2],
        false=parts[:, 3], c=c, p=p, track_of=track_of, switches=switches,
        tracks_per_aircraft=float(np.mean(per_aircraft)) if per_aircraft else float("nan"),
        n_tracks=int(present.sum()), false_tracks=n_false,
        false_tracks_per_hour=n_false / hours, latency=latency,
        nees=_nees(history, traffic, track_of),
        seconds_per_scan=None if scans is None else history.seconds / scans)


def _nees(history, traffic, track_of):
    """Position NEES of the confirmed rows of paired tracks against their main aircraft."""
    pairs = np.stack(np.nonzero(track_of >= 0), axis=-1)
    if not pairs.size:
        return None
    trk = track_of[pairs[:, 0], pairs[:, 1]]
    key, counts = np.unique(np.stack([trk, pairs[:, 0]], axis=-1), axis=0, return_counts=True)
    order = np.lexsort((-counts, key[:, 0]))                 # most pairings first per track
    key = key[order]
    first = np.unique(key[:, 0], return_index=True)[1]
    main = dict(zip(key[first, 0].tolist(), key[first, 1].tolist(), strict=True))
    rows = np.flatnonzero(history.confirmed & np.isin(history.track, list(main)))
    if not rows.size:
        return None
    times, inv = np.unique(history.time[rows], return_inverse=True)
    truth, valid = truth_at(traffic, times)
    aircraft = np.array([main[int(k)] for k in history.track[rows]])
    ok = valid[aircraft, inv]
    if not ok.any():
        return None
    err = history.state[rows[ok], :3] - truth[aircraft[ok], inv[ok]]
    try:
        return nees(err, history.covariance[rows[ok], :3, :3])
    except ValueError as exc:           # the engine names its own argument; name ours
        raise ValueError(f"`history`: the position covariances of its confirmed rows: "
                         f"{str(exc).replace('`cov` ', '', 1)}") from None


def summarise_runs(runs) -> dict[str, MeanEstimate]:
    """Each metric's mean over replicated runs (seeds) with its Student-t interval.

    Parameters
    ----------
    runs : sequence of TrackingMetrics
        At least two runs of the same setting with different seeds.

    Returns
    -------
    dict of str to MeanEstimate
        ``mean_gospa``, ``switches``, ``tracks_per_aircraft``, ``false_tracks_per_hour``,
        ``mean_latency``, ``nees`` (the runs' mean NEES; the interval the replication
        supports) and, when every run has it, ``seconds_per_scan``
        (:func:`radarfusion_ref.engine.montecarlo.mean`).

    Raises
    ------
    TypeError
        `runs` not a sequence of :class:`TrackingMetrics`.
    ValueError
        Fewer than two runs, or a run without NEES rows.

    Examples
    --------
    >>> summarise_runs([])
    Traceback (most recent call last):
    ...
    ValueError: `runs` must hold at least two TrackingMetrics (seeds); received 0
    """
    if not isinstance(runs, (list, tuple)) or not all(isinstance(r, TrackingMetrics)
                                                      for r in runs):
        raise TypeError(f"`runs` must be a list of TrackingMetrics; received {_describe(runs)}")
    if len(runs) < 2:
        raise ValueError(f"`runs` must hold at least two TrackingMetrics (seeds); received "
                         f"{len(runs)}")
    if any(r.nees is None for r in runs):
        raise ValueError("`runs`: a run has no NEES rows (no confirmed track paired with an "
                         "aircraft)")
    out = {name: mean([float(getattr(r, name)) for r in runs]) for name in (
        "mean_gospa", "switches", "tracks_per_aircraft", "false_tracks_per_hour",
        "mean_latency")}
    out["nees"] = mean([r.nees.mean for r in runs])
    if all(r.seconds_per_scan is not None for r in runs):
        out["seconds_per_scan"] = mean([r.seconds_per_scan for r in runs])
    return out
