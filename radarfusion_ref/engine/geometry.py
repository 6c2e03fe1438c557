r"""Two radars measuring range and azimuth: where they are, and how their errors are drawn.

Radar 1 sits at the origin of its Cartesian frame; radar 2 a base :math:`B` away
at azimuth :math:`\beta_0` (counter-clockwise from the x axis). Targets are
points of that frame; each radar sees a target at a range :math:`r` and an
azimuth :math:`\beta` (radians, counter-clockwise from its own x axis).

* :func:`radar2_position`, :func:`polar_from` and :class:`Geometry` — the scene;
* :data:`SIGMA_BETA_MAX` — the package's one limit on an angle's standard
  deviation, checked in one place for every public function that takes one;
* :data:`BLOCK_TRIALS`, :data:`MAX_TRIALS` — how the polar reports of
  :func:`radarfusion_ref.engine.scenes.polar_scene` and
  :func:`radarfusion_ref.separated.association_experiment` are drawn: per block
  of trials, each block from its own spawned seed sequence, so a seed gives the
  same reports whatever the chunking.

Units: kilometres and radians in the book, any consistent length unit here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .validation import as_float, as_float_array, as_positive, broadcast, describe

__all__ = [
    "SIGMA_BETA_MAX",
    "BLOCK_TRIALS",
    "MAX_TRIALS",
    "Geometry",
    "radar2_position",
    "polar_from",
    "as_geometry",
    "as_polar_sigmas",
    "as_sigma_beta",
    "normal_chunks",
]

#: Largest angle standard deviation accepted (azimuth or elevation), in radians (≈ 28.6°):
#: the package's one limit on :math:`\sigma_\beta`.
#: Why 0.5 and not π/4: at :math:`\sigma_\beta = 0.5` an azimuth error beyond ±90° (a report
#: folded behind the radar's cross-range line, which no 2×2 covariance can describe) has
#: probability :math:`2\Phi(-\pi/(2\sigma_\beta)) \approx 1.7\times 10^{-3}`; at π/4 it is
#: 4.6 %, one report in 22. The first-order correction's dropped term
#: :math:`\sigma_\beta^4/8` is 0.8 % of the range at 0.5 and 4.7 % at π/4. And the smaller
#: limit also catches azimuth deviations from 0.5 to 0.79 passed in degrees by mistake.
SIGMA_BETA_MAX = 0.5

#: Trials per random block. Trial ``t`` takes its draws from block
#: ``t // BLOCK_TRIALS``, whose generator is seeded by its own child of the
#: root :class:`numpy.random.SeedSequence` (spawn key ``(k,)``), so a seed
#: gives the same draws whatever ``chunk_size`` (or batch split) is used.
BLOCK_TRIALS = 1 << 16

#: Largest number of Monte-Carlo trials one call accepts (about two minutes
#: of the separated-radar experiment on one core); run several seeded calls and
#: add the counts for more.
MAX_TRIALS = 10**8


# --------------------------------------------------------------------------- validation
def as_sigma_beta(sigma_beta, name: str = "sigma_beta", *, strict: bool = False) -> np.ndarray:
    r"""The door of an angle standard deviation: in [0, SIGMA_BETA_MAX] (``strict``: > 0).

    The package's one check of :math:`\sigma_\beta` (and of an elevation's), shared by
    the conversion, registration and separated-radar chapters; `name` is the caller's
    public name for it. A value above :data:`SIGMA_BETA_MAX` is most likely in degrees,
    and the message says so.

    Examples
    --------
    >>> as_sigma_beta(5.0)
    Traceback (most recent call last):
    ...
    ValueError: `sigma_beta` must be an angle standard deviation in radians in [0, 0.5] (SIGMA_BETA_MAX); received largest entry 5 — did you pass degrees? Use np.deg2rad.
    """
    s = as_positive(sigma_beta, name, strict=strict)
    if np.any(s > SIGMA_BETA_MAX):
        raise ValueError(
            f"`{name}` must be an angle standard deviation in radians in "
            f"{'(' if strict else '['}0, {SIGMA_BETA_MAX}] (SIGMA_BETA_MAX); received largest "
            f"entry {float(np.max(s)):.6g} — did you pass degrees? Use np.deg2rad.")
    return s


# --------------------------------------------------------------------------- geometry
def radar2_position(base, base_azimuth):
    r"""Position of radar 2 in radar 1's Cartesian frame.

    Parameters
    ----------
    base : float or array_like
        Base length :math:`B > 0` (km).
    base_azimuth : float or array_like
        Azimuth :math:`\beta_0` of the base seen from radar 1 (rad, counted
        from the x axis counter-clockwise, as in the paper).

    Returns
    -------
    numpy.ndarray, shape (..., 2)
        :math:`B(\cos\beta_0, \sin\beta_0)`.

    Raises
    ------
    ValueError
        If `base` is not positive or the arguments do not broadcast.

    References
    ----------
    Prosov, Fig. 1 and the scenario text before Table 1.

    Examples
    --------
    >>> radar2_position(30.0, 0.0)
    array([30.,  0.])
    """
    b = as_positive(base, "base")
    a = as_float_array(base_azimuth, "base_azimuth")
    b, a = broadcast(base=b, base_azimuth=a)
    return np.stack([b * np.cos(a), b * np.sin(a)], axis=-1)   # |B cos| <= B: no overflow


def polar_from(xy, origin=(0.0, 0.0)):
    r"""True range and azimuth of points seen from a radar at `origin`.

    Parameters
    ----------
    xy : array_like, shape (..., 2)
        Points in radar 1's frame (km).
    origin : array_like, shape (..., 2), optional
        The radar's position in the same frame.

    Returns
    -------
    r, beta : numpy.ndarray, shape (...)
        Range (km) and azimuth (rad, in :math:`(-\pi, \pi]`).

    Raises
    ------
    ValueError
        If a point coincides with the radar (range 0), shapes are wrong, or the
        coordinates are not finite (or so large that their difference overflows).

    Examples
    --------
    >>> r, b = polar_from([[3.0, 4.0]], origin=[0.0, 0.0])
    >>> float(r[0]), round(float(b[0]), 4)
    (5.0, 0.9273)
    """
    p = as_float_array(xy, "xy", ndim_min=1, last_dims=(2,))
    o = as_float_array(origin, "origin", ndim_min=1, last_dims=(2,))
    p, o = broadcast(xy=p, origin=o)
    with np.errstate(over="ignore", invalid="ignore"):
        d = p - o
    if not np.all(np.isfinite(d)):
        raise ValueError("`xy` - `origin` overflows (a coordinate difference beyond "
                         f"{np.finfo(float).max:.3g} km); received {describe(p)} and "
                         f"{describe(o)}")
    r = np.hypot(d[..., 0], d[..., 1])
    if np.any(r <= 0):
        raise ValueError("`xy` must not coincide with the radar at `origin` (range 0); "
                         f"received {int(np.count_nonzero(r <= 0))} such point(s)")
    return r, np.arctan2(d[..., 1], d[..., 0])


@dataclass(frozen=True)
class Geometry:
    r"""Two radars and the targets they observe, in radar 1's frame.

    Attributes
    ----------
    base : float
        Base length :math:`B` (km).
    base_azimuth : float
        Azimuth :math:`\beta_0` of the base from radar 1 (rad).
    targets : numpy.ndarray, shape (n, 2)
        True target positions in radar 1's frame (km); radar 1 is at the origin.
        Every target lies off both radar sites (a target at a site, range 0, has
        no azimuth) at a range that does not overflow; otherwise the constructor
        refuses it naming `targets`.
    """

    base: float
    base_azimuth: float
    targets: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "base", as_float(as_positive(self.base, "base"), "base"))
        object.__setattr__(self, "base_azimuth", as_float(self.base_azimuth, "base_azimuth"))
        t = as_float_array(self.targets, "targets", ndim_min=2, last_dims=(None, 2))
        if t.ndim != 2 or t.shape[0] < 1:
            raise ValueError(f"`targets` must have shape (n, 2) with n >= 1; received shape "
                             f"{t.shape}")
        site2 = radar2_position(self.base, self.base_azimuth)
        for k, site in ((1, np.zeros(2)), (2, site2)):
            with np.errstate(over="ignore", invalid="ignore"):
                r = np.hypot(*(t - site).T)
            if not np.all(np.isfinite(r)) or np.any(r <= 0):
                raise ValueError(
                    f"`targets` must lie off radar {k}'s site {site.tolist()} at a finite "
                    f"range (a target at a site has no azimuth); received {describe(t)} "
                    f"(ranges from {float(np.min(r)):.6g} to {float(np.max(r)):.6g} km)")
        object.__setattr__(self, "targets", t)

    @property
    def radar2(self) -> np.ndarray:
        """Radar 2's position, shape (2,)."""
        return radar2_position(self.base, self.base_azimuth)

    @property
    def polar1(self) -> tuple[np.ndarray, np.ndarray]:
        """True (range, azimuth) of every target seen from radar 1, each shape (n,)."""
        return polar_from(self.targets, (0.0, 0.0))

    @property
    def polar2(self) -> tuple[np.ndarray, np.ndarray]:
        """True (range, azimuth) of every target seen from radar 2, each shape (n,)."""
        return polar_from(self.targets, self.radar2)


def as_geometry(geometry) -> Geometry:
    """The door of a two-radar geometry: a :class:`Geometry`, refused by name otherwise."""
    if not isinstance(geometry, Geometry):
        raise TypeError("`geometry` must be a Geometry (see "
                        "radarfusion_ref.separated.paper_geometry); received "
                        f"{type(geometry).__name__}")
    return geometry


def as_polar_sigmas(sigma_r, sigma_beta, geometry) -> tuple[float, float]:
    """The door of one radar noise for a geometry: one `sigma_r` and one `sigma_beta`.

    `sigma_r` positive and below a tenth of the shortest target range of `geometry`
    (so that measured ranges stay positive), `sigma_beta` by :func:`as_sigma_beta`
    (strictly positive); returned as floats.
    """
    geometry = as_geometry(geometry)
    sr = as_float(as_positive(sigma_r, "sigma_r"), "sigma_r")
    sb = as_float(as_sigma_beta(sigma_beta, strict=True), "sigma_beta")
    rmin = min(geometry.polar1[0].min(), geometry.polar2[0].min())
    if rmin < 10 * sr:
        raise ValueError(f"`sigma_r` must be below a tenth of the shortest target range "
                         f"({rmin:.6g} km) so that measured ranges stay positive; received "
                         f"{float(sr):.6g}")
    return sr, sb


# --------------------------------------------------------------------------- block draws
def _normal_blocks(root: np.random.SeedSequence, n: int, trials: int):
    """Standard normals of shape (4, n, L) per block of :data:`BLOCK_TRIALS` trials."""
    for k, start in enumerate(range(0, trials, BLOCK_TRIALS)):
        child = np.random.SeedSequence(root.entropy, spawn_key=(*root.spawn_key, k),
                                       pool_size=root.pool_size)
        yield np.random.default_rng(child).standard_normal(
            (4, n, min(BLOCK_TRIALS, trials - start)))


def normal_chunks(root: np.random.SeedSequence, n: int, trials: int, chunk: int):
    """Kernel (trusted input): the polar scene's standard normals, in pieces of `chunk` trials.

    The draws of the scene simulator (shape ``(4, n, L)`` per block of
    :data:`BLOCK_TRIALS` trials, one seed per block spawned from `root`), regrouped so
    that an experiment streaming them in chunks sees the same numbers as the scene.
    """
    buf, have = [], 0
    for block in _normal_blocks(root, n, trials):
        while block.shape[-1]:
            take = min(chunk - have, block.shape[-1])
            buf.append(block[..., :take])
            have += take
            block = block[..., take:]
            if have == chunk:
                yield buf[0] if len(buf) == 1 else np.concatenate(buf, axis=-1)
                buf, have = [], 0
    if buf:
        yield buf[0] if len(buf) == 1 else np.concatenate(buf, axis=-1)
