r"""Compiled kernels of :func:`radarfusion_ref.engine.linalg.mahalanobis_sq_pairwise` (numba).

Private to :mod:`radarfusion_ref.engine.linalg`, which imports it on first use when numba
(the ``fast`` extra) is installed. Each kernel is the numpy route's arithmetic written for
one pair, the same operations in the same order: no ``fastmath`` (so no reassociation and
no fused multiply-add), IEEE division and square root, so every result has the numpy
route's bits. Functions compile on their first call and are cached on disk (next to this
file, or in numba's user-wide cache or ``NUMBA_CACHE_DIR`` when this folder is read-only;
compiled afresh in each process when no folder is writable).

Arrays, all C-contiguous float64: coordinates ``x`` ``(T_x, n, k)`` and covariances ``c``
``(U, m, k * k)`` (each matrix flat, row by row), with ``T_x`` and ``U`` in ``{1, T}`` and
``m`` in ``{1, n}``: a size-1 axis is shared by every trial or report.

* :func:`in_domain`, :func:`rule2`, :func:`rule3` — the door's checks:
  coordinates finite and within the numeric domain, and the one covariance rule of
  :func:`~radarfusion_ref.engine.validation.as_covariance` (finite, symmetric, variances
  in the domain, positive definite by the pivots of the correlation matrix), each as
  one bool for a whole stack; the caller sends a refused argument through the numpy door
  for its message;
* :func:`rows2`, :func:`rows3` — :math:`\kappa` of every pair into ``out`` ``(T, n1, n2)``,
  trial by trial, the second set's reports innermost (gathered component by component);
* :func:`trials2`, :func:`trials3` — the same into ``out`` ``(n1, n2, T)`` with the trials
  innermost, in blocks of :data:`TRIAL_BLOCK` trials, for many trials of few reports.

The pair kernels check the covariances that vary from trial to trial when asked
(``check1``, ``check2``), block by block while the block is in cache, and return 0; 1
if a covariance breaks the rule (the result is then incomplete); 2 if some
:math:`\kappa` overflowed to infinity.
"""

from __future__ import annotations

import importlib
from types import ModuleType

import numpy as np

from .validation import _SYMMETRY_RTOL, MAX_MAGNITUDE, SINGULAR_RTOL

numba: ModuleType | None
try:
    numba = importlib.import_module("numba")
except ImportError:                             # without the `fast` extra: not used, but this
    numba = None                                # module still imports (its doctests, tools)
#: Whether numba is installed: :mod:`~radarfusion_ref.engine.linalg` uses the kernels only then.
AVAILABLE = numba is not None

#: Trials per block of the trial-last kernels: a block's reports stay in the L1 cache.
TRIAL_BLOCK = 128

_HI = MAX_MAGNITUDE
_LO = 1.0 / MAX_MAGNITUDE
_FMAX = float(np.finfo(float).max)
_TINY = float(np.finfo(float).tiny)
_SYM = _SYMMETRY_RTOL
_PIV = SINGULAR_RTOL
_INF = np.inf


def _jit(func):
    """numba.njit with an on-disk cache when a cache folder is writable.

    error_model="numpy": a division by zero gives inf or NaN as numpy does (it does not
    occur on accepted input) instead of a Python exception, which would keep the loops
    from being vectorised.
    """
    if numba is None:
        return func
    try:
        return numba.njit(cache=True, error_model="numpy", nogil=True)(func)
    except RuntimeError:                    # numba: no writable cache folder for this file
        return numba.njit(cache=False, error_model="numpy", nogil=True)(func)


# --------------------------------------------------------------------------- the door's checks
@_jit
def in_domain(x):
    """All entries of `x` finite with magnitude at most MAX_MAGNITUDE (NaN fails)."""
    flat = x.reshape(-1)
    ok = True
    for r in range(flat.size):
        ok &= abs(flat[r]) <= _HI
    return ok


# The positive-definiteness part of the rule: the pivots of the correlation matrix R are
# computed as validation._pd_mask does (square roots and divisions) only for a stack in
# which some matrix fails a cheaper sufficient test, division free on the covariance C:
#     det_2 >= 2e-3 c_00 c_11,   c_20^2 <= c_00 c_22,   c_21^2 <= c_11 c_22,
#     det_3 >= 2e-3 c_00 c_11 c_22,
# with det_2 = c_00 c_11 - c_10^2 and det_3 = det C (cofactors of the first column). The
# pivots of R are delta_1 = det_2 / (c_00 c_11) and delta_2 = det_3 / (det_2 c_22) >=
# det_3 / (c_00 c_11 c_22). Once the test holds every product of det_3 is at most
# c_00 c_11 c_22 (1 + 3u) (u = 2**-53), so the rounding error of det_2 is below
# 4u c_00 c_11 and that of det_3 below 30u c_00 c_11 c_22: in exact arithmetic
# delta_1, delta_2 > 1e-3. _pd_mask's pivots lie within 11u and 14u + 90u / 1e-3 (< 2e-11)
# of them (its entries of R carry at most 4u relative error, |r_ij| < 1), far above
# SINGULAR_RTOL: it accepts the matrix too. With variances in [2**-150, 2**150] no product
# of the test overflows, and one that underflows is negligible next to 2e-3 c_00 c_11 c_22.
_SURE = 2e-3


@_jit
def _pd2(c):
    """_pd_mask's pivot for every row of `c` ``(R, 4)``: all above SINGULAR_RTOL."""
    ok = True
    for m in range(c.shape[0]):
        low10 = c[m, 2] / (np.sqrt(c[m, 3]) * np.sqrt(c[m, 0]))
        ok &= 1.0 - low10 * low10 > _PIV                        # D_1
    return ok


@_jit
def _pd3(c):
    """_pd_mask's pivots for every row of `c` ``(R, 9)``: all above SINGULAR_RTOL.

    Its operations in its order, from the lower triangle (its division by the first
    pivot, exactly 1, is left out: it changes no bit).
    """
    ok = True
    for m in range(c.shape[0]):
        r0, r1, r2 = np.sqrt(c[m, 0]), np.sqrt(c[m, 4]), np.sqrt(c[m, 8])
        low10 = c[m, 3] / (r1 * r0)
        low20 = c[m, 6] / (r2 * r0)
        low21 = c[m, 7] / (r2 * r1)
        d1 = 1.0 - low10 * low10                                # D_1
        low21 = low21 - low20 * low10
        d2 = 1.0 - low20 * low20
        d2 = d2 - low21 * (low21 / d1)                          # D_2
        ok &= (d1 > _PIV) & (d2 > _PIV)
    return ok


@_jit
def _rule2_full(c):
    """The covariance rule on every row of `c` ``(R, 4)`` (2x2 matrices, flat): all pass.

    As ``validation.as_covariance``: finite; symmetric to 1e-9 of the largest entry
    (``_symmetric_mask``); variances in [2**-150, 2**150]; positive definite by
    ``_pd_mask`` (see the note above :func:`_pd2`).
    """
    ok = sure = True
    for m in range(c.shape[0]):
        a00, a01, a10, a11 = c[m, 0], c[m, 1], c[m, 2], c[m, 3]
        # finite, entry by entry (NaN fails each comparison; max() may drop a NaN)
        good = (abs(a00) <= _FMAX) & (abs(a01) <= _FMAX) & (abs(a10) <= _FMAX)
        good &= abs(a11) <= _FMAX
        scale = max(max(abs(a00), abs(a01)), max(abs(a10), abs(a11)))
        good &= abs(a10 - a01) <= _SYM * max(scale, _TINY)      # symmetric
        good &= (a00 >= _LO) & (a00 <= _HI) & (a11 >= _LO) & (a11 <= _HI)
        ok &= good
        p = a00 * a11
        sure &= p - a10 * a10 >= _SURE * p
    return ok and (sure or _pd2(c))


@_jit
def _rule3_full(c):
    """The covariance rule on every row of `c` ``(R, 9)`` (3x3 matrices, flat): all pass.

    As :func:`_rule2_full`, for 3x3 matrices.
    """
    ok = sure = True
    for m in range(c.shape[0]):
        a00, a01, a02 = c[m, 0], c[m, 1], c[m, 2]
        a10, a11, a12 = c[m, 3], c[m, 4], c[m, 5]
        a20, a21, a22 = c[m, 6], c[m, 7], c[m, 8]
        # finite, entry by entry (NaN fails each comparison; max() may drop a NaN)
        good = (abs(a00) <= _FMAX) & (abs(a01) <= _FMAX) & (abs(a02) <= _FMAX)
        good &= (abs(a10) <= _FMAX) & (abs(a11) <= _FMAX) & (abs(a12) <= _FMAX)
        good &= (abs(a20) <= _FMAX) & (abs(a21) <= _FMAX) & (abs(a22) <= _FMAX)
        scale = max(max(max(abs(a00), abs(a01)), max(abs(a02), abs(a10))),
                    max(max(abs(a11), abs(a12)), max(abs(a20), max(abs(a21), abs(a22)))))
        asym = max(abs(a10 - a01), max(abs(a20 - a02), abs(a21 - a12)))
        good &= asym <= _SYM * max(scale, _TINY)                # symmetric
        good &= (a00 >= _LO) & (a00 <= _HI) & (a11 >= _LO) & (a11 <= _HI)
        good &= (a22 >= _LO) & (a22 <= _HI)
        ok &= good
        p = a00 * a11
        m0 = a11 * a22 - a21 * a21                              # cofactors of column 0
        m1 = a10 * a22 - a21 * a20
        m2 = a10 * a21 - a11 * a20
        det3 = a00 * m0 - a10 * m1 + a20 * m2
        sure &= ((p - a10 * a10 >= _SURE * p) & (a20 * a20 <= a00 * a22)
                 & (a21 * a21 <= a11 * a22) & (det3 >= _SURE * (p * a22)))
    return ok and (sure or _pd3(c))


# The rule's first pass takes the largest variance for the largest entry: an entry-wise
# symmetric test against it implies the rule's (the largest entry is at least as large),
# and it refuses a non-finite entry (the variances are checked against the domain, so the
# bound is finite; an infinite or NaN off-diagonal entry makes its difference inf or NaN).
# A stack in which some matrix fails this pass or the positive-definiteness test goes
# through the rule's own operations (_rule2_full, _rule3_full).
@_jit
def rule2(c):
    """The covariance rule on every row of `c` ``(R, 4)`` (2x2 matrices, flat): all pass."""
    sure = True
    for m in range(c.shape[0]):
        a00, a01, a10, a11 = c[m, 0], c[m, 1], c[m, 2], c[m, 3]
        good = (a00 >= _LO) & (a00 <= _HI) & (a11 >= _LO) & (a11 <= _HI)
        good &= abs(a10 - a01) <= _SYM * max(a00, a11)
        p = a00 * a11
        sure &= good & (p - a10 * a10 >= _SURE * p)
    return sure or _rule2_full(c)


@_jit
def rule3(c):
    """The covariance rule on every row of `c` ``(R, 9)`` (3x3 matrices, flat): all pass."""
    sure = True
    for m in range(c.shape[0]):
        a00, a01, a02 = c[m, 0], c[m, 1], c[m, 2]
        a10, a11, a12 = c[m, 3], c[m, 4], c[m, 5]
        a20, a21, a22 = c[m, 6], c[m, 7], c[m, 8]
        good = (a00 >= _LO) & (a00 <= _HI) & (a11 >= _LO) & (a11 <= _HI)
        good &= (a22 >= _LO) & (a22 <= _HI)
        tol = _SYM * max(a00, max(a11, a22))
        good &= (abs(a10 - a01) <= tol) & (abs(a20 - a02) <= tol) & (abs(a21 - a12) <= tol)
        p = a00 * a11
        m0 = a11 * a22 - a21 * a21                              # cofactors of column 0
        m1 = a10 * a22 - a21 * a20
        m2 = a10 * a21 - a11 * a20
        det3 = a00 * m0 - a10 * m1 + a20 * m2
        sure &= good & ((p - a10 * a10 >= _SURE * p) & (a20 * a20 <= a00 * a22)
                        & (a21 * a21 <= a11 * a22) & (det3 >= _SURE * (p * a22)))
    return sure or _rule3_full(c)


# --------------------------------------------------------------------------- one pair
@_jit
def _factor2(s00, s10, s11):
    """S = L D L^T for k = 2: (D_0, L_10, D_1)."""
    low10 = s10 / s00
    return s00, low10, s11 - s10 * low10


@_jit
def _kappa2(f, w0, w1):
    """kappa = sum_j w_j (w_j / D_j), w = L^-1 Delta, for the factor `f` of :func:`_factor2`."""
    d0, low10, d1 = f
    w1 = w1 - low10 * w0
    return w0 * (w0 / d0) + w1 * (w1 / d1)


@_jit
def _factor3(s00, s10, s11, s20, s21, s22):
    """S = L D L^T for k = 3: (D_0, L_10, L_20, D_1, L_21, D_2), G_21 = L_21 D_1."""
    low10 = s10 / s00
    low20 = s20 / s00
    d1 = s11 - s10 * low10
    g21 = s21 - s20 * low10
    low21 = g21 / d1
    d2 = s22 - s20 * low20
    d2 = d2 - g21 * low21
    return s00, low10, low20, d1, low21, d2


@_jit
def _kappa3(f, w0, w1, w2):
    """kappa = sum_j w_j (w_j / D_j), w = L^-1 Delta, for the factor `f` of :func:`_factor3`."""
    d0, low10, low20, d1, low21, d2 = f
    w1 = w1 - low10 * w0
    w2 = w2 - low20 * w0
    w2 = w2 - low21 * w1
    kappa = w0 * (w0 / d0)
    kappa = kappa + w1 * (w1 / d1)
    return kappa + w2 * (w2 / d2)


# --------------------------------------------------------------------------- second set innermost
@_jit
def rows2(x1, x2, c1, c2, out, check1, check2):
    """kappa[t, i, j] for k = 2, the reports of `x2` innermost (see the module)."""
    n_t, n1, n2 = out.shape
    m1, m2 = c1.shape[1], c2.shape[1]
    rows1, rows2_ = c1.reshape((-1, 4)), c2.reshape((-1, 4))
    xs, qs = np.empty((2, n2)), np.empty((3, m2))
    big = False
    for t in range(n_t):
        tx1, tx2 = min(t, x1.shape[0] - 1), min(t, x2.shape[0] - 1)
        tc1, tc2 = min(t, c1.shape[0] - 1), min(t, c2.shape[0] - 1)
        if (check1 and not rule2(rows1[t * m1:(t + 1) * m1])) or (
                check2 and not rule2(rows2_[t * m2:(t + 1) * m2])):
            return 1
        if t == 0 or x2.shape[0] > 1:
            for j in range(n2):
                xs[0, j], xs[1, j] = x2[tx2, j, 0], x2[tx2, j, 1]
        if t == 0 or c2.shape[0] > 1:
            for j in range(m2):
                qs[0, j], qs[1, j], qs[2, j] = c2[tc2, j, 0], c2[tc2, j, 2], c2[tc2, j, 3]
        for i in range(n1):
            a0, a1 = x1[tx1, i, 0], x1[tx1, i, 1]
            p = c1[tc1, min(i, m1 - 1)]
            row = out[t, i]
            if m2 > 1:                              # S per pair
                for j in range(n2):
                    f = _factor2(p[0] + qs[0, j], p[2] + qs[1, j], p[3] + qs[2, j])
                    kappa = _kappa2(f, a0 - xs[0, j], a1 - xs[1, j])
                    row[j] = kappa
                    big |= not kappa < _INF
            else:                                   # one S for the row
                f = _factor2(p[0] + qs[0, 0], p[2] + qs[1, 0], p[3] + qs[2, 0])
                for j in range(n2):
                    kappa = _kappa2(f, a0 - xs[0, j], a1 - xs[1, j])
                    row[j] = kappa
                    big |= not kappa < _INF
    return 2 if big else 0


@_jit
def rows3(x1, x2, c1, c2, out, check1, check2):
    """kappa[t, i, j] for k = 3, the reports of `x2` innermost (see the module)."""
    n_t, n1, n2 = out.shape
    m1, m2 = c1.shape[1], c2.shape[1]
    rows1, rows2_ = c1.reshape((-1, 9)), c2.reshape((-1, 9))
    xs, qs = np.empty((3, n2)), np.empty((6, m2))
    big = False
    for t in range(n_t):
        tx1, tx2 = min(t, x1.shape[0] - 1), min(t, x2.shape[0] - 1)
        tc1, tc2 = min(t, c1.shape[0] - 1), min(t, c2.shape[0] - 1)
        if (check1 and not rule3(rows1[t * m1:(t + 1) * m1])) or (
                check2 and not rule3(rows2_[t * m2:(t + 1) * m2])):
            return 1
        if t == 0 or x2.shape[0] > 1:
            for j in range(n2):
                xs[0, j], xs[1, j], xs[2, j] = x2[tx2, j, 0], x2[tx2, j, 1], x2[tx2, j, 2]
        if t == 0 or c2.shape[0] > 1:
            for j in range(m2):
                q = c2[tc2, j]
                qs[0, j], qs[1, j], qs[2, j] = q[0], q[3], q[4]
                qs[3, j], qs[4, j], qs[5, j] = q[6], q[7], q[8]
        for i in range(n1):
            a0, a1, a2 = x1[tx1, i, 0], x1[tx1, i, 1], x1[tx1, i, 2]
            p = c1[tc1, min(i, m1 - 1)]
            row = out[t, i]
            if m2 > 1:                              # S per pair
                for j in range(n2):
                    f = _factor3(p[0] + qs[0, j], p[3] + qs[1, j], p[4] + qs[2, j],
                                 p[6] + qs[3, j], p[7] + qs[4, j], p[8] + qs[5, j])
                    kappa = _kappa3(f, a0 - xs[0, j], a1 - xs[1, j], a2 - xs[2, j])
                    row[j] = kappa
                    big |= not kappa < _INF
            else:                                   # one S for the row
                f = _factor3(p[0] + qs[0, 0], p[3] + qs[1, 0], p[4] + qs[2, 0],
                             p[6] + qs[3, 0], p[7] + qs[4, 0], p[8] + qs[5, 0])
                for j in range(n2):
                    kappa = _kappa3(f, a0 - xs[0, j], a1 - xs[1, j], a2 - xs[2, j])
                    row[j] = kappa
                    big |= not kappa < _INF
    return 2 if big else 0


# --------------------------------------------------------------------------- trials innermost
@_jit
def trials2(x1, x2, c1, c2, out, check1, check2):
    """kappa[i, j, t] for k = 2, the trials innermost, block by block (see the module)."""
    n1, n2, n_t = out.shape
    m1, m2 = c1.shape[1], c2.shape[1]
    lx1, lx2, lc1, lc2 = x1.shape[0] - 1, x2.shape[0] - 1, c1.shape[0] - 1, c2.shape[0] - 1
    rows1, rows2_ = c1.reshape((-1, 4)), c2.reshape((-1, 4))
    big = False
    for t0 in range(0, n_t, TRIAL_BLOCK):
        t1 = min(t0 + TRIAL_BLOCK, n_t)
        if (check1 and not rule2(rows1[t0 * m1:t1 * m1])) or (
                check2 and not rule2(rows2_[t0 * m2:t1 * m2])):
            return 1
        for i in range(n1):
            ic = min(i, m1 - 1)
            for j in range(n2):
                jc = min(j, m2 - 1)
                dst = out[i, j]
                for t in range(t0, t1):
                    p, q = c1[min(t, lc1), ic], c2[min(t, lc2), jc]
                    a, b = x1[min(t, lx1), i], x2[min(t, lx2), j]
                    f = _factor2(p[0] + q[0], p[2] + q[2], p[3] + q[3])
                    kappa = _kappa2(f, a[0] - b[0], a[1] - b[1])
                    dst[t] = kappa
                    big |= not kappa < _INF
    return 2 if big else 0


@_jit
def trials3(x1, x2, c1, c2, out, check1, check2):
    """kappa[i, j, t] for k = 3, the trials innermost, block by block (see the module)."""
    n1, n2, n_t = out.shape
    m1, m2 = c1.shape[1], c2.shape[1]
    lx1, lx2, lc1, lc2 = x1.shape[0] - 1, x2.shape[0] - 1, c1.shape[0] - 1, c2.shape[0] - 1
    rows1, rows2_ = c1.reshape((-1, 9)), c2.reshape((-1, 9))
    big = False
    for t0 in range(0, n_t, TRIAL_BLOCK):
        t1 = min(t0 + TRIAL_BLOCK, n_t)
        if (check1 and not rule3(rows1[t0 * m1:t1 * m1])) or (
                check2 and not rule3(rows2_[t0 * m2:t1 * m2])):
            return 1
        for i in range(n1):
            ic = min(i, m1 - 1)
            for j in range(n2):
                jc = min(j, m2 - 1)
                dst = out[i, j]
                for t in range(t0, t1):
                    p, q = c1[min(t, lc1), ic], c2[min(t, lc2), jc]
                    a, b = x1[min(t, lx1), i], x2[min(t, lx2), j]
                    f = _factor3(p[0] + q[0], p[3] + q[3], p[4] + q[4],
                                 p[6] + q[6], p[7] + q[7], p[8] + q[8])
                    kappa = _kappa3(f, a[0] - b[0], a[1] - b[1], a[2] - b[2])
                    dst[t] = kappa
                    big |= not kappa < _INF
    return 2 if big else 0
