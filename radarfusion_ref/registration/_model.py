r"""The bias model: biased polar reports, their Cartesian form, their effect on a true pair."""

from __future__ import annotations

import math

import numpy as np

from .. import conversion
from ..engine.geometry import as_sigma_beta
from ..engine.linalg import (
    is_positive_definite,
    mahalanobis_sq,
    mahalanobis_sq_pairwise,
)
from ..engine.validation import (
    MAX_MAGNITUDE,
    MEMORY_LIMIT,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    as_rng,
    check_size,
    describe,
)

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
    for a, name in ((as_positive(sigma_r, "sigma_r"), "sigma_r"),
                    (as_sigma_beta(sigma_beta, strict=True), "sigma_beta")):
        if a.ndim > 1 or (a.ndim == 1 and a.shape[0] not in (1, m)):
            raise ValueError(f"`{name}` must be a number or one number per radar, shape ({m},); "
                             f"received {describe(a)}")
        out.append(np.broadcast_to(a, (m,)).astype(float))
    return out[0], out[1]


def _biases_iv(biases, name: str = "biases") -> np.ndarray:
    b = as_float_array(biases, name, ndim_min=1, last_dims=(3,))
    if np.any(b[..., 1] <= -1.0):
        raise ValueError(f"`{name}`: the range scale error (entry [..., 1]) must be > -1 so "
                         f"that ranges stay positive; received {describe(b)}")
    if np.any(np.abs(b[..., 2]) > np.pi):
        raise ValueError(f"`{name}`: the azimuth offset (entry [..., 2]) must lie in "
                         f"[-pi, pi] rad; received {describe(b)}")
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
    try:
        arr = np.asarray(fixed)
    except ValueError:
        arr = np.asarray(None)                  # ragged: refused just below, by name
    if arr.dtype != bool:
        raise TypeError(f"`fixed` must be a boolean array of shape ({m}, 3) (True = bias known "
                        f"to be zero); received {describe(fixed)}")
    if arr.shape != (m, 3):
        raise ValueError(f"`fixed` must have shape ({m}, 3); received shape {arr.shape}")
    if arr.all():
        raise ValueError("`fixed` holds every bias fixed: nothing is left to estimate")
    return arr


def _probability_iv(value, name: str, *, open_interval: bool = True) -> float:
    """One probability (a scalar), refused by name otherwise."""
    p = as_probability(value, name, open_interval=open_interval)
    if p.ndim:
        raise ValueError(f"`{name}` must be a single probability; received {describe(value)}")
    return float(p)


def _polar_reports_iv(reports, name: str, m: int | None = None) -> np.ndarray:
    z = as_float_array(reports, name, ndim_min=2, last_dims=(None, 2))
    if np.any(z[..., 0] <= 0):
        raise ValueError(f"`{name}`: ranges (entry [..., 0]) must be > 0; received "
                         f"{describe(z)}")
    if np.any(z[..., 0] > MAX_MAGNITUDE):
        raise ValueError(f"`{name}`: ranges (entry [..., 0]) must lie within the numeric domain "
                         f"<= 2**150 (about 1.4e45; see engine.linalg); received a range of "
                         f"{float(z[..., 0].max()):.4g}")
    if m is not None and (z.ndim < 3 or z.shape[-3] != m):
        raise ValueError(f"`{name}` must have shape (..., {m}, n, 2): per radar, n reports of "
                         f"(range, azimuth); received shape {z.shape}")
    return z


def _targets_iv(targets, sensors: np.ndarray, name: str = "targets") -> np.ndarray:
    t = as_float_array(targets, name, ndim_min=2, last_dims=(None, 2))
    d = t[..., None, :, :] - sensors[:, None, :]
    if np.any(np.hypot(d[..., 0], d[..., 1]) <= 0):
        raise ValueError(f"`{name}`: an object sits exactly on a radar site (zero range); "
                         f"received {describe(t)}")
    return t


def _elements(count: int, name: str) -> None:
    check_size(count, MAX_ELEMENTS, what=f"batch elements x radars x objects (`{name}`)",
               alternative="fewer trials per call (split the batch)")


def _require_finite_range(out, r, name: str) -> None:
    if not np.all(np.isfinite(out)):
        raise ValueError(f"`{name}` and `biases`: the biased or corrected range overflows "
                         f"float64 (largest `{name}` {float(np.max(r)):.3g}); express ranges "
                         "in a larger unit")


def _wrap(angle):
    """Angle wrapped to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


# --------------------------------------------------------------------------- the model
def apply_biases(r, beta, biases):
    r"""Biased range and azimuth of true polar coordinates.

    Parameters
    ----------
    r : array_like
        True ranges :math:`r > 0`.
    beta : array_like
        True azimuths :math:`\beta` in radians (counter-clockwise from x).
    biases : array_like, shape (..., 3)
        :math:`(\Delta r, g, \Delta\beta)`: range offset (unit of
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

        r^{b} = (1 + g)\, r + \Delta r, \qquad \beta^{b} = \beta + \Delta\beta .

    Examples
    --------
    >>> apply_biases(100.0, 0.5, [0.2, 1e-3, 0.01])
    (array(100.3), array(0.51))
    """
    r = as_positive(r, "r")
    beta = as_float_array(beta, "beta")
    b = _biases_iv(biases)
    try:
        with np.errstate(over="ignore", invalid="ignore"):
            out = ((1.0 + b[..., 1]) * r + b[..., 0], beta + b[..., 2])
    except ValueError:
        raise ValueError(f"`r`, `beta` and `biases[..., :]` must broadcast; received shapes "
                         f"{r.shape}, {beta.shape}, {b.shape}") from None
    _require_finite_range(out[0], r, "r")
    return tuple(np.asarray(o) for o in np.broadcast_arrays(*out))


def remove_biases(r_hat, beta_hat, biases):
    r"""Correct measured ranges and azimuths for known biases (the inverse of :func:`apply_biases`).

    Parameters
    ----------
    r_hat, beta_hat : array_like
        Measured range (> 0) and azimuth (rad).
    biases : array_like, shape (..., 3)
        :math:`(\Delta r, g, \Delta\beta)`, broadcasting as in
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

        r = (\hat r - \Delta r)/(1 + g), \qquad \beta = \hat\beta - \Delta\beta .

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
        with np.errstate(over="ignore", invalid="ignore"):
            rc = (r - b[..., 0]) / (1.0 + b[..., 1])
        bc = beta - b[..., 2]
    except ValueError:
        raise ValueError(f"`r_hat`, `beta_hat` and `biases[..., :]` must broadcast; received "
                         f"shapes {r.shape}, {beta.shape}, {b.shape}") from None
    _require_finite_range(rc, r, "r_hat")
    if np.any(rc <= 0):
        raise ValueError("`biases`: the range offset exceeds a measured range, so a corrected "
                         f"range is not positive; received smallest corrected range "
                         f"{float(np.min(rc)):.6g}")
    return tuple(np.asarray(o) for o in np.broadcast_arrays(rc, bc))


def true_polar(sensors, targets):
    r"""True range and azimuth of every object from every radar.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites.
    targets : array_like, shape (..., n, 2)
        Object positions (a leading batch allowed).

    Returns
    -------
    numpy.ndarray, shape (..., m, n, 2)
        :math:`(r_{ik}, \beta_{ik})` with :math:`r_{ik} = \lVert x_k - s_i\rVert` and
        :math:`\beta_{ik} = \operatorname{atan2}(y_k - s_{i,y}, x_k - s_{i,x})`.

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


def draw_biased_reports(sensors, targets, biases, sigma_r, sigma_beta, *, trials=None,
                        rng=None):
    r"""Draw biased, noisy polar reports of every object by every radar.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites.
    targets : array_like, shape (..., n, 2)
        Object positions.
    biases : array_like, shape (..., m, 3)
        Each radar's :math:`(\Delta r, g, \Delta\beta)`; leading axes
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
        Reports :math:`(\hat r_{ik}, \hat\beta_{ik})`: report ``k`` of every
        radar is of object ``k`` (shuffle them to hide the association).

    Raises
    ------
    ValueError, TypeError
        Bad shapes or values (named), a batch above :data:`MAX_ELEMENTS`, or a
        range so small that a negative range could be drawn
        (:math:`r < 8\sigma_r`).

    Examples
    --------
    >>> z = draw_biased_reports([[0.0, 0.0], [10.0, 0.0]], [[5.0, 50.0]], [[0, 0, 0]] * 2,
    ...                         0.05, 1e-3, trials=4, rng=1)
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
    r"""Convert polar reports to Cartesian positions, optionally correcting known biases first.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites.
    reports : array_like, shape (..., m, n, 2)
        Polar reports :math:`(\hat r, \hat\beta)` of each radar.
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
    r"""Where the biases move each object's noise-free report: the Cartesian bias.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
    targets : array_like, shape (..., n, 2)
    biases : array_like, shape (..., m, 3)

    Returns
    -------
    numpy.ndarray, shape (..., m, n, 2)
        :math:`\mu_{ik} = s_i + r^b_{ik} u(\beta^b_{ik}) - x_k`, exact, with
        :math:`(r^b, \beta^b)` from :func:`apply_biases` and
        :math:`u(\beta) = (\cos\beta, \sin\beta)`.

    Notes
    -----
    To first order in the biases,
    :math:`\mu \approx (\Delta r + g r)\, u(\beta) + r\,\Delta\beta\, u^\perp(\beta)`,
    :math:`u^\perp = (-\sin\beta, \cos\beta)`: range biases move a report
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
    r"""Noncentrality of the proximity measure of a TRUE pair of biased reports (two radars).

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
        :math:`\lambda_k = (\mu_{1k} - \mu_{2k})^{\mathsf T} S_k^{-1} (\mu_{1k} - \mu_{2k})`
        with :math:`\mu` from :func:`bias_displacement` and
        :math:`S_k = \Sigma_{1k} + \Sigma_{2k}` the linearized covariances
        (eqs. 2a–c of the conversion chapter) at the true position.

    Raises
    ------
    ValueError, TypeError
        Bad shapes or values, named; `sensors` must hold exactly two sites.

    Notes
    -----
    With linearized Gaussian errors the difference of the two reports of one
    object is :math:`\Delta \sim \mathcal N(\mu_1 - \mu_2, S)`, so the
    proximity measure :math:`\kappa = \Delta^{\mathsf T} S^{-1} \Delta` of the
    *true* pair follows the noncentral law :math:`\chi'^2_2(\lambda)` instead
    of :math:`\chi^2_2` (the book's eq. ``eq-registration-lambda``).

    Examples
    --------
    >>> round(float(noncentrality([[0, 0], [0, 0.001]], [[100.0, 0.0]],
    ...                           [[0.1, 0, 0], [0, 0, 0]], 0.1, 1e-3)[0]), 6)
    0.5
    """
    s, sr, sb = _two_radars_iv(sensors, sigma_r, sigma_beta)
    polar = true_polar(s, targets)
    # each radar's mean position error
    mu = bias_displacement(s, targets, biases)
    cov = conversion.polar_to_cartesian(polar[..., 0], polar[..., 1],
                                        sr[:, None], sb[:, None]).cov
    # lambda = (mu1 - mu2)^T (Sigma1 + Sigma2)^-1 (mu1 - mu2)
    delta = mu[..., 0, :, :] - mu[..., 1, :, :]
    summed = cov[..., 0, :, :, :] + cov[..., 1, :, :, :]
    _require_variance_domain(summed, sr, sb)
    return np.asarray(mahalanobis_sq(delta, summed), dtype=float)


def _require_variance_domain(cov, sr, sb) -> None:
    """Refuse, naming the sigmas, covariances outside the numeric domain of engine.linalg."""
    var = np.diagonal(cov, axis1=-2, axis2=-1)
    if var.size and (var.max() > MAX_MAGNITUDE or var.min() < 1.0 / MAX_MAGNITUDE):
        raise ValueError(
            f"`sigma_r`, `sigma_beta`: the report variances they give at these ranges, "
            f"{var.min():.3g} to {var.max():.3g}, leave the numeric domain [2**-150, 2**150] "
            f"(sigma_r = {np.max(sr):.3g}, sigma_beta = {np.max(sb):.3g}); express lengths "
            "in a unit where ranges and sigma_r are nearer 1")


def _two_radars_iv(sensors, sigma_r, sigma_beta):
    s = _sensors_iv(sensors)
    if s.shape[0] != 2:
        raise ValueError(f"`sensors` must hold exactly two radar sites, shape (2, 2); received "
                         f"shape {s.shape}")
    return (s, *_sigmas_iv(sigma_r, sigma_beta, 2))


def cost_matrix(sensors, reports1, reports2, sigma_r, sigma_beta, *, biases=None):
    r"""Proximity measures of every pair of reports of two radars, after optional bias correction.

    Parameters
    ----------
    sensors : array_like, shape (2, 2)
        The two radar sites.
    reports1, reports2 : array_like, shape (..., n1, 2) and (..., n2, 2)
        Polar reports :math:`(\hat r, \hat\beta)` of radar 1 and radar 2.
    sigma_r, sigma_beta : float or array_like, shape (2,)
        Random error standard deviations.
    biases : array_like, shape (..., 2, 3), optional
        Biases corrected before conversion (None: none).

    Returns
    -------
    numpy.ndarray, shape (..., n1, n2)
        :math:`\kappa_{ij} = \Delta_{ij}^{\mathsf T}(\Sigma_{1i} + \Sigma_{2j})^{-1}\Delta_{ij}`,
        eq. ``eq-proximity``, with the converted reports and their linearized
        covariances (:func:`to_cartesian`); the input of
        :func:`radarfusion_ref.engine.assignment.assign_two_lists`.

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
    s, sr, sb = _two_radars_iv(sensors, sigma_r, sigma_beta)
    z1 = _polar_reports_iv(reports1, "reports1")
    z2 = _polar_reports_iv(reports2, "reports2")
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
    for k, (cov, z) in enumerate(((c1, z1), (c2, z2))):
        bad = ~np.asarray(is_positive_definite(cov))
        if np.any(bad):
            # the cross-range deviation r sigma_beta against sigma_r: a report next to its
            # radar has no azimuth to speak of, whatever the sigmas
            rng_k = np.broadcast_to(z[..., 0], bad.shape)
            near = bad & (rng_k * sb[k] < 1e-6 * sr[k])
            # the report's range is the cause only where a typical range is resolvable
            if np.any(near) and np.max(rng_k) * sb[k] >= 1e-6 * sr[k]:
                i = tuple(int(v) for v in np.argwhere(near)[0])
                raise ValueError(
                    f"`reports{k + 1}`: report {i} is at range {float(rng_k[i]):.3g}, next to "
                    f"radar {k}'s site: its cross-range deviation r*sigma_beta = "
                    f"{float(rng_k[i]) * sb[k]:.3g} is below 1e-6 of sigma_r = {sr[k]:.3g}, so "
                    "its covariance is singular; drop reports at the site or give them a "
                    "range of at least 1e-6 sigma_r / sigma_beta")
            raise ValueError(
                f"`sigma_r`, `sigma_beta`: radar {k}'s report covariances are singular to "
                f"working precision (sigma_r = {sr[k]:.3g}, sigma_beta = {sb[k]:.3g} rad at "
                f"ranges up to {float(np.max(z1[..., 0] if k == 0 else z2[..., 0])):.3g}: "
                "ellipses too thin for float64); no proximity can be computed from them")
    try:
        return np.asarray(mahalanobis_sq_pairwise(x1, x2, c1, c2), dtype=float)
    except ValueError as exc:   # the engine names its own arguments; name ours
        raise ValueError(str(exc).replace("`x1`", "`reports1`").replace("`x2`", "`reports2`")
                         .replace("`cov1`", "`reports1`").replace("`cov2`", "`reports2`")
                         ) from None
