r"""Feature (attribute) measurements: type recognition and feature-aided association.

Besides a coordinate :math:`\hat x_i`, each radar reports a *feature*
:math:`\hat\Pi_i = \Pi + \Delta\Pi_i` (a signal, trajectory or behaviour
parameter), :math:`\Delta\Pi_i \sim \mathcal N(0, \sigma_{\Pi i}^2)`. An
object of type :math:`T_k` has a feature value drawn from the type-conditional
density (Grachov & Korneev 2010, eq. (8), corrected — see the chapter)

.. math::

    f(\Pi \mid T_k) = \mathcal N(\Pi;\ \Pi_k, \sigma_{\Pi k}^2),
    \qquad k = 1, \dots, K.

.. rubric:: Public functions

* :func:`fused_feature` — the maximum-likelihood fused feature of two reports
  and its variance;
* :func:`type_likelihood` — :math:`f(\hat\Pi \mid T_k)` for a feature measured
  with variance :math:`v` (the type density convolved with the error);
* :func:`type_posterior` — the type posterior (13), computed in the log domain;
* :func:`pair_type_posterior` — the type posterior from both radars' reports,
  under either feature observation model;
* :func:`combined_proximity` — the coordinate + feature proximity measure (12)
  (vector coordinates allowed), for both feature observation models;
* the scenes these functions take come from
  :func:`radarfusion_ref.engine.scenes.typed_scene`;
* :func:`association_costs` — the :math:`n \times n` cost matrices of a scene;
* :func:`triune` — the association – estimation – recognition outcome of a
  given association, with accuracy, RMSE and a confusion matrix;
* :func:`reliability_curve` — binned calibration of predicted probabilities.

Two feature observation models are supported (the paper's closing discussion):
``"shared"`` (model 1: both radars see the same value :math:`\Pi`, their
reports differ only by measurement error) and ``"spread"`` (model 2: each
radar sees its own value, drawn from the type's density, so the reports of
one object differ by the type's spread as well).

.. rubric:: References

.. [1] V. M. Grachov, V. A. Korneev, "Method of combining radar information
   taking coordinate and feature measurements into account", Kharkiv Air
   Force University, 2010 — eqs. (8)–(13) and the two feature observation
   models.
"""

from __future__ import annotations

from ._common import (
    MAX_BINS,
)
from ._evaluation import (
    Confusion,
    ReliabilityCurve,
    TriuneResult,
    reliability_curve,
    triune,
)
from ._proximity import (
    CombinedProximity,
    association_costs,
    combined_proximity,
    type_agreement,
)
from ._recognition import (
    FusedFeature,
    fused_feature,
    pair_type_posterior,
    type_likelihood,
    type_posterior,
)

__all__ = [
    "MAX_BINS",
    "CombinedProximity",
    "Confusion",
    "FusedFeature",
    "ReliabilityCurve",
    "TriuneResult",
    "association_costs",
    "combined_proximity",
    "fused_feature",
    "pair_type_posterior",
    "reliability_curve",
    "triune",
    "type_agreement",
    "type_likelihood",
    "type_posterior",
]
