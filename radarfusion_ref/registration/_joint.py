r"""Registration and association together, and the Monte Carlo that compares them."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from .. import gating
from ..engine.assignment import Association, assign_two_lists
from ..engine.errors import RadarFusionWarning
from ..engine.montecarlo import proportion
from ..engine.validation import (
    as_choice,
    as_float_array,
    as_int,
    as_rng,
    describe,
)
from ._estimation import (
    BiasEstimate,
    _information,
    _initial_targets,
    _scaled_rank,
    estimate_biases,
)
from ._model import (
    _elements,
    _fixed_iv,
    _polar_reports_iv,
    _probability_iv,
    _radar_biases_iv,
    _sensors_iv,
    _sigmas_iv,
    _targets_iv,
    cost_matrix,
    draw_biased_reports,
)


# --------------------------------------------------------------------------- joint registration
@dataclass(frozen=True)
class RegistrationStep:
    """One pass of association then bias estimation.

    Attributes
    ----------
    iteration : int
        Pass number, from 1.
    biases : numpy.ndarray, shape (2, 3)
        Biases used to correct the reports before this pass's association.
    row_to_col : numpy.ndarray of int, shape (n1,)
        This pass's association (-1: unassigned).
    total_cost : float
        Summed proximity measure of the association.
    n_pairs : int
        Number of associated pairs.
    """

    iteration: int
    biases: np.ndarray
    row_to_col: np.ndarray
    total_cost: float
    n_pairs: int


@dataclass(frozen=True)
class Registration:
    """Result of :func:`register_and_associate`.

    Attributes
    ----------
    biases : numpy.ndarray, shape (2, 3)
        Final bias estimates.
    estimate : BiasEstimate or None
        The last bias estimate (covariance, CRLB, objects) from the final pairs;
        ``None`` when no pass paired enough reports to make one (``converged``
        is then False and `biases` are the initial biases).
    association : radarfusion_ref.engine.assignment.Association
        The association of the reports corrected with the final biases.
    history : tuple of RegistrationStep
        Every pass, in order.
    converged : bool
        True when a pass repeated the previous pass's association.
    """

    biases: np.ndarray
    estimate: BiasEstimate
    association: Association
    history: tuple[RegistrationStep, ...]
    converged: bool

    @property
    def iterations(self) -> int:
        """Number of passes made."""
        return len(self.history)


class RegistrationError(RuntimeError):
    """Joint registration and association did not converge (``on_failure="raise"``).

    Attributes
    ----------
    history : tuple of RegistrationStep
        The passes made before giving up.
    """

    def __init__(self, message: str, history: tuple[RegistrationStep, ...]):
        super().__init__(message)
        self.history = history


def _history_text(history) -> str:
    return "; ".join(f"pass {h.iteration}: {h.n_pairs} pairs, summed kappa {h.total_cost:.4g}"
                     for h in history)


def _trimmed_estimate(s, paired, sr, sb, fx, gate):
    """Bias estimate from paired reports, dropping the worst pair while it fails the gate.

    Without a gate: the plain estimate. With one: after each fit, the pair
    with the largest proximity measure of its corrected reports is dropped if
    that measure is outside the gate and enough pairs remain to observe the
    biases; then the biases are fitted again (sequential outlier rejection).
    """
    free = ~fx.ravel()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RadarFusionWarning)
        est = estimate_biases(s, paired, sr, sb, fixed=fx)
        while gate is not None and paired.shape[1] > 3:
            k = np.diagonal(cost_matrix(s, paired[0], paired[1], sr, sb, biases=est.biases))
            worst = int(np.argmax(k))
            if k[worst] < gate:
                break
            keep = np.delete(paired, worst, axis=1)
            info, ref = _information(s, _initial_targets(s, keep, est.biases, sr, sb), sr, sb)
            if _scaled_rank(info, free, ref)[0] < int(free.sum()):
                break
            paired = keep
            est = estimate_biases(s, paired, sr, sb, fixed=fx, initial=est.biases)
    return est


def register_and_associate(sensors, reports1, reports2, sigma_r, sigma_beta, *, fixed=None,
                           initial=None, p_false_reject=None, max_iter: int = 20,
                           on_failure: str = "warn") -> Registration:
    r"""Alternate association and bias estimation for two radars until the pairing repeats.

    Parameters
    ----------
    sensors : array_like, shape (2, 2)
        The two radar sites.
    reports1, reports2 : array_like, shape (n1, 2) and (n2, 2)
        Polar reports :math:`(\hat r, \hat\beta)` of each radar, in any order
        (one scene; no batch).
    sigma_r, sigma_beta : float or array_like, shape (2,)
        Random error standard deviations.
    fixed : array_like of bool, shape (2, 3), optional
        Biases known to be zero (see :func:`estimate_biases`).
    initial : array_like, shape (2, 3), optional
        Biases assumed for the first association (default zero).
    p_false_reject : float, optional
        If given, pairs are gated from the second pass on with the
        :math:`\chi^2_2` gate :math:`\kappa < \gamma` of false-rejection
        probability :math:`P_{\text{lo}}` (eq. ``eq-gate``). The first pass is
        never gated: the gate is calibrated for registered reports, and the
        biases are not known yet. Default: no gate, every report of the
        smaller list is paired.
    max_iter : int, optional
        Largest number of passes (default 20).
    on_failure : {"warn", "raise"}, optional
        On non-convergence (no repeat within `max_iter` passes, a cycle, too
        few pairs to estimate the biases, or a pass's estimate outside the
        model, e.g. a range offset beyond a measured range): warn with
        :class:`~radarfusion_ref.engine.errors.RadarFusionWarning` and return the
        last pass (``converged=False``; with no estimate made, ``estimate=None``
        and the initial biases with their association), or raise
        :class:`RegistrationError`. Both carry the iteration history.

    Returns
    -------
    Registration

    Raises
    ------
    ValueError, TypeError
        Bad input (named; `initial` biases outside the model included), or a
        geometry whose biases are unobservable even with every report paired
        (see :func:`estimate_biases`).
    RegistrationError
        With ``on_failure="raise"``, on non-convergence.

    Warns
    -----
    RadarFusionWarning
        With ``on_failure="warn"``, on non-convergence (the message lists the passes).

    Notes
    -----
    Pass :math:`t`: correct the reports with :math:`b^{(t-1)}`, compute the
    proximity measures (:func:`cost_matrix`), take the joint ML pairing
    (:func:`radarfusion_ref.engine.assignment.assign_two_lists`, eq.
    ``eq-joint-ml``), then estimate :math:`b^{(t)}` from the *raw* reports of
    the paired objects (:func:`estimate_biases`). With a gate, the estimate
    is made robust to wrong pairs by dropping, one at a time, the pair whose
    corrected reports fail the gate worst, and fitting again. Each pass can only lower the
    joint cost of pairing and biases for a fixed pairing, so the loop stops
    when the pairing repeats. It converges to the right pairing when the
    initial biases misplace reports by less than about half the object
    spacing; beyond that it can lock onto a consistently shifted pairing.

    Examples
    --------
    >>> s = [[0.0, 0.0], [20.0, 0.0]]
    >>> x = [[0.0, 60.0], [30.0, 70.0], [-20.0, 50.0], [10.0, 80.0], [5.0, 65.0]]
    >>> b = [[0.3, 0.0, 0.004], [0.0, 0.0, 0.0]]
    >>> z = draw_biased_reports(s, x, b, 0.02, 2e-4, rng=3)
    >>> reg = register_and_associate(s, z[0], z[1][::-1], 0.02, 2e-4)
    >>> reg.converged, reg.association.row_to_col.tolist()
    (True, [4, 3, 2, 1, 0])
    """
    s = _sensors_iv(sensors)
    if s.shape[0] != 2:
        raise ValueError(f"`sensors` must hold exactly two radar sites, shape (2, 2); received "
                         f"shape {s.shape}")
    z1 = _polar_reports_iv(reports1, "reports1")
    z2 = _polar_reports_iv(reports2, "reports2")
    for z, name in ((z1, "reports1"), (z2, "reports2")):
        if z.ndim != 2:
            raise ValueError(f"`{name}` must have shape (n, 2), one scene; received shape "
                             f"{z.shape}")
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, 2)
    fx = _fixed_iv(fixed, 2)
    b = np.zeros((2, 3)) if initial is None else np.array(_radar_biases_iv(initial, 2, "initial"))
    if b.shape != (2, 3):
        raise ValueError(f"`initial` must have shape (2, 3); received shape {b.shape}")
    b[fx] = 0.0
    gate = None if p_false_reject is None else float(
        gating.gate_threshold(_probability_iv(p_false_reject, "p_false_reject"), 2))
    max_iter = as_int(max_iter, "max_iter", minimum=1, maximum=1000)
    on_failure = as_choice(on_failure, "on_failure", ("warn", "raise"))
    _elements(z1.shape[0] * z2.shape[0], "reports1")

    history: list[RegistrationStep] = []
    seen: list[np.ndarray] = []
    est, prev_est, failure = None, None, None
    for t in range(1, max_iter + 1):
        try:
            cost = cost_matrix(s, z1, z2, sr, sb, biases=b)
        except ValueError as exc:
            if not str(exc).startswith("`biases`"):
                raise
            if t == 1:                                  # the caller's `initial` biases
                raise ValueError("`initial`" + str(exc)[len("`biases`"):]) from None
            failure = (f"pass {t - 1}'s bias estimate lies outside the model "
                       f"({str(exc)[len('`biases`: '):]}); the biases of pass {t - 1} are "
                       "kept")
            b, est = history[-1].biases.copy(), prev_est
            break
        res = assign_two_lists(cost, threshold=None if t == 1 else gate)
        history.append(RegistrationStep(t, b.copy(), res.row_to_col.copy(),
                                        float(res.cost), int(res.n_assigned)))
        if seen and np.array_equal(res.row_to_col, seen[-1]):
            return Registration(b, est, res, tuple(history), True)
        if any(np.array_equal(res.row_to_col, p) for p in seen[:-1]):
            failure = f"the association cycles (pass {t} repeats an earlier pass, not the last)"
            break
        seen.append(res.row_to_col.copy())
        rows = np.flatnonzero(res.row_to_col >= 0)
        if len(rows) == 0:
            failure = f"pass {t} paired no reports"
            break
        paired = np.stack([z1[rows], z2[res.row_to_col[rows]]])       # (2, k, 2)
        info, ref = _information(s, _initial_targets(s, paired, np.zeros((2, 3)), sr, sb),
                                 sr, sb)
        rank, _ = _scaled_rank(info, ~fx.ravel(), ref)
        if rank < int((~fx).sum()):
            failure = (f"pass {t} paired {len(rows)} reports, too few (or too degenerate) to "
                       f"observe the biases (information rank {rank})")
            break
        prev_est, est = est, _trimmed_estimate(s, paired, sr, sb, fx, gate)
        b = np.array(est.biases)
    else:
        failure = f"no pass repeated the previous association within {max_iter} passes"
    est_text = ("no bias estimate was made (the initial biases are returned)" if est is None
                else f"last biases {np.round(b, 6).tolist()}")
    message = (f"register_and_associate did not converge: {failure}; {est_text}. History: "
               f"{_history_text(history)}")
    if on_failure == "raise":
        raise RegistrationError(message, tuple(history))
    warnings.warn(message, RadarFusionWarning, stacklevel=2)
    cost = cost_matrix(s, z1, z2, sr, sb, biases=b)
    res = assign_two_lists(cost, threshold=gate)
    return Registration(b, est, res, tuple(history), False)


# --------------------------------------------------------------------------- Monte Carlo
@dataclass(frozen=True)
class BiasedScene:
    r"""One simulated two-radar scene with biased reports in unknown order.

    Attributes
    ----------
    targets : numpy.ndarray, shape (n, 2)
        True object positions.
    reports1, reports2 : numpy.ndarray, shape (n1, 2) and (n2, 2)
        Polar reports :math:`(\hat r, \hat\beta)` of the detected objects,
        shuffled.
    object1, object2 : numpy.ndarray of int, shape (n1,) and (n2,)
        Which object each report is of.
    true_row_to_col : numpy.ndarray of int, shape (n1,)
        The correct association (-1: the object was missed by radar 2).
    """

    targets: np.ndarray
    reports1: np.ndarray
    reports2: np.ndarray
    object1: np.ndarray
    object2: np.ndarray
    true_row_to_col: np.ndarray


def simulate_scene(sensors, targets, biases, sigma_r, sigma_beta, *, p_detect=1.0,
                   rng=None) -> BiasedScene:
    r"""One two-radar scene: biased noisy reports, missed detections, shuffled lists.

    Parameters
    ----------
    sensors : array_like, shape (2, 2)
        The two radar sites.
    targets : array_like, shape (n, 2)
        Object positions.
    biases : array_like, shape (2, 3)
        Both radars' :math:`(\Delta r, g, \Delta\beta)`.
    sigma_r, sigma_beta : float or array_like, shape (2,)
        Random error standard deviations.
    p_detect : float, optional
        Probability :math:`P_D \in (0, 1]` that a radar reports an object
        (independently per radar and object; at least one report per radar is kept).
    rng : None, int, SeedSequence or numpy.random.Generator
        Randomness (SPEC 7).

    Returns
    -------
    BiasedScene

    Raises
    ------
    ValueError, TypeError
        Bad input, named.

    Examples
    --------
    >>> sc = simulate_scene([[0, 0], [20, 0]], [[0, 60], [10, 70]], [[0, 0, 0]] * 2,
    ...                     0.05, 1e-3, rng=1)
    >>> sorted(sc.object1[sc.true_row_to_col >= 0]) == sorted(sc.object2)
    True
    """
    s = _sensors_iv(sensors)
    if s.shape[0] != 2:
        raise ValueError(f"`sensors` must hold exactly two radar sites, shape (2, 2); received "
                         f"shape {s.shape}")
    t = _targets_iv(targets, s)
    if t.ndim != 2 or t.shape[0] < 1:
        raise ValueError(f"`targets` must have shape (n, 2) with n >= 1, one scene; received "
                         f"shape {t.shape}")
    pd = _probability_iv(p_detect, "p_detect", open_interval=False)
    if pd <= 0:
        raise ValueError(f"`p_detect` must lie in (0, 1]; received {p_detect!r}")
    gen = as_rng(rng)
    z = draw_biased_reports(s, t, biases, sigma_r, sigma_beta, rng=gen)
    n = t.shape[0]
    objs = []
    for _k in range(2):
        keep = gen.random(n) < pd
        if not keep.any():
            keep[gen.integers(n)] = True
        objs.append(gen.permutation(np.flatnonzero(keep)))
    o1, o2 = objs
    where2 = np.full(n, -1)
    where2[o2] = np.arange(len(o2))
    return BiasedScene(t, z[0][o1], z[1][o2], o1, o2, where2[o1])


@dataclass(frozen=True)
class AccuracyComparison:
    """Probability that every association decision of a scene is right, three ways.

    Attributes
    ----------
    unregistered : Proportion
        Reports associated as they come (biases ignored).
    registered : Proportion
        :func:`register_and_associate` (joint registration and association).
    known : Proportion
        Reports corrected with the true biases before association.
    converged : Proportion
        How often :func:`register_and_associate` converged.
    """

    unregistered: object
    registered: object
    known: object
    converged: object


def association_accuracy(sensors, biases, sigma_r, sigma_beta, *, n_objects: int, region,
                         trials: int, p_detect=1.0, p_false_reject=None, fixed=None,
                         rng=None) -> AccuracyComparison:
    r"""Monte Carlo: association accuracy without registration, with it, and with known biases.

    Parameters
    ----------
    sensors : array_like, shape (2, 2)
        The two radar sites.
    biases : array_like, shape (2, 3)
        The radars' true biases.
    sigma_r, sigma_beta : float or array_like, shape (2,)
        Random error standard deviations.
    n_objects : int
        Objects per scene, drawn uniformly in `region` afresh in every trial.
    region : array_like, shape (2, 2)
        ``[[x_min, y_min], [x_max, y_max]]``.
    trials : int
        Number of scenes.
    p_detect : float, optional
        Detection probability (see :func:`simulate_scene`).
    p_false_reject : float, optional
        The :math:`\chi^2_2` gate of every association (None: no gate); for
        registration, from its second pass on.
    fixed : array_like of bool, shape (2, 3), optional
        Biases held at zero by the registration.
    rng : None, int, SeedSequence or numpy.random.Generator
        Randomness (SPEC 7).

    Returns
    -------
    AccuracyComparison
        Proportions (with 95 % Wilson intervals) of scenes in which every
        decision (pairs and non-pairs) is correct.

    Raises
    ------
    ValueError, TypeError
        Bad input, named.

    Notes
    -----
    A failed registration (a :class:`RegistrationError`, or a warning of
    non-convergence) counts as converged = False; its last association is
    scored (an error, or a pass that made no bias estimate, scores as wrong).

    Examples
    --------
    >>> acc = association_accuracy([[0, 0], [30, 0]], [[0.2, 0, 0.002], [0, 0, 0]], 0.05,
    ...                            1e-3, n_objects=5, region=[[5, 45], [25, 65]], trials=20,
    ...                            rng=1)
    >>> acc.known.trials
    20
    """
    s = _sensors_iv(sensors)
    b = _radar_biases_iv(biases, 2)
    if b.shape != (2, 3):
        raise ValueError(f"`biases` must have shape (2, 3); received shape {b.shape}")
    n = as_int(n_objects, "n_objects", minimum=3, maximum=1000)
    reg = as_float_array(region, "region")
    if reg.shape != (2, 2) or np.any(reg[1] <= reg[0]):
        raise ValueError(f"`region` must be [[x_min, y_min], [x_max, y_max]] with max > min; "
                         f"received {describe(reg)}")
    trials = as_int(trials, "trials", minimum=1, maximum=100_000)
    _fixed_iv(fixed, 2)                         # refused here, not swallowed per trial below
    _sigmas_iv(sigma_r, sigma_beta, 2)
    if _probability_iv(p_detect, "p_detect", open_interval=False) <= 0:
        raise ValueError(f"`p_detect` must lie in (0, 1]; received {p_detect!r}")
    gen = as_rng(rng)
    gate = None if p_false_reject is None else float(
        gating.gate_threshold(_probability_iv(p_false_reject, "p_false_reject"), 2))
    ok = np.zeros((4, trials), dtype=bool)
    for k in range(trials):
        x = gen.uniform(reg[0], reg[1], size=(n, 2))
        sc = simulate_scene(s, x, b, sigma_r, sigma_beta, p_detect=p_detect, rng=gen)
        for row, bb in ((0, None), (2, b)):
            c = cost_matrix(s, sc.reports1, sc.reports2, sigma_r, sigma_beta, biases=bb)
            ok[row, k] = np.array_equal(
                assign_two_lists(c, threshold=gate).row_to_col, sc.true_row_to_col)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RadarFusionWarning)
            try:
                r = register_and_associate(s, sc.reports1, sc.reports2, sigma_r, sigma_beta,
                                           fixed=fixed, p_false_reject=p_false_reject)
            except (RegistrationError, ValueError):
                continue
        if r.estimate is None:                  # nothing registered: scored as wrong
            continue
        ok[1, k] = np.array_equal(r.association.row_to_col, sc.true_row_to_col)
        ok[3, k] = r.converged
    return AccuracyComparison(*(proportion(o, None) for o in ok))
