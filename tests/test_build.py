"""The built book: complete, built once, and free of network dependencies."""

from __future__ import annotations

import re

import pytest
from book_tools import BUILD_DIR, EXECUTED, ROOT, html_pages, toc_docnames

pytestmark = pytest.mark.book

HTML = BUILD_DIR / "html"
EXTERNAL_ASSET = re.compile(
    r"""<(?:script|link|img|iframe)\b[^>]*?\b(?:src|href)\s*=\s*["'](?:https?:)?//""", re.I
)


def test_every_page_is_built(built_book):
    missing = [str(p.relative_to(ROOT)) for p in html_pages() if not p.exists()]
    assert not missing, f"pages listed in _toc.yml but not built: {missing}"


def test_no_notebook_is_executed_twice(built_book):
    """Chapters executed by the notebook tests come from the cache in the build."""
    out = built_book.stdout + built_book.stderr
    rebuilt = set(re.findall(r"(\S+\.md): Executing notebook", out))
    again = sorted(rebuilt & EXECUTED)
    assert not again, f"executed twice in one test run: {again}"


def test_mathjax_is_served_from_the_site(built_book):
    assert (HTML / "_static" / "mathjax" / "tex-chtml.js").exists()
    sources = {}
    for page in html_pages():
        text = page.read_text(encoding="utf-8")
        for src in re.findall(r'<script[^>]*\bsrc="([^"]*mathjax[^"]*)"', text, flags=re.I):
            sources.setdefault(src.split("?")[0].split("_static/")[-1], []).append(page.name)
    assert sources, "no page loads MathJax"
    assert set(sources) == {"mathjax/tex-chtml.js"}, sources


def test_no_page_loads_assets_from_the_network(built_book):
    offenders = {}
    for page in HTML.rglob("*.html"):
        hits = EXTERNAL_ASSET.findall(page.read_text(encoding="utf-8"))
        if hits:
            offenders[str(page.relative_to(HTML))] = hits[:3]
    assert not offenders, f"pages that load assets from the network: {offenders}"


def test_no_widget_embed_scripts(built_book):
    """Widget cells are live-only: no ipywidgets embed manager from a CDN."""
    for page in html_pages():
        text = page.read_text(encoding="utf-8")
        assert "embed-amd" not in text and "require.min.js" not in text, page.name


def test_exercise_solutions_are_folded(built_book):
    for docname in toc_docnames():
        text = (HTML / f"{docname}.html").read_text(encoding="utf-8")
        for classes in re.findall(r'<(?:div|details) class="([^"]*)"', text):
            names = classes.split()
            if "solution" in names:
                assert "dropdown" in names, f"{docname}: a solution is not folded ({classes})"
