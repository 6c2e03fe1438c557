"""Simulated scenes: n objects seen by two radars, vectorised over trials.

The fusion centre receives from each radar one report per object, with
independent Gaussian errors, in an order that says nothing about which object
produced it. :func:`two_radar_scene` draws many such scenes at once; the
association chapters build on it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validation import as_choice, as_float_array, as_int, as_positive, as_rng

__all__ = ["TwoRadarScene", "two_radar_scene", "nearest_neighbour_pairing",
           "ellipse_covariance"]


@dataclass(frozen=True)
class TwoRadarScene:
    """Reports of two radars about the same objects, for many trials.

    Attributes
    ----------
    truth : numpy.ndarray, shape (trials, n, d)
        True object positions.
    reports1 : numpy.ndarray, shape (trials, n, d)
        Radar 1's reports, ``reports1[t, j]`` produced by object ``j``.
    reports2 : numpy.ndarray, shape (trials, n, d)
        Radar 2's reports in shuffled order.
    owner2 : numpy.ndarray of int, shape (trials, n)
        ``owner2[t, i]`` is the object that produced ``reports2[t, i]``.
    sigma1, sigma2 : float
        Standard deviations of the radars' errors (per coordinate).
    """

    truth: np.ndarray
    reports1: np.ndarray
    reports2: np.ndarray
    owner2: np.ndarray
    sigma1: float
    sigma2: float

    @property
    def true_match(self) -> np.ndarray:
        """``true_match[t, j]``: index in ``reports2[t]`` of object ``j``'s report."""
        return np.argsort(self.owner2, axis=-1)


def two_radar_scene(n_objects: int, *, spacing: float, sigma1: float, sigma2: float,
                    trials: int = 1, dim: int = 1, layout: str = "line",
                    rng=None) -> TwoRadarScene:
    """Draw `trials` independent scenes of `n_objects` seen by two radars.

    Parameters
    ----------
    n_objects : int
        Number of objects, each seen once by each radar (no misses, no false
        reports).
    spacing : float
        ``"line"``: distance between neighbouring objects on the first axis;
        ``"uniform"``: objects uniform in a cube of side
        ``spacing * n_objects ** (1 / dim)`` (mean density one object per
        ``spacing ** dim``).
    sigma1, sigma2 : float
        Error standard deviations of radar 1 and radar 2, per coordinate.
    trials : int, optional
        Number of independent scenes.
    dim : int, optional
        Dimension of the measured position.
    layout : {"line", "uniform"}, optional
        Object placement.
    rng : None, int or numpy.random.Generator, optional
        Source of randomness (SPEC 7).

    Returns
    -------
    TwoRadarScene

    Examples
    --------
    >>> s = two_radar_scene(3, spacing=1.0, sigma1=0.1, sigma2=0.2, trials=5, rng=1)
    >>> s.reports2.shape, s.owner2.shape
    ((5, 3, 1), (5, 3))
    >>> bool(np.all(np.sort(s.owner2, axis=1) == np.arange(3)))
    True
    """
    n = as_int(n_objects, "n_objects", minimum=1)
    trials = as_int(trials, "trials", minimum=1)
    dim = as_int(dim, "dim", minimum=1)
    spacing = float(as_positive(spacing, "spacing"))
    s1 = float(as_positive(sigma1, "sigma1"))
    s2 = float(as_positive(sigma2, "sigma2"))
    layout = as_choice(layout, "layout", ("line", "uniform"))
    rng = as_rng(rng)

    if layout == "line":
        truth = np.zeros((trials, n, dim))
        truth[..., 0] = spacing * np.arange(n)
    else:
        side = spacing * n ** (1.0 / dim)
        truth = rng.uniform(0.0, side, size=(trials, n, dim))
    reports1 = truth + s1 * rng.standard_normal((trials, n, dim))
    owner2 = rng.permuted(np.broadcast_to(np.arange(n), (trials, n)), axis=1)
    truth2 = np.take_along_axis(truth, owner2[..., None], axis=1)
    reports2 = truth2 + s2 * rng.standard_normal((trials, n, dim))
    return TwoRadarScene(truth, reports1, reports2, owner2, s1, s2)


def nearest_neighbour_pairing(reports1, reports2) -> np.ndarray:
    """For each radar-1 report, the index of the nearest radar-2 report.

    The naive rule the book starts from: no gate, no exclusivity (two radar-1
    reports may pick the same radar-2 report).

    Parameters
    ----------
    reports1 : array_like, shape (..., n1, d)
    reports2 : array_like, shape (..., n2, d)

    Returns
    -------
    numpy.ndarray of int, shape (..., n1)

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
    """2-D covariance whose 1-sigma ellipse has semi-axes `major`, `minor`, rotated by `angle`.

    Parameters
    ----------
    angle : float
        Direction of the major axis, radians counter-clockwise from the x axis.
    major, minor : float
        Standard deviations along the major and minor axes (> 0).

    Returns
    -------
    numpy.ndarray, shape (2, 2)
        :math:`R(\\theta)\\,\\mathrm{diag}(a^2, b^2)\\,R(\\theta)^\\mathsf{T}`.

    Examples
    --------
    >>> ellipse_covariance(np.pi / 2, 2.0, 1.0).round(12)
    array([[1., 0.],
           [0., 4.]])
    """
    theta, a, b = (as_float_array(angle, "angle"), as_positive(major, "major"),
                   as_positive(minor, "minor"))
    for name, v in (("angle", theta), ("major", a), ("minor", b)):
        if v.ndim:
            raise TypeError(f"`{name}` must be a scalar; received an array of shape {v.shape}")
    theta, a, b = float(theta), float(a), float(b)
    if a * a == 0 or b * b == 0 or not np.isfinite(a * a):
        raise ValueError(f"`major`, `minor` must square to positive finite variances; "
                         f"received {major!r}, {minor!r}")
    c, s = np.cos(theta), np.sin(theta)
    rot = np.array([[c, -s], [s, c]])
    return rot @ np.diag([a * a, b * b]) @ rot.T
