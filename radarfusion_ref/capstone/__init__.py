r"""A fusion centre over real air traffic: three radars, the whole pipeline, GOSPA.

The truth is one hour of ADS-B records over Switzerland (2018-08-01 11:00–12:00 UTC,
142 aircraft, en-route traffic at 30 000–47 000 ft) from the ``traffic`` package's
samples, shipped inside this package (``capstone/data/``). The subpackage has one
module per concept:

* :mod:`~radarfusion_ref.capstone.traffic` — loads the hour (:func:`load_traffic`, read
  with :mod:`importlib.resources`) and interpolates the aircraft at the scan times in
  the east-north-up frame about :data:`ORIGIN` (:func:`truth_scans`; the WGS-84
  projection is :func:`radarfusion_ref.engine.geodesy.geodetic_to_enu`); the country
  borders for maps (:func:`border_lines`);
* :mod:`~radarfusion_ref.capstone.radars` — three radars at stated sites
  (:data:`RADAR_SITES`, :func:`default_radars`) reporting range, azimuth, elevation and
  a speed feature, with noise, systematic biases, missed detections, clutter and
  coverage limits (:func:`simulate_reports`, :func:`coverage_count`; :func:`as_radars`
  is the door check of every `radars` argument);
* :mod:`~radarfusion_ref.capstone.detections` — the radars' reports over time
  (:func:`simulate_detections`): synchronous in the common frame (``mode="simple"``), or
  each radar at its own period and phase in its own east-north-up frame
  (``"realistic"``, :func:`realistic_radars`); :func:`to_common` converts them, with a
  registration estimate, into the common frame, and :func:`truth_at` gives the truth at
  any instant;
* :mod:`~radarfusion_ref.capstone.pipeline` — the fusion centre scan by scan
  (:func:`run_pipeline`, configured by a frozen :class:`PipelineSettings`), each step
  calling the function its chapter teaches;
* :mod:`~radarfusion_ref.capstone.evaluation` — scores against the truth
  (:func:`evaluate`, over the truth sets :data:`SCOPES`) with the engine's metrics
  (:mod:`radarfusion_ref.engine.metrics`: GOSPA, NEES, purity); :func:`gospa_parameters`
  checks an evaluation's GOSPA cut-off and order at GOSPA's own door;
* :mod:`~radarfusion_ref.capstone.scenes` — named experiments (:class:`Scene`: radars,
  window, settings, scoring), among them :func:`hard_scene`, where every stage matters.

.. rubric:: References

.. [1] A. S. Rahmathullah, Á. F. García-Fernández, L. Svensson, "Generalized
   optimal sub-pattern assignment metric", FUSION 2017 (GOSPA, eqs. 1–2 and
   the decomposition for α = 2).
.. [2] X. Olive, "traffic, a toolbox for processing and analysing air traffic
   data", JOSS 4(39) 1518 (2019) — the source of the ADS-B samples.
"""

from .detections import (
    MODES,
    Detections,
    local_rotation,
    register_detections,
    simulate_detections,
    to_common,
)
from .evaluation import SCOPES, Evaluation, evaluate, gospa_parameters
from .pipeline import (
    MIN_REGISTRATION_GROUPS,
    SPEED_TYPE_MEANS,
    SPEED_TYPE_VARS,
    STAGES,
    PipelineResult,
    PipelineSettings,
    run_pipeline,
)
from .radars import (
    RADAR_SITES,
    REALISTIC_TIMING,
    Radar,
    Reports,
    as_radars,
    coverage_count,
    default_radars,
    realistic_radars,
    simulate_reports,
)
from .scenes import FAR_SITES, Scene, hard_scene
from .traffic import (
    BORDERS_FILE,
    COLUMNS,
    DATA_FILE,
    FRESH_BAND,
    HOURS,
    ORIGIN,
    SPEED_BOUNDS,
    SPEED_CLASSES,
    TUNING_FILE,
    Traffic,
    TruthScans,
    border_lines,
    load_traffic,
    truth_at,
    truth_scans,
)

__all__ = [
    "BORDERS_FILE",
    "COLUMNS",
    "DATA_FILE",
    "FAR_SITES",
    "FRESH_BAND",
    "HOURS",
    "MIN_REGISTRATION_GROUPS",
    "MODES",
    "ORIGIN",
    "RADAR_SITES",
    "REALISTIC_TIMING",
    "SCOPES",
    "SPEED_BOUNDS",
    "SPEED_CLASSES",
    "SPEED_TYPE_MEANS",
    "SPEED_TYPE_VARS",
    "STAGES",
    "TUNING_FILE",
    "Detections",
    "Evaluation",
    "PipelineResult",
    "PipelineSettings",
    "Radar",
    "Reports",
    "Scene",
    "Traffic",
    "TruthScans",
    "as_radars",
    "coverage_count",
    "default_radars",
    "evaluate",
    "gospa_parameters",
    "hard_scene",
    "border_lines",
    "load_traffic",
    "local_rotation",
    "realistic_radars",
    "register_detections",
    "run_pipeline",
    "simulate_detections",
    "simulate_reports",
    "to_common",
    "truth_at",
    "truth_scans",
]
