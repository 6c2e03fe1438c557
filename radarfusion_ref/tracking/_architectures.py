r"""Architectures (b) and (c): fuse the scans then track, or track per radar then fuse tracks."""

from __future__ import annotations

import itertools
import time as _time

import numpy as np

from .. import gating, trackfusion
from ..engine import assignment
from ..engine._validation import as_choice, as_float, as_positive
from ..engine.linalg import mahalanobis_sq_pairwise
from ..engine.tracker import kalman_predict
from ..fusion import fuse_gaussian
from ._centralised import _reports_iv, track_reports
from ._settings import TrackerSettings, TrackHistory

#: Track-to-track fusion rules of :func:`track_then_fuse`.
T2T_RULES = ("ci", "naive")


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
    kappa = np.atleast_2d(mahalanobis_sq_pairwise(x1, x2, P1, P2))
    if kept is not None:
        kappa = np.where(kept & (kappa < gamma), kappa - gamma, kappa)
    return assignment.solve_2d(kappa, threshold=gamma).row_to_col


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
def fuse_then_track(time, position, covariance, radar, scan, *, window, settings=None):
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
    :math:`(v_{\max}\Delta t)^2 I`, :math:`\Delta t` the time between the report and
    the window's last instant (without a track there is no velocity to align the
    reports with, chapter 10); each object is the maximum-likelihood fusion
    (:func:`radarfusion_ref.fusion.fuse_gaussian`) of its inflated reports at the
    window's last report instant. The objects feed one tracker as scans of one source.
    """
    t0 = _time.perf_counter()
    settings = TrackerSettings() if settings is None else settings
    t, z, R, rad, _ = _reports_iv(time, position, covariance, radar, scan, settings)
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
        Ri = Rw + ((settings.speed_max * (t_end - tw)) ** 2)[:, None, None] * eye
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
    h = track_reports(ft, np.concatenate(out_z), np.concatenate(out_R),
                      np.zeros(ft.size, np.int64), fk, settings=settings)
    return TrackHistory(h.track, h.time, h.state, h.covariance, h.confirmed,
                        _time.perf_counter() - t0, h.initiated)


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
def track_then_fuse(time, position, covariance, radar, scan, *, period, settings=None,
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
    rule : {"ci", "naive"}, optional
        :func:`radarfusion_ref.trackfusion.covariance_intersection` (default: consistent
        whatever the tracks' cross-covariance) or
        :func:`radarfusion_ref.trackfusion.naive_fusion` (independence assumed).

    Returns
    -------
    TrackHistory
        The fused tracks at the output instants (all rows confirmed).

    Raises
    ------
    ValueError, TypeError
        As :func:`~radarfusion_ref.tracking.track_reports`, a `period` not > 0, or an
        unknown `rule`.

    Notes
    -----
    Each radar's reports go to their own :func:`~radarfusion_ref.tracking.track_reports`.
    At each output instant the last state of every confirmed local track updated within
    `settings.max_coast` is predicted to the instant
    (:func:`radarfusion_ref.trackfusion.predict`, chapter 10's time alignment); the
    radars' tracks join radar after radar by the gated 2-D assignment of their
    positions (:math:`\kappa` with :math:`P_1 + P_2`) and are fused pairwise by `rule`;
    the association has memory: local tracks fused together at the previous instant stay
    together while they pass the gate (two aircraft passing close must not trade their
    radars' tracks). A fused track keeps the identity most of its local tracks carried
    at the previous instant (ties: the oldest), each identity going to one track, so a
    single local track joining another group cannot carry that group's identity away.
    Bar-Shalom–Campo would need the cross-covariance of two asynchronous
    filters, which the local trackers do not carry.
    """
    t0 = _time.perf_counter()
    settings = TrackerSettings() if settings is None else settings
    t, z, R, rad, sc = _reports_iv(time, position, covariance, radar, scan, settings)
    dt_out = as_float(as_positive(period, "period"), "period")
    rule = as_choice(rule, "rule", T2T_RULES)
    empty = TrackHistory(np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 6)),
                         np.zeros((0, 6, 6)), np.zeros(0, bool))
    if not t.size:
        return empty
    local = {}
    for r in np.unique(rad):
        s = rad == r
        h = track_reports(t[s], z[s], R[s], rad[s], sc[s], settings=settings)
        c = h.confirmed
        local[int(r)] = (h.track[c], h.time[c], h.state[c], h.covariance[c])
    gamma = _gamma(settings)
    fuse = trackfusion.covariance_intersection if rule == "ci" else trackfusion.naive_fusion
    ident: dict[tuple[int, int], int] = {}
    next_id = 0
    rows = []
    for tg in np.arange(t.min() + dt_out, t.max() + dt_out / 2, dt_out):
        groups = None                   # (state, cov, [(radar, local id)])
        for r, (ids, tt, xs, Ps) in local.items():
            sel = (tt <= tg) & (tt > tg - settings.max_coast)
            if not sel.any():
                continue
            rev = np.flatnonzero(sel)[::-1]              # rows in time order: latest first
            rr = rev[np.unique(ids[rev], return_index=True)[1]]
            p = kalman_predict(xs[rr], Ps[rr], tg - tt[rr], settings.q)
            x, P, keys = p.state, p.covariance, [(r, int(i)) for i in ids[rr]]
            if groups is None:
                groups = (x, P, [[k] for k in keys])
                continue
            gx, gP, gk = groups
            before = [{ident[k] for k in keys if k in ident} for keys in gk]
            kept = np.array([[ident.get(k, -1) in b for b in before] for k in keys], bool)
            link = _link(x[:, :3], P[:, :3, :3], gx[:, :3], gP[:, :3, :3], gamma,
                         kept.reshape(len(keys), len(gk)))
            lk = link >= 0
            if lk.any():
                f = fuse(gx[link[lk]], gP[link[lk]], x[lk], P[lk])
                gx, gP = gx.copy(), gP.copy()
                gx[link[lk]], gP[link[lk]] = f.estimate, f.covariance
                for i in np.flatnonzero(lk):
                    gk[link[i]].append(keys[i])
            new = ~lk
            groups = (np.concatenate([gx, x[new]]), np.concatenate([gP, P[new]]),
                      gk + [[keys[i]] for i in np.flatnonzero(new)])
        if groups is None:
            continue
        gx, gP, gk = groups
        gid, next_id = _identities(gk, ident, next_id)
        for g, keys in zip(gid.tolist(), gk, strict=True):
            for k in keys:
                ident[k] = g
        rows.append((gid, np.full(gid.size, tg), gx, gP))
    if not rows:
        return empty
    ids, tt, xs, Ps = (np.concatenate(c) for c in zip(*rows, strict=True))
    o = np.lexsort((ids, tt))
    return TrackHistory(ids[o], tt[o], xs[o], Ps[o], np.ones(ids.size, bool),
                        _time.perf_counter() - t0, next_id)
