"""Two separated radars measuring range and azimuth of targets at given places."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import (
    MAX_TRIALS,
    Geometry,
    _normal_blocks,
    as_geometry,
    as_polar_sigmas,
)
from ..validation import (
    MEMORY_LIMIT,
    as_int,
    as_seed_sequence,
    check_size,
)
from ._base import (
    Scene,
)


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
        fit in :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT` (about 5
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
    geo = as_geometry(geometry)
    sr, sb = as_polar_sigmas(sigma_r, sigma_beta, geo)
    n = as_int(trials, "trials", minimum=1)
    check_size(n, MAX_TRIALS, what="trials (`trials`)",
               alternative="several calls with spawned seeds")
    n_t = geo.targets.shape[0]
    check_size(8 * 8 * n_t * n, MEMORY_LIMIT, what="bytes of polar reports for `trials`",
               alternative="association_experiment (chunked) or several smaller calls")
    root = as_seed_sequence(rng)
    (r1, b1), (r2, b2) = geo.polar1, geo.polar2
    z = np.concatenate(list(_normal_blocks(root, n_t, n)), axis=-1)   # trial axis last
    r1 = r1[:, None] + sr * z[0]
    b1 = b1[:, None] + sb * z[1]
    r2 = r2[:, None] + sr * z[2]
    b2 = b2[:, None] + sb * z[3]
    return PolarReports(r1.T, b1.T, r2.T, b2.T, sr, sb, geo)
