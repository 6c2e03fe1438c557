r"""The constant-velocity Kalman filter: the one home of its prediction and update.

State :math:`\mathbf x = (p_1, \dots, p_d, v_1, \dots, v_d)`, measurement of the
position alone (:math:`H = [I_d \; 0]`). The kernels (``cv_matrices``, ``predict_kernel``,
``update_kernel``) trust their input; the public :func:`kalman_predict` and
:func:`kalman_update` validate at the door and call them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..linalg import mahalanobis_sq_kernel
from ..validation import (
    MAX_MAGNITUDE,
    as_choice,
    as_covariance,
    as_float_array,
    as_positive,
    check_size,
)

#: Largest number of batch elements × state entries of one call.
MAX_BATCH = 1 << 24


@dataclass(frozen=True)
class KalmanEstimate:
    """A batch of track states and covariances.

    Attributes
    ----------
    state : numpy.ndarray, shape (..., 2 d)
    covariance : numpy.ndarray, shape (..., 2 d, 2 d)
    """

    state: np.ndarray
    covariance: np.ndarray


@dataclass(frozen=True)
class KalmanUpdate:
    r"""Updated tracks and what the innovation says about the report.

    Attributes
    ----------
    state : numpy.ndarray, shape (..., 2 d)
        :math:`\hat{\mathbf x} + K\boldsymbol\nu`.
    covariance : numpy.ndarray, shape (..., 2 d, 2 d)
        Joseph form :math:`(I - KH)P(I - KH)^\mathsf T + K\Sigma K^\mathsf T`.
    statistic : numpy.ndarray, shape (...)
        :math:`\boldsymbol\nu^\mathsf T S^{-1}\boldsymbol\nu`, the squared Mahalanobis
        distance of the report from the predicted position (the gate's statistic).
    log_det : numpy.ndarray, shape (...)
        :math:`\ln\det S` of the innovation covariance :math:`S = HPH^\mathsf T + \Sigma`.
    """

    state: np.ndarray
    covariance: np.ndarray
    statistic: np.ndarray
    log_det: np.ndarray


def _sym(a):
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def cv_matrices(dt, q, dim, noise="continuous", per_axis=False):
    """Kernel (trusted input): ``(F, Q)`` of the constant-velocity model, broadcast over `dt`, `q`.

    With `per_axis`, `q` holds one intensity per coordinate on its last axis (shape
    ``(..., dim)``) and :math:`Q` is block-diagonal per coordinate with those intensities.
    """
    dt, q = np.asarray(dt, float), np.asarray(q, float)
    if per_axis:
        dt, _ = np.broadcast_arrays(dt, q[..., 0])
        dq = dt[..., None]
    else:
        dt, q = np.broadcast_arrays(dt, q)
        dq = dt
    if noise == "continuous":
        qpp, qpv, qvv = q * dq**3 / 3, q * dq**2 / 2, q * dq
    else:
        qpp, qpv, qvv = q * dq**4 / 4, q * dq**3 / 2, q * dq**2
    eye = np.eye(dim)

    def blocks(a, b, c, e, axes=False):
        a, b, c, e = ((v[..., None, :] if axes else v[..., None, None]) * eye
                      for v in (a, b, c, e))
        return np.concatenate([np.concatenate([a, b], -1), np.concatenate([c, e], -1)], -2)

    one, zero = np.ones_like(dt), np.zeros_like(dt)
    return blocks(one, dt, zero, one), blocks(qpp, qpv, qpv, qvv, per_axis)


def check_prediction(xp, Pp, dt, q) -> None:
    """Kernel (trusted input): refuse, naming `dt` and `q`, a prediction beyond the numeric domain.

    The domain (:data:`radarfusion_ref.engine.validation.MAX_MAGNITUDE`): coordinates of
    magnitude at most :math:`2^{150}`, variances at most :math:`2^{150}`.
    """
    var = np.diagonal(Pp, axis1=-2, axis2=-1)
    if not (np.all(np.abs(xp) <= MAX_MAGNITUDE) and np.all(var <= MAX_MAGNITUDE)):
        raise ValueError(
            f"`dt`, `q`: the predicted track leaves the numeric domain (variances and "
            f"coordinates up to 2**150, about 1.4e45; largest predicted variance "
            f"{float(np.max(var)):.6g}) for dt up to {float(np.max(dt)):.6g} and q up to "
            f"{float(np.max(q)):.6g}; predict over a shorter interval or use larger units")


def predict_kernel(x, P, dt, q, noise="continuous", per_axis=False):
    r"""Kernel: :math:`F\mathbf x` and :math:`FPF^\mathsf T + Q` (trusted input; `per_axis`
    as in :func:`cv_matrices`)."""
    F, Q = cv_matrices(dt, q, x.shape[-1] // 2, noise, per_axis)
    xp = (F @ x[..., None])[..., 0]
    return xp, _sym(F @ P @ np.swapaxes(F, -1, -2) + Q)


def update_kernel(x, P, z, R):
    r"""Kernel: the Kalman update with position reports `z` (trusted input).

    Returns the state, the Joseph-form covariance, the statistic
    :math:`\nu^\mathsf T S^{-1}\nu` and :math:`\ln\det S`.
    """
    d = z.shape[-1]
    S = _sym(P[..., :d, :d] + R)                                      # H P Hᵀ + Σ
    nu = z - x[..., :d]                                               # ν = z - H x
    PHt = P[..., :, :d]                                               # P Hᵀ
    K = np.swapaxes(np.linalg.solve(S, np.swapaxes(PHt, -1, -2)), -1, -2)   # P Hᵀ S⁻¹
    xn = x + (K @ nu[..., None])[..., 0]                              # x + K ν
    A = np.eye(x.shape[-1]) - np.concatenate([K, np.zeros(K.shape)], -1)      # I - K H
    Pn = _sym(A @ P @ np.swapaxes(A, -1, -2) + K @ R @ np.swapaxes(K, -1, -2))
    ld: list = []
    stat = mahalanobis_sq_kernel(nu, S, "`z`, `z_cov`", ld)                  # νᵀ S⁻¹ ν, ln det S
    logdet = np.broadcast_to(ld[0], stat.shape)
    return xn, Pn, stat, logdet


def _state_iv(x, P):
    x = as_float_array(x, "x", ndim_min=1)
    n = x.shape[-1]
    if n not in (2, 4, 6):
        raise ValueError(f"`x` must hold [positions, velocities] of 1, 2 or 3 coordinates "
                         f"(last axis 2, 4 or 6); received shape {x.shape}")
    return x, as_covariance(P, "cov", dim=n)


def kalman_predict(x, cov, dt, q, *, noise="continuous") -> KalmanEstimate:
    r"""Predict constant-velocity tracks forward by `dt`.

    Parameters
    ----------
    x : array_like, shape (..., 2 d)
        States ``[positions, velocities]``, d = 1, 2 or 3.
    cov : array_like, shape (..., 2 d, 2 d)
        Their covariances, symmetric positive definite.
    dt : float or array_like, shape (...)
        Interval(s) :math:`\Delta t \ge 0`, one per track if an array.
    q : float or array_like
        Process-noise intensity :math:`q \ge 0` (power spectral density of the white
        acceleration for ``"continuous"``, acceleration variance for ``"discrete"``).
    noise : {"continuous", "discrete"}, optional
        Continuous white-noise acceleration (default) or piecewise constant.

    Returns
    -------
    KalmanEstimate
        :math:`F(\Delta t)\mathbf x` and :math:`F P F^\mathsf T + Q(\Delta t)`.

    Raises
    ------
    ValueError
        If the state is not 2, 4 or 6 long, `cov` not positive definite, `dt` or `q`
        negative, the shapes do not broadcast, or the batch is too large.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    Per coordinate :math:`F = \begin{pmatrix}1 & \Delta t\\ 0 & 1\end{pmatrix}`,
    :math:`Q = q\begin{pmatrix}\Delta t^3/3 & \Delta t^2/2\\ \Delta t^2/2 & \Delta t\end{pmatrix}`
    (continuous). Bar-Shalom, Li & Kirubarajan (2001), eqs. (6.2.3-8), (5.2.3-5).

    Examples
    --------
    >>> r = kalman_predict([0.0, 1.0], np.eye(2), 2.0, 0.0)
    >>> r.state, r.covariance
    (array([2., 1.]), array([[5., 2.],
           [2., 1.]]))
    """
    x, cov = _state_iv(x, cov)
    dt = as_positive(dt, "dt", strict=False)
    q = as_positive(q, "q", strict=False)
    noise = as_choice(noise, "noise", ("continuous", "discrete"))
    try:
        lead = np.broadcast_shapes(x.shape[:-1], cov.shape[:-2], dt.shape, q.shape)
    except ValueError:
        raise ValueError(f"`x`, `cov`, `dt`, `q` must have broadcasting batch shapes; received "
                         f"{x.shape}, {cov.shape}, {dt.shape}, {q.shape}") from None
    n = x.shape[-1]
    check_size(math.prod(lead) * n * n, MAX_BATCH, what="batch elements × state entries",
               alternative="several calls on slices of the batch")
    with np.errstate(over="ignore", invalid="ignore"):
        xp, Pp = predict_kernel(x, cov, dt, q, noise)
    check_prediction(xp, Pp, dt, q)
    return KalmanEstimate(np.broadcast_to(xp, (*lead, n)).copy(),
                          np.broadcast_to(Pp, (*lead, n, n)).copy())


def kalman_update(x, cov, z, z_cov) -> KalmanUpdate:
    r"""Update constant-velocity tracks with position reports.

    Parameters
    ----------
    x : array_like, shape (..., 2 d)
        Predicted states ``[positions, velocities]``.
    cov : array_like, shape (..., 2 d, 2 d)
        Their covariances.
    z : array_like, shape (..., d)
        Position reports.
    z_cov : array_like, shape (..., d, d)
        The reports' error covariances :math:`\Sigma` (each report its own).

    Returns
    -------
    KalmanUpdate
        State, covariance, the gate statistic and :math:`\ln\det S`.

    Raises
    ------
    ValueError
        Wrong shapes, a covariance not positive definite, non-finite entries, or a
        batch too large.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    With :math:`H = [I\;0]`, :math:`S = HPH^\mathsf T + \Sigma`,
    :math:`K = PH^\mathsf T S^{-1}`:

    .. math::

        \hat{\mathbf x}^+ = \hat{\mathbf x} + K(\mathbf z - H\hat{\mathbf x}), \qquad
        P^+ = (I - KH)P(I - KH)^\mathsf T + K\Sigma K^\mathsf T.

    The Joseph form equals :math:`(I - KH)P` for the optimal gain and stays
    symmetric positive definite in floating point.

    Examples
    --------
    >>> r = kalman_update([0.0, 0.0], np.eye(2), [2.0], [[1.0]])
    >>> r.state, round(float(r.statistic), 9)
    (array([1., 0.]), 2.0)
    """
    x, cov = _state_iv(x, cov)
    d = x.shape[-1] // 2
    z = as_float_array(z, "z", ndim_min=1, last_dims=(d,))
    z_cov = as_covariance(z_cov, "z_cov", dim=d)
    try:
        lead = np.broadcast_shapes(x.shape[:-1], cov.shape[:-2], z.shape[:-1], z_cov.shape[:-2])
    except ValueError:
        raise ValueError(f"`x`, `cov`, `z`, `z_cov` must have broadcasting batch shapes; received "
                         f"{x.shape}, {cov.shape}, {z.shape}, {z_cov.shape}") from None
    n = 2 * d
    check_size(math.prod(lead) * n * n, MAX_BATCH, what="batch elements × state entries",
               alternative="several calls on slices of the batch")
    x, cov = np.broadcast_to(x, (*lead, n)), np.broadcast_to(cov, (*lead, n, n))
    z, z_cov = np.broadcast_to(z, (*lead, d)), np.broadcast_to(z_cov, (*lead, d, d))
    return KalmanUpdate(*update_kernel(x, cov, z, z_cov))
