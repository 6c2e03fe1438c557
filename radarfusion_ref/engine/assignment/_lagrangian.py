"""The S-D assignment on explicit candidate groups by Lagrangian relaxation (Deb et al. 1997)."""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.optimize import linear_sum_assignment

from ._milp import _milp_tuples, _report_nodes
from ._sparse import int32_indices

# --------------------------------------------------------------------------- S-D: explicit candidate groups
#: What a caller of the grouping chapter can change when no grouping exists.
_HINT = ("widen the gate or allow missed detections and false reports (`p_detect` < 1, "
         "`false_density` > 0)")
_LAGRANGE_STALL = 6          # iterations without a better dual value before the step halves


_LAGRANGE_PATIENCE = 20      # iterations without progress of either bound: branch and bound


_EPS = np.finfo(float).eps


_DENSE_ASSIGN = 1 << 20      # cells up to which a square assignment is solved densely


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
    graph = int32_indices(sparse.coo_array((np.ones(rows.size), (rows, cols)), shape=(N, N)))
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
    graph = int32_indices(sparse.coo_array((wts - lo + 1.0, (rows, cols)), shape=(N, N)))
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


def sd_candidates_kernel(T, c, counts, *, dummy, method, gap, max_iter, time_limit, why,
                         name="x", hint=None):
    """Kernel (trusted input): one scene's S-D problem over candidates, cluster by cluster.

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


