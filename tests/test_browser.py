"""Every page of the built book in a real browser, with the network cut off.

Debian's Chromium is driven by Playwright through ``executable_path`` (no
browser download). The built site is served on 127.0.0.1; every request to any
other host is aborted and counts as a failure. For each page: it loads, MathJax
typesets every equation (no raw TeX left, no MathJax error), every image loads,
no request fails, no script error is thrown, nothing is logged to the console at
error or warning level, and no script — by ``<script src>`` or by an address in an
inline script (as sphinx-thebe's ``THEBE_JS_URL`` did) — points at the network.
There is no allow-list.
"""

from __future__ import annotations

from urllib.parse import urlparse

import pytest
from book_tools import BUILD_DIR, browser_fixture, serve, toc_docnames

pytestmark = pytest.mark.book


@pytest.fixture(scope="module")
def browser():
    yield from browser_fixture("browser test")


@pytest.fixture(scope="module")
def server(built_book):
    with serve(BUILD_DIR / "html") as url:
        yield url


CHECK_PAGE = """
async () => {
  if (window.MathJax && MathJax.startup && MathJax.startup.promise) {
    await MathJax.startup.promise;
  }
  const skip = new Set(["SCRIPT", "STYLE", "PRE", "CODE", "TEXTAREA", "NOSCRIPT"]);
  const raw = [];
  const walker = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  while (walker.nextNode()) {
    const node = walker.currentNode;
    let el = node.parentElement, inside = false;
    while (el) {
      if (skip.has(el.tagName) || el.classList.contains("highlight")) { inside = true; break; }
      el = el.parentElement;
    }
    if (inside) continue;
    const t = node.textContent;
    if (/\\\\\\(|\\\\\\[|\\$\\$|\\\\begin\\{|\\$[^$\\s][^$\\n]{0,80}\\$/.test(t)) raw.push(t.trim().slice(0, 80));
  }
  const imgs = Array.from(document.images);
  await Promise.all(imgs.map(i => i.complete ? null :
      new Promise(r => { i.onload = r; i.onerror = r; })));
  const here = window.location.host;
  const remoteScripts = [];
  for (const s of document.querySelectorAll("script")) {
    const src = s.getAttribute("src");
    if (src) {
      const u = new URL(src, window.location.href);
      if (u.protocol !== "data:" && u.host !== here) remoteScripts.push(u.href.slice(0, 100));
    } else {
      for (const m of (s.textContent || "").matchAll(/(?:https?:)?\\/\\/[^\\s"'`<>]+?\\.m?js\\b/g)) {
        remoteScripts.push("inline: " + m[0].slice(0, 100));
      }
    }
  }
  return {
    remoteScripts: remoteScripts,
    mathjax: !!window.MathJax,
    typeset: document.querySelectorAll("mjx-container").length,
    mathSpans: document.querySelectorAll(".math").length,
    mathErrors: document.querySelectorAll("mjx-merror").length,
    raw: raw,
    brokenImages: imgs.filter(i => !(i.complete && i.naturalWidth > 0))
                      .map(i => (i.getAttribute("src") || "").slice(0, 80)),
  };
}
"""


def page_problems(browser, url: str) -> list[str]:
    """Everything wrong with one page loaded with the network cut off."""
    host = urlparse(url).netloc
    context = browser.new_context()
    blocked, failed, errors, console = [], [], [], []

    def route(r):
        if urlparse(r.request.url).netloc == host or r.request.url.startswith("data:"):
            r.continue_()
        else:
            blocked.append(r.request.url)
            r.abort()

    context.route("**/*", route)
    page = context.new_page()
    page.on("requestfailed", lambda r: failed.append(f"{r.url} ({r.failure})"))
    page.on("response", lambda r: failed.append(f"{r.url} (HTTP {r.status})")
            if r.status >= 400 else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: console.append(f"{m.type}: {m.text}"[:200])
            if m.type in ("error", "warning") else None)
    try:
        response = page.goto(url, wait_until="load")
        if response is None or not response.ok:
            return [f"page did not load ({response.status if response else 'no response'})"]
        result = page.evaluate(CHECK_PAGE)
    finally:
        context.close()

    problems = []
    if blocked:
        problems.append(f"requests to the network: {blocked[:5]}")
    failed = [f for f in failed if not any(b in f for b in blocked)]
    if failed:
        problems.append(f"failed requests: {failed[:5]}")
    if errors:
        problems.append(f"script errors: {errors[:5]}")
    # a failed request is also logged to the console; it is reported above
    console = [c for c in console if "Failed to load resource" not in c]
    if console:
        problems.append(f"console errors or warnings: {console[:5]}")
    if result["remoteScripts"]:
        problems.append(f"scripts referenced from the network: {result['remoteScripts'][:5]}")
    if result["mathSpans"] and not result["mathjax"]:
        problems.append("MathJax did not load")
    if result["typeset"] < result["mathSpans"]:
        problems.append(f"{result['mathSpans']} math spans but {result['typeset']} typeset")
    if result["mathErrors"]:
        problems.append(f"{result['mathErrors']} MathJax errors")
    if result["raw"]:
        problems.append(f"raw TeX left on the page: {result['raw'][:3]}")
    if result["brokenImages"]:
        problems.append(f"broken images: {result['brokenImages']}")
    return problems


@pytest.mark.parametrize("docname", toc_docnames())
def test_page_renders_offline(browser, server, docname):
    problems = page_problems(browser, f"{server}/{docname}.html")
    assert not problems, f"{docname}: " + "; ".join(problems)


BAD_PAGE = """<!DOCTYPE html><html><head>
<script src="https://cdn.example.org/lib.js"></script></head>
<body><p>The proximity measure $\\kappa = x^2$ was never typeset.</p>
<img src="missing.png" alt="missing">
<script>console.error("deliberate console error");</script>
<script>console.warn("deliberate console warning");</script>
<script>throw new Error("deliberate failure");</script></body></html>"""

#: Only a script address in an inline script (what sphinx-thebe's config did), and a
#: script that redeclares a constant: no request is made, yet both must be caught.
SUBTLE_PAGE = """<!DOCTYPE html><html><head>
<script>const LIB_URL = "https://cdn.example.org/lib/index.js"</script>
<script>const LIB_URL = "https://cdn.example.org/lib/index.js"</script></head>
<body><p>Nothing else is wrong.</p></body></html>"""


def test_the_check_catches_a_bad_page(browser, tmp_path):
    """The control: a page with each kind of defect is reported for each of them."""
    (tmp_path / "bad.html").write_text(BAD_PAGE)
    with serve(tmp_path) as url:
        problems = " | ".join(page_problems(browser, f"{url}/bad.html"))
    for expected in ("requests to the network", "failed requests", "deliberate failure",
                     "deliberate console error", "deliberate console warning",
                     "scripts referenced from the network: ['https://cdn.example.org/lib.js",
                     "raw TeX", "broken images"):
        assert expected in problems, f"not caught: {expected} (got: {problems})"


def test_the_check_catches_a_script_address_and_a_redeclared_constant(browser, tmp_path):
    """The control for the THEBE_JS_URL defect: no request fails, yet the page is caught."""
    (tmp_path / "subtle.html").write_text(SUBTLE_PAGE)
    with serve(tmp_path) as url:
        problems = " | ".join(page_problems(browser, f"{url}/subtle.html"))
    assert "has already been declared" in problems, problems
    assert "inline: https://cdn.example.org/lib/index.js" in problems, problems
