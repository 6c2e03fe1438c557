"""Murty's ranking of the k best 2-D assignments (with the Miller-Stone-Cox bounds)."""

from __future__ import annotations

import bisect
import heapq
import itertools
from functools import lru_cache

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..validation import MEMORY_LIMIT, as_int, check_size
from ._checks import _inverse, as_cost, cost_exponents, scale_costs
from ._results import KBestAssignments

__all__ = ["MAX_K_BEST", "k_best_two_lists"]


#: Largest `k` of :func:`k_best_two_lists` (and ``association_probabilities(k=...)``).
MAX_K_BEST = 100_000


#: Planned bytes per ranked hypothesis and matrix entry in :func:`k_best_two_lists`
#: (sub-problem matrices kept for pending children): the memory limit is checked
#: against ``_MURTY_BYTES_PER_NODE * k * n**2``.
_MURTY_BYTES_PER_NODE = 32

#: The pairs fixed above a Murty node: ``(previous, rows, cols)``, a chain shared
#: with the node's siblings and ended by ``None``.
_Fixed = tuple["_Fixed | None", np.ndarray, np.ndarray]


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


def k_best_two_lists(cost, k) -> KBestAssignments:
    r"""Rank the `k` best complete assignments (joint hypotheses): Murty's algorithm.

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
        For NaN or ``-inf`` costs, an empty matrix, ``k < 1``, ``k >``
        :data:`~radarfusion_ref.engine.assignment.MAX_K_BEST`, a planned working memory (about ``_MURTY_BYTES_PER_NODE
        * k * n**2`` bytes) above ``MEMORY_LIMIT``, or a hypothesis total
        beyond the float range.
    TypeError
        If `k` is not an integer.

    Notes
    -----
    Murty's partitioning: after the best remaining solution :math:`\pi` of a
    sub-problem (some pairs fixed, some forbidden) is output, its free rows
    :math:`r_1, \dots, r_q` give :math:`q` disjoint children — child
    :math:`t` fixes :math:`r_1 \dots r_{t-1}` to their columns in
    :math:`\pi` and forbids :math:`(r_t, \pi(r_t))`. Their union is every
    solution of the parent apart from :math:`\pi`, so taking the best child
    solution overall, repeatedly, ranks all assignments exactly.

    Work is saved as in Miller, Stone & Cox (1997): with dual potentials of
    the parent's optimum (reduced costs :math:`\bar c \ge 0`), child
    :math:`t` costs at least

    .. math::

        C(\pi) + \min_{j \ne \pi(r_t)} \bar c_{r_t j}
               + \min_{i \ne r_t} \bar c_{i \pi(r_t)},

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
    >>> r = k_best_two_lists([[1.0, 2.0], [2.0, 5.0]], 5)
    >>> r.row_to_col.tolist(), r.cost.tolist()
    ([[1, 0], [0, 1]], [4.0, 6.0])
    """
    c = as_cost(cost)
    if c.ndim != 2:
        raise ValueError(f"`cost` must be a single matrix (n1, n2); received shape {c.shape}")
    k = as_int(k, "k", minimum=1)
    check_size(k, MAX_K_BEST, name="k", what="ranked hypotheses",
               alternative="association_probabilities(cost) (exact, small n) or fewer hypotheses")
    n1, n2 = c.shape
    b0 = max(n1, n2)
    check_size(_MURTY_BYTES_PER_NODE * k * b0 * b0, MEMORY_LIMIT, name="k",
               what=f"bytes of Murty sub-problems (about {_MURTY_BYTES_PER_NODE} k n^2 "
                    f"for k = {k}, n = {b0})",
               alternative="a smaller `k`, or assign_two_lists for the best hypothesis alone")
    transpose = n1 > n2
    e = int(cost_exponents(c))
    work = scale_costs(c.T if transpose else c, e)             # exact power-of-two scaling
    a, b = work.shape                                      # a <= b real rows
    square = np.zeros((b, b))
    square[:a] = work
    is_real = np.arange(b) < a

    out_assign: list[tuple[_Fixed | None, np.ndarray, np.ndarray]] = []
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
    assign = np.array(rows_out, dtype=int).reshape(-1, a)
    if transpose:
        assign = _inverse(assign, n1) if assign.size else np.empty((0, n1), dtype=int)
    with np.errstate(over="ignore"):
        costs = np.ldexp(np.array(out_cost, dtype=float), e)
    if not np.all(np.isfinite(costs)):
        raise ValueError(
            "`cost`: a ranked hypothesis's total cost lies beyond the float range "
            f"(|total| > {np.finfo(float).max:.3g}); divide `cost` by a common factor")
    return KBestAssignments(assign, costs, solved)


