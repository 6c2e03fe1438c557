"""The README's "running live" command, tested for real.

A JupyterLab server is started on loopback exactly as the README starts it
(with the project's settings that open chapters as notebooks). The test
fetches the introduction through the contents API *as a notebook* (jupytext's
contents manager), opens a kernel session for it through the REST API and
executes every code cell over the kernel's websocket, checking that nothing
errs and that the interactive cell produces a live widget.
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
from book_tools import ROOT

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
           f"--ServerApp.root_dir={ROOT}", "--allow-root"]
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
