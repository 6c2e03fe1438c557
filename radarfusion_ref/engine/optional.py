"""Optional dependencies: imported when a feature needs them, refused naming the extra.

Public, so that the book kit, chapter modules and users' own extensions ask for an
optional package the same way.

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

from .validation import describe

__all__ = ["EXTRAS", "available", "require", "require_installed"]

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
    "numba": "fast",                    # the compiled pairwise Mahalanobis route (automatic)
}


def require(module: str, *, feature: str) -> ModuleType:
    """Import `module` (a dotted name), or raise naming the extra that installs it.

    `feature` says what needs it (``"sweep(progress=True)"``); the message reads
    ``"<feature> needs <package>: pip install 'radarfusion-ref[<extra>]'"``.

    Raises
    ------
    ImportError
        Naming the extra, if `module`'s top-level package is not installed.
    ValueError
        If `module` is not the name of a package listed in :data:`EXTRAS`.
    TypeError
        If `module` or `feature` is not a string.

    Examples
    --------
    >>> require("numpy", feature="this example").__name__
    Traceback (most recent call last):
    ...
    ValueError: `module` must be an optional package of radarfusion-ref, one of 'tqdm', 'dask', 'distributed', 'stonesoup', 'ipywidgets', 'IPython', 'sympy', 'matplotlib', 'numba' (or a submodule); received 'numpy'
    """
    top = _module_iv(module, feature)
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        if exc.name is not None and exc.name.partition(".")[0] != top:
            raise                    # the package is there, but something it imports is broken
        raise _missing(top, feature) from exc


def require_installed(*modules: str, feature: str) -> None:
    """Raise as :func:`require` does if a top-level package is not installed (imports nothing)."""
    if not isinstance(feature, str):
        raise TypeError(f"`feature` must be a string; received {describe(feature)}")
    if not modules:
        raise TypeError("`modules` must name at least one package; received none")
    for top in modules:
        _module_iv(top, feature)
        if importlib.util.find_spec(top) is None:
            raise _missing(top, feature)


def _module_iv(module, feature) -> str:
    """The top-level package of `module`, one of :data:`EXTRAS`; `feature` a string."""
    if not isinstance(feature, str):
        raise TypeError(f"`feature` must be a string; received {describe(feature)}")
    if not isinstance(module, str):
        raise TypeError(f"`module` must be a dotted module name; received {describe(module)}")
    top = module.partition(".")[0]
    if top not in EXTRAS:
        allowed = ", ".join(repr(k) for k in EXTRAS)
        raise ValueError(f"`module` must be an optional package of radarfusion-ref, one of "
                         f"{allowed} (or a submodule); received {describe(module)}")
    return top


def _missing(top: str, feature: str) -> ImportError:
    return ImportError(f"{feature} needs {top}, which is not installed: "
                       f"pip install 'radarfusion-ref[{EXTRAS[top]}]'", name=top)


def available(module: str) -> bool:
    """True if `module` imports (an optional feature's automatic default asks this)."""
    _module_iv(module, "available")
    try:
        importlib.import_module(module)
    except ImportError:
        return False
    return True
