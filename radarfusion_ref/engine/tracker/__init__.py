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

The kernels under these doors (:func:`cv_matrices`, :func:`predict_kernel`,
:func:`update_kernel`, :func:`check_prediction`, :func:`increments_kernel`,
:func:`window_kernel`, :func:`event_bound`, :func:`exact_kernel`, :func:`kbest_kernel`,
:func:`combine_kernel`, :func:`imm_predict_kernel`, :func:`imm_update_kernel`) are public
for the chapter modules' trackers, which validate a whole scenario once at their own door
and then run these per scan; each says "trusted input" in its summary: it does not
validate its arguments.

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

from ._imm import (
    ImmEstimate,
    ImmMixing,
    combine_kernel,
    imm_combine,
    imm_mixing,
    imm_predict,
    imm_predict_kernel,
    imm_update,
    imm_update_kernel,
)
from ._jpda import (
    MAX_EVENTS,
    JpdaProbabilities,
    event_bound,
    exact_kernel,
    jpda_probabilities,
    kbest_kernel,
)
from ._kalman import (
    KalmanEstimate,
    KalmanUpdate,
    check_prediction,
    cv_matrices,
    kalman_predict,
    kalman_update,
    predict_kernel,
    update_kernel,
)
from ._score import (
    SprtThresholds,
    increments_kernel,
    m_of_n,
    score_increments,
    sprt_thresholds,
    window_kernel,
)

__all__ = [
    "MAX_EVENTS",
    "ImmEstimate",
    "ImmMixing",
    "JpdaProbabilities",
    "KalmanEstimate",
    "KalmanUpdate",
    "SprtThresholds",
    "check_prediction",
    "combine_kernel",
    "cv_matrices",
    "event_bound",
    "exact_kernel",
    "imm_combine",
    "imm_mixing",
    "imm_predict",
    "imm_predict_kernel",
    "imm_update",
    "imm_update_kernel",
    "increments_kernel",
    "jpda_probabilities",
    "kalman_predict",
    "kalman_update",
    "kbest_kernel",
    "m_of_n",
    "predict_kernel",
    "score_increments",
    "sprt_thresholds",
    "update_kernel",
    "window_kernel",
]
