"""The shared two-radar scene simulator."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from radarfusion_ref.montecarlo import binomial_tolerance
from radarfusion_ref.scenes import nearest_neighbour_pairing, two_radar_scene


def test_errors_have_the_stated_variances():
    sc = two_radar_scene(3, spacing=2.0, sigma1=0.3, sigma2=0.7, trials=40_000, dim=2, rng=1)
    e1 = sc.reports1 - sc.truth
    e2 = sc.reports2 - np.take_along_axis(sc.truth, sc.owner2[..., None], axis=1)
    # sample variance of 240 000 normals: relative standard error sqrt(2/N) ~ 0.3 %
    np.testing.assert_allclose(e1.var(), 0.09, rtol=0.02)
    np.testing.assert_allclose(e2.var(), 0.49, rtol=0.02)
    np.testing.assert_allclose(e1.mean(), 0, atol=0.01)


def test_owner_is_a_uniform_random_permutation():
    sc = two_radar_scene(3, spacing=1.0, sigma1=0.1, sigma2=0.1, trials=60_000, rng=2)
    perms = {p: 0 for p in itertools.permutations(range(3))}
    for row in map(tuple, sc.owner2):
        perms[row] += 1
    freq = np.array(list(perms.values())) / 60_000
    assert np.all(np.abs(freq - 1 / 6) < binomial_tolerance(1 / 6, 60_000))


def test_true_match_inverts_owner():
    sc = two_radar_scene(5, spacing=1.0, sigma1=0.1, sigma2=0.1, trials=10, rng=3)
    owner_of_match = np.take_along_axis(sc.owner2, sc.true_match, axis=1)
    np.testing.assert_array_equal(owner_of_match, np.broadcast_to(np.arange(5), (10, 5)))


def test_reproducible_with_seed():
    a = two_radar_scene(4, spacing=1.0, sigma1=0.2, sigma2=0.2, trials=3, rng=42)
    b = two_radar_scene(4, spacing=1.0, sigma1=0.2, sigma2=0.2, trials=3, rng=42)
    np.testing.assert_array_equal(a.reports2, b.reports2)


def test_uniform_layout_density():
    sc = two_radar_scene(50, spacing=2.0, sigma1=0.1, sigma2=0.1, trials=200, dim=2,
                         layout="uniform", rng=4)
    side = 2.0 * np.sqrt(50)
    assert sc.truth.min() >= 0 and sc.truth.max() <= side


@settings(max_examples=40, deadline=None)
@given(n1=st.integers(1, 6), n2=st.integers(1, 6), d=st.integers(1, 3), seed=st.integers(0, 99))
def test_nearest_neighbour_equals_loop(n1, n2, d, seed):
    g = np.random.default_rng(seed)
    r1, r2 = g.normal(size=(n1, d)), g.normal(size=(n2, d))
    loop = [int(np.argmin([np.sum((a - b) ** 2) for b in r2])) for a in r1]
    np.testing.assert_array_equal(nearest_neighbour_pairing(r1, r2), loop)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"spacing": 0.0}, "`spacing`"),
        ({"sigma1": -1.0}, "`sigma1`"),
        ({"trials": 0}, "`trials`"),
        ({"layout": "grid"}, "`layout`"),
        ({"n_objects": 0}, "`n_objects`"),
    ],
)
def test_bad_input(kwargs, match):
    args = {"n_objects": 2, "spacing": 1.0, "sigma1": 0.1, "sigma2": 0.1} | kwargs
    n = args.pop("n_objects")
    with pytest.raises(ValueError, match=match):
        two_radar_scene(n, **args)


def test_nearest_neighbour_dimension_mismatch():
    with pytest.raises(ValueError, match="same last dimension"):
        nearest_neighbour_pairing(np.zeros((2, 2)), np.zeros((2, 3)))


@settings(max_examples=30, deadline=None)
@given(angle=st.floats(-4, 4), a=st.floats(0.1, 5), b=st.floats(0.1, 5))
def test_ellipse_covariance_has_the_stated_axes(angle, a, b):
    from radarfusion_ref.scenes import ellipse_covariance

    cov = ellipse_covariance(angle, a, b)
    u = np.array([np.cos(angle), np.sin(angle)])          # the major-axis direction
    v = np.array([-np.sin(angle), np.cos(angle)])
    assert u @ cov @ u == pytest.approx(a * a) and v @ cov @ v == pytest.approx(b * b)
    assert u @ cov @ v == pytest.approx(0.0, abs=1e-9 * (a * a + b * b))
