"""Tests of radarfusion_ref.trackfusion.

Oracles are independent of the module: the best linear unbiased estimate (BLUE) of
the stacked pair [x1; x2] with the joint covariance, written here with explicit
inverses; a brute-force scan over ω; Kalata's closed-form steady state of the
α–β filter and a sympy solution of the cross-covariance equation; Van Loan's
matrix-exponential route to the process noise; and a Monte Carlo of two Kalman
filters written here, with tolerances from the standard error.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st
from scipy import linalg, stats

from radarfusion_ref import trackfusion as tf

SEEDS = st.integers(0, 2**32 - 1)
DIMS = st.integers(1, 4)


def _joint(seed, d, rho=1.0):
    """A random joint covariance of two tracks: P1, P2, P12 (PSD by construction)."""
    g = np.random.default_rng(seed)
    common = g.standard_normal((d, 2 * d))
    B1 = g.standard_normal((d, 2 * d)) + 0.3 * np.eye(d, 2 * d)
    B2 = g.standard_normal((d, 2 * d)) + 0.3 * np.eye(d, 2 * d, k=d)
    L = np.vstack([B1 + rho * common, B2 + rho * common])
    C = L @ L.T + 1e-3 * np.eye(2 * d)
    return C[:d, :d], C[d:, d:], C[:d, d:], C


def _blue(x1, x2, C):
    """BLUE of x from z = [x1; x2] = [I; I] x + e, Cov e = C (explicit inverses)."""
    d = len(x1)
    A = np.vstack([np.eye(d), np.eye(d)])
    Ci = np.linalg.inv(C)
    P = np.linalg.inv(A.T @ Ci @ A)
    return P @ A.T @ Ci @ np.concatenate([x1, x2]), P


def _psd(M, tol=1e-9):
    return np.linalg.eigvalsh(0.5 * (M + M.T)).min() >= -tol * max(1.0, np.abs(M).max())


# --------------------------------------------------------------------------- fusion rules
@given(SEEDS, DIMS, st.floats(0.0, 2.0))
def test_bar_shalom_campo_is_the_blue_of_the_stacked_pair(seed, d, rho):
    P1, P2, P12, C = _joint(seed, d, rho)
    g = np.random.default_rng(seed + 1)
    x1, x2 = g.standard_normal(d), g.standard_normal(d)
    out = tf.bar_shalom_campo(x1, P1, x2, P2, P12)
    x_ref, P_ref = _blue(x1, x2, C)
    np.testing.assert_allclose(out.estimate, x_ref, rtol=1e-7, atol=1e-7 * np.abs(x_ref).max())
    np.testing.assert_allclose(out.covariance, P_ref, rtol=1e-7, atol=1e-9 * np.abs(P_ref).max())
    # optimality: no larger than either track
    assert _psd(P1 - out.covariance) and _psd(P2 - out.covariance)


@given(SEEDS, DIMS)
def test_naive_fusion_is_the_information_sum(seed, d):
    P1, P2, _, _ = _joint(seed, d)
    g = np.random.default_rng(seed)
    x1, x2 = g.standard_normal(d), g.standard_normal(d)
    out = tf.naive_fusion(x1, P1, x2, P2)
    P = np.linalg.inv(np.linalg.inv(P1) + np.linalg.inv(P2))
    np.testing.assert_allclose(out.covariance, P, rtol=1e-8, atol=1e-10 * np.abs(P).max())
    np.testing.assert_allclose(out.estimate, P @ (np.linalg.solve(P1, x1) + np.linalg.solve(P2, x2)),
                               rtol=1e-7, atol=1e-8)
    # = Bar-Shalom–Campo with P12 = 0 (the BLUE with a block-diagonal joint covariance)
    x_ref, _ = _blue(x1, x2, linalg.block_diag(P1, P2))
    np.testing.assert_allclose(out.estimate, x_ref, rtol=1e-7, atol=1e-8)


def _criterion(w, P1, P2, kind):
    """det or trace of (ω P1⁻¹ + (1-ω) P2⁻¹)⁻¹, for an array of ω."""
    w = np.asarray(w, dtype=float)[..., None, None]
    P = np.linalg.inv(w * np.linalg.inv(P1) + (1 - w) * np.linalg.inv(P2))
    return np.linalg.det(P) if kind == "det" else np.trace(P, axis1=-2, axis2=-1)


@pytest.mark.parametrize("kind", tf.CRITERIA)
@given(seed=SEEDS, d=DIMS)
def test_covariance_intersection_omega_beats_a_brute_force_scan(kind, seed, d):
    P1, P2, _, _ = _joint(seed, d)
    out = tf.covariance_intersection(np.zeros(d), P1, np.ones(d), P2, criterion=kind)
    grid = np.linspace(0.0, 1.0, 2001)
    values = _criterion(grid, P1, P2, kind)
    best = values.min()
    got = _criterion(float(out.omega), P1, P2, kind)
    assert 0.0 <= out.omega <= 1.0
    assert got <= best * (1 + 1e-9)
    # the scan's minimiser is within one grid step unless the criterion is flat there
    w_scan = grid[np.argmin(values)]
    if values.max() - best > 1e-6 * best:
        assert abs(float(out.omega) - w_scan) <= 2e-3 or abs(got - best) <= 1e-9 * best


@given(SEEDS, DIMS, st.floats(0.0, 3.0), st.sampled_from(tf.CRITERIA))
def test_covariance_intersection_is_consistent_for_any_cross_covariance(seed, d, rho, kind):
    P1, P2, P12, C = _joint(seed, d, rho)
    out = tf.covariance_intersection(np.zeros(d), P1, np.zeros(d), P2, criterion=kind)
    w = float(out.omega)
    W1 = w * out.covariance @ np.linalg.inv(P1)
    W2 = (1 - w) * out.covariance @ np.linalg.inv(P2)
    np.testing.assert_allclose(W1 + W2, np.eye(d), atol=1e-8)          # unbiased
    W = np.hstack([W1, W2])
    mse = W @ C @ W.T                                                  # true error covariance
    assert _psd(out.covariance - mse, tol=1e-7)
    # and the BLUE (Bar-Shalom–Campo with the true P12) is at least as good
    bsc = tf.bar_shalom_campo(np.zeros(d), P1, np.zeros(d), P2, P12)
    assert _psd(mse - bsc.covariance, tol=1e-7)


def test_covariance_intersection_given_omega_and_scalar_case():
    P1, P2 = np.array([[2.0]]), np.array([[3.0]])
    for w in (0.0, 0.3, 1.0):
        out = tf.covariance_intersection([1.0], P1, [4.0], P2, omega=w)
        J = w / 2 + (1 - w) / 3
        np.testing.assert_allclose(out.covariance, [[1 / J]])
        np.testing.assert_allclose(out.estimate, [(w * 1 / 2 + (1 - w) * 4 / 3) / J])
        assert out.criterion == "given"
    # in one dimension both criteria pick the better track
    for kind in tf.CRITERIA:
        out = tf.covariance_intersection([1.0], P1, [4.0], P2, criterion=kind)
        assert out.omega == 1.0 and out.covariance[0, 0] == pytest.approx(2.0)


def test_fusion_rules_are_batched_over_leading_axes():
    items = [_joint(s, 2, 0.7) for s in range(6)]
    P1 = np.stack([a[0] for a in items]).reshape(2, 3, 2, 2)
    P2 = np.stack([a[1] for a in items]).reshape(2, 3, 2, 2)
    P12 = np.stack([a[2] for a in items]).reshape(2, 3, 2, 2)
    g = np.random.default_rng(3)
    x1, x2 = g.standard_normal((2, 3, 2)), g.standard_normal((1, 3, 2))
    outs = {
        "naive": tf.naive_fusion(x1, P1, x2, P2),
        "bsc": tf.bar_shalom_campo(x1, P1, x2, P2, P12),
        "ci": tf.covariance_intersection(x1, P1, x2, P2, criterion="trace"),
    }
    assert outs["ci"].omega.shape == (2, 3)
    for i in range(2):
        for j in range(3):
            one = {
                "naive": tf.naive_fusion(x1[i, j], P1[i, j], x2[0, j], P2[i, j]),
                "bsc": tf.bar_shalom_campo(x1[i, j], P1[i, j], x2[0, j], P2[i, j], P12[i, j]),
                "ci": tf.covariance_intersection(x1[i, j], P1[i, j], x2[0, j], P2[i, j],
                                                 criterion="trace"),
            }
            for k, r in one.items():
                np.testing.assert_allclose(outs[k].estimate[i, j], r.estimate, rtol=1e-10)
                np.testing.assert_allclose(outs[k].covariance[i, j], r.covariance, rtol=1e-10)
    with pytest.raises(AttributeError):
        outs["bsc"].estimate = None        # frozen result


# --------------------------------------------------------------------------- association
@given(SEEDS, DIMS, st.floats(0.0, 2.0))
def test_track_statistic_is_the_mahalanobis_distance_with_the_cross_covariance(seed, d, rho):
    P1, P2, P12, _ = _joint(seed, d, rho)
    g = np.random.default_rng(seed)
    x1, x2 = g.standard_normal(d), g.standard_normal(d)
    S = P1 + P2 - P12 - P12.T
    delta = x1 - x2
    ref = delta @ np.linalg.inv(S) @ delta
    assert tf.track_statistic(x1, P1, x2, P2, P12) == pytest.approx(ref, rel=1e-7)
    ref0 = delta @ np.linalg.inv(P1 + P2) @ delta
    assert tf.track_statistic(x1, P1, x2, P2) == pytest.approx(ref0, rel=1e-7)


def test_track_statistic_is_chi_square_under_one_object():
    P1, P2, P12, C = _joint(11, 3, 1.0)
    g = np.random.default_rng(5)
    e = g.standard_normal((20_000, 6)) @ np.linalg.cholesky(C).T
    k = tf.track_statistic(e[:, :3], P1, e[:, 3:], P2, P12)
    assert stats.kstest(k, stats.chi2(3).cdf).pvalue > 1e-4
    # ignoring P12 (here positively correlated tracks) the statistic is too small
    k0 = tf.track_statistic(e[:, :3], P1, e[:, 3:], P2)
    assert k0.mean() < 3 - 5 * np.sqrt(6 / 20_000)


# --------------------------------------------------------------------------- motion model
def test_constant_velocity_matches_van_loan():
    dt, q = 0.7, 2.3
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    G = np.array([[0.0], [1.0]])
    # Van Loan (1978): expm([[-A, G q Gᵀ], [0, Aᵀ]] dt) gives F and Q
    M = np.block([[-A, q * G @ G.T], [np.zeros((2, 2)), A.T]]) * dt
    E = linalg.expm(M)
    F = E[2:, 2:].T
    Q = F @ E[:2, 2:]
    m = tf.constant_velocity(dt, q)
    np.testing.assert_allclose(m.F, F, atol=1e-12)
    np.testing.assert_allclose(m.Q, Q, rtol=1e-10)
    # the discrete model: a constant acceleration a over the interval, Var a = q
    g = np.array([dt**2 / 2, dt])
    np.testing.assert_allclose(tf.constant_velocity(dt, q, noise="discrete").Q, q * np.outer(g, g))
    two = tf.constant_velocity([dt, 1.0], q, dim=2)
    assert two.F.shape == (2, 4, 4)
    np.testing.assert_allclose(two.F[0][np.ix_([0, 2], [0, 2])], F)
    np.testing.assert_allclose(two.Q[0][np.ix_([1, 3], [1, 3])], Q)


# --------------------------------------------------------------------------- cross-covariance
@functools.lru_cache(maxsize=1)
def _kalata():
    """Steady state of the α–β filter (DWNA model, position measured, T = 1, σ_w = 1),
    parametrised by u = sqrt(1 - α): Kalata's gains and covariance, and P12 solved by sympy."""
    u = sp.symbols("u", positive=True)
    alpha, beta = 1 - u**2, 2 * (1 - u) ** 2
    lam2 = beta**2 / (1 - alpha)                       # tracking index² = q T⁴ / σ_w²
    F = sp.Matrix([[1, 1], [0, 1]])
    Q = lam2 * sp.Matrix([[sp.Rational(1, 4), sp.Rational(1, 2)], [sp.Rational(1, 2), 1]])
    K = sp.Matrix([alpha, beta])
    A = sp.eye(2) - K * sp.Matrix([[1, 0]])
    a, b, c = sp.symbols("a b c")
    X = sp.Matrix([[a, b], [b, c]])
    sol = sp.solve(list(X - A * (F * X * F.T + Q) * A.T), [a, b, c], dict=True)[0]
    P = sp.Matrix([[alpha, beta], [beta, beta * (alpha - beta / 2) / (1 - alpha)]])
    lam = sp.sqrt(lam2)
    return (sp.lambdify(u, lam), sp.lambdify(u, P, "numpy"),
            sp.lambdify(u, X.subs(sol), "numpy"))


@pytest.mark.parametrize("u", [0.2, 0.5, 0.8, 0.95])
def test_steady_state_matches_kalata_and_sympy(u):
    lam, P, P12 = _kalata()
    m = tf.constant_velocity(1.0, lam(u) ** 2, noise="discrete")
    H = [[1.0, 0.0]]
    c = tf.cross_covariance(m.F, m.Q, H, [[1.0]], H, [[1.0]])
    np.testing.assert_allclose(c.P1, P(u), rtol=1e-8)
    np.testing.assert_allclose(c.P2, P(u), rtol=1e-8)
    np.testing.assert_allclose(c.K1[:, 0], [1 - u**2, 2 * (1 - u) ** 2], rtol=1e-8)
    np.testing.assert_allclose(c.P12, P12(u), rtol=1e-8)


def test_recursion_converges_to_the_steady_state_and_is_batched():
    m = tf.constant_velocity([0.5, 1.0, 2.0], 0.3, dim=2)
    H = np.hstack([np.eye(2), np.zeros((2, 2))])
    R1, R2 = np.diag([1.0, 0.1]), np.diag([0.2, 2.0])
    rec = tf.cross_covariance(m.F, m.Q, H, R1, H, R2, steps=400, P1_0=100 * np.eye(4),
                              P2_0=50 * np.eye(4))
    ss = tf.cross_covariance(m.F, m.Q, H, R1, H, R2)
    assert rec.P12.shape == (3, 400, 4, 4) and ss.P12.shape == (3, 4, 4)
    for k in ("P1", "P2", "P12", "K1", "K2"):
        np.testing.assert_allclose(getattr(rec, k)[:, -1], getattr(ss, k), rtol=1e-7, atol=1e-10)
    one = tf.cross_covariance(m.F[1], m.Q[1], H, R1, H, R2)
    np.testing.assert_allclose(one.P12, ss.P12[1], rtol=1e-10)


def _two_filters(F, Q, H1, R1, H2, R2, P0, steps, trials, seed):
    """Two Kalman filters (written here) on one simulated object; returns the errors."""
    g = np.random.default_rng(seed)
    d = F.shape[0]
    x = np.zeros((trials, d))
    est = [g.multivariate_normal(np.zeros(d), P0, trials) for _ in range(2)]
    P = [P0.copy(), P0.copy()]
    for _ in range(steps):
        x = x @ F.T + g.multivariate_normal(np.zeros(d), Q, trials, method="eigh")
        for i, (H, R) in enumerate(((H1, R1), (H2, R2))):
            M = F @ P[i] @ F.T + Q
            K = M @ H.T @ np.linalg.inv(H @ M @ H.T + R)
            z = x @ H.T + g.multivariate_normal(np.zeros(len(R)), R, trials)
            pred = est[i] @ F.T
            est[i] = pred + (z - pred @ H.T) @ K.T
            P[i] = (np.eye(d) - K @ H) @ M
    return est[0] - x, est[1] - x


def test_cross_covariance_matches_a_monte_carlo_of_two_filters():
    m = tf.constant_velocity(1.0, 0.5)
    H = np.array([[1.0, 0.0]])
    R1, R2 = np.array([[1.0]]), np.array([[3.0]])
    P0, steps, trials = 10 * np.eye(2), 8, 20_000
    e1, e2 = _two_filters(m.F, m.Q, H, R1, H, R2, P0, steps, trials, seed=7)
    c = tf.cross_covariance(m.F, m.Q, H, R1, H, R2, steps=steps, P1_0=P0, P2_0=P0)
    prod = e1[:, :, None] * e2[:, None, :]
    mc, se = prod.mean(0), prod.std(0, ddof=1) / np.sqrt(trials)
    assert np.all(np.abs(mc - c.P12[-1]) <= 5 * se)
    assert np.all(np.abs(c.P12[-1]) > 10 * se)          # a correlation the MC resolves
    # the package's own simulator agrees with the recursion too
    runs = tf.simulate_tracks(m.F, m.Q, H, R1, H, R2, steps=steps, trials=trials, P1_0=P0,
                              P2_0=P0, rng=8)
    prod = runs.error1[:, -1, :, None] * runs.error2[:, -1, None, :]
    mc, se = prod.mean(0), prod.std(0, ddof=1) / np.sqrt(trials)
    assert np.all(np.abs(mc - c.P12[-1]) <= 5 * se)
    v = runs.error1[:, -1, 0] ** 2
    assert abs(v.mean() - c.P1[-1, 0, 0]) <= 5 * v.std() / np.sqrt(trials)


# --------------------------------------------------------------------------- bad input
def test_joint_covariance_not_psd_is_refused_by_name():
    P = np.eye(2)
    with pytest.raises(ValueError, match=r"`cov12`.*positive semi-definite"):
        tf.bar_shalom_campo([0, 0], P, [0, 0], P, 1.5 * np.eye(2))
    with pytest.raises(ValueError, match=r"`cov12`.*positive semi-definite"):
        tf.track_statistic([0, 0], P, [0, 0], P, [[0.0, 2.0], [0.0, 0.0]])
    with pytest.raises(ValueError, match=r"`cov12`.*singular"):
        tf.bar_shalom_campo([0, 0], P, [0, 0], P, P)              # identical tracks
    with pytest.raises(ValueError, match=r"`P12_0`.*positive semi-definite"):
        tf.cross_covariance(np.eye(2), np.eye(2), [[1, 0]], [[1]], [[1, 0]], [[1]], steps=2,
                            P1_0=P, P2_0=P, P12_0=3 * P)


def test_omega_and_options_are_validated():
    P = np.eye(2)
    for bad in (-0.1, 1.5, [0.2, 2.0]):
        with pytest.raises(ValueError, match=r"`omega` must lie in the closed interval \[0, 1\]"):
            tf.covariance_intersection([0, 0], P, [1, 1], P, omega=bad)
    with pytest.raises(ValueError, match="`criterion`"):
        tf.covariance_intersection([0, 0], P, [1, 1], P, criterion="max")
    with pytest.raises(TypeError, match="`omega`"):
        tf.covariance_intersection([0, 0], P, [1, 1], P, omega="0.5")
    with pytest.raises(ValueError, match="`P1_0`"):
        tf.cross_covariance(np.eye(2), np.eye(2), [[1, 0]], [[1]], [[1, 0]], [[1]], steps=3)
    with pytest.raises(ValueError, match="`P1_0` is only used with `steps`"):
        tf.cross_covariance(np.eye(2), np.eye(2), [[1, 0]], [[1]], [[1, 0]], [[1]], P1_0=P)
    with pytest.raises(ValueError, match="`Q` must be positive semi-definite"):
        tf.cross_covariance(np.eye(2), -np.eye(2), [[1, 0]], [[1]], [[1, 0]], [[1]])
    with pytest.raises(ValueError, match="`cov1`"):
        tf.naive_fusion([0, 0], -P, [0, 0], P)
    with pytest.raises(ValueError, match="`x2`"):
        tf.naive_fusion([0, 0], P, [0, 0, 0], P)
    with pytest.raises(ValueError, match="`R1`"):
        tf.cross_covariance(np.eye(2), np.eye(2), [[1, 0]], [[0.0]], [[1, 0]], [[1]])


def test_no_steady_state_without_process_noise_is_reported():
    F = np.array([[1.0, 1.0], [0.0, 1.0]])
    with pytest.raises(ValueError, match=r"no (stabilising|unique steady state)"):
        tf.cross_covariance(F, np.zeros((2, 2)), [[1, 0]], [[1]], [[1, 0]], [[1]])


def test_ci_weight_minimises_the_criterion_on_a_fine_grid():
    # independent route: the criterion evaluated with numpy on 20 001 weights
    from radarfusion_ref.trackfusion import ci_weight

    rng = np.random.default_rng(8)
    for _ in range(5):
        a, b = rng.normal(size=(2, 3, 3))
        P1, P2 = a @ a.T + 0.2 * np.eye(3), b @ b.T + 0.2 * np.eye(3)
        grid = np.linspace(0.0, 1.0, 20_001)
        J = grid[:, None, None] * np.linalg.inv(P1) + (1 - grid[:, None, None]) * np.linalg.inv(P2)
        for criterion, value in (("det", 1 / np.linalg.det(J)),
                                 ("trace", np.trace(np.linalg.inv(J), axis1=1, axis2=2))):
            w = ci_weight(P1, P2, criterion=criterion)
            assert abs(w - grid[np.argmin(value)]) <= 1e-3
    with pytest.raises(ValueError, match="`criterion`"):
        ci_weight(np.eye(2), np.eye(2), criterion="max")
    with pytest.raises(ValueError, match="`cov2`"):
        ci_weight(np.eye(2), -np.eye(2))


# --------------------------------------------------------------------------- blue_fusion
def _random_joint(rng, n, d):
    """A random joint covariance of n correlated d-vectors (symmetric positive definite)."""
    a = rng.normal(size=(n * d, n * d))
    return a @ a.T + 0.1 * np.eye(n * d)


def test_blue_fusion_is_the_generalised_least_squares_estimate():
    # independent route: whiten the stacked problem y = H x + e by C's Cholesky factor and
    # solve it by numpy.linalg.lstsq; the covariance is the inverse of the whitened normal
    # matrix
    rng = np.random.default_rng(21)
    for n, d in ((2, 1), (3, 2), (3, 6), (4, 3)):
        C = _random_joint(rng, n, d)
        x = rng.normal(size=(n, d)) + 1e3
        L = np.linalg.cholesky(C)
        Hw = np.linalg.solve(L, np.tile(np.eye(d), (n, 1)))
        ref, *_ = np.linalg.lstsq(Hw, np.linalg.solve(L, x.reshape(-1)), rcond=None)
        r = tf.blue_fusion(x, C)
        np.testing.assert_allclose(r.estimate, ref, rtol=1e-10, atol=1e-9)
        np.testing.assert_allclose(r.covariance, np.linalg.inv(Hw.T @ Hw), rtol=1e-9,
                                   atol=1e-12)


def test_blue_fusion_of_two_is_bar_shalom_campo_and_without_correlation_naive():
    rng = np.random.default_rng(22)
    C = np.stack([_random_joint(rng, 2, 3) for _ in range(5)])      # a batch of 5
    x = rng.normal(size=(5, 2, 3))
    r = tf.blue_fusion(x, C)
    b = tf.bar_shalom_campo(x[:, 0], C[:, :3, :3], x[:, 1], C[:, 3:, 3:], C[:, :3, 3:])
    np.testing.assert_allclose(r.estimate, b.estimate, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.covariance, b.covariance, rtol=1e-10, atol=1e-12)
    C[:, :3, 3:] = C[:, 3:, :3] = 0.0
    r = tf.blue_fusion(x, C)
    nv = tf.naive_fusion(x[:, 0], C[:, :3, :3], x[:, 1], C[:, 3:, 3:])
    np.testing.assert_allclose(r.covariance, nv.covariance, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(r.estimate, nv.estimate, rtol=1e-10, atol=1e-12)


def test_blue_fusion_covariance_is_the_error_covariance_monte_carlo():
    # 20 000 draws of three correlated estimates of a known state: the fused errors' sample
    # covariance matches the returned covariance, each entry within 4.5 standard errors
    rng = np.random.default_rng(23)
    n, d, trials = 3, 2, 20_000
    C = _random_joint(rng, n, d)
    truth = np.array([5.0, -2.0])
    e = rng.multivariate_normal(np.zeros(n * d), C, trials).reshape(trials, n, d)
    r = tf.blue_fusion(truth + e, C)
    err = r.estimate - truth
    P = r.covariance[0]
    emp = err.T @ err / trials
    se = np.sqrt((np.outer(np.diag(P), np.diag(P)) + P**2) / trials)
    assert np.all(np.abs(emp - P) < 4.5 * se), (emp, P)
    assert np.all(np.abs(err.mean(0)) < 4.5 * np.sqrt(np.diag(P) / trials))


def test_blue_fusion_refuses_bad_input_by_name():
    with pytest.raises(ValueError, match=r"`cov` must have shape \(\.\.\., 4, 4\) for `x`"):
        tf.blue_fusion(np.zeros((2, 2)), np.eye(3))
    with pytest.raises(ValueError, match="`cov`"):
        tf.blue_fusion(np.zeros((2, 1)), [[1.0, 2.0], [2.0, 1.0]])        # not PD
    with pytest.raises(ValueError, match=r"`x` must have shape \(\.\.\., n, d\)"):
        tf.blue_fusion(np.zeros((0, 2)), np.eye(0))
    with pytest.raises(ValueError, match="`x`"):
        tf.blue_fusion([1.0, 2.0], np.eye(2))                              # no (n, d) axes
    with pytest.raises(ValueError, match=r"`x`, `cov` must have broadcasting"):
        tf.blue_fusion(np.zeros((3, 2, 1)), np.broadcast_to(np.eye(2), (4, 2, 2)))
    with pytest.raises(ValueError, match=r"`x`.*2\*\*150"):
        tf.blue_fusion([[1e300], [0.0]], np.eye(2))
