"""Interactive cells that still mean something on the rendered page.

The book's pattern for an interactive Monte-Carlo view ``view(**params)``
(a function that draws one figure):

1. call ``view()`` once with its defaults, so the executed page shows the
   default result;
2. ``controls(view, ...)`` gives a live kernel ipywidgets sliders
   (``continuous_update=False``: the view re-runs when a slider is released);
   the cell is tagged ``remove-output`` because a frozen widget on a static
   page does nothing;
3. where exploring one parameter is the point, ``sweep_player(draw, values)``
   precomputes a sweep and renders it with matplotlib's ``to_jshtml()``: a
   frame slider that works in the static HTML, with no kernel and no CDN.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.animation import FuncAnimation

from ._validation import as_int

__all__ = ["controls", "sweep_player", "slider"]

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


def slider(value: float, lo: float, hi: float, step: float | None = None, *,
           description: str = "", integer: bool = False):
    """An ipywidgets slider that updates on release (``continuous_update=False``)."""
    import ipywidgets as widgets

    if not lo <= value <= hi:
        raise ValueError(f"`value` must lie in [lo, hi] = [{lo}, {hi}]; received {value}")
    cls = widgets.IntSlider if integer else widgets.FloatSlider
    kw = {} if step is None else {"step": step}
    return cls(value=value, min=lo, max=hi, description=description,
               continuous_update=False, style={"description_width": "initial"}, **kw)


def controls(view: Callable, **widgets_or_values):
    """Live controls for ``view``: an :func:`ipywidgets.interactive` box.

    Keyword arguments are passed to :func:`ipywidgets.interactive`; sliders
    made here by :func:`slider` update on release. Tag the cell
    ``remove-output`` in a chapter (its widget is dead on the static page).
    """
    import ipywidgets as widgets
    from IPython.display import display

    if not callable(view):
        raise TypeError(f"`view` must be callable; received {view!r}")
    for w in widgets_or_values.values():
        if hasattr(w, "continuous_update"):
            w.continuous_update = False
    box = widgets.interactive(view, **widgets_or_values)
    display(box)
    return box


def sweep_player(draw: Callable, values: Sequence, *, fig=None, interval: int = 600):
    """Precompute a parameter sweep as a static, scrubbable animation.

    Parameters
    ----------
    draw : callable
        ``draw(fig, value)`` clears and redraws the figure for one value of
        the swept parameter (computing nothing that is not cheap: pass
        precomputed results in through a closure).
    values : sequence
        The swept values, one frame each.
    fig : matplotlib.figure.Figure, optional
        Figure to draw into (a new one in the book's style by default).
    interval : int, optional
        Milliseconds per frame when played.

    Returns
    -------
    IPython.display.HTML
        The ``to_jshtml()`` player; the figure is closed so it is not shown twice.
    """
    from IPython.display import HTML

    values = list(values)
    as_int(len(values), "len(values)", minimum=1)
    if not callable(draw):
        raise TypeError(f"`draw` must be callable; received {draw!r}")
    fig = fig or plt.figure()
    # Lay the figure out once, on the first frame, then keep that layout: a
    # tight layout per frame costs about half of each frame's time. Axes that
    # `draw` re-creates after `fig.clear()` inherit the adjusted subplot params.
    draw(fig, values[0])
    fig.canvas.draw()
    fig.set_layout_engine("none")

    def frame(i):
        draw(fig, values[i])
        return []

    anim = FuncAnimation(fig, frame, frames=np.arange(len(values)), interval=interval,
                         blit=False, repeat=False)
    html = _offline_player(anim.to_jshtml(default_mode="once"))
    plt.close(fig)
    return HTML(html)
