"""The book's checks can fail: each check helper is fed wrong values and must refuse them."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st

from radarfusion_ref.engine.montecarlo import mean, proportion
from radarfusion_ref.kit import checks
from radarfusion_ref.kit.checks import (
    CheckError,
    MonteCarloCheckError,
    check_close,
    check_equal,
    check_true,
    require,
)
from radarfusion_ref.kit.symbolic import SymbolicCheckError, check_numeric_agreement, check_zero

VACUOUS = [None, np.nan, [1.0, np.nan], np.inf, [-np.inf], [], np.zeros((0, 3)), "1.0",
           [True, False]]


@pytest.mark.parametrize("bad", VACUOUS, ids=repr)
@pytest.mark.parametrize("side", ["value", "reference"])
def test_check_close_refuses_what_would_pass_vacuously(bad, side):
    args = {"value": [1.0, 2.0], "reference": [1.0, 2.0]}
    args[side] = bad
    with pytest.raises((CheckError, TypeError), match=f"`{side}`"):
        check_close(args["value"], args["reference"], what="t")


@pytest.mark.parametrize("bad", VACUOUS, ids=repr)
def test_check_numeric_agreement_names_its_own_arguments(bad):
    with pytest.raises((CheckError, TypeError), match="`package`"):
        check_numeric_agreement([1.0, 2.0], bad)
    with pytest.raises((CheckError, TypeError), match="`derived`"):
        check_numeric_agreement(bad, [1.0, 2.0])


@pytest.mark.parametrize(("rtol", "atol"), [(np.inf, 0.0), (0.0, np.inf), (-1e-9, 0.0),
                                            (0.0, -1.0), (np.nan, 0.0), (1.0, 0.0), (5, 0),
                                            (None, 0.0), ("1e-9", 0.0), (True, 0.0)])
def test_check_close_refuses_meaningless_tolerances(rtol, atol):
    with pytest.raises((ValueError, TypeError), match=r"`rtol`|`atol`"):
        check_close(1.0, 1.0, what="t", rtol=rtol, atol=atol)


def test_check_close_refuses_a_shape_mismatch():
    with pytest.raises(CheckError, match="shapes differ"):
        check_close([1.0, 2.0], [1.0, 2.0, 3.0], what="t")
    with pytest.raises(CheckError, match="shapes differ"):
        check_close([[1.0, 2.0]], [1.0, 2.0], what="t")
    check_close([3.0, 3.0], 3.0, what="scalar reference")  # a scalar reference broadcasts


@given(st.floats(-1e6, 1e6), st.floats(1e-12, 1e-3))
def test_check_close_fails_just_outside_its_tolerance(x, rtol):
    ref = x if x != 0 else 1.0
    off = ref * (1 + 2 * rtol)
    with pytest.raises(CheckError, match="disagree"):
        check_close(off, ref, what="t", rtol=rtol)
    check_close(ref * (1 + rtol / 2), ref, what="t", rtol=rtol)


def test_check_equal_fails_on_one_differing_decision():
    with pytest.raises(CheckError, match="differ at 1 of 4"):
        check_equal([0, 1, 2, 3], [0, 1, 3, 3], what="assignment")
    for bad in (None, [], [0.5, 1.0], [np.nan, 1.0]):
        with pytest.raises((CheckError, TypeError), match="`value`"):
            check_equal(bad, [0, 1], what="t")
    with pytest.raises(CheckError, match="shapes differ"):
        check_equal([0, 1], [0, 1, 2], what="t")
    assert check_equal(np.array([0.0, 2.0]), [0, 2], what="whole floats")


@pytest.mark.parametrize("bad", [None, 1, 0.0, "yes", [1, 0], np.array([]), [[True], [True, False]]],
                         ids=repr)
def test_check_true_refuses_non_booleans_and_empty(bad):
    with pytest.raises((CheckError, TypeError), match="`condition`"):
        check_true(bad, what="t")


def test_check_true_fails_when_false_anywhere():
    with pytest.raises(CheckError, match="false at 1 of 3"):
        check_true(np.array([True, False, True]), what="t")
    with pytest.raises(CheckError):
        check_true(False, what="t")
    with pytest.raises(TypeError, match="`what`"):
        check_true(True, what="")


def test_check_zero_fails_on_a_wrong_identity_and_refuses_vacuous_input():
    a, b = sp.symbols("a b")
    with pytest.raises(SymbolicCheckError):
        check_zero("wrong", (a + b) ** 2 - a**2 - b**2, quiet=True)
    with pytest.raises(SymbolicCheckError):
        check_zero("nan", sp.nan, quiet=True)
    with pytest.raises(SymbolicCheckError, match="empty"):
        check_zero("empty", sp.zeros(0, 2), quiet=True)
    for bad in (None, "0", True):
        with pytest.raises(TypeError, match="`expr`"):
            check_zero("bad", bad, quiet=True)


def test_require_fails_off_tolerance_and_refuses_vacuous_input():
    est = proportion(480, 1000)
    with pytest.raises(MonteCarloCheckError):
        require(est, 0.4, "wrong value")
    for bad in (None, np.nan, [], "0.5", [0.5, 0.5, 0.5]):
        with pytest.raises((ValueError, TypeError), match="`exact`"):
            require(est, bad, "t")
    for sig in (-1.0, 0.0, np.inf, np.nan, 11.0, None, True):
        with pytest.raises((ValueError, TypeError), match="`sigmas`"):
            require(est, 0.5, "t", sigmas=sig)
    with pytest.raises(ValueError, match="`axis`"):
        mean(np.ones((3, 4)), axis=5)
    with pytest.raises(TypeError, match="`axis`"):
        mean(np.ones((3, 4)), axis=None)


def test_passing_checks_are_counted_and_failing_ones_are_not():
    before = sum(checks.passed().values())
    check_close(1.0, 1.0, what="t")
    with pytest.raises(CheckError):
        check_close(1.0, 2.0, what="t")
    assert sum(checks.passed().values()) == before + 1
    assert checks.page_summary().total >= 1


def test_the_ledger_file_gets_one_line_per_passing_check(tmp_path, monkeypatch):
    log = tmp_path / "ledger"
    monkeypatch.setenv(checks.LOG_ENV, str(log))
    check_true(True, what="first")
    require(proportion(500, 1000), 0.5, "second")
    with pytest.raises(CheckError):
        check_true(False, what="third")
    assert log.read_text().splitlines() == ["property\tfirst", "monte-carlo\tsecond"]


@pytest.mark.parametrize("side", ["value", "reference"])
@pytest.mark.parametrize("z", [1 + 2j, [1.0, 2 + 0j], np.array([1 + 1e-3j])])
def test_check_close_refuses_complex_input_by_name(side, z):
    # 1+1j against 1+2j used to pass, the imaginary parts dropped with a ComplexWarning
    args = {"value": 1.0, "reference": 1.0, side: z}
    with pytest.raises(TypeError, match=f"`{side}`.*complex"):
        check_close(args["value"], args["reference"], what="complex")
    with pytest.raises(TypeError, match=r"`value`.*complex"):
        check_close(1 + 1j, 1 + 2j, what="complex")


def test_page_summary_counts_this_kernels_checks_and_folds_their_list(monkeypatch):
    monkeypatch.setattr(checks, "_LEDGER", [])
    with pytest.raises(CheckError, match="no check has run"):
        checks.page_summary()
    check_true(True, what="weights <sum> to one & more")
    for _ in range(3):
        check_close(2.0, 2.0, what="two routes")
    with pytest.raises(CheckError):
        check_close(1.0, 2.0, what="a failing check is not counted")
    check_zero("an identity", sp.Integer(0), quiet=True)
    summary = checks.page_summary()
    assert summary.total == 5
    assert str(summary) == repr(summary) == "Verified on this page: 5 checks"
    assert summary.items == [("property", "weights <sum> to one & more", 1),
                             ("numeric", "two routes", 3), ("symbolic", "an identity", 1)]
    html = summary._repr_html_()
    assert html.startswith("<details") and html.endswith("</details>")
    assert "<summary><strong>Verified on this page: 5 checks</strong></summary>" in html
    assert "weights &lt;sum&gt; to one &amp; more" in html  # escaped, not markup
    assert "two routes (×3)" in html and html.count("<li>") == 3
    assert "failing" not in html
    # the PDF edition shows the line alone
    assert summary._repr_markdown_() == "**Verified on this page: 5 checks**"
    monkeypatch.setattr(checks, "_LEDGER", [("numeric", "one")])
    assert str(checks.page_summary()) == "Verified on this page: 1 check"


def test_page_summary_shows_the_fold_in_html_and_the_line_alone_in_print(monkeypatch):
    """What Jupyter stores and which of it the book's builders pick (myst-nb's priorities)."""
    InteractiveShell = pytest.importorskip("IPython.core.interactiveshell").InteractiveShell
    get_mime_priority = pytest.importorskip("myst_nb.core.render").get_mime_priority

    monkeypatch.setattr(checks, "_LEDGER", [("numeric", "two routes"), ("property", "p")])
    data, _ = InteractiveShell.instance().display_formatter.format(checks.page_summary())
    assert set(data) == {"text/plain", "text/html", "text/markdown"}

    def shown(builder):
        return next(m for m in get_mime_priority(builder, []) if m in data)

    assert shown("html") == "text/html" and "<details" in data["text/html"]
    assert shown("latex") == "text/markdown"
    assert data["text/markdown"] == "**Verified on this page: 2 checks**"
    assert data["text/plain"] == "Verified on this page: 2 checks"
