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
    d = ecef(frame.inverse(xyz)) - site_ecef(rad)
    return np.einsum("ni,ji->nj", d, enu_rotation(rad.lat, rad.lon))          # R d, row-wise


def sees(frame, rad, xyz):
    """Boolean (n,): map points (n, 3) within `rad`'s range and above its elevation floor."""
    site = frame.forward(rad.lat, rad.lon, rad.height)
    out = np.zeros(xyz.shape[0], dtype=bool)
    near = np.flatnonzero(np.hypot(xyz[:, 0] - site[0], xyz[:, 1] - site[1])
                          <= REACH[0] * rad.max_range + REACH[1])
    if near.size:
        p = polar(to_local(frame, rad, xyz[near]))
        out[near] = (p[:, 0] <= rad.max_range) & (p[:, 2] >= rad.min_elevation)
    return out


def scan_times(rad, start, duration):
    k0 = math.ceil((start - rad.phase) / rad.period - 1e-9)
    k1 = math.ceil((start + duration - rad.phase) / rad.period - 1e-9)
    k = np.arange(max(k0, 0), max(k1, 0))
    return k, rad.phase + rad.period * k


def intervals(flights, geom, rad, site_xy, start, duration):
    """Time intervals (flight, t_lo, t_hi) in which a flight may be within the radar's reach.

    Each leg of the polyline A-W-B is cut by the reach circle about the site (closed form);
    the arc stays within 2 km of the corner and its length within 1 km of the two tangent
    lengths, both inside the reach's margin. Leg 1 covers the path up to the arc's middle,
    leg 2 the rest (widened by 1 s, so the two may share a scan: :func:`pairs` keeps it
    once).
    """
    reach = REACH[0] * rad.max_range + REACH[1]
    near = np.flatnonzero(_flights.distance_to_path(flights, site_xy) <= reach)
    g = {k: v[near] for k, v in geom.items()}
    tau = np.linalg.norm(flights.waypoint[near] - flights.start[near], axis=-1) - g["d1"]
    middle = g["d1"] + g["arc"] / 2
    total = g["d1"] + g["arc"] + g["d2"]
    v, dep = flights.speed[near], flights.departure[near]
    out = []
    for origin, u, offset, lo_d, hi_d in (
            (flights.start[near], g["u1"], 0.0, 0.0, middle),
            (flights.waypoint[near], g["u2"], g["d1"] + g["arc"] - tau, middle, total)):
        rel = site_xy - origin
        b = np.sum(rel * u, axis=-1)
        c2 = np.sum(rel * rel, axis=-1) - b * b
        half = np.sqrt(np.maximum(reach**2 - c2, 0.0))
        d_lo = np.maximum(offset + b - half, lo_d)
        d_hi = np.minimum(offset + b + half, hi_d)
        t_lo = np.maximum(dep + d_lo / v - 1.0, start)
        t_hi = np.minimum(dep + d_hi / v + 1.0, start + duration)
        ok = (c2 <= reach**2) & (d_lo <= d_hi) & (t_lo <= t_hi)
        out.append((near[ok], t_lo[ok], t_hi[ok]))
    return tuple(np.concatenate(x) for x in zip(*out, strict=True))


def _scan_range(rad, k, t_lo, t_hi):
    """First scan row (into `k`) inside each [t_lo, t_hi] and how many, within the window."""
    t0 = rad.phase + rad.period * k[0]
    lo = np.maximum(np.ceil((t_lo - t0) / rad.period - 1e-9), 0).astype(np.int64)
    hi = np.minimum(np.floor((t_hi - t0) / rad.period + 1e-9), k.size - 1).astype(np.int64)
    return lo, np.maximum(hi - lo + 1, 0)


def pairs(flights, geom, rad, site_xy, start, duration):
    """(flight, scan-row) pairs that may lie within the radar's reach, and the scans."""
    k, times = scan_times(rad, start, duration)
    if k.size == 0:
        return np.empty(0, np.int64), np.empty(0, np.int64), k, times
    j, t_lo, t_hi = intervals(flights, geom, rad, site_xy, start, duration)
    lo, n = _scan_range(rad, k, t_lo, t_hi)
    jj = np.repeat(j, n)
    s = np.repeat(lo - (np.cumsum(n) - n), n) + np.arange(jj.size)
    # the two legs' intervals may share the scans about the arc's middle: each pair once
    key = np.unique(jj * k.size + s)
    jj, s = key // k.size, key % k.size
    keep = (times[s] >= flights.departure[jj]) & (times[s] <= flights.arrival[jj])
    return jj[keep], s[keep], k, times


def count_pairs(flights, geom, rad, site_xy, start, duration):
    """How many pairs :func:`pairs` would examine (no allocation of them)."""
    k, _ = scan_times(rad, start, duration)
    if k.size == 0:
        return 0
    _, t_lo, t_hi = intervals(flights, geom, rad, site_xy, start, duration)
    return int(_scan_range(rad, k, t_lo, t_hi)[1].sum())


def _join(parts):
    """Concatenate (n_i, 3) pieces; (0, 3) if there are none."""
    return np.concatenate(parts) if parts else np.empty((0, 3))


def scan_stream(seeds, i, k):
    """The generator of radar `i`'s scan `k`: spawn key (radar, scan) under `seeds`."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(
        seeds.entropy, spawn_key=(*seeds.spawn_key, i, int(k)))))


def draw_radar(frame, flights, geom, rad, i, site_xy, start, duration, seeds):
    """One radar's reports over the window: dict of time, scan, polar (n, 3), aircraft.

    Every scan draws from its own stream (:func:`scan_stream`), in this order: detection of
    its covered aircraft (by increasing flight), its number of false reports, their
    positions, then the noise of its reports (detections first). A scan's reports so depend
    on the seed, the radar and the scan only, not on the window they are simulated in.
    """
    j, s, k, times = pairs(flights, geom, rad, site_xy, start, duration)
    pos = _flights.state(flights, geom, j, times[s])
    reach = REACH[0] * rad.max_range + REACH[1]
    close = np.hypot(pos[:, 0] - site_xy[0], pos[:, 1] - site_xy[1]) <= reach
    j, s, pos = j[close], s[close], pos[close]
    true = polar(to_local(frame, rad, pos))
    cover = (true[:, 0] <= rad.max_range) & (true[:, 2] >= rad.min_elevation)
    order = np.lexsort((j[cover], s[cover]))                         # by scan, then flight
    j, s, true = j[cover][order], s[cover][order], true[cover][order]
    bounds = np.searchsorted(s, np.arange(k.size + 1))
    sig = np.array([rad.sigma_r, rad.sigma_beta, rad.sigma_epsilon])
    rows, det_noise, false, false_noise, n_false = [], [], [], [], np.zeros(k.size, np.int64)
    for row in range(k.size):
        gen = scan_stream(seeds, i, k[row])
        a, b = bounds[row], bounds[row + 1]
        det = np.flatnonzero(gen.random(b - a) < rad.p_detect) + a
        nf = n_false[row] = gen.poisson(rad.clutter_rate)
        rho = rad.max_range * np.sqrt(gen.random(nf))
        phi = gen.uniform(-np.pi, np.pi, nf)
        up = gen.uniform(*CLUTTER_UP, nf)
        noise = gen.standard_normal((det.size + nf, 3)) * sig
        rows.append(det)
        det_noise.append(noise[:det.size])
        false.append(np.stack([rho * np.cos(phi), rho * np.sin(phi), up], -1))
        false_noise.append(noise[det.size:])
    rows = np.concatenate(rows) if rows else np.empty(0, np.int64)
    true, j, s = true[rows], j[rows], s[rows]
    rb, bb = registration.apply_biases(true[:, 0], true[:, 1], rad.biases) if j.size else \
        (true[:, 0], true[:, 1])
    meas = np.concatenate([np.stack([rb, bb, true[:, 2]], -1) + _join(det_noise),
                           polar(_join(false)) + _join(false_noise)])
    meas[:, 0] = np.abs(meas[:, 0])
    meas[:, 1] = (meas[:, 1] + np.pi) % (2 * np.pi) - np.pi
    s_all = np.concatenate([s, np.repeat(np.arange(k.size), n_false)])
    aircraft = np.concatenate([j, np.full(int(n_false.sum()), -1, np.int64)])
    order = np.argsort(s_all, kind="stable")                         # by scan: detections first
    return dict(time=times[s_all][order], scan=k[s_all][order], polar=meas[order],
                aircraft=aircraft[order])


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
    geo = geodetic(site_ecef(rad) + np.einsum("nj,ji->ni", out.xyz, rot))  # s + R^T l
    jac = np.einsum("nik,jk->nij", frame.jacobian(geo), rot)          # d map / d l
    cov = np.einsum("nij,njk,nlk->nil", jac, out.cov, jac, optimize=True)
    cov = 0.5 * (cov + np.swapaxes(cov, -1, -2))
    return frame.forward(geo[:, 0], geo[:, 1], geo[:, 2]), cov
