r"""A continental scenario, generated, seeded and offline: flights over Europe and radars.

The Swiss hour of :mod:`radarfusion_ref.capstone` has about 40 aircraft in the air at once
and three radars. This module makes the scene of the chapter "A continent in real time":
flights between real European airports (:func:`load_airports`, a committed extract of the
``airportsdata`` package) and a network of radars (at least 30), with one parameter,
`scale`, such that about ``40 * scale`` aircraft are airborne at any instant of the window.

**The common frame.** Over :math:`\pm 2000` km a flat east-north-up frame about one origin
tilts the local vertical by up to 18°: a level aircraft far from the origin would climb or
sink at tens of m/s in it. The scene lives instead in a *conformal map frame* about
:data:`ORIGIN`: :math:`x, y` are the stereographic projection of the WGS-84 latitude and
longitude, through Gauss's conformal sphere (the conformal latitude :math:`\chi` of the
geodetic latitude :math:`\varphi`, on a sphere of radius :math:`R = N_0\cos\varphi_0 /
\cos\chi_0`, so that the scale is exactly 1 at the origin), onto the plane tangent at the
origin; :math:`z` is the height above the WGS-84 ellipsoid. Both steps are conformal, so
the map is (angles and turn rates are kept; lengths are scaled by :func:`map_scale`, from
1 at the origin to about 1.03 at 2000 km). A level aircraft has zero vertical velocity in
it, and its map speed is its ground speed times the scale.

The flights are defined in the map frame (straight legs, arcs and a height profile,
:class:`Flights`); each radar sees the truth through the inverse map, Earth-centred
coordinates and its own east-north-up frame; each report goes back to the map frame with
its covariance through the Jacobian of the whole chain (:func:`polar_to_map`).

:func:`simulate_continent` gives reports ready for
:func:`radarfusion_ref.tracking.track_reports` and :func:`truth_samples` the truth for
:func:`radarfusion_ref.tracking.evaluate_tracks`, both in map metres.

**Scale.** With the default 60 radars, an hour at scale 100 holds about 4000 aircraft
airborne at once and 5 million reports, simulated in windows under the memory limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..capstone import Radar
from ..engine.validation import (
    MEMORY_LIMIT,
    as_bool,
    as_choice,
    as_float,
    as_float_array,
    as_int,
    as_positive,
    as_rng,
    as_seed_sequence,
    check_size,
    describe,
)
from . import _flights, _registration, _reports, _scene
from ._frame import conformal_latitude, frame_of, radii

__all__ = [
    "AIRPORTS_FILE",
    "ORIGIN",
    "SWISS_AIRBORNE",
    "RADAR_DRAWS",
    "Airports",
    "ContinentBiases",
    "ContinentReports",
    "ContinentScenario",
    "Flights",
    "airborne_count",
    "continent_scenario",
    "expected_reports",
    "from_map",
    "load_airports",
    "map_scale",
    "polar_to_map",
    "register_continent",
    "simulate_continent",
    "to_map",
    "truth_at",
    "truth_samples",
]

#: Origin of the map frame: (latitude, longitude) in degrees, the middle of the airports' box
#: (latitude 36..62, longitude -10..30).
ORIGIN = (49.0, 10.0)
#: The committed airports (CSV with a ``#`` header line naming its source; made by
#: ``data/make_airports.py`` from the ``airportsdata`` package, MIT licence).
AIRPORTS_FILE = _scene.AIRPORTS_FILE
#: Ranges (uniform) of the radars' drawn parameters: scan period (s), coverage (m), range
#: noise (m), azimuth and elevation noise (deg), detection probability, false reports per
#: scan; and the standard deviations (normal, mean 0) of the biases: range offset (m), range
#: scale, azimuth offset (deg).
RADAR_DRAWS = _scene.RADAR_DRAWS
#: Aircraft airborne at once in the Swiss hour of the capstone: ``scale = 1``.
SWISS_AIRBORNE = 40
SITINGS = ("planned", "spread")  #: Where :func:`continent_scenario` puts the radars.
#: Bytes of :func:`simulate_continent` per report at its peak, counted against the memory
#: limit: the per-radar pieces (152: time, position, covariance, radar, scan, aircraft,
#: polar), the sorted output being filled (up to 152), the covariance's joined copy while it
#: is sorted (72) and the order (8). Measured: 2.19 million reports (scale 100, one hour)
#: peak at 344 bytes each above the interpreter's baseline; 384 leaves a margin.
_REPORT_BYTES = 8 * 48
#: Bytes of work per (aircraft, scan) pair a radar examines, and per (flight, instant) of
#: :func:`truth_at`.
_PAIR_BYTES = 8 * 40
#: Bytes per flight of a scenario (its arrays and the draws' working copies).
_FLIGHT_BYTES = 8 * 64


# --------------------------------------------------------------------------------- airports
@dataclass(frozen=True)
class Airports:
    """Airports, one row each.

    Attributes
    ----------
    icao, iata, name : numpy.ndarray of str, shape (k,)
    lat, lon : numpy.ndarray, shape (k,)
        Reference point (degrees).
    elevation : numpy.ndarray, shape (k,)
        Above mean sea level (m); the scene takes it as the height above the ellipsoid
        (the geoid lies 40–55 m above it over Europe, immaterial to a simulation).
    """

    icao: np.ndarray
    iata: np.ndarray
    name: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    elevation: np.ndarray

    def __len__(self) -> int:
        return int(self.lat.size)


def load_airports() -> Airports:
    """The committed European airports with an IATA code (731 of them).

    From the PyPI package ``airportsdata`` (MIT licence, ``data/airports_LICENSE.txt``),
    extracted by ``data/make_airports.py``: ICAO code of the European regions (E, L),
    reference point in latitude 36..62°, longitude -10..30°, heliports left out.

    Returns
    -------
    Airports

    Examples
    --------
    >>> ap = load_airports()
    >>> str(ap.icao[ap.iata == "ZRH"][0]), len(ap) > 500
    ('LSZH', True)
    """
    return Airports(**_scene.airports())


# -------------------------------------------------------------------------------- map frame
def _origin_iv(origin):
    o = as_float_array(origin, "origin")
    if o.shape != (2,) or abs(o[0]) > 80 or abs(o[1]) > 180:
        raise ValueError(f"`origin` must be (lat, lon) in degrees, |lat| <= 80 and |lon| <= "
                         f"180; received {describe(origin)}")
    return frame_of(float(o[0]), float(o[1]))


def _latlon_iv(lat, lon):
    lat, lon = as_float_array(lat, "lat"), as_float_array(lon, "lon")
    for name, arr, lim in (("lat", lat, 85.0), ("lon", lon, 180.0)):
        if np.any(np.abs(arr) > lim):
            raise ValueError(f"`{name}` must lie in [-{lim:g}, {lim:g}] degrees; received "
                             f"{describe(arr)}")
    return lat, lon


def to_map(lat, lon, h, *, origin=ORIGIN) -> np.ndarray:
    r"""Geodetic coordinates to the continental map frame (m).

    Parameters
    ----------
    lat, lon : array_like
        WGS-84 latitude in [-85, 85] and longitude in [-180, 180] (degrees).
    h : array_like
        Height above the ellipsoid (m). The three broadcast together.
    origin : (float, float), optional
        The frame's origin (lat, lon), default :data:`ORIGIN`.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        :math:`(x, y, z)`: the stereographic projection through Gauss's conformal sphere
        (east, north at the origin) and :math:`z = h`.

    Raises
    ------
    ValueError, TypeError
        Non-numeric or non-finite input, latitudes or longitudes out of range, shapes that
        do not broadcast, a bad `origin`.

    Notes
    -----
    With the conformal latitude
    :math:`\chi = 2\arctan\big(\tan(\tfrac\pi4 + \tfrac\varphi2)
    (\tfrac{1 - e\sin\varphi}{1 + e\sin\varphi})^{e/2}\big) - \tfrac\pi2`,
    :math:`\Delta\lambda = \lambda - \lambda_0` and
    :math:`k' = 2R / (1 + \sin\chi_0\sin\chi + \cos\chi_0\cos\chi\cos\Delta\lambda)`:

    .. math::

        x = k'\cos\chi\sin\Delta\lambda, \qquad
        y = k'(\cos\chi_0\sin\chi - \sin\chi_0\cos\chi\cos\Delta\lambda), \qquad z = h.

    References: J. P. Snyder, *Map Projections — A Working Manual*, USGS Professional
    Paper 1395 (1987), eqs. (3-1) and (21-2)–(21-4).

    Examples
    --------
    >>> np.round(to_map(49.0, 10.0, 100.0), 6)
    array([  0.,   0., 100.])
    >>> bool(np.allclose(from_map(to_map(47.46, 8.55, 432.0)), [47.46, 8.55, 432.0]))
    True
    """
    frame = _origin_iv(origin)
    lat, lon = _latlon_iv(lat, lon)
    h = as_float_array(h, "h")
    try:
        lat, lon, h = np.broadcast_arrays(lat, lon, h)
    except ValueError:
        raise ValueError(f"`lat`, `lon` and `h` must broadcast; received shapes {lat.shape}, "
                         f"{lon.shape}, {h.shape}") from None
    return frame.forward(lat, lon, h)


def from_map(xyz, *, origin=ORIGIN) -> np.ndarray:
    """The continental map frame back to geodetic coordinates: the inverse of :func:`to_map`.

    Parameters
    ----------
    xyz : array_like, shape (..., 3)
        Map coordinates (m), with :math:`x^2 + y^2 < (4R)^2` (:math:`R` about 6390 km:
        the antipode of the origin is at infinity).
    origin : (float, float), optional
        As :func:`to_map`.

    Returns
    -------
    numpy.ndarray, shape (..., 3)
        Latitude, longitude (degrees) and height above the ellipsoid (m).

    Raises
    ------
    ValueError, TypeError
        Non-numeric or non-finite input, a last axis other than 3, points beyond
        :math:`4R` of the origin, a bad `origin`.

    Examples
    --------
    >>> np.round(from_map([0.0, 0.0, 10.0]), 9)
    array([49., 10., 10.])
    """
    frame = _origin_iv(origin)
    p = as_float_array(xyz, "xyz", ndim_min=1, last_dims=(3,))
    if np.any(np.hypot(p[..., 0], p[..., 1]) >= 4 * frame.radius):
        raise ValueError(f"`xyz`: points must lie within {4 * frame.radius:.6g} m of the "
                         f"origin (the map of the sphere minus the antipode); received "
                         f"{describe(p)}")
    return frame.inverse(p)


def map_scale(lat, lon, *, origin=ORIGIN) -> np.ndarray:
    r"""The map's scale factor at ground points: map metres per ground metre, any direction.

    Parameters
    ----------
    lat, lon : array_like
        As :func:`to_map` (broadcast together).
    origin : (float, float), optional
        As :func:`to_map`.

    Returns
    -------
    numpy.ndarray
        :math:`k = \dfrac{2}{1 + \cos c}\,\dfrac{R\cos\chi}{N\cos\varphi}`,
        :math:`\cos c = \sin\chi_0\sin\chi + \cos\chi_0\cos\chi\cos\Delta\lambda` (the
        stereographic scale of the sphere times the ellipsoid-to-sphere scale;
        :math:`N` the prime-vertical radius). 1 at the origin.

    Raises
    ------
    ValueError, TypeError
        As :func:`to_map`.

    Examples
    --------
    >>> float(np.round(map_scale(49.0, 10.0), 12))
    1.0
    >>> 1.02 < float(map_scale(36.0, -10.0)) < 1.04
    True
    """
    frame = _origin_iv(origin)
    lat, lon = _latlon_iv(lat, lon)
    phi = np.radians(lat)
    chi = conformal_latitude(phi)
    cos_c = frame.s0 * np.sin(chi) + frame.c0 * np.cos(chi) * np.cos(
        np.radians(lon) - frame.lam0)
    return 2.0 / (1.0 + cos_c) * frame.radius * np.cos(chi) / (radii(phi)[1] * np.cos(phi))


# ---------------------------------------------------------------------------------- flights
@dataclass(frozen=True)
class Flights:
    r"""The flights of a continental scenario, one row per flight, in the map frame.

    A flight takes off from :math:`A` towards a waypoint :math:`W` off the direct line,
    turns at :math:`W` at the constant rate :math:`\omega` (an arc of radius
    :math:`v/\omega`, tangent to both legs), flies on to :math:`B`, all at the one
    horizontal speed :math:`v`; its height :math:`s` seconds after take-off is
    :math:`z(s) = \min(z_A + c\,s,\ z_c,\ z_B + q\,(T - s))`. Drawn (uniformly): the airports
    (great-circle map distance 300–2500 km), the waypoint at 0.3–0.7 of the line and off it
    by 5–15 % of its length, :math:`v` 210–250 m/s, a bank :math:`\phi` of 15–25°
    (:math:`\omega = g \tan\phi / v`, 0.6–1.3 °/s), :math:`c` 8–15 m/s, :math:`q` 7–9 m/s,
    :math:`z_c` FL300–FL400 (9144–12192 m), lowered where climb and descent would take more
    than 80 % of the flight (short flights).

    Attributes
    ----------
    departure : numpy.ndarray, shape (F,)
        Take-off instant (s from the scenario's window start; negative before it).
    duration : numpy.ndarray, shape (F,)
        Flight time :math:`T` (s).
    airports : numpy.ndarray of int, shape (F, 2)
        Departure and destination: rows of :func:`load_airports`.
    speed : numpy.ndarray, shape (F,)
        :math:`v` (map m/s).
    climb, descent : numpy.ndarray, shape (F,)
        :math:`c, q` (m/s, both positive).
    cruise : numpy.ndarray, shape (F,)
        :math:`z_c` (m above the ellipsoid).
    z_ends : numpy.ndarray, shape (F, 2)
        :math:`z_A, z_B`: heights of the two airports (m).
    start, waypoint, end : numpy.ndarray, shape (F, 2)
        Map points :math:`A, W, B` (m).
    turn_rate : numpy.ndarray, shape (F,)
        :math:`\omega` (rad/s).
    """

    departure: np.ndarray
    duration: np.ndarray
    airports: np.ndarray
    speed: np.ndarray
    climb: np.ndarray
    descent: np.ndarray
    cruise: np.ndarray
    z_ends: np.ndarray
    start: np.ndarray
    waypoint: np.ndarray
    end: np.ndarray
    turn_rate: np.ndarray

    def __len__(self) -> int:
        return int(self.departure.size)

    @property
    def arrival(self) -> np.ndarray:
        """Landing instants (s)."""
        return self.departure + self.duration


@dataclass(frozen=True)
class ContinentScenario:
    """A continental scene: flights, radars and the window over which it is steady.

    Attributes
    ----------
    scale : float
        ``SWISS_AIRBORNE * scale`` aircraft are expected airborne at any instant of the
        window.
    duration : float
        The window ``[0, duration)`` (s).
    origin : (float, float)
        The map frame's origin (degrees).
    flights : Flights
        Every flight airborne at some instant of the window or after its start.
    radars : tuple of radarfusion_ref.capstone.Radar
    departure_rate : float
        Departures per second (Poisson), from ``-T_max`` (the longest flight) to the
        window's end.
    """

    scale: float
    duration: float
    origin: tuple
    flights: Flights
    radars: tuple
    departure_rate: float

    @property
    def expected_airborne(self) -> float:
        """``SWISS_AIRBORNE * scale``."""
        return SWISS_AIRBORNE * self.scale


def _scenario_args_iv(scale, n_radars, duration, siting):
    siting = as_choice(siting, "siting", SITINGS)
    scale = as_float(as_positive(scale, "scale"), "scale")
    duration = as_float(as_positive(duration, "duration"), "duration")
    n_radars = as_int(n_radars, "n_radars", minimum=1, maximum=_scene.airports()["lat"].size)
    return scale, n_radars, duration, siting


def continent_scenario(scale=1.0, *, n_radars=60, duration=3600.0, siting="planned",
                       rng=None):
    r"""A continental scene: ``40 * scale`` aircraft airborne at once, `n_radars` radars.

    Parameters
    ----------
    scale : float, optional
        Traffic relative to the Swiss hour (> 0, default 1): the expected number of
        aircraft airborne at any instant of the window is ``SWISS_AIRBORNE * scale``
        (1 → 40, 10 → 400, 100 → 4000).
    n_radars : int, optional
        Number of radars (1 to the number of airports, default 60).
    duration : float, optional
        The window ``[0, duration)`` over which the traffic is steady (s, > 0, default
        3600).
    siting : {"planned", "spread"}, optional
        Where the radars stand (default ``"planned"``; see Notes).
    rng : None, int or numpy.random.Generator, optional
        Randomness (SPEC 7). Draw order: the radars, the number of departures, their
        instants, the flights.

    Returns
    -------
    ContinentScenario

    Raises
    ------
    ValueError
        `scale` or `duration` not a positive finite number, `n_radars` not in
        ``[1, len(load_airports())]``, `siting` not in :data:`SITINGS`, or flights whose
        arrays would pass
        :data:`~radarfusion_ref.engine.validation.MEMORY_LIMIT` (named `scale`, refused
        before any draw: a smaller `scale` or a shorter `duration`).
    TypeError
        Non-numeric arguments, a bad `rng`.

    Notes
    -----
    **Schedule.** Departures are a Poisson process of rate :math:`\lambda = 40\,\mathrm{scale}
    / E[T]` from :math:`-T_{\max}` (the longest flight, so every flight airborne in the window
    is drawn) to the window's end; the number airborne at any instant of the window is then
    Poisson with mean :math:`\lambda E[T] = 40\,\mathrm{scale}`. :math:`E[T]`, the mean flight
    time (:class:`Flights`), comes from a fixed draw of 200 000 flights (standard error about
    0.1 %). Airports are drawn uniformly (no airport is busier than another).

    **Radars** (:class:`radarfusion_ref.capstone.Radar`): each draws (uniformly) its scan
    period 4–12 s, phase, coverage 250–400 km (above 0° elevation), range noise 30–80 m,
    azimuth noise 0.05–0.12°, elevation noise 0.08–0.2°, detection probability 0.8–0.95
    and 5–20 false reports per scan, and its biases (normal): range offset (80 m), range
    scale error (1e-4) and azimuth offset (0.1°). Its site is an airport, moved by up to
    0.1° and raised 10–300 m:

    * ``"planned"``: for double coverage of the traffic, as en-route networks are. On a
      fixed draw of 6000 airborne aircraft, each radar in turn takes the free airport
      whose coverage (its range, above a 155 m mast's horizon) adds the most aircraft
      seen by fewer than two radars, one no radar sees weighing three (a hole also
      breaks the track of an aircraft that flies out and back in). With 60 radars about
      four in five aircraft are seen by two or more.
    * ``"spread"``: farthest-point sampling over the airports (the first one drawn),
      whatever the traffic; with 36 such radars about half the aircraft are seen by one
      radar only.

    Examples
    --------
    >>> sc = continent_scenario(1.0, rng=1)
    >>> len(sc.radars), sc.expected_airborne
    (60, 40.0)
    """
    scale, n_radars, duration, siting = _scenario_args_iv(scale, n_radars, duration, siting)
    gen = as_rng(rng)
    lat0, lon0 = ORIGIN
    rate = SWISS_AIRBORNE * scale / _scene.mean_duration(lat0, lon0)
    span = duration + _flights.T_MAX
    mean_n = rate * span
    # the Poisson count exceeds mean + 10 sqrt(mean) + 10 with probability below 1e-20
    need = (mean_n + 10 * math.sqrt(mean_n) + 10) * _FLIGHT_BYTES
    check_size(need if need < 2.0**62 else 2**62, MEMORY_LIMIT,
               what=f"bytes of flights (about {mean_n:.0f} departures over {span:.0f} s)",
               alternative="a smaller `scale` or a shorter `duration`", name="scale")
    xyz = _scene.airport_map(lat0, lon0)
    radars = _scene.draw_radars(xyz, n_radars, gen, lat0, lon0, siting)
    n = int(gen.poisson(mean_n))
    departure = np.sort(gen.uniform(-_flights.T_MAX, duration, n))
    f = _flights.draw(xyz[:, :2], xyz[:, 2], n, gen)
    keep = departure + f["duration"] >= 0.0                   # still airborne in the window
    flights = Flights(departure=departure[keep], **{k: v[keep] for k, v in f.items()})
    return ContinentScenario(scale=scale, duration=duration, origin=ORIGIN, flights=flights,
                             radars=radars, departure_rate=rate)


# ------------------------------------------------------------------------------------ truth
def _scenario_iv(scenario):
    if not isinstance(scenario, ContinentScenario):
        raise TypeError(f"`scenario` must be a ContinentScenario (from continent_scenario); "
                        f"received {describe(scenario)}")
    return scenario


def _times_iv(times):
    t = as_float_array(times, "times", ndim_min=1)
    if t.ndim != 1:
        raise ValueError(f"`times` must be one-dimensional; received shape {t.shape}")
    return t


def _check_truth(scenario, times, what):
    check_size(len(scenario.flights) * times.size * _PAIR_BYTES // 4, MEMORY_LIMIT,
               what=f"bytes of truth ({len(scenario.flights)} flights x {times.size} "
                    f"instants, {what})",
               alternative="fewer instants per call (the times in pieces)", name="times")


def truth_at(scenario, times):
    """Positions of every flight at the given instants, in the map frame.

    Parameters
    ----------
    scenario : ContinentScenario
    times : array_like, shape (T,)
        Instants (s from the window start; any order, any value).

    Returns
    -------
    position : numpy.ndarray, shape (F, T, 3)
        Map position (m) of flight ``f`` at ``times[t]``; 0 where it is not airborne.
    valid : numpy.ndarray of bool, shape (F, T)
        Airborne: ``departure <= t <= arrival``.

    Raises
    ------
    TypeError
        `scenario` not a ContinentScenario, non-numeric `times`.
    ValueError
        `times` not a finite 1-D array, or an answer beyond
        :data:`~radarfusion_ref.engine.validation.MEMORY_LIMIT` (refused naming `times`).

    Examples
    --------
    >>> sc = continent_scenario(0.5, n_radars=3, rng=2)
    >>> pos, valid = truth_at(sc, [0.0, 60.0])
    >>> pos.shape[1:], valid.shape == pos.shape[:2]
    ((2, 3), True)
    """
    sc = _scenario_iv(scenario)
    t = _times_iv(times)
    _check_truth(sc, t, "(F, T, 3) positions")
    f = sc.flights
    j, ti = _scene.airborne_pairs(f, t)
    pos = np.zeros((len(f), t.size, 3))
    valid = np.zeros((len(f), t.size), dtype=bool)
    pos[j, ti] = _flights.state(f, _flights.geometry(f), j, t[ti])
    valid[j, ti] = True
    return pos, valid


def airborne_count(scenario, times) -> np.ndarray:
    """Number of aircraft airborne at each instant (the scenario's actual count).

    Parameters
    ----------
    scenario : ContinentScenario
    times : array_like, shape (T,)
        Instants (s).

    Returns
    -------
    numpy.ndarray of int, shape (T,)
        Expected ``SWISS_AIRBORNE * scenario.scale`` inside the window (Poisson).

    Raises
    ------
    TypeError, ValueError
        As :func:`truth_at`.

    Examples
    --------
    >>> sc = continent_scenario(1.0, n_radars=3, rng=3)
    >>> n = airborne_count(sc, [0.0, 1800.0, 3599.0])
    >>> bool(np.all((n > 10) & (n < 80)))
    True
    """
    sc = _scenario_iv(scenario)
    t = _times_iv(times)
    _check_truth(sc, t, "airborne pairs")
    _, ti = _scene.airborne_pairs(sc.flights, t)
    return np.bincount(ti, minlength=t.size)


def truth_samples(scenario, times, *, visible=True):
    """The truth at the given instants, as :func:`radarfusion_ref.tracking.evaluate_tracks`
    takes it.

    Parameters
    ----------
    scenario : ContinentScenario
    times : array_like, shape (T,)
        Instants (s).
    visible : bool, optional
        Keep only the aircraft inside at least one radar's coverage (slant range at most
        `max_range` and elevation at least `min_elevation` in the radar's own frame;
        default True), or every airborne one.

    Returns
    -------
    truth_time : numpy.ndarray, shape (N,)
    truth_position : numpy.ndarray, shape (N, 3)
        Map frame (m).
    truth_id : numpy.ndarray of int, shape (N,)
        The flight (row of ``scenario.flights``). Rows sorted by time, then id.

    Raises
    ------
    TypeError, ValueError
        As :func:`truth_at`; `visible` not a bool.

    Examples
    --------
    >>> sc = continent_scenario(1.0, rng=4)
    >>> t, x, i = truth_samples(sc, [0.0, 10.0])
    >>> x.shape == (t.size, 3), bool(np.all(np.diff(t) >= 0))
    (True, True)
    """
    sc = _scenario_iv(scenario)
    t = _times_iv(times)
    visible = as_bool(visible, "visible")
    _check_truth(sc, t, "airborne samples")
    f = sc.flights
    j, ti = _scene.airborne_pairs(f, t)
    order = np.lexsort((j, t[ti]))
    j, ti = j[order], ti[order]
    pos = _flights.state(f, _flights.geometry(f), j, t[ti])
    if visible:
        keep = _scene.covered(sc, pos)
        j, ti, pos = j[keep], ti[keep], pos[keep]
    return t[ti], pos, j


# ---------------------------------------------------------------------------------- reports
def _bias_iv(bias_estimate, radars):
    m = len(radars)
    if bias_estimate is None:
        return None
    if isinstance(bias_estimate, str):
        if bias_estimate != "true":
            raise ValueError(f"`bias_estimate` must be None, 'true' or a finite ({m}, 3) "
                             f"array; received {describe(bias_estimate)}")
        return np.array([r.biases for r in radars])
    b = as_float_array(bias_estimate, "bias_estimate")
    if b.shape != (m, 3):
        raise ValueError(f"`bias_estimate` must be None, 'true' or a finite ({m}, 3) array "
                         f"(range offset m, range scale, azimuth offset rad per radar); "
                         f"received {describe(bias_estimate)}")
    return b


def polar_to_map(polar, radar, *, bias_estimate=None, debias=True, origin=ORIGIN):
    r"""A radar's polar reports in the continental map frame, with their covariances.

    Parameters
    ----------
    polar : array_like, shape (n, 3)
        Measured range (m, >= 0), azimuth (rad, counter-clockwise from east) and elevation
        (rad) in the radar's own east-north-up frame.
    radar : radarfusion_ref.capstone.Radar
        Its site and noise levels (the covariance of `polar` is
        ``diag(sigma_r, sigma_beta, sigma_epsilon)**2``).
    bias_estimate : array_like, shape (3,), optional
        :math:`(\Delta r, g, \Delta\beta)` removed from range and azimuth first
        (:func:`radarfusion_ref.registration.remove_biases`); None corrects nothing.
    debias : bool, optional
        Measurement-conditioned 3-D conversion (default) or the linearized one
        (:func:`radarfusion_ref.conversion.spherical_to_cartesian`).
    origin : (float, float), optional
        As :func:`to_map`.

    Returns
    -------
    position : numpy.ndarray, shape (n, 3)
        Map frame (m).
    covariance : numpy.ndarray, shape (n, 3, 3)

    Raises
    ------
    TypeError
        Non-numeric `polar`, `radar` not a Radar.
    ValueError
        `polar` not finite (n, 3) with ranges >= 0, a bad `bias_estimate` or `origin`.

    Notes
    -----
    The radar's frame point :math:`l` (with covariance :math:`C` from the conversion) is
    the Earth-centred point :math:`s + R^{\mathsf T} l` (:math:`s` the site, :math:`R`
    :func:`radarfusion_ref.engine.geodesy.enu_rotation` at the site), mapped by
    :func:`to_map`; the covariance is :math:`J C J^{\mathsf T}` with :math:`J` the
    Jacobian of that chain, in closed form: at a point of latitude :math:`\varphi` and
    height :math:`h` the map takes a step :math:`(e, n, u)` of the local east-north-up
    frame to :math:`(k\,\mathrm{R}(\gamma)\,(e\,N/(N+h),\ n\,M/(M+h)),\ u)` with
    :math:`k` :func:`map_scale`, :math:`\gamma` the map's convergence and :math:`M, N` the
    ellipsoid's radii of curvature.

    Examples
    --------
    >>> from radarfusion_ref.capstone import Radar
    >>> rad = Radar("R", 49.0, 10.0, 0.0)
    >>> x, P = polar_to_map([[100e3, 0.0, 0.05]], rad, debias=False)
    >>> np.round(x[0, [0, 2]] / 1e3, 2), P.shape
    (array([99.79,  5.78]), (1, 3, 3))
    """
    frame = _origin_iv(origin)
    if not isinstance(radar, Radar):
        raise TypeError(f"`radar` must be a radarfusion_ref.capstone.Radar; received "
                        f"{describe(radar)}")
    p = as_float_array(polar, "polar", ndim_min=2, last_dims=(3,))
    if p.ndim != 2 or np.any(p[:, 0] < 0):
        raise ValueError(f"`polar` must be (n, 3) with ranges >= 0; received {describe(p)}")
    b = None
    if bias_estimate is not None:
        b = as_float_array(bias_estimate, "bias_estimate")
        if b.shape != (3,):
            raise ValueError(f"`bias_estimate` must be (range offset m, range scale, azimuth "
                             f"offset rad); received {describe(bias_estimate)}")
    return _reports.convert(frame, radar, p, b, as_bool(debias, "debias"))


@dataclass(frozen=True)
class ContinentReports:
    """The reports of all radars over a window, sorted by time, then radar.

    Attributes
    ----------
    time : numpy.ndarray, shape (N,)
        Instant (s).
    position : numpy.ndarray, shape (N, 3)
        Map frame (m).
    cov : numpy.ndarray, shape (N, 3, 3)
        The report's error covariance in the map frame (m²).
    radar : numpy.ndarray of int, shape (N,)
        Index into ``scenario.radars``.
    scan : numpy.ndarray of int, shape (N,)
        The radar's own scan number (its scan at ``phase + scan * period``).
    aircraft : numpy.ndarray of int, shape (N,)
        The flight (row of ``scenario.flights``), -1 for a false report.
    polar : numpy.ndarray, shape (N, 3)
        The measurement itself: range (m), azimuth (rad, counter-clockwise from east) and
        elevation (rad) in the radar's own east-north-up frame, biases included (for a
        registration: :func:`polar_to_map` converts it with any bias estimate).
    start, duration : float
        The window.
    """

    time: np.ndarray
    position: np.ndarray
    cov: np.ndarray
    radar: np.ndarray
    scan: np.ndarray
    aircraft: np.ndarray
    polar: np.ndarray
    start: float
    duration: float

    def __len__(self) -> int:
        return int(self.time.size)


def _window_iv(sc, start, duration):
    start = as_float(as_positive(start, "start", strict=False), "start")
    duration = sc.duration - start if duration is None else duration
    duration = as_float(as_positive(duration, "duration"), "duration")
    if start + duration > sc.duration * (1 + 1e-12):
        raise ValueError(f"`start` + `duration` must lie within the scenario's window "
                         f"[0, {sc.duration:g}] s; received {start:g} + {duration:g}")
    scans = sum(duration / r.period + 2 for r in sc.radars)
    check_size(min(scans * _PAIR_BYTES, 2.0**62), MEMORY_LIMIT,
               what=f"bytes of scan instants ({scans:.3g} scans of {len(sc.radars)} radars)",
               alternative="a shorter window (`duration`, the window in pieces)",
               name="duration")
    return start, duration


def expected_reports(scenario, *, start=0.0, duration=None) -> int:
    r"""The expected number of reports of :func:`simulate_continent` over a window.

    Parameters
    ----------
    scenario : ContinentScenario
    start, duration : float, optional
        As :func:`simulate_continent`.

    Returns
    -------
    int
        :math:`\sum_i S_i(\lambda_i + P_{D,i}\,\bar n_i)`: radar :math:`i`'s scans in the
        window times its false reports per scan plus its detection probability times the
        mean number of aircraft in its coverage (counted at five instants of the window).

    Raises
    ------
    TypeError, ValueError
        As :func:`simulate_continent` (but no memory refusal).

    Examples
    --------
    >>> sc = continent_scenario(1.0, rng=5)
    >>> expected_reports(sc, duration=60.0) > 1000
    True
    """
    sc = _scenario_iv(scenario)
    start, duration = _window_iv(sc, start, duration)
    return _scene.expected(sc, start, duration)


def simulate_continent(scenario, *, start=0.0, duration=None, bias_estimate=None, debias=True,
                       rng=None) -> ContinentReports:
    r"""The radars' reports over a window of the scenario, in the map frame.

    Parameters
    ----------
    scenario : ContinentScenario
        From :func:`continent_scenario`.
    start, duration : float, optional
        The window ``[start, start + duration)`` (s, within the scenario's; default the
        whole of it).
    bias_estimate : None, "true" or array_like of shape (m, 3), optional
        The reports always carry the radars' biases; they are converted to the map frame
        after removing this estimate (:math:`\Delta r`, :math:`g`, :math:`\Delta\beta` per
        radar): None (default) removes nothing, ``"true"`` removes the true biases (a
        perfect registration: tracking studied apart from registration).
    debias : bool, optional
        Measurement-conditioned 3-D conversion (default) or the linearized one.
    rng : None, int or numpy.random.Generator, optional
        Randomness (SPEC 7): every scan of every radar draws from its own stream (spawn
        key (radar, scan number) of the seed), so the reports are the same whether the
        window is simulated whole or in pieces, and one radar's do not depend on the others.

    Returns
    -------
    ContinentReports
        Ready for ``tracking.track_reports(r.time, r.position, r.cov, r.radar, r.scan)``.

    Raises
    ------
    TypeError
        `scenario` not a ContinentScenario, bad `rng`, non-numeric arguments.
    ValueError
        Negative `start`, non-positive `duration`, a window beyond the scenario's, a bad
        `bias_estimate`, or reports (:func:`expected_reports`) or per-radar work whose
        memory would pass :data:`~radarfusion_ref.engine.validation.MEMORY_LIMIT`: refused
        naming `duration` before anything is drawn (a shorter window, or a smaller
        `scale`).

    Notes
    -----
    Radar :math:`i` scans at ``phase + k * period``. The truth at a scan (:func:`truth_at`)
    goes through :func:`from_map`, Earth-centred coordinates and the radar's own
    east-north-up frame to range, azimuth and elevation; an aircraft within `max_range`
    and above `min_elevation` is detected with probability :math:`P_D`, and reported as
    :math:`((1+g) r + \Delta r + v_r,\ \beta + \Delta\beta + v_\beta,\ \varepsilon +
    v_\varepsilon)` with independent Gaussian noises
    (:func:`radarfusion_ref.registration.apply_biases`). False reports:
    Poisson(`clutter_rate`) per scan, uniform over the coverage disk and 1–15 km above the
    radar's plane. Every report is converted by :func:`polar_to_map`.

    Examples
    --------
    >>> sc = continent_scenario(1.0, rng=6)
    >>> rep = simulate_continent(sc, duration=30.0, bias_estimate="true", rng=7)
    >>> rep.position.shape == (len(rep), 3), bool(np.all(np.diff(rep.time) >= 0))
    (True, True)
    """
    sc = _scenario_iv(scenario)
    start, duration = _window_iv(sc, start, duration)
    biases = _bias_iv(bias_estimate, sc.radars)
    debias = as_bool(debias, "debias")
    seeds = as_seed_sequence(rng)
    expected = _scene.expected(sc, start, duration)
    check_size(expected * _REPORT_BYTES, MEMORY_LIMIT,
               what=f"bytes of reports (about {expected} reports, {_REPORT_BYTES} bytes "
                    f"each, over {duration:g} s at scale {sc.scale:g})",
               alternative="a shorter window (`duration`, the window simulated in pieces) "
                           "or a smaller `scale`", name="duration")
    frame = frame_of(*sc.origin)
    f = sc.flights
    sites = [frame.forward(r.lat, r.lon, r.height)[:2] for r in sc.radars]
    geom = _flights.geometry(f)
    for i, rad in enumerate(sc.radars):
        n = _reports.count_pairs(f, geom, rad, sites[i], start, duration)
        check_size(n * _PAIR_BYTES, MEMORY_LIMIT,
                   what=f"bytes of radar {i}'s (aircraft, scan) pairs ({n})",
                   alternative="a shorter window (`duration`) or a smaller `scale`",
                   name="duration")
    cols = {k: [] for k in ("time", "position", "cov", "radar", "scan", "aircraft", "polar")}
    for i, rad in enumerate(sc.radars):
        d = _reports.draw_radar(frame, f, geom, rad, i, sites[i], start, duration, seeds)
        pos, cov = _reports.convert(frame, rad, d["polar"], None if biases is None
                                    else biases[i], debias)
        for k in ("time", "scan", "aircraft", "polar"):
            cols[k].append(d[k])
        cols["position"].append(pos)
        cols["cov"].append(cov)
        cols["radar"].append(np.full(pos.shape[0], i, dtype=np.int64))
    time = np.concatenate(cols.pop("time"))
    radar = np.concatenate(cols.pop("radar"))
    order = np.lexsort((radar, time))
    out = {"time": time[order], "radar": radar[order]}
    del time, radar
    for k in ("cov", "position", "polar", "scan", "aircraft"):        # largest first
        whole = np.concatenate(cols.pop(k))                           # its pieces freed
        out[k] = whole[order]
        del whole
    return ContinentReports(**out, start=start, duration=duration)


# ----------------------------------------------------------------------------- registration
@dataclass(frozen=True)
class ContinentBiases:
    """Every radar's biases estimated from the overlaps (:func:`register_continent`).

    Attributes
    ----------
    biases : numpy.ndarray, shape (m, 3)
        Range offset (m), range scale, azimuth offset (rad) per radar (``bias_estimate``).
    covariance : numpy.ndarray, shape (3m, 3m)
        Their covariance (radar-major), the weak prior and shared reports included.
    pairs : numpy.ndarray of int, shape (m,)
        Report pairs that informed each radar (0: its estimate is the prior's zero).
    """

    biases: np.ndarray
    covariance: np.ndarray
    pairs: np.ndarray


def register_continent(scenario, reports) -> ContinentBiases:
    r"""Every radar's biases from the reports of aircraft seen by two radars.

    Parameters
    ----------
    scenario : ContinentScenario
        The radars (sites, noise levels, periods).
    reports : ContinentReports
        From :func:`simulate_continent` (its `polar` measurements are used; any
        `bias_estimate` it was converted with is ignored).

    Returns
    -------
    ContinentBiases

    Raises
    ------
    TypeError
        `scenario` or `reports` of another type.
    ValueError
        `reports` naming a radar the scenario does not have, or no aircraft seen by two
        radars.

    Notes
    -----
    Association by address, as a Mode S radar reports it (``reports.aircraft``; false
    reports have none). Every report of radar :math:`j` of an aircraft that radar
    :math:`i < j` saw just before and after (at most 1.5 of its periods apart) gives a
    pair: :math:`x_j - \bar x_i = B_j b_j - B_i b_i + e` with :math:`\bar x_i` the
    linear interpolation of radar :math:`i`'s two converted reports,
    :math:`B = \partial x / \partial b` (finite differences of :func:`polar_to_map` in range
    and azimuth; :math:`\partial x/\partial g = r\,\partial x/\partial r`) and
    :math:`\operatorname{Cov} e` the reports' covariances. Weighted least squares over
    all pairs with a weak prior (2 km, 0.01, 2° standard deviations, so a radar overlapping
    no other stays at zero), three passes dropping pairs beyond the 0.999 quantile of
    :math:`\chi^2_3` (an aircraft turning between the bracketing reports). Pairs share
    reports: the covariance is :math:`I^{-1} M I^{-1}`, :math:`M` summing each report's
    covariance through every pair using it. Range offset and scale are nearly confounded
    over one radar's ranges; the azimuth offset is the best determined.

    Examples
    --------
    >>> sc = continent_scenario(5.0, rng=1)
    >>> rep = simulate_continent(sc, start=0.0, duration=120.0, rng=2)
    >>> register_continent(sc, rep).biases.shape
    (60, 3)
    """
    sc = _scenario_iv(scenario)
    if not isinstance(reports, ContinentReports):
        raise TypeError(f"`reports` must be ContinentReports (from simulate_continent); "
                        f"received {describe(reports)}")
    m = len(sc.radars)
    if reports.radar.size and int(reports.radar.max()) >= m:
        raise ValueError(f"`reports` name radar {int(reports.radar.max())} but `scenario` "
                         f"has {m} radars")
    out = _registration.register(frame_of(*sc.origin), sc.radars, reports)
    if out is None:
        raise ValueError("`reports`: no aircraft is seen by two radars in them (a longer "
                         "window or a larger `scale`)")
    biases, covariance, _, pairs = out
    return ContinentBiases(biases, covariance, pairs)
