"""The code a chapter shows: the equation in the page's symbols, tied to the package.

Each chapter's main page shows at least one *reader's function*: a visible code cell
with a ``def`` of at most :data:`book_metrics.MAX_BOX_LINES` lines and no docstring,
written in the page's symbols. A hidden (``remove-cell``) cell then calls that function
and a public function of ``radarfusion_ref`` in a cell with a ``checks.check_*`` call, so the
executed book fails if the short version and the production one ever disagree.

Whatever package source a page still shows with ``{literalinclude}`` and ``:pyobject:``
must fit the code box: about :data:`book_metrics.MAX_WIDTH` characters a line on the built page. What
the directive shows is reproduced by :func:`book_metrics.shown_lines` -- the object
located with :mod:`ast` (decorators and docstring included), then
``:start-at:``/``:start-after:``, ``:end-before:``/``:end-at:``, ``:lines:``,
``:dedent:`` and ``:prepend:``/``:append:`` in the order Sphinx applies them -- and a
test fails naming page, file, object and source line for every shown line that is too
long.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from book_metrics import (
    MAX_BOX_LINES,
    box_too_long,
    listings,
    parse_cell,
    shown_lines,
    too_wide,
    visible_code_cells,
)
from book_tools import ROOT

from radarfusion_ref.kit import catalog

#: Chapters whose main page is still being converted to a reader's function (the
#: listing of package source they show today goes). Emptied as each page is converted;
#: every chapter not listed is held to the rule.
NOT_YET_CLEAN: set[str] = set()


def reader_functions(path: Path) -> dict[str, str]:
    """The reader's functions of a page: {name: problem or ""} for each visible ``def``.

    A visible code cell defining a function at its top level; the problem names what
    keeps it from being one (a box longer than the limit, a docstring).
    """
    found = {}
    for n, src in visible_code_cells(path):
        tree = parse_cell(src)
        if tree is None:
            continue
        for node in tree.body:
            if not isinstance(node, ast.FunctionDef):
                continue
            problem = box_too_long(src) or ""
            if ast.get_docstring(node) is not None:
                problem += f"cell {n}: `{node.name}` has a docstring (say it in the prose)"
            found[node.name] = problem
    return found


def _package_roots(cells: list[str]) -> set[str]:
    """Names the page binds to ``radarfusion_ref`` outside its kit (modules or functions)."""
    roots = set()
    for src in cells:
        tree = parse_cell(src)
        for node in ast.walk(tree) if tree is not None else ():
            if isinstance(node, ast.Import):
                roots |= {a.asname or a.name.split(".")[0] for a in node.names
                          if a.name.split(".")[0] == "radarfusion_ref"
                          and not a.name.startswith("radarfusion_ref.kit")}
            elif isinstance(node, ast.ImportFrom):
                module = node.module or ""
                if module.split(".")[0] == "radarfusion_ref" and not module.startswith(
                        "radarfusion_ref.kit"):
                    roots |= {a.asname or a.name for a in node.names
                              if not a.name.startswith("_") and a.name != "kit"}
    return roots


def _dotted(node: ast.AST) -> list[str] | None:
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    return [node.id, *reversed(parts)]


def tied_functions(path: Path, names: set[str]) -> set[str]:
    """The reader's functions (of `names`) a hidden cell checks against the package.

    A ``remove-cell`` cell that calls the reader's function and a public function of
    ``radarfusion_ref`` (not of its kit) and holds a ``check_*`` call.
    """
    import jupytext

    cells = [c for c in jupytext.read(path).cells if c.cell_type == "code"]
    roots = _package_roots([c.source for c in cells])
    tied = set()
    for cell in cells:
        if "remove-cell" not in cell.metadata.get("tags", []):
            continue
        tree = parse_cell(cell.source)
        called = [_dotted(c.func) for c in ast.walk(tree) if isinstance(c, ast.Call)] \
            if tree is not None else []
        called = [d for d in called if d]
        if not any(d[-1].startswith("check_") for d in called):
            continue
        package = any(d[0] in roots and d[0] not in names and d[1:2] != ["kit"]
                      and not any(p.startswith("_") for p in d) for d in called)
        if package:
            tied |= {d[0] for d in called if len(d) == 1 and d[0] in names}
    return tied


def reader_function_problem(path: Path) -> str | None:
    """Why a page fails the rule of the module docstring, or None."""
    functions = reader_functions(path)
    good = {name for name, problem in functions.items() if not problem}
    if not good:
        bad = "; ".join(p for p in functions.values() if p)
        return ("no reader's function: a visible cell with a `def` of at most "
                f"{MAX_BOX_LINES} lines and no docstring"
                + (f" ({bad})" if bad else ""))
    if not tied_functions(path, good):
        return (f"no hidden (remove-cell) cell calls the reader's functions {sorted(good)} "
                "and a public radarfusion_ref function in a cell with a checks.check_* call")
    return None



# ----------------------------------------------------------------------------- the book
BOOK_LISTINGS = listings(ROOT / "book")


MAIN_PAGES = sorted(c.docname for c in catalog.CHAPTERS)


@pytest.mark.parametrize("docname", [
    pytest.param(d, marks=pytest.mark.xfail(strict=False, reason="being converted"))
    if d in NOT_YET_CLEAN else d for d in MAIN_PAGES])
def test_a_chapter_shows_the_equation_as_a_readers_function(docname):
    problem = reader_function_problem(ROOT / f"{docname}.md")
    assert problem is None, f"{docname}: {problem}"


def test_the_not_yet_clean_list_names_chapters():
    assert set(MAIN_PAGES) >= NOT_YET_CLEAN, sorted(NOT_YET_CLEAN - set(MAIN_PAGES))


def test_every_listing_fits_the_code_box():
    """Every package listing a page shows (none today: pages show reader's functions)."""
    problems = []
    for listing in BOOK_LISTINGS:
        if not shown_lines(listing):
            problems.append(f"{listing.page.name}: {listing.pyobject} shows nothing")
        problems += too_wide(listing)
    assert not problems, "\n".join(problems)


# ----------------------------------------------------------------------------- the checks
_READER_PAGE = """\
---{front}---
# Page

```{{code-cell}} ipython3
:tags: [remove-cell]
from radarfusion_ref import fusion
from radarfusion_ref.kit import checks
```

```{{code-cell}} ipython3
def fuse_two(x_hat, Sigma):{doc}
    w = 1 / Sigma          # eq. (1.1)
    return (w * x_hat).sum() / w.sum()
```

```{{code-cell}} ipython3
:tags: [{tags}]
{check}
```
"""
_TIE = 'checks.check_close(fuse_two(x, v), fusion.fuse(x, v).x, what="fused")'


def test_the_readers_function_rule_can_fail(tmp_path):
    front = (ROOT / "book" / "intro.md").read_text(encoding="utf-8").split("---", 2)[1]
    page = tmp_path / "page.md"
    for doc, tags, check, expected in (
        ("", "remove-cell", _TIE, None),
        ("\n    \"\"\"Docstring.\"\"\"", "remove-cell", _TIE, "docstring"),
        ("\n" + "    x = 1\n" * 14, "remove-cell", _TIE, "lines (at most"),
        ("", "hide-input", _TIE, "no hidden"),
        ("", "remove-cell", 'checks.check_close(fuse_two(x, v), 1.0, what="x")', "no hidden"),
        ("", "remove-cell", "a, b = fuse_two(x, v), fusion.fuse(x, v).x\n"
         'checks.check_close(a, b, what="x")', None),
        ("", "remove-cell", "a, b = fuse_two(x, v), fusion.fuse(x, v).x\n"
         "print(a == b)", "no hidden"),
        ("", "remove-cell", 'checks.check_close(fuse_two(x, v), fusion._fuse(x, v), '
         'what="x")', "no hidden"),
    ):
        page.write_text(_READER_PAGE.format(front=front, doc=doc, tags=tags, check=check),
                        encoding="utf-8")
        problem = reader_function_problem(page)
        if expected is None:
            assert problem is None, problem
        else:
            assert problem is not None and expected in problem, (doc, check, problem)


_SOURCE = '''\
import functools


@functools.cache
def target(a, b):
    """Docstring."""
    total = a + b
    result = total * total + a * a + b * b + 2 * a * b + total - a - b + 10.0
    return result  # a trailing comment here pushes this line past the code box


def other():
    return 0
'''


def _page(tmp_path: Path, options: str) -> Path:
    (tmp_path / "pkg").mkdir(exist_ok=True)
    (tmp_path / "pkg" / "mod.py").write_text(_SOURCE, encoding="utf-8")
    (tmp_path / "book").mkdir(exist_ok=True)
    page = tmp_path / "book" / "page.md"
    page.write_text("# Page\n\n```{literalinclude} ../pkg/mod.py\n" + options
                    + "```\n\ntext\n", encoding="utf-8")
    return tmp_path / "book"


def test_a_long_shown_line_fails_naming_page_file_object_and_line(tmp_path):
    (listing,) = listings(_page(tmp_path, ":pyobject: target\n"))
    assert [n for n, _ in shown_lines(listing)][:2] == [4, 5], "decorator shown"
    long_expression, long_comment = too_wide(listing)
    assert "page.md:3:" in long_expression and "(target)" in long_expression
    assert "mod.py:8 " in long_expression and "77 > 76" in long_expression
    assert "mod.py:9 " in long_comment and "79 > 76" in long_comment
    assert len(too_wide(listing, width=77)) == 1 and too_wide(listing, width=79) == []


def test_the_options_select_what_is_measured(tmp_path):
    (cut,) = listings(_page(tmp_path, ":pyobject: target\n:start-at: total =\n"
                                      ":end-before: return result\n:dedent: 4\n"))
    assert [n for n, _ in shown_lines(cut)] == [7, 8]
    assert too_wide(cut) == [] and len(too_wide(cut, width=72)) == 1
    (picked,) = listings(_page(tmp_path, ":pyobject: target\n:lines: 1,3-4\n"))
    assert [n for n, _ in shown_lines(picked)] == [4, 6, 7]
    (added,) = listings(_page(tmp_path, ":pyobject: other\n:prepend: " + "x" * 77 + "\n"))
    assert len(too_wide(added)) == 1
    (missing,) = listings(_page(tmp_path, ":pyobject: nowhere\n"))
    with pytest.raises(LookupError, match="nowhere"):
        shown_lines(missing)
