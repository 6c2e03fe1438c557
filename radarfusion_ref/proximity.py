r"""Likelihood and proximity measures of a pointwise association hypothesis.

Hypothesis :math:`G_k`: report :math:`\hat x_1` of radar 1 and report
:math:`\hat x_2` of radar 2 belong to one object with unknown position
:math:`x`. With independent Gaussian errors of variances :math:`\sigma_1^2,
\sigma_2^2` (covariances :math:`\Sigma_1, \Sigma_2` in :math:`d` dimensions):

* the **proximity measure** is :math:`\kappa = (\hat x_1 - \hat x_2)^2 /
  (\sigma_1^2 + \sigma_2^2)`, in vector form the squared Mahalanobis distance
  :math:`\kappa = \Delta^T S^{-1} \Delta` with :math:`\Delta = \hat x_1 - \hat x_2`
  and :math:`S = \Sigma_1 + \Sigma_2` (the book's eq-proximity); it is
  :math:`\chi^2_\nu` (:math:`\nu = d`) under a true hypothesis and noncentral
  :math:`\chi'^2_\nu(\lambda)` under a false one, with :math:`\lambda` the same
  quadratic form of the two objects' true positions (eq-proximity-chi2; the
  paper's :math:`V` and :math:`m` are :math:`\lambda` and :math:`\nu`);
* the **profile likelihood measure** (the paper's :math:`f_k^*`, eq. (4)) is the
  likelihood (2) with the ML estimate :math:`\tilde x` substituted,
  :math:`\exp(-\kappa/2) / (2\pi\sigma_1\sigma_2)`;
* the **marginal likelihood** integrates :math:`x` out (flat prior),
  :math:`\exp(-\kappa/2) / \sqrt{2\pi(\sigma_1^2 + \sigma_2^2)}`.

Numerical domain: :math:`\kappa` is computed by
:mod:`radarfusion_ref.engine.linalg`, whose documented domain (coordinates of
magnitude at most :math:`2^{150}`, variances in :math:`[2^{-150}, 2^{150}]`)
is refused outside with a ``ValueError`` naming the argument; inside it no
intermediate overflows or underflows. The densities of :func:`proximity_pdf`
switch to the log domain where :mod:`scipy.stats` underflows or returns NaN.

.. rubric:: Public functions

* :func:`proximity` — scalar :math:`\kappa` (paper, text after eq. (7));
* :func:`proximity_gaussian` — vector :math:`\kappa`, batched over leading axes;
* :func:`log_likelihood_measure` — log profile / marginal likelihood, scalar model;
* :func:`log_likelihood_measure_gaussian` — the same for vectors with covariances;
* :func:`best_partner` — which candidate report maximises a likelihood measure;
* :func:`proximity_pdf` — the density of :math:`\kappa` (the paper's Fig. 1).

.. rubric:: References

.. [1] V. M. Grachov, V. A. Korneev, "Method of combining radar information
   taking coordinate and feature measurements into account", Kharkiv Air
   Force University, 2010 — eqs. (1)–(7), Fig. 1.
"""

from __future__ import annotations

import numpy as np
from scipy import special, stats

from .engine.linalg import mahalanobis_sq_kernel
from .engine.validation import (
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    broadcast,
    check_domain,
    unwrap,
)

__all__ = [
    "best_partner",
    "log_likelihood_measure",
    "log_likelihood_measure_gaussian",
    "proximity",
    "proximity_gaussian",
    "proximity_pdf",
]

_KINDS = ("profile", "marginal")
_LOG_2PI = float(np.log(2 * np.pi))
#: Below this, scipy's noncentral chi-square density is re-evaluated in the log domain.
_PDF_FLOOR = 1e-200
#: Above this noncentrality the density is the log-domain Bessel form (2e-14 from mpmath
#: there): scipy 1.11's ncx2 drifts from lambda ~ 1e9 and is wrong by O(1) from ~ 3e10
#: without returning NaN.
_NCX2_SCIPY_MAX = 1e6


def _scalar_iv(x1, x2, var1, var2, names=("x1", "x2", "var1", "var2")):
    """Scalar reports and variances, within the numeric domain of engine.linalg, broadcast."""
    n1, n2, n3, n4 = names
    a = as_float_array(x1, n1)
    b = as_float_array(x2, n2)
    v1 = _as_variance(var1, n3)
    v2 = _as_variance(var2, n4)
    check_domain(a, n1)
    check_domain(b, n2)
    return broadcast(**{n1: a, n2: b, n3: v1, n4: v2})


def _as_variance(value, name):
    """Positive variances within the numeric domain of engine.linalg."""
    return as_covariance(as_positive(value, name)[..., None, None], name)[..., 0, 0]


def _gaussian_iv(x1, x2, cov1, cov2):
    """Vector reports and covariances (the positive-definiteness rule, the domain)."""
    a = as_float_array(x1, "x1", ndim_min=1)
    d = a.shape[-1]
    b = as_float_array(x2, "x2", ndim_min=1)
    c1 = as_covariance(cov1, "cov1")
    c2 = as_covariance(cov2, "cov2")
    for name, arr, got in (("x2", b, b.shape[-1]), ("cov1", c1, c1.shape[-1]),
                           ("cov2", c2, c2.shape[-1])):
        if got != d:
            want = "(..., d)" if name == "x2" else "(..., d, d)"
            raise ValueError(f"`{name}` must have shape {want} with d = {d} (the last axis of "
                             f"`x1`); received shape {arr.shape}")
    check_domain(a, "x1")
    check_domain(b, "x2")
    try:
        np.broadcast_shapes(a.shape[:-1], b.shape[:-1], c1.shape[:-2], c2.shape[:-2])
    except ValueError:
        raise ValueError(
            "`x1`, `x2`, `cov1`, `cov2` must have broadcastable leading (batch) axes; received "
            f"shapes {a.shape}, {b.shape}, {c1.shape}, {c2.shape}"
        ) from None
    return a, b, c1, c2


def proximity(x1, x2, var1, var2):
    r"""Proximity measure of two scalar reports, :math:`\kappa = (\hat x_1 - \hat x_2)^2/(\sigma_1^2 + \sigma_2^2)`.

    Parameters
    ----------
    x1, x2 : float or array_like
        Reports :math:`\hat x_1` of radar 1 and :math:`\hat x_2` of radar 2,
        of magnitude at most :math:`2^{150}`.
    var1, var2 : float or array_like
        Error variances :math:`\sigma_1^2, \sigma_2^2` in :math:`[2^{-150}, 2^{150}]`.

    Returns
    -------
    float or numpy.ndarray
        :math:`\kappa \ge 0`, broadcast over the arguments.

    Raises
    ------
    ValueError
        If a variance is not positive, an entry is not finite or outside the
        numeric domain, or the shapes do not broadcast.
    TypeError
        If an argument is not numeric (bools and strings included).

    Notes
    -----
    .. math::

        \kappa = \frac{(\hat x_1 - \hat x_2)^2}{\sigma_1^2 + \sigma_2^2}
        \sim \chi^2_1 \text{ under } G_k \text{ true}, \qquad
        \chi'^2_1\!\Bigl(\lambda = \tfrac{(x_1 - x_2)^2}{\sigma_1^2 + \sigma_2^2}\Bigr)
        \text{ under } G_k \text{ false},

    where :math:`x_1, x_2` are the true positions of the two different
    objects. :math:`-\kappa/2` is the exponent of the likelihood measure (7).
    It is the one-dimensional squared Mahalanobis distance of
    :mod:`radarfusion_ref.engine.linalg`.

    References
    ----------
    Grachov & Korneev (2010), eq. (7) and the text after it.

    Examples
    --------
    >>> proximity(1.0, 0.0, 0.5, 0.5)
    1.0
    >>> proximity([0.0, 2.0], 0.0, 1.0, [1.0, 3.0])
    array([0., 1.])
    """
    a, b, v1, v2 = _scalar_iv(x1, x2, var1, var2)
    return unwrap(mahalanobis_sq_kernel((a - b)[..., None],
                                        (v1 + v2)[..., None, None], "`x1`, `x2`"))


def proximity_gaussian(x1, x2, cov1, cov2):
    r"""Proximity measure of two vector reports, :math:`\kappa = \Delta^T (\Sigma_1 + \Sigma_2)^{-1} \Delta`.

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        Reports of radar 1 and radar 2 (:math:`d`-dimensional positions),
        coordinates of magnitude at most :math:`2^{150}`.
    cov1, cov2 : array_like, shape (..., d, d)
        Error covariances :math:`\Sigma_1, \Sigma_2`, each obeying the
        positive-definiteness rule of
        :func:`radarfusion_ref.engine.linalg.is_positive_definite` (checked:
        a non-symmetric, singular or indefinite matrix is refused even when the
        sum would be positive definite), variances in :math:`[2^{-150}, 2^{150}]`.

    Returns
    -------
    float or numpy.ndarray, shape (...)
        :math:`\kappa`, broadcast over the leading (batch) axes of all four
        arguments.

    Raises
    ------
    ValueError
        If a covariance breaks the rule, the last axes do not agree on
        :math:`d`, the batch axes do not broadcast, or an entry is not finite
        or outside the numeric domain.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    With :math:`\Delta = \hat x_1 - \hat x_2` and :math:`S = \Sigma_1 + \Sigma_2`,

    .. math::

        \kappa = \Delta^T S^{-1} \Delta \sim \chi^2_d
        \text{ under a true hypothesis,}

    the squared Mahalanobis distance of
    :func:`radarfusion_ref.engine.linalg.mahalanobis_sq` (an :math:`LDL^T`
    factorisation, no inverse). For every pair of two report sets use
    :func:`radarfusion_ref.engine.linalg.mahalanobis_sq_pairwise`.

    References
    ----------
    Grachov & Korneev (2010), eq. (7), generalised to vectors; see also
    Bar-Shalom, Willett & Tian (2011), the track-to-track association test.

    Examples
    --------
    >>> proximity_gaussian([1.0, 0.0], [0.0, 0.0], np.eye(2), np.eye(2))
    0.5
    >>> proximity_gaussian(np.zeros((3, 2)), [[1.0, 1.0]], np.eye(2), 3 * np.eye(2)).round(3)
    array([0.5, 0.5, 0.5])
    """
    a, b, c1, c2 = _gaussian_iv(x1, x2, cov1, cov2)
    delta, s = a - b, c1 + c2
    return unwrap(mahalanobis_sq_kernel(delta, s, "`x1`, `x2`"))


def log_likelihood_measure(x1, x2, var1, var2, *, kind="profile"):
    r"""Log likelihood measure of the hypothesis that two scalar reports share one object.

    Parameters
    ----------
    x1, x2 : float or array_like
        Reports :math:`\hat x_1, \hat x_2`.
    var1, var2 : float or array_like
        Error variances :math:`\sigma_1^2, \sigma_2^2 > 0`.
    kind : {"profile", "marginal"}, optional
        ``"profile"`` (default): the paper's measure :math:`f_k^*`, the likelihood
        (2) at the ML estimate :math:`\tilde x` (eq. (4)). ``"marginal"``: the
        likelihood with :math:`x` integrated out under a flat prior.

    Returns
    -------
    float or numpy.ndarray
        The natural log of the measure, broadcast over the arguments.

    Raises
    ------
    ValueError
        If a variance is not positive, an entry is not finite, the shapes do
        not broadcast, `kind` is unknown or :math:`\kappa` exceeds the largest
        double.

    Notes
    -----
    With :math:`\kappa` from :func:`proximity`,

    .. math::

        \ln f^*_{\text{profile}} = -\frac{\kappa}{2} - \ln(2\pi\sigma_1\sigma_2),
        \qquad
        \ln f_{\text{marginal}} = -\frac{\kappa}{2}
            - \frac12 \ln\bigl(2\pi(\sigma_1^2 + \sigma_2^2)\bigr).

    The paper prints (7) with the
    factor :math:`1/(2\pi(\sigma_1^2 + \sigma_2^2))`, which is neither (see the
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
    # eq. (7)
    kappa = mahalanobis_sq_kernel((a - b)[..., None],
                                  (v1 + v2)[..., None, None], "`x1`, `x2`")
    if kind == "profile":
        # -kappa/2 - ln(2 pi sigma_1 sigma_2)
        return unwrap(-0.5 * kappa - _LOG_2PI
                      - 0.5 * (np.log(v1) + np.log(v2)))
    return unwrap(-0.5 * kappa - 0.5 * (_LOG_2PI + np.log(v1 + v2)))


def log_likelihood_measure_gaussian(x1, x2, cov1, cov2, *, kind="profile"):
    r"""Log likelihood measure of a pointwise hypothesis for vector reports.

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
        As :func:`proximity_gaussian`, or if `kind` is unknown.

    Notes
    -----
    With :math:`\kappa` the squared Mahalanobis distance and :math:`S = \Sigma_1 + \Sigma_2`,

    .. math::

        \ln f^*_{\text{profile}} = -\frac{\kappa}{2} - d\ln 2\pi
            - \tfrac12\ln|\Sigma_1| - \tfrac12\ln|\Sigma_2|, \qquad
        \ln f_{\text{marginal}} = -\frac{\kappa}{2} - \tfrac d2 \ln 2\pi
            - \tfrac12 \ln|S|.

    Log-determinants come from Cholesky factors (:math:`\ln|\Sigma| = 2\sum_i \ln
    L_{ii}`); :math:`S` is scaled by a power of two first, so it cannot overflow.

    Examples
    --------
    >>> v = log_likelihood_measure_gaussian([[1.0]], [[0.0]], [[[1.0]]], [[[3.0]]])
    >>> bool(np.isclose(v, log_likelihood_measure(1.0, 0.0, 1.0, 3.0)))
    True
    """
    kind = as_choice(kind, "kind", _KINDS)
    a, b, c1, c2 = _gaussian_iv(x1, x2, cov1, cov2)
    d = a.shape[-1]
    logdet_s = []
    kappa = mahalanobis_sq_kernel(a - b, c1 + c2, "`x1`, `x2`", logdet_s)
    if kind == "profile":
        out = -0.5 * kappa - d * _LOG_2PI - 0.5 * (np.linalg.slogdet(c1)[1]
                                                   + np.linalg.slogdet(c2)[1])
    else:
        out = -0.5 * kappa - 0.5 * d * _LOG_2PI - 0.5 * logdet_s[0]
    return unwrap(np.broadcast_to(out, kappa.shape))


def best_partner(x1, candidates, var1, candidate_vars, *, kind="profile"):
    r"""Index of the candidate report with the largest likelihood measure.

    Parameters
    ----------
    x1 : float or array_like, shape (...)
        Report(s) of radar 1.
    candidates : array_like, shape (..., k)
        For each radar-1 report, :math:`k \ge 1` candidate partner reports
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
    pick the nearest report (the smallest :math:`\kappa`); when the candidates'
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
    v1 = _as_variance(var1, "var1")
    cv = _as_variance(candidate_vars, "candidate_vars")
    check_domain(a, "x1")
    check_domain(c, "candidates")
    try:
        np.broadcast_shapes(a.shape, v1.shape)
        np.broadcast_shapes((*a.shape, 1), (*v1.shape, 1), c.shape, cv.shape)
    except ValueError:
        raise ValueError(
            "`x1`, `candidates`, `var1`, `candidate_vars` must broadcast with shapes (...), "
            f"(..., k), (...), (..., k); received shapes {a.shape}, {c.shape}, {v1.shape}, "
            f"{cv.shape}") from None
    ll = log_likelihood_measure(a[..., None], c, v1[..., None], cv, kind=kind)
    return unwrap(np.argmax(np.asarray(ll), axis=-1))


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
    r"""Density of the proximity measure: :math:`\chi^2_\nu` or noncentral :math:`\chi'^2_\nu(\lambda)`.

    Parameters
    ----------
    kappa : float or array_like
        Points :math:`\kappa \ge 0` at which to evaluate the density.
    dof : int, optional
        Degrees of freedom :math:`\nu` (the dimension :math:`d`; the paper's
        :math:`m`). Default 1.
    noncentrality : float or array_like, optional
        :math:`\lambda \ge 0` (the paper's :math:`V`); 0 (default) gives the
        law under a true hypothesis.

    Returns
    -------
    float or numpy.ndarray
        The density, finite everywhere except at :math:`\kappa = 0` with
        :math:`\nu = 1`, where the density is infinite and ``inf`` is returned.

    Raises
    ------
    ValueError
        If `kappa` or `noncentrality` is negative or not finite, or `dof` < 1.
    TypeError
        If an argument is not numeric, or `dof` is not an integer.

    Notes
    -----
    .. math::

        f_{\chi'^2_\nu(\lambda)}(\kappa) = \sum_{j\ge 0} \frac{e^{-\lambda/2}(\lambda/2)^j}{j!}\,
        f_{\chi^2_{\nu + 2j}}(\kappa)
        = \tfrac12 e^{-(\sqrt\kappa - \sqrt\lambda)^2/2}
          (\kappa/\lambda)^{\nu/4 - 1/2}\, I_{\nu/2 - 1}(\sqrt{\lambda\kappa})\,
          e^{-\sqrt{\lambda\kappa}},

    evaluated with :mod:`scipy.stats` (``chi2`` at :math:`\lambda = 0`, ``ncx2``
    otherwise). Above :math:`\lambda = 10^6` (where scipy's ``ncx2`` returns NaN,
    or in scipy 1.11 a wrong finite value, as :math:`\lambda` grows), for a value
    below 1e-200 (where it may have underflowed) and at :math:`\kappa = 0`, the
    Bessel form on the right is evaluated in the log
    domain (exponentially scaled Bessel function, or its uniform asymptotic
    expansion). The two curves for :math:`\lambda = 0` and :math:`\lambda > 0`
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
        redo = (v > 0) & (k > 0) & (~(np.isfinite(out) & (out > _PDF_FLOOR))
                                    | (v > _NCX2_SCIPY_MAX))
        if np.any(redo):
            out = np.where(redo, np.exp(_log_ncx2_pdf(np.where(redo, k, 1.0), nu,
                                                      np.where(redo, v, 1.0))), out)
        # the limit kappa -> 0 under lambda > 0: inf (nu = 1), e^{-lambda/2}/2 (nu = 2), 0
        at0 = (v > 0) & (k == 0)
        if np.any(at0):
            lim = np.inf if nu == 1 else (0.5 * np.exp(-0.5 * v) if nu == 2 else 0.0)
            out = np.where(at0, lim, out)
    return unwrap(out)
