"""The 2-D assignment: dense (batched), sparse (gated) and by enumeration."""

from __future__ import annotations

import itertools
import math
from functools import lru_cache

import numpy as np
from scipy import sparse
from scipy.optimize import linear_sum_assignment
from scipy.sparse.csgraph import min_weight_full_bipartite_matching

from ..validation import MEMORY_LIMIT, check_size
from ._checks import (
    _as_miss_cost,
    _inverse,
    as_cost,
    as_threshold,
    cost_exponents,
    scale_costs,
)
from ._results import Association
from ._sparse import int32_indices

__all__ = [
    "MAX_HYPOTHESES",
    "MAX_PARTIAL_MATCHINGS",
    "MAX_SCORED_HYPOTHESES",
    "assign_two_lists",
    "assign_two_lists_bruteforce",
]


# --------------------------------------------------------------------------- 2-D limits
#: Largest number of joint hypotheses of one cost matrix that
#: :func:`assign_two_lists_bruteforce` and the exact :func:`radarfusion_ref.association.association_probabilities`
#: enumerate (:math:`10! = 3\,628\,800` fits; :math:`n = 11` does not).
MAX_HYPOTHESES = 4_000_000


#: Largest number of *partial* matchings :func:`assign_two_lists_bruteforce` scores
#: when a gate, a non-assignment cost or forbidden pairs are given (7 x 7 fits).
MAX_PARTIAL_MATCHINGS = 200_000


#: Largest number of hypotheses :func:`assign_two_lists_bruteforce` scores in one call,
#: summed over a batch of cost matrices (bounds its run time).
MAX_SCORED_HYPOTHESES = 200_000_000


#: Working memory of one vectorized block of the enumerations, in bytes.
BLOCK_BYTES = 1 << 25


def make_association(cost: np.ndarray, row_to_col: np.ndarray, miss_cost: float | None):
    """Kernel (trusted input): an :class:`Association` from decisions, its total computed.

    `cost` ``(..., n1, n2)`` and `row_to_col` ``(..., n1)`` (-1 for unassigned) as a solver
    returns them; the total adds `miss_cost` per unassigned row and column when given, and
    a total beyond the float range is refused naming `cost`.
    """
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
def _work_costs(c: np.ndarray, allowed: np.ndarray, miss: float | None):
    """One plain rectangular assignment per matrix ``(..., n1, n2)`` (validated inputs).

    Returns the working matrices, whose complete assignment of least total is
    the optimum of the gated / non-assignment problem, and the mask of pairs
    worth keeping afterwards. Costs are first scaled by a power of two (exact),
    so that the working matrices cannot overflow.
    """
    n1, n2 = c.shape[-2:]
    e = cost_exponents(c, *(() if miss is None else (miss,)))
    c = scale_costs(c, e)
    if miss is not None:
        miss = np.ldexp(miss, -e)[..., None, None]    # per matrix, same scale as its costs
        # Partial matching with a cost `miss` per unassigned report: a pair is worth
        # taking only if c < 2*miss, and
        #   min over partial matchings of sum(c - 2 miss)
        #     = min over full assignments of sum(min(c - 2 miss, 0)),
        # so one rectangular assignment of the clipped matrix is exact (no augmentation).
        work = np.where(allowed, np.minimum(c - 2.0 * miss, 0.0), 0.0)     # |work| < 4
        return work, allowed & (work < 0)
    if allowed.all():
        return c, allowed                          # the plain complete assignment
    # Maximum number of allowed pairs first, then the smallest cost among those:
    # forbidden pairs get a cost larger than any possible saving, so every
    # assignment with fewer forbidden pairs is cheaper (exact lexicographic order).
    lo = np.min(c, axis=(-2, -1), where=allowed, initial=np.inf)
    hi = np.max(c, axis=(-2, -1), where=allowed, initial=-np.inf)
    lo, hi = np.where(np.isfinite(lo), lo, 0.0), np.where(np.isfinite(hi), hi, 0.0)
    big = (min(n1, n2) + 1) * (hi - lo + 1.0)            # hi - lo < 2 after scaling
    return np.where(allowed, c - lo[..., None, None], big[..., None, None]), allowed


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
    r"""Optimal ``row_to_col`` of one gated sparse problem (validated inputs).

    The partial matching with a cost per unassigned report is the full matching
    of the rows into the columns plus one private dummy column per row:

    * an allowed pair (i, j) is an edge of weight :math:`c_{ij} - 2 c_0`, the
      dummy edge (i, n2 + i) has weight 0 — so the matching cost is
      :math:`\sum_{\text{pairs}} c_{ij} + c_0 (\#\text{unassigned rows} +
      \#\text{unassigned columns}) - c_0 (n_1 + n_2)`; pairs with
      :math:`c_{ij} \ge 2 c_0` are never worth taking and are left out;
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
    graph = int32_indices(sparse.coo_array(
        (np.concatenate([w_pair, np.full(n1, w_dummy)]),
         (np.concatenate([rows, np.arange(n1)]), np.concatenate([cols, n2 + np.arange(n1)]))),
        shape=(n1, n1 + n2)))
    r, col = min_weight_full_bipartite_matching(graph)
    real = col < n2
    out[r[real]] = col[real]
    return out


def _associate_sparse(cost, threshold, miss_cost) -> Association:
    """:func:`assign_two_lists` for a scipy.sparse matrix of gated pair costs."""
    csr = _as_sparse_cost(cost)
    th = as_threshold(threshold)
    miss = _as_miss_cost(miss_cost)
    n1, n2 = csr.shape
    check_size(24 * (csr.nnz + n1), MEMORY_LIMIT, name="cost", what="bytes of the sparse graph",
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


def assign_two_lists(cost, *, threshold=None, miss_cost=None) -> Association:
    r"""The joint maximum-likelihood association: an exact linear assignment.

    Parameters
    ----------
    cost : array_like, shape (..., n1, n2), or scipy.sparse matrix (n1, n2)
        Pair costs (proximity measures :math:`\kappa_{ij}` or negative
        log-likelihoods); ``+inf`` forbids a pair; rectangular allowed.
        Leading axes are a batch (solved one matrix at a time). A
        ``scipy.sparse`` array or matrix holds the *gated* pairs only: a stored
        entry (an explicit 0 included) is an allowed pair, a missing entry a
        forbidden one (what ``+inf`` is in a dense matrix); it is solved by a
        sparse assignment (see Notes), in memory and time that grow with the
        stored pairs instead of :math:`n_1 n_2`
        (:func:`radarfusion_ref.gating.gate_sparse` builds such a matrix).
    threshold : float, optional
        Gate :math:`\gamma > 0`: a pair is allowed only if its cost is
        strictly below it, as in
        :func:`radarfusion_ref.association.associate_pointwise` and
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
    :math:`\pi`) is the product of the pointwise likelihood measures, so its
    negative logarithm is :math:`\tfrac12\sum_j \kappa_{j\pi(j)}` plus a constant,
    and the ML hypothesis solves

    .. math::

        \hat\pi = \arg\min_{\pi} \sum_{i} c_{i\pi(i)},

    a linear assignment problem (:func:`scipy.optimize.linear_sum_assignment`,
    :math:`O(n^3)`, instead of enumerating :math:`n!` hypotheses).

    * No `threshold`, no `miss_cost`: a complete assignment of
      :math:`\min(n_1, n_2)` pairs of smallest total cost.
    * `threshold` only: the largest number of pairs within the gate, and among
      those the smallest total cost (the :math:`\text{miss\_cost}\to\infty`
      limit). All pairs gated out: no pairs, no error.
    * `miss_cost` :math:`c_0`: the partial assignment minimising
      :math:`\sum_{\text{pairs}} c_{ij} + c_0\,(\#\text{unassigned rows} +
      \#\text{unassigned columns})`. This equals the standard augmented
      :math:`(n_1+n_2)` square problem with dummy rows and columns; it is
      solved exactly, without the augmentation, as one rectangular assignment
      of :math:`\min(c_{ij} - 2c_0, 0)`.
    * Sparse `cost`: the same three problems on the stored pairs, as one
      full matching of the :math:`n_1` rows into the :math:`n_2` columns plus
      one private "unassigned" column per row — pair weight
      :math:`c_{ij} - 2c_0` (pairs with :math:`c_{ij} \ge 2c_0` are left out),
      unassigned weight 0; without `miss_cost`, an unassigned weight larger than
      any saving among pairs, so the largest number of pairs comes first — by
      :func:`scipy.sparse.csgraph.min_weight_full_bipartite_matching` (LAPJVsp).
      Decisions equal the dense solver's on the same problem (``+inf`` where
      nothing is stored); gating plus assignment of :math:`10^4` reports per
      radar takes well under a second (``benchmarks/bench_association.py``).

    References
    ----------
    Grachov & Korneev (2010), eqs. (5)–(6) and the joint proximity measure
    :math:`\kappa_n^* = \sum_j \kappa_j^*`; Crouse (2016).

    Examples
    --------
    >>> c = [[0.5, 0.1], [0.2, 3.0]]
    >>> r = assign_two_lists(c)
    >>> r.pairs.tolist(), r.cost
    ([[0, 1], [1, 0]], 0.30000000000000004)
    >>> r = assign_two_lists([[1.0, 9.0], [9.0, 9.0]], miss_cost=2.0)
    >>> r.pairs.tolist(), r.unassigned_rows.tolist(), r.unassigned_cols.tolist(), r.cost
    ([[0, 0]], [1], [1], 5.0)
    >>> assign_two_lists([[5.0, 6.0]], threshold=1.0).n_assigned
    0
    >>> from scipy import sparse
    >>> gated = sparse.csr_array(([0.5, 0.1, 0.2], ([0, 0, 1], [0, 1, 0])), shape=(2, 3))
    >>> assign_two_lists(gated).pairs.tolist()
    [[0, 1], [1, 0]]
    """
    if sparse.issparse(cost):
        # gated, scipy.sparse
        return _associate_sparse(cost, threshold, miss_cost)
    c, gate, c0 = (as_cost(cost), as_threshold(threshold),
                   _as_miss_cost(miss_cost))
    allowed = (c < gate) & np.isfinite(c)       # the gate: kappa < gamma
    # one plain assignment per matrix
    work, useful = _work_costs(c, allowed, c0)
    row_to_col = np.full(c.shape[:-1], -1)
    for b in np.ndindex(c.shape[:-2]):          # every matrix of a batch
        # argmin over pairings pi
        rows, cols = linear_sum_assignment(work[b])
        # drop pairs not allowed / not worth it
        keep = useful[b][rows, cols]
        row_to_col[b][rows[keep]] = cols[keep]
    return make_association(c, row_to_col, c0)


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
def injections(n1: int, n2: int) -> np.ndarray:
    """Kernel (trusted input): all ``n2! / (n2 - n1)!`` injective maps rows -> columns.

    For ``n1 <= n2``, as a cached read-only int8 array (check the count first).
    """
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


def assign_two_lists_bruteforce(cost, *, threshold=None, miss_cost=None) -> Association:
    r"""The joint ML association by enumerating every joint hypothesis.

    The reference route for :func:`assign_two_lists`: the same problem (same
    arguments, same meaning), solved by scoring every hypothesis. Square
    matrices without gate or miss cost enumerate the :math:`n!` permutations
    (chunked, vectorized); otherwise all partial matchings are scored.

    Parameters
    ----------
    cost : array_like, shape (..., n1, n2)
        As in :func:`assign_two_lists`.
    threshold, miss_cost : float, optional
        As in :func:`assign_two_lists`.

    Returns
    -------
    Association

    Raises
    ------
    ValueError
        As :func:`assign_two_lists`; and, before anything is allocated, if
        there are more than
        :data:`~radarfusion_ref.engine.assignment.MAX_HYPOTHESES` complete
        hypotheses (:math:`n > 10`), more than
        :data:`~radarfusion_ref.engine.assignment.MAX_PARTIAL_MATCHINGS` partial
        ones (gate / miss cost / forbidden pairs, e.g. :math:`8 \times 8`), or
        more than :data:`~radarfusion_ref.engine.assignment.MAX_SCORED_HYPOTHESES`
        over the whole batch. The message names
        the scalable alternative, :func:`assign_two_lists`.

    Notes
    -----
    Grachov & Korneev's "optimal algorithm": full enumeration of the
    hypotheses :math:`H_n` and choice of the most plausible one, eq. (6).
    Among hypotheses of equal cost the first enumerated is returned.

    Examples
    --------
    >>> assign_two_lists_bruteforce([[0.5, 0.1], [0.2, 3.0]]).row_to_col
    array([1, 0])
    """
    c = as_cost(cost)
    th = as_threshold(threshold)
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
        count = check_size(math.perm(b, a), MAX_HYPOTHESES, name="cost",
                           what=f"joint hypotheses (n!-type count for a {n1} x {n2} matrix)",
                           alternative="assign_two_lists (exact linear assignment, O(n^3))")
    else:
        count = check_size(_n_partial(n1, n2), MAX_PARTIAL_MATCHINGS, name="cost",
                           what=f"partial matchings (gated or with a miss cost, {n1} x {n2} "
                                "matrix)",
                           alternative="assign_two_lists (exact linear assignment, O(n^3))")
    check_size(nb * count, MAX_SCORED_HYPOTHESES, name="cost",
               what=f"hypotheses to score over a batch of {nb} matrices",
               alternative="assign_two_lists (exact linear assignment, O(n^3))")
    e = cost_exponents(flat, *(() if miss is None else (miss,)))
    scaled = scale_costs(flat, e)                         # exact; sums of n entries cannot overflow
    if simple:
        work = np.swapaxes(scaled, 1, 2) if transpose else scaled
        hyps = injections(a, b)
        best = np.full(nb, np.inf)
        best_k = np.zeros(nb, dtype=int)
        idx = np.arange(a)
        chunk = max(1, BLOCK_BYTES // (8 * a * nb))   # bounded memory per block
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
        return make_association(c, out.reshape(*batch, n1), None)

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
    return make_association(c, out.reshape(*batch, n1), miss)


