"""Kernels of the continental reports: one radar's draws and the conversion to the map.

Trusted input; the door is :func:`radarfusion_ref.continent.scenario.simulate_continent`.
"""

from __future__ import annotations

import math

import numpy as np

from .. import conversion, registration
from ..engine.geodesy import enu_rotation
from . import _flights
from ._frame import ecef, geodetic

#: Heights (m) in the radar's own frame between which false reports are placed, uniformly
#: over its coverage disk (as the capstone places its clutter).
CLUTTER_UP = (1000.0, 15000.0)
#: Map reach of a radar: a point within `max_range` (slant) of the site lies within
#: ``REACH[0] * max_range + REACH[1]`` map metres of it (the map's scale is below 1.04 over
#: the continent; the arc cuts a leg's corner by under 2 km).
REACH = (1.04, 5000.0)


def site_ecef(rad):
    return ecef(np.array([rad.lat, rad.lon, rad.height]))


def polar(local):
    """Slant range, azimuth (from east, counter-clockwise) and elevation of (n, 3) offsets."""
    ground = np.hypot(local[:, 0], local[:, 1])
    return np.stack([np.linalg.norm(local, axis=1), np.arctan2(local[:, 1], local[:, 0]),
                     np.arctan2(local[:, 2], ground)], axis=-1)


def to_local(frame, rad, xyz):
    """Map points (n, 3) -> the radar's own east-north-up frame (n, 3)."""
    return (ecef(frame.inverse(xyz)) - site_ecef(rad)) @ enu_rotation(rad.lat, rad.lon).T


def scan_times(rad, start, duration):
    k0 = math.ceil((start - rad.phase) / rad.period - 1e-9)
    k1 = math.ceil((start + duration - rad.phase) / rad.period - 1e-9)
    k = np.arange(max(k0, 0), max(k1, 0))
    return k, rad.phase + rad.period * k


def pairs(flights, rad, site_xy, k, times):
    """(flight, scan-row) pairs of the flights within the radar's reach, airborne at a scan."""
    reach = REACH[0] * rad.max_range + REACH[1]
    near = np.flatnonzero(_flights.distance_to_path(flights, site_xy) <= reach)
    if k.size == 0 or near.size == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64)
    t0, p = times[0], rad.period
    lo = np.maximum(np.ceil((flights.departure[near] - t0) / p - 1e-9), 0).astype(np.int64)
    hi = np.minimum(np.floor((flights.arrival[near] - t0) / p + 1e-9), k.size - 1) \
        .astype(np.int64)
    n = np.maximum(hi - lo + 1, 0)
    j = np.repeat(near, n)
    first = np.repeat(lo - (np.cumsum(n) - n), n)
    s = first + np.arange(j.size)
    return j, s


def count_pairs(flights, rad, site_xy, start, duration):
    """How many (flight, scan) pairs :func:`pairs` would make (no allocation of them)."""
    k, times = scan_times(rad, start, duration)
    reach = REACH[0] * rad.max_range + REACH[1]
    near = np.flatnonzero(_flights.distance_to_path(flights, site_xy) <= reach)
    if k.size == 0:
        return 0
    t0, p = times[0], rad.period
    lo = np.maximum(np.ceil((flights.departure[near] - t0) / p - 1e-9), 0)
    hi = np.minimum(np.floor((flights.arrival[near] - t0) / p + 1e-9), k.size - 1)
    return int(np.maximum(hi - lo + 1, 0).sum())


def draw_radar(frame, flights, geom, rad, site_xy, start, duration, gen):
    """One radar's reports over the window: dict of time, scan, polar (n, 3), aircraft.

    Draw order: detection of every covered (aircraft, scan), clutter counts per scan,
    clutter positions, then the noise of every report (detections first).
    """
    k, times = scan_times(rad, start, duration)
    j, s = pairs(flights, rad, site_xy, k, times)
    pos = _flights.state(flights, geom, j, times[s])
    reach = REACH[0] * rad.max_range + REACH[1]
    close = np.hypot(pos[:, 0] - site_xy[0], pos[:, 1] - site_xy[1]) <= reach
    j, s, pos = j[close], s[close], pos[close]
    true = polar(to_local(frame, rad, pos))
    cover = (true[:, 0] <= rad.max_range) & (true[:, 2] >= rad.min_elevation)
    det = cover & (gen.random(j.size) < rad.p_detect)
    true, j, s = true[det], j[det], s[det]
    rb, bb = registration.apply_biases(true[:, 0], true[:, 1], rad.biases) if j.size else \
        (true[:, 0], true[:, 1])
    n_false = gen.poisson(rad.clutter_rate, size=k.size)
    nf = int(n_false.sum())
    rho = rad.max_range * np.sqrt(gen.random(nf))
    phi = gen.uniform(-np.pi, np.pi, nf)
    up = gen.uniform(*CLUTTER_UP, nf)
    false = polar(np.stack([rho * np.cos(phi), rho * np.sin(phi), up], -1))
    noise = gen.standard_normal((j.size + nf, 3)) * [rad.sigma_r, rad.sigma_beta,
                                                      rad.sigma_epsilon]
    meas = np.concatenate([np.stack([rb, bb, true[:, 2]], -1), false]) + noise
    meas[:, 0] = np.abs(meas[:, 0])
    meas[:, 1] = (meas[:, 1] + np.pi) % (2 * np.pi) - np.pi
    s_all = np.concatenate([s, np.repeat(np.arange(k.size), n_false)])
    return dict(time=times[s_all], scan=k[s_all], polar=meas,
                aircraft=np.concatenate([j, np.full(nf, -1, np.int64)]))


def convert(frame, rad, meas, bias, debias):
    r"""Polar reports of one radar -> map positions (n, 3) and covariances (n, 3, 3).

    Bias correction (:func:`radarfusion_ref.registration.remove_biases`) if `bias` is given,
    the 3-D conversion in the radar's frame
    (:func:`radarfusion_ref.conversion.spherical_to_cartesian`), then the map:
    :math:`x = \mathrm{map}(s_i + R_i^{\mathsf T} l)`, :math:`P = J C J^{\mathsf T}` with
    :math:`J = \partial\,\mathrm{map}/\partial\,\mathrm{ECEF}\; R_i^{\mathsf T}`.
    """
    n = meas.shape[0]
    if n == 0:
        return np.empty((0, 3)), np.empty((0, 3, 3))
    r, beta = meas[:, 0], meas[:, 1]
    if bias is not None:
        r, beta = registration.remove_biases(r, beta, bias)
        r = np.abs(r)
    out = conversion.spherical_to_cartesian(
        r, beta, meas[:, 2], rad.sigma_r, rad.sigma_beta, rad.sigma_epsilon,
        method="measurement_conditioned" if debias else "linearized")
    rot = enu_rotation(rad.lat, rad.lon)
    geo = geodetic(site_ecef(rad) + out.xyz @ rot)                    # s + R^T l, row-wise
    jac = frame.jacobian(geo) @ rot.T                                 # d map / d l
    cov = jac @ out.cov @ np.swapaxes(jac, -1, -2)
    cov = 0.5 * (cov + np.swapaxes(cov, -1, -2))
    return frame.forward(geo[:, 0], geo[:, 1], geo[:, 2]), cov
