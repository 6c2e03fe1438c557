"""Polar-to-Cartesian conversion of radar reports, with and without bias correction.

A radar measures range :math:`\\hat r = r + \\tilde r` and azimuth
:math:`\\hat\\beta = \\beta + \\tilde\\beta`, with independent Gaussian errors
:math:`\\tilde r \\sim \\mathcal N(0, \\sigma_r^2)`,
:math:`\\tilde\\beta \\sim \\mathcal N(0, \\sigma_\\beta^2)`. Every method here
returns a Cartesian position :math:`(\\hat x, \\hat y)` and a 2×2 covariance.

**Azimuth convention** (the paper's: Prosov, description of the simulated
example, "the azimuth is counted from the X axis counter-clockwise"): :math:`\\beta` is in **radians**,
measured **counter-clockwise from the x axis**, so

.. math::

    \\hat x = \\hat r\\cos\\hat\\beta, \\qquad \\hat y = \\hat r\\sin\\hat\\beta
    \\qquad \\text{(Prosov, eq. 1)}.

This is *not* the navigation convention (clockwise from north, :math:`x = r\\sin\\beta`).
To use navigation azimuths :math:`\\alpha`, pass ``beta = np.pi / 2 - alpha``.

Methods (``method=``):

``"linearized"``
    eq. (1) with the Jacobian covariance (2a–c) evaluated at the measurement.
``"additive"``
    Lerro & Bar-Shalom's debiased conversion: subtract the bias averaged over
    the truth given the measurement; covariance (4a–c), which is their
    "average true covariance" conditioned on the *measured* values.
``"multiplicative"``
    Mo, Song et al.'s unbiased conversion :math:`e^{\\sigma_\\beta^2/2}\\hat r(\\cos\\hat\\beta,
    \\sin\\hat\\beta)`, exactly unbiased given the truth; covariance = mean squared
    error given the measurement (flat prior on the truth).
``"first_order"``
    the paper's eq. (3) with the sign of the correction derived here,
    :math:`\\hat r(1 + \\sigma_\\beta^2/2)(\\cos\\hat\\beta, \\sin\\hat\\beta)`, paired (as in the
    paper) with covariance (4a–c).
``"first_order_printed"``
    eq. (3) **as printed**, :math:`\\hat r(1 - \\sigma_\\beta^2/2)(\\ldots)`, with (4a–c);
    kept only to reproduce the paper — the printed sign doubles the bias
    instead of removing it (see the book's erratum).
``"measurement_conditioned"``
    Duan, Han & Li's modified unbiased conversion: the mean of the truth GIVEN the
    measurement, :math:`e^{-\\sigma_\\beta^2/2}\\hat r(\\cos\\hat\\beta, \\sin\\hat\\beta)`,
    with the covariance of the truth given the measurement (flat prior). It is the
    conditional mean, so its covariance is exact given the measurement; given the
    truth it is biased by :math:`(e^{-\\sigma_\\beta^2} - 1)\\,r u(\\beta)`.
``"decorrelated"``
    Bordonaro, Willett & Bar-Shalom's decorrelated unbiased conversion: the
    multiplicative position, with the covariance given the truth averaged over a
    PRIOR position (a track's prediction, ``prior_xy``/``prior_cov``) instead of over
    the measurement, so that the covariance is independent of the measurement's error.

The paper's and the classic methods are :data:`METHODS`; :data:`ALL_METHODS` adds the
two above. The 3-D conversion of (range, azimuth, elevation) is
:func:`spherical_to_cartesian`, with the methods :data:`METHODS_3D`; elevation
:math:`\\varepsilon` is measured up from the x–y plane, so
:math:`(x, y, z) = r(\\cos\\varepsilon\\cos\\beta, \\cos\\varepsilon\\sin\\beta, \\sin\\varepsilon)`.

Every covariance here has the form :math:`aI + bM(\\beta)` with
:math:`M(\\beta) = \\begin{pmatrix}\\cos 2\\beta & \\sin 2\\beta\\\\ \\sin 2\\beta & -\\cos 2\\beta\\end{pmatrix}`:
its eigenvectors point along range (variance :math:`a + b`) and across range
(variance :math:`a - b`).

.. rubric:: References

.. [1] A. V. Prosov, "Analysis of the effect of linearization errors of radar
   measurements on the reliability of associating data from spatially
   separated radars", eqs. (1)–(4).
.. [2] D. Lerro, Y. Bar-Shalom, "Tracking with debiased consistent converted
   measurements versus EKF", IEEE Trans. AES 29(3) (1993) 1015–1022.
.. [3] L. Mo, X. Song, Y. Zhou, Z. K. Sun, Y. Bar-Shalom, "Unbiased converted
   measurements for tracking", IEEE Trans. AES 34(3) (1998) 1023–1027.
.. [4] Z. Duan, C. Han, X. R. Li, "Comments on 'Unbiased converted measurements for
   tracking'", IEEE Trans. AES 40(4) (2004) 1374–1377.
.. [5] S. V. Bordonaro, P. Willett, Y. Bar-Shalom, "Decorrelated unbiased converted
   measurement Kalman filter", IEEE Trans. AES 50(2) (2014) 1431–1444.
.. [7] P. Suchomski, "Explicit expressions for debiased statistics of 3D converted
   measurements", IEEE Trans. AES 35(1) (1999) 368–370.
.. [6] X. R. Li, Z. Zhao, "Measuring estimator's credibility: noncredibility index",
   Proc. 9th Int. Conf. Information Fusion (2006).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from .engine._validation import (
    MEMORY_LIMIT,
    _describe,
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_rng,
    broadcast,
    check_size,
)
from .engine.errors import RadarFusionWarning
from .engine.montecarlo import MeanEstimate, mean

__all__ = [
    "ALL_METHODS",
    "LERRO_THRESHOLD",
    "MAX_BATCH",
    "METHODS",
    "METHODS_3D",
    "SIGMA_BETA_MAX",
    "ConversionMoments",
    "ConversionTrials",
    "ConvertedMeasurement",
    "ConvertedMeasurement3D",
    "conversion_bias",
    "conversion_moments",
    "conversion_monte_carlo",
    "nees",
    "nees_at_truth",
    "nonlinearity_index",
    "polar_to_cartesian",
    "simulate_polar",
    "simulate_spherical",
    "spherical_moments",
    "spherical_monte_carlo",
    "spherical_to_cartesian",
]

#: The conversion methods accepted by :func:`polar_to_cartesian`.
METHODS = ("linearized", "additive", "multiplicative", "first_order", "first_order_printed")

#: Every 2-D method: :data:`METHODS` (the paper's and the classic ones, unchanged) and the
#: current ones, Duan et al.'s measurement-conditioned conversion and Bordonaro et al.'s
#: decorrelated one (which needs a prior position, ``prior_xy``).
ALL_METHODS = (*METHODS, "measurement_conditioned", "decorrelated")

#: The 3-D methods accepted by :func:`spherical_to_cartesian` (range, azimuth, elevation).
METHODS_3D = ("linearized", "additive", "multiplicative", "measurement_conditioned")

#: Largest azimuth standard deviation accepted, in radians (≈ 28.6°): the package's one
#: limit on :math:`\sigma_\beta` (:mod:`radarfusion_ref.separated` imports it from here).
#: Why 0.5 and not π/4: at :math:`\sigma_\beta = 0.5` an azimuth error beyond ±90° (a report
#: folded behind the radar's cross-range line, which no 2×2 covariance can describe) has
#: probability :math:`2\Phi(-\pi/(2\sigma_\beta)) \approx 1.7\times 10^{-3}`; at π/4 it is
#: 4.6 %, one report in 22. The first-order correction's dropped term
#: :math:`\sigma_\beta^4/8` is 0.8 % of the range at 0.5 and 4.7 % at π/4. And the smaller
#: limit also catches azimuth deviations from 0.5 to 0.79 passed in degrees by mistake.
SIGMA_BETA_MAX = 0.5

#: Largest number of batch elements (broadcast inputs × trials) one call works on at once:
#: about 256 bytes of working memory each, so one call stays within
#: :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT` (1 GiB).
MAX_BATCH = MEMORY_LIMIT // 256

#: Lerro & Bar-Shalom's rule of thumb (as usually quoted): the linearized
#: conversion is adequate while :math:`r\sigma_\beta^2/\sigma_r` stays below this value.
LERRO_THRESHOLD = 0.4

#: Smallest r/σr accepted by :func:`simulate_polar` (a negative simulated range
#: then has probability below 1e-15).
MIN_RANGE_OVER_SIGMA = 8.0


@dataclass(frozen=True)
class ConvertedMeasurement:
    """A converted report: Cartesian position and its covariance.

    Attributes
    ----------
    xy : numpy.ndarray, shape (..., 2)
        Converted position :math:`(\\hat x, \\hat y)` in the radar's frame
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
    """Exact moments of a converted report given the TRUE range and azimuth.

    Attributes
    ----------
    mean : numpy.ndarray, shape (..., 2)
        :math:`E[\\hat{\\mathbf x} \\mid r, \\beta]`.
    bias : numpy.ndarray, shape (..., 2)
        ``mean - r (cos β, sin β)``.
    cov : numpy.ndarray, shape (..., 2, 2)
        :math:`\\operatorname{Cov}[\\hat{\\mathbf x} \\mid r, \\beta]`.
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


@dataclass(frozen=True)
class ConversionTrials:
    """Monte-Carlo trials of one conversion method.

    Attributes
    ----------
    method : str
        One of :data:`METHODS`.
    error : numpy.ndarray, shape (..., trials, 2)
        Converted position minus true position, one row per trial.
    nees : numpy.ndarray, shape (..., trials)
        Normalized estimation error squared
        :math:`\\mathbf e^\\mathsf T C^{-1}\\mathbf e` with the method's own
        covariance :math:`C`; its mean is the dimension (2, or 3 in 3-D) for a
        consistent method.
    nees_true : numpy.ndarray or None, shape (..., trials)
        The same error normalized by the exact mean squared error matrix given the
        truth, :math:`\\mathbf e^\\mathsf T \\mathrm{MSE}^{-1}\\mathbf e` (from
        :func:`conversion_moments`); filled by :func:`conversion_monte_carlo` and
        :func:`spherical_monte_carlo`, ``None`` when built by hand. It is the
        reference of :meth:`noncredibility`.
    """

    method: str
    error: np.ndarray
    nees: np.ndarray
    nees_true: np.ndarray | None = None

    @property
    def trials(self) -> int:
        """Number of trials (length of the last axis of :attr:`nees`)."""
        return int(self.nees.shape[-1])

    def bias(self, *, confidence: float = 0.95) -> MeanEstimate:
        """Mean error over the trials, shape ``(..., 2)``, with t-intervals."""
        return mean(self.error, axis=-2, confidence=confidence)

    def mean_nees(self, *, confidence: float = 0.95) -> MeanEstimate:
        """Mean NEES over the trials, shape ``(...)``, with t-intervals (2 if consistent)."""
        return mean(self.nees, axis=-1, confidence=confidence)

    def noncredibility(self, *, confidence: float = 0.95) -> MeanEstimate:
        """Li & Zhao's noncredibility index, in dB, shape ``(...)``, with t-intervals.

        .. math::

            \\mathrm{NCI} = \\frac{10}{N}\\sum_{i=1}^N \\log_{10}
            \\frac{\\mathbf e_i^\\mathsf T C_i^{-1}\\mathbf e_i}
                 {\\mathbf e_i^\\mathsf T \\mathrm{MSE}^{-1}\\mathbf e_i}.

        0 dB for a credible covariance (one that is the true MSE matrix); positive when
        the covariance is too small (optimistic), negative when it is too large
        (pessimistic). Unlike the mean NEES it weights every trial alike, so a few large
        errors cannot hide a covariance that is wrong for most reports.

        Raises
        ------
        ValueError
            When :attr:`nees_true` is ``None`` (a hand-built result) or a trial has a
            zero error (the log-ratio is undefined).
        """
        if self.nees_true is None:
            raise ValueError("`nees_true` is None: the noncredibility index needs the NEES "
                             "against the true MSE (use conversion_monte_carlo)")
        if np.any(self.nees_true <= 0) or np.any(self.nees <= 0):
            raise ValueError("`nees` and `nees_true` must be > 0 for the log-ratio; a trial "
                             "has a zero error")
        return mean(10 * np.log10(self.nees / self.nees_true), axis=-1, confidence=confidence)


# --------------------------------------------------------------------------- validation
def _polar_iv(r, beta, sigma_r, sigma_beta, *, strict: bool = False, trials: int = 1):
    """Validate and broadcast the four polar arguments (shared by the public functions).

    ``strict=True`` requires ``sigma_r > 0`` and ``sigma_beta > 0`` (for functions that
    need a positive-definite covariance); `trials` multiplies the batch size checked
    against :data:`MAX_BATCH` before anything is allocated."""
    r = as_positive(r, "r", strict=False)
    beta = as_float_array(beta, "beta")
    sigma_r = as_positive(sigma_r, "sigma_r", strict=strict)
    sigma_beta = _sigma_beta_iv(sigma_beta, strict=strict)
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


def _sigma_beta_iv(sigma_beta, *, strict: bool = False):
    sigma_beta = as_positive(sigma_beta, "sigma_beta", strict=strict)
    if np.any(sigma_beta > SIGMA_BETA_MAX):
        raise ValueError(
            f"`sigma_beta` must be an azimuth standard deviation in radians in "
            f"{'(' if strict else '['}0, {SIGMA_BETA_MAX}] (SIGMA_BETA_MAX); received largest entry "
            f"{float(np.max(sigma_beta)):.6g} — did you pass degrees? Use np.deg2rad."
        )
    return sigma_beta


# --------------------------------------------------------------------------- building blocks
def _gain(method: str, s: np.ndarray) -> np.ndarray:
    """Scalar factor g with converted position = g · r̂ (cos β̂, sin β̂); s = σβ²."""
    t = s / 2                         # E cos w = e^{−t}
    if method == "linearized":        # eq. (1): no correction
        return np.ones_like(s)
    if method == "additive":          # r̂u − r̂u(e^{−s} − e^{−t}) = r̂u (1 + e^{−t}(1 − e^{−t}))
        return 1.0 - np.exp(-t) * np.expm1(-t)
    if method == "multiplicative":    # e^{t} r̂u: exactly unbiased
        return np.exp(t)
    if method == "first_order":       # eq. (3) with the derived sign
        return 1.0 + t
    if method == "measurement_conditioned":    # Duan et al.: E[x | r̂, β̂] = e^{−t} r̂u
        return np.exp(-t)
    if method == "decorrelated":      # Bordonaro et al.: the multiplicative position
        return np.exp(t)
    return 1.0 - t                    # "first_order_printed": eq. (3) as printed


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


def _principal_variances(method, r, sr2, s):
    """Variances along the line of sight and across it of the method's covariance.

    Evaluated at the measurement (r = r̂), s = σβ²; written with expm1 so that no
    difference of nearly equal numbers loses the small cross-range variance."""
    em = -np.expm1(-s)                                 # 1 − e^{−s}
    if method == "linearized":                         # eq. (2a–c): J diag(σr², σβ²) Jᵀ
        return sr2, r**2 * s
    if method == "measurement_conditioned":            # Duan et al.: Cov[x | r̂, β̂]
        return (0.5 * r**2 * em**2 + 0.5 * sr2 * (1 + np.exp(-2 * s)),
                -0.5 * (r**2 + sr2) * np.expm1(-2 * s))
    if method == "multiplicative":                     # Mo et al.: MSE given the measurement
        big = np.where(s < 1e-4, 1.5 * s**2 - 0.5 * s**3 + 0.375 * s**4,
                       np.expm1(s) + 0.5 * np.expm1(-2 * s))   # e^{s} − 3/2 + e^{−2s}/2
        along = r**2 * big + 0.5 * sr2 * (1 + np.exp(-2 * s))
        return along, -0.5 * (r**2 + sr2) * np.expm1(-2 * s)
    # additive / first_order / first_order_printed: eq. (4a–c), Lerro & Bar-Shalom's R^a
    along = (-0.5 * r**2 * em * np.expm1(-3 * s)
             + sr2 * (1 - 0.5 * np.exp(-s) + np.exp(-4 * s) - 0.5 * np.exp(-3 * s)))
    cross = (0.5 * r**2 * em * (1 + np.exp(-3 * s))
             + sr2 * (-np.expm1(-4 * s) + 0.5 * np.exp(-s) * np.expm1(-2 * s)))
    return along, cross


def _truth_variances(method, r, sr2, s):
    """Principal variances of Cov[x̂ | r, β] (given the TRUE position), s = σβ²."""
    g2 = _gain(method, s) ** 2
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
    s = sigma_beta**2
    g = _gain(method, s)
    with np.errstate(over="ignore"):
        gr = g * r
    if not np.all(np.isfinite(gr)):
        raise ValueError(f"`r` is too large: the converted position overflows float64; "
                         f"received largest entry {float(np.max(r)):.6g}")
    xy = np.stack([gr * np.cos(beta), gr * np.sin(beta)], axis=-1)
    e = _scale(r, sigma_r)
    along, cross = _principal_variances(method, np.ldexp(r, -e), np.ldexp(sigma_r, -e)**2, s)
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
                             f"received {_describe(pc)}")
    if np.any(np.hypot(xp[..., 0], xp[..., 1]) == 0):
        raise ValueError("`prior_xy` must not be at the radar (0, 0): its azimuth is undefined; "
                         f"received {_describe(xp)}")
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


def _decorrelated_variances(r_p2, sr2, s, sp):
    """Principal variances of R^D = E[Cov(x̂_mult | r, β) | prior], along u(β_p) and across.

    `r_p2` is E r² = r_p² + σ_rp² over the prior, `sr2` = σr², s = σβ², `sp` = σ_βp²:

        R^D = ½(E r² + σr²) e^{s} (I + e^{−2s−2sp} M(β_p)) − ½ E r² (I + e^{−2sp} M(β_p)),

    written with expm1 so that no difference of nearly equal numbers appears."""
    with np.errstate(under="ignore"):
        d = np.exp(-2 * sp)
        along = 0.5 * (sr2 * (np.exp(s) + d * np.exp(-s))
                       + r_p2 * (4 * np.sinh(s / 2) ** 2 + np.expm1(-2 * sp) * np.expm1(-s)))
        cross = 0.5 * (sr2 * (-np.exp(s) * np.expm1(-2 * s - 2 * sp))
                       + r_p2 * (np.expm1(s) - d * np.expm1(-s)))
    return along, cross


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
    along, cross = _decorrelated_variances(rp2, np.ldexp(sigma_r, -e) ** 2, s, var_b)
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
    """Convert measured range and azimuth to a Cartesian position and covariance.

    Parameters
    ----------
    r : array_like
        Measured range :math:`\\hat r \\ge 0` (any length unit).
    beta : array_like
        Measured azimuth :math:`\\hat\\beta` in radians, counter-clockwise from
        the x axis (the paper's convention; see the module docstring).
    sigma_r : array_like
        Range error standard deviation :math:`\\sigma_r \\ge 0` (unit of `r`).
    sigma_beta : array_like
        Azimuth error standard deviation :math:`\\sigma_\\beta` in radians,
        :math:`0 \\le \\sigma_\\beta \\le` :data:`SIGMA_BETA_MAX` (0.5 rad).
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
        :data:`SIGMA_BETA_MAX`; non-finite input; shapes that do not broadcast;
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
    With :math:`u = (\\cos\\hat\\beta, \\sin\\hat\\beta)`, :math:`s = \\sigma_\\beta^2`,
    :math:`q = e^{-s/2} = E\\cos\\tilde\\beta`, every method returns
    :math:`\\hat{\\mathbf x} = g\\,\\hat r u` with gain :math:`g = 1` (linearized),
    :math:`1 + q - q^2` (additive), :math:`q^{-1}`
    (multiplicative and decorrelated), :math:`1 \\pm s/2` (first order, derived / printed),
    :math:`q` (measurement-conditioned).
    The covariances, written as :math:`aI + bM(\\hat\\beta)` (the package computes them
    from their principal variances :math:`a \\pm b` along and across the line of sight,
    with ``expm1`` and a power-of-two scaling of :math:`\\hat r` and :math:`\\sigma_r`, so
    they are accurate over the whole float range or refused when they overflow):

    .. math::

        \\text{linearized (2a–c)}:\\quad & a = \\tfrac12(\\sigma_r^2 + \\hat r^2 s),\\;
            b = \\tfrac12(\\sigma_r^2 - \\hat r^2 s)\\\\
        \\text{(4a–c)}:\\quad & a = \\tfrac12(\\hat r^2 + 2\\sigma_r^2) - \\tfrac12(\\hat r^2 + \\sigma_r^2)e^{-s},\\;
            b = \\tfrac12(\\hat r^2 + 2\\sigma_r^2)e^{-4s} - \\tfrac12(\\hat r^2 + \\sigma_r^2)e^{-3s}\\\\
        \\text{multiplicative}:\\quad & a = \\tfrac12(e^{s} - 2)\\hat r^2 + \\tfrac12(\\hat r^2 + \\sigma_r^2),\\;
            b = \\tfrac12(e^{s} - 2)\\hat r^2 + \\tfrac12(\\hat r^2 + \\sigma_r^2)e^{-2s}\\\\
        \\text{measurement-conditioned}:\\quad & a = \\tfrac12(\\hat r^2 + \\sigma_r^2) - \\tfrac12 e^{-s}\\hat r^2,\\;
            b = \\tfrac12(\\hat r^2 + \\sigma_r^2)e^{-2s} - \\tfrac12 e^{-s}\\hat r^2\\\\
        \\text{decorrelated}:\\quad & a = \\tfrac12(\\bar r^2 + \\sigma_r^2)e^{s} - \\tfrac12\\bar r^2,\\;
            b = \\tfrac12(\\bar r^2 + \\sigma_r^2)e^{-s-2s_p} - \\tfrac12\\bar r^2 e^{-2s_p}
            \\;\\text{ (with } M(\\beta_p)\\text{)}.

    (4a–c) is Lerro & Bar-Shalom's :math:`E[\\operatorname{Cov}(\\hat{\\mathbf x}\\mid r,\\beta)\\mid
    \\hat r, \\hat\\beta]` (true-conditioned covariance averaged over the truth
    given the measurement); the multiplicative covariance is
    :math:`E[(\\hat{\\mathbf x} - \\mathbf x)(\\hat{\\mathbf x} - \\mathbf x)^\\mathsf T\\mid
    \\hat r, \\hat\\beta]`. Both treat the truth as :math:`r \\sim \\mathcal N(\\hat r, \\sigma_r^2)`,
    :math:`\\beta \\sim \\mathcal N(\\hat\\beta, \\sigma_\\beta^2)` given the measurement.
    The measurement-conditioned covariance (Duan et al. 2004) is
    :math:`\\operatorname{Cov}[\\mathbf x \\mid \\hat r, \\hat\\beta]` under the same law, and its
    position is :math:`E[\\mathbf x \\mid \\hat r, \\hat\\beta] = q\\hat r u`. The decorrelated
    covariance (Bordonaro et al. 2014) averages the multiplicative conversion's covariance
    given the truth over the PRIOR instead, :math:`r \\sim \\mathcal N(r_p, \\sigma_{rp}^2)`,
    :math:`\\beta \\sim \\mathcal N(\\beta_p, s_p)`, with :math:`(r_p, \\beta_p)` the prior position in
    polar form, :math:`\\sigma_{rp}^2 = u_p^\\mathsf T P u_p`, :math:`s_p = u_{p\\perp}^\\mathsf T P
    u_{p\\perp}/r_p^2` (the prior covariance :math:`P` carried to polar coordinates, its
    range–azimuth correlation dropped, as in the paper) and :math:`\\bar r^2 = r_p^2 +
    \\sigma_{rp}^2`; its principal axes are those of :math:`u(\\beta_p)`, and it does not depend
    on the measurement at all.

    **Limit on** :math:`\\sigma_\\beta`. The moment formulas are exact for any
    :math:`\\sigma_\\beta` (cos and sin are periodic, so even a wrapped Gaussian
    gives the same moments), but the first-order form drops
    :math:`O(\\sigma_\\beta^4)` terms, the linearized form assumes the error is
    small, and beyond a few tenths of a radian the converted error is a
    crescent that no 2×2 covariance summarises. The package refuses
    :math:`\\sigma_\\beta >` :data:`SIGMA_BETA_MAX` = 0.5 rad (≈ 28.6°), which also
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
    """Exact mean, bias, covariance and MSE of a converted report given the TRUTH.

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
    The converted report is :math:`g\\hat r u(\\hat\\beta)` (see
    :func:`polar_to_cartesian`). With :math:`q = e^{-s/2}`, :math:`E\\cos k\\tilde\\beta = e^{-k^2 s/2}`,
    :math:`E\\sin k\\tilde\\beta = 0`, :math:`E\\hat r^2 = r^2 + \\sigma_r^2`:

    .. math::

        E[\\hat{\\mathbf x}] = g q\\, r u(\\beta),\\qquad
        \\operatorname{Cov}[\\hat{\\mathbf x}] = g^2\\left[\\tfrac12(r^2 + \\sigma_r^2)
        (I + e^{-2s}M(\\beta)) - \\tfrac12 q^2 r^2 (I + M(\\beta))\\right].

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
    along, cross = _truth_variances(method, rn, srn**2, s)
    # the bias lies along the line of sight: it adds (bf r)² to the along-range MSE only
    along_mse = _unscale(along + (bf * rn) ** 2, e, "mean squared error")
    along = _unscale(along, e, "along-range variance")
    cross = _unscale(cross, e, "cross-range variance")
    return ConversionMoments(mean_xy, bias, _rotate(along, cross, beta),
                             _rotate(along_mse, cross, beta), method)


def conversion_bias(r, beta, sigma_beta, *, method: str = "linearized") -> np.ndarray:
    """Bias of a converted report given the true range and azimuth.

    For the plain conversion (1), :math:`E[\\hat r\\cos\\hat\\beta] = r\\cos\\beta\\,
    e^{-\\sigma_\\beta^2/2}`, so the bias is :math:`(e^{-\\sigma_\\beta^2/2} - 1)\\,r u(\\beta)`:
    it points towards the radar, and does not depend on :math:`\\sigma_r`
    (for any method, since every converted report is linear in :math:`\\hat r`).

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
        :math:`E[\\hat{\\mathbf x} \\mid r, \\beta] - r(\\cos\\beta, \\sin\\beta)`.

    Raises
    ------
    ValueError
        As :func:`polar_to_cartesian`.

    Notes
    -----
    .. math::

        \\mathbf b = (g\\,e^{-\\sigma_\\beta^2/2} - 1)\\, r\\,(\\cos\\beta, \\sin\\beta),

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
                                    sigma_beta=_sigma_beta_iv(sigma_beta))
    _check_batch(1, r=r)
    bf = _bias_factor(method, sigma_beta**2)
    return (bf * r)[..., None] * np.stack([np.cos(beta), np.sin(beta)], axis=-1)


def nonlinearity_index(r, sigma_r, sigma_beta) -> np.ndarray:
    """Lerro & Bar-Shalom's criterion :math:`r\\sigma_\\beta^2/\\sigma_r`.

    The range-direction bias of conversion (1) is about
    :math:`r\\sigma_\\beta^2/2`; this index is twice that bias in units of the
    range error. Lerro & Bar-Shalom found the linearized conversion adequate
    while it stays below :data:`LERRO_THRESHOLD` (0.4).

    Parameters
    ----------
    r : array_like
        Range, ≥ 0.
    sigma_r : array_like
        Range error standard deviation, > 0.
    sigma_beta : array_like
        Azimuth error standard deviation in radians (≤ :data:`SIGMA_BETA_MAX`).

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
    sigma_beta = _sigma_beta_iv(sigma_beta)
    r, sigma_r, sigma_beta = broadcast(r=r, sigma_r=sigma_r, sigma_beta=sigma_beta)
    (mr, er), (ms, es), (mb, eb) = np.frexp(r), np.frexp(sigma_r), np.frexp(sigma_beta)
    with np.errstate(over="ignore"):
        out = np.ldexp(mr * mb * mb / ms, er + 2 * eb - es)
    if not np.all(np.isfinite(out)):
        raise ValueError("`r`·`sigma_beta`²/`sigma_r` exceeds the float range (1.8e308); "
                         f"received r up to {float(np.max(r)):.3g} and sigma_r down to "
                         f"{float(np.min(sigma_r)):.3g}")
    return out


def simulate_polar(r, beta, sigma_r, sigma_beta, *, trials: int, rng=None):
    """Draw noisy polar measurements of true positions.

    Parameters
    ----------
    r, beta, sigma_r, sigma_beta : array_like
        TRUE range and azimuth, and the error standard deviations; they
        broadcast to a batch shape ``(...)``. ``r >= 8 sigma_r`` is required
        so that a negative range is never drawn (probability < 1e-15).
    trials : int
        Number of independent measurements per batch element (≥ 1).
    rng : None, int, SeedSequence or numpy.random.Generator
        Randomness (SPEC 7).

    Returns
    -------
    r_hat, beta_hat : numpy.ndarray, shape (..., trials)

    Raises
    ------
    ValueError
        As :func:`polar_to_cartesian`; ``r < 8 sigma_r``; `trials` < 1; a batch
        (broadcast inputs × `trials`) above :data:`MAX_BATCH`, refused before
        anything is drawn.
    TypeError
        Non-numeric input, a non-integer `trials`, or an `rng` that is not
        ``None``, a seed, a SeedSequence or a Generator.

    Notes
    -----
    The draws are ``r + sigma_r z_r`` and ``beta + sigma_beta z_beta`` with all
    range deviates drawn first, then all azimuth deviates, each in C order of the
    shape ``(..., trials)``: a seed fixes the result for a given batch shape and
    `trials`. :func:`conversion_monte_carlo` draws once through this function and
    only then works through the trials in chunks, so its results do not depend
    on its `chunk_size`.

    Examples
    --------
    >>> r_hat, b_hat = simulate_polar([100.0, 150.0], 0.3, 0.1, 0.01, trials=5, rng=1)
    >>> r_hat.shape
    (2, 5)
    """
    trials = as_int(trials, "trials", minimum=1)
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta, trials=trials)
    return _draw_range_azimuth(r, beta, sigma_r, sigma_beta, trials, as_rng(rng))


def _draw_range_azimuth(r, beta, sigma_r, sigma_beta, trials, rng):
    """Noisy ranges, then azimuths, ``trials`` of each along a new last axis (validated input)."""
    if np.any(r < MIN_RANGE_OVER_SIGMA * sigma_r):
        raise ValueError(
            f"`r` must be at least {MIN_RANGE_OVER_SIGMA:g} `sigma_r` so that the Gaussian "
            f"range error never produces a negative range; received smallest r/sigma_r "
            f"{float(np.min(r / np.where(sigma_r > 0, sigma_r, np.inf))):.4g}")
    shape = (*r.shape, trials)
    with np.errstate(over="ignore"):
        r_hat = r[..., None] + sigma_r[..., None] * rng.standard_normal(shape)
    if not np.all(np.isfinite(r_hat)):
        raise ValueError("`r` is too large: simulated ranges overflow float64; received "
                         f"largest entry {float(np.max(r)):.6g}")
    beta_hat = beta[..., None] + sigma_beta[..., None] * rng.standard_normal(shape)
    return r_hat, beta_hat


def nees(error, cov) -> np.ndarray:
    """Normalized estimation error squared :math:`\\mathbf e^\\mathsf T C^{-1}\\mathbf e`.

    Computed through a Cholesky factor :math:`C = LL^\\mathsf T`:
    :math:`\\|L^{-1}\\mathbf e\\|^2`. If :math:`C` is the true error covariance,
    the mean is the dimension :math:`d`; for Gaussian errors NEES is
    :math:`\\chi^2_d`.

    Parameters
    ----------
    error : array_like, shape (..., d)
        Estimate minus truth.
    cov : array_like, shape (..., d, d)
        Symmetric positive-definite covariances, broadcasting with `error`.

    Returns
    -------
    numpy.ndarray, shape (...)

    Raises
    ------
    ValueError
        If `cov` is not symmetric positive definite (Cholesky fails), or the
        shapes disagree.

    Examples
    --------
    >>> float(nees([1.0, 2.0], [[1.0, 0.0], [0.0, 4.0]]))
    2.0
    """
    e = as_float_array(error, "error", ndim_min=1)
    d = e.shape[-1]
    if d < 1:
        raise ValueError(f"`error` must have shape (..., d) with d >= 1; received shape {e.shape}")
    c = as_float_array(cov, "cov", ndim_min=2, last_dims=(d, d))
    try:
        shape = np.broadcast_shapes(e.shape[:-1], c.shape[:-2])
    except ValueError:
        raise ValueError(
            f"`error` (..., d) and `cov` (..., d, d) must have broadcasting batch shapes; "
            f"received shapes {e.shape} and {c.shape}") from None
    check_size(int(np.prod(shape, dtype=object)) * d * d, MAX_BATCH,
               what="broadcast `error` × `cov` entries",
               alternative="several calls on slices of the batch")
    # scale each matrix by a power of 4 (and its error by the power of 2): exact, and the
    # factorisation then never overflows or underflows, whatever the unit
    big = np.max(np.abs(c), axis=(-2, -1))
    k = np.frexp(np.where(big > 0, big, 1.0))[1] // 2
    c = np.ldexp(c, -2 * k[..., None, None])
    e = np.ldexp(e, -np.broadcast_to(k, shape)[..., None]) if shape else np.ldexp(e, -k)
    if d != 2:
        chol = np.linalg.cholesky(np.broadcast_to(as_covariance(c, "cov"), (*shape, d, d)))
        z = np.linalg.solve(chol, np.broadcast_to(e, (*shape, d))[..., None])[..., 0]
        return _finite_nees(np.sum(z**2, axis=-1))
    # d = 2: the Cholesky factor in closed form (fast on millions of trials)
    c00, c01, c10, c11 = c[..., 0, 0], c[..., 0, 1], c[..., 1, 0], c[..., 1, 1]
    scale = np.maximum(np.abs(c).max(axis=(-2, -1)), np.finfo(float).tiny)
    with np.errstate(invalid="ignore", divide="ignore"):
        l00 = np.sqrt(c00)
        l10 = c10 / l00
        schur = c11 - l10**2
        ok = (c00 > 0) & (schur > 0) & (np.abs(c01 - c10) <= 1e-9 * scale)
    if not np.all(ok):
        as_covariance(cov, "cov", dim=2)     # raises the package's standard message
        raise ValueError("`cov` must be symmetric positive definite; the Cholesky "
                         f"factorisation failed for {int(np.count_nonzero(~ok))} matrices "
                         "(numerically singular)")
    with np.errstate(over="ignore"):
        z0 = e[..., 0] / l00
        z1 = (e[..., 1] - l10 * z0) / np.sqrt(schur)
        return _finite_nees(z0**2 + z1**2)


def _finite_nees(value):
    if not np.all(np.isfinite(value)):
        raise ValueError("NEES exceeds the float range (1.8e308): `error` is too large for "
                         "`cov`; received an error more than 1e154 standard deviations out")
    return value


def nees_at_truth(r, beta, sigma_r, sigma_beta, *, method: str = "linearized") -> np.ndarray:
    """Expected NEES when the method's covariance is evaluated at the TRUE position.

    :math:`\\operatorname{tr}\\big(\\Sigma(r, \\beta)^{-1}\\,\\mathrm{MSE}(r, \\beta)\\big)`, with
    :math:`\\Sigma` the covariance :func:`polar_to_cartesian` would attach to a report
    lying exactly at the truth and MSE the exact mean squared error matrix of
    :func:`conversion_moments`. It is 2 when :math:`\\Sigma` is the true MSE. In
    practice :math:`\\Sigma` is evaluated at the measurement, and the Monte-Carlo mean
    NEES of :func:`conversion_monte_carlo` is the relevant figure; the two
    agree for ``"linearized"`` but not for the measured-conditioned covariances
    of ``"additive"`` and ``"multiplicative"`` (see the book's chapter).

    Parameters
    ----------
    r, beta, sigma_r, sigma_beta : array_like
        TRUE range and azimuth and the error standard deviations (broadcast).
        The covariance must be positive definite: ``sigma_r > 0``,
        ``sigma_beta > 0``, and ``r > 0`` for ``"linearized"``.
    method : str
        One of :data:`ALL_METHODS` (keyword-only). For ``"decorrelated"`` the prior is
        taken exactly at the truth (zero prior covariance), where its covariance is the
        exact one and the result is 2.

    Returns
    -------
    numpy.ndarray
        Shape of the broadcast inputs.

    Raises
    ------
    ValueError
        As :func:`polar_to_cartesian`; a zero `sigma_r` or `sigma_beta`, a zero
        `r` with ``"linearized"``, or a covariance numerically singular
        (principal variances in a ratio below 1e-300).

    Notes
    -----
    Both matrices have their principal axes along and across the line of sight
    :math:`u(\\beta)`, so the trace is the sum of two ratios of principal
    variances, computed without any factorisation:
    :math:`\\mathrm{MSE}_\\parallel/\\Sigma_\\parallel + \\mathrm{MSE}_\\perp/\\Sigma_\\perp`.

    Examples
    --------
    >>> round(float(nees_at_truth(150.0, 0.0, 0.1, 1e-4)), 4)
    2.0
    """
    method = as_choice(method, "method", ALL_METHODS)
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta, strict=True)
    if method == "linearized" and np.any(r == 0):
        raise ValueError("`r` must be > 0 for method 'linearized' (its covariance at zero "
                         f"range is singular); received {_describe(r)}")
    s = sigma_beta**2
    e = _scale(r, sigma_r)
    rn, sr2 = np.ldexp(r, -e), np.ldexp(sigma_r, -e) ** 2
    along_t, cross_t = _truth_variances(method, rn, sr2, s)
    if method == "decorrelated":      # a prior exactly at the truth: R^D is Cov[x̂ | r, β]
        along_c, cross_c = along_t, cross_t
    else:
        along_c, cross_c = _principal_variances(method, rn, sr2, s)
    along_m = along_t + (_bias_factor(method, s) * rn) ** 2
    tiny = np.finfo(float).tiny
    if np.any(along_c <= tiny * along_m) or np.any(cross_c <= tiny * cross_t):
        raise ValueError("the method's covariance is numerically singular for these "
                         "`sigma_r`/`sigma_beta`/`r` (a principal variance below 1e-308 of the "
                         "error's): its expected NEES is beyond the float range")
    return along_m / along_c + cross_t / cross_c


def _as_methods(methods, allowed) -> tuple[str, ...]:
    """A method name or a non-empty sequence of them, each one of `allowed`."""
    if isinstance(methods, str):
        methods = (methods,)
    if isinstance(methods, (bytes, np.ndarray)) or not hasattr(methods, "__iter__"):
        raise TypeError(f"`methods` must be a sequence of method names; received "
                        f"{_describe(methods)}")
    methods = tuple(as_choice(m, "methods", allowed) for m in methods)
    if not methods:
        raise ValueError("`methods` must name at least one method; received an empty sequence")
    return methods


def conversion_monte_carlo(r, beta, sigma_r, sigma_beta, *,
                           methods=("linearized", "additive", "multiplicative"),
                           trials: int = 10_000, rng=None,
                           chunk_size: int | None = None,
                           prior_std=None) -> dict[str, ConversionTrials]:
    """Monte Carlo of the conversion error and NEES for several methods.

    All methods see the same simulated measurements (common random numbers),
    so their differences are not blurred by independent noise.

    Parameters
    ----------
    r, beta, sigma_r, sigma_beta : array_like
        TRUE range and azimuth and the error standard deviations (broadcast
        to a batch shape ``(...)``; ``r >= 8 sigma_r``; ``sigma_r > 0`` and
        ``sigma_beta > 0``, since NEES needs a positive-definite covariance).
    methods : sequence of str
        Methods from :data:`ALL_METHODS` (keyword-only).
    trials : int
        Measurements per batch element (≥ 1; batch × trials at most
        :data:`MAX_BATCH`).
    rng : None, int, SeedSequence or numpy.random.Generator
        Randomness (SPEC 7).
    chunk_size : int, optional
        Trials converted at a time (working memory); ``None`` chooses about
        2**16 batch elements per chunk. At most :data:`MAX_BATCH`. The results
        do not depend on it: all measurements are drawn first
        (:func:`simulate_polar`), then converted chunk by chunk.
    prior_std : array_like, optional
        Required with ``"decorrelated"`` (and refused without it): the standard
        deviation, in each Cartesian axis, of the prior position, drawn independently
        per trial as ``truth + prior_std · N(0, I)`` and passed with covariance
        ``prior_std² I``. Broadcasts with the batch; ≥ 0. These draws come after
        all the measurements, so the other methods' results do not depend on it.

    Returns
    -------
    dict of str to ConversionTrials
        ``error`` with shape ``(..., trials, 2)``, ``nees`` and ``nees_true`` with
        shape ``(..., trials)`` for each method.

    Raises
    ------
    ValueError
        As :func:`simulate_polar`; a zero `sigma_r` or `sigma_beta`; an
        unknown method; an empty `methods`; a `chunk_size` below 1 or above
        :data:`MAX_BATCH`; results above 1 GiB (refused before drawing).

    Notes
    -----
    The NEES of each trial is computed in the covariance's principal axes,
    :math:`(\\mathbf e\\cdot u)^2/\\Sigma_\\parallel + (\\mathbf e\\cdot u_\\perp)^2/\\Sigma_\\perp`
    with :math:`u = u(\\hat\\beta)`, which equals :math:`\\mathbf e^\\mathsf T\\Sigma^{-1}\\mathbf e`
    and needs no factorisation.

    Examples
    --------
    >>> out = conversion_monte_carlo(150.0, 0.7, 0.1, 0.01, trials=2000, rng=3)
    >>> out["multiplicative"].mean_nees().contains(2.0)
    True
    """
    methods = _as_methods(methods, ALL_METHODS)
    trials = as_int(trials, "trials", minimum=1)
    if ("decorrelated" in methods) != (prior_std is not None):
        raise ValueError("`prior_std` is required with method 'decorrelated' and used by it "
                         f"only; received methods {methods} and prior_std {_describe(prior_std)}")
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta, strict=True,
                                             trials=trials)
    if prior_std is not None:
        prior_std = as_positive(prior_std, "prior_std", strict=False)
        _check_batch(trials, r=r, prior_std=prior_std)
        r, beta, sigma_r, sigma_beta, prior_std = broadcast(
            r=r, beta=beta, sigma_r=sigma_r, sigma_beta=sigma_beta, prior_std=prior_std)
    batch = max(int(r.size), 1)
    check_size(batch * trials * (16 + 24 * len(methods)), MEMORY_LIMIT,
               what="bytes of measurements and results (batch × trials × (16 + 24 × methods))",
               alternative="fewer trials per call, pooling calls seeded from SeedSequence.spawn")
    if chunk_size is None:
        chunk = max(1, (1 << 16) // batch)
    else:
        chunk = as_int(chunk_size, "chunk_size", minimum=1, maximum=MAX_BATCH)
    chunk = min(chunk, trials)
    rng = as_rng(rng)
    r_hat, beta_hat = simulate_polar(r, beta, sigma_r, sigma_beta, trials=trials, rng=rng)
    truth = np.stack([r * np.cos(beta), r * np.sin(beta)], axis=-1)[..., None, :]
    if prior_std is not None:      # drawn after the measurements: other methods unchanged
        prior = truth + prior_std[..., None, None] * rng.standard_normal((*r.shape, trials, 2))
        r_p, b_p, var_r, var_b = _prior_polar(
            prior, (prior_std**2)[..., None, None, None] * np.eye(2))
        if np.any(r_p == 0):
            raise ValueError("a drawn prior fell on the radar: `prior_std` is too large for "
                             "this range")
    sr, sb = sigma_r[..., None], sigma_beta[..., None]
    u_t = np.stack([np.cos(beta), np.sin(beta)], axis=-1)[..., None, :]
    out = {m: (np.empty((*r.shape, trials, 2)), np.empty((*r.shape, trials)),
               np.empty((*r.shape, trials))) for m in methods}
    u0, u1 = u_t[..., 0, 0], u_t[..., 0, 1]
    for m in methods:          # the exact MSE given the truth, in its principal axes u(β), u⊥
        mse = _moments(m, r, beta, sigma_r, sigma_beta).mse
        mse_a = mse[..., 0, 0] * u0**2 + 2 * mse[..., 0, 1] * u0 * u1 + mse[..., 1, 1] * u1**2
        mse_c = mse[..., 0, 0] * u1**2 - 2 * mse[..., 0, 1] * u0 * u1 + mse[..., 1, 1] * u0**2
        out[m] += (mse_a[..., None], mse_c[..., None])
    for lo in range(0, trials, chunk):
        sl = slice(lo, min(lo + chunk, trials))
        rh, bh = r_hat[..., sl], beta_hat[..., sl]
        u = np.stack([np.cos(bh), np.sin(bh)], axis=-1)
        for m in methods:
            if m == "decorrelated":
                xy, along, cross = _convert_decorrelated(rh, bh, sr, sb, r_p[..., sl],
                                                         var_r[..., sl], var_b[..., sl])
                axis = np.stack([np.cos(b_p[..., sl]), np.sin(b_p[..., sl])], axis=-1)
            else:
                xy, along, cross = _convert(m, rh, bh, sr, sb)
                axis = u
            err = xy - truth
            ea = np.sum(err * axis, axis=-1)                                # along the axis
            ec = err[..., 1] * axis[..., 0] - err[..., 0] * axis[..., 1]    # across it
            if np.any(along <= 0) or np.any(cross <= 0):
                raise ValueError("a converted covariance is singular (a measured range of 0 "
                                 "with 'linearized', or `sigma_r`/`sigma_beta` too small for "
                                 "float64 at these ranges)")
            out[m][0][..., sl, :] = err
            out[m][1][..., sl] = _finite_nees(ea**2 / along + ec**2 / cross)
            # against the exact MSE given the truth (principal axes along u(β), the bias on it)
            mse_a, mse_c = out[m][3], out[m][4]
            ta = np.sum(err * u_t, axis=-1)
            tc = err[..., 1] * u_t[..., 0] - err[..., 0] * u_t[..., 1]
            with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
                out[m][2][..., sl] = ta**2 / mse_a + tc**2 / mse_c
    return {m: ConversionTrials(m, v[0], v[1], v[2]) for m, v in out.items()}


# =========================================================================== 3-D
@dataclass(frozen=True)
class ConvertedMeasurement3D:
    """A converted 3-D report: Cartesian position and its covariance.

    Attributes
    ----------
    xyz : numpy.ndarray, shape (..., 3)
        Converted position in the radar's frame: x axis at azimuth 0 and elevation 0,
        azimuth counter-clockwise towards y, elevation up from the x–y plane towards z.
    cov : numpy.ndarray, shape (..., 3, 3)
        The covariance the method attaches to `xyz` (symmetric, positive semi-definite).
    method : str
        One of :data:`METHODS_3D`.
    """

    xyz: np.ndarray
    cov: np.ndarray
    method: str


def _spherical_iv(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, *, strict=False,
                  trials=1):
    """Validate and broadcast the six spherical arguments."""
    r = as_positive(r, "r", strict=False)
    beta = as_float_array(beta, "beta")
    epsilon = as_float_array(epsilon, "epsilon")
    sigma_r = as_positive(sigma_r, "sigma_r", strict=strict)
    sigma_beta = _sigma_beta_iv(sigma_beta, strict=strict)
    sigma_epsilon = as_positive(sigma_epsilon, "sigma_epsilon", strict=strict)
    if np.any(sigma_epsilon > SIGMA_BETA_MAX):
        raise ValueError(
            f"`sigma_epsilon` must be an elevation standard deviation in radians in "
            f"{'(' if strict else '['}0, {SIGMA_BETA_MAX}] (SIGMA_BETA_MAX); received largest "
            f"entry {float(np.max(sigma_epsilon)):.6g} — did you pass degrees? Use np.deg2rad.")
    _check_batch(trials * 4, r=r, beta=beta, epsilon=epsilon, sigma_r=sigma_r,
                 sigma_beta=sigma_beta, sigma_epsilon=sigma_epsilon)
    return broadcast(r=r, beta=beta, epsilon=epsilon, sigma_r=sigma_r, sigma_beta=sigma_beta,
                     sigma_epsilon=sigma_epsilon)


def _unit3(beta, eps):
    """Line of sight a(β, ε) = (cos ε cos β, cos ε sin β, sin ε), shape (..., 3)."""
    ce = np.cos(eps)
    return np.stack([ce * np.cos(beta), ce * np.sin(beta), np.sin(eps)], axis=-1)


def _damping3(sb2, se2):
    """Z = diag(ζ_β ζ_ε, ζ_β ζ_ε, ζ_ε), ζ = E cos(angle error) = e^{−σ²/2}: E[a(β+w, ε+u)] = Z a."""
    qb, qe = np.exp(-sb2 / 2), np.exp(-se2 / 2)
    return np.stack([qb * qe, qb * qe, qe], axis=-1)


def _second3(beta, eps, sb2, se2):
    """E[a aᵀ] over Gaussian angle errors of variances sb2, se2 about (β, ε), shape (..., 3, 3).

    Each product of components is a trigonometric polynomial; the error damps the harmonic
    k of an angle by e^{−k²σ²/2}:  a₁a₁ = ¼(1 + cos 2ε)(1 + cos 2β), a₁a₃ = ½ sin 2ε cos β, …"""
    c2b, s2b = np.exp(-2 * sb2) * np.cos(2 * beta), np.exp(-2 * sb2) * np.sin(2 * beta)
    c2e, s2e = np.exp(-2 * se2) * np.cos(2 * eps), np.exp(-2 * se2) * np.sin(2 * eps)
    cb, sb = np.exp(-sb2 / 2) * np.cos(beta), np.exp(-sb2 / 2) * np.sin(beta)
    out = np.empty((*np.shape(c2b), 3, 3))
    out[..., 0, 0] = 0.25 * (1 + c2e) * (1 + c2b)
    out[..., 1, 1] = 0.25 * (1 + c2e) * (1 - c2b)
    out[..., 2, 2] = 0.5 * (1 - c2e)
    out[..., 0, 1] = out[..., 1, 0] = 0.25 * (1 + c2e) * s2b
    out[..., 0, 2] = out[..., 2, 0] = 0.5 * s2e * cb
    out[..., 1, 2] = out[..., 2, 1] = 0.5 * s2e * sb
    return out


def _gain3(method, sb2, se2):
    """Per-axis gains G with x̂ = G ⊙ r̂ a(β̂, ε̂), shape (..., 3)."""
    lam = _damping3(sb2, se2)
    if method == "linearized":
        return np.ones_like(lam)
    if method == "multiplicative":          # Mo et al.: exactly unbiased given the truth
        return 1.0 / lam
    if method == "measurement_conditioned":  # Duan et al.: E[x | measurement]
        return lam
    return 1.0 + lam - lam**2               # "additive": subtract the averaged bias


def _outer(u, v):
    return u[..., :, None] * v[..., None, :]


def _spherical_cov(method, r, beta, eps, sigma_r, sb2, se2):
    """The method's covariance at the measurement (r̂, β̂, ε̂), in the units of r (scaled)."""
    a = _unit3(beta, eps)
    lam = _damping3(sb2, se2)
    sr2 = sigma_r**2
    r2 = (r**2)[..., None, None]
    if method == "linearized":              # J diag(σr², σβ², σε²) Jᵀ
        ce, se = np.cos(eps), np.sin(eps)
        jb = np.stack([-ce * np.sin(beta), ce * np.cos(beta), np.zeros_like(ce)], -1)
        je = np.stack([-se * np.cos(beta), -se * np.sin(beta), ce], -1)
        return (sr2[..., None, None] * _outer(a, a) + r2 * sb2[..., None, None] * _outer(jb, jb)
                + r2 * se2[..., None, None] * _outer(je, je))
    # Cov[x | measurement] = (r̂² + σr²) E[aaᵀ] − r̂² Zaaᵀ Z  (truth ~ N(measurement, σ²))
    la = lam * a
    cond = (r2 + sr2[..., None, None]) * _second3(beta, eps, sb2, se2) - r2 * _outer(la, la)
    if method == "measurement_conditioned":
        return cond
    if method == "multiplicative":          # MSE given the measurement: + (x̂ − E[x|z])(…)ᵀ
        d = (1.0 / lam - lam) * a
        return cond + r2 * _outer(d, d)
    # "additive": Lerro & Bar-Shalom's E[Cov(r̂a(β̂, ε̂) | truth) | measurement] — the errors
    # damp the harmonics twice, and E[r² + σr² | z] = r̂² + 2σr²
    return ((r2 + 2 * sr2[..., None, None]) * _second3(beta, eps, 2 * sb2, 2 * se2)
            - (r2 + sr2[..., None, None]) * lam[..., :, None] * _second3(beta, eps, sb2, se2)
            * lam[..., None, :])


def _unscale3(m, e, what):
    with np.errstate(over="ignore", under="ignore"):
        v = np.ldexp(m, 2 * e[..., None, None])
    if not np.all(np.isfinite(v)):
        raise ValueError(f"the {what} overflows float64 (above 1.8e308): `r`/`sigma_r` are too "
                         "large for their variances to be represented; express them in a "
                         "larger unit (km instead of m)")
    return v


def _convert3(method, r, beta, eps, sigma_r, sigma_beta, sigma_epsilon):
    sb2, se2 = sigma_beta**2, sigma_epsilon**2
    with np.errstate(over="ignore"):
        xyz = _gain3(method, sb2, se2) * r[..., None] * _unit3(beta, eps)
    if not np.all(np.isfinite(xyz)):
        raise ValueError(f"`r` is too large: the converted position overflows float64; "
                         f"received largest entry {float(np.max(r)):.6g}")
    e = _scale(r, sigma_r)
    cov = _spherical_cov(method, np.ldexp(r, -e), beta, eps, np.ldexp(sigma_r, -e), sb2, se2)
    return xyz, _unscale3(cov, e, "covariance")


def spherical_to_cartesian(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, *,
                           method: str = "linearized") -> ConvertedMeasurement3D:
    """Convert measured range, azimuth and elevation to a 3-D position and covariance.

    Parameters
    ----------
    r : array_like
        Measured range :math:`\\hat r \\ge 0`.
    beta : array_like
        Measured azimuth :math:`\\hat\\beta` in radians, counter-clockwise from the x axis.
    epsilon : array_like
        Measured elevation :math:`\\hat\\varepsilon` in radians, up from the x–y plane.
    sigma_r, sigma_beta, sigma_epsilon : array_like
        Error standard deviations (≥ 0; the angular ones in radians, at most
        :data:`SIGMA_BETA_MAX`). The errors are independent and Gaussian.
    method : str
        One of :data:`METHODS_3D` (keyword-only): ``"linearized"``, ``"additive"``,
        ``"multiplicative"``, ``"measurement_conditioned"``.

    The six arrays broadcast together to a batch shape ``(...)``.

    Returns
    -------
    ConvertedMeasurement3D
        ``xyz`` with shape ``(..., 3)`` and ``cov`` with shape ``(..., 3, 3)``.

    Raises
    ------
    ValueError
        As :func:`polar_to_cartesian` (negative `r` or deviations, angular deviations
        above :data:`SIGMA_BETA_MAX`, non-finite input, shapes that do not broadcast,
        unknown `method`, batches above :data:`MAX_BATCH`, overflow).
    TypeError
        Non-numeric input.

    Warns
    -----
    RadarFusionWarning
        When a returned covariance is singular or nearly so (zero deviations, or the
        linearized covariance at zero range or at the zenith).

    Notes
    -----
    With :math:`a(\\beta, \\varepsilon) = (\\cos\\varepsilon\\cos\\beta, \\cos\\varepsilon\\sin\\beta,
    \\sin\\varepsilon)`, :math:`q_\\beta = e^{-\\sigma_\\beta^2/2}`, :math:`q_\\varepsilon =
    e^{-\\sigma_\\varepsilon^2/2}` and :math:`\\Lambda = \\operatorname{diag}(q_\\beta q_\\varepsilon,
    q_\\beta q_\\varepsilon, q_\\varepsilon)`, the plain conversion has mean
    :math:`E[\\hat r a(\\hat\\beta, \\hat\\varepsilon) \\mid r, \\beta, \\varepsilon] = \\Lambda\\, r a`:
    its bias is :math:`(\\Lambda - I) r a`, and the vertical component is damped less than the
    horizontal ones. Every method returns :math:`\\hat{\\mathbf x} = G\\hat r a(\\hat\\beta,
    \\hat\\varepsilon)` with a diagonal gain :math:`G`: :math:`I` (linearized), :math:`I + \\Lambda -
    \\Lambda^2` (additive), :math:`\\Lambda^{-1}` (multiplicative, Mo et al. 1998, unbiased given the
    truth), :math:`\\Lambda` (measurement-conditioned, Duan et al. 2004: the mean of the truth given
    the measurement). With :math:`D_k = E[a a^\\mathsf T]` over angle errors of variances
    :math:`k\\sigma^2` about the measurement,

    .. math::

        \\operatorname{Cov}[\\mathbf x \\mid \\hat{\\mathbf z}] &= (\\hat r^2 + \\sigma_r^2) D_1
            - \\hat r^2 \\Lambda a a^\\mathsf T \\Lambda \\quad\\text{(measurement-conditioned)},\\\\
        \\mathrm{MSE} &= \\operatorname{Cov}[\\mathbf x \\mid \\hat{\\mathbf z}] + \\hat r^2
            (\\Lambda^{-1} - \\Lambda) a a^\\mathsf T (\\Lambda^{-1} - \\Lambda)
            \\quad\\text{(multiplicative)},\\\\
        \\Sigma^a &= (\\hat r^2 + 2\\sigma_r^2) D_2 - (\\hat r^2 + \\sigma_r^2)\\Lambda D_1 \\Lambda
            \\quad\\text{(additive, Lerro \\& Bar-Shalom's average of the covariance given the truth)},

    and the linearized covariance is :math:`J\\operatorname{diag}(\\sigma_r^2, \\sigma_\\beta^2,
    \\sigma_\\varepsilon^2)J^\\mathsf T` with :math:`J = \\partial(x, y, z)/\\partial(r, \\beta,
    \\varepsilon)` at the measurement. Each entry of :math:`D_k` is a trigonometric polynomial
    whose harmonic :math:`m` of an angle is damped by :math:`e^{-km^2\\sigma^2/2}`.

    In 2-D (:math:`\\varepsilon = \\sigma_\\varepsilon = 0`) every method reduces to the one of the
    same name in :func:`polar_to_cartesian`.

    References
    ----------
    Mo, Song et al. (1998), the spherical unbiased conversion; Duan, Han & Li (2004), the
    modified (measurement-conditioned) one; Lerro & Bar-Shalom (1993) for the additive
    averaging, carried to 3-D as in Suchomski (1999).

    Examples
    --------
    >>> out = spherical_to_cartesian(100.0, 0.0, 0.0, 0.1, 0.01, 0.01)
    >>> out.xyz.round(3)
    array([100.,   0.,   0.])
    >>> np.diag(out.cov).round(4)
    array([0.01, 1.  , 1.  ])
    """
    method = as_choice(method, "method", METHODS_3D)
    args = _spherical_iv(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon)
    xyz, cov = _convert3(method, *args)
    _warn_singular3(cov, method)
    return ConvertedMeasurement3D(xyz, cov, method)


def _warn_singular3(cov, method):
    ev = np.linalg.eigvalsh(cov) if cov.size else np.zeros((0, 3))
    bad = ev[..., 0] <= 1e-12 * np.maximum(ev[..., -1], np.finfo(float).tiny)
    if np.any(bad):
        warnings.warn(
            f"{int(np.count_nonzero(bad))} of {bad.size} covariances from method {method!r} are "
            "singular or nearly so (zero range or elevation ±90° with 'linearized', or a zero "
            "or tiny deviation); a Cholesky factorisation of them will fail",
            RadarFusionWarning, stacklevel=3)


def spherical_moments(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, *,
                      method: str = "linearized") -> ConversionMoments:
    """Exact mean, bias, covariance and MSE of a converted 3-D report given the TRUTH.

    Parameters
    ----------
    r, beta, epsilon : array_like
        TRUE range (≥ 0), azimuth and elevation (radians).
    sigma_r, sigma_beta, sigma_epsilon : array_like
        Error standard deviations, as in :func:`spherical_to_cartesian`.
    method : str
        One of :data:`METHODS_3D` (keyword-only).

    Returns
    -------
    ConversionMoments
        With ``mean`` and ``bias`` of shape ``(..., 3)``, ``cov`` and ``mse`` of shape
        ``(..., 3, 3)``.

    Raises
    ------
    ValueError
        As :func:`spherical_to_cartesian`.

    Notes
    -----
    .. math::

        E[\\hat{\\mathbf x}] = G\\Lambda\\, r a(\\beta, \\varepsilon),\\qquad
        \\operatorname{Cov}[\\hat{\\mathbf x}] = G\\left[(r^2 + \\sigma_r^2) D_1
            - r^2\\Lambda a a^\\mathsf T\\Lambda\\right] G,

    with :math:`D_1 = E[a a^\\mathsf T]` about the truth (see :func:`spherical_to_cartesian`).
    The multiplicative gain :math:`G = \\Lambda^{-1}` makes the bias vanish.

    Examples
    --------
    >>> m = spherical_moments(100.0, 0.3, 0.2, 0.1, 0.05, 0.05, method="multiplicative")
    >>> bool(np.abs(m.bias).max() < 1e-12)
    True
    """
    method = as_choice(method, "method", METHODS_3D)
    r, beta, eps, sigma_r, sigma_beta, sigma_epsilon = _spherical_iv(
        r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon)
    return _moments3(method, r, beta, eps, sigma_r, sigma_beta, sigma_epsilon)


def _moments3(method, r, beta, eps, sigma_r, sigma_beta, sigma_epsilon):
    sb2, se2 = sigma_beta**2, sigma_epsilon**2
    a = _unit3(beta, eps)
    lam = _damping3(sb2, se2)
    g = _gain3(method, sb2, se2)
    mean_xyz = (g * lam) * r[..., None] * a
    bias = (g * lam - 1.0) * r[..., None] * a
    if method == "multiplicative":
        bias = np.zeros_like(bias)
    e = _scale(r, sigma_r)
    rn, srn = np.ldexp(r, -e), np.ldexp(sigma_r, -e)
    la = lam * a
    cov = ((rn**2 + srn**2)[..., None, None] * _second3(beta, eps, sb2, se2)
           - (rn**2)[..., None, None] * _outer(la, la))
    cov = g[..., :, None] * cov * g[..., None, :]
    bn = (g * lam - 1.0) * rn[..., None] * a if method != "multiplicative" else 0.0 * a
    mse = cov + _outer(bn, bn)
    return ConversionMoments(mean_xyz, bias, _unscale3(cov, e, "covariance"),
                             _unscale3(mse, e, "mean squared error"), method)


def simulate_spherical(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, *, trials: int,
                       rng=None):
    """Draw noisy (range, azimuth, elevation) measurements of true positions.

    Parameters
    ----------
    r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon : array_like
        TRUE range, azimuth and elevation and the error standard deviations (broadcast to
        a batch shape ``(...)``; ``r >= 8 sigma_r``).
    trials : int
        Measurements per batch element (≥ 1).
    rng : None, int, SeedSequence or numpy.random.Generator
        Randomness (SPEC 7).

    Returns
    -------
    r_hat, beta_hat, epsilon_hat : numpy.ndarray, shape (..., trials)

    Raises
    ------
    ValueError
        As :func:`spherical_to_cartesian`; ``r < 8 sigma_r``; a batch × `trials` above
        :data:`MAX_BATCH`.
    TypeError
        Non-numeric input or an invalid `rng`.

    Notes
    -----
    Range deviates are drawn first, then azimuth, then elevation deviates, each in C order
    of the shape ``(..., trials)``.

    Examples
    --------
    >>> rh, bh, eh = simulate_spherical(100.0, 0.3, 0.1, 0.1, 0.01, 0.01, trials=4, rng=1)
    >>> eh.shape
    (4,)
    """
    trials = as_int(trials, "trials", minimum=1)
    r, beta, eps, sigma_r, sigma_beta, sigma_epsilon = _spherical_iv(
        r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, trials=trials)
    rng = as_rng(rng)
    r_hat, beta_hat = _draw_range_azimuth(r, beta, sigma_r, sigma_beta, trials, rng)
    eps_hat = eps[..., None] + sigma_epsilon[..., None] * rng.standard_normal(r_hat.shape)
    return r_hat, beta_hat, eps_hat


def spherical_monte_carlo(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, *,
                          methods=METHODS_3D, trials: int = 10_000,
                          rng=None) -> dict[str, ConversionTrials]:
    """Monte Carlo of the 3-D conversion error, NEES and NEES against the true MSE.

    All methods see the same simulated measurements (common random numbers).

    Parameters
    ----------
    r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon : array_like
        TRUE position and error standard deviations (broadcast; ``r >= 8 sigma_r``;
        every deviation > 0).
    methods : sequence of str
        Methods from :data:`METHODS_3D` (keyword-only).
    trials : int
        Measurements per batch element (≥ 1).
    rng : None, int, SeedSequence or numpy.random.Generator
        Randomness (SPEC 7).

    Returns
    -------
    dict of str to ConversionTrials
        ``error`` with shape ``(..., trials, 3)``, ``nees`` and ``nees_true`` with shape
        ``(..., trials)``; a consistent method has mean NEES 3.

    Raises
    ------
    ValueError
        As :func:`simulate_spherical`; a zero deviation; an unknown or empty `methods`;
        results above 1 GiB (refused before drawing).
    TypeError
        Non-numeric input, a non-integer `trials`, a bad `rng`.

    Examples
    --------
    >>> out = spherical_monte_carlo(100.0, 0.3, 0.2, 0.1, 0.01, 0.01, trials=2000, rng=3)
    >>> out["multiplicative"].mean_nees().contains(3.0)
    True
    """
    methods = _as_methods(methods, METHODS_3D)
    trials = as_int(trials, "trials", minimum=1)
    r, beta, eps, sigma_r, sigma_beta, sigma_epsilon = _spherical_iv(
        r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, strict=True, trials=trials)
    batch = max(int(r.size), 1)
    check_size(batch * trials * (24 + 40 * len(methods)), MEMORY_LIMIT,
               what="bytes of measurements and results (batch × trials × (24 + 40 × methods))",
               alternative="fewer trials per call, pooling calls seeded from SeedSequence.spawn")
    rh, bh, eh = simulate_spherical(r, beta, eps, sigma_r, sigma_beta, sigma_epsilon,
                                    trials=trials, rng=rng)
    truth = (r[..., None] * _unit3(beta, eps))[..., None, :]
    sr, sb, se = sigma_r[..., None], sigma_beta[..., None], sigma_epsilon[..., None]
    out = {}
    for m in methods:
        xyz, cov = _convert3(m, rh, bh, eh, sr, sb, se)
        err = xyz - truth
        mse = _moments3(m, r, beta, eps, sigma_r, sigma_beta, sigma_epsilon).mse[..., None, :, :]
        out[m] = ConversionTrials(m, err, nees(err, cov), nees(err, mse))
    return out
