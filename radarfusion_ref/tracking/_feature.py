r"""The reports' scalar feature in the tracker: its likelihood ratio and its estimate per track.

A radar may report a feature with each plot (the capstone's radars: a speed feature in
knots). A track carries an estimate :math:`\hat f` of its target's feature with variance
:math:`P_f`, a random walk of intensity :math:`q_f` between reports. A report :math:`j`
with feature :math:`f_j` (variance :math:`\sigma_j^2`) adds to the pair's score increment
the log-likelihood ratio of its feature,

.. math::

   \ln\frac{\mathcal N(f_j;\ \hat f,\ P_f + \sigma_j^2)}{\lambda_f},

with :math:`\lambda_f` the density of a false report's feature. A tentative track's
first report starts the estimate (:math:`\hat f = f_j`, :math:`P_f = \sigma_j^2`), and a
report taken updates it as a scalar Kalman filter; JPDA keeps the moments of the mixture
over the track's events, as for the state.
"""

from __future__ import annotations

import math

import numpy as np

from ..engine.validation import as_float_array, as_positive

_LN_2PI = math.log(2.0 * math.pi)


def features_iv(feature, feature_var, n):
    """`feature` and `feature_var` (both None, or both finite of shape (n,), the
    variances > 0), as float arrays or (None, None)."""
    if feature is None and feature_var is None:
        return None, None
    if feature is None or feature_var is None:
        missing = "feature" if feature is None else "feature_var"
        raise ValueError(f"`feature` and `feature_var` go together; received `{missing}` "
                         f"None and the other given")
    f = as_float_array(feature, "feature", ndim_min=1)
    v = as_float_array(feature_var, "feature_var", ndim_min=1)
    for name, a in (("feature", f), ("feature_var", v)):
        if a.shape != (n,):
            raise ValueError(f"`{name}` must have shape ({n},), one entry per report; "
                             f"received shape {a.shape}")
    return f, as_positive(v, "feature_var")


def increments(est, var, f, fv, density):
    r"""Feature terms of the gated pairs' increments:
    :math:`\ln\mathcal N(f; \hat f, P_f + \sigma^2) - \ln\lambda_f` (arrays per pair)."""
    s = var + fv
    return -0.5 * ((f - est) ** 2 / s + np.log(s) + _LN_2PI) - math.log(density)


def update(est, var, f, fv):
    """Scalar Kalman update of each track's feature with its report: (estimate, variance)."""
    k = var / (var + fv)
    return est + k * (f - est), (1.0 - k) * var
