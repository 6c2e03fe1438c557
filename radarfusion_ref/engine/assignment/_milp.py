"""The S-D assignment as an integer program (HiGHS): the full tensor and explicit candidates."""

from __future__ import annotations

import functools

import numpy as np
from scipy import sparse
from scipy.optimize import Bounds, LinearConstraint, linprog, milp

from ..validation import as_int, check_size
from ._sparse import int32_indices

__all__ = ["MAX_SD_TUPLES", "sd_constraint_matrix"]

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
            index: list[slice | int] = [slice(None)] * m
            index[i] = int(j)
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


#: Largest full cost tensor (:math:`n^m` candidate groups, the binary variables
#: of HiGHS) :func:`assign_s_lists` accepts with ``method="milp"``; beyond it, use
#: ``method="lagrangian"`` (full tensors sized by bytes against ``MEMORY_LIMIT``)
#: or pass the gated candidate groups.
MAX_SD_TUPLES = 10**6


def sd_constraint_matrix(m, n):
    r"""Constraints of the S-D assignment.

    Every report lies in exactly one chosen group. Row :math:`i n + j` is
    report :math:`j` of source :math:`i` (``m >= 2`` sources, ``n >= 1``
    reports each), column :math:`t` the candidate group
    :math:`t = (t_1, \dots, t_m)`, the :math:`n^m` groups in C order; the
    entry is 1 when :math:`t_i = j`, so :math:`A z = 1` reads
    :math:`\sum_{t:\,t_i = j} z_t = 1`. More than :data:`MAX_SD_TUPLES`
    groups raise a ``ValueError``.

    >>> sd_constraint_matrix(2, 2).toarray().astype(int).tolist()
    [[1, 1, 0, 0], [0, 0, 1, 1], [1, 0, 1, 0], [0, 1, 0, 1]]
    """
    m, n = as_int(m, "m", minimum=2), as_int(n, "n", minimum=1)
    # n**64 > the limit for n >= 2
    check_size(n ** min(m, 64), MAX_SD_TUPLES, name="n",
               what=f"candidate groups n**m (n = {n}, m = {m})",
               alternative="gated candidate groups "
                       "(assign_s_lists with `candidates`)")
    # t_i of every candidate group t
    t = np.indices((n,) * m).reshape(m, -1)
    # report j = t_i of source i lies in group t
    rows = (np.arange(m)[:, None] * n + t).ravel()
    cols = np.tile(np.arange(n**m), m)
    return sparse.csc_array((np.ones(m * n**m), (rows, cols)),
                            shape=(m * n, n**m))


@functools.lru_cache(maxsize=16)
def _sd_constraints(m, n):
    """:func:`sd_constraint_matrix`, cached for repeated solves of one size."""
    return sd_constraint_matrix(m, n)


def _sd_solve_once(c, m, n, *, relaxation=True, time_limit=None):
    """One HiGHS solve of the S-D assignment with conditioned costs `c`."""
    A = _sd_constraints(m, n)
    z, integral = None, False
    if relaxation:
        lp = linprog(c, A_eq=A, b_eq=np.ones(m * n), bounds=(0, 1), method="highs")
        if lp.status == 0 and np.all(np.minimum(lp.x, 1 - lp.x) < 1e-6):
            z, integral = lp.x, True
    if z is None:
        options = {"mip_rel_gap": 0.0, "presolve": False}
        if time_limit is not None:
            options["time_limit"] = time_limit
        res = milp(c, constraints=LinearConstraint(int32_indices(A, "csc"), 1, 1), integrality=np.ones(n**m),
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


def sd_milp_kernel(c_raw, m, n, *, relaxation=True, time_limit=None):
    """Kernel (trusted input): the S-D assignment of a flat cost vector over n**m tuples.

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


def _report_nodes(T, counts):
    offsets = np.concatenate([[0], np.cumsum(counts)])
    return np.where(T >= 0, T + offsets[:-1], -1), offsets


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
    res = milp(cc * scale, constraints=LinearConstraint(int32_indices(A, "csc"), 1, 1), integrality=np.ones(K),
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

