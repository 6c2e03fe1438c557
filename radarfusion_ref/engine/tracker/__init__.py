r"""Tracking: the constant-velocity Kalman filter, the track score and JPDA.

The one home of the formulas a tracker is built from; the chapter module
:mod:`radarfusion_ref.tracking` runs them over time and
:mod:`radarfusion_ref.trackfusion` predicts with them.

* :func:`kalman_predict`, :func:`kalman_update` — the constant-velocity filter with
  position reports, each with its own covariance;
* :func:`sprt_thresholds`, :func:`score_increments`, :func:`m_of_n` — the track score as
  a log-likelihood ratio, Wald's sequential test on it, and M-of-N logic;
* :func:`jpda_probabilities` — JPDA association probabilities, exact or from the k best
  joint events with a proved truncation bound;
* :func:`imm_mixing`, :func:`imm_predict`, :func:`imm_update`, :func:`imm_combine` — the
  interacting multiple model filter of constant-velocity modes of different process noise.

.. rubric:: References

.. [1] R. W. Sittler, "An optimal data association problem in surveillance theory",
   IEEE Trans. Military Electronics 8(2) (1964) 125–139.
.. [2] A. Wald, "Sequential tests of statistical hypotheses", Ann. Math. Statist.
   16(2) (1945) 117–186.
.. [3] S. Blackman, R. Popoli, *Design and Analysis of Modern Tracking Systems*,
   Artech House, 1999, ch. 6 (track score, confirmation and deletion).
.. [4] T. E. Fortmann, Y. Bar-Shalom, M. Scheffe, "Sonar tracking of multiple targets
   using joint probabilistic data association", IEEE J. Oceanic Eng. 8(3) (1983) 173–184.
.. [5] H. A. P. Blom, Y. Bar-Shalom, "The interacting multiple model algorithm for systems
   with Markovian switching coefficients", IEEE Trans. Automatic Control 33(8) (1988)
   780–783.
"""

from __future__ import annotations

from ._imm import ImmEstimate, ImmMixing, imm_combine, imm_mixing, imm_predict, imm_update
from ._jpda import MAX_EVENTS, JpdaProbabilities, jpda_probabilities
from ._kalman import KalmanEstimate, KalmanUpdate, kalman_predict, kalman_update
from ._score import SprtThresholds, m_of_n, score_increments, sprt_thresholds

__all__ = [
    "MAX_EVENTS",
    "ImmEstimate",
    "ImmMixing",
    "JpdaProbabilities",
    "KalmanEstimate",
    "KalmanUpdate",
    "SprtThresholds",
    "imm_combine",
    "imm_mixing",
    "imm_predict",
    "imm_update",
    "jpda_probabilities",
    "kalman_predict",
    "kalman_update",
    "m_of_n",
    "score_increments",
    "sprt_thresholds",
]
