"""Features: limits, option checks and the log-domain helpers shared by the rules."""

from __future__ import annotations

import numpy as np
from scipy.special import logsumexp

from ..engine.validation import (
    MEMORY_LIMIT,
    check_size,
    describe,
)

_LOG_2PI = np.log(2.0 * np.pi)

#: Largest number of bins :func:`reliability_curve` accepts. A reliability diagram
#: needs tens of bins; more only splits the predictions into bins too small to
#: estimate a frequency, and the limit is checked before anything is allocated.
MAX_BINS = 10_000

#: Working arrays of one type posterior, each of the output's size (for the
#: memory limit :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT`).
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
        raise TypeError(f"`{name}` must be True or False; received {describe(value)}")
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
