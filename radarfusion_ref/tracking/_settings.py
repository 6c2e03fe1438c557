"""The tracker's settings and its output: :class:`TrackerSettings` and :class:`TrackHistory`."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..engine.tracker import sprt_thresholds
from ..engine.validation import (
    as_bool,
    as_choice,
    as_float,
    as_float_array,
    as_int,
    as_positive,
    as_probability,
)

#: Association rules of the tracker.
ASSOCIATIONS = ("gnn", "jpda")
#: Confirmation logics of the tracker.
CONFIRMATIONS = ("sprt", "m_of_n")
#: Names of the six state components of a track (:meth:`TrackHistory.to_dict`).
STATE_NAMES = ("x", "y", "z", "vx", "vy", "vz")
#: Motion models of the tracker.
MOTIONS = ("cv", "imm")


@dataclass(frozen=True)
class TrackerSettings:
    r"""Settings of :func:`~radarfusion_ref.tracking.track_reports` (validated when built).

    The defaults of `q`, `q_vertical`, `speed_max_vertical`, `p_false_confirm`,
    `p_false_delete`, `relink`, `p_relink` and `p_false_reject` are tuned on the tuning hour by
    benchmarks/tune_tracking.py (``capstone.load_traffic(hour="tuning")``, never the scored
    hour; its protocol is the script's docstring, its runs are in
    benchmarks/data/tracking_tuning.csv). The others are stated design values.

    Units: every dimensional setting is in SI units (m, s and their products, whatever
    the unit of the reports), and `length_unit` says how many metres one unit of the
    reports' positions is. The trackers convert the reports to metres at the door and
    return the tracks in the reports' unit, so their decisions (gates, scores,
    confirmations, identities) do not depend on the unit. The defaults describe the
    capstone's airspace (airliners, about ten false reports per scan in 220 km of
    coverage): state `clutter_density`, `q` and `speed_max` for another scene.

    Attributes
    ----------
    p_detection : float
        :math:`P_D`, probability that a radar reports a target it covers (default 0.9).
    clutter_density : float
        :math:`\lambda`, false reports per m³ per radar scan (default 1e-14: about ten
        false reports per scan in a radar's 220 km coverage below 15 km; the number of
        false reports per scan over the volume they fall in).
    p_false_confirm, p_false_delete : float
        Design rates of the sequential test: false confirmation :math:`\alpha`
        (default 1e-3) and false deletion :math:`\beta` (default 0.01), both tuned on the
        tuning hour,
        :math:`\alpha + \beta < 1` (:func:`radarfusion_ref.engine.tracker.sprt_thresholds`).
    lower, upper : float
        Wald's deletion and confirmation thresholds of the score, computed from
        `p_false_confirm` and `p_false_delete` by
        :func:`radarfusion_ref.engine.tracker.sprt_thresholds` (not arguments).
    confirmation : {"sprt", "m_of_n"}
        Confirm by the score's sequential test (default) or by M-of-N logic.
    m, n : int
        M-of-N: confirm when `m` of the last `n` scored scans were hits
        (:math:`1 \le m \le n`, defaults 3 and 4).
    q : float
        Process-noise intensity of the constant-velocity model (m²/s³, default 50, tuned on
        the tuning hour by ``benchmarks/tune_tracking.py``: airliners turn and change level).
    p_false_reject : float
        The gate: :math:`P_{lo}` of :func:`radarfusion_ref.gating.gate_threshold` with
        3 degrees of freedom (default :math:`\chi^2_3` survival at 64, about 8.2e-14: a
        Mahalanobis distance of 8; tuned on the tuning hour).
    association : {"gnn", "jpda"}
        Global nearest neighbour (default) or joint probabilistic data association.
    k : int
        JPDA: clusters with more joint events than `max_events` use the `k` best
        (default 200, :math:`k \ge 1`).
    max_events : int
        JPDA: largest cluster (in joint events) enumerated exactly (default 5000).
    speed_max : float
        Standard deviation of each velocity component of a new track (m/s, default 250).
    max_coast : float
        Seconds without an update after which a track is deleted (s, default 40, > 0).
    max_coast_tentative : float or None
        Seconds without an update after which a *tentative* track is deleted (s, > 0 and
        at most `max_coast`); None (default): `max_coast`. A confirmed track may coast longer than the tracks
        clutter starts: a radar network whose aircraft are often seen by one slow radar
        alone needs a long coast for its confirmed tracks, and its tentative tracks of
        clutter, which no radar scores once its `miss_scans` scans have passed, would
        otherwise all live that long.
    miss_scans : int
        A radar's missed detection lowers a track's score only while that radar has
        reported the track within its last `miss_scans` scans (default 3, ≥ 1): a radar
        that stops seeing an aircraft (coverage, terrain) stops scoring it.
    relink : bool
        Keep one identity per aircraft (default True, tuned on the tuning hour). A newly
        confirmed track whose position passes the relinking gate of a confirmed track
        that lost its reports before the new one began (still live, or deleted less than
        `max_coast` seconds ago, predicted to the instant) continues that track's
        identity: a manoeuvre or a gap in the reports that breaks the track does not break
        the identity. A track about to be confirmed inside the relinking gate of a
        confirmed track still updated after it began is a duplicate of that aircraft
        (reports of one radar off the line, for one or two scans) and is deleted instead.
    p_relink : float
        The relinking gate: :math:`P_{lo}` of the :math:`\chi^2_3` gate on the two tracks'
        positions (default 1e-20, tuned on the tuning hour; :math:`d^2 < 96`: wider than
        the report gate, because a manoeuvre that broke the track moved the aircraft off
        the old track's line).
    length_unit : float
        Metres per unit of the reports' positions (> 0; default 1: positions in m, 1000:
        in km). Reports whose standard deviations come out below 1 m or above 100 km in
        metres are warned of (:class:`~radarfusion_ref.engine.errors.RadarFusionWarning`):
        usually a `length_unit` not stated.
    q_vertical : float or None
        Process-noise intensity of the vertical coordinate (m²/s³, > 0; default 0.03,
        tuned on the tuning hour); None: the same as `q`. Aircraft change level far more
        gently than they turn.
    speed_max_vertical : float or None
        Standard deviation of the vertical velocity of a new track (m/s, > 0; default 5,
        tuned on the tuning hour); None: the same as `speed_max`.
    motion : {"cv", "imm"}
        The motion model: one constant-velocity filter (default) or the interacting
        multiple model (:mod:`radarfusion_ref.engine.tracker`'s ``imm_*``) of constant-velocity
        modes that differ by their process noise.
    imm_q : tuple of float
        IMM: the horizontal process-noise intensity of each mode (m²/s³, > 0; default
        (5, 300): a quiet mode and a manoeuvre mode).
    imm_q_vertical : tuple of float or None
        IMM: the vertical intensity of each mode; None (default): `q_vertical` for every
        mode if set, else each mode's `imm_q`.
    imm_sojourn : tuple of float
        IMM: mean time (s, > 0) spent in each mode before switching (default (120, 20)).
        Over an interval :math:`\Delta t` the transition matrix is
        :math:`\Pi(\Delta t) = e^{\Lambda\Delta t}`, :math:`\Lambda_{jj} = -1/s_j`, the
        leaving rate spread evenly over the other modes: reports at irregular instants
        switch modes at the same rate per second whatever the number of radars.
    imm_probability : tuple of float
        IMM: the mode probabilities of a new track, each in (0, 1], summing to 1
        (default (0.8, 0.2)).
    feature_density : float
        :math:`\lambda_f`, the density of a false report's feature, per unit of the
        feature (> 0; default 1/300: the capstone's false reports carry a speed feature
        spread evenly over 300 kt). Used only with the reports' `feature`.
    q_feature : float
        Intensity of the random walk of a target's feature (the feature's unit squared
        per second, > 0; default 0.05 kt²/s, the mean squared change of the tuning hour's
        ADS-B ground speeds per second). Used only with the reports' `feature`.

    Raises
    ------
    ValueError
        A probability outside (0, 1), :math:`\alpha + \beta \ge 1`, ``m > n``,
        ``k < 1``, a non-positive period or intensity, an unknown choice, IMM tuples of
        different lengths or mode probabilities not summing to 1; the message names the
        attribute and shows the value.
    TypeError
        A non-numeric value.
    """

    p_detection: float = 0.9
    clutter_density: float = 1e-14
    p_false_confirm: float = 1e-3
    p_false_delete: float = 0.01
    confirmation: str = "sprt"
    m: int = 3
    n: int = 4
    q: float = 50.0
    p_false_reject: float = 8.208052945144475e-14      # chi2.sf(64, 3): distance 8
    association: str = "gnn"
    k: int = 200
    max_events: int = 5000
    speed_max: float = 250.0
    max_coast: float = 40.0
    max_coast_tentative: float | None = None
    miss_scans: int = 3
    relink: bool = True
    p_relink: float = 1e-20
    length_unit: float = 1.0
    # the motion model: vertical noise and prior apart, and the IMM
    q_vertical: float | None = 0.03
    speed_max_vertical: float | None = 5.0
    motion: str = "cv"
    imm_q: tuple = (5.0, 300.0)
    imm_q_vertical: tuple | None = None
    imm_sojourn: tuple = (120.0, 20.0)
    imm_probability: tuple = (0.8, 0.2)
    feature_density: float = 1.0 / 300.0
    q_feature: float = 0.05
    lower: float = field(init=False, repr=False)
    upper: float = field(init=False, repr=False)

    def __post_init__(self):
        def put(name, value):
            object.__setattr__(self, name, value)

        for name in ("p_detection", "p_false_confirm", "p_false_delete", "p_false_reject",
                     "p_relink"):
            put(name, as_float(as_probability(getattr(self, name), name), name))
        for name in ("clutter_density", "q", "speed_max", "max_coast", "length_unit",
                     "feature_density", "q_feature"):
            put(name, as_float(as_positive(getattr(self, name), name), name))
        sprt = sprt_thresholds(self.p_false_confirm, self.p_false_delete)  # refuses a sum >= 1
        put("confirmation", as_choice(self.confirmation, "confirmation", CONFIRMATIONS))
        put("association", as_choice(self.association, "association", ASSOCIATIONS))
        put("n", as_int(self.n, "n", minimum=1, maximum=62))
        put("m", as_int(self.m, "m", minimum=1))
        if self.m > self.n:
            raise ValueError(f"`m` must be <= `n` (m of the last n scans); received m={self.m}, "
                             f"n={self.n}")
        put("k", as_int(self.k, "k", minimum=1))
        put("max_events", as_int(self.max_events, "max_events", minimum=1))
        put("miss_scans", as_int(self.miss_scans, "miss_scans", minimum=1))
        put("relink", as_bool(self.relink, "relink"))
        if self.max_coast_tentative is not None:
            put("max_coast_tentative", as_float(as_positive(self.max_coast_tentative,
                                                            "max_coast_tentative"),
                                                "max_coast_tentative"))
            if self.max_coast_tentative > self.max_coast:   # the longer limit would not act
                raise ValueError(f"`max_coast_tentative` must be <= `max_coast` "
                                 f"({self.max_coast!r} s); received "
                                 f"{self.max_coast_tentative!r}")
        self._motion_iv(put)
        put("lower", sprt.lower)
        put("upper", sprt.upper)

    def _motion_iv(self, put):
        for name in ("q_vertical", "speed_max_vertical"):
            if getattr(self, name) is not None:
                put(name, as_float(as_positive(getattr(self, name), name), name))
        put("motion", as_choice(self.motion, "motion", MOTIONS))
        sizes = {}
        for name in ("imm_q", "imm_q_vertical", "imm_sojourn", "imm_probability"):
            v = getattr(self, name)
            if v is None and name == "imm_q_vertical":
                continue
            a = as_float_array(v, name, ndim_min=1)
            if a.ndim != 1 or not a.size:
                raise ValueError(f"`{name}` must be a non-empty sequence of numbers (one per "
                                 f"mode); received {v!r}")
            a = (as_probability(a, name, open_interval=False) if name == "imm_probability"
                 else as_positive(a, name))
            put(name, tuple(float(e) for e in a))
            sizes[name] = a.size
        if len(set(sizes.values())) != 1:
            raise ValueError(f"`imm_q`, `imm_q_vertical`, `imm_sojourn`, `imm_probability` "
                             f"must have one entry per mode (the same length); received "
                             f"lengths {sizes}")
        p = self.imm_probability
        if min(p) <= 0 or abs(sum(p) - 1) > 1e-9:
            raise ValueError(f"`imm_probability` must hold mode probabilities in (0, 1] "
                             f"summing to 1; received {p!r}")


@dataclass(frozen=True, repr=False)
class TrackHistory:
    """Tracks over time: one row per (track, update instant), sorted by (time, track).

    Attributes
    ----------
    track : numpy.ndarray of int, shape (K,)
        Track identity.
    time : numpy.ndarray, shape (K,)
        Instant of the update (s).
    state : numpy.ndarray, shape (K, 6)
        ``[x, y, z, vx, vy, vz]`` in the common east-north-up frame (the reports' length
        unit, and that unit per second).
    covariance : numpy.ndarray, shape (K, 6, 6)
    confirmed : numpy.ndarray of bool, shape (K,)
        The row is of a confirmed track (False: still tentative at that instant; the
        rows of a tentative track are kept only if it is confirmed later).
    initiated : int
        Tracks started, confirmed or not.
    mode_probability : numpy.ndarray, shape (K, M), or None
        With the interacting multiple model (``motion="imm"``): each row's mode
        probabilities after its update (the columns in the order of ``imm_q``); the row
        of a track's first report holds the prior ``imm_probability``. None otherwise.

    Notes
    -----
    The history holds data only: time a run with :func:`time.perf_counter` around the
    call. Its repr is one line of counts; :meth:`to_dict` gives plain columns.
    """

    track: np.ndarray
    time: np.ndarray
    state: np.ndarray
    covariance: np.ndarray
    confirmed: np.ndarray
    initiated: int = 0
    mode_probability: np.ndarray | None = None

    def __len__(self) -> int:
        return int(self.track.size)

    def __repr__(self) -> str:
        span = (f", time {float(self.time.min()):g} to {float(self.time.max()):g} s"
                if self.time.size else "")
        return (f"TrackHistory({len(self)} rows, {np.unique(self.track).size} tracks, "
                f"{self.n_confirmed} confirmed, {self.initiated} initiated{span})")

    @property
    def n_confirmed(self) -> int:
        """Number of distinct tracks that were ever confirmed."""
        return int(np.unique(self.track[self.confirmed]).size)

    def to_dict(self) -> dict[str, np.ndarray]:
        """The rows as plain one-dimensional columns of equal length (K,).

        Returns
        -------
        dict of str to numpy.ndarray
            ``track``, ``time``, ``confirmed``, the state ``x``, ``y``, ``z``, ``vx``,
            ``vy``, ``vz``, and the covariance's upper triangle ``cov_<a>_<b>`` (21
            columns, ``cov_x_x`` to ``cov_vz_vz``), and with the IMM ``mode_0``,
            ``mode_1``, ... (`mode_probability`'s columns): ready for
            ``pandas.DataFrame``, which this package does not need.

        Examples
        --------
        >>> h = TrackHistory(np.array([4]), np.array([5.0]), np.arange(6.0)[None],
        ...                  np.eye(6)[None], np.array([True]))
        >>> d = h.to_dict()
        >>> len(d), d["vx"].tolist(), d["cov_y_y"].tolist(), d["cov_x_y"].tolist()
        (30, [3.0], [1.0], [0.0])
        """
        out = {"track": self.track.copy(), "time": self.time.copy(),
               "confirmed": self.confirmed.copy()}
        for i, name in enumerate(STATE_NAMES):
            out[name] = self.state[:, i].copy()
        for i, j in zip(*np.triu_indices(6), strict=True):
            out[f"cov_{STATE_NAMES[i]}_{STATE_NAMES[j]}"] = self.covariance[:, i, j].copy()
        if self.mode_probability is not None:
            for j in range(self.mode_probability.shape[1]):
                out[f"mode_{j}"] = self.mode_probability[:, j].copy()
        return out


def _in_unit(history, unit):
    """`history` (in metres) in the reports' unit, `unit` metres each."""
    if unit == 1.0:
        return history
    return TrackHistory(history.track, history.time, history.state / unit,
                        history.covariance / unit**2, history.confirmed, history.initiated,
                        history.mode_probability)


#: Ours with the interacting multiple model, tuned on the tuning hour
#: (``capstone.load_traffic(hour="tuning")``, never the scored hour) by
#: ``benchmarks/tune_tracking.py`` with the protocol that tuned :class:`TrackerSettings`'
#: defaults (ours, constant velocity) and :data:`STONESOUP_SETTINGS`; the script fails if its
#: choice differs from this, and a test checks it against the committed table
#: (``benchmarks/data/tracking_tuning.csv``).
IMM_SETTINGS = TrackerSettings(motion="imm", imm_q=(2.0, 300.0), imm_q_vertical=(0.03, 0.03),
                               speed_max_vertical=5.0, p_false_confirm=1e-3,
                               p_false_delete=1e-3, relink=True,
                               p_relink=1e-20, p_false_reject=8.208052945144475e-14)

#: Stone Soup's settings, tuned on the tuning hour by ``benchmarks/tune_tracking.py`` with
#: the same protocol (the same motion knobs, its own track-management knobs: the initiator's
#: ``min_points`` and hold, the deleter's ``max_coast``, the gate / missed distance), from the
#: set-up of an experienced Stone Soup user (q 50, vertical q 2, vertical-velocity prior
#: 15 m/s, missed distance 8, min_points 3, hold 1.5 revisits, max_coast 40 s); the script
#: fails if its choice differs from these, and a test checks them against the committed
#: table (``benchmarks/data/tracking_tuning.csv``). Keys: Stone Soup's ``"gnn"`` and
#: ``"jpda"``; values: keyword arguments of
#: :func:`~radarfusion_ref.tracking.stonesoup.stonesoup_track` (``settings``, ``hold``), as in
#: ``stonesoup_track(*reports, tracker="gnn", **STONESOUP_SETTINGS["gnn"])``.
STONESOUP_SETTINGS = {
    "gnn": {"settings": TrackerSettings(q=20.0, q_vertical=0.03, speed_max_vertical=5.0, m=4,
                                        max_coast=40.0, p_false_reject=8.208052945144475e-14),
            "hold": 1.0},
    "jpda": {"settings": TrackerSettings(q=50.0, q_vertical=0.03, speed_max_vertical=5.0, m=5,
                                         n=5, max_coast=40.0,
                                         p_false_reject=8.208052945144475e-14),
             "hold": 1.5},
}
