r"""The capstone's truth: the committed hour of ADS-B traffic, and the aircraft at scan times.

The hour (2018-08-01 11:00–12:00 UTC over Switzerland, 142 aircraft) ships inside the
package as ``radarfusion_ref/capstone/data/switzerland_busiest_hour.csv.gz`` (its
``README.md`` beside it gives the source, licence and columns; the script beside it
regenerates it byte for byte). :func:`load_traffic` reads it with
:mod:`importlib.resources`, so a plain (non-editable) install finds it, and
:func:`truth_scans` interpolates the aircraft at the scan times in the east-north-up
frame about :data:`ORIGIN`.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import math
import zlib
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from ..engine.geodesy import geodetic_to_enu
from ..engine.validation import (
    MEMORY_LIMIT,
    as_choice,
    as_float,
    as_float_array,
    as_positive,
    check_size,
    describe,
)

__all__ = [
    "COLUMNS",
    "DATA_FILE",
    "FRESH_BAND",
    "HOURS",
    "ORIGIN",
    "SPEED_BOUNDS",
    "SPEED_CLASSES",
    "TUNING_FILE",
    "Traffic",
    "BORDERS_FILE",
    "TruthScans",
    "border_lines",
    "load_traffic",
    "truth_at",
    "truth_scans",
]

#: The committed hour, a resource of this package (``data/README.md`` beside it). A
#: :class:`importlib.resources.abc.Traversable`: ``DATA_FILE.read_bytes()`` works in any
#: install, also from a zip.
DATA_FILE = resources.files(__package__).joinpath("data", "switzerland_busiest_hour.csv.gz")
#: The second busiest hour of the same day (09:00–10:00 UTC, 128 aircraft), extracted the
#: same way: trackers are tuned on it, never on the scored hour ``load_traffic(hour="tuning")``.
TUNING_FILE = resources.files(__package__).joinpath("data", "switzerland_tuning_hour.csv.gz")
#: The committed hours of :func:`load_traffic`.
HOURS = {"scored": DATA_FILE, "tuning": TUNING_FILE}
#: Country borders around Switzerland (Natural Earth, public domain; ``data/borders_README.md``
#: beside it), read by :func:`border_lines`.
BORDERS_FILE = resources.files(__package__).joinpath("data", "borders.json")

#: Header of a traffic file (integers, except the two names).
COLUMNS = ("t_s", "icao24", "callsign", "lat_e5", "lon_e5", "alt_ft", "gs_kt", "track_deg")

#: Origin of the common east-north-up frame: latitude, longitude (degrees, WGS-84) and
#: ellipsoidal height (m) — the middle of the data's box (45.8–47.8 N, 6.0–10.5 E).
ORIGIN = (46.8, 8.2, 0.0)

#: Speed classes of the recognition step, by ground speed: slow < 440 kt <= medium
#: < 465 kt <= fast (about the tertiles of the committed hour).
SPEED_CLASSES = ("slow", "medium", "fast")
SPEED_BOUNDS = (440.0, 465.0)

_FT = 0.3048                        # metres per foot
_KT = 1852.0 / 3600.0               # metres per second per knot
#: A record is fresh when its horizontal move from the last fresh record is within this
#: band of what the ground speed allows (times the elapsed time), or within _SLACK m of it.
FRESH_BAND = (0.5, 1.5)
_SLACK = 50.0


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


def _read_iv(path, hour="scored"):
    """The raw bytes of `path` (default: the committed hour named by `hour`)."""
    hour = as_choice(hour, "hour", tuple(HOURS))
    if path is None:
        return HOURS[hour], HOURS[hour].read_bytes()
    if isinstance(path, bool) or not isinstance(path, (str, Path)):
        raise TypeError(f"`path` must be a file path (str or pathlib.Path); received "
                        f"{describe(path)}")
    p = Path(path)
    if not p.is_file():
        raise _bad_file(p, "no such file (the default, load_traffic(), reads the committed "
                           "hour shipped with the package)")
    return p, p.read_bytes()


def _parse(p, raw):
    """Columns of a traffic file: names, then the integer columns by name."""
    try:
        text = gzip.decompress(raw).decode("ascii")
    except (OSError, EOFError, zlib.error) as exc:
        raise _bad_file(p, f"not a complete gzip file ({exc})") from None
    except UnicodeDecodeError:
        raise _bad_file(p, "the decompressed data is not ASCII text") from None
    rows = list(csv.reader(io.StringIO(text)))
    if not rows or tuple(rows[0]) != COLUMNS:
        raise _bad_file(p, f"the header must be {','.join(COLUMNS)}; received "
                           f"{','.join(rows[0]) if rows else '(empty file)'!r}")
    body = rows[1:]
    if not body:
        raise _bad_file(p, "the file holds no records")
    bad = [k for k, r in enumerate(body) if len(r) != len(COLUMNS)]
    if bad:
        raise _bad_file(p, f"row {bad[0] + 2} has {len(body[bad[0]])} columns, not "
                           f"{len(COLUMNS)}")
    cols = list(zip(*body, strict=True))
    num = {}
    for k, name in enumerate(COLUMNS):
        if name in ("icao24", "callsign"):
            continue
        try:
            num[name] = np.array(cols[k], dtype=np.int64)
        except (ValueError, OverflowError):
            j = next((i for i, v in enumerate(cols[k]) if not v.strip().lstrip("-").isdigit()),
                     None)
            if j is None:                       # all digits: one beyond the 64-bit range
                j = next(i for i, v in enumerate(cols[k]) if abs(int(v)) >= 2**63)
                raise _bad_file(p, f"column {name!r}, row {j + 2}: {cols[k][j]!r} lies beyond "
                                   "the 64-bit integer range") from None
            raise _bad_file(p, f"column {name!r}, row {j + 2}: {cols[k][j]!r} is not an "
                               "integer") from None
    for name, scale, lo, hi in (("lat_e5", 1e-5, -90, 90), ("lon_e5", 1e-5, -180, 180),
                                ("t_s", 1, 0, np.inf), ("gs_kt", 1, 0, np.inf)):
        arr = num[name] * scale
        out = np.flatnonzero((arr < lo) | (arr > hi))
        if out.size:
            raise _bad_file(p, f"column {name!r}, row {out[0] + 2}: {arr[out[0]]} is outside "
                               f"[{lo}, {hi}]")
    return np.array(cols[1]), np.array(cols[2]), num


def load_traffic(path=None, *, hour="scored") -> Traffic:
    """Load the committed ADS-B hour (or a file of the same format).

    Parameters
    ----------
    path : str or pathlib.Path, optional
        A gzip CSV with header ``t_s,icao24,callsign,lat_e5,lon_e5,alt_ft,gs_kt,track_deg``
        (:data:`COLUMNS`; integers, except the two names). Default: the committed hour
        named by `hour`; no network access, no extra package.
    hour : {"scored", "tuning"}, optional
        Without `path`: :data:`DATA_FILE` (default, 11:00–12:00 UTC, the hour every result
        is scored on) or :data:`TUNING_FILE` (09:00–10:00 UTC, the hour to tune on).

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
    p, raw = _read_iv(path, hour)
    icao, calls, num = _parse(p, raw)
    names, aircraft = np.unique(icao, return_inverse=True)
    order = np.lexsort((num["t_s"], aircraft))
    first = {}
    for a, c in zip(aircraft[order], calls[order], strict=True):
        first.setdefault(int(a), c)
    return Traffic(
        t=num["t_s"][order].astype(float), aircraft=aircraft[order].astype(np.int64),
        icao24=tuple(str(n) for n in names), callsign=tuple(first[a] for a in range(names.size)),
        lat=num["lat_e5"][order] * 1e-5, lon=num["lon_e5"][order] * 1e-5,
        alt=num["alt_ft"][order] * _FT, speed=num["gs_kt"][order].astype(float),
        track=num["track_deg"][order].astype(float))


def border_lines() -> list[np.ndarray]:
    """The country borders around Switzerland in the common frame, for maps.

    Every border of Switzerland, France, Germany, Italy, Austria and Liechtenstein inside
    3.5–13.0° E, 44.5–49.2° N (:data:`BORDERS_FILE`, Natural Earth), projected at height
    0 with :func:`radarfusion_ref.engine.geodesy.geodetic_to_enu` about :data:`ORIGIN`.

    Returns
    -------
    list of numpy.ndarray, shape (k, 2)
        One polyline per border: east and north (m).

    Examples
    --------
    >>> lines = border_lines()
    >>> len(lines), lines[0].shape[1]
    (16, 2)
    """
    data = json.loads(BORDERS_FILE.read_text(encoding="utf-8"))
    out = []
    for line in data["lines"]:
        lonlat = np.asarray(line["lonlat"], dtype=float)
        out.append(geodetic_to_enu(lonlat[:, 1], lonlat[:, 0], 0.0, origin=ORIGIN)[:, :2])
    return out


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
        Interpolated ENU position (m) about :data:`ORIGIN`.
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


def _truth_iv(traffic, period, start, duration, max_gap):
    if not isinstance(traffic, Traffic):
        raise TypeError(f"`traffic` must be a Traffic (from load_traffic); received "
                        f"{describe(traffic)}")
    period = as_float(as_positive(period, "period"), "period")
    start = as_float(as_positive(start, "start", strict=False), "start")
    duration = as_float(as_positive(duration, "duration"), "duration")
    max_gap = as_float(as_positive(max_gap, "max_gap"), "max_gap")
    n_scans = math.ceil(duration / period - 1e-9)
    check_size(8 * 8 * n_scans * len(traffic.icao24), MEMORY_LIMIT,
               what=f"bytes of truth rows ({n_scans} scans of `duration` / `period` x "
                    f"{len(traffic.icao24)} aircraft)",
               alternative="a longer `period` or a shorter `duration`, in windows")
    return period, start, duration, max_gap, n_scans


def _at_scans(t, times, max_gap):
    """Scan indices at which an aircraft with record times `t` is placed."""
    k = np.searchsorted(t, times, side="right") - 1             # record at or before
    ok = (k >= 0) & (k < t.size - 1)
    exact = (k >= 0) & (t[np.maximum(k, 0)] == times)            # a record at the scan
    kk = np.clip(k, 0, max(t.size - 2, 0))
    if t.size >= 2:
        ok &= (t[kk + 1] - t[kk]) <= max_gap
    return np.flatnonzero(ok | exact)


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
    period, start, duration, max_gap, n_scans = _truth_iv(traffic, period, start, duration,
                                                          max_gap)
    times = start + period * np.arange(n_scans)
    enu = geodetic_to_enu(traffic.lat, traffic.lon, traffic.alt, origin=ORIGIN)
    bounds = np.flatnonzero(np.diff(traffic.aircraft)) + 1
    starts = np.concatenate([[0], bounds])
    stops = np.concatenate([bounds, [traffic.t.size]])
    parts = []
    for a0, a1 in zip(starts, stops, strict=True):
        t = traffic.t[a0:a1]
        s = _at_scans(t, times, max_gap)
        if not s.size:
            continue
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


# ----------------------------------------------------------------------------- truth at any time
def _fresh(t, xy, speed, max_gap):
    """Mask of the fresh records of one aircraft (the rule of :func:`truth_at`)."""
    keep = np.ones(t.size, dtype=bool)
    last = 0
    lo, hi = FRESH_BAND
    for k in range(1, t.size):
        dt = t[k] - t[last]
        d = math.hypot(xy[k, 0] - xy[last, 0], xy[k, 1] - xy[last, 1])
        e = 0.5 * (speed[k] + speed[last]) * _KT * dt
        if dt > max_gap or lo * e <= d <= hi * e or abs(d - e) <= _SLACK:
            last = k
        else:
            keep[k] = False
    return keep


def _truth_at_iv(traffic, times, max_gap):
    if not isinstance(traffic, Traffic):
        raise TypeError(f"`traffic` must be a Traffic (from load_traffic); received "
                        f"{describe(traffic)}")
    tt = np.asarray(as_float_array(times, "times"), dtype=float)
    if tt.ndim != 1:
        raise ValueError(f"`times` must be a 1-D array of instants (s); received shape "
                         f"{tt.shape}")
    max_gap = as_float(as_positive(max_gap, "max_gap"), "max_gap")
    check_size(8 * 8 * tt.size * len(traffic.icao24), MEMORY_LIMIT,
               what=f"bytes of truth ({tt.size} `times` x {len(traffic.icao24)} aircraft)",
               alternative="fewer `times` per call (the distinct scan instants, in windows)")
    return tt, max_gap


def truth_at(traffic, times, *, max_gap=30.0, return_velocity=False, fresh_only=True):
    r"""Every aircraft at any instants: ADS-B records interpolated by their own time stamps.

    Parameters
    ----------
    traffic : Traffic
        From :func:`load_traffic`.
    times : array_like, shape (T,)
        Instants (s from the window start), in any order.
    max_gap : float, optional
        Largest time between the two records an instant is interpolated between
        (s, default 30); never extrapolated.
    return_velocity : bool, optional
        Also return the velocity (default False).
    fresh_only : bool, optional
        Interpolate between the fresh records only (default; the rule below) or between
        all records (``False``: the stop-and-jump steps of stale records stay in).

    Returns
    -------
    position : numpy.ndarray, shape (A, T, 3)
        East, north, up (m) about :data:`ORIGIN` of aircraft ``a`` (index into
        ``traffic.icao24``) at ``times[j]``; NaN where not valid.
    valid : numpy.ndarray of bool, shape (A, T)
        Whether the aircraft is known at that instant.
    velocity : numpy.ndarray, shape (A, T, 3)
        Only with `return_velocity`: the slope (m/s) of the segment the instant lies on
        (the segment after it at a record's own time; the one before at the last record).

    Raises
    ------
    TypeError
        If `traffic` is not a :class:`Traffic`.
    ValueError
        Non-finite or non-1-D `times`, non-positive `max_gap`, or A x T beyond the memory
        limit.

    Notes
    -----
    The rule. A record's time stamp is the instant of its position only if the position
    was updated for it; a stale record repeats an old position, so the aircraft seems to
    stop, then jump ahead at the next fresh record. A record is **fresh** when its
    horizontal move from the last fresh record of its aircraft lies within
    :data:`FRESH_BAND` (0.5 to 1.5 times) of the distance its ground speed allows over
    the elapsed time (the mean of the two records' ground speeds), or within 50 m of it;
    the first record is fresh, and so is any record more than `max_gap` after the last
    fresh one (a new segment). Positions are linear in time between consecutive fresh
    records (WGS-84 to ENU first, :func:`radarfusion_ref.engine.geodesy.geodetic_to_enu`),
    at an instant bracketed by two fresh records at most `max_gap` apart, or at a fresh
    record's own time.

    Examples
    --------
    >>> pos, ok = truth_at(load_traffic(), [0.0, 5.0])
    >>> pos.shape, ok.shape
    ((142, 2, 3), (142, 2))
    """
    tt, max_gap = _truth_at_iv(traffic, times, max_gap)
    A, T = len(traffic.icao24), tt.size
    pos = np.full((A, T, 3), np.nan)
    vel = np.full((A, T, 3), np.nan)
    valid = np.zeros((A, T), dtype=bool)
    enu = geodetic_to_enu(traffic.lat, traffic.lon, traffic.alt, origin=ORIGIN)
    bounds = np.flatnonzero(np.diff(traffic.aircraft)) + 1
    for a0, a1 in zip(np.concatenate([[0], bounds]), np.concatenate([bounds, [traffic.t.size]]),
                      strict=True):
        a = int(traffic.aircraft[a0])
        t, p = traffic.t[a0:a1], enu[a0:a1]
        if fresh_only:
            keep = _fresh(t, p, traffic.speed[a0:a1], max_gap)
            t, p = t[keep], p[keep]
        k = np.searchsorted(t, tt, side="right") - 1                  # record at or before
        exact = (k >= 0) & (t[np.maximum(k, 0)] == tt)
        if t.size < 2:                                # one record: known at its time only
            ok = exact
            here = np.repeat(p[:1], T, axis=0)
            slope = np.full((T, 3), np.nan)
        else:
            kk = np.clip(k, 0, t.size - 2)
            span = t[kk + 1] - t[kk]
            inside = (k >= 0) & (k < t.size - 1) & (span <= max_gap)
            ok = inside | exact
            w = np.where(inside, (tt - t[kk]) / span, 0.0)
            here = p[kk] + w[:, None] * (p[kk + 1] - p[kk])
            here[exact] = p[k[exact]]
            # the segment the instant lies on; at the last record the one before it
            slope = (p[kk + 1] - p[kk]) / span[:, None]
            slope[exact & (span > max_gap)] = np.nan     # a lone record: no segment to read
        pos[a, ok] = here[ok]
        vel[a, ok] = slope[ok]
        valid[a] = ok
    return (pos, valid, vel) if return_velocity else (pos, valid)
