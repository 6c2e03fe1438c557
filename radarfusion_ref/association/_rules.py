"""The association rules: pointwise, joint (exact), and the marginal association probabilities."""

from __future__ import annotations

import math

import numpy as np

from ..engine import assignment
from ..engine._validation import (
    _describe,
    as_choice,
)
from ..engine.assignment import (
    MAX_HYPOTHESES,
    Association,
)
from ..engine.assignment._checks import (
    _as_cost,
    _as_threshold,
    _exponents,
    _limit,
    _scaled,
)
from ..engine.assignment._two_d import _BLOCK_BYTES, _injections, _make_result


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


# --------------------------------------------------------------------------- pointwise
def associate_pointwise(cost, threshold=None, *, order: str = "scan") -> Association:
    r"""The paper's simplified pointwise association, or its greedy best-first variant.

    Parameters
    ----------
    cost : array_like, shape (..., n1, n2)
        Proximity measures :math:`\kappa_{ij}`; ``+inf`` forbids a pair.
        Leading axes are a batch, processed vectorized.
    threshold : float or None
        The gate :math:`\gamma > 0` (the paper's :math:`\kappa_{\text{th}}`):
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
        ``cost`` is the sum of the accepted pairs' costs.

    Raises
    ------
    ValueError
        For NaN or ``-inf`` costs, an empty matrix, a threshold ≤ 0 or an
        unknown `order`.

    Notes
    -----
    The paper replaces the full search over pairwise hypotheses :math:`G_k`
    by "accepting the first plausible hypothesis with
    :math:`\kappa_k^* < \kappa_{\text{th}}` (the book's :math:`\gamma`), then excluding the associated
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
def associate_joint(cost, *, threshold=None, miss_cost=None) -> Association:
    r"""The joint maximum-likelihood association: an exact linear assignment.

    The engine's 2-D solver, :func:`radarfusion_ref.engine.assignment.solve_2d`,
    applied to the chapter's cost matrix; its arguments, result and errors are
    documented here.

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
        (:func:`radarfusion_ref.gating.gate_sparse_2d` builds such a matrix).
    threshold : float, optional
        Gate :math:`\gamma > 0`: a pair is allowed only if its cost is
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
    >>> r = associate_joint(c)
    >>> r.pairs.tolist(), r.cost
    ([[0, 1], [1, 0]], 0.30000000000000004)
    >>> r = associate_joint([[1.0, 9.0], [9.0, 9.0]], miss_cost=2.0)
    >>> r.pairs.tolist(), r.unassigned_rows.tolist(), r.unassigned_cols.tolist(), r.cost
    ([[0, 0]], [1], [1], 5.0)
    >>> associate_joint([[5.0, 6.0]], threshold=1.0).n_assigned
    0
    >>> from scipy import sparse
    >>> gated = sparse.csr_array(([0.5, 0.1, 0.2], ([0, 0, 1], [0, 1, 0])), shape=(2, 3))
    >>> associate_joint(gated).pairs.tolist()
    [[0, 1], [1, 0]]
    """
    return assignment.solve_2d(cost, threshold=threshold, miss_cost=miss_cost)


# --------------------------------------------------------------------------- marginals
def association_probabilities(cost, *, k=None) -> np.ndarray:
    r"""Marginal probabilities that report ``i`` of radar 1 and ``j`` of radar 2 match.

    Parameters
    ----------
    cost : array_like, shape (n1, n2)
        **Negative log-likelihoods** of the pairs (for the proximity measure,
        :math:`\kappa/2`), so a joint hypothesis :math:`\pi` has likelihood
        proportional to :math:`\exp(-\sum_i c_{i\pi(i)})`; ``+inf`` forbids.
    k : int, optional
        None (default): exact, by enumerating every complete assignment (small
        matrices only). An integer: the approximation from the `k` best
        hypotheses of :func:`radarfusion_ref.engine.assignment.k_best_2d`
        (Murty's ranking).

    Returns
    -------
    numpy.ndarray, shape (n1, n2)
        :math:`P(i \leftrightarrow j)`; rows (of the shorter side) sum to 1.

    Raises
    ------
    ValueError
        For invalid costs, ``k < 1``, no feasible assignment, or, before
        anything is allocated, more than :data:`~radarfusion_ref.engine.assignment.MAX_HYPOTHESES` hypotheses to
        enumerate exactly (the message points to the `k`-best route) or a `k`
        beyond the limits of :func:`radarfusion_ref.engine.assignment.k_best_2d`.

    Notes
    -----
    With equal priors over the complete hypotheses,

    .. math::

        P(i \leftrightarrow j) = \frac{\sum_{\pi:\,\pi(i) = j} e^{-C(\pi)}}
                                       {\sum_{\pi} e^{-C(\pi)}},

    computed with the log-sum-exp shift so nothing underflows. Truncating the
    sums to the :math:`k` best :math:`\pi` is the usual approximation; it is
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
        kb = assignment.k_best_2d(ws, k)        # rows = the shorter side; scaled: same ranking
        assign, costs = kb.row_to_col, kb.cost
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


