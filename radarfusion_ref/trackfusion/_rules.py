"""Track fusion: the fusion rules (naive, Bar-Shalom–Campo, covariance intersection) and the
track-to-track statistic."""

from __future__ import annotations

import numpy as np

from ..engine.linalg import is_positive_definite, mahalanobis_sq_kernel
from ..engine.validation import (
    as_choice,
    as_covariance,
    as_float_array,
    check_domain,
    check_size,
    describe,
    unwrap,
)
from ..fusion import fuse_gaussian
from ._common import (
    _OMEGA_STEPS,
    CRITERIA,
    MAX_BATCH,
    CovarianceIntersection,
    TrackEstimate,
    _pair_iv,
    _solve,
    _sym,
)


# --------------------------------------------------------------------------- fusion rules
def naive_fusion(x1, cov1, x2, cov2) -> TrackEstimate:
    r"""Fuse two tracks as if their errors were independent (ignoring :math:`P_{12}`).

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        The two track estimates :math:`\hat{\mathbf x}_1, \hat{\mathbf x}_2`.
    cov1, cov2 : array_like, shape (..., d, d)
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
    x1, cov1, x2, cov2 = _pair_iv(x1, cov1, x2, cov2)
    out = fuse_gaussian(np.stack([x1, x2], axis=-2), np.stack([cov1, cov2], axis=-3))
    return TrackEstimate(out.estimate, out.covariance)


def bar_shalom_campo(x1, cov1, x2, cov2, cov12) -> TrackEstimate:
    r"""Fuse two correlated tracks with the Bar-Shalom–Campo rule (known :math:`P_{12}`).

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        The two track estimates.
    cov1, cov2 : array_like, shape (..., d, d)
        Their covariances, symmetric positive definite.
    cov12 : array_like, shape (..., d, d)
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
    x1, cov1, x2, cov2, cov12 = _pair_iv(x1, cov1, x2, cov2, cov12)
    P21 = np.swapaxes(cov12, -1, -2)
    U = _sym(cov1 + cov2 - cov12 - P21)                       # Cov(x2 - x1)
    if not np.all(is_positive_definite(U)):
        raise ValueError(
            "`cov12`: cov1 + cov2 - cov12 - cov12ᵀ (the covariance of x2 - x1) is "
            "singular: the two tracks differ by a deterministic amount and "
            "carry the same information; use either track")
    # W = (P1 - P12) U^-1
    W = np.swapaxes(_solve(U, cov1 - P21, "cov12"), -1, -2)
    estimate = x1 + (W @ (x2 - x1)[..., None])[..., 0]  # x1 + W (x2 - x1)
    # P1 - (P1 - P12) U^-1 (P1 - P21)
    covariance = _sym(cov1 - W @ (cov1 - P21))
    return TrackEstimate(estimate, covariance)


def _blue_iv(x, cov):
    x = as_float_array(x, "x", ndim_min=2)
    n, d = x.shape[-2:]
    if n < 1 or d < 1:
        raise ValueError(f"`x` must have shape (..., n, d) with n, d >= 1 (n estimates of a "
                         f"d-vector); received shape {x.shape}")
    check_domain(x, "x")
    C = as_float_array(cov, "cov", ndim_min=2)
    if C.shape[-2:] != (n * d, n * d):
        raise ValueError(f"`cov` must have shape (..., {n * d}, {n * d}) for `x` of "
                         f"shape {x.shape} (n = {n} estimates of d = {d}); received shape "
                         f"{C.shape}")
    C = as_covariance(C, "cov", dim=n * d)      # the PD rule and the variance domain
    try:
        lead = np.broadcast_shapes(x.shape[:-2], C.shape[:-2])
    except ValueError:
        raise ValueError(f"`x`, `cov` must have broadcasting batch shapes; received "
                         f"{x.shape}, {C.shape}") from None
    check_size(int(np.prod(lead, dtype=object)) * (n * d) ** 2, MAX_BATCH,
               what="batch elements × joint covariance entries",
               alternative="several calls on slices of the batch")
    return (np.broadcast_to(x, (*lead, n, d)),
            np.broadcast_to(C, (*lead, n * d, n * d)))


def blue_fusion(x, cov) -> TrackEstimate:
    r"""Fuse `n` correlated estimates of one state: the best linear unbiased estimate.

    Parameters
    ----------
    x : array_like, shape (..., n, d)
        The estimates :math:`\hat{\mathbf x}_1, \dots, \hat{\mathbf x}_n` of one state.
    cov : array_like, shape (..., n d, n d)
        The joint covariance :math:`C` of the stacked errors
        :math:`[\mathbf e_1; \dots; \mathbf e_n]`: block :math:`(i, j)` is
        :math:`P_{ij} = E[\mathbf e_i\mathbf e_j^\mathsf T]` (:math:`P_{ii} = P_i`),
        symmetric positive definite.

    Returns
    -------
    TrackEstimate
        ``estimate`` (..., d) and ``cov`` (..., d, d).

    Raises
    ------
    ValueError
        If `cov` is not symmetric positive definite or not ``n d`` square, a
        variance or coordinate lies outside the numeric domain, the batch shapes do not
        broadcast or the batch is too large.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    Every estimate measures the same state, :math:`[\hat{\mathbf x}_1; \dots;
    \hat{\mathbf x}_n] = \mathsf H\mathbf x + \mathbf e` with
    :math:`\mathsf H = [I; \dots; I]` and :math:`\operatorname{Cov}\mathbf e = C`. The
    generalised least-squares (Aitken) estimate is the BLUE:

    .. math::

        \tilde P = (\mathsf H^\mathsf T C^{-1}\mathsf H)^{-1}, \qquad
        \tilde{\mathbf x} = \tilde P\,\mathsf H^\mathsf T C^{-1}
        [\hat{\mathbf x}_1; \dots; \hat{\mathbf x}_n],

    and :math:`\tilde P` is its true error covariance. For two tracks it is
    :func:`bar_shalom_campo`; with every :math:`P_{ij} = 0` (:math:`i \ne j`) it is
    :func:`naive_fusion`. Computed on the differences from :math:`\hat{\mathbf x}_1`
    (no cancellation far from the origin).

    References
    ----------
    A. C. Aitken, "On least squares and linear combination of observations",
    Proc. Royal Society of Edinburgh 55 (1935) 42–48; S.-L. Sun, Z.-L. Deng,
    "Multi-sensor optimal information fusion Kalman filter", Automatica 40(6) (2004)
    1017–1023 (the same weights for `n` correlated tracks).

    Examples
    --------
    >>> r = blue_fusion([[0.0], [2.0]], [[1.0, 0.5], [0.5, 1.0]])
    >>> r.estimate, r.covariance
    (array([1.]), array([[0.75]]))
    >>> C = np.eye(3) + 0.5 * (1 - np.eye(3))             # three equally correlated tracks
    >>> r = blue_fusion([[0.0], [3.0], [6.0]], C)
    >>> r.estimate, 3 * r.covariance          # (1 + (n - 1) 0.5) / n = 2/3
    (array([3.]), array([[2.]]))
    """
    x, C = _blue_iv(x, cov)
    n, d = x.shape[-2:]
    ref = x[..., 0, :]
    y = (x - ref[..., None, :]).reshape(*x.shape[:-2], n * d, 1)      # differences from x̂1
    H = np.broadcast_to(np.tile(np.eye(d), (n, 1)), (*x.shape[:-2], n * d, d))
    Z = _solve(C, np.concatenate([H, y], -1), "cov")          # C^-1 [H, y]
    M = Z[..., :d].reshape(*x.shape[:-2], n, d, d).sum(-3)            # Hᵀ C^-1 H
    b = Z[..., d].reshape(*x.shape[:-2], n, d).sum(-2)                # Hᵀ C^-1 y
    cov = _sym(_solve(M, np.eye(d), "cov"))
    estimate = ref + (cov @ b[..., None])[..., 0]
    return TrackEstimate(estimate, cov)


def _ci_slope(w, I1, I2, D, criterion):
    """d/dω of the criterion at ω (batched): −tr(J⁻¹D) for log det, −tr(J⁻¹DJ⁻¹) for trace."""
    J = w[..., None, None] * I1 + (1 - w[..., None, None]) * I2
    JD = np.linalg.solve(J, D)
    if criterion == "det":
        return -np.trace(JD, axis1=-2, axis2=-1)
    return -np.trace(np.linalg.solve(J, np.swapaxes(JD, -1, -2)), axis1=-2, axis2=-1)


def ci_weight(cov1, cov2, *, criterion="det"):
    r"""The covariance-intersection weight :math:`\omega \in [0, 1]` minimising det or trace of :math:`\tilde P`.

    Parameters
    ----------
    cov1, cov2 : array_like, shape (..., d, d)
        The two tracks' covariances, symmetric positive definite.
    criterion : {"det", "trace"}, optional
        What ω minimises: :math:`\det\tilde P` (default) or :math:`\operatorname{tr}\tilde P`,
        with :math:`\tilde P^{-1} = \omega P_1^{-1} + (1 - \omega) P_2^{-1}`.

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
    I1, I2 = _ci_informations(cov1, cov2)                           # P1^-1, P2^-1
    D = I1 - I2
    lo, hi = np.zeros(I1.shape[:-2]), np.ones(I1.shape[:-2])
    at0 = _ci_slope(lo, I1, I2, D, criterion) >= 0  # increasing from ω = 0
    at1 = _ci_slope(hi, I1, I2, D, criterion) <= 0  # decreasing up to ω = 1
    for _ in range(_OMEGA_STEPS):
        mid = 0.5 * (lo + hi)
        # still descending: go right
        up = _ci_slope(mid, I1, I2, D, criterion) < 0
        lo, hi = np.where(up, mid, lo), np.where(up, hi, mid)
    return unwrap(np.where(at0, 0.0, np.where(at1, 1.0, 0.5 * (lo + hi))))


def _ci_informations(P1, P2):
    """Validated, broadcast ``P1^-1, P2^-1``."""
    P1 = as_covariance(P1, "cov1")                # the PD rule and the variance domain
    P2 = as_covariance(P2, "cov2", dim=P1.shape[-1])
    try:
        lead = np.broadcast_shapes(P1.shape[:-2], P2.shape[:-2])
    except ValueError:
        raise ValueError(f"`cov1`, `cov2` must have broadcasting batch shapes; received "
                         f"{P1.shape}, {P2.shape}") from None
    eye = np.eye(P1.shape[-1])
    P1, P2 = (np.broadcast_to(P, (*lead, *P.shape[-2:])) for P in (P1, P2))
    return _sym(_solve(P1, eye, "cov1")), _sym(_solve(P2, eye, "cov2"))


def covariance_intersection(x1, cov1, x2, cov2, *, criterion="det",
                            omega=None) -> CovarianceIntersection:
    r"""Fuse two tracks whose cross-covariance is unknown: covariance intersection.

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        The two track estimates.
    cov1, cov2 : array_like, shape (..., d, d)
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
    x1, cov1, x2, cov2 = _pair_iv(x1, cov1, x2, cov2)
    eye = np.eye(x1.shape[-1])
    I1, I2 = _sym(_solve(cov1, eye, "cov1")), _sym(_solve(cov2, eye, "cov2"))   # P1^-1, P2^-1
    if omega is None:
        w = np.asarray(ci_weight(cov1, cov2, criterion=criterion), dtype=float)
    else:
        w = as_float_array(omega, "omega")
        if np.any((w < 0) | (w > 1)):
            raise ValueError(f"`omega` must lie in the closed interval [0, 1]; received "
                             f"{describe(omega)}")
        try:
            w = np.broadcast_to(w, x1.shape[:-1]).astype(float)
        except ValueError:
            raise ValueError(f"`omega` must broadcast to the batch shape {x1.shape[:-1]}; "
                             f"received shape {np.shape(omega)}") from None
        criterion = "given"
    ww = w[..., None, None]
    J = _sym(ww * I1 + (1 - ww) * I2)                           # P~^-1
    y = ww[..., 0] * (I1 @ x1[..., None])[..., 0] + (1 - ww[..., 0]) * (I2 @ x2[..., None])[..., 0]
    covariance = _sym(_solve(J, eye, "cov1`, `cov2"))
    estimate = (covariance @ y[..., None])[..., 0]
    return CovarianceIntersection(estimate, covariance, w[()] if w.ndim == 0 else w, criterion)


def track_statistic(x1, cov1, x2, cov2, cov12=None):
    r"""Track-to-track association statistic :math:`\kappa`, with the cross-covariance.

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        Two tracks (to be tested for being of one object).
    cov1, cov2 : array_like, shape (..., d, d)
        Their covariances.
    cov12 : array_like, shape (..., d, d), optional
        Their cross-covariance under the hypothesis "one object"; ``None`` means 0
        (the statistic that ignores the common process noise).

    Returns
    -------
    float or numpy.ndarray, shape (...)
        :math:`\kappa`, distributed :math:`\chi^2_d` under the hypothesis when `cov12`
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
    if cov12 is None:
        x1, cov1, x2, cov2 = _pair_iv(x1, cov1, x2, cov2)
        S = _sym(cov1 + cov2)
    else:
        x1, cov1, x2, cov2, cov12 = _pair_iv(x1, cov1, x2, cov2, cov12)
        S = _sym(cov1 + cov2 - cov12 - np.swapaxes(cov12, -1, -2))
    if not np.all(is_positive_definite(S)):
        raise ValueError("`cov12`: cov1 + cov2 - cov12 - cov12ᵀ (the covariance of x1 - x2) is singular; "
                         "the statistic is undefined")
    check_domain(x1, "x1")
    check_domain(x2, "x2")
    return mahalanobis_sq_kernel(x1 - x2, S, "`x1`, `x2`")
