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
* simulates scenes (:func:`grouping_scene`).

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

import functools
import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy import sparse, stats
from scipy.optimize import Bounds, LinearConstraint, linear_sum_assignment, linprog, milp

from ._validation import (
    MEMORY_LIMIT,
    as_bool,
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    as_rng,
    check_size,
)

__all__ = [
    "PAPER_HYPOTHESES",
    "GroupingResult",
    "GroupingScene",
    "MAX_BINDING_HYPOTHESES",
    "MAX_CANDIDATE_GROUPS",
    "MAX_GROUPINGS",
    "binding_costs",
    "binding_hypotheses",
    "group_bruteforce",
    "group_costs",
    "group_sd",
    "grouping_scene",
    "n_groupings",
]

_COSTS = ("ml", "pairwise")

#: Largest number of binding hypotheses :math:`(n!)^m` that
#: :func:`binding_hypotheses` and :func:`binding_costs` enumerate (``(n, m) = (6, 2)``
#: has 518 400; ``(6, 3)`` has 3.7e8 and is refused). The scalable route is the
#: exact ML binding as a grouping of ``m + 1`` sources with the tracks as source
#: 0, solved by :func:`group_sd`.
MAX_BINDING_HYPOTHESES = 10**6

#: Largest number of groupings :math:`(n!)^{m-1}` that :func:`group_bruteforce`
#: enumerates, whatever its `max_groupings` (about a minute of work); beyond it,
#: use :func:`group_sd`.
MAX_GROUPINGS = 10**8

#: Largest number of candidate groups :math:`n^m` (binary variables) of one
#: scene that :func:`group_sd` hands to HiGHS (e.g. ``n = 100`` targets of
#: ``m = 3`` sources, or ``n = 31`` of ``m = 4``).
MAX_CANDIDATE_GROUPS = 10**6

#: Costs up to this size are handed to HiGHS as they are; larger ones are capped
#: (never changing the optimum) and rescaled, since HiGHS treats costs from
#: 1e20 on as infinite.
_HIGHS_COST_SCALE = 1e9

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
    """The best grouping of one scene (or of a batch of scenes).

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
        :math:`(\text{cost} - \text{lower bound}) / \\max(|\text{cost}|, 1)`
        (0 for the exact methods).
    history : numpy.ndarray or None, shape (iterations, 2)
        For ``"lagrangian"`` on one scene: the best lower bound and the best
        cost after each iteration (summed over the independent clusters).
        ``None`` otherwise.

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

    def __post_init__(self):
        if self.lower_bound is None:            # exact methods: the cost is its own bound
            object.__setattr__(self, "lower_bound", self.cost)


@dataclass(frozen=True)
class GroupingScene:
    """Reports of m sources about n targets, for many independent trials.

    Attributes
    ----------
    truth : numpy.ndarray, shape (trials, n, d)
        True target states.
    reports : numpy.ndarray, shape (trials, m, n, d)
        ``reports[t, i, j]``: report ``j`` of source ``i``, in shuffled order.
    owner : numpy.ndarray of int, shape (trials, m, n)
        ``owner[t, i, j]``: the target that produced ``reports[t, i, j]``.
    cov : numpy.ndarray, shape (m, n, d, d)
        Error covariance of each report (the same in every trial, indexed by
        the report's position in the list).
    tracks : numpy.ndarray or None, shape (trials, n, d)
        Fused-track estimates, ``tracks[t, p]`` of target ``p`` (or ``None``).
    track_cov : numpy.ndarray or None, shape (n, d, d)
        Error covariance of the fused tracks (or ``None``).
    """

    truth: np.ndarray
    reports: np.ndarray
    owner: np.ndarray
    cov: np.ndarray
    tracks: np.ndarray | None
    track_cov: np.ndarray | None

    @property
    def true_binding(self) -> np.ndarray:
        """``true_binding[t, i, p]``: index of source ``i``'s report of target ``p``."""
        return np.argsort(self.owner, axis=-1)

    @property
    def true_groups(self) -> np.ndarray:
        """The true grouping, shape (trials, n, m), rows sorted by source 0."""
        bind = self.true_binding                      # (T, m, n)
        target_of_row = self.owner[:, 0, :]           # (T, n): target of source-0 report k
        idx = np.broadcast_to(target_of_row[:, None, :], bind.shape)
        return np.swapaxes(np.take_along_axis(bind, idx, axis=-1), -1, -2)

    def is_correct(self, groups) -> np.ndarray:
        """Per trial: is `groups` (shape (trials, n, m)) the true grouping?"""
        g = np.asarray(groups)
        if g.shape != self.true_groups.shape:
            raise ValueError(
                f"`groups` must have shape {self.true_groups.shape}; received shape {g.shape}"
            )
        return np.all(g == self.true_groups, axis=(-2, -1))

    def true_hypothesis(self) -> np.ndarray:
        """Per trial, the index of the true binding in :func:`binding_hypotheses` order."""
        m, n = self.owner.shape[-2:]
        hyp = binding_hypotheses(n, m)                # (H, m, n)
        match = np.all(hyp[None] == self.true_binding[:, None], axis=(-2, -1))
        return np.argmax(match, axis=-1)


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


def _ml_tensor(x, cov):
    """ML group costs, (B, n, ..., n) over m axes (see group_costs)."""
    B, m, n, d = x.shape
    x = x - x.mean(axis=(1, 2), keepdims=True)       # costs are translation invariant
    info, logdet_c = _information(cov)               # (Bc, m, n, d, d), (Bc, m, n)
    ia = np.einsum("bijkl,bijl->bijk", info, x) if info.shape[0] == B else \
        np.einsum("ijkl,bijl->bijk", info[0], x)
    out = np.empty((B,) + (n,) * m)
    k = m - 1
    # sources 1..m-1 spread over k tuple axes; source 0 handled one report at a time
    I_rest = [_expand(info[:, i], i - 1, k) for i in range(1, m)]
    ia_rest = [_expand(ia[:, i], i - 1, k) for i in range(1, m)]
    x_rest = [_expand(x[:, i], i - 1, k) for i in range(1, m)]
    ld_rest = sum(_expand(logdet_c[:, i], i - 1, k) for i in range(1, m))
    pad = (1,) * k
    for j0 in range(n):
        I0 = info[:, 0, j0].reshape(info.shape[0], *pad, d, d)
        x0 = x[:, 0, j0].reshape(B, *pad, d)
        W = I0 + sum(I_rest)
        b = ia[:, 0, j0].reshape(B, *pad, d) + sum(ia_rest)
        xhat = np.linalg.solve(W, b[..., None])[..., 0]
        r = x0 - xhat
        q = np.einsum("...k,...kl,...l->...", r, I0, r)
        for Ii, xi in zip(I_rest, x_rest, strict=True):
            r = xi - xhat
            q = q + np.einsum("...k,...kl,...l->...", r, Ii, r)
        chol = np.linalg.cholesky(W)
        ld_w = 2.0 * np.sum(np.log(np.diagonal(chol, axis1=-2, axis2=-1)), axis=-1)
        ld0 = logdet_c[:, 0, j0].reshape(-1, *pad)
        out[:, j0] = q + ld_w + ld0 + ld_rest
    return out


def _pairwise_tensor(x, cov):
    """Sum of pairwise quadratic forms, (B, n, ..., n) over m axes."""
    B, m, n, _ = x.shape
    out = np.zeros((B,) + (n,) * m)
    for i, k in itertools.combinations(range(m), 2):
        S = cov[:, i, :, None] + cov[:, k, None, :]          # (Bc, n, n, d, d)
        D = x[:, i, :, None] - x[:, k, None, :]              # (B, n, n, d)
        q = np.einsum("...k,...k->...", D, np.linalg.solve(S, D[..., None])[..., 0])
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
    """Number of ways to group the reports of `n_sources` sources about `n_targets` targets.

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
    :math:`k = (n!)^m`. The paper prints :math:`k = (m-1)!\\,n!` (eq. 24), which
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
    """Cost of every candidate group (one report from each source).

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
        :math:`(m-1)d\\log 2\\pi` dropped. ``"pairwise"``: the paper's sum of
        the pairwise quadratic forms.

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
    :math:`a_i \\sim \\mathcal N(x, C_i)` of one group have the marginal
    likelihood :math:`\\int\\prod_i \\mathcal N(a_i; x, C_i)\\,dx`. With
    :math:`W = \\sum_i C_i^{-1}` and the fused estimate
    :math:`\\hat x = W^{-1}\\sum_i C_i^{-1}a_i`,

    .. math::

        c_{\\mathrm{ML}} = \\sum_i (a_i-\\hat x)^T C_i^{-1}(a_i-\\hat x)
        + \\log\\det W + \\sum_i \\log\\det C_i ,

    which for :math:`m = 2` is :math:`\\Delta^T(C_1+C_2)^{-1}\\Delta + \\log\\det(C_1+C_2)`.
    The paper's cost is

    .. math::

        c_{\\mathrm{pw}} = \\sum_{i<k} (a_i-a_k)^T (C_i+C_k)^{-1} (a_i-a_k).

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


# ----------------------------------------------------------------------------- solvers
def _perms(n):
    dtype = np.int8 if n < 127 else np.int32
    return np.array(list(itertools.permutations(range(n))), dtype=dtype).reshape(-1, n)


def _normalise(tuples):
    """Sort the rows of (..., n, m) tuples by source 0."""
    order = np.argsort(tuples[..., 0], axis=-1)
    return np.take_along_axis(tuples, order[..., None], axis=-2)


def group_bruteforce(x, cov, *, cost: str = "ml", max_groupings: int = 10**7) -> GroupingResult:
    """Best grouping by enumerating all :math:`(n!)^{m-1}` groupings.

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
    :math:`\\sum_{k=1}^n c(g_k)`. Enumeration is vectorised over scenes and
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
    perms = _perms(n).astype(np.int64)                        # (n!, n)
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
    if not np.all(np.isfinite(best)):
        raise ValueError(
            "`x` and `cov`: the total cost of every grouping overflows the floating-point "
            "range; split the scene or gate the candidate groups first"
        )
    groups = np.empty((B, n, m), dtype=np.int64)
    groups[:, :, 0] = np.arange(n)
    rem = best_g
    for i in range(m - 1, 0, -1):
        groups[:, :, i] = perms[rem % nf]
        rem = rem // nf
    groups = groups.reshape(*batch, n, m)
    cost_out = best.reshape(batch)
    return GroupingResult(groups, float(cost_out) if not batch else cost_out, cost, "bruteforce")


def _greedy_total(c, m, n):
    """Cost of the greedy grouping (cheapest free candidate group first): an upper bound."""
    work = c.reshape((n,) * m).copy()
    total = 0.0
    for _ in range(n):
        t = np.unravel_index(np.argmin(work), work.shape)
        total += work[t]
        for i, j in enumerate(t):
            index = [slice(None)] * m
            index[i] = j
            work[tuple(index)] = np.inf
    return total


def _condition_costs(c_raw, m, n, bound=None):
    """Costs HiGHS can take without changing the optimum.

    Shift to a minimum of 0 (every grouping has n groups: a constant). If the
    largest cost exceeds ``_HIGHS_COST_SCALE``, cap every cost at ``K = 2 U + 1``,
    ``U`` the total of some grouping (`bound`; the greedy one by default): a grouping holding a capped
    group costs at least ``K > U >= optimum``, so the optimum is unchanged; then,
    if ``K`` itself is that large, scale all costs by ``_HIGHS_COST_SCALE / K``
    (a positive factor, the same optimum; HiGHS treats costs from 1e20 on as
    infinite).
    """
    c = c_raw - c_raw.min()
    if c.max() <= _HIGHS_COST_SCALE:
        return c
    if bound is None:
        bound = _greedy_total(c, m, n)
    cap = 2.0 * bound + 1.0
    c = np.minimum(c, cap)
    if cap > _HIGHS_COST_SCALE:
        c = c * (_HIGHS_COST_SCALE / cap)
    return c


@functools.lru_cache(maxsize=16)
def _sd_constraints(m, n):
    """Equality constraints of the S-D assignment: each report in exactly one tuple."""
    N = n**m
    idx = np.indices((n,) * m).reshape(m, -1)
    rows = (np.arange(m)[:, None] * n + idx).ravel()
    cols = np.tile(np.arange(N), m)
    A = sparse.csc_array((np.ones(m * N), (rows, cols)), shape=(m * n, N))
    return A, idx


def _sd_solve_once(c, m, n, *, relaxation=True, time_limit=None):
    """One HiGHS solve of the S-D assignment with conditioned costs `c`."""
    A, _ = _sd_constraints(m, n)
    z, integral = None, False
    if relaxation:
        lp = linprog(c, A_eq=A, b_eq=np.ones(m * n), bounds=(0, 1), method="highs")
        if lp.status == 0 and np.all(np.minimum(lp.x, 1 - lp.x) < 1e-6):
            z, integral = lp.x, True
    if z is None:
        options = {"mip_rel_gap": 0.0, "presolve": False}
        if time_limit is not None:
            options["time_limit"] = time_limit
        res = milp(c, constraints=LinearConstraint(A, 1, 1), integrality=np.ones(n**m),
                   bounds=Bounds(0, 1), options=options)
        if res.status != 0 or res.x is None:
            raise RuntimeError(
                f"HiGHS did not return a proven optimum (status {res.status}: {res.message})"
            )
        z = res.x
    chosen = np.flatnonzero(z > 0.5)
    tuples = np.array(np.unravel_index(chosen, (n,) * m))          # (m, n)
    if chosen.size != n or np.any(np.sort(tuples, axis=1) != np.arange(n)):
        raise RuntimeError("HiGHS returned an infeasible grouping")
    return chosen, integral


def _sd_solve(c_raw, m, n, *, relaxation=True, time_limit=None):
    """Solve the S-D assignment for a flat cost vector over the n**m tuples.

    Returns the flat indices of the n chosen tuples and whether the LP
    relaxation's solution was already integral. With costs above
    ``_HIGHS_COST_SCALE`` the cap of :func:`_condition_costs` is tightened to
    each solution's own total until it no longer improves, so the rescaled
    costs resolve the optimum to the precision of a double.
    """
    c0 = c_raw - c_raw.min()
    if c0.max() <= _HIGHS_COST_SCALE:
        return _sd_solve_once(c0, m, n, relaxation=relaxation, time_limit=time_limit)
    bound = _greedy_total(c0, m, n)
    for _ in range(64):
        chosen, integral = _sd_solve_once(_condition_costs(c0, m, n, bound), m, n,
                                          relaxation=relaxation, time_limit=time_limit)
        total = c0[chosen].sum()
        if not total < bound * (1 - 1e-12):
            break
        bound = total
    return chosen, integral


# ----------------------------------------------------------------------------- gated S-D
_LAGRANGE_STALL = 6          # iterations without a better dual value before the step halves
_LAGRANGE_PATIENCE = 20      # iterations without progress of either bound: branch and bound
_EPS = np.finfo(float).eps
_DENSE_ASSIGN = 1 << 20      # cells up to which a square assignment is solved densely


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
    S = ca[:, None] + cb[None, :]
    D = xa[:, None] - xb[None, :]
    return np.einsum("...k,...k->...", D, np.linalg.solve(S, D[..., None])[..., 0])


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


def _tuple_ml_costs(xs, cs, T, log_s2):
    """ML cost of every candidate group (rows of T, -1 = absent), as in group_costs."""
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
    out = q + ld_w + ld + (cnt - 1) * d * log_s2
    out[cnt == 1] = 0.0
    return out, cnt


def _scene_candidates(xs, cs, *, cost, gamma, det):
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
        c, cnt = _tuple_ml_costs(xs_s, cs_s, T, log_s2)
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


def _report_nodes(T, counts):
    offsets = np.concatenate([[0], np.cumsum(counts)])
    return np.where(T >= 0, T + offsets[:-1], -1), offsets


def _check_cover(T, counts, dummy, why):
    """Every report must be in some candidate group (and, without the dummy index, the
    candidate graph's components must hold as many reports of every source)."""
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
            f"`x`: report(s) {mine[:10].tolist()} of source {i} cannot be grouped: no candidate "
            f"group holds them ({why}); never a partial grouping -- widen the gate or allow "
            "missed detections and false reports (`p_detect` < 1, `false_density` > 0)"
        )
    first = nodes[np.arange(T.shape[0]), np.argmax(T >= 0, axis=1)]
    rows = np.concatenate([first[nodes[:, i] >= 0] for i in range(m)])
    cols = np.concatenate([nodes[nodes[:, i] >= 0, i] for i in range(m)])
    graph = sparse.coo_array((np.ones(rows.size), (rows, cols)), shape=(N, N))
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
                f"`x`: the reports {mine[:10].tolist()} of source {i} cannot be grouped: their "
                f"cluster of candidate groups holds {comp.tolist()} reports of the m = {m} "
                f"sources, not one of each per group ({why}); widen the gate or allow missed "
                "detections and false reports (`p_detect` < 1, `false_density` > 0)"
            )
    return ncomp, label, first, offsets


def _milp_tuples(T, c, counts, *, time_limit=None, upper=None):
    """Exact S-D on explicit candidate groups (HiGHS); (chosen, lower bound) or None."""
    m = len(counts)
    nodes, offsets = _report_nodes(T, counts)
    K = T.shape[0]
    rows = nodes.T.ravel()
    cols = np.tile(np.arange(K), m)
    ok = rows >= 0
    A = sparse.csc_array((np.ones(ok.sum()), (rows[ok], cols[ok])), shape=(int(offsets[-1]), K))
    cc = c
    if not np.any(T < 0):             # every grouping has counts[0] groups: shift to min 0
        shift = float(c.min())
        cc = c - shift
        if cc.max() > _HIGHS_COST_SCALE and upper is not None and np.isfinite(upper):
            cc = np.minimum(cc, 2.0 * (upper - shift * counts[0]) + 1.0)   # as _condition_costs
    top = float(np.max(np.abs(cc))) if cc.size else 0.0
    scale = _HIGHS_COST_SCALE / top if top > _HIGHS_COST_SCALE else 1.0
    options = {"mip_rel_gap": 0.0}
    if time_limit is not None:
        options["time_limit"] = time_limit
    res = milp(cc * scale, constraints=LinearConstraint(A, 1, 1), integrality=np.ones(K),
               bounds=Bounds(0, 1), options=options)
    if res.status == 2:                                              # infeasible
        return None
    if res.status != 0 or res.x is None:
        raise RuntimeError(
            f"HiGHS did not return a proven optimum (status {res.status}: {res.message})"
        )
    chosen = np.flatnonzero(res.x > 0.5)
    cover = np.bincount(nodes[chosen][nodes[chosen] >= 0], minlength=int(offsets[-1]))
    if np.any(cover != 1):
        raise RuntimeError("HiGHS returned an infeasible grouping")
    return chosen


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
    graph = sparse.csr_array((wts - lo + 1.0, (rows, cols)), shape=(N, N))
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
            raise ValueError("`x`: too many reports for the Lagrangian's tuple keys")
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


def _solve_candidates(T, c, counts, *, dummy, method, gap, max_iter, time_limit, why):
    """Solve one scene's S-D problem over explicit candidates, cluster by cluster.

    Returns (chosen tuple indices, cost, lower bound, history (iterations, 2) or None).
    """
    ncomp, label, first, offsets = _check_cover(T, counts, dummy, why)
    m = len(counts)
    tlabel = label[first]
    order = np.argsort(tlabel, kind="stable")
    bounds = np.searchsorted(tlabel[order], np.arange(ncomp + 1))
    if method == "milp":
        chosen = _milp_tuples(T, c, counts, time_limit=time_limit)
        if chosen is None:
            raise ValueError(_infeasible_text(None, counts, why))
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
                raise ValueError(_infeasible_text(exc.args[0], counts, why)) from None

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
                raise ValueError(_infeasible_text(None, counts, why)) from None
    ub, lb = totals()
    chosen = np.concatenate([sel[s.best] for sel, s in comps])
    length = max(len(s.history) for s in solvers)
    hist = np.zeros((length, 2))
    for s in solvers:
        h = np.array(s.history)
        hist += np.vstack([h, np.repeat(h[-1:], length - len(h), axis=0)])
    return chosen, float(c[chosen].sum()), min(lb, float(c[chosen].sum())), hist


def _infeasible_text(source, counts, why):
    srcs = "sources 0 and 1" if source in (0, 1) else "the sources"
    return (f"`x`: the gated problem has no grouping: the reports of {srcs} (report counts "
            f"{list(counts)}) cannot all be put into groups of one report per source ({why}); "
            "never a partial grouping -- widen the gate or allow missed detections and false "
            "reports (`p_detect` < 1, `false_density` > 0)")


def _groups_from_tuples(T):
    """Rows sorted by source 0, then 1, ... (a missing report, -1, sorts last)."""
    key = np.where(T >= 0, T, np.iinfo(np.int64).max)
    return T[np.lexsort(key.T[::-1])]


def group_sd(x, cov, *, cost: str = "ml", relaxation: bool = True,
             time_limit: float | None = None, method: str = "milp", gap: float = 0.01,
             max_iter: int = 100, p_false_reject: float | None = None, p_detect=None,
             false_density=None, object_density=None) -> GroupingResult:
    """Best grouping as an S-D assignment: exactly (HiGHS) or to a proved gap (Lagrangian).

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
        Gate: the probability :math:`P_{\\text{lo}}` that one true pair of
        reports fails its gate. A candidate group is kept only if each of its
        report pairs has :math:`\\kappa \\le \\gamma`, :math:`\\gamma` the
        :math:`\\chi^2_d` quantile at :math:`1 - P_{\\text{lo}}`; costs are then
        computed for the kept groups only. ``None`` (default): no gate.
    p_detect : float or array_like of shape (m,), optional
        Detection probability :math:`P_{D,i} \\in (0, 1]` of each source.
        Given with `false_density` and `object_density`, every source may miss
        targets and report false alarms (the dummy index), and report counts
        may differ.
    false_density : float or array_like of shape (m,), optional
        False-report density :math:`\\rho_{F,i} \\ge 0` of each source (per unit
        volume of the report space).
    object_density : float, optional
        Target density :math:`\\rho_T > 0` (per unit volume).

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
    :math:`t = (j_1, \\dots, j_m)`, :math:`n^m` in all:

    .. math::

        \\min_z \\sum_t c_t z_t \\quad\\text{s.t.}\\quad
        \\sum_{t:\\,t_i = j} z_t = 1 \\;\\; (i = 1..m,\\; j = 1..n),
        \\qquad z_t \\in \\{0, 1\\}.

    Costs of any size are accepted: when they exceed 1e9 they are capped above
    twice the greedy grouping's total (which cannot change the optimum) and
    rescaled by a positive factor before HiGHS sees them.

    For :math:`m = 2` this is the linear assignment problem (its LP relaxation
    is integral); for :math:`m \\ge 3` it is the NP-hard S-D assignment problem
    (Deb et al., 1997). The relaxation's optimum is a lower bound on the integer optimum, so
    an integral relaxed solution is an exact answer; in well-separated scenes
    this is the common case and is much faster than branch and bound.

    *Gate.* The pair statistics :math:`\\kappa` of all report pairs are
    computed first (:math:`O(m^2 n^2)`), then tuples are grown source by
    source, keeping only those whose pairs all pass: memory follows the number
    of gated candidates, not :math:`n^m`. A true group of :math:`m` reports
    passes with probability at least :math:`1 - \\binom{m}{2} P_{\\text{lo}}`.

    *Dummy index.* Targets form a Poisson field of density :math:`\\rho_T`;
    source :math:`i` detects each with probability :math:`P_{D,i}` and adds
    false reports of density :math:`\\rho_{F,i}`. A group of the sources
    :math:`S` (:math:`|S| \\ge 2`) and a lone report of source :math:`i` cost

    .. math::

        c_S = c_{\\mathrm{ML}} + (|S|-1)\\,d\\ln 2\\pi - 2\\ln\\Big(\\rho_T
              \\prod_{i\\in S} P_{D,i} \\prod_{i\\notin S}(1-P_{D,i})\\Big),
        \\qquad c_i = -2\\ln u_i,\\;\\;
        u_i = \\rho_{F,i} + \\rho_T P_{D,i}\\prod_{k\\ne i}(1-P_{D,k}),

    so the total is :math:`-2\\ln` of the grouping's likelihood up to one
    constant; for :math:`m = 2`, :math:`c_{12} - c_1 - c_2 = \\kappa - 2c_0`
    with :math:`c_0` of :func:`radarfusion_ref.association.non_assignment_cost`.

    *Lagrangian relaxation.* The candidate groups are split into independent
    clusters (connected reports). In each, the constraints of sources
    :math:`3..m` get multipliers :math:`\\mu`; for each pair :math:`(j_1, j_2)`
    the cheapest completion of reduced cost :math:`c_t - \\sum_{i\\ge 3}
    \\mu_i(t_i)` leaves a 2-D assignment over the gated pairs, solved exactly
    (:func:`scipy.sparse.csgraph.min_weight_full_bipartite_matching`, with
    the dummy rows and columns kept sparse). Its value plus
    :math:`\\sum \\mu` is a valid lower bound :math:`q(\\mu)` (reduced by a
    floating-point rounding allowance). A feasible grouping is recovered each
    iteration by fixing the relaxed pairs and assigning sources
    :math:`3, \\dots, m` one at a time, and :math:`\\mu` moves along the
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
    if p_detect is not None or false_density is not None or object_density is not None:
        xs, cs = _ragged_iv(x, cov)
        det = _detection_iv(len(xs), p_detect, false_density, object_density)
        if cost != "ml":
            raise ValueError("`cost` must be 'ml' with missed detections and false reports "
                             f"(`p_detect`): the likelihood defines their costs; received {cost!r}")
        d = xs[0].shape[1]
        gamma = None if p_lo is None else float(stats.chi2.isf(p_lo, d))
        counts = [xi.shape[0] for xi in xs]
        T, c = _scene_candidates(xs, cs, cost=cost, gamma=gamma, det=det)
        chosen, total, lb, hist = _solve_candidates(
            T, c, counts, dummy=True, method=method, gap=gap, max_iter=max_iter,
            time_limit=time_limit, why=why)
        return GroupingResult(_groups_from_tuples(T[chosen]), total, cost, method, None,
                              lb, _gap_of(total, lb), hist)
    xb, cb, batch = _reports_iv(x, cov)
    B, m, n, d = xb.shape
    if p_lo is None:
        check_size(n**m, MAX_CANDIDATE_GROUPS,
                   what=f"candidate groups n**m = {n}**{m} of one scene (`x` with m = {m}, n = {n})",
                   alternative="a gate on the candidate groups (`p_false_reject`) and Lagrangian "
                               "relaxation (`method`='lagrangian', Deb et al. 1997), or "
                               "splitting the scene into clusters")
    groups = np.empty((B, n, m), dtype=np.int64)
    totals = np.empty(B)
    lbs = np.empty(B)
    integral = np.zeros(B, dtype=bool)
    hist = None
    for b in range(B):
        cov_b = cb[min(b, cb.shape[0] - 1)]
        if method == "milp" and p_lo is None:
            c_raw = _tensor(xb[b:b + 1], cov_b[None], cost).ravel()
            try:
                chosen, integral[b] = _sd_solve(c_raw, m, n, relaxation=relaxation,
                                                time_limit=time_limit)
            except RuntimeError as exc:
                raise RuntimeError(f"scene {b}: {exc}") from None
            groups[b] = _normalise(np.array(np.unravel_index(chosen, (n,) * m)).T)
            totals[b] = lbs[b] = c_raw[chosen].sum()
        else:
            if p_lo is None:
                T = np.indices((n,) * m).reshape(m, -1).T
                c = _tensor(xb[b:b + 1], cov_b[None], cost).ravel()
            else:
                T, c = _scene_candidates(list(xb[b]), list(cov_b), cost=cost,
                                         gamma=float(stats.chi2.isf(p_lo, d)), det=None)
            try:
                chosen, totals[b], lbs[b], hist = _solve_candidates(
                    T, c, [n] * m, dummy=False, method=method, gap=gap, max_iter=max_iter,
                    time_limit=time_limit, why=why)
            except ValueError as exc:
                raise ValueError(f"scene {b}: {exc}" if batch else str(exc)) from None
            groups[b] = _normalise(T[chosen])
        if not np.isfinite(totals[b]):
            raise ValueError(
                f"`x` and `cov`: scene {b}: the total cost of the best grouping overflows "
                "the floating-point range; split the scene or gate the candidate groups first"
            )
    groups = groups.reshape(*batch, n, m)
    exact_full = method == "milp" and p_lo is None
    gaps = np.array([_gap_of(t, lo) for t, lo in zip(totals, lbs, strict=True)])
    if not batch:
        return GroupingResult(groups, float(totals[0]), cost, method,
                              bool(integral[0]) if exact_full else None,
                              float(lbs[0]), float(gaps[0]), hist)
    return GroupingResult(groups, totals.reshape(batch), cost, method,
                          integral.reshape(batch) if exact_full else None,
                          lbs.reshape(batch), gaps.reshape(batch))


def _gap_of(total, lower):
    """Proved relative gap (cost - lower bound) / max(|cost|, 1), never negative."""
    return max(0.0, (float(total) - float(lower)) / max(abs(float(total)), 1.0))


# ----------------------------------------------------------------------------- binding
def binding_hypotheses(n_targets: int, n_sources: int) -> np.ndarray:
    """All ways to bind every source's reports one-to-one to `n_targets` fused tracks.

    Parameters
    ----------
    n_targets : int
        Number of tracks (= reports per source), ``>= 1``.
    n_sources : int
        Number of sources, ``>= 1``.

    Returns
    -------
    numpy.ndarray of int, shape (H, m, n)
        ``hyp[h, i, p]``: index of the report of source ``i`` bound to track
        ``p`` under hypothesis ``h``; :math:`H = (n!)^m`, in
        :func:`itertools.product` order of the sources' permutations.

    Raises
    ------
    ValueError
        If :math:`(n!)^m` exceeds :data:`MAX_BINDING_HYPOTHESES` (checked before
        anything is built; use :func:`group_sd` with the tracks as source 0).

    Examples
    --------
    >>> binding_hypotheses(2, 2).shape
    (4, 2, 2)
    >>> binding_hypotheses(2, 2)[1].tolist()    # the paper's hypothesis IV
    [[0, 1], [1, 0]]
    """
    n = as_int(n_targets, "n_targets", minimum=1)
    m = as_int(n_sources, "n_sources", minimum=1)
    _check_bindings(n, m)
    perms = _perms(n).astype(np.int64)
    return np.array([np.stack(p) for p in itertools.product(perms, repeat=m)])


def _check_bindings(n, m):
    check_size(math.factorial(n) ** m, MAX_BINDING_HYPOTHESES,
               what=f"binding hypotheses (n!)**m (`n_targets` n = {n}, `n_sources` m = {m})",
               alternative="group_sd on the m + 1 sources with the tracks as source 0 "
                           "(the exact ML binding, without enumeration)")


def binding_costs(x, cov, tracks, track_cov, *, cost: str = "paper") -> np.ndarray:
    """Score every binding hypothesis of m sources' reports to n fused tracks.

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
        One cost per hypothesis of :func:`binding_hypotheses` (``H = (n!)**m``);
        the rule picks the minimum.

    Raises
    ------
    ValueError
        For inconsistent shapes, covariances that are not symmetric positive
        definite, more than :data:`MAX_BINDING_HYPOTHESES` hypotheses, or costs
        beyond the floating-point range.

    Notes
    -----
    Paper, eq. (6)–(7): :math:`\\Sigma_h = \\sum_{i,p}\\Delta_{ij/p}^T
    (R_i+R_p)^{-1}\\Delta_{ij/p}` with :math:`\\Delta_{ij/p} = a_{ij} - a_p`
    and :math:`j` the report of source :math:`i` bound to track :math:`p`.
    Exact: the track is one more noisy report of the target, so each track's
    group {track, bound reports} is scored by :func:`group_costs` (``"ml"``):

    .. math::

        \\Sigma^{\\mathrm{exact}}_h = \\sum_p c_{\\mathrm{ML}}(a_p, a_{1 j_1}, \\dots, a_{m j_m}),

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
    _check_bindings(n, m)
    H = math.factorial(n) ** m
    check_size(8 * B * (H + (n ** (m + 1) if cost == "ml" else 0)) + 8 * H * m * n,
               MEMORY_LIMIT, what=f"bytes of binding costs (`x`: {B} scene(s) x {H} hypotheses)",
               alternative="fewer scenes per call")
    hyp = binding_hypotheses(n, m)                                   # (H, m, n)
    (xb, cb, tb, tcb), log_s2 = _rescale(xb, cb, tb, tcb)
    if cost == "paper":
        S = cb[:, :, :, None] + tcb[:, None, None, :]               # (B, m, n_j, n_p, d, d)
        D = xb[:, :, :, None] - tb[:, None, None, :]                 # (B, m, n_j, n_p, d)
        q = np.einsum("...k,...k->...", D, np.linalg.solve(S, D[..., None])[..., 0])
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
def grouping_scene(n_targets: int, n_sources: int, *, cov, spacing: float = 1.0,
                   layout: str = "line", track_cov=None, trials: int = 1,
                   rng=None) -> GroupingScene:
    """Draw `trials` scenes of `n_targets` targets reported by `n_sources` sources.

    Parameters
    ----------
    n_targets : int
        Number of targets ``n`` (every source reports every target once).
    n_sources : int
        Number of sources ``m >= 1``.
    cov : array_like, shape (m, n, d, d)
        Error covariance of each report (broadcastable, e.g. ``(m, 1, d, d)``);
        ``d`` is taken from it.
    spacing : float or array_like of shape (d,), optional
        ``"line"``: targets ``spacing`` (its first entry) apart on the first
        coordinate, all other coordinates zero; ``"uniform"``: coordinate ``c``
        of each target uniform on ``[0, spacing[c] * n ** (1 / d)]`` (one target
        per ``prod(spacing)`` of state space) — a vector lets positions and
        velocities have their own scales.
    layout : {"line", "uniform"}, optional
        Target placement.
    track_cov : array_like, shape (n, d, d), optional
        If given, also draw fused-track estimates ``tracks[t, p] = truth[t, p] + e``,
        ``e ~ N(0, track_cov[p])``.
    trials : int, optional
        Number of independent scenes.
    rng : None, int or numpy.random.Generator, optional
        Source of randomness (SPEC 7).

    Returns
    -------
    GroupingScene

    Examples
    --------
    >>> s = grouping_scene(3, 2, cov=np.eye(2)[None, None] * 0.01, trials=4, rng=1)
    >>> s.reports.shape, s.true_groups.shape
    ((4, 2, 3, 2), (4, 3, 2))
    >>> bool(np.all(s.true_groups[..., 0] == np.arange(3)))
    True
    """
    n = as_int(n_targets, "n_targets", minimum=1)
    m = as_int(n_sources, "n_sources", minimum=1)
    trials = as_int(trials, "trials", minimum=1)
    spacing = as_positive(spacing, "spacing")
    layout = as_choice(layout, "layout", ("line", "uniform"))
    c = as_float_array(cov, "cov", ndim_min=4)
    try:
        c = np.broadcast_to(c, (m, n, *c.shape[-2:]))
    except ValueError:
        raise ValueError(
            f"`cov` must broadcast to shape (m, n, d, d) = ({m}, {n}, d, d); "
            f"received shape {np.shape(cov)}"
        ) from None
    c = as_covariance(c, "cov")
    d = c.shape[-1]
    if spacing.ndim > 1 or spacing.size not in (1, d):
        raise ValueError(
            f"`spacing` must be a number or have shape ({d},) (one scale per coordinate); "
            f"received shape {spacing.shape}"
        )
    spacing = np.broadcast_to(spacing.reshape(-1), (d,))
    tcov = None
    if track_cov is not None:
        tcov = as_float_array(track_cov, "track_cov", ndim_min=2)
        try:
            tcov = np.broadcast_to(tcov, (n, d, d))
        except ValueError:
            raise ValueError(
                f"`track_cov` must broadcast to shape ({n}, {d}, {d}); received shape "
                f"{np.shape(track_cov)}"
            ) from None
        tcov = as_covariance(tcov, "track_cov")
    check_size(8 * trials * (4 * m * n * d + 3 * n * d + m * n), MEMORY_LIMIT,
               what=f"bytes of scenes (`trials` = {trials} x {m} sources x {n} targets x d = {d})",
               alternative="several calls with generators spawned from one SeedSequence")
    rng = as_rng(rng)
    if layout == "line":
        truth = np.zeros((trials, n, d))
        truth[..., 0] = spacing[0] * np.arange(n)
    else:
        truth = rng.uniform(0.0, 1.0, size=(trials, n, d)) * (spacing * n ** (1.0 / d))
    owner = rng.permuted(np.broadcast_to(np.arange(n), (trials, m, n)), axis=-1)
    chol = np.linalg.cholesky(c)                                    # (m, n, d, d)
    z = rng.standard_normal((trials, m, n, d))
    src = np.take_along_axis(truth[:, None], owner[..., None], axis=2)   # (T, m, n, d)
    reports = src + np.einsum("ijkl,tijl->tijk", chol, z)
    tracks = None
    if tcov is not None:
        zt = rng.standard_normal((trials, n, d))
        tracks = truth + np.einsum("pkl,tpl->tpk", np.linalg.cholesky(tcov), zt)
    return GroupingScene(truth, reports, owner, np.array(c), tracks,
                         None if tcov is None else np.array(tcov))
