r"""JPDA association probabilities: exact by enumeration, or from the k best joint events."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..assignment import k_best_two_lists
from ..validation import as_float_array, as_int, check_size, describe

#: Largest number of joint events :func:`jpda_probabilities` enumerates exactly.
MAX_EVENTS = 2_000_000


@dataclass(frozen=True)
class JpdaProbabilities:
    r"""Marginal association probabilities of a cluster of tracks and reports.

    Attributes
    ----------
    probabilities : numpy.ndarray, shape (T, M)
        :math:`\beta_{ij}`: probability that report *j* is track *i*'s.
    miss : numpy.ndarray, shape (T,)
        :math:`\beta_{i0}`: probability that track *i* has no report (rows of
        ``probabilities`` plus ``miss`` sum to 1).
    bound : float
        Proved bound on the error of every probability (0 when exact).
    events : int
        Joint events summed.
    exact : bool
        Every feasible joint event was summed.
    """

    probabilities: np.ndarray
    miss: np.ndarray
    bound: float
    events: int
    exact: bool


def _jpda_iv(ratio, miss, k):
    r = as_float_array(ratio, "ratio", ndim_min=2)
    if r.ndim != 2:
        raise ValueError(f"`ratio` must be a matrix (tracks, reports); received shape {r.shape}")
    if np.any(r < 0):
        raise ValueError(f"`ratio` must be >= 0 (0: report outside the track's gate); received "
                         f"{describe(r)}")
    w = as_float_array(miss, "miss", ndim_min=1)
    if w.shape != (r.shape[0],):
        raise ValueError(f"`miss` must have shape ({r.shape[0]},) (one per track); received "
                         f"shape {w.shape}")
    if np.any(w <= 0):
        raise ValueError(f"`miss` must be > 0 (the weight 1 - P_D P_G of a missed track); "
                         f"received {describe(w)}")
    if k is not None:
        k = as_int(k, "k", minimum=1)
    return r, w, k


def event_bound(ratio) -> int:
    r"""Kernel (trusted input): a bound on the number of joint events.

    :math:`\prod_i (1 + \deg i)`, the degree of track :math:`i` being its number of
    gated reports (positive entries of its row of `ratio`).
    """
    return math.prod(1 + int(c) for c in np.count_nonzero(ratio > 0, axis=1))


def jpda_probabilities(ratio, miss, *, k=None) -> JpdaProbabilities:
    r"""JPDA association probabilities of tracks and reports in one cluster.

    Parameters
    ----------
    ratio : array_like, shape (T, M)
        :math:`\ell_{ij} = P_D\,\mathcal N(\boldsymbol\nu_{ij}; 0, S_{ij})/\lambda`:
        likelihood ratio of report *j* coming from track *i* rather than clutter of
        density :math:`\lambda`; 0 outside the gate.
    miss : array_like, shape (T,)
        Weight of track *i* having no report, :math:`1 - P_DP_G` (> 0).
    k : int, optional
        None (default): exact, every joint event enumerated (refused beyond
        :data:`MAX_EVENTS`). An integer: the `k` best joint events by Murty's
        ranking (:func:`radarfusion_ref.engine.assignment.k_best_two_lists`), with a
        proved error bound.

    Returns
    -------
    JpdaProbabilities

    Raises
    ------
    ValueError
        Negative ratios, weights not positive, wrong shapes, `k` < 1, or too many
        events to enumerate (the message points to `k`).
    TypeError
        If an argument is not numeric.

    Notes
    -----
    A joint event :math:`\theta` gives each track at most one report and each report
    at most one track; its weight is
    :math:`w(\theta) = \prod_{(i,j)\in\theta}\ell_{ij}\prod_{i\ \text{missed}}(1 - P_DP_G)`
    and :math:`\beta_{ij} = \sum_{\theta\ni(i,j)} w(\theta) / \sum_\theta w(\theta)`
    (Fortmann, Bar-Shalom & Scheffe 1983). With ``k``, the events are the
    assignments of the :math:`T \times (M + T)` cost matrix
    :math:`[-\ln\ell \mid \operatorname{diag}(-\ln(1 - P_DP_G))]`; the unseen events
    number at most :math:`N - k` with :math:`N = \prod_i(1 + \deg i)` and weigh at
    most the k-th best each, so every probability is off by at most
    :math:`B/(Z_k + B)`, :math:`B = (N - k)\,w_k`, :math:`Z_k` the sum of the k best.

    Examples
    --------
    >>> r = jpda_probabilities([[2.0, 0.0], [1.0, 1.0]], [1.0, 1.0])
    >>> r.probabilities.round(4).tolist(), r.miss.round(4).tolist()
    ([[0.5714, 0.0], [0.1429, 0.4286]], [0.4286, 0.4286])
    """
    r, w, k = _jpda_iv(ratio, miss, k)
    if k is None:
        check_size(event_bound(r), MAX_EVENTS, what="joint events (upper bound prod(1 + gated "
                   "reports per track))", alternative="jpda_probabilities(ratio, miss, k=...) "
                   "(Murty's k best events with an error bound)")
        return exact_kernel(r, w)
    return kbest_kernel(r, w, k)


def exact_kernel(r, w) -> JpdaProbabilities:
    """Kernel: every joint event, by extension track after track (trusted input)."""
    T, M = r.shape
    with np.errstate(divide="ignore"):
        lr, lw = np.log(r), np.log(w)
    events = np.zeros((1, 0), dtype=np.int64)
    logw = np.zeros(1)
    for i in range(T):
        parts_e = [np.concatenate([events, np.full((events.shape[0], 1), -1)], 1)]
        parts_w = [logw + lw[i]]
        for j in np.flatnonzero(r[i] > 0):
            free = ~np.any(events == j, axis=1)
            parts_e.append(np.concatenate([events[free], np.full((int(free.sum()), 1), j)], 1))
            parts_w.append(logw[free] + lr[i, j])
        events, logw = np.concatenate(parts_e), np.concatenate(parts_w)
    wts = np.exp(logw - logw.max())
    return _marginals(events, wts, T, M, 0.0, True)


def _marginals(events, wts, T, M, bound, exact):
    p = np.zeros((T, M + 1))
    for i in range(T):
        p[i] = np.bincount(np.where(events[:, i] < 0, M, events[:, i]), weights=wts,
                           minlength=M + 1)
    p /= wts.sum()
    return JpdaProbabilities(p[:, :M], p[:, M], float(bound), int(events.shape[0]), exact)


def kbest_kernel(r, w, k) -> JpdaProbabilities:
    """Kernel: the k best joint events and the truncation bound (trusted input)."""
    T, M = r.shape
    cost = np.full((T, M + T), np.inf)
    with np.errstate(divide="ignore"):
        cost[:, :M] = -np.log(r)
    cost[np.arange(T), M + np.arange(T)] = -np.log(w)
    kb = k_best_two_lists(cost, k)
    events = np.where(kb.row_to_col >= M, -1, kb.row_to_col)
    wts = np.exp(-(kb.cost - kb.cost[0]))
    n_up = event_bound(r)
    exact = kb.k < k or kb.k >= n_up
    bound = 0.0 if exact else (n_up - kb.k) * wts[-1] / (wts.sum() + (n_up - kb.k) * wts[-1])
    return _marginals(events, wts, T, M, bound, exact)
