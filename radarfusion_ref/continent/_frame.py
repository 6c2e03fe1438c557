r"""Kernels of the continental map frame (trusted input; the doors are in :mod:`.scenario`).

The map: WGS-84 geodetic latitude :math:`\varphi` → conformal latitude :math:`\chi` (Gauss's
conformal sphere, radius :math:`R`), then the stereographic projection of the sphere onto the
plane tangent at the origin; the third coordinate is the height :math:`h` above the
ellipsoid. Both steps are conformal, so the whole map is.
"""

from __future__ import annotations

import functools

import numpy as np

from ..engine.geodesy import WGS84_A, WGS84_F

_E2 = WGS84_F * (2.0 - WGS84_F)          # e^2 = f (2 - f)
_E = np.sqrt(_E2)
#: Fixed-point iterations of the inverse conformal latitude and of ECEF -> geodetic: the
#: error shrinks by a factor about e^2 (0.0067) per iteration, so 7 reach rounding.
_ITER = 7


def conformal_latitude(phi):
    r""":math:`\chi = 2\arctan\!\big(\tan(\pi/4 + \varphi/2)\,
    ((1 - e\sin\varphi)/(1 + e\sin\varphi))^{e/2}\big) - \pi/2` (radians)."""
    s = _E * np.sin(phi)
    return 2.0 * np.arctan(np.tan(np.pi / 4 + phi / 2) * ((1 - s) / (1 + s)) ** (_E / 2)) \
        - np.pi / 2


def geodetic_latitude(chi):
    """Inverse of :func:`conformal_latitude` by fixed-point iteration (radians)."""
    t = np.tan(np.pi / 4 + chi / 2)
    phi = np.array(chi, dtype=float, copy=True)
    for _ in range(_ITER):
        s = _E * np.sin(phi)
        phi = 2.0 * np.arctan(t * ((1 + s) / (1 - s)) ** (_E / 2)) - np.pi / 2
    return phi


def radii(phi):
    """Meridian radius M and prime-vertical radius N of the ellipsoid at latitude phi."""
    w2 = 1.0 - _E2 * np.sin(phi) ** 2
    n = WGS84_A / np.sqrt(w2)
    return n * (1.0 - _E2) / w2, n


class Frame:
    """The constants of the map about one origin (lat0, lon0 in degrees)."""

    def __init__(self, lat0: float, lon0: float):
        self.lat0, self.lon0 = float(lat0), float(lon0)
        phi0 = np.radians(self.lat0)
        self.lam0 = np.radians(self.lon0)
        self.chi0 = float(conformal_latitude(phi0))
        # sphere radius making the scale exactly 1 at the origin: R cos(chi0) = N0 cos(phi0)
        self.radius = float(radii(phi0)[1] * np.cos(phi0) / np.cos(self.chi0))
        self.s0, self.c0 = np.sin(self.chi0), np.cos(self.chi0)

    # ------------------------------------------------------------------ projection
    def forward(self, lat, lon, h):
        """(lat, lon deg, h m) -> (x, y, z) map metres, shape (..., 3)."""
        chi = conformal_latitude(np.radians(lat))
        dl = np.radians(lon) - self.lam0
        sc, cc, cl = np.sin(chi), np.cos(chi), np.cos(dl)
        k = 2.0 * self.radius / (1.0 + self.s0 * sc + self.c0 * cc * cl)
        return np.stack([k * cc * np.sin(dl), k * (self.c0 * sc - self.s0 * cc * cl),
                         np.asarray(h, dtype=float) + 0.0 * k], axis=-1)

    def inverse(self, xyz):
        """(x, y, z) map metres -> (lat, lon deg, h m), shape (..., 3)."""
        x, y = xyz[..., 0], xyz[..., 1]
        rho = np.hypot(x, y)
        c = 2.0 * np.arctan(rho / (2.0 * self.radius))
        sc, cc = np.sin(c), np.cos(c)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(rho > 0, y * sc / np.where(rho > 0, rho, 1.0), 0.0)
        chi = np.arcsin(np.clip(cc * self.s0 + ratio * self.c0, -1.0, 1.0))
        dl = np.arctan2(x * sc, rho * self.c0 * cc - y * self.s0 * sc)
        lon = np.degrees((dl + self.lam0 + np.pi) % (2 * np.pi) - np.pi)
        return np.stack([np.degrees(geodetic_latitude(chi)), lon, xyz[..., 2] + 0.0 * x],
                        axis=-1)

    def east_image(self, lat, lon):
        r"""(dx/d\lambda, dy/d\lambda) of the map at ground points (per radian of longitude)."""
        chi = conformal_latitude(np.radians(lat))
        dl = np.radians(lon) - self.lam0
        sc, cc, cl, sl = np.sin(chi), np.cos(chi), np.cos(dl), np.sin(dl)
        d = 1.0 + self.s0 * sc + self.c0 * cc * cl
        k = 2.0 * self.radius / d
        dk = k * self.c0 * cc * sl / d                          # dk/dlambda
        return np.stack([dk * cc * sl + k * cc * cl,
                         dk * (self.c0 * sc - self.s0 * cc * cl) + k * self.s0 * cc * sl], -1)

    def jacobian(self, geo):
        """d(x, y, z)/d(ECEF) at geodetic points geo (..., 3): shape (..., 3, 3).

        On the ellipsoid the map takes a ground step of dE metres east and dN north to
        k R(gamma) (dE, dN) (conformal: a scale k and a rotation, the convergence gamma);
        at height h a step of e metres east is e N / (N + h) metres of the ground (and
        n M / (M + h) north), and the height follows the up component.
        """
        phi, lam = np.radians(geo[..., 0]), np.radians(geo[..., 1])
        m, n = radii(phi)
        h = geo[..., 2]
        g = self.east_image(geo[..., 0], geo[..., 1]) / (n * np.cos(phi))[..., None]
        a, b = g[..., 0], g[..., 1]                               # k cos(gamma), k sin(gamma)
        fe, fn = n / (n + h), m / (m + h)
        sp, cp, sl, cl = np.sin(phi), np.cos(phi), np.sin(lam), np.cos(lam)
        east = np.stack([-sl, cl, 0.0 * sl], -1)
        north = np.stack([-sp * cl, -sp * sl, cp], -1)
        up = np.stack([cp * cl, cp * sl, sp], -1)
        row_x = (a * fe)[..., None] * east - (b * fn)[..., None] * north
        row_y = (b * fe)[..., None] * east + (a * fn)[..., None] * north
        return np.stack([row_x, row_y, up], axis=-2)


def ecef(geo):
    """Earth-centred, Earth-fixed position (m) of geodetic points (..., 3) (deg, deg, m)."""
    phi, lam, h = np.radians(geo[..., 0]), np.radians(geo[..., 1]), geo[..., 2]
    n = WGS84_A / np.sqrt(1.0 - _E2 * np.sin(phi) ** 2)
    return np.stack([(n + h) * np.cos(phi) * np.cos(lam), (n + h) * np.cos(phi) * np.sin(lam),
                     (n * (1.0 - _E2) + h) * np.sin(phi)], axis=-1)


def geodetic(p):
    """Geodetic (lat deg, lon deg, h m) of ECEF points (..., 3), by fixed-point iteration.

    Valid away from the poles and the Earth's centre (all the continent's points).
    """
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    r = np.hypot(x, y)
    phi = np.arctan2(z, r * (1.0 - _E2))
    for _ in range(_ITER):
        n = WGS84_A / np.sqrt(1.0 - _E2 * np.sin(phi) ** 2)
        h = r / np.cos(phi) - n
        phi = np.arctan2(z, r * (1.0 - _E2 * n / (n + h)))
    n = WGS84_A / np.sqrt(1.0 - _E2 * np.sin(phi) ** 2)
    h = r / np.cos(phi) - n
    return np.stack([np.degrees(phi), np.degrees(np.arctan2(y, x)), h], axis=-1)


@functools.lru_cache(maxsize=8)
def frame_of(lat0: float, lon0: float) -> Frame:
    """The (cached) :class:`Frame` about an origin."""
    return Frame(lat0, lon0)
