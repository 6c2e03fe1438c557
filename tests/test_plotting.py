"""Plotting helpers: geometry checked against the quadratic form they draw."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from radarfusion_ref.kit.plotting import plot_covariance_ellipse, plot_reports


@settings(max_examples=30, deadline=None)
@given(a=st.floats(0.1, 5), b=st.floats(0.1, 5), rho=st.floats(-0.9, 0.9),
       n_sigma=st.floats(0.5, 3))
def test_ellipse_points_lie_on_the_quadratic_form(a, b, rho, n_sigma):
    cov = np.array([[a * a, rho * a * b], [rho * a * b, b * b]])
    mean = np.array([1.0, -2.0])
    fig, ax = plt.subplots()
    plot_covariance_ellipse(ax, mean, cov, n_sigma=n_sigma)
    patch = ax.patches[0]
    # the patch maps the unit circle onto the drawn ellipse
    t = np.linspace(0, 2 * np.pi, 50)
    unit = np.column_stack([np.cos(t), np.sin(t)])
    pts = patch.get_patch_transform().transform(unit) - mean
    q = np.einsum("ni,ij,nj->n", pts, np.linalg.inv(cov), pts)
    plt.close(fig)
    np.testing.assert_allclose(q, n_sigma**2, rtol=1e-6)


def test_ellipse_rejects_bad_covariance():
    fig, ax = plt.subplots()
    with pytest.raises(ValueError, match="`cov`"):
        plot_covariance_ellipse(ax, (0, 0), [[1.0, 2.0], [2.0, 1.0]])
    with pytest.raises(ValueError, match="`mean`"):
        plot_covariance_ellipse(ax, (0, 0, 0), np.eye(2))
    plt.close(fig)


def test_wrong_pairs_are_drawn_red():
    fig, ax = plt.subplots()
    xy = np.array([[0.0, 0.0], [1.0, 0.0]])
    plot_reports(ax, xy, xy, pairs=[(0, 0), (1, 0)], true_pairs=[(0, 0), (1, 1)])
    colors = [line.get_color() for line in ax.lines[2:]]
    plt.close(fig)
    assert colors == ["0.4", "red"]


def test_plot_groups_marks_wrong_groups():
    from radarfusion_ref.kit.plotting import plot_groups

    x = np.zeros((3, 2, 2))
    x[:, 1] = 1.0
    cov = np.broadcast_to(np.eye(2) * 0.01, (3, 2, 2, 2))
    fig, ax = plt.subplots()
    plot_groups(ax, x, cov, [[0, 0, 0], [1, 1, 0]], [True, False])
    n_ellipses = len(ax.patches)
    colors = [line.get_color() for line in ax.lines[3:]]
    plt.close(fig)
    assert n_ellipses == 6
    assert colors[:3] != ["red"] * 3 and colors[3:] == ["red"] * 3


def test_plot_scene_draws_sites_reports_ellipses_truth():
    from radarfusion_ref.kit.plotting import plot_scene

    fig, ax = plt.subplots()
    truth = np.array([[4.0, 5.0], [6.0, 5.5]])
    plot_scene(ax, sensors=[[0, 0], [10, 0]], reports=[truth + 0.1, truth - 0.1],
               covariances=[np.diag([0.5, 0.1]), np.array([[0.5, 0.2], [0.2, 0.3]])],
               truth=truth, n_sigma=3.0)
    labels = ax.get_legend_handles_labels()[1]
    n_ellipses = len(ax.patches)
    legend = ax.get_legend()
    aspect = ax.get_aspect()
    plt.close(fig)
    assert n_ellipses == 4
    assert labels == ["radar site", r"radar 1 ($\pm3\sigma$)", r"radar 2 ($\pm3\sigma$)", "truth"]
    assert legend is not None and aspect == 1.0


def test_plot_scene_accepts_a_simulated_scene_in_one_and_two_dimensions():
    from radarfusion_ref.engine.scenes import two_radar_scene
    from radarfusion_ref.kit.plotting import plot_scene

    fig, (ax1, ax2) = plt.subplots(1, 2)
    plot_scene(ax1, scene=two_radar_scene(3, spacing=1.0, sigma1=0.1, sigma2=0.2, rng=1))
    plot_scene(ax2, scene=two_radar_scene(3, spacing=1.0, sigma1=0.1, sigma2=0.2, dim=2,
                                          trials=2, rng=1), trial=1)
    n1, n2 = len(ax1.lines), len(ax2.patches)
    plt.close(fig)
    assert n1 >= 3 and n2 == 6


# --- input validation (issue 12, point 8) ------------------------------------

from hypothesis import HealthCheck  # noqa: E402

from radarfusion_ref.engine.montecarlo import mean as mc_mean  # noqa: E402
from radarfusion_ref.engine.montecarlo import proportion  # noqa: E402
from radarfusion_ref.kit import plotting  # noqa: E402


@pytest.fixture
def ax():
    fig, ax = plt.subplots()
    yield ax
    plt.close(fig)


def _helpers(ax):
    """One valid call of every public drawing helper."""
    p = proportion(np.array([3, 5]), 10)
    m = mc_mean(np.arange(20.0).reshape(2, 10))
    xy = np.array([[0.0, 0.0], [1.0, 1.0]])
    return {
        "plot_proportion": lambda a: plotting.plot_proportion(a, [1, 2], p, theory=[0.3, 0.5]),
        "plot_mean": lambda a: plotting.plot_mean(a, [1, 2], m),
        "plot_reports": lambda a: plotting.plot_reports(a, xy, xy, pairs=[(0, 1)]),
        "plot_density": lambda a: plotting.plot_density(a, [0, 1], [0.5, 0.5], samples=[0.2]),
        "plot_covariance_ellipse": lambda a: plotting.plot_covariance_ellipse(a, (0, 0),
                                                                              np.eye(2)),
        "plot_groups": lambda a: plotting.plot_groups(a, np.zeros((2, 1, 2)),
                                                      np.broadcast_to(np.eye(2), (2, 1, 2, 2)),
                                                      [[0, 0]]),
        "plot_scene": lambda a: plotting.plot_scene(a, reports=[xy]),
    }


@pytest.mark.parametrize("name", sorted(_helpers(None)))
@pytest.mark.parametrize("bad_ax", [None, "ax", plt, np.zeros(2)])
def test_every_helper_refuses_a_non_axes(name, bad_ax, ax):
    assert _helpers(ax)[name](ax) is ax          # the valid call works and returns ax
    with pytest.raises(TypeError, match=r"`ax` must be a matplotlib.axes.Axes.*received"):
        _helpers(ax)[name](bad_ax)


def test_result_objects_of_the_wrong_type(ax):
    p = proportion(np.array([3, 5]), 10)
    m = mc_mean(np.arange(20.0).reshape(2, 10))
    with pytest.raises(TypeError, match=r"`p` must be a Proportion .*received MeanEstimate"):
        plotting.plot_proportion(ax, [1, 2], m)
    with pytest.raises(TypeError, match=r"`m` must be a MeanEstimate .*received Proportion"):
        plotting.plot_mean(ax, [1, 2], p)
    with pytest.raises(TypeError, match=r"`p` must be a Proportion .*received \[0.3, 0.5\]"):
        plotting.plot_proportion(ax, [1, 2], [0.3, 0.5])
    with pytest.raises(TypeError, match=r"`scene` must be a .*TwoRadarScene"):
        plotting.plot_scene(ax, scene={"reports1": 1})


def test_bad_shapes_and_numbers(ax):
    p = proportion(np.array([3, 5]), 10)
    cases = [
        (lambda: plotting.plot_proportion(ax, [1, 2, 3], p), ValueError, "`x` must have one entry"),
        (lambda: plotting.plot_proportion(ax, [1, np.nan], p), ValueError, "`x` must be finite"),
        (lambda: plotting.plot_proportion(ax, [1, 2], p, theory=[1]), ValueError, "`theory`"),
        (lambda: plotting.plot_proportion(ax, [1, 2], p, color="nocolour"), ValueError,
         "`color` must be a matplotlib colour"),
        (lambda: plotting.plot_reports(ax, [[0]], [[1, 1]]), ValueError, "`xy1`"),
        (lambda: plotting.plot_reports(ax, [[0, 0]], [1, 1], pairs=[(0, 3)]), ValueError,
         r"`pairs` must index existing reports \(i < 1, j < 1\)"),
        (lambda: plotting.plot_reports(ax, [[0, 0]], [1, 1], pairs=[(0.5, 0)]), ValueError,
         "`pairs` must be integer index pairs"),
        (lambda: plotting.plot_reports(ax, [[0, 0]], [[1, "a"]]), TypeError, "`xy2`"),
        (lambda: plotting.plot_density(ax, [0, 1], [0.5]), ValueError, "`x` and `pdf`"),
        (lambda: plotting.plot_density(ax, [0, 1], [0.5, -0.1]), ValueError, "`pdf` must be >= 0"),
        (lambda: plotting.plot_density(ax, [0, 1], [1, 1], samples=[]), ValueError, "`samples`"),
        (lambda: plotting.plot_density(ax, [0, 1], [1, 1], bins=0), ValueError, "`bins`"),
        (lambda: plotting.plot_density(ax, [0, 1], [1, 1], bins=2.5), TypeError, "`bins`"),
        (lambda: plotting.plot_covariance_ellipse(ax, (0, 0), np.eye(2), n_sigma=0), ValueError,
         "`n_sigma` must be > 0"),
        (lambda: plotting.plot_covariance_ellipse(ax, (0, 0), np.eye(2), n_sigma=True),
         TypeError, "`n_sigma`"),
        (lambda: plotting.plot_covariance_ellipse(ax, [[0, 0]], np.eye(2)), ValueError,
         r"`mean` must have shape \(2,\)"),
        (lambda: plotting.plot_groups(ax, np.zeros((2, 1, 2)), np.eye(2)[None, None], [[0, 1]]),
         ValueError, "`groups` must pick reports 0 .. 0"),
        (lambda: plotting.plot_groups(ax, np.zeros((2, 1, 2)), np.ones((2, 2)), [[0, 0]]),
         ValueError, "`cov` must be positive definite"),
        (lambda: plotting.plot_groups(ax, np.zeros((2, 1, 2)), np.eye(2), [[0, 0]],
                                      correct=[1]), ValueError, "`correct` must be booleans"),
        (lambda: plotting.plot_scene(ax, reports=[[[0, 0]], [[0, 0, 0]]]), ValueError,
         "`reports` must hold arrays of shape"),
        (lambda: plotting.plot_scene(ax, reports=[[[0, 0]]], covariances=[np.eye(3)]),
         ValueError, r"`covariances\[0\]` must have shape \(..., 2, 2\)"),
        (lambda: plotting.plot_scene(ax, reports=[[[0, 0]]], covariances=[np.eye(2)] * 2),
         ValueError, "`covariances` must be empty or hold one entry per source"),
        (lambda: plotting.plot_scene(ax, reports=[[[0, 0]]], labels=["a", "b"]), ValueError,
         "`labels`"),
        (lambda: plotting.plot_scene(ax, reports=[[[0, 0]]], truth=[[0, 0, 0]]), ValueError,
         "`truth` must have shape"),
        (lambda: plotting.plot_scene(ax, sensors=[[0, 0, 1]], reports=[[[0, 0]]]), ValueError,
         "`sensors`"),
        (lambda: plotting.plot_scene(ax, reports="abc"), TypeError, "`reports` must be a sequence"),
        (lambda: plotting.plot_scene(ax, reports=[[[0, 0]]], n_sigma=-1), ValueError,
         "`n_sigma`"),
    ]
    for call, exc, message in cases:
        with pytest.raises(exc, match=message):
            call()


def test_negative_pair_index_means_no_partner(ax):
    xy = np.array([[0.0, 0.0], [1.0, 0.0]])
    plotting.plot_reports(ax, xy, xy, pairs=[(0, 0), (1, -1)])
    assert len(ax.lines) == 3                     # two report sets, one segment


_finite = st.floats(-1e6, 1e6, allow_nan=False)
_points = st.integers(1, 4).flatmap(lambda n: st.lists(st.tuples(_finite, _finite),
                                                       min_size=n, max_size=n))


@settings(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(reports=st.lists(_points, min_size=1, max_size=3),
       sigma=st.floats(1e-3, 1e3), n_sigma=st.floats(0.1, 5), with_truth=st.booleans())
def test_plot_scene_fuzz_valid_input_draws_everything(ax, reports, sigma, n_sigma, with_truth):
    ax.clear()
    covs = [sigma**2 * np.eye(2)] * len(reports)
    truth = reports[0] if with_truth else None
    plotting.plot_scene(ax, sensors=[[0, 0]] * len(reports), reports=reports,
                        covariances=covs, truth=truth, n_sigma=n_sigma)
    assert len(ax.patches) == sum(len(r) for r in reports)
    assert ax.get_legend() is not None


_bad_number = st.sampled_from([np.nan, np.inf, -np.inf, "1.0", True, None, 1 + 2j, [1, 2]])


@settings(deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(bad=_bad_number, where=st.sampled_from(["report", "cov", "n_sigma", "truth", "x", "pdf"]))
def test_fuzz_bad_numbers_are_refused_naming_the_argument(ax, bad, where):
    # numpy turns a bool inside a list of floats into 0.0/1.0: only whole bools are refused
    assume(bad is not True or where == "n_sigma")
    ok = np.array([[0.0, 0.0]])
    if where == "report":
        call, name = (lambda: plotting.plot_scene(ax, reports=[[[0.0, bad]]])), r"reports\[0\]"
    elif where == "cov":
        call, name = (lambda: plotting.plot_scene(ax, reports=[ok],
                                                  covariances=[[[1.0, 0.0], [0.0, bad]]])), \
            r"covariances\[0\]"
    elif where == "n_sigma":
        call, name = (lambda: plotting.plot_scene(ax, reports=[ok], n_sigma=bad)), "n_sigma"
    elif where == "truth":
        call, name = (lambda: plotting.plot_scene(ax, reports=[ok], truth=[[bad, 0.0]])), "truth"
    elif where == "x":
        call, name = (lambda: plotting.plot_density(ax, [0.0, bad], [1.0, 1.0])), "x"
    else:
        call, name = (lambda: plotting.plot_density(ax, [0.0, 1.0], [1.0, bad])), "pdf"
    with pytest.raises((TypeError, ValueError), match=f"`{name}`"):
        call()


def test_the_default_figure_text_is_at_least_9_pt_as_displayed():
    """A default-size figure fills the text column; its smallest text shows at >= 9 pt."""
    from radarfusion_ref.kit.plotting import BOOK_STYLE, TEXT_COLUMN_PX

    width_in = BOOK_STYLE["figure.figsize"][0]
    dpi = BOOK_STYLE["savefig.dpi"]
    # the image is width_in * dpi pixels, scaled to the column; 1 pt = dpi / 72 pixels
    shown_scale = min(1.0, TEXT_COLUMN_PX / (width_in * dpi))
    sizes = {k: v for k, v in BOOK_STYLE.items()
             if k.endswith("size") and not k.startswith("figure.fig")}
    assert {"legend.fontsize", "xtick.labelsize", "ytick.labelsize", "axes.labelsize"} <= set(sizes)
    for key, pt in sizes.items():
        shown_pt = pt * dpi / 72 * shown_scale * 72 / 96  # CSS: 96 px per inch
        assert shown_pt >= 9.0, f"{key} = {pt} pt shows at {shown_pt:.1f} pt"
    assert width_in * 96 == pytest.approx(TEXT_COLUMN_PX, rel=0.05)  # fills the column


def test_plot_fusion_centre_links_every_site():
    from radarfusion_ref.kit.plotting import plot_fusion_centre

    fig, ax = plt.subplots()
    plot_fusion_centre(ax, [5.0, -3.0], [[0, 0], [10, 0], [5, 8]])
    assert len(ax.texts) == 3                       # one arrow per radar
    assert ax.get_legend_handles_labels()[1] == ["fusion centre"]
    with pytest.raises(ValueError, match="`centre`"):
        plot_fusion_centre(ax, [[1.0, 2.0], [3.0, 4.0]], [[0, 0]])
    plt.close(fig)
