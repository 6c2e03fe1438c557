r"""The hand-over kernel of :func:`~radarfusion_ref.continent.sectors.track_sectored`
(trusted input): the sectors' track histories merged into one, with one identity per
aircraft across borders."""

from __future__ import annotations

import numpy as np
from scipy import sparse

from ..engine.assignment import assign_two_lists
from ..engine.linalg import mahalanobis_sq
from ..tracking import TrackHistory


def empty_history(initiated=0):
    """A history without rows."""
    return TrackHistory(np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 6)),
                        np.zeros((0, 6, 6)), np.zeros(0, bool), initiated)


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


def _band_rows(history, sectors, s, t):
    """Confirmed rows of `history` (sector `s`) whose position lies in both grown rectangles."""
    x = history.state
    inside = sectors._in_grown(x[:, :2], s) & sectors._in_grown(x[:, :2], t)
    return np.flatnonzero(history.confirmed & inside)


def pair_costs(ha, hb, rows_a, rows_b):
    r"""Mean squared distance of every pair of tracks (one of `ha`, one of `hb`) over their
    common instants: ``(track_a, track_b, kappa)`` sorted by the two tracks."""
    ta, tb = ha.time[rows_a], hb.time[rows_b]
    oa, ob = np.argsort(ta, kind="stable"), np.argsort(tb, kind="stable")
    rows_a, rows_b, ta, tb = rows_a[oa], rows_b[ob], ta[oa], tb[ob]
    lo = np.searchsorted(tb, ta, side="left")                # rows of b at each a's instant
    hi = np.searchsorted(tb, ta, side="right")
    n = hi - lo
    empty = (np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0))
    if not n.sum():
        return empty
    ia = np.repeat(rows_a, n)
    start = np.repeat(lo - np.r_[0, np.cumsum(n)[:-1]], n)
    ib = rows_b[start + np.arange(ia.size)]
    d = ha.state[ia, :3] - hb.state[ib, :3]
    d2 = np.atleast_1d(mahalanobis_sq(d, ha.covariance[ia, :3, :3] + hb.covariance[ib, :3, :3]))
    key_a, key_b = ha.track[ia], hb.track[ib]
    pairs, inv = np.unique(np.c_[key_a, key_b], axis=0, return_inverse=True)
    inv = inv.reshape(-1)
    total = np.bincount(inv, weights=d2, minlength=pairs.shape[0])
    count = np.bincount(inv, minlength=pairs.shape[0])
    return pairs[:, 0], pairs[:, 1], total / count


def _rows_of(history, tracks):
    """Confirmed rows of each of `tracks` (sorted distinct ids), in time order."""
    rows = np.flatnonzero(history.confirmed & np.isin(history.track, tracks))
    rows = rows[np.lexsort((history.time[rows], history.track[rows]))]
    cut = np.searchsorted(history.track[rows], tracks, side="left")
    end = np.searchsorted(history.track[rows], tracks, side="right")
    return {int(k): rows[a:b] for k, a, b in zip(tracks, cut, end, strict=True)}


def consistent(ha, hb, ka, kb, gamma):
    """Whether the tracks `ka[i]` of `ha` and `kb[i]` of `hb` agree (squared distance below
    `gamma`) at every common instant of their confirmed rows, anywhere: a track that one
    sector's tracker carried on to another aircraft after the hand-over is not joined."""
    rows_a, rows_b = _rows_of(ha, np.unique(ka)), _rows_of(hb, np.unique(kb))
    ok = np.ones(ka.size, bool)
    for i, (a, b) in enumerate(zip(ka.tolist(), kb.tolist(), strict=True)):
        ra, rb = rows_a[a], rows_b[b]
        lo = np.searchsorted(hb.time[rb], ha.time[ra], side="left")
        hi = np.searchsorted(hb.time[rb], ha.time[ra], side="right")
        n = hi - lo
        if not n.sum():
            continue
        ia = np.repeat(ra, n)
        ib = rb[np.repeat(lo - np.r_[0, np.cumsum(n)[:-1]], n) + np.arange(ia.size)]
        d2 = mahalanobis_sq(ha.state[ia, :3] - hb.state[ib, :3],
                            ha.covariance[ia, :3, :3] + hb.covariance[ib, :3, :3])
        ok[i] = bool(np.max(d2) < gamma)
    return ok


def candidate_links(sectors, histories, gamma):
    """The one-to-one links of every pair of neighbouring sectors: arrays ``s, a, t, b,
    kappa`` (sector and local track of each side, mean squared distance), in the order
    of the pairs of sectors, then of `a`."""
    out = []
    for s, t in neighbour_pairs(sectors):
        ha, hb = histories[s], histories[t]
        if not (ha.confirmed.any() and hb.confirmed.any()):
            continue
        ra, rb = _band_rows(ha, sectors, s, t), _band_rows(hb, sectors, s, t)
        if not (ra.size and rb.size):
            continue
        ka, kb, kappa = pair_costs(ha, hb, ra, rb)
        ok = kappa < gamma                               # the gate on the mean distance
        if not ok.any():
            continue
        ka, kb, kappa = ka[ok], kb[ok], kappa[ok]
        ok = consistent(ha, hb, ka, kb, gamma)
        if not ok.any():
            continue
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
    if not out:
        return (np.zeros(0, np.int64),) * 4 + (np.zeros(0),)
    s, a, t, b, kappa = (np.array(v) for v in zip(*out, strict=True))
    return s.astype(np.int64), a.astype(np.int64), t.astype(np.int64), b.astype(np.int64), \
        kappa.astype(float)


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


def join_identities(histories, offset, links):
    """Union of the linked tracks, in order of increasing cost; a link that would give
    one identity to two tracks of one sector alive at a common instant is refused.
    Returns the identity of every provisional id and the accepted links (mask)."""
    s, a, t, b, kappa = links
    n_ids = int(offset[-1]) if offset.size else 0
    parent = np.arange(n_ids, dtype=np.int64)
    spans = [_spans(h) for h in histories]

    def span(sector, local):
        ids, first, last = spans[sector]
        k = int(np.searchsorted(ids, local))
        return sector, float(first[k]), float(last[k])

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


def merge_histories(sectors, histories, gamma):
    """The merged history, the accepted links and the hand-overs per sector."""
    initiated = np.array([h.initiated for h in histories], dtype=np.int64)
    offset = np.r_[0, np.cumsum(initiated)]
    links = candidate_links(sectors, histories, gamma)
    identity, accepted = join_identities(histories, offset, links)
    links = tuple(v[accepted] for v in links)
    parts = []
    for k, h in enumerate(histories):
        own = np.flatnonzero(sectors._owner(h.state[:, :2]) == k) if h.track.size else []
        if len(own):
            parts.append((identity[offset[k] + h.track[own]], h.time[own], h.state[own],
                          h.covariance[own], h.confirmed[own], np.full(len(own), k)))
    handovers = (np.bincount(links[0], minlength=sectors.n_sectors)
                 + np.bincount(links[2], minlength=sectors.n_sectors))
    if not parts:
        return empty_history(int(initiated.sum())), links, handovers
    ids, t, x, P, c, sec = (np.concatenate(v) for v in zip(*parts, strict=True))
    order = np.lexsort((sec, ids, t))                    # time, identity, then sector
    ids, t, sec = ids[order], t[order], sec[order]
    # an identity's rows at one instant come from one sector: the aircraft on a border,
    # placed on each side by the two trackers, keeps the rows of the lower sector (one
    # tracker's several rows at one instant, scans of several radars, all stay)
    start = np.r_[True, (np.diff(t) != 0) | (np.diff(ids) != 0)]
    group = np.cumsum(start) - 1
    lowest = sec[np.flatnonzero(start)][group]
    mine = sec == lowest
    keep = order[mine]
    history = TrackHistory(ids[mine], t[mine], x[keep], P[keep], c[keep],
                           int(initiated.sum()))
    return history, links, handovers
