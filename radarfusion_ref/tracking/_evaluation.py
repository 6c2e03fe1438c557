r"""Tracks against the truth over time: GOSPA, identity, fragmentation, latency, NEES.

:func:`tracks_at` reads a :class:`~radarfusion_ref.tracking.TrackHistory` at any
instants; :func:`evaluate_tracks` scores it against a truth given as arrays (time,
position, identity), and :func:`evaluate_tracks_over_time` against the ADS-B truth
(:func:`radarfusion_ref.capstone.truth_at`), by the same scoring;
:func:`summarise_runs` gives each metric's mean over seeds with its Student-t interval,
and :func:`load_scored_runs` the same for runs stored one row per seed in a CSV table.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..capstone.evaluation import gospa_parameters
from ..capstone.radars import as_radars, coverage_count
from ..capstone.traffic import Traffic, truth_at
from ..engine.metrics import NeesResult, gospa, nees
from ..engine.montecarlo import MeanEstimate, mean
from ..engine.validation import (
    MEMORY_LIMIT,
    as_float,
    as_float_array,
    as_int,
    as_positive,
    check_size,
)
from ..engine.validation import (
    describe as _describe,
)
from ._settings import TrackHistory

__all__ = ["TrackStates", "TrackingMetrics", "evaluate_tracks", "evaluate_tracks_over_time",
           "load_scored_runs", "summarise_runs", "tracks_at"]


@dataclass(frozen=True)
class TrackingMetrics:
    r"""Scores of one tracking run against the truth at the instants `times`.

    Attributes
    ----------
    times : numpy.ndarray, shape (T,)
    truth_id : numpy.ndarray of int, shape (A,)
        The identity of each true target, in the order of the rows of `track_of` and
        `latency` (:func:`evaluate_tracks`: the sorted distinct `truth_id`;
        :func:`evaluate_tracks_over_time`: the index into ``traffic.icao24``).
    gospa, localisation, missed, false : numpy.ndarray, shape (T,)
        GOSPA at each instant (the positions' unit) and its three parts (that unit to the
        power p; they sum to ``gospa**p``).
    c, p : float
        GOSPA cut-off (the positions' unit) and order; :math:`\alpha = 2`.
    track_of : numpy.ndarray of int, shape (A, T)
        The confirmed track GOSPA's assignment pairs with target ``a`` at ``times[j]``
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
    """

    times: np.ndarray
    truth_id: np.ndarray = field(repr=False)
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

    @property
    def mean_gospa(self) -> float:
        """Mean over the instants of GOSPA (m)."""
        return float(np.mean(self.gospa))

    @property
    def mean_latency(self) -> float:
        """Mean confirmation latency over the aircraft that got a track (s; NaN if none)."""
        ok = np.isfinite(self.latency)
        return float(np.mean(self.latency[ok])) if ok.any() else float("nan")


@dataclass(frozen=True, repr=False)
class TrackStates:
    """Confirmed tracks read at chosen instants (:func:`tracks_at`).

    Attributes
    ----------
    track : numpy.ndarray of int, shape (K,)
        The identities of the tracks with a confirmed row, increasing.
    times : numpy.ndarray, shape (T,)
        The instants.
    state : numpy.ndarray, shape (K, T, 6)
        Track ``k`` at ``times[j]``: its latest confirmed row at most `max_age` before,
        the position moved on at the row's velocity; NaN where the track is not present.
    """

    track: np.ndarray
    times: np.ndarray
    state: np.ndarray

    @property
    def present(self) -> np.ndarray:
        """numpy.ndarray of bool, shape (K, T): track ``k`` is present at ``times[j]``."""
        return np.isfinite(self.state[..., 0])

    def __repr__(self) -> str:
        return (f"TrackStates({self.track.size} tracks x {self.times.size} times, "
                f"{int(self.present.sum())} present)")


def _history_iv(history):
    if not isinstance(history, TrackHistory):
        raise TypeError(f"`history` must be a TrackHistory (from track_reports or "
                        f"stonesoup_track); received {_describe(history)}")


def _times_iv(times, least):
    t = as_float_array(times, "times")
    if t.ndim != 1 or t.size < least or np.any(np.diff(t) <= 0):
        raise ValueError(f"`times` must be at least {least} increasing instants (s); received "
                         f"{_describe(times)}")
    return t


def _tracks_at_iv(history, times, max_age):
    _history_iv(history)
    t = _times_iv(times, 1)
    max_age = as_float(as_positive(max_age, "max_age"), "max_age")
    n_tracks = np.unique(history.track).size
    check_size(8 * 6 * n_tracks * t.size, MEMORY_LIMIT,
               what=f"bytes of track states ({n_tracks} tracks x {t.size} `times`)",
               alternative="fewer `times` (a coarser grid, or windows)")
    return t, max_age


def tracks_at(history, times, *, max_age=15.0) -> TrackStates:
    r"""The confirmed tracks of a history at chosen instants.

    Parameters
    ----------
    history : TrackHistory
        A tracking run (:func:`~radarfusion_ref.tracking.track_reports`, ...).
    times : array_like, shape (T,)
        Increasing instants (s), at least one.
    max_age : float, optional
        A track is present at an instant if its latest confirmed row at or before it is
        at most this old (s, > 0, default 15: longer than a slow radar's revisit).

    Returns
    -------
    TrackStates
        Each track's state there: the row's position moved on at its velocity,
        :math:`\mathbf p + (t - t_k)\mathbf v`, and its velocity; NaN where absent.

    Raises
    ------
    TypeError
        `history` not a :class:`~radarfusion_ref.tracking.TrackHistory`.
    ValueError
        `times` not increasing finite instants, `max_age` not > 0, tracks x times beyond
        the memory limit.

    Examples
    --------
    >>> h = TrackHistory(np.array([7, 7]), np.array([0.0, 10.0]),
    ...                  np.array([[0.0, 0, 0, 1, 0, 0], [10.0, 0, 0, 2, 0, 0]]),
    ...                  np.tile(np.eye(6), (2, 1, 1)), np.array([True, True]))
    >>> s = tracks_at(h, [5.0, 12.0, 40.0], max_age=15.0)
    >>> s.track.tolist(), s.state[0, :2, 0].tolist(), s.present.tolist()
    ([7], [5.0, 14.0], [[True, True, False]])
    """
    t, max_age = _tracks_at_iv(history, times, max_age)
    return _tracks_at(history, t, max_age)


def _tracks_at(history, times, max_age):
    """Kernel of :func:`tracks_at` (trusted input)."""
    conf = history.confirmed
    tr, tm, st = history.track[conf], history.time[conf], history.state[conf]
    order = np.lexsort((tm, tr))
    tr, tm, st = tr[order], tm[order], st[order]
    ids, first = np.unique(tr, return_index=True)
    stops = np.append(first[1:], tr.size)[:ids.size]
    state = np.full((ids.size, times.size, 6), np.nan)
    for k, (a, b) in enumerate(zip(first, stops, strict=True)):
        j = np.searchsorted(tm[a:b], times, side="right") - 1
        ok = j >= 0
        jj = a + np.maximum(j, 0)
        age = times - tm[jj]
        ok &= age <= max_age
        state[k, ok, :3] = st[jj[ok], :3] + age[ok, None] * st[jj[ok], 3:]
        state[k, ok, 3:] = st[jj[ok], 3:]
    return TrackStates(track=ids.astype(np.int64), times=times, state=state)


# --------------------------------------------------------------------------- scoring
def _score(history, t, truth, valid, truth_id, truth_rows, c, p, max_age):
    """The scores of :class:`TrackingMetrics` at instants `t` against `truth` (A, T, 3)
    present where `valid`; `truth_rows(target, times)` gives (truth (N, 3), valid (N,)) of
    target ``target[i]`` (a row of `truth`) at ``times[i]``, for NEES."""
    states = _tracks_at(history, t, max_age)
    ids, est = states.track, states.state[..., :3]
    A, T = valid.shape
    parts = np.zeros((T, 4))
    track_of = np.full((A, T), -1, dtype=np.int64)
    for j in range(T):
        a_idx = np.flatnonzero(valid[:, j])
        k_idx = np.flatnonzero(np.isfinite(est[:, j, 0]))
        g = gospa(truth[a_idx, j], est[k_idx, j], c=c, p=p)
        parts[j] = g.total, g.localisation, g.missed, g.false
        track_of[a_idx[g.pairs[:, 0]], j] = ids[k_idx[g.pairs[:, 1]]]
    switches, per_target, latency = 0, [], np.full(A, np.nan)
    for a in range(A):
        seq = track_of[a][track_of[a] >= 0]
        if not seq.size:
            continue
        switches += int(np.sum(seq[1:] != seq[:-1]))
        per_target.append(np.unique(seq).size)
        first_seen = t[np.argmax(valid[a])]
        latency[a] = t[np.argmax(track_of[a] >= 0)] - first_seen
    present = np.isfinite(est[:, :, 0]).any(axis=1)
    paired = np.isin(ids, track_of[track_of >= 0])
    n_false = int(np.sum(present & ~paired))
    hours = (t[-1] - t[0]) / 3600.0
    return TrackingMetrics(
        times=t, truth_id=truth_id, gospa=parts[:, 0], localisation=parts[:, 1],
        missed=parts[:, 2], false=parts[:, 3], c=c, p=p, track_of=track_of,
        switches=switches,
        tracks_per_aircraft=float(np.mean(per_target)) if per_target else float("nan"),
        n_tracks=int(present.sum()), false_tracks=n_false,
        false_tracks_per_hour=n_false / hours, latency=latency,
        nees=_nees(history, truth_rows, track_of))


def _evaluate_iv(history, c, p, times, max_age, n_truth):
    _history_iv(history)
    c, p = gospa_parameters(c, p)
    t = _times_iv(times, 2)
    max_age = as_float(as_positive(max_age, "max_age"), "max_age")
    n_tracks = np.unique(history.track).size
    check_size(8 * 6 * max(n_tracks, n_truth) * t.size, MEMORY_LIMIT,
               what=f"bytes of track and truth states ({n_tracks} tracks, "
                    f"{n_truth} targets x {t.size} `times`)",
               alternative="fewer `times` (a coarser grid, or windows)")
    return c, p, t, max_age


def _truth_iv(truth_time, truth_position, truth_id):
    tt = as_float_array(truth_time, "truth_time", ndim_min=1)
    if tt.ndim != 1 or not tt.size:
        raise ValueError(f"`truth_time` must have shape (N,), N >= 1; received "
                         f"{_describe(truth_time)}")
    n = tt.size
    pos = as_float_array(truth_position, "truth_position", ndim_min=2, last_dims=(3,))
    if pos.shape != (n, 3):
        raise ValueError(f"`truth_position` must have shape ({n}, 3); received shape "
                         f"{pos.shape}")
    ident = (np.asarray(truth_id) if not isinstance(truth_id, (str, bytes))
             and truth_id is not None else None)
    if ident is None or ident.dtype.kind not in "iu" or ident.shape != (n,):
        raise TypeError(f"`truth_id` must be an integer array of shape ({n},); received "
                        f"{_describe(truth_id)}")
    key = np.lexsort((tt, ident))
    same = (np.diff(ident[key]) == 0) & (np.diff(tt[key]) == 0)
    if same.any():
        k = key[np.flatnonzero(same)[0]]
        raise ValueError(f"`truth_id`, `truth_time`: target {int(ident[k])} has two positions "
                         f"at time {float(tt[k])!r}; give one per (id, time)")
    return tt, pos, ident


class _Samples:
    """Truth samples of each target, linearly interpolated between its own samples."""

    def __init__(self, tt, pos, ident):
        self.ids, inv = np.unique(ident, return_inverse=True)
        order = np.lexsort((tt, inv))
        self.inv, self.t, self.pos = inv[order], tt[order], pos[order]
        self.bounds = np.searchsorted(self.inv, np.arange(self.ids.size + 1))

    def at_pairs(self, target, times):
        """Target ``target[i]`` (index into `ids`) at ``times[i]``: positions (N, 3), NaN
        where not valid, and valid (N,), as :meth:`__call__` gives them, pair by pair."""
        out = np.full((target.size, 3), np.nan)
        valid = np.zeros(target.size, bool)
        order = np.argsort(target, kind="stable")
        cuts = np.searchsorted(target[order], np.arange(self.ids.size + 1))
        for a in np.flatnonzero(np.diff(cuts)):
            q = order[cuts[a]:cuts[a + 1]]
            lo, hi = self.bounds[a], self.bounds[a + 1]
            ts, ps = self.t[lo:hi], self.pos[lo:hi]
            ok = (times[q] >= ts[0]) & (times[q] <= ts[-1])
            valid[q] = ok
            for d in range(3):
                out[q[ok], d] = np.interp(times[q][ok], ts, ps[:, d])
        return out, valid

    def __call__(self, times):
        A = self.ids.size
        out = np.full((A, times.size, 3), np.nan)
        valid = np.zeros((A, times.size), bool)
        for a in range(A):
            lo, hi = self.bounds[a], self.bounds[a + 1]
            ts, ps = self.t[lo:hi], self.pos[lo:hi]
            ok = (times >= ts[0]) & (times <= ts[-1])
            valid[a] = ok
            for d in range(3):
                out[a, ok, d] = np.interp(times[ok], ts, ps[:, d])
        return out, valid


def evaluate_tracks(history, truth_time, truth_position, truth_id, *, c, p=2.0, times,
                    max_age=15.0) -> TrackingMetrics:
    r"""Score confirmed tracks against a truth given as arrays, at the given instants.

    Parameters
    ----------
    history : TrackHistory
        A tracking run (:func:`~radarfusion_ref.tracking.track_reports`, ...).
    truth_time : array_like, shape (N,)
        Instants of the truth samples (s).
    truth_position : array_like, shape (N, 3)
        The true positions, in the unit and frame of the tracks.
    truth_id : array_like of int, shape (N,)
        The true target of each sample (any integers), one sample per (id, time).
    c : float
        GOSPA cut-off (> 0), in the positions' unit.
    p : float, optional
        GOSPA order (>= 1, default 2); :math:`\alpha = 2`.
    times : array_like, shape (T,)
        Increasing instants of evaluation (s), at least two.
    max_age : float, optional
        As :func:`tracks_at` (s, default 15).

    Returns
    -------
    TrackingMetrics
        `truth_id` holds the sorted distinct target ids (the rows of `track_of`).

    Raises
    ------
    TypeError
        `history` not a :class:`~radarfusion_ref.tracking.TrackHistory`, `truth_id` not
        integers, non-numeric arrays.
    ValueError
        Shapes that disagree, non-finite entries, two samples of one target at one
        instant, bad `c`, `p`, `times` or `max_age`, or sizes beyond the memory limit.

    Notes
    -----
    A target is in the truth set at instant :math:`t` when :math:`t` lies between its
    first and last samples; its position there is interpolated linearly between the
    samples around :math:`t` (exact for constant velocity). At each instant the present
    confirmed tracks (:func:`tracks_at`) are compared with the truth set by GOSPA
    (:func:`radarfusion_ref.engine.metrics.gospa`), and its optimal assignment's pairs
    give the identity metrics: a switch is a target paired with another track than at
    its previous pairing; a false track is a confirmed track never paired; latency runs
    from a target's first instant in the truth set to its first pairing. NEES is that of
    each confirmed row of a paired track against the target its track is paired with
    most often, at the row's own time.

    Examples
    --------
    >>> h = TrackHistory(np.array([3, 3]), np.array([0.0, 10.0]),
    ...                  np.array([[0.0, 0, 0, 1, 0, 0], [10.0, 0, 0, 1, 0, 0]]),
    ...                  np.tile(np.eye(6), (2, 1, 1)), np.array([True, True]))
    >>> m = evaluate_tracks(h, [0.0, 20.0], [[0.0, 1, 0], [20.0, 1, 0]], [41, 41],
    ...                     c=5.0, times=[0.0, 10.0, 20.0])
    >>> m.gospa.tolist(), m.switches, m.false_tracks, m.truth_id.tolist()
    ([1.0, 1.0, 1.0], 0, 0, [41])
    """
    _history_iv(history)
    tt, pos, ident = _truth_iv(truth_time, truth_position, truth_id)
    c, p, t, max_age = _evaluate_iv(history, c, p, times, max_age, np.unique(ident).size)
    samples = _Samples(tt, pos, ident)
    truth, valid = samples(t)
    return _score(history, t, truth, valid, samples.ids.astype(np.int64), samples.at_pairs,
                  c, p, max_age)


def evaluate_tracks_over_time(history, traffic, *, c=2000.0, p=2.0, times, radars=None,
                              min_radars=1, max_age=15.0) -> TrackingMetrics:
    r"""Score confirmed tracks against the ADS-B truth at the given instants.

    The ADS-B adapter of :func:`evaluate_tracks`: the truth is the traffic's aircraft,
    interpolated by :func:`radarfusion_ref.capstone.truth_at`, optionally restricted to
    the radars' coverage.

    Parameters
    ----------
    history : TrackHistory
        A tracking run (:func:`~radarfusion_ref.tracking.track_reports`,
        :func:`~radarfusion_ref.tracking.stonesoup.stonesoup_track`, ...).
    traffic : Traffic
        The truth (:func:`radarfusion_ref.capstone.load_traffic`).
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
        As :func:`tracks_at` (s, default 15).

    Returns
    -------
    TrackingMetrics
        `truth_id` is the index of each aircraft into ``traffic.icao24``.

    Raises
    ------
    TypeError
        Wrong types of `history`, `traffic` or `radars`.
    ValueError
        Bad `c`, `p`, `times`, `min_radars` or `max_age`, tracks x truth x times beyond
        the memory limit, or confirmed rows whose position covariance is not symmetric
        positive definite (named `history`).

    Notes
    -----
    Scored as :func:`evaluate_tracks` describes; the truth set at an instant is every
    aircraft :func:`~radarfusion_ref.capstone.truth_at` knows then (inside the coverage,
    with `radars`), and the NEES compares each row with the aircraft's interpolated
    position at the row's own time.

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
    _history_iv(history)
    if not isinstance(traffic, Traffic):
        raise TypeError(f"`traffic` must be a Traffic (from load_traffic); received "
                        f"{_describe(traffic)}")
    c, p, t, max_age = _evaluate_iv(history, c, p, times, max_age, len(traffic.icao24))
    if radars is not None:
        radars = as_radars(radars)
        min_radars = as_int(min_radars, "min_radars", minimum=1, maximum=len(radars))
    truth, valid = truth_at(traffic, t)
    if radars is not None:
        cov = np.zeros(valid.shape, dtype=bool)
        cov[valid] = coverage_count(truth[valid], radars) >= min_radars
        valid = cov
    return _score(history, t, truth, valid, np.arange(valid.shape[0], dtype=np.int64),
                  lambda target, at: _truth_at_pairs(traffic, target, at), c, p, max_age)


def _truth_at_pairs(traffic, target, times):
    """Aircraft ``target[i]`` at ``times[i]`` by :func:`~radarfusion_ref.capstone.truth_at`,
    asked for a block of distinct instants at a time (the whole fleet at each), so memory
    stays bounded whatever the number of instants."""
    out = np.full((target.size, 3), np.nan)
    valid = np.zeros(target.size, bool)
    at, inv = np.unique(times, return_inverse=True)
    block = max(1, _TRUTH_BLOCK // (8 * 8 * max(len(traffic.icao24), 1)))
    order = np.argsort(inv, kind="stable")
    cuts = np.searchsorted(inv[order], np.arange(0, at.size + block, block))
    for b, lo in enumerate(range(0, at.size, block)):
        sel = order[cuts[b]:cuts[b + 1]]
        pos, ok = truth_at(traffic, at[lo:lo + block])
        out[sel] = pos[target[sel], inv[sel] - lo]
        valid[sel] = ok[target[sel], inv[sel] - lo]
    return out, valid


#: Bytes of the fleet's truth asked of ``truth_at`` at once, for the NEES rows.
_TRUTH_BLOCK = 1 << 26


def _nees(history, truth_rows, track_of):
    """Position NEES of the confirmed rows of paired tracks against their main target."""
    pairs = np.stack(np.nonzero(track_of >= 0), axis=-1)
    if not pairs.size:
        return None
    trk = track_of[pairs[:, 0], pairs[:, 1]]
    key, counts = np.unique(np.stack([trk, pairs[:, 0]], axis=-1), axis=0, return_counts=True)
    order = np.lexsort((-counts, key[:, 0]))                 # most pairings first per track
    key = key[order]
    first = np.unique(key[:, 0], return_index=True)[1]
    tracks, mains = key[first, 0], key[first, 1]         # each paired track's main target
    rows = np.flatnonzero(history.confirmed & np.isin(history.track, tracks))
    if not rows.size:
        return None
    target = mains[np.searchsorted(tracks, history.track[rows])]
    truth, ok = truth_rows(target, history.time[rows])             # only the pairs needed
    if not ok.any():
        return None
    err = history.state[rows[ok], :3] - truth[ok]
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
        ``mean_latency`` and ``nees`` (the runs' mean NEES; the interval the replication
        supports), by :func:`radarfusion_ref.engine.montecarlo.mean`.

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
    return out


def _scored_runs_iv(path, by):
    if not isinstance(path, (str, Path)) or not str(path):
        raise TypeError(f"`path` must be the path of a CSV file (str or pathlib.Path); "
                        f"received {_describe(path)}")
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"`path` must name an existing CSV file; received {str(path)!r}")
    by = (by,) if isinstance(by, str) else by
    if (not isinstance(by, tuple) or not by
            or not all(isinstance(b, str) and b for b in by)):
        raise TypeError(f"`by` must be a column name or a tuple of column names; received "
                        f"{_describe(by)}")
    with path.open(newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    columns = list(rows[0]) if rows else []
    missing = [b for b in (*by, "seed") if b not in columns]
    if missing:
        raise ValueError(f"`path`: the table {path.name!r} must have the columns "
                         f"{[*by, 'seed']} and numeric ones; it lacks {missing} (its columns: "
                         f"{columns})")
    return path, by, rows, columns


def load_scored_runs(path, *, by="tracker") -> dict:
    r"""Each metric's mean over seeds, with its Student-t interval, from a CSV of runs.

    The reader of the benchmark tables (one row per run and seed, e.g.
    ``benchmarks/data/tracking_scored.csv``): the rows are grouped by the column(s) `by`,
    and every other numeric column is summarised over each group's seeds by
    :func:`radarfusion_ref.engine.montecarlo.mean`, as :func:`summarise_runs` does for
    runs in memory.

    Parameters
    ----------
    path : str or pathlib.Path
        A CSV file with a header row, a ``seed`` column, the column(s) `by`, and numeric
        metric columns (a column of labels, non-numeric in every row, is left out; one
        numeric in some rows only refuses the table).
    by : str or tuple of str, optional
        The column(s) that name a run (default ``"tracker"``).

    Returns
    -------
    dict
        Keyed by the value of `by` (a tuple of the values when `by` is a tuple), in the
        table's order; each value a dict of column name to
        :class:`~radarfusion_ref.engine.montecarlo.MeanEstimate` (95 %).

    Raises
    ------
    TypeError
        `path` not a str or path, `by` not column names.
    ValueError
        No such file, a missing column, a group with fewer than two seeds or one seed
        twice, a metric column empty, non-numeric or not finite in some row.

    Examples
    --------
    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as d:
    ...     f = os.path.join(d, "runs.csv")
    ...     _ = open(f, "w").write("tracker,seed,gospa\na,1,10\na,2,12\nb,1,9\nb,2,9\n")
    ...     runs = load_scored_runs(f)
    >>> list(runs), runs["a"]["gospa"].estimate, runs["b"]["gospa"].trials
    (['a', 'b'], 11.0, 2)
    """
    path, by, rows, columns = _scored_runs_iv(path, by)
    metrics = []
    for c in columns:
        if c in (*by, "seed"):
            continue
        numeric = [_is_number(r[c]) for r in rows]
        if all(numeric):
            metrics.append(c)
        elif any(numeric):
            n = numeric.index(False) + 2
            raise ValueError(f"`path`: column {c!r} must be numeric in every row; line {n} "
                             f"holds {rows[n - 2][c]!r}")
    groups: dict = {}
    for n, r in enumerate(rows, start=2):
        key = tuple(r[b] for b in by)
        groups.setdefault(key, []).append((n, r))
    out = {}
    for key, members in groups.items():
        seeds = [r["seed"] for _, r in members]
        name = key[0] if len(by) == 1 else key
        if len(set(seeds)) != len(seeds) or len(seeds) < 2:
            raise ValueError(f"`path`: {name!r} must have at least two rows, one per seed; "
                             f"received seeds {seeds}")
        summary = {}
        for c in metrics:
            values = [float(r[c]) for _, r in members]
            bad = [(n, r[c]) for (n, r), v in zip(members, values, strict=True)
                   if not math.isfinite(v)]
            if bad:
                raise ValueError(f"`path`: column {c!r} of {name!r} must be finite; line "
                                 f"{bad[0][0]} holds {bad[0][1]!r}")
            summary[c] = mean(values)
        out[name] = summary
    return out


def _is_number(text) -> bool:
    """Whether a CSV entry reads as a number (NaN and inf included: refused later)."""
    try:
        float(text)
    except (TypeError, ValueError):
        return False
    return True
