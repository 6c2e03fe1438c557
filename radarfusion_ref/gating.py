"""Chi-square gating of association hypotheses.

A pointwise hypothesis :math:`G_k` ("report 1 and report 2 belong to one
object") is accepted when its proximity measure :math:`\\kappa` (a squared
Mahalanobis distance, see :mod:`radarfusion_ref.proximity`) falls below a gate
:math:`\\gamma`. Under a true hypothesis :math:`\\kappa \\sim \\chi^2_\\nu`; under a
false one :math:`\\kappa \\sim \\chi'^2_\\nu(\\lambda)`, a noncentral chi-square with
noncentrality :math:`\\lambda`. The gate is set from the probability
:math:`P_{\\text{lo}}` of falsely rejecting a true hypothesis (Grachov & Korneev
2010, text after eq. (7) and Fig. 1; the book's eq-gate):

.. math::

    P\\{\\chi^2_\\nu > \\gamma\\} = P_{\\text{lo}}.

The paper's :math:`\\kappa_{\\text{th}}`, :math:`m` and :math:`V` are the book's
:math:`\\gamma`, :math:`\\nu` and :math:`\\lambda`.

.. rubric:: Public functions

* :func:`gate_threshold` — :math:`\\gamma` from :math:`P_{\\text{lo}}` and the
  degrees of freedom;
* :func:`in_gate` — the accept/reject decision for observed statistics;
* :func:`p_false_accept` — the probability that a false hypothesis with
  noncentrality :math:`\\lambda` passes the gate (1 − power);
* :func:`required_noncentrality` — the :math:`\\lambda` a false hypothesis needs for
  its acceptance probability to drop to a target (root-finding in the log domain);
* :func:`gate_mahalanobis_2d` — the chunked, vectorized 2-D squared-Mahalanobis
  + gate kernel used by Monte-Carlo experiments and the benchmark;
* :func:`pairwise_mahalanobis_2d` and :func:`gate_pairwise_2d` — the chunked
  kernel for every pair of two sets of 2-D reports when each report carries its
  own covariance (polar reports, separated radars): :math:`\\kappa_{ij}` (and
  :math:`\\ln\\det(\\Sigma_{1i} + \\Sigma_{2j})`) or the gate decisions, batched over
  trials;
* :func:`gate_sparse_2d` — the gated pairs of a large scene (one shared
  covariance) as a sparse matrix of :math:`\\kappa`, found with a k-d tree in
  whitened coordinates: the input of a gated sparse assignment.

All functions broadcast over their array arguments.

.. rubric:: Numerical range and limits

* :func:`p_false_accept` is correct down to the smallest double: where
  scipy's noncentral chi-square CDF falls below 1e-200 (it underflows to 0
  near 1e-146), the probability is summed in the log domain as a Poisson
  mixture of regularised incomplete gamma functions, and where the bound
  :math:`P \\le \\Phi(\\sqrt\\gamma - \\sqrt\\lambda)` is below the smallest double
  the result is 0.
* :func:`required_noncentrality` solves :math:`\\ln P_{\\text{fa}}(\\lambda) =
  \\ln p`, so targets down to the smallest double have their true root instead
  of a clamped constant; it refuses more than :data:`MAX_ROOTS` roots per call.
* :func:`gate_mahalanobis_2d`, :func:`pairwise_mahalanobis_2d` and
  :func:`gate_pairwise_2d` refuse a `chunk_size` above :data:`MAX_CHUNK`
  before allocating their work buffers; the pairwise kernels also refuse a
  call whose result and per-report copies exceed
  :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT`, and covariances that are
  singular to working precision (determinant at most 1e-12 of the product of
  the variances, where :math:`\\kappa` would have no correct digit left).

.. rubric:: References

.. [1] V. M. Grachov, V. A. Korneev, "Method of combining radar information
   taking coordinate and feature measurements into account", Kharkiv Air
   Force University, 2010 — the gating rule after eq. (7), Fig. 1.
"""

from __future__ import annotations

import math

import numpy as np
from scipy import optimize, special, stats

from .engine._validation import (
    MEMORY_LIMIT,
    _describe,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    broadcast,
    check_size,
    unwrap,
)

__all__ = [
    "MAX_CHUNK",
    "MAX_ROOTS",
    "gate_mahalanobis_2d",
    "gate_pairwise_2d",
    "gate_sparse_2d",
    "gate_threshold",
    "in_gate",
    "p_false_accept",
    "pairwise_mahalanobis_2d",
    "required_noncentrality",
]

#: Largest `chunk_size` of :func:`gate_mahalanobis_2d`: 2**20 pairs, three
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
                        f"received {_describe(value)}")
    arr = as_float_array(value, name)
    if np.any(arr != np.round(arr)) or np.any(arr < 1):
        bad = arr[(arr != np.round(arr)) | (arr < 1)].ravel()[0]
        raise ValueError(
            f"`{name}` must be an integer >= 1 (or an array of them); received "
            f"{_describe(value)} (offending entry {bad:.6g})"
        )
    return arr


def _log_gammainc(a, x):
    """log P(a, x), the regularised lower incomplete gamma function, for arrays a > 0, x > 0.

    scipy's ``gammainc`` where it is above 1e-290; below, the series
    :math:`P(a, x) = x^a e^{-x}/\\Gamma(a + 1) \\sum_k x^k / ((a + 1)\\cdots(a + k))`
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
    """Gate :math:`\\gamma` for a given false-rejection probability (eq-gate).

    Parameters
    ----------
    p_false_reject : float or array_like
        :math:`P_{\\text{lo}}`, the probability of rejecting a true hypothesis,
        in the open interval (0, 1). The paper uses 0.01 and 0.005.
    dof : int or array_like of int, optional
        Degrees of freedom :math:`\\nu \\ge 1` of the chi-square law (1 for one
        scalar coordinate; :math:`d` for a :math:`d`-dimensional position;
        :math:`n` for the sum over the :math:`n` pairs of a joint hypothesis).

    Returns
    -------
    float or numpy.ndarray
        :math:`\\gamma`, broadcast over the arguments.

    Raises
    ------
    ValueError
        If `p_false_reject` is outside (0, 1) or `dof` is not an integer >= 1.
    TypeError
        If an argument is not numeric (bools and strings included).

    Notes
    -----
    The upper :math:`P_{\\text{lo}}` quantile of :math:`\\chi^2_\\nu`:

    .. math::

        \\gamma = F^{-1}_{\\chi^2_\\nu}(1 - P_{\\text{lo}}),

    computed with :func:`scipy.stats.chi2.isf` (accurate also for tiny
    :math:`P_{\\text{lo}}`, down to the smallest double).

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
    """Accept (``True``) or reject (``False``) hypotheses by the chi-square gate.

    Parameters
    ----------
    statistic : float or array_like
        Proximity measures :math:`\\kappa \\ge 0` (squared Mahalanobis distances).
    dof : int or array_like of int, optional
        Degrees of freedom :math:`\\nu` of the chi-square law of `statistic`
        under a true hypothesis. Default 1.
    p_false_reject : float or array_like, optional
        :math:`P_{\\text{lo}}` in (0, 1). Default 0.01.

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
    The paper's rule: :math:`\\kappa_k^* < \\gamma` — the hypothesis is taken as
    true; :math:`\\kappa_k^* > \\gamma` — it is rejected. (Equality has
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
    return unwrap(k < stats.chi2.isf(p, m))


def p_false_accept(noncentrality, dof=1, p_false_reject=0.01):
    """Probability that a false hypothesis passes the gate.

    Parameters
    ----------
    noncentrality : float or array_like
        :math:`\\lambda \\ge 0`, the noncentrality of the proximity measure under
        the false hypothesis (for scalars, :math:`\\lambda = (x_1 - x_2)^2/
        (\\sigma_1^2 + \\sigma_2^2)` with the two objects' true positions).
    dof : int or array_like of int, optional
        Degrees of freedom :math:`\\nu`. Default 1.
    p_false_reject : float or array_like, optional
        :math:`P_{\\text{lo}}` that sets the gate. Default 0.01.

    Returns
    -------
    float or numpy.ndarray
        :math:`P\\{\\chi'^2_\\nu(\\lambda) < \\gamma\\}`; the power of the gate
        against this false hypothesis is one minus it. At :math:`\\lambda = 0` it
        equals :math:`1 - P_{\\text{lo}}`. Correct (to about 1e-12 relative) down
        to the smallest double, and exactly 0 only below it.

    Raises
    ------
    ValueError
        If `noncentrality` is negative or not finite, the shapes do not
        broadcast, or the other arguments are invalid.

    Notes
    -----
    .. math::

        P_{\\text{fa}}(\\lambda) = F_{\\chi'^2_\\nu(\\lambda)}(\\gamma),
        \\qquad \\gamma = F^{-1}_{\\chi^2_\\nu}(1 - P_{\\text{lo}}).

    It decreases monotonically in :math:`\\lambda` — the paper's remark that
    false hypotheses with small :math:`\\lambda` are accepted with high
    probability, the weakness of pointwise gating. scipy's ``ncx2.cdf`` is used
    where it is above 1e-200; below, the Poisson mixture
    :math:`\\sum_j e^{-\\lambda/2}(\\lambda/2)^j/j!\\; P(\\nu/2 + j, \\gamma/2)` is summed in the
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
    th = stats.chi2.isf(p, m)
    out = np.where(v > 0, 0.0, stats.chi2.cdf(th, m))
    pos = v > 0
    if np.any(pos):
        out[pos] = np.exp(_log_p_accept(th[pos], m[pos], v[pos]))
    return unwrap(out)


def required_noncentrality(p_accept, dof=1, p_false_reject=0.01, *, xtol=1e-10):
    """Noncentrality :math:`\\lambda` at which a false hypothesis is accepted with probability `p_accept`.

    Parameters
    ----------
    p_accept : float or array_like
        Target false-acceptance probability, in :math:`(0, 1 - P_{\\text{lo}})`
        (at :math:`\\lambda = 0` the acceptance probability is already
        :math:`1 - P_{\\text{lo}}`, and it only falls as :math:`\\lambda` grows).
        Any positive double is allowed, down to the smallest subnormal.
    dof : int or array_like of int, optional
        Degrees of freedom :math:`\\nu`. Default 1.
    p_false_reject : float or array_like, optional
        :math:`P_{\\text{lo}}`. Default 0.01.
    xtol : float, optional
        Absolute tolerance on :math:`\\lambda` for :func:`scipy.optimize.brentq`,
        finite and > 0.

    Returns
    -------
    float or numpy.ndarray
        The unique root :math:`\\lambda^*` of :math:`P_{\\text{fa}}(\\lambda) =
        p_{\\text{accept}}`.

    Raises
    ------
    ValueError
        If `p_accept` is not in :math:`(0, 1 - P_{\\text{lo}})`, `xtol` is not
        positive and finite, the broadcast shape holds more than
        :data:`MAX_ROOTS` roots, or the other arguments are invalid.

    Notes
    -----
    :math:`P_{\\text{fa}}(\\lambda)` is continuous and strictly decreasing from
    :math:`1 - P_{\\text{lo}}` at :math:`\\lambda = 0` to 0, so the root is unique.
    The equation is solved as :math:`\\ln P_{\\text{fa}}(\\lambda) = \\ln
    p_{\\text{accept}}` (log-domain tail, see :func:`p_false_accept`), bracketed
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
    tol = float(as_positive(xtol, "xtol")) if np.ndim(xtol) == 0 else None
    if tol is None:
        raise ValueError(f"`xtol` must be a positive number; received {_describe(xtol)}")
    pa, m, p = broadcast(p_accept=pa, dof=m, p_false_reject=p)
    check_size(pa.size, MAX_ROOTS, what="roots (entries of the broadcast arguments)",
               alternative="a coarser grid of `p_accept` and interpolation")
    if np.any(pa >= 1 - p):
        raise ValueError(
            "`p_accept` must be below 1 - p_false_reject (the acceptance probability at "
            f"lambda = 0); received p_accept={_describe(unwrap(pa))} with "
            f"p_false_reject={_describe(unwrap(p))}"
        )
    out = np.empty(pa.shape)
    for idx in np.ndindex(pa.shape):
        th = stats.chi2.isf(p[idx], m[idx])
        log_target = np.log(pa[idx])

        def f(v, th=th, idx=idx, log_target=log_target):
            if v <= 0:
                return np.log1p(-p[idx]) - log_target
            return _log_p_accept(th, m[idx], v)[()] - log_target

        hi = max(1.0, th)
        while f(hi) > 0:
            hi *= 2.0
        out[idx] = optimize.brentq(f, 0.0, hi, xtol=tol, rtol=4 * np.finfo(float).eps)
    return unwrap(out)


def _gate_options(return_statistic, p_false_reject) -> float:
    """Validate the 2-D gate kernels' shared options; return the threshold for `p_false_reject`."""
    if not isinstance(return_statistic, (bool, np.bool_)):
        raise TypeError(f"`return_statistic` must be a bool; received "
                        f"{_describe(return_statistic)}")
    p = as_probability(p_false_reject, "p_false_reject")
    if p.ndim != 0:
        raise ValueError(f"`p_false_reject` must be a scalar; received {_describe(p)}")
    return float(stats.chi2.isf(p, 2))


def gate_mahalanobis_2d(x1, x2, cov, *, p_false_reject=0.01, chunk_size=32768,
                        return_statistic=False):
    """Chunked squared-Mahalanobis distance and chi-square gate for 2-D pairs.

    The fast kernel behind the chapter's Monte-Carlo runs and the benchmark:
    for ``N`` pairs of 2-D positions sharing one covariance
    :math:`S = \\Sigma_1 + \\Sigma_2`, compute :math:`\\kappa = (\\hat x_1 - \\hat x_2)^T
    S^{-1} (\\hat x_1 - \\hat x_2)` (through the Cholesky factor of :math:`S`, never
    an inverse) and the gate decision with 2 degrees of freedom.

    Parameters
    ----------
    x1, x2 : array_like, shape (N, 2)
        Paired reports of radar 1 and radar 2.
    cov : array_like, shape (2, 2)
        :math:`S`, symmetric positive definite (for per-pair covariances use
        :func:`radarfusion_ref.proximity.mahalanobis_sq`).
    p_false_reject : float, optional
        :math:`P_{\\text{lo}}` in (0, 1). Default 0.01.
    chunk_size : int, optional
        Pairs per chunk, from 1 to :data:`MAX_CHUNK` (2**20); work buffers hold
        ``chunk_size`` pairs, so memory beyond the inputs and the ``N``-byte
        result does not grow with ``N``. The result does not depend on it.
    return_statistic : bool, optional
        Also return :math:`\\kappa` (an ``N``-float array).

    Returns
    -------
    numpy.ndarray of bool, shape (N,)
        Gate decisions; with ``return_statistic=True`` a tuple ``(accepted, kappa)``.

    Raises
    ------
    ValueError
        If the shapes are not ``(N, 2)``, ``(N, 2)``, ``(2, 2)``, `cov` is not
        symmetric positive definite, an entry is not finite, `chunk_size` is
        below 1 or above :data:`MAX_CHUNK` (checked before anything is
        allocated), or a :math:`\\kappa` exceeds the largest double.
    TypeError
        If an argument is not numeric, `chunk_size` is not an integer, or
        `return_statistic` is not a bool.

    Notes
    -----
    With :math:`S = L L^T`, :math:`L = \\begin{pmatrix} l_{11} & 0 \\\\ l_{21} &
    l_{22}\\end{pmatrix}` and :math:`\\Delta = \\hat x_1 - \\hat x_2`:

    .. math::

        z_1 = \\Delta_1 / l_{11}, \\quad z_2 = (\\Delta_2 - l_{21} z_1)/l_{22},
        \\quad \\kappa = z_1^2 + z_2^2 .

    Each chunk is processed with in-place ufuncs into preallocated buffers,
    so the working set stays in cache, and the inputs are checked for NaN/inf
    chunk by chunk (through :math:`\\kappa`), so the only memory that grows with
    ``N`` is the 1-byte-per-pair result. A chunk whose :math:`\\kappa` overflows
    with finite inputs is recomputed with the scaled route of
    :func:`~radarfusion_ref.proximity.mahalanobis_sq`, which returns the correct
    value or refuses when :math:`\\kappa` itself exceeds the largest double.

    Examples
    --------
    >>> acc, k = gate_mahalanobis_2d([[0.0, 0.0], [4.0, 0.0]], [[0.0, 1.0], [0.0, 0.0]],
    ...                              np.eye(2), return_statistic=True)
    >>> acc, k
    (array([ True, False]), array([ 1., 16.]))
    """
    from .proximity import mahalanobis_sq

    # finiteness is checked chunk by chunk below, so no N-sized temporary is made here
    a = as_float_array(x1, "x1", last_dims=(None, 2), allow_nonfinite=True)
    b = as_float_array(x2, "x2", last_dims=(None, 2), allow_nonfinite=True)
    if a.ndim != 2 or b.shape != a.shape:
        raise ValueError(f"`x1` and `x2` must both have shape (N, 2); received shapes "
                         f"{a.shape} and {b.shape}")
    s = as_covariance(cov, "cov", dim=2)
    if s.ndim != 2:
        raise ValueError(f"`cov` must have shape (2, 2); received shape {s.shape}")
    chunk = as_int(chunk_size, "chunk_size", minimum=1)
    check_size(chunk, MAX_CHUNK, what="pairs per chunk (`chunk_size`)",
               alternative=f"chunk_size <= {MAX_CHUNK} (memory does not grow with N anyway)")
    th = _gate_options(return_statistic, p_false_reject)
    L = np.linalg.cholesky(s)
    inv_l11, l21, inv_l22 = 1.0 / L[0, 0], L[1, 0], 1.0 / L[1, 1]
    n = a.shape[0]
    accepted = np.empty(n, dtype=bool)
    kappa = np.empty(n) if return_statistic else None
    z1 = np.empty(chunk)
    z2 = np.empty(chunk)
    k = np.empty(chunk)
    with np.errstate(invalid="ignore", over="ignore"):
        for start in range(0, n, chunk):
            stop = min(start + chunk, n)
            m = stop - start
            u, w, kk = z1[:m], z2[:m], k[:m]
            np.subtract(a[start:stop, 0], b[start:stop, 0], out=u)
            np.subtract(a[start:stop, 1], b[start:stop, 1], out=w)
            u *= inv_l11                      # z1 = d1 / l11
            np.multiply(u, l21, out=kk)       # w = (d2 - l21 z1) / l22
            w -= kk
            w *= inv_l22
            np.multiply(u, u, out=kk)         # kappa = z1^2 + z2^2
            w *= w
            kk += w
            if not np.isfinite(kk).all():     # NaN/inf in an input makes kappa non-finite
                for name, arr in (("x1", a), ("x2", b)):
                    as_float_array(arr[start:stop], f"{name}[{start}:{stop}]")
                # finite inputs: an intermediate overflowed; the scaled route is exact or refuses
                kk[:] = mahalanobis_sq(a[start:stop], b[start:stop], 0.5 * s, 0.5 * s)
            np.less(kk, th, out=accepted[start:stop])
            if kappa is not None:
                kappa[start:stop] = kk
    return (accepted, kappa) if return_statistic else accepted


# --------------------------------------------------------------------------- per-report covariances
#: Default pairs per chunk of the pairwise kernels: six work buffers of 512 KiB.
_PAIR_CHUNK = 65536
#: Below this determinant / (product of the variances) a 2x2 covariance is singular
#: to working precision (kappa would carry no correct digit); the same floor as
#: :func:`radarfusion_ref.separated.pair_statistic`.
_SINGULAR = 1e-12
#: The fast route runs unscaled while every variance lies in [2**-900, 2**900] and
#: every coordinate below 2**900 (no intermediate can underflow to a subnormal);
#: outside, every pair takes the exactly scaled route of ``mahalanobis_sq``.
_SAFE_EXP = 900


def _report_ok(a, b, b2, d):
    """Closed-form 2x2 test per report: (symmetric, positive definite and not singular)."""
    with np.errstate(all="ignore"):
        if b2 is None or np.array_equal(b, b2):     # None: symmetry checked already
            sym = np.True_
        else:
            top = np.maximum(np.maximum(np.abs(a), np.abs(d)), np.abs(b))
            sym = ~(np.abs(b - b2) > 1e-9 * np.maximum(top, np.finfo(float).tiny))
        r = b / a
        r *= b                                       # b^2 / a <= d when valid: no overflow
        pd = (a > 0) & (d - r > _SINGULAR * d)       # l22^2 > 1e-12 d, false for NaN
    return sym, pd


def _refuse_covs(c: np.ndarray, name: str) -> None:
    """Raise the full message for a stack of report covariances that failed the test."""
    sym, pd = _report_ok(c[..., 0, 0], c[..., 0, 1], c[..., 1, 0], c[..., 1, 1])
    if not sym.all():
        raise ValueError(f"`{name}` must be symmetric; received {_describe(c)}")
    if not pd.all():
        bad = int(pd.size - np.count_nonzero(pd))
        raise ValueError(
            f"`{name}` must be positive definite and not singular to working precision "
            f"(determinant above {_SINGULAR:g} of the product of the variances); "
            f"{bad} of {pd.size} matrices are not: {_describe(c)}")


def _pairwise_iv(x1, x2, cov1, cov2, chunk_size, out_bytes):
    """Validate the pairwise kernels' shapes and sizes (covariances are tested per chunk)."""
    a = as_float_array(x1, "x1", ndim_min=2, last_dims=(None, 2))
    b = as_float_array(x2, "x2", ndim_min=2, last_dims=(None, 2))
    c1 = as_float_array(cov1, "cov1", ndim_min=3, last_dims=(None, 2, 2))
    c2 = as_float_array(cov2, "cov2", ndim_min=3, last_dims=(None, 2, 2))
    n1, n2 = a.shape[-2], b.shape[-2]
    for name, c, n, xname in (("cov1", c1, n1, "x1"), ("cov2", c2, n2, "x2")):
        if c.shape[-3] not in (1, n):
            raise ValueError(f"`{name}` must hold one 2x2 matrix per report of `{xname}` "
                             f"(shape (..., {n}, 2, 2)); received shape {c.shape}")
    try:
        lead = np.broadcast_shapes(a.shape[:-2], b.shape[:-2], c1.shape[:-3], c2.shape[:-3])
    except ValueError:
        raise ValueError("`x1`, `x2`, `cov1`, `cov2` must have broadcastable leading (batch) "
                         f"axes; received shapes {a.shape}, {b.shape}, {c1.shape}, "
                         f"{c2.shape}") from None
    chunk = as_int(chunk_size, "chunk_size", minimum=1)
    check_size(chunk, MAX_CHUNK, what="pairs per chunk (`chunk_size`)",
               alternative=f"chunk_size <= {MAX_CHUNK} (the work buffers do not grow with "
                           "the number of pairs anyway)")
    n_lead = math.prod(lead)
    n_pairs = n_lead * n1 * n2
    planned = (n_pairs * out_bytes                     # the result
               + 6 * 8 * n_lead * (n1 + n2)           # per-report component copies (at most)
               + 19 * 8 * min(chunk, n_pairs))        # work and per-chunk report buffers
    check_size(planned, MEMORY_LIMIT,
               what=f"bytes for {n_pairs} pairs of `x1` x `x2` (result, per-report copies "
                    "and work buffers)",
               alternative="smaller batches of trials (split the leading axes of `x1`, `x2`)")
    return a, b, c1, c2, lead, chunk


def _report_parts(x, c, lead, n):
    """Six (L, n) per-report views: x, y, var_x, cov_xy, cov_yx, var_y."""
    n_lead = math.prod(lead)
    return [np.broadcast_to(part, (*lead, n)).reshape(n_lead, n)
            for part in (x[..., 0], x[..., 1], c[..., 0, 0], c[..., 0, 1], c[..., 1, 0],
                         c[..., 1, 1])]


def _tiles(lengths, chunk):
    """Blocks (slices per axis, outer to inner) of at most `chunk` elements.

    Whole outer and middle axes when the inner run can still be long (at least
    256 elements, so each ufunc call streams), else shorter inner runs.
    """
    outer, mid, inner = lengths
    bi = min(inner, chunk, max(256, chunk // (outer * mid)))
    bm = max(1, min(mid, chunk // bi))
    bo = max(1, min(outer, chunk // (bi * bm)))
    for o0 in range(0, outer, bo):
        for m0 in range(0, mid, bm):
            for i0 in range(0, inner, bi):
                yield (slice(o0, min(o0 + bo, outer)), slice(m0, min(m0 + bm, mid)),
                       slice(i0, min(i0 + bi, inner)))


def _scaled_pairs(xa, ca, xb, cb):
    """kappa and ln det of paired reports by the exactly scaled route (or a clear refusal)."""
    from .proximity import _pow2_scale, mahalanobis_sq

    try:
        kappa = np.atleast_1d(mahalanobis_sq(xa, xb, ca, cb))
    except ValueError:
        raise ValueError(
            "`x1`, `x2`: the statistic kappa overflows the float range (it exceeds the largest "
            "double, about 1.8e308): the reports differ by more than ~1.3e154 standard "
            "deviations; rescale the coordinates or the covariances") from None
    scale = _pow2_scale(ca, cb)
    s = ca / scale[:, None, None] + cb / scale[:, None, None]
    l21 = s[:, 0, 1] / np.sqrt(s[:, 0, 0])
    logdet = np.log(s[:, 0, 0]) + np.log(s[:, 1, 1] - l21 * l21) + 2.0 * np.log(scale)
    return kappa, logdet


def _chol_block(pv, qv, work, kk, ld):
    """kappa (and ln det) of one block, in place; False if a kappa is not finite.

    The operation sequence of ``separated._chol_quadratic``, so results agree
    bit for bit: S = L L^T, l11 = sqrt(a), l21 = b / l11, l22 = sqrt(c - l21^2),
    z = L^-1 d, kappa = z1^2 + z2^2, ln det S = ln a + ln l22^2.
    """
    va, vb, vc, d0, d1, t = work
    np.add(pv[2], qv[2], out=va)
    np.add(pv[3], qv[3], out=vb)
    np.add(pv[5], qv[5], out=vc)
    if ld is not None:
        np.log(va, out=ld)
    np.sqrt(va, out=va)                      # l11
    np.divide(vb, va, out=vb)                # l21
    np.multiply(vb, vb, out=t)
    np.subtract(vc, t, out=vc)               # l22^2
    if ld is not None:
        np.log(vc, out=t)
        ld += t
    np.sqrt(vc, out=vc)                      # l22
    with np.errstate(over="ignore", invalid="ignore"):
        np.subtract(pv[0], qv[0], out=d0)
        np.divide(d0, va, out=d0)            # z1
        np.subtract(pv[1], qv[1], out=d1)
        np.multiply(vb, d0, out=t)
        np.subtract(d1, t, out=d1)
        np.divide(d1, vc, out=d1)            # z2
        np.multiply(d0, d0, out=kk)
        np.multiply(d1, d1, out=d1)
        np.add(kk, d1, out=kk)
    return bool(np.max(kk) < np.inf)         # False for an overflow or a NaN


def _ldl_block(pv, qv, work, kk):
    """kappa of one block by the square-root-free factorisation S = L D L^T, in place.

    With u = s12 / s11, l = s22 - u s12 (the Schur complement) and w = d1 - u d0:
    kappa = d0^2 / s11 + w^2 / l — no square root (a numpy square root costs
    several multiplications), the same rounding class as the Cholesky route.
    Returns False if a kappa is not finite.
    """
    va, vb, vc, d0, d1, t = work
    np.add(pv[2], qv[2], out=va)
    np.add(pv[3], qv[3], out=vb)
    np.add(pv[5], qv[5], out=vc)
    np.divide(vb, va, out=t)                 # u
    np.multiply(t, vb, out=vb)
    np.subtract(vc, vb, out=vc)              # l = s22 - u s12
    with np.errstate(over="ignore", invalid="ignore"):
        np.subtract(pv[0], qv[0], out=d0)
        np.subtract(pv[1], qv[1], out=d1)
        np.multiply(t, d0, out=vb)
        np.subtract(d1, vb, out=d1)          # w
        np.multiply(d0, d0, out=d0)
        np.divide(d0, va, out=d0)
        np.multiply(d1, d1, out=d1)
        np.divide(d1, vc, out=d1)
        np.add(d0, d1, out=kk)
    return bool(np.max(kk) < np.inf)


def _pairwise_run(a, b, c1, c2, lead, chunk, *, threshold=None, want_kappa=True,
                  want_logdet=False, ldl=False):
    """The chunked kernel; returns (kappa | None, logdet | None, accepted | None)."""
    n1, n2 = a.shape[-2], b.shape[-2]
    n_lead = math.prod(lead)
    if n1 * n2 * n_lead == 0:                        # no pairs: empty results
        def empty(wanted, dtype=float):
            return np.empty((*lead, n1, n2), dtype=dtype) if wanted else None

        return empty(want_kappa), empty(want_logdet), empty(threshold is not None, bool)
    # The longest axis innermost: with many small scenes (a Monte-Carlo layout) the
    # trials, and each chunk's reports are gathered into small contiguous buffers
    # (a cache-sized transpose); with few large scenes the radar-2 reports.
    trial_last = n_lead > 1 and n_lead >= n2
    p = _report_parts(a, c1, lead, n1)
    q = _report_parts(b, c2, lead, n2)
    for c, name in ((c1, "cov1"), (c2, "cov2")):
        if not np.array_equal(c[..., 0, 1], c[..., 1, 0]):
            sym, _ = _report_ok(c[..., 0, 0], c[..., 0, 1], c[..., 1, 0], c[..., 1, 1])
            if not sym.all():
                _refuse_covs(c, name)
    if not trial_last:
        p = [np.ascontiguousarray(v) for v in p]
        q = [np.ascontiguousarray(v) for v in q]
        for parts, c, name in ((p, c1, "cov1"), (q, c2, "cov2")):
            sym, pd = _report_ok(parts[2], parts[3], parts[4], parts[5])
            if not (sym.all() and pd.all()):
                _refuse_covs(c, name)
    big = 2.0 ** _SAFE_EXP
    with np.errstate(invalid="ignore"):
        fast = all(float(np.max(np.abs(v))) < big for v in (a, b)) and all(
            big > float(np.max(v)) and float(np.min(v)) > 1.0 / big
            for v in (c1[..., 0, 0], c1[..., 1, 1], c2[..., 0, 0], c2[..., 1, 1]))
    shape = (n1, n2, n_lead) if trial_last else (n_lead, n1, n2)
    kappa = np.empty(shape) if want_kappa else None
    logdet = np.empty(shape) if want_logdet else None
    accepted = np.empty(shape, dtype=bool) if threshold is not None else None
    size = min(chunk, n1 * n2 * n_lead)
    work = [np.empty(size) for _ in range(7)]
    gather = [np.empty(size) for _ in range(12)] if trial_last else None
    for blk in _tiles(shape, chunk):
        bshape = tuple(s.stop - s.start for s in blk)
        k = math.prod(bshape)
        wv = [x[:k].reshape(bshape) for x in work]
        if trial_last:
            si, sj, st = blk
            m = st.stop - st.start
            pv, qv = [], []
            for parts, s_rep, out, c, name in ((p, si, pv, c1, "cov1"),
                                               (q, sj, qv, c2, "cov2")):
                nr = s_rep.stop - s_rep.start
                base = 0 if out is pv else 6
                for r, v in enumerate(parts):
                    if r == 4:                       # cov_yx: symmetry is checked already
                        out.append(out[3])
                        continue
                    g = gather[base + r][:nr * m].reshape(nr, m)
                    np.copyto(g, v[st, s_rep].T)
                    out.append(g)
                sym, pd = _report_ok(out[2], out[3], None, out[5])
                if not (sym.all() and pd.all()):
                    _refuse_covs(c, name)
            pv = [v[:, None, :] for v in pv]
            qv = [v[None, :, :] for v in qv]
        else:
            st, si, sj = blk
            pv = [v[st, si, None] for v in p]
            qv = [v[st, None, sj] for v in q]
        kk = kappa[blk] if kappa is not None else wv[6]
        ld = logdet[blk] if logdet is not None else None
        if fast and (_ldl_block(pv, qv, wv[:6], kk) if ldl
                     else _chol_block(pv, qv, wv[:6], kk, ld)):
            redo = None
        elif fast:
            redo = np.nonzero(~np.isfinite(kk))
        else:
            redo = np.nonzero(np.ones(bshape, dtype=bool))
        if redo is not None:
            # the pairs' own per-report values, by broadcasting the block's operands
            def take(v, redo=redo, bshape=bshape):
                return np.broadcast_to(v, bshape)[redo]

            def stack(parts):
                x = np.stack([take(parts[0]), take(parts[1])], axis=-1)
                cv = np.empty((x.shape[0], 2, 2))
                cv[:, 0, 0], cv[:, 0, 1] = take(parts[2]), take(parts[3])
                cv[:, 1, 0], cv[:, 1, 1] = take(parts[3]), take(parts[5])
                return x, cv

            if not fast:
                for parts, c, name in ((pv, c1, "cov1"), (qv, c2, "cov2")):
                    sym, pd = _report_ok(parts[2], parts[3], parts[4], parts[5])
                    if not (sym.all() and pd.all()):
                        _refuse_covs(c, name)
            kr, lr = _scaled_pairs(*stack(pv), *stack(qv))
            kk[redo] = kr
            if ld is not None:
                ld[redo] = lr
        if accepted is not None:
            np.less(kk, threshold, out=accepted[blk])

    def back(arr):
        if arr is None:
            return None
        moved = np.moveaxis(arr, -1, 0) if trial_last else arr
        return moved.reshape(*lead, n1, n2)

    return back(kappa), back(logdet), back(accepted)


def pairwise_mahalanobis_2d(x1, x2, cov1, cov2, *, chunk_size=_PAIR_CHUNK,
                            return_logdet=False):
    """Squared Mahalanobis distance of every pair of 2-D reports, each with its own covariance.

    The per-report-covariance counterpart of :func:`gate_mahalanobis_2d`, for
    polar reports and separated radars: for report :math:`i` of radar 1 and
    report :math:`j` of radar 2, with :math:`S_{ij} = \\Sigma_{1i} + \\Sigma_{2j}`,

    .. math::

        \\kappa_{ij} = (\\hat x_{1i} - \\hat x_{2j})^T S_{ij}^{-1} (\\hat x_{1i} - \\hat x_{2j}),

    for all :math:`n_1 n_2` pairs, batched over leading (trial) axes, in chunks.

    Parameters
    ----------
    x1 : array_like, shape (..., n1, 2)
        Radar 1's reports.
    x2 : array_like, shape (..., n2, 2)
        Radar 2's reports in the same frame.
    cov1 : array_like, shape (..., n1, 2, 2) or (..., 1, 2, 2)
        One covariance per report of `x1` (a size-1 report axis is shared),
        symmetric positive definite and not singular to working precision.
    cov2 : array_like, shape (..., n2, 2, 2) or (..., 1, 2, 2)
        The same for `x2`.
    chunk_size : int, optional
        Pairs per chunk, from 1 to :data:`MAX_CHUNK`. The work buffers hold
        ``chunk_size`` pairs; the result does not depend on it (bit for bit).
    return_logdet : bool, optional
        Also return :math:`\\ln\\det S_{ij}`, the term the full ML cost adds.

    Returns
    -------
    numpy.ndarray, shape (..., n1, n2)
        :math:`\\kappa_{ij}`; the leading axes are the broadcast of the four
        arguments' leading axes. With ``return_logdet=True`` a tuple
        ``(kappa, logdet)``. When the batch is larger than `n2`, the result is
        stored trial axis last (a transposed view; values are the same).

    Raises
    ------
    ValueError
        If the shapes do not match, an entry is not finite, a covariance is
        not symmetric, not positive definite or singular to working precision
        (no reports on one side is allowed: the result is empty),
        `chunk_size` is outside [1, :data:`MAX_CHUNK`], the result would exceed
        :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT` (both checked before
        any allocation that grows with the pairs), or a :math:`\\kappa`
        overflows the largest double.
    TypeError
        If an argument is not numeric, `chunk_size` is not an integer or
        `return_logdet` is not a bool.

    Notes
    -----
    Each pair's :math:`S_{ij}` is factored in closed form, :math:`S = L L^T`,
    :math:`l_{11} = \\sqrt{s_{11}}`, :math:`l_{21} = s_{12}/l_{11}`,
    :math:`l_{22} = \\sqrt{s_{22} - l_{21}^2}`, and :math:`z = L^{-1}\\Delta` by
    forward substitution, :math:`\\kappa = z_1^2 + z_2^2`, :math:`\\ln\\det S =
    \\ln s_{11} + \\ln l_{22}^2` — no inverse, no per-pair temporary array beyond
    the chunk: each chunk is a handful of in-place ufuncs over preallocated
    buffers, with the longest axis (the trials, in a Monte-Carlo layout)
    innermost. The operation sequence is that of
    :func:`radarfusion_ref.separated.pair_statistic`, so the two agree bit for
    bit. A singular-to-working-precision report covariance is refused, which
    guarantees every sum :math:`S_{ij}` factors (the correlation coefficient of a
    sum of two covariances is at most the larger of theirs). Pairs whose
    :math:`\\kappa` overflows, and every pair when a variance or coordinate lies
    beyond :math:`2^{\\pm 900}`, take the exactly scaled route of
    :func:`radarfusion_ref.proximity.mahalanobis_sq`.

    Examples
    --------
    >>> eye = np.eye(2)
    >>> pairwise_mahalanobis_2d([[0.0, 0.0], [1.0, 0.0]], [[2.0, 0.0]], [eye, 3 * eye], [eye])
    array([[2.  ],
           [0.25]])
    """
    if not isinstance(return_logdet, (bool, np.bool_)):
        raise TypeError(f"`return_logdet` must be a bool; received {_describe(return_logdet)}")
    a, b, c1, c2, lead, chunk = _pairwise_iv(x1, x2, cov1, cov2, chunk_size,
                                             16 if return_logdet else 8)
    kappa, logdet, _ = _pairwise_run(a, b, c1, c2, lead, chunk, want_logdet=bool(return_logdet))
    return (kappa, logdet) if return_logdet else kappa


def gate_pairwise_2d(x1, x2, cov1, cov2, *, p_false_reject=0.01, chunk_size=_PAIR_CHUNK,
                     return_statistic=False):
    """Chi-square gate (2 degrees of freedom) for every pair of 2-D reports with own covariances.

    :math:`\\kappa_{ij}` as in :func:`pairwise_mahalanobis_2d`, then
    :math:`\\kappa_{ij} < \\gamma` (eq-gate), without storing :math:`\\kappa`
    unless asked: the result is one byte per pair. For speed the statistic is
    computed by the square-root-free factorisation :math:`S = L D L^T`,

    .. math::

        u = s_{12}/s_{11}, \\quad l = s_{22} - u s_{12}, \\quad
        \\kappa = \\frac{\\Delta_1^2}{s_{11}} + \\frac{(\\Delta_2 - u\\Delta_1)^2}{l},

    (no per-pair square root, which costs several multiplications in numpy);
    it agrees with :func:`pairwise_mahalanobis_2d` to rounding (a few units of
    :math:`\\varepsilon\\,\\mathrm{cond}(S)` relative), so decisions can differ only
    for a :math:`\\kappa` within that distance of :math:`\\gamma`.

    Parameters
    ----------
    x1, x2, cov1, cov2 : array_like
        As in :func:`pairwise_mahalanobis_2d`.
    p_false_reject : float, optional
        :math:`P_{\\text{lo}}` in (0, 1). Default 0.01.
    chunk_size : int, optional
        Pairs per chunk, from 1 to :data:`MAX_CHUNK`.
    return_statistic : bool, optional
        Also return :math:`\\kappa` (shape (..., n1, n2)).

    Returns
    -------
    numpy.ndarray of bool, shape (..., n1, n2)
        Gate decisions; with ``return_statistic=True`` a tuple ``(accepted, kappa)``.

    Raises
    ------
    ValueError, TypeError
        As :func:`pairwise_mahalanobis_2d`, or for a `p_false_reject` that is
        not a single number in (0, 1).

    Examples
    --------
    >>> eye = np.eye(2)
    >>> gate_pairwise_2d([[0.0, 0.0], [9.0, 0.0]], [[1.0, 0.0]], [eye, eye], [eye])
    array([[ True],
           [False]])
    """
    th = _gate_options(return_statistic, p_false_reject)
    a, b, c1, c2, lead, chunk = _pairwise_iv(x1, x2, cov1, cov2, chunk_size,
                                             9 if return_statistic else 1)
    kappa, _, accepted = _pairwise_run(a, b, c1, c2, lead, chunk, threshold=th,
                                       want_kappa=bool(return_statistic), ldl=True)
    return (accepted, kappa) if return_statistic else accepted


# --------------------------------------------------------------------------- sparse gating
#: Bytes planned per candidate pair of :func:`gate_sparse_2d` (indices, distances,
#: the kernel's inputs and the sparse result).
_SPARSE_PAIR_BYTES = 96


def gate_sparse_2d(x1, x2, cov, *, p_false_reject=0.01):
    """The gated pairs of two sets of 2-D reports as a sparse matrix of :math:`\\kappa_{ij}`.

    For a scene of :math:`n_1` and :math:`n_2` reports sharing one
    :math:`S = \\Sigma_1 + \\Sigma_2`, only the pairs inside the gate,
    :math:`\\kappa_{ij} < \\gamma` (eq-gate, 2 degrees of freedom), are found and
    scored — in time and memory that grow with the gated pairs, not with
    :math:`n_1 n_2`. The result is the input
    :func:`radarfusion_ref.association.associate_joint` takes for a gated
    sparse assignment (a missing entry is a forbidden pair).

    Parameters
    ----------
    x1 : array_like, shape (n1, 2)
        Radar 1's reports.
    x2 : array_like, shape (n2, 2)
        Radar 2's reports.
    cov : array_like, shape (2, 2)
        :math:`S`, symmetric positive definite.
    p_false_reject : float, optional
        :math:`P_{\\text{lo}}` in (0, 1). Default 0.01.

    Returns
    -------
    scipy.sparse.csr_array, shape (n1, n2)
        :math:`\\kappa_{ij}` stored for every pair with :math:`\\kappa_{ij} <
        \\gamma` (a :math:`\\kappa` of exactly 0 is stored as an explicit 0).

    Raises
    ------
    ValueError
        If the shapes are not ``(n1, 2)``, ``(n2, 2)``, ``(2, 2)``, an entry is
        not finite, `cov` is not symmetric positive definite, the whitened
        coordinates overflow, or the candidate pairs would exceed
        :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT` (counted before they
        are listed).
    TypeError
        If an argument is not numeric.

    Notes
    -----
    With :math:`S = L L^T`, :math:`\\kappa_{ij} = \\lVert L^{-1}\\hat x_{1i} -
    L^{-1}\\hat x_{2j}\\rVert^2`: the gate is a disc of radius
    :math:`\\sqrt\\gamma` in whitened coordinates, so a k-d tree
    (:class:`scipy.spatial.cKDTree`) lists the candidates (radius enlarged by
    a relative 1e-9 against rounding), and :func:`gate_mahalanobis_2d` scores
    them — the stored values and the gate decisions are bit for bit those of
    the dense kernel on all pairs.

    Examples
    --------
    >>> k = gate_sparse_2d([[0.0, 0.0], [10.0, 0.0]], [[1.0, 0.0], [0.0, 0.5]], np.eye(2))
    >>> k.nnz, k.toarray()
    (2, array([[1.  , 0.25],
           [0.  , 0.  ]]))
    """
    from scipy.linalg import solve_triangular
    from scipy.sparse import csr_array
    from scipy.spatial import cKDTree

    a = as_float_array(x1, "x1", last_dims=(None, 2))
    b = as_float_array(x2, "x2", last_dims=(None, 2))
    if a.ndim != 2 or b.ndim != 2:
        raise ValueError(f"`x1` and `x2` must have shapes (n1, 2) and (n2, 2); received shapes "
                         f"{a.shape} and {b.shape}")
    s = as_covariance(cov, "cov", dim=2)
    if s.ndim != 2:
        raise ValueError(f"`cov` must have shape (2, 2); received shape {s.shape}")
    p = as_probability(p_false_reject, "p_false_reject")
    if p.ndim != 0:
        raise ValueError(f"`p_false_reject` must be a scalar; received {_describe(p)}")
    th = float(stats.chi2.isf(p, 2))
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
    accepted, kappa = gate_mahalanobis_2d(a[i], b[j], s, p_false_reject=float(p),
                                          return_statistic=True)
    return csr_array((kappa[accepted], (i[accepted], j[accepted])), shape=(n1, n2))
