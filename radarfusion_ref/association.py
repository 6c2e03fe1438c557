"""Pointwise and joint association of two radars' reports.

Two radars report on the same objects; the fusion centre must decide which
report of radar 1 and which report of radar 2 belong to one object. The input
of every function here is a **cost matrix** ``cost[..., i, j]`` — the proximity
measure :math:`\\kappa_{ij}` (or any negative log-likelihood) of pairing report
``i`` of radar 1 with report ``j`` of radar 2. ``+inf`` marks a forbidden pair;
NaN and ``-inf`` are refused.

Procedures (Grachov & Korneev 2010, text around eqs. (5)–(6)):

* :func:`associate_pointwise` — the paper's simplified pointwise rule: scan the
  :math:`n^2` pairwise hypotheses :math:`G_k`, accept the first one whose
  :math:`\\kappa` is below the gate, remove both reports, go on
  (``order="scan"``); or the greedy best-first variant (``order="best_first"``);
* :func:`associate_joint` — the joint maximum-likelihood hypothesis
  :math:`H_n`: the complete pairing with the smallest summed cost, a linear
  assignment problem solved exactly in :math:`O(n^3)` by
  :func:`scipy.optimize.linear_sum_assignment`; rectangular matrices, gating
  and a per-report non-assignment cost (missed detections, false reports) are
  supported;
* :func:`associate_bruteforce` — the same optimum by enumerating every joint
  hypothesis (the :math:`n!` route; small :math:`n` only);
* :func:`k_best_assignments` — Murty's ranking of the :math:`k` best joint
  hypotheses, and :func:`association_probabilities` — marginal association
  probabilities, exact (enumeration) or approximated from the :math:`k` best;
* :func:`non_assignment_cost` — the non-assignment cost implied by the
  likelihood ratio (detection probabilities, false-report densities);
* :func:`two_radar_clutter_scene` — the shared scene simulator
  (:func:`radarfusion_ref.scenes.two_radar_scene`) with missed detections and
  false reports added (it lives in :mod:`radarfusion_ref.scenes`);
* :func:`compare_decisions` — the Monte-Carlo decision-level comparison of the
  three procedures used by the chapter.

.. rubric:: References

.. [1] V. M. Grachov, V. A. Korneev, "Method of combining radar information
   taking coordinate and feature measurements into account", Kharkiv Air
   Force University, 2010 — eqs. (5)–(7) and the joint proximity measure.
.. [2] K. G. Murty, "An algorithm for ranking all the assignments in order of
   increasing cost", Operations Research 16 (1968) 682–687.
.. [3] M. L. Miller, H. S. Stone, I. J. Cox, "Optimizing Murty's ranked
   assignment method", IEEE Trans. AES 33 (1997) 851–862.
.. [4] D. F. Crouse, "On implementing 2D rectangular assignment algorithms",
   IEEE Trans. AES 52 (2016) 1679–1696.
"""

from __future__ import annotations

import bisect
import heapq
import itertools
import math
import warnings
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import sparse
from scipy.optimize import linear_sum_assignment
from scipy.sparse.csgraph import min_weight_full_bipartite_matching

from . import scenes
from ._validation import (
    MEMORY_LIMIT,
    _describe,
    as_bool,
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    broadcast,
    check_size,
)
from .errors import RadarFusionWarning
from .montecarlo import Proportion, proportion
from .proximity import mahalanobis_sq

__all__ = [
    "Association",
    "ClutterScene",
    "DecisionComparison",
    "KBestAssignments",
    "all_correct",
    "associate_bruteforce",
    "associate_joint",
    "associate_pointwise",
    "association_probabilities",
    "compare_decisions",
    "k_best_assignments",
    "non_assignment_cost",
    "proximity_matrix",
    "two_radar_clutter_scene",
]

#: Largest number of joint hypotheses of one cost matrix that
#: :func:`associate_bruteforce` and the exact :func:`association_probabilities`
#: enumerate (:math:`10! = 3\,628\,800` fits; :math:`n = 11` does not).
MAX_HYPOTHESES = 4_000_000
#: Largest number of *partial* matchings :func:`associate_bruteforce` scores
#: when a gate, a non-assignment cost or forbidden pairs are given (7 x 7 fits).
MAX_PARTIAL_MATCHINGS = 200_000
#: Largest number of hypotheses :func:`associate_bruteforce` scores in one call,
#: summed over a batch of cost matrices (bounds its run time).
MAX_SCORED_HYPOTHESES = 200_000_000
#: Largest `k` of :func:`k_best_assignments` (and ``association_probabilities(k=...)``).
MAX_K_BEST = 100_000
#: Planned bytes per ranked hypothesis and matrix entry in :func:`k_best_assignments`
#: (sub-problem matrices kept for pending children): the memory limit is checked
#: against ``_MURTY_BYTES_PER_NODE * k * n**2``.
_MURTY_BYTES_PER_NODE = 32
#: Working copies of the report arrays :func:`two_radar_clutter_scene` makes.
_SCENE_COPIES = 6
#: Working memory of one vectorized block of the enumerations, in bytes.
_BLOCK_BYTES = 1 << 25


def _limit(requested, limit, *, name: str, what: str, alternative: str) -> int:
    """:func:`check_size`, with the public argument named in the message."""
    try:
        return check_size(requested, limit, what=what, alternative=alternative)
    except ValueError as exc:
        raise ValueError(f"`{name}`: {exc}") from None


def _exponents(c: np.ndarray, *extra: float) -> np.ndarray:
    """Binary exponents ``e`` (per matrix) with ``|finite entries| < 2**e``.

    The solvers work on ``ldexp(cost, -e)``: a power-of-two scaling is exact,
    keeps every finite entry below 1 in magnitude, so no sum or difference of
    a few entries overflows even for costs near the float maximum.
    """
    finite = np.where(np.isfinite(c), np.abs(c), 0.0)
    top = finite.max(axis=(-2, -1)) if c.size else np.zeros(c.shape[:-2])
    for x in extra:
        top = np.maximum(top, abs(x))
    return np.frexp(top)[1]


def _scaled(c: np.ndarray, e: np.ndarray) -> np.ndarray:
    """``c * 2**-e`` per matrix (exact; ``+inf`` stays ``+inf``)."""
    return np.ldexp(c, -np.asarray(e)[..., None, None])


# --------------------------------------------------------------------------- validation
def _as_cost(cost, name: str = "cost") -> np.ndarray:
    """Cost matrices ``(..., n1, n2)``: finite or ``+inf``; NaN, ``-inf`` and empty refused."""
    arr = as_float_array(cost, name, ndim_min=2, allow_nonfinite=True)
    if arr.shape[-1] == 0 or arr.shape[-2] == 0:
        raise ValueError(
            f"`{name}` must have at least one row and one column; received shape {arr.shape}"
        )
    if np.any(np.isnan(arr)):
        raise ValueError(
            f"`{name}` must not contain NaN (use +inf for a forbidden pair); received "
            f"{int(np.count_nonzero(np.isnan(arr)))} NaN entries in shape {arr.shape}"
        )
    if np.any(arr == -np.inf):
        raise ValueError(
            f"`{name}` must not contain -inf (a pair cannot be infinitely likely); received "
            f"{int(np.count_nonzero(arr == -np.inf))} -inf entries in shape {arr.shape}"
        )
    return arr


def _as_threshold(threshold, name: str = "threshold") -> float:
    """A gate: a number > 0; ``+inf`` and None both mean "no gate" (returned as ``+inf``)."""
    if threshold is None:
        return np.inf
    arr = as_float_array(threshold, name, allow_nonfinite=True)
    if arr.ndim != 0:
        raise ValueError(f"`{name}` must be a single number > 0; received shape {arr.shape}")
    value = float(arr)
    if math.isnan(value) or value <= 0:
        raise ValueError(f"`{name}` must be a number > 0 (or +inf for no gate); received {value}")
    return value


def _as_miss_cost(miss_cost, name: str = "miss_cost") -> float | None:
    """Non-assignment cost: a real number; ``+inf`` means the same as None."""
    if miss_cost is None:
        return None
    arr = as_float_array(miss_cost, name, allow_nonfinite=True)
    if arr.ndim != 0:
        raise ValueError(f"`{name}` must be a single number; received shape {arr.shape}")
    value = float(arr)
    if math.isnan(value) or value == -np.inf:
        raise ValueError(f"`{name}` must be a real number or +inf; received {value}")
    return None if value == np.inf else value


def _scalar(arr: np.ndarray, name: str) -> float:
    """A validated 0-d array as a float (one number expected)."""
    if arr.ndim != 0:
        raise ValueError(f"`{name}` must be a single number; received shape {arr.shape}")
    return float(arr)


def _as_decisions(value, name: str) -> np.ndarray:
    """``row_to_col`` vectors: integers >= -1, at least one axis, not empty."""
    if value is None or isinstance(value, (str, bytes, bool, np.bool_)):
        raise TypeError(f"`{name}` must be an integer array of decisions (row_to_col, -1 for "
                        f"unassigned); received {_describe(value)}")
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be an integer array of decisions; received "
                        f"{_describe(value)}") from None
    if arr.dtype.kind == "f" and arr.size and np.all(np.isfinite(arr)) \
            and np.all(arr == np.round(arr)):
        arr = arr.astype(int)
    if arr.dtype.kind not in "iu":
        raise TypeError(f"`{name}` must be an integer array of decisions (row_to_col, -1 for "
                        f"unassigned); received {_describe(value)}")
    if arr.ndim < 1 or arr.size == 0:
        raise ValueError(f"`{name}` must be a non-empty array of shape (..., n1); received "
                         f"shape {arr.shape}")
    if np.any(arr < -1):
        raise ValueError(f"`{name}` entries must be column indices >= 0 or -1 (unassigned); "
                         f"received {_describe(value)} (smallest entry {int(arr.min())})")
    return arr


# --------------------------------------------------------------------------- result
@dataclass(frozen=True)
class Association:
    """Association decisions for one cost matrix or a batch of them.

    Attributes
    ----------
    row_to_col : numpy.ndarray of int, shape (..., n1)
        ``row_to_col[..., i]`` is the radar-2 report paired with radar-1
        report ``i``, or -1 if report ``i`` is left unassigned.
    col_to_row : numpy.ndarray of int, shape (..., n2)
        The inverse map; -1 for an unassigned radar-2 report.
    total_cost : numpy.ndarray or float, shape (...)
        Sum of the costs of the assigned pairs, plus ``miss_cost`` for every
        unassigned row and every unassigned column when a ``miss_cost`` was
        given.
    pairs : numpy.ndarray of int, shape (k, 2)
        (property, unbatched results only) the assigned pairs ``(i, j)``,
        sorted by ``i``.
    unassigned_rows, unassigned_cols : numpy.ndarray of int
        (properties, unbatched results only) reports left without a partner.
    n_assigned : numpy.ndarray or int, shape (...)
        (property) number of assigned pairs.
    """

    row_to_col: np.ndarray
    col_to_row: np.ndarray
    total_cost: np.ndarray | float

    def _single(self, what: str) -> None:
        if self.row_to_col.ndim != 1:
            raise ValueError(
                f"`{what}` is defined for a single cost matrix; this result holds a batch of "
                f"shape {self.row_to_col.shape[:-1]} (index it with .row_to_col instead)"
            )

    @property
    def pairs(self) -> np.ndarray:
        """Assigned pairs ``(i, j)`` as a ``(k, 2)`` int array, sorted by ``i``."""
        self._single("pairs")
        rows = np.flatnonzero(self.row_to_col >= 0)
        return np.column_stack([rows, self.row_to_col[rows]]).astype(int)

    @property
    def unassigned_rows(self) -> np.ndarray:
        """Radar-1 reports left unassigned."""
        self._single("unassigned_rows")
        return np.flatnonzero(self.row_to_col < 0)

    @property
    def unassigned_cols(self) -> np.ndarray:
        """Radar-2 reports left unassigned."""
        self._single("unassigned_cols")
        return np.flatnonzero(self.col_to_row < 0)

    @property
    def n_assigned(self):
        """Number of assigned pairs (per batch entry)."""
        out = np.count_nonzero(self.row_to_col >= 0, axis=-1)
        return int(out) if np.ndim(out) == 0 else out


def _inverse(row_to_col: np.ndarray, n2: int) -> np.ndarray:
    """``col_to_row`` from ``row_to_col`` (batched, -1 for unassigned)."""
    batch = row_to_col.shape[:-1]
    flat = row_to_col.reshape(-1, row_to_col.shape[-1])
    inv = np.full((flat.shape[0], n2), -1, dtype=int)
    b, i = np.nonzero(flat >= 0)
    inv[b, flat[b, i]] = i
    return inv.reshape(*batch, n2)


def _make_result(cost: np.ndarray, row_to_col: np.ndarray, miss_cost: float | None):
    """Assemble an :class:`Association` (total cost computed from the decisions)."""
    n1, n2 = cost.shape[-2:]
    col_to_row = _inverse(row_to_col, n2)
    assigned = row_to_col >= 0
    picked = np.take_along_axis(cost, np.where(assigned, row_to_col, 0)[..., None], axis=-1)[..., 0]
    with np.errstate(over="ignore", invalid="ignore"):
        total = np.where(assigned, picked, 0.0).sum(axis=-1)
        if miss_cost is not None:
            n_un = (n1 - assigned.sum(-1)) + (n2 - np.count_nonzero(col_to_row >= 0, axis=-1))
            total = total + miss_cost * n_un
    if not np.all(np.isfinite(total)):
        raise ValueError(
            "`cost`: the total cost of the chosen association lies beyond the float range "
            f"(|total| > {np.finfo(float).max:.3g}); the decisions exist but their sum cannot be "
            "represented: divide `cost` (and `miss_cost`) by a common factor")
    total = float(total) if np.ndim(total) == 0 else total
    return Association(row_to_col, col_to_row, total)


# --------------------------------------------------------------------------- pointwise
def associate_pointwise(cost, threshold=None, *, order: str = "scan") -> Association:
    """The paper's simplified pointwise association, or its greedy best-first variant.

    Parameters
    ----------
    cost : array_like, shape (..., n1, n2)
        Proximity measures :math:`\\kappa_{ij}`; ``+inf`` forbids a pair.
        Leading axes are a batch, processed vectorized.
    threshold : float or None
        The gate :math:`\\gamma > 0` (the paper's :math:`\\kappa_{\\text{th}}`):
        a pair is acceptable only if its cost is strictly below it. None or
        ``+inf``: no gate (the same meaning as in :func:`associate_joint`).
    order : {"scan", "best_first"}, optional
        ``"scan"`` (the paper's rule as written): go through the hypotheses in
        list order — radar-1 report 0 against radar-2 reports 0, 1, ..., then
        report 1, ... — and accept the *first* acceptable pair whose reports
        are both still free. ``"best_first"`` (greedy nearest neighbour):
        repeatedly accept the globally smallest acceptable cost among free
        reports.

    Returns
    -------
    Association
        ``total_cost`` is the sum of the accepted pairs' costs.

    Raises
    ------
    ValueError
        For NaN or ``-inf`` costs, an empty matrix, a threshold ≤ 0 or an
        unknown `order`.

    Notes
    -----
    The paper replaces the full search over pairwise hypotheses :math:`G_k`
    by "accepting the first plausible hypothesis with
    :math:`\\kappa_k^* < \\kappa_{\\text{th}}` (the book's :math:`\\gamma`), then excluding the associated
    measurements and continuing the check". The result depends on the order
    of the lists, which carries no information; ``"best_first"`` removes that
    arbitrariness. Neither is the joint maximum-likelihood decision
    (:func:`associate_joint`).

    References
    ----------
    Grachov & Korneev (2010), the simplified pointwise rule after Fig. 1.

    Examples
    --------
    >>> c = [[0.5, 0.1], [0.2, 3.0]]
    >>> associate_pointwise(c, 1.0).row_to_col          # row 0 takes column 0 first
    array([ 0, -1])
    >>> associate_pointwise(c, 1.0, order="best_first").row_to_col
    array([1, 0])
    """
    c = _as_cost(cost)
    th = _as_threshold(threshold)
    order = as_choice(order, "order", ("scan", "best_first"))
    n1, n2 = c.shape[-2:]
    batch = c.shape[:-2]
    flat = c.reshape(-1, n1, n2)
    nb = flat.shape[0]
    ok = flat < th
    row_to_col = np.full((nb, n1), -1, dtype=int)
    if order == "scan":
        free = np.ones((nb, n2), dtype=bool)
        for i in range(n1):
            cand = ok[:, i, :] & free
            has = cand.any(axis=1)
            j = cand.argmax(axis=1)
            row_to_col[has, i] = j[has]
            free[has, j[has]] = False
    else:
        work = np.where(ok, flat, np.inf).reshape(nb, n1 * n2)
        view = work.reshape(nb, n1, n2)
        for _ in range(min(n1, n2)):
            k = work.argmin(axis=1)
            live = np.isfinite(work[np.arange(nb), k])
            if not live.any():
                break
            b = np.flatnonzero(live)
            i, j = np.divmod(k[b], n2)
            row_to_col[b, i] = j
            view[b, i, :] = np.inf
            view[b, :, j] = np.inf
    return _make_result(c, row_to_col.reshape(*batch, n1), None)


# --------------------------------------------------------------------------- joint (exact)
def _solve_batch(c: np.ndarray, th: float, miss: float | None) -> np.ndarray:
    """Optimal ``row_to_col`` for a stack of matrices ``(B, n1, n2)`` (validated inputs).

    Every matrix is turned into one plain rectangular assignment problem
    (vectorized over the stack), then solved by
    :func:`scipy.optimize.linear_sum_assignment`; pairs that are not allowed or
    not worth taking are dropped afterwards. Costs are first scaled by a power
    of two (exact) so that the working matrix cannot overflow.
    """
    nb, n1, n2 = c.shape
    allowed = (c < th) & np.isfinite(c)              # the gate of eq. (eq-gate): kappa < gamma
    e = _exponents(c, *(() if miss is None else (miss,)))
    c = _scaled(c, e)
    if miss is not None:
        miss = np.ldexp(miss, -e)[:, None, None]      # per matrix, same scale as its costs
        # Partial matching with a cost `miss` per unassigned report: a pair is worth
        # taking only if c < 2*miss, and
        #   min over partial matchings of sum(c - 2 miss)
        #     = min over full assignments of sum(min(c - 2 miss, 0)),
        # so one rectangular assignment of the clipped matrix is exact (no augmentation).
        work = np.where(allowed, np.minimum(c - 2.0 * miss, 0.0), 0.0)     # |work| < 4
        useful = allowed & (work < 0)
    elif allowed.all():
        work, useful = c, allowed                 # the plain complete assignment
    else:
        # Maximum number of allowed pairs first, then the smallest cost among those:
        # forbidden pairs get a cost larger than any possible saving, so every
        # assignment with fewer forbidden pairs is cheaper (exact lexicographic order).
        lo = np.min(c, axis=(1, 2), where=allowed, initial=np.inf)
        hi = np.max(c, axis=(1, 2), where=allowed, initial=-np.inf)
        lo, hi = np.where(np.isfinite(lo), lo, 0.0), np.where(np.isfinite(hi), hi, 0.0)
        big = (min(n1, n2) + 1) * (hi - lo + 1.0)            # hi - lo < 2 after scaling
        work = np.where(allowed, c - lo[:, None, None], big[:, None, None])
        useful = allowed
    k = min(n1, n2)
    rows = np.empty((nb, k), dtype=int)
    cols = np.empty((nb, k), dtype=int)
    for b in range(nb):
        rows[b], cols[b] = linear_sum_assignment(work[b])
    keep = useful[np.arange(nb)[:, None], rows, cols]
    out = np.full((nb, n1), -1, dtype=int)
    bb, kk = np.nonzero(keep)
    out[bb, rows[bb, kk]] = cols[bb, kk]
    return out


# --------------------------------------------------------------------------- joint (sparse, gated)
def _as_sparse_cost(cost, name: str = "cost"):
    """A scipy.sparse cost matrix as canonical CSR: 2-D, real, finite stored entries."""
    shape = cost.shape
    if len(shape) != 2:
        raise ValueError(f"`{name}` (sparse) must be a 2-D matrix (n1, n2); received shape "
                         f"{shape}")
    if shape[0] == 0 or shape[1] == 0:
        raise ValueError(f"`{name}` must have at least one row and one column; received shape "
                         f"{shape}")
    if cost.dtype.kind not in "iuf":
        raise TypeError(f"`{name}` (sparse) must hold real numbers; received dtype {cost.dtype}")
    csr = sparse.csr_array(cost, dtype=float, copy=True)
    csr.sum_duplicates()                       # scipy's meaning of repeated (i, j) entries
    data = csr.data
    if np.any(np.isnan(data)):
        raise ValueError(
            f"`{name}` (sparse) must not store NaN: a forbidden pair is one left out of the "
            f"matrix; received {int(np.count_nonzero(np.isnan(data)))} stored NaN entries")
    if not np.all(np.isfinite(data)):
        bad = int(np.count_nonzero(~np.isfinite(data)))
        raise ValueError(
            f"`{name}` (sparse) must store finite costs only: a missing entry already forbids "
            f"the pair, so +inf is never stored, and -inf (an infinitely likely pair) is "
            f"refused; received {bad} infinite stored entries")
    return csr


def _solve_sparse(csr, th: float, miss: float | None) -> np.ndarray:
    """Optimal ``row_to_col`` of one gated sparse problem (validated inputs).

    The partial matching with a cost per unassigned report is the full matching
    of the rows into the columns plus one private dummy column per row:

    * an allowed pair (i, j) is an edge of weight :math:`c_{ij} - 2 c_0`, the
      dummy edge (i, n2 + i) has weight 0 — so the matching cost is
      :math:`\\sum_{\\text{pairs}} c_{ij} + c_0 (\\#\\text{unassigned rows} +
      \\#\\text{unassigned columns}) - c_0 (n_1 + n_2)`; pairs with
      :math:`c_{ij} \\ge 2 c_0` are never worth taking and are left out;
    * with no `miss_cost`, the largest number of pairs first: the dummy weight is
      larger than any saving among pairs (the lexicographic order of the dense
      solver).

    Every full matching saturates the n1 rows, so adding one constant to every
    weight keeps the optimum and makes all weights >= 1 (LAPJVsp needs non-zero
    weights). Solved by :func:`scipy.sparse.csgraph.min_weight_full_bipartite_matching`.
    """
    n1, n2 = csr.shape
    rows = np.repeat(np.arange(n1), np.diff(csr.indptr))
    cols = csr.indices
    c = csr.data
    keep = c < th
    if miss is not None:
        keep &= c < 2.0 * miss                 # scaled below; the comparison is exact in 2**k
    rows, cols, c = rows[keep], cols[keep], c[keep]
    out = np.full(n1, -1, dtype=int)
    if c.size == 0:
        return out
    e = int(np.frexp(max(float(np.max(np.abs(c))), 0.0 if miss is None else abs(miss)))[1])
    c = np.ldexp(c, -e)                        # exact: every |entry| < 1
    if miss is not None:
        gain = np.ldexp(2.0 * miss, -e) - c    # > 0: what taking the pair saves, < 4
        w_pair = float(np.max(gain)) + 1.0 - gain
        w_dummy = float(np.max(gain)) + 1.0
    else:
        lo, hi = float(np.min(c)), float(np.max(c))
        w_pair = c - lo + 1.0                  # in [1, 3)
        w_dummy = 2.0 * (min(n1, n2) + 1) * (hi - lo + 1.0) + 1.0
    graph = sparse.csr_array(
        (np.concatenate([w_pair, np.full(n1, w_dummy)]),
         (np.concatenate([rows, np.arange(n1)]), np.concatenate([cols, n2 + np.arange(n1)]))),
        shape=(n1, n1 + n2))
    r, col = min_weight_full_bipartite_matching(graph)
    real = col < n2
    out[r[real]] = col[real]
    return out


def _associate_sparse(cost, threshold, miss_cost) -> Association:
    """:func:`associate_joint` for a scipy.sparse matrix of gated pair costs."""
    csr = _as_sparse_cost(cost)
    th = _as_threshold(threshold)
    miss = _as_miss_cost(miss_cost)
    n1, n2 = csr.shape
    _limit(24 * (csr.nnz + n1), MEMORY_LIMIT, name="cost", what="bytes of the sparse graph",
           alternative="a tighter gate (fewer stored pairs)")
    row_to_col = _solve_sparse(csr, th, miss)
    assigned = row_to_col >= 0
    # the chosen pairs' stored costs: canonical CSR keys row * n2 + col are sorted
    keys = np.repeat(np.arange(n1, dtype=np.int64), np.diff(csr.indptr)) * n2 + csr.indices
    want = np.flatnonzero(assigned).astype(np.int64) * n2 + row_to_col[assigned]
    picked = csr.data[np.searchsorted(keys, want)]
    col_to_row = _inverse(row_to_col, n2)
    with np.errstate(over="ignore", invalid="ignore"):
        total = float(np.sum(picked))
        if miss is not None:
            total += miss * float((n1 - assigned.sum()) + (n2 - assigned.sum()))
    if not math.isfinite(total):
        raise ValueError(
            "`cost`: the total cost of the chosen association lies beyond the float range; "
            "divide `cost` (and `miss_cost`) by a common factor")
    return Association(row_to_col, col_to_row, total)


def associate_joint(cost, *, threshold=None, miss_cost=None) -> Association:
    """The joint maximum-likelihood association: an exact linear assignment.

    Parameters
    ----------
    cost : array_like, shape (..., n1, n2), or scipy.sparse matrix (n1, n2)
        Pair costs (proximity measures :math:`\\kappa_{ij}` or negative
        log-likelihoods); ``+inf`` forbids a pair; rectangular allowed.
        Leading axes are a batch (solved one matrix at a time). A
        ``scipy.sparse`` array or matrix holds the *gated* pairs only: a stored
        entry (an explicit 0 included) is an allowed pair, a missing entry a
        forbidden one (what ``+inf`` is in a dense matrix); it is solved by a
        sparse assignment (see Notes), in memory and time that grow with the
        stored pairs instead of :math:`n_1 n_2`
        (:func:`radarfusion_ref.gating.gate_sparse_2d` builds such a matrix).
    threshold : float, optional
        Gate :math:`\\gamma > 0`: a pair is allowed only if its cost is
        strictly below it, as in :func:`associate_pointwise` and
        :func:`radarfusion_ref.gating.in_gate`. None or ``+inf``: no gate.
    miss_cost : float, optional
        Cost charged for *each* report left unassigned, row or column alike
        (the convention of MATLAB's ``assignmunkres(cost, costOfNonAssignment)``);
        a pair is then used only if its cost is below ``2 * miss_cost``.
        ``+inf`` is the same as None.

    Returns
    -------
    Association

    Raises
    ------
    ValueError
        For NaN or ``-inf`` costs, an empty matrix, a threshold ≤ 0, a NaN
        / ``-inf`` miss cost, or a total cost beyond the float range (costs up
        to the float maximum are solved exactly; only a *sum* that cannot be
        represented is refused); for a sparse `cost`, also a stored NaN or
        infinite entry (leave a forbidden pair out instead) or a matrix that
        is not 2-D.
    TypeError
        For a sparse `cost` that does not hold real numbers.

    Notes
    -----
    By eqs. (5)–(6) the likelihood of a joint hypothesis :math:`H` (a pairing
    :math:`\\pi`) is the product of the pointwise likelihood measures, so its
    negative logarithm is :math:`\\tfrac12\\sum_j \\kappa_{j\\pi(j)}` plus a constant,
    and the ML hypothesis solves

    .. math::

        \\hat\\pi = \\arg\\min_{\\pi} \\sum_{i} c_{i\\pi(i)},

    a linear assignment problem (:func:`scipy.optimize.linear_sum_assignment`,
    :math:`O(n^3)`, instead of enumerating :math:`n!` hypotheses).

    * No `threshold`, no `miss_cost`: a complete assignment of
      :math:`\\min(n_1, n_2)` pairs of smallest total cost.
    * `threshold` only: the largest number of pairs within the gate, and among
      those the smallest total cost (the :math:`\\text{miss\\_cost}\\to\\infty`
      limit). All pairs gated out: no pairs, no error.
    * `miss_cost` :math:`c_0`: the partial assignment minimising
      :math:`\\sum_{\\text{pairs}} c_{ij} + c_0\\,(\\#\\text{unassigned rows} +
      \\#\\text{unassigned columns})`. This equals the standard augmented
      :math:`(n_1+n_2)` square problem with dummy rows and columns; it is
      solved exactly, without the augmentation, as one rectangular assignment
      of :math:`\\min(c_{ij} - 2c_0, 0)`.
    * Sparse `cost`: the same three problems on the stored pairs, as one
      full matching of the :math:`n_1` rows into the :math:`n_2` columns plus
      one private "unassigned" column per row — pair weight
      :math:`c_{ij} - 2c_0` (pairs with :math:`c_{ij} \\ge 2c_0` are left out),
      unassigned weight 0; without `miss_cost`, an unassigned weight larger than
      any saving among pairs, so the largest number of pairs comes first — by
      :func:`scipy.sparse.csgraph.min_weight_full_bipartite_matching` (LAPJVsp).
      Decisions equal the dense solver's on the same problem (``+inf`` where
      nothing is stored); gating plus assignment of :math:`10^4` reports per
      radar takes well under a second (``benchmarks/bench_association.py``).

    References
    ----------
    Grachov & Korneev (2010), eqs. (5)–(6) and the joint proximity measure
    :math:`\\kappa_n^* = \\sum_j \\kappa_j^*`; Crouse (2016).

    Examples
    --------
    >>> c = [[0.5, 0.1], [0.2, 3.0]]
    >>> r = associate_joint(c)
    >>> r.pairs.tolist(), r.total_cost
    ([[0, 1], [1, 0]], 0.30000000000000004)
    >>> r = associate_joint([[1.0, 9.0], [9.0, 9.0]], miss_cost=2.0)
    >>> r.pairs.tolist(), r.unassigned_rows.tolist(), r.unassigned_cols.tolist(), r.total_cost
    ([[0, 0]], [1], [1], 5.0)
    >>> associate_joint([[5.0, 6.0]], threshold=1.0).n_assigned
    0
    >>> from scipy import sparse
    >>> gated = sparse.csr_array(([0.5, 0.1, 0.2], ([0, 0, 1], [0, 1, 0])), shape=(2, 3))
    >>> associate_joint(gated).pairs.tolist()
    [[0, 1], [1, 0]]
    """
    if sparse.issparse(cost):
        return _associate_sparse(cost, threshold, miss_cost)
    c = _as_cost(cost)
    th = _as_threshold(threshold)
    miss = _as_miss_cost(miss_cost)
    n1, n2 = c.shape[-2:]
    flat = c.reshape(-1, n1, n2)
    out = _solve_batch(flat, th, miss)
    return _make_result(c, out.reshape(*c.shape[:-2], n1), miss)


# --------------------------------------------------------------------------- brute force
@lru_cache(maxsize=16)
def _permutations(n: int) -> np.ndarray:
    """All ``n!`` permutations of ``range(n)``, one per row (int8, read-only)."""
    perms = np.zeros((1, 0), dtype=np.int8)
    for k in range(n):
        m = perms.shape[0]
        out = np.empty((m * (k + 1), k + 1), dtype=np.int8)
        for pos in range(k + 1):
            block = out[pos * m:(pos + 1) * m]
            block[:, :pos] = perms[:, :pos]
            block[:, pos] = k
            block[:, pos + 1:] = perms[:, pos:]
        perms = out
    perms.setflags(write=False)
    return perms


@lru_cache(maxsize=16)
def _injections(n1: int, n2: int) -> np.ndarray:
    """All ``n2! / (n2 - n1)!`` injective maps rows -> columns (n1 <= n2)."""
    if n1 == n2:
        return _permutations(n1)
    out = np.array(list(itertools.permutations(range(n2), n1)), dtype=np.int8).reshape(-1, n1)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=16)
def _partial_matchings(n1: int, n2: int) -> np.ndarray:
    """Every partial matching as a ``row_to_col`` vector with -1 for unassigned."""
    rows = []
    for k in range(min(n1, n2) + 1):
        for rsel in itertools.combinations(range(n1), k):
            for cperm in itertools.permutations(range(n2), k):
                v = [-1] * n1
                for r, cc in zip(rsel, cperm, strict=True):
                    v[r] = cc
                rows.append(v)
    out = np.array(rows, dtype=np.int8).reshape(-1, n1)
    out.setflags(write=False)
    return out


def _n_partial(n1: int, n2: int) -> int:
    return sum(math.comb(n1, k) * math.perm(n2, k) for k in range(min(n1, n2) + 1))


def associate_bruteforce(cost, *, threshold=None, miss_cost=None) -> Association:
    """The joint ML association by enumerating every joint hypothesis.

    The reference route for :func:`associate_joint`: the same problem (same
    arguments, same meaning), solved by scoring every hypothesis. Square
    matrices without gate or miss cost enumerate the :math:`n!` permutations
    (chunked, vectorized); otherwise all partial matchings are scored.

    Parameters
    ----------
    cost : array_like, shape (..., n1, n2)
        As in :func:`associate_joint`.
    threshold, miss_cost : float, optional
        As in :func:`associate_joint`.

    Returns
    -------
    Association

    Raises
    ------
    ValueError
        As :func:`associate_joint`; and, before anything is allocated, if
        there are more than ``MAX_HYPOTHESES`` complete hypotheses
        (:math:`n > 10`), more than ``MAX_PARTIAL_MATCHINGS`` partial ones
        (gate / miss cost / forbidden pairs, e.g. :math:`8 \\times 8`), or more
        than ``MAX_SCORED_HYPOTHESES`` over the whole batch. The message names
        the scalable alternative, :func:`associate_joint`.

    Notes
    -----
    Grachov & Korneev's "optimal algorithm": full enumeration of the
    hypotheses :math:`H_n` and choice of the most plausible one, eq. (6).
    Among hypotheses of equal cost the first enumerated is returned.

    Examples
    --------
    >>> associate_bruteforce([[0.5, 0.1], [0.2, 3.0]]).row_to_col
    array([1, 0])
    """
    c = _as_cost(cost)
    th = _as_threshold(threshold)
    miss = _as_miss_cost(miss_cost)
    n1, n2 = c.shape[-2:]
    batch = c.shape[:-2]
    flat = c.reshape(-1, n1, n2)
    nb = flat.shape[0]
    allowed = (flat < th) & np.isfinite(flat)
    # Plain complete assignment: enumerate permutations. With a gate, a miss cost or
    # forbidden (+inf) pairs, score every partial matching instead.
    simple = th == np.inf and miss is None and bool(np.all(np.isfinite(flat)))
    if simple:
        transpose = n1 > n2
        a, b = min(n1, n2), max(n1, n2)
        count = _limit(math.perm(b, a), MAX_HYPOTHESES, name="cost",
                       what=f"joint hypotheses (n!-type count for a {n1} x {n2} matrix)",
                       alternative="associate_joint (exact linear assignment, O(n^3))")
    else:
        count = _limit(_n_partial(n1, n2), MAX_PARTIAL_MATCHINGS, name="cost",
                       what=f"partial matchings (gated or with a miss cost, {n1} x {n2} matrix)",
                       alternative="associate_joint (exact linear assignment, O(n^3))")
    _limit(nb * count, MAX_SCORED_HYPOTHESES, name="cost",
           what=f"hypotheses to score over a batch of {nb} matrices",
           alternative="associate_joint (exact linear assignment, O(n^3))")
    e = _exponents(flat, *(() if miss is None else (miss,)))
    scaled = _scaled(flat, e)                         # exact; sums of n entries cannot overflow
    if simple:
        work = np.swapaxes(scaled, 1, 2) if transpose else scaled
        hyps = _injections(a, b)
        best = np.full(nb, np.inf)
        best_k = np.zeros(nb, dtype=int)
        idx = np.arange(a)
        chunk = max(1, _BLOCK_BYTES // (8 * a * nb))   # bounded memory per block
        for start in range(0, hyps.shape[0], chunk):
            h = hyps[start:start + chunk]
            tot = work[:, idx, h].sum(axis=-1)            # (nb, chunk)
            k = tot.argmin(axis=1)
            v = tot[np.arange(nb), k]
            better = v < best
            best[better] = v[better]
            best_k[better] = start + k[better]
        chosen = hyps[best_k].astype(int)                 # (nb, a)
        out = _inverse(chosen, n1) if transpose else chosen
        return _make_result(c, out.reshape(*batch, n1), None)

    hyps = _partial_matchings(n1, n2).astype(int)         # (H, n1)
    used = hyps >= 0
    safe = np.maximum(hyps, 0)
    npairs = used.sum(axis=1)
    out = np.full((nb, n1), -1, dtype=int)
    for t in range(nb):
        ct = np.where(allowed[t], scaled[t], np.inf)
        vals = np.where(used, ct[np.arange(n1), safe], 0.0)
        ok = np.all(np.isfinite(vals), axis=1)
        total = vals.sum(axis=1)
        if miss is not None:
            m_t = np.ldexp(miss, -e[t])
            score = np.where(ok, total + m_t * (n1 + n2 - 2 * npairs), np.inf)
        else:
            top = npairs[ok].max()
            score = np.where(ok & (npairs == top), total, np.inf)
        out[t] = hyps[int(np.argmin(score))]
    return _make_result(c, out.reshape(*batch, n1), miss)


# --------------------------------------------------------------------------- Murty k-best
@dataclass(frozen=True)
class KBestAssignments:
    """The best joint hypotheses in order of increasing cost.

    Attributes
    ----------
    assignments : numpy.ndarray of int, shape (k_found, n1)
        ``assignments[r]`` is the ``row_to_col`` vector of the ``r``-th best
        complete assignment (every row assigned when ``n1 <= n2``; otherwise
        -1 marks the ``n1 - n2`` rows left out).
    costs : numpy.ndarray, shape (k_found,)
        Their total costs, non-decreasing.
    solved : int
        Number of assignment sub-problems solved exactly (a measure of work).
    """

    assignments: np.ndarray
    costs: np.ndarray
    solved: int

    @property
    def k(self) -> int:
        """Number of assignments found (fewer than asked if fewer exist)."""
        return int(self.costs.shape[0])


def _reduced_costs(m: np.ndarray, v0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reduced costs certifying the diagonal of ``m`` as an optimal assignment.

    ``m`` is ``(s, s)`` with ``+inf`` for forbidden pairs and an optimal
    assignment on its diagonal. Column potentials ``v`` with
    ``v_j - v_i <= m_ij - m_ii`` are found by Bellman–Ford (vectorized; an
    optimum has no negative cycle), started from ``v0`` — any finite start
    converges, and a parent's potentials converge in a few sweeps. With
    ``u_i = m_ii - v_i`` the reduced costs ``m_ij - u_i - v_j`` are >= 0 and vanish on
    the diagonal.

    Returns
    -------
    red : numpy.ndarray, shape (s, s)
        Reduced costs, clipped at 0, with ``+inf`` on the diagonal (an
        assignment's own pairs are excluded from the bounds).
    v : numpy.ndarray, shape (s,)
        The column potentials (a warm start for the children).
    """
    s = m.shape[0]
    diag = np.diagonal(m)
    w = m - diag[:, None]                     # edge i -> j (column i is held by row i)
    tol = 1e-12 * (1.0 + float(np.abs(diag).max()))
    v = v0
    for _ in range(s + 1):
        nv = np.min(v[:, None] + w, axis=0)
        if not (nv < v - tol).any():
            break
        v = np.minimum(v, nv)
    red = w + v[:, None]
    red -= v
    np.maximum(red, 0.0, out=red)
    red.flat[::s + 1] = np.inf
    return red, v


@lru_cache(maxsize=64)
def _not_upper(s: int) -> np.ndarray:
    """``+inf`` on and below the diagonal, 0 above (cached, read-only)."""
    out = np.where(np.triu(np.ones((s, s), dtype=bool), 1), 0.0, np.inf)
    out.setflags(write=False)
    return out


def k_best_assignments(cost, k) -> KBestAssignments:
    """Rank the `k` best complete assignments (joint hypotheses): Murty's algorithm.

    Parameters
    ----------
    cost : array_like, shape (n1, n2)
        Pair costs; ``+inf`` forbids a pair; rectangular allowed (then every
        report of the shorter side is assigned).
    k : int
        Number of hypotheses wanted (≥ 1).

    Returns
    -------
    KBestAssignments
        Fewer than `k` if fewer feasible assignments exist.

    Raises
    ------
    ValueError
        For NaN or ``-inf`` costs, an empty matrix, ``k < 1``, ``k >
        MAX_K_BEST``, a planned working memory (about ``_MURTY_BYTES_PER_NODE
        * k * n**2`` bytes) above ``MEMORY_LIMIT``, or a hypothesis total
        beyond the float range.
    TypeError
        If `k` is not an integer.

    Notes
    -----
    Murty's partitioning: after the best remaining solution :math:`\\pi` of a
    sub-problem (some pairs fixed, some forbidden) is output, its free rows
    :math:`r_1, \\dots, r_q` give :math:`q` disjoint children — child
    :math:`t` fixes :math:`r_1 \\dots r_{t-1}` to their columns in
    :math:`\\pi` and forbids :math:`(r_t, \\pi(r_t))`. Their union is every
    solution of the parent apart from :math:`\\pi`, so taking the best child
    solution overall, repeatedly, ranks all assignments exactly.

    Work is saved as in Miller, Stone & Cox (1997): with dual potentials of
    the parent's optimum (reduced costs :math:`\\bar c \\ge 0`), child
    :math:`t` costs at least

    .. math::

        C(\\pi) + \\min_{j \\ne \\pi(r_t)} \\bar c_{r_t j}
               + \\min_{i \\ne r_t} \\bar c_{i \\pi(r_t)},

    so children enter the queue with this bound and are solved
    (:func:`scipy.optimize.linear_sum_assignment` on the child's reduced
    matrix) only when the bound reaches the front. A rectangular problem is
    padded with zero-cost dummy rows, and only real rows are partitioned, so
    every assignment of the real rows appears once.

    References
    ----------
    Murty (1968); Miller, Stone & Cox (1997).

    Examples
    --------
    >>> r = k_best_assignments([[1.0, 2.0], [2.0, 5.0]], 5)
    >>> r.assignments.tolist(), r.costs.tolist()
    ([[1, 0], [0, 1]], [4.0, 6.0])
    """
    c = _as_cost(cost)
    if c.ndim != 2:
        raise ValueError(f"`cost` must be a single matrix (n1, n2); received shape {c.shape}")
    k = as_int(k, "k", minimum=1)
    _limit(k, MAX_K_BEST, name="k", what="ranked hypotheses",
           alternative="association_probabilities(cost) (exact, small n) or fewer hypotheses")
    n1, n2 = c.shape
    b0 = max(n1, n2)
    _limit(_MURTY_BYTES_PER_NODE * k * b0 * b0, MEMORY_LIMIT, name="k",
           what=f"bytes of Murty sub-problems (about {_MURTY_BYTES_PER_NODE} k n^2 for k = {k}, "
                f"n = {b0})",
           alternative="a smaller `k`, or associate_joint for the best hypothesis alone")
    transpose = n1 > n2
    e = int(_exponents(c))
    work = _scaled(c.T if transpose else c, e)             # exact power-of-two scaling
    a, b = work.shape                                      # a <= b real rows
    square = np.zeros((b, b))
    square[:a] = work
    is_real = np.arange(b) < a

    out_assign: list[np.ndarray] = []
    out_cost: list[float] = []
    counter = itertools.count()
    solved = 0

    def solve(mat):
        try:
            r, cc = linear_sum_assignment(mat)
        except ValueError:            # "cost matrix is infeasible"
            return None
        return cc, float(mat[r, cc].sum())

    root = solve(square)
    solved += 1
    heap: list = []
    exact_pending: list[float] = []     # sorted costs of solved, not yet output, nodes
    # An exact node: (row_ids, col_ids, matrix, fixed, offset, cols, v0) -- the
    # sub-problem's rows/columns (original indices), its matrix, the pairs fixed above it
    # (a chain (previous, rows, cols) shared with its siblings), their cost, its optimal
    # column per row, and a warm start for its duals.
    # A pending child: (parent, t) -- solved only when its lower bound reaches the front.
    if root is not None:
        cols, total = root
        node = (np.arange(b), np.arange(b), square, None, 0.0, cols, np.zeros(b))
        heapq.heappush(heap, (total, next(counter), True, node))
        exact_pending.append(total)
    while heap and len(out_assign) < k:
        bound, _, exact, node = heapq.heappop(heap)
        if not exact:
            (row_ids, col_ids, pm, fixed, offsets, v), t = node
            sub = pm[t:, t:].copy()
            sub[0, 0] = np.inf
            res = solve(sub)
            solved += 1
            if res is None:
                continue
            cols, total = res
            child = (row_ids[t:], col_ids[t:], sub, (fixed, row_ids[:t], col_ids[:t]),
                     offsets[t], cols, v[t:])
            heapq.heappush(heap, (offsets[t] + total, next(counter), True, child))
            bisect.insort(exact_pending, offsets[t] + total)
            continue
        exact_pending.pop(0)
        row_ids, col_ids, mat, fixed, offset, cols, v0 = node
        out_assign.append((fixed, row_ids, col_ids[cols]))
        out_cost.append(bound)
        need = k - len(out_assign)
        if need == 0:
            break
        real = is_real[row_ids]
        m_real = int(np.count_nonzero(real))
        if m_real == 0:
            continue
        # Solved nodes already queued give an upper bound on the k-th best cost: a
        # child whose lower bound exceeds it can never be output.
        upper = exact_pending[need - 1] if len(exact_pending) >= need else np.inf
        # Solution on the diagonal, then reduced costs.
        pm = mat[:, cols]
        red, v = _reduced_costs(pm, v0[cols])
        # Partition order (Miller et al.): real rows whose children are likely needed
        # (small bound) go last, where their sub-problems are smallest; dummies after.
        loose = red.min(axis=1) + red.min(axis=0)
        if m_real == len(real):
            order = np.argsort(-loose, kind="stable")
        else:
            idx_real = np.flatnonzero(real)
            order = np.concatenate([idx_real[np.argsort(-loose[idx_real], kind="stable")],
                                    np.flatnonzero(~real)])
        pm, red = pm[order][:, order], red[order][:, order]
        mask = _not_upper(red.shape[0])
        row_min = np.min(red + mask, axis=1)      # row r_t to a column s_tau, tau > t
        col_min = np.min(red + mask.T, axis=0)    # column s_t from a row r_tau, tau > t
        lb = (bound - 1e-9 * (1.0 + abs(bound))) + (row_min + col_min)[:m_real]
        keep = np.flatnonzero(lb <= upper)
        if keep.size == 0:
            continue
        # child t's fixed cost: this node's offset plus its first t diagonal entries
        offsets = (offset + np.concatenate([[0.0], np.cumsum(np.diagonal(pm))])).tolist()
        parent = (row_ids[order], col_ids[cols][order], pm, fixed, offsets, v[order])
        for t, val in zip(keep.tolist(), lb[keep].tolist(), strict=True):
            heapq.heappush(heap, (val, next(counter), False, (parent, t)))

    rows_out = []
    for fixed, rids, cids in out_assign:
        full = np.empty(b, dtype=int)
        full[rids] = cids
        while fixed is not None:
            fixed, frows, fcols = fixed
            full[frows] = fcols
        rows_out.append(full[:a])
    out_assign = rows_out
    assign = np.array(out_assign, dtype=int).reshape(-1, a)
    if transpose:
        assign = _inverse(assign, n1) if assign.size else np.empty((0, n1), dtype=int)
    with np.errstate(over="ignore"):
        costs = np.ldexp(np.array(out_cost, dtype=float), e)
    if not np.all(np.isfinite(costs)):
        raise ValueError(
            "`cost`: a ranked hypothesis's total cost lies beyond the float range "
            f"(|total| > {np.finfo(float).max:.3g}); divide `cost` by a common factor")
    return KBestAssignments(assign, costs, solved)


# --------------------------------------------------------------------------- marginals
def association_probabilities(cost, *, k=None) -> np.ndarray:
    """Marginal probabilities that report ``i`` of radar 1 and ``j`` of radar 2 match.

    Parameters
    ----------
    cost : array_like, shape (n1, n2)
        **Negative log-likelihoods** of the pairs (for the proximity measure,
        :math:`\\kappa/2`), so a joint hypothesis :math:`\\pi` has likelihood
        proportional to :math:`\\exp(-\\sum_i c_{i\\pi(i)})`; ``+inf`` forbids.
    k : int, optional
        None (default): exact, by enumerating every complete assignment (small
        matrices only). An integer: the approximation from the `k` best
        hypotheses of :func:`k_best_assignments`.

    Returns
    -------
    numpy.ndarray, shape (n1, n2)
        :math:`P(i \\leftrightarrow j)`; rows (of the shorter side) sum to 1.

    Raises
    ------
    ValueError
        For invalid costs, ``k < 1``, no feasible assignment, or, before
        anything is allocated, more than ``MAX_HYPOTHESES`` hypotheses to
        enumerate exactly (the message points to the `k`-best route) or a `k`
        beyond the limits of :func:`k_best_assignments`.

    Notes
    -----
    With equal priors over the complete hypotheses,

    .. math::

        P(i \\leftrightarrow j) = \\frac{\\sum_{\\pi:\\,\\pi(i) = j} e^{-C(\\pi)}}
                                       {\\sum_{\\pi} e^{-C(\\pi)}},

    computed with the log-sum-exp shift so nothing underflows. Truncating the
    sums to the :math:`k` best :math:`\\pi` is the usual approximation; it is
    exact when the neglected hypotheses carry negligible weight.

    Examples
    --------
    >>> p = association_probabilities([[0.0, 1.0], [1.0, 0.0]])
    >>> np.round(p, 4)
    array([[0.8808, 0.1192],
           [0.1192, 0.8808]])
    """
    c = _as_cost(cost)
    if c.ndim != 2:
        raise ValueError(f"`cost` must be a single matrix (n1, n2); received shape {c.shape}")
    n1, n2 = c.shape
    transpose = n1 > n2
    w = c.T if transpose else c
    a, b = w.shape
    e = int(_exponents(c))
    ws = _scaled(w, e)                  # exact; hypothesis sums of scaled costs cannot overflow
    p = np.zeros((a, b))
    if k is None:
        _limit(math.perm(b, a), MAX_HYPOTHESES, name="cost",
               what=f"joint hypotheses to enumerate exactly (a {n1} x {n2} matrix)",
               alternative="association_probabilities(cost, k=...) (Murty's k best)")
        hyps = _injections(a, b)                             # int8, cached, read-only
        rows = np.arange(a)
        chunk = max(1, _BLOCK_BYTES // (8 * a))
        blocks = range(0, hyps.shape[0], chunk)
        best = min(float(ws[rows, hyps[s0:s0 + chunk]].sum(axis=1).min()) for s0 in blocks)
        if not np.isfinite(best):
            raise ValueError("`cost` admits no feasible complete assignment (every hypothesis "
                             "uses a forbidden +inf pair)")
        for s0 in blocks:                                    # memory bounded per block
            h = hyps[s0:s0 + chunk].astype(np.intp)
            with np.errstate(over="ignore"):
                wts = np.exp(-np.ldexp(ws[rows, h].sum(axis=1) - best, e))
            for i in range(a):
                p[i] += np.bincount(h[:, i], weights=wts, minlength=b)
    else:
        kb = k_best_assignments(ws, k)          # rows = the shorter side; scaled: same ranking
        assign, costs = kb.assignments, kb.costs
        finite = np.isfinite(costs)
        if not finite.any():
            raise ValueError("`cost` admits no feasible complete assignment (every hypothesis "
                             "uses a forbidden +inf pair)")
        assign, costs = assign[finite], costs[finite]
        with np.errstate(over="ignore"):
            wts = np.exp(-np.ldexp(costs - costs.min(), e))
        for i in range(a):
            p[i] += np.bincount(assign[:, i], weights=wts, minlength=b)
    p /= p[0].sum()
    return p.T if transpose else p


# --------------------------------------------------------------------------- non-assignment cost
def non_assignment_cost(*, p_detect1, p_detect2, false_density1, false_density2,
                        object_density, innovation_cov=None, logdet: bool = False):
    """Per-report non-assignment cost (in proximity units) from the likelihood ratio.

    Parameters
    ----------
    p_detect1, p_detect2 : float or array_like
        Detection probabilities :math:`P_{D,1}, P_{D,2}` of the two radars, in (0, 1].
    false_density1, false_density2 : float or array_like
        False-report densities :math:`\\rho_{F,1}, \\rho_{F,2}` (expected false
        reports per unit volume of the measurement space), ≥ 0.
    object_density : float or array_like
        Density :math:`\\rho_T > 0` of objects (per unit volume).
    innovation_cov : float or array_like, shape (..., d, d) or scalar
        :math:`S = \\Sigma_1 + \\Sigma_2`, the covariance of the difference of
        two reports of one object (a scalar is a 1-D variance). Symmetric
        positive definite; variances from 1e-300 to 1e300 are handled.
        Required with ``logdet=False``; optional with ``logdet=True`` (then
        only validated and broadcast: the pair costs carry the determinant).
    logdet : bool, optional
        False (default): the cost for a matrix of proximity measures
        :math:`\\kappa_{ij}` (``proximity_matrix(...)``), which holds
        :math:`-\\tfrac12\\ln\\det(2\\pi S)` for the one `innovation_cov`. True:
        the cost for a matrix of full ML costs :math:`\\kappa_{ij} +
        \\ln\\det(2\\pi S_{ij})` (``proximity_matrix(..., logdet=True)``), right when
        :math:`S_{ij}` differs from pair to pair.

    Returns
    -------
    float or numpy.ndarray
        The cost :math:`c_0` to pass as ``miss_cost`` to :func:`associate_joint`
        with a cost matrix of proximity measures :math:`\\kappa_{ij}`; ``+inf``
        when no report can be left unassigned (both radars detect everything
        and report nothing false). Array arguments broadcast together.

    Raises
    ------
    ValueError
        For probabilities outside (0, 1], negative densities, a non-positive
        object density, an invalid covariance or shapes that do not broadcast.
    TypeError
        For bools, strings or None where numbers are expected.

    Warns
    -----
    RadarFusionWarning
        If :math:`c_0 \\le 0`: no pair with :math:`\\kappa \\ge 0` can beat
        leaving both reports unassigned. (``logdet=False`` only: the full
        costs of ``logdet=True`` may be negative).

    Notes
    -----
    Objects form a Poisson field of density :math:`\\rho_T`; radar :math:`r`
    detects each with probability :math:`P_{D,r}` and adds false reports of
    density :math:`\\rho_{F,r}`. Integrating the unknown position out, a pair
    :math:`(i, j)` contributes :math:`\\rho_T P_{D,1} P_{D,2}\\, \\mathcal N(\\hat x_{1i} -
    \\hat x_{2j}; 0, S)` to the likelihood of a hypothesis and an unpaired
    report :math:`u_r = \\rho_{F,r} + \\rho_T P_{D,r} (1 - P_{D,\\bar r})` (a false
    report, or an object the other radar missed). Pairing beats leaving both
    reports unpaired iff

    .. math::

        \\kappa_{ij} < 2\\ln\\frac{\\rho_T P_{D,1} P_{D,2}}{u_1 u_2} - \\ln\\det(2\\pi S)
        = 2c_0,

    and, with ``logdet=True``, :math:`c_0 = \\ln(\\rho_T P_{D,1} P_{D,2}/(u_1 u_2))`
    against the costs :math:`\\kappa_{ij} + \\ln\\det(2\\pi S_{ij})`,

    and with cost :math:`c_0` per unassigned report the assignment cost
    :math:`\\sum \\kappa + c_0\\,(\\#\\text{unassigned})` is, up to a constant,
    :math:`-2\\ln` of the hypothesis likelihood (the book's eq.
    ``eq-non-assignment-cost``). Everything is computed in the log domain
    (:func:`numpy.logaddexp` for :math:`\\ln u_r`, :math:`\\ln\\det S` through
    the correlation matrix), so no density or variance in the float range
    overflows or underflows.

    References
    ----------
    Grachov & Korneev (2010) list false reports and missed detections among
    the real-world uncertainties (problem statement) and then assume them
    away; the cost follows Deb et al. (1997) and Bar-Shalom et al. (2011).

    Examples
    --------
    >>> m = non_assignment_cost(p_detect1=0.9, p_detect2=0.9, false_density1=0.1,
    ...                         false_density2=0.1, object_density=1.0, innovation_cov=0.02)
    >>> round(float(m), 4)
    4.1478
    >>> m_full = non_assignment_cost(p_detect1=0.9, p_detect2=0.9, false_density1=0.1,
    ...                              false_density2=0.1, object_density=1.0, logdet=True)
    >>> round(float(m_full - m), 4)          # = ln(2 pi 0.02) / 2
    -1.0371
    """
    with_logdet = as_bool(logdet, "logdet")
    if innovation_cov is None and not with_logdet:
        raise TypeError("`innovation_cov` is required with `logdet=False` (the covariance S of "
                        "the difference of two reports of one object); received None")
    p1 = as_probability(p_detect1, "p_detect1", open_interval=False)
    p2 = as_probability(p_detect2, "p_detect2", open_interval=False)
    for name, p, raw in (("p_detect1", p1, p_detect1), ("p_detect2", p2, p_detect2)):
        if np.any(p <= 0):
            raise ValueError(f"`{name}` must lie in (0, 1]; received {_describe(raw)}")
    lam1 = as_positive(false_density1, "false_density1", strict=False)
    lam2 = as_positive(false_density2, "false_density2", strict=False)
    beta = as_positive(object_density, "object_density")
    s = as_float_array(0.0 if innovation_cov is None else innovation_cov, "innovation_cov")
    if innovation_cov is None:
        logdet = s
    elif s.ndim < 2:
        s = as_positive(s, "innovation_cov")
        logdet = np.log(2 * np.pi) + np.log(s)                 # no overflow of 2 pi S
    else:
        s = as_covariance(s, "innovation_cov")
        d = s.shape[-1]
        # ln det S = 2 sum ln sd_i + ln det R with the correlation matrix R: no overflow or
        # underflow whatever the variances' scales (1e-300 beside 1e300 included).
        sd = np.sqrt(np.diagonal(s, axis1=-2, axis2=-1))
        corr = s / sd[..., :, None] / sd[..., None, :]
        chol = np.linalg.cholesky(corr)
        logdet = d * np.log(2 * np.pi) + 2 * np.sum(np.log(sd), axis=-1) + 2 * np.sum(
            np.log(np.diagonal(chol, axis1=-2, axis2=-1)), axis=-1)
    p1, p2, lam1, lam2, beta, logdet = broadcast(
        p_detect1=p1, p_detect2=p2, false_density1=lam1, false_density2=lam2,
        object_density=beta, innovation_cov=logdet)
    # Log domain throughout: ln u_r = ln(rho_F,r + rho_T P_r (1 - P_other)) by logaddexp,
    # so neither tiny nor huge densities overflow or underflow.
    with np.errstate(divide="ignore"):
        lb = np.log(beta)
        log_u1 = np.logaddexp(np.log(lam1), lb + np.log(p1) + np.log1p(-p2))
        log_u2 = np.logaddexp(np.log(lam2), lb + np.log(p2) + np.log1p(-p1))
    m = lb + np.log(p1) + np.log(p2) - log_u1 - log_u2
    # with logdet=True a given `innovation_cov` only shapes the result (0 * its log det)
    m = m + (0.0 if with_logdet else -0.5) * logdet
    # (full costs kappa + ln det 2 pi S may be negative, so c_0 <= 0 is no alarm there)
    if not with_logdet and np.any(m <= 0):
        warnings.warn(
            "non-assignment cost <= 0: no pair with proximity >= 0 beats leaving both "
            "reports unassigned (false-report density too high for this accuracy)",
            RadarFusionWarning, stacklevel=2)
    return float(m) if np.ndim(m) == 0 else m


# --------------------------------------------------------------------------- scenes
#: The two-radar scene with misses and false reports; its home is
#: :mod:`radarfusion_ref.scenes` (the same function and class, under their names here).
ClutterScene = scenes.ClutterScene
two_radar_clutter_scene = scenes.two_radar_clutter_scene


def proximity_matrix(reports1, reports2, sigma1, sigma2, *, logdet: bool = False) -> np.ndarray:
    """All pairwise proximity measures :math:`\\kappa_{ij}` (or full ML costs) of two report lists.

    A thin wrapper that broadcasts :func:`radarfusion_ref.proximity.mahalanobis_sq`
    over every (radar-1, radar-2) pair.

    Parameters
    ----------
    reports1, reports2 : array_like, shape (..., n1, d) and (..., n2, d)
    sigma1, sigma2 : float or array_like, shape (..., n1) and (..., n2)
        Per-coordinate error standard deviations: one number per radar, or one
        per report (each report's covariance is :math:`\\sigma^2 I`); arrays
        broadcast against the reports' leading axes.
    logdet : bool, optional
        False (default): the proximity measure :math:`\\kappa_{ij}` alone.
        True: the full maximum-likelihood cost
        :math:`c_{ij} = \\kappa_{ij} + \\ln\\det(2\\pi S_{ij})`, :math:`-2\\ln` of the
        likelihood :math:`\\mathcal N(\\hat x_{1i} - \\hat x_{2j}; 0, S_{ij})` of the pair
        with the object's position integrated out, :math:`S_{ij} = (\\sigma_{1i}^2 +
        \\sigma_{2j}^2) I`. Pass it with ``non_assignment_cost(..., logdet=True)``.

    Returns
    -------
    numpy.ndarray, shape (..., n1, n2)
        :math:`\\kappa_{ij} = \\lVert \\hat x_{1i} - \\hat x_{2j}\\rVert^2 /
        (\\sigma_{1i}^2 + \\sigma_{2j}^2)` — the exponent of eq. (7) (times −2) — plus
        :math:`d\\ln(2\\pi(\\sigma_{1i}^2 + \\sigma_{2j}^2))` with ``logdet=True``.

    Raises
    ------
    ValueError
        For reports of different dimensions or unbroadcastable batch axes, sigmas
        that are not > 0 or do not broadcast against the reports, and sizes
        beyond the memory limit.
    TypeError
        For non-numeric input or a `logdet` that is not a bool.

    Notes
    -----
    With one variance per radar the log-determinant is the same for every
    pair: it cannot change which complete pairing is best, only how a pair
    compares with leaving its reports unassigned. With one variance per report
    it is not a sum of a row term and a column term, and it can change the
    joint decision (the book's page on the full ML cost). It is computed in the log
    domain, :math:`\\ln(\\sigma_1^2 + \\sigma_2^2)` by :func:`numpy.logaddexp`, so
    no variance in the float range overflows.

    Examples
    --------
    >>> proximity_matrix([[0.0], [1.0]], [[0.5]], 0.3, 0.4)
    array([[1.],
           [1.]])
    >>> proximity_matrix([[0.0]], [[0.5]], 0.3, 0.4, logdet=True).round(4)   # 1 + ln(2 pi 0.25)
    array([[1.4516]])
    """
    r1 = as_float_array(reports1, "reports1", ndim_min=2)
    r2 = as_float_array(reports2, "reports2", ndim_min=2)
    with_logdet = as_bool(logdet, "logdet")
    if r1.shape[-1] != r2.shape[-1]:
        raise ValueError("`reports1` and `reports2` must have the same last dimension d; "
                         f"received shapes {r1.shape} and {r2.shape}")
    sd1 = as_positive(sigma1, "sigma1")
    sd2 = as_positive(sigma2, "sigma2")
    shapes = []
    for name, sd, r in (("sigma1", sd1, r1), ("sigma2", sd2, r2)):
        try:
            shapes.append(np.broadcast_shapes(sd.shape, r.shape[:-1]))
        except ValueError:
            raise ValueError(f"`{name}` must be one number or one per report, broadcasting "
                             f"against the reports' shape without d {r.shape[:-1]}; received "
                             f"shape {sd.shape}") from None
        if shapes[-1][-1] != r.shape[-2]:
            raise ValueError(f"`{name}` must be one number or one per report (last axis "
                             f"{r.shape[-2]}); received shape {sd.shape}")
    try:
        batch = np.broadcast_shapes(shapes[0][:-1], shapes[1][:-1])
    except ValueError:
        raise ValueError("`reports1` and `reports2` (with `sigma1`, `sigma2`) must have "
                         f"broadcastable leading (batch) axes; received shapes {r1.shape}, "
                         f"{r2.shape}, {sd1.shape} and {sd2.shape}") from None
    n1, n2, d = r1.shape[-2], r2.shape[-2], r1.shape[-1]
    per_report = sd1.ndim > 0 or sd2.ndim > 0
    per_pair = d + d * d if per_report else d
    _limit(math.prod(batch) * n1 * n2 * per_pair * 8 * 4, MEMORY_LIMIT, name="reports1",
           what=f"bytes of pair differences ({math.prod(batch)} x {n1} x {n2} pairs, d = {d})",
           alternative="fewer trials per call (split the batch)")
    eye = np.eye(d)
    if not per_report:
        v1, v2 = float(sd1) ** 2, float(sd2) ** 2
        out = mahalanobis_sq(r1[..., :, None, :], r2[..., None, :, :], v1 * eye, v2 * eye)
    else:
        v1, v2 = np.square(np.atleast_1d(sd1)), np.square(np.atleast_1d(sd2))
        if not (np.all(np.isfinite(v1)) and np.all(v1 > 0) and np.all(np.isfinite(v2))
                and np.all(v2 > 0)):
            raise ValueError("`sigma1` and `sigma2` must have squares within the float range "
                             f"(1e-154 < sigma < 1e154); received {_describe(sd1)} and "
                             f"{_describe(sd2)}")
        c1 = v1[..., :, None, None, None] * eye               # (..., n1, 1, d, d)
        c2 = v2[..., None, :, None, None] * eye               # (..., 1, n2, d, d)
        out = mahalanobis_sq(r1[..., :, None, :], r2[..., None, :, :], c1, c2)
    out = np.asarray(out, dtype=float)
    if with_logdet:
        # ln det(2 pi S) = d (ln 2 pi + ln(s1^2 + s2^2)), ln(s1^2 + s2^2) by logaddexp
        l1 = 2 * np.log(np.atleast_1d(sd1))[..., :, None]
        l2 = 2 * np.log(np.atleast_1d(sd2))[..., None, :]
        out = out + d * (math.log(2 * math.pi) + np.logaddexp(l1, l2))
    return out


# --------------------------------------------------------------------------- Monte Carlo
def all_correct(decided, truth) -> np.ndarray:
    """Per trial: did the decisions match the truth exactly (pairs and non-pairs)?

    Parameters
    ----------
    decided, truth : array_like of int, shape (..., n1)
        ``row_to_col`` vectors (-1 = unassigned).

    Returns
    -------
    numpy.ndarray of bool, shape (...)

    Raises
    ------
    TypeError
        If either is not an integer array (bools, strings, fractional floats).
    ValueError
        If either is empty, has entries below -1, or the shapes differ.

    Examples
    --------
    >>> all_correct([[0, 1], [1, 0]], [[0, 1], [0, 1]])
    array([ True, False])
    """
    d = _as_decisions(decided, "decided")
    t = _as_decisions(truth, "truth")
    if d.shape != t.shape:
        raise ValueError(f"`decided` and `truth` must have the same shape (..., n1); received "
                         f"{d.shape} and {t.shape}")
    return np.all(d == t, axis=-1)


@dataclass(frozen=True)
class DecisionComparison:
    """Probability that every pairing is correct, for three procedures.

    Attributes
    ----------
    pointwise : Proportion
        The paper's pointwise rule as written (scan order, gate on each pair).
    greedy : Proportion
        Greedy best-first with the same gate.
    joint : Proportion
        Joint ML (:func:`associate_joint`), followed by the paper's joint
        test (:math:`\\kappa_n^* < \\gamma_n`, the :math:`\\chi^2_n` gate; rejection counts as
        a wrong decision).
    joint_ml : Proportion
        Joint ML alone (no test).
    """

    pointwise: Proportion
    greedy: Proportion
    joint: Proportion
    joint_ml: Proportion


def compare_decisions(kappa, truth, *, threshold, joint_threshold) -> DecisionComparison:
    """Monte-Carlo decision-level comparison of pointwise, greedy and joint association.

    Parameters
    ----------
    kappa : array_like, shape (trials, n, n)
        Proximity measures of each simulated scene.
    truth : array_like of int, shape (trials, n)
        Correct ``row_to_col`` of each scene.
    threshold : float or None
        Pointwise gate :math:`\\gamma` (1 hypothesis, e.g.
        ``gating.gate_threshold(P_lo, d)``); None or ``+inf``: no gate.
    joint_threshold : float or None
        Joint gate on :math:`\\kappa_n^*` (e.g. ``gating.gate_threshold(P_lo, n * d)``);
        None or ``+inf``: no joint test.

    Returns
    -------
    DecisionComparison
        Each field a :class:`~radarfusion_ref.montecarlo.Proportion` carrying
        its trial count and 95 % Wilson interval.

    Raises
    ------
    ValueError
        For an invalid `kappa` (see :func:`associate_joint`), a `truth` of the
        wrong shape or with indices out of range, or a threshold <= 0.
    TypeError
        For a non-integer `truth`.

    Examples
    --------
    >>> k = np.array([[[0.1, 4.0], [5.0, 0.2]]] * 3)
    >>> r = compare_decisions(k, [[0, 1]] * 3, threshold=6.6, joint_threshold=9.2)
    >>> float(r.joint.estimate)
    1.0
    """
    c = _as_cost(kappa, "kappa")
    if c.ndim != 3:
        raise ValueError(f"`kappa` must have shape (trials, n1, n2); received shape {c.shape}")
    truth = _as_decisions(truth, "truth")
    if truth.shape != c.shape[:-1]:
        raise ValueError(f"`truth` must have shape (trials, n1) = {c.shape[:-1]} to match "
                         f"`kappa`; received shape {truth.shape}")
    if np.any(truth >= c.shape[-1]):
        raise ValueError(f"`truth` entries must be radar-2 indices < n2 = {c.shape[-1]} or -1; "
                         f"received largest entry {int(truth.max())}")
    th = _as_threshold(threshold)
    jth = _as_threshold(joint_threshold, "joint_threshold")
    pw = associate_pointwise(c, th, order="scan")
    gr = associate_pointwise(c, th, order="best_first")
    jt = associate_joint(c)
    ok_j = all_correct(jt.row_to_col, truth)
    passed = np.asarray(jt.total_cost) < jth
    return DecisionComparison(
        proportion(all_correct(pw.row_to_col, truth), None),
        proportion(all_correct(gr.row_to_col, truth), None),
        proportion(ok_j & passed, None),
        proportion(ok_j, None),
    )
