r"""Architectures (b) and (c): fuse the scans then track, or track per radar then fuse tracks."""

from __future__ import annotations

import itertools

import numpy as np

from .. import gating, trackfusion
from ..engine import assignment
from ..engine.tracker import cv_matrices, predict_kernel
from ..engine.validation import as_choice, as_float, as_positive
from ..fusion import fuse_gaussian
from ._centralised import _kappa_pairs, _reports_iv, track_reports
from ._motion import axis_q, predict, velocity_sd
from ._settings import TrackerSettings, TrackHistory

#: Track-to-track fusion rules of :func:`track_then_fuse`.
T2T_RULES = ("ci", "naive", "bar_shalom_campo")


def _gamma(settings):
    return float(gating.gate_threshold(settings.p_false_reject, 3))


def _link(x1, P1, x2, P2, gamma, kept=None):
    r"""Gated joint assignment of two lists of positions (row -> column, -1 unlinked).

    `kept` (n1, n2) bool marks the pairs linked at the previous instant: inside the gate
    they cost :math:`\kappa - \gamma < 0`, so a remembered pair that still passes the gate
    is kept against any new one (association with memory).
    """
    if not len(x1) or not len(x2):
        return np.full(len(x1), -1)
    kappa = _kappa_pairs(x1, x2, P1, P2)              # trusted: validated or our own
    if kept is not None:
        kappa = np.where(kept & (kappa < gamma), kappa - gamma, kappa)
    return assignment.assign_two_lists(kappa, threshold=gamma).row_to_col


def _identities(groups, ident, next_id):
    """Fused identity of each group of local tracks: the one most of its tracks carried.

    Groups and previous identities are matched greedily by (votes, age); a group with
    no vote left gets a new identity. Returns (ids (G,), next_id).
    """
    votes: dict[tuple[int, int], int] = {}
    for n, keys in enumerate(groups):
        for k in keys:
            if k in ident:
                votes[n, ident[k]] = votes.get((n, ident[k]), 0) + 1
    gid = np.full(len(groups), -1, np.int64)
    used = set()
    for (n, g), _ in sorted(votes.items(), key=lambda kv: (-kv[1], kv[0][1], kv[0][0])):
        if gid[n] < 0 and g not in used:
            gid[n] = g
            used.add(g)
    for n in np.flatnonzero(gid < 0):
        gid[n], next_id = next_id, next_id + 1
    return gid, next_id


# --------------------------------------------------------------------------- (b)
def fuse_then_track(time, position, cov, radar, scan, *, window, settings=None):
    r"""Architecture (b): group and fuse the radars' scans per time window, then track.

    Parameters
    ----------
    time, position, covariance, radar, scan : array_like
        The reports, as :func:`~radarfusion_ref.tracking.track_reports` takes them.
    window : float
        Width of the fusion windows (s, > 0): reports in ``[k w, (k + 1) w)`` are grouped.
    settings : TrackerSettings, optional
        The tracker's settings (its gate also gates the grouping).

    Returns
    -------
    TrackHistory
        Tracks of the fused objects (one update per window).

    Raises
    ------
    ValueError, TypeError
        As :func:`~radarfusion_ref.tracking.track_reports`, or a `window` not > 0.

    Notes
    -----
    In each window the radars' reports join objects radar after radar by the gated 2-D
    assignment (chapter 4) on :math:`\kappa` with covariances **inflated** by
    :math:`\operatorname{diag}(v_{\max}, v_{\max}, v_{z,\max})^2\Delta t^2` (`speed_max`,
    `speed_max_vertical`), :math:`\Delta t` the time between the report and
    the window's last instant (without a track there is no velocity to align the
    reports with, chapter 10); each object is the maximum-likelihood fusion
    (:func:`radarfusion_ref.fusion.fuse_gaussian`) of its inflated reports at the
    window's last report instant. The objects feed one tracker as scans of one source.
    """
    settings = TrackerSettings() if settings is None else settings
    t, z, R, rad, _ = _reports_iv(time, position, cov, radar, scan, settings)
    w = as_float(as_positive(window, "window"), "window")
    if not t.size:
        return track_reports(t, z, R, rad, rad, settings=settings)
    gamma = _gamma(settings)
    k = np.floor((t - t.min()) / w).astype(np.int64)
    order = np.lexsort((rad, t, k))
    t, z, R, rad, k = t[order], z[order], R[order], rad[order], k[order]
    cut = np.flatnonzero(np.r_[True, np.diff(k) != 0, True])
    out_t, out_z, out_R, out_k = [], [], [], []
    eye = np.eye(3)
    for a, b in itertools.pairwise(cut):
        tw, zw, Rw, rw = t[a:b], z[a:b], R[a:b], rad[a:b]
        t_end = tw.max()
        Ri = Rw + ((velocity_sd(settings) / settings.length_unit
                    * (t_end - tw)[:, None]) ** 2)[:, None, :] * eye
        members: list[list[int]] = []
        for r in np.unique(rw):
            idx = np.flatnonzero(rw == r)
            if members:
                fz, fR = _fused(zw, Ri, members)
                link = _link(zw[idx], Ri[idx], fz, fR, gamma)
                taken = set()
                for j, g in zip(idx, link, strict=True):
                    if g >= 0 and g not in taken:
                        members[g].append(int(j))
                        taken.add(int(g))
                    else:
                        members.append([int(j)])
            else:
                members = [[int(j)] for j in idx]
        fz, fR = _fused(zw, Ri, members)
        out_t.append(np.full(len(members), t_end))
        out_z.append(fz)
        out_R.append(fR)
        out_k.append(np.full(len(members), k[a]))
    ft, fk = np.concatenate(out_t), np.concatenate(out_k)
    return track_reports(ft, np.concatenate(out_z), np.concatenate(out_R),
                         np.zeros(ft.size, np.int64), fk, settings=settings)


def _fused(z, R, members):
    """ML fusion of each object's reports (objects of one report keep it)."""
    fz = np.empty((len(members), 3))
    fR = np.empty((len(members), 3, 3))
    sizes = np.array([len(m) for m in members])
    for n in np.unique(sizes):
        sel = np.flatnonzero(sizes == n)
        idx = np.array([members[i] for i in sel])
        if n == 1:
            fz[sel], fR[sel] = z[idx[:, 0]], R[idx[:, 0]]
        else:
            f = fuse_gaussian(z[idx], R[idx])
            fz[sel], fR[sel] = f.estimate, f.covariance
    return fz, fR


# --------------------------------------------------------------------------- (c)
#: Relative tolerance of the restart test of a local track's row (see :func:`track_then_fuse`).
RESTART_RTOL = 1e-8


def _swap(a):
    return np.swapaxes(a, -1, -2)


class _Local:
    """The radars' local tracks: every row (tentative ones too), sorted by (radar, track, time).

    With `gains`, each row also carries what the cross-covariance recursion needs: ``A``,
    the update's :math:`I - K_kH = P_k P_{k|k-1}^{-1}`, and ``last_restart``, the latest
    row at or before it that starts its track's filter afresh.
    """

    def __init__(self, histories, q, gains):
        parts = [(np.full(len(h), r), h.track, h.time, h.state, h.covariance, h.confirmed)
                 for r, h in histories.items()]
        cols = [np.concatenate(c) for c in zip(*parts, strict=True)]
        o = np.lexsort((cols[2], cols[1], cols[0]))
        self.radar, self.track, self.t, self.x, self.P, self.confirmed = (c[o] for c in cols)
        first = np.r_[True, (np.diff(self.radar) != 0) | (np.diff(self.track) != 0)]
        self.segment = np.cumsum(first) - 1                # one number per (radar, track)
        self.rows = {r: np.searchsorted(self.radar, [r, r + 1]) for r in histories}
        self.px, self.pP = np.empty_like(self.x), np.empty_like(self.P)   # predicted at t_g
        if gains and self.t.size:
            self._gains(first, q)

    def _gains(self, first, q):
        k = np.flatnonzero(~first)                         # rows with a row before them
        _, Pp = predict_kernel(self.x[k - 1], self.P[k - 1], self.t[k] - self.t[k - 1], q,
                               per_axis=True)
        Pk = self.P[k]
        self.A = np.broadcast_to(np.eye(6), self.P.shape).copy()
        self.A[k] = _swap(np.linalg.solve(Pp, Pk))         # P_k Pp⁻¹ = I - K H
        restart = first.copy()                             # P_k not <= Pp: a fresh start
        restart[k] = (np.linalg.eigvalsh(Pp - Pk)[:, 0]
                      < -RESTART_RTOL * np.linalg.eigvalsh(Pp)[:, -1])
        self.last_restart = np.maximum.accumulate(
            np.where(restart, np.arange(restart.size), 0))
        self.t0, self.span = self.t.min(), np.ptp(self.t) + 1.0
        self.key = self.segment * self.span + (self.t - self.t0)     # increasing

    def latest(self, r, tg, max_coast):
        """Radar r's latest confirmed row of each track updated in (tg - max_coast, tg]."""
        lo, hi = self.rows[r]
        t = self.t[lo:hi]
        idx = lo + np.flatnonzero(self.confirmed[lo:hi] & (t <= tg) & (t > tg - max_coast))
        seg = self.segment[idx]
        return idx[np.r_[seg[1:] != seg[:-1], True]] if idx.size else idx


class _Cross:
    r"""Cross-covariances :math:`P_{ab}` of pairs of local tracks (a's radar before b's).

    Each pair keeps its running :math:`P_{ab}` at the last update it took in, and the next
    row of each track; :meth:`at` advances it through the two tracks' updates in time order
    up to the rows in use, so every update enters once over the whole run.
    """

    def __init__(self, loc, q):
        self.loc, self.q = loc, q
        self.slots: dict[tuple[int, int], int] = {}
        self.P12 = np.zeros((0, 6, 6))
        self.t = np.zeros(0)
        self.next = np.zeros((0, 2), np.int64)
        self.start = np.zeros((0, 2), np.int64)

    def _predict(self, P12, dt):
        F, Q = cv_matrices(dt, self.q, 3, per_axis=True)
        return F @ P12 @ _swap(F) + Q                      # common process noise

    def at(self, rows_a, rows_b, tg):
        """:math:`P_{ab}` at `tg` of the tracks whose rows in use are `rows_a`, `rows_b`."""
        loc = self.loc
        n0 = len(self.slots)
        pairs = zip(loc.segment[rows_a].tolist(), loc.segment[rows_b].tolist(), strict=True)
        s = np.fromiter((self.slots.setdefault(p, len(self.slots)) for p in pairs), np.int64,
                        len(rows_a))
        grow = len(self.slots) - n0
        if grow:
            self.P12 = np.concatenate([self.P12, np.zeros((grow, 6, 6))])
            self.t = np.concatenate([self.t, np.zeros(grow)])
            self.next = np.concatenate([self.next, np.zeros((grow, 2), np.int64)])
            self.start = np.concatenate([self.start, np.full((grow, 2), -1)])
        lim = np.stack([rows_a, rows_b], -1)               # the rows in use, (m, 2)
        begin = loc.last_restart[lim]
        nxt, tc, P12 = self.next[s], self.t[s], self.P12[s]
        ahead = (nxt <= lim) & (loc.t[np.minimum(nxt, lim)] < tc[:, None])
        stale = (self.start[s] != begin).any(-1) | ahead.any(-1)
        if stale.any():                                    # (re)start at the later start
            i = np.flatnonzero(stale)
            t0 = loc.t[begin[i]].max(-1)
            nxt[i] = np.searchsorted(loc.key, loc.segment[lim[i]] * loc.span
                                     + (t0 - loc.t0)[:, None], side="right")
            tc[i], P12[i] = t0, 0.0
        act = np.flatnonzero((nxt <= lim).any(-1))
        while act.size:                                    # the next update of each pair
            n, lm = nxt[act], lim[act]
            te2 = np.where(n <= lm, loc.t[np.minimum(n, lm)], np.inf)
            te = te2.min(-1)
            M = self._predict(P12[act], te - tc[act])
            ua, ub = te2[:, 0] == te, te2[:, 1] == te
            M[ua] = loc.A[n[ua, 0]] @ M[ua]                # (I - K_a H) P_ab
            M[ub] = M[ub] @ _swap(loc.A[n[ub, 1]])         # P_ab (I - K_b H)ᵀ
            P12[act], tc[act] = M, te
            nxt[act] = n + np.stack([ua, ub], -1)
            act = act[(nxt[act] <= lim[act]).any(-1)]
        self.next[s], self.t[s], self.P12[s], self.start[s] = nxt, tc, P12, begin
        return self._predict(P12, tg - tc)


def _blue(loc, cross, members, tg):
    """BLUE of each group's members (rows in radar order) with their cross-covariances."""
    sizes = np.array([len(m) for m in members])
    x, P = np.empty((sizes.size, 6)), np.empty((sizes.size, 6, 6))
    for n in np.unique(sizes):
        sel = np.flatnonzero(sizes == n)
        rows = np.array([members[i] for i in sel])         # (G, n)
        C = np.zeros((sel.size, n, 6, n, 6))
        for i in range(n):
            C[:, i, :, i] = loc.pP[rows[:, i]]
            for j in range(i + 1, n):
                C[:, i, :, j] = cross.at(rows[:, i], rows[:, j], tg)
                C[:, j, :, i] = _swap(C[:, i, :, j])
        f = trackfusion.blue_fusion(loc.px[rows], C.reshape(sel.size, 6 * n, 6 * n))
        x[sel], P[sel] = f.estimate, f.covariance
    return x, P


def _fuse_at(loc, cross, tg, settings, rule, ident):
    """The fused groups at the output instant `tg`: states, covariances, the (radar, local
    id) of their tracks and the tracks' rows in use; None without a track."""
    gamma = _gamma(settings)
    groups = None
    for r in loc.rows:
        rr = loc.latest(r, tg, settings.max_coast)
        if not rr.size:
            continue
        x, P = predict(loc.x[rr], loc.P[rr], tg - loc.t[rr], settings,
                       unit=settings.length_unit)
        loc.px[rr], loc.pP[rr] = x, P
        keys = [(r, int(i)) for i in loc.track[rr]]
        if groups is None:
            groups = (x, P, [[k] for k in keys], [[int(j)] for j in rr])
            continue
        gx, gP, gk, gr = groups
        before = [{ident[k] for k in keys if k in ident} for keys in gk]
        kept = np.array([[ident.get(k, -1) in b for b in before] for k in keys], bool)
        link = _link(x[:, :3], P[:, :3, :3], gx[:, :3], gP[:, :3, :3], gamma,
                     kept.reshape(len(keys), len(gk)))
        lk = link >= 0
        if lk.any():
            g = link[lk]
            for i in np.flatnonzero(lk):
                gk[link[i]].append(keys[i])
                gr[link[i]].append(int(rr[i]))
            gx, gP = gx.copy(), gP.copy()
            if rule == "bar_shalom_campo":
                gx[g], gP[g] = _blue(loc, cross, [gr[j] for j in g], tg)
            else:
                fuse = (trackfusion.covariance_intersection if rule == "ci"
                        else trackfusion.naive_fusion)
                f = fuse(gx[g], gP[g], x[lk], P[lk])
                gx[g], gP[g] = f.estimate, f.covariance
        new = np.flatnonzero(~lk)
        groups = (np.concatenate([gx, x[new]]), np.concatenate([gP, P[new]]),
                  gk + [[keys[i]] for i in new], gr + [[int(rr[i])] for i in new])
    return groups


def track_then_fuse(time, position, cov, radar, scan, *, period, settings=None,
                    rule="ci"):
    r"""Architecture (c): a local tracker per radar, then track-to-track fusion.

    Parameters
    ----------
    time, position, covariance, radar, scan : array_like
        The reports, as :func:`~radarfusion_ref.tracking.track_reports` takes them.
    period : float
        The fusion centre's output period (s, > 0): every `period` the radars' confirmed
        local tracks are predicted to the instant, associated and fused.
    settings : TrackerSettings, optional
        Settings of every local tracker (and the association gate).
    rule : {"ci", "naive", "bar_shalom_campo"}, optional
        :func:`radarfusion_ref.trackfusion.covariance_intersection` (default: consistent
        whatever the tracks' cross-covariance),
        :func:`radarfusion_ref.trackfusion.naive_fusion` (independence assumed), or the
        best linear unbiased fusion with the tracks' cross-covariances
        (:func:`radarfusion_ref.trackfusion.blue_fusion`; for two tracks
        :func:`radarfusion_ref.trackfusion.bar_shalom_campo`), which needs local Kalman
        updates with one report each (``settings.association="gnn"``).

    Returns
    -------
    TrackHistory
        The fused tracks at the output instants (all rows confirmed).

    Raises
    ------
    ValueError, TypeError
        As :func:`~radarfusion_ref.tracking.track_reports`, a `period` not > 0, an
        unknown `rule`, or ``"bar_shalom_campo"`` with JPDA local trackers.

    Notes
    -----
    Each radar's reports go to their own :func:`~radarfusion_ref.tracking.track_reports`.
    At each output instant :math:`t_g` the last state of every confirmed local track
    updated within `settings.max_coast` is predicted to the instant
    (:func:`radarfusion_ref.engine.tracker.kalman_predict`, chapter 10's time alignment);
    the radars' tracks join radar after radar by the gated 2-D assignment of their
    positions (:math:`\kappa` with :math:`P_1 + P_2`, whatever the rule) and are fused
    by `rule` (``"ci"``, ``"naive"``: pairwise, as each radar joins); the association has
    memory: local tracks fused together at the previous instant stay together while they
    pass the gate (two aircraft passing close must not trade their radars' tracks). A
    fused track keeps the identity most of its local tracks carried at the previous
    instant (ties: the oldest), each identity going to one track, so a single local
    track joining another group cannot carry that group's identity away.

    ``"bar_shalom_campo"`` fuses the group's tracks (one per radar) by the BLUE of the
    stacked estimates with their joint covariance. The cross-covariance :math:`P_{ab}` of
    two asynchronous local tracks comes from their own histories (Bar-Shalom's recursion,
    1981, on the merged update instants): a row :math:`k` of track *a* holds :math:`P_k`
    and, predicted from the row before, :math:`P_{k|k-1} = FP_{k-1}F^\mathsf T + Q` (the
    continuous white-noise acceleration composes exactly, so missed scans need no rows),
    hence :math:`I - K_kH = P_kP_{k|k-1}^{-1}`. Between updates
    :math:`P_{ab} \leftarrow FP_{ab}F^\mathsf T + Q(\Delta t)` (both errors carry the
    aircraft's process noise), at an update of *a*
    :math:`P_{ab} \leftarrow (I - K_kH)P_{ab}`, at one of *b*
    :math:`P_{ab} \leftarrow P_{ab}(I - K_kH)^\mathsf T`, and at :math:`t_g` a last
    prediction. :math:`P_{ab} = 0` when the later of the two tracks starts (its initial
    error is its first report's and a velocity prior, taken independent of the other
    track's error: an approximation) and again when a row starts its filter afresh (a
    relinked identity continues with a freshly initiated covariance): a row whose
    :math:`P_k` is not below :math:`P_{k|k-1}` in the Loewner order, smallest eigenvalue
    of :math:`P_{k|k-1} - P_k` below ``-RESTART_RTOL`` (1e-8) times the largest of
    :math:`P_{k|k-1}`. Each pair keeps its running :math:`P_{ab}` between output
    instants. Exact for linear Kalman updates with one report (GNN); the mixture
    update of JPDA is not of this form and is refused.
    """
    settings = TrackerSettings() if settings is None else settings
    t, z, R, rad, sc = _reports_iv(time, position, cov, radar, scan, settings)
    dt_out = as_float(as_positive(period, "period"), "period")
    rule = as_choice(rule, "rule", T2T_RULES)
    bsc = rule == "bar_shalom_campo"
    if bsc and settings.motion != "cv":
        raise ValueError("`rule` 'bar_shalom_campo' needs local Kalman updates of one linear "
                         "model (settings.motion='cv'); received `settings` with "
                         f"motion={settings.motion!r}; use rule='ci'")
    if bsc and settings.association != "gnn":
        raise ValueError("`rule` 'bar_shalom_campo' needs local Kalman updates with one report "
                         "each (settings.association='gnn'); received `settings` with "
                         f"association={settings.association!r}; use rule='ci'")
    empty = TrackHistory(np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 6)),
                         np.zeros((0, 6, 6)), np.zeros(0, bool))
    if not t.size:
        return empty
    hist = {}
    for r in np.unique(rad):
        s = rad == r
        hist[int(r)] = track_reports(t[s], z[s], R[s], rad[s], sc[s], settings=settings)
    q = axis_q(settings) / settings.length_unit**2         # in the reports' unit
    loc = _Local(hist, q, gains=bsc)
    cross = _Cross(loc, q) if bsc else None
    ident: dict[tuple[int, int], int] = {}
    next_id = 0
    out = []
    for tg in np.arange(t.min() + dt_out, t.max() + dt_out / 2, dt_out):
        groups = _fuse_at(loc, cross, tg, settings, rule, ident)
        if groups is None:
            continue
        gx, gP, gk, _ = groups
        gid, next_id = _identities(gk, ident, next_id)
        for g, keys in zip(gid.tolist(), gk, strict=True):
            for k in keys:
                ident[k] = g
        out.append((gid, np.full(gid.size, tg), gx, gP))
    if not out:
        return empty
    ids, tt, xs, Ps = (np.concatenate(c) for c in zip(*out, strict=True))
    o = np.lexsort((ids, tt))
    return TrackHistory(ids[o], tt[o], xs[o], Ps[o], np.ones(ids.size, bool), next_id)
