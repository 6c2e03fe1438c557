"""Features: the triune task outcome and the calibration of predicted probabilities."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..engine.montecarlo import MeanEstimate, Proportion, mean, proportion
from ..engine.scenes import (
    TypedScene,
)
from ..engine.validation import (
    as_choice,
    as_float_array,
    as_int,
    check_size,
    describe,
)
from ..fusion import fuse
from ._common import (
    MAX_BINS,
)
from ._recognition import (
    fused_feature,
    pair_type_posterior,
    type_posterior,
)


# ----------------------------------------------------------------------------- triune task
@dataclass(frozen=True)
class Confusion:
    """A type confusion matrix with Wilson intervals per entry.

    Attributes
    ----------
    counts : numpy.ndarray of int, shape (K, K)
        ``counts[k, l]``: objects of true type ``k`` recognised as type ``l``.
    rate : numpy.ndarray, shape (K, K)
        Row-normalised counts (``nan``-free: a type that never occurred has a
        zero row and is flagged in `support`).
    low, high : numpy.ndarray, shape (K, K)
        95 % Wilson limits of each rate (objects treated as independent).
    support : numpy.ndarray of int, shape (K,)
        Number of objects of each true type.
    """

    counts: np.ndarray
    rate: np.ndarray
    low: np.ndarray
    high: np.ndarray
    support: np.ndarray


@dataclass(frozen=True)
class TriuneResult:
    """Outcome of association – estimation – recognition on a batch of typed scenes.

    Attributes
    ----------
    match : numpy.ndarray of int, shape (trials, n)
        The association evaluated: radar-1 report ``j`` paired with radar-2
        report ``match[t, j]`` (``-1``: left unpaired).
    correct : numpy.ndarray of bool, shape (trials, n)
        Whether each radar-1 report got its true partner.
    fused : numpy.ndarray, shape (trials, n, d)
        Fused coordinates of each object (a lone radar-1 report if unpaired).
    sq_error : numpy.ndarray, shape (trials, n)
        Squared Euclidean error of `fused` against the truth.
    posterior : numpy.ndarray, shape (trials, n, K)
        Type posterior of each object.
    recognised : numpy.ndarray of int, shape (trials, n)
        The maximum-a-posteriori type.
    true_type : numpy.ndarray of int, shape (trials, n)
        The true type.
    """

    match: np.ndarray
    correct: np.ndarray
    fused: np.ndarray
    sq_error: np.ndarray
    posterior: np.ndarray
    recognised: np.ndarray
    true_type: np.ndarray

    def pair_accuracy(self) -> MeanEstimate:
        """Mean fraction of correctly associated reports per scene (t-interval over scenes)."""
        return mean(self.correct.mean(axis=-1))

    def all_correct(self) -> Proportion:
        """Probability that a scene is associated entirely correctly (Wilson interval)."""
        return proportion(np.all(self.correct, axis=-1), None)

    def mse(self) -> MeanEstimate:
        """Mean squared position error per object (t-interval over per-scene means)."""
        return mean(self.sq_error.mean(axis=-1))

    def rmse(self) -> tuple[float, float, float]:
        """RMSE with its 95 % interval: the square roots of :meth:`mse` and its limits."""
        m = self.mse()
        return (float(np.sqrt(m.estimate)), float(np.sqrt(max(m.low, 0.0))),
                float(np.sqrt(m.high)))

    def type_accuracy(self) -> Proportion:
        """Fraction of objects recognised correctly (Wilson; objects treated as independent)."""
        return proportion((self.recognised == self.true_type).ravel(), None)

    def confusion(self) -> Confusion:
        """The type confusion matrix with per-entry Wilson intervals."""
        n_types = self.posterior.shape[-1]
        counts = np.zeros((n_types, n_types), dtype=int)
        np.add.at(counts, (self.true_type.ravel(), self.recognised.ravel()), 1)
        support = counts.sum(axis=1)
        rate = np.zeros((n_types, n_types))
        low = np.zeros((n_types, n_types))
        high = np.ones((n_types, n_types))
        for k in np.flatnonzero(support):
            p = proportion(counts[k], int(support[k]))
            rate[k], low[k], high[k] = p.estimate, p.low, p.high
        return Confusion(counts, rate, low, high, support)


def triune(scene: TypedScene, match, *, rule: str = "exact") -> TriuneResult:
    """Estimate and recognise every object of `scene` under the association `match`.

    Parameters
    ----------
    scene : TypedScene
    match : array_like of int, shape (trials, n)
        Radar-2 partner of each radar-1 report (``-1``: unpaired), e.g. from
        an associator run on :func:`association_costs`.
    rule : {"exact", "plugin"}, optional
        Type posterior: the exact one for the scene's feature model
        (:func:`pair_type_posterior` with the scene's priors; a lone report's
        own posterior if unpaired) or the paper's plug-in (13) (the fused
        feature with variance 0 and uniform priors).

    Returns
    -------
    TriuneResult

    Raises
    ------
    ValueError
        If `match` has the wrong shape or out-of-range entries.

    Examples
    --------
    >>> from radarfusion_ref.engine.scenes import typed_scene
    >>> s = typed_scene(3, type_means=[0.0, 9.0], type_vars=[1.0, 1.0], spacing=5.0,
    ...                 sigma1=0.1, sigma2=0.1, feature_sigma1=0.1, feature_sigma2=0.1,
    ...                 trials=50, rng=2)
    >>> r = triune(s, s.true_match)
    >>> r.all_correct().estimate, r.type_accuracy().estimate > 0.95
    (1.0, True)
    """
    if not isinstance(scene, TypedScene):
        raise TypeError(f"`scene` must be a TypedScene; received {type(scene).__name__}")
    rule = as_choice(rule, "rule", ("exact", "plugin"))
    c = scene.coords
    trials, n = c.owner2.shape
    m = np.asarray(match)
    if m.shape != (trials, n) or not np.issubdtype(m.dtype, np.integer):
        raise ValueError(f"`match` must be an integer array of shape {(trials, n)}; "
                         f"received dtype {m.dtype} with shape {m.shape}")
    if np.any((m < -1) | (m >= n)):
        raise ValueError(f"`match` entries must lie in [-1, {n - 1}]; received min {m.min()}, "
                         f"max {m.max()}")
    paired = m >= 0
    idx = np.where(paired, m, 0)
    x2 = np.take_along_axis(c.reports2, idx[..., None], axis=1)
    f2 = np.take_along_axis(scene.features2, idx, axis=1)
    s1, s2 = c.sigma1**2, c.sigma2**2
    pair_fused = fuse(np.stack([c.reports1, x2], axis=-1), np.array([s1, s2])).estimate
    fused = np.where(paired[..., None], pair_fused, c.reports1)
    v1, v2 = scene.feature_sigma1**2, scene.feature_sigma2**2
    types = (scene.type_means, scene.type_vars)
    if rule == "exact":
        post = np.where(paired[..., None],
                        pair_type_posterior(scene.features1, v1, f2, v2, *types, scene.priors,
                                            model=scene.model),
                        type_posterior(scene.features1, v1, *types, scene.priors))
    else:
        ff = fused_feature(scene.features1, v1, f2, v2)
        post = type_posterior(np.where(paired, ff.value, scene.features1), 0.0, *types)
    sq = np.sum((fused - c.truth) ** 2, axis=-1)
    return TriuneResult(m, m == scene.true_match, fused, sq, post, np.argmax(post, axis=-1),
                        scene.types)


# ----------------------------------------------------------------------------- calibration
@dataclass(frozen=True)
class ReliabilityCurve:
    """Binned calibration of predicted probabilities (a reliability diagram).

    Attributes
    ----------
    predicted : numpy.ndarray, shape (B,)
        Mean predicted probability in each non-empty bin.
    observed : numpy.ndarray, shape (B,)
        Observed frequency of the event in the bin.
    low, high : numpy.ndarray, shape (B,)
        95 % Wilson limits of `observed`.
    counts : numpy.ndarray of int, shape (B,)
        Number of predictions in the bin.
    """

    predicted: np.ndarray
    observed: np.ndarray
    low: np.ndarray
    high: np.ndarray
    counts: np.ndarray


def reliability_curve(prob, outcome, *, bins: int = 10) -> ReliabilityCurve:
    """Reliability diagram data: predicted probability against observed frequency.

    Parameters
    ----------
    prob : array_like
        Predicted probabilities in [0, 1] (any shape; flattened).
    outcome : array_like of bool
        Whether the predicted event happened (same shape as `prob`).
    bins : int, optional
        Number of equal-width bins on [0, 1], at most :data:`MAX_BINS`; empty
        bins are dropped.

    Returns
    -------
    ReliabilityCurve

    Raises
    ------
    ValueError
        Probabilities outside [0, 1] or non-finite, an empty `prob`, an
        `outcome` that is not boolean or of another size, `bins` < 1 or above
        :data:`MAX_BINS` (refused before anything is allocated).
    TypeError
        A non-integer `bins`, non-numeric `prob`.

    Examples
    --------
    >>> r = reliability_curve([0.1, 0.1, 0.9, 0.9], [False, False, True, True], bins=2)
    >>> r.predicted, r.observed, r.counts
    (array([0.1, 0.9]), array([0., 1.]), array([2, 2]))
    """
    bins = as_int(bins, "bins", minimum=1)
    check_size(bins, MAX_BINS, what="bins (`bins`)",
               alternative=f"at most {MAX_BINS} bins (a reliability diagram needs tens)")
    p = as_float_array(prob, "prob").ravel()
    if p.size == 0:
        raise ValueError("`prob` must hold at least one prediction; received an empty array")
    if np.any((p < 0) | (p > 1)):
        raise ValueError(f"`prob` must lie in [0, 1]; received {describe(p)} (min {p.min():.6g},"
                         f" max {p.max():.6g})")
    o = np.asarray(outcome)
    if o.dtype != bool or o.size != p.size:
        raise ValueError(f"`outcome` must be a boolean array with as many entries as `prob` "
                         f"({p.size}); received {describe(outcome)} (dtype {o.dtype}, "
                         f"{o.size} entries)")
    which = np.minimum((p * bins).astype(int), bins - 1)
    counts = np.bincount(which, minlength=bins)
    hits = np.bincount(which[o.ravel()], minlength=bins)
    sums = np.bincount(which, weights=p, minlength=bins)
    keep = np.flatnonzero(counts)
    pred = sums[keep] / counts[keep]
    obs, low, high = (np.empty(keep.size) for _ in range(3))
    for i, b in enumerate(keep):
        est = proportion(int(hits[b]), int(counts[b]))
        obs[i], low[i], high[i] = est.estimate, est.low, est.high
    return ReliabilityCurve(pred, obs, low, high, counts[keep])
