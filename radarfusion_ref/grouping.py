"""Grouping the reports of m sources about n targets (the sonar paper).

Each of ``m`` sources (hydroacoustic stations, radars) reports every one of
``n`` targets once, already in one frame and at one time; the report order
says nothing about which target produced it. A *grouping* puts the ``m * n``
reports into ``n`` groups holding one report of each source. This module

* counts the groupings (:func:`n_groupings`), with and without *binding* the
  groups to ``n`` existing fused tracks;
* scores a candidate group by the exact maximum-likelihood cost or by the
  paper's sum of pairwise quadratic forms (:func:`group_costs`);
* finds the best grouping by brute-force enumeration (:func:`group_bruteforce`)
  or exactly as an S-D (multidimensional) assignment integer program solved
  by HiGHS (:func:`group_sd`);
* scores the ``(n!)**m`` binding hypotheses — the paper's hypotheses I–IV for
  two sources and two tracks — by the paper's product of independent
  densities or by the exact likelihood (:func:`binding_costs`);
* simulates scenes (:func:`grouping_scene`, from :mod:`radarfusion_ref.engine.scenes`).

Arrays follow one convention: ``x[..., i, j, :]`` is report ``j`` of source
``i`` (shape ``(..., m, n, d)``) and ``cov[..., i, j, :, :]`` its error
covariance (shape ``(..., m, n, d, d)``, broadcastable). A grouping is an
integer array ``groups`` of shape ``(n, m)``: row ``k`` lists, for every
source ``i``, the index ``groups[k, i]`` of its report in group ``k``. Rows
are sorted so that ``groups[:, 0] == arange(n)``, which makes a grouping's
array unique.

.. rubric:: References

.. [1] "Optimal association of information from hydroacoustic stations",
   National Security and Strategic Planning, no. 3 (2013), eqs. (4)–(26)
   (in Russian).
.. [2] S. Deb, M. Yeddanapudi, K. Pattipati, Y. Bar-Shalom, "A generalized
   S-D assignment algorithm for multisensor-multitarget state estimation",
   IEEE Trans. AES 33(2) (1997) 523–538.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from .engine import scenes
from .engine._validation import (
    MEMORY_LIMIT,
    _describe,
    as_bool,
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    check_size,
)
from .engine.assignment._lagrangian import _solve_candidates
from .engine.assignment._milp import _sd_solve
from .engine.assignment._results import _gap_of
from .engine.assignment._sd import _sd_enumerate
from .engine.linalg import mahalanobis_sq_pairwise
from .engine.scenes import GroupingScene, binding_hypotheses
from .gating import gate_threshold

__all__ = [
    "PAPER_HYPOTHESES",
    "GroupingResult",
    "MAX_CANDIDATE_GROUPS",
    "MAX_GROUPINGS",
    "binding_costs",
    "group_bruteforce",
    "group_costs",
    "group_sd",
    "grouping_scene",
    "ml_group_cost",
    "n_groupings",
]

_COSTS = ("ml", "pairwise")

#: Largest number of groupings :math:`(n!)^{m-1}` that :func:`group_bruteforce`
#: enumerates, whatever its `max_groupings` (about a minute of work); beyond it,
#: use :func:`group_sd`.
MAX_GROUPINGS = 10**8

#: Largest number of candidate groups :math:`n^m` (binary variables) of one
#: scene that :func:`group_sd` hands to HiGHS (e.g. ``n = 100`` targets of
#: ``m = 3`` sources, or ``n = 31`` of ``m = 4``).
MAX_CANDIDATE_GROUPS = 10**6

#: The paper's four hypotheses for two sources and two fused tracks, as
#: ``hyp[i, p]`` = index of the report of source ``i`` bound to track ``p``
#: (0-based; the paper's :math:`J_{ij}` is report ``j`` of source ``i``).
PAPER_HYPOTHESES = {
    "I": np.array([[0, 1], [0, 1]]),    # J11, J21 -> track 1; J12, J22 -> track 2
    "II": np.array([[1, 0], [1, 0]]),   # J12, J22 -> track 1; J11, J21 -> track 2
    "III": np.array([[1, 0], [0, 1]]),  # J21, J12 -> track 1; J11, J22 -> track 2
    "IV": np.array([[0, 1], [1, 0]]),   # J11, J22 -> track 1; J21, J12 -> track 2
}
for _h in PAPER_HYPOTHESES.values():
    _h.setflags(write=False)


# ----------------------------------------------------------------------------- results
@dataclass(frozen=True)
class GroupingResult:
    r"""The best grouping of one scene (or of a batch of scenes).

    Attributes
    ----------
    groups : numpy.ndarray of int, shape (..., n, m)
        ``groups[..., k, i]`` is the index of source ``i``'s report in group
        ``k``; rows are sorted so that ``groups[..., :, 0] == arange(n)``.
    cost : float or numpy.ndarray, shape (...)
        Total cost of the grouping: the sum of its groups' costs
        (see :func:`group_costs`).
    cost_kind : str
        ``"ml"`` or ``"pairwise"``.
    method : str
        ``"bruteforce"`` (enumeration of all groupings), ``"milp"`` (the
        integer program of :func:`group_sd`) or ``"lagrangian"`` (its
        Lagrangian relaxation).
    relaxation_integral : bool or numpy.ndarray of bool or None
        For ``"milp"`` on the full tensor: whether the integer program's LP
        relaxation already had an integral optimum (so no branching was
        needed). ``None`` otherwise.
    lower_bound : float or numpy.ndarray
        A proved lower bound on the optimal total cost: the cost itself for the
        exact methods, the best Lagrangian dual value for ``"lagrangian"``.
    gap : float or numpy.ndarray
        Proved relative duality gap
        :math:`(\text{cost} - \text{lower bound}) / \max(|\text{cost}|, 1)`
        (0 for the exact methods).
    history : numpy.ndarray or None, shape (iterations, 2)
        For ``"lagrangian"`` on one scene: the best lower bound and the best
        cost after each iteration (summed over the independent clusters).
        ``None`` otherwise.
    exact : bool
        True when the proved gap is 0 (for every scene of a batch). With
        `cost`, `lower_bound`, `gap` and `history`, the
        :class:`radarfusion_ref.engine.assignment.AssignmentResult` vocabulary
        shared with the 2-D results.

    With missed detections and false reports (:func:`group_sd` with
    `p_detect`), `groups` has one row per group, ``-1`` marking a source
    without a report in that group, and the number of rows varies.
    """

    groups: np.ndarray
    cost: np.ndarray | float
    cost_kind: str
    method: str
    relaxation_integral: np.ndarray | bool | None = None
    lower_bound: np.ndarray | float | None = None
    gap: np.ndarray | float = 0.0
    history: np.ndarray | None = None
    exact: bool = True

    def __post_init__(self):
        if self.lower_bound is None:            # exact methods: the cost is its own bound
            object.__setattr__(self, "lower_bound", self.cost)


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
    c = as_covariance(c, "cov", dim=d)
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
    covs = [as_covariance(c, "cov", dim=d) for c in cov]
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
    r"""ML cost of groups of one report per source, eq. (eq-group-cost) of the chapter.

    `x` holds the ``m`` reports :math:`a_i` of a group (``m`` arrays of shape
    ``(..., d)``, or one array ``(m, ..., d)``), `cov` their covariances
    :math:`C_i` (``(..., d, d)`` each); leading axes broadcast, one cost each:
    :math:`\sum_i (a_i-\hat x)^T C_i^{-1}(a_i-\hat x) + \ln\det W + \sum_i \ln\det C_i`
    with :math:`W = \sum_i C_i^{-1}`, :math:`\hat x = W^{-1}\sum_i C_i^{-1}a_i`
    (see :func:`group_costs`, which evaluates it for every candidate group).

    >>> float(ml_group_cost([[0.0], [2.0]], [[[1.0]], [[1.0]]]).round(4))   # 2 + ln 2
    2.6931
    """
    xs, covs = _group_iv(x, cov)
    info, logdet = zip(*(_information(c) for c in covs), strict=True)  # C_i^-1, ln det C_i
    W = info[0] + sum(info[1:])                                      # W = sum_i C_i^-1
    ia = [np.einsum("...kl,...l->...k", Ci, a) for Ci, a in zip(info, xs, strict=True)]
    xhat = np.linalg.solve(W, (ia[0] + sum(ia[1:]))[..., None])[..., 0]   # the fused estimate
    q = sum(_quad(a - xhat, Ci) for a, Ci in zip(xs, info, strict=True))
    ld_w = 2.0 * np.sum(np.log(np.diagonal(np.linalg.cholesky(W), axis1=-2, axis2=-1)), -1)
    return q + ld_w + logdet[0] + sum(logdet[1:])


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


# ----------------------------------------------------------------------------- solvers (assignment)
def _normalise(tuples):
    """Sort the rows of (..., n, m) tuples by source 0."""
    order = np.argsort(tuples[..., 0], axis=-1)
    return np.take_along_axis(tuples, order[..., None], axis=-2)


def group_bruteforce(x, cov, *, cost: str = "ml", max_groupings: int = 10**7) -> GroupingResult:
    r"""Best grouping by enumerating all :math:`(n!)^{m-1}` groupings.

    Parameters
    ----------
    x : array_like, shape (..., m, n, d)
        Reports (see :func:`group_costs`); leading axes are independent scenes.
    cov : array_like, shape (..., m, n, d, d)
        Their covariances (broadcastable).
    cost : {"ml", "pairwise"}, optional
        Group cost (see :func:`group_costs`).
    max_groupings : int, optional
        Refuse problems with more groupings than this (default :math:`10^7`);
        whatever its value, more than :data:`MAX_GROUPINGS` (:math:`10^8`) are
        refused.

    Returns
    -------
    GroupingResult
        ``groups`` of shape ``(..., n, m)`` and the minimal total ``cost``;
        ties go to the first grouping in enumeration order.

    Raises
    ------
    ValueError
        For bad input (see :func:`group_costs`), more than `max_groupings` or
        :data:`MAX_GROUPINGS` groupings (use :func:`group_sd`), or totals that
        overflow.

    Notes
    -----
    The rule of the paper, eq. (26): the grouping :math:`g` minimising
    :math:`\sum_{k=1}^n c(g_k)`. Enumeration is vectorised over scenes and
    chunked over groupings.

    References
    ----------
    Sonar paper (2013), eqs. (7), (17), (24)–(26).

    Examples
    --------
    >>> x = np.array([[[0.0], [5.0]], [[5.3], [0.1]]])
    >>> r = group_bruteforce(x, np.ones((2, 2, 1, 1)))
    >>> r.groups.tolist()
    [[0, 1], [1, 0]]
    """
    cost = as_choice(cost, "cost", _COSTS)
    xb, cb, batch = _reports_iv(x, cov)
    B, m, n, _ = xb.shape
    G = n_groupings(n, m)
    limit = as_int(max_groupings, "max_groupings", minimum=1)
    if limit < G:
        raise ValueError(
            f"`max_groupings` = {limit} is below the {G} groupings of m = {m} sources and "
            f"n = {n} targets; raise it or use group_sd"
        )
    check_size(G, MAX_GROUPINGS, what=f"groupings (n!)**(m-1) (`x` with n = {n}, m = {m})",
               alternative="group_sd (the exact S-D assignment integer program)")
    tensor = _tensor(xb, cb, cost).reshape(B, -1)
    best, groups = _sd_enumerate(tensor, m, n)                 # assignment's enumeration
    if not np.all(np.isfinite(best)):
        raise ValueError(
            "`x` and `cov`: the total cost of every grouping overflows the floating-point "
            "range; split the scene or gate the candidate groups first"
        )
    groups = groups.reshape(*batch, n, m)
    cost_out = best.reshape(batch)
    return GroupingResult(groups, float(cost_out) if not batch else cost_out, cost, "bruteforce")


# ----------------------------------------------------------------------------- gated S-D
def _detection_iv(m, p_detect, false_density, object_density):
    """Validate the detection model; ``None`` when no argument is given."""
    given = [a is not None for a in (p_detect, false_density, object_density)]
    if not any(given):
        return None
    if not all(given):
        missing = [n for n, g in zip(("p_detect", "false_density", "object_density"), given,
                                     strict=True) if not g]
        raise ValueError(
            "`p_detect`, `false_density` and `object_density` define the dummy index together; "
            f"received no {', '.join(f'`{n}`' for n in missing)}"
        )
    out = {}
    for name, value, lo_ok, hi in (("p_detect", p_detect, False, 1.0),
                                   ("false_density", false_density, True, None),
                                   ("object_density", object_density, False, None)):
        a = as_float_array(value, name)
        if name == "object_density":
            if a.ndim != 0:
                raise ValueError(f"`object_density` must be a number; received shape {a.shape}")
        else:
            try:
                a = np.broadcast_to(a, (m,)).astype(float)
            except ValueError:
                raise ValueError(
                    f"`{name}` must be a number or have shape ({m},) (one per source); "
                    f"received shape {a.shape}"
                ) from None
        bad = (a < 0 if lo_ok else a <= 0) | ((a > hi) if hi is not None else False)
        if np.any(bad):
            rng_txt = "(0, 1]" if hi is not None else ("[0, inf)" if lo_ok else "(0, inf)")
            raise ValueError(f"`{name}` must lie in {rng_txt}; received {value!r}")
        out[name] = a
    return out


def _ragged_iv(x, cov):
    """Reports of a single scene with possibly unequal counts: lists of (n_i, d), (n_i, d, d)."""
    if isinstance(x, (list, tuple)):
        xs = [as_float_array(xi, "x", ndim_min=2) for xi in x]
    else:
        arr = as_float_array(x, "x", ndim_min=3)
        if arr.ndim != 3:
            raise ValueError(
                "`x` must be one scene, shape (m, n, d) or a list of m arrays (n_i, d), when "
                f"`p_detect` is given (the number of groups varies); received shape {arr.shape}"
            )
        xs = list(arr)
    m = len(xs)
    if m < 2 or any(xi.ndim != 2 for xi in xs):
        raise ValueError(
            "`x` must hold m >= 2 sources, each an array of shape (n_i, d); received "
            f"shapes {[xi.shape for xi in xs]}"
        )
    d = xs[0].shape[1]
    if d < 1 or any(xi.shape[1] != d for xi in xs) or any(xi.shape[0] < 1 for xi in xs):
        raise ValueError(
            "`x`: every source must report n_i >= 1 reports of one dimension d >= 1; received "
            f"shapes {[xi.shape for xi in xs]}"
        )
    cl = list(cov) if isinstance(cov, (list, tuple)) else None
    if cl is None:
        c = as_float_array(cov, "cov", ndim_min=2)
        if c.ndim >= 4:
            if c.shape[-4] not in (1, m):
                raise ValueError(
                    f"`cov` must have shape (m, n_i, {d}, {d}) with m = {m} (broadcastable); "
                    f"received shape {c.shape}"
                )
            cl = [c[..., min(i, c.shape[-4] - 1), :, :, :] for i in range(m)]
        else:
            cl = [c] * m
    if len(cl) != m:
        raise ValueError(f"`cov` must hold one entry per source (m = {m}); received {len(cl)}")
    cs = []
    for i, (xi, ci) in enumerate(zip(xs, cl, strict=True)):
        ci = as_float_array(ci, "cov", ndim_min=2)
        if ci.ndim == 2:
            ci = ci[None]
        if ci.ndim != 3 or ci.shape[-2:] != (d, d) or ci.shape[0] not in (1, xi.shape[0]):
            raise ValueError(
                f"`cov` of source {i} must have shape ({xi.shape[0]}, {d}, {d}) or ({d}, {d}); "
                f"received shape {ci.shape}"
            )
        cs.append(as_covariance(np.broadcast_to(ci, (xi.shape[0], d, d)), "cov", dim=d))
    return xs, cs


def _pair_statistics(xa, ca, xb, cb):
    """``kappa[a, b]``: the fused-difference statistic of report a and report b."""
    check_size(8 * 6 * xa.shape[0] * xb.shape[0] * (xa.shape[1] + 1) ** 2, MEMORY_LIMIT,
               what=f"bytes of pair statistics ({xa.shape[0]} x {xb.shape[0]} report pairs)",
               alternative="splitting the scene into regions")
    return mahalanobis_sq_pairwise(xa, xb, ca, cb)


def _gated_tuples(gates, counts, dummy):
    """Tuples (K, m) whose report pairs all pass the gate (``-1``: no report of that source)."""
    m = len(counts)
    T = np.arange(counts[0], dtype=np.int64)[:, None]
    if dummy:
        T = np.vstack([T, [[-1]]])
    for k in range(1, m):
        check_size(T.shape[0] * counts[k], MEMORY_LIMIT,
                   what=f"bytes of the gate mask ({T.shape[0]} partial groups x "
                        f"{counts[k]} reports of source {k})",
                   alternative="a narrower gate (smaller `p_false_reject`)")
        mask = np.ones((T.shape[0], counts[k]), dtype=bool)
        for i in range(k):
            col = T[:, i]
            ok = col >= 0
            mask[ok] &= gates[i, k][col[ok]]
        r, j = np.nonzero(mask)
        parts = [np.hstack([T[r], j[:, None]])]
        if dummy:
            parts.append(np.hstack([T, np.full((T.shape[0], 1), -1)]))
        T = np.vstack(parts)
        check_size(8 * T.shape[0] * (m + 1), MEMORY_LIMIT,
                   what=f"bytes of gated candidate groups ({T.shape[0]} after source {k})",
                   alternative="a narrower gate (smaller `p_false_reject`)")
    if dummy:
        T = T[np.any(T >= 0, axis=1)]
    return T


def _tuple_ml_costs(xs, cs, T, log_s2, median_logdet=False):
    """ML cost of every candidate group (rows of T, -1 = absent), as in group_costs.

    ``median_logdet=True``: the log-determinant part, ln|W| + sum_i ln|C_i|, is replaced by its
    median over the candidate groups of the same size (the cost without the term, kept on
    the same scale so that groups still compete fairly with lone reports).
    """
    K, m = T.shape
    d = xs[0].shape[1]
    check_size(8 * K * (3 * d * d + 3 * d + 4), MEMORY_LIMIT,
               what=f"bytes of group costs ({K} gated candidate groups)",
               alternative="a narrower gate (smaller `p_false_reject`)")
    infos, lds = zip(*(_information(c) for c in cs), strict=True)
    W = np.zeros((K, d, d))
    b = np.zeros((K, d))
    ld = np.zeros(K)
    cnt = np.zeros(K, dtype=np.int64)
    for i in range(m):
        p = T[:, i] >= 0
        j = T[p, i]
        W[p] += infos[i][j]
        b[p] += np.einsum("kab,kb->ka", infos[i][j], xs[i][j])
        ld[p] += lds[i][j]
        cnt[p] += 1
    xhat = np.linalg.solve(W, b[..., None])[..., 0]
    q = np.zeros(K)
    for i in range(m):
        p = T[:, i] >= 0
        j = T[p, i]
        r = xs[i][j] - xhat[p]
        q[p] += np.einsum("ka,kab,kb->k", r, infos[i][j], r)
    chol = np.linalg.cholesky(W)
    ld_w = 2.0 * np.sum(np.log(np.diagonal(chol, axis1=-2, axis2=-1)), axis=-1)
    ld_all = ld_w + ld
    if median_logdet:
        for k in np.unique(cnt[cnt >= 2]):
            ld_all[cnt == k] = np.median(ld_all[cnt == k])
    out = q + ld_all + (cnt - 1) * d * log_s2
    out[cnt == 1] = 0.0
    return out, cnt


def _scene_candidates(xs, cs, *, cost, gamma, det, median_logdet=False):
    """Candidate groups of one scene (tuples, costs), gated and with the dummy index.

    `xs`, `cs`: per-source reports (n_i, d) and covariances (n_i, d, d);
    `gamma`: gate threshold on the pair statistic (None: no gate); `det`: the
    detection model (None: every source reports every target once).
    """
    m, d = len(xs), xs[0].shape[1]
    counts = [xi.shape[0] for xi in xs]
    dummy = det is not None
    (xcat, ccat), log_s2 = _rescale(np.concatenate(xs)[None], np.concatenate(cs)[None])
    split = np.cumsum(counts)[:-1]
    xs_s, cs_s = np.split(xcat[0], split), np.split(ccat[0], split)
    kappa = {}
    if gamma is not None or cost == "pairwise":
        for i, k in itertools.combinations(range(m), 2):
            kappa[i, k] = _pair_statistics(xs_s[i], cs_s[i], xs_s[k], cs_s[k])
    if gamma is None:
        total = math.prod(n + 1 if dummy else n for n in counts) - int(dummy)
        check_size(total, MAX_CANDIDATE_GROUPS,
                   what=f"candidate groups of one scene (report counts {counts})",
                   alternative="a gate on the candidate groups (`p_false_reject`)")
        gates = {(i, k): np.ones((counts[i], counts[k]), dtype=bool)
                 for i, k in itertools.combinations(range(m), 2)}
    else:
        with np.errstate(invalid="ignore"):
            gates = {key: v <= gamma for key, v in kappa.items()}
    T = _gated_tuples(gates, counts, dummy)
    if cost == "pairwise":
        c = np.zeros(T.shape[0])
        for (i, k), v in kappa.items():
            c += v[T[:, i], T[:, k]]
        cnt = np.full(T.shape[0], m)
    else:
        c, cnt = _tuple_ml_costs(xs_s, cs_s, T, log_s2, median_logdet)
    if dummy:
        c, keep = _detection_costs(c, cnt, T, det, d)
        T, c = T[keep], c[keep]
    if not np.all(np.isfinite(c)):
        _finite_costs(c)
    return T, c


def _detection_costs(c_ml, cnt, T, det, d):
    """-2 ln of the likelihood of each candidate group under the detection model.

    A group of the sources S (|S| >= 2) from one target: rho_T prod_S P_D prod_not-S (1 - P_D)
    times the marginal likelihood of its reports; a lone report of source i:
    u_i = rho_F,i + rho_T P_D,i prod_{k != i} (1 - P_D,k). Groups dearer than their
    members left alone can never be chosen (the lone reports are a cheaper cover) and
    are dropped, as are impossible ones (cost +inf).
    """
    pd, rf, rt = det["p_detect"], det["false_density"], det["object_density"]
    m = T.shape[1]
    with np.errstate(divide="ignore"):
        lpd, l1m, lrf, lrt = np.log(pd), np.log1p(-pd), np.log(rf), np.log(rt)
    miss_others = np.array([np.sum(np.delete(l1m, i)) for i in range(m)])
    with np.errstate(invalid="ignore"):
        lu = np.logaddexp(lrf, lrt + lpd + miss_others)             # ln u_i
    present = T >= 0
    lone = -2.0 * lu                                                  # cost of a lone report
    with np.errstate(invalid="ignore"):
        group = (c_ml + (cnt - 1) * d * math.log(2 * math.pi) - 2.0 * lrt
                 - 2.0 * np.where(present, lpd, 0.0).sum(axis=1)
                 - 2.0 * np.where(present, 0.0, l1m).sum(axis=1))
    src = np.argmax(present, axis=1)
    cost = np.where(cnt == 1, lone[src], group)
    keep = np.isfinite(cost) & (cost < np.inf)
    if np.all(np.isfinite(lone)):
        alone = np.where(present, lone, 0.0).sum(axis=1)
        keep &= (cnt == 1) | (cost < alone)
    return cost, keep


def _groups_from_tuples(T):
    """Rows sorted by source 0, then 1, ... (a missing report, -1, sorts last)."""
    key = np.where(T >= 0, T, np.iinfo(np.int64).max)
    return T[np.lexsort(key.T[::-1])]


def group_sd(x, cov, *, cost: str = "ml", relaxation: bool = True,
             time_limit: float | None = None, method: str = "milp", gap: float = 0.01,
             max_iter: int = 100, p_false_reject: float | None = None, p_detect=None,
             false_density=None, object_density=None,
             median_logdet: bool = False) -> GroupingResult:
    r"""Best grouping as an S-D assignment: exactly (HiGHS) or to a proved gap (Lagrangian).

    Parameters
    ----------
    x : array_like, shape (..., m, n, d)
        Reports (see :func:`group_costs`); leading axes are solved one scene at a time.
        With `p_detect`, one scene: shape ``(m, n, d)`` or a list of ``m`` arrays
        of shape ``(n_i, d)`` (unequal report counts).
    cov : array_like, shape (..., m, n, d, d)
        Their covariances (broadcastable; with `p_detect` and a list `x`, a
        list of ``(n_i, d, d)`` or ``(d, d)`` arrays).
    cost : {"ml", "pairwise"}, optional
        Group cost (see :func:`group_costs`); ``"ml"`` with `p_detect`.
    relaxation : bool, optional
        ``method="milp"`` on the full tensor: solve the LP relaxation first
        (default) and accept its solution when it is integral — it is then
        optimal for the integer program too; otherwise (or with
        ``relaxation=False``) run HiGHS branch and bound
        (:func:`scipy.optimize.milp`) with a zero optimality gap.
    time_limit : float, optional
        Seconds allowed to branch and bound per scene (or per stalled cluster
        of the Lagrangian); if HiGHS cannot prove optimality in time a
        :class:`RuntimeError` is raised (never a silently suboptimal answer).
    method : {"milp", "lagrangian"}, optional
        ``"milp"`` (default): the exact integer program. ``"lagrangian"``: the
        Lagrangian relaxation of Deb et al. (1997), stopped once the proved
        gap is at most `gap`.
    gap : float, optional
        Relative duality gap, in (0, 1), at which ``"lagrangian"`` stops
        (default 0.01). Clusters whose relaxation stalls above it are closed
        by branch and bound on their own candidate groups, so the returned
        ``gap`` never exceeds it.
    max_iter : int, optional
        Subgradient iterations per cluster before the gap target is tightened
        (then twice as many before branch and bound takes over).
    p_false_reject : float, optional
        Gate: the probability :math:`P_{\text{lo}}` that one true pair of
        reports fails its gate. A candidate group is kept only if each of its
        report pairs has :math:`\kappa \le \gamma`, :math:`\gamma` the
        :math:`\chi^2_d` quantile at :math:`1 - P_{\text{lo}}`; costs are then
        computed for the kept groups only. ``None`` (default): no gate.
    p_detect : float or array_like of shape (m,), optional
        Detection probability :math:`P_{D,i} \in (0, 1]` of each source.
        Given with `false_density` and `object_density`, every source may miss
        targets and report false alarms (the dummy index), and report counts
        may differ.
    false_density : float or array_like of shape (m,), optional
        False-report density :math:`\rho_{F,i} \ge 0` of each source (per unit
        volume of the report space).
    object_density : float, optional
        Target density :math:`\rho_T > 0` (per unit volume).
    median_logdet : bool, optional
        ``False`` (default) keeps the log-determinant term :math:`\ln|2\pi S|` of
        the ML group cost: the full :math:`-2\ln` likelihood. ``True`` replaces each candidate
        group's :math:`\ln|W| + \sum_i \ln|\Sigma_i|` (:math:`W = \sum_i \Sigma_i^{-1}`)
        by its median over the candidate groups of the same size: the cost of a rule that
        ignores the term, on the same scale so that groups still compete fairly with lone
        reports. Only for ``cost="ml"`` on candidate groups (with `p_false_reject` or
        `p_detect`).

    Returns
    -------
    GroupingResult
        ``groups`` of shape ``(..., n, m)`` (with `p_detect`: ``(G, m)``, -1
        for a missing report), total ``cost``, ``method``, ``lower_bound`` and
        the proved ``gap``; ``relaxation_integral`` for the full-tensor MILP;
        ``history`` for the Lagrangian on one scene.

    Raises
    ------
    ValueError
        For bad input (see :func:`group_costs`; `gap` outside (0, 1); a partial
        detection model), more than :data:`MAX_CANDIDATE_GROUPS` candidate
        groups without a gate, or a gated problem without any grouping (the
        message names the source whose reports cannot be grouped).
    TypeError
        If `relaxation` is not a boolean.
    RuntimeError
        If the solver does not return a proven optimum.

    Notes
    -----
    One binary variable :math:`z_t` per candidate group (tuple)
    :math:`t = (j_1, \dots, j_m)`, :math:`n^m` in all:

    .. math::

        \min_z \sum_t c_t z_t \quad\text{s.t.}\quad
        \sum_{t:\,t_i = j} z_t = 1 \;\; (i = 1..m,\; j = 1..n),
        \qquad z_t \in \{0, 1\}.

    Costs of any size are accepted: when they exceed 1e9 they are capped above
    twice the greedy grouping's total (which cannot change the optimum) and
    rescaled by a positive factor before HiGHS sees them.

    For :math:`m = 2` this is the linear assignment problem (its LP relaxation
    is integral); for :math:`m \ge 3` it is the NP-hard S-D assignment problem
    (Deb et al., 1997). The relaxation's optimum is a lower bound on the integer optimum, so
    an integral relaxed solution is an exact answer; in well-separated scenes
    this is the common case and is much faster than branch and bound.

    *Gate.* The pair statistics :math:`\kappa` of all report pairs are
    computed first (:math:`O(m^2 n^2)`), then tuples are grown source by
    source, keeping only those whose pairs all pass: memory follows the number
    of gated candidates, not :math:`n^m`. A true group of :math:`m` reports
    passes with probability at least :math:`1 - \binom{m}{2} P_{\text{lo}}`.

    *Dummy index.* Targets form a Poisson field of density :math:`\rho_T`;
    source :math:`i` detects each with probability :math:`P_{D,i}` and adds
    false reports of density :math:`\rho_{F,i}`. A group of the sources
    :math:`S` (:math:`|S| \ge 2`) and a lone report of source :math:`i` cost

    .. math::

        c_S = c_{\mathrm{ML}} + (|S|-1)\,d\ln 2\pi - 2\ln\Big(\rho_T
              \prod_{i\in S} P_{D,i} \prod_{i\notin S}(1-P_{D,i})\Big),
        \qquad c_i = -2\ln u_i,\;\;
        u_i = \rho_{F,i} + \rho_T P_{D,i}\prod_{k\ne i}(1-P_{D,k}),

    so the total is :math:`-2\ln` of the grouping's likelihood up to one
    constant; for :math:`m = 2`, :math:`c_{12} - c_1 - c_2 = \kappa - 2c_0`
    with :math:`c_0` of :func:`radarfusion_ref.association.non_assignment_cost`.

    *Lagrangian relaxation.* The candidate groups are split into independent
    clusters (connected reports). In each, the constraints of sources
    :math:`3..m` get multipliers :math:`y`; for each pair :math:`(j_1, j_2)`
    the cheapest completion of reduced cost :math:`c_t - \sum_{i\ge 3}
    y_i(t_i)` leaves a 2-D assignment over the gated pairs, solved exactly
    (:func:`scipy.sparse.csgraph.min_weight_full_bipartite_matching`, with
    the dummy rows and columns kept sparse). Its value plus
    :math:`\sum y` is a valid lower bound :math:`q(y)` (reduced by a
    floating-point rounding allowance). A feasible grouping is recovered each
    iteration by fixing the relaxed pairs and assigning sources
    :math:`3, \dots, m` one at a time, and :math:`y` moves along the
    subgradient with a Polyak step toward the best cost found. A relaxed
    solution that is itself feasible is optimal (gap 0).

    References
    ----------
    Sonar paper (2013), eqs. (24)–(26); Deb et al. (1997).

    Examples
    --------
    >>> x = np.array([[[0.0], [5.0]], [[5.3], [0.1]], [[0.2], [4.9]]])
    >>> r = group_sd(x, np.ones((3, 2, 1, 1)))
    >>> r.groups.tolist(), r.method
    ([[0, 1, 0], [1, 0, 1]], 'milp')
    >>> r = group_sd(x, np.ones((3, 2, 1, 1)), method="lagrangian", p_false_reject=1e-3)
    >>> r.groups.tolist(), r.gap
    ([[0, 1, 0], [1, 0, 1]], 0.0)
    """
    cost = as_choice(cost, "cost", _COSTS)
    relaxation = as_bool(relaxation, "relaxation")
    if time_limit is not None:
        time_limit = float(as_positive(time_limit, "time_limit"))
    method = as_choice(method, "method", ("milp", "lagrangian"))
    gap = as_probability(gap, "gap")
    if gap.ndim:
        raise ValueError(f"`gap` must be a number in the open interval (0, 1); received shape "
                         f"{gap.shape}")
    gap = float(gap)
    max_iter = as_int(max_iter, "max_iter", minimum=1)
    p_lo = None
    if p_false_reject is not None:
        p_lo = as_probability(p_false_reject, "p_false_reject")
        if p_lo.ndim:
            raise ValueError("`p_false_reject` must be a number in (0, 1); received shape "
                             f"{p_lo.shape}")
        p_lo = float(p_lo)
    why = (f"pair gate P_lo = {p_lo:g}" if p_lo is not None else "no gate")
    median_logdet = as_bool(median_logdet, "median_logdet")
    with_det = p_detect is not None or false_density is not None or object_density is not None
    if median_logdet and (cost != "ml" or (p_lo is None and not with_det)):
        raise ValueError("`median_logdet`=True applies to the ML cost (`cost`='ml') of candidate "
                         "groups: give `p_false_reject` (a gate) or `p_detect` (the dummy "
                         f"index); received cost={cost!r}, p_false_reject={p_false_reject!r}, "
                         f"p_detect={_describe(p_detect) if p_detect is not None else None}")
    if with_det:
        xs, cs = _ragged_iv(x, cov)
        det = _detection_iv(len(xs), p_detect, false_density, object_density)
        if cost != "ml":
            raise ValueError("`cost` must be 'ml' with missed detections and false reports "
                             f"(`p_detect`): the likelihood defines their costs; received {cost!r}")
        d = xs[0].shape[1]
        gamma = None if p_lo is None else float(gate_threshold(p_lo, d))
        counts = [xi.shape[0] for xi in xs]
        T, c = _scene_candidates(xs, cs, cost=cost, gamma=gamma, det=det,
                                  median_logdet=median_logdet)
        chosen, total, lb, hist = _solve_candidates(
            T, c, counts, dummy=True, method=method, gap=gap, max_iter=max_iter,
            time_limit=time_limit, why=why)
        gp = _gap_of(total, lb)
        return GroupingResult(_groups_from_tuples(T[chosen]), total, cost, method, None,
                              lb, gp, hist, gp == 0.0)
    xb, cb, batch = _reports_iv(x, cov)
    B, m, n, d = xb.shape
    if p_lo is None:
        check_size(n**m, MAX_CANDIDATE_GROUPS,
                   what=f"candidate groups n**m = {n}**{m} of one scene (`x` with m = {m}, n = {n})",
                   alternative="a gate on the candidate groups (`p_false_reject`) and Lagrangian "
                               "relaxation (`method`='lagrangian', Deb et al. 1997), or "
                               "splitting the scene into clusters")
    groups = np.empty((B, n, m), dtype=np.int64)
    totals, lbs = np.empty(B), np.empty(B)
    integral = np.zeros(B, dtype=bool)
    hist = None
    for b in range(B):
        x_b, cov_b = xb[b:b + 1], cb[min(b, cb.shape[0] - 1)][None]
        if method == "milp" and p_lo is None:          # the full tensor: exact, HiGHS
            c = _tensor(x_b, cov_b, cost).ravel()
            chosen, integral[b] = _scene_milp(c, m, n, relaxation, time_limit, b)
            groups[b] = _normalise(np.array(np.unravel_index(chosen, (n,) * m)).T)
            totals[b] = lbs[b] = c[chosen].sum()
        else:                                            # candidate groups, cluster by cluster
            T, c = _scene_tuples(x_b, cov_b, cost, p_lo, median_logdet)
            chosen, totals[b], lbs[b], hist = _scene_candidates_solve(
                T, c, [n] * m, method, gap, max_iter, time_limit, why, b, batch)
            groups[b] = _normalise(T[chosen])
        _finite_total(totals[b], b)
    gaps = np.maximum(0.0, (totals - lbs) / np.maximum(np.abs(totals), 1.0))  # proved gap
    integral = integral if method == "milp" and p_lo is None else None
    if not batch:
        return GroupingResult(groups[0], float(totals[0]), cost, method,
                              None if integral is None else bool(integral[0]),
                              float(lbs[0]), float(gaps[0]), hist, bool(gaps[0] == 0.0))
    return GroupingResult(groups.reshape(*batch, n, m), totals.reshape(batch), cost, method,
                          None if integral is None else integral.reshape(batch),
                          lbs.reshape(batch), gaps.reshape(batch), None, bool(np.all(gaps == 0)))


def _scene_milp(c, m, n, relaxation, time_limit, b):
    """Exact S-D of one scene's full cost tensor (flat); the scene named in errors."""
    try:
        return _sd_solve(c, m, n, relaxation=relaxation, time_limit=time_limit)
    except RuntimeError as exc:
        raise RuntimeError(f"scene {b}: {exc}") from None


def _scene_tuples(x, cov, cost, p_lo, median_logdet):
    """Candidate groups of one scene (all n**m, or the gated ones) and their costs."""
    _, m, n, d = x.shape
    if p_lo is None:
        return np.indices((n,) * m).reshape(m, -1).T, _tensor(x, cov, cost).ravel()
    return _scene_candidates(list(x[0]), list(cov[0]), cost=cost,
                             gamma=float(gate_threshold(p_lo, d)), det=None,
                             median_logdet=median_logdet)


def _scene_candidates_solve(T, c, counts, method, gap, max_iter, time_limit, why, b, batch):
    """:func:`radarfusion_ref.engine.assignment._lagrangian._solve_candidates` for one scene."""
    try:
        return _solve_candidates(T, c, counts, dummy=False, method=method, gap=gap,
                                 max_iter=max_iter, time_limit=time_limit, why=why)
    except ValueError as exc:
        raise ValueError(f"scene {b}: {exc}" if batch else str(exc)) from None


def _finite_total(total, b):
    if not np.isfinite(total):
        raise ValueError(
            f"`x` and `cov`: scene {b}: the total cost of the best grouping overflows "
            "the floating-point range; split the scene or gate the candidate groups first")


# ----------------------------------------------------------------------------- binding
def binding_costs(x, cov, tracks, track_cov, *, cost: str = "paper") -> np.ndarray:
    r"""Score every binding hypothesis of m sources' reports to n fused tracks.

    Parameters
    ----------
    x : array_like, shape (..., m, n, d)
        New reports, ``x[..., i, j]`` report ``j`` of source ``i``.
    cov : array_like, shape (..., m, n, d, d)
        Their covariances (broadcastable).
    tracks : array_like, shape (..., n, d)
        Fused-track estimates (the paper's combined messages :math:`J_p`).
    track_cov : array_like, shape (..., n, d, d)
        Their error covariances (broadcastable).
    cost : {"paper", "ml"}, optional
        ``"paper"`` (default): the paper's sum of quadratic forms of the
        report-minus-track differences, each with covariance
        :math:`R_i + R_p` and treated as independent (eqs. 4–7). ``"ml"``:
        minus twice the exact log-likelihood, in which the reports bound to one
        track share that track's error.

    Returns
    -------
    numpy.ndarray, shape (..., H)
        One cost per hypothesis of `radarfusion_ref.engine.scenes.binding_hypotheses` (``H = (n!)**m``);
        the rule picks the minimum.

    Raises
    ------
    ValueError
        For inconsistent shapes, covariances that are not symmetric positive
        definite, more than :data:`radarfusion_ref.engine.scenes.MAX_BINDING_HYPOTHESES` hypotheses, or costs
        beyond the floating-point range.

    Notes
    -----
    Paper, eq. (6)–(7): :math:`\Sigma_h = \sum_{i,p}\Delta_{ij/p}^T
    (R_i+R_p)^{-1}\Delta_{ij/p}` with :math:`\Delta_{ij/p} = a_{ij} - a_p`
    and :math:`j` the report of source :math:`i` bound to track :math:`p`.
    Exact: the track is one more noisy report of the target, so each track's
    group {track, bound reports} is scored by :func:`group_costs` (``"ml"``):

    .. math::

        \Sigma^{\mathrm{exact}}_h = \sum_p c_{\mathrm{ML}}(a_p, a_{1 j_1}, \dots, a_{m j_m}),

    equivalently the quadratic form of the stacked differences with their
    full (correlated) covariance, whose off-diagonal blocks are :math:`R_p`.

    References
    ----------
    Sonar paper (2013), eqs. (4)–(7).

    Examples
    --------
    >>> x = np.array([[[0.1], [5.2]], [[-0.1], [4.9]]])     # 2 sources x 2 targets
    >>> c = np.full((2, 2, 1, 1), 0.04)
    >>> t, tc = np.array([[0.0], [5.0]]), np.full((2, 1, 1), 0.01)
    >>> int(np.argmin(binding_costs(x, c, t, tc)))          # hypothesis I
    0
    """
    cost = as_choice(cost, "cost", ("paper", "ml"))
    xb, cb, batch_x = _reports_iv(x, cov)
    B, m, n, d = xb.shape
    t = as_float_array(tracks, "tracks", ndim_min=2)
    if t.shape[-2:] != (n, d):
        raise ValueError(f"`tracks` must have shape (..., {n}, {d}) to match `x`; received shape {t.shape}")
    tc = as_float_array(track_cov, "track_cov", ndim_min=3)
    if tc.shape[-3:] not in {(n, d, d), (1, d, d)}:
        raise ValueError(
            f"`track_cov` must have shape (..., {n}, {d}, {d}); received shape {tc.shape}"
        )
    tc = as_covariance(tc, "track_cov", dim=d)
    try:
        batch = np.broadcast_shapes(batch_x, t.shape[:-2], tc.shape[:-3])
    except ValueError:
        raise ValueError(
            "`x`, `tracks` and `track_cov` must have broadcastable leading (scene) axes; "
            f"received shapes {np.shape(x)}, {t.shape}, {tc.shape}"
        ) from None
    xb = np.broadcast_to(xb.reshape(*batch_x, m, n, d), (*batch, m, n, d)).reshape(-1, m, n, d)
    if cb.shape[0] > 1:
        cb = np.broadcast_to(cb.reshape(*batch_x, m, n, d, d),
                             (*batch, m, n, d, d)).reshape(-1, m, n, d, d)
    tb = np.broadcast_to(t, (*batch, n, d)).reshape(-1, n, d)
    if math.prod(tc.shape[:-3]) == 1 and cb.shape[0] == 1:     # no per-scene covariances
        tcb = np.broadcast_to(tc.reshape(tc.shape[-3:]), (n, d, d))[None]
    else:
        tcb = np.broadcast_to(tc, (*batch, n, d, d)).reshape(-1, n, d, d)
    B = xb.shape[0]
    hyp = binding_hypotheses(n, m)                                   # (H, m, n), size-checked
    H = hyp.shape[0]
    check_size(8 * B * (H + (n ** (m + 1) if cost == "ml" else 0)) + 8 * H * m * n,
               MEMORY_LIMIT, what=f"bytes of binding costs (`x`: {B} scene(s) x {H} hypotheses)",
               alternative="fewer scenes per call")
    (xb, cb, tb, tcb), log_s2 = _rescale(xb, cb, tb, tcb)
    if cost == "paper":
        q = mahalanobis_sq_pairwise(xb, tb[:, None], cb, tcb[:, None])  # (B, m, n_j, n_p)
        ii = np.arange(m)[None, :, None]
        pp = np.arange(n)[None, None, :]
        out = q[:, ii, hyp, pp].sum(axis=(-2, -1))                   # (B, H)
    else:
        xe = np.concatenate([tb[:, None], xb], axis=1)               # track = source 0
        bc = max(tcb.shape[0], cb.shape[0])
        ce = np.concatenate([np.broadcast_to(tcb[:, None], (bc, 1, n, d, d)),
                             np.broadcast_to(cb, (bc, m, n, d, d))], axis=1)
        tensor = _ml_tensor(xe, ce).reshape(B, -1) + m * d * log_s2
        w = np.array([n ** (m - i) for i in range(m + 1)])
        flat = np.arange(n) * w[0] + np.einsum("hip,i->hp", hyp, w[1:])   # (H, n)
        out = tensor[:, flat].sum(axis=-1)
    return _finite_costs(out).reshape(*batch, hyp.shape[0])


# ----------------------------------------------------------------------------- scenes
def grouping_scene(n_targets: int, n_sources: int, *, spacing: float = 1.0,
                   layout: str = "line", cov, track_cov=None, trials: int = 1,
                   rng=None) -> GroupingScene:
    """Draw `trials` scenes of `n_targets` targets reported by `n_sources` sources.

    :func:`radarfusion_ref.engine.scenes.grouping_scene` under this chapter's name for
    its first argument (the same draws for the same seed).

    Parameters
    ----------
    n_targets : int
        Number of targets ``n`` (every source reports every target once).
    n_sources, spacing, layout, cov, track_cov, trials, rng
        As in :func:`radarfusion_ref.engine.scenes.grouping_scene`.

    Returns
    -------
    GroupingScene

    Raises
    ------
    ValueError, TypeError
        As :func:`radarfusion_ref.engine.scenes.grouping_scene`, naming `n_targets`.

    Examples
    --------
    >>> s = grouping_scene(3, 2, cov=np.eye(2)[None, None] * 0.01, trials=4, rng=1)
    >>> s.reports.shape, s.true_groups.shape
    ((4, 2, 3, 2), (4, 3, 2))
    """
    n = as_int(n_targets, "n_targets", minimum=1)
    return scenes.grouping_scene(n, n_sources, spacing=spacing, layout=layout, cov=cov,
                                 track_cov=track_cov, trials=trials, rng=rng)
