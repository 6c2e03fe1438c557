"""Every page of the built book in a real browser, with the network cut off.

Debian's Chromium is driven by Playwright through ``executable_path`` (no
browser download). The built site is served on 127.0.0.1; every request to any
other host is aborted and counts as a failure. For each page: it loads, MathJax
typesets every equation (no raw TeX left, no MathJax error), every image loads,
no request fails, and no script error occurs other than the allow-list below.
"""

from __future__ import annotations

import functools
import http.server
import os
import shutil
import threading
from urllib.parse import urlparse

import pytest
from book_tools import BUILD_DIR, toc_docnames

pytestmark = pytest.mark.book

#: Script errors of the theme that do not affect the page, each with its reason.
ALLOWED_PAGE_ERRORS = {
    # Jupyter Book 1 registers sphinx-thebe twice, so its one-line config script is
    # included twice and the second `const` declaration throws. Thebe (live code
    # on the page) is disabled in _config.yml; nothing else is affected.
    "Identifier 'THEBE_JS_URL' has already been declared",
}

CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--disable-dev-shm-usage"]


def chromium_path() -> str | None:
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.fixture(scope="module")
def browser():
    path = chromium_path()
    if path is None:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail("Chromium is not installed (apt-get install chromium); under CI=true "
                        "the browser test must run")
        pytest.skip("Chromium is not installed (apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=path, args=CHROMIUM_ARGS)
        yield b
        b.close()


@pytest.fixture(scope="module")
def server(built_book):
    handler = functools.partial(_QuietHandler, directory=str(BUILD_DIR / "html"))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{httpd.server_address[1]}"
    httpd.shutdown()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


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
  return {
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


@pytest.mark.parametrize("docname", toc_docnames())
def test_page_renders_offline(browser, server, docname):
    host = urlparse(server).netloc
    context = browser.new_context()
    blocked, failed, errors = [], [], []

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
    try:
        response = page.goto(f"{server}/{docname}.html", wait_until="load")
        assert response is not None and response.ok, f"{docname}: page did not load"
        result = page.evaluate(CHECK_PAGE)
    finally:
        context.close()

    assert not blocked, f"{docname}: requests to the network: {blocked[:5]}"
    assert not failed, f"{docname}: failed requests: {failed[:5]}"
    unexpected = [e for e in errors if not any(a in e for a in ALLOWED_PAGE_ERRORS)]
    assert not unexpected, f"{docname}: script errors: {unexpected}"
    if result["mathSpans"]:
        assert result["mathjax"], f"{docname}: MathJax did not load"
    assert result["typeset"] >= result["mathSpans"], (
        f"{docname}: {result['mathSpans']} math spans but {result['typeset']} typeset")
    assert result["mathErrors"] == 0, f"{docname}: {result['mathErrors']} MathJax errors"
    assert not result["raw"], f"{docname}: raw TeX left on the page: {result['raw'][:3]}"
    assert not result["brokenImages"], f"{docname}: broken images: {result['brokenImages']}"
