"""Helpers for the chapters' symbolic derivations.

Every chapter derives its equations with sympy and then proves that the
derivation and the package agree. These helpers keep that pattern short and
make the executed book fail when a check fails:

* :func:`latex` — the book's LaTeX for a sympy expression (``ln``, Greek
  subscripts, positive terms first), used by :func:`show` and, after
  :func:`use_book_printing`, by every sympy result a cell displays;
* :func:`show` — display one step of a derivation, ``lhs = expr``;
* :func:`check_zero` — a symbolic identity that must simplify to zero;
* :func:`check_numeric_agreement` — a lambdified derivation against the package's numbers.
"""

from __future__ import annotations

import re
import typing

import numpy as np

from ..engine.optional import require
from .checks import CheckError, _check_close, _record

__all__ = ["latex", "use_book_printing", "show", "check_zero", "check_numeric_agreement",
           "SymbolicCheckError"]

#: Greek letter names sympy's printer knows (lower and upper case).
_GREEK = frozenset({
    "alpha", "beta", "gamma", "delta", "epsilon", "varepsilon", "zeta", "eta", "theta",
    "vartheta", "iota", "kappa", "lambda", "mu", "nu", "xi", "pi", "rho", "sigma", "tau",
    "upsilon", "phi", "varphi", "chi", "psi", "omega", "Gamma", "Delta", "Theta", "Lambda",
    "Xi", "Pi", "Sigma", "Upsilon", "Phi", "Psi", "Omega"
})
_TOKEN = re.compile(r"([A-Za-z]+)(\d*)")
#: ``Delta_<one letter or a Greek name><index>``: an increment (Δr_1, Δβ_1, Δt).
_INCREMENT = re.compile(r"([A-Za-z]|" + "|".join(sorted(_GREEK)) + r")(\d*)")


def _subscript(token: str) -> str:
    r"""One subscript of a symbol's name, as a textbook writes it.

    ``beta1`` → ``\beta_{1}`` (a Greek name with an index), ``r`` → ``r``,
    ``Pi`` → ``\Pi``, ``pos`` → ``\mathrm{pos}`` (a word is upright), digits
    and LaTeX stay as they are.
    """
    match = _TOKEN.fullmatch(token)
    if match is None:
        return token
    word, index = match.groups()
    if word in _GREEK:
        head = "\\" + word
    elif len(word) == 1:
        return word + ("," + index if index else "")
    elif not index:
        return "\\mathrm{" + word + "}"
    else:
        return token
    return head + ("_{" + index + "}" if index else "")


def _book_printer_class():
    """The book's LaTeX printer (built lazily: sympy is imported only when used)."""
    from sympy.printing.conventions import split_super_sub
    from sympy.printing.latex import LatexPrinter

    class BookLatexPrinter(LatexPrinter):
        """sympy's LaTeX printer with the book's conventions."""

        _default_settings: typing.ClassVar[dict] = {**LatexPrinter._default_settings, "ln_notation": True}

        def _deal_with_super_sub(self, string, style="plain"):
            if "{" in string or "\\" in string:
                return super()._deal_with_super_sub(string, style=style)
            name, supers, subs = split_super_sub(string)
            increment = _INCREMENT.fullmatch(subs[0]) if name == "Delta" and subs else None
            if increment is not None and not supers:
                # Delta_r1 is the increment Δr_1 of the book's notation, not Δ subscripted.
                of, index = increment.groups()
                inner = _subscript(of) + ("_{" + ",".join([index, *subs[1:]]) + "}"
                                          if index or subs[1:] else "")
                return r"\Delta " + inner
            name = _subscript(name) if name in _GREEK else super()._deal_with_super_sub(
                name, style=style)
            if style == "bold":
                name = r"\mathbf{" + name + "}"
            if supers:
                name += "^{" + ",".join(_subscript(t) for t in supers) + "}"
            if subs:
                name += "_{" + ",".join(_subscript(t) for t in subs) + "}"
            return name

        def _as_ordered_terms(self, expr, order=None):
            # (x - x~)^2, not (-x~ + x)^2: the positive terms first, in sympy's order.
            terms = super()._as_ordered_terms(expr, order=order)
            return ([t for t in terms if not t.could_extract_minus_sign()]
                    + [t for t in terms if t.could_extract_minus_sign()])

        def _print_Pow(self, expr):
            base = expr.base
            if (base.is_Symbol and not expr.exp.could_extract_minus_sign()
                    and self._print(base).startswith(r"\Delta ")):
                exp = self._print(expr.exp)
                return r"\left(" + self._print(base) + r"\right)^{" + exp + "}"
            return super()._print_Pow(expr)

    return BookLatexPrinter


def latex(expr, **settings) -> str:
    r"""The book's LaTeX for a sympy expression or matrix.

    sympy's printer with the book's conventions: the natural logarithm is
    :math:`\ln`; a symbol's subscripts read as a textbook writes them
    (``sigma_Pi_1`` → :math:`\sigma_{\Pi,1}`, a word such as ``pos``
    upright); an increment is written as in the book's notation (``Delta_r`` →
    :math:`\Delta r`, ``Delta_beta1`` → :math:`\Delta\beta_{1}`); and a sum
    starts with its positive terms, so :math:`(x - \tilde x)^2` is not printed
    :math:`(-\tilde x + x)^2`.

    Raises
    ------
    TypeError
        If `expr` is not a sympy expression or matrix (a number or a string is
        not: build it with sympy first).

    Examples
    --------
    >>> import sympy as sp
    >>> x, xt = sp.symbols(r"x \tilde{x}")
    >>> latex((x - xt)**2)
    '\\left(x - \\tilde{x}\\right)^{2}'
    >>> latex(sp.log(sp.Symbol("Delta_beta1")))
    '\\ln{\\left(\\Delta \\beta_{1} \\right)}'
    """
    import sympy as sp
    from sympy.logic.boolalg import BooleanAtom

    if not isinstance(expr, (sp.Basic, sp.MatrixBase)) or isinstance(expr, BooleanAtom):
        raise TypeError(f"`expr` must be a sympy expression or matrix; received "
                        f"{type(expr).__name__} {expr!r:.60}")
    return _book_printer_class()(settings).doprint(expr)


def use_book_printing() -> None:
    """Display every sympy result of a cell with :func:`latex` (call once per page).

    Outside IPython it does nothing.
    """
    try:
        from IPython import get_ipython
    except ImportError:
        return
    shell = get_ipython()
    if shell is None:
        return
    import sympy as sp

    def as_math(expr):
        try:
            return "$\\displaystyle " + latex(expr) + "$"
        except TypeError:                  # sympy's true and false: their plain repr
            return None

    formatter = shell.display_formatter.formatters["text/latex"]
    for kind in (sp.Basic, sp.MatrixBase):
        formatter.for_type(kind, as_math)


class SymbolicCheckError(CheckError):
    """A derivation and its claimed result (or the package) disagree."""


def show(lhs: str, expr) -> None:
    """Display ``lhs = expr`` as typeset mathematics (sympy's LaTeX printer).

    Parameters
    ----------
    lhs : str
        LaTeX of the left-hand side.
    expr : sympy expression, matrix or str
        The right-hand side (a string is used as LaTeX as it is), printed by
        :func:`latex`.
    """
    if not isinstance(lhs, str):
        raise TypeError(f"`lhs` must be a LaTeX string; received {type(lhs).__name__}")
    ipy = require("IPython.display", feature="show")
    Math, display = ipy.Math, ipy.display
    if isinstance(expr, str):
        rhs = expr
    else:
        import sympy as sp

        rhs = latex(expr if isinstance(expr, (sp.Basic, sp.MatrixBase)) else sp.sympify(expr))
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
