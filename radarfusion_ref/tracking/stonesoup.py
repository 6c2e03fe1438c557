r"""Stone Soup's trackers on the same reports: the anchor the book's tracker is compared with.

:func:`stonesoup_track` runs Stone Soup's ``MultiTargetTracker`` (global nearest neighbour)
or ``MultiTargetMixtureTracker`` (JPDA, by ``JPDAwithEHM2`` or plain enumeration) on
reports already in the common frame, configured as Stone Soup's own tutorials configure
them, and returns a :class:`~radarfusion_ref.tracking.TrackHistory` like
:func:`~radarfusion_ref.tracking.track_reports`. Stone Soup is imported only when called.

.. rubric:: References

.. [1] D. Barr et al., "Stone Soup: announcement of beta release of an open-source
   framework for tracking and state estimation", Proc. SPIE 11018 (2019); the tutorials
   "Multi-target tracking: data association" and "Joint probabilistic data association"
   of its documentation.
"""

from __future__ import annotations

import datetime as dt
import functools
import itertools
import math

import numpy as np

from ..engine.optional import require
from ..engine.validation import (
    as_bool,
    as_choice,
    as_float,
    as_float_array,
    as_positive,
    describe,
)
from ._motion import axis_q, velocity_sd
from ._settings import TrackerSettings, TrackHistory, _in_unit

__all__ = ["HOLD_DEFAULT", "STONESOUP_TRACKERS", "stonesoup_track"]

#: Trackers of :func:`stonesoup_track`.
STONESOUP_TRACKERS = ("gnn", "jpda", "jpda_enumerate")

#: The initiator's hold time when `hold` is None: this many revisits of the slowest radar.
HOLD_DEFAULT = 1.5
#: Stone Soup state order [x, vx, y, vy, z, vz] -> ours [x, y, z, vx, vy, vz].
_TO_OURS = np.array([0, 2, 4, 1, 3, 5])
#: An arbitrary epoch: Stone Soup's clock needs dates; seconds are added to it.
_EPOCH = dt.datetime(2018, 8, 1, 11, 0, 0)


def _import():
    require("stonesoup", feature="stonesoup_track")


def _inputs_iv(time, position, cov, radar, scan):
    t = as_float_array(time, "time")
    x = as_float_array(position, "position", ndim_min=2, last_dims=(3,))
    P = as_float_array(cov, "cov", ndim_min=3, last_dims=(3, 3))
    n = t.size
    if t.ndim != 1 or x.shape != (n, 3) or P.shape != (n, 3, 3):
        raise ValueError(f"`time` (N,), `position` (N, 3) and `cov` (N, 3, 3) must "
                         f"describe the same N reports; received shapes {t.shape}, {x.shape}, "
                         f"{P.shape}")
    ints = []
    for name, v in (("radar", radar), ("scan", scan)):
        a = np.asarray(v)
        if a.dtype.kind not in "iu" or a.shape != (n,):
            raise ValueError(f"`{name}` must be N = {n} integers; received {describe(v)}")
        ints.append(a.astype(np.int64))
    if n and np.any(np.diff(t) < 0):
        k = int(np.flatnonzero(np.diff(t) < 0)[0])
        raise ValueError(f"`time` must be in time order (non-decreasing), as the reports "
                         f"arrive; received time[{k}] = {float(t[k])!r} > time[{k + 1}] = "
                         f"{float(t[k + 1])!r} (sort by (time, radar) first)")
    return t, x, P, ints[0], ints[1]


def _steps(t, x, P, radar, scan, Detection, LinearGaussian):
    """One step per radar scan, in time order: (datetime, set of Detection)."""
    key = np.stack([t, radar, scan], axis=1)
    change = np.flatnonzero(np.any(np.diff(key, axis=0) != 0, axis=1)) + 1
    bounds = np.concatenate([[0], change, [t.size]])
    for lo, hi in itertools.pairwise(bounds):
        when = _EPOCH + dt.timedelta(seconds=float(t[lo]))
        yield when, {Detection(x[k].reshape(3, 1), timestamp=when,
                               measurement_model=LinearGaussian(ndim_state=6, mapping=(0, 2, 4),
                                                                noise_covar=P[k]))
                     for k in range(lo, hi)}


@functools.cache
def _pregate_class():
    """A Stone Soup hypothesiser that drops, before its inner hypothesiser sees them, the
    detections outside the Mahalanobis gate of the track's prediction (made once here)."""
    from stonesoup.base import Property
    from stonesoup.hypothesiser.base import Hypothesiser
    from stonesoup.predictor.base import Predictor

    class PreGate(Hypothesiser):
        """Hypotheses of the inner hypothesiser for the detections inside the gate only."""

        hypothesiser: Hypothesiser = Property(doc="The hypothesiser given the gated detections")
        predictor: Predictor = Property(doc="The predictor the inner hypothesiser uses")
        gate_sq: float = Property(doc="Squared Mahalanobis gate (chi-square quantile)")

        def hypothesise(self, track, detections, timestamp, **kwargs):
            if detections:
                pred = self.predictor.predict(track, timestamp=timestamp)
                dets = list(detections)
                x = np.asarray(pred.state_vector, dtype=float).ravel()[[0, 2, 4]]
                Pp = np.asarray(pred.covar, dtype=float)[np.ix_([0, 2, 4], [0, 2, 4])]
                z = np.array([np.asarray(d.state_vector, dtype=float).ravel() for d in dets])
                R = np.array([d.measurement_model.noise_covar for d in dets], dtype=float)
                e = z - x
                m2 = np.einsum("ka,ka->k", e, np.linalg.solve(Pp + R, e[..., None])[..., 0])
                # a margin: a detection on the gate's edge is left to the inner hypothesiser
                detections = {d for d, k in zip(dets, m2 <= 1.001 * self.gate_sq, strict=True)
                              if k}
            return self.hypothesiser.hypothesise(track, detections, timestamp, **kwargs)

    return PreGate


def stonesoup_track(time, position, cov, radar, scan, *, tracker="gnn",
                    settings=None, pregate=True, hold=None) -> TrackHistory:
    r"""Stone Soup's GNN or JPDA tracker on reports in the common frame.

    Parameters
    ----------
    time : array_like, shape (N,)
        Report instants (s), non-decreasing (as :func:`radarfusion_ref.capstone.
        simulate_detections` sorts them).
    position, cov : array_like, shape (N, 3) and (N, 3, 3)
        Reports in the common frame and their covariances
        (:func:`radarfusion_ref.capstone.to_common`).
    radar, scan : array_like of int, shape (N,)
        Each report's radar and that radar's scan number: the reports of one radar scan
        are fed to Stone Soup as one step.
    tracker : {"gnn", "jpda", "jpda_enumerate"}, optional
        ``"gnn"`` (default): ``MultiTargetTracker`` with ``GNNWith2DAssignment`` over a
        ``DistanceHypothesiser``; ``"jpda"``: ``MultiTargetMixtureTracker`` with
        ``JPDAwithEHM2`` (efficient hypothesis management: the same probabilities as the
        enumeration without listing the joint events) over a gated ``PDAHypothesiser``;
        ``"jpda_enumerate"``: the same with Stone Soup's plain ``JPDA``.
    settings : TrackerSettings, optional
        The settings of the book's tracker, matched: :math:`P_D`, clutter density, gate,
        process noise, new-track velocity spread, coasting time, and `m` as the
        initiator's points.
    pregate : bool, optional
        Drop each track's detections outside its Mahalanobis gate before Stone Soup's
        hypothesiser sees them (default True). The gated-out detections could never be
        chosen (GNN: farther than the missed distance; JPDA: removed by the gater), so
        the tracks are the same as without it, and Stone Soup's per-pair work falls from
        every track x every detection of a scan to the pairs inside the gates. ``False``:
        Stone Soup's configuration alone.
    hold : float, optional
        How long the initiator keeps a tentative track without an update before it forgets
        it, in revisits of the slowest radar (the median spacing of one radar's scans):
        a number > 0, the time capped at `settings.max_coast`. None (default):
        ``HOLD_DEFAULT`` (1.5) revisits. With `settings.m` (the initiator's ``min_points``),
        `settings.max_coast` (the deleter) and `settings.p_false_reject` (the missed
        distance, the gate) it is what a Stone Soup user tunes of track management;
        it plays the part of `settings.max_coast_tentative`, which is not read here.

    Returns
    -------
    TrackHistory
        One row per (track, update), sorted by (time, track), covariances symmetrised;
        `confirmed` from the update at which Stone Soup's initiator released the track;
        `initiated` the tracks started (held ones included).

    Raises
    ------
    ImportError
        If Stone Soup is not installed (the message says how to get it).
    TypeError
        `settings` not a :class:`~radarfusion_ref.tracking.TrackerSettings`, non-numeric
        arrays.
    ValueError
        Arrays that do not describe the same reports, non-finite values, reports out of
        time order (refused: sort them), an unknown `tracker`, a `hold` not > 0.

    Notes
    -----
    The configuration follows Stone Soup's tutorials: a constant-velocity model per axis
    (``ConstantVelocity(q)``, continuous white-noise acceleration of intensity
    :math:`q`; vertically `q_vertical` if set), combined into one model whose transition
    and noise matrices are kept per time interval (an experienced user's configuration
    choice: Stone Soup's ``CombinedLinearGaussianTransitionModel`` rebuilds both
    block-diagonal matrices for every track at every scan, about 40 % of an hour's run;
    the kept matrices are Stone Soup's own, so the tracks are the same bit for bit), a
    Kalman predictor and updater (its Joseph form, symmetrised: the plain
    form leaves some covariances indefinite over an hour), each report with its own
    ``LinearGaussian`` measurement model (its covariance), Mahalanobis gating at
    :math:`\sqrt{\gamma}` with :math:`\gamma` the :math:`\chi^2_3` quantile of
    ``1 - p_false_reject`` (GNN: the hypothesiser's missed distance; JPDA: a
    ``DistanceGater`` around a ``PDAHypothesiser`` with the clutter density and
    :math:`P_D`), the ``MultiMeasurementInitiator`` (new tracks from single reports with
    velocity spread `speed_max`, vertically `speed_max_vertical` if set, released after `m` updates, held ones forgotten after
    `hold` revisits of the slowest radar), and the ``UpdateTimeDeleter`` at `max_coast`
    seconds without an update — the closest of Stone Soup's initiators and deleters to
    the book's M-of-N start and coasting limit.
    """
    t, x, P, radar, scan = _inputs_iv(time, position, cov, radar, scan)
    tracker = as_choice(tracker, "tracker", STONESOUP_TRACKERS)
    if settings is None:
        settings = TrackerSettings()
    if not isinstance(settings, TrackerSettings):
        raise TypeError(f"`settings` must be a TrackerSettings or None; received "
                        f"{describe(settings)}")
    pregate = as_bool(pregate, "pregate")
    if hold is None:
        hold = HOLD_DEFAULT
    elif isinstance(hold, bool) or not isinstance(hold, (int, float, np.integer, np.floating)):
        raise TypeError(f"`hold` must be a number of revisits of the slowest radar (> 0) or "
                        f"None; received {describe(hold)}")
    hold = as_float(as_positive(hold, "hold"), "hold")
    if settings.motion != "cv":
        raise ValueError(f"`settings`: the Stone Soup adapter runs the constant-velocity model "
                         f"(Stone Soup has no interacting multiple model); received "
                         f"motion={settings.motion!r}, use 'cv'")
    _import()                                     # bad input is refused first, by name
    from scipy import stats
    from stonesoup.dataassociator.neighbour import GNNWith2DAssignment
    from stonesoup.dataassociator.probability import JPDA, JPDAwithEHM2
    from stonesoup.deleter.time import UpdateTimeDeleter
    from stonesoup.gater.distance import DistanceGater
    from stonesoup.hypothesiser.distance import DistanceHypothesiser
    from stonesoup.hypothesiser.probability import PDAHypothesiser
    from stonesoup.initiator.simple import MultiMeasurementInitiator, SimpleMeasurementInitiator
    from stonesoup.measures import Mahalanobis
    from stonesoup.models.measurement.linear import LinearGaussian
    from stonesoup.predictor.kalman import KalmanPredictor
    from stonesoup.tracker.simple import MultiTargetMixtureTracker, MultiTargetTracker
    from stonesoup.types.detection import Detection
    from stonesoup.types.state import GaussianState
    from stonesoup.types.update import Update
    from stonesoup.updater.kalman import KalmanUpdater

    x, P = x * settings.length_unit, P * settings.length_unit**2     # metres
    predictor = KalmanPredictor(_transition_model(settings))
    # the Joseph form, symmetrised: over an hour the plain P - K S K^T form leaves some
    # covariances indefinite (40 of 40 195 rows of the GNN hour)
    updater = KalmanUpdater(measurement_model=None, use_joseph_cov=True,
                            force_symmetric_covariance=True)
    gate = math.sqrt(float(stats.chi2.isf(settings.p_false_reject, 3)))

    def gated(hypothesiser):
        if not pregate:
            return hypothesiser
        return _pregate_class()(hypothesiser=hypothesiser, predictor=predictor,
                                gate_sq=gate**2)

    gnn = GNNWith2DAssignment(gated(DistanceHypothesiser(
        predictor, updater, measure=Mahalanobis(), missed_distance=gate)))
    prior = GaussianState(np.zeros((6, 1)), _prior_covariance(settings))
    started = [0]

    class _Counting(SimpleMeasurementInitiator):
        def initiate(self, detections, timestamp, **kwargs):
            out = super().initiate(detections, timestamp, **kwargs)
            started[0] += len(out)
            return out

    # revisit of the slowest radar: the spacing of one radar's scans, at most max_coast
    revisit = 0.0
    for i in np.unique(radar):
        ti = np.unique(t[radar == i])
        if ti.size > 1:
            revisit = max(revisit, float(np.median(np.diff(ti))))
    hold_s = min(hold * revisit if revisit else settings.max_coast, settings.max_coast)
    initiator = MultiMeasurementInitiator(
        prior_state=prior, deleter=UpdateTimeDeleter(dt.timedelta(seconds=hold_s)),
        data_associator=gnn, updater=updater, min_points=settings.m,
        initiator=_Counting(prior_state=prior, measurement_model=None))
    deleter = UpdateTimeDeleter(dt.timedelta(seconds=settings.max_coast))
    steps = _steps(t, x, P, radar, scan, Detection, LinearGaussian)
    if tracker == "gnn":
        run = MultiTargetTracker(initiator=initiator, deleter=deleter, detector=steps,
                                 data_associator=gnn, updater=updater)
    else:
        pda = PDAHypothesiser(predictor=predictor, updater=updater,
                              clutter_spatial_density=settings.clutter_density,
                              prob_detect=settings.p_detection,
                              prob_gate=1.0 - settings.p_false_reject)
        hyp = gated(DistanceGater(pda, measure=Mahalanobis(), gate_threshold=gate))
        assoc = JPDAwithEHM2(hyp) if tracker == "jpda" else JPDA(hyp)
        run = MultiTargetMixtureTracker(initiator=initiator, deleter=deleter, detector=steps,
                                        data_associator=assoc, updater=updater)
    every = set()
    for _, tracks in run:
        every |= tracks
    return _in_unit(_history(every, settings.m, started[0], Update), settings.length_unit)


def _transition_model(settings, cached=True):
    r"""Stone Soup's transition model of `settings`: one ``ConstantVelocity`` per axis, each
    with its own intensity (:func:`~radarfusion_ref.tracking._motion.axis_q`), combined;
    `cached`: Stone Soup's combined model with :math:`F(\Delta t)` and :math:`Q(\Delta t)`
    kept per interval (:func:`_cached_model_class`), else Stone Soup's own class."""
    from stonesoup.models.transition.linear import (
        CombinedLinearGaussianTransitionModel,
        ConstantVelocity,
    )
    cls = _cached_model_class() if cached else CombinedLinearGaussianTransitionModel
    return cls([ConstantVelocity(float(q)) for q in axis_q(settings)])


@functools.cache
def _cached_model_class():
    """Stone Soup's ``CombinedLinearGaussianTransitionModel`` that keeps the matrices it
    computed: the same ``matrix`` and ``covar`` (Stone Soup's own computation, once per time
    interval), returned as copies. Every track predicted over the same interval (all the
    tracks updated by one scan, predicted to the next) reuses them instead of rebuilding
    the block-diagonal matrices (made once here)."""
    from stonesoup.models.transition.linear import CombinedLinearGaussianTransitionModel

    class CachedCombinedLinearGaussianTransitionModel(CombinedLinearGaussianTransitionModel):
        """The combined linear Gaussian model with F and Q kept per time interval."""

        _SIZE = 4096                     # intervals kept; the store is emptied beyond it

        def _kept(self, which, compute, kwargs):
            store = self.__dict__.setdefault("_kept_matrices", {})
            key = (which, kwargs.get("time_interval"))
            if set(kwargs) - {"time_interval", "prior"}:
                return compute(**kwargs)            # anything else: Stone Soup's own route
            if key not in store:
                if len(store) >= self._SIZE:
                    store.clear()
                store[key] = compute(**kwargs)
            return store[key].copy()

        def matrix(self, **kwargs):
            return self._kept("F", super().matrix, kwargs)

        def covar(self, **kwargs):
            return self._kept("Q", super().covar, kwargs)

    return CachedCombinedLinearGaussianTransitionModel


def _prior_covariance(settings):
    """The initiator's prior covariance in Stone Soup's order (x, vx, y, vy, z, vz)."""
    v = velocity_sd(settings) ** 2
    return np.diag([0.0, v[0], 0.0, v[1], 0.0, v[2]])


def _history(tracks, min_points, initiated, Update):
    rows = []
    def first(tr):                    # identities in order of birth, then of place (no uuid)
        s0 = tr.states[0]
        return (s0.timestamp, *np.asarray(s0.state_vector, dtype=float).ravel().tolist())

    for ident, track in enumerate(sorted(tracks, key=first)):
        n_up = 0
        for s in track.states:
            if not isinstance(s, Update):
                continue
            n_up += 1
            sec = (s.timestamp - _EPOCH).total_seconds()
            sv = np.asarray(s.state_vector, dtype=float).ravel()[_TO_OURS]
            cv = np.asarray(s.covar, dtype=float)[np.ix_(_TO_OURS, _TO_OURS)]
            cv = 0.5 * (cv + cv.T)          # Stone Soup's update leaves rounding asymmetry
            rows.append((sec, ident, sv, cv, n_up >= min_points))
    if not rows:
        return TrackHistory(track=np.zeros(0, dtype=np.int64), time=np.zeros(0),
                            state=np.zeros((0, 6)), covariance=np.zeros((0, 6, 6)),
                            confirmed=np.zeros(0, dtype=bool),
                            initiated=initiated)
    rows.sort(key=lambda r: (r[0], r[1]))
    sec, ident, sv, cv, conf = zip(*rows, strict=True)
    return TrackHistory(track=np.array(ident, dtype=np.int64), time=np.array(sec),
                        state=np.stack(sv), covariance=np.stack(cv),
                        confirmed=np.array(conf, dtype=bool),
                        initiated=initiated)
