"""The association rules of the chapter: the paper's pointwise rule, and the marginal
association probabilities of the joint hypotheses."""

from __future__ import annotations

import math

import numpy as np

from ..engine import assignment
from ..engine.assignment import (
    BLOCK_BYTES,
    MAX_HYPOTHESES,
    Association,
    as_cost,
    as_threshold,
    cost_exponents,
    injections,
    make_association,
    scale_costs,
)
from ..engine.validation import (
    as_choice,
    check_size,
    describe,
)


def _as_decisions(value, name: str) -> np.ndarray:
    """``row_to_col`` vectors: integers >= -1, at least one axis, not empty."""
    if value is None or isinstance(value, (str, bytes, bool, np.bool_)):
        raise TypeError(f"`{name}` must be an integer array of decisions (row_to_col, -1 for "
                        f"unassigned); received {describe(value)}")
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        raise TypeError(f"`{name}` must be an integer array of decisions; received "
                        f"{describe(value)}") from None
    if arr.dtype.kind == "f" and arr.size and np.all(np.isfinite(arr)) \
            and np.all(arr == np.round(arr)):
        arr = arr.astype(int)
    if arr.dtype.kind not in "iu":
        raise TypeError(f"`{name}` must be an integer array of decisions (row_to_col, -1 for "
                        f"unassigned); received {describe(value)}")
    if arr.ndim < 1 or arr.size == 0:
        raise ValueError(f"`{name}` must be a non-empty array of shape (..., n1); received "
                         f"shape {arr.shape}")
    if np.any(arr < -1):
        raise ValueError(f"`{name}` entries must be column indices >= 0 or -1 (unassigned); "
                         f"received {describe(value)} (smallest entry {int(arr.min())})")
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
        ``+inf``: no gate (the same meaning as in
        :func:`~radarfusion_ref.engine.assignment.assign_two_lists`).
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
    (:func:`~radarfusion_ref.engine.assignment.assign_two_lists`).

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
    c = as_cost(cost)
    th = as_threshold(threshold)
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
    return make_association(c, row_to_col.reshape(*batch, n1), None)


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
        hypotheses of :func:`radarfusion_ref.engine.assignment.k_best_two_lists`
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
        beyond the limits of :func:`radarfusion_ref.engine.assignment.k_best_two_lists`.

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
    c = as_cost(cost)
    if c.ndim != 2:
        raise ValueError(f"`cost` must be a single matrix (n1, n2); received shape {c.shape}")
    n1, n2 = c.shape
    transpose = n1 > n2
    w = c.T if transpose else c
    a, b = w.shape
    e = int(cost_exponents(c))
    ws = scale_costs(w, e)                  # exact; hypothesis sums of scaled costs cannot overflow
    p = np.zeros((a, b))
    if k is None:
        check_size(math.perm(b, a), MAX_HYPOTHESES, name="cost",
                   what=f"joint hypotheses to enumerate exactly (a {n1} x {n2} matrix)",
                   alternative="association_probabilities(cost, k=...) (Murty's k best)")
        hyps = injections(a, b)                             # int8, cached, read-only
        rows = np.arange(a)
        chunk = max(1, BLOCK_BYTES // (8 * a))
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
        kb = assignment.k_best_two_lists(ws, k)        # rows = the shorter side; scaled: same ranking
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


