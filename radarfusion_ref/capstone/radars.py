r"""The capstone's radars: sites, accuracy, biases, detection, clutter, and their reports.

Frames. All geometry lives in the common ENU frame about
:data:`radarfusion_ref.capstone.traffic.ORIGIN`; each radar measures range, azimuth
(counter-clockwise from east, as in :mod:`radarfusion_ref.conversion`) and elevation
of the aircraft's common-frame position relative to its own common-frame position. A
real radar measures in its own local frame, which is rotated against the common one
(by the meridian convergence, about 0.7° per degree of longitude here); a fusion
centre undoes that known rotation before fusing, and the simulation leaves it out.
In :func:`simulate_reports` (the simple mode) the radars scan at the same instants
(every `period` seconds of the truth), so the reports of one scan describe the aircraft at
one time, as S-D grouping assumes. The realistic mode,
:func:`radarfusion_ref.capstone.detections.simulate_detections` with
:func:`realistic_radars`, drops both simplifications: each radar scans at its own period
and phase and measures in its own east-north-up frame.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .. import registration
from ..engine.geodesy import geodetic_to_enu
from ..engine.validation import (
    MAX_MAGNITUDE,
    MEMORY_LIMIT,
    as_float_array,
    as_rng,
    check_size,
    describe,
)
from .traffic import ORIGIN, TruthScans

__all__ = [
    "RADAR_SITES",
    "REALISTIC_TIMING",
    "Radar",
    "Reports",
    "as_radars",
    "coverage_count",
    "default_radars",
    "realistic_radars",
    "simulate_reports",
]

#: Radar sites: name -> (latitude deg, longitude deg, height m). Mountain-top sites of
#: MeteoSwiss's weather-radar network (coordinates rounded), standing in for air-traffic
#: radars: La Dôle (west), Albis (north), Monte Lema (south).
RADAR_SITES = {
    "La Dole": (46.4256, 6.0994, 1682.0),
    "Albis": (47.2844, 8.5122, 938.0),
    "Monte Lema": (46.0408, 8.8332, 1626.0),
}

#: Fields of :class:`Radar` whose magnitude :func:`as_radars` bounds by
#: :data:`radarfusion_ref.engine.validation.MAX_MAGNITUDE` (:math:`2^{150}`): a range or
#: noise level beyond it overflows the reports or the coverage volume.
_DOMAIN_FIELDS = ("height", "sigma_r", "bias_range", "clutter_rate", "max_range",
                  "sigma_feature")
#: Span (kt) over which false reports draw their speed feature, uniformly.
_FEATURE_SPAN = (300.0, 600.0)
#: Altitudes (m, common frame) between which false reports are placed, uniformly.
_CLUTTER_ALT = (8000.0, 15000.0)


@dataclass(frozen=True)
class Radar:
    r"""One radar: site, accuracy, biases, detection and clutter.

    Attributes
    ----------
    name : str
    lat, lon, height : float
        Site (degrees, degrees, m).
    sigma_r : float
        Range noise standard deviation (m).
    sigma_beta, sigma_epsilon : float
        Azimuth and elevation noise standard deviations (rad).
    bias_range : float
        Systematic range offset :math:`\Delta r` (m).
    bias_azimuth : float
        Systematic azimuth offset :math:`\Delta\beta` (rad); the bias model is
        :func:`radarfusion_ref.registration.apply_biases` with zero scale error.
    p_detect : float
        Detection probability of an aircraft in coverage.
    clutter_rate : float
        Mean number of false reports per scan (Poisson), uniform over the coverage
        disk and the altitudes 8–15 km, with a speed feature uniform on 300–600 kt.
    max_range : float
        Coverage: slant range at most this (m) ...
    min_elevation : float
        ... and elevation at least this (rad).
    sigma_feature : float
        Noise standard deviation of the speed feature (kt).
    period : float
        Scan period (s, > 0; default 10). The radar's scans are at the instants
        ``phase + k * period`` (s from the traffic start), k = 0, 1, ...
    phase : float
        Time of its scan 0 (s, ``0 <= phase < period``; default 0).
    bias_scale : float
        Systematic range scale error :math:`g` (dimensionless, > -1; default 0): the
        biased range is :math:`(1 + g) r + \Delta r`.
    """

    name: str
    lat: float
    lon: float
    height: float
    sigma_r: float = 50.0
    sigma_beta: float = math.radians(0.08)
    sigma_epsilon: float = math.radians(0.12)
    bias_range: float = 0.0
    bias_azimuth: float = 0.0
    p_detect: float = 0.9
    clutter_rate: float = 10.0
    max_range: float = 220_000.0
    min_elevation: float = 0.0
    sigma_feature: float = 10.0
    period: float = 10.0
    phase: float = 0.0
    bias_scale: float = 0.0

    @property
    def enu(self) -> np.ndarray:
        """Site in the common ENU frame (m)."""
        return geodetic_to_enu(self.lat, self.lon, self.height, origin=ORIGIN)

    @property
    def biases(self) -> np.ndarray:
        """(range offset m, range scale, azimuth offset rad), as registration orders them."""
        return np.array([self.bias_range, self.bias_scale, self.bias_azimuth])

    @property
    def coverage_volume(self) -> float:
        """Volume (m^3) of the clutter region: the coverage disk times 8–15 km."""
        return math.pi * self.max_range**2 * (_CLUTTER_ALT[1] - _CLUTTER_ALT[0])


def default_radars(**overrides) -> tuple[Radar, ...]:
    """The three radars of the capstone, at the :data:`RADAR_SITES`.

    Every radar: range noise 50 m, azimuth 0.08°, elevation 0.12°, speed feature
    10 kt, coverage 220 km slant range above 0° elevation, 10 false reports per scan.
    Biases (range offset, azimuth offset) and detection probabilities:
    La Dôle (+120 m, +0.12°, 0.90), Albis (−80 m, −0.10°, 0.85),
    Monte Lema (+60 m, +0.15°, 0.92).

    Parameters
    ----------
    **overrides
        Fields of :class:`Radar` (other than the site) set to the same value for all
        three radars, e.g. ``sigma_beta=np.radians(1.0), clutter_rate=50.0``.

    Returns
    -------
    tuple of Radar

    Raises
    ------
    TypeError
        An override that is not a field of :class:`Radar` (or is a site field).
    ValueError
        An override value the radars cannot take (as :func:`as_radars` checks them).

    Examples
    --------
    >>> [r.name for r in default_radars()]
    ['La Dole', 'Albis', 'Monte Lema']
    """
    extra = {"La Dole": (120.0, 0.12, 0.90), "Albis": (-80.0, -0.10, 0.85),
             "Monte Lema": (60.0, 0.15, 0.92)}
    allowed = set(Radar.__dataclass_fields__) - {"name", "lat", "lon", "height"}
    bad = sorted(set(overrides) - allowed)
    if bad:
        raise TypeError(f"`overrides`: {', '.join(f'`{k}`' for k in bad)} not a radar "
                        f"parameter; allowed: {', '.join(sorted(allowed))}")
    for k, v in overrides.items():
        if not _is_number(v):
            raise TypeError(f"`{k}` must be a number; received {describe(v)}")
    out = tuple(dataclasses.replace(
        Radar(name, *site, bias_range=extra[name][0],
              bias_azimuth=math.radians(extra[name][1]), p_detect=extra[name][2]),
        **{k: float(v) for k, v in overrides.items()})
        for name, site in RADAR_SITES.items())
    return as_radars(out)


#: Fewest groups holding a report of every radar that the registration accepts
#: (:func:`~radarfusion_ref.capstone.pipeline.run_pipeline` and
#: :func:`~radarfusion_ref.capstone.detections.register_detections`).
MIN_REGISTRATION_GROUPS = 10

#: Scan period (s), phase (s) and range scale error of each radar in
#: :func:`realistic_radars`.
REALISTIC_TIMING = {"La Dole": (12.0, 5.0, 2e-4), "Albis": (8.0, 2.5, -1.5e-4),
                    "Monte Lema": (5.0, 1.0, 1e-4)}


def realistic_radars(**overrides) -> tuple[Radar, ...]:
    """The three radars of :func:`default_radars`, asynchronous and with range scale errors.

    Each radar keeps its site, noise, offsets and detection model, and gets its own scan
    period, phase and range scale error (:data:`REALISTIC_TIMING`): La Dôle every 12 s from
    5 s (+2e-4, i.e. +40 m at 200 km), Albis every 8 s from 2.5 s (-1.5e-4), Monte Lema
    every 5 s from 1 s (+1e-4). With ``mode="realistic"``
    (:func:`radarfusion_ref.capstone.simulate_detections`) each also measures in its own
    local east-north-up frame.

    Parameters
    ----------
    **overrides
        As :func:`default_radars` (the same value for all three; `period`, `phase` and
        `bias_scale` among them).

    Returns
    -------
    tuple of Radar

    Raises
    ------
    TypeError, ValueError
        As :func:`default_radars`; a period, phase or scale error outside its meaning is
        refused naming ``radars[i].period`` (or ``phase``, ``bias_scale``).

    Examples
    --------
    >>> [r.period for r in realistic_radars()]
    [12.0, 8.0, 5.0]
    """
    base = default_radars()
    out = tuple(dataclasses.replace(r, period=REALISTIC_TIMING[r.name][0],
                                    phase=REALISTIC_TIMING[r.name][1],
                                    bias_scale=REALISTIC_TIMING[r.name][2]) for r in base)
    if overrides:
        default_radars(**overrides)                          # the same checks, by name
        out = tuple(dataclasses.replace(r, **{k: float(v) for k, v in overrides.items()})
                    for r in out)
    return as_radars(out)


#: Bytes one false report of :func:`simulate_reports` occupies at most, summed over
#: its working copies (positions, polar coordinates, noise, columns, the sorted copy).
_FALSE_REPORT_BYTES = 8 * 32


def _limit_false_reports(i: int, count: int, scans: int) -> int:
    """Refuse `count` false reports of radar `i` whose working memory would not fit."""
    try:
        check_size(count * _FALSE_REPORT_BYTES, MEMORY_LIMIT,
                   what=f"bytes of false reports ({count} over {scans} scans, "
                        f"{_FALSE_REPORT_BYTES} bytes each)",
                   alternative="a lower clutter_rate or fewer scans (a shorter `duration` "
                               "in truth_scans, the scans simulated in batches)")
    except ValueError as exc:
        raise ValueError(f"`radars[{i}].clutter_rate`: {exc}") from None
    return count


def _is_number(v) -> bool:
    return not isinstance(v, bool) and isinstance(v, (int, float, np.floating, np.integer))


def _timing_iv(i, r):
    """Refuse, naming ``radars[i].<field>``, a bad scan period, phase or range scale."""
    for name in ("period", "phase", "bias_scale"):
        v = getattr(r, name)
        if not _is_number(v) or not math.isfinite(v):
            raise (ValueError if _is_number(v) else TypeError)(
                f"`radars[{i}].{name}` (radar {r.name!r}) must be a finite number; received "
                f"{describe(v)}")
    for name, bad, rule in (
            ("period", not r.period > 0, "> 0 s"),
            ("phase", not 0 <= r.phase < r.period, f">= 0 and < its period ({r.period!r} s)"),
            ("bias_scale", not abs(r.bias_scale) < 0.5, "in (-0.5, 0.5) (a range scale error)")):
        if bad:
            raise ValueError(f"`radars[{i}].{name}` (radar {r.name!r}) must be {rule}; "
                             f"received {describe(getattr(r, name))}")


def as_radars(radars) -> tuple[Radar, ...]:
    """Check a `radars` argument: at least two valid :class:`Radar`, as a tuple.

    The door check of every function of the package that takes radars; a caller with
    radars of its own (``dataclasses.replace`` of :func:`default_radars`, say) can run it
    once up front.

    Parameters
    ----------
    radars : list or tuple of Radar

    Returns
    -------
    tuple of Radar

    Raises
    ------
    TypeError
        `radars` not a list or tuple of :class:`Radar`, or a timing field not a number.
    ValueError
        Fewer than two radars; a scan period not > 0, a phase outside ``[0, period)`` or a
        range scale error outside (-0.5, 0.5) (named ``radars[i].period`` and so on); a
        site, noise level, range, detection probability, clutter rate or azimuth offset
        outside its meaning; a height, range noise, range offset, clutter rate, coverage
        range or feature noise above :math:`2^{150}` in magnitude (named
        ``radars[i].max_range`` and so on: beyond it reports or the coverage volume
        overflow).

    Examples
    --------
    >>> len(as_radars(list(default_radars())))
    3
    >>> as_radars(default_radars()[:1])
    Traceback (most recent call last):
    ...
    ValueError: `radars` must hold at least two radars; received 1
    """
    if isinstance(radars, Radar) or not isinstance(radars, (list, tuple)) or not all(
            isinstance(r, Radar) for r in radars):
        raise TypeError(f"`radars` must be a list or tuple of Radar (see default_radars()); "
                        f"received {describe(radars)}")
    if len(radars) < 2:
        raise ValueError(f"`radars` must hold at least two radars; received {len(radars)}")
    for i, r in enumerate(radars):
        _timing_iv(i, r)
        vals = np.array([r.lat, r.lon, r.height, r.sigma_r, r.sigma_beta, r.sigma_epsilon,
                         r.bias_range, r.bias_azimuth, r.p_detect, r.clutter_rate,
                         r.max_range, r.min_elevation, r.sigma_feature], dtype=float)
        if not np.all(np.isfinite(vals)) or min(r.sigma_r, r.sigma_beta, r.sigma_epsilon,
                                                 r.sigma_feature, r.max_range) <= 0 \
                or not 0 < r.p_detect <= 1 or r.clutter_rate < 0 \
                or abs(r.bias_azimuth) >= math.pi or abs(r.lat) > 90 or abs(r.lon) > 180:
            raise ValueError(f"`radars`: radar {r.name!r} needs finite values, positive "
                             "deviations and range, p_detect in (0, 1], clutter_rate >= 0, "
                             f"|bias_azimuth| < pi and a valid site; received {r!r}")
        for name in _DOMAIN_FIELDS:
            if not abs(getattr(r, name)) <= MAX_MAGNITUDE:
                raise ValueError(
                    f"`radars[{i}].{name}` (radar {r.name!r}) must lie within the numeric "
                    f"domain |value| <= 2**150 (about 1.4e45), so that ranges, noise and "
                    f"the coverage volume stay finite; received {getattr(r, name)!r}")
    return tuple(radars)



@dataclass(frozen=True)
class Reports:
    """All reports of all radars over all scans (one row per report).

    Attributes
    ----------
    scan, radar : numpy.ndarray of int, shape (N,)
        Scan index and radar index (into the `radars` given to :func:`simulate_reports`).
    r, beta, epsilon : numpy.ndarray, shape (N,)
        Measured range (m), azimuth and elevation (rad).
    feature : numpy.ndarray, shape (N,)
        Measured speed feature (kt).
    source : numpy.ndarray of int, shape (N,)
        Truth: the aircraft index, or -1 for a false report.
    n_scans : int
        Number of scans (reports may be absent from some).
    """

    scan: np.ndarray
    radar: np.ndarray
    r: np.ndarray
    beta: np.ndarray
    epsilon: np.ndarray
    feature: np.ndarray
    source: np.ndarray
    n_scans: int

    def subset(self, rows) -> Reports:
        """The reports of the given rows (a boolean mask or indices), same `n_scans`."""
        return Reports(**{k: getattr(self, k)[rows] for k in
                          ("scan", "radar", "r", "beta", "epsilon", "feature", "source")},
                       n_scans=self.n_scans)


def _polar(rel):
    """Slant range, azimuth (from east, counter-clockwise) and elevation of (n, 3) offsets."""
    ground = np.hypot(rel[:, 0], rel[:, 1])
    return (np.linalg.norm(rel, axis=1), np.arctan2(rel[:, 1], rel[:, 0]),
            np.arctan2(rel[:, 2], ground))


def _coverage_count(position, radars):
    n = np.zeros(position.shape[0], dtype=np.int64)
    for rad in radars:
        r, _, eps = _polar(position - rad.enu)
        n += (r <= rad.max_range) & (eps >= rad.min_elevation)
    return n


def coverage_count(position, radars) -> np.ndarray:
    """Number of radars whose coverage holds each position.

    Parameters
    ----------
    position : array_like, shape (n, 3)
        Positions in the common ENU frame (m).
    radars : sequence of Radar

    Returns
    -------
    numpy.ndarray of int, shape (n,)
        How many radars have the position within `max_range` and above `min_elevation`.

    Raises
    ------
    ValueError, TypeError
        Positions that are not finite (n, 3) numbers, or bad `radars`.

    Examples
    --------
    >>> coverage_count([[0.0, 0.0, 10_000.0], [0.0, 0.0, -1e6]], default_radars()).tolist()
    [3, 0]
    """
    pos = _position_iv(position)
    return _coverage_count(pos, as_radars(radars))


def _position_iv(position):
    pos = as_float_array(position, "position", ndim_min=2, last_dims=(3,))
    if pos.ndim != 2:
        raise ValueError(f"`position` must have shape (n, 3); received shape {pos.shape}")
    return pos


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


@dataclass(frozen=True)
class _Drawn:
    """One radar's reports over a batch of scans: its detections first, then its clutter."""

    detected: np.ndarray        # (n_truth,) bool: which truth rows gave a report
    n_false: np.ndarray         # (S,) int: false reports per scan, in scan order
    r: np.ndarray               # (n + nf,) measured range (m)
    beta: np.ndarray            # (n + nf,) measured azimuth (rad)
    epsilon: np.ndarray         # (n + nf,) measured elevation (rad)
    feature: np.ndarray         # (n + nf,) measured speed feature (kt)

    @property
    def n_detected(self) -> int:
        return int(self.detected.sum())


def _draw_scans(i, rad, r, beta, eps, speed, S, site_up, gen) -> _Drawn:
    """The one home of a radar's detection, clutter and noise draw (trusted input).

    `r`, `beta`, `eps`: the true polar coordinates of the truth rows in the radar's frame;
    `speed`: their ground speeds (kt); `S`: the scans of the batch; `site_up`: the site's
    height in the frame the clutter altitudes are placed in. The draws, in this order:
    detection, clutter counts, clutter positions, the noise of every report, the clutter's
    speed features (both modes of the capstone's simulation share this stream).
    """
    cover = (r <= rad.max_range) & (eps >= rad.min_elevation)
    det = cover & (gen.random(r.size) < rad.p_detect)
    rb, bb = registration.apply_biases(r[det], beta[det], rad.biases)
    n_false = gen.poisson(rad.clutter_rate, size=S)
    nf = _limit_false_reports(i, int(n_false.sum()), S)
    rho = rad.max_range * np.sqrt(gen.random(nf))
    phi = gen.uniform(-np.pi, np.pi, nf)
    z = gen.uniform(*_CLUTTER_ALT, nf) - site_up
    fr, fb, fe = _polar(np.stack([rho * np.cos(phi), rho * np.sin(phi), z], -1))
    n = int(det.sum())
    noise = gen.standard_normal((n + nf, 4))
    feat = np.concatenate([speed[det], gen.uniform(*_FEATURE_SPAN, nf)])
    return _Drawn(det, n_false,
                  np.abs(np.concatenate([rb, fr]) + rad.sigma_r * noise[:, 0]),
                  _wrap(np.concatenate([bb, fb]) + rad.sigma_beta * noise[:, 1]),
                  np.concatenate([eps[det], fe]) + rad.sigma_epsilon * noise[:, 2],
                  feat + rad.sigma_feature * noise[:, 3])


def simulate_reports(truth, radars, *, rng=None) -> Reports:
    r"""Reports of the radars at every scan: detections with noise and biases, and clutter.

    Parameters
    ----------
    truth : TruthScans
        From :func:`radarfusion_ref.capstone.traffic.truth_scans`.
    radars : sequence of Radar
        E.g. :func:`default_radars`.
    rng : None, int or numpy.random.Generator, optional
        Randomness (SPEC 7).

    Returns
    -------
    Reports
        Sorted by scan, then radar; within them detections precede false reports.

    Raises
    ------
    TypeError
        If `truth` is not a :class:`~radarfusion_ref.capstone.traffic.TruthScans`, `radars`
        not a sequence of :class:`Radar` or `rng` not a seed or generator.
    ValueError
        Invalid radar parameters (named), or false reports (`clutter_rate` times
        the scans, then the drawn count) whose working memory would exceed
        :data:`~radarfusion_ref.engine.validation.MEMORY_LIMIT`: refused naming the
        radar's `clutter_rate` before anything is drawn or allocated.

    Notes
    -----
    An aircraft at slant range :math:`r \le r_{\max}` and elevation
    :math:`\varepsilon \ge \varepsilon_{\min}` from a radar is detected with
    probability :math:`P_D`; its report is
    :math:`(r + \Delta r + v_r,\ \beta + \Delta\beta + v_\beta,\ \varepsilon + v_\varepsilon)`
    (:func:`radarfusion_ref.registration.apply_biases`) with independent Gaussian
    noises, and speed feature :math:`s + v_s`, :math:`s` the ground speed. False reports:
    Poisson(`clutter_rate`) per scan, uniform over the coverage disk and altitudes
    8–15 km, measured with the same noise (no bias), speed uniform on 300–600 kt.

    Examples
    --------
    >>> from radarfusion_ref.capstone.traffic import load_traffic, truth_scans
    >>> tr = truth_scans(load_traffic(), duration=30.0)
    >>> rep = simulate_reports(tr, default_radars(), rng=1)
    >>> int(rep.n_scans)
    3
    """
    if not isinstance(truth, TruthScans):
        raise TypeError(f"`truth` must be a TruthScans (from truth_scans); received "
                        f"{describe(truth)}")
    radars = as_radars(radars)
    gen = as_rng(rng)
    S = truth.n_scans
    for i, rad in enumerate(radars):                 # refused before any draw
        _limit_false_reports(i, math.ceil(rad.clutter_rate * S), S)
    cols = {k: [] for k in ("scan", "radar", "r", "beta", "epsilon", "feature", "source")}
    for i, rad in enumerate(radars):
        site = rad.enu
        d = _draw_scans(i, rad, *_polar(truth.position - site), truth.speed, S, site[2], gen)
        cols["r"].append(d.r)
        cols["beta"].append(d.beta)
        cols["epsilon"].append(d.epsilon)
        cols["feature"].append(d.feature)
        cols["scan"].append(np.concatenate([truth.scan[d.detected],
                                            np.repeat(np.arange(S), d.n_false)]))
        cols["radar"].append(np.full(d.r.size, i))
        cols["source"].append(np.concatenate([truth.aircraft[d.detected],
                                              np.full(d.r.size - d.n_detected, -1)]))
    out = {k: np.concatenate(v) for k, v in cols.items()}
    order = np.lexsort((out["source"] < 0, out["radar"], out["scan"]))
    return Reports(**{k: v[order] for k, v in out.items()}, n_scans=S)
