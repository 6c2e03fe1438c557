r"""From reports to tracks: one tracker over the radars' reports, and three architectures.

* :class:`TrackerSettings` — the tracker's settings, validated when built (defaults tuned
  on the tuning hour); :data:`IMM_SETTINGS` — ours with the interacting multiple model and
  :data:`STONESOUP_SETTINGS` — Stone Soup's (``stonesoup_track`` keyword arguments), tuned
  by the same protocol;
* :class:`TrackHistory` — tracks over time, one row per (track, update);
* :func:`track_reports` — architecture (a): every report, in time order, updates one
  tracker (GNN or JPDA, the track score's sequential test or M-of-N logic);
* :func:`fuse_then_track` — architecture (b): the radars' scans grouped and fused per time
  window, then tracked;
* :func:`track_then_fuse` — architecture (c): a tracker per radar, then track-to-track
  fusion (covariance intersection, naive or Bar-Shalom–Campo);
* :func:`~radarfusion_ref.tracking.stonesoup.stonesoup_track` — Stone Soup's GNN and JPDA
  trackers on the same reports, for comparison (Stone Soup imported when called);
* :func:`tracks_at` — the confirmed tracks of a history at any instants;
* :func:`evaluate_tracks` — GOSPA over time, track switches against the true identities,
  tracks per target, false tracks per hour, confirmation latency and NEES, against a
  truth given as arrays (time, position, id); :func:`evaluate_tracks_over_time` the same
  against the ADS-B truth; :func:`summarise_runs` their means over seeds with intervals,
  and :func:`load_scored_runs` the same from a benchmark's CSV table.

The formulas (Kalman filter, track score, JPDA probabilities) live in
:mod:`radarfusion_ref.engine.tracker`.

.. rubric:: References

.. [1] S. Blackman, R. Popoli, *Design and Analysis of Modern Tracking Systems*,
   Artech House, 1999, ch. 6 and 7.
.. [2] Y. Bar-Shalom, P. Willett, X. Tian, *Tracking and Data Fusion: A Handbook of
   Algorithms*, YBS Publishing, 2011.
"""

from ._architectures import T2T_RULES, fuse_then_track, track_then_fuse
from ._centralised import MAX_REPORTS, track_reports
from ._evaluation import (
    TrackingMetrics,
    TrackStates,
    evaluate_tracks,
    evaluate_tracks_over_time,
    load_scored_runs,
    summarise_runs,
    tracks_at,
)
from ._settings import (
    ASSOCIATIONS,
    CONFIRMATIONS,
    IMM_SETTINGS,
    STONESOUP_SETTINGS,
    TrackerSettings,
    TrackHistory,
)
from .stonesoup import STONESOUP_TRACKERS, stonesoup_track

__all__ = [
    "ASSOCIATIONS",
    "CONFIRMATIONS",
    "IMM_SETTINGS",
    "MAX_REPORTS",
    "STONESOUP_SETTINGS",
    "STONESOUP_TRACKERS",
    "T2T_RULES",
    "TrackHistory",
    "TrackerSettings",
    "TrackStates",
    "TrackingMetrics",
    "evaluate_tracks",
    "evaluate_tracks_over_time",
    "fuse_then_track",
    "load_scored_runs",
    "stonesoup_track",
    "summarise_runs",
    "track_reports",
    "track_then_fuse",
    "tracks_at",
]
