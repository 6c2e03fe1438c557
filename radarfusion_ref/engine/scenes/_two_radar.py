"""Two radars seeing the same objects: plain, with misses and false reports, with types."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..validation import (
    MEMORY_LIMIT,
    as_choice,
    as_float,
    as_int,
    as_positive,
    as_probability,
    as_rng,
    check_size,
)
from ._base import (
    _SCENE_COPIES,
    _TWO_RADAR_COPIES,
    FEATURE_MODELS,
    LAYOUTS,
    Scene,
    _domain,
    as_type_model,
)


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
        number, a scene outside the numeric domain (``spacing * n_objects``,
        `sigma1` or `sigma2` above
        :data:`radarfusion_ref.engine.validation.MAX_MAGNITUDE`, :math:`2^{150}`), an
        unknown `layout`, or a scene beyond
        :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT`.
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
    spacing = as_float(as_positive(spacing, "spacing"), "spacing")
    s1 = as_float(as_positive(sigma1, "sigma1"), "sigma1")
    s2 = as_float(as_positive(sigma2, "sigma2"), "sigma2")
    layout = as_choice(layout, "layout", LAYOUTS)
    _domain(spacing * n, name="spacing", what=f"`spacing` x `n_objects` ({n})")
    _domain(s1, name="sigma1", what="`sigma1`")
    _domain(s2, name="sigma2", what="`sigma2`")
    check_size(8 * _TWO_RADAR_COPIES * trials * n * dim, MEMORY_LIMIT, name="trials",
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
        negative or non-finite false-report density, a box volume or expected
        false-report count that overflows the largest double, or false reports beyond
        :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT` (checked on the
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
    pd1 = as_float(as_probability(p_detect1, "p_detect1", open_interval=False), "p_detect1")
    pd2 = as_float(as_probability(p_detect2, "p_detect2", open_interval=False), "p_detect2")
    lam1 = as_float(as_positive(false_density1, "false_density1", strict=False), "false_density1")
    lam2 = as_float(as_positive(false_density2, "false_density2", strict=False), "false_density2")
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
    with np.errstate(over="ignore"):
        volume = float(np.prod(high - low))
    if not math.isfinite(volume):
        raise ValueError(f"`spacing`, `dim`: the surveillance box's volume n * spacing**dim "
                         f"overflows the largest double (spacing {s:.6g}, dim {d}); change "
                         "the unit of the coordinates")
    owner1_obj = np.broadcast_to(np.arange(n), (t, n))

    # The false reports' memory is checked before any is drawn: expected count, then
    # (after the Poisson draw, before the positions are allocated) the actual one.
    for name, lam in (("false_density1", lam1), ("false_density2", lam2)):
        if not math.isfinite(lam * volume):
            raise ValueError(f"`{name}` times the box's volume ({volume:.6g}) overflows the "
                             f"largest double; received {lam:.6g}")
        check_size(math.ceil(lam * volume) * t * d * 8 * _SCENE_COPIES, MEMORY_LIMIT, name=name,
                   what=f"bytes of false reports (expected {lam * volume:.3g} per trial, "
                    f"{t} trials, d = {d})",
                   alternative="fewer `trials` per call (draw the trials in batches)")

    def build(reports, owners, pd, lam):
        detected = rng.random((t, n)) < pd
        nfalse = rng.poisson(lam * volume, size=t)
        fmax = int(nfalse.max()) if t else 0
        check_size((n + fmax) * t * d * 8 * _SCENE_COPIES, MEMORY_LIMIT, name="trials",
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
    means, tvars, log_priors = as_type_model(type_means, type_vars, priors)
    fs1 = as_float(as_positive(feature_sigma1, "feature_sigma1"), "feature_sigma1")
    fs2 = as_float(as_positive(feature_sigma2, "feature_sigma2"), "feature_sigma2")
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
