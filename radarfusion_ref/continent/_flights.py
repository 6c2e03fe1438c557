r"""Kernels of the continental flights: drawing them and evaluating them (trusted input).

A flight, in the map frame: from its departure airport :math:`A` towards a waypoint
:math:`W` off the direct line, a coordinated turn at :math:`W` (an arc of radius
:math:`\rho = v/\omega`), on to the destination :math:`B`, at one horizontal speed
:math:`v`; its height is :math:`z(s) = \min(z_A + c\,s,\ z_c,\ z_B + q\,(T - s))` at
:math:`s` seconds after take-off (climb at :math:`c`, cruise at :math:`z_c`, descent at
:math:`q`, landing at :math:`T`).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

#: Great-circle distance range of a flight's airports (map metres).
DISTANCE = (300e3, 2500e3)
#: Cruise speed, map metres per second (uniform).
SPEED = (210.0, 250.0)
#: Climb rate (m/s, uniform).
CLIMB = (8.0, 15.0)
#: Descent rate magnitude (m/s, uniform).
DESCENT = (7.0, 9.0)
#: Cruise level (m): FL300..FL400, uniform.
CRUISE = (9144.0, 12192.0)
#: Bank angle of the turn (rad, uniform): 15..25 deg, an airliner's at cruise; the turn
#: rate is then g tan(bank) / v (about 0.6..1.3 deg/s at 210..250 m/s).
BANK = (np.radians(15.0), np.radians(25.0))
#: Standard gravity (m/s^2).
G0 = 9.80665
#: Waypoint: at this fraction of the direct line (uniform) ...
WAYPOINT_AT = (0.3, 0.7)
#: ... and off it by this fraction of the line's length (uniform, either side).
WAYPOINT_OFF = (0.05, 0.15)
#: Climb and descent take at most this fraction of the flight's time (a short flight levels
#: off lower than FL300, as short flights do).
MAX_CLIMB_DESCENT = 0.8
#: Longest flight (s): the longest path (the two legs at most 1.06 times the direct line)
#: at the lowest speed. Departures start this long before the window, so the airborne
#: count is steady over it.
T_MAX = 1.06 * DISTANCE[1] / SPEED[0]


def _unit(v):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / n, n[..., 0]


def _left(u):
    """u turned by +90 degrees."""
    return np.stack([-u[..., 1], u[..., 0]], axis=-1)


def geometry(f):
    """Legs and arc of every flight: a dict of (F,) / (F, 2) arrays (trusted input)."""
    u1, l1 = _unit(f.waypoint - f.start)
    u2, l2 = _unit(f.end - f.waypoint)
    cross = u1[:, 0] * u2[:, 1] - u1[:, 1] * u2[:, 0]
    theta = np.arctan2(np.abs(cross), np.sum(u1 * u2, axis=-1))      # turn angle, [0, pi)
    sign = np.where(cross >= 0, 1.0, -1.0)                             # +1 left, -1 right
    rho = f.speed / f.turn_rate
    tau = rho * np.tan(theta / 2)                                      # tangent length
    t1 = f.waypoint - tau[:, None] * u1                                # arc start
    return dict(u1=u1, u2=u2, d1=l1 - tau, arc=rho * theta, d2=l2 - tau, rho=rho, sign=sign,
                centre=t1 + (sign * rho)[:, None] * _left(u1), t1=t1,
                t2=f.waypoint + tau[:, None] * u2, psi1=np.arctan2(u1[:, 1], u1[:, 0]))


def path_length(f):
    g = geometry(f)
    return g["d1"] + g["arc"] + g["d2"]


def state(f, g, j, t, *, velocity=False):
    """Map position (n, 3) (and velocity) of flights `j` at instants `t` (both (n,)).

    Trusted: every instant lies within its flight (departure <= t <= arrival).
    """
    s = t - f.departure[j]
    v = f.speed[j]
    d = v * s                                                          # distance flown
    d1, arc = g["d1"][j], g["arc"][j]
    rho, sign = g["rho"][j], g["sign"][j]
    on1, on_arc = d < d1, (d >= d1) & (d < d1 + arc)
    phi = np.clip(d - d1, 0.0, arc) / rho                              # angle turned
    psi = g["psi1"][j] + sign * phi                                    # heading on the arc
    u_arc = np.stack([np.cos(psi), np.sin(psi)], -1)
    p_arc = g["centre"][j] - (sign * rho)[:, None] * _left(u_arc)
    p1 = f.start[j] + d[:, None] * g["u1"][j]
    p2 = g["t2"][j] + (d - d1 - arc)[:, None] * g["u2"][j]
    xy = np.where(on1[:, None], p1, np.where(on_arc[:, None], p_arc, p2))
    climb, descent, T = f.climb[j], f.descent[j], f.duration[j]
    z_up, z_down = f.z_ends[j, 0] + climb * s, f.z_ends[j, 1] + descent * (T - s)
    z = np.minimum(np.minimum(z_up, f.cruise[j]), z_down)
    pos = np.concatenate([xy, z[:, None]], axis=-1)
    if not velocity:
        return pos
    vxy = v[:, None] * np.where(on1[:, None], g["u1"][j],
                                np.where(on_arc[:, None], u_arc, g["u2"][j]))
    vz = np.where(z == z_up, climb, np.where(z == z_down, -descent, 0.0))
    return pos, np.concatenate([vxy, vz[:, None]], axis=-1)


def draw(xy, elev, n, gen):
    """`n` flights between airports at map points `xy` (k, 2), heights `elev` (k,): a dict
    of the fields of :class:`~radarfusion_ref.continent.scenario.Flights` but `departure`.
 Draw order: airport pairs (by
    rejection, in rounds of 2n), then per flight the waypoint's place, side and offset, the
    speed, turn rate, climb and descent rates and the cruise level.
    """
    pairs = np.empty((0, 2), dtype=np.int64)
    k = xy.shape[0]
    while pairs.shape[0] < n:
        cand = gen.integers(0, k, size=(2 * n + 16, 2))
        dist = np.linalg.norm(xy[cand[:, 1]] - xy[cand[:, 0]], axis=-1)
        ok = (dist >= DISTANCE[0]) & (dist <= DISTANCE[1])
        pairs = np.concatenate([pairs, cand[ok]])
    pairs = pairs[:n]
    a, b = xy[pairs[:, 0]], xy[pairs[:, 1]]
    at = gen.uniform(*WAYPOINT_AT, n)
    off = gen.uniform(*WAYPOINT_OFF, n) * np.where(gen.random(n) < 0.5, -1.0, 1.0)
    u, length = _unit(b - a)
    w = a + (at * length)[:, None] * u + (off * length)[:, None] * _left(u)
    speed = gen.uniform(*SPEED, n)
    turn = G0 * np.tan(gen.uniform(*BANK, n)) / speed
    climb = gen.uniform(*CLIMB, n)
    descent = gen.uniform(*DESCENT, n)
    cruise = gen.uniform(*CRUISE, n)
    z_ends = elev[pairs]
    geo = SimpleNamespace(start=a, waypoint=w, end=b, speed=speed, turn_rate=turn)
    T = path_length(geo) / speed
    # climb + descent time <= MAX_CLIMB_DESCENT T:
    # (zc - zA)/c + (zc - zB)/q <= 0.8 T  <=>  zc <= (0.8 T + zA/c + zB/q) / (1/c + 1/q)
    cap = (MAX_CLIMB_DESCENT * T + z_ends[:, 0] / climb + z_ends[:, 1] / descent) \
        / (1.0 / climb + 1.0 / descent)
    return dict(duration=T, airports=pairs, speed=speed, climb=climb, descent=descent,
                cruise=np.minimum(cruise, cap), z_ends=z_ends, start=a, waypoint=w, end=b,
                turn_rate=turn)


def distance_to_path(f, point):
    """Map distance (F,) from a point (2,) to each flight's two legs A-W-B (a lower bound of
    the distance to its path up to the arc's cut of the corner, at most rho (1 - cos) < 2 km)."""
    def seg(p, q):
        d = q - p
        t = np.clip(np.sum((point - p) * d, -1) / np.maximum(np.sum(d * d, -1), 1e-300), 0, 1)
        return np.linalg.norm(p + t[:, None] * d - point, axis=-1)
    return np.minimum(seg(f.start, f.waypoint), seg(f.waypoint, f.end))
