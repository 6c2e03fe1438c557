"""Grouping the reports of m sources about n targets (the sonar paper).

Each of ``m`` sources (hydroacoustic stations, radars) reports every one of
``n`` targets once, already in one frame and at one time; the report order
says nothing about which target produced it. A *grouping* puts the ``m * n``
reports into ``n`` groups holding one report of each source. This module

* counts the groupings (:func:`n_groupings`), with and without *binding* the
  groups to ``n`` existing fused tracks;
* scores a candidate group by the exact maximum-likelihood cost or by the
  paper's sum of pairwise quadratic forms (:func:`group_costs`);
* finds the best grouping by brute-force enumeration (:func:`group_bruteforce`)
  or exactly as an S-D (multidimensional) assignment integer program solved
  by HiGHS (:func:`group_sd`);
* scores the ``(n!)**m`` binding hypotheses — the paper's hypotheses I–IV for
  two sources and two tracks — by the paper's product of independent
  densities or by the exact likelihood (:func:`binding_costs`);
* is tried on the scenes of :func:`radarfusion_ref.engine.scenes.grouping_scene`.

Arrays follow one convention: ``x[..., i, j, :]`` is report ``j`` of source
``i`` (shape ``(..., m, n, d)``) and ``cov[..., i, j, :, :]`` its error
covariance (shape ``(..., m, n, d, d)``, broadcastable). A grouping is an
integer array ``groups`` of shape ``(n, m)``: row ``k`` lists, for every
source ``i``, the index ``groups[k, i]`` of its report in group ``k``. Rows
are sorted so that ``groups[:, 0] == arange(n)``, which makes a grouping's
array unique.

.. rubric:: References

.. [1] "Optimal association of information from hydroacoustic stations",
   National Security and Strategic Planning, no. 3 (2013), eqs. (4)–(26)
   (in Russian).
.. [2] S. Deb, M. Yeddanapudi, K. Pattipati, Y. Bar-Shalom, "A generalized
   S-D assignment algorithm for multisensor-multitarget state estimation",
   IEEE Trans. AES 33(2) (1997) 523–538.
"""

from __future__ import annotations

from ._binding import PAPER_HYPOTHESES, binding_costs
from ._costs import group_costs, ml_group_cost, n_groupings
from ._solve import (
    MAX_CANDIDATE_GROUPS,
    MAX_GROUPINGS,
    GroupingResult,
    group_bruteforce,
    group_sd,
)

__all__ = [
    "PAPER_HYPOTHESES",
    "GroupingResult",
    "MAX_CANDIDATE_GROUPS",
    "MAX_GROUPINGS",
    "binding_costs",
    "group_bruteforce",
    "group_costs",
    "group_sd",
    "ml_group_cost",
    "n_groupings",
]
