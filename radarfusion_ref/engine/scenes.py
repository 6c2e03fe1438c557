"""Simulated scenes: the book's scene simulators, in one place, with one vocabulary.

Every chapter that needs reports to associate, group or fuse draws them here.

.. rubric:: The simulators

* :func:`two_radar_scene` → :class:`TwoRadarScene`: n objects, two radars,
  every object seen once by each (chapters 2-4);
* :func:`two_radar_clutter_scene` → :class:`ClutterScene`: the same with
  missed detections and false reports (chapter 4);
* :func:`typed_scene` → :class:`TypedScene`: the same objects with types and
  feature reports (chapter 5);
* :func:`grouping_scene` → :class:`GroupingScene`: n objects, m sources,
  general report covariances (chapter 8);
* :func:`polar_scene` → :class:`PolarReports`: a given geometry, two
  separated radars measuring range and azimuth (chapter 7).

.. rubric:: One convention for all of them

*Arguments.* The counts that size the scene are positional: ``n_objects``
(then ``n_sources`` for :func:`grouping_scene`); :func:`polar_scene`, whose
objects sit at given places, takes a ``geometry`` instead. Everything else is
keyword-only and, in every signature and docstring, comes in one order:

1. placement — ``spacing``, ``layout`` (``"line"`` or ``"uniform"``);
2. measurement errors — ``sigma1``, ``sigma2`` (per coordinate, per radar),
   or ``cov`` (one covariance per report), or ``sigma_r``, ``sigma_beta``;
3. detection — ``p_detect1``, ``p_detect2``;
4. clutter — ``false_density1``, ``false_density2`` (false reports per unit
   volume);
5. what the scene adds — feature types (``type_means``, ``type_vars``,
   ``priors``, ``feature_sigma1``, ``feature_sigma2``, ``model``) or fused
   tracks (``track_cov``);
6. size — ``trials``, ``dim``;
7. ``rng`` — None, a seed or a :class:`numpy.random.Generator` (SPEC 7); the
   same seed gives bit-identical scenes, and each docstring states the order
   of the draws.

*Names.* ``truth`` are the true object positions; ``reports`` (``reports1``,
``reports2`` for two radars) the measured ones; ``owner`` (``owner1``,
``owner2``) the object behind each report — ``-1`` a false report, ``-2``
padding (report lists of different lengths are padded to a common one);
``cov`` a report's error covariance; ``true_row_to_col`` (two radars) and
``true_groups`` (m sources) the correct decisions.

*Shapes.* The trial axis comes first: ``truth`` is ``(trials, n, d)``, a
radar's reports ``(trials, k, d)``, m sources' reports ``(trials, m, k, d)``,
per-report numbers (owners, features, ranges) ``(trials, k)``. Every result
derives from :class:`Scene`, which reads ``trials``, ``n_objects`` and
``dim`` off ``truth``.

*Size.* Scenes are drawn in memory; a request beyond
:data:`radarfusion_ref.engine._validation.MEMORY_LIMIT` is refused before anything is
allocated (draw the trials in batches from generators spawned from one
:class:`numpy.random.SeedSequence`).

The geometry of :func:`polar_scene` (two radars, targets at given places) is
:mod:`radarfusion_ref.engine.geometry`.

Also here: :func:`binding_hypotheses` (every binding of m sources' reports to n
tracks, in the order of :meth:`GroupingScene.true_hypothesis`),
:func:`nearest_neighbour_pairing` (the naive rule the book starts from) and
:func:`ellipse_covariance` (a 2-D covariance from its ellipse).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ._validation import (
    MEMORY_LIMIT,
    _describe,
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    as_rng,
    check_size,
)
from .geometry import (
    MAX_TRIALS,
    Geometry,
    _as_geometry,
    _normal_blocks,
    _polar_sigmas_iv,
    _root_seed,
)

__all__ = [
    "Scene",
    "TwoRadarScene",
    "ClutterScene",
    "TypedScene",
    "GroupingScene",
    "PolarReports",
    "FEATURE_MODELS",
    "LAYOUTS",
    "MAX_BINDING_HYPOTHESES",
    "two_radar_scene",
    "two_radar_clutter_scene",
    "typed_scene",
    "grouping_scene",
    "polar_scene",
    "binding_hypotheses",
    "nearest_neighbour_pairing",
    "ellipse_covariance",
]

#: Object placements of the simulators that place objects themselves.
LAYOUTS = ("line", "uniform")
#: Feature observation models of :func:`typed_scene`: ``"shared"`` — both radars
#: measure one feature value per object (model 1); ``"spread"`` — each radar
#: measures its own draw from the type density (model 2).
FEATURE_MODELS = ("shared", "spread")
#: Largest number of binding hypotheses :math:`(n!)^m` that :func:`binding_hypotheses`
#: enumerates (``(n, m) = (6, 2)`` is 518 400).
MAX_BINDING_HYPOTHESES = 10**6
#: Working copies of the report arrays :func:`two_radar_clutter_scene` makes
#: (its memory check counts them).
_SCENE_COPIES = 6
#: Arrays of the size of the reports that :func:`two_radar_scene` holds at once
#: (truth, two report arrays, their noise, the permuted truth).
_TWO_RADAR_COPIES = 5


# ----------------------------------------------------------------------------- helpers
def _number(arr: np.ndarray, name: str) -> float:
    """A validated 0-d array as a float (one number expected)."""
    if arr.ndim != 0:
        raise ValueError(f"`{name}` must be a single number; received shape {arr.shape}")
    return float(arr)


def _limit(requested, limit, *, name: str, what: str, alternative: str) -> int:
    """:func:`check_size`, with the public argument named in the message."""
    try:
        return check_size(requested, limit, what=what, alternative=alternative)
    except ValueError as exc:
        raise ValueError(f"`{name}`: {exc}") from None


def _types_iv(type_means, type_vars, priors):
    """Validate the type description; return means, variances and log priors, each (K,)."""
    means = as_float_array(type_means, "type_means")
    if means.ndim != 1 or means.size == 0:
        raise ValueError("`type_means` must be a non-empty 1-D array (one mean per type); "
                         f"received {_describe(means)}")
    tvars = as_positive(type_vars, "type_vars")
    if tvars.shape != means.shape:
        raise ValueError(f"`type_vars` must have the same shape as `type_means`, {means.shape}; "
                         f"received shape {tvars.shape}")
    n_types = means.size
    if priors is None:
        return means, tvars, np.full(n_types, -np.log(n_types))
    p = as_float_array(priors, "priors")
    if p.shape != means.shape:
        raise ValueError(f"`priors` must have the same shape as `type_means`, {means.shape}; "
                         f"received shape {p.shape}")
    if np.any(p < 0):
        raise ValueError(f"`priors` must be >= 0; received {_describe(p)}")
    if abs(p.sum() - 1.0) > 1e-8:
        raise ValueError(f"`priors` must sum to 1 (within 1e-8); received {_describe(p)} "
                         f"(sum {p.sum():.10g})")
    with np.errstate(divide="ignore"):
        return means, tvars, np.log(p)


# ----------------------------------------------------------------------------- results
class Scene:
    """Common base of the simulators' results: the trial axis comes first.

    A subclass holds (or computes) ``truth``, the true object positions of
    shape ``(trials, n, d)``; the sizes below are read off it.
    """

    __slots__ = ()

    @property
    def trials(self) -> int:
        """Number of independent trials (the first axis of every array)."""
        return int(self.truth.shape[0])

    @property
    def n_objects(self) -> int:
        """Number of objects n."""
        return int(self.truth.shape[1])

    @property
    def dim(self) -> int:
        """Dimension d of an object's position."""
        return int(self.truth.shape[-1])


@dataclass(frozen=True)
class TwoRadarScene(Scene):
    """Reports of two radars about the same objects, for many trials.

    Attributes
    ----------
    truth : numpy.ndarray, shape (trials, n, d)
        True object positions.
    reports1 : numpy.ndarray, shape (trials, n, d)
        Radar 1's reports, ``reports1[t, j]`` produced by object ``j``.
    reports2 : numpy.ndarray, shape (trials, n, d)
        Radar 2's reports in shuffled order.
    owner2 : numpy.ndarray of int, shape (trials, n)
        ``owner2[t, i]`` is the object that produced ``reports2[t, i]``.
    sigma1, sigma2 : float
        Standard deviations of the radars' errors (per coordinate).
    """

    truth: np.ndarray
    reports1: np.ndarray
    reports2: np.ndarray
    owner2: np.ndarray
    sigma1: float
    sigma2: float

    @property
    def owner1(self) -> np.ndarray:
        """``owner1[t, j] = j``: radar 1 lists its reports in object order."""
        return np.broadcast_to(np.arange(self.owner2.shape[-1]), self.owner2.shape)

    @property
    def true_match(self) -> np.ndarray:
        """``true_match[t, j]``: index in ``reports2[t]`` of object ``j``'s report."""
        return np.argsort(self.owner2, axis=-1)

    @property
    def true_row_to_col(self) -> np.ndarray:
        """The correct decisions: for radar-1 report ``j``, the index of the radar-2
        report of the same object (every object is seen by both radars, so this is
        :attr:`true_match`; named as in :class:`ClutterScene`)."""
        return self.true_match


@dataclass(frozen=True)
class ClutterScene(Scene):
    """Two radars' reports with missed detections and false reports, many trials.

    Report lists have different lengths in different trials; they are padded
    to a common length (padding has owner -2 and coordinates 0).

    Attributes
    ----------
    truth : numpy.ndarray, shape (trials, n, d)
        True object positions.
    reports1, reports2 : numpy.ndarray, shape (trials, m1, d) and (trials, m2, d)
        Reports of each radar, in random order, padded.
    owner1, owner2 : numpy.ndarray of int, shape (trials, m1) and (trials, m2)
        Object that produced each report; -1 for a false report, -2 for padding.
    sigma1, sigma2 : float
        Error standard deviations (per coordinate).
    p_detect1, p_detect2, false_density1, false_density2 : float
        The simulation's detection probabilities and false-report densities.
    region_low, region_high : numpy.ndarray, shape (d,)
        The box in which false reports fall (volume ``n * spacing**d``).
    """

    truth: np.ndarray
    reports1: np.ndarray
    reports2: np.ndarray
    owner1: np.ndarray
    owner2: np.ndarray
    sigma1: float
    sigma2: float
    p_detect1: float
    p_detect2: float
    false_density1: float
    false_density2: float
    region_low: np.ndarray
    region_high: np.ndarray

    @property
    def valid1(self) -> np.ndarray:
        """Which entries of ``reports1`` are real reports (not padding)."""
        return self.owner1 > -2

    @property
    def valid2(self) -> np.ndarray:
        """Which entries of ``reports2`` are real reports (not padding)."""
        return self.owner2 > -2

    @property
    def volume(self) -> float:
        """Volume of the surveillance region."""
        return float(np.prod(self.region_high - self.region_low))

    @property
    def object_density(self) -> float:
        r"""Objects per unit volume, :math:`\rho_T = n / \text{volume}`."""
        return self.truth.shape[1] / self.volume

    @property
    def true_row_to_col(self) -> np.ndarray:
        """The correct decisions: for each radar-1 report, the radar-2 report of the
        same object, or -1 (false report, object missed by radar 2, padding)."""
        o1, o2 = self.owner1[..., :, None], self.owner2[..., None, :]
        match = (o1 == o2) & (o1 >= 0)
        return np.where(match.any(-1), match.argmax(-1), -1)

    def mask_cost(self, cost) -> np.ndarray:
        """`cost` with ``+inf`` in the padding rows and columns."""
        c = np.array(cost, dtype=float)
        return np.where(self.valid1[..., :, None] & self.valid2[..., None, :], c, np.inf)


@dataclass(frozen=True)
class TypedScene(Scene):
    """Two-radar scenes of typed objects with coordinate and feature reports.

    Attributes
    ----------
    coords : TwoRadarScene
        The coordinate part (truth, reports, ``owner2``), from
        :func:`two_radar_scene`.
    types : numpy.ndarray of int, shape (trials, n)
        True type index of each object.
    feature_truth : numpy.ndarray, shape (trials, n)
        The feature value of each object as radar 1 sees it (under
        ``"shared"`` also radar 2's; under ``"spread"`` radar 2 sees an
        independent draw from the same type density).
    features1 : numpy.ndarray, shape (trials, n)
        Radar 1's feature reports, in object order (like ``coords.reports1``).
    features2 : numpy.ndarray, shape (trials, n)
        Radar 2's feature reports, in radar 2's shuffled order (like
        ``coords.reports2``).
    feature_sigma1, feature_sigma2 : float
        Feature error standard deviations of the two radars.
    type_means, type_vars, priors : numpy.ndarray, shape (K,)
        The type description the scene was drawn from.
    model : str
        ``"shared"`` or ``"spread"``.
    """

    coords: TwoRadarScene
    types: np.ndarray
    feature_truth: np.ndarray
    features1: np.ndarray
    features2: np.ndarray
    feature_sigma1: float
    feature_sigma2: float
    type_means: np.ndarray
    type_vars: np.ndarray
    priors: np.ndarray
    model: str

    @property
    def truth(self) -> np.ndarray:
        """True object positions, shape (trials, n, d) (``coords.truth``)."""
        return self.coords.truth

    @property
    def owner2(self) -> np.ndarray:
        """``owner2[t, i]``: the object behind radar 2's report ``i`` (``coords.owner2``)."""
        return self.coords.owner2

    @property
    def true_match(self) -> np.ndarray:
        """``true_match[t, j]``: index in radar 2's list of object ``j``'s report."""
        return self.coords.true_match

    @property
    def n_types(self) -> int:
        """Number of types K."""
        return int(self.type_means.size)


@dataclass(frozen=True)
class GroupingScene(Scene):
    """Reports of m sources about n targets, for many independent trials.

    Attributes
    ----------
    truth : numpy.ndarray, shape (trials, n, d)
        True target states.
    reports : numpy.ndarray, shape (trials, m, n, d)
        ``reports[t, i, j]``: report ``j`` of source ``i``, in shuffled order.
    owner : numpy.ndarray of int, shape (trials, m, n)
        ``owner[t, i, j]``: the target that produced ``reports[t, i, j]``.
    cov : numpy.ndarray, shape (m, n, d, d)
        Error covariance of each report (the same in every trial, indexed by
        the report's position in the list).
    tracks : numpy.ndarray or None, shape (trials, n, d)
        Fused-track estimates, ``tracks[t, p]`` of target ``p`` (or ``None``).
    track_cov : numpy.ndarray or None, shape (n, d, d)
        Error covariance of the fused tracks (or ``None``).
    """

    truth: np.ndarray
    reports: np.ndarray
    owner: np.ndarray
    cov: np.ndarray
    tracks: np.ndarray | None
    track_cov: np.ndarray | None

    @property
    def n_sources(self) -> int:
        """Number of sources m."""
        return int(self.owner.shape[-2])

    @property
    def true_binding(self) -> np.ndarray:
        """``true_binding[t, i, p]``: index of source ``i``'s report of target ``p``."""
        return np.argsort(self.owner, axis=-1)

    @property
    def true_groups(self) -> np.ndarray:
        """The true grouping, shape (trials, n, m), rows sorted by source 0."""
        bind = self.true_binding                      # (T, m, n)
        target_of_row = self.owner[:, 0, :]           # (T, n): target of source-0 report k
        idx = np.broadcast_to(target_of_row[:, None, :], bind.shape)
        return np.swapaxes(np.take_along_axis(bind, idx, axis=-1), -1, -2)

    def is_correct(self, groups) -> np.ndarray:
        """Per trial: is `groups` (shape (trials, n, m)) the true grouping?"""
        g = np.asarray(groups)
        if g.shape != self.true_groups.shape:
            raise ValueError(
                f"`groups` must have shape {self.true_groups.shape}; received shape {g.shape}"
            )
        return np.all(g == self.true_groups, axis=(-2, -1))

    def true_hypothesis(self) -> np.ndarray:
        """Per trial, the index of the true binding in :func:`binding_hypotheses` order."""
        m, n = self.owner.shape[-2:]
        hyp = binding_hypotheses(n, m)                # (H, m, n)
        match = np.all(hyp[None] == self.true_binding[:, None], axis=(-2, -1))
        return np.argmax(match, axis=-1)


@dataclass(frozen=True)
class PolarReports(Scene):
    """Noisy polar reports of both radars about every target, for many trials.

    Attributes
    ----------
    r1, beta1 : numpy.ndarray, shape (trials, n)
        Radar 1's measured range (km) and azimuth (rad) of target ``j`` in
        column ``j``.
    r2, beta2 : numpy.ndarray, shape (trials, n)
        The same for radar 2, in radar 2's own polar frame.
    sigma_r, sigma_beta : float
        Measurement error standard deviations (km, rad), equal for both radars.
    geometry : radarfusion_ref.engine.geometry.Geometry
        The scene that produced the reports.
    """

    r1: np.ndarray
    beta1: np.ndarray
    r2: np.ndarray
    beta2: np.ndarray
    sigma_r: float
    sigma_beta: float
    geometry: Geometry

    @property
    def trials(self) -> int:
        """Number of trials (rows)."""
        return self.r1.shape[0]

    @property
    def truth(self) -> np.ndarray:
        """True target positions in radar 1's frame, shape (trials, n, 2) (a
        read-only broadcast of ``geometry.targets``: they do not move)."""
        t = self.geometry.targets
        return np.broadcast_to(t, (self.trials, *t.shape))


# ----------------------------------------------------------------------------- simulators
def two_radar_scene(n_objects: int, *, spacing: float, layout: str = "line", sigma1: float,
                    sigma2: float, trials: int = 1, dim: int = 1,
                    rng=None) -> TwoRadarScene:
    """Draw `trials` independent scenes of `n_objects` seen by two radars.

    Parameters
    ----------
    n_objects : int
        Number of objects, each seen once by each radar (no misses, no false
        reports).
    spacing : float
        ``"line"``: distance between neighbouring objects on the first axis;
        ``"uniform"``: objects uniform in a cube of side
        ``spacing * n_objects ** (1 / dim)`` (mean density one object per
        ``spacing ** dim``).
    layout : {"line", "uniform"}, optional
        Object placement.
    sigma1, sigma2 : float
        Error standard deviations of radar 1 and radar 2, per coordinate.
    trials : int, optional
        Number of independent scenes.
    dim : int, optional
        Dimension of the measured position.
    rng : None, int or numpy.random.Generator, optional
        Source of randomness (SPEC 7).

    Returns
    -------
    TwoRadarScene

    Raises
    ------
    ValueError
        A count below 1, a `spacing` or sigma that is not a positive finite
        number, an unknown `layout`, or a scene beyond
        :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT`.
    TypeError
        A count that is not an integer, or an `rng` that is not a seed or a
        Generator.

    Notes
    -----
    Draw order: (``"uniform"`` only) the positions, shape ``(trials, n, dim)``;
    radar 1's standard normal errors, same shape; radar 2's permutation per
    trial (:meth:`numpy.random.Generator.permuted`); radar 2's standard normal
    errors.

    Examples
    --------
    >>> s = two_radar_scene(3, spacing=1.0, sigma1=0.1, sigma2=0.2, trials=5, rng=1)
    >>> s.reports2.shape, s.owner2.shape
    ((5, 3, 1), (5, 3))
    >>> bool(np.all(np.sort(s.owner2, axis=1) == np.arange(3)))
    True
    """
    n = as_int(n_objects, "n_objects", minimum=1)
    trials = as_int(trials, "trials", minimum=1)
    dim = as_int(dim, "dim", minimum=1)
    spacing = _number(as_positive(spacing, "spacing"), "spacing")
    s1 = _number(as_positive(sigma1, "sigma1"), "sigma1")
    s2 = _number(as_positive(sigma2, "sigma2"), "sigma2")
    layout = as_choice(layout, "layout", LAYOUTS)
    _limit(8 * _TWO_RADAR_COPIES * trials * n * dim, MEMORY_LIMIT, name="trials",
           what=f"bytes of scenes ({trials} trials x {n} objects x dim {dim})",
           alternative="fewer `trials` per call (draw the trials in batches)")
    rng = as_rng(rng)

    if layout == "line":
        truth = np.zeros((trials, n, dim))
        truth[..., 0] = spacing * np.arange(n)
    else:
        side = spacing * n ** (1.0 / dim)
        truth = rng.uniform(0.0, side, size=(trials, n, dim))
    reports1 = truth + s1 * rng.standard_normal((trials, n, dim))
    owner2 = rng.permuted(np.broadcast_to(np.arange(n), (trials, n)), axis=1)
    truth2 = np.take_along_axis(truth, owner2[..., None], axis=1)
    reports2 = truth2 + s2 * rng.standard_normal((trials, n, dim))
    return TwoRadarScene(truth, reports1, reports2, owner2, s1, s2)


def two_radar_clutter_scene(n_objects: int, *, spacing: float, layout: str = "line",
                            sigma1: float, sigma2: float,
                            p_detect1: float = 1.0, p_detect2: float = 1.0,
                            false_density1: float = 0.0, false_density2: float = 0.0,
                            trials: int = 1, dim: int = 1, rng=None) -> ClutterScene:
    r"""The two-radar scene with missed detections and false reports.

    Draws :func:`two_radar_scene`, then lets radar :math:`r` keep each
    object's report with probability :math:`P_{D,r}` and add a Poisson number
    of false reports, uniform over the surveillance box, with density
    :math:`\rho_{F,r}`; both lists are then shuffled.

    Parameters
    ----------
    n_objects, spacing, layout, sigma1, sigma2, trials, dim
        As in :func:`two_radar_scene`.
    p_detect1, p_detect2 : float, optional
        Detection probabilities in [0, 1] (default 1).
    false_density1, false_density2 : float, optional
        Expected false reports per unit volume (default 0). The box is
        ``[-s/2, (n - 1/2) s] x [-s/2, s/2]^(d-1)`` for the line layout and
        the objects' cube for the uniform layout; its volume is
        :math:`n s^d` either way.
    rng : None, int or numpy.random.Generator, optional
        Source of randomness (SPEC 7).

    Returns
    -------
    ClutterScene

    Raises
    ------
    ValueError
        As :func:`two_radar_scene`; a detection probability outside [0, 1], a
        negative or non-finite false-report density, or false reports beyond
        :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT` (checked on the
        expected count before any draw, and on the drawn count before the
        positions are allocated).

    Notes
    -----
    Draw order: :func:`two_radar_scene`; then for radar 1 and then radar 2:
    the detections (uniforms, shape ``(trials, n)``), the false-report
    counts (Poisson, ``(trials,)``), their positions (uniforms,
    ``(trials, max count, d)``) and the shuffling keys (uniforms, one per
    detected or false report slot).

    Examples
    --------
    >>> s = two_radar_clutter_scene(4, spacing=1.0, sigma1=0.1, sigma2=0.1, p_detect2=0.5,
    ...                             false_density1=0.5, trials=3, rng=2)
    >>> s.reports1.shape[0], s.true_row_to_col.shape == s.owner1.shape
    (3, True)
    """
    pd1 = _number(as_probability(p_detect1, "p_detect1", open_interval=False), "p_detect1")
    pd2 = _number(as_probability(p_detect2, "p_detect2", open_interval=False), "p_detect2")
    lam1 = _number(as_positive(false_density1, "false_density1", strict=False), "false_density1")
    lam2 = _number(as_positive(false_density2, "false_density2", strict=False), "false_density2")
    rng = as_rng(rng)
    base = two_radar_scene(n_objects, spacing=spacing, layout=layout, sigma1=sigma1,
                           sigma2=sigma2, trials=trials, dim=dim, rng=rng)
    t, n, d = base.truth.shape
    s = float(spacing)
    if layout == "line":
        low = np.full(d, -s / 2)
        high = np.full(d, s / 2)
        high[0] = (n - 0.5) * s
    else:
        low, high = np.zeros(d), np.full(d, s * n ** (1.0 / d))
    volume = float(np.prod(high - low))
    owner1_obj = np.broadcast_to(np.arange(n), (t, n))

    # The false reports' memory is checked before any is drawn: expected count, then
    # (after the Poisson draw, before the positions are allocated) the actual one.
    for name, lam in (("false_density1", lam1), ("false_density2", lam2)):
        _limit(math.ceil(lam * volume) * t * d * 8 * _SCENE_COPIES, MEMORY_LIMIT, name=name,
               what=f"bytes of false reports (expected {lam * volume:.3g} per trial, "
                    f"{t} trials, d = {d})",
               alternative="fewer `trials` per call (draw the trials in batches)")

    def build(reports, owners, pd, lam):
        detected = rng.random((t, n)) < pd
        nfalse = rng.poisson(lam * volume, size=t)
        fmax = int(nfalse.max()) if t else 0
        _limit((n + fmax) * t * d * 8 * _SCENE_COPIES, MEMORY_LIMIT, name="trials",
               what=f"bytes of reports ({n} objects + up to {fmax} false reports per trial)",
               alternative="fewer `trials` per call (draw the trials in batches)")
        fpos = low + (high - low) * rng.random((t, fmax, d))
        fvalid = np.arange(fmax)[None, :] < nfalse[:, None]
        allpos = np.concatenate([reports, fpos], axis=1)
        allown = np.concatenate([np.where(detected, owners, -2),
                                 np.where(fvalid, -1, -2)], axis=1)
        keys = np.where(allown > -2, rng.random(allown.shape), np.inf)
        order = np.argsort(keys, axis=1, kind="stable")
        width = max(1, int((allown > -2).sum(axis=1).max()))
        order = order[:, :width]
        own = np.take_along_axis(allown, order, axis=1)
        pos = np.take_along_axis(allpos, order[..., None], axis=1)
        pos = np.where(own[..., None] > -2, pos, 0.0)
        return pos, own

    r1, o1 = build(base.reports1, owner1_obj, pd1, lam1)
    r2, o2 = build(base.reports2, base.owner2, pd2, lam2)
    return ClutterScene(base.truth, r1, r2, o1, o2, base.sigma1, base.sigma2, pd1, pd2,
                        lam1, lam2, low, high)


def typed_scene(n_objects: int, *, spacing: float, layout: str = "line", sigma1: float,
                sigma2: float, type_means, type_vars, priors=None, feature_sigma1: float,
                feature_sigma2: float, model: str = "shared", trials: int = 1, dim: int = 1,
                rng=None) -> TypedScene:
    r"""Draw `trials` scenes of `n_objects` typed objects seen by two radars.

    Positions and coordinate reports come from :func:`two_radar_scene` (same
    arguments); then each object gets a type :math:`k \sim p`, a feature value
    :math:`\Pi \sim \mathcal N(\Pi_k, \sigma_{\Pi k}^2)` and a feature report from
    each radar.

    Parameters
    ----------
    n_objects : int
        Number of objects.
    spacing, layout, sigma1, sigma2 :
        As in :func:`two_radar_scene`.
    type_means, type_vars : array_like, shape (K,)
        Type densities (8): means :math:`\Pi_k` and variances :math:`\sigma_{\Pi k}^2`.
    priors : array_like, shape (K,), optional
        Type probabilities (default uniform).
    feature_sigma1, feature_sigma2 : float
        Feature error standard deviations :math:`\sigma_{\Pi1}, \sigma_{\Pi2}`.
    model : {"shared", "spread"}, optional
        Model 1: both radars measure the same value; model 2: each radar
        measures its own draw from the type density (:data:`FEATURE_MODELS`).
    trials, dim :
        As in :func:`two_radar_scene`.
    rng : None, int or numpy.random.Generator, optional
        Source of randomness (SPEC 7).

    Returns
    -------
    TypedScene

    Raises
    ------
    ValueError
        Bad type description or scene parameters.

    Notes
    -----
    Draw order: :func:`two_radar_scene`; the types (``Generator.choice``,
    shape ``(trials, n)``); the feature values (standard normals); under
    ``"spread"`` radar 2's own values; radar 1's feature errors; radar 2's.

    Examples
    --------
    >>> s = typed_scene(3, type_means=[0.0, 5.0], type_vars=[1.0, 1.0], spacing=1.0,
    ...                 sigma1=0.1, sigma2=0.1, feature_sigma1=0.1, feature_sigma2=0.1,
    ...                 trials=4, rng=1)
    >>> s.features2.shape, s.types.shape, s.n_types
    ((4, 3), (4, 3), 2)
    """
    means, tvars, log_priors = _types_iv(type_means, type_vars, priors)
    fs1 = _number(as_positive(feature_sigma1, "feature_sigma1"), "feature_sigma1")
    fs2 = _number(as_positive(feature_sigma2, "feature_sigma2"), "feature_sigma2")
    model = as_choice(model, "model", FEATURE_MODELS)
    rng = as_rng(rng)
    coords = two_radar_scene(n_objects, spacing=spacing, layout=layout, sigma1=sigma1,
                             sigma2=sigma2, trials=trials, dim=dim, rng=rng)
    trials, n = coords.owner2.shape
    p = np.exp(log_priors)
    types = rng.choice(means.size, size=(trials, n), p=p / p.sum())
    sd = np.sqrt(tvars[types])
    truth = means[types] + sd * rng.standard_normal((trials, n))
    types2 = np.take_along_axis(types, coords.owner2, axis=1)
    if model == "shared":
        seen2 = np.take_along_axis(truth, coords.owner2, axis=1)
    else:
        seen2 = means[types2] + np.sqrt(tvars[types2]) * rng.standard_normal((trials, n))
    features1 = truth + fs1 * rng.standard_normal((trials, n))
    features2 = seen2 + fs2 * rng.standard_normal((trials, n))
    return TypedScene(coords, types, truth, features1, features2, fs1, fs2, means, tvars,
                      np.exp(log_priors), model)


def grouping_scene(n_objects: int, n_sources: int, *, spacing: float = 1.0,
                   layout: str = "line", cov, track_cov=None, trials: int = 1,
                   rng=None) -> GroupingScene:
    """Draw `trials` scenes of `n_objects` targets reported by `n_sources` sources.

    Parameters
    ----------
    n_objects : int
        Number of targets ``n`` (every source reports every target once).
    n_sources : int
        Number of sources ``m >= 1``.
    spacing : float or array_like of shape (d,), optional
        ``"line"``: targets ``spacing`` (its first entry) apart on the first
        coordinate, all other coordinates zero; ``"uniform"``: coordinate ``c``
        of each target uniform on ``[0, spacing[c] * n ** (1 / d)]`` (one target
        per ``prod(spacing)`` of state space) — a vector lets positions and
        velocities have their own scales.
    layout : {"line", "uniform"}, optional
        Target placement.
    cov : array_like, shape (m, n, d, d)
        Error covariance of each report (broadcastable, e.g. ``(m, 1, d, d)``);
        ``d`` is taken from it.
    track_cov : array_like, shape (n, d, d), optional
        If given, also draw fused-track estimates ``tracks[t, p] = truth[t, p] + e``,
        ``e ~ N(0, track_cov[p])``.
    trials : int, optional
        Number of independent scenes.
    rng : None, int or numpy.random.Generator, optional
        Source of randomness (SPEC 7).

    Returns
    -------
    GroupingScene

    Raises
    ------
    ValueError
        A count below 1, a non-positive `spacing` or one of the wrong length,
        a `cov` or `track_cov` that does not broadcast to its shape or is not
        symmetric positive definite, an unknown `layout`, or scenes beyond
        :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT`.
    TypeError
        A count that is not an integer, or an `rng` that is not a seed or a
        Generator.

    Notes
    -----
    Draw order: (``"uniform"`` only) the positions, uniforms of shape
    ``(trials, n, d)``; each source's permutation per trial; the reports'
    standard normals ``(trials, m, n, d)``; (with `track_cov`) the tracks'
    standard normals ``(trials, n, d)``.

    Examples
    --------
    >>> s = grouping_scene(3, 2, cov=np.eye(2)[None, None] * 0.01, trials=4, rng=1)
    >>> s.reports.shape, s.true_groups.shape
    ((4, 2, 3, 2), (4, 3, 2))
    >>> bool(np.all(s.true_groups[..., 0] == np.arange(3)))
    True
    """
    n = as_int(n_objects, "n_objects", minimum=1)
    m = as_int(n_sources, "n_sources", minimum=1)
    trials = as_int(trials, "trials", minimum=1)
    spacing = as_positive(spacing, "spacing")
    layout = as_choice(layout, "layout", LAYOUTS)
    c = as_float_array(cov, "cov", ndim_min=4)
    try:
        c = np.broadcast_to(c, (m, n, *c.shape[-2:]))
    except ValueError:
        raise ValueError(
            f"`cov` must broadcast to shape (m, n, d, d) = ({m}, {n}, d, d); "
            f"received shape {np.shape(cov)}"
        ) from None
    c = as_covariance(c, "cov")
    d = c.shape[-1]
    if spacing.ndim > 1 or spacing.size not in (1, d):
        raise ValueError(
            f"`spacing` must be a number or have shape ({d},) (one scale per coordinate); "
            f"received shape {spacing.shape}"
        )
    spacing = np.broadcast_to(spacing.reshape(-1), (d,))
    tcov = None
    if track_cov is not None:
        tcov = as_float_array(track_cov, "track_cov", ndim_min=2)
        try:
            tcov = np.broadcast_to(tcov, (n, d, d))
        except ValueError:
            raise ValueError(
                f"`track_cov` must broadcast to shape ({n}, {d}, {d}); received shape "
                f"{np.shape(track_cov)}"
            ) from None
        tcov = as_covariance(tcov, "track_cov")
    check_size(8 * trials * (4 * m * n * d + 3 * n * d + m * n), MEMORY_LIMIT,
               what=f"bytes of scenes (`trials` = {trials} x {m} sources x {n} targets x d = {d})",
               alternative="several calls with generators spawned from one SeedSequence")
    rng = as_rng(rng)
    if layout == "line":
        truth = np.zeros((trials, n, d))
        truth[..., 0] = spacing[0] * np.arange(n)
    else:
        truth = rng.uniform(0.0, 1.0, size=(trials, n, d)) * (spacing * n ** (1.0 / d))
    owner = rng.permuted(np.broadcast_to(np.arange(n), (trials, m, n)), axis=-1)
    chol = np.linalg.cholesky(c)                                    # (m, n, d, d)
    z = rng.standard_normal((trials, m, n, d))
    src = np.take_along_axis(truth[:, None], owner[..., None], axis=2)   # (T, m, n, d)
    reports = src + np.einsum("ijkl,tijl->tijk", chol, z)
    tracks = None
    if tcov is not None:
        zt = rng.standard_normal((trials, n, d))
        tracks = truth + np.einsum("pkl,tpl->tpk", np.linalg.cholesky(tcov), zt)
    return GroupingScene(truth, reports, owner, np.array(c), tracks,
                         None if tcov is None else np.array(tcov))


def polar_scene(geometry: Geometry, *, sigma_r, sigma_beta, trials: int = 1,
                   rng=None) -> PolarReports:
    r"""Draw independent Gaussian polar measurements of every target by both radars.

    The objects sit where `geometry` puts them (no `n_objects`, `spacing` or
    `layout`).

    Parameters
    ----------
    geometry : radarfusion_ref.engine.geometry.Geometry
        Radars and targets.
    sigma_r : float
        Range error standard deviation :math:`\sigma_r` (km).
    sigma_beta : float
        Azimuth error standard deviation :math:`\sigma_\beta` (rad), at most
        :data:`radarfusion_ref.engine.geometry.SIGMA_BETA_MAX`.
    trials : int, optional
        Number of independent trials, at most
        :data:`radarfusion_ref.engine.geometry.MAX_TRIALS` and such that the reports
        fit in :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT` (about 5
        million trials of two targets; run several calls for more).
    rng : None, int, numpy.random.SeedSequence or numpy.random.Generator, optional
        Source of randomness (SPEC 7). Draws are made per block of
        :data:`radarfusion_ref.engine.geometry.BLOCK_TRIALS` trials from spawned seed
        sequences, exactly as in
        :func:`radarfusion_ref.separated.association_experiment`: the same seed
        gives the same reports there and here.

    Returns
    -------
    PolarReports

    Raises
    ------
    ValueError
        If a sigma is not positive, `sigma_beta` exceeds
        :data:`radarfusion_ref.engine.geometry.SIGMA_BETA_MAX`, `sigma_r` is not
        below a tenth of the shortest range, or `trials` is below 1 or above
        its limit.
    TypeError
        If `geometry` is not a :class:`radarfusion_ref.engine.geometry.Geometry`.

    Notes
    -----
    .. math::

        \hat r_{kj} = r_{kj} + \sigma_r \xi, \quad
        \hat\beta_{kj} = \beta_{kj} + \sigma_\beta \eta, \quad
        \xi, \eta \sim \mathcal N(0, 1)

    independently for radar :math:`k`, target :math:`j` and trial. The
    standard normals are drawn per block as arrays of shape ``(4, n, L)`` in
    the order :math:`\hat r_1, \hat\beta_1, \hat r_2, \hat\beta_2` (the
    attributes are transposed views of them).

    References
    ----------
    Prosov, the measurement model before eq. (1).

    Examples
    --------
    >>> from radarfusion_ref.engine.geometry import Geometry
    >>> geo = Geometry(30.0, 0.0, [[106.0, 106.0], [109.6, 102.5]])
    >>> rep = polar_scene(geo, sigma_r=0.1, sigma_beta=np.deg2rad(1.0), trials=3, rng=1)
    >>> rep.r1.shape, rep.trials
    ((3, 2), 3)
    """
    geo = _as_geometry(geometry)
    sr, sb = _polar_sigmas_iv(sigma_r, sigma_beta, geo)
    n = as_int(trials, "trials", minimum=1)
    check_size(n, MAX_TRIALS, what="trials (`trials`)",
               alternative="several calls with spawned seeds")
    n_t = geo.targets.shape[0]
    check_size(8 * 8 * n_t * n, MEMORY_LIMIT, what="bytes of polar reports for `trials`",
               alternative="association_experiment (chunked) or several smaller calls")
    root = _root_seed(rng)
    (r1, b1), (r2, b2) = geo.polar1, geo.polar2
    z = np.concatenate(list(_normal_blocks(root, n_t, n)), axis=-1)   # trial axis last
    r1 = r1[:, None] + sr * z[0]
    b1 = b1[:, None] + sb * z[1]
    r2 = r2[:, None] + sr * z[2]
    b2 = b2[:, None] + sb * z[3]
    return PolarReports(r1.T, b1.T, r2.T, b2.T, sr, sb, geo)


def binding_hypotheses(n_targets: int, n_sources: int) -> np.ndarray:
    """All ways to bind every source's reports one-to-one to `n_targets` fused tracks.

    Parameters
    ----------
    n_targets : int
        Number of tracks (= reports per source), ``>= 1``.
    n_sources : int
        Number of sources, ``>= 1``.

    Returns
    -------
    numpy.ndarray of int, shape (H, m, n)
        ``hyp[h, i, p]``: index of the report of source ``i`` bound to track
        ``p`` under hypothesis ``h``; :math:`H = (n!)^m`, in
        :func:`itertools.product` order of the sources' permutations (the order
        of :meth:`GroupingScene.true_hypothesis`).

    Raises
    ------
    ValueError
        If :math:`(n!)^m` exceeds :data:`MAX_BINDING_HYPOTHESES` (checked before
        anything is built; the scalable route is the exact ML binding as a
        grouping of ``m + 1`` sources with the tracks as source 0,
        :func:`radarfusion_ref.grouping.group_sd`).

    Examples
    --------
    >>> binding_hypotheses(2, 2).shape
    (4, 2, 2)
    >>> binding_hypotheses(2, 2)[1].tolist()    # the paper's hypothesis IV
    [[0, 1], [1, 0]]
    """
    n = as_int(n_targets, "n_targets", minimum=1)
    m = as_int(n_sources, "n_sources", minimum=1)
    check_size(math.factorial(n) ** m, MAX_BINDING_HYPOTHESES,
               what=f"binding hypotheses (n!)**m (`n_targets` n = {n}, `n_sources` m = {m})",
               alternative="group_sd on the m + 1 sources with the tracks as source 0 "
                           "(the exact ML binding, without enumeration)")
    perms = np.array(list(itertools.permutations(range(n))), dtype=np.int64).reshape(-1, n)
    return np.array([np.stack(p) for p in itertools.product(perms, repeat=m)])


# ----------------------------------------------------------------------------- helpers for callers
def nearest_neighbour_pairing(reports1, reports2) -> np.ndarray:
    """For each radar-1 report, the index of the nearest radar-2 report.

    The naive rule the book starts from: no gate, no exclusivity (two radar-1
    reports may pick the same radar-2 report).

    Parameters
    ----------
    reports1 : array_like, shape (..., n1, d)
        Radar 1's reports (leading axes are a batch, e.g. trials).
    reports2 : array_like, shape (..., n2, d)
        Radar 2's reports, the same leading axes and d.

    Returns
    -------
    numpy.ndarray of int, shape (..., n1)
        Index in `reports2` of the report nearest (Euclidean) to each radar-1 report.

    Raises
    ------
    ValueError
        If the last dimensions differ, or an input is not finite or has fewer
        than two axes.

    Examples
    --------
    >>> nearest_neighbour_pairing([[0.0], [1.0]], [[0.9], [0.1]])
    array([1, 0])
    """
    r1 = as_float_array(reports1, "reports1", ndim_min=2)
    r2 = as_float_array(reports2, "reports2", ndim_min=2)
    if r1.shape[-1] != r2.shape[-1]:
        raise ValueError(
            "`reports1` and `reports2` must have the same last dimension d; "
            f"received shapes {r1.shape} and {r2.shape}"
        )
    d2 = np.sum((r1[..., :, None, :] - r2[..., None, :, :]) ** 2, axis=-1)
    return np.argmin(d2, axis=-1)


def ellipse_covariance(angle, major, minor) -> np.ndarray:
    r"""2-D covariance whose 1-sigma ellipse has semi-axes `major`, `minor`, rotated by `angle`.

    Parameters
    ----------
    angle : float
        Direction of the major axis, radians counter-clockwise from the x axis.
    major, minor : float
        Standard deviations along the major and minor axes (> 0).

    Returns
    -------
    numpy.ndarray, shape (2, 2)
        :math:`R(\theta)\,\mathrm{diag}(a^2, b^2)\,R(\theta)^\mathsf{T}`.

    Examples
    --------
    >>> ellipse_covariance(np.pi / 2, 2.0, 1.0).round(12)
    array([[1., 0.],
           [0., 4.]])
    """
    theta, a, b = (as_float_array(angle, "angle"), as_positive(major, "major"),
                   as_positive(minor, "minor"))
    for name, v in (("angle", theta), ("major", a), ("minor", b)):
        if v.ndim:
            raise TypeError(f"`{name}` must be a scalar; received an array of shape {v.shape}")
    theta, a, b = float(theta), float(a), float(b)
    if a * a == 0 or b * b == 0 or not np.isfinite(a * a):
        raise ValueError(f"`major`, `minor` must square to positive finite variances; "
                         f"received {major!r}, {minor!r}")
    c, s = np.cos(theta), np.sin(theta)
    rot = np.array([[c, -s], [s, c]])
    return rot @ np.diag([a * a, b * b]) @ rot.T
