r"""The motion model of the tracker's settings: process noise per axis and the new-track prior.

One home for what :class:`~radarfusion_ref.tracking.TrackerSettings` says about motion, so
that the architectures (a), (b), (c) and the Stone Soup adapter read it the same way.
"""

from __future__ import annotations

import functools

import numpy as np

from ..engine.linalg import mahalanobis_sq_kernel
from ..engine.tracker import (
    combine_kernel,
    imm_predict_kernel,
    imm_update_kernel,
    increments_kernel,
    predict_kernel,
)


def axis_q(s) -> np.ndarray:
    """Process-noise intensity per coordinate (east, north, up) of the constant-velocity model."""
    qv = s.q if s.q_vertical is None else s.q_vertical
    return np.array([s.q, s.q, qv])


def velocity_sd(s) -> np.ndarray:
    """Standard deviation per coordinate of a new track's velocity."""
    vz = s.speed_max if s.speed_max_vertical is None else s.speed_max_vertical
    return np.array([s.speed_max, s.speed_max, vz])


def mode_q(s) -> np.ndarray:
    """IMM: process-noise intensity per mode and coordinate, shape (M, 3)."""
    qh = np.asarray(s.imm_q, float)
    if s.imm_q_vertical is not None:
        qv = np.asarray(s.imm_q_vertical, float)
    elif s.q_vertical is not None:
        qv = np.full(qh.size, s.q_vertical)
    else:
        qv = qh
    return np.stack([qh, qh, qv], -1)


def coast_q(s) -> np.ndarray:
    """Intensity per coordinate for predicting a track whose mode is not known.

    The constant-velocity model's own; for the IMM, the modes' intensities weighted by the
    chain's long-run probabilities (proportional to the mean sojourn times).
    """
    if s.motion == "cv":
        return axis_q(s)
    w = np.asarray(s.imm_sojourn) / np.sum(s.imm_sojourn)
    return w @ mode_q(s)


def predict(x, P, dt, s, unit=1.0):
    """Predict combined estimates by `dt` with :func:`coast_q` (trusted input; states in
    `unit` metres, e.g. the reports' ``length_unit``)."""
    return predict_kernel(x, P, dt, coast_q(s) / unit**2, per_axis=True)


def transition(s, dt) -> np.ndarray:
    r"""IMM: :math:`\Pi(\Delta t) = e^{\Lambda\Delta t}` for each interval, shape (..., M, M).

    Through the eigen-decomposition :math:`\Lambda = V\operatorname{diag}(\lambda)V^{-1}`
    (one per settings): :math:`e^{\Lambda\Delta t} = V\operatorname{diag}(e^{\lambda\Delta t})
    V^{-1}`, exact for the diagonalisable generators built here (eigenvalues 0 and
    negative reals for two modes).
    """
    lam, V, Vinv = _generator(s.imm_sojourn)
    e = np.exp(np.asarray(dt, float)[..., None] * lam)
    out = np.real(np.einsum("ik,...k,kj->...ij", V, e, Vinv))
    return np.clip(out, 0.0, 1.0)


@functools.lru_cache(maxsize=16)
def _generator(sojourn):
    rate = 1.0 / np.asarray(sojourn, float)
    M = rate.size
    if M == 1:
        return np.zeros(1), np.ones((1, 1)), np.ones((1, 1))
    gen = np.repeat((rate / (M - 1))[:, None], M, 1)
    np.fill_diagonal(gen, -rate)
    lam, V = np.linalg.eig(gen)
    return lam, V, np.linalg.inv(V)


# ----------------------------------------------------------------------------- IMM tracks
def imm_predict_live(lv, t, s, qm):
    """Predict the live tracks' modes to `t` (mixing first); the combined estimate follows.

    Every live track stands at the same instant (the last scan's), so one interval, one
    transition matrix and one set of model matrices serve them all.
    """
    dt = t - float(lv.t[0])
    cbar, lv.xm, lv.Pm = imm_predict_kernel(lv.mu, lv.xm, lv.Pm, transition(s, dt), dt, qm,
                                            per_axis=True)
    lv.mu = cbar
    lv.x, lv.P = combine_kernel(cbar, lv.xm, lv.Pm)


def imm_increments(lv, ti, rj, z, R, s):
    r"""Score increments of gated pairs from the mixture of the mode likelihoods:
    :math:`\ln\frac{P_D\sum_j\bar c_j\Lambda_j}{\lambda}`."""
    nu = z[rj][:, None, :] - lv.xm[ti, :, :3]
    ld: list = []                                      # trusted: the tracker's own modes
    d2 = mahalanobis_sq_kernel(nu, lv.Pm[ti, :, :3, :3] + R[rj][:, None], "`position`, `cov`",
                               ld)
    with np.errstate(divide="ignore"):
        a = np.log(lv.mu[ti]) + increments_kernel(d2, ld[0], s.p_detection, s.clutter_density)
    top = a.max(1)
    return top + np.log(np.exp(a - top[:, None]).sum(1))


def imm_gnn_update(lv, i, z, R):
    """Update tracks `i` with one report each: every mode, then the mode probabilities."""
    xn, Pn, _, post = imm_update_kernel(lv.mu[i], lv.xm[i], lv.Pm[i], z, R)
    lv.xm[i], lv.Pm[i], lv.mu[i] = xn, Pn, post
    lv.x[i], lv.P[i] = combine_kernel(post, xn, Pn)


def imm_jpda_update(lv, ti, rj, z, R, beta, b0):
    r"""JPDA with IMM tracks: the moments, per mode, of the posterior mixture over (event,
    mode). Given that report k is the track's, mode j has probability
    :math:`\bar c_j\Lambda_{jk}/\sum_l\bar c_l\Lambda_{lk}`; given a miss, :math:`\bar c_j`."""
    rows = np.unique(ti)
    loc = np.searchsorted(rows, ti)
    xu, Pu, _, post = imm_update_kernel(lv.mu[ti], lv.xm[ti], lv.Pm[ti], z[rj], R[rj])
    w0 = b0[rows, None] * lv.mu[rows]                     # (rows, M): miss, then mode j
    a = beta[:, None] * post                              # (pairs, M): report k, mode j
    mu = w0.copy()
    np.add.at(mu, loc, a)
    safe = np.where(mu > 0, mu, 1.0)
    x0, P0 = lv.xm[rows], lv.Pm[rows]
    mean = w0[..., None] * x0
    np.add.at(mean, loc, a[..., None] * xu)
    mean = np.where(mu[..., None] > 0, mean / safe[..., None], x0)
    d0 = x0 - mean
    cov = w0[..., None, None] * (P0 + d0[..., :, None] * d0[..., None, :])
    du = xu - mean[loc]
    np.add.at(cov, loc, a[..., None, None] * (Pu + du[..., :, None] * du[..., None, :]))
    cov = np.where(mu[..., None, None] > 0, cov / safe[..., None, None], P0)
    mu = mu / mu.sum(1, keepdims=True)
    lv.xm[rows], lv.Pm[rows], lv.mu[rows] = mean, 0.5 * (cov + np.swapaxes(cov, -1, -2)), mu
    lv.x[rows], lv.P[rows] = combine_kernel(mu, lv.xm[rows], lv.Pm[rows])
