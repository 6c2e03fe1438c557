r"""The interacting multiple model (IMM) filter of constant-velocity modes.

Modes :math:`j = 1..M` share the constant-velocity state of :mod:`._kalman` and differ by
their process-noise intensity :math:`q_j`; the mode follows a Markov chain with transition
matrix :math:`\Pi`, :math:`\pi_{ij} = P(\text{mode } j \text{ now} \mid i \text{ before})`.
One cycle (Blom & Bar-Shalom 1988):

1. **mixing** — :math:`\bar c_j = \sum_i \pi_{ij}\mu_i`,
   :math:`\mu_{i|j} = \pi_{ij}\mu_i / \bar c_j`, and each mode starts from the moments of
   the mixture :math:`\sum_i \mu_{i|j}\mathcal N(\hat{\mathbf x}_i, P_i)`;
2. **mode-matched prediction and update** — one Kalman filter per mode;
3. **mode probabilities** — :math:`\mu_j \propto \bar c_j\Lambda_j`, with
   :math:`\Lambda_j = \mathcal N(\boldsymbol\nu_j; 0, S_j)` the mode's likelihood of the
   report;
4. **combination** — the moments of :math:`\sum_j \mu_j\mathcal N(\hat{\mathbf x}_j, P_j)`
   (the output; the modes keep their own estimates).

Arrays carry the modes on the axis before the state: ``x (..., M, 2 d)``,
``P (..., M, 2 d, 2 d)``, ``probability (..., M)``, ``transition (..., M, M)``. The kernels
trust their input; the public functions validate at the door.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..validation import as_choice, as_covariance, as_float_array, as_positive, check_size
from ._kalman import MAX_BATCH, KalmanEstimate, check_prediction, predict_kernel, update_kernel

#: Tolerance on a sum of probabilities that must be 1.
SUM_TOL = 1e-9


@dataclass(frozen=True)
class ImmMixing:
    r"""The mixing step's probabilities.

    Attributes
    ----------
    predicted : numpy.ndarray, shape (..., M)
        :math:`\bar c_j = \sum_i \pi_{ij}\mu_i`, the mode probabilities before the report.
    mixing : numpy.ndarray, shape (..., M, M)
        :math:`\mu_{i|j} = \pi_{ij}\mu_i/\bar c_j` at ``[..., i, j]``: each column sums to 1.
    """

    predicted: np.ndarray
    mixing: np.ndarray


@dataclass(frozen=True)
class ImmEstimate:
    r"""Mode-conditioned estimates and the mode probabilities.

    Attributes
    ----------
    probability : numpy.ndarray, shape (..., M)
        Mode probabilities (:math:`\bar c_j` after a prediction, :math:`\mu_j` after an
        update).
    state : numpy.ndarray, shape (..., M, 2 d)
    covariance : numpy.ndarray, shape (..., M, 2 d, 2 d)
    log_likelihood : numpy.ndarray or None, shape (..., M)
        After an update: :math:`\ln\Lambda_j`, each mode's log-likelihood of the report
        (None after a prediction).
    """

    probability: np.ndarray
    state: np.ndarray
    covariance: np.ndarray
    log_likelihood: np.ndarray | None = None


# ----------------------------------------------------------------------------- kernels
def mixing_kernel(mu, transition):
    r"""Kernel: :math:`\bar c_j` and :math:`\mu_{i|j}` (trusted input)."""
    joint = mu[..., :, None] * transition                     # μ_i π_ij
    cbar = joint.sum(-2)                                      # c̄_j = Σ_i π_ij μ_i
    with np.errstate(invalid="ignore", divide="ignore"):
        w = joint / cbar[..., None, :]                        # μ_{i|j}
    w = np.where(cbar[..., None, :] > 0, w, mu[..., :, None])  # unreachable mode: no mixing
    return cbar, w


def mix_kernel(w, x, P):
    r"""Kernel: moments of the mixtures :math:`\sum_i w_{ij}\mathcal N(\mathbf x_i, P_i)`,
    one per column :math:`j` of `w` (..., M_in, M_out)."""
    x0 = np.einsum("...ij,...in->...jn", w, x)                           # Σ_i w_ij x_i
    d = x[..., :, None, :] - x0[..., None, :, :]                          # x_i - x0_j
    P0 = (np.einsum("...ij,...inm->...jnm", w, P)
          + np.einsum("...ij,...ijn,...ijm->...jnm", w, d, d))            # + spread
    return x0, 0.5 * (P0 + np.swapaxes(P0, -1, -2))


def combine_kernel(mu, x, P):
    r"""Kernel: moments of :math:`\sum_j \mu_j\mathcal N(\mathbf x_j, P_j)` (trusted)."""
    x0, P0 = mix_kernel(mu[..., :, None], x, P)
    return x0[..., 0, :], P0[..., 0, :, :]


def imm_predict_kernel(mu, x, P, transition, dt, q, noise="continuous", per_axis=False):
    r"""Kernel: mixing, then each mode's prediction with its own `q` (trusted input).

    `dt` has the batch shape (no mode axis); `q` broadcasts against (..., M), or
    (..., M, d) with `per_axis`. Returns :math:`\bar c`, the states and covariances.
    """
    cbar, w = mixing_kernel(mu, transition)
    x0, P0 = mix_kernel(w, x, P)
    xp, Pp = predict_kernel(x0, P0, np.asarray(dt, float)[..., None], q, noise, per_axis)
    return cbar, xp, Pp


def imm_update_kernel(cbar, x, P, z, R):
    r"""Kernel: each mode's Kalman update with the report, the mode log-likelihoods
    :math:`\ln\Lambda_j` and the posterior mode probabilities (trusted input)."""
    d = z.shape[-1]
    zz = np.broadcast_to(z[..., None, :], (*x.shape[:-1], d))
    RR = np.broadcast_to(R[..., None, :, :], (*x.shape[:-1], d, d))
    xn, Pn, stat, logdet = update_kernel(x, P, zz, RR)
    loglik = -0.5 * (stat + logdet + d * math.log(2 * math.pi))          # ln N(ν_j; 0, S_j)
    return xn, Pn, loglik, posterior_kernel(cbar, loglik)


def posterior_kernel(cbar, loglik):
    r"""Kernel: :math:`\mu_j = \bar c_j\Lambda_j / \sum_k \bar c_k\Lambda_k` in the log domain."""
    with np.errstate(divide="ignore"):
        a = np.log(cbar) + loglik
    a = a - a.max(-1, keepdims=True)
    e = np.exp(a)
    return e / e.sum(-1, keepdims=True)


# ----------------------------------------------------------------------------- doors
def _modes_iv(probability, x=None, P=None):
    mu = as_float_array(probability, "probability", ndim_min=1)
    if np.any((mu < 0) | (mu > 1)):
        raise ValueError(f"`probability` must hold mode probabilities in [0, 1]; received "
                         f"entries from {mu.min():.6g} to {mu.max():.6g}")
    s = mu.sum(-1)
    if np.any(np.abs(s - 1) > SUM_TOL * mu.shape[-1]):
        bad = float(s.flat[np.argmax(np.abs(s - 1))])
        raise ValueError(f"`probability` must sum to 1 over the modes (last axis); received "
                         f"a sum of {bad:.12g}")
    M = mu.shape[-1]
    if x is None:
        return mu, None, None
    x = as_float_array(x, "x", ndim_min=2)
    n = x.shape[-1]
    if n not in (2, 4, 6) or x.shape[-2] != M:
        raise ValueError(f"`x` must have shape (..., M, n) with M = {M} modes (the last axis "
                         f"of `probability`) and n = 2, 4 or 6 ([positions, velocities]); "
                         f"received shape {x.shape}")
    P = as_covariance(P, "cov", dim=n)
    if P.ndim < 3 or P.shape[-3] != M:
        raise ValueError(f"`cov` must have shape (..., {M}, {n}, {n}), one covariance per mode; "
                         f"received shape {P.shape}")
    return mu, x, P


def _transition_iv(transition, M):
    T = as_float_array(transition, "transition", ndim_min=2)
    if T.shape[-2:] != (M, M):
        raise ValueError(f"`transition` must have shape (..., {M}, {M}) for {M} modes; "
                         f"received shape {T.shape}")
    if np.any((T < 0) | (T > 1)):
        raise ValueError(f"`transition` must hold probabilities in [0, 1]; received entries "
                         f"from {T.min():.6g} to {T.max():.6g}")
    s = T.sum(-1)
    if np.any(np.abs(s - 1) > SUM_TOL * M):
        bad = float(s.flat[np.argmax(np.abs(s - 1))])
        raise ValueError(f"`transition`: each row (from one mode to all) must sum to 1; "
                         f"received a row summing to {bad:.12g}")
    return T


def _lead(names, *shapes):
    try:
        return np.broadcast_shapes(*shapes)
    except ValueError:
        raise ValueError(f"{names} must have broadcasting batch shapes; received "
                         f"{', '.join(str(s) for s in shapes)}") from None


def imm_mixing(probability, transition) -> ImmMixing:
    r"""The IMM's mixing probabilities.

    Parameters
    ----------
    probability : array_like, shape (..., M)
        Mode probabilities :math:`\mu_i` after the last update, in [0, 1], summing to 1.
    transition : array_like, shape (..., M, M)
        Markov transition matrix, :math:`\pi_{ij}` at ``[i, j]``; each row sums to 1.

    Returns
    -------
    ImmMixing
        :math:`\bar c_j` and :math:`\mu_{i|j}`.

    Raises
    ------
    ValueError
        A probability outside [0, 1], a row of `transition` or the mode probabilities not
        summing to 1, shapes that do not match.
    TypeError
        Non-numeric input.

    Notes
    -----
    Bayes' rule on the chain: :math:`\bar c_j = \sum_i\pi_{ij}\mu_i` and
    :math:`\mu_{i|j} = P(\text{mode } i \text{ before} \mid j \text{ now})
    = \pi_{ij}\mu_i/\bar c_j`. Bar-Shalom, Li & Kirubarajan (2001), eq. (11.6.6-8).
    A mode no mode can reach (:math:`\bar c_j = 0`) mixes with :math:`\mu_i` itself.

    Examples
    --------
    >>> m = imm_mixing([0.9, 0.1], [[0.95, 0.05], [0.2, 0.8]])
    >>> m.predicted.round(4).tolist(), m.mixing[:, 1].round(4).tolist()
    ([0.875, 0.125], [0.36, 0.64])
    """
    mu, _, _ = _modes_iv(probability)
    T = _transition_iv(transition, mu.shape[-1])
    lead = _lead("`probability`, `transition`", mu.shape[:-1], T.shape[:-2])
    M = mu.shape[-1]
    check_size(math.prod(lead) * M * M, MAX_BATCH, what="batch elements × mode pairs",
               alternative="several calls on slices of the batch")
    cbar, w = mixing_kernel(mu, T)
    return ImmMixing(np.broadcast_to(cbar, (*lead, M)).copy(),
                     np.broadcast_to(w, (*lead, M, M)).copy())


def imm_predict(probability, x, cov, transition, dt, q, *, noise="continuous") -> ImmEstimate:
    r"""IMM prediction: mixing, then each constant-velocity mode predicted by `dt`.

    Parameters
    ----------
    probability : array_like, shape (..., M)
        Mode probabilities after the last update, in [0, 1], summing to 1.
    x : array_like, shape (..., M, 2 d)
        Each mode's state ``[positions, velocities]``, d = 1, 2 or 3.
    cov : array_like, shape (..., M, 2 d, 2 d)
        Each mode's covariance.
    transition : array_like, shape (..., M, M)
        :math:`\Pi` over this interval; rows sum to 1.
    dt : float or array_like, shape (...)
        Interval(s) :math:`\Delta t \ge 0`.
    q : float or array_like, shape (..., M)
        Each mode's process-noise intensity :math:`q_j \ge 0` (as in
        :func:`kalman_predict`).
    noise : {"continuous", "discrete"}, optional
        As in :func:`kalman_predict`.

    Returns
    -------
    ImmEstimate
        :math:`\bar c_j` and each mode's predicted state and covariance.

    Raises
    ------
    ValueError
        As :func:`imm_mixing`, or a state not 2, 4 or 6 long, `cov` not positive definite,
        `dt` or `q` negative, shapes that do not broadcast.
    TypeError
        Non-numeric input.

    Notes
    -----
    Mode :math:`j` starts from :math:`\mathbf x_{0j} = \sum_i\mu_{i|j}\hat{\mathbf x}_i`,
    :math:`P_{0j} = \sum_i\mu_{i|j}\,[P_i + (\hat{\mathbf x}_i - \mathbf x_{0j})
    (\hat{\mathbf x}_i - \mathbf x_{0j})^\mathsf T]`, then
    :math:`F\mathbf x_{0j}`, :math:`FP_{0j}F^\mathsf T + Q(q_j)`. These are exactly the
    moments of the predicted mixture of mode :math:`j`. Bar-Shalom, Li & Kirubarajan
    (2001), sec. 11.6.6.

    Examples
    --------
    >>> r = imm_predict([0.5, 0.5], [[0.0, 1.0], [0.0, 1.0]], [np.eye(2)] * 2,
    ...                 [[0.9, 0.1], [0.1, 0.9]], 1.0, [0.0, 3.0])
    >>> r.state[:, 0].tolist(), r.covariance[:, 0, 0].tolist()
    ([1.0, 1.0], [2.0, 3.0])
    """
    mu, x, cov = _modes_iv(probability, x, cov)
    M = mu.shape[-1]
    T = _transition_iv(transition, M)
    dt = as_positive(dt, "dt", strict=False)
    q = as_positive(q, "q", strict=False)
    noise = as_choice(noise, "noise", ("continuous", "discrete"))
    try:
        q_lead = np.broadcast_shapes(q.shape, (M,))[:-1]
    except ValueError:
        raise ValueError(f"`q` must broadcast against (..., {M}), one intensity per mode; "
                         f"received shape {q.shape}") from None
    lead = _lead("`probability`, `x`, `cov`, `transition`, `dt`, `q` (without the mode axis)",
                 mu.shape[:-1], x.shape[:-2], cov.shape[:-3], T.shape[:-2], dt.shape, q_lead)
    n = x.shape[-1]
    check_size(math.prod(lead) * M * n * n, MAX_BATCH, what="batch elements × modes × state "
               "entries", alternative="several calls on slices of the batch")
    with np.errstate(over="ignore", invalid="ignore"):
        cbar, xp, Pp = imm_predict_kernel(mu, x, cov, T, dt, q, noise)
    check_prediction(xp, Pp, dt, q)
    return ImmEstimate(np.broadcast_to(cbar, (*lead, M)).copy(),
                       np.broadcast_to(xp, (*lead, M, n)).copy(),
                       np.broadcast_to(Pp, (*lead, M, n, n)).copy())


def imm_update(probability, x, cov, z, z_cov) -> ImmEstimate:
    r"""IMM update: each mode's Kalman update with the report, and the mode probabilities.

    Parameters
    ----------
    probability : array_like, shape (..., M)
        Predicted mode probabilities :math:`\bar c_j` (from :func:`imm_predict`).
    x : array_like, shape (..., M, 2 d)
        Each mode's predicted state.
    cov : array_like, shape (..., M, 2 d, 2 d)
        Each mode's predicted covariance.
    z : array_like, shape (..., d)
        The position report (one per batch element, the same for every mode).
    z_cov : array_like, shape (..., d, d)
        Its error covariance.

    Returns
    -------
    ImmEstimate
        :math:`\mu_j`, each mode's updated state and covariance (Joseph form, as
        :func:`kalman_update`) and :math:`\ln\Lambda_j`.

    Raises
    ------
    ValueError
        As :func:`imm_mixing` for `probability`, wrong shapes, a covariance not positive
        definite, non-finite entries.
    TypeError
        Non-numeric input.

    Notes
    -----
    :math:`\Lambda_j = \mathcal N(\mathbf z - H\hat{\mathbf x}_j;\, 0,\, HP_jH^\mathsf T +
    \Sigma)` and :math:`\mu_j = \bar c_j\Lambda_j/\sum_k\bar c_k\Lambda_k`, computed in the
    log domain. Bar-Shalom, Li & Kirubarajan (2001), eqs. (11.6.6-15)–(11.6.6-19).

    Examples
    --------
    >>> r = imm_update([0.5, 0.5], [[0.0, 0.0], [0.0, 0.0]],
    ...                [np.eye(2), 4.0 * np.eye(2)], [3.0], [[1.0]])
    >>> r.probability.round(4).tolist()
    [0.2907, 0.7093]
    """
    mu, x, cov = _modes_iv(probability, x, cov)
    M, n = mu.shape[-1], x.shape[-1]
    d = n // 2
    z = as_float_array(z, "z", ndim_min=1, last_dims=(d,))
    z_cov = as_covariance(z_cov, "z_cov", dim=d)
    lead = _lead("`probability`, `x`, `cov`, `z`, `z_cov` (without the mode axis)", mu.shape[:-1],
                 x.shape[:-2], cov.shape[:-3], z.shape[:-1], z_cov.shape[:-2])
    check_size(math.prod(lead) * M * n * n, MAX_BATCH, what="batch elements × modes × state "
               "entries", alternative="several calls on slices of the batch")
    mu = np.broadcast_to(mu, (*lead, M))
    x, cov = np.broadcast_to(x, (*lead, M, n)), np.broadcast_to(cov, (*lead, M, n, n))
    z, z_cov = np.broadcast_to(z, (*lead, d)), np.broadcast_to(z_cov, (*lead, d, d))
    xn, Pn, loglik, post = imm_update_kernel(mu, x, cov, z, z_cov)
    return ImmEstimate(post, xn, Pn, loglik)


def imm_combine(probability, x, cov) -> KalmanEstimate:
    r"""The IMM's output: the moments of the mode mixture.

    Parameters
    ----------
    probability : array_like, shape (..., M)
        Mode probabilities, in [0, 1], summing to 1.
    x : array_like, shape (..., M, 2 d)
    cov : array_like, shape (..., M, 2 d, 2 d)

    Returns
    -------
    KalmanEstimate
        :math:`\hat{\mathbf x} = \sum_j\mu_j\hat{\mathbf x}_j`,
        :math:`P = \sum_j\mu_j[P_j + (\hat{\mathbf x}_j - \hat{\mathbf x})
        (\hat{\mathbf x}_j - \hat{\mathbf x})^\mathsf T]`.

    Raises
    ------
    ValueError
        As :func:`imm_mixing` for `probability`; wrong shapes; a covariance not positive
        definite.
    TypeError
        Non-numeric input.

    Notes
    -----
    Bar-Shalom, Li & Kirubarajan (2001), eqs. (11.6.6-20), (11.6.6-21).

    Examples
    --------
    >>> r = imm_combine([0.5, 0.5], [[0.0, 0.0], [2.0, 0.0]], [np.eye(2)] * 2)
    >>> r.state.tolist(), r.covariance[0, 0].item()
    ([1.0, 0.0], 2.0)
    """
    mu, x, cov = _modes_iv(probability, x, cov)
    M, n = mu.shape[-1], x.shape[-1]
    lead = _lead("`probability`, `x`, `cov` (without the mode axis)", mu.shape[:-1],
                 x.shape[:-2], cov.shape[:-3])
    check_size(math.prod(lead) * M * n * n, MAX_BATCH, what="batch elements × modes × state "
               "entries", alternative="several calls on slices of the batch")
    mu = np.broadcast_to(mu, (*lead, M))
    x, cov = np.broadcast_to(x, (*lead, M, n)), np.broadcast_to(cov, (*lead, M, n, n))
    return KalmanEstimate(*combine_kernel(mu, x, cov))
