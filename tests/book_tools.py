"""Helpers for the tests that execute, build and browse the book.

A chapter is executed the way a reader's kernel would run it: the MyST
Markdown file is read with jupytext and executed with nbclient in ``book/``.
The executed notebook is then stored in Jupyter Book's execution cache
(``_build/.jupyter_cache``), keyed — as Jupyter Book keys it — by the hash of
its code cells, so the build that follows in the same test run re-uses it.
"""

from __future__ import annotations

import contextlib
import functools
import http.server
import os
import re
import shutil
import subprocess
import sys
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if __name__ == "__main__":  # run as a script: the package of this checkout
    sys.path.insert(0, str(ROOT))

from radarfusion_ref.kit.checks import LOG_ENV as CHECK_LOG_ENV  # noqa: E402

BUILD_DIR = ROOT / "_build"
CACHE_DIR = BUILD_DIR / ".jupyter_cache"

#: Command that builds the book (the README's build command, minus the install).
BUILD_CMD = [sys.executable, "-c", "from jupyter_book.cli.main import main; main()",
             "build", "--all", "-W", "--keep-going"]


#: Chapters executed (and cached) by the notebook tests in this test run.
EXECUTED: set[str] = set()


class ChapterExecutionError(RuntimeError):
    """A chapter's notebook raised while executing."""


def toc_docnames(root: Path = ROOT) -> list[str]:
    """Every document listed in ``_toc.yml``, in order (no suffix).

    Parsed without a YAML library: the table of contents uses only
    ``root:`` and ``- file:`` entries.
    """
    text = (root / "_toc.yml").read_text(encoding="utf-8")
    names = re.findall(r"^\s*(?:root|-\s*file)\s*:\s*(\S+)\s*$", text, flags=re.M)
    return names


def is_notebook(path: Path) -> bool:
    """A MyST Markdown page is a notebook when its front matter names a kernel.

    A page listed in ``_toc.yml`` but missing on disk is not a notebook here (so
    collection never errors); ``test_every_toc_entry_exists`` names it instead.
    """
    if not path.exists():
        return False
    text = path.read_text(encoding="utf-8")
    return text.startswith("---") and "kernelspec:" in text.split("---", 2)[1]


def notebook_docnames(root: Path = ROOT) -> list[str]:
    """The documents of the table of contents that are executable notebooks."""
    return [d for d in toc_docnames(root) if is_notebook(root / f"{d}.md")]


def _short_error(exc: Exception) -> str:
    """The last lines of an nbclient error: the exception and the cell's line."""
    text = re.sub(r"\x1b\[[0-9;]*m", "", str(exc))
    lines = [ln for ln in text.splitlines() if ln.strip()]
    return "\n".join(lines[-25:])


def execute_chapter(path: Path, *, timeout: int = 300, cache_dir: Path | None = CACHE_DIR,
                    kernel_name: str = "python3", check_log: Path | None = None,
                    preamble: str | None = None):
    """Execute a MyST Markdown chapter and return ``(notebook, seconds)``.

    Parameters
    ----------
    check_log : Path, optional
        File in which the kernel's passing checks are recorded, one line each
        (``radarfusion_ref.kit.checks.LOG_ENV``).
    preamble : str, optional
        Code run in the kernel before the chapter's first cell (used by the
        mutation tests); the notebook is then not cached.

    Raises
    ------
    ChapterExecutionError
        Naming the chapter, with the failing cell's error.
    """
    import jupytext
    import nbformat
    from nbclient import NotebookClient
    from nbclient.exceptions import CellExecutionError, CellTimeoutError

    path = Path(path).resolve()
    nb = jupytext.read(path)
    if preamble is not None:
        nb.cells.insert(0, nbformat.v4.new_code_cell(preamble))
        cache_dir = None
    # record_timing=False: no execution timestamps in the cell metadata, which
    # Jupyter Book's cache hashes (it executes the same way)
    client = NotebookClient(nb, timeout=timeout, kernel_name=kernel_name, record_timing=False,
                            resources={"metadata": {"path": str(path.parent)}})
    start = time.perf_counter()
    saved = os.environ.get(CHECK_LOG_ENV)
    try:
        if check_log is not None:
            os.environ[CHECK_LOG_ENV] = str(check_log)  # the kernel inherits it
        client.execute()
    except (CellExecutionError, CellTimeoutError) as exc:
        raise ChapterExecutionError(
            f"chapter {path.relative_to(ROOT) if path.is_relative_to(ROOT) else path} "
            f"failed to execute:\n{_short_error(exc)}"
        ) from None
    finally:
        if saved is None:
            os.environ.pop(CHECK_LOG_ENV, None)
        else:
            os.environ[CHECK_LOG_ENV] = saved
    seconds = time.perf_counter() - start
    shown = _shown_errors(nb)
    if shown:
        raise ChapterExecutionError(
            f"chapter {path.relative_to(ROOT) if path.is_relative_to(ROOT) else path} "
            f"shows an error the kernel did not raise (e.g. a figure that fails to draw): "
            f"{shown}")
    if cache_dir is not None:
        _store_in_cache(nb, path, seconds, cache_dir)
        EXECUTED.add(str(path))
    return nb, seconds


#: Chapters the notebook and mutation tests execute at once, one kernel and one process each
#: (``RADARFUSION_TEST_WORKERS`` overrides; the suite's budget is measured on 2 cores).
WORKERS = int(os.environ.get("RADARFUSION_TEST_WORKERS", min(2, os.cpu_count() or 1)))


def selected(request, test_name: str) -> list:
    """The `docname` parameters of `test_name` in this module that this run selected."""
    return [item.callspec.params["docname"] for item in request.session.items
            if item.path == request.path and getattr(item, "originalname", None) == test_name]


def _execute_job(job):
    """One chapter in a worker process: ``(notebook, seconds, None)`` or ``(None, 0, error)``."""
    path, kwargs = job
    try:
        nb, seconds = execute_chapter(path, cache_dir=None, **kwargs)
    except ChapterExecutionError as exc:
        return None, 0.0, str(exc)
    return nb, seconds, None


def execute_chapters(jobs: dict, *, cache_dir: Path | None = None, workers: int = WORKERS):
    """Execute several chapters, `workers` at a time, each in a process of its own.

    `jobs` maps a key to ``(path, keyword arguments of execute_chapter)`` (``check_log``,
    ``preamble``, ``timeout``). Returns the same keys mapped to ``(notebook, seconds,
    error)``: the error text of :class:`ChapterExecutionError`, or None. The notebooks that
    executed without error and without a preamble are stored in `cache_dir` afterwards, in
    this process (one writer for the cache). The largest files go first, so the last
    chapter to finish is a short one.
    """
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    order = sorted(jobs, key=lambda k: -Path(jobs[k][0]).stat().st_size)
    if workers <= 1 or len(jobs) <= 1:
        results = {k: _execute_job(jobs[k]) for k in order}
    else:
        ctx = multiprocessing.get_context("spawn")      # no fork of the test process
        with ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=ctx) as pool:
            futures = {k: pool.submit(_execute_job, jobs[k]) for k in order}
            results = {k: f.result() for k, f in futures.items()}
    for k, (nb, seconds, error) in results.items():
        path, kwargs = jobs[k]
        if error is None and cache_dir is not None and kwargs.get("preamble") is None:
            _store_in_cache(nb, Path(path).resolve(), seconds, cache_dir)
            EXECUTED.add(str(Path(path).resolve()))
    return {k: results[k] for k in jobs}


def _shown_errors(nb) -> list[str]:
    """Error outputs of cells not tagged ``raises-exception``, as "cell N: Name: value"."""
    out = []
    for n, cell in enumerate(nb.cells):
        if cell.cell_type != "code" or "raises-exception" in cell.metadata.get("tags", []):
            continue
        for o in cell.get("outputs", []):
            if o.get("output_type") == "error":
                out.append(f"cell {n}: {o.get('ename')}: {str(o.get('evalue'))[:200]}")
    return out


def html_pages(root: Path = ROOT) -> list[Path]:
    """The built HTML page of every document in the table of contents."""
    return [root / "_build" / "html" / f"{d}.html" for d in toc_docnames(root)]


def _store_in_cache(nb, path: Path, seconds: float, cache_dir: Path) -> None:
    """Put the executed notebook where Jupyter Book's ``cache`` mode finds it."""
    from jupyter_cache import get_cache
    from jupyter_cache.base import CacheBundleIn

    cache_dir.parent.mkdir(parents=True, exist_ok=True)
    cache = get_cache(str(cache_dir))
    cache.cache_notebook_bundle(
        CacheBundleIn(nb, str(path), data={"execution_seconds": seconds}),
        check_validity=False, overwrite=True,
    )


#: Debian's Chromium, driven by Playwright through ``executable_path`` (no browser download).
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--disable-dev-shm-usage"]


def chromium_path() -> str | None:
    """The system's Chromium, or None."""
    for name in ("chromium", "chromium-browser"):
        path = shutil.which(name)
        if path:
            return path
    return None


CHROMIUM_MISSING = "Chromium is not installed (apt-get install chromium)"


@contextlib.contextmanager
def chromium_browser():
    """The system's Chromium launched by Playwright (:data:`CHROMIUM_ARGS`); yields the
    browser and closes it after. Raises :class:`FileNotFoundError` without Chromium."""
    path = chromium_path()
    if path is None:
        raise FileNotFoundError(CHROMIUM_MISSING)
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=path, args=CHROMIUM_ARGS)
        try:
            yield browser
        finally:
            browser.close()


def browser_fixture(what: str):
    """Body of a module-scoped pytest fixture: the browser of `what` (e.g. "layout test").

    Without Chromium the module's tests are skipped, except under ``CI=true``, where
    they fail: there the browser tests must run. Use as
    ``yield from browser_fixture("layout test")``.
    """
    import pytest

    if chromium_path() is None:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(f"{CHROMIUM_MISSING}; under CI=true the {what} must run")
        pytest.skip(CHROMIUM_MISSING)
    with chromium_browser() as browser:
        yield browser


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):
        pass


@contextlib.contextmanager
def serve(directory: Path):
    """Serve `directory` on an ephemeral loopback port; yields the base URL."""
    handler = functools.partial(_QuietHandler, directory=str(directory))
    httpd = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=httpd.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{httpd.server_address[1]}"
    finally:
        httpd.shutdown()


def page_docname(page: str | Path) -> str:
    """``book/01_fusion`` from ``book/01_fusion.md``, ``01_fusion`` or a path to the file."""
    text = str(page)
    if text.endswith(".md"):
        text = text[:-3]
    path = Path(text)
    if path.is_absolute() and path.is_relative_to(ROOT):
        text = str(path.relative_to(ROOT))
    if not text.startswith("book/"):
        text = f"book/{text}"
    if text not in toc_docnames(ROOT):
        raise ValueError(f"`pages`: {page!r} is not a page of _toc.yml")
    return text


def build_pages(pages, out_dir: Path, *, fresh: bool = False, timeout: int = 3600) -> Path:
    """Build the whole book into `out_dir`, executing only `pages`; return the HTML dir.

    Every page of ``_toc.yml`` is built, so numbering (chapters, equations,
    exercises) and cross-references are those of the full book, but only the
    chosen notebooks are executed (or taken from the execution cache): the
    others are listed in ``execute.exclude_patterns`` of a private copy of
    ``_config.yml`` and are rendered without outputs. The first build copies the
    checkout's execution cache (``_build/.jupyter_cache``), if any, into
    `out_dir`; later builds of the same pages are incremental. Nothing is written
    outside `out_dir`.

    Sphinx re-reads only pages whose source changed: pass ``fresh=True`` (the
    command line's ``--fresh``) after changing the package, so that every chosen
    page is executed again (or taken from the cache if its code is unchanged).
    A build in which a chosen page failed makes the next one fresh by itself.
    """
    import yaml

    chosen = {page_docname(p) for p in pages}
    if not chosen:
        raise ValueError("`pages`: name at least one page to build")
    out_dir = Path(out_dir).resolve()
    if out_dir == BUILD_DIR.resolve() or out_dir == ROOT.resolve():
        raise ValueError(f"`out_dir` must be a private directory, not {out_dir}")
    out_dir.mkdir(parents=True, exist_ok=True)
    config = yaml.safe_load((ROOT / "_config.yml").read_text(encoding="utf-8"))
    others = [f"{d}.md" for d in notebook_docnames(ROOT) if d not in chosen]
    config.setdefault("execute", {})["exclude_patterns"] = others
    # paths in the config are read relative to the config file: make them absolute
    local = config.get("sphinx", {}).get("local_extensions", {})
    for name, where in local.items():
        local[name] = str(ROOT / where)
    config["bibtex_bibfiles"] = [str(ROOT / b) for b in config.get("bibtex_bibfiles", [])]
    config_path = out_dir / "_config.yml"
    config_path.write_text(yaml.safe_dump(config, allow_unicode=True, sort_keys=False),
                           encoding="utf-8")
    cache = out_dir / "_build" / ".jupyter_cache"
    if not cache.exists() and CACHE_DIR.exists():
        shutil.copytree(CACHE_DIR, cache)
    marker = out_dir / ".fresh-next"
    fresh = fresh or marker.exists()
    cmd = [sys.executable, "-c", "from jupyter_book.cli.main import main; main()", "build",
           "--keep-going", "--path-output", str(out_dir), "--config", str(config_path),
           *(["--all"] if fresh else []), str(ROOT)]
    # the kernels (run in book/) import this checkout's package, installed or not
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p)
    env = dict(os.environ, PYDEVD_DISABLE_FILE_VALIDATION="1", PYTHONPATH=path)
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env=env,
                          timeout=timeout)
    (out_dir / "build.log").write_text(proc.stdout + proc.stderr, encoding="utf-8")
    marker.unlink(missing_ok=True)
    html = out_dir / "_build" / "html"
    if proc.returncode != 0 or not (html / "index.html").exists():
        marker.touch()
        tail = "\n".join((proc.stdout + proc.stderr).splitlines()[-40:])
        raise RuntimeError(f"the build failed (exit {proc.returncode}):\n{tail}")
    failed = [d for d in sorted(chosen)
              if f"{d}.md: WARNING: Executing notebook failed" in proc.stdout + proc.stderr]
    if failed:
        marker.touch()
        raise RuntimeError(f"{', '.join(failed)} failed to execute; the tracebacks are in "
                           f"{html / 'reports'}")
    return html


#: What a wheel of the package is built from (pyproject.toml reads README.md and LICENSE).
SOURCES = ("pyproject.toml", "README.md", "LICENSE", "radarfusion_ref")


def plain_install(tmp: Path) -> Path:
    """Install a copy of this checkout, plainly (not editable, no dependencies), into
    ``tmp/site``; return that folder. Built here without build isolation (setuptools >= 77)."""
    import shutil
    import subprocess

    src, site = tmp / "src", tmp / "site"
    src.mkdir()
    for name in SOURCES:
        if (ROOT / name).is_dir():
            shutil.copytree(ROOT / name, src / name,
                            ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
        else:
            shutil.copy2(ROOT / name, src / name)
    proc = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--quiet", "--no-deps", "--no-build-isolation",
         "--no-index", "--no-compile", "--disable-pip-version-check", "--target", str(site),
         str(src)], capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    return site


#: The kernelspec JupyterLab writes when it saves a notebook run in the default kernel.
LIVE_KERNELSPEC = {"name": "python3", "display_name": "Python 3 (ipykernel)",
                   "language": "python"}
#: Tags of the cells a page hides or removes; the notebook collapses their code.
HIDDEN_TAGS = frozenset({"remove-cell", "hide-input", "remove-input"})


def live_form(text: str) -> str:
    """A notebook page as JupyterLab (through jupytext) saves it.

    jupytext's writer fixes the blank lines between cells, the kernelspec is the one the
    reader's kernel writes back, and the code of a cell the page hides or removes is
    collapsed in the notebook (``jupyter.source_hidden``), as is an exercise's solution
    code, so a reader tries the exercise first — except live controls
    (``controls(``), which a page removes only because a widget is dead without a kernel.
    A page whose text equals its live form is left unchanged when a reader opens, runs
    and saves it.
    """
    import jupytext

    nb = jupytext.reads(text, fmt="md:myst")
    nb.metadata["kernelspec"] = dict(LIVE_KERNELSPEC)
    in_solution = False
    for cell in nb.cells:
        if cell.cell_type == "markdown":
            for mark in re.findall(r"\{solution-(start|end)\}", cell.source):
                in_solution = mark == "start"
            continue
        hidden = HIDDEN_TAGS & set(cell.metadata.get("tags", []))
        if (hidden or in_solution) and "controls(" not in cell.source:
            cell.metadata["jupyter"] = {"source_hidden": True}
        else:
            cell.metadata.pop("jupyter", None)
    return jupytext.writes(nb, fmt="md:myst")


def main(argv: list[str]) -> None:
    """``python tests/book_tools.py build-pages [--fresh] OUT_DIR PAGE...``: build some pages;
    ``python tests/book_tools.py live-form PAGE...``: rewrite pages in their live form."""
    if argv[:1] == ["live-form"]:
        for page in argv[1:]:
            path = Path(page)
            text = path.read_text(encoding="utf-8")
            if is_notebook(path) and live_form(text) != text:
                path.write_text(live_form(text), encoding="utf-8")
                print(f"rewrote {path}")
        return
    fresh = "--fresh" in argv
    argv = [a for a in argv if a != "--fresh"]
    if len(argv) < 3 or argv[0] != "build-pages":
        sys.exit("usage: python tests/book_tools.py build-pages [--fresh] OUT_DIR PAGE...\n"
                 "       python tests/book_tools.py live-form PAGE...\n"
                 "  e.g. python tests/book_tools.py build-pages /tmp/me_build book/01_fusion\n"
                 "  --fresh: re-read every page (after a change to the package)")
    start = time.perf_counter()
    html = build_pages(argv[2:], Path(argv[1]), fresh=fresh)
    print(f"built {html} in {time.perf_counter() - start:.0f} s "
          f"(log: {Path(argv[1]).resolve() / 'build.log'})")


if __name__ == "__main__":
    main(sys.argv[1:])
