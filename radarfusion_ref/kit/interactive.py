"""Interactive cells that still mean something on the rendered page.

The book's pattern for an interactive Monte-Carlo view ``view(**params)``
(a function that draws one figure):

1. call ``view()`` once with its defaults, so the executed page shows the
   default result;
2. ``controls(view, ...)`` gives a live kernel ipywidgets sliders
   (``continuous_update=False``: the view re-runs when a slider is released);
   the cell is tagged ``remove-cell``: it stays in the notebook for a live
   kernel, and the static page carries neither its code nor its widget
   (the book's ``_ext/radarfusion_pages.py`` drops the widget state of pages
   that show no widget);
3. where exploring one parameter is the point, ``sweep_player(draw, values)``
   precomputes a sweep of at least :data:`MIN_FRAMES` frames and renders it
   with matplotlib's ``to_jshtml()``: a frame slider that works in the static
   HTML, with no kernel and no CDN. The player fixes the axis limits across
   frames and lays the figure out once, with room for every frame's labels
   and legends. In print (the PDF edition) the player degrades to its static
   default frame: its display bundle also carries an ``image/png`` of the
   first frame at :data:`PRINT_DPI`, which the LaTeX builder picks (myst-nb's
   priority for ``latex`` has ``image/png`` and no ``text/html``) while the
   HTML builder and JupyterLab keep the player.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable, Sequence

import matplotlib as mpl
import matplotlib.pyplot as plt
import numpy as np

from ..engine.errors import RadarFusionWarning
from ..engine.optional import require
from ..engine.validation import as_float, as_float_array, as_int, describe

__all__ = ["controls", "sweep_player", "slider", "MIN_FRAMES", "PLAYER_DPI", "PRINT_DPI",
           "Player"]

#: Fewest frames a player should have: below this a sweep is too coarse to be
#: explored by scrubbing, and :func:`sweep_player` warns (RadarFusionWarning).
MIN_FRAMES = 24

#: Resolution of the player's frames (dots per inch; at least 110 for the book).
PLAYER_DPI = 120

#: Resolution of a player's static default frame, shown in print (dots per inch).
PRINT_DPI = 200

#: Largest embedded player, in MB of base64 frames (matplotlib drops the frames
#: beyond its ``animation.embed_limit``; the player refuses instead).
MAX_PLAYER_MB = 16.0

# matplotlib's player draws its buttons with Font Awesome icons loaded from a CDN;
# the book must render offline, so the icons become plain Unicode symbols.
_ICONS = {
    "fa-minus": "\u2212", "fa-fast-backward": "|\u00ab", "fa-step-backward": "\u2039",
    "fa-play fa-flip-horizontal": "\u25c0", "fa-pause": "||", "fa-play": "\u25b6",
    "fa-step-forward": "\u203a", "fa-fast-forward": "\u00bb|", "fa-plus": "+",
}
_CDN_LINK = re.compile(r"<link[^>]*font-awesome[^>]*>", re.S)
_ICON = re.compile(r'<i class="fa (fa-[a-z-]+(?: fa-flip-horizontal)?)"></i>')


def _offline_player(html: str) -> str:
    """Remove the player's CDN stylesheet and replace its icons by Unicode symbols."""
    html = _CDN_LINK.sub("", html)
    return _ICON.sub(lambda m: _ICONS.get(m.group(1), "?"), html)


class Player:
    """A sweep player's display: the HTML player, and its default frame for print.

    Displayed in a notebook, its bundle holds ``text/html`` (the player, which
    HTML pages and JupyterLab show) and ``image/png`` (the default frame, the
    first value of the sweep, as the player shows it on load, at
    :data:`PRINT_DPI`), which builders without HTML output (LaTeX) show.

    Attributes
    ----------
    data : str
        The player's HTML.
    png : bytes
        The default frame as a PNG image.
    """

    def __init__(self, data: str, png: bytes):
        self.data, self.png = data, png

    def _repr_html_(self) -> str:
        return self.data

    def _repr_png_(self) -> bytes:
        return self.png

    def __repr__(self) -> str:
        return f"<sweep player: {self.data.count('data:image/png;base64')} frames>"


def _as_bool(value, name: str) -> bool:
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"`{name}` must be True or False; received {describe(value)}")
    return bool(value)


def _as_limits(value, name: str) -> tuple[float, float] | None:
    """None, or a pair ``(lo, hi)`` of finite numbers with ``lo != hi``."""
    if value is None:
        return None
    arr = as_float_array(value, name)
    if arr.shape != (2,) or arr[0] == arr[1]:
        raise ValueError(f"`{name}` must be None or a pair (lo, hi) of finite numbers with "
                         f"lo != hi; received {describe(value)}")
    return float(arr[0]), float(arr[1])


def _decimals(*numbers: float) -> int:
    """Fewest decimals (at most 12) that print each of `numbers` exactly: the readout of a
    slider whose values are ``lo + k * step`` shows every value it can take."""
    for d in range(13):
        if all(abs(round(x, d) - x) <= 1e-9 * max(1.0, abs(x)) for x in numbers):
            return d
    return 12


def slider(value: float, lo: float, hi: float, step: float | None = None, *,
           description: str = "", integer: bool = False):
    """An ipywidgets slider that updates on release (``continuous_update=False``).

    Parameters
    ----------
    value, lo, hi : float
        Initial value and range, ``lo < hi`` and ``lo <= value <= hi``
        (integers when `integer` is true).
    step : float, optional
        Step (> 0; ipywidgets' default 0.1 when omitted). The readout of a float slider
        shows as many decimals as `lo`, `value` and `step` need, so every value the
        slider can take reads as it is (0.013 on a 0.001 step, not 0.01).
    description : str, optional
        Label shown beside the slider.
    integer : bool, optional
        An ``IntSlider`` instead of a ``FloatSlider``.

    Raises
    ------
    TypeError
        For non-numeric bounds, a non-string `description`, non-integer bounds
        of an integer slider.
    ValueError
        For non-finite numbers, ``lo >= hi``, a `value` outside ``[lo, hi]`` or
        a `step` <= 0.
    """
    integer = _as_bool(integer, "integer")
    if not isinstance(description, str):
        raise TypeError(f"`description` must be a string; received {describe(description)}")
    if integer:
        value, lo, hi = (as_int(v, n) for v, n in ((value, "value"), (lo, "lo"), (hi, "hi")))
        step = None if step is None else as_int(step, "step", minimum=1)
    else:
        value, lo, hi = (as_float(v, n) for v, n in ((value, "value"), (lo, "lo"), (hi, "hi")))
        if step is not None and not as_float(step, "step") > 0:
            raise ValueError(f"`step` must be > 0; received {describe(step)}")
    if not lo < hi:
        raise ValueError(f"`lo` must be below `hi`; received lo = {lo}, hi = {hi}")
    if not lo <= value <= hi:
        raise ValueError(f"`value` must lie in [lo, hi] = [{lo}, {hi}]; received {value}")
    widgets = require("ipywidgets", feature="slider")
    cls = widgets.IntSlider if integer else widgets.FloatSlider
    kw = {} if step is None else {"step": step}
    if not integer:
        kw["readout_format"] = f".{_decimals(lo, value, 0.1 if step is None else step)}f"
    return cls(value=value, min=lo, max=hi, description=description,
               continuous_update=False, style={"description_width": "initial"}, **kw)


def controls(view: Callable, **widgets_or_values):
    """Live controls for ``view``: an :func:`ipywidgets.interactive` box.

    Keyword arguments are passed to :func:`ipywidgets.interactive`; sliders
    made here by :func:`slider` update on release. Tag the cell
    ``remove-cell`` in a chapter: its widget is dead on the static page, and
    the notebook keeps the cell for a live kernel.

    Raises
    ------
    TypeError
        If `view` is not callable.
    """
    if not callable(view):
        raise TypeError(f"`view` must be callable; received {describe(view)}")
    widgets = require("ipywidgets", feature="controls")
    display = require("IPython.display", feature="controls").display
    for w in widgets_or_values.values():
        if hasattr(w, "continuous_update"):
            w.continuous_update = False
    box = widgets.interactive(view, **widgets_or_values)
    display(box)
    return box


def _is_colorbar(ax) -> bool:
    return getattr(ax, "_colorbar", None) is not None


def _union(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    """Smallest interval holding both, keeping the orientation of `a`."""
    lo, hi = min(*a, *b), max(*a, *b)
    return (hi, lo) if a[0] > a[1] else (lo, hi)


def _equal_aspect(ax) -> None:
    """Equal aspect by widening the fixed limits to the axes' box, the same on every frame.

    (``adjustable="datalim"`` would widen them from each frame's own data, so the
    limits would change between frames; ``"box"`` alone would shrink the axes.)
    """
    fig = ax.get_figure()
    if ax.get_xscale() == "linear" and ax.get_yscale() == "linear":
        pos = ax.get_position(original=True)
        w, h = pos.width * fig.get_figwidth(), pos.height * fig.get_figheight()
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        dx, dy = abs(x1 - x0), abs(y1 - y0)
        if w > 0 and h > 0 and dx > 0 and dy > 0:
            if dy / dx < h / w:
                grow = (dx * h / w - dy) / 2 * np.sign(y1 - y0)
                ax.set_ylim(y0 - grow, y1 + grow)
            else:
                grow = (dy * w / h - dx) / 2 * np.sign(x1 - x0)
                ax.set_xlim(x0 - grow, x1 + grow)
    ax.set_aspect("equal", adjustable="box")


def _frame_limits(fig) -> list[tuple | None]:
    """(xlim, ylim) of each axes of the current frame (None for colorbars)."""
    return [None if _is_colorbar(ax) else (ax.get_xlim(), ax.get_ylim()) for ax in fig.axes]


def _margins(fig) -> dict[str, float] | None:
    """The subplot parameters a tight layout of the current frame asks for."""
    from matplotlib.layout_engine import TightLayoutEngine

    if not any(ax.get_subplotspec() is not None for ax in fig.axes):
        return None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)   # axes tight_layout cannot handle
        TightLayoutEngine(pad=0.6).execute(fig)
    p = fig.subplotpars
    return {"left": p.left, "right": p.right, "bottom": p.bottom, "top": p.top,
            "wspace": p.wspace, "hspace": p.hspace}


def _merge_margins(a: dict | None, b: dict | None) -> dict | None:
    """Margins with room for both layouts."""
    if a is None or b is None:
        return a or b
    return {"left": max(a["left"], b["left"]), "bottom": max(a["bottom"], b["bottom"]),
            "right": min(a["right"], b["right"]), "top": min(a["top"], b["top"]),
            "wspace": max(a["wspace"], b["wspace"]), "hspace": max(a["hspace"], b["hspace"])}


def _clipped_texts(fig, *, ticks: bool = True, tol: float = 1.0) -> list[str]:
    """Names of the texts and legends of the drawn figure that stick out of it.

    Titles, axis labels, texts and legends are checked; tick labels too unless
    ``ticks=False`` (with limits fixed across frames they are the same on every
    frame, and the layout already made room for them). Used on every frame of a
    player and by the tests.
    """
    renderer = fig.canvas.get_renderer()
    box = fig.bbox
    named = [(t, t.get_text()) for t in fig.texts] + [(g, "figure legend") for g in fig.legends]
    for k, ax in enumerate(fig.axes):
        named += [(t, t.get_text()) for t in (ax.title, ax._left_title, ax._right_title,
                                             ax.xaxis.label, ax.yaxis.label, *ax.texts)]
        if ticks:
            named += [(ax.xaxis, f"x tick labels of axes {k}"),
                      (ax.yaxis, f"y tick labels of axes {k}")]
        if ax.get_legend() is not None:
            named.append((ax.get_legend(), f"legend of axes {k}"))
    out = []
    for artist, name in named:
        if not artist.get_visible() or not name:
            continue
        if hasattr(artist, "get_ticklabels"):
            bb = artist.get_tightbbox(renderer)
        else:
            bb = artist.get_window_extent(renderer)
        if bb is None or (bb.width == 0 and bb.height == 0):
            continue
        if (bb.x0 < box.x0 - tol or bb.y0 < box.y0 - tol or bb.x1 > box.x1 + tol
                or bb.y1 > box.y1 + tol):
            out.append(name)
    return out


def _render_player(fig, draw, values, apply, margins, interval, dpi, *, final,
                   ticks):
    """``(html, margins, clipped)``: the player, and the wider margins and names of
    the texts of a clipped frame (None if none). Unless `final`, rendering stops at
    the first clipped frame."""
    import tempfile
    from pathlib import Path

    from matplotlib.animation import HTMLWriter

    wider, clipped = None, []
    with tempfile.TemporaryDirectory() as tmp, mpl.rc_context(
            {"savefig.bbox": None, "animation.embed_limit": MAX_PLAYER_MB,
             # savefig restores the layout engine with set_layout_engine(None), which
             # reads these: without them, every later frame is laid out (and drawn) twice
             "figure.autolayout": False, "figure.constrained_layout.use": False}):
        path = Path(tmp, "player.html")
        writer = HTMLWriter(fps=1000.0 / interval, embed_frames=True, default_mode="once")
        with writer.saving(fig, str(path), dpi):
            for i, v in enumerate(values):
                draw(fig, v)
                apply(margins)
                writer.grab_frame()
                names = _clipped_texts(fig, ticks=ticks)
                if names:
                    clipped += [f"frame {i}: {n}" for n in names]
                    wider = _merge_margins(wider, _margins(fig))
                    if not final:
                        return "", wider, clipped
        return path.read_text(encoding="utf-8"), wider, clipped or None


def sweep_player(draw: Callable, values: Sequence, *, fig=None, interval: int = 600,
                 dpi: int = PLAYER_DPI, xlim=None, ylim=None, fixed_limits: bool = True,
                 equal_aspect: bool = False):
    """Precompute a parameter sweep as a static, scrubbable animation.

    Parameters
    ----------
    draw : callable
        ``draw(fig, value)`` clears and redraws the figure for one value of
        the swept parameter (computing nothing that is not cheap: pass
        precomputed results in through a closure). It is called about three
        times per value (limits, layout, rendering), so it must not draw
        random numbers of its own.
    values : sequence
        The swept values, one frame each; at least :data:`MIN_FRAMES` (24) for
        a sweep a reader can explore (fewer warn with
        :class:`~radarfusion_ref.engine.errors.RadarFusionWarning`).
    fig : matplotlib.figure.Figure, optional
        Figure to draw into (a new one in the book's style by default).
    interval : int, optional
        Milliseconds per frame when played (>= 1).
    dpi : int, optional
        Resolution of the frames (default :data:`PLAYER_DPI` = 120; 50 to 600).
    xlim, ylim : (float, float), optional
        Explicit axis limits applied to every (non-colorbar) axes of every
        frame. Where not given and `fixed_limits` is true, each axes gets the
        union of its limits over all frames, so the axes never rescale while
        the reader scrubs.
    fixed_limits : bool, optional
        Fix the limits across frames as above (default ``True``); ``False``
        keeps each frame's own limits.
    equal_aspect : bool, optional
        One unit on x is as long as one unit on y, on every non-colorbar axes:
        the fixed limits are widened (never narrowed) to the shape of the axes,
        the same way on every frame. Use it for geometry plots.

    Returns
    -------
    Player
        The ``to_jshtml()`` player (``.data``, shown as ``text/html``) and its
        default frame, the first value's, at :data:`PRINT_DPI` (``.png``, shown
        as ``image/png`` in print); the figure is closed so it is not shown twice.

    Raises
    ------
    TypeError
        If `draw` is not callable, `values` is not a sequence (a string is
        not), `fig` is not a matplotlib Figure, or an option has the wrong type.
    ValueError
        If `values` is empty, an option is out of range, or the embedded
        frames would exceed :data:`MAX_PLAYER_MB`.

    Notes
    -----
    The figure is laid out once for the whole sweep: a tight layout is
    computed on every frame (with the fixed limits) and the most generous
    margins are kept, then applied after each ``draw`` call (``fig.clear()``
    resets a figure's margins). So a label or legend that is longer on one
    frame than on the first is not clipped, and nothing moves between frames.
    """
    from matplotlib.figure import Figure

    if not callable(draw):
        raise TypeError(f"`draw` must be callable, called as draw(fig, value); "
                        f"received {describe(draw)}")
    if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
        raise TypeError(f"`values` must be a sequence of swept values; received {describe(values)}")
    values = list(values)
    as_int(len(values), "len(values)", minimum=1)
    if fig is not None and not isinstance(fig, Figure):
        raise TypeError(f"`fig` must be a matplotlib.figure.Figure or None; received {describe(fig)}")
    interval = as_int(interval, "interval", minimum=1)
    dpi = as_int(dpi, "dpi", minimum=50, maximum=600)
    xlim, ylim = _as_limits(xlim, "xlim"), _as_limits(ylim, "ylim")
    fixed_limits = _as_bool(fixed_limits, "fixed_limits")
    equal_aspect = _as_bool(equal_aspect, "equal_aspect")
    if len(values) < MIN_FRAMES:
        warnings.warn(f"sweep_player: {len(values)} frames is a coarse sweep; a player should "
                      f"have at least MIN_FRAMES = {MIN_FRAMES} values", RadarFusionWarning,
                      stacklevel=2)

    fig = fig or plt.figure()
    # render at the figure's own resolution: artists placed in pixels at draw time
    # (axis labels) are then where the clipping check measures them
    fig.set_dpi(dpi)
    fig.set_layout_engine("none")
    if type(fig.get_layout_engine()).__name__ == "PlaceHolderLayoutEngine" and hasattr(
            fig, "_layout_engine"):
        # "none" keeps a placeholder engine, and any engine makes savefig draw every
        # frame twice; the player sets the margins itself
        fig._layout_engine = None

    # 1. limits: the union over all frames of each axes' limits (drawing is cheap;
    #    nothing is rendered here)
    limits: list[tuple | None] = []
    if fixed_limits and (xlim is None or ylim is None):
        for v in values:
            draw(fig, v)
            for k, lims in enumerate(_frame_limits(fig)):
                if k == len(limits):
                    limits.append(lims)
                elif lims is not None and limits[k] is not None:
                    limits[k] = (_union(limits[k][0], lims[0]), _union(limits[k][1], lims[1]))

    def apply(margins=None):
        if margins is not None:
            fig.subplots_adjust(**margins)
        for k, ax in enumerate(fig.axes):
            if _is_colorbar(ax):
                continue
            fixed = limits[k] if k < len(limits) else None
            if xlim is not None:
                ax.set_xlim(xlim)
            elif fixed is not None:
                ax.set_xlim(fixed[0])
            if ylim is not None:
                ax.set_ylim(ylim)
            elif fixed is not None:
                ax.set_ylim(fixed[1])
            if equal_aspect:
                _equal_aspect(ax)

    # 2. layout: a tight layout of a few frames (with the fixed limits, tick labels
    #    no longer change between frames), the most generous margins kept
    margins = None
    for i in sorted({0, len(values) // 2, len(values) - 1}):
        draw(fig, values[i])
        apply()
        margins = _merge_margins(margins, _margins(fig))

    # 3. the frames, all with the same limits and layout. A frame whose texts
    #    stick out of the figure widens the margins and the frames are rendered
    #    again; what a layout cannot fit (a title wider than the figure) warns.
    for attempt in range(3):
        html, wider, clipped = _render_player(
            fig, draw, values, apply, margins, interval, dpi, final=attempt == 2,
            ticks=not (fixed_limits or (xlim is not None and ylim is not None)))
        if clipped is None:
            break
        margins = _merge_margins(margins, wider)
    # 4. the static default frame for print: the first value, as the player shows it
    #    on load, with the same limits and layout, at print resolution
    import io

    draw(fig, values[0])
    apply(margins)
    buf = io.BytesIO()
    with mpl.rc_context({"savefig.bbox": None, "figure.autolayout": False,
                         "figure.constrained_layout.use": False}):
        fig.savefig(buf, format="png", dpi=PRINT_DPI)
    if clipped:
        warnings.warn(f"sweep_player: texts cut off at the figure's edge even with the widest "
                      f"layout: {clipped[:4]}; shorten them or enlarge the figure",
                      RadarFusionWarning, stacklevel=2)
    plt.close(fig)
    if html.count("data:image/png;base64") < len(values):
        raise ValueError(
            f"sweep_player: {len(values)} frames at dpi = {dpi} exceed the embedding limit of "
            f"MAX_PLAYER_MB = {MAX_PLAYER_MB:g} MB; use a smaller figure, a lower `dpi` or "
            "fewer `values`")
    return Player(_offline_player(html), buf.getvalue())

