"""The assignment results: one protocol, one name per field."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["AssignmentResult", "Association", "KBestAssignments", "SDAssignment"]


@runtime_checkable
class AssignmentResult(Protocol):
    r"""What every assignment result provides (a protocol: any class with these attributes).

    Each result also holds its decisions under the name that says what they are:
    ``row_to_col`` (and ``col_to_row``) for the 2-D results, ``groups`` for the
    S-D results.

    Attributes
    ----------
    cost : float or numpy.ndarray
        Total cost of the decisions (per ranked hypothesis or per batch entry).
    lower_bound : float or numpy.ndarray
        A proved lower bound on the optimal total cost (the cost itself for an
        exact solver).
    gap : float or numpy.ndarray
        Proved relative gap :math:`(\text{cost} - \text{lower bound}) /
        \max(|\text{cost}|, 1)`, never negative; 0 for an exact solver.
    history : numpy.ndarray or None
        Iterative solvers: the lower bound and the best cost after each
        iteration, shape (iterations, 2); None otherwise.
    exact : bool
        True when the result is a proved optimum (gap 0): a plain field of
        every result.
    """

    cost: np.ndarray | float
    lower_bound: np.ndarray | float
    gap: np.ndarray | float
    history: np.ndarray | None
    exact: bool


def relative_gap(total, lower):
    """Kernel (trusted input): the relative gap ``(cost - lower) / max(abs(cost), 1)``, >= 0."""
    return max(0.0, (float(total) - float(lower)) / max(abs(float(total)), 1.0))


@dataclass(frozen=True)
class Association:
    """Association decisions for one cost matrix or a batch of them.

    Attributes
    ----------
    row_to_col : numpy.ndarray of int, shape (..., n1)
        ``row_to_col[..., i]`` is the radar-2 report paired with radar-1
        report ``i``, or -1 if report ``i`` is left unassigned.
    col_to_row : numpy.ndarray of int, shape (..., n2)
        The inverse map; -1 for an unassigned radar-2 report.
    cost : numpy.ndarray or float, shape (...)
        Total cost: the sum of the costs of the assigned pairs, plus
        ``miss_cost`` for every unassigned row and every unassigned column
        when a ``miss_cost`` was given.
    lower_bound : numpy.ndarray or float, shape (...)
        `cost` itself (the 2-D solvers are exact).
    gap : numpy.ndarray or float, shape (...)
        0 (the 2-D solvers are exact).
    history : None
        The 2-D solvers are not iterative.
    exact : bool
        True: a proved optimum.
    pairs : numpy.ndarray of int, shape (k, 2)
        (property, unbatched results only) the assigned pairs ``(i, j)``,
        sorted by ``i``.
    unassigned_rows, unassigned_cols : numpy.ndarray of int
        (properties, unbatched results only) reports left without a partner.
    n_assigned : numpy.ndarray or int, shape (...)
        (property) number of assigned pairs.
    """

    row_to_col: np.ndarray
    col_to_row: np.ndarray
    cost: np.ndarray | float
    lower_bound: np.ndarray | float = field(init=False)
    gap: np.ndarray | float = field(init=False)
    history: None = None
    exact: bool = True

    def __post_init__(self):
        object.__setattr__(self, "lower_bound", self.cost)
        object.__setattr__(self, "gap", 0.0 if np.ndim(self.cost) == 0
                           else np.zeros(np.shape(self.cost)))

    def _single(self, what: str) -> None:
        if self.row_to_col.ndim != 1:
            raise ValueError(
                f"`{what}` is defined for a single cost matrix; this result holds a batch of "
                f"shape {self.row_to_col.shape[:-1]} (index it with .row_to_col instead)"
            )

    @property
    def pairs(self) -> np.ndarray:
        """Assigned pairs ``(i, j)`` as a ``(k, 2)`` int array, sorted by ``i``."""
        self._single("pairs")
        rows = np.flatnonzero(self.row_to_col >= 0)
        return np.column_stack([rows, self.row_to_col[rows]]).astype(int)

    @property
    def unassigned_rows(self) -> np.ndarray:
        """Radar-1 reports left unassigned."""
        self._single("unassigned_rows")
        return np.flatnonzero(self.row_to_col < 0)

    @property
    def unassigned_cols(self) -> np.ndarray:
        """Radar-2 reports left unassigned."""
        self._single("unassigned_cols")
        return np.flatnonzero(self.col_to_row < 0)

    @property
    def n_assigned(self):
        """Number of assigned pairs (per batch entry)."""
        out = np.count_nonzero(self.row_to_col >= 0, axis=-1)
        return int(out) if np.ndim(out) == 0 else out


@dataclass(frozen=True)
class KBestAssignments:
    """The best joint hypotheses in order of increasing cost.

    Attributes
    ----------
    row_to_col : numpy.ndarray of int, shape (k_found, n1)
        ``row_to_col[r]`` is the ``row_to_col`` vector of the ``r``-th best
        complete assignment (every row assigned when ``n1 <= n2``; otherwise
        -1 marks the ``n1 - n2`` rows left out).
    cost : numpy.ndarray, shape (k_found,)
        Their total costs, non-decreasing.
    solved : int
        Number of assignment sub-problems solved exactly (a measure of work).
    lower_bound : numpy.ndarray, shape (k_found,)
        `cost` itself (each ranked cost is exact: the r-th best cost).
    gap : numpy.ndarray, shape (k_found,)
        Zeros (the ranking is exact).
    history : None
        Not iterative.
    exact : bool
        True: an exact ranking.
    k : int
        (property) number of assignments found (fewer than asked if fewer exist).
    """

    row_to_col: np.ndarray
    cost: np.ndarray
    solved: int
    lower_bound: np.ndarray = field(init=False)
    gap: np.ndarray = field(init=False)
    history: None = None
    exact: bool = True

    def __post_init__(self):
        object.__setattr__(self, "lower_bound", self.cost)
        object.__setattr__(self, "gap", np.zeros(self.cost.shape))

    @property
    def k(self) -> int:
        """Number of assignments found (fewer than asked if fewer exist)."""
        return int(self.cost.shape[0])


@dataclass(frozen=True)
class SDAssignment:
    r"""The best S-D assignment (grouping) found by :func:`assign_s_lists` or :func:`assign_s_lists_bruteforce`.

    Attributes
    ----------
    groups : numpy.ndarray of int, shape (G, m)
        The chosen groups, one row per group: ``groups[k, i]`` is source
        ``i``'s report in group ``k``, ``-1`` when source ``i`` has none;
        rows sorted by source 0, then 1, ... (``-1`` last).
    chosen : numpy.ndarray of int, shape (G,)
        Their indices: rows of `candidates`, or flat (C-order) indices into
        the cost tensor.
    cost : float
        Total cost of the chosen groups.
    lower_bound : float
        A proved lower bound on the optimal total: the cost itself for an
        exact method, the best Lagrangian dual value (less a rounding
        allowance) for ``"lagrangian"``.
    gap : float
        Proved relative gap :math:`(\text{cost} - \text{lower bound}) /
        \max(|\text{cost}|, 1)`.
    history : numpy.ndarray or None, shape (iterations, 2)
        ``"lagrangian"``: lower bound and best cost after each iteration
        (summed over independent clusters); None otherwise.
    exact : bool
        True when `gap` is 0 (a proved optimum).
    method : str
        ``"milp"``, ``"lagrangian"`` or ``"bruteforce"``.
    relaxation_integral : bool or None
        ``"milp"`` on a full finite tensor: whether the LP relaxation was
        already integral (no branching). None otherwise.
    """

    groups: np.ndarray
    chosen: np.ndarray
    cost: float
    lower_bound: float
    gap: float
    history: np.ndarray | None
    exact: bool
    method: str
    relaxation_integral: bool | None = None

