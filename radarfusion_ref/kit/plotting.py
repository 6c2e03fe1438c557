"""The book's plotting look, and drawing helpers shared by the chapters.

Rules: every helper draws into an ``ax`` it is given and returns it; none
calls ``plt.show()``, and none simulates anything — helpers take results
computed elsewhere in the package.
"""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import contextmanager

import matplotlib as mpl
import numpy as np

from ..engine.montecarlo import MeanEstimate, Proportion
from ..engine.validation import (
    as_covariance,
    as_float,
    as_float_array,
    as_int,
    as_positive,
    describe,
)

__all__ = [
    "BOOK_STYLE",
    "SENSOR_COLORS",
    "TEXT_COLUMN_PX",
    "use_book_style",
    "book_style",
    "plot_proportion",
    "plot_mean",
    "plot_reports",
    "plot_density",
    "plot_covariance_ellipse",
    "plot_groups",
    "plot_scene",
    "plot_fusion_centre",
]

#: Colours by role, used consistently across chapters.
SENSOR_COLORS = {"radar1": "#1f77b4", "radar2": "#d62728", "fused": "#2ca02c",
                 "truth": "#222222", "theory": "#222222", "mc": "#ff7f0e"}

#: Width of the book's text column at a 1 280 px window, in CSS pixels (measured on the
#: built pages); a figure this wide in inches × 96 is shown at its own size.
TEXT_COLUMN_PX = 688

#: rcParams of the book's look. The default figure is as wide as the text column
#: (7.2 in), so its text is shown at its nominal size: with 120-dpi pixels scaled down
#: to the column, 1 pt of figure text displays as 688 / (7.2 × 96) ≈ 1.0 pt, and the
#: smallest text the style sets (10 pt: ticks, legends) stays above 9 pt on figures up
#: to 8 in wide. Wider figures (players) go in a cell tagged ``full-width``.
BOOK_STYLE = {
    "figure.figsize": (7.2, 4.0),
    "figure.dpi": 120,
    "savefig.dpi": 120,
    "figure.autolayout": True,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "font.size": 10.5,
    "axes.titlesize": 12,
    "axes.labelsize": 11,
    "legend.fontsize": 10,
    "legend.title_fontsize": 10,
    "legend.frameon": False,
    "xtick.labelsize": 10,
    "ytick.labelsize": 10,
    "figure.titlesize": 12,
    "lines.linewidth": 1.8,
    "image.cmap": "viridis",
    "animation.embed_limit": 8.0,
}


def _as_axes(ax, name: str = "ax"):
    """`ax` itself if it is a matplotlib Axes, else a TypeError naming it."""
    from matplotlib.axes import Axes

    if not isinstance(ax, Axes):
        raise TypeError(f"`{name}` must be a matplotlib.axes.Axes (e.g. from plt.subplots()); "
                        f"received {describe(ax)}")
    return ax


def _as_result(value, cls, name: str, producer: str):
    """`value` itself if it is a `cls` result object, else a TypeError naming it."""
    if not isinstance(value, cls):
        raise TypeError(f"`{name}` must be a {cls.__name__} (from {producer}); "
                        f"received {describe(value)}")
    return value


def _abscissae(x, estimate, name: str = "x") -> np.ndarray:
    """Finite abscissae with one entry per estimate (a scalar estimate takes one)."""
    x = as_float_array(x, name)
    want = np.shape(estimate) or (1,)
    if np.shape(x) not in (want, ()) or (np.ndim(x) == 0 and want != (1,)):
        raise ValueError(f"`{name}` must have one entry per estimate, shape {want}; "
                         f"received shape {np.shape(x)}")
    return x


def _points(value, name: str, *, dim: int = 2) -> np.ndarray:
    """Finite points, shape (n, >= dim) (a single point may be given as shape (dim,))."""
    arr = np.atleast_2d(as_float_array(value, name, ndim_min=1))
    if arr.ndim != 2 or arr.shape[-1] < dim:
        raise ValueError(f"`{name}` must have shape (n, {dim}); received shape {arr.shape}")
    return arr


def _color(value, name: str):
    """None or a matplotlib colour."""
    from matplotlib.colors import is_color_like

    if value is not None and not is_color_like(value):
        raise ValueError(f"`{name}` must be a matplotlib colour or None; "
                         f"received {describe(value)}")
    return value


def use_book_style() -> None:
    """Apply the book's look to all later figures and sympy results (call once per chapter).

    Figures take :data:`BOOK_STYLE`; a sympy expression a cell displays is
    printed by :func:`radarfusion_ref.kit.symbolic.latex` (``ln``, Greek
    subscripts, positive terms first).
    """
    mpl.rcParams.update(BOOK_STYLE)
    from importlib.util import find_spec

    if find_spec("sympy") is None:          # the book's extra is not installed
        return
    from .symbolic import use_book_printing

    use_book_printing()


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
        Vector-valued result of :func:`radarfusion_ref.engine.montecarlo.proportion`.
    label, color : optional
        Legend label (the trial count is appended) and colour.
    theory : array_like, optional
        Exact values drawn as a line at the same abscissae.

    Raises
    ------
    TypeError
        If `ax` is not a matplotlib Axes or `p` not a ``Proportion``.
    ValueError
        If `x` or `theory` do not have one finite entry per estimate.
    """
    ax = _as_axes(ax)
    p = _as_result(p, Proportion, "p", "radarfusion_ref.engine.montecarlo.proportion")
    x = _abscissae(x, p.estimate)
    if theory is not None:
        theory = _abscissae(theory, p.estimate, "theory")
    color = _color(color, "color") or SENSOR_COLORS["mc"]
    lbl = None if label is None else f"{label} (MC, n={p.trials})"
    ax.plot(x, p.estimate, "o", ms=4, color=color, label=lbl)
    ax.fill_between(x, p.low, p.high, color=color, alpha=0.25, lw=0)
    if theory is not None:
        ax.plot(x, theory, "-", color=SENSOR_COLORS["theory"], lw=1.2, label=theory_label)
    return ax


def plot_mean(ax, x, m: MeanEstimate, *, label=None, color=None):
    """Monte-Carlo means with confidence bars.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    x : array_like
        Abscissae, one per entry of ``m.estimate``.
    m : MeanEstimate
        Result of :func:`radarfusion_ref.engine.montecarlo.mean`.
    label, color : optional
        Legend label (the sample count is appended) and colour.

    Raises
    ------
    TypeError
        If `ax` is not a matplotlib Axes or `m` not a ``MeanEstimate``.
    ValueError
        If `x` does not have one finite entry per estimate.
    """
    ax = _as_axes(ax)
    m = _as_result(m, MeanEstimate, "m", "radarfusion_ref.engine.montecarlo.mean")
    x = _abscissae(x, m.estimate)
    color = _color(color, "color") or SENSOR_COLORS["mc"]
    err = np.vstack([np.asarray(m.estimate) - m.low, np.asarray(m.high) - m.estimate])
    lbl = None if label is None else f"{label} (n={m.trials})"
    ax.errorbar(x, m.estimate, yerr=err, fmt="o", ms=4, capsize=2, color=color, label=lbl)
    return ax


def plot_reports(ax, xy1, xy2, *, truth=None, pairs=None, true_pairs=None,
                 labels=("radar 1", "radar 2")):
    """Reports of two radars in the plane, with optional truth and pairing lines.

    Parameters
    ----------
    xy1, xy2 : array_like, shape (n1, d) and (n2, d), d >= 2
        Report positions (the first two coordinates are drawn).
    truth : array_like, shape (n, 2), optional
        True object positions.
    pairs : iterable of (i, j), optional
        Association decisions, drawn as segments from ``xy1[i]`` to ``xy2[j]``
        (a pair with a negative index, "no partner", is not drawn).
    true_pairs : iterable of (i, j), optional
        The correct pairs. When given, decided pairs not among them are drawn
        thick and red, so wrong decisions stand out.

    Raises
    ------
    TypeError
        If `ax` is not a matplotlib Axes or an argument is not numeric.
    ValueError
        If a point array is not of shape (n, 2) and finite, or a pair's index
        is not a valid report index.
    """
    ax = _as_axes(ax)
    xy1, xy2 = _points(xy1, "xy1"), _points(xy2, "xy2")
    pairs = _pairs(pairs, "pairs", len(xy1), len(xy2))
    true_pairs = None if true_pairs is None else _pairs(true_pairs, "true_pairs",
                                                        len(xy1), len(xy2))
    if isinstance(labels, str) or len(labels) != 2:
        raise ValueError(f"`labels` must be two strings; received {describe(labels)}")
    if truth is not None:
        t = _points(truth, "truth")
        ax.plot(t[:, 0], t[:, 1], "x", color=SENSOR_COLORS["truth"], ms=7, label="truth")
    ax.plot(xy1[:, 0], xy1[:, 1], "o", mfc="none", color=SENSOR_COLORS["radar1"], label=labels[0])
    ax.plot(xy2[:, 0], xy2[:, 1], "s", mfc="none", color=SENSOR_COLORS["radar2"], label=labels[1])
    correct = None if true_pairs is None else {(int(i), int(j)) for i, j in true_pairs}
    for i, j in pairs:
        wrong = correct is not None and (int(i), int(j)) not in correct
        ax.plot([xy1[i, 0], xy2[j, 0]], [xy1[i, 1], xy2[j, 1]], "-",
                color="red" if wrong else "0.4", lw=2 if wrong else 1)
    ax.set_aspect("equal", adjustable="datalim")
    return ax


def _pairs(value, name: str, n1: int, n2: int) -> list[tuple[int, int]]:
    """Index pairs ``(i, j)`` with ``0 <= i < n1`` and ``0 <= j < n2``."""
    if value is None:
        return []
    arr = np.asarray(list(value) if not isinstance(value, np.ndarray) else value)
    if arr.size == 0:
        return []
    if arr.dtype.kind not in "iu" or arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"`{name}` must be integer index pairs (i, j), shape (k, 2); "
                         f"received {describe(value)}")
    arr = arr[(arr[:, 0] >= 0) & (arr[:, 1] >= 0)]      # a negative index: no partner
    bad = (arr[:, 0] >= n1) | (arr[:, 1] >= n2)
    if np.any(bad):
        raise ValueError(f"`{name}` must index existing reports (i < {n1}, j < {n2}); "
                         f"received {describe(arr[bad][:3])}")
    return [(int(i), int(j)) for i, j in arr]


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

    Raises
    ------
    TypeError
        If `ax` is not a matplotlib Axes or an argument is not numeric.
    ValueError
        If `mean` is not a finite 2-vector, `cov` not a symmetric
        positive-definite 2x2 matrix or `n_sigma` not a positive number.

    Notes
    -----
    The semi-axes are ``n_sigma * sqrt(eigenvalues)`` along the eigenvectors of
    `cov`.
    """
    from matplotlib.patches import Ellipse

    ax = _as_axes(ax)
    mean = as_float_array(mean, "mean", last_dims=(2,))
    if mean.shape != (2,):
        raise ValueError(f"`mean` must have shape (2,); received shape {mean.shape}")
    cov = as_covariance(cov, "cov", dim=2)
    if cov.shape != (2, 2):
        raise ValueError(f"`cov` must have shape (2, 2); received shape {cov.shape}")
    n_sigma = as_float(as_positive(n_sigma, "n_sigma"), "n_sigma")
    vals, vecs = np.linalg.eigh(cov)
    angle = np.degrees(np.arctan2(vecs[1, 1], vecs[0, 1]))
    kwargs.setdefault("fill", False)
    patch = Ellipse(tuple(mean), 2 * n_sigma * np.sqrt(vals[1]), 2 * n_sigma * np.sqrt(vals[0]),
                    angle=angle, **kwargs)
    ax.add_patch(patch)
    return ax


def plot_scene(ax, *, sensors=None, reports=(), covariances=(), labels=(), truth=None,
               n_sigma: float = 2.0, equal: bool = True, legend: bool = True,
               colors=None, scene=None, trial: int = 0):
    """The picture of a fusion problem: radar sites, each source's reports and error ellipses.

    Chapters draw it before their first equation, so the reader sees what the
    mathematics is about. Each source ``k`` (a radar) gets one colour and one
    marker for its reports and their ``n_sigma`` error ellipses.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
        Axes to draw into.
    sensors : array_like, shape (s, 2) or (2,), optional
        Positions of the radar sites, drawn as filled triangles (in the colour
        of source ``k`` when there is one site per source).
    reports : sequence of array_like, each of shape (n_k, d) or (d,)
        The reports of each source, ``d`` = 1 or 2 (for ``d`` > 2 the first
        two coordinates are drawn). With ``d`` = 1 the reports of source
        ``k`` are drawn on the horizontal row ``y = -k`` and their error
        intervals as horizontal bars.
    covariances : sequence of array_like, optional
        Empty (no ellipses) or one entry per source: a ``(d, d)`` covariance
        shared by all of its reports, or ``(n_k, d, d)``, one per report
        (symmetric positive definite).
    labels : sequence of str, optional
        Legend label of each source (default ``"radar 1"``, ``"radar 2"``, ...).
    truth : array_like, shape (n, d) or (d,), optional
        True object positions, drawn as black crosses (vertical dotted lines
        when ``d`` = 1).
    n_sigma : float, optional
        Scale of the ellipses in standard deviations (default 2).
    equal : bool, optional
        Equal aspect (default ``True``; ignored when ``d`` = 1).
    legend : bool, optional
        Draw a legend inside the axes (default ``True``).
    colors : sequence, optional
        One colour per source (the book's radar colours by default).
    scene : radarfusion_ref.engine.scenes.TwoRadarScene, optional
        Shortcut: draw trial `trial` of a simulated scene (its two sources'
        reports, their ``sigma**2 I`` covariances and the truth). Cannot be
        combined with `reports`, `covariances` or `truth`.
    trial : int, optional
        Which trial of `scene` to draw (default 0).

    Returns
    -------
    matplotlib.axes.Axes

    Raises
    ------
    TypeError
        If `ax` is not a matplotlib Axes, `scene` is not a ``TwoRadarScene``,
        or an argument is not numeric.
    ValueError
        If shapes disagree, a covariance is not symmetric positive definite,
        or `n_sigma` is not a positive finite number.

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig, ax = plt.subplots()
    >>> ax = plot_scene(ax, sensors=[[0, 0], [10, 0]],
    ...                 reports=[[[4.0, 5.0]], [[4.4, 5.3]]],
    ...                 covariances=[np.diag([0.5, 0.1]), np.diag([0.1, 0.5])],
    ...                 truth=[[4.2, 5.1]])
    >>> len(ax.patches)
    2
    >>> plt.close(fig)
    """
    from ..engine.scenes import TwoRadarScene

    ax = _as_axes(ax)
    n_sigma = as_float(as_positive(n_sigma, "n_sigma"), "n_sigma")
    if scene is not None:
        if not isinstance(scene, TwoRadarScene):
            raise TypeError("`scene` must be a radarfusion_ref.engine.scenes.TwoRadarScene; "
                            f"received {describe(scene)}")
        if len(reports) or len(covariances) or truth is not None:
            raise ValueError("`scene` cannot be combined with `reports`, `covariances` or "
                             "`truth`; received both")
        t = as_int(trial, "trial", minimum=0, maximum=scene.truth.shape[0] - 1)
        d = scene.truth.shape[-1]
        reports = [scene.reports1[t], scene.reports2[t]]
        covariances = [scene.sigma1**2 * np.eye(d), scene.sigma2**2 * np.eye(d)]
        truth = scene.truth[t]
    if isinstance(reports, np.ndarray) and reports.ndim == 3:
        reports = list(reports)
    if isinstance(reports, (str, bytes)) or not isinstance(reports, Sequence):
        raise TypeError("`reports` must be a sequence with one (n_k, d) array per source; "
                        f"received {describe(reports)}")
    pts = [np.atleast_2d(as_float_array(r, f"reports[{k}]", ndim_min=1))
           for k, r in enumerate(reports)]
    dims = {p.shape[-1] for p in pts}
    if len(dims) > 1 or any(p.ndim != 2 for p in pts):
        raise ValueError("`reports` must hold arrays of shape (n_k, d) with one common d; "
                         f"received shapes {[p.shape for p in pts]}")
    d = dims.pop() if dims else 2
    if covariances is None:
        covariances = ()
    if isinstance(covariances, np.ndarray) and covariances.ndim >= 3 and len(covariances) == len(pts):
        covariances = list(covariances)
    if not isinstance(covariances, Sequence) or len(covariances) not in (0, len(pts)):
        raise ValueError("`covariances` must be empty or hold one entry per source "
                         f"({len(pts)}); received {describe(covariances)}")
    covs = []
    for k, (c, p) in enumerate(zip(covariances, pts, strict=False)):
        c = as_covariance(c, f"covariances[{k}]", dim=d)
        if c.ndim == 2:
            c = np.broadcast_to(c, (len(p), d, d))
        elif c.shape[:-2] != (len(p),):
            raise ValueError(f"`covariances[{k}]` must have shape ({d}, {d}) or "
                             f"({len(p)}, {d}, {d}); received shape {c.shape}")
        covs.append(c)
    labels = list(labels) if labels is not None else []
    if len(labels) not in (0, len(pts)):
        raise ValueError(f"`labels` must be empty or hold one label per source ({len(pts)}); "
                         f"received {describe(labels)}")
    labels = labels or [f"radar {k + 1}" for k in range(len(pts))]
    default = [SENSOR_COLORS["radar1"], SENSOR_COLORS["radar2"]]
    colors = list(colors) if colors is not None else (
        default + [f"C{k}" for k in range(2, len(pts))])
    if len(colors) < len(pts):
        raise ValueError(f"`colors` must hold at least one colour per source ({len(pts)}); "
                         f"received {describe(colors)}")
    markers = "os^vDph<>"
    suffix = f" ($\\pm{n_sigma:g}\\sigma$)" if covs else ""

    if truth is not None:
        tr = np.atleast_2d(as_float_array(truth, "truth", ndim_min=1))
        if tr.ndim != 2 or tr.shape[-1] != d:
            raise ValueError(f"`truth` must have shape (n, {d}) like the reports; "
                             f"received shape {tr.shape}")
    if d == 1:
        for k, p in enumerate(pts):
            y = np.full(len(p), -float(k))
            xerr = n_sigma * np.sqrt(covs[k][:, 0, 0]) if covs else None
            ax.errorbar(p[:, 0], y, xerr=xerr, fmt=markers[k % len(markers)], mfc="none",
                        color=colors[k], ms=6, capsize=3, lw=1.2, label=labels[k] + suffix)
        if truth is not None:
            for i, x0 in enumerate(tr[:, 0]):
                ax.axvline(x0, color=SENSOR_COLORS["truth"], ls=":", lw=1,
                           label="truth" if i == 0 else None)
        if pts:
            ax.set_yticks(-np.arange(len(pts)), labels)
            ax.set_ylim(-len(pts) + 0.3, 0.9)
        ax.grid(False, axis="y")
    else:
        if sensors is not None:
            s = np.atleast_2d(as_float_array(sensors, "sensors", last_dims=(2,)))
            if s.ndim != 2:
                raise ValueError(f"`sensors` must have shape (s, 2); received shape {s.shape}")
            scol = colors[:len(s)] if len(s) == len(pts) else ["0.25"] * len(s)
            for i, (xy, c) in enumerate(zip(s, scol, strict=True)):
                ax.plot(xy[0], xy[1], "^", color=c, ms=10, mec="k", mew=0.6,
                        label="radar site" if i == 0 else None)
        for k, p in enumerate(pts):
            ax.plot(p[:, 0], p[:, 1], markers[k % len(markers)], mfc="none", color=colors[k],
                    ms=6, mew=1.3, label=labels[k] + suffix)
            for j in range(len(covs[k]) if covs else 0):
                plot_covariance_ellipse(ax, p[j, :2], covs[k][j, :2, :2], n_sigma=n_sigma,
                                        color=colors[k], lw=1.0, alpha=0.8)
        if truth is not None:
            ax.plot(tr[:, 0], tr[:, 1], "x", color=SENSOR_COLORS["truth"], ms=8, mew=1.5,
                    label="truth")
        if equal:
            ax.set_aspect("equal", adjustable="datalim")
    if legend and ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", framealpha=0.85, frameon=True)
    return ax


def plot_fusion_centre(ax, centre, sensors, *, label="fusion centre", colors=None):
    """The fusion centre and the links that bring each radar's reports to it.

    Draws a square at `centre` and a dashed arrow from every radar site to it;
    with :func:`plot_scene` (the sites, reports and ellipses) it is the book's
    picture of the whole problem.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    centre : array_like, shape (2,)
        Position of the fusion centre.
    sensors : array_like, shape (s, 2)
        Radar sites.
    label : str, optional
        Legend label of the centre.
    colors : sequence, optional
        One colour per link (default dark grey).

    Returns
    -------
    matplotlib.axes.Axes

    Raises
    ------
    TypeError
        If `ax` is not a matplotlib Axes or a position is not numeric.
    ValueError
        If `centre` is not one point or `sensors` not of shape (s, 2).

    Examples
    --------
    >>> import matplotlib.pyplot as plt
    >>> fig, ax = plt.subplots()
    >>> ax = plot_fusion_centre(ax, [5, -3], [[0, 0], [10, 0]])
    >>> len(ax.texts), ax.get_legend_handles_labels()[1]
    (2, ['fusion centre'])
    >>> plt.close(fig)
    """
    ax = _as_axes(ax)
    c = as_float_array(centre, "centre", last_dims=(2,))
    if c.shape != (2,):
        raise ValueError(f"`centre` must have shape (2,); received shape {c.shape}")
    s = np.atleast_2d(as_float_array(sensors, "sensors", last_dims=(2,)))
    if s.ndim != 2:
        raise ValueError(f"`sensors` must have shape (s, 2); received shape {s.shape}")
    colors = list(colors) if colors is not None else ["0.35"] * len(s)
    if len(colors) < len(s):
        raise ValueError(f"`colors` must hold at least one colour per site ({len(s)}); "
                         f"received {describe(colors)}")
    for xy, col in zip(s, colors[:len(s)], strict=True):
        ax.annotate("", c, xy, arrowprops=dict(arrowstyle="-|>", ls="--", lw=1.1, color=col,
                                               shrinkA=7, shrinkB=9))
    ax.plot(c[0], c[1], "s", color="0.15", ms=12, label=label)
    return ax


def plot_density(ax, x, pdf, *, samples=None, bins=60, label=None, color=None):
    """A density curve, optionally over a normalised histogram of samples.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    x, pdf : array_like, shape (n,)
        Abscissae and density values (finite, ``pdf >= 0``).
    samples : array_like, optional
        Monte-Carlo samples (finite, at least one) drawn as a histogram.
    bins : int, optional
        Histogram bins (1 to 10 000).
    label, color : optional
        Legend label and colour of the curve.

    Raises
    ------
    TypeError
        If `ax` is not a matplotlib Axes or an argument is not numeric.
    ValueError
        If `x` and `pdf` differ in shape, a density is negative, `samples` is
        empty or `bins` out of range.
    """
    ax = _as_axes(ax)
    x = as_float_array(x, "x", ndim_min=1)
    pdf = as_float_array(pdf, "pdf", ndim_min=1)
    if x.shape != pdf.shape:
        raise ValueError(f"`x` and `pdf` must have the same shape; received shapes {x.shape} "
                         f"and {pdf.shape}")
    if np.any(pdf < 0):
        raise ValueError(f"`pdf` must be >= 0; received {describe(pdf)}")
    bins = as_int(bins, "bins", minimum=1, maximum=10_000)
    color = _color(color, "color") or SENSOR_COLORS["theory"]
    if samples is not None:
        samples = as_float_array(samples, "samples", ndim_min=1)
        if samples.size == 0:
            raise ValueError("`samples` must hold at least one sample; received an empty array")
        ax.hist(samples.ravel(), bins=bins, density=True, alpha=0.35,
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
        Their covariances (the upper-left 2x2 block is drawn); any shape that
        broadcasts to it, e.g. (m, 1, d, d) for one covariance per source.
    groups : array_like of int, shape (g, m)
        Each row picks one report of every source (a grouping's ``groups``).
    correct : array_like of bool, shape (g,), optional
        Which groups are right; wrong groups are drawn thick and red.
    truth : array_like, shape (n, >= 2), optional
        True positions.
    colors : sequence, optional
        One colour per source (matplotlib's cycle by default).

    Raises
    ------
    TypeError
        If `ax` is not a matplotlib Axes or an argument is not numeric.
    ValueError
        If the shapes disagree, a covariance is not symmetric positive
        definite, or a group picks a report that does not exist.
    """
    ax = _as_axes(ax)
    x = as_float_array(x, "x", ndim_min=3)
    if x.ndim != 3 or x.shape[-1] < 2:
        raise ValueError(f"`x` must have shape (m, n, d) with d >= 2; received shape {x.shape}")
    m, n, d = x.shape
    cov = as_covariance(cov, "cov", dim=d)
    try:
        cov = np.broadcast_to(cov, (m, n, d, d))
    except ValueError:
        raise ValueError(f"`cov` must broadcast to shape (m, n, d, d) = {(m, n, d, d)} like "
                         f"`x`; received shape {cov.shape}") from None
    graw = np.asarray(groups)
    if graw.size and (graw.dtype.kind not in "iu" or graw.ndim != 2 or graw.shape[1] != m):
        raise ValueError(f"`groups` must be integer indices of shape (g, m) = (g, {m}); "
                         f"received {describe(groups)}")
    groups = graw.astype(int).reshape(-1, m)
    if np.any((groups < 0) | (groups >= n)):
        raise ValueError(f"`groups` must pick reports 0 .. {n - 1}; received {describe(graw)}")
    if correct is None:
        correct = np.ones(len(groups), bool)
    else:
        craw = np.asarray(correct)
        if craw.dtype.kind != "b" or craw.shape != (len(groups),):
            raise ValueError(f"`correct` must be booleans, one per group, shape ({len(groups)},); "
                             f"received {describe(correct)}")
        correct = craw
    colors = list(colors) if colors is not None else [f"C{i}" for i in range(m)]
    if len(colors) < m:
        raise ValueError(f"`colors` must hold one colour per source ({m}); "
                         f"received {describe(colors)}")
    if truth is not None:
        truth = _points(truth, "truth")
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
        ax.plot(truth[:, 0], truth[:, 1], "x", color=SENSOR_COLORS["truth"], ms=5, label="truth")
    ax.set_aspect("equal", adjustable="datalim")
    return ax
