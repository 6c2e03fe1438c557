r"""Pointwise and joint association of two radars' reports.

Two radars report on the same objects; the fusion centre must decide which
report of radar 1 and which report of radar 2 belong to one object. The input
of every function here is a **cost matrix** ``cost[..., i, j]`` — the proximity
measure :math:`\kappa_{ij}` (or any negative log-likelihood) of pairing report
``i`` of radar 1 with report ``j`` of radar 2. ``+inf`` marks a forbidden pair;
NaN and ``-inf`` are refused.

Procedures (Grachov & Korneev 2010, text around eqs. (5)–(6)):

* :func:`associate_pointwise` — the paper's simplified pointwise rule: scan the
  :math:`n^2` pairwise hypotheses :math:`G_k`, accept the first one whose
  :math:`\kappa` is below the gate, remove both reports, go on
  (``order="scan"``); or the greedy best-first variant (``order="best_first"``);
* the joint maximum-likelihood hypothesis :math:`H_n` — the complete pairing
  with the smallest summed cost — is a linear (2-D) assignment problem: the
  chapter builds its cost (:func:`proximity_matrix`, the gate, the
  non-assignment cost) and hands it to the engine's solvers,
  :func:`radarfusion_ref.engine.assignment.assign_two_lists` (exact, :math:`O(n^3)`;
  rectangular matrices, gating and a per-report non-assignment cost),
  :func:`radarfusion_ref.engine.assignment.assign_two_lists_bruteforce` (the same
  optimum by enumerating every joint hypothesis, the :math:`n!` route, small
  :math:`n` only) and :func:`radarfusion_ref.engine.assignment.k_best_two_lists`
  (Murty's ranking of the :math:`k` best joint hypotheses); their results,
  :class:`radarfusion_ref.engine.assignment.Association` and
  :class:`radarfusion_ref.engine.assignment.KBestAssignments`, share the
  vocabulary ``cost``, ``lower_bound``, ``gap``, ``history``, ``exact`` with
  the decisions in ``row_to_col``;
* :func:`association_probabilities` — the chapter's hypothesis likelihood
  :math:`e^{-C(\pi)}` turned into marginal association probabilities, exact
  (enumeration) or approximated from the :math:`k` best;
* :func:`non_assignment_cost` — the non-assignment cost implied by the
  likelihood ratio (detection probabilities, false-report densities);
* the scenes of the chapter come from
  :func:`radarfusion_ref.engine.scenes.two_radar_clutter_scene` (missed detections and
  false reports included);
* :func:`compare_decisions` — the Monte-Carlo decision-level comparison of the
  three procedures used by the chapter;
* :func:`decision_outcome` and :func:`calibrate_gate` — every rule's decisions
  classified per trial (correct, false accept, rejected), and the gate that
  puts a rule at a given false-accept or false-reject rate (the fair
  comparison of the rules at the same error rate).

The module adds the chapter's meaning — its costs, its gates, its hypothesis
likelihood and its decision rules — and does not rename a solver: the 2-D
assignment has one home, :mod:`radarfusion_ref.engine.assignment`.

.. rubric:: References

.. [1] V. M. Grachov, V. A. Korneev, "Method of combining radar information
   taking coordinate and feature measurements into account", Kharkiv Air
   Force University, 2010 — eqs. (5)–(7) and the joint proximity measure.
.. [2] K. G. Murty, "An algorithm for ranking all the assignments in order of
   increasing cost", Operations Research 16 (1968) 682–687.
.. [3] M. L. Miller, H. S. Stone, I. J. Cox, "Optimizing Murty's ranked
   assignment method", IEEE Trans. AES 33 (1997) 851–862.
.. [4] D. F. Crouse, "On implementing 2D rectangular assignment algorithms",
   IEEE Trans. AES 52 (2016) 1679–1696.
"""

from __future__ import annotations

from ._costs import non_assignment_cost, proximity_matrix
from ._decisions import (
    DecisionComparison,
    DecisionOutcome,
    all_correct,
    calibrate_gate,
    compare_decisions,
    decision_outcome,
    outcome_by_gate,
)
from ._rules import (
    associate_pointwise,
    association_probabilities,
)

__all__ = [
    "DecisionComparison",
    "DecisionOutcome",
    "all_correct",
    "associate_pointwise",
    "association_probabilities",
    "calibrate_gate",
    "compare_decisions",
    "decision_outcome",
    "non_assignment_cost",
    "outcome_by_gate",
    "proximity_matrix",
]
