r"""The maximum-likelihood fused estimate of one object seen by several sensors.

Under a pointwise association hypothesis the reports :math:`\hat x_1, \dots,
\hat x_k` of different radars belong to one object at the unknown coordinate
:math:`x`. With independent Gaussian errors the likelihood is the product of
the sensors' densities (Grachov & Korneev, eqs. (1)–(2)); its maximum — the
root of the likelihood equation (3) — is the inverse-variance weighted mean,
and its variance attains the Cramér–Rao bound.

.. rubric:: Functions

* :func:`fuse` — scalar reports, ``x, var: (..., m)`` for `m` sources (the paper's case is ``m = 2``);
* :func:`fuse_gaussian` — vector reports with full covariances in information
  form, ``x: (..., m, d)``, ``cov: (..., m, d, d)``;
* :func:`log_likelihood` — the log of the likelihood (2) as a function of the
  candidate coordinate;
* :func:`misweighted` — what the fused estimate is worth when the weights come
  from wrong (assumed) variances;
* :func:`sample_reports`, :func:`sample_reports_gaussian` — simulated reports
  for Monte-Carlo checks.

.. rubric:: References

.. [1] V. M. Grachov, V. A. Korneev, "Method of combining radar information
   taking coordinate and feature measurements into account", Kharkiv Air Force
   University, 2010, eqs. (1)–(3).
.. [2] S. M. Kay, *Fundamentals of Statistical Signal Processing: Estimation
   Theory*, Prentice Hall, 1993, ch. 3 (Cramér–Rao bound) and ch. 7 (MLE).
.. [3] Y. Bar-Shalom, X.-R. Li, T. Kirubarajan, *Estimation with Applications
   to Tracking and Navigation*, Wiley, 2001, sec. 2.6 and 3.3 (static fusion
   in information form).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .engine.validation import (
    MEMORY_LIMIT,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_rng,
    broadcast,
    check_size,
    describe,
)

__all__ = [
    "FusedEstimate",
    "GaussianFusion",
    "Misweighting",
    "VAR_DOMAIN",
    "fuse",
    "fuse_gaussian",
    "log_likelihood",
    "misweighted",
    "sample_reports",
    "sample_reports_gaussian",
]

_LOG_2PI = float(np.log(2.0 * np.pi))


def _scalar(a: np.ndarray):
    """0-d arrays become numpy scalars, everything else is returned unchanged."""
    return a[()] if isinstance(a, np.ndarray) and a.ndim == 0 else a


# ----------------------------------------------------------------------------- results


@dataclass(frozen=True)
class FusedEstimate:
    r"""The ML fused estimate of a scalar coordinate.

    Attributes
    ----------
    estimate : numpy.ndarray or float, shape (...)
        The fused estimate :math:`\tilde x = \sum_i w_i \hat x_i`.
    variance : numpy.ndarray or float, shape (...)
        Its variance :math:`\tilde\sigma^2 = (\sum_i \sigma_i^{-2})^{-1}`, equal to
        the Cramér–Rao bound.
    weights : numpy.ndarray, shape (..., m)
        The weights :math:`w_i = \sigma_i^{-2} / \sum_j \sigma_j^{-2}` (they sum to 1).
    """

    estimate: np.ndarray | float
    variance: np.ndarray | float
    weights: np.ndarray

    @property
    def information(self):
        r"""Fisher information :math:`\sum_i \sigma_i^{-2} = 1/\tilde\sigma^2`."""
        return 1.0 / np.asarray(self.variance)

    @property
    def std(self):
        r"""Standard deviation :math:`\tilde\sigma` of the fused estimate."""
        return np.sqrt(self.variance)


@dataclass(frozen=True)
class GaussianFusion:
    r"""The ML fused estimate of a vector position, in information form.

    Attributes
    ----------
    estimate : numpy.ndarray, shape (..., d)
        :math:`\tilde{\mathbf x} = \tilde\Sigma \sum_i \Sigma_i^{-1} \hat{\mathbf x}_i`.
    covariance : numpy.ndarray, shape (..., d, d)
        :math:`\tilde\Sigma = (\sum_i \Sigma_i^{-1})^{-1}`, the covariance of the estimate (and the
        Cramér–Rao bound).
    information : numpy.ndarray, shape (..., d, d)
        The Fisher information matrix :math:`\tilde\Sigma^{-1} = \sum_i \Sigma_i^{-1}`.
    """

    estimate: np.ndarray
    covariance: np.ndarray
    information: np.ndarray


@dataclass(frozen=True)
class Misweighting:
    r"""The inverse-variance weighted mean computed with assumed variances.

    Attributes
    ----------
    weights : numpy.ndarray, shape (..., m)
        Weights built from the assumed variances, :math:`w_i = a_i^{-1}/\sum_j a_j^{-1}`.
    actual_variance : numpy.ndarray or float, shape (...)
        True variance of the resulting estimate, :math:`\sum_i w_i^2 \sigma_i^2`.
    reported_variance : numpy.ndarray or float, shape (...)
        The variance the fusion centre believes, :math:`(\sum_i a_i^{-1})^{-1}`.
    bound : numpy.ndarray or float, shape (...)
        The Cramér–Rao bound :math:`(\sum_i \sigma_i^{-2})^{-1}` of the true model.
    """

    weights: np.ndarray
    actual_variance: np.ndarray | float
    reported_variance: np.ndarray | float
    bound: np.ndarray | float

    @property
    def efficiency(self):
        """``bound / actual_variance`` in (0, 1]; 1 when the assumed variances are proportional
        to the true ones.

        Raises ValueError if the ratio lies outside the float range (a weighting more than
        about 1e308 times worse than the bound)."""
        return _ratio(self.bound, self.actual_variance, "efficiency")

    @property
    def consistency(self):
        """``reported_variance / actual_variance``: below 1 the centre is over-confident.

        Raises ValueError if the ratio lies outside the float range."""
        return _ratio(self.reported_variance, self.actual_variance, "consistency")


def _ratio(num, den, what):
    """A ratio of two positive normal floats, refused if it leaves the float range."""
    with np.errstate(over="ignore", under="ignore"):
        out = np.asarray(num) / np.asarray(den)
    if not np.all((out > 0) & np.isfinite(out)):
        raise ValueError(f"the {what} ({describe(out)}) lies outside the float range: "
                         "`var_assumed` and `var_true` differ by more than floating point can "
                         "express")
    return _scalar(out)


# ----------------------------------------------------------------------------- validation


#: The scalar fusion's numeric domain: variances in [2**-1000, 2**1000] (about 9.3e-302 to
#: 1.1e301), reports of magnitude at most 2**1000, at most 2**20 sources. Inside it the
#: informations, their sum, the weights and the weighted sum are computed as written
#: without overflow, and the fused variance is a normal float; outside it the input is
#: refused, naming the argument.
VAR_DOMAIN = (2.0**-1000, 2.0**1000)
_MAX_SOURCES = 1 << 20
#: Smallest positive normal float (about 2.2e-308). A derived variance below it would be
#: subnormal, carried with fewer significant bits, so it is refused instead of returned.
_TINY = float(np.finfo(float).tiny)


def _in_domain(arr, name, lo, hi, what):
    """Refuse entries of `arr` outside [lo, hi] (the numeric domain), naming `name`."""
    if arr.size and not (float(arr.min()) >= lo and float(arr.max()) <= hi):
        raise ValueError(f"`{name}` must have {what} within the numeric domain [{lo:.3g}, "
                         f"{hi:.3g}]; received {describe(arr)} (from {float(arr.min()):.6g} "
                         f"to {float(arr.max()):.6g}); express the coordinates in other units")


def _as_variances(value, name):
    """Positive variances within :data:`VAR_DOMAIN`, at least one sensor on the last axis."""
    var = as_positive(value, name)
    _in_domain(var, name, *VAR_DOMAIN, "every variance")
    return var


def _reports_iv(x, var):
    """Validate `x` and `var` of shape (..., m); return them broadcast together."""
    x = as_float_array(x, "x", ndim_min=1)
    var = as_positive(var, "var")
    x, var = broadcast(x=x, var=var)
    if x.shape[-1] == 0:
        raise ValueError(f"`x` must hold at least one report on its last axis; received shape "
                         f"{x.shape}")
    return x, var


def _fuse_iv(x, var):
    """:func:`_reports_iv` and the numeric domain of :func:`fuse`."""
    x, var = _reports_iv(x, var)
    _in_domain(var, "var", *VAR_DOMAIN, "every variance")
    check_size(x.shape[-1], _MAX_SOURCES, what="sources on the last axis of `x`",
               alternative="fusing groups of sources one after the other")
    _in_domain(np.abs(x), "x", 0.0, VAR_DOMAIN[1], "every report's magnitude")
    return x, var


def _gaussian_iv(x, cov):
    """Validate `x` (..., m, d) and `cov` (..., m, d, d); return them with broadcast batch."""
    x = as_float_array(x, "x", ndim_min=2)
    cov = as_float_array(cov, "cov", ndim_min=3)
    d = x.shape[-1]
    if d == 0 or x.shape[-2] == 0:
        raise ValueError(f"`x` must have shape (..., m, d) with m, d >= 1; received shape "
                         f"{x.shape}")
    if cov.shape[-2:] != (d, d):
        raise ValueError(f"`cov` must have shape (..., m, {d}, {d}) to match `x` with shape "
                         f"{x.shape}; received shape {cov.shape}")
    cov = as_covariance(cov, "cov", domain=False)   # rescaled exactly: any float
    try:
        lead = np.broadcast_shapes(x.shape[:-1], cov.shape[:-2])
    except ValueError:
        raise ValueError(f"`x` (..., m, d) and `cov` (..., m, d, d) must agree in m and "
                         f"broadcast in their leading axes; received shapes {x.shape} and "
                         f"{cov.shape}") from None
    return np.broadcast_to(x, (*lead, d)), np.broadcast_to(cov, (*lead, d, d))


# ----------------------------------------------------------------------------- scalar


def fuse(x, var) -> FusedEstimate:
    r"""Maximum-likelihood fused estimate of one coordinate from `m` sources.

    Parameters
    ----------
    x : array_like, shape (..., m)
        Reports :math:`\hat x_i` of the same object by `m` sources (the last
        axis); leading axes are batch axes (trials, hypotheses, ...).
    var : array_like, broadcastable to ``x``
        Error variances :math:`\sigma_i^2 > 0` of the sensors (variances, not
        standard deviations).

    Returns
    -------
    FusedEstimate
        ``estimate`` and ``variance`` with shape ``(...)``, ``weights`` with
        shape ``(..., k)``.

    Raises
    ------
    ValueError
        If `var` has a zero, negative or non-finite entry or one outside
        :data:`VAR_DOMAIN`; if `x` is non-finite, beyond :math:`2^{1000}` in
        magnitude or has no reports (or more than :math:`2^{20}`), or the two do
        not broadcast.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    The log-likelihood of the pointwise hypothesis, the log of eq. (2)
    generalised to `m` sources,

    .. math::

        \ell(x) = -\frac12 \sum_{i=1}^m \left[\ln(2\pi\sigma_i^2)
                   + \frac{(\hat x_i - x)^2}{\sigma_i^2}\right],

    is a concave parabola. The likelihood equation (3),
    :math:`\ell'(\tilde x) = 0`, has the single root

    .. math::

        \tilde x = \frac{\sum_i \hat x_i/\sigma_i^2}{\sum_i 1/\sigma_i^2},
        \qquad
        \operatorname{Var}\tilde x = \Big(\sum_i \sigma_i^{-2}\Big)^{-1}
        = \frac{1}{I(x)},

    which for :math:`m = 2` is the paper's
    :math:`\tilde x = (\sigma_2^2\hat x_1 + \sigma_1^2\hat x_2)/(\sigma_1^2+\sigma_2^2)`.
    The variance equals the inverse Fisher information, so the estimate is
    efficient (it attains the Cramér–Rao bound) [2]_.

    Numerically the formula is computed as written, inside a documented domain
    (:data:`VAR_DOMAIN`: variances in :math:`[2^{-1000}, 2^{1000}]`, reports of
    magnitude at most :math:`2^{1000}`, at most :math:`2^{20}` sources): there the
    information sum cannot overflow, the fused variance is a normal float and no
    partial weighted sum exceeds the largest report, so the result is accurate
    to a few units in the last place. Input outside the domain is refused.

    References
    ----------
    .. [1] Grachov & Korneev (2010), eqs. (1)–(3) and the estimate after (3).
    .. [2] Kay (1993), Theorem 3.1.

    Examples
    --------
    >>> r = fuse([10.0, 12.0], [1.0, 4.0])
    >>> float(r.estimate), float(r.variance)
    (10.4, 0.8)
    >>> r.weights
    array([0.8, 0.2])
    >>> fuse([[0.0, 1.0], [2.0, 4.0]], 1.0).estimate   # a batch of two hypotheses
    array([0.5, 3. ])
    """
    x, var = _fuse_iv(x, var)
    info = 1.0 / var                                 # sigma_i^-2
    total = info.sum(axis=-1)                        # I = sum_i sigma_i^-2
    weights = info / total[..., None]                # w_i = sigma_i^-2 / I
    # x~ = sum_i w_i x_i, the root of (3)
    estimate = np.sum(weights * x, axis=-1)
    variance = 1.0 / total                           # sigma~^2 = 1 / I
    return FusedEstimate(_scalar(estimate), _scalar(variance), weights)


def log_likelihood(x, var, position):
    r"""Log-likelihood of a pointwise hypothesis as a function of the coordinate.

    Parameters
    ----------
    x : array_like, shape (..., m)
        Reports of the `m` sources.
    var : array_like, broadcastable to ``x``
        Error variances, > 0.
    position : array_like
        Candidate true coordinate(s) :math:`x`; broadcast against the batch
        shape ``x.shape[:-1]``.

    Returns
    -------
    numpy.ndarray or float
        :math:`\ell(x) = \sum_i \ln \mathcal N(\hat x_i; x, \sigma_i^2)`.

    Raises
    ------
    ValueError
        On non-positive variances, non-finite input or shapes that do not broadcast.

    Notes
    -----
    The logarithm of eq. (2) of Grachov & Korneev (2010) (for `m` sources),
    computed in the log domain so that many hypotheses never underflow:

    .. math::

        \ell(x) = -\frac12\sum_{i=1}^m\left[\ln 2\pi + \ln\sigma_i^2
                   + \frac{(\hat x_i - x)^2}{\sigma_i^2}\right].

    Examples
    --------
    >>> round(float(log_likelihood([0.0, 0.0], [1.0, 1.0], 0.0)), 6)   # -ln(2 pi)
    -1.837877
    >>> log_likelihood([1.0, 3.0], [1.0, 1.0], [1.0, 2.0, 3.0]).round(3)
    array([-3.838, -2.838, -3.838])
    """
    x, var = _reports_iv(x, var)
    position = as_float_array(position, "position")
    try:
        np.broadcast_shapes(position.shape, x.shape[:-1])
    except ValueError:
        raise ValueError(f"`position` must broadcast against the batch shape {x.shape[:-1]} "
                         f"of `x`; received shape {position.shape}") from None
    # (x_i - x) / sigma_i from halves, so that the difference of two large coordinates
    # cannot overflow before it is scaled
    half = 0.5 * x - 0.5 * position[..., None]
    with np.errstate(over="ignore"):
        z = 2.0 * (half / np.sqrt(var))
        out = -0.5 * np.sum(_LOG_2PI + np.log(var) + z * z, axis=-1)
    if not np.all(np.isfinite(out)):
        raise ValueError("`position` is so many standard deviations from the reports `x` that "
                         "the log-likelihood is below the float range (about -1.8e308)")
    return _scalar(out)


def _misweighted_iv(var_true, var_assumed):
    """Both variance sets within :data:`VAR_DOMAIN`, broadcast, at least one sensor."""
    var_true = _as_variances(var_true, "var_true")
    var_assumed = _as_variances(var_assumed, "var_assumed")
    if var_true.ndim < 1:
        raise ValueError(f"`var_true` must have shape (..., m); received shape {var_true.shape}")
    var_true, var_assumed = broadcast(var_true=var_true, var_assumed=var_assumed)
    if var_true.shape[-1] == 0:
        raise ValueError("`var_true` must hold at least one sensor on its last axis")
    check_size(var_true.shape[-1], _MAX_SOURCES, what="sensors on the last axis of `var_true`",
               alternative="several calls on groups of sensors")
    return var_true, var_assumed


def misweighted(var_true, var_assumed) -> Misweighting:
    r"""Accuracy of the weighted mean when the weights use wrong variances.

    Parameters
    ----------
    var_true : array_like, shape (..., m)
        The sensors' true error variances :math:`\sigma_i^2 > 0`.
    var_assumed : array_like, broadcastable to ``var_true``
        The variances :math:`a_i > 0` the fusion centre uses to weight the reports.

    Returns
    -------
    Misweighting

    Raises
    ------
    ValueError
        On zero, negative or non-finite variances, or shapes that do not broadcast.

    Notes
    -----
    With weights :math:`w_i = a_i^{-1}/\sum_j a_j^{-1}` the estimate is still
    unbiased (the weights sum to 1) but its variance is

    .. math::

        \operatorname{Var}\tilde x = \sum_i w_i^2\sigma_i^2
        \;\ge\; \Big(\sum_i\sigma_i^{-2}\Big)^{-1},

    with equality iff :math:`a_i \propto \sigma_i^2`, while the centre
    reports :math:`(\sum_i a_i^{-1})^{-1}`.

    Examples
    --------
    >>> m = misweighted([1.0, 9.0], [1.0, 1.0])       # plain average of unequal radars
    >>> float(m.actual_variance), float(m.bound), float(m.reported_variance)
    (2.5, 0.9, 0.5)
    >>> float(misweighted([1.0, 9.0], [2.0, 18.0]).efficiency)   # proportional: efficient
    1.0
    """
    var_true, var_assumed = _misweighted_iv(var_true, var_assumed)
    info_a = 1.0 / var_assumed                      # a_i^-1
    # w_i = a_i^-1 / sum_j a_j^-1
    weights = info_a / info_a.sum(axis=-1)[..., None]
    reported = 1.0 / info_a.sum(axis=-1)            # (sum_i a_i^-1)^-1
    bound = 1.0 / np.sum(1.0 / var_true, axis=-1)   # (sum_i sigma_i^-2)^-1
    # Var sum_i w_i x_i = sum_i w_i^2 sigma_i^2
    actual = np.sum(weights**2 * var_true, axis=-1)
    return Misweighting(weights, _scalar(actual), _scalar(reported),
                        _scalar(bound))


# ----------------------------------------------------------------------------- vector


def fuse_gaussian(x, cov) -> GaussianFusion:
    r"""Maximum-likelihood fusion of `m` vector reports with full error covariances.

    Parameters
    ----------
    x : array_like, shape (..., m, d)
        Reports :math:`\hat{\mathbf x}_i` of one object by `m` sources.
    cov : array_like, shape (..., m, d, d)
        Their error covariances :math:`\Sigma_i`, symmetric positive definite;
        leading axes broadcast against those of `x`.

    Returns
    -------
    GaussianFusion
        ``estimate`` (..., d), ``covariance`` (..., d, d), ``information`` (..., d, d).

    Raises
    ------
    ValueError
        If a covariance is not symmetric positive definite (or so close to
        singular that the information overflows), the shapes disagree, or an
        entry is non-finite.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    The log-likelihood :math:`\ell(\mathbf x) = \sum_i \ln\mathcal N(\hat{\mathbf x}_i;
    \mathbf x, \Sigma_i)` has gradient
    :math:`\sum_i \Sigma_i^{-1}(\hat{\mathbf x}_i - \mathbf x)` and Hessian
    :math:`-\sum_i \Sigma_i^{-1}`; the likelihood equation gives the information form

    .. math::

        \tilde\Sigma^{-1}\tilde{\mathbf x} = \sum_i \Sigma_i^{-1}\hat{\mathbf x}_i, \qquad
        \tilde\Sigma^{-1} = \sum_i \Sigma_i^{-1}, \qquad
        \operatorname{Cov}\tilde{\mathbf x} = \tilde\Sigma,

    and :math:`\tilde\Sigma^{-1}` is the Fisher information, so :math:`\tilde\Sigma` is
    the Cramér–Rao bound.

    Numerically nothing is inverted explicitly, and no sum over- or underflows:
    each :math:`\Sigma_i = c_i \Sigma_i'` is scaled by its largest variance
    :math:`c_i`, Cholesky-factored, :math:`\Sigma_i' = L_iL_i^{\mathsf T}`, and
    whitened with a triangular solve, :math:`W_i = \sqrt{r_i}\,L_i^{-1}` with
    :math:`r_i = c_{\min}/c_i \in (0, 1]`, so that
    :math:`c_{\min}\Sigma_i^{-1} = W_i^{\mathsf T}W_i` is symmetric positive
    definite by construction; the scaled information
    :math:`c_{\min}\tilde\Sigma^{-1} = RR^{\mathsf T}` is factored the same way,
    :math:`\tilde\Sigma = c_{\min}(R^{-1})^{\mathsf T}R^{-1}`, and the reports are
    scaled by an exact power of two. Results beyond the float range (a fused
    variance below the smallest normal float, an information above the largest)
    are refused. For :math:`m = 2` this equals the covariance form
    :math:`\hat{\mathbf x}_1 + \Sigma_1(\Sigma_1+\Sigma_2)^{-1}(\hat{\mathbf x}_2-\hat{\mathbf x}_1)`.

    References
    ----------
    .. [1] Grachov & Korneev (2010), eqs. (1)–(3), generalised to vectors.
    .. [2] Bar-Shalom, Li & Kirubarajan (2001), sec. 3.3 (information form).

    Examples
    --------
    >>> x = [[0.0, 0.0], [2.0, 2.0]]
    >>> cov = [[[1.0, 0.0], [0.0, 4.0]], [[4.0, 0.0], [0.0, 1.0]]]
    >>> r = fuse_gaussian(x, cov)
    >>> r.estimate
    array([0.4, 1.6])
    >>> r.covariance
    array([[0.8, 0. ],
           [0. , 0.8]])
    """
    x, cov = _gaussian_iv(x, cov)
    # c Sigma_i^-1, c an exact power of two
    info_i, c = _scaled_informations(cov)
    x_s, e = _unit_reports(x)                       # x_i / 2^e, exact
    # c Sigma~^-1 = c sum_i Sigma_i^-1
    information = info_i.sum(axis=-3)
    # c sum_i Sigma_i^-1 x_i / 2^e
    y = np.sum(info_i @ x_s[..., None], axis=-3)
    covariance = _spd_inverse(information)          # Sigma~ / c
    # x~ = Sigma~ sum_i Sigma_i^-1 x_i
    estimate = np.ldexp((covariance @ y)[..., 0], e[..., None])
    return _gaussian_result(estimate, covariance, information, c)


def _scaled_informations(cov):
    r"""``c Sigma_i^-1`` (symmetric positive definite by construction) and ``c``.

    Each :math:`\Sigma_i = c_i \Sigma_i'` is scaled by a power of two near its largest
    variance, Cholesky-factored and whitened, :math:`W_i = \sqrt{r_i} L_i^{-1}` with
    :math:`r_i = c / c_i \in (0, 1]` and :math:`c = \min_i c_i`, so that
    :math:`c \Sigma_i^{-1} = W_i^T W_i` and no sum over the sensors overflows.
    """
    _, k = np.frexp(np.max(np.diagonal(cov, axis1=-2, axis2=-1), axis=-1))
    c_i = np.ldexp(1.0, k - 1)                                       # (..., m), exact
    c = np.min(c_i, axis=-1)                                         # (...)
    eye = np.broadcast_to(np.eye(cov.shape[-1]), cov.shape)   # a stack: NumPy 1 would read
    try:                                                       # a lone (d, d) as d vectors
        chol = np.linalg.cholesky(cov / c_i[..., None, None])
    except np.linalg.LinAlgError:
        raise ValueError("`cov` is numerically singular: a covariance is too ill-conditioned "
                         "for floating point; rescale the coordinates") from None
    white = np.linalg.solve(chol, eye) * np.sqrt(c[..., None] / c_i)[..., None, None]
    return np.swapaxes(white, -1, -2) @ white, c


def _unit_reports(x):
    """Reports divided by an exact power of two ``2^e`` near their largest magnitude, and ``e``."""
    _, e = np.frexp(np.max(np.abs(x), axis=(-2, -1)))
    return np.ldexp(x, -e[..., None, None]), e


def _spd_inverse(a):
    """The inverse of symmetric positive definite matrices through their Cholesky factor."""
    try:
        r_inv = np.linalg.solve(np.linalg.cholesky(a), np.broadcast_to(np.eye(a.shape[-1]),
                                                                         a.shape))
    except np.linalg.LinAlgError:
        raise ValueError("`cov` is numerically singular: a covariance is too ill-conditioned "
                         "for floating point; rescale the coordinates") from None
    return np.swapaxes(r_inv, -1, -2) @ r_inv


def _gaussian_result(estimate, covariance_s, information_s, c):
    """Undo the scale ``c``; refuse results beyond the float range."""
    with np.errstate(over="ignore", under="ignore"):
        covariance = covariance_s * c[..., None, None]               # Sigma~
        information = information_s / c[..., None, None]             # sum_i Sigma_i^-1
    if not (np.isfinite(information).all() and np.isfinite(estimate).all()
            and np.all(np.diagonal(covariance, axis1=-2, axis2=-1) >= _TINY)):
        raise ValueError("`cov` is numerically singular for floating point: the fused "
                         "information overflows or the fused covariance underflows; rescale "
                         "the coordinates")
    return GaussianFusion(estimate, covariance, information)


# ----------------------------------------------------------------------------- simulation


def sample_reports(truth, var, *, trials: int, rng=None) -> np.ndarray:
    r"""Draw scalar reports :math:`\hat x_i = x + \Delta x_i`, :math:`\Delta x_i\sim\mathcal N(0,\sigma_i^2)`.

    Parameters
    ----------
    truth : array_like, shape (...)
        True coordinate(s).
    var : array_like, shape (..., m)
        Error variances of the `k` sensors, > 0; leading axes broadcast with `truth`.
    trials : int
        Number of independent draws (>= 1).
    rng : None, int or numpy.random.Generator, optional
        Source of randomness (SPEC 7).

    Returns
    -------
    numpy.ndarray, shape (trials, ..., k)

    Examples
    --------
    >>> sample_reports(5.0, [1.0, 4.0], trials=3, rng=0).shape
    (3, 2)
    """
    truth = as_float_array(truth, "truth")
    var = as_positive(var, "var")
    if var.ndim < 1:
        raise ValueError(f"`var` must have shape (..., m); received shape {var.shape}")
    trials = as_int(trials, "trials", minimum=1)
    rng = as_rng(rng)
    truth_k, var = broadcast(truth=truth[..., None], var=var)
    _check_memory(trials, var.size, "sample_reports")
    noise = rng.standard_normal((trials, *var.shape))
    with np.errstate(over="ignore"):
        out = truth_k + np.sqrt(var) * noise
    if not np.all(np.isfinite(out)):
        raise ValueError("`truth` and `var` are so large that simulated reports overflow the "
                         "float range; express the coordinates in larger units")
    return out


def _check_memory(trials, per_trial, name):
    """Refuse draws whose arrays would exceed MEMORY_LIMIT, before allocating them."""
    check_size(8 * 2 * int(trials) * int(per_trial), MEMORY_LIMIT,
               what=f"bytes of simulated reports in {name}",
               alternative="fewer `trials` per call, accumulating the results over calls "
                           "with spawned seeds")


def sample_reports_gaussian(truth, cov, *, trials: int, rng=None) -> np.ndarray:
    r"""Draw vector reports :math:`\hat{\mathbf x}_i = \mathbf x + L_i\mathbf z`, :math:`C_i = L_iL_i^{\mathsf T}`.

    Parameters
    ----------
    truth : array_like, shape (..., d)
        True position(s).
    cov : array_like, shape (..., m, d, d)
        Error covariances of the `k` sensors.
    trials : int
        Number of independent draws (>= 1).
    rng : None, int or numpy.random.Generator, optional
        Source of randomness (SPEC 7).

    Returns
    -------
    numpy.ndarray, shape (trials, ..., k, d)

    Examples
    --------
    >>> sample_reports_gaussian([0.0, 0.0], [np.eye(2), 4 * np.eye(2)], trials=5, rng=0).shape
    (5, 2, 2)
    """
    truth = as_float_array(truth, "truth", ndim_min=1)
    cov = as_float_array(cov, "cov", ndim_min=3)
    if cov.shape[-2:] != (truth.shape[-1],) * 2:
        raise ValueError(f"`cov` must have shape (..., k, {truth.shape[-1]}, {truth.shape[-1]}) "
                         f"to match `truth` with shape {truth.shape}; received shape {cov.shape}")
    cov = as_covariance(cov, "cov", domain=False)   # drawn by scale: any float
    trials = as_int(trials, "trials", minimum=1)
    rng = as_rng(rng)
    try:
        lead = np.broadcast_shapes((*truth.shape[:-1], 1), cov.shape[:-2])
    except ValueError:
        raise ValueError(f"`truth` (..., d) and `cov` (..., m, d, d) must broadcast in their "
                         f"leading axes; received shapes {truth.shape} and {cov.shape}") from None
    _check_memory(trials, int(np.prod(lead)) * truth.shape[-1], "sample_reports_gaussian")
    chol = np.linalg.cholesky(cov)
    z = rng.standard_normal((trials, *lead, truth.shape[-1], 1))
    with np.errstate(over="ignore", invalid="ignore"):
        out = truth[..., None, :] + (chol @ z)[..., 0]
    if not np.all(np.isfinite(out)):
        raise ValueError("`truth` and `cov` are so large that simulated reports overflow the "
                         "float range; express the coordinates in larger units")
    return out
