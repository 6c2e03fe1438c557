"""Decision-level Monte Carlo: outcomes per trial, comparison of the rules, calibrated gates."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..engine import assignment
from ..engine.assignment import as_cost, as_threshold
from ..engine.montecarlo import Proportion, proportion
from ..engine.validation import (
    as_choice,
    as_float,
    as_float_array,
    as_probability,
    describe,
)
from ._rules import _as_decisions, associate_pointwise


# --------------------------------------------------------------------------- Monte Carlo
def all_correct(decided, truth) -> np.ndarray:
    """Per trial: did the decisions match the truth exactly (pairs and non-pairs)?

    Parameters
    ----------
    decided, truth : array_like of int, shape (..., n1)
        ``row_to_col`` vectors (-1 = unassigned).

    Returns
    -------
    numpy.ndarray of bool, shape (...)

    Raises
    ------
    TypeError
        If either is not an integer array (bools, strings, fractional floats).
    ValueError
        If either is empty, has entries below -1, or the shapes differ.

    Examples
    --------
    >>> all_correct([[0, 1], [1, 0]], [[0, 1], [0, 1]])
    array([ True, False])
    """
    d = _as_decisions(decided, "decided")
    t = _as_decisions(truth, "truth")
    if d.shape != t.shape:
        raise ValueError(f"`decided` and `truth` must have the same shape (..., n1); received "
                         f"{d.shape} and {t.shape}")
    return np.all(d == t, axis=-1)


@dataclass(frozen=True)
class DecisionComparison:
    r"""Probability that every pairing is correct, for three procedures.

    Attributes
    ----------
    pointwise : Proportion
        The paper's pointwise rule as written (scan order, gate on each pair).
    greedy : Proportion
        Greedy best-first with the same gate.
    joint : Proportion
        Joint ML (the 2-D assignment of
        :func:`~radarfusion_ref.engine.assignment.assign_two_lists`), followed by the paper's joint
        test (:math:`\kappa_n^* < \gamma_n`, the :math:`\chi^2_n` gate; rejection counts as
        a wrong decision).
    joint_ml : Proportion
        Joint ML alone (no test).
    """

    pointwise: Proportion
    greedy: Proportion
    joint: Proportion
    joint_ml: Proportion


def compare_decisions(kappa, truth, *, threshold, joint_threshold) -> DecisionComparison:
    r"""Monte-Carlo decision-level comparison of pointwise, greedy and joint association.

    Parameters
    ----------
    kappa : array_like, shape (trials, n, n)
        Proximity measures of each simulated scene.
    truth : array_like of int, shape (trials, n)
        Correct ``row_to_col`` of each scene.
    threshold : float or None
        Pointwise gate :math:`\gamma` (1 hypothesis, e.g.
        ``gating.gate_threshold(P_lo, d)``); None or ``+inf``: no gate.
    joint_threshold : float or None
        Joint gate on :math:`\kappa_n^*` (e.g. ``gating.gate_threshold(P_lo, n * d)``);
        None or ``+inf``: no joint test.

    Returns
    -------
    DecisionComparison
        Each field a :class:`~radarfusion_ref.engine.montecarlo.Proportion` carrying
        its trial count and 95 % Wilson interval.

    Raises
    ------
    ValueError
        For an invalid `kappa` (see :func:`~radarfusion_ref.engine.assignment.assign_two_lists`), a
        `truth` of the wrong shape or with indices out of range, or a threshold <= 0.
    TypeError
        For a non-integer `truth`.

    Examples
    --------
    >>> k = np.array([[[0.1, 4.0], [5.0, 0.2]]] * 3)
    >>> r = compare_decisions(k, [[0, 1]] * 3, threshold=6.6, joint_threshold=9.2)
    >>> float(r.joint.estimate)
    1.0
    """
    c, truth = _kappa_truth_iv(kappa, truth)
    if c.ndim != 3:
        raise ValueError(f"`kappa` must have shape (trials, n1, n2); received shape {c.shape}")
    th = as_threshold(threshold)
    jth = as_threshold(joint_threshold, "joint_threshold")
    pw = associate_pointwise(c, th, order="scan")
    gr = associate_pointwise(c, th, order="best_first")
    jt = assignment.assign_two_lists(c)
    ok_j = all_correct(jt.row_to_col, truth)
    passed = np.asarray(jt.cost) < jth
    return DecisionComparison(
        proportion(all_correct(pw.row_to_col, truth), None),
        proportion(all_correct(gr.row_to_col, truth), None),
        proportion(ok_j & passed, None),
        proportion(ok_j, None),
    )


# --------------------------------------------------------------------------- calibration
class DecisionOutcome(NamedTuple):
    """Per-trial classes of one rule's decisions (see :func:`decision_outcome`).

    Attributes
    ----------
    correct : numpy.ndarray of bool, shape (...)
        Every pair right and accepted (for ``"joint"``: and the joint test passed).
    false_accept : numpy.ndarray of bool, shape (...)
        At least one wrong pair accepted.
    rejected : numpy.ndarray of bool, shape (...)
        (property) Neither: nothing wrong accepted, but some true pair not.
    """

    correct: np.ndarray
    false_accept: np.ndarray

    @property
    def rejected(self) -> np.ndarray:
        """Nothing wrong accepted, some true pair not accepted."""
        return ~self.correct & ~self.false_accept


_RULES = ("scan", "greedy", "joint")


def _kappa_truth_iv(kappa, truth):
    """`kappa` (..., n1, n2) and the true partners `truth` (..., n1): one check for both."""
    c = as_cost(kappa, "kappa")
    t = _as_decisions(truth, "truth")
    if t.shape != c.shape[:-1]:
        raise ValueError(f"`truth` must have shape (..., n1) = {c.shape[:-1]} to match `kappa`; "
                         f"received shape {t.shape}")
    if np.any(t >= c.shape[-1]):
        raise ValueError(f"`truth` entries must be radar-2 indices < n2 = {c.shape[-1]} or -1; "
                         f"received largest entry {int(t.max())}")
    return c, t


def _outcome_iv(kappa, truth, rule):
    c, t = _kappa_truth_iv(kappa, truth)
    return c, t, as_choice(rule, "rule", _RULES)


def _as_gate(gate, name: str = "gate") -> float:
    g = as_float(gate, name, allow_inf=True)
    if not g > 0:
        raise ValueError(f"`{name}` must be a single number > 0 (+inf: no gate); received "
                         f"{describe(gate)}")
    return g


def outcome_by_gate(kappa, truth, rule: str):
    r"""A rule's outcome as a function of its gate.

    The result maps ``gate -> DecisionOutcome`` per trial. `kappa`, `truth`
    and `rule` as in :func:`decision_outcome` (which calls the returned
    function once); a trial is correct when every pair is right and
    accepted, a false accept when a wrong pair is accepted, rejected
    otherwise. The joint pairing does not depend on the gate, so it is
    computed once, here.

    >>> o = outcome_by_gate([[0.1, 4.0], [5.0, 0.2]], [0, 1], "joint")
    >>> bool(o(1.0).correct), bool(o(0.2).rejected)
    (True, True)
    """
    c, t, rule = _outcome_iv(kappa, truth, rule)
    if rule == "joint":
        res = _named(assignment.assign_two_lists, c)
        right = all_correct(res.row_to_col, t)
        wrong = _wrong_pair(res.row_to_col, t)
        total = np.asarray(res.cost)

        def joint(gate):
            # the joint test, kappa*_n < gamma_n
            passed = total < _as_gate(gate)
            return DecisionOutcome(right & passed, wrong & passed)
        return joint
    order = "scan" if rule == "scan" else "best_first"

    def pointwise(gate):
        decided = _named(associate_pointwise, c, _as_gate(gate),
                         order=order).row_to_col
        return DecisionOutcome(all_correct(decided, t),
                               _wrong_pair(decided, t))
    return pointwise


def _named(rule, c, *args, **kwargs):
    """``rule(c, ...)``, its summed-cost overflow refused naming `kappa`, not the solver's names."""
    try:
        return rule(c, *args, **kwargs)
    except ValueError as exc:
        if "float range" not in str(exc):
            raise
        big = float(np.max(np.where(np.isfinite(c), np.abs(c), 0.0)))
        raise ValueError(f"`kappa`: a pairing's summed kappa overflows float64 (above "
                         f"{np.finfo(float).max:.3g}); largest finite kappa received "
                         f"{big:.4g} (proximity measures this large pass no gate: give "
                         f"kappa in a smaller unit or forbid such pairs with +inf)") from None


def _wrong_pair(decided, truth):
    """Per trial: some pair accepted that the truth does not hold (a false accept)."""
    return np.any((decided >= 0) & (decided != truth), axis=-1)


def decision_outcome(kappa, truth, rule: str, gate) -> DecisionOutcome:
    r"""Classify one rule's decisions per trial: correct, false accept, or rejected.

    Parameters
    ----------
    kappa : array_like, shape (..., n1, n2)
        Proximity measures :math:`\kappa_{ij}` per trial (``+inf`` forbids a pair).
    truth : array_like of int, shape (..., n1)
        The true ``row_to_col`` per trial (-1: no partner).
    rule : {"scan", "greedy", "joint"}
        The paper's pointwise scan (:func:`associate_pointwise`,
        ``order="scan"``), greedy best-first (``order="best_first"``), or
        joint ML (:func:`~radarfusion_ref.engine.assignment.assign_two_lists`) followed by the
        joint test.
    gate : float
        The per-pair gate :math:`\gamma` of a pointwise rule, or the gate
        :math:`\gamma_n` of the joint test on the chosen pairing's summed
        :math:`\kappa`; ``+inf``: no gate.

    Returns
    -------
    DecisionOutcome
        ``(correct, false_accept)`` boolean arrays of shape (...), and the
        ``rejected`` property.

    Raises
    ------
    ValueError
        For NaN or ``-inf`` in `kappa`, a `truth` of another shape or with
        indices outside ``[-1, n2)``, an unknown `rule`, or a `gate` that is not
        a single number > 0.
    TypeError
        For non-numeric `kappa` or a `truth` that is not an integer array.

    Notes
    -----
    A trial is **correct** when every pair is right and accepted (the joint
    rule also needs :math:`\kappa^*_n < \gamma_n`), a **false accept** when
    at least one wrong pair is accepted, and **rejected** otherwise. For
    ``"greedy"`` and ``"joint"`` the false-accept rate cannot fall and the
    rejection rate cannot rise as the gate widens: greedy best-first takes
    the pairs in increasing :math:`\kappa`, so the pairs it accepts under a
    gate are a subset of those it accepts under any wider gate; the joint
    pairing does not depend on the gate at all.

    Examples
    --------
    >>> k = np.array([[[0.1, 4.0], [5.0, 0.2]], [[3.0, 0.1], [0.2, 3.0]]])
    >>> o = decision_outcome(k, [[0, 1], [0, 1]], "greedy", 6.6)
    >>> o.correct, o.false_accept, o.rejected
    (array([ True, False]), array([False,  True]), array([False, False]))
    """
    c, t, rule = _outcome_iv(kappa, truth, rule)
    gate = _as_gate(gate)
    return outcome_by_gate(c, t, rule)(gate)


def calibrate_gate(kappa, truth, rule: str, target, *, error: str = "false_accept",
                   gates=None) -> float:
    r"""The gate at which a rule's empirical error rate on these trials meets `target`.

    Parameters
    ----------
    kappa, truth, rule
        As in :func:`decision_outcome` (the calibration trials).
    target : float
        Target rate in [0, 1].
    error : {"false_accept", "false_reject"}, optional
        ``"false_accept"`` (default): the **widest** gate whose false-accept
        rate (share of trials with a wrong pair accepted) is at most `target`.
        ``"false_reject"``: the **narrowest** gate whose rejection rate (share
        of trials with nothing wrong accepted but some true pair not) is at
        most `target`.
    gates : array_like, shape (k,), optional
        Candidate gates (> 0, increasing); every one is scored and the
        widest (narrowest) one meeting `target` is returned. None (default):
        the exact answer among all gates, found by bisection over the
        breakpoints of the rate — just above each distinct :math:`\kappa`
        (pointwise rules) or each trial's summed :math:`\kappa` of the
        chosen pairing (``"joint"``), where the decisions can change. The
        bisection is exact because the rates are monotone in the gate for
        ``"greedy"`` and ``"joint"`` (see :func:`decision_outcome`); for
        ``"scan"``, whose rates need not be monotone, `gates` is required.

    Returns
    -------
    float
        The calibrated gate.

    Raises
    ------
    ValueError
        As :func:`decision_outcome`; for `target` outside [0, 1], an unknown
        `error`, `gates` that are empty, not > 0 or not increasing, no
        `gates` with ``rule="scan"``, or no candidate gate meeting `target`
        (the message gives the best rate reached; never a clamped gate).

    Notes
    -----
    Calibrate on one set of trials and evaluate on fresh ones: the rate at
    the returned gate is biased low on the trials that chose it. For one
    object (``n1 = n2 = 1``) and known covariances the true pair's
    :math:`\kappa` is :math:`\chi^2_d`, so ``error="false_reject"`` returns
    the empirical :math:`1-\alpha` quantile of :math:`\kappa`, which
    converges to the :math:`\chi^2_d` quantile of eq-gate.

    Examples
    --------
    >>> k = np.array([[[0.5]], [[1.5]], [[2.5]], [[3.5]]])
    >>> calibrate_gate(k, [[0]] * 4, "greedy", 0.25, error="false_reject") > 2.5
    True
    """
    c, t, rule = _outcome_iv(kappa, truth, rule)
    a = as_float(as_probability(target, "target", open_interval=False), "target")
    error = as_choice(error, "error", ("false_accept", "false_reject"))
    outcome = outcome_by_gate(c, t, rule)
    wide = error == "false_accept"

    def rate(g):
        o = outcome(g)
        return float(np.mean(o.false_accept if wide else o.rejected))

    if gates is not None:
        cand = as_float_array(gates, "gates")
        if (cand.ndim != 1 or cand.size == 0 or np.any(cand <= 0)
                or np.any(np.diff(cand) <= 0)):
            raise ValueError(
                "`gates` must be a non-empty increasing 1-D array of "
                f"numbers > 0; received {describe(gates)}")
        rates = np.array([rate(float(g)) for g in cand])
        ok = np.flatnonzero(rates <= a)
        if ok.size == 0:
            raise ValueError(
                f"`target` = {a:g} is not reached by any of the `gates`: "
                f"the lowest {error.replace('_', '-')} rate is "
                f"{rates.min():.4g} (at gate "
                f"{cand[int(np.argmin(rates))]:.4g}); pass "
                f"{'narrower' if wide else 'wider'} gates")
        return float(cand[ok.max()] if wide else cand[ok.min()])
    if rule == "scan":
        raise ValueError("`gates` must be given for `rule` = 'scan': its error rates need not be "
                         "monotone in the gate, so only a scored grid is exact")
    if rule == "joint":
        stat = np.asarray(assignment.assign_two_lists(c).cost, dtype=float).ravel()
    else:
        stat = c[np.isfinite(c)]
    vals = np.unique(stat[np.isfinite(stat)])
    above = np.nextafter(vals, np.inf)                 # just above: a value passes the gate
    lowest = vals[0] if vals.size and vals[0] > 0 else np.nextafter(0.0, 1.0)
    cand = np.unique(np.concatenate([[lowest], above[above > 0], [np.inf]]))
    # the rate is monotone over cand: non-decreasing (false accept), non-increasing (reject)
    lo, hi = 0, cand.size - 1
    if wide:
        if rate(cand[0]) > a:
            raise ValueError(f"`target` = {a:g} is below the false-accept rate "
                             f"{rate(cand[0]):.4g} of the narrowest gate {cand[0]:.4g}")
        while lo < hi:                                  # largest index with rate <= a
            mid = (lo + hi + 1) // 2
            lo, hi = (mid, hi) if rate(cand[mid]) <= a else (lo, mid - 1)
        return float(cand[lo])
    if rate(cand[-1]) > a:
        raise ValueError(f"`target` = {a:g} is below the rejection rate {rate(cand[-1]):.4g} "
                         "even without a gate")
    while lo < hi:                                      # smallest index with rate <= a
        mid = (lo + hi) // 2
        lo, hi = (lo, mid) if rate(cand[mid]) <= a else (mid + 1, hi)
    return float(cand[lo])
