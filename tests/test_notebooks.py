"""Execute every chapter of the book, one test per chapter.

A failing cell fails the test named after its chapter, with the cell's error.
The executed notebooks go into Jupyter Book's execution cache, so the book
build later in the same run re-uses them instead of executing again.

``RADARFUSION_BOOK_ROOT`` points the tests at another book (used by the test
that proves a broken chapter fails the test command).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from book_tools import ROOT, execute_chapters, notebook_docnames, selected

BOOK_ROOT = Path(os.environ.get("RADARFUSION_BOOK_ROOT", ROOT))
CHAPTERS = notebook_docnames(BOOK_ROOT)


#: Checks each chapter executed before its checks were hidden from the page.
BASELINE = json.loads((ROOT / "tests" / "check_baseline.json").read_text(encoding="utf-8"))
#: Passing checks recorded by each executed page in this run, by chapter key.
EXECUTED_CHECKS: dict[str, int] = {}


def chapter_key(docname: str) -> str:
    """``book/07_separated_table1`` → ``"07"`` (a chapter and its sub-pages share it)."""
    stem = docname.rsplit("/", 1)[-1]
    match = re.match(r"(\d\d)_", stem)
    return match.group(1) if match else stem


@pytest.fixture(scope="module")
def executed(request, tmp_path_factory):
    """The selected chapters, executed two at a time (``book_tools.execute_chapters``) into
    Jupyter Book's cache, each with its own ledger of passing checks."""
    logs = tmp_path_factory.mktemp("checks")
    jobs = {d: (BOOK_ROOT / f"{d}.md", {"check_log": logs / f"{d.replace('/', '-')}.log"})
            for d in selected(request, "test_chapter_executes")}
    return jobs, execute_chapters(jobs, cache_dir=BOOK_ROOT / "_build" / ".jupyter_cache")


@pytest.mark.notebook
@pytest.mark.parametrize("docname", CHAPTERS)
def test_chapter_executes(docname, executed):
    jobs, results = executed
    _, seconds, error = results[docname]
    if error is not None:
        pytest.fail(error, pytrace=False)
    log = jobs[docname][1]["check_log"]
    lines = log.read_text(encoding="utf-8").splitlines() if log.exists() else []
    key = chapter_key(docname)
    EXECUTED_CHECKS[key] = EXECUTED_CHECKS.get(key, 0) + len(lines)
    print(f"{docname}: executed in {seconds:.1f} s, {len(lines)} checks passed")


@pytest.mark.notebook
@pytest.mark.skipif(BOOK_ROOT != ROOT, reason="the baseline belongs to this book")
def test_hidden_checks_still_execute():
    """Every chapter executes at least as many checks as it did before they were hidden.

    Runs after the chapter tests (same file, same rank), from the ledger each
    chapter's kernel wrote.
    """
    missing = [k for k in BASELINE["chapters"] if k not in EXECUTED_CHECKS]
    if missing:
        pytest.fail(f"chapters not executed in this run: {missing}", pytrace=False)
    short = {k: (EXECUTED_CHECKS[k], n) for k, n in BASELINE["chapters"].items()
             if EXECUTED_CHECKS[k] < n}
    assert not short, f"chapters executing fewer checks than before (executed, baseline): {short}"


FRONT_MATTER = (ROOT / "book" / "intro.md").read_text(encoding="utf-8").split("---", 2)[1]


def make_book(tmp_path: Path, cell: str) -> Path:
    """A one-chapter book whose only code cell is `cell`."""
    (tmp_path / "book").mkdir()
    (tmp_path / "_toc.yml").write_text("format: jb-book\nroot: book/broken\n")
    (tmp_path / "_config.yml").write_text(textwrap.dedent("""\
        title: broken
        only_build_toc_files: true
        execute:
          execute_notebooks: cache
        """))
    (tmp_path / "book" / "broken.md").write_text(
        f"---{FRONT_MATTER}---\n\n# A broken chapter\n\n```{{code-cell}} ipython3\n{cell}\n```\n"
    )
    return tmp_path


def run_chapter_tests(book: Path) -> subprocess.CompletedProcess:
    """The chapter tests of this file, run by pytest against another book."""
    env = dict(os.environ, RADARFUSION_BOOK_ROOT=str(book))
    return subprocess.run(
        [sys.executable, "-m", "pytest", str(ROOT / "tests" / "test_notebooks.py"), "-q",
         "-p", "no:cacheprovider", "-k", "test_chapter_executes"],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=300,
    )


@pytest.mark.notebook
def test_broken_chapter_fails_the_test_command(tmp_path):
    proc = run_chapter_tests(make_book(tmp_path, "1 / 0"))
    assert proc.returncode == 1, proc.stdout[-2000:]
    assert "book/broken" in proc.stdout
    assert "ZeroDivisionError" in proc.stdout


@pytest.mark.notebook
def test_an_error_the_kernel_only_shows_fails_the_test_command(tmp_path):
    """A display that fails (a figure that cannot be drawn) is shown as an error output
    while the cell itself succeeds: the chapter test fails on it all the same."""
    cell = ("class Figure:\n    def _repr_html_(self):\n"
            "        raise RuntimeError('cannot draw')\n\n\nFigure()")
    proc = run_chapter_tests(make_book(tmp_path, cell))
    assert proc.returncode == 1, proc.stdout[-2000:]
    assert "shows an error the kernel did not raise" in proc.stdout
    assert "cannot draw" in proc.stdout


@pytest.mark.notebook
def test_working_chapter_passes_the_test_command(tmp_path):
    """The control for the test above: the same book with a working cell passes."""
    proc = run_chapter_tests(make_book(tmp_path, "x = 1 / 2"))
    assert proc.returncode == 0, proc.stdout[-2000:]


@pytest.mark.book
def test_broken_chapter_fails_the_build(tmp_path):
    """`jupyter-book build -W` exits non-zero when a cell raises."""
    from book_tools import BUILD_CMD

    book = make_book(tmp_path, "raise RuntimeError('deliberately broken')")
    proc = subprocess.run([*BUILD_CMD, str(book)], cwd=book, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode != 0
    assert "broken" in proc.stdout + proc.stderr
    assert "Executing notebook failed" in proc.stdout + proc.stderr
