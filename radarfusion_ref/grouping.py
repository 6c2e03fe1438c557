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
from scipy import sparse
from scipy.optimize import Bounds, LinearConstraint, linprog, milp

from ._validation import (
    MEMORY_LIMIT,
    as_bool,
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
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
        ``"bruteforce"`` (enumeration of all groupings) or ``"milp"`` (the
        integer program of :func:`group_sd`).
    relaxation_integral : bool or numpy.ndarray of bool or None
        For ``"milp"``: whether the integer program's LP relaxation already had
        an integral optimum (so no branching was needed). ``None`` for
        ``"bruteforce"``.
    """

    groups: np.ndarray
    cost: np.ndarray | float
    cost_kind: str
    method: str
    relaxation_integral: np.ndarray | bool | None = None


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


def group_sd(x, cov, *, cost: str = "ml", relaxation: bool = True,
             time_limit: float | None = None) -> GroupingResult:
    """Best grouping, exactly, as an S-D assignment integer program (HiGHS).

    Parameters
    ----------
    x : array_like, shape (..., m, n, d)
        Reports (see :func:`group_costs`); leading axes are solved one scene at a time.
    cov : array_like, shape (..., m, n, d, d)
        Their covariances (broadcastable).
    cost : {"ml", "pairwise"}, optional
        Group cost (see :func:`group_costs`).
    relaxation : bool, optional
        Solve the LP relaxation first (default) and accept its solution when it
        is integral — it is then optimal for the integer program too; otherwise
        (or with ``relaxation=False``) run HiGHS branch and bound
        (:func:`scipy.optimize.milp`) with a zero optimality gap.
    time_limit : float, optional
        Seconds allowed to branch and bound per scene; if HiGHS cannot prove
        optimality in time a :class:`RuntimeError` is raised (never a silently
        suboptimal answer).

    Returns
    -------
    GroupingResult
        ``groups`` of shape ``(..., n, m)``, total ``cost``, ``method="milp"``,
        and ``relaxation_integral`` per scene.

    Raises
    ------
    ValueError
        For bad input (see :func:`group_costs`), or more than
        :data:`MAX_CANDIDATE_GROUPS` candidate groups :math:`n^m` per scene.
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

    References
    ----------
    Sonar paper (2013), eqs. (24)–(26); Deb et al. (1997).

    Examples
    --------
    >>> x = np.array([[[0.0], [5.0]], [[5.3], [0.1]], [[0.2], [4.9]]])
    >>> r = group_sd(x, np.ones((3, 2, 1, 1)))
    >>> r.groups.tolist(), r.method
    ([[0, 1, 0], [1, 0, 1]], 'milp')
    """
    cost = as_choice(cost, "cost", _COSTS)
    relaxation = as_bool(relaxation, "relaxation")
    if time_limit is not None:
        time_limit = float(as_positive(time_limit, "time_limit"))
    xb, cb, batch = _reports_iv(x, cov)
    B, m, n, _ = xb.shape
    check_size(n**m, MAX_CANDIDATE_GROUPS,
               what=f"candidate groups n**m = {n}**{m} of one scene (`x` with m = {m}, n = {n})",
               alternative="a gate on the candidate groups or Lagrangian relaxation "
                           "(Deb et al. 1997), or splitting the scene into clusters")
    groups = np.empty((B, n, m), dtype=np.int64)
    totals = np.empty(B)
    integral = np.zeros(B, dtype=bool)
    for b in range(B):
        c_raw = _tensor(xb[b:b + 1], cb[min(b, cb.shape[0] - 1):][:1], cost).ravel()
        try:
            chosen, integral[b] = _sd_solve(c_raw, m, n, relaxation=relaxation,
                                            time_limit=time_limit)
        except RuntimeError as exc:
            raise RuntimeError(f"scene {b}: {exc}") from None
        groups[b] = _normalise(np.array(np.unravel_index(chosen, (n,) * m)).T)
        totals[b] = c_raw[chosen].sum()
        if not np.isfinite(totals[b]):
            raise ValueError(
                f"`x` and `cov`: scene {b}: the total cost of the best grouping overflows "
                "the floating-point range; split the scene or gate the candidate groups first"
            )
    groups = groups.reshape(*batch, n, m)
    cost_out = totals.reshape(batch)
    integral = integral.reshape(batch)
    if not batch:
        return GroupingResult(groups, float(cost_out), cost, "milp", bool(integral))
    return GroupingResult(groups, cost_out, cost, "milp", integral)


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
