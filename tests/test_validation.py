"""The shared input checks: clear messages naming the argument."""

from __future__ import annotations

import numpy as np
import pytest

from radarfusion_ref.engine import validation as v


def test_float_array_accepts_numbers_and_lists():
    np.testing.assert_array_equal(v.as_float_array([1, 2], "x"), [1.0, 2.0])
    assert v.as_float_array(3, "x").shape == ()


@pytest.mark.parametrize("bad", ["abc", None, [[1, 2], [3]], {"a": 1}, True, np.bool_(False),
                                 [True, False], ["1.5", "2"], np.array(["1"]), [1 + 2j]])
def test_float_array_rejects_non_numeric(bad):
    with pytest.raises(TypeError, match="`x` must be a number or an array of numbers"):
        v.as_float_array(bad, "x")


@pytest.mark.parametrize("bad", [np.nan, np.inf, [1.0, -np.inf]])
def test_float_array_rejects_non_finite(bad):
    with pytest.raises(ValueError, match="`x` must be finite"):
        v.as_float_array(bad, "x")


def test_trailing_shape_is_checked():
    v.as_float_array(np.zeros((4, 2)), "xy", last_dims=(2,))
    with pytest.raises(ValueError, match=r"`xy` must have shape \(\.\.\., 2\)"):
        v.as_float_array(np.zeros((4, 3)), "xy", last_dims=(2,))


def test_positive_and_probability():
    with pytest.raises(ValueError, match="`var` must be > 0"):
        v.as_positive([1.0, 0.0], "var")
    v.as_positive([1.0, 0.0], "var", strict=False)
    with pytest.raises(ValueError, match="`p` must lie in the open interval"):
        v.as_probability(0.0, "p")
    v.as_probability(0.0, "p", open_interval=False)


@pytest.mark.parametrize("bad", [1.0, True, "3"])
def test_int_rejects_non_integers(bad):
    with pytest.raises(TypeError, match="`n` must be an integer"):
        v.as_int(bad, "n")


def test_int_range():
    assert v.as_int(np.int64(3), "n", minimum=1) == 3
    with pytest.raises(ValueError, match="`n` must be an integer >= 1 and <= 5; received 6"):
        v.as_int(6, "n", minimum=1, maximum=5)


def test_covariance_checks():
    good = np.array([[2.0, 0.5], [0.5, 1.0]])
    np.testing.assert_array_equal(v.as_covariance(np.stack([good, good]), "cov"),
                                  np.stack([good, good]))
    with pytest.raises(ValueError, match="`cov` must be symmetric"):
        v.as_covariance([[1.0, 0.5], [0.0, 1.0]], "cov")
    with pytest.raises(ValueError, match="1 of 2 matrices are not"):
        v.as_covariance(np.stack([good, [[1.0, 2.0], [2.0, 1.0]]]), "cov")
    with pytest.raises(ValueError, match=r"`cov` must have shape \(\.\.\., d, d\)"):
        v.as_covariance(np.zeros((2, 3)), "cov")
    with pytest.raises(ValueError, match=r"\(\.\.\., 3, 3\)"):
        v.as_covariance(good, "cov", dim=3)


def test_choice_and_rng():
    assert v.as_choice("a", "kind", ("a", "b")) == "a"
    with pytest.raises(ValueError, match="`kind` must be one of 'a', 'b'"):
        v.as_choice("c", "kind", ("a", "b"))
    g = np.random.default_rng(0)
    assert v.as_rng(g) is g
    with pytest.raises(TypeError, match="legacy RandomState"):
        v.as_rng(np.random.RandomState(0))
    with pytest.raises(TypeError, match="`rng`"):
        v.as_rng("seed")
    for flag in (True, False, np.True_):  # numpy takes a bool as the seed 1 or 0
        with pytest.raises(TypeError, match=r"`rng` must be None, an int seed.*received"):
            v.as_rng(flag)


def test_broadcast_names_all_arguments():
    a, b = v.broadcast(x1=np.zeros((3, 1)), x2=np.zeros(2))
    assert a.shape == b.shape == (3, 2)
    with pytest.raises(ValueError, match="`x1`, `x2` must broadcast"):
        v.broadcast(x1=np.zeros(3), x2=np.zeros(2))


def test_check_size_refuses_before_allocating():
    import math

    assert v.check_size(10, 10, what="things", alternative="x") == 10
    with pytest.raises(ValueError, match=r"refused: 3628800 hypotheses n! requested, above the "
                                         r"limit of 1000; use the solver instead"):
        v.check_size(math.factorial(10), 1000, what="hypotheses n!", alternative="the solver")


def test_seed_sequence_one_conversion():
    assert v.as_seed_sequence(7).entropy == 7
    seq = np.random.SeedSequence(3, spawn_key=(1,))
    assert v.as_seed_sequence(seq) is seq
    assert isinstance(v.as_seed_sequence(None), np.random.SeedSequence)
    # a Generator gives 128 bits: the four 32-bit words it draws, and it advances
    words = np.random.default_rng(5).integers(0, 2**32, size=4, dtype=np.uint64).tolist()
    g = np.random.default_rng(5)
    assert v.as_seed_sequence(g).entropy == words
    assert v.as_seed_sequence(g).entropy != words
    for bad in (-1, 1.5, True, "7", np.random.RandomState(0)):
        with pytest.raises(TypeError, match="`rng` must be None, a non-negative int seed"):
            v.as_seed_sequence(bad)


def test_single_number_check():
    assert v.as_float(np.float32(0.25), "p") == 0.25 and v.as_float(np.array(3), "p") == 3.0
    assert isinstance(v.as_float(1, "p"), float)
    with pytest.raises(ValueError, match=r"`p` must be a single number; received array"):
        v.as_float([0.1, 0.2], "p")
    with pytest.raises(ValueError, match="`p` must be finite"):
        v.as_float(float("nan"), "p")
    with pytest.raises(TypeError, match="`p`"):
        v.as_float("0.5", "p")
    with pytest.raises(ValueError, match="`p` must be finite"):
        v.as_float(float("inf"), "p")


def test_single_number_check_with_infinities():
    assert v.as_float(np.inf, "gate", allow_inf=True) == np.inf
    assert v.as_float(np.array(-np.inf), "gate", allow_inf=True) == -np.inf
    assert v.as_float(2, "gate", allow_inf=True) == 2.0
    for nan in (float("nan"), np.array(np.nan), np.float32("nan")):
        with pytest.raises(ValueError, match="`gate` must be a number or \\+-inf, not NaN"):
            v.as_float(nan, "gate", allow_inf=True)
    with pytest.raises(ValueError, match="`gate` must be a single number"):
        v.as_float([1.0, np.inf], "gate", allow_inf=True)


def test_covariance_rule_is_scale_free_and_refuses_singular_to_precision():
    corr = np.array([[1.0, 0.0], [0.0, 1.0]])
    for rho, ok in ((1 - 1e-11, True), (1 - 1e-13, False)):   # 1 - rho^2 about 2e-11, 2e-13
        corr[0, 1] = corr[1, 0] = rho
        for scale in (np.diag([1e-20, 1e20]), np.eye(2)):   # variances 1e-40, 1e40: in the domain
            c = scale @ corr @ scale
            if ok:
                v.as_covariance(c, "cov")
            else:
                with pytest.raises(ValueError, match="`cov` must be positive definite and not "
                                                     "singular to working precision"):
                    v.as_covariance(c, "cov")


# --------------------------------------------------------------------------- one covariance rule
#: Argument names that hold a covariance matrix (or a stack of them) in the public API.
COVARIANCE_ARGUMENTS = {"cov", "covariances", "z_cov", "R1", "R2", "cov1", "cov2", "P1_0",
                        "P2_0", "track_cov", "innovation_cov"}
#: Names that look like a covariance argument and are not one, each with its reason.
NOT_COVARIANCES = {
    "cov12": "a cross-covariance: any real matrix",
    "P12_0": "a cross-covariance: any real matrix",
    "Q": "process noise: positive semi-definite (a singular Q is legitimate)",
    "prior_cov": "a prior's covariance: positive semi-definite (zero, the default, is the truth)",
    "cov_method": "the name of a conversion method",
}
#: Functions whose kernels rescale exactly and are tested over the whole float range
#: (``as_covariance(..., domain=False)``): a variance of 1e-200 or 1e+200 gives a finite
#: answer, or a refusal naming the argument if the answer leaves the float range.
WHOLE_FLOAT_RANGE = {
    "association.non_assignment_cost", "fusion.fuse_gaussian", "fusion.sample_reports_gaussian",
    "grouping.binding_costs", "grouping.group_bruteforce", "grouping.group_costs",
    "grouping.group_sd", "grouping.ml_group_cost",
}
#: Public functions that take a covariance yet must not refuse a bad one, with the reason.
COVARIANCE_EXEMPT = {
    ("linalg.is_positive_definite", "cov"): "it answers the rule as a mask, False for a bad one",
}


def _public_covariance_parameters():
    """Every (function, argument) of the public API whose argument looks like a covariance."""
    import importlib
    import inspect
    import pkgutil
    import re

    import radarfusion_ref

    found, unclassified = {}, []
    for info in pkgutil.walk_packages(radarfusion_ref.__path__, "radarfusion_ref."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        module = importlib.import_module(info.name)
        parts = info.name.split(".")[1:]
        short = ".".join(parts[1:] if parts[0] in ("engine", "kit") else parts)
        for name in getattr(module, "__all__", []):
            obj = getattr(module, name)
            if not inspect.isfunction(obj) or obj.__name__.endswith("_kernel"):
                continue
            for arg in inspect.signature(obj).parameters:
                if arg in COVARIANCE_ARGUMENTS:
                    found[(f"{short}.{name}", arg)] = obj
                elif re.search(r"cov|^[PRQ]\d*(_0)?$", arg) and arg not in NOT_COVARIANCES:
                    unclassified.append(f"{short}.{name}({arg})")
    return found, unclassified


def _bad_covariances(d):
    """The same bad matrix, d x d, each breaking one clause of the rule (no asymmetry at d = 1)."""
    eye = np.eye(d)
    nan, asym, indef = eye.copy(), 2 * eye, eye.copy()
    nan[0, 0] = np.nan
    asym[0, -1] = 0.5
    indef[-1, -1] = -1.0
    out = {"variance 1e-200": 1e-200 * eye, "variance 1e+200": 1e200 * eye, "NaN": nan,
           "asymmetric": asym, "indefinite": indef}
    if d == 1:
        del out["asymmetric"]
    return out


def _cv_state(n):
    return np.zeros((n, 4)), np.tile(np.eye(4), (n, 1, 1))


def _tracking_reports():
    t = np.arange(6) * 5.0
    z = np.c_[100.0 * t, np.zeros(6), np.full(6, 9000.0)]
    return dict(time=t, position=z, cov=np.tile(100.0 * np.eye(3), (6, 1, 1)),
                radar=np.zeros(6, int), scan=np.arange(6))


def _valid_calls():
    """A valid call of each public function that takes a covariance: (function, kwargs, dims).

    `dims` maps each covariance argument to the size d of its matrices.
    """
    from radarfusion_ref import (
        association,
        continent,
        conversion,
        features,
        fusion,
        gating,
        grouping,
        proximity,
        separated,
        trackfusion,
        tracking,
    )
    from radarfusion_ref.engine import linalg, metrics, scenes, tracker
    from radarfusion_ref.kit import plotting

    eye2, x2 = np.eye(2), np.array([[0.0, 0.0], [1.0, 0.5]])
    covs2 = np.stack([eye2, 2 * eye2])
    xg = np.zeros((2, 2, 2))                            # 2 sources x 2 reports x 2-D
    cg = np.broadcast_to(eye2, (2, 2, 2, 2))
    m = trackfusion.constant_velocity(1.0, 1.0)
    h, one = [[1.0, 0.0]], [[1.0]]
    prob, xi = np.array([0.5, 0.5]), np.zeros((2, 4))
    Pi = np.tile(np.eye(4), (2, 1, 1))
    calls = {
        "association.non_assignment_cost": (
            association.non_assignment_cost,
            dict(p_detect1=0.9, p_detect2=0.9, false_density1=1e-3, false_density2=1e-3,
                 object_density=1e-3, innovation_cov=eye2), {"innovation_cov": 2}),
        "conversion.nees_per_trial": (conversion.nees_per_trial,
                                      dict(error=x2, cov=covs2), {"cov": 2}),
        "linalg.cholesky": (linalg.cholesky, dict(cov=eye2), {"cov": 2}),
        "linalg.mahalanobis_sq": (linalg.mahalanobis_sq, dict(d=[1.0, 0.0], cov=eye2),
                                  {"cov": 2}),
        "linalg.mahalanobis_sq_pairwise": (linalg.mahalanobis_sq_pairwise,
                                           dict(x1=x2, x2=x2, cov1=covs2, cov2=eye2),
                                           {"cov1": 2, "cov2": 2}),
        "metrics.nees": (metrics.nees, dict(error=x2, cov=covs2), {"cov": 2}),
        "scenes.grouping_scene": (scenes.grouping_scene,
                                  dict(n_objects=2, n_sources=2, cov=cg, track_cov=covs2,
                                       rng=1), {"cov": 2, "track_cov": 2}),
        "tracker.imm_combine": (tracker.imm_combine, dict(probability=prob, x=xi, cov=Pi),
                                {"cov": 4}),
        "tracker.imm_predict": (tracker.imm_predict,
                                dict(probability=prob, x=xi, cov=Pi,
                                     transition=[[0.9, 0.1], [0.1, 0.9]], dt=1.0,
                                     q=[0.1, 1.0]), {"cov": 4}),
        "tracker.imm_update": (tracker.imm_update,
                               dict(probability=prob, x=xi, cov=Pi, z=[0.0, 0.0], z_cov=eye2),
                               {"cov": 4, "z_cov": 2}),
        "tracker.kalman_predict": (tracker.kalman_predict,
                                   dict(x=np.zeros(4), cov=np.eye(4), dt=1.0, q=1.0), {"cov": 4}),
        "tracker.kalman_update": (tracker.kalman_update,
                                  dict(x=np.zeros(4), cov=np.eye(4), z=[0.0, 0.0], z_cov=eye2),
                                  {"cov": 4, "z_cov": 2}),
        "features.combined_proximity": (
            features.combined_proximity,
            dict(x1=[0.0, 0.0], x2=[1.0, 0.0], cov1=eye2, cov2=eye2, feature1=0.0,
                 feature2=0.5, feature_var1=1.0, feature_var2=1.0), {"cov1": 2, "cov2": 2}),
        "fusion.fuse_gaussian": (fusion.fuse_gaussian, dict(x=x2, cov=covs2), {"cov": 2}),
        "fusion.sample_reports_gaussian": (fusion.sample_reports_gaussian,
                                           dict(truth=[0.0, 0.0], cov=covs2, trials=3, rng=1),
                                           {"cov": 2}),
        "gating.gate_mahalanobis": (gating.gate_mahalanobis,
                                       dict(x1=x2, x2=x2, cov=eye2), {"cov": 2}),
        "gating.gate_pairwise": (gating.gate_pairwise,
                                    dict(x1=x2, x2=x2, cov1=covs2, cov2=eye2),
                                    {"cov1": 2, "cov2": 2}),
        "gating.gate_sparse": (gating.gate_sparse, dict(x1=x2, x2=x2, cov=eye2),
                                  {"cov": 2}),
        "grouping.binding_costs": (grouping.binding_costs,
                                   dict(x=xg, cov=cg, tracks=np.zeros((2, 2)),
                                        track_cov=np.broadcast_to(eye2, (2, 2, 2))),
                                   {"cov": 2, "track_cov": 2}),
        "grouping.group_bruteforce": (grouping.group_bruteforce, dict(x=xg, cov=cg), {"cov": 2}),
        "grouping.group_costs": (grouping.group_costs, dict(x=xg, cov=cg), {"cov": 2}),
        "grouping.group_sd": (grouping.group_sd, dict(x=xg, cov=cg), {"cov": 2}),
        "grouping.ml_group_cost": (grouping.ml_group_cost, dict(x=np.zeros((2, 2)),
                                                                cov=np.stack([eye2, eye2])),
                                   {"cov": 2}),
        "proximity.log_likelihood_measure_gaussian": (
            proximity.log_likelihood_measure_gaussian,
            dict(x1=[0.0, 0.0], x2=[1.0, 0.0], cov1=eye2, cov2=eye2), {"cov1": 2, "cov2": 2}),
        "proximity.proximity_gaussian": (proximity.proximity_gaussian,
                                         dict(x1=[0.0, 0.0], x2=[1.0, 0.0], cov1=eye2,
                                              cov2=eye2), {"cov1": 2, "cov2": 2}),
        "separated.pair_statistic": (separated.pair_statistic,
                                     dict(xy1=x2, cov1=covs2, xy2=x2, cov2=covs2),
                                     {"cov1": 2, "cov2": 2}),
        "trackfusion.bar_shalom_campo": (trackfusion.bar_shalom_campo,
                                         dict(x1=[0.0, 0.0], cov1=2 * eye2, x2=[1.0, 0.0],
                                              cov2=2 * eye2, cov12=0.5 * eye2), {"cov1": 2, "cov2": 2}),
        "trackfusion.blue_fusion": (trackfusion.blue_fusion,
                                    dict(x=np.zeros((2, 2)), cov=np.eye(4)),
                                    {"cov": 4}),
        "trackfusion.ci_weight": (trackfusion.ci_weight, dict(cov1=eye2, cov2=2 * eye2),
                                  {"cov1": 2, "cov2": 2}),
        "trackfusion.covariance_intersection": (
            trackfusion.covariance_intersection,
            dict(x1=[0.0, 0.0], cov1=eye2, x2=[1.0, 0.0], cov2=2 * eye2), {"cov1": 2, "cov2": 2}),
        "trackfusion.naive_fusion": (trackfusion.naive_fusion,
                                     dict(x1=[0.0, 0.0], cov1=eye2, x2=[1.0, 0.0], cov2=2 * eye2),
                                     {"cov1": 2, "cov2": 2}),
        "trackfusion.track_statistic": (trackfusion.track_statistic,
                                        dict(x1=[0.0, 0.0], cov1=eye2, x2=[1.0, 0.0],
                                             cov2=2 * eye2), {"cov1": 2, "cov2": 2}),
        "trackfusion.cross_covariance": (
            trackfusion.cross_covariance,
            dict(F=m.F, Q=m.Q, H1=h, R1=one, H2=h, R2=one, steps=3, P1_0=eye2, P2_0=eye2),
            {"R1": 1, "R2": 1, "P1_0": 2, "P2_0": 2}),
        "trackfusion.simulate_tracks": (
            trackfusion.simulate_tracks,
            dict(F=m.F, Q=m.Q, H1=h, R1=one, H2=h, R2=one, steps=3, trials=2, P1_0=eye2,
                 P2_0=eye2, rng=1), {"R1": 1, "R2": 1, "P1_0": 2, "P2_0": 2}),
        "tracking.track_reports": (tracking.track_reports, _tracking_reports(),
                                   {"cov": 3}),
        "tracking.track_then_fuse": (tracking.track_then_fuse,
                                     dict(_tracking_reports(), period=5.0), {"cov": 3}),
        "tracking.fuse_then_track": (tracking.fuse_then_track,
                                     dict(_tracking_reports(), window=5.0), {"cov": 3}),
    }
    one_sector = continent.Sectors([-1.0, 3000.0], [-1.0, 1.0], overlap=0.0)
    for name in ("continent.track_sectored", "continent.sectors.track_sectored"):
        calls[name] = (continent.track_sectored,
                       dict(_tracking_reports(), sectors=one_sector), {"cov": 3})
    calls |= {
        "plotting.plot_covariance_ellipse": (
            _on_axes(plotting.plot_covariance_ellipse), dict(mean=[0.0, 0.0], cov=eye2),
            {"cov": 2}),
        "plotting.plot_groups": (
            _on_axes(plotting.plot_groups),
            dict(x=xg, cov=cg, groups=np.array([[0, 0], [1, 1]])), {"cov": 2}),
        "plotting.plot_scene": (_on_axes(plotting.plot_scene),
                                dict(reports=[x2], covariances=[covs2]), {"covariances": 2}),
    }
    return calls


def _on_axes(fn):
    """Call a plotting function on a fresh axes (closed afterwards)."""
    def call(**kwargs):
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots()
        try:
            return fn(ax, **kwargs)
        finally:
            plt.close(fig)
    return call


def test_every_public_covariance_argument_is_under_the_one_rule():
    """The table of valid calls covers every public function with a covariance argument."""
    found, unclassified = _public_covariance_parameters()
    assert not unclassified, ("arguments named like a covariance, in neither "
                              f"COVARIANCE_ARGUMENTS nor NOT_COVARIANCES: {unclassified}")
    calls = _valid_calls()
    covered = {(q, arg) for q, (_, _, dims) in calls.items() for arg in dims}
    missing = set(found) - covered - set(COVARIANCE_EXEMPT) - {   # needs the [stonesoup] extra
        ("tracking.stonesoup_track", "cov"), ("tracking.stonesoup.stonesoup_track",
                                                     "cov")}
    assert len(found) >= 50, len(found)
    assert not missing, f"no valid call in _valid_calls() for {sorted(missing)}"


def _covariance_cases():
    calls = _valid_calls()
    out = []
    for qualname, (fn, kwargs, dims) in calls.items():
        for arg, d in dims.items():
            for label, bad in _bad_covariances(d).items():
                whole = qualname in WHOLE_FLOAT_RANGE and label.startswith("variance")
                out.append(pytest.param(fn, kwargs, arg, bad, whole,
                                        id=f"{qualname}-{arg}-{label}"))
    return out


def _finite(result) -> bool:
    """Every number a result holds (fields of a dataclass, arrays, scalars) is finite."""
    import dataclasses

    if dataclasses.is_dataclass(result):
        return all(_finite(getattr(result, f.name)) for f in dataclasses.fields(result))
    if isinstance(result, (tuple, list)):
        return all(_finite(r) for r in result)
    arr = np.asarray(result)
    return arr.dtype.kind not in "fc" or bool(np.all(np.isfinite(arr)))


@pytest.mark.parametrize(("fn", "kwargs", "arg", "bad", "whole_range"), _covariance_cases())
def test_the_same_bad_covariance_is_refused_by_name_everywhere(fn, kwargs, arg, bad,
                                                               whole_range):
    """Refused naming the argument; a whole-float-range function may answer, finitely."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fn(**kwargs)                                   # the valid call passes
        if arg == "covariances":                      # a list of stacks, one per sensor
            value = [np.broadcast_to(bad, np.shape(c)).copy() for c in kwargs[arg]]
        else:
            value = np.broadcast_to(bad, np.shape(kwargs[arg])).copy()
        if whole_range:
            refusal, result = None, None
            try:
                result = fn(**{**kwargs, arg: value})
            except ValueError as exc:
                refusal = str(exc)
            if refusal is not None:
                assert f"`{arg}`" in refusal, refusal
            else:
                assert _finite(result), f"a variance of {bad[0, 0]:g} gave a non-finite result"
            return
        with pytest.raises(ValueError, match=rf"`{arg}(\[\d+\])?` must"):
            fn(**{**kwargs, arg: value})
