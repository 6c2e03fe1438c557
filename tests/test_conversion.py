"""Tests of radarfusion_ref.conversion.

Oracles are independent of the module: a sympy derivation written here (the
Gaussian characteristic function, the Jacobian), the paper's printed equations
(2a–c) and (4a–c) typed in from the text, numerical quadrature, and seeded
Monte Carlo with tolerances from the standard error.
"""

from __future__ import annotations

import functools
import math

import mpmath
import numpy as np
import pytest
import sympy as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from radarfusion_ref import conversion as cv
from radarfusion_ref.engine.errors import RadarFusionWarning
from radarfusion_ref.engine.geometry import SIGMA_BETA_MAX

ALL = (*cv.METHODS, "measurement_conditioned")     # every method that needs no prior


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
            g.uniform(1e-3, SIGMA_BETA_MAX, n))


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
         "first_order_printed": 1 - sb**2 / 2, "measurement_conditioned": np.exp(-sb**2 / 2)
         }[method]
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
                  st.floats(0.01, 5, **finite), st.floats(1e-3, SIGMA_BETA_MAX, **finite))


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


# --------------------------------------------------------------------------- measured-conditioned covariances
def _gauss_hermite(n=40):
    """Nodes and weights for E f(Z), Z ~ N(0, 1)."""
    x, wts = np.polynomial.hermite_e.hermegauss(n)
    return x, wts / np.sqrt(2 * np.pi)


def _truth_cov_sympy(r, b, sr, sb):
    """Cov[x̂ | r, β] from the sympy route, shape (..., 2, 2)."""
    route = _sympy_route()
    mx, my = route["mean"](r, b, sr, sb)
    exx, exy, eyy = route["second"](r, b, sr, sb)
    out = np.empty((*np.shape(mx), 2, 2))
    out[..., 0, 0] = exx - mx**2
    out[..., 1, 1] = eyy - my**2
    out[..., 0, 1] = out[..., 1, 0] = exy - mx * my
    return out


def test_additive_covariance_is_truth_covariance_averaged_over_truth():
    """R^a = E[Cov(x̂ | r, β) | r̂, β̂] by Gauss-Hermite quadrature over r = r̂ - v, β = β̂ - w."""
    x, wt = _gauss_hermite()
    for rh, bh, sr, sb in zip(*_rand_inputs(5, n=6), strict=True):
        rr = rh - sr * x[:, None]
        bb = bh - sb * x[None, :]
        cov = _truth_cov_sympy(rr, bb, sr, sb)
        avg = np.einsum("i,j,ijkl->kl", wt, wt, cov)
        got = cv.polar_to_cartesian(rh, bh, sr, sb, method="additive").cov
        np.testing.assert_allclose(got, avg, rtol=1e-8, atol=1e-10 * rh**2)


def test_multiplicative_covariance_is_mse_given_measurement():
    """Mo et al.: E[(x_u - x)(x_u - x)ᵀ | r̂, β̂] by quadrature, the truth N(measurement, σ²)."""
    x, wt = _gauss_hermite()
    for rh, bh, sr, sb in zip(*_rand_inputs(6, n=6), strict=True):
        conv = cv.polar_to_cartesian(rh, bh, sr, sb, method="multiplicative")
        rr = rh - sr * x[:, None]
        bb = bh - sb * x[None, :]
        e = conv.xy - np.stack([rr * np.cos(bb), rr * np.sin(bb)], -1)
        mse = np.einsum("i,j,ijk,ijl->kl", wt, wt, e, e)
        np.testing.assert_allclose(conv.cov, mse, rtol=1e-8, atol=1e-10 * rh**2)


def test_measurement_conditioned_is_the_conditional_mean_and_covariance():
    """Duan et al.: E[x | r̂, β̂] and Cov[x | r̂, β̂] by quadrature, the truth N(measurement, σ²)."""
    x, wt = _gauss_hermite()
    for rh, bh, sr, sb in zip(*_rand_inputs(16, n=6), strict=True):
        conv = cv.polar_to_cartesian(rh, bh, sr, sb, method="measurement_conditioned")
        rr = rh - sr * x[:, None]
        bb = bh - sb * x[None, :]
        pts = np.stack([rr * np.cos(bb), rr * np.sin(bb)], -1)
        mu = np.einsum("i,j,ijk->k", wt, wt, pts)
        cov = np.einsum("i,j,ijk,ijl->kl", wt, wt, pts - mu, pts - mu)
        np.testing.assert_allclose(conv.xy, mu, rtol=1e-10, atol=1e-10 * rh)
        np.testing.assert_allclose(conv.cov, cov, rtol=1e-8, atol=1e-10 * rh**2)


def _prior_polar_by_jacobian(xp, pc):
    """Polar prior (r_p, β_p, σ_rp², σ_βp²): the diagonal of J⁻¹ P J⁻ᵀ, J = ∂(x, y)/∂(r, β)."""
    r_p, b_p = np.hypot(*xp), np.arctan2(xp[1], xp[0])
    jac = np.array([[np.cos(b_p), -r_p * np.sin(b_p)], [np.sin(b_p), r_p * np.cos(b_p)]])
    polar = np.linalg.solve(jac, np.linalg.solve(jac, pc).T)       # J⁻¹ P J⁻ᵀ (P symmetric)
    return r_p, b_p, polar[0, 0], polar[1, 1]


def test_decorrelated_covariance_is_truth_covariance_averaged_over_the_prior():
    """Bordonaro et al.: E[Cov(x̂_mult | r, β) | prior] by quadrature, r ~ N(r_p, σ_rp²),
    β ~ N(β_p, σ_βp²), with the sympy covariance given the truth (times the gain²)."""
    x, wt = _gauss_hermite()
    g = np.random.default_rng(7)
    for rh, bh, sr, sb in zip(*_rand_inputs(17, n=6), strict=True):
        xp = rh * np.array([np.cos(bh + 0.05), np.sin(bh + 0.05)]) + g.normal(0, 1, 2)
        a = g.normal(0, 1.5, (2, 2))
        pc = a @ a.T
        r_p, b_p, vr, vb = _prior_polar_by_jacobian(xp, pc)
        rr = r_p + np.sqrt(vr) * x[:, None]
        bb = b_p + np.sqrt(vb) * x[None, :]
        avg = np.exp(sb**2) * np.einsum("i,j,ijkl->kl", wt, wt, _truth_cov_sympy(rr, bb, sr, sb))
        got = cv.polar_to_cartesian(rh, bh, sr, sb, method="decorrelated", prior_xy=xp,
                                    prior_cov=pc)
        np.testing.assert_allclose(got.cov, avg, rtol=1e-8, atol=1e-10 * rh**2)
        np.testing.assert_allclose(got.xy, np.exp(sb**2 / 2) * rh * np.array(
            [np.cos(bh), np.sin(bh)]), rtol=1e-12)
        # the covariance does not depend on the measurement
        other = cv.polar_to_cartesian(rh * 1.3, bh - 0.2, sr, sb, method="decorrelated",
                                      prior_xy=xp, prior_cov=pc)
        np.testing.assert_array_equal(other.cov, got.cov)


def test_decorrelated_with_an_exact_prior_is_the_exact_covariance():
    r, b, sr, sb = _rand_inputs(18)
    exact = np.exp(sb**2)[:, None, None] * _truth_cov_sympy(r, b, sr, sb)
    xp = np.stack([r * np.cos(b), r * np.sin(b)], -1)
    got = cv.polar_to_cartesian(r * 0.9, b + 0.1, sr, sb, method="decorrelated", prior_xy=xp)
    np.testing.assert_allclose(got.cov, exact, rtol=1e-9, atol=1e-12 * np.max(r**2))
    np.testing.assert_allclose(cv.nees_at_truth(r, b, sr, sb, method="decorrelated"), 2.0,
                               rtol=1e-12)


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"method": "decorrelated"}, "`prior_xy`"),
    ({"method": "multiplicative", "prior_xy": [1.0, 1.0]}, "`prior_xy`"),
    ({"method": "decorrelated", "prior_xy": [0.0, 0.0]}, "`prior_xy`"),
    ({"method": "decorrelated", "prior_xy": [1.0, 1.0, 1.0]}, "`prior_xy`"),
    ({"method": "decorrelated", "prior_xy": [1.0, np.nan]}, "`prior_xy`"),
    ({"method": "decorrelated", "prior_xy": [1.0, 1.0], "prior_cov": -np.eye(2)}, "`prior_cov`"),
    ({"method": "decorrelated", "prior_xy": [1.0, 1.0], "prior_cov": [[1.0, 2.0], [0.0, 1.0]]},
     "`prior_cov`"),
    ({"method": "decorrelated", "prior_xy": [1.0, 1.0], "prior_cov": [[1.0, 2.0], [2.0, 1.0]]},
     "`prior_cov`"),
    ({"method": "decorrelated", "prior_xy": [1.0, 1.0], "prior_cov": "big"}, "`prior_cov`"),
])
def test_decorrelated_bad_prior(kwargs, match):
    with pytest.raises((ValueError, TypeError), match=match):
        cv.polar_to_cartesian(100.0, 0.3, 0.5, 0.1, **kwargs)


def test_monte_carlo_prior_std_is_required_by_decorrelated_only():
    with pytest.raises(ValueError, match="`prior_std`"):
        cv.conversion_monte_carlo(100.0, 0.3, 0.5, 0.1, methods=("decorrelated",), trials=3, rng=1)
    with pytest.raises(ValueError, match="`prior_std`"):
        cv.conversion_monte_carlo(100.0, 0.3, 0.5, 0.1, trials=3, rng=1, prior_std=1.0)
    with pytest.raises(ValueError, match="`prior_std`"):
        cv.conversion_monte_carlo(100.0, 0.3, 0.5, 0.1, methods=("decorrelated",), trials=3,
                                  rng=1, prior_std=-1.0)


def test_monte_carlo_prior_draws_leave_the_other_methods_unchanged():
    a = cv.conversion_monte_carlo([100.0, 50.0], 0.3, 0.5, 0.2, methods=("linearized",),
                                  trials=500, rng=4)["linearized"]
    b = cv.conversion_monte_carlo([100.0, 50.0], 0.3, 0.5, 0.2,
                                  methods=("linearized", "decorrelated"), trials=500, rng=4,
                                  prior_std=2.0)
    np.testing.assert_array_equal(a.error, b["linearized"].error)
    np.testing.assert_array_equal(a.nees, b["linearized"].nees)


def test_monte_carlo_decorrelated_matches_the_direct_conversion_and_nees():
    """The chunked decorrelated NEES equals the generic NEES of polar_to_cartesian's output,
    with the prior re-drawn from the same stream (after the measurements)."""
    r, b, sr, sb, ps, n = 80.0, -0.7, 0.5, 0.3, 1.5, 300
    out = cv.conversion_monte_carlo(r, b, sr, sb, methods=("decorrelated",), trials=n, rng=9,
                                    prior_std=ps)["decorrelated"]
    g = np.random.default_rng(9)
    rh = r + sr * g.standard_normal(n)
    bh = b + sb * g.standard_normal(n)
    xp = r * np.array([np.cos(b), np.sin(b)]) + ps * g.standard_normal((n, 2))
    conv = cv.polar_to_cartesian(rh, bh, sr, sb, method="decorrelated", prior_xy=xp,
                                 prior_cov=ps**2 * np.eye(2))
    truth = r * np.array([np.cos(b), np.sin(b)])
    np.testing.assert_allclose(out.error, conv.xy - truth, rtol=1e-12, atol=1e-12 * r)
    err = conv.xy - truth
    direct = np.einsum("ni,ni->n", err, np.linalg.solve(conv.cov, err[..., None])[..., 0])
    np.testing.assert_allclose(out.nees, direct, rtol=1e-9)


@pytest.mark.parametrize("method", [*ALL, "decorrelated"])
def test_noncredibility_index_is_the_mean_log_ratio(method):
    """NCI against a direct evaluation: the exact MSE from the sympy route, NEES by solve."""
    r, b, sr, sb, n = 90.0, 1.1, 0.5, 0.25, 400
    kw = {"prior_std": 1.0} if method == "decorrelated" else {}
    out = cv.conversion_monte_carlo(r, b, sr, sb, methods=(method,), trials=n, rng=5,
                                    **kw)[method]
    route = _sympy_route()
    g = {"linearized": 1.0, "additive": 1 + np.exp(-sb**2 / 2) - np.exp(-sb**2),
         "multiplicative": np.exp(sb**2 / 2), "decorrelated": np.exp(sb**2 / 2),
         "first_order": 1 + sb**2 / 2, "first_order_printed": 1 - sb**2 / 2,
         "measurement_conditioned": np.exp(-sb**2 / 2)}[method]
    mean_xy = g * np.array(route["mean"](r, b, sr, sb))
    bias = mean_xy - r * np.array([np.cos(b), np.sin(b)])
    mse = g**2 * _truth_cov_sympy(r, b, sr, sb) + np.outer(bias, bias)
    e = out.error
    ntrue = np.einsum("ni,ni->n", e, np.linalg.solve(mse, e.T).T)
    np.testing.assert_allclose(out.nees_true, ntrue, rtol=1e-8)
    nci = out.noncredibility()
    ref = 10 * np.log10(out.nees / ntrue)
    assert nci.estimate == pytest.approx(ref.mean(), rel=1e-8, abs=1e-10)
    assert nci.std_error == pytest.approx(ref.std(ddof=1) / np.sqrt(n), rel=1e-6)


def test_noncredibility_needs_the_true_nees():
    t = cv.ConversionTrials("linearized", np.ones((3, 2)), np.ones(3))
    with pytest.raises(ValueError, match="`nees_true`"):
        t.noncredibility()


def test_new_methods_consistent_and_biased_as_derived_by_monte_carlo():
    """Mean NEES 2 (given the truth, over the measurements) for the decorrelated covariance
    with an exact prior; the measurement-conditioned bias given the truth is
    (e^{−σβ²} − 1) r u(β) (by the sympy route: E cos w = e^{−σβ²/2}, twice)."""
    r, b, sr, sb, n = 100.0, 0.3, 1.0, 0.3, 100_000
    out = cv.conversion_monte_carlo(r, b, sr, sb, methods=("measurement_conditioned",
                                                           "decorrelated"),
                                    trials=n, rng=21, prior_std=0.0)
    ecos = float(_sympy_route()["ecos"].subs({sp.Symbol("k", positive=True): 1,
                                              sp.Symbol("sigma_beta", positive=True): sb}))
    bias = (ecos**2 - 1) * r * np.array([np.cos(b), np.sin(b)])
    est = out["measurement_conditioned"].bias()
    assert np.all(np.abs(est.estimate - bias) < 5 * est.std_error)
    mn = out["decorrelated"].mean_nees()
    assert abs(mn.estimate - 2.0) < 5 * mn.std_error


def test_additive_gain_subtracts_the_averaged_bias():
    x, wt = _gauss_hermite()
    rh, bh, sr, sb = 120.0, 0.8, 0.3, 0.25
    rr = rh - sr * x[:, None]
    bb = bh - sb * x[None, :]
    bias_t = (np.exp(-sb**2 / 2) - 1) * np.stack([rr * np.cos(bb), rr * np.sin(bb)], -1)
    mu_a = np.einsum("i,j,ijk->k", wt, wt, bias_t)
    got = cv.polar_to_cartesian(rh, bh, sr, sb, method="additive").xy
    np.testing.assert_allclose(got, rh * np.array([np.cos(bh), np.sin(bh)]) - mu_a, rtol=1e-10)


# --------------------------------------------------------------------------- biases by Monte Carlo
def test_printed_first_order_doubles_the_bias_and_derived_removes_it():
    r, b, sr, sb = 150.0, np.pi / 4, 0.1, np.deg2rad(1.0)
    n = 200_000
    out = cv.conversion_monte_carlo(r, b, sr, sb, methods=("linearized", "first_order",
                                                           "first_order_printed"),
                                    trials=n, rng=2024)
    los = np.array([np.cos(b), np.sin(b)])
    plain = -r * (1 - np.exp(-sb**2 / 2))            # closed form, along the line of sight
    for m, expected in (("linearized", plain), ("first_order", 0.0),
                        ("first_order_printed", 2 * plain)):
        est = out[m].bias()
        along = float(est.estimate @ los)
        se = float(np.sqrt(np.var(out[m].error @ los, ddof=1) / n))
        # first order: residual -rσ⁴/8 ≈ 1e-9 km; printed: 2·plain up to O(σ⁴)
        assert abs(along - expected) < 5 * se + abs(plain) * sb**2, (m, along, expected, se)


def test_residual_bias_of_corrected_conversions_by_monte_carlo():
    r, sr, sb, n = 100.0, 1.0, 0.4, 200_000
    out = cv.conversion_monte_carlo(r, 0.0, sr, sb, methods=("additive", "first_order",
                                                           "multiplicative"),
                                    trials=n, rng=99)
    for m, o in out.items():
        est = o.bias()
        exact = cv.conversion_bias(r, 0.0, sb, method=m)
        assert np.all(np.abs(est.estimate - exact) < 5 * est.std_error), m
    # the additive residual is really there (≈ -rσ⁴/2), not a rounding artefact
    add = out["additive"].bias()
    assert add.high[0] < 0


# --------------------------------------------------------------------------- NEES
def test_nees_matches_solve_and_chi2_mean():
    g = np.random.default_rng(3)
    a = g.normal(size=(500, 2, 2))
    cov = a @ np.swapaxes(a, -1, -2) + 0.1 * np.eye(2)
    e = g.normal(size=(500, 2))
    ref = np.einsum("ni,ni->n", e, np.linalg.solve(cov, e[..., None])[..., 0])
    np.testing.assert_allclose(cv.nees_per_trial(e, cov), ref, rtol=1e-10)
    # Gaussian errors with the right covariance: mean NEES = 2, variance 4 (χ²₂)
    chol = np.linalg.cholesky(cov)
    draws = np.einsum("nij,tnj->tni", chol, g.normal(size=(400, 500, 2)))
    vals = cv.nees_per_trial(draws, cov)
    assert abs(vals.mean() - 2) < 5 * 2 / np.sqrt(vals.size)


def test_nees_general_dimension():
    cov = np.diag([1.0, 4.0, 9.0])
    assert cv.nees_per_trial([1.0, 2.0, 3.0], cov) == pytest.approx(3.0)


@pytest.mark.parametrize(("err", "cov", "name"), [
    ([1.0, 1.0], [[1.0, 2.0], [2.0, 1.0]], "`cov`"),
    ([1.0, 1.0], [[1.0, 0.5], [0.4, 1.0]], "`cov`"),
    ([1.0, 1.0], np.eye(3), "`cov`"),
    (np.ones((3, 2)), np.broadcast_to(np.eye(2), (4, 2, 2)), "`error`"),
])
def test_nees_bad_input(err, cov, name):
    with pytest.raises(ValueError, match=name):
        cv.nees_per_trial(err, cov)


def test_nees_at_truth_linearized_small_sigma_is_two_and_matches_sympy():
    assert cv.nees_at_truth(150.0, 0.3, 0.1, 1e-5) == pytest.approx(2.0, rel=1e-6)
    r, b, sr, sb = _rand_inputs(7)
    lin = np.moveaxis(np.array(_sympy_route()["lin"](r, b, sr, sb), dtype=float), -1, 0)
    mse = _truth_cov_sympy(r, b, sr, sb)
    bias = cv.conversion_bias(r, b, sb)  # checked against the closed form above
    mse = mse + bias[:, :, None] * bias[:, None, :]
    ref = np.trace(np.linalg.solve(lin, mse), axis1=-2, axis2=-1)
    np.testing.assert_allclose(cv.nees_at_truth(r, b, sr, sb), ref, rtol=1e-8)


def test_monte_carlo_mean_nees_linearized_follows_truth_prediction():
    sb, sr = np.deg2rad(1.0), 1.0
    rho = np.array([0.05, 0.5, 2.0])
    out = cv.conversion_monte_carlo(rho / sb**2, 0.3, sr, sb, methods=("linearized",),
                                    trials=50_000, rng=5)["linearized"].mean_nees()
    pred = cv.nees_at_truth(rho / sb**2, 0.3, sr, sb)
    # the covariance is evaluated at the measurement in the Monte Carlo, at the truth in
    # the prediction: they agree to about 1 % for ρ ≤ 2 (measured in the chapter)
    assert np.all(np.abs(out.estimate - pred) < 5 * out.std_error + 0.02 * pred)


def test_debiased_conversions_consistent_on_average():
    """Approximate claim: mean NEES within 0.05 of 2 (plus 5 SE) for σβ = 1°, ρ ≤ 10."""
    sb, sr = np.deg2rad(1.0), 1.0
    rho = np.array([0.1, 1.0, 10.0])
    out = cv.conversion_monte_carlo(rho / sb**2, 1.1, sr, sb,
                                    methods=("additive", "multiplicative"), trials=40_000, rng=8)
    for m, o in out.items():
        mn = o.mean_nees()
        assert np.all(np.abs(mn.estimate - 2) < 0.05 + 5 * mn.std_error), (m, mn)


# --------------------------------------------------------------------------- simulation and helpers
def test_draw_polar_shapes_moments_and_seed():
    r_hat, b_hat = cv.draw_polar([100.0, 200.0], [0.1, 0.2], 0.5, 0.01, trials=50_000, rng=1)
    assert r_hat.shape == b_hat.shape == (50_000, 2)          # the trial axis first
    assert np.all(np.abs(r_hat.mean(0) - [100, 200]) < 5 * 0.5 / np.sqrt(50_000))
    assert np.all(np.abs(b_hat.std(0) - 0.01) < 5 * 0.01 / np.sqrt(2 * 50_000))
    again = cv.draw_polar([100.0, 200.0], [0.1, 0.2], 0.5, 0.01, trials=50_000, rng=1)
    np.testing.assert_array_equal(r_hat, again[0])


def test_draw_polar_bad_input():
    with pytest.raises(ValueError, match="`r`"):
        cv.draw_polar(1.0, 0.0, 0.5, 0.01, trials=10, rng=1)
    with pytest.raises(ValueError, match="`trials`"):
        cv.draw_polar(100.0, 0.0, 0.5, 0.01, trials=0, rng=1)
    with pytest.raises(TypeError, match="`rng`"):
        cv.draw_polar(100.0, 0.0, 0.5, 0.01, trials=5, rng=np.random.RandomState(1))


def test_nonlinearity_index_and_bad_input():
    assert cv.nonlinearity_index(150.0, 0.1, np.deg2rad(1.0)) == pytest.approx(
        150 * np.deg2rad(1.0) ** 2 / 0.1)
    with pytest.raises(ValueError, match="`sigma_r`"):
        cv.nonlinearity_index(150.0, 0.0, 0.01)
    with pytest.raises(ValueError, match="`sigma_beta`"):
        cv.nonlinearity_index(150.0, 0.1, 1.0)


def test_other_entry_points_validate():
    with pytest.raises(TypeError, match="`r`"):
        cv.polar_to_cartesian("far", 0.0, 0.1, 0.01)
    with pytest.raises(ValueError, match="`methods`"):
        cv.conversion_monte_carlo(100.0, 0.0, 0.1, 0.01, methods=("exact",), trials=5)
    with pytest.raises(ValueError, match="`sigma_beta`"):
        cv.conversion_bias(100.0, 0.0, -0.1)
    with pytest.raises(ValueError, match="`r`"):
        cv.conversion_moments(-5.0, 0.0, 0.1, 0.01)
    with pytest.raises(ValueError, match="`sigma_r`"):
        cv.conversion_moments(np.ones(2), 0.0, np.ones(3), 0.01)


def test_broadcasting_batch_shapes():
    out = cv.polar_to_cartesian(np.full((3, 1), 100.0), np.linspace(0, 1, 4), 0.1,
                                np.full((1, 4), 0.02), method="additive")
    assert out.xy.shape == (3, 4, 2)
    assert out.cov.shape == (3, 4, 2, 2)


def test_result_is_frozen():
    out = cv.polar_to_cartesian(100.0, 0.0, 0.1, 0.01)
    with pytest.raises(AttributeError):
        out.xy = None


@settings(max_examples=40, deadline=None)
@given(polar, st.sampled_from(ALL))
def test_moments_bias_independent_of_sigma_r_and_mse_psd(p, method):
    r, b, sr, sb = p
    m1 = cv.conversion_moments(r, b, sr, sb, method=method)
    m2 = cv.conversion_moments(r, b, 2 * sr, sb, method=method)
    np.testing.assert_allclose(m1.bias, m2.bias, rtol=1e-12, atol=1e-14 * r)
    assert np.linalg.eigvalsh(m1.mse)[0] >= -1e-12 * (r**2 + sr**2)
    np.testing.assert_allclose(m1.bias, cv.conversion_bias(r, b, sb, method=method),
                               rtol=1e-12, atol=1e-14 * r)


# =========================================================================== trust (issue 12)


PUBLIC = ("polar_to_cartesian", "conversion_moments", "conversion_bias", "nonlinearity_index",
          "conversion_gain", "principal_variances", "decorrelated_variances",
          "spherical_covariance",
          "draw_polar", "nees_per_trial", "nees_at_truth", "conversion_monte_carlo",
          "spherical_to_cartesian", "spherical_moments", "draw_spherical",
          "spherical_monte_carlo")


def test_public_functions_are_the_covered_ones():
    funcs = {n for n in cv.__all__ if callable(getattr(cv, n)) and not isinstance(
        getattr(cv, n), type)}
    assert funcs == set(PUBLIC)


def test_gain_and_principal_variances_closed_forms():
    """E cos w = exp(-s/2) (w ~ N(0, s)): the multiplicative gain undoes it exactly, the
    measurement-conditioned one applies it once more; the linearized covariance is the
    Jacobian's, diag(sigma_r^2, r^2 sigma_beta^2) in the line-of-sight frame."""
    sb = np.array([1e-4, 0.01, 0.3, SIGMA_BETA_MAX])
    q = np.exp(-sb**2 / 2)
    np.testing.assert_allclose(cv.conversion_gain(sb, method="multiplicative") * q, 1.0,
                               rtol=1e-15)
    np.testing.assert_allclose(cv.conversion_gain(sb, method="measurement_conditioned"), q,
                               rtol=1e-15)
    np.testing.assert_array_equal(cv.conversion_gain(sb), 1.0)
    along, cross = cv.principal_variances(150.0, 0.1, sb)
    np.testing.assert_allclose(along, 0.01, rtol=1e-15)
    np.testing.assert_allclose(cross, (150.0 * sb) ** 2, rtol=1e-15)
    with pytest.raises(ValueError, match="`method`"):
        cv.principal_variances(150.0, 0.1, 0.01, method="decorrelated")
    with pytest.raises(ValueError, match="`r`"):
        cv.principal_variances(1e200, 0.1, 0.01)
    # a prior exactly at the truth (zero spread): R^D is the multiplicative conversion's
    # covariance given the truth, conversion_moments' cov (an independent formula)
    r, sr = 150.0, 0.1
    mom = cv.conversion_moments(r, 0.0, sr, sb, method="multiplicative").cov
    along, cross = cv.decorrelated_variances(r**2, sr, sb, 0.0)
    np.testing.assert_allclose(along, mom[..., 0, 0], rtol=1e-9)
    np.testing.assert_allclose(cross, mom[..., 1, 1], rtol=1e-9)
    # 3-D linearized at beta = eps = 0: diag(sigma_r^2, (r sigma_beta)^2, (r sigma_eps)^2)
    np.testing.assert_allclose(cv.spherical_covariance(r, 0.0, 0.0, sr, 0.01, 0.02),
                               np.diag([sr**2, (r * 0.01) ** 2, (r * 0.02) ** 2]), atol=1e-15)


# --------------------------------------------------------------------------- σβ limit
def test_sigma_beta_max_is_one_documented_value():
    """0.5 rad: the fold-over probability P(|w| > 90°) is below 2e-3 there (4.6 % at π/4)."""
    from scipy import stats
    assert SIGMA_BETA_MAX == 0.5
    assert 2 * stats.norm.sf(np.pi / 2 / SIGMA_BETA_MAX) < 2e-3
    assert 2 * stats.norm.sf(2.0) > 0.04                      # at π/4
    cv.polar_to_cartesian(100.0, 0.0, 0.1, SIGMA_BETA_MAX)  # the limit itself is accepted
    for f in (lambda sb: cv.polar_to_cartesian(100.0, 0.0, 0.1, sb),
              lambda sb: cv.conversion_bias(100.0, 0.0, sb),
              lambda sb: cv.nonlinearity_index(100.0, 0.1, sb),
              lambda sb: cv.nees_at_truth(100.0, 0.0, 0.1, sb),
              lambda sb: cv.draw_polar(100.0, 0.0, 0.1, sb, trials=2, rng=1),
              lambda sb: cv.conversion_monte_carlo(100.0, 0.0, 0.1, sb, trials=2, rng=1)):
        with pytest.raises(ValueError, match=r"`sigma_beta`.*SIGMA_BETA_MAX"):
            f(np.nextafter(SIGMA_BETA_MAX, 1.0))


# --------------------------------------------------------------------------- extreme values vs mpmath
mpmath.mp.dps = 60


def _mp_principal(method, r, sr, sb, *, truth=False):
    """(along, cross) by the unsimplified formulas, in 60-digit arithmetic."""
    r, sr, s = mpmath.mpf(r), mpmath.mpf(sr), mpmath.mpf(sb) ** 2
    e = mpmath.exp
    gain = {"linearized": 1, "additive": 1 + e(-s / 2) - e(-s), "multiplicative": e(s / 2),
            "first_order": 1 + s / 2, "first_order_printed": 1 - s / 2,
            "measurement_conditioned": e(-s / 2)}[method]
    if truth:
        e2 = r**2 + sr**2
        a = gain**2 * (e2 / 2 - e(-s) * r**2 / 2)
        b = gain**2 * (e2 * e(-2 * s) / 2 - e(-s) * r**2 / 2)
    elif method == "linearized":
        return sr**2, r**2 * s
    elif method == "measurement_conditioned":
        a = (r**2 + sr**2) / 2 - e(-s) * r**2 / 2
        b = (r**2 + sr**2) * e(-2 * s) / 2 - e(-s) * r**2 / 2
    elif method == "multiplicative":
        k = (e(s) - 2) * r**2
        a, b = k / 2 + (r**2 + sr**2) / 2, k / 2 + (r**2 + sr**2) * e(-2 * s) / 2
    else:
        a = (r**2 + 2 * sr**2) / 2 - (r**2 + sr**2) * e(-s) / 2
        b = (r**2 + 2 * sr**2) * e(-4 * s) / 2 - (r**2 + sr**2) * e(-3 * s) / 2
    return a + b, a - b


def _mp_bias_factor(method, sb):
    s = mpmath.mpf(sb) ** 2
    e = mpmath.exp
    gain = {"linearized": 1, "additive": 1 + e(-s / 2) - e(-s), "multiplicative": e(s / 2),
            "first_order": 1 + s / 2, "first_order_printed": 1 - s / 2,
            "measurement_conditioned": e(-s / 2)}[method]
    return gain * e(-s / 2) - 1


log_r = st.floats(-100, 170, **finite)
log_ratio = st.floats(-12, 3, **finite)        # σr / r
log_sb = st.floats(-12, math.log10(SIGMA_BETA_MAX), **finite)


@given(log_r, log_ratio, log_sb, st.sampled_from(ALL))
def test_covariances_over_the_float_range_match_mpmath(lr, lq, ls, method):
    """Principal variances at β = 0 to 1e-10 relative, or a ValueError where they overflow."""
    r, sb = 10.0**lr, 10.0**ls
    sr = r * 10.0**lq
    along, cross = _mp_principal(method, r, sr, sb)
    big = float(max(along, cross)) if max(along, cross) < mpmath.mpf("1e308") else math.inf
    small = float(min(along, cross))
    if not (big < 1.7e308 and small > 1e-300):
        with pytest.raises(ValueError, match=r"`r`|flow"):
            cv.polar_to_cartesian(r, 0.0, sr, sb, method=method)
        return
    with warnings_ignored():
        out = cv.polar_to_cartesian(r, 0.0, sr, sb, method=method)
    np.testing.assert_allclose(out.cov[0, 0], float(along), rtol=1e-10)
    np.testing.assert_allclose(out.cov[1, 1], float(cross), rtol=1e-10)
    assert out.cov[0, 1] == 0.0


@given(log_r, log_ratio, log_sb, st.sampled_from(ALL))
def test_truth_moments_over_the_float_range_match_mpmath(lr, lq, ls, method):
    r, sb = 10.0**lr, 10.0**ls
    sr = r * 10.0**lq
    along, cross = _mp_principal(method, r, sr, sb, truth=True)
    bf = _mp_bias_factor(method, sb)
    if not (max(along, cross) < mpmath.mpf("1.7e308") and min(along, cross) > 1e-300
            and along + (bf * r) ** 2 < mpmath.mpf("1.7e308")):
        with pytest.raises(ValueError, match="flow"):
            cv.conversion_moments(r, 0.0, sr, sb, method=method)
        return
    m = cv.conversion_moments(r, 0.0, sr, sb, method=method)
    np.testing.assert_allclose(m.cov[0, 0], float(along), rtol=1e-10)
    np.testing.assert_allclose(m.cov[1, 1], float(cross), rtol=1e-10)
    np.testing.assert_allclose(m.mse[0, 0], float(along + (bf * r) ** 2), rtol=1e-10)
    np.testing.assert_allclose(m.bias[0], float(bf * r), rtol=1e-10, atol=1e-50 * r)
    np.testing.assert_allclose(cv.conversion_bias(r, 0.0, sb, method=method)[0], float(bf * r),
                               rtol=1e-10, atol=1e-50 * r)


def test_tiny_azimuth_error_keeps_the_small_numbers():
    """Reproduced defects: 1 − e^{−s} lost the cross-range variance and the bias at tiny σβ."""
    out = cv.polar_to_cartesian(1.0, 0.0, 1.0, 1e-8, method="additive")
    _, cross = _mp_principal("additive", 1.0, 1.0, 1e-8)
    np.testing.assert_allclose(out.cov[1, 1], float(cross), rtol=1e-12)   # was 11 % off
    np.testing.assert_allclose(cv.conversion_bias(1.0, 0.0, 1e-8)[0], -5e-17, rtol=1e-12)


def test_coordinates_near_1e154_no_longer_overflow_in_silence():
    """Reproduced defect: r = 1e155 gave inf/NaN covariances; now exact, or refused."""
    for m in ALL:
        with warnings_ignored():
            assert np.all(np.isfinite(cv.polar_to_cartesian(1e155, 0.3, 1.0, 0.01, method=m).cov))
            out = cv.polar_to_cartesian(1e155, 0.0, 1.0, 0.01, method=m)
        along, cross = _mp_principal(m, 1e155, 1.0, 0.01)
        np.testing.assert_allclose(np.diag(out.cov), [float(along), float(cross)], rtol=1e-10)
    assert np.all(np.isfinite(cv.conversion_moments(1e155, 0.3, 1.0, 0.01).mse))
    with pytest.raises(ValueError, match="overflows"):
        cv.polar_to_cartesian(1e160, 0.3, 1.0, 0.01)
    with pytest.raises(ValueError, match="float range"):
        cv.nonlinearity_index(1e300, 1e-300, 0.1)
    with pytest.raises(ValueError, match=r"`error`.*numeric domain"):
        cv.nees_per_trial([1e200, 0.0], np.eye(2))
    with pytest.raises(ValueError, match=r"`cov`.*numeric domain"):
        cv.nees_per_trial([1.0, 0.0], np.eye(2) * 1e-200)
    with pytest.raises(ValueError, match="`r`"):
        cv.draw_polar(1.7e308, 0.0, 1e307, 0.01, trials=50, rng=0)


@given(st.floats(-40, 40, **finite), st.floats(-40, 40, **finite))
def test_nees_is_invariant_to_the_unit(le, lc):
    """NEES is scale free: error × k, cov × k² gives the same value, over the engine's
    numeric domain (variances within 2**-150 .. 2**150)."""
    err = np.array([0.3, -1.2])
    cov = np.array([[2.0, 0.4], [0.4, 0.5]])
    ref = cv.nees_per_trial(err, cov)
    k = 10.0 ** ((le + lc) / 4)
    np.testing.assert_allclose(cv.nees_per_trial(err * k, cov * k**2), ref, rtol=1e-12)
    np.testing.assert_allclose(cv.nees_per_trial(np.r_[err, 1.0] * k, np.diag([2.0, 0.5, 1.0]) * k**2),
                               cv.nees_per_trial(np.r_[err, 1.0], np.diag([2.0, 0.5, 1.0])), rtol=1e-12)


def test_nonlinearity_index_over_the_float_range():
    np.testing.assert_allclose(cv.nonlinearity_index(1e300, 1e-5, 1e-160), 1e-15, rtol=1e-14)
    np.testing.assert_allclose(cv.nonlinearity_index(1e-300, 1e-300, 0.5), 0.25, rtol=1e-14)
    assert cv.nonlinearity_index(0.0, 1.0, 0.1) == 0.0


# --------------------------------------------------------------------------- zero sigmas
def test_zero_sigmas_refused_where_a_positive_definite_covariance_is_needed():
    """Reproduced defects: a raw LinAlgError (nees_at_truth) and a message naming the internal
    `cov` (conversion_monte_carlo); now the public argument is named."""
    for kwargs, name in (({"sigma_r": 0.0}, "`sigma_r`"), ({"sigma_beta": 0.0}, "`sigma_beta`"),
                         ({"sigma_r": -1.0}, "`sigma_r`")):
        args = {"r": 100.0, "beta": 0.0, "sigma_r": 0.1, "sigma_beta": 0.01} | kwargs
        with pytest.raises(ValueError, match=name):
            cv.nees_at_truth(**args)
        with pytest.raises(ValueError, match=name):
            cv.conversion_monte_carlo(**args, trials=3, rng=1)
    with pytest.raises(ValueError, match="`r`"):
        cv.nees_at_truth(0.0, 0.0, 0.1, 0.01)
    assert np.isfinite(cv.nees_at_truth(0.0, 0.0, 0.1, 0.01, method="additive"))


def test_zero_sigmas_are_legal_where_the_answer_exists():
    """A perfect range or azimuth is a degenerate but legal report: converted, with a warning."""
    with pytest.warns(RadarFusionWarning, match="singular"):
        out = cv.polar_to_cartesian(100.0, 0.3, 0.0, 0.01)
    assert np.all(np.isfinite(out.cov))
    np.testing.assert_array_equal(cv.conversion_bias(100.0, 0.3, 0.0), [0.0, 0.0])
    r_hat, _ = cv.draw_polar(100.0, 0.3, 0.0, 0.0, trials=4, rng=1)
    np.testing.assert_array_equal(r_hat, 100.0)


# --------------------------------------------------------------------------- sizes, reproducibility
def test_sizes_are_refused_before_allocation():
    with pytest.raises(ValueError, match="refused"):
        cv.draw_polar(100.0, 0.0, 1.0, 0.01, trials=10**12, rng=1)
    with pytest.raises(ValueError, match="refused"):
        cv.polar_to_cartesian(np.ones((100_000, 1)), np.ones((1, 100_000)), 0.1, 0.01)
    with pytest.raises(ValueError, match="refused"):
        cv.conversion_monte_carlo(100.0, 0.0, 1.0, 0.01, methods=cv.METHODS,
                                  trials=cv.MAX_BATCH + 1, rng=1)
    with pytest.raises(ValueError, match="`chunk_size`"):
        cv.conversion_monte_carlo(100.0, 0.0, 1.0, 0.01, trials=10, rng=1,
                                  chunk_size=cv.MAX_BATCH + 1)
    with pytest.raises(ValueError, match="`chunk_size`"):
        cv.conversion_monte_carlo(100.0, 0.0, 1.0, 0.01, trials=10, rng=1, chunk_size=0)
    with pytest.raises(TypeError, match="`chunk_size`"):
        cv.conversion_monte_carlo(100.0, 0.0, 1.0, 0.01, trials=10, rng=1, chunk_size=2.5)
    with pytest.raises(ValueError, match="refused"):
        cv.nees_per_trial(np.ones((100_000, 1, 2)), np.broadcast_to(np.eye(2), (1, 100_000, 2, 2)))


@given(st.integers(1, 700), st.integers(1, 3), st.integers(0, 2**32 - 1))
def test_monte_carlo_does_not_depend_on_chunk_size(chunk, batch, seed):
    r = np.linspace(100.0, 200.0, batch)
    a = cv.conversion_monte_carlo(r, 0.4, 0.5, 0.05, methods=cv.METHODS, trials=357, rng=seed)
    b = cv.conversion_monte_carlo(r, 0.4, 0.5, 0.05, methods=cv.METHODS, trials=357, rng=seed,
                                  chunk_size=chunk)
    for m in cv.METHODS:
        np.testing.assert_array_equal(a[m].error, b[m].error)
        np.testing.assert_array_equal(a[m].nees, b[m].nees)


def test_monte_carlo_nees_equals_the_generic_nees():
    out = cv.conversion_monte_carlo([120.0, 80.0], [0.4, -2.0], 0.5, 0.2, methods=cv.METHODS,
                                    trials=500, rng=4)
    r_hat, b_hat = cv.draw_polar([120.0, 80.0], [0.4, -2.0], 0.5, 0.2, trials=500, rng=4)
    for m in cv.METHODS:
        conv = cv.polar_to_cartesian(r_hat.T, b_hat.T, 0.5, 0.2, method=m)   # trials last
        np.testing.assert_allclose(out[m].nees, cv.nees_per_trial(out[m].error, conv.cov), rtol=1e-9)


# --------------------------------------------------------------------------- properties of every public function
pol = st.tuples(st.floats(1.0, 1e4, **finite), st.floats(-10, 10, **finite),
                st.floats(1e-3, 10, **finite), st.floats(1e-4, SIGMA_BETA_MAX, **finite))


@given(pol, st.sampled_from(ALL))
def test_properties_of_the_deterministic_functions(p, method):
    r, b, sr, sb = p
    with warnings_ignored():
        out = cv.polar_to_cartesian(r, b, sr, sb, method=method)
    assert out.xy.shape == (2,) and np.all(np.isfinite(out.xy)) and np.all(np.isfinite(out.cov))
    np.testing.assert_allclose(np.hypot(*out.xy), cv.conversion_gain(sb, method=method) * r, rtol=1e-12)
    assert np.linalg.eigvalsh(out.cov)[0] >= -1e-12 * np.abs(out.cov).max()
    m = cv.conversion_moments(r, b, sr, sb, method=method)
    np.testing.assert_allclose(m.mean - m.bias, r * np.array([np.cos(b), np.sin(b)]),
                               rtol=1e-12, atol=1e-12 * r)
    # the bias points at the radar (or vanishes), and MSE ⪰ Cov
    assert m.bias @ [np.cos(b), np.sin(b)] <= 1e-12 * r or method == "first_order_printed"
    assert np.linalg.eigvalsh(m.mse - m.cov)[0] >= -1e-9 * np.abs(m.mse).max()
    eta = cv.nonlinearity_index(r, sr, sb)
    np.testing.assert_allclose(eta, r * sb**2 / sr, rtol=1e-13)
    nt = cv.nees_at_truth(r, b, sr, sb, method=method)
    assert np.isfinite(nt) and nt > 0


@settings(max_examples=15)
@given(pol, st.integers(0, 2**32 - 1), st.integers(1, 40))
def test_properties_of_the_random_functions(p, seed, trials):
    r, b, sr, sb = p
    r = max(r, cv.MIN_RANGE_OVER_SIGMA * sr)
    rh, bh = cv.draw_polar(r, b, sr, sb, trials=trials, rng=seed)
    assert rh.shape == bh.shape == (trials,) and np.all(rh > 0)
    again = cv.draw_polar(r, b, sr, sb, trials=trials, rng=np.random.default_rng(seed))
    np.testing.assert_array_equal(rh, again[0])
    out = cv.conversion_monte_carlo(r, b, sr, sb, methods=("linearized", "multiplicative"),
                                    trials=trials, rng=seed)
    for o in out.values():
        assert o.error.shape == (trials, 2) and o.nees.shape == (trials,)
        assert np.all(np.isfinite(o.nees)) and np.all(o.nees >= 0)
        assert o.trials == trials
    # common random numbers: the linearized error is the plain conversion of those draws
    np.testing.assert_allclose(out["linearized"].error + r * np.array([np.cos(b), np.sin(b)]),
                               np.stack([rh * np.cos(bh), rh * np.sin(bh)], -1),
                               rtol=1e-12, atol=1e-12 * r)


# --------------------------------------------------------------------------- generated bad input
BASE = {"r": 100.0, "beta": 0.3, "sigma_r": 0.5, "sigma_beta": 0.01}
CALLS = {
    "polar_to_cartesian": (lambda **k: cv.polar_to_cartesian(**k), BASE),
    "conversion_moments": (lambda **k: cv.conversion_moments(**k), BASE),
    "conversion_bias": (lambda **k: cv.conversion_bias(**k),
                        {"r": 100.0, "beta": 0.3, "sigma_beta": 0.01}),
    "nonlinearity_index": (lambda **k: cv.nonlinearity_index(**k),
                           {"r": 100.0, "sigma_r": 0.5, "sigma_beta": 0.01}),
    "nees_at_truth": (lambda **k: cv.nees_at_truth(**k), BASE),
    "draw_polar": (lambda **k: cv.draw_polar(**k, trials=3, rng=1), BASE),
    "conversion_monte_carlo": (lambda **k: cv.conversion_monte_carlo(**k, trials=3, rng=1), BASE),
    "nees_per_trial": (lambda **k: cv.nees_per_trial(**k), {"error": [1.0, 2.0], "cov": np.eye(2)}),
    "conversion_gain": (lambda **k: cv.conversion_gain(**k), {"sigma_beta": 0.01}),
    "principal_variances": (lambda **k: cv.principal_variances(**k),
                            {"r": 100.0, "sigma_r": 0.5, "sigma_beta": 0.01}),
    "decorrelated_variances": (lambda **k: cv.decorrelated_variances(**k),
                               {"mean_sq_range": 1e4, "sigma_r": 0.5, "sigma_beta": 0.01,
                                "prior_azimuth_var": 1e-6}),
    "spherical_covariance": (lambda **k: cv.spherical_covariance(**k),
                             {"r": 100.0, "beta": 0.3, "epsilon": 0.1, "sigma_r": 0.5,
                              "sigma_beta": 0.01, "sigma_epsilon": 0.02}),
}
BAD_VALUES = st.sampled_from([np.nan, np.inf, -np.inf, "1.5", True, None, [1.0, np.nan],
                              object(), 1 + 2j, [[1.0, 2.0], [3.0]]])


@given(st.sampled_from(sorted(CALLS)), st.data(), BAD_VALUES)
def test_bad_values_name_the_argument(func, data, bad):
    call, base = CALLS[func]
    arg = data.draw(st.sampled_from(sorted(base)))
    with pytest.raises((ValueError, TypeError), match=f"`{arg}`"):
        call(**(base | {arg: bad}))


NEGATIVE = {"r": -1.0, "sigma_r": -0.1, "sigma_beta": -1e-3}


@given(st.sampled_from(sorted(CALLS)), st.data(), st.floats(1e-300, 1e300, **finite))
def test_negative_values_name_the_argument(func, data, mag):
    call, base = CALLS[func]
    names = sorted(set(base) & set(NEGATIVE))
    if not names:
        return
    arg = data.draw(st.sampled_from(names))
    with pytest.raises(ValueError, match=f"`{arg}`"):
        call(**(base | {arg: -mag}))


@given(st.sampled_from(["polar_to_cartesian", "conversion_moments", "nees_at_truth",
                        "draw_polar", "conversion_monte_carlo"]),
       st.integers(2, 4), st.integers(5, 7))
def test_shape_mismatch_names_the_arguments(func, n1, n2):
    call, base = CALLS[func]
    with pytest.raises(ValueError, match=r"`r`.*`beta`"):
        call(**(base | {"r": np.full(n1, 100.0), "beta": np.zeros(n2)}))


@given(st.sampled_from([0, -3, 2.5, "10", True, None, 10**12]))
def test_bad_trials(trials):
    with pytest.raises((ValueError, TypeError), match="`trials`"):
        cv.conversion_monte_carlo(100.0, 0.0, 0.5, 0.01, trials=trials, rng=1)
    with pytest.raises((ValueError, TypeError), match=r"`trials`|refused"):
        cv.draw_polar(100.0, 0.0, 0.5, 0.01, trials=trials, rng=1)


@given(st.sampled_from([(), [], ("exact",), ("linearized", 3), b"linearized", 5, None]))
def test_bad_methods(methods):
    with pytest.raises((ValueError, TypeError), match="`methods`"):
        cv.conversion_monte_carlo(100.0, 0.0, 0.5, 0.01, methods=methods, trials=3, rng=1)


@given(st.sampled_from(["exact", "", None, 3, "Linearized"]), st.sampled_from(
    ["polar_to_cartesian", "conversion_moments", "conversion_bias", "nees_at_truth"]))
def test_bad_method_generated(method, func):
    call, base = CALLS[func]
    with pytest.raises(ValueError, match="`method`"):
        call(**base, method=method)


@pytest.mark.parametrize(("err", "cov", "name"), [
    ([1.0, 1.0], -np.eye(2), "`cov`"),
    ([1.0, 1.0], [[1.0, 1.0], [1.0, 1.0]], "`cov`"),
    (np.empty(0), np.empty((0, 0)), "`error`"),
    ([1.0, np.inf], np.eye(2), "`error`"),
    ([1.0, 1.0], [[1.0, np.nan], [np.nan, 1.0]], "`cov`"),
    ([True, False], np.eye(2), "`error`"),
])
def test_nees_bad_input_more(err, cov, name):
    with pytest.raises((ValueError, TypeError), match=name):
        cv.nees_per_trial(err, cov)


def warnings_ignored():
    import warnings
    ctx = warnings.catch_warnings()
    ctx.__enter__()
    warnings.simplefilter("ignore", RadarFusionWarning)

    class _Ctx:
        def __enter__(self):
            return self

        def __exit__(self, *exc):
            ctx.__exit__(*exc)
            return False
    return _Ctx()


# =========================================================================== 3-D (range, azimuth, elevation)
def _sph(r, b, e):
    r, b, e = np.broadcast_arrays(r, b, e)
    return np.stack([r * np.cos(e) * np.cos(b), r * np.cos(e) * np.sin(b), r * np.sin(e)], -1)


def _grid3(center, sigmas, n):
    """Gauss–Hermite nodes of three independent Gaussians and their product weights."""
    x, wt = np.polynomial.hermite_e.hermegauss(n)
    wt = wt / np.sqrt(2 * np.pi)
    axes = [c + s * x for c, s in zip(center, sigmas, strict=True)]
    grids = np.meshgrid(*axes, indexing="ij")
    return grids, wt[:, None, None] * wt[None, :, None] * wt[None, None, :]


CASES3 = [(100.0, 0.3, 0.4, 1.0, 0.3, 0.25), (40.0, -2.0, -0.9, 0.5, 0.05, 0.4),
          (300.0, 1.2, 1.3, 2.0, 0.5, 0.1)]


@pytest.mark.parametrize("case", CASES3)
def test_3d_measurement_conditioned_and_multiplicative_by_quadrature(case):
    """Truth ~ N(measurement, σ²) in (r, β, ε): Duan et al.'s position and covariance are its
    conditional mean and covariance; Mo et al.'s covariance is its MSE about x_u."""
    rh, bh, eh, sr, sb, se = case
    (rr, bb, ee), wt = _grid3((rh, bh, eh), (sr, sb, se), 40)
    pts = _sph(rr, bb, ee)
    mu = np.einsum("ijk,ijkl->l", wt, pts)
    cov = np.einsum("ijk,ijkl,ijkm->lm", wt, pts - mu, pts - mu)
    mc = cv.spherical_to_cartesian(rh, bh, eh, sr, sb, se, method="measurement_conditioned")
    np.testing.assert_allclose(mc.xyz, mu, rtol=1e-10, atol=1e-10 * rh)
    np.testing.assert_allclose(mc.cov, cov, rtol=1e-8, atol=1e-10 * rh**2)
    mu_u = cv.spherical_to_cartesian(rh, bh, eh, sr, sb, se, method="multiplicative")
    mse = np.einsum("ijk,ijkl,ijkm->lm", wt, mu_u.xyz - pts, mu_u.xyz - pts)
    np.testing.assert_allclose(mu_u.cov, mse, rtol=1e-8, atol=1e-10 * rh**2)


@pytest.mark.parametrize("case", CASES3)
def test_3d_moments_given_truth_by_quadrature(case):
    """Mean and covariance given the truth, the plain conversion's by quadrature over the
    errors, scaled by each method's gain G (the multiplicative gain makes it unbiased)."""
    r, b, e, sr, sb, se = case
    (rr, bb, ee), wt = _grid3((r, b, e), (sr, sb, se), 40)
    pts = _sph(rr, bb, ee)
    mu = np.einsum("ijk,ijkl->l", wt, pts)
    cov = np.einsum("ijk,ijkl,ijkm->lm", wt, pts - mu, pts - mu)
    lam = mu / _sph(r, b, e)                       # the damping, measured by quadrature
    gains = {"linearized": np.ones(3), "additive": 1 + lam - lam**2,
             "multiplicative": 1 / lam, "measurement_conditioned": lam}
    for m, g in gains.items():
        mom = cv.spherical_moments(r, b, e, sr, sb, se, method=m)
        np.testing.assert_allclose(mom.mean, g * mu, rtol=1e-9)
        np.testing.assert_allclose(mom.cov, np.outer(g, g) * cov, rtol=1e-8, atol=1e-10 * r**2)
        bias = g * mu - _sph(r, b, e)
        np.testing.assert_allclose(mom.bias, bias, atol=1e-9 * r)
        np.testing.assert_allclose(mom.mse, mom.cov + np.outer(bias, bias), rtol=1e-8,
                                   atol=1e-9 * r**2)
    assert np.abs(cv.spherical_moments(*case, method="multiplicative").bias).max() == 0.0


def test_3d_additive_is_the_truth_covariance_averaged_over_the_truth():
    """Σᵃ = E[Cov(r̂a | truth) | measurement], both expectations by (nested) quadrature."""
    rh, bh, eh, sr, sb, se = 100.0, 0.3, 0.4, 1.0, 0.3, 0.25
    n = 10
    (rr, bb, ee), wt = _grid3((rh, bh, eh), (sr, sb, se), n)       # the truth | measurement
    x, w1 = np.polynomial.hermite_e.hermegauss(n)
    w1 = w1 / np.sqrt(2 * np.pi)
    wi = w1[:, None, None] * w1[None, :, None] * w1[None, None, :]
    inner = _sph(rr[..., None, None, None] + sr * x[:, None, None],
                 bb[..., None, None, None] + sb * x[None, :, None],
                 ee[..., None, None, None] + se * x[None, None, :])
    m_in = np.einsum("pqr,ijkpqrl->ijkl", wi, inner)
    d = inner - m_in[..., None, None, None, :]
    c_in = np.einsum("pqr,ijkpqrl,ijkpqrm->ijklm", wi, d, d)
    avg = np.einsum("ijk,ijklm->lm", wt, c_in)
    got = cv.spherical_to_cartesian(rh, bh, eh, sr, sb, se, method="additive")
    np.testing.assert_allclose(got.cov, avg, rtol=1e-7, atol=1e-9 * rh**2)
    # its position subtracts the averaged bias E[(Λ − I) x | measurement]
    mu = np.einsum("ijk,ijkl->l", wt, _sph(rr, bb, ee))
    lam = mu / _sph(rh, bh, eh)
    np.testing.assert_allclose(got.xyz, _sph(rh, bh, eh) - (lam - 1) * mu, rtol=1e-9)


def test_3d_linearized_is_the_jacobian_covariance():
    """J diag(σ²) Jᵀ with J by central differences."""
    r, b, e, sr, sb, se = 150.0, 0.7, -0.3, 0.2, 0.01, 0.02
    h = 1e-6
    jac = np.stack([(_sph(*(np.array([r, b, e]) + h * np.eye(3)[k]))
                     - _sph(*(np.array([r, b, e]) - h * np.eye(3)[k]))) / (2 * h)
                    for k in range(3)], axis=1)
    ref = jac @ np.diag([sr**2, sb**2, se**2]) @ jac.T
    got = cv.spherical_to_cartesian(r, b, e, sr, sb, se)
    np.testing.assert_allclose(got.cov, ref, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(got.xyz, _sph(r, b, e), rtol=1e-14)


@pytest.mark.parametrize("method", cv.METHODS_3D)
def test_3d_reduces_to_2d_in_the_horizontal_plane(method):
    r, b, sr, sb = _rand_inputs(30)
    three = cv.spherical_to_cartesian(r, b, 0.0, sr, sb, 0.0, method=method)
    with warnings_ignored():
        two = cv.polar_to_cartesian(r, b, sr, sb, method=method)
    np.testing.assert_allclose(three.xyz[:, :2], two.xy, rtol=1e-12, atol=1e-12 * r.max())
    np.testing.assert_allclose(three.cov[:, :2, :2], two.cov, rtol=1e-9,
                               atol=1e-11 * r.max() ** 2)


@pytest.mark.parametrize("method", cv.METHODS_3D)
def test_3d_monte_carlo_agrees_with_the_moments(method):
    case = (100.0, 0.3, 0.4, 1.0, 0.2, 0.15)
    n = 100_000
    out = cv.spherical_monte_carlo(*case, methods=(method,), trials=n, rng=3)[method]
    mom = cv.spherical_moments(*case, method=method)
    est = out.bias()
    assert np.all(np.abs(est.estimate - mom.bias) < 5 * est.std_error)
    emp = np.cov(out.error.T)
    d = np.sqrt(np.diag(mom.cov))
    se = np.sqrt((np.outer(d, d) ** 2 + mom.cov**2) / n)
    assert np.all(np.abs(emp - mom.cov) < 6 * se)
    # NEES against the exact MSE has mean 3 and a χ²-like scale
    nt = cv.ConversionTrials(method, out.error, out.nees_true)
    assert abs(nt.mean_nees().estimate - 3.0) < 5 * nt.mean_nees().std_error
    # the NEES is e C⁻¹ e with the conversion's own covariance, by solve
    rh, bh, eh = (v[:50] for v in cv.draw_spherical(*case, trials=n, rng=3))
    conv = cv.spherical_to_cartesian(rh, bh, eh, *case[3:], method=method)
    err = conv.xyz - _sph(*case[:3])
    ref = np.einsum("ni,ni->n", err, np.linalg.solve(conv.cov, err[..., None])[..., 0])
    np.testing.assert_allclose(out.nees[:50], ref, rtol=1e-8)


def test_3d_bad_input():
    base = (100.0, 0.3, 0.1, 0.5, 0.01, 0.01)
    with pytest.raises(ValueError, match=r"`sigma_epsilon`.*SIGMA_BETA_MAX"):
        cv.spherical_to_cartesian(*base[:5], 1.0)
    with pytest.raises(ValueError, match="`sigma_beta`"):
        cv.spherical_to_cartesian(*base[:4], 2.0, 0.01)
    with pytest.raises(ValueError, match="`method`"):
        cv.spherical_to_cartesian(*base, method="decorrelated")
    with pytest.raises(ValueError, match="`epsilon`"):
        cv.spherical_to_cartesian(100.0, 0.3, np.nan, 0.5, 0.01, 0.01)
    with pytest.raises(ValueError, match=r"`r`.*`epsilon`"):
        cv.spherical_moments(np.ones(3), 0.3, np.ones(2), 0.5, 0.01, 0.01)
    with pytest.raises(ValueError, match="`methods`"):
        cv.spherical_monte_carlo(*base, methods=(), trials=3, rng=1)
    with pytest.raises(ValueError, match="`sigma_epsilon`"):
        cv.spherical_monte_carlo(*base[:5], 0.0, trials=3, rng=1)
    with pytest.raises(ValueError, match="`r`"):
        cv.draw_spherical(1.0, 0.3, 0.1, 0.5, 0.01, 0.01, trials=3, rng=1)
    with pytest.raises((ValueError, TypeError), match="`trials`"):
        cv.draw_spherical(*base, trials=0, rng=1)
    with pytest.warns(RadarFusionWarning):
        cv.spherical_to_cartesian(100.0, 0.3, np.pi / 2, 0.5, 0.01, 0.01)


@settings(max_examples=15)
@given(st.floats(1.0, 1e4, **finite), st.floats(-10, 10, **finite), st.floats(-1.5, 1.5, **finite),
       st.floats(1e-3, 10, **finite), st.floats(1e-4, SIGMA_BETA_MAX, **finite),
       st.floats(1e-4, SIGMA_BETA_MAX, **finite), st.sampled_from(cv.METHODS_3D))
def test_3d_properties(r, b, e, sr, sb, se, method):
    with warnings_ignored():
        out = cv.spherical_to_cartesian(r, b, e, sr, sb, se, method=method)
    assert out.xyz.shape == (3,) and out.cov.shape == (3, 3)
    np.testing.assert_allclose(out.cov, out.cov.T, rtol=0, atol=1e-12 * np.abs(out.cov).max())
    assert np.linalg.eigvalsh(out.cov)[0] >= -1e-9 * np.abs(out.cov).max()
    m = cv.spherical_moments(r, b, e, sr, sb, se, method=method)
    assert np.linalg.eigvalsh(m.mse - m.cov)[0] >= -1e-9 * np.abs(m.mse).max()
    np.testing.assert_allclose(m.mean - m.bias, _sph(r, b, e), rtol=1e-12, atol=1e-12 * r)
