r"""The fusion centre, scan by scan: convert, register, gate, group, fuse, recognise.

:func:`run_pipeline` runs the book's chapters in sequence on the reports of all radars,
configured by a frozen :class:`PipelineSettings`. Each stage calls the function its
chapter teaches: the debiased 3-D conversion
(:func:`radarfusion_ref.conversion.spherical_to_cartesian`), registration over a
warm-up window (:func:`radarfusion_ref.registration.estimate_biases`), the
per-report-covariance gate (:func:`radarfusion_ref.gating.gate_pairwise`), S-D
grouping with dummies for misses and false reports
(:func:`radarfusion_ref.grouping.group_sd`), ML fusion
(:func:`radarfusion_ref.fusion.fuse_gaussian`, :func:`radarfusion_ref.fusion.fuse`)
and type recognition (:func:`radarfusion_ref.features.type_posterior`).
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import stats

from .. import features, fusion, gating, grouping, registration
from ..engine.validation import (
    as_bool,
    as_choice,
    as_float,
    as_int,
    as_probability,
    describe,
)
from .detections import _convert as _convert_polar
from .radars import (
    _FEATURE_SPAN,
    MIN_REGISTRATION_GROUPS,
    Reports,
    _coverage_count,
    as_radars,
)

__all__ = [
    "MIN_REGISTRATION_GROUPS",
    "SPEED_TYPE_MEANS",
    "SPEED_TYPE_VARS",
    "STAGES",
    "PipelineResult",
    "PipelineSettings",
    "run_pipeline",
]

#: Gaussian type model of the speed feature (kt, kt^2) used by the recognition step
#: (:func:`radarfusion_ref.features.type_posterior`): the class means and variances of
#: the ground speed over the committed hour's 10-s scan positions (standard deviations
#: 39.0, 7.0 and 10.7 kt; the slow class has a long tail of slower aircraft).
SPEED_TYPE_MEANS = (419.0, 451.0, 479.5)
SPEED_TYPE_VARS = (39.0**2, 7.0**2, 10.7**2)

#: The grouping's detection model: the per-scan P_D of a radar (its P_D times the share of
#: the scan's reports inside its coverage) is kept in [_MIN_PD, _MAX_PD], and the false-report
#: density is at least _MIN_FALSE times the object density, so that a report failing the gate
#: can always stay alone (never an infeasible scan).
_MIN_PD, _MAX_PD, _MIN_FALSE = 1e-3, 0.999, 1e-3

#: Registration passes over the warm-up: group, estimate, regroup with the estimate,
#: estimate again. One pass is biased towards small offsets (the uncorrected gate keeps
#: the triples whose offsets happen to cancel); the second removes most of that.
_REG_PASSES = 2

#: Stages timed by :func:`run_pipeline` (in order);
#: :func:`radarfusion_ref.capstone.evaluation.evaluate` adds "metrics".
STAGES = ("conversion", "registration", "gating", "grouping", "fusion", "recognition")


@dataclass(frozen=True)
class PipelineSettings:
    r"""The switches and parameters of :func:`run_pipeline` (checked when made).

    Attributes
    ----------
    debias : bool
        Convert with the measurement-conditioned (debiased) 3-D conversion and its
        covariance (default) or the linearized one.
    register : bool
        Estimate the range and azimuth offsets (:func:`radarfusion_ref.registration.
        estimate_biases`, scale errors fixed at 0) from the groups of all radars in the
        first `warmup` scans (grouped without correction, then again with the first
        estimate), and remove them from every report (default). ``False``: no correction.
    median_logdet : bool
        As in :func:`radarfusion_ref.grouping.group_sd`: ``False`` (default) keeps the
        :math:`\ln|2\pi S|` term of the ML grouping cost as it is; ``True`` replaces it by
        its median over the scan's candidate groups of each size, so only its variation
        between groups is removed (the ablation of the term).
    use_features : bool
        Group on position and speed feature (4-D reports; default) or on position only.
    warmup : int
        Scans used by the registration (default 30, i.e. 5 minutes at 10 s).
    p_false_reject : float
        Gate :math:`P_{\text{lo}}` of the grouping (default 1e-3): report pairs whose
        statistic exceeds the :math:`\chi^2_d` quantile are never grouped. The 2-D gate
        (:func:`radarfusion_ref.gating.gate_pairwise` on east-north) runs first with
        the same threshold, so it removes only reports that could not pass it.
    method : {"milp", "lagrangian"}
        Solver of :func:`radarfusion_ref.grouping.group_sd`: the exact integer program over
        the gated candidate groups (default; one HiGHS call per scan) or the Lagrangian
        relaxation to a proved 1 % gap (slower here: the scans split into many small
        clusters, each iterated on its own).
    min_reports : int
        A group of at least this many reports is declared an object (default 2); lone
        reports are left as false reports. At most the number of radars.

    Raises
    ------
    TypeError
        A switch that is not a boolean, or a number that is not numeric.
    ValueError
        `warmup` or `min_reports` below 1, `p_false_reject` outside (0, 1), an unknown
        `method`.

    Examples
    --------
    >>> import dataclasses
    >>> s = PipelineSettings(register=False)
    >>> s.register, dataclasses.replace(s, warmup=6).warmup
    (False, 6)
    """

    debias: bool = True
    register: bool = True
    median_logdet: bool = False
    use_features: bool = True
    warmup: int = 30
    p_false_reject: float = 1e-3
    method: str = "milp"
    min_reports: int = 2

    def __post_init__(self):
        for name in ("debias", "register", "median_logdet", "use_features"):
            object.__setattr__(self, name, as_bool(getattr(self, name), name))
        object.__setattr__(self, "warmup", as_int(self.warmup, "warmup", minimum=1))
        object.__setattr__(self, "min_reports", as_int(self.min_reports, "min_reports",
                                                       minimum=1))
        object.__setattr__(self, "method", as_choice(self.method, "method",
                                                     ("milp", "lagrangian")))
        object.__setattr__(self, "p_false_reject", as_float(as_probability(
            self.p_false_reject, "p_false_reject"), "p_false_reject"))


@dataclass(frozen=True)
class PipelineResult:
    r"""Output of :func:`run_pipeline`: the fused objects of every scan.

    Attributes
    ----------
    scan : numpy.ndarray of int, shape (G,)
        Scan of each declared object (a group of at least `min_reports` reports).
    members : numpy.ndarray of int, shape (G, m)
        Row indices into `reports` of the group's report from each radar (-1: none).
    position : numpy.ndarray, shape (G, 3)
        ML fused ENU position (m).
    covariance : numpy.ndarray, shape (G, 3, 3)
        Its covariance.
    speed, speed_var : numpy.ndarray, shape (G,)
        Fused speed feature (kt) and its variance.
    class_prob : numpy.ndarray, shape (G, K)
        Posterior probability of each speed class
        (:data:`radarfusion_ref.capstone.traffic.SPEED_CLASSES`).
    group_of : numpy.ndarray of int, shape (N,)
        For every report, the index of its group in the scan's grouping, numbered over the
        whole run (singletons included) — the full partition of the reports.
    biases : numpy.ndarray, shape (m, 3)
        Registration estimate :math:`(\Delta r, g, \Delta\beta)` per radar (zeros with
        ``register=False``).
    timings : dict
        Seconds spent in each of :data:`STAGES`.
    settings : PipelineSettings
        The switches and parameters used.
    reports : Reports
        The input.
    radars : tuple of Radar
        The radars used.
    report_position, report_covariance : numpy.ndarray, shape (N, 3) and (N, 3, 3)
        Every report converted (and bias-corrected) into the common frame.
    """

    scan: np.ndarray
    members: np.ndarray
    position: np.ndarray
    covariance: np.ndarray
    speed: np.ndarray
    speed_var: np.ndarray
    class_prob: np.ndarray
    group_of: np.ndarray
    biases: np.ndarray
    timings: dict = field(hash=False)
    settings: PipelineSettings = field(hash=False)
    reports: Reports = field(hash=False, repr=False)
    radars: tuple = field(hash=False, repr=False, default=())
    report_position: np.ndarray | None = field(hash=False, repr=False, default=None)
    report_covariance: np.ndarray | None = field(hash=False, repr=False, default=None)

    @property
    def speed_class(self) -> np.ndarray:
        """Recognised class (index into the speed classes) of each object."""
        return np.argmax(self.class_prob, axis=-1)


# ----------------------------------------------------------------------------- the stages
def _convert(reports, radars, biases, debias):
    """Bias-corrected, converted reports in the common frame: (N, 3) and (N, 3, 3)."""
    sigma = np.array([[x.sigma_r, x.sigma_beta, x.sigma_epsilon] for x in radars])
    return _convert_polar(reports.r, reports.beta, reports.epsilon, sigma[reports.radar],
                          reports.radar, radars, biases, debias, False)


def _register(reports, radars, settings):
    """Estimate the biases from the all-radar groups of the warm-up scans (two passes)."""
    m = len(radars)
    scans = np.arange(min(settings.warmup, reports.n_scans))
    sub = reports.subset(np.isin(reports.scan, scans))
    sites = np.stack([x.enu for x in radars])
    biases = np.zeros((m, 3))
    for _ in range(_REG_PASSES):
        x, cov = _convert(sub, radars, biases, settings.debias)
        linked = _gate(sub, x, cov, m, settings)
        _, full = _group(sub, radars, x, cov, linked, settings)
        full = full[np.all(full >= 0, axis=1)]
        if full.shape[0] < MIN_REGISTRATION_GROUPS:
            raise ValueError(
                f"`settings.warmup`: only {full.shape[0]} groups hold a report of all {m} "
                f"radars in the {len(scans)} warm-up scans; the registration needs at least "
                f"{MIN_REGISTRATION_GROUPS} (a longer `warmup`, or `register`=False)")
        # in km: the estimator's rank test compares the information of range offsets
        # (1/sigma_r^2) with that of azimuth offsets (r^2/sigma_beta^2) on one scale
        ground = sub.r * np.cos(sub.epsilon) / 1000.0
        z = np.stack([ground[full.T], sub.beta[full.T]], axis=-1)     # (m, n, 2)
        est = registration.estimate_biases(
            sites[:, :2] / 1000.0, z, np.array([x.sigma_r for x in radars]) / 1000.0,
            np.array([x.sigma_beta for x in radars]),
            fixed=np.tile([False, True, False], (m, 1)))
        biases = est.biases * [1000.0, 1.0, 1.0]
    return biases


def _scan_bounds(reports):
    return np.searchsorted(reports.scan, np.arange(reports.n_scans + 1))


def _gate(reports, x, cov, m, settings):
    """Reports that some other radar's report of their scan passes the 2-D pair gate with."""
    d = 4 if settings.use_features else 3
    gamma = gating.gate_threshold(settings.p_false_reject, d)
    p2 = float(stats.chi2.sf(gamma, 2))          # 2-D gate no tighter than the d-D one
    bounds = _scan_bounds(reports)
    linked = np.zeros(reports.scan.size, dtype=bool)
    for s in range(reports.n_scans):
        lo, hi = bounds[s], bounds[s + 1]
        rad = reports.radar[lo:hi]
        idx = [lo + np.flatnonzero(rad == i) for i in range(m)]
        for i in range(m):
            for k in range(i + 1, m):
                if idx[i].size and idx[k].size:
                    g = gating.gate_pairwise(x[idx[i], :2], x[idx[k], :2],
                                                cov[idx[i], :2, :2], cov[idx[k], :2, :2],
                                                p_false_reject=p2)
                    linked[idx[i]] |= g.any(axis=1)
                    linked[idx[k]] |= g.any(axis=0)
    return linked


def _detection_model(reports, radars, x, use_f):
    """Per radar: P_D, false-report density; the object density; coverage of each report."""
    m = len(radars)
    span = _FEATURE_SPAN[1] - _FEATURE_SPAN[0]
    vol = np.array([r.coverage_volume for r in radars]) * (span if use_f else 1.0)
    p_detect = np.array([r.p_detect for r in radars])
    false_density = np.array([r.clutter_rate for r in radars]) / vol
    counts = np.bincount(reports.radar, minlength=m) / max(reports.n_scans, 1)
    n_obj = max(float(np.mean(np.maximum(counts - [r.clutter_rate for r in radars], 1.0)
                              / p_detect)), 1.0)
    object_density = n_obj / float(np.mean(vol))
    false_density = np.maximum(false_density, _MIN_FALSE * object_density)
    cover = np.stack([_coverage_count(x, [r]) > 0 for r in radars])      # (m, n)
    return p_detect, false_density, object_density, cover


def _group(reports, radars, x, cov, linked, settings):
    """S-D grouping of every scan; returns (group index per report, members (G, m))."""
    m = len(radars)
    n = reports.scan.size
    if settings.use_features:
        xf = np.concatenate([x, reports.feature[:, None]], axis=1)
        cf = np.zeros((n, 4, 4))
        cf[:, :3, :3] = cov
        cf[:, 3, 3] = np.array([r.sigma_feature for r in radars])[reports.radar] ** 2
    else:
        xf, cf = x, cov
    p_detect, false_density, object_density, cover = _detection_model(
        reports, radars, x, settings.use_features)
    bounds = _scan_bounds(reports)
    group_of = np.full(n, -1, dtype=np.int64)
    members = []
    next_id = 0
    for s in range(reports.n_scans):
        lo, hi = bounds[s], bounds[s + 1]
        if hi == lo:
            continue
        rad = reports.radar[lo:hi]
        sel = [lo + np.flatnonzero((rad == i) & linked[lo:hi]) for i in range(m)]
        tuples = np.empty((0, m), dtype=np.int64)
        active = [i for i in range(m) if sel[i].size]
        if len(active) >= 2:
            # detection probability averaged over the scan's report positions: P_D inside
            # the radar's coverage, 0 outside it
            pd_ = np.clip(p_detect * cover[:, lo:hi].mean(axis=1), _MIN_PD, _MAX_PD)
            g = grouping.group_sd(
                [xf[sel[i]] for i in active], [cf[sel[i]] for i in active],
                method=settings.method, p_false_reject=settings.p_false_reject,
                p_detect=pd_[active], false_density=false_density[active],
                object_density=object_density,
                median_logdet=settings.median_logdet).groups
            tuples = np.full((g.shape[0], m), -1, dtype=np.int64)
            for c, i in enumerate(active):
                ok = g[:, c] >= 0
                tuples[ok, i] = sel[i][g[ok, c]]
        used = np.zeros(hi - lo, dtype=bool)
        for c in range(m):
            v = tuples[:, c]
            used[v[v >= 0] - lo] = True
        lone = lo + np.flatnonzero(~used)
        single = np.full((lone.size, m), -1, dtype=np.int64)
        single[np.arange(lone.size), reports.radar[lone]] = lone
        allg = np.vstack([tuples, single])
        ids = next_id + np.arange(allg.shape[0])
        for c in range(m):
            v = allg[:, c]
            group_of[v[v >= 0]] = ids[v >= 0]
        next_id += allg.shape[0]
        members.append(allg)
    allm = np.vstack(members) if members else np.empty((0, m), dtype=np.int64)
    return group_of, allm


def _fuse(reports, radars, x, cov, members, min_reports):
    """ML fusion of every group of at least `min_reports` reports: the objects' fields."""
    size = np.sum(members >= 0, axis=1)
    keep = size >= min_reports
    mem = members[keep]
    size = size[keep]
    G = mem.shape[0]
    pos = np.empty((G, 3))
    pcov = np.empty((G, 3, 3))
    spd = np.empty(G)
    svar = np.empty(G)
    fvar = np.array([r.sigma_feature for r in radars]) ** 2
    for k in np.unique(size):
        rows = np.flatnonzero(size == k)
        sub = mem[rows]
        cols = np.argsort(sub < 0, axis=1, kind="stable")[:, :k]
        ridx = np.take_along_axis(sub, cols, axis=1)                  # (g, k) report rows
        if k == 1:
            pos[rows], pcov[rows] = x[ridx[:, 0]], cov[ridx[:, 0]]
            spd[rows], svar[rows] = reports.feature[ridx[:, 0]], fvar[cols[:, 0]]
            continue
        fg = fusion.fuse_gaussian(x[ridx], cov[ridx])
        pos[rows], pcov[rows] = fg.estimate, fg.covariance
        fs = fusion.fuse(reports.feature[ridx], fvar[cols])
        spd[rows], svar[rows] = fs.estimate, fs.variance
    scan = reports.scan[np.max(mem, axis=1)] if G else np.empty(0, dtype=np.int64)
    return dict(scan=scan, members=mem, position=pos, covariance=pcov, speed=spd,
                speed_var=svar)


def _recognise(speed, speed_var):
    """Posterior of the speed classes given the fused speed feature."""
    if not speed.size:
        return np.empty((0, len(SPEED_TYPE_MEANS)))
    return features.type_posterior(speed, speed_var, np.array(SPEED_TYPE_MEANS),
                                   np.array(SPEED_TYPE_VARS))


class _Clock(dict):
    """Wall time per stage: ``with clock("stage"): ...``."""

    @contextlib.contextmanager
    def __call__(self, stage):
        t0 = time.perf_counter()
        yield
        self[stage] = time.perf_counter() - t0

    def stages(self):
        return {s: self.get(s, 0.0) for s in STAGES}


def _pipeline_iv(reports, radars, settings):
    if not isinstance(reports, Reports):
        raise TypeError(f"`reports` must be a Reports (from simulate_reports); received "
                        f"{describe(reports)}")
    radars = as_radars(radars)
    if settings is None:
        settings = PipelineSettings()
    if not isinstance(settings, PipelineSettings):
        raise TypeError(f"`settings` must be a PipelineSettings or None; received "
                        f"{describe(settings)}")
    if settings.min_reports > len(radars):
        raise ValueError(f"`settings.min_reports` must be at most the number of radars, "
                         f"{len(radars)}; received {settings.min_reports}")
    if reports.radar.size and reports.radar.max() >= len(radars):
        raise ValueError(f"`reports` name radar {int(reports.radar.max())} but `radars` holds "
                         f"{len(radars)}")
    return reports, radars, settings


def run_pipeline(reports, radars, settings=None) -> PipelineResult:
    r"""The fusion centre, scan by scan: convert, register, gate, group, fuse, recognise.

    Parameters
    ----------
    reports : Reports
        From :func:`radarfusion_ref.capstone.radars.simulate_reports`.
    radars : sequence of Radar
        The radars that produced them (sites, noise levels, P_D, clutter rates).
    settings : PipelineSettings, optional
        Switches and parameters (default ``PipelineSettings()``: every stage on).

    Returns
    -------
    PipelineResult

    Raises
    ------
    TypeError
        If `reports` is not a :class:`~radarfusion_ref.capstone.radars.Reports`, `radars`
        not a sequence of :class:`~radarfusion_ref.capstone.radars.Radar`, or `settings`
        not a :class:`PipelineSettings`.
    ValueError
        Reports of a radar index outside `radars`, a `settings.min_reports` above the
        number of radars, or a warm-up without enough all-radar groups to register.

    Notes
    -----
    The grouping's detection model (:func:`radarfusion_ref.grouping.group_sd` with
    `p_detect`, `false_density`, `object_density`) uses, per scan and radar, the radar's
    P_D times the share of the scan's converted reports inside its coverage (kept in
    [0.001, 0.999]); the false-report density is the radar's clutter rate over its
    coverage volume (times the 300 kt feature span with `use_features`), at least 0.001
    times the object density; the object density is estimated from the mean report
    counts, :math:`(\bar n_i - \lambda_i)/(P_{D,i} V_i)` averaged over the radars.

    Examples
    --------
    >>> from radarfusion_ref.capstone import default_radars, load_traffic, simulate_reports
    >>> from radarfusion_ref.capstone import truth_scans
    >>> tr = truth_scans(load_traffic(), duration=60.0)
    >>> res = run_pipeline(simulate_reports(tr, default_radars(), rng=0), default_radars(),
    ...                    PipelineSettings(warmup=6))
    >>> sorted(res.timings) == sorted(STAGES)
    True
    """
    reports, radars, settings = _pipeline_iv(reports, radars, settings)
    clock = _Clock()
    with clock("registration"):     # 2. each radar's offsets, from the warm-up scans
        biases = _register(reports, radars, settings) if settings.register else None
    with clock("conversion"):       # 1. every report, corrected, to the common frame
        x, cov = _convert(reports, radars, biases, settings.debias)
    with clock("gating"):           # 3. keep the reports another radar's report can join
        linked = _gate(reports, x, cov, len(radars), settings)
    with clock("grouping"):         # 4. S-D grouping with dummies, scan by scan
        group_of, members = _group(reports, radars, x, cov, linked, settings)
    with clock("fusion"):           # 5. ML fusion of every group of min_reports or more
        objects = _fuse(reports, radars, x, cov, members, settings.min_reports)
    with clock("recognition"):      # 6. the speed-class posterior of every object
        class_prob = _recognise(objects["speed"], objects["speed_var"])
    return PipelineResult(
        **objects, class_prob=class_prob, group_of=group_of,
        biases=np.zeros((len(radars), 3)) if biases is None else biases,
        timings=clock.stages(), settings=settings, reports=reports, radars=radars,
        report_position=x, report_covariance=cov)
