"""Layout of the built pages in Chromium: what a reader sees at 1 280 px (and 390 px).

``python tests/page_layout.py [--build DIR] [PAGE ...]`` prints one row per page;
``tests/test_page_layout.py`` fails naming the page on any limit below. DIR is a
``jupyter-book build --path-output`` directory or its ``_build/html`` (default: the
checkout's ``_build/html``); PAGEs are docnames (``book/01_fusion``) or files
(default: every page of ``_toc.yml`` except the API reference).

Measured in the browser (network cut off, MathJax typeset, folds as the reader finds
them):

* **eq clipped** — display equations (``div.math``) wider than their box at 1 280 px: the
  MathJax container scrolls (``scrollWidth > clientWidth``), the typeset equation is
  wider than the container, reaches outside the box, or runs under its equation number.
  Folded equations (solutions, dropdowns) are opened and measured too. **eq px** is the
  largest overflow in CSS pixels.
* **eq 390** — at 390 px an equation may scroll sideways, but must not be cut off: the
  overflowing equations whose container does not scroll (or that run under the number).
* **code wide** — visible code boxes (``pre`` outside outputs: cell inputs, literal
  includes) that scroll sideways (``scrollWidth > clientWidth``); folded ones excluded.
* **output wide** — visible output lines that run past their box: a ``pre`` in a cell's
  output whose ``scrollWidth`` exceeds its ``clientWidth`` (the reader sees the line cut
  off at the column's edge, or has to scroll to read it); folded ones excluded.
* **verdicts** — visible outputs that read as a check's verdict (the strings
  ``radarfusion_ref.kit.checks`` and ``kit.symbolic`` return or print), a quoted string,
  a bare repr (``0``, ``True``, a dict, a list, ``array(...)``, a matplotlib object), or a
  label name (``eq-...``, ``ex-...``, ``fig-...``) in visible text.
* **stderr** — ``.output.stderr`` outputs anywhere on the page, except in cells tagged
  ``lesson-stderr``.
* **minutes** — reading minutes of the source (``tests/book_metrics.py``); **figs** —
  visible images (players included) outside folds; **need** — ``ceil(minutes / 5)``.
* **player px** — the narrowest player's visible width (at least 800): its displayed width,
  clipped by any box around it that scrolls (a wide player in a text-column output scrolls).
* **text pt** — an estimate of the smallest figure text at displayed size: the book
  style's smallest font (``kit.plotting.BOOK_STYLE``) times the smallest displayed scale
  of the page's images (displayed width / pixel width × the PNG's dpi / 96). It assumes
  the figure uses the style's sizes; a figure that sets a smaller size is not seen.
* **small fonts** — font sizes below 9 pt set in the page's source (``fontsize=7``,
  ``size="small"``, ``prop={"size": 8}``): what the estimate above cannot see.
* **first ex** — the number of the page's first exercise; **closing** — whether the
  page ends with "Verified on this page: N checks".
"""

from __future__ import annotations

import argparse
import base64
import math
import re
import struct
import sys
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from urllib.parse import unquote, urlparse

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
if str(ROOT) not in sys.path:
    sys.path.insert(1, str(ROOT))

from book_metrics import html_metrics, source_metrics  # noqa: E402
from book_tools import (  # noqa: E402
    BUILD_DIR,
    CHROMIUM_MISSING,
    chromium_browser,
    chromium_path,
    is_notebook,
    page_docname,
    serve,
    toc_docnames,
)

WIDE, NARROW = 1280, 390
MAX_READING_MINUTES = 35.0
MINUTES_PER_FIGURE = 5.0
MIN_PLAYER_PX = 800
MIN_TEXT_PT = 9.0
LESSON_STDERR_TAG = "lesson-stderr"

#: Output text that reads as a check's verdict (kit.checks / kit.symbolic wording).
VERDICT = re.compile(
    r"agree on \d+ values|identical on \d+ entries|:\s*holds\b|\bholds on \d+ entries"
    r"|^.{1,120} = (0|Matrix\(\[\[0[, 0\]\[]*\]\]\))\s*$|Verification: (all \d+|no) checks"
    r"|symbolic check (passed|failed)",
    re.M,
)
#: A bare repr left as a cell's last expression (``text/plain`` outputs only).
BARE_REPR = re.compile(
    r"""^\s*(?:'[^\n]*'|"[^\n]*"|[-+]?\d+(?:\.\d*)?(?:e[-+]?\d+)?|True|False|None"""
    r"""|\{.*\}|\(.*\)|\[.*\]|array\(.*|<[\w.]+ (?:object )?at 0x[0-9a-f]+>.*"""
    r"""|<matplotlib\..*|Text\(.*|<Figure size.*|np\.\w+\(.*)\s*$""",
    re.S,
)
#: A font size set in a page's code (``fontsize=7``, ``size="small"``, ``prop={"size": 8}``).
FONT_SIZE = re.compile(
    r"""\b(?:font|label|title)size\s*=\s*(?:(\d+(?:\.\d+)?)|["']((?:xx?-)?small)["'])"""
    r"""|["'](?:font|label|title)?size["']\s*:\s*(?:(\d+(?:\.\d+)?)|["']((?:xx?-)?small)["'])"""
    r"""|\bsize\s*=\s*()["']((?:xx?-)?small)["']""")
#: matplotlib's relative sizes in pt, at the style's 10 pt base.
RELATIVE_PT = {"small": 8.33, "x-small": 6.94, "xx-small": 5.79}
#: A label name leaked into visible text.
LABEL = re.compile(r"\b(?:eq|ex|fig)-[a-z0-9]+(?:-[a-z0-9]+)*\b")

MEASURE_JS = r"""
async (opts) => {
  if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
    await MathJax.startup.promise;
  }
  const imgs = Array.from(document.images);
  await Promise.all(imgs.map(i => i.complete ? null :
      new Promise(r => { i.onload = r; i.onerror = r; })));
  await new Promise(r => setTimeout(r, 100));
  const main = document.querySelector("main article") || document.querySelector("main")
               || document.body;
  const shown = el => {
    if (!el.getClientRects().length) return false;
    if (el.checkVisibility && !el.checkVisibility({contentVisibilityAuto: true,
                                                   opacityProperty: true,
                                                   visibilityProperty: true})) return false;
    // inside a closed fold (its summary line excepted)
    for (let d = el.closest("details:not([open])"); d; d = d.parentElement &&
         d.parentElement.closest("details:not([open])")) {
      const s = d.querySelector(":scope > summary");
      if (!(s && s.contains(el))) return false;
    }
    for (let a = el; a; a = a.parentElement) {
      const st = getComputedStyle(a);
      if (st.visibility === "hidden" || st.display === "none") return false;
    }
    return true;
  };
  const inside = (el, sel) => !!el.closest(sel);
  // the width of `el` the reader can see: clipped by every ancestor that scrolls or hides
  const visibleWidth = el => {
    const r = el.getBoundingClientRect();
    let left = r.left, right = r.right;
    for (let a = el.parentElement; a && a !== document.documentElement; a = a.parentElement) {
      if (getComputedStyle(a).overflowX === "visible") continue;
      const ar = a.getBoundingClientRect();
      left = Math.max(left, ar.left + a.clientLeft);
      right = Math.min(right, ar.left + a.clientLeft + a.clientWidth);
    }
    return Math.max(0, right - left);
  };
  const short = (t, n) => t.replace(/\s+/g, " ").trim().slice(0, n || 90);
  const out = {code: [], outputs: [], labels: [], stderr: [], images: [], players: [],
               wideOutputs: [], closing: false};

  if (!opts.equationsOnly) {
    // visible code boxes (not outputs) that scroll sideways
    for (const pre of main.querySelectorAll("pre")) {
      if (inside(pre, ".cell_output, .output") || !shown(pre)) continue;
      if (pre.scrollWidth > pre.clientWidth + 1) {
        const longest = pre.innerText.split("\n").reduce((a, b) => b.length > a.length ? b : a, "");
        out.code.push({over: pre.scrollWidth - pre.clientWidth, line: short(longest, 100)});
      }
    }
    // visible outputs
    for (const o of main.querySelectorAll(".cell_output .output, .cell_output > .text_html")) {
      if (!shown(o)) continue;
      if (o.querySelector("details.rf-page-summary")) { out.closing = true; continue; }
      const cls = o.className;
      const kind = /stderr/.test(cls) ? "stderr" : /text_plain/.test(cls) ? "text_plain"
                 : /stream/.test(cls) ? "stream" : /text_html/.test(cls) ? "html"
                 : /text_markdown|text_latex/.test(cls) ? "rich" : "other";
      out.outputs.push({kind: kind, text: (o.innerText || "").slice(0, 2000)});
      for (const pre of o.querySelectorAll("pre")) {
        if (pre.scrollWidth > pre.clientWidth + 1) {
          const longest = pre.innerText.split("\n").reduce((a, b) => b.length > a.length ? b : a, "");
          out.wideOutputs.push({over: pre.scrollWidth - pre.clientWidth, line: short(longest, 100)});
        }
      }
    }
    if (!out.closing) out.closing = /Verified on this page: \d+ checks?/.test(main.innerText);
    // every stderr output, folded or not, except in cells tagged as part of the lesson
    for (const o of main.querySelectorAll(".output.stderr")) {
      const cell = o.closest(".cell");
      if (cell && cell.classList.contains("tag_" + opts.lessonTag)) continue;
      out.stderr.push(short(o.textContent || "", 120));
    }
    // label names in visible text (code and math excluded)
    const skip = new Set(["SCRIPT", "STYLE", "PRE", "CODE", "TEXTAREA", "NOSCRIPT",
                          "MJX-CONTAINER"]);
    const walker = document.createTreeWalker(main, NodeFilter.SHOW_TEXT);
    while (walker.nextNode()) {
      const node = walker.currentNode;
      const el = node.parentElement;
      if (!el) continue;
      let code = false;
      for (let a = el; a && a !== main; a = a.parentElement) {
        if (skip.has(a.tagName) || a.classList.contains("highlight")) { code = true; break; }
      }
      if (code || !shown(el)) continue;
      const m = node.textContent.match(new RegExp(opts.label, "g"));
      if (m) out.labels.push(...m);
    }
    // figures: visible images outside folds; players
    for (const img of main.querySelectorAll("img")) {
      if (!shown(img) || img.naturalWidth < 100) continue;
      const r = img.getBoundingClientRect();
      const player = !!img.closest(".animation") || /^_anim_img/.test(img.id || "");
      const src = img.getAttribute("src") || "";
      out.images.push({src: src.startsWith("data:") ? src.slice(0, 200000) : src,
                       natural: img.naturalWidth, shown: r.width, player: player});
      if (player) out.players.push(Math.round(visibleWidth(img)));
    }
  }

  // display equations, with every fold opened
  for (const d of document.querySelectorAll("details")) d.open = true;
  for (const b of document.querySelectorAll(".toggle-hidden, .dropdown .toggle-details__container"))
    { b.classList.remove("toggle-hidden"); b.style.display = ""; }
  await new Promise(r => setTimeout(r, 50));
  const tex = new Map();
  try {
    for (const item of MathJax.startup.document.math) {
      if (item.display && item.typesetRoot) tex.set(item.typesetRoot, item.math);
    }
  } catch (e) { /* no MathJax */ }
  out.equations = [];
  for (const box of main.querySelectorAll("div.math")) {
    const c = box.querySelector("mjx-container");
    if (!c || !box.getClientRects().length) continue;
    const m = c.querySelector("mjx-math") || c.querySelector("svg") || c;
    const br = box.getBoundingClientRect(), cr = c.getBoundingClientRect();
    const mr = m.getBoundingClientRect();
    const eqno = box.querySelector(".eqno");
    const er = eqno ? eqno.getBoundingClientRect() : null;
    const ox = getComputedStyle(c).overflowX;
    const clips = ox !== "visible";
    // the part of the equation the reader can see (a scrolling container clips it)
    const vl = clips ? Math.max(mr.left, cr.left) : mr.left;
    const vr = clips ? Math.min(mr.right, cr.right) : mr.right;
    const scroll = Math.max(0, c.scrollWidth - c.clientWidth);
    const wider = Math.max(0, mr.width - c.clientWidth);
    const leftCut = Math.max(0, cr.left - mr.left);  // never reachable by scrolling
    const outside = Math.max(0, cr.right - br.right, br.left - cr.left, vr - br.right,
                             br.left - vl);
    let under = 0;
    if (er && er.width > 0 && vr > er.left + 1 && vl < er.right - 1
        && mr.bottom > er.top && mr.top < er.bottom) under = vr - er.left;
    const over = Math.max(scroll, wider, outside, under, leftCut);
    if (over > 1) {
      out.equations.push({
        over: Math.round(over),
        scrollable: (ox === "auto" || ox === "scroll") && under <= 1 && outside <= 1
                    && leftCut <= 1,
        number: eqno ? short(eqno.textContent, 12).replace(/#$/, "") : "",
        tex: short(tex.get(c) || c.getAttribute("aria-label") || box.textContent, 70)});
    }
  }
  out.equationCount = main.querySelectorAll("div.math").length;
  return out;
}
"""


@dataclass
class PageLayout:
    """The layout measures of one page (see the module docstring)."""

    page: str
    eq_clipped: int = 0
    eq_px: int = 0
    eq_390: int = 0
    code_wide: int = 0
    output_wide: int = 0
    verdicts: int = 0
    stderr: int = 0
    minutes: float | None = None
    figs: int = 0
    need: int | None = None
    player_px: int | None = None
    text_pt: float | None = None
    small_fonts: int = 0
    first_ex: str | None = None
    closing: bool = False
    notebook: bool = False
    details: dict = field(default_factory=dict, repr=False)


def png_dpi(data: bytes) -> float | None:
    """Horizontal resolution from a PNG's ``pHYs`` chunk (dots per inch), or None."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    pos = 8
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        if kind == b"pHYs" and length == 9:
            x, _, unit = struct.unpack(">IIB", data[pos + 8:pos + 17])
            return x * 0.0254 if unit == 1 else None
        if kind in (b"IDAT", b"IEND"):
            return None
        pos += 12 + length
    return None


def _image_dpi(src: str, page_url: str, html_dir: Path) -> float | None:
    if src.startswith("data:image/png;base64,"):
        try:
            return png_dpi(base64.b64decode(src.split(",", 1)[1][:4000] + "==="))
        except ValueError:
            return None
    path = urlparse(src).path
    if not path or path.startswith("data:"):
        return None
    target = (html_dir / Path(urlparse(page_url).path.lstrip("/")).parent / unquote(path))
    try:
        with open(target.resolve(), "rb") as fh:
            return png_dpi(fh.read(4096))
    except OSError:
        return None


def small_fonts(source: str) -> list[str]:
    """Font sizes below 9 pt that a page's source sets (numbers or relative names)."""
    found = []
    for m in FONT_SIZE.finditer(source):
        number = m.group(1) or m.group(3)
        name = m.group(2) or m.group(4) or m.group(6)
        pt = float(number) if number else RELATIVE_PT[name]
        if pt < MIN_TEXT_PT:
            found.append(m.group(0))
    return found


def verdict_texts(outputs: list[dict]) -> list[str]:
    """The visible outputs that are verdicts, quoted strings or bare reprs."""
    found = []
    for o in outputs:
        text = o["text"].strip()
        if not text or o["kind"] == "stderr":
            continue
        if VERDICT.search(text) or (o["kind"] == "text_plain" and BARE_REPR.match(text)):
            found.append(text[:100])
    return found


def smallest_style_font() -> float:
    """The smallest font size (pt) set by the book's matplotlib style."""
    from radarfusion_ref.kit.plotting import BOOK_STYLE

    sizes = [v for k, v in BOOK_STYLE.items()
             if k.endswith(("size", "fontsize")) and isinstance(v, (int, float))
             and not k.startswith("figure.")]
    return float(min(sizes)) if sizes else 10.0


def measure_page(browser, base_url: str, docname: str, html_dir: Path,
                 screenshot: Path | None = None) -> PageLayout:
    """Load one built page at 1 280 px and at 390 px and measure it.

    With `screenshot`, the first screen at 1 280 × 800 px (as a reader opens the page)
    is saved there as PNG, before anything is measured or unfolded.
    """
    url = f"{base_url}/{docname}.html"
    row = PageLayout(page=docname)
    host = urlparse(base_url).netloc
    results = {}
    for width in (WIDE, NARROW):
        context = browser.new_context(viewport={"width": width, "height": 900})
        context.route("**/*", lambda r: r.continue_()
                      if urlparse(r.request.url).netloc == host
                      or r.request.url.startswith("data:") else r.abort())
        page = context.new_page()
        try:
            page.goto(url, wait_until="load")
            if screenshot is not None and width == WIDE:
                page.set_viewport_size({"width": WIDE, "height": 800})
                page.evaluate("async () => { if (window.MathJax && MathJax.startup) "
                              "await MathJax.startup.promise; }")
                screenshot.parent.mkdir(parents=True, exist_ok=True)
                page.screenshot(path=str(screenshot))
            results[width] = page.evaluate(MEASURE_JS, {
                "equationsOnly": width != WIDE, "lessonTag": LESSON_STDERR_TAG,
                "label": LABEL.pattern})
        finally:
            context.close()
    wide, narrow = results[WIDE], results[NARROW]
    eqs = wide["equations"]
    row.eq_clipped = len(eqs)
    row.eq_px = max((e["over"] for e in eqs), default=0)
    cut = [e for e in narrow["equations"] if not e["scrollable"]]
    row.eq_390 = len(cut)
    row.code_wide = len(wide["code"])
    row.output_wide = len(wide["wideOutputs"])
    verdicts = verdict_texts(wide["outputs"])
    labels = sorted(set(wide["labels"]))
    row.verdicts = len(verdicts) + len(labels)
    row.stderr = len(wide["stderr"])
    row.figs = len(wide["images"])
    row.player_px = min(wide["players"]) if wide["players"] else None
    row.closing = bool(wide["closing"])
    font = smallest_style_font()
    scales = []
    for img in wide["images"]:
        dpi = _image_dpi(img["src"], url, html_dir)
        if dpi and img["natural"]:
            scales.append(img["shown"] / img["natural"] * dpi / 96.0)
    row.text_pt = round(font * min(scales), 1) if scales else None
    source = ROOT / f"{docname}.md"
    row.notebook = is_notebook(source)
    small = small_fonts(source.read_text(encoding="utf-8")) if source.exists() else []
    row.small_fonts = len(small)
    if row.notebook:
        row.minutes = source_metrics(source).reading_minutes
        row.need = max(1, math.ceil(row.minutes / MINUTES_PER_FIGURE))
    html_file = html_dir / f"{docname}.html"
    if html_file.exists():
        row.first_ex = html_metrics(html_file.read_text(encoding="utf-8"))["first_exercise"]
    row.details = {"equations": eqs, "equations_390": cut, "code": wide["code"],
                   "verdicts": verdicts, "labels": labels, "stderr": wide["stderr"],
                   "wide_outputs": wide["wideOutputs"], "small_fonts": small,
                   "players": wide["players"]}
    return row


def expected_first_exercise(docname: str) -> str | None:
    """``"N.1"`` on chapter N's main page, ``"1"`` on an unnumbered page, else None."""
    from radarfusion_ref.kit import catalog

    numbers = {c.docname: c.number for c in catalog.CHAPTERS}
    if docname in numbers:
        return f"{numbers[docname]}.1"
    if not re.search(r"/\d\d_", docname):
        return "1"
    return None  # a chapter's sub-page continues the chapter's numbering


def problems(row: PageLayout) -> dict[str, str]:
    """Each limit the page breaks, by name, with what was measured."""
    d, out = row.details, {}
    if row.eq_clipped:
        out["equations"] = (f"{row.eq_clipped} display equations wider than their box at "
                            f"{WIDE} px (up to {row.eq_px} px): "
                            + "; ".join(f"{e['number']} {e['tex']!r} +{e['over']}px"
                                        for e in d["equations"][:4]))
    if row.eq_390:
        out["equations_390"] = (f"{row.eq_390} display equations cut off at {NARROW} px (not "
                                "scrollable or under their number): "
                                + "; ".join(f"{e['number']} {e['tex']!r}"
                                            for e in d["equations_390"][:3]))
    if row.code_wide:
        out["code"] = (f"{row.code_wide} visible code boxes scroll sideways at {WIDE} px, e.g. "
                       + "; ".join(repr(c["line"]) for c in d["code"][:3]))
    if row.output_wide:
        out["outputs"] = (f"{row.output_wide} visible output lines run past their box at "
                          f"{WIDE} px, e.g. "
                          + "; ".join(f"{c['line']!r} +{c['over']}px"
                                      for c in d["wide_outputs"][:3]))
    if row.verdicts:
        out["verdicts"] = (f"{row.verdicts} check verdicts, quoted strings, bare values or "
                           f"label names in the reading flow: "
                           f"{(d['verdicts'] + d['labels'])[:4]}")
    if row.stderr:
        out["stderr"] = (f"{row.stderr} stderr outputs (tag the cell `{LESSON_STDERR_TAG}` "
                         f"only if the warning is the lesson): {d['stderr'][:3]}")
    if row.minutes is not None and row.minutes > MAX_READING_MINUTES:
        out["minutes"] = f"{row.minutes} reading minutes (at most {MAX_READING_MINUTES:g})"
    if row.need is not None and row.figs < row.need:
        out["figures"] = (f"{row.figs} figures for {row.minutes} reading minutes (at least "
                          f"{row.need}: one per {MINUTES_PER_FIGURE:g} minutes)")
    if row.player_px is not None and row.player_px < MIN_PLAYER_PX:
        out["player"] = f"a player {row.player_px} px wide (at least {MIN_PLAYER_PX})"
    if (row.text_pt is not None and row.text_pt < MIN_TEXT_PT) or row.small_fonts:
        out["figure_text"] = (f"figure text below {MIN_TEXT_PT:g} pt at displayed size: "
                              f"estimate {row.text_pt} pt for the style's sizes; "
                              f"{row.small_fonts} smaller sizes set in the source "
                              f"{d.get('small_fonts', [])[:4]}")
    want = expected_first_exercise(row.page)
    if want is not None and row.first_ex is not None and row.first_ex != want:
        out["exercises"] = f"the first exercise is numbered {row.first_ex}, not {want}"
    if row.notebook and not row.closing:
        out["closing"] = "no closing line 'Verified on this page: N checks'"
    return out


def default_pages() -> list[str]:
    """Every page of the table of contents except the API reference."""
    return [d for d in toc_docnames() if not d.startswith("book/api/")]


def html_dir_of(build: str | Path | None) -> Path:
    """The ``html`` directory of a build directory (or the checkout's)."""
    if build is None:
        return BUILD_DIR / "html"
    build = Path(build).resolve()
    for cand in (build, build / "html", build / "_build" / "html"):
        if (cand / "index.html").exists():
            return cand
    raise SystemExit(f"no built book (index.html) under {build}")


def measure(pages: list[str], html_dir: Path,
            screenshots: Path | None = None) -> list[PageLayout]:
    """Measure `pages` of the book built in `html_dir` (first screens into `screenshots`)."""
    if chromium_path() is None:
        raise SystemExit(CHROMIUM_MISSING)
    rows = []
    with chromium_browser() as browser, serve(html_dir) as url:
        for d in pages:
            shot = (Path(screenshots) / f"{d.replace('/', '_')}.png"
                    if screenshots is not None else None)
            rows.append(measure_page(browser, url, d, html_dir, screenshot=shot))
    return rows


COLUMNS = [f.name for f in fields(PageLayout) if f.name not in ("details", "notebook")]


def table(rows: list[PageLayout]) -> str:
    """The measures as a Markdown table, and the pages' totals."""
    out = ["| " + " | ".join(COLUMNS) + " | fails |", "|" + "---|" * (len(COLUMNS) + 1)]
    for r in rows:
        vals = asdict(r)
        cells = ["–" if vals[c] is None else
                 ("yes" if vals[c] is True else "no" if vals[c] is False else str(vals[c]))
                 for c in COLUMNS]
        out.append("| " + " | ".join(cells) + f" | {', '.join(problems(r)) or '–'} |")
    main = [r for r in rows if r.notebook]
    out.append("")
    out.append(f"pages: {len(rows)}; failing: {sum(bool(problems(r)) for r in rows)}; "
               f"clipped equations: {sum(r.eq_clipped for r in rows)} on "
               f"{sum(r.eq_clipped > 0 for r in rows)} pages; sideways code boxes: "
               f"{sum(r.code_wide for r in rows)}; output lines past their box: "
               f"{sum(r.output_wide for r in rows)}; visible verdicts: "
               f"{sum(r.verdicts for r in rows)}; stderr outputs: "
               f"{sum(r.stderr for r in rows)}; notebook pages over {MAX_READING_MINUTES:g} "
               f"min: {sum((r.minutes or 0) > MAX_READING_MINUTES for r in main)}; short of "
               f"figures: {sum(r.need is not None and r.figs < r.need for r in main)}; "
               f"figure text estimate: smallest {min((r.text_pt for r in rows if r.text_pt), default=float('nan'))} pt "
               f"(style's smallest font {smallest_style_font():g} pt)")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", help="a jupyter-book --path-output dir, or its html dir")
    parser.add_argument("--details", action="store_true",
                        help="print each failing page's problems in full")
    parser.add_argument("--screenshots", metavar="DIR",
                        help="save each page's first screen at 1280 x 800 px as DIR/<page>.png")
    parser.add_argument("pages", nargs="*")
    args = parser.parse_args(argv)
    html_dir = html_dir_of(args.build)
    pages = [page_docname(p) for p in args.pages] or default_pages()
    rows = measure(pages, html_dir, args.screenshots)
    print(f"built book: {html_dir}")
    print(table(rows))
    if args.details:
        for r in rows:
            for name, text in problems(r).items():
                print(f"{r.page} [{name}]: {text}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
