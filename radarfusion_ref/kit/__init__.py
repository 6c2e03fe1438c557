"""The book kit: what the pages need beyond the mathematics.

It may import the engine, and nothing below it imports the kit.

* :mod:`~radarfusion_ref.kit.checks` — the executed checks (``check_close``, ``require``
  for a Monte-Carlo estimate against its exact value) and their ledger;
* :mod:`~radarfusion_ref.kit.symbolic` — sympy derivations checked against the package;
* :mod:`~radarfusion_ref.kit.interactive` — live sliders and static sweeps;
* :mod:`~radarfusion_ref.kit.plotting` — the book's look;
* :mod:`~radarfusion_ref.kit.catalog` — the chapter map.
"""

from ..engine.optional import require_installed

# the kit draws with matplotlib and derives with sympy: the `book` extra
require_installed("matplotlib", "sympy", feature="the book kit (radarfusion_ref.kit)")
