"""What a reader sees on each built page, in Chromium at 1 280 px (and 390 px).

The measures and limits are those of ``tests/page_layout.py`` (``python
tests/page_layout.py`` prints them as a table): no display equation wider than its
box, no visible code box that scrolls sideways, no output line that runs past its
box, no check verdict, quoted string, bare
value or label name in the reading flow, no stderr output (except in a cell tagged
``lesson-stderr``), at most 35 reading minutes and one figure per 5 of them, players
at least 800 px wide, exercises numbered from 1 on every page that starts a count, and
the closing line "Verified on this page: N checks".

The tests marked ``book`` measure the built book: the session's build, or the one
named by ``RADARFUSION_HTML`` (an ``html`` directory, e.g. from
``python tests/book_tools.py build-pages``). The others prove, on small synthetic
pages, that each measure fails on a defect and passes without it.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from book_tools import browser_fixture, serve
from page_layout import (
    LESSON_STDERR_TAG,
    PageLayout,
    default_pages,
    expected_first_exercise,
    measure_page,
    png_dpi,
    problems,
    small_fonts,
    smallest_style_font,
)

PAGES = default_pages()


@pytest.fixture(scope="module")
def browser():
    yield from browser_fixture("layout test")


@pytest.fixture(scope="module")
def html_dir(request) -> Path:
    named = os.environ.get("RADARFUSION_HTML")
    if named:
        path = Path(named)
        if not (path / "index.html").exists():
            pytest.fail(f"RADARFUSION_HTML={named} holds no built book (index.html)")
        return path
    request.getfixturevalue("built_book")
    from book_tools import BUILD_DIR

    return BUILD_DIR / "html"


@pytest.fixture(scope="module")
def layout(browser, html_dir):
    """Measure each page once, on first use."""
    cache: dict[str, PageLayout] = {}
    with serve(html_dir) as url:
        def get(docname: str) -> PageLayout:
            if docname not in cache:
                cache[docname] = measure_page(browser, url, docname, html_dir)
            return cache[docname]
        yield get


def _fails(row: PageLayout, *names: str) -> str | None:
    found = {k: v for k, v in problems(row).items() if k in names}
    return f"{row.page}: " + " | ".join(found.values()) if found else None


@pytest.mark.book
@pytest.mark.parametrize("docname", PAGES)
def test_display_equations_fit_their_box(layout, docname):
    failure = _fails(layout(docname), "equations", "equations_390")
    assert failure is None, failure


@pytest.mark.book
@pytest.mark.parametrize("docname", PAGES)
def test_visible_code_does_not_scroll_sideways(layout, docname):
    failure = _fails(layout(docname), "code")
    assert failure is None, failure


@pytest.mark.book
@pytest.mark.parametrize("docname", PAGES)
def test_output_lines_stay_in_their_box(layout, docname):
    failure = _fails(layout(docname), "outputs")
    assert failure is None, failure


@pytest.mark.book
@pytest.mark.parametrize("docname", PAGES)
def test_no_verdict_in_the_reading_flow(layout, docname):
    failure = _fails(layout(docname), "verdicts")
    assert failure is None, failure


@pytest.mark.book
@pytest.mark.parametrize("docname", PAGES)
def test_no_stderr_output_on_the_page(layout, docname):
    failure = _fails(layout(docname), "stderr")
    assert failure is None, failure


@pytest.mark.book
@pytest.mark.parametrize("docname", PAGES)
def test_reading_time_and_figures(layout, docname):
    failure = _fails(layout(docname), "minutes", "figures")
    assert failure is None, failure


@pytest.mark.book
@pytest.mark.parametrize("docname", PAGES)
def test_figure_text_is_at_least_9_pt(layout, docname):
    failure = _fails(layout(docname), "figure_text")
    assert failure is None, failure


@pytest.mark.book
@pytest.mark.parametrize("docname", PAGES)
def test_players_are_wide_enough(layout, docname):
    failure = _fails(layout(docname), "player")
    assert failure is None, failure


@pytest.mark.book
@pytest.mark.parametrize("docname", PAGES)
def test_exercises_number_from_one(layout, docname):
    failure = _fails(layout(docname), "exercises")
    assert failure is None, failure


@pytest.mark.book
@pytest.mark.parametrize("docname", PAGES)
def test_the_page_closes_with_its_checks(layout, docname):
    failure = _fails(layout(docname), "closing")
    assert failure is None, failure


# ---------------------------------------------------------------------------------------
# The controls: synthetic pages with each defect, and without.

#: The theme's rules for display math (sphinx-book-theme), so the boxes behave as on the book.
THEME_CSS = """
main { width: 700px; margin: 0 auto; font: 16px sans-serif; }
@media (max-width: 700px) { main { width: auto; margin: 0 8px; } }
pre { overflow: auto; white-space: pre; }
div.math { align-items: center; display: flex; max-width: 100%; overflow: hidden;
           flex-direction: row-reverse; gap: .5em; }
div.math mjx-container { flex-grow: 1; overflow: auto; padding-bottom: .2rem; }
div.math.noscroll mjx-container { overflow: visible; flex-grow: 0; flex-shrink: 0; }
"""

HEAD = """<!DOCTYPE html><html><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>{css}</style>
<script>window.MathJax = {{options: {{processHtmlClass: "math", ignoreHtmlClass: "document"}}}};
</script><script defer src="mathjax/tex-chtml.js"></script></head>
<body class="document"><main><article>"""

LONG_TEX = " + ".join(f"a_{{{i}}} x_{{{i}}}^{{2}}" for i in range(40))
LONG_CODE = "value = " + " + ".join(f"term_{i}" for i in range(30))
LONG_OUTPUT = "SweepResult(" + ", ".join(f"field_{i}={i}.0" for i in range(20)) + ")"


def _cell(inp: str = "", out: str = "", tags: str = "") -> str:
    code = f'<div class="cell_input"><div class="highlight"><pre>{inp}</pre></div></div>'
    return (f'<div class="cell {tags}">{code if inp else ""}'
            f'<div class="cell_output">{out}</div></div>')


def _plain(text: str, kind: str = "text_plain") -> str:
    return f'<div class="output {kind}"><div class="highlight"><pre>{text}</pre></div></div>'


def _exercise(number: str) -> str:
    return (f'<div class="exercise admonition"><p class="admonition-title">'
            f'<span class="caption-number">Exercise {number} </span></p><p>Do it.</p></div>')


BAD_BODY = f"""
<p>Start. As eq. (eq-hidden-label) shows, a label leaked.</p>
<div class="math notranslate nohighlight"><span class="eqno">(1.1)</span>\\[{LONG_TEX}\\]</div>
<div class="math notranslate nohighlight noscroll">\\[{LONG_TEX[:400]}\\]</div>
<div class="math notranslate nohighlight"><span class="eqno">(1.2)</span>\\[a = b\\]</div>
{_cell(LONG_CODE, _plain("'two routes: agree on 3 values (largest relative difference 1e-16)'"))}
{_cell("x = 1", _plain("0"))}
{_cell("print(result)", _plain(LONG_OUTPUT, "stream"))}
{_cell("print(msg)", _plain("the weights sum to one: holds", "stream"))}
{_cell("y = 2", '<div class="output stderr"><pre>UserWarning: Ignoring fixed y limits</pre></div>')}
{_cell("z = 3", '<div class="output stderr"><pre>RuntimeWarning: shown on purpose</pre></div>',
       tags="tag_" + LESSON_STDERR_TAG)}
<details class="hide"><summary>Show code</summary>
{_cell(LONG_CODE, _plain("'hidden: agree on 9 values (largest relative difference 0)'"))}
{_cell("print(result)", _plain(LONG_OUTPUT, "stream"))}
</details>
<img src="figure.png" alt="figure">
<div class="animation"><img id="_anim_img1" src="figure.png" style="width: 460px"></div>
<div class="cell_output"><div class="output text_html" style="overflow-x: auto">
<div class="animation" style="width: 900px"><img id="_anim_img3" src="figure.png"
 style="width: 900px"></div></div></div>
{_exercise("2")}
"""

GOOD_BODY = f"""
<p>Start. As eq. (1.2) shows, nothing leaked.</p>
<div class="math notranslate nohighlight"><span class="eqno">(1.1)</span>\\[a + b = c\\]</div>
{_cell("x = 1", _plain("a computed table of numbers, in words", "stream"))}
{_cell("print(result)", _plain(LONG_OUTPUT[:60] + ")", "stream"))}
<details class="hide"><summary>Show code</summary>{_cell(LONG_CODE, "")}</details>
<img src="figure.png" alt="figure">
<div class="animation"><img id="_anim_img2" src="figure.png" style="width: 820px"></div>
{_exercise("1")}
<div class="cell tag_remove-input"><div class="cell_output"><div class="output text_html">
<details class="rf-page-summary"><summary><strong>Verified on this page: 3 checks</strong>
</summary><ol><li>x: agree on 3 values</li></ol></details></div></div></div>
"""


def _mathjax_dir() -> Path | None:
    import importlib.util

    spec = importlib.util.find_spec("sphinx_book_theme")
    if spec is None or spec.origin is None:
        return None
    site = Path(spec.origin).parents[1]
    cand = site / "sphinx-mathjax-offline" / "static" / "mathjax"
    return cand if (cand / "tex-chtml.js").exists() else None


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """A served directory with a bad and a good page, MathJax and a 100-dpi PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    mathjax = _mathjax_dir()
    if mathjax is None:
        pytest.skip("sphinx-mathjax-offline's MathJax is not installed")
    root = tmp_path_factory.mktemp("layout")
    (root / "mathjax").symlink_to(mathjax)
    fig, ax = plt.subplots(figsize=(4, 2), dpi=100)
    ax.plot([0, 1], [0, 1])
    fig.savefig(root / "figure.png", dpi=100)
    plt.close(fig)
    for name, body in (("bad", BAD_BODY), ("good", GOOD_BODY)):
        (root / f"{name}.html").write_text(HEAD.format(css=THEME_CSS) + body
                                           + "</article></main></body></html>")
    return root


def test_the_layout_check_catches_each_defect(browser, synthetic):
    with serve(synthetic) as url:
        row = measure_page(browser, url, "bad", synthetic)
    found = problems(row)
    assert row.eq_clipped == 2 and row.eq_px > 100, row
    assert row.eq_390 == 1, row.details["equations_390"]  # the one that cannot scroll
    assert row.code_wide == 1, row.details["code"]  # the folded one is not counted
    assert row.output_wide == 1, row.details["wide_outputs"]  # nor the folded output
    assert row.details["wide_outputs"][0]["line"].startswith("SweepResult(field_0=0.0")
    assert sorted(row.details["verdicts"]) == [
        "'two routes: agree on 3 values (largest relative difference 1e-16)'", "0",
        "the weights sum to one: holds"], row.details["verdicts"]
    assert row.details["labels"] == ["eq-hidden-label"]
    assert row.stderr == 1 and "Ignoring fixed y limits" in row.details["stderr"][0]
    # the 900 px player scrolls inside its 700 px output: 700 px are seen; the narrowest is 460
    assert row.player_px == 460 and row.figs == 3
    assert sorted(measured_players(row)) == [460, 700]
    assert row.first_ex == "2"
    assert set(found) == {"equations", "equations_390", "code", "outputs", "verdicts", "stderr",
                          "player", "exercises"}, found
    assert "(1.1)" in found["equations"]


def measured_players(row: PageLayout) -> list[int]:
    return row.details["players"]


def test_the_layout_check_passes_a_clean_page(browser, synthetic):
    with serve(synthetic) as url:
        row = measure_page(browser, url, "good", synthetic)
    assert problems(row) == {}, problems(row)
    assert row.closing and row.figs == 2 and row.player_px == 820 and row.first_ex == "1"
    # a 100-dpi PNG shown at its pixel size: the style's smallest text (F pt) displays at
    # F × 100/96 pt
    assert row.text_pt == pytest.approx(smallest_style_font() * 100 / 96, abs=0.05)


def test_page_limits_on_measured_rows():
    """Reading time, figures per 5 minutes, the exercise count and the closing line."""
    ok = PageLayout(page="book/01_fusion", minutes=20.0, figs=4, need=4, first_ex="1.1",
                    closing=True, notebook=True)
    assert problems(ok) == {}
    slow = PageLayout(page="book/11_capstone", minutes=42.0, figs=8, need=9, first_ex="11.1",
                      closing=False, notebook=True)
    assert set(problems(slow)) == {"minutes", "figures", "closing"}
    shared = PageLayout(page="book/montecarlo", first_ex="3", notebook=False)
    assert set(problems(shared)) == {"exercises"}
    assert expected_first_exercise("book/intro") == "1"
    assert expected_first_exercise("book/04_association") == "4.1"
    assert expected_first_exercise("book/04_association_fair") is None


def test_png_dpi_reads_the_resolution(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(1, 1))
    for dpi in (72, 120):
        fig.savefig(tmp_path / "f.png", dpi=dpi)
        assert png_dpi((tmp_path / "f.png").read_bytes()) == pytest.approx(dpi, abs=0.02)
    plt.close(fig)
    assert png_dpi(b"not a png") is None
    shutil.rmtree(tmp_path)


def test_unnumbered_pages_count_their_own_exercises():
    """_ext/radarfusion_pages.py: intro 1, 2 and montecarlo 1, 2, not 1, 2 and 3, 4."""
    import importlib
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "_ext"))
    try:
        pages = importlib.import_module("radarfusion_pages")
    finally:
        sys.path.pop(0)
    fignumbers = {
        "book/intro": {"exercise": {"ex-a": (1,), "ex-b": (2,)}, "figure": {"f": (1,)}},
        "book/montecarlo": {"exercise": {"ex-c": (3,), "ex-d": (4,)}},
        "book/01_fusion": {"exercise": {"ex-e": (1, 1), "ex-f": (1, 2)}},
        "book/01_fusion_vector": {"exercise": {"ex-g": (1, 3)}},
    }
    secnumbers = {"book/intro": {}, "book/montecarlo": {"": ()},
                  "book/01_fusion": {"": (1,)}, "book/01_fusion_vector": {"": (1, 1)}}
    changed = pages.number_per_page(fignumbers, secnumbers)
    assert changed == ["book/montecarlo"]
    assert fignumbers["book/montecarlo"]["exercise"] == {"ex-c": (1,), "ex-d": (2,)}
    assert fignumbers["book/intro"]["exercise"] == {"ex-a": (1,), "ex-b": (2,)}
    assert fignumbers["book/01_fusion"]["exercise"] == {"ex-e": (1, 1), "ex-f": (1, 2)}
    assert fignumbers["book/01_fusion_vector"]["exercise"] == {"ex-g": (1, 3)}
    assert fignumbers["book/intro"]["figure"] == {"f": (1,)}  # other types untouched


def test_small_fonts_in_the_source_are_found():
    src = """ax.legend(fontsize=7)\nax.text(0, 0, "a", size="small")\nax.legend(prop={"size": 8})
ax.set_title("t", fontsize=12)\nax.plot(x, y, markersize=3)\nax.legend(fontsize="large")
u = rng.uniform(0, 1, size=3)\nax.tick_params(labelsize=6)"""
    assert small_fonts(src) == ["fontsize=7", 'size="small"', '"size": 8', "labelsize=6"]
    row = PageLayout(page="book/01_fusion", text_pt=10.0, small_fonts=0)
    assert "figure_text" not in problems(row)
    row.text_pt = 7.5
    assert "figure_text" in problems(row)
