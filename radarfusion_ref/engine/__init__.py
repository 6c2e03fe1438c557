r"""The engine: the general machinery every chapter is built from.

It imports nothing from the chapter modules or the book kit (an import-linter
contract in ``pyproject.toml`` holds it to that).

* :mod:`~radarfusion_ref.engine.validation` — the checks at the door of every public
  function, public so that chapter modules and users call them by name (one message per
  rule, one seed conversion, the one covariance rule, the numeric domain);
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

.. rubric:: The numeric domain

One domain holds for every public function; input outside it is refused by name at
the door (never rescaled, clamped or passed on as NaN or inf), and inside it the
results are finite and correct to rounding:

* **lengths** (coordinates, positions, ranges and their differences):
  :math:`|x| \le` :data:`~radarfusion_ref.engine.validation.MAX_MAGNITUDE`
  (:math:`2^{150} \approx 1.4\times 10^{45}`), in any unit — answers do not depend on
  the unit (property tests scale every length by :math:`10^{-3} \ldots 10^{3}`);
* **variances** (diagonal entries of every covariance): in
  :math:`[2^{-150}, 2^{150}]`, and every covariance passes the one
  positive-definiteness rule (correlation pivots above
  :data:`~radarfusion_ref.engine.validation.SINGULAR_RTOL`) — both checked by the one
  covariance rule, :func:`~radarfusion_ref.engine.validation.as_covariance`; the functions
  whose kernels rescale exactly (the Gaussian fusion, the grouping costs, the
  non-assignment cost) take any variance a float holds, and say so;
* **costs** (assignment costs, :math:`\kappa`, log-likelihoods): finite, with the total
  of a chosen assignment representable in float64 (:math:`|\sum| < 1.8\times10^{308}`);
* **GOSPA**: cut-off :math:`c > 0` and order :math:`p \ge 1`, with :math:`c^p` a normal
  float64 whenever the parts are asked for (``parts=True``); the total alone accepts any
  positive :math:`c`;
* **probabilities** (false-rejection, detection, design error rates): in the open
  interval :math:`(0, 1)`;
* **rates, periods and counts** (clutter rates, scan periods, time steps, trials):
  positive and finite; any size whose work would exceed
  :data:`~radarfusion_ref.engine.validation.MEMORY_LIMIT` bytes (1 GiB) at once is
  refused before anything is allocated, naming the limit and a scalable route.
"""
