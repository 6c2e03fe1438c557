"""radarfusion_ref — the reference package behind the radarfusion book.

One module per topic, sharing its stem with a chapter and a test file
(``book/NN_<stem>.md`` ↔ ``radarfusion_ref/<stem>.py`` ↔ ``tests/test_<stem>.py``).
Shared infrastructure:

* :mod:`radarfusion_ref.engine.montecarlo` — proportions and means with confidence intervals;
* :mod:`radarfusion_ref.kit.plotting` — the book's look; helpers draw into a given ``ax``;
* :mod:`radarfusion_ref.kit.interactive` — live sliders and static sweeps for chapters;
* :mod:`radarfusion_ref.engine.scenes` — simulated two-radar scenes;
* :mod:`radarfusion_ref.engine.errors` — :class:`~radarfusion_ref.engine.errors.RadarFusionWarning`;
* :mod:`radarfusion_ref.kit.catalog` — the chapter map.

Randomness follows SPEC 7: every stochastic function takes keyword ``rng``
(``None``, a seed or a :class:`numpy.random.Generator`); nothing touches
numpy's global random state.
"""

from .engine.errors import RadarFusionWarning

__version__ = "0.1.0"
__all__ = ["RadarFusionWarning", "__version__"]
