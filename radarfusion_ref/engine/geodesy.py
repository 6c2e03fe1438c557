r"""WGS-84 geodesy: geodetic coordinates to a local east-north-up frame.

A fusion centre works in one Cartesian frame; its reports and its truth arrive as
latitude, longitude and height on the WGS-84 ellipsoid. :func:`geodetic_to_enu` maps
them (closed form, no iteration) to east, north and up about a chosen origin.

.. rubric:: References

.. [1] National Imagery and Mapping Agency, "Department of Defense World Geodetic
   System 1984", NIMA TR8350.2, 3rd ed. (2000): the constants ``WGS84_A`` and
   ``WGS84_F``.
"""

from __future__ import annotations

import numpy as np

from .validation import as_float, as_float_array, describe

__all__ = ["WGS84_A", "WGS84_F", "enu_rotation", "geodetic_to_enu"]

#: WGS-84 semi-major axis :math:`a` (m).
WGS84_A = 6378137.0
#: WGS-84 flattening :math:`f`.
WGS84_F = 1.0 / 298.257223563
_E2 = WGS84_F * (2.0 - WGS84_F)          # first eccentricity squared, e^2 = f (2 - f)


def _ecef(lat, lon, h):
    """Earth-centred, Earth-fixed position (m) of geodetic coordinates (degrees, m)."""
    phi, lam = np.radians(lat), np.radians(lon)
    n = WGS84_A / np.sqrt(1.0 - _E2 * np.sin(phi) ** 2)              # N(phi)
    return np.stack([(n + h) * np.cos(phi) * np.cos(lam), (n + h) * np.cos(phi) * np.sin(lam),
                     (n * (1.0 - _E2) + h) * np.sin(phi)], axis=-1)


def enu_rotation(lat0, lon0):
    r"""The rotation from Earth-centred axes to the east-north-up axes at a point.

    Parameters
    ----------
    lat0, lon0 : float
        Geodetic latitude and longitude of the point, in degrees.

    Returns
    -------
    numpy.ndarray, shape (3, 3)
        Rows: the east, north and up unit vectors at the point, in Earth-centred
        axes, so ``enu_rotation(lat0, lon0) @ d`` gives the east, north and up parts
        of an Earth-centred vector ``d``.

    Raises
    ------
    ValueError
        If an argument is not a single finite number.
    TypeError
        If an argument is not numeric.

    Examples
    --------
    >>> enu_rotation(0.0, 0.0)
    array([[-0.,  1.,  0.],
           [-0., -0.,  1.],
           [ 1.,  0.,  0.]])
    """
    p0, l0 = np.radians(as_float(lat0, "lat0")), np.radians(as_float(lon0, "lon0"))
    return np.array([[-np.sin(l0), np.cos(l0), 0.0],
                     [-np.sin(p0) * np.cos(l0), -np.sin(p0) * np.sin(l0), np.cos(p0)],
                     [np.cos(p0) * np.cos(l0), np.cos(p0) * np.sin(l0), np.sin(p0)]])


def _geodetic_iv(lat, lon, h, origin):
    lat = as_float_array(lat, "lat")
    lon = as_float_array(lon, "lon")
    h = as_float_array(h, "h")
    o = as_float_array(origin, "origin")
    if o.shape != (3,):
        raise ValueError(f"`origin` must be (lat, lon, h); received {describe(origin)}")
    for name, arr, lim in (("lat", lat, 90.0), ("lon", lon, 180.0)):
        if np.any(np.abs(arr) > lim):
            raise ValueError(f"`{name}` must lie in [-{lim:g}, {lim:g}] degrees; received "
                             f"{describe(arr)}")
    if abs(o[0]) > 90 or abs(o[1]) > 180:
        raise ValueError(f"`origin` latitude must lie in [-90, 90] and longitude in "
                         f"[-180, 180]; received {describe(origin)}")
    try:
        lat, lon, h = np.broadcast_arrays(lat, lon, h)
    except ValueError:
        raise ValueError(f"`lat`, `lon` and `h` must broadcast; received shapes {lat.shape}, "
                         f"{lon.shape}, {h.shape}") from None
    return lat, lon, h, o


def geodetic_to_enu(lat, lon, h, *, origin) -> np.ndarray:
    r"""WGS-84 geodetic coordinates to east-north-up about an origin (closed form).

    Parameters
    ----------
    lat, lon : array_like
        Latitude in [-90, 90] and longitude in [-180, 180] (degrees).
    h : array_like
        Ellipsoidal height (m). The three broadcast together.
    origin : sequence of 3 floats
        ``(lat0, lon0, h0)`` of the frame's origin (degrees, degrees, m).

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
    With :math:`a` = :data:`WGS84_A`, :math:`f` = :data:`WGS84_F`, :math:`e^2 = f(2-f)`
    and :math:`N = a/\sqrt{1 - e^2\sin^2\varphi}`, the Earth-centred position is
    :math:`((N+h)\cos\varphi\cos\lambda, (N+h)\cos\varphi\sin\lambda,
    (N(1-e^2)+h)\sin\varphi)`; ENU is its difference from the origin's, rotated by
    the origin's east, north and up unit vectors.

    Examples
    --------
    >>> np.round(geodetic_to_enu(0.0, 90.0, 0.0, origin=(0.0, 0.0, 0.0)), 3)
    array([ 6378137.,        0., -6378137.])
    """
    lat, lon, h, o = _geodetic_iv(lat, lon, h, origin)
    d = _ecef(lat, lon, h) - _ecef(o[0], o[1], o[2])          # g - g0
    return d @ enu_rotation(o[0], o[1]).T                     # (e, n, u) . (g - g0)
