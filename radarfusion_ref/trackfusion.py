r"""Track-to-track fusion: the cross-covariance of two tracks and three fusion rules.

Two radars track one object with Kalman filters. Each track carries a state
estimate :math:`\hat{\mathbf x}_i` (position and velocity) and a covariance
:math:`P_i`. Both filters follow the same object, whose motion is driven by
one process noise :math:`\mathbf w`; the two track errors therefore share it and
are **correlated**, with cross-covariance :math:`P_{12} = E[\mathbf e_1\mathbf e_2^\mathsf T]`
even though the radars' measurement errors are independent.

.. rubric:: Functions

* :func:`cross_covariance` — the recursion of :math:`P_1, P_2, P_{12}` of two Kalman
  filters of one object, or its steady state;
* :func:`constant_velocity` — the constant-velocity motion model :math:`(F, Q)`;
* :func:`naive_fusion` — fusion that ignores :math:`P_{12}` (the ML fusion of
  independent reports, :func:`radarfusion_ref.fusion.fuse_gaussian`);
* :func:`bar_shalom_campo` — the best linear fusion with a known :math:`P_{12}`;
* :func:`covariance_intersection` — fusion that is consistent for *every*
  :math:`P_{12}`, with the weight :math:`\omega` minimising the determinant or the trace;
* :func:`track_statistic` — the track-to-track association statistic
  :math:`\kappa = \Delta^\mathsf T(P_1 + P_2 - P_{12} - P_{21})^{-1}\Delta`;
* :func:`predict` — a track predicted to a later instant (time alignment);
* :func:`simulate_tracks` — Monte-Carlo runs of the two filters on one simulated object.

Notation (the book's): :math:`F` the transition matrix, :math:`Q` the process-noise
covariance, :math:`H_i` radar *i*'s measurement matrix, :math:`\Sigma_i` its
measurement error covariance (argument ``R1``/``R2``), :math:`K_i` the Kalman gain,
:math:`P_{21} = P_{12}^\mathsf T`, :math:`\tilde{\mathbf x}`, :math:`\tilde P` a fused track.

.. rubric:: References

.. [1] Y. Bar-Shalom, "On the track-to-track correlation problem", IEEE Trans.
   Automatic Control 26(2) (1981) 571–572 (the cross-covariance recursion).
.. [2] Y. Bar-Shalom, L. Campo, "The effect of the common process noise on the
   two-sensor fused-track covariance", IEEE Trans. AES 22(6) (1986) 803–805.
.. [3] S. J. Julier, J. K. Uhlmann, "A non-divergent estimation algorithm in the
   presence of unknown correlations", Proc. American Control Conference (1997)
   2369–2373 (covariance intersection).
.. [4] Y. Bar-Shalom, X.-R. Li, T. Kirubarajan, *Estimation with Applications to
   Tracking and Navigation*, Wiley, 2001, sec. 6.3.2 (the constant-velocity model),
   6.5 (α–β filter) and 11.2.3 (track-to-track association).
.. [5] P. R. Kalata, "The tracking index: a generalized parameter for α–β and
   α–β–γ target trackers", IEEE Trans. AES 20(2) (1984) 174–182.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg

from .engine._validation import (
    MEMORY_LIMIT,
    _describe,
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_rng,
    check_size,
    unwrap,
)
from .engine.linalg import _check_domain, _kappa, is_positive_definite
from .fusion import fuse_gaussian

__all__ = [
    "CRITERIA",
    "MAX_DIM",
    "CovarianceIntersection",
    "MotionModel",
    "TrackCovariances",
    "TrackEstimate",
    "TrackRuns",
    "bar_shalom_campo",
    "constant_velocity",
    "ci_weight",
    "covariance_intersection",
    "cross_covariance",
    "naive_fusion",
    "predict",
    "simulate_tracks",
    "track_statistic",
]

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
        raise ValueError(f"`{name}` must be symmetric; received {_describe(arr)}")
    low = np.linalg.eigvalsh(_sym(arr))[..., 0]
    if np.any(low < -PSD_RTOL * scale[..., 0, 0]):
        raise ValueError(f"`{name}` must be positive semi-definite; smallest eigenvalue "
                         f"{float(np.min(low)):.6g}")
    return arr


def _joint_psd(P1, P2, P12, names=("P1", "P2", "P12")):
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
    x2 = as_float_array(x2, "x2", ndim_min=1, last_dims=(d,))
    P1 = as_covariance(P1, "P1", dim=d)
    P2 = as_covariance(P2, "P2", dim=d)
    mats = {"x1": x1[..., None], "P1": P1, "x2": x2[..., None], "P2": P2}
    if P12 is not None:
        P12 = as_float_array(P12, "P12", ndim_min=2, last_dims=(d, d))
        mats["P12"] = P12
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


def _solve(a, b):
    """Batched solve of a x = b for matrix b (..., d, k)."""
    try:
        return np.linalg.solve(a, b)
    except np.linalg.LinAlgError:
        raise ValueError("a covariance is numerically singular; rescale the state "
                         "(for example km instead of m)") from None


# --------------------------------------------------------------------------- fusion rules
def naive_fusion(x1, P1, x2, P2) -> TrackEstimate:
    r"""Fuse two tracks as if their errors were independent (ignoring :math:`P_{12}`).

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        The two track estimates :math:`\hat{\mathbf x}_1, \hat{\mathbf x}_2`.
    P1, P2 : array_like, shape (..., d, d)
        Their covariances, symmetric positive definite.

    Returns
    -------
    TrackEstimate
        ``estimate`` (..., d) and ``covariance`` (..., d, d).

    Raises
    ------
    ValueError
        If a covariance is not symmetric positive definite, the shapes disagree or an
        entry is not finite.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    The ML fusion of independent reports (the book's eq-fused-estimate in
    information form, :func:`radarfusion_ref.fusion.fuse_gaussian`):

    .. math::

        \tilde P = (P_1^{-1} + P_2^{-1})^{-1}, \qquad
        \tilde{\mathbf x} = \tilde P(P_1^{-1}\hat{\mathbf x}_1 + P_2^{-1}\hat{\mathbf x}_2).

    With correlated tracks (:math:`P_{12} \ne 0`) the covariance it reports is too
    small: the rule is over-confident.

    References
    ----------
    Bar-Shalom & Campo (1986), the "independent" fusion they compare with.

    Examples
    --------
    >>> r = naive_fusion([0.0, 0.0], np.eye(2), [2.0, 0.0], np.eye(2))
    >>> r.estimate, np.diag(r.covariance)
    (array([1., 0.]), array([0.5, 0.5]))
    """
    x1, P1, x2, P2 = _pair_iv(x1, P1, x2, P2)
    out = fuse_gaussian(np.stack([x1, x2], axis=-2), np.stack([P1, P2], axis=-3))
    return TrackEstimate(out.estimate, out.covariance)


def bar_shalom_campo(x1, P1, x2, P2, P12) -> TrackEstimate:
    r"""Fuse two correlated tracks with the Bar-Shalom–Campo rule (known :math:`P_{12}`).

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        The two track estimates.
    P1, P2 : array_like, shape (..., d, d)
        Their covariances, symmetric positive definite.
    P12 : array_like, shape (..., d, d)
        The cross-covariance :math:`P_{12} = E[\mathbf e_1\mathbf e_2^\mathsf T]` (for
        example from :func:`cross_covariance`); :math:`P_{21} = P_{12}^\mathsf T`.

    Returns
    -------
    TrackEstimate
        ``estimate`` (..., d) and ``covariance`` (..., d, d).

    Raises
    ------
    ValueError
        If the joint covariance :math:`[[P_1, P_{12}], [P_{21}, P_2]]` is not positive
        semi-definite, if :math:`U = P_1 + P_2 - P_{12} - P_{21}` is singular (the tracks'
        difference is deterministic: they carry the same information), or for the
        reasons of :func:`naive_fusion`.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    The best (minimum-variance) estimate of the form
    :math:`\hat{\mathbf x}_1 + W(\hat{\mathbf x}_2 - \hat{\mathbf x}_1)`:

    .. math::

        U = P_1 + P_2 - P_{12} - P_{21}, \qquad W = (P_1 - P_{12})U^{-1},

        \tilde{\mathbf x} = \hat{\mathbf x}_1 + W(\hat{\mathbf x}_2 - \hat{\mathbf x}_1), \qquad
        \tilde P = P_1 - (P_1 - P_{12})U^{-1}(P_1 - P_{21}).

    It equals the best linear unbiased estimate (BLUE) from the stacked pair
    :math:`[\hat{\mathbf x}_1; \hat{\mathbf x}_2]` with the joint covariance, and
    :math:`\tilde P` is its true error covariance. With :math:`P_{12} = 0` it is
    :func:`naive_fusion`.

    References
    ----------
    Bar-Shalom & Campo (1986), eqs. (9)–(10); Bar-Shalom, Li & Kirubarajan (2001),
    sec. 11.2.

    Examples
    --------
    >>> r = bar_shalom_campo([0.0], [[1.0]], [2.0], [[1.0]], [[0.5]])
    >>> r.estimate, r.covariance
    (array([1.]), array([[0.75]]))
    """
    x1, P1, x2, P2, P12 = _pair_iv(x1, P1, x2, P2, P12)
    P21 = np.swapaxes(P12, -1, -2)
    U = _sym(P1 + P2 - P12 - P21)                               # Cov(x2 - x1)
    if not np.all(is_positive_definite(U)):
        raise ValueError("`P12`: P1 + P2 - P12 - P12ᵀ (the covariance of x2 - x1) is singular: "
                         "the two tracks differ by a deterministic amount and carry the same "
                         "information; use either track")
    W = np.swapaxes(_solve(U, P1 - P21), -1, -2)                # W = (P1 - P12) U^-1
    estimate = x1 + (W @ (x2 - x1)[..., None])[..., 0]         # x1 + W (x2 - x1)
    covariance = _sym(P1 - W @ (P1 - P21))                      # P1 - (P1 - P12) U^-1 (P1 - P21)
    return TrackEstimate(estimate, covariance)


def _ci_slope(w, I1, I2, D, criterion):
    """d/dω of the criterion at ω (batched): −tr(J⁻¹D) for log det, −tr(J⁻¹DJ⁻¹) for trace."""
    J = w[..., None, None] * I1 + (1 - w[..., None, None]) * I2
    JD = np.linalg.solve(J, D)
    if criterion == "det":
        return -np.trace(JD, axis1=-2, axis2=-1)
    return -np.trace(np.linalg.solve(J, np.swapaxes(JD, -1, -2)), axis1=-2, axis2=-1)


def ci_weight(P1, P2, *, criterion="det"):
    r"""The covariance-intersection weight :math:`\omega \in [0, 1]` minimising det or trace of :math:`	ilde P`.

    Parameters
    ----------
    P1, P2 : array_like, shape (..., d, d)
        The two tracks' covariances, symmetric positive definite.
    criterion : {"det", "trace"}, optional
        What ω minimises: :math:`\det	ilde P` (default) or :math:`\operatorname{tr}	ilde P`,
        with :math:`	ilde P^{-1} = \omega P_1^{-1} + (1 - \omega) P_2^{-1}`.

    Returns
    -------
    float or numpy.ndarray, shape (...)

    Raises
    ------
    ValueError, TypeError
        For covariances that are not symmetric positive definite, shapes that do
        not broadcast, or an unknown `criterion`.

    Notes
    -----
    Both criteria are convex in ω (:math:`-\log\det J` and :math:`\operatorname{tr} J^{-1}`
    of a matrix :math:`J` affine in ω), so the minimiser is 0 if the slope at 0 is
    :math:`\ge 0`, 1 if the slope at 1 is :math:`\le 0`, and otherwise the unique
    root of the slope; 60 bisection steps reach it to double precision.

    Examples
    --------
    >>> ci_weight(np.diag([1.0, 4.0]), np.diag([4.0, 1.0]))
    0.5
    """
    criterion = as_choice(criterion, "criterion", CRITERIA)
    I1, I2 = _ci_informations(P1, P2)                           # P1^-1, P2^-1
    D = I1 - I2
    lo, hi = np.zeros(I1.shape[:-2]), np.ones(I1.shape[:-2])
    at0 = _ci_slope(lo, I1, I2, D, criterion) >= 0             # increasing from ω = 0
    at1 = _ci_slope(hi, I1, I2, D, criterion) <= 0             # decreasing up to ω = 1
    for _ in range(_OMEGA_STEPS):
        mid = 0.5 * (lo + hi)
        up = _ci_slope(mid, I1, I2, D, criterion) < 0           # still descending: go right
        lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
    return unwrap(np.where(at0, 0.0, np.where(at1, 1.0, 0.5 * (lo + hi))))


def _ci_informations(P1, P2):
    """Validated, broadcast ``P1^-1, P2^-1``."""
    P1 = as_covariance(P1, "P1")
    P2 = as_covariance(P2, "P2", dim=P1.shape[-1])
    try:
        lead = np.broadcast_shapes(P1.shape[:-2], P2.shape[:-2])
    except ValueError:
        raise ValueError(f"`P1`, `P2` must have broadcasting batch shapes; received "
                         f"{P1.shape}, {P2.shape}") from None
    eye = np.eye(P1.shape[-1])
    P1, P2 = (np.broadcast_to(P, (*lead, *P.shape[-2:])) for P in (P1, P2))
    return _sym(_solve(P1, eye)), _sym(_solve(P2, eye))


def covariance_intersection(x1, P1, x2, P2, *, criterion="det",
                            omega=None) -> CovarianceIntersection:
    r"""Fuse two tracks whose cross-covariance is unknown: covariance intersection.

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        The two track estimates.
    P1, P2 : array_like, shape (..., d, d)
        Their covariances, symmetric positive definite.
    criterion : {"det", "trace"}, optional
        What ω minimises: the determinant (default) or the trace of :math:`\tilde P`.
        Ignored when `omega` is given.
    omega : float or array_like, optional
        A given weight in [0, 1] (broadcast over the batch) instead of the optimum.

    Returns
    -------
    CovarianceIntersection
        ``estimate``, ``covariance``, ``omega`` and ``criterion``.

    Raises
    ------
    ValueError
        If `omega` lies outside [0, 1], `criterion` is not one of :data:`CRITERIA`, or
        for the reasons of :func:`naive_fusion`.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    .. math::

        \tilde P^{-1} = \omega P_1^{-1} + (1 - \omega)P_2^{-1}, \qquad
        \tilde P^{-1}\tilde{\mathbf x} = \omega P_1^{-1}\hat{\mathbf x}_1
        + (1-\omega)P_2^{-1}\hat{\mathbf x}_2 .

    For every ω in [0, 1] and **every** cross-covariance for which the joint
    covariance is positive semi-definite, :math:`\tilde P` is at least the true
    error covariance of :math:`\tilde{\mathbf x}` (consistency without knowing
    :math:`P_{12}`). ω is found by bisection on the derivative of the convex
    criterion (:math:`-\log\det\tilde P^{-1}` or :math:`\operatorname{tr}\tilde P`).
    When several ω give the same criterion (e.g. :math:`P_1 = P_2`), any of them
    may be returned; the covariance is then the same.

    References
    ----------
    Julier & Uhlmann (1997), eqs. (5)–(6) and the choice of ω by det or trace.

    Examples
    --------
    >>> r = covariance_intersection([0.0, 0.0], np.diag([1.0, 4.0]),
    ...                             [1.0, 1.0], np.diag([4.0, 1.0]))
    >>> round(float(r.omega), 6), np.diag(r.covariance).round(6)
    (0.5, array([1.6, 1.6]))
    """
    criterion = as_choice(criterion, "criterion", CRITERIA)
    x1, P1, x2, P2 = _pair_iv(x1, P1, x2, P2)
    eye = np.eye(x1.shape[-1])
    I1, I2 = _sym(_solve(P1, eye)), _sym(_solve(P2, eye))      # P1^-1, P2^-1
    if omega is None:
        w = np.asarray(ci_weight(P1, P2, criterion=criterion), dtype=float)
    else:
        w = as_float_array(omega, "omega")
        if np.any((w < 0) | (w > 1)):
            raise ValueError(f"`omega` must lie in the closed interval [0, 1]; received "
                             f"{_describe(omega)}")
        try:
            w = np.broadcast_to(w, x1.shape[:-1]).astype(float)
        except ValueError:
            raise ValueError(f"`omega` must broadcast to the batch shape {x1.shape[:-1]}; "
                             f"received shape {np.shape(omega)}") from None
        criterion = "given"
    ww = w[..., None, None]
    J = _sym(ww * I1 + (1 - ww) * I2)                           # P~^-1
    y = ww[..., 0] * (I1 @ x1[..., None])[..., 0] + (1 - ww[..., 0]) * (I2 @ x2[..., None])[..., 0]
    covariance = _sym(_solve(J, eye))
    estimate = (covariance @ y[..., None])[..., 0]
    return CovarianceIntersection(estimate, covariance, w[()] if w.ndim == 0 else w, criterion)


def track_statistic(x1, P1, x2, P2, P12=None):
    r"""Track-to-track association statistic :math:`\kappa`, with the cross-covariance.

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        Two tracks (to be tested for being of one object).
    P1, P2 : array_like, shape (..., d, d)
        Their covariances.
    P12 : array_like, shape (..., d, d), optional
        Their cross-covariance under the hypothesis "one object"; ``None`` means 0
        (the statistic that ignores the common process noise).

    Returns
    -------
    float or numpy.ndarray, shape (...)
        :math:`\kappa`, distributed :math:`\chi^2_d` under the hypothesis when `P12`
        is right.

    Raises
    ------
    ValueError
        If the joint covariance is not positive semi-definite or
        :math:`P_1 + P_2 - P_{12} - P_{21}` is singular, or for the reasons of
        :func:`naive_fusion`.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    Under "one object" :math:`\Delta = \hat{\mathbf x}_1 - \hat{\mathbf x}_2 = \mathbf e_1 - \mathbf e_2`
    has covariance :math:`S = P_1 + P_2 - P_{12} - P_{21}`, and

    .. math::

        \kappa = \Delta^\mathsf T S^{-1}\Delta \sim \chi^2_d .

    Computed by the kernel of :func:`radarfusion_ref.engine.linalg.mahalanobis_sq`
    (inside its numeric domain: coordinates up to :math:`2^{150}`).

    References
    ----------
    Bar-Shalom (1981); Bar-Shalom, Li & Kirubarajan (2001), sec. 11.2.3.

    Examples
    --------
    >>> float(track_statistic([1.0], [[1.0]], [0.0], [[1.0]]))
    0.5
    >>> float(track_statistic([1.0], [[1.0]], [0.0], [[1.0]], [[0.5]]))
    1.0
    """
    if P12 is None:
        x1, P1, x2, P2 = _pair_iv(x1, P1, x2, P2)
        S = _sym(P1 + P2)
    else:
        x1, P1, x2, P2, P12 = _pair_iv(x1, P1, x2, P2, P12)
        S = _sym(P1 + P2 - P12 - np.swapaxes(P12, -1, -2))
    if not np.all(is_positive_definite(S)):
        raise ValueError("`P12`: P1 + P2 - P12 - P12ᵀ (the covariance of x1 - x2) is singular; "
                         "the statistic is undefined")
    _check_domain(x1, "x1")
    _check_domain(x2, "x2")
    return _kappa(x1 - x2, S, "`x1`, `x2`")


# --------------------------------------------------------------------------- motion model
def constant_velocity(dt, q, *, dim=1, noise="continuous") -> MotionModel:
    r"""The constant-velocity model over an interval `dt`, state ``[positions, velocities]``.

    Parameters
    ----------
    dt : float or array_like
        Time interval(s) :math:`\Delta t \ge 0`.
    q : float or array_like
        Process-noise intensity :math:`q \ge 0`: the power spectral density of the
        white acceleration (``"continuous"``, units length²/time³) or the variance of
        the acceleration held constant over each interval (``"discrete"``, length²/time⁴).
    dim : int, optional
        Number of spatial coordinates (1, 2 or 3). The state is
        :math:`(p_1, \dots, p_{\text{dim}}, v_1, \dots, v_{\text{dim}})`.
    noise : {"continuous", "discrete"}, optional
        Continuous white-noise acceleration (default) or piecewise-constant
        (discrete white-noise) acceleration.

    Returns
    -------
    MotionModel
        ``F`` and ``Q``, shape ``(..., 2 dim, 2 dim)`` broadcast over `dt` and `q`.

    Raises
    ------
    ValueError
        If `dt` or `q` is negative or not finite, `dim` not in 1..3 or `noise` unknown.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    Per coordinate, with :math:`\Delta t` the interval,

    .. math::

        F = \begin{pmatrix}1 & \Delta t\\ 0 & 1\end{pmatrix}, \qquad
        Q_{\text{cont}} = q\begin{pmatrix}\Delta t^3/3 & \Delta t^2/2\\ \Delta t^2/2 & \Delta t\end{pmatrix}, \qquad
        Q_{\text{disc}} = q\begin{pmatrix}\Delta t^4/4 & \Delta t^3/2\\ \Delta t^3/2 & \Delta t^2\end{pmatrix}.

    The continuous model composes exactly: predicting over :math:`\Delta t_1` then
    :math:`\Delta t_2` equals predicting over :math:`\Delta t_1 + \Delta t_2`.

    References
    ----------
    Bar-Shalom, Li & Kirubarajan (2001), eqs. (6.2.3-8) and (6.3.2-4).

    Examples
    --------
    >>> m = constant_velocity(2.0, 3.0)
    >>> m.F
    array([[1., 2.],
           [0., 1.]])
    >>> m.Q
    array([[8., 6.],
           [6., 6.]])
    """
    dt = as_positive(dt, "dt", strict=False)
    q = as_positive(q, "q", strict=False)
    dim = as_int(dim, "dim", minimum=1, maximum=3)
    noise = as_choice(noise, "noise", ("continuous", "discrete"))
    try:
        dt, q = np.broadcast_arrays(dt, q)
    except ValueError:
        raise ValueError(f"`dt`, `q` must broadcast to a common shape; received shapes "
                         f"{np.shape(dt)}, {np.shape(q)}") from None
    check_size(dt.size * 4 * dim * dim, MAX_BATCH, what="model entries",
               alternative="several calls on slices of `dt`")
    if noise == "continuous":
        qpp, qpv, qvv = q * dt**3 / 3, q * dt**2 / 2, q * dt
    else:
        qpp, qpv, qvv = q * dt**4 / 4, q * dt**3 / 2, q * dt**2
    if not all(np.all(np.isfinite(v)) for v in (qpp, qpv, qvv)):
        raise ValueError("`dt`, `q`: the process-noise covariance overflows float64; use a "
                         "smaller time unit")
    eye = np.eye(dim)

    def blocks(a, b, c):
        top = np.concatenate([a[..., None, None] * eye, b[..., None, None] * eye], axis=-1)
        bottom = np.concatenate([b[..., None, None] * eye, c[..., None, None] * eye], axis=-1)
        return np.concatenate([top, bottom], axis=-2)

    one, zero = np.ones_like(dt), np.zeros_like(dt)
    F = np.concatenate([np.concatenate([one[..., None, None] * eye, dt[..., None, None] * eye], -1),
                        np.concatenate([zero[..., None, None] * eye, one[..., None, None] * eye], -1)],
                       axis=-2)
    return MotionModel(F, blocks(qpp, qpv, qvv))


def predict(x, P, dt, q, *, noise="continuous") -> TrackEstimate:
    r"""Predict constant-velocity tracks forward by `dt` (time alignment).

    Parameters
    ----------
    x : array_like, shape (..., 2 dim)
        Track states ``[positions, velocities]`` (dim = 1, 2 or 3).
    P : array_like, shape (..., 2 dim, 2 dim)
        Their covariances, symmetric positive definite.
    dt : float or array_like, shape (...)
        Time to predict forward, :math:`\delta \ge 0`.
    q : float or array_like
        Process-noise intensity (see :func:`constant_velocity`).
    noise : {"continuous", "discrete"}, optional
        The process-noise model (see :func:`constant_velocity`).

    Returns
    -------
    TrackEstimate
        :math:`F(\delta)\hat{\mathbf x}` and :math:`F(\delta)PF(\delta)^\mathsf T + Q(\delta)`.

    Raises
    ------
    ValueError
        If the state dimension is not 2, 4 or 6, `P` is not symmetric positive
        definite, `dt` or `q` is negative, or the shapes do not broadcast.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    .. math::

        \hat{\mathbf x}(t+\delta) = F(\delta)\hat{\mathbf x}(t), \qquad
        P(t+\delta) = F(\delta)P(t)F(\delta)^\mathsf T + Q(\delta).

    The added :math:`Q(\delta)` is the uncertainty of the motion between the two
    instants; without it a predicted track would be over-confident.

    References
    ----------
    Bar-Shalom, Li & Kirubarajan (2001), sec. 5.2.3 (prediction).

    Examples
    --------
    >>> r = predict([0.0, 1.0], np.eye(2), 2.0, 0.0)
    >>> r.estimate, r.covariance
    (array([2., 1.]), array([[5., 2.],
           [2., 1.]]))
    """
    x = as_float_array(x, "x", ndim_min=1)
    n = x.shape[-1]
    if n not in (2, 4, 6):
        raise ValueError(f"`x` must hold [positions, velocities] of 1, 2 or 3 coordinates "
                         f"(last axis 2, 4 or 6); received shape {x.shape}")
    P = as_covariance(P, "P", dim=n)
    model = constant_velocity(dt, q, dim=n // 2, noise=noise)
    try:
        lead = np.broadcast_shapes(x.shape[:-1], P.shape[:-2], model.F.shape[:-2])
    except ValueError:
        raise ValueError(f"`x`, `P`, `dt`, `q` must have broadcasting batch shapes; received "
                         f"{x.shape}, {P.shape}, {np.shape(dt)}, {np.shape(q)}") from None
    check_size(int(np.prod(lead, dtype=object)) * n * n, MAX_BATCH,
               what="batch elements × state entries", alternative="several calls on slices")
    F = model.F
    estimate = (F @ x[..., None])[..., 0]                             # F x
    covariance = _sym(F @ P @ np.swapaxes(F, -1, -2) + model.Q)      # F P Fᵀ + Q
    if not (np.all(np.isfinite(estimate)) and np.all(np.isfinite(covariance))):
        raise ValueError("`dt`: the predicted track overflows float64")
    return TrackEstimate(np.broadcast_to(estimate, (*lead, n)).copy(),
                         np.broadcast_to(covariance, (*lead, n, n)).copy())


# --------------------------------------------------------------------------- cross-covariance
def _model_iv(F, Q, H1, R1, H2, R2):
    F = as_float_array(F, "F", ndim_min=2)
    d = F.shape[-1]
    if F.shape[-2] != d or d < 1:
        raise ValueError(f"`F` must have shape (..., d, d); received shape {F.shape}")
    if d > MAX_DIM:
        raise ValueError(f"`F`: state dimension {d} above the limit MAX_DIM = {MAX_DIM}")
    Q = _as_psd(Q, "Q", dim=d)
    out = {"F": F, "Q": Q}
    for hn, rn, H, R in (("H1", "R1", H1, R1), ("H2", "R2", H2, R2)):
        H = as_float_array(H, hn, ndim_min=2, last_dims=(None, d))
        if H.shape[-2] < 1:
            raise ValueError(f"`{hn}` must have shape (..., p, {d}) with p >= 1; received "
                             f"shape {H.shape}")
        out[hn] = H
        out[rn] = as_covariance(R, rn, dim=H.shape[-2])
    try:
        lead = np.broadcast_shapes(*(v.shape[:-2] for v in out.values()))
    except ValueError:
        shapes = ", ".join(str(v.shape) for v in out.values())
        raise ValueError("`F`, `Q`, `H1`, `R1`, `H2`, `R2` must have broadcasting batch "
                         f"shapes; received {shapes}") from None
    return lead, d, {k: np.broadcast_to(v, (*lead, *v.shape[-2:])) for k, v in out.items()}


def _update(M, H, R):
    """Kalman update of a predicted covariance M: gain K and Joseph-form covariance."""
    S = _sym(H @ M @ np.swapaxes(H, -1, -2) + R)                       # H M Hᵀ + Σ
    K = np.swapaxes(_solve(S, H @ M), -1, -2)                          # M Hᵀ S^-1
    A = np.eye(M.shape[-1]) - K @ H                                    # I - K H
    P = _sym(A @ M @ np.swapaxes(A, -1, -2) + K @ R @ np.swapaxes(K, -1, -2))
    return K, A, P


def _steady(F, Q, H, R, name):
    """Steady-state predicted covariance by the discrete algebraic Riccati equation."""
    flat = [a.reshape(-1, *a.shape[-2:]) for a in (F, Q, H, R)]
    out = np.empty(flat[0].shape)
    for i, (f, q, h, r) in enumerate(zip(*flat, strict=True)):
        try:
            m = linalg.solve_discrete_are(f.T, h.T, q, r)
        except (np.linalg.LinAlgError, ValueError):
            m = np.full(f.shape, np.nan)
        if not np.all(np.isfinite(m)):
            raise ValueError(f"`{name}`: the Riccati equation of this filter has no stabilising "
                             "solution (the model is not detectable/stabilisable, e.g. Q = 0); "
                             "no steady state exists — pass `steps` for the recursion")
        out[i] = m
    return _sym(out.reshape(F.shape))


def cross_covariance(F, Q, H1, R1, H2, R2, *, steps=None, P1_0=None, P2_0=None,
                     P12_0=None) -> TrackCovariances:
    r"""Covariances and cross-covariance of two Kalman filters tracking one object.

    Parameters
    ----------
    F, Q : array_like, shape (..., d, d)
        The motion model :math:`\mathbf x_k = F\mathbf x_{k-1} + \mathbf w_k`,
        :math:`\mathbf w_k \sim \mathcal N(0, Q)` (``Q`` positive semi-definite), shared by
        the object and both filters.
    H1, R1, H2, R2 : array_like, shapes (..., p_i, d) and (..., p_i, p_i)
        Radar *i* measures :math:`\mathbf z_i = H_i\mathbf x + \mathbf v_i`,
        :math:`\mathbf v_i \sim \mathcal N(0, \Sigma_i)` (``R_i`` = :math:`\Sigma_i`,
        positive definite), independent of the other radar and of :math:`\mathbf w`.
    steps : int, optional
        ``None`` (default): the steady state. An integer :math:`k \ge 1`: the first
        :math:`k` steps of the recursion from the initial covariances.
    P1_0, P2_0 : array_like, shape (..., d, d)
        Initial (updated) covariances of the two tracks; required with `steps`.
    P12_0 : array_like, shape (..., d, d), optional
        Initial cross-covariance (default 0: independently initialised tracks). The
        joint covariance ``[[P1_0, P12_0], [P12_0ᵀ, P2_0]]`` must be PSD.

    Returns
    -------
    TrackCovariances
        ``P1``, ``P2``, ``P12``, ``K1``, ``K2``.

    Raises
    ------
    ValueError
        If a matrix has the wrong shape, ``Q`` is not PSD or an ``R`` not positive
        definite, `steps` is given without ``P1_0``/``P2_0``, the initial joint
        covariance is not PSD, no steady state exists, or the batch is too large.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    Track *i*'s error :math:`\mathbf e_i = \hat{\mathbf x}_i - \mathbf x` obeys
    :math:`\mathbf e_i(k) = A_i(F\mathbf e_i(k-1) - \mathbf w_k) + K_i\mathbf v_i(k)` with
    :math:`A_i = I - K_iH_i`. The common :math:`\mathbf w_k` gives

    .. math::

        P_{12}(k) = A_1\,\big(F P_{12}(k-1) F^\mathsf T + Q\big)\,A_2^\mathsf T,

    beside each track's own :math:`P_i(k) = A_i(FP_i(k-1)F^\mathsf T + Q)A_i^\mathsf T +
    K_i\Sigma_iK_i^\mathsf T`. The steady state takes the Riccati solution of each
    filter (:func:`scipy.linalg.solve_discrete_are`) and solves the linear equation
    :math:`P_{12} = A_1(FP_{12}F^\mathsf T + Q)A_2^\mathsf T` for :math:`P_{12}` by
    vectorisation, :math:`(I - (A_2F)\otimes(A_1F))\operatorname{vec}P_{12} =
    \operatorname{vec}(A_1QA_2^\mathsf T)`.

    References
    ----------
    Bar-Shalom (1981), eq. (4); Bar-Shalom & Campo (1986), eq. (5).

    Examples
    --------
    >>> m = constant_velocity(1.0, 1.0, noise="discrete")
    >>> H = [[1.0, 0.0]]
    >>> c = cross_covariance(m.F, m.Q, H, [[1.0]], H, [[1.0]])
    >>> c.P1.round(4)
    array([[0.75, 0.5 ],
           [0.5 , 1.  ]])
    >>> round(float(c.correlation[0]), 4)
    0.1111
    """
    lead, d, m = _model_iv(F, Q, H1, R1, H2, R2)
    F, Q = m["F"], m["Q"]
    Ft = np.swapaxes(F, -1, -2)
    if steps is None:
        for name in ("P1_0", "P2_0", "P12_0"):
            if locals()[name] is not None:
                raise ValueError(f"`{name}` is only used with `steps` (the steady state does "
                                 "not depend on the initial covariances)")
        check_size(int(np.prod(lead, dtype=object)) * d**4, MAX_BATCH,
                   what="entries of the steady-state systems (batch × d⁴)",
                   alternative="several calls on slices of the batch")
        K1, A1, P1 = _update(_steady(F, Q, m["H1"], m["R1"], "R1"), m["H1"], m["R1"])
        K2, A2, P2 = _update(_steady(F, Q, m["H2"], m["R2"], "R2"), m["H2"], m["R2"])
        B1, B2 = A1 @ F, A2 @ F
        # vec(B1 X B2ᵀ) = (B1 ⊗ B2) vec(X) for row-major vec
        kron = np.einsum("...ij,...kl->...ikjl", B1, B2).reshape(*lead, d * d, d * d)
        rhs = (A1 @ Q @ np.swapaxes(A2, -1, -2)).reshape(*lead, d * d, 1)
        try:
            P12 = np.linalg.solve(np.eye(d * d) - kron, rhs).reshape(*lead, d, d)
        except np.linalg.LinAlgError:
            raise ValueError("`F`: the cross-covariance recursion has no unique steady state "
                             "(a closed-loop filter is not stable)") from None
        return TrackCovariances(P1, P2, P12, K1, K2)
    steps = as_int(steps, "steps", minimum=1)
    if P1_0 is None or P2_0 is None:
        raise ValueError("`P1_0` and `P2_0` (the initial covariances) are required with `steps`")
    check_size(int(np.prod(lead, dtype=object)) * steps * d * (3 * d + 2 * 3), MAX_BATCH,
               what="stored entries (batch × `steps` × state)",
               alternative="fewer `steps` or several calls on slices of the batch")
    P1 = np.broadcast_to(as_covariance(P1_0, "P1_0", dim=d), (*lead, d, d))
    P2 = np.broadcast_to(as_covariance(P2_0, "P2_0", dim=d), (*lead, d, d))
    if P12_0 is None:
        P12 = np.zeros((*lead, d, d))
    else:
        P12 = np.broadcast_to(as_float_array(P12_0, "P12_0", ndim_min=2, last_dims=(d, d)),
                              (*lead, d, d))
        _joint_psd(P1, P2, P12, names=("P1_0", "P2_0", "P12_0"))
    hist = {k: [] for k in ("P1", "P2", "P12", "K1", "K2")}
    for _ in range(steps):
        K1, A1, P1 = _update(F @ P1 @ Ft + Q, m["H1"], m["R1"])
        K2, A2, P2 = _update(F @ P2 @ Ft + Q, m["H2"], m["R2"])
        P12 = A1 @ (F @ P12 @ Ft + Q) @ np.swapaxes(A2, -1, -2)    # common process noise only
        for k, v in zip(hist, (P1, P2, P12, K1, K2), strict=True):
            hist[k].append(v)
    out = {k: np.stack(v, axis=-3) for k, v in hist.items()}
    if not all(np.all(np.isfinite(v)) for v in out.values()):
        raise ValueError("`F`: the covariances overflow float64 within `steps` steps")
    return TrackCovariances(**out)


def simulate_tracks(F, Q, H1, R1, H2, R2, *, steps, trials, P1_0, P2_0, x0=None,
                    rng=None) -> TrackRuns:
    r"""Monte-Carlo runs of two Kalman filters tracking one simulated object.

    Parameters
    ----------
    F, Q, H1, R1, H2, R2 : array_like
        One model, as in :func:`cross_covariance` (no batch axes).
    steps : int
        Number of measurement updates per run.
    trials : int
        Number of independent runs.
    P1_0, P2_0 : array_like, shape (d, d)
        Covariances of the two filters' initial errors, drawn independently
        (so :math:`P_{12}(0) = 0`).
    x0 : array_like, shape (d,), optional
        The object's initial state (default 0; the errors do not depend on it).
    rng : None, int, SeedSequence or numpy.random.Generator, optional
        Source of randomness (SPEC 7).

    Returns
    -------
    TrackRuns

    Raises
    ------
    ValueError
        For the reasons of :func:`cross_covariance`, if a model argument has batch
        axes, or the run is too large.
    TypeError
        If an argument is not numeric or `rng` is not a valid generator.

    Notes
    -----
    Per step: :math:`\mathbf x_k = F\mathbf x_{k-1} + \mathbf w_k`; each radar measures
    :math:`\mathbf z_i = H_i\mathbf x_k + \mathbf v_i`; each filter predicts and updates
    with its gain :math:`K_i(k)` from :func:`cross_covariance`.

    Examples
    --------
    >>> m = constant_velocity(1.0, 1.0)
    >>> runs = simulate_tracks(m.F, m.Q, [[1.0, 0.0]], [[1.0]], [[1.0, 0.0]], [[1.0]],
    ...                        steps=5, trials=3, P1_0=np.eye(2), P2_0=np.eye(2), rng=1)
    >>> runs.error1.shape
    (3, 5, 2)
    """
    trials = as_int(trials, "trials", minimum=1)
    steps = as_int(steps, "steps", minimum=1)
    lead, d, m = _model_iv(F, Q, H1, R1, H2, R2)
    if lead:
        raise ValueError(f"`F`, `Q`, `H1`, `R1`, `H2`, `R2` must be single matrices (no batch "
                         f"axes) in simulate_tracks; received batch shape {lead}")
    check_size(trials * steps * d * 3, MAX_BATCH, what="simulated entries "
               "(`trials` × `steps` × state × 3)", alternative="fewer `trials` per call, pooling "
               "calls seeded from SeedSequence.spawn")
    cov = cross_covariance(F, Q, H1, R1, H2, R2, steps=steps, P1_0=P1_0, P2_0=P2_0)
    x = np.zeros(d) if x0 is None else as_float_array(x0, "x0", last_dims=(d,))
    if x.shape != (d,):
        raise ValueError(f"`x0` must have shape ({d},); received shape {x.shape}")
    g = as_rng(rng)
    F, Q = m["F"], m["Q"]
    lam, vec = np.linalg.eigh(Q)                            # Q = V diag(l) Vᵀ (may be singular)
    q_root = vec * np.sqrt(np.clip(lam, 0, None))
    roots = {k: np.linalg.cholesky(m[k]) for k in ("R1", "R2")}
    P10, P20 = as_covariance(P1_0, "P1_0", dim=d), as_covariance(P2_0, "P2_0", dim=d)
    truth = np.broadcast_to(x, (trials, d)).copy()
    est1 = truth + g.standard_normal((trials, d)) @ np.linalg.cholesky(P10).T
    est2 = truth + g.standard_normal((trials, d)) @ np.linalg.cholesky(P20).T
    out = np.empty((3, trials, steps, d))
    for k in range(steps):
        truth = truth @ F.T + g.standard_normal((trials, d)) @ q_root.T
        for i, (est, H, R, K) in enumerate(((est1, m["H1"], "R1", cov.K1[k]),
                                            (est2, m["H2"], "R2", cov.K2[k]))):
            z = truth @ H.T + g.standard_normal((trials, H.shape[0])) @ roots[R].T
            pred = est @ F.T                                # F x̂(k-1)
            new = pred + (z - pred @ H.T) @ K.T             # + K (z - H F x̂(k-1))
            est1, est2 = (new, est2) if i == 0 else (est1, new)
        out[0, :, k], out[1, :, k], out[2, :, k] = truth, est1, est2
    return TrackRuns(out[0], out[1], out[2], cov)
