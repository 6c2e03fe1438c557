r"""From polar reports to decisions: radar 1's frame, the quadratic form, the decision rules."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from .. import conversion
from ..engine.linalg import mahalanobis_sq_pairwise
from ..engine.scenes import PolarReports
from ..engine.validation import (
    MEMORY_LIMIT,
    as_bool,
    as_choice,
    as_float,
    as_float_array,
    as_positive,
    check_size,
    describe,
)
from ._scenario import (
    _JOINT_ALTERNATIVE,
    _METHODS,
    CORRECT,
    MAX_JOINT_PAIRINGS,
    NO_DECISION,
    WRONG,
    _joint_bytes,
)


@dataclass(frozen=True)
class CartesianReports:
    """Both radars' reports converted to Cartesian and brought to radar 1's frame.

    Attributes
    ----------
    xy1, xy2 : numpy.ndarray, shape (trials, n, 2)
        Positions (km) of radar 1's and radar 2's reports in radar 1's frame.
    cov1, cov2 : numpy.ndarray, shape (trials, n, 2, 2)
        Their error covariances as the conversion reports them (the shift to
        radar 1's frame does not change them: survey errors are neglected).
    method : str
        Conversion used for the positions.
    cov_method : str
        Conversion used for the covariances.
    """

    xy1: np.ndarray
    cov1: np.ndarray
    xy2: np.ndarray
    cov2: np.ndarray
    method: str
    cov_method: str


def _method_pair(method, cov_method) -> tuple[str, str]:
    m = as_choice(method, "method", _METHODS)
    c = m if cov_method is None else as_choice(cov_method, "cov_method", _METHODS)
    return m, c


def _convert(r, beta, sigma_r, sigma_beta, method, cov_method):
    """Positions by `method`, covariances by `cov_method` (one conversion if equal)."""
    res = conversion.polar_to_cartesian(r, beta, sigma_r, sigma_beta, method=method)
    if cov_method == method:
        return res.xy, res.cov
    res_c = conversion.polar_to_cartesian(r, beta, sigma_r, sigma_beta, method=cov_method)
    return res.xy, res_c.cov


def to_common_frame(reports: PolarReports, *, method: str = "linearized",
                    cov_method: str | None = None) -> CartesianReports:
    r"""Convert both radars' polar reports and bring them to radar 1's frame.

    Parameters
    ----------
    reports : PolarReports
        From :func:`radarfusion_ref.engine.scenes.polar_scene`.
    method : {"linearized", "additive", "multiplicative", "first_order"}, optional
        Conversion of :func:`radarfusion_ref.conversion.polar_to_cartesian`
        used for the positions.
    cov_method : same choices, optional
        Conversion whose covariance is used (default: `method`). Mixing the
        two separates the effect of position debiasing from that of the
        covariance change.

    Returns
    -------
    CartesianReports

    Raises
    ------
    ValueError
        If a method name is unknown.
    TypeError
        If `reports` is not a :class:`PolarReports`.

    Notes
    -----
    Radar 2's report, converted in its own frame, is shifted by radar 2's
    position :math:`p_2 = B(\cos\beta_0, \sin\beta_0)`:

    .. math::

        \hat x_{2j} = p_2 + \hat r_{2j}(\cos\hat\beta_{2j}, \sin\hat\beta_{2j})^T,

    with the covariance unchanged (the paper neglects survey errors).

    References
    ----------
    Prosov, eqs. (1)–(4) and the text before Table 1.

    Examples
    --------
    >>> from radarfusion_ref.engine.scenes import polar_scene
    >>> from radarfusion_ref.separated import paper_geometry
    >>> rep = polar_scene(paper_geometry(0.0, -5.0), sigma_r=0.1,
    ...                  sigma_beta=np.deg2rad(1.0), trials=2, rng=0)
    >>> cart = to_common_frame(rep)
    >>> cart.xy2.shape, cart.cov2.shape
    ((2, 2, 2), (2, 2, 2, 2))
    """
    if not isinstance(reports, PolarReports):
        raise TypeError("`reports` must be a PolarReports (from `polar_scene`); "
                        f"received {type(reports).__name__}")
    m, c = _method_pair(method, cov_method)
    sr, sb = reports.sigma_r, reports.sigma_beta
    xy1, cov1 = _convert(reports.r1, reports.beta1, sr, sb, m, c)
    xy2, cov2 = _convert(reports.r2, reports.beta2, sr, sb, m, c)
    return CartesianReports(xy1, cov1, xy2 + reports.geometry.radar2, cov2, m, c)


# --------------------------------------------------------------------------- statistic
def pair_statistic(xy1, cov1, xy2, cov2, *, return_logdet: bool = False,
                   logdet: bool = False):
    r"""The quadratic form :math:`\kappa` for every pair of radar-1 and radar-2 reports.

    Parameters
    ----------
    xy1 : array_like, shape (..., n1, 2)
        Radar 1's report positions.
    cov1 : array_like, shape (..., n1, 2, 2)
        Their covariances.
    xy2 : array_like, shape (..., n2, 2)
        Radar 2's report positions in the same frame.
    cov2 : array_like, shape (..., n2, 2, 2)
        Their covariances.
    return_logdet : bool, optional
        Also return :math:`\ln\det(\Sigma_{1i} + \Sigma_{2j})`, needed by the
        likelihood of a joint hypothesis.
    logdet : bool, optional
        False (default): the quadratic form :math:`\kappa_{ij}` (the gate's
        statistic). True: the full maximum-likelihood cost
        :math:`\kappa_{ij} + \ln\det(2\pi S_{ij})`, :math:`S_{ij} = \Sigma_{1i} +
        \Sigma_{2j}` — the same cost as
        ``radarfusion_ref.association.proximity_matrix(..., logdet=True)``, for an
        assignment solver; not a :math:`\chi^2` statistic (it may be negative), so
        not for :func:`per_report_outcome`.

    Returns
    -------
    S : numpy.ndarray, shape (..., n1, n2)
        ``S[..., i, j]`` scores report ``i`` of radar 1 against report ``j``
        of radar 2 (with ``logdet=True`` the full cost). With
        ``return_logdet=True`` a tuple ``(S, logdet)``, `logdet` being
        :math:`\ln\det(\Sigma_{1i} + \Sigma_{2j})` (without :math:`2\pi`).

    Raises
    ------
    ValueError
        If shapes do not match, entries are not finite or lie outside the engine's
        numeric domain, a covariance breaks the package's positive-definiteness rule
        (:func:`radarfusion_ref.engine.linalg.is_positive_definite`), or the pairs are
        too many for :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT`.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    .. math::

        \kappa_{ij} = (\hat x_{1i} - \hat x_{2j})^T (\Sigma_{1i} + \Sigma_{2j})^{-1}
        (\hat x_{1i} - \hat x_{2j}),

    computed for every pair by
    :func:`radarfusion_ref.engine.linalg.mahalanobis_sq_pairwise` (the package's
    one squared-Mahalanobis function: a factorisation of each sum, forward
    substitution, no inverse), batched over every leading axis.

    References
    ----------
    Prosov, the quadratic form :math:`S^{qf}_{pg}` after eq. (4).

    Examples
    --------
    >>> eye = np.eye(2)[None]
    >>> pair_statistic([[0.0, 0.0]], eye, [[2.0, 0.0]], eye)
    array([[2.]])
    >>> pair_statistic([[0.0, 0.0]], eye, [[2.0, 0.0]], eye, logdet=True).round(4)
    array([[7.062]])
    """
    a1, c1, a2, c2, with_logdet = _pair_statistic_iv(xy1, cov1, xy2, cov2,
                                                     logdet)
    # kappa_ij = (x1_i - x2_j)^T (Sigma_1i + Sigma_2j)^-1 (x1_i - x2_j)
    # for every pair i, j
    kappa, logdet_s = _pairwise_kappa(a1, c1, a2, c2)
    cost = (kappa + (2 * math.log(2 * math.pi) + logdet_s)
            if with_logdet else kappa)
    return (cost, logdet_s) if return_logdet else cost


def _pair_statistic_iv(xy1, cov1, xy2, cov2, logdet):
    """Shapes at the door; definiteness and the numeric domain are the engine's rule."""
    with_logdet = as_bool(logdet, "logdet")
    a1 = as_float_array(xy1, "xy1", ndim_min=2, last_dims=(None, 2))
    a2 = as_float_array(xy2, "xy2", ndim_min=2, last_dims=(None, 2))
    c1 = as_float_array(cov1, "cov1", ndim_min=3, last_dims=(None, 2, 2))
    c2 = as_float_array(cov2, "cov2", ndim_min=3, last_dims=(None, 2, 2))
    if c1.shape[-3] != a1.shape[-2] or c2.shape[-3] != a2.shape[-2]:
        raise ValueError("`cov1`/`cov2` must have one 2x2 matrix per report of `xy1`/`xy2`; "
                         f"received shapes {c1.shape} for {a1.shape} and {c2.shape} for "
                         f"{a2.shape}")
    return a1, c1, a2, c2, with_logdet


def _pairwise_kappa(a1, c1, a2, c2):
    """The engine's pairwise kappa and ln det, its messages naming this module's arguments."""
    try:
        return mahalanobis_sq_pairwise(a1, a2, c1, c2, return_logdet=True)
    except ValueError as exc:
        raise ValueError(str(exc).replace("`x1`", "`xy1`").replace("`x2`", "`xy2`")) from None


# --------------------------------------------------------------------------- decisions
def _as_statistic(statistic) -> np.ndarray:
    s = as_float_array(statistic, "statistic", ndim_min=2)
    if s.shape[-1] != s.shape[-2] or s.shape[-1] == 0:
        raise ValueError(f"`statistic` must have shape (..., n, n) with n >= 1; received shape "
                         f"{s.shape}")
    if np.any(s < 0):
        raise ValueError(f"`statistic` must be >= 0 (a quadratic form); received "
                         f"{describe(s)} (smallest entry {s.min():.6g})")
    return s


def per_report_outcome(statistic, threshold) -> np.ndarray:
    r"""Per-report gating decision for each report of radar 1 (Table 1's rule).

    Report ``i`` of radar 1 is compared with every report of radar 2; the
    true partner is report ``i`` (reports are in target order).

    Parameters
    ----------
    statistic : array_like, shape (..., n, n)
        :math:`\kappa` from :func:`pair_statistic`.
    threshold : float
        Gate :math:`\gamma` (a pair passes when :math:`\kappa < \gamma`).

    Returns
    -------
    numpy.ndarray of int8, shape (..., n)
        :data:`CORRECT` (only the true partner passes), :data:`WRONG` (only
        one other report passes) or :data:`NO_DECISION` (none or several pass).

    Raises
    ------
    ValueError
        If `statistic` is not a stack of square matrices of finite entries
        >= 0, or `threshold` is not one positive number.

    References
    ----------
    Prosov, definitions of :math:`\hat P_{\text{прав}}`, :math:`\hat P_{\text{ош}}`,
    :math:`\hat P_{\text{неопр}}` before Table 1.

    Examples
    --------
    >>> per_report_outcome([[1.0, 20.0], [3.0, 5.0]], 9.21)
    array([0, 2], dtype=int8)
    """
    s = _as_statistic(statistic)
    th = as_float(as_positive(threshold, "threshold"), "threshold")
    passed = s < th
    n_pass = passed.sum(axis=-1)
    true_pass = np.diagonal(passed, axis1=-2, axis2=-1)
    out = np.full(true_pass.shape, NO_DECISION, dtype=np.int8)
    single = n_pass == 1
    out[single & true_pass] = CORRECT
    out[single & ~true_pass] = WRONG
    return out


def joint_outcome(statistic, logdet=None, *, threshold=None) -> np.ndarray:
    r"""Joint (global) assignment of all reports at once: the best complete pairing.

    Parameters
    ----------
    statistic : array_like, shape (..., n, n)
        :math:`\kappa` from :func:`pair_statistic` (``n`` ≤ 7: all :math:`n!`
        pairings are enumerated).
    logdet : array_like, shape (..., n, n), optional
        :math:`\ln\det(\Sigma_{1i} + \Sigma_{2j})`; with it the rule is maximum
        likelihood, without it minimum summed :math:`\kappa`.
    threshold : float, optional
        Gate for the chosen pairing's summed :math:`\kappa` (a :math:`\chi^2(2n)`
        quantile). If given, a pairing whose sum reaches it gives
        :data:`NO_DECISION`.

    Returns
    -------
    numpy.ndarray of int8, shape (...)
        :data:`CORRECT` if the chosen pairing is the true one (identity),
        :data:`WRONG` otherwise, or :data:`NO_DECISION` (gated only).

    Raises
    ------
    ValueError
        If `statistic` is not square with finite entries >= 0, ``n!`` exceeds
        :data:`MAX_JOINT_PAIRINGS` (``n`` > 7: use
        :func:`radarfusion_ref.engine.assignment.assign_two_lists`), the work exceeds
        :data:`radarfusion_ref.engine.validation.MEMORY_LIMIT`, `logdet` has another
        shape or non-finite entries, or `threshold` is not positive.

    Notes
    -----
    For a pairing :math:`\pi` the negative log-likelihood is

    .. math::

        -2\ln L(\pi) = \sum_i \bigl[\kappa_{i\pi(i)} + \ln\det(\Sigma_{1i} + \Sigma_{2\pi(i)})\bigr]
        + 2n\ln 2\pi,

    whose last term, the same for every complete pairing, is dropped (the
    package's rule: a constant of the full :math:`-2\ln f` is dropped only
    where every hypothesis holds the same number of pairs; the per-pair cost
    ``pair_statistic(..., logdet=True)`` keeps its :math:`2\ln 2\pi`),

    and the rule picks :math:`\hat\pi = \arg\min_\pi`. Under the true
    pairing the sum of the :math:`\kappa` is :math:`\chi^2(2n)`.

    Examples
    --------
    >>> joint_outcome([[1.0, 2.0], [3.0, 5.0]])       # 1+5 > 2+3: pairing swapped
    array(1, dtype=int8)
    """
    s = _as_statistic(statistic)
    n = s.shape[-1]
    check_size(math.factorial(n), MAX_JOINT_PAIRINGS,
               what=f"pairings n! (n = {n} reports in `statistic`)", alternative=_JOINT_ALTERNATIVE)
    check_size(_joint_bytes(n, s.size // (n * n)), MEMORY_LIMIT,
               what="bytes of pairing costs for `statistic`",
               alternative="smaller batches of `statistic`")
    th = None if threshold is None else as_float(as_positive(threshold, "threshold"), "threshold")
    perms = np.array(list(itertools.permutations(range(n))))      # identity first
    rows = np.arange(n)
    sum_s = s[..., rows, perms].sum(axis=-1)                       # (..., n!)
    cost = sum_s
    if logdet is not None:
        ld = as_float_array(logdet, "logdet")
        if ld.shape != s.shape:
            raise ValueError(f"`logdet` must have the shape of `statistic` {s.shape}; "
                             f"received {ld.shape}")
        cost = sum_s + ld[..., rows, perms].sum(axis=-1)
    best = np.argmin(cost, axis=-1)
    out = np.where(best == 0, CORRECT, WRONG).astype(np.int8)
    if th is not None:
        best_s = np.take_along_axis(sum_s, best[..., None], axis=-1)[..., 0]
        out[best_s >= th] = NO_DECISION
    return out
