r"""From reports to tracks: one tracker over the radars' reports, and three architectures.

* :class:`TrackerSettings` — the tracker's settings, validated when built;
* :class:`TrackHistory` — tracks over time, one row per (track, update);
* :func:`track_reports` — architecture (a): every report, in time order, updates one
  tracker (GNN or JPDA, the track score's sequential test or M-of-N logic);
* :func:`fuse_then_track` — architecture (b): the radars' scans grouped and fused per time
  window, then tracked;
* :func:`track_then_fuse` — architecture (c): a tracker per radar, then track-to-track
  fusion (covariance intersection).

The formulas (Kalman filter, track score, JPDA probabilities) live in
:mod:`radarfusion_ref.engine.tracking`.

.. rubric:: References

.. [1] S. Blackman, R. Popoli, *Design and Analysis of Modern Tracking Systems*,
   Artech House, 1999, ch. 6 and 7.
.. [2] Y. Bar-Shalom, P. Willett, X. Tian, *Tracking and Data Fusion: A Handbook of
   Algorithms*, YBS Publishing, 2011.
"""

from ._architectures import T2T_RULES, fuse_then_track, track_then_fuse
from ._centralised import MAX_REPORTS, track_reports
from ._settings import ASSOCIATIONS, CONFIRMATIONS, TrackerSettings, TrackHistory

__all__ = [
    "ASSOCIATIONS",
    "CONFIRMATIONS",
    "MAX_REPORTS",
    "T2T_RULES",
    "TrackHistory",
    "TrackerSettings",
    "fuse_then_track",
    "track_reports",
    "track_then_fuse",
]
