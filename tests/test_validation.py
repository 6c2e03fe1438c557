"""The shared input checks: clear messages naming the argument."""

from __future__ import annotations

import numpy as np
import pytest

from radarfusion_ref.engine import validation as v


def test_float_array_accepts_numbers_and_lists():
    np.testing.assert_array_equal(v.as_float_array([1, 2], "x"), [1.0, 2.0])
    assert v.as_float_array(3, "x").shape == ()


@pytest.mark.parametrize("bad", ["abc", None, [[1, 2], [3]], {"a": 1}, True, np.bool_(False),
                                 [True, False], ["1.5", "2"], np.array(["1"]), [1 + 2j]])
def test_float_array_rejects_non_numeric(bad):
    with pytest.raises(TypeError, match="`x` must be a number or an array of numbers"):
        v.as_float_array(bad, "x")


@pytest.mark.parametrize("bad", [np.nan, np.inf, [1.0, -np.inf]])
def test_float_array_rejects_non_finite(bad):
    with pytest.raises(ValueError, match="`x` must be finite"):
        v.as_float_array(bad, "x")


def test_trailing_shape_is_checked():
    v.as_float_array(np.zeros((4, 2)), "xy", last_dims=(2,))
    with pytest.raises(ValueError, match=r"`xy` must have shape \(\.\.\., 2\)"):
        v.as_float_array(np.zeros((4, 3)), "xy", last_dims=(2,))


def test_positive_and_probability():
    with pytest.raises(ValueError, match="`var` must be > 0"):
        v.as_positive([1.0, 0.0], "var")
    v.as_positive([1.0, 0.0], "var", strict=False)
    with pytest.raises(ValueError, match="`p` must lie in the open interval"):
        v.as_probability(0.0, "p")
    v.as_probability(0.0, "p", open_interval=False)


@pytest.mark.parametrize("bad", [1.0, True, "3"])
def test_int_rejects_non_integers(bad):
    with pytest.raises(TypeError, match="`n` must be an integer"):
        v.as_int(bad, "n")


def test_int_range():
    assert v.as_int(np.int64(3), "n", minimum=1) == 3
    with pytest.raises(ValueError, match="`n` must be an integer >= 1 and <= 5; received 6"):
        v.as_int(6, "n", minimum=1, maximum=5)


def test_covariance_checks():
    good = np.array([[2.0, 0.5], [0.5, 1.0]])
    np.testing.assert_array_equal(v.as_covariance(np.stack([good, good]), "cov"),
                                  np.stack([good, good]))
    with pytest.raises(ValueError, match="`cov` must be symmetric"):
        v.as_covariance([[1.0, 0.5], [0.0, 1.0]], "cov")
    with pytest.raises(ValueError, match="1 of 2 matrices are not"):
        v.as_covariance(np.stack([good, [[1.0, 2.0], [2.0, 1.0]]]), "cov")
    with pytest.raises(ValueError, match=r"`cov` must have shape \(\.\.\., d, d\)"):
        v.as_covariance(np.zeros((2, 3)), "cov")
    with pytest.raises(ValueError, match=r"\(\.\.\., 3, 3\)"):
        v.as_covariance(good, "cov", dim=3)


def test_choice_and_rng():
    assert v.as_choice("a", "kind", ("a", "b")) == "a"
    with pytest.raises(ValueError, match="`kind` must be one of 'a', 'b'"):
        v.as_choice("c", "kind", ("a", "b"))
    g = np.random.default_rng(0)
    assert v.as_rng(g) is g
    with pytest.raises(TypeError, match="legacy RandomState"):
        v.as_rng(np.random.RandomState(0))
    with pytest.raises(TypeError, match="`rng`"):
        v.as_rng("seed")
    for flag in (True, False, np.True_):  # numpy takes a bool as the seed 1 or 0
        with pytest.raises(TypeError, match=r"`rng` must be None, an int seed.*received"):
            v.as_rng(flag)


def test_broadcast_names_all_arguments():
    a, b = v.broadcast(x1=np.zeros((3, 1)), x2=np.zeros(2))
    assert a.shape == b.shape == (3, 2)
    with pytest.raises(ValueError, match="`x1`, `x2` must broadcast"):
        v.broadcast(x1=np.zeros(3), x2=np.zeros(2))


def test_check_size_refuses_before_allocating():
    import math

    assert v.check_size(10, 10, what="things", alternative="x") == 10
    with pytest.raises(ValueError, match=r"refused: 3628800 hypotheses n! requested, above the "
                                         r"limit of 1000; use the solver instead"):
        v.check_size(math.factorial(10), 1000, what="hypotheses n!", alternative="the solver")


def test_seed_sequence_one_conversion():
    assert v.as_seed_sequence(7).entropy == 7
    seq = np.random.SeedSequence(3, spawn_key=(1,))
    assert v.as_seed_sequence(seq) is seq
    assert isinstance(v.as_seed_sequence(None), np.random.SeedSequence)
    # a Generator gives 128 bits: the four 32-bit words it draws, and it advances
    words = np.random.default_rng(5).integers(0, 2**32, size=4, dtype=np.uint64).tolist()
    g = np.random.default_rng(5)
    assert v.as_seed_sequence(g).entropy == words
    assert v.as_seed_sequence(g).entropy != words
    for bad in (-1, 1.5, True, "7", np.random.RandomState(0)):
        with pytest.raises(TypeError, match="`rng` must be None, a non-negative int seed"):
            v.as_seed_sequence(bad)


def test_single_number_check():
    assert v.as_float(np.float32(0.25), "p") == 0.25 and v.as_float(np.array(3), "p") == 3.0
    assert isinstance(v.as_float(1, "p"), float)
    with pytest.raises(ValueError, match=r"`p` must be a single number; received array"):
        v.as_float([0.1, 0.2], "p")
    with pytest.raises(ValueError, match="`p` must be finite"):
        v.as_float(float("nan"), "p")
    with pytest.raises(TypeError, match="`p`"):
        v.as_float("0.5", "p")
    with pytest.raises(ValueError, match="`p` must be finite"):
        v.as_float(float("inf"), "p")


def test_single_number_check_with_infinities():
    assert v.as_float(np.inf, "gate", allow_inf=True) == np.inf
    assert v.as_float(np.array(-np.inf), "gate", allow_inf=True) == -np.inf
    assert v.as_float(2, "gate", allow_inf=True) == 2.0
    for nan in (float("nan"), np.array(np.nan), np.float32("nan")):
        with pytest.raises(ValueError, match="`gate` must be a number or \\+-inf, not NaN"):
            v.as_float(nan, "gate", allow_inf=True)
    with pytest.raises(ValueError, match="`gate` must be a single number"):
        v.as_float([1.0, np.inf], "gate", allow_inf=True)


def test_covariance_rule_is_scale_free_and_refuses_singular_to_precision():
    corr = np.array([[1.0, 0.0], [0.0, 1.0]])
    for rho, ok in ((1 - 1e-11, True), (1 - 1e-13, False)):   # 1 - rho^2 about 2e-11, 2e-13
        corr[0, 1] = corr[1, 0] = rho
        for scale in (np.diag([1e-20, 1e20]), np.eye(2)):   # variances 1e-40, 1e40: in the domain
            c = scale @ corr @ scale
            if ok:
                v.as_covariance(c, "cov")
            else:
                with pytest.raises(ValueError, match="`cov` must be positive definite and not "
                                                     "singular to working precision"):
                    v.as_covariance(c, "cov")
