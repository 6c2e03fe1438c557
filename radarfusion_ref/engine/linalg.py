r"""The one home of the squared Mahalanobis distance and of positive definiteness.

For a difference :math:`\Delta` of two :math:`k`-dimensional reports and the
covariance :math:`S` of that difference,

.. math::

    \kappa = \Delta^T S^{-1} \Delta ,

computed by the square-root-free factorisation :math:`S = L D L^T` (:math:`L`
unit lower triangular, :math:`D` diagonal) and forward substitution
:math:`w = L^{-1}\Delta`, :math:`\kappa = \sum_j w_j^2 / D_j` — no inverse is
formed. The factorisation is written out component by component over whole
arrays, so a batch of millions of small matrices costs a handful of ufunc
passes instead of one LAPACK call per matrix.

Public functions (each validates its arguments once, then calls a private
kernel that trusts them):

* :func:`mahalanobis_sq` — pointwise, batched over leading axes;
* :func:`mahalanobis_sq_pairwise` — every pair of two report sets, each report
  with its own covariance, batched over leading (trial) axes, in chunks (the
  same factorisation as in-place ufuncs over preallocated buffers), or, for 2-D
  and 3-D reports with numba installed (the ``fast`` extra), by compiled kernels
  that give the same bits;
* :func:`is_positive_definite` — the package's one positive-definiteness rule;
* :func:`cholesky` — a validated Cholesky factor.

The kernels :func:`mahalanobis_sq_kernel` and :func:`mahalanobis_sq_k2_kernel`
(named ``*_kernel``: they trust their input) are public too, for the chapter
modules' public functions that validate their own arguments at their door, with
:func:`radarfusion_ref.engine.validation.as_covariance` and
:func:`~radarfusion_ref.engine.validation.check_domain`.

.. rubric:: The positive-definiteness rule

A covariance :math:`C` is accepted when it is symmetric (to 1e-9 of its
largest entry), its variances are positive, and every pivot of the
:math:`LDL^T` factorisation of its correlation matrix
:math:`R = D_C^{-1/2} C D_C^{-1/2}` — the variance of each coordinate given the
preceding ones, as a fraction of its own variance — exceeds
:data:`~radarfusion_ref.engine.validation.SINGULAR_RTOL` (1e-12). A matrix that
fails is singular to working precision: :math:`\kappa` against it would carry no correct digit. The rule is
scale-free (a change of unit per coordinate does not change it) and closed
under sums (a conditional variance of :math:`A + B` is at least the sum of
those of :math:`A` and :math:`B`), so two accepted report covariances always
give an accepted :math:`S = \Sigma_1 + \Sigma_2`.

.. rubric:: The numeric domain

Instead of rescaling, the Mahalanobis functions accept a documented domain and
refuse input outside it: every coordinate (and every difference) of magnitude
at most :data:`~radarfusion_ref.engine.validation.MAX_MAGNITUDE`
(:math:`2^{150} \approx 1.4 \times 10^{45}`) and every variance (diagonal entry of a covariance) in
:math:`[2^{-150}, 2^{150}]`. Inside it, with pivots above
:data:`~radarfusion_ref.engine.validation.SINGULAR_RTOL` and :math:`k \le 8`, no
intermediate of the factorisation overflows or becomes subnormal, so :math:`\kappa` is correct to rounding (a few
units of :math:`\varepsilon\,\mathrm{cond}(S)` relative) — physical radar
coordinates in any unit from micrometres to light years lie well inside.
"""

from __future__ import annotations

import importlib
import math
import numbers
import os
from types import ModuleType

import numpy as np

from .validation import (
    MEMORY_LIMIT,
    _pd_mask,
    _symmetric_mask,
    as_covariance,
    as_float_array,
    as_int,
    check_domain,
    check_size,
    describe,
    unwrap,
)

__all__ = [
    "cholesky",
    "is_positive_definite",
    "mahalanobis_sq",
    "mahalanobis_sq_k2_kernel",
    "mahalanobis_sq_kernel",
    "mahalanobis_sq_pairwise",
]

#: Default pairs per chunk of :func:`mahalanobis_sq_pairwise`: long enough that each ufunc
#: call's fixed cost is small, short enough that the k^2 + k + 3 work buffers stay in the
#: last-level cache.
_PAIR_CHUNK = 65536
#: Largest chunk: larger `chunk_size` values give the same blocks as this one.
_MAX_CHUNK = 1 << 20
#: Reports per radar at or below which, with more trials than that, the trials run innermost.
_TRIAL_LAST_REPORTS = 64
#: Covariances per run of the door's check (:func:`_covariance_in_runs`).
_VALIDATE_RUN = 32768
#: Shortest inner run of a block, when the chunk allows it.
_MIN_RUN = 4096
#: Set to 1, this environment variable makes :func:`mahalanobis_sq_pairwise` take the numpy
#: route even when numba is installed (read at each call).
NO_COMPILED_ENV = "RADARFUSION_NO_COMPILED"
#: Reports per set at or below which the compiled route runs the trials innermost.
_COMPILED_TRIAL_LAST = 3
#: The compiled kernels once imported (None without numba), or nothing before the first use.
_COMPILED: list[ModuleType | None] = []


# --------------------------------------------------------------------------- door checks
def _refuse_overflow(kappa: np.ndarray, names: str) -> None:
    if kappa.size and not float(np.max(kappa)) < np.inf:
        raise ValueError(
            f"{names}: the squared Mahalanobis distance exceeds the largest double "
            "(about 1.8e308); change the unit of the coordinates")


def mahalanobis_sq_kernel(d: np.ndarray, s: np.ndarray, names: str,
                          logdet: list | None = None) -> np.ndarray:
    r"""Kernel (trusted input): :math:`\kappa = d^T S^{-1} d`, broadcast over leading axes.

    The kernel of :func:`mahalanobis_sq`, for a public function that validated its
    own arguments at its door: `d` ``(..., k)`` and `s` ``(..., k, k)`` float
    arrays, `d` checked by :func:`~radarfusion_ref.engine.validation.check_domain`
    and `s` by :func:`~radarfusion_ref.engine.validation.as_covariance` (or a sum of
    such covariances: the rule is closed under sums). It checks nothing but
    overflow: a :math:`\kappa` beyond the largest double is refused with a message
    headed by `names` (the caller's public argument names, in backticks). With
    `logdet` (a list), :math:`\ln\det S` is appended to it.
    """
    k = d.shape[-1]
    with np.errstate(under="ignore"):
        out = _ldl_kappa([d[..., i] for i in range(k)],
                         [[s[..., i, j] for j in range(i + 1)] for i in range(k)], logdet)
    out = np.broadcast_to(out, np.broadcast_shapes(d.shape[:-1], s.shape[:-2]))
    _refuse_overflow(out, names)
    return out


def _mahalanobis_iv(d, cov):
    a = as_float_array(d, "d", ndim_min=1)
    k = a.shape[-1]
    c = as_covariance(cov, "cov", dim=k)
    check_domain(a, "d")
    try:
        np.broadcast_shapes(a.shape[:-1], c.shape[:-2])
    except ValueError:
        raise ValueError("`d`, `cov` must have broadcastable leading (batch) axes; received "
                         f"shapes {a.shape}, {c.shape}") from None
    return a, c


def _covariance_in_runs(value, name, k):
    """:func:`~radarfusion_ref.engine.validation.as_covariance` of a long stack, run by run.

    The same rule on runs of :data:`_VALIDATE_RUN` matrices, so its work arrays stay
    in cache; a run that breaks it sends the whole argument through the rule, for the
    one message (and count) of the argument as received.
    """
    if not (isinstance(value, np.ndarray) and value.dtype == np.float64 and value.ndim > 2
            and value.shape[-2:] == (k, k) and value.flags.c_contiguous
            and value.size > 2 * _VALIDATE_RUN * k * k):
        return as_covariance(value, name, dim=k)
    flat = value.reshape(-1, k, k)
    try:
        for r0 in range(0, len(flat), _VALIDATE_RUN):
            as_covariance(flat[r0:r0 + _VALIDATE_RUN], name, dim=k)
    except ValueError:
        as_covariance(value, name, dim=k)
        raise                                   # not reached: the whole breaks the rule too
    return value


def _pairwise_iv(x1, x2, cov1, cov2, chunk_size, out_bytes):
    a = as_float_array(x1, "x1", ndim_min=2)
    k = a.shape[-1]
    b = as_float_array(x2, "x2", ndim_min=2, last_dims=(None, k))
    covs = []
    for name, value, x, xname in (("cov1", cov1, a, "x1"), ("cov2", cov2, b, "x2")):
        c = _covariance_in_runs(value, name, k)
        c = c[None] if c.ndim == 2 else c                 # one (k, k) matrix: shared
        if c.shape[-3] not in (1, x.shape[-2]):
            raise ValueError(f"`{name}` must hold one {k}x{k} matrix per report of `{xname}` "
                             f"(shape (..., {x.shape[-2]}, {k}, {k}) or ({k}, {k})); "
                             f"received shape {c.shape}")
        covs.append(c)
        check_domain(x, xname)
    c1, c2 = covs
    try:
        lead = np.broadcast_shapes(a.shape[:-2], b.shape[:-2], c1.shape[:-3], c2.shape[:-3])
    except ValueError:
        raise ValueError("`x1`, `x2`, `cov1`, `cov2` must have broadcastable leading (batch) "
                         f"axes; received shapes {a.shape}, {b.shape}, {np.shape(cov1)}, "
                         f"{np.shape(cov2)}") from None
    chunk = min(as_int(chunk_size, "chunk_size", minimum=1), _MAX_CHUNK)
    n_lead, n1, n2 = math.prod(lead), a.shape[-2], b.shape[-2]
    n_pairs = n_lead * n1 * n2
    check_size(_planned_bytes(k, n_lead, n1, n2, chunk, out_bytes), MEMORY_LIMIT,
               what=f"bytes for {n_pairs} pairs of `x1` x `x2` (result, per-report copies "
                    "and work buffers)",
               alternative="smaller batches of trials (split the leading axes of `x1`, `x2`)")
    return a, b, c1, c2, lead, chunk


def _planned_bytes(k, n_lead, n1, n2, chunk, out_bytes):
    """The memory :func:`mahalanobis_sq_pairwise` plans for (either route stays within it)."""
    n_pairs = n_lead * n1 * n2
    parts = k + k * (k + 1) // 2
    return (n_pairs * out_bytes                             # the result
            + 2 * parts * 8 * n_lead * (n1 + n2)            # per-report component copies
            + (k * k + k + 3 + 2 * parts) * 8 * min(chunk, n_pairs))    # work, gathers


# --------------------------------------------------------------------------- kernels
def _ldl_kappa(d, s, logdet=None):
    """kappa = d' S^-1 d from components: d[i] and s[i][j] (i >= j), arrays that broadcast.

    S = L D L^T with L unit lower triangular: D_j = s_jj - sum_m L_jm^2 D_m,
    L_ij = (s_ij - sum_m L_im L_jm D_m) / D_j; w = L^-1 d; kappa = sum_j w_j (w_j / D_j).
    With `logdet` (a list) the log-determinant sum_j ln D_j is appended to it.
    """
    k = len(d)
    g = [[s[i][j] for j in range(i + 1)] for i in range(k)]   # g[i][j] -> L_ij D_j
    low: list[list] = [[None] * k for _ in range(k)]            # L_ij
    piv: list = []
    w: list = []
    kappa = None
    for j in range(k):
        dj = g[j][j]
        for m in range(j):
            dj = dj - g[j][m] * low[j][m]
        piv.append(dj)
        for i in range(j + 1, k):
            for m in range(j):
                g[i][j] = g[i][j] - g[i][m] * low[j][m]
            low[i][j] = g[i][j] / dj
        wj = d[j]
        for m in range(j):
            wj = wj - low[j][m] * w[m]
        w.append(wj)
        term = wj * (wj / dj)
        kappa = term if kappa is None else kappa + term
    if logdet is not None:
        logdet.append(sum((np.log(p) for p in piv[1:]), np.log(piv[0])))
    return kappa


def mahalanobis_sq_k2_kernel(delta: np.ndarray, s: np.ndarray, out: np.ndarray) -> None:
    r"""Kernel (trusted input): :math:`\kappa` of many 2-vectors against one 2x2 matrix, in place.

    The :math:`k = 2` case of :func:`mahalanobis_sq_kernel` without temporaries,
    for a public function that validated its arguments at its door: `delta`, a
    ``(2, m)`` work array of differences within the numeric domain (overwritten);
    `s`, one ``(2, 2)`` covariance accepted by
    :func:`~radarfusion_ref.engine.validation.as_covariance`; `out`, an ``(m,)``
    array that receives :math:`\kappa = d_0^2 / s_{00} + w^2 / D_2` with
    :math:`u = s_{10}/s_{00}`, :math:`D_2 = s_{11} - u s_{10}`,
    :math:`w = d_1 - u d_0`. Overflow is not checked (the caller does).
    """
    d0, d1 = delta
    u = s[1, 0] / s[0, 0]
    piv = s[1, 1] - s[1, 0] * u
    np.multiply(d0, u, out=out)
    np.subtract(d1, out, out=d1)             # w
    np.divide(d0, s[0, 0], out=out)
    np.multiply(out, d0, out=out)            # d0 (d0 / s00)
    np.divide(d1, piv, out=d0)
    np.multiply(d0, d1, out=d0)              # w (w / D2)
    np.add(out, d0, out=out)


def _ldl_pairs(px, qx, pc, qc, k, work, cwork, out, logdet=None):
    """kappa of one block of pairs, in place into `out`: the in-place form of :func:`_ldl_kappa`.

    `px`, `qx`: each side's coordinates, stacked ``(k, ...)``, broadcasting to the
    block; `pc`, `qc`: each side's lower-triangle covariance entries, row by row,
    stacked ``(k (k + 1) / 2, ...)``, broadcasting to the shape the covariances vary
    along within the block (one element when both sides share one matrix), over which
    the factorisation runs; `work`: ``(k + 2, *block)`` and `cwork`:
    ``(k^2 + 1, *that shape)`` buffers. S = P + Q and Delta = x_p - x_q, then for
    each pivot j

        D_j  = S_jj - sum_{m<j} G_jm L_jm,
        G_ij = S_ij - sum_{m<j} G_im L_jm,        L_ij = G_ij / D_j     (i > j),
        w_j  = Delta_j - sum_{m<j} L_jm w_m,      kappa += w_j (w_j / D_j)

    (G_ij = L_ij D_j). With `logdet` (an array like `out`), sum_j ln D_j goes into it.
    """
    nt = k * (k + 1) // 2
    w, (acc, t) = work[:k], work[k:]                # Delta -> w; kappa's running sum; a temporary
    s, low, ts = cwork[:nt], cwork[nt:-1], cwork[-1]    # S_ij -> G_ij (D_j); L_ij; a temporary
    np.subtract(px, qx, out=w)
    np.add(pc, qc, out=s)
    for j in range(k):
        dj, row = s[j * (j + 1) // 2 + j], j * (j - 1) // 2     # L_jm at row + m
        for m in range(j):
            np.multiply(s[j * (j + 1) // 2 + m], low[row + m], out=ts)
            np.subtract(dj, ts, out=dj)             # D_j
            np.multiply(low[row + m], w[m], out=t)
            np.subtract(w[j], t, out=w[j])          # w_j
        for i in range(j + 1, k):
            gij = s[i * (i + 1) // 2 + j]
            for m in range(j):
                np.multiply(s[i * (i + 1) // 2 + m], low[row + m], out=ts)
                np.subtract(gij, ts, out=gij)       # G_ij
            np.divide(gij, dj, out=low[i * (i - 1) // 2 + j])   # L_ij
        np.divide(w[j], dj, out=t)
        if j:
            np.multiply(t, w[j], out=t)
            np.add(acc, t, out=out if j == k - 1 else acc)    # kappa += w_j^2 / D_j
        else:
            np.multiply(t, w[j], out=out if k == 1 else acc)
    if logdet is not None:                          # the result is written once
        np.log(s[0], out=logdet if k == 1 else acc)
        for j in range(1, k):
            np.log(s[j * (j + 1) // 2 + j], out=t)
            np.add(acc, t, out=logdet if j == k - 1 else acc)


def _report_parts(x, c, lead, n):
    """One side's parts: k coordinate views ``(L, n)``, then the lower-triangle covariance entries.

    The covariance entries are ``(Lc, nc)`` views with ``Lc = 1`` when every trial
    shares them and ``nc = 1`` when every report does: a shared covariance is not
    copied per report, and its factorisation is not repeated.
    """
    k = x.shape[-1]
    n_lead = math.prod(lead)
    xs = [np.broadcast_to(x[..., i], (*lead, n)).reshape(n_lead, n) for i in range(k)]
    nc, shared = c.shape[-3], all(v == 1 for v in c.shape[:-3])
    lc = 1 if shared else n_lead
    cs = [(c[..., i, j] if shared else np.broadcast_to(c[..., i, j], (*lead, nc)))
          .reshape(lc, nc) for i in range(k) for j in range(i + 1)]
    return xs, cs


def _trial_last(n_lead, n1, n2):
    """Whether the trials run innermost: few reports per radar (short pair rows), many trials."""
    return max(n1, n2) <= _TRIAL_LAST_REPORTS and n_lead > max(n1, n2)


def _trial_run(n_lead, n1, n2, chunk):
    """Trials per gathered run of the trial-last order: long enough for fast inner loops."""
    return max(1, min(n_lead, max(_MIN_RUN, chunk // (n1 * n2)), chunk // max(n1, n2)))


def _tiles(lengths, chunk):
    """Blocks (slices per axis, outer to inner) of at most `chunk` elements, long inner runs."""
    outer, mid, inner = lengths
    bi = min(inner, chunk, max(_MIN_RUN, chunk // max(1, outer * mid)))
    bm = max(1, min(mid, chunk // bi))
    bo = max(1, min(outer, chunk // (bi * bm)))
    for o0 in range(0, outer, bo):
        for m0 in range(0, mid, bm):
            for i0 in range(0, inner, bi):
                yield (slice(o0, min(o0 + bo, outer)), slice(m0, min(m0 + bm, mid)),
                       slice(i0, min(i0 + bi, inner)))


def _pairwise(a, b, c1, c2, lead, chunk, want_logdet=False):
    """The chunked pairwise kernel on validated input; returns (kappa, logdet | None).

    Two loop orders, the same arithmetic pair by pair (so the same bits): with many
    trials of few reports the trials run innermost (each run of trials' reports
    gathered once into contiguous buffers, the result stored trial-last); otherwise
    the longer report axis does. Blocks of at most `chunk` pairs go through
    :func:`_ldl_pairs`, the factorisation over the covariances' own shape in the block.
    """
    k, n1, n2 = a.shape[-1], a.shape[-2], b.shape[-2]
    n_lead = math.prod(lead)
    if n_lead * n1 * n2 == 0:
        return np.empty((*lead, n1, n2)), (np.empty((*lead, n1, n2)) if want_logdet else None)
    trial_last = _trial_last(n_lead, n1, n2)
    if not trial_last and n1 > n2:
        # the longer report axis innermost: with the sides swapped every difference is negated
        # exactly and every sum of covariances is the same, so kappa and logdet keep their bits
        kappa, logdet = _pairwise(b, a, c2, c1, lead, chunk, want_logdet)
        return kappa.swapaxes(-1, -2), (None if logdet is None else logdet.swapaxes(-1, -2))
    (px, pc), (qx, qc) = _report_parts(a, c1, lead, n1), _report_parts(b, c2, lead, n2)
    shape = (n1, n2, n_lead) if trial_last else (n_lead, n1, n2)
    kappa = np.empty(shape)
    logdet = np.empty(shape) if want_logdet else None
    size = min(chunk, n1 * n2 * n_lead)
    work, cwork = np.empty((k + 2, size)), np.empty((k * k + 1, size))
    every = slice(None)

    def pick(parts, trials, reports):           # a side's covariance entries in a block
        lc, nc = parts[0].shape
        return (trials if lc > 1 else every), (reports if nc > 1 else every)

    if trial_last:
        bt = _trial_run(n_lead, n1, n2, chunk)
        # per side, (parts, reports, trials) buffers; entries shared by every trial stay put
        bufs = [np.empty((len(v), v[0].shape[-1], bt)) if v[0].shape[-2] > 1
                else np.stack(v).swapaxes(-1, -2) for v in (px, pc, qx, qc)]
        runs = [slice(t0, min(t0 + bt, n_lead)) for t0 in range(0, n_lead, bt)]
    else:
        px, pc, qx, qc = (np.stack(v) for v in (px, pc, qx, qc))
        runs = [every]
    for run in runs:
        if trial_last:
            m = run.stop - run.start
            gathered = []
            for v, buf in zip((px, pc, qx, qc), bufs, strict=True):
                if v[0].shape[-2] == 1:
                    gathered.append(buf)
                    continue
                g = buf.reshape(-1)[:buf.size // bt * m].reshape(len(v), v[0].shape[-1], m)
                for dst, part in zip(g, v, strict=True):
                    np.copyto(dst, part[run].T)
                gathered.append(g)
            prx, prc, qrx, qrc = gathered
            tiles = _tiles((n1, n2, m), chunk)
        else:
            tiles = _tiles(shape, chunk)
        for blk in tiles:
            if trial_last:
                si, sj, st = blk
                kk = kappa[si, sj, run][..., st]
                ld = None if logdet is None else logdet[si, sj, run][..., st]
                ti, ri = pick(pc, st, si)
                tj, rj = pick(qc, st, sj)
                views = (prx[:, si, None, st], qrx[:, None, sj, st],
                         prc[:, ri, None, ti], qrc[:, None, rj, tj])
            else:
                st, si, sj = blk
                kk, ld = kappa[blk], (None if logdet is None else logdet[blk])
                ti, ri = pick(pc, st, si)
                tj, rj = pick(qc, st, sj)
                views = (px[:, st, si, None], qx[:, st, None, sj],
                         pc[:, ti, ri, None], qc[:, tj, None, rj])
            cshape = np.broadcast_shapes(views[2].shape[1:], views[3].shape[1:])
            _ldl_pairs(*views, k, work[:, :kk.size].reshape(-1, *kk.shape),
                       cwork[:, :math.prod(cshape)].reshape(-1, *cshape), kk, ld)

    def back(arr):
        if arr is None:
            return None
        moved = np.moveaxis(arr, -1, 0) if trial_last else arr
        return moved.reshape(*lead, n1, n2)

    return back(kappa), back(logdet)


# --------------------------------------------------------------------------- the compiled route
def _compiled_kernels() -> ModuleType | None:
    """The compiled kernels (:mod:`radarfusion_ref.engine._compiled`), imported on first use.

    None when numba is not installed or :data:`NO_COMPILED_ENV` is set to 1.
    """
    if os.environ.get(NO_COMPILED_ENV, "0").strip() not in ("", "0"):
        return None
    if not _COMPILED:
        try:
            kernels = importlib.import_module("._compiled", __package__)
        except ImportError:                     # the kernels' module itself failed to import
            kernels = None
        _COMPILED.append(kernels if kernels is not None and kernels.AVAILABLE else None)
    return _COMPILED[0]


def _per_trial(v, lead, n, width):
    """One side's array as the kernels take it: C-contiguous, read-only ``(1 or T, n, width)``.

    A size-1 trial axis stays shared (one copy for every trial); leading axes that only
    partly broadcast are copied per trial (within the memory the door planned).
    """
    n_lead = math.prod(lead)
    if all(d == 1 for d in v.shape[:-2]):
        out = v.reshape(1, n, width)
    elif v.shape[:-2] == lead:
        out = v.reshape(n_lead, n, width)
    else:
        out = np.broadcast_to(v, (*lead, n, width)).reshape(n_lead, n, width)
    out = np.ascontiguousarray(out).view()
    out.flags.writeable = False                 # one compiled signature for every input
    return out


def _compiled_pairs(kernels, a, b, c1, c2, lead, check):
    """kappa of every pair by the compiled kernels (k = 2 or 3); None if `check` finds bad input.

    `a`, `b`, `c1`, `c2` as :func:`_pairwise` takes them; with `check`, the coordinates'
    domain and the covariance rule are checked here (the covariances that vary from trial
    to trial inside the kernels, block by block), None meaning that some argument breaks
    a rule: the numpy door then names it.
    """
    k, n1, n2 = a.shape[-1], a.shape[-2], b.shape[-2]
    n_lead = math.prod(lead)
    kk = k * k
    xs = [_per_trial(a, lead, n1, k), _per_trial(b, lead, n2, k)]
    cs = [_per_trial(c.reshape(*c.shape[:-2], kk), lead, c.shape[-3], kk) for c in (c1, c2)]
    rule = kernels.rule2 if k == 2 else kernels.rule3
    if check and not (all(kernels.in_domain(x) for x in xs)
                      and all(rule(c.reshape(-1, kk)) for c in cs if c.shape[0] == 1)):
        return None
    inside = [check and c.shape[0] > 1 for c in cs]
    if max(n1, n2) <= _COMPILED_TRIAL_LAST and n_lead > 1:
        out = np.empty((n1, n2, n_lead))
        code = (kernels.trials2 if k == 2 else kernels.trials3)(*xs, *cs, out, *inside)
        kappa = np.moveaxis(out, -1, 0)
    elif n1 > n2:                               # the longer report axis innermost: the
        out = np.empty((n_lead, n2, n1))        # differences change sign exactly, same bits
        code = (kernels.rows2 if k == 2 else kernels.rows3)(xs[1], xs[0], cs[1], cs[0], out,
                                                            inside[1], inside[0])
        kappa = out.swapaxes(-1, -2)
    else:
        out = np.empty((n_lead, n1, n2))
        code = (kernels.rows2 if k == 2 else kernels.rows3)(*xs, *cs, out, *inside)
        kappa = out
    if code == 1:
        return None
    kappa = kappa.reshape(*lead, n1, n2)
    if code == 2:
        _refuse_overflow(kappa, "`x1`, `x2`")
    return kappa


def _compiled_route(kernels, x1, x2, cov1, cov2, chunk_size):
    """The door and kernels of the compiled route in one pass, or None.

    For float64 arrays with k = 2 or 3 and every shape, size and chunk valid, the checks
    of :func:`_pairwise_iv` (as the compiled rule) and the pairs; None for any other
    input or when a check fails: the numpy door then raises its message, or validates
    input of another form for :func:`_compiled_pairs`.
    """
    if not all(isinstance(v, np.ndarray) and v.dtype == np.float64 and v.ndim >= 2
               for v in (x1, x2, cov1, cov2)):
        return None
    k, n1, n2 = x1.shape[-1], x1.shape[-2], x2.shape[-2]
    if k not in (2, 3) or x2.shape[-1] != k or cov1.shape[-2:] != (k, k) \
            or cov2.shape[-2:] != (k, k):
        return None
    c1, c2 = (c[None] if c.ndim == 2 else c for c in (cov1, cov2))
    if c1.shape[-3] not in (1, n1) or c2.shape[-3] not in (1, n2):
        return None
    try:
        lead = np.broadcast_shapes(x1.shape[:-2], x2.shape[:-2], c1.shape[:-3], c2.shape[:-3])
    except ValueError:
        return None
    if isinstance(chunk_size, bool) or not isinstance(chunk_size, numbers.Integral) \
            or chunk_size < 1:
        return None
    n_lead = math.prod(lead)
    if n_lead * n1 * n2 == 0 or _planned_bytes(
            k, n_lead, n1, n2, min(int(chunk_size), _MAX_CHUNK), 8) > MEMORY_LIMIT:
        return None
    return _compiled_pairs(kernels, x1, x2, c1, c2, lead, check=True)


# --------------------------------------------------------------------------- public functions
def mahalanobis_sq(d, cov, *, return_logdet=False):
    r"""Squared Mahalanobis distance :math:`\kappa = d^T C^{-1} d`, batched over leading axes.

    Parameters
    ----------
    d : array_like, shape (..., k)
        Differences (for two reports, :math:`\hat x_1 - \hat x_2`), each entry
        of magnitude at most :data:`~radarfusion_ref.engine.validation.MAX_MAGNITUDE`.
    cov : array_like, shape (..., k, k)
        Their covariances (for two independent reports, :math:`\Sigma_1 +
        \Sigma_2`), each obeying :func:`is_positive_definite`, with variances
        in :math:`[2^{-150}, 2^{150}]`; the leading axes broadcast with `d`'s.
    return_logdet : bool, optional
        Also return :math:`\ln\det C` (from the same factorisation).

    Returns
    -------
    float or numpy.ndarray, shape (...)
        :math:`\kappa`; with ``return_logdet=True`` a tuple ``(kappa, logdet)``.

    Raises
    ------
    ValueError
        If `cov` breaks the positive-definiteness rule or is not square with
        ``k`` matching `d`, the leading axes do not broadcast, an entry is not
        finite or lies outside the numeric domain, or :math:`\kappa` exceeds the
        largest double.
    TypeError
        If an argument is not numeric or `return_logdet` is not a bool.

    Examples
    --------
    >>> mahalanobis_sq([1.0, 0.0], 2 * np.eye(2))
    0.5
    >>> mahalanobis_sq([[1.0, 1.0], [2.0, 0.0]], [[4.0, 0.0], [0.0, 1.0]])
    array([1.25, 1.  ])
    """
    if not isinstance(return_logdet, (bool, np.bool_)):
        raise TypeError(f"`return_logdet` must be a bool; received {describe(return_logdet)}")
    a, c = _mahalanobis_iv(d, cov)
    ld: list = []
    kappa = mahalanobis_sq_kernel(a, c, "`d`, `cov`", ld if return_logdet else None)
    if return_logdet:
        return unwrap(kappa), unwrap(np.broadcast_to(ld[0], kappa.shape))
    return unwrap(kappa)


def mahalanobis_sq_pairwise(x1, x2, cov1, cov2, *, return_logdet=False,
                            chunk_size=_PAIR_CHUNK):
    r"""Squared Mahalanobis distance of every pair of two report sets, each report with its own covariance.

    For report :math:`i` of set 1 and report :math:`j` of set 2, with
    :math:`S_{ij} = \Sigma_{1i} + \Sigma_{2j}`,

    .. math::

        \kappa_{ij} = (\hat x_{1i} - \hat x_{2j})^T S_{ij}^{-1} (\hat x_{1i} - \hat x_{2j}),

    for all :math:`n_1 n_2` pairs, batched over leading (trial) axes, in chunks
    whose work buffers do not grow with the number of pairs.

    Parameters
    ----------
    x1 : array_like, shape (..., n1, k)
        The first set of reports (coordinates within the numeric domain).
    x2 : array_like, shape (..., n2, k)
        The second set, in the same frame.
    cov1 : array_like, shape (..., n1, k, k), (..., 1, k, k) or (k, k)
        One covariance per report of `x1` (a size-1 report axis, or a single
        matrix, is shared), each obeying :func:`is_positive_definite`.
    cov2 : array_like, shape (..., n2, k, k), (..., 1, k, k) or (k, k)
        The same for `x2`.
    return_logdet : bool, optional
        Also return :math:`\ln\det S_{ij}`.
    chunk_size : int, optional
        Pairs per chunk (at least 1; above 2**20 the work buffers are capped at
        2**20 pairs). The result does not depend on it, to the bit.

    Returns
    -------
    numpy.ndarray, shape (..., n1, n2)
        :math:`\kappa_{ij}`, the leading axes the broadcast of the four
        arguments'; with ``return_logdet=True`` a tuple ``(kappa, logdet)``. The
        result may be a view of an array stored in another axis order (the trial
        axis last for many trials of few reports, else the longer report axis
        last); the values are the same.

    Raises
    ------
    ValueError
        If the shapes do not match, an entry is not finite or lies outside the
        numeric domain, a covariance breaks the positive-definiteness rule, the
        planned memory exceeds
        :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT` (checked before
        anything that grows with the pairs is allocated), or a :math:`\kappa`
        exceeds the largest double.
    TypeError
        If an argument is not numeric, `chunk_size` is not an integer or
        `return_logdet` is not a bool.

    Notes
    -----
    Each report covariance is checked once (not each of the :math:`n_1 n_2`
    sums: the rule is closed under sums), in runs of 32768 matrices. Each
    chunk of pairs is a fixed sequence of in-place ufuncs into preallocated
    buffers (no temporary grows with the pairs, none holds a :math:`k \times k`
    matrix per pair): the sums :math:`S = \Sigma_{1i} + \Sigma_{2j}` and
    differences :math:`\Delta`, then per pivot :math:`j` of :math:`S = L D L^T`

    .. math::

        D_j = S_{jj} - \sum_{m<j} G_{jm} L_{jm}, \quad
        G_{ij} = S_{ij} - \sum_{m<j} G_{im} L_{jm}, \quad L_{ij} = G_{ij} / D_j,

        w_j = \Delta_j - \sum_{m<j} L_{jm} w_m, \qquad
        \kappa = \sum_j w_j \, (w_j / D_j),

    fifteen element-wise operations per pair for :math:`k = 2`, thirty-four for
    :math:`k = 3`. The operations on :math:`S` alone run over the axes the
    covariances vary along: with one covariance per side (or per trial) they run
    once per block, not per pair, leaving nine (:math:`k = 2`) or seventeen
    (:math:`k = 3`) per pair. Every pair goes through the same operations whatever
    the chunk, loop order or sharing, so the result is the same to the bit.

    .. rubric:: The compiled route

    With numba installed (the ``fast`` extra), 2-D and 3-D reports without
    `return_logdet` take compiled kernels instead, chosen automatically (set the
    environment variable ``RADARFUSION_NO_COMPILED=1`` for the numpy route). They
    run the same operations in the same order per pair (no fast-math: no
    reassociation, no fused multiply-add; IEEE division and square root), so the
    result is the numpy route's **to the bit**, in every layout and chunking
    (`chunk_size` only sizes the numpy route's buffers). The door's checks run in
    the same pass, trial block by trial block: the coordinates' domain and the
    covariance rule, first as a cheaper sufficient test (symmetry against the
    largest variance; both pivots of the correlation matrix above 1e-3 by a
    division-free test, with the rounding of both routes bounded), then by the
    rule's own operations for a block where that test fails, so exactly the
    same matrices are accepted. Input that breaks a rule goes through the numpy
    door, which raises its message. The kernels compile on their first call
    (a few seconds) and are cached on disk (next to the package, else numba's
    user cache or ``NUMBA_CACHE_DIR``; where no folder is writable they compile
    once per process).

    Examples
    --------
    >>> eye = np.eye(2)
    >>> mahalanobis_sq_pairwise([[0.0, 0.0], [1.0, 0.0]], [[2.0, 0.0]], [eye, 3 * eye], eye)
    array([[2.  ],
           [0.25]])
    """
    if not isinstance(return_logdet, (bool, np.bool_)):
        raise TypeError(f"`return_logdet` must be a bool; received {describe(return_logdet)}")
    kernels = None if return_logdet else _compiled_kernels()
    if kernels is not None:
        kappa = _compiled_route(kernels, x1, x2, cov1, cov2, chunk_size)
        if kappa is not None:
            return kappa
    a, b, c1, c2, lead, chunk = _pairwise_iv(x1, x2, cov1, cov2, chunk_size,
                                             16 if return_logdet else 8)
    if kernels is not None and a.shape[-1] in (2, 3) and math.prod(lead) * a.shape[-2] * b.shape[-2]:
        return _compiled_pairs(kernels, a, b, c1, c2, lead, check=False)
    with np.errstate(under="ignore"):
        kappa, logdet = _pairwise(a, b, c1, c2, lead, chunk, bool(return_logdet))
    _refuse_overflow(kappa, "`x1`, `x2`")
    return (kappa, logdet) if return_logdet else kappa


def is_positive_definite(cov):
    r"""The package's one positive-definiteness rule, per matrix of a stack.

    A matrix passes when it is symmetric (to 1e-9 of its largest entry), its
    variances are positive and every pivot of the :math:`LDL^T` factorisation
    of its correlation matrix :math:`R = D_C^{-1/2} C D_C^{-1/2}` exceeds
    :data:`~radarfusion_ref.engine.validation.SINGULAR_RTOL`, i.e. no coordinate's
    variance given the preceding coordinates falls below 1e-12 of its own variance (a matrix that fails is
    singular to working precision). NaN entries fail.

    Parameters
    ----------
    cov : array_like, shape (..., k, k)

    Returns
    -------
    bool or numpy.ndarray of bool, shape (...)

    Raises
    ------
    ValueError
        If `cov` is not a stack of square matrices.
    TypeError
        If `cov` is not numeric.

    Examples
    --------
    >>> is_positive_definite([[[2.0, 1.0], [1.0, 2.0]], [[1.0, 1.0], [1.0, 1.0]]])
    array([ True, False])
    """
    c = as_float_array(cov, "cov", ndim_min=2, allow_nonfinite=True)
    if c.shape[-1] != c.shape[-2]:
        raise ValueError(f"`cov` must have shape (..., k, k); received shape {c.shape}")
    return unwrap(_symmetric_mask(c) & _pd_mask(c))


def cholesky(cov, name="cov"):
    r"""Lower Cholesky factor :math:`L` (:math:`C = L L^T`) of covariances that obey the rule.

    Parameters
    ----------
    cov : array_like, shape (..., k, k)
        Covariances accepted by the one covariance rule,
        :func:`radarfusion_ref.engine.validation.as_covariance` (symmetric,
        positive definite by :func:`is_positive_definite`, variances in
        :math:`[2^{-150}, 2^{150}]`).
    name : str, optional
        The caller's name for `cov`, used in error messages (default ``"cov"``).

    Returns
    -------
    numpy.ndarray, shape (..., k, k)

    Raises
    ------
    ValueError
        Naming `name`, if `cov` is not square, not finite or breaks the rule.
    TypeError
        If `cov` is not numeric or `name` not a string.

    Examples
    --------
    >>> cholesky([[4.0, 2.0], [2.0, 2.0]])
    array([[2., 0.],
           [1., 1.]])
    """
    if not isinstance(name, str):
        raise TypeError(f"`name` must be a string; received {describe(name)}")
    return np.linalg.cholesky(as_covariance(cov, name))
