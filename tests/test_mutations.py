"""The executed book can fail: break one core function per chapter, and the chapter must stop.

Each entry perturbs one package function slightly (a variance scaled by 1 %, a
sign flipped) in the chapter's kernel, before the chapter's first cell, and
replaces it everywhere the package refers to it. The chapter must then fail
*at one of its own checks* — a :class:`radarfusion_ref.kit.checks.CheckError` —
not at some unrelated error. This proves that the chapter's verification,
hidden from the page, is live.
"""

from __future__ import annotations

import textwrap

import pytest
from book_tools import ROOT, execute_chapters, selected

#: chapter (``page`` or ``page:variant`` for a further mutation of the same page) →
#: (module, function, wrapper). The wrapper is Python source of a
#: function ``wrap(f)`` returning the perturbed function (``np``, ``dataclasses``
#: and ``functools`` are available to it).
MUTATIONS = {
    "book/01_fusion": ("radarfusion_ref.fusion", "fuse", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                r = f(*a, **k)
                return dataclasses.replace(r, variance=np.asarray(r.variance) * 1.01)
            return g
        """),
    "book/02_proximity": ("radarfusion_ref.proximity", "proximity", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/03_gating": ("radarfusion_ref.gating", "gate_threshold", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/04_association": ("radarfusion_ref.engine.assignment", "assign_two_lists", """
        def wrap(f):
            @functools.wraps(f)
            def g(cost, *a, **k):
                c = np.asarray(cost, dtype=float)   # costs tilted by up to 1 % across columns
                return f(c * (1.0 + 0.01 * np.linspace(0.0, 1.0, c.shape[-1])), *a, **k)
            return g
        """),
    "book/05_features": ("radarfusion_ref.features", "type_posterior", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    # plausible variants, chapters 01–05
    # standard deviations passed where variances belong: weights sigma^-1, not sigma^-2
    "book/01_fusion:sigma-weights": ("radarfusion_ref.fusion", "fuse", """
        def wrap(f):
            @functools.wraps(f)
            def g(x, var):
                return f(x, np.sqrt(np.asarray(var, dtype=float)))
            return g
        """),
    # vector fusion per axis: the off-diagonal (correlation) terms of each covariance dropped
    "book/01_fusion_vector:diagonal-only": ("radarfusion_ref.fusion", "fuse_gaussian", """
        def wrap(f):
            @functools.wraps(f)
            def g(x, cov):
                c = np.asarray(cov, dtype=float)
                return f(x, c * np.eye(c.shape[-1]))
            return g
        """),
    # the first report's covariance counted twice (2 C1 for C1 + C2): wrong only when unequal
    "book/02_proximity:cov1-twice": ("radarfusion_ref.proximity", "proximity_gaussian", """
        def wrap(f):
            @functools.wraps(f)
            def g(x1, x2, cov1, cov2):
                return f(x1, x2, cov1, cov1)
            return g
        """),
    # the profile measure without its ln(sigma_1 sigma_2) term (the missing ln det)
    "book/02_proximity_marginal:profile-no-logdet": ("radarfusion_ref.proximity",
                                                     "log_likelihood_measure", """
        def wrap(f):
            @functools.wraps(f)
            def g(x1, x2, var1, var2, *, kind="profile"):
                r = f(x1, x2, var1, var2, kind=kind)
                if kind != "profile":
                    return r
                return r + 0.5 * (np.log(np.asarray(var1, dtype=float))
                                  + np.log(np.asarray(var2, dtype=float)))
            return g
        """),
    # the gate's degree of freedom ignored: the 1-D threshold used in every dimension
    "book/03_gating:dof-ignored": ("radarfusion_ref.gating", "gate_threshold", """
        def wrap(f):
            @functools.wraps(f)
            def g(p_false_reject, dof=1):
                return f(p_false_reject, np.ones_like(np.asarray(dof)))
            return g
        """),
    # the distance passed where its square (the noncentrality) belongs
    "book/03_gating:distance-not-squared": ("radarfusion_ref.gating", "p_false_accept", """
        def wrap(f):
            @functools.wraps(f)
            def g(noncentrality, dof=1, p_false_reject=0.01):
                return f(np.sqrt(np.asarray(noncentrality, dtype=float)), dof, p_false_reject)
            return g
        """),
    # ln det(2 pi S) counted once instead of once per dimension d (right only in 1-D)
    "book/04_association_logdet:logdet-once": ("radarfusion_ref.association",
                                               "proximity_matrix", """
        def wrap(f):
            @functools.wraps(f)
            def g(reports1, reports2, sigma1, sigma2, *, logdet=False):
                r = np.asarray(f(reports1, reports2, sigma1, sigma2, logdet=logdet))
                if not logdet:
                    return r
                r0 = np.asarray(f(reports1, reports2, sigma1, sigma2, logdet=False))
                return r0 + (r - r0) / np.shape(reports1)[-1]
            return g
        """),
    # a report's object term without (1 - P_other): the other sensor's miss left out
    "book/04_association_clutter:miss-factor": ("radarfusion_ref.association",
                                                "non_assignment_cost", """
        def wrap(f):
            @functools.wraps(f)
            def g(*, p_detect1, p_detect2, false_density1, false_density2, object_density,
                  **k):
                r = f(p_detect1=p_detect1, p_detect2=p_detect2, false_density1=false_density1,
                      false_density2=false_density2, object_density=object_density, **k)
                p1, p2 = np.asarray(p_detect1, float), np.asarray(p_detect2, float)
                l1, l2 = np.asarray(false_density1, float), np.asarray(false_density2, float)
                b = np.asarray(object_density, float)
                r = r + np.log((l1 + b * p1 * (1 - p2)) / (l1 + b * p1))
                r = r + np.log((l2 + b * p2 * (1 - p1)) / (l2 + b * p2))
                return float(r) if np.ndim(r) == 0 else r
            return g
        """),
    # the posterior from the type spread alone: the feature's measurement variance not added
    "book/05_features:no-feature-var": ("radarfusion_ref.features", "type_posterior", """
        def wrap(f):
            @functools.wraps(f)
            def g(feature, feature_var, *a, **k):
                return f(feature, 0.0 * np.asarray(feature_var, dtype=float), *a, **k)
            return g
        """),
    # the agreement without the division by the prior: sum_k P1_k P2_k, not / p_k
    "book/05_features_models:prior-not-divided": ("radarfusion_ref.features",
                                                  "type_agreement", """
        def wrap(f):
            @functools.wraps(f)
            def g(feature1, feature_var1, feature2, feature_var2, type_means, type_vars,
                  priors=None):
                from radarfusion_ref.features import type_posterior
                p1 = type_posterior(feature1, feature_var1, type_means, type_vars, priors)
                p2 = type_posterior(feature2, feature_var2, type_means, type_vars, priors)
                r = -2.0 * np.log(np.sum(np.asarray(p1) * np.asarray(p2), axis=-1))
                return float(r) if np.ndim(r) == 0 else r
            return g
        """),
    # the misweighted variance with the weights not squared: sum_i w_i sigma_i^2
    "book/01_fusion_misweight:weights-not-squared": ("radarfusion_ref.fusion", "misweighted", """
        def wrap(f):
            @functools.wraps(f)
            def g(var_true, var_assumed):
                r = f(var_true, var_assumed)
                actual = np.sum(r.weights * np.asarray(var_true, dtype=float), axis=-1)
                return dataclasses.replace(r, actual_variance=actual)
            return g
        """),
    # hypothesis weights exp(-C/2), as for a proximity, where the costs are -ln L: exp(-C)
    "book/04_association_kbest:half-cost": ("radarfusion_ref.association",
                                            "association_probabilities", """
        def wrap(f):
            @functools.wraps(f)
            def g(cost, *, k=None):
                return f(np.asarray(cost, dtype=float) / 2, k=k)
            return g
        """),
    # the fused feature weighted by sigma^-1 (standard deviations for variances): wrong only
    # when the two accuracies differ
    "book/05_features:fused-sigma-weights": ("radarfusion_ref.features", "fused_feature", """
        def wrap(f):
            @functools.wraps(f)
            def g(feature1, feature_var1, feature2, feature_var2):
                r = f(feature1, feature_var1, feature2, feature_var2)
                w1 = 1 / np.sqrt(np.asarray(feature_var1, dtype=float))
                w2 = 1 / np.sqrt(np.asarray(feature_var2, dtype=float))
                value = (w1 * np.asarray(feature1) + w2 * np.asarray(feature2)) / (w1 + w2)
                return dataclasses.replace(r, value=value)
            return g
        """),
    "book/06_conversion": ("radarfusion_ref.conversion", "conversion_bias", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                r = f(*a, **k)
                return -np.asarray(r) if not dataclasses.is_dataclass(r) else r
            return g
        """),
    "book/07_separated": ("radarfusion_ref.separated", "pair_statistic", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/08_grouping": ("radarfusion_ref.grouping", "group_costs", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/09_registration": ("radarfusion_ref.registration", "bias_information", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/10_trackfusion": ("radarfusion_ref.trackfusion", "bar_shalom_campo", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                r = f(*a, **k)
                return dataclasses.replace(r, covariance=np.asarray(r.covariance) * 1.01)
            return g
        """),
    # a plausible bug: ω optimised for the trace whatever criterion is asked for
    "book/10_trackfusion:ci-criterion": ("radarfusion_ref.trackfusion", "ci_weight", """
        def wrap(f):
            @functools.wraps(f)
            def g(P1, P2, *, criterion="det"):
                return f(P1, P2, criterion="trace")
            return g
        """),
    "book/11_capstone": ("radarfusion_ref.engine.metrics", "gospa", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                r = f(*a, **k)
                return dataclasses.replace(r, total=r.total * 1.01)
            return g
        """),
    "book/montecarlo": ("radarfusion_ref.engine.montecarlo", "unit_rng", """
        def wrap(f):
            @functools.wraps(f)
            def g(root, point, unit):
                return f(root, 0, unit)   # every point, one stream
            return g
        """),
    # plausible bugs in chapters 06-11: one function the chapter teaches, one slip each
    # κ with the off-diagonal of S dropped (x and y errors taken as independent)
    "book/07_separated:kappa-diagonal-only": ("radarfusion_ref.separated", "pair_statistic", """
        def wrap(f):
            @functools.wraps(f)
            def g(xy1, cov1, xy2, cov2, **k):
                eye = np.eye(2)
                return f(xy1, np.asarray(cov1, float) * eye, xy2, np.asarray(cov2, float) * eye, **k)
            return g
        """),
    # a report whose true partner passes counts as correct even when others pass too
    "book/07_separated:several-pass-correct": ("radarfusion_ref.separated", "per_report_outcome", """
        def wrap(f):
            @functools.wraps(f)
            def g(statistic, threshold):
                out = np.array(f(statistic, threshold))
                s = np.asarray(statistic, float)
                out[np.diagonal(s < threshold, axis1=-2, axis2=-1)] = 0   # CORRECT
                return out
            return g
        """),
    # the ML group cost without its -ln det of the fused covariance
    "book/08_grouping:ml-no-fused-logdet": ("radarfusion_ref.grouping", "ml_group_cost", """
        def wrap(f):
            @functools.wraps(f)
            def g(x, cov):
                W = sum(np.linalg.inv(np.asarray(c, float)) for c in cov)
                return f(x, cov) - np.linalg.slogdet(W)[1]
            return g
        """),
    # off by one: ln det Sigma_i summed over sources 2..m only
    "book/08_grouping:ml-logdet-off-by-one": ("radarfusion_ref.grouping", "ml_group_cost", """
        def wrap(f):
            @functools.wraps(f)
            def g(x, cov):
                return f(x, cov) - np.linalg.slogdet(np.asarray(cov[0], float))[1]
            return g
        """),
    # the 3-D azimuth Jacobian copied from 2-D: no cos(elevation) factor
    "book/06_conversion_modern:azimuth-no-cos-elevation": (
        "radarfusion_ref.conversion", "spherical_covariance", """
        def wrap(f):
            @functools.wraps(f)
            def g(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, *, method="linearized"):
                out = f(r, beta, epsilon, sigma_r, sigma_beta, sigma_epsilon, method=method)
                if method != "linearized":
                    return out
                b, e = np.asarray(beta, float), np.asarray(epsilon, float)
                u = np.stack(np.broadcast_arrays(-np.sin(b), np.cos(b), 0.0 * b), -1)
                w = (np.asarray(r, float) * np.asarray(sigma_beta, float) * np.sin(e)) ** 2
                return out + np.asarray(w)[..., None, None] * u[..., :, None] * u[..., None, :]
            return g
        """),
    # the unbiasing gain e^{sigma^2} instead of e^{sigma^2/2}
    "book/06_conversion:gain-exponent-twice": ("radarfusion_ref.conversion", "conversion_gain", """
        def wrap(f):
            @functools.wraps(f)
            def g(sigma_beta, *, method="linearized"):
                if method in ("multiplicative", "decorrelated"):
                    return np.exp(np.asarray(sigma_beta, float) ** 2)
                return f(sigma_beta, method=method)
            return g
        """),
    # the object positions taken as known: U alone, no Schur complement U - sum_k W V^-1 W^T
    "book/09_registration:info-no-elimination": (
        "radarfusion_ref.registration", "reduced_information", """
        def wrap(f):
            @functools.wraps(f)
            def g(jac_bias, jac_object):
                f(jac_bias, jac_object)                                   # its door checks
                B = np.asarray(jac_bias, float)
                *lead, m, _, _, _ = B.shape
                U = np.einsum("...ikab,...ikac->...ibc", B, B)
                info = np.zeros((*lead, 3 * m, 3 * m))
                for i in range(m):
                    info[..., 3 * i:3 * i + 3, 3 * i:3 * i + 3] = U[..., i, :, :]
                return info
            return g
        """),
    # λ with radar 1's covariance counted for both radars (S = 2 Σ1 instead of Σ1 + Σ2)
    "book/09_registration:lambda-one-covariance": (
        "radarfusion_ref.registration", "noncentrality", """
        def wrap(f):
            @functools.wraps(f)
            def g(sensors, targets, biases, sigma_r, sigma_beta):
                import radarfusion_ref.registration as rg
                from radarfusion_ref.conversion import polar_to_cartesian
                f(sensors, targets, biases, sigma_r, sigma_beta)          # its door checks
                s = np.asarray(sensors, float)
                sr = np.broadcast_to(np.asarray(sigma_r, float), (2,))
                sb = np.broadcast_to(np.asarray(sigma_beta, float), (2,))
                polar = rg.true_polar(s, targets)
                mu = rg.bias_displacement(s, targets, biases)
                cov = polar_to_cartesian(polar[..., 0], polar[..., 1], sr[:, None],
                                         sb[:, None]).cov
                d = mu[..., 0, :, :] - mu[..., 1, :, :]
                S = 2.0 * cov[..., 0, :, :, :]
                return np.einsum("...i,...ij,...j->...", d, np.linalg.inv(S), d)
            return g
        """),
    # the cross-covariance transposed: P21 where P12 belongs (matters only when P12 is asymmetric)
    "book/10_trackfusion:bsc-cross-transposed": (
        "radarfusion_ref.trackfusion", "bar_shalom_campo", """
        def wrap(f):
            @functools.wraps(f)
            def g(x1, P1, x2, P2, P12):
                r = f(x1, P1, x2, P2, P12)                                # its door checks
                x1, P1, x2, P2, P12 = (np.asarray(a, float) for a in (x1, P1, x2, P2, P12))
                P21 = np.swapaxes(P12, -1, -2)
                U = P1 + P2 - P12 - P21
                W = np.swapaxes(np.linalg.solve(U, P1 - P12), -1, -2)    # (P1 - P21) U^-1
                cov = P1 - W @ (P1 - P12)
                return dataclasses.replace(
                    r, estimate=x1 + (W @ (x2 - x1)[..., None])[..., 0],
                    covariance=0.5 * (cov + np.swapaxes(cov, -1, -2)))
            return g
        """),
    # the ellipsoid's z taken as (N + h) sin φ, without the factor 1 - e² on N
    "book/11_capstone:ecef-z-no-eccentricity": (
        "radarfusion_ref.engine.geodesy", "geodetic_to_enu", """
        def wrap(f):
            @functools.wraps(f)
            def g(lat, lon, h, *, origin):
                from radarfusion_ref.engine import geodesy as gd
                f(lat, lon, h, origin=origin)                             # its door checks
                e2 = gd.WGS84_F * (2.0 - gd.WGS84_F)
                def ecef(la, lo, hh):
                    ph, lm = np.radians(la), np.radians(lo)
                    n = gd.WGS84_A / np.sqrt(1.0 - e2 * np.sin(ph) ** 2)
                    return np.stack([(n + hh) * np.cos(ph) * np.cos(lm),
                                     (n + hh) * np.cos(ph) * np.sin(lm), (n + hh) * np.sin(ph)], -1)
                o = np.asarray(origin, float)
                la, lo, hh = np.broadcast_arrays(*(np.asarray(v, float) for v in (lat, lon, h)))
                d = ecef(la, lo, hh) - ecef(o[0], o[1], o[2])
                return d @ gd.enu_rotation(o[0], o[1]).T
            return g
        """),
    # a pair beyond the cut-off kept in the assignment at c^p instead of one miss plus one false
    # (the total is unchanged; the parts are not)
    "book/11_capstone:gospa-cut-pairs-kept": ("radarfusion_ref.engine.metrics", "gospa", """
        def wrap(f):
            @functools.wraps(f)
            def g(x, y, *, c, p=2.0, parts=True):
                from scipy.optimize import linear_sum_assignment
                r = f(x, y, c=c, p=p, parts=parts)
                X, Y = np.asarray(x, float), np.asarray(y, float)
                if X.size == 0 or Y.size == 0:
                    return r
                u = np.linalg.norm(X[:, None] - Y[None], axis=-1) / c
                ri, ci = linear_sum_assignment(np.minimum(u, 1.0) ** p)
                far, cp = int((u[ri, ci] >= 1.0).sum()), float(c) ** p
                return dataclasses.replace(
                    r, localisation=r.localisation + far * cp, missed=r.missed - far * cp / 2,
                    false=r.false - far * cp / 2, n_assigned=r.n_assigned + far,
                    n_missed=r.n_missed - far, n_false=r.n_false - far)
            return g
        """),
    # the NEES consistency range with d - 1 degrees of freedom per estimate instead of d
    "book/11_capstone:nees-range-dof": ("radarfusion_ref.engine.metrics", "nees", """
        def wrap(f):
            @functools.wraps(f)
            def g(error, cov, *, level=0.95):
                from scipy import stats
                r = f(error, cov, level=level)
                k = (r.dof - 1) * r.count
                return dataclasses.replace(
                    r, low=float(stats.chi2.ppf((1 - level) / 2, k) / r.count),
                    high=float(stats.chi2.ppf((1 + level) / 2, k) / r.count))
            return g
        """),
    # the pipeline page: the registration's correction adds the offsets instead of removing them
    "book/11_capstone_pipeline:registration-sign": (
        "radarfusion_ref.registration", "remove_biases", """
        def wrap(f):
            @functools.wraps(f)
            def g(r_hat, beta_hat, biases):
                return f(r_hat, beta_hat, np.asarray(biases, float) * [-1.0, 1.0, -1.0])
            return g
        """),
    # the pipeline page: the converted covariance filled in one triangle only
    "book/11_capstone_pipeline:conversion-cov-one-triangle": (
        "radarfusion_ref.conversion", "spherical_to_cartesian", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                r = f(*a, **k)
                return dataclasses.replace(r, cov=np.triu(r.cov))
            return g
        """),
    # chapter 12: the piecewise-constant (discrete) process noise where the continuous
    # white-noise acceleration is derived
    "book/12_tracking": ("radarfusion_ref.engine.tracker", "kalman_predict", """
        def wrap(f):
            @functools.wraps(f)
            def g(x, P, dt, q, *, noise="continuous"):
                return f(x, P, dt, q, noise="discrete")
            return g
        """),
    # a plausible bug: Wald's thresholds with alpha and beta swapped
    "book/12_tracking:sprt-swapped": ("radarfusion_ref.engine.tracker", "sprt_thresholds", """
        def wrap(f):
            @functools.wraps(f)
            def g(alpha, beta):
                return f(beta, alpha)
            return g
        """),
    # a plausible bug: each track's probabilities normalised alone (PDA), the joint
    # events' one-report-per-track exclusion forgotten
    "book/12_tracking:jpda-no-exclusion": ("radarfusion_ref.engine.tracker",
                                           "jpda_probabilities", """
        def wrap(f):
            @functools.wraps(f)
            def g(ratio, miss, *, k=None):
                r = f(ratio, miss, k=k)
                ratio, miss = np.asarray(ratio, float), np.asarray(miss, float)
                total = miss + ratio.sum(axis=1)
                return dataclasses.replace(r, probabilities=ratio / total[:, None],
                                           miss=miss / total)
            return g
        """),    # the hand-over's statistic off by 1 %: every link's mean squared distance scaled
    "book/13_continent": ("radarfusion_ref.continent.sectors", "track_sectored", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                r = f(*a, **k)
                return dataclasses.replace(r, link_cost=np.asarray(r.link_cost) * 1.01)
            return g
        """),
}

PREAMBLE = """\
import dataclasses, functools, importlib, sys
import numpy as np
{wrap}
_module = importlib.import_module({module!r})
_original = getattr(_module, {name!r})
_mutant = wrap(_original)
for _m in list(sys.modules.values()):
    if getattr(_m, "__name__", "").startswith("radarfusion_ref"):
        for _k, _v in list(vars(_m).items()):
            if _v is _original:
                setattr(_m, _k, _mutant)
del _m, _k, _v
"""

CHECK_ERRORS = ("CheckError", "SymbolicCheckError", "MonteCarloCheckError")


def preamble(module: str, name: str, wrap: str) -> str:
    return PREAMBLE.format(wrap=textwrap.dedent(wrap).strip(), module=module, name=name)


@pytest.fixture(scope="module")
def mutant_runs(request):
    """The selected mutations' chapters, executed two at a time with their preambles."""
    chosen = selected(request, "test_a_broken_function_stops_its_chapter_at_a_check")
    return execute_chapters({d: (ROOT / f"{d.split(':')[0]}.md",
                                 {"preamble": preamble(*MUTATIONS[d])}) for d in chosen})


@pytest.mark.notebook
@pytest.mark.parametrize("docname", sorted(MUTATIONS))
def test_a_broken_function_stops_its_chapter_at_a_check(docname, mutant_runs):
    _, _, error = mutant_runs[docname]
    assert error is not None, f"{docname} executed to its end with its function broken"
    assert any(err in error for err in CHECK_ERRORS), (
        f"{docname} failed, but not at one of its checks:\n{error[-3000:]}"
    )
