"""The package code that the pages show fits the page's code box.

A chapter shows package source with ``{literalinclude}`` and ``:pyobject:``. On the built
page a code box holds about :data:`MAX_WIDTH` characters; a longer line scrolls sideways
and breaks the equation the listing is meant to show. This test reproduces what the
directive shows -- the object located with :mod:`ast` (decorators and docstring
included), then ``:start-at:``/``:start-after:``, ``:end-before:``/``:end-at:``,
``:lines:``, ``:dedent:`` and ``:prepend:``/``:append:`` in the order Sphinx applies
them -- and fails naming page, file, object and source line for every shown line that is
too long.
"""

from __future__ import annotations

import ast
import re
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest
from book_tools import ROOT

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


def listings(book: Path) -> list[Listing]:
    """Every ``{literalinclude}`` with ``:pyobject:`` in the pages under *book*."""
    found = []
    for page in sorted(book.rglob("*.md")):
        text = page.read_text(encoding="utf-8")
        for m in _DIRECTIVE.finditer(text):
            options = dict(_OPTION.findall(m.group(2)))
            if "pyobject" in options:
                found.append(Listing(page, text.count("\n", 0, m.start()) + 1,
                                     (page.parent / m.group(1)).resolve(), options))
    return found


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
    for key, keep_marker in (("start-at", True), ("start-after", False)):
        if key in opts:
            at = next((i for i, (_, s) in enumerate(lines) if opts[key] in s), None)
            if at is None:
                raise LookupError(f"{listing.page.name}:{listing.page_line}: "
                                  f":{key}: {opts[key]!r} not in {listing.pyobject}")
            lines = lines[at if keep_marker else at + 1:]
    for key, keep_marker in (("end-at", True), ("end-before", False)):
        if key in opts:
            at = next((i for i, (_, s) in enumerate(lines) if opts[key] in s), None)
            if at is None:
                raise LookupError(f"{listing.page.name}:{listing.page_line}: "
                                  f":{key}: {opts[key]!r} not in {listing.pyobject}")
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


# ----------------------------------------------------------------------------- the book
BOOK_LISTINGS = listings(ROOT / "book")


def test_the_pages_show_package_code():
    assert len(BOOK_LISTINGS) >= 20, "the chapters show package code"


@pytest.mark.parametrize("listing", BOOK_LISTINGS,
                         ids=[f"{x.page.stem}-{x.pyobject}" for x in BOOK_LISTINGS])
def test_listing_fits_the_code_box(listing):
    assert shown_lines(listing), f"{listing.page.name}: {listing.pyobject} shows nothing"
    assert not too_wide(listing), "\n".join(too_wide(listing))


# ----------------------------------------------------------------------------- the check
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
