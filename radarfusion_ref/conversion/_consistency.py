r"""Is a converted covariance right? Noisy polar measurements, NEES, and the Monte Carlo."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..engine.linalg import mahalanobis_sq
from ..engine.montecarlo import MeanEstimate, mean
from ..engine.validation import (
    MEMORY_LIMIT,
    as_choice,
    as_float_array,
    as_int,
    as_positive,
    as_rng,
    broadcast,
    check_size,
    describe,
)
from ._planar import (
    ALL_METHODS,
    MAX_BATCH,
    MIN_RANGE_OVER_SIGMA,
    _bias_factor,
    _check_batch,
    _convert,
    _convert_decorrelated,
    _moments,
    _polar_iv,
    _prior_polar,
    _scale,
    _truth_variances,
    principal_variances,
)


@dataclass(frozen=True)
class ConversionTrials:
    r"""Monte-Carlo trials of one conversion method.

    Attributes
    ----------
    method : str
        One of :data:`METHODS`.
    error : numpy.ndarray, shape (..., trials, 2)
        Converted position minus true position, one row per trial.
    nees : numpy.ndarray, shape (..., trials)
        Normalized estimation error squared
        :math:`\mathbf e^\mathsf T C^{-1}\mathbf e` with the method's own
        covariance :math:`C`; its mean is the dimension (2, or 3 in 3-D) for a
        consistent method.
    nees_true : numpy.ndarray or None, shape (..., trials)
        The same error normalized by the exact mean squared error matrix given the
        truth, :math:`\mathbf e^\mathsf T \mathrm{MSE}^{-1}\mathbf e` (from
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
        r"""Li & Zhao's noncredibility index, in dB, shape ``(...)``, with t-intervals.

        .. math::

            \mathrm{NCI} = \frac{10}{N}\sum_{i=1}^N \log_{10}
            \frac{\mathbf e_i^\mathsf T C_i^{-1}\mathbf e_i}
                 {\mathbf e_i^\mathsf T \mathrm{MSE}^{-1}\mathbf e_i}.

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


def draw_polar(r, beta, sigma_r, sigma_beta, *, trials: int, rng=None):
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
    r_hat, beta_hat : numpy.ndarray, shape (trials, ...)
        The trial axis first, as everywhere in the package.

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
    shape ``(..., trials)`` (returned as views with the trial axis moved first): a
    seed fixes the result for a given batch shape and `trials`.
    :func:`conversion_monte_carlo` makes the same draws and only then works
    through the trials in chunks, so its results do not depend on its `chunk_size`.

    Examples
    --------
    >>> r_hat, b_hat = draw_polar([100.0, 150.0], 0.3, 0.1, 0.01, trials=5, rng=1)
    >>> r_hat.shape
    (5, 2)
    """
    trials = as_int(trials, "trials", minimum=1)
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta, trials=trials)
    r_hat, beta_hat = _draw_range_azimuth(r, beta, sigma_r, sigma_beta, trials, as_rng(rng))
    return np.moveaxis(r_hat, -1, 0), np.moveaxis(beta_hat, -1, 0)


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


def nees_per_trial(error, cov) -> np.ndarray:
    r"""The NEES :math:`\mathbf e^\mathsf T C^{-1}\mathbf e` of every trial: one value per error.

    The per-trial statistic of a conversion's Monte Carlo (the ``nees`` of
    :class:`ConversionTrials`): one value for each error of a batch, with
    covariances that broadcast against the errors (one per trial, or one for
    all), and no summary. The summary over :math:`N` errors — the mean NEES
    and its :math:`\chi^2_{dN}` consistency range — is
    :func:`radarfusion_ref.engine.metrics.nees`; both compute the value with the
    package's one squared Mahalanobis distance,
    :func:`radarfusion_ref.engine.linalg.mahalanobis_sq` (a factorisation of
    :math:`C`, forward substitution, no inverse). If :math:`C` is the true error
    covariance, the mean is the dimension :math:`d`; for Gaussian errors the
    NEES is :math:`\chi^2_d`.

    Parameters
    ----------
    error : array_like, shape (..., d)
        Estimate minus truth, within the engine's numeric domain (entries of
        magnitude at most :data:`radarfusion_ref.engine.validation.MAX_MAGNITUDE`).
    cov : array_like, shape (..., d, d)
        Symmetric positive-definite covariances, broadcasting with `error`, variances
        within the numeric domain.

    Returns
    -------
    numpy.ndarray, shape (...)

    Raises
    ------
    ValueError
        If `cov` is not symmetric positive definite, the shapes disagree, or a value
        lies outside the numeric domain.

    Examples
    --------
    >>> float(nees_per_trial([1.0, 2.0], [[1.0, 0.0], [0.0, 4.0]]))
    2.0
    """
    e = as_float_array(error, "error", ndim_min=1)
    if e.shape[-1] < 1:
        raise ValueError(f"`error` must have shape (..., d) with d >= 1; received shape {e.shape}")
    try:
        batch = np.broadcast_shapes(e.shape[:-1], np.shape(cov)[:-2])
    except ValueError:
        batch = ()                # a shape the engine refuses, naming it
    check_size(math.prod(batch) * e.shape[-1] ** 2, MAX_BATCH,
               what="broadcast `error` × `cov` entries",
               alternative="several calls on slices of the batch")
    try:
        return mahalanobis_sq(e, cov)
    except ValueError as exc:     # the engine names its own argument `d`; this one is `error`
        raise ValueError(str(exc).replace("`d`", "`error`")) from None


def _finite_nees(value):
    if not np.all(np.isfinite(value)):
        raise ValueError("NEES exceeds the float range (1.8e308): `error` is too large for "
                         "`cov`; received an error more than 1e154 standard deviations out")
    return value


def nees_at_truth(r, beta, sigma_r, sigma_beta, *, method: str = "linearized") -> np.ndarray:
    r"""Expected NEES when the method's covariance is evaluated at the TRUE position.

    :math:`\operatorname{tr}\big(\Sigma(r, \beta)^{-1}\,\mathrm{MSE}(r, \beta)\big)`, with
    :math:`\Sigma` the covariance :func:`polar_to_cartesian` would attach to a report
    lying exactly at the truth and MSE the exact mean squared error matrix of
    :func:`conversion_moments`. It is 2 when :math:`\Sigma` is the true MSE. In
    practice :math:`\Sigma` is evaluated at the measurement, and the Monte-Carlo mean
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
    :math:`u(\beta)`, so the trace is the sum of two ratios of principal
    variances, computed without any factorisation:
    :math:`\mathrm{MSE}_\parallel/\Sigma_\parallel + \mathrm{MSE}_\perp/\Sigma_\perp`.

    Examples
    --------
    >>> round(float(nees_at_truth(150.0, 0.0, 0.1, 1e-4)), 4)
    2.0
    """
    method = as_choice(method, "method", ALL_METHODS)
    r, beta, sigma_r, sigma_beta = _polar_iv(r, beta, sigma_r, sigma_beta, strict=True)
    if method == "linearized" and np.any(r == 0):
        raise ValueError("`r` must be > 0 for method 'linearized' (its covariance at zero "
                         f"range is singular); received {describe(r)}")
    s = sigma_beta**2
    e = _scale(r, sigma_r)
    rn, sr2 = np.ldexp(r, -e), np.ldexp(sigma_r, -e) ** 2
    along_t, cross_t = _truth_variances(method, rn, sr2, sigma_beta)
    if method == "decorrelated":      # a prior exactly at the truth: R^D is Cov[x̂ | r, β]
        along_c, cross_c = along_t, cross_t
    else:
        along_c, cross_c = principal_variances(rn, np.ldexp(sigma_r, -e), sigma_beta,
                                               method=method)
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
                        f"{describe(methods)}")
    methods = tuple(as_choice(m, "methods", allowed) for m in methods)
    if not methods:
        raise ValueError("`methods` must name at least one method; received an empty sequence")
    return methods


def conversion_monte_carlo(r, beta, sigma_r, sigma_beta, *,
                           methods=("linearized", "additive", "multiplicative"),
                           trials: int = 10_000, rng=None,
                           chunk_size: int | None = None,
                           prior_std=None) -> dict[str, ConversionTrials]:
    r"""Monte Carlo of the conversion error and NEES for several methods.

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
        (as by :func:`draw_polar`), then converted chunk by chunk.
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
        As :func:`draw_polar`; a zero `sigma_r` or `sigma_beta`; an
        unknown method; an empty `methods`; a `chunk_size` below 1 or above
        :data:`MAX_BATCH`; results above 1 GiB (refused before drawing).

    Notes
    -----
    The NEES of each trial is computed in the covariance's principal axes,
    :math:`(\mathbf e\cdot u)^2/\Sigma_\parallel + (\mathbf e\cdot u_\perp)^2/\Sigma_\perp`
    with :math:`u = u(\hat\beta)`, which equals :math:`\mathbf e^\mathsf T\Sigma^{-1}\mathbf e`
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
                         f"only; received methods {methods} and prior_std {describe(prior_std)}")
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
    r_hat, beta_hat = _draw_range_azimuth(r, beta, sigma_r, sigma_beta, trials, rng)
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
