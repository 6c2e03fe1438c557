"""Associating the reports of two spatially separated radars (Prosov).

Two radars a base :math:`B` apart (radar 2 at azimuth :math:`\\beta_0` of the
base, seen from radar 1) measure range and azimuth of the same targets. Each
report is converted to Cartesian coordinates in its own radar's frame
(:func:`radarfusion_ref.conversion.polar_to_cartesian`, linearized or
bias-corrected), radar 2's reports are shifted into radar 1's frame, and every
pair (report :math:`q` of radar :math:`p`, report :math:`f` of radar :math:`g`)
is scored by the proximity measure (the book's notation; the paper's quadratic
form :math:`S^{qf}_{pg}` with :math:`\\hat\\alpha \\to \\hat x`, :math:`C \\to \\Sigma`)

.. math::

    \\kappa_{jk} = \\Delta_{jk}^T S_{jk}^{-1} \\Delta_{jk}, \\quad
    \\Delta_{jk} = \\hat x_{1j} - \\hat x_{2k}, \\quad S_{jk} = \\Sigma_{1j} + \\Sigma_{2k},

which is :math:`\\chi^2(2)` when the two reports belong to one target (and the
conversion is unbiased with a correct covariance), and noncentral
:math:`\\chi'^2(2, \\lambda)` otherwise. A pair passes the gate when
:math:`\\kappa` is below the gate :math:`\\gamma`, the :math:`\\chi^2(2)` quantile at the false-rejection
probability :math:`P_{\\text{lo}} = 0.01`.

Decision outcomes (Table 1 of the paper), for the report of target :math:`i`
by radar 1 compared with every report of radar 2:

* **correct** — exactly one radar-2 report passes the gate, and it is target
  :math:`i`'s;
* **wrong association** — exactly one passes, and it is another target's;
* **no decision** — none passes, or more than one does (for two targets: the
  true and the false pair both pass, or both fail).

.. rubric:: Public functions

* :func:`radar2_position`, :func:`paper_geometry`, :func:`polar_from` — the
  geometry;
* :func:`simulate_polar` — noisy polar reports of both radars, vectorized over
  trials (:func:`radarfusion_ref.engine.scenes.simulate_polar`, under its name here);
* :func:`to_common_frame` — conversion to Cartesian in radar 1's frame;
* :func:`pair_statistic` — :math:`\\kappa` for every pair, by a hand-written batched
  2×2 Cholesky factorisation (and :math:`\\ln\\det`);
* :func:`per_report_outcome`, :func:`joint_outcome` — the decision rules;
* :func:`association_experiment` — the Table 1 Monte-Carlo experiment,
  chunked, with common random numbers across methods;
* :func:`false_pair_noncentrality`, :func:`approximate_outcomes`,
  :func:`fit_target2_offset` — the linear-Gaussian approximation and the
  placement of target 2 fitted to the paper's linearized row.

Units: kilometres and radians throughout.

.. rubric:: References

.. [1] A. V. Prosov, "Analysis of the effect of linearization errors of radar
   measurements on the reliability of associating data from spatially
   separated radars" — Fig. 1, eqs. (1)–(4), the quadratic form :math:`\\kappa`,
   Table 1.
.. [2] D. Lerro, Y. Bar-Shalom, "Tracking with debiased consistent converted
   measurements versus EKF", IEEE Trans. AES 29 (1993) 1015–1022.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from . import conversion, gating
from .engine._validation import (
    MEMORY_LIMIT,
    _describe,
    as_bool,
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
    as_rng,
    broadcast,
    check_size,
)
from .engine.montecarlo import Proportion, proportion
from .engine.scenes import PolarReports, simulate_polar  # the simulator's home is scenes

__all__ = [
    "CORRECT",
    "WRONG",
    "NO_DECISION",
    "OUTCOMES",
    "PAPER",
    "BLOCK_TRIALS",
    "MAX_TRIALS",
    "MAX_JOINT_PAIRINGS",
    "MAX_GRID_POINTS",
    "PAPER_TABLE1",
    "Geometry",
    "PolarReports",
    "CartesianReports",
    "MethodResult",
    "ExperimentResult",
    "radar2_position",
    "polar_from",
    "paper_geometry",
    "simulate_polar",
    "to_common_frame",
    "pair_statistic",
    "per_report_outcome",
    "joint_outcome",
    "association_experiment",
    "false_pair_noncentrality",
    "approximate_outcomes",
    "collect",
    "OffsetSweep",
    "offset_sweep",
    "fit_target2_offset",
]

#: Outcome codes returned by :func:`per_report_outcome` and :func:`joint_outcome`.
CORRECT, WRONG, NO_DECISION = 0, 1, 2
#: Outcome names, indexed by code (the columns of Table 1).
OUTCOMES = ("correct", "wrong", "no decision")

#: The paper's scenario (km, rad): sigma_r, sigma_beta, target 1's range and
#: azimuth from radar 1, the base and its azimuth, the false-rejection probability.
PAPER = {
    "sigma_r": 0.1,
    "sigma_beta": float(np.deg2rad(1.0)),
    "range1": 150.0,
    "azimuth1": float(np.deg2rad(45.0)),
    "base": 30.0,
    "base_azimuth": 0.0,
    "p_false_reject": 0.01,
}

#: Table 1 as printed: ``PAPER_TABLE1[method][target]`` = (P_correct, P_wrong,
#: P_no-decision), targets 1 and 2 in rows.
PAPER_TABLE1 = {
    "linearized": np.array([[0.674, 0.010, 0.316], [0.342, 0.008, 0.650]]),
    "bias-corrected": np.array([[0.631, 0.009, 0.360], [0.649, 0.004, 0.347]]),
}

_METHODS = conversion.METHODS

#: Trials per random block. Trial ``t`` takes its draws from block
#: ``t // BLOCK_TRIALS``, whose generator is seeded by its own child of the
#: root :class:`numpy.random.SeedSequence` (spawn key ``(k,)``), so a seed
#: gives the same draws whatever ``chunk_size`` (or batch split) is used.
BLOCK_TRIALS = 1 << 16

#: Largest number of Monte-Carlo trials one call accepts (about two minutes
#: of the experiment on one core); run several seeded calls and add the counts
#: for more.
MAX_TRIALS = 10**8

#: Largest number of complete pairings (:math:`n!`) the joint rules enumerate
#: (7! = 5040, i.e. at most 7 targets).
MAX_JOINT_PAIRINGS = 5040

#: Largest number of placements one :func:`offset_sweep` accepts.
MAX_GRID_POINTS = 10_000

_JOINT_ALTERNATIVE = ("radarfusion_ref.association.associate_joint (linear assignment, "
                      "polynomial in the number of targets)")


def _root_seed(rng) -> np.random.SeedSequence:
    """The root SeedSequence of a call: from a seed, a SeedSequence or a Generator.

    A Generator contributes 128 bits drawn from it, so consecutive calls with
    one Generator get independent draws, and a seeded Generator is reproducible.
    """
    if isinstance(rng, np.random.SeedSequence):
        return rng
    if isinstance(rng, np.random.Generator):
        return np.random.SeedSequence(rng.integers(0, 2**32, size=4, dtype=np.uint64).tolist())
    if rng is None:
        return np.random.SeedSequence()
    gen = as_rng(rng)                       # validates (and refuses a RandomState)
    if isinstance(rng, (int, np.integer)) and not isinstance(rng, bool):
        return np.random.SeedSequence(int(rng))
    return np.random.SeedSequence(gen.integers(0, 2**32, size=4, dtype=np.uint64).tolist())


def _normal_blocks(root: np.random.SeedSequence, n: int, trials: int):
    """Standard normals of shape (4, n, L) per block of :data:`BLOCK_TRIALS` trials."""
    for k, start in enumerate(range(0, trials, BLOCK_TRIALS)):
        child = np.random.SeedSequence(root.entropy, spawn_key=(*root.spawn_key, k),
                                       pool_size=root.pool_size)
        yield np.random.default_rng(child).standard_normal(
            (4, n, min(BLOCK_TRIALS, trials - start)))


def _normal_chunks(root: np.random.SeedSequence, n: int, trials: int, chunk: int):
    """The draws of :func:`_normal_blocks`, regrouped into pieces of `chunk` trials."""
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


def _scalar(value, name: str, *, positive: bool = False) -> float:
    """One finite real number (a 0-d array or Python/numpy scalar)."""
    arr = as_positive(value, name) if positive else as_float_array(value, name)
    if arr.ndim:
        raise ValueError(f"`{name}` must be a single number; received {_describe(value)}")
    return float(arr)


def _joint_bytes(n: int, batch: int) -> int:
    """Working memory (bytes) of the joint rule over `batch` statistic matrices."""
    return 8 * batch * math.factorial(n) * (n + 3)


# --------------------------------------------------------------------------- geometry
def radar2_position(base, base_azimuth):
    """Position of radar 2 in radar 1's Cartesian frame.

    Parameters
    ----------
    base : float or array_like
        Base length :math:`B > 0` (km).
    base_azimuth : float or array_like
        Azimuth :math:`\\beta_0` of the base seen from radar 1 (rad, counted
        from the x axis counter-clockwise, as in the paper).

    Returns
    -------
    numpy.ndarray, shape (..., 2)
        :math:`B(\\cos\\beta_0, \\sin\\beta_0)`.

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
    """True range and azimuth of points seen from a radar at `origin`.

    Parameters
    ----------
    xy : array_like, shape (..., 2)
        Points in radar 1's frame (km).
    origin : array_like, shape (..., 2), optional
        The radar's position in the same frame.

    Returns
    -------
    r, beta : numpy.ndarray, shape (...)
        Range (km) and azimuth (rad, in :math:`(-\\pi, \\pi]`).

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
                         f"{np.finfo(float).max:.3g} km); received {_describe(p)} and "
                         f"{_describe(o)}")
    r = np.hypot(d[..., 0], d[..., 1])
    if np.any(r <= 0):
        raise ValueError("`xy` must not coincide with the radar at `origin` (range 0); "
                         f"received {int(np.count_nonzero(r <= 0))} such point(s)")
    return r, np.arctan2(d[..., 1], d[..., 0])


@dataclass(frozen=True)
class Geometry:
    """Two radars and the targets they observe, in radar 1's frame.

    Attributes
    ----------
    base : float
        Base length :math:`B` (km).
    base_azimuth : float
        Azimuth :math:`\\beta_0` of the base from radar 1 (rad).
    targets : numpy.ndarray, shape (n, 2)
        True target positions in radar 1's frame (km); radar 1 is at the origin.
    """

    base: float
    base_azimuth: float
    targets: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "base", _scalar(self.base, "base", positive=True))
        object.__setattr__(self, "base_azimuth", _scalar(self.base_azimuth, "base_azimuth"))
        t = as_float_array(self.targets, "targets", ndim_min=2, last_dims=(None, 2))
        if t.ndim != 2 or t.shape[0] < 1:
            raise ValueError(f"`targets` must have shape (n, 2) with n >= 1; received shape "
                             f"{t.shape}")
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


def paper_geometry(offset_range=0.0, offset_cross=0.0, *, range1=PAPER["range1"],
                   azimuth1=PAPER["azimuth1"], base=PAPER["base"],
                   base_azimuth=PAPER["base_azimuth"]) -> Geometry:
    """The paper's scene: target 1 at (150 km, 45°), target 2 offset from it.

    The paper's Fig. 2 (where target 2 is) is missing from the source, so
    target 2 is placed at an offset from target 1 measured in radar 1's
    line-of-sight frame: `offset_range` along the line of sight (away from
    radar 1) and `offset_cross` across it (towards increasing azimuth).

    Parameters
    ----------
    offset_range, offset_cross : float
        Offset of target 2 from target 1 (km). Both zero gives a single target.
    range1, azimuth1 : float, optional
        Target 1's range (km) and azimuth (rad) from radar 1.
    base, base_azimuth : float, optional
        Base length (km) and azimuth (rad).

    Returns
    -------
    Geometry
        With one target if both offsets are zero, two otherwise.

    Raises
    ------
    ValueError
        If `range1` or `base` is not positive, an argument is not one finite
        number, or target 2 would sit on a radar.

    References
    ----------
    Prosov, the scenario text before Table 1 (Fig. 2 is missing).

    Examples
    --------
    >>> g = paper_geometry(0.0, -5.0)
    >>> g.targets.round(3)
    array([[106.066, 106.066],
           [109.602, 102.53 ]])
    >>> g.radar2
    array([30.,  0.])
    """
    r1 = _scalar(range1, "range1", positive=True)
    a1 = _scalar(azimuth1, "azimuth1")
    dr = _scalar(offset_range, "offset_range")
    dc = _scalar(offset_cross, "offset_cross")
    b = _scalar(base, "base", positive=True)
    b0 = _scalar(base_azimuth, "base_azimuth")
    u = np.array([np.cos(a1), np.sin(a1)])
    v = np.array([-u[1], u[0]])
    t1 = r1 * u
    with np.errstate(over="ignore", invalid="ignore"):
        t2 = t1 + dr * u + dc * v
    if not np.all(np.isfinite(t2)):
        raise ValueError("`offset_range`, `offset_cross` put target 2 beyond the float range; "
                         f"received {dr!r}, {dc!r}")
    targets = t1[None] if dr == 0.0 and dc == 0.0 else np.stack([t1, t2])
    geo = Geometry(b, b0, targets)
    geo.polar1  # noqa: B018  (raises if a target sits on a radar)
    geo.polar2  # noqa: B018
    return geo


# --------------------------------------------------------------------------- simulation
# PolarReports and simulate_polar live in radarfusion_ref.engine.scenes (imported above).
def _as_geometry(geometry) -> Geometry:
    if not isinstance(geometry, Geometry):
        raise TypeError("`geometry` must be a radarfusion_ref.separated.Geometry (see "
                        f"`paper_geometry`); received {type(geometry).__name__}")
    return geometry


def _as_sigmas(sigma_r, sigma_beta, geometry: Geometry) -> tuple[float, float]:
    sr = _scalar(sigma_r, "sigma_r", positive=True)
    sb = _scalar(sigma_beta, "sigma_beta", positive=True)
    limit = conversion.SIGMA_BETA_MAX        # the package's one limit (see conversion)
    if sb > limit:
        raise ValueError(f"`sigma_beta` must be an azimuth standard deviation in radians in "
                         f"(0, {limit:g}] (conversion.SIGMA_BETA_MAX); received {sb:.6g} — did "
                         f"you pass degrees? Use np.deg2rad.")
    rmin = min(geometry.polar1[0].min(), geometry.polar2[0].min())
    if rmin < 10 * sr:
        raise ValueError(f"`sigma_r` must be below a tenth of the shortest target range "
                         f"({rmin:.6g} km) so that measured ranges stay positive; received "
                         f"{float(sr):.6g}")
    return sr, sb


@dataclass(frozen=True)
class CartesianReports:
    """Both radars' reports converted to Cartesian and brought to radar 1's frame.

    Attributes
    ----------
    xy1, xy2 : numpy.ndarray, shape (trials, n, 2)
        Positions (km) of radar 1's and radar 2's reports in radar 1's frame.
    cov1, cov2 : numpy.ndarray, shape (trials, n, 2, 2)
        Their error covariances as the conversion reports them (the shift to
        radar 1's frame does not change them: survey errors are neglected).
    method : str
        Conversion used for the positions.
    cov_method : str
        Conversion used for the covariances.
    """

    xy1: np.ndarray
    cov1: np.ndarray
    xy2: np.ndarray
    cov2: np.ndarray
    method: str
    cov_method: str


def _method_pair(method, cov_method) -> tuple[str, str]:
    m = as_choice(method, "method", _METHODS)
    c = m if cov_method is None else as_choice(cov_method, "cov_method", _METHODS)
    return m, c


def _convert(r, beta, sigma_r, sigma_beta, method, cov_method):
    """Positions by `method`, covariances by `cov_method` (one conversion if equal)."""
    res = conversion.polar_to_cartesian(r, beta, sigma_r, sigma_beta, method=method)
    if cov_method == method:
        return res.xy, res.cov
    res_c = conversion.polar_to_cartesian(r, beta, sigma_r, sigma_beta, method=cov_method)
    return res.xy, res_c.cov


def to_common_frame(reports: PolarReports, *, method: str = "linearized",
                    cov_method: str | None = None) -> CartesianReports:
    """Convert both radars' polar reports and bring them to radar 1's frame.

    Parameters
    ----------
    reports : PolarReports
        From :func:`simulate_polar`.
    method : {"linearized", "additive", "multiplicative", "first_order"}, optional
        Conversion of :func:`radarfusion_ref.conversion.polar_to_cartesian`
        used for the positions.
    cov_method : same choices, optional
        Conversion whose covariance is used (default: `method`). Mixing the
        two separates the effect of position debiasing from that of the
        covariance change.

    Returns
    -------
    CartesianReports

    Raises
    ------
    ValueError
        If a method name is unknown.
    TypeError
        If `reports` is not a :class:`PolarReports`.

    Notes
    -----
    Radar 2's report, converted in its own frame, is shifted by radar 2's
    position :math:`p_2 = B(\\cos\\beta_0, \\sin\\beta_0)`:

    .. math::

        \\hat x_{2j} = p_2 + \\hat r_{2j}(\\cos\\hat\\beta_{2j}, \\sin\\hat\\beta_{2j})^T,

    with the covariance unchanged (the paper neglects survey errors).

    References
    ----------
    Prosov, eqs. (1)–(4) and the text before Table 1.

    Examples
    --------
    >>> rep = simulate_polar(paper_geometry(0.0, -5.0), sigma_r=0.1,
    ...                      sigma_beta=np.deg2rad(1.0), trials=2, rng=0)
    >>> cart = to_common_frame(rep)
    >>> cart.xy2.shape, cart.cov2.shape
    ((2, 2, 2), (2, 2, 2, 2))
    """
    if not isinstance(reports, PolarReports):
        raise TypeError("`reports` must be a PolarReports (from `simulate_polar`); "
                        f"received {type(reports).__name__}")
    m, c = _method_pair(method, cov_method)
    sr, sb = reports.sigma_r, reports.sigma_beta
    xy1, cov1 = _convert(reports.r1, reports.beta1, sr, sb, m, c)
    xy2, cov2 = _convert(reports.r2, reports.beta2, sr, sb, m, c)
    return CartesianReports(xy1, cov1, xy2 + reports.geometry.radar2, cov2, m, c)


# --------------------------------------------------------------------------- statistic
def _chol_quadratic(d0, d1, a, b, c):
    """S and ln det for 2x2 covariance [[a, b], [b, c]] by a hand Cholesky factor.

    All arguments are broadcastable arrays; raises if any matrix is not
    numerically positive definite.
    """
    # C = L L^T, L = [[l11, 0], [l21, l22]]
    if not (a > 0).all():
        raise ValueError("the summed covariance `cov1 + cov2` must be positive definite; "
                         f"{int(np.count_nonzero(~(a > 0)))} of {np.size(a)} matrices have a "
                         "non-positive first diagonal entry (Cholesky failed)")
    l11 = np.sqrt(a)
    l21 = b / l11
    l22sq = c - l21 * l21
    ok = l22sq > 1e-12 * c                         # fails for NaN, c <= 0 and near-singular C
    if not ok.all():
        bad = ~ok
        raise ValueError(f"the summed covariance `cov1 + cov2` must be positive definite; "
                         f"{int(np.count_nonzero(bad))} of {bad.size} matrices are singular "
                         "or nearly so (Cholesky failed)")
    z1 = d0 / l11                                  # z = L^{-1} d
    z2 = (d1 - l21 * z1) / np.sqrt(l22sq)
    return z1 * z1 + z2 * z2, np.log(a) + np.log(l22sq)   # S = |z|^2, ln det C = 2 ln(l11 l22)


def _as_cov_stack(cov: np.ndarray, name: str) -> np.ndarray:
    """Symmetric positive-definite 2x2 matrices, not singular to working precision."""
    c = as_covariance(cov, name, dim=2)
    # scaled to a largest variance of 1, so the test neither underflows nor overflows
    m = np.maximum(c[..., 0, 0], c[..., 1, 1])
    m = np.where(m > 0, m, 1.0)
    a, b, d = c[..., 0, 0] / m, c[..., 0, 1] / m, c[..., 1, 1] / m
    prod = a * d
    det = prod - b * b
    bad = ~(det > 1e-12 * prod)
    if np.any(bad):
        raise ValueError(f"`{name}` must be positive definite; {int(np.count_nonzero(bad))} of "
                         f"{bad.size} matrices are singular or nearly so (determinant below "
                         f"1e-12 of the product of the variances): {_describe(c)}")
    return c


def pair_statistic(xy1, cov1, xy2, cov2, *, return_logdet: bool = False,
                   logdet: bool = False):
    """The quadratic form :math:`\\kappa` for every pair of radar-1 and radar-2 reports.

    Parameters
    ----------
    xy1 : array_like, shape (..., n1, 2)
        Radar 1's report positions.
    cov1 : array_like, shape (..., n1, 2, 2)
        Their covariances.
    xy2 : array_like, shape (..., n2, 2)
        Radar 2's report positions in the same frame.
    cov2 : array_like, shape (..., n2, 2, 2)
        Their covariances.
    return_logdet : bool, optional
        Also return :math:`\\ln\\det(\\Sigma_{1i} + \\Sigma_{2j})`, needed by the
        likelihood of a joint hypothesis.
    logdet : bool, optional
        False (default): the quadratic form :math:`\\kappa_{ij}` (the gate's
        statistic). True: the full maximum-likelihood cost
        :math:`\\kappa_{ij} + \\ln\\det(2\\pi S_{ij})`, :math:`S_{ij} = \\Sigma_{1i} +
        \\Sigma_{2j}` — the same cost as
        ``radarfusion_ref.association.proximity_matrix(..., logdet=True)``, for an
        assignment solver; not a :math:`\\chi^2` statistic (it may be negative), so
        not for :func:`per_report_outcome`.

    Returns
    -------
    S : numpy.ndarray, shape (..., n1, n2)
        ``S[..., i, j]`` scores report ``i`` of radar 1 against report ``j``
        of radar 2 (with ``logdet=True`` the full cost). With
        ``return_logdet=True`` a tuple ``(S, logdet)``, `logdet` being
        :math:`\\ln\\det(\\Sigma_{1i} + \\Sigma_{2j})` (without :math:`2\\pi`).

    Raises
    ------
    ValueError
        If shapes do not match, entries are not finite, a covariance is not
        symmetric or not positive definite (:func:`radarfusion_ref.engine._validation.as_covariance`),
        the sums are too many for :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT`,
        or a summed covariance is numerically singular.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    .. math::

        \\kappa_{ij} = (\\hat x_{1i} - \\hat x_{2j})^T (\\Sigma_{1i} + \\Sigma_{2j})^{-1}
        (\\hat x_{1i} - \\hat x_{2j}) = z_1^2 + z_2^2,

    with :math:`\\Sigma_{1i} + \\Sigma_{2j} = L L^T` factored by hand
    (:math:`l_{11} = \\sqrt{c_{11}}`, :math:`l_{21} = c_{12}/l_{11}`,
    :math:`l_{22} = \\sqrt{c_{22} - l_{21}^2}`) and
    :math:`z = L^{-1}(\\hat x_{1i} - \\hat x_{2j})` by forward
    substitution — batched over every leading axis, no inverse.

    References
    ----------
    Prosov, the quadratic form :math:`S^{qf}_{pg}` after eq. (4).

    Examples
    --------
    >>> eye = np.eye(2)[None]
    >>> pair_statistic([[0.0, 0.0]], eye, [[2.0, 0.0]], eye)
    array([[2.]])
    >>> pair_statistic([[0.0, 0.0]], eye, [[2.0, 0.0]], eye, logdet=True).round(4)
    array([[7.062]])
    """
    with_logdet = as_bool(logdet, "logdet")
    a1 = as_float_array(xy1, "xy1", ndim_min=2, last_dims=(None, 2))
    a2 = as_float_array(xy2, "xy2", ndim_min=2, last_dims=(None, 2))
    c1 = as_float_array(cov1, "cov1", ndim_min=3, last_dims=(None, 2, 2))
    c2 = as_float_array(cov2, "cov2", ndim_min=3, last_dims=(None, 2, 2))
    c1 = _as_cov_stack(c1, "cov1")
    c2 = _as_cov_stack(c2, "cov2")
    if c1.shape[-3] != a1.shape[-2] or c2.shape[-3] != a2.shape[-2]:
        raise ValueError("`cov1`/`cov2` must have one 2x2 matrix per report of `xy1`/`xy2`; "
                         f"received shapes {c1.shape} for {a1.shape} and {c2.shape} for "
                         f"{a2.shape}")
    try:
        np.broadcast_shapes(a1.shape[:-2], c1.shape[:-3], a2.shape[:-2], c2.shape[:-3])
    except ValueError:
        raise ValueError("`xy1`, `cov1`, `xy2`, `cov2` must have broadcastable leading axes; "
                         f"received shapes {a1.shape}, {c1.shape}, {a2.shape}, "
                         f"{c2.shape}") from None
    lead = np.broadcast_shapes(a1.shape[:-2], c1.shape[:-3], a2.shape[:-2], c2.shape[:-3])
    n_pairs = math.prod(lead) * a1.shape[-2] * a2.shape[-2]
    check_size(8 * 12 * n_pairs, MEMORY_LIMIT,
               what="bytes of pair statistics for `xy1` x `xy2`",
               alternative="smaller batches of reports")
    # pairs: radar-1 report on axis -2, radar-2 report on axis -1. The chunked kernel
    # runs the operation sequence of _chol_quadratic (bit-for-bit the same numbers)
    # without per-pair temporaries; pairs it cannot form unscaled take a scaled route.
    try:
        s, logdet = gating.pairwise_mahalanobis_2d(a1, a2, c1, c2, return_logdet=True)
    except ValueError as exc:
        if "overflows" not in str(exc):
            raise
        raise ValueError("the statistic overflows the float range: `xy1` - `xy2` is too large "
                         "against the spread of `cov1` + `cov2`; rescale the coordinates"
                         ) from None
    cost = s + (2 * math.log(2 * math.pi) + logdet) if with_logdet else s
    return (cost, logdet) if return_logdet else cost


# --------------------------------------------------------------------------- decisions
def _as_statistic(statistic) -> np.ndarray:
    s = as_float_array(statistic, "statistic", ndim_min=2)
    if s.shape[-1] != s.shape[-2] or s.shape[-1] == 0:
        raise ValueError(f"`statistic` must have shape (..., n, n) with n >= 1; received shape "
                         f"{s.shape}")
    if np.any(s < 0):
        raise ValueError(f"`statistic` must be >= 0 (a quadratic form); received "
                         f"{_describe(s)} (smallest entry {s.min():.6g})")
    return s


def per_report_outcome(statistic, threshold) -> np.ndarray:
    """Per-report gating decision for each report of radar 1 (Table 1's rule).

    Report ``i`` of radar 1 is compared with every report of radar 2; the
    true partner is report ``i`` (reports are in target order).

    Parameters
    ----------
    statistic : array_like, shape (..., n, n)
        :math:`\\kappa` from :func:`pair_statistic`.
    threshold : float
        Gate :math:`\\gamma` (a pair passes when :math:`\\kappa < \\gamma`).

    Returns
    -------
    numpy.ndarray of int8, shape (..., n)
        :data:`CORRECT` (only the true partner passes), :data:`WRONG` (only
        one other report passes) or :data:`NO_DECISION` (none or several pass).

    Raises
    ------
    ValueError
        If `statistic` is not a stack of square matrices of finite entries
        >= 0, or `threshold` is not one positive number.

    References
    ----------
    Prosov, definitions of :math:`\\hat P_{\\text{прав}}`, :math:`\\hat P_{\\text{ош}}`,
    :math:`\\hat P_{\\text{неопр}}` before Table 1.

    Examples
    --------
    >>> per_report_outcome([[1.0, 20.0], [3.0, 5.0]], 9.21)
    array([0, 2], dtype=int8)
    """
    s = _as_statistic(statistic)
    th = _scalar(threshold, "threshold", positive=True)
    passed = s < th
    n_pass = passed.sum(axis=-1)
    true_pass = np.diagonal(passed, axis1=-2, axis2=-1)
    out = np.full(true_pass.shape, NO_DECISION, dtype=np.int8)
    single = n_pass == 1
    out[single & true_pass] = CORRECT
    out[single & ~true_pass] = WRONG
    return out


def joint_outcome(statistic, logdet=None, *, threshold=None) -> np.ndarray:
    """Joint (global) assignment of all reports at once: the best complete pairing.

    Parameters
    ----------
    statistic : array_like, shape (..., n, n)
        :math:`\\kappa` from :func:`pair_statistic` (``n`` ≤ 7: all :math:`n!`
        pairings are enumerated).
    logdet : array_like, shape (..., n, n), optional
        :math:`\\ln\\det(\\Sigma_{1i} + \\Sigma_{2j})`; with it the rule is maximum
        likelihood, without it minimum summed :math:`\\kappa`.
    threshold : float, optional
        Gate for the chosen pairing's summed :math:`\\kappa` (a :math:`\\chi^2(2n)`
        quantile). If given, a pairing whose sum reaches it gives
        :data:`NO_DECISION`.

    Returns
    -------
    numpy.ndarray of int8, shape (...)
        :data:`CORRECT` if the chosen pairing is the true one (identity),
        :data:`WRONG` otherwise, or :data:`NO_DECISION` (gated only).

    Raises
    ------
    ValueError
        If `statistic` is not square with finite entries >= 0, ``n!`` exceeds
        :data:`MAX_JOINT_PAIRINGS` (``n`` > 7: use
        :func:`radarfusion_ref.association.associate_joint`), the work exceeds
        :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT`, `logdet` has another
        shape or non-finite entries, or `threshold` is not positive.

    Notes
    -----
    For a pairing :math:`\\pi` the negative log-likelihood is

    .. math::

        -2\\ln L(\\pi) = \\sum_i \\bigl[\\kappa_{i\\pi(i)} + \\ln\\det(\\Sigma_{1i} + \\Sigma_{2\\pi(i)})\\bigr]
        + 2n\\ln 2\\pi,

    whose last term, the same for every complete pairing, is dropped (the
    package's rule: a constant of the full :math:`-2\\ln f` is dropped only
    where every hypothesis holds the same number of pairs; the per-pair cost
    ``pair_statistic(..., logdet=True)`` keeps its :math:`2\\ln 2\\pi`),

    and the rule picks :math:`\\hat\\pi = \\arg\\min_\\pi`. Under the true
    pairing the sum of the :math:`\\kappa` is :math:`\\chi^2(2n)`.

    Examples
    --------
    >>> joint_outcome([[1.0, 2.0], [3.0, 5.0]])       # 1+5 > 2+3: pairing swapped
    array(1, dtype=int8)
    """
    s = _as_statistic(statistic)
    n = s.shape[-1]
    check_size(math.factorial(n), MAX_JOINT_PAIRINGS,
               what=f"pairings n! (n = {n} reports in `statistic`)", alternative=_JOINT_ALTERNATIVE)
    check_size(_joint_bytes(n, s.size // (n * n)), MEMORY_LIMIT,
               what="bytes of pairing costs for `statistic`",
               alternative="smaller batches of `statistic`")
    th = None if threshold is None else _scalar(threshold, "threshold", positive=True)
    perms = np.array(list(itertools.permutations(range(n))))      # identity first
    rows = np.arange(n)
    sum_s = s[..., rows, perms].sum(axis=-1)                       # (..., n!)
    cost = sum_s
    if logdet is not None:
        ld = as_float_array(logdet, "logdet")
        if ld.shape != s.shape:
            raise ValueError(f"`logdet` must have the shape of `statistic` {s.shape}; "
                             f"received {ld.shape}")
        cost = sum_s + ld[..., rows, perms].sum(axis=-1)
    best = np.argmin(cost, axis=-1)
    out = np.where(best == 0, CORRECT, WRONG).astype(np.int8)
    if th is not None:
        best_s = np.take_along_axis(sum_s, best[..., None], axis=-1)[..., 0]
        out[best_s >= th] = NO_DECISION
    return out


# --------------------------------------------------------------------------- experiment
@dataclass(frozen=True)
class MethodResult:
    """Monte-Carlo outcome frequencies of one conversion method.

    Attributes
    ----------
    label : str
        ``method`` or ``"method/cov_method"`` when they differ.
    method, cov_method : str
        Conversions used for positions and covariances.
    per_report : Proportion
        Shape (n, 3): row ``i`` = target ``i``'s (correct, wrong, no decision)
        under per-report gating — Table 1's rows.
    joint : Proportion
        Shape (3,): the maximum-likelihood joint assignment with the
        :math:`\\chi^2(2n)` gate on the chosen pairing.
    joint_ungated : Proportion
        Shape (3,): the same without the gate (never "no decision").
    true_reject : Proportion
        Shape (n,): how often the true pair of target ``i`` fails the gate
        (nominally :math:`P_{\\text{lo}}`; tests the :math:`\\chi^2(2)` law).
    false_pass : Proportion
        Shape (n,): how often the false pair of radar-1 report ``i`` with
        radar-2 report ``i+1`` (cyclically) passes the gate.
    all_correct : Proportion
        Scalar: how often per-report gating decides *every* target correctly
        (comparable with ``joint``, which decides all targets at once).
    """

    label: str
    method: str
    cov_method: str
    per_report: Proportion
    joint: Proportion
    joint_ungated: Proportion
    true_reject: Proportion
    false_pass: Proportion
    all_correct: Proportion


@dataclass(frozen=True)
class ExperimentResult:
    """Result of :func:`association_experiment`.

    Attributes
    ----------
    results : dict of str to MethodResult
        One entry per method, keyed by its label.
    trials : int
        Number of Monte-Carlo trials (the same draws for every method).
    threshold : float
        The per-pair gate :math:`\\gamma` (:math:`\\chi^2(2)` quantile).
    joint_threshold : float
        The gate of the joint pairing (:math:`\\chi^2(2n)` quantile).
    geometry : Geometry
    sigma_r, sigma_beta, p_false_reject : float
    """

    results: dict
    trials: int
    threshold: float
    joint_threshold: float
    geometry: Geometry
    sigma_r: float
    sigma_beta: float
    p_false_reject: float

    def __getitem__(self, label: str) -> MethodResult:
        return self.results[label]


def _as_methods(methods) -> list[tuple[str, str]]:
    if isinstance(methods, str):
        methods = [methods]
    out = []
    try:
        items = list(methods)
    except TypeError:
        raise TypeError(f"`methods` must be a sequence of method names or (method, "
                        f"cov_method) pairs; received {methods!r}") from None
    if not items:
        raise ValueError("`methods` must name at least one method; received an empty sequence")
    for m in items:
        if isinstance(m, str):
            out.append(_method_pair(m, None))
        elif isinstance(m, tuple) and len(m) == 2:
            out.append(_method_pair(m[0], m[1]))
        else:
            raise ValueError(f"`methods` entries must be method names or (method, cov_method) "
                             f"pairs from {_METHODS}; received {m!r}")
    return out


def association_experiment(geometry: Geometry, *, sigma_r=PAPER["sigma_r"],
                           sigma_beta=PAPER["sigma_beta"],
                           methods=("linearized", "additive"), trials: int = 100_000,
                           p_false_reject=PAPER["p_false_reject"], rng=None,
                           chunk_size: int = 65_536) -> ExperimentResult:
    """Monte Carlo of the Table 1 experiment: per-report gating and joint assignment.

    Every trial draws one polar report per target and radar; each method
    converts the *same* draws (common random numbers, so differences between
    methods are paired and precise), computes :math:`\\kappa` for all pairs and
    scores the decisions. Trials are processed in chunks of `chunk_size`, all
    vectorized (no per-trial Python loop). The draws are made per block of
    :data:`BLOCK_TRIALS` trials from spawned seed sequences, so the result of a
    seed does not depend on `chunk_size`, and trial ``t`` sees the same
    reports as trial ``t`` of :func:`simulate_polar` with that seed.

    Parameters
    ----------
    geometry : Geometry
        Radars and targets (at least two, at most 7: the joint rule enumerates
        all :math:`n!` pairings, see :data:`MAX_JOINT_PAIRINGS`).
    sigma_r, sigma_beta : float, optional
        Measurement errors (km, rad); the paper's 0.1 km and 1° by default.
    methods : sequence, optional
        Conversion names, or ``(method, cov_method)`` pairs to use one
        method's positions with another's covariances.
    trials : int, optional
        Number of trials, at most :data:`MAX_TRIALS`.
    p_false_reject : float, optional
        :math:`P_{\\text{lo}}` of the per-pair :math:`\\chi^2(2)` gate and of
        the joint :math:`\\chi^2(2n)` gate.
    rng : None, int, numpy.random.SeedSequence or numpy.random.Generator, optional
        Source of randomness (SPEC 7); a Generator is advanced by one draw of
        the root seed.
    chunk_size : int, optional
        Trials per vectorized chunk (memory ~ 1.5 kB per trial for two
        targets); the working memory of one chunk must stay within
        :data:`radarfusion_ref.engine._validation.MEMORY_LIMIT`. It changes speed and
        memory only, never the result.

    Returns
    -------
    ExperimentResult

    Raises
    ------
    ValueError
        For fewer than two or more than seven targets, bad sigmas, unknown
        methods, or counts out of their limits.
    TypeError
        If `geometry` is not a :class:`Geometry`, or a count is not an integer.

    References
    ----------
    Prosov, Table 1 and the text before it.

    Examples
    --------
    >>> res = association_experiment(paper_geometry(0.0, -5.0), trials=2000, rng=3)
    >>> res["linearized"].per_report.estimate.shape
    (2, 3)
    """
    geo = _as_geometry(geometry)
    if geo.targets.shape[0] < 2:
        raise ValueError("`geometry` must hold at least two targets for association; "
                         f"received {geo.targets.shape[0]}")
    n = geo.targets.shape[0]
    check_size(math.factorial(n), MAX_JOINT_PAIRINGS,
               what=f"joint pairings n! (n = {n} targets in `geometry`)",
               alternative=_JOINT_ALTERNATIVE)
    sr, sb = _as_sigmas(sigma_r, sigma_beta, geo)
    meths = _as_methods(methods)
    n_trials = as_int(trials, "trials", minimum=1)
    check_size(n_trials, MAX_TRIALS, what="trials (`trials`)",
               alternative="several calls with spawned seeds, adding the counts")
    chunk = as_int(chunk_size, "chunk_size", minimum=1)
    per_trial = 8 * (40 * n + 16 * n * n + math.factorial(n) * (n + 4))
    check_size(per_trial * chunk, MEMORY_LIMIT,
               what=f"bytes of working memory for `chunk_size` = {chunk}",
               alternative=f"a `chunk_size` of at most {MEMORY_LIMIT // per_trial}")
    p_lo = _scalar(as_probability(p_false_reject, "p_false_reject"), "p_false_reject")
    root = _root_seed(rng)
    th = float(gating.gate_threshold(p_lo, 2))
    th_joint = float(gating.gate_threshold(p_lo, 2 * n))
    k = len(meths)
    per = np.zeros((k, n, 3), dtype=np.int64)
    joint = np.zeros((k, 3), dtype=np.int64)
    joint_ug = np.zeros((k, 3), dtype=np.int64)
    true_rej = np.zeros((k, n), dtype=np.int64)
    false_pass = np.zeros((k, n), dtype=np.int64)
    all_ok = np.zeros(k, dtype=np.int64)
    idx = np.arange(n)
    nxt = (idx + 1) % n
    perms = np.array(list(itertools.permutations(range(n))))
    p2 = geo.radar2
    (r1t, b1t), (r2t, b2t) = geo.polar1, geo.polar2
    r_true = np.stack([r1t, r2t])[:, :, None]                # (2, n, 1)
    b_true = np.stack([b1t, b2t])[:, :, None]
    for z in _normal_chunks(root, n, n_trials, chunk):     # (4, n, m), per-block seeds
        m = z.shape[-1]
        # both radars in one array, trial axis last: shape (2, n, m)
        r = r_true + sr * z[0::2]
        beta = b_true + sb * z[1::2]
        for q, (pm, cm) in enumerate(meths):
            xy, cov = _convert(r, beta, sr, sb, pm, cm)
            s, ld = _pair_kernel(xy, cov, p2)              # (n, n, m)
            passed = s < th
            true_pass = passed[idx, idx]                     # (n, m)
            single = passed.sum(axis=1) == 1
            ok_i = single & true_pass
            all_ok[q] += np.count_nonzero(ok_i.all(axis=0))
            c_ok = np.count_nonzero(ok_i, axis=1)
            c_wrong = np.count_nonzero(single & ~true_pass, axis=1)
            per[q] += np.stack([c_ok, c_wrong, m - c_ok - c_wrong], axis=-1)
            true_rej[q] += m - np.count_nonzero(true_pass, axis=1)
            false_pass[q] += np.count_nonzero(passed[idx, nxt], axis=1)
            sum_s = s[idx, perms].sum(axis=1)               # (n!, m), identity first
            best = np.argmin(sum_s + ld[idx, perms].sum(axis=1), axis=0)
            ok = best == 0
            n_ok = int(np.count_nonzero(ok))
            joint_ug[q] += (n_ok, m - n_ok, 0)
            gated = np.take_along_axis(sum_s, best[None], axis=0)[0] >= th_joint
            g_ok = int(np.count_nonzero(ok & ~gated))
            g_none = int(np.count_nonzero(gated))
            joint[q] += (g_ok, m - g_ok - g_none, g_none)
    results = {}
    for q, (pm, cm) in enumerate(meths):
        label = pm if pm == cm else f"{pm}/{cm}"
        # one interval computation for all counts of the method, then sliced
        parts = [per[q], joint[q], joint_ug[q], true_rej[q], false_pass[q], all_ok[q]]
        flat = proportion(np.concatenate([np.ravel(x) for x in parts]), n_trials)
        props, pos = [], 0
        for x in parts:
            size, shape = np.size(x), np.shape(x)
            sl = slice(pos, pos + size)
            pos += size

            def cut(v, sl=sl, shape=shape):
                out = np.asarray(v)[sl].reshape(shape)
                return out.item() if out.ndim == 0 else out

            props.append(Proportion(cut(flat.successes), n_trials, cut(flat.estimate),
                                    cut(flat.low), cut(flat.high), flat.confidence,
                                    flat.method))
        results[label] = MethodResult(label, pm, cm, *props)
    return ExperimentResult(results, n_trials, th, th_joint, geo, sr, sb, p_lo)


def _pair_kernel(xy, cov, radar2):
    """S and ln det for all pairs; inputs for both radars, trial axis last.

    ``xy`` has shape (2, n, m, 2) and ``cov`` (2, n, m, 2, 2) (radar, target,
    trial); radar 2's positions are shifted by `radar2`. Returns arrays of
    shape (n, n, m): radar-1 report, radar-2 report, trial. The pairs go through
    the shared per-report-covariance kernel
    :func:`radarfusion_ref.gating.pairwise_mahalanobis_2d` (the operation
    sequence of :func:`_chol_quadratic`, so the numbers are the same).
    """
    x1 = np.moveaxis(xy[0], 1, 0)                               # (m, n, 2)
    x2 = np.moveaxis(xy[1], 1, 0) + np.asarray(radar2, float)
    c1 = np.moveaxis(cov[0], 1, 0)                              # (m, n, 2, 2)
    c2 = np.moveaxis(cov[1], 1, 0)
    s, ld = gating.pairwise_mahalanobis_2d(x1, x2, c1, c2, return_logdet=True)
    return np.moveaxis(s, 0, -1), np.moveaxis(ld, 0, -1)       # (n, n, m)


# --------------------------------------------------------------------------- approximation
def false_pair_noncentrality(geometry: Geometry, *, sigma_r=PAPER["sigma_r"],
                             sigma_beta=PAPER["sigma_beta"], bias_method: str | None = None):
    """Noncentrality :math:`\\lambda_{ij}` of :math:`\\kappa` for every pair, linear-Gaussian model.

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
        :math:`\\lambda_{ij} = \\mu_{ij}^T (\\Sigma_{1i} + \\Sigma_{2j})^{-1} \\mu_{ij}` with
        :math:`\\mu_{ij} = E[\\hat x_{1i} - \\hat x_{2j}]` and the
        linearized covariances (2a–c) evaluated at the true coordinates. The
        diagonal is 0 without `bias_method`.

    Raises
    ------
    ValueError
        For bad sigmas or an unknown method.

    Notes
    -----
    If :math:`\\hat x_{1i} - \\hat x_{2j} \\sim \\mathcal N(\\mu, S_{ij})` then
    :math:`\\kappa \\sim \\chi'^2(2, \\lambda)`. The model ignores that the
    covariances used in :math:`\\kappa` are evaluated at the *measured* coordinates.

    Examples
    --------
    >>> lam = false_pair_noncentrality(paper_geometry(0.0, -5.0))
    >>> lam.shape, float(lam[0, 0])
    ((2, 2), 0.0)
    """
    geo = _as_geometry(geometry)
    sr, sb = _as_sigmas(sigma_r, sigma_beta, geo)
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
    """Per-report outcome probabilities for two targets, treating the two pairs as independent.

    Parameters
    ----------
    noncentrality : array_like, shape (..., 2, 2)
        :math:`\\lambda_{ij}` from :func:`false_pair_noncentrality` (the
        diagonal is the true pairs').
    p_false_reject : float, optional
        :math:`P_{\\text{lo}}`.

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
    With :math:`a_i = P\\{\\kappa_{ii} < \\gamma\\}` and :math:`b_i = P\\{\\kappa_{ij} < \\gamma\\}`
    (noncentral :math:`\\chi^2(2)` CDFs, :func:`radarfusion_ref.gating.p_false_accept`),

    .. math::

        P_{\\text{correct}} = a_i(1 - b_i), \\quad P_{\\text{wrong}} = (1 - a_i) b_i,
        \\quad P_{\\text{none}} = a_i b_i + (1 - a_i)(1 - b_i).

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
    p_lo = _scalar(as_probability(p_false_reject, "p_false_reject"), "p_false_reject")
    p = np.asarray(gating.p_false_accept(lam, 2, p_lo), dtype=float)
    a = np.diagonal(p, axis1=-2, axis2=-1)
    b = p[..., [0, 1], [1, 0]]
    return np.stack([a * (1 - b), (1 - a) * b, a * b + (1 - a) * (1 - b)], axis=-1)


def collect(experiments, label: str, field: str = "per_report") -> Proportion:
    """Stack one field of several experiments into one array-valued proportion.

    Parameters
    ----------
    experiments : sequence of ExperimentResult
        Results with the same number of trials (e.g. a parameter sweep).
    label : str
        Method label (a key of ``ExperimentResult.results``).
    field : {"per_report", "joint", "joint_ungated", "true_reject", "false_pass", "all_correct"}
        Which :class:`MethodResult` field to stack.

    Returns
    -------
    Proportion
        With a new leading axis of length ``len(experiments)``.

    Raises
    ------
    ValueError
        If `experiments` is empty, trial counts differ, or names are unknown.
    TypeError
        If an entry is not an :class:`ExperimentResult` or `label` is not a string.

    Examples
    --------
    >>> g = paper_geometry(0.0, -5.0)
    >>> runs = [association_experiment(g, trials=500, rng=s) for s in (1, 2)]
    >>> collect(runs, "linearized").estimate.shape
    (2, 2, 3)
    """
    try:
        runs = list(experiments)
    except TypeError:
        raise TypeError("`experiments` must be a sequence of ExperimentResult; received "
                        f"{_describe(experiments)}") from None
    if not runs:
        raise ValueError("`experiments` must hold at least one ExperimentResult; received none")
    for r in runs:
        if not isinstance(r, ExperimentResult):
            raise TypeError("`experiments` must hold ExperimentResult objects (from "
                            f"`association_experiment`); received a {type(r).__name__}")
    if not isinstance(label, str):
        raise TypeError(f"`label` must be a method label (str); received {_describe(label)}")
    missing = [k for k, r in enumerate(runs) if label not in r.results]
    as_choice(field, "field", ("per_report", "joint", "joint_ungated", "true_reject",
                               "false_pass", "all_correct"))
    if missing:
        raise ValueError(f"`label` must be one of {', '.join(map(repr, runs[0].results))} "
                         f"in every experiment; received {label!r}")
    trials = {r.trials for r in runs}
    if len(trials) != 1:
        raise ValueError(f"`experiments` must share one trial count; received {sorted(trials)}")
    counts = np.stack([np.asarray(getattr(r[label], field).successes) for r in runs])
    return proportion(counts, trials.pop())


@dataclass(frozen=True)
class OffsetSweep:
    """Table 1's experiment over a grid of target-2 placements.

    Attributes
    ----------
    offsets_range, offsets_cross : numpy.ndarray
        Grid axes (km): target 2's offset from target 1 along and across
        radar 1's line of sight (see :func:`paper_geometry`).
    per_report : dict of str to Proportion
        Per method label, estimates of shape ``(n_range, n_cross, 2, 3)``.
    joint : dict of str to Proportion
        Per method label, the gated joint assignment, shape ``(n_range, n_cross, 3)``.
    trials : int
        Trials per grid point (the same draws at every point: common random numbers).
    """

    offsets_range: np.ndarray
    offsets_cross: np.ndarray
    per_report: dict
    joint: dict
    trials: int


def offset_sweep(offsets_range, offsets_cross, *, methods=("linearized", "additive"),
                 trials: int = 10_000, sigma_r=PAPER["sigma_r"],
                 sigma_beta=PAPER["sigma_beta"], p_false_reject=PAPER["p_false_reject"],
                 rng=None) -> OffsetSweep:
    """Run :func:`association_experiment` on a grid of target-2 placements.

    Parameters
    ----------
    offsets_range, offsets_cross : array_like, 1-D
        Offsets (km) of target 2 from target 1 along and across radar 1's
        line of sight; the grid is their outer product. No point may have
        both offsets zero.
    methods, trials, sigma_r, sigma_beta, p_false_reject :
        As :func:`association_experiment`.
    rng : None, int or numpy.random.Generator, optional
        One seed is drawn from it and reused at every grid point (common
        random numbers), so the maps are smooth and differences between
        neighbouring points are not masked by independent noise.

    Returns
    -------
    OffsetSweep

    Raises
    ------
    ValueError
        If an axis is not 1-D and non-empty, a grid point has both offsets zero,
        the grid has more than :data:`MAX_GRID_POINTS` points or more than
        :data:`MAX_TRIALS` trials in all, or an argument of
        :func:`association_experiment` is bad.

    Examples
    --------
    >>> sw = offset_sweep([0.0, 1.0], [-5.0], trials=500, rng=1)
    >>> sw.per_report["linearized"].estimate.shape
    (2, 1, 2, 3)
    """
    ar = as_float_array(offsets_range, "offsets_range", ndim_min=1)
    ac = as_float_array(offsets_cross, "offsets_cross", ndim_min=1)
    for name, arr in (("offsets_range", ar), ("offsets_cross", ac)):
        if arr.ndim != 1 or arr.size == 0:
            raise ValueError(f"`{name}` must be a non-empty 1-D array; received shape {arr.shape}")
    check_size(ar.size * ac.size, MAX_GRID_POINTS,
               what="grid points (`offsets_range` x `offsets_cross`)",
               alternative="a coarse grid refined around its best point")
    n_trials = as_int(trials, "trials", minimum=1)
    check_size(ar.size * ac.size * n_trials, MAX_TRIALS,
               what="trials over the whole grid (`trials` per point)",
               alternative="fewer grid points or trials per point")
    if np.any(ar == 0) and np.any(ac == 0):
        raise ValueError("`offsets_range` and `offsets_cross` must not both contain 0: the "
                         "grid point (0, 0) puts target 2 on target 1")
    seed = int(as_rng(rng).integers(2**63))
    runs = [association_experiment(paper_geometry(a, c), sigma_r=sigma_r,
                                   sigma_beta=sigma_beta, methods=methods, trials=trials,
                                   p_false_reject=p_false_reject,
                                   rng=np.random.default_rng(seed))
            for a in ar for c in ac]
    shape = (ar.size, ac.size)

    def grid(label, field):
        p = collect(runs, label, field)
        counts = np.asarray(p.successes).reshape(shape + np.shape(p.successes)[1:])
        return proportion(counts, p.trials)

    labels = list(runs[0].results)
    return OffsetSweep(ar, ac, {k: grid(k, "per_report") for k in labels},
                       {k: grid(k, "joint") for k in labels}, runs[0].trials)


def fit_target2_offset(sweep: OffsetSweep, target=None, *, method: str = "linearized"):
    """The grid placement whose no-decision rates are closest to a target pair.

    Parameters
    ----------
    sweep : OffsetSweep
        From :func:`offset_sweep`.
    target : pair of float, optional
        :math:`P_{\\text{none}}` of targets 1 and 2; by default the paper's
        linearized row (0.316, 0.650), which stands in for the missing Fig. 2.
    method : str, optional
        Method label in the sweep whose rates are matched.

    Returns
    -------
    offset_range, offset_cross, misfit : float
        The best grid point (km) and its Euclidean distance to `target`.

    Raises
    ------
    ValueError
        If `target` is not two probabilities or `method` is not in the sweep.

    Examples
    --------
    >>> sw = offset_sweep([0.0, 1.0], [-6.0, -5.0], trials=500, rng=1)
    >>> a, c, miss = fit_target2_offset(sw)
    >>> bool(a in (0.0, 1.0) and c in (-6.0, -5.0) and miss >= 0)
    True
    """
    if not isinstance(sweep, OffsetSweep):
        raise TypeError(f"`sweep` must be an OffsetSweep; received {type(sweep).__name__}")
    tgt = as_probability(PAPER_TABLE1["linearized"][:, 2] if target is None else target,
                         "target")
    if tgt.shape != (2,):
        raise ValueError(f"`target` must hold two probabilities; received {tgt}")
    if not isinstance(method, str) or method not in sweep.per_report:
        raise ValueError(f"`method` must be one of {', '.join(map(repr, sweep.per_report))}; "
                         f"received {method!r}")
    none = np.asarray(sweep.per_report[method].estimate)[..., 2]
    miss = np.linalg.norm(none - tgt, axis=-1)
    i, j = np.unravel_index(np.argmin(miss), miss.shape)
    return float(sweep.offsets_range[i]), float(sweep.offsets_cross[j]), float(miss[i, j])
