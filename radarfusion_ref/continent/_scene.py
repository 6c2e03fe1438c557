"""Kernels of the continental scene: airports, radars, schedule, truth samples (trusted input).

The doors are in :mod:`radarfusion_ref.continent.scenario`.
"""

from __future__ import annotations

import csv
import functools
import io
import math
from importlib import resources
from types import SimpleNamespace

import numpy as np

from ..capstone import Radar
from ..engine.geodesy import enu_rotation
from . import _flights, _reports
from ._frame import ecef, frame_of

#: The committed airports (CSV with a ``#`` header line; see ``data/make_airports.py``).
AIRPORTS_FILE = resources.files(__package__).joinpath("data", "airports.csv")
#: Ranges (uniform) of the radars' drawn parameters: scan period (s), coverage (m), range
#: noise (m), azimuth and elevation noise (deg), detection probability, false reports per
#: scan; and the standard deviations of the biases: range offset (m), range scale, azimuth
#: offset (deg).
RADAR_DRAWS = {"period": (4.0, 12.0), "max_range": (250e3, 400e3), "sigma_r": (30.0, 80.0),
               "sigma_beta": (0.05, 0.12), "sigma_epsilon": (0.08, 0.2),
               "p_detect": (0.8, 0.95), "clutter_rate": (5.0, 20.0),
               "bias_range": 80.0, "bias_scale": 1e-4, "bias_azimuth": 0.1}


@functools.lru_cache(maxsize=1)
def airports() -> dict:
    """The committed airports' columns: icao, iata, name (str), lat, lon, elevation (float)."""
    text = AIRPORTS_FILE.read_text(encoding="utf-8")
    rows = list(csv.DictReader(io.StringIO(
        "\n".join(line for line in text.splitlines() if not line.startswith("#")))))
    col = {k: np.array([r[k] for r in rows]) for k in rows[0]}
    return dict(icao=col["icao"], iata=col["iata"], name=col["name"],
                lat=col["lat"].astype(float), lon=col["lon"].astype(float),
                elevation=col["elevation_m"].astype(float))


@functools.lru_cache(maxsize=8)
def airport_map(lat0, lon0):
    ap = airports()
    return frame_of(lat0, lon0).forward(ap["lat"], ap["lon"], ap["elevation"])


#: Flights of the fixed draw that gives the mean flight time (its standard error about
#: 0.1 %).
_CALIBRATION_FLIGHTS = 200_000


@functools.lru_cache(maxsize=8)
def mean_duration(lat0, lon0) -> float:
    """Mean flight time E[T] (s) of the flight distribution, from a fixed seeded draw."""
    xyz = airport_map(lat0, lon0)
    f = _flights.draw(xyz[:, :2], xyz[:, 2], _CALIBRATION_FLIGHTS,
                      np.random.default_rng(20260101))
    return float(np.mean(f["duration"]))


#: The traffic a radar network is planned for: airborne aircraft of a fixed seeded draw,
#: each flight at a uniform instant of its flight, flights drawn in proportion to their
#: duration (so the samples follow the airborne density); and how many radars each sample
#: should see (double coverage, as en-route airspace is planned); a sample no radar sees
#: weighs `PLAN_HOLE_WEIGHT` times one that one radar sees (a hole also costs an aircraft
#: its track's identity when it flies out and back in).
_PLAN_FLIGHTS, _PLAN_SAMPLES, PLAN_COVERAGE, PLAN_HOLE_WEIGHT = 20_000, 6_000, 2, 3.0
#: A site's antenna height above its airport in the plan (m): the middle of the drawn 10-300 m.
_PLAN_MAST = 155.0


@functools.lru_cache(maxsize=4)
def plan_points(lat0, lon0):
    """The plan's traffic: map positions (m) of ``_PLAN_SAMPLES`` airborne aircraft, each
    flight of a fixed seeded draw taken in proportion to its duration and placed at a
    uniform instant of it (so the samples follow the airborne density); shape (S, 3)."""
    xyz = airport_map(lat0, lon0)
    gen = np.random.default_rng(20260102)
    f = _flights.draw(xyz[:, :2], xyz[:, 2], _PLAN_FLIGHTS, gen)
    j = gen.choice(_PLAN_FLIGHTS, _PLAN_SAMPLES, p=f["duration"] / f["duration"].sum())
    fl = SimpleNamespace(departure=np.zeros(_PLAN_FLIGHTS), **f)
    return _flights.state(fl, _flights.geometry(fl), j, gen.uniform(0.0, f["duration"][j]))


@functools.lru_cache(maxsize=4)
def plan_ranges(lat0, lon0):
    """Slant range (m, float32) from every airport site to every planning sample
    (:func:`plan_points`), inf where the sample is below the site's horizon (elevation
    < 0): shape (airports, samples)."""
    pos = plan_points(lat0, lon0)
    frame = frame_of(lat0, lon0)
    ap = airports()
    p = ecef(frame.inverse(pos))                                           # (S, 3)
    sites = ecef(np.stack([ap["lat"], ap["lon"], ap["elevation"] + _PLAN_MAST], -1))
    out = np.empty((ap["lat"].size, _PLAN_SAMPLES), np.float32)
    for i in range(ap["lat"].size):
        d = p - sites[i]
        up = d @ enu_rotation(ap["lat"][i], ap["lon"][i])[2]
        out[i] = np.where(up >= 0.0, np.linalg.norm(d, axis=1), np.inf)
    return out


def planned_sites(max_range, lat0, lon0):
    """Airport index of each radar's site, chosen greedily in the radars' order: each takes
    the free airport whose coverage (its own `max_range`) adds the most weight of planning
    samples still seen by fewer than ``PLAN_COVERAGE`` radars (weight ``PLAN_HOLE_WEIGHT``
    for a sample no radar sees yet, 1 for the others; ties: the first airport)."""
    r = plan_ranges(lat0, lon0)
    count = np.zeros(r.shape[1], np.int64)
    free = np.ones(r.shape[0], bool)
    chosen = []
    for rmax in max_range:
        cover = r <= np.float32(rmax)
        weight = np.where(count == 0, PLAN_HOLE_WEIGHT, (count < PLAN_COVERAGE) * 1.0)
        gain = cover @ weight.astype(np.float32)
        gain[~free] = -1.0
        i = int(np.argmax(gain))
        chosen.append(i)
        free[i] = False
        count += cover[i]
    return chosen


def draw_radars(xyz, n, gen, lat0, lon0, siting="planned"):
    """`n` radars with their drawn parameters, at sites planned for double coverage of the
    traffic (``siting="planned"``, :func:`planned_sites`) or spread by farthest-point
    sampling over the airports (``"spread"``), then jittered."""
    ap = airports()
    # the spread siting's first site, drawn for either siting: one order of draws, so the
    # parameters below are the same for both sitings of a seed
    first = int(gen.integers(ap["lat"].size))
    u = {k: gen.uniform(*v, n) for k, v in RADAR_DRAWS.items() if isinstance(v, tuple)}
    if siting == "planned":
        chosen = planned_sites(u["max_range"], lat0, lon0)
    else:
        chosen = [first]
        d = np.linalg.norm(xyz[:, :2] - xyz[first, :2], axis=-1)
        for _ in range(n - 1):
            nxt = int(np.argmax(d))
            chosen.append(nxt)
            d = np.minimum(d, np.linalg.norm(xyz[:, :2] - xyz[nxt, :2], axis=-1))
    idx = np.array(chosen)
    # jitter: up to 0.1 deg of latitude and longitude; mast or hill 10-300 m above the airport
    lat = ap["lat"][idx] + gen.uniform(-0.1, 0.1, n)
    lon = ap["lon"][idx] + gen.uniform(-0.1, 0.1, n)
    height = ap["elevation"][idx] + gen.uniform(10.0, 300.0, n)
    bias = gen.standard_normal((n, 3)) * [RADAR_DRAWS["bias_range"], RADAR_DRAWS["bias_scale"],
                                          RADAR_DRAWS["bias_azimuth"]]
    phase = gen.random(n) * u["period"]
    return tuple(Radar(
        name=f"{ap['iata'][i]} radar", lat=float(lat[m]), lon=float(lon[m]),
        height=float(height[m]), sigma_r=float(u["sigma_r"][m]),
        sigma_beta=math.radians(u["sigma_beta"][m]),
        sigma_epsilon=math.radians(u["sigma_epsilon"][m]), bias_range=float(bias[m, 0]),
        bias_azimuth=math.radians(bias[m, 2]), p_detect=float(u["p_detect"][m]),
        clutter_rate=float(u["clutter_rate"][m]), max_range=float(u["max_range"][m]),
        min_elevation=0.0, period=float(u["period"][m]), phase=float(phase[m]),
        bias_scale=float(bias[m, 1])) for m, i in enumerate(idx))



def airborne_pairs(flights, times):
    """(flight, time-index) of every flight airborne at every instant (sparse, no F x T)."""
    order = np.argsort(times, kind="stable")
    ts = times[order]
    lo = np.searchsorted(ts, flights.departure, side="left")
    hi = np.searchsorted(ts, flights.arrival, side="right")
    n = hi - lo
    j = np.repeat(np.arange(len(flights)), n)
    pos = np.repeat(lo - (np.cumsum(n) - n), n) + np.arange(j.size)
    return j, order[pos]



def covered(sc, pos):
    """Boolean (n,): map positions inside at least one radar's coverage."""
    frame = frame_of(*sc.origin)
    out = np.zeros(pos.shape[0], dtype=bool)
    for rad in sc.radars:
        out |= _reports.sees(frame, rad, pos)
    return out



def expected(sc, start, duration):
    """Expected reports over the window: per radar, scans x (clutter + P_D x the mean number
    of aircraft in its coverage at five instants), one instant at a time (little memory)."""
    frame = frame_of(*sc.origin)
    seen = np.zeros(len(sc.radars))
    for t in start + duration * (np.arange(5) + 0.5) / 5:             # five instants
        j, _ = airborne_pairs(sc.flights, np.array([t]))
        pos = _flights.state(sc.flights, _flights.geometry(sc.flights), j, np.full(j.size, t))
        for i, rad in enumerate(sc.radars):
            seen[i] += np.count_nonzero(_reports.sees(frame, rad, pos)) / 5
    total = 0.0
    for i, rad in enumerate(sc.radars):
        n_scans = _reports.scan_times(rad, start, duration)[0].size
        total += n_scans * (rad.clutter_rate + rad.p_detect * seen[i])
    return math.ceil(total)


