"""The book's plotting look, and drawing helpers shared by the chapters.

Rules: every helper draws into an ``ax`` it is given and returns it; none
calls ``plt.show()``, and none simulates anything — helpers take results
computed elsewhere in the package.
"""

from __future__ import annotations

from contextlib import contextmanager

import matplotlib as mpl
import numpy as np

from .montecarlo import MeanEstimate, Proportion

__all__ = [
    "BOOK_STYLE",
    "SENSOR_COLORS",
    "use_book_style",
    "book_style",
    "plot_proportion",
    "plot_mean",
    "plot_reports",
    "plot_density",
    "plot_covariance_ellipse",
    "plot_groups",
]

#: Colours by role, used consistently across chapters.
SENSOR_COLORS = {"radar1": "#1f77b4", "radar2": "#d62728", "fused": "#2ca02c",
                 "truth": "#222222", "theory": "#222222", "mc": "#ff7f0e"}

#: rcParams of the book's look.
BOOK_STYLE = {
    "figure.figsize": (7.0, 3.6),
    "figure.dpi": 96,
    "savefig.dpi": 96,
    "figure.autolayout": True,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.titlesize": 11,
    "axes.labelsize": 10,
    "legend.fontsize": 9,
    "legend.frameon": False,
    "xtick.labelsize": 9,
    "ytick.labelsize": 9,
    "lines.linewidth": 1.8,
    "image.cmap": "viridis",
    "animation.embed_limit": 8.0,
}


def use_book_style() -> None:
    """Apply the book's look to all later figures (call once per chapter)."""
    mpl.rcParams.update(BOOK_STYLE)


@contextmanager
def book_style():
    """Context manager form of :func:`use_book_style`."""
    with mpl.rc_context(BOOK_STYLE):
        yield


def plot_proportion(ax, x, p: Proportion, *, label=None, color=None, theory=None,
                    theory_label="exact"):
    """Monte-Carlo proportions with their confidence band, optionally against theory.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    x : array_like
        Abscissae, one per entry of ``p.estimate``.
    p : Proportion
        Vector-valued result of :func:`radarfusion_ref.montecarlo.proportion`.
    label, color : optional
        Legend label (the trial count is appended) and colour.
    theory : array_like, optional
        Exact values drawn as a line at the same abscissae.
    """
    x = np.asarray(x)
    color = color or SENSOR_COLORS["mc"]
    lbl = None if label is None else f"{label} (MC, n={p.trials})"
    ax.plot(x, p.estimate, "o", ms=4, color=color, label=lbl)
    ax.fill_between(x, p.low, p.high, color=color, alpha=0.25, lw=0)
    if theory is not None:
        ax.plot(x, theory, "-", color=SENSOR_COLORS["theory"], lw=1.2, label=theory_label)
    return ax


def plot_mean(ax, x, m: MeanEstimate, *, label=None, color=None):
    """Monte-Carlo means with confidence bars."""
    x = np.asarray(x)
    color = color or SENSOR_COLORS["mc"]
    err = np.vstack([np.asarray(m.estimate) - m.low, np.asarray(m.high) - m.estimate])
    lbl = None if label is None else f"{label} (n={m.trials})"
    ax.errorbar(x, m.estimate, yerr=err, fmt="o", ms=4, capsize=2, color=color, label=lbl)
    return ax


def plot_reports(ax, xy1, xy2, *, truth=None, pairs=None, true_pairs=None,
                 labels=("radar 1", "radar 2")):
    """Reports of two radars in the plane, with optional truth and pairing lines.

    Parameters
    ----------
    xy1, xy2 : array_like, shape (n1, 2) and (n2, 2)
        Report positions.
    truth : array_like, shape (n, 2), optional
        True object positions.
    pairs : iterable of (i, j), optional
        Association decisions, drawn as segments from ``xy1[i]`` to ``xy2[j]``.
    true_pairs : iterable of (i, j), optional
        The correct pairs. When given, decided pairs not among them are drawn
        thick and red, so wrong decisions stand out.
    """
    xy1, xy2 = np.atleast_2d(xy1), np.atleast_2d(xy2)
    if truth is not None:
        t = np.atleast_2d(truth)
        ax.plot(t[:, 0], t[:, 1], "x", color=SENSOR_COLORS["truth"], ms=7, label="truth")
    ax.plot(xy1[:, 0], xy1[:, 1], "o", mfc="none", color=SENSOR_COLORS["radar1"], label=labels[0])
    ax.plot(xy2[:, 0], xy2[:, 1], "s", mfc="none", color=SENSOR_COLORS["radar2"], label=labels[1])
    correct = None if true_pairs is None else {(int(i), int(j)) for i, j in true_pairs}
    for i, j in pairs or ():
        wrong = correct is not None and (int(i), int(j)) not in correct
        ax.plot([xy1[i, 0], xy2[j, 0]], [xy1[i, 1], xy2[j, 1]], "-",
                color="red" if wrong else "0.4", lw=2 if wrong else 1)
    ax.set_aspect("equal", adjustable="datalim")
    return ax


def plot_covariance_ellipse(ax, mean, cov, *, n_sigma: float = 2.0, **kwargs):
    """The ``n_sigma`` ellipse of a 2-D Gaussian: ``(x - mean)' cov^-1 (x - mean) = n_sigma**2``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    mean : array_like, shape (2,)
    cov : array_like, shape (2, 2)
        Symmetric positive-definite covariance.
    n_sigma : float, optional
        Scale of the ellipse in standard deviations (default 2).
    **kwargs
        Passed to :class:`matplotlib.patches.Ellipse` (``fill=False`` by default).

    Notes
    -----
    The semi-axes are ``n_sigma * sqrt(eigenvalues)`` along the eigenvectors of
    `cov`.
    """
    from matplotlib.patches import Ellipse

    from ._validation import as_covariance, as_float_array

    mean = as_float_array(mean, "mean", last_dims=(2,))
    cov = as_covariance(cov, "cov", dim=2)
    vals, vecs = np.linalg.eigh(cov)
    angle = np.degrees(np.arctan2(vecs[1, 1], vecs[0, 1]))
    kwargs.setdefault("fill", False)
    patch = Ellipse(tuple(mean), 2 * n_sigma * np.sqrt(vals[1]), 2 * n_sigma * np.sqrt(vals[0]),
                    angle=angle, **kwargs)
    ax.add_patch(patch)
    return ax


def plot_density(ax, x, pdf, *, samples=None, bins=60, label=None, color=None):
    """A density curve, optionally over a normalised histogram of samples."""
    color = color or SENSOR_COLORS["theory"]
    if samples is not None:
        ax.hist(np.asarray(samples).ravel(), bins=bins, density=True, alpha=0.35,
                color=SENSOR_COLORS["mc"], label=f"MC (n={np.size(samples)})")
    ax.plot(x, pdf, color=color, label=label)
    return ax


def plot_groups(ax, x, cov, groups, correct=None, *, truth=None, colors=None,
                markers="os^vD<>ph"):
    """Reports of `m` sources with 1-sigma ellipses, and the groups formed from them.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    x : array_like, shape (m, n, >= 2)
        Report ``j`` of source ``i`` (the first two coordinates are drawn).
    cov : array_like, shape (m, n, d, d)
        Their covariances (the upper-left 2x2 block is drawn).
    groups : array_like of int, shape (g, m)
        Each row picks one report of every source (a grouping's ``groups``).
    correct : array_like of bool, shape (g,), optional
        Which groups are right; wrong groups are drawn thick and red.
    truth : array_like, shape (n, >= 2), optional
        True positions.
    colors : sequence, optional
        One colour per source (matplotlib's cycle by default).
    """
    x = np.asarray(x, dtype=float)
    cov = np.asarray(cov, dtype=float)
    groups = np.asarray(groups, dtype=int)
    m, n = x.shape[:2]
    colors = colors or [f"C{i}" for i in range(m)]
    correct = np.ones(len(groups), bool) if correct is None else np.asarray(correct, bool)
    for i in range(m):
        for j in range(n):
            plot_covariance_ellipse(ax, x[i, j, :2], cov[i, j, :2, :2], n_sigma=1.0, lw=0.5,
                                    color=colors[i], alpha=0.5)
        ax.plot(x[i, :, 0], x[i, :, 1], markers[i % len(markers)], mfc="none",
                color=colors[i], ms=5, label=f"source {i + 1}")
    for g, ok in zip(groups, correct, strict=True):
        pts = x[np.arange(m), g, :2]
        centre = pts.mean(axis=0)
        for pnt in pts:
            ax.plot([centre[0], pnt[0]], [centre[1], pnt[1]], "-",
                    color=SENSOR_COLORS["fused"] if ok else "red", lw=1.2 if ok else 2.0)
    if truth is not None:
        t = np.asarray(truth, dtype=float)
        ax.plot(t[:, 0], t[:, 1], "x", color=SENSOR_COLORS["truth"], ms=5, label="truth")
    ax.set_aspect("equal", adjustable="datalim")
    return ax
