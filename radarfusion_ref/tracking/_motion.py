r"""The motion model of the tracker's settings: process noise per axis and the new-track prior.

One home for what :class:`~radarfusion_ref.tracking.TrackerSettings` says about motion, so
that the architectures (a), (b), (c) and the Stone Soup adapter read it the same way.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from ..engine.tracker._kalman import predict_kernel


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


def predict(x, P, dt, s):
    """Predict combined estimates by `dt` with :func:`coast_q` (trusted input)."""
    return predict_kernel(x, P, dt, coast_q(s), per_axis=True)


def transition(s, dt) -> np.ndarray:
    r"""IMM: :math:`\Pi(\Delta t) = e^{\Lambda\Delta t}` for each interval, shape (..., M, M)."""
    rate = 1.0 / np.asarray(s.imm_sojourn, float)
    M = rate.size
    if M == 1:
        return np.ones((*np.shape(dt), 1, 1))
    gen = np.repeat((rate / (M - 1))[:, None], M, 1)
    np.fill_diagonal(gen, -rate)
    dt = np.asarray(dt, float)
    return expm(dt[..., None, None] * gen)
