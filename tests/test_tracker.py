"""The engine's tracking formulas against independent routes.

Kalman filter: Stone Soup's constant-velocity transition model (an independent
implementation) and the information form of the update; JPDA: brute-force sums over
every joint event listed by itertools; the score: Wald's inequality by simulation;
M-of-N: a plain loop.
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
    with pytest.raises(ValueError, match=r"`alpha`|`beta`"):
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
