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


WIDGET_STATE = re.compile(
    r'<script type="application/vnd\.jupyter\.widget-state\+json">(.*?)</script>', re.S)


def test_no_widget_state_without_a_widget_view(built_book):
    """Controls cells are `remove-cell`: their widget state must not reach the page
    (``_ext/radarfusion_pages.py`` drops it)."""
    offenders = {}
    for page in html_pages():
        text = page.read_text(encoding="utf-8")
        state = sum(len(s) for s in WIDGET_STATE.findall(text))
        if state and "application/vnd.jupyter.widget-view+json" not in text:
            offenders[page.name] = state
    assert not offenders, f"widget-state bytes on pages that show no widget: {offenders}"


def test_no_thebe_and_no_script_address_on_the_network(built_book):
    """Thebe is off: neither its scripts nor its CDN address (THEBE_JS_URL) are on a page."""
    inline_url = re.compile(r"<script[^>]*>[^<]*?(?:https?:)?//[^\s\"'<>]+?\.m?js\b", re.I)
    offenders = {}
    for page in HTML.rglob("*.html"):
        text = page.read_text(encoding="utf-8")
        hits = [h[-80:] for h in inline_url.findall(text)]
        if "THEBE_JS_URL" in text or "sphinx-thebe" in text:
            hits.append("sphinx-thebe")
        if hits:
            offenders[str(page.relative_to(HTML))] = hits[:3]
    assert not offenders, f"pages referring to network scripts or Thebe: {offenders}"


def test_exercises_and_equations_are_numbered_per_chapter(built_book):
    """Exercise numbers restart in every chapter (1.1, 1.2, ...; 2.1, ...), and so do the
    labelled equations."""
    from radarfusion_ref.kit import catalog

    main = {c.docname: c.number for c in catalog.CHAPTERS}
    for docname in toc_docnames():
        if not re.search(r"/\d\d_", docname):
            continue  # the front matter and appendices are not numbered
        text = (HTML / f"{docname}.html").read_text(encoding="utf-8")
        numbers = re.findall(r'<span class="caption-number">Exercise (\d+(?:\.\d+)*)', text)
        chapter = int(docname.rsplit("/", 1)[-1][:2])
        if numbers:
            assert all(re.fullmatch(rf"{chapter}\.\d+", n) for n in numbers), (
                f"{docname}: exercises {numbers} are not numbered in chapter {chapter}")
            if docname in main:
                assert numbers[0] == f"{chapter}.1", f"{docname}: first exercise {numbers[0]}"
        eqnos = re.findall(r'class="eqno">\((\d+(?:\.\d+)*)\)', text)
        if eqnos:
            assert re.fullmatch(rf"{chapter}\.\d+", eqnos[0]), f"{docname}: equation ({eqnos[0]})"


def test_players_have_enough_frames(built_book):
    from radarfusion_ref.kit.interactive import MIN_FRAMES

    short = {}
    for page in html_pages():
        counts = [int(n) for n in re.findall(r"var frames = new Array\((\d+)\)",
                                             page.read_text(encoding="utf-8"))]
        if any(n < MIN_FRAMES for n in counts):
            short[page.name] = counts
    assert not short, f"players with fewer than {MIN_FRAMES} frames: {short}"
