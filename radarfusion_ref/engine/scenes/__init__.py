"""Simulated scenes: the book's scene simulators, in one place, with one vocabulary.

Every chapter that needs reports to associate, group or fuse draws them here.

.. rubric:: The simulators

* :func:`two_radar_scene` → :class:`TwoRadarScene`: n objects, two radars,
  every object seen once by each (chapters 2-4);
* :func:`two_radar_clutter_scene` → :class:`ClutterScene`: the same with
  missed detections and false reports (chapter 4);
* :func:`typed_scene` → :class:`TypedScene`: the same objects with types and
  feature reports (chapter 5);
* :func:`grouping_scene` → :class:`GroupingScene`: n objects, m sources,
  general report covariances (chapter 8);
* :func:`polar_scene` → :class:`PolarReports`: a given geometry, two
  separated radars measuring range and azimuth (chapter 7).

.. rubric:: One convention for all of them

*Arguments.* The counts that size the scene are positional: ``n_objects``
(then ``n_sources`` for :func:`grouping_scene`); :func:`polar_scene`, whose
objects sit at given places, takes a ``geometry`` instead. Everything else is
keyword-only and, in every signature and docstring, comes in one order:

1. placement — ``spacing``, ``layout`` (``"line"`` or ``"uniform"``);
2. measurement errors — ``sigma1``, ``sigma2`` (per coordinate, per radar),
   or ``cov`` (one covariance per report), or ``sigma_r``, ``sigma_beta``;
3. detection — ``p_detect1``, ``p_detect2``;
4. clutter — ``false_density1``, ``false_density2`` (false reports per unit
   volume);
5. what the scene adds — feature types (``type_means``, ``type_vars``,
   ``priors``, ``feature_sigma1``, ``feature_sigma2``, ``model``) or fused
   tracks (``track_cov``);
6. size — ``trials``, ``dim``;
7. ``rng`` — None, a seed or a :class:`numpy.random.Generator` (SPEC 7); the
   same seed gives bit-identical scenes, and each docstring states the order
   of the draws.

*Names.* ``truth`` are the true object positions; ``reports`` (``reports1``,
``reports2`` for two radars) the measured ones; ``owner`` (``owner1``,
``owner2``) the object behind each report — ``-1`` a false report, ``-2``
padding (report lists of different lengths are padded to a common one);
``cov`` a report's error covariance; ``true_row_to_col`` (two radars) and
``true_groups`` (m sources) the correct decisions.

*Shapes.* The trial axis comes first: ``truth`` is ``(trials, n, d)``, a
radar's reports ``(trials, k, d)``, m sources' reports ``(trials, m, k, d)``,
per-report numbers (owners, features, ranges) ``(trials, k)``. Every result
derives from :class:`Scene`, which reads ``trials``, ``n_objects`` and
``dim`` off ``truth``.

*Size.* Scenes are drawn in memory; a request beyond
:data:`radarfusion_ref.engine.validation.MEMORY_LIMIT` is refused before anything is
allocated (draw the trials in batches from generators spawned from one
:class:`numpy.random.SeedSequence`).

The geometry of :func:`polar_scene` (two radars, targets at given places) is
:mod:`radarfusion_ref.engine.geometry`.

Also here: :func:`binding_hypotheses` (every binding of m sources' reports to n
tracks, in the order of :meth:`GroupingScene.true_hypothesis`),
:func:`nearest_neighbour_pairing` (the naive rule the book starts from) and
:func:`ellipse_covariance` (a 2-D covariance from its ellipse) and :func:`as_type_model`
(the door of a type description, shared with the feature rules of chapter 5).
"""

from ._base import FEATURE_MODELS, LAYOUTS, Scene, as_type_model
from ._grouping import MAX_BINDING_HYPOTHESES, GroupingScene, binding_hypotheses, grouping_scene
from ._helpers import ellipse_covariance, nearest_neighbour_pairing
from ._polar import PolarReports, polar_scene
from ._two_radar import (
    ClutterScene,
    TwoRadarScene,
    TypedScene,
    two_radar_clutter_scene,
    two_radar_scene,
    typed_scene,
)

__all__ = [
    "Scene",
    "TwoRadarScene",
    "ClutterScene",
    "TypedScene",
    "GroupingScene",
    "PolarReports",
    "FEATURE_MODELS",
    "LAYOUTS",
    "MAX_BINDING_HYPOTHESES",
    "two_radar_scene",
    "two_radar_clutter_scene",
    "typed_scene",
    "grouping_scene",
    "polar_scene",
    "binding_hypotheses",
    "nearest_neighbour_pairing",
    "ellipse_covariance",
    "as_type_model",
]
