"""What every scene shares: the result base class, the placements, the door helpers."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..validation import (
    MAX_MAGNITUDE,
    as_float_array,
    as_positive,
    describe,
)

#: Object placements of the simulators that place objects themselves.
LAYOUTS = ("line", "uniform")
#: Feature observation models of :func:`typed_scene`: ``"shared"`` — both radars
#: measure one feature value per object (model 1); ``"spread"`` — each radar
#: measures its own draw from the type density (model 2).
FEATURE_MODELS = ("shared", "spread")
#: Working copies of the report arrays :func:`two_radar_clutter_scene` makes
#: (its memory check counts them).
_SCENE_COPIES = 6
#: Arrays of the size of the reports that :func:`two_radar_scene` holds at once
#: (truth, two report arrays, their noise, the permuted truth).
_TWO_RADAR_COPIES = 5



# ----------------------------------------------------------------------------- helpers
def _domain(value: float, *, name: str, what: str) -> None:
    """Refuse a scene whose coordinates or errors would leave the numeric domain.

    The simulators place objects and draw errors inside the Mahalanobis functions'
    domain, magnitudes at most :data:`radarfusion_ref.engine.validation.MAX_MAGNITUDE`
    (:math:`2^{150}`), so no position, difference or square overflows.
    """
    if not value <= MAX_MAGNITUDE:
        raise ValueError(f"`{name}` must keep the scene within the numeric domain "
                         f"|coordinate| <= 2**150 (about 1.4e45): {what} = {value:.6g}; "
                         "change the unit of the coordinates")


def as_type_model(type_means, type_vars, priors=None):
    r"""The door of a type description: K types, each a Gaussian feature with a prior.

    Shared by the typed scenes and the feature rules of chapter 5.

    Parameters
    ----------
    type_means : array_like, shape (K,)
        The feature's mean for each type (at least one type).
    type_vars : array_like, shape (K,)
        Its variance for each type, positive.
    priors : array_like, shape (K,), optional
        The types' prior probabilities, non-negative and summing to 1 (within
        1e-8); equal priors if omitted.

    Returns
    -------
    tuple of numpy.ndarray, each shape (K,)
        The means, the variances and the log priors (``-inf`` for a zero prior).

    Raises
    ------
    ValueError, TypeError
        Naming the argument that breaks its rule.

    Examples
    --------
    >>> as_type_model([0.0, 3.0], [1.0, 1.0])[2]
    array([-0.69314718, -0.69314718])
    >>> as_type_model([0.0, 3.0], [1.0, 1.0], [0.5, 0.6])
    Traceback (most recent call last):
    ...
    ValueError: `priors` must sum to 1 (within 1e-8); received array [0.5 0.6] with shape (2,) (sum 1.1)
    """
    means = as_float_array(type_means, "type_means")
    if means.ndim != 1 or means.size == 0:
        raise ValueError("`type_means` must be a non-empty 1-D array (one mean per type); "
                         f"received {describe(means)}")
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
        raise ValueError(f"`priors` must be >= 0; received {describe(p)}")
    if abs(p.sum() - 1.0) > 1e-8:
        raise ValueError(f"`priors` must sum to 1 (within 1e-8); received {describe(p)} "
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

    if TYPE_CHECKING:                 # a field or a property of every subclass
        @property
        def truth(self) -> np.ndarray: ...

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
