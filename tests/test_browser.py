"""Every page of the built book in a real browser, with the network cut off.

Debian's Chromium is driven by Playwright through ``executable_path`` (no
browser download). The built site is served on 127.0.0.1; every request to any
other host is aborted and counts as a failure. For each page: it loads, MathJax
typesets every equation (no raw TeX left, no MathJax error), every image loads,
no request fails, and no script error occurs other than the allow-list below.
"""

from __future__ import annotations

import contextlib
import functools
import http.server
import os
import shutil
import threading
from pathlib import Path
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


@contextlib.contextmanager
def serve(directory: Path):
    """Serve `directory` on an ephemeral loopback port."""
    handler = functools.partial(_QuietHandler, directory=str(directory))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}"
    finally:
        httpd.shutdown()


@pytest.fixture(scope="module")
def server(built_book):
    with serve(BUILD_DIR / "html") as url:
        yield url


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


def page_problems(browser, url: str) -> list[str]:
    """Everything wrong with one page loaded with the network cut off."""
    host = urlparse(url).netloc
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
    unexpected = [e for e in errors if not any(a in e for a in ALLOWED_PAGE_ERRORS)]
    if unexpected:
        problems.append(f"script errors: {unexpected[:5]}")
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
<script>throw new Error("deliberate failure");</script></body></html>"""


def test_the_check_catches_a_bad_page(browser, tmp_path):
    """The control: a page with each kind of defect is reported for each of them."""
    (tmp_path / "bad.html").write_text(BAD_PAGE)
    with serve(tmp_path) as url:
        problems = " | ".join(page_problems(browser, f"{url}/bad.html"))
    for expected in ("requests to the network", "failed requests", "deliberate failure",
                     "raw TeX", "broken images"):
        assert expected in problems, f"not caught: {expected} (got: {problems})"
