"""Trust at the edges: extreme but legal magnitudes, wrong-but-plausible input, and names.

Each case was a silent wrong value, a raw library error or a message naming an internal
argument. A representable answer must be computed; otherwise the refusal names the public
argument and the value received. Reference values come from closed forms typed in here.
"""

from __future__ import annotations

import inspect
import warnings

import numpy as np
import pytest

from radarfusion_ref import registration as rg
from radarfusion_ref import trackfusion as tf
from radarfusion_ref.engine.tracker import kalman_predict

SITES = np.array([[0.0, 0.0], [30.0, 0.0]])
OBJS = np.array([[0.0, 60.0], [30.0, 70.0], [-20.0, 50.0], [10.0, 80.0], [45.0, 55.0]])


# --------------------------------------------------------------------------- registration
def test_wrongly_associated_reports_are_refused_by_name():
    # radar 1's reports shuffled: once refused naming the internal `jac_object`
    z = rg.draw_biased_reports(SITES, OBJS, [[0.3, 1e-3, 2e-3], [-0.2, 0, 0]], 0.05, 1e-3,
                               rng=1)
    z[1] = z[1][np.random.default_rng(8).permutation(len(OBJS))]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match=r"^`reports`: these reports do not determine.*"
                                             r"association") as err:
            rg.estimate_biases(SITES, z, 0.05, 1e-3)
    assert "jac_object" not in str(err.value)


@pytest.mark.parametrize(("sigma_r", "sigma_beta", "name"),
                         [(1e-200, 1e-3, "sigma_r"), (0.05, 1e-200, "sigma_beta"),
                          (1e-160, 1e-3, "sigma_r")])
def test_information_at_tiny_sigmas_is_refused_by_name(sigma_r, sigma_beta, name):
    # bias_information returned NaN; observability then reported rank 0 ("nothing seen")
    for call in (lambda: rg.bias_information(SITES, OBJS, sigma_r, sigma_beta),
                 lambda: rg.observability(SITES, OBJS, sigma_r, sigma_beta)):
        with pytest.raises(ValueError, match=rf"`{name}`.*1e-[12][0-9]0"):
            call()


def test_information_at_small_but_representable_sigmas_is_computed():
    # 1e-100 m and 1e-100 rad: information ~1e200, representable; rank as at ordinary sigmas
    J = rg.bias_information(SITES, OBJS, 1e-100, 1e-100)
    assert np.all(np.isfinite(J))
    assert rg.observability(SITES, OBJS, 1e-100, 1e-100).rank == 6


def test_apply_and_remove_biases_never_return_inf():
    # (1 + g) r + dr overflowed to inf silently
    with pytest.raises(ValueError, match=r"`r`.*`biases`.*1e\+308"):
        rg.apply_biases(1e308, 0.1, [0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match=r"`r_hat`.*`biases`.*1e\+308"):
        rg.remove_biases(1e308, 0.1, [0.0, -0.9, 0.0])
    r, b = rg.apply_biases(1e307, 0.1, [0.0, 1.0, 0.0])           # 2e307: representable
    assert float(r) == pytest.approx(2e307, rel=1e-15) and float(b) == 0.1


# --------------------------------------------------------------------------- own names
_P = np.array([[2.0, 0.3], [0.3, 1.0]])
_F, _Q = np.array([[1.0, 1.0], [0.0, 1.0]]), np.array([[0.25, 0.5], [0.5, 1.0]])
_H, _R = np.array([[1.0, 0.0]]), np.array([[4.0]])
_Z = rg.draw_biased_reports(SITES, OBJS, np.zeros((2, 3)), 0.05, 1e-3, rng=0)
_B = np.zeros((2, 3))

#: A valid call of every public function of registration and trackfusion, by keyword.
VALID = {
    rg.apply_biases: dict(r=100.0, beta=0.5, biases=[0.2, 1e-3, 0.01]),
    rg.remove_biases: dict(r_hat=100.0, beta_hat=0.5, biases=[0.2, 1e-3, 0.01]),
    rg.true_polar: dict(sensors=SITES, targets=OBJS),
    rg.bias_displacement: dict(sensors=SITES, targets=OBJS, biases=_B),
    rg.bias_information: dict(sensors=SITES, targets=OBJS, sigma_r=0.05, sigma_beta=1e-3,
                              biases=_B),
    rg.observability: dict(sensors=SITES, targets=OBJS, sigma_r=0.05, sigma_beta=1e-3,
                           fixed=np.zeros((2, 3), bool)),
    rg.noncentrality: dict(sensors=SITES, targets=OBJS, biases=_B, sigma_r=0.05,
                           sigma_beta=1e-3),
    rg.cost_matrix: dict(sensors=SITES, reports1=_Z[0], reports2=_Z[1], sigma_r=0.05,
                         sigma_beta=1e-3, biases=_B),
    rg.to_cartesian: dict(sensors=SITES, reports=_Z, sigma_r=0.05, sigma_beta=1e-3, biases=_B),
    rg.draw_biased_reports: dict(sensors=SITES, targets=OBJS, biases=_B, sigma_r=0.05,
                                 sigma_beta=1e-3, trials=2, rng=1),
    rg.estimate_biases: dict(sensors=SITES, reports=_Z, sigma_r=0.05, sigma_beta=1e-3,
                             fixed=np.zeros((2, 3), bool), initial=_B, max_iter=50, tol=1e-10),
    rg.reduced_information: dict(jac_bias=np.ones((2, 1, 2, 3)),
                                 jac_object=np.broadcast_to(np.eye(2), (2, 1, 2, 2))),
    rg.simulate_scene: dict(sensors=SITES, targets=OBJS, biases=_B, sigma_r=0.05,
                            sigma_beta=1e-3, p_detect=0.9, rng=1),
    rg.register_and_associate: dict(sensors=SITES, reports1=_Z[0], reports2=_Z[1], sigma_r=0.05,
                                    sigma_beta=1e-3, fixed=np.zeros((2, 3), bool), initial=_B,
                                    p_false_reject=1e-3, max_iter=20, on_failure="warn"),
    rg.association_accuracy: dict(sensors=SITES, biases=_B, sigma_r=0.05, sigma_beta=1e-3,
                                  n_objects=4, region=[[-20, 40], [50, 90]], trials=2,
                                  p_detect=1.0, p_false_reject=1e-3,
                                  fixed=np.zeros((2, 3), bool), rng=1),
    tf.naive_fusion: dict(x1=[0.0, 1.0], cov1=_P, x2=[1.0, 0.0], cov2=np.eye(2)),
    tf.bar_shalom_campo: dict(x1=[0.0, 1.0], cov1=_P, x2=[1.0, 0.0], cov2=np.eye(2),
                              cov12=0.2 * np.eye(2)),
    tf.covariance_intersection: dict(x1=[0.0, 1.0], cov1=_P, x2=[1.0, 0.0], cov2=np.eye(2),
                                     criterion="det", omega=0.5),
    tf.ci_weight: dict(cov1=_P, cov2=np.eye(2), criterion="trace"),
    tf.track_statistic: dict(x1=[0.0, 1.0], cov1=_P, x2=[1.0, 0.0], cov2=np.eye(2),
                             cov12=0.2 * np.eye(2)),
    tf.blue_fusion: dict(x=[[0.0, 1.0], [1.0, 0.0]],
                         cov=np.block([[_P, 0.2 * np.eye(2)], [0.2 * np.eye(2), np.eye(2)]])),
    tf.constant_velocity: dict(dt=1.0, q=0.5, dim=1, noise="continuous"),
    # the prediction chapter 10 aligns tracks with (the engine's one home of it)
    kalman_predict: dict(x=[0.0, 1.0], cov=_P, dt=1.0, q=0.5, noise="continuous"),
    tf.cross_covariance: dict(F=_F, Q=_Q, H1=_H, R1=_R, H2=_H, R2=2 * _R, steps=3,
                              P1_0=10 * np.eye(2), P2_0=10 * np.eye(2), P12_0=np.zeros((2, 2))),
    tf.simulate_tracks: dict(F=_F, Q=_Q, H1=_H, R1=_R, H2=_H, R2=2 * _R, steps=3, trials=2,
                             P1_0=10 * np.eye(2), P2_0=10 * np.eye(2), x0=[0.0, 1.0], rng=1),
}
BAD = ["abc", np.nan, [[1.0, 2.0], [3.0]], np.full((3, 5, 7), 0.5)]
#: Element-wise arguments: an array of another shape is a batch, not bad input.
BATCH = {(rg.apply_biases, "r"), (rg.apply_biases, "beta"), (rg.remove_biases, "r_hat"),
         (rg.remove_biases, "beta_hat"), (tf.constant_velocity, "dt"),
         (tf.constant_velocity, "q"), (kalman_predict, "dt"), (kalman_predict, "q")}


def test_every_public_function_has_a_valid_call_here():
    public = {getattr(m, n) for m in (rg, tf) for n in m.__all__
              if inspect.isfunction(getattr(m, n))}
    assert public | {kalman_predict} == set(VALID)
    for fn, kw in VALID.items():
        assert set(kw) == set(inspect.signature(fn).parameters), fn.__name__
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fn(**kw)


@pytest.mark.parametrize(("fn", "arg"), [(fn, a) for fn, kw in VALID.items() for a in kw],
                         ids=[f"{fn.__name__}-{a}" for fn, kw in VALID.items() for a in kw])
def test_bad_input_to_each_argument_is_refused_under_its_own_name(fn, arg):
    for bad in BAD[:3] if (fn, arg) in BATCH else BAD:
        kw = dict(VALID[fn], **{arg: bad})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with pytest.raises((ValueError, TypeError)) as err:
                fn(**kw)
        assert f"`{arg}`" in str(err.value), (repr(bad)[:40], str(err.value))


# --------------------------------------------------------------------------- trackfusion
HUGE_X = dict(x1=[1e308, 0.0], x2=[-1e308, 0.0])


@pytest.mark.parametrize("rule", [tf.naive_fusion, tf.bar_shalom_campo,
                                  tf.covariance_intersection, tf.track_statistic])
def test_fusion_rules_never_return_inf_or_nan(rule):
    # bar_shalom_campo returned [-inf, nan] for tracks at +-1e308 (x2 - x1 overflowed)
    kw = dict(VALID[rule], **HUGE_X)
    with pytest.raises(ValueError, match=r"`x1`.*2\*\*150"):
        rule(**kw)
    for P in (1e-310 * np.eye(2), 1e300 * np.eye(2)):        # subnormal / huge variances
        with pytest.raises(ValueError, match=r"`cov1`.*numeric domain"):
            rule(**dict(VALID[rule], cov1=P))
    # inside the domain, at its extremes: finite, and the closed form for equal covariances
    big = dict(VALID[rule], x1=[2.0**149, 0.0], x2=[-(2.0**149), 0.0], cov1=np.eye(2),
               cov2=np.eye(2))
    if rule is tf.bar_shalom_campo:
        big["cov12"] = 0.5 * np.eye(2)
    out = rule(**big)
    if rule is tf.track_statistic:
        assert np.isfinite(out) or out == pytest.approx(0.0)
    else:
        np.testing.assert_allclose(out.estimate, [0.0, 0.0], atol=1e-9 * 2.0**149)
        assert np.all(np.isfinite(out.covariance))


@pytest.mark.filterwarnings("ignore:.*singular or nearly so")
@pytest.mark.parametrize(("sigma_r", "sigma_beta"), [(1e-30, 1e-3), (0.05, 1e-30)])
def test_cost_matrix_blames_the_sigmas_for_singular_report_covariances(sigma_r, sigma_beta):
    # the refusal named `reports1`, whose values were fine
    z = rg.draw_biased_reports(SITES, OBJS, np.zeros((2, 3)), 0.05, 1e-3, rng=1)
    with pytest.raises(ValueError, match=r"^`sigma_r`, `sigma_beta`.*1e-30"):
        rg.cost_matrix(SITES, z[0], z[1], sigma_r, sigma_beta)


# --------------------------------------------------------------------------- metrics
def test_nees_refuses_under_its_own_argument_names():
    from radarfusion_ref.engine.metrics import nees

    # the refusal named `d`, the engine kernel's argument
    with pytest.raises(ValueError, match=r"^`error`.*2\*\*150"):
        nees([[1e200, 0.0]], [np.eye(2)])
    with pytest.raises(ValueError, match=r"^`cov`.*1e-300"):
        nees([[1.0, 0.0]], [1e-300 * np.eye(2)])
    # at the edge of the domain: the closed form e^2 / var
    r = nees([[2.0**140, 0.0]], [2.0**140 * np.eye(2)])
    assert r.values[0] == 2.0**140


@pytest.mark.parametrize("k", [1e-10, 1e10, 1e20])
def test_bias_estimate_at_extreme_units_is_computed(k):
    # an absolute determinant test once refused the right association at extreme units ("object
    # 0's position is not fixed"); inside the numeric domain the estimate is the same in any unit
    z = rg.draw_biased_reports(SITES, OBJS, [[1.0, 0, 0], [0, 0, 0]], 0.05, 1e-3, rng=1)
    ref = rg.estimate_biases(SITES, z, 0.05, 1e-3).biases
    est = rg.estimate_biases(SITES * k, z * [k, 1.0], 0.05 * k, 1e-3).biases
    np.testing.assert_allclose(est / [k, 1.0, 1.0], ref, rtol=1e-9, atol=1e-12)


def test_ranges_beyond_the_numeric_domain_are_refused_by_name():
    z = rg.draw_biased_reports(SITES, OBJS, [[1.0, 0, 0], [0, 0, 0]], 0.05, 1e-3, rng=1)
    with pytest.raises(ValueError, match=r"^`reports`: ranges .* numeric domain .* received a range of [0-9.]+e\+151"):
        rg.estimate_biases(SITES * 1e150, z * [1e150, 1.0], 0.05 * 1e150, 1e-3)


@pytest.mark.parametrize("k", [1e-300, 1e300])
def test_information_outside_float64_is_refused_naming_sigma_r(k):
    # at 1e300 the refusal named the internal `jac_object`
    for call in (lambda: rg.observability(SITES * k, OBJS * k, 0.05 * k, 1e-3),
                 lambda: rg.bias_information(SITES * k, OBJS * k, 0.05 * k, 1e-3)):
        with pytest.raises(ValueError, match=r"^`sigma_r` = 5e[+-]"):
            call()


def test_noncentrality_outside_the_domain_names_the_sigmas():
    # the refusal named the kernel's `cov`
    k = 1e150
    with pytest.raises(ValueError, match=r"^`sigma_r`, `sigma_beta`.*numeric domain"):
        rg.noncentrality(SITES * k, OBJS * k, [[k, 0, 0], [0, 0, 0]], 0.05 * k, 1e-3)


# --------------------------------------------------------------------------- scenes
def test_scene_spacing_and_sigmas_outside_the_domain_are_refused_by_name():
    from radarfusion_ref.engine import scenes as sc

    # a spacing of 1e308 gave inf positions (line) or numpy's OverflowError (uniform)
    for layout in ("line", "uniform"):
        with pytest.raises(ValueError, match=r"^`spacing`.*2\*\*150.*inf"):
            sc.two_radar_scene(5, spacing=1e308, layout=layout, sigma1=1, sigma2=1, rng=1)
    with pytest.raises(ValueError, match=r"^`sigma1`.*2\*\*150.*1e\+300"):
        sc.two_radar_scene(5, spacing=1.0, sigma1=1e300, sigma2=1, rng=1)
    with pytest.raises(ValueError, match=r"^`spacing`.*2\*\*150.*inf"):
        sc.grouping_scene(3, 2, spacing=1e308, cov=np.eye(2)[None, None], rng=1)
    # at the edge of the domain the scene is drawn, finite
    s = sc.two_radar_scene(4, spacing=2.0**148, sigma1=2.0**140, sigma2=1, rng=1)
    assert np.all(np.isfinite(s.reports1)) and s.truth[0, 3, 0] == 3 * 2.0**148


def test_clutter_box_and_false_counts_that_overflow_are_refused_by_name():
    from radarfusion_ref.engine import scenes as sc

    # ceil(inf) raised a raw OverflowError
    with pytest.raises(ValueError, match=r"^`spacing`, `dim`.*volume.*1e\+40, dim 9"):
        sc.two_radar_clutter_scene(5, spacing=1e40, sigma1=1, sigma2=1, dim=9, rng=1)
    with pytest.raises(ValueError, match=r"^`false_density1`.*overflows.*1e\+308"):
        sc.two_radar_clutter_scene(5, spacing=1.0, sigma1=1, sigma2=1, false_density1=1e308,
                                   rng=1)


def test_huge_grouping_scenes_are_refused_before_cov_is_broadcast():
    from radarfusion_ref.engine import scenes as sc

    # broadcasting and checking `cov` asked for 7.45 GiB before the size check ran
    with pytest.raises(ValueError, match=r"refused: .* bytes of scenes .*`trials`"):
        sc.grouping_scene(10**9, 2, cov=np.eye(2)[None, None], trials=10**9, rng=1)
    with pytest.raises(ValueError, match=r"refused: .* bytes of scenes"):
        sc.grouping_scene(10**5, 10**4, cov=np.eye(2)[None, None], rng=1)


def test_binding_hypotheses_refuses_huge_counts_without_forming_them():
    from radarfusion_ref.engine import scenes as sc

    # (10**9)! was computed exactly before the limit was compared (it never returned)
    with pytest.raises(ValueError, match=r"^refused: about 10\*\*\d+ binding hypotheses.*"
                                         r"`n_targets` n = 1000000000.*group_sd"):
        sc.binding_hypotheses(10**9, 10**9)
    with pytest.raises(ValueError, match=r"above the limit of 1000000"):
        sc.binding_hypotheses(7, 2)                       # 25 401 600
    assert sc.binding_hypotheses(6, 2).shape == (518400, 2, 6)


def test_nearest_neighbour_pairing_outside_the_domain_and_memory_is_refused():
    from radarfusion_ref.engine import scenes as sc

    # squared differences overflowed to inf and argmin picked index 0: a wrong pairing
    with pytest.raises(ValueError, match=r"^`reports1`.*2\*\*150.*1e\+300"):
        sc.nearest_neighbour_pairing([[-1e300]], [[1e300], [5e299]])
    assert sc.nearest_neighbour_pairing([[-(2.0**149)]], [[2.0**149], [2.0**148]]).tolist() == [1]
    # broadcast views of 10**8 x 10**8 reports: refused before any copy or finiteness mask
    with pytest.raises(ValueError, match=r"^refused: .*bytes of reports.*`reports1`"):
        sc.nearest_neighbour_pairing(np.zeros((10**8, 1, 1)),
                                     np.broadcast_to(np.zeros((1, 1)), (10**8, 10**8, 1)))
    with pytest.raises(ValueError, match=r"^refused: .*1000000 scenes"):
        sc.nearest_neighbour_pairing(np.broadcast_to(np.zeros((1, 1, 1)), (10**6, 10**3, 1)),
                                     np.zeros((1, 1)))
    with pytest.raises(ValueError, match=r"^`reports1` and `reports2`.*broadcast"):
        sc.nearest_neighbour_pairing(np.zeros((3, 1, 1)), np.zeros((2, 1, 1)))


def test_a_target_at_a_radar_site_is_refused_naming_targets():
    from radarfusion_ref.engine import scenes as sc
    from radarfusion_ref.engine.geometry import Geometry

    # polar_scene refused naming polar_from's `xy` and `origin`, not its own arguments
    for target, k in (([0.0, 0.0], 1), ([30.0, 0.0], 2)):
        with pytest.raises(ValueError, match=rf"^`targets` must lie off radar {k}'s site"):
            Geometry(30.0, 0.0, [target, [100.0, 100.0]])
    rep = sc.polar_scene(Geometry(30.0, 0.0, [[1e-3, 0.0]]), sigma_r=1e-5, sigma_beta=0.01,
                         rng=1)
    assert np.all(np.isfinite(rep.r1))


# --------------------------------------------------------------------------- capstone radars
@pytest.mark.parametrize("field", ["sigma_r", "max_range", "clutter_rate", "sigma_feature",
                                   "bias_range", "height"])
def test_radar_lengths_beyond_the_domain_are_refused_by_field(field):
    import dataclasses

    from radarfusion_ref.capstone import radars as ra

    # sigma_r = 1e308 gave inf ranges, max_range = 1e200 an inf clutter range and an
    # OverflowError from coverage_volume, clutter_rate = 1e308 an OverflowError
    bad = [dataclasses.replace(r, **{field: 1e200}) for r in ra.default_radars()]
    with pytest.raises(ValueError, match=rf"^`radars\[0\]\.{field}`.*2\*\*150.*1e\+200"):
        ra.as_radars(bad)
    assert np.isfinite(ra.default_radars(max_range=2.0**150)[0].coverage_volume)


# --------------------------------------------------------------------------- S-D assignment
def test_sd_counts_beyond_memory_are_refused_before_allocation():
    from radarfusion_ref.engine.assignment import assign_s_lists

    # counts of 10**9 reports per source asked numpy for 2.79 GiB of per-report masks
    with pytest.raises(ValueError, match=r"^`counts`: refused: .*3000000000 reports"):
        assign_s_lists(np.zeros(1), np.zeros((1, 3), int), counts=[10**9] * 3)
    ok = assign_s_lists(np.zeros(2), np.array([[0, 0, 0], [1, 1, 1]]), counts=[2, 2, 2])
    assert ok.groups.tolist() == [[0, 0, 0], [1, 1, 1]]


def test_a_scene_without_targets_is_refused_naming_targets():
    # numpy's "high <= 0" escaped from the draw that keeps one report
    with pytest.raises(ValueError, match=r"^`targets` must have shape \(n, 2\) with n >= 1"):
        rg.simulate_scene(SITES, np.zeros((0, 2)), np.zeros((2, 3)), 0.05, 1e-3, p_detect=0.9,
                          rng=1)


def test_a_traffic_integer_beyond_64_bits_is_refused_naming_path(tmp_path):
    import gzip

    from radarfusion_ref.capstone.traffic import COLUMNS, load_traffic

    # every character a digit, but beyond int64: a bare StopIteration escaped
    row = ["99999999999999999999", "abc123", "CALL1", "4600000", "700000", "35000", "450", "90"]
    f = tmp_path / "t.csv.gz"
    f.write_bytes(gzip.compress((",".join(COLUMNS) + "\n" + ",".join(row) + "\n").encode()))
    with pytest.raises(ValueError, match=r"^`path` .*column 't_s', row 2: "
                                         r"'99999999999999999999' lies beyond the 64-bit"):
        load_traffic(f)


# --------------------------------------------------------------------------- association
def test_proximity_matrix_outside_the_domain_names_its_own_arguments():
    from radarfusion_ref.association import proximity_matrix

    # 1e300 reports were refused naming the engine's `x2`; a sigma of 1e200 raised a raw
    # OverflowError from its square
    with pytest.raises(ValueError, match=r"^`reports2` must lie within the numeric domain"):
        proximity_matrix(np.zeros((2, 2)), np.full((2, 2), 1e300), 1.0, 1.0)
    with pytest.raises(ValueError, match=r"^`sigma1` squared .*numeric domain.*1\.e\+200"):
        proximity_matrix(np.zeros((2, 2)), np.ones((2, 2)), 1e200, 1.0)
    with pytest.raises(ValueError, match=r"^`sigma2` squared"):
        proximity_matrix(np.zeros((2, 2)), np.ones((2, 2)), 1.0, [1e-100, 1.0])
    # inside it: the closed form |x1 - x2|^2 / (sigma1^2 + sigma2^2)
    out = proximity_matrix(np.zeros((1, 2)), np.full((1, 2), 2.0**70), 2.0**70, 2.0**70)
    assert out[0, 0] == pytest.approx(1.0, rel=1e-12)


# --------------------------------------------------------------------------- capstone detections
def test_detection_windows_beyond_memory_or_numbering_are_refused_by_name():
    from radarfusion_ref.capstone import load_traffic, realistic_radars, simulate_detections

    traffic, radars = load_traffic(), realistic_radars()
    # numpy's "Maximum allowed size exceeded" escaped from the scans' np.arange
    with pytest.raises(ValueError, match=r"^`start`, `duration`, `radars\[0\]\.period`.*1e\+154"):
        simulate_detections(traffic, radars, duration=1e154, rng=1)
    # a far start was refused naming truth_at's `times`, with an empty object array
    with pytest.raises(ValueError, match=r"^`start`, `duration`"):
        simulate_detections(traffic, radars, start=1e154, duration=10.0, rng=1)
    with pytest.raises(ValueError, match=r"^refused: .*scans of radar 0.*`duration` = 1e\+09"):
        simulate_detections(traffic, radars, duration=1e9, rng=1)


# --------------------------------------------------------------------------- grouping
def test_binding_costs_outside_the_domain_names_its_own_arguments():
    from radarfusion_ref.grouping import binding_costs

    # the refusals named the engine's `x1` and `cov1`
    eye, x = np.eye(2), np.zeros((2, 2, 2))
    c = np.broadcast_to(eye, (2, 2, 2, 2))
    with pytest.raises(ValueError, match=r"^`x` and `tracks` must lie within the numeric domain"):
        binding_costs(x, c, np.full((2, 2), 1e300), np.broadcast_to(eye, (2, 2, 2)))
    with pytest.raises(ValueError, match=r"^`cov` and `track_cov` must have every variance"):
        binding_costs(x, c, np.zeros((2, 2)), np.broadcast_to(1e300 * eye, (2, 2, 2)))


def test_ml_group_cost_never_returns_inf():
    from radarfusion_ref.grouping import ml_group_cost

    # reports at +-1e300 gave a cost of inf
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(ValueError, match=r"^`x` and `cov`: 1 candidate group costs exceed"):
            ml_group_cost(np.array([[1e300, 0.0], [-1e300, 0.0]]),
                          np.broadcast_to(np.eye(2), (2, 2, 2)))
    # two unit-variance reports 2 apart: 2**2 / 2 + ln det W (W = 2), ln det C_i = 0
    c = ml_group_cost([[0.0], [2.0]], [[[1.0]], [[1.0]]])
    assert float(c) == pytest.approx(2.0 + np.log(2.0), rel=1e-12)
