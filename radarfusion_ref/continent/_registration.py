"""Kernel of the continental registration: every radar's biases from the overlaps (trusted).

The door is :func:`radarfusion_ref.continent.scenario.register_continent`.
"""

from __future__ import annotations

import numpy as np
from scipy import stats

from . import _reports

#: Finite-difference steps of the bias Jacobian: range (m), azimuth (rad).
_STEP = (1.0, 1e-6)
#: Weak prior on every bias (its standard deviation): range offset (m), range scale, azimuth
#: offset (rad). It keeps a radar that overlaps no other at zero instead of singular.
PRIOR = (2000.0, 1e-2, np.radians(2.0))
#: Reports of one radar bracket another's report if at most this many of its periods apart.
_BRACKET = 1.5
#: Pairs whose normalised residual passes this chi-square(3) quantile are dropped and the
#: estimate is made again (the aircraft turned between the two bracketing reports).
_OUTLIER_P = 0.999
_PASSES = 3


def bias_jacobian(frame, rad, polar):
    """d(map position)/d(range offset, range scale, azimuth offset) of reports: (n, 3, 3)."""
    def pos(p):
        return _reports.convert(frame, rad, p, None, False)[0]

    dr = np.array([_STEP[0], 0.0, 0.0])
    db = np.array([0.0, _STEP[1], 0.0])
    d_range = (pos(polar + dr) - pos(polar - dr)) / (2 * _STEP[0])
    d_az = (pos(polar + db) - pos(polar - db)) / (2 * _STEP[1])
    return np.stack([d_range, polar[:, :1] * d_range, d_az], axis=-1)


def _sym(a):
    return np.swapaxes(a, -1, -2)


def register(frame, radars, rep):
    """Biases (m, 3), their covariance (3m, 3m), pairs used and pairs per radar."""
    m = len(radars)
    det = np.flatnonzero(rep.aircraft >= 0)
    radar, time, air = rep.radar[det], rep.time[det], rep.aircraft[det]
    x, cov = np.empty((det.size, 3)), np.empty((det.size, 3, 3))
    jac = np.empty((det.size, 3, 3))
    for i, rad in enumerate(radars):
        rows = radar == i
        x[rows], cov[rows] = _reports.convert(frame, rad, rep.polar[det][rows], None, False)
        jac[rows] = bias_jacobian(frame, rad, rep.polar[det][rows])
    # pairs: a report of radar j, bracketed by two reports of the same aircraft by radar i < j
    pair = []
    for i, rad in enumerate(radars):
        mine = np.flatnonzero(radar == i)
        order = np.lexsort((time[mine], air[mine]))
        mine = mine[order]
        other = np.flatnonzero(radar > i)
        if mine.size < 2 or other.size == 0:
            continue
        key_a, key_t = air[mine], time[mine]
        lo = np.searchsorted(key_a * 1e6 + key_t, air[other] * 1e6 + time[other]) - 1
        ok = (lo >= 0) & (lo < mine.size - 1)
        lo, other = lo[ok], other[ok]
        a, b = mine[lo], mine[lo + 1]
        ok = ((air[a] == air[other]) & (air[b] == air[other]) & (time[a] <= time[other])
              & (time[other] <= time[b]) & (time[b] - time[a] <= _BRACKET * rad.period))
        a, b, other = a[ok], b[ok], other[ok]
        w = ((time[other] - time[a]) / np.maximum(time[b] - time[a], 1e-9))[:, None]
        pair.append((np.full(other.size, i), other, a, b, w))
    if not pair:
        return None
    i_idx, j_row, a, b, w = (np.concatenate(v) for v in zip(*pair, strict=True))
    j_idx = radar[j_row]
    w3 = w[:, :, None]
    resid = x[j_row] - ((1 - w) * x[a] + w * x[b])
    b_i = (1 - w3) * jac[a] + w3 * jac[b]
    b_j = jac[j_row]
    s = cov[j_row] + (1 - w3) ** 2 * cov[a] + w3**2 * cov[b]
    keep = np.ones(resid.shape[0], dtype=bool)
    prior = np.diag(np.tile(1.0 / np.asarray(PRIOR) ** 2, m))
    for _ in range(_PASSES):
        # residual = B_j b_j - B_i b_i + noise, weight S^-1
        used = keep
        wt = np.linalg.inv(s[keep])
        info, rhs = prior.copy(), np.zeros(3 * m)
        for (u, bu, su), (v, bv, sv) in (((j_idx, b_j, 1), (j_idx, b_j, 1)),
                                         ((i_idx, b_i, -1), (i_idx, b_i, -1)),
                                         ((j_idx, b_j, 1), (i_idx, b_i, -1)),
                                         ((i_idx, b_i, -1), (j_idx, b_j, 1))):
            block = su * sv * (_sym(bu[keep]) @ wt @ bv[keep])
            np.add.at(info.reshape(m, 3, m, 3).transpose(0, 2, 1, 3),
                      (u[keep], v[keep]), block)
        for u, bu, su in ((j_idx, b_j, 1), (i_idx, b_i, -1)):
            g = su * (_sym(bu[keep]) @ wt @ resid[keep][..., None])[..., 0]
            np.add.at(rhs.reshape(m, 3), u[keep], g)
        est = np.linalg.solve(info, rhs)
        e = est.reshape(m, 3)
        r = resid - (b_j @ e[j_idx][..., None])[..., 0] + (b_i @ e[i_idx][..., None])[..., 0]
        nees = np.einsum("ni,ni->n", r, np.linalg.solve(s, r[..., None])[..., 0])
        keep = nees <= stats.chi2.ppf(_OUTLIER_P, 3)
    counts = np.bincount(i_idx[keep], minlength=m) + np.bincount(j_idx[keep], minlength=m)
    bread = np.linalg.inv(info)
    # the prior is one more observation of every bias, independent of the reports
    meat = prior + _shared_noise(m, used, j_row, a, b, w[:, 0], j_idx, i_idx, b_j, b_i, wt,
                                 cov)
    return e, bread @ meat @ bread, int(keep.sum()), counts


def _shared_noise(m, keep, j_row, a, b, w, j_idx, i_idx, b_j, b_i, wt, cov):
    r"""Covariance (3m, 3m) of the normal equations' right-hand side when pairs share
    reports: :math:`\sum_r U_r C_r U_r^\mathsf T` over the reports :math:`r` (covariance
    :math:`C_r`), with :math:`U_r = \sum_n c_{nr} H_n^\mathsf T S_n^{-1}` summed over the
    pairs :math:`n` that use report :math:`r`: :math:`c` is 1 for radar j's report,
    :math:`-(1-w)` and :math:`-w` for radar i's two, and :math:`H_n` holds :math:`B_j` at
    radar j's place and :math:`-B_i` at radar i's."""
    reports = (j_row[keep], a[keep], b[keep])
    weights = (np.ones(int(keep.sum())), -(1 - w[keep]), -w[keep])
    blocks = ((j_idx[keep], _sym(b_j[keep]) @ wt), (i_idx[keep], -_sym(b_i[keep]) @ wt))
    # one entry per (report, radar it informs): U_r's block at that radar
    key = np.concatenate([rep * m + blk for rep in reports for blk, _ in blocks])
    uk, inv = np.unique(key, return_inverse=True)
    inv = inv.reshape(len(reports) * len(blocks), -1)
    u = np.zeros((uk.size, 3, 3))
    for n, (c, (_, hw)) in enumerate((c, bl) for c in weights for bl in blocks):
        np.add.at(u, inv[n], c[:, None, None] * hw)
    urep, ublk = uk // m, uk % m                         # sorted by report, then radar
    first = np.flatnonzero(np.r_[True, urep[1:] != urep[:-1]])
    size = np.diff(np.r_[first, urep.size])
    out = np.zeros((m, m, 3, 3))
    for k in range(int(size.max())):
        for kk in range(int(size.max())):
            p = first[size > max(k, kk)]
            p, q = p + k, p + kk
            np.add.at(out, (ublk[p], ublk[q]), u[p] @ cov[urep[p]] @ _sym(u[q]))
    return out.transpose(0, 2, 1, 3).reshape(3 * m, 3 * m)
