"""Assignment solvers: the 2-D (two lists) and S-D (many lists) assignment problems.

One home for the solvers shared by the association (chapter 4), the separated
radars (chapter 7) and the grouping of many sources (chapter 8):
:mod:`radarfusion_ref.association` and :mod:`radarfusion_ref.grouping` build
costs from reports and call the functions here.

.. rubric:: Public functions

* :func:`solve_2d` — the minimum-cost 2-D assignment of a dense cost matrix
  (batched) or a gated ``scipy.sparse`` one, with an optional gate and a
  per-report non-assignment cost; :func:`solve_2d_bruteforce` — the same
  optimum by enumeration (the reference route, small matrices);
  :func:`k_best_2d` — Murty's ranking of the ``k`` best complete assignments;
* :func:`solve_sd` — the S-D assignment (one report of each of ``m`` sources
  per group) over a full cost tensor or over explicit candidate groups
  (gated, with ``-1`` for a source without a report in a group): exact
  (``method="milp"``, HiGHS) or to a proved relative duality gap
  (``method="lagrangian"``); :func:`solve_sd_bruteforce` — the exact optimum
  of a full tensor by enumerating the :math:`(n!)^{m-1}` groupings.

.. rubric:: One result vocabulary

Every result — :class:`Association` (2-D), :class:`KBestAssignments` (ranked
2-D), :class:`SDAssignment` (S-D) and
:class:`radarfusion_ref.grouping.GroupingResult` — follows the
:class:`AssignmentResult` protocol: ``assignment`` (the decisions),
``cost`` (their total cost), ``lower_bound`` (a proved lower bound on the
optimal cost), ``gap`` (the proved relative gap
:math:`(\\text{cost} - \\text{lower bound})/\\max(|\\text{cost}|, 1)`),
``history`` (bound and cost per iteration, or None) and ``exact`` (whether
the result is a proved optimum). Their older field names (``row_to_col``,
``total_cost``, ``assignments``, ``costs``, ``groups``) keep working.

.. rubric:: Conventions

A cost is a negative log-likelihood (or a proximity measure
:math:`\\kappa`): ``+inf`` forbids a pair or a group in a dense array, a
missing entry forbids it in a sparse matrix; NaN and ``-inf`` are refused, as
is a stored ``+inf``, NaN or ``-inf`` in a sparse matrix.

.. rubric:: References

.. [1] K. G. Murty, "An algorithm for ranking all the assignments in order of
   increasing cost", Operations Research 16 (1968) 682–687.
.. [2] M. L. Miller, H. S. Stone, I. J. Cox, "Optimizing Murty's ranked
   assignment method", IEEE Trans. AES 33 (1997) 851–862.
.. [3] D. F. Crouse, "On implementing 2D rectangular assignment algorithms",
   IEEE Trans. AES 52 (2016) 1679–1696.
.. [4] S. Deb, M. Yeddanapudi, K. Pattipati, Y. Bar-Shalom, "A generalized S-D
   assignment algorithm for multisensor-multitarget state estimation", IEEE
   Trans. AES 33 (1997) 523–538.
"""

from __future__ import annotations

import bisect
import functools
import heapq
import itertools
import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Protocol, runtime_checkable

import numpy as np
from scipy import sparse
from scipy.optimize import Bounds, LinearConstraint, linear_sum_assignment, linprog, milp
from scipy.sparse.csgraph import min_weight_full_bipartite_matching

from ._validation import (
    MEMORY_LIMIT,
    _describe,
    as_bool,
    as_choice,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    check_size,
)

__all__ = [
    "MAX_HYPOTHESES",
    "MAX_K_BEST",
    "MAX_PARTIAL_MATCHINGS",
    "MAX_SCORED_HYPOTHESES",
    "MAX_SD_GROUPINGS",
    "MAX_SD_TUPLES",
    "Association",
    "AssignmentResult",
    "KBestAssignments",
    "SDAssignment",
    "k_best_2d",
    "solve_2d",
    "solve_2d_bruteforce",
    "solve_sd",
    "solve_sd_bruteforce",
]


# --------------------------------------------------------------------------- vocabulary
@runtime_checkable
class AssignmentResult(Protocol):
    """What every assignment result provides (a protocol: any class with these attributes).

    Attributes
    ----------
    assignment : numpy.ndarray of int
        The decisions: ``row_to_col`` for a 2-D assignment, the ranked
        ``row_to_col`` vectors for the ``k`` best, the chosen groups (rows of
        report indices, ``-1`` for a source without a report) for S-D.
    cost : float or numpy.ndarray
        Total cost of the decisions (per ranked hypothesis or per batch entry).
    lower_bound : float or numpy.ndarray
        A proved lower bound on the optimal total cost (the cost itself for an
        exact solver).
    gap : float or numpy.ndarray
        Proved relative gap :math:`(\\text{cost} - \\text{lower bound}) /
        \\max(|\\text{cost}|, 1)`, never negative; 0 for an exact solver.
    history : numpy.ndarray or None
        Iterative solvers: the lower bound and the best cost after each
        iteration, shape (iterations, 2); None otherwise.
    exact : bool
        True when the result is a proved optimum (gap 0).
    """

    assignment: np.ndarray
    cost: np.ndarray | float
    lower_bound: np.ndarray | float
    gap: np.ndarray | float
    history: np.ndarray | None
    exact: bool


def _gap_of(total, lower):
    """Proved relative gap (cost - lower bound) / max(|cost|, 1), never negative."""
    return max(0.0, (float(total) - float(lower)) / max(abs(float(total)), 1.0))


def _as_gap(gap, name: str = "gap") -> float:
    """A relative gap: one number in the open interval (0, 1)."""
    g = as_probability(gap, name)
    if g.ndim:
        raise ValueError(f"`{name}` must be a number in the open interval (0, 1); received "
                         f"shape {g.shape}")
    return float(g)


# --------------------------------------------------------------------------- 2-D limits
#: Largest number of joint hypotheses of one cost matrix that
#: :func:`solve_2d_bruteforce` and the exact :func:`radarfusion_ref.association.association_probabilities`
#: enumerate (:math:`10! = 3\,628\,800` fits; :math:`n = 11` does not).
MAX_HYPOTHESES = 4_000_000


#: Largest number of *partial* matchings :func:`solve_2d_bruteforce` scores
#: when a gate, a non-assignment cost or forbidden pairs are given (7 x 7 fits).
MAX_PARTIAL_MATCHINGS = 200_000


#: Largest number of hypotheses :func:`solve_2d_bruteforce` scores in one call,
#: summed over a batch of cost matrices (bounds its run time).
MAX_SCORED_HYPOTHESES = 200_000_000


#: Largest `k` of :func:`k_best_2d` (and ``association_probabilities(k=...)``).
MAX_K_BEST = 100_000


#: Planned bytes per ranked hypothesis and matrix entry in :func:`k_best_2d`
#: (sub-problem matrices kept for pending children): the memory limit is checked
#: against ``_MURTY_BYTES_PER_NODE * k * n**2``.
_MURTY_BYTES_PER_NODE = 32


#: Working memory of one vectorized block of the enumerations, in bytes.
_BLOCK_BYTES = 1 << 25




# --------------------------------------------------------------------------- 2-D validation
def _limit(requested, limit, *, name: str, what: str, alternative: str) -> int:
    """:func:`radarfusion_ref.engine._validation.check_size`, with the public argument named in the message."""
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




# --------------------------------------------------------------------------- 2-D results
class _Exact:
    """The shared part of the exact 2-D results: no iterations, a proved optimum."""

    @property
    def history(self) -> None:
        """None: the 2-D solvers are not iterative."""
        return None

    @property
    def exact(self) -> bool:
        """True: a proved optimum (or an exact ranking)."""
        return True


@dataclass(frozen=True)
class Association(_Exact):
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
    assignment, cost, lower_bound, gap, history, exact
        (properties) the :class:`AssignmentResult` vocabulary: ``row_to_col``,
        ``total_cost``, ``total_cost`` (an exact solver's cost is its own
        bound), 0.0, None and True.
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

    @property
    def assignment(self) -> np.ndarray:
        """The decisions, ``row_to_col``."""
        return self.row_to_col

    @property
    def cost(self):
        """Total cost of the decisions, ``total_cost``."""
        return self.total_cost

    @property
    def lower_bound(self):
        """The optimal cost itself (the 2-D solvers are exact)."""
        return self.total_cost

    @property
    def gap(self):
        """0.0: the 2-D solvers are exact."""
        return 0.0 if np.ndim(self.total_cost) == 0 else np.zeros(np.shape(self.total_cost))



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




# --------------------------------------------------------------------------- 2-D dense
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




# --------------------------------------------------------------------------- 2-D sparse (gated)
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
    """:func:`solve_2d` for a scipy.sparse matrix of gated pair costs."""
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


def solve_2d(cost, *, threshold=None, miss_cost=None) -> Association:
    """The joint maximum-likelihood association: an exact linear assignment.

    The solver behind :func:`radarfusion_ref.association.associate_joint`, which
    documents the arguments, the three problems it solves (complete, gated, with a
    non-assignment cost), the sparse route and the errors: they are the same here.

    Parameters
    ----------
    cost : array_like, shape (..., n1, n2), or scipy.sparse matrix (n1, n2)
        Pair costs; ``+inf`` (dense) or a missing entry (sparse) forbids a pair.
    threshold : float, optional
        Gate: a pair is allowed only if its cost is strictly below it.
    miss_cost : float, optional
        Cost charged for each report left unassigned.

    Returns
    -------
    Association

    Raises
    ------
    ValueError, TypeError
        As :func:`radarfusion_ref.association.associate_joint`.

    Examples
    --------
    >>> c = [[0.5, 0.1], [0.2, 3.0]]
    >>> r = solve_2d(c)
    >>> r.pairs.tolist(), r.total_cost
    ([[0, 1], [1, 0]], 0.30000000000000004)
    >>> r = solve_2d([[1.0, 9.0], [9.0, 9.0]], miss_cost=2.0)
    >>> r.pairs.tolist(), r.unassigned_rows.tolist(), r.unassigned_cols.tolist(), r.total_cost
    ([[0, 0]], [1], [1], 5.0)
    >>> solve_2d([[5.0, 6.0]], threshold=1.0).n_assigned
    0
    >>> from scipy import sparse
    >>> gated = sparse.csr_array(([0.5, 0.1, 0.2], ([0, 0, 1], [0, 1, 0])), shape=(2, 3))
    >>> solve_2d(gated).pairs.tolist()
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




# --------------------------------------------------------------------------- 2-D brute force
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


def solve_2d_bruteforce(cost, *, threshold=None, miss_cost=None) -> Association:
    """The joint ML association by enumerating every joint hypothesis.

    The reference route for :func:`solve_2d`: the same problem (same
    arguments, same meaning), solved by scoring every hypothesis. Square
    matrices without gate or miss cost enumerate the :math:`n!` permutations
    (chunked, vectorized); otherwise all partial matchings are scored.

    Parameters
    ----------
    cost : array_like, shape (..., n1, n2)
        As in :func:`solve_2d`.
    threshold, miss_cost : float, optional
        As in :func:`solve_2d`.

    Returns
    -------
    Association

    Raises
    ------
    ValueError, TypeError
        As :func:`radarfusion_ref.association.associate_bruteforce`, which also gives
        the enumeration limits.

    Examples
    --------
    >>> solve_2d_bruteforce([[0.5, 0.1], [0.2, 3.0]]).row_to_col
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
                       alternative="solve_2d (associate_joint: exact linear assignment, O(n^3))")
    else:
        count = _limit(_n_partial(n1, n2), MAX_PARTIAL_MATCHINGS, name="cost",
                       what=f"partial matchings (gated or with a miss cost, {n1} x {n2} matrix)",
                       alternative="solve_2d (associate_joint: exact linear assignment, O(n^3))")
    _limit(nb * count, MAX_SCORED_HYPOTHESES, name="cost",
           what=f"hypotheses to score over a batch of {nb} matrices",
           alternative="solve_2d (associate_joint: exact linear assignment, O(n^3))")
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




# --------------------------------------------------------------------------- 2-D k best (Murty)
@dataclass(frozen=True)
class KBestAssignments(_Exact):
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
    assignment, cost, lower_bound, gap, history, exact
        (properties) the :class:`AssignmentResult` vocabulary: ``assignments``,
        ``costs``, ``costs`` (each ranked cost is exact), zeros, None and True.
    """

    assignments: np.ndarray
    costs: np.ndarray
    solved: int

    @property
    def k(self) -> int:
        """Number of assignments found (fewer than asked if fewer exist)."""
        return int(self.costs.shape[0])

    @property
    def assignment(self) -> np.ndarray:
        """The ranked decisions, ``assignments`` (one ``row_to_col`` per row)."""
        return self.assignments

    @property
    def cost(self) -> np.ndarray:
        """Their total costs, ``costs``."""
        return self.costs

    @property
    def lower_bound(self) -> np.ndarray:
        """``costs``: each ranked cost is exact (the r-th best cost)."""
        return self.costs

    @property
    def gap(self) -> np.ndarray:
        """Zeros: the ranking is exact."""
        return np.zeros(self.costs.shape)



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


def k_best_2d(cost, k) -> KBestAssignments:
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
    ValueError, TypeError
        As :func:`radarfusion_ref.association.k_best_assignments`, which also
        documents the algorithm (Murty's partitioning with the Miller, Stone & Cox
        bound).

    Examples
    --------
    >>> r = k_best_2d([[1.0, 2.0], [2.0, 5.0]], 5)
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




# --------------------------------------------------------------------------- S-D: full tensor, HiGHS
#: Costs up to this size are handed to HiGHS as they are; larger ones are capped
#: (never changing the optimum) and rescaled, since HiGHS treats costs from
#: 1e20 on as infinite.
_HIGHS_COST_SCALE = 1e9


def _greedy_total(c, m, n):
    """Cost of the greedy grouping (cheapest free candidate group first): an upper bound."""
    work = c.reshape((n,) * m).copy()
    total = 0.0
    for _ in range(n):
        t = np.unravel_index(np.argmin(work), work.shape)
        total += work[t]
        for i, j in enumerate(t):
            index = [slice(None)] * m
            index[i] = j
            work[tuple(index)] = np.inf
    return total


def _condition_costs(c_raw, m, n, bound=None):
    """Costs HiGHS can take without changing the optimum.

    Shift to a minimum of 0 (every grouping has n groups: a constant). If the
    largest cost exceeds ``_HIGHS_COST_SCALE``, cap every cost at ``K = 2 U + 1``,
    ``U`` the total of some grouping (`bound`; the greedy one by default): a grouping holding a capped
    group costs at least ``K > U >= optimum``, so the optimum is unchanged; then,
    if ``K`` itself is that large, scale all costs by ``_HIGHS_COST_SCALE / K``
    (a positive factor, the same optimum; HiGHS treats costs from 1e20 on as
    infinite).
    """
    c = c_raw - c_raw.min()
    if c.max() <= _HIGHS_COST_SCALE:
        return c
    if bound is None:
        bound = _greedy_total(c, m, n)
    cap = 2.0 * bound + 1.0
    c = np.minimum(c, cap)
    if cap > _HIGHS_COST_SCALE:
        c = c * (_HIGHS_COST_SCALE / cap)
    return c


@functools.lru_cache(maxsize=16)
def _sd_constraints(m, n):
    """Equality constraints of the S-D assignment: each report in exactly one tuple."""
    N = n**m
    idx = np.indices((n,) * m).reshape(m, -1)
    rows = (np.arange(m)[:, None] * n + idx).ravel()
    cols = np.tile(np.arange(N), m)
    A = sparse.csc_array((np.ones(m * N), (rows, cols)), shape=(m * n, N))
    return A, idx


def _sd_solve_once(c, m, n, *, relaxation=True, time_limit=None):
    """One HiGHS solve of the S-D assignment with conditioned costs `c`."""
    A, _ = _sd_constraints(m, n)
    z, integral = None, False
    if relaxation:
        lp = linprog(c, A_eq=A, b_eq=np.ones(m * n), bounds=(0, 1), method="highs")
        if lp.status == 0 and np.all(np.minimum(lp.x, 1 - lp.x) < 1e-6):
            z, integral = lp.x, True
    if z is None:
        options = {"mip_rel_gap": 0.0, "presolve": False}
        if time_limit is not None:
            options["time_limit"] = time_limit
        res = milp(c, constraints=LinearConstraint(A, 1, 1), integrality=np.ones(n**m),
                   bounds=Bounds(0, 1), options=options)
        if res.status != 0 or res.x is None:
            raise RuntimeError(
                f"HiGHS did not return a proven optimum (status {res.status}: {res.message})"
            )
        z = res.x
    chosen = np.flatnonzero(z > 0.5)
    tuples = np.array(np.unravel_index(chosen, (n,) * m))          # (m, n)
    if chosen.size != n or np.any(np.sort(tuples, axis=1) != np.arange(n)):
        raise RuntimeError("HiGHS returned an infeasible grouping")
    return chosen, integral


def _sd_solve(c_raw, m, n, *, relaxation=True, time_limit=None):
    """Solve the S-D assignment for a flat cost vector over the n**m tuples.

    Returns the flat indices of the n chosen tuples and whether the LP
    relaxation's solution was already integral. With costs above
    ``_HIGHS_COST_SCALE`` the cap of :func:`_condition_costs` is tightened to
    each solution's own total until it no longer improves, so the rescaled
    costs resolve the optimum to the precision of a double.
    """
    c0 = c_raw - c_raw.min()
    if c0.max() <= _HIGHS_COST_SCALE:
        return _sd_solve_once(c0, m, n, relaxation=relaxation, time_limit=time_limit)
    bound = _greedy_total(c0, m, n)
    for _ in range(64):
        chosen, integral = _sd_solve_once(_condition_costs(c0, m, n, bound), m, n,
                                          relaxation=relaxation, time_limit=time_limit)
        total = c0[chosen].sum()
        if not total < bound * (1 - 1e-12):
            break
        bound = total
    return chosen, integral




# --------------------------------------------------------------------------- S-D: explicit candidate groups
#: What a caller of the grouping chapter can change when no grouping exists.
_HINT = ("widen the gate or allow missed detections and false reports (`p_detect` < 1, "
         "`false_density` > 0)")
_LAGRANGE_STALL = 6          # iterations without a better dual value before the step halves


_LAGRANGE_PATIENCE = 20      # iterations without progress of either bound: branch and bound


_EPS = np.finfo(float).eps


_DENSE_ASSIGN = 1 << 20      # cells up to which a square assignment is solved densely


def _report_nodes(T, counts):
    offsets = np.concatenate([[0], np.cumsum(counts)])
    return np.where(T >= 0, T + offsets[:-1], -1), offsets


def _check_cover(T, counts, dummy, why, name="x", hint=None):
    """Every report must be in some candidate group (and, without the dummy index, the
    candidate graph's components must hold as many reports of every source).

    `name` is the public argument the reports came from, `hint` what the caller
    can change (the grouping chapter's gate and detection model by default).
    """
    hint = _HINT if hint is None else hint
    from scipy.sparse.csgraph import connected_components

    m = len(counts)
    nodes, offsets = _report_nodes(T, counts)
    N = int(offsets[-1])
    covered = np.zeros(N, dtype=bool)
    covered[nodes[nodes >= 0]] = True
    if not covered.all():
        lost = np.flatnonzero(~covered)
        i = int(np.searchsorted(offsets, lost[0], side="right") - 1)
        mine = lost[(lost >= offsets[i]) & (lost < offsets[i + 1])] - offsets[i]
        raise ValueError(
            f"`{name}`: report(s) {mine[:10].tolist()} of source {i} cannot be grouped: no "
            f"candidate group holds them ({why}); never a partial grouping -- {hint}"
        )
    first = nodes[np.arange(T.shape[0]), np.argmax(T >= 0, axis=1)]
    rows = np.concatenate([first[nodes[:, i] >= 0] for i in range(m)])
    cols = np.concatenate([nodes[nodes[:, i] >= 0, i] for i in range(m)])
    graph = sparse.coo_array((np.ones(rows.size), (rows, cols)), shape=(N, N))
    ncomp, label = connected_components(graph, directed=False)
    if not dummy:
        per = np.stack([np.bincount(label[offsets[i]:offsets[i + 1]], minlength=ncomp)
                        for i in range(m)])                          # (m, ncomp)
        bad = np.flatnonzero(np.any(per != per[0], axis=0))
        if bad.size:
            comp = per[:, bad[0]]
            i = int(np.argmax(comp != np.median(comp))) if np.any(comp != np.median(comp)) \
                else int(np.argmax(comp))
            mine = np.flatnonzero(label[offsets[i]:offsets[i + 1]] == bad[0])
            raise ValueError(
                f"`{name}`: the reports {mine[:10].tolist()} of source {i} cannot be grouped: "
                f"their cluster of candidate groups holds {comp.tolist()} reports of the m = "
                f"{m} sources, not one of each per group ({why}); {hint}"
            )
    return ncomp, label, first, offsets


def _milp_tuples(T, c, counts, *, time_limit=None, upper=None):
    """Exact S-D on explicit candidate groups (HiGHS); (chosen, lower bound) or None."""
    m = len(counts)
    nodes, offsets = _report_nodes(T, counts)
    K = T.shape[0]
    rows = nodes.T.ravel()
    cols = np.tile(np.arange(K), m)
    ok = rows >= 0
    A = sparse.csc_array((np.ones(ok.sum()), (rows[ok], cols[ok])), shape=(int(offsets[-1]), K))
    cc = c
    if not np.any(T < 0):             # every grouping has counts[0] groups: shift to min 0
        shift = float(c.min())
        cc = c - shift
        if cc.max() > _HIGHS_COST_SCALE and upper is not None and np.isfinite(upper):
            cc = np.minimum(cc, 2.0 * (upper - shift * counts[0]) + 1.0)   # as _condition_costs
    top = float(np.max(np.abs(cc))) if cc.size else 0.0
    scale = _HIGHS_COST_SCALE / top if top > _HIGHS_COST_SCALE else 1.0
    options = {"mip_rel_gap": 0.0}
    if time_limit is not None:
        options["time_limit"] = time_limit
    res = milp(cc * scale, constraints=LinearConstraint(A, 1, 1), integrality=np.ones(K),
               bounds=Bounds(0, 1), options=options)
    if res.status == 2:                                              # infeasible
        return None
    if res.status != 0 or res.x is None:
        raise RuntimeError(
            f"HiGHS did not return a proven optimum (status {res.status}: {res.message})"
        )
    chosen = np.flatnonzero(res.x > 0.5)
    cover = np.bincount(nodes[chosen][nodes[chosen] >= 0], minlength=int(offsets[-1]))
    if np.any(cover != 1):
        raise RuntimeError("HiGHS returned an infeasible grouping")
    return chosen


def _assign(R, C, r, c, w, drow=None, dcol=None):
    """Minimum-cost assignment on a sparse bipartite graph, optionally with a dummy.

    Edges ``(r, c)`` of weight ``w`` join rows ``0..R-1`` and columns ``0..C-1``
    (duplicates: the cheapest counts). Without a dummy every row and column is
    matched (``R == C``); with one, row ``r`` may stay unmatched at cost
    ``drow[r]`` and column ``c`` at ``dcol[c]`` (``inf``: must be matched).
    The augmented square graph has the diagonal dummy blocks and, in the
    dummy-dummy block, the transpose of the real edges (all that any optimal
    matching needs), so it stays sparse; it is solved exactly by
    :func:`scipy.sparse.csgraph.min_weight_full_bipartite_matching` (LAPJVsp).
    Returns ``((rows, cols) of matched real pairs, unmatched rows, unmatched
    columns, total cost, sum of |terms|)`` or None when no assignment exists.
    """
    from scipy.sparse.csgraph import min_weight_full_bipartite_matching

    key = r.astype(np.int64) * max(C, 1) + c
    o = np.lexsort((w, key))
    key, r, c, w = key[o], r[o], c[o], w[o]
    first = np.r_[True, np.diff(key) != 0] if key.size else np.zeros(0, bool)
    key, r, c, w = key[first], r[first], c[first], w[first]
    if drow is None:
        if R != C:
            return None
        if 0 < R * C <= _DENSE_ASSIGN:                # small enough: dense LAPJV is faster
            M = np.full((R, C), np.inf)
            M[r, c] = w
            try:
                pr, pc = linear_sum_assignment(M)
            except ValueError:
                return None
            wr = M[pr, pc]
            if not np.all(np.isfinite(wr)):
                return None
            empty = np.zeros(0, dtype=np.int64)
            return (pr, pc), empty, empty, float(np.sum(wr)), float(np.sum(np.abs(wr)))
        rows, cols, wts, N = r, c, w, R
    else:
        fr, fc = np.flatnonzero(np.isfinite(drow)), np.flatnonzero(np.isfinite(dcol))
        rows = np.concatenate([r, fr, R + fc, R + c])
        cols = np.concatenate([c, C + fr, fc, C + r])
        wts = np.concatenate([w, drow[fr], dcol[fc], np.zeros(r.size)])
        N = R + C
    empty = np.zeros(0, dtype=np.int64)
    if N == 0:
        return (empty, empty), empty, empty, 0.0, 0.0
    if wts.size == 0 or not np.all(np.isfinite(wts)):
        return None
    lo = float(wts.min())
    graph = sparse.csr_array((wts - lo + 1.0, (rows, cols)), shape=(N, N))
    try:
        ri, ci = min_weight_full_bipartite_matching(graph)
    except ValueError:
        return None
    real = (ri < R) & (ci < C)
    pr, pc = ri[real], ci[real]
    wr = w[np.searchsorted(key, pr.astype(np.int64) * max(C, 1) + pc)]
    if drow is None:
        rd = cd = empty
        parts = [wr]
    else:
        rd = ri[(ri < R) & (ci >= C)]
        cd = ci[(ri >= R) & (ci < C)]
        parts = [wr, drow[rd], dcol[cd]]
    total = float(sum(np.sum(p) for p in parts))
    mag = float(sum(np.sum(np.abs(p)) for p in parts))
    return (pr, pc), rd, cd, total, mag


class _Lagrangian:
    """Lagrangian relaxation of one S-D problem on explicit candidate groups.

    Sources 2..m-1's constraints are relaxed with multipliers ``u``; what remains
    (sources 0 and 1) is a 2-D assignment over the pairs (j0, j1), each carrying its
    cheapest completion, solved exactly by linear assignment: its value is a lower
    bound. A feasible grouping is recovered each iteration by fixing the relaxed
    solution's pairs and assigning the other sources one at a time (Deb et al. 1997).
    """

    def __init__(self, T, c, counts, dummy):
        self.T, self.c, self.counts, self.dummy = T, c, list(counts), dummy
        m = self.m = T.shape[1]
        self.u = [np.zeros(counts[i] + 1) for i in range(m)]    # u[i][-1] = 0: the dummy
        self.lb, self.ub, self.best = -np.inf, np.inf, None
        self.history = []
        self.lam, self.stall, self.best_q, self.it = 1.0, 0, -np.inf, 0
        self.optimal, self.stalled, self.last_progress = False, False, 0
        base = np.array([n + 1 for n in counts], dtype=np.int64)
        mult = np.concatenate([[1], np.cumprod(base)[:-1]])
        if float(np.prod(base.astype(float))) > 2.0**62:
            raise ValueError("`x`: too many reports for the Lagrangian's tuple keys (the "
                             "product of (report count + 1) over the sources exceeds 2**62)")
        self.mult = mult
        # prefix keys: pref[k] over positions < k (k = 0..m)
        contrib = (T + 1) * mult
        self.pref = [np.zeros(T.shape[0], dtype=np.int64)]
        for k in range(m):
            self.pref.append(self.pref[-1] + contrib[:, k])
        self.full_order = np.argsort(self.pref[m], kind="stable")
        self.full_sorted = self.pref[m][self.full_order]
        key = self.pref[2]
        free = key == 0
        self.free = np.flatnonzero(free)
        idx = np.flatnonzero(~free)
        order = idx[np.argsort(key[idx], kind="stable")]
        ks = key[order]
        starts = np.flatnonzero(np.r_[True, np.diff(ks) != 0]) if ks.size else np.zeros(0, int)
        self.order, self.starts = order, starts
        self.sizes = np.diff(np.r_[starts, ks.size])
        self.ukeys = ks[starts]
        self.base0 = int(base[0])
        self.ka, self.kb = self.ukeys % base[0] - 1, self.ukeys // base[0] - 1

    def _reduced(self, first):
        rc = self.c.copy()
        for i in range(first, self.m):
            rc -= self.u[i][self.T[:, i]]
        return rc

    def relaxed(self):
        rc = self._reduced(2)
        rs = rc[self.order]
        mins = np.minimum.reduceat(rs, self.starts) if rs.size else rs
        pos = np.flatnonzero(rs == np.repeat(mins, self.sizes))
        best = self.order[pos[np.searchsorted(pos, self.starts)]]
        n0, n1 = self.counts[0], self.counts[1]
        a, b = self.ka, self.kb
        real = (a >= 0) & (b >= 0)
        drow = dcol = None
        if self.dummy:
            drow, dcol = np.full(n0, np.inf), np.full(n1, np.inf)
            lone_a, lone_b = (a >= 0) & (b < 0), (a < 0) & (b >= 0)
            drow[a[lone_a]], dcol[b[lone_b]] = mins[lone_a], mins[lone_b]
        sol = _assign(n0, n1, a[real], b[real], mins[real], drow, dcol)
        if sol is None:
            return None
        (pr, pc), rd, cd, value, mag = sol
        keys = np.concatenate([(pr + 1) + (pc + 1) * self.base0, rd + 1, (cd + 1) * self.base0])
        chosen = best[np.searchsorted(self.ukeys, keys)]
        fr = rc[self.free]
        neg = self.free[fr < 0]
        us = [self.u[i][:-1] for i in range(2, self.m)]
        q = value + float(np.sum(fr[fr < 0])) + float(sum(np.sum(ui) for ui in us))
        # rounding allowance of the sums behind q (never claim an unproved bound)
        mag = mag + np.sum(np.abs(fr)) + np.sum(np.abs(self.c[chosen])) + \
            2 * sum(np.sum(np.abs(ui)) for ui in us)
        slack = 8.0 * _EPS * (self.T.shape[0] + sum(self.counts) + 8) * mag
        return q, slack, np.concatenate([chosen, neg])

    def recover(self, chosen):
        """A feasible grouping from the relaxed solution (None if recovery fails)."""
        m, T, counts = self.m, self.T, self.counts
        keys = np.unique(self.pref[2][chosen])
        keys = keys[keys != 0]
        for k in range(2, m):
            R, nk = keys.size, counts[k]
            pk = self.pref[k]
            pos = np.minimum(np.searchsorted(keys, pk), max(R - 1, 0))
            ok = (keys[pos] == pk) if R else np.zeros(pk.size, bool)
            tk = T[:, k]
            rc = self.c.copy()
            for i in range(k + 1, m):
                rc -= self.u[i][T[:, i]]
            e = ok & (tk >= 0)
            drow = dcol = None
            if self.dummy:
                drow, dcol = np.full(R, np.inf), np.full(nk, np.inf)
                s = ok & (tk < 0)
                np.minimum.at(drow, pos[s], rc[s])
                s = (pk == 0) & (tk >= 0)
                np.minimum.at(dcol, tk[s], rc[s])
            sol = _assign(R, nk, pos[e], tk[e], rc[e], drow, dcol)
            if sol is None:
                return None
            (pr, pc), rd, cd, _, _ = sol
            keys = np.sort(np.concatenate([keys[pr] + (pc + 1) * self.mult[k], keys[rd],
                                           (cd + 1) * self.mult[k]]))
        pos = np.searchsorted(self.full_sorted, keys)
        if np.any(pos >= self.full_sorted.size) or np.any(self.full_sorted[pos] != keys):
            return None
        return self.full_order[pos]

    def improve(self, sol, sweeps=2):
        """Local search: reassign one source at a time, the others fixed (exact 2-D steps).

        Every step keeps the current grouping available, so the cost never rises.
        """
        T, m = self.T, self.m
        full = self.pref[m]
        keys = full[sol]
        for _ in range(sweeps):
            before = float(self.c[sol].sum())
            for k in range(m):
                nk, mk = self.counts[k], self.mult[k]
                excl = full - (T[:, k] + 1) * mk
                G = np.unique(keys - ((keys // mk) % (self.counts[k] + 1)) * mk)
                G = G[G != 0]
                R = G.size
                pos = np.minimum(np.searchsorted(G, excl), max(R - 1, 0))
                ok = (G[pos] == excl) if R else np.zeros(excl.size, bool)
                tk = T[:, k]
                e = ok & (tk >= 0)
                drow = dcol = None
                if self.dummy:
                    drow, dcol = np.full(R, np.inf), np.full(nk, np.inf)
                    s_ = ok & (tk < 0)
                    np.minimum.at(drow, pos[s_], self.c[s_])
                    s_ = (excl == 0) & (tk >= 0)
                    np.minimum.at(dcol, tk[s_], self.c[s_])
                res = _assign(R, nk, pos[e], tk[e], self.c[e], drow, dcol)
                if res is None:
                    break
                (pr, pc), rd, cd, _, _ = res
                keys = np.sort(np.concatenate([G[pr] + (pc + 1) * mk, G[rd], (cd + 1) * mk]))
                p = np.searchsorted(self.full_sorted, keys)
                sol = self.full_order[p]
            if not float(self.c[sol].sum()) < before:
                break
        return sol

    def step(self):
        """One iteration: relaxed problem, bound, recovery, multiplier update."""
        self.it += 1
        out = self.relaxed()
        if out is None:
            raise _Infeasible(0 if self.dummy else 1)
        q, slack, chosen = out
        m = self.m
        g = [np.zeros(0)] * 2 + [
            1.0 - np.bincount(self.T[chosen, i][self.T[chosen, i] >= 0],
                              minlength=self.counts[i]) for i in range(2, m)]
        norm2 = float(sum(np.sum(gi * gi) for gi in g))
        if norm2 == 0.0:                      # relaxed optimum is feasible: it is optimal
            total = float(self.c[chosen].sum())
            if total < self.ub:
                self.ub, self.best = total, chosen
            self.lb = self.ub
            self.optimal = True
            self.history.append((self.lb, self.ub))
            return
        self.lb = max(self.lb, q - slack)
        lb_before, ub_before = self.lb, self.ub
        sol = self.recover(chosen)
        if sol is not None:
            total = float(self.c[sol].sum())
            if total < self.ub or self.it % 5 == 0:
                sol = self.improve(sol)
                total = float(self.c[sol].sum())
            if total < self.ub:
                self.ub, self.best = total, sol
        self.lb = min(self.lb, self.ub)
        tiny = 1e-4 * max(1.0, abs(self.ub)) if np.isfinite(self.ub) else np.inf
        if self.lb > lb_before + tiny or self.ub < ub_before - tiny or not np.isfinite(self.ub):
            self.last_progress = self.it
        self.stalled = self.it - self.last_progress >= _LAGRANGE_PATIENCE
        self.history.append((self.lb, self.ub))
        if q > self.best_q + 1e-12 * max(1.0, abs(q)):
            self.best_q, self.stall = q, 0
        else:
            self.stall += 1
            if self.stall >= _LAGRANGE_STALL:
                self.lam, self.stall = self.lam / 2, 0
        target = self.ub if np.isfinite(self.ub) else q + 0.05 * max(1.0, abs(q))
        t = self.lam * max(target - q, 1e-9 * max(1.0, abs(q))) / norm2
        for i in range(2, m):
            self.u[i][:-1] += t * g[i]

    def close(self, time_limit=None):
        """Branch and bound (HiGHS) on this problem's candidates: an exact optimum."""
        chosen = _milp_tuples(self.T, self.c, self.counts, time_limit=time_limit,
                              upper=self.ub)
        if chosen is None:
            raise _Infeasible(None)
        self.best, self.ub = chosen, float(self.c[chosen].sum())
        self.lb, self.optimal = self.ub, True
        self.history.append((self.lb, self.ub))


class _Infeasible(Exception):
    """The candidate groups admit no grouping."""


def _solve_candidates(T, c, counts, *, dummy, method, gap, max_iter, time_limit, why,
                      name="x", hint=None):
    """Solve one scene's S-D problem over explicit candidates, cluster by cluster.

    Returns (chosen tuple indices, cost, lower bound, history (iterations, 2) or None).
    """
    ncomp, label, first, offsets = _check_cover(T, counts, dummy, why, name, hint)
    m = len(counts)
    tlabel = label[first]
    order = np.argsort(tlabel, kind="stable")
    bounds = np.searchsorted(tlabel[order], np.arange(ncomp + 1))
    if method == "milp":
        chosen = _milp_tuples(T, c, counts, time_limit=time_limit)
        if chosen is None:
            raise ValueError(_infeasible_text(None, counts, why, name, hint))
        total = float(c[chosen].sum())
        return chosen, total, total, None
    # local report indices inside each cluster
    local = []
    for i in range(m):
        lab = label[offsets[i]:offsets[i + 1]]
        srt = np.argsort(lab, kind="stable")
        loc = np.empty_like(srt)
        starts = np.searchsorted(lab[srt], lab[srt])
        loc[srt] = np.arange(srt.size) - starts
        local.append((loc, np.bincount(lab, minlength=ncomp)))
    comps = []
    for q in range(ncomp):
        sel = order[bounds[q]:bounds[q + 1]]
        if sel.size == 0:
            continue
        Tq = np.stack([np.where(T[sel, i] >= 0, local[i][0][np.maximum(T[sel, i], 0)], -1)
                       for i in range(m)], axis=1)
        cnt = [int(local[i][1][q]) for i in range(m)]
        comps.append((sel, _Lagrangian(Tq, c[sel], cnt, dummy)))
    solvers = [s for _, s in comps]

    def run(tol_of, budget):
        for s in solvers:
            try:
                while not (s.optimal or s.stalled) and s.it < budget and \
                        not (s.ub - s.lb <= tol_of(s)):
                    s.step()
            except _Infeasible as exc:
                raise ValueError(_infeasible_text(exc.args[0], counts, why, name, hint)) from None

    def totals():
        return sum(s.ub for s in solvers), sum(s.lb for s in solvers)

    run(lambda s: 0.5 * gap * max(abs(s.ub), 1.0) if np.isfinite(s.ub) else -1.0, max_iter)
    ub, lb = totals()
    if np.isfinite(ub) and (ub - lb) > gap * max(abs(ub), 1.0):
        share = 0.999 * gap * max(abs(ub), 1.0) / len(solvers)
        run(lambda s: share, 2 * max_iter)
    ub, lb = totals()
    if not np.isfinite(ub) or (ub - lb) > gap * max(abs(ub), 1.0):
        # stalled clusters (a duality gap): branch and bound on their candidates only
        worst = sorted(solvers, key=lambda s: -(s.ub - s.lb) if np.isfinite(s.ub) else -np.inf)
        for s in worst:
            ub, lb = totals()
            if np.isfinite(ub) and (ub - lb) <= gap * max(abs(ub), 1.0):
                break
            try:
                s.close(time_limit)
            except _Infeasible:
                raise ValueError(_infeasible_text(None, counts, why, name, hint)) from None
    ub, lb = totals()
    chosen = np.concatenate([sel[s.best] for sel, s in comps])
    length = max(len(s.history) for s in solvers)
    hist = np.zeros((length, 2))
    for s in solvers:
        h = np.array(s.history)
        hist += np.vstack([h, np.repeat(h[-1:], length - len(h), axis=0)])
    return chosen, float(c[chosen].sum()), min(lb, float(c[chosen].sum())), hist


def _infeasible_text(source, counts, why, name="x", hint=None):
    srcs = "sources 0 and 1" if source in (0, 1) else "the sources"
    return (f"`{name}`: the gated problem has no grouping: the reports of {srcs} (report "
            f"counts {list(counts)}) cannot all be put into groups of one report per source "
            f"({why}); never a partial grouping -- {_HINT if hint is None else hint}")




# --------------------------------------------------------------------------- S-D: public API
#: Largest full cost tensor (:math:`n^m` candidate groups) :func:`solve_sd`
#: accepts; beyond it, pass the gated candidate groups instead.
MAX_SD_TUPLES = 10**6

#: Largest number of groupings :math:`(n!)^{m-1}` :func:`solve_sd_bruteforce`
#: enumerates (about a minute of work).
MAX_SD_GROUPINGS = 10**8

#: What a caller of :func:`solve_sd` can change when no grouping exists.
_SD_HINT = ("add candidate groups (a wider gate), or groups with -1 for a source without a "
            "report (missed detections and false reports)")


@dataclass(frozen=True)
class SDAssignment:
    """The best S-D assignment (grouping) found by :func:`solve_sd` or :func:`solve_sd_bruteforce`.

    Attributes
    ----------
    assignment : numpy.ndarray of int, shape (G, m)
        The chosen groups, one row per group: ``assignment[k, i]`` is source
        ``i``'s report in group ``k``, ``-1`` when source ``i`` has none;
        rows sorted by source 0, then 1, ... (``-1`` last).
    chosen : numpy.ndarray of int, shape (G,)
        Their indices: rows of `candidates`, or flat (C-order) indices into
        the cost tensor.
    cost : float
        Total cost of the chosen groups.
    lower_bound : float
        A proved lower bound on the optimal total: the cost itself for an
        exact method, the best Lagrangian dual value (less a rounding
        allowance) for ``"lagrangian"``.
    gap : float
        Proved relative gap :math:`(\\text{cost} - \\text{lower bound}) /
        \\max(|\\text{cost}|, 1)`.
    history : numpy.ndarray or None, shape (iterations, 2)
        ``"lagrangian"``: lower bound and best cost after each iteration
        (summed over independent clusters); None otherwise.
    exact : bool
        True when `gap` is 0 (a proved optimum).
    method : str
        ``"milp"``, ``"lagrangian"`` or ``"bruteforce"``.
    relaxation_integral : bool or None
        ``"milp"`` on a full finite tensor: whether the LP relaxation was
        already integral (no branching). None otherwise.
    """

    assignment: np.ndarray
    chosen: np.ndarray
    cost: float
    lower_bound: float
    gap: float
    history: np.ndarray | None
    exact: bool
    method: str
    relaxation_integral: bool | None = None


def _sorted_groups(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Order of the rows of T by source 0, then 1, ... (a missing report, -1, sorts last)."""
    key = np.where(T >= 0, T, np.iinfo(np.int64).max)
    order = np.lexsort(key.T[::-1])
    return T[order], order


def _as_sd_tensor(cost, name: str = "cost") -> np.ndarray:
    """A full S-D cost tensor of shape (n,) * m: finite or +inf (forbidden)."""
    c = as_float_array(cost, name, ndim_min=2, allow_nonfinite=True)
    n = c.shape[0]
    if n == 0 or any(s != n for s in c.shape):
        raise ValueError(f"`{name}` must be a cost tensor of shape (n,) * m with n >= 1 (one "
                         f"axis per source, n reports each); received shape {c.shape}")
    if np.any(np.isnan(c)):
        raise ValueError(f"`{name}` must not contain NaN (use +inf for a forbidden group); "
                         f"received {int(np.count_nonzero(np.isnan(c)))} NaN entries")
    if np.any(c == -np.inf):
        raise ValueError(f"`{name}` must not contain -inf (a group cannot be infinitely "
                         f"likely); received {int(np.count_nonzero(c == -np.inf))} -inf entries")
    return c


def _as_candidates(candidates, cost, counts):
    """Candidate groups (K, m) of ints >= -1, their finite costs (K,) and the report counts."""
    if candidates is None or isinstance(candidates, (str, bytes, bool, np.bool_)):
        raise TypeError(f"`candidates` must be an integer array of shape (K, m); received "
                        f"{_describe(candidates)}")
    T = np.asarray(candidates)
    if T.dtype.kind == "f" and T.size and np.all(np.isfinite(T)) and np.all(np.round(T) == T):
        T = T.astype(np.int64)
    if T.dtype.kind not in "iu":
        raise TypeError(f"`candidates` must be an integer array of shape (K, m) (report indices, "
                        f"-1 for none); received {_describe(candidates)}")
    if T.ndim != 2 or T.shape[0] == 0 or T.shape[1] < 2:
        raise ValueError(f"`candidates` must have shape (K, m) with K >= 1 groups of m >= 2 "
                         f"sources; received shape {T.shape}")
    T = T.astype(np.int64)
    if np.any(T < -1):
        raise ValueError(f"`candidates` entries must be report indices >= 0 or -1 (no report); "
                         f"received {_describe(candidates)} (smallest entry {int(T.min())})")
    if np.any(np.all(T < 0, axis=1)):
        k = int(np.flatnonzero(np.all(T < 0, axis=1))[0])
        raise ValueError(f"`candidates`: every group must hold at least one report; row {k} is "
                         "all -1")
    c = as_float_array(cost, "cost", allow_nonfinite=True)
    if c.shape != (T.shape[0],):
        raise ValueError(f"`cost` must hold one cost per candidate group, shape "
                         f"({T.shape[0]},); received shape {c.shape}")
    if not np.all(np.isfinite(c)):
        raise ValueError("`cost` of candidate groups must be finite (leave a forbidden group "
                         f"out of `candidates`); received {_describe(c)} with "
                         f"{int(np.count_nonzero(~np.isfinite(c)))} non-finite entries")
    m = T.shape[1]
    top = T.max(axis=0) + 1
    if counts is None:
        cnt = [int(v) for v in top]
    else:
        arr = np.asarray(counts)
        if arr.shape != (m,) or arr.dtype.kind not in "iu":
            raise ValueError(f"`counts` must be {m} integers (reports per source); received "
                             f"{_describe(counts)}")
        cnt = [int(v) for v in arr]
        if any(ci < ti for ci, ti in zip(cnt, top, strict=True)):
            raise ValueError(f"`counts` must be at least the largest report index + 1 of each "
                             f"source ({top.tolist()}); received {cnt}")
    if min(cnt) < 1:
        raise ValueError(f"`candidates`: every source must have at least one report; report "
                         f"counts {cnt}")
    return T, c, cnt


def solve_sd(cost, candidates=None, *, counts=None, method: str = "milp", gap: float = 0.01,
             max_iter: int = 100, time_limit: float | None = None,
             relaxation: bool = True) -> SDAssignment:
    """Minimum-cost S-D assignment: exact (HiGHS) or to a proved duality gap (Lagrangian).

    Parameters
    ----------
    cost : array_like
        Either a full cost tensor of shape ``(n,) * m`` (``cost[j1, ..., jm]``
        the cost of grouping report ``j_i`` of every source ``i``; ``+inf``
        forbids a group), or, with `candidates`, one finite cost per candidate
        group, shape ``(K,)``.
    candidates : array_like of int, shape (K, m), optional
        Explicit (gated) candidate groups: ``candidates[k, i]`` is source
        ``i``'s report in group ``k``, or ``-1`` when the group has no report
        of source ``i`` (then reports may stay out of full groups: missed
        detections and false reports; a lone report is a group with one
        entry). Memory and time follow `K`, not :math:`n^m`.
    counts : sequence of int, shape (m,), optional
        Reports per source (default: the largest index + 1 in `candidates`);
        every report must be covered by exactly one chosen group.
    method : {"milp", "lagrangian"}, optional
        ``"milp"``: the exact integer program (HiGHS branch and bound, after
        the LP relaxation when it is integral). ``"lagrangian"``: Lagrangian
        relaxation of sources :math:`3..m`, stopped at a proved gap.
    gap : float, optional
        Relative gap in (0, 1) at which ``"lagrangian"`` stops (default
        0.01); clusters that stall above it are closed by branch and bound,
        so the returned gap never exceeds it.
    max_iter : int, optional
        Subgradient iterations per cluster before the gap target is tightened.
    time_limit : float, optional
        Seconds allowed to branch and bound (per stalled cluster); a
        :class:`RuntimeError` when no proved optimum is found in time.
    relaxation : bool, optional
        ``"milp"`` on a full finite tensor: try the LP relaxation first.

    Returns
    -------
    SDAssignment

    Raises
    ------
    ValueError
        For NaN or ``-inf`` costs, a non-finite candidate cost, a tensor that
        is not ``(n,) * m`` or larger than :data:`MAX_SD_TUPLES`, candidate
        rows outside ``[-1, counts)`` or all ``-1``, a `gap` outside (0, 1),
        or a problem without any grouping (the message names the source
        whose reports cannot be grouped; never a partial answer).
    TypeError
        If `candidates` is not an integer array, `relaxation` not a bool or
        `max_iter` not an integer.
    RuntimeError
        If HiGHS returns no proved optimum (e.g. within `time_limit`).

    Notes
    -----
    One binary variable :math:`z_t` per candidate group :math:`t`:
    :math:`\\min \\sum_t c_t z_t` subject to every report of every source
    lying in exactly one chosen group. For :math:`m = 2` it is the linear
    assignment problem; for :math:`m \\ge 3` it is NP-hard (Deb et al. 1997).
    The Lagrangian relaxation splits the candidates into independent
    clusters, relaxes sources :math:`3..m` with multipliers :math:`y`,
    solves the remaining 2-D assignment exactly (a valid lower bound
    :math:`q(y)`), recovers a feasible grouping each iteration and moves
    :math:`y` along the subgradient; see
    :func:`radarfusion_ref.grouping.group_sd`, which builds the costs from
    reports and calls this solver.

    Examples
    --------
    >>> c = np.full((2, 2, 2), 5.0)
    >>> c[0, 1, 0] = c[1, 0, 1] = 1.0
    >>> r = solve_sd(c)
    >>> r.assignment.tolist(), r.cost, r.exact
    ([[0, 1, 0], [1, 0, 1]], 2.0, True)
    >>> r = solve_sd([1.0, 1.0, 3.0], [[0, 1, 0], [1, 0, 1], [0, 0, -1]], method="lagrangian")
    >>> r.assignment.tolist(), r.gap
    ([[0, 1, 0], [1, 0, 1]], 0.0)
    """
    method = as_choice(method, "method", ("milp", "lagrangian"))
    g = _as_gap(gap)
    max_iter = as_int(max_iter, "max_iter", minimum=1)
    relaxation = as_bool(relaxation, "relaxation")
    if time_limit is not None:
        time_limit = float(as_positive(time_limit, "time_limit"))
    integral = None
    if candidates is None:
        if counts is not None:
            raise ValueError("`counts` is for explicit `candidates`; a full tensor has n reports "
                             f"per source; received {_describe(counts)}")
        c = _as_sd_tensor(cost)
        m, n = c.ndim, c.shape[0]
        check_size(c.size, MAX_SD_TUPLES,
                   what=f"candidate groups n**m = {n}**{m} of a full `cost` tensor",
                   alternative="gated candidate groups (`candidates`) and method='lagrangian'")
        if method == "milp" and np.all(np.isfinite(c)):
            chosen, integral = _sd_solve(c.ravel(), m, n, relaxation=relaxation,
                                         time_limit=time_limit)
            T = np.array(np.unravel_index(chosen, c.shape)).T
            total = float(c.ravel()[chosen].sum())
            lb, hist = total, None
        else:
            flat = np.flatnonzero(np.isfinite(c.ravel()))
            T = np.array(np.unravel_index(flat, c.shape)).T.astype(np.int64)
            if T.shape[0] == 0:
                raise ValueError("`cost` has no finite group: no grouping exists")
            cc = c.ravel()[flat]
            sel, total, lb, hist = _solve_candidates(
                T, cc, [n] * m, dummy=False, method=method, gap=g, max_iter=max_iter,
                time_limit=time_limit, why="+inf entries of `cost`", name="cost",
                hint=_SD_HINT)
            chosen, T = flat[sel], T[sel]
    else:
        T_all, cc, cnt = _as_candidates(candidates, cost, counts)
        dummy = bool(np.any(T_all < 0))
        sel, total, lb, hist = _solve_candidates(
            T_all, cc, cnt, dummy=dummy, method=method, gap=g, max_iter=max_iter,
            time_limit=time_limit, why="the given candidate groups", name="candidates",
            hint=_SD_HINT)
        chosen, T = sel, T_all[sel]
    if not math.isfinite(total):
        raise ValueError("`cost`: the total cost of the best grouping lies beyond the float "
                         "range; divide the costs by a common factor")
    T, order = _sorted_groups(np.asarray(T, dtype=np.int64))
    gp = _gap_of(total, lb)
    return SDAssignment(T, np.asarray(chosen)[order], float(total), float(min(lb, total)), gp,
                        hist, gp == 0.0, method, integral)


def _sd_enumerate(tensor: np.ndarray, m: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Best grouping of each of B flat tensors (B, n**m) by enumeration.

    Returns (best totals (B,), groups (B, n, m), rows sorted by source 0);
    ties go to the first grouping in enumeration order.
    """
    B = tensor.shape[0]
    G = math.factorial(n) ** (m - 1)
    dtype = np.int8 if n < 127 else np.int32
    perms = np.array(list(itertools.permutations(range(n))), dtype=dtype).reshape(-1, n)
    perms = perms.astype(np.int64)                             # (n!, n)
    nf = perms.shape[0]
    weights = [n ** (m - 1 - i) for i in range(m)]
    base = np.arange(n) * weights[0]
    pflat = [perms * weights[i] for i in range(1, m)]
    best = np.full(B, np.inf)
    best_g = np.zeros(B, dtype=np.int64)
    chunk = max(1, 2**22 // max(1, B * n))
    for start in range(0, G, chunk):
        g = np.arange(start, min(G, start + chunk))
        flat = np.broadcast_to(base, (len(g), n)).copy()
        rem = g
        for i in range(m - 1, 0, -1):
            digit = rem % nf
            rem = rem // nf
            flat += pflat[i - 1][digit]
        totals = tensor[:, flat].sum(axis=-1)                 # (B, chunk)
        arg = np.argmin(totals, axis=-1)
        val = totals[np.arange(B), arg]
        better = val < best
        best = np.where(better, val, best)
        best_g = np.where(better, g[arg], best_g)
    groups = np.empty((B, n, m), dtype=np.int64)
    groups[:, :, 0] = np.arange(n)
    rem = best_g
    for i in range(m - 1, 0, -1):
        groups[:, :, i] = perms[rem % nf]
        rem = rem // nf
    return best, groups


def solve_sd_bruteforce(cost) -> SDAssignment:
    """The exact S-D optimum of a full cost tensor by enumerating every grouping.

    The reference route for :func:`solve_sd`: all :math:`(n!)^{m-1}` ways to
    split the reports into :math:`n` groups of one report per source are
    scored (vectorized, chunked), the cheapest is returned.

    Parameters
    ----------
    cost : array_like, shape (n,) * m
        Group costs (``+inf`` forbids a group), as in :func:`solve_sd`.

    Returns
    -------
    SDAssignment
        ``method="bruteforce"``, exact; ties go to the first grouping in
        enumeration order.

    Raises
    ------
    ValueError
        For a tensor that is not ``(n,) * m``, NaN or ``-inf`` costs, more
        than :data:`MAX_SD_GROUPINGS` groupings (use :func:`solve_sd`), no
        grouping of finite cost, or a total beyond the float range.

    Examples
    --------
    >>> c = np.full((2, 2, 2), 5.0)
    >>> c[0, 1, 0] = c[1, 0, 1] = 1.0
    >>> solve_sd_bruteforce(c).assignment.tolist()
    [[0, 1, 0], [1, 0, 1]]
    """
    c = _as_sd_tensor(cost)
    m, n = c.ndim, c.shape[0]
    check_size(math.factorial(n) ** (m - 1), MAX_SD_GROUPINGS,
               what=f"groupings (n!)**(m-1) of `cost` (n = {n}, m = {m})",
               alternative="solve_sd (the exact integer program, or the Lagrangian relaxation)")
    e = int(_exponents(c.reshape(1, -1)))
    best, groups = _sd_enumerate(np.ldexp(c.reshape(1, -1), -e), m, n)   # exact scaling
    if not np.isfinite(best[0]):
        raise ValueError("`cost`: every grouping uses a forbidden (+inf) group: no grouping exists")
    with np.errstate(over="ignore"):
        total = float(np.ldexp(best[0], e))
    if not math.isfinite(total):
        raise ValueError("`cost`: the total cost of the best grouping lies beyond the float "
                         "range; divide the costs by a common factor")
    T = groups[0]
    chosen = np.ravel_multi_index(tuple(T.T), c.shape)
    return SDAssignment(T, chosen, total, total, 0.0, None, True, "bruteforce")
