"""Optional dependencies: imported when a feature needs them, refused naming the extra.

The core install (``pip install radarfusion-ref``) brings numpy and scipy, all the
engine and the chapter modules import. What only some features use is an extra of
``pyproject.toml``; :func:`require` imports it or raises an :class:`ImportError`
that says which extra installs it, and :func:`available` lets an automatic default
(the progress bar of :func:`~radarfusion_ref.engine.montecarlo.sweep`) turn itself
off instead of failing.
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

#: The extra of ``pyproject.toml`` that installs each optional top-level package.
EXTRAS = {
    "tqdm": "progress",
    "dask": "dask",
    "distributed": "dask",
    "stonesoup": "stonesoup",
    "ipywidgets": "widgets",
    "IPython": "book",                  # with Jupyter (ipykernel); ipywidgets brings it too
    "sympy": "book",
    "matplotlib": "book",
}


def require(module: str, *, feature: str) -> ModuleType:
    """Import `module` (a dotted name), or raise naming the extra that installs it.

    `feature` says what needs it (``"sweep(progress=True)"``); the message reads
    ``"<feature> needs <package>: pip install 'radarfusion-ref[<extra>]'"``.
    """
    top = module.partition(".")[0]
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        if exc.name is not None and exc.name.partition(".")[0] != top:
            raise                    # the package is there, but something it imports is broken
        raise _missing(top, feature) from exc


def require_installed(*modules: str, feature: str) -> None:
    """Raise as :func:`require` does if a top-level package is not installed (imports nothing)."""
    for top in modules:
        if importlib.util.find_spec(top) is None:
            raise _missing(top, feature)


def _missing(top: str, feature: str) -> ImportError:
    return ImportError(f"{feature} needs {top}, which is not installed: "
                       f"pip install 'radarfusion-ref[{EXTRAS[top]}]'", name=top)


def available(module: str) -> bool:
    """True if `module` imports (an optional feature's automatic default asks this)."""
    try:
        importlib.import_module(module)
    except ImportError:
        return False
    return True
