"""Group costs: the ML cost of a group (fused information) and the paper's pairwise sum."""

from __future__ import annotations

import itertools
import math

import numpy as np

from ..engine.linalg import mahalanobis_sq_pairwise
from ..engine.validation import (
    MEMORY_LIMIT,
    as_bool,
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    check_size,
)

_COSTS = ("ml", "pairwise")


# ----------------------------------------------------------------------------- validation
def _reports_iv(x, cov):
    """Validate reports and covariances; return x (B, m, n, d), cov (Bc, m, n, d, d), batch."""
    if isinstance(x, (list, tuple)) and len(x) > 0 and not np.isscalar(x[0]):
        shapes = [np.shape(xi) for xi in x]
        counts = [s[0] if len(s) else 0 for s in shapes]
        if len({len(s) for s in shapes}) == 1 and len(set(counts)) > 1:
            raise ValueError(
                "`x` must hold the same number n of reports from every source (this model has "
                f"no missed or false reports); received report counts {counts} for "
                f"{len(x)} sources"
            )
    arr = as_float_array(x, "x", ndim_min=3)
    *batch_x, m, n, d = arr.shape
    if m < 2:
        raise ValueError(
            "`x` must have shape (..., m, n, d) with m >= 2 sources to group; "
            f"received shape {arr.shape} (m = {m})"
        )
    if n < 1 or d < 1:
        raise ValueError(f"`x` must have n >= 1 reports of dimension d >= 1; received shape {arr.shape}")
    c = as_float_array(cov, "cov", ndim_min=4)
    if c.shape[-2:] != (d, d):
        raise ValueError(
            f"`cov` must have shape (..., m, n, {d}, {d}) to match `x` (d = {d}); "
            f"received shape {c.shape}"
        )
    try:
        mn = np.broadcast_shapes(c.shape[-4:-2], (m, n))
        batch = np.broadcast_shapes(tuple(batch_x), c.shape[:-4])
    except ValueError:
        mn = None
    if mn != (m, n):
        raise ValueError(
            f"`cov` must have shape (..., {m}, {n}, {d}, {d}) (one covariance per report of `x`, "
            f"broadcastable); received shape {c.shape} for `x` of shape {arr.shape}"
        )
    c = as_covariance(c, "cov", dim=d, domain=False)
    xb = np.broadcast_to(arr, (*batch, m, n, d)).reshape(-1, m, n, d)
    if math.prod(c.shape[:-4]) == 1:
        cb = np.broadcast_to(c.reshape(c.shape[-4:]), (m, n, d, d))[None]
    else:
        cb = np.broadcast_to(c, (*batch, m, n, d, d)).reshape(-1, m, n, d, d)
    return xb, cb, tuple(batch)


def _information(cov):
    """Information matrices and log-determinants of a stack of SPD matrices."""
    chol = np.linalg.cholesky(cov)
    eye = np.broadcast_to(np.eye(cov.shape[-1]), cov.shape)
    info = np.linalg.solve(cov, eye)                 # natural parameter of the fusion
    info = 0.5 * (info + np.swapaxes(info, -1, -2))
    logdet = 2.0 * np.sum(np.log(np.diagonal(chol, axis1=-2, axis2=-1)), axis=-1)
    return info, logdet


def _expand(arr, axis, m_axes):
    """Put the report axis (axis 1 of `arr`, after the batch) at tuple axis `axis`."""
    shape = [arr.shape[0]] + [1] * m_axes + list(arr.shape[2:])
    shape[1 + axis] = arr.shape[1]
    return arr.reshape(shape)


def _group_iv(x, cov):
    """Reports (m arrays (..., d)) and covariances (m arrays (..., d, d)) of groups."""
    if isinstance(x, np.ndarray) or not isinstance(x, (list, tuple)):
        x = list(as_float_array(x, "x", ndim_min=2))
    if isinstance(cov, np.ndarray) or not isinstance(cov, (list, tuple)):
        cov = list(as_float_array(cov, "cov", ndim_min=3))
    xs = [as_float_array(a, "x", ndim_min=1) for a in x]
    if len(xs) < 2 or len({a.shape[-1] for a in xs}) != 1:
        raise ValueError("`x` must hold m >= 2 reports of one dimension d (arrays (..., d)); "
                         f"received shapes {[a.shape for a in xs]}")
    d = xs[0].shape[-1]
    if len(cov) != len(xs):
        raise ValueError(f"`cov` must hold one covariance per report of `x` (m = {len(xs)}); "
                         f"received {len(cov)}")
    covs = [as_covariance(c, "cov", dim=d, domain=False) for c in cov]
    try:
        np.broadcast_shapes(*(a.shape[:-1] for a in xs), *(c.shape[:-2] for c in covs))
    except ValueError:
        raise ValueError("`x` and `cov` must have broadcastable leading (group) axes; received "
                         f"shapes {[a.shape for a in xs]} and {[c.shape for c in covs]}") from None
    return xs, covs


def _quad(r, info):
    """r^T I r over the last axes."""
    return np.einsum("...k,...kl,...l->...", r, info, r)


def ml_group_cost(x, cov):
    r"""ML cost of groups of one report per source.

    Eq. (eq-group-cost) of the chapter. `x` holds the ``m`` reports
    :math:`a_i` of a group (``m`` arrays of shape ``(..., d)``, or one
    array ``(m, ..., d)``), `cov` their covariances :math:`C_i`
    (``(..., d, d)`` each); leading axes broadcast, one cost each:

    .. math::

        \sum_i (a_i-\hat x)^T C_i^{-1}(a_i-\hat x) + \ln\det W
        + \sum_i \ln\det C_i

    with :math:`W = \sum_i C_i^{-1}`,
    :math:`\hat x = W^{-1}\sum_i C_i^{-1}a_i` (see :func:`group_costs`,
    which evaluates it for every candidate group).

    >>> c = ml_group_cost([[0.0], [2.0]], [[[1.0]], [[1.0]]])   # 2 + ln 2
    >>> float(c.round(4))
    2.6931
    """
    xs, covs = _group_iv(x, cov)
    # C_i^-1, ln det C_i
    info, logdet = zip(*(_information(c) for c in covs), strict=True)
    W = info[0] + sum(info[1:])                       # W = sum_i C_i^-1
    ia = [np.einsum("...kl,...l->...k", Ci, a)
          for Ci, a in zip(info, xs, strict=True)]
    # the fused estimate
    xhat = np.linalg.solve(W, (ia[0] + sum(ia[1:]))[..., None])[..., 0]
    q = sum(_quad(a - xhat, Ci) for a, Ci in zip(xs, info, strict=True))
    ld_w = 2.0 * np.sum(np.log(np.diagonal(np.linalg.cholesky(W),
                                           axis1=-2, axis2=-1)), -1)
    return _finite_costs(q + ld_w + logdet[0] + sum(logdet[1:]))


def _ml_tensor(x, cov):
    """ML group costs, (B, n, ..., n) over m axes (see group_costs).

    Source 0's report is fixed in an outer loop; the other sources' reports are
    spread over the remaining m - 1 tuple axes (broadcast views, no copies).
    """
    B, m, n, d = x.shape
    x = x - x.mean(axis=(1, 2), keepdims=True)       # costs are translation invariant
    out = np.empty((B,) + (n,) * m)
    k = m - 1
    pad = (1,) * k
    x_rest = [_expand(x[:, i], i - 1, k) for i in range(1, m)]
    c_rest = [_expand(cov[:, i], i - 1, k) for i in range(1, m)]
    for j0 in range(n):
        x0 = x[:, 0, j0].reshape(B, *pad, d)
        c0 = cov[:, 0, j0].reshape(cov.shape[0], *pad, d, d)
        out[:, j0] = ml_group_cost([x0, *x_rest], [c0, *c_rest])
    return out


def _pairwise_tensor(x, cov):
    """Sum of pairwise quadratic forms, (B, n, ..., n) over m axes."""
    B, m, n, _ = x.shape
    out = np.zeros((B,) + (n,) * m)
    for i, k in itertools.combinations(range(m), 2):
        q = mahalanobis_sq_pairwise(x[:, i], x[:, k], cov[:, i], cov[:, k])   # (B, n, n)
        shape = [B] + [1] * m
        shape[1 + i] = n
        shape[1 + k] = n
        out = out + q.reshape(shape)
    return out


def _rescale(x, cov, *extra):
    """Centre and rescale reports and covariances so that no step overflows.

    The group costs are quadratic forms, invariant under ``x -> (x - c) / s``
    and ``cov -> cov / s**2``; only the ML log-determinants shift, by
    ``d * log(s**2)`` per covariance, which the caller adds back. ``c`` is the
    mid-range of every coordinate (``|x - c|`` never overflows) and ``s**2`` a
    power of two near the largest variance (exact scaling). `extra` holds
    further (points, covariances) pairs (the fused tracks) treated alike.
    Returns the scaled arrays and ``log(s**2)``.
    """
    pts = [x.reshape(x.shape[0], -1, x.shape[-1])] + [e.reshape(e.shape[0], -1, e.shape[-1])
                                                       for e in extra[0::2]]
    lo = np.min([p.min(axis=1) for p in pts], axis=0)            # (B, d), per scene
    hi = np.max([p.max(axis=1) for p in pts], axis=0)
    centre = lo / 2 + hi / 2

    def shift(a):
        return a - centre.reshape((a.shape[0],) + (1,) * (a.ndim - 2) + (a.shape[-1],))

    covs = [cov, *extra[1::2]]
    top = max(float(np.max(np.diagonal(c, axis1=-2, axis2=-1))) for c in covs)
    k = 2 * int(np.round(np.log2(top) / 2))                       # even: s exact too
    s, s2 = np.ldexp(1.0, k // 2), np.ldexp(1.0, k)
    out = [shift(x) / s, cov / s2]
    for i in range(0, len(extra), 2):
        out += [shift(extra[i]) / s, extra[i + 1] / s2]
    return out, k * np.log(2.0)


def _finite_costs(tensor):
    """Refuse costs that overflowed: no grouping decision can rest on them."""
    if not np.all(np.isfinite(tensor)):
        bad = int(np.count_nonzero(~np.isfinite(tensor)))
        raise ValueError(
            f"`x` and `cov`: {bad} candidate group costs exceed the floating-point range "
            "(reports some 1e154 standard deviations apart); such groups cannot be scored "
            "-- split the scene or gate the candidate groups first"
        )
    return tensor


def _cost_bytes(B, m, n, d):
    """Working memory of one cost tensor (output plus the per-row fused information)."""
    return 8 * B * n ** (m - 1) * (3 * n + 8 * d * d + 4 * d)


def _tensor(x, cov, cost):
    B, m, n, d = x.shape
    check_size(_cost_bytes(B, m, n, d), MEMORY_LIMIT,
               what=f"bytes of group costs (`x`: {B} scene(s) x n**m = {n}**{m} candidate groups)",
               alternative="fewer scenes per call, or group_sd scene by scene")
    (xs, cs), log_s2 = _rescale(x, cov)
    if cost == "pairwise":
        return _finite_costs(_pairwise_tensor(xs, cs))
    return _finite_costs(_ml_tensor(xs, cs) + (m - 1) * d * log_s2)


# ----------------------------------------------------------------------------- counting
def n_groupings(n_targets: int, n_sources: int, *, binding: bool = False) -> int:
    r"""Number of ways to group the reports of `n_sources` sources about `n_targets` targets.

    Parameters
    ----------
    n_targets : int
        Number of targets ``n`` (each source reports each target once), ``n >= 1``.
    n_sources : int
        Number of sources ``m`` (``>= 2``; ``>= 1`` with binding).
    binding : bool, optional
        Also bind each group to one of ``n`` existing fused tracks.

    Returns
    -------
    int
        :math:`(n!)^{m-1}` without binding, :math:`(n!)^m` with binding (exact integer).

    Raises
    ------
    ValueError
        If `n_targets` < 1 or `n_sources` is below its minimum, or if the count
        has more than a million decimal digits.
    TypeError
        If a count is not an integer or `binding` not a boolean.

    Notes
    -----
    Fix the order of source 1's reports; a grouping is then the choice, for each
    of the other :math:`m-1` sources, of a permutation of its :math:`n` reports:

    .. math::

        k = (n!)^{m-1}.

    With binding, source 1's order relative to the tracks is free as well, so
    :math:`k = (n!)^m`. The paper prints :math:`k = (m-1)!\,n!` (eq. 24), which
    agrees only for :math:`m = 2` and for :math:`(m, n) = (3, 2)`.

    References
    ----------
    Sonar paper (2013), eq. (24) and Fig. 3.

    Examples
    --------
    >>> n_groupings(3, 2)
    6
    >>> n_groupings(3, 3), n_groupings(2, 2, binding=True)
    (36, 4)
    """
    binding = as_bool(binding, "binding")
    n = as_int(n_targets, "n_targets", minimum=1)
    m = as_int(n_sources, "n_sources", minimum=1 if binding else 2)
    power = m - 1 + int(binding)
    digits = math.ceil(power * math.lgamma(n + 1) / math.log(10))
    check_size(digits, 10**6, what=f"decimal digits of the count (`n_targets` = {n})",
               alternative=f"its logarithm, {power} * math.lgamma(n_targets + 1)")
    return math.factorial(n) ** power


# ----------------------------------------------------------------------------- costs
def group_costs(x, cov, *, cost: str = "ml") -> np.ndarray:
    r"""Cost of every candidate group (one report from each source).

    Parameters
    ----------
    x : array_like, shape (..., m, n, d)
        ``x[..., i, j]`` is report ``j`` of source ``i`` (``m >= 2``). A list of
        ``m`` arrays of shape ``(n, d)`` is accepted.
    cov : array_like, shape (..., m, n, d, d)
        Error covariance of each report (broadcastable, e.g. ``(m, 1, d, d)``
        for one covariance per source); symmetric positive definite.
    cost : {"ml", "pairwise"}, optional
        ``"ml"`` (default): minus twice the log marginal likelihood that the
        group's reports come from one target, with the constant
        :math:`(m-1)d\ln 2\pi` dropped: every grouping has the same :math:`n`
        groups of :math:`m` reports, so the constant is the same for every
        grouping and cannot change a decision (the package's rule: a constant
        of the full :math:`-2\ln f` is dropped only where every hypothesis
        holds the same number of groups; :func:`group_sd` with the dummy
        index, where group sizes differ, adds :math:`(|S|-1)d\ln 2\pi` back,
        as ``association.proximity_matrix(..., logdet=True)`` and
        ``separated.pair_statistic(..., logdet=True)`` include it for a pair).
        ``"pairwise"``: the paper's sum of the pairwise quadratic forms.

    Returns
    -------
    numpy.ndarray, shape (..., n, ..., n)
        ``out[..., j_1, ..., j_m]``: cost of the group made of report ``j_i`` of
        each source ``i`` (``m`` report axes).

    Raises
    ------
    ValueError
        If ``m < 2``, if the sources report different numbers of targets, if
        the shapes of `x` and `cov` disagree, or if a covariance is singular.

    Notes
    -----
    With a flat prior on the target state :math:`x`, the reports
    :math:`a_i \sim \mathcal N(x, C_i)` of one group have the marginal
    likelihood :math:`\int\prod_i \mathcal N(a_i; x, C_i)\,dx`. With
    :math:`W = \sum_i C_i^{-1}` and the fused estimate
    :math:`\hat x = W^{-1}\sum_i C_i^{-1}a_i`,

    .. math::

        c_{\mathrm{ML}} = \sum_i (a_i-\hat x)^T C_i^{-1}(a_i-\hat x)
        + \ln\det W + \sum_i \ln\det C_i ,

    which for :math:`m = 2` is :math:`\Delta^T(C_1+C_2)^{-1}\Delta + \ln\det(C_1+C_2)`.
    The paper's cost is

    .. math::

        c_{\mathrm{pw}} = \sum_{i<k} (a_i-a_k)^T (C_i+C_k)^{-1} (a_i-a_k).

    Both agree (up to the factor :math:`m/2` and a constant) when all reports
    share one covariance. Coordinates are centred before fusing, so large
    absolute positions lose no precision.

    References
    ----------
    Sonar paper (2013), eqs. (15)–(17), (25)–(26).

    Examples
    --------
    >>> x = np.array([[[0.0], [5.0]], [[0.1], [5.3]]])   # m=2 sources, n=2, d=1
    >>> c = np.ones((2, 2, 1, 1))
    >>> group_costs(x, c, cost="pairwise").round(3).tolist()
    [[0.005, 14.045], [12.005, 0.045]]
    """
    cost = as_choice(cost, "cost", _COSTS)
    xb, cb, batch = _reports_iv(x, cov)
    n, m = xb.shape[2], xb.shape[1]
    return _tensor(xb, cb, cost).reshape(*batch, *(n,) * m)


