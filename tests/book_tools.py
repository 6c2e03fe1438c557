"""Helpers for the tests that execute, build and browse the book.

A chapter is executed the way a reader's kernel would run it: the MyST
Markdown file is read with jupytext and executed with nbclient in ``book/``.
The executed notebook is then stored in Jupyter Book's execution cache
(``_build/.jupyter_cache``), keyed — as Jupyter Book keys it — by the hash of
its code cells, so the build that follows in the same test run re-uses it.
"""

from __future__ import annotations

import os
import re
import sys
import time
from pathlib import Path

import nbformat

from radarfusion_ref.kit.checks import LOG_ENV as CHECK_LOG_ENV

ROOT = Path(__file__).resolve().parents[1]
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
    if cache_dir is not None:
        _store_in_cache(nb, path, seconds, cache_dir)
        EXECUTED.add(str(path))
    return nb, seconds


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
