"""Features: the combined coordinate + feature proximity, the type agreement and the
association costs of a typed scene."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import logsumexp

from ..engine.scenes import (
    FEATURE_MODELS,
    TypedScene,
    as_type_model,
)
from ..engine.validation import (
    as_choice,
    as_float_array,
    as_positive,
    broadcast,
    unwrap,
)
from ..proximity import proximity_gaussian
from ._common import (
    _check_memory,
    _log_normal,
    _log_posterior,
    _log_var_sum,
    _quadratic,
)
from ._recognition import (
    _fuse_two,
)


# ----------------------------------------------------------------------------- proximity
@dataclass(frozen=True)
class CombinedProximity:
    r"""The combined coordinate + feature proximity measure of report pairs.

    Attributes
    ----------
    total : numpy.ndarray
        :math:`\kappa = \kappa^x + \kappa^\Pi`.
    coordinate : numpy.ndarray
        :math:`\kappa^x = (\hat{\mathbf x}_1-\hat{\mathbf x}_2)^\top (\Sigma_1+\Sigma_2)^{-1}
        (\hat{\mathbf x}_1-\hat{\mathbf x}_2)`.
    feature : numpy.ndarray
        :math:`\kappa^\Pi`, the feature term (see :func:`combined_proximity`).
    dof : int or None
        Degrees of freedom of the :math:`\chi^2` law of `total` under a true
        hypothesis: ``d + 1`` for the profile measure of model 1, ``d`` for the
        profile measure of model 2 (whose feature term is zero); ``None`` for
        the marginal measures, which are log-likelihood ratios, not
        :math:`\chi^2`.
    model : str
        ``"shared"`` or ``"spread"``.
    kind : str
        ``"profile"`` or ``"marginal"``.
    """

    total: np.ndarray
    coordinate: np.ndarray
    feature: np.ndarray
    dof: int | None
    model: str
    kind: str


def type_agreement(feature1, feature_var1, feature2, feature_var2, type_means, type_vars,
                   priors=None):
    r"""Type agreement of two feature reports under model 2: :math:`-2 \ln \sum_k P(T_k \mid \hat\Pi_1) P(T_k \mid \hat\Pi_2) / p_k`.

    Minus twice the log-likelihood ratio of "one object" against "two
    objects" when each radar measures its own draw of the object's feature
    (model 2), the feature values integrated out under the type description:

    .. math::

        \kappa^{\Pi}_{(2)} = -2 \ln \frac{\sum_k p_k\, g_{1k}(\hat\Pi_1)\, g_{2k}(\hat\Pi_2)}
        {\sum_k p_k\, g_{1k}(\hat\Pi_1)\ \sum_j p_j\, g_{2j}(\hat\Pi_2)}
        = -2 \ln \sum_k \frac{P(T_k \mid \hat\Pi_1)\, P(T_k \mid \hat\Pi_2)}{p_k},

    with :math:`g_{ik} = \mathcal N(\,\cdot\,; \Pi_k, \sigma_{\Pi k}^2 + \sigma_{\Pi i}^2)`
    (the second form by Bayes' rule on each report). Not :math:`\chi^2`; negative
    when the reports agree on a rare type.

    Parameters
    ----------
    feature1, feature2 : array_like
        The two radars' feature reports (broadcast together).
    feature_var1, feature_var2 : array_like
        Their error variances (> 0).
    type_means, type_vars, priors : array_like, shape (K,)
        The type description, as in :func:`type_posterior`.

    Returns
    -------
    float or numpy.ndarray

    Raises
    ------
    ValueError, TypeError
        For non-finite or non-numeric reports, non-positive variances, shapes
        that do not broadcast or an invalid type description.

    Examples
    --------
    >>> round(type_agreement(0.0, 0.01, 0.0, 0.01, [0.0, 5.0], [1.0, 1.0]), 4)   # both type 1
    -1.3863
    """
    f1, v1, f2, v2 = _feature_pair_iv(feature1, feature_var1, feature2, feature_var2)
    means, tvars, log_priors = as_type_model(type_means, type_vars, priors)
    _check_memory(f1.shape, means.size, "type agreement")
    log_p1 = _log_posterior([f1], means,
                            [_log_var_sum(tvars, v1[..., None])], log_priors)
    log_p2 = _log_posterior([f2], means,
                            [_log_var_sum(tvars, v2[..., None])], log_priors)
    # a type of prior 0 contributes nothing
    with np.errstate(invalid="ignore"):
        terms = np.where(np.isneginf(log_priors), -np.inf,
                         log_p1 + log_p2 - log_priors)
    # -2 ln sum_k P1_k P2_k / p_k
    return unwrap(-2.0 * logsumexp(terms, axis=-1))


def _feature_pair_iv(feature1, feature_var1, feature2, feature_var2):
    """Two feature reports and their variances (> 0), broadcast together."""
    f1 = as_float_array(feature1, "feature1")
    f2 = as_float_array(feature2, "feature2")
    v1 = as_positive(feature_var1, "feature_var1")
    v2 = as_positive(feature_var2, "feature_var2")
    f1, f2, v1, v2 = broadcast(feature1=f1, feature2=f2, feature_var1=v1, feature_var2=v2)
    return f1, v1, f2, v2


def _marginal_feature_term(f1, v1, f2, v2, means, tvars, log_priors):
    """-2 ln LR("one object" vs "two objects") of two feature reports under model 1."""
    lv1, lv2 = _log_var_sum(tvars, v1[..., None]), _log_var_sum(tvars, v2[..., None])
    # N(Π̂1 - Π̂2; 0, v1 + v2) sum_k p_k N(Π̃; Π_k, σ_Πk² + ṽ) over the two marginals
    fused, fused_var = _fuse_two(f1, v1, f2, v2)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        apart = (logsumexp(_log_normal(f1[..., None], means, np.exp(lv1)) + log_priors, -1)
                 + logsumexp(_log_normal(f2[..., None], means, np.exp(lv2)) + log_priors, -1))
        same = (_log_normal(f1 - f2, 0.0, v1 + v2)
                + logsumexp(_log_normal(fused[..., None], means,
                                        tvars + fused_var[..., None]) + log_priors, -1))
        out = -2.0 * (same - apart)
    if not np.all(np.isfinite(out)):
        raise ValueError("the marginal feature term is beyond the floating-point range for "
                         "some `feature1`, `feature2` (reports too far from every type "
                         "relative to its spread); use kind='profile' or rescale the feature")
    return out


def combined_proximity(x1, x2, cov1, cov2, feature1, feature2, feature_var1, feature_var2, *,
                       model: str = "shared", kind: str = "profile", type_means=None,
                       type_vars=None, priors=None) -> CombinedProximity:
    r"""Combined coordinate + feature proximity measure of report pairs, eq. (12) corrected.

    Parameters
    ----------
    x1, x2 : array_like, shape (..., d)
        Coordinate reports of radar 1 and radar 2 (batch axes broadcast).
    cov1, cov2 : array_like, shape (..., d, d)
        Their error covariances (symmetric positive definite).
    feature1, feature2 : array_like, shape (...)
        Feature reports.
    feature_var1, feature_var2 : array_like
        Feature error variances (> 0).
    model : {"shared", "spread"}, optional
        Feature observation model: ``"shared"`` (the paper's model 1, used for
        (9)–(12)) or ``"spread"`` (model 2).
    kind : {"profile", "marginal"}, optional
        ``"profile"`` (default): the unknown feature value(s) replaced by their
        ML estimates, as the paper does — for model 1 the corrected (12).
        ``"marginal"``: the feature value integrated out under the type
        description, giving minus twice a log-likelihood ratio.
    type_means, type_vars, priors : array_like, shape (K,), optional
        Type description, required for ``kind="marginal"``.

    Returns
    -------
    CombinedProximity

    Raises
    ------
    ValueError
        Mismatched coordinate dimensions, shapes that do not broadcast,
        covariances that are not positive definite, non-positive feature
        variances, an unknown `model` or `kind`, a missing or invalid type
        description for ``kind="marginal"``.

    Notes
    -----
    The coordinate part is :func:`radarfusion_ref.proximity.proximity_gaussian`.

    *Profile, model 1* — minus twice the log of the profile likelihood (11)
    is, up to a constant,

    .. math::

        \kappa = (\hat{\mathbf x}_1-\hat{\mathbf x}_2)^\top (\Sigma_1+\Sigma_2)^{-1}
                  (\hat{\mathbf x}_1-\hat{\mathbf x}_2)
                + \frac{(\hat\Pi_1-\hat\Pi_2)^2}{\sigma_{\Pi1}^2+\sigma_{\Pi2}^2},

    :math:`\chi^2(d+1)` under a true hypothesis and noncentral
    :math:`\chi'^2(d+1, \lambda_x + \lambda_\Pi)` under a false one (given the two objects'
    positions and feature values). The paper prints (12) without the squares.

    *Profile, model 2* — each radar's value is a separate unknown, fitted
    exactly by its own report: the feature term is zero (features say nothing
    about association — the paper's conclusion for model 2).

    *Marginal* — with :math:`g_{ik} = \mathcal N(\,\cdot\,; \Pi_k, \sigma_{\Pi k}^2 +
    \sigma_{\Pi i}^2)` and :math:`p(\hat\Pi_i) = \sum_k p_k g_{ik}(\hat\Pi_i)`,

    .. math::

        \kappa^\Pi = -2 \ln \frac{p(\hat\Pi_1, \hat\Pi_2 \mid \text{one object})}
                                 {p(\hat\Pi_1)\, p(\hat\Pi_2)},

    where the numerator is :math:`\sum_k p_k\, g_{1k}(\hat\Pi_1)\, g_{2k}(\hat\Pi_2)`
    under model 2 (the reports share only the type) and
    :math:`\mathcal N(\hat\Pi_1-\hat\Pi_2; 0, \sigma_{\Pi1}^2+\sigma_{\Pi2}^2)
    \sum_k p_k\, \mathcal N(\tilde\Pi; \Pi_k, \sigma_{\Pi k}^2 + v)` under model 1.
    The model-1 marginal term is the profile term plus a correction that
    matters when the feature noise is not small against the type spread.

    References
    ----------
    Grachov & Korneev (2010), eqs. (9)–(12) and the two observation models.

    Examples
    --------
    >>> k = combined_proximity([0.0], [1.0], [[0.5]], [[0.5]], 0.0, 2.0, 1.0, 1.0)
    >>> float(k.total), float(k.coordinate), float(k.feature), k.dof
    (3.0, 1.0, 2.0, 2)
    >>> k = combined_proximity([0.0], [1.0], [[0.5]], [[0.5]], 0.0, 2.0, 1.0, 1.0,
    ...                        model="spread", kind="marginal", type_means=[0.0, 2.0],
    ...                        type_vars=[0.1, 0.1])
    >>> round(float(k.feature), 3), k.dof
    (1.465, None)
    """
    model = as_choice(model, "model", FEATURE_MODELS)
    kind = as_choice(kind, "kind", ("profile", "marginal"))
    kx = np.asarray(proximity_gaussian(x1, x2, cov1, cov2), dtype=float)
    d = np.shape(x1)[-1]

    f1, v1, f2, v2 = _feature_pair_iv(feature1, feature_var1, feature2, feature_var2)
    if kind == "profile":
        if model == "shared":
            # (Π̂1 - Π̂2)² / (σ_Π1² + σ_Π2²), formed in the log domain: no overflow of the
            # square or of the sum of variances when the quotient itself is representable
            with np.errstate(over="ignore"):
                kf = _quadratic(f1, f2, np.logaddexp(np.log(v1), np.log(v2)))
        else:
            kf = np.zeros(f1.shape)
        dof = d + 1 if model == "shared" else d
    else:
        if type_means is None or type_vars is None:
            raise ValueError("`type_means` and `type_vars` are required with kind='marginal'; "
                             f"received type_means={type_means!r}, type_vars={type_vars!r}")
        if model == "spread":
            kf = np.asarray(type_agreement(f1, v1, f2, v2, type_means, type_vars, priors))
        else:
            means, tvars, log_priors = as_type_model(type_means, type_vars, priors)
            _check_memory(f1.shape, means.size, "marginal feature term")
            kf = _marginal_feature_term(f1, v1, f2, v2, means, tvars, log_priors)
        dof = None
    try:
        kx, kf = np.broadcast_arrays(kx, kf)
    except ValueError:
        raise ValueError("the coordinate batch shape (of `x1`, `x2`) and the feature shape (of "
                         f"`feature1`, `feature2`) must broadcast; received {kx.shape} and "
                         f"{kf.shape}") from None
    with np.errstate(over="ignore"):
        total = kx + kf
    if not np.all(np.isfinite(total)):
        raise ValueError("the combined proximity exceeds the floating-point range (about "
                         "1.8e308) for some pair: the reports (`x1`, `x2`, `feature1`, "
                         "`feature2`) are too far apart for their variances; such a pair is "
                         "outside any gate, so drop it before computing the measure")
    return CombinedProximity(total, kx, kf, dof, model, kind)


def association_costs(scene: TypedScene, *, features: str = "shared",
                      kind: str = "profile") -> np.ndarray:
    r"""Cost matrices ``cost[t, i, j]`` of pairing radar-1 report i with radar-2 report j.

    Parameters
    ----------
    scene : TypedScene
    features : {"none", "shared", "spread"}, optional
        ``"none"``: coordinates only (:math:`\kappa^x`); otherwise coordinates
        plus the feature term of :func:`combined_proximity` for that model.
        The model need not match the scene's own — using ``"shared"`` on a
        ``"spread"`` scene is the mistake the chapter shows.
    kind : {"profile", "marginal"}, optional
        The feature term's kind (see :func:`combined_proximity`); the scene's
        type description is used for ``"marginal"``.

    Returns
    -------
    numpy.ndarray, shape (trials, n, n)

    Examples
    --------
    >>> from radarfusion_ref.engine.scenes import typed_scene
    >>> s = typed_scene(2, type_means=[0.0], type_vars=[1.0], spacing=1.0, sigma1=0.1,
    ...                 sigma2=0.1, feature_sigma1=0.1, feature_sigma2=0.1, rng=0)
    >>> association_costs(s, features="none").shape
    (1, 2, 2)
    """
    if not isinstance(scene, TypedScene):
        raise TypeError(f"`scene` must be a TypedScene; received {type(scene).__name__}")
    features = as_choice(features, "features", ("none", *FEATURE_MODELS))
    kind = as_choice(kind, "kind", ("profile", "marginal"))
    c = scene.coords
    d = c.reports1.shape[-1]
    cov1 = c.sigma1**2 * np.eye(d)
    cov2 = c.sigma2**2 * np.eye(d)
    k = combined_proximity(c.reports1[:, :, None, :], c.reports2[:, None, :, :], cov1, cov2,
                           scene.features1[:, :, None], scene.features2[:, None, :],
                           scene.feature_sigma1**2, scene.feature_sigma2**2,
                           model="shared" if features == "none" else features,
                           kind="profile" if features == "none" else kind,
                           type_means=scene.type_means, type_vars=scene.type_vars,
                           priors=scene.priors)
    return k.coordinate if features == "none" else k.total
