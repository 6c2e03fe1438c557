"""Plotting helpers: geometry checked against the quadratic form they draw."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from radarfusion_ref.plotting import plot_covariance_ellipse, plot_reports


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
    from radarfusion_ref.plotting import plot_groups

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
    from radarfusion_ref.plotting import plot_scene

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
    from radarfusion_ref.plotting import plot_scene
    from radarfusion_ref.scenes import two_radar_scene

    fig, (ax1, ax2) = plt.subplots(1, 2)
    plot_scene(ax1, scene=two_radar_scene(3, spacing=1.0, sigma1=0.1, sigma2=0.2, rng=1))
    plot_scene(ax2, scene=two_radar_scene(3, spacing=1.0, sigma1=0.1, sigma2=0.2, dim=2,
                                          trials=2, rng=1), trial=1)
    n1, n2 = len(ax1.lines), len(ax2.patches)
    plt.close(fig)
    assert n1 >= 3 and n2 == 6
