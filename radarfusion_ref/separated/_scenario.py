r"""The paper's scenario: its numbers, its Table 1, its outcome codes and its geometry (Prosov)."""

from __future__ import annotations

import math

import numpy as np

from .. import conversion
from ..engine.geometry import (
    Geometry,
)
from ..engine.validation import as_float, as_positive

CORRECT, WRONG, NO_DECISION = 0, 1, 2
#: Outcome names, indexed by code (the columns of Table 1).
OUTCOMES = ("correct", "wrong", "no decision")

#: The paper's scenario (km, rad): sigma_r, sigma_beta, target 1's range and
#: azimuth from radar 1, the base and its azimuth, the false-rejection probability.
PAPER = {
    "sigma_r": 0.1,
    "sigma_beta": float(np.deg2rad(1.0)),
    "range1": 150.0,
    "azimuth1": float(np.deg2rad(45.0)),
    "base": 30.0,
    "base_azimuth": 0.0,
    "p_false_reject": 0.01,
}

#: Table 1 as printed: ``PAPER_TABLE1[method][target]`` = (P_correct, P_wrong,
#: P_no-decision), targets 1 and 2 in rows.
PAPER_TABLE1 = {
    "linearized": np.array([[0.674, 0.010, 0.316], [0.342, 0.008, 0.650]]),
    "bias-corrected": np.array([[0.631, 0.009, 0.360], [0.649, 0.004, 0.347]]),
}

_METHODS = conversion.METHODS

#: Largest number of complete pairings (:math:`n!`) the joint rules enumerate
#: (7! = 5040, i.e. at most 7 targets).
MAX_JOINT_PAIRINGS = 5040

#: Largest number of placements one :func:`offset_sweep` accepts.
MAX_GRID_POINTS = 10_000

_JOINT_ALTERNATIVE = ("radarfusion_ref.engine.assignment.assign_two_lists (linear assignment, "
                      "polynomial in the number of targets)")


def _joint_bytes(n: int, batch: int) -> int:
    """Working memory (bytes) of the joint rule over `batch` statistic matrices."""
    return 8 * batch * math.factorial(n) * (n + 3)


# --------------------------------------------------------------------------- geometry
def paper_geometry(offset_range=0.0, offset_cross=0.0, *, range1=PAPER["range1"],
                   azimuth1=PAPER["azimuth1"], base=PAPER["base"],
                   base_azimuth=PAPER["base_azimuth"]) -> Geometry:
    """The paper's scene: target 1 at (150 km, 45°), target 2 offset from it.

    The paper's Fig. 2 (where target 2 is) is missing from the source, so
    target 2 is placed at an offset from target 1 measured in radar 1's
    line-of-sight frame: `offset_range` along the line of sight (away from
    radar 1) and `offset_cross` across it (towards increasing azimuth).

    Parameters
    ----------
    offset_range, offset_cross : float
        Offset of target 2 from target 1 (km). Both zero gives a single target.
    range1, azimuth1 : float, optional
        Target 1's range (km) and azimuth (rad) from radar 1.
    base, base_azimuth : float, optional
        Base length (km) and azimuth (rad).

    Returns
    -------
    Geometry
        With one target if both offsets are zero, two otherwise.

    Raises
    ------
    ValueError
        If `range1` or `base` is not positive, an argument is not one finite
        number, or target 2 would sit on a radar.

    References
    ----------
    Prosov, the scenario text before Table 1 (Fig. 2 is missing).

    Examples
    --------
    >>> g = paper_geometry(0.0, -5.0)
    >>> g.targets.round(3)
    array([[106.066, 106.066],
           [109.602, 102.53 ]])
    >>> g.radar2
    array([30.,  0.])
    """
    r1 = as_float(as_positive(range1, "range1"), "range1")
    a1 = as_float(azimuth1, "azimuth1")
    dr = as_float(offset_range, "offset_range")
    dc = as_float(offset_cross, "offset_cross")
    b = as_float(as_positive(base, "base"), "base")
    b0 = as_float(base_azimuth, "base_azimuth")
    u = np.array([np.cos(a1), np.sin(a1)])
    v = np.array([-u[1], u[0]])
    t1 = r1 * u
    with np.errstate(over="ignore", invalid="ignore"):
        t2 = t1 + dr * u + dc * v
    if not np.all(np.isfinite(t2)):
        raise ValueError("`offset_range`, `offset_cross` put target 2 beyond the float range; "
                         f"received {dr!r}, {dc!r}")
    targets = t1[None] if dr == 0.0 and dc == 0.0 else np.stack([t1, t2])
    geo = Geometry(b, b0, targets)
    geo.polar1  # noqa: B018  (raises if a target sits on a radar)
    geo.polar2  # noqa: B018
    return geo
