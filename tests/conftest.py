"""Shared fixtures: the chapter list, the executed-notebook cache and the built book.

Test order matters for speed, not correctness: unit tests run first, then one
test per chapter executes its notebook (filling Jupyter Book's execution
cache), then the tests marked ``book`` build the book once — re-using that
cache, so no notebook is executed twice in one run — and check the HTML in a
real browser and the chapters in a live JupyterLab server.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))

from book_tools import BUILD_CMD, BUILD_DIR, toc_docnames  # noqa: E402
from hypothesis import HealthCheck, settings  # noqa: E402

# The property and fuzz suite's example budget. "ci" (the default) keeps the whole
# suite within a few minutes on 2 cores; "thorough" is for a long local run:
# HYPOTHESIS_PROFILE=thorough python -m pytest tests/test_fuzz.py
settings.register_profile("ci", max_examples=60, deadline=None, derandomize=True,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("thorough", max_examples=2000, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def pytest_collection_modifyitems(config, items):
    """Unit tests first, then chapter execution, then the built-book tests."""

    def rank(item):
        if item.get_closest_marker("book"):
            return 2
        if item.get_closest_marker("notebook"):
            return 1
        return 0

    items.sort(key=rank)


def pytest_configure(config):
    config.addinivalue_line("markers", "notebook: executes one chapter of the book")


@pytest.fixture(scope="session")
def root() -> Path:
    return ROOT


@pytest.fixture(scope="session")
def docnames() -> list[str]:
    return toc_docnames(ROOT)


@pytest.fixture(scope="session")
def built_book():
    """Build the whole book once per session (``jupyter-book build --all -W``).

    Chapters already executed by the notebook tests come from the cache.
    Returns the completed process (its output is checked by the build tests).
    """
    cmd = [*BUILD_CMD, str(ROOT)]
    env = dict(os.environ, PYDEVD_DISABLE_FILE_VALIDATION="1")
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, env=env, timeout=1800)
    html = BUILD_DIR / "html"
    if proc.returncode != 0 or not (html / "index.html").exists():
        tail = "\n".join((proc.stdout + proc.stderr).splitlines()[-60:])
        pytest.fail(f"the book build failed (exit {proc.returncode}):\n{tail}")
    return proc
