"""Monte-Carlo estimates with their confidence intervals.

Every Monte-Carlo number in the book is reported through these helpers, so it
always carries its trial count and an interval:

* :func:`proportion` — a probability estimated from ``k`` successes in ``n``
  trials, with a Wilson score or Clopper–Pearson interval;
* :func:`mean` — a mean of i.i.d. samples with a Student-t interval.

Both return frozen dataclasses whose ``str`` is the form used in the prose,
e.g. ``0.9512 [0.9469, 0.9552] (n=10000, 95% Wilson)``.

.. rubric:: References

.. [1] E. B. Wilson, "Probable inference, the law of succession, and
   statistical inference", JASA 22 (1927) 209–212.
.. [2] C. J. Clopper, E. S. Pearson, "The use of confidence or fiducial limits
   illustrated in the case of the binomial", Biometrika 26 (1934) 404–413.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from ._validation import _describe, as_choice, as_float_array, as_int, as_probability, unwrap
from .checks import CheckError, _record

__all__ = ["Proportion", "MeanEstimate", "proportion", "mean", "binomial_tolerance",
           "require", "MonteCarloCheckError"]


class MonteCarloCheckError(CheckError):
    """A Monte-Carlo estimate contradicts the exact value it was meant to confirm."""


def _as_sigmas(sigmas) -> float:
    """A tolerance in standard errors: finite, in (0, 10]."""
    if isinstance(sigmas, bool) or not isinstance(sigmas, (int, float, np.integer, np.floating)):
        raise TypeError(f"`sigmas` must be a real number; received {_describe(sigmas)}")
    s = float(sigmas)
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
            raise ValueError(f"`exact` must be a probability in [0, 1]; received {_describe(exact)}")
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
    """Estimate a probability from Monte-Carlo counts, with a confidence interval.

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
    With :math:`\\hat p = k/n` and :math:`z = \\Phi^{-1}((1+c)/2)` the Wilson
    interval is

    .. math::

        \\frac{\\hat p + z^2/(2n) \\pm z\\sqrt{\\hat p(1-\\hat p)/n + z^2/(4n^2)}}{1 + z^2/n}.

    The Clopper–Pearson limits are beta quantiles,
    :math:`B^{-1}(\\alpha/2; k, n-k+1)` and :math:`B^{-1}(1-\\alpha/2; k+1, n-k)`.

    Examples
    --------
    >>> p = proportion(95, 100)
    >>> print(p)
    0.9500 [0.8883, 0.9785] (n=100, 95% Wilson)
    >>> proportion(np.array([True, False, True, True]), None).estimate
    0.75
    """
    confidence = float(as_probability(confidence, "confidence"))
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
    confidence = float(as_probability(confidence, "confidence"))
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
    """Tolerance for comparing a Monte-Carlo proportion with its exact value.

    ``sigmas`` standard errors of a binomial proportion, :math:`s\\sqrt{p(1-p)/n}`;
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
    >>> require(proportion(480, 1000), 0.5, "a fair coin")
    >>> require(proportion(400, 1000), 0.5, "a fair coin")
    Traceback (most recent call last):
    ...
    radarfusion_ref.montecarlo.MonteCarloCheckError: a fair coin: Monte Carlo 0.4000 [0.3700, 0.4307] (n=1000, 95% Wilson) disagrees with the exact value 0.5 (5 standard errors)
    """
    if not isinstance(estimate, (Proportion, MeanEstimate)):
        raise TypeError("`estimate` must be a Proportion or a MeanEstimate; received "
                        f"{type(estimate).__name__}")
    if not isinstance(what, str) or not what.strip():
        raise TypeError(f"`what` must be a non-empty string; received {_describe(what)}")
    if not np.all(np.isfinite(np.asarray(estimate.estimate, dtype=float))):
        raise MonteCarloCheckError(f"{what}: the Monte-Carlo estimate is not finite: {estimate}")
    if not estimate.agrees(exact, sigmas=sigmas):
        raise MonteCarloCheckError(
            f"{what}: Monte Carlo {estimate} disagrees with the exact value "
            f"{np.round(exact, 6)} ({sigmas:g} standard errors)"
        )
    _record("monte-carlo", what)
