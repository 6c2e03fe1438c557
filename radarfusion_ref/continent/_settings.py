"""The tracker's settings for the continental scene: its design values and its tuned choice.

:data:`CONTINENT_DESIGN` states what the tracker is told of the continental radars (their
clutter density and detection probability, from the scene's draws,
:data:`~radarfusion_ref.continent.scenario.RADAR_DRAWS`), as
:class:`~radarfusion_ref.tracking.TrackerSettings` asks for another scene than the
capstone's; :data:`CONTINENT_SETTINGS` adds the knobs tuned on a continental tuning hour by
``benchmarks/tune_continent.py`` (the protocol of ``benchmarks/tune_tracking.py``; its runs
are in ``benchmarks/data/continent_tuning.csv``).
"""

from __future__ import annotations

import math

from ..tracking import TrackerSettings
from ._reports import CLUTTER_UP
from ._scene import RADAR_DRAWS


def _clutter_density():
    r"""Mean false reports per m³ per scan of the drawn radars: :math:`E[\lambda]\,E[1/R^2]
    / (\pi\,\Delta h)` with :math:`\lambda` uniform, :math:`R` uniform on :math:`[a, b]`
    (:math:`E[1/R^2] = 1/(ab)`) and :math:`\Delta h` the clutter's height band."""
    lam = sum(RADAR_DRAWS["clutter_rate"]) / 2
    a, b = RADAR_DRAWS["max_range"]
    return lam / (a * b) / (math.pi * (CLUTTER_UP[1] - CLUTTER_UP[0]))


#: A chance run of missed detections this rare must not end a confirmed track: the
#: probability of its misses in a row at the weakest radar's detection probability.
CHANCE_MISSES = 1e-4


def _max_coast():
    r"""Seconds a confirmed track coasts without a report: half a revisit past :math:`k`
    missed scans of the slowest radar, :math:`k` the fewest misses in a row whose
    probability at the weakest radar's detection probability is at most
    :data:`CHANCE_MISSES`: :math:`(1 - P_{D,\min})^k \le` ``CHANCE_MISSES``. A
    continental aircraft is often seen by one radar alone, so such a run breaks its track
    unless the coast outlasts it."""
    k = math.ceil(math.log(CHANCE_MISSES) / math.log(1.0 - RADAR_DRAWS["p_detect"][0]))
    return (k + 0.5) * RADAR_DRAWS["period"][1]


#: What the tracker is told of the continental radars: the mean clutter density of their
#: draws (about 2.8e-15 per m³ per scan: 5-20 false reports per scan over a 250-400 km
#: disk, 1-15 km up), their mean detection probability (0.875), and how long a confirmed
#: track coasts (``_max_coast``); a tentative track keeps the tracker's default coast.
CONTINENT_DESIGN = {"clutter_density": _clutter_density(),
                    "p_detection": sum(RADAR_DRAWS["p_detect"]) / 2,
                    "max_coast": _max_coast(),
                    "max_coast_tentative": TrackerSettings().max_coast}

#: The tracker's settings for the continental scene: :data:`CONTINENT_DESIGN` and the
#: knobs chosen on the continental tuning hour (scale 100, seed 2025, never the scored seed
#: 2026; ``benchmarks/tune_continent.py``, the Swiss protocol): q 20 m²/s³, vertical q
#: 0.03 m²/s³, vertical-velocity prior 15 m/s, SPRT false confirmation 1e-3 and deletion
#: 1e-3, relinking at 1e-20, the gate at 1e-6. Every setting of the search was feasible
#: (the runs and their scores are in the table); the gates at 1e-6 and at distance 8 tied
#: on mean GOSPA, false tracks and latency, and the protocol's last tie rule took the
#: grid's first.
CONTINENT_SETTINGS = TrackerSettings(**CONTINENT_DESIGN, q=20.0, q_vertical=0.03,
                                     speed_max_vertical=15.0, p_false_confirm=1e-3,
                                     p_false_delete=1e-3, relink=True, p_relink=1e-20,
                                     p_false_reject=1e-6)
