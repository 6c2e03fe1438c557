"""Input checks and exact power-of-two scaling shared by the assignment solvers.

The doors :func:`as_cost` and :func:`as_threshold` and the kernels :func:`cost_exponents`
and :func:`scale_costs` are public names of :mod:`radarfusion_ref.engine.assignment`, for the
chapter modules that build their own assignment rules from them.
"""

from __future__ import annotations

import numpy as np

from ..validation import as_float, as_float_array, as_probability


def _as_gap(gap, name: str = "gap") -> float:
    """A relative gap: one number in the open interval (0, 1)."""
    return as_float(as_probability(gap, name), name)


def cost_exponents(c: np.ndarray, *extra: float) -> np.ndarray:
    """Kernel (trusted input): binary exponents ``e`` (per matrix), ``|finite entries| < 2**e``.

    The solvers work on ``ldexp(cost, -e)``: a power-of-two scaling is exact,
    keeps every finite entry below 1 in magnitude, so no sum or difference of
    a few entries overflows even for costs near the float maximum.
    """
    finite = np.where(np.isfinite(c), np.abs(c), 0.0)
    top = finite.max(axis=(-2, -1)) if c.size else np.zeros(c.shape[:-2])
    for x in extra:
        top = np.maximum(top, abs(x))
    return np.frexp(top)[1]


def scale_costs(c: np.ndarray, e: np.ndarray | int) -> np.ndarray:
    """Kernel (trusted input): ``c * 2**-e`` per matrix, exact (``+inf`` stays ``+inf``).

    `e`: one exponent per matrix (from :func:`cost_exponents`), or one for all.
    """
    return np.ldexp(c, -np.asarray(e)[..., None, None])


def as_cost(cost, name: str = "cost") -> np.ndarray:
    """The door of cost matrices ``(..., n1, n2)``: finite or ``+inf``, not empty.

    NaN and ``-inf`` are refused.

    `name` is the caller's public name for the argument.
    """
    arr = as_float_array(cost, name, ndim_min=2, allow_nonfinite=True)
    if arr.shape[-1] == 0 or arr.shape[-2] == 0:
        raise ValueError(
            f"`{name}` must have at least one row and one column; received shape {arr.shape}"
        )
    if np.any(np.isnan(arr)):
        raise ValueError(
            f"`{name}` must not contain NaN (use +inf for a forbidden pair); received "
            f"{int(np.count_nonzero(np.isnan(arr)))} NaN entries in shape {arr.shape}"
        )
    if np.any(arr == -np.inf):
        raise ValueError(
            f"`{name}` must not contain -inf (a pair cannot be infinitely likely); received "
            f"{int(np.count_nonzero(arr == -np.inf))} -inf entries in shape {arr.shape}"
        )
    return arr


def as_threshold(threshold, name: str = "threshold") -> float:
    """The door of a gate: a number > 0; ``+inf`` and None both mean "no gate" (``+inf``).

    `name` is the caller's public name for the argument.
    """
    if threshold is None:
        return np.inf
    value = as_float(threshold, name, allow_inf=True)
    if value <= 0:
        raise ValueError(f"`{name}` must be a number > 0 (or +inf for no gate); received {value}")
    return value


def _as_miss_cost(miss_cost, name: str = "miss_cost") -> float | None:
    """Non-assignment cost: a real number; ``+inf`` means the same as None."""
    if miss_cost is None:
        return None
    value = as_float(miss_cost, name, allow_inf=True)
    if value == -np.inf:
        raise ValueError(f"`{name}` must be a real number or +inf; received {value}")
    return None if value == np.inf else value


def _inverse(row_to_col: np.ndarray, n2: int) -> np.ndarray:
    """``col_to_row`` from ``row_to_col`` (batched, -1 for unassigned)."""
    batch = row_to_col.shape[:-1]
    flat = row_to_col.reshape(-1, row_to_col.shape[-1])
    inv = np.full((flat.shape[0], n2), -1, dtype=int)
    b, i = np.nonzero(flat >= 0)
    inv[b, flat[b, i]] = i
    return inv.reshape(*batch, n2)

