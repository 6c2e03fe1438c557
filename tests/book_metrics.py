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
from html import unescape
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HIDDEN_TAGS = {"remove-cell", "remove-input", "hide-input", "hide-cell"}
CHECK_CALL = re.compile(
    r"\b(check_\w+|require|assert_\w+)\s*\(|^\s*assert\s|raise\s+\w*(Error|Exception)\b", re.M
)
#: A code cell of a MyST page, its body (options and code) as group 1.
CODE_CELL = re.compile(r"```\{code-cell\}[^\n]*\n(.*?)```", re.S)
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


# ------------------------------------------------------------------ what the reader sees as text
_HIDDEN_BLOCKS = re.compile(
    r"<(script|style|pre|code|svg|textarea)\b.*?</\1>"
    r"|<(span|div)\b[^>]*class=\"[^\"]*\bmath\b[^\"]*\"[^>]*>.*?</\2>", re.S | re.I)


def visible_text(html: str) -> str:
    """The prose of a built page, with maths, code, scripts and styles removed."""
    main = re.search(r"<main\b.*?</main>", html, re.S)
    text = _HIDDEN_BLOCKS.sub(" ", main.group(0) if main else html)
    text = unescape(re.sub(r"<[^>]+>", " ", text))
    # inline maths MathJax has not typeset yet: \( ... \) and $ ... $
    return re.sub(r"\\\(.*?\\\)|\$[^$]*\$", " ", text, flags=re.S)


#: A LaTeX command a reader would see verbatim (MathJax typesets maths, not prose).
BACKSLASH_COMMAND = re.compile(r"\\(?:[A-Za-z]{2,}|_)")


def contents_entries(html: str) -> list[str]:
    """The entries of the page's contents panel ("On this page"), as the reader sees them."""
    nav = re.search(r'<nav[^>]*class="[^"]*page-toc[^"]*"[^>]*>(.*?)</nav>', html, re.S)
    if nav is None:
        return []
    return [re.sub(r"\s+", " ", re.sub(r"<[^>]+>", "", a)).strip()
            for a in re.findall(r"<a\b[^>]*>(.*?)</a>", nav.group(1), re.S)]


def contents_problems(entries: list[str], labels: set[str]) -> list[str]:
    """Entries that show a raw label "(label)" or a second number ("11.7.1. 1. ...")."""
    bad = []
    for e in entries:
        raw = [m for m in re.findall(r"\(([\w-]+)\)", e) if m in labels]
        if raw or re.match(r"^\d+(?:\.\d+)*\.?\s+\d+\.\s", e):
            bad.append(e)
    return bad


def book_labels(root: Path = ROOT) -> set[str]:
    """Every MyST target ``(label)=`` of the book's sources."""
    return {m for f in (root / "book").rglob("*.md")
            for m in re.findall(r"^\(([\w-]+)\)=", f.read_text(encoding="utf-8"), re.M)}


# ------------------------------------------------------------------ numbers that write the prose
_TELLS_PROSE = {
    "a plural in brackets, 'worker(s)'": re.compile(r"[a-z]\(s\)"),
    "a count of its own total, '2 of the 2'": re.compile(r"\b(\d+) of (?:the )?\1\b"),
    "an interval in bold": re.compile(r"\*\*[^*\n]*\[\s*-?\d[\d.]*,\s*-?\d[\d.]*\][^*\n]*\*\*"),
}


def _string_constants(tree):
    """The string literals of a cell that can reach the page (docstrings left out)."""
    import ast

    docs = {id(n.body[0].value) for n in ast.walk(tree)
            if isinstance(n, (ast.Module, ast.FunctionDef, ast.ClassDef))
            and ast.get_docstring(n, clean=False) is not None}
    return [n.value for n in ast.walk(tree)
            if isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in docs]


def prose_tells(path: Path) -> list[str]:
    """Where generated numbers write the prose badly: what a reader would stumble on.

    In the prose and in the strings a cell can print: "worker(s)", "2 of the 2", an
    interval in bold; and a generated paragraph (a ``Markdown(...)`` that is not a table)
    that strings two or more intervals (``.format(...)`` of a Monte-Carlo result) together.
    One rounded number goes in a sentence; intervals go in a table or a caption.
    """
    import ast

    text = path.read_text(encoding="utf-8")
    found = []
    prose = CODE_CELL.sub("", text)
    for what, pattern in _TELLS_PROSE.items():
        found += [f"{what}: {m.group(0)[:60]!r}" for m in pattern.finditer(prose)]
    for body in CODE_CELL.findall(text):
        body = re.sub(r"\A---\n.*?\n---\n", "", body, flags=re.S)   # a YAML options block
        code = "\n".join(line for line in body.splitlines() if not line.startswith(":"))
        try:
            tree = ast.parse(code)
        except SyntaxError:
            continue
        for s in _string_constants(tree):
            if _TELLS_PROSE["a plural in brackets, 'worker(s)'"].search(s):
                found.append(f"a plural in brackets in a printed string: {s[:60]!r}")
            if re.search(r"^ of the \d+\b", s):
                found.append(f"a count against a typed total, '... of the 2': {s[:60]!r}")
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and getattr(node.func, "id", "") == "Markdown":
                src = ast.get_source_segment(code, node) or ""
                if "|---" not in src and len(re.findall(r"\.format\(", src)) >= 2:
                    found.append(f"a paragraph of intervals: {src[:70]!r}")
                if re.search(r"\*\*\{[^}]*(?:format|low|high)", src):
                    found.append(f"an interval in bold: {src[:70]!r}")
    return found
