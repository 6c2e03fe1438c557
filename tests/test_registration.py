"""Tests of radarfusion_ref.registration.

Oracles are independent of the module: direct trigonometry for the biased
reports, the printed linearized covariance (2a–c) typed in here, scipy.stats.ncx2
for the law of the proximity measure, the full Fisher information built from a
finite-difference Jacobian and inverted as one matrix (no Schur complement), a
sympy derivation for one object, and seeded Monte Carlo with tolerances from the
standard error.
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import pytest
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

from radarfusion_ref import gating
from radarfusion_ref import registration as rg
from radarfusion_ref.engine.assignment import assign_two_lists
from radarfusion_ref.engine.errors import RadarFusionWarning

SITES = np.array([[0.0, 0.0], [30.0, 0.0]])
SPREAD = np.array([[0.0, 60.0], [30.0, 70.0], [-20.0, 50.0], [10.0, 80.0], [45.0, 55.0],
                   [-5.0, 40.0], [20.0, 90.0], [60.0, 75.0]])
SR, SB = 0.05, 1e-3
BIAS = np.array([[0.3, 1e-3, 2e-3], [-0.2, -5e-4, -1e-3]])


# --------------------------------------------------------------------------- independent routes
def polar_direct(s, x):
    """Range and azimuth by plain trigonometry, one site and one point."""
    dx, dy = x[0] - s[0], x[1] - s[1]
    return np.hypot(dx, dy), np.arctan2(dy, dx)


def printed_cov(r, beta, sr, sb):
    """Prosov (2a-c), typed in."""
    c11 = r**2 * sb**2 * np.sin(beta)**2 + sr**2 * np.cos(beta)**2
    c22 = r**2 * sb**2 * np.cos(beta)**2 + sr**2 * np.sin(beta)**2
    c12 = (sr**2 - r**2 * sb**2) * np.sin(beta) * np.cos(beta)
    return np.array([[c11, c12], [c12, c22]])


def full_fim_bias_block(sites, targets, sr, sb, h=1e-6):
    """CRLB route without elimination: finite-difference Jacobian of all measurements
    w.r.t. (biases, every object), full information, inverse, then the bias block."""
    m, n = len(sites), len(targets)

    def meas(theta):
        b = theta[:3 * m].reshape(m, 3)
        x = theta[3 * m:].reshape(n, 2)
        out = []
        for i in range(m):
            for k in range(n):
                r, beta = polar_direct(sites[i], x[k])
                out += [((1 + b[i, 1]) * r + b[i, 0]) / sr, (beta + b[i, 2]) / sb]
        return np.array(out)

    theta0 = np.concatenate([np.zeros(3 * m), np.asarray(targets, float).ravel()])
    H = np.empty((2 * m * n, theta0.size))
    for p in range(theta0.size):
        e = np.zeros_like(theta0)
        e[p] = h * max(1.0, abs(theta0[p]))
        H[:, p] = (meas(theta0 + e) - meas(theta0 - e)) / (2 * e[p])
    F = H.T @ H
    return F, np.linalg.inv(F)[:3 * m, :3 * m]


@functools.lru_cache(maxsize=1)
def sympy_one_object():
    """Bias information of one object seen by two radars, (0,0) and (L,0), by sympy."""
    x, y, L = sp.symbols("x y L", real=True)
    sr, sb = sp.symbols("sigma_r sigma_beta", positive=True)
    b = sp.symbols("dr1 e1 db1 dr2 e2 db2", real=True)
    h = []
    for (sx, sy), (dr, e, db) in (((0, 0), b[:3]), ((L, 0), b[3:])):
        r = sp.sqrt((x - sx)**2 + (y - sy)**2)
        h += [((1 + e) * r + dr) / sr, (sp.atan2(y - sy, x - sx) + db) / sb]
    h = sp.Matrix(h)
    zero = dict.fromkeys(b, 0)
    Hb = h.jacobian(b).subs(zero)
    Hx = h.jacobian([x, y]).subs(zero)
    J = Hb.T * Hb - Hb.T * Hx * (Hx.T * Hx).inv() * Hx.T * Hb
    return sp.lambdify((x, y, L, sr, sb), J, "numpy")


# --------------------------------------------------------------------------- the model
def test_apply_and_remove_against_direct_formula():
    rb, bb = rg.apply_biases(100.0, 0.5, [0.2, 1e-3, 0.01])
    assert rb == pytest.approx(100.0 * 1.001 + 0.2, rel=1e-15)
    assert bb == pytest.approx(0.51, rel=1e-15)


@given(r=st.floats(1.0, 1e5), beta=st.floats(-3.0, 3.0), dr=st.floats(-0.5, 0.5),
       eps=st.floats(-0.01, 0.01), db=st.floats(-0.1, 0.1))
def test_remove_inverts_apply(r, beta, dr, eps, db):
    b = [dr, eps, db]
    r2, beta2 = rg.remove_biases(*rg.apply_biases(r, beta, b), b)
    assert float(r2) == pytest.approx(r, rel=1e-12, abs=1e-12)
    assert float(beta2) == pytest.approx(beta, rel=1e-12, abs=1e-12)


def test_true_polar_against_trigonometry():
    p = rg.true_polar(SITES, SPREAD)
    for i, s in enumerate(SITES):
        for k, x in enumerate(SPREAD):
            assert p[i, k] == pytest.approx(polar_direct(s, x), rel=1e-14)


def test_displacement_exact_and_first_order():
    mu = rg.bias_displacement(SITES, SPREAD, BIAS)
    for i, s in enumerate(SITES):
        for k, x in enumerate(SPREAD):
            r, beta = polar_direct(s, x)
            rb = (1 + BIAS[i, 1]) * r + BIAS[i, 0]
            bb = beta + BIAS[i, 2]
            exact = s + rb * np.array([np.cos(bb), np.sin(bb)]) - x
            assert mu[i, k] == pytest.approx(exact, abs=1e-12)
    small = BIAS * 1e-3
    mu = rg.bias_displacement(SITES, SPREAD, small)
    for i, s in enumerate(SITES):
        for k, x in enumerate(SPREAD):
            r, beta = polar_direct(s, x)
            u, up = np.array([np.cos(beta), np.sin(beta)]), np.array([-np.sin(beta), np.cos(beta)])
            first = (small[i, 0] + small[i, 1] * r) * u + r * small[i, 2] * up
            assert mu[i, k] == pytest.approx(first, rel=1e-3, abs=1e-12)


def test_simulated_reports_mean_is_biased_truth():
    z = rg.draw_biased_reports(SITES, SPREAD[:2], BIAS, SR, SB, trials=20000, rng=4)
    truth = rg.true_polar(SITES, SPREAD[:2])
    err_r = z[..., 0] - ((1 + BIAS[:, None, 1]) * truth[..., 0] + BIAS[:, None, 0])
    err_b = z[..., 1] - (truth[..., 1] + BIAS[:, None, 2])
    se = np.array([SR, SB]) / np.sqrt(20000)
    assert np.all(np.abs(err_r.mean(0)) < 5 * se[0])
    assert np.all(np.abs(err_b.mean(0)) < 5 * se[1])
    assert err_r.std() == pytest.approx(SR, rel=0.02)


def test_to_cartesian_and_cost_matrix_against_printed_covariance():
    z = rg.draw_biased_reports(SITES, SPREAD[:4], BIAS, SR, SB, rng=5)
    k = rg.cost_matrix(SITES, z[0], z[1], SR, SB, biases=BIAS)
    for i in range(4):
        for j in range(4):
            pts, covs = [], []
            for radar, idx in ((0, i), (1, j)):
                r = (z[radar, idx, 0] - BIAS[radar, 0]) / (1 + BIAS[radar, 1])
                beta = z[radar, idx, 1] - BIAS[radar, 2]
                pts.append(SITES[radar] + r * np.array([np.cos(beta), np.sin(beta)]))
                covs.append(printed_cov(r, beta, SR, SB))
            d = pts[0] - pts[1]
            assert k[i, j] == pytest.approx(d @ np.linalg.solve(covs[0] + covs[1], d), rel=1e-9)


def test_noncentrality_closed_form_and_ncx2_law():
    x = SPREAD[:1]
    lam = rg.noncentrality(SITES, x, BIAS * 0.2, SR, SB)[0]
    mu = rg.bias_displacement(SITES, x, BIAS * 0.2)[:, 0]
    S = sum(printed_cov(*polar_direct(SITES[i], x[0]), SR, SB) for i in range(2))
    d = mu[0] - mu[1]
    assert lam == pytest.approx(d @ np.linalg.solve(S, d), rel=1e-10)
    # Monte Carlo: kappa of the true pair follows ncx2(2, lam)
    N = 20000
    z = rg.draw_biased_reports(SITES, x, BIAS * 0.2, SR, SB, trials=N, rng=6)
    kap = rg.cost_matrix(SITES, z[:, 0], z[:, 1], SR, SB)[:, 0, 0]
    for q in (1.0, 3.0, gating.gate_threshold(0.01, 2), 15.0):
        p = stats.ncx2.cdf(q, 2, lam)
        assert abs(np.mean(kap < q) - p) < 5 * np.sqrt(p * (1 - p) / N) + 1e-3
    assert lam > 1.0     # the test is not vacuous


# --------------------------------------------------------------------------- information
def test_bias_information_against_full_fisher_matrix():
    J = rg.bias_information(SITES, SPREAD, SR, SB)
    F, crlb = full_fim_bias_block(SITES, SPREAD, SR, SB)
    np.testing.assert_allclose(np.linalg.inv(J), crlb, rtol=1e-5)
    assert np.linalg.matrix_rank(F / np.sqrt(np.outer(np.diag(F), np.diag(F)))) == F.shape[0]


def test_bias_information_against_sympy_one_object():
    f = sympy_one_object()
    for x, y, L in ((10.0, 60.0, 30.0), (-25.0, 40.0, 12.0), (5.0, 90.0, 0.0)):
        J = rg.bias_information([[0.0, 0.0], [L, 0.0]], [[x, y]], SR, SB)
        np.testing.assert_allclose(J, np.array(f(x, y, L, SR, SB), dtype=float),
                                   rtol=1e-7, atol=1e-9 * np.abs(J).max())


@given(seed=st.integers(0, 2**31 - 1))
def test_bias_information_is_symmetric_psd_and_additive(seed):
    g = np.random.default_rng(seed)
    x = np.column_stack([g.uniform(-50, 80, 5), g.uniform(20, 100, 5)])
    J = rg.bias_information(SITES, x, SR, SB)
    np.testing.assert_allclose(J, J.T, rtol=0, atol=1e-9 * np.abs(J).max())
    assert np.linalg.eigvalsh(J).min() > -1e-8 * np.abs(J).max()
    parts = sum(rg.bias_information(SITES, x[k:k + 1], SR, SB) for k in range(5))
    np.testing.assert_allclose(J, parts, rtol=1e-9, atol=1e-9 * np.abs(J).max())


@pytest.mark.parametrize(("sites", "targets", "fixed", "rank", "n_free"), [
    ([[0, 0], [0, 0]], SPREAD, None, 3, 6),                      # colocated: relative only
    (SITES, SPREAD, None, 6, 6),                                  # separated: all
    (SITES, SPREAD[:2], None, 4, 6),                              # too few objects
    (SITES, SPREAD[:3], None, 6, 6),
    (SITES, [[50, 0], [60, 0], [75, 0], [90, 0]], None, 4, 6),    # on the baseline
    ([[0, 0], [0, 0]], SPREAD, np.array([[True] * 3, [False] * 3]), 3, 3),   # reference
    ([[0, 0], [0, 0], [0, 0]], SPREAD, None, 6, 9),
])
def test_observability_ranks(sites, targets, fixed, rank, n_free):
    o = rg.observability(sites, targets, SR, SB, fixed=fixed)
    assert (o.rank, o.n_free) == (rank, n_free)
    assert o.observable == (rank == n_free)
    assert o.unobservable.shape == (n_free - rank, 3 * len(sites))
    J = rg.bias_information(sites, targets, SR, SB)
    for v in o.unobservable:                 # null vectors: J v = 0 relative to J's scale
        w = v / np.linalg.norm(v)
        assert np.abs(J @ w).max() < 1e-7 * np.abs(J).max() * max(1.0, 1 / np.abs(w).max())


def test_colocated_null_space_is_common_mode():
    o = rg.observability([[0, 0], [0, 0]], SPREAD, SR, SB)
    np.testing.assert_allclose(o.unobservable, [[1, 0, 0, 1, 0, 0], [0, 1, 0, 0, 1, 0],
                                                [0, 0, 1, 0, 0, 1]], atol=1e-8)
    assert o.descriptions[2] == "azimuth_offset[0] + azimuth_offset[1]"


def test_equal_range_objects_hide_scale_from_offset():
    ang = np.linspace(0.5, 2.0, 6)
    o = rg.observability(SITES, 70 * np.column_stack([np.cos(ang), np.sin(ang)]), SR, SB)
    assert o.rank == 5
    v = o.unobservable[0]
    assert v[0] == pytest.approx(1.0) and v[1] == pytest.approx(-1 / 70, rel=1e-6)


# --------------------------------------------------------------------------- estimation
def test_noise_free_reports_give_the_biases():
    z = rg.draw_biased_reports(SITES, SPREAD, BIAS, 1e-7, 1e-10, rng=1)
    est = rg.estimate_biases(SITES, z, 1e-7, 1e-10)
    np.testing.assert_allclose(est.biases, BIAS, rtol=1e-4, atol=1e-7)
    np.testing.assert_allclose(est.targets, SPREAD, atol=1e-5)


def test_rmse_matches_the_crlb():
    N = 1500
    z = rg.draw_biased_reports(SITES, SPREAD, BIAS, SR, SB, trials=N, rng=7)
    est = rg.estimate_biases(SITES, z, SR, SB)
    _, crlb = full_fim_bias_block(SITES, SPREAD, SR, SB)
    var = np.diag(crlb).reshape(2, 3)
    ratio = ((est.biases - BIAS) ** 2 / var).reshape(N, 6)     # each ~ chi2_1 if efficient
    se = ratio.std(axis=0, ddof=1) / np.sqrt(N)
    assert np.all(np.abs(ratio.mean(axis=0) - 1) < 5 * se)
    assert np.all(np.abs((est.biases - BIAS).mean(0)) < 5 * np.sqrt(var / N))
    # the reported covariance is the inverse information at the estimate, close to the CRLB
    np.testing.assert_allclose(np.median(est.crlb, axis=0), np.sqrt(var), rtol=0.02)
    # chi2 of the residuals ~ chi2_dof
    assert est.dof == 2 * 2 * 8 - 2 * 8 - 6
    assert abs(np.mean(est.chi2) - est.dof) < 5 * np.sqrt(2 * est.dof / N)


def test_batch_equals_loop_and_object_order_does_not_matter():
    z = rg.draw_biased_reports(SITES, SPREAD, BIAS, SR, SB, trials=3, rng=8)
    batch = rg.estimate_biases(SITES, z, SR, SB)
    for t in range(3):
        one = rg.estimate_biases(SITES, z[t], SR, SB)
        np.testing.assert_allclose(one.biases, batch.biases[t], rtol=1e-8, atol=1e-12)
        perm = np.random.default_rng(t).permutation(len(SPREAD))
        shuffled = rg.estimate_biases(SITES, z[t][:, perm], SR, SB)
        np.testing.assert_allclose(shuffled.biases, one.biases, rtol=1e-7, atol=1e-12)


def test_fixed_reference_radar():
    fixed = np.array([[True] * 3, [False] * 3])
    z = rg.draw_biased_reports([[0, 0], [0, 0]], SPREAD, [[0, 0, 0], BIAS[1]], 1e-7, 1e-10, rng=2)
    est = rg.estimate_biases([[0, 0], [0, 0]], z, 1e-7, 1e-10, fixed=fixed)
    assert np.all(est.biases[0] == 0) and np.all(est.crlb[0] == 0)
    np.testing.assert_allclose(est.biases[1], BIAS[1], rtol=1e-4, atol=1e-7)


def test_unobservable_configuration_is_a_value_error():
    z = rg.draw_biased_reports([[0, 0], [0, 0]], SPREAD, BIAS, SR, SB, rng=3)
    with pytest.raises(ValueError, match=r"not observable.*rank 3 of 6.*azimuth_offset"):
        rg.estimate_biases([[0, 0], [0, 0]], z, SR, SB)
    z = rg.draw_biased_reports(SITES, SPREAD[:2], BIAS, SR, SB, rng=3)
    with pytest.raises(ValueError, match="not observable"):
        rg.estimate_biases(SITES, z, SR, SB)


# --------------------------------------------------------------------------- joint registration
def _scene(D, seed, p_detect=1.0):
    g = np.random.default_rng(seed)
    x = g.uniform([12, 47], [18, 53], size=(10, 2))
    b = [[D / np.sqrt(2), 0, D / np.sqrt(2) / 50], [0, 0, 0]]
    return rg.simulate_scene(SITES, x, b, SR, SB, p_detect=p_detect, rng=g), b


FIX = np.array([[True] * 3, [False, True, False]])


def test_registration_recovers_the_association():
    sc, _ = _scene(0.8, 1)
    reg = rg.register_and_associate(SITES, sc.reports1, sc.reports2, SR, SB, fixed=FIX,
                                    p_false_reject=0.01)
    assert reg.converged and reg.iterations == len(reg.history) >= 2
    np.testing.assert_array_equal(reg.association.row_to_col, sc.true_row_to_col)
    unreg = assign_two_lists(
        rg.cost_matrix(SITES, sc.reports1, sc.reports2, SR, SB),
        threshold=gating.gate_threshold(0.01, 2))
    assert not np.array_equal(unreg.row_to_col, sc.true_row_to_col)


def test_non_convergence_warns_or_raises_with_history():
    sc, _ = _scene(0.8, 2)
    with pytest.warns(RadarFusionWarning, match="did not converge.*History: pass 1"):
        reg = rg.register_and_associate(SITES, sc.reports1, sc.reports2, SR, SB, fixed=FIX,
                                        max_iter=1)
    assert not reg.converged and len(reg.history) == 1
    with pytest.raises(rg.RegistrationError, match="did not converge") as info:
        rg.register_and_associate(SITES, sc.reports1, sc.reports2, SR, SB, fixed=FIX,
                                  max_iter=1, on_failure="raise")
    assert len(info.value.history) == 1


def test_warn_without_any_estimate_warns_and_returns_the_last_pass():
    """Too few pairs to estimate anything: "warn" warns and returns, as documented."""
    s = [[0.0, 0.0], [20.0, 0.0]]
    z1, z2 = [[60.0, 0.1]], [[58.0, 0.5]]
    initial = [[0.1, 0.0, 0.0], [0.0, 0.0, 0.0]]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.warns(RadarFusionWarning, match="did not converge.*too few"):
            reg = rg.register_and_associate(s, z1, z2, 0.02, 2e-4, initial=initial)
    assert not reg.converged and reg.estimate is None and len(reg.history) == 1
    np.testing.assert_array_equal(reg.biases, initial)
    expect = assign_two_lists(rg.cost_matrix(s, z1, z2, 0.02, 2e-4, biases=initial))
    np.testing.assert_array_equal(reg.association.row_to_col, expect.row_to_col)
    with pytest.raises(rg.RegistrationError, match="too few"):
        rg.register_and_associate(s, z1, z2, 0.02, 2e-4, on_failure="raise")


def test_accuracy_monte_carlo_orders_the_methods():
    acc = rg.association_accuracy(SITES, [[0.4, 0, 0.006], [0, 0, 0]], SR, SB, n_objects=8,
                                  region=[[12, 47], [18, 53]], trials=30, p_detect=0.9,
                                  p_false_reject=0.01, fixed=FIX, rng=3)
    assert acc.unregistered.estimate < 0.2
    assert acc.registered.estimate > 0.6 and acc.known.estimate > 0.6


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(("call", "exc", "text"), [
    (lambda: rg.apply_biases(-1.0, 0.0, [0, 0, 0]), ValueError, "`r`"),
    (lambda: rg.apply_biases(1.0, 0.0, [0, -1.5, 0]), ValueError, "`biases`"),
    (lambda: rg.apply_biases(1.0, 0.0, [0, 0]), ValueError, "`biases`"),
    (lambda: rg.apply_biases("a", 0.0, [0, 0, 0]), TypeError, "`r`"),
    (lambda: rg.true_polar([0, 0], SPREAD), ValueError, "`sensors`"),
    (lambda: rg.true_polar(SITES, [[0.0, 0.0]]), ValueError, "`targets`"),
    (lambda: rg.draw_biased_reports(SITES, SPREAD, BIAS, -1, SB), ValueError, "`sigma_r`"),
    (lambda: rg.draw_biased_reports(SITES, SPREAD, BIAS, SR, [SB] * 3), ValueError, "`sigma_beta`"),
    (lambda: rg.draw_biased_reports(SITES, SPREAD, BIAS[:1], SR, SB), ValueError, "`biases`"),
    (lambda: rg.draw_biased_reports(SITES, SPREAD, BIAS, SR, SB, trials=0), ValueError, "`trials`"),
    (lambda: rg.draw_biased_reports(SITES, SPREAD, BIAS, SR, SB, rng=np.random.RandomState(1)),
     TypeError, "`rng`"),
    (lambda: rg.noncentrality(SITES[:1], SPREAD, BIAS, SR, SB), ValueError, "`sensors`"),
    (lambda: rg.estimate_biases(SITES[:1], np.ones((1, 3, 2)), SR, SB), ValueError, "`sensors`"),
    (lambda: rg.estimate_biases(SITES, np.ones((3, 4, 2)), SR, SB), ValueError, "`reports`"),
    (lambda: rg.estimate_biases(SITES, -np.ones((2, 4, 2)), SR, SB), ValueError, "`reports`"),
    (lambda: rg.estimate_biases(SITES, np.ones((2, 4, 2)), SR, SB, fixed=[[1, 0, 0]] * 2),
     TypeError, "`fixed`"),
    (lambda: rg.estimate_biases(SITES, np.ones((2, 4, 2)), SR, SB, fixed=np.ones((2, 3), bool)),
     ValueError, "`fixed`"),
    (lambda: rg.estimate_biases(SITES, np.ones((2, 4, 2)), SR, SB, max_iter=0), ValueError,
     "`max_iter`"),
    (lambda: rg.estimate_biases(SITES, np.ones((2, 4, 2)), SR, SB, tol=2.0), ValueError, "`tol`"),
    (lambda: rg.register_and_associate(SITES, np.ones((4, 2)), np.ones((4, 2)), SR, SB,
                                       on_failure="ignore"), ValueError, "`on_failure`"),
    (lambda: rg.register_and_associate(SITES, np.ones((4, 2)), np.ones((4, 2)), SR, SB,
                                       p_false_reject=1.5), ValueError, "`p_false_reject`"),
    (lambda: rg.register_and_associate(SITES, np.ones((2, 4, 2)), np.ones((4, 2)), SR, SB),
     ValueError, "`reports1`"),
    (lambda: rg.simulate_scene(SITES, SPREAD, BIAS, SR, SB, p_detect=0.0), ValueError,
     "`p_detect`"),
    (lambda: rg.association_accuracy(SITES, BIAS, SR, SB, n_objects=5, region=[[1, 1], [0, 2]],
                                     trials=3), ValueError, "`region`"),
    (lambda: rg.cost_matrix(SITES, np.ones((3, 2)), np.ones((3, 3)), SR, SB), ValueError,
     "`reports2`"),
])
def test_bad_input_names_the_argument(call, exc, text):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadarFusionWarning)
        with pytest.raises(exc, match=text):
            call()


def test_reduced_information_is_the_bias_block_of_the_full_information():
    """Eliminating the objects (Schur complement) equals inverting the full normal matrix
    of biases and positions and reading off the bias block of the inverse."""
    g = np.random.default_rng(3)
    m, n = 2, 4
    B, G = g.normal(size=(m, n, 2, 3)), g.normal(size=(m, n, 2, 2))
    rows = []
    for i in range(m):
        for k in range(n):
            J = np.zeros((2, 3 * m + 2 * n))        # one report: its radar's biases, its object
            J[:, 3 * i:3 * i + 3] = B[i, k]
            J[:, 3 * m + 2 * k:3 * m + 2 * k + 2] = G[i, k]
            rows.append(J)
    J = np.concatenate(rows)
    full = J.T @ J
    want = np.linalg.inv(np.linalg.inv(full)[:3 * m, :3 * m])
    np.testing.assert_allclose(rg.reduced_information(B, G), want, rtol=1e-8, atol=1e-10)
    with pytest.raises(ValueError, match=r"`jac_bias`.*`jac_object`"):
        rg.reduced_information(B, G[:, :3])


# --------------------------------------------------------------------------- units
# The same geometries as test_observability_ranks, in kilometres; a change of length unit by
# k multiplies sites, objects, range offsets and sigma_r by k and leaves the rest alone.
UNIT_CASES = [([[0, 0], [0, 0]], SPREAD, 3), (SITES, SPREAD, 6), (SITES, SPREAD[:2], 4),
              (SITES, SPREAD[:3], 6), (SITES, [[50, 0], [60, 0], [75, 0], [90, 0]], 4)]


EXPONENTS = st.one_of(st.sampled_from([-3.0, 3.0]), st.floats(-3.0, 3.0))   # 1e-3 ... 1e3


@given(case=st.sampled_from(range(len(UNIT_CASES))), exponent=EXPONENTS)
def test_observability_rank_does_not_depend_on_the_length_unit(case, exponent):
    # metres (k = 1000) gave rank 4 where kilometres gave 6: the "no information" test
    # compared the range offset's information (1/sigma_r**2) with the range scale's
    sites, targets, rank = UNIT_CASES[case]
    k = 10.0 ** exponent
    o = rg.observability(np.asarray(sites) * k, np.asarray(targets) * k, SR * k, SB)
    assert o.rank == rank


@given(exponent=EXPONENTS)
def test_bias_estimate_does_not_depend_on_the_length_unit(exponent):
    k = 10.0 ** exponent
    z = rg.draw_biased_reports(SITES, SPREAD, BIAS, SR, SB, rng=5)
    ref = rg.estimate_biases(SITES, z, SR, SB)
    zk = np.array(z)
    zk[..., 0] *= k
    est = rg.estimate_biases(SITES * k, zk, SR * k, SB)
    units = np.array([k, 1.0, 1.0])
    np.testing.assert_allclose(est.biases / units, ref.biases, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(est.crlb / units, ref.crlb, rtol=1e-6)
    np.testing.assert_allclose(est.targets / k, ref.targets, rtol=1e-8, atol=1e-9)


def test_a_user_in_metres_with_realistic_noise_is_not_refused():
    # the capstone's radars, in metres: 50 m range noise, 1 mrad azimuth noise
    sites, objs = SITES * 1e3, SPREAD * 1e3
    assert rg.observability(sites, objs, 50.0, 1e-3).rank == 6
    bias_m = BIAS * [1e3, 1, 1]
    z = rg.draw_biased_reports(sites, objs, bias_m, 50.0, 1e-3, trials=200, rng=9)
    est = rg.estimate_biases(sites, z, 50.0, 1e-3)
    err = (est.biases - bias_m) / est.crlb
    assert np.all(np.abs(err.mean(axis=0)) < 5 / np.sqrt(200))


def test_a_pass_estimate_outside_the_model_is_a_failure_not_an_internal_name():
    """A pass's bias estimate beyond the azimuth domain once leaked `biases` (no such argument)."""
    s = [[0.0, 0.0], [0.03471110916176175, 0.0]]
    z1 = [[1.0224992689242969, 1.3431159961090886], [0.001002726555166524, -2.691676416655084],
          [0.011562528200655309, -1.5678555983956006], [0.015709384372036422, 1.19471429104538],
          [1.057022351995125e-05, 1.591803018146205], [4.132102234519689e-05, -2.329311732360455]]
    z2 = [[7.211384153654566, 0.244439220934777], [8.220494513958334, -1.003564138768824],
          [6.164055377748589e-05, -1.35205783573173], [0.7283928490955967, -2.938217357619693],
          [0.0007886597605728409, 2.945597401058798], [0.13979254408386216, -1.2938459369689774]]
    sr, sb = 0.003959362588973653, 5.370047290402376e-05
    with pytest.raises(rg.RegistrationError, match=r"did not converge.*outside") as info:
        rg.register_and_associate(s, z1, z2, sr, sb, on_failure="raise")
    assert "`biases`" not in str(info.value)
    with pytest.warns(RadarFusionWarning, match="did not converge.*outside"):
        reg = rg.register_and_associate(s, z1, z2, sr, sb)
    assert not reg.converged
    np.testing.assert_array_equal(reg.biases, reg.history[-1].biases)


def test_initial_biases_outside_the_model_are_refused_as_initial():
    s = [[0.0, 0.0], [20.0, 0.0]]
    with pytest.raises(ValueError, match=r"^`initial`"):
        rg.register_and_associate(s, [[60.0, 0.1], [61, 0.2]], [[58.0, 0.5], [59, 0.6]], 0.02,
                                  2e-4, initial=[[100.0, 0, 0], [0, 0, 0]])


@given(exponent=EXPONENTS, p_lo=st.sampled_from([None, 1e-3]))
def test_joint_registration_decisions_do_not_depend_on_the_length_unit(exponent, p_lo):
    """The pairs chosen, the passes made and the convergence are the same in any length unit;
    the range offsets scale with it and nothing else does."""
    k = 10.0 ** exponent
    z = rg.draw_biased_reports(SITES, SPREAD, BIAS, SR, SB, rng=11)
    gen = np.random.default_rng(3)
    z1, z2 = z[0], z[1][gen.permutation(len(SPREAD))]
    kw = dict(p_false_reject=p_lo)
    ref = rg.register_and_associate(SITES, z1, z2, SR, SB, **kw)
    s1, s2 = np.array(z1), np.array(z2)
    s1[:, 0] *= k
    s2[:, 0] *= k
    got = rg.register_and_associate(SITES * k, s1, s2, SR * k, SB, **kw)
    np.testing.assert_array_equal(got.association.row_to_col, ref.association.row_to_col)
    assert got.iterations == ref.iterations and got.converged == ref.converged
    units = np.array([k, 1.0, 1.0])
    np.testing.assert_allclose(got.biases / units, ref.biases, rtol=1e-6, atol=1e-12)


def test_a_report_at_the_radar_site_is_named_not_the_sigmas():
    """A report next to its radar (range r with r*sigma_beta < 1e-6 sigma_r) has a singular
    covariance whatever the sigmas: the refusal names that report's argument and index."""
    sites = [[0.0, 0.0], [50.0, 0.0]]
    for k, (r1, r2) in enumerate((([[1e-20, 0.3], [30.0, 0.2]], [[50.0, 3.1]]),
                                   ([[30.0, 0.2]], [[40.0, 3.1], [1e-9, 1.0]]))):
        with pytest.raises(ValueError, match=rf"`reports{k + 1}`: report \(\d+,\) is at range"):
            rg.cost_matrix(sites, r1, r2, 0.1, 1e-3)
    # a short but resolvable range is scored, not refused
    assert np.all(np.isfinite(rg.cost_matrix(sites, [[1e-3, 0.3]], [[50.0, 3.1]], 0.1, 1e-3)))
