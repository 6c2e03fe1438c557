"""Regenerate ``switzerland_busiest_hour.csv.gz`` (beside this script) from the ``traffic`` wheel.

Usage::

    python radarfusion_ref/capstone/data/make_traffic_subset.py [WHEEL]

``WHEEL`` is the path of ``traffic-2.13-py3-none-any.whl``; without it the script
runs ``pip download traffic==2.13 --no-deps`` into a temporary directory. Only the
standard library reads the data (the ``traffic`` package is never imported).

The source file is ``traffic/data/samples/collections/switzerland.json.gz``: a JSON
list of ADS-B records (timestamp in ms, latitude, longitude, altitude in ft,
callsign, icao24, ground speed in kt, track in degrees, vertical rate).

The window is chosen by a rule: the whole UTC clock hour holding the most distinct
aircraft (``icao24``), ties going to the earliest; the second busiest hour by the same
rule is written beside it (``switzerland_tuning_hour.csv.gz``) for tuning trackers
without touching the scored hour. The output is a gzip CSV
(deterministic: gzip mtime 0) with integer columns

    t_s, icao24, callsign, lat_e5, lon_e5, alt_ft, gs_kt, track_deg

(seconds from the window start; latitude and longitude in 1e-5 degrees; altitude
in feet; ground speed in knots; track in degrees clockwise from north), sorted by
icao24 then time. The script prints the window, the counts, the size and the SHA-256.
"""

from __future__ import annotations

import collections
import datetime as dt
import gzip
import hashlib
import io
import json
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

MEMBER = "traffic/data/samples/collections/switzerland.json.gz"
VERSION = "2.13"
OUT = Path(__file__).resolve().parent / "switzerland_busiest_hour.csv.gz"
#: The second busiest hour of the same day, extracted the same way: the hour on which
#: trackers are tuned (the busiest one is scored).
OUT_TUNING = Path(__file__).resolve().parent / "switzerland_tuning_hour.csv.gz"
HEADER = "t_s,icao24,callsign,lat_e5,lon_e5,alt_ft,gs_kt,track_deg"


def _wheel(argv: list[str]) -> Path:
    if argv:
        return Path(argv[0])
    tmp = Path(tempfile.mkdtemp())
    subprocess.run([sys.executable, "-m", "pip", "download", f"traffic=={VERSION}", "--no-deps",
                    "-d", str(tmp)], check=True)
    return next(tmp.glob("traffic-*.whl"))


def main(argv: list[str]) -> None:
    with zipfile.ZipFile(_wheel(argv)) as zf:
        records = json.loads(gzip.decompress(zf.read(MEMBER)))
    hours = collections.defaultdict(set)
    for r in records:
        hours[r["timestamp"] // 3_600_000].add(r["icao24"])
    ranked = sorted(sorted(hours), key=lambda h: -len(hours[h]))  # stable: earliest tie first
    for hour, out in zip(ranked[:2], (OUT, OUT_TUNING), strict=True):
        _write_hour(records, hour, out)
        start = dt.datetime.fromtimestamp(hour * 3600, dt.timezone.utc)
        print(f"window: {start:%Y-%m-%d %H:%M} to {start + dt.timedelta(hours=1):%H:%M} UTC "
              f"({len(hours[hour])} aircraft)")
        print(f"wrote {out.name}: {out.stat().st_size} bytes, "
              f"SHA-256 {hashlib.sha256(out.read_bytes()).hexdigest()}")


def _write_hour(records, hour: int, out: Path) -> None:
    """Write the records of one UTC clock hour to `out` (the format of the module doc)."""
    start_ms = hour * 3_600_000
    rows = []
    for r in records:
        t_ms = r["timestamp"] - start_ms
        if 0 <= t_ms < 3_600_000:
            rows.append((t_ms // 1000, r["icao24"], (r["callsign"] or "").strip(),
                         round(r["latitude"] * 1e5), round(r["longitude"] * 1e5),
                         round(r["altitude"]), round(r["groundspeed"]),
                         round(r["track"]) % 360))
    rows.sort(key=lambda row: (row[1], row[0]))
    text = io.StringIO()
    text.write(HEADER + "\n")
    for row in rows:
        text.write(",".join(str(v) for v in row) + "\n")
    buf = io.BytesIO()
    with gzip.GzipFile(filename="", mode="wb", fileobj=buf, mtime=0, compresslevel=9) as gz:
        gz.write(text.getvalue().encode("ascii"))
    out.write_bytes(buf.getvalue())

if __name__ == "__main__":
    main(sys.argv[1:])
