r"""Pointwise and joint association of two radars' reports.

Two radars report on the same objects; the fusion centre must decide which
report of radar 1 and which report of radar 2 belong to one object. The input
of every function here is a **cost matrix** ``cost[..., i, j]`` — the proximity
measure :math:`\kappa_{ij}` (or any negative log-likelihood) of pairing report
``i`` of radar 1 with report ``j`` of radar 2. ``+inf`` marks a forbidden pair;
NaN and ``-inf`` are refused.

Procedures (Grachov & Korneev 2010, text around eqs. (5)–(6)):

* :func:`associate_pointwise` — the paper's simplified pointwise rule: scan the
  :math:`n^2` pairwise hypotheses :math:`G_k`, accept the first one whose
  :math:`\kappa` is below the gate, remove both reports, go on
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
* the scenes of the chapter come from
  :func:`radarfusion_ref.engine.scenes.two_radar_clutter_scene` (missed detections and
  false reports included);
* :func:`compare_decisions` — the Monte-Carlo decision-level comparison of the
  three procedures used by the chapter;
* :func:`decision_outcome` and :func:`calibrate_gate` — every rule's decisions
  classified per trial (correct, false accept, rejected), and the gate that
  puts a rule at a given false-accept or false-reject rate (the fair
  comparison of the rules at the same error rate).

The solvers themselves live in :mod:`radarfusion_ref.engine.assignment` (the home of
the 2-D and S-D assignment solvers): :func:`associate_joint`,
:func:`associate_bruteforce` and :func:`k_best_assignments` call
:func:`radarfusion_ref.engine.assignment.solve_2d`,
:func:`radarfusion_ref.engine.assignment.solve_2d_bruteforce` and
:func:`radarfusion_ref.engine.assignment.k_best_2d`; their results,
:class:`radarfusion_ref.engine.assignment.Association` and
:class:`radarfusion_ref.engine.assignment.KBestAssignments` (import them from there),
share the vocabulary ``cost``, ``lower_bound``, ``gap``, ``history``, ``exact``
with the decisions in ``row_to_col``.

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

import math
import warnings
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .engine import assignment
from .engine._validation import (
    MEMORY_LIMIT,
    _describe,
    as_bool,
    as_choice,
    as_covariance,
    as_float_array,
    as_positive,
    as_probability,
    broadcast,
)
from .engine.assignment import (
    MAX_HYPOTHESES,
    Association,
    KBestAssignments,
)
from .engine.assignment._checks import (
    _as_cost,
    _as_threshold,
    _exponents,
    _limit,
    _scaled,
)
from .engine.assignment._two_d import _BLOCK_BYTES, _injections, _make_result
from .engine.errors import RadarFusionWarning
from .engine.linalg import mahalanobis_sq_pairwise
from .engine.montecarlo import Proportion, proportion

__all__ = [
    "DecisionComparison",
    "DecisionOutcome",
    "all_correct",
    "associate_bruteforce",
    "associate_joint",
    "associate_pointwise",
    "association_probabilities",
    "calibrate_gate",
    "compare_decisions",
    "decision_outcome",
    "k_best_assignments",
    "non_assignment_cost",
    "outcome_by_gate",
    "proximity_matrix",
]

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


# --------------------------------------------------------------------------- brute force
def associate_bruteforce(cost, *, threshold=None, miss_cost=None) -> Association:
    r"""The joint ML association by enumerating every joint hypothesis.

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
        there are more than
        :data:`~radarfusion_ref.engine.assignment.MAX_HYPOTHESES` complete
        hypotheses (:math:`n > 10`), more than
        :data:`~radarfusion_ref.engine.assignment.MAX_PARTIAL_MATCHINGS` partial
        ones (gate / miss cost / forbidden pairs, e.g. :math:`8 \times 8`), or
        more than :data:`~radarfusion_ref.engine.assignment.MAX_SCORED_HYPOTHESES`
        over the whole batch. The message names
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
    return assignment.solve_2d_bruteforce(cost, threshold=threshold, miss_cost=miss_cost)


# --------------------------------------------------------------------------- Murty k-best
def k_best_assignments(cost, k) -> KBestAssignments:
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
    >>> r = k_best_assignments([[1.0, 2.0], [2.0, 5.0]], 5)
    >>> r.row_to_col.tolist(), r.cost.tolist()
    ([[1, 0], [0, 1]], [4.0, 6.0])
    """
    return assignment.k_best_2d(cost, k)


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
        hypotheses of :func:`k_best_assignments`.

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
        beyond the limits of :func:`k_best_assignments`.

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
        kb = k_best_assignments(ws, k)          # rows = the shorter side; scaled: same ranking
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


# --------------------------------------------------------------------------- non-assignment cost
def _non_assignment_iv(p_detect1, p_detect2, false_density1, false_density2, object_density,
                       innovation_cov, with_logdet):
    """Validated, broadcast arguments of :func:`non_assignment_cost`, ``ln det(2 pi S)`` last."""
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
    return broadcast(p_detect1=p1, p_detect2=p2, false_density1=lam1, false_density2=lam2,
                     object_density=beta, innovation_cov=logdet)


def non_assignment_cost(*, p_detect1, p_detect2, false_density1, false_density2,
                        object_density, innovation_cov=None, logdet: bool = False):
    r"""Per-report non-assignment cost (in proximity units) from the likelihood ratio.

    Parameters
    ----------
    p_detect1, p_detect2 : float or array_like
        Detection probabilities :math:`P_{D,1}, P_{D,2}` of the two radars, in (0, 1].
    false_density1, false_density2 : float or array_like
        False-report densities :math:`\rho_{F,1}, \rho_{F,2}` (expected false
        reports per unit volume of the measurement space), ≥ 0.
    object_density : float or array_like
        Density :math:`\rho_T > 0` of objects (per unit volume).
    innovation_cov : float or array_like, shape (..., d, d) or scalar
        :math:`S = \Sigma_1 + \Sigma_2`, the covariance of the difference of
        two reports of one object (a scalar is a 1-D variance). Symmetric
        positive definite; variances from 1e-300 to 1e300 are handled.
        Required with ``logdet=False``; optional with ``logdet=True`` (then
        only validated and broadcast: the pair costs carry the determinant).
    logdet : bool, optional
        False (default): the cost for a matrix of proximity measures
        :math:`\kappa_{ij}` (``proximity_matrix(...)``), which holds
        :math:`-\tfrac12\ln\det(2\pi S)` for the one `innovation_cov`. True:
        the cost for a matrix of full ML costs :math:`\kappa_{ij} +
        \ln\det(2\pi S_{ij})` (``proximity_matrix(..., logdet=True)``), right when
        :math:`S_{ij}` differs from pair to pair.

    Returns
    -------
    float or numpy.ndarray
        The cost :math:`c_0` to pass as ``miss_cost`` to :func:`associate_joint`
        with a cost matrix of proximity measures :math:`\kappa_{ij}`; ``+inf``
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
        If :math:`c_0 \le 0`: no pair with :math:`\kappa \ge 0` can beat
        leaving both reports unassigned. (``logdet=False`` only: the full
        costs of ``logdet=True`` may be negative).

    Notes
    -----
    Objects form a Poisson field of density :math:`\rho_T`; radar :math:`r`
    detects each with probability :math:`P_{D,r}` and adds false reports of
    density :math:`\rho_{F,r}`. Integrating the unknown position out, a pair
    :math:`(i, j)` contributes :math:`\rho_T P_{D,1} P_{D,2}\, \mathcal N(\hat x_{1i} -
    \hat x_{2j}; 0, S)` to the likelihood of a hypothesis and an unpaired
    report :math:`u_r = \rho_{F,r} + \rho_T P_{D,r} (1 - P_{D,\bar r})` (a false
    report, or an object the other radar missed). Pairing beats leaving both
    reports unpaired iff

    .. math::

        \kappa_{ij} < 2\ln\frac{\rho_T P_{D,1} P_{D,2}}{u_1 u_2} - \ln\det(2\pi S)
        = 2c_0,

    and, with ``logdet=True``, :math:`c_0 = \ln(\rho_T P_{D,1} P_{D,2}/(u_1 u_2))`
    against the costs :math:`\kappa_{ij} + \ln\det(2\pi S_{ij})`,

    and with cost :math:`c_0` per unassigned report the assignment cost
    :math:`\sum \kappa + c_0\,(\#\text{unassigned})` is, up to a constant,
    :math:`-2\ln` of the hypothesis likelihood (the book's eq.
    ``eq-non-assignment-cost``). Everything is computed in the log domain
    (:func:`numpy.logaddexp` for :math:`\ln u_r`, :math:`\ln\det S` through
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
    p1, p2, lam1, lam2, beta, ln_det_2pi_s = _non_assignment_iv(
        p_detect1, p_detect2, false_density1, false_density2, object_density, innovation_cov,
        with_logdet)
    # Log domain throughout: ln u_r = ln(rho_F,r + rho_T P_r (1 - P_other)) by logaddexp,
    # so neither tiny nor huge densities overflow or underflow.
    with np.errstate(divide="ignore"):
        lb = np.log(beta)
        log_u1 = np.logaddexp(np.log(lam1), lb + np.log(p1) + np.log1p(-p2))
        log_u2 = np.logaddexp(np.log(lam2), lb + np.log(p2) + np.log1p(-p1))
    m = lb + np.log(p1) + np.log(p2) - log_u1 - log_u2
    # with logdet=True a given `innovation_cov` only shapes the result (0 * its log det)
    m = m + (0.0 if with_logdet else -0.5) * ln_det_2pi_s
    # (full costs kappa + ln det 2 pi S may be negative, so c_0 <= 0 is no alarm there)
    if not with_logdet and np.any(m <= 0):
        warnings.warn(
            "non-assignment cost <= 0: no pair with proximity >= 0 beats leaving both "
            "reports unassigned (false-report density too high for this accuracy)",
            RadarFusionWarning, stacklevel=2)
    return float(m) if np.ndim(m) == 0 else m


def proximity_matrix(reports1, reports2, sigma1, sigma2, *, logdet: bool = False) -> np.ndarray:
    r"""All pairwise proximity measures :math:`\kappa_{ij}` (or full ML costs) of two report lists.

    A thin wrapper around :func:`radarfusion_ref.engine.linalg.mahalanobis_sq_pairwise`
    (every (radar-1, radar-2) pair).

    Parameters
    ----------
    reports1, reports2 : array_like, shape (..., n1, d) and (..., n2, d)
    sigma1, sigma2 : float or array_like, shape (..., n1) and (..., n2)
        Per-coordinate error standard deviations: one number per radar, or one
        per report (each report's covariance is :math:`\sigma^2 I`); arrays
        broadcast against the reports' leading axes.
    logdet : bool, optional
        False (default): the proximity measure :math:`\kappa_{ij}` alone.
        True: the full maximum-likelihood cost
        :math:`c_{ij} = \kappa_{ij} + \ln\det(2\pi S_{ij})`, :math:`-2\ln` of the
        likelihood :math:`\mathcal N(\hat x_{1i} - \hat x_{2j}; 0, S_{ij})` of the pair
        with the object's position integrated out, :math:`S_{ij} = (\sigma_{1i}^2 +
        \sigma_{2j}^2) I`. Pass it with ``non_assignment_cost(..., logdet=True)``.

    Returns
    -------
    numpy.ndarray, shape (..., n1, n2)
        :math:`\kappa_{ij} = \lVert \hat x_{1i} - \hat x_{2j}\rVert^2 /
        (\sigma_{1i}^2 + \sigma_{2j}^2)` — the exponent of eq. (7) (times −2) — plus
        :math:`d\ln(2\pi(\sigma_{1i}^2 + \sigma_{2j}^2))` with ``logdet=True``.

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
    domain, :math:`\ln(\sigma_1^2 + \sigma_2^2)` by :func:`numpy.logaddexp`, so
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
        out = mahalanobis_sq_pairwise(r1, r2, v1 * eye, v2 * eye)
    else:
        v1, v2 = np.square(np.atleast_1d(sd1)), np.square(np.atleast_1d(sd2))
        if not (np.all(np.isfinite(v1)) and np.all(v1 > 0) and np.all(np.isfinite(v2))
                and np.all(v2 > 0)):
            raise ValueError("`sigma1` and `sigma2` must have squares within the float range "
                             f"(1e-154 < sigma < 1e154); received {_describe(sd1)} and "
                             f"{_describe(sd2)}")
        c1 = v1[..., :, None, None] * eye                     # (..., n1, d, d)
        c2 = v2[..., :, None, None] * eye                     # (..., n2, d, d)
        out = mahalanobis_sq_pairwise(r1, r2, c1, c2)
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
    r"""Probability that every pairing is correct, for three procedures.

    Attributes
    ----------
    pointwise : Proportion
        The paper's pointwise rule as written (scan order, gate on each pair).
    greedy : Proportion
        Greedy best-first with the same gate.
    joint : Proportion
        Joint ML (:func:`associate_joint`), followed by the paper's joint
        test (:math:`\kappa_n^* < \gamma_n`, the :math:`\chi^2_n` gate; rejection counts as
        a wrong decision).
    joint_ml : Proportion
        Joint ML alone (no test).
    """

    pointwise: Proportion
    greedy: Proportion
    joint: Proportion
    joint_ml: Proportion


def compare_decisions(kappa, truth, *, threshold, joint_threshold) -> DecisionComparison:
    r"""Monte-Carlo decision-level comparison of pointwise, greedy and joint association.

    Parameters
    ----------
    kappa : array_like, shape (trials, n, n)
        Proximity measures of each simulated scene.
    truth : array_like of int, shape (trials, n)
        Correct ``row_to_col`` of each scene.
    threshold : float or None
        Pointwise gate :math:`\gamma` (1 hypothesis, e.g.
        ``gating.gate_threshold(P_lo, d)``); None or ``+inf``: no gate.
    joint_threshold : float or None
        Joint gate on :math:`\kappa_n^*` (e.g. ``gating.gate_threshold(P_lo, n * d)``);
        None or ``+inf``: no joint test.

    Returns
    -------
    DecisionComparison
        Each field a :class:`~radarfusion_ref.engine.montecarlo.Proportion` carrying
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
    passed = np.asarray(jt.cost) < jth
    return DecisionComparison(
        proportion(all_correct(pw.row_to_col, truth), None),
        proportion(all_correct(gr.row_to_col, truth), None),
        proportion(ok_j & passed, None),
        proportion(ok_j, None),
    )


# --------------------------------------------------------------------------- calibration
class DecisionOutcome(NamedTuple):
    """Per-trial classes of one rule's decisions (see :func:`decision_outcome`).

    Attributes
    ----------
    correct : numpy.ndarray of bool, shape (...)
        Every pair right and accepted (for ``"joint"``: and the joint test passed).
    false_accept : numpy.ndarray of bool, shape (...)
        At least one wrong pair accepted.
    rejected : numpy.ndarray of bool, shape (...)
        (property) Neither: nothing wrong accepted, but some true pair not.
    """

    correct: np.ndarray
    false_accept: np.ndarray

    @property
    def rejected(self) -> np.ndarray:
        """Nothing wrong accepted, some true pair not accepted."""
        return ~self.correct & ~self.false_accept


_RULES = ("scan", "greedy", "joint")


def _outcome_iv(kappa, truth, rule):
    c = _as_cost(kappa, "kappa")
    t = _as_decisions(truth, "truth")
    if t.shape != c.shape[:-1]:
        raise ValueError(f"`truth` must have shape (..., n1) = {c.shape[:-1]} to match `kappa`; "
                         f"received shape {t.shape}")
    if np.any(t >= c.shape[-1]):
        raise ValueError(f"`truth` entries must be radar-2 indices < n2 = {c.shape[-1]} or -1; "
                         f"received largest entry {int(t.max())}")
    return c, t, as_choice(rule, "rule", _RULES)


def _as_gate(gate, name: str = "gate") -> float:
    g = as_float_array(gate, name, allow_nonfinite=True)
    if g.ndim != 0 or not (float(g) > 0):
        raise ValueError(f"`{name}` must be a single number > 0 (+inf: no gate); received "
                         f"{_describe(gate)}")
    return float(g)


def outcome_by_gate(kappa, truth, rule: str):
    r"""A rule's outcome as a function of its gate: ``gate -> DecisionOutcome`` per trial.

    `kappa`, `truth` and `rule` as in :func:`decision_outcome` (which calls the returned
    function once); a trial is correct when every pair is right and accepted, a false
    accept when a wrong pair is accepted, rejected otherwise. The joint pairing does not
    depend on the gate, so it is computed once, here.

    >>> o = outcome_by_gate([[0.1, 4.0], [5.0, 0.2]], [0, 1], "joint")
    >>> bool(o(1.0).correct), bool(o(0.2).rejected)
    (True, True)
    """
    c, t, rule = _outcome_iv(kappa, truth, rule)
    if rule == "joint":
        res = associate_joint(c)
        right = all_correct(res.row_to_col, t)
        total = np.asarray(res.cost)

        def joint(gate):
            passed = total < _as_gate(gate)             # the joint test, kappa*_n < gamma_n
            return DecisionOutcome(right & passed, ~right & passed)
        return joint
    order = "scan" if rule == "scan" else "best_first"

    def pointwise(gate):
        decided = associate_pointwise(c, _as_gate(gate), order=order).row_to_col
        return DecisionOutcome(all_correct(decided, t),
                               np.any((decided >= 0) & (decided != t), axis=-1))
    return pointwise


def decision_outcome(kappa, truth, rule: str, gate) -> DecisionOutcome:
    r"""Classify one rule's decisions per trial: correct, false accept, or rejected.

    Parameters
    ----------
    kappa : array_like, shape (..., n1, n2)
        Proximity measures :math:`\kappa_{ij}` per trial (``+inf`` forbids a pair).
    truth : array_like of int, shape (..., n1)
        The true ``row_to_col`` per trial (-1: no partner).
    rule : {"scan", "greedy", "joint"}
        The paper's pointwise scan (:func:`associate_pointwise`,
        ``order="scan"``), greedy best-first (``order="best_first"``), or
        joint ML (:func:`associate_joint`) followed by the joint test.
    gate : float
        The per-pair gate :math:`\gamma` of a pointwise rule, or the gate
        :math:`\gamma_n` of the joint test on the chosen pairing's summed
        :math:`\kappa`; ``+inf``: no gate.

    Returns
    -------
    DecisionOutcome
        ``(correct, false_accept)`` boolean arrays of shape (...), and the
        ``rejected`` property.

    Raises
    ------
    ValueError
        For NaN or ``-inf`` in `kappa`, a `truth` of another shape or with
        indices outside ``[-1, n2)``, an unknown `rule`, or a `gate` that is not
        a single number > 0.
    TypeError
        For non-numeric `kappa` or a `truth` that is not an integer array.

    Notes
    -----
    A trial is **correct** when every pair is right and accepted (the joint
    rule also needs :math:`\kappa^*_n < \gamma_n`), a **false accept** when
    at least one wrong pair is accepted, and **rejected** otherwise. For
    ``"greedy"`` and ``"joint"`` the false-accept rate cannot fall and the
    rejection rate cannot rise as the gate widens: greedy best-first takes
    the pairs in increasing :math:`\kappa`, so the pairs it accepts under a
    gate are a subset of those it accepts under any wider gate; the joint
    pairing does not depend on the gate at all.

    Examples
    --------
    >>> k = np.array([[[0.1, 4.0], [5.0, 0.2]], [[3.0, 0.1], [0.2, 3.0]]])
    >>> o = decision_outcome(k, [[0, 1], [0, 1]], "greedy", 6.6)
    >>> o.correct, o.false_accept, o.rejected
    (array([ True, False]), array([False,  True]), array([False, False]))
    """
    c, t, rule = _outcome_iv(kappa, truth, rule)
    gate = _as_gate(gate)
    return outcome_by_gate(c, t, rule)(gate)


def calibrate_gate(kappa, truth, rule: str, alpha, *, error: str = "false_accept",
                   gates=None) -> float:
    r"""The gate at which a rule's empirical error rate on these trials meets `alpha`.

    Parameters
    ----------
    kappa, truth, rule
        As in :func:`decision_outcome` (the calibration trials).
    alpha : float
        Target rate in [0, 1].
    error : {"false_accept", "false_reject"}, optional
        ``"false_accept"`` (default): the **widest** gate whose false-accept
        rate (share of trials with a wrong pair accepted) is at most `alpha`.
        ``"false_reject"``: the **narrowest** gate whose rejection rate (share
        of trials with nothing wrong accepted but some true pair not) is at
        most `alpha`.
    gates : array_like, shape (k,), optional
        Candidate gates (> 0, increasing); every one is scored and the
        widest (narrowest) one meeting `alpha` is returned. None (default):
        the exact answer among all gates, found by bisection over the
        breakpoints of the rate — just above each distinct :math:`\kappa`
        (pointwise rules) or each trial's summed :math:`\kappa` of the
        chosen pairing (``"joint"``), where the decisions can change. The
        bisection is exact because the rates are monotone in the gate for
        ``"greedy"`` and ``"joint"`` (see :func:`decision_outcome`); for
        ``"scan"``, whose rates need not be monotone, `gates` is required.

    Returns
    -------
    float
        The calibrated gate.

    Raises
    ------
    ValueError
        As :func:`decision_outcome`; for `alpha` outside [0, 1], an unknown
        `error`, `gates` that are empty, not > 0 or not increasing, no
        `gates` with ``rule="scan"``, or no candidate gate meeting `alpha`
        (the message gives the best rate reached; never a clamped gate).

    Notes
    -----
    Calibrate on one set of trials and evaluate on fresh ones: the rate at
    the returned gate is biased low on the trials that chose it. For one
    object (``n1 = n2 = 1``) and known covariances the true pair's
    :math:`\kappa` is :math:`\chi^2_d`, so ``error="false_reject"`` returns
    the empirical :math:`1-\alpha` quantile of :math:`\kappa`, which
    converges to the :math:`\chi^2_d` quantile of eq-gate.

    Examples
    --------
    >>> k = np.array([[[0.5]], [[1.5]], [[2.5]], [[3.5]]])
    >>> calibrate_gate(k, [[0]] * 4, "greedy", 0.25, error="false_reject") > 2.5
    True
    """
    c, t, rule = _outcome_iv(kappa, truth, rule)
    a = _scalar(as_probability(alpha, "alpha", open_interval=False), "alpha")
    error = as_choice(error, "error", ("false_accept", "false_reject"))
    outcome = outcome_by_gate(c, t, rule)
    wide = error == "false_accept"

    def rate(g):
        o = outcome(g)
        return float(np.mean(o.false_accept if wide else o.rejected))

    if gates is not None:
        cand = as_float_array(gates, "gates")
        if cand.ndim != 1 or cand.size == 0 or np.any(cand <= 0) or np.any(np.diff(cand) <= 0):
            raise ValueError(f"`gates` must be a non-empty increasing 1-D array of numbers > 0; "
                             f"received {_describe(gates)}")
        rates = np.array([rate(float(g)) for g in cand])
        ok = np.flatnonzero(rates <= a)
        if ok.size == 0:
            raise ValueError(f"`alpha` = {a:g} is not reached by any of the `gates`: the lowest "
                             f"{error.replace('_', '-')} rate is {rates.min():.4g} (at gate "
                             f"{cand[int(np.argmin(rates))]:.4g}); pass "
                             f"{'narrower' if wide else 'wider'} gates")
        return float(cand[ok.max()] if wide else cand[ok.min()])
    if rule == "scan":
        raise ValueError("`gates` must be given for `rule` = 'scan': its error rates need not be "
                         "monotone in the gate, so only a scored grid is exact")
    if rule == "joint":
        stat = np.asarray(associate_joint(c).cost, dtype=float).ravel()
    else:
        stat = c[np.isfinite(c)]
    vals = np.unique(stat[np.isfinite(stat)])
    above = np.nextafter(vals, np.inf)                 # just above: a value passes the gate
    lowest = vals[0] if vals.size and vals[0] > 0 else np.nextafter(0.0, 1.0)
    cand = np.unique(np.concatenate([[lowest], above[above > 0], [np.inf]]))
    # the rate is monotone over cand: non-decreasing (false accept), non-increasing (reject)
    lo, hi = 0, cand.size - 1
    if wide:
        if rate(cand[0]) > a:
            raise ValueError(f"`alpha` = {a:g} is below the false-accept rate "
                             f"{rate(cand[0]):.4g} of the narrowest gate {cand[0]:.4g}")
        while lo < hi:                                  # largest index with rate <= a
            mid = (lo + hi + 1) // 2
            lo, hi = (mid, hi) if rate(cand[mid]) <= a else (lo, mid - 1)
        return float(cand[lo])
    if rate(cand[-1]) > a:
        raise ValueError(f"`alpha` = {a:g} is below the rejection rate {rate(cand[-1]):.4g} "
                         "even without a gate")
    while lo < hi:                                      # smallest index with rate <= a
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if rate(cand[mid]) <= a else (mid + 1, hi)
    return float(cand[lo])
