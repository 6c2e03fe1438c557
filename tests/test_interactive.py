"""Interactive helpers: the static sweep player works offline, its frames are sharp,
share their axis limits and layout, and nothing on them is clipped."""

from __future__ import annotations

import base64
import re
import struct
import warnings

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from radarfusion_ref.engine.errors import RadarFusionWarning
from radarfusion_ref.kit import interactive
from radarfusion_ref.kit.interactive import MIN_FRAMES, PLAYER_DPI, controls, slider, sweep_player


def _frames(html: str) -> list[bytes]:
    return [base64.b64decode(b.replace("\\n", "")) for b in
            re.findall(r'data:image/png;base64,([^"]+)"', html)]


class Recorder:
    """A draw function that, before redrawing, records the previous frame as drawn.

    The player calls ``draw`` for the limits, the layout and the rendering; the
    frames recorded during the rendering pass are the frames of the player.
    """

    def __init__(self, long_label=False, legend_outside=False):
        self.seen, self.long_label, self.legend_outside = [], long_label, legend_outside

    def __call__(self, fig, value):
        if fig.axes and fig.canvas.get_renderer() is not None:
            ax = fig.axes[0]
            self.seen.append({"xlim": ax.get_xlim(), "ylim": ax.get_ylim(),
                              "position": tuple(ax.get_position().bounds),
                              "aspect": ax.get_aspect(),
                              "clipped": interactive._clipped_texts(fig)})
        fig.clear()
        ax = fig.add_subplot()
        t = np.linspace(0, 2 * np.pi, 60)
        ax.plot(value * np.cos(t), np.sin(t) * 10 ** value, label=f"value {value:.3f}")
        ylabel = "a longer vertical label (km)" if self.long_label else "y"
        ax.set_ylabel(ylabel)
        ax.set_xlabel("x")
        if self.legend_outside:
            ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0))
        else:
            ax.legend(loc="upper right")


def _play(draw, n=MIN_FRAMES, **kw):
    kw.setdefault("fig", plt.figure(figsize=(3, 2)))
    kw.setdefault("dpi", 60)
    return sweep_player(draw, np.linspace(0.5, 1.5, n), **kw).data


def test_sweep_player_has_one_frame_per_value_and_no_cdn():
    html = _play(Recorder())
    assert html.count("data:image/png;base64") == MIN_FRAMES
    assert "font-awesome" not in html and "http://" not in html and "https://" not in html
    assert 'class="fa' not in html


def test_frames_have_the_player_resolution():
    def draw(fig, v):
        fig.clear()
        fig.add_subplot().plot([0, 1], [0, v])

    assert PLAYER_DPI >= 110
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadarFusionWarning)
        html = sweep_player(draw, [1, 2], fig=plt.figure(figsize=(2, 1.5))).data
    width, height = struct.unpack(">II", _frames(html)[0][16:24])
    assert (width, height) == (2 * PLAYER_DPI, round(1.5 * PLAYER_DPI))


def test_limits_and_layout_are_fixed_across_frames():
    rec = Recorder()
    _play(rec)
    frames = rec.seen[-(MIN_FRAMES - 1):]            # the rendering pass
    assert len({f["xlim"] for f in frames}) == 1
    assert len({f["ylim"] for f in frames}) == 1
    assert len({f["position"] for f in frames}) == 1
    (x0, x1), (y0, y1) = frames[0]["xlim"], frames[0]["ylim"]
    assert x0 <= -1.5 and x1 >= 1.5 and y0 <= -10**1.5 and y1 >= 10**1.5   # every frame's data


def test_explicit_limits_and_equal_aspect():
    rec = Recorder()
    _play(rec, xlim=(-2, 2), ylim=(-40, 40), equal_aspect=True)
    frames = rec.seen[-(MIN_FRAMES - 1):]
    assert len({(f["xlim"], f["ylim"]) for f in frames}) == 1
    (x0, x1), (y0, y1) = frames[0]["xlim"], frames[0]["ylim"]
    assert x0 <= -2 and x1 >= 2 and y0 <= -40 and y1 >= 40      # widened, never narrowed
    assert all(f["aspect"] == 1.0 for f in frames)


@pytest.mark.parametrize("legend_outside", [False, True])
def test_no_label_or_legend_is_clipped(legend_outside):
    rec = Recorder(long_label=True, legend_outside=legend_outside)
    _play(rec, fig=plt.figure(figsize=(4, 3)))
    frames = rec.seen[-(MIN_FRAMES - 1):]
    assert all(f["clipped"] == [] for f in frames), [f["clipped"] for f in frames]


def test_a_label_longer_than_the_figure_warns():
    class Hopeless(Recorder):
        def __call__(self, fig, value):
            super().__call__(fig, value)
            fig.axes[0].set_ylabel("a label of the vertical axis far longer than the figure")

    with pytest.warns(RadarFusionWarning, match="texts cut off"):
        _play(Hopeless(), n=MIN_FRAMES)


def test_clipping_detector_sees_a_clipped_label():
    fig, ax = plt.subplots(figsize=(2, 1.5))
    ax.set_ylabel("label")
    fig.subplots_adjust(left=0.0)
    fig.canvas.draw()
    assert "label" in interactive._clipped_texts(fig)
    plt.close(fig)


def test_too_few_frames_warn():
    with pytest.warns(RadarFusionWarning, match="MIN_FRAMES = 24"):
        _play(Recorder(), n=3)


def test_slider_updates_on_release():
    pytest.importorskip("ipywidgets")                       # the `widgets` extra
    s = slider(0.3, 0.0, 1.0, 0.1, description="sigma")
    assert s.continuous_update is False and s.value == 0.3
    assert slider(3, 1, 5, 1, integer=True).value == 3


def test_bad_input():
    draw = Recorder()
    cases = [
        (lambda: slider(2.0, 0.0, 1.0), ValueError, r"`value` must lie in \[lo, hi\]"),
        (lambda: slider(0.5, 1.0, 0.0), ValueError, "`lo` must be below `hi`"),
        (lambda: slider(np.nan, 0.0, 1.0), ValueError, "`value` must be finite"),
        (lambda: slider("0.5", 0.0, 1.0), TypeError, "`value`"),
        (lambda: slider(0.5, 0.0, 1.0, 0.0), ValueError, "`step` must be > 0"),
        (lambda: slider(0.5, 0.0, 1.0, description=3), TypeError, "`description`"),
        (lambda: slider(0.5, 0, 1, integer=True), TypeError, "`value` must be an integer"),
        (lambda: slider(1, 0, 2, integer="yes"), TypeError, "`integer` must be True or False"),
        (lambda: controls("not callable"), TypeError, "`view` must be callable"),
        (lambda: sweep_player(lambda fig, v: None, []), ValueError, r"`len\(values\)`"),
        (lambda: sweep_player("not callable", [1]), TypeError, "`draw` must be callable"),
        (lambda: sweep_player(draw, "abc"), TypeError, "`values` must be a sequence"),
        (lambda: sweep_player(draw, 5), TypeError, "`values` must be a sequence"),
        (lambda: sweep_player(draw, [1], fig="figure"), TypeError,
         "`fig` must be a matplotlib.figure.Figure"),
        (lambda: sweep_player(draw, [1], interval=0), ValueError, "`interval`"),
        (lambda: sweep_player(draw, [1], dpi=10), ValueError, "`dpi` must be an integer >= 50"),
        (lambda: sweep_player(draw, [1], dpi=120.0), TypeError, "`dpi`"),
        (lambda: sweep_player(draw, [1], xlim=(1, 1)), ValueError, "`xlim` must be None or a pair"),
        (lambda: sweep_player(draw, [1], ylim=(0, np.inf)), ValueError, "`ylim` must be finite"),
        (lambda: sweep_player(draw, [1], equal_aspect="yes"), TypeError, "`equal_aspect`"),
        (lambda: sweep_player(draw, [1], fixed_limits=1), TypeError, "`fixed_limits`"),
    ]
    for call, exc, message in cases:
        with pytest.raises(exc, match=message):
            call()
    assert draw.seen == []                 # refused before drawing anything


_anything = st.one_of(st.none(), st.booleans(), st.text(max_size=3),
                      st.floats(allow_nan=True, allow_infinity=True), st.integers(-10, 10**4),
                      st.lists(st.floats(-5, 5), max_size=3))


@given(value=_anything, lo=_anything, hi=_anything, step=_anything)
def test_fuzz_slider_accepts_or_names_the_argument(value, lo, hi, step):
    pytest.importorskip("ipywidgets")
    try:
        s = slider(value, lo, hi, step)
    except (TypeError, ValueError) as exc:
        assert re.search(r"`(value|lo|hi|step)`", str(exc)), str(exc)  # noqa: PT017
    else:
        assert s.min <= s.value <= s.max and s.continuous_update is False


@given(interval=_anything, dpi=_anything, xlim=_anything, equal_aspect=_anything)
def test_fuzz_player_options_are_validated_before_drawing(interval, dpi, xlim, equal_aspect):
    def draw(fig, v):
        raise AssertionError("drawn")

    try:
        sweep_player(draw, [1.0], interval=interval, dpi=dpi, xlim=xlim,
                     equal_aspect=equal_aspect)
    except (TypeError, ValueError) as exc:
        assert re.search(r"`(interval|dpi|xlim|equal_aspect)`", str(exc)), str(exc)  # noqa: PT017
    except AssertionError:
        # every option valid: the player started drawing
        assert isinstance(interval, int) and not isinstance(interval, bool) and interval >= 1
        assert isinstance(dpi, int) and 50 <= dpi <= 600 and isinstance(equal_aspect, bool)
    finally:
        plt.close("all")


def _picked(builder: str, bundle: dict) -> str:
    """The mime type myst-nb renders from `bundle` for `builder` (no overrides in _config.yml)."""
    from myst_nb.core.render import get_mime_priority

    return next(m for m in get_mime_priority(builder, []) if m in bundle)


def test_player_degrades_to_its_default_frame_in_print():
    """HTML pages keep the player; the LaTeX builder gets the first frame as a PNG."""
    import io

    DisplayFormatter = pytest.importorskip("IPython.core.formatters").DisplayFormatter

    colours = ["#ff0000", "#00ff00", "#0000ff"]

    def draw(fig, value):
        fig.clear()
        ax = fig.add_subplot()
        ax.set_facecolor(colours[int(value) % 3])
        ax.set_title(f"value {value}")

    values = [2, 0, 1] * 8                      # first frame blue, so not the first colour
    player = sweep_player(draw, values, fig=plt.figure(figsize=(3.0, 2.0)), dpi=60)
    bundle, _ = DisplayFormatter().format(player)
    assert {"text/html", "image/png"} <= set(bundle)
    assert bundle["text/html"] == player.data and "<script" in player.data
    assert _picked("html", bundle) == "text/html"
    assert _picked("latex", bundle) == "image/png"

    png = player.png
    assert png.startswith(b"\x89PNG")
    width, height = struct.unpack(">II", png[16:24])
    assert (width, height) == (3 * interactive.PRINT_DPI, 2 * interactive.PRINT_DPI)
    image = plt.imread(io.BytesIO(png))
    centre = image[height // 2, width // 2, :3]
    np.testing.assert_allclose(centre, [0.0, 0.0, 1.0], atol=0.02)  # the first value's frame
    # and the same frame as the player's first frame, drawn at the player's resolution
    first = plt.imread(io.BytesIO(_frames(player.data)[0]))
    h, w = first.shape[:2]
    np.testing.assert_allclose(first[h // 2, w // 2, :3], [0.0, 0.0, 1.0], atol=0.02)


def test_player_print_frame_has_the_players_layout():
    """The static frame is laid out like the frames: the same axes box and limits, and
    nothing on it clipped."""
    draw = Recorder(legend_outside=True)
    fig = plt.figure(figsize=(4, 3))
    player = sweep_player(draw, np.linspace(0.5, 1.5, MIN_FRAMES), fig=fig, dpi=60)
    rendered = draw.seen[-MIN_FRAMES:]     # the frames of the player, as drawn
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig).draw()            # the (closed) figure holds the print frame
    ax = fig.axes[0]
    assert tuple(ax.get_position().bounds) == pytest.approx(rendered[0]["position"])
    assert (ax.get_xlim(), ax.get_ylim()) == (rendered[0]["xlim"], rendered[0]["ylim"])
    assert ax.get_legend().get_texts()[0].get_text() == "value 0.500"
    assert interactive._clipped_texts(fig) == []
    assert struct.unpack(">II", player.png[16:24]) == (4 * interactive.PRINT_DPI,
                                                       3 * interactive.PRINT_DPI)
    assert repr(player) == f"<sweep player: {MIN_FRAMES} frames>"


@pytest.mark.parametrize(("lo", "value", "step", "decimals"), [
    (0.001, 0.01, 0.001, 3), (0.5, 8.0, 0.5, 1), (10.0, 150.0, 10.0, 0), (0.02, 0.08, 0.02, 2),
    (0.0, 1.0, 0.25, 2), (0.0, 1e-6, 1e-7, 7)])
def test_slider_readout_shows_every_value_it_can_take(lo, value, step, decimals):
    s = slider(value, lo, lo + 100 * step, step)
    assert s.readout_format == f".{decimals}f"
    # every value the slider can take prints to the value itself (0.013 on a 0.001 step)
    for k in (1, 12, 37):
        v = lo + k * step
        assert float(format(v, s.readout_format)) == pytest.approx(v, rel=1e-9, abs=1e-12)
