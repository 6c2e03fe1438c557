"""The numeric domain and the length unit: answers that must not depend on either.

* Every decision of :func:`registration.register_and_associate` (the pairing of
  every pass, convergence, the number of passes) is the same when all lengths are
  scaled by a factor in 1e-3 ... 1e3, with and without a gate; its bias estimate
  scales with the unit (range offsets by the factor, range scale and azimuth offset
  not at all).
* The fusion rules stay finite everywhere inside the documented domain: values of
  magnitude up to ``MAX_MAGNITUDE`` and variances in [2**-150, 2**150] (the domain
  of :mod:`radarfusion_ref.engine.linalg`), and they match an independent
  formula evaluated in exact rational arithmetic.
* The conversion layer's refusal of a range whose conversion overflows is what a
  user of :func:`register_and_associate` sees, named by the public argument.
"""

from __future__ import annotations

import warnings
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from radarfusion_ref import fusion, trackfusion
from radarfusion_ref import registration as rg
from radarfusion_ref.engine.errors import RadarFusionWarning
from radarfusion_ref.engine.validation import MAX_MAGNITUDE

SITES = np.array([[0.0, 0.0], [30.0, 0.0]])
TARGETS = np.array([[0.0, 60.0], [30.0, 70.0], [-20.0, 50.0], [10.0, 80.0], [45.0, 55.0],
                    [5.0, 65.0], [-10.0, 75.0]])
BIAS = np.array([[0.3, 1e-3, 2e-3], [-0.2, -5e-4, -1e-3]])
SR, SB = 0.05, 1e-3
EXPONENTS = st.one_of(st.sampled_from([-3.0, 3.0]), st.floats(-3.0, 3.0))     # 1e-3 ... 1e3
UNITS = np.array([1.0, 0.0, 0.0])          # which bias components carry a length


def _run(k, seed, gate, initial=None):
    z = rg.draw_biased_reports(SITES, TARGETS, BIAS, SR, SB, rng=seed)
    z1, z2 = np.array(z[0]), np.array(z[1][::-1])
    z1[:, 0] *= k
    z2[:, 0] *= k
    with warnings.catch_warnings():
        warnings.simplefilter("error", RadarFusionWarning)
        return rg.register_and_associate(SITES * k, z1, z2, SR * k, SB, p_false_reject=gate,
                                         initial=initial)


@settings(max_examples=25, deadline=None)
@given(exponent=EXPONENTS, seed=st.integers(0, 50), gate=st.sampled_from([None, 1e-3]))
def test_register_and_associate_decides_the_same_in_any_length_unit(exponent, seed, gate):
    k = 10.0 ** exponent
    ref, got = _run(1.0, seed, gate), _run(k, seed, gate)
    assert got.converged == ref.converged
    assert got.iterations == ref.iterations
    assert [h.row_to_col.tolist() for h in got.history] == \
        [h.row_to_col.tolist() for h in ref.history]
    assert [h.n_pairs for h in got.history] == [h.n_pairs for h in ref.history]
    scale = np.where(UNITS > 0, k, 1.0)
    np.testing.assert_allclose(got.biases / scale, ref.biases, rtol=1e-6, atol=1e-12)
    # kappa is dimensionless: the summed cost of every pass is the same number
    np.testing.assert_allclose([h.total_cost for h in got.history],
                               [h.total_cost for h in ref.history], rtol=1e-6)


def test_the_unit_test_above_can_see_a_unit_dependent_decision():
    """A pairing made with sigma_r left in the old unit differs: the property can fail."""
    z = rg.draw_biased_reports(SITES, TARGETS, BIAS, SR, SB, rng=1)
    k = 1e3
    z1, z2 = np.array(z[0]), np.array(z[1][::-1])
    z1[:, 0] *= k
    z2[:, 0] *= k
    ref = rg.register_and_associate(SITES, z[0], z[1][::-1], SR, SB)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadarFusionWarning)
        wrong = rg.register_and_associate(SITES * k, z1, z2, SR, SB)   # sigma_r not scaled
    assert [h.total_cost for h in wrong.history] != pytest.approx(
        [h.total_cost for h in ref.history], rel=1e-3)


# --------------------------------------------------------------------------- fusion domain
_MAG = st.floats(-float(MAX_MAGNITUDE), float(MAX_MAGNITUDE), allow_nan=False,
                 allow_infinity=False)
_VAR_EXP = st.integers(-150, 150)


def _exact_fuse(x, var):
    """Inverse-variance weighting in exact rational arithmetic (independent of the package)."""
    xs, ws = [Fraction(v) for v in x], [1 / Fraction(v) for v in var]
    total = sum(ws)
    return float(sum(w * v for w, v in zip(ws, xs, strict=True)) / total), float(1 / total)


@settings(max_examples=200, deadline=None)
@given(x=st.lists(_MAG, min_size=2, max_size=5), exps=st.lists(_VAR_EXP, min_size=5,
                                                                 max_size=5),
       mant=st.lists(st.floats(1.0, 2.0), min_size=5, max_size=5))
def test_fuse_is_finite_and_exact_everywhere_in_the_domain(x, exps, mant):
    var = [m * 2.0 ** e for m, e in zip(mant, exps, strict=True)][:len(x)]
    est = fusion.fuse(x, var)
    value, variance = float(np.asarray(est.estimate)), float(np.asarray(est.variance))
    assert np.isfinite(value) and np.isfinite(variance) and variance > 0
    want, want_var = _exact_fuse(x, var)
    assert variance == pytest.approx(want_var, rel=1e-12)
    # the estimate is a convex combination: within rounding of the exact weighted mean
    assert abs(value - want) <= 1e-12 * max(abs(v) for v in x) + 1e-300


def _random_track_pair(rng, scale_exp):
    a = rng.normal(size=(4, 4))
    joint = (a @ a.T + 0.5 * np.eye(4)) * 2.0 ** scale_exp      # a valid joint covariance
    x1, x2 = rng.normal(size=2), rng.normal(size=2)
    return x1, joint[:2, :2], x2, joint[2:, 2:], joint[:2, 2:]


@settings(max_examples=60, deadline=None)
@given(scale_exp=st.integers(-140, 140), seed=st.integers(0, 10_000))
def test_track_fusion_rules_stay_finite_and_scale_exactly_in_the_domain(scale_exp, seed):
    """Bar-Shalom-Campo and CI across the domain: finite, and equal to the unit-scale answer
    multiplied by the scale (a power of two, so the scaling itself is exact)."""
    rng = np.random.default_rng(seed)
    x1, p1, x2, p2, c = _random_track_pair(rng, 0)
    s = 2.0 ** scale_exp
    r = np.sqrt(s)
    for rule, args in (("bc", (c,)), ("ci", ())):
        if rule == "bc":
            ref = trackfusion.bar_shalom_campo(x1, p1, x2, p2, *args)
            got = trackfusion.bar_shalom_campo(x1 * r, p1 * s, x2 * r, p2 * s, c * s)
        else:
            ref = trackfusion.covariance_intersection(x1, p1, x2, p2)
            got = trackfusion.covariance_intersection(x1 * r, p1 * s, x2 * r, p2 * s)
        assert np.all(np.isfinite(got.estimate)) and np.all(np.isfinite(got.covariance))
        np.testing.assert_allclose(got.estimate / r, ref.estimate, rtol=1e-7, atol=1e-9)
        np.testing.assert_allclose(got.covariance / s, ref.covariance, rtol=1e-7, atol=1e-9)


# --------------------------------------------------------------------------- conversion layer
def test_an_overflowing_range_reaches_the_user_of_register_and_associate_by_name():
    z = rg.draw_biased_reports(SITES, TARGETS, BIAS, SR, SB, rng=2)
    z1 = np.array(z[0])
    z1[0, 0] = 1e308
    with pytest.raises(ValueError, match=r"`reports1`") as info:
        rg.register_and_associate(SITES, z1, z[1], SR, SB)
    assert "1e+308" in str(info.value)
