"""Finding the best grouping: enumeration, and the S-D assignment (HiGHS, Lagrangian, dummy index)."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..engine.assignment import (
    dense_work_bytes,
    relative_gap,
    sd_candidates_kernel,
    sd_dense_lagrangian_kernel,
    sd_enumerate_kernel,
    sd_milp_kernel,
)
from ..engine.linalg import mahalanobis_sq_pairwise
from ..engine.validation import (
    MEMORY_LIMIT,
    as_bool,
    as_choice,
    as_covariance,
    as_float,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    check_size,
    describe,
)
from ..gating import gate_threshold
from ._costs import (
    _COSTS,
    _cost_bytes,
    _finite_costs,
    _information,
    _reports_iv,
    _rescale,
    _tensor,
    n_groupings,
)

#: Largest number of groupings :math:`(n!)^{m-1}` that :func:`group_bruteforce`
#: enumerates, whatever its `max_groupings` (about a minute of work); beyond it,
#: use :func:`group_sd`.
MAX_GROUPINGS = 10**8

#: Largest number of candidate groups :math:`n^m` (binary variables) of one
#: scene that :func:`group_sd` hands to HiGHS (e.g. ``n = 100`` targets of
#: ``m = 3`` sources, or ``n = 31`` of ``m = 4``). ``method="lagrangian"``
#: without a gate is sized by memory instead: the cost tensor and its work
#: arrays within ``MEMORY_LIMIT`` bytes (``m = 3`` up to about ``n = 340`` in 2-D).
MAX_CANDIDATE_GROUPS = 10**6

#: The paper's four hypotheses for two sources and two fused tracks, as
#: ``hyp[i, p]`` = index of the report of source ``i`` bound to track ``p``

# ----------------------------------------------------------------------------- results
@dataclass(frozen=True)
class GroupingResult:
    r"""The best grouping of one scene (or of a batch of scenes).

    Attributes
    ----------
    groups : numpy.ndarray of int, shape (..., n, m)
        ``groups[..., k, i]`` is the index of source ``i``'s report in group
        ``k``; rows are sorted so that ``groups[..., :, 0] == arange(n)``.
    cost : float or numpy.ndarray, shape (...)
        Total cost of the grouping: the sum of its groups' costs
        (see :func:`group_costs`).
    cost_kind : str
        ``"ml"`` or ``"pairwise"``.
    method : str
        ``"bruteforce"`` (enumeration of all groupings), ``"milp"`` (the
        integer program of :func:`group_sd`) or ``"lagrangian"`` (its
        Lagrangian relaxation).
    relaxation_integral : bool or numpy.ndarray of bool or None
        For ``"milp"`` on the full tensor: whether the integer program's LP
        relaxation already had an integral optimum (so no branching was
        needed). ``None`` otherwise.
    lower_bound : float or numpy.ndarray
        A proved lower bound on the optimal total cost: the cost itself for the
        exact methods, the best Lagrangian dual value for ``"lagrangian"``.
    gap : float or numpy.ndarray
        Proved relative duality gap
        :math:`(\text{cost} - \text{lower bound}) / \max(|\text{cost}|, 1)`
        (0 for the exact methods).
    history : numpy.ndarray or None, shape (iterations, 2)
        For ``"lagrangian"`` on one scene: the best lower bound and the best
        cost after each iteration (summed over the independent clusters).
        ``None`` otherwise.
    exact : bool
        True when the proved gap is 0 (for every scene of a batch). With
        `cost`, `lower_bound`, `gap` and `history`, the
        :class:`radarfusion_ref.engine.assignment.AssignmentResult` vocabulary
        shared with the 2-D results.

    With missed detections and false reports (:func:`group_sd` with
    `p_detect`), `groups` has one row per group, ``-1`` marking a source
    without a report in that group, and the number of rows varies.
    """

    groups: np.ndarray
    cost: np.ndarray | float
    cost_kind: str
    method: str
    relaxation_integral: np.ndarray | bool | None = None
    lower_bound: np.ndarray | float | None = None
    gap: np.ndarray | float = 0.0
    history: np.ndarray | None = None
    exact: bool = True

    def __post_init__(self):
        if self.lower_bound is None:            # exact methods: the cost is its own bound
            object.__setattr__(self, "lower_bound", self.cost)



# ----------------------------------------------------------------------------- solvers (assignment)
def _normalise(tuples):
    """Sort the rows of (..., n, m) tuples by source 0."""
    order = np.argsort(tuples[..., 0], axis=-1)
    return np.take_along_axis(tuples, order[..., None], axis=-2)


def group_bruteforce(x, cov, *, cost: str = "ml", max_groupings: int = 10**7) -> GroupingResult:
    r"""Best grouping by enumerating all :math:`(n!)^{m-1}` groupings.

    Parameters
    ----------
    x : array_like, shape (..., m, n, d)
        Reports (see :func:`group_costs`); leading axes are independent scenes.
    cov : array_like, shape (..., m, n, d, d)
        Their covariances (broadcastable).
    cost : {"ml", "pairwise"}, optional
        Group cost (see :func:`group_costs`).
    max_groupings : int, optional
        Refuse problems with more groupings than this (default :math:`10^7`);
        whatever its value, more than :data:`MAX_GROUPINGS` (:math:`10^8`) are
        refused.

    Returns
    -------
    GroupingResult
        ``groups`` of shape ``(..., n, m)`` and the minimal total ``cost``;
        ties go to the first grouping in enumeration order.

    Raises
    ------
    ValueError
        For bad input (see :func:`group_costs`), more than `max_groupings` or
        :data:`MAX_GROUPINGS` groupings (use :func:`group_sd`), or totals that
        overflow.

    Notes
    -----
    The rule of the paper, eq. (26): the grouping :math:`g` minimising
    :math:`\sum_{k=1}^n c(g_k)`. Enumeration is vectorised over scenes and
    chunked over groupings.

    References
    ----------
    Sonar paper (2013), eqs. (7), (17), (24)–(26).

    Examples
    --------
    >>> x = np.array([[[0.0], [5.0]], [[5.3], [0.1]]])
    >>> r = group_bruteforce(x, np.ones((2, 2, 1, 1)))
    >>> r.groups.tolist()
    [[0, 1], [1, 0]]
    """
    cost = as_choice(cost, "cost", _COSTS)
    xb, cb, batch = _reports_iv(x, cov)
    B, m, n, _ = xb.shape
    G = n_groupings(n, m)
    limit = as_int(max_groupings, "max_groupings", minimum=1)
    if limit < G:
        raise ValueError(
            f"`max_groupings` = {limit} is below the {G} groupings of m = {m} sources and "
            f"n = {n} targets; raise it or use group_sd"
        )
    check_size(G, MAX_GROUPINGS, what=f"groupings (n!)**(m-1) (`x` with n = {n}, m = {m})",
               alternative="group_sd (the exact S-D assignment integer program)")
    tensor = _tensor(xb, cb, cost).reshape(B, -1)
    best, groups = sd_enumerate_kernel(tensor, m, n)                 # assignment's enumeration
    if not np.all(np.isfinite(best)):
        raise ValueError(
            "`x` and `cov`: the total cost of every grouping overflows the floating-point "
            "range; split the scene or gate the candidate groups first"
        )
    groups = groups.reshape(*batch, n, m)
    cost_out = best.reshape(batch)
    return GroupingResult(groups, float(cost_out) if not batch else cost_out, cost, "bruteforce")


# ----------------------------------------------------------------------------- gated S-D
def _detection_iv(m, p_detect, false_density, object_density):
    """Validate the detection model; ``None`` when no argument is given."""
    given = [a is not None for a in (p_detect, false_density, object_density)]
    if not any(given):
        return None
    if not all(given):
        missing = [n for n, g in zip(("p_detect", "false_density", "object_density"), given,
                                     strict=True) if not g]
        raise ValueError(
            "`p_detect`, `false_density` and `object_density` define the dummy index together; "
            f"received no {', '.join(f'`{n}`' for n in missing)}"
        )
    out = {}
    for name, value, lo_ok, hi in (("p_detect", p_detect, False, 1.0),
                                   ("false_density", false_density, True, None),
                                   ("object_density", object_density, False, None)):
        if name == "object_density":
            a = as_float(value, name)
        else:
            a = as_float_array(value, name)
            try:
                a = np.broadcast_to(a, (m,)).astype(float)
            except ValueError:
                raise ValueError(
                    f"`{name}` must be a number or have shape ({m},) (one per source); "
                    f"received shape {a.shape}"
                ) from None
        bad = (a < 0 if lo_ok else a <= 0) | ((a > hi) if hi is not None else False)
        if np.any(bad):
            rng_txt = "(0, 1]" if hi is not None else ("[0, inf)" if lo_ok else "(0, inf)")
            raise ValueError(f"`{name}` must lie in {rng_txt}; received {value!r}")
        out[name] = a
    return out


def _ragged_iv(x, cov):
    """Reports of a single scene with possibly unequal counts: lists of (n_i, d), (n_i, d, d)."""
    if isinstance(x, (list, tuple)):
        xs = [as_float_array(xi, "x", ndim_min=2) for xi in x]
    else:
        arr = as_float_array(x, "x", ndim_min=3)
        if arr.ndim != 3:
            raise ValueError(
                "`x` must be one scene, shape (m, n, d) or a list of m arrays (n_i, d), when "
                f"`p_detect` is given (the number of groups varies); received shape {arr.shape}"
            )
        xs = list(arr)
    m = len(xs)
    if m < 2 or any(xi.ndim != 2 for xi in xs):
        raise ValueError(
            "`x` must hold m >= 2 sources, each an array of shape (n_i, d); received "
            f"shapes {[xi.shape for xi in xs]}"
        )
    d = xs[0].shape[1]
    if d < 1 or any(xi.shape[1] != d for xi in xs) or any(xi.shape[0] < 1 for xi in xs):
        raise ValueError(
            "`x`: every source must report n_i >= 1 reports of one dimension d >= 1; received "
            f"shapes {[xi.shape for xi in xs]}"
        )
    cl = list(cov) if isinstance(cov, (list, tuple)) else None
    if cl is None:
        c = as_float_array(cov, "cov", ndim_min=2)
        if c.ndim >= 4:
            if c.shape[-4] not in (1, m):
                raise ValueError(
                    f"`cov` must have shape (m, n_i, {d}, {d}) with m = {m} (broadcastable); "
                    f"received shape {c.shape}"
                )
            cl = [c[..., min(i, c.shape[-4] - 1), :, :, :] for i in range(m)]
        else:
            cl = [c] * m
    if len(cl) != m:
        raise ValueError(f"`cov` must hold one entry per source (m = {m}); received {len(cl)}")
    cs = []
    for i, (xi, ci) in enumerate(zip(xs, cl, strict=True)):
        ci = as_float_array(ci, "cov", ndim_min=2)
        if ci.ndim == 2:
            ci = ci[None]
        if ci.ndim != 3 or ci.shape[-2:] != (d, d) or ci.shape[0] not in (1, xi.shape[0]):
            raise ValueError(
                f"`cov` of source {i} must have shape ({xi.shape[0]}, {d}, {d}) or ({d}, {d}); "
                f"received shape {ci.shape}"
            )
        cs.append(as_covariance(np.broadcast_to(ci, (xi.shape[0], d, d)), "cov", dim=d,
                                domain=False))
    return xs, cs


def _pair_statistics(xa, ca, xb, cb):
    """``kappa[a, b]``: the fused-difference statistic of report a and report b."""
    check_size(8 * 6 * xa.shape[0] * xb.shape[0] * (xa.shape[1] + 1) ** 2, MEMORY_LIMIT,
               what=f"bytes of pair statistics ({xa.shape[0]} x {xb.shape[0]} report pairs)",
               alternative="splitting the scene into regions")
    return mahalanobis_sq_pairwise(xa, xb, ca, cb)


def _gated_tuples(gates, counts, dummy):
    """Tuples (K, m) whose report pairs all pass the gate (``-1``: no report of that source)."""
    m = len(counts)
    T = np.arange(counts[0], dtype=np.int64)[:, None]
    if dummy:
        T = np.vstack([T, [[-1]]])
    for k in range(1, m):
        check_size(T.shape[0] * counts[k], MEMORY_LIMIT,
                   what=f"bytes of the gate mask ({T.shape[0]} partial groups x "
                        f"{counts[k]} reports of source {k})",
                   alternative="a narrower gate (larger `p_false_reject`)")
        mask = np.ones((T.shape[0], counts[k]), dtype=bool)
        for i in range(k):
            col = T[:, i]
            ok = col >= 0
            mask[ok] &= gates[i, k][col[ok]]
        r, j = np.nonzero(mask)
        parts = [np.hstack([T[r], j[:, None]])]
        if dummy:
            parts.append(np.hstack([T, np.full((T.shape[0], 1), -1)]))
        T = np.vstack(parts)
        check_size(8 * T.shape[0] * (m + 1), MEMORY_LIMIT,
                   what=f"bytes of gated candidate groups ({T.shape[0]} after source {k})",
                   alternative="a narrower gate (larger `p_false_reject`)")
    if dummy:
        T = T[np.any(T >= 0, axis=1)]
    return T


def _tuple_ml_costs(xs, cs, T, log_s2, median_logdet=False):
    """ML cost of every candidate group (rows of T, -1 = absent), as in group_costs.

    ``median_logdet=True``: the log-determinant part, ln|W| + sum_i ln|C_i|, is replaced by its
    median over the candidate groups of the same size (the cost without the term, kept on
    the same scale so that groups still compete fairly with lone reports).
    """
    K, m = T.shape
    d = xs[0].shape[1]
    check_size(8 * K * (3 * d * d + 3 * d + 4), MEMORY_LIMIT,
               what=f"bytes of group costs ({K} gated candidate groups)",
               alternative="a narrower gate (larger `p_false_reject`)")
    infos, lds = zip(*(_information(c) for c in cs), strict=True)
    W = np.zeros((K, d, d))
    b = np.zeros((K, d))
    ld = np.zeros(K)
    cnt = np.zeros(K, dtype=np.int64)
    for i in range(m):
        p = T[:, i] >= 0
        j = T[p, i]
        W[p] += infos[i][j]
        b[p] += np.einsum("kab,kb->ka", infos[i][j], xs[i][j])
        ld[p] += lds[i][j]
        cnt[p] += 1
    xhat = np.linalg.solve(W, b[..., None])[..., 0]
    q = np.zeros(K)
    for i in range(m):
        p = T[:, i] >= 0
        j = T[p, i]
        r = xs[i][j] - xhat[p]
        q[p] += np.einsum("ka,kab,kb->k", r, infos[i][j], r)
    chol = np.linalg.cholesky(W)
    ld_w = 2.0 * np.sum(np.log(np.diagonal(chol, axis1=-2, axis2=-1)), axis=-1)
    ld_all = ld_w + ld
    if median_logdet:
        for k in np.unique(cnt[cnt >= 2]):
            ld_all[cnt == k] = np.median(ld_all[cnt == k])
    out = q + ld_all + (cnt - 1) * d * log_s2
    out[cnt == 1] = 0.0
    return out, cnt


def _scene_candidates(xs, cs, *, cost, gamma, det, median_logdet=False):
    """Candidate groups of one scene (tuples, costs), gated and with the dummy index.

    `xs`, `cs`: per-source reports (n_i, d) and covariances (n_i, d, d);
    `gamma`: gate threshold on the pair statistic (None: no gate); `det`: the
    detection model (None: every source reports every target once).
    """
    m, d = len(xs), xs[0].shape[1]
    counts = [xi.shape[0] for xi in xs]
    dummy = det is not None
    (xcat, ccat), log_s2 = _rescale(np.concatenate(xs)[None], np.concatenate(cs)[None])
    split = np.cumsum(counts)[:-1]
    xs_s, cs_s = np.split(xcat[0], split), np.split(ccat[0], split)
    kappa = {}
    if gamma is not None or cost == "pairwise":
        for i, k in itertools.combinations(range(m), 2):
            kappa[i, k] = _pair_statistics(xs_s[i], cs_s[i], xs_s[k], cs_s[k])
    if gamma is None:
        total = math.prod(n + 1 if dummy else n for n in counts) - int(dummy)
        check_size(total, MAX_CANDIDATE_GROUPS,
                   what=f"candidate groups of one scene (report counts {counts})",
                   alternative="a gate on the candidate groups (`p_false_reject`)")
        gates = {(i, k): np.ones((counts[i], counts[k]), dtype=bool)
                 for i, k in itertools.combinations(range(m), 2)}
    else:
        with np.errstate(invalid="ignore"):
            gates = {key: v <= gamma for key, v in kappa.items()}
    T = _gated_tuples(gates, counts, dummy)
    if cost == "pairwise":
        c = np.zeros(T.shape[0])
        for (i, k), v in kappa.items():
            c += v[T[:, i], T[:, k]]
        cnt = np.full(T.shape[0], m)
    else:
        c, cnt = _tuple_ml_costs(xs_s, cs_s, T, log_s2, median_logdet)
    if dummy:
        c, keep = _detection_costs(c, cnt, T, det, d)
        T, c = T[keep], c[keep]
    if not np.all(np.isfinite(c)):
        _finite_costs(c)
    return T, c


def _detection_costs(c_ml, cnt, T, det, d):
    """-2 ln of the likelihood of each candidate group under the detection model.

    A group of the sources S (|S| >= 2) from one target: rho_T prod_S P_D prod_not-S (1 - P_D)
    times the marginal likelihood of its reports; a lone report of source i:
    u_i = rho_F,i + rho_T P_D,i prod_{k != i} (1 - P_D,k). Groups dearer than their
    members left alone can never be chosen (the lone reports are a cheaper cover) and
    are dropped, as are impossible ones (cost +inf).
    """
    pd, rf, rt = det["p_detect"], det["false_density"], det["object_density"]
    m = T.shape[1]
    with np.errstate(divide="ignore"):
        lpd, l1m, lrf, lrt = np.log(pd), np.log1p(-pd), np.log(rf), np.log(rt)
    miss_others = np.array([np.sum(np.delete(l1m, i)) for i in range(m)])
    with np.errstate(invalid="ignore"):
        lu = np.logaddexp(lrf, lrt + lpd + miss_others)             # ln u_i
    present = T >= 0
    lone = -2.0 * lu                                                  # cost of a lone report
    with np.errstate(invalid="ignore"):
        group = (c_ml + (cnt - 1) * d * math.log(2 * math.pi) - 2.0 * lrt
                 - 2.0 * np.where(present, lpd, 0.0).sum(axis=1)
                 - 2.0 * np.where(present, 0.0, l1m).sum(axis=1))
    src = np.argmax(present, axis=1)
    cost = np.where(cnt == 1, lone[src], group)
    keep = np.isfinite(cost) & (cost < np.inf)
    if np.all(np.isfinite(lone)):
        alone = np.where(present, lone, 0.0).sum(axis=1)
        keep &= (cnt == 1) | (cost < alone)
    return cost, keep


def _groups_from_tuples(T):
    """Rows sorted by source 0, then 1, ... (a missing report, -1, sorts last)."""
    key = np.where(T >= 0, T, np.iinfo(np.int64).max)
    return T[np.lexsort(key.T[::-1])]


def group_sd(x, cov, *, cost: str = "ml", relaxation: bool = True,
             time_limit: float | None = None, method: str = "milp", gap: float = 0.01,
             max_iter: int = 100, p_false_reject: float | None = None, p_detect=None,
             false_density=None, object_density=None,
             median_logdet: bool = False) -> GroupingResult:
    r"""Best grouping as an S-D assignment: exactly (HiGHS) or to a proved gap (Lagrangian).

    Parameters
    ----------
    x : array_like, shape (..., m, n, d)
        Reports (see :func:`group_costs`); leading axes are solved one scene at a time.
        With `p_detect`, one scene: shape ``(m, n, d)`` or a list of ``m`` arrays
        of shape ``(n_i, d)`` (unequal report counts).
    cov : array_like, shape (..., m, n, d, d)
        Their covariances (broadcastable; with `p_detect` and a list `x`, a
        list of ``(n_i, d, d)`` or ``(d, d)`` arrays).
    cost : {"ml", "pairwise"}, optional
        Group cost (see :func:`group_costs`); ``"ml"`` with `p_detect`.
    relaxation : bool, optional
        ``method="milp"`` on the full tensor: solve the LP relaxation first
        (default) and accept its solution when it is integral — it is then
        optimal for the integer program too; otherwise (or with
        ``relaxation=False``) run HiGHS branch and bound
        (:func:`scipy.optimize.milp`) with a zero optimality gap.
    time_limit : float, optional
        Seconds allowed to branch and bound per scene (or per stalled cluster
        of the Lagrangian); if HiGHS cannot prove optimality in time a
        :class:`RuntimeError` is raised (never a silently suboptimal answer).
    method : {"milp", "lagrangian"}, optional
        ``"milp"`` (default): the exact integer program. ``"lagrangian"``: the
        Lagrangian relaxation of Deb et al. (1997), stopped once the proved
        gap is at most `gap`.
    gap : float, optional
        Relative duality gap, in (0, 1), at which ``"lagrangian"`` stops
        (default 0.01). Clusters whose relaxation stalls above it are closed
        by branch and bound on their own candidate groups, so the returned
        ``gap`` never exceeds it.
    max_iter : int, optional
        Subgradient iterations per cluster before the gap target is tightened
        (then twice as many before branch and bound takes over).
    p_false_reject : float, optional
        Gate: the probability :math:`P_{\text{lo}}` that one true pair of
        reports fails its gate. A candidate group is kept only if each of its
        report pairs has :math:`\kappa \le \gamma`, :math:`\gamma` the
        :math:`\chi^2_d` quantile at :math:`1 - P_{\text{lo}}`; costs are then
        computed for the kept groups only. ``None`` (default): no gate.
    p_detect : float or array_like of shape (m,), optional
        Detection probability :math:`P_{D,i} \in (0, 1]` of each source.
        Given with `false_density` and `object_density`, every source may miss
        targets and report false alarms (the dummy index), and report counts
        may differ.
    false_density : float or array_like of shape (m,), optional
        False-report density :math:`\rho_{F,i} \ge 0` of each source (per unit
        volume of the report space).
    object_density : float, optional
        Target density :math:`\rho_T > 0` (per unit volume).
    median_logdet : bool, optional
        ``False`` (default) keeps the log-determinant term :math:`\ln|2\pi S|` of
        the ML group cost: the full :math:`-2\ln` likelihood. ``True`` replaces each candidate
        group's :math:`\ln|W| + \sum_i \ln|\Sigma_i|` (:math:`W = \sum_i \Sigma_i^{-1}`)
        by its median over the candidate groups of the same size: the cost of a rule that
        ignores the term, on the same scale so that groups still compete fairly with lone
        reports. Only for ``cost="ml"`` on candidate groups (with `p_false_reject` or
        `p_detect`).

    Returns
    -------
    GroupingResult
        ``groups`` of shape ``(..., n, m)`` (with `p_detect`: ``(G, m)``, -1
        for a missing report), total ``cost``, ``method``, ``lower_bound`` and
        the proved ``gap``; ``relaxation_integral`` for the full-tensor MILP;
        ``history`` for the Lagrangian on one scene.

    Raises
    ------
    ValueError
        For bad input (see :func:`group_costs`; `gap` outside (0, 1); a partial
        detection model), more than :data:`MAX_CANDIDATE_GROUPS` candidate
        groups for ``"milp"`` without a gate, a full cost tensor whose bytes
        (with the Lagrangian's work arrays) exceed ``MEMORY_LIMIT`` for
        ``"lagrangian"`` without a gate (the message names the bytes, the limit
        and the gate), or a gated problem without any grouping (the message
        names the source whose reports cannot be grouped).
    TypeError
        If `relaxation` is not a boolean.
    RuntimeError
        If the solver does not return a proven optimum.

    Notes
    -----
    One binary variable :math:`z_t` per candidate group (tuple)
    :math:`t = (j_1, \dots, j_m)`, :math:`n^m` in all:

    .. math::

        \min_z \sum_t c_t z_t \quad\text{s.t.}\quad
        \sum_{t:\,t_i = j} z_t = 1 \;\; (i = 1..m,\; j = 1..n),
        \qquad z_t \in \{0, 1\}.

    Costs of any size are accepted: when they exceed 1e9 they are capped above
    twice the greedy grouping's total (which cannot change the optimum) and
    rescaled by a positive factor before HiGHS sees them.

    For :math:`m = 2` this is the linear assignment problem (its LP relaxation
    is integral); for :math:`m \ge 3` it is the NP-hard S-D assignment problem
    (Deb et al., 1997). The relaxation's optimum is a lower bound on the integer optimum, so
    an integral relaxed solution is an exact answer; in well-separated scenes
    this is the common case and is much faster than branch and bound.

    *Gate.* The pair statistics :math:`\kappa` of all report pairs are
    computed first (:math:`O(m^2 n^2)`), then tuples are grown source by
    source, keeping only those whose pairs all pass: memory follows the number
    of gated candidates, not :math:`n^m`. A true group of :math:`m` reports
    passes with probability at least :math:`1 - \binom{m}{2} P_{\text{lo}}`.

    *Dummy index.* Targets form a Poisson field of density :math:`\rho_T`;
    source :math:`i` detects each with probability :math:`P_{D,i}` and adds
    false reports of density :math:`\rho_{F,i}`. A group of the sources
    :math:`S` (:math:`|S| \ge 2`) and a lone report of source :math:`i` cost

    .. math::

        c_S = c_{\mathrm{ML}} + (|S|-1)\,d\ln 2\pi - 2\ln\Big(\rho_T
              \prod_{i\in S} P_{D,i} \prod_{i\notin S}(1-P_{D,i})\Big),
        \qquad c_i = -2\ln u_i,\;\;
        u_i = \rho_{F,i} + \rho_T P_{D,i}\prod_{k\ne i}(1-P_{D,k}),

    so the total is :math:`-2\ln` of the grouping's likelihood up to one
    constant; for :math:`m = 2`, :math:`c_{12} - c_1 - c_2 = \kappa - 2c_0`
    with :math:`c_0` of :func:`radarfusion_ref.association.non_assignment_cost`.

    *Lagrangian relaxation.* The candidate groups are split into independent
    clusters (connected reports). In each, the constraints of sources
    :math:`3..m` get multipliers :math:`y`; for each pair :math:`(j_1, j_2)`
    the cheapest completion of reduced cost :math:`c_t - \sum_{i\ge 3}
    y_i(t_i)` leaves a 2-D assignment over the gated pairs, solved exactly
    (:func:`scipy.sparse.csgraph.min_weight_full_bipartite_matching`, with
    the dummy rows and columns kept sparse). Its value plus
    :math:`\sum y` is a valid lower bound :math:`q(y)` (reduced by a
    floating-point rounding allowance). A feasible grouping is recovered each
    iteration by fixing the relaxed pairs and assigning sources
    :math:`3, \dots, m` one at a time, and :math:`y` moves along the
    subgradient with a Polyak step toward the best cost found. A relaxed
    solution that is itself feasible is optimal (gap 0).

    *Full tensor (no gate), ``"lagrangian"``.* Sources :math:`1..m-2` are
    relaxed and the cheapest completion of every pair of the last two
    sources is a minimum over the tensor's other axes, taken exactly (over a
    short list of each pair's smallest costs whenever the list provably holds
    the minimum); the 2-D assignment is
    :func:`scipy.optimize.linear_sum_assignment`, the multipliers move along
    a deflected subgradient toward a variable target level, and each
    recovered grouping is improved by exact reassignment of one source at a
    time. A run that stalls above `gap` is closed by branch and bound up to
    :data:`MAX_CANDIDATE_GROUPS` groups, and beyond that returned with its
    proved gap and a :class:`~radarfusion_ref.engine.errors.RadarFusionWarning`.

    References
    ----------
    Sonar paper (2013), eqs. (24)–(26); Deb et al. (1997).

    Examples
    --------
    >>> x = np.array([[[0.0], [5.0]], [[5.3], [0.1]], [[0.2], [4.9]]])
    >>> r = group_sd(x, np.ones((3, 2, 1, 1)))
    >>> r.groups.tolist(), r.method
    ([[0, 1, 0], [1, 0, 1]], 'milp')
    >>> r = group_sd(x, np.ones((3, 2, 1, 1)), method="lagrangian", p_false_reject=1e-3)
    >>> r.groups.tolist(), r.gap
    ([[0, 1, 0], [1, 0, 1]], 0.0)
    """
    cost = as_choice(cost, "cost", _COSTS)
    relaxation = as_bool(relaxation, "relaxation")
    if time_limit is not None:
        time_limit = as_float(as_positive(time_limit, "time_limit"), "time_limit")
    method = as_choice(method, "method", ("milp", "lagrangian"))
    gap = as_float(as_probability(gap, "gap"), "gap")
    max_iter = as_int(max_iter, "max_iter", minimum=1)
    p_lo = None
    if p_false_reject is not None:
        p_lo = as_float(as_probability(p_false_reject, "p_false_reject"), "p_false_reject")
    why = (f"pair gate P_lo = {p_lo:g}" if p_lo is not None else "no gate")
    median_logdet = as_bool(median_logdet, "median_logdet")
    with_det = p_detect is not None or false_density is not None or object_density is not None
    if median_logdet and (cost != "ml" or (p_lo is None and not with_det)):
        raise ValueError("`median_logdet`=True applies to the ML cost (`cost`='ml') of candidate "
                         "groups: give `p_false_reject` (a gate) or `p_detect` (the dummy "
                         f"index); received cost={cost!r}, p_false_reject={p_false_reject!r}, "
                         f"p_detect={describe(p_detect) if p_detect is not None else None}")
    if with_det:
        xs, cs = _ragged_iv(x, cov)
        det = _detection_iv(len(xs), p_detect, false_density, object_density)
        if cost != "ml":
            raise ValueError("`cost` must be 'ml' with missed detections and false reports "
                             f"(`p_detect`): the likelihood defines their costs; received {cost!r}")
        d = xs[0].shape[1]
        gamma = None if p_lo is None else float(gate_threshold(p_lo, d))
        counts = [xi.shape[0] for xi in xs]
        T, c = _scene_candidates(xs, cs, cost=cost, gamma=gamma, det=det,
                                  median_logdet=median_logdet)
        chosen, total, lb, hist = sd_candidates_kernel(
            T, c, counts, dummy=True, method=method, gap=gap, max_iter=max_iter,
            time_limit=time_limit, why=why)
        gp = relative_gap(total, lb)
        return GroupingResult(_groups_from_tuples(T[chosen]), total, cost, method, None,
                              lb, gp, hist, gp == 0.0)
    xb, cb, batch = _reports_iv(x, cov)
    B, m, n, d = xb.shape
    if p_lo is None:
        _full_tensor_size(m, n, d, method)
    groups = np.empty((B, n, m), dtype=np.int64)
    totals, lbs = np.empty(B), np.empty(B)
    integral = np.zeros(B, dtype=bool)
    hist = None
    for b in range(B):
        x_b, cov_b = xb[b:b + 1], cb[min(b, cb.shape[0] - 1)][None]
        if method == "milp" and p_lo is None:
            # the full tensor: exact, HiGHS
            c = _tensor(x_b, cov_b, cost).ravel()
            chosen, integral[b] = _scene_milp(c, m, n, relaxation,
                                              time_limit, b)
            groups[b] = _normalise(
                np.array(np.unravel_index(chosen, (n,) * m)).T)
            totals[b] = lbs[b] = c[chosen].sum()
        elif p_lo is None:
            # the full tensor: dense Lagrangian
            c = _tensor(x_b, cov_b, cost)[0]
            T, totals[b], lbs[b], hist = sd_dense_lagrangian_kernel(
                c, gap=gap, max_iter=max_iter, time_limit=time_limit,
                name="x", exact_limit=MAX_CANDIDATE_GROUPS,
                hint="a gate (`p_false_reject`)")
            groups[b] = _normalise(T)
        else:
            # gated candidate groups, by cluster
            T, c = _scene_candidates(list(x_b[0]), list(cov_b[0]), cost=cost,
                                     gamma=float(gate_threshold(p_lo, d)),
                                     det=None, median_logdet=median_logdet)
            chosen, totals[b], lbs[b], hist = _scene_candidates_solve(
                T, c, [n] * m, method, gap, max_iter, time_limit, why, b, batch)
            groups[b] = _normalise(T[chosen])
        _finite_total(totals[b], b)
    # proved gap
    gaps = np.maximum(0.0, (totals - lbs) / np.maximum(np.abs(totals), 1.0))
    integral = integral if method == "milp" and p_lo is None else None
    if not batch:
        return GroupingResult(groups[0], float(totals[0]), cost, method,
                              None if integral is None else bool(integral[0]),
                              float(lbs[0]), float(gaps[0]), hist,
                              bool(gaps[0] == 0.0))
    return GroupingResult(groups.reshape(*batch, n, m), totals.reshape(batch),
                          cost, method,
                          None if integral is None else integral.reshape(batch),
                          lbs.reshape(batch), gaps.reshape(batch), None,
                          bool(np.all(gaps == 0)))


def _full_tensor_size(m, n, d, method):
    """Refuse an ungated scene too large for `method` before its cost tensor is built.

    ``"milp"``: at most :data:`MAX_CANDIDATE_GROUPS` groups (binary variables of
    HiGHS). ``"lagrangian"``: the cost tensor's working memory and the dense
    Lagrangian's work arrays within ``MEMORY_LIMIT`` bytes.
    """
    if method == "milp":
        check_size(n**m, MAX_CANDIDATE_GROUPS,
                   what=f"candidate groups n**m = {n}**{m} of one scene (`x` with m = {m}, n = {n}) "
                        "as binary variables of the integer program",
                   alternative="method='lagrangian' (the full tensor, sized by memory), a gate "
                               "on the candidate groups (`p_false_reject`), or splitting the "
                               "scene into clusters")
        return
    need = _cost_bytes(1, m, n, d) + dense_work_bytes(m, n)
    check_size(need, MEMORY_LIMIT,
               what=f"bytes of the full cost tensor of one scene (`x` with m = {m}, n = {n}: "
                    f"n**m = {n}**{m} groups) and the Lagrangian's work arrays",
               alternative="a gate on the candidate groups (`p_false_reject`: memory follows "
                           "the gated groups, not n**m), or splitting the scene into clusters")


def _scene_milp(c, m, n, relaxation, time_limit, b):
    """Exact S-D of one scene's full cost tensor (flat); the scene named in errors."""
    try:
        return sd_milp_kernel(c, m, n, relaxation=relaxation, time_limit=time_limit)
    except RuntimeError as exc:
        raise RuntimeError(f"scene {b}: {exc}") from None


def _scene_candidates_solve(T, c, counts, method, gap, max_iter, time_limit, why, b, batch):
    """:func:`radarfusion_ref.engine.assignment.sd_candidates_kernel` for one scene."""
    try:
        return sd_candidates_kernel(T, c, counts, dummy=False, method=method, gap=gap,
                                    max_iter=max_iter, time_limit=time_limit, why=why)
    except ValueError as exc:
        raise ValueError(f"scene {b}: {exc}" if batch else str(exc)) from None


def _finite_total(total, b):
    if not np.isfinite(total):
        raise ValueError(
            f"`x` and `cov`: scene {b}: the total cost of the best grouping overflows "
            "the floating-point range; split the scene or gate the candidate groups first")


