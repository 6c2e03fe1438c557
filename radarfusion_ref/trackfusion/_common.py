"""Track fusion: constants, result types and the validation shared by the rules and the models."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..engine.validation import (
    MEMORY_LIMIT,
    as_covariance,
    as_float_array,
    check_domain,
    check_size,
    describe,
)

#: The criteria :func:`covariance_intersection` minimises.
CRITERIA = ("det", "trace")

#: Largest state dimension accepted by :func:`cross_covariance` (its steady state solves
#: a linear system of :math:`d^2` unknowns per batch element).
MAX_DIM = 12

#: Largest number of batch elements × state entries one call works on at once.
MAX_BATCH = MEMORY_LIMIT // 64

#: Relative tolerance on the smallest eigenvalue of a joint covariance: a matrix whose
#: smallest eigenvalue is above ``-PSD_RTOL`` times its largest is accepted as PSD.
PSD_RTOL = 1e-10

#: Bisection steps for ω: the bracket [0, 1] shrinks to 2^-60, below double precision.
_OMEGA_STEPS = 60


# --------------------------------------------------------------------------- results
@dataclass(frozen=True)
class TrackEstimate:
    r"""A track (or fused track): state estimate and its covariance.

    Attributes
    ----------
    estimate : numpy.ndarray, shape (..., d)
        The state estimate :math:`\tilde{\mathbf x}`.
    covariance : numpy.ndarray, shape (..., d, d)
        The covariance :math:`\tilde P` the rule attaches to it.
    """

    estimate: np.ndarray
    covariance: np.ndarray


@dataclass(frozen=True)
class CovarianceIntersection:
    r"""The result of :func:`covariance_intersection`.

    Attributes
    ----------
    estimate : numpy.ndarray, shape (..., d)
        :math:`\tilde{\mathbf x} = \tilde P(\omega P_1^{-1}\hat{\mathbf x}_1
        + (1-\omega)P_2^{-1}\hat{\mathbf x}_2)`.
    covariance : numpy.ndarray, shape (..., d, d)
        :math:`\tilde P = (\omega P_1^{-1} + (1-\omega)P_2^{-1})^{-1}`.
    omega : numpy.ndarray or float, shape (...)
        The weight :math:`\omega \in [0, 1]` of track 1.
    criterion : str
        ``"det"``, ``"trace"`` (ω chosen by minimising it) or ``"given"``.
    """

    estimate: np.ndarray
    covariance: np.ndarray
    omega: np.ndarray | float
    criterion: str


@dataclass(frozen=True)
class MotionModel:
    r"""A linear motion model :math:`\mathbf x_k = F\mathbf x_{k-1} + \mathbf w_k`,
    :math:`\mathbf w_k \sim \mathcal N(0, Q)`.

    Attributes
    ----------
    F : numpy.ndarray, shape (..., d, d)
        Transition matrix.
    Q : numpy.ndarray, shape (..., d, d)
        Process-noise covariance (symmetric positive semi-definite).
    """

    F: np.ndarray
    Q: np.ndarray


@dataclass(frozen=True)
class TrackCovariances:
    r"""Covariances and gains of two Kalman filters of one object.

    With ``steps=None`` (the steady state) the arrays have shape ``(..., d, d)`` and
    ``(..., d, p_i)``; with ``steps=k`` they hold the first `k` updates along axis
    ``-3`` (shape ``(..., k, d, d)``).

    Attributes
    ----------
    P1, P2 : numpy.ndarray
        Updated covariances :math:`P_1, P_2` of the two tracks.
    P12 : numpy.ndarray
        Their cross-covariance :math:`P_{12} = E[\mathbf e_1\mathbf e_2^\mathsf T]`.
    K1, K2 : numpy.ndarray
        The Kalman gains :math:`K_1, K_2`.
    """

    P1: np.ndarray
    P2: np.ndarray
    P12: np.ndarray
    K1: np.ndarray
    K2: np.ndarray

    @property
    def correlation(self) -> np.ndarray:
        r"""Correlation coefficients :math:`[P_{12}]_{jj}/\sqrt{[P_1]_{jj}[P_2]_{jj}}` of
        each state component, shape ``(..., d)``."""
        d1 = np.diagonal(self.P1, axis1=-2, axis2=-1)
        d2 = np.diagonal(self.P2, axis1=-2, axis2=-1)
        return np.diagonal(self.P12, axis1=-2, axis2=-1) / np.sqrt(d1 * d2)


@dataclass(frozen=True)
class TrackRuns:
    """Monte-Carlo runs of :func:`simulate_tracks`.

    Attributes
    ----------
    truth : numpy.ndarray, shape (trials, steps, d)
        The object's state after each step.
    estimate1, estimate2 : numpy.ndarray, shape (trials, steps, d)
        The two filters' updated estimates.
    covariances : TrackCovariances
        The filters' covariances and gains (the same in every trial), shape
        ``(steps, d, d)``.
    """

    truth: np.ndarray
    estimate1: np.ndarray
    estimate2: np.ndarray
    covariances: TrackCovariances

    @property
    def error1(self) -> np.ndarray:
        r"""Track 1's error :math:`\mathbf e_1 = \hat{\mathbf x}_1 - \mathbf x`."""
        return self.estimate1 - self.truth

    @property
    def error2(self) -> np.ndarray:
        r"""Track 2's error :math:`\mathbf e_2 = \hat{\mathbf x}_2 - \mathbf x`."""
        return self.estimate2 - self.truth


# --------------------------------------------------------------------------- validation
def _sym(a):
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def _as_psd(value, name: str, *, dim: int | None = None) -> np.ndarray:
    """Symmetric positive semi-definite matrices (..., d, d) (a process noise may be singular)."""
    arr = as_float_array(value, name, ndim_min=2)
    if arr.shape[-1] != arr.shape[-2] or (dim is not None and arr.shape[-1] != dim):
        want = "(..., d, d)" if dim is None else f"(..., {dim}, {dim})"
        raise ValueError(f"`{name}` must have shape {want}; received shape {arr.shape}")
    scale = np.max(np.abs(arr), axis=(-2, -1), keepdims=True)
    if np.any(np.abs(arr - np.swapaxes(arr, -1, -2)) > 1e-9 * np.maximum(scale, 1e-300)):
        raise ValueError(f"`{name}` must be symmetric; received {describe(arr)}")
    low = np.linalg.eigvalsh(_sym(arr))[..., 0]
    if np.any(low < -PSD_RTOL * scale[..., 0, 0]):
        raise ValueError(f"`{name}` must be positive semi-definite; smallest eigenvalue "
                         f"{float(np.min(low)):.6g}")
    return arr


def _joint_psd(P1, P2, P12, names=("cov1", "cov2", "cov12")):
    """Refuse a cross-covariance for which [[P1, P12], [P12ᵀ, P2]] is not PSD."""
    top = np.concatenate([P1, P12], axis=-1)
    bottom = np.concatenate([np.swapaxes(P12, -1, -2), P2], axis=-1)
    joint = _sym(np.concatenate([top, bottom], axis=-2))
    eig = np.linalg.eigvalsh(joint)
    bad = eig[..., 0] < -PSD_RTOL * np.maximum(np.abs(eig[..., -1]), 1e-300)
    if np.any(bad):
        a, b, c = names
        raise ValueError(
            f"`{c}`: the joint covariance [[{a}, {c}], [{c}ᵀ, {b}]] of the two tracks must be "
            f"positive semi-definite; it is not for {int(np.count_nonzero(bad))} of "
            f"{bad.size} batch elements (smallest eigenvalue {float(np.min(eig[..., 0])):.6g})")


def _pair_iv(x1, P1, x2, P2, P12=None):
    """Validate two tracks (and a cross-covariance) and broadcast their batch axes."""
    x1 = as_float_array(x1, "x1", ndim_min=1)
    d = x1.shape[-1]
    if d < 1:
        raise ValueError(f"`x1` must have shape (..., d) with d >= 1; received shape {x1.shape}")
    x2 = as_float_array(x2, "x2", ndim_min=1)
    if x2.shape[-1] != d:
        raise ValueError(f"`x1` and `x2` must have the same dimension d (last axis); received "
                         f"shapes {x1.shape} and {x2.shape}")
    check_domain(x1, "x1")
    check_domain(x2, "x2")
    P1 = as_covariance(P1, "cov1", dim=d)                   # the PD rule and the variance domain
    P2 = as_covariance(P2, "cov2", dim=d)
    mats = {"x1": x1[..., None], "cov1": P1, "x2": x2[..., None], "cov2": P2}
    if P12 is not None:
        P12 = as_float_array(P12, "cov12", ndim_min=2, last_dims=(d, d))
        mats["cov12"] = P12
    try:
        lead = np.broadcast_shapes(*(m.shape[:-2] for m in mats.values()))
    except ValueError:
        names = ", ".join(f"`{k}`" for k in mats)
        shapes = ", ".join(str(np.shape(v)) for v in mats.values())
        raise ValueError(f"{names} must have broadcasting batch shapes; received {shapes}") from None
    check_size(int(np.prod(lead, dtype=object)) * d * d, MAX_BATCH,
               what="batch elements × state entries",
               alternative="several calls on slices of the batch")
    if P12 is not None:                          # checked once per distinct matrix
        cov_lead = np.broadcast_shapes(P1.shape[:-2], P2.shape[:-2], P12.shape[:-2])
        _joint_psd(*(np.broadcast_to(m, (*cov_lead, d, d)) for m in (P1, P2, P12)))
    out = [np.broadcast_to(m, (*lead, *m.shape[-2:])) for m in mats.values()]
    out[0], out[2] = out[0][..., 0], out[2][..., 0]
    return out


def _solve(a, b, name: str):
    """Batched solve of a x = b for matrix b (..., d, k); `name` is the public argument behind `a`."""
    # b as a full stack: NumPy 1 reads a b of one dimension fewer than `a` as vectors
    b = np.broadcast_to(b, (*np.broadcast_shapes(a.shape[:-2], b.shape[:-2]), *b.shape[-2:]))
    try:
        return np.linalg.solve(a, b)
    except np.linalg.LinAlgError:
        raise ValueError(f"`{name}`: a covariance is numerically singular; rescale the state "
                         "(for example km instead of m)") from None
