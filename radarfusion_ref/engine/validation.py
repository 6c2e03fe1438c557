r"""The doors: input validation shared by every public function of the package.

Each helper checks one argument and raises a :class:`ValueError` or
:class:`TypeError` whose message names the argument in backticks (the caller
passes its public name as `name`), states the expected form and shows what was
received. Public functions call these at their entry point, then a kernel that
trusts its input; nothing deeper in the package re-validates. Each rule is
written once, here, and every module of the package (engine, chapter modules,
book kit) and any user's own code call these functions by their public names.

.. rubric:: The rules

* numbers: :func:`as_float_array` (numeric, finite, shape), :func:`as_float` (one
  number), :func:`as_int`, :func:`as_bool`, :func:`as_positive`,
  :func:`as_probability`, :func:`as_choice`;
* the numeric domain: :func:`check_domain` (lengths of magnitude at most
  :data:`MAX_MAGNITUDE`);
* covariances: :func:`as_covariance`, the one covariance rule (square,
  finite, symmetric, variances in :math:`[2^{-150}, 2^{150}]`, positive
  definite to :data:`SINGULAR_RTOL`);
* randomness (SPEC 7): :func:`as_rng`, :func:`as_seed_sequence`;
* sizes: :func:`check_size` against :data:`MEMORY_LIMIT`, before anything is
  allocated;
* messages and results: :func:`describe` (the received value, shortened),
  :func:`broadcast`, :func:`unwrap`.
"""

from __future__ import annotations

import contextlib
import numbers
from collections.abc import Sequence

import numpy as np

__all__ = [
    "MAX_MAGNITUDE",
    "MEMORY_LIMIT",
    "SINGULAR_RTOL",
    "as_bool",
    "as_choice",
    "as_covariance",
    "as_float",
    "as_float_array",
    "as_int",
    "as_positive",
    "as_probability",
    "as_rng",
    "as_seed_sequence",
    "broadcast",
    "check_domain",
    "check_size",
    "describe",
    "unwrap",
]


def describe(value) -> str:
    """Short description of a received value, for the end of an error message.

    Small arrays are shown with their shape, larger ones by shape and dtype,
    anything else by its ``repr`` cut to 80 characters.

    Examples
    --------
    >>> describe(np.zeros((100, 3)))
    'array with shape (100, 3) and dtype float64'
    >>> describe("abc")
    "'abc'"
    """
    if isinstance(value, np.ndarray):
        if value.size <= 6:
            return f"array {np.array2string(value, precision=4)} with shape {value.shape}"
        return f"array with shape {value.shape} and dtype {value.dtype}"
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."


#: Largest working memory any single call may plan for, in bytes (about 1 GiB).
MEMORY_LIMIT = 1 << 30
#: The numeric domain: the largest magnitude of a coordinate or difference, and of a
#: variance (whose smallest accepted value is its reciprocal), :math:`2^{150}`.
MAX_MAGNITUDE = 2.0 ** 150


def check_size(requested, limit, *, what: str, alternative: str, name: str | None = None) -> int:
    """Refuse work whose size exceeds a documented limit, before anything is allocated.

    Parameters
    ----------
    requested : int
        The size the call would need (hypotheses, bins, bytes, ...). Python
        ints, so factorials do not overflow.
    limit : int
        The largest size allowed.
    what : str
        What is counted, with its unit ("hypotheses n!", "bytes of pair costs").
    alternative : str
        The scalable route to use instead.
    name : str, optional
        The public argument whose value sets the size; the message then opens with it
        in backticks.

    Raises
    ------
    ValueError
        Naming the limit, the size asked for and the alternative (and `name`).

    Examples
    --------
    >>> import math
    >>> check_size(math.factorial(12), 10**6, what="hypotheses n!",
    ...            alternative="assign_two_lists (linear assignment)")
    Traceback (most recent call last):
    ...
    ValueError: refused: 479001600 hypotheses n! requested, above the limit of 1000000; use assign_two_lists (linear assignment) instead
    >>> check_size(2**40, MEMORY_LIMIT, what="bytes", alternative="batches", name="trials")
    Traceback (most recent call last):
    ...
    ValueError: `trials`: refused: 1099511627776 bytes requested, above the limit of 1073741824; use batches instead
    """
    requested, limit = int(requested), int(limit)
    if requested > limit:
        head = "" if name is None else f"`{name}`: "
        raise ValueError(f"{head}refused: {requested} {what} requested, above the limit of "
                         f"{limit}; use {alternative} instead")
    return requested


def as_float_array(value, name: str, *, ndim_min: int = 0, allow_nonfinite: bool = False,
                   last_dims: Sequence[int | None] | None = None) -> np.ndarray:
    """Convert `value` to a float array, rejecting non-numeric input and NaN/inf.

    Parameters
    ----------
    value : array_like
        The argument as the caller passed it.
    name : str
        The argument's name, used in error messages.
    ndim_min : int, optional
        Minimum number of dimensions.
    allow_nonfinite : bool, optional
        Accept NaN and infinities (default: reject them).
    last_dims : sequence of int or None, optional
        Required sizes of the trailing axes (``None`` accepts any size).

    Returns
    -------
    numpy.ndarray
        A float64 array.

    Raises
    ------
    TypeError
        If `value` is not numeric.
    ValueError
        If it has too few dimensions, the wrong trailing shape or non-finite
        entries.

    Examples
    --------
    >>> as_float_array([1, 2], "x")
    array([1., 2.])
    >>> as_float_array([1, float("nan")], "x")
    Traceback (most recent call last):
    ...
    ValueError: `x` must be finite; received array [ 1. nan] with shape (2,) (1 non-finite entries)
    """
    if isinstance(value, (str, bytes, bool, np.bool_)) or value is None:
        raise TypeError(f"`{name}` must be a number or an array of numbers; received {describe(value)}")
    try:
        raw = value if isinstance(value, np.ndarray) else np.asarray(value)
    except (TypeError, ValueError):
        raise TypeError(
            f"`{name}` must be a number or an array of numbers; received {describe(value)}"
        ) from None
    # bools and strings (even numeric ones such as "1.5") are not numbers here
    if raw.dtype.kind not in "iuf":
        kind = {"b": "booleans", "U": "strings", "S": "bytes", "O": "objects",
                "c": "complex numbers"}.get(raw.dtype.kind, f"dtype {raw.dtype}")
        raise TypeError(
            f"`{name}` must be a number or an array of numbers (reals); received {kind}: "
            f"{describe(value)}"
        )
    arr = raw.astype(float, copy=False)
    if arr.ndim < ndim_min:
        raise ValueError(
            f"`{name}` must have at least {ndim_min} dimension(s); received {describe(arr)}"
        )
    if last_dims is not None:
        k = len(last_dims)
        tail = arr.shape[arr.ndim - k:] if k else ()
        ok = arr.ndim >= k and all(d is None or d == t for d, t in zip(last_dims, tail, strict=True))
        if not ok:
            want = "(..., " + ", ".join("n" if d is None else str(d) for d in last_dims) + ")"
            raise ValueError(f"`{name}` must have shape {want}; received shape {arr.shape}")
    if not allow_nonfinite and not np.all(np.isfinite(arr)):
        bad = int(np.count_nonzero(~np.isfinite(arr)))
        raise ValueError(
            f"`{name}` must be finite; received {describe(arr)} ({bad} non-finite entries)"
        )
    return arr


def as_positive(value, name: str, *, strict: bool = True) -> np.ndarray:
    """Float array whose entries are all > 0 (or >= 0 with ``strict=False``).

    Examples
    --------
    >>> as_positive(-1.0, "sigma")
    Traceback (most recent call last):
    ...
    ValueError: `sigma` must be > 0; received -1.0 (smallest entry -1)
    """
    arr = as_float_array(value, name)
    bad = (arr <= 0) if strict else (arr < 0)
    if np.any(bad):
        op = ">" if strict else ">="
        raise ValueError(
            f"`{name}` must be {op} 0; received {describe(value)} (smallest entry {arr.min():.6g})"
        )
    return arr


def as_probability(value, name: str, *, open_interval: bool = True) -> np.ndarray:
    """Float array of probabilities in (0, 1) (or [0, 1] with ``open_interval=False``).

    Examples
    --------
    >>> as_probability(1.5, "p_false_reject")
    Traceback (most recent call last):
    ...
    ValueError: `p_false_reject` must lie in the open interval (0, 1); received 1.5
    """
    arr = as_float_array(value, name)
    if open_interval:
        bad, text = (arr <= 0) | (arr >= 1), "the open interval (0, 1)"
    else:
        bad, text = (arr < 0) | (arr > 1), "the closed interval [0, 1]"
    if np.any(bad):
        raise ValueError(f"`{name}` must lie in {text}; received {describe(value)}")
    return arr


def as_int(value, name: str, *, minimum: int | None = None, maximum: int | None = None) -> int:
    """A Python int within ``[minimum, maximum]``; bools and floats are rejected.

    Examples
    --------
    >>> as_int(0, "dof", minimum=1)
    Traceback (most recent call last):
    ...
    ValueError: `dof` must be an integer >= 1; received 0
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"`{name}` must be an integer; received {describe(value)}")
    out = int(value)
    if (minimum is not None and out < minimum) or (maximum is not None and out > maximum):
        lo = "" if minimum is None else f" >= {minimum}"
        hi = "" if maximum is None else f" <= {maximum}"
        joint = " and" if lo and hi else ""
        raise ValueError(f"`{name}` must be an integer{lo}{joint}{hi}; received {out}")
    return out


#: The positive-definiteness rule's tolerance: every pivot of the LDL^T factorisation of a
#: covariance's correlation matrix (each variable's variance given the preceding ones, as a
#: fraction of its own variance) must exceed this. Closed under sums: if ``A`` and ``B``
#: pass, ``A + B`` passes (a conditional variance of a sum is at least the sum of theirs).
SINGULAR_RTOL = 1e-12
#: Relative tolerance of the symmetry test, against the largest entry of each matrix.
_SYMMETRY_RTOL = 1e-9


def _symmetric_mask(arr: np.ndarray) -> np.ndarray:
    """Per matrix of a ``(..., k, k)`` stack: symmetric to :data:`_SYMMETRY_RTOL` (False for NaN)."""
    k = arr.shape[-1]
    with np.errstate(invalid="ignore"):
        if k > 4:
            scale = np.max(np.abs(arr), axis=(-2, -1))
            asym = np.max(np.abs(arr - np.swapaxes(arr, -1, -2)), axis=(-2, -1))
        else:                                       # entry by entry: fast for many small matrices
            scale = np.abs(arr[..., 0, 0])
            asym = np.zeros(arr.shape[:-2])
            for i in range(k):
                for j in range(k):
                    scale = np.maximum(scale, np.abs(arr[..., i, j]))
                    if j < i:
                        asym = np.maximum(asym, np.abs(arr[..., i, j] - arr[..., j, i]))
        return asym <= _SYMMETRY_RTOL * np.maximum(scale, np.finfo(float).tiny)


def _pd_mask(arr: np.ndarray) -> np.ndarray:
    """The one positive-definiteness rule, per matrix of a ``(..., k, k)`` stack (lower triangle).

    Positive variances, and every pivot of the LDL^T factorisation of the
    correlation matrix ``R = D^-1/2 C D^-1/2`` above :data:`SINGULAR_RTOL`
    (False for NaN). Scale-free: it does not change when a coordinate changes unit.
    """
    k = arr.shape[-1]
    with np.errstate(all="ignore"):
        var = [arr[..., i, i] for i in range(k)]
        ok = np.ones(arr.shape[:-2], dtype=bool)
        for v in var:
            ok &= v > 0
        root = [np.sqrt(np.where(v > 0, v, 1.0)) for v in var]
        if k > 8:                                   # LAPACK: pivots are diag(L)^2
            r = arr / np.stack(root, -1)[..., :, None] / np.stack(root, -1)[..., None, :]
            flat = r.reshape(-1, k, k)
            diag = np.zeros((flat.shape[0], k))
            for i, m in enumerate(flat):
                with contextlib.suppress(np.linalg.LinAlgError):
                    diag[i] = np.diagonal(np.linalg.cholesky(m)) ** 2
            return ok & np.all(diag.reshape(*arr.shape[:-2], k) > SINGULAR_RTOL, axis=-1)
        low = [[arr[..., i, j] / (root[i] * root[j]) for j in range(i)] for i in range(k)]
        piv: list = []                              # D_j; low[i][j] becomes L_ij D_j
        for j in range(k):
            d = 1.0
            for m in range(j):
                d = d - low[j][m] * (low[j][m] / piv[m])
            piv.append(d)
            if j:
                ok &= d > SINGULAR_RTOL
            for i in range(j + 1, k):
                for m in range(j):
                    low[i][j] = low[i][j] - low[i][m] * (low[j][m] / piv[m])
    return ok


def _refuse_covariance(arr: np.ndarray, name: str) -> None:
    """Raise the one message of each rule a covariance stack breaks (symmetry, then definiteness)."""
    sym = _symmetric_mask(arr)
    if not np.all(sym):
        raise ValueError(f"`{name}` must be symmetric; received {describe(arr)}")
    pd = _pd_mask(arr)
    if not np.all(pd):
        bad = int(pd.size - np.count_nonzero(pd))
        raise ValueError(
            f"`{name}` must be positive definite and not singular to working precision "
            f"(every pivot of its correlation matrix above {SINGULAR_RTOL:g}); "
            f"{bad} of {pd.size} matrices are not: {describe(arr)}")


def as_covariance(value, name: str, *, dim: int | None = None, domain: bool = True) -> np.ndarray:
    r"""The one covariance rule: a stack of covariances with shape ``(..., d, d)``.

    Every covariance the package accepts passes this door, in this order:

    1. numeric and finite, at least 2-D, square (``d == dim`` when `dim` is given);
    2. symmetric to a relative tolerance (1e-9 of the largest entry of each matrix);
    3. positive definite by the package's one rule
       (:func:`radarfusion_ref.engine.linalg.is_positive_definite`): positive
       variances and every pivot of the :math:`LDL^T` factorisation of the
       correlation matrix above :data:`SINGULAR_RTOL`, so a singular or
       indefinite matrix is reported instead of producing NaN later;
    4. every variance (diagonal entry) within the numeric domain
       :math:`[2^{-150}, 2^{150}]` (:data:`MAX_MAGNITUDE`), where no
       factorisation of the package overflows or becomes subnormal — unless
       ``domain=False``: a public function whose kernel rescales its covariances
       exactly (by powers of two) and is documented and tested over the whole float
       range (the Gaussian fusion, the grouping costs, the non-assignment cost) takes
       any variance a float can hold, and refuses a result that leaves the float range.

    Parameters
    ----------
    value : array_like, shape (..., d, d)
        The argument as the caller passed it.
    name : str
        The caller's public name for it, used in error messages.
    dim : int, optional
        Required size ``d`` of the matrices.
    domain : bool, optional
        Apply rule 4, the variance domain (default). ``False`` only for a caller
        that rescales, as above.

    Returns
    -------
    numpy.ndarray, shape (..., d, d)
        A float64 array (the input itself when it already is one).

    Raises
    ------
    TypeError
        If `value` is not numeric.
    ValueError
        Naming `name`, at the first rule it breaks.

    Examples
    --------
    >>> as_covariance([[1.0, 0.0], [0.0, -1.0]], "cov")
    Traceback (most recent call last):
    ...
    ValueError: `cov` must be positive definite and not singular to working precision (every pivot of its correlation matrix above 1e-12); 1 of 1 matrices are not: array [[ 1.  0.]
     [ 0. -1.]] with shape (2, 2)
    >>> as_covariance(1e-200 * np.eye(2), "R")
    Traceback (most recent call last):
    ...
    ValueError: `R` must have every variance within the numeric domain [2**-150, 2**150] (about 7e-46 to 1.4e45); received variances from 1e-200 to 1e-200; change the unit of the coordinates
    """
    arr = as_float_array(value, name, ndim_min=2)
    if arr.shape[-1] != arr.shape[-2] or (dim is not None and arr.shape[-1] != dim):
        want = "(..., d, d)" if dim is None else f"(..., {dim}, {dim})"
        raise ValueError(f"`{name}` must have shape {want}; received shape {arr.shape}")
    if not (np.all(_symmetric_mask(arr)) and np.all(_pd_mask(arr))):
        _refuse_covariance(arr, name)
    var = np.diagonal(arr, axis1=-2, axis2=-1)
    if domain and var.size and (var.max() > MAX_MAGNITUDE or var.min() < 1.0 / MAX_MAGNITUDE):
        raise ValueError(
            f"`{name}` must have every variance within the numeric domain [2**-150, 2**150] "
            f"(about 7e-46 to 1.4e45); received variances from {var.min():.6g} to "
            f"{var.max():.6g}; change the unit of the coordinates")
    return arr


def check_domain(value, name: str) -> np.ndarray:
    r"""Lengths within the numeric domain :math:`|x| \le 2^{150}` (:data:`MAX_MAGNITUDE`).

    For coordinates, positions, ranges and their differences: a finite float
    array (as :func:`as_float_array`) whose every entry has magnitude at most
    :data:`MAX_MAGNITUDE`, refused naming `name` otherwise.

    Examples
    --------
    >>> check_domain([1.0, -2.0], "x")
    array([ 1., -2.])
    >>> check_domain([1e50], "x")
    Traceback (most recent call last):
    ...
    ValueError: `x` must lie within the numeric domain |value| <= 2**150 (about 1.4e45); received array [1.e+50] with shape (1,) (largest magnitude 1e+50); change the unit of the coordinates
    """
    arr = as_float_array(value, name)
    if arr.size and float(np.max(np.abs(arr))) > MAX_MAGNITUDE:
        raise ValueError(
            f"`{name}` must lie within the numeric domain |value| <= 2**150 (about 1.4e45); "
            f"received {describe(arr)} (largest magnitude {float(np.max(np.abs(arr))):.6g}); "
            "change the unit of the coordinates")
    return arr


def as_choice(value, name: str, choices: Sequence[str]) -> str:
    """One of a fixed set of string options.

    Examples
    --------
    >>> as_choice("exact", "kind", ("profile", "marginal"))
    Traceback (most recent call last):
    ...
    ValueError: `kind` must be one of 'profile', 'marginal'; received 'exact'
    """
    if not isinstance(value, str) or value not in choices:
        allowed = ", ".join(repr(c) for c in choices)
        raise ValueError(f"`{name}` must be one of {allowed}; received {describe(value)}")
    return value


def as_rng(rng) -> np.random.Generator:
    """The SPEC 7 convention: ``None``, a seed or a Generator → a Generator.

    A legacy :class:`numpy.random.RandomState` is refused so that no code path
    touches the global random state.

    Examples
    --------
    >>> bool(as_rng(1).integers(10) == as_rng(1).integers(10))
    True
    >>> as_rng(True)
    Traceback (most recent call last):
    ...
    TypeError: `rng` must be None, an int seed, a SeedSequence or a numpy.random.Generator; received True
    """
    if isinstance(value := rng, np.random.RandomState):
        raise TypeError(
            "`rng` must be None, an int seed, a SeedSequence or a numpy.random.Generator; "
            "received a legacy RandomState (use numpy.random.default_rng)"
        )
    if isinstance(value, (bool, np.bool_)):  # an int to numpy, but never a seed
        raise TypeError(
            "`rng` must be None, an int seed, a SeedSequence or a numpy.random.Generator; "
            f"received {describe(value)}"
        )
    try:
        return np.random.default_rng(value)
    except (TypeError, ValueError):
        raise TypeError(
            "`rng` must be None, an int seed, a SeedSequence or a numpy.random.Generator; "
            f"received {describe(value)}"
        ) from None


def as_seed_sequence(rng) -> np.random.SeedSequence:
    """The one seed conversion: ``None``, a seed, a SeedSequence or a Generator → a SeedSequence.

    ``None`` gives fresh OS entropy; a non-negative int ``s`` gives
    ``SeedSequence(s)``; a SeedSequence is used as it is; a Generator
    contributes 128 bits drawn from it (four 32-bit words, which advances it as
    any draw would), so consecutive calls with one Generator are independent and
    a seeded Generator is reproducible. Anything else — a negative int, a float,
    a legacy RandomState — is refused.

    Examples
    --------
    >>> as_seed_sequence(7).entropy
    7
    >>> as_seed_sequence(-1)
    Traceback (most recent call last):
    ...
    TypeError: `rng` must be None, a non-negative int seed, a numpy.random.SeedSequence or a numpy.random.Generator; received -1
    """
    if isinstance(rng, np.random.SeedSequence):
        return rng
    if isinstance(rng, np.random.Generator):
        return np.random.SeedSequence(rng.integers(0, 2**32, size=4, dtype=np.uint64).tolist())
    if rng is None:
        return np.random.SeedSequence()
    if isinstance(rng, numbers.Integral) and not isinstance(rng, (bool, np.bool_)) and int(rng) >= 0:
        return np.random.SeedSequence(int(rng))
    raise TypeError("`rng` must be None, a non-negative int seed, a numpy.random.SeedSequence "
                    f"or a numpy.random.Generator; received {describe(rng)}")


def as_float(value, name: str, *, allow_inf: bool = False) -> float:
    """The one "single number" check: a real given as a scalar or 0-d array → float.

    Finite unless ``allow_inf=True``, which also accepts ``+inf`` and ``-inf``
    (NaN is refused either way). Range rules stay with :func:`as_positive`,
    :func:`as_probability` and the caller (``as_float(as_positive(v, "v"), "v")``
    for a single positive number).

    Examples
    --------
    >>> as_float(np.float32(0.5), "p")
    0.5
    >>> as_float([0.01, 0.02], "p")
    Traceback (most recent call last):
    ...
    ValueError: `p` must be a single number; received array [0.01 0.02] with shape (2,)
    >>> as_float(float("inf"), "gate", allow_inf=True)
    inf
    >>> as_float(float("nan"), "gate", allow_inf=True)
    Traceback (most recent call last):
    ...
    ValueError: `gate` must be a number or +-inf, not NaN; received nan
    """
    arr = as_float_array(value, name, allow_nonfinite=allow_inf)
    if arr.ndim != 0:
        raise ValueError(f"`{name}` must be a single number; received {describe(arr)}")
    x = float(arr)
    if x != x:
        raise ValueError(f"`{name}` must be a number or +-inf, not NaN; received {describe(value)}")
    return x


def broadcast(**arrays: np.ndarray) -> tuple[np.ndarray, ...]:
    """Broadcast named arrays together, naming them all if their shapes clash.

    Examples
    --------
    >>> broadcast(x1=np.zeros(3), x2=np.zeros(2))
    Traceback (most recent call last):
    ...
    ValueError: `x1`, `x2` must broadcast to a common shape; received shapes (3,), (2,)
    """
    try:
        return tuple(np.broadcast_arrays(*arrays.values()))
    except ValueError:
        names = ", ".join(f"`{k}`" for k in arrays)
        shapes = ", ".join(str(np.shape(v)) for v in arrays.values())
        raise ValueError(
            f"{names} must broadcast to a common shape; received shapes {shapes}"
        ) from None


def unwrap(x):
    """Results of scalar input come back as Python scalars, arrays as arrays.

    Public functions pass their outputs through this, so ``f(1.0)`` is a
    ``float`` while ``f([1.0, 2.0])`` is an array.

    Examples
    --------
    >>> unwrap(np.float64(2.5)), unwrap(np.array(3)), unwrap([1, 2])
    (2.5, 3, array([1, 2]))
    """
    arr = np.asarray(x)
    return arr.item() if arr.ndim == 0 else arr


def as_bool(value, name: str) -> bool:
    """A genuine boolean (Python or numpy); numbers, strings and ``None`` are refused.

    Examples
    --------
    >>> as_bool(np.True_, "binding")
    True
    >>> as_bool("no", "binding")
    Traceback (most recent call last):
    ...
    TypeError: `binding` must be True or False; received 'no'
    """
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"`{name}` must be True or False; received {describe(value)}")
    return bool(value)
