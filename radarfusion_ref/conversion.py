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
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ._validation import (
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_rng,
    broadcast,
)
from .errors import RadarFusionWarning
from .montecarlo import MeanEstimate, mean

__all__ = [
    "LERRO_THRESHOLD",
    "METHODS",
    "SIGMA_BETA_MAX",
    "ConversionMoments",
    "ConversionTrials",
    "ConvertedMeasurement",
    "conversion_bias",
    "conversion_moments",
    "conversion_monte_carlo",
    "nees",
    "nees_at_truth",
    "nonlinearity_index",
    "polar_to_cartesian",
    "simulate_polar",
]

#: The conversion methods accepted by :func:`polar_to_cartesian`.
METHODS = ("linearized", "additive", "multiplicative", "first_order", "first_order_printed")

#: Largest azimuth standard deviation accepted (radians, ≈ 28.6°). See :func:`polar_to_cartesian`.
SIGMA_BETA_MAX = 0.5

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
        covariance :math:`C`; its mean is 2 for a consistent method.
    """

    method: str
    error: np.ndarray
    nees: np.ndarray

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


# --------------------------------------------------------------------------- validation
def _polar_iv(r, beta, sigma_r, sigma_beta):
    """Validate and broadcast the four polar arguments (shared by the public functions)."""
    r = as_positive(r, "r", strict=False)
    beta = as_float_array(beta, "beta")
    sigma_r = as_positive(sigma_r, "sigma_r", strict=False)
    sigma_beta = _sigma_beta_iv(sigma_beta)
    return broadcast(r=r, beta=beta, sigma_r=sigma_r, sigma_beta=sigma_beta)


def _sigma_beta_iv(sigma_beta):
    sigma_beta = as_positive(sigma_beta, "sigma_beta", strict=False)
    if np.any(sigma_beta > SIGMA_BETA_MAX):
        raise ValueError(
            f"`sigma_beta` must be an azimuth standard deviation in radians in "
            f"[0, {SIGMA_BETA_MAX}] (SIGMA_BETA_MAX); received largest entry "
            f"{float(np.max(sigma_beta)):.6g} — did you pass degrees? Use np.deg2rad."
        )
    return sigma_beta


# --------------------------------------------------------------------------- building blocks
def _gain(method: str, s: np.ndarray) -> np.ndarray:
    """Scalar factor g with converted position = g · r̂ (cos β̂, sin β̂); s = σβ²."""
    lam = np.exp(-s / 2)
    if method == "linearized":
        return np.ones_like(s)
    if method == "additive":          # r̂u − r̂u(e^{−s} − e^{−s/2})
        return 1.0 + lam - lam**2
    if method == "multiplicative":    # e^{s/2} r̂u
        return 1.0 / lam
    if method == "first_order":       # eq. (3) with the derived sign
        return 1.0 + s / 2
    return 1.0 - s / 2                # "first_order_printed": eq. (3) as printed


def _am_matrix(a, b, beta):
    """Stack a I + b M(β), M = [[cos 2β, sin 2β], [sin 2β, −cos 2β]], shape (..., 2, 2)."""
    c2, s2 = np.cos(2 * beta), np.sin(2 * beta)
    out = np.empty((*np.shape(a), 2, 2))
    out[..., 0, 0] = a + b * c2
    out[..., 1, 1] = a - b * c2
    out[..., 0, 1] = out[..., 1, 0] = b * s2
    return out


def _cov_coefficients(method, r, sr2, s):
    """(a, b) of the method's covariance a I + b M(β̂), evaluated at the measurement."""
    lam2 = np.exp(-s)          # (E cos w)^2
    q = np.exp(-2 * s)         # E cos 2w
    if method == "linearized":                        # eq. (2a–c)
        return 0.5 * (sr2 + r**2 * s), 0.5 * (sr2 - r**2 * s)
    if method == "multiplicative":                    # Mo et al., measured-conditioned
        k = (1.0 / lam2 - 2.0) * r**2
        return 0.5 * k + 0.5 * (r**2 + sr2), 0.5 * k + 0.5 * (r**2 + sr2) * q
    # additive / first_order / first_order_printed: eq. (4a–c), Lerro & Bar-Shalom R^a
    a = 0.5 * (r**2 + 2 * sr2) - 0.5 * (r**2 + sr2) * lam2
    b = 0.5 * (r**2 + 2 * sr2) * q**2 - 0.5 * (r**2 + sr2) * lam2 * q
    return a, b


def _warn_singular(cov, method):
    a = 0.5 * (cov[..., 0, 0] + cov[..., 1, 1])
    det = cov[..., 0, 0] * cov[..., 1, 1] - cov[..., 0, 1] ** 2
    disc = np.sqrt(np.maximum(a**2 - det, 0.0))
    low, high = a - disc, a + disc
    bad = low <= 1e-12 * high
    if np.any(bad):
        warnings.warn(
            f"{int(np.count_nonzero(bad))} of {bad.size} covariances from method "
            f"{method!r} are singular (zero range with 'linearized', or a zero "
            "`sigma_r`/`sigma_beta`); a Cholesky factorisation of them will fail",
            RadarFusionWarning, stacklevel=3)


# --------------------------------------------------------------------------- public API
def polar_to_cartesian(r, beta, sigma_r, sigma_beta, *, method: str = "linearized"
                       ) -> ConvertedMeasurement:
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
    method : {"linearized", "additive", "multiplicative", "first_order", "first_order_printed"}
        The conversion (keyword-only); see the module docstring.

    The four arrays broadcast together to a batch shape ``(...)``.

    Returns
    -------
    ConvertedMeasurement
        ``xy`` with shape ``(..., 2)`` and ``cov`` with shape ``(..., 2, 2)``.

    Raises
    ------
    ValueError
        Negative `r`, `sigma_r` or `sigma_beta`; `sigma_beta` above
        :data:`SIGMA_BETA_MAX`; non-finite input; shapes that do not broadcast;
        unknown `method`.
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
    :math:`\\lambda = e^{-s/2} = E\\cos\\tilde\\beta`, every method returns
    :math:`\\hat{\\mathbf x} = g\\,\\hat r u` with gain :math:`g = 1` (linearized),
    :math:`1 + \\lambda - \\lambda^2` (additive), :math:`\\lambda^{-1}`
    (multiplicative), :math:`1 \\pm s/2` (first order, derived / printed).
    The covariances, written as :math:`aI + bM(\\hat\\beta)`:

    .. math::

        \\text{linearized (2a–c)}:\\quad & a = \\tfrac12(\\sigma_r^2 + \\hat r^2 s),\\;
            b = \\tfrac12(\\sigma_r^2 - \\hat r^2 s)\\\\
        \\text{(4a–c)}:\\quad & a = \\tfrac12(\\hat r^2 + 2\\sigma_r^2) - \\tfrac12(\\hat r^2 + \\sigma_r^2)e^{-s},\\;
            b = \\tfrac12(\\hat r^2 + 2\\sigma_r^2)e^{-4s} - \\tfrac12(\\hat r^2 + \\sigma_r^2)e^{-3s}\\\\
        \\text{multiplicative}:\\quad & a = \\tfrac12(e^{s} - 2)\\hat r^2 + \\tfrac12(\\hat r^2 + \\sigma_r^2),\\;
            b = \\tfrac12(e^{s} - 2)\\hat r^2 + \\tfrac12(\\hat r^2 + \\sigma_r^2)e^{-2s}.

    (4a–c) is Lerro & Bar-Shalom's :math:`E[\\operatorname{Cov}(\\hat{\\mathbf x}\\mid r,\\beta)\\mid
    \\hat r, \\hat\\beta]` (true-conditioned covariance averaged over the truth
    given the measurement); the multiplicative covariance is
    :math:`E[(\\hat{\\mathbf x} - \\mathbf x)(\\hat{\\mathbf x} - \\mathbf x)^\\mathsf T\\mid
    \\hat r, \\hat\\beta]`. Both treat the truth as :math:`r \\sim \\mathcal N(\\hat r, \\sigma_r^2)`,
    :math:`\\beta \\sim \\mathcal N(\\hat\\beta, \\sigma_\\beta^2)` given the measurement.

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
    Mo, Song et al. (1998).

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
    method = as_choice(method, "method", METHODS)
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta)
    s = sigma_beta**2
    g = _gain(method, s)
    xy = np.stack([g * r * np.cos(beta), g * r * np.sin(beta)], axis=-1)
    a, b = _cov_coefficients(method, r, sigma_r**2, s)
    cov = _am_matrix(a, b, beta)
    _warn_singular(cov, method)
    return ConvertedMeasurement(xy, cov, method)


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
        One of :data:`METHODS` (keyword-only).

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
    :func:`polar_to_cartesian`). With :math:`E\\cos k\\tilde\\beta = e^{-k^2 s/2}`,
    :math:`E\\sin k\\tilde\\beta = 0`, :math:`E\\hat r^2 = r^2 + \\sigma_r^2`:

    .. math::

        E[\\hat{\\mathbf x}] = g\\lambda\\, r u(\\beta),\\qquad
        \\operatorname{Cov}[\\hat{\\mathbf x}] = g^2\\left[\\tfrac12(r^2 + \\sigma_r^2)
        (I + e^{-2s}M(\\beta)) - \\tfrac12\\lambda^2 r^2 (I + M(\\beta))\\right].

    These are conditioned on the true position; the covariances that
    :func:`polar_to_cartesian` attaches are evaluated at the measurement
    instead, so they are random.

    Examples
    --------
    >>> m = conversion_moments(150.0, 0.0, 0.1, 0.05, method="multiplicative")
    >>> bool(np.abs(m.bias).max() < 1e-12)
    True
    """
    method = as_choice(method, "method", METHODS)
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta)
    s = sigma_beta**2
    g = _gain(method, s)
    lam = np.exp(-s / 2)
    u = np.stack([np.cos(beta), np.sin(beta)], axis=-1)
    mean_xy = (g * lam * r)[..., None] * u
    bias = ((g * lam - 1.0) * r)[..., None] * u
    e2 = r**2 + sigma_r**2
    a = g**2 * (0.5 * e2 - 0.5 * lam**2 * r**2)
    b = g**2 * (0.5 * e2 * np.exp(-2 * s) - 0.5 * lam**2 * r**2)
    cov = _am_matrix(a, b, beta)
    mse = cov + bias[..., :, None] * bias[..., None, :]
    return ConversionMoments(mean_xy, bias, cov, mse, method)


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
        One of :data:`METHODS`; the default ``"linearized"`` is conversion (1).

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
    return conversion_moments(r, beta, 0.0, sigma_beta, method=method).bias


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

    Examples
    --------
    >>> float(nonlinearity_index(150.0, 0.1, np.deg2rad(1.0))).__round__(3)
    0.457
    """
    r = as_positive(r, "r", strict=False)
    sigma_r = as_positive(sigma_r, "sigma_r")
    sigma_beta = _sigma_beta_iv(sigma_beta)
    r, sigma_r, sigma_beta = broadcast(r=r, sigma_r=sigma_r, sigma_beta=sigma_beta)
    return r * sigma_beta**2 / sigma_r


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

    Examples
    --------
    >>> r_hat, b_hat = simulate_polar([100.0, 150.0], 0.3, 0.1, 0.01, trials=5, rng=1)
    >>> r_hat.shape
    (2, 5)
    """
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta)
    trials = as_int(trials, "trials", minimum=1)
    rng = as_rng(rng)
    if np.any(r < MIN_RANGE_OVER_SIGMA * sigma_r):
        raise ValueError(
            f"`r` must be at least {MIN_RANGE_OVER_SIGMA:g} `sigma_r` so that the Gaussian "
            f"range error never produces a negative range; received smallest r/sigma_r "
            f"{float(np.min(r / np.where(sigma_r > 0, sigma_r, np.inf))):.4g}")
    shape = (*r.shape, trials)
    r_hat = r[..., None] + sigma_r[..., None] * rng.standard_normal(shape)
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
    c = as_float_array(cov, "cov", ndim_min=2, last_dims=(d, d))
    try:
        shape = np.broadcast_shapes(e.shape[:-1], c.shape[:-2])
    except ValueError:
        raise ValueError(
            f"`error` (..., d) and `cov` (..., d, d) must have broadcasting batch shapes; "
            f"received shapes {e.shape} and {c.shape}") from None
    if d != 2:
        chol = np.linalg.cholesky(np.broadcast_to(as_covariance(c, "cov"), (*shape, d, d)))
        z = np.linalg.solve(chol, np.broadcast_to(e, (*shape, d))[..., None])[..., 0]
        return np.sum(z**2, axis=-1)
    # d = 2: the Cholesky factor in closed form (fast on millions of trials)
    c00, c01, c10, c11 = c[..., 0, 0], c[..., 0, 1], c[..., 1, 0], c[..., 1, 1]
    scale = np.maximum(np.abs(c).max(axis=(-2, -1)), np.finfo(float).tiny)
    with np.errstate(invalid="ignore", divide="ignore"):
        l00 = np.sqrt(c00)
        l10 = c10 / l00
        schur = c11 - l10**2
        ok = (c00 > 0) & (schur > 0) & (np.abs(c01 - c10) <= 1e-9 * scale)
    if not np.all(ok):
        as_covariance(c, "cov", dim=2)     # raises the package's standard message
        raise ValueError("`cov` must be symmetric positive definite; the Cholesky "
                         "factorisation failed for some matrices")
    z0 = e[..., 0] / l00
    z1 = (e[..., 1] - l10 * z0) / np.sqrt(schur)
    return z0**2 + z1**2


def nees_at_truth(r, beta, sigma_r, sigma_beta, *, method: str = "linearized") -> np.ndarray:
    """Expected NEES when the method's covariance is evaluated at the TRUE position.

    :math:`\\operatorname{tr}\\big(C(r, \\beta)^{-1}\\,\\mathrm{MSE}(r, \\beta)\\big)`, with
    :math:`C` the covariance :func:`polar_to_cartesian` would attach to a report
    lying exactly at the truth and MSE the exact mean squared error matrix of
    :func:`conversion_moments`. It is 2 when :math:`C` is the true MSE. In
    practice :math:`C` is evaluated at the measurement, and the Monte-Carlo mean
    NEES of :func:`conversion_monte_carlo` is the relevant figure; the two
    agree for ``"linearized"`` but not for the measured-conditioned covariances
    of ``"additive"`` and ``"multiplicative"`` (see the book's chapter).

    Parameters
    ----------
    r, beta, sigma_r, sigma_beta : array_like
        TRUE range and azimuth and the error standard deviations (broadcast).
    method : str
        One of :data:`METHODS` (keyword-only).

    Returns
    -------
    numpy.ndarray
        Shape of the broadcast inputs.

    Examples
    --------
    >>> round(float(nees_at_truth(150.0, 0.0, 0.1, 1e-4)), 4)
    2.0
    """
    conv = polar_to_cartesian(r, beta, sigma_r, sigma_beta, method=method)
    mse = conversion_moments(r, beta, sigma_r, sigma_beta, method=method).mse
    chol = np.linalg.cholesky(conv.cov)
    half = np.linalg.solve(chol, mse)                       # L⁻¹ MSE
    inner = np.linalg.solve(chol, np.swapaxes(half, -1, -2))  # L⁻¹ (L⁻¹ MSE)ᵀ = L⁻¹ MSE L⁻ᵀ
    return np.trace(inner, axis1=-2, axis2=-1)


def conversion_monte_carlo(r, beta, sigma_r, sigma_beta, *,
                           methods=("linearized", "additive", "multiplicative"),
                           trials: int = 10_000, rng=None) -> dict[str, ConversionTrials]:
    """Monte Carlo of the conversion error and NEES for several methods.

    All methods see the same simulated measurements (common random numbers),
    so their differences are not blurred by independent noise.

    Parameters
    ----------
    r, beta, sigma_r, sigma_beta : array_like
        TRUE range and azimuth and the error standard deviations (broadcast
        to a batch shape ``(...)``; ``r >= 8 sigma_r``).
    methods : sequence of str
        Methods from :data:`METHODS` (keyword-only).
    trials : int
        Measurements per batch element.
    rng : None, int, SeedSequence or numpy.random.Generator
        Randomness (SPEC 7).

    Returns
    -------
    dict of str to ConversionTrials
        ``error`` with shape ``(..., trials, 2)`` and ``nees`` with shape
        ``(..., trials)`` for each method.

    Examples
    --------
    >>> out = conversion_monte_carlo(150.0, 0.7, 0.1, 0.01, trials=2000, rng=3)
    >>> out["multiplicative"].mean_nees().contains(2.0)
    True
    """
    if isinstance(methods, str):
        methods = (methods,)
    methods = tuple(as_choice(m, "methods", METHODS) for m in methods)
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta)
    r_hat, beta_hat = simulate_polar(r, beta, sigma_r, sigma_beta, trials=trials, rng=rng)
    truth = np.stack([r * np.cos(beta), r * np.sin(beta)], axis=-1)[..., None, :]
    out = {}
    for m in methods:
        conv = polar_to_cartesian(r_hat, beta_hat, sigma_r[..., None], sigma_beta[..., None],
                                  method=m)
        err = conv.xy - truth
        out[m] = ConversionTrials(m, err, nees(err, conv.cov))
    return out
