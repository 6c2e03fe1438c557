r"""Feature (attribute) measurements: type recognition and feature-aided association.

Besides a coordinate :math:`\hat x_i`, each radar reports a *feature*
:math:`\hat\Pi_i = \Pi + \Delta\Pi_i` (a signal, trajectory or behaviour
parameter), :math:`\Delta\Pi_i \sim \mathcal N(0, \sigma_{\Pi i}^2)`. An
object of type :math:`T_k` has a feature value drawn from the type-conditional
density (Grachov & Korneev 2010, eq. (8), corrected — see the chapter)

.. math::

    f(\Pi \mid T_k) = \mathcal N(\Pi;\ \Pi_k, \sigma_{\Pi k}^2),
    \qquad k = 1, \dots, K.

.. rubric:: Public functions

* :func:`fused_feature` — the maximum-likelihood fused feature of two reports
  and its variance;
* :func:`type_likelihood` — :math:`f(\hat\Pi \mid T_k)` for a feature measured
  with variance :math:`v` (the type density convolved with the error);
* :func:`type_posterior` — the type posterior (13), computed in the log domain;
* :func:`pair_type_posterior` — the type posterior from both radars' reports,
  under either feature observation model;
* :func:`combined_proximity` — the coordinate + feature proximity measure (12)
  (vector coordinates allowed), for both feature observation models;
* the scenes these functions take come from
  :func:`radarfusion_ref.engine.scenes.typed_scene`;
* :func:`association_costs` — the :math:`n \times n` cost matrices of a scene;
* :func:`triune` — the association – estimation – recognition outcome of a
  given association, with accuracy, RMSE and a confusion matrix;
* :func:`reliability_curve` — binned calibration of predicted probabilities.

Two feature observation models are supported (the paper's closing discussion):
``"shared"`` (model 1: both radars see the same value :math:`\Pi`, their
reports differ only by measurement error) and ``"spread"`` (model 2: each
radar sees its own value, drawn from the type's density, so the reports of
one object differ by the type's spread as well).

.. rubric:: References

.. [1] V. M. Grachov, V. A. Korneev, "Method of combining radar information
   taking coordinate and feature measurements into account", Kharkiv Air
   Force University, 2010 — eqs. (8)–(13) and the two feature observation
   models.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import expit, logsumexp

from .engine._validation import (
    MEMORY_LIMIT,
    _describe,
    as_choice,
    as_float_array,
    as_int,
    as_positive,
    broadcast,
    check_size,
    unwrap,
)
from .engine.montecarlo import MeanEstimate, Proportion, mean, proportion
from .engine.scenes import (
    FEATURE_MODELS,
    TypedScene,
    _types_iv,
)
from .fusion import fuse
from .proximity import proximity_gaussian

__all__ = [
    "MAX_BINS",
    "CombinedProximity",
    "Confusion",
    "FusedFeature",
    "ReliabilityCurve",
    "TriuneResult",
    "association_costs",
    "combined_proximity",
    "fused_feature",
    "pair_type_posterior",
    "reliability_curve",
    "triune",
    "type_agreement",
    "type_likelihood",
    "type_posterior",
]

_LOG_2PI = np.log(2.0 * np.pi)

#: Largest number of bins :func:`reliability_curve` accepts. A reliability diagram
#: needs tens of bins; more only splits the predictions into bins too small to
#: estimate a frequency, and the limit is checked before anything is allocated.
MAX_BINS = 10_000

#: Working arrays of one type posterior, each of the output's size (for the
#: memory limit :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT`).
_WORK_ARRAYS = 24


def _check_memory(shape, n_types, what):
    """Refuse a batch whose working memory would exceed the package's limit."""
    n = int(np.prod(shape, dtype=object)) * int(n_types)
    check_size(n * 8 * _WORK_ARRAYS, MEMORY_LIMIT,
               what=f"bytes of working memory ({what}: {n} feature-type pairs)",
               alternative=f"calls on chunks of the features (at most about "
                           f"{MEMORY_LIMIT // (8 * _WORK_ARRAYS * max(int(n_types), 1))} "
                           "features per call)")


def _as_flag(value, name):
    """A plain bool option (``log``); refuse strings and numbers, which are always truthy."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"`{name}` must be True or False; received {_describe(value)}")
    return bool(value)


# ----------------------------------------------------------------------------- validation
def _log_normal(x, mean_, var):
    """log N(x; mean, var), elementwise (moderate arguments only; see `_log_quadratic`)."""
    return -0.5 * (_LOG_2PI + np.log(var) + (x - mean_) ** 2 / var)


def _difference(a, b):
    """``a - b`` without overflow to inf when both are huge and of opposite signs.

    The result is returned as ``(value, log2_scale)`` with ``a - b = value * 2**log2_scale``
    and ``|value| <= 2`` (the scale is a power of two, so scaling is exact).
    """
    big = np.maximum(np.abs(a), np.abs(b))
    _, e = np.frexp(big)
    return np.ldexp(a, -e) - np.ldexp(b, -e), e


def _log_quadratic(x, mean_, log_var):
    """``log((x - mean)**2 / var)`` from ``log var``, finite over the whole float range.

    ``-inf`` where ``x == mean``. Never overflows: the difference is taken at a
    power-of-two scale and the square is formed in the log domain.
    """
    diff, e = _difference(x, mean_)
    with np.errstate(divide="ignore"):
        return 2.0 * (np.log(np.abs(diff)) + e * np.log(2.0)) - log_var


def _quadratic(x, mean_, log_var):
    """``(x - mean)**2 / var`` from ``log var``: direct where safe, else by the log domain.

    ``inf`` only where the true value exceeds the float range.
    """
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        var = np.exp(log_var)
        direct = (x - mean_) ** 2 / var
        safe = np.isfinite(direct) & (var >= np.finfo(float).tiny)
        if np.all(safe):
            return direct
        return np.where(safe, direct, np.exp(_log_quadratic(x, mean_, log_var)))


def _log_var_sum(tvars, var):
    """``log(tvars + var)`` without overflow (``var`` may be 0)."""
    with np.errstate(divide="ignore"):
        return np.logaddexp(np.log(tvars), np.log(var))


def _signed_log(a, b):
    """``a - b`` as ``(log|a - b|, sign)``, without overflow (see :func:`_difference`)."""
    diff, e = _difference(a, b)
    with np.errstate(divide="ignore"):
        return np.log(np.abs(diff)) + e * np.log(2.0), np.sign(diff)


def _relative_log_joint(xs, means, log_vars, log_priors, ref):
    r"""``log_joint[..., k] - log_joint[..., ref]`` of the Gaussian type model, exactly.

    ``log_joint[k] = log p_k - 1/2 sum_j (log V_jk + (x_j - m_k)**2 / V_jk)`` with
    ``V_jk = exp(log_vars[j][..., k])``. The difference of the quadratic terms
    ``D_jk = (x_j - m_k)**2/V_jk - (x_j - m_r)**2/V_jr`` is formed without
    overflow or cancellation. For near-equal variances (``|ln V_jk - ln V_jr| <= 1``)

    .. math::

        D_{jk} = V_{jk}^{-1}\,[e_k^2 - 2 u e_k - u^2 \operatorname{expm1}(\ln V_{jk} - \ln V_{jr})],
        \qquad u = x_j - m_r,\ e_k = m_k - m_r,

    which stays exact when the means nearly coincide relative to the feature
    (no ``x - m`` cancellation); otherwise as the difference of the two terms.
    Every product is formed as a sum of logarithms, and the terms are added by a
    signed ``logsumexp``, so nothing overflows before the final ``exp`` (whose
    ``+-inf`` is then the exact limit).
    """
    mr = np.take_along_axis(np.broadcast_to(means, log_vars[0].shape), ref[..., None], axis=-1)
    le, se = _signed_log(means, mr)                             # m_k - m_r
    log2 = np.log(2.0)
    logs, signs = [], []
    total_dlv = 0.0
    for x, lv in zip(xs, log_vars, strict=True):
        lvr = np.take_along_axis(lv, ref[..., None], axis=-1)
        dlv = lv - lvr
        total_dlv = total_dlv + dlv
        lu, su = _signed_log(x[..., None], mr)                  # u = x - m_r
        lk, _ = _signed_log(x[..., None], means)                # x - m_k
        close = np.abs(dlv) <= 1.0
        em1 = np.expm1(np.where(close, dlv, 0.0))
        with np.errstate(divide="ignore"):
            l_em1 = np.log(np.abs(em1))
        # close: (e^2 - 2 u e - u^2 expm1(dlv)) / V_k ; far: (x-m_k)^2/V_k - (x-m_r)^2/V_r
        terms = [(np.where(close, 2 * le, 2 * lk) - lv, np.where(close, se * se, 1.0)),
                 (np.where(close, log2 + lu + le - lv, 2 * lu - lvr),
                  np.where(close, -su * se, -(su * su))),
                 (np.where(close, 2 * lu + l_em1 - lv, -np.inf),
                  np.where(close, -np.sign(em1) * su * su, 0.0))]
        for lg, sg in terms:
            logs.append(np.broadcast_to(lg, lv.shape))
            signs.append(np.broadcast_to(sg, lv.shape))
    a = np.stack(logs, axis=0)
    b = np.stack(signs, axis=0)
    a = np.where(b == 0, -np.inf, a)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        mag, sgn = logsumexp(a, axis=0, b=b, return_sign=True)
        d = np.where(sgn == 0, 0.0, sgn * np.exp(mag))           # may be +-inf: exact limit
        lp = np.broadcast_to(log_priors, d.shape)
        lpr = np.take_along_axis(lp, ref[..., None], axis=-1)
        rel = (lp - lpr) - 0.5 * total_dlv - 0.5 * d
    return np.where(np.isneginf(lp), -np.inf, rel)


def _log_posterior(xs, means, log_vars, log_priors):
    """Normalised log posterior of the types, ``(..., K)``, over the whole float range.

    Parameters are as in :func:`_relative_log_joint`. The reference type is first
    taken from a cheap estimate of the log-joint, then replaced by the best type
    of the exact differences, so every difference is <= 0 and ``exp`` of them
    cannot overflow; the log-sum of those is then between 0 and ``log K``.
    """
    shape = np.broadcast_shapes(*(np.shape(x) for x in xs),
                                *(np.shape(lv)[:-1] for lv in log_vars))
    xs = [np.broadcast_to(x, shape) for x in xs]
    log_vars = [np.broadcast_to(lv, (*shape, means.size)) for lv in log_vars]
    feasible = np.isfinite(log_priors)
    # a cheap first guess of the best type: log-joint where representable, else least q
    with np.errstate(over="ignore"):
        log_q = [_log_quadratic(x[..., None], means, lv) for x, lv in zip(xs, log_vars,
                                                                          strict=True)]
        q_sum = logsumexp(np.stack(log_q), axis=0)
        guess = log_priors - 0.5 * sum(log_vars) - 0.5 * np.exp(q_sum)
    guess = np.where(feasible, guess, -np.inf)
    finite = np.isfinite(guess)
    by_q = np.argmin(np.where(feasible, q_sum, np.inf), axis=-1)
    ref = np.where(finite.any(axis=-1), np.argmax(np.where(finite, guess, -np.inf), axis=-1),
                   by_q)
    rel = _relative_log_joint(xs, means, log_vars, log_priors, ref)
    ref2 = np.argmax(np.where(np.isnan(rel), -np.inf, rel), axis=-1)
    if np.any(ref2 != ref):
        rel = _relative_log_joint(xs, means, log_vars, log_priors, ref2)
    if np.any(np.isnan(rel) | (rel == np.inf)):
        raise FloatingPointError("type posterior: the log-likelihood differences could not be "
                                 "formed in floating point; please report the input")
    return rel - logsumexp(rel, axis=-1, keepdims=True)


# ----------------------------------------------------------------------------- fusion
@dataclass(frozen=True)
class FusedFeature:
    r"""The fused feature of two reports of one object.

    Attributes
    ----------
    value : numpy.ndarray or float
        :math:`\tilde\Pi`, the inverse-variance weighted mean of the two reports.
    var : numpy.ndarray or float
        Its variance :math:`\sigma_{\Pi1}^2\sigma_{\Pi2}^2/(\sigma_{\Pi1}^2+\sigma_{\Pi2}^2)`.
    """

    value: np.ndarray | float
    var: np.ndarray | float


def fused_feature(feature1, feature_var1, feature2, feature_var2) -> FusedFeature:
    r"""Maximum-likelihood fused feature of two reports (model 1) and its variance.

    Parameters
    ----------
    feature1, feature2 : array_like
        Feature reports :math:`\hat\Pi_1, \hat\Pi_2` (broadcast together).
    feature_var1, feature_var2 : array_like
        Their error variances :math:`\sigma_{\Pi1}^2, \sigma_{\Pi2}^2` (> 0).

    Returns
    -------
    FusedFeature

    Raises
    ------
    ValueError
        If a variance is not positive or the shapes do not broadcast.

    Notes
    -----
    Maximising the feature factor of the likelihood (9) over :math:`\Pi` gives
    (the estimate printed after (9))

    .. math::

        \tilde\Pi = \frac{\sigma_{\Pi2}^2\hat\Pi_1 + \sigma_{\Pi1}^2\hat\Pi_2}
                           {\sigma_{\Pi1}^2 + \sigma_{\Pi2}^2},
        \qquad
        \operatorname{Var}\tilde\Pi = \frac{\sigma_{\Pi1}^2\sigma_{\Pi2}^2}
                                          {\sigma_{\Pi1}^2 + \sigma_{\Pi2}^2}.

    It is the same rule as the fused coordinate (3); under model 1 it is a
    sufficient statistic for the type (see :func:`type_posterior`).

    References
    ----------
    Grachov & Korneev (2010), eq. (9) and the estimate after it.

    Examples
    --------
    >>> f = fused_feature(1.0, 1.0, 3.0, 1.0)
    >>> f.value, f.var
    (2.0, 0.5)
    """
    f1 = as_float_array(feature1, "feature1")
    f2 = as_float_array(feature2, "feature2")
    v1 = as_positive(feature_var1, "feature_var1")
    v2 = as_positive(feature_var2, "feature_var2")
    f1, v1, f2, v2 = broadcast(feature1=f1, feature_var1=v1, feature2=f2, feature_var2=v2)
    value, var = _fuse_two(f1, v1, f2, v2)
    return FusedFeature(unwrap(value), unwrap(var))


def _fuse_two(f1, v1, f2, v2):
    """Inverse-variance mean of two values and its variance, over the whole float range.

    The weights are logistic functions of ``ln v1 - ln v2`` (no information
    ``1/v`` is formed, so neither 1e-320 nor 1e308 overflows), the value a convex
    combination (never beyond the inputs), the variance
    the smaller variance times its own weight (never above ``min(v1, v2)``).
    """
    lv1, lv2 = np.log(v1), np.log(v2)
    w1 = expit(lv2 - lv1)                    # v2 / (v1 + v2)
    w2 = expit(lv1 - lv2)
    # a convex combination; the clip only removes rounding beyond the two reports
    value = np.clip(w1 * f1 + w2 * f2, np.minimum(f1, f2), np.maximum(f1, f2))
    # v1 v2 / (v1 + v2) as the smaller variance times its weight (near 1): at most
    # min(v1, v2) and no underflow of the other weight
    var = np.where(v1 <= v2, v1 * w1, v2 * w2)
    return value, var


# ----------------------------------------------------------------------------- recognition
def type_likelihood(feature, feature_var, type_means, type_vars, *, log: bool = False):
    r"""Likelihood of each type given a feature measured with error variance `feature_var`.

    Parameters
    ----------
    feature : array_like, shape (...)
        Measured (or fused) feature :math:`\hat\Pi`.
    feature_var : array_like, broadcastable to `feature`
        Variance :math:`v \ge 0` of its error; ``0`` treats the feature as exact.
    type_means, type_vars : array_like, shape (K,)
        :math:`\Pi_k` and :math:`\sigma_{\Pi k}^2 > 0` of the type densities (8).
    log : bool, optional
        Return the log-likelihood (default: the likelihood).

    Returns
    -------
    numpy.ndarray, shape (..., K)

    Raises
    ------
    ValueError
        Negative `feature_var`, non-positive `type_vars`, an empty or
        non-1-D `type_means`, mismatched shapes, a batch above the memory
        limit; with ``log=True``, a log-likelihood below the float range (its
        likelihood, returned with ``log=False``, is then 0 to double precision).
    TypeError
        Non-numeric input, or a `log` that is not a bool.

    Notes
    -----
    The feature value of a type-:math:`k` object is
    :math:`\Pi \sim \mathcal N(\Pi_k, \sigma_{\Pi k}^2)` (the corrected (8)) and it
    is measured with independent error of variance :math:`v`, so

    .. math::

        f(\hat\Pi \mid T_k) = \int \mathcal N(\hat\Pi; \Pi, v)\,
        \mathcal N(\Pi; \Pi_k, \sigma_{\Pi k}^2)\, d\Pi
        = \mathcal N(\hat\Pi;\ \Pi_k,\ \sigma_{\Pi k}^2 + v).

    References
    ----------
    Grachov & Korneev (2010), eq. (8) (corrected) and (13).

    Examples
    --------
    >>> type_likelihood(0.0, 0.0, [0.0, 1.0], [1.0, 1.0]).round(3)
    array([0.399, 0.242])
    """
    f = as_float_array(feature, "feature")
    v = as_positive(feature_var, "feature_var", strict=False)
    f, v = broadcast(feature=f, feature_var=v)
    means, tvars, _ = _types_iv(type_means, type_vars, None)
    log = _as_flag(log, "log")
    _check_memory(f.shape, means.size, "type likelihood")
    log_var = _log_var_sum(tvars, v[..., None])
    with np.errstate(over="ignore"):
        out = -0.5 * (_LOG_2PI + log_var + _quadratic(f[..., None], means, log_var))
    if log and np.any(np.isinf(out)):
        raise ValueError("the log-likelihood is below the floating-point range (about -1.8e308) "
                         "for some `feature`; use type_posterior for normalised probabilities "
                         f"(received feature {_describe(f)})")
    return out if log else np.exp(out)


def type_posterior(feature, feature_var, type_means, type_vars, priors=None, *,
                   log: bool = False):
    r"""Posterior probability of each type, eq. (13) done properly.

    Parameters
    ----------
    feature : array_like, shape (...)
        The fused feature :math:`\tilde\Pi` (or a single report).
    feature_var : array_like, broadcastable to `feature`
        Its error variance :math:`v \ge 0` (for the fused feature,
        :attr:`FusedFeature.var`). ``0`` with ``priors=None`` reproduces the
        paper's plug-in rule (13).
    type_means, type_vars : array_like, shape (K,)
        :math:`\Pi_k` and :math:`\sigma_{\Pi k}^2 > 0` of the type densities.
    priors : array_like, shape (K,), optional
        Prior type probabilities :math:`p_k \ge 0` summing to 1 (default uniform).
    log : bool, optional
        Return log-probabilities (useful for log-loss: no underflow to 0).

    Returns
    -------
    numpy.ndarray, shape (..., K)
        :math:`P(T_k \mid \tilde\Pi)`; sums to 1 over the last axis.

    Raises
    ------
    ValueError
        As :func:`type_likelihood`; `priors` of the wrong shape, negative or
        not summing to 1.
    TypeError
        Non-numeric input, or a `log` that is not a bool.

    Notes
    -----
    With two reports of one object (model 1) the type likelihood factorises
    into a type-free factor in :math:`\hat\Pi_1 - \hat\Pi_2` and a factor in the
    fused feature :math:`\tilde\Pi` alone, so :math:`\tilde\Pi` is sufficient and

    .. math::

        P(T_k \mid \hat\Pi_1, \hat\Pi_2)
        = \frac{p_k\, \mathcal N(\tilde\Pi;\ \Pi_k,\ \sigma_{\Pi k}^2 + v)}
               {\sum_{j=1}^K p_j\, \mathcal N(\tilde\Pi;\ \Pi_j,\ \sigma_{\Pi j}^2 + v)},
        \qquad v = \operatorname{Var}\tilde\Pi.

    The paper's (13) plugs :math:`\tilde\Pi` into :math:`f(\Pi \mid T_k)`, i.e.
    takes :math:`v = 0` and uniform priors; that is overconfident unless
    :math:`v \ll \sigma_{\Pi k}^2`. (The book writes :math:`v` as
    :math:`\tilde\sigma_\Pi^2`.)

    *Numerical range.* The posterior is formed from the exact differences of
    the log-joint against the best type (:func:`_relative_log_joint`): the
    squares are never formed outside the log domain and near-equal means are
    not cancelled against the feature. So it is finite and sums to 1 over the
    whole float range — a feature of 1e300 goes to the type whose density has
    the heavier tail, types of variance 1e-310 are still told apart, and
    means 1e-18 apart are resolved at a feature of 1 — and agrees with an
    mpmath evaluation of the same formula (``tests/test_features.py``).

    References
    ----------
    Grachov & Korneev (2010), eq. (13) (and (8), corrected).

    Examples
    --------
    >>> p = type_posterior(0.5, 0.1, [0.0, 1.0], [0.2, 0.2])
    >>> p.round(3), float(p.sum())
    (array([0.5, 0.5]), 1.0)
    >>> type_posterior(1e3, 0.0, [0.0, 1.0], [1.0, 1.0]).round(3)
    array([0., 1.])
    """
    f = as_float_array(feature, "feature")
    v = as_positive(feature_var, "feature_var", strict=False)
    f, v = broadcast(feature=f, feature_var=v)
    means, tvars, log_priors = _types_iv(type_means, type_vars, priors)
    log = _as_flag(log, "log")
    _check_memory(f.shape, means.size, "type posterior")
    # log of the widened variances σ_Πk² + v, then exact differences against the best type
    log_post = _log_posterior([f], means, [_log_var_sum(tvars, v[..., None])], log_priors)
    return log_post if log else np.exp(log_post)


def pair_type_posterior(feature1, feature_var1, feature2, feature_var2, type_means, type_vars,
                        priors=None, *, model: str = "shared", log: bool = False):
    r"""Type posterior from the two feature reports of one object, under either model.

    Parameters
    ----------
    feature1, feature2 : array_like
        The two radars' feature reports of the object (broadcast together).
    feature_var1, feature_var2 : array_like
        Their error variances (> 0).
    type_means, type_vars, priors : array_like, shape (K,)
        As in :func:`type_posterior`.
    model : {"shared", "spread"}, optional
        Feature observation model.
    log : bool, optional
        Return log-probabilities.

    Returns
    -------
    numpy.ndarray, shape (..., K)

    Notes
    -----
    ``"shared"``: :func:`type_posterior` of the fused feature with its
    variance (the fused feature is sufficient). ``"spread"``: the two reports
    are independent given the type, so

    .. math::

        P(T_k \mid \hat\Pi_1, \hat\Pi_2) \propto p_k\,
        \mathcal N(\hat\Pi_1; \Pi_k, \sigma_{\Pi k}^2 + \sigma_{\Pi 1}^2)\,
        \mathcal N(\hat\Pi_2; \Pi_k, \sigma_{\Pi k}^2 + \sigma_{\Pi 2}^2).

    References
    ----------
    Grachov & Korneev (2010), eq. (13) and the two observation models.

    Examples
    --------
    >>> pair_type_posterior(0.9, 0.1, 1.1, 0.1, [0.0, 1.0], [0.2, 0.2]).round(3)
    array([0.119, 0.881])
    >>> pair_type_posterior(0.9, 0.1, 1.1, 0.1, [0.0, 1.0], [0.2, 0.2], model="spread").round(3)
    array([0.034, 0.966])
    """
    model = as_choice(model, "model", FEATURE_MODELS)
    log = _as_flag(log, "log")
    if model == "shared":
        ff = fused_feature(feature1, feature_var1, feature2, feature_var2)
        return type_posterior(ff.value, ff.var, type_means, type_vars, priors, log=log)
    f1 = as_float_array(feature1, "feature1")
    f2 = as_float_array(feature2, "feature2")
    v1 = as_positive(feature_var1, "feature_var1")
    v2 = as_positive(feature_var2, "feature_var2")
    f1, v1, f2, v2 = broadcast(feature1=f1, feature_var1=v1, feature2=f2, feature_var2=v2)
    means, tvars, log_priors = _types_iv(type_means, type_vars, priors)
    _check_memory(f1.shape, means.size, "type posterior")
    log_post = _log_posterior([f1, f2], means, [_log_var_sum(tvars, v1[..., None]),
                                                _log_var_sum(tvars, v2[..., None])], log_priors)
    return log_post if log else np.exp(log_post)


# ----------------------------------------------------------------------------- proximity
@dataclass(frozen=True)
class CombinedProximity:
    r"""The combined coordinate + feature proximity measure of report pairs.

    Attributes
    ----------
    total : numpy.ndarray
        :math:`\kappa = \kappa^x + \kappa^\Pi`.
    coordinate : numpy.ndarray
        :math:`\kappa^x = (\hat{\mathbf x}_1-\hat{\mathbf x}_2)^\top (\Sigma_1+\Sigma_2)^{-1}
        (\hat{\mathbf x}_1-\hat{\mathbf x}_2)`.
    feature : numpy.ndarray
        :math:`\kappa^\Pi`, the feature term (see :func:`combined_proximity`).
    dof : int or None
        Degrees of freedom of the :math:`\chi^2` law of `total` under a true
        hypothesis: ``d + 1`` for the profile measure of model 1, ``d`` for the
        profile measure of model 2 (whose feature term is zero); ``None`` for
        the marginal measures, which are log-likelihood ratios, not
        :math:`\chi^2`.
    model : str
        ``"shared"`` or ``"spread"``.
    kind : str
        ``"profile"`` or ``"marginal"``.
    """

    total: np.ndarray
    coordinate: np.ndarray
    feature: np.ndarray
    dof: int | None
    model: str
    kind: str


def type_agreement(feature1, feature_var1, feature2, feature_var2, type_means, type_vars,
                   priors=None):
    r"""Type agreement of two feature reports under model 2: :math:`-2 \ln \sum_k P(T_k \mid \hat\Pi_1) P(T_k \mid \hat\Pi_2) / p_k`.

    Minus twice the log-likelihood ratio of "one object" against "two
    objects" when each radar measures its own draw of the object's feature
    (model 2), the feature values integrated out under the type description:

    .. math::

        \kappa^{\Pi}_{(2)} = -2 \ln rac{\sum_k p_k\, g_{1k}(\hat\Pi_1)\, g_{2k}(\hat\Pi_2)}
        {\sum_k p_k\, g_{1k}(\hat\Pi_1)\ \sum_j p_j\, g_{2j}(\hat\Pi_2)}
        = -2 \ln \sum_k rac{P(T_k \mid \hat\Pi_1)\, P(T_k \mid \hat\Pi_2)}{p_k},

    with :math:`g_{ik} = \mathcal N(\,\cdot\,; \Pi_k, \sigma_{\Pi k}^2 + \sigma_{\Pi i}^2)`
    (the second form by Bayes' rule on each report). Not :math:`\chi^2`; negative
    when the reports agree on a rare type.

    Parameters
    ----------
    feature1, feature2 : array_like
        The two radars' feature reports (broadcast together).
    feature_var1, feature_var2 : array_like
        Their error variances (> 0).
    type_means, type_vars, priors : array_like, shape (K,)
        The type description, as in :func:`type_posterior`.

    Returns
    -------
    float or numpy.ndarray

    Raises
    ------
    ValueError, TypeError
        For non-finite or non-numeric reports, non-positive variances, shapes
        that do not broadcast or an invalid type description.

    Examples
    --------
    >>> round(type_agreement(0.0, 0.01, 0.0, 0.01, [0.0, 5.0], [1.0, 1.0]), 4)   # both type 1
    -1.3863
    """
    f1, v1, f2, v2 = _feature_pair_iv(feature1, feature_var1, feature2, feature_var2)
    means, tvars, log_priors = _types_iv(type_means, type_vars, priors)
    _check_memory(f1.shape, means.size, "type agreement")
    log_p1 = _log_posterior([f1], means, [_log_var_sum(tvars, v1[..., None])], log_priors)
    log_p2 = _log_posterior([f2], means, [_log_var_sum(tvars, v2[..., None])], log_priors)
    with np.errstate(invalid="ignore"):              # a type of prior 0 contributes nothing
        terms = np.where(np.isneginf(log_priors), -np.inf, log_p1 + log_p2 - log_priors)
    return unwrap(-2.0 * logsumexp(terms, axis=-1))  # -2 ln sum_k P1_k P2_k / p_k


def _feature_pair_iv(feature1, feature_var1, feature2, feature_var2):
    """Two feature reports and their variances (> 0), broadcast together."""
    f1 = as_float_array(feature1, "feature1")
    f2 = as_float_array(feature2, "feature2")
    v1 = as_positive(feature_var1, "feature_var1")
    v2 = as_positive(feature_var2, "feature_var2")
    f1, f2, v1, v2 = broadcast(feature1=f1, feature2=f2, feature_var1=v1, feature_var2=v2)
    return f1, v1, f2, v2


def _marginal_feature_term(f1, v1, f2, v2, means, tvars, log_priors):
    """-2 ln LR("one object" vs "two objects") of two feature reports under model 1."""
    lv1, lv2 = _log_var_sum(tvars, v1[..., None]), _log_var_sum(tvars, v2[..., None])
    # N(Π̂1 - Π̂2; 0, v1 + v2) sum_k p_k N(Π̃; Π_k, σ_Πk² + ṽ) over the two marginals
    fused, fused_var = _fuse_two(f1, v1, f2, v2)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        apart = (logsumexp(_log_normal(f1[..., None], means, np.exp(lv1)) + log_priors, -1)
                 + logsumexp(_log_normal(f2[..., None], means, np.exp(lv2)) + log_priors, -1))
        same = (_log_normal(f1 - f2, 0.0, v1 + v2)
                + logsumexp(_log_normal(fused[..., None], means,
                                        tvars + fused_var[..., None]) + log_priors, -1))
        out = -2.0 * (same - apart)
    if not np.all(np.isfinite(out)):
        raise ValueError("the marginal feature term is beyond the floating-point range for "
                         "some `feature1`, `feature2` (reports too far from every type "
                         "relative to its spread); use kind='profile' or rescale the feature")
    return out


def combined_proximity(x1, x2, cov1, cov2, feature1, feature2, feature_var1, feature_var2, *,
                       model: str = "shared", kind: str = "profile", type_means=None,
                       type_vars=None, priors=None) -> CombinedProximity:
    r"""Combined coordinate + feature proximity measure of report pairs, eq. (12) corrected.

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        Coordinate reports of radar 1 and radar 2 (batch axes broadcast).
    cov1, cov2 : array_like, shape (..., d, d)
        Their error covariances (symmetric positive definite).
    feature1, feature2 : array_like, shape (...)
        Feature reports.
    feature_var1, feature_var2 : array_like
        Feature error variances (> 0).
    model : {"shared", "spread"}, optional
        Feature observation model: ``"shared"`` (the paper's model 1, used for
        (9)–(12)) or ``"spread"`` (model 2).
    kind : {"profile", "marginal"}, optional
        ``"profile"`` (default): the unknown feature value(s) replaced by their
        ML estimates, as the paper does — for model 1 the corrected (12).
        ``"marginal"``: the feature value integrated out under the type
        description, giving minus twice a log-likelihood ratio.
    type_means, type_vars, priors : array_like, shape (K,), optional
        Type description, required for ``kind="marginal"``.

    Returns
    -------
    CombinedProximity

    Raises
    ------
    ValueError
        Mismatched coordinate dimensions, shapes that do not broadcast,
        covariances that are not positive definite, non-positive feature
        variances, an unknown `model` or `kind`, a missing or invalid type
        description for ``kind="marginal"``.

    Notes
    -----
    The coordinate part is :func:`radarfusion_ref.proximity.proximity_gaussian`.

    *Profile, model 1* — minus twice the log of the profile likelihood (11)
    is, up to a constant,

    .. math::

        \kappa = (\hat{\mathbf x}_1-\hat{\mathbf x}_2)^\top (\Sigma_1+\Sigma_2)^{-1}
                  (\hat{\mathbf x}_1-\hat{\mathbf x}_2)
                + \frac{(\hat\Pi_1-\hat\Pi_2)^2}{\sigma_{\Pi1}^2+\sigma_{\Pi2}^2},

    :math:`\chi^2(d+1)` under a true hypothesis and noncentral
    :math:`\chi'^2(d+1, \lambda_x + \lambda_\Pi)` under a false one (given the two objects'
    positions and feature values). The paper prints (12) without the squares.

    *Profile, model 2* — each radar's value is a separate unknown, fitted
    exactly by its own report: the feature term is zero (features say nothing
    about association — the paper's conclusion for model 2).

    *Marginal* — with :math:`g_{ik} = \mathcal N(\,\cdot\,; \Pi_k, \sigma_{\Pi k}^2 +
    \sigma_{\Pi i}^2)` and :math:`p(\hat\Pi_i) = \sum_k p_k g_{ik}(\hat\Pi_i)`,

    .. math::

        \kappa^\Pi = -2 \ln \frac{p(\hat\Pi_1, \hat\Pi_2 \mid \text{one object})}
                                 {p(\hat\Pi_1)\, p(\hat\Pi_2)},

    where the numerator is :math:`\sum_k p_k\, g_{1k}(\hat\Pi_1)\, g_{2k}(\hat\Pi_2)`
    under model 2 (the reports share only the type) and
    :math:`\mathcal N(\hat\Pi_1-\hat\Pi_2; 0, \sigma_{\Pi1}^2+\sigma_{\Pi2}^2)
    \sum_k p_k\, \mathcal N(\tilde\Pi; \Pi_k, \sigma_{\Pi k}^2 + v)` under model 1.
    The model-1 marginal term is the profile term plus a correction that
    matters when the feature noise is not small against the type spread.

    References
    ----------
    Grachov & Korneev (2010), eqs. (9)–(12) and the two observation models.

    Examples
    --------
    >>> k = combined_proximity([0.0], [1.0], [[0.5]], [[0.5]], 0.0, 2.0, 1.0, 1.0)
    >>> float(k.total), float(k.coordinate), float(k.feature), k.dof
    (3.0, 1.0, 2.0, 2)
    >>> k = combined_proximity([0.0], [1.0], [[0.5]], [[0.5]], 0.0, 2.0, 1.0, 1.0,
    ...                        model="spread", kind="marginal", type_means=[0.0, 2.0],
    ...                        type_vars=[0.1, 0.1])
    >>> round(float(k.feature), 3), k.dof
    (1.465, None)
    """
    model = as_choice(model, "model", FEATURE_MODELS)
    kind = as_choice(kind, "kind", ("profile", "marginal"))
    kx = np.asarray(proximity_gaussian(x1, x2, cov1, cov2), dtype=float)
    d = np.shape(x1)[-1]

    f1, v1, f2, v2 = _feature_pair_iv(feature1, feature_var1, feature2, feature_var2)
    if kind == "profile":
        if model == "shared":
            # (Π̂1 - Π̂2)² / (σ_Π1² + σ_Π2²), formed in the log domain: no overflow of the
            # square or of the sum of variances when the quotient itself is representable
            with np.errstate(over="ignore"):
                kf = _quadratic(f1, f2, np.logaddexp(np.log(v1), np.log(v2)))
        else:
            kf = np.zeros(f1.shape)
        dof = d + 1 if model == "shared" else d
    else:
        if type_means is None or type_vars is None:
            raise ValueError("`type_means` and `type_vars` are required with kind='marginal'; "
                             f"received type_means={type_means!r}, type_vars={type_vars!r}")
        if model == "spread":
            kf = np.asarray(type_agreement(f1, v1, f2, v2, type_means, type_vars, priors))
        else:
            means, tvars, log_priors = _types_iv(type_means, type_vars, priors)
            _check_memory(f1.shape, means.size, "marginal feature term")
            kf = _marginal_feature_term(f1, v1, f2, v2, means, tvars, log_priors)
        dof = None
    try:
        kx, kf = np.broadcast_arrays(kx, kf)
    except ValueError:
        raise ValueError("the coordinate batch shape (of `x1`, `x2`) and the feature shape (of "
                         f"`feature1`, `feature2`) must broadcast; received {kx.shape} and "
                         f"{kf.shape}") from None
    with np.errstate(over="ignore"):
        total = kx + kf
    if not np.all(np.isfinite(total)):
        raise ValueError("the combined proximity exceeds the floating-point range (about "
                         "1.8e308) for some pair: the reports (`x1`, `x2`, `feature1`, "
                         "`feature2`) are too far apart for their variances; such a pair is "
                         "outside any gate, so drop it before computing the measure")
    return CombinedProximity(total, kx, kf, dof, model, kind)


def association_costs(scene: TypedScene, *, features: str = "shared",
                      kind: str = "profile") -> np.ndarray:
    r"""Cost matrices ``cost[t, i, j]`` of pairing radar-1 report i with radar-2 report j.

    Parameters
    ----------
    scene : TypedScene
    features : {"none", "shared", "spread"}, optional
        ``"none"``: coordinates only (:math:`\kappa^x`); otherwise coordinates
        plus the feature term of :func:`combined_proximity` for that model.
        The model need not match the scene's own — using ``"shared"`` on a
        ``"spread"`` scene is the mistake the chapter shows.
    kind : {"profile", "marginal"}, optional
        The feature term's kind (see :func:`combined_proximity`); the scene's
        type description is used for ``"marginal"``.

    Returns
    -------
    numpy.ndarray, shape (trials, n, n)

    Examples
    --------
    >>> from radarfusion_ref.engine.scenes import typed_scene
    >>> s = typed_scene(2, type_means=[0.0], type_vars=[1.0], spacing=1.0, sigma1=0.1,
    ...                 sigma2=0.1, feature_sigma1=0.1, feature_sigma2=0.1, rng=0)
    >>> association_costs(s, features="none").shape
    (1, 2, 2)
    """
    if not isinstance(scene, TypedScene):
        raise TypeError(f"`scene` must be a TypedScene; received {type(scene).__name__}")
    features = as_choice(features, "features", ("none", *FEATURE_MODELS))
    kind = as_choice(kind, "kind", ("profile", "marginal"))
    c = scene.coords
    d = c.reports1.shape[-1]
    cov1 = c.sigma1**2 * np.eye(d)
    cov2 = c.sigma2**2 * np.eye(d)
    k = combined_proximity(c.reports1[:, :, None, :], c.reports2[:, None, :, :], cov1, cov2,
                           scene.features1[:, :, None], scene.features2[:, None, :],
                           scene.feature_sigma1**2, scene.feature_sigma2**2,
                           model="shared" if features == "none" else features,
                           kind="profile" if features == "none" else kind,
                           type_means=scene.type_means, type_vars=scene.type_vars,
                           priors=scene.priors)
    return k.coordinate if features == "none" else k.total


# ----------------------------------------------------------------------------- triune task
@dataclass(frozen=True)
class Confusion:
    """A type confusion matrix with Wilson intervals per entry.

    Attributes
    ----------
    counts : numpy.ndarray of int, shape (K, K)
        ``counts[k, l]``: objects of true type ``k`` recognised as type ``l``.
    rate : numpy.ndarray, shape (K, K)
        Row-normalised counts (``nan``-free: a type that never occurred has a
        zero row and is flagged in `support`).
    low, high : numpy.ndarray, shape (K, K)
        95 % Wilson limits of each rate (objects treated as independent).
    support : numpy.ndarray of int, shape (K,)
        Number of objects of each true type.
    """

    counts: np.ndarray
    rate: np.ndarray
    low: np.ndarray
    high: np.ndarray
    support: np.ndarray


@dataclass(frozen=True)
class TriuneResult:
    """Outcome of association – estimation – recognition on a batch of typed scenes.

    Attributes
    ----------
    match : numpy.ndarray of int, shape (trials, n)
        The association evaluated: radar-1 report ``j`` paired with radar-2
        report ``match[t, j]`` (``-1``: left unpaired).
    correct : numpy.ndarray of bool, shape (trials, n)
        Whether each radar-1 report got its true partner.
    fused : numpy.ndarray, shape (trials, n, d)
        Fused coordinates of each object (a lone radar-1 report if unpaired).
    sq_error : numpy.ndarray, shape (trials, n)
        Squared Euclidean error of `fused` against the truth.
    posterior : numpy.ndarray, shape (trials, n, K)
        Type posterior of each object.
    recognised : numpy.ndarray of int, shape (trials, n)
        The maximum-a-posteriori type.
    true_type : numpy.ndarray of int, shape (trials, n)
        The true type.
    """

    match: np.ndarray
    correct: np.ndarray
    fused: np.ndarray
    sq_error: np.ndarray
    posterior: np.ndarray
    recognised: np.ndarray
    true_type: np.ndarray

    def pair_accuracy(self) -> MeanEstimate:
        """Mean fraction of correctly associated reports per scene (t-interval over scenes)."""
        return mean(self.correct.mean(axis=-1))

    def all_correct(self) -> Proportion:
        """Probability that a scene is associated entirely correctly (Wilson interval)."""
        return proportion(np.all(self.correct, axis=-1), None)

    def mse(self) -> MeanEstimate:
        """Mean squared position error per object (t-interval over per-scene means)."""
        return mean(self.sq_error.mean(axis=-1))

    def rmse(self) -> tuple[float, float, float]:
        """RMSE with its 95 % interval: the square roots of :meth:`mse` and its limits."""
        m = self.mse()
        return (float(np.sqrt(m.estimate)), float(np.sqrt(max(m.low, 0.0))),
                float(np.sqrt(m.high)))

    def type_accuracy(self) -> Proportion:
        """Fraction of objects recognised correctly (Wilson; objects treated as independent)."""
        return proportion((self.recognised == self.true_type).ravel(), None)

    def confusion(self) -> Confusion:
        """The type confusion matrix with per-entry Wilson intervals."""
        n_types = self.posterior.shape[-1]
        counts = np.zeros((n_types, n_types), dtype=int)
        np.add.at(counts, (self.true_type.ravel(), self.recognised.ravel()), 1)
        support = counts.sum(axis=1)
        rate = np.zeros((n_types, n_types))
        low = np.zeros((n_types, n_types))
        high = np.ones((n_types, n_types))
        for k in np.flatnonzero(support):
            p = proportion(counts[k], int(support[k]))
            rate[k], low[k], high[k] = p.estimate, p.low, p.high
        return Confusion(counts, rate, low, high, support)


def triune(scene: TypedScene, match, *, rule: str = "exact") -> TriuneResult:
    """Estimate and recognise every object of `scene` under the association `match`.

    Parameters
    ----------
    scene : TypedScene
    match : array_like of int, shape (trials, n)
        Radar-2 partner of each radar-1 report (``-1``: unpaired), e.g. from
        an associator run on :func:`association_costs`.
    rule : {"exact", "plugin"}, optional
        Type posterior: the exact one for the scene's feature model
        (:func:`pair_type_posterior` with the scene's priors; a lone report's
        own posterior if unpaired) or the paper's plug-in (13) (the fused
        feature with variance 0 and uniform priors).

    Returns
    -------
    TriuneResult

    Raises
    ------
    ValueError
        If `match` has the wrong shape or out-of-range entries.

    Examples
    --------
    >>> from radarfusion_ref.engine.scenes import typed_scene
    >>> s = typed_scene(3, type_means=[0.0, 9.0], type_vars=[1.0, 1.0], spacing=5.0,
    ...                 sigma1=0.1, sigma2=0.1, feature_sigma1=0.1, feature_sigma2=0.1,
    ...                 trials=50, rng=2)
    >>> r = triune(s, s.true_match)
    >>> r.all_correct().estimate, r.type_accuracy().estimate > 0.95
    (1.0, True)
    """
    if not isinstance(scene, TypedScene):
        raise TypeError(f"`scene` must be a TypedScene; received {type(scene).__name__}")
    rule = as_choice(rule, "rule", ("exact", "plugin"))
    c = scene.coords
    trials, n = c.owner2.shape
    m = np.asarray(match)
    if m.shape != (trials, n) or not np.issubdtype(m.dtype, np.integer):
        raise ValueError(f"`match` must be an integer array of shape {(trials, n)}; "
                         f"received dtype {m.dtype} with shape {m.shape}")
    if np.any((m < -1) | (m >= n)):
        raise ValueError(f"`match` entries must lie in [-1, {n - 1}]; received min {m.min()}, "
                         f"max {m.max()}")
    paired = m >= 0
    idx = np.where(paired, m, 0)
    x2 = np.take_along_axis(c.reports2, idx[..., None], axis=1)
    f2 = np.take_along_axis(scene.features2, idx, axis=1)
    s1, s2 = c.sigma1**2, c.sigma2**2
    pair_fused = fuse(np.stack([c.reports1, x2], axis=-1), np.array([s1, s2])).estimate
    fused = np.where(paired[..., None], pair_fused, c.reports1)
    v1, v2 = scene.feature_sigma1**2, scene.feature_sigma2**2
    types = (scene.type_means, scene.type_vars)
    if rule == "exact":
        post = np.where(paired[..., None],
                        pair_type_posterior(scene.features1, v1, f2, v2, *types, scene.priors,
                                            model=scene.model),
                        type_posterior(scene.features1, v1, *types, scene.priors))
    else:
        ff = fused_feature(scene.features1, v1, f2, v2)
        post = type_posterior(np.where(paired, ff.value, scene.features1), 0.0, *types)
    sq = np.sum((fused - c.truth) ** 2, axis=-1)
    return TriuneResult(m, m == scene.true_match, fused, sq, post, np.argmax(post, axis=-1),
                        scene.types)


# ----------------------------------------------------------------------------- calibration
@dataclass(frozen=True)
class ReliabilityCurve:
    """Binned calibration of predicted probabilities (a reliability diagram).

    Attributes
    ----------
    predicted : numpy.ndarray, shape (B,)
        Mean predicted probability in each non-empty bin.
    observed : numpy.ndarray, shape (B,)
        Observed frequency of the event in the bin.
    low, high : numpy.ndarray, shape (B,)
        95 % Wilson limits of `observed`.
    counts : numpy.ndarray of int, shape (B,)
        Number of predictions in the bin.
    """

    predicted: np.ndarray
    observed: np.ndarray
    low: np.ndarray
    high: np.ndarray
    counts: np.ndarray


def reliability_curve(prob, outcome, *, bins: int = 10) -> ReliabilityCurve:
    """Reliability diagram data: predicted probability against observed frequency.

    Parameters
    ----------
    prob : array_like
        Predicted probabilities in [0, 1] (any shape; flattened).
    outcome : array_like of bool
        Whether the predicted event happened (same shape as `prob`).
    bins : int, optional
        Number of equal-width bins on [0, 1], at most :data:`MAX_BINS`; empty
        bins are dropped.

    Returns
    -------
    ReliabilityCurve

    Raises
    ------
    ValueError
        Probabilities outside [0, 1] or non-finite, an empty `prob`, an
        `outcome` that is not boolean or of another size, `bins` < 1 or above
        :data:`MAX_BINS` (refused before anything is allocated).
    TypeError
        A non-integer `bins`, non-numeric `prob`.

    Examples
    --------
    >>> r = reliability_curve([0.1, 0.1, 0.9, 0.9], [False, False, True, True], bins=2)
    >>> r.predicted, r.observed, r.counts
    (array([0.1, 0.9]), array([0., 1.]), array([2, 2]))
    """
    bins = as_int(bins, "bins", minimum=1)
    check_size(bins, MAX_BINS, what="bins (`bins`)",
               alternative=f"at most {MAX_BINS} bins (a reliability diagram needs tens)")
    p = as_float_array(prob, "prob").ravel()
    if p.size == 0:
        raise ValueError("`prob` must hold at least one prediction; received an empty array")
    if np.any((p < 0) | (p > 1)):
        raise ValueError(f"`prob` must lie in [0, 1]; received {_describe(p)} (min {p.min():.6g},"
                         f" max {p.max():.6g})")
    o = np.asarray(outcome)
    if o.dtype != bool or o.size != p.size:
        raise ValueError(f"`outcome` must be a boolean array with as many entries as `prob` "
                         f"({p.size}); received {_describe(outcome)} (dtype {o.dtype}, "
                         f"{o.size} entries)")
    which = np.minimum((p * bins).astype(int), bins - 1)
    counts = np.bincount(which, minlength=bins)
    hits = np.bincount(which[o.ravel()], minlength=bins)
    sums = np.bincount(which, weights=p, minlength=bins)
    keep = np.flatnonzero(counts)
    pred = sums[keep] / counts[keep]
    obs, low, high = (np.empty(keep.size) for _ in range(3))
    for i, b in enumerate(keep):
        est = proportion(int(hits[b]), int(counts[b]))
        obs[i], low[i], high[i] = est.estimate, est.low, est.high
    return ReliabilityCurve(pred, obs, low, high, counts[keep])
