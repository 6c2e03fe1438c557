r"""Radar detections over time, synchronous or realistic, and their conversion to the common frame.

:func:`simulate_detections` draws the reports of the radars over a window of the traffic in
one of two modes:

* ``"simple"`` — today's capstone simulation
  (:func:`radarfusion_ref.capstone.radars.simulate_reports` on
  :func:`radarfusion_ref.capstone.traffic.truth_scans`): the radars scan together and
  measure along the common frame's axes;
* ``"realistic"`` — each radar scans at its own period and phase and measures range,
  azimuth and elevation in its **own** east-north-up frame (WGS-84 geodetic → Earth-centred
  → the radar's frame), with range offset, range scale and azimuth offset; the truth is
  :func:`radarfusion_ref.capstone.traffic.truth_at` at each scan's instant.

:func:`to_common` converts any :class:`Detections` into the common frame (positions and
covariances), correcting a registration estimate if one is given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import conversion, registration
from ..engine.geodesy import enu_rotation
from ..engine.validation import (
    MEMORY_LIMIT,
    as_bool,
    as_choice,
    as_float,
    as_positive,
    as_rng,
    check_size,
    describe,
)
from .radars import (
    MIN_REGISTRATION_GROUPS,
    Radar,
    _draw_scans,
    _limit_false_reports,
    _polar,
    as_radars,
    simulate_reports,
)
from .traffic import ORIGIN, Traffic, truth_at, truth_scans

__all__ = [
    "MODES",
    "Detections",
    "local_rotation",
    "register_detections",
    "simulate_detections",
    "to_common",
]

#: Modes of :func:`simulate_detections`.
MODES = ("simple", "realistic")


@dataclass(frozen=True)
class Detections:
    """Reports of all radars over a window, one row per report, sorted by (time, radar).

    Attributes
    ----------
    time : numpy.ndarray, shape (N,)
        Instant of the report (s from the traffic start).
    radar : numpy.ndarray of int, shape (N,)
        Index into the radars.
    scan : numpy.ndarray of int, shape (N,)
        The radar's own scan number: the scan at ``phase + scan * period``; a scan is all
        the radar's reports at one instant (in simple mode the common scan index of the
        window).
    polar : numpy.ndarray, shape (N, 3)
        Measured range (m), azimuth (rad, counter-clockwise from east) and elevation (rad)
        in the frame named by `frame`.
    polar_cov : numpy.ndarray, shape (N, 3, 3)
        Covariance of the random errors of `polar` (diagonal).
    aircraft : numpy.ndarray of int, shape (N,)
        Truth: index into the traffic's aircraft, -1 for a false report.
    feature : numpy.ndarray, shape (N,)
        Measured speed feature (kt).
    frame : str
        ``"common"`` (simple mode: the radar's axes are the common frame's) or ``"local"``
        (realistic mode: the radar's own east-north-up frame).
    start, duration : float
        The simulated window (s).
    """

    time: np.ndarray
    radar: np.ndarray
    scan: np.ndarray
    polar: np.ndarray
    polar_cov: np.ndarray
    aircraft: np.ndarray
    feature: np.ndarray
    frame: str
    start: float
    duration: float

    def __len__(self) -> int:
        return int(self.time.size)

    def subset(self, rows) -> Detections:
        """The detections of the given rows (a boolean mask or sorted indices)."""
        return Detections(**{k: getattr(self, k)[rows] for k in
                             ("time", "radar", "scan", "polar", "polar_cov", "aircraft",
                              "feature")}, frame=self.frame, start=self.start,
                          duration=self.duration)


def local_rotation(radar) -> np.ndarray:
    r"""Rotation from the common east-north-up frame to a radar's own one.

    Parameters
    ----------
    radar : Radar

    Returns
    -------
    numpy.ndarray, shape (3, 3)
        :math:`A = R_i R_0^{\mathsf T}` with :math:`R` the rows of the east, north and up
        unit vectors in Earth-centred axes (:mod:`radarfusion_ref.engine.geodesy`) at the
        radar's site and at :data:`~radarfusion_ref.capstone.traffic.ORIGIN`: a common-frame
        offset :math:`d` from the site is :math:`A d` in the radar's frame.

    Examples
    --------
    >>> from radarfusion_ref.capstone import default_radars
    >>> A = local_rotation(default_radars()[0])
    >>> bool(np.allclose(A @ A.T, np.eye(3)))
    True
    """
    if not isinstance(radar, Radar):
        raise TypeError(f"`radar` must be a Radar (see realistic_radars()); received "
                        f"{describe(radar)}")
    return _rotation(as_radars((radar, radar))[0])


def _rotation(radar):
    return enu_rotation(radar.lat, radar.lon) @ enu_rotation(ORIGIN[0], ORIGIN[1]).T


#: Bytes of :func:`simulate_detections`' work arrays per scan and aircraft (the truth's
#: position, validity and speed at each instant, with their copies), counted against the
#: memory limit.
_SCAN_BYTES = 8 * 8


def _simulate_iv(traffic, radars, start, duration, mode):
    if not isinstance(traffic, Traffic):
        raise TypeError(f"`traffic` must be a Traffic (from load_traffic); received "
                        f"{describe(traffic)}")
    radars = as_radars(radars)
    start = as_float(as_positive(start, "start", strict=False), "start")
    duration = as_float(as_positive(duration, "duration"), "duration")
    mode = as_choice(mode, "mode", MODES)
    n_aircraft = int(traffic.aircraft.max()) + 1 if traffic.aircraft.size else 1
    for i, r in enumerate(radars):                   # before np.arange sizes the scans
        if not (start + duration) / r.period < 2.0**62:
            raise ValueError(f"`start`, `duration`, `radars[{i}].period`: the window's end "
                             f"{start + duration:.6g} s is beyond 2**62 scans of radar {i} "
                             f"(period {r.period:g} s), too many to number")
        n_scans = max(math.ceil(duration / r.period) + 1, 0)
        check_size(n_scans * n_aircraft * _SCAN_BYTES, MEMORY_LIMIT,
                   what=f"bytes of truth at the scans ({n_scans} scans of radar {i}, period "
                        f"{r.period:g} s, over `duration` = {duration:g} s, x {n_aircraft} "
                        "aircraft)",
                   alternative="a shorter `duration` (the window simulated in pieces)")
    if mode == "simple":
        per = {(r.period, r.phase) for r in radars}
        if len(per) > 1:
            raise ValueError("`radars`: the simple mode scans all radars together, so they "
                             "must share one `period` and `phase`; received "
                             f"{[(r.period, r.phase) for r in radars]} (use "
                             "mode='realistic', or default_radars())")
    return radars, start, duration, mode


def _diag_cov(sr, sb, se):
    cov = np.zeros((sr.size, 3, 3))
    cov[:, 0, 0], cov[:, 1, 1], cov[:, 2, 2] = sr**2, sb**2, se**2
    return cov


def _simple(traffic, radars, start, duration, rng):
    r0 = radars[0]
    truth = truth_scans(traffic, period=r0.period, start=start + r0.phase,
                        duration=duration - r0.phase)
    rep = simulate_reports(truth, radars, rng=rng)
    sig = np.array([[r.sigma_r, r.sigma_beta, r.sigma_epsilon] for r in radars])[rep.radar]
    return dict(time=truth.times[rep.scan], radar=rep.radar, scan=rep.scan,
                polar=np.stack([rep.r, rep.beta, rep.epsilon], axis=-1),
                polar_cov=_diag_cov(*sig.T), aircraft=rep.source, feature=rep.feature)


def _scan_times(radar, start, duration):
    k0 = math.ceil((start - radar.phase) / radar.period - 1e-9)
    k1 = math.ceil((start + duration - radar.phase) / radar.period - 1e-9)
    k = np.arange(max(k0, 0), max(k1, 0))
    return k, radar.phase + radar.period * k


def _speed_at(traffic, times, valid):
    """Ground speed (kt) of every aircraft at the times, interpolated over all its records."""
    out = np.zeros(valid.shape)
    bounds = np.flatnonzero(np.diff(traffic.aircraft)) + 1
    for a0, a1 in zip(np.concatenate([[0], bounds]), np.concatenate([bounds, [traffic.t.size]]),
                      strict=True):
        a = int(traffic.aircraft[a0])
        out[a] = np.interp(times, traffic.t[a0:a1], traffic.speed[a0:a1])
    return out


def _realistic(traffic, radars, start, duration, gen):
    scans = [_scan_times(r, start, duration) for r in radars]
    for i, rad in enumerate(radars):                 # refused before any draw
        _limit_false_reports(i, math.ceil(rad.clutter_rate * scans[i][0].size),
                             scans[i][0].size)
    cols = {k: [] for k in ("time", "radar", "scan", "polar", "sigma", "aircraft", "feature")}
    for i, rad in enumerate(radars):
        k, times = scans[i]
        S = k.size
        pos, valid = truth_at(traffic, times)
        speed = _speed_at(traffic, times, valid)
        a_idx, s_idx = np.nonzero(valid)
        local = (pos[a_idx, s_idx] - rad.enu) @ _rotation(rad).T
        d = _draw_scans(i, rad, *_polar(local), speed[a_idx, s_idx], S, rad.height, gen)
        n, nf = d.n_detected, d.r.size - d.n_detected
        cols["polar"].append(np.stack([d.r, d.beta, d.epsilon], axis=-1))
        cols["feature"].append(d.feature)
        sidx = np.concatenate([s_idx[d.detected], np.repeat(np.arange(S), d.n_false)])
        cols["time"].append(times[sidx])
        cols["scan"].append(k[sidx])
        cols["radar"].append(np.full(n + nf, i))
        cols["aircraft"].append(np.concatenate([a_idx[d.detected], np.full(nf, -1)]))
        cols["sigma"].append(np.tile([rad.sigma_r, rad.sigma_beta, rad.sigma_epsilon],
                                     (n + nf, 1)))
    out = {key: np.concatenate(v) for key, v in cols.items()}
    sig = out.pop("sigma")
    out["polar_cov"] = _diag_cov(*sig.T)
    out["aircraft"] = out["aircraft"].astype(np.int64)
    return out


def simulate_detections(traffic, radars, *, start=0.0, duration=3600.0, mode="realistic",
                        rng=None) -> Detections:
    r"""The radars' reports over a window of the traffic, synchronous or realistic.

    Parameters
    ----------
    traffic : Traffic
        From :func:`radarfusion_ref.capstone.traffic.load_traffic`.
    radars : sequence of Radar
        E.g. :func:`~radarfusion_ref.capstone.radars.realistic_radars` (realistic) or
        :func:`~radarfusion_ref.capstone.radars.default_radars` (simple).
    start, duration : float, optional
        The window ``[start, start + duration)`` (s from the traffic start; defaults 0 and
        3600, the whole hour).
    mode : {"realistic", "simple"}, optional
        ``"realistic"`` (default): each radar scans at its instants
        ``phase + k * period`` inside the window and measures in its own east-north-up
        frame; ``"simple"``: the capstone's synchronous common-frame simulation — the
        same draws, numbers and order as
        :func:`~radarfusion_ref.capstone.radars.simulate_reports` on
        ``truth_scans(traffic, period=period, start=start + phase, duration=duration -
        phase)`` for the same `rng` (the radars must share `period` and `phase`).
    rng : None, int or numpy.random.Generator, optional
        Randomness (SPEC 7).

    Returns
    -------
    Detections
        Rows sorted by (time, radar) (stable: in each radar's scan, detections first).

    Raises
    ------
    TypeError
        `traffic` not a Traffic, `radars` not radars, `rng` not a seed or generator.
    ValueError
        A radar's period not > 0, or its phase outside ``[0, period)`` (named
        ``radars[i].period`` / ``radars[i].phase``), other bad radar parameters, negative
        `start`, non-positive `duration`, unknown `mode`, radars of different timing in
        simple mode, clutter beyond the memory limit (named ``radars[i].clutter_rate``),
        scan instants beyond it (named `duration`) or a window whose end is beyond
        :math:`2^{62}` scans of a radar (named `start`, `duration`),
        or a window holding no aircraft.

    Notes
    -----
    Realistic mode. The truth of aircraft :math:`a` at radar :math:`i`'s scan instant is
    :func:`~radarfusion_ref.capstone.traffic.truth_at`; its offset from the site in the
    common frame, :math:`d`, is :math:`A_i d` in the radar's frame
    (:func:`local_rotation`). An aircraft within `max_range` and above `min_elevation`
    there is detected with probability :math:`P_D`; the report is
    :math:`((1+g) r + \Delta r + v_r,\ \beta + \Delta\beta + v_\beta,\ \varepsilon +
    v_\varepsilon)` with independent Gaussian noises, and the speed feature is the
    interpolated ground speed plus noise. False reports: Poisson(`clutter_rate`) per scan,
    uniform over the coverage disk and altitudes 8–15 km of the radar's frame, speed
    uniform on 300–600 kt.

    Examples
    --------
    >>> from radarfusion_ref.capstone import load_traffic, realistic_radars
    >>> det = simulate_detections(load_traffic(), realistic_radars(), duration=60.0, rng=1)
    >>> det.frame, bool(np.all(np.diff(det.time) >= 0))
    ('local', True)
    """
    radars, start, duration, mode = _simulate_iv(traffic, radars, start, duration, mode)
    gen = as_rng(rng)
    if mode == "simple":
        cols = _simple(traffic, radars, start, duration, gen)
    else:
        cols = _realistic(traffic, radars, start, duration, gen)
    order = np.lexsort((cols["radar"], cols["time"]))
    cols = {k: v[order] for k, v in cols.items()}
    return Detections(**cols, frame="common" if mode == "simple" else "local",
                      start=start, duration=duration)


def _to_common_iv(detections, radars, biases, debias):
    if not isinstance(detections, Detections):
        raise TypeError(f"`detections` must be a Detections (from simulate_detections); "
                        f"received {describe(detections)}")
    radars = as_radars(radars)
    m = len(radars)
    if detections.radar.size and int(detections.radar.max()) >= m:
        raise ValueError(f"`detections` name radar {int(detections.radar.max())} but "
                         f"`radars` holds {m}")
    if biases is not None:
        b = np.asarray(biases, dtype=float) if not isinstance(biases, str) else None
        if b is None or b.shape != (m, 3) or not np.all(np.isfinite(b)):
            raise ValueError(f"`biases` must be a finite ({m}, 3) array (range offset m, range "
                             f"scale, azimuth offset rad per radar); received "
                             f"{describe(biases)}")
        biases = b
    check_size(8 * 40 * len(detections), MEMORY_LIMIT,
               what=f"bytes of converted reports ({len(detections)} `detections`)",
               alternative="converting the detections in windows (Detections.subset)")
    return radars, biases, as_bool(debias, "debias")


def _convert(r, beta, eps, sigma, radar, radars, biases, debias, local):
    """Polar reports of radars `radar` to the common frame: (N, 3) and (N, 3, 3).

    The one home of the capstone's report conversion (the pipeline's stage 1 calls it):
    bias correction (:func:`radarfusion_ref.registration.remove_biases`), the 3-D
    conversion (:func:`radarfusion_ref.conversion.spherical_to_cartesian`), then the
    radar's frame rotated into the common one when `local`, and the site added.
    """
    if biases is not None:
        r, beta = registration.remove_biases(r, beta, biases[radar])
        r = np.abs(r)
    out = conversion.spherical_to_cartesian(
        r, beta, eps, sigma[:, 0], sigma[:, 1], sigma[:, 2],
        method="measurement_conditioned" if debias else "linearized")
    if not local:
        sites = np.stack([x.enu for x in radars])
        return out.xyz + sites[radar], out.cov
    xyz, cov = np.empty_like(out.xyz), np.empty_like(out.cov)
    for i, rad in enumerate(radars):
        rows = radar == i
        A = _rotation(rad)
        xyz[rows] = rad.enu + out.xyz[rows] @ A               # A^T l, row-wise
        cov[rows] = A.T @ out.cov[rows] @ A
    return xyz, cov


def to_common(detections, radars, biases=None, *, debias=True):
    r"""Reports in the common east-north-up frame (m), with their covariances.

    Parameters
    ----------
    detections : Detections
        From :func:`simulate_detections`.
    radars : sequence of Radar
        The radars that made them (sites, for the local frames).
    biases : array_like, shape (m, 3), optional
        A registration estimate :math:`(\Delta r, g, \Delta\beta)` per radar, removed from
        the measured range and azimuth first (:func:`radarfusion_ref.registration.
        remove_biases`); None (default) corrects nothing.
    debias : bool, optional
        Measurement-conditioned (debiased) 3-D conversion (default) or the linearized one,
        as :class:`~radarfusion_ref.capstone.pipeline.PipelineSettings`.

    Returns
    -------
    position : numpy.ndarray, shape (N, 3)
        Common-frame ENU about :data:`~radarfusion_ref.capstone.traffic.ORIGIN` (m).
    covariance : numpy.ndarray, shape (N, 3, 3)
        The converted covariance (from `polar_cov`), rotated into the common frame.

    Raises
    ------
    TypeError
        Wrong types of `detections` or `radars`.
    ValueError
        A radar index outside `radars`, `biases` of another shape or not finite, or a
        correction making a range non-positive.

    Notes
    -----
    In the radar's frame the report is converted as in the conversion chapter; in realistic
    mode the local position :math:`l` and covariance :math:`C` go to the common frame as
    :math:`s_i + A_i^{\mathsf T} l` and :math:`A_i^{\mathsf T} C A_i`
    (:func:`local_rotation`; :math:`s_i` the site).

    Examples
    --------
    >>> from radarfusion_ref.capstone import load_traffic, realistic_radars
    >>> radars = realistic_radars()
    >>> det = simulate_detections(load_traffic(), radars, duration=30.0, rng=2)
    >>> x, P = to_common(det, radars)
    >>> x.shape == (len(det), 3), P.shape == (len(det), 3, 3)
    (True, True)
    """
    radars, biases, debias = _to_common_iv(detections, radars, biases, debias)
    sigma = np.sqrt(np.diagonal(detections.polar_cov, axis1=1, axis2=2))
    pol = detections.polar
    return _convert(pol[:, 0], pol[:, 1], pol[:, 2], sigma, detections.radar, radars, biases,
                    debias, detections.frame == "local")


# ----------------------------------------------------------------------------- registration
def _common_polar(detections, radars):
    """Measured ground range, azimuth and cos(elevation) of every report, common frame.

    The measured direction is turned from the radar's frame into the common one (its known
    rotation); the range stays the measured one, so the biases stay the radar's own.
    """
    pol = detections.polar
    ce = np.cos(pol[:, 2])
    d = pol[:, :1] * np.stack([ce * np.cos(pol[:, 1]), ce * np.sin(pol[:, 1]),
                               np.sin(pol[:, 2])], axis=-1)
    if detections.frame == "local":
        for i, rad in enumerate(radars):
            rows = detections.radar == i
            d[rows] = d[rows] @ _rotation(rad)                      # A^T d, row-wise
    ground = np.hypot(d[:, 0], d[:, 1])
    return ground, np.arctan2(d[:, 1], d[:, 0]), ground / pol[:, 0]


#: Passes of :func:`register_detections` (each puts the previous range-offset estimate into
#: the ground ranges: the 2-D model's offset error shrinks by 1 - cos(elevation) per pass).
_REG_PASSES = 3


def _aligned(detections, radars, ground, azimuth, t_ref, a_ref):
    """Every radar's ground range and azimuth of aircraft `a_ref` at instants `t_ref`.

    Linear in time (in the plane about the site) between the radar's two reports of the
    aircraft that bracket the instant, at most 1.5 of its periods apart; NaN where there
    are none.
    """
    m = len(radars)
    out = np.full((m, t_ref.size, 2), np.nan)
    for j, rad in enumerate(radars):
        rows = np.flatnonzero((detections.radar == j) & (detections.aircraft >= 0))
        key = detections.aircraft[rows] * 1e7 + detections.time[rows]
        order = np.argsort(key, kind="stable")
        rows, key = rows[order], key[order]
        q = a_ref * 1e7 + t_ref
        hi = np.clip(np.searchsorted(key, q, side="left"), 1, max(rows.size - 1, 1))
        lo = hi - 1
        if rows.size < 2:
            continue
        rl, rh = rows[lo], rows[hi]
        tl, th = detections.time[rl], detections.time[rh]
        same = ((detections.aircraft[rl] == a_ref) & (detections.aircraft[rh] == a_ref)
                & (tl <= t_ref) & (t_ref <= th) & (th - tl <= 1.5 * rad.period))
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.where(th > tl, (t_ref - tl) / np.where(th > tl, th - tl, 1.0), 0.0)
        # straight-line motion is linear in the plane, not in range and azimuth
        xy = ground[:, None] * np.stack([np.cos(azimuth), np.sin(azimuth)], axis=-1)
        here = xy[rl] + w[:, None] * (xy[rh] - xy[rl])
        out[j, same, 0] = np.hypot(here[:, 0], here[:, 1])[same]
        out[j, same, 1] = np.arctan2(here[:, 1], here[:, 0])[same]
    return out


def register_detections(detections, radars, *, warmup=300.0):
    r"""Each radar's range offset, range scale and azimuth offset from the first reports.

    Parameters
    ----------
    detections : Detections
        From :func:`simulate_detections` (either mode).
    radars : sequence of Radar
        The radars (sites, noise levels, periods).
    warmup : float, optional
        Seconds from the detections' start whose reports are used (default 300).

    Returns
    -------
    radarfusion_ref.registration.BiasEstimate
        ``biases`` (m, 3): :math:`(\Delta r` m, :math:`g`, :math:`\Delta\beta` rad) per
        radar, the layout :func:`to_common` corrects; ``crlb`` in the same units.

    Raises
    ------
    TypeError
        Wrong types of `detections` or `radars`.
    ValueError
        Non-positive `warmup`, a radar index outside `radars`, fewer than
        :data:`~radarfusion_ref.capstone.MIN_REGISTRATION_GROUPS` aircraft instants
        seen by every radar in the warm-up, or biases the geometry cannot observe (from
        :func:`radarfusion_ref.registration.estimate_biases`, naming the combinations).

    Notes
    -----
    Association: the reports of one aircraft are known to be one object by its address
    (``detections.aircraft``; a Mode S secondary radar reports the aircraft's 24-bit
    address, a false report has none). Time alignment: the instants are the scans of the
    radar with the longest period; every other radar's measured ground range
    :math:`\hat r\cos\hat\varepsilon` and azimuth, with the measured direction turned into
    the common frame (:func:`local_rotation`), are interpolated between its two reports
    that bracket the instant (at most 1.5 periods apart), linearly in the plane about its
    site (straight-line motion; linear in range and azimuth would bias the range by up to
    20 m at 20 km). The aligned reports of
    every aircraft instant seen by all radars go to
    :func:`radarfusion_ref.registration.estimate_biases` (in km, every bias free). Its 2-D
    model would see the slant-range offset as :math:`\Delta r\cos\varepsilon`, which
    varies with the elevation and so leaks into the scale; the ground range given to it is
    :math:`\hat r\cos\hat\varepsilon + \widehat{\Delta r}(1 - \cos\hat\varepsilon)`
    with the previous pass's offset (three passes from zero). The interpolation shrinks
    the noise of the aligned reports, so the stated bound is conservative.

    Examples
    --------
    >>> from radarfusion_ref.capstone import load_traffic, realistic_radars
    >>> radars = realistic_radars()
    >>> det = simulate_detections(load_traffic(), radars, duration=300.0, rng=0)
    >>> register_detections(det, radars).biases.shape
    (3, 3)
    """
    radars, _, _ = _to_common_iv(detections, radars, None, True)
    warmup = as_float(as_positive(warmup, "warmup"), "warmup")
    m = len(radars)
    sub = detections.subset((detections.time < detections.start + warmup)
                            & (detections.aircraft >= 0))
    ground, azimuth, cos_e = _common_polar(sub, radars)
    ref = int(np.argmax([r.period for r in radars]))
    mine = sub.radar == ref
    t_ref, a_ref = sub.time[mine], sub.aircraft[mine]
    offset = np.zeros(m)
    for _ in range(_REG_PASSES):
        # r cos(e) + dr (1 - cos(e)): the slant-range offset seen whole by the 2-D model
        g_eff = ground + offset[sub.radar] * (1.0 - cos_e)
        z = _aligned(sub, radars, g_eff, azimuth, t_ref, a_ref)
        full = np.all(np.isfinite(z[..., 0]), axis=0)
        if full.sum() < MIN_REGISTRATION_GROUPS:
            raise ValueError(f"`warmup`: only {int(full.sum())} aircraft instants are seen by "
                             f"all {m} radars in the first {warmup:g} s; the registration "
                             f"needs at least {MIN_REGISTRATION_GROUPS} (a longer `warmup`)")
        z = z[:, full] * [1e-3, 1.0]
        sites = np.stack([r.enu[:2] for r in radars]) * 1e-3
        est = registration.estimate_biases(
            sites, z, np.array([r.sigma_r for r in radars]) * 1e-3,
            np.array([r.sigma_beta for r in radars]))
        offset = est.biases[:, 0] * 1e3
    unit = np.array([1e3, 1.0, 1.0])
    scale = np.repeat(unit[None, :], m, axis=0).ravel()
    return registration.BiasEstimate(
        biases=est.biases * unit, targets=est.targets * 1e3,
        covariance=est.covariance * np.outer(scale, scale), crlb=est.crlb * unit,
        information=est.information / np.outer(scale, scale), chi2=est.chi2, dof=est.dof,
        iterations=est.iterations)
