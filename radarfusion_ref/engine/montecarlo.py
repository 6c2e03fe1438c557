"""Monte-Carlo estimates with their confidence intervals.

Every Monte-Carlo number in the book is reported through these helpers, so it
always carries its trial count and an interval:

* :func:`proportion` — a probability estimated from ``k`` successes in ``n``
  trials, with a Wilson score or Clopper–Pearson interval;
* :func:`mean` — a mean of i.i.d. samples with a Student-t interval.

Both return frozen dataclasses whose ``str`` is the form used in the prose,
e.g. ``0.9512 [0.9469, 0.9552] (n=10000, 95% Wilson)``.

:func:`sweep` runs a vectorized experiment over a parameter grid in blocks of
trials, in this process or on a Dask cluster, with results that depend only on
the seed and the grid (never on the cluster, the block size or the order in
which tasks finish).

.. rubric:: References

.. [1] E. B. Wilson, "Probable inference, the law of succession, and
   statistical inference", JASA 22 (1927) 209–212.
.. [2] C. J. Clopper, E. S. Pearson, "The use of confidence or fiducial limits
   illustrated in the case of the binomial", Biometrika 26 (1934) 404–413.
"""

from __future__ import annotations

import itertools
import math
import numbers
import os
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from scipy import stats

from .optional import available, require
from .validation import (
    MEMORY_LIMIT,
    as_bool,
    as_choice,
    as_float,
    as_float_array,
    as_int,
    as_probability,
    as_seed_sequence,
    check_size,
    describe,
    unwrap,
)

__all__ = ["Proportion", "MeanEstimate", "proportion", "mean", "binomial_tolerance",
           "sweep", "unit_rng", "SweepResult", "SweepError", "as_client",
           "SEED_BLOCK", "DEFAULT_BLOCK", "MAX_POINTS", "PROGRESS_ENV"]


def _as_sigmas(sigmas) -> float:
    """A tolerance in standard errors: finite, in (0, 10]."""
    s = as_float(sigmas, "sigmas")
    if not (0 < s <= 10):
        raise ValueError(f"`sigmas` must lie in (0, 10] standard errors (a wider tolerance "
                         f"cannot fail); received {sigmas!r}")
    return s


def _as_exact(exact, shape) -> np.ndarray:
    """The exact value a Monte-Carlo estimate is compared with: finite, broadcastable."""
    if exact is None:
        raise TypeError("`exact` must be a number or an array of numbers; received None")
    arr = as_float_array(exact, "exact")
    if arr.size == 0:
        raise ValueError("`exact` must not be empty; an empty comparison proves nothing")
    try:
        ok = np.broadcast_shapes(arr.shape, shape) == tuple(shape)
    except ValueError:
        ok = False
    if not ok:
        raise ValueError(f"`exact` with shape {arr.shape} does not broadcast to the "
                         f"estimate's shape {tuple(shape)}")
    return arr


def _pick(x, index):
    return np.asarray(x)[index] if index is not None else x


def _format(est, index, digits):
    e, lo, hi = (float(_pick(v, index)) for v in (est.estimate, est.low, est.high))
    return f"{e:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def _fmt(x) -> str:
    return np.array2string(np.asarray(x), precision=4, floatmode="fixed") if np.ndim(x) else f"{x:.4f}"


@dataclass(frozen=True)
class Proportion:
    """A proportion estimated by Monte Carlo, with its confidence interval.

    Attributes
    ----------
    successes : numpy.ndarray or int
        Number of trials in which the event occurred.
    trials : int
        Number of trials.
    estimate : numpy.ndarray or float
        ``successes / trials``.
    low, high : numpy.ndarray or float
        Confidence limits.
    confidence : float
        Coverage of the interval, e.g. 0.95.
    method : str
        ``"wilson"`` or ``"clopper-pearson"``.
    """

    successes: np.ndarray | int
    trials: int
    estimate: np.ndarray | float
    low: np.ndarray | float
    high: np.ndarray | float
    confidence: float
    method: str

    @property
    def half_width(self):
        """Half the interval's width, the ± figure quoted in prose."""
        return (np.asarray(self.high) - np.asarray(self.low)) / 2

    def contains(self, value) -> np.ndarray | bool:
        """Whether `value` lies in the interval (element-wise)."""
        out = (np.asarray(self.low) <= value) & (value <= np.asarray(self.high))
        return bool(out) if np.ndim(out) == 0 else out

    def agrees(self, exact, *, sigmas: float = 5.0) -> bool:
        """Whether every estimate lies within `sigmas` binomial standard errors of `exact`.

        The standard error is that of the *exact* proportion, so an exact value
        of 0 or 1 demands an estimate of exactly 0 or 1.
        """
        exact = _as_exact(exact, np.shape(self.estimate))
        if np.any((exact < 0) | (exact > 1)):
            raise ValueError(f"`exact` must be a probability in [0, 1]; received {describe(exact)}")
        tol = binomial_tolerance(exact, self.trials, sigmas=_as_sigmas(sigmas))
        return bool(np.all(np.abs(np.asarray(self.estimate) - exact) <= tol))

    def format(self, index=None, *, digits: int = 3) -> str:
        """``'0.627 [0.625, 0.629]'`` for prose (entry `index` of a vector result)."""
        return _format(self, index, digits)

    def __str__(self) -> str:
        name = "Wilson" if self.method == "wilson" else "Clopper-Pearson"
        return (f"{_fmt(self.estimate)} [{_fmt(self.low)}, {_fmt(self.high)}] "
                f"(n={self.trials}, {self.confidence:.0%} {name})")


@dataclass(frozen=True)
class MeanEstimate:
    """A Monte-Carlo mean with a Student-t confidence interval.

    Attributes
    ----------
    estimate : numpy.ndarray or float
        Sample mean.
    std_error : numpy.ndarray or float
        Standard error of the mean.
    low, high : numpy.ndarray or float
        Confidence limits.
    trials : int
        Number of samples.
    confidence : float
        Coverage of the interval.
    """

    estimate: np.ndarray | float
    std_error: np.ndarray | float
    low: np.ndarray | float
    high: np.ndarray | float
    trials: int
    confidence: float

    def contains(self, value) -> np.ndarray | bool:
        """Whether `value` lies in the interval (element-wise)."""
        out = (np.asarray(self.low) <= value) & (value <= np.asarray(self.high))
        return bool(out) if np.ndim(out) == 0 else out

    def agrees(self, exact, *, sigmas: float = 5.0) -> bool:
        """Whether every estimate lies within `sigmas` standard errors of `exact`."""
        exact = _as_exact(exact, np.shape(self.estimate))
        diff = np.abs(np.asarray(self.estimate) - exact)
        return bool(np.all(diff <= _as_sigmas(sigmas) * np.asarray(self.std_error)))

    def format(self, index=None, *, digits: int = 3) -> str:
        """``'2.005 [1.990, 2.019]'`` for prose (entry `index` of a vector result)."""
        return _format(self, index, digits)

    def __str__(self) -> str:
        return (f"{_fmt(self.estimate)} [{_fmt(self.low)}, {_fmt(self.high)}] "
                f"(n={self.trials}, {self.confidence:.0%} t-interval)")


def proportion(successes, trials, *, confidence: float = 0.95,
               method: str = "wilson") -> Proportion:
    r"""Estimate a probability from Monte-Carlo counts, with a confidence interval.

    Parameters
    ----------
    successes : int or array_like of int, or array_like of bool
        Either counts of successes (integers in ``[0, trials]``), or an array
        of booleans whose last axis holds the individual trials (then
        `trials` must be ``None``).
    trials : int or None
        Number of trials.
    confidence : float, optional
        Coverage of the interval, in (0, 1). Default 0.95.
    method : {"wilson", "clopper-pearson"}, optional
        Wilson score interval (default; close to nominal coverage, never
        outside [0, 1]) or the conservative Clopper–Pearson interval.

    Returns
    -------
    Proportion

    Raises
    ------
    ValueError
        If counts are negative, exceed `trials`, or `confidence` is not in (0, 1).

    Notes
    -----
    With :math:`\hat p = k/n` and :math:`z = \Phi^{-1}((1+c)/2)` the Wilson
    interval is

    .. math::

        \frac{\hat p + z^2/(2n) \pm z\sqrt{\hat p(1-\hat p)/n + z^2/(4n^2)}}{1 + z^2/n}.

    The Clopper–Pearson limits are beta quantiles,
    :math:`B^{-1}(\alpha/2; k, n-k+1)` and :math:`B^{-1}(1-\alpha/2; k+1, n-k)`.

    Examples
    --------
    >>> p = proportion(95, 100)
    >>> print(p)
    0.9500 [0.8883, 0.9785] (n=100, 95% Wilson)
    >>> proportion(np.array([True, False, True, True]), None).estimate
    0.75
    """
    confidence = as_float(as_probability(confidence, "confidence"), "confidence")
    method = as_choice(method, "method", ("wilson", "clopper-pearson"))
    if trials is None:
        try:
            arr = np.asarray(successes)
        except ValueError:
            arr = np.asarray(None)
        if arr.dtype != bool or arr.ndim < 1 or arr.shape[-1] == 0:
            raise ValueError(
                "with `trials=None`, `successes` must be a non-empty boolean array whose last "
                f"axis holds the trials; received dtype {arr.dtype} with shape {arr.shape}"
            )
        n = arr.shape[-1]
        k = arr.sum(axis=-1)
    else:
        n = as_int(trials, "trials", minimum=1)
        k = as_float_array(successes, "successes")
        if np.any(k < 0) or np.any(k > n) or np.any(k != np.round(k)):
            raise ValueError(
                f"`successes` must be integer counts in [0, trials={n}]; received {successes!r}"
            )
    k = np.asarray(k, dtype=float)
    p = k / n
    alpha = 1.0 - confidence
    if method == "wilson":
        z = stats.norm.ppf(1 - alpha / 2)
        denom = 1 + z**2 / n
        centre = (p + z**2 / (2 * n)) / denom
        half = z * np.sqrt(p * (1 - p) / n + z**2 / (4 * n**2)) / denom
        # exact limits at the boundaries (rounding would leave them a hair off)
        low = np.where(k == 0, 0.0, np.clip(centre - half, 0, 1))
        high = np.where(k == n, 1.0, np.clip(centre + half, 0, 1))
    else:
        with np.errstate(invalid="ignore"):
            low = np.where(k > 0, stats.beta.ppf(alpha / 2, k, n - k + 1), 0.0)
            high = np.where(k < n, stats.beta.ppf(1 - alpha / 2, k + 1, n - k), 1.0)

    k_out = int(k) if np.ndim(k) == 0 else k.astype(int)
    return Proportion(k_out, n, unwrap(p), unwrap(low), unwrap(high), confidence, method)


def mean(samples, *, axis: int = -1, confidence: float = 0.95) -> MeanEstimate:
    """Monte-Carlo mean with a Student-t confidence interval.

    Parameters
    ----------
    samples : array_like
        Finite samples; the trials run along `axis` (at least 2 of them).
    axis : int, optional
        Axis holding the trials (default: the last).
    confidence : float, optional
        Coverage of the interval, in (0, 1).

    Returns
    -------
    MeanEstimate

    Examples
    --------
    >>> m = mean([1.0, 2.0, 3.0, 4.0])
    >>> round(m.estimate, 3), round(m.std_error, 4)
    (2.5, 0.6455)
    """
    x = as_float_array(samples, "samples", ndim_min=1)
    confidence = as_float(as_probability(confidence, "confidence"), "confidence")
    axis = as_int(axis, "axis", minimum=-x.ndim, maximum=x.ndim - 1)
    n = x.shape[axis]
    if n < 2:
        raise ValueError(f"`samples` needs at least 2 trials along axis {axis}; received {n}")
    m = x.mean(axis=axis)
    se = x.std(axis=axis, ddof=1) / np.sqrt(n)
    t = stats.t.ppf(0.5 + confidence / 2, df=n - 1)

    return MeanEstimate(unwrap(m), unwrap(se), unwrap(m - t * se), unwrap(m + t * se), n,
                        confidence)


def binomial_tolerance(p, trials, *, sigmas: float = 5.0):
    r"""Tolerance for comparing a Monte-Carlo proportion with its exact value.

    ``sigmas`` standard errors of a binomial proportion, :math:`s\sqrt{p(1-p)/n}`;
    statistical tests use it so a correct implementation fails with
    probability below about 6e-7 (at 5 sigma) while a wrong one is caught.

    Examples
    --------
    >>> round(binomial_tolerance(0.5, 10_000), 4)
    0.025
    """
    p = as_probability(p, "p", open_interval=False)
    n = as_int(trials, "trials", minimum=1)
    tol = _as_sigmas(sigmas) * np.sqrt(p * (1 - p) / n)
    return float(tol) if np.ndim(tol) == 0 else tol


# ----------------------------------------------------------------------------
# Sweeps over a parameter grid, locally or on a Dask cluster
# ----------------------------------------------------------------------------

#: Trials seeded together: the unit of randomness of :func:`sweep`. Trials
#: ``[j * SEED_BLOCK, (j + 1) * SEED_BLOCK)`` of grid point ``i`` are drawn from
#: their own generator, whatever task runs them (the last unit may be shorter).
SEED_BLOCK = 1024

#: Default trials per task of :func:`sweep` (16 seed units).
DEFAULT_BLOCK = 16 * SEED_BLOCK

#: Most grid points one :func:`sweep` call accepts (each point is a dict held
#: in the result; split larger grids into several sweeps).
MAX_POINTS = 100_000

#: Environment variable that forces the progress bar of :func:`sweep` on
#: (``"1"``) or off (``"0"``) when ``progress=None``.
PROGRESS_ENV = "RADARFUSION_PROGRESS"

_NUMERIC_KINDS = "biufc"


class SweepError(RuntimeError):
    """The experiment of a :func:`sweep` failed, or returned something unusable, at one
    grid point and block of trials; no partial result is returned."""


@dataclass(frozen=True, eq=False)
class SweepResult:
    """The per-trial results of :func:`sweep`, in grid order and trial order.

    Attributes
    ----------
    points : tuple of dict
        The grid points, in the order of the first axis of every output.
    names : tuple of str
        The grid's parameter names.
    grid_shape : tuple of int or None
        Shape of the Cartesian grid (one length per name) when the grid was a
        mapping; ``None`` for a list of points.
    outputs : Mapping of str to numpy.ndarray
        Read-only arrays of shape ``(points, trials, ...)``: the experiment's
        per-trial results concatenated in trial order. An experiment that
        returns a bare array has the single output ``"value"``.
    trials : int
        Trials per grid point.
    block : int
        Trials per task (a multiple of :data:`SEED_BLOCK`).
    seed_block : int
        Trials per seed unit (:data:`SEED_BLOCK` when the sweep ran).
    entropy : int or tuple of int
        Entropy of the root :class:`numpy.random.SeedSequence`; with
        `spawn_key` it reproduces the sweep exactly (pass
        ``SeedSequence(entropy, spawn_key=spawn_key)`` as `rng`).
    spawn_key : tuple of int
        Spawn key of the root sequence (empty unless a spawned SeedSequence was passed).
    tasks : int
        Number of tasks (grid points × blocks).
    wall_time : float
        Seconds the sweep took, from validation to the last result.
    backend : str
        ``"local"`` or ``"dask (<n> workers)"``: where it ran (the outputs do not
        depend on it).
    """

    points: tuple
    names: tuple
    grid_shape: tuple | None
    outputs: Mapping
    trials: int
    block: int
    seed_block: int
    entropy: int | Sequence[int] | None  # as numpy types SeedSequence.entropy
    spawn_key: tuple
    tasks: int
    wall_time: float
    backend: str

    def __getitem__(self, name: str) -> np.ndarray:
        """The output `name`, shape ``(points, trials, ...)``."""
        if name not in self.outputs:
            raise KeyError(f"no output {name!r}; the experiment returned "
                           f"{', '.join(map(repr, self.outputs))}")
        return self.outputs[name]

    def _only(self, name):
        if name is None:
            if len(self.outputs) != 1:
                raise ValueError(f"`name` is required: the experiment returned several "
                                 f"outputs ({', '.join(map(repr, self.outputs))})")
            name = next(iter(self.outputs))
        return self[name]

    @property
    def value(self) -> np.ndarray:
        """The single output, shape ``(points, trials, ...)`` (an error if there are several)."""
        return self._only(None)

    def param(self, name: str) -> np.ndarray:
        """The value of grid parameter `name` at every point, in point order."""
        if name not in self.names:
            raise KeyError(f"no grid parameter {name!r}; the grid has {self.names}")
        return np.array([p[name] for p in self.points])

    def on_grid(self, name: str | None = None) -> np.ndarray:
        """An output reshaped to ``grid_shape + (trials, ...)`` (Cartesian grids only)."""
        arr = self._only(name)
        if self.grid_shape is None:
            raise ValueError("`on_grid` needs a Cartesian grid (a mapping of axes); this sweep "
                             "ran over a list of points: use the `(points, trials, ...)` arrays")
        return arr.reshape(self.grid_shape + arr.shape[1:])

    def map(self, fn: Callable, name: str | None = None) -> np.ndarray:
        """``fn`` applied to each point's results (shape ``(trials, ...)``), stacked.

        Examples
        --------
        >>> res = sweep(lambda p, n, rng: rng.normal(p["mu"], 1.0, n), {"mu": [0.0, 5.0]},
        ...             trials=2048, rng=1)
        >>> res.map(np.mean).round(1)
        array([0., 5.])
        """
        if not callable(fn):
            raise TypeError(f"`fn` must be callable; received {describe(fn)}")
        arr = self._only(name)
        return np.asarray([fn(a) for a in arr])

    def identical(self, other: SweepResult) -> bool:
        """Bit-for-bit equality with another sweep: same points, outputs, dtypes and trials."""
        if not isinstance(other, SweepResult):
            raise TypeError(f"`other` must be a SweepResult; received {describe(other)}")
        if (self.points != other.points or self.trials != other.trials
                or set(self.outputs) != set(other.outputs)):
            return False
        return all(a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
                   for a, b in ((self.outputs[k], other.outputs[k]) for k in self.outputs))

    def __repr__(self) -> str:
        outs = ", ".join(f"{k}: {v.dtype}{list(v.shape)}" for k, v in self.outputs.items())
        return (f"SweepResult({len(self.points)} points x {self.trials} trials, {outs}; "
                f"{self.tasks} tasks of {self.block} trials, {self.backend}, "
                f"{self.wall_time:.2f} s)")


def _grid_value(v, where: str):
    """One parameter value: a finite number, a bool or a string (as a Python scalar)."""
    if isinstance(v, np.generic):
        v = v.item()
    if isinstance(v, (str, bool)):
        return v
    if isinstance(v, numbers.Real):
        if not math.isfinite(float(v)):
            raise ValueError(f"`grid` {where} must be finite; received {v!r}")
        return v
    raise TypeError(f"`grid` {where} must be a number, a bool or a string; "
                    f"received {describe(v)}")


def _is_1d(values) -> bool:
    if isinstance(values, np.ndarray):
        return values.ndim == 1
    return not any(isinstance(v, (list, tuple, np.ndarray, Mapping, set)) for v in values)


def _as_grid(grid):
    """``(points, names, grid_shape)`` from a mapping of 1-D axes or a sequence of dicts."""
    if isinstance(grid, Mapping):
        if not grid:
            raise ValueError("`grid` must have at least one axis; received an empty mapping")
        names, axes = [], []
        for key, values in grid.items():
            if not isinstance(key, str) or not key:
                raise TypeError(f"`grid` keys must be non-empty parameter names (str); "
                                f"received {key!r}")
            if isinstance(values, (str, bytes, Mapping)) or not hasattr(values, "__len__"):
                raise TypeError(f"`grid` axis {key!r} must be a 1-D sequence of values; "
                                f"received {describe(values)}")
            if not _is_1d(values):
                raise ValueError(f"`grid` axis {key!r} must be 1-D; received {describe(values)}")
            if len(values) == 0:
                raise ValueError(f"`grid` axis {key!r} is empty; every axis needs at least one "
                                 "value")
            axes.append([_grid_value(v, f"axis {key!r}") for v in values])
            names.append(key)
        shape = tuple(len(a) for a in axes)
        check_size(math.prod(shape), MAX_POINTS, what="grid points",
                   alternative="several sweeps over slices of the grid")
        points = tuple(dict(zip(names, combo, strict=True)) for combo in itertools.product(*axes))
        return points, tuple(names), shape
    if isinstance(grid, Sequence) and not isinstance(grid, (str, bytes)):
        if len(grid) == 0:
            raise ValueError("`grid` must hold at least one point; received an empty sequence")
        check_size(len(grid), MAX_POINTS, what="grid points",
                   alternative="several sweeps over slices of the grid")
        rows: list[dict] = []
        first: tuple | None = None
        for k, point in enumerate(grid):
            if not isinstance(point, Mapping) or not point:
                raise TypeError(f"`grid` point {k} must be a non-empty dict of parameters; "
                                f"received {describe(point)}")
            keys = tuple(point)
            if any(not isinstance(n, str) or not n for n in keys):
                raise TypeError(f"`grid` point {k} must have str parameter names; "
                                f"received {keys!r}")
            if first is None:
                first = keys
            elif set(keys) != set(first):
                raise ValueError(f"`grid` point {k} has parameters {keys}, point 0 has {first}; "
                                 "every point needs the same names")
            rows.append({n: _grid_value(point[n], f"point {k}, {n!r},") for n in first})
        return tuple(rows), first, None
    raise TypeError("`grid` must be a mapping of parameter names to 1-D sequences of values, "
                    f"or a sequence of dicts; received {describe(grid)}")


def unit_rng(root, point, unit) -> np.random.Generator:
    """The generator of seed unit `unit` of grid point `point` in a sweep seeded with `root`.

    A PCG64 (pinned, not ``default_rng``'s choice) on the SeedSequence that
    ``root.spawn(points)[point].spawn(units)[unit]`` would give, built directly from
    its spawn key so that no state is shared between tasks (`root` is not advanced).

    Parameters
    ----------
    root : numpy.random.SeedSequence
        The sweep's root sequence: its `rng` after the seed conversion
        (``SeedSequence(result.entropy, spawn_key=result.spawn_key)`` for a
        :class:`SweepResult` ``result``).
    point, unit : int
        The grid point's index and the seed unit's index (≥ 0); unit `unit`
        holds trials ``unit * SEED_BLOCK`` up to ``(unit + 1) * SEED_BLOCK``.

    Examples
    --------
    >>> root = np.random.SeedSequence(7)
    >>> spawned = np.random.SeedSequence(7).spawn(2)[1].spawn(3)[2]
    >>> unit_rng(root, 1, 2).random() == np.random.Generator(np.random.PCG64(spawned)).random()
    True
    """
    root, point, unit = _unit_rng_iv(root, point, unit)
    seq = np.random.SeedSequence(root.entropy, spawn_key=(*root.spawn_key, point, unit),
                                 pool_size=root.pool_size)
    return np.random.Generator(np.random.PCG64(seq))


def _unit_rng_iv(root, point, unit) -> tuple[np.random.SeedSequence, int, int]:
    """Validate :func:`unit_rng`'s arguments."""
    if not isinstance(root, np.random.SeedSequence):
        raise TypeError("`root` must be a numpy.random.SeedSequence (the sweep's root); "
                        f"received {describe(root)}")
    return root, as_int(point, "point", minimum=0), as_int(unit, "unit", minimum=0)


def _as_outputs(out, n: int) -> dict:
    """Validate one call's result: an array, or a dict of arrays, first axis ``n``."""
    if isinstance(out, Mapping):
        if not out:
            raise TypeError("`experiment` returned an empty dict")
        items = list(out.items())
    else:
        items = [("value", out)]
    result = {}
    for key, value in items:
        if not isinstance(key, str):
            raise TypeError(f"`experiment` output names must be str; received {key!r}")
        if not isinstance(value, (np.ndarray, np.generic, list, tuple)):
            raise TypeError(f"`experiment` must return an array (or a dict of arrays) whose "
                            f"first axis holds the trials; output {key!r} is {describe(value)}")
        arr = np.asarray(value)
        if arr.dtype.kind not in _NUMERIC_KINDS:
            raise TypeError(f"`experiment` output {key!r} must be numeric or bool; received "
                            f"dtype {arr.dtype}")
        if arr.ndim == 0 or arr.shape[0] != n:
            raise ValueError(f"`experiment` output {key!r} must have the trials on its first "
                             f"axis ({n} of them); received shape {arr.shape}")
        if arr.dtype.kind in "fc" and not np.all(np.isfinite(arr)):
            raise ValueError(f"`experiment` output {key!r} holds NaN or inf")
        result[key] = arr
    return result


def _run_task(params, point, units, *, experiment, trials, root):
    """One task: seed units `units` of grid point `point`, concatenated in trial order.

    Module-level (picklable), so a Dask worker runs exactly what the local path runs.
    """
    parts = []
    for unit in units:
        start = unit * SEED_BLOCK
        n = min(SEED_BLOCK, trials - start)
        rng = unit_rng(root, point, unit)
        parts.append(_as_outputs(experiment(dict(params), n, rng), n))
    first = parts[0]
    for part in parts[1:]:
        _same_layout(first, part)
    return {k: (np.concatenate([p[k] for p in parts]) if len(parts) > 1 else first[k])
            for k in first}


def _same_layout(ref: dict, got: dict) -> None:
    """Every call of the experiment returns the same outputs, dtypes and trailing shapes."""
    if list(got) != list(ref):
        raise TypeError(f"`experiment` returned outputs {list(got)}, earlier calls {list(ref)}")
    for k in ref:
        a, b = ref[k], got[k]
        if a.dtype != b.dtype or a.shape[1:] != b.shape[1:]:
            raise TypeError(f"`experiment` output {k!r} is {b.dtype} {b.shape[1:]} per trial "
                            f"here and {a.dtype} {a.shape[1:]} in earlier calls")


def _schedule(tasks: list) -> list:
    """Order in which the local path runs the tasks (a hook the tests permute)."""
    return tasks


def _live_notebook() -> bool:
    """A kernel started by a Jupyter server for an open notebook (not nbclient/a build).

    Jupyter Server sets ``JPY_SESSION_NAME`` in the environment of the kernels it
    starts for a notebook session; nbclient (``jupyter-book build``, the tests)
    does not.
    """
    if "JPY_SESSION_NAME" not in os.environ:
        return False
    ipython = sys.modules.get("IPython")
    shell = ipython.get_ipython() if ipython is not None else None
    return type(shell).__name__ == "ZMQInteractiveShell"


def _want_progress(progress) -> bool:
    """Whether to draw the bar; asked for (True, or the variable at "1") it needs tqdm."""
    if progress is None:
        env = os.environ.get(PROGRESS_ENV, "").strip()
        if env in ("0", "1"):
            progress = env == "1"
        else:                        # automatic: never fails for want of the progress extra
            return _live_notebook() and available("tqdm.auto")
    if as_bool(progress, "progress"):
        require("tqdm.auto", feature="sweep's progress bar")
        return True
    return False


class _NoBar:
    def update(self, n=1):
        pass

    def close(self):
        pass


def _bar(show: bool, total: int, backend: str):
    if not show:
        return _NoBar()
    tqdm = require("tqdm.auto", feature="sweep's progress bar").tqdm
    return tqdm(total=total, desc=f"sweep ({backend})", unit="task")


def as_client(client, *, feature="sweep(client=...)"):
    """A running ``distributed.Client`` with at least one worker, and its worker count.

    Parameters
    ----------
    client : distributed.Client
        The cluster's client.
    feature : str, optional
        What needs the client, for the message when dask.distributed is not installed.

    Returns
    -------
    client : distributed.Client
    workers : int
        Its number of workers (at least one).

    Raises
    ------
    TypeError
        `client` not a ``distributed.Client``.
    ValueError
        `client` closed, unable to reach its scheduler, or without workers.
    ImportError
        dask.distributed not installed (naming the extra).
    """
    Client = require("distributed", feature=feature).Client
    if not isinstance(client, Client):
        raise TypeError("`client` must be None (run here) or a distributed.Client; received "
                        f"{describe(client)}")
    if client.status != "running":
        raise ValueError(f"`client` must be a running distributed.Client; its status is "
                         f"{client.status!r} (closed or not connected to its scheduler: "
                         "create a new Client with the scheduler address)")
    try:
        workers = len(client.nthreads())
    except (OSError, TimeoutError) as exc:
        raise ValueError(f"`client` cannot reach its scheduler ({type(exc).__name__}: {exc}); "
                         "check the scheduler address") from None
    if workers == 0:
        raise ValueError("`client` has no workers: start some (dask worker <scheduler address>) "
                         "or wait for them with client.wait_for_workers(n)")
    return client, workers


def _limit_trials(points: int, trials: int) -> None:
    """Refuse `trials` whose results cannot fit, before any task exists."""
    try:
        check_size(points * trials, MEMORY_LIMIT,
                   what=f"bytes at least of per-trial results ({points} grid points x "
                        f"{trials} trials x 1 byte)",
                   alternative="fewer `trials` per call (separate sweeps with separate "
                               "seeds, combined afterwards) or a reduction inside `experiment`")
    except ValueError as exc:
        raise ValueError(f"`trials`: {exc}") from None


def sweep(experiment: Callable, grid, *, trials: int, rng, block: int = DEFAULT_BLOCK,
          client=None, progress: bool | None = None) -> SweepResult:
    r"""Run a vectorized experiment over a parameter grid, here or on a Dask cluster.

    The trials of each grid point are cut into seed units of :data:`SEED_BLOCK`
    trials, each with its own generator spawned from one root
    :class:`numpy.random.SeedSequence`; a task runs ``block`` trials (a whole
    number of units). The results therefore depend only on the seed, the grid
    and `trials`: not on `block`, on `client`, on the number of workers, nor
    on the order in which tasks finish.

    Parameters
    ----------
    experiment : callable
        ``experiment(params, n, rng)``: `params` is a dict (one grid point), `n`
        the number of trials to run, `rng` a :class:`numpy.random.Generator` to
        draw them from. It returns the per-trial results, vectorized over the
        trials: an array whose first axis has length `n`, or a dict of such
        arrays (numeric or bool; NaN and inf refused). Each call gets at most
        :data:`SEED_BLOCK` trials. On a cluster it must be picklable (functions
        defined in a notebook are sent by value).
    grid : mapping or sequence of dict
        Either a mapping from parameter names to 1-D sequences of values — the
        grid is their Cartesian product, the last axis varying fastest — or a
        sequence of dicts, one per point, all with the same names. Values are
        finite numbers, bools or strings. At most :data:`MAX_POINTS` points.
    trials : int
        Trials per grid point (≥ 1).
    rng : None, int, numpy.random.SeedSequence or numpy.random.Generator
        The seed (SPEC 7), converted by
        :func:`radarfusion_ref.engine.validation.as_seed_sequence`. A
        non-negative int or a SeedSequence is used as is (a SeedSequence is not
        advanced: the same one gives the same sweep). A Generator is not shared
        with the tasks: 128 bits drawn from it become the root entropy (this
        advances it, like any draw). ``None`` draws fresh
        entropy from the operating system; it is kept in the result
        (``entropy``), so the sweep can be repeated.
    block : int, optional
        Trials per task, a positive multiple of :data:`SEED_BLOCK` (default
        :data:`DEFAULT_BLOCK`). Larger blocks mean fewer, longer tasks; the
        results do not depend on it.
    client : distributed.Client, optional
        ``None`` runs every task here, one after the other. A running
        ``distributed.Client`` runs one task per (grid point, block) on its
        cluster and gathers the results in grid and trial order.
    progress : bool or None, optional
        Show a tqdm progress bar (``tqdm.auto``: a notebook bar in a kernel;
        ``True`` needs the ``progress`` extra). ``None`` (default): on only in a
        live notebook — a kernel started by a Jupyter server for an open notebook
        (``JPY_SESSION_NAME`` is set) — and only if tqdm is installed; never in a
        book build, nbclient run or test. The environment variable
        :data:`PROGRESS_ENV` set to ``"1"`` or ``"0"`` overrides this as
        ``True`` or ``False`` would.

    Returns
    -------
    SweepResult
        Per-trial outputs shaped ``(points, trials, ...)``, the grid, the seed and
        the wall time.

    Raises
    ------
    TypeError
        If `experiment` is not callable, `grid` is not a mapping or a sequence of
        dicts (or holds values that are not numbers, bools or strings), `trials`
        or `block` is not an integer, `rng` is not a seed, `client` is not a
        ``distributed.Client`` or `progress` is not a bool.
    ValueError
        If a `grid` axis is empty, not 1-D or holds NaN/inf, the grid is empty or
        exceeds :data:`MAX_POINTS`; `trials` < 1; `block` is not a positive
        multiple of :data:`SEED_BLOCK`; grid points × `trials` exceeds
        :data:`~radarfusion_ref.engine.validation.MEMORY_LIMIT` (each trial's
        result takes at least a byte; refused before any task is built);
        `client` is closed, cannot reach its scheduler or has no workers; or the outputs (points × trials × bytes
        per trial, known after the first task) would exceed
        :data:`~radarfusion_ref.engine.validation.MEMORY_LIMIT` — refused before they
        are allocated.
    ImportError
        If `progress` asks for the bar and tqdm is not installed, or `client` is
        given and dask.distributed is not (the message names the extra to install).
    SweepError
        If the experiment raises, or returns something other than the per-trial
        arrays described above, at some grid point and block: the message names
        both, the original exception is chained, and nothing is returned (on a
        cluster, when several tasks fail, the first failure to arrive is named
        and the remaining tasks are cancelled).

    Notes
    -----
    Seed unit :math:`j` (trials :math:`j n_u, \dots, (j+1) n_u - 1`, :math:`n_u` =
    :data:`SEED_BLOCK`) of grid point :math:`i` draws from :func:`unit_rng`,
    ``Generator(PCG64(SeedSequence(entropy, spawn_key=spawn_key + (i, j))))``:
    the sequence ``root.spawn(points)[i].spawn(units)[j]`` would give, built
    directly so no state is shared between tasks. (Do not also use the
    children a passed SeedSequence spawns elsewhere.) A task is a pure function
    of ``(experiment, params, i, its units)``, so where and when it runs
    cannot change its bits; the results are written into place by
    ``(i, j)``, so the order tasks finish in cannot either.

    The first task runs alone; its output size per trial fixes the total
    size, which is checked against the memory limit before the output
    arrays are allocated and the other tasks are started.

    Examples
    --------
    >>> def coin(params, n, rng):
    ...     return rng.random(n) < params["p"]
    >>> res = sweep(coin, {"p": [0.25, 0.5]}, trials=4096, rng=7)
    >>> res.value.shape, res.value.dtype
    ((2, 4096), dtype('bool'))
    >>> res.identical(sweep(coin, {"p": [0.25, 0.5]}, trials=4096, rng=7, block=1024))
    True
    """
    start_time = time.perf_counter()
    if not callable(experiment):
        raise TypeError(f"`experiment` must be a callable experiment(params, n, rng); "
                        f"received {describe(experiment)}")
    points, names, grid_shape = _as_grid(grid)
    trials = as_int(trials, "trials", minimum=1)
    block = as_int(block, "block", minimum=1)
    if block % SEED_BLOCK:
        raise ValueError(f"`block` must be a positive multiple of SEED_BLOCK = {SEED_BLOCK} "
                         f"trials (the seed unit); received {block} (use "
                         f"{max(1, round(block / SEED_BLOCK)) * SEED_BLOCK})")
    root = as_seed_sequence(rng)
    show = _want_progress(progress)
    if client is not None:
        client, workers = as_client(client)
        backend = f"dask ({workers} workers)"
    else:
        backend = "local"

    _limit_trials(len(points), trials)
    n_units = -(-trials // SEED_BLOCK)
    per_task = block // SEED_BLOCK
    tasks = [(i, b, tuple(range(b * per_task, min((b + 1) * per_task, n_units))))
             for i in range(len(points)) for b in range(-(-n_units // per_task))]

    def failed(task, exc):
        i, b, units = task
        lo, hi = units[0] * SEED_BLOCK, min((units[-1] + 1) * SEED_BLOCK, trials)
        return SweepError(f"`experiment` failed at grid point {i} {points[i]}, block {b} "
                          f"(trials {lo}..{hi - 1}): {type(exc).__name__}: {exc}")

    outputs: dict[str, np.ndarray] = {}
    layout: dict = {}

    def place(task, result):
        i, _, units = task
        if not outputs:
            per_trial = sum(a.nbytes // a.shape[0] if a.shape[0] else
                            a.dtype.itemsize * math.prod(a.shape[1:]) for a in result.values())
            check_size(len(points) * trials * per_trial, MEMORY_LIMIT,
                       what="bytes of per-trial results (points x trials x "
                            f"{per_trial} bytes per trial)",
                       alternative="a reduction inside `experiment` (return per-trial "
                                   "summaries, not whole scenes) or fewer `trials` per call")
            for k, a in result.items():
                outputs[k] = np.empty((len(points), trials, *a.shape[1:]), dtype=a.dtype)
            layout.update(result)
        try:
            _same_layout(layout, result)
        except TypeError as exc:
            raise failed(task, exc) from exc
        lo = units[0] * SEED_BLOCK
        for k, a in result.items():
            outputs[k][i, lo:lo + a.shape[0]] = a

    bar = _bar(show, len(tasks), backend)
    try:
        if client is None:
            for task in _schedule(tasks):
                i, _, units = task
                try:
                    result = _run_task(points[i], i, units, experiment=experiment,
                                       trials=trials, root=root)
                except Exception as exc:
                    raise failed(task, exc) from exc
                place(task, result)
                bar.update()
        else:
            _run_on_cluster(client, experiment, points, tasks, trials, root, place, failed, bar)
    finally:
        bar.close()

    for a in outputs.values():
        a.flags.writeable = False
    return SweepResult(points, names, grid_shape, MappingProxyType(outputs), trials, block,
                       SEED_BLOCK, root.entropy, tuple(root.spawn_key), len(tasks),
                       time.perf_counter() - start_time, backend)


def _run_on_cluster(client, experiment, points, tasks, trials, root, place, failed, bar):
    """Run the first task, check the output size, then map the rest; place as they finish."""
    from distributed import as_completed

    shared = {"experiment": experiment, "trials": trials, "root": root}

    def submit(batch):
        return client.map(_run_task, [points[i] for i, _, _ in batch],
                          [i for i, _, _ in batch], [u for _, _, u in batch],
                          pure=False, **shared)

    def settle(batch):
        """Place the finished futures of `batch` (fetched in one gather), or raise."""
        for future in batch:
            if future.status != "finished":
                task = pending.get(future, tasks[0])
                exc = (future.exception() if future.status == "error" else
                       RuntimeError(f"the task ended with status {future.status!r}"))
                raise failed(task, exc) from exc
        for future, result in zip(batch, client.gather(batch), strict=True):
            place(pending.pop(future, tasks[0]), result)
            bar.update()

    pending: dict = {}
    settle(list(as_completed(submit(tasks[:1]))))
    pending.update(zip(submit(tasks[1:]), tasks[1:], strict=True))
    try:
        for batch in as_completed(list(pending)).batches():
            settle(batch)
    finally:
        if pending:
            client.cancel(list(pending))
