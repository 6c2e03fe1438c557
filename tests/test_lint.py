"""Lint: ruff over the code, pyflakes rules over every chapter, and the pre-commit hooks."""

from __future__ import annotations

import subprocess
import sys

import pytest
from book_tools import ROOT, notebook_docnames


def _ruff(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "ruff", *args], cwd=ROOT, input=stdin,
                          capture_output=True, text=True, timeout=120)


def test_ruff_is_clean():
    proc = _ruff("check", "--no-cache", ".")
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.parametrize("docname", notebook_docnames())
def test_chapter_code_has_no_pyflakes_errors(docname):
    """Undefined names, unused imports and similar slips in a chapter's code cells."""
    import jupytext

    nb = jupytext.read(ROOT / f"{docname}.md")
    script = jupytext.writes(nb, fmt="py:percent")
    # `display` and `get_ipython` are builtins in an IPython kernel
    proc = _ruff("check", "--no-cache", "--select", "F,E9", "--ignore", "F811",
                 "--config", "builtins = ['display', 'get_ipython']",
                 "--stdin-filename", f"{docname}.py", "-", stdin=script)
    assert proc.returncode == 0, f"{docname}:\n{proc.stdout}"


def test_pre_commit_runs_ruff_lint_and_the_import_contracts():
    """`.pre-commit-config.yaml` is valid and runs the checks the suite runs (no formatter)."""
    import yaml

    proc = subprocess.run([sys.executable, "-m", "pre_commit", "validate-config",
                           ".pre-commit-config.yaml"], cwd=ROOT, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    config = yaml.safe_load((ROOT / ".pre-commit-config.yaml").read_text(encoding="utf-8"))
    hooks = {(repo["repo"].rsplit("/", 1)[-1], hook["id"])
             for repo in config["repos"] for hook in repo["hooks"]}
    assert hooks == {("ruff-pre-commit", "ruff-check"), ("local", "lint-imports")}
