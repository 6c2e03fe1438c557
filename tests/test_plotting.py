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
