"""The engine's tracking formulas against independent routes.

Kalman filter: Stone Soup's constant-velocity transition model (an independent
implementation) and the information form of the update; JPDA: brute-force sums over
every joint event listed by itertools; the score: Wald's inequality by simulation;
M-of-N: a plain loop; IMM: the exact Gaussian-mixture posterior over every mode sequence
(where the IMM must equal it) and filterpy's IMMEstimator.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from radarfusion_ref.engine.montecarlo import binomial_tolerance
from radarfusion_ref.engine.tracker import (
    imm_combine,
    imm_mixing,
    imm_predict,
    imm_update,
    jpda_probabilities,
    kalman_predict,
    kalman_update,
    m_of_n,
    score_increments,
    sprt_thresholds,
)


def _random_cov(rng, n, scale=1.0):
    a = rng.standard_normal((n, n))
    return scale * (a @ a.T + n * np.eye(n))


def test_predict_matches_stone_soup_constant_velocity():
    models = pytest.importorskip("stonesoup.models.transition.linear")
    rng = np.random.default_rng(3)
    q, dt = 7.0, 4.5
    ss = models.CombinedLinearGaussianTransitionModel([models.ConstantVelocity(q)] * 3)
    F_ss, Q_ss = ss.matrix(time_interval=_td(dt)), ss.covar(time_interval=_td(dt))
    # Stone Soup orders the state (x, vx, y, vy, z, vz); ours is (x, y, z, vx, vy, vz)
    perm = [0, 2, 4, 1, 3, 5]
    F = np.asarray(F_ss)[np.ix_(perm, perm)]
    Q = np.asarray(Q_ss)[np.ix_(perm, perm)]
    x = rng.standard_normal(6)
    P = _random_cov(rng, 6)
    r = kalman_predict(x, P, dt, q)
    np.testing.assert_allclose(r.state, F @ x, rtol=1e-12)
    np.testing.assert_allclose(r.covariance, F @ P @ F.T + Q, rtol=1e-12)


def _td(dt):
    import datetime
    return datetime.timedelta(seconds=dt)


@given(st.floats(0.0, 5.0), st.floats(0.0, 5.0), st.floats(0.0, 3.0))
def test_prediction_composes_and_adds_process_noise(t1, t2, q):
    x = np.array([1.0, -2.0, 0.5, 0.3])
    P = np.diag([1.0, 2.0, 0.3, 0.4]) + 0.1
    half = kalman_predict(x, P, t1, q)
    a = kalman_predict(half.state, half.covariance, t2, q)
    b = kalman_predict(x, P, t1 + t2, q)
    np.testing.assert_allclose(a.state, b.state, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(a.covariance, b.covariance, rtol=1e-9, atol=1e-9)
    F = np.eye(4) + (t1 + t2) * np.eye(4, k=2)
    # the motion's uncertainty is added, never removed: P(t + dt) - F P F^T is PSD
    assert np.linalg.eigvalsh(b.covariance - F @ P @ F.T).min() >= -1e-9


def test_predict_broadcasts_over_tracks_and_intervals():
    rng = np.random.default_rng(4)
    x = rng.standard_normal((5, 4))
    P = np.stack([_random_cov(rng, 4) for _ in range(5)])
    dt = rng.uniform(0, 10, 5)
    batch = kalman_predict(x, P, dt, 2.0)
    for i in range(5):
        single = kalman_predict(x[i], P[i], dt[i], 2.0)
        np.testing.assert_allclose(single.state, batch.state[i], rtol=1e-12)
        np.testing.assert_allclose(single.covariance, batch.covariance[i], rtol=1e-12)


def test_predict_refuses_by_name():
    with pytest.raises(ValueError, match="`dt`"):
        kalman_predict([0, 1], np.eye(2), -1.0, 1.0)
    with pytest.raises(ValueError, match="`x`"):
        kalman_predict([0, 1, 2], np.eye(3), 1.0, 1.0)


def test_update_equals_information_form():
    rng = np.random.default_rng(5)
    for n in (2, 4, 6):
        d = n // 2
        x, P = rng.standard_normal(n), _random_cov(rng, n)
        z, R = rng.standard_normal(d), _random_cov(rng, d, 0.5)
        H = np.hstack([np.eye(d), np.zeros((d, d))])
        info = np.linalg.inv(P) + H.T @ np.linalg.inv(R) @ H
        P_ref = np.linalg.inv(info)
        x_ref = P_ref @ (np.linalg.solve(P, x) + H.T @ np.linalg.solve(R, z))
        r = kalman_update(x, P, z, R)
        np.testing.assert_allclose(r.covariance, P_ref, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(r.state, x_ref, rtol=1e-9, atol=1e-12)
        S = H @ P @ H.T + R
        nu = z - H @ x
        assert r.statistic == pytest.approx(nu @ np.linalg.solve(S, nu), rel=1e-12)
        assert r.log_det == pytest.approx(np.linalg.slogdet(S)[1], rel=1e-12)


def test_score_increment_is_log_of_gaussian_ratio():
    from scipy import stats
    rng = np.random.default_rng(6)
    S = _random_cov(rng, 3, 100.0)
    nu = rng.standard_normal(3) * 10
    d2 = nu @ np.linalg.solve(S, nu)
    got = score_increments(d2, np.linalg.slogdet(S)[1], p_detection=0.8, clutter_density=1e-9)
    ref = math.log(0.8 * stats.multivariate_normal(np.zeros(3), S).pdf(nu) / 1e-9)
    assert float(got) == pytest.approx(ref, rel=1e-12)


def test_sprt_thresholds_wald_inequality_by_simulation():
    # H0: Bernoulli(0.2) hits, H1: Bernoulli(0.7); increments are the exact LLR
    alpha, beta = 0.05, 0.1
    t = sprt_thresholds(alpha, beta)
    assert math.exp(t.upper) == pytest.approx((1 - beta) / alpha)
    assert math.exp(t.lower) == pytest.approx(beta / (1 - alpha))
    rng = np.random.default_rng(7)
    trials, steps = 20000, 200
    p0, p1 = 0.2, 0.7
    hit, miss = math.log(p1 / p0), math.log((1 - p1) / (1 - p0))
    for truth, bound in ((p0, alpha / (1 - beta)), (p1, beta / (1 - alpha))):
        h = rng.random((trials, steps)) < truth
        score = np.cumsum(np.where(h, hit, miss), axis=1)
        t_up, t_lo = t.upper, t.lower
        above, below = score >= t_up, score <= t_lo
        up = np.where(above.any(1), np.argmax(above, 1), steps)
        lo = np.where(below.any(1), np.argmax(below, 1), steps)
        assert np.all(np.minimum(up, lo) < steps)
        wrong = np.count_nonzero(up < lo) if truth == p0 else np.count_nonzero(lo < up)
        assert wrong / trials <= bound + binomial_tolerance(bound, trials)


@pytest.mark.parametrize(("alpha", "beta"), [(0.0, 0.1), (1.0, 0.1), (0.6, 0.5), (0.1, -0.1)])
def test_sprt_refuses_by_name(alpha, beta):
    with pytest.raises(ValueError, match=r"`p_false_confirm`|`p_false_delete`"):
        sprt_thresholds(alpha, beta)


def _brute_jpda(r, w):
    T, M = r.shape
    num = np.zeros((T, M + 1))
    total = 0.0
    for choice in itertools.product(*[[-1, *range(M)]] * T):
        used = [j for j in choice if j >= 0]
        if len(used) != len(set(used)) or any(j >= 0 and r[i, j] == 0 for i, j in enumerate(choice)):
            continue
        wt = math.prod(w[i] if j < 0 else r[i, j] for i, j in enumerate(choice))
        total += wt
        for i, j in enumerate(choice):
            num[i, j if j >= 0 else M] += wt
    return num / total


@pytest.mark.parametrize("seed", range(6))
def test_jpda_exact_and_kbest_against_brute_force(seed):
    rng = np.random.default_rng(seed)
    T, M = rng.integers(1, 5), rng.integers(0, 5)
    r = rng.exponential(3.0, (T, M)) * (rng.random((T, M)) < 0.7)
    w = rng.uniform(0.05, 0.5, T)
    ref = _brute_jpda(r, w)
    e = jpda_probabilities(r, w)
    assert e.exact and e.bound == 0
    np.testing.assert_allclose(e.probabilities, ref[:, :M], atol=1e-12)
    np.testing.assert_allclose(e.miss, ref[:, M], atol=1e-12)
    for k in (1, 3, 10, 10_000):
        kb = jpda_probabilities(r, w, k=k)
        err = max(np.abs(kb.probabilities - ref[:, :M]).max(initial=0),
                  np.abs(kb.miss - ref[:, M]).max())
        assert err <= kb.bound + 1e-12
        if kb.exact:
            assert err < 1e-12


def test_jpda_refuses_large_exact_and_bad_input():
    r = np.ones((12, 12))
    with pytest.raises(ValueError, match=r"k="):
        jpda_probabilities(r, np.ones(12))
    with pytest.raises(ValueError, match="`ratio`"):
        jpda_probabilities(-r, np.ones(12))
    with pytest.raises(ValueError, match="`miss`"):
        jpda_probabilities(r, np.zeros(12))
    with pytest.raises(ValueError, match="`k`"):
        jpda_probabilities(r, np.ones(12), k=0)


def test_m_of_n_against_loop():
    rng = np.random.default_rng(8)
    h = rng.random((200, 12)) < 0.4
    for m, n in ((1, 1), (2, 3), (3, 5), (4, 4)):
        got = m_of_n(h, m, n)
        for row, g in zip(h, got, strict=True):
            ref = next((t for t in range(12) if row[max(0, t - n + 1):t + 1].sum() >= m), -1)
            assert g == ref
    with pytest.raises(ValueError, match="`m`"):
        m_of_n(h, 4, 3)
    with pytest.raises(TypeError, match="`hits`"):
        m_of_n([1, 0], 1, 2)


@pytest.mark.parametrize(("dt", "q"), [(1e200, 1.0), (1.0, 1e300), (1e60, 1e-10)])
def test_prediction_beyond_the_numeric_domain_refused_by_name(dt, q):
    import warnings

    from radarfusion_ref import trackfusion
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(ValueError, match=r"`dt`, `q`.*numeric domain"):
            kalman_predict(np.zeros(4), np.eye(4), dt, q)
        with pytest.raises(ValueError, match=r"`dt`, `q`.*numeric domain"):
            trackfusion.constant_velocity(dt, q)


# --------------------------------------------------------------------------- IMM
def _kf_step(x, P, dt, q, z, R):
    """One plain Kalman step of a 1-D constant-velocity target (written out, with inv)."""
    F = np.array([[1.0, dt], [0.0, 1.0]])
    Q = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
    H = np.array([[1.0, 0.0]])
    xp, Pp = F @ x, F @ P @ F.T + Q
    S = H @ Pp @ H.T + R
    K = Pp @ H.T @ np.linalg.inv(S)
    nu = z - H @ xp
    lik = float(np.exp(-0.5 * nu @ np.linalg.inv(S) @ nu) / np.sqrt(2 * np.pi * np.linalg.det(S)))
    return xp, Pp, xp + K @ nu, (np.eye(2) - K @ H) @ Pp, lik


def _brute_force(mu0, xs, Ps, Pi, qs, dts, zs, R):
    """The exact posterior: one Kalman filter per mode sequence, weighted by Bayes' rule.

    Returns, per mode j of the last step, its probability and the moments of the mixture
    of the sequences ending in j, and the moments of the whole mixture; also the predicted
    (before the last report) mode probabilities and mode moments.
    """
    hyps = [(mu0[i], xs[i], Ps[i], i) for i in range(len(mu0))]
    M = len(mu0)
    for dt, z in zip(dts, zs, strict=True):
        new, pred = [], []
        for w, x, P, i in hyps:
            for j in range(M):
                xp, Pp, xu, Pu, lik = _kf_step(x, P, dt, qs[j], np.atleast_1d(z), R)
                pred.append((w * Pi[i][j], xp, Pp, j))
                new.append((w * Pi[i][j] * lik, xu, Pu, j))
        tot = sum(h[0] for h in new)
        hyps = [(w / tot, x, P, j) for w, x, P, j in new]

    def moments(hs):
        w = np.array([h[0] for h in hs])
        x = sum(h[0] * h[1] for h in hs) / w.sum()
        P = sum(h[0] * (h[2] + np.outer(h[1] - x, h[1] - x)) for h in hs) / w.sum()
        return w.sum(), x, P

    post = [moments([h for h in hyps if h[3] == j]) for j in range(M)]
    before = [moments([h for h in pred if h[3] == j]) for j in range(M)]
    return post, moments(hyps), before


def _imm_run(mu, xs, Ps, Pi, qs, dts, zs, R):
    mu, x, P = np.asarray(mu, float), np.asarray(xs, float), np.asarray(Ps, float)
    for dt, z in zip(dts, zs, strict=True):
        p = imm_predict(mu, x, P, Pi, dt, qs)
        u = imm_update(p.probability, p.state, p.covariance, [z], R)
        mu, x, P = u.probability, u.state, u.covariance
    return p, u, imm_combine(mu, x, P)


PI = [[0.9, 0.1], [0.25, 0.75]]


def test_imm_with_identical_modes_is_the_kalman_filter():
    rng = np.random.default_rng(11)
    dts, zs, R = rng.uniform(1, 5, 8), rng.normal(0, 300, 8) + np.arange(8) * 800.0, [[900.0]]
    x0, P0 = np.array([0.0, 150.0]), np.diag([900.0, 250.0**2])
    _, u, c = _imm_run([0.3, 0.7], [x0, x0], [P0, P0], PI, [40.0, 40.0], dts, zs, R)
    x, P = x0, P0
    for dt, z in zip(dts, zs, strict=True):
        _, _, x, P, _ = _kf_step(x, P, dt, 40.0, np.atleast_1d(z), np.asarray(R))
    np.testing.assert_allclose(c.state, x, rtol=1e-10)
    np.testing.assert_allclose(c.covariance, P, rtol=1e-9)
    # equal likelihoods leave the chain alone: the probabilities follow mu <- mu Pi
    mu = np.array([0.3, 0.7])
    for _ in dts:
        mu = mu @ np.asarray(PI)
    np.testing.assert_allclose(u.probability, mu, rtol=1e-12)


@pytest.mark.parametrize("z", [150.0, 700.0, 2500.0])
def test_imm_one_step_from_a_single_mode_prior_is_the_exact_posterior(z):
    x0, P0, R = np.array([0.0, 100.0]), np.diag([400.0, 900.0]), [[2500.0]]
    qs, mu0 = [1.0, 400.0], [0.6, 0.4]
    post, whole, _ = _brute_force(mu0, [x0, x0], [P0, P0], PI, qs, [4.0], [z], np.asarray(R))
    _, u, c = _imm_run(mu0, [x0, x0], [P0, P0], PI, qs, [4.0], [z], R)
    for j in range(2):
        assert u.probability[j] == pytest.approx(post[j][0], rel=1e-12)
        np.testing.assert_allclose(u.state[j], post[j][1], rtol=1e-12)
        np.testing.assert_allclose(u.covariance[j], post[j][2], rtol=1e-10)
    np.testing.assert_allclose(c.state, whole[1], rtol=1e-12)
    np.testing.assert_allclose(c.covariance, whole[2], rtol=1e-10)
    # the report is informative: the posterior differs from the predicted 0.6 0.1 + 0.4 0.25
    assert abs(post[1][0] - 0.16) > 0.05


def test_imm_prediction_is_exact_moments_from_any_prior():
    """From distinct mode estimates the predicted mode moments are still the exact moments
    of the predicted mixture (the approximation enters at the update)."""
    xs = [np.array([0.0, 100.0]), np.array([300.0, 60.0])]
    Ps = [np.diag([400.0, 900.0]), np.array([[2500.0, 300.0], [300.0, 1600.0]])]
    qs, mu0, R = [2.0, 300.0], [0.7, 0.3], np.array([[900.0]])
    _, _, before = _brute_force(mu0, xs, Ps, PI, qs, [3.0], [500.0], R)
    p = imm_predict(mu0, xs, Ps, PI, 3.0, qs)
    m = imm_mixing(mu0, PI)
    for j in range(2):
        assert p.probability[j] == pytest.approx(before[j][0], rel=1e-12)
        assert m.predicted[j] == pytest.approx(before[j][0], rel=1e-12)
        np.testing.assert_allclose(p.state[j], before[j][1], rtol=1e-12)
        np.testing.assert_allclose(p.covariance[j], before[j][2], rtol=1e-10)
    np.testing.assert_allclose(m.mixing.sum(0), 1.0, rtol=1e-14)
    # the update is where the IMM approximates: its probabilities differ from the exact ones
    post, _, _ = _brute_force(mu0, xs, Ps, PI, qs, [3.0], [500.0], R)
    u = imm_update(p.probability, p.state, p.covariance, [500.0], R)
    assert abs(u.probability[0] - post[0][0]) > 1e-6


def test_imm_over_several_steps_stays_near_the_exact_posterior():
    rng = np.random.default_rng(5)
    n = 7                                               # 2**8 sequences
    t = np.cumsum(rng.uniform(2, 4, n))
    acc = np.where(t > t[3], 15.0, 0.0)                 # a manoeuvre after the fourth report
    zs = 200.0 * t + 0.5 * acc * (t - t[3]) ** 2 + rng.normal(0, 30, n)
    dts = np.diff(np.r_[0.0, t])
    x0, P0, R, qs = np.array([0.0, 200.0]), np.diag([900.0, 400.0]), [[900.0]], [1.0, 500.0]
    post, whole, _ = _brute_force([0.9, 0.1], [x0, x0], [P0, P0], PI, qs, dts, zs,
                                  np.asarray(R))
    _, u, c = _imm_run([0.9, 0.1], [x0, x0], [P0, P0], PI, qs, dts, zs, R)
    assert post[1][0] > 0.7                              # the exact filter saw the manoeuvre
    # an approximation: here the IMM says 0.96 where the exact posterior says 0.85, but its
    # estimate is within 0.04 standard deviations of the exact posterior mean
    assert u.probability[1] > 0.7 and abs(u.probability[1] - post[1][0]) < 0.15
    sd = np.sqrt(np.diag(whole[2]))
    assert np.all(np.abs(c.state - whole[1]) < 0.1 * sd)


def test_imm_equals_filterpy():
    fk = pytest.importorskip("filterpy.kalman")
    rng = np.random.default_rng(2)
    qs, R, Pi = [2.0, 300.0], 900.0, np.array(PI)
    dt = 3.0
    filters = []
    for q in qs:
        kf = fk.KalmanFilter(dim_x=2, dim_z=1)
        kf.x = np.array([[0.0], [150.0]])
        kf.P = np.diag([900.0, 2500.0])
        kf.F = np.array([[1.0, dt], [0.0, 1.0]])
        kf.Q = q * np.array([[dt**3 / 3, dt**2 / 2], [dt**2 / 2, dt]])
        kf.H = np.array([[1.0, 0.0]])
        kf.R = np.array([[R]])
        filters.append(kf)
    imm = fk.IMMEstimator(filters, np.array([0.8, 0.2]), Pi)
    mu = np.array([0.8, 0.2])
    x = np.array([[0.0, 150.0]] * 2)
    P = np.array([np.diag([900.0, 2500.0])] * 2)
    for k in range(12):
        z = 150.0 * dt * (k + 1) + 4.0 * max(k - 6, 0) ** 2 * dt**2 + rng.normal(0, 30)
        imm.predict()
        imm.update(np.array([[z]]))
        p = imm_predict(mu, x, P, Pi, dt, qs)
        u = imm_update(p.probability, p.state, p.covariance, [z], [[R]])
        mu, x, P = u.probability, u.state, u.covariance
        c = imm_combine(mu, x, P)
        np.testing.assert_allclose(mu, imm.mu, rtol=1e-9)
        np.testing.assert_allclose(c.state, imm.x_post.ravel(), rtol=1e-9)
        np.testing.assert_allclose(c.covariance, imm.P_post, rtol=1e-8)
        for j in range(2):
            np.testing.assert_allclose(x[j], filters[j].x.ravel(), rtol=1e-9)
    assert mu[1] > 0.5                                   # the turn-on of acceleration is seen


def test_imm_vectorised_over_tracks_equals_one_at_a_time():
    rng = np.random.default_rng(8)
    T, M = 5, 3
    mu = rng.dirichlet(np.ones(M), T)
    x = rng.normal(0, 100, (T, M, 4))
    P = np.array([[_random_cov(rng, 4, 100.0) for _ in range(M)] for _ in range(T)])
    Pi = rng.dirichlet(np.ones(M), (T, M))
    dt, q = rng.uniform(0, 5, T), rng.uniform(0, 50, M)
    z, R = rng.normal(0, 100, (T, 2)), np.array([_random_cov(rng, 2, 100.0) for _ in range(T)])
    p = imm_predict(mu, x, P, Pi, dt, q)
    u = imm_update(p.probability, p.state, p.covariance, z, R)
    for i in range(T):
        pi = imm_predict(mu[i], x[i], P[i], Pi[i], dt[i], q)
        ui = imm_update(pi.probability, pi.state, pi.covariance, z[i], R[i])
        np.testing.assert_allclose(u.probability[i], ui.probability, rtol=1e-12)
        np.testing.assert_allclose(u.state[i], ui.state, rtol=1e-12, atol=1e-9)
        np.testing.assert_allclose(u.log_likelihood[i], ui.log_likelihood, rtol=1e-12)
    np.testing.assert_allclose(u.probability.sum(-1), 1.0, rtol=1e-14)


@pytest.mark.parametrize(("kw", "match"), [
    ({"transition": [[0.9, 0.2], [0.1, 0.9]]}, "`transition`"),
    ({"transition": [[1.1, -0.1], [0.1, 0.9]]}, "`transition`"),
    ({"transition": np.eye(3)}, "`transition`"),
    ({"probability": [1.5, -0.5]}, "`probability`"),
    ({"probability": [0.5, 0.6]}, "`probability`"),
    ({"q": [1.0, -2.0]}, "`q`"),
    ({"q": [1.0, 2.0, 3.0]}, "`q`"),
    ({"dt": [1.0, 2.0, 3.0], "transition": np.array([PI, PI])}, "`transition`"),
    ({"dt": -1.0}, "`dt`"),
    ({"x": np.zeros((3, 2))}, "`x`"),
    ({"cov": np.eye(2)}, "`cov`"),
])
def test_imm_bad_input_refused_by_name(kw, match):
    args = {"probability": [0.5, 0.5], "x": np.zeros((2, 2)), "cov": np.array([np.eye(2)] * 2),
            "transition": PI, "dt": 1.0, "q": [1.0, 10.0]}
    args.update(kw)
    with pytest.raises(ValueError, match=match):
        imm_predict(**args)


def test_imm_update_and_combine_refuse_by_name():
    x, P = np.zeros((2, 2)), np.array([np.eye(2)] * 2)
    with pytest.raises(ValueError, match="`probability`"):
        imm_update([0.7, 0.7], x, P, [1.0], [[1.0]])
    with pytest.raises(ValueError, match="`z_cov`"):
        imm_update([0.5, 0.5], x, P, [1.0], [[-1.0]])
    with pytest.raises(ValueError, match="`z`"):
        imm_update([0.5, 0.5], x, P, [1.0, 2.0], [[1.0]])
    with pytest.raises(ValueError, match="`probability`"):
        imm_combine([2.0, -1.0], x, P)
    with pytest.raises(ValueError, match="`transition`"):
        imm_mixing([0.5, 0.5], [[0.5, 0.4], [0.5, 0.5]])
