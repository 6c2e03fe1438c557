"""Helpers for callers: the naive nearest-neighbour rule and a covariance from its ellipse."""

from __future__ import annotations

import numpy as np

from .._validation import (
    as_float,
    as_float_array,
    as_positive,
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
        Index in `reports2` of the report nearest (Euclidean) to each radar-1 report.

    Raises
    ------
    ValueError
        If the last dimensions differ, or an input is not finite or has fewer
        than two axes.

    Examples
    --------
    >>> nearest_neighbour_pairing([[0.0], [1.0]], [[0.9], [0.1]])
    array([1, 0])
    """
    r1 = as_float_array(reports1, "reports1", ndim_min=2)
    r2 = as_float_array(reports2, "reports2", ndim_min=2)
    if r1.shape[-1] != r2.shape[-1]:
        raise ValueError(
            "`reports1` and `reports2` must have the same last dimension d; "
            f"received shapes {r1.shape} and {r2.shape}"
        )
    d2 = np.sum((r1[..., :, None, :] - r2[..., None, :, :]) ** 2, axis=-1)
    return np.argmin(d2, axis=-1)


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
