"""radarfusion_ref — the reference package behind the radarfusion book.

Three layers, imports pointing one way (``pyproject.toml`` holds the contract):

* the engine, :mod:`radarfusion_ref.engine` — validation, linear algebra (the one
  squared-Mahalanobis home), assignment, Monte Carlo, metrics, scenes and geodesy;
* the chapter modules — the papers' rules and experiments, one per chapter and sharing
  its stem with the chapter and its test file (``book/NN_<stem>.md`` ↔
  ``radarfusion_ref/<stem>`` ↔ ``tests/test_<stem>.py``), built only from the engine
  and from one another;
* the book kit, :mod:`radarfusion_ref.kit` — checks, symbolic derivations, interactive
  controls, plotting and the chapter catalog.

Randomness follows SPEC 7: every stochastic function takes keyword ``rng``
(``None``, a seed or a :class:`numpy.random.Generator`); nothing touches
numpy's global random state.
"""

from .engine.errors import RadarFusionWarning

__version__ = "0.1.0"
__all__ = ["RadarFusionWarning", "__version__"]
