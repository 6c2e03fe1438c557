r"""Polar to Cartesian in 2-D: gains, covariances and the exact moments given the truth.

The linearized, debiased (additive), unbiased (multiplicative), first-order,
measurement-conditioned and decorrelated conversions.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..engine.errors import RadarFusionWarning
from ..engine.geometry import as_sigma_beta
from ..engine.validation import (
    MEMORY_LIMIT,
    as_choice,
    as_float_array,
    as_positive,
    broadcast,
    check_size,
    describe,
)

#: The conversion methods accepted by :func:`polar_to_cartesian`.
METHODS = ("linearized", "additive", "multiplicative", "first_order", "first_order_printed")

#: Every 2-D method: :data:`METHODS` (the paper's and the classic ones, unchanged) and the
#: current ones, Duan et al.'s measurement-conditioned conversion and Bordonaro et al.'s
#: decorrelated one (which needs a prior position, ``prior_xy``).
ALL_METHODS = (*METHODS, "measurement_conditioned", "decorrelated")

#: The 3-D methods accepted by :func:`spherical_to_cartesian` (range, azimuth, elevation).
METHODS_3D = ("linearized", "additive", "multiplicative", "measurement_conditioned")

#: Largest number of batch elements (broadcast inputs × trials) one call works on at once:
#: about 256 bytes of working memory each, so one call stays within
#: :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT` (1 GiB).
MAX_BATCH = MEMORY_LIMIT // 256

#: Lerro & Bar-Shalom's rule of thumb (as usually quoted): the linearized
#: conversion is adequate while :math:`r\sigma_\beta^2/\sigma_r` stays below this value.
LERRO_THRESHOLD = 0.4

#: Smallest r/σr accepted by :func:`draw_polar` (a negative simulated range
#: then has probability below 1e-15).
MIN_RANGE_OVER_SIGMA = 8.0



@dataclass(frozen=True)
class ConvertedMeasurement:
    r"""A converted report: Cartesian position and its covariance.

    Attributes
    ----------
    xy : numpy.ndarray, shape (..., 2)
        Converted position :math:`(\hat x, \hat y)` in the radar's frame
        (x axis at azimuth 0, azimuth counter-clockwise).
    cov : numpy.ndarray, shape (..., 2, 2)
        The covariance the method attaches to `xy` (symmetric, positive
        semi-definite; positive definite unless a warning said otherwise).
    method : str
        The method that produced it, one of :data:`METHODS`.
    """

    xy: np.ndarray
    cov: np.ndarray
    method: str


@dataclass(frozen=True)
class ConversionMoments:
    r"""Exact moments of a converted report given the TRUE range and azimuth.

    Attributes
    ----------
    mean : numpy.ndarray, shape (..., 2)
        :math:`E[\hat{\mathbf x} \mid r, \beta]`.
    bias : numpy.ndarray, shape (..., 2)
        ``mean - r (cos β, sin β)``.
    cov : numpy.ndarray, shape (..., 2, 2)
        :math:`\operatorname{Cov}[\hat{\mathbf x} \mid r, \beta]`.
    mse : numpy.ndarray, shape (..., 2, 2)
        Mean squared error matrix ``cov + bias biasᵀ`` about the true position.
    method : str
        One of :data:`METHODS`.
    """

    mean: np.ndarray
    bias: np.ndarray
    cov: np.ndarray
    mse: np.ndarray
    method: str


# --------------------------------------------------------------------------- validation
def _polar_iv(r, beta, sigma_r, sigma_beta, *, strict: bool = False, trials: int = 1):
    """Validate and broadcast the four polar arguments (shared by the public functions).

    ``strict=True`` requires ``sigma_r > 0`` and ``sigma_beta > 0`` (for functions that
    need a positive-definite covariance); `trials` multiplies the batch size checked
    against :data:`MAX_BATCH` before anything is allocated."""
    r = as_positive(r, "r", strict=False)
    beta = as_float_array(beta, "beta")
    sigma_r = as_positive(sigma_r, "sigma_r", strict=strict)
    sigma_beta = as_sigma_beta(sigma_beta, strict=strict)
    _check_batch(trials, r=r, beta=beta, sigma_r=sigma_r, sigma_beta=sigma_beta)
    return broadcast(r=r, beta=beta, sigma_r=sigma_r, sigma_beta=sigma_beta)


def _check_batch(trials: int, **arrays) -> int:
    """Refuse, before allocating, a broadcast batch (× trials) above :data:`MAX_BATCH`."""
    try:
        shape = np.broadcast_shapes(*(np.shape(v) for v in arrays.values()))
    except ValueError:
        broadcast(**arrays)          # raises the package's message naming the arguments
        raise
    size = int(np.prod(shape, dtype=object)) * int(trials)
    check_size(size, MAX_BATCH, what="batch elements (broadcast inputs × `trials`)",
               alternative="several calls on slices of the batch (or fewer trials per call, "
                           "pooling calls seeded from SeedSequence.spawn)")
    return size


# --------------------------------------------------------------------------- building blocks
def conversion_gain(sigma_beta, *, method: str = "linearized"):
    r"""Gain :math:`g` of a conversion: its position is :math:`g\,\hat r\,u(\hat\beta)`.

    Parameters
    ----------
    sigma_beta : array_like
        Azimuth error standard deviation in radians, from 0 up to
        :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX`.
    method : str
        One of :data:`ALL_METHODS` (keyword-only).

    Returns
    -------
    numpy.ndarray
        With :math:`t = \sigma_\beta^2/2` (so :math:`E\cos\tilde\beta = e^{-t}`):
        1 (linearized), :math:`1 - e^{-t}(e^{-t} - 1)` (additive), :math:`e^{t}`
        (multiplicative, decorrelated), :math:`1 + t` (first order), :math:`1 - t`
        (first order as printed), :math:`e^{-t}` (measurement-conditioned).

    Raises
    ------
    ValueError
        `sigma_beta` negative or above that limit, or an unknown `method`.

    Examples
    --------
    >>> round(float(conversion_gain(0.1, method="multiplicative")), 6)
    1.005013
    """
    t = as_sigma_beta(sigma_beta) ** 2 / 2          # E cos w = e^{-t}
    method = as_choice(method, "method", ALL_METHODS)
    if method == "linearized":        # eq. (1): no correction
        return np.ones_like(t)
    if method == "additive":
        # r̂u − r̂u(e^{−s} − e^{−t}) = r̂u (1 + e^{−t}(1 − e^{−t}))
        return 1.0 - np.exp(-t) * np.expm1(-t)
    if method in ("multiplicative", "decorrelated"):
        # e^{t} r̂u: exactly unbiased
        return np.exp(t)
    if method == "first_order":       # eq. (3) with the derived sign
        return 1.0 + t
    if method == "measurement_conditioned":
        # Duan et al.: E[x | r̂, β̂] = e^{−t} r̂u
        return np.exp(-t)
    # "first_order_printed": eq. (3) as printed
    return 1.0 - t


def _bias_factor(method: str, s: np.ndarray) -> np.ndarray:
    """g e^{−s/2} − 1, the bias given the truth in units of the range, free of cancellation."""
    t = s / 2
    if method == "linearized":
        return np.expm1(-t)
    if method in ("multiplicative", "decorrelated"):
        return np.zeros_like(s)
    if method == "measurement_conditioned":   # e^{−s} − 1
        return np.expm1(-s)
    if method == "additive":          # (e^{−t} − 1)(1 − e^{−s})
        return -np.expm1(-t) * np.expm1(-s)
    if method == "first_order_printed":
        return np.expm1(-t) - t * np.exp(-t)
    # first_order: (1 + t) e^{−t} − 1 = Σ_{k≥2} (−1)^{k+1} (k − 1) t^k / k!  (a series for small t)
    small = t < 1e-2
    ts = np.where(small, t, 0.0)
    series = sum((-1) ** (k + 1) * (k - 1) * ts**k / math.factorial(k) for k in range(2, 11))
    return np.where(small, series, (1 + t) * np.exp(-t) - 1)


#: The methods whose covariance is evaluated at the measurement (all but ``"decorrelated"``).
_MEASURED_METHODS = (*METHODS, "measurement_conditioned")
#: Largest `r` and `sigma_r` whose square :func:`principal_variances` forms directly.
_SQUARE_MAX = 1e150


def principal_variances(r, sigma_r, sigma_beta, *,
                        method: str = "linearized"):
    r"""Variances of a method's covariance along the line of sight and across it.

    Every covariance of :func:`polar_to_cartesian` (but the decorrelated one) is
    :math:`R(\hat\beta)\,\mathrm{diag}(\text{along}, \text{cross})\,R(\hat\beta)^\mathsf T`;
    these are its two principal variances, evaluated at the measurement and written
    with ``expm1`` so that no difference of nearly equal numbers loses the small
    cross-range variance.

    Parameters
    ----------
    r : array_like
        Measured range :math:`\hat r \ge 0`, at most 1e150 (:func:`polar_to_cartesian`
        scales larger ones by powers of two).
    sigma_r, sigma_beta : array_like
        Range and azimuth error standard deviations, :math:`\ge 0`: at most 1e150
        and at most :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX` (radians).
    method : str
        One of :data:`ALL_METHODS` but ``"decorrelated"`` (keyword-only).

    Returns
    -------
    along, cross : numpy.ndarray
        The variances along :math:`u(\hat\beta)` and across it.

    Raises
    ------
    ValueError
        A negative or too large `r` or `sigma_r`, a bad `sigma_beta`, or an unknown
        `method`.

    Examples
    --------
    >>> along, cross = principal_variances(150.0, 0.1, 0.01)
    >>> float(along), round(float(cross), 6)
    (0.010000000000000002, 2.25)
    """
    r, sr2, s, method = _variances_iv(r, sigma_r, sigma_beta, method)
    em = -np.expm1(-s)                                 # 1 − e^{−s}
    if method == "linearized":
        # eq. (2a–c): J diag(σr², σβ²) Jᵀ
        return sr2, r**2 * s
    if method == "measurement_conditioned":
        # Duan et al.: Cov[x | r̂, β̂]
        return (0.5 * r**2 * em**2 + 0.5 * sr2 * (1 + np.exp(-2 * s)),
                -0.5 * (r**2 + sr2) * np.expm1(-2 * s))
    if method == "multiplicative":
        # Mo et al.: MSE given the measurement;
        # big = e^{s} − 3/2 + e^{−2s}/2
        big = np.where(s < 1e-4, 1.5 * s**2 - 0.5 * s**3 + 0.375 * s**4,
                       np.expm1(s) + 0.5 * np.expm1(-2 * s))
        along = r**2 * big + 0.5 * sr2 * (1 + np.exp(-2 * s))
        return along, -0.5 * (r**2 + sr2) * np.expm1(-2 * s)
    # additive / first_order / first_order_printed: eq. (4a–c),
    # Lerro & Bar-Shalom's R^a
    along = (-0.5 * r**2 * em * np.expm1(-3 * s)
             + sr2 * (1 - 0.5 * np.exp(-s) + np.exp(-4 * s)
                      - 0.5 * np.exp(-3 * s)))
    cross = (0.5 * r**2 * em * (1 + np.exp(-3 * s))
             + sr2 * (-np.expm1(-4 * s)
                      + 0.5 * np.exp(-s) * np.expm1(-2 * s)))
    return along, cross




def _variances_iv(r, sigma_r, sigma_beta, method):
    method = as_choice(method, "method", _MEASURED_METHODS)
    r = as_positive(r, "r", strict=False)
    sigma_r = as_positive(sigma_r, "sigma_r", strict=False)
    for name, v in (("r", r), ("sigma_r", sigma_r)):
        if np.any(v > _SQUARE_MAX):
            raise ValueError(f"`{name}` must be at most 1e150 here (its square must stay finite); "
                             f"received largest entry {float(np.max(v)):.6g}; "
                             "polar_to_cartesian scales larger values")
    return r, sigma_r**2, as_sigma_beta(sigma_beta) ** 2, method


def _truth_variances(method, r, sr2, sigma_beta):
    """Principal variances of Cov[x̂ | r, β] (given the TRUE position)."""
    s = sigma_beta**2
    g2 = conversion_gain(sigma_beta, method=method) ** 2
    em = -np.expm1(-s)
    along = g2 * (0.5 * r**2 * em**2 + 0.5 * sr2 * (1 + np.exp(-2 * s)))
    return along, -0.5 * g2 * (r**2 + sr2) * np.expm1(-2 * s)


def _rotate(along, cross, beta):
    """Stack the covariances with variance `along` on the line of sight u(β) and `cross`
    across it: R diag(along, cross) Rᵀ, shape (..., 2, 2)."""
    c, s = np.cos(beta), np.sin(beta)
    out = np.empty((*np.shape(along), 2, 2))
    out[..., 0, 0] = along * c**2 + cross * s**2
    out[..., 1, 1] = along * s**2 + cross * c**2
    out[..., 0, 1] = out[..., 1, 0] = (along - cross) * c * s
    return out


def _scale(r, sigma_r):
    """Exponents e with r / 2^e and σr / 2^e at most 1: variances are computed in units of
    4^e and scaled back exactly (ldexp), so r near 1e154 neither overflows r² nor loses it."""
    return np.frexp(np.maximum(r, sigma_r))[1]


def _unscale(v_scaled, e, what):
    """v · 4^e, refusing a result that overflows or underflows float64."""
    with np.errstate(over="ignore", under="ignore"):
        v = np.ldexp(v_scaled, 2 * e)
    if not np.all(np.isfinite(v)):
        raise ValueError(f"the {what} overflows float64 (above 1.8e308): `r`/`sigma_r` are too "
                         "large for their variances to be represented; express them in a "
                         "larger unit (km instead of m)")
    if np.any((v == 0) & (v_scaled > 0)):
        raise ValueError(f"the {what} underflows float64 (below 5e-324): `r`/`sigma_r` "
                         "are too small for their variances to be represented; express them "
                         "in a smaller unit")
    return v


def _convert(method, r, beta, sigma_r, sigma_beta):
    """Position g r̂ u(β̂) and the principal variances of the method's covariance."""
    g = conversion_gain(sigma_beta, method=method)
    with np.errstate(over="ignore"):
        gr = g * r
    if not np.all(np.isfinite(gr)):
        raise ValueError(f"`r` is too large: the converted position overflows float64; "
                         f"received largest entry {float(np.max(r)):.6g}")
    xy = np.stack([gr * np.cos(beta), gr * np.sin(beta)], axis=-1)
    e = _scale(r, sigma_r)
    along, cross = principal_variances(np.ldexp(r, -e), np.ldexp(sigma_r, -e), sigma_beta,
                                       method=method)
    along = _unscale(along, e, "along-range variance")
    cross = _unscale(cross, e, "cross-range variance")
    return xy, along, cross


def _prior_iv(prior_xy, prior_cov):
    """Validate a prior position (..., 2) and its covariance (..., 2, 2), symmetric PSD."""
    if prior_xy is None:
        raise ValueError("method 'decorrelated' needs `prior_xy`, the prior (predicted) position "
                         "whose covariance is averaged over; received None")
    xp = as_float_array(prior_xy, "prior_xy", ndim_min=1, last_dims=(2,))
    if prior_cov is None:
        pc = np.zeros((2, 2))
    else:
        pc = as_float_array(prior_cov, "prior_cov", ndim_min=2, last_dims=(2, 2))
        scale = np.maximum(np.abs(pc).max(axis=(-2, -1)), np.finfo(float).tiny)
        det = pc[..., 0, 0] * pc[..., 1, 1] - pc[..., 0, 1] * pc[..., 1, 0]
        if (np.any(np.abs(pc[..., 0, 1] - pc[..., 1, 0]) > 1e-9 * scale)
                or np.any(pc[..., 0, 0] < 0) or np.any(pc[..., 1, 1] < 0)
                or np.any(det < -1e-12 * scale**2)):
            raise ValueError("`prior_cov` must be symmetric positive semi-definite (..., 2, 2); "
                             f"received {describe(pc)}")
    if np.any(np.hypot(xp[..., 0], xp[..., 1]) == 0):
        raise ValueError("`prior_xy` must not be at the radar (0, 0): its azimuth is undefined; "
                         f"received {describe(xp)}")
    return xp, pc


def _prior_polar(xp, pc):
    """Prior position and covariance → (r_p, β_p, σ_rp², σ_βp²).

    The covariance is carried to polar coordinates by the Jacobian of the inverse map at
    the prior, keeping its diagonal (Bordonaro et al. 2014, who also drop the range–azimuth
    correlation): σ_rp² = uᵀPu, σ_βp² = u⊥ᵀPu⊥ / r_p²."""
    r_p = np.hypot(xp[..., 0], xp[..., 1])
    b_p = np.arctan2(xp[..., 1], xp[..., 0])
    c, s = np.cos(b_p), np.sin(b_p)
    p00, p01, p11 = pc[..., 0, 0], 0.5 * (pc[..., 0, 1] + pc[..., 1, 0]), pc[..., 1, 1]
    var_r = np.maximum(p00 * c**2 + 2 * p01 * c * s + p11 * s**2, 0.0)
    with np.errstate(over="ignore", under="ignore"):
        var_b = np.maximum(p00 * s**2 - 2 * p01 * c * s + p11 * c**2, 0.0) / r_p**2
    if not np.all(np.isfinite(var_b)):
        raise ValueError("`prior_xy` is too close to the radar for `prior_cov`: the prior's "
                         "azimuth variance overflows float64")
    return r_p, b_p, var_r, var_b


def decorrelated_variances(mean_sq_range, sigma_r, sigma_beta,
                           prior_azimuth_var):
    r"""Principal variances of the decorrelated covariance, along :math:`u(\beta_p)` and across.

    Bordonaro et al.'s :math:`R^D = E[\operatorname{Cov}(\hat x_{\text{mult}} \mid r, \beta)
    \mid \text{prior}]`:

    .. math::

        R^D = \tfrac12(\overline{r^2} + \sigma_r^2)e^{s}(I + e^{-2s-2s_p}M(\beta_p))
              - \tfrac12\overline{r^2}(I + e^{-2s_p}M(\beta_p)),

    written with ``expm1`` so that no difference of nearly equal numbers appears.

    Parameters
    ----------
    mean_sq_range : array_like
        :math:`\overline{r^2} = r_p^2 + \sigma_{rp}^2`, the mean squared range over the prior.
    sigma_r, sigma_beta : array_like
        Range and azimuth error standard deviations, :math:`\ge 0`: at most 1e150
        and at most :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX` (radians).
    prior_azimuth_var : array_like
        :math:`s_p = \sigma_{\beta p}^2`, the prior's azimuth variance (rad², :math:`\ge 0`).

    Returns
    -------
    along, cross : numpy.ndarray
        The variances along the prior's line of sight and across it.

    Raises
    ------
    ValueError
        A negative argument, a `sigma_r` above 1e150 or a `sigma_beta` above
        :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX`.

    Examples
    --------
    >>> along, cross = decorrelated_variances(150.0**2, 0.1, 0.01, 0.0)
    >>> round(float(along), 6), round(float(cross), 4)
    (0.010113, 2.25)
    """
    r_p2, sr2, s, sp = _decorrelated_iv(mean_sq_range, sigma_r, sigma_beta,
                                        prior_azimuth_var)
    with np.errstate(under="ignore"):
        d = np.exp(-2 * sp)
        along = 0.5 * (sr2 * (np.exp(s) + d * np.exp(-s))
                       + r_p2 * (4 * np.sinh(s / 2) ** 2
                                 + np.expm1(-2 * sp) * np.expm1(-s)))
        cross = 0.5 * (sr2 * (-np.exp(s) * np.expm1(-2 * s - 2 * sp))
                       + r_p2 * (np.expm1(s) - d * np.expm1(-s)))
    return along, cross


def _decorrelated_iv(mean_sq_range, sigma_r, sigma_beta, prior_azimuth_var):
    r_p2 = as_positive(mean_sq_range, "mean_sq_range", strict=False)
    sigma_r = as_positive(sigma_r, "sigma_r", strict=False)
    if np.any(sigma_r > _SQUARE_MAX):
        raise ValueError("`sigma_r` must be at most 1e150 here (its square must stay finite); "
                         f"received largest entry {float(np.max(sigma_r)):.6g}")
    sp = as_positive(prior_azimuth_var, "prior_azimuth_var", strict=False)
    return r_p2, sigma_r**2, as_sigma_beta(sigma_beta) ** 2, sp


def _convert_decorrelated(r, beta, sigma_r, sigma_beta, r_p, var_r, var_b):
    """Multiplicative position and the decorrelated principal variances (about u(β_p))."""
    s = sigma_beta**2
    with np.errstate(over="ignore"):
        gr = np.exp(s / 2) * r
    if not np.all(np.isfinite(gr)):
        raise ValueError(f"`r` is too large: the converted position overflows float64; "
                         f"received largest entry {float(np.max(r)):.6g}")
    xy = np.stack([gr * np.cos(beta), gr * np.sin(beta)], axis=-1)
    e = np.frexp(np.maximum(np.maximum(r_p, np.sqrt(var_r)), sigma_r))[1]
    rp2 = np.ldexp(r_p, -e) ** 2 + np.ldexp(np.sqrt(var_r), -e) ** 2
    along, cross = decorrelated_variances(rp2, np.ldexp(sigma_r, -e), sigma_beta, var_b)
    return (xy, _unscale(along, e, "along-range variance"),
            _unscale(cross, e, "cross-range variance"))


def _warn_singular(along, cross, method):
    low, high = np.minimum(along, cross), np.maximum(along, cross)
    bad = low <= 1e-12 * high
    if np.any(bad):
        warnings.warn(
            f"{int(np.count_nonzero(bad))} of {bad.size} covariances from method "
            f"{method!r} are singular or nearly so (ratio of principal variances at most "
            "1e-12: zero range with 'linearized', or a zero or tiny `sigma_r`/`sigma_beta`); "
            "a Cholesky factorisation of them will fail",
            RadarFusionWarning, stacklevel=3)


# --------------------------------------------------------------------------- public API
def polar_to_cartesian(r, beta, sigma_r, sigma_beta, *, method: str = "linearized",
                       prior_xy=None, prior_cov=None) -> ConvertedMeasurement:
    r"""Convert measured range and azimuth to a Cartesian position and covariance.

    Parameters
    ----------
    r : array_like
        Measured range :math:`\hat r \ge 0` (any length unit).
    beta : array_like
        Measured azimuth :math:`\hat\beta` in radians, counter-clockwise from
        the x axis (the paper's convention; see the module docstring).
    sigma_r : array_like
        Range error standard deviation :math:`\sigma_r \ge 0` (unit of `r`).
    sigma_beta : array_like
        Azimuth error standard deviation :math:`\sigma_\beta` in radians,
        :math:`0 \le \sigma_\beta \le`
        :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX` (0.5 rad).
    method : str
        The conversion (keyword-only), one of :data:`ALL_METHODS`: ``"linearized"``,
        ``"additive"``, ``"multiplicative"``, ``"first_order"``, ``"first_order_printed"``,
        ``"measurement_conditioned"``, ``"decorrelated"``; see the module docstring.
    prior_xy : array_like, shape (..., 2), optional
        For ``"decorrelated"`` only (and required there): the prior position of the
        target in the radar's frame — a track's prediction — not at the radar.
    prior_cov : array_like, shape (..., 2, 2), optional
        For ``"decorrelated"`` only: the prior's covariance, symmetric positive
        semi-definite (default zero: the prior is the truth).

    The four arrays (and the prior's batch axes) broadcast together to a batch shape ``(...)``.

    Returns
    -------
    ConvertedMeasurement
        ``xy`` with shape ``(..., 2)`` and ``cov`` with shape ``(..., 2, 2)``.

    Raises
    ------
    ValueError
        Negative `r`, `sigma_r` or `sigma_beta`; `sigma_beta` above
        :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX`;
        non-finite input; shapes that do not broadcast;
        unknown `method`; a broadcast batch above :data:`MAX_BATCH` (refused
        before allocation); a position or variance beyond the float range
        (about 1.8e308, or below 5e-324: express `r` and `sigma_r` in another
        unit).
    TypeError
        Non-numeric input.

    Warns
    -----
    RadarFusionWarning
        When a returned covariance is singular (zero `sigma_r` or `sigma_beta`,
        or zero range with ``"linearized"``).

    Notes
    -----
    With :math:`u = (\cos\hat\beta, \sin\hat\beta)`, :math:`s = \sigma_\beta^2`,
    :math:`q = e^{-s/2} = E\cos\tilde\beta`, every method returns
    :math:`\hat{\mathbf x} = g\,\hat r u` with gain :math:`g = 1` (linearized),
    :math:`1 + q - q^2` (additive), :math:`q^{-1}`
    (multiplicative and decorrelated), :math:`1 \pm s/2` (first order, derived / printed),
    :math:`q` (measurement-conditioned).
    The covariances, written as :math:`aI + bM(\hat\beta)` (the package computes them
    from their principal variances :math:`a \pm b` along and across the line of sight,
    with ``expm1`` and a power-of-two scaling of :math:`\hat r` and :math:`\sigma_r`, so
    they are accurate over the whole float range or refused when they overflow):

    .. math::

        \text{linearized (2a–c)}:\quad & a = \tfrac12(\sigma_r^2 + \hat r^2 s),\;
            b = \tfrac12(\sigma_r^2 - \hat r^2 s)\\
        \text{(4a–c)}:\quad & a = \tfrac12(\hat r^2 + 2\sigma_r^2) - \tfrac12(\hat r^2 + \sigma_r^2)e^{-s},\;
            b = \tfrac12(\hat r^2 + 2\sigma_r^2)e^{-4s} - \tfrac12(\hat r^2 + \sigma_r^2)e^{-3s}\\
        \text{multiplicative}:\quad & a = \tfrac12(e^{s} - 2)\hat r^2 + \tfrac12(\hat r^2 + \sigma_r^2),\;
            b = \tfrac12(e^{s} - 2)\hat r^2 + \tfrac12(\hat r^2 + \sigma_r^2)e^{-2s}\\
        \text{measurement-conditioned}:\quad & a = \tfrac12(\hat r^2 + \sigma_r^2) - \tfrac12 e^{-s}\hat r^2,\;
            b = \tfrac12(\hat r^2 + \sigma_r^2)e^{-2s} - \tfrac12 e^{-s}\hat r^2\\
        \text{decorrelated}:\quad & a = \tfrac12(\bar r^2 + \sigma_r^2)e^{s} - \tfrac12\bar r^2,\;
            b = \tfrac12(\bar r^2 + \sigma_r^2)e^{-s-2s_p} - \tfrac12\bar r^2 e^{-2s_p}
            \;\text{ (with } M(\beta_p)\text{)}.

    (4a–c) is Lerro & Bar-Shalom's :math:`E[\operatorname{Cov}(\hat{\mathbf x}\mid r,\beta)\mid
    \hat r, \hat\beta]` (true-conditioned covariance averaged over the truth
    given the measurement); the multiplicative covariance is
    :math:`E[(\hat{\mathbf x} - \mathbf x)(\hat{\mathbf x} - \mathbf x)^\mathsf T\mid
    \hat r, \hat\beta]`. Both treat the truth as :math:`r \sim \mathcal N(\hat r, \sigma_r^2)`,
    :math:`\beta \sim \mathcal N(\hat\beta, \sigma_\beta^2)` given the measurement.
    The measurement-conditioned covariance (Duan et al. 2004) is
    :math:`\operatorname{Cov}[\mathbf x \mid \hat r, \hat\beta]` under the same law, and its
    position is :math:`E[\mathbf x \mid \hat r, \hat\beta] = q\hat r u`. The decorrelated
    covariance (Bordonaro et al. 2014) averages the multiplicative conversion's covariance
    given the truth over the PRIOR instead, :math:`r \sim \mathcal N(r_p, \sigma_{rp}^2)`,
    :math:`\beta \sim \mathcal N(\beta_p, s_p)`, with :math:`(r_p, \beta_p)` the prior position in
    polar form, :math:`\sigma_{rp}^2 = u_p^\mathsf T P u_p`, :math:`s_p = u_{p\perp}^\mathsf T P
    u_{p\perp}/r_p^2` (the prior covariance :math:`P` carried to polar coordinates, its
    range–azimuth correlation dropped, as in the paper) and :math:`\bar r^2 = r_p^2 +
    \sigma_{rp}^2`; its principal axes are those of :math:`u(\beta_p)`, and it does not depend
    on the measurement at all.

    **Limit on** :math:`\sigma_\beta`. The moment formulas are exact for any
    :math:`\sigma_\beta` (cos and sin are periodic, so even a wrapped Gaussian
    gives the same moments), but the first-order form drops
    :math:`O(\sigma_\beta^4)` terms, the linearized form assumes the error is
    small, and beyond a few tenths of a radian the converted error is a
    crescent that no 2×2 covariance summarises. The package refuses
    :math:`\sigma_\beta >` :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX`
    = 0.5 rad (≈ 28.6°), which also
    catches azimuths passed in degrees by mistake.

    References
    ----------
    Prosov, eqs. (1), (2a–c), (3a–b), (4a–c); Lerro & Bar-Shalom (1993);
    Mo, Song et al. (1998); Duan, Han & Li (2004), the modified unbiased conversion;
    Bordonaro, Willett & Bar-Shalom (2014), the decorrelated unbiased conversion.

    Examples
    --------
    >>> out = polar_to_cartesian(150.0, np.pi / 4, 0.1, np.deg2rad(1.0))
    >>> out.xy.round(3)
    array([106.066, 106.066])
    >>> out.cov.round(3)
    array([[ 3.432, -3.422],
           [-3.422,  3.432]])
    >>> polar_to_cartesian([100.0, 150.0], 0.0, 0.1, 0.02, method="multiplicative").xy.shape
    (2, 2)
    """
    method = as_choice(method, "method", ALL_METHODS)
    if method != "decorrelated" and (prior_xy is not None or prior_cov is not None):
        raise ValueError("`prior_xy`/`prior_cov` are used only by method 'decorrelated'; "
                         f"received them with method {method!r}")
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta)
    if method == "decorrelated":
        xp, pc = _prior_iv(prior_xy, prior_cov)
        r_p, b_p, var_r, var_b = _prior_polar(xp, pc)
        _check_batch(1, r=r, prior_xy=r_p, prior_cov=var_b)
        r, beta, sigma_r, sigma_beta, r_p, b_p, var_r, var_b = broadcast(
            r=r, beta=beta, sigma_r=sigma_r, sigma_beta=sigma_beta, prior_xy=r_p, b_p=b_p,
            prior_cov=var_r, v_b=var_b)
        xy, along, cross = _convert_decorrelated(r, beta, sigma_r, sigma_beta, r_p, var_r,
                                                 var_b)
        _warn_singular(along, cross, method)
        return ConvertedMeasurement(xy, _rotate(along, cross, b_p), method)
    xy, along, cross = _convert(method, r, beta, sigma_r, sigma_beta)
    _warn_singular(along, cross, method)
    return ConvertedMeasurement(xy, _rotate(along, cross, beta), method)


def conversion_moments(r, beta, sigma_r, sigma_beta, *, method: str = "linearized"
                       ) -> ConversionMoments:
    r"""Exact mean, bias, covariance and MSE of a converted report given the TRUTH.

    Parameters
    ----------
    r, beta : array_like
        TRUE range (≥ 0) and azimuth (radians, counter-clockwise from x).
    sigma_r, sigma_beta : array_like
        Error standard deviations, as in :func:`polar_to_cartesian`.
    method : str
        One of :data:`ALL_METHODS` (keyword-only); ``"decorrelated"`` has the
        multiplicative position, hence its moments.

    Returns
    -------
    ConversionMoments

    Raises
    ------
    ValueError
        As :func:`polar_to_cartesian`.

    Notes
    -----
    The converted report is :math:`g\hat r u(\hat\beta)` (see
    :func:`polar_to_cartesian`). With :math:`q = e^{-s/2}`, :math:`E\cos k\tilde\beta = e^{-k^2 s/2}`,
    :math:`E\sin k\tilde\beta = 0`, :math:`E\hat r^2 = r^2 + \sigma_r^2`:

    .. math::

        E[\hat{\mathbf x}] = g q\, r u(\beta),\qquad
        \operatorname{Cov}[\hat{\mathbf x}] = g^2\left[\tfrac12(r^2 + \sigma_r^2)
        (I + e^{-2s}M(\beta)) - \tfrac12 q^2 r^2 (I + M(\beta))\right].

    These are conditioned on the true position; the covariances that
    :func:`polar_to_cartesian` attaches are evaluated at the measurement
    instead, so they are random.

    Examples
    --------
    >>> m = conversion_moments(150.0, 0.0, 0.1, 0.05, method="multiplicative")
    >>> bool(np.abs(m.bias).max() < 1e-12)
    True
    """
    method = as_choice(method, "method", ALL_METHODS)
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta)
    return _moments(method, r, beta, sigma_r, sigma_beta)


def _moments(method, r, beta, sigma_r, sigma_beta) -> ConversionMoments:
    s = sigma_beta**2
    bf = _bias_factor(method, s)
    u = np.stack([np.cos(beta), np.sin(beta)], axis=-1)
    mean_xy = ((1.0 + bf) * r)[..., None] * u
    bias = (bf * r)[..., None] * u
    e = _scale(r, sigma_r)
    rn, srn = np.ldexp(r, -e), np.ldexp(sigma_r, -e)
    along, cross = _truth_variances(method, rn, srn**2, sigma_beta)
    # the bias lies along the line of sight: it adds (bf r)² to the along-range MSE only
    along_mse = _unscale(along + (bf * rn) ** 2, e, "mean squared error")
    along = _unscale(along, e, "along-range variance")
    cross = _unscale(cross, e, "cross-range variance")
    return ConversionMoments(mean_xy, bias, _rotate(along, cross, beta),
                             _rotate(along_mse, cross, beta), method)


def conversion_bias(r, beta, sigma_beta, *, method: str = "linearized") -> np.ndarray:
    r"""Bias of a converted report given the true range and azimuth.

    For the plain conversion (1), :math:`E[\hat r\cos\hat\beta] = r\cos\beta\,
    e^{-\sigma_\beta^2/2}`, so the bias is :math:`(e^{-\sigma_\beta^2/2} - 1)\,r u(\beta)`:
    it points towards the radar, and does not depend on :math:`\sigma_r`
    (for any method, since every converted report is linear in :math:`\hat r`).

    Parameters
    ----------
    r, beta : array_like
        TRUE range (≥ 0) and azimuth (radians, counter-clockwise from x).
    sigma_beta : array_like
        Azimuth standard deviation in radians, ``0 <= sigma_beta <= SIGMA_BETA_MAX``.
    method : str
        One of :data:`ALL_METHODS`; the default ``"linearized"`` is conversion (1).

    Returns
    -------
    numpy.ndarray, shape (..., 2)
        :math:`E[\hat{\mathbf x} \mid r, \beta] - r(\cos\beta, \sin\beta)`.

    Raises
    ------
    ValueError
        As :func:`polar_to_cartesian`.

    Notes
    -----
    .. math::

        \mathbf b = (g\,e^{-\sigma_\beta^2/2} - 1)\, r\,(\cos\beta, \sin\beta),

    with the gain :math:`g` of the method (Prosov, eq. 1 and 3; Lerro &
    Bar-Shalom 1993; Mo et al. 1998).

    Examples
    --------
    >>> conversion_bias(150.0, 0.0, np.deg2rad(1.0)).round(5)
    array([-0.02284,  0.     ])
    >>> conversion_bias(150.0, 0.0, np.deg2rad(1.0), method="multiplicative").round(12)
    array([0., 0.])
    """
    method = as_choice(method, "method", ALL_METHODS)
    r, beta, sigma_beta = broadcast(r=as_positive(r, "r", strict=False),
                                    beta=as_float_array(beta, "beta"),
                                    sigma_beta=as_sigma_beta(sigma_beta))
    _check_batch(1, r=r)
    bf = _bias_factor(method, sigma_beta**2)
    return (bf * r)[..., None] * np.stack([np.cos(beta), np.sin(beta)], axis=-1)


def nonlinearity_index(r, sigma_r, sigma_beta) -> np.ndarray:
    r"""Lerro & Bar-Shalom's criterion :math:`r\sigma_\beta^2/\sigma_r`.

    The range-direction bias of conversion (1) is about
    :math:`r\sigma_\beta^2/2`; this index is twice that bias in units of the
    range error. Lerro & Bar-Shalom found the linearized conversion adequate
    while it stays below :data:`LERRO_THRESHOLD` (0.4).

    Parameters
    ----------
    r : array_like
        Range, ≥ 0.
    sigma_r : array_like
        Range error standard deviation, > 0.
    sigma_beta : array_like
        Azimuth error standard deviation in radians (at most
        :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX`).

    Returns
    -------
    numpy.ndarray

    Raises
    ------
    ValueError
        Negative `r`, non-positive `sigma_r`, `sigma_beta` outside
        ``[0, SIGMA_BETA_MAX]``, or an index above the float range (the
        product is formed from mantissas and exponents, so no intermediate
        overflows or underflows).

    Examples
    --------
    >>> float(nonlinearity_index(150.0, 0.1, np.deg2rad(1.0))).__round__(3)
    0.457
    """
    r = as_positive(r, "r", strict=False)
    sigma_r = as_positive(sigma_r, "sigma_r")
    sigma_beta = as_sigma_beta(sigma_beta)
    r, sigma_r, sigma_beta = broadcast(r=r, sigma_r=sigma_r, sigma_beta=sigma_beta)
    (mr, er), (ms, es), (mb, eb) = np.frexp(r), np.frexp(sigma_r), np.frexp(sigma_beta)
    with np.errstate(over="ignore"):
        out = np.ldexp(mr * mb * mb / ms, er + 2 * eb - es)
    if not np.all(np.isfinite(out)):
        raise ValueError("`r`·`sigma_beta`²/`sigma_r` exceeds the float range (1.8e308); "
                         f"received r up to {float(np.max(r)):.3g} and sigma_r down to "
                         f"{float(np.min(sigma_r)):.3g}")
    return out
