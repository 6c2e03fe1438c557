"""Track fusion: the constant-velocity model, the cross-covariance of two filters and
simulated tracks (tracks are predicted by
:func:`radarfusion_ref.engine.tracker.kalman_predict`)."""

from __future__ import annotations

import numpy as np
from scipy import linalg

from ..engine.tracker import check_prediction, cv_matrices
from ..engine.validation import (
    as_choice,
    as_covariance,
    as_float_array,
    as_int,
    as_positive,
    as_rng,
    check_size,
)
from ._common import (
    MAX_BATCH,
    MAX_DIM,
    MotionModel,
    TrackCovariances,
    TrackRuns,
    _as_psd,
    _joint_psd,
    _solve,
    _sym,
)


# --------------------------------------------------------------------------- motion model
def constant_velocity(dt, q, *, dim=1, noise="continuous") -> MotionModel:
    r"""The constant-velocity model over an interval `dt`, state ``[positions, velocities]``.

    Parameters
    ----------
    dt : float or array_like
        Time interval(s) :math:`\Delta t \ge 0`.
    q : float or array_like
        Process-noise intensity :math:`q \ge 0`: the power spectral density of the
        white acceleration (``"continuous"``, units length²/time³) or the variance of
        the acceleration held constant over each interval (``"discrete"``, length²/time⁴).
    dim : int, optional
        Number of spatial coordinates (1, 2 or 3). The state is
        :math:`(p_1, \dots, p_{\text{dim}}, v_1, \dots, v_{\text{dim}})`.
    noise : {"continuous", "discrete"}, optional
        Continuous white-noise acceleration (default) or piecewise-constant
        (discrete white-noise) acceleration.

    Returns
    -------
    MotionModel
        ``F`` and ``Q``, shape ``(..., 2 dim, 2 dim)`` broadcast over `dt` and `q`.

    Raises
    ------
    ValueError
        If `dt` or `q` is negative or not finite, `dim` not in 1..3 or `noise` unknown.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    Per coordinate, with :math:`\Delta t` the interval,

    .. math::

        F = \begin{pmatrix}1 & \Delta t\\ 0 & 1\end{pmatrix}, \qquad
        Q_{\text{cont}} = q\begin{pmatrix}\Delta t^3/3 & \Delta t^2/2\\ \Delta t^2/2 & \Delta t\end{pmatrix}, \qquad
        Q_{\text{disc}} = q\begin{pmatrix}\Delta t^4/4 & \Delta t^3/2\\ \Delta t^3/2 & \Delta t^2\end{pmatrix}.

    The continuous model composes exactly: predicting over :math:`\Delta t_1` then
    :math:`\Delta t_2` equals predicting over :math:`\Delta t_1 + \Delta t_2`.

    References
    ----------
    Bar-Shalom, Li & Kirubarajan (2001), eqs. (6.2.3-8) and (6.3.2-4).

    Examples
    --------
    >>> m = constant_velocity(2.0, 3.0)
    >>> m.F
    array([[1., 2.],
           [0., 1.]])
    >>> m.Q
    array([[8., 6.],
           [6., 6.]])
    """
    dt = as_positive(dt, "dt", strict=False)
    q = as_positive(q, "q", strict=False)
    dim = as_int(dim, "dim", minimum=1, maximum=3)
    noise = as_choice(noise, "noise", ("continuous", "discrete"))
    try:
        dt, q = np.broadcast_arrays(dt, q)
    except ValueError:
        raise ValueError(f"`dt`, `q` must broadcast to a common shape; received shapes "
                         f"{np.shape(dt)}, {np.shape(q)}") from None
    check_size(dt.size * 4 * dim * dim, MAX_BATCH, what="model entries",
               alternative="several calls on slices of `dt`")
    with np.errstate(over="ignore", invalid="ignore"):
        model = MotionModel(*cv_matrices(dt, q, dim, noise))
    check_prediction(model.F[..., 0, :], model.Q, dt, q)
    return model


# --------------------------------------------------------------------------- cross-covariance
def _model_iv(F, Q, H1, R1, H2, R2):
    F = as_float_array(F, "F", ndim_min=2)
    d = F.shape[-1]
    if F.shape[-2] != d or d < 1:
        raise ValueError(f"`F` must have shape (..., d, d); received shape {F.shape}")
    if d > MAX_DIM:
        raise ValueError(f"`F`: state dimension {d} above the limit MAX_DIM = {MAX_DIM}")
    Q = _as_psd(Q, "Q", dim=d)
    out = {"F": F, "Q": Q}
    for hn, rn, H, R in (("H1", "R1", H1, R1), ("H2", "R2", H2, R2)):
        H = as_float_array(H, hn, ndim_min=2, last_dims=(None, d))
        if H.shape[-2] < 1:
            raise ValueError(f"`{hn}` must have shape (..., p, {d}) with p >= 1; received "
                             f"shape {H.shape}")
        out[hn] = H
        out[rn] = as_covariance(R, rn, dim=H.shape[-2])
    try:
        lead = np.broadcast_shapes(*(v.shape[:-2] for v in out.values()))
    except ValueError:
        shapes = ", ".join(str(v.shape) for v in out.values())
        raise ValueError("`F`, `Q`, `H1`, `R1`, `H2`, `R2` must have broadcasting batch "
                         f"shapes; received {shapes}") from None
    return lead, d, {k: np.broadcast_to(v, (*lead, *v.shape[-2:])) for k, v in out.items()}


def _update(M, H, R, name):
    """Kalman update of a predicted covariance M: gain K and Joseph-form covariance.

    `name` is the public argument of `R` (for the refusal of a singular innovation covariance)."""
    S = _sym(H @ M @ np.swapaxes(H, -1, -2) + R)                       # H M Hᵀ + Σ
    K = np.swapaxes(_solve(S, H @ M, name), -1, -2)                    # M Hᵀ S^-1
    A = np.eye(M.shape[-1]) - K @ H                                    # I - K H
    P = _sym(A @ M @ np.swapaxes(A, -1, -2) + K @ R @ np.swapaxes(K, -1, -2))
    return K, A, P


def _steady(F, Q, H, R, name):
    """Steady-state predicted covariance by the discrete algebraic Riccati equation."""
    flat = [a.reshape(-1, *a.shape[-2:]) for a in (F, Q, H, R)]
    out = np.empty(flat[0].shape)
    for i, (f, q, h, r) in enumerate(zip(*flat, strict=True)):
        try:
            m = linalg.solve_discrete_are(f.T, h.T, q, r)
        except (np.linalg.LinAlgError, ValueError):
            m = np.full(f.shape, np.nan)
        if not np.all(np.isfinite(m)):
            raise ValueError(f"`{name}`: the Riccati equation of this filter has no stabilising "
                             "solution (the model is not detectable/stabilisable, e.g. Q = 0); "
                             "no steady state exists — pass `steps` for the recursion")
        out[i] = m
    return _sym(out.reshape(F.shape))


def cross_covariance(F, Q, H1, R1, H2, R2, *, steps=None, P1_0=None, P2_0=None,
                     P12_0=None) -> TrackCovariances:
    r"""Covariances and cross-covariance of two Kalman filters tracking one object.

    Parameters
    ----------
    F, Q : array_like, shape (..., d, d)
        The motion model :math:`\mathbf x_k = F\mathbf x_{k-1} + \mathbf w_k`,
        :math:`\mathbf w_k \sim \mathcal N(0, Q)` (``Q`` positive semi-definite), shared by
        the object and both filters.
    H1, R1, H2, R2 : array_like, shapes (..., p_i, d) and (..., p_i, p_i)
        Radar *i* measures :math:`\mathbf z_i = H_i\mathbf x + \mathbf v_i`,
        :math:`\mathbf v_i \sim \mathcal N(0, \Sigma_i)` (``R_i`` = :math:`\Sigma_i`,
        positive definite), independent of the other radar and of :math:`\mathbf w`.
    steps : int, optional
        ``None`` (default): the steady state. An integer :math:`k \ge 1`: the first
        :math:`k` steps of the recursion from the initial covariances.
    P1_0, P2_0 : array_like, shape (..., d, d)
        Initial (updated) covariances of the two tracks; required with `steps`.
    P12_0 : array_like, shape (..., d, d), optional
        Initial cross-covariance (default 0: independently initialised tracks). The
        joint covariance ``[[P1_0, P12_0], [P12_0ᵀ, P2_0]]`` must be PSD.

    Returns
    -------
    TrackCovariances
        ``P1``, ``P2``, ``P12``, ``K1``, ``K2``.

    Raises
    ------
    ValueError
        If a matrix has the wrong shape, ``Q`` is not PSD or an ``R`` not positive
        definite, `steps` is given without ``P1_0``/``P2_0``, the initial joint
        covariance is not PSD, no steady state exists, or the batch is too large.
    TypeError
        If an argument is not numeric.

    Notes
    -----
    Track *i*'s error :math:`\mathbf e_i = \hat{\mathbf x}_i - \mathbf x` obeys
    :math:`\mathbf e_i(k) = A_i(F\mathbf e_i(k-1) - \mathbf w_k) + K_i\mathbf v_i(k)` with
    :math:`A_i = I - K_iH_i`. The common :math:`\mathbf w_k` gives

    .. math::

        P_{12}(k) = A_1\,\big(F P_{12}(k-1) F^\mathsf T + Q\big)\,A_2^\mathsf T,

    beside each track's own :math:`P_i(k) = A_i(FP_i(k-1)F^\mathsf T + Q)A_i^\mathsf T +
    K_i\Sigma_iK_i^\mathsf T`. The steady state takes the Riccati solution of each
    filter (:func:`scipy.linalg.solve_discrete_are`) and solves the linear equation
    :math:`P_{12} = A_1(FP_{12}F^\mathsf T + Q)A_2^\mathsf T` for :math:`P_{12}` by
    vectorisation, :math:`(I - (A_2F)\otimes(A_1F))\operatorname{vec}P_{12} =
    \operatorname{vec}(A_1QA_2^\mathsf T)`.

    References
    ----------
    Bar-Shalom (1981), eq. (4); Bar-Shalom & Campo (1986), eq. (5).

    Examples
    --------
    >>> m = constant_velocity(1.0, 1.0, noise="discrete")
    >>> H = [[1.0, 0.0]]
    >>> c = cross_covariance(m.F, m.Q, H, [[1.0]], H, [[1.0]])
    >>> c.P1.round(4)
    array([[0.75, 0.5 ],
           [0.5 , 1.  ]])
    >>> round(float(c.correlation[0]), 4)
    0.1111
    """
    lead, d, m = _model_iv(F, Q, H1, R1, H2, R2)
    F, Q = m["F"], m["Q"]
    Ft = np.swapaxes(F, -1, -2)
    if steps is None:
        for name in ("P1_0", "P2_0", "P12_0"):
            if locals()[name] is not None:
                raise ValueError(f"`{name}` is only used with `steps` (the steady state does "
                                 "not depend on the initial covariances)")
        check_size(int(np.prod(lead, dtype=object)) * d**4, MAX_BATCH,
                   what="entries of the steady-state systems (batch × d⁴)",
                   alternative="several calls on slices of the batch")
        K1, A1, P1 = _update(_steady(F, Q, m["H1"], m["R1"], "R1"), m["H1"], m["R1"], "R1")
        K2, A2, P2 = _update(_steady(F, Q, m["H2"], m["R2"], "R2"), m["H2"], m["R2"], "R2")
        B1, B2 = A1 @ F, A2 @ F
        # vec(B1 X B2ᵀ) = (B1 ⊗ B2) vec(X) for row-major vec
        kron = np.einsum("...ij,...kl->...ikjl", B1, B2).reshape(*lead, d * d, d * d)
        rhs = (A1 @ Q @ np.swapaxes(A2, -1, -2)).reshape(*lead, d * d, 1)
        try:
            P12 = np.linalg.solve(np.eye(d * d) - kron, rhs).reshape(*lead, d, d)
        except np.linalg.LinAlgError:
            raise ValueError("`F`: the cross-covariance recursion has no unique steady state "
                             "(a closed-loop filter is not stable)") from None
        return TrackCovariances(P1, P2, P12, K1, K2)
    steps = as_int(steps, "steps", minimum=1)
    if P1_0 is None or P2_0 is None:
        raise ValueError("`P1_0` and `P2_0` (the initial covariances) are required with `steps`")
    check_size(int(np.prod(lead, dtype=object)) * steps * d * (3 * d + 2 * 3), MAX_BATCH,
               what="stored entries (batch × `steps` × state)",
               alternative="fewer `steps` or several calls on slices of the batch")
    P1 = np.broadcast_to(as_covariance(P1_0, "P1_0", dim=d), (*lead, d, d))
    P2 = np.broadcast_to(as_covariance(P2_0, "P2_0", dim=d), (*lead, d, d))
    if P12_0 is None:
        P12 = np.zeros((*lead, d, d))
    else:
        P12 = np.broadcast_to(as_float_array(P12_0, "P12_0", ndim_min=2, last_dims=(d, d)),
                              (*lead, d, d))
        _joint_psd(P1, P2, P12, names=("P1_0", "P2_0", "P12_0"))
    hist = {k: [] for k in ("P1", "P2", "P12", "K1", "K2")}
    for _ in range(steps):
        K1, A1, P1 = _update(F @ P1 @ Ft + Q, m["H1"], m["R1"], "R1")
        K2, A2, P2 = _update(F @ P2 @ Ft + Q, m["H2"], m["R2"], "R2")
        P12 = A1 @ (F @ P12 @ Ft + Q) @ np.swapaxes(A2, -1, -2)    # common process noise only
        for k, v in zip(hist, (P1, P2, P12, K1, K2), strict=True):
            hist[k].append(v)
    out = {k: np.stack(v, axis=-3) for k, v in hist.items()}
    if not all(np.all(np.isfinite(v)) for v in out.values()):
        raise ValueError("`F`: the covariances overflow float64 within `steps` steps")
    return TrackCovariances(**out)


def simulate_tracks(F, Q, H1, R1, H2, R2, *, steps, trials, P1_0, P2_0, x0=None,
                    rng=None) -> TrackRuns:
    r"""Monte-Carlo runs of two Kalman filters tracking one simulated object.

    Parameters
    ----------
    F, Q, H1, R1, H2, R2 : array_like
        One model, as in :func:`cross_covariance` (no batch axes).
    steps : int
        Number of measurement updates per run.
    trials : int
        Number of independent runs.
    P1_0, P2_0 : array_like, shape (d, d)
        Covariances of the two filters' initial errors, drawn independently
        (so :math:`P_{12}(0) = 0`).
    x0 : array_like, shape (d,), optional
        The object's initial state (default 0; the errors do not depend on it).
    rng : None, int, SeedSequence or numpy.random.Generator, optional
        Source of randomness (SPEC 7).

    Returns
    -------
    TrackRuns

    Raises
    ------
    ValueError
        For the reasons of :func:`cross_covariance`, if a model argument has batch
        axes, or the run is too large.
    TypeError
        If an argument is not numeric or `rng` is not a valid generator.

    Notes
    -----
    Per step: :math:`\mathbf x_k = F\mathbf x_{k-1} + \mathbf w_k`; each radar measures
    :math:`\mathbf z_i = H_i\mathbf x_k + \mathbf v_i`; each filter predicts and updates
    with its gain :math:`K_i(k)` from :func:`cross_covariance`.

    Examples
    --------
    >>> m = constant_velocity(1.0, 1.0)
    >>> runs = simulate_tracks(m.F, m.Q, [[1.0, 0.0]], [[1.0]], [[1.0, 0.0]], [[1.0]],
    ...                        steps=5, trials=3, P1_0=np.eye(2), P2_0=np.eye(2), rng=1)
    >>> runs.error1.shape
    (3, 5, 2)
    """
    trials = as_int(trials, "trials", minimum=1)
    steps = as_int(steps, "steps", minimum=1)
    lead, d, m = _model_iv(F, Q, H1, R1, H2, R2)
    if lead:
        raise ValueError(f"`F`, `Q`, `H1`, `R1`, `H2`, `R2` must be single matrices (no batch "
                         f"axes) in simulate_tracks; received batch shape {lead}")
    check_size(trials * steps * d * 3, MAX_BATCH, what="simulated entries "
               "(`trials` × `steps` × state × 3)", alternative="fewer `trials` per call, pooling "
               "calls seeded from SeedSequence.spawn")
    cov = cross_covariance(F, Q, H1, R1, H2, R2, steps=steps, P1_0=P1_0, P2_0=P2_0)
    x = np.zeros(d) if x0 is None else as_float_array(x0, "x0", last_dims=(d,))
    if x.shape != (d,):
        raise ValueError(f"`x0` must have shape ({d},); received shape {x.shape}")
    g = as_rng(rng)
    F, Q = m["F"], m["Q"]
    lam, vec = np.linalg.eigh(Q)                            # Q = V diag(l) Vᵀ (may be singular)
    q_root = vec * np.sqrt(np.clip(lam, 0, None))
    roots = {k: np.linalg.cholesky(m[k]) for k in ("R1", "R2")}
    P10, P20 = as_covariance(P1_0, "P1_0", dim=d), as_covariance(P2_0, "P2_0", dim=d)
    truth = np.broadcast_to(x, (trials, d)).copy()
    est1 = truth + g.standard_normal((trials, d)) @ np.linalg.cholesky(P10).T
    est2 = truth + g.standard_normal((trials, d)) @ np.linalg.cholesky(P20).T
    out = np.empty((3, trials, steps, d))
    for k in range(steps):
        truth = truth @ F.T + g.standard_normal((trials, d)) @ q_root.T
        for i, (est, H, R, K) in enumerate(((est1, m["H1"], "R1", cov.K1[k]),
                                            (est2, m["H2"], "R2", cov.K2[k]))):
            z = truth @ H.T + g.standard_normal((trials, H.shape[0])) @ roots[R].T
            pred = est @ F.T                                # F x̂(k-1)
            new = pred + (z - pred @ H.T) @ K.T             # + K (z - H F x̂(k-1))
            est1, est2 = (new, est2) if i == 0 else (est1, new)
        out[0, :, k], out[1, :, k], out[2, :, k] = truth, est1, est2
    return TrackRuns(out[0], out[1], out[2], cov)
