r"""Range, azimuth and elevation to Cartesian in 3-D, with its moments and Monte Carlo."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..engine.errors import RadarFusionWarning
from ..engine.geometry import as_sigma_beta
from ..engine.validation import (
    MEMORY_LIMIT,
    as_choice,
    as_float_array,
    as_int,
    as_positive,
    as_rng,
    broadcast,
    check_size,
)
from ._consistency import (
    ConversionTrials,
    _as_methods,
    _draw_range_azimuth,
    nees_per_trial,
)
from ._planar import (
    METHODS_3D,
    ConversionMoments,
    _check_batch,
    _scale,
)


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
    sigma_beta = as_sigma_beta(sigma_beta, strict=strict)
    sigma_epsilon = as_sigma_beta(sigma_epsilon, "sigma_epsilon", strict=strict)
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


def spherical_covariance(r, beta, epsilon, sigma_r, sigma_beta,
                         sigma_epsilon, *, method: str = "linearized"):
    r"""A 3-D method's covariance at the measurement :math:`(\hat r, \hat\beta, \hat\varepsilon)`.

    With :math:`a = a(\hat\beta, \hat\varepsilon)` the line of sight and :math:`Z` the
    damping of the angle errors (:math:`E[a(\beta, \varepsilon)] = Z a` given the
    measurement), the truth given the measurement has
    :math:`\operatorname{Cov} = (\hat r^2 + \sigma_r^2)E[aa^\mathsf T] - \hat r^2 Zaa^\mathsf T Z`
    (measurement-conditioned); the multiplicative method adds the square of its offset from
    that mean, the additive one is Lerro & Bar-Shalom's average of the covariance given the
    truth, and the linearized one is :math:`J\,\mathrm{diag}(\sigma_r^2, \sigma_\beta^2,
    \sigma_\varepsilon^2)J^\mathsf T`.

    Parameters
    ----------
    r, beta, epsilon : array_like
        Measured range (:math:`\ge 0`, at most 1e150; :func:`spherical_to_cartesian` scales
        larger ones), azimuth and elevation (radians).
    sigma_r, sigma_beta, sigma_epsilon : array_like
        Error standard deviations (:math:`\sigma_r` at most 1e150, the angles' at most
        :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX`).
    method : str
        One of :data:`METHODS_3D` (keyword-only).

    Returns
    -------
    numpy.ndarray, shape (..., 3, 3)

    Raises
    ------
    ValueError
        Bad values or shapes (named), or an unknown `method`.

    Examples
    --------
    >>> spherical_covariance(100.0, 0.0, 0.0, 0.1, 0.01, 0.02).round(6)
    array([[0.01, 0.  , 0.  ],
           [0.  , 1.  , 0.  ],
           [0.  , 0.  , 4.  ]])
    """
    r, beta, eps, sigma_r, sb2, se2, method = _covariance_iv(
        r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, method)
    a = _unit3(beta, eps)
    lam = _damping3(sb2, se2)
    sr2 = sigma_r**2
    r2 = (r**2)[..., None, None]
    if method == "linearized":              # J diag(σr², σβ², σε²) Jᵀ
        ce, se = np.cos(eps), np.sin(eps)
        jb = np.stack([-ce * np.sin(beta), ce * np.cos(beta),
                       np.zeros_like(ce)], -1)
        je = np.stack([-se * np.cos(beta), -se * np.sin(beta), ce], -1)
        return (sr2[..., None, None] * _outer(a, a)
                + r2 * sb2[..., None, None] * _outer(jb, jb)
                + r2 * se2[..., None, None] * _outer(je, je))
    # Cov[x | measurement] = (r̂² + σr²) E[aaᵀ] − r̂² Zaaᵀ Z
    # (truth ~ N(measurement, σ²))
    la = lam * a
    cond = ((r2 + sr2[..., None, None]) * _second3(beta, eps, sb2, se2)
            - r2 * _outer(la, la))
    if method == "measurement_conditioned":
        return cond
    if method == "multiplicative":
        # MSE given the measurement: + (x̂ − E[x|z])(…)ᵀ
        d = (1.0 / lam - lam) * a
        return cond + r2 * _outer(d, d)
    # "additive": Lerro & Bar-Shalom's
    # E[Cov(r̂a(β̂, ε̂) | truth) | measurement] — the errors damp the
    # harmonics twice, and E[r² + σr² | z] = r̂² + 2σr²
    return ((r2 + 2 * sr2[..., None, None])
            * _second3(beta, eps, 2 * sb2, 2 * se2)
            - (r2 + sr2[..., None, None]) * lam[..., :, None]
            * _second3(beta, eps, sb2, se2) * lam[..., None, :])



def _covariance_iv(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, method):
    method = as_choice(method, "method", METHODS_3D)
    r, beta, eps, sigma_r, sigma_beta, sigma_epsilon = _spherical_iv(
        r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon)
    for name, v in (("r", r), ("sigma_r", sigma_r)):
        if np.any(v > 1e150):
            raise ValueError(f"`{name}` must be at most 1e150 here (its square must stay finite); "
                             f"received largest entry {float(np.max(v)):.6g}; "
                             "spherical_to_cartesian scales larger values")
    return r, beta, eps, sigma_r, sigma_beta**2, sigma_epsilon**2, method


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
    cov = spherical_covariance(np.ldexp(r, -e), beta, eps, np.ldexp(sigma_r, -e), sigma_beta,
                               sigma_epsilon, method=method)
    return xyz, _unscale3(cov, e, "covariance")


def spherical_to_cartesian(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, *,
                           method: str = "linearized") -> ConvertedMeasurement3D:
    r"""Convert measured range, azimuth and elevation to a 3-D position and covariance.

    Parameters
    ----------
    r : array_like
        Measured range :math:`\hat r \ge 0`.
    beta : array_like
        Measured azimuth :math:`\hat\beta` in radians, counter-clockwise from the x axis.
    epsilon : array_like
        Measured elevation :math:`\hat\varepsilon` in radians, up from the x–y plane.
    sigma_r, sigma_beta, sigma_epsilon : array_like
        Error standard deviations (≥ 0; the angular ones in radians, at most
        :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX`).
        The errors are independent and Gaussian.
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
        above :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX`,
        non-finite input, shapes that do not broadcast,
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
    With :math:`a(\beta, \varepsilon) = (\cos\varepsilon\cos\beta, \cos\varepsilon\sin\beta,
    \sin\varepsilon)`, :math:`q_\beta = e^{-\sigma_\beta^2/2}`, :math:`q_\varepsilon =
    e^{-\sigma_\varepsilon^2/2}` and :math:`\Lambda = \operatorname{diag}(q_\beta q_\varepsilon,
    q_\beta q_\varepsilon, q_\varepsilon)`, the plain conversion has mean
    :math:`E[\hat r a(\hat\beta, \hat\varepsilon) \mid r, \beta, \varepsilon] = \Lambda\, r a`:
    its bias is :math:`(\Lambda - I) r a`, and the vertical component is damped less than the
    horizontal ones. Every method returns :math:`\hat{\mathbf x} = G\hat r a(\hat\beta,
    \hat\varepsilon)` with a diagonal gain :math:`G`: :math:`I` (linearized), :math:`I + \Lambda -
    \Lambda^2` (additive), :math:`\Lambda^{-1}` (multiplicative, Mo et al. 1998, unbiased given the
    truth), :math:`\Lambda` (measurement-conditioned, Duan et al. 2004: the mean of the truth given
    the measurement). With :math:`D_k = E[a a^\mathsf T]` over angle errors of variances
    :math:`k\sigma^2` about the measurement,

    .. math::

        \operatorname{Cov}[\mathbf x \mid \hat{\mathbf z}] &= (\hat r^2 + \sigma_r^2) D_1
            - \hat r^2 \Lambda a a^\mathsf T \Lambda \quad\text{(measurement-conditioned)},\\
        \mathrm{MSE} &= \operatorname{Cov}[\mathbf x \mid \hat{\mathbf z}] + \hat r^2
            (\Lambda^{-1} - \Lambda) a a^\mathsf T (\Lambda^{-1} - \Lambda)
            \quad\text{(multiplicative)},\\
        \Sigma^a &= (\hat r^2 + 2\sigma_r^2) D_2 - (\hat r^2 + \sigma_r^2)\Lambda D_1 \Lambda
            \quad\text{(additive, Lerro \& Bar-Shalom's average of the covariance given the truth)},

    and the linearized covariance is :math:`J\operatorname{diag}(\sigma_r^2, \sigma_\beta^2,
    \sigma_\varepsilon^2)J^\mathsf T` with :math:`J = \partial(x, y, z)/\partial(r, \beta,
    \varepsilon)` at the measurement. Each entry of :math:`D_k` is a trigonometric polynomial
    whose harmonic :math:`m` of an angle is damped by :math:`e^{-km^2\sigma^2/2}`.

    In 2-D (:math:`\varepsilon = \sigma_\varepsilon = 0`) every method reduces to the one of the
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
    r"""Exact mean, bias, covariance and MSE of a converted 3-D report given the TRUTH.

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

        E[\hat{\mathbf x}] = G\Lambda\, r a(\beta, \varepsilon),\qquad
        \operatorname{Cov}[\hat{\mathbf x}] = G\left[(r^2 + \sigma_r^2) D_1
            - r^2\Lambda a a^\mathsf T\Lambda\right] G,

    with :math:`D_1 = E[a a^\mathsf T]` about the truth (see :func:`spherical_to_cartesian`).
    The multiplicative gain :math:`G = \Lambda^{-1}` makes the bias vanish.

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


def draw_spherical(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, *, trials: int,
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
    r_hat, beta_hat, epsilon_hat : numpy.ndarray, shape (trials, ...)
        The trial axis first, as everywhere in the package.

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
    of the shape ``(..., trials)`` (returned with the trial axis moved first).

    Examples
    --------
    >>> rh, bh, eh = draw_spherical([100.0, 90.0], 0.3, 0.1, 0.1, 0.01, 0.01, trials=4, rng=1)
    >>> eh.shape
    (4, 2)
    """
    trials = as_int(trials, "trials", minimum=1)
    r, beta, eps, sigma_r, sigma_beta, sigma_epsilon = _spherical_iv(
        r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, trials=trials)
    draws = _draw_spherical(r, beta, eps, sigma_r, sigma_beta, sigma_epsilon, trials,
                            as_rng(rng))
    return tuple(np.moveaxis(x, -1, 0) for x in draws)


def _draw_spherical(r, beta, eps, sigma_r, sigma_beta, sigma_epsilon, trials, rng):
    """Noisy ranges, azimuths, then elevations, trial axis last (validated input)."""
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
        As :func:`draw_spherical`; a zero deviation; an unknown or empty `methods`;
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
    rh, bh, eh = _draw_spherical(r, beta, eps, sigma_r, sigma_beta, sigma_epsilon, trials,
                                 as_rng(rng))
    truth = (r[..., None] * _unit3(beta, eps))[..., None, :]
    sr, sb, se = sigma_r[..., None], sigma_beta[..., None], sigma_epsilon[..., None]
    out = {}
    for m in methods:
        xyz, cov = _convert3(m, rh, bh, eh, sr, sb, se)
        err = xyz - truth
        mse = _moments3(m, r, beta, eps, sigma_r, sigma_beta, sigma_epsilon).mse[..., None, :, :]
        out[m] = ConversionTrials(m, err, nees_per_trial(err, cov),
                                  nees_per_trial(err, mse))
    return out
