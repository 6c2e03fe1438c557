"""Chi-square gating of association hypotheses.

A pointwise hypothesis :math:`G_k` ("report 1 and report 2 belong to one
object") is accepted when its proximity measure :math:`\\kappa` (a squared
Mahalanobis distance, see :mod:`radarfusion_ref.proximity`) falls below a gate
:math:`\\kappa_{\\text{th}}`. Under a true hypothesis :math:`\\kappa \\sim
\\chi^2(m)`; under a false one :math:`\\kappa \\sim \\chi'^2(m, V)`, a
noncentral chi-square with noncentrality :math:`V`. The gate is set from the
probability :math:`P_{\\text{lo}}` of falsely rejecting a true hypothesis
(Grachov & Korneev 2010, text after eq. (7) and Fig. 1):

.. math::

    P\\{\\chi^2(m) > \\kappa_{\\text{th}}\\} = P_{\\text{lo}}.

.. rubric:: Public functions

* :func:`gate_threshold` — :math:`\\kappa_{\\text{th}}` from :math:`P_{\\text{lo}}` and the
  degrees of freedom;
* :func:`in_gate` — the accept/reject decision for observed statistics;
* :func:`p_false_accept` — the probability that a false hypothesis with
  noncentrality :math:`V` passes the gate (1 − power);
* :func:`required_noncentrality` — the :math:`V` a false hypothesis needs for its
  acceptance probability to drop to a target (root-finding);
* :func:`gate_mahalanobis_2d` — the chunked, vectorized 2-D squared-Mahalanobis
  + gate kernel used by Monte-Carlo experiments and the benchmark.

All functions broadcast over their array arguments.

.. rubric:: References

.. [1] V. M. Grachov, V. A. Korneev, "Method of combining radar information
   taking coordinate and feature measurements into account", Kharkiv Air
   Force University, 2010 — the gating rule after eq. (7), Fig. 1.
"""

from __future__ import annotations

import numpy as np
from scipy import optimize, stats

from ._validation import (
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    broadcast,
    unwrap,
)

__all__ = [
    "gate_mahalanobis_2d",
    "gate_threshold",
    "in_gate",
    "p_false_accept",
    "required_noncentrality",
]


def _as_dof(value, name: str = "dof") -> np.ndarray:
    """Degrees of freedom: integer-valued numbers >= 1 (scalar or array)."""
    if isinstance(value, bool) or (isinstance(value, np.ndarray) and value.dtype == bool):
        raise TypeError(f"`{name}` must be an integer or an array of integers >= 1; "
                        f"received {value!r}")
    arr = as_float_array(value, name)
    if np.any(arr != np.round(arr)) or np.any(arr < 1):
        bad = arr[(arr != np.round(arr)) | (arr < 1)].ravel()[0]
        raise ValueError(
            f"`{name}` must be an integer >= 1 (or an array of them); received {value!r} "
            f"(offending entry {bad:.6g})"
        )
    return arr



def gate_threshold(p_false_reject, dof=1):
    """Gate :math:`\\kappa_{\\text{th}}` for a given false-rejection probability.

    Parameters
    ----------
    p_false_reject : float or array_like
        :math:`P_{\\text{lo}}`, the probability of rejecting a true hypothesis,
        in the open interval (0, 1). The paper uses 0.01 and 0.005.
    dof : int or array_like of int, optional
        Degrees of freedom :math:`m \\ge 1` of the chi-square law (1 for one
        scalar coordinate; :math:`d` for a :math:`d`-dimensional position;
        :math:`n` for the sum over the :math:`n` pairs of a joint hypothesis).

    Returns
    -------
    float or numpy.ndarray
        :math:`\\kappa_{\\text{th}}`, broadcast over the arguments.

    Raises
    ------
    ValueError
        If `p_false_reject` is outside (0, 1) or `dof` is not an integer >= 1.

    Notes
    -----
    The upper :math:`P_{\\text{lo}}` quantile of :math:`\\chi^2(m)`:

    .. math::

        \\kappa_{\\text{th}} = F^{-1}_{\\chi^2(m)}(1 - P_{\\text{lo}}),

    computed with :func:`scipy.stats.chi2.isf` (accurate also for tiny
    :math:`P_{\\text{lo}}`).

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
        Degrees of freedom of the chi-square law of `statistic` under a true
        hypothesis. Default 1.
    p_false_reject : float or array_like, optional
        :math:`P_{\\text{lo}}` in (0, 1). Default 0.01.

    Returns
    -------
    bool or numpy.ndarray of bool
        ``statistic < gate_threshold(p_false_reject, dof)``, broadcast.

    Raises
    ------
    ValueError
        If `statistic` is negative or not finite, or the other arguments are
        invalid (see :func:`gate_threshold`).

    Notes
    -----
    The paper's rule: :math:`\\kappa_k^* < \\kappa_{\\text{th}}` — the hypothesis is
    taken as true; :math:`\\kappa_k^* > \\kappa_{\\text{th}}` — it is rejected.
    (Equality has probability zero.)

    Examples
    --------
    >>> in_gate([1.0, 7.0], 1, 0.01)
    array([ True, False])
    """
    k = as_positive(statistic, "statistic", strict=False)
    th = np.asarray(gate_threshold(p_false_reject, dof))
    k, th = broadcast(statistic=k, threshold=th)
    return unwrap(k < th)


def p_false_accept(noncentrality, dof=1, p_false_reject=0.01):
    """Probability that a false hypothesis passes the gate.

    Parameters
    ----------
    noncentrality : float or array_like
        :math:`V \\ge 0`, the noncentrality of the proximity measure under the
        false hypothesis (for scalars, :math:`V = (x_1 - x_2)^2/(\\sigma_1^2 +
        \\sigma_2^2)` with the two objects' true coordinates).
    dof : int or array_like of int, optional
        Degrees of freedom. Default 1.
    p_false_reject : float or array_like, optional
        :math:`P_{\\text{lo}}` that sets the gate. Default 0.01.

    Returns
    -------
    float or numpy.ndarray
        :math:`P\\{\\chi'^2(m, V) < \\kappa_{\\text{th}}\\}`; the power of the gate
        against this false hypothesis is one minus it. At :math:`V = 0` it
        equals :math:`1 - P_{\\text{lo}}`.

    Raises
    ------
    ValueError
        If `noncentrality` is negative or not finite, or the other arguments are
        invalid.

    Notes
    -----
    .. math::

        P_{\\text{fa}}(V) = F_{\\chi'^2(m, V)}\\bigl(\\kappa_{\\text{th}}\\bigr),
        \\qquad \\kappa_{\\text{th}} = F^{-1}_{\\chi^2(m)}(1 - P_{\\text{lo}}).

    It decreases monotonically in :math:`V` — the paper's remark that false
    hypotheses with small :math:`V` are accepted with high probability, the
    weakness of pointwise gating.

    References
    ----------
    Grachov & Korneev (2010), text after Fig. 1.

    Examples
    --------
    >>> round(p_false_accept(0.0, 1, 0.01), 6)
    0.99
    >>> round(p_false_accept(10.0, 1, 0.01), 4)
    0.2788
    """
    v = as_positive(noncentrality, "noncentrality", strict=False)
    th = np.asarray(gate_threshold(p_false_reject, dof))
    m = _as_dof(dof)
    v, m, th = broadcast(noncentrality=v, dof=m, threshold=th)
    out = np.where(v > 0, stats.ncx2.cdf(th, m, np.where(v > 0, v, 1.0)), stats.chi2.cdf(th, m))
    return unwrap(out)


def required_noncentrality(p_accept, dof=1, p_false_reject=0.01, *, xtol=1e-10):
    """Noncentrality :math:`V` at which a false hypothesis is accepted with probability `p_accept`.

    Parameters
    ----------
    p_accept : float or array_like
        Target false-acceptance probability, in :math:`(0, 1 - P_{\\text{lo}})`
        (at :math:`V = 0` the acceptance probability is already
        :math:`1 - P_{\\text{lo}}`, and it only falls as :math:`V` grows).
    dof : int or array_like of int, optional
        Degrees of freedom. Default 1.
    p_false_reject : float or array_like, optional
        :math:`P_{\\text{lo}}`. Default 0.01.
    xtol : float, optional
        Absolute tolerance on :math:`V` for :func:`scipy.optimize.brentq`.

    Returns
    -------
    float or numpy.ndarray
        The unique root :math:`V^*` of :math:`P_{\\text{fa}}(V) = p_{\\text{accept}}`.

    Raises
    ------
    ValueError
        If `p_accept` is not in :math:`(0, 1 - P_{\\text{lo}})` or the other
        arguments are invalid.

    Notes
    -----
    :math:`P_{\\text{fa}}(V)` is continuous and strictly decreasing from
    :math:`1 - P_{\\text{lo}}` at :math:`V = 0` to 0, so the root is unique; it is
    bracketed by doubling an upper bound and found with Brent's method.

    Examples
    --------
    >>> v = required_noncentrality(0.05, 1, 0.01)
    >>> round(v, 3), round(p_false_accept(v, 1, 0.01), 6)
    (17.814, 0.05)
    """
    pa = as_probability(p_accept, "p_accept")
    p = as_probability(p_false_reject, "p_false_reject")
    m = _as_dof(dof)
    pa, m, p = broadcast(p_accept=pa, dof=m, p_false_reject=p)
    if np.any(pa >= 1 - p):
        raise ValueError(
            "`p_accept` must be below 1 - p_false_reject (the acceptance probability at V = 0); "
            f"received p_accept={unwrap(pa)!r} with p_false_reject={unwrap(p)!r}"
        )
    out = np.empty(pa.shape)
    for idx in np.ndindex(pa.shape):
        th = stats.chi2.isf(p[idx], m[idx])

        def f(v, th=th, idx=idx):
            return stats.ncx2.cdf(th, m[idx], v) - pa[idx] if v > 0 else (1 - p[idx]) - pa[idx]

        hi = max(1.0, th)
        while f(hi) > 0:
            hi *= 2.0
        out[idx] = optimize.brentq(f, 0.0, hi, xtol=xtol, rtol=4 * np.finfo(float).eps)
    return unwrap(out)


def gate_mahalanobis_2d(x1, x2, cov, *, p_false_reject=0.01, chunk_size=32768,
                        return_statistic=False):
    """Chunked squared-Mahalanobis distance and chi-square gate for 2-D pairs.

    The fast kernel behind the chapter's Monte-Carlo runs and the benchmark:
    for ``N`` pairs of 2-D positions sharing one innovation covariance
    :math:`S = C_1 + C_2`, compute :math:`\\kappa = (\\hat x_1 - \\hat x_2)^T S^{-1}
    (\\hat x_1 - \\hat x_2)` (through the Cholesky factor of :math:`S`, never an
    inverse) and the gate decision with 2 degrees of freedom.

    Parameters
    ----------
    x1, x2 : array_like, shape (N, 2)
        Paired reports of radar 1 and radar 2.
    cov : array_like, shape (2, 2)
        :math:`S`, symmetric positive definite (for per-pair covariances use
        :func:`radarfusion_ref.proximity.mahalanobis_sq`).
    p_false_reject : float, optional
        :math:`P_{\\text{lo}}`. Default 0.01.
    chunk_size : int, optional
        Pairs per chunk; work buffers hold ``chunk_size`` pairs, so memory
        beyond the inputs and the ``N``-byte result does not grow with ``N``.
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
        positive definite, or any entry is not finite.

    Notes
    -----
    With :math:`S = L L^T`, :math:`L = \\begin{pmatrix} l_{11} & 0 \\\\ l_{21} &
    l_{22}\\end{pmatrix}` and :math:`\\delta = \\hat x_1 - \\hat x_2`:

    .. math::

        z_1 = \\delta_1 / l_{11}, \\quad z_2 = (\\delta_2 - l_{21} z_1)/l_{22},
        \\quad \\kappa = z_1^2 + z_2^2 .

    Each chunk is processed with in-place ufuncs into preallocated buffers,
    so the working set stays in cache, and the inputs are checked for NaN/inf
    chunk by chunk (through :math:`\\kappa`), so the only memory that grows with
    ``N`` is the 1-byte-per-pair result.

    Examples
    --------
    >>> acc, k = gate_mahalanobis_2d([[0.0, 0.0], [4.0, 0.0]], [[0.0, 1.0], [0.0, 0.0]],
    ...                              np.eye(2), return_statistic=True)
    >>> acc, k
    (array([ True, False]), array([ 1., 16.]))
    """
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
    th = float(gate_threshold(p_false_reject, 2))
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
            np.less(kk, th, out=accepted[start:stop])
            if kappa is not None:
                kappa[start:stop] = kk
    return (accepted, kappa) if return_statistic else accepted
