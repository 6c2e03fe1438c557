r"""Architecture (a): one tracker fed every report in time order (:func:`track_reports`)."""

from __future__ import annotations

import itertools
import math
import warnings

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial import cKDTree

from .. import gating
from ..engine import assignment
from ..engine.errors import RadarFusionWarning
from ..engine.linalg import mahalanobis_sq_kernel
from ..engine.tracker import (
    event_bound,
    exact_kernel,
    increments_kernel,
    kbest_kernel,
    predict_kernel,
    update_kernel,
    window_kernel,
)
from ..engine.validation import (
    MAX_MAGNITUDE,
    MEMORY_LIMIT,
    as_covariance,
    as_float_array,
    check_size,
    describe,
)
from . import _feature
from ._motion import (
    axis_q,
    imm_gnn_update,
    imm_increments,
    imm_jpda_update,
    imm_predict_live,
    mode_q,
    predict,
    velocity_sd,
)
from ._settings import TrackerSettings, TrackHistory, _in_unit

#: Largest number of reports of one call (memory of the inputs and their sort).
MAX_REPORTS = 50_000_000


class _Live:
    """The live tracks, as parallel arrays (one row per track)."""

    FIELDS = ("x", "P", "t", "t_hit", "score", "peak", "confirmed", "ids", "recent", "scored",
              "key", "born", "mu", "xm", "Pm", "f", "Pf")

    def __init__(self, n_window, modes=0):
        self.x = np.zeros((0, 6))
        self.P = np.zeros((0, 6, 6))
        self.t = np.zeros(0)
        self.t_hit = np.zeros(0)
        self.score = np.zeros(0)
        self.peak = np.zeros(0)
        self.confirmed = np.zeros(0, dtype=bool)
        self.ids = np.zeros(0, dtype=np.int64)
        self.recent = np.zeros((0, n_window), dtype=bool)     # M-of-N: last n scored scans
        self.scored = np.zeros(0, dtype=np.int64)
        self.key = np.zeros(0, dtype=np.int64)      # start order, never changes (ids may)
        self.born = np.zeros(0)
        self.mu = np.zeros((0, modes))               # IMM: mode probabilities, states, covs
        self.xm = np.zeros((0, modes, 6))
        self.Pm = np.zeros((0, modes, 6, 6))
        self.f = np.zeros(0)                         # the feature's estimate and variance
        self.Pf = np.zeros(0)

    def keep(self, mask):
        for f in self.FIELDS:
            setattr(self, f, getattr(self, f)[mask])

    def extend(self, kept=None, **new):
        """Append the tracks `new` (one array per field), after keeping the rows `kept`
        (a mask; None: all), in one copy."""
        for f in self.FIELDS:
            a = getattr(self, f)
            setattr(self, f, np.concatenate([a if kept is None else a[kept], new[f]]))


class _Rows:
    """Rows written out: confirmed tracks' rows, and the pending rows of tentative tracks.

    Each row written out carries its place in the order of writing (``seq`` of its chunk,
    then its place in it), which breaks the ties of (time, track) in the history as the
    order of writing would. The pending rows are sorted out in batches, when they have
    doubled since the last sorting (so the work per row stays constant however many
    tentative tracks are alive): a promoted track's rows then go out with the place they
    had when it was promoted, a dropped track's are forgotten.
    """

    #: Pending rows below which they are not sorted out.
    MIN_BATCH = 4096

    def __init__(self):
        self.out = []          # (ids, time, state, cov, confirmed, mu, seq, place) chunks
        self.pending = []      # (ids, time, state, cov, confirmed, mu, place) of tentatives
        self.n_chunks = 0      # chunks written (the next seq)
        self.n_pending = 0     # pending rows added so far (the next place)
        self.n_sorted = 0      # pending rows left at the last sorting
        self.n_new = 0         # pending rows added since
        self.promoted: dict[int, int] = {}     # id -> seq, rows not moved out yet
        self.dropped: list[np.ndarray] = []    # ids whose pending rows are to be forgotten

    def _write(self, chunk):
        n = chunk[0].size
        self.out.append((*chunk, np.full(n, self.n_chunks), np.arange(n)))
        self.n_chunks += 1

    def add(self, ids, t, x, P, confirmed, mu):
        if not ids.size:
            return
        chunk = (ids.copy(), np.full(ids.size, t), x.copy(), P.copy(), confirmed.copy(),
                 mu.copy())
        if confirmed.all():
            self._write(chunk)
            return
        if confirmed.any():
            self._write(tuple(c[confirmed] for c in chunk))
            chunk = tuple(c[~confirmed] for c in chunk)
        n = chunk[0].size
        self.pending.append((*chunk, self.n_pending + np.arange(n)))
        self.n_pending += n
        self.n_new += n

    def settle(self, promoted, dropped):
        """The pending rows of `promoted` tracks go out (in place of a chunk written now);
        those of `dropped` ones are forgotten."""
        if promoted.size:
            for i in promoted.tolist():
                self.promoted[i] = self.n_chunks
            self.n_chunks += 1
        if dropped.size:
            self.dropped.append(dropped)
        if self.n_new > max(self.n_sorted, self.MIN_BATCH):
            self._sort_out()

    def _sort_out(self):
        self.n_new = 0
        if not self.pending:
            self.promoted, self.dropped = {}, []
            return
        cols = [np.concatenate(c) for c in zip(*self.pending, strict=True)]
        ids = cols[0]
        rest = np.ones(ids.size, bool)
        if self.promoted:
            pid = np.fromiter(self.promoted, np.int64, len(self.promoted))
            pseq = np.fromiter(self.promoted.values(), np.int64, len(self.promoted))
            up = np.isin(ids, pid)
            if up.any():
                o = np.argsort(pid)
                seq = pseq[o][np.searchsorted(pid[o], ids[up])]
                self.out.append((*(c[up] for c in cols[:6]), seq, cols[6][up]))
                rest &= ~up
        if self.dropped:
            rest &= ~np.isin(ids, np.concatenate(self.dropped))
        self.promoted, self.dropped = {}, []
        self.pending = [tuple(c[rest] for c in cols)] if rest.any() else []
        self.n_sorted = int(rest.sum())

    def history(self, initiated, alias=None, modes=0):
        self._sort_out()
        mu0 = np.zeros((0, modes)) if modes else None
        if not self.out:
            return TrackHistory(np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 6)),
                                np.zeros((0, 6, 6)), np.zeros(0, bool), initiated, mu0)
        ids, t, x, P, c, mu, seq, place = (np.concatenate(v)
                                           for v in zip(*self.out, strict=True))
        if alias:                                        # a relinked track takes its old id
            u, inv = np.unique(ids, return_inverse=True)
            for n, i in enumerate(u):
                while int(i) in alias:
                    i = alias[int(i)]
                u[n] = i
            ids = u[inv]
        o = np.lexsort((place, seq, ids, t))
        return TrackHistory(ids[o], t[o], x[o], P[o], c[o], initiated,
                            mu[o] if modes else None)


def _reports_iv(time, position, cov, radar, scan, settings):
    if not isinstance(settings, TrackerSettings):
        raise TypeError(f"`settings` must be a TrackerSettings; received {describe(settings)}")
    t = as_float_array(time, "time", ndim_min=1)
    if t.ndim != 1:
        raise ValueError(f"`time` must have shape (N,); received shape {t.shape}")
    n = t.size
    if n > MAX_REPORTS:
        raise ValueError(f"`time`: {n} reports exceed the limit MAX_REPORTS = {MAX_REPORTS}; "
                         "track the window in consecutive slices")
    span = float(t.max() - t.min()) if n else 0.0
    q = np.maximum(axis_q(settings), mode_q(settings).max(axis=0))
    var = velocity_sd(settings) ** 2 * span**2 + q * span**3 / 3
    if var.max() > MAX_MAGNITUDE:                # a track predicted across the whole window
        raise ValueError(f"`time` spans {span:.6g} s: a track predicted across it would have "
                         f"a position variance of {var.max():.3g} m², beyond the numeric domain "
                         "[2**-150, 2**150]; track consecutive windows of time")
    z = as_float_array(position, "position", ndim_min=2, last_dims=(3,))
    if z.shape != (n, 3):
        raise ValueError(f"`position` must have shape ({n}, 3); received shape {z.shape}")
    R = as_covariance(cov, "cov", dim=3) if n else np.zeros((0, 3, 3))
    if R.shape != (n, 3, 3):
        raise ValueError(f"`cov` must have shape ({n}, 3, 3); received shape {R.shape}")
    out = []
    for name, v in (("radar", radar), ("scan", scan)):
        a = np.asarray(v) if not isinstance(v, (str, bytes)) and v is not None else None
        if a is None or a.dtype.kind not in "iu" or a.shape != (n,):
            raise TypeError(f"`{name}` must be an integer array of shape ({n},); received "
                            f"{describe(v)}")
        if n and a.min() < 0:
            raise ValueError(f"`{name}` must be >= 0; received smallest entry {a.min()}")
        out.append(a.astype(np.int64))
    return t, z, R, out[0], out[1]


def track_reports(time, position, cov, radar, scan, *, feature=None, feature_var=None,
                  settings=None) -> TrackHistory:
    r"""Architecture (a): every report, in time order, updates one tracker.

    Parameters
    ----------
    time : array_like, shape (N,)
        Report instants (s). Reports are processed in order of time, then radar, then
        (within one scan) east, north and up position: input in any other order is
        **sorted** so (no report is dropped), as a fusion centre that buffers the window
        would; the result depends on the reports, not on their order.
    position : array_like, shape (N, 3)
        Reports in the common east-north-up frame, finite, in units of
        `settings.length_unit` metres (default: m).
    cov : array_like, shape (N, 3, 3)
        Each report's own error covariance (that unit squared), positive definite.
    radar : array_like of int, shape (N,)
        The radar of each report: any integers (≥ 0), only compared with each other.
    scan : array_like of int, shape (N,)
        The radar's own scan number of each report: the reports of one radar at one
        instant form a scan, processed together.
    feature, feature_var : array_like, shape (N,), optional
        A scalar feature of each report (e.g. the capstone's speed feature, kt) and its
        error variance (> 0, that unit squared); with them a pair's score increment
        gains the feature's log-likelihood ratio (Notes). None (default, both): position
        only.
    settings : TrackerSettings, optional
        Defaults if None.

    Returns
    -------
    TrackHistory
        One row per (track, update), in the reports' unit; tentative tracks that were
        deleted leave no row.

    Warns
    -----
    RadarFusionWarning
        The reports' median standard deviation, in metres, is outside 1 m to 100 km
        (``PLAUSIBLE_SIGMA``): positions likely in another unit than
        `settings.length_unit` says.

    Raises
    ------
    ValueError
        NaN or infinite entries (named, with the row), a covariance not positive
        definite, wrong shapes, negative radar or scan numbers, too many reports; a
        `feature` without its `feature_var` or the reverse, a feature variance <= 0.
    TypeError
        Non-numeric input, non-integer `radar` or `scan`, `settings` not a
        :class:`TrackerSettings`.

    Notes
    -----
    Per scan (one radar at one instant): every live track is predicted to the instant
    (:func:`radarfusion_ref.engine.tracker.kalman_predict`'s kernel); a report enters a
    track's gate when :math:`d^2 = \boldsymbol\nu^\mathsf T S^{-1}\boldsymbol\nu` is below
    :func:`radarfusion_ref.gating.gate_threshold` (3 degrees of freedom). Only the tracks
    whose search radius :math:`\sqrt{\gamma\,(\operatorname{tr}P + \max\operatorname{tr}R)}`
    (:math:`|\boldsymbol\nu|^2 \le d^2\operatorname{tr}S`) reaches the bounding box of the
    scan's reports are gated (:math:`\gamma` the gate threshold), so a scan's gating,
    association and updates cost in proportion to the tracks near its radar, not to all
    the tracks of a wide airspace. Clusters of
    tracks and reports linked by gates are solved apart:

    * ``"gnn"`` — the assignment that maximises the summed score increments
      :math:`\ln\frac{P_D\mathcal N(\boldsymbol\nu; 0, S)}{\lambda}` (hit) and
      :math:`\ln(1 - P_D)` (miss), by :func:`radarfusion_ref.engine.assignment.assign_two_lists`
      on :math:`[\,-\Delta L_{ij} \mid \operatorname{diag}(-\ln(1 - P_D))\,]`;
    * ``"jpda"`` — each track is updated with the mixture of its gated reports weighted by
      :func:`radarfusion_ref.engine.tracker.jpda_probabilities` (exact up to
      `settings.max_events` joint events, else the `settings.k` best); a track whose
      probability of a report exceeds 1/2 counts a hit, and its score grows by the
      probability-weighted hit increment, otherwise by a miss.

    A report no track takes (JPDA: total association probability below 1/2) starts a
    tentative track at the report with velocity :math:`0 \pm` `speed_max` (vertically
    `speed_max_vertical`) and score 0.
    A radar's miss lowers a score only if that radar reported the track within its last
    `miss_scans` scans. With ``confirmation="sprt"`` a tentative track is confirmed when
    its score reaches :math:`\ln\frac{1-\beta}{\alpha}` and deleted at
    :math:`\ln\frac{\beta}{1-\alpha}`; a confirmed one is deleted when its score falls
    that same width below its peak. With ``"m_of_n"`` a track is confirmed when `m` of its
    last `n` scored scans were hits, and deleted (tentative) when it can no longer be or
    (confirmed) after `n` scored misses in a row. Any track is deleted after `max_coast`
    seconds without a hit (a tentative one after `max_coast_tentative`, if set). With
    `settings.relink`, a track about to be confirmed that duplicates a confirmed track is
    deleted, and a newly confirmed track may continue the identity of one that lost its
    reports (see :class:`TrackerSettings`).

    With `feature`, each track also estimates its target's feature (a random walk of
    intensity `settings.q_feature`, started at its first report, updated by a scalar
    Kalman filter), and each gated pair's increment gains
    :math:`\ln\mathcal N(f_j;\hat f,P_f+\sigma_j^2) - \ln\lambda_f`
    (:math:`\lambda_f` = `settings.feature_density`): reports whose features disagree with
    the track's are less likely to be taken, and a run of false reports with scattered
    features is less likely to be confirmed.

    With ``motion="imm"`` each track carries the interacting multiple model's modes
    (:func:`radarfusion_ref.engine.tracker.imm_predict` and ``imm_update``'s kernels): the
    gate is on the combined prediction, a pair's increment is
    :math:`\ln\frac{P_D\sum_j\bar c_j\Lambda_j}{\lambda}` (the mixture of the mode
    likelihoods), GNN updates every mode with its report, and JPDA keeps per mode the
    moments of the posterior mixture over (event, mode); the rows hold the combined
    estimate.

    The memory is bounded by the live tracks and those lost within `max_coast`: a deleted
    tentative track's rows are forgotten, a confirmed track's rows are written out as they
    come.

    Examples
    --------
    >>> t = np.repeat(np.arange(6) * 5.0, 1)
    >>> z = np.c_[100.0 * t, np.zeros(6), np.full(6, 9000.0)]
    >>> h = track_reports(t, z, np.tile(np.eye(3) * 100.0, (6, 1, 1)), np.zeros(6, int),
    ...                   np.arange(6), settings=TrackerSettings(p_false_confirm=0.01))
    >>> int(h.n_confirmed), bool(h.confirmed[-1]), round(float(h.state[-1, 3]))
    (1, True, 100)
    """
    settings = TrackerSettings() if settings is None else settings
    t, z, R, radar, scan = _reports_iv(time, position, cov, radar, scan, settings)
    f, fv = _feature.features_iv(feature, feature_var, t.size)
    if not t.size:
        return _Rows().history(0, modes=_modes(settings))
    u = settings.length_unit
    z, R = z * u, R * u**2                                   # metres, as the settings
    _warn_scale(R)
    radar = np.unique(radar, return_inverse=True)[1].reshape(-1)    # ids 0..n_radars-1
    order = np.lexsort((z[:, 2], z[:, 1], z[:, 0], radar, t))   # time, radar, then position
    t, z, R, radar, scan = t[order], z[order], R[order], radar[order], scan[order]
    if f is not None:
        f, fv = f[order], fv[order]
    new_group = np.r_[True, (np.diff(t) != 0) | (np.diff(radar) != 0)]
    starts = np.flatnonzero(new_group)
    ends = np.r_[starts[1:], t.size]
    state = _Tracker(settings)
    for a, b in zip(starts, ends, strict=True):
        state.scan(float(t[a]), int(radar[a]), int(scan[a]), z[a:b], R[a:b],
                   None if f is None else (f[a:b], fv[a:b]))
    return _in_unit(state.rows.history(state.next_id, state.alias, _modes(settings)), u)


def _modes(settings):
    """Modes whose probabilities the rows carry: the IMM's, none for one filter."""
    return len(settings.imm_q) if settings.motion == "imm" else 0


#: Plausible standard deviations of a report (m): outside, the unit was likely not stated.
PLAUSIBLE_SIGMA = (1.0, 1e5)


def _warn_scale(R):
    """Warn when the reports' median standard deviation (m) is implausible."""
    sigma = float(np.sqrt(np.median(np.trace(R, axis1=1, axis2=2)) / 3))
    lo, hi = PLAUSIBLE_SIGMA
    if not lo <= sigma <= hi:
        warnings.warn(f"the reports' median standard deviation is {sigma:.3g} m, outside "
                      f"[{lo:g}, {hi:g}] m: if the positions are not in metres, state "
                      "`length_unit` (metres per unit, 1000 for km) in TrackerSettings; the "
                      "settings' clutter density, process noise and speeds are in SI units",
                      RadarFusionWarning, stacklevel=3)


#: The last scan at which a radar reported a track it never reported.
_NEVER = 1 << 40


class _Tracker:
    """The tracker's state between scans and the processing of one scan."""

    def __init__(self, s: TrackerSettings):
        self.s = s
        self.imm = s.motion == "imm"
        self.qm = mode_q(s)
        self.q_axis = axis_q(s)
        self.live = _Live(s.n, self.qm.shape[0] if self.imm else 0)
        # per radar: the keys (increasing) of the tracks it reported, and its last scan of each
        self.seen: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self.rows = _Rows()
        self.next_id = 0
        self.gamma = float(gating.gate_threshold(s.p_false_reject, 3))
        self.p_gate = 1.0 - s.p_false_reject
        self.miss_inc = math.log(1.0 - s.p_detection)
        self.alias: dict[int, int] = {}
        self.feat = None                                 # this scan's (features, variances)
        self.gamma_relink = float(gating.gate_threshold(s.p_relink, 3))
        # confirmed tracks lost within max_coast, for relinking: ids, x, P, t, t_hit
        self.lost = (np.zeros(0, np.int64), np.zeros((0, 6)), np.zeros((0, 6, 6)),
                     np.zeros(0), np.zeros(0))

    # ------------------------------------------------------------------ gate
    def _gate(self, z, R):
        """Gated (track, report) pairs with d² and ln det S, in order of track then report.

        Only tracks near the scan are looked at: a report within a track's search radius
        lies in the reports' bounding box grown by that radius, so the tracks outside it
        (most of a wide airspace) have no candidate and skip the tree query.
        """
        lv = self.live
        T, M = lv.ids.size, z.shape[0]
        empty = np.zeros(0, np.int64)
        if not T or not M:
            return empty, empty, np.zeros(0), np.zeros(0)
        spread = np.trace(lv.P[:, :3, :3], axis1=1, axis2=2) + np.trace(R, axis1=1, axis2=2).max()
        radius = np.sqrt(self.gamma * spread)            # |ν|² <= tr(S) d²: a sound prefilter
        near = _near_box(lv.x[:, :3], radius, z)
        if not near.size:
            return empty, empty, np.zeros(0), np.zeros(0)
        lists = cKDTree(z).query_ball_point(lv.x[near, :3], radius[near], return_sorted=True)
        counts = np.fromiter((len(v) for v in lists), np.int64, near.size)
        if not counts.sum():
            return empty, empty, np.zeros(0), np.zeros(0)
        ti = np.repeat(near, counts)
        rj = np.fromiter(itertools.chain.from_iterable(lists), np.int64, int(counts.sum()))
        ld: list = []
        d2 = mahalanobis_sq_kernel(z[rj] - lv.x[ti, :3], lv.P[ti, :3, :3] + R[rj],
                                   "`position`, `cov`", ld)
        ok = d2 < self.gamma
        return ti[ok], rj[ok], d2[ok], ld[0][ok]

    # ------------------------------------------------------------------ one scan
    def scan(self, t, r, s, z, R, feat=None):
        """Process one scan of radar `r` (its scan `s`) at `t`: reports `z`, `R`, and their
        features ``feat = (f, variance)`` or None."""
        lv, st = self.live, self.s
        self.feat = feat
        if feat is not None and lv.ids.size:
            lv.Pf = lv.Pf + st.q_feature * (t - float(lv.t[0]))
        if lv.ids.size and self.imm:
            imm_predict_live(lv, t, st, self.qm)
            lv.t[:] = t
        elif lv.ids.size:                                # all at the last scan's instant
            lv.x, lv.P = predict_kernel(lv.x, lv.P, t - float(lv.t[0]), self.q_axis,
                                        per_axis=True)
            lv.t[:] = t
        T, M = lv.ids.size, z.shape[0]
        scored = self._scored(r, s)
        ti, rj, d2, ld = self._gate(z, R)
        inc_pair = (imm_increments(lv, ti, rj, z, R, st) if self.imm and ti.size
                    else increments_kernel(d2, ld, st.p_detection, st.clutter_density))
        if feat is not None and ti.size:
            inc_pair = inc_pair + _feature.increments(lv.f[ti], lv.Pf[ti], feat[0][rj],
                                                      feat[1][rj], st.feature_density)
        inc = np.where(scored, self.miss_inc, 0.0)       # a miss, unless a report is taken
        hit = np.zeros(T, dtype=bool)
        used = np.zeros(M)                               # total probability of each report
        if ti.size:
            pair_lab = _clusters(ti, rj, M)
            if st.association == "gnn":
                self._gnn(z, R, ti, rj, inc_pair, pair_lab, scored, inc, hit, used)
            else:
                self._jpda(z, R, ti, rj, inc_pair, pair_lab, scored, inc, hit, used)
        seen = lv.key[hit]
        lv.t_hit[hit] = t
        kept = self._score(t, inc, hit, scored)
        fresh = used < 0.5
        if feat is not None:
            self.feat = (feat[0][fresh], feat[1][fresh])
        born = self._start(t, r, s, z[fresh], R[fresh], kept)
        self._see(r, s, np.concatenate([seen, born]))

    def _scored(self, r, s):
        """Tracks whose miss at radar `r`'s scan `s` counts: those `r` reported within its
        last `miss_scans` scans (a track it never reported: last scan -2⁴⁰). The radar's
        table forgets the deleted tracks."""
        lv = self.live
        keys, scans = self.seen.get(r, (np.zeros(0, np.int64), np.zeros(0, np.int64)))
        scored = np.full(lv.key.size, (s + _NEVER) <= self.s.miss_scans)
        if not keys.size or not lv.key.size:
            return scored
        row = np.searchsorted(lv.key, keys)
        alive = row < lv.key.size
        alive[alive] = lv.key[row[alive]] == keys[alive]
        keys, scans, row = keys[alive], scans[alive], row[alive]
        self.seen[r] = (keys, scans)
        scored[row] = (s - scans) <= self.s.miss_scans
        return scored

    def _see(self, r, s, keys):
        """Radar `r` reported the tracks `keys` (increasing) at its scan `s`."""
        if not keys.size:
            return
        old_k, old_s = self.seen.get(r, (np.zeros(0, np.int64), np.zeros(0, np.int64)))
        other = ~np.isin(old_k, keys, assume_unique=True)
        k = np.concatenate([old_k[other], keys])
        o = np.argsort(k, kind="stable")
        self.seen[r] = (k[o], np.concatenate([old_s[other], np.full(keys.size, s)])[o])

    def _gnn(self, z, R, ti, rj, inc_pair, pair_lab, scored, inc, hit, used):
        lv = self.live
        take = np.zeros(ti.size, dtype=bool)
        first = lv.confirmed[ti]                         # confirmed tracks choose first
        _assign_clusters(np.flatnonzero(first), ti, rj, inc_pair, pair_lab, inc, take)
        taken = np.zeros(z.shape[0], dtype=bool)
        taken[rj[take]] = True
        _assign_clusters(np.flatnonzero(~first & ~taken[rj]), ti, rj, inc_pair, pair_lab, inc,
                         take)
        i, j = ti[take], rj[take]
        if self.imm:
            imm_gnn_update(lv, i, z[j], R[j])
        else:
            lv.x[i], lv.P[i], _, _ = update_kernel(lv.x[i], lv.P[i], z[j], R[j])
        if self.feat is not None:
            lv.f[i], lv.Pf[i] = _feature.update(lv.f[i], lv.Pf[i], self.feat[0][j],
                                                self.feat[1][j])
        inc[i] = inc_pair[take]
        hit[i] = True
        used[j] = 1.0

    def _jpda(self, z, R, ti, rj, inc_pair, pair_lab, scored, inc, hit, used):
        lv, st = self.live, self.s
        if not self.imm:
            xu, Pu, _, _ = update_kernel(lv.x[ti], lv.P[ti], z[rj], R[rj])
        w_miss = np.where(scored, 1.0 - st.p_detection * self.p_gate, 1.0)
        beta = np.zeros(ti.size)
        b0 = np.ones(lv.ids.size)
        order = np.argsort(pair_lab, kind="stable")
        cut = _cuts(pair_lab[order])
        for a, b in itertools.pairwise(cut):
            p = order[a:b]
            rows, cols = np.unique(ti[p], return_inverse=True)
            rep, rcol = np.unique(rj[p], return_inverse=True)
            shift = inc_pair[p].max()
            ratio = np.zeros((rows.size, rep.size))
            ratio[cols, rcol] = np.exp(inc_pair[p] - shift)
            w = w_miss[rows] * math.exp(-shift)
            if w.min() <= 0:                             # a report far likelier than a miss
                w = np.maximum(w, 1e-300)
            res = (exact_kernel(ratio, w) if event_bound(ratio) <= st.max_events
                   else kbest_kernel(ratio, w, st.k))
            beta[p] = res.probabilities[cols, rcol]
            b0[rows] = res.miss
        np.add.at(used, rj, beta)
        rows = np.unique(ti)
        if self.imm:
            imm_jpda_update(lv, ti, rj, z, R, beta, b0)
        else:
            lv.x[rows], lv.P[rows] = pda_moments(rows, ti, beta, b0, lv.x, lv.P, xu, Pu)
        if self.feat is not None:
            fu, pu = _feature.update(lv.f[ti], lv.Pf[ti], self.feat[0][rj], self.feat[1][rj])
            f, Pf = pda_moments(rows, ti, beta, b0, lv.f[:, None], lv.Pf[:, None, None],
                                fu[:, None], pu[:, None, None])
            lv.f[rows], lv.Pf[rows] = f[:, 0], Pf[:, 0, 0]
        hit[rows] = b0[rows] < 0.5
        gain = np.zeros(lv.ids.size)                     # expected increment given a hit
        np.add.at(gain, ti, beta * inc_pair)
        h = rows[hit[rows]]
        inc[h] = gain[h] / (1.0 - b0[h])

    # ------------------------------------------------------------------ score and life
    def _score(self, t, inc, hit, scored):
        lv, st = self.live, self.s
        counted = hit | scored
        lv.score += inc
        lv.recent = window_kernel(lv.recent, hit, counted)
        lv.scored += counted
        tent = ~lv.confirmed
        if st.confirmation == "sprt":
            promote = tent & (lv.score >= st.upper)
            drop = (tent & (lv.score <= st.lower)) | (
                lv.confirmed & (lv.peak - lv.score >= st.upper - st.lower))
        else:
            ones = np.count_nonzero(lv.recent, axis=1)
            window = np.minimum(lv.scored, st.n)
            promote = tent & (ones >= st.m)
            drop = (tent & (ones + (st.n - window) < st.m)) | (
                lv.confirmed & (window >= st.n) & (ones == 0))
        coast = t - lv.t_hit
        drop |= coast > st.max_coast
        if st.max_coast_tentative is not None:
            drop |= tent & (coast > st.max_coast_tentative)
        promote &= ~drop
        if st.relink and promote.any():
            dup = self._duplicates(promote)
            promote &= ~dup
            drop |= dup
        lv.confirmed |= promote
        lv.peak = np.where(lv.confirmed, np.maximum(lv.peak, lv.score), lv.score)
        rec = hit & ~drop
        self.rows.add(lv.ids[rec], t, lv.x[rec], lv.P[rec], lv.confirmed[rec], lv.mu[rec])
        self.rows.settle(lv.ids[promote], lv.ids[drop & ~lv.confirmed])
        if self.s.relink:
            merged = self._relink(t, promote, drop) if promote.any() else []
            lost = drop & lv.confirmed
            lost[merged] = False
            self._lose(t, lost)
        return None if not drop.any() else ~drop

    def _duplicates(self, promote):
        """Tracks about to be confirmed inside the relinking gate of a confirmed track that
        was still updated after they began: duplicates of its aircraft."""
        lv = self.live
        new = np.flatnonzero(promote)
        old = np.flatnonzero(lv.confirmed)
        dup = np.zeros(lv.ids.size, bool)
        if not old.size:
            return dup
        kappa = _kappa_pairs(lv.x[new, :3], lv.x[old, :3], lv.P[new, :3, :3], lv.P[old, :3, :3])
        alive = lv.t_hit[old][None, :] >= lv.born[new][:, None]
        dup[new] = ((kappa < self.gamma_relink) & alive).any(axis=1)
        return dup

    def _lose(self, t, lost):
        """Keep the confirmed tracks deleted now, and forget those lost over `max_coast` ago."""
        lv = self.live
        ids, x, P, tt, th = self.lost
        keep = (t - th) <= self.s.max_coast
        if keep.all() and not lost.any():
            return
        self.lost = (np.concatenate([ids[keep], lv.ids[lost]]),
                     np.concatenate([x[keep], lv.x[lost]]),
                     np.concatenate([P[keep], lv.P[lost]]),
                     np.concatenate([tt[keep], lv.t[lost]]),
                     np.concatenate([th[keep], lv.t_hit[lost]]))

    def _relink(self, t, promote, drop):
        """A newly confirmed track continues a confirmed one that lost its reports before it
        began, live or deleted within `max_coast`, if their positions pass the gate: it takes
        that track's identity. Returns the live tracks so merged."""
        lv = self.live
        new = np.flatnonzero(promote)
        old = np.flatnonzero(lv.confirmed & ~promote)
        ids, x, P, tt, th = self.lost
        fresh = (t - th) <= self.s.max_coast
        xl, Pl = predict(x[fresh], P[fresh], t - tt[fresh], self.s)
        cand_x = np.concatenate([lv.x[old, :3], xl[:, :3]])
        if not cand_x.shape[0]:
            return []
        cand_P = np.concatenate([lv.P[old, :3, :3], Pl[:, :3, :3]])
        cand_hit = np.concatenate([lv.t_hit[old], th[fresh]])
        cand_id = np.concatenate([lv.ids[old], ids[fresh]])
        kappa = _kappa_pairs(lv.x[new, :3], cand_x, lv.P[new, :3, :3], cand_P)
        before = cand_hit[None, :] < lv.born[new][:, None]
        link = assignment.assign_two_lists(np.where(before, kappa, np.inf),
                                   threshold=self.gamma_relink).row_to_col
        merged, gone = [], []
        for i, j in zip(new, link, strict=True):
            if j >= 0:
                self.alias[int(lv.ids[i])] = int(cand_id[j])
                lv.ids[i] = cand_id[j]
                if j < old.size:
                    drop[old[j]] = True
                    merged.append(old[j])
                else:
                    gone.append(np.flatnonzero(fresh)[j - old.size])
        if gone:
            keep = np.ones(ids.size, bool)
            keep[gone] = False
            self.lost = tuple(a[keep] for a in self.lost)
        return merged

    def _start(self, t, r, s, z, R, kept=None):
        """Start a tentative track at each report, once the tracks not `kept` (a mask,
        None: all) are removed; returns their keys."""
        n = z.shape[0]
        if not n:
            if kept is not None:
                self.live.keep(kept)
            return np.zeros(0, np.int64)
        x = np.zeros((n, 6))
        x[:, :3] = z
        P = np.zeros((n, 6, 6))
        P[:, :3, :3] = R
        P[:, 3:, 3:] = np.diag(velocity_sd(self.s) ** 2)
        ids = self.next_id + np.arange(n, dtype=np.int64)
        recent = np.zeros((n, self.s.n), dtype=bool)
        recent[:, -1] = True                                  # the report that started it
        self.next_id += n
        M = self.live.mu.shape[1]
        mu = np.tile(np.asarray(self.s.imm_probability[:M]), (n, 1))
        f, fv = self.feat if self.feat is not None else (np.zeros(n), np.ones(n))
        self.live.extend(kept, x=x, P=P, f=f, Pf=fv, t=np.full(n, t), t_hit=np.full(n, t),
                         score=np.zeros(n), peak=np.zeros(n), confirmed=np.zeros(n, bool), ids=ids,
                         recent=recent, scored=np.ones(n, np.int64), key=ids.copy(),
                         born=np.full(n, t), mu=mu,
                         xm=np.repeat(x[:, None], M, 1), Pm=np.repeat(P[:, None], M, 1))
        self.rows.add(ids, t, x, P, np.zeros(n, bool), mu)
        return ids


def pda_moments(rows, ti, beta, b0, x, P, xu, Pu):
    """JPDA: per track of `rows`, the mean and covariance of the mixture over its events:
    the prediction (`x`, `P` of every track) with probability `b0`, and pair p's update
    (`xu[p]`, `Pu[p]`) with `beta[p]`, pairs `ti` in order of track."""
    x0, P0 = x[rows], P[rows]
    mean = b0[rows, None] * x0
    loc = np.searchsorted(rows, ti)
    np.add.at(mean, loc, beta[:, None] * xu)
    dx0 = x0 - mean
    cov = b0[rows, None, None] * (P0 + dx0[:, :, None] * dx0[:, None, :])
    dxu = xu - mean[loc]
    np.add.at(cov, loc, beta[:, None, None] * (Pu + dxu[:, :, None] * dxu[:, None, :]))
    return mean, 0.5 * (cov + np.swapaxes(cov, 1, 2))


def _clusters(ti, rj, M):
    """Cluster label of each gated pair: the connected components of the graph linking
    each track (`ti`, nondecreasing) to its reports (`rj`, of `M`).

    A cluster's label is its first track's index: labels increase with the cluster's
    first track, as the components of the graph of every track and report are numbered.
    Each track's label falls to the smallest label among the tracks of its reports,
    then to its label's label, until nothing changes (a few passes: one per link of the
    longest chain of overlapping gates, halved by the second step).
    """
    lab = ti.copy()                                    # each pair: its track's label
    first = np.flatnonzero(_starts(ti))
    node = np.full(int(ti[-1]) + 1, np.iinfo(np.int64).max)
    while True:
        rep = np.full(M, np.iinfo(np.int64).max)
        np.minimum.at(rep, rj, lab)                    # each report: its tracks' smallest
        low = np.minimum.reduceat(rep[rj], first)      # each track: its reports' smallest
        node[ti[first]] = low
        new = node[node[ti]]                           # and its label's label
        if np.array_equal(new, lab):
            return lab
        lab = new


#: Pairs per block of :func:`_kappa_pairs` (its work arrays stay in cache).
_PAIR_BLOCK = 65536


def _kappa_pairs(x1, x2, P1, P2):
    """κ of every pair of two sets of positions, shape (n1, n2) (trusted input: validated
    reports or the tracker's own estimates), in blocks of rows of at most `_PAIR_BLOCK`
    pairs; the result is refused beyond ``MEMORY_LIMIT`` bytes before it is allocated."""
    n1, n2 = x1.shape[0], x2.shape[0]
    check_size(8 * n1 * n2, MEMORY_LIMIT, name="position",
               what=f"bytes for {n1} x {n2} pairs of tracks",
               alternative="fewer tracks at once (shorter `settings.max_coast`, or the "
                           "reports in consecutive slices)")
    out = np.empty((n1, n2))
    step = max(1, _PAIR_BLOCK // max(n2, 1))
    for a in range(0, n1, step):
        out[a:a + step] = mahalanobis_sq_kernel(x1[a:a + step, None] - x2[None],
                                                P1[a:a + step, None] + P2[None],
                                                "`position`, `cov`")
    return out


def _near_box(x, radius, z):
    """Indices (increasing) of the points `x` (T, 3) within their own `radius` of the
    bounding box of `z` (M, 3): the only ones that can have a point of `z` within `radius`.

    The box is grown by a relative margin of 1e-9 (and 1e-300 absolute) so that rounding
    never excludes a point whose distance, as the tree computes it, is within its radius.
    """
    r = radius * (1.0 + 1e-9) + 1e-300
    lo, hi = z.min(0), z.max(0)
    inside = ((x[:, 0] >= lo[0] - r) & (x[:, 0] <= hi[0] + r)
              & (x[:, 1] >= lo[1] - r) & (x[:, 1] <= hi[1] + r)
              & (x[:, 2] >= lo[2] - r) & (x[:, 2] <= hi[2] + r))
    return np.flatnonzero(inside)


def _assign_clusters(pairs, ti, rj, inc_pair, pair_lab, inc, take):
    """GNN in each gated cluster among `pairs`: the assignment of largest summed increment."""
    if not pairs.size:
        return
    order = pairs[np.argsort(pair_lab[pairs], kind="stable")]
    cut = _cuts(pair_lab[order])
    first, t_o, r_o = cut[:-1], ti[order], rj[order]
    # a cluster of one track or of one report: its pair of largest gain over the track's
    # miss, if positive (the assignment of such a cluster), for every such cluster at once
    simple = ((np.minimum.reduceat(t_o, first) == np.maximum.reduceat(t_o, first))
              | (np.minimum.reduceat(r_o, first) == np.maximum.reduceat(r_o, first)))
    gain = inc_pair[order] - inc[t_o]
    cluster = np.repeat(np.arange(first.size), np.diff(cut))
    best = np.lexsort((-gain, cluster))[first]           # largest gain first per cluster
    pick = simple & (gain[best] > 0.0)
    take[order[best[pick]]] = True
    # the other clusters: one exact assignment each, of the tracks to their gated reports
    # or to their own miss column (always allowed, so every track is assigned and the
    # solver's optimum is the GNN hypothesis; the inputs are trusted: finite increments)
    rest = np.repeat(~simple, np.diff(cut))
    if not rest.any():
        return
    p_all, c_all = order[rest], cluster[rest]
    col_all = _rank_within(c_all, ti[p_all])        # the track's row in its cluster's matrix
    rep_all = _rank_within(c_all, rj[p_all])        # the report's column
    edges = _cuts(c_all)
    for a, b in zip(edges[:-1].tolist(), edges[1:].tolist(), strict=True):
        p, cols, rcol = p_all[a:b], col_all[a:b], rep_all[a:b]
        nt, nm = int(cols.max()) + 1, int(rcol.max()) + 1
        tracks = np.empty(nt, np.int64)
        tracks[cols] = ti[p]
        cost = np.full((nt, nm + nt), np.inf)
        cost[cols, rcol] = -inc_pair[p]
        cost[np.arange(nt), nm + np.arange(nt)] = -inc[tracks]
        r_i, c_i = linear_sum_assignment(cost)
        choice = np.empty(nt, dtype=np.intp)
        choice[r_i] = c_i
        take[p[choice[cols] == rcol]] = True


def _rank_within(group, key):
    """Dense rank (0, 1, ...) of each `key` among the distinct keys of its `group` (`group`
    non-decreasing): the index ``np.unique`` of the group's keys would give it."""
    o = np.lexsort((key, group))
    g, k = group[o], key[o]
    first = _starts(g)
    step = np.cumsum(first | _starts(k))
    rank = np.empty(o.size, np.int64)
    rank[o] = step - step[np.flatnonzero(first)][np.cumsum(first) - 1]
    return rank


def _starts(a):
    """Mask of the entries of `a` (1-D) that differ from their predecessor (the first: True)."""
    m = np.empty(a.size, dtype=bool)
    m[:1] = True
    np.not_equal(a[1:], a[:-1], out=m[1:])
    return m


def _cuts(a):
    """Bounds of the runs of equal entries of `a` (1-D): run k is ``a[c[k]:c[k + 1]]``."""
    return np.append(np.flatnonzero(_starts(a)), a.size)
