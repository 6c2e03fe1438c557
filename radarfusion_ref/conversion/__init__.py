r"""Polar-to-Cartesian conversion of radar reports, with and without bias correction.

A radar measures range :math:`\hat r = r + \tilde r` and azimuth
:math:`\hat\beta = \beta + \tilde\beta`, with independent Gaussian errors
:math:`\tilde r \sim \mathcal N(0, \sigma_r^2)`,
:math:`\tilde\beta \sim \mathcal N(0, \sigma_\beta^2)`. Every method here
returns a Cartesian position :math:`(\hat x, \hat y)` and a 2×2 covariance.

**Azimuth convention** (the paper's: Prosov, description of the simulated
example, "the azimuth is counted from the X axis counter-clockwise"): :math:`\beta` is in **radians**,
measured **counter-clockwise from the x axis**, so

.. math::

    \hat x = \hat r\cos\hat\beta, \qquad \hat y = \hat r\sin\hat\beta
    \qquad \text{(Prosov, eq. 1)}.

This is *not* the navigation convention (clockwise from north, :math:`x = r\sin\beta`).
To use navigation azimuths :math:`\alpha`, pass ``beta = np.pi / 2 - alpha``.

Methods (``method=``):

``"linearized"``
    eq. (1) with the Jacobian covariance (2a–c) evaluated at the measurement.
``"additive"``
    Lerro & Bar-Shalom's debiased conversion: subtract the bias averaged over
    the truth given the measurement; covariance (4a–c), which is their
    "average true covariance" conditioned on the *measured* values.
``"multiplicative"``
    Mo, Song et al.'s unbiased conversion :math:`e^{\sigma_\beta^2/2}\hat r(\cos\hat\beta,
    \sin\hat\beta)`, exactly unbiased given the truth; covariance = mean squared
    error given the measurement (flat prior on the truth).
``"first_order"``
    the paper's eq. (3) with the sign of the correction derived here,
    :math:`\hat r(1 + \sigma_\beta^2/2)(\cos\hat\beta, \sin\hat\beta)`, paired (as in the
    paper) with covariance (4a–c).
``"first_order_printed"``
    eq. (3) **as printed**, :math:`\hat r(1 - \sigma_\beta^2/2)(\ldots)`, with (4a–c);
    kept only to reproduce the paper — the printed sign doubles the bias
    instead of removing it (see the book's erratum).
``"measurement_conditioned"``
    Duan, Han & Li's modified unbiased conversion: the mean of the truth GIVEN the
    measurement, :math:`e^{-\sigma_\beta^2/2}\hat r(\cos\hat\beta, \sin\hat\beta)`,
    with the covariance of the truth given the measurement (flat prior). It is the
    conditional mean, so its covariance is exact given the measurement; given the
    truth it is biased by :math:`(e^{-\sigma_\beta^2} - 1)\,r u(\beta)`.
``"decorrelated"``
    Bordonaro, Willett & Bar-Shalom's decorrelated unbiased conversion: the
    multiplicative position, with the covariance given the truth averaged over a
    PRIOR position (a track's prediction, ``prior_xy``/``prior_cov``) instead of over
    the measurement, so that the covariance is independent of the measurement's error.

The paper's and the classic methods are :data:`METHODS`; :data:`ALL_METHODS` adds the
two above. The 3-D conversion of (range, azimuth, elevation) is
:func:`spherical_to_cartesian`, with the methods :data:`METHODS_3D`; elevation
:math:`\varepsilon` is measured up from the x–y plane, so
:math:`(x, y, z) = r(\cos\varepsilon\cos\beta, \cos\varepsilon\sin\beta, \sin\varepsilon)`.

Every covariance here has the form :math:`aI + bM(\beta)` with
:math:`M(\beta) = \begin{pmatrix}\cos 2\beta & \sin 2\beta\\ \sin 2\beta & -\cos 2\beta\end{pmatrix}`:
its eigenvectors point along range (variance :math:`a + b`) and across range
(variance :math:`a - b`).

.. rubric:: References

.. [1] A. V. Prosov, "Analysis of the effect of linearization errors of radar
   measurements on the reliability of associating data from spatially
   separated radars", eqs. (1)–(4).
.. [2] D. Lerro, Y. Bar-Shalom, "Tracking with debiased consistent converted
   measurements versus EKF", IEEE Trans. AES 29(3) (1993) 1015–1022.
.. [3] L. Mo, X. Song, Y. Zhou, Z. K. Sun, Y. Bar-Shalom, "Unbiased converted
   measurements for tracking", IEEE Trans. AES 34(3) (1998) 1023–1027.
.. [4] Z. Duan, C. Han, X. R. Li, "Comments on 'Unbiased converted measurements for
   tracking'", IEEE Trans. AES 40(4) (2004) 1374–1377.
.. [5] S. V. Bordonaro, P. Willett, Y. Bar-Shalom, "Decorrelated unbiased converted
   measurement Kalman filter", IEEE Trans. AES 50(2) (2014) 1431–1444.
.. [7] P. Suchomski, "Explicit expressions for debiased statistics of 3D converted
   measurements", IEEE Trans. AES 35(1) (1999) 368–370.
.. [6] X. R. Li, Z. Zhao, "Measuring estimator's credibility: noncredibility index",
   Proc. 9th Int. Conf. Information Fusion (2006).

.. rubric:: Where things are

* 2-D conversion and its exact moments given the truth (:func:`polar_to_cartesian`, built
  from :func:`conversion_gain` and :func:`principal_variances`; :func:`conversion_moments`,
  :func:`conversion_bias`, :func:`nonlinearity_index`);
* consistency — noisy measurements (:func:`draw_polar`, trial axis first), NEES
  (:func:`nees_per_trial`, :func:`nees_at_truth`; the summary over many errors is
  :func:`radarfusion_ref.engine.metrics.nees`) and the Monte Carlo of every method
  (:func:`conversion_monte_carlo`);
* 3-D (:func:`spherical_to_cartesian`, :func:`spherical_moments`, :func:`draw_spherical`,
  :func:`spherical_monte_carlo`).

The limit :data:`~radarfusion_ref.engine.geometry.SIGMA_BETA_MAX` on an angle's standard
deviation is the engine's, checked there for every function that takes one; import it from
:mod:`radarfusion_ref.engine.geometry` (it is not one of this chapter's names).
"""

from ._consistency import (
    ConversionTrials,
    conversion_monte_carlo,
    draw_polar,
    nees_at_truth,
    nees_per_trial,
)
from ._planar import (
    ALL_METHODS,
    LERRO_THRESHOLD,
    MAX_BATCH,
    METHODS,
    METHODS_3D,
    MIN_RANGE_OVER_SIGMA,
    ConversionMoments,
    ConvertedMeasurement,
    conversion_bias,
    conversion_gain,
    conversion_moments,
    decorrelated_variances,
    nonlinearity_index,
    polar_to_cartesian,
    principal_variances,
)
from ._spherical import (
    ConvertedMeasurement3D,
    draw_spherical,
    spherical_covariance,
    spherical_moments,
    spherical_monte_carlo,
    spherical_to_cartesian,
)

__all__ = [
    "ALL_METHODS",
    "LERRO_THRESHOLD",
    "MAX_BATCH",
    "METHODS",
    "METHODS_3D",
    "MIN_RANGE_OVER_SIGMA",
    "ConversionMoments",
    "ConversionTrials",
    "ConvertedMeasurement",
    "ConvertedMeasurement3D",
    "conversion_bias",
    "conversion_gain",
    "conversion_moments",
    "conversion_monte_carlo",
    "decorrelated_variances",
    "draw_polar",
    "draw_spherical",
    "nees_at_truth",
    "nees_per_trial",
    "nonlinearity_index",
    "polar_to_cartesian",
    "principal_variances",
    "spherical_covariance",
    "spherical_moments",
    "spherical_monte_carlo",
    "spherical_to_cartesian",
]
