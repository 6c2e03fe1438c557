"""Trust at the edges: extreme but legal magnitudes, wrong-but-plausible input, and names.

Each case was a silent wrong value, a raw library error or a message naming an internal
argument. A representable answer must be computed; otherwise the refusal names the public
argument and the value received. Reference values come from closed forms typed in here.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from radarfusion_ref import registration as rg

SITES = np.array([[0.0, 0.0], [30.0, 0.0]])
OBJS = np.array([[0.0, 60.0], [30.0, 70.0], [-20.0, 50.0], [10.0, 80.0], [45.0, 55.0]])


# --------------------------------------------------------------------------- registration
def test_wrongly_associated_reports_are_refused_by_name():
    # radar 1's reports shuffled: once refused naming the internal `jac_object`
    z = rg.draw_biased_reports(SITES, OBJS, [[0.3, 1e-3, 2e-3], [-0.2, 0, 0]], 0.05, 1e-3,
                               rng=1)
    z[1] = z[1][np.random.default_rng(8).permutation(len(OBJS))]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(ValueError, match=r"^`reports`: these reports do not determine.*"
                                             r"association") as err:
            rg.estimate_biases(SITES, z, 0.05, 1e-3)
    assert "jac_object" not in str(err.value)


@pytest.mark.parametrize(("sigma_r", "sigma_beta", "name"),
                         [(1e-200, 1e-3, "sigma_r"), (0.05, 1e-200, "sigma_beta"),
                          (1e-160, 1e-3, "sigma_r")])
def test_information_at_tiny_sigmas_is_refused_by_name(sigma_r, sigma_beta, name):
    # bias_information returned NaN; observability then reported rank 0 ("nothing seen")
    for call in (lambda: rg.bias_information(SITES, OBJS, sigma_r, sigma_beta),
                 lambda: rg.observability(SITES, OBJS, sigma_r, sigma_beta)):
        with pytest.raises(ValueError, match=rf"`{name}`.*1e-[12][0-9]0"):
            call()


def test_information_at_small_but_representable_sigmas_is_computed():
    # 1e-100 m and 1e-100 rad: information ~1e200, representable; rank as at ordinary sigmas
    J = rg.bias_information(SITES, OBJS, 1e-100, 1e-100)
    assert np.all(np.isfinite(J))
    assert rg.observability(SITES, OBJS, 1e-100, 1e-100).rank == 6


def test_apply_and_remove_biases_never_return_inf():
    # (1 + g) r + dr overflowed to inf silently
    with pytest.raises(ValueError, match=r"`r`.*`biases`.*1e\+308"):
        rg.apply_biases(1e308, 0.1, [0.0, 1.0, 0.0])
    with pytest.raises(ValueError, match=r"`r_hat`.*`biases`.*1e\+308"):
        rg.remove_biases(1e308, 0.1, [0.0, -0.9, 0.0])
    r, b = rg.apply_biases(1e307, 0.1, [0.0, 1.0, 0.0])           # 2e307: representable
    assert float(r) == pytest.approx(2e307, rel=1e-15) and float(b) == 0.1
