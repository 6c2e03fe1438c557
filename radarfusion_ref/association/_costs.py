"""Pair costs: the proximity matrix and the non-assignment cost of the likelihood ratio."""

from __future__ import annotations

import math
import warnings

import numpy as np

from ..engine.errors import RadarFusionWarning
from ..engine.linalg import mahalanobis_sq_pairwise
from ..engine.validation import (
    MAX_MAGNITUDE,
    MEMORY_LIMIT,
    as_bool,
    as_covariance,
    as_float_array,
    as_positive,
    as_probability,
    broadcast,
    check_size,
    describe,
)


# --------------------------------------------------------------------------- non-assignment cost
def _non_assignment_iv(p_detect1, p_detect2, false_density1, false_density2, object_density,
                       innovation_cov, with_logdet):
    """Validated, broadcast arguments of :func:`non_assignment_cost`, ``ln det(2 pi S)`` last."""
    if innovation_cov is None and not with_logdet:
        raise TypeError("`innovation_cov` is required with `logdet=False` (the covariance S of "
                        "the difference of two reports of one object); received None")
    p1 = as_probability(p_detect1, "p_detect1", open_interval=False)
    p2 = as_probability(p_detect2, "p_detect2", open_interval=False)
    for name, p, raw in (("p_detect1", p1, p_detect1), ("p_detect2", p2, p_detect2)):
        if np.any(p <= 0):
            raise ValueError(f"`{name}` must lie in (0, 1]; received {describe(raw)}")
    lam1 = as_positive(false_density1, "false_density1", strict=False)
    lam2 = as_positive(false_density2, "false_density2", strict=False)
    beta = as_positive(object_density, "object_density")
    s = as_float_array(0.0 if innovation_cov is None else innovation_cov, "innovation_cov")
    if innovation_cov is None:
        logdet = s
    elif s.ndim < 2:
        s = as_positive(s, "innovation_cov")
        logdet = np.log(2 * np.pi) + np.log(s)                 # no overflow of 2 pi S
    else:
        s = as_covariance(s, "innovation_cov", domain=False)
        d = s.shape[-1]
        # ln det S = 2 sum ln sd_i + ln det R with the correlation matrix R: no overflow or
        # underflow whatever the variances' scales (1e-300 beside 1e300 included).
        sd = np.sqrt(np.diagonal(s, axis1=-2, axis2=-1))
        corr = s / sd[..., :, None] / sd[..., None, :]
        chol = np.linalg.cholesky(corr)
        logdet = d * np.log(2 * np.pi) + 2 * np.sum(np.log(sd), axis=-1) + 2 * np.sum(
            np.log(np.diagonal(chol, axis1=-2, axis2=-1)), axis=-1)
    return broadcast(p_detect1=p1, p_detect2=p2, false_density1=lam1, false_density2=lam2,
                     object_density=beta, innovation_cov=logdet)


def non_assignment_cost(*, p_detect1, p_detect2, false_density1, false_density2,
                        object_density, innovation_cov=None, logdet: bool = False):
    r"""Per-report non-assignment cost (in proximity units) from the likelihood ratio.

    Parameters
    ----------
    p_detect1, p_detect2 : float or array_like
        Detection probabilities :math:`P_{D,1}, P_{D,2}` of the two radars, in (0, 1].
    false_density1, false_density2 : float or array_like
        False-report densities :math:`\rho_{F,1}, \rho_{F,2}` (expected false
        reports per unit volume of the measurement space), ≥ 0.
    object_density : float or array_like
        Density :math:`\rho_T > 0` of objects (per unit volume).
    innovation_cov : float or array_like, shape (..., d, d) or scalar
        :math:`S = \Sigma_1 + \Sigma_2`, the covariance of the difference of
        two reports of one object (a scalar is a 1-D variance). Symmetric
        positive definite; variances from 1e-300 to 1e300 are handled.
        Required with ``logdet=False``; optional with ``logdet=True`` (then
        only validated and broadcast: the pair costs carry the determinant).
    logdet : bool, optional
        False (default): the cost for a matrix of proximity measures
        :math:`\kappa_{ij}` (``proximity_matrix(...)``), which holds
        :math:`-\tfrac12\ln\det(2\pi S)` for the one `innovation_cov`. True:
        the cost for a matrix of full ML costs :math:`\kappa_{ij} +
        \ln\det(2\pi S_{ij})` (``proximity_matrix(..., logdet=True)``), right when
        :math:`S_{ij}` differs from pair to pair.

    Returns
    -------
    float or numpy.ndarray
        The cost :math:`c_0` to pass as ``miss_cost`` to the joint association
        (:func:`~radarfusion_ref.engine.assignment.assign_two_lists`) with a cost matrix of
        proximity measures :math:`\kappa_{ij}`; ``+inf``
        when no report can be left unassigned (both radars detect everything
        and report nothing false). Array arguments broadcast together.

    Raises
    ------
    ValueError
        For probabilities outside (0, 1], negative densities, a non-positive
        object density, an invalid covariance or shapes that do not broadcast.
    TypeError
        For bools, strings or None where numbers are expected.

    Warns
    -----
    RadarFusionWarning
        If :math:`c_0 \le 0`: no pair with :math:`\kappa \ge 0` can beat
        leaving both reports unassigned. (``logdet=False`` only: the full
        costs of ``logdet=True`` may be negative).

    Notes
    -----
    Objects form a Poisson field of density :math:`\rho_T`; radar :math:`r`
    detects each with probability :math:`P_{D,r}` and adds false reports of
    density :math:`\rho_{F,r}`. Integrating the unknown position out, a pair
    :math:`(i, j)` contributes :math:`\rho_T P_{D,1} P_{D,2}\, \mathcal N(\hat x_{1i} -
    \hat x_{2j}; 0, S)` to the likelihood of a hypothesis and an unpaired
    report :math:`u_r = \rho_{F,r} + \rho_T P_{D,r} (1 - P_{D,\bar r})` (a false
    report, or an object the other radar missed). Pairing beats leaving both
    reports unpaired iff

    .. math::

        \kappa_{ij} < 2\ln\frac{\rho_T P_{D,1} P_{D,2}}{u_1 u_2} - \ln\det(2\pi S)
        = 2c_0,

    and, with ``logdet=True``, :math:`c_0 = \ln(\rho_T P_{D,1} P_{D,2}/(u_1 u_2))`
    against the costs :math:`\kappa_{ij} + \ln\det(2\pi S_{ij})`,

    and with cost :math:`c_0` per unassigned report the assignment cost
    :math:`\sum \kappa + c_0\,(\#\text{unassigned})` is, up to a constant,
    :math:`-2\ln` of the hypothesis likelihood (the book's eq.
    ``eq-non-assignment-cost``). Everything is computed in the log domain
    (:func:`numpy.logaddexp` for :math:`\ln u_r`, :math:`\ln\det S` through
    the correlation matrix), so no density or variance in the float range
    overflows or underflows.

    References
    ----------
    Grachov & Korneev (2010) list false reports and missed detections among
    the real-world uncertainties (problem statement) and then assume them
    away; the cost follows Deb et al. (1997) and Bar-Shalom et al. (2011).

    Examples
    --------
    >>> m = non_assignment_cost(p_detect1=0.9, p_detect2=0.9, false_density1=0.1,
    ...                         false_density2=0.1, object_density=1.0, innovation_cov=0.02)
    >>> round(float(m), 4)
    4.1478
    >>> m_full = non_assignment_cost(p_detect1=0.9, p_detect2=0.9, false_density1=0.1,
    ...                              false_density2=0.1, object_density=1.0, logdet=True)
    >>> round(float(m_full - m), 4)          # = ln(2 pi 0.02) / 2
    -1.0371
    """
    with_logdet = as_bool(logdet, "logdet")
    p1, p2, lam1, lam2, beta, ln_det_2pi_s = _non_assignment_iv(
        p_detect1, p_detect2, false_density1, false_density2,
        object_density, innovation_cov, with_logdet)
    # Log domain throughout: ln u_r = ln(rho_F,r + rho_T P_r (1 - P_other))
    # by logaddexp, so neither tiny nor huge densities overflow or
    # underflow.
    with np.errstate(divide="ignore"):
        lb = np.log(beta)
        log_u1 = np.logaddexp(np.log(lam1), lb + np.log(p1) + np.log1p(-p2))
        log_u2 = np.logaddexp(np.log(lam2), lb + np.log(p2) + np.log1p(-p1))
    m = lb + np.log(p1) + np.log(p2) - log_u1 - log_u2
    # with logdet=True a given `innovation_cov` only shapes the result
    # (0 * its log det)
    m = m + (0.0 if with_logdet else -0.5) * ln_det_2pi_s
    # (full costs kappa + ln det 2 pi S may be negative, so c_0 <= 0 is no
    # alarm there)
    if not with_logdet and np.any(m <= 0):
        warnings.warn(
            "non-assignment cost <= 0: no pair with proximity >= 0 beats leaving both "
            "reports unassigned (false-report density too high for this accuracy)",
            RadarFusionWarning, stacklevel=2)
    return float(m) if np.ndim(m) == 0 else m


def proximity_matrix(reports1, reports2, sigma1, sigma2, *, logdet: bool = False) -> np.ndarray:
    r"""All pairwise proximity measures :math:`\kappa_{ij}` (or full ML costs) of two report lists.

    A thin wrapper around :func:`radarfusion_ref.engine.linalg.mahalanobis_sq_pairwise`
    (every (radar-1, radar-2) pair).

    Parameters
    ----------
    reports1, reports2 : array_like, shape (..., n1, d) and (..., n2, d)
    sigma1, sigma2 : float or array_like, shape (..., n1) and (..., n2)
        Per-coordinate error standard deviations: one number per radar, or one
        per report (each report's covariance is :math:`\sigma^2 I`); arrays
        broadcast against the reports' leading axes.
    logdet : bool, optional
        False (default): the proximity measure :math:`\kappa_{ij}` alone.
        True: the full maximum-likelihood cost
        :math:`c_{ij} = \kappa_{ij} + \ln\det(2\pi S_{ij})`, :math:`-2\ln` of the
        likelihood :math:`\mathcal N(\hat x_{1i} - \hat x_{2j}; 0, S_{ij})` of the pair
        with the object's position integrated out, :math:`S_{ij} = (\sigma_{1i}^2 +
        \sigma_{2j}^2) I`. Pass it with ``non_assignment_cost(..., logdet=True)``.

    Returns
    -------
    numpy.ndarray, shape (..., n1, n2)
        :math:`\kappa_{ij} = \lVert \hat x_{1i} - \hat x_{2j}\rVert^2 /
        (\sigma_{1i}^2 + \sigma_{2j}^2)` — the exponent of eq. (7) (times −2) — plus
        :math:`d\ln(2\pi(\sigma_{1i}^2 + \sigma_{2j}^2))` with ``logdet=True``.

    Raises
    ------
    ValueError
        For reports of different dimensions or unbroadcastable batch axes, sigmas
        that are not > 0 or do not broadcast against the reports, and sizes
        beyond the memory limit; reports beyond 2**150 in magnitude, or a sigma
        whose square leaves [2**-150, 2**150] (the numeric domain of
        :mod:`radarfusion_ref.engine.linalg`).
    TypeError
        For non-numeric input or a `logdet` that is not a bool.

    Notes
    -----
    With one variance per radar the log-determinant is the same for every
    pair: it cannot change which complete pairing is best, only how a pair
    compares with leaving its reports unassigned. With one variance per report
    it is not a sum of a row term and a column term, and it can change the
    joint decision (the book's page on the full ML cost). It is computed in the log
    domain, :math:`\ln(\sigma_1^2 + \sigma_2^2)` by :func:`numpy.logaddexp`, so
    no variance in the float range overflows.

    Examples
    --------
    >>> proximity_matrix([[0.0], [1.0]], [[0.5]], 0.3, 0.4)
    array([[1.],
           [1.]])
    >>> proximity_matrix([[0.0]], [[0.5]], 0.3, 0.4, logdet=True).round(4)   # 1 + ln(2 pi 0.25)
    array([[1.4516]])
    """
    r1 = as_float_array(reports1, "reports1", ndim_min=2)
    r2 = as_float_array(reports2, "reports2", ndim_min=2)
    with_logdet = as_bool(logdet, "logdet")
    if r1.shape[-1] != r2.shape[-1]:
        raise ValueError("`reports1` and `reports2` must have the same last dimension d; "
                         f"received shapes {r1.shape} and {r2.shape}")
    sd1 = as_positive(sigma1, "sigma1")
    sd2 = as_positive(sigma2, "sigma2")
    for name, a in (("reports1", r1), ("reports2", r2)):
        if a.size and not float(np.max(np.abs(a))) <= MAX_MAGNITUDE:
            raise ValueError(f"`{name}` must lie within the numeric domain |value| <= 2**150 "
                             f"(about 1.4e45); received {describe(a)} (largest magnitude "
                             f"{float(np.max(np.abs(a))):.6g}); change the unit of the "
                             "coordinates")
    for name, sd in (("sigma1", sd1), ("sigma2", sd2)):
        if sd.size and not (sd.min() >= MAX_MAGNITUDE ** -0.5 and sd.max() <= MAX_MAGNITUDE ** 0.5):
            raise ValueError(f"`{name}` squared (the report variances) must lie within the "
                             "numeric domain [2**-150, 2**150] (about 7e-46 to 1.4e45); "
                             f"received {describe(sd)}; change the unit of the coordinates")
    shapes = []
    for name, sd, r in (("sigma1", sd1, r1), ("sigma2", sd2, r2)):
        try:
            shapes.append(np.broadcast_shapes(sd.shape, r.shape[:-1]))
        except ValueError:
            raise ValueError(f"`{name}` must be one number or one per report, broadcasting "
                             f"against the reports' shape without d {r.shape[:-1]}; received "
                             f"shape {sd.shape}") from None
        if shapes[-1][-1] != r.shape[-2]:
            raise ValueError(f"`{name}` must be one number or one per report (last axis "
                             f"{r.shape[-2]}); received shape {sd.shape}")
    try:
        batch = np.broadcast_shapes(shapes[0][:-1], shapes[1][:-1])
    except ValueError:
        raise ValueError("`reports1` and `reports2` (with `sigma1`, `sigma2`) must have "
                         f"broadcastable leading (batch) axes; received shapes {r1.shape}, "
                         f"{r2.shape}, {sd1.shape} and {sd2.shape}") from None
    n1, n2, d = r1.shape[-2], r2.shape[-2], r1.shape[-1]
    per_report = sd1.ndim > 0 or sd2.ndim > 0
    per_pair = d + d * d if per_report else d
    check_size(math.prod(batch) * n1 * n2 * per_pair * 8 * 4, MEMORY_LIMIT, name="reports1",
               what=f"bytes of pair differences ({math.prod(batch)} x {n1} x {n2} pairs, d = {d})",
               alternative="fewer trials per call (split the batch)")
    eye = np.eye(d)
    if not per_report:
        v1, v2 = float(sd1) ** 2, float(sd2) ** 2
        out = mahalanobis_sq_pairwise(r1, r2, v1 * eye, v2 * eye)
    else:
        v1 = np.square(np.atleast_1d(sd1))
        v2 = np.square(np.atleast_1d(sd2))
        if not (np.all(np.isfinite(v1)) and np.all(v1 > 0)
                and np.all(np.isfinite(v2)) and np.all(v2 > 0)):
            raise ValueError(
                "`sigma1` and `sigma2` must have squares within the float "
                "range (1e-154 < sigma < 1e154); received "
                f"{describe(sd1)} and {describe(sd2)}")
        c1 = v1[..., :, None, None] * eye               # (..., n1, d, d)
        c2 = v2[..., :, None, None] * eye               # (..., n2, d, d)
        out = mahalanobis_sq_pairwise(r1, r2, c1, c2)
    out = np.asarray(out, dtype=float)
    if with_logdet:
        # ln det(2 pi S) = d (ln 2 pi + ln(s1^2 + s2^2)),
        # ln(s1^2 + s2^2) by logaddexp
        l1 = 2 * np.log(np.atleast_1d(sd1))[..., :, None]
        l2 = 2 * np.log(np.atleast_1d(sd2))[..., None, :]
        out = out + d * (math.log(2 * math.pi) + np.logaddexp(l1, l2))
    return out


