r"""The hand-over kernel of :func:`~radarfusion_ref.continent.sectors.track_sectored`
(trusted input): the sectors' track histories merged into one, with one identity per
aircraft across borders.

The merge works on what each sector's history contributes, computed where the sector was
tracked (:func:`summarise`, on a worker when the run is on a cluster):

* its **summary** (small): its tracks' spans of time, and its *edge*, the confirmed rows
  of the tracks that have a confirmed row in a band shared with a neighbour (position and
  its covariance only): all the hand-over's rule reads;
* its **part** (large): the rows it owns, which the merged history keeps.

The links (:func:`candidate_links`, :func:`join_identities`) are found from the summaries
and the merged history is assembled from the parts (:func:`assemble`). The edge keeps its
rows in the history's order, so every floating-point operation of the hand-over is the
one the whole histories would give, in the same order.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import sparse

from ..engine.assignment import assign_two_lists
from ..engine.linalg import mahalanobis_sq_kernel
from ..tracking import TrackHistory


def empty_history(initiated=0):
    """A history without rows."""
    return TrackHistory(np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 6)),
                        np.zeros((0, 6, 6)), np.zeros(0, bool), initiated)


@dataclass(frozen=True, eq=False)
class Edge:
    """Confirmed rows of the tracks that reach a band (position and covariance only), in
    the history's row order; read by the hand-over as a history is."""

    track: np.ndarray            # (E,)
    time: np.ndarray             # (E,)
    state: np.ndarray            # (E, 3) position
    covariance: np.ndarray       # (E, 3, 3)
    confirmed: np.ndarray        # (E,), all True
    trace: np.ndarray            # (E,), the covariance's trace


@dataclass(frozen=True, eq=False)
class Summary:
    """What the hand-over needs of one sector's history."""

    initiated: int
    n_confirmed: int
    span_ids: np.ndarray         # local track ids, sorted
    first: np.ndarray            # first instant of each (any row)
    last: np.ndarray             # last instant
    edge: Edge


@dataclass(frozen=True, eq=False)
class Part:
    """The rows one sector owns: local track ids, instants, states, covariances, flags,
    and the IMM's mode probabilities (None without the IMM)."""

    track: np.ndarray
    time: np.ndarray
    state: np.ndarray
    covariance: np.ndarray
    confirmed: np.ndarray
    mode_probability: np.ndarray | None = None


def neighbour_pairs(sectors):
    """Pairs ``(s, t)``, ``s < t``, of sectors whose grown rectangles intersect, in order."""
    lo_e, hi_e, lo_n, hi_n = sectors._grown_edges()
    ne = lo_e.size
    pairs = []
    for s in range(sectors.n_sectors):
        i, j = s % ne, s // ne
        ie = np.flatnonzero((lo_e <= hi_e[i]) & (lo_e[i] <= hi_e))
        jn = np.flatnonzero((lo_n <= hi_n[j]) & (lo_n[j] <= hi_n))
        t = (jn[:, None] * ne + ie[None, :]).ravel()
        pairs.extend((s, int(u)) for u in np.sort(t[t > s]))
    return pairs


def _neighbours(sectors, k):
    """The sectors whose grown rectangles meet sector `k`'s (`k` excluded), in order."""
    lo_e, hi_e, lo_n, hi_n = sectors._grown_edges()
    ne = lo_e.size
    i, j = k % ne, k // ne
    ie = np.flatnonzero((lo_e <= hi_e[i]) & (lo_e[i] <= hi_e))
    jn = np.flatnonzero((lo_n <= hi_n[j]) & (lo_n[j] <= hi_n))
    t = np.sort((jn[:, None] * ne + ie[None, :]).ravel())
    return t[t != k]


def _spans(history):
    """First and last instant of each local track of a history: ``ids, first, last``."""
    if not history.track.size:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    ids, inv = np.unique(history.track, return_inverse=True)
    inv = inv.reshape(-1)
    first = np.full(ids.size, np.inf)
    last = np.full(ids.size, -np.inf)
    np.minimum.at(first, inv, history.time)
    np.maximum.at(last, inv, history.time)
    return ids, first, last


def summarise(sectors, k, history):
    """Sector `k`'s history split into its :class:`Summary` and its owned :class:`Part`."""
    x, c = history.state, history.confirmed
    band = np.zeros(c.size, bool)
    if c.any():
        mine = sectors._in_grown(x[:, :2], k)
        for t in _neighbours(sectors, k):
            band |= mine & sectors._in_grown(x[:, :2], int(t))
        band &= c
    tracks = np.unique(history.track[band])
    rows = np.flatnonzero(c & np.isin(history.track, tracks))
    P = np.ascontiguousarray(history.covariance[rows, :3, :3])
    edge = Edge(history.track[rows], history.time[rows], np.ascontiguousarray(x[rows, :3]),
                P, c[rows], P[:, 0, 0] + P[:, 1, 1] + P[:, 2, 2])
    ids, first, last = _spans(history)
    own = np.flatnonzero(sectors._owner(x[:, :2]) == k)
    mu = history.mode_probability
    part = Part(history.track[own], history.time[own], x[own], history.covariance[own],
                c[own], None if mu is None else mu[own])
    return Summary(int(history.initiated), history.n_confirmed, ids, first, last, edge), part


def _band_rows(history, sectors, s, t):
    """Confirmed rows of `history` (sector `s`) whose position lies in both grown rectangles."""
    x = history.state
    inside = sectors._in_grown(x[:, :2], s) & sectors._in_grown(x[:, :2], t)
    return np.flatnonzero(history.confirmed & inside)


def _common(ta, tb):
    """Pairs of rows at common instants of two time-sorted row lists: positions ``(i, j)``
    in `ta`, `tb` (for each row of `ta`, the rows of `tb` at its instant, in order)."""
    lo = np.searchsorted(tb, ta, side="left")
    hi = np.searchsorted(tb, ta, side="right")
    n = hi - lo
    i = np.repeat(np.arange(ta.size), n)
    j = np.repeat(lo - np.r_[0, np.cumsum(n)[:-1]], n) + np.arange(i.size)
    return i, j


def _kappa(ha, hb, ia, ib):
    """Squared distance of the positions of rows `ia` of `ha` and `ib` of `hb` (their
    covariances summed): tracker output, inside the numeric domain."""
    d = ha.state[ia, :3] - hb.state[ib, :3]
    return np.atleast_1d(mahalanobis_sq_kernel(
        d, ha.covariance[ia, :3, :3] + hb.covariance[ib, :3, :3], "hand-over"))


def pair_costs(ha, hb, rows_a, rows_b, gamma):
    r"""Mean squared distance of the pairs of tracks (one of `ha`, one of `hb`) over their
    common instants that may pass the gate `gamma`: ``(track_a, track_b, kappa)`` sorted by
    the two tracks.

    A pair's mean is below `gamma` only if one of its instants is, and
    :math:`d^\mathsf T S^{-1} d \ge |d|^2 / \operatorname{tr} S`: the pairs without an
    instant of :math:`|d|^2 < \gamma \operatorname{tr} S` (with a margin for rounding)
    are left out before any covariance is read. The others' means are summed over all
    their instants, in the same order as over every pair."""
    ta, tb = ha.time[rows_a], hb.time[rows_b]
    oa, ob = np.argsort(ta, kind="stable"), np.argsort(tb, kind="stable")
    rows_a, rows_b, ta, tb = rows_a[oa], rows_b[ob], ta[oa], tb[ob]
    i, j = _common(ta, tb)
    empty = np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0)
    if not i.size:
        return empty
    ia, ib = rows_a[i], rows_b[j]
    key_a, key_b = ha.track[ia], hb.track[ib]
    # one integer key per pair, ordered as the pairs (a, b) are
    a0, b0 = key_a.min(), key_b.min()
    width = np.int64(key_b.max() - b0 + 1)
    key = (key_a - a0) * width + (key_b - b0)
    d = ha.state[ia, :3] - hb.state[ib, :3]
    near = np.einsum("ij,ij->i", d, d) < gamma * (ha.trace[ia] + hb.trace[ib]) * (1.0 + 1e-6)
    cand = np.unique(key[near])
    if not cand.size:
        return empty
    pos = np.minimum(np.searchsorted(cand, key), cand.size - 1)
    mine = np.flatnonzero(cand[pos] == key)              # every instant of those pairs
    inv = pos[mine]
    d2 = _kappa(ha, hb, ia[mine], ib[mine])
    total = np.bincount(inv, weights=d2, minlength=cand.size)
    count = np.bincount(inv, minlength=cand.size)
    return cand // width + a0, cand % width + b0, total / count


def _rows_of(history, tracks):
    """Confirmed rows of `tracks` (sorted distinct ids) in track then time order, and where
    each track's rows start and end in that list."""
    rows = np.flatnonzero(history.confirmed & np.isin(history.track, tracks))
    rows = rows[np.lexsort((history.time[rows], history.track[rows]))]
    cut = np.searchsorted(history.track[rows], tracks, side="left")
    end = np.searchsorted(history.track[rows], tracks, side="right")
    return rows, cut, end


def consistent(ha, hb, ka, kb, gamma):
    """Whether the tracks `ka[i]` of `ha` and `kb[i]` of `hb` agree (squared distance below
    `gamma`) at every common instant of their confirmed rows, anywhere: a track that one
    sector's tracker carried on to another aircraft after the hand-over is not joined."""
    ua, ub = np.unique(ka), np.unique(kb)
    rows_a, cut_a, end_a = _rows_of(ha, ua)
    rows_b, cut_b, end_b = _rows_of(hb, ub)
    pa, pb = np.searchsorted(ua, ka), np.searchsorted(ub, kb)
    ia, ib, pair = [], [], []
    for i, (p, q) in enumerate(zip(pa.tolist(), pb.tolist(), strict=True)):
        ra, rb = rows_a[cut_a[p]:end_a[p]], rows_b[cut_b[q]:end_b[q]]
        x, y = _common(ha.time[ra], hb.time[rb])
        ia.append(ra[x])
        ib.append(rb[y])
        pair.append(np.full(x.size, i))
    ok = np.ones(ka.size, bool)
    ia, ib, pair = (np.concatenate(v) for v in (ia, ib, pair))
    if not ia.size:
        return ok
    d2 = _kappa(ha, hb, ia, ib)
    worst = np.full(ka.size, -np.inf)
    np.maximum.at(worst, pair, d2)
    return ok & (worst < gamma)


def pair_links(sectors, s, t, ha, hb, gamma):
    """The one-to-one links of the neighbouring sectors `s` < `t` from their edges
    (:class:`Edge`): a list of ``(s, a, t, b, kappa)`` (local tracks, mean squared
    distance) in the order of `a`."""
    out = []
    if not (ha.confirmed.any() and hb.confirmed.any()):
        return out
    ra, rb = _band_rows(ha, sectors, s, t), _band_rows(hb, sectors, s, t)
    if not (ra.size and rb.size):
        return out
    ka, kb, kappa = pair_costs(ha, hb, ra, rb, gamma)
    ok = kappa < gamma                                   # the gate on the mean distance
    if not ok.any():
        return out
    ka, kb, kappa = ka[ok], kb[ok], kappa[ok]
    ok = consistent(ha, hb, ka, kb, gamma)
    if not ok.any():
        return out
    ka, kb, kappa = ka[ok], kb[ok], kappa[ok]
    ua, ia = np.unique(ka, return_inverse=True)
    ub, ib = np.unique(kb, return_inverse=True)
    # stored entries are the allowed pairs (an exact 0 included)
    cost = sparse.csr_array((kappa, (ia.reshape(-1), ib.reshape(-1))),
                            shape=(ua.size, ub.size))
    row_to_col = assign_two_lists(cost).row_to_col
    got = np.flatnonzero(row_to_col >= 0)
    cols = row_to_col[got]
    lookup = dict(zip(zip(ia.reshape(-1).tolist(), ib.reshape(-1).tolist(), strict=True),
                      kappa.tolist(), strict=True))
    for r, c in zip(got.tolist(), cols.tolist(), strict=True):
        out.append((s, int(ua[r]), t, int(ub[c]), lookup[(r, c)]))
    return out


class Links:
    """The candidate links, found pair of sectors by pair as the sectors' edges arrive
    (in any order: each pair's links depend on its two edges only), and given in the
    order of the pairs."""

    def __init__(self, sectors, gamma):
        self.sectors, self.gamma = sectors, gamma
        self.pairs = neighbour_pairs(sectors)
        self.edges: dict[int, Edge] = {}
        self.found: dict[tuple[int, int], list] = {}

    def add(self, k, edge):
        """Sector `k`'s edge; the links of its pairs with the sectors already in."""
        self.edges[k] = edge
        for s, t in self.pairs:
            if k in (s, t) and s in self.edges and t in self.edges:
                self.found[s, t] = pair_links(self.sectors, s, t, self.edges[s],
                                              self.edges[t], self.gamma)

    def result(self):
        """Arrays ``s, a, t, b, kappa``, in the order of the pairs of sectors, then of `a`."""
        out = [link for p in self.pairs for link in self.found[p]]
        if not out:
            return (np.zeros(0, np.int64),) * 4 + (np.zeros(0),)
        s, a, t, b, kappa = (np.array(v) for v in zip(*out, strict=True))
        return (s.astype(np.int64), a.astype(np.int64), t.astype(np.int64),
                b.astype(np.int64), kappa.astype(float))


def candidate_links(sectors, edges, gamma):
    """The one-to-one links of every pair of neighbouring sectors from the sectors' edges
    (:class:`Edge`, one per sector in order): :meth:`Links.result`."""
    links = Links(sectors, gamma)
    for k, edge in enumerate(edges):
        links.add(k, edge)
    return links.result()


def join_identities(summaries, offset, links):
    """Union of the linked tracks, in order of increasing cost; a link that would give
    one identity to two tracks of one sector alive at a common instant is refused.
    Returns the identity of every provisional id and the accepted links (mask)."""
    s, a, t, b, kappa = links
    n_ids = int(offset[-1]) if offset.size else 0
    parent = np.arange(n_ids, dtype=np.int64)

    def span(sector, local):
        m = summaries[sector]
        k = int(np.searchsorted(m.span_ids, local))
        return sector, float(m.first[k]), float(m.last[k])

    members: dict[int, list] = {}

    def find(i):
        root = i
        while parent[root] != root:
            root = parent[root]
        while parent[i] != root:                         # path compression
            parent[i], i = root, parent[i]
        return root

    accepted = np.zeros(kappa.size, bool)
    for k in np.lexsort((b, t, a, s, kappa)):            # cheapest link first, then by index
        p, q = int(offset[s[k]] + a[k]), int(offset[t[k]] + b[k])
        rp, rq = find(p), find(q)
        if rp == rq:
            accepted[k] = True
            continue
        mp = members.get(rp) or [span(int(s[k]), int(a[k]))]
        mq = members.get(rq) or [span(int(t[k]), int(b[k]))]
        clash = any(x[0] == y[0] and x[1] <= y[2] and y[1] <= x[2] for x in mp for y in mq)
        if clash:
            continue
        lo, hi = min(rp, rq), max(rp, rq)                # the group's id: its smallest
        parent[hi] = lo
        members[lo] = mp + mq
        members.pop(hi, None)
        accepted[k] = True
    identity = parent.copy()
    for i in np.flatnonzero(parent != np.arange(n_ids)):   # the linked tracks only
        identity[i] = find(int(i))
    return identity, accepted


def assemble(parts, identity, offset, initiated):
    """The merged history from the sectors' owned rows, sorted by (time, identity); an
    identity's rows at one instant come from one sector (see :func:`merge`)."""
    sizes = np.array([p.track.size for p in parts], np.int64)
    if not sizes.sum():
        return empty_history(initiated)
    ids = np.concatenate([identity[offset[k] + p.track] for k, p in enumerate(parts)])
    t = np.concatenate([p.time for p in parts])
    sec = np.repeat(np.arange(len(parts)), sizes)
    order = np.lexsort((sec, ids, t))                    # time, identity, then sector
    ids, t, sec = ids[order], t[order], sec[order]
    # an identity's rows at one instant come from one sector: the aircraft on a border,
    # placed on each side by the two trackers, keeps the rows of the lower sector (one
    # tracker's several rows at one instant, scans of several radars, all stay)
    start = np.r_[True, (np.diff(t) != 0) | (np.diff(ids) != 0)]
    group = np.cumsum(start) - 1
    mine = sec == sec[np.flatnonzero(start)][group]
    keep, sec = order[mine], sec[mine]
    local = keep - np.r_[0, np.cumsum(sizes)[:-1]][sec]   # row within its sector's part
    n = keep.size
    state, cov, conf = np.empty((n, 6)), np.empty((n, 6, 6)), np.empty(n, bool)
    imm = bool(parts) and all(p.mode_probability is not None for p in parts)
    mu = np.empty((n, parts[0].mode_probability.shape[1])) if imm else None
    for k, p in enumerate(parts):                        # one copy of the large arrays
        at = np.flatnonzero(sec == k)
        if at.size:
            src = local[at]
            state[at], cov[at], conf[at] = p.state[src], p.covariance[src], p.confirmed[src]
            if imm:
                mu[at] = p.mode_probability[src]
    return TrackHistory(ids[mine], t[mine], state, cov, conf, int(initiated), mu)


def merge(sectors, summaries, parts, gamma, links=None):
    """The merged history, the accepted links and the hand-overs per sector, from the
    sectors' summaries and parts (:func:`summarise`) and their candidate links (found
    here if None)."""
    initiated = np.array([m.initiated for m in summaries], dtype=np.int64)
    offset = np.r_[0, np.cumsum(initiated)]
    if links is None:
        links = candidate_links(sectors, [m.edge for m in summaries], gamma)
    identity, accepted = join_identities(summaries, offset, links)
    links = tuple(v[accepted] for v in links)
    handovers = (np.bincount(links[0], minlength=sectors.n_sectors)
                 + np.bincount(links[2], minlength=sectors.n_sectors))
    history = assemble(parts, identity, offset, int(initiated.sum()))
    return history, links, handovers


def merge_histories(sectors, histories, gamma):
    """:func:`merge` of whole histories (one per sector, in order)."""
    split = [summarise(sectors, k, h) for k, h in enumerate(histories)]
    return merge(sectors, [m for m, _ in split], [p for _, p in split], gamma)
