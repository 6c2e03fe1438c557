r"""Scores of the capstone's fusion centre against the truth.

:func:`evaluate` scores the fused objects of each scan: GOSPA with its localisation, missed
and false parts
(:func:`radarfusion_ref.engine.metrics.gospa`), association accuracy (purity,
:func:`radarfusion_ref.engine.metrics.purity`, and completeness), NEES
(:func:`radarfusion_ref.engine.metrics.nees`) and recognition accuracy.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..engine.metrics import NeesResult, gospa, nees, purity
from ..engine.montecarlo import Proportion, proportion
from ..engine.validation import as_choice, describe
from .pipeline import PipelineResult
from .radars import _coverage_count
from .traffic import TruthScans

__all__ = ["SCOPES", "Evaluation", "evaluate", "gospa_parameters"]

#: Truth sets GOSPA can score against (:func:`evaluate`'s `scope`).
SCOPES = ("covered", "detected", "all")


@dataclass(frozen=True)
class Evaluation:
    r"""Scores of a :class:`~radarfusion_ref.capstone.pipeline.PipelineResult` against the truth.

    Attributes
    ----------
    times : numpy.ndarray, shape (S,)
        Scan times (s).
    gospa, localisation, missed, false : numpy.ndarray, shape (S,)
        Per scan: GOSPA (m) and its three parts (m^p; they sum to ``gospa**p``).
    c, p : float
        GOSPA cut-off (m) and order (α = 2).
    purity : Proportion or None
        Fraction of declared objects whose reports all come from one aircraft (None
        without declared objects; likewise below when there is nothing to count).
    completeness : Proportion or None
        Fraction of (aircraft, scan) pairs with at least one report whose reports form
        exactly one group of the grouping (all of them together, nothing else; a lone
        report counts when it is left alone).
    nees : NeesResult or None
        3-D NEES of the pure objects, its mean and the two-sided 95 % range of that mean
        under :math:`\chi^2_3` errors, :math:`[\chi^2_{3N}(0.025), \chi^2_{3N}(0.975)]/N`.
    recognition : Proportion or None
        Fraction of pure objects whose most probable class is the aircraft's.
    timings : dict
        The pipeline's stage times plus "metrics".
    """

    times: np.ndarray
    gospa: np.ndarray
    localisation: np.ndarray
    missed: np.ndarray
    false: np.ndarray
    c: float
    p: float
    purity: Proportion | None
    completeness: Proportion | None
    nees: NeesResult | None
    recognition: Proportion | None
    timings: dict = field(hash=False)

    @property
    def mean_gospa(self) -> float:
        """Mean over scans of the per-scan GOSPA (m)."""
        return float(np.mean(self.gospa))

    def parts_rms(self) -> dict:
        """Each part and the total as a length: the p-th root of its mean over scans (m)."""
        out = {k: float(np.mean(getattr(self, k)) ** (1.0 / self.p))
               for k in ("localisation", "missed", "false")}
        out["total"] = float(np.mean(self.gospa ** self.p) ** (1.0 / self.p))
        return out


def _truth_rows(truth, scan, aircraft):
    """Row of the truth of each (scan, aircraft) pair."""
    base = len(truth.icao24) + 1
    tkey = truth.scan.astype(np.int64) * base + truth.aircraft
    return np.searchsorted(tkey, np.asarray(scan, dtype=np.int64) * base + aircraft)


def _detected_count(truth, reports):
    """Number of distinct radars with a report of each truth row's aircraft in its scan."""
    real = reports.source >= 0
    base = len(truth.icao24) + 1
    key = reports.scan[real].astype(np.int64) * base + reports.source[real]
    pair = np.unique(key * (int(reports.radar.max(initial=0)) + 1) + reports.radar[real])
    key = pair // (int(reports.radar.max(initial=0)) + 1)
    tkey = truth.scan.astype(np.int64) * base + truth.aircraft
    at = np.searchsorted(tkey, key)
    ok = (at < tkey.size) & (tkey[np.minimum(at, tkey.size - 1)] == key)
    return np.bincount(at[ok], minlength=tkey.size)


def _gospa_per_scan(truth, keep, scan, position, c, p):
    """GOSPA and its parts (S, 4) of the estimates of each scan against the kept truth."""
    S = truth.n_scans
    tb = np.searchsorted(truth.scan, np.arange(S + 1))
    order = np.argsort(scan, kind="stable")
    rb = np.searchsorted(scan[order], np.arange(S + 1))
    parts = np.zeros((S, 4))
    for s in range(S):
        g = gospa(truth.position[tb[s]:tb[s + 1]][keep[tb[s]:tb[s + 1]]],
                  position[order[rb[s]:rb[s + 1]]], c=c, p=p)
        parts[s] = g.total, g.localisation, g.missed, g.false
    return parts


def _completeness(result, truth):
    """Share of (aircraft, scan) pairs whose reports form exactly one group, alone."""
    rep = result.reports
    real = rep.source >= 0
    key = rep.scan[real].astype(np.int64) * (len(truth.icao24) + 1) + rep.source[real]
    grp = result.group_of[real]
    uk, inv = np.unique(key, return_inverse=True)
    gmin = np.full(uk.size, np.iinfo(np.int64).max)
    gmax = np.full(uk.size, -1)
    np.minimum.at(gmin, inv, grp)
    np.maximum.at(gmax, inv, grp)
    one_group = gmin == gmax
    gsize = np.bincount(result.group_of[result.group_of >= 0])
    nrep = np.bincount(inv)
    ok = one_group & (gsize[gmin.clip(0, gsize.size - 1)] == nrep)
    return proportion(int(ok.sum()), uk.size) if uk.size else None


def gospa_parameters(c, p) -> tuple[float, float]:
    """Check the GOSPA cut-off and order of an evaluation, before any work.

    The rule has one home, the door of :func:`radarfusion_ref.engine.metrics.gospa`:
    this calls it with no points, so an evaluation refuses a bad `c` or `p` exactly as
    GOSPA would, but before it interpolates a truth or pairs a track.

    Parameters
    ----------
    c : float
        Cut-off (a single finite number > 0).
    p : float
        Order (a single finite number >= 1).

    Returns
    -------
    (float, float)
        `c` and `p` as floats.

    Raises
    ------
    TypeError
        A value that is not a number.
    ValueError
        `c` not > 0, `p` not >= 1, or either not a single finite number.

    Examples
    --------
    >>> gospa_parameters(2000, 2)
    (2000.0, 2.0)
    >>> gospa_parameters(2000.0, 0.5)
    Traceback (most recent call last):
    ...
    ValueError: `p` must be a finite number >= 1; received 0.5
    """
    gospa(np.zeros((0, 1)), np.zeros((0, 1)), c=c, p=p)
    return float(c), float(p)


def _evaluate_iv(result, truth, c, p, scope):
    if not isinstance(result, PipelineResult):
        raise TypeError(f"`result` must be a PipelineResult (from run_pipeline); received "
                        f"{describe(result)}")
    if not isinstance(truth, TruthScans):
        raise TypeError(f"`truth` must be a TruthScans (from truth_scans); received "
                        f"{describe(truth)}")
    c, p = gospa_parameters(c, p)
    scope = as_choice(scope, "scope", SCOPES)
    if truth.n_scans != result.reports.n_scans:
        raise ValueError(f"`truth` has {truth.n_scans} scans but the result's reports "
                         f"{result.reports.n_scans}")
    return c, p, scope


def evaluate(result, truth, *, c=2000.0, p=2.0, scope="covered") -> Evaluation:
    r"""Score a pipeline run against the truth: GOSPA per scan, association, NEES, recognition.

    Parameters
    ----------
    result : PipelineResult
    truth : TruthScans
        The truth the reports were simulated from.
    c : float, optional
        GOSPA cut-off (m, default 2000: an estimate further than 2 km from every aircraft
        is false).
    p : float, optional
        GOSPA order (default 2); α = 2.
    scope : {"covered", "detected", "all"}, optional
        Truth set of GOSPA in each scan: the aircraft inside the coverage (range and
        elevation limits) of at least ``min_reports`` radars (default); the aircraft that
        at least ``min_reports`` distinct radars actually reported in that scan (their
        detections, not clutter), those the centre can declare, so a miss it could not
        avoid leaves the score; or every aircraft of the window.

    Returns
    -------
    Evaluation

    Raises
    ------
    TypeError
        If `result` or `truth` has the wrong type.
    ValueError
        Bad `c`, `p` or `scope`, or a truth whose scan count differs from the reports'.

    Notes
    -----
    GOSPA compares the truth positions of each scan with the declared objects. NEES uses
    the pure objects: :math:`(\hat x - x)^T P^{-1} (\hat x - x)`, 3 degrees of freedom.
    With ``scope="detected"`` an aircraft counts in a scan when reports of at least
    ``result.settings.min_reports`` distinct radars come from it (``reports.source``).

    Examples
    --------
    >>> from radarfusion_ref.capstone import (default_radars, load_traffic, run_pipeline,
    ...                                       simulate_reports, truth_scans)
    >>> from radarfusion_ref.capstone import PipelineSettings
    >>> truth = truth_scans(load_traffic(), start=600.0, duration=60.0)
    >>> rep = simulate_reports(truth, default_radars(), rng=1)
    >>> res = run_pipeline(rep, default_radars(), PipelineSettings(warmup=6))
    >>> ev = evaluate(res, truth, scope="detected")
    >>> ev.gospa.shape, bool(np.all(ev.missed <= evaluate(res, truth).missed))
    ((6,), True)
    """
    c, p, scope = _evaluate_iv(result, truth, c, p, scope)
    t0 = time.perf_counter()
    keep = np.ones(truth.scan.size, dtype=bool)
    if scope == "covered":
        keep = _coverage_count(truth.position, result.radars) >= result.settings.min_reports
    elif scope == "detected":
        keep = _detected_count(truth, result.reports) >= result.settings.min_reports
    parts = _gospa_per_scan(truth, keep, result.scan, result.position, c, p)
    mem = result.members
    pur = purity(np.where(mem >= 0, result.reports.source[np.maximum(mem, 0)], -1), mem >= 0)
    nees_t = recognition = None
    if pur.pure.any():
        ti = _truth_rows(truth, result.scan[pur.pure], pur.source[pur.pure])
        nees_t = nees(result.position[pur.pure] - truth.position[ti],
                      result.covariance[pur.pure])
        correct = result.speed_class[pur.pure] == truth.speed_class[ti]
        recognition = proportion(int(correct.sum()), nees_t.count)
    timings = dict(result.timings)
    timings["metrics"] = time.perf_counter() - t0
    return Evaluation(times=truth.times, gospa=parts[:, 0], localisation=parts[:, 1],
                      missed=parts[:, 2], false=parts[:, 3], c=c, p=p, purity=pur.fraction,
                      completeness=_completeness(result, truth), nees=nees_t,
                      recognition=recognition, timings=timings)
