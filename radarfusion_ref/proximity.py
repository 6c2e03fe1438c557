"""Likelihood and proximity measures of a pointwise association hypothesis.

Hypothesis :math:`G_k`: report :math:`\\hat x_1` of radar 1 and report
:math:`\\hat x_2` of radar 2 belong to one object with unknown position
:math:`x`. With independent Gaussian errors of variances :math:`\\sigma_1^2,
\\sigma_2^2` (covariances :math:`\\Sigma_1, \\Sigma_2` in :math:`d` dimensions):

* the **proximity measure** is :math:`\\kappa = (\\hat x_1 - \\hat x_2)^2 /
  (\\sigma_1^2 + \\sigma_2^2)`, in vector form the squared Mahalanobis distance
  :math:`\\kappa = \\Delta^T S^{-1} \\Delta` with :math:`\\Delta = \\hat x_1 - \\hat x_2`
  and :math:`S = \\Sigma_1 + \\Sigma_2` (the book's eq-proximity); it is
  :math:`\\chi^2_\\nu` (:math:`\\nu = d`) under a true hypothesis and noncentral
  :math:`\\chi'^2_\\nu(\\lambda)` under a false one, with :math:`\\lambda` the same
  quadratic form of the two objects' true positions (eq-proximity-chi2; the
  paper's :math:`V` and :math:`m` are :math:`\\lambda` and :math:`\\nu`);
* the **profile likelihood measure** (the paper's :math:`f_k^*`, eq. (4)) is the
  likelihood (2) with the ML estimate :math:`\\tilde x` substituted,
  :math:`\\exp(-\\kappa/2) / (2\\pi\\sigma_1\\sigma_2)`;
* the **marginal likelihood** integrates :math:`x` out (flat prior),
  :math:`\\exp(-\\kappa/2) / \\sqrt{2\\pi(\\sigma_1^2 + \\sigma_2^2)}`.

Numerical range: :math:`\\kappa` is computed with exact power-of-two scaling, so
it neither overflows nor underflows in intermediate steps; a :math:`\\kappa`
beyond the largest double (about 1.8e308) is refused with a ``ValueError``
instead of being returned as ``inf``. The densities of :func:`proximity_pdf`
switch to the log domain where :mod:`scipy.stats` underflows or returns NaN.

.. rubric:: Public functions

* :func:`proximity` — scalar :math:`\\kappa` (paper, text after eq. (7));
* :func:`mahalanobis_sq` — vector :math:`\\kappa`, batched over leading axes;
* :func:`log_likelihood_measure` — log profile / marginal likelihood, scalar model;
* :func:`log_likelihood_measure_gaussian` — the same for vectors with covariances;
* :func:`best_partner` — which candidate report maximises a likelihood measure;
* :func:`proximity_pdf` — the density of :math:`\\kappa` (the paper's Fig. 1).

.. rubric:: References

.. [1] V. M. Grachov, V. A. Korneev, "Method of combining radar information
   taking coordinate and feature measurements into account", Kharkiv Air
   Force University, 2010 — eqs. (1)–(7), Fig. 1.
"""

from __future__ import annotations

import numpy as np
from scipy import special, stats

from .engine._validation import (
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    broadcast,
    unwrap,
)

__all__ = [
    "best_partner",
    "log_likelihood_measure",
    "log_likelihood_measure_gaussian",
    "mahalanobis_sq",
    "proximity",
    "proximity_pdf",
]

_KINDS = ("profile", "marginal")
_LOG_2PI = float(np.log(2 * np.pi))
#: Below this, scipy's noncentral chi-square density is re-evaluated in the log domain.
_PDF_FLOOR = 1e-200


def _scalar_iv(x1, x2, var1, var2, names=("x1", "x2", "var1", "var2")):
    n1, n2, n3, n4 = names
    a = as_float_array(x1, n1)
    b = as_float_array(x2, n2)
    v1 = as_positive(var1, n3)
    v2 = as_positive(var2, n4)
    return broadcast(**{n1: a, n2: b, n3: v1, n4: v2})


def _gaussian_iv(x1, x2, cov1, cov2):
    a = as_float_array(x1, "x1", ndim_min=1)
    b = as_float_array(x2, "x2", ndim_min=1)
    c1 = as_covariance(cov1, "cov1")
    c2 = as_covariance(cov2, "cov2")
    d = a.shape[-1]
    for name, arr, got in (("x2", b, b.shape[-1]), ("cov1", c1, c1.shape[-1]),
                           ("cov2", c2, c2.shape[-1])):
        if got != d:
            want = "(..., d)" if name == "x2" else "(..., d, d)"
            raise ValueError(
                f"`{name}` must have shape {want} with d = {d} (the last axis of `x1`); "
                f"received shape {arr.shape}"
            )
    try:
        lead = np.broadcast_shapes(a.shape[:-1], b.shape[:-1], c1.shape[:-2], c2.shape[:-2])
    except ValueError:
        raise ValueError(
            "`x1`, `x2`, `cov1`, `cov2` must have broadcastable leading (batch) axes; received "
            f"shapes {a.shape}, {b.shape}, {c1.shape}, {c2.shape}"
        ) from None
    return a, b, c1, c2, lead


def _difference(a, b):
    """``(a - b) / 2**k`` and the factor ``4**k`` for kappa: no overflow for finite inputs."""
    with np.errstate(over="ignore", invalid="ignore"):
        delta = a - b
    over = ~np.isfinite(delta)
    if np.any(over):
        delta = np.where(over, 0.5 * a - 0.5 * b, delta)
    return delta, np.where(over, 4.0, 1.0)


def _refuse_overflow(kappa, names):
    if not np.all(np.isfinite(kappa)):
        bad = int(np.count_nonzero(~np.isfinite(kappa)))
        raise ValueError(
            f"{names}: the proximity measure kappa exceeds the largest double (about 1.8e308) "
            f"at {bad} entries — the reports differ by more than ~1.3e154 standard deviations; "
            "rescale the coordinates or the covariances (for example to other units)"
        )


def _kappa_scalar(a, b, v1, v2, names="`x1`, `x2`"):
    """(a - b)^2 / (v1 + v2) without intermediate overflow or underflow."""
    delta, factor = _difference(a, b)
    root_s = np.hypot(np.sqrt(v1), np.sqrt(v2))     # sqrt(v1 + v2), never overflows
    with np.errstate(over="ignore"):
        z = delta / root_s
        kappa = factor * (z * z)
    _refuse_overflow(kappa, names)
    return kappa


def _pow2_scale(c1, c2):
    """A power of two near the largest entry of each pair of covariances (exact scaling)."""
    big = np.maximum(np.max(np.abs(c1), axis=(-2, -1)), np.max(np.abs(c2), axis=(-2, -1)))
    _, e = np.frexp(big)
    return np.ldexp(1.0, e - 1)                       # 2**(e-1) <= big < 2**e


def _kappa_vector(a, b, c1, c2, lead, names="`x1`, `x2`"):
    """Delta' (c1 + c2)^-1 Delta by a Cholesky factor, scaled by powers of two."""
    delta, factor = _difference(a, b)
    factor = factor.max(axis=-1) if factor.ndim else factor
    scale = _pow2_scale(c1, c2)                       # shape: broadcast of the batch axes
    s = c1 / scale[..., None, None] + c2 / scale[..., None, None]
    delta = delta / np.sqrt(scale)[..., None]
    d = delta.shape[-1]
    with np.errstate(over="ignore", invalid="ignore"):
        if d == 1:
            out = delta[..., 0] ** 2 / s[..., 0, 0]
        elif d == 2:
            l11 = np.sqrt(s[..., 0, 0])
            l21 = s[..., 1, 0] / l11
            l22 = np.sqrt(s[..., 1, 1] - l21**2)
            z1 = delta[..., 0] / l11
            z2 = (delta[..., 1] - l21 * z1) / l22
            out = z1**2 + z2**2
        else:
            L = np.linalg.cholesky(s)
            bshape = np.broadcast_shapes(L.shape[:-2], delta.shape[:-1])
            z = np.linalg.solve(np.broadcast_to(L, (*bshape, d, d)),
                                np.broadcast_to(delta, (*bshape, d))[..., None])[..., 0]
            out = np.sum(z**2, axis=-1)
        out = np.broadcast_to(out * factor, lead)
    _refuse_overflow(out, names)
    return out


def proximity(x1, x2, var1, var2):
    """Proximity measure of two scalar reports, :math:`\\kappa = (\\hat x_1 - \\hat x_2)^2/(\\sigma_1^2 + \\sigma_2^2)`.

    Parameters
    ----------
    x1, x2 : float or array_like
        Reports :math:`\\hat x_1` of radar 1 and :math:`\\hat x_2` of radar 2.
    var1, var2 : float or array_like
        Error variances :math:`\\sigma_1^2, \\sigma_2^2 > 0`.

    Returns
    -------
    float or numpy.ndarray
        :math:`\\kappa \\ge 0`, broadcast over the arguments.

    Raises
    ------
    ValueError
        If a variance is not positive, an entry is not finite, the shapes
        do not broadcast, or :math:`\\kappa` exceeds the largest double.
    TypeError
        If an argument is not numeric (bools and strings included).

    Notes
    -----
    .. math::

        \\kappa = \\frac{(\\hat x_1 - \\hat x_2)^2}{\\sigma_1^2 + \\sigma_2^2}
        \\sim \\chi^2_1 \\text{ under } G_k \\text{ true}, \\qquad
        \\chi'^2_1\\!\\Bigl(\\lambda = \\tfrac{(x_1 - x_2)^2}{\\sigma_1^2 + \\sigma_2^2}\\Bigr)
        \\text{ under } G_k \\text{ false},

    where :math:`x_1, x_2` are the true positions of the two different
    objects. :math:`-\\kappa/2` is the exponent of the likelihood measure (7).
    The ratio is formed as :math:`z^2`, :math:`z = \\Delta/\\sqrt{\\sigma_1^2 +
    \\sigma_2^2}` with the square root taken as ``hypot(sigma1, sigma2)``, so
    coordinates and variances anywhere in the float range give the correctly
    rounded :math:`\\kappa` when it is representable.

    References
    ----------
    Grachov & Korneev (2010), eq. (7) and the text after it.

    Examples
    --------
    >>> proximity(1.0, 0.0, 0.5, 0.5)
    1.0
    >>> proximity([0.0, 2.0], 0.0, 1.0, [1.0, 3.0])
    array([0., 1.])
    >>> proximity(1e200, 0.0, 1e300, 1e300)
    5e+99
    """
    a, b, v1, v2 = _scalar_iv(x1, x2, var1, var2)
    return unwrap(_kappa_scalar(a, b, v1, v2))


def mahalanobis_sq(x1, x2, cov1, cov2):
    """Squared Mahalanobis distance :math:`\\Delta^T (\\Sigma_1 + \\Sigma_2)^{-1} \\Delta` of paired reports.

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        Reports of radar 1 and radar 2 (:math:`d`-dimensional positions).
    cov1, cov2 : array_like, shape (..., d, d)
        Error covariances :math:`\\Sigma_1, \\Sigma_2`, each symmetric positive
        definite (checked: a non-symmetric, singular or indefinite matrix is
        refused even when the sum would be positive definite).

    Returns
    -------
    float or numpy.ndarray, shape (...)
        :math:`\\kappa`, broadcast over the leading (batch) axes of all four
        arguments.

    Raises
    ------
    ValueError
        If a covariance is not symmetric positive definite, the last axes do not
        agree on :math:`d`, the batch axes do not broadcast, an entry is not
        finite, or :math:`\\kappa` exceeds the largest double.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    With :math:`S = \\Sigma_1 + \\Sigma_2 = L L^T` (Cholesky) and :math:`z = L^{-1}\\Delta`
    (a triangular solve),

    .. math::

        \\kappa = \\Delta^T S^{-1} \\Delta = z^T z \\sim \\chi^2_d
        \\text{ under a true hypothesis.}

    No inverse is formed. For :math:`d = 1` and :math:`d = 2` the Cholesky
    factor is written out in closed form (one division; two square roots),
    which is several times faster than the batched LAPACK path for large
    batches of small matrices. Both covariances are divided by a power of two
    near their largest entry (exact), and :math:`\\Delta` by its square root, so
    entries anywhere in the float range neither overflow nor underflow.

    References
    ----------
    Grachov & Korneev (2010), eq. (7), generalised to vectors; see also
    Bar-Shalom, Willett & Tian (2011), the track-to-track association test.

    Examples
    --------
    >>> mahalanobis_sq([1.0, 0.0], [0.0, 0.0], np.eye(2), np.eye(2))
    0.5
    >>> mahalanobis_sq(np.zeros((3, 2)), [[1.0, 1.0]], np.eye(2), 3 * np.eye(2)).round(3)
    array([0.5, 0.5, 0.5])
    """
    a, b, c1, c2, lead = _gaussian_iv(x1, x2, cov1, cov2)
    return unwrap(_kappa_vector(a, b, c1, c2, lead))


def log_likelihood_measure(x1, x2, var1, var2, *, kind="profile"):
    """Log likelihood measure of the hypothesis that two scalar reports share one object.

    Parameters
    ----------
    x1, x2 : float or array_like
        Reports :math:`\\hat x_1, \\hat x_2`.
    var1, var2 : float or array_like
        Error variances :math:`\\sigma_1^2, \\sigma_2^2 > 0`.
    kind : {"profile", "marginal"}, optional
        ``"profile"`` (default): the paper's measure :math:`f_k^*`, the likelihood
        (2) at the ML estimate :math:`\\tilde x` (eq. (4)). ``"marginal"``: the
        likelihood with :math:`x` integrated out under a flat prior.

    Returns
    -------
    float or numpy.ndarray
        The natural log of the measure, broadcast over the arguments.

    Raises
    ------
    ValueError
        If a variance is not positive, an entry is not finite, the shapes do
        not broadcast, `kind` is unknown or :math:`\\kappa` exceeds the largest
        double.

    Notes
    -----
    With :math:`\\kappa` from :func:`proximity`,

    .. math::

        \\ln f^*_{\\text{profile}} = -\\frac{\\kappa}{2} - \\ln(2\\pi\\sigma_1\\sigma_2),
        \\qquad
        \\ln f_{\\text{marginal}} = -\\frac{\\kappa}{2}
            - \\frac12 \\ln\\bigl(2\\pi(\\sigma_1^2 + \\sigma_2^2)\\bigr).

    :math:`\\ln(\\sigma_1^2 + \\sigma_2^2)` is taken as ``logaddexp`` of the two
    log variances, so it does not overflow. The paper prints (7) with the
    factor :math:`1/(2\\pi(\\sigma_1^2 + \\sigma_2^2))`, which is neither (see the
    errata). The two correct measures differ by a term that depends only on the
    variances, so they rank hypotheses that involve the same sensors identically
    and can disagree otherwise.

    References
    ----------
    Grachov & Korneev (2010), eqs. (2), (4), (7).

    Examples
    --------
    >>> round(log_likelihood_measure(0.0, 0.0, 1.0, 1.0), 6)
    -1.837877
    >>> round(log_likelihood_measure(0.0, 0.0, 1.0, 1.0, kind="marginal"), 6)
    -1.265512
    """
    kind = as_choice(kind, "kind", _KINDS)
    a, b, v1, v2 = _scalar_iv(x1, x2, var1, var2)
    return unwrap(_log_measure(a, b, v1, v2, kind, "`x1`, `x2`"))


def _log_measure(a, b, v1, v2, kind, names):
    kappa = _kappa_scalar(a, b, v1, v2, names)
    lv1, lv2 = np.log(v1), np.log(v2)
    if kind == "profile":
        return -0.5 * kappa - _LOG_2PI - 0.5 * (lv1 + lv2)
    return -0.5 * kappa - 0.5 * (_LOG_2PI + np.logaddexp(lv1, lv2))


def log_likelihood_measure_gaussian(x1, x2, cov1, cov2, *, kind="profile"):
    """Log likelihood measure of a pointwise hypothesis for vector reports.

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        Reports of radar 1 and radar 2.
    cov1, cov2 : array_like, shape (..., d, d)
        Error covariances, symmetric positive definite.
    kind : {"profile", "marginal"}, optional
        See :func:`log_likelihood_measure`.

    Returns
    -------
    float or numpy.ndarray, shape (...)

    Raises
    ------
    ValueError
        As :func:`mahalanobis_sq`, or if `kind` is unknown.

    Notes
    -----
    With :math:`\\kappa` the squared Mahalanobis distance and :math:`S = \\Sigma_1 + \\Sigma_2`,

    .. math::

        \\ln f^*_{\\text{profile}} = -\\frac{\\kappa}{2} - d\\ln 2\\pi
            - \\tfrac12\\ln|\\Sigma_1| - \\tfrac12\\ln|\\Sigma_2|, \\qquad
        \\ln f_{\\text{marginal}} = -\\frac{\\kappa}{2} - \\tfrac d2 \\ln 2\\pi
            - \\tfrac12 \\ln|S|.

    Log-determinants come from Cholesky factors (:math:`\\ln|\\Sigma| = 2\\sum_i \\ln
    L_{ii}`); :math:`S` is scaled by a power of two first, so it cannot overflow.

    Examples
    --------
    >>> v = log_likelihood_measure_gaussian([[1.0]], [[0.0]], [[[1.0]]], [[[3.0]]])
    >>> bool(np.isclose(v, log_likelihood_measure(1.0, 0.0, 1.0, 3.0)))
    True
    """
    kind = as_choice(kind, "kind", _KINDS)
    a, b, c1, c2, lead = _gaussian_iv(x1, x2, cov1, cov2)
    kappa = _kappa_vector(a, b, c1, c2, lead)
    d = a.shape[-1]

    def logdet(c):
        return 2.0 * np.sum(np.log(np.diagonal(np.linalg.cholesky(c), axis1=-2, axis2=-1)),
                            axis=-1)

    if kind == "profile":
        out = -0.5 * kappa - d * _LOG_2PI - 0.5 * (logdet(c1) + logdet(c2))
    else:
        scale = _pow2_scale(c1, c2)
        s = c1 / scale[..., None, None] + c2 / scale[..., None, None]
        out = -0.5 * kappa - 0.5 * d * _LOG_2PI - 0.5 * (logdet(s) + d * np.log(scale))
    return unwrap(np.broadcast_to(out, lead))


def best_partner(x1, candidates, var1, candidate_vars, *, kind="profile"):
    """Index of the candidate report with the largest likelihood measure.

    Parameters
    ----------
    x1 : float or array_like, shape (...)
        Report(s) of radar 1.
    candidates : array_like, shape (..., k)
        For each radar-1 report, :math:`k \\ge 1` candidate partner reports
        (possibly from different sensors), along the last axis.
    var1 : float or array_like, shape (...)
        Variance of `x1`, > 0.
    candidate_vars : array_like, shape (..., k)
        Variance of each candidate (e.g. of the sensor that produced it), > 0.
    kind : {"profile", "marginal"}, optional
        Which likelihood measure to maximise.

    Returns
    -------
    int or numpy.ndarray of int, shape (...)
        ``argmax`` over the candidates of :func:`log_likelihood_measure`.

    Raises
    ------
    ValueError
        If a variance is not positive, an entry is not finite, `candidates`
        has no last axis or an empty one, the shapes do not broadcast, or
        `kind` is unknown. Messages name these public arguments.

    Notes
    -----
    When every candidate comes from sensors with the same variance both kinds
    pick the nearest report (the smallest :math:`\\kappa`); when the candidates'
    variances differ they can disagree, because the two measures differ by a
    variance-dependent term.

    Examples
    --------
    >>> best_partner(0.0, [0.5, -0.2], 1.0, [1.0, 1.0])
    1
    """
    kind = as_choice(kind, "kind", _KINDS)
    a = as_float_array(x1, "x1")
    c = as_float_array(candidates, "candidates", ndim_min=1)
    if c.shape[-1] < 1:
        raise ValueError(f"`candidates` must hold at least one candidate along its last axis; "
                         f"received shape {c.shape}")
    v1 = as_positive(var1, "var1")
    cv = as_positive(candidate_vars, "candidate_vars")
    try:
        np.broadcast_shapes(a.shape, v1.shape)
        np.broadcast_shapes((*a.shape, 1), (*v1.shape, 1), c.shape, cv.shape)
    except ValueError:
        raise ValueError(
            "`x1`, `candidates`, `var1`, `candidate_vars` must broadcast with shapes (...), "
            f"(..., k), (...), (..., k); received shapes {a.shape}, {c.shape}, {v1.shape}, "
            f"{cv.shape}") from None
    a, c, v1, cv = np.broadcast_arrays(a[..., None], c, v1[..., None], cv)
    ll = _log_measure(a, c, v1, cv, kind, "`x1`, `candidates`")
    return unwrap(np.argmax(ll, axis=-1))


def _log_ive(order, z):
    """log of the exponentially scaled Bessel function I_order(z) e^-z, for z > 0.

    scipy's ``ive`` where it is finite and well above underflow; otherwise the
    uniform (Debye) asymptotic expansion with its first correction term, whose
    relative error is O(1 / (order^2 + z^2)) — tiny exactly where ``ive`` fails
    (very large arguments or orders).
    """
    with np.errstate(all="ignore"):
        r = special.ive(order, z)
        out = np.log(np.where(np.isfinite(r) & (r > 1e-290), r, 1.0))
        bad = ~(np.isfinite(r) & (r > 1e-290))
        if np.any(bad):
            v, zz = np.abs(order) * np.ones_like(z), z
            rt = np.hypot(v, zz)
            p = v / rt
            # eta - z = (rt - z) + v log(z / (v + rt)), with rt - z = v^2 / (rt + z)
            eta_minus_z = v * v / (rt + zz) + v * np.log(zz / (v + rt))
            debye = (-0.5 * _LOG_2PI - 0.5 * np.log(rt) + eta_minus_z
                     + np.log1p((3 - 5 * p * p) / (24 * rt)))
            out = np.where(bad, debye, out)
    return out


def _log_ncx2_pdf(k, nu, lam):
    """log density of the noncentral chi-square, k > 0 and lam > 0 (arrays)."""
    rk, rl = np.sqrt(k), np.sqrt(lam)
    root = rk * rl                                   # sqrt(k lam) without overflow
    gap = (k - lam) / (rk + rl)                      # sqrt k - sqrt lam without cancellation
    if nu == 1:
        # (phi(sqrt k - sqrt lam) + phi(sqrt k + sqrt lam)) / (2 sqrt k), exactly
        return (-0.5 * _LOG_2PI - 0.5 * gap**2 + np.log1p(np.exp(-2 * root))
                - np.log(2 * rk))
    return (-np.log(2.0) - 0.5 * gap**2 + (nu / 4 - 0.5) * (np.log(k) - np.log(lam))
            + _log_ive(nu / 2 - 1, root))


def proximity_pdf(kappa, *, dof=1, noncentrality=0.0):
    """Density of the proximity measure: :math:`\\chi^2_\\nu` or noncentral :math:`\\chi'^2_\\nu(\\lambda)`.

    Parameters
    ----------
    kappa : float or array_like
        Points :math:`\\kappa \\ge 0` at which to evaluate the density.
    dof : int, optional
        Degrees of freedom :math:`\\nu` (the dimension :math:`d`; the paper's
        :math:`m`). Default 1.
    noncentrality : float or array_like, optional
        :math:`\\lambda \\ge 0` (the paper's :math:`V`); 0 (default) gives the
        law under a true hypothesis.

    Returns
    -------
    float or numpy.ndarray
        The density, finite everywhere except at :math:`\\kappa = 0` with
        :math:`\\nu = 1`, where the density is infinite and ``inf`` is returned.

    Raises
    ------
    ValueError
        If `kappa` or `noncentrality` is negative or not finite, or `dof` < 1.
    TypeError
        If an argument is not numeric, or `dof` is not an integer.

    Notes
    -----
    .. math::

        f_{\\chi'^2_\\nu(\\lambda)}(\\kappa) = \\sum_{j\\ge 0} \\frac{e^{-\\lambda/2}(\\lambda/2)^j}{j!}\\,
        f_{\\chi^2_{\\nu + 2j}}(\\kappa)
        = \\tfrac12 e^{-(\\sqrt\\kappa - \\sqrt\\lambda)^2/2}
          (\\kappa/\\lambda)^{\\nu/4 - 1/2}\\, I_{\\nu/2 - 1}(\\sqrt{\\lambda\\kappa})\\,
          e^{-\\sqrt{\\lambda\\kappa}},

    evaluated with :mod:`scipy.stats` (``chi2`` at :math:`\\lambda = 0`, ``ncx2``
    otherwise). Where scipy returns NaN (very large :math:`\\lambda`), a value
    below 1e-200 (where it may have underflowed) or the wrong limit at
    :math:`\\kappa = 0`, the Bessel form on the right is evaluated in the log
    domain (exponentially scaled Bessel function, or its uniform asymptotic
    expansion). The two curves for :math:`\\lambda = 0` and :math:`\\lambda > 0`
    are the paper's Fig. 1.

    Examples
    --------
    >>> round(proximity_pdf(1.0), 6)
    0.241971
    >>> f"{proximity_pdf(1e15, noncentrality=1e15):.6e}"  # scipy alone gives nan
    '6.307831e-09'
    """
    k = as_positive(kappa, "kappa", strict=False)
    nu = as_int(dof, "dof", minimum=1)
    v = as_positive(noncentrality, "noncentrality", strict=False)
    k, v = broadcast(kappa=k, noncentrality=v)
    with np.errstate(all="ignore"):
        central = stats.chi2.pdf(k, nu)
        out = np.where(v > 0, stats.ncx2.pdf(k, nu, np.where(v > 0, v, 1.0)), central)
        redo = (v > 0) & (k > 0) & ~(np.isfinite(out) & (out > _PDF_FLOOR))
        if np.any(redo):
            out = np.where(redo, np.exp(_log_ncx2_pdf(np.where(redo, k, 1.0), nu,
                                                      np.where(redo, v, 1.0))), out)
        # the limit kappa -> 0 under lambda > 0: inf (nu = 1), e^{-lambda/2}/2 (nu = 2), 0
        at0 = (v > 0) & (k == 0)
        if np.any(at0):
            lim = np.inf if nu == 1 else (0.5 * np.exp(-0.5 * v) if nu == 2 else 0.0)
            out = np.where(at0, lim, out)
    return unwrap(out)
