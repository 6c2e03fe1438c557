r"""Assignment solvers: the 2-D (two lists) and S-D (many lists) assignment problems.

One home for the solvers shared by the association (chapter 4), the separated
radars (chapter 7) and the grouping of many sources (chapter 8):
:mod:`radarfusion_ref.association` and :mod:`radarfusion_ref.grouping` build
costs from reports and call the functions here.

.. rubric:: Public functions

* :func:`assign_two_lists` — the minimum-cost 2-D assignment of a dense cost matrix
  (batched) or a gated ``scipy.sparse`` one, with an optional gate and a
  per-report non-assignment cost; :func:`assign_two_lists_bruteforce` — the same
  optimum by enumeration (the reference route, small matrices);
  :func:`k_best_two_lists` — Murty's ranking of the ``k`` best complete assignments;
* :func:`assign_s_lists` — the S-D assignment (one report of each of ``m`` sources
  per group) over a full cost tensor or over explicit candidate groups
  (gated, with ``-1`` for a source without a report in a group): exact
  (``method="milp"``, HiGHS) or to a proved relative duality gap
  (``method="lagrangian"``: dense on a full tensor, sized by bytes, cluster
  by cluster on candidates); :func:`assign_s_lists_bruteforce` — the exact optimum
  of a full tensor by enumerating the :math:`(n!)^{m-1}` groupings;
  :func:`sd_constraint_matrix` — the constraints of the S-D integer program.

.. rubric:: Doors and kernels for the chapter modules

The association and grouping chapters build their own rules from the solvers' parts,
public here: the doors :func:`as_cost` and :func:`as_threshold`; the kernels (trusted
input) :func:`cost_exponents` and :func:`scale_costs` (exact power-of-two scaling),
:func:`injections` and :data:`BLOCK_BYTES` (the enumerations), :func:`make_association`,
:func:`relative_gap`, :func:`dense_work_bytes`, and the S-D solvers' kernels
:func:`sd_milp_kernel`, :func:`sd_dense_lagrangian_kernel`, :func:`sd_candidates_kernel` and
:func:`sd_enumerate_kernel`.

.. rubric:: One result vocabulary

Every result — :class:`Association` (2-D), :class:`KBestAssignments` (ranked
2-D), :class:`SDAssignment` (S-D) and
:class:`radarfusion_ref.grouping.GroupingResult` — follows the
:class:`AssignmentResult` protocol, each attribute a plain dataclass field:
``cost`` (the total cost), ``lower_bound`` (a proved lower bound on the
optimal cost), ``gap`` (the proved relative gap
:math:`(\text{cost} - \text{lower bound})/\max(|\text{cost}|, 1)`),
``history`` (bound and cost per iteration, or None) and ``exact`` (whether
the result is a proved optimum). The decisions carry the name of what they
are: ``row_to_col`` (2-D, one vector per matrix or per ranked hypothesis)
and ``groups`` (S-D).

.. rubric:: Layout

One private module per concept, their public names gathered here: ``_two_d``
(dense, sparse and enumerated 2-D assignment), ``_murty`` (the k best),
``_sd`` (the public S-D solvers and the enumeration) with ``_milp`` (HiGHS:
the full tensor and explicit candidates), ``_lagrangian`` (Deb et al., on
candidates) and ``_dense`` (the Lagrangian on a full tensor),
``_results`` (the result classes) and ``_checks`` (the shared input checks).

.. rubric:: Conventions

A cost is a negative log-likelihood (or a proximity measure
:math:`\kappa`): ``+inf`` forbids a pair or a group in a dense array, a
missing entry forbids it in a sparse matrix; NaN and ``-inf`` are refused, as
is a stored ``+inf``, NaN or ``-inf`` in a sparse matrix.

.. rubric:: References

.. [1] K. G. Murty, "An algorithm for ranking all the assignments in order of
   increasing cost", Operations Research 16 (1968) 682–687.
.. [2] M. L. Miller, H. S. Stone, I. J. Cox, "Optimizing Murty's ranked
   assignment method", IEEE Trans. AES 33 (1997) 851–862.
.. [3] D. F. Crouse, "On implementing 2D rectangular assignment algorithms",
   IEEE Trans. AES 52 (2016) 1679–1696.
.. [4] S. Deb, M. Yeddanapudi, K. Pattipati, Y. Bar-Shalom, "A generalized S-D
   assignment algorithm for multisensor-multitarget state estimation", IEEE
   Trans. AES 33 (1997) 523–538.
.. [5] P. M. Camerini, L. Fratta, F. Maffioli, "On improving relaxation methods
   by modified gradient techniques", Mathematical Programming Study 3 (1975)
   26–34.
.. [6] J.-L. Goffin, K. C. Kiwiel, "Convergence of a simple subgradient level
   method", Mathematical Programming 85 (1999) 207–211.
"""

from __future__ import annotations

from ._checks import as_cost, as_threshold, cost_exponents, scale_costs
from ._dense import dense_work_bytes, sd_dense_lagrangian_kernel
from ._lagrangian import sd_candidates_kernel
from ._milp import MAX_SD_TUPLES, sd_constraint_matrix, sd_milp_kernel
from ._murty import MAX_K_BEST, k_best_two_lists
from ._results import (
    AssignmentResult,
    Association,
    KBestAssignments,
    SDAssignment,
    relative_gap,
)
from ._sd import MAX_SD_GROUPINGS, assign_s_lists, assign_s_lists_bruteforce, sd_enumerate_kernel
from ._two_d import (
    BLOCK_BYTES,
    MAX_HYPOTHESES,
    MAX_PARTIAL_MATCHINGS,
    MAX_SCORED_HYPOTHESES,
    assign_two_lists,
    assign_two_lists_bruteforce,
    injections,
    make_association,
)

__all__ = [
    "BLOCK_BYTES",
    "MAX_HYPOTHESES",
    "MAX_K_BEST",
    "MAX_PARTIAL_MATCHINGS",
    "MAX_SCORED_HYPOTHESES",
    "MAX_SD_GROUPINGS",
    "MAX_SD_TUPLES",
    "Association",
    "AssignmentResult",
    "KBestAssignments",
    "SDAssignment",
    "as_cost",
    "as_threshold",
    "cost_exponents",
    "dense_work_bytes",
    "injections",
    "k_best_two_lists",
    "make_association",
    "relative_gap",
    "scale_costs",
    "sd_candidates_kernel",
    "sd_constraint_matrix",
    "sd_dense_lagrangian_kernel",
    "sd_enumerate_kernel",
    "sd_milp_kernel",
    "assign_two_lists",
    "assign_two_lists_bruteforce",
    "assign_s_lists",
    "assign_s_lists_bruteforce",
]

