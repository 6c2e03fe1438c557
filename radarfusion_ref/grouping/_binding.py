"""Binding the reports of m sources to n fused tracks (the paper's hypotheses), and the scenes."""

from __future__ import annotations

import math

import numpy as np

from ..engine.linalg import mahalanobis_sq_pairwise
from ..engine.scenes import binding_hypotheses
from ..engine.validation import (
    MEMORY_LIMIT,
    as_choice,
    as_covariance,
    as_float_array,
    check_size,
)
from ._costs import _finite_costs, _ml_tensor, _reports_iv, _rescale

#: (0-based; the paper's :math:`J_{ij}` is report ``j`` of source ``i``).
PAPER_HYPOTHESES = {
    "I": np.array([[0, 1], [0, 1]]),    # J11, J21 -> track 1; J12, J22 -> track 2
    "II": np.array([[1, 0], [1, 0]]),   # J12, J22 -> track 1; J11, J21 -> track 2
    "III": np.array([[1, 0], [0, 1]]),  # J21, J12 -> track 1; J11, J22 -> track 2
    "IV": np.array([[0, 1], [1, 0]]),   # J11, J22 -> track 1; J21, J12 -> track 2
}
for _h in PAPER_HYPOTHESES.values():
    _h.setflags(write=False)



# ----------------------------------------------------------------------------- binding
#: The arguments of :func:`~radarfusion_ref.engine.linalg.mahalanobis_sq_pairwise` as
#: :func:`binding_costs` passes them, under the names its caller gave them.
_ENGINE_NAMES = {"`x1` must": "`x` and `tracks` must", "`x2` must": "`x` and `tracks` must",
                 "`cov1` must": "`cov` and `track_cov` must",
                 "`cov2` must": "`cov` and `track_cov` must"}


def binding_costs(x, cov, tracks, track_cov, *, cost: str = "paper") -> np.ndarray:
    r"""Score every binding hypothesis of m sources' reports to n fused tracks.

    Parameters
    ----------
    x : array_like, shape (..., m, n, d)
        New reports, ``x[..., i, j]`` report ``j`` of source ``i``.
    cov : array_like, shape (..., m, n, d, d)
        Their covariances (broadcastable).
    tracks : array_like, shape (..., n, d)
        Fused-track estimates (the paper's combined messages :math:`J_p`).
    track_cov : array_like, shape (..., n, d, d)
        Their error covariances (broadcastable).
    cost : {"paper", "ml"}, optional
        ``"paper"`` (default): the paper's sum of quadratic forms of the
        report-minus-track differences, each with covariance
        :math:`R_i + R_p` and treated as independent (eqs. 4–7). ``"ml"``:
        minus twice the exact log-likelihood, in which the reports bound to one
        track share that track's error.

    Returns
    -------
    numpy.ndarray, shape (..., H)
        One cost per hypothesis of `radarfusion_ref.engine.scenes.binding_hypotheses` (``H = (n!)**m``);
        the rule picks the minimum.

    Raises
    ------
    ValueError
        For inconsistent shapes, covariances that are not symmetric positive
        definite, more than :data:`radarfusion_ref.engine.scenes.MAX_BINDING_HYPOTHESES` hypotheses, or costs
        beyond the floating-point range.

    Notes
    -----
    Paper, eq. (6)–(7): :math:`\Sigma_h = \sum_{i,p}\Delta_{ij/p}^T
    (R_i+R_p)^{-1}\Delta_{ij/p}` with :math:`\Delta_{ij/p} = a_{ij} - a_p`
    and :math:`j` the report of source :math:`i` bound to track :math:`p`.
    Exact: the track is one more noisy report of the target, so each track's
    group {track, bound reports} is scored by :func:`group_costs` (``"ml"``):

    .. math::

        \Sigma^{\mathrm{exact}}_h = \sum_p c_{\mathrm{ML}}(a_p, a_{1 j_1}, \dots, a_{m j_m}),

    equivalently the quadratic form of the stacked differences with their
    full (correlated) covariance, whose off-diagonal blocks are :math:`R_p`.

    References
    ----------
    Sonar paper (2013), eqs. (4)–(7).

    Examples
    --------
    >>> x = np.array([[[0.1], [5.2]], [[-0.1], [4.9]]])     # 2 sources x 2 targets
    >>> c = np.full((2, 2, 1, 1), 0.04)
    >>> t, tc = np.array([[0.0], [5.0]]), np.full((2, 1, 1), 0.01)
    >>> int(np.argmin(binding_costs(x, c, t, tc)))          # hypothesis I
    0
    """
    cost = as_choice(cost, "cost", ("paper", "ml"))
    xb, cb, batch_x = _reports_iv(x, cov)
    B, m, n, d = xb.shape
    t = as_float_array(tracks, "tracks", ndim_min=2)
    if t.shape[-2:] != (n, d):
        raise ValueError(f"`tracks` must have shape (..., {n}, {d}) to match `x`; received shape {t.shape}")
    tc = as_float_array(track_cov, "track_cov", ndim_min=3)
    if tc.shape[-3:] not in {(n, d, d), (1, d, d)}:
        raise ValueError(
            f"`track_cov` must have shape (..., {n}, {d}, {d}); received shape {tc.shape}"
        )
    tc = as_covariance(tc, "track_cov", dim=d, domain=False)
    try:
        batch = np.broadcast_shapes(batch_x, t.shape[:-2], tc.shape[:-3])
    except ValueError:
        raise ValueError(
            "`x`, `tracks` and `track_cov` must have broadcastable leading (scene) axes; "
            f"received shapes {np.shape(x)}, {t.shape}, {tc.shape}"
        ) from None
    xb = np.broadcast_to(xb.reshape(*batch_x, m, n, d), (*batch, m, n, d)).reshape(-1, m, n, d)
    if cb.shape[0] > 1:
        cb = np.broadcast_to(cb.reshape(*batch_x, m, n, d, d),
                             (*batch, m, n, d, d)).reshape(-1, m, n, d, d)
    tb = np.broadcast_to(t, (*batch, n, d)).reshape(-1, n, d)
    if math.prod(tc.shape[:-3]) == 1 and cb.shape[0] == 1:     # no per-scene covariances
        tcb = np.broadcast_to(tc.reshape(tc.shape[-3:]), (n, d, d))[None]
    else:
        tcb = np.broadcast_to(tc, (*batch, n, d, d)).reshape(-1, n, d, d)
    B = xb.shape[0]
    hyp = binding_hypotheses(n, m)                                   # (H, m, n), size-checked
    H = hyp.shape[0]
    check_size(8 * B * (H + (n ** (m + 1) if cost == "ml" else 0)) + 8 * H * m * n,
               MEMORY_LIMIT, what=f"bytes of binding costs (`x`: {B} scene(s) x {H} hypotheses)",
               alternative="fewer scenes per call")
    (xb, cb, tb, tcb), log_s2 = _rescale(xb, cb, tb, tcb)
    if cost == "paper":
        try:
            q = mahalanobis_sq_pairwise(xb, tb[:, None], cb, tcb[:, None])  # (B, m, n_j, n_p)
        except ValueError as exc:                # the engine's names -> this function's
            text = str(exc)
            for engine, public in _ENGINE_NAMES.items():
                text = text.replace(engine, public)
            raise ValueError(f"{text} (the values after the common rescaling of `x`, `cov`, "
                             "`tracks` and `track_cov`)") from None
        ii = np.arange(m)[None, :, None]
        pp = np.arange(n)[None, None, :]
        out = q[:, ii, hyp, pp].sum(axis=(-2, -1))                   # (B, H)
    else:
        xe = np.concatenate([tb[:, None], xb], axis=1)               # track = source 0
        bc = max(tcb.shape[0], cb.shape[0])
        ce = np.concatenate([np.broadcast_to(tcb[:, None], (bc, 1, n, d, d)),
                             np.broadcast_to(cb, (bc, m, n, d, d))], axis=1)
        tensor = _ml_tensor(xe, ce).reshape(B, -1) + m * d * log_s2
        w = np.array([n ** (m - i) for i in range(m + 1)])
        flat = np.arange(n) * w[0] + np.einsum("hip,i->hp", hyp, w[1:])   # (H, n)
        out = tensor[:, flat].sum(axis=-1)
    return _finite_costs(out).reshape(*batch, hyp.shape[0])
