"""Helpers for callers: the naive nearest-neighbour rule and a covariance from its ellipse."""

from __future__ import annotations

import math

import numpy as np

from ..validation import (
    MAX_MAGNITUDE,
    MEMORY_LIMIT,
    as_float,
    as_float_array,
    as_positive,
    check_size,
    describe,
)


# ----------------------------------------------------------------------------- helpers for callers
def nearest_neighbour_pairing(reports1, reports2) -> np.ndarray:
    """For each radar-1 report, the index of the nearest radar-2 report.

    The naive rule the book starts from: no gate, no exclusivity (two radar-1
    reports may pick the same radar-2 report).

    Parameters
    ----------
    reports1 : array_like, shape (..., n1, d)
        Radar 1's reports (leading axes are a batch, e.g. trials).
    reports2 : array_like, shape (..., n2, d)
        Radar 2's reports, the same leading axes and d.

    Returns
    -------
    numpy.ndarray of int, shape (..., n1)
        Index in `reports2` of the report nearest (Euclidean) to each radar-1
        report; of equally near reports, the one with the lowest index.

    Notes
    -----
    Memory stays bounded: small scenes compare every pair (in batches of
    trials), large ones search a k-d tree (:class:`scipy.spatial.cKDTree`,
    megabytes at 10^5 reports where every pair would take tens of GiB) and
    re-score the reports the tree finds within the least distance, so both
    routes give the same indices, ties included.

    Raises
    ------
    ValueError
        If the last dimensions differ or the leading axes do not broadcast, an
        input is not finite, lies outside the numeric domain (a magnitude above
        :data:`radarfusion_ref.engine.validation.MAX_MAGNITUDE`, :math:`2^{150}`,
        whose squared differences could overflow) or has fewer than two axes,
        `reports2` holds no report, or the broadcast scenes exceed
        :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT` (checked before
        anything is allocated).

    Examples
    --------
    >>> nearest_neighbour_pairing([[0.0], [1.0]], [[0.9], [0.1]])
    array([1, 0])
    """
    _pairing_size_iv(np.shape(reports1) if isinstance(reports1, np.ndarray) else None,
                     np.shape(reports2) if isinstance(reports2, np.ndarray) else None)
    r1 = as_float_array(reports1, "reports1", ndim_min=2)
    r2 = as_float_array(reports2, "reports2", ndim_min=2)
    _pairing_size_iv(r1.shape, r2.shape)
    if r1.shape[-1] != r2.shape[-1]:
        raise ValueError(
            "`reports1` and `reports2` must have the same last dimension d; "
            f"received shapes {r1.shape} and {r2.shape}"
        )
    if r2.shape[-2] == 0:
        raise ValueError(f"`reports2` must hold at least one report to be nearest; received "
                         f"shape {r2.shape}")
    for arr, name in ((r1, "reports1"), (r2, "reports2")):
        if arr.size and not float(np.max(np.abs(arr))) <= MAX_MAGNITUDE:
            raise ValueError(
                f"`{name}` must lie within the numeric domain |value| <= 2**150 (about "
                f"1.4e45); received {describe(arr)} (largest magnitude "
                f"{float(np.max(np.abs(arr))):.6g}); change the unit of the coordinates")
    return _nearest(r1, r2)


def _pairing_size_iv(shape1, shape2) -> None:
    """Refuse leading axes that do not broadcast, or scenes beyond the memory limit.

    Run on the arrays' shapes before they are converted or checked (a broadcast view
    may stand for far more reports than it stores), and again after conversion.
    """
    if shape1 is None or shape2 is None or len(shape1) < 2 or len(shape2) < 2:
        return
    try:
        lead = np.broadcast_shapes(shape1[:-2], shape2[:-2])
    except ValueError:
        raise ValueError(f"`reports1` and `reports2` must have leading axes that broadcast; "
                         f"received shapes {shape1} and {shape2}") from None
    (n1, d), n2, m = shape1[-2:], shape2[-2], math.prod(lead)
    check_size(8 * (math.prod(shape1) + math.prod(shape2) + m * (2 * n1 + (n1 + n2) * d)),
               MEMORY_LIMIT,
               what=f"bytes of reports and indices ({m} scenes of {n1} and {n2} reports, "
                    f"d = {d})",
               alternative="slices of the leading (trial) axes of `reports1` and `reports2`")


#: Largest n1 x n2 x d for which one scene's nearest neighbours are found from the
#: dense difference array (8 MiB); larger scenes use a k-d tree.
_DENSE_ELEMENTS = 1 << 20


def _nearest(r1, r2):
    """Nearest neighbours over broadcast leading axes, in bounded memory."""
    lead = np.broadcast_shapes(r1.shape[:-2], r2.shape[:-2])
    (n1, d), n2 = r1.shape[-2:], r2.shape[-2]
    m = math.prod(lead)
    a = np.broadcast_to(r1, (*lead, n1, d)).reshape(m, n1, d)
    b = np.broadcast_to(r2, (*lead, n2, d)).reshape(m, n2, d)
    out = np.empty((m, n1), dtype=np.intp)
    per = n1 * n2 * d
    if per <= _DENSE_ELEMENTS:
        step = max(1, _DENSE_ELEMENTS // max(per, 1))
        for k in range(0, a.shape[0], step):
            out[k:k + step] = _nearest_dense(a[k:k + step], b[k:k + step])
    else:
        for k in range(a.shape[0]):
            out[k] = _nearest_kdtree(a[k], b[k])
    return out.reshape(*lead, n1)


def _nearest_dense(a, b):
    """The defining rule: least squared distance, ties to the lowest index (argmin)."""
    return np.argmin(np.sum((a[..., :, None, :] - b[..., None, :, :]) ** 2, axis=-1), axis=-1)


def _nearest_kdtree(a, b):
    """:func:`_nearest_dense` for one scene through a k-d tree, with the same answer.

    The tree's nearest point bounds the least distance; every point within that
    bound (widened by 1e-9 relative and 1e-150 absolute, far above rounding and
    underflow) is re-scored by the dense formula, and the lowest index among the
    least scores wins, as :func:`numpy.argmin` picks.
    """
    from scipy.spatial import cKDTree

    tree = cKDTree(b)
    _, idx = tree.query(a, k=1)
    bound = np.sqrt(np.sum((a - b[idx]) ** 2, axis=-1))
    near = tree.query_ball_point(a, bound * (1 + 1e-9) + 1e-150)
    out = np.asarray(idx, dtype=np.intp)
    for i, cand in enumerate(near):
        if len(cand) > 1:
            cand = np.sort(cand)
            out[i] = cand[np.argmin(np.sum((a[i] - b[cand]) ** 2, axis=-1))]
    return out


def ellipse_covariance(angle, major, minor) -> np.ndarray:
    r"""2-D covariance whose 1-sigma ellipse has semi-axes `major`, `minor`, rotated by `angle`.

    Parameters
    ----------
    angle : float
        Direction of the major axis, radians counter-clockwise from the x axis.
    major, minor : float
        Standard deviations along the major and minor axes (> 0).

    Returns
    -------
    numpy.ndarray, shape (2, 2)
        :math:`R(\theta)\,\mathrm{diag}(a^2, b^2)\,R(\theta)^\mathsf{T}`.

    Examples
    --------
    >>> ellipse_covariance(np.pi / 2, 2.0, 1.0).round(12)
    array([[1., 0.],
           [0., 4.]])
    """
    theta = as_float(angle, "angle")
    a, b = (as_float(as_positive(v, n), n) for v, n in ((major, "major"), (minor, "minor")))
    if a * a == 0 or b * b == 0 or not np.isfinite(a * a):
        raise ValueError(f"`major`, `minor` must square to positive finite variances; "
                         f"received {major!r}, {minor!r}")
    c, s = np.cos(theta), np.sin(theta)
    rot = np.array([[c, -s], [s, c]])
    return rot @ np.diag([a * a, b * b]) @ rot.T
