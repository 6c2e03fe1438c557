r"""A continent in real time: a generated continental scenario and a fusion centre split by
sectors.

* :mod:`radarfusion_ref.continent.scenario` — flights between real airports over Europe and a
  network of radars, seeded and offline, scalable by one parameter from the Swiss hour's
  number of aircraft to thousands;
* :mod:`radarfusion_ref.continent.sectors` — the airspace split into sectors with an
  overlap, one tracker per sector, hand-over of tracks that cross a border, run in one
  process or on a Dask cluster with the same answer.
"""

from .sectors import (
    MAX_LOST,
    MAX_SECTORS,
    REPORT_BYTES,
    SectoredTracks,
    SectorError,
    Sectors,
    sector_grid,
    track_sectored,
)

__all__ = [
    "MAX_LOST",
    "MAX_SECTORS",
    "REPORT_BYTES",
    "SectoredTracks",
    "SectorError",
    "Sectors",
    "sector_grid",
    "track_sectored",
]
