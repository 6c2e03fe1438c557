r"""Scores of a fusion result against the truth: GOSPA, NEES and purity.

* :func:`gospa` — the generalized optimal sub-pattern assignment metric between a set
  of true and a set of estimated points, split into its localisation, missed and false
  parts ([1]_);
* :func:`nees` — the normalised estimation error squared of estimates with their
  covariances, and the range its mean takes for consistent covariances;
* :func:`purity` — which groups of reports (or tracks) hold the reports of one true
  source only.

.. rubric:: References

.. [1] A. S. Rahmathullah, Á. F. García-Fernández, L. Svensson, "Generalized
   optimal sub-pattern assignment metric", FUSION 2017 (GOSPA, eqs. 1–2 and
   the decomposition for α = 2).
.. [2] Y. Bar-Shalom, X. R. Li, T. Kirubarajan, *Estimation with Applications to
   Tracking and Navigation*, Wiley (2001), sec. 5.4.2 (NEES).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats
from scipy.optimize import linear_sum_assignment
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .linalg import mahalanobis_sq
from .montecarlo import Proportion, proportion
from .validation import (
    MEMORY_LIMIT,
    as_covariance,
    as_float_array,
    as_positive,
    as_probability,
    check_domain,
    check_size,
    describe,
)

__all__ = ["GospaResult", "NeesResult", "PurityResult", "gospa", "nees", "purity"]


# ----------------------------------------------------------------------------- GOSPA
@dataclass(frozen=True)
class GospaResult:
    """GOSPA between a truth set and an estimate set (α = 2).

    Attributes
    ----------
    total : float
        :math:`d_p^{(c,2)}`, in the unit of the points.
    localisation, missed, false : float
        The three parts of :math:`d^p` (they sum to ``total**p``): the sum of
        :math:`d(x, y)^p` over assigned pairs closer than `c`, :math:`c^p/2` per missed
        truth, :math:`c^p/2` per false estimate.
    n_assigned, n_missed, n_false : int
    pairs : numpy.ndarray of int, shape (n_assigned, 2)
        The assigned pairs ``(i, j)``: truth ``x[i]`` with estimate ``y[j]``, closer than
        `c`, in increasing ``i``.
    """

    total: float
    localisation: float
    missed: float
    false: float
    n_assigned: int
    n_missed: int
    n_false: int
    pairs: np.ndarray


def _points(value, name):
    a = as_float_array(value, name)
    if a.ndim == 1 and a.size == 0:
        a = a.reshape(0, 1)
    if a.ndim != 2:
        raise ValueError(f"`{name}` must be points of shape (n, d); received shape {a.shape}")
    return a


def _number(value, name):
    """A single finite number > 0."""
    v = as_positive(value, name)
    if v.ndim:
        raise ValueError(f"`{name}` must be a number; received {describe(value)}")
    return float(v)


def _gospa_iv(x, y, c, p, parts):
    x = _points(x, "x")
    y = _points(y, "y")
    if x.size and y.size and x.shape[1] != y.shape[1]:
        raise ValueError(f"`x` and `y` must have the same dimension; received shapes "
                         f"{x.shape} and {y.shape}")
    c = _number(c, "c")
    p = _number(p, "p")
    if p < 1:
        raise ValueError(f"`p` must be a finite number >= 1; received {p!r}")
    if not isinstance(parts, (bool, np.bool_)):
        raise TypeError(f"`parts` must be True or False; received {describe(parts)}")
    n, k = x.shape[0], y.shape[0]
    _check_differences(x, y)
    if n * k <= _SPARSE_ABOVE or not _kdtree_safe(x, y, c):
        _check_matrix(n, k, x.shape[1])
    # the parts are in units of c**p: refuse where that unit is no normal float64
    log_cp = p * np.log(c)
    if parts and (n or k) and not (np.log(_TINY) <= log_cp <= np.log(_HUGE / (n + k))):
        raise ValueError(
            f"`c` = {c!r} with `p` = {p!r}: the parts of GOSPA are in units of c**p = "
            f"10**{log_cp / np.log(10):.0f}, outside float64's range [{_TINY:.1e}, "
            f"{_HUGE / (n + k):.1e}]; express lengths in a unit where `c` is nearer 1, or "
            "pass parts=False for the total alone")
    return x, y, c, p


_TINY, _HUGE = np.finfo(float).tiny, np.finfo(float).max


def _scaled_distances(x, y, c):
    """Distances between the points, divided by `c`, without overflow in the squares."""
    with np.errstate(over="ignore", invalid="ignore"):
        diff = x[:, None, :] - y[None, :, :]
    if not np.all(np.isfinite(diff)):
        raise ValueError("`x` and `y` hold points whose differences overflow float64 "
                         f"(largest |coordinate| {max(np.max(np.abs(x)), np.max(np.abs(y))):.3g})")
    big = np.max(np.abs(diff), axis=-1, keepdims=True)
    safe = np.where(big > 0, big, 1.0)
    dist = big[..., 0] * np.linalg.norm(diff / safe, axis=-1)     # |d|, scaled norm
    with np.errstate(over="ignore"):
        return dist / c                                           # inf only beyond the cut-off


#: Above this many (truth, estimate) combinations `gospa` solves the assignment sparsely.
_SPARSE_ABOVE = 2500            # the crossover of the two routes, about 50 x 50 points


def _check_differences(x, y):
    """Refuse points whose differences overflow float64 (the largest |x - y| per axis is
    max(x) - min(y) or max(y) - min(x))."""
    if not (x.shape[0] and y.shape[0]):
        return
    with np.errstate(over="ignore", invalid="ignore"):
        span = np.maximum(x.max(axis=0) - y.min(axis=0), y.max(axis=0) - x.min(axis=0))
    if not np.all(np.isfinite(span)):
        raise ValueError("`x` and `y` hold points whose differences overflow float64 "
                         f"(largest |coordinate| {max(np.max(np.abs(x)), np.max(np.abs(y))):.3g})")


def _check_matrix(n, k, d):
    check_size(8 * 3 * n * k * max(d, 1), MEMORY_LIMIT,
               what=f"bytes of the distance matrix of {n} x {k} points (`x`, `y`)",
               alternative="scoring smaller sets (one scan at a time, or spatial regions)")


def _kdtree_safe(x, y, c):
    """Whether the points divided by `c` keep their squared distances finite (the k-d
    tree's domain); otherwise the dense route, which scales each difference, is used."""
    with np.errstate(over="ignore"):
        m = max(np.max(np.abs(x)), np.max(np.abs(y))) / c
    return bool(np.isfinite(m) and m < 2.0 ** 400)


def _assign_dense(x, y, c, p):
    """The assignment on the full matrix of min(d / c, 1)**p: (loc, assigned, pairs)."""
    n, k = x.shape[0], y.shape[0]
    if not (n and k):
        return 0.0, 0, np.zeros((0, 2), dtype=np.int64)
    u = _scaled_distances(x, y, c)                                    # d / c
    ri, ci = linear_sum_assignment(np.minimum(u, 1.0) ** p)           # min over gamma
    close = u[ri, ci] < 1.0                                           # pairs kept in gamma
    loc = float(np.sum(u[ri, ci][close] ** p))
    pairs = np.stack([ri[close], ci[close]], axis=-1).astype(np.int64)
    return loc, int(close.sum()), pairs


def _pair_distances(x, y, i, j, c):
    """d(x_i, y_j) / c for listed pairs, by the formula of :func:`_scaled_distances`."""
    diff = x[i] - y[j]
    big = np.max(np.abs(diff), axis=-1, keepdims=True)
    safe = np.where(big > 0, big, 1.0)
    with np.errstate(over="ignore"):
        return big[:, 0] * np.linalg.norm(diff / safe, axis=-1) / c


def _assign_sparse(x, y, c, p):
    r"""The same optimum as :func:`_assign_dense`, component by component.

    A pair at distance :math:`\ge c` costs :math:`c^p`, as much as leaving both points
    unassigned, so the optimum splits over the connected components of the bipartite
    graph of the pairs closer than `c`: a component of one truth and one estimate is
    that pair; a larger one is a small dense assignment.
    """
    n, k = x.shape[0], y.shape[0]
    tx, ty = cKDTree(x / c), cKDTree(y / c)
    reach = 1.0 + 1e-9                     # a margin over the tree's rounding; u < 1 decides
    count = int(tx.count_neighbors(ty, reach))
    check_size(8 * 6 * count, MEMORY_LIMIT,
               what=f"bytes of the {count} pairs of points (`x`, `y`) closer than `c`",
               alternative="scoring smaller sets (one scan at a time, or spatial regions) "
                           "or a smaller `c`")
    near = tx.sparse_distance_matrix(ty, reach, output_type="ndarray")
    i, j = near["i"].astype(np.int64), near["j"].astype(np.int64)
    u = _pair_distances(x, y, i, j, c)
    keep = u < 1.0                                                 # the graph's edges
    i, j, u = i[keep], j[keep], u[keep]
    if not i.size:
        return 0.0, 0, np.zeros((0, 2), dtype=np.int64)
    graph = coo_matrix((np.ones(i.size), (i, n + j)), shape=(n + k, n + k))
    _, label = connected_components(graph, directed=False)
    size = np.bincount(label[i], minlength=label.max() + 1)        # edges per component
    single = size[label[i]] == 1                                   # one truth, one estimate
    loc_parts = [u[single] ** p]
    pi, pj = [i[single]], [j[single]]
    rest = np.flatnonzero(~single)
    if rest.size:
        rest = rest[np.argsort(label[i[rest]], kind="stable")]
        bounds = np.flatnonzero(np.diff(label[i[rest]])) + 1
        for e in np.split(rest, bounds):
            rows, r_inv = np.unique(i[e], return_inverse=True)
            cols, c_inv = np.unique(j[e], return_inverse=True)
            _check_matrix(rows.size, cols.size, x.shape[1])
            cost = np.ones((rows.size, cols.size))                 # min(d / c, 1)**p
            cost[r_inv, c_inv] = u[e] ** p
            ri, ci = linear_sum_assignment(cost)
            sub = np.full((rows.size, cols.size), np.inf)
            sub[r_inv, c_inv] = u[e]
            close = sub[ri, ci] < 1.0
            loc_parts.append(sub[ri, ci][close] ** p)
            pi.append(rows[ri[close]])
            pj.append(cols[ci[close]])
    pairs = np.stack([np.concatenate(pi), np.concatenate(pj)], axis=-1)
    pairs = pairs[np.argsort(pairs[:, 0], kind="stable")]
    return float(np.sum(np.concatenate(loc_parts))), pairs.shape[0], pairs


def gospa(x, y, *, c, p=2.0, parts=True) -> GospaResult:
    r"""Generalized OSPA metric with α = 2 and its localisation, missed and false parts.

    Parameters
    ----------
    x, y : array_like, shape (n, d) and (k, d)
        Truth and estimated points (either may be empty).
    c : float
        Cut-off distance :math:`c > 0`.
    p : float, optional
        Order :math:`1 \le p < \infty` (default 2).
    parts : bool, optional
        Whether to return the three parts (default). They are in units of :math:`c^p`,
        which must be a normal float64; with ``parts=False`` the total alone is computed
        (at any `c` for which it is representable) and the parts are NaN.

    Returns
    -------
    GospaResult

    Raises
    ------
    ValueError
        Non-finite points, points whose differences overflow, a dimension mismatch, `c`
        not positive, `p` < 1 or not finite, a distance matrix (of small sets, or of one
        cluster of points all linked by pairs closer than `c`) or pairs closer than `c`
        beyond the memory limit, or (with `parts`) :math:`c^p` outside float64.
    TypeError
        Non-numeric input, or `parts` not a bool.

    Notes
    -----
    .. math::

        d_p^{(c,2)}(X, Y) = \Big(\min_{\gamma} \sum_{(i,j)\in\gamma} d(x_i, y_j)^p
        + \frac{c^p}{2}\big(|X| + |Y| - 2|\gamma|\big)\Big)^{1/p},

    the minimum over partial assignments :math:`\gamma` of pairs closer than :math:`c`
    (Rahmathullah et al. 2017). It is found as a rectangular linear assignment
    (:func:`scipy.optimize.linear_sum_assignment`) on :math:`\min(d, c)^p`: a pair at
    distance :math:`\ge c` costs :math:`c^p`, exactly one miss plus one false estimate.
    The sum is formed in units of :math:`c^p` (distances divided by :math:`c`) and the
    total is :math:`c` times its p-th root, so no term underflows or overflows.

    Large sets (more than 2 500 truth-estimate combinations) are solved without the full
    matrix, with the same optimum: since a pair at :math:`d \ge c` costs exactly what
    leaving both points unassigned costs, the minimum splits over the connected
    components of the bipartite graph of the pairs closer than :math:`c` (found with a
    k-d tree, :class:`scipy.spatial.cKDTree`, and
    :func:`scipy.sparse.csgraph.connected_components`). A component of one truth and one
    estimate is that pair; a larger one is a small assignment on its own matrix. The
    total and parts equal the dense ones to rounding; where the optimum is not unique
    (ties) the pairs, and so the split between the parts, may be another optimum's.

    Examples
    --------
    >>> g = gospa([[0.0, 0.0], [10.0, 0.0]], [[1.0, 0.0]], c=5.0)
    >>> g.total ** 2, g.localisation, g.missed, g.false
    (13.5, 1.0, 12.5, 0.0)
    """
    x, y, c, p = _gospa_iv(x, y, c, p, parts)
    n, k = x.shape[0], y.shape[0]
    if n * k > _SPARSE_ABOVE and _kdtree_safe(x, y, c):
        loc, assigned, pairs = _assign_sparse(x, y, c, p)
    else:
        loc, assigned, pairs = _assign_dense(x, y, c, p)
    missed, false = (n - assigned) / 2.0, (k - assigned) / 2.0
    with np.errstate(over="ignore"):
        total = float(c * (loc + missed + false) ** (1.0 / p))
    if not np.isfinite(total):
        raise ValueError(f"`c` = {c!r}: the GOSPA total c * {(loc + missed + false) ** (1 / p):.3g} "
                         "overflows float64; express lengths in a larger unit")
    cp = (c**p if n or k else 0.0) if parts else np.nan             # c**p checked at the door
    return GospaResult(total=total, localisation=loc * cp, missed=missed * cp,
                       false=false * cp, n_assigned=assigned,
                       n_missed=n - assigned, n_false=k - assigned, pairs=pairs)


# ----------------------------------------------------------------------------- NEES
@dataclass(frozen=True)
class NeesResult:
    r"""Normalised estimation errors squared and the consistency range of their mean.

    Attributes
    ----------
    values : numpy.ndarray, shape (N,)
        :math:`\epsilon_k = e_k^\mathsf T P_k^{-1} e_k` of each estimate.
    mean : float
        Their mean.
    low, high : float
        The central `level` range of that mean when the covariances are right (the
        errors Gaussian with covariances :math:`P_k`, independent):
        :math:`[\chi^2_{dN}((1-\text{level})/2),\ \chi^2_{dN}((1+\text{level})/2)]/N`.
    count : int
        N.
    dof : int
        d, the dimension of each error.
    level : float
    """

    values: np.ndarray
    mean: float
    low: float
    high: float
    count: int
    dof: int
    level: float


def _nees_iv(error, cov, level):
    e = as_float_array(error, "error", ndim_min=2)
    if e.ndim != 2 or e.shape[0] == 0 or e.shape[1] == 0:
        raise ValueError(f"`error` must hold N >= 1 errors of shape (N, d); received shape "
                         f"{e.shape}")
    check_domain(e, "error")
    P = as_float_array(cov, "cov", ndim_min=3)
    if P.shape != (*e.shape, e.shape[1]):
        raise ValueError(f"`cov` must have shape {(*e.shape, e.shape[1])} (one covariance per "
                         f"error); received shape {P.shape}")
    P = as_covariance(P, "cov", dim=e.shape[1])              # the PD rule and the variance domain
    lv = as_probability(level, "level")
    if lv.ndim:
        raise ValueError(f"`level` must be a number in (0, 1); received {describe(level)}")
    return e, P, float(lv)


def nees(error, cov, *, level=0.95) -> NeesResult:
    r"""Normalised estimation error squared (NEES) and its consistency range.

    Parameters
    ----------
    error : array_like, shape (N, d)
        Estimation errors :math:`e_k = \hat x_k - x_k`.
    cov : array_like, shape (N, d, d)
        The covariance each estimate claims, symmetric positive definite.
    level : float, optional
        Probability of the range of the mean (default 0.95).

    Returns
    -------
    NeesResult

    Raises
    ------
    ValueError
        No errors, shapes that disagree, a `cov` that is not positive definite, a
        non-finite entry or `level` outside (0, 1).
    TypeError
        Non-numeric input.

    Notes
    -----
    .. math::

        \epsilon_k = e_k^\mathsf T P_k^{-1} e_k, \qquad
        \bar\epsilon = \frac1N\sum_k \epsilon_k .

    With consistent covariances each :math:`\epsilon_k` is :math:`\chi^2_d`, so
    :math:`N\bar\epsilon` is :math:`\chi^2_{dN}` (independent errors): a mean above
    `high` says the covariances are too small, below `low` too large.

    Examples
    --------
    >>> r = nees([[1.0, 0.0], [0.0, 2.0]], [np.eye(2), 4.0 * np.eye(2)])
    >>> r.values, r.mean, r.count
    (array([1., 1.]), 1.0, 2)
    """
    e, P, level = _nees_iv(error, cov, level)
    values = np.asarray(mahalanobis_sq(e, P), dtype=float)     # e' P^-1 e (checks P's rule)
    N, d = e.shape
    return NeesResult(values=values, mean=float(values.mean()),
                      low=float(stats.chi2.ppf((1 - level) / 2, d * N) / N),
                      high=float(stats.chi2.ppf((1 + level) / 2, d * N) / N),
                      count=N, dof=d, level=level)


# ----------------------------------------------------------------------------- purity
@dataclass(frozen=True)
class PurityResult:
    """Which groups hold the reports of one true source only.

    Attributes
    ----------
    source : numpy.ndarray of int, shape (G,)
        The true source of each pure group; -1 for a group that mixes sources, holds a
        false report (a negative source) or no report.
    pure : numpy.ndarray of bool, shape (G,)
        ``source >= 0``.
    fraction : Proportion or None
        Fraction of pure groups with its 95 % interval (None without groups).
    """

    source: np.ndarray
    pure: np.ndarray
    fraction: Proportion | None


def _array_of(value, kinds):
    """`value` as an array if it is one of the dtype kinds `kinds`, else None."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):                                # ragged lists
        return None
    return a if a.dtype.kind in kinds else None


def _purity_iv(sources, present):
    s = _array_of(sources, "iu")
    if s is None or s.ndim != 2:
        raise TypeError(f"`sources` must be an integer array of shape (G, m); received "
                        f"{describe(sources)}")
    if present is None:
        return s, np.ones(s.shape, dtype=bool)
    m = _array_of(present, "b")
    if m is None:
        raise TypeError(f"`present` must be a boolean array; received {describe(present)}")
    if m.shape != s.shape:
        raise ValueError(f"`present` must have the shape of `sources` {s.shape}; received "
                         f"shape {m.shape}")
    return s, m


def purity(sources, present=None) -> PurityResult:
    """Pure groups: every report of the group comes from one and the same true source.

    Parameters
    ----------
    sources : array_like of int, shape (G, m)
        The true source of each member of each group (an object index >= 0; a negative
        value for a false report). Slots without a report are marked by `present`.
    present : array_like of bool, shape (G, m), optional
        Which slots hold a report (default: all).

    Returns
    -------
    PurityResult

    Raises
    ------
    TypeError
        `sources` not an integer matrix or `present` not booleans.
    ValueError
        `present` of another shape.

    Examples
    --------
    >>> r = purity([[3, 3, 0], [3, 4, 4], [-1, 2, 2]], [[True, True, False]] * 3)
    >>> r.source.tolist(), r.fraction.estimate
    ([3, -1, -1], 0.3333333333333333)
    """
    s, m = _purity_iv(sources, present)
    G = s.shape[0]
    first = s[np.arange(G), np.argmax(m, axis=1)] if s.shape[1] else np.full(G, -1)
    pure = m.any(axis=1) & (first >= 0) & np.all((s == first[:, None]) | ~m, axis=1)
    return PurityResult(source=np.where(pure, first, -1), pure=pure,
                        fraction=proportion(int(pure.sum()), G) if G else None)

