"""m sources reporting n targets, and every binding of their reports to n tracks."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..validation import (
    MEMORY_LIMIT,
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_rng,
    check_size,
)
from ._base import (
    LAYOUTS,
    Scene,
    _domain,
)

#: Largest number of binding hypotheses :math:`(n!)^m` that :func:`binding_hypotheses`
#: enumerates (``(n, m) = (6, 2)`` is 518 400).
MAX_BINDING_HYPOTHESES = 10**6

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
        symmetric positive definite, an unknown `layout`, targets outside the
        numeric domain (``spacing * n_objects`` above
        :data:`radarfusion_ref.engine.validation.MAX_MAGNITUDE`, :math:`2^{150}`), or
        scenes beyond :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT`
        (checked before `cov` is broadcast).
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
    scale = as_positive(spacing, "spacing")
    layout = as_choice(layout, "layout", LAYOUTS)
    c = as_float_array(cov, "cov", ndim_min=4)
    d = c.shape[-1]
    check_size(8 * trials * (4 * m * n * d + 3 * n * d + m * n) + 8 * m * n * d * d,
               MEMORY_LIMIT,
               what=f"bytes of scenes (`trials` = {trials} x {m} sources x {n} targets x d = {d})",
               alternative="several calls with generators spawned from one SeedSequence")
    try:
        c = np.broadcast_to(c, (m, n, *c.shape[-2:]))
    except ValueError:
        raise ValueError(
            f"`cov` must broadcast to shape (m, n, d, d) = ({m}, {n}, d, d); "
            f"received shape {np.shape(cov)}"
        ) from None
    c = as_covariance(c, "cov")
    if scale.ndim > 1 or scale.size not in (1, d):
        raise ValueError(
            f"`spacing` must be a number or have shape ({d},) (one scale per coordinate); "
            f"received shape {scale.shape}"
        )
    scale = np.broadcast_to(scale.reshape(-1), (d,))
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
    _domain(float(scale.max()) * n, name="spacing", what=f"`spacing` x `n_objects` ({n})")
    rng = as_rng(rng)
    if layout == "line":
        truth = np.zeros((trials, n, d))
        truth[..., 0] = scale[0] * np.arange(n)
    else:
        truth = rng.uniform(0.0, 1.0, size=(trials, n, d)) * (scale * n ** (1.0 / d))
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
    if m * math.lgamma(n + 1) > math.log(MAX_BINDING_HYPOTHESES) + 1:   # (n!)**m not formed
        raise ValueError(
            f"refused: about 10**{m * math.lgamma(n + 1) / math.log(10):.0f} binding hypotheses "
            f"(n!)**m (`n_targets` n = {n}, `n_sources` m = {m}) requested, above the limit of "
            f"{MAX_BINDING_HYPOTHESES}; use group_sd on the m + 1 sources with the tracks as "
            "source 0 (the exact ML binding, without enumeration) instead")
    check_size(math.factorial(n) ** m, MAX_BINDING_HYPOTHESES,
               what=f"binding hypotheses (n!)**m (`n_targets` n = {n}, `n_sources` m = {m})",
               alternative="group_sd on the m + 1 sources with the tracks as source 0 "
                           "(the exact ML binding, without enumeration)")
    perms = np.array(list(itertools.permutations(range(n))), dtype=np.int64).reshape(-1, n)
    return np.array([np.stack(p) for p in itertools.product(perms, repeat=m)])
