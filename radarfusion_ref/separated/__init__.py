r"""Associating the reports of two spatially separated radars (Prosov).

Two radars a base :math:`B` apart (radar 2 at azimuth :math:`\beta_0` of the
base, seen from radar 1) measure range and azimuth of the same targets. Each
report is converted to Cartesian coordinates in its own radar's frame
(:func:`radarfusion_ref.conversion.polar_to_cartesian`, linearized or
bias-corrected), radar 2's reports are shifted into radar 1's frame, and every
pair (report :math:`q` of radar :math:`p`, report :math:`f` of radar :math:`g`)
is scored by the proximity measure (the book's notation; the paper's quadratic
form :math:`S^{qf}_{pg}` with :math:`\hat\alpha \to \hat x`, :math:`C \to \Sigma`)

.. math::

    \kappa_{jk} = \Delta_{jk}^T S_{jk}^{-1} \Delta_{jk}, \quad
    \Delta_{jk} = \hat x_{1j} - \hat x_{2k}, \quad S_{jk} = \Sigma_{1j} + \Sigma_{2k},

which is :math:`\chi^2(2)` when the two reports belong to one target (and the
conversion is unbiased with a correct covariance), and noncentral
:math:`\chi'^2(2, \lambda)` otherwise. A pair passes the gate when
:math:`\kappa` is below the gate :math:`\gamma`, the :math:`\chi^2(2)` quantile at the false-rejection
probability :math:`P_{\text{lo}} = 0.01`.

Decision outcomes (Table 1 of the paper), for the report of target :math:`i`
by radar 1 compared with every report of radar 2:

* **correct** — exactly one radar-2 report passes the gate, and it is target
  :math:`i`'s;
* **wrong association** — exactly one passes, and it is another target's;
* **no decision** — none passes, or more than one does (for two targets: the
  true and the false pair both pass, or both fail).

.. rubric:: Public functions

* :func:`paper_geometry` — the paper's scene (the geometry itself,
  :class:`~radarfusion_ref.engine.geometry.Geometry`, lives in the engine);
* :func:`radarfusion_ref.engine.scenes.polar_scene` — noisy polar reports of
  both radars, trial axis first;
* :func:`to_common_frame` — conversion to Cartesian in radar 1's frame;
* :func:`pair_statistic` — :math:`\kappa` for every pair, by a hand-written batched
  2×2 Cholesky factorisation (and :math:`\ln\det`);
* :func:`per_report_outcome`, :func:`joint_outcome` — the decision rules;
* :func:`association_experiment` — the Table 1 Monte-Carlo experiment,
  chunked, with common random numbers across methods;
* :func:`false_pair_noncentrality`, :func:`approximate_outcomes`,
  :func:`fit_target2_offset` — the linear-Gaussian approximation and the
  placement of target 2 fitted to the paper's linearized row.

Units: kilometres and radians throughout.

.. rubric:: References

.. [1] A. V. Prosov, "Analysis of the effect of linearization errors of radar
   measurements on the reliability of associating data from spatially
   separated radars" — Fig. 1, eqs. (1)–(4), the quadratic form :math:`\kappa`,
   Table 1.
.. [2] D. Lerro, Y. Bar-Shalom, "Tracking with debiased consistent converted
   measurements versus EKF", IEEE Trans. AES 29 (1993) 1015–1022.
"""
from ._approximation import approximate_outcomes, false_pair_noncentrality
from ._experiment import (
    ExperimentResult,
    MethodResult,
    OffsetSweep,
    association_experiment,
    collect,
    fit_target2_offset,
    offset_sweep,
)
from ._scenario import (
    CORRECT,
    MAX_GRID_POINTS,
    MAX_JOINT_PAIRINGS,
    NO_DECISION,
    OUTCOMES,
    PAPER,
    PAPER_TABLE1,
    WRONG,
    paper_geometry,
)
from ._statistic import (
    CartesianReports,
    joint_outcome,
    pair_statistic,
    per_report_outcome,
    to_common_frame,
)

__all__ = [
    "CORRECT",
    "WRONG",
    "NO_DECISION",
    "OUTCOMES",
    "PAPER",
    "MAX_JOINT_PAIRINGS",
    "MAX_GRID_POINTS",
    "PAPER_TABLE1",
    "CartesianReports",
    "MethodResult",
    "ExperimentResult",
    "paper_geometry",
    "to_common_frame",
    "pair_statistic",
    "per_report_outcome",
    "joint_outcome",
    "association_experiment",
    "false_pair_noncentrality",
    "approximate_outcomes",
    "collect",
    "OffsetSweep",
    "offset_sweep",
    "fit_target2_offset",
]
