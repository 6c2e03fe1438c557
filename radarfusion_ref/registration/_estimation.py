r"""What the reports say about the biases: Fisher information, observability, maximum likelihood."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..engine.errors import RadarFusionWarning
from ..engine.validation import (
    as_float_array,
    as_int,
    describe,
)
from ._model import (
    BIAS_NAMES,
    RANK_TOL,
    _elements,
    _fixed_iv,
    _polar_reports_iv,
    _radar_biases_iv,
    _sensors_iv,
    _sigmas_iv,
    _targets_iv,
    _wrap,
)


# --------------------------------------------------------------------------- estimation core
def _blocks(s, x, b, sr, sb):
    """Whitened Jacobians of the predicted polar reports.

    Returns (pred (…, m, n, 2), B (…, m, n, 2, 3), G (…, m, n, 2, 2)) for
    sites s (m, 2), objects x (…, n, 2), biases b (…, m, 3).
    """
    d = x[..., None, :, :] - s[:, None, :]                     # (…, m, n, 2)
    rho = np.hypot(d[..., 0], d[..., 1])
    phi = np.arctan2(d[..., 1], d[..., 0])
    u = d / rho[..., None]
    uperp = np.stack([-u[..., 1], u[..., 0]], axis=-1)
    scale = 1.0 + b[..., :, None, 1]
    pred = np.stack([scale * rho + b[..., :, None, 0], phi + b[..., :, None, 2]], axis=-1)
    w_r, w_b = 1.0 / sr[:, None], 1.0 / sb[:, None]
    zero, one = np.zeros_like(rho), np.ones_like(rho)
    # d r^b / d(Δr, g, Δβ) = (1, r, 0);  d β^b / d(Δr, g, Δβ) = (0, 0, 1)
    B = np.stack([np.stack([one * w_r, rho * w_r, zero], -1),
                  np.stack([zero, zero, one * w_b], -1)], -2)
    # d r^b / dx = (1 + g) u^T;  d β / dx = u_perp^T / r
    G = np.stack([(scale * w_r)[..., None] * u, (w_b / rho)[..., None] * uperp], -2)
    return pred, B, G


def reduced_information(jac_bias, jac_object):
    r"""Fisher information of the biases with every object's position eliminated.

    With the whitened Jacobians :math:`B_{ik}` (report of object :math:`k` by radar
    :math:`i` against that radar's biases) and :math:`G_{ik}` (against the object's
    position), the normal equations have the blocks :math:`U = \operatorname{blockdiag}_i
    \sum_k B_{ik}^\mathsf T B_{ik}`, :math:`W_k = \sum_i B_{ik}^\mathsf T G_{ik}` and
    :math:`V_k = \sum_i G_{ik}^\mathsf T G_{ik}`; eliminating the objects (a Schur
    complement, the bundle-adjustment trick) leaves

    .. math::

        \mathcal J_b = U - \sum_k W_k V_k^{-1} W_k^\mathsf T

    (book eq. ``eq-registration-fim``).

    Parameters
    ----------
    jac_bias : array_like, shape (..., m, n, 2, 3)
        :math:`B_{ik}`, whitened (divided by the error standard deviations).
    jac_object : array_like, shape (..., m, n, 2, 2)
        :math:`G_{ik}`, whitened.

    Returns
    -------
    numpy.ndarray, shape (..., 3m, 3m)
        :math:`\mathcal J_b`, symmetric.

    Raises
    ------
    ValueError
        Shapes that do not describe the same reports, non-finite entries, or an object
        whose position its reports do not determine (:math:`V_k` singular).

    Examples
    --------
    >>> B = np.zeros((2, 1, 2, 3)); B[0, 0, 0, 0] = B[1, 0, 0, 0] = 1.0
    >>> reduced_information(B, np.broadcast_to(np.eye(2), (2, 1, 2, 2)))[[0, 3]][:, [0, 3]]
    array([[ 0.5, -0.5],
           [-0.5,  0.5]])
    """
    B, G = _jacobians_iv(jac_bias, jac_object)
    *lead, m, _, _, _ = B.shape
    # per radar, summed over k
    U = np.einsum("...ikab,...ikac->...ibc", B, B)
    info = np.zeros((*lead, 3 * m, 3 * m))
    for i in range(m):                            # U is block-diagonal
        info[..., 3 * i:3 * i + 3, 3 * i:3 * i + 3] = U[..., i, :, :]
    W, V = _object_blocks(B, G)       # (…, n, 3m, 2), (…, n, 2, 2)
    try:
        Vinv_Wt = np.linalg.solve(V, np.swapaxes(W, -1, -2))
    except np.linalg.LinAlgError:
        raise ValueError(
            "`jac_object`: an object's position is not determined by its "
            "reports (a V_k is singular)") from None
    # U - sum_k W V^-1 W^T
    info = info - np.einsum("...kpa,...kaq->...pq", W, Vinv_Wt)
    return 0.5 * (info + np.swapaxes(info, -1, -2))


def _jacobians_iv(jac_bias, jac_object):
    B = as_float_array(jac_bias, "jac_bias", ndim_min=4, last_dims=(2, 3))
    G = as_float_array(jac_object, "jac_object", ndim_min=4, last_dims=(2, 2))
    if B.shape[:-1] != G.shape[:-1]:
        raise ValueError("`jac_bias` (..., m, n, 2, 3) and `jac_object` (..., m, n, 2, 2) must "
                         f"describe the same reports; received shapes {B.shape} and {G.shape}")
    return B, G


def _object_blocks(B, G):
    """W_k = sum_i B_ik^T G_ik, laid out (…, n, 3m, 2), and V_k = sum_i G_ik^T G_ik."""
    *lead, m, n, _, _ = B.shape
    W = np.einsum("...ikab,...ikac->...kibc", B, G).reshape(*lead, n, 3 * m, 2)
    return W, np.einsum("...ikab,...ikac->...kbc", G, G)


def _reduced(B, G, e):
    """The reduced information, the reduced gradient and the per-object pieces of one step.

    B (…, m, n, 2, 3), G (…, m, n, 2, 2), e (…, m, n, 2) whitened residuals.
    """
    *lead, m, _, _, _ = B.shape
    info = reduced_information(B, G)
    W, V = _object_blocks(B, G)
    gb = np.einsum("...ikab,...ika->...ib", B, e).reshape(*lead, 3 * m)
    gx = np.einsum("...ikab,...ika->...kb", G, e)                   # (…, n, 2)
    Vinv_gx = np.linalg.solve(V, gx[..., None])[..., 0]
    grad = gb - np.einsum("...kpa,...ka->...p", W, Vinv_gx)
    return info, grad, (W, V, gx, np.einsum("...ka,...ka->...", gx, Vinv_gx))


def _known_object_information(B):
    """Diagonal of the biases' information were the objects known, (…, 3m): sum_k B^T B."""
    *lead, m, _, _, _ = B.shape
    return np.einsum("...ikaj,...ikaj->...ij", B, B).reshape(*lead, 3 * m)


def _scaled_rank(info, free, reference):
    """Rank and null space (physical units) of the free block of one information matrix.

    Unit-free by construction. A bias counts as unseen when eliminating the objects
    left less than :data:`RANK_TOL` of the information it would have were the
    objects known (`reference`, :func:`_known_object_information`): both scale
    alike with its unit. The others' block is scaled to a unit diagonal (a
    congruence by the diagonal, which is what a change of units does to it, so
    its eigenvalues are the same in any units); eigenvalues below
    :data:`RANK_TOL` times the largest count as zero.
    """
    idx = np.flatnonzero(free)
    sub = info[np.ix_(idx, idx)]
    diag = np.diag(sub)
    zero = ~(diag > RANK_TOL * reference[idx])          # no information left (or none at all)
    if zero.all():
        full = np.zeros((len(free), len(idx)))
        full[idx, np.arange(len(idx))] = 1.0
        return 0, full
    d = np.sqrt(np.where(zero, 1.0, diag))
    scaled = sub / np.outer(d, d)
    scaled[zero, :] = 0.0
    scaled[:, zero] = 0.0
    vals, vecs = np.linalg.eigh(scaled)
    bad = vals <= RANK_TOL * vals.max()
    null = vecs[:, bad] / d[:, None]
    full = np.zeros((len(free), null.shape[1]))
    full[idx] = null
    return len(idx) - null.shape[1], full


def _rref_rows(null: np.ndarray, tol: float = 1e-8) -> np.ndarray:
    """Rows spanning the null space, in reduced row-echelon form (readable combinations)."""
    a = null.T.copy()
    rows, cols = a.shape
    r = 0
    for c in range(cols):
        if r == rows:
            break
        p = r + int(np.argmax(np.abs(a[r:, c])))
        if abs(a[p, c]) <= tol * max(1.0, np.abs(a).max()):
            continue
        a[[r, p]] = a[[p, r]]
        a[r] /= a[r, c]
        for q in range(rows):
            if q != r:
                a[q] -= a[q, c] * a[r]
        r += 1
    a[np.abs(a) < 1e-10] = 0.0
    return a[:r]


def _describe_combination(row: np.ndarray) -> str:
    terms = []
    for p in np.flatnonzero(row):
        i, j = divmod(int(p), 3)
        c = row[p]
        coef = "" if abs(c - 1) < 1e-9 else ("-" if abs(c + 1) < 1e-9 else f"{c:.3g}*")
        terms.append(f"{coef}{BIAS_NAMES[j]}[{i}]")
    return " + ".join(terms).replace("+ -", "- ")


# --------------------------------------------------------------------------- information
def bias_information(sensors, targets, sigma_r, sigma_beta, *, biases=None):
    r"""Fisher information of the radar biases, the object positions being unknown.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites.
    targets : array_like, shape (..., n, 2)
        Positions of the n objects seen by every radar.
    sigma_r, sigma_beta : float or array_like, shape (m,)
        Random error standard deviations.
    biases : array_like, shape (..., m, 3), optional
        Point of evaluation (default zero; only the range scale enters).

    Returns
    -------
    numpy.ndarray, shape (..., 3m, 3m)
        :math:`\mathcal J_b`, ordered radar by radar as
        :math:`(\Delta r_1, g_1, \Delta\beta_1, \Delta r_2, \dots)`.

    Raises
    ------
    ValueError, TypeError
        Bad shapes or values, named; `sigma_r` or `sigma_beta` for which the information
        (as 1/sigma_r**2 and 1/(sigma_beta * range)**2) leaves float64's normal range.

    Notes
    -----
    With :math:`R^{-1/2}`-whitened Jacobians :math:`B_{ik} = \partial h_{ik}/\partial b_i`
    and :math:`G_{ik} = \partial h_{ik}/\partial x_k` of the predicted report
    :math:`h_{ik} = ((1+g_i) r_{ik} + \Delta r_i,\ \beta_{ik} + \Delta\beta_i)`,
    the full information :math:`H^{\mathsf T} H` of :math:`(b, x_1, \dots, x_n)` has
    a block-arrow form. Eliminating each object (Schur complement) gives

    .. math::

        \mathcal J_b = \sum_k \left( \mathcal B_k^{\mathsf T}\mathcal B_k
        - \mathcal B_k^{\mathsf T}\mathcal G_k (\mathcal G_k^{\mathsf T}
        \mathcal G_k)^{-1}\mathcal G_k^{\mathsf T}\mathcal B_k \right),

    where :math:`\mathcal B_k, \mathcal G_k` stack radar :math:`i`'s rows
    (:math:`\mathcal B_k` block-diagonal over radars): each object contributes
    the information left after its own position has been estimated. The CRLB
    of the biases is :math:`\mathcal J_b^{-1}` where it exists (book eq.
    ``eq-registration-fim``; Bar-Shalom, Li & Kirubarajan, sec. 2.7).

    Examples
    --------
    >>> J = bias_information([[0, 0], [20, 0]], [[0, 60], [30, 70], [-20, 50]], 0.05, 1e-3)
    >>> J.shape, int(np.linalg.matrix_rank(J / np.sqrt(np.outer(np.diag(J), np.diag(J)))))
    ((6, 6), 6)
    """
    s = _sensors_iv(sensors)
    m = s.shape[0]
    t = _targets_iv(targets, s)
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, m)
    b = np.zeros((m, 3)) if biases is None else _radar_biases_iv(biases, m)
    _elements(t.size // 2 * m, "targets")
    return _information(s, t, sr, sb, b)[0]


def _information(s, t, sr, sb, b=None):
    """:func:`bias_information` on validated input, and :func:`_known_object_information`."""
    m = s.shape[0]
    b = np.zeros((m, 3)) if b is None else b
    lead = np.broadcast_shapes(t.shape[:-2], b.shape[:-2])
    t = np.broadcast_to(t, (*lead, *t.shape[-2:]))
    b = np.broadcast_to(b, (*lead, m, 3))
    with np.errstate(over="ignore", invalid="ignore", under="ignore"):
        _, B, G = _blocks(s, t, b, sr, sb)
        reference = _known_object_information(B)
        _require_representable_information(reference, G, sr, sb)
        return reduced_information(B, G), reference


def _require_representable_information(reference, G, sr, sb) -> None:
    """Refuse, by name, sigmas for which the information leaves float64's normal range.

    `reference` (…, 3m) is the biases' information with the objects known, `G`
    (…, m, n, 2, 2) the whitened Jacobians of the objects, whose range rows go as
    1/sigma_r and azimuth rows as 1/(sigma_beta * range); a zero or subnormal entry
    has lost every digit.
    """
    *lead, m3 = reference.shape
    per_bias = reference.reshape(*lead, m3 // 3, 3)
    v_diag = np.einsum("...ikab,...ikab->...ka", G, G)              # (…, n, 2): range, azimuth
    tiny, huge = np.finfo(float).tiny, np.finfo(float).max

    def out_of_range(a):
        return ~((a >= tiny) & (a <= huge))

    for bad, name, sigma, what in (
            (out_of_range(per_bias[..., :2]).any(-1)
             | out_of_range(v_diag[..., 0]).any(-1)[..., None],
             "sigma_r", sr, "1 / sigma_r**2"),
            (out_of_range(per_bias[..., 2]) | out_of_range(v_diag[..., 1]).any(-1)[..., None],
             "sigma_beta", sb, "1 / sigma_beta**2 and 1 / (sigma_beta * range)**2")):
        if np.any(bad):
            raise ValueError(
                f"`{name}` = {float(np.min(sigma)):.3g}: the Fisher information of the biases "
                f"and objects, which goes as {what}, leaves float64's range [{tiny:.3g}, "
                f"{huge:.3g}] at these ranges; express lengths in a unit where the ranges "
                f"and `sigma_r` are nearer 1")


def _require_determined(V, iteration: int) -> None:
    """Refuse, naming `reports`, when an object's reports do not fix its position."""
    # unit-free: 1 - rho**2 of V scaled to a unit diagonal (det V / (V00 V11))
    a, c = np.sqrt(V[..., 0, 0]), np.sqrt(V[..., 1, 1])
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = V[..., 0, 1] / a / c
    ok = (a > 0) & (c > 0) & np.isfinite(rho) & (1.0 - rho**2 > 1e-12)
    if not np.all(ok):
        k = int(np.argwhere(~ok)[0][-1])
        raise ValueError(
            f"`reports`: these reports do not determine the biases: object {k}'s position is "
            f"not fixed by its reports at the biases of iteration {iteration} (its reports do "
            "not describe one object); check the association (``reports[..., i, k]`` must be "
            "every radar's report of the same object k) or start from a better `initial`")


@dataclass(frozen=True)
class Observability:
    """Which radar biases a geometry lets one estimate.

    Attributes
    ----------
    rank : int
        Rank of the bias information matrix restricted to the free biases.
    n_free : int
        Number of free (not fixed) biases, :math:`3m` minus the fixed ones.
    unobservable : numpy.ndarray, shape (n_free - rank, 3m)
        Rows spanning the combinations of biases the data cannot see, in
        reduced row-echelon form (physical units; zero in fixed columns).
    descriptions : tuple of str
        The same rows in words, e.g. ``"range_offset[0] + range_offset[1]"``.
    """

    rank: int
    n_free: int
    unobservable: np.ndarray
    descriptions: tuple[str, ...]

    @property
    def observable(self) -> bool:
        """True when every free bias is observable (full rank)."""
        return self.rank == self.n_free


def observability(sensors, targets, sigma_r=1.0, sigma_beta=1e-3, *, fixed=None):
    r"""Rank of the bias information of one geometry, and the combinations it cannot see.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites.
    targets : array_like, shape (n, 2)
        Object positions (one geometry, no batch).
    sigma_r, sigma_beta : float or array_like, shape (m,), optional
        Random error standard deviations (they change the information, not its rank).
    fixed : array_like of bool, shape (m, 3), optional
        Biases known to be zero (e.g. a reference radar), left out.

    Returns
    -------
    Observability

    Raises
    ------
    ValueError, TypeError
        Bad shapes or values, named; `sigma_r` or `sigma_beta` for which the information
        (as 1/sigma_r**2 and 1/(sigma_beta * range)**2) leaves float64's normal range.

    Notes
    -----
    The rank is that of the information restricted to the free biases after
    scaling it to a unit diagonal; eigenvalues below :data:`RANK_TOL` times
    the largest count as zero. A bias whose information after eliminating the
    objects is below :data:`RANK_TOL` times what it would be were the objects
    known counts as unseen. Both rules compare quantities in the same units,
    so the rank does not depend on the unit of length (or of angle). The unobservable combinations are the null
    space :math:`\mathcal J_b v = 0`: bias changes :math:`v` that every object
    position can absorb.

    Examples
    --------
    >>> o = observability([[0, 0], [0, 0]], [[0, 60], [30, 70], [-20, 50]])
    >>> o.rank, o.descriptions[0]
    (3, 'range_offset[0] + range_offset[1]')
    """
    s = _sensors_iv(sensors)
    m = s.shape[0]
    t = _targets_iv(targets, s)
    if t.ndim != 2:
        raise ValueError(f"`targets` must have shape (n, 2), one geometry; received shape "
                         f"{t.shape}")
    fx = _fixed_iv(fixed, m)
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, m)
    _elements(t.size // 2 * m, "targets")
    info, reference = _information(s, t, sr, sb)
    rank, null = _scaled_rank(info, ~fx.ravel(), reference)
    rows = _rref_rows(null) if null.shape[1] else np.zeros((0, 3 * m))
    return Observability(int(rank), int((~fx).sum()), rows,
                         tuple(_describe_combination(r) for r in rows))


# --------------------------------------------------------------------------- estimation
@dataclass(frozen=True)
class BiasEstimate:
    r"""Maximum-likelihood radar biases from reports of common objects.

    Attributes
    ----------
    biases : numpy.ndarray, shape (..., m, 3)
        Estimated :math:`(\Delta r_i, g_i, \Delta\beta_i)`; fixed
        biases are exactly zero.
    targets : numpy.ndarray, shape (..., n, 2)
        Estimated object positions (the nuisance parameters).
    covariance : numpy.ndarray, shape (..., 3m, 3m)
        Covariance of the estimate: the inverse Fisher information of the
        free biases at the estimate (zero rows and columns for fixed biases).
    crlb : numpy.ndarray, shape (..., m, 3)
        Cramér–Rao bound on each bias's standard deviation at the estimated
        geometry, the square root of the diagonal of `covariance` (zero for
        fixed biases). :func:`bias_information` gives the bound at any geometry.
    information : numpy.ndarray, shape (..., 3m, 3m)
        Fisher information of the biases (objects eliminated) at the estimate.
    chi2 : numpy.ndarray or float, shape (...)
        Minimised sum of squared whitened residuals.
    dof : int
        Residual degrees of freedom, :math:`2mn - 2n - n_{\text{free}}`:
        under the model `chi2` is about :math:`\chi^2_{\text{dof}}`.
    iterations : int
        Gauss–Newton iterations used (the largest over the batch).
    """

    biases: np.ndarray
    targets: np.ndarray
    covariance: np.ndarray
    crlb: np.ndarray
    information: np.ndarray
    chi2: np.ndarray | float
    dof: int
    iterations: int


def _initial_targets(s, z, b, sr, sb):
    """Mean of the radars' converted, bias-corrected reports of each object."""
    rc = (z[..., 0] - b[..., :, None, 0]) / (1.0 + b[..., :, None, 1])
    bc = z[..., 1] - b[..., :, None, 2]
    rc = np.maximum(rc, 1e-12 * np.abs(z[..., 0]).max())
    pos = s[:, None, :] + rc[..., None] * np.stack([np.cos(bc), np.sin(bc)], axis=-1)
    return pos.mean(axis=-3)


def _unobservable_error(info, free, reference, where: str) -> None:
    rank, null = _scaled_rank(info, free, reference)
    if rank < int(free.sum()):
        rows = _rref_rows(null)
        combos = "; ".join(_describe_combination(r) for r in rows) or "(see `observability`)"
        raise ValueError(
            f"`reports`: the biases are not observable from this geometry{where}: the bias "
            f"information matrix has rank {rank} of {int(free.sum())} free biases; the data "
            f"cannot see these combinations: {combos}. Use radars at different sites, objects "
            f"in more directions and ranges (at least 3 in general position for two radars), "
            f"or fix a reference radar's biases with `fixed`")


def estimate_biases(sensors, reports, sigma_r, sigma_beta, *, fixed=None, initial=None,
                    max_iter: int = 50, tol: float = 1e-10) -> BiasEstimate:
    r"""Maximum-likelihood (weighted least-squares) biases of radars seeing common objects.

    Parameters
    ----------
    sensors : array_like, shape (m, 2)
        Radar sites, :math:`m \ge 2`.
    reports : array_like, shape (..., m, n, 2)
        Associated polar reports: ``reports[..., i, k]`` is radar ``i``'s
        :math:`(\hat r, \hat\beta)` of object ``k`` (every radar sees every
        object). Leading axes are a batch, solved vectorized.
    sigma_r, sigma_beta : float or array_like, shape (m,)
        Random error standard deviations (> 0).
    fixed : array_like of bool, shape (m, 3), optional
        Biases known to be zero, held fixed (e.g. ``fixed[0] = True`` makes
        radar 0 the reference).
    initial : array_like, shape (..., m, 3), optional
        Starting biases (default zero); fixed entries are set to zero.
    max_iter : int, optional
        Largest number of Gauss–Newton iterations (default 50).
    tol : float, optional
        Stop when the Gauss–Newton decrement (the predicted drop of the
        whitened sum of squares) is below `tol` for every batch element.

    Returns
    -------
    BiasEstimate

    Raises
    ------
    ValueError
        Bad shapes or values (named), fewer than two radars, sigmas whose
        information leaves float64's range (named), an **unobservable
        configuration**: the free biases' information matrix is rank deficient
        (the message names the unobservable combinations), or reports that do
        not determine the biases (typically a wrong association; named `reports`).
    TypeError
        Non-numeric input or a non-boolean `fixed`.

    Warns
    -----
    RadarFusionWarning
        If Gauss–Newton has not converged after `max_iter` iterations.

    Notes
    -----
    The negative log-likelihood is, up to a constant, the whitened sum of
    squares over radars :math:`i` and objects :math:`k`

    .. math::

        \ell(b, x) = \sum_{i,k} \frac{(\hat r_{ik} - (1+g_i) r_{ik}(x_k)
        - \Delta r_i)^2}{\sigma_{r,i}^2}
        + \frac{(\hat\beta_{ik} - \beta_{ik}(x_k) - \Delta\beta_i)^2}{\sigma_{\beta,i}^2},

    minimised jointly over the biases and the object positions by
    Gauss–Newton. Each step solves the normal equations after eliminating
    the objects (the Schur complement of :func:`bias_information`, as in
    bundle adjustment), then back-substitutes each object's 2×2 system.
    Azimuth residuals are wrapped to :math:`[-\pi, \pi)`. The rank of the
    information is checked first, at the starting point: a rank-deficient
    configuration raises instead of producing a singular solve.

    References
    ----------
    Zhou, Leung & Yip (1997); Okello & Ristic (2003); Bar-Shalom, Li &
    Kirubarajan (2001), sec. 3.4.

    Examples
    --------
    >>> s = [[0.0, 0.0], [20.0, 0.0]]
    >>> x = [[0.0, 60.0], [30.0, 70.0], [-20.0, 50.0], [10.0, 80.0]]
    >>> b = [[0.2, 0.0, 0.002], [-0.1, 0.0, -0.001]]
    >>> from radarfusion_ref.registration import draw_biased_reports
    >>> z = draw_biased_reports(s, x, b, 1e-6, 1e-9, rng=0)       # nearly noise-free
    >>> est = estimate_biases(s, z, 1e-6, 1e-9)
    >>> np.round(est.biases, 4)
    array([[ 0.2  ,  0.   ,  0.002],
           [-0.1  ,  0.   , -0.001]])
    """
    s = _sensors_iv(sensors)
    m = s.shape[0]
    if m < 2:
        raise ValueError(f"`sensors` must hold at least two radar sites to register them; "
                         f"received shape {s.shape}")
    z = _polar_reports_iv(reports, "reports", m)
    sr, sb = _sigmas_iv(sigma_r, sigma_beta, m)
    fx = _fixed_iv(fixed, m)
    max_iter = as_int(max_iter, "max_iter", minimum=1, maximum=10_000)
    if isinstance(tol, bool) or not isinstance(tol, (int, float)) or not (0 < tol < 1):
        raise ValueError(f"`tol` must be a number in (0, 1); received {describe(tol)}")
    lead, n = z.shape[:-3], z.shape[-2]
    _elements(math.prod(lead) * m * n, "reports")
    free = ~fx.ravel()
    if initial is None:
        b = np.zeros((*lead, m, 3))
    else:
        b = np.array(np.broadcast_to(_radar_biases_iv(initial, m, "initial"), (*lead, m, 3)))
    b[..., fx] = 0.0
    x = _initial_targets(s, z, b, sr, sb)
    mask = np.zeros(3 * m)
    mask[~free] = 1.0

    def step(b, x, iteration):
        with np.errstate(over="ignore", invalid="ignore", divide="ignore", under="ignore"):
            pred, B, G = _blocks(s, x, b, sr, sb)
            if iteration == 0:
                _require_representable_information(_known_object_information(B), G, sr, sb)
        _require_determined(_object_blocks(B, G)[1], iteration)
        B = B * free.reshape(m, 3)[:, None, None, :]           # fixed biases: no columns
        e = np.stack([(z[..., 0] - pred[..., 0]) / sr[:, None],
                      _wrap(z[..., 1] - pred[..., 1]) / sb[:, None]], axis=-1)
        info, grad, (W, V, gx, gvg) = _reduced(B, G, e)
        return info, grad, W, V, gx, gvg, e, B

    info, grad, W, V, gx, gvg, e, B = step(b, x, 0)
    flat_info = info.reshape(-1, 3 * m, 3 * m)
    flat_ref = np.broadcast_to(_known_object_information(B), (*lead, 3 * m)).reshape(-1, 3 * m)
    for k in range(flat_info.shape[0]):
        _unobservable_error(flat_info[k], free, flat_ref[k], "" if flat_info.shape[0] == 1
                            else f" (batch element {k})")
    iterations, converged = 0, False
    while iterations < max_iter:
        iterations += 1
        a = info + np.diag(mask)
        try:
            db = np.linalg.solve(a, grad[..., None])[..., 0]
        except np.linalg.LinAlgError:
            raise ValueError(f"`reports`: these reports do not determine the biases: the "
                             f"bias information became singular at iteration {iterations}; "
                             "check the association of `reports`") from None
        dx = np.linalg.solve(V, (gx - np.einsum("...kpa,...p->...ka", W, db))[..., None])[..., 0]
        # Gauss-Newton decrement g^T delta = db . grad_reduced + gx^T V^-1 gx
        decrement = np.einsum("...p,...p->...", db, grad) + gvg
        b = b + db.reshape(*lead, m, 3)
        x = x + dx
        if np.any(b[..., 1] <= -1):
            raise ValueError("`reports`: the range scale estimate left (-1, inf); the reports "
                             "are not consistent with the bias model (check the association)")
        info, grad, W, V, gx, gvg, e, _ = step(b, x, iterations)
        if np.all(np.abs(decrement) < tol):
            converged = True
            break
    if not converged:
        warnings.warn(f"estimate_biases: Gauss-Newton did not converge in {max_iter} "
                      f"iterations (largest decrement {float(np.max(np.abs(decrement))):.3g})",
                      RadarFusionWarning, stacklevel=2)
    cov = np.linalg.inv(info + np.diag(mask)) * np.outer(free, free)
    crlb = np.sqrt(np.clip(np.diagonal(cov, axis1=-2, axis2=-1), 0, None)).reshape(*lead, m, 3)
    chi2 = np.einsum("...ikj,...ikj->...", e, e)
    dof = 2 * m * n - 2 * n - int(free.sum())
    chi2 = float(chi2) if np.ndim(chi2) == 0 else chi2
    return BiasEstimate(b, x, cov, crlb, info, chi2, dof, iterations)
