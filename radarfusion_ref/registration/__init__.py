r"""Registration: systematic range and azimuth biases of radars, and their estimation.

Each radar :math:`i` at a known site :math:`s_i` measures the range and azimuth
of an object at :math:`x` with a **range offset** :math:`\Delta r_i`, a **range
scale** error :math:`g_i` and an **azimuth offset**
:math:`\Delta\beta_i` added to the random errors of the conversion chapter:

.. math::

    \hat r_i = (1 + g_i)\, r_i + \Delta r_i + v_i, \qquad
    \hat\beta_i = \beta_i + \Delta\beta_i + w_i,

with :math:`r_i = \lVert x - s_i\rVert`, :math:`\beta_i` the azimuth of
:math:`x - s_i` (radians, counter-clockwise from the x axis, as in
:mod:`radarfusion_ref.conversion`), :math:`v_i \sim \mathcal N(0, \sigma_{r,i}^2)`
and :math:`w_i \sim \mathcal N(0, \sigma_{\beta,i}^2)`. The bias vector of
radar :math:`i` is :math:`b_i = (\Delta r_i, g_i, \Delta\beta_i)`;
arrays of biases have a last axis of length 3 in that order
(:data:`BIAS_NAMES`). Polar reports are arrays whose last axis holds
:math:`(\hat r, \hat\beta)`.

Contents:

* the model: :func:`apply_biases`, :func:`remove_biases`, :func:`true_polar`,
  :func:`draw_biased_reports`, :func:`to_cartesian`, :func:`bias_displacement`;
* its effect on association: :func:`noncentrality` (the proximity measure of a
  *true* pair becomes :math:`\chi'^2_2(\lambda)`) and :func:`cost_matrix`;
* estimation from associated reports: :func:`bias_information` (Fisher
  information of the biases with the object positions as nuisance
  parameters), :func:`observability` (its rank and unobservable combinations),
  :func:`estimate_biases` (maximum likelihood by Gauss–Newton);
* joint registration and association: :func:`register_and_associate`.

.. rubric:: References

.. [1] Y. Zhou, H. Leung, P. C. Yip, "An exact maximum likelihood registration
   algorithm for data fusion", IEEE Trans. Signal Processing 45(6) (1997)
   1560–1573.
.. [2] N. N. Okello, B. Ristic, "Maximum likelihood registration for
   multiple dissimilar sensors", IEEE Trans. AES 39(3) (2003) 1074–1083.
.. [3] Y. Bar-Shalom, X. R. Li, T. Kirubarajan, *Estimation with Applications
   to Tracking and Navigation*, Wiley 2001, sections 2.7 (Fisher information,
   CRLB) and 3.4 (nonlinear least squares, Gauss–Newton).
.. [4] B. Triggs, P. McLauchlan, R. Hartley, A. Fitzgibbon, "Bundle
   adjustment — a modern synthesis", LNCS 1883 (2000) — the elimination of
   the per-object parameters (Schur complement) used here.
"""

from ._estimation import (
    BiasEstimate,
    Observability,
    bias_information,
    estimate_biases,
    observability,
    reduced_information,
)
from ._joint import (
    AccuracyComparison,
    BiasedScene,
    Registration,
    RegistrationError,
    RegistrationStep,
    association_accuracy,
    register_and_associate,
    simulate_scene,
)
from ._model import (
    BIAS_NAMES,
    MAX_ELEMENTS,
    MAX_RADARS,
    RANK_TOL,
    apply_biases,
    bias_displacement,
    cost_matrix,
    draw_biased_reports,
    noncentrality,
    remove_biases,
    to_cartesian,
    true_polar,
)

__all__ = [
    "BIAS_NAMES",
    "MAX_ELEMENTS",
    "MAX_RADARS",
    "RANK_TOL",
    "AccuracyComparison",
    "BiasEstimate",
    "BiasedScene",
    "Observability",
    "Registration",
    "RegistrationError",
    "RegistrationStep",
    "apply_biases",
    "association_accuracy",
    "bias_displacement",
    "bias_information",
    "cost_matrix",
    "draw_biased_reports",
    "estimate_biases",
    "noncentrality",
    "observability",
    "reduced_information",
    "register_and_associate",
    "remove_biases",
    "simulate_scene",
    "to_cartesian",
    "true_polar",
]
