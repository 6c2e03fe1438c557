"""The README's "running live" command, tested for real.

A JupyterLab server is started on loopback exactly as the README starts it
(with the project's settings that open chapters as notebooks), and with the
application object exposed to the page so a browser can drive it. The tests
fetch the introduction through the contents API *as a notebook* (jupytext's
contents manager), open a kernel session for it through the REST API and
execute every code cell over the kernel's websocket, checking that nothing
errs and that the interactive cell produces a live widget; then, in Chromium,
they open the chapter as a reader does, check that its MyST renders, run it,
move a slider, check that the figure changes, save, and check that the page's
source is unchanged; and they open the notebook the built site offers for
download.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import time
import urllib.request
import uuid
from datetime import datetime, timezone

import pytest
from book_tools import BUILD_DIR, ROOT, browser_fixture

pytestmark = pytest.mark.book

CHAPTER = "book/intro.md"
TOKEN = uuid.uuid4().hex


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _get(url: str, method: str = "GET", body: dict | None = None):
    data = None if body is None else json.dumps(body).encode()
    req = urllib.request.Request(url, data=data, method=method,
                                 headers={"Authorization": f"token {TOKEN}",
                                          "Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=30) as r:
        raw = r.read()
    return json.loads(raw) if raw[:1] in (b"{", b"[") else raw.decode()


@pytest.fixture(scope="module")
def lab():
    port = _free_port()
    env = dict(os.environ, JUPYTERLAB_SETTINGS_DIR=str(ROOT / ".jupyter/lab/user-settings"))
    cmd = [sys.executable, "-m", "jupyterlab", "--no-browser", "--ip=127.0.0.1",
           f"--port={port}", f"--IdentityProvider.token={TOKEN}",
           f"--ServerApp.root_dir={ROOT}", "--allow-root",
           "--LabApp.expose_app_in_browser=True"]
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    base = f"http://127.0.0.1:{port}"
    deadline = time.time() + 90
    while True:
        try:
            _get(f"{base}/api/status")
            break
        except OSError:
            if proc.poll() is not None or time.time() > deadline:
                proc.kill()
                out = proc.stdout.read() if proc.stdout else ""
                pytest.fail(f"JupyterLab did not start:\n{out[-3000:]}")
            time.sleep(0.5)
    yield base
    proc.terminate()
    try:
        proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()


def test_chapters_open_as_notebooks_by_default(lab):
    settings = _get(f"{lab}/lab/api/settings/@jupyterlab/docmanager-extension:plugin")
    viewers = settings["settings"]["defaultViewers"]
    assert viewers.get("markdown") == "Jupytext Notebook"


def test_widget_and_jupytext_extensions_are_enabled(lab):
    page = _get(f"{lab}/lab")
    assert "@jupyter-widgets/jupyterlab-manager" in page
    assert "jupyterlab-jupytext" in page


def _execute(ws, session_id: str, code: str, timeout: float = 240.0) -> list[dict]:
    """Run `code` in the kernel; return the iopub messages it produced."""
    msg_id = uuid.uuid4().hex
    ws.send(json.dumps({
        "header": {"msg_id": msg_id, "username": "test", "session": session_id,
                   "msg_type": "execute_request", "version": "5.3",
                   "date": datetime.now(timezone.utc).isoformat()},
        "parent_header": {}, "metadata": {}, "buffers": [], "channel": "shell",
        "content": {"code": code, "silent": False, "store_history": True,
                    "user_expressions": {}, "allow_stdin": False, "stop_on_error": True},
    }))
    outputs, deadline = [], time.time() + timeout
    while time.time() < deadline:
        msg = json.loads(ws.recv())
        if msg.get("parent_header", {}).get("msg_id") != msg_id:
            continue
        kind = msg["header"]["msg_type"]
        if msg["channel"] == "iopub":
            if kind == "status" and msg["content"]["execution_state"] == "idle":
                return outputs
            outputs.append(msg)
    raise TimeoutError(f"cell did not finish in {timeout} s:\n{code[:200]}")


def test_chapter_runs_in_a_server_kernel(lab):
    import websocket

    model = _get(f"{lab}/api/contents/{CHAPTER}?type=notebook&content=1")
    assert model["type"] == "notebook"
    cells = [c for c in model["content"]["cells"] if c["cell_type"] == "code"]
    assert len(cells) >= 5

    session = _get(f"{lab}/api/sessions", "POST",
                   {"path": CHAPTER, "type": "notebook", "name": "",
                    "kernel": {"name": "python3"}})
    kernel_id = session["kernel"]["id"]
    ws = websocket.create_connection(
        f"{lab.replace('http', 'ws')}/api/kernels/{kernel_id}/channels?token={TOKEN}",
        timeout=300)
    try:
        widget_views = 0
        for cell in cells:
            source = "".join(cell["source"])
            outputs = _execute(ws, uuid.uuid4().hex, source)
            errors = [m["content"] for m in outputs if m["header"]["msg_type"] == "error"]
            assert not errors, f"{CHAPTER}: {errors[0]['ename']}: {errors[0]['evalue']}"
            widget_views += sum(
                "application/vnd.jupyter.widget-view+json" in m["content"].get("data", {})
                for m in outputs if m["header"]["msg_type"] in ("display_data", "execute_result"))
        assert widget_views >= 1, "the interactive cell produced no widget"
    finally:
        ws.close()
        _get(f"{lab}/api/sessions/{session['id']}", "DELETE")


def test_myst_extension_is_enabled(lab):
    assert "jupyterlab-myst" in _get(f"{lab}/lab")


@pytest.fixture(scope="module")
def browser():
    yield from browser_fixture("live JupyterLab test")


_CURRENT = "window.jupyterapp.shell.currentWidget"
_KERNEL_IDLE = f"""() => {{ const w = {_CURRENT}; const k = w.sessionContext.session &&
    w.sessionContext.session.kernel; return !!k && k.status === 'idle'; }}"""
_ALL_RUN = f"""() => {{ const w = {_CURRENT}; return w.sessionContext.session.kernel.status ===
    'idle' && w.content.widgets.every(c => c.model.type !== 'code' ||
    c.model.executionCount !== null); }}"""
#: MyST that shows raw where a Markdown renderer does not know it.
_RAW_MYST = ("```{", ":::{", "{eq}`", "{ref}`", "{doc}`", ")=\n#")


def _open(page, lab: str, path: str) -> None:
    """Open `path` in a fresh JupyterLab workspace; wait until its document is loaded."""
    page.goto(f"{lab}/lab/tree/{path}?reset&token={TOKEN}")
    page.wait_for_function(f"() => window.jupyterapp && {_CURRENT} && "
                           f"{_CURRENT}.context && {_CURRENT}.context.isReady "
                           f"&& {_CURRENT}.title.label === {json.dumps(path.rsplit('/', 1)[-1])}",
                           timeout=120_000)


def test_a_chapter_run_moved_and_saved_in_jupyterlab_keeps_its_source(lab, browser):
    path = ROOT / CHAPTER
    before = path.read_bytes()
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    try:
        _open(page, lab, CHAPTER)
        page.wait_for_function("() => document.querySelectorAll('.jp-MarkdownCell .myst')"
                               ".length >= 5", timeout=180_000)
        rendered = page.locator(".jp-MarkdownCell .myst").all_inner_texts()
        raw = [m for m in _RAW_MYST for text in rendered if m in text]
        assert not raw, f"MyST shown raw in JupyterLab: {sorted(set(raw))}"

        page.wait_for_function(_KERNEL_IDLE, timeout=300_000)
        page.evaluate("() => window.jupyterapp.commands.execute('notebook:run-all-cells')")
        page.wait_for_function(_ALL_RUN, timeout=300_000)
        errors = page.locator(".jp-OutputArea-output[data-mime-type='application/vnd.jupyter.stderr']")
        traces = [t for t in errors.all_inner_texts() if "Error" in t]
        assert not traces, f"{CHAPTER}: a cell failed in JupyterLab: {traces[0][-400:]}"

        box = page.locator(".widget-interact").first
        box.scroll_into_view_if_needed()
        figure = box.locator("img").first
        readout = box.locator(".widget-readout").first
        before_src, before_readout = figure.get_attribute("src"), readout.inner_text()
        box.locator(".noUi-handle").first.focus()
        page.keyboard.press("ArrowRight")
        # the view re-runs on release and replaces its figure
        page.wait_for_function(
            "(old) => { const i = document.querySelector('.widget-interact img');"
            " return !!i && i.getAttribute('src') !== old; }", arg=before_src, timeout=120_000)
        assert readout.inner_text() != before_readout, "the slider's readout did not move"

        page.evaluate("() => window.jupyterapp.commands.execute('docmanager:save')")
        page.wait_for_function(f"() => !{_CURRENT}.context.model.dirty", timeout=60_000)
    finally:
        page.close()
        after = path.read_bytes()
        if after != before:
            path.write_bytes(before)
    assert after == before, (
        f"saving {CHAPTER} in JupyterLab rewrote its source; run "
        f"`python tests/book_tools.py live-form {CHAPTER}` (see test_every_page_is_in_its_live_form)")


def test_the_downloaded_notebook_opens_in_jupyterlab(lab, browser, built_book):
    offered = BUILD_DIR / "html" / "_sources" / CHAPTER.replace(".md", ".ipynb")
    assert offered.exists(), "the built site offers no notebook of the introduction"
    folder = BUILD_DIR / "live_download"
    folder.mkdir(exist_ok=True)
    (folder / "intro.ipynb").write_bytes(offered.read_bytes())
    rel = (folder / "intro.ipynb").relative_to(ROOT).as_posix()
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    try:
        _open(page, lab, rel)
        cells = page.evaluate(f"() => {_CURRENT}.content.widgets.length")
        assert cells >= 10, f"the downloaded notebook opened with {cells} cells"
    finally:
        page.close()
