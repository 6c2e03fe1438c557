"""The derivation-check helpers fail when they should."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from radarfusion_ref.kit.symbolic import SymbolicCheckError, check_numeric_agreement, check_zero


def test_check_zero_accepts_identities_and_rejects_others():
    x = sp.symbols("x", positive=True)
    check_zero("log identity", sp.log(x**2) - 2 * sp.log(x), quiet=True)
    with pytest.raises(SymbolicCheckError, match="not an identity"):
        check_zero("not an identity", sp.sin(x) - x, quiet=True)


def test_check_zero_on_matrices():
    a = sp.symbols("a")
    m = sp.Matrix([[a, 1], [1, a]])
    check_zero("inverse", m * m.inv() - sp.eye(2), quiet=True)
    with pytest.raises(SymbolicCheckError):
        check_zero("not inverse", m * m - sp.eye(2), quiet=True)


def test_check_numeric_agreement():
    assert "agree on 3 values" in check_numeric_agreement(np.ones(3), np.ones(3))
    with pytest.raises(SymbolicCheckError, match="gain: disagree"):
        check_numeric_agreement([1.0], [1.001], what="gain")


@pytest.mark.parametrize("side", ["derived", "package"])
def test_check_numeric_agreement_refuses_complex_input_by_name(side):
    # 1+1j against 1+2j used to pass, the imaginary parts dropped with a ComplexWarning
    args = {"derived": 1.0, "package": 1.0, side: 1 + 2j}
    with pytest.raises(TypeError, match=f"`{side}`.*complex"):
        check_numeric_agreement(args["derived"], args["package"])
    with pytest.raises(TypeError, match="complex"):
        check_numeric_agreement(1 + 1j, 1 + 2j)


def test_book_latex_reads_like_a_textbook():
    import sympy as sp

    from radarfusion_ref.kit.symbolic import latex

    x, xt = sp.symbols(r"x \tilde{x}")
    assert latex((x - xt) ** 2) == r"\left(x - \tilde{x}\right)^{2}"
    assert latex(sp.log(x)) == r"\ln{\left(x \right)}"
    assert latex(sp.Symbol("Delta_beta1")) == r"\Delta \beta_{1}"
    assert latex(sp.Symbol("Delta_r") ** 2) == r"\left(\Delta r\right)^{2}"
    assert latex(1 / sp.Symbol("Delta_r") ** 2) == r"\frac{1}{\left(\Delta r\right)^{2}}"
    assert latex(sp.Symbol("Delta_1")) == r"\Delta_{1}"
    assert latex(sp.Symbol("sigma_Pi_1")) == r"\sigma_{\Pi,1}"
    assert latex(sp.Symbol("rho_pos")) == r"\rho_{\mathrm{pos}}"
    assert latex(sp.Symbol("P_D1")) == r"P_{D,1}"
    assert latex(sp.Symbol(r"\hat{x}_1") - x) == r"\hat{x}_1 - x"
