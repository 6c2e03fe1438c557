r"""The linear-Gaussian approximation of the outcome probabilities."""

from __future__ import annotations

import numpy as np

from .. import conversion, gating
from ..engine.geometry import (
    Geometry,
    as_geometry,
    as_polar_sigmas,
)
from ..engine.validation import (
    as_choice,
    as_float,
    as_positive,
    as_probability,
)
from ._scenario import _METHODS, PAPER
from ._statistic import pair_statistic


# --------------------------------------------------------------------------- approximation
def false_pair_noncentrality(geometry: Geometry, *, sigma_r=PAPER["sigma_r"],
                             sigma_beta=PAPER["sigma_beta"], bias_method: str | None = None):
    r"""Noncentrality :math:`\lambda_{ij}` of :math:`\kappa` for every pair, linear-Gaussian model.

    Parameters
    ----------
    geometry : Geometry
    sigma_r, sigma_beta : float, optional
        Measurement errors (km, rad).
    bias_method : str, optional
        Include the mean error of this conversion method
        (:func:`radarfusion_ref.conversion.conversion_bias`) in the mean
        difference; by default the conversion is taken as unbiased.

    Returns
    -------
    numpy.ndarray, shape (n, n)
        :math:`\lambda_{ij} = \mu_{ij}^T (\Sigma_{1i} + \Sigma_{2j})^{-1} \mu_{ij}` with
        :math:`\mu_{ij} = E[\hat x_{1i} - \hat x_{2j}]` and the
        linearized covariances (2a–c) evaluated at the true coordinates. The
        diagonal is 0 without `bias_method`.

    Raises
    ------
    ValueError
        For bad sigmas or an unknown method.

    Notes
    -----
    If :math:`\hat x_{1i} - \hat x_{2j} \sim \mathcal N(\mu, S_{ij})` then
    :math:`\kappa \sim \chi'^2(2, \lambda)`. The model ignores that the
    covariances used in :math:`\kappa` are evaluated at the *measured* coordinates.

    Examples
    --------
    >>> from radarfusion_ref.separated import paper_geometry
    >>> lam = false_pair_noncentrality(paper_geometry(0.0, -5.0))
    >>> lam.shape, float(lam[0, 0])
    ((2, 2), 0.0)
    """
    geo = as_geometry(geometry)
    sr, sb = as_polar_sigmas(sigma_r, sigma_beta, geo)
    (r1, b1), (r2, b2) = geo.polar1, geo.polar2
    mean1 = geo.targets.copy()
    mean2 = geo.targets.copy()
    if bias_method is not None:
        bm = as_choice(bias_method, "bias_method", _METHODS)
        mean1 = mean1 + conversion.conversion_bias(r1, b1, sb, method=bm)
        mean2 = mean2 + conversion.conversion_bias(r2, b2, sb, method=bm)
    c1 = conversion.polar_to_cartesian(r1, b1, sr, sb, method="linearized").cov
    c2 = conversion.polar_to_cartesian(r2, b2, sr, sb, method="linearized").cov
    return pair_statistic(mean1, c1, mean2, c2)


def approximate_outcomes(noncentrality, p_false_reject=PAPER["p_false_reject"]):
    r"""Per-report outcome probabilities for two targets, treating the two pairs as independent.

    Parameters
    ----------
    noncentrality : array_like, shape (..., 2, 2)
        :math:`\lambda_{ij}` from :func:`false_pair_noncentrality` (the
        diagonal is the true pairs').
    p_false_reject : float, optional
        :math:`P_{\text{lo}}`.

    Returns
    -------
    numpy.ndarray, shape (..., 2, 3)
        For each target (row): (correct, wrong, no decision).

    Raises
    ------
    ValueError
        If `noncentrality` is not a stack of 2x2 arrays of finite entries >= 0,
        or `p_false_reject` is not one probability in (0, 1).

    Notes
    -----
    With :math:`a_i = P\{\kappa_{ii} < \gamma\}` and :math:`b_i = P\{\kappa_{ij} < \gamma\}`
    (noncentral :math:`\chi^2(2)` CDFs, :func:`radarfusion_ref.gating.p_false_accept`),

    .. math::

        P_{\text{correct}} = a_i(1 - b_i), \quad P_{\text{wrong}} = (1 - a_i) b_i,
        \quad P_{\text{none}} = a_i b_i + (1 - a_i)(1 - b_i).

    The two pairs share radar 1's report, so they are not exactly
    independent; the Monte Carlo of :func:`association_experiment` has no
    such approximation.

    Examples
    --------
    >>> approximate_outcomes(np.array([[0.0, 30.0], [30.0, 0.0]]))[0].round(3)
    array([0.985, 0.   , 0.015])
    """
    lam = as_positive(noncentrality, "noncentrality", strict=False)
    if lam.ndim < 2 or lam.shape[-2:] != (2, 2):
        raise ValueError(f"`noncentrality` must have shape (..., 2, 2); received {lam.shape}")
    p_lo = as_float(as_probability(p_false_reject, "p_false_reject"), "p_false_reject")
    p = np.asarray(gating.p_false_accept(lam, 2, p_lo), dtype=float)
    a = np.diagonal(p, axis1=-2, axis2=-1)
    b = p[..., [0, 1], [1, 0]]
    return np.stack([a * (1 - b), (1 - a) * b, a * b + (1 - a) * (1 - b)], axis=-1)
