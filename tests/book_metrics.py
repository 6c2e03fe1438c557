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
* **dead controls** — visible code cells that build live controls (``controls(``);
* **long boxes** — visible code cells longer than :data:`MAX_BOX_LINES` lines;
* **door boxes** — visible code cells that call a validation function (``as_*``,
  ``require*``) or use a private name (``_x``) of ``radarfusion_ref``: the package's door
  and plumbing, where the reader should see the equation (see :func:`code_box_problems`).

From the built page (``_build/html``), when it exists:

* **figure first** — an image appears before the first display equation;
* **first exercise** — the number Sphinx gives the page's first exercise;
* **widget-state bytes** — size of the embedded ipywidgets state;
* **player frames** — the fewest frames of any scrubbable player on the page.
"""

from __future__ import annotations

import ast
import re
import sys
import textwrap
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
#: The longest visible code box, in lines: longer code is folded (``hide-input``).
MAX_BOX_LINES = 15
#: A call of the package's validation doors (``as_rng(...)``, ``checks.require(...)``).
VALIDATION_CALL = re.compile(r"(?<![\w.])(?:\w+\.)*(as_\w+|require(?:_\w+)?)\s*\(")
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
    long_boxes: int = 0
    door_boxes: int = 0
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


def _package_names(cells) -> tuple[set[str], set[str]]:
    """Names a page binds by importing ``radarfusion_ref``: (modules/objects, private ones)."""
    bound: set[str] = set()
    private: set[str] = set()
    for src in cells:
        tree = parse_cell(src)
        if tree is None:
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                for a in node.names:
                    if a.name.split(".")[0] == "radarfusion_ref":
                        bound.add(a.asname or a.name.split(".")[0])
            elif isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
                    "radarfusion_ref"):
                for a in node.names:
                    bound.add(a.asname or a.name)
                    if _private(a.name) or any(map(_private, node.module.split("."))):
                        private.add(a.asname or a.name)
    return bound, private


def _private(name: str) -> bool:
    return name.startswith("_") and not name.startswith("__")


def parse_cell(src: str):
    """The syntax tree of a cell, IPython magics and shell lines left out (None if invalid)."""
    code = "\n".join("" if ln.lstrip().startswith(("%", "!")) else ln
                     for ln in src.splitlines())
    try:
        return ast.parse(code)
    except SyntaxError:
        return None


def box_too_long(src: str) -> str | None:
    """A message if a code box is longer than :data:`MAX_BOX_LINES` lines (blank ends left out)."""
    lines = src.strip("\n").splitlines()
    if len(lines) <= MAX_BOX_LINES:
        return None
    return f"{len(lines)} lines (at most {MAX_BOX_LINES}): {lines[0].strip()[:50]!r}"


def box_shows_the_door(src: str, package: set[str], private: set[str]) -> list[str]:
    """What a code box shows of the package's door and plumbing instead of the equation.

    A call of a validation function (``as_*``, ``require*``), and a private name of the
    package: an import from a ``_module`` or of a ``_name`` of ``radarfusion_ref``, an
    attribute ``_x`` reached from a name the page imported from the package, or a private
    name the page imported, used here. `package` and `private` are the names the page's
    ``radarfusion_ref`` imports bind (:func:`_package_names`).
    """
    found = []
    calls = sorted({m.group(1) for m in VALIDATION_CALL.finditer(src)})
    if calls:
        found.append(f"calls the validation functions {calls}")
    tree = parse_cell(src)
    if tree is None:
        return found
    hidden: set[str] = set()
    own_package, own_private = _package_names([src])
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith(
                "radarfusion_ref"):
            hidden |= {f"{node.module}.{a.name}" for a in node.names
                       if _private(a.name) or any(map(_private, node.module.split(".")))}
        elif isinstance(node, ast.Attribute) and _private(node.attr):
            root = node.value
            while isinstance(root, ast.Attribute):
                root = root.value
            if isinstance(root, ast.Name) and root.id in package | own_package:
                hidden.add(f"{ast.unparse(node.value)}.{node.attr}")
        elif isinstance(node, ast.Name) and node.id in private | own_private:
            hidden.add(node.id)
    if hidden:
        found.append(f"shows the package's private names {sorted(hidden)}")
    return found


# ------------------------------------------------------------- package code shown by a page
#: Characters a code box shows without scrolling on a 1280 px page.
MAX_WIDTH = 76

_DIRECTIVE = re.compile(r"^```\{literalinclude\}[ \t]+(\S+)[ \t]*\n((?::[\w-]+:[^\n]*\n)*)",
                        flags=re.M)
_OPTION = re.compile(r"^:([\w-]+):[ \t]*(.*?)[ \t]*$", flags=re.M)


@dataclass(frozen=True)
class Listing:
    """One ``{literalinclude}`` with ``:pyobject:`` on a page."""

    page: Path
    page_line: int
    source: Path
    options: dict[str, str]

    @property
    def pyobject(self) -> str:
        return self.options["pyobject"]


def listings_of(page: Path) -> list[Listing]:
    """Every ``{literalinclude}`` with ``:pyobject:`` on one page."""
    found = []
    text = page.read_text(encoding="utf-8")
    for m in _DIRECTIVE.finditer(text):
        options = dict(_OPTION.findall(m.group(2)))
        if "pyobject" in options:
            found.append(Listing(page, text.count("\n", 0, m.start()) + 1,
                                 (page.parent / m.group(1)).resolve(), options))
    return found


def listings(book: Path) -> list[Listing]:
    """Every ``{literalinclude}`` with ``:pyobject:`` in the pages under *book*."""
    return [x for page in sorted(book.rglob("*.md")) for x in listings_of(page)]


def _object_span(tree: ast.Module, dotted: str) -> tuple[int, int] | None:
    """1-based first (decorator) and last line of ``Class.method``-style *dotted*."""
    body: list[ast.stmt] = tree.body
    node: ast.AST | None = None
    for part in dotted.split("."):
        node = next((n for n in body
                     if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
                     and n.name == part), None)
        if node is None:
            return None
        body = node.body
    assert isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
    first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
    return first, node.end_lineno or node.lineno


def _line_spec(spec: str, total: int) -> list[int]:
    """0-based indices of a ``:lines:`` spec such as ``1,30-`` or ``1-2,41-``."""
    picked: list[int] = []
    for part in (p.strip() for p in spec.split(",")):
        if "-" in part:
            lo, hi = part.split("-", 1)
            start = int(lo) - 1 if lo else 0
            stop = int(hi) if hi else total
            picked.extend(range(start, stop))
        else:
            picked.append(int(part) - 1)
    return [i for i in picked if 0 <= i < total]


def shown_lines(listing: Listing) -> list[tuple[int | None, str]]:
    """The lines the directive shows, each with its 1-based source line (None if added)."""
    source = listing.source.read_text(encoding="utf-8")
    span = _object_span(ast.parse(source), listing.pyobject)
    if span is None:
        raise LookupError(f"{listing.page.name}:{listing.page_line}: no object "
                          f"{listing.pyobject!r} in {listing.source}")
    text = source.splitlines()
    lines: list[tuple[int | None, str]] = [(n, text[n - 1])
                                           for n in range(span[0], span[1] + 1)]
    opts = listing.options

    def marker(key: str) -> int:
        """Index of the first shown line holding the option's text."""
        at = next((i for i, (_, s) in enumerate(lines) if opts[key] in s), None)
        if at is None:
            raise LookupError(f"{listing.page.name}:{listing.page_line}: "
                              f":{key}: {opts[key]!r} not in {listing.pyobject}")
        return at

    for key, keep_marker in (("start-at", True), ("start-after", False)):
        if key in opts:
            at = marker(key)
            lines = lines[at if keep_marker else at + 1:]
    for key, keep_marker in (("end-at", True), ("end-before", False)):
        if key in opts:
            at = marker(key)
            lines = lines[:at + 1 if keep_marker else at]
    if "lines" in opts:
        lines = [lines[i] for i in _line_spec(opts["lines"], len(lines))]
    if "dedent" in opts:
        if opts["dedent"]:
            k = int(opts["dedent"])
            lines = [(n, s[k:]) for n, s in lines]
        else:
            body = textwrap.dedent("\n".join(s for _, s in lines)).split("\n")
            lines = [(n, s) for (n, _), s in zip(lines, body, strict=True)]
    if "prepend" in opts:
        lines.insert(0, (None, opts["prepend"]))
    if "append" in opts:
        lines.append((None, opts["append"]))
    return lines


def too_wide(listing: Listing, width: int = MAX_WIDTH) -> list[str]:
    """One message per shown line of *listing* longer than *width* characters."""
    rel = listing.source.relative_to(ROOT) if listing.source.is_relative_to(ROOT) \
        else listing.source
    return [f"{listing.page.name}:{listing.page_line}: {rel}:{n} "
            f"({listing.pyobject}) shows {len(s)} > {width} characters: {s.strip()[:60]}"
            for n, s in shown_lines(listing) if len(s.expandtabs()) > width]


def visible_code_cells(path: Path) -> list[tuple[int, str]]:
    """The visible code cells of a page: (1-based cell number, source), solutions left out."""
    import jupytext

    nb = jupytext.read(path)
    in_solution = False
    out = []
    for number, cell in enumerate(nb.cells, start=1):
        if cell.cell_type == "markdown":
            for part in re.findall(r"```\{solution-(start|end)\}", cell.source):
                in_solution = part == "start"
            continue
        tags = set(cell.metadata.get("tags", []))
        if cell.cell_type == "code" and not in_solution and not tags & HIDDEN_TAGS:
            out.append((number, cell.source))
    return out


def listing_boxes(path: Path) -> list[tuple[str, str]]:
    """The package code a page shows with ``{literalinclude}`` and ``:pyobject:``.

    Each as (where, the shown text); a listing that names no object shows nothing here.
    """
    out = []
    for listing in listings_of(path):
        try:
            shown = "\n".join(s for _, s in shown_lines(listing))
        except LookupError:
            continue
        out.append((f"line {listing.page_line} ({listing.pyobject})", shown))
    return out


def _listing_private(src: str) -> set[str]:
    """In package source, every private name is the package's."""
    tree = parse_cell(textwrap.dedent(src))
    if tree is None:
        return set()
    return {n.id for n in ast.walk(tree) if isinstance(n, ast.Name) and _private(n.id)} | {
        n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute) and _private(n.attr)}


def code_boxes(path: Path) -> list[str]:
    """Every problem of every visible code box of a page (cells and listings), named."""
    import jupytext

    cells = [c.source for c in jupytext.read(path).cells if c.cell_type == "code"]
    package, private = _package_names(cells)
    boxes = [(f"cell {n}", src, box_shows_the_door(src, package, private))
             for n, src in visible_code_cells(path)]
    for where, src in listing_boxes(path):
        door = box_shows_the_door(textwrap.dedent(src), set(), _listing_private(src))
        boxes.append((f"listing at {where}", src, door))
    found = []
    for where, src, door in boxes:
        long = box_too_long(src)
        found += [f"{where}: {what}" for what in ([long] if long else []) + door]
    return found


def source_metrics(path: Path) -> PageMetrics:
    """The source half of a page's metrics."""
    import jupytext

    nb = jupytext.read(path)
    in_solution = False
    code = visible = checks = words = code_lines = dead = exercises = 0
    summary = learn = know = False
    package, private = _package_names([c.source for c in nb.cells if c.cell_type == "code"])
    long_boxes = door_boxes = 0
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
        long_boxes += box_too_long(src) is not None
        door_boxes += bool(box_shows_the_door(src, package, private))
    for _, src in listing_boxes(path):
        long_boxes += box_too_long(src) is not None
        door_boxes += bool(box_shows_the_door(textwrap.dedent(src), set(),
                                              _listing_private(src)))
    minutes = words / WORDS_PER_MINUTE + code_lines / CODE_LINES_PER_MINUTE
    return PageMetrics(
        page=_docname(path), code_cells=code, visible_code=visible, visible_checks=checks,
        check_share=checks / visible if visible else 0.0, prose_words=words,
        visible_code_lines=code_lines, reading_minutes=round(minutes, 1), summary=summary,
        learn_know=learn and know, exercises=exercises, dead_controls=dead,
        long_boxes=long_boxes, door_boxes=door_boxes,
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
