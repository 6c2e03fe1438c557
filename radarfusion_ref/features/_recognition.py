"""Features: the fused feature and the type likelihood and posteriors (recognition)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import expit

from ..engine.scenes import (
    FEATURE_MODELS,
    as_type_model,
)
from ..engine.validation import (
    as_choice,
    as_float_array,
    as_positive,
    broadcast,
    describe,
    unwrap,
)
from ._common import (
    _LOG_2PI,
    _as_flag,
    _check_memory,
    _log_posterior,
    _log_var_sum,
    _quadratic,
)


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
    means, tvars, _ = as_type_model(type_means, type_vars, None)
    log = _as_flag(log, "log")
    _check_memory(f.shape, means.size, "type likelihood")
    log_var = _log_var_sum(tvars, v[..., None])
    with np.errstate(over="ignore"):
        out = -0.5 * (_LOG_2PI + log_var + _quadratic(f[..., None], means, log_var))
    if log and np.any(np.isinf(out)):
        raise ValueError("the log-likelihood is below the floating-point range (about -1.8e308) "
                         "for some `feature`; use type_posterior for normalised probabilities "
                         f"(received feature {describe(f)})")
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
    means, tvars, log_priors = as_type_model(type_means, type_vars, priors)
    log = _as_flag(log, "log")
    _check_memory(f.shape, means.size, "type posterior")
    # log of the widened variances σ_Πk² + v, then exact differences
    # against the best type
    log_post = _log_posterior([f], means,
                              [_log_var_sum(tvars, v[..., None])],
                              log_priors)
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
    means, tvars, log_priors = as_type_model(type_means, type_vars, priors)
    _check_memory(f1.shape, means.size, "type posterior")
    log_post = _log_posterior([f1, f2], means, [_log_var_sum(tvars, v1[..., None]),
                                                _log_var_sum(tvars, v2[..., None])], log_priors)
    return log_post if log else np.exp(log_post)
