r"""Track-to-track fusion: the cross-covariance of two tracks and three fusion rules.

Two radars track one object with Kalman filters. Each track carries a state
estimate :math:`\hat{\mathbf x}_i` (position and velocity) and a covariance
:math:`P_i`. Both filters follow the same object, whose motion is driven by
one process noise :math:`\mathbf w`; the two track errors therefore share it and
are **correlated**, with cross-covariance :math:`P_{12} = E[\mathbf e_1\mathbf e_2^\mathsf T]`
even though the radars' measurement errors are independent.

.. rubric:: Functions

* :func:`cross_covariance` — the recursion of :math:`P_1, P_2, P_{12}` of two Kalman
  filters of one object, or its steady state;
* :func:`constant_velocity` — the constant-velocity motion model :math:`(F, Q)`;
* :func:`naive_fusion` — fusion that ignores :math:`P_{12}` (the ML fusion of
  independent reports, :func:`radarfusion_ref.fusion.fuse_gaussian`);
* :func:`bar_shalom_campo` — the best linear fusion with a known :math:`P_{12}`;
* :func:`blue_fusion` — the best linear unbiased fusion of n correlated tracks from
  their joint covariance (Bar-Shalom–Campo for two);
* :func:`covariance_intersection` — fusion that is consistent for *every*
  :math:`P_{12}`, with the weight :math:`\omega` minimising the determinant or the trace;
* :func:`track_statistic` — the track-to-track association statistic
  :math:`\kappa = \Delta^\mathsf T(P_1 + P_2 - P_{12} - P_{21})^{-1}\Delta`;
* :func:`simulate_tracks` — Monte-Carlo runs of the two filters on one simulated object.

A track is predicted to a later instant (time alignment) by the engine's
:func:`radarfusion_ref.engine.tracker.kalman_predict`, the one home of the
constant-velocity prediction.

Notation (the book's): :math:`F` the transition matrix, :math:`Q` the process-noise
covariance, :math:`H_i` radar *i*'s measurement matrix, :math:`\Sigma_i` its
measurement error covariance (argument ``R1``/``R2``), :math:`K_i` the Kalman gain,
:math:`P_{21} = P_{12}^\mathsf T`, :math:`\tilde{\mathbf x}`, :math:`\tilde P` a fused track.

.. rubric:: References

.. [1] Y. Bar-Shalom, "On the track-to-track correlation problem", IEEE Trans.
   Automatic Control 26(2) (1981) 571–572 (the cross-covariance recursion).
.. [2] Y. Bar-Shalom, L. Campo, "The effect of the common process noise on the
   two-sensor fused-track covariance", IEEE Trans. AES 22(6) (1986) 803–805.
.. [3] S. J. Julier, J. K. Uhlmann, "A non-divergent estimation algorithm in the
   presence of unknown correlations", Proc. American Control Conference (1997)
   2369–2373 (covariance intersection).
.. [4] Y. Bar-Shalom, X.-R. Li, T. Kirubarajan, *Estimation with Applications to
   Tracking and Navigation*, Wiley, 2001, sec. 6.3.2 (the constant-velocity model),
   6.5 (α–β filter) and 11.2.3 (track-to-track association).
.. [5] P. R. Kalata, "The tracking index: a generalized parameter for α–β and
   α–β–γ target trackers", IEEE Trans. AES 20(2) (1984) 174–182.
"""

from __future__ import annotations

from ._common import (
    CRITERIA,
    MAX_DIM,
    CovarianceIntersection,
    MotionModel,
    TrackCovariances,
    TrackEstimate,
    TrackRuns,
)
from ._motion import (
    constant_velocity,
    cross_covariance,
    simulate_tracks,
)
from ._rules import (
    bar_shalom_campo,
    blue_fusion,
    ci_weight,
    covariance_intersection,
    naive_fusion,
    track_statistic,
)

__all__ = [
    "CRITERIA",
    "MAX_DIM",
    "CovarianceIntersection",
    "MotionModel",
    "TrackCovariances",
    "TrackEstimate",
    "TrackRuns",
    "bar_shalom_campo",
    "blue_fusion",
    "constant_velocity",
    "ci_weight",
    "covariance_intersection",
    "cross_covariance",
    "naive_fusion",
    "simulate_tracks",
    "track_statistic",
]
