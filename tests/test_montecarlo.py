"""Monte-Carlo helpers against scipy's independent implementations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from radarfusion_ref.engine.montecarlo import binomial_tolerance, mean, proportion


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 5000), frac=st.floats(0, 1), conf=st.sampled_from([0.8, 0.9, 0.95, 0.99]))
def test_wilson_matches_scipy(n, frac, conf):
    k = round(frac * n)
    ours = proportion(k, n, confidence=conf)
    ref = stats.binomtest(k, n).proportion_ci(confidence_level=conf, method="wilson")
    np.testing.assert_allclose([ours.low, ours.high], [ref.low, ref.high], atol=1e-10)
    assert ours.low <= ours.estimate <= ours.high


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 5000), frac=st.floats(0, 1))
def test_clopper_pearson_matches_scipy(n, frac):
    k = round(frac * n)
    ours = proportion(k, n, method="clopper-pearson")
    ref = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
    np.testing.assert_allclose([ours.low, ours.high], [ref.low, ref.high], atol=1e-10)


def test_vectorised_counts_equal_loop():
    k = np.array([0, 3, 50, 100])
    vec = proportion(k, 100)
    for i, ki in enumerate(k):
        one = proportion(int(ki), 100)
        assert vec.low[i] == pytest.approx(one.low) and vec.high[i] == pytest.approx(one.high)


def test_boolean_trials_on_last_axis():
    hits = np.array([[True, False, True, True], [False, False, False, True]])
    p = proportion(hits, None)
    np.testing.assert_allclose(p.estimate, [0.75, 0.25])
    assert p.trials == 4


def test_wilson_coverage_is_close_to_nominal():
    """Coverage of the 95 % interval over 4000 replications, p = 0.3, n = 200."""
    rng = np.random.default_rng(5)
    reps, n, p = 4000, 200, 0.3
    k = rng.binomial(n, p, size=reps)
    covered = proportion(k, n).contains(p)
    cover = covered.mean()
    tol = binomial_tolerance(0.95, reps)
    assert abs(cover - 0.95) < tol + 0.01


def test_mean_interval_matches_t_distribution():
    x = np.array([1.0, 2.0, 4.0, 7.0, 11.0])
    m = mean(x)
    lo, hi = stats.t.interval(0.95, df=4, loc=x.mean(), scale=stats.sem(x))
    assert (m.low, m.high) == pytest.approx((lo, hi))


def test_mean_along_axis():
    x = np.arange(12.0).reshape(3, 4)
    np.testing.assert_allclose(mean(x, axis=1).estimate, x.mean(axis=1))
    np.testing.assert_allclose(mean(x, axis=0).estimate, x.mean(axis=0))


@pytest.mark.parametrize(
    ("args", "kwargs", "match"),
    [
        ((5, 4), {}, "`successes`"),
        ((-1, 4), {}, "`successes`"),
        ((1.5, 4), {}, "`successes`"),
        ((1, 0), {}, "`trials`"),
        ((1, 4), {"confidence": 1.0}, "`confidence`"),
        ((1, 4), {"confidence": [0.9, 0.95]}, "`confidence` must be a single number"),
        ((1, 4), {"method": "exact"}, "`method`"),
        ((np.array([1, 2]), None), {}, "`successes`"),
    ],
)
def test_bad_input(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        proportion(*args, **kwargs)


def test_mean_confidence_is_one_number():
    with pytest.raises(ValueError, match="`confidence` must be a single number"):
        mean([1.0, 2.0, 3.0], confidence=[0.9, 0.95])


def test_mean_needs_two_samples():
    with pytest.raises(ValueError, match="`samples`"):
        mean([1.0])
    with pytest.raises(ValueError, match="`samples`"):
        mean([1.0, np.nan])


def test_agrees_uses_the_standard_error_of_the_exact_value():
    p = proportion(5_300, 10_000)                # 0.53
    # binomial standard error at 0.5 with n = 10 000 is 0.005: 0.03 is 6 of them
    assert not p.agrees(0.5)
    assert p.agrees(0.5, sigmas=7.0)
    assert proportion(0, 100).agrees(0.0)
    assert not proportion(1, 100).agrees(0.0)


def test_mean_agrees_and_require():
    m = mean(np.array([1.0, 2.0, 3.0, 4.0]))    # 2.5, standard error 0.6455
    assert m.agrees(2.5 + 3 * 0.6455)
    assert not m.agrees(2.5 + 6 * 0.6455)
    from radarfusion_ref.kit.checks import MonteCarloCheckError, require

    require(m, 2.0, "close")
    with pytest.raises(MonteCarloCheckError, match="far: Monte Carlo"):
        require(m, 10.0, "far")
    with pytest.raises(TypeError, match="`estimate`"):
        require(0.5, 0.5, "not an estimate")


def test_format_for_prose():
    p = proportion(np.array([627, 100]), 1000)
    assert p.format(0) == f"0.627 [{p.low[0]:.3f}, {p.high[0]:.3f}]"
    assert proportion(1, 4).format(digits=2).startswith("0.25 [")


# ---------------------------------------------------------------------------
# sweep: a grid of experiments in seed units, here or on a Dask cluster
# ---------------------------------------------------------------------------

from radarfusion_ref import gating  # noqa: E402
from radarfusion_ref.engine import montecarlo  # noqa: E402
from radarfusion_ref.engine.montecarlo import (  # noqa: E402
    SEED_BLOCK,
    SweepError,
    SweepResult,
    sweep,
)
from radarfusion_ref.kit import checks  # noqa: E402
from radarfusion_ref.kit.checks import require  # noqa: E402

# Chapter 3's false-pair experiment: two radars report two different objects whose
# separation has noncentrality lambda in S = Sigma_1 + Sigma_2; the 2-D gate accepts
# the pair with probability P_fa(lambda; P_lo) (1 - P_lo at lambda = 0).
SIG1 = np.array([[1.0, 0.3], [0.3, 0.5]])
SIG2 = np.array([[0.6, -0.1], [-0.1, 0.8]])
S_PAIR = SIG1 + SIG2
L1, L2, L_PAIR = (np.linalg.cholesky(c) for c in (SIG1, SIG2, S_PAIR))
GRID = {"p_lo": [0.01, 0.05], "lam": [0.0, 4.0, 9.0, 16.0]}


def false_pairs(params, n, rng):
    """Gate decisions and kappa for n simulated pairs of reports (vectorized)."""
    offset = L_PAIR @ [np.sqrt(params["lam"]), 0.0]
    x1 = rng.standard_normal((n, 2)) @ L1.T
    x2 = offset + rng.standard_normal((n, 2)) @ L2.T
    acc, kappa = gating.gate_mahalanobis(x1, x2, S_PAIR, p_false_reject=params["p_lo"],
                                            return_statistic=True)
    return {"accepted": acc, "kappa": kappa}


def coin(params, n, rng):
    return rng.random(n) < params["p"]


def fails_at_lam_9(params, n, rng):
    if params["lam"] == 9.0 and params["p_lo"] == 0.01:           # grid point 2 only
        raise ZeroDivisionError("boom")
    return false_pairs(params, n, rng)


def _cluster(**kwargs):
    """A LocalCluster with no dashboard; its HTTP server (health checks) on a free port, so
    a second cluster or another process on port 8787 does not make it warn."""
    distributed = pytest.importorskip("distributed")
    return distributed.LocalCluster(dashboard_address=None,
                                    scheduler_kwargs={"dashboard_address": ":0"}, **kwargs)


@pytest.fixture(scope="module")
def local_sweep():
    return sweep(false_pairs, GRID, trials=3 * SEED_BLOCK + 100, rng=2026, block=2 * SEED_BLOCK)


@pytest.fixture(scope="module")
def dask_client():
    """One LocalCluster of two worker processes for the whole module."""
    distributed = pytest.importorskip("distributed")
    cluster = _cluster(n_workers=2, threads_per_worker=1, processes=True)
    client = distributed.Client(cluster)
    yield client
    client.close()
    cluster.close()


def test_sweep_shapes_and_accessors(local_sweep):
    res = local_sweep
    trials = 3 * SEED_BLOCK + 100
    assert isinstance(res, SweepResult) and res.backend == "local"
    assert res["accepted"].shape == (8, trials) and res["accepted"].dtype == bool
    assert res["kappa"].shape == (8, trials) and res["kappa"].dtype == np.float64
    assert res.on_grid("kappa").shape == (2, 4, trials)
    np.testing.assert_array_equal(res.param("lam"), [0.0, 4.0, 9.0, 16.0] * 2)
    assert res.points[5] == {"p_lo": 0.05, "lam": 4.0}
    assert res.tasks == 8 * 2                      # 4 seed units -> 2 blocks per point
    assert not res["kappa"].flags.writeable
    np.testing.assert_array_equal(res.map(np.mean, "accepted"), res["accepted"].mean(axis=1))
    with pytest.raises(ValueError, match="`name`"):
        _ = res.value
    with pytest.raises(KeyError, match="'accepted', 'kappa'"):
        res["nope"]


def test_sweep_follows_the_documented_seeding(local_sweep):
    """Unit j of point i is the experiment on SeedSequence(seed).spawn(P)[i].spawn(U)[j]."""
    trials, units = 3 * SEED_BLOCK + 100, 4
    children = np.random.SeedSequence(2026).spawn(8)
    for i in (0, 6):
        grand = children[i].spawn(units)
        direct = [false_pairs(local_sweep.points[i], min(SEED_BLOCK, trials - j * SEED_BLOCK),
                              np.random.Generator(np.random.PCG64(grand[j])))["kappa"]
                  for j in range(units)]
        np.testing.assert_array_equal(np.concatenate(direct), local_sweep["kappa"][i])


def test_unit_rng_is_the_spawned_sequence():
    """unit_rng(root, i, j) draws what root.spawn(P)[i].spawn(U)[j] draws, also for a child root."""
    for root_of in (lambda: np.random.SeedSequence(2026),
                    lambda: np.random.SeedSequence(11).spawn(3)[2]):
        grand = root_of().spawn(5)[4].spawn(3)[1]
        direct = np.random.Generator(np.random.PCG64(grand)).integers(0, 2**63, 8)
        root = root_of()
        np.testing.assert_array_equal(montecarlo.unit_rng(root, 4, 1).integers(0, 2**63, 8),
                                      direct)
        assert root.n_children_spawned == 0                          # the root is not advanced
    with pytest.raises(TypeError, match=r"`root`.*received 7"):
        montecarlo.unit_rng(7, 0, 0)
    with pytest.raises(ValueError, match="`unit`"):
        montecarlo.unit_rng(np.random.SeedSequence(7), 0, -1)
    with pytest.raises(TypeError, match="`point`"):
        montecarlo.unit_rng(np.random.SeedSequence(7), 0.5, 0)


def test_sweep_does_not_depend_on_block_or_task_order(local_sweep, monkeypatch):
    for block in (SEED_BLOCK, 4 * SEED_BLOCK, 64 * SEED_BLOCK):
        other = sweep(false_pairs, GRID, trials=3 * SEED_BLOCK + 100, rng=2026, block=block)
        assert local_sweep.identical(other), block
    shuffled = np.random.default_rng(3).permutation
    monkeypatch.setattr(montecarlo, "_schedule", lambda tasks: [tasks[k] for k in
                                                               shuffled(len(tasks))])
    other = sweep(false_pairs, GRID, trials=3 * SEED_BLOCK + 100, rng=2026, block=SEED_BLOCK)
    assert local_sweep.identical(other)
    assert not local_sweep.identical(sweep(false_pairs, GRID, trials=3 * SEED_BLOCK + 100,
                                           rng=2027))


def test_sweep_seed_forms():
    grid = {"p": [0.3, 0.6]}
    a = sweep(coin, grid, trials=2000, rng=11)
    assert a.identical(sweep(coin, grid, trials=2000, rng=np.random.SeedSequence(11)))
    ss = np.random.SeedSequence(11)
    assert a.identical(sweep(coin, grid, trials=2000, rng=ss))      # a SeedSequence is not advanced
    g1, g2 = np.random.default_rng(5), np.random.default_rng(5)
    b = sweep(coin, grid, trials=2000, rng=g1)
    assert b.identical(sweep(coin, grid, trials=2000, rng=g2))
    assert not b.identical(sweep(coin, grid, trials=2000, rng=g1))  # the Generator moved on
    fresh = sweep(coin, grid, trials=2000, rng=None)
    again = sweep(coin, grid, trials=2000,
                  rng=np.random.SeedSequence(fresh.entropy, spawn_key=fresh.spawn_key))
    assert fresh.identical(again)
    child = np.random.SeedSequence(11).spawn(2)[1]
    c = sweep(coin, grid, trials=2000, rng=child)
    assert c.spawn_key == (1,) and not c.identical(a)


def test_sweep_agrees_with_the_closed_form(local_sweep):
    """Accepted fraction = P_fa(lambda; P_lo) (1 - P_lo at lambda = 0), within 5 sigma."""
    acc = local_sweep.on_grid("accepted")                       # (2, 4, trials)
    lam = np.array(GRID["lam"])
    p_lo = np.array(GRID["p_lo"])[:, None]
    exact = np.where(lam == 0, 1 - p_lo, gating.p_false_accept(lam, 2, p_lo))
    require(proportion(acc, None), exact, "sweep: false pairs pass the 2-D gate at P_fa")
    # and a wrong closed form (P_lo swapped between rows) is caught
    with pytest.raises(checks.MonteCarloCheckError):
        require(proportion(acc, None), exact[::-1], "rows swapped")


def test_sweep_on_a_cluster_is_bit_identical(local_sweep, dask_client):
    remote = sweep(false_pairs, GRID, trials=3 * SEED_BLOCK + 100, rng=2026,
                   block=SEED_BLOCK, client=dask_client)
    assert remote.backend == "dask (2 workers)"
    for name in ("accepted", "kappa"):
        assert remote[name].dtype == local_sweep[name].dtype
        assert np.array_equal(remote[name], local_sweep[name])
    assert local_sweep.identical(remote)


def test_sweep_does_not_depend_on_the_worker_count(local_sweep):
    distributed = pytest.importorskip("distributed")
    with _cluster(n_workers=1, threads_per_worker=1, processes=False) as cluster, \
            distributed.Client(cluster) as client:
        one = sweep(false_pairs, GRID, trials=3 * SEED_BLOCK + 100, rng=2026,
                    block=4 * SEED_BLOCK, client=client)
    assert one.backend == "dask (1 workers)"
    assert local_sweep.identical(one)


def test_sweep_failure_names_the_point_and_block(dask_client):
    for client in (None, dask_client):
        with pytest.raises(SweepError, match=r"grid point 2 \{'p_lo': 0.01, 'lam': 9.0\}, "
                                             r"block 0 \(trials 0..1023\): ZeroDivisionError"):
            sweep(fails_at_lam_9, GRID, trials=SEED_BLOCK, rng=1, block=SEED_BLOCK,
                  client=client)                               # one failing task in all


    def fails_on_short_units(params, n, rng):
        if n < SEED_BLOCK:
            raise ValueError("short")
        return rng.random(n)

    with pytest.raises(SweepError, match=r"grid point 0 \{'p': 0.5\}, block 1 "
                                         r"\(trials 1024..1999\): ValueError: short"):
        sweep(fails_on_short_units, {"p": [0.5]}, trials=2000, rng=1, block=SEED_BLOCK)


def test_sweep_refuses_bad_experiment_output():
    cases = [
        (lambda p, n, rng: rng.random(n - 1), "first axis"),
        (lambda p, n, rng: float(n), "must return an array"),
        (lambda p, n, rng: np.full(n, np.nan), "NaN or inf"),
        (lambda p, n, rng: np.array(["a"] * n), "numeric or bool"),
        (lambda p, n, rng: {}, "empty dict"),
        (lambda p, n, rng: rng.random(n) if p["p"] < 0.5 else rng.random(n) < 0.5,
         "float64"),
    ]
    for experiment, match in cases:
        with pytest.raises(SweepError, match=rf"grid point \d.*{match}"):
            sweep(experiment, {"p": [0.3, 0.6]}, trials=100, rng=1)


def test_sweep_refuses_results_above_the_memory_limit(monkeypatch):
    calls = []

    def big(params, n, rng):
        calls.append(n)
        return np.zeros((n, 4))                                    # 32 bytes per trial

    monkeypatch.setattr(montecarlo, "MEMORY_LIMIT", 32 * 4 * SEED_BLOCK - 1)
    with pytest.raises(ValueError, match=r"refused: 131072 bytes.*reduction inside `experiment`"):
        sweep(big, {"p": [1, 2]}, trials=2 * SEED_BLOCK, rng=1, block=SEED_BLOCK)
    assert calls == [SEED_BLOCK]                                   # only the first task ran


def test_sweep_refuses_a_trial_count_beyond_memory_before_building_tasks():
    """10**12 trials once built a task list of 6e7 entries and died of MemoryError."""
    import time
    calls = []

    def coin(params, n, rng):
        calls.append(n)
        return rng.random(n) < 0.5

    start = time.perf_counter()
    with pytest.raises(ValueError, match=r"`trials`.*refused: 2000000000000 .*limit of "
                                         r"1073741824.*separate sweeps"):
        sweep(coin, {"p": [0.25, 0.5]}, trials=10**12, rng=1)
    assert time.perf_counter() - start < 1.0 and calls == []


def test_sweep_refuses_a_closed_or_foreign_client():
    distributed = pytest.importorskip("distributed")
    with _cluster(n_workers=1, processes=False) as cluster:
        client = distributed.Client(cluster)
        client.close()
    with pytest.raises(ValueError, match=r"`client` must be a running.*'closed'"):
        sweep(coin, {"p": [0.5]}, trials=10, rng=1, client=client)
    with pytest.raises(TypeError, match="`client` must be None"):
        sweep(coin, {"p": [0.5]}, trials=10, rng=1, client="tcp://127.0.0.1:8786")


@pytest.mark.parametrize(
    ("grid", "error", "match"),
    [
        ({"p": [0.5, np.nan]}, ValueError, "must be finite"),
        ({"p": [0.5, np.inf]}, ValueError, "must be finite"),
        ({"p": []}, ValueError, "is empty"),
        ({"p": np.zeros((2, 2))}, ValueError, "must be 1-D"),
        ({"p": [[0.1, 0.2]]}, ValueError, "must be 1-D"),
        ({}, ValueError, "at least one axis"),
        ([], ValueError, "at least one point"),
        ({"p": 0.5}, TypeError, "1-D sequence"),
        ({"p": "abc"}, TypeError, "1-D sequence"),
        ({"p": [None]}, TypeError, "number, a bool or a string"),
        ({"p": [1 + 2j]}, TypeError, "number, a bool or a string"),
        ({1: [0.5]}, TypeError, "parameter names"),
        ([{"p": 0.5}, {"q": 0.5}], ValueError, "same names"),
        ([{"p": 0.5}, 3], TypeError, "point 1"),
        ([{"p": float("nan")}], ValueError, "must be finite"),
        ("p=0.5", TypeError, "mapping"),
        (None, TypeError, "mapping"),
        ({"a": range(1000), "b": range(1000)}, ValueError, "grid points"),
    ],
)
def test_sweep_bad_grid(grid, error, match):
    with pytest.raises(error, match=r"`grid`|grid points") as info:
        sweep(coin, grid, trials=10, rng=1)
    assert info.type is error
    assert match in str(info.value)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"trials": 0}, ValueError, "`trials`"),
        ({"trials": -5}, ValueError, "`trials`"),
        ({"trials": 10.0}, TypeError, "`trials`"),
        ({"block": 0}, ValueError, "`block`"),
        ({"block": 1000}, ValueError, "`block` must be a positive multiple of SEED_BLOCK"),
        ({"block": 2048.0}, TypeError, "`block`"),
        ({"rng": "seed"}, TypeError, "`rng`"),
        ({"rng": -1}, TypeError, "`rng`"),
        ({"rng": np.random.RandomState(1)}, TypeError, "`rng`"),
        ({"progress": "yes"}, TypeError, "`progress`"),
    ],
)
def test_sweep_bad_arguments(kwargs, error, match):
    args = {"trials": 10, "rng": 1} | kwargs
    with pytest.raises(error, match=match):
        sweep(coin, {"p": [0.5]}, **args)
    with pytest.raises(TypeError, match="`experiment`"):
        sweep("coin", {"p": [0.5]}, trials=10, rng=1)


def test_sweep_progress_bar_only_when_asked(capsys, monkeypatch):
    pytest.importorskip("tqdm")                              # the `progress` extra
    monkeypatch.delenv(montecarlo.PROGRESS_ENV, raising=False)
    monkeypatch.delenv("JPY_SESSION_NAME", raising=False)
    sweep(coin, {"p": [0.5]}, trials=2048, rng=1, block=SEED_BLOCK)
    assert capsys.readouterr().err == ""                     # default: no bar in a test/build
    sweep(coin, {"p": [0.5]}, trials=2048, rng=1, block=SEED_BLOCK, progress=True)
    assert "2/2" in capsys.readouterr().err
    monkeypatch.setenv(montecarlo.PROGRESS_ENV, "1")
    sweep(coin, {"p": [0.5]}, trials=2048, rng=1, block=SEED_BLOCK)
    assert "2/2" in capsys.readouterr().err
    monkeypatch.setenv(montecarlo.PROGRESS_ENV, "0")
    monkeypatch.setenv("JPY_SESSION_NAME", "nb.ipynb")       # not a kernel: still off
    sweep(coin, {"p": [0.5]}, trials=2048, rng=1, block=SEED_BLOCK)
    assert capsys.readouterr().err == ""
    assert montecarlo._want_progress(None) is False
    monkeypatch.delenv(montecarlo.PROGRESS_ENV)
    assert montecarlo._want_progress(None) is False           # JPY_SESSION_NAME but no kernel


def test_sweep_progress_default_is_on_in_a_live_notebook_kernel(monkeypatch):
    """JPY_SESSION_NAME (set by a Jupyter server for a notebook's kernel) and an IPython
    kernel shell: the default shows the bar; either one alone does not."""
    import sys
    import types

    class ZMQInteractiveShell:                 # the class name ipykernel's shell has
        pass

    pytest.importorskip("tqdm")                              # the `progress` extra
    fake = types.SimpleNamespace(get_ipython=lambda: ZMQInteractiveShell())
    monkeypatch.delenv(montecarlo.PROGRESS_ENV, raising=False)
    monkeypatch.setitem(sys.modules, "IPython", fake)
    monkeypatch.delenv("JPY_SESSION_NAME", raising=False)
    assert montecarlo._want_progress(None) is False           # nbclient / a book build
    monkeypatch.setenv("JPY_SESSION_NAME", "/home/reader/montecarlo.ipynb")
    assert montecarlo._want_progress(None) is True             # a live notebook
    monkeypatch.setenv(montecarlo.PROGRESS_ENV, "0")
    assert montecarlo._want_progress(None) is False            # forced off
    assert montecarlo._want_progress(True) is True


def test_sweep_without_tqdm_the_default_runs_and_asking_names_the_extra(capsys, monkeypatch):
    """tqdm not installed (the `progress` extra left out): in a live notebook kernel the
    default runs the sweep without a bar; progress=True, or the variable at "1", refuses
    with an ImportError naming the extra, before any task runs."""
    import sys
    import types

    class ZMQInteractiveShell:
        pass

    calls = []

    def counted(params, n, rng):
        calls.append(n)
        return coin(params, n, rng)

    monkeypatch.setitem(sys.modules, "IPython",
                        types.SimpleNamespace(get_ipython=lambda: ZMQInteractiveShell()))
    monkeypatch.setenv("JPY_SESSION_NAME", "/home/reader/montecarlo.ipynb")
    monkeypatch.delenv(montecarlo.PROGRESS_ENV, raising=False)
    for name in [m for m in sys.modules if m == "tqdm" or m.startswith("tqdm.")]:
        monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "tqdm", None)            # import tqdm now fails
    res = sweep(counted, {"p": [0.5]}, trials=2048, rng=1, block=SEED_BLOCK)
    assert capsys.readouterr().err == ""
    assert res.value.shape == (1, 2048) and len(calls) == 2 and res.tasks == 2
    expected = r"sweep's progress bar needs tqdm.*pip install 'radarfusion-ref\[progress\]'"
    for env in (None, "1"):
        if env is not None:
            monkeypatch.setenv(montecarlo.PROGRESS_ENV, env)
        calls.clear()
        with pytest.raises(ImportError, match=expected):
            sweep(counted, {"p": [0.5]}, trials=2048, rng=1, block=SEED_BLOCK,
                  progress=True if env is None else None)
        assert calls == []


def test_sweep_client_without_dask_names_the_extra(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(ImportError,
                       match=r"sweep\(client=\.\.\.\) needs distributed.*radarfusion-ref\[dask\]"):
        sweep(coin, {"p": [0.5]}, trials=10, rng=1, client=object())
