"""Tests of radarfusion_ref.conversion.

Oracles are independent of the module: a sympy derivation written here (the
Gaussian characteristic function, the Jacobian), the paper's printed equations
(2a–c) and (4a–c) typed in from the text, numerical quadrature, and seeded
Monte Carlo with tolerances from the standard error.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from radarfusion_ref import conversion as cv
from radarfusion_ref.errors import RadarFusionWarning

ALL = cv.METHODS


# --------------------------------------------------------------------------- independent sympy route
@functools.lru_cache(maxsize=1)
def _sympy_route():
    """Derive, with sympy, the moments of (r̂ cos β̂, r̂ sin β̂) and the linearized covariance."""
    r, sr, sb = sp.symbols("r sigma_r sigma_beta", positive=True)
    beta, w = sp.symbols("beta w", real=True)
    k = sp.symbols("k", positive=True)
    pdf = sp.exp(-w**2 / (2 * sb**2)) / (sp.sqrt(2 * sp.pi) * sb)
    ecos = sp.simplify(sp.integrate(sp.cos(k * w) * pdf, (w, -sp.oo, sp.oo), conds="none"))
    esin = sp.integrate(sp.sin(k * w) * pdf, (w, -sp.oo, sp.oo), conds="none")
    assert esin == 0

    # E[cos(β+w)] and E[cos 2(β+w)], E[sin 2(β+w)] through the characteristic function
    e1 = ecos.subs(k, 1)
    e2 = ecos.subs(k, 2)
    mean_x = r * sp.cos(beta) * e1
    mean_y = r * sp.sin(beta) * e1
    er2 = r**2 + sr**2
    exx = er2 * (1 + sp.cos(2 * beta) * e2) / 2
    eyy = er2 * (1 - sp.cos(2 * beta) * e2) / 2
    exy = er2 * sp.sin(2 * beta) * e2 / 2
    # linearized covariance from the Jacobian of (r cos β, r sin β)
    f = sp.Matrix([r * sp.cos(beta), r * sp.sin(beta)])
    jac = f.jacobian([r, beta])
    lin = sp.simplify(jac * sp.diag(sr**2, sb**2) * jac.T)
    syms = (r, beta, sr, sb)
    lam = sp.lambdify
    return {
        "mean": lam(syms, [mean_x, mean_y], "numpy"),
        "second": lam(syms, [exx, exy, eyy], "numpy"),
        "lin": lam(syms, lin, "numpy"),
        "ecos": ecos,
    }


def _rand_inputs(seed, n=25):
    g = np.random.default_rng(seed)
    return (g.uniform(1, 300, n), g.uniform(-np.pi, np.pi, n), g.uniform(0.01, 2, n),
            g.uniform(1e-3, cv.SIGMA_BETA_MAX, n))


def test_sympy_characteristic_function():
    ks, sb = sp.symbols("k sigma_beta", positive=True)
    assert sp.simplify(_sympy_route()["ecos"] - sp.exp(-ks**2 * sb**2 / 2)) == 0


def test_linearized_covariance_matches_jacobian_and_printed_2abc():
    r, b, sr, sb = _rand_inputs(1)
    out = cv.polar_to_cartesian(r, b, sr, sb)
    ref = np.moveaxis(np.array(_sympy_route()["lin"](r, b, sr, sb), dtype=float), -1, 0)
    np.testing.assert_allclose(out.cov, ref, rtol=1e-12)
    # Prosov (2a)-(2c) as printed
    c11 = r**2 * sb**2 * np.sin(b)**2 + sr**2 * np.cos(b)**2
    c22 = r**2 * sb**2 * np.cos(b)**2 + sr**2 * np.sin(b)**2
    c21 = (sr**2 - r**2 * sb**2) * np.sin(b) * np.cos(b)
    np.testing.assert_allclose(out.cov[:, 0, 0], c11, rtol=1e-12)
    np.testing.assert_allclose(out.cov[:, 1, 1], c22, rtol=1e-12)
    np.testing.assert_allclose(out.cov[:, 1, 0], c21, rtol=1e-12, atol=1e-12 * np.max(r**2))
    np.testing.assert_allclose(out.xy, np.stack([r * np.cos(b), r * np.sin(b)], -1))


@pytest.mark.parametrize("method", ALL)
def test_moments_given_truth_match_sympy(method):
    r, b, sr, sb = _rand_inputs(2)
    route = _sympy_route()
    mx, my = route["mean"](r, b, sr, sb)
    exx, exy, eyy = route["second"](r, b, sr, sb)
    g = {"linearized": 1.0, "additive": 1 + np.exp(-sb**2 / 2) - np.exp(-sb**2),
         "multiplicative": np.exp(sb**2 / 2), "first_order": 1 + sb**2 / 2,
         "first_order_printed": 1 - sb**2 / 2}[method]
    m = cv.conversion_moments(r, b, sr, sb, method=method)
    np.testing.assert_allclose(m.mean, np.stack([g * mx, g * my], -1), rtol=1e-12)
    cov = np.empty((len(r), 2, 2))
    cov[:, 0, 0] = g**2 * (exx - mx**2)
    cov[:, 1, 1] = g**2 * (eyy - my**2)
    cov[:, 0, 1] = cov[:, 1, 0] = g**2 * (exy - mx * my)
    np.testing.assert_allclose(m.cov, cov, rtol=1e-9, atol=1e-12 * np.max(r**2))
    np.testing.assert_allclose(m.bias, m.mean - np.stack([r * np.cos(b), r * np.sin(b)], -1),
                               atol=1e-12 * np.max(r))


def test_conversion_bias_closed_form_from_issue():
    r, b, _, sb = _rand_inputs(3)
    bias = cv.conversion_bias(r, b, sb)
    np.testing.assert_allclose(bias[:, 0], r * np.cos(b) * (np.exp(-sb**2 / 2) - 1), rtol=1e-12)
    np.testing.assert_allclose(bias[:, 1], r * np.sin(b) * (np.exp(-sb**2 / 2) - 1), rtol=1e-12)
    np.testing.assert_allclose(cv.conversion_bias(r, b, sb, method="multiplicative"), 0.0,
                               atol=1e-12 * np.max(r))


def test_bias_by_quadrature():
    # E[cos(β + w)] by numerical integration, independent of any closed form
    b, sb = 0.7, 0.3
    val, _ = integrate.quad(lambda w: np.cos(b + w) * np.exp(-w**2 / (2 * sb**2))
                            / np.sqrt(2 * np.pi) / sb, -12 * sb, 12 * sb, epsabs=1e-13)
    assert cv.conversion_bias(1.0, b, sb)[0] == pytest.approx(val - np.cos(b), abs=1e-12)


def test_additive_covariance_is_printed_4abc():
    """(4a)-(4c) as printed (exponents e^{-2σ²}, e^{-4σ²}, e^{+σ²}), evaluated at the measurement."""
    r, b, sr, sb = _rand_inputs(4)
    s = sb**2
    c, si = np.cos(b), np.sin(b)
    c11 = (r**2 * np.exp(-2 * s) * (c**2 * (np.cosh(2 * s) - np.cosh(s))
                                     + si**2 * (np.sinh(2 * s) - np.sinh(s)))
           + sr**2 * np.exp(-2 * s) * (c**2 * (2 * np.cosh(2 * s) - np.cosh(s))
                                      + si**2 * (2 * np.sinh(2 * s) - np.sinh(s))))
    c22 = (r**2 * np.exp(-2 * s) * (si**2 * (np.cosh(2 * s) - np.cosh(s))
                                     + c**2 * (np.sinh(2 * s) - np.sinh(s)))
           + sr**2 * np.exp(-2 * s) * (si**2 * (2 * np.cosh(2 * s) - np.cosh(s))
                                      + c**2 * (2 * np.sinh(2 * s) - np.sinh(s))))
    c12 = si * c * np.exp(-4 * s) * (sr**2 + (r**2 + sr**2) * (1 - np.exp(s)))
    for method in ("additive", "first_order", "first_order_printed"):
        out = cv.polar_to_cartesian(r, b, sr, sb, method=method)
        np.testing.assert_allclose(out.cov[:, 0, 0], c11, rtol=1e-9)
        np.testing.assert_allclose(out.cov[:, 1, 1], c22, rtol=1e-9)
        np.testing.assert_allclose(out.cov[:, 0, 1], c12, rtol=1e-9, atol=1e-12 * np.max(r**2))


@pytest.mark.parametrize("method", ["linearized", "additive", "multiplicative"])
def test_monte_carlo_mean_and_covariance_given_truth(method):
    r, b, sr, sb = 120.0, 0.4, 0.5, 0.2
    n = 200_000
    out = cv.conversion_monte_carlo(r, b, sr, sb, methods=(method,), trials=n, rng=11)[method]
    m = cv.conversion_moments(r, b, sr, sb, method=method)
    est = out.bias()
    assert np.all(np.abs(est.estimate - m.bias) < 5 * est.std_error)
    emp_cov = np.cov(out.error.T)
    # standard error of a sample covariance entry ~ sqrt((σ_ii σ_jj + σ_ij²)/n)
    d = np.sqrt(np.diag(m.cov))
    se = np.sqrt((np.outer(d, d) ** 2 + m.cov**2) / n)
    assert np.all(np.abs(emp_cov - m.cov) < 6 * se)


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(("kwargs", "name"), [
    ({"r": -1.0}, "`r`"),
    ({"sigma_r": -0.1}, "`sigma_r`"),
    ({"sigma_beta": -0.01}, "`sigma_beta`"),
    ({"sigma_beta": 1.0}, "`sigma_beta`"),
    ({"beta": np.nan}, "`beta`"),
    ({"r": np.ones(3), "beta": np.ones(2)}, "`beta`"),
])
def test_bad_input_names_argument(kwargs, name):
    args = {"r": 100.0, "beta": 0.1, "sigma_r": 0.1, "sigma_beta": 0.01} | kwargs
    with pytest.raises(ValueError, match=name):
        cv.polar_to_cartesian(**args)


def test_bad_method():
    with pytest.raises(ValueError, match="`method`"):
        cv.polar_to_cartesian(100.0, 0.0, 0.1, 0.01, method="exact")


def test_degrees_by_mistake_is_caught():
    with pytest.raises(ValueError, match=r"np\.deg2rad"):
        cv.polar_to_cartesian(100.0, 0.0, 0.1, 1.0)


def test_singular_covariance_warns():
    with pytest.warns(RadarFusionWarning, match="singular"):
        cv.polar_to_cartesian(100.0, 0.0, 0.1, 0.0)


# --------------------------------------------------------------------------- properties
finite = dict(allow_nan=False, allow_infinity=False)
polar = st.tuples(st.floats(0.5, 500, **finite), st.floats(-7, 7, **finite),
                  st.floats(0.01, 5, **finite), st.floats(1e-3, cv.SIGMA_BETA_MAX, **finite))


@settings(max_examples=40, deadline=None)
@given(st.lists(polar, min_size=1, max_size=6), st.sampled_from(ALL))
def test_vectorized_equals_loop(rows, method):
    r, b, sr, sb = (np.array(c) for c in zip(*rows, strict=True))
    batch = cv.polar_to_cartesian(r, b, sr, sb, method=method)
    for i in range(len(r)):
        one = cv.polar_to_cartesian(r[i], b[i], sr[i], sb[i], method=method)
        np.testing.assert_allclose(batch.xy[i], one.xy, rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(batch.cov[i], one.cov, rtol=1e-13, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(polar, st.floats(-7, 7, **finite), st.sampled_from(ALL))
def test_rotation_equivariance(p, phi, method):
    r, b, sr, sb = p
    rot = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]])
    a = cv.polar_to_cartesian(r, b, sr, sb, method=method)
    c = cv.polar_to_cartesian(r, b + phi, sr, sb, method=method)
    scale = r**2 + sr**2
    np.testing.assert_allclose(c.xy, rot @ a.xy, atol=1e-9 * r)
    np.testing.assert_allclose(c.cov, rot @ a.cov @ rot.T, atol=1e-9 * scale)


@settings(max_examples=60, deadline=None)
@given(polar, st.sampled_from(ALL))
def test_covariance_symmetric_positive_definite(p, method):
    out = cv.polar_to_cartesian(*p, method=method)
    assert out.cov[0, 1] == out.cov[1, 0]
    eig = np.linalg.eigvalsh(out.cov)
    assert eig[0] > 0
