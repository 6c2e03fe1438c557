r"""Named scenes of the capstone: radars, window, pipeline settings and scoring together.

A :class:`Scene` holds everything an experiment of the chapter fixes before it draws a
report, so the page and the tests share one definition. :func:`hard_scene` is the scene in
which every stage of the pipeline changes the score.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from ..engine.validation import describe
from .evaluation import SCOPES, gospa_parameters
from .pipeline import PipelineSettings
from .radars import as_radars, default_radars
from .traffic import Traffic, TruthScans, truth_scans

__all__ = ["FAR_SITES", "Scene", "hard_scene"]

#: Sites of :func:`hard_scene`: name -> (latitude deg, longitude deg, height m), rounded
#: coordinates near three cities around Switzerland (stand-ins, not real radar sites), each
#: 160–260 km from the common origin.
FAR_SITES = {
    "Lyon": (45.73, 5.08, 300.0),
    "Stuttgart": (48.69, 9.22, 500.0),
    "Milan": (45.45, 9.28, 200.0),
}


@dataclass(frozen=True)
class Scene:
    """One experiment's fixed part: the radars, the window, the pipeline and the score.

    Attributes
    ----------
    radars : tuple of Radar
        The radars (checked by :func:`~radarfusion_ref.capstone.radars.as_radars`).
    start, duration, period : float
        The window: scans every `period` s from `start` (s after 11:00 UTC) for
        `duration` s (:func:`~radarfusion_ref.capstone.traffic.truth_scans`).
    settings : PipelineSettings
        The full pipeline of the scene; an ablation replaces one switch
        (``dataclasses.replace(scene.settings, debias=False)``).
    c : float
        GOSPA cut-off (m), order 2.
    scope : str
        GOSPA's truth set, one of :data:`~radarfusion_ref.capstone.evaluation.SCOPES`.

    Raises
    ------
    TypeError, ValueError
        Bad radars, settings, cut-off or scope, named as the field.

    Examples
    --------
    >>> sc = hard_scene()
    >>> [r.name for r in sc.radars], sc.duration
    (['Lyon', 'Stuttgart', 'Milan'], 120.0)
    """

    radars: tuple
    start: float
    duration: float
    period: float
    settings: PipelineSettings
    c: float = 2000.0
    scope: str = "detected"

    def __post_init__(self):
        object.__setattr__(self, "radars", as_radars(self.radars))
        if not isinstance(self.settings, PipelineSettings):
            raise TypeError(f"`settings` must be a PipelineSettings; received "
                            f"{describe(self.settings)}")
        object.__setattr__(self, "c", gospa_parameters(self.c, 2.0)[0])
        if self.scope not in SCOPES:
            raise ValueError(f"`scope` must be one of {', '.join(SCOPES)}; received "
                             f"{describe(self.scope)}")

    def truth(self, traffic) -> TruthScans:
        """The aircraft at the scene's scan times (:func:`truth_scans` of `traffic`).

        Parameters
        ----------
        traffic : Traffic
            From :func:`~radarfusion_ref.capstone.traffic.load_traffic`.

        Returns
        -------
        TruthScans

        Raises
        ------
        TypeError
            `traffic` not a Traffic.

        Examples
        --------
        >>> from radarfusion_ref.capstone import load_traffic
        >>> hard_scene().truth(load_traffic()).n_scans
        12
        """
        if not isinstance(traffic, Traffic):
            raise TypeError(f"`traffic` must be a Traffic (from load_traffic); received "
                            f"{describe(traffic)}")
        return truth_scans(traffic, period=self.period, start=self.start,
                           duration=self.duration)


def hard_scene() -> Scene:
    r"""The chapter's hard scene: far radars, noisy in azimuth, in heavy clutter.

    The window is the first two minutes (12 scans of 10 s) of the chapter's ten minutes,
    2100 s after 11:00 UTC (the busiest ten minutes of the hour on a 5-minute grid). The
    three radars of :func:`~radarfusion_ref.capstone.radars.default_radars` keep their
    offsets and detection probabilities but stand at :data:`FAR_SITES` (Lyon in place of
    La Dôle, Stuttgart of Albis, Milan of Monte Lema), measure azimuth ten times less
    precisely (0.8°), reach 400 km, and report 200 false plots per scan. The registration
    uses the whole window (``warmup=12``); GOSPA has cut-off 2 km and scores the aircraft
    that at least two radars detected.

    Why each stage matters here: at 200–300 km a 0.8° azimuth error is 3–4 km across
    the line of sight, so the conversion's bias (eq. conversion-3d-bias, about
    :math:`r\sigma_\beta^2/2`, 20–30 m, several times the fused error along range) and
    its covariance matter; report covariances differ by an order of magnitude between
    near and far radars, which is what the :math:`\ln\det(2\pi S)` term weighs; and the
    clutter falls inside those wide gates, where only the speed feature tells it apart.

    Returns
    -------
    Scene

    Examples
    --------
    >>> sc = hard_scene()
    >>> round(math.degrees(sc.radars[0].sigma_beta), 3), sc.radars[0].clutter_rate
    (0.8, 200.0)
    """
    base = default_radars(sigma_beta=math.radians(0.8), max_range=400_000.0,
                          clutter_rate=200.0)
    radars = tuple(dataclasses.replace(r, name=name, lat=site[0], lon=site[1],
                                       height=site[2])
                   for r, (name, site) in zip(base, FAR_SITES.items(), strict=True))
    return Scene(radars=radars, start=2100.0, duration=120.0, period=10.0,
                 settings=PipelineSettings(warmup=12), c=2000.0, scope="detected")
