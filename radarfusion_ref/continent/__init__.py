r"""A continent in real time: a generated continental scenario and a fusion centre split by
sectors.

* :mod:`radarfusion_ref.continent.scenario` — flights between real airports over Europe and a
  network of radars, seeded and offline, scalable by one parameter from the Swiss hour's
  number of aircraft to thousands;
* :mod:`radarfusion_ref.continent.sectors` — the airspace split into sectors with an
  overlap, one tracker per sector, hand-over of tracks that cross a border, run in one
  process or on a Dask cluster with the same answer.
"""

from ._settings import CONTINENT_DESIGN, CONTINENT_SETTINGS
from .scenario import (
    AIRPORTS_FILE,
    ORIGIN,
    RADAR_DRAWS,
    SWISS_AIRBORNE,
    Airports,
    ContinentBiases,
    ContinentReports,
    ContinentScenario,
    Flights,
    airborne_count,
    continent_scenario,
    expected_reports,
    from_map,
    load_airports,
    map_scale,
    polar_to_map,
    register_continent,
    simulate_continent,
    to_map,
    truth_at,
    truth_samples,
)
from .sectors import (
    MAX_LOST,
    MAX_SECTORS,
    REPORT_BYTES,
    SectoredTracks,
    SectorError,
    Sectors,
    sector_grid,
    sector_settings,
    track_sectored,
)

__all__ = [
    # scenario
    "AIRPORTS_FILE",
    "ORIGIN",
    "RADAR_DRAWS",
    "SWISS_AIRBORNE",
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
    # settings
    "CONTINENT_DESIGN",
    "CONTINENT_SETTINGS",
    # sectors
    "MAX_LOST",
    "MAX_SECTORS",
    "REPORT_BYTES",
    "SectoredTracks",
    "SectorError",
    "Sectors",
    "sector_grid",
    "sector_settings",
    "track_sectored",
]
