r"""Step 7 of the capstone: a track per aircraft, one local track per radar, fused track to track.

The fused objects of :func:`radarfusion_ref.capstone.pipeline.run_pipeline` are linked
scan to scan into tracks; each track keeps one local Kalman filter per radar and fuses
them with the rules of :mod:`radarfusion_ref.trackfusion` (motion model, prediction,
covariance intersection, the naive rule).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from .. import gating, trackfusion
from ..engine import assignment
from ..engine._validation import _describe, as_choice, as_float, as_int, as_positive, as_probability
from ..engine.linalg import mahalanobis_sq_pairwise
from ..engine.metrics import purity
from ..engine.tracker._kalman import predict_kernel, update_kernel
from .pipeline import PipelineResult

__all__ = ["TrackFusionResult", "track_fusion"]


@dataclass(frozen=True)
class TrackFusionResult:
    """Fused tracks of every scan (one row per confirmed track and scan).

    Attributes
    ----------
    scan, track : numpy.ndarray of int, shape (R,)
        Scan and track number of each row.
    position : numpy.ndarray, shape (R, 3)
        Track-to-track fused position (m).
    covariance : numpy.ndarray, shape (R, 3, 3)
        Its covariance under the fusion rule.
    source : numpy.ndarray of int, shape (R,)
        Truth label: the aircraft whose reports alone made the object the track was
        updated with at this scan; -1 when that object mixed sources or the track coasted.
    rule : str
        ``"ci"`` (covariance intersection) or ``"naive"`` (independence assumed).
    n_scans : int
    seconds : float
        Wall time of the tracking stage.
    """

    scan: np.ndarray
    track: np.ndarray
    position: np.ndarray
    covariance: np.ndarray
    source: np.ndarray
    rule: str
    n_scans: int
    seconds: float


#: Cost of leaving a track or an object unlinked: far above any gated pair's cost, so the
#: link takes as many gated pairs as it can, then the likeliest.
_LINK_MISS = 1e6
#: Velocity variance (m²/s²) of a new track: 0 ± 250 m/s per axis.
_V0 = 250.0 ** 2


def _kf_update(x, P, z, R):
    """Kalman update of (k, 6) states with (k, 3) position reports (the engine's kernel)."""
    xn, Pn, _, _ = update_kernel(x, P, z, R)
    return xn, Pn


def _predict(x, P, period, q):
    """Constant-velocity prediction (the engine's kernel; trusted input)."""
    if not x.shape[0]:
        return x, P
    return predict_kernel(x, P, float(period), float(q))


def _link(pos, cov, XF, PF, gamma):
    """Exact gated assignment of predicted tracks to the scan's objects (-1: unlinked)."""
    kappa, logdet = mahalanobis_sq_pairwise(XF[:, :3], pos, PF[:, :3, :3], cov,
                                            return_logdet=True)
    # full negative log-likelihood (with ln|2 pi S|): a confident track keeps its object
    # against a young, uncertain one; pairs outside the gate are forbidden
    cost = np.where(kappa < gamma, kappa + logdet + 3 * math.log(2 * math.pi), np.inf)
    return assignment.solve_2d(cost, miss_cost=_LINK_MISS).row_to_col


def _fuse_local(X, P, act, rule):
    """Fuse the active local tracks (k, m, 6) of each track into one (k, 6)."""
    k, m = act.shape
    fx = np.zeros((k, 6))
    fp = np.zeros((k, 6, 6))
    have = np.zeros(k, dtype=bool)
    fuse = trackfusion.covariance_intersection if rule == "ci" else trackfusion.naive_fusion
    for i in range(m):
        a = act[:, i]
        start = a & ~have
        fx[start], fp[start] = X[start, i], P[start, i]
        both = a & have
        if both.any():
            r = fuse(fx[both], fp[both], X[both, i], P[both, i])
            fx[both], fp[both] = r.estimate, r.covariance
        have |= a
    return fx, fp


def _track_iv(result, period, q, rule, confirm, max_misses, p_false_reject):
    if not isinstance(result, PipelineResult) or result.report_position is None:
        raise TypeError(f"`result` must be a PipelineResult from run_pipeline; received "
                        f"{_describe(result)}")
    p_lo = as_float(as_probability(p_false_reject, "p_false_reject"), "p_false_reject")
    return (as_float(as_positive(period, "period"), "period"), as_float(as_positive(q, "q"), "q"),
            as_choice(rule, "rule", ("ci", "naive")), as_int(confirm, "confirm", minimum=1),
            as_int(max_misses, "max_misses", minimum=0), p_lo)


def track_fusion(result, *, period=10.0, q=10.0, rule="ci", confirm=2, max_misses=2,
                 p_false_reject=1e-3) -> TrackFusionResult:
    r"""Step 7: a track per aircraft, one local track per radar, fused track to track.

    Parameters
    ----------
    result : PipelineResult
        The fused objects of :func:`radarfusion_ref.capstone.pipeline.run_pipeline` (and
        the converted reports it keeps).
    period : float, optional
        Scan period (s, default 10), as given to
        :func:`radarfusion_ref.capstone.traffic.truth_scans`.
    q : float, optional
        Process-noise intensity of the constant-velocity model (m²/s³, default 10:
        :func:`radarfusion_ref.trackfusion.constant_velocity`, continuous white noise).
    rule : {"ci", "naive"}, optional
        Track-to-track fusion: :func:`radarfusion_ref.trackfusion.covariance_intersection`
        (sequentially over the radars; default) or
        :func:`radarfusion_ref.trackfusion.naive_fusion`, which assumes the local tracks'
        errors independent although they share the process noise.
    confirm : int, optional
        Updates before a track is reported (default 2).
    max_misses : int, optional
        Consecutive scans without an object before a track is dropped (default 2).
    p_false_reject : float, optional
        Gate of the scan-to-scan link (default 1e-3): an object joins a track only if
        its statistic against the predicted track is below the :math:`\chi^2_3` quantile
        (:func:`radarfusion_ref.gating.gate_threshold`).

    Returns
    -------
    TrackFusionResult

    Raises
    ------
    TypeError
        If `result` is not a :class:`~radarfusion_ref.capstone.pipeline.PipelineResult`
        with its converted reports.
    ValueError
        Bad `period`, `q`, `rule`, `confirm`, `max_misses` or `p_false_reject`.

    Notes
    -----
    Each scan: the fused track of every live track is predicted over the period
    (:func:`radarfusion_ref.trackfusion.predict`) and linked to the scan's objects by an
    exact gated assignment (:func:`radarfusion_ref.engine.assignment.solve_2d`): pairs
    whose Mahalanobis statistic passes the gate cost :math:`\kappa + \ln|2\pi S|` (the
    full negative log-likelihood, so that a young, uncertain track cannot take a
    confident track's object), and the link takes as many gated pairs as possible. A
    linked track updates the local filter of every radar that has a report in the object
    (a Kalman update with the report's converted covariance; a radar's first report
    starts its local track from the fused velocity), then fuses its local tracks.
    Unlinked objects start tracks (velocity 0 ± 250 m/s); unlinked tracks coast and are
    dropped after `max_misses` scans.
    """
    t0 = time.perf_counter()
    period, q, rule, confirm, max_misses, p_lo = _track_iv(
        result, period, q, rule, confirm, max_misses, p_false_reject)
    gamma = float(gating.gate_threshold(p_lo, 3))
    rep = result.reports
    m = result.members.shape[1]
    xr, cr = result.report_position, result.report_covariance
    label = purity(np.where(result.members >= 0, rep.source[np.maximum(result.members, 0)],
                            -1), result.members >= 0).source
    # live tracks: local states (k, m, 6), which are active, fused states (k, 6)
    X = np.zeros((0, m, 6))
    P = np.zeros((0, m, 6, 6))
    act = np.zeros((0, m), dtype=bool)
    XF = np.zeros((0, 6))
    PF = np.zeros((0, 6, 6))
    hits = np.zeros(0, dtype=np.int64)
    miss = np.zeros(0, dtype=np.int64)
    ids = np.zeros(0, dtype=np.int64)
    next_id = 0
    order = np.argsort(result.scan, kind="stable")
    bounds = np.searchsorted(result.scan[order], np.arange(rep.n_scans + 1))
    out = []
    for s in range(rep.n_scans):
        obj = order[bounds[s]:bounds[s + 1]]
        # predict
        X, P = _predict(X.reshape(-1, 6), P.reshape(-1, 6, 6), period, q)
        X, P = X.reshape(-1, m, 6), P.reshape(-1, m, 6, 6)
        XF, PF = _predict(XF, PF, period, q)
        k, g = XF.shape[0], obj.size
        link = np.full(k, -1)
        if k and g:
            link = _link(result.position[obj], result.covariance[obj], XF, PF, gamma)
        linked = link >= 0
        # update the linked tracks' local filters
        for i in range(m):
            rows = np.flatnonzero(linked)
            rr = result.members[obj[link[rows]], i]
            has = rr >= 0
            rows, rr = rows[has], rr[has]
            new = ~act[rows, i]
            if new.any():
                nr = rows[new]
                X[nr, i, :3], X[nr, i, 3:] = xr[rr[new]], XF[nr, 3:]
                P[nr, i] = 0.0
                P[nr, i, :3, :3] = cr[rr[new]]
                P[nr, i, 3:, 3:] = PF[nr, 3:, 3:]
                act[nr, i] = True
            old = ~new
            if old.any():
                X[rows[old], i], P[rows[old], i] = _kf_update(
                    X[rows[old], i], P[rows[old], i], xr[rr[old]], cr[rr[old]])
        hits[linked] += 1
        miss[linked] = 0
        miss[~linked] += 1
        keep = miss <= max_misses
        # fuse the local tracks of the linked tracks
        rows = np.flatnonzero(linked)
        if rows.size:
            XF[rows], PF[rows] = _fuse_local(X[rows], P[rows], act[rows], rule)
        # start tracks from unlinked objects
        used = np.zeros(g, dtype=bool)
        used[link[linked]] = True
        fresh = obj[~used]
        nf = fresh.size
        lab_t = np.where(linked, label[obj[np.maximum(link, 0)]] if g else -1, -1)[keep]
        X, P, act, XF, PF = X[keep], P[keep], act[keep], XF[keep], PF[keep]
        hits, miss, ids = hits[keep], miss[keep], ids[keep]
        if nf:
            Xn, Pn, an, XFn, PFn = _new_tracks(result, fresh, m)
            X, P, act = (np.concatenate([X, Xn]), np.concatenate([P, Pn]),
                         np.concatenate([act, an]))
            XF, PF = np.concatenate([XF, XFn]), np.concatenate([PF, PFn])
            lab_t = np.concatenate([lab_t, label[fresh]])
            hits = np.concatenate([hits, np.ones(nf, dtype=np.int64)])
            miss = np.concatenate([miss, np.zeros(nf, dtype=np.int64)])
            ids = np.concatenate([ids, next_id + np.arange(nf)])
            next_id += nf
        show = hits >= confirm
        out.append((np.full(int(show.sum()), s), ids[show], XF[show, :3], PF[show, :3, :3],
                    lab_t[show]))
    cols = [np.concatenate(c) if c else np.empty(0) for c in zip(*out, strict=True)]
    return TrackFusionResult(scan=cols[0].astype(np.int64), track=cols[1].astype(np.int64),
                             position=cols[2].reshape(-1, 3),
                             covariance=cols[3].reshape(-1, 3, 3),
                             source=cols[4].astype(np.int64), rule=rule,
                             n_scans=rep.n_scans, seconds=time.perf_counter() - t0)


def _new_tracks(result, fresh, m):
    """Tracks started from the unlinked objects `fresh`: local and fused states."""
    xr, cr = result.report_position, result.report_covariance
    nf = fresh.size
    Xn = np.zeros((nf, m, 6))
    Pn = np.zeros((nf, m, 6, 6))
    an = result.members[fresh] >= 0
    for i in range(m):
        rr = result.members[fresh, i]
        h = rr >= 0
        Xn[h, i, :3] = xr[rr[h]]
        Pn[h, i, :3, :3] = cr[rr[h]]
        Pn[:, i, 3:, 3:] = _V0 * np.eye(3)
        Pn[~h, i, :3, :3] = np.eye(3)
    XFn = np.zeros((nf, 6))
    XFn[:, :3] = result.position[fresh]
    PFn = np.zeros((nf, 6, 6))
    PFn[:, :3, :3] = result.covariance[fresh]
    PFn[:, 3:, 3:] = _V0 * np.eye(3)
    return Xn, Pn, an, XFn, PFn
