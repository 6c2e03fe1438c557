r"""Chi-square gating of association hypotheses.

A pointwise hypothesis :math:`G_k` ("report 1 and report 2 belong to one
object") is accepted when its proximity measure :math:`\kappa` (a squared
Mahalanobis distance, see :mod:`radarfusion_ref.proximity`) falls below a gate
:math:`\gamma`. Under a true hypothesis :math:`\kappa \sim \chi^2_\nu`; under a
false one :math:`\kappa \sim \chi'^2_\nu(\lambda)`, a noncentral chi-square with
noncentrality :math:`\lambda`. The gate is set from the probability
:math:`P_{\text{lo}}` of falsely rejecting a true hypothesis (Grachov & Korneev
2010, text after eq. (7) and Fig. 1; the book's eq-gate):

.. math::

    P\{\chi^2_\nu > \gamma\} = P_{\text{lo}}.

The paper's :math:`\kappa_{\text{th}}`, :math:`m` and :math:`V` are the book's
:math:`\gamma`, :math:`\nu` and :math:`\lambda`.

.. rubric:: Public functions

* :func:`gate_threshold` — :math:`\gamma` from :math:`P_{\text{lo}}` and the
  degrees of freedom;
* :func:`in_gate` — the accept/reject decision for observed statistics;
* :func:`p_false_accept` — the probability that a false hypothesis with
  noncentrality :math:`\lambda` passes the gate (1 − power);
* :func:`required_noncentrality` — the :math:`\lambda` a false hypothesis needs for
  its acceptance probability to drop to a target (root-finding in the log domain);
* :func:`gate_mahalanobis` — :math:`\kappa` and the gate for ``N`` paired d-dimensional
  reports sharing one covariance, chunked (Monte-Carlo experiments);
* :func:`gate_pairwise` — the gate for every pair of two sets of d-dimensional reports
  when each report carries its own covariance (polar reports, separated
  radars), batched over trials;
* :func:`gate_sparse` — the gated pairs of a large scene (one shared
  covariance) as a sparse matrix of :math:`\kappa`, found with a k-d tree in
  whitened coordinates: the input of a gated sparse assignment.

All functions broadcast over their array arguments.

.. rubric:: Numerical range and limits

* :func:`p_false_accept` is correct down to the smallest double: where
  scipy's noncentral chi-square CDF falls below 1e-200 (it underflows to 0
  near 1e-146), the probability is summed in the log domain as a Poisson
  mixture of regularised incomplete gamma functions, and where the bound
  :math:`P \le \Phi(\sqrt\gamma - \sqrt\lambda)` is below the smallest double
  the result is 0.
* :func:`required_noncentrality` solves :math:`\ln P_{\text{fa}}(\lambda) =
  \ln p`, so targets down to the smallest double have their true root instead
  of a clamped constant; it refuses more than :data:`MAX_ROOTS` roots per call.
* The squared Mahalanobis distance itself, its numeric domain and the
  positive-definiteness rule live in :mod:`radarfusion_ref.engine.linalg`;
  :func:`gate_mahalanobis` refuses a `chunk_size` above :data:`MAX_CHUNK`
  before allocating anything.

.. rubric:: References

.. [1] V. M. Grachov, V. A. Korneev, "Method of combining radar information
   taking coordinate and feature measurements into account", Kharkiv Air
   Force University, 2010 — the gating rule after eq. (7), Fig. 1.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize, special, stats

from .engine.linalg import (
    mahalanobis_sq_k2_kernel,
    mahalanobis_sq_kernel,
    mahalanobis_sq_pairwise,
)
from .engine.validation import (
    MAX_MAGNITUDE,
    MEMORY_LIMIT,
    as_covariance,
    as_float,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    broadcast,
    check_domain,
    check_size,
    describe,
    unwrap,
)

__all__ = [
    "MAX_CHUNK",
    "MAX_ROOTS",
    "gate_mahalanobis",
    "gate_pairwise",
    "gate_sparse",
    "gate_threshold",
    "in_gate",
    "p_false_accept",
    "required_noncentrality",
]

#: Largest `chunk_size` of :func:`gate_mahalanobis`: 2**20 pairs, three
#: work buffers of 8 MiB each. Larger chunks buy nothing (memory does not grow
#: with the number of pairs anyway).
MAX_CHUNK = 1 << 20

#: Most roots :func:`required_noncentrality` solves in one call (each is a
#: scalar root search of about a millisecond).
MAX_ROOTS = 100_000

#: Below this, scipy's noncentral chi-square CDF is re-evaluated in the log domain.
_CDF_FLOOR = 1e-200
#: exp(_LOG_ZERO) is 0 in double precision (the smallest subnormal is exp(-744.4)).
_LOG_ZERO = -760.0
#: Longest Poisson-mixture window summed for one extreme-tail probability.
_MAX_TERMS = 1 << 20


def _as_dof(value, name: str = "dof") -> np.ndarray:
    """Degrees of freedom: integer-valued numbers >= 1 (scalar or array)."""
    if isinstance(value, bool) or (isinstance(value, np.ndarray) and value.dtype == bool):
        raise TypeError(f"`{name}` must be an integer or an array of integers >= 1; "
                        f"received {describe(value)}")
    arr = as_float_array(value, name)
    if np.any(arr != np.round(arr)) or np.any(arr < 1):
        bad = arr[(arr != np.round(arr)) | (arr < 1)].ravel()[0]
        raise ValueError(
            f"`{name}` must be an integer >= 1 (or an array of them); received "
            f"{describe(value)} (offending entry {bad:.6g})"
        )
    return arr


def _log_gammainc(a, x):
    r"""log P(a, x), the regularised lower incomplete gamma function, for arrays a > 0, x > 0.

    scipy's ``gammainc`` where it is above 1e-290; below, the series
    :math:`P(a, x) = x^a e^{-x}/\Gamma(a + 1) \sum_k x^k / ((a + 1)\cdots(a + k))`
    in the log domain (it underflows only where x is well below a, so the series
    converges fast).
    """
    a, x = np.broadcast_arrays(np.asarray(a, float), np.asarray(x, float))
    with np.errstate(divide="ignore"):
        p = special.gammainc(a, x)
        out = np.log(np.where(p > 1e-290, p, 1.0))
    low = ~(p > 1e-290)
    if np.any(low):
        aa, xx = a[low], x[low]
        k = np.arange(1, 401)
        terms = np.cumsum(np.log(xx)[:, None] - np.log(aa[:, None] + k[None, :]), axis=1)
        series = special.logsumexp(np.concatenate([np.zeros((aa.size, 1)), terms], axis=1),
                                   axis=1)
        out[low] = aa * np.log(xx) - xx - special.gammaln(aa + 1) + series
    return out


def _log_ncx2_cdf_tail(t, nu, lam):
    """log P{chi'^2_nu(lam) < t} for one (t, nu, lam) whose probability is tiny.

    Returns a finite number; values below ``_LOG_ZERO`` mean "0 in double
    precision" (they are the upper bound log Phi(sqrt t - sqrt lam) there, so
    the function stays monotone for root finding).
    """
    bound = float(special.log_ndtr(np.sqrt(t) - np.sqrt(lam)))
    if bound < _LOG_ZERO:
        return bound
    x, a0, h = 0.5 * t, 0.5 * nu, 0.5 * lam
    # the dominant Poisson term: j (a0 + j) = h x, or the Poisson mode h if smaller
    j_star = min(h, 0.5 * (-a0 + np.sqrt(a0 * a0 + 4.0 * h * x)))
    width = int(40.0 * np.sqrt(j_star + 1.0)) + 60
    lo, hi = max(0, int(j_star) - width), int(j_star) + width + 1
    check_size(hi - lo, _MAX_TERMS, what="Poisson-mixture terms (extreme tail, huge `dof`)",
               alternative="a smaller `dof`, or scipy.stats.ncx2 with its normal range")
    j = np.arange(lo, hi, dtype=float)
    log_w = -h + j * np.log(h) - special.gammaln(j + 1.0)
    return float(special.logsumexp(log_w + _log_gammainc(a0 + j, x)))


def _log_p_accept(th, nu, lam):
    """log P{chi'^2_nu(lam) < th}, elementwise over broadcast arrays (lam >= 0)."""
    th, nu, lam = np.broadcast_arrays(np.asarray(th, float), np.asarray(nu, float),
                                      np.asarray(lam, float))
    out = np.empty(th.shape)
    central = lam == 0
    if np.any(central):
        out[central] = _log_gammainc(0.5 * nu[central], 0.5 * th[central])
    nc = ~central
    if np.any(nc):
        with np.errstate(all="ignore"):
            bound = special.log_ndtr(np.sqrt(th[nc]) - np.sqrt(lam[nc]))
            direct = np.where(bound < _LOG_ZERO, 0.0,
                              stats.ncx2.cdf(th[nc], nu[nc], np.where(lam[nc] > 0, lam[nc], 1)))
            vals = np.log(np.where(direct > _CDF_FLOOR, direct, 1.0))
        redo = ~(np.isfinite(direct) & (direct > _CDF_FLOOR))
        for i in np.flatnonzero(redo):
            vals[i] = _log_ncx2_cdf_tail(th[nc][i], nu[nc][i], lam[nc][i])
        out[nc] = vals
    return out


def gate_threshold(p_false_reject, dof=1):
    r"""Gate :math:`\gamma` for a given false-rejection probability (eq-gate).

    Parameters
    ----------
    p_false_reject : float or array_like
        :math:`P_{\text{lo}}`, the probability of rejecting a true hypothesis,
        in the open interval (0, 1). The paper uses 0.01 and 0.005.
    dof : int or array_like of int, optional
        Degrees of freedom :math:`\nu \ge 1` of the chi-square law (1 for one
        scalar coordinate; :math:`d` for a :math:`d`-dimensional position;
        :math:`n` for the sum over the :math:`n` pairs of a joint hypothesis).

    Returns
    -------
    float or numpy.ndarray
        :math:`\gamma`, broadcast over the arguments.

    Raises
    ------
    ValueError
        If `p_false_reject` is outside (0, 1) or `dof` is not an integer >= 1.
    TypeError
        If an argument is not numeric (bools and strings included).

    Notes
    -----
    The upper :math:`P_{\text{lo}}` quantile of :math:`\chi^2_\nu`:

    .. math::

        \gamma = F^{-1}_{\chi^2_\nu}(1 - P_{\text{lo}}),

    computed with :func:`scipy.stats.chi2.isf` (accurate also for tiny
    :math:`P_{\text{lo}}`, down to the smallest double).

    References
    ----------
    Grachov & Korneev (2010), the threshold rule after eq. (7), Fig. 1.

    Examples
    --------
    >>> round(gate_threshold(0.01, 1), 4)
    6.6349
    >>> gate_threshold([0.01, 0.005], 2).round(4)
    array([ 9.2103, 10.5966])
    """
    p = as_probability(p_false_reject, "p_false_reject")
    m = _as_dof(dof)
    p, m = broadcast(p_false_reject=p, dof=m)
    return unwrap(stats.chi2.isf(p, m))


def in_gate(statistic, dof=1, p_false_reject=0.01):
    r"""Accept (``True``) or reject (``False``) hypotheses by the chi-square gate.

    Parameters
    ----------
    statistic : float or array_like
        Proximity measures :math:`\kappa \ge 0` (squared Mahalanobis distances).
    dof : int or array_like of int, optional
        Degrees of freedom :math:`\nu` of the chi-square law of `statistic`
        under a true hypothesis. Default 1.
    p_false_reject : float or array_like, optional
        :math:`P_{\text{lo}}` in (0, 1). Default 0.01.

    Returns
    -------
    bool or numpy.ndarray of bool
        ``statistic < gate_threshold(p_false_reject, dof)``, broadcast. For a
        fixed statistic the decision is monotone: a larger `p_false_reject`
        (a smaller gate) never accepts what a smaller one rejects.

    Raises
    ------
    ValueError
        If `statistic` is negative or not finite, the shapes do not broadcast,
        or the other arguments are invalid (see :func:`gate_threshold`).

    Notes
    -----
    The paper's rule: :math:`\kappa_k^* < \gamma` — the hypothesis is taken as
    true; :math:`\kappa_k^* > \gamma` — it is rejected. (Equality has
    probability zero.)

    Examples
    --------
    >>> in_gate([1.0, 7.0], 1, 0.01)
    array([ True, False])
    """
    k = as_positive(statistic, "statistic", strict=False)
    p = as_probability(p_false_reject, "p_false_reject")
    m = _as_dof(dof)
    k, m, p = broadcast(statistic=k, dof=m, p_false_reject=p)
    return unwrap(k < gate_threshold(p, m))


def p_false_accept(noncentrality, dof=1, p_false_reject=0.01):
    r"""Probability that a false hypothesis passes the gate.

    Parameters
    ----------
    noncentrality : float or array_like
        :math:`\lambda \ge 0`, the noncentrality of the proximity measure under
        the false hypothesis (for scalars, :math:`\lambda = (x_1 - x_2)^2/
        (\sigma_1^2 + \sigma_2^2)` with the two objects' true positions).
    dof : int or array_like of int, optional
        Degrees of freedom :math:`\nu`. Default 1.
    p_false_reject : float or array_like, optional
        :math:`P_{\text{lo}}` that sets the gate. Default 0.01.

    Returns
    -------
    float or numpy.ndarray
        :math:`P\{\chi'^2_\nu(\lambda) < \gamma\}`; the power of the gate
        against this false hypothesis is one minus it. At :math:`\lambda = 0` it
        equals :math:`1 - P_{\text{lo}}`. Correct (to about 1e-12 relative) down
        to the smallest double, and exactly 0 only below it.

    Raises
    ------
    ValueError
        If `noncentrality` is negative or not finite, the shapes do not
        broadcast, or the other arguments are invalid.

    Notes
    -----
    .. math::

        P_{\text{fa}}(\lambda) = F_{\chi'^2_\nu(\lambda)}(\gamma),
        \qquad \gamma = F^{-1}_{\chi^2_\nu}(1 - P_{\text{lo}}).

    It decreases monotonically in :math:`\lambda` — the paper's remark that
    false hypotheses with small :math:`\lambda` are accepted with high
    probability, the weakness of pointwise gating. scipy's ``ncx2.cdf`` is used
    where it is above 1e-200; below, the Poisson mixture
    :math:`\sum_j e^{-\lambda/2}(\lambda/2)^j/j!\; P(\nu/2 + j, \gamma/2)` is summed in the
    log domain over the terms that matter.

    References
    ----------
    Grachov & Korneev (2010), text after Fig. 1.

    Examples
    --------
    >>> round(p_false_accept(0.0, 1, 0.01), 6)
    0.99
    >>> round(p_false_accept(10.0, 1, 0.01), 4)
    0.2788
    >>> f"{p_false_accept(1000.0, 1, 0.01):.4e}"    # scipy's ncx2.cdf alone gives 0.0
    '8.4083e-186'
    """
    v = as_positive(noncentrality, "noncentrality", strict=False)
    p = as_probability(p_false_reject, "p_false_reject")
    m = _as_dof(dof)
    v, m, p = broadcast(noncentrality=v, dof=m, p_false_reject=p)
    th = np.asarray(gate_threshold(p, m))
    out = np.where(v > 0, 0.0, stats.chi2.cdf(th, m))
    pos = v > 0
    if np.any(pos):
        out[pos] = np.exp(_log_p_accept(th[pos], m[pos], v[pos]))
    return unwrap(out)


def required_noncentrality(p_accept, dof=1, p_false_reject=0.01, *, xtol=1e-10):
    r"""Noncentrality :math:`\lambda` at which a false hypothesis is accepted with probability `p_accept`.

    Parameters
    ----------
    p_accept : float or array_like
        Target false-acceptance probability, in :math:`(0, 1 - P_{\text{lo}})`
        (at :math:`\lambda = 0` the acceptance probability is already
        :math:`1 - P_{\text{lo}}`, and it only falls as :math:`\lambda` grows).
        Any positive double is allowed, down to the smallest subnormal.
    dof : int or array_like of int, optional
        Degrees of freedom :math:`\nu`. Default 1.
    p_false_reject : float or array_like, optional
        :math:`P_{\text{lo}}`. Default 0.01.
    xtol : float, optional
        Absolute tolerance on :math:`\lambda` for :func:`scipy.optimize.brentq`,
        finite and > 0.

    Returns
    -------
    float or numpy.ndarray
        The unique root :math:`\lambda^*` of :math:`P_{\text{fa}}(\lambda) =
        p_{\text{accept}}`.

    Raises
    ------
    ValueError
        If `p_accept` is not in :math:`(0, 1 - P_{\text{lo}})`, `xtol` is not
        positive and finite, the broadcast shape holds more than
        :data:`MAX_ROOTS` roots, or the other arguments are invalid.

    Notes
    -----
    :math:`P_{\text{fa}}(\lambda)` is continuous and strictly decreasing from
    :math:`1 - P_{\text{lo}}` at :math:`\lambda = 0` to 0, so the root is unique.
    The equation is solved as :math:`\ln P_{\text{fa}}(\lambda) = \ln
    p_{\text{accept}}` (log-domain tail, see :func:`p_false_accept`), bracketed
    by doubling an upper bound and found with Brent's method — so a target such
    as 1e-300 gets its own root instead of the constant where the CDF would
    underflow.

    Examples
    --------
    >>> v = required_noncentrality(0.05, 1, 0.01)
    >>> round(v, 3), round(p_false_accept(v, 1, 0.01), 6)
    (17.814, 0.05)
    >>> round(required_noncentrality(1e-300, 1, 0.01), 1)
    1570.0
    """
    pa = as_probability(p_accept, "p_accept")
    p = as_probability(p_false_reject, "p_false_reject")
    m = _as_dof(dof)
    tol = as_float(as_positive(xtol, "xtol"), "xtol")
    pa, m, p = broadcast(p_accept=pa, dof=m, p_false_reject=p)
    check_size(pa.size, MAX_ROOTS, what="roots (entries of the broadcast arguments)",
               alternative="a coarser grid of `p_accept` and interpolation")
    if np.any(pa >= 1 - p):
        raise ValueError(
            "`p_accept` must be below 1 - p_false_reject (the acceptance probability at "
            f"lambda = 0); received p_accept={describe(unwrap(pa))} with "
            f"p_false_reject={describe(unwrap(p))}"
        )
    out = np.empty(pa.shape)
    for idx in np.ndindex(pa.shape):
        th = gate_threshold(p[idx], m[idx])
        log_target = np.log(pa[idx])

        def f(v, th=th, idx=idx, log_target=log_target):
            if v <= 0:
                return np.log1p(-p[idx]) - log_target
            return _log_p_accept(th, m[idx], v)[()] - log_target

        hi = max(1.0, th)
        while f(hi) > 0:
            hi *= 2.0
        out[idx] = optimize.brentq(f, 0.0, hi, xtol=tol,
                                   rtol=4 * np.finfo(float).eps)
    return unwrap(out)


def _gate_options(return_statistic, p_false_reject, dof) -> float:
    """Validate the gates' shared options; the threshold of `p_false_reject` at `dof`."""
    if not isinstance(return_statistic, (bool, np.bool_)):
        raise TypeError(f"`return_statistic` must be a bool; received "
                        f"{describe(return_statistic)}")
    p = as_float(as_probability(p_false_reject, "p_false_reject"), "p_false_reject")
    return float(gate_threshold(p, dof))


def gate_mahalanobis(x1, x2, cov, *, p_false_reject=0.01, chunk_size=32768,
                        return_statistic=False):
    r"""Chunked squared-Mahalanobis distance and chi-square gate for pairs of positions.

    For ``N`` pairs of d-dimensional positions sharing one covariance
    :math:`S = \Sigma_1 + \Sigma_2`: :math:`\kappa = (\hat x_1 - \hat x_2)^T
    S^{-1} (\hat x_1 - \hat x_2)` (by
    :func:`radarfusion_ref.engine.linalg.mahalanobis_sq`'s kernel) and the gate
    decision :math:`\kappa < \gamma` with d degrees of freedom, chunk by chunk
    (a 2x2 closed form for d = 2, the plane of the book's scenes).

    Parameters
    ----------
    x1, x2 : array_like, shape (N, d)
        Paired reports of radar 1 and radar 2, whose differences lie within
        the numeric domain (magnitude at most
        :data:`radarfusion_ref.engine.validation.MAX_MAGNITUDE`).
    cov : array_like, shape (d, d)
        :math:`S`, obeying :func:`radarfusion_ref.engine.linalg.is_positive_definite`
        (for per-report covariances use :func:`gate_pairwise`).
    p_false_reject : float, optional
        :math:`P_{\text{lo}}` in (0, 1). Default 0.01.
    chunk_size : int, optional
        Pairs per chunk, from 1 to :data:`MAX_CHUNK` (2**20); work buffers hold
        ``chunk_size`` pairs, so memory beyond the inputs and the ``N``-byte
        result does not grow with ``N``. The result does not depend on it.
    return_statistic : bool, optional
        Also return :math:`\kappa` (an ``N``-float array).

    Returns
    -------
    numpy.ndarray of bool, shape (N,)
        Gate decisions; with ``return_statistic=True`` a tuple ``(accepted, kappa)``.

    Raises
    ------
    ValueError
        If the shapes are not ``(N, d)``, ``(N, d)``, ``(d, d)``, `cov` breaks
        the positive-definiteness rule, an entry is not finite or outside the
        numeric domain of :mod:`radarfusion_ref.engine.linalg` (checked chunk
        by chunk, the message names the chunk), or `chunk_size` is below 1 or
        above :data:`MAX_CHUNK` (checked before anything is allocated).
    TypeError
        If an argument is not numeric, `chunk_size` is not an integer, or
        `return_statistic` is not a bool.

    Examples
    --------
    >>> acc, k = gate_mahalanobis([[0.0, 0.0], [4.0, 0.0]], [[0.0, 1.0], [0.0, 0.0]],
    ...                           np.eye(2), return_statistic=True)
    >>> acc, k
    (array([ True, False]), array([ 1., 16.]))
    """
    a = as_float_array(x1, "x1", allow_nonfinite=True)
    b = as_float_array(x2, "x2", allow_nonfinite=True)
    if a.ndim != 2 or b.shape != a.shape or a.shape[1] < 1:
        raise ValueError(f"`x1` and `x2` must both have shape (N, d), d >= 1; received shapes "
                         f"{a.shape} and {b.shape}")
    d = a.shape[1]
    s = as_covariance(cov, "cov", dim=d)
    if s.ndim != 2:
        raise ValueError(f"`cov` must have shape ({d}, {d}); received shape {s.shape}")
    chunk = as_int(chunk_size, "chunk_size", minimum=1)
    check_size(chunk, MAX_CHUNK, what="pairs per chunk (`chunk_size`)",
               alternative=f"chunk_size <= {MAX_CHUNK} (memory does not grow with N anyway)")
    th = _gate_options(return_statistic, p_false_reject, d)
    n = a.shape[0]
    accepted = np.empty(n, dtype=bool)
    kappa = np.empty(n) if return_statistic else None
    work, buf = np.empty((d, min(chunk, n))), np.empty(min(chunk, n))
    for start in range(0, n, chunk):
        stop = min(start + chunk, n)
        pa, pb = a[start:stop], b[start:stop]
        with np.errstate(invalid="ignore", over="ignore"):
            delta = np.subtract(pa.T, pb.T, out=work[:, :stop - start])   # rows contiguous
            inside = np.min(delta) >= -MAX_MAGNITUDE and np.max(delta) <= MAX_MAGNITUDE
        if not inside:                               # NaN, inf or beyond the domain: name it
            names = f"x1[{start}:{stop}]", f"x2[{start}:{stop}]"
            for name, part in zip(names, (pa, pb), strict=True):
                as_float_array(part, name)
            check_domain(delta, " - ".join(names))
        kk = kappa[start:stop] if kappa is not None else buf[:stop - start]
        with np.errstate(under="ignore"):
            if d == 2:
                mahalanobis_sq_k2_kernel(delta, s, kk)
            else:
                kk[:] = mahalanobis_sq_kernel(delta.T, s, "`x1` - `x2`")
        np.less(kk, th, out=accepted[start:stop])
    return (accepted, kappa) if return_statistic else accepted


def gate_pairwise(x1, x2, cov1, cov2, *, p_false_reject=0.01, chunk_size=32768,
                     return_statistic=False):
    r"""Chi-square gate for every pair of two sets of reports, each with its own covariance.

    :math:`\kappa_{ij} = (\hat x_{1i} - \hat x_{2j})^T (\Sigma_{1i} + \Sigma_{2j})^{-1}
    (\hat x_{1i} - \hat x_{2j})` by
    :func:`radarfusion_ref.engine.linalg.mahalanobis_sq_pairwise`, then
    :math:`\kappa_{ij} < \gamma` (eq-gate).

    Parameters
    ----------
    x1, x2, cov1, cov2 : array_like
        As in :func:`radarfusion_ref.engine.linalg.mahalanobis_sq_pairwise`,
        with d-dimensional reports: shapes ``(..., n1, d)``, ``(..., n2, d)`` and
        one ``d x d`` covariance per report (or one shared); the gate has d degrees
        of freedom.
    p_false_reject : float, optional
        :math:`P_{\text{lo}}` in (0, 1). Default 0.01.
    chunk_size : int, optional
        Pairs per chunk of the kernel (at least 1).
    return_statistic : bool, optional
        Also return :math:`\kappa` (shape (..., n1, n2)).

    Returns
    -------
    numpy.ndarray of bool, shape (..., n1, n2)
        Gate decisions; with ``return_statistic=True`` a tuple ``(accepted, kappa)``.

    Raises
    ------
    ValueError, TypeError
        As :func:`radarfusion_ref.engine.linalg.mahalanobis_sq_pairwise`, or for a
        `p_false_reject` that is not a single number in (0, 1).

    Examples
    --------
    >>> eye = np.eye(2)
    >>> gate_pairwise([[0.0, 0.0], [9.0, 0.0]], [[1.0, 0.0]], [eye, eye], [eye])
    array([[ True],
           [False]])
    """
    a = as_float_array(x1, "x1", ndim_min=2)
    th = _gate_options(return_statistic, p_false_reject, a.shape[-1])
    kappa = mahalanobis_sq_pairwise(a, x2, cov1, cov2, chunk_size=chunk_size)
    accepted = kappa < th
    return (accepted, kappa) if return_statistic else accepted


# --------------------------------------------------------------------------- sparse gating
#: Bytes planned per candidate pair of :func:`gate_sparse` (indices, distances,
#: the kernel's inputs and the sparse result).
_SPARSE_PAIR_BYTES = 96


def gate_sparse(x1, x2, cov, *, p_false_reject=0.01):
    r"""The gated pairs of two sets of reports as a sparse matrix of :math:`\kappa_{ij}`.

    For a scene of :math:`n_1` and :math:`n_2` reports sharing one
    :math:`S = \Sigma_1 + \Sigma_2`, only the pairs inside the gate,
    :math:`\kappa_{ij} < \gamma` (eq-gate, d degrees of freedom), are found and
    scored — in time and memory that grow with the gated pairs, not with
    :math:`n_1 n_2`. The result is the input
    :func:`radarfusion_ref.engine.assignment.assign_two_lists` takes for a gated
    sparse assignment (a missing entry is a forbidden pair).

    Parameters
    ----------
    x1 : array_like, shape (n1, d)
        Radar 1's reports.
    x2 : array_like, shape (n2, d)
        Radar 2's reports.
    cov : array_like, shape (d, d)
        :math:`S`, symmetric positive definite.
    p_false_reject : float, optional
        :math:`P_{\text{lo}}` in (0, 1). Default 0.01.

    Returns
    -------
    scipy.sparse.csr_array, shape (n1, n2)
        :math:`\kappa_{ij}` stored for every pair with :math:`\kappa_{ij} <
        \gamma` (a :math:`\kappa` of exactly 0 is stored as an explicit 0).

    Raises
    ------
    ValueError
        If the shapes are not ``(n1, d)``, ``(n2, d)``, ``(d, d)``, an entry is
        not finite, `cov` is not symmetric positive definite, the whitened
        coordinates overflow, or the candidate pairs would exceed
        :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT` (counted before they
        are listed).
    TypeError
        If an argument is not numeric.

    Notes
    -----
    With :math:`S = L L^T`, :math:`\kappa_{ij} = \lVert L^{-1}\hat x_{1i} -
    L^{-1}\hat x_{2j}\rVert^2`: the gate is a ball of radius
    :math:`\sqrt\gamma` in whitened coordinates, so a k-d tree
    (:class:`scipy.spatial.cKDTree`) lists the candidates (radius enlarged by
    a relative 1e-9 against rounding), and :func:`gate_mahalanobis` scores
    them — the stored values and the gate decisions are bit for bit those of
    the dense kernel on all pairs.

    Examples
    --------
    >>> k = gate_sparse([[0.0, 0.0], [10.0, 0.0]], [[1.0, 0.0], [0.0, 0.5]], np.eye(2))
    >>> k.nnz, k.toarray()
    (2, array([[1.  , 0.25],
           [0.  , 0.  ]]))
    """
    from scipy.linalg import solve_triangular
    from scipy.sparse import csr_array
    from scipy.spatial import cKDTree

    a = as_float_array(x1, "x1")
    b = as_float_array(x2, "x2")
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != b.shape[1] or a.shape[1] < 1:
        raise ValueError(f"`x1` and `x2` must have shapes (n1, d) and (n2, d); received shapes "
                         f"{a.shape} and {b.shape}")
    check_domain(a, "x1")
    check_domain(b, "x2")
    d = a.shape[1]
    s = as_covariance(cov, "cov", dim=d)
    if s.ndim != 2:
        raise ValueError(f"`cov` must have shape ({d}, {d}); received shape {s.shape}")
    th = _gate_options(False, p_false_reject, d)
    p = float(p_false_reject)
    n1, n2 = a.shape[0], b.shape[0]
    if n1 == 0 or n2 == 0:
        return csr_array((n1, n2))
    L = np.linalg.cholesky(s)
    with np.errstate(over="ignore", invalid="ignore"):
        z1 = solve_triangular(L, a.T, lower=True).T
        z2 = solve_triangular(L, b.T, lower=True).T
    if not (np.isfinite(z1).all() and np.isfinite(z2).all()):
        raise ValueError("`x1`, `x2`: the whitened coordinates L^-1 x overflow the float range "
                         "against `cov`; rescale the coordinates (for example to km)")
    radius = np.sqrt(th) * (1.0 + 1e-9)
    t1, t2 = cKDTree(z1), cKDTree(z2)
    count = int(t1.count_neighbors(t2, radius))
    check_size(_SPARSE_PAIR_BYTES * count, MEMORY_LIMIT,
               what=f"bytes for {count} candidate pairs inside the gate",
               alternative="a smaller gate (smaller `p_false_reject` is a larger gate) or "
                           "fewer reports per call")
    found = t1.sparse_distance_matrix(t2, radius, output_type="ndarray")
    i, j = found["i"].astype(np.intp), found["j"].astype(np.intp)
    accepted, kappa = gate_mahalanobis(a[i], b[j], s, p_false_reject=p,
                                       return_statistic=True)
    return csr_array((kappa[accepted], (i[accepted], j[accepted])), shape=(n1, n2))
