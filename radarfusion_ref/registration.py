"""Registration: systematic range and azimuth biases of radars, and their estimation.

Each radar :math:`i` at a known site :math:`s_i` measures the range and azimuth
of an object at :math:`x` with a **range offset** :math:`\\Delta r_i`, a **range
scale** error :math:`g_i` and an **azimuth offset**
:math:`\\Delta\\beta_i` added to the random errors of the conversion chapter:

.. math::

    \\hat r_i = (1 + g_i)\\, r_i + \\Delta r_i + v_i, \\qquad
    \\hat\\beta_i = \\beta_i + \\Delta\\beta_i + w_i,

with :math:`r_i = \\lVert x - s_i\\rVert`, :math:`\\beta_i` the azimuth of
:math:`x - s_i` (radians, counter-clockwise from the x axis, as in
:mod:`radarfusion_ref.conversion`), :math:`v_i \\sim \\mathcal N(0, \\sigma_{r,i}^2)`
and :math:`w_i \\sim \\mathcal N(0, \\sigma_{\\beta,i}^2)`. The bias vector of
radar :math:`i` is :math:`b_i = (\\Delta r_i, g_i, \\Delta\\beta_i)`;
arrays of biases have a last axis of length 3 in that order
(:data:`BIAS_NAMES`). Polar reports are arrays whose last axis holds
:math:`(\\hat r, \\hat\\beta)`.

Contents:

* the model: :func:`apply_biases`, :func:`remove_biases`, :func:`true_polar`,
  :func:`simulate_reports`, :func:`to_cartesian`, :func:`bias_displacement`;
* its effect on association: :func:`noncentrality` (the proximity measure of a
  *true* pair becomes :math:`\\chi'^2_2(\\lambda)`) and :func:`cost_matrix`;
* estimation from associated reports: :func:`bias_information` (Fisher
  information of the biases with the object positions as nuisance
  parameters), :func:`observability` (its rank and unobservable combinations),
  :func:`estimate_biases` (maximum likelihood by Gauss–Newton);
* joint registration and association: :func:`register_and_associate`.

.. rubric:: References

.. [1] Y. Zhou, H. Leung, P. C. Yip, "An exact maximum likelihood registration
   algorithm for data fusion", IEEE Trans. Signal Processing 45(6) (1997)
   1560–1573.
.. [2] N. N. Okello, B. Ristic, "Maximum likelihood registration for
   multiple dissimilar sensors", IEEE Trans. AES 39(3) (2003) 1074–1083.
.. [3] Y. Bar-Shalom, X. R. Li, T. Kirubarajan, *Estimation with Applications
   to Tracking and Navigation*, Wiley 2001, sections 2.7 (Fisher information,
   CRLB) and 3.4 (nonlinear least squares, Gauss–Newton).
.. [4] B. Triggs, P. McLauchlan, R. Hartley, A. Fitzgibbon, "Bundle
   adjustment — a modern synthesis", LNCS 1883 (2000) — the elimination of
   the per-object parameters (Schur complement) used here.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from . import association, conversion, gating
from .engine._validation import (
    MEMORY_LIMIT,
    _describe,
    as_choice,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    as_rng,
    check_size,
)
from .engine.errors import RadarFusionWarning
from .engine.montecarlo import proportion
from .proximity import mahalanobis_sq

__all__ = [
    "BIAS_NAMES",
    "AccuracyComparison",
    "BiasEstimate",
    "BiasedScene",
    "Observability",
    "Registration",
    "RegistrationError",
    "RegistrationStep",
    "apply_biases",
    "association_accuracy",
    "bias_displacement",
    "bias_information",
    "cost_matrix",
    "estimate_biases",
    "noncentrality",
    "observability",
    "register_and_associate",
    "remove_biases",
    "simulate_reports",
    "simulate_scene",
    "to_cartesian",
    "true_polar",
]

#: Names of the three biases of one radar, in the order of the last axis.
BIAS_NAMES = ("range_offset", "range_scale", "azimuth_offset")
#: Largest number of radars in one problem.
MAX_RADARS = 64
#: Largest number of batch elements × radars × objects handled in one call.
MAX_ELEMENTS = MEMORY_LIMIT // 512
#: Relative eigenvalue below which the (scaled) bias information counts as singular.
RANK_TOL = 1e-9


# --------------------------------------------------------------------------- validation
def _sensors_iv(sensors, name: str = "sensors") -> np.ndarray:
    s = as_float_array(sensors, name, ndim_min=2, last_dims=(None, 2))
    if s.ndim != 2:
        raise ValueError(f"`{name}` must have shape (m, 2), one site per radar; received "
                         f"shape {s.shape}")
    as_int(s.shape[0], f"number of radars in `{name}`", minimum=1, maximum=MAX_RADARS)
    return s


def _sigmas_iv(sigma_r, sigma_beta, m: int) -> tuple[np.ndarray, np.ndarray]:
    out = []
    for value, name in ((sigma_r, "sigma_r"), (sigma_beta, "sigma_beta")):
        a = as_positive(value, name)
        if a.ndim > 1 or (a.ndim == 1 and a.shape[0] not in (1, m)):
            raise ValueError(f"`{name}` must be a number or one number per radar, shape ({m},); "
                             f"received {_describe(a)}")
        out.append(np.broadcast_to(a, (m,)).astype(float))
    if np.any(out[1] > conversion.SIGMA_BETA_MAX):
        raise ValueError(f"`sigma_beta` must be at most {conversion.SIGMA_BETA_MAX} rad; "
                         f"received {_describe(sigma_beta)}")
    return out[0], out[1]


def _biases_iv(biases, name: str = "biases") -> np.ndarray:
    b = as_float_array(biases, name, ndim_min=1, last_dims=(3,))
    if np.any(b[..., 1] <= -1.0):
        raise ValueError(f"`{name}`: the range scale error (entry [..., 1]) must be > -1 so "
                         f"that ranges stay positive; received {_describe(b)}")
    if np.any(np.abs(b[..., 2]) > np.pi):
        raise ValueError(f"`{name}`: the azimuth offset (entry [..., 2]) must lie in "
                         f"[-pi, pi] rad; received {_describe(b)}")
    return b


def _radar_biases_iv(biases, m: int, name: str = "biases") -> np.ndarray:
    b = _biases_iv(biases, name)
    if b.ndim < 2 or b.shape[-2] != m:
        raise ValueError(f"`{name}` must have shape (..., {m}, 3), one (range offset, range "
                         f"scale, azimuth offset) per radar; received shape {b.shape}")
    return b


def _fixed_iv(fixed, m: int) -> np.ndarray:
    if fixed is None:
        return np.zeros((m, 3), dtype=bool)
    arr = np.asarray(fixed)
    if arr.dtype != bool:
        raise TypeError(f"`fixed` must be a boolean array of shape ({m}, 3) (True = bias known "
                        f"to be zero); received {_describe(fixed)}")
    if arr.shape != (m, 3):
        raise ValueError(f"`fixed` must have shape ({m}, 3); received shape {arr.shape}")
    if arr.all():
        raise ValueError("`fixed` holds every bias fixed: nothing is left to estimate")
    return arr


def _polar_reports_iv(reports, name: str, m: int | None = None) -> np.ndarray:
    z = as_float_array(reports, name, ndim_min=2, last_dims=(None, 2))
    if np.any(z[..., 0] <= 0):
        raise ValueError(f"`{name}`: ranges (entry [..., 0]) must be > 0; received "
                         f"{_describe(z)}")
    if m is not None and (z.ndim < 3 or z.shape[-3] != m):
        raise ValueError(f"`{name}` must have shape (..., {m}, n, 2): per radar, n reports of "
                         f"(range, azimuth); received shape {z.shape}")
    return z


def _targets_iv(targets, sensors: np.ndarray, name: str = "targets") -> np.ndarray:
    t = as_float_array(targets, name, ndim_min=2, last_dims=(None, 2))
    d = t[..., None, :, :] - sensors[:, None, :]
    if np.any(np.hypot(d[..., 0], d[..., 1]) <= 0):
        raise ValueError(f"`{name}`: an object sits exactly on a radar site (zero range); "
                         f"received {_describe(t)}")
    return t


def _elements(count: int, name: str) -> None:
    check_size(count, MAX_ELEMENTS, what=f"batch elements x radars x objects (`{name}`)",
               alternative="fewer trials per call (split the batch)")


def _wrap(angle):
    """Angle wrapped to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


# --------------------------------------------------------------------------- the model
def apply_biases(r, beta, biases):
    """Biased range and azimuth of true polar coordinates.

    Parameters
    ----------
    r : array_like
        True ranges :math:`r > 0`.
    beta : array_like
        True azimuths :math:`\\beta` in radians (counter-clockwise from x).
    biases : array_like, shape (..., 3)
        :math:`(\\Delta r, g, \\Delta\\beta)`: range offset (unit of
        `r`), range scale error (dimensionless, > -1), azimuth offset (rad).
        Its leading axes broadcast against those of `r` and `beta`.

    Returns
    -------
    r_biased, beta_biased : numpy.ndarray

    Raises
    ------
    ValueError
        Non-positive `r`, a scale error ≤ -1, an azimuth offset beyond ±π,
        non-finite entries or shapes that do not broadcast.
    TypeError
        Non-numeric input.

    Notes
    -----
    .. math::

        r^{b} = (1 + g)\\, r + \\Delta r, \\qquad \\beta^{b} = \\beta + \\Delta\\beta .

    Examples
    --------
    >>> apply_biases(100.0, 0.5, [0.2, 1e-3, 0.01])
    (array(100.3), array(0.51))
    """
    r = as_positive(r, "r")
    beta = as_float_array(beta, "beta")
    b = _biases_iv(biases)
    try:
        out = ((1.0 + b[..., 1]) * r + b[..., 0], beta + b[..., 2])
    except ValueError:
        raise ValueError(f"`r`, `beta` and `biases[..., :]` must broadcast; received shapes "
                         f"{r.shape}, {beta.shape}, {b.shape}") from None
    return tuple(np.asarray(o) for o in np.broadcast_arrays(*out))


def remove_biases(r_hat, beta_hat, biases):
    """Correct measured ranges and azimuths for known biases (the inverse of :func:`apply_biases`).

    Parameters
    ----------
    r_hat, beta_hat : array_like
        Measured range (> 0) and azimuth (rad).
    biases : array_like, shape (..., 3)
        :math:`(\\Delta r, g, \\Delta\\beta)`, broadcasting as in
        :func:`apply_biases`.

    Returns
    -------
    r_corrected, beta_corrected : numpy.ndarray

    Raises
    ------
    ValueError, TypeError
        As :func:`apply_biases`; also when a corrected range is not positive.

    Notes
    -----
    .. math::

        r = (\\hat r - \\Delta r)/(1 + g), \\qquad \\beta = \\hat\\beta - \\Delta\\beta .

    Examples
    --------
    >>> rb, bb = apply_biases(100.0, 0.5, [0.2, 1e-3, 0.01])
    >>> [round(float(v), 12) for v in remove_biases(rb, bb, [0.2, 1e-3, 0.01])]
    [100.0, 0.5]
    """
    r = as_positive(r_hat, "r_hat")
    beta = as_float_array(beta_hat, "beta_hat")
    b = _biases_iv(biases)
    try:
        rc = (r - b[..., 0]) / (1.0 + b[..., 1])
        bc = beta - b[..., 2]
    except ValueError:
        raise ValueError(f"`r_hat`, `beta_hat` and `biases[..., :]` must broadcast; received "
                         f"shapes {r.shape}, {beta.shape}, {b.shape}") from None
    if np.any(rc <= 0):
        raise ValueError("`biases`: the range offset exceeds a measured range, so a corrected "
                         f"range is not positive; received smallest corrected range "
                         f"{float(np.min(rc)):.6g}")
    return tuple(np.asarray(o) for o in np.broadcast_arrays(rc, bc))


def true_polar(sensors, targets):
    """True range and azimuth of every object from every radar.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites.
    targets : array_like, shape (..., n, 2)
        Object positions (a leading batch allowed).

    Returns
    -------
    numpy.ndarray, shape (..., m, n, 2)
        :math:`(r_{ik}, \\beta_{ik})` with :math:`r_{ik} = \\lVert x_k - s_i\\rVert` and
        :math:`\\beta_{ik} = \\operatorname{atan2}(y_k - s_{i,y}, x_k - s_{i,x})`.

    Raises
    ------
    ValueError
        Wrong shapes, non-finite entries, or an object on a radar site.

    Examples
    --------
    >>> true_polar([[0.0, 0.0]], [[3.0, 4.0]]).round(4)
    array([[[5.    , 0.9273]]])
    """
    s = _sensors_iv(sensors)
    t = _targets_iv(targets, s)
    _elements(t.size // 2 * s.shape[0], "targets")
    d = t[..., None, :, :] - s[:, None, :]
    return np.stack([np.hypot(d[..., 0], d[..., 1]), np.arctan2(d[..., 1], d[..., 0])], axis=-1)


def simulate_reports(sensors, targets, biases, sigma_r, sigma_beta, *, trials=None, rng=None):
    """Draw biased, noisy polar reports of every object by every radar.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites.
    targets : array_like, shape (..., n, 2)
        Object positions.
    biases : array_like, shape (..., m, 3)
        Each radar's :math:`(\\Delta r, g, \\Delta\\beta)`; leading axes
        broadcast against those of `targets`.
    sigma_r, sigma_beta : float or array_like, shape (m,)
        Standard deviations of the random range and azimuth errors (> 0).
    trials : int or None, optional
        Number of independent draws, prepended as a leading axis (None: one
        draw, no extra axis).
    rng : None, int, SeedSequence or numpy.random.Generator
        Randomness (SPEC 7).

    Returns
    -------
    numpy.ndarray, shape (trials, ..., m, n, 2)
        Reports :math:`(\\hat r_{ik}, \\hat\\beta_{ik})`: report ``k`` of every
        radar is of object ``k`` (shuffle them to hide the association).

    Raises
    ------
    ValueError, TypeError
        Bad shapes or values (named), a batch above :data:`MAX_ELEMENTS`, or a
        range so small that a negative range could be drawn
        (:math:`r < 8\\sigma_r`).

    Examples
    --------
    >>> z = simulate_reports([[0.0, 0.0], [10.0, 0.0]], [[5.0, 50.0]], [[0, 0, 0]] * 2,
    ...                      0.05, 1e-3, trials=4, rng=1)
    >>> z.shape
    (4, 2, 1, 2)
    """
    s = _sensors_iv(sensors)
    m = s.shape[0]
    polar = true_polar(s, targets)
    b = _radar_biases_iv(biases, m)
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, m)
    reps = 1 if trials is None else as_int(trials, "trials", minimum=1)
    gen = as_rng(rng)
    try:
        shape = np.broadcast_shapes(polar.shape[:-3], b.shape[:-2])
    except ValueError:
        raise ValueError(f"`targets` and `biases` must have broadcastable leading axes; "
                         f"received shapes {np.shape(targets)} and {b.shape}") from None
    n = polar.shape[-2]
    _elements(reps * math.prod(shape) * m * n, "trials")
    if np.any(polar[..., 0] < conversion.MIN_RANGE_OVER_SIGMA * sr[:, None]):
        raise ValueError("`targets`: every object must be at least "
                         f"{conversion.MIN_RANGE_OVER_SIGMA:g} `sigma_r` from each radar")
    rb, bb = apply_biases(polar[..., 0], polar[..., 1], b[..., :, None, :])
    full = (reps, *shape, m, n)
    rb, bb = np.broadcast_to(rb, full), np.broadcast_to(bb, full)
    r_hat = rb + sr[:, None] * gen.standard_normal(full)
    b_hat = _wrap(bb + sb[:, None] * gen.standard_normal(full))
    out = np.stack([r_hat, b_hat], axis=-1)
    return out[0] if trials is None else out


def to_cartesian(sensors, reports, sigma_r, sigma_beta, *, biases=None):
    """Convert polar reports to Cartesian positions, optionally correcting known biases first.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites.
    reports : array_like, shape (..., m, n, 2)
        Polar reports :math:`(\\hat r, \\hat\\beta)` of each radar.
    sigma_r, sigma_beta : float or array_like, shape (m,)
        Random error standard deviations.
    biases : array_like, shape (..., m, 3), optional
        Biases removed (:func:`remove_biases`) before conversion.

    Returns
    -------
    conversion.ConvertedMeasurement
        ``xy`` (..., m, n, 2) in the common frame (the sites added) and the
        linearized covariance ``cov`` (..., m, n, 2, 2) of
        :func:`radarfusion_ref.conversion.polar_to_cartesian`, eqs. (2a–c).

    Raises
    ------
    ValueError, TypeError
        Bad shapes or values, named.

    Examples
    --------
    >>> c = to_cartesian([[1.0, 0.0]], [[[2.0, 0.0]]], 0.1, 0.01)
    >>> c.xy
    array([[[3., 0.]]])
    """
    s = _sensors_iv(sensors)
    m = s.shape[0]
    z = _polar_reports_iv(reports, "reports", m)
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, m)
    _elements(z.size // 2, "reports")
    r, beta = z[..., 0], z[..., 1]
    if biases is not None:
        b = _radar_biases_iv(biases, m)
        r, beta = remove_biases(r, beta, b[..., :, None, :])
    cv = conversion.polar_to_cartesian(r, beta, sr[:, None], sb[:, None])
    return conversion.ConvertedMeasurement(cv.xy + s[:, None, :], cv.cov, cv.method)


def bias_displacement(sensors, targets, biases):
    """Where the biases move each object's noise-free report: the Cartesian bias.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
    targets : array_like, shape (..., n, 2)
    biases : array_like, shape (..., m, 3)

    Returns
    -------
    numpy.ndarray, shape (..., m, n, 2)
        :math:`\\mu_{ik} = s_i + r^b_{ik} u(\\beta^b_{ik}) - x_k`, exact, with
        :math:`(r^b, \\beta^b)` from :func:`apply_biases` and
        :math:`u(\\beta) = (\\cos\\beta, \\sin\\beta)`.

    Notes
    -----
    To first order in the biases,
    :math:`\\mu \\approx (\\Delta r + g r)\\, u(\\beta) + r\\,\\Delta\\beta\\, u^\\perp(\\beta)`,
    :math:`u^\\perp = (-\\sin\\beta, \\cos\\beta)`: range biases move a report
    along the line of sight, the azimuth bias across it, in proportion to the range.

    Examples
    --------
    >>> bias_displacement([[0.0, 0.0]], [[10.0, 0.0]], [[0.5, 0.0, 0.0]])
    array([[[0.5, 0. ]]])
    """
    s = _sensors_iv(sensors)
    polar = true_polar(s, targets)
    t = np.asarray(targets, dtype=float)
    b = _radar_biases_iv(biases, s.shape[0])
    rb, bb = apply_biases(polar[..., 0], polar[..., 1], b[..., :, None, :])
    pos = s[:, None, :] + rb[..., None] * np.stack([np.cos(bb), np.sin(bb)], axis=-1)
    return pos - t[..., None, :, :]


def noncentrality(sensors, targets, biases, sigma_r, sigma_beta):
    """Noncentrality of the proximity measure of a TRUE pair of biased reports (two radars).

    Parameters
    ----------
    sensors : array_like, shape (2, 2)
        The two radar sites.
    targets : array_like, shape (..., n, 2)
        Object positions.
    biases : array_like, shape (..., 2, 3)
        Both radars' biases.
    sigma_r, sigma_beta : float or array_like, shape (2,)
        Random error standard deviations.

    Returns
    -------
    numpy.ndarray, shape (..., n)
        :math:`\\lambda_k = (\\mu_{1k} - \\mu_{2k})^{\\mathsf T} S_k^{-1} (\\mu_{1k} - \\mu_{2k})`
        with :math:`\\mu` from :func:`bias_displacement` and
        :math:`S_k = \\Sigma_{1k} + \\Sigma_{2k}` the linearized covariances
        (eqs. 2a–c of the conversion chapter) at the true position.

    Raises
    ------
    ValueError, TypeError
        Bad shapes or values, named; `sensors` must hold exactly two sites.

    Notes
    -----
    With linearized Gaussian errors the difference of the two reports of one
    object is :math:`\\Delta \\sim \\mathcal N(\\mu_1 - \\mu_2, S)`, so the
    proximity measure :math:`\\kappa = \\Delta^{\\mathsf T} S^{-1} \\Delta` of the
    *true* pair follows the noncentral law :math:`\\chi'^2_2(\\lambda)` instead
    of :math:`\\chi^2_2` (the book's eq. ``eq-registration-lambda``).

    Examples
    --------
    >>> round(float(noncentrality([[0, 0], [0, 0.001]], [[100.0, 0.0]],
    ...                           [[0.1, 0, 0], [0, 0, 0]], 0.1, 1e-3)[0]), 6)
    0.5
    """
    s = _sensors_iv(sensors)
    if s.shape[0] != 2:
        raise ValueError(f"`sensors` must hold exactly two radar sites, shape (2, 2); received "
                         f"shape {s.shape}")
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, 2)
    polar = true_polar(s, targets)
    mu = bias_displacement(s, targets, biases)
    cov = conversion.polar_to_cartesian(polar[..., 0], polar[..., 1], sr[:, None], sb[:, None]).cov
    return np.asarray(mahalanobis_sq(mu[..., 0, :, :], mu[..., 1, :, :],
                                     cov[..., 0, :, :, :], cov[..., 1, :, :, :]), dtype=float)


def cost_matrix(sensors, reports1, reports2, sigma_r, sigma_beta, *, biases=None):
    """Proximity measures of every pair of reports of two radars, after optional bias correction.

    Parameters
    ----------
    sensors : array_like, shape (2, 2)
        The two radar sites.
    reports1, reports2 : array_like, shape (..., n1, 2) and (..., n2, 2)
        Polar reports :math:`(\\hat r, \\hat\\beta)` of radar 1 and radar 2.
    sigma_r, sigma_beta : float or array_like, shape (2,)
        Random error standard deviations.
    biases : array_like, shape (..., 2, 3), optional
        Biases corrected before conversion (None: none).

    Returns
    -------
    numpy.ndarray, shape (..., n1, n2)
        :math:`\\kappa_{ij} = \\Delta_{ij}^{\\mathsf T}(\\Sigma_{1i} + \\Sigma_{2j})^{-1}\\Delta_{ij}`,
        eq. ``eq-proximity``, with the converted reports and their linearized
        covariances (:func:`to_cartesian`); the input of
        :func:`radarfusion_ref.association.associate_joint`.

    Raises
    ------
    ValueError, TypeError
        Bad shapes or values, named.

    Examples
    --------
    >>> k = cost_matrix([[0, 0], [10, 0]], [[50.0, 0.2]], [[45.0, 0.2], [41.0, 0.25]],
    ...                 0.1, 1e-3)
    >>> k.shape
    (1, 2)
    """
    s = _sensors_iv(sensors)
    if s.shape[0] != 2:
        raise ValueError(f"`sensors` must hold exactly two radar sites, shape (2, 2); received "
                         f"shape {s.shape}")
    z1 = _polar_reports_iv(reports1, "reports1")
    z2 = _polar_reports_iv(reports2, "reports2")
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, 2)
    try:
        batch = np.broadcast_shapes(z1.shape[:-2], z2.shape[:-2])
    except ValueError:
        raise ValueError(f"`reports1` and `reports2` must have broadcastable leading axes; "
                         f"received shapes {z1.shape} and {z2.shape}") from None
    n1, n2 = z1.shape[-2], z2.shape[-2]
    _elements(math.prod(batch) * n1 * n2, "reports1")
    b = np.zeros((2, 3)) if biases is None else _radar_biases_iv(biases, 2)
    c = []
    for k, z in enumerate((z1, z2)):
        r, beta = remove_biases(z[..., 0], z[..., 1], b[..., k, None, :])
        cv = conversion.polar_to_cartesian(r, beta, sr[k], sb[k])
        c.append((cv.xy + s[k], cv.cov))
    (x1, c1), (x2, c2) = c
    return np.asarray(mahalanobis_sq(x1[..., :, None, :], x2[..., None, :, :],
                                     c1[..., :, None, :, :], c2[..., None, :, :, :]), dtype=float)


# --------------------------------------------------------------------------- estimation core
def _blocks(s, x, b, sr, sb):
    """Whitened Jacobians of the predicted polar reports.

    Returns (pred (…, m, n, 2), B (…, m, n, 2, 3), G (…, m, n, 2, 2)) for
    sites s (m, 2), objects x (…, n, 2), biases b (…, m, 3).
    """
    d = x[..., None, :, :] - s[:, None, :]                     # (…, m, n, 2)
    rho = np.hypot(d[..., 0], d[..., 1])
    phi = np.arctan2(d[..., 1], d[..., 0])
    u = d / rho[..., None]
    uperp = np.stack([-u[..., 1], u[..., 0]], axis=-1)
    scale = 1.0 + b[..., :, None, 1]
    pred = np.stack([scale * rho + b[..., :, None, 0], phi + b[..., :, None, 2]], axis=-1)
    w_r, w_b = 1.0 / sr[:, None], 1.0 / sb[:, None]
    zero, one = np.zeros_like(rho), np.ones_like(rho)
    # d r^b / d(Δr, g, Δβ) = (1, r, 0);  d β^b / d(Δr, g, Δβ) = (0, 0, 1)
    B = np.stack([np.stack([one * w_r, rho * w_r, zero], -1),
                  np.stack([zero, zero, one * w_b], -1)], -2)
    # d r^b / dx = (1 + g) u^T;  d β / dx = u_perp^T / r
    G = np.stack([(scale * w_r)[..., None] * u, (w_b / rho)[..., None] * uperp], -2)
    return pred, B, G


def _reduced(B, G, e=None):
    """Schur complement over the objects: the bias information and (optionally) gradient.

    B (…, m, n, 2, 3), G (…, m, n, 2, 2), e (…, m, n, 2) whitened residuals.
    Returns (info (…, 3m, 3m), grad (…, 3m) or None, per-object pieces).
    """
    *lead, m, n, _, _ = B.shape
    # U: block-diagonal per radar; W_k: (…, n, 3m, 2); V_k: (…, n, 2, 2)
    U = np.einsum("...ikab,...ikac->...ibc", B, B)
    info = np.zeros((*lead, 3 * m, 3 * m))
    for i in range(m):
        info[..., 3 * i:3 * i + 3, 3 * i:3 * i + 3] = U[..., i, :, :]
    W = np.einsum("...ikab,...ikac->...kibc", B, G).reshape(*lead, n, 3 * m, 2)
    V = np.einsum("...ikab,...ikac->...kbc", G, G)
    Vinv_Wt = np.linalg.solve(V, np.swapaxes(W, -1, -2))           # (…, n, 2, 3m)
    info = info - np.einsum("...kpa,...kaq->...pq", W, Vinv_Wt)
    info = 0.5 * (info + np.swapaxes(info, -1, -2))
    if e is None:
        return info, None, (W, V)
    gb = np.einsum("...ikab,...ika->...ib", B, e).reshape(*lead, 3 * m)
    gx = np.einsum("...ikab,...ika->...kb", G, e)                   # (…, n, 2)
    Vinv_gx = np.linalg.solve(V, gx[..., None])[..., 0]
    grad = gb - np.einsum("...kpa,...ka->...p", W, Vinv_gx)
    return info, grad, (W, V, gx, np.einsum("...ka,...ka->...", gx, Vinv_gx))


def _scaled_rank(info, free):
    """Rank and null space (physical units) of the free block of one information matrix.

    The block is scaled to a unit diagonal first (the biases have different
    units); eigenvalues below :data:`RANK_TOL` times the largest count as zero.
    """
    idx = np.flatnonzero(free)
    sub = info[np.ix_(idx, idx)]
    diag = np.diag(sub)
    full = np.zeros((len(free), 0))
    top = float(diag.max()) if len(idx) else 0.0
    if top <= 0:
        full = np.zeros((len(free), len(idx)))
        full[idx, np.arange(len(idx))] = 1.0
        return 0, full
    zero = diag <= RANK_TOL * top                       # no information at all
    d = np.sqrt(np.where(zero, 1.0, diag))
    scaled = sub / np.outer(d, d)
    scaled[zero, :] = 0.0
    scaled[:, zero] = 0.0
    vals, vecs = np.linalg.eigh(scaled)
    bad = vals <= RANK_TOL * vals.max()
    null = vecs[:, bad] / d[:, None]
    full = np.zeros((len(free), null.shape[1]))
    full[idx] = null
    return len(idx) - null.shape[1], full


def _rref_rows(null: np.ndarray, tol: float = 1e-8) -> np.ndarray:
    """Rows spanning the null space, in reduced row-echelon form (readable combinations)."""
    a = null.T.copy()
    rows, cols = a.shape
    r = 0
    for c in range(cols):
        if r == rows:
            break
        p = r + int(np.argmax(np.abs(a[r:, c])))
        if abs(a[p, c]) <= tol * max(1.0, np.abs(a).max()):
            continue
        a[[r, p]] = a[[p, r]]
        a[r] /= a[r, c]
        for q in range(rows):
            if q != r:
                a[q] -= a[q, c] * a[r]
        r += 1
    a[np.abs(a) < 1e-10] = 0.0
    return a[:r]


def _describe_combination(row: np.ndarray) -> str:
    terms = []
    for p in np.flatnonzero(row):
        i, j = divmod(int(p), 3)
        c = row[p]
        coef = "" if abs(c - 1) < 1e-9 else ("-" if abs(c + 1) < 1e-9 else f"{c:.3g}*")
        terms.append(f"{coef}{BIAS_NAMES[j]}[{i}]")
    return " + ".join(terms).replace("+ -", "- ")


# --------------------------------------------------------------------------- information
def bias_information(sensors, targets, sigma_r, sigma_beta, *, biases=None):
    """Fisher information of the radar biases, the object positions being unknown.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites.
    targets : array_like, shape (..., n, 2)
        Positions of the n objects seen by every radar.
    sigma_r, sigma_beta : float or array_like, shape (m,)
        Random error standard deviations.
    biases : array_like, shape (..., m, 3), optional
        Point of evaluation (default zero; only the range scale enters).

    Returns
    -------
    numpy.ndarray, shape (..., 3m, 3m)
        :math:`\\mathcal J_b`, ordered radar by radar as
        :math:`(\\Delta r_1, g_1, \\Delta\\beta_1, \\Delta r_2, \\dots)`.

    Raises
    ------
    ValueError, TypeError
        Bad shapes or values, named.

    Notes
    -----
    With :math:`R^{-1/2}`-whitened Jacobians :math:`B_{ik} = \\partial h_{ik}/\\partial b_i`
    and :math:`G_{ik} = \\partial h_{ik}/\\partial x_k` of the predicted report
    :math:`h_{ik} = ((1+g_i) r_{ik} + \\Delta r_i,\\ \\beta_{ik} + \\Delta\\beta_i)`,
    the full information :math:`H^{\\mathsf T} H` of :math:`(b, x_1, \\dots, x_n)` has
    a block-arrow form. Eliminating each object (Schur complement) gives

    .. math::

        \\mathcal J_b = \\sum_k \\left( \\mathcal B_k^{\\mathsf T}\\mathcal B_k
        - \\mathcal B_k^{\\mathsf T}\\mathcal G_k (\\mathcal G_k^{\\mathsf T}
        \\mathcal G_k)^{-1}\\mathcal G_k^{\\mathsf T}\\mathcal B_k \\right),

    where :math:`\\mathcal B_k, \\mathcal G_k` stack radar :math:`i`'s rows
    (:math:`\\mathcal B_k` block-diagonal over radars): each object contributes
    the information left after its own position has been estimated. The CRLB
    of the biases is :math:`\\mathcal J_b^{-1}` where it exists (book eq.
    ``eq-registration-fim``; Bar-Shalom, Li & Kirubarajan, sec. 2.7).

    Examples
    --------
    >>> J = bias_information([[0, 0], [20, 0]], [[0, 60], [30, 70], [-20, 50]], 0.05, 1e-3)
    >>> J.shape, int(np.linalg.matrix_rank(J / np.sqrt(np.outer(np.diag(J), np.diag(J)))))
    ((6, 6), 6)
    """
    s = _sensors_iv(sensors)
    m = s.shape[0]
    t = _targets_iv(targets, s)
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, m)
    b = np.zeros((m, 3)) if biases is None else _radar_biases_iv(biases, m)
    _elements(t.size // 2 * m, "targets")
    lead = np.broadcast_shapes(t.shape[:-2], b.shape[:-2])
    t = np.broadcast_to(t, (*lead, *t.shape[-2:]))
    b = np.broadcast_to(b, (*lead, m, 3))
    _, B, G = _blocks(s, t, b, sr, sb)
    return _reduced(B, G)[0]


@dataclass(frozen=True)
class Observability:
    """Which radar biases a geometry lets one estimate.

    Attributes
    ----------
    rank : int
        Rank of the bias information matrix restricted to the free biases.
    n_free : int
        Number of free (not fixed) biases, :math:`3m` minus the fixed ones.
    unobservable : numpy.ndarray, shape (n_free - rank, 3m)
        Rows spanning the combinations of biases the data cannot see, in
        reduced row-echelon form (physical units; zero in fixed columns).
    descriptions : tuple of str
        The same rows in words, e.g. ``"range_offset[0] + range_offset[1]"``.
    """

    rank: int
    n_free: int
    unobservable: np.ndarray
    descriptions: tuple[str, ...]

    @property
    def observable(self) -> bool:
        """True when every free bias is observable (full rank)."""
        return self.rank == self.n_free


def observability(sensors, targets, sigma_r=1.0, sigma_beta=1e-3, *, fixed=None):
    """Rank of the bias information of one geometry, and the combinations it cannot see.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites.
    targets : array_like, shape (n, 2)
        Object positions (one geometry, no batch).
    sigma_r, sigma_beta : float or array_like, shape (m,), optional
        Random error standard deviations (they change the information, not its rank).
    fixed : array_like of bool, shape (m, 3), optional
        Biases known to be zero (e.g. a reference radar), left out.

    Returns
    -------
    Observability

    Raises
    ------
    ValueError, TypeError
        Bad shapes or values, named.

    Notes
    -----
    The rank is that of the information restricted to the free biases after
    scaling it to a unit diagonal; eigenvalues below :data:`RANK_TOL` times
    the largest count as zero. The unobservable combinations are the null
    space :math:`\\mathcal J_b v = 0`: bias changes :math:`v` that every object
    position can absorb.

    Examples
    --------
    >>> o = observability([[0, 0], [0, 0]], [[0, 60], [30, 70], [-20, 50]])
    >>> o.rank, o.descriptions[0]
    (3, 'range_offset[0] + range_offset[1]')
    """
    s = _sensors_iv(sensors)
    m = s.shape[0]
    t = _targets_iv(targets, s)
    if t.ndim != 2:
        raise ValueError(f"`targets` must have shape (n, 2), one geometry; received shape "
                         f"{t.shape}")
    fx = _fixed_iv(fixed, m)
    info = bias_information(s, t, sigma_r, sigma_beta)
    rank, null = _scaled_rank(info, ~fx.ravel())
    rows = _rref_rows(null) if null.shape[1] else np.zeros((0, 3 * m))
    return Observability(int(rank), int((~fx).sum()), rows,
                         tuple(_describe_combination(r) for r in rows))


# --------------------------------------------------------------------------- estimation
@dataclass(frozen=True)
class BiasEstimate:
    """Maximum-likelihood radar biases from reports of common objects.

    Attributes
    ----------
    biases : numpy.ndarray, shape (..., m, 3)
        Estimated :math:`(\\Delta r_i, g_i, \\Delta\\beta_i)`; fixed
        biases are exactly zero.
    targets : numpy.ndarray, shape (..., n, 2)
        Estimated object positions (the nuisance parameters).
    covariance : numpy.ndarray, shape (..., 3m, 3m)
        Covariance of the estimate: the inverse Fisher information of the
        free biases at the estimate (zero rows and columns for fixed biases).
    crlb : numpy.ndarray, shape (..., m, 3)
        Cramér–Rao bound on each bias's standard deviation at the estimated
        geometry, the square root of the diagonal of `covariance` (zero for
        fixed biases). :func:`bias_information` gives the bound at any geometry.
    information : numpy.ndarray, shape (..., 3m, 3m)
        Fisher information of the biases (objects eliminated) at the estimate.
    chi2 : numpy.ndarray or float, shape (...)
        Minimised sum of squared whitened residuals.
    dof : int
        Residual degrees of freedom, :math:`2mn - 2n - n_{\\text{free}}`:
        under the model `chi2` is about :math:`\\chi^2_{\\text{dof}}`.
    iterations : int
        Gauss–Newton iterations used (the largest over the batch).
    """

    biases: np.ndarray
    targets: np.ndarray
    covariance: np.ndarray
    crlb: np.ndarray
    information: np.ndarray
    chi2: np.ndarray | float
    dof: int
    iterations: int


def _initial_targets(s, z, b, sr, sb):
    """Mean of the radars' converted, bias-corrected reports of each object."""
    rc = (z[..., 0] - b[..., :, None, 0]) / (1.0 + b[..., :, None, 1])
    bc = z[..., 1] - b[..., :, None, 2]
    rc = np.maximum(rc, 1e-12 * np.abs(z[..., 0]).max())
    pos = s[:, None, :] + rc[..., None] * np.stack([np.cos(bc), np.sin(bc)], axis=-1)
    return pos.mean(axis=-3)


def _unobservable_error(info, free, where: str) -> None:
    rank, null = _scaled_rank(info, free)
    if rank < int(free.sum()):
        rows = _rref_rows(null)
        combos = "; ".join(_describe_combination(r) for r in rows) or "(see `observability`)"
        raise ValueError(
            f"`reports`: the biases are not observable from this geometry{where}: the bias "
            f"information matrix has rank {rank} of {int(free.sum())} free biases; the data "
            f"cannot see these combinations: {combos}. Use radars at different sites, objects "
            f"in more directions and ranges (at least 3 in general position for two radars), "
            f"or fix a reference radar's biases with `fixed`")


def estimate_biases(sensors, reports, sigma_r, sigma_beta, *, fixed=None, initial=None,
                    max_iter: int = 50, tol: float = 1e-10) -> BiasEstimate:
    """Maximum-likelihood (weighted least-squares) biases of radars seeing common objects.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites, :math:`m \\ge 2`.
    reports : array_like, shape (..., m, n, 2)
        Associated polar reports: ``reports[..., i, k]`` is radar ``i``'s
        :math:`(\\hat r, \\hat\\beta)` of object ``k`` (every radar sees every
        object). Leading axes are a batch, solved vectorized.
    sigma_r, sigma_beta : float or array_like, shape (m,)
        Random error standard deviations (> 0).
    fixed : array_like of bool, shape (m, 3), optional
        Biases known to be zero, held fixed (e.g. ``fixed[0] = True`` makes
        radar 0 the reference).
    initial : array_like, shape (..., m, 3), optional
        Starting biases (default zero); fixed entries are set to zero.
    max_iter : int, optional
        Largest number of Gauss–Newton iterations (default 50).
    tol : float, optional
        Stop when the Gauss–Newton decrement (the predicted drop of the
        whitened sum of squares) is below `tol` for every batch element.

    Returns
    -------
    BiasEstimate

    Raises
    ------
    ValueError
        Bad shapes or values (named), fewer than two radars, or an
        **unobservable configuration**: the free biases' information matrix
        is rank deficient (the message names the unobservable combinations).
    TypeError
        Non-numeric input or a non-boolean `fixed`.

    Warns
    -----
    RadarFusionWarning
        If Gauss–Newton has not converged after `max_iter` iterations.

    Notes
    -----
    The negative log-likelihood is, up to a constant, the whitened sum of
    squares over radars :math:`i` and objects :math:`k`

    .. math::

        \\ell(b, x) = \\sum_{i,k} \\frac{(\\hat r_{ik} - (1+g_i) r_{ik}(x_k)
        - \\Delta r_i)^2}{\\sigma_{r,i}^2}
        + \\frac{(\\hat\\beta_{ik} - \\beta_{ik}(x_k) - \\Delta\\beta_i)^2}{\\sigma_{\\beta,i}^2},

    minimised jointly over the biases and the object positions by
    Gauss–Newton. Each step solves the normal equations after eliminating
    the objects (the Schur complement of :func:`bias_information`, as in
    bundle adjustment), then back-substitutes each object's 2×2 system.
    Azimuth residuals are wrapped to :math:`[-\\pi, \\pi)`. The rank of the
    information is checked first, at the starting point: a rank-deficient
    configuration raises instead of producing a singular solve.

    References
    ----------
    Zhou, Leung & Yip (1997); Okello & Ristic (2003); Bar-Shalom, Li &
    Kirubarajan (2001), sec. 3.4.

    Examples
    --------
    >>> s = [[0.0, 0.0], [20.0, 0.0]]
    >>> x = [[0.0, 60.0], [30.0, 70.0], [-20.0, 50.0], [10.0, 80.0]]
    >>> b = [[0.2, 0.0, 0.002], [-0.1, 0.0, -0.001]]
    >>> z = simulate_reports(s, x, b, 1e-6, 1e-9, rng=0)       # nearly noise-free
    >>> est = estimate_biases(s, z, 1e-6, 1e-9)
    >>> np.round(est.biases, 4)
    array([[ 0.2  ,  0.   ,  0.002],
           [-0.1  ,  0.   , -0.001]])
    """
    s = _sensors_iv(sensors)
    m = s.shape[0]
    if m < 2:
        raise ValueError(f"`sensors` must hold at least two radar sites to register them; "
                         f"received shape {s.shape}")
    z = _polar_reports_iv(reports, "reports", m)
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, m)
    fx = _fixed_iv(fixed, m)
    max_iter = as_int(max_iter, "max_iter", minimum=1, maximum=10_000)
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (0 < tol < 1):
        raise ValueError(f"`tol` must be a number in (0, 1); received {_describe(tol)}")
    lead, n = z.shape[:-3], z.shape[-2]
    _elements(math.prod(lead) * m * n, "reports")
    free = ~fx.ravel()
    if initial is None:
        b = np.zeros((*lead, m, 3))
    else:
        b = np.array(np.broadcast_to(_radar_biases_iv(initial, m, "initial"), (*lead, m, 3)))
    b[..., fx] = 0.0
    x = _initial_targets(s, z, b, sr, sb)
    mask = np.zeros(3 * m)
    mask[~free] = 1.0

    def step(b, x):
        pred, B, G = _blocks(s, x, b, sr, sb)
        B = B * free.reshape(m, 3)[:, None, None, :]           # fixed biases: no columns
        e = np.stack([(z[..., 0] - pred[..., 0]) / sr[:, None],
                      _wrap(z[..., 1] - pred[..., 1]) / sb[:, None]], axis=-1)
        info, grad, (W, V, gx, gvg) = _reduced(B, G, e)
        return info, grad, W, V, gx, gvg, e

    info, grad, W, V, gx, gvg, e = step(b, x)
    flat_info = info.reshape(-1, 3 * m, 3 * m)
    for k in range(flat_info.shape[0]):
        _unobservable_error(flat_info[k], free, "" if flat_info.shape[0] == 1
                            else f" (batch element {k})")
    iterations, converged = 0, False
    while iterations < max_iter:
        iterations += 1
        a = info + np.diag(mask)
        db = np.linalg.solve(a, grad[..., None])[..., 0]
        dx = np.linalg.solve(V, (gx - np.einsum("...kpa,...p->...ka", W, db))[..., None])[..., 0]
        # Gauss-Newton decrement g^T delta = db . grad_reduced + gx^T V^-1 gx
        decrement = np.einsum("...p,...p->...", db, grad) + gvg
        b = b + db.reshape(*lead, m, 3)
        x = x + dx
        if np.any(b[..., 1] <= -1):
            raise ValueError("`reports`: the range scale estimate left (-1, inf); the reports "
                             "are not consistent with the bias model (check the association)")
        info, grad, W, V, gx, gvg, e = step(b, x)
        if np.all(np.abs(decrement) < tol):
            converged = True
            break
    if not converged:
        warnings.warn(f"estimate_biases: Gauss-Newton did not converge in {max_iter} "
                      f"iterations (largest decrement {float(np.max(np.abs(decrement))):.3g})",
                      RadarFusionWarning, stacklevel=2)
    cov = np.linalg.inv(info + np.diag(mask)) * np.outer(free, free)
    crlb = np.sqrt(np.clip(np.diagonal(cov, axis1=-2, axis2=-1), 0, None)).reshape(*lead, m, 3)
    chi2 = np.einsum("...ikj,...ikj->...", e, e)
    dof = 2 * m * n - 2 * n - int(free.sum())
    chi2 = float(chi2) if np.ndim(chi2) == 0 else chi2
    return BiasEstimate(b, x, cov, crlb, info, chi2, dof, iterations)


# --------------------------------------------------------------------------- joint registration
@dataclass(frozen=True)
class RegistrationStep:
    """One pass of association then bias estimation.

    Attributes
    ----------
    iteration : int
        Pass number, from 1.
    biases : numpy.ndarray, shape (2, 3)
        Biases used to correct the reports before this pass's association.
    row_to_col : numpy.ndarray of int, shape (n1,)
        This pass's association (-1: unassigned).
    total_cost : float
        Summed proximity measure of the association.
    n_pairs : int
        Number of associated pairs.
    """

    iteration: int
    biases: np.ndarray
    row_to_col: np.ndarray
    total_cost: float
    n_pairs: int


@dataclass(frozen=True)
class Registration:
    """Result of :func:`register_and_associate`.

    Attributes
    ----------
    biases : numpy.ndarray, shape (2, 3)
        Final bias estimates.
    estimate : BiasEstimate
        The last bias estimate (covariance, CRLB, objects) from the final pairs.
    association : radarfusion_ref.association.Association
        The association of the reports corrected with the final biases.
    history : tuple of RegistrationStep
        Every pass, in order.
    converged : bool
        True when a pass repeated the previous pass's association.
    """

    biases: np.ndarray
    estimate: BiasEstimate
    association: association.Association
    history: tuple[RegistrationStep, ...]
    converged: bool

    @property
    def iterations(self) -> int:
        """Number of passes made."""
        return len(self.history)


class RegistrationError(RuntimeError):
    """Joint registration and association did not converge (``on_failure="raise"``).

    Attributes
    ----------
    history : tuple of RegistrationStep
        The passes made before giving up.
    """

    def __init__(self, message: str, history: tuple[RegistrationStep, ...]):
        super().__init__(message)
        self.history = history


def _history_text(history) -> str:
    return "; ".join(f"pass {h.iteration}: {h.n_pairs} pairs, summed kappa {h.total_cost:.4g}"
                     for h in history)


def _trimmed_estimate(s, paired, sr, sb, fx, gate):
    """Bias estimate from paired reports, dropping the worst pair while it fails the gate.

    Without a gate: the plain estimate. With one: after each fit, the pair
    with the largest proximity measure of its corrected reports is dropped if
    that measure is outside the gate and enough pairs remain to observe the
    biases; then the biases are fitted again (sequential outlier rejection).
    """
    free = ~fx.ravel()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadarFusionWarning)
        est = estimate_biases(s, paired, sr, sb, fixed=fx)
        while gate is not None and paired.shape[1] > 3:
            k = np.diagonal(cost_matrix(s, paired[0], paired[1], sr, sb, biases=est.biases))
            worst = int(np.argmax(k))
            if k[worst] < gate:
                break
            keep = np.delete(paired, worst, axis=1)
            info = bias_information(s, _initial_targets(s, keep, est.biases, sr, sb), sr, sb)
            if _scaled_rank(info, free)[0] < int(free.sum()):
                break
            paired = keep
            est = estimate_biases(s, paired, sr, sb, fixed=fx, initial=est.biases)
    return est


def register_and_associate(sensors, reports1, reports2, sigma_r, sigma_beta, *, fixed=None,
                           initial=None, p_false_reject=None, max_iter: int = 20,
                           on_failure: str = "warn") -> Registration:
    """Alternate association and bias estimation for two radars until the pairing repeats.

    Parameters
    ----------
    sensors : array_like, shape (2, 2)
        The two radar sites.
    reports1, reports2 : array_like, shape (n1, 2) and (n2, 2)
        Polar reports :math:`(\\hat r, \\hat\\beta)` of each radar, in any order
        (one scene; no batch).
    sigma_r, sigma_beta : float or array_like, shape (2,)
        Random error standard deviations.
    fixed : array_like of bool, shape (2, 3), optional
        Biases known to be zero (see :func:`estimate_biases`).
    initial : array_like, shape (2, 3), optional
        Biases assumed for the first association (default zero).
    p_false_reject : float, optional
        If given, pairs are gated from the second pass on with the
        :math:`\\chi^2_2` gate :math:`\\kappa < \\gamma` of false-rejection
        probability :math:`P_{\\text{lo}}` (eq. ``eq-gate``). The first pass is
        never gated: the gate is calibrated for registered reports, and the
        biases are not known yet. Default: no gate, every report of the
        smaller list is paired.
    max_iter : int, optional
        Largest number of passes (default 20).
    on_failure : {"warn", "raise"}, optional
        On non-convergence (no repeat within `max_iter` passes, a cycle, or
        too few pairs to estimate the biases): warn with
        :class:`~radarfusion_ref.engine.errors.RadarFusionWarning` and return the
        last pass (``converged=False``), or raise :class:`RegistrationError`.
        Both carry the iteration history.

    Returns
    -------
    Registration

    Raises
    ------
    ValueError, TypeError
        Bad input (named), or a geometry whose biases are unobservable even
        with every report paired (see :func:`estimate_biases`).
    RegistrationError
        With ``on_failure="raise"``, on non-convergence.

    Warns
    -----
    RadarFusionWarning
        With ``on_failure="warn"``, on non-convergence (the message lists the passes).

    Notes
    -----
    Pass :math:`t`: correct the reports with :math:`b^{(t-1)}`, compute the
    proximity measures (:func:`cost_matrix`), take the joint ML pairing
    (:func:`radarfusion_ref.association.associate_joint`, eq.
    ``eq-joint-ml``), then estimate :math:`b^{(t)}` from the *raw* reports of
    the paired objects (:func:`estimate_biases`). With a gate, the estimate
    is made robust to wrong pairs by dropping, one at a time, the pair whose
    corrected reports fail the gate worst, and fitting again. Each pass can only lower the
    joint cost of pairing and biases for a fixed pairing, so the loop stops
    when the pairing repeats. It converges to the right pairing when the
    initial biases misplace reports by less than about half the object
    spacing; beyond that it can lock onto a consistently shifted pairing.

    Examples
    --------
    >>> s = [[0.0, 0.0], [20.0, 0.0]]
    >>> x = [[0.0, 60.0], [30.0, 70.0], [-20.0, 50.0], [10.0, 80.0], [5.0, 65.0]]
    >>> b = [[0.3, 0.0, 0.004], [0.0, 0.0, 0.0]]
    >>> z = simulate_reports(s, x, b, 0.02, 2e-4, rng=3)
    >>> reg = register_and_associate(s, z[0], z[1][::-1], 0.02, 2e-4)
    >>> reg.converged, reg.association.row_to_col.tolist()
    (True, [4, 3, 2, 1, 0])
    """
    s = _sensors_iv(sensors)
    if s.shape[0] != 2:
        raise ValueError(f"`sensors` must hold exactly two radar sites, shape (2, 2); received "
                         f"shape {s.shape}")
    z1 = _polar_reports_iv(reports1, "reports1")
    z2 = _polar_reports_iv(reports2, "reports2")
    for z, name in ((z1, "reports1"), (z2, "reports2")):
        if z.ndim != 2:
            raise ValueError(f"`{name}` must have shape (n, 2), one scene; received shape "
                             f"{z.shape}")
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, 2)
    fx = _fixed_iv(fixed, 2)
    b = np.zeros((2, 3)) if initial is None else np.array(_radar_biases_iv(initial, 2, "initial"))
    if b.shape != (2, 3):
        raise ValueError(f"`initial` must have shape (2, 3); received shape {b.shape}")
    b[fx] = 0.0
    gate = None if p_false_reject is None else float(
        gating.gate_threshold(as_probability(p_false_reject, "p_false_reject"), 2))
    max_iter = as_int(max_iter, "max_iter", minimum=1, maximum=1000)
    on_failure = as_choice(on_failure, "on_failure", ("warn", "raise"))
    _elements(z1.shape[0] * z2.shape[0], "reports1")

    history: list[RegistrationStep] = []
    seen: list[np.ndarray] = []
    est, failure = None, None
    for t in range(1, max_iter + 1):
        cost = cost_matrix(s, z1, z2, sr, sb, biases=b)
        res = association.associate_joint(cost, threshold=None if t == 1 else gate)
        history.append(RegistrationStep(t, b.copy(), res.row_to_col.copy(),
                                        float(res.total_cost), int(res.n_assigned)))
        if seen and np.array_equal(res.row_to_col, seen[-1]):
            return Registration(b, est, res, tuple(history), True)
        if any(np.array_equal(res.row_to_col, p) for p in seen[:-1]):
            failure = f"the association cycles (pass {t} repeats an earlier pass, not the last)"
            break
        seen.append(res.row_to_col.copy())
        rows = np.flatnonzero(res.row_to_col >= 0)
        if len(rows) == 0:
            failure = f"pass {t} paired no reports"
            break
        paired = np.stack([z1[rows], z2[res.row_to_col[rows]]])       # (2, k, 2)
        info = bias_information(s, _initial_targets(s, paired, np.zeros((2, 3)), sr, sb),
                                sr, sb)
        rank, _ = _scaled_rank(info, ~fx.ravel())
        if rank < int((~fx).sum()):
            failure = (f"pass {t} paired {len(rows)} reports, too few (or too degenerate) to "
                       f"observe the biases (information rank {rank})")
            break
        est = _trimmed_estimate(s, paired, sr, sb, fx, gate)
        b = np.array(est.biases)
    else:
        failure = f"no pass repeated the previous association within {max_iter} passes"
    if est is None:
        # no estimate at all: fall back to the initial biases' association
        est_text = "no bias estimate was made"
    else:
        est_text = f"last biases {np.round(b, 6).tolist()}"
    message = (f"register_and_associate did not converge: {failure}; {est_text}. History: "
               f"{_history_text(history)}")
    if on_failure == "raise" or est is None:
        if on_failure == "warn":
            message += " (raised, not warned: there is no estimate to return)"
        raise RegistrationError(message, tuple(history))
    warnings.warn(message, RadarFusionWarning, stacklevel=2)
    cost = cost_matrix(s, z1, z2, sr, sb, biases=b)
    res = association.associate_joint(cost, threshold=gate)
    return Registration(b, est, res, tuple(history), False)


# --------------------------------------------------------------------------- Monte Carlo
@dataclass(frozen=True)
class BiasedScene:
    """One simulated two-radar scene with biased reports in unknown order.

    Attributes
    ----------
    targets : numpy.ndarray, shape (n, 2)
        True object positions.
    reports1, reports2 : numpy.ndarray, shape (n1, 2) and (n2, 2)
        Polar reports :math:`(\\hat r, \\hat\\beta)` of the detected objects,
        shuffled.
    object1, object2 : numpy.ndarray of int, shape (n1,) and (n2,)
        Which object each report is of.
    true_row_to_col : numpy.ndarray of int, shape (n1,)
        The correct association (-1: the object was missed by radar 2).
    """

    targets: np.ndarray
    reports1: np.ndarray
    reports2: np.ndarray
    object1: np.ndarray
    object2: np.ndarray
    true_row_to_col: np.ndarray


def simulate_scene(sensors, targets, biases, sigma_r, sigma_beta, *, p_detect=1.0,
                   rng=None) -> BiasedScene:
    """One two-radar scene: biased noisy reports, missed detections, shuffled lists.

    Parameters
    ----------
    sensors : array_like, shape (2, 2)
        The two radar sites.
    targets : array_like, shape (n, 2)
        Object positions.
    biases : array_like, shape (2, 3)
        Both radars' :math:`(\\Delta r, g, \\Delta\\beta)`.
    sigma_r, sigma_beta : float or array_like, shape (2,)
        Random error standard deviations.
    p_detect : float, optional
        Probability :math:`P_D \\in (0, 1]` that a radar reports an object
        (independently per radar and object; at least one report per radar is kept).
    rng : None, int, SeedSequence or numpy.random.Generator
        Randomness (SPEC 7).

    Returns
    -------
    BiasedScene

    Raises
    ------
    ValueError, TypeError
        Bad input, named.

    Examples
    --------
    >>> sc = simulate_scene([[0, 0], [20, 0]], [[0, 60], [10, 70]], [[0, 0, 0]] * 2,
    ...                     0.05, 1e-3, rng=1)
    >>> sorted(sc.object1[sc.true_row_to_col >= 0]) == sorted(sc.object2)
    True
    """
    s = _sensors_iv(sensors)
    if s.shape[0] != 2:
        raise ValueError(f"`sensors` must hold exactly two radar sites, shape (2, 2); received "
                         f"shape {s.shape}")
    t = _targets_iv(targets, s)
    if t.ndim != 2:
        raise ValueError(f"`targets` must have shape (n, 2), one scene; received shape {t.shape}")
    pd = float(as_probability(p_detect, "p_detect", open_interval=False))
    if pd <= 0:
        raise ValueError(f"`p_detect` must lie in (0, 1]; received {p_detect!r}")
    gen = as_rng(rng)
    z = simulate_reports(s, t, biases, sigma_r, sigma_beta, rng=gen)
    n = t.shape[0]
    objs = []
    for _k in range(2):
        keep = gen.random(n) < pd
        if not keep.any():
            keep[gen.integers(n)] = True
        objs.append(gen.permutation(np.flatnonzero(keep)))
    o1, o2 = objs
    where2 = np.full(n, -1)
    where2[o2] = np.arange(len(o2))
    return BiasedScene(t, z[0][o1], z[1][o2], o1, o2, where2[o1])


@dataclass(frozen=True)
class AccuracyComparison:
    """Probability that every association decision of a scene is right, three ways.

    Attributes
    ----------
    unregistered : Proportion
        Reports associated as they come (biases ignored).
    registered : Proportion
        :func:`register_and_associate` (joint registration and association).
    known : Proportion
        Reports corrected with the true biases before association.
    converged : Proportion
        How often :func:`register_and_associate` converged.
    """

    unregistered: object
    registered: object
    known: object
    converged: object


def association_accuracy(sensors, biases, sigma_r, sigma_beta, *, n_objects: int, region,
                         trials: int, p_detect=1.0, p_false_reject=None, fixed=None,
                         rng=None) -> AccuracyComparison:
    """Monte Carlo: association accuracy without registration, with it, and with known biases.

    Parameters
    ----------
    sensors : array_like, shape (2, 2)
        The two radar sites.
    biases : array_like, shape (2, 3)
        The radars' true biases.
    sigma_r, sigma_beta : float or array_like, shape (2,)
        Random error standard deviations.
    n_objects : int
        Objects per scene, drawn uniformly in `region` afresh in every trial.
    region : array_like, shape (2, 2)
        ``[[x_min, y_min], [x_max, y_max]]``.
    trials : int
        Number of scenes.
    p_detect : float, optional
        Detection probability (see :func:`simulate_scene`).
    p_false_reject : float, optional
        The :math:`\\chi^2_2` gate of every association (None: no gate); for
        registration, from its second pass on.
    fixed : array_like of bool, shape (2, 3), optional
        Biases held at zero by the registration.
    rng : None, int, SeedSequence or numpy.random.Generator
        Randomness (SPEC 7).

    Returns
    -------
    AccuracyComparison
        Proportions (with 95 % Wilson intervals) of scenes in which every
        decision (pairs and non-pairs) is correct.

    Raises
    ------
    ValueError, TypeError
        Bad input, named.

    Notes
    -----
    A failed registration (a :class:`RegistrationError`, or a warning of
    non-convergence) counts as converged = False; its last association is
    scored (an error with no association at all scores as wrong).

    Examples
    --------
    >>> acc = association_accuracy([[0, 0], [30, 0]], [[0.2, 0, 0.002], [0, 0, 0]], 0.05,
    ...                            1e-3, n_objects=5, region=[[5, 45], [25, 65]], trials=20,
    ...                            rng=1)
    >>> acc.known.trials
    20
    """
    s = _sensors_iv(sensors)
    b = _radar_biases_iv(biases, 2)
    if b.shape != (2, 3):
        raise ValueError(f"`biases` must have shape (2, 3); received shape {b.shape}")
    n = as_int(n_objects, "n_objects", minimum=3, maximum=1000)
    reg = as_float_array(region, "region")
    if reg.shape != (2, 2) or np.any(reg[1] <= reg[0]):
        raise ValueError(f"`region` must be [[x_min, y_min], [x_max, y_max]] with max > min; "
                         f"received {_describe(reg)}")
    trials = as_int(trials, "trials", minimum=1, maximum=100_000)
    gen = as_rng(rng)
    gate = None if p_false_reject is None else float(
        gating.gate_threshold(as_probability(p_false_reject, "p_false_reject"), 2))
    ok = np.zeros((4, trials), dtype=bool)
    for k in range(trials):
        x = gen.uniform(reg[0], reg[1], size=(n, 2))
        sc = simulate_scene(s, x, b, sigma_r, sigma_beta, p_detect=p_detect, rng=gen)
        for row, bb in ((0, None), (2, b)):
            c = cost_matrix(s, sc.reports1, sc.reports2, sigma_r, sigma_beta, biases=bb)
            ok[row, k] = np.array_equal(
                association.associate_joint(c, threshold=gate).row_to_col, sc.true_row_to_col)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RadarFusionWarning)
            try:
                r = register_and_associate(s, sc.reports1, sc.reports2, sigma_r, sigma_beta,
                                           fixed=fixed, p_false_reject=p_false_reject)
            except (RegistrationError, ValueError):
                continue
        ok[1, k] = np.array_equal(r.association.row_to_col, sc.true_row_to_col)
        ok[3, k] = r.converged
    return AccuracyComparison(*(proportion(o, None) for o in ok))
