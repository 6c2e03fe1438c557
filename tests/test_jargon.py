"""Every term of the book is defined, or linked to the glossary, at its first use on each page.

The glossary (``book/glossary.md``, a Sphinx ``glossary`` directive) defines each term of
:data:`TERMS` once. On every page under ``book/``, the first prose occurrence of a term
(Markdown text outside code cells, math, directive options, labels and headings) must either
link to the glossary with the ``{term}`` role or be the bold ``**term**`` of the sentence that
defines it. A ``{term}`` whose target is not a glossary entry is a Sphinx warning, and the book
builds with warnings as errors, so every target is checked too.
"""

from __future__ import annotations

import re
from bisect import bisect_right
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import pytest
from book_metrics import CODE_CELL, book_labels

ROOT = Path(__file__).resolve().parents[1]
BOOK = ROOT / "book"
GLOSSARY_PAGE = BOOK / "glossary.md"

#: Glossary entry -> the pattern that finds the term in prose. Acronyms match in capitals
#: only; words match in any case and in their usual inflections.
TERMS: dict[str, str] = {
    "NEES": r"\bNEES\b",
    "NIS": r"\bNIS\b",
    "GOSPA": r"\bGOSPA\b",
    "Mahalanobis distance": r"(?i:\b(?:squared[- ])?Mahalanobis(?: distances?)?\b)",
    "gate": r"(?i:\bchi-square gat(?:e|es|ing)\b|\bgating\b|\bgate(?:s|d)?\b)",
    "GNN": r"\bGNN\b|(?i:\bglobal nearest[- ]neighbou?r)",
    "JPDA": r"\bJPDA\b|(?i:\bjoint probabilistic data association)",
    "IMM": r"\bIMM\b|(?i:\binteracting multiple[- ]model)",
    "SPRT": r"\bSPRT\b|(?i:\bsequential probability ratio test|\bWald's sequential test)",
    "BLUE": r"\bBLUE\b|(?i:\bbest linear unbiased)",
    "maximum likelihood": r"(?i:\bmaximum[- ]likelihood\b)|\bML\b",
    "likelihood ratio": r"(?i:\blikelihood[- ]ratios?\b)",
    "profile likelihood": r"(?i:\bprofile likelihoods?\b)",
    "dual potentials": r"(?i:\bdual potentials?\b)",
    "association hypothesis": r"(?i:\b(?:association|joint|pairwise|pointwise|grouping) "
                              r"hypothes[ie]s\b)",
    "clutter": r"(?i:\bclutter\b)",
    "registration": r"(?i:\bregistration\b)",
    "covariance intersection": r"(?i:\bcovariance[- ]intersection\b)",
    "track-to-track fusion": r"(?i:\btrack-to-track(?: fusion)?\b|\btrack fusion\b)",
    "Monte Carlo interval": r"(?i:\b95 ?% (?:confidence |Wilson )?intervals?\b|\bMonte[- ]Carlo "
                            r"intervals?\b|\bconfidence intervals?\b|\bWilson(?:'s)?(?: score)? "
                            r"intervals?\b)",
    "confirmation latency": r"(?i:\blatenc(?:y|ies)\b)",
    "false track": r"(?i:\bfalse tracks?\b)",
    "track switch": r"(?i:\btrack switch(?:es)?\b|\bidentity switch(?:es)?\b)",
    "debiased conversion": r"(?i:\bdebiased(?: consistent)?(?: conversions?)?\b)",
    "Cholesky factor": r"(?i:\bCholesky(?: factors?| factori[sz]ation| decomposition)?\b)",
    "fusion centre": r"(?i:\bfusion cent(?:re|er)s?\b)",
    "proximity measure": r"(?i:\bproximity measures?\b)",
    "likelihood measure": r"(?i:\blikelihood measures?\b)",
    "noncentrality": r"(?i:\bnoncentrality(?: parameter)?\b|\bnoncentral\b)",
    "Fisher information": r"(?i:\bFisher information\b)",
    "Cramér–Rao bound": r"(?i:\bCram[eé]r[–-]Rao(?: bound| lower bound)?\b)|\bCRLB\b",
    "whitening": r"(?i:\bwhiten(?:ed|ing|s)?\b)",
    "S-D assignment": r"\bS-D(?: assignment(?: problem)?)?\b",
    "Lagrangian relaxation": r"(?i:\bLagrangian relaxation\b|\bduality gap\b)",
    "Murty's algorithm": r"\bMurty(?:'s(?: algorithm)?)?",
    "process noise": r"(?i:\bprocess[- ]noise\b)",
    "track score": r"(?i:\btrack scores?\b)",
    "M-of-N": r"\bM-of-N\b",
    "NCI": r"\bNCI\b|(?i:\bnoncredibility\b)",
    "Bar-Shalom–Campo fusion": r"\bBar-Shalom[–-]Campo\b",
    "Kalman filter": r"(?i:\bKalman(?: filters?| gains?| update| prediction)?\b)",
    "constant-velocity model": r"(?i:\bconstant[- ]velocity(?: models?| motion)?\b)|\bCV\b",
    "Joseph form": r"\bJoseph(?: form)?\b",
    "tracking index": r"(?i:\btracking index\b)",
    "LP relaxation": r"\bLP(?: relaxation)?\b|(?i:\blinear program(?:me|ming)?s?\b)",
    "subgradient": r"(?i:\bsubgradients?\b)",
    "greedy association": r"(?i:\bgreedy\b|\bnearest[- ]neighbou?r (?:pairing|rule)s?\b)",
    "operating characteristic": r"(?i:\boperating characteristics?\b)",
    "ADS-B": r"\bADS-B\b",
    "WGS-84": r"\bWGS-84\b",
    "ENU": r"\bENU\b|(?i:\beast[- ]north[- ]up\b)",
    "Stone Soup": r"\bStone Soup\b",
    "non-assignment cost": r"(?i:\bnon-assignment costs?\b)",
    "linearized conversion": r"(?i:\blineari[sz]ed (?:conversions?|covariances?)\b)",
    "binding": r"(?i:\bbinding\b)",
    "false-accept probability": r"(?i:\bfalse[- ]accept(?:ance)?(?: rates?| probabilit(?:y|ies))?\b)",
    "sector": r"(?i:\bsectors?\b)",
    "hand-over": r"(?i:\bhand-overs?\b)",
    "real-time factor": r"(?i:\breal-time factors?\b)",
    "spatial index": r"(?i:\bspatial ind(?:ex|exes|ices)\b)",
}


@dataclass(frozen=True)
class Use:
    """The first prose use of a term on a page that is neither linked nor defined."""

    page: str
    line: int
    term: str
    text: str

    def __str__(self) -> str:
        return f"{self.page}:{self.line}: {self.term!r} first used as {self.text!r} " \
               f"without {{term}}`{self.term}` or a bold definition"


def _blank(m: re.Match) -> str:
    """The match replaced by spaces, its newlines kept, so offsets and lines stay put."""
    return re.sub(r"[^\n]", " ", m.group(0))


_FRONT_MATTER = re.compile(r"\A---\n.*?\n---\n", re.S)
_FENCED = re.compile(r"^(`{3,}|:{3,})\{(?:math|eval-rst|glossary|code-block|code)\}.*?^\1[ \t]*$",
                     re.S | re.M)
_PLAIN_FENCE = re.compile(r"^(`{3,})(?!\{)[^\n]*\n.*?^\1[ \t]*$", re.S | re.M)
_DISPLAY_MATH = re.compile(r"\$\$.*?\$\$|\\begin\{(\w+\*?)\}.*?\\end\{\1\}", re.S)
_COMMENT = re.compile(r"<!--.*?-->|^%.*$", re.S | re.M)
_DIRECTIVE_LINE = re.compile(r"^[ \t]*(?:`{3,}|:{3,}).*$", re.M)
_OPTION_BLOCK = re.compile(r"^([ \t]*(?:`{3,}|:{3,})\{[^\n]*\n)(---\n.*?\n---\n)", re.S | re.M)
_OPTION_LINE = re.compile(r"^[ \t]*:[\w-]+:.*$", re.M)
_LABEL_LINE = re.compile(r"^\([\w-]+\)=[ \t]*$", re.M)
_HEADING = re.compile(r"^#{1,6} .*$", re.M)
_ROLE = re.compile(r"\{([\w:-]+)\}`([^`]*)`")
_INLINE_CODE = re.compile(r"`[^`\n]+`")
_INLINE_MATH = re.compile(r"\$[^$\n]+\$")
_LINK_TARGET = re.compile(r"(?<=\])\([^)\s]+\)|<https?://[^>]+>")
_BOLD = re.compile(r"\*\*[^*\n]+?\*\*")
_TITLED = re.compile(r"^(.*?)[ \t]*<([^<>]+)>$", re.S)


def prose(text: str) -> tuple[str, list[tuple[int, int, str]]]:
    """A page's prose, every other character blanked (offsets kept), and its ``{term}`` links.

    Returns the blanked text and the links as ``(start, end, target)``: the span of the
    text a reader sees and the glossary entry it points to. Code cells, fenced blocks, math,
    directive lines and options, labels, headings, comments, inline code and link targets
    are blanked; a role's visible text is kept (``{ref}`text <label>``` keeps ``text``).
    """
    text = _FRONT_MATTER.sub(_blank, text)
    text = CODE_CELL.sub(_blank, text)
    for pattern in (_FENCED, _PLAIN_FENCE, _DISPLAY_MATH, _COMMENT):
        text = pattern.sub(_blank, text)
    text = _OPTION_BLOCK.sub(lambda m: m.group(1) + re.sub(r"[^\n]", " ", m.group(2)), text)
    for pattern in (_DIRECTIVE_LINE, _OPTION_LINE, _LABEL_LINE, _HEADING):
        text = pattern.sub(_blank, text)
    links = []
    out = []
    last = 0
    for m in _ROLE.finditer(text):
        role, body = m.group(1), m.group(2)
        start = m.start(2)
        titled = _TITLED.match(body)
        shown = titled.group(1) if titled else body
        keep = role in {"term", "ref", "doc", "numref"} and (role == "term" or titled)
        piece = ["\n" if c == "\n" else " " for c in m.group(0)]
        if keep:
            offset = start - m.start()
            piece[offset:offset + len(shown)] = shown
            if role == "term":
                target = titled.group(2) if titled else body
                links.append((start, start + len(shown), " ".join(target.split()).lower()))
        out.append(text[last:m.start()])
        out.append("".join(piece))
        last = m.end()
    out.append(text[last:])
    text = "".join(out)
    for pattern in (_INLINE_CODE, _INLINE_MATH, _LINK_TARGET):
        text = pattern.sub(_blank, text)
    return text, links


def page_text(path: Path) -> str:
    """A page's source with its ``{include}`` directives replaced by the included files."""
    text = path.read_text(encoding="utf-8")

    def include(m: re.Match) -> str:
        return (path.parent / m.group(1).strip()).read_text(encoding="utf-8")

    return re.sub(r"^```\{include\}\s*(\S+)\s*\n```\s*$", include, text, flags=re.M)


def _compact(text: str, body: str):
    """The prose's words joined by single spaces, and the map back to offsets in the page.

    Blanked prose is mostly spaces, which makes every pattern search slow; the words, joined
    by one character each, are searched quickly. Words that the page separates by a space or
    a line break (a term may be broken across lines) are joined by a space; words separated by
    anything else (a blank line, math, the markup of a role) by a NUL, which no term spans.
    """
    tokens = list(re.finditer(r"[^ \n]+", body))
    pieces, starts, position, last = [], [], 0, None
    for t in tokens:
        if last is not None:
            gap = text[last:t.start()]
            pieces.append(" " if re.fullmatch(r" |[ \t]*\n[ \t]*", gap) else "\0")
            position += 1
        starts.append(position)
        pieces.append(t.group())
        position += len(t.group())
        last = t.end()
    compact = "".join(pieces)

    def to_body(i: int) -> int:
        k = bisect_right(starts, i) - 1
        return tokens[k].start() + (i - starts[k])

    return compact, to_body


@cache
def _compiled(pattern: str) -> tuple[re.Pattern, re.Pattern]:
    """A term's pattern, and the same without its word boundaries (a quicker superset)."""
    return re.compile(pattern), re.compile(pattern.replace(r"\b", ""))


def _search(pattern: str, text: str) -> re.Match | None:
    r"""``re.search(pattern, text)``, started where the pattern without ``\b`` first matches.

    Every match of the pattern matches without its boundaries, so none starts earlier; a
    leading ``\b`` keeps ``re`` from its quick literal scan, which the superset can use.
    """
    exact, loose = _compiled(pattern)
    first = loose.search(text)
    return None if first is None else exact.search(text, first.start())


def first_uses(text: str, terms: dict[str, str] = TERMS, *,
               parsed=None) -> dict[str, tuple[int, int, bool]]:
    """Each term's first prose use on a page: ``term -> (offset, end, linked_or_defined)``.

    ``parsed`` is the page's ``prose(text)`` when already computed.
    """
    body, links = parsed or prose(text)
    bold = [m.span() for m in _BOLD.finditer(body)]
    compact, to_body = _compact(text, body)
    found = {}
    for term, pattern in terms.items():
        m = _search(pattern, compact)
        if m is None:
            continue
        a, b = to_body(m.start()), to_body(m.end() - 1) + 1
        linked = any(s <= a and b <= e and t == term.lower() for s, e, t in links)
        defined = any(s <= a and b <= e for s, e in bold)
        found[term] = (a, b, linked or defined)
    return found


def unexplained(path: Path, terms: dict[str, str] = TERMS, *, name: str | None = None) -> list[Use]:
    """The terms whose first prose use on a page is neither linked nor defined."""
    text, body, links = page_prose(path)
    name = name or str(path.relative_to(ROOT) if path.is_relative_to(ROOT) else path)
    uses = (book_uses(path) if terms is TERMS
            else first_uses(text, terms, parsed=(body, links)))
    return [Use(name, text.count("\n", 0, a) + 1, term, text[a:b])
            for term, (a, b, ok) in uses.items() if not ok]


@cache
def book_uses(path: Path) -> dict[str, tuple[int, int, bool]]:
    """:func:`first_uses` of the listed terms on a page (computed once per test run)."""
    text, body, links = page_prose(path)
    return first_uses(text, TERMS, parsed=(body, links))


def glossary_entries(text: str) -> dict[str, str]:
    """The entries of the ``{glossary}`` directives of a page: ``term (lower case) -> definition``.

    A term starts a line; terms on consecutive lines share the indented definition below them.
    """
    entries: dict[str, str] = {}
    for block in re.findall(r"^```\{glossary\}[^\n]*\n(.*?)^```[ \t]*$", text, re.S | re.M):
        names: list[str] = []
        defining = False
        for line in block.splitlines():
            if not line.strip() or line.startswith(":"):
                continue
            if line[0].isspace():
                defining = True
                for n in names:
                    entries[n] = f"{entries[n]} {line.strip()}".strip()
            else:
                if defining:
                    names, defining = [], False
                names.append(line.strip().lower())
                entries.setdefault(names[-1], "")
    return entries


@cache
def page_prose(path: Path) -> tuple[str, str, tuple[tuple[int, int, str], ...]]:
    """A book page's source, its prose and its ``{term}`` links (read once per test run)."""
    text = page_text(path)
    body, links = prose(text)
    return text, body, tuple(links)


def book_pages() -> list[Path]:
    """The book's pages: ``book/**/*.md``, the included errata fragments counted in their page."""
    return sorted(p for p in BOOK.rglob("*.md") if p.parent.name != "errata")


# ------------------------------------------------------------------------------------ tests
GLOSSARY = glossary_entries(GLOSSARY_PAGE.read_text(encoding="utf-8"))


def test_every_listed_term_is_a_glossary_entry():
    missing = [t for t in TERMS if t.lower() not in GLOSSARY]
    assert GLOSSARY and not missing, f"terms without a glossary entry: {missing}"


def test_every_glossary_entry_is_defined_and_links_to_its_derivation():
    labels = book_labels() | {m for f in BOOK.rglob("*.md") for m in re.findall(
        r"^:label:\s*(\S+)|^\$\$.*\$\$\s*\(([\w-]+)\)", f.read_text(encoding="utf-8"), re.M)
        for m in m if m}
    bad = []
    for term, definition in GLOSSARY.items():
        refs = re.findall(r"\{(ref|doc|eq|numref)\}`(?:[^`<]*<)?([^`>]+)>?`", definition)
        if len(definition.split()) < 8 or not refs:
            bad.append(f"{term}: no definition or no link ({definition[:60]!r})")
        for role, target in refs:
            exists = ((BOOK / f"{target}.md").exists() if role == "doc"
                      else target in labels)
            if not exists:
                bad.append(f"{term}: {{{role}}}`{target}` names nothing in the book")
    assert not bad, "\n".join(bad)


def test_every_term_is_used_in_the_book():
    """Each pattern finds its term somewhere, so the rule below checks something."""
    used = {t for p in book_pages() if p != GLOSSARY_PAGE for t in book_uses(p)}
    unused = [t for t in TERMS if t not in used]
    assert not unused, f"patterns that find nothing in the book's prose: {unused}"


def test_every_term_link_names_a_glossary_entry():
    bad = []
    for page in book_pages():
        text, _, links = page_prose(page)
        for a, _, target in links:
            if target not in GLOSSARY:
                bad.append(f"{page.relative_to(ROOT)}:{text.count(chr(10), 0, a) + 1}: "
                           f"{{term}} target {target!r} is not a glossary entry")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("page", [p for p in book_pages() if p != GLOSSARY_PAGE],
                         ids=lambda p: str(p.relative_to(BOOK)))
def test_first_use_of_each_term_is_linked_or_defined(page):
    problems = unexplained(page)
    assert not problems, "\n".join(map(str, problems))


# ------------------------------------------------------------------ the rule on planted pages
_PLANTED_HEAD = """---
jupytext:
  text_representation:
    format_name: myst
---

(planted)=
# A page about GOSPA

```{code-cell} ipython3
gospa = "GOSPA in code is not prose"
```

$$\\text{GOSPA} = d_p^{(c)}$$

```{math}
:label: eq-planted
\\text{NEES}
```
"""


@pytest.mark.parametrize(("sentence", "ok"), [
    ("The GOSPA score of a scan is small.", False),
    ("The {term}`GOSPA` score of a scan is small.", True),
    ("The {term}`score <GOSPA>` of a scan is small, and GOSPA is a metric.", False),
    ("The {term}`GOSPA score <GOSPA>` of a scan is small.", True),
    ("The **GOSPA** metric charges every error of a set of estimates.", True),
    ("The *GOSPA* score of a scan is small.", False),
    ("Scores as `gospa(x, y)` and $\\mathrm{GOSPA}$ first, then {term}`GOSPA`.", True),
    ("A {term}`GOSPA <NEES>` link to another entry.", False),
])
def test_rule_on_a_planted_page(tmp_path, sentence, ok):
    page = tmp_path / "planted.md"
    page.write_text(_PLANTED_HEAD + "\n" + sentence + " Later GOSPA is plain.\n",
                    encoding="utf-8")
    problems = unexplained(page, {"GOSPA": TERMS["GOSPA"]}, name="planted.md")
    assert (not problems) == ok, problems
    if not ok:
        line = _PLANTED_HEAD.count("\n") + 2
        assert [(p.page, p.line, p.term) for p in problems] == [("planted.md", line, "GOSPA")]


def test_rule_blanks_only_what_is_not_prose():
    text = _PLANTED_HEAD + "\nSee {ref}`the NEES section <planted>` and [NIS](https://x.org/NIS).\n"
    body, links = prose(text)
    assert "GOSPA" not in body and body.count("NEES") == 1 and body.count("NIS") == 1
    assert len(body) == len(text) and body.count("\n") == text.count("\n")
    assert links == []


def test_rule_finds_a_term_broken_across_lines_and_not_across_markup(tmp_path):
    terms = {"maximum likelihood": TERMS["maximum likelihood"]}
    page = tmp_path / "broken.md"
    page.write_text("# Title\n\nThe maximum $x$ likelihood of it, the {term}`maximum <GOSPA>`\n"
                    "likelihood, then the\nmaximum-likelihood\n  estimate.\n", encoding="utf-8")
    assert [(u.line, u.text) for u in unexplained(page, terms, name="broken.md")] == [
        (5, "maximum-likelihood")]
    page = tmp_path / "broken_2.md"      # pages are read once per path
    page.write_text("# Title\n\nThe first is the maximum\n  likelihood estimate.\n", encoding="utf-8")
    assert [(u.line, u.text) for u in unexplained(page, terms, name="broken.md")] == [
        (3, "maximum\n  likelihood")]


def test_glossary_entries_are_read_as_sphinx_reads_them():
    text = ("```{glossary}\n:sorted:\n\nGOSPA\n  A metric, eq. {eq}`eq-gospa`.\n\nclutter\n"
            "false report\n  Reports of no object.\n  Uniform in space.\nlone\n```\n")
    assert glossary_entries(text) == {
        "gospa": "A metric, eq. {eq}`eq-gospa`.",
        "clutter": "Reports of no object. Uniform in space.",
        "false report": "Reports of no object. Uniform in space.",
        "lone": ""}
