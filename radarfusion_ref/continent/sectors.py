r"""The fusion centre split by sectors: one tracker per sector, hand-over across borders.

An area control centre splits its airspace into sectors, each with its own tracker, and
hands a track over when its aircraft crosses a border. Here:

* :class:`Sectors` — a grid of rectangles in the common frame's east and north, with an
  overlap: each sector's tracker sees the reports inside its rectangle grown by the
  overlap; :func:`sector_grid` builds one from the reports' extent and the counts;
* :func:`track_sectored` — one :func:`~radarfusion_ref.tracking.track_reports` per sector
  (with :func:`sector_settings`),
  in this process or one task per sector on a Dask cluster (the same answer, bit for bit),
  then the hand-over: one merged :class:`~radarfusion_ref.tracking.TrackHistory` over the
  whole airspace in which an aircraft that crosses a border keeps its identity;
  :class:`SectoredTracks` holds it with per-sector diagnostics, and :class:`SectorError`
  names the sector whose tracker failed.

The sectored answer is not the single tracker's: a sector's tracker sees only its own
reports (a radar scan with no report in a sector is not seen there, so it scores no miss
there), and its track identities are its own until the hand-over joins them.
``benchmarks/bench_sectors.py`` measures the difference on the Swiss hour (mean GOSPA)
and the run times.
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass

import numpy as np

from .. import gating
from ..engine.montecarlo import as_client
from ..engine.validation import (
    MEMORY_LIMIT,
    as_covariance,
    as_float,
    as_float_array,
    as_int,
    check_size,
    describe,
)
from ..tracking import MAX_REPORTS, TrackerSettings, TrackHistory
from ._sectors_merge import Links, merge
from ._sectors_run import on_cluster, run_sector

__all__ = ["MAX_LOST", "MAX_SECTORS", "REPORT_BYTES", "SectorError", "SectoredTracks", "Sectors",
           "sector_grid", "sector_settings", "track_sectored"]

#: Most sectors of one grid (one tracker, and on a cluster one task, each).
MAX_SECTORS = 65_536

#: Times a sector's task may be cancelled because every worker's copy of the scattered
#: reports was lost (they are scattered and the task submitted again) before the run fails.
MAX_LOST = 3

#: Bytes of one report's copy in a sector's inputs (time, position, covariance, radar,
#: scan): the unit of the memory check of :func:`track_sectored`.
REPORT_BYTES = 8 + 3 * 8 + 9 * 8 + 8 + 8


class SectorError(RuntimeError):
    """The tracker of one sector failed; the message names the sector (index and bounds)
    and the run returns nothing (no sector is silently left out)."""


def _edges_iv(value, name):
    e = as_float_array(value, name, ndim_min=1)
    if e.ndim != 1 or e.size < 2:
        raise ValueError(f"`{name}` must be a 1-D array of at least 2 edges (one sector "
                         f"between each two); received {describe(value)}")
    step = np.diff(e)
    if np.any(step <= 0):
        k = int(np.flatnonzero(step <= 0)[0])
        raise ValueError(f"`{name}` must be strictly increasing (every sector of positive "
                         f"extent); received edges {e[k]:.6g} then {e[k + 1]:.6g} at "
                         f"positions {k}, {k + 1} of {describe(value)}")
    return e


def _overlap_iv(overlap):
    w = as_float(overlap, "overlap")
    if w < 0:
        raise ValueError(f"`overlap` must be a finite width >= 0 (the positions' unit); "
                         f"received {overlap!r}")
    return w


@dataclass(frozen=True, eq=False)
class Sectors:
    r"""A grid of rectangular sectors in the common frame's east and north, with an overlap.

    Sector :math:`k = j\,n_e + i` (:math:`i` the column from west, :math:`j` the row from
    south) is the rectangle :math:`[e_i, e_{i+1}) \times [n_j, n_{j+1})` (closed at the
    grid's east and north edges). It **owns** the positions inside it; positions beyond
    the grid's outer edges belong to the nearest border sector. Its tracker sees the
    reports inside the rectangle **grown** by `overlap` on every side,
    :math:`[e_i - w, e_{i+1} + w] \times [n_j - w, n_{j+1} + w]`.

    Attributes
    ----------
    east : numpy.ndarray, shape (n_east + 1,)
        Strictly increasing east edges (the positions' unit).
    north : numpy.ndarray, shape (n_north + 1,)
        Strictly increasing north edges.
    overlap : float
        :math:`w \ge 0`, finite: how far each sector's tracker sees beyond its borders.
        To hand a track over, the band :math:`2w` wide along a border must hold enough
        scans for the next sector's tracker to confirm its track before the aircraft
        leaves the previous sector's sight: more than the distance an aircraft flies in
        a few scans (airliners, scans of 4 to 12 s: 20 km is ample).

    Raises
    ------
    ValueError
        Edges not strictly increasing (a sector of zero or negative extent), fewer than
        two edges, an `overlap` negative or not finite, more than :data:`MAX_SECTORS`
        sectors.
    TypeError
        Non-numeric edges or overlap.

    Examples
    --------
    >>> g = Sectors([0.0, 50e3, 100e3], [0.0, 80e3], overlap=10e3)
    >>> g.n_sectors, g.bounds(1)
    (2, (50000.0, 100000.0, 0.0, 80000.0))
    >>> g.owner([[49e3, 5e3], [50e3, 5e3], [130e3, -9e3]]).tolist()
    [0, 1, 1]
    """

    east: np.ndarray
    north: np.ndarray
    overlap: float

    def __post_init__(self):
        east = _edges_iv(self.east, "east").copy()              # read-only copies
        north = _edges_iv(self.north, "north").copy()
        count = (east.size - 1) * (north.size - 1)
        if count > MAX_SECTORS:
            raise ValueError(f"`east`, `north`: {east.size - 1} x {north.size - 1} = {count} "
                             f"sectors exceed MAX_SECTORS = {MAX_SECTORS} (one tracker each); "
                             "use fewer, larger sectors")
        east.flags.writeable = False
        north.flags.writeable = False
        object.__setattr__(self, "east", east)
        object.__setattr__(self, "north", north)
        object.__setattr__(self, "overlap", _overlap_iv(self.overlap))

    @property
    def shape(self) -> tuple[int, int]:
        """``(n_north, n_east)``: rows and columns of the grid."""
        return self.north.size - 1, self.east.size - 1

    @property
    def n_sectors(self) -> int:
        """Number of sectors, ``n_east * n_north``."""
        return (self.east.size - 1) * (self.north.size - 1)

    def bounds(self, k) -> tuple[float, float, float, float]:
        """``(east_min, east_max, north_min, north_max)`` of sector `k` (without overlap).

        Examples
        --------
        >>> Sectors([0.0, 1.0, 3.0], [0.0, 2.0, 5.0], overlap=0.5).bounds(3)
        (1.0, 3.0, 2.0, 5.0)
        """
        k = as_int(k, "k", minimum=0, maximum=self.n_sectors - 1)
        i, j = k % (self.east.size - 1), k // (self.east.size - 1)
        return (float(self.east[i]), float(self.east[i + 1]), float(self.north[j]),
                float(self.north[j + 1]))

    def owner(self, position) -> np.ndarray:
        """The sector that owns each position (its east and north; beyond the grid: the
        nearest border sector).

        Parameters
        ----------
        position : array_like, shape (N, 2) or (N, 3)
            East, north (and up, ignored), finite.

        Returns
        -------
        numpy.ndarray of int, shape (N,)

        Examples
        --------
        >>> Sectors([0.0, 1.0, 2.0], [0.0, 1.0, 2.0], overlap=0.1).owner(
        ...     [[0.5, 0.5], [1.5, 0.5], [0.5, 1.5], [1.0, 1.0]]).tolist()
        [0, 1, 2, 3]
        """
        p = as_float_array(position, "position", ndim_min=2)
        if p.ndim != 2 or p.shape[1] not in (2, 3):
            raise ValueError(f"`position` must have shape (N, 2) or (N, 3); received shape "
                             f"{p.shape}")
        return self._owner(p)

    def _owner(self, p):
        """Kernel of :meth:`owner` (positions (N, >= 2), trusted)."""
        i = np.searchsorted(self.east[1:-1], p[:, 0], side="right")
        j = np.searchsorted(self.north[1:-1], p[:, 1], side="right")
        return (j * (self.east.size - 1) + i).astype(np.int64)

    def _grown_edges(self):
        """Kernel: the grown rectangles' edges ``(lo_e, hi_e, lo_n, hi_n)`` per column/row."""
        w = self.overlap
        return (self.east[:-1] - w, self.east[1:] + w, self.north[:-1] - w, self.north[1:] + w)

    def _in_grown(self, p, k):
        """Kernel: which of the positions `p` (N, >= 2) lie in sector `k`'s grown rectangle."""
        lo_e, hi_e, lo_n, hi_n = self._grown_edges()
        i, j = k % lo_e.size, k // lo_e.size
        return ((p[:, 0] >= lo_e[i]) & (p[:, 0] <= hi_e[i])
                & (p[:, 1] >= lo_n[j]) & (p[:, 1] <= hi_n[j]))

    def _counts(self, p):
        """Kernel: how many of the positions `p` (N, >= 2) lie in each sector's grown
        rectangle, shape (n_sectors,), in one pass (no per-sector masks): each position's
        columns ``c0 .. c1 - 1`` and rows ``r0 .. r1 - 1`` mark the corners of a 2-D
        difference array, summed along both axes."""
        lo_e, hi_e, lo_n, hi_n = self._grown_edges()
        ne, nn = lo_e.size, lo_n.size
        c0 = np.searchsorted(hi_e, p[:, 0], side="left")      # first column reaching it
        c1 = np.searchsorted(lo_e, p[:, 0], side="right")     # one past the last
        r0 = np.searchsorted(hi_n, p[:, 1], side="left")
        r1 = np.searchsorted(lo_n, p[:, 1], side="right")
        ok = (c0 < c1) & (r0 < r1)
        c0, c1, r0, r1 = c0[ok], c1[ok], r0[ok], r1[ok]
        w = ne + 1
        diff = (np.bincount(r0 * w + c0, minlength=(nn + 1) * w)
                - np.bincount(r0 * w + c1, minlength=(nn + 1) * w)
                - np.bincount(r1 * w + c0, minlength=(nn + 1) * w)
                + np.bincount(r1 * w + c1, minlength=(nn + 1) * w))
        full = diff.reshape(nn + 1, w).cumsum(axis=0).cumsum(axis=1)
        return full[:nn, :ne].ravel().astype(np.int64)


def sector_grid(position, n_east, n_north, *, overlap, spacing="equal") -> Sectors:
    """A grid of sectors spanning the reports' east and north extent.

    Parameters
    ----------
    position : array_like, shape (N, 3) or (N, 2)
        The reports in the common frame (east, north, up), finite.
    n_east, n_north : int
        Columns and rows of the grid (>= 1).
    overlap : float
        Width by which each sector's tracker sees beyond its borders (>= 0, the
        positions' unit; see :class:`Sectors`).
    spacing : {"equal", "reports"}, optional
        ``"equal"`` (default): edges evenly spaced from the smallest to the largest east
        (north) of `position`. ``"reports"``: edges at the quantiles of the reports' east
        (north), so that each column (row) of the grid holds about the same number of
        reports: sectors of balanced work where the traffic is uneven, as a continent's is.

    Returns
    -------
    Sectors

    Raises
    ------
    ValueError
        Counts below 1, no reports, reports of zero extent in east or north (the sectors
        would have none), a bad `overlap`, more than :data:`MAX_SECTORS` sectors, a
        `spacing` not listed, or ``"reports"`` quantiles that coincide (too many reports at
        one east or north for that many columns or rows).
    TypeError
        Non-numeric `position` or `overlap`, non-integer counts.

    Examples
    --------
    >>> g = sector_grid([[0.0, 0.0, 9e3], [120e3, 60e3, 9e3]], 3, 1, overlap=5e3)
    >>> g.east.tolist(), g.north.tolist(), g.overlap
    ([0.0, 40000.0, 80000.0, 120000.0], [0.0, 60000.0], 5000.0)
    >>> sector_grid([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [90.0, 3.0]], 2, 1, overlap=0.0,
    ...             spacing="reports").east.tolist()
    [0.0, 1.5, 90.0]
    """
    p = as_float_array(position, "position", ndim_min=2)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise ValueError(f"`position` must have shape (N, 3) or (N, 2); received shape {p.shape}")
    n_east = as_int(n_east, "n_east", minimum=1)
    n_north = as_int(n_north, "n_north", minimum=1)
    if n_east * n_north > MAX_SECTORS:
        raise ValueError(f"`n_east`, `n_north`: {n_east} x {n_north} sectors exceed "
                         f"MAX_SECTORS = {MAX_SECTORS}; use fewer, larger sectors")
    w = _overlap_iv(overlap)
    if not p.shape[0]:
        raise ValueError("`position` must hold at least one report (the grid spans their "
                         "extent); received none")
    lo, hi = p[:, :2].min(axis=0), p[:, :2].max(axis=0)
    for axis, name in ((0, "east"), (1, "north")):
        if not hi[axis] > lo[axis]:
            raise ValueError(f"`position`: the reports' {name} extent is zero (all at "
                             f"{lo[axis]:.6g}), so the sectors would have none; give the "
                             "edges to Sectors(...) instead")
    if spacing not in ("equal", "reports"):
        raise ValueError(f"`spacing` must be 'equal' or 'reports'; received {describe(spacing)}")
    edges = []
    for axis, n, name in ((0, n_east, "n_east"), (1, n_north, "n_north")):
        if spacing == "equal":
            e = np.linspace(lo[axis], hi[axis], n + 1)
        else:
            e = np.quantile(p[:, axis], np.linspace(0.0, 1.0, n + 1))
            e[0], e[-1] = lo[axis], hi[axis]
            if not np.all(np.diff(e) > 0):
                raise ValueError(f"`{name}`: with spacing='reports' the {n} columns or rows "
                                 "would have coinciding edges (many reports at one "
                                 "coordinate); use fewer, or spacing='equal'")
        edges.append(e)
    return Sectors(edges[0], edges[1], w)


@dataclass(frozen=True, repr=False, eq=False)
class SectoredTracks:
    r"""The result of :func:`track_sectored`: the merged history and per-sector diagnostics.

    Attributes
    ----------
    history : TrackHistory
        One history over the whole airspace (ids unique across sectors; see
        :func:`track_sectored` for the rule). `initiated` is the sum over the sectors.
    sectors : Sectors
        The grid.
    reports : numpy.ndarray of int, shape (S,)
        Reports each sector's tracker received (its grown rectangle's).
    tracks : numpy.ndarray of int, shape (S,)
        Tracks each sector's tracker confirmed (its own identities, before the hand-over).
    handovers : numpy.ndarray of int, shape (S,)
        Links (hand-overs) in which each sector's tracks take part.
    links : numpy.ndarray of int, shape (L, 4)
        The accepted links, ``(sector_a, track_a, sector_b, track_b)`` with the sectors'
        own track ids, ``sector_a < sector_b``, in the order of the pairs of sectors.
    link_cost : numpy.ndarray, shape (L,)
        Each link's mean squared distance :math:`\bar\kappa_{ab}`.
    """

    history: TrackHistory
    sectors: Sectors
    reports: np.ndarray
    tracks: np.ndarray
    handovers: np.ndarray
    links: np.ndarray
    link_cost: np.ndarray

    def __repr__(self) -> str:
        return (f"SectoredTracks({self.sectors.n_sectors} sectors, {int(self.reports.sum())} "
                f"report copies, {int(self.tracks.sum())} sector tracks, "
                f"{self.links.shape[0]} hand-overs; {self.history!r})")


def _reports_iv(time, position, cov, radar, scan):
    t = as_float_array(time, "time", ndim_min=1)
    if t.ndim != 1:
        raise ValueError(f"`time` must have shape (N,); received shape {t.shape}")
    n = t.size
    check_size(n, MAX_REPORTS, what="reports", name="time",
               alternative="consecutive slices of the window")
    z = as_float_array(position, "position", ndim_min=2, last_dims=(3,))
    if z.shape != (n, 3):
        raise ValueError(f"`position` must have shape ({n}, 3); received shape {z.shape}")
    R = as_covariance(cov, "cov", dim=3) if n else np.zeros((0, 3, 3))
    if R.shape != (n, 3, 3):
        raise ValueError(f"`cov` must have shape ({n}, 3, 3); received shape {R.shape}")
    out = []
    for name, v in (("radar", radar), ("scan", scan)):
        a = np.asarray(v) if not isinstance(v, (str, bytes)) and v is not None else None
        if a is None or a.dtype.kind not in "iu" or a.shape != (n,):
            raise TypeError(f"`{name}` must be an integer array of shape ({n},); received "
                            f"{describe(v)}")
        if n and a.min() < 0:
            raise ValueError(f"`{name}` must be >= 0; received smallest entry {a.min()}")
        out.append(a.astype(np.int64))
    return t, z, R, out[0], out[1]


def _coverage_iv(sectors, z):
    """Refuse reports outside every sector, and per-sector copies beyond the memory limit;
    the reports in each sector's grown rectangle, counted."""
    e, n = z[:, 0], z[:, 1]
    out = ((e < sectors.east[0]) | (e > sectors.east[-1]) | (n < sectors.north[0])
           | (n > sectors.north[-1]))
    if out.any():
        k = int(np.flatnonzero(out)[0])
        raise ValueError(f"`position`: {int(out.sum())} reports lie outside every sector (a gap "
                         f"in coverage: the grid spans east [{sectors.east[0]:.6g}, "
                         f"{sectors.east[-1]:.6g}], north [{sectors.north[0]:.6g}, "
                         f"{sectors.north[-1]:.6g}]); e.g. report {k} at east {e[k]:.6g}, north "
                         f"{n[k]:.6g}; widen the grid (sector_grid(position, ...) spans the "
                         "reports)")
    counts = sectors._counts(z)
    copies = int(counts.sum())
    check_size(copies * REPORT_BYTES, MEMORY_LIMIT, name="sectors",
               what=f"bytes of per-sector copies of the reports ({copies} copies in "
                    f"{sectors.n_sectors} sectors, overlap {sectors.overlap:.6g})",
               alternative="a smaller `overlap`, fewer sectors, or consecutive time slices")
    return counts


def _client_iv(client):
    """A running ``distributed.Client`` with at least one worker, and its worker count."""
    return as_client(client, feature="track_sectored(client=...)")[1]


def _describe_sector(sectors, k, n_reports):
    e0, e1, n0, n1 = sectors.bounds(k)
    return (f"sector {k} (east [{e0:.6g}, {e1:.6g}], north [{n0:.6g}, {n1:.6g}], overlap "
            f"{sectors.overlap:.6g}; {n_reports} reports)")


def _failed(sectors, k, n_reports, exc):
    return SectorError(f"the tracker of {_describe_sector(sectors, k, n_reports)} failed: "
                       f"{type(exc).__name__}: {exc}")


def sector_settings(settings=None) -> TrackerSettings:
    """The settings each sector's tracker of :func:`track_sectored` runs with: `settings`
    without relinking.

    At a sector's edge every aircraft that leaves the sector is a track its tracker has
    lost, and relinking would continue such a track with the next aircraft that enters
    nearby, in dense traffic often another one. Across the borders the hand-over joins the
    identities instead, with `settings.p_relink` as its gate.

    Parameters
    ----------
    settings : TrackerSettings, optional
        The tracker's settings (defaults if None).

    Returns
    -------
    TrackerSettings
        `settings` with ``relink=False`` (`settings` itself if it does not relink).

    Raises
    ------
    TypeError
        `settings` not a :class:`~radarfusion_ref.tracking.TrackerSettings`.

    Examples
    --------
    >>> sector_settings().relink, TrackerSettings().relink
    (False, True)
    """
    settings = TrackerSettings() if settings is None else settings
    if not isinstance(settings, TrackerSettings):
        raise TypeError(f"`settings` must be a TrackerSettings; received {describe(settings)}")
    return dataclasses.replace(settings, relink=False) if settings.relink else settings


def track_sectored(time, position, cov, radar, scan, *, sectors, settings=None,
                   client=None) -> SectoredTracks:
    r"""Track by sectors, one tracker each, and hand tracks over across borders.

    Parameters
    ----------
    time, position, cov, radar, scan : array_like
        The reports, as :func:`~radarfusion_ref.tracking.track_reports` takes them (N
        instants, (N, 3) positions in the common east-north-up frame, (N, 3, 3)
        covariances, radar and scan numbers).
    sectors : Sectors
        The grid (:func:`sector_grid`), in the positions' unit. Every report must lie
        inside it.
    settings : TrackerSettings, optional
        The tracker's settings (defaults if None): every sector's tracker runs with them
        but without relinking (:func:`sector_settings`), and their relinking gate
        `p_relink` is the hand-over's gate.
    client : distributed.Client, optional
        None (default): the sectors one after the other in this process. A running
        ``distributed.Client``: the reports scattered once to every worker, one task
        per sector (the largest first) that selects its sector's reports there, tracks
        them and sends back only the sector's owned rows and what the hand-over needs
        (its tracks' spans and the confirmed rows of its tracks that reach a band
        along a border); the same hand-over then runs here. The answer is the same bit
        for bit. A worker lost mid-run changes nothing: the scheduler reruns its task on
        another worker, and if every copy of the reports was lost they are scattered and
        the task submitted again (up to :data:`MAX_LOST` times).

    Returns
    -------
    SectoredTracks
        The merged history and the per-sector diagnostics.

    Warns
    -----
    RadarFusionWarning
        A sector's tracker's warnings, re-issued here (also from a cluster) with the
        sector named, in sector order.

    Raises
    ------
    SectorError
        A sector's tracker failed: the sector's index, bounds and report count and the
        tracker's error (the lowest such sector when several fail; nothing is returned).
    ValueError
        Bad reports (as :func:`~radarfusion_ref.tracking.track_reports`), reports outside
        every sector (the count and an example), per-sector copies of the reports whose
        memory (:data:`REPORT_BYTES` each) would exceed
        :data:`~radarfusion_ref.engine.validation.MEMORY_LIMIT`, a `client` closed or
        without workers; all before any tracking.
    TypeError
        `sectors` not a :class:`Sectors`, `settings` not a
        :class:`~radarfusion_ref.tracking.TrackerSettings`, `client` not a
        ``distributed.Client``, non-numeric or non-integer inputs.
    ImportError
        `client` given and dask.distributed not installed (naming the extra).

    Notes
    -----
    **Sectors.** Sector :math:`k`'s tracker receives the reports inside its rectangle
    grown by the overlap :math:`w` (:class:`Sectors`). A sector without reports yields no
    tracks. A radar scan with no report in a sector is not seen by that sector's tracker.

    **Ownership.** Sector :math:`k` contributes the rows of its tracks whose position
    (east, north) it owns (:meth:`Sectors.owner`), not those in the overlap: there the
    neighbour's tracker, which sees the reports on both sides, speaks.

    **Hand-over.** For each two sectors :math:`s < t` whose grown rectangles meet, and
    each track :math:`a` of :math:`s` and :math:`b` of :math:`t` with confirmed rows at
    common instants inside both grown rectangles (the band along their border, where both
    trackers see the same reports), :math:`\mathcal T_{ab}` the pairs of such rows at one
    instant,

    .. math::

        \bar\kappa_{ab} = \frac{1}{|\mathcal T_{ab}|}\sum_{\tau\in\mathcal T_{ab}}
        (\hat{\mathbf p}_a(\tau) - \hat{\mathbf p}_b(\tau))^\mathsf T
        \left(P_a(\tau) + P_b(\tau)\right)^{-1}
        (\hat{\mathbf p}_a(\tau) - \hat{\mathbf p}_b(\tau)),

    over the position :math:`\hat{\mathbf p}` (east, north, up) and its covariance. A
    pair is allowed when :math:`\bar\kappa_{ab} < \gamma`, the :math:`\chi^2_3` gate of
    `settings.p_relink` (:func:`radarfusion_ref.gating.gate_threshold`; the sum
    :math:`P_a + P_b` ignores the two estimates' correlation through common reports, so
    the gate is conservative), and if at every common instant of their confirmed rows,
    in the band or not, the squared distance is below :math:`\gamma` too (a track that
    one sector's tracker carried on to another aircraft once the first left its sight is
    not joined: that aircraft changes identity at the border rather than two aircraft
    sharing one); the pairs of the two sectors are then made one-to-one by
    the assignment of least total :math:`\bar\kappa`
    (:func:`radarfusion_ref.engine.assignment.assign_two_lists`). The links of all
    pairs of sectors are then joined in order of increasing :math:`\bar\kappa` (ties by
    sector and track index); a link that would give one identity to two tracks of one
    sector whose spans of time meet is refused. Track :math:`a` of sector :math:`s` has
    provisional id :math:`o_s + a`, with :math:`o_s` the tracks initiated by the sectors
    before :math:`s`; each joined group takes its smallest provisional id, so an
    aircraft that crosses a border keeps its track's id. When rows of one identity come
    from two sectors at one instant (the aircraft on the border, each tracker placing it
    on its own side), the rows of the lower sector are kept. Every step is a function of
    the inputs alone (sorted, never in the order of a dict, a set or a finishing task).

    Examples
    --------
    >>> t = np.repeat(np.arange(20) * 5.0, 1)
    >>> z = np.c_[-20e3 + 2e3 * t / 5, np.zeros(20), np.full(20, 9e3)]
    >>> g = Sectors([-30e3, 0.0, 30e3], [-10e3, 10e3], overlap=8e3)
    >>> r = track_sectored(t, z, np.tile(np.eye(3) * 1e4, (20, 1, 1)), np.zeros(20, int),
    ...                    np.arange(20), sectors=g)
    >>> r.tracks.tolist(), r.handovers.tolist(), np.unique(r.history.track).size
    ([1, 1], [1, 1], 1)
    """
    if not isinstance(sectors, Sectors):
        raise TypeError(f"`sectors` must be a Sectors (see sector_grid); received "
                        f"{describe(sectors)}")
    settings = TrackerSettings() if settings is None else settings
    inner = sector_settings(settings)            # refuses anything but a TrackerSettings
    t, z, R, rad, sc = _reports_iv(time, position, cov, radar, scan)
    counts = _coverage_iv(sectors, z)
    if client is not None:
        _client_iv(client)
    reports = (t, z, R, rad, sc)
    gamma = float(gating.gate_threshold(settings.p_relink, 3))
    links = Links(sectors, gamma)            # the hand-over's candidates, as sectors finish
    if client is None:
        runs = []
        for k in range(sectors.n_sectors):
            try:
                runs.append(run_sector(reports, sectors, k, inner))
            except Exception as exc:
                raise _failed(sectors, k, counts[k], exc) from exc
            links.add(k, runs[k][0].edge)
    else:
        runs, failed = on_cluster(client, reports, sectors, inner, counts, MAX_LOST,
                                  lambda k, run: links.add(k, run[0].edge))
        if failed:
            k = min(failed)                              # the lowest failing sector
            raise _failed(sectors, k, counts[k], failed[k]) from failed[k]
    for k, (_, _, caught) in enumerate(runs):
        for category, message in caught:
            warnings.warn(f"{_describe_sector(sectors, k, counts[k])}: {message}", category,
                          stacklevel=2)
    summaries = [m for m, _, _ in runs]
    history, links, handovers = merge(sectors, summaries, [p for _, p, _ in runs], gamma,
                                      links.result())
    return SectoredTracks(history, sectors, counts,
                          np.array([m.n_confirmed for m in summaries], np.int64), handovers,
                          np.stack(links[:4], axis=1).astype(np.int64), links[4])
