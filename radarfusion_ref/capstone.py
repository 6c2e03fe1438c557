"""A fusion centre over real air traffic: three radars, the whole pipeline, GOSPA.

The truth is one hour of ADS-B records over Switzerland (``data/``, 2018-08-01
11:00–12:00 UTC, 142 aircraft, en-route traffic at 30 000–47 000 ft) from the
``traffic`` package's samples. This module

* loads the committed subset (:func:`load_traffic`) and projects WGS-84
  coordinates to a local east-north-up plane (:func:`geodetic_to_enu`) about
  :data:`ORIGIN`;
* interpolates the aircraft at the scan times (:func:`truth_scans`);
* simulates three radars at stated sites (:data:`RADAR_SITES`,
  :func:`default_radars`) reporting range, azimuth, elevation and a speed
  feature, with noise, systematic biases, missed detections, clutter and
  coverage limits (:func:`simulate_reports`);
* runs the fusion centre scan by scan (:func:`run_pipeline`), each step calling
  the function its chapter teaches: the debiased 3-D conversion
  (:func:`radarfusion_ref.conversion.spherical_to_cartesian`), registration
  over a warm-up window (:func:`radarfusion_ref.registration.estimate_biases`),
  the per-report-covariance gate (:func:`radarfusion_ref.gating.gate_pairwise_2d`),
  S-D grouping with dummies for misses and false reports
  (:func:`radarfusion_ref.grouping.group_sd`), ML fusion
  (:func:`radarfusion_ref.fusion.fuse_gaussian`, :func:`radarfusion_ref.fusion.fuse`)
  and type recognition (:func:`radarfusion_ref.features.type_posterior`);
* scores the result against the truth (:func:`evaluate`): GOSPA
  (:func:`gospa`) with its localisation, missed and false parts, association
  accuracy, NEES and recognition accuracy;
* optionally tracks the fused objects, one local track per radar fused track to
  track (:func:`track_fusion`, with
  :func:`radarfusion_ref.trackfusion.covariance_intersection`), scored by
  :func:`evaluate_tracks`.

Frames. All geometry lives in the common ENU frame about :data:`ORIGIN`; each
radar measures range, azimuth (counter-clockwise from east, as in
:mod:`radarfusion_ref.conversion`) and elevation of the aircraft's common-frame
position relative to its own common-frame position. A real radar measures in
its own local frame, which is rotated against the common one (by the meridian
convergence, about 0.7° per degree of longitude here); a fusion centre undoes
that known rotation before fusing, and the simulation leaves it out. The three
radars scan at the same instants (every `period` seconds), so the reports of one
scan describe the aircraft at one time, as S-D grouping assumes.

.. rubric:: References

.. [1] A. S. Rahmathullah, Á. F. García-Fernández, L. Svensson, "Generalized
   optimal sub-pattern assignment metric", FUSION 2017 (GOSPA, eqs. 1–2 and
   the decomposition for α = 2).
.. [2] X. Olive, "traffic, a toolbox for processing and analysing air traffic
   data", JOSS 4(39) 1518 (2019) — the source of the ADS-B samples.
"""

from __future__ import annotations

import csv
import dataclasses
import gzip
import io
import math
import time
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy import stats
from scipy.optimize import linear_sum_assignment

from . import conversion, features, fusion, gating, grouping, registration, trackfusion
from .engine import assignment
from .engine._validation import (
    MEMORY_LIMIT,
    _describe,
    as_bool,
    as_choice,
    as_float_array,
    as_int,
    as_probability,
    as_rng,
    check_size,
)
from .engine.montecarlo import Proportion, proportion

__all__ = [
    "DATA_FILE",
    "ORIGIN",
    "RADAR_SITES",
    "SPEED_CLASSES",
    "SPEED_BOUNDS",
    "SPEED_TYPE_MEANS",
    "SPEED_TYPE_VARS",
    "MIN_REGISTRATION_GROUPS",
    "STAGES",
    "Evaluation",
    "GospaResult",
    "PipelineResult",
    "Radar",
    "Reports",
    "TrackEvaluation",
    "TrackFusionResult",
    "Traffic",
    "TruthScans",
    "default_radars",
    "evaluate",
    "evaluate_tracks",
    "geodetic_to_enu",
    "gospa",
    "load_traffic",
    "run_pipeline",
    "simulate_reports",
    "track_fusion",
    "truth_scans",
]

#: The committed subset (see ``data/README.md``).
DATA_FILE = Path(__file__).resolve().parents[1] / "data" / "switzerland_busiest_hour.csv.gz"

_HEADER = ("t_s", "icao24", "callsign", "lat_e5", "lon_e5", "alt_ft", "gs_kt", "track_deg")

#: Origin of the common east-north-up frame: latitude, longitude (degrees, WGS-84) and
#: ellipsoidal height (m) — the middle of the data's box (45.8–47.8 N, 6.0–10.5 E).
ORIGIN = (46.8, 8.2, 0.0)

#: Radar sites: name -> (latitude deg, longitude deg, height m). Mountain-top sites of
#: MeteoSwiss's weather-radar network (coordinates rounded), standing in for air-traffic
#: radars: La Dôle (west), Albis (north), Monte Lema (south).
RADAR_SITES = {
    "La Dole": (46.4256, 6.0994, 1682.0),
    "Albis": (47.2844, 8.5122, 938.0),
    "Monte Lema": (46.0408, 8.8332, 1626.0),
}

#: Speed classes of the recognition step, by ground speed: slow < 440 kt <= medium
#: < 465 kt <= fast (about the tertiles of the committed hour).
SPEED_CLASSES = ("slow", "medium", "fast")
SPEED_BOUNDS = (440.0, 465.0)
#: Gaussian type model of the speed feature (kt, kt^2) used by the recognition step
#: (:func:`radarfusion_ref.features.type_posterior`): the class means and variances of
#: the ground speed over the committed hour's 10-s scan positions (standard deviations
#: 39.0, 7.0 and 10.7 kt; the slow class has a long tail of slower aircraft).
SPEED_TYPE_MEANS = (419.0, 451.0, 479.5)
SPEED_TYPE_VARS = (39.0**2, 7.0**2, 10.7**2)
#: Span (kt) over which false reports draw their speed feature, uniformly.
_FEATURE_SPAN = (300.0, 600.0)
#: Altitudes (m, common frame) between which false reports are placed, uniformly.
_CLUTTER_ALT = (8000.0, 15000.0)

#: The grouping's detection model: the per-scan P_D of a radar (its P_D times the share of
#: the scan's reports inside its coverage) is kept in [_MIN_PD, _MAX_PD], and the false-report
#: density is at least _MIN_FALSE times the object density, so that a report failing the gate
#: can always stay alone (never an infeasible scan).
_MIN_PD, _MAX_PD, _MIN_FALSE = 1e-3, 0.999, 1e-3

#: Fewest groups holding a report of every radar that the registration accepts.
MIN_REGISTRATION_GROUPS = 10
#: Registration passes over the warm-up: group, estimate, regroup with the estimate,
#: estimate again. One pass is biased towards small offsets (the uncorrected gate keeps
#: the triples whose offsets happen to cancel); the second removes most of that.
_REG_PASSES = 2

#: Stages timed by :func:`run_pipeline` (in order); :func:`evaluate` adds "metrics".
STAGES = ("conversion", "registration", "gating", "grouping", "fusion", "recognition")

_A = 6378137.0                      # WGS-84 semi-major axis (m)
_F = 1.0 / 298.257223563            # WGS-84 flattening
_E2 = _F * (2.0 - _F)               # first eccentricity squared
_FT = 0.3048                        # metres per foot


# ----------------------------------------------------------------------------- data
@dataclass(frozen=True)
class Traffic:
    """ADS-B records of one window, sorted by aircraft then time.

    Attributes
    ----------
    t : numpy.ndarray of float, shape (N,)
        Seconds from the window start.
    aircraft : numpy.ndarray of int, shape (N,)
        Aircraft index into `icao24` (0..A-1).
    icao24, callsign : tuple of str, length A
        Transponder address and the first callsign seen of each aircraft.
    lat, lon : numpy.ndarray, shape (N,)
        WGS-84 latitude and longitude (degrees).
    alt : numpy.ndarray, shape (N,)
        Barometric altitude (m; the records' feet times 0.3048), used as height.
    speed : numpy.ndarray, shape (N,)
        Ground speed (kt).
    track : numpy.ndarray, shape (N,)
        Track (degrees clockwise from north).
    """

    t: np.ndarray
    aircraft: np.ndarray
    icao24: tuple
    callsign: tuple
    lat: np.ndarray
    lon: np.ndarray
    alt: np.ndarray
    speed: np.ndarray
    track: np.ndarray


def _bad_file(path, what):
    return ValueError(f"`path` {str(path)!r}: {what}")


def load_traffic(path=None) -> Traffic:
    """Load the committed ADS-B subset (or a file of the same format).

    Parameters
    ----------
    path : str or pathlib.Path, optional
        A gzip CSV with header ``t_s,icao24,callsign,lat_e5,lon_e5,alt_ft,gs_kt,track_deg``
        (integers, except the two names). Default :data:`DATA_FILE`, the hour of
        ``data/README.md``; no network access, no extra package.

    Returns
    -------
    Traffic

    Raises
    ------
    ValueError
        If the file is missing, not gzip, truncated, has another header, a row of another
        column count, a non-integer or non-finite entry, latitude outside [-90, 90] or
        longitude outside [-180, 180] degrees, a negative time or ground speed, or no rows.
        The message names `path` and what is wrong.
    TypeError
        If `path` is not a string or path.

    Examples
    --------
    >>> tr = load_traffic()
    >>> len(tr.icao24), tr.t.size
    (142, 12902)
    """
    if path is None:
        path = DATA_FILE
    if isinstance(path, bool) or not isinstance(path, (str, Path)):
        raise TypeError(f"`path` must be a file path (str or pathlib.Path); received "
                        f"{_describe(path)}")
    p = Path(path)
    if not p.is_file():
        raise _bad_file(p, "no such file; the committed subset is data/"
                           "switzerland_busiest_hour.csv.gz (regenerate it with "
                           "`python data/make_traffic_subset.py`)")
    try:
        text = gzip.decompress(p.read_bytes()).decode("ascii")
    except (OSError, EOFError, zlib.error) as exc:
        raise _bad_file(p, f"not a complete gzip file ({exc})") from None
    except UnicodeDecodeError:
        raise _bad_file(p, "the decompressed data is not ASCII text") from None
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or tuple(rows[0]) != _HEADER:
        raise _bad_file(p, f"the header must be {','.join(_HEADER)}; received "
                           f"{','.join(rows[0]) if rows else '(empty file)'!r}")
    body = rows[1:]
    if not body:
        raise _bad_file(p, "the file holds no records")
    bad = [k for k, r in enumerate(body) if len(r) != len(_HEADER)]
    if bad:
        raise _bad_file(p, f"row {bad[0] + 2} has {len(body[bad[0]])} columns, not "
                           f"{len(_HEADER)}")
    cols = list(zip(*body, strict=True))
    num = {}
    for k, name in enumerate(_HEADER):
        if name in ("icao24", "callsign"):
            continue
        try:
            num[name] = np.array(cols[k], dtype=np.int64)
        except (ValueError, OverflowError):
            j = next(i for i, v in enumerate(cols[k]) if not v.strip().lstrip("-").isdigit())
            raise _bad_file(p, f"column {name!r}, row {j + 2}: {cols[k][j]!r} is not an "
                               "integer") from None
    lat, lon = num["lat_e5"] * 1e-5, num["lon_e5"] * 1e-5
    for name, arr, lo, hi in (("lat_e5", lat, -90, 90), ("lon_e5", lon, -180, 180),
                              ("t_s", num["t_s"], 0, np.inf), ("gs_kt", num["gs_kt"], 0, np.inf)):
        out = np.flatnonzero((arr < lo) | (arr > hi))
        if out.size:
            raise _bad_file(p, f"column {name!r}, row {out[0] + 2}: {arr[out[0]]} is outside "
                               f"[{lo}, {hi}]")
    names, aircraft = np.unique(np.array(cols[1]), return_inverse=True)
    order = np.lexsort((num["t_s"], aircraft))
    first = {}
    for a, c in zip(aircraft[order], np.array(cols[2])[order], strict=True):
        first.setdefault(int(a), c)
    return Traffic(
        t=num["t_s"][order].astype(float), aircraft=aircraft[order].astype(np.int64),
        icao24=tuple(str(n) for n in names), callsign=tuple(first[a] for a in range(names.size)),
        lat=lat[order], lon=lon[order], alt=num["alt_ft"][order] * _FT,
        speed=num["gs_kt"][order].astype(float), track=num["track_deg"][order].astype(float))


# ----------------------------------------------------------------------------- geometry
def _ecef(lat, lon, h):
    phi, lam = np.radians(lat), np.radians(lon)
    n = _A / np.sqrt(1.0 - _E2 * np.sin(phi) ** 2)
    return np.stack([(n + h) * np.cos(phi) * np.cos(lam), (n + h) * np.cos(phi) * np.sin(lam),
                     (n * (1.0 - _E2) + h) * np.sin(phi)], axis=-1)


def geodetic_to_enu(lat, lon, h, *, origin=ORIGIN) -> np.ndarray:
    """WGS-84 geodetic coordinates to east-north-up about an origin (closed form).

    Parameters
    ----------
    lat, lon : array_like
        Latitude in [-90, 90] and longitude in [-180, 180] (degrees).
    h : array_like
        Ellipsoidal height (m). The three broadcast together.
    origin : sequence of 3 floats, optional
        ``(lat0, lon0, h0)`` of the frame's origin (default :data:`ORIGIN`).

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        East, north, up (m).

    Raises
    ------
    ValueError
        Non-finite input, latitudes or longitudes out of range, shapes that do not
        broadcast, or an `origin` that is not three finite numbers.
    TypeError
        Non-numeric input.

    Notes
    -----
    With :math:`a = 6378137` m, :math:`f = 1/298.257223563`, :math:`e^2 = f(2-f)` and
    :math:`N = a/\\sqrt{1 - e^2\\sin^2\\varphi}`, the Earth-centred position is
    :math:`((N+h)\\cos\\varphi\\cos\\lambda, (N+h)\\cos\\varphi\\sin\\lambda,
    (N(1-e^2)+h)\\sin\\varphi)`; ENU is its difference from the origin's, rotated by
    the origin's east, north and up unit vectors.

    Examples
    --------
    >>> np.round(geodetic_to_enu(0.0, 90.0, 0.0, origin=(0.0, 0.0, 0.0)), 3)
    array([ 6378137.,        0., -6378137.])
    """
    lat = as_float_array(lat, "lat")
    lon = as_float_array(lon, "lon")
    h = as_float_array(h, "h")
    o = as_float_array(origin, "origin")
    if o.shape != (3,):
        raise ValueError(f"`origin` must be (lat, lon, h); received {_describe(origin)}")
    for name, arr, lim in (("lat", lat, 90.0), ("lon", lon, 180.0)):
        if np.any(np.abs(arr) > lim):
            raise ValueError(f"`{name}` must lie in [-{lim:g}, {lim:g}] degrees; received "
                             f"{_describe(arr)}")
    if abs(o[0]) > 90 or abs(o[1]) > 180:
        raise ValueError(f"`origin` latitude must lie in [-90, 90] and longitude in "
                         f"[-180, 180]; received {_describe(origin)}")
    try:
        lat, lon, h = np.broadcast_arrays(lat, lon, h)
    except ValueError:
        raise ValueError(f"`lat`, `lon` and `h` must broadcast; received shapes {lat.shape}, "
                         f"{lon.shape}, {h.shape}") from None
    d = _ecef(lat, lon, h) - _ecef(o[0], o[1], o[2])
    p0, l0 = np.radians(o[0]), np.radians(o[1])
    rot = np.array([[-np.sin(l0), np.cos(l0), 0.0],
                    [-np.sin(p0) * np.cos(l0), -np.sin(p0) * np.sin(l0), np.cos(p0)],
                    [np.cos(p0) * np.cos(l0), np.cos(p0) * np.sin(l0), np.sin(p0)]])
    return d @ rot.T


# ----------------------------------------------------------------------------- truth
@dataclass(frozen=True)
class TruthScans:
    """Aircraft positions at the scan times (one row per aircraft and scan).

    Attributes
    ----------
    times : numpy.ndarray, shape (S,)
        Scan times (s from the window start).
    scan, aircraft : numpy.ndarray of int, shape (K,)
        Scan index and aircraft index (into `icao24`) of each row.
    position : numpy.ndarray, shape (K, 3)
        Interpolated ENU position (m).
    speed : numpy.ndarray, shape (K,)
        Interpolated ground speed (kt).
    speed_class : numpy.ndarray of int, shape (K,)
        Index into :data:`SPEED_CLASSES` (by :data:`SPEED_BOUNDS`).
    icao24 : tuple of str
        Aircraft addresses.
    period : float
        Scan period (s).
    """

    times: np.ndarray
    scan: np.ndarray
    aircraft: np.ndarray
    position: np.ndarray
    speed: np.ndarray
    speed_class: np.ndarray
    icao24: tuple
    period: float

    @property
    def n_scans(self) -> int:
        """Number of scans."""
        return int(self.times.size)


def _scalar(value, name, *, positive=True):
    v = as_float_array(value, name)
    if v.ndim:
        raise ValueError(f"`{name}` must be a number; received {_describe(value)}")
    if (v <= 0) if positive else (v < 0):
        raise ValueError(f"`{name}` must be {'> 0' if positive else '>= 0'}; received "
                         f"{_describe(value)}")
    return float(v)


def truth_scans(traffic, *, period=10.0, start=0.0, duration=600.0,
                max_gap=30.0) -> TruthScans:
    """Aircraft positions at scan times ``start, start + period, ...`` (linear interpolation).

    Parameters
    ----------
    traffic : Traffic
        From :func:`load_traffic`.
    period : float, optional
        Scan period T (s; default 10, the records' own spacing).
    start : float, optional
        Time of the first scan (s from the window start, >= 0; default 0).
    duration : float, optional
        Length of the scanned interval (s, > 0; default 600): scans at
        ``start + k * period < start + duration``.
    max_gap : float, optional
        An aircraft is placed at a scan time only if it has a record at that time, or two
        of its records bracket the time and lie at most `max_gap` seconds apart (default
        30); never extrapolated.

    Returns
    -------
    TruthScans

    Raises
    ------
    TypeError
        If `traffic` is not a :class:`Traffic`.
    ValueError
        Non-positive `period`, `duration` or `max_gap`, negative `start`, a window
        holding no aircraft at any scan, or one whose rows would exceed the memory limit.

    Examples
    --------
    >>> tr = truth_scans(load_traffic(), period=10.0, duration=60.0)
    >>> tr.n_scans, tr.position.shape[1]
    (6, 3)
    """
    if not isinstance(traffic, Traffic):
        raise TypeError(f"`traffic` must be a Traffic (from load_traffic); received "
                        f"{_describe(traffic)}")
    period = _scalar(period, "period")
    start = _scalar(start, "start", positive=False)
    duration = _scalar(duration, "duration")
    max_gap = _scalar(max_gap, "max_gap")
    n_scans = math.ceil(duration / period - 1e-9)
    check_size(8 * 8 * n_scans * len(traffic.icao24), MEMORY_LIMIT,
               what=f"bytes of truth rows ({n_scans} scans of `duration` / `period` x "
                    f"{len(traffic.icao24)} aircraft)",
               alternative="a longer `period` or a shorter `duration`, in windows")
    times = start + period * np.arange(n_scans)
    enu = geodetic_to_enu(traffic.lat, traffic.lon, traffic.alt)
    bounds = np.flatnonzero(np.diff(traffic.aircraft)) + 1
    starts = np.concatenate([[0], bounds])
    stops = np.concatenate([bounds, [traffic.t.size]])
    parts = []
    for a0, a1 in zip(starts, stops, strict=True):
        t = traffic.t[a0:a1]
        k = np.searchsorted(t, times, side="right") - 1             # record at or before
        ok = (k >= 0) & (k < t.size - 1)
        exact = (k >= 0) & (t[np.maximum(k, 0)] == times)            # a record at the scan
        kk = np.clip(k, 0, max(t.size - 2, 0))
        if t.size >= 2:
            ok &= (t[kk + 1] - t[kk]) <= max_gap
        ok |= exact
        if not ok.any():
            continue
        s = np.flatnonzero(ok)
        cols = [np.interp(times[s], t, v[a0:a1]) for v in
                (enu[:, 0], enu[:, 1], enu[:, 2], traffic.speed)]
        parts.append((s, np.full(s.size, traffic.aircraft[a0]), np.stack(cols[:3], -1),
                      cols[3]))
    if not parts:
        raise ValueError(f"`traffic`: no aircraft has records bracketing any scan time in "
                         f"[{start:g}, {start + duration:g}) s")
    scan, aircraft, pos, speed = (np.concatenate(p) for p in zip(*parts, strict=True))
    order = np.lexsort((aircraft, scan))
    speed = speed[order]
    return TruthScans(times=times, scan=scan[order], aircraft=aircraft[order],
                      position=pos[order], speed=speed,
                      speed_class=np.searchsorted(SPEED_BOUNDS, speed, side="right"),
                      icao24=traffic.icao24, period=period)


# ----------------------------------------------------------------------------- radars
@dataclass(frozen=True)
class Radar:
    """One radar: site, accuracy, biases, detection and clutter.

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
        Systematic range offset :math:`\\Delta r` (m).
    bias_azimuth : float
        Systematic azimuth offset :math:`\\Delta\\beta` (rad); the bias model is
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

    @property
    def enu(self) -> np.ndarray:
        """Site in the common ENU frame (m)."""
        return geodetic_to_enu(self.lat, self.lon, self.height)

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
        An override value the radars cannot take (as :func:`run_pipeline` checks them).

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
        if isinstance(v, bool) or not isinstance(v, (int, float, np.floating, np.integer)):
            raise TypeError(f"`{k}` must be a number; received {_describe(v)}")
    out = tuple(dataclasses.replace(
        Radar(name, *site, bias_range=extra[name][0],
              bias_azimuth=math.radians(extra[name][1]), p_detect=extra[name][2]),
        **{k: float(v) for k, v in overrides.items()})
        for name, site in RADAR_SITES.items())
    return _radars_iv(out)


def _radars_iv(radars):
    if isinstance(radars, Radar) or not isinstance(radars, (list, tuple)) or not all(
            isinstance(r, Radar) for r in radars):
        raise TypeError(f"`radars` must be a list or tuple of Radar (see default_radars()); "
                        f"received {_describe(radars)}")
    if len(radars) < 2:
        raise ValueError(f"`radars` must hold at least two radars; received {len(radars)}")
    for r in radars:
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


def _polar(rel):
    ground = np.hypot(rel[:, 0], rel[:, 1])
    return (np.linalg.norm(rel, axis=1), np.arctan2(rel[:, 1], rel[:, 0]),
            np.arctan2(rel[:, 2], ground))


def _coverage_count(position, radars):
    """Number of radars whose coverage holds each position."""
    n = np.zeros(position.shape[0], dtype=np.int64)
    for rad in radars:
        r, _, eps = _polar(position - rad.enu)
        n += (r <= rad.max_range) & (eps >= rad.min_elevation)
    return n


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def simulate_reports(truth, radars, *, rng=None) -> Reports:
    """Reports of the radars at every scan: detections with noise and biases, and clutter.

    Parameters
    ----------
    truth : TruthScans
        From :func:`truth_scans`.
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
        If `truth` is not a :class:`TruthScans`, `radars` not a sequence of :class:`Radar`
        or `rng` not a seed or generator.
    ValueError
        Invalid radar parameters (named).

    Notes
    -----
    An aircraft at slant range :math:`r \\le r_{\\max}` and elevation
    :math:`\\varepsilon \\ge \\varepsilon_{\\min}` from a radar is detected with
    probability :math:`P_D`; its report is
    :math:`(r + \\Delta r + v_r,\\ \\beta + \\Delta\\beta + v_\\beta,\\ \\varepsilon + v_\\varepsilon)`
    (:func:`radarfusion_ref.registration.apply_biases`) with independent Gaussian
    noises, and speed feature :math:`s + v_s`, :math:`s` the ground speed. False reports:
    Poisson(`clutter_rate`) per scan, uniform over the coverage disk and altitudes
    8–15 km, measured with the same noise (no bias), speed uniform on 300–600 kt.

    Examples
    --------
    >>> tr = truth_scans(load_traffic(), duration=30.0)
    >>> rep = simulate_reports(tr, default_radars(), rng=1)
    >>> int(rep.n_scans)
    3
    """
    if not isinstance(truth, TruthScans):
        raise TypeError(f"`truth` must be a TruthScans (from truth_scans); received "
                        f"{_describe(truth)}")
    radars = _radars_iv(radars)
    gen = as_rng(rng)
    S = truth.n_scans
    cols = {k: [] for k in ("scan", "radar", "r", "beta", "epsilon", "feature", "source")}
    for i, rad in enumerate(radars):
        site = rad.enu
        r, beta, eps = _polar(truth.position - site)
        cover = (r <= rad.max_range) & (eps >= rad.min_elevation)
        det = cover & (gen.random(r.size) < rad.p_detect)
        rb, bb = registration.apply_biases(r[det], beta[det],
                                           [rad.bias_range, 0.0, rad.bias_azimuth])
        n_false = gen.poisson(rad.clutter_rate, size=S)
        nf = int(n_false.sum())
        rho = rad.max_range * np.sqrt(gen.random(nf))
        phi = gen.uniform(-np.pi, np.pi, nf)
        z = gen.uniform(*_CLUTTER_ALT, nf) - site[2]
        fr, fb, fe = _polar(np.stack([rho * np.cos(phi), rho * np.sin(phi), z], -1))
        n = int(det.sum())
        r_all = np.concatenate([rb, fr])
        b_all = np.concatenate([bb, fb])
        e_all = np.concatenate([eps[det], fe])
        noise = gen.standard_normal((n + nf, 4))
        cols["r"].append(np.abs(r_all + rad.sigma_r * noise[:, 0]))
        cols["beta"].append(_wrap(b_all + rad.sigma_beta * noise[:, 1]))
        cols["epsilon"].append(e_all + rad.sigma_epsilon * noise[:, 2])
        feat = np.concatenate([truth.speed[det], gen.uniform(*_FEATURE_SPAN, nf)])
        cols["feature"].append(feat + rad.sigma_feature * noise[:, 3])
        cols["scan"].append(np.concatenate([truth.scan[det], np.repeat(np.arange(S), n_false)]))
        cols["radar"].append(np.full(n + nf, i))
        cols["source"].append(np.concatenate([truth.aircraft[det], np.full(nf, -1)]))
    out = {k: np.concatenate(v) for k, v in cols.items()}
    order = np.lexsort((out["source"] < 0, out["radar"], out["scan"]))
    return Reports(**{k: v[order] for k, v in out.items()}, n_scans=S)


# ----------------------------------------------------------------------------- pipeline
@dataclass(frozen=True)
class PipelineResult:
    """Output of :func:`run_pipeline`: the fused objects of every scan.

    Attributes
    ----------
    scan : numpy.ndarray of int, shape (G,)
        Scan of each declared object (a group of at least `min_reports` reports).
    members : numpy.ndarray of int, shape (G, m)
        Row indices into `reports` of the group's report from each radar (-1: none).
    position : numpy.ndarray, shape (G, 3)
        ML fused ENU position (m).
    covariance : numpy.ndarray, shape (G, 3, 3)
        Its covariance.
    speed, speed_var : numpy.ndarray, shape (G,)
        Fused speed feature (kt) and its variance.
    class_prob : numpy.ndarray, shape (G, K)
        Posterior probability of each of :data:`SPEED_CLASSES`.
    group_of : numpy.ndarray of int, shape (N,)
        For every report, the index of its group in the scan's grouping, numbered over the
        whole run (singletons included) — the full partition of the reports.
    biases : numpy.ndarray, shape (m, 3)
        Registration estimate :math:`(\\Delta r, g, \\Delta\\beta)` per radar (zeros with
        ``register=False``).
    timings : dict
        Seconds spent in each of :data:`STAGES`.
    settings : dict
        The switches and parameters used.
    reports : Reports
        The input.
    radars : tuple of Radar
        The radars used.
    report_position, report_covariance : numpy.ndarray, shape (N, 3) and (N, 3, 3)
        Every report converted (and bias-corrected) into the common frame.
    """

    scan: np.ndarray
    members: np.ndarray
    position: np.ndarray
    covariance: np.ndarray
    speed: np.ndarray
    speed_var: np.ndarray
    class_prob: np.ndarray
    group_of: np.ndarray
    biases: np.ndarray
    timings: dict = field(hash=False)
    settings: dict = field(hash=False)
    reports: Reports = field(hash=False, repr=False)
    radars: tuple = field(hash=False, repr=False, default=())
    report_position: np.ndarray | None = field(hash=False, repr=False, default=None)
    report_covariance: np.ndarray | None = field(hash=False, repr=False, default=None)

    @property
    def speed_class(self) -> np.ndarray:
        """Recognised class (index into :data:`SPEED_CLASSES`) of each object."""
        return np.argmax(self.class_prob, axis=-1)


def _convert(reports, radars, sites, biases, debias):
    """Bias-corrected, converted reports in the common frame: (N, 3) and (N, 3, 3)."""
    r, b = reports.r, reports.beta
    if biases is not None:
        bi = biases[reports.radar]
        r, b = registration.remove_biases(r, b, bi)
        r = np.abs(r)
    sr = np.array([x.sigma_r for x in radars])[reports.radar]
    sb = np.array([x.sigma_beta for x in radars])[reports.radar]
    se = np.array([x.sigma_epsilon for x in radars])[reports.radar]
    out = conversion.spherical_to_cartesian(
        r, b, reports.epsilon, sr, sb, se,
        method="measurement_conditioned" if debias else "linearized")
    return out.xyz + sites[reports.radar], out.cov


def _register(reports, radars, sites, scans, debias, opts):
    """Estimate the biases from the three-radar groups of the warm-up scans (two passes)."""
    m = len(radars)
    sel = np.isin(reports.scan, scans)
    sub = Reports(**{k: getattr(reports, k)[sel] for k in
                     ("scan", "radar", "r", "beta", "epsilon", "feature", "source")},
                  n_scans=reports.n_scans)
    biases = np.zeros((m, 3))
    est = None
    for _ in range(_REG_PASSES):
        x, cov = _convert(sub, radars, sites, biases, debias)
        _, full = _group_all(sub, x, cov, radars, opts, timings=None)
        full = full[np.all(full >= 0, axis=1)]
        if full.shape[0] < MIN_REGISTRATION_GROUPS:
            raise ValueError(
                f"`warmup`: only {full.shape[0]} groups hold a report of all {m} radars in the "
                f"{len(scans)} warm-up scans; the registration needs at least "
                f"{MIN_REGISTRATION_GROUPS} (a longer `warmup`, or `register`=False)")
        # in km: the estimator's rank test compares the information of range offsets
        # (1/sigma_r^2) with that of azimuth offsets (r^2/sigma_beta^2) on one scale
        ground = sub.r * np.cos(sub.epsilon) / 1000.0
        z = np.stack([ground[full.T], sub.beta[full.T]], axis=-1)     # (m, n, 2)
        est = registration.estimate_biases(
            sites[:, :2] / 1000.0, z, np.array([x.sigma_r for x in radars]) / 1000.0,
            np.array([x.sigma_beta for x in radars]),
            fixed=np.tile([False, True, False], (m, 1)))
        biases = est.biases * [1000.0, 1.0, 1.0]
    return biases


def _group_all(reports, x, cov, radars, opts, timings):
    """Gate and group every scan; returns (group index per report, members (G, m))."""
    m = len(radars)
    n = reports.scan.size
    use_f = opts["use_features"]
    if use_f:
        d = 4
        xf = np.concatenate([x, reports.feature[:, None]], axis=1)
        cf = np.zeros((n, 4, 4))
        cf[:, :3, :3] = cov
        cf[:, 3, 3] = np.array([r.sigma_feature for r in radars])[reports.radar] ** 2
    else:
        d, xf, cf = 3, x, cov
    span = _FEATURE_SPAN[1] - _FEATURE_SPAN[0]
    vol = np.array([r.coverage_volume for r in radars]) * (span if use_f else 1.0)
    p_detect = np.array([r.p_detect for r in radars])
    false_density = np.array([r.clutter_rate for r in radars]) / vol
    counts = np.bincount(reports.radar, minlength=m) / max(reports.n_scans, 1)
    n_obj = max(float(np.mean(np.maximum(counts - [r.clutter_rate for r in radars], 1.0)
                              / p_detect)), 1.0)
    object_density = n_obj / float(np.mean(vol))
    false_density = np.maximum(false_density, _MIN_FALSE * object_density)
    cover = np.stack([_coverage_count(x, [r]) > 0 for r in radars])      # (m, n)
    p_lo = opts["p_false_reject"]
    gamma = float(stats.chi2.isf(p_lo, d))
    p2 = float(stats.chi2.sf(gamma, 2))          # 2-D gate no tighter than the d-D one
    bounds = np.searchsorted(reports.scan, np.arange(reports.n_scans + 1))
    group_of = np.full(n, -1, dtype=np.int64)
    members = []
    next_id = 0
    t_gate = t_group = 0.0
    for s in range(reports.n_scans):
        lo, hi = bounds[s], bounds[s + 1]
        if hi == lo:
            continue
        t0 = time.perf_counter()
        rad = reports.radar[lo:hi]
        idx = [lo + np.flatnonzero(rad == i) for i in range(m)]
        linked = np.zeros(hi - lo, dtype=bool)
        for i in range(m):
            for k in range(i + 1, m):
                if idx[i].size and idx[k].size:
                    g = gating.gate_pairwise_2d(x[idx[i], :2], x[idx[k], :2],
                                                cov[idx[i], :2, :2], cov[idx[k], :2, :2],
                                                p_false_reject=p2)
                    linked[idx[i] - lo] |= g.any(axis=1)
                    linked[idx[k] - lo] |= g.any(axis=0)
        t1 = time.perf_counter()
        t_gate += t1 - t0
        sel = [ix[linked[ix - lo]] for ix in idx]
        tuples = np.empty((0, m), dtype=np.int64)
        active = [i for i in range(m) if sel[i].size]
        if len(active) >= 2:
            xs = [xf[sel[i]] for i in active]
            cs = [cf[sel[i]] for i in active]
            # detection probability averaged over the scan's report positions: P_D inside
            # the radar's coverage, 0 outside it
            pd_ = np.clip(p_detect * cover[:, lo:hi].mean(axis=1), _MIN_PD, _MAX_PD)
            g = grouping.group_sd(
                xs, cs, method=opts["method"], p_false_reject=p_lo, p_detect=pd_[active],
                false_density=false_density[active], object_density=object_density,
                logdet=opts["logdet"]).groups
            tg = np.full((g.shape[0], m), -1, dtype=np.int64)
            for c, i in enumerate(active):
                ok = g[:, c] >= 0
                tg[ok, i] = sel[i][g[ok, c]]
            tuples = tg
        used = np.zeros(hi - lo, dtype=bool)
        for c in range(m):
            v = tuples[:, c]
            used[v[v >= 0] - lo] = True
        lone = lo + np.flatnonzero(~used)
        single = np.full((lone.size, m), -1, dtype=np.int64)
        single[np.arange(lone.size), reports.radar[lone]] = lone
        allg = np.vstack([tuples, single])
        ids = next_id + np.arange(allg.shape[0])
        for c in range(m):
            v = allg[:, c]
            group_of[v[v >= 0]] = ids[v >= 0]
        next_id += allg.shape[0]
        members.append(allg)
        t_group += time.perf_counter() - t1
    if timings is not None:
        timings["gating"] += t_gate
        timings["grouping"] += t_group
    allm = np.vstack(members) if members else np.empty((0, m), dtype=np.int64)
    return group_of, allm


def run_pipeline(reports, radars, *, debias=True, register=True, logdet=True,
                 use_features=True, warmup=30, p_false_reject=1e-3, method="milp",
                 min_reports=2) -> PipelineResult:
    """The fusion centre, scan by scan: convert, register, gate, group, fuse, recognise.

    Parameters
    ----------
    reports : Reports
        From :func:`simulate_reports`.
    radars : sequence of Radar
        The radars that produced them (sites, noise levels, P_D, clutter rates).
    debias : bool, optional
        Convert with the measurement-conditioned (debiased) 3-D conversion and its
        covariance (default) or the linearized one.
    register : bool, optional
        Estimate the range and azimuth offsets (:func:`radarfusion_ref.registration.
        estimate_biases`, scale errors fixed at 0) from the groups of all radars in the
        first `warmup` scans (grouped without correction, then again with the first
        estimate), and remove them from every report (default). ``False``: no correction.
    logdet : bool, optional
        Keep the :math:`\\ln|2\\pi S|` term of the ML grouping cost (default). ``False``
        replaces it by its median over the scan's candidate groups of each size, so only
        its variation between groups is removed (:func:`radarfusion_ref.grouping.group_sd`
        with ``logdet=False``).
    use_features : bool, optional
        Group on position and speed feature (4-D reports; default) or on position only.
    warmup : int, optional
        Scans used by the registration (default 30, i.e. 5 minutes at 10 s).
    p_false_reject : float, optional
        Gate :math:`P_{\\text{lo}}` of the grouping (default 1e-3): report pairs whose
        statistic exceeds the :math:`\\chi^2_d` quantile are never grouped. The 2-D gate
        (:func:`radarfusion_ref.gating.gate_pairwise_2d` on east-north) runs first with
        the same threshold, so it removes only reports that could not pass it.
    method : {"milp", "lagrangian"}, optional
        Solver of :func:`radarfusion_ref.grouping.group_sd`: the exact integer program over
        the gated candidate groups (default; one HiGHS call per scan) or the Lagrangian
        relaxation to a proved 1 % gap (slower here: the scans split into many small
        clusters, each iterated on its own).
    min_reports : int, optional
        A group of at least this many reports is declared an object (default 2); lone
        reports are left as false reports.

    Notes
    -----
    The grouping's detection model (:func:`radarfusion_ref.grouping.group_sd` with
    `p_detect`, `false_density`, `object_density`) uses, per scan and radar, the radar's
    P_D times the share of the scan's converted reports inside its coverage (kept in
    [0.001, 0.999]); the false-report density is the radar's clutter rate over its
    coverage volume (times the 300 kt feature span with `use_features`), at least 0.001
    times the object density; the object density is estimated from the mean report
    counts, :math:`(\\bar n_i - \\lambda_i)/(P_{D,i} V_i)` averaged over the radars.

    Returns
    -------
    PipelineResult

    Raises
    ------
    TypeError
        If `reports` is not a :class:`Reports`, `radars` not a sequence of :class:`Radar`,
        or a switch not a boolean.
    ValueError
        Bad numbers (named), reports of a radar index outside `radars`, or a warm-up
        without enough three-radar groups to register.

    Examples
    --------
    >>> tr = truth_scans(load_traffic(), duration=60.0)
    >>> res = run_pipeline(simulate_reports(tr, default_radars(), rng=0), default_radars(),
    ...                    warmup=6)
    >>> sorted(res.timings) == sorted(STAGES)
    True
    """
    if not isinstance(reports, Reports):
        raise TypeError(f"`reports` must be a Reports (from simulate_reports); received "
                        f"{_describe(reports)}")
    radars = _radars_iv(radars)
    opts = {"debias": as_bool(debias, "debias"), "register": as_bool(register, "register"),
            "logdet": as_bool(logdet, "logdet"),
            "use_features": as_bool(use_features, "use_features"),
            "warmup": as_int(warmup, "warmup", minimum=1),
            "method": as_choice(method, "method", ("milp", "lagrangian")),
            "min_reports": as_int(min_reports, "min_reports", minimum=1,
                                  maximum=len(radars))}
    p = as_probability(p_false_reject, "p_false_reject")
    if p.ndim:
        raise ValueError(f"`p_false_reject` must be a number in (0, 1); received "
                         f"{_describe(p_false_reject)}")
    opts["p_false_reject"] = float(p)
    m = len(radars)
    if reports.radar.size and (reports.radar.max() >= m):
        raise ValueError(f"`reports` name radar {int(reports.radar.max())} but `radars` holds "
                         f"{m}")
    sites = np.stack([r.enu for r in radars])
    timings = dict.fromkeys(STAGES, 0.0)
    t0 = time.perf_counter()
    biases = np.zeros((m, 3))
    if opts["register"]:
        biases = _register(reports, radars, sites, np.arange(min(opts["warmup"],
                                                                 reports.n_scans)),
                           opts["debias"], opts)
    t1 = time.perf_counter()
    timings["registration"] = t1 - t0
    x, cov = _convert(reports, radars, sites, biases if opts["register"] else None,
                      opts["debias"])
    timings["conversion"] = time.perf_counter() - t1
    group_of, allm = _group_all(reports, x, cov, radars, opts, timings)
    t2 = time.perf_counter()
    size = np.sum(allm >= 0, axis=1)
    keep = size >= opts["min_reports"]
    mem = allm[keep]
    size = size[keep]
    G = mem.shape[0]
    pos = np.empty((G, 3))
    pcov = np.empty((G, 3, 3))
    spd = np.empty(G)
    svar = np.empty(G)
    fvar = np.array([r.sigma_feature for r in radars]) ** 2
    for k in np.unique(size):
        rows = np.flatnonzero(size == k)
        sub = mem[rows]
        cols = np.argsort(sub < 0, axis=1, kind="stable")[:, :k]
        ridx = np.take_along_axis(sub, cols, axis=1)                  # (g, k) report rows
        if k == 1:
            pos[rows], pcov[rows] = x[ridx[:, 0]], cov[ridx[:, 0]]
            spd[rows], svar[rows] = reports.feature[ridx[:, 0]], fvar[cols[:, 0]]
            continue
        fg = fusion.fuse_gaussian(x[ridx], cov[ridx])
        pos[rows], pcov[rows] = fg.estimate, fg.covariance
        fs = fusion.fuse(reports.feature[ridx], fvar[cols])
        spd[rows], svar[rows] = fs.estimate, fs.variance
    t3 = time.perf_counter()
    timings["fusion"] = t3 - t2
    prob = (features.type_posterior(spd, svar, np.array(SPEED_TYPE_MEANS),
                                    np.array(SPEED_TYPE_VARS)) if G else np.empty((0, 3)))
    timings["recognition"] = time.perf_counter() - t3
    scan = reports.scan[np.max(mem, axis=1)] if G else np.empty(0, dtype=np.int64)
    settings = {k: v for k, v in opts.items()}
    return PipelineResult(scan=scan, members=mem, position=pos, covariance=pcov, speed=spd,
                          speed_var=svar, class_prob=prob, group_of=group_of, biases=biases,
                          timings=timings, settings=settings, reports=reports,
                          radars=radars, report_position=x, report_covariance=cov)


# ----------------------------------------------------------------------------- metrics
@dataclass(frozen=True)
class GospaResult:
    """GOSPA between a truth set and an estimate set (α = 2).

    Attributes
    ----------
    total : float
        :math:`d_p^{(c,2)}`, in the unit of the points.
    localisation, missed, false : float
        The three parts of :math:`d^p` (they sum to ``total**p``): the sum of
        :math:`d(x, y)^p` over assigned pairs closer than `c`, :math:`c^p/2` per missed
        truth, :math:`c^p/2` per false estimate.
    n_assigned, n_missed, n_false : int
    """

    total: float
    localisation: float
    missed: float
    false: float
    n_assigned: int
    n_missed: int
    n_false: int


def _points(value, name):
    a = as_float_array(value, name)
    if a.ndim == 1 and a.size == 0:
        a = a.reshape(0, 1)
    if a.ndim != 2:
        raise ValueError(f"`{name}` must be points of shape (n, d); received shape {a.shape}")
    return a


def gospa(x, y, *, c, p=2.0, alpha=2.0) -> GospaResult:
    """Generalized OSPA metric with α = 2 and its localisation, missed and false parts.

    Parameters
    ----------
    x, y : array_like, shape (n, d) and (k, d)
        Truth and estimated points (either may be empty).
    c : float
        Cut-off distance :math:`c > 0`.
    p : float, optional
        Order :math:`1 \\le p < \\infty` (default 2).
    alpha : float, optional
        Must be 2 (the value for which GOSPA splits into the three parts).

    Returns
    -------
    GospaResult

    Raises
    ------
    ValueError
        Non-finite points, a dimension mismatch, `c` not positive, `p` < 1 or not finite,
        `alpha` other than 2.
    TypeError
        Non-numeric input.

    Notes
    -----
    .. math::

        d_p^{(c,2)}(X, Y) = \\Big(\\min_{\\gamma} \\sum_{(i,j)\\in\\gamma} d(x_i, y_j)^p
        + \\frac{c^p}{2}\\big(|X| + |Y| - 2|\\gamma|\\big)\\Big)^{1/p},

    the minimum over partial assignments :math:`\\gamma` of pairs closer than :math:`c`
    (Rahmathullah et al. 2017). It is found as a rectangular linear assignment
    (:func:`scipy.optimize.linear_sum_assignment`) on :math:`\\min(d, c)^p`: a pair at
    distance :math:`\\ge c` costs :math:`c^p`, exactly one miss plus one false estimate.

    Examples
    --------
    >>> g = gospa([[0.0, 0.0], [10.0, 0.0]], [[1.0, 0.0]], c=5.0)
    >>> g.total ** 2, g.localisation, g.missed, g.false
    (13.5, 1.0, 12.5, 0.0)
    """
    x = _points(x, "x")
    y = _points(y, "y")
    if x.size and y.size and x.shape[1] != y.shape[1]:
        raise ValueError(f"`x` and `y` must have the same dimension; received shapes "
                         f"{x.shape} and {y.shape}")
    c = _scalar(c, "c")
    p = _scalar(p, "p")
    if p < 1 or not math.isfinite(p):
        raise ValueError(f"`p` must be a finite number >= 1; received {p!r}")
    a = _scalar(alpha, "alpha")
    if a != 2.0:
        raise ValueError(f"`alpha` must be 2 (the decomposable GOSPA); received {alpha!r}")
    n, k = x.shape[0], y.shape[0]
    check_size(8 * 3 * n * k * max(x.shape[1], 1), MEMORY_LIMIT,
               what=f"bytes of the distance matrix of {n} x {k} points (`x`, `y`)",
               alternative="scoring smaller sets (one scan at a time, or spatial regions)")
    loc, assigned = 0.0, 0
    if n and k:
        dist = np.linalg.norm(x[:, None, :] - y[None, :, :], axis=-1)
        cost = np.minimum(dist, c) ** p
        ri, ci = linear_sum_assignment(cost)
        close = dist[ri, ci] < c
        assigned = int(close.sum())
        loc = float(np.sum(dist[ri, ci][close] ** p))
    missed = (n - assigned) * c**p / 2.0
    false = (k - assigned) * c**p / 2.0
    return GospaResult(total=float((loc + missed + false) ** (1.0 / p)), localisation=loc,
                       missed=float(missed), false=float(false), n_assigned=assigned,
                       n_missed=n - assigned, n_false=k - assigned)


@dataclass(frozen=True)
class Evaluation:
    """Scores of a :class:`PipelineResult` against the truth.

    Attributes
    ----------
    times : numpy.ndarray, shape (S,)
        Scan times (s).
    gospa, localisation, missed, false : numpy.ndarray, shape (S,)
        Per scan: GOSPA (m) and its three parts (m^p; they sum to ``gospa**p``).
    c, p : float
        GOSPA cut-off (m) and order (α = 2).
    purity : Proportion or None
        Fraction of declared objects whose reports all come from one aircraft (None
        without declared objects; likewise below when there is nothing to count).
    completeness : Proportion
        Fraction of (aircraft, scan) pairs with at least one report whose reports form
        exactly one group of the grouping (all of them together, nothing else; a lone
        report counts when it is left alone).
    nees : tuple or None
        ``(mean, low, high, count)``: mean 3-D NEES of the pure objects and the
        two-sided 95 % interval of that mean under :math:`\\chi^2_3` errors,
        :math:`[\\chi^2_{3N}(0.025), \\chi^2_{3N}(0.975)]/N`.
    recognition : Proportion or None
        Fraction of pure objects whose most probable class is the aircraft's.
    timings : dict
        The pipeline's stage times plus "metrics".
    """

    times: np.ndarray
    gospa: np.ndarray
    localisation: np.ndarray
    missed: np.ndarray
    false: np.ndarray
    c: float
    p: float
    purity: Proportion
    completeness: Proportion
    nees: tuple
    recognition: Proportion
    timings: dict = field(hash=False)

    @property
    def mean_gospa(self) -> float:
        """Mean over scans of the per-scan GOSPA (m)."""
        return float(np.mean(self.gospa))

    def parts_rms(self) -> dict:
        """Each part and the total as a length: the p-th root of its mean over scans (m)."""
        out = {k: float(np.mean(getattr(self, k)) ** (1.0 / self.p))
               for k in ("localisation", "missed", "false")}
        out["total"] = float(np.mean(self.gospa ** self.p) ** (1.0 / self.p))
        return out


def _errors_against_truth(truth, scan, aircraft, position, covariance):
    """Estimates of known aircraft against the truth of their scan.

    Returns the truth rows, the position errors and the NEES summary ``(mean, low, high,
    N)``, where ``[low, high]`` is the central 95 % range of the mean of ``N`` χ²₃ values
    (what a consistent covariance gives).
    """
    base = len(truth.icao24) + 1
    tkey = truth.scan.astype(np.int64) * base + truth.aircraft
    ti = np.searchsorted(tkey, np.asarray(scan, dtype=np.int64) * base + aircraft)
    err = position - truth.position[ti]
    nees = np.einsum("ka,ka->k", err, np.linalg.solve(covariance, err[..., None])[..., 0])
    N = nees.size
    return ti, err, (float(nees.mean()), float(stats.chi2.ppf(0.025, 3 * N) / N),
                     float(stats.chi2.ppf(0.975, 3 * N) / N), N)


def evaluate(result, truth, *, c=2000.0, p=2.0, scope="covered") -> Evaluation:
    """Score a pipeline run against the truth: GOSPA per scan, association, NEES, recognition.

    Parameters
    ----------
    result : PipelineResult
    truth : TruthScans
        The truth the reports were simulated from.
    c : float, optional
        GOSPA cut-off (m, default 2000: an estimate further than 2 km from every aircraft
        is false).
    p : float, optional
        GOSPA order (default 2); α = 2.
    scope : {"covered", "all"}, optional
        Truth set of GOSPA: the aircraft inside the coverage (range and elevation limits)
        of at least ``min_reports`` radars — those the fusion centre can declare
        (default) — or every aircraft of the window.

    Returns
    -------
    Evaluation

    Raises
    ------
    TypeError
        If `result` or `truth` has the wrong type.
    ValueError
        Bad `c` or `p`, or a truth whose scan count differs from the reports'.

    Notes
    -----
    GOSPA compares the truth positions of each scan (every aircraft in the window, also
    those no radar covers) with the declared objects. NEES uses the pure objects:
    :math:`(\\hat x - x)^T P^{-1} (\\hat x - x)`, 3 degrees of freedom.
    """
    if not isinstance(result, PipelineResult):
        raise TypeError(f"`result` must be a PipelineResult (from run_pipeline); received "
                        f"{_describe(result)}")
    if not isinstance(truth, TruthScans):
        raise TypeError(f"`truth` must be a TruthScans (from truth_scans); received "
                        f"{_describe(truth)}")
    c = _scalar(c, "c")
    p = _scalar(p, "p")
    if p < 1:
        raise ValueError(f"`p` must be >= 1; received {p!r}")
    scope = as_choice(scope, "scope", ("covered", "all"))
    rep = result.reports
    if truth.n_scans != rep.n_scans:
        raise ValueError(f"`truth` has {truth.n_scans} scans but the result's reports "
                         f"{rep.n_scans}")
    t0 = time.perf_counter()
    S = truth.n_scans
    tb = np.searchsorted(truth.scan, np.arange(S + 1))
    order = np.argsort(result.scan, kind="stable")
    rb = np.searchsorted(result.scan[order], np.arange(S + 1))
    keep = np.ones(truth.scan.size, dtype=bool)
    if scope == "covered":
        keep = _coverage_count(truth.position, result.radars) >= result.settings["min_reports"]
    parts = np.zeros((S, 4))
    for s in range(S):
        g = gospa(truth.position[tb[s]:tb[s + 1]][keep[tb[s]:tb[s + 1]]],
                  result.position[order[rb[s]:rb[s + 1]]], c=c, p=p)
        parts[s] = g.total, g.localisation, g.missed, g.false
    # association
    mem = result.members
    src = np.where(mem >= 0, rep.source[np.maximum(mem, 0)], -2)
    first = src[np.arange(mem.shape[0]), np.argmax(mem >= 0, axis=1)]
    pure = (first >= 0) & np.all((src == first[:, None]) | (mem < 0), axis=1)
    purity = proportion(int(pure.sum()), mem.shape[0]) if mem.shape[0] else None
    real = rep.source >= 0
    key = rep.scan[real].astype(np.int64) * (len(truth.icao24) + 1) + rep.source[real]
    grp = result.group_of[real]
    uk, inv = np.unique(key, return_inverse=True)
    gmin = np.full(uk.size, np.iinfo(np.int64).max)
    gmax = np.full(uk.size, -1)
    np.minimum.at(gmin, inv, grp)
    np.maximum.at(gmax, inv, grp)
    one_group = gmin == gmax
    gsize = np.bincount(result.group_of[result.group_of >= 0])
    nrep = np.bincount(inv)
    ok = one_group & (gsize[gmin.clip(0, gsize.size - 1)] == nrep)
    completeness = proportion(int(ok.sum()), uk.size) if uk.size else None
    # NEES and recognition on pure objects
    if pure.any():
        ti, _, nees_t = _errors_against_truth(truth, result.scan[pure], first[pure],
                                              result.position[pure], result.covariance[pure])
        N = nees_t[3]
        correct = result.speed_class[pure] == truth.speed_class[ti]
        recognition = proportion(int(correct.sum()), N)
    else:
        nees_t = None
        recognition = None
    timings = dict(result.timings)
    timings["metrics"] = time.perf_counter() - t0
    return Evaluation(times=truth.times, gospa=parts[:, 0], localisation=parts[:, 1],
                      missed=parts[:, 2], false=parts[:, 3], c=c, p=p, purity=purity,
                      completeness=completeness, nees=nees_t, recognition=recognition,
                      timings=timings)


# ----------------------------------------------------------------------------- tracking
@dataclass(frozen=True)
class TrackFusionResult:
    """Fused tracks of every scan (one row per confirmed track and scan).

    Attributes
    ----------
    scan, track : numpy.ndarray of int, shape (R,)
        Scan and track number of each row.
    position : numpy.ndarray, shape (R, 3)
        Track-to-track fused position (m).
    covariance : numpy.ndarray, shape (R, 3, 3)
        Its covariance under the fusion rule.
    source : numpy.ndarray of int, shape (R,)
        Truth label: the aircraft whose reports alone made the object the track was
        updated with at this scan; -1 when that object mixed sources or the track coasted.
    rule : str
        ``"ci"`` (covariance intersection) or ``"naive"`` (independence assumed).
    n_scans : int
    seconds : float
        Wall time of the tracking stage.
    """

    scan: np.ndarray
    track: np.ndarray
    position: np.ndarray
    covariance: np.ndarray
    source: np.ndarray
    rule: str
    n_scans: int
    seconds: float


#: Cost of leaving a track or an object unlinked: far above any gated pair's cost, so the
#: link takes as many gated pairs as it can, then the likeliest.
_LINK_MISS = 1e6


def _kf_update(x, P, z, R):
    """Kalman update of (k, 6) states with (k, 3) position reports."""
    S = P[:, :3, :3] + R
    K = np.linalg.solve(S, P[:, :3, :])                         # (k, 3, 6) = S^-1 H P
    K = np.swapaxes(K, -1, -2)                                  # P H^T S^-1
    x = x + np.einsum("kab,kb->ka", K, z - x[:, :3])
    P = P - K @ P[:, :3, :]
    return x, 0.5 * (P + np.swapaxes(P, -1, -2))


def track_fusion(result, *, period=10.0, q=10.0, rule="ci", confirm=2, max_misses=2,
                 p_false_reject=1e-3) -> TrackFusionResult:
    """Step 7: a track per aircraft, one local track per radar, fused track to track.

    Parameters
    ----------
    result : PipelineResult
        The fused objects of :func:`run_pipeline` (and the converted reports it keeps).
    period : float, optional
        Scan period (s, default 10), as given to :func:`truth_scans`.
    q : float, optional
        Process-noise intensity of the constant-velocity model (m²/s³, default 10:
        :func:`radarfusion_ref.trackfusion.constant_velocity`, continuous white noise).
    rule : {"ci", "naive"}, optional
        Track-to-track fusion: :func:`radarfusion_ref.trackfusion.covariance_intersection`
        (sequentially over the radars; default) or
        :func:`radarfusion_ref.trackfusion.naive_fusion`, which assumes the local tracks'
        errors independent although they share the process noise.
    confirm : int, optional
        Updates before a track is reported (default 2).
    max_misses : int, optional
        Consecutive scans without an object before a track is dropped (default 2).
    p_false_reject : float, optional
        Gate of the scan-to-scan link (default 1e-3): an object joins a track only if
        its statistic against the predicted track is below the :math:`\\chi^2_3` quantile.

    Returns
    -------
    TrackFusionResult

    Raises
    ------
    TypeError
        If `result` is not a :class:`PipelineResult` with its converted reports.
    ValueError
        Bad `q`, `rule`, `confirm`, `max_misses` or `p_false_reject`.

    Notes
    -----
    Each scan: the fused track of every live track is predicted over the period
    by the constant-velocity model and linked to the scan's objects by an exact gated
    assignment (:func:`radarfusion_ref.engine.assignment.solve_2d`): pairs whose Mahalanobis
    statistic passes the gate cost :math:`\\kappa + \\ln|2\\pi S|` (the full negative
    log-likelihood, so that a young, uncertain track cannot take a confident track's
    object), and the link takes as many gated pairs as possible. A linked track updates the
    local filter of every radar that has a report in the object (a Kalman update with the
    report's converted covariance; a radar's first report starts its local track from the
    fused velocity), then fuses its local tracks. Unlinked objects start tracks (velocity
    0 ± 250 m/s); unlinked tracks coast and are dropped after `max_misses` scans.
    """
    t0 = time.perf_counter()
    if not isinstance(result, PipelineResult) or result.report_position is None:
        raise TypeError(f"`result` must be a PipelineResult from run_pipeline; received "
                        f"{_describe(result)}")
    period = _scalar(period, "period")
    q = _scalar(q, "q")
    rule = as_choice(rule, "rule", ("ci", "naive"))
    confirm = as_int(confirm, "confirm", minimum=1)
    max_misses = as_int(max_misses, "max_misses", minimum=0)
    p_lo = as_probability(p_false_reject, "p_false_reject")
    if p_lo.ndim:
        raise ValueError(f"`p_false_reject` must be a number in (0, 1); received "
                         f"{_describe(p_false_reject)}")
    gamma = float(stats.chi2.isf(float(p_lo), 3))
    rep = result.reports
    m = result.members.shape[1]
    model = trackfusion.constant_velocity(period, q, dim=3)
    F, Q = model.F, model.Q
    v0 = 250.0 ** 2
    xr, cr = result.report_position, result.report_covariance
    src = np.where(result.members >= 0, rep.source[np.maximum(result.members, 0)], -2)
    first = src[np.arange(src.shape[0]), np.argmax(result.members >= 0, axis=1)]
    pure = (first >= 0) & np.all((src == first[:, None]) | (result.members < 0), axis=1)
    label = np.where(pure, first, -1)
    # live tracks
    X = np.zeros((0, m, 6))
    P = np.zeros((0, m, 6, 6))
    act = np.zeros((0, m), dtype=bool)
    XF = np.zeros((0, 6))
    PF = np.zeros((0, 6, 6))
    hits = np.zeros(0, dtype=np.int64)
    miss = np.zeros(0, dtype=np.int64)
    ids = np.zeros(0, dtype=np.int64)
    next_id = 0
    order = np.argsort(result.scan, kind="stable")
    bounds = np.searchsorted(result.scan[order], np.arange(rep.n_scans + 1))
    out = []
    for s in range(rep.n_scans):
        obj = order[bounds[s]:bounds[s + 1]]
        # predict
        X = X @ F.T
        P = F @ P @ F.T + Q
        XF = XF @ F.T
        PF = F @ PF @ F.T + Q
        k, g = XF.shape[0], obj.size
        link = np.full(k, -1)
        if k and g:
            D = result.position[obj][None, :, :] - XF[:, None, :3]
            S = PF[:, None, :3, :3] + result.covariance[obj][None]
            kappa = np.einsum("kga,kga->kg", D, np.linalg.solve(S, D[..., None])[..., 0])
            # full negative log-likelihood (with ln|2 pi S|): a confident track keeps its
            # object against a young, uncertain one; pairs outside the gate are forbidden
            cost = np.where(kappa < gamma, kappa + np.linalg.slogdet(2 * np.pi * S)[1],
                            np.inf)
            link = assignment.solve_2d(cost, miss_cost=_LINK_MISS).row_to_col
        linked = link >= 0
        # update the linked tracks' local filters
        for i in range(m):
            rows = np.flatnonzero(linked)
            rr = result.members[obj[link[rows]], i]
            has = rr >= 0
            rows, rr = rows[has], rr[has]
            new = ~act[rows, i]
            if new.any():
                nr = rows[new]
                X[nr, i, :3], X[nr, i, 3:] = xr[rr[new]], XF[nr, 3:]
                P[nr, i] = 0.0
                P[nr, i, :3, :3] = cr[rr[new]]
                P[nr, i, 3:, 3:] = PF[nr, 3:, 3:]
                act[nr, i] = True
            old = ~new
            if old.any():
                X[rows[old], i], P[rows[old], i] = _kf_update(
                    X[rows[old], i], P[rows[old], i], xr[rr[old]], cr[rr[old]])
        hits[linked] += 1
        miss[linked] = 0
        miss[~linked] += 1
        keep = miss <= max_misses
        # fuse the local tracks of the linked tracks
        rows = np.flatnonzero(linked)
        if rows.size:
            fx, fp = _fuse_local(X[rows], P[rows], act[rows], rule)
            XF[rows], PF[rows] = fx, fp
        # start tracks from unlinked objects
        used = np.zeros(g, dtype=bool)
        used[link[linked]] = True
        fresh = obj[~used]
        nf = fresh.size
        if nf:
            Xn = np.zeros((nf, m, 6))
            Pn = np.zeros((nf, m, 6, 6))
            an = result.members[fresh] >= 0
            for i in range(m):
                rr = result.members[fresh, i]
                h = rr >= 0
                Xn[h, i, :3] = xr[rr[h]]
                Pn[h, i, :3, :3] = cr[rr[h]]
                Pn[:, i, 3:, 3:] = v0 * np.eye(3)
                Pn[~h, i, :3, :3] = np.eye(3)
            XFn = np.zeros((nf, 6))
            XFn[:, :3] = result.position[fresh]
            PFn = np.zeros((nf, 6, 6))
            PFn[:, :3, :3] = result.covariance[fresh]
            PFn[:, 3:, 3:] = v0 * np.eye(3)
            X, P, act = (np.concatenate([X[keep], Xn]), np.concatenate([P[keep], Pn]),
                         np.concatenate([act[keep], an]))
            XF, PF = np.concatenate([XF[keep], XFn]), np.concatenate([PF[keep], PFn])
            lab_t = np.concatenate([np.where(linked, label[obj[np.maximum(link, 0)]]
                                             if g else -1, -1)[keep], label[fresh]])
            hits = np.concatenate([hits[keep], np.ones(nf, dtype=np.int64)])
            miss = np.concatenate([miss[keep], np.zeros(nf, dtype=np.int64)])
            ids = np.concatenate([ids[keep], next_id + np.arange(nf)])
            next_id += nf
        else:
            X, P, act, XF, PF = X[keep], P[keep], act[keep], XF[keep], PF[keep]
            lab_t = np.where(linked, label[obj[np.maximum(link, 0)]] if g else -1, -1)[keep]
            hits, miss, ids = hits[keep], miss[keep], ids[keep]
        show = hits >= confirm
        out.append((np.full(int(show.sum()), s), ids[show], XF[show, :3], PF[show, :3, :3],
                    lab_t[show]))
    cols = [np.concatenate(c) if c else np.empty(0) for c in zip(*out, strict=True)]
    return TrackFusionResult(scan=cols[0].astype(np.int64), track=cols[1].astype(np.int64),
                             position=cols[2].reshape(-1, 3),
                             covariance=cols[3].reshape(-1, 3, 3),
                             source=cols[4].astype(np.int64), rule=rule,
                             n_scans=rep.n_scans, seconds=time.perf_counter() - t0)


def _fuse_local(X, P, act, rule):
    """Fuse the active local tracks (k, m, 6) of each track into one (k, 6)."""
    k, m = act.shape
    fx = np.zeros((k, 6))
    fp = np.zeros((k, 6, 6))
    have = np.zeros(k, dtype=bool)
    for i in range(m):
        a = act[:, i]
        start = a & ~have
        fx[start], fp[start] = X[start, i], P[start, i]
        both = a & have
        if both.any():
            if rule == "ci":
                r = trackfusion.covariance_intersection(fx[both], fp[both], X[both, i],
                                                        P[both, i])
            else:
                r = trackfusion.naive_fusion(fx[both], fp[both], X[both, i], P[both, i])
            fx[both], fp[both] = r.estimate, r.covariance
        have |= a
    return fx, fp


@dataclass(frozen=True)
class TrackEvaluation:
    """Scores of a :class:`TrackFusionResult` against the truth.

    Attributes
    ----------
    gospa, localisation, missed, false : numpy.ndarray, shape (S,)
        Per scan, as in :class:`Evaluation`.
    c, p : float
    nees : tuple or None
        ``(mean, low, high, count)`` of the 3-D NEES of the labelled rows (a track row
        whose object came from one aircraft), with the 95 % interval of the mean under
        :math:`\\chi^2_3` errors.
    rmse : float or None
        Root-mean-square position error of those rows (m).
    n_tracks : int
        Tracks reported at least once.
    """

    gospa: np.ndarray
    localisation: np.ndarray
    missed: np.ndarray
    false: np.ndarray
    c: float
    p: float
    nees: tuple | None
    rmse: float | None
    n_tracks: int

    @property
    def mean_gospa(self) -> float:
        """Mean over scans of the per-scan GOSPA (m)."""
        return float(np.mean(self.gospa))


def evaluate_tracks(tracks, truth, radars, *, c=2000.0, p=2.0, min_radars=2) -> TrackEvaluation:
    """Score fused tracks against the truth: GOSPA per scan, NEES and RMSE.

    Parameters
    ----------
    tracks : TrackFusionResult
    truth : TruthScans
    radars : sequence of Radar
        For the GOSPA truth set: the aircraft inside the coverage of at least
        `min_radars` of them (as :func:`evaluate` with ``scope="covered"``).
    c, p : float, optional
        GOSPA cut-off (m, default 2000) and order (default 2); α = 2.
    min_radars : int, optional
        Default 2.

    Returns
    -------
    TrackEvaluation

    Raises
    ------
    TypeError
        Wrong types of `tracks`, `truth` or `radars`.
    ValueError
        Bad `c`, `p` or `min_radars`, or scan counts that differ.
    """
    if not isinstance(tracks, TrackFusionResult):
        raise TypeError(f"`tracks` must be a TrackFusionResult (from track_fusion); received "
                        f"{_describe(tracks)}")
    if not isinstance(truth, TruthScans):
        raise TypeError(f"`truth` must be a TruthScans (from truth_scans); received "
                        f"{_describe(truth)}")
    radars = _radars_iv(radars)
    c = _scalar(c, "c")
    p = _scalar(p, "p")
    min_radars = as_int(min_radars, "min_radars", minimum=1, maximum=len(radars))
    if truth.n_scans != tracks.n_scans:
        raise ValueError(f"`truth` has {truth.n_scans} scans but `tracks` {tracks.n_scans}")
    keep = _coverage_count(truth.position, radars) >= min_radars
    S = truth.n_scans
    tb = np.searchsorted(truth.scan, np.arange(S + 1))
    rb = np.searchsorted(tracks.scan, np.arange(S + 1))
    parts = np.zeros((S, 4))
    for s in range(S):
        g = gospa(truth.position[tb[s]:tb[s + 1]][keep[tb[s]:tb[s + 1]]],
                  tracks.position[rb[s]:rb[s + 1]], c=c, p=p)
        parts[s] = g.total, g.localisation, g.missed, g.false
    ok = tracks.source >= 0
    nees_t, rmse = None, None
    if ok.any():
        _, err, nees_t = _errors_against_truth(truth, tracks.scan[ok], tracks.source[ok],
                                               tracks.position[ok], tracks.covariance[ok])
        rmse = float(np.sqrt(np.mean(np.sum(err**2, axis=1))))
    return TrackEvaluation(gospa=parts[:, 0], localisation=parts[:, 1], missed=parts[:, 2],
                           false=parts[:, 3], c=c, p=p, nees=nees_t, rmse=rmse,
                           n_tracks=int(np.unique(tracks.track).size))
