"""Helpers for the chapters' symbolic derivations.

Every chapter derives its equations with sympy and then proves that the
derivation and the package agree. These helpers keep that pattern short and
make the executed book fail when a check fails:

* :func:`show` — display one step of a derivation, ``lhs = expr``;
* :func:`check_zero` — a symbolic identity that must simplify to zero;
* :func:`check_numeric_agreement` — a lambdified derivation against the package's numbers.
"""

from __future__ import annotations

import numpy as np

from ..engine._optional import require
from .checks import CheckError, _check_close, _record

__all__ = ["show", "check_zero", "check_numeric_agreement", "SymbolicCheckError"]


class SymbolicCheckError(CheckError):
    """A derivation and its claimed result (or the package) disagree."""


def show(lhs: str, expr) -> None:
    """Display ``lhs = expr`` as typeset mathematics (sympy's LaTeX printer).

    Parameters
    ----------
    lhs : str
        LaTeX of the left-hand side.
    expr : sympy expression, matrix or str
        The right-hand side (a string is used as LaTeX as it is).
    """
    import sympy as sp

    if not isinstance(lhs, str):
        raise TypeError(f"`lhs` must be a LaTeX string; received {type(lhs).__name__}")
    ipy = require("IPython.display", feature="show")
    Math, display = ipy.Math, ipy.display
    rhs = expr if isinstance(expr, str) else sp.latex(expr)
    display(Math(f"{lhs} = {rhs}"))


def check_zero(label: str, expr, *, quiet: bool = False):
    """Require a symbolic expression (or matrix) to simplify to exactly zero.

    Parameters
    ----------
    label : str
        What the identity says, printed with the simplified result.
    expr : sympy expression or matrix
        Typically ``derived - claimed``.
    quiet : bool, optional
        Do not print the simplified result.

    Returns
    -------
    sympy expression or matrix
        The simplified expression (zero).

    Raises
    ------
    SymbolicCheckError
        If it does not simplify to zero.

    Examples
    --------
    >>> import sympy as sp
    >>> a, b = sp.symbols("a b")
    >>> check_zero("(a+b)^2 - expanded", (a + b)**2 - (a**2 + 2*a*b + b**2))
    (a+b)^2 - expanded = 0
    0
    >>> check_zero("wrong", a - b, quiet=True)
    Traceback (most recent call last):
    ...
    radarfusion_ref.kit.symbolic.SymbolicCheckError: symbolic check failed: wrong (a - b != 0)
    """
    import sympy as sp

    if not isinstance(label, str) or not label.strip():
        raise TypeError(f"`label` must be a non-empty string; received {label!r}")
    if expr is None or isinstance(expr, (str, bytes, bool)):
        raise TypeError(f"`expr` must be a sympy expression or matrix; received {expr!r}")
    if isinstance(expr, sp.MatrixBase):
        if 0 in expr.shape:
            raise SymbolicCheckError(f"symbolic check failed: {label} (empty matrix {expr.shape}"
                                     " proves nothing)")
        simplified = expr.applyfunc(lambda e: sp.simplify(sp.cancel(e)))
        ok = simplified.is_zero_matrix is True
    else:
        try:
            simplified = sp.simplify(sp.sympify(expr, strict=True))
        except sp.SympifyError:
            raise TypeError(f"`expr` must be a sympy expression or matrix; received "
                            f"{expr!r}") from None
        ok = simplified.is_zero is True
    if not ok:
        raise SymbolicCheckError(f"symbolic check failed: {label} ({simplified} != 0)")
    _record("symbolic", label)
    if not quiet:
        print(f"{label} = {simplified}")
    return simplified


def check_numeric_agreement(derived, package, *, what: str = "derivation and package",
                            rtol: float = 1e-9, atol: float = 0.0) -> str:
    """Require numbers from a lambdified derivation to equal the package's.

    Parameters
    ----------
    derived, package : array_like
        The same quantity on the same inputs, by the two routes.
    what : str, optional
        Name used in the returned message and the error.
    rtol, atol : float, optional
        Tolerances of :func:`numpy.testing.assert_allclose`.

    Returns
    -------
    str
        ``"<what> agree on N values"`` (a cell can print it).

    Raises
    ------
    SymbolicCheckError
        With the largest discrepancy, if they disagree, or if either side is
        empty, non-finite or of another shape (see
        :func:`radarfusion_ref.kit.checks.check_close`).
    TypeError
        If either side is not numeric, or is complex (naming `derived` or `package`).

    Examples
    --------
    >>> check_numeric_agreement([1.0, 2.0], [1.0, 2.0 + 1e-12])
    'derivation and package agree on 2 values'
    """
    try:
        _check_close(package, derived, what=what, rtol=rtol, atol=atol,
                     names=("package", "derived"))
    except CheckError as exc:
        raise SymbolicCheckError(str(exc)) from None
    return f"{what} agree on {np.size(package)} values"
