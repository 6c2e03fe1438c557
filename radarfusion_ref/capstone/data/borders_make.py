"""Regenerate ``borders.json`` (beside this script) from the npm package ``world-atlas``.

Usage::

    python radarfusion_ref/capstone/data/borders_make.py [TARBALL]

``TARBALL`` is ``world-atlas-2.0.2.tgz`` (``npm pack world-atlas@2.0.2`` fetches it);
without it the script runs that command in a temporary directory. Only the standard
library reads the data.

The source is ``package/countries-10m.json`` inside the tarball: Natural Earth's
Admin 0 country boundaries, 1:10m, version 4.1.0, as TopoJSON (quantized, delta-encoded
arcs in longitude/latitude degrees). The script decodes every arc that bounds
Switzerland or one of its neighbours (France, Germany, Italy, Austria, Liechtenstein),
each shared border once, cuts it to the box ``BOX`` around the capstone's map, rounds
the coordinates to 1e-4 degree (about 10 m) and writes a small JSON file::

    {"source": ..., "box": [lon_min, lat_min, lon_max, lat_max],
     "lines": [{"countries": ["Switzerland", "France"], "lonlat": [[lon, lat], ...]}, ...]}

``countries`` names the one or two countries an arc bounds. The output is
deterministic; the script prints the number of lines and points, the size and the
SHA-256.
"""

from __future__ import annotations

import hashlib
import io
import json
import subprocess
import sys
import tarfile
import tempfile
from pathlib import Path

PACKAGE = "world-atlas@2.0.2"
MEMBER = "package/countries-10m.json"
COUNTRIES = ("Switzerland", "France", "Germany", "Italy", "Austria", "Liechtenstein")
#: lon_min, lat_min, lon_max, lat_max (degrees): the capstone's map with a margin
BOX = (3.5, 44.5, 13.0, 49.2)
DIGITS = 4
OUT = Path(__file__).with_name("borders.json")


def _topology(tarball: Path) -> dict:
    with tarfile.open(tarball) as tar:
        member = tar.extractfile(MEMBER)
        if member is None:
            raise FileNotFoundError(f"{MEMBER} not in {tarball}")
        return json.load(io.TextIOWrapper(member, encoding="utf-8"))


def _decode(arc: list, scale: list, translate: list) -> list:
    """Delta-decoded, de-quantized points of one TopoJSON arc."""
    x = y = 0
    points = []
    for dx, dy in arc:
        x, y = x + dx, y + dy
        points.append((x * scale[0] + translate[0], y * scale[1] + translate[1]))
    return points


def _inside(point: tuple) -> bool:
    lon, lat = point
    return BOX[0] <= lon <= BOX[2] and BOX[1] <= lat <= BOX[3]


def _cut(points: list) -> list:
    """The runs of consecutive points inside BOX (each run of two points or more)."""
    runs, run = [], []
    for point in points:
        if _inside(point):
            run.append(point)
        else:
            if len(run) > 1:
                runs.append(run)
            run = []
    if len(run) > 1:
        runs.append(run)
    return runs


def _arcs_of(geometry: dict) -> set:
    polygons = geometry["arcs"] if geometry["type"] == "MultiPolygon" else [geometry["arcs"]]
    return {i if i >= 0 else ~i for polygon in polygons for ring in polygon for i in ring}


def extract(topology: dict) -> dict:
    """The border lines of COUNTRIES inside BOX, each shared arc once."""
    owners: dict[int, list] = {}
    for geometry in topology["objects"]["countries"]["geometries"]:
        name = geometry["properties"]["name"]
        if name in COUNTRIES:
            for i in _arcs_of(geometry):
                owners.setdefault(i, []).append(name)
    scale, translate = topology["transform"]["scale"], topology["transform"]["translate"]
    lines = []
    for i in sorted(owners):
        for run in _cut(_decode(topology["arcs"][i], scale, translate)):
            lonlat = [[round(lon, DIGITS), round(lat, DIGITS)] for lon, lat in run]
            lines.append({"countries": sorted(owners[i], key=COUNTRIES.index),
                          "lonlat": lonlat})
    return {"source": f"npm {PACKAGE}, {MEMBER} (Natural Earth 1:10m Admin 0, v4.1.0; "
                      "public domain)",
            "box": list(BOX), "lines": lines}


def main(argv: list) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        if argv:
            tarball = Path(argv[0])
        else:
            subprocess.run(["npm", "pack", PACKAGE], cwd=tmp, check=True)
            tarball = Path(tmp) / "world-atlas-2.0.2.tgz"
        data = extract(_topology(tarball))
    text = json.dumps(data, separators=(",", ":")) + "\n"
    OUT.write_text(text, encoding="utf-8")
    n_points = sum(len(line["lonlat"]) for line in data["lines"])
    print(f"{OUT.name}: {len(data['lines'])} lines, {n_points} points, "
          f"{len(text.encode())} bytes, SHA-256 {hashlib.sha256(text.encode()).hexdigest()}")


if __name__ == "__main__":
    main(sys.argv[1:])
