r"""Checks that can fail: the executed book's proof that derivation and package agree.

Every check in a chapter goes through one of these helpers, so that a check
is never weaker than it looks:

* :func:`check_close` — numbers by two routes (a lambdified derivation and the
  package, a closed form and a simulation) agree within a stated tolerance;
* :func:`check_equal` — two decisions (assignments, labels, counts) are identical;
* :func:`check_true` — a stated property holds for every entry;
* :func:`radarfusion_ref.kit.symbolic.check_zero` and
  :func:`radarfusion_ref.kit.checks.require` (symbolic identities and
  Monte-Carlo tolerances) record themselves here as well.

Each helper refuses what would let it pass vacuously — ``None``, NaN or inf,
an empty array, a shape mismatch, a non-finite, negative or meaningless
tolerance — and raises :class:`CheckError` (an :class:`AssertionError`) when
the claim is false, so a failing check stops the executed book with its
message in the build log.

Every passing check is counted (:func:`passed`) and its description kept, so
that a page closes with one line, :func:`page_summary` ("Verified on this
page: N checks", the list folded beneath it). When the environment variable
``RADARFUSION_CHECK_LOG`` names a file, each passing check also appends one
line ``<kind>\t<what>`` to it; the test suite uses that ledger to prove that
hiding a check from the page never skipped its execution.
"""

from __future__ import annotations

import html
import os
from collections import Counter

import numpy as np

from ..engine.montecarlo import MeanEstimate, Proportion
from ..engine.validation import describe

__all__ = ["CheckError", "check_close", "check_equal", "check_true", "passed", "page_summary",
           "PageSummary", "require", "MonteCarloCheckError", "LOG_ENV"]

#: Environment variable naming the ledger file of passing checks.
LOG_ENV = "RADARFUSION_CHECK_LOG"

_PASSED: Counter = Counter()
#: Every passing check of this process, in order: ``(kind, what)``.
_LEDGER: list[tuple[str, str]] = []


class CheckError(AssertionError):
    """A check of the book failed: two routes disagree, or a claimed property is false."""


def _record(kind: str, what: str) -> None:
    """Count one passing check (and append it to the ledger file, if one is named)."""
    _PASSED[kind] += 1
    line = " ".join(str(what).split())[:200]
    _LEDGER.append((kind, line))
    path = os.environ.get(LOG_ENV)
    if path:
        with open(path, "a", encoding="utf-8") as fh:
            fh.write(f"{kind}\t{line}\n")


def passed() -> dict[str, int]:
    """How many checks have passed in this process, by kind.

    Examples
    --------
    >>> before = sum(passed().values())
    >>> _ = check_true(True, what="one is one")
    >>> sum(passed().values()) - before
    1
    """
    return dict(_PASSED)


class PageSummary:
    """The closing line of a page and, folded beneath it, what the page verified.

    Displayed by Jupyter (and so by the built book) as

    * HTML: ``<details>`` whose ``<summary>`` is the line "Verified on this
      page: N checks" and whose body lists the checks (repeated descriptions
      once, with their count);
    * Markdown (the PDF edition's choice): the line alone;
    * plain text: the line alone.

    Attributes
    ----------
    total : int
        How many checks passed in this kernel.
    items : list of (str, str, int)
        ``(kind, description, count)`` in the order each was first recorded.
    """

    def __init__(self, ledger: list[tuple[str, str]]):
        counts: dict[tuple[str, str], int] = {}
        for entry in ledger:
            counts[entry] = counts.get(entry, 0) + 1
        self.total = len(ledger)
        self.items = [(kind, what, n) for (kind, what), n in counts.items()]

    @property
    def line(self) -> str:
        """The one closing line: ``"Verified on this page: N checks"``."""
        noun = "check" if self.total == 1 else "checks"
        return f"Verified on this page: {self.total} {noun}"

    def __str__(self) -> str:
        return self.line

    def __repr__(self) -> str:
        return self.line

    def _repr_markdown_(self) -> str:
        return f"**{self.line}**"

    def _repr_html_(self) -> str:
        rows = "".join(
            f"<li><span class=\"rf-check-kind\">{html.escape(kind)}</span> "
            f"{html.escape(what)}{f' (×{n})' if n > 1 else ''}</li>"
            for kind, what, n in self.items
        )
        return (f'<details class="rf-page-summary tex2jax_ignore mathjax_ignore">'
                f"<summary><strong>{html.escape(self.line)}</strong></summary>"
                f'<ol class="rf-check-list">{rows}</ol></details>')


def page_summary() -> PageSummary:
    """The closing line of a page: how many checks it executed, the list folded beneath.

    Put it in the last cell of a page, tagged ``remove-input``, as the cell's
    last expression (not inside ``print``) so the page shows the folded list::

        checks.page_summary()

    The count is the ledger of this kernel: every :func:`check_close`,
    :func:`check_equal`, :func:`check_true`, :func:`require` and
    :func:`radarfusion_ref.kit.symbolic.check_zero` that passed since the
    kernel started, i.e. on this page.

    Returns
    -------
    PageSummary
        Shown as "Verified on this page: N checks" with the list in an HTML
        ``<details>`` fold (the line alone in Markdown, LaTeX and plain text).

    Raises
    ------
    CheckError
        If no check has run: a page that claims no checks is a broken page.

    Examples
    --------
    >>> _ = check_true(True, what="one is one")
    >>> str(page_summary()).startswith("Verified on this page:")
    True
    """
    if not _LEDGER:
        raise CheckError("page_summary: no check has run in this kernel; a page must verify "
                         "what it teaches (check_close, check_equal, check_true, require or "
                         "symbolic.check_zero) before its closing line")
    return PageSummary(list(_LEDGER))


def _as_what(what) -> str:
    if not isinstance(what, str) or not what.strip():
        raise TypeError(f"`what` must be a non-empty string naming the check; received "
                        f"{describe(what)}")
    return what


def _numeric(value, name: str, what: str) -> np.ndarray:
    """A non-empty, all-finite numeric array, or a CheckError / TypeError saying why not."""
    if value is None:
        raise TypeError(f"{what}: `{name}` is None; a check needs numbers")
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{what}: `{name}` must be numeric; received {describe(value)}")
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError):
        raise TypeError(f"{what}: `{name}` must be numeric; received {describe(value)}") from None
    if arr.dtype == object or not np.issubdtype(arr.dtype, np.number):
        raise TypeError(f"{what}: `{name}` must be numeric; received {describe(value)}")
    if np.iscomplexobj(arr):
        raise TypeError(f"{what}: `{name}` must be real; received complex {describe(value)} "
                        "(compare real and imaginary parts as two real checks)")
    if arr.size == 0:
        raise CheckError(f"{what}: `{name}` is empty (shape {arr.shape}); an empty "
                         "comparison proves nothing")
    if np.issubdtype(arr.dtype, np.inexact) and not np.all(np.isfinite(arr)):
        bad = int(np.count_nonzero(~np.isfinite(arr)))
        raise CheckError(f"{what}: `{name}` has {bad} non-finite entries: {describe(arr)}")
    return arr


def _tolerance(value, name: str, *, upper: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"`{name}` must be a real number; received {describe(value)}")
    tol = float(value)
    if not np.isfinite(tol) or tol < 0 or (upper is not None and tol >= upper):
        bound = f"[0, {upper:g})" if upper is not None else "[0, inf)"
        raise ValueError(f"`{name}` must be a finite tolerance in {bound}; received {value!r}")
    return tol


def _same_shape(value: np.ndarray, reference: np.ndarray, what: str) -> None:
    if value.shape != reference.shape and reference.ndim != 0:
        raise CheckError(f"{what}: shapes differ, {value.shape} against the reference's "
                         f"{reference.shape}")


def check_close(value, reference, *, what: str, rtol: float = 1e-9, atol: float = 0.0) -> str:
    """Require `value` to equal `reference` within ``atol + rtol * |reference|``.

    Parameters
    ----------
    value : array_like
        The quantity under test (usually the package's output).
    reference : array_like
        The same quantity by an independent route (a lambdified derivation, a
        closed form, brute force). It must have `value`'s shape, or be a scalar.
    what : str
        What is being compared, for the message.
    rtol : float, optional
        Relative tolerance, in [0, 1): a relative tolerance of 100 % or more
        could not tell a value from its double.
    atol : float, optional
        Absolute tolerance, finite and >= 0.

    Returns
    -------
    str
        ``"<what>: agree on N values (largest relative difference d)"``.

    Raises
    ------
    CheckError
        If they disagree, if either is empty or non-finite, or if the shapes differ.
    TypeError
        If either is ``None``, not numeric or complex, or `what` is not a string.
    ValueError
        If a tolerance is negative, non-finite or ``rtol >= 1``.

    Examples
    --------
    >>> check_close([1.0, 2.0], [1.0, 2.0 + 1e-12], what="two routes")
    'two routes: agree on 2 values (largest relative difference 5e-13)'
    >>> check_close([1.0, float("nan")], [1.0, 2.0], what="two routes")
    Traceback (most recent call last):
    ...
    radarfusion_ref.kit.checks.CheckError: two routes: `value` has 1 non-finite entries: array [ 1. nan] with shape (2,)
    """
    return _check_close(value, reference, what=what, rtol=rtol, atol=atol)


def _check_close(value, reference, *, what, rtol, atol, names=("value", "reference")) -> str:
    """:func:`check_close`, with the caller's public names for the two inputs."""
    what = _as_what(what)
    rtol = _tolerance(rtol, "rtol", upper=1.0)
    atol = _tolerance(atol, "atol")
    v = _numeric(value, names[0], what).astype(float)
    r = _numeric(reference, names[1], what).astype(float)
    _same_shape(v, r, what)
    diff = np.abs(v - r)
    allowed = atol + rtol * np.abs(r)
    if not np.all(diff <= allowed):
        worst = int(np.argmax(diff - allowed))
        vb, rb = np.broadcast_arrays(v, r)
        raise CheckError(
            f"{what}: disagree at {int(np.count_nonzero(diff > allowed))} of {diff.size} values; "
            f"worst {vb.flat[worst]:.17g} against {rb.flat[worst]:.17g} "
            f"(|diff| {diff.flat[worst]:.3g} > allowed {np.broadcast_to(allowed, diff.shape).flat[worst]:.3g}; "
            f"rtol={rtol:g}, atol={atol:g})"
        )
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(r != 0, diff / np.abs(r), diff)
    _record("numeric", what)
    return f"{what}: agree on {diff.size} values (largest relative difference {rel.max():.1g})"


def check_equal(value, reference, *, what: str) -> str:
    """Require two decisions (integer or boolean arrays, labels) to be identical.

    Parameters
    ----------
    value, reference : array_like
        Integer, boolean or string arrays of the same shape (a scalar reference
        is compared with every entry). Floats must be whole numbers.
    what : str
        What is being compared.

    Returns
    -------
    str
        ``"<what>: identical on N entries"``.

    Raises
    ------
    CheckError
        If any entry differs, either input is empty or contains NaN, or the
        shapes differ.
    TypeError
        If either is ``None``.

    Examples
    --------
    >>> check_equal([0, 2, 1], [0, 2, 1], what="assignment")
    'assignment: identical on 3 entries'
    >>> check_equal([0, 2, 1], [0, 1, 2], what="assignment")
    Traceback (most recent call last):
    ...
    radarfusion_ref.kit.checks.CheckError: assignment: differ at 2 of 3 entries (first at index (1,): 2 against 1)
    """
    what = _as_what(what)
    arrays = []
    for name, x in (("value", value), ("reference", reference)):
        if x is None:
            raise TypeError(f"{what}: `{name}` is None; a check needs values")
        try:
            a = np.asarray(x)
        except ValueError:
            raise TypeError(f"{what}: `{name}` must be a regular array; received "
                            f"{describe(x)}") from None
        if a.size == 0:
            raise CheckError(f"{what}: `{name}` is empty (shape {a.shape}); an empty "
                             "comparison proves nothing")
        if a.dtype.kind in "fc":
            a = _numeric(a, name, what)
            if np.any(a != np.round(a)):
                raise CheckError(f"{what}: `{name}` must hold whole numbers or labels; "
                                 f"received {describe(a)}")
        elif a.dtype == object:
            raise TypeError(f"{what}: `{name}` must be an array of integers, booleans or "
                            f"strings; received {describe(x)}")
        arrays.append(a)
    v, r = arrays
    _same_shape(v, r, what)
    differ = np.asarray(v != r)
    if np.any(differ):
        first = tuple(int(i) for i in np.argwhere(differ)[0])
        vb, rb = np.broadcast_arrays(v, r)
        raise CheckError(f"{what}: differ at {int(differ.sum())} of {differ.size} entries "
                         f"(first at index {first}: {vb[first].tolist()!r} against {rb[first].tolist()!r})")
    _record("decision", what)
    return f"{what}: identical on {differ.size} entries"


def check_true(condition, *, what: str) -> str:
    """Require a stated property to hold: a bool, or every entry of a boolean array.

    Parameters
    ----------
    condition : bool or array_like of bool
        Must be a genuine boolean (Python or numpy), not a number, ``None`` or
        an empty array.
    what : str
        The property, in words ("the gate is monotone in the threshold").

    Returns
    -------
    str
        ``"<what>: holds"`` (``"holds on N entries"`` for arrays).

    Raises
    ------
    CheckError
        If it is false anywhere, or the array is empty.
    TypeError
        If `condition` is not boolean.

    Examples
    --------
    >>> check_true(np.array([True, True]), what="weights are positive")
    'weights are positive: holds on 2 entries'
    >>> check_true(None, what="weights are positive")
    Traceback (most recent call last):
    ...
    TypeError: weights are positive: `condition` must be a bool or a boolean array; received None
    """
    what = _as_what(what)
    try:
        arr = np.asarray(condition) if condition is not None else None
    except ValueError:
        arr = None
    if arr is None or arr.dtype != bool:
        raise TypeError(f"{what}: `condition` must be a bool or a boolean array; received "
                        f"{describe(condition)}")
    if arr.size == 0:
        raise CheckError(f"{what}: `condition` is empty; an empty check proves nothing")
    if not np.all(arr):
        raise CheckError(f"{what}: false at {int(np.count_nonzero(~arr))} of {arr.size} entries")
    _record("property", what)
    return f"{what}: holds" if arr.ndim == 0 else f"{what}: holds on {arr.size} entries"


class MonteCarloCheckError(CheckError):
    """A Monte-Carlo estimate contradicts the exact value it was meant to confirm."""


def require(estimate: Proportion | MeanEstimate, exact, what: str, *,
            sigmas: float = 5.0) -> None:
    """Stop (raise) if a Monte-Carlo estimate contradicts the exact value it checks.

    The book calls this after every Monte-Carlo check, so the executed book
    fails when a claim breaks. The tolerance is generous — `sigmas` standard
    errors (default 5; a 95 % interval is about 2) — so a correct claim fails
    by bad luck with probability below about 6e-7 per comparison.

    Parameters
    ----------
    estimate : Proportion or MeanEstimate
    exact : float or array_like
        The value the estimate should agree with (broadcast against it).
    what : str
        What is being checked, for the error message.
    sigmas : float, optional
        Tolerance in standard errors.

    Raises
    ------
    MonteCarloCheckError
        If any entry disagrees.
    TypeError
        If `estimate` is not a :class:`Proportion` or :class:`MeanEstimate`.

    Examples
    --------
    >>> from radarfusion_ref.engine.montecarlo import proportion
    >>> require(proportion(480, 1000), 0.5, "a fair coin")
    >>> require(proportion(400, 1000), 0.5, "a fair coin")
    Traceback (most recent call last):
    ...
    radarfusion_ref.kit.checks.MonteCarloCheckError: a fair coin: Monte Carlo 0.4000 [0.3700, 0.4307] (n=1000, 95% Wilson) disagrees with the exact value 0.5 (5 standard errors)
    """
    if not isinstance(estimate, (Proportion, MeanEstimate)):
        raise TypeError("`estimate` must be a Proportion or a MeanEstimate; received "
                        f"{type(estimate).__name__}")
    if not isinstance(what, str) or not what.strip():
        raise TypeError(f"`what` must be a non-empty string; received {describe(what)}")
    if not np.all(np.isfinite(np.asarray(estimate.estimate, dtype=float))):
        raise MonteCarloCheckError(f"{what}: the Monte-Carlo estimate is not finite: {estimate}")
    if not estimate.agrees(exact, sigmas=sigmas):
        raise MonteCarloCheckError(
            f"{what}: Monte Carlo {estimate} disagrees with the exact value "
            f"{np.round(exact, 6)} ({sigmas:g} standard errors)"
        )
    _record("monte-carlo", what)
