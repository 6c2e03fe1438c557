"""The map of the book: chapters, the modules behind them and the papers' equations.

The introduction renders this table and a test checks it against ``_toc.yml``
and the files on disk, so the map cannot drift from the book.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Chapter", "CHAPTERS", "PAPERS", "chapter_table"]

#: Short keys of the source papers, with their bibliography keys ("B": the chapters that go
#: beyond the papers, with no source of their own).
PAPERS = {
    "GK": ("Grachov & Korneev (2010)", "grachov2010"),
    "P": ("Prosov", "prosov"),
    "S": ("Sonar paper (2013)", "sonar2013"),
    "B": ("Beyond the papers", None),
}


@dataclass(frozen=True)
class Chapter:
    """One chapter of the book.

    Attributes
    ----------
    stem : str
        Shared stem: ``book/NN_<stem>.md`` ↔ ``radarfusion_ref/<stem>.py`` ↔
        ``tests/test_<stem>.py``.
    number : int
        Chapter number (the ``NN`` of the file name).
    title : str
        Chapter title.
    paper : str
        Key into :data:`PAPERS`.
    source : str
        The equations, figures and tables of the paper the chapter covers.
    builds_on : tuple of int
        Numbers of the chapters a reader should know first.
    """

    stem: str
    number: int
    title: str
    paper: str
    source: str
    builds_on: tuple[int, ...] = ()

    @property
    def docname(self) -> str:
        """Path of the chapter in ``_toc.yml`` (no suffix)."""
        return f"book/{self.number:02d}_{self.stem}"

    @property
    def module(self) -> str:
        """Dotted name of the module behind the chapter."""
        return f"radarfusion_ref.{self.stem}"


CHAPTERS: tuple[Chapter, ...] = (
    Chapter("fusion", 1, "The maximum-likelihood fused estimate", "GK", "eqs. (1)–(3)"),
    Chapter("proximity", 2, "Likelihood and proximity measures", "GK", "eqs. (4), (7); Fig. 1",
            (1,)),
    Chapter("gating", 3, "Chi-square gating", "GK", "threshold rule, $P_{lo}$", (2,)),
    Chapter("association", 4, "Pointwise and joint association", "GK",
            "eqs. (5)–(6); joint measure", (2, 3)),
    Chapter("features", 5, "Features and type recognition", "GK", "eqs. (8)–(13)", (1, 4)),
    Chapter("conversion", 6, "Bias-corrected polar-to-Cartesian conversion", "P",
            "eqs. (1)–(4)", (1,)),
    Chapter("separated", 7, "Associating two separated radars", "P",
            "quadratic form $S$; Table 1", (3, 4, 6)),
    Chapter("grouping", 8, "Grouping reports of many sources", "S", "eqs. (4)–(26)", (1, 2, 4)),
    Chapter("registration", 9, "Registration: systematic sensor biases", "B",
            "bias model; estimation and its CRLB", (1, 2, 3, 4, 6, 7)),
    Chapter("trackfusion", 10, "Track-to-track fusion", "B", "cross-covariance; time alignment",
            (1, 2, 3)),
    Chapter("capstone", 11, "A fusion centre over real traffic", "B",
            "ADS-B truth; the whole pipeline; GOSPA score", (1, 3, 5, 6, 8, 9)),
    Chapter("tracking", 12, "From reports to tracks", "B",
            "track score and SPRT; GNN; JPDA; three architectures", (3, 4, 10, 11)),
    Chapter("continent", 13, "A continent in real time", "B",
            "cost per report; sectors and hand-over; real-time factor", (3, 4, 11, 12)),
)


def _check_dependencies(chapters) -> None:
    """Every chapter builds only on earlier chapters (a reading order exists)."""
    for ch in chapters:
        for k in ch.builds_on:
            if not 1 <= k < ch.number:
                raise ValueError(f"chapter {ch.number} cannot build on chapter {k}")


_check_dependencies(CHAPTERS)


def chapter_table() -> str:
    """The chapter map as a Markdown table (rendered in the introduction).

    Examples
    --------
    >>> chapter_table().splitlines()[0]
    '| # | chapter | module | paper | equations |'
    """
    rows = ["| # | chapter | module | paper | equations |", "|---|---|---|---|---|"]
    for ch in CHAPTERS:
        paper = PAPERS[ch.paper][0]
        rows.append(f"| {ch.number} | [{ch.title}]({ch.number:02d}_{ch.stem}.md) | "
                    f"`{ch.module}` | {paper} | {ch.source} |")
    return "\n".join(rows)
