"""The S-D assignment: the public solvers (integer program, Lagrangian, enumeration)."""

from __future__ import annotations

import itertools
import math

import numpy as np

from ..validation import (
    MEMORY_LIMIT,
    as_bool,
    as_choice,
    as_float,
    as_float_array,
    as_int,
    as_positive,
    check_size,
    describe,
)
from ._checks import _as_gap, cost_exponents
from ._dense import dense_bytes, sd_dense_lagrangian_kernel
from ._lagrangian import sd_candidates_kernel
from ._milp import MAX_SD_TUPLES, sd_milp_kernel
from ._results import SDAssignment, relative_gap

__all__ = ["MAX_SD_GROUPINGS", "assign_s_lists", "assign_s_lists_bruteforce"]


# --------------------------------------------------------------------------- S-D: public API

#: Largest number of groupings :math:`(n!)^{m-1}` :func:`assign_s_lists_bruteforce`
#: enumerates (about a minute of work).
MAX_SD_GROUPINGS = 10**8

#: What a caller of :func:`assign_s_lists` can change when no grouping exists.
_SD_HINT = ("add candidate groups (a wider gate), or groups with -1 for a source without a "
            "report (missed detections and false reports)")


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


def _candidate_words(m: int) -> int:
    """Words (8 bytes) the candidate-group route allocates per candidate group of m sources."""
    return 3 * m + 12


def _full_size(m: int, n: int, method: str) -> None:
    """Refuse a full tensor too large for `method` before any work array is allocated.

    ``"milp"``: at most :data:`MAX_SD_TUPLES` groups (binary variables of HiGHS).
    ``"lagrangian"``: the tensor and the dense Lagrangian's work arrays within
    :data:`~radarfusion_ref.engine.validation.MEMORY_LIMIT` bytes.
    """
    if method == "milp":
        check_size(n ** min(m, 64), MAX_SD_TUPLES, name="cost",
                   what=f"binary variables (groups n**m = {n}**{m} of the full tensor) for the "
                    "integer program",
                   alternative=f"method='lagrangian' (full tensors up to {MEMORY_LIMIT} bytes with "
                           "its work arrays), or gated candidate groups (`candidates`)")
    else:
        check_size(dense_bytes(m, n) if m <= 64 else 8 * n ** 64, MEMORY_LIMIT, name="cost",
                   what=f"bytes of the full tensor (n**m = {n}**{m} groups, 8 bytes each) and the "
                    "Lagrangian's work arrays",
                   alternative="gated candidate groups (`candidates`: memory follows their count, "
                           "not n**m)")


#: Bytes of the S-D solvers' work arrays per report of `counts` (labels, offsets, masks).
_COUNT_BYTES = 64


def _as_candidates(candidates, cost, counts):
    """Candidate groups (K, m) of ints >= -1, their finite costs (K,) and the report counts."""
    if candidates is None or isinstance(candidates, (str, bytes, bool, np.bool_)):
        raise TypeError(f"`candidates` must be an integer array of shape (K, m); received "
                        f"{describe(candidates)}")
    T = np.asarray(candidates)
    if T.dtype.kind == "f" and T.size and np.all(np.isfinite(T)) and np.all(np.round(T) == T):
        T = T.astype(np.int64)
    if T.dtype.kind not in "iu":
        raise TypeError(f"`candidates` must be an integer array of shape (K, m) (report indices, "
                        f"-1 for none); received {describe(candidates)}")
    if T.ndim != 2 or T.shape[0] == 0 or T.shape[1] < 2:
        raise ValueError(f"`candidates` must have shape (K, m) with K >= 1 groups of m >= 2 "
                         f"sources; received shape {T.shape}")
    T = T.astype(np.int64)
    if np.any(T < -1):
        raise ValueError(f"`candidates` entries must be report indices >= 0 or -1 (no report); "
                         f"received {describe(candidates)} (smallest entry {int(T.min())})")
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
                         f"out of `candidates`); received {describe(c)} with "
                         f"{int(np.count_nonzero(~np.isfinite(c)))} non-finite entries")
    m = T.shape[1]
    top = T.max(axis=0) + 1
    if counts is None:
        cnt = [int(v) for v in top]
    else:
        arr = np.asarray(counts)
        if arr.shape != (m,) or arr.dtype.kind not in "iu":
            raise ValueError(f"`counts` must be {m} integers (reports per source); received "
                             f"{describe(counts)}")
        cnt = [int(v) for v in arr]
        if any(ci < ti for ci, ti in zip(cnt, top, strict=True)):
            raise ValueError(f"`counts` must be at least the largest report index + 1 of each "
                             f"source ({top.tolist()}); received {cnt}")
    if min(cnt) < 1:
        raise ValueError(f"`candidates`: every source must have at least one report; report "
                         f"counts {cnt}")
    # one constraint row, label and offset per report: sized by the counts, not by K
    check_size(_COUNT_BYTES * sum(cnt), MEMORY_LIMIT, name="counts",
               what=f"bytes of per-report work arrays ({sum(cnt)} reports over {m} sources)",
               alternative="counts equal to the reports the candidate groups name (the default)")
    return T, c, cnt


def assign_s_lists(cost, candidates=None, *, counts=None, method: str = "milp", gap: float = 0.01,
             max_iter: int = 100, time_limit: float | None = None,
             relaxation: bool = True) -> SDAssignment:
    r"""Minimum-cost S-D assignment: exact (HiGHS) or to a proved duality gap (Lagrangian).

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
        the LP relaxation when it is integral), at most :data:`MAX_SD_TUPLES`
        groups. ``"lagrangian"``: Lagrangian relaxation, stopped at a proved
        gap; on a full tensor the dense route (sized by bytes: the tensor and
        its work arrays within ``MEMORY_LIMIT``, e.g. ``m = 3`` up to
        ``n = 480``), on candidate groups cluster by cluster.
    gap : float, optional
        Relative gap in (0, 1) at which ``"lagrangian"`` stops (default
        0.01); clusters that stall above it are closed by branch and bound,
        so the returned gap never exceeds it -- except for a full tensor of
        more than :data:`MAX_SD_TUPLES` groups, which is returned with the
        gap it proved and a :class:`~radarfusion_ref.engine.errors.RadarFusionWarning`.
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
        is not ``(n,) * m``, one of more than :data:`MAX_SD_TUPLES` groups
        for ``"milp"`` or whose bytes with the work arrays exceed
        ``MEMORY_LIMIT`` for ``"lagrangian"`` (refused before any work array
        is allocated, naming the bytes, the limit and `candidates`), candidate
        rows outside ``[-1, counts)`` or all ``-1``, `counts` whose per-report
        work arrays exceed ``MEMORY_LIMIT`` (refused before they are
        allocated), a `gap` outside (0, 1),
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
    :math:`\min \sum_t c_t z_t` subject to every report of every source
    lying in exactly one chosen group. For :math:`m = 2` it is the linear
    assignment problem; for :math:`m \ge 3` it is NP-hard (Deb et al. 1997).
    The Lagrangian relaxation splits the candidates into independent
    clusters, relaxes sources :math:`3..m` with multipliers :math:`y`,
    solves the remaining 2-D assignment exactly (a valid lower bound
    :math:`q(y)`), recovers a feasible grouping each iteration and moves
    :math:`y` along the subgradient. On a full tensor (at least half of it
    finite) it relaxes sources :math:`1..m-2` instead and keeps the last
    two: the cheapest completion of each of their :math:`n^2` pairs is an
    exact minimum over the other axes (over a short list of each pair's
    smallest costs wherever the list provably holds it, over the whole
    tensor otherwise), the 2-D assignment is
    :func:`scipy.optimize.linear_sum_assignment`, every recovered grouping
    is improved by exact reassignment of one source at a time, and
    :math:`y` moves along a deflected subgradient (Camerini, Fratta and
    Maffioli 1975) toward a variable target level (Goffin and Kiwiel 1999);
    see
    :func:`radarfusion_ref.grouping.group_sd`, which builds the costs from
    reports and calls this solver.

    Examples
    --------
    >>> c = np.full((2, 2, 2), 5.0)
    >>> c[0, 1, 0] = c[1, 0, 1] = 1.0
    >>> r = assign_s_lists(c)
    >>> r.groups.tolist(), r.cost, r.exact
    ([[0, 1, 0], [1, 0, 1]], 2.0, True)
    >>> r = assign_s_lists([1.0, 1.0, 3.0], [[0, 1, 0], [1, 0, 1], [0, 0, -1]], method="lagrangian")
    >>> r.groups.tolist(), r.gap
    ([[0, 1, 0], [1, 0, 1]], 0.0)
    """
    method = as_choice(method, "method", ("milp", "lagrangian"))
    g = _as_gap(gap)
    max_iter = as_int(max_iter, "max_iter", minimum=1)
    relaxation = as_bool(relaxation, "relaxation")
    if time_limit is not None:
        time_limit = as_float(as_positive(time_limit, "time_limit"), "time_limit")
    integral = None
    if candidates is None:
        if counts is not None:
            raise ValueError("`counts` is for explicit `candidates`; a full tensor has n reports "
                             f"per source; received {describe(counts)}")
        if isinstance(cost, np.ndarray) and cost.ndim >= 2:      # refuse before converting
            _full_size(cost.ndim, cost.shape[0], method)
        c = _as_sd_tensor(cost)
        m, n = c.ndim, c.shape[0]
        _full_size(m, n, method)
        finite = int(np.count_nonzero(np.isfinite(c)))
        if finite == 0:
            raise ValueError("`cost` has no finite group: no grouping exists")
        if method == "milp" and finite == c.size:
            chosen, integral = sd_milp_kernel(c.ravel(), m, n, relaxation=relaxation,
                                              time_limit=time_limit)
            T = np.array(np.unravel_index(chosen, c.shape)).T
            total = float(c.ravel()[chosen].sum())
            lb, hist = total, None
        elif method == "lagrangian" and (m == 2 or 2 * finite >= c.size):
            T, total, lb, hist = sd_dense_lagrangian_kernel(
                c, gap=g, max_iter=max_iter, time_limit=time_limit, name="cost",
                exact_limit=MAX_SD_TUPLES, hint="gated candidate groups (`candidates`)")
            chosen = np.ravel_multi_index(tuple(T.T), c.shape)
        else:                                   # mostly forbidden: the finite groups only
            check_size(_candidate_words(m) * 8 * finite, MEMORY_LIMIT, name="cost",
                       what=f"bytes of the {finite} finite groups of the {n}**{m} tensor as "
                        "candidate groups",
                       alternative="gated candidate groups (`candidates`) built without the tensor")
            flat = np.flatnonzero(np.isfinite(c.ravel()))
            T = np.array(np.unravel_index(flat, c.shape)).T.astype(np.int64)
            cc = c.ravel()[flat]
            sel, total, lb, hist = sd_candidates_kernel(
                T, cc, [n] * m, dummy=False, method=method, gap=g, max_iter=max_iter,
                time_limit=time_limit, why="+inf entries of `cost`", name="cost",
                hint=_SD_HINT)
            chosen, T = flat[sel], T[sel]
    else:
        T_all, cc, cnt = _as_candidates(candidates, cost, counts)
        dummy = bool(np.any(T_all < 0))
        sel, total, lb, hist = sd_candidates_kernel(
            T_all, cc, cnt, dummy=dummy, method=method, gap=g, max_iter=max_iter,
            time_limit=time_limit, why="the given candidate groups", name="candidates",
            hint=_SD_HINT)
        chosen, T = sel, T_all[sel]
    if not math.isfinite(total):
        raise ValueError("`cost`: the total cost of the best grouping lies beyond the float "
                         "range; divide the costs by a common factor")
    T, order = _sorted_groups(np.asarray(T, dtype=np.int64))
    gp = relative_gap(total, lb)
    return SDAssignment(T, np.asarray(chosen)[order], float(total), float(min(lb, total)), gp,
                        hist, gp == 0.0, method, integral)


def sd_enumerate_kernel(tensor: np.ndarray, m: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Kernel (trusted input): the best grouping of each of B flat tensors (B, n**m).

    By enumeration.

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


def assign_s_lists_bruteforce(cost) -> SDAssignment:
    """The exact S-D optimum of a full cost tensor by enumerating every grouping.

    The reference route for :func:`assign_s_lists`: all :math:`(n!)^{m-1}` ways to
    split the reports into :math:`n` groups of one report per source are
    scored (vectorized, chunked), the cheapest is returned.

    Parameters
    ----------
    cost : array_like, shape (n,) * m
        Group costs (``+inf`` forbids a group), as in :func:`assign_s_lists`.

    Returns
    -------
    SDAssignment
        ``method="bruteforce"``, exact; ties go to the first grouping in
        enumeration order.

    Raises
    ------
    ValueError
        For a tensor that is not ``(n,) * m``, NaN or ``-inf`` costs, more
        than :data:`MAX_SD_GROUPINGS` groupings (use :func:`assign_s_lists`), no
        grouping of finite cost, or a total beyond the float range.

    Examples
    --------
    >>> c = np.full((2, 2, 2), 5.0)
    >>> c[0, 1, 0] = c[1, 0, 1] = 1.0
    >>> assign_s_lists_bruteforce(c).groups.tolist()
    [[0, 1, 0], [1, 0, 1]]
    """
    c = _as_sd_tensor(cost)
    m, n = c.ndim, c.shape[0]
    check_size(math.factorial(n) ** (m - 1), MAX_SD_GROUPINGS,
               what=f"groupings (n!)**(m-1) of `cost` (n = {n}, m = {m})",
               alternative="assign_s_lists (the exact integer program, or the Lagrangian relaxation)")
    e = int(cost_exponents(c.reshape(1, -1)))
    best, groups = sd_enumerate_kernel(np.ldexp(c.reshape(1, -1), -e), m, n)   # exact scaling
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
