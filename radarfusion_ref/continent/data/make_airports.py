"""Make ``airports.csv``: the European airports with an IATA code, from ``airportsdata``.

Run by hand (``pip install airportsdata``, then ``python make_airports.py`` in this folder);
the package does not depend on ``airportsdata``, it ships the CSV this script writes.
``airportsdata`` is MIT licensed (``airports_LICENSE.txt``, copied from its wheel).

Kept: airports with an IATA code and a four-letter ICAO code of the European regions
(first letter E or L), whose reference point lies in the box latitude 36..62 deg,
longitude -10..30 deg, heliports left out. Elevation is converted from feet to metres.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

BOX = {"lat": (36.0, 62.0), "lon": (-10.0, 30.0)}
FOOT = 0.3048


def main(out: Path) -> int:
    import airportsdata

    rows = []
    for a in airportsdata.load("IATA").values():
        icao, iata = a["icao"], a["iata"]
        if not (len(icao) == 4 and icao.isalpha() and icao[0] in "EL" and len(iata) == 3):
            continue
        if "heliport" in a["name"].lower():
            continue
        lat, lon = float(a["lat"]), float(a["lon"])
        if not (BOX["lat"][0] <= lat <= BOX["lat"][1] and BOX["lon"][0] <= lon <= BOX["lon"][1]):
            continue
        rows.append((icao, iata, a["name"], f"{lat:.5f}", f"{lon:.5f}",
                     f"{float(a['elevation']) * FOOT:.0f}"))
    rows.sort()
    version = getattr(airportsdata, "__version__", "unknown")
    with out.open("w", newline="", encoding="utf-8") as f:
        f.write(f"# European airports with an IATA code (lat 36..62, lon -10..30, ICAO E*/L*), "
                f"from the PyPI package airportsdata {version} (MIT, airports_LICENSE.txt); "
                "made by make_airports.py; elevation_m above mean sea level\n")
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["icao", "iata", "name", "lat", "lon", "elevation_m"])
        w.writerows(rows)
    print(f"{len(rows)} airports -> {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(Path(__file__).with_name("airports.csv")))
