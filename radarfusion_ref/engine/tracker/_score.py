r"""The track score: a log-likelihood ratio, Wald's sequential test on it, and M-of-N logic."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..validation import as_float, as_float_array, as_int, as_positive, as_probability, describe


@dataclass(frozen=True)
class SprtThresholds:
    r"""Wald's thresholds of the track score.

    Attributes
    ----------
    lower : float
        :math:`T_1 = \ln\frac{\beta}{1 - \alpha}`: delete a tentative track at or below it.
    upper : float
        :math:`T_2 = \ln\frac{1 - \beta}{\alpha}`: confirm a track at or above it.
    """

    lower: float
    upper: float


def sprt_thresholds(p_false_confirm, p_false_delete) -> SprtThresholds:
    r"""Wald's confirmation and deletion thresholds from the design rates.

    Parameters
    ----------
    p_false_confirm : float
        Design probability of confirming a false track, in (0, 1).
    p_false_delete : float
        Design probability of deleting a true track, in (0, 1);
        :math:`\alpha + \beta < 1`.

    Returns
    -------
    SprtThresholds

    Raises
    ------
    ValueError
        If a probability is outside (0, 1) or :math:`\alpha + \beta \ge 1`
        (the thresholds would be in the wrong order).
    TypeError
        If an argument is not a number.

    Notes
    -----
    Wald (1945): the test that stops when the log-likelihood ratio leaves
    :math:`(T_1, T_2)` has error rates :math:`\alpha' \le \alpha/(1-\beta)`
    and :math:`\beta' \le \beta/(1-\alpha)`, with equality when the score
    does not overshoot. Blackman & Popoli (1999), sec. 6.2.

    Examples
    --------
    >>> t = sprt_thresholds(1e-3, 0.1)
    >>> round(t.lower, 4), round(t.upper, 4)
    (-2.3016, 6.8024)
    """
    a = as_float(as_probability(p_false_confirm, "p_false_confirm"), "p_false_confirm")
    b = as_float(as_probability(p_false_delete, "p_false_delete"), "p_false_delete")
    if a + b >= 1:
        raise ValueError(f"`p_false_confirm` + `p_false_delete` must be < 1 (else the deletion "
                         f"threshold is not below the confirmation "
                         f"threshold); received p_false_confirm={a!r}, p_false_delete={b!r}")
    lower = math.log(b / (1 - a))          # T1 = ln(beta / (1 - alpha))
    upper = math.log((1 - b) / a)          # T2 = ln((1 - beta) / alpha)
    return SprtThresholds(lower, upper)


def score_increments(statistic, log_det, *, p_detection, clutter_density, dim=3):
    r"""Track-score increments of reports that update a track.

    Parameters
    ----------
    statistic : array_like
        :math:`d^2 = \boldsymbol\nu^\mathsf T S^{-1}\boldsymbol\nu` of each report.
    log_det : array_like
        :math:`\ln\det S` of each innovation covariance (S in the report's units).
    p_detection : float
        :math:`P_D` in (0, 1).
    clutter_density : float
        :math:`\beta_{FT}`, false reports per unit volume per scan, > 0.
    dim : int, optional
        Dimension :math:`m` of a report (default 3):
        :math:`\ln\det(2\pi S) = m\ln 2\pi + \ln\det S`.

    Returns
    -------
    numpy.ndarray
        :math:`\Delta L = \ln\frac{P_D\, \mathcal N(\boldsymbol\nu; 0, S)}{\beta_{FT}}`;
        a missed detection adds :math:`\ln(1 - P_D)`.

    Raises
    ------
    ValueError
        Non-finite input, a probability outside (0, 1) or a density not positive.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    The score is the log of the likelihood ratio of "a target" to "false reports"
    for the reports a track has taken (Sittler 1964; Blackman & Popoli 1999, eq. 6.13).

    Examples
    --------
    >>> round(float(score_increments(0.0, 0.0, p_detection=0.5, clutter_density=1.0)), 4)
    -3.45
    """
    d2 = as_positive(statistic, "statistic", strict=False)
    ld = as_float_array(log_det, "log_det")
    pd = as_float(as_probability(p_detection, "p_detection"), "p_detection")
    lam = as_float(as_positive(clutter_density, "clutter_density"), "clutter_density")
    try:
        np.broadcast_shapes(d2.shape, ld.shape)
    except ValueError:
        raise ValueError(f"`statistic`, `log_det` must broadcast; received shapes {d2.shape}, "
                         f"{ld.shape}") from None
    return increments_kernel(d2, ld, pd, lam, as_int(dim, "dim", minimum=1))


def increments_kernel(d2, log_det, pd, lam, m=3):
    """Kernel of :func:`score_increments` (trusted input)."""
    return math.log(pd / lam) - 0.5 * (d2 + log_det + m * math.log(2 * math.pi))


def m_of_n(hits, m, n):
    r"""M-of-N confirmation: the first update at which `m` of the last `n` were hits.

    Parameters
    ----------
    hits : array_like of bool, shape (..., K)
        Per track (leading axes), per scan: whether the track was updated (True)
        or missed (False).
    m, n : int
        :math:`1 \le m \le n`.

    Returns
    -------
    numpy.ndarray of int, shape (...)
        Index of the scan at which the track is confirmed, or -1 if it never is.

    Raises
    ------
    ValueError
        If `m` is not in 1..`n`.
    TypeError
        If `hits` is not boolean or `m`, `n` not integers.

    Examples
    --------
    >>> m_of_n([[True, False, True, True], [True, False, False, True]], 2, 3).tolist()
    [2, -1]
    """
    if isinstance(hits, (str, bytes)) or hits is None:
        raise TypeError(f"`hits` must be an array of booleans; received {describe(hits)}")
    try:
        h = np.asarray(hits)
    except (TypeError, ValueError):
        raise TypeError(f"`hits` must be an array of booleans; received {describe(hits)}") from None
    if h.dtype != bool or h.ndim < 1:
        raise TypeError(f"`hits` must be an array of booleans with at least one axis; received "
                        f"{describe(hits)}")
    n = as_int(n, "n", minimum=1)
    m = as_int(m, "m", minimum=1, maximum=n)
    K = h.shape[-1]
    recent = np.zeros((*h.shape[:-1], min(n, K)), dtype=bool)   # a window past K: all K
    first = np.full(h.shape[:-1], -1, dtype=np.int64)
    for k in range(K):
        recent = window_kernel(recent, h[..., k], True)
        first[(first < 0) & (np.count_nonzero(recent, axis=-1) >= m)] = k
    return first


def window_kernel(recent, hit, counted):
    """Kernel of M-of-N (trusted input): the last n scored outcomes `recent` (..., n),
    oldest first, moved on by one scan where `counted` (bool, broadcast), `hit` newest.
    Their count of True is the number of hits in the last n scored scans; the tracker
    and :func:`m_of_n` both keep their window with it."""
    moved = np.concatenate([recent[..., 1:], np.asarray(hit)[..., None]], axis=-1)
    return np.where(np.asarray(counted)[..., None], moved, recent)
