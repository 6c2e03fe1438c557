r"""The Table 1 Monte Carlo, chunked, with common random numbers; and its sweep over placements."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from .. import gating
from ..engine.geometry import (
    MAX_TRIALS,
    Geometry,
    as_geometry,
    as_polar_sigmas,
    normal_chunks,
)
from ..engine.linalg import mahalanobis_sq_pairwise
from ..engine.montecarlo import Proportion, proportion
from ..engine.validation import (
    MEMORY_LIMIT,
    as_choice,
    as_float,
    as_float_array,
    as_int,
    as_probability,
    as_seed_sequence,
    check_size,
    describe,
)
from ._scenario import (
    _JOINT_ALTERNATIVE,
    _METHODS,
    MAX_GRID_POINTS,
    MAX_JOINT_PAIRINGS,
    PAPER,
    PAPER_TABLE1,
    paper_geometry,
)
from ._statistic import _convert, _method_pair


# --------------------------------------------------------------------------- experiment
@dataclass(frozen=True)
class MethodResult:
    r"""Monte-Carlo outcome frequencies of one conversion method.

    Attributes
    ----------
    label : str
        ``method`` or ``"method/cov_method"`` when they differ.
    method, cov_method : str
        Conversions used for positions and covariances.
    per_report : Proportion
        Shape (n, 3): row ``i`` = target ``i``'s (correct, wrong, no decision)
        under per-report gating — Table 1's rows.
    joint : Proportion
        Shape (3,): the maximum-likelihood joint assignment with the
        :math:`\chi^2(2n)` gate on the chosen pairing.
    joint_ungated : Proportion
        Shape (3,): the same without the gate (never "no decision").
    true_reject : Proportion
        Shape (n,): how often the true pair of target ``i`` fails the gate
        (nominally :math:`P_{\text{lo}}`; tests the :math:`\chi^2(2)` law).
    false_pass : Proportion
        Shape (n,): how often the false pair of radar-1 report ``i`` with
        radar-2 report ``i+1`` (cyclically) passes the gate.
    all_correct : Proportion
        Scalar: how often per-report gating decides *every* target correctly
        (comparable with ``joint``, which decides all targets at once).
    """

    label: str
    method: str
    cov_method: str
    per_report: Proportion
    joint: Proportion
    joint_ungated: Proportion
    true_reject: Proportion
    false_pass: Proportion
    all_correct: Proportion


@dataclass(frozen=True)
class ExperimentResult:
    r"""Result of :func:`association_experiment`.

    Attributes
    ----------
    results : dict of str to MethodResult
        One entry per method, keyed by its label.
    trials : int
        Number of Monte-Carlo trials (the same draws for every method).
    threshold : float
        The per-pair gate :math:`\gamma` (:math:`\chi^2(2)` quantile).
    joint_threshold : float
        The gate of the joint pairing (:math:`\chi^2(2n)` quantile).
    geometry : Geometry
    sigma_r, sigma_beta, p_false_reject : float
    """

    results: dict
    trials: int
    threshold: float
    joint_threshold: float
    geometry: Geometry
    sigma_r: float
    sigma_beta: float
    p_false_reject: float

    def __getitem__(self, label: str) -> MethodResult:
        return self.results[label]


def _as_methods(methods) -> list[tuple[str, str]]:
    if isinstance(methods, str):
        methods = [methods]
    out = []
    try:
        items = list(methods)
    except TypeError:
        raise TypeError(f"`methods` must be a sequence of method names or (method, "
                        f"cov_method) pairs; received {methods!r}") from None
    if not items:
        raise ValueError("`methods` must name at least one method; received an empty sequence")
    for m in items:
        if isinstance(m, str):
            out.append(_method_pair(m, None))
        elif isinstance(m, tuple) and len(m) == 2:
            out.append(_method_pair(m[0], m[1]))
        else:
            raise ValueError(f"`methods` entries must be method names or (method, cov_method) "
                             f"pairs from {_METHODS}; received {m!r}")
    return out


def association_experiment(geometry: Geometry, *, sigma_r=PAPER["sigma_r"],
                           sigma_beta=PAPER["sigma_beta"],
                           methods=("linearized", "additive"), trials: int = 100_000,
                           p_false_reject=PAPER["p_false_reject"], rng=None,
                           chunk_size: int = 65_536) -> ExperimentResult:
    r"""Monte Carlo of the Table 1 experiment: per-report gating and joint assignment.

    Every trial draws one polar report per target and radar; each method
    converts the *same* draws (common random numbers, so differences between
    methods are paired and precise), computes :math:`\kappa` for all pairs and
    scores the decisions. Trials are processed in chunks of `chunk_size`, all
    vectorized (no per-trial Python loop). The draws are made per block of
    :data:`BLOCK_TRIALS` trials from spawned seed sequences, so the result of a
    seed does not depend on `chunk_size`, and trial ``t`` sees the same
    reports as trial ``t`` of :func:`radarfusion_ref.engine.scenes.polar_scene` with that seed.

    Parameters
    ----------
    geometry : Geometry
        Radars and targets (at least two, at most 7: the joint rule enumerates
        all :math:`n!` pairings, see :data:`MAX_JOINT_PAIRINGS`).
    sigma_r, sigma_beta : float, optional
        Measurement errors (km, rad); the paper's 0.1 km and 1° by default.
    methods : sequence, optional
        Conversion names, or ``(method, cov_method)`` pairs to use one
        method's positions with another's covariances.
    trials : int, optional
        Number of trials, at most :data:`MAX_TRIALS`.
    p_false_reject : float, optional
        :math:`P_{\text{lo}}` of the per-pair :math:`\chi^2(2)` gate and of
        the joint :math:`\chi^2(2n)` gate.
    rng : None, int, numpy.random.SeedSequence or numpy.random.Generator, optional
        Source of randomness (SPEC 7); a Generator is advanced by one draw of
        the root seed.
    chunk_size : int, optional
        Trials per vectorized chunk (memory ~ 1.5 kB per trial for two
        targets); the working memory of one chunk must stay within
        :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT`. It changes speed and
        memory only, never the result.

    Returns
    -------
    ExperimentResult

    Raises
    ------
    ValueError
        For fewer than two or more than seven targets, bad sigmas, unknown
        methods, or counts out of their limits.
    TypeError
        If `geometry` is not a :class:`Geometry`, or a count is not an integer.

    References
    ----------
    Prosov, Table 1 and the text before it.

    Examples
    --------
    >>> res = association_experiment(paper_geometry(0.0, -5.0), trials=2000, rng=3)
    >>> res["linearized"].per_report.estimate.shape
    (2, 3)
    """
    geo = as_geometry(geometry)
    if geo.targets.shape[0] < 2:
        raise ValueError("`geometry` must hold at least two targets for association; "
                         f"received {geo.targets.shape[0]}")
    n = geo.targets.shape[0]
    check_size(math.factorial(n), MAX_JOINT_PAIRINGS,
               what=f"joint pairings n! (n = {n} targets in `geometry`)",
               alternative=_JOINT_ALTERNATIVE)
    sr, sb = as_polar_sigmas(sigma_r, sigma_beta, geo)
    meths = _as_methods(methods)
    n_trials = as_int(trials, "trials", minimum=1)
    check_size(n_trials, MAX_TRIALS, what="trials (`trials`)",
               alternative="several calls with spawned seeds, adding the counts")
    chunk = as_int(chunk_size, "chunk_size", minimum=1)
    per_trial = 8 * (40 * n + 16 * n * n + math.factorial(n) * (n + 4))
    check_size(per_trial * chunk, MEMORY_LIMIT,
               what=f"bytes of working memory for `chunk_size` = {chunk}",
               alternative=f"a `chunk_size` of at most {MEMORY_LIMIT // per_trial}")
    p_lo = as_float(as_probability(p_false_reject, "p_false_reject"), "p_false_reject")
    root = as_seed_sequence(rng)
    th = float(gating.gate_threshold(p_lo, 2))
    th_joint = float(gating.gate_threshold(p_lo, 2 * n))
    k = len(meths)
    per = np.zeros((k, n, 3), dtype=np.int64)
    joint = np.zeros((k, 3), dtype=np.int64)
    joint_ug = np.zeros((k, 3), dtype=np.int64)
    true_rej = np.zeros((k, n), dtype=np.int64)
    false_pass = np.zeros((k, n), dtype=np.int64)
    all_ok = np.zeros(k, dtype=np.int64)
    idx = np.arange(n)
    nxt = (idx + 1) % n
    perms = np.array(list(itertools.permutations(range(n))))
    p2 = geo.radar2
    (r1t, b1t), (r2t, b2t) = geo.polar1, geo.polar2
    r_true = np.stack([r1t, r2t])[:, :, None]                # (2, n, 1)
    b_true = np.stack([b1t, b2t])[:, :, None]
    for z in normal_chunks(root, n, n_trials, chunk):     # (4, n, m), per-block seeds
        m = z.shape[-1]
        # both radars in one array, trial axis last: shape (2, n, m)
        r = r_true + sr * z[0::2]
        beta = b_true + sb * z[1::2]
        for q, (pm, cm) in enumerate(meths):
            xy, cov = _convert(r, beta, sr, sb, pm, cm)
            s, ld = _pair_kernel(xy, cov, p2)              # (n, n, m)
            passed = s < th
            true_pass = passed[idx, idx]                     # (n, m)
            single = passed.sum(axis=1) == 1
            ok_i = single & true_pass
            all_ok[q] += np.count_nonzero(ok_i.all(axis=0))
            c_ok = np.count_nonzero(ok_i, axis=1)
            c_wrong = np.count_nonzero(single & ~true_pass, axis=1)
            per[q] += np.stack([c_ok, c_wrong, m - c_ok - c_wrong], axis=-1)
            true_rej[q] += m - np.count_nonzero(true_pass, axis=1)
            false_pass[q] += np.count_nonzero(passed[idx, nxt], axis=1)
            sum_s = s[idx, perms].sum(axis=1)               # (n!, m), identity first
            best = np.argmin(sum_s + ld[idx, perms].sum(axis=1), axis=0)
            ok = best == 0
            n_ok = int(np.count_nonzero(ok))
            joint_ug[q] += (n_ok, m - n_ok, 0)
            gated = np.take_along_axis(sum_s, best[None], axis=0)[0] >= th_joint
            g_ok = int(np.count_nonzero(ok & ~gated))
            g_none = int(np.count_nonzero(gated))
            joint[q] += (g_ok, m - g_ok - g_none, g_none)
    results = {}
    for q, (pm, cm) in enumerate(meths):
        label = pm if pm == cm else f"{pm}/{cm}"
        # one interval computation for all counts of the method, then sliced
        parts = [per[q], joint[q], joint_ug[q], true_rej[q], false_pass[q], all_ok[q]]
        flat = proportion(np.concatenate([np.ravel(x) for x in parts]), n_trials)
        props, pos = [], 0
        for x in parts:
            size, shape = np.size(x), np.shape(x)
            sl = slice(pos, pos + size)
            pos += size

            def cut(v, sl=sl, shape=shape):
                out = np.asarray(v)[sl].reshape(shape)
                return out.item() if out.ndim == 0 else out

            props.append(Proportion(cut(flat.successes), n_trials, cut(flat.estimate),
                                    cut(flat.low), cut(flat.high), flat.confidence,
                                    flat.method))
        results[label] = MethodResult(label, pm, cm, *props)
    return ExperimentResult(results, n_trials, th, th_joint, geo, sr, sb, p_lo)


def _pair_kernel(xy, cov, radar2):
    """S and ln det for all pairs; inputs for both radars, trial axis last.

    ``xy`` has shape (2, n, m, 2) and ``cov`` (2, n, m, 2, 2) (radar, target,
    trial); radar 2's positions are shifted by `radar2`. Returns arrays of
    shape (n, n, m): radar-1 report, radar-2 report, trial. The pairs go through
    the package's one squared-Mahalanobis function,
    :func:`radarfusion_ref.engine.linalg.mahalanobis_sq_pairwise`.
    """
    x1 = np.moveaxis(xy[0], 1, 0)                               # (m, n, 2)
    x2 = np.moveaxis(xy[1], 1, 0) + np.asarray(radar2, float)
    c1 = np.moveaxis(cov[0], 1, 0)                              # (m, n, 2, 2)
    c2 = np.moveaxis(cov[1], 1, 0)
    s, ld = mahalanobis_sq_pairwise(x1, x2, c1, c2, return_logdet=True)
    return np.moveaxis(s, 0, -1), np.moveaxis(ld, 0, -1)       # (n, n, m)


def collect(experiments, label: str, field: str = "per_report") -> Proportion:
    """Stack one field of several experiments into one array-valued proportion.

    Parameters
    ----------
    experiments : sequence of ExperimentResult
        Results with the same number of trials (e.g. a parameter sweep).
    label : str
        Method label (a key of ``ExperimentResult.results``).
    field : {"per_report", "joint", "joint_ungated", "true_reject", "false_pass", "all_correct"}
        Which :class:`MethodResult` field to stack.

    Returns
    -------
    Proportion
        With a new leading axis of length ``len(experiments)``.

    Raises
    ------
    ValueError
        If `experiments` is empty, trial counts differ, or names are unknown.
    TypeError
        If an entry is not an :class:`ExperimentResult` or `label` is not a string.

    Examples
    --------
    >>> g = paper_geometry(0.0, -5.0)
    >>> runs = [association_experiment(g, trials=500, rng=s) for s in (1, 2)]
    >>> collect(runs, "linearized").estimate.shape
    (2, 2, 3)
    """
    try:
        runs = list(experiments)
    except TypeError:
        raise TypeError("`experiments` must be a sequence of ExperimentResult; received "
                        f"{describe(experiments)}") from None
    if not runs:
        raise ValueError("`experiments` must hold at least one ExperimentResult; received none")
    for r in runs:
        if not isinstance(r, ExperimentResult):
            raise TypeError("`experiments` must hold ExperimentResult objects (from "
                            f"`association_experiment`); received a {type(r).__name__}")
    if not isinstance(label, str):
        raise TypeError(f"`label` must be a method label (str); received {describe(label)}")
    missing = [k for k, r in enumerate(runs) if label not in r.results]
    as_choice(field, "field", ("per_report", "joint", "joint_ungated", "true_reject",
                               "false_pass", "all_correct"))
    if missing:
        raise ValueError(f"`label` must be one of {', '.join(map(repr, runs[0].results))} "
                         f"in every experiment; received {label!r}")
    trials = {r.trials for r in runs}
    if len(trials) != 1:
        raise ValueError(f"`experiments` must share one trial count; received {sorted(trials)}")
    counts = np.stack([np.asarray(getattr(r[label], field).successes) for r in runs])
    return proportion(counts, trials.pop())


@dataclass(frozen=True)
class OffsetSweep:
    """Table 1's experiment over a grid of target-2 placements.

    Attributes
    ----------
    offsets_range, offsets_cross : numpy.ndarray
        Grid axes (km): target 2's offset from target 1 along and across
        radar 1's line of sight (see :func:`paper_geometry`).
    per_report : dict of str to Proportion
        Per method label, estimates of shape ``(n_range, n_cross, 2, 3)``.
    joint : dict of str to Proportion
        Per method label, the gated joint assignment, shape ``(n_range, n_cross, 3)``.
    trials : int
        Trials per grid point (the same draws at every point: common random numbers).
    """

    offsets_range: np.ndarray
    offsets_cross: np.ndarray
    per_report: dict
    joint: dict
    trials: int


def offset_sweep(offsets_range, offsets_cross, *, methods=("linearized", "additive"),
                 trials: int = 10_000, sigma_r=PAPER["sigma_r"],
                 sigma_beta=PAPER["sigma_beta"], p_false_reject=PAPER["p_false_reject"],
                 rng=None) -> OffsetSweep:
    """Run :func:`association_experiment` on a grid of target-2 placements.

    Parameters
    ----------
    offsets_range, offsets_cross : array_like, 1-D
        Offsets (km) of target 2 from target 1 along and across radar 1's
        line of sight; the grid is their outer product. No point may have
        both offsets zero.
    methods, trials, sigma_r, sigma_beta, p_false_reject :
        As :func:`association_experiment`.
    rng : None, int, numpy.random.SeedSequence or numpy.random.Generator, optional
        The seed, converted once by the engine's seed recipe
        (:func:`radarfusion_ref.engine.validation.as_seed_sequence`); the one
        root sequence is given to every grid point (common random numbers), so
        the maps are smooth and differences between neighbouring points are not
        masked by independent noise. A point's result is therefore that of
        :func:`association_experiment` with the same seed: it depends only on
        the seed and the point, not on the other points of the grid nor on
        their order.

    Returns
    -------
    OffsetSweep

    Raises
    ------
    ValueError
        If an axis is not 1-D and non-empty, a grid point has both offsets zero,
        the grid has more than :data:`MAX_GRID_POINTS` points or more than
        :data:`MAX_TRIALS` trials in all, or an argument of
        :func:`association_experiment` is bad.

    Examples
    --------
    >>> sw = offset_sweep([0.0, 1.0], [-5.0], trials=500, rng=1)
    >>> sw.per_report["linearized"].estimate.shape
    (2, 1, 2, 3)
    """
    ar = as_float_array(offsets_range, "offsets_range", ndim_min=1)
    ac = as_float_array(offsets_cross, "offsets_cross", ndim_min=1)
    for name, arr in (("offsets_range", ar), ("offsets_cross", ac)):
        if arr.ndim != 1 or arr.size == 0:
            raise ValueError(f"`{name}` must be a non-empty 1-D array; received shape {arr.shape}")
    check_size(ar.size * ac.size, MAX_GRID_POINTS,
               what="grid points (`offsets_range` x `offsets_cross`)",
               alternative="a coarse grid refined around its best point")
    n_trials = as_int(trials, "trials", minimum=1)
    check_size(ar.size * ac.size * n_trials, MAX_TRIALS,
               what="trials over the whole grid (`trials` per point)",
               alternative="fewer grid points or trials per point")
    if np.any(ar == 0) and np.any(ac == 0):
        raise ValueError("`offsets_range` and `offsets_cross` must not both contain 0: the "
                         "grid point (0, 0) puts target 2 on target 1")
    root = as_seed_sequence(rng)      # one root, used as is (not advanced) at every point
    runs = [association_experiment(paper_geometry(a, c), sigma_r=sigma_r,
                                   sigma_beta=sigma_beta, methods=methods, trials=trials,
                                   p_false_reject=p_false_reject, rng=root)
            for a in ar for c in ac]
    shape = (ar.size, ac.size)

    def grid(label, field):
        p = collect(runs, label, field)
        counts = np.asarray(p.successes).reshape(shape + np.shape(p.successes)[1:])
        return proportion(counts, p.trials)

    labels = list(runs[0].results)
    return OffsetSweep(ar, ac, {k: grid(k, "per_report") for k in labels},
                       {k: grid(k, "joint") for k in labels}, runs[0].trials)


def fit_target2_offset(sweep: OffsetSweep, target=None, *, method: str = "linearized"):
    r"""The grid placement whose no-decision rates are closest to a target pair.

    Parameters
    ----------
    sweep : OffsetSweep
        From :func:`offset_sweep`.
    target : pair of float, optional
        :math:`P_{\text{none}}` of targets 1 and 2; by default the paper's
        linearized row (0.316, 0.650), which stands in for the missing Fig. 2.
    method : str, optional
        Method label in the sweep whose rates are matched.

    Returns
    -------
    offset_range, offset_cross, misfit : float
        The best grid point (km) and its Euclidean distance to `target`.

    Raises
    ------
    ValueError
        If `target` is not two probabilities or `method` is not in the sweep.

    Examples
    --------
    >>> sw = offset_sweep([0.0, 1.0], [-6.0, -5.0], trials=500, rng=1)
    >>> a, c, miss = fit_target2_offset(sw)
    >>> bool(a in (0.0, 1.0) and c in (-6.0, -5.0) and miss >= 0)
    True
    """
    if not isinstance(sweep, OffsetSweep):
        raise TypeError(f"`sweep` must be an OffsetSweep; received {type(sweep).__name__}")
    tgt = as_probability(PAPER_TABLE1["linearized"][:, 2] if target is None else target,
                         "target")
    if tgt.shape != (2,):
        raise ValueError(f"`target` must hold two probabilities; received {tgt}")
    if not isinstance(method, str) or method not in sweep.per_report:
        raise ValueError(f"`method` must be one of {', '.join(map(repr, sweep.per_report))}; "
                         f"received {method!r}")
    none = np.asarray(sweep.per_report[method].estimate)[..., 2]
    miss = np.linalg.norm(none - tgt, axis=-1)
    i, j = np.unravel_index(np.argmin(miss), miss.shape)
    return float(sweep.offsets_range[i]), float(sweep.offsets_cross[j]), float(miss[i, j])
