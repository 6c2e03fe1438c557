r"""Sphinx extension of the radarfusion book: the PDF edition (LaTeX builder only).

What the printed book needs that the HTML pages get elsewhere:

* **Macros.** The book's TeX macros (``\E``, ``\Var``, ``\Cov``, ``\T``) are
  defined once, for MathJax, in ``_config.yml`` (``mathjax3_config.tex.macros``).
  Here the same definitions become ``\newcommand``\ s in the LaTeX preamble, so
  the two editions cannot drift apart.
* **A class that Debian's TeX Live has.** sphinx-jupyterbook-latex (which turns the
  parts of ``_toc.yml`` into LaTeX parts and leaves out what ``hide-input``,
  ``hide-output`` and ``hide-cell`` hide on the HTML page) sets its own
  ``jupyterBook`` class, which loads ``bbm``, a package Debian ships only in
  texlive-fonts-extra (500 MB to download). The book uses none of that class's
  additions but the two environments its code cells are wrapped in, so the
  book's PDF uses Sphinx's ``manual`` class with those two environments.

* **Equations tagged by hand.** ``\tag`` inside the ``split`` Sphinx wraps display
  math in is an error in LaTeX (MathJax accepts it); such an equation's tag is moved
  after the ``split``.

* **Exercise references across pages** get the label Sphinx's ``{ref}`` points at.
* **Chapter numbers as on the HTML pages**: the unnumbered parts' chapters are
  unnumbered in print too, so chapter 1 is the fused estimate in both editions
  (equations read (1.1) as on the HTML pages; sphinx-jupyterbook-latex numbers
  exercises per section in print, 1.7.1).
* **Exercises on the root page** keep their text inside their boxes.
* **Long tables** (the notation table) wrap their cells instead of running off the page.
* **Fonts** with every character the book prints, code outputs included.

Nothing here changes the HTML build: it sets LaTeX configuration values and
transforms the doctree for the ``latex`` format only.

Registered in ``_config.yml`` under ``sphinx: local_extensions:``.
"""

from __future__ import annotations

import re

from docutils import nodes
from sphinx import addnodes
from sphinx.transforms.post_transforms import SphinxPostTransform

_TAG = re.compile(r"\\tag\*?\{[^{}]*\}")


def macro_preamble(macros: dict) -> str:
    r"""``\newcommand`` lines for MathJax macros (``name: body`` or ``name: [body, n]``).

    A name LaTeX already defines is redefined (``\providecommand`` then
    ``\renewcommand``), so the printed macro is the book's, not a package's.
    """
    lines = []
    for name, body in macros.items():
        nargs = 0
        if isinstance(body, (list, tuple)):
            body, nargs = body[0], int(body[1])
        arg = f"[{nargs}]" if nargs else ""
        lines.append(f"\\providecommand{{\\{name}}}{{}}\\renewcommand{{\\{name}}}{arg}{{{body}}}")
    return "\n".join(lines)


class TaggedDisplayMath(SphinxPostTransform):
    r"""A display equation numbered by hand (``$$ ... \tag{1} $$``) keeps its tag in print.

    Sphinx wraps every display equation in ``split``, where amsmath forbids
    ``\tag`` (MathJax allows it); the tag is moved after the ``split``.
    """

    default_priority = 200
    formats = ("latex",)

    def run(self, **kwargs) -> None:
        for node in list(self.document.findall(nodes.math_block)):
            text = node.astext()
            tags = _TAG.findall(text)
            if node.get("nowrap") or node.get("label") or len(tags) != 1 or "\n\n" in text.strip():
                continue
            body = _TAG.sub("", text).strip()
            wrapped = f"\\begin{{equation*}}\\begin{{split}}{body}\\end{{split}}{tags[0]}\\end{{equation*}}"
            new = nodes.math_block(wrapped, wrapped, nowrap=True, docname=node.get("docname"))
            new.source, new.line = node.source, node.line
            node.replace_self(new)


class ExerciseLabels(SphinxPostTransform):
    """A ``{ref}`` to an exercise from another page resolves in print.

    sphinx-exercise labels an exercise ``exercise:<label>`` in LaTeX, while Sphinx's
    cross-page ``{ref}`` points at ``<docname>:<label>``; the second label is added,
    carrying the exercise's number (so the reference reads "Exercise 8.3").
    """

    default_priority = 25          # after sphinx-exercise numbers its titles (20, 21)
    formats = ("latex",)

    def run(self, **kwargs) -> None:
        try:
            from sphinx_exercise.nodes import exercise_enumerable_node, exercise_node
            from sphinx_exercise.utils import get_node_number
        except ImportError:
            return
        kinds = (exercise_node, exercise_enumerable_node)
        for node in list(self.document.findall(lambda n: isinstance(n, kinds))):
            label, docname = node.get("label"), node.get("docname")
            if not label or not docname or node.parent is None:
                continue
            number = ""
            if isinstance(node, exercise_enumerable_node):
                number = get_node_number(self.app, node, "exercise")
            tex = (r"\begingroup\expandafter\def\csname @currentlabel\endcsname{" + number
                   + r"}\phantomsection\label{\detokenize{" + f"{docname}:{label}"
                   + r"}}\endgroup" + "\n")
            node.parent.insert(node.parent.index(node), nodes.raw("", tex, format="latex"))


class LongTableWidths(SphinxPostTransform):
    r"""A long table (more than 30 rows, a LaTeX ``longtable``) wraps its cells in print.

    Without widths, Sphinx sets a long table's columns as ``l`` (one line per cell), so
    a wide table runs off the page. Here each column gets a width in proportion to its
    longest cell (between 6 and 60 characters), which Sphinx turns into wrapping
    ``\X`` columns that share the text width.
    """

    default_priority = 200
    formats = ("latex",)
    LONG = 30

    def run(self, **kwargs) -> None:
        for table in list(self.document.findall(nodes.table)):
            if "colwidths-given" in table["classes"]:
                continue
            groups = list(table.findall(nodes.tgroup))
            if len(groups) != 1:
                continue
            rows = list(groups[0].findall(nodes.row))
            colspecs = [c for c in groups[0].children if isinstance(c, nodes.colspec)]
            if len(rows) <= self.LONG or not colspecs:
                continue
            longest = [6] * len(colspecs)
            for row in rows:
                for k, entry in enumerate(e for e in row.children if isinstance(e, nodes.entry)):
                    if k < len(longest):
                        longest[k] = max(longest[k], min(60, len(entry.astext())))
            for spec, width in zip(colspecs, longest, strict=True):
                spec["colwidth"] = width
            table["classes"].append("colwidths-given")


class ExerciseContent(SphinxPostTransform):
    """An exercise or solution keeps its text inside its box on the root page too.

    sphinx-exercise puts the text of an ``{exercise-start}`` / ``{solution-start}``
    block in an untitled section inside the box; on the root page,
    sphinx-jupyterbook-latex moves that page's sections (priority 700), which
    leaves the boxes empty and their text after the page's last cell. Here such a
    section becomes a plain container first.
    """

    default_priority = 650
    formats = ("latex",)

    def run(self, **kwargs) -> None:
        try:
            from sphinx_exercise.nodes import (
                exercise_enumerable_node,
                exercise_node,
                solution_node,
            )
        except ImportError:
            return
        kinds = (exercise_node, exercise_enumerable_node, solution_node)
        for box in list(self.document.findall(lambda n: isinstance(n, kinds))):
            for child in list(box.children):
                if isinstance(child, nodes.section) and not any(
                        isinstance(c, nodes.title) for c in child.children):
                    content = nodes.container("", *child.children)
                    child.replace_self(content)


class PartNumbering(SphinxPostTransform):
    """Chapters are numbered in print as on the HTML pages.

    The parts of ``_toc.yml`` that are not ``numbered`` ("Start here", the appendices)
    print their chapters and sections unnumbered, and do not advance the chapter
    counter, so the first numbered chapter is chapter 1 in both editions (LaTeX would
    otherwise count the two "Start here" pages as chapters 1 and 2).
    """

    default_priority = 750         # after sphinx-jupyterbook-latex builds the parts (700)
    formats = ("latex",)

    def run(self, **kwargs) -> None:
        sitemap = getattr(self.config, "external_site_map", None)
        if sitemap is None or not getattr(self.env, "jblatex_captions_to_parts", False):
            return
        numbered = {t.caption: bool(t.numbered) for t in sitemap.root.subtrees if t.caption}
        for section in list(self.document.findall(nodes.section)):
            caption = section.get("docname")
            if caption not in numbered or section.parent is None:
                continue
            anchor = section.parent.parent if isinstance(
                section.parent, addnodes.start_of_file) else section.parent
            if anchor is None or anchor.parent is None:
                continue
            depth = r"\rfSecNumDepth" if numbered[caption] else "-2"
            raw = nodes.raw("", r"\setcounter{secnumdepth}{" + depth + "}\n", format="latex")
            anchor.parent.insert(anchor.parent.index(anchor), raw)


#: The PDF's fonts: Sphinx's FreeSerif and FreeSans (Cyrillic, Greek), and DejaVu Sans
#: Mono for code and outputs, which has the characters the book's outputs print
#: (ᵀ, ᵃ, ✗, box drawing) that FreeMono lacks.
FONTPKG = r"""
\setmainfont{FreeSerif}[Extension=.otf, UprightFont=*, ItalicFont=*Italic,
  BoldFont=*Bold, BoldItalicFont=*BoldItalic]
\setsansfont{FreeSans}[Extension=.otf, UprightFont=*, ItalicFont=*Oblique,
  BoldFont=*Bold, BoldItalicFont=*BoldOblique]
\setmonofont{DejaVu Sans Mono}[Scale=MatchLowercase]
"""


#: What the book's LaTeX needs besides Sphinx's ``manual`` class: the two environments
#: sphinx-jupyterbook-latex wraps code cells' inputs and outputs in (from its
#: ``jupyterBook.cls``, whose other packages the book does not use, ``bbm`` among them,
#: which Debian ships only in texlive-fonts-extra).
CELL_ENVIRONMENTS = r"""
\AtBeginDocument{\edef\rfSecNumDepth{\number\value{secnumdepth}}}
\usepackage[strict]{changepage}
\definecolor{CodeBlockInputBorderColor}{RGB}{204,204,204}
\definecolor{CodeBlockInputColor}{RGB}{247,247,247}
\definecolor{CodeBlockOutputBorderColor}{RGB}{247,247,247}
\definecolor{CodeBlockOutputColor}{RGB}{252,252,252}
\newenvironment{sphinxVerbatimInput}
  {\colorlet{VerbatimBorderColor}{CodeBlockInputBorderColor}%
   \colorlet{VerbatimColor}{CodeBlockInputColor}%
   \begin{adjustwidth}{5pt}{}}
  {\end{adjustwidth}}
\newenvironment{sphinxVerbatimOutput}
  {\colorlet{VerbatimBorderColor}{CodeBlockOutputBorderColor}%
   \colorlet{VerbatimColor}{CodeBlockOutputColor}%
   \begin{adjustwidth}{20pt}{}}
  {\end{adjustwidth}}
"""


def _configure_latex(app, config) -> None:
    """After sphinx-jupyterbook-latex's own set-up: Sphinx's ``manual`` class with the
    cell environments, and the book's macros, in the preamble."""
    elements = dict(config.latex_elements or {})
    preamble = elements.get("preamble", "")
    if config.latex_theme == "jupyterBook":
        config.latex_theme = "manual"
        preamble += CELL_ENVIRONMENTS
    macros = (config.mathjax3_config or {}).get("tex", {}).get("macros", {})
    if macros:
        preamble += "\n% The book's macros (_config.yml: mathjax3_config.tex.macros)\n"
        preamble += macro_preamble(macros) + "\n"
    elements["preamble"] = preamble
    if config.latex_engine == "xelatex":
        elements.setdefault("fontpkg", FONTPKG)
    config.latex_elements = elements


def setup(app):
    app.connect("config-inited", _configure_latex, priority=900)
    app.add_post_transform(TaggedDisplayMath)
    app.add_post_transform(ExerciseLabels)
    app.add_post_transform(LongTableWidths)
    app.add_post_transform(ExerciseContent)
    app.add_post_transform(PartNumbering)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
