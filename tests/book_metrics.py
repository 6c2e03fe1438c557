"""Teaching metrics of the book's pages, from the chapter sources and the built HTML.

``python tests/book_metrics.py`` prints one row per page of the table of contents
that is a notebook (``python tests/book_metrics.py book/01_fusion.md`` for some
pages); ``tests/test_teaching.py`` asserts the limits of ``CONTRIBUTING.md``.

From the source (the MyST notebook, read with jupytext):

* **visible code cells** — code cells not tagged ``remove-cell``, ``remove-input``,
  ``hide-input`` or ``hide-cell`` and not inside a (folded) solution;
* **visible check cells** — visible code cells that call a check
  (``check_*``, ``require``, ``np.testing``, ``assert``, ``raise ...Error``);
* **reading minutes** — prose words / 200 + visible code lines / 10, where prose is
  the Markdown outside solutions, with display math, directive options, labels and
  comments left out and inline math counted as one word;
* **summary**, **learn / know** — the admonitions the chapter shape requires;
* **exercises** — ``{exercise-start}`` / ``{exercise}`` directives;
* **dead controls** — visible code cells that build live controls (``controls(``).

From the built page (``_build/html``), when it exists:

* **figure first** — an image appears before the first display equation;
* **first exercise** — the number Sphinx gives the page's first exercise;
* **widget-state bytes** — size of the embedded ipywidgets state;
* **player frames** — the fewest frames of any scrubbable player on the page.
"""

from __future__ import annotations

import re
import sys
from dataclasses import asdict, dataclass, fields
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HIDDEN_TAGS = {"remove-cell", "remove-input", "hide-input", "hide-cell"}
CHECK_CALL = re.compile(
    r"\b(check_\w+|require|assert_\w+)\s*\(|^\s*assert\s|raise\s+\w*(Error|Exception)\b", re.M
)
WORDS_PER_MINUTE = 200
CODE_LINES_PER_MINUTE = 10


@dataclass
class PageMetrics:
    """Teaching metrics of one page (see the module docstring)."""

    page: str
    code_cells: int
    visible_code: int
    visible_checks: int
    check_share: float
    prose_words: int
    visible_code_lines: int
    reading_minutes: float
    summary: bool
    learn_know: bool
    exercises: int
    dead_controls: int
    figure_first: bool | None = None
    first_exercise: str | None = None
    widget_state_bytes: int | None = None
    player_frames: int | None = None


_DISPLAY_MATH = re.compile(r"\$\$.*?\$\$|```\{math\}.*?```|\\begin\{(\w+\*?)\}.*?\\end\{\1\}",
                           re.S)
_INLINE_MATH = re.compile(r"\$[^$\n]+\$")
_NON_PROSE_LINE = re.compile(r"^\s*(:[\w-]+:.*|\(.+\)=\s*|```.*|:::.*|<!--.*-->|---\s*)$")


def _prose_words(markdown: str) -> int:
    text = _DISPLAY_MATH.sub(" ", markdown)
    text = _INLINE_MATH.sub(" math ", text)
    lines = [ln for ln in text.splitlines() if not _NON_PROSE_LINE.match(ln)]
    return len(re.findall(r"\S+", "\n".join(lines)))


def source_metrics(path: Path) -> PageMetrics:
    """The source half of a page's metrics."""
    import jupytext

    nb = jupytext.read(path)
    in_solution = False
    code = visible = checks = words = code_lines = dead = exercises = 0
    summary = learn = know = False
    for cell in nb.cells:
        src = cell.source
        if cell.cell_type == "markdown":
            # a markdown cell may open or close a solution; count only prose outside them
            parts = re.split(r"(```\{solution-start\}|```\{solution-end\})", src)
            for part in parts:
                if part == "```{solution-start}":
                    in_solution = True
                elif part == "```{solution-end}":
                    in_solution = False
                elif not in_solution:
                    words += _prose_words(part)
            exercises += len(re.findall(r"```\{exercise(?:-start)?\}", src))
            summary |= bool(re.search(r"\{admonition\}\s*Summary", src))
            learn |= "{admonition} What you will learn" in src
            know |= "{admonition} You should already know" in src
            continue
        if cell.cell_type != "code":
            continue
        code += 1
        tags = set(cell.metadata.get("tags", []))
        if in_solution or tags & HIDDEN_TAGS:
            continue
        visible += 1
        code_lines += len([ln for ln in src.splitlines() if ln.strip()])
        checks += bool(CHECK_CALL.search(src))
        dead += "controls(" in src
    minutes = words / WORDS_PER_MINUTE + code_lines / CODE_LINES_PER_MINUTE
    return PageMetrics(
        page=_docname(path), code_cells=code, visible_code=visible, visible_checks=checks,
        check_share=checks / visible if visible else 0.0, prose_words=words,
        visible_code_lines=code_lines, reading_minutes=round(minutes, 1), summary=summary,
        learn_know=learn and know, exercises=exercises, dead_controls=dead,
    )


_WIDGET_STATE = re.compile(
    r'<script type="application/vnd\.jupyter\.widget-state\+json">(.*?)</script>', re.S)
_DISPLAY_MATH_HTML = re.compile(r'<div class="math[^"]*"|class="[^"]*text_latex')
_OUTPUT_IMAGE = re.compile(r'<img[^>]+src="(?:data:image|[^"]*_images/)')
_PLAYER = re.compile(r"var frames = new Array\((\d+)\)")


def html_metrics(html: str) -> dict:
    """The built-page half of a page's metrics."""
    body = html.split('<main', 1)[-1]
    eq = _DISPLAY_MATH_HTML.search(body)
    img = _OUTPUT_IMAGE.search(body)
    figure_first = img is not None and (eq is None or img.start() < eq.start())
    first = re.search(r'class="exercise[^"]*".*?<span class="caption-number">Exercise\s*'
                      r'(\d+(?:\.\d+)*)', body, flags=re.S)
    state = sum(len(m.group(1)) for m in _WIDGET_STATE.finditer(html))
    frames = [int(n) for n in _PLAYER.findall(body)]
    return {"figure_first": figure_first, "first_exercise": first.group(1) if first else None,
            "widget_state_bytes": state, "player_frames": min(frames) if frames else None}


def _docname(path: Path) -> str:
    """``book/01_fusion`` for a page of this book or of another checkout of it."""
    path = path.resolve()
    return str(path.relative_to(_book_root(path)).with_suffix(""))


def _book_root(path: Path) -> Path:
    """The directory holding ``book/`` (this checkout, or another one)."""
    return next((p.parent for p in path.resolve().parents if p.name == "book"),
                path.resolve().parent)


def page_metrics(path: Path, html_dir: Path | None = None) -> PageMetrics:
    """Source metrics, plus the built page's when `html_dir` holds it."""
    m = source_metrics(path)
    if html_dir is None:
        html_dir = _book_root(path) / "_build" / "html"
    page = html_dir / f"{m.page}.html"
    if page.exists():
        for k, v in html_metrics(page.read_text(encoding="utf-8")).items():
            setattr(m, k, v)
    return m


def table(rows: list[PageMetrics]) -> str:
    """The metrics as a Markdown table."""
    names = [f.name for f in fields(PageMetrics)]
    out = ["| " + " | ".join(names) + " |", "|" + "---|" * len(names)]
    for r in rows:
        vals = []
        for v in asdict(r).values():
            vals.append(f"{v:.2f}" if isinstance(v, float) else ("–" if v is None else str(v)))
        out.append("| " + " | ".join(vals) + " |")
    return "\n".join(out)


def main(argv: list[str]) -> None:
    sys.path.insert(0, str(ROOT / "tests"))
    from book_tools import notebook_docnames

    paths = [Path(a) for a in argv] or [ROOT / f"{d}.md" for d in notebook_docnames()]
    print(table([page_metrics(p) for p in paths]))


if __name__ == "__main__":
    main(sys.argv[1:])
