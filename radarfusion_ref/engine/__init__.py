"""The engine: the general machinery every chapter is built from.

It imports nothing from the chapter modules or the book kit (an import-linter
contract in ``pyproject.toml`` holds it to that).

* :mod:`~radarfusion_ref.engine._validation` — the checks at the door of every public
  function (one message per rule, one seed conversion, one positive-definiteness rule);
* :mod:`~radarfusion_ref.engine.linalg` — the one squared-Mahalanobis home (pointwise,
  batched and pairwise) and Cholesky factors;
* :mod:`~radarfusion_ref.engine.assignment` — 2-D assignment (dense, sparse, brute force,
  Murty's k best) and S-D assignment (MILP, Lagrangian, brute force), with one result
  protocol;
* :mod:`~radarfusion_ref.engine.montecarlo` — proportions and means with intervals, and
  the seeded parameter sweep (one process or a Dask cluster);
* :mod:`~radarfusion_ref.engine.metrics` — GOSPA, NEES and purity;
* :mod:`~radarfusion_ref.engine.scenes` and :mod:`~radarfusion_ref.engine.geometry` — every
  simulated scene, trial axis first;
* :mod:`~radarfusion_ref.engine.geodesy` — WGS-84 to a local east-north-up frame;
* :mod:`~radarfusion_ref.engine.errors` — the package's warning class.
"""
