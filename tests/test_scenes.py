"""The scene simulators of :mod:`radarfusion_ref.engine.scenes`.

Three kinds of test:

* bit identity — every simulator that moved into ``scenes`` draws exactly what
  its old home drew for the same seed (``tests/data/scenes_golden.npz``,
  written by the old code paths at commit 70ba20b2647d809bac0521b59af6e38e34b95b49:
  ``scenes.two_radar_scene``, ``association.two_radar_clutter_scene``,
  ``features.typed_scene``, ``grouping.grouping_scene``,
  ``separated.simulate_polar``; never regenerate it from this module);
* statistics — noise covariances, detection probabilities, false-report counts
  and positions, type frequencies, against their exact values by Monte Carlo
  with confidence intervals (``checks.require``, 5 standard errors);
* the conventions — one argument order, one vocabulary, trial axis first,
  bad input refused by name.
"""

from __future__ import annotations

import inspect
import itertools
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from radarfusion_ref import association, features, grouping, separated
from radarfusion_ref.engine import geometry, scenes
from radarfusion_ref.engine.montecarlo import binomial_tolerance, mean, proportion
from radarfusion_ref.engine.scenes import nearest_neighbour_pairing, two_radar_scene
from radarfusion_ref.engine.validation import MEMORY_LIMIT
from radarfusion_ref.kit.checks import MonteCarloCheckError, require


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


@settings(max_examples=40, deadline=None)
@given(n1=st.integers(1, 30), n2=st.integers(1, 30), d=st.integers(1, 3),
       seed=st.integers(0, 99), batch=st.integers(0, 2))
def test_nearest_neighbour_kd_route_equals_brute_force_with_ties(n1, n2, d, seed, batch):
    """The k-d tree route gives the dense route's answer, ties to the lowest index.

    Points on a small integer grid make exact ties (and duplicates) common.
    """
    from radarfusion_ref.engine.scenes import _helpers
    g = np.random.default_rng(seed)
    lead = (2,) * batch
    r1 = g.integers(-2, 3, size=(*lead, n1, d)).astype(float)
    r2 = g.integers(-2, 3, size=(*lead, n2, d)).astype(float)
    flat1, flat2 = r1.reshape(-1, n1, d), r2.reshape(-1, n2, d)
    brute = np.array([[min(range(n2), key=lambda j: (np.sum((a - b[j]) ** 2), j)) for a in A]
                      for A, b in zip(flat1, flat2, strict=True)]).reshape(*lead, n1)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(_helpers, "_DENSE_ELEMENTS", 0)                # force the k-d tree
        np.testing.assert_array_equal(nearest_neighbour_pairing(r1, r2), brute)
    np.testing.assert_array_equal(nearest_neighbour_pairing(r1, r2), brute)


def test_nearest_neighbour_memory_stays_bounded_on_large_inputs():
    """3000 x 3000 points in 2-D: the dense route held 144 MB of differences."""
    import tracemalloc
    g = np.random.default_rng(5)
    r1, r2 = g.normal(size=(3000, 2)), g.normal(size=(3000, 2))
    tracemalloc.start()
    got = nearest_neighbour_pairing(r1, r2)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 32 * 2**20, peak
    brute = np.concatenate([np.argmin(np.sum((r1[i:i + 300, None] - r2[None]) ** 2, -1), -1)
                            for i in range(0, 3000, 300)])
    np.testing.assert_array_equal(got, brute)


def test_nearest_neighbour_dimension_mismatch():
    with pytest.raises(ValueError, match="same last dimension"):
        nearest_neighbour_pairing(np.zeros((2, 2)), np.zeros((2, 3)))


@settings(max_examples=30, deadline=None)
@given(angle=st.floats(-4, 4), a=st.floats(0.1, 5), b=st.floats(0.1, 5))
def test_ellipse_covariance_has_the_stated_axes(angle, a, b):
    from radarfusion_ref.engine.scenes import ellipse_covariance

    cov = ellipse_covariance(angle, a, b)
    u = np.array([np.cos(angle), np.sin(angle)])          # the major-axis direction
    v = np.array([-np.sin(angle), np.cos(angle)])
    assert u @ cov @ u == pytest.approx(a * a) and v @ cov @ v == pytest.approx(b * b)
    assert u @ cov @ v == pytest.approx(0.0, abs=1e-9 * (a * a + b * b))


# ================================================================ bit identity with the old homes
GOLDEN = np.load(Path(__file__).parent / "data" / "scenes_golden.npz")
COV3 = np.array([np.diag([0.1, 0.2]), [[0.3, 0.1], [0.1, 0.2]], np.diag([0.05, 0.4])])[:, None]
#: The cases of the golden file: (key, simulator name, positional counts, keywords).
GOLDEN_CASES = [
    ("two_line", "two_radar_scene", (4,),
     dict(spacing=1.0, sigma1=0.1, sigma2=0.3, trials=5, rng=11)),
    ("two_uniform2d", "two_radar_scene", (5,),
     dict(spacing=2.0, sigma1=0.2, sigma2=0.4, trials=4, dim=2, layout="uniform", rng=12)),
    ("clutter_line", "two_radar_clutter_scene", (5,),
     dict(spacing=1.0, sigma1=0.1, sigma2=0.2, p_detect1=0.8, p_detect2=0.6,
          false_density1=0.5, false_density2=1.2, trials=6, rng=21)),
    ("clutter_uniform2d", "two_radar_clutter_scene", (4,),
     dict(spacing=1.5, sigma1=0.3, sigma2=0.2, p_detect2=0.7, false_density1=0.3, trials=5,
          dim=2, layout="uniform", rng=22)),
    ("clutter_clean", "two_radar_clutter_scene", (3,),
     dict(spacing=1.0, sigma1=0.1, sigma2=0.1, trials=3, dim=2, rng=23)),
    ("typed_shared", "typed_scene", (4,),
     dict(type_means=[0.0, 3.0, 7.0], type_vars=[1.0, 0.5, 2.0], priors=[0.2, 0.5, 0.3],
          spacing=1.0, sigma1=0.2, sigma2=0.3, feature_sigma1=0.1, feature_sigma2=0.4,
          trials=6, rng=31)),
    ("typed_spread2d", "typed_scene", (3,),
     dict(type_means=[0.0, 5.0], type_vars=[1.0, 1.0], spacing=2.0, sigma1=0.2, sigma2=0.3,
          feature_sigma1=0.3, feature_sigma2=0.2, model="spread", trials=5, dim=2,
          layout="uniform", rng=32)),
    ("group_line", "grouping_scene", (4, 3), dict(cov=COV3, trials=5, rng=41)),
    ("group_uniform_tracks", "grouping_scene", (3, 2),
     dict(cov=COV3[:2], spacing=[1.0, 3.0], layout="uniform", track_cov=np.eye(2) * 0.5,
          trials=4, rng=42)),
    ("polar_small", "polar_scene", (separated.paper_geometry(0.0, -5.0),),
     dict(sigma_r=0.1, sigma_beta=np.deg2rad(1.0), trials=4, rng=51)),
]
#: Each simulator under its old name (the chapters call these).
OLD_HOMES = {
    "two_radar_scene": scenes, "two_radar_clutter_scene": association,
    "typed_scene": features, "grouping_scene": grouping, "polar_scene": separated,
}


def _golden(prefix):
    keys = [k for k in GOLDEN.files if k.rsplit(".", 1)[0] == prefix]
    assert keys, f"no golden arrays for {prefix}"
    return {k.rsplit(".", 1)[1]: GOLDEN[k] for k in keys}


def _assert_same_draws(result, prefix):
    for field, want in _golden(prefix).items():
        got = np.asarray(getattr(result, field))
        assert got.dtype == want.dtype and got.shape == want.shape, (prefix, field)
        np.testing.assert_array_equal(got, want, err_msg=f"{prefix}.{field}")


#: (case, home): every case through scenes, and through the chapter module's name where
#: the chapter still offers one.
GOLDEN_HOMES = [(case, home) for case in GOLDEN_CASES for home in ("scenes", "old")
                if home == "scenes" or hasattr(OLD_HOMES[case[1]], case[1])]


@pytest.mark.parametrize(("case", "home"), GOLDEN_HOMES,
                         ids=[f"{c[0]}-{h}" for c, h in GOLDEN_HOMES])
def test_same_seed_same_draws_as_before_the_move(case, home):
    key, name, counts, kwargs = case
    module = scenes if home == "scenes" else OLD_HOMES[name]
    result = getattr(module, name)(*counts, **kwargs)
    _assert_same_draws(result, key)
    if name == "typed_scene":
        _assert_same_draws(result.coords, key + ".coords")


def test_polar_draws_across_a_block_boundary_are_unchanged():
    assert geometry.BLOCK_TRIALS < 70_000
    rep = scenes.polar_scene(separated.paper_geometry(2.0, 3.0), sigma_r=0.2,
                             sigma_beta=0.01, trials=70_000,
                             rng=np.random.SeedSequence(52))
    rows = np.r_[0:3, 65534:65538, 69997:70000]
    for field, want in _golden("polar_blocks").items():
        np.testing.assert_array_equal(getattr(rep, field)[rows], want)


def test_no_chapter_module_offers_a_scene_under_its_own_name():
    """A scene has one name, the engine's: chapter modules do not re-export it."""
    pairs = [(features, "typed_scene"), (features, "TypedScene"), (features, "FEATURE_MODELS"),
             (separated, "polar_scene"), (separated, "PolarReports"),
             (grouping, "GroupingScene"), (association, "two_radar_clutter_scene"),
             (association, "ClutterScene")]
    assert all(hasattr(scenes, name) for _, name in pairs)
    offered = [(m.__name__, name) for m, name in pairs if name in getattr(m, "__all__", ())]
    assert not offered, offered


def test_no_chapter_module_offers_a_geometry_name_under_its_own_name():
    """The geometry's names (the two-radar layout, the trial limits, the one limit on an
    angle's standard deviation) have one home, the engine's: no chapter module lists them."""
    import importlib
    import pkgutil

    import radarfusion_ref
    assert {"SIGMA_BETA_MAX", "Geometry", "radar2_position", "polar_from",
            "BLOCK_TRIALS", "MAX_TRIALS"} <= set(geometry.__all__)
    chapters = [importlib.import_module(f"radarfusion_ref.{m.name}")
                for m in pkgutil.iter_modules(radarfusion_ref.__path__)
                if m.name not in ("engine", "kit")]
    assert {"conversion", "separated", "registration"} <= {m.__name__.rsplit(".", 1)[-1]
                                                          for m in chapters}
    offered = [(m.__name__, name) for m in chapters for name in getattr(m, "__all__", ())
               if name in geometry.__all__]
    assert not offered, offered


# ================================================================ statistics
def test_two_radar_errors_by_monte_carlo():
    sc = two_radar_scene(3, spacing=2.0, sigma1=0.3, sigma2=0.7, trials=20_000, dim=2, rng=5)
    e1 = (sc.reports1 - sc.truth).reshape(-1)
    e2 = (sc.reports2 - np.take_along_axis(sc.truth, sc.owner2[..., None], axis=1)).reshape(-1)
    require(mean(e1 ** 2), 0.09, "radar-1 error variance")
    require(mean(e2 ** 2), 0.49, "radar-2 error variance")
    require(mean(e1), 0.0, "radar-1 error mean")
    require(mean(e1[0::2] * e1[1::2]), 0.0, "radar-1 coordinates uncorrelated")


@pytest.mark.parametrize("layout", ["line", "uniform"])
def test_clutter_detection_false_count_and_noise(layout):
    pd1, pd2, lam1, lam2, s, n, d = 0.8, 0.55, 0.4, 1.5, 1.5, 5, 2
    sc = scenes.two_radar_clutter_scene(n, spacing=s, layout=layout, sigma1=0.2, sigma2=0.3,
                                        p_detect1=pd1, p_detect2=pd2, false_density1=lam1,
                                        false_density2=lam2, trials=8_000, dim=d, rng=6)
    assert sc.volume == pytest.approx(n * s ** d)
    for own, rep, pd, lam, sig in ((sc.owner1, sc.reports1, pd1, lam1, 0.2),
                                   (sc.owner2, sc.reports2, pd2, lam2, 0.3)):
        # each object appears at most once per trial
        for j in range(n):
            assert np.all((own == j).sum(axis=1) <= 1)
        require(proportion(int((own >= 0).sum()), n * sc.trials), pd, "P_D")
        nfalse = (own == -1).sum(axis=1)
        require(mean(nfalse), lam * sc.volume, "false reports per trial")
        require(mean((nfalse - lam * sc.volume) ** 2), lam * sc.volume,
                "Poisson variance of the false-report count")
        fpos = rep[own == -1]
        assert np.all(fpos >= sc.region_low) and np.all(fpos <= sc.region_high)
        mid = (sc.region_low + sc.region_high) / 2
        require(proportion(int((fpos[:, 0] < mid[0]).sum()), len(fpos)), 0.5,
                "false reports uniform over the box (first axis)")
        det = own >= 0
        err = rep[det] - np.take_along_axis(sc.truth, np.where(det, own, 0)[..., None],
                                            axis=1)[det]
        require(mean(err.reshape(-1) ** 2), sig ** 2, "clutter-scene error variance")
        assert np.all(rep[own == -2] == 0.0)


def test_clutter_true_decisions_agree_with_the_owners():
    sc = scenes.two_radar_clutter_scene(6, spacing=1.0, sigma1=0.1, sigma2=0.1, p_detect1=0.7,
                                        p_detect2=0.7, false_density1=0.5,
                                        false_density2=0.5, trials=50, rng=7)
    t2c = sc.true_row_to_col
    for t in range(sc.trials):
        for i, o in enumerate(sc.owner1[t]):
            if t2c[t, i] >= 0:
                assert o >= 0 and sc.owner2[t, t2c[t, i]] == o
            else:
                assert o < 0 or o not in sc.owner2[t]


def test_clean_clutter_scene_matches_the_two_radar_scene():
    """Without misses or false reports only the list order differs from two_radar_scene."""
    a = scenes.two_radar_clutter_scene(4, spacing=1.0, sigma1=0.1, sigma2=0.2, trials=30,
                                       dim=2, rng=8)
    b = scenes.two_radar_scene(4, spacing=1.0, sigma1=0.1, sigma2=0.2, trials=30, dim=2, rng=8)
    np.testing.assert_array_equal(a.truth, b.truth)
    r1 = np.take_along_axis(a.reports1, np.argsort(a.owner1, axis=1)[..., None], axis=1)
    np.testing.assert_array_equal(r1, b.reports1)


@pytest.mark.parametrize("model", scenes.FEATURE_MODELS)
def test_typed_scene_types_and_feature_noise(model):
    means, tvars, pri = np.array([0.0, 4.0, 9.0]), np.array([1.0, 0.25, 2.0]), [0.2, 0.3, 0.5]
    sc = scenes.typed_scene(3, spacing=1.0, sigma1=0.1, sigma2=0.1, type_means=means,
                            type_vars=tvars, priors=pri, feature_sigma1=0.3,
                            feature_sigma2=0.5, model=model, trials=20_000, rng=9)
    for k in range(3):
        require(proportion(int((sc.types == k).sum()), sc.types.size), pri[k], f"type {k}")
    z = (sc.feature_truth - means[sc.types]) / np.sqrt(tvars[sc.types])
    require(mean(z.reshape(-1) ** 2), 1.0, "feature values' standardised variance")
    require(mean((sc.features1 - sc.feature_truth).reshape(-1) ** 2), 0.09,
            "radar-1 feature error variance")
    types2 = np.take_along_axis(sc.types, sc.owner2, axis=1)
    dev2 = (sc.features2 - means[types2]).reshape(-1)
    want = (tvars[types2] + 0.25).reshape(-1)
    require(mean(dev2 ** 2 / want), 1.0, "radar-2 feature deviation / its variance")
    if model == "shared":
        seen2 = np.take_along_axis(sc.feature_truth, sc.owner2, axis=1)
        require(mean((sc.features2 - seen2).reshape(-1) ** 2), 0.25,
                "radar-2 feature error variance")


def test_grouping_scene_report_and_track_covariances():
    cov = COV3[:, 0]
    tcov = np.array([[0.5, -0.2], [-0.2, 0.3]])
    sc = scenes.grouping_scene(2, 3, cov=cov[:, None], track_cov=tcov, trials=30_000, rng=10)
    src = np.take_along_axis(sc.truth[:, None], sc.owner[..., None], axis=2)
    e = sc.reports - src                                        # (T, m, n, d)
    for i in range(3):
        for a, b in ((0, 0), (0, 1), (1, 1)):
            require(mean(e[:, i, :, a].reshape(-1) * e[:, i, :, b].reshape(-1)), cov[i, a, b],
                    f"source {i} error covariance [{a}, {b}]")
    et = sc.tracks - sc.truth
    for a, b in ((0, 0), (0, 1), (1, 1)):
        require(mean(et[..., a].reshape(-1) * et[..., b].reshape(-1)), tcov[a, b],
                f"track error covariance [{a}, {b}]")
    # each source's report order is a uniform random permutation
    first = sc.owner[:, :, 0].reshape(-1)
    require(proportion(int((first == 0).sum()), first.size), 0.5, "uniform report order")


def test_polar_errors_by_monte_carlo():
    geo = separated.paper_geometry(0.0, -5.0)
    rep = scenes.polar_scene(geo, sigma_r=0.1, sigma_beta=0.01, trials=20_000, rng=11)
    (r1, b1), (r2, b2) = geo.polar1, geo.polar2
    for got, true, sig, what in ((rep.r1, r1, 0.1, "r1"), (rep.beta1, b1, 0.01, "beta1"),
                                 (rep.r2, r2, 0.1, "r2"), (rep.beta2, b2, 0.01, "beta2")):
        require(mean(((got - true) / sig).reshape(-1) ** 2), 1.0, f"{what} error variance")
        require(mean(((got - true) / sig).reshape(-1)), 0.0, f"{what} error mean")


def test_require_catches_a_wrong_variance():
    """The statistical tests can fail: a 10 % variance error is caught at this size."""
    sc = two_radar_scene(3, spacing=2.0, sigma1=0.3, sigma2=0.7, trials=20_000, dim=2, rng=5)
    e1 = (sc.reports1 - sc.truth).reshape(-1)
    with pytest.raises(MonteCarloCheckError):
        require(mean(e1 ** 2), 0.09 * 1.1, "a wrong variance")


# ================================================================ the conventions
#: The one order of the keyword arguments (CONVENTIONS in the module docstring).
CANONICAL_ORDER = [
    "spacing", "layout", "sigma1", "sigma2", "cov", "sigma_r", "sigma_beta",
    "p_detect1", "p_detect2", "false_density1", "false_density2",
    "type_means", "type_vars", "priors", "feature_sigma1", "feature_sigma2", "model",
    "track_cov", "trials", "dim", "rng",
]
SIMULATORS = ["two_radar_scene", "two_radar_clutter_scene", "typed_scene", "grouping_scene",
              "polar_scene"]


@pytest.mark.parametrize("name", SIMULATORS)
def test_one_argument_order(name):
    params = inspect.signature(getattr(scenes, name)).parameters.values()
    positional = [p.name for p in params if p.kind is not p.KEYWORD_ONLY]
    keywords = [p.name for p in params if p.kind is p.KEYWORD_ONLY]
    assert positional in (["n_objects"], ["n_objects", "n_sources"], ["geometry"])
    assert set(keywords) <= set(CANONICAL_ORDER), set(keywords) - set(CANONICAL_ORDER)
    assert keywords == sorted(keywords, key=CANONICAL_ORDER.index)
    assert keywords[-1] == "rng" and "trials" in keywords


@pytest.mark.parametrize(("key", "name", "counts", "kwargs"), GOLDEN_CASES,
                         ids=[c[0] for c in GOLDEN_CASES])
def test_results_share_the_base_and_the_trial_axis(key, name, counts, kwargs):
    sc = getattr(scenes, name)(*counts, **kwargs)
    assert isinstance(sc, scenes.Scene)
    assert sc.trials == kwargs["trials"]
    assert sc.truth.shape == (sc.trials, sc.n_objects, sc.dim)
    for field in ("reports1", "reports2", "reports", "owner1", "owner2", "owner",
                  "features1", "features2", "r1", "beta1", "r2", "beta2"):
        if hasattr(sc, field):
            assert np.shape(getattr(sc, field))[0] == sc.trials, field


def test_grouping_scene_names_its_first_argument():
    with pytest.raises(ValueError, match="`n_objects`"):
        scenes.grouping_scene(0, 2, cov=np.eye(2)[None, None])


GEO = separated.paper_geometry(0.0, -5.0)
BASE = {
    "two_radar_scene": ((3,), dict(spacing=1.0, sigma1=0.1, sigma2=0.1)),
    "two_radar_clutter_scene": ((3,), dict(spacing=1.0, sigma1=0.1, sigma2=0.1)),
    "typed_scene": ((3,), dict(spacing=1.0, sigma1=0.1, sigma2=0.1, type_means=[0.0, 1.0],
                               type_vars=[1.0, 1.0], feature_sigma1=0.1, feature_sigma2=0.1)),
    "grouping_scene": ((3, 2), dict(cov=np.eye(2)[None, None])),
    "polar_scene": ((GEO,), dict(sigma_r=0.1, sigma_beta=0.01)),
}
BAD = [
    ("two_radar_scene", "n_objects", 0, ValueError),
    ("two_radar_scene", "n_objects", 2.5, TypeError),
    ("two_radar_scene", "spacing", [1.0, 2.0], ValueError),
    ("two_radar_scene", "spacing", np.nan, ValueError),
    ("two_radar_scene", "layout", 3, ValueError),
    ("two_radar_scene", "sigma1", np.inf, ValueError),
    ("two_radar_scene", "sigma2", "0.1", TypeError),
    ("two_radar_scene", "trials", True, TypeError),
    ("two_radar_scene", "dim", 0, ValueError),
    ("two_radar_scene", "rng", "seed", TypeError),
    ("two_radar_clutter_scene", "n_objects", -1, ValueError),
    ("two_radar_clutter_scene", "spacing", 0.0, ValueError),
    ("two_radar_clutter_scene", "sigma1", -0.1, ValueError),
    ("two_radar_clutter_scene", "trials", 0, ValueError),
    ("two_radar_clutter_scene", "p_detect1", 1.5, ValueError),
    ("two_radar_clutter_scene", "p_detect2", np.nan, ValueError),
    ("two_radar_clutter_scene", "p_detect2", [0.5, 0.5], ValueError),
    ("two_radar_clutter_scene", "false_density1", -0.1, ValueError),
    ("two_radar_clutter_scene", "false_density2", np.inf, ValueError),
    ("two_radar_clutter_scene", "sigma2", 0.0, ValueError),
    ("two_radar_clutter_scene", "layout", "grid", ValueError),
    ("two_radar_clutter_scene", "dim", 0, ValueError),
    ("two_radar_clutter_scene", "rng", np.random.RandomState(0), TypeError),
    ("typed_scene", "type_means", [], ValueError),
    ("typed_scene", "type_vars", [1.0, -1.0], ValueError),
    ("typed_scene", "priors", [0.5, 0.6], ValueError),
    ("typed_scene", "feature_sigma1", 0.0, ValueError),
    ("typed_scene", "feature_sigma2", [0.1, 0.2], ValueError),
    ("typed_scene", "model", "mixed", ValueError),
    ("typed_scene", "spacing", -1.0, ValueError),
    ("typed_scene", "n_objects", 0, ValueError),
    ("typed_scene", "layout", "ring", ValueError),
    ("typed_scene", "sigma1", 0.0, ValueError),
    ("typed_scene", "sigma2", np.nan, ValueError),
    ("typed_scene", "trials", -2, ValueError),
    ("typed_scene", "dim", 1.5, TypeError),
    ("typed_scene", "rng", np.random.RandomState(1), TypeError),
    ("grouping_scene", "n_objects", 0, ValueError),
    ("grouping_scene", "rng", "seed", TypeError),
    ("grouping_scene", "n_sources", 0, ValueError),
    ("grouping_scene", "cov", np.ones((2, 2)), ValueError),
    ("grouping_scene", "cov", -np.eye(2)[None, None], ValueError),
    ("grouping_scene", "spacing", [1.0, 2.0, 3.0], ValueError),
    ("grouping_scene", "track_cov", np.eye(3), ValueError),
    ("grouping_scene", "layout", "grid", ValueError),
    ("grouping_scene", "trials", 0, ValueError),
    ("polar_scene", "geometry", "paper", TypeError),
    ("polar_scene", "sigma_r", -0.1, ValueError),
    ("polar_scene", "sigma_beta", 1.0, ValueError),
    ("polar_scene", "trials", 0, ValueError),
    ("polar_scene", "rng", "seed", TypeError),
]


@pytest.mark.parametrize(("name", "arg", "value", "exc"), BAD,
                         ids=[f"{b[0]}-{b[1]}-{i}" for i, b in enumerate(BAD)])
def test_bad_input_is_refused_by_name(name, arg, value, exc):
    counts, kwargs = BASE[name]
    counts, kwargs = list(counts), dict(kwargs)
    if arg in ("geometry", "n_objects"):
        counts[0] = value
    elif arg == "n_sources":
        counts[1] = value
    else:
        kwargs[arg] = value
    with pytest.raises(exc, match=f"`{arg}`"):
        getattr(scenes, name)(*counts, **kwargs)


@pytest.mark.parametrize(("call", "name"), [
    (lambda: two_radar_scene(10_000, spacing=1.0, sigma1=0.1, sigma2=0.1, trials=10_000,
                             dim=2), "trials"),
    (lambda: scenes.two_radar_clutter_scene(10, spacing=1.0, sigma1=0.1, sigma2=0.1,
                                            false_density1=1e9, trials=10), "false_density1"),
    (lambda: scenes.grouping_scene(1000, 10, cov=np.eye(2)[None, None], trials=10**5),
     "trials"),
    (lambda: scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=0.01, trials=5 * 10**7),
  "trials"),
])
def test_memory_is_refused_before_allocation(call, name):
    with pytest.raises(ValueError, match=f"`{name}`") as info:
        call()
    msg = str(info.value)
    # the limit, and the scalable route instead (check_size's wording)
    assert f"above the limit of {MEMORY_LIMIT}" in msg and "; use " in msg, msg


def test_the_shared_vocabulary_agrees_across_results():
    two = scenes.two_radar_scene(5, spacing=1.0, sigma1=0.1, sigma2=0.1, trials=7, rng=13)
    rows = np.arange(two.trials)[:, None]
    np.testing.assert_array_equal(two.owner2[rows, two.true_row_to_col], two.owner1)
    typed = scenes.typed_scene(5, spacing=1.0, sigma1=0.1, sigma2=0.1, type_means=[0.0],
                               type_vars=[1.0], feature_sigma1=0.1, feature_sigma2=0.1,
                               trials=7, rng=13)
    np.testing.assert_array_equal(typed.owner2, typed.coords.owner2)
    np.testing.assert_array_equal(typed.truth, typed.coords.truth)
    grp = scenes.grouping_scene(4, 3, cov=np.eye(2)[None, None], trials=2, rng=13)
    assert (grp.n_objects, grp.n_sources, grp.dim, grp.trials) == (4, 3, 2, 2)
    rep = scenes.polar_scene(GEO, sigma_r=0.1, sigma_beta=0.01, trials=3, rng=13)
    np.testing.assert_array_equal(rep.truth[2], GEO.targets)
    assert (rep.n_objects, rep.dim) == (2, 2)


@pytest.mark.parametrize("name", SIMULATORS)
def test_every_argument_has_a_bad_input_case(name):
    """The table above covers every public argument of every simulator."""
    covered = {arg for fn, arg, _, _ in BAD if fn == name}
    assert set(inspect.signature(getattr(scenes, name)).parameters) == covered


@settings(max_examples=25, deadline=None)
@given(n=st.integers(1, 5), trials=st.integers(1, 4), dim=st.integers(1, 3),
       layout=st.sampled_from(scenes.LAYOUTS), pd=st.floats(0.0, 1.0),
       lam=st.floats(0.0, 3.0), seed=st.integers(0, 2**32 - 1))
def test_property_clutter_scene_shapes_owners_and_seed(n, trials, dim, layout, pd, lam, seed):
    kw = dict(spacing=1.3, layout=layout, sigma1=0.2, sigma2=0.3, p_detect1=pd, p_detect2=pd,
              false_density1=lam, false_density2=lam, trials=trials, dim=dim, rng=seed)
    sc = scenes.two_radar_clutter_scene(n, **kw)
    again = scenes.two_radar_clutter_scene(n, **kw)
    for field in ("reports1", "reports2", "owner1", "owner2"):
        np.testing.assert_array_equal(getattr(sc, field), getattr(again, field))
    for rep, own in ((sc.reports1, sc.owner1), (sc.reports2, sc.owner2)):
        assert rep.shape[:2] == own.shape and rep.shape[0] == trials and rep.shape[2] == dim
        assert np.all(np.isfinite(rep)) and np.all(own >= -2) and np.all(own < n)
        # padding only at the end of each list; every object at most once
        valid = own > -2
        assert np.all(np.diff(valid.astype(int), axis=1) <= 0)
        for j in range(n):
            assert np.all((own == j).sum(axis=1) <= 1)
    if pd == 1.0:
        assert np.all(np.sort(np.where(sc.owner1 >= 0, sc.owner1, n), axis=1)[:, :n]
                      == np.arange(n))
    if pd == 0.0 and lam == 0.0:
        assert np.all(sc.owner1 == -2)


@pytest.mark.parametrize("layout", scenes.LAYOUTS)
def test_two_radar_scene_draws_in_the_documented_order(layout):
    """Rebuild the scene from a Generator following the docstring's Notes, loop by loop."""
    n, trials, dim, s, s1, s2 = 4, 3, 2, 1.5, 0.2, 0.3
    sc = two_radar_scene(n, spacing=s, layout=layout, sigma1=s1, sigma2=s2, trials=trials,
                         dim=dim, rng=77)
    g = np.random.default_rng(77)
    if layout == "uniform":
        truth = g.uniform(0.0, s * n ** (1 / dim), size=(trials, n, dim))
    else:
        truth = np.zeros((trials, n, dim))
        for j in range(n):
            truth[:, j, 0] = s * j
    e1 = g.standard_normal((trials, n, dim))
    perm = g.permuted(np.tile(np.arange(n), (trials, 1)), axis=1)
    e2 = g.standard_normal((trials, n, dim))
    for t in range(trials):
        for i in range(n):
            np.testing.assert_array_equal(sc.reports1[t, i], truth[t, i] + s1 * e1[t, i])
            np.testing.assert_array_equal(sc.reports2[t, i], truth[t, perm[t, i]] + s2 * e2[t, i])
    np.testing.assert_array_equal(sc.owner2, perm)


def test_grouping_scene_draws_in_the_documented_order():
    n, m, trials = 3, 2, 4
    cov = np.array([[[0.5, 0.1], [0.1, 0.3]], [[0.2, 0.0], [0.0, 0.7]]])[:, None]
    tcov = np.eye(2) * 0.4
    sc = scenes.grouping_scene(n, m, layout="uniform", spacing=[1.0, 2.0], cov=cov,
                               track_cov=tcov, trials=trials, rng=78)
    g = np.random.default_rng(78)
    truth = g.uniform(0.0, 1.0, size=(trials, n, 2)) * (np.array([1.0, 2.0]) * n ** 0.5)
    owner = g.permuted(np.tile(np.arange(n), (trials, m, 1)), axis=-1)
    z = g.standard_normal((trials, m, n, 2))
    zt = g.standard_normal((trials, n, 2))
    np.testing.assert_array_equal(sc.owner, owner)
    for t in range(trials):
        for i in range(m):
            L = np.linalg.cholesky(cov[i, 0])
            for j in range(n):
                np.testing.assert_allclose(sc.reports[t, i, j],
                                           truth[t, owner[t, i, j]] + L @ z[t, i, j],
                                           rtol=0, atol=1e-14)
        np.testing.assert_allclose(sc.tracks[t], truth[t] + zt[t] @ np.linalg.cholesky(tcov).T,
                                   rtol=0, atol=1e-14)
