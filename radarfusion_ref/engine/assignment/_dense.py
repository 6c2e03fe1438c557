"""The S-D assignment on a full cost tensor by Lagrangian relaxation (dense, vectorised).

The constraints of sources ``0 .. m-3`` are relaxed with multipliers; what remains is
a 2-D assignment between the last two sources over the matrix of cheapest
completions, solved exactly by :func:`scipy.optimize.linear_sum_assignment`: its
value is a proved lower bound. The cheapest completion of every pair is a minimum
over the tensor's leading axes; it is taken over a short list of each pair's
smallest entries whenever that list provably holds the minimum, and over the
whole tensor otherwise, so every bound is exact. A feasible grouping is recovered
each iteration (Deb et al. 1997) and improved by exact reassignment of one source
at a time.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..errors import RadarFusionWarning
from ..validation import MEMORY_LIMIT, check_size
from ._milp import _milp_tuples, sd_milp_kernel

__all__: list[str] = []

_EPS = np.finfo(float).eps

#: Smallest entries kept per (last two sources') pair for the relaxed minimum.
_TOP = 8

#: Bytes of one block of the full pass over the tensor (cache-sized).
BLOCK_BYTES = 1 << 21

#: Iterations without a better dual value before the target level drops.
_STALL = 10

#: Growth of the target distance when the target level is reached.
_GROW = 1.5

#: Shrink of the target distance after a stall of the dual value.
_SHRINK = 0.5

#: First target distance, as a share of (best cost - first bound).
_DELTA0 = 1.0

#: Deflection of the subgradient direction (Camerini-Fratta-Maffioli, gamma).
_DEFLECT = 1.5

#: Costs above this magnitude are scaled by an exact power of two first.
_SCALE_ABOVE = 2.0**400

#: Iterations without progress of either bound before the run counts as stalled.
_PATIENCE = 50


def dense_work_bytes(m: int, n: int) -> int:
    """Kernel (trusted input): bytes the dense Lagrangian allocates beside the tensor itself.

    The short lists of smallest entries (values, their leading index, the next
    value: ``(2 _TOP + 1) n^2`` words), the gathered columns of the chosen pairs
    and the reassignment matrices (``4 n^{m-1} + 6 n^2`` words), the leading
    indices (``(m - 1) n^{m-2}`` words), the mask of finite groups (``n^m``
    bytes) and a few cache-sized blocks.
    """
    lead = n ** (m - 2)
    return 8 * ((2 * _TOP + 1) * n * n + 4 * lead * n + (m - 1) * lead + 6 * n * n) \
        + n**m + 4 * BLOCK_BYTES


def dense_bytes(m: int, n: int) -> int:
    """Bytes of a full float64 tensor ``(n,) * m`` plus the dense Lagrangian's work."""
    return 8 * n**m + dense_work_bytes(m, n)


def _lsa(M):
    """Square linear assignment: columns of rows 0..n-1, or None when none is finite."""
    try:
        r, j = linear_sum_assignment(M)
    except ValueError:                          # +inf everywhere a full matching must go
        return None
    w = M[r, j]
    if not np.all(np.isfinite(w)):
        return None
    return j


class _Dense:
    """Lagrangian relaxation of the S-D assignment of one full tensor ``(n,) * m``, m >= 3."""

    def __init__(self, c: np.ndarray):
        self.c = np.ascontiguousarray(c, dtype=float)
        self.m, self.n = m, n = c.ndim, c.shape[0]
        self.flat = self.c.reshape(-1)
        self.c3 = self.c.reshape(-1, n, n)                 # (leading L, last-but-one, last)
        self.L = L = n ** (m - 2)
        self.lead = np.indices((n,) * (m - 2)).reshape(m - 2, L)   # sources 0..m-3 of each L
        self.stride = np.array([n ** (m - 1 - i) for i in range(m)], dtype=np.int64)
        self.u = np.zeros((m - 2, n))
        self.block = max(1, BLOCK_BYTES // (8 * n * n))
        self.top: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        if L > 2 * _TOP:
            self._shortlist()
        self.lb, self.ub = -math.inf, math.inf
        self.best: np.ndarray | None = None
        self.history: list[tuple[float, float]] = []
        self.stall, self.best_q, self.it = 0, -np.inf, 0
        self.delta = math.nan                      # set from the first bound and cost
        self.level, self.best_u = math.inf, self.u.copy()
        self.best_g: np.ndarray = np.zeros_like(self.u)
        self.direction = np.zeros_like(self.u)
        self.optimal, self.stalled, self.last_progress = False, False, 0
        self.full_passes = 0

    # ------------------------------------------------------------------ relaxed problem
    def _shortlist(self):
        """Per pair, the ``_TOP`` smallest entries over L, their L, and the next smallest."""
        n, K, c3 = self.n, _TOP, self.c3
        vals = np.empty((K, n, n))
        idx = np.empty((K, n, n), dtype=np.int64)
        nxt = np.empty((n, n))
        rows = max(1, BLOCK_BYTES // (8 * self.L * n))
        for a0 in range(0, n, rows):
            a1 = min(n, a0 + rows)
            chunk = np.moveaxis(c3[:, a0:a1, :], 0, -1)          # (rows, n, L) view
            part = np.argpartition(chunk, K, axis=-1)[..., :K + 1]
            v = np.take_along_axis(chunk, part, axis=-1)
            o = np.argsort(v, axis=-1, kind="stable")
            part, v = np.take_along_axis(part, o, -1), np.take_along_axis(v, o, -1)
            vals[:, a0:a1] = np.moveaxis(v[..., :K], -1, 0)
            idx[:, a0:a1] = np.moveaxis(part[..., :K], -1, 0)
            nxt[a0:a1] = v[..., K]
        self.top = (vals, idx, nxt)

    def _offsets(self):
        """``U[L]``: the summed multipliers of the relaxed sources of each leading index."""
        U = self.u[0][self.lead[0]]
        for i in range(1, self.m - 2):
            U = U + self.u[i][self.lead[i]]
        return U

    def _full_min(self, U):
        """min over L of ``c3[L] - U[L]``, block by block."""
        self.full_passes += 1
        M = np.full((self.n, self.n), np.inf)
        for L0 in range(0, self.L, self.block):
            L1 = min(self.L, L0 + self.block)
            np.minimum(M, (self.c3[L0:L1] - U[L0:L1, None, None]).min(axis=0), out=M)
        return M

    def _relaxed_matrix(self, U):
        """The cheapest completion of every pair (exactly the full minimum)."""
        if self.top is None:
            return self._full_min(U)
        vals, idx, nxt = self.top
        M = (vals - U[idx]).min(axis=0)
        # an entry outside the list costs at least nxt - max U: the list holds the minimum
        # wherever M is no larger (rounding is monotone, so this holds for the float values)
        bad = np.greater(M, nxt - U.max())
        nb = int(np.count_nonzero(bad))
        if nb == 0:
            return M
        if nb * 4 > self.n * self.n:
            return self._full_min(U)
        a, b = np.nonzero(bad)
        M[a, b] = (self.c3[:, a, b] - U[:, None]).min(axis=0)
        return M

    def relaxed(self):
        """Bound q (less a rounding allowance), the pairs and the leading index of each."""
        U = self._offsets()
        M = self._relaxed_matrix(U)
        j = _lsa(M)
        if j is None:
            return None
        a = np.arange(self.n)
        cols = self.c3[:, a, j]                                   # (L, n)
        lstar = np.argmin(cols - U[:, None], axis=0)
        w = M[a, j]
        q = float(np.sum(w)) + float(np.sum(self.u))
        # rounding allowance of the sums behind q (never claim an unproved bound)
        mag = float(np.sum(np.abs(w))) + float(np.sum(np.abs(cols[lstar, a]))) + \
            2.0 * float(np.sum(np.abs(self.u))) * self.m
        slack = 8.0 * _EPS * (self.m * self.n + 8) * mag
        return q - slack, q, j, lstar, cols

    # ------------------------------------------------------------------ feasible groupings
    def total(self, groups):
        return float(np.sum(self.flat[groups @ self.stride]))

    def recover(self, j, cols):
        """Fix the relaxed pairs; assign sources m-3, ..., 0 one at a time (exact 2-D steps)."""
        n, m = self.n, self.m
        groups = np.empty((n, m), dtype=np.int64)
        groups[:, m - 2], groups[:, m - 1] = np.arange(n), j
        cur = cols                                                 # (n**(m-2), P)
        p = np.arange(n)
        for k in range(m - 3, -1, -1):
            cur = cur.reshape(n**k, n, n)                          # (sources < k, source k, P)
            if k:
                Uk = self.u[0][_lead_prefix(n, k, 0)]
                for i in range(1, k):
                    Uk = Uk + self.u[i][_lead_prefix(n, k, i)]
                cost = (cur - Uk[:, None, None]).min(axis=0).T     # (P, n)
            else:
                cost = cur[0].T
            jk = _lsa(cost)
            if jk is None:
                return None
            groups[:, k] = jk
            cur = cur[:, jk, p]                                    # (n**k, P)
        return groups

    def improve(self, groups, sweeps=4):
        """Reassign one source at a time, the others fixed (exact 2-D steps); never worse."""
        n, m = self.n, self.m
        cur = self.total(groups)
        ar = np.arange(n)
        for _ in range(sweeps):
            before = cur
            for k in range(m):
                base = groups @ self.stride - groups[:, k] * self.stride[k]
                C = self.flat[base[:, None] + ar[None, :] * self.stride[k]]
                jk = _lsa(C)
                if jk is None:
                    continue
                groups = groups.copy()
                groups[:, k] = jk
                cur = float(np.sum(C[ar, jk]))
            if not cur < before:
                break
        return groups

    # ------------------------------------------------------------------ one iteration
    def step(self):
        self.it += 1
        out = self.relaxed()
        if out is None:
            raise _NoGrouping
        lower, q, j, lstar, cols = out
        n, m = self.n, self.m
        src = self.lead[:, lstar]                                  # (m-2, n)
        g = 1.0 - np.stack([np.bincount(s, minlength=n) for s in src])
        lb_before, ub_before = self.lb, self.ub
        if not np.any(g):                                          # relaxed optimum feasible
            groups = np.empty((n, m), dtype=np.int64)
            groups[:, :m - 2], groups[:, m - 2], groups[:, m - 1] = src.T, np.arange(n), j
            self.ub, self.best = self.total(groups), groups
            self.lb, self.optimal = self.ub, True
            self.history.append((self.lb, self.ub))
            return
        self.lb = max(self.lb, lower)
        groups = self.recover(j, cols)
        if groups is not None:
            groups = self.improve(groups)
            tot = self.total(groups)
            if tot < self.ub:
                self.ub, self.best = tot, groups
        self.lb = min(self.lb, self.ub)
        tiny = 1e-6 * max(1.0, abs(self.ub)) if math.isfinite(self.ub) else math.inf
        if self.lb > lb_before + tiny or self.ub < ub_before - tiny or not math.isfinite(self.ub):
            self.last_progress = self.it
        self.stalled = self.it - self.last_progress >= _PATIENCE
        self.history.append((self.lb, self.ub))
        # variable target level (Goffin-Kiwiel): aim at the best q + delta, delta adapted
        if math.isnan(self.delta):
            self.delta = (_DELTA0 * (self.ub - q) if math.isfinite(self.ub)
                          else 0.05 * max(1.0, abs(q)))
        base = q
        if q > self.best_q + 1e-12 * max(1.0, abs(q)):
            if q >= self.level:
                self.delta *= _GROW
            self.best_q, self.best_u, self.best_g, self.stall = q, self.u.copy(), g, 0
        else:
            self.stall += 1
            if self.stall >= _STALL:                 # back to the best multipliers, aim lower
                room = self.ub - self.best_q if math.isfinite(self.ub) else self.delta
                self.delta = _SHRINK * min(self.delta, room)   # the level moves at once
                self.stall = 0
                self.u, self.direction = self.best_u.copy(), np.zeros_like(self.u)
                g, base = self.best_g, self.best_q
        self.level = self.best_q + self.delta
        if math.isfinite(self.ub):
            self.level = min(self.level, self.ub)
        # deflected subgradient (Camerini, Fratta, Maffioli 1975)
        d = self.direction
        dd = float(np.sum(d * d))
        beta = max(0.0, -_DEFLECT * float(np.sum(g * d)) / dd) if dd > 0 else 0.0
        d = g + beta * d
        self.direction = d
        t = max(self.level - base, 1e-12 * max(1.0, abs(q))) / float(np.sum(d * d))
        self.u = self.u + t * d


def _lead_prefix(n, k, i):
    """Index of source i (< k) in the flat leading index over sources 0..k-1."""
    return (np.arange(n**k) // n ** (k - 1 - i)) % n


class _NoGrouping(Exception):
    """The tensor admits no grouping of finite cost."""


def _run(s, gap, max_iter):
    """Iterate until the proved gap is at most `gap`, a stall, or ``3 max_iter`` iterations."""

    def reached():
        return math.isfinite(s.ub) and s.ub - s.lb <= gap * max(abs(s.ub), 1.0)

    while not (s.optimal or s.stalled or reached()) and s.it < 3 * max_iter:
        s.step()
    return reached() or s.optimal


def sd_dense_lagrangian_kernel(c, *, gap, max_iter, time_limit=None, name="cost",
                               exact_limit=10**6, hint="gated candidate groups"):
    """Kernel (trusted input): the S-D assignment of a full tensor ``(n,) * m`` to a gap.

    To a proved relative gap (the Lagrangian on the full tensor).

    `c` holds finite costs or ``+inf`` (a forbidden group). ``m = 2`` is solved
    exactly (one linear assignment). For ``m >= 3`` the dense Lagrangian runs
    (:class:`_Dense`); a run that stalls above `gap` is closed by branch and
    bound (HiGHS) when the tensor has at most `exact_limit` groups, and otherwise
    returned with its proved gap and a :class:`RadarFusionWarning`.

    Returns ``(groups (n, m), total cost, lower bound, history (iterations, 2) or
    None)``; the total is summed on `c` itself.
    """
    m, n = c.ndim, c.shape[0]
    if m == 2:
        j = _lsa(c)
        if j is None:
            raise ValueError(f"`{name}` has no grouping of finite cost: every assignment of "
                             f"the {n} reports uses a forbidden (+inf) group")
        groups = np.column_stack([np.arange(n), j]).astype(np.int64)
        total = float(np.sum(c[groups[:, 0], groups[:, 1]]))
        return groups, total, total, None
    finite = np.isfinite(c)
    top = max(float(np.max(c, where=finite, initial=0.0)),
              -float(np.min(c, where=finite, initial=0.0)))
    e = int(np.frexp(top)[1]) if top > _SCALE_ABOVE else 0
    if e:                                                # exact power-of-two scaling: a copy
        check_size(2 * 8 * c.size + dense_work_bytes(m, n), MEMORY_LIMIT,
                   what=f"bytes of `{name}` scaled by 2**-{e} (costs up to {top:.3g}) beside "
                        "the tensor and the Lagrangian's work arrays",
                   alternative=f"costs divided by a common factor, or {hint}")
    work = np.ldexp(c, -e) if e else c
    s = _Dense(work)
    try:
        done = _run(s, gap, max_iter)
    except _NoGrouping:
        raise ValueError(f"`{name}` has no grouping of finite cost: even with sources "
                         f"0..{m - 3} relaxed, the reports of sources {m - 2} and {m - 1} cannot "
                         f"all be paired through finite (not +inf) groups") from None
    if not done and n**m <= exact_limit:
        flat = _exact(c, m, n, time_limit, name, upper=s.ub * 2.0**e)
        groups = np.array(np.unravel_index(flat, c.shape)).T.astype(np.int64)
        total = float(np.sum(c.ravel()[flat]))
        hist = np.vstack([np.ldexp(np.array(s.history).reshape(-1, 2), e), [[total, total]]])
        return groups, total, total, hist
    if s.best is None:
        raise RuntimeError(f"`{name}`: no grouping of finite cost was found in {s.it} "
                           f"iterations (the tensor has {int(np.count_nonzero(~finite))} +inf "
                           f"groups); raise `max_iter`, or pass {hint}")
    total = float(np.sum(c.ravel()[s.best @ s.stride]))
    with np.errstate(over="ignore"):
        lb = min(float(np.ldexp(s.lb, e)), total)
    if not done:
        reached = (total - lb) / max(abs(total), 1.0)
        warnings.warn(f"`gap`: the Lagrangian relaxation of the {n}**{m} tensor stalled at a "
                      f"proved gap of {reached:.3g}, above the {gap:g} asked, after {s.it} "
                      f"iterations; the grouping is returned with that gap (branch and bound "
                      f"is refused above {exact_limit} groups): raise `max_iter` or `gap`",
                      RadarFusionWarning, stacklevel=3)
    return s.best, total, lb, np.ldexp(np.array(s.history), e)


def _exact(c, m, n, time_limit, name, upper):
    """Flat indices of the optimal groups (HiGHS) of a full tensor with finite or +inf costs."""
    if np.all(np.isfinite(c)):
        chosen, _ = sd_milp_kernel(c.ravel(), m, n, time_limit=time_limit)
        return chosen
    flat = np.flatnonzero(np.isfinite(c.ravel()))
    T = np.array(np.unravel_index(flat, c.shape)).T.astype(np.int64)
    sel = _milp_tuples(T, c.ravel()[flat], [n] * m, time_limit=time_limit,
                       upper=upper if math.isfinite(upper) else None)
    if sel is None:
        raise ValueError(f"`{name}` has no grouping of finite cost: every grouping uses a "
                         "forbidden (+inf) group")
    return flat[sel]
