"""The build budget: each chapter's execution time and a whole clean build's.

Usage::

    python benchmarks/notebook_times.py            # chapters, then a clean full build
    python benchmarks/notebook_times.py --no-build # chapters only

Each chapter is executed in a fresh kernel (jupytext + nbclient, as the tests
do, without touching the build cache). The full build runs the README's build
command into a temporary directory with an empty execution cache, so it
executes every notebook. Budgets: 60 s per chapter, 300 s for the build, on a
2-core machine.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from book_tools import BUILD_CMD, execute_chapter, notebook_docnames  # noqa: E402

CHAPTER_BUDGET_S = 60.0
BUILD_BUDGET_S = 300.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-build", action="store_true", help="skip the full build")
    args = parser.parse_args()

    print(f"machine: {os.cpu_count()} cores, Python {sys.version.split()[0]}")
    print(f"{'chapter':<28}{'seconds':>9}  {'of budget':>9}")
    total, over = 0.0, []
    for docname in notebook_docnames(ROOT):
        _, seconds = execute_chapter(ROOT / f"{docname}.md", cache_dir=None)
        total += seconds
        share = seconds / CHAPTER_BUDGET_S
        flag = "  OVER" if share > 1 else ""
        print(f"{docname:<28}{seconds:>9.1f}  {share:>8.0%}{flag}")
        if share > 1:
            over.append(docname)
    print(f"{'sum of chapters':<28}{total:>9.1f}")

    if not args.no_build:
        with tempfile.TemporaryDirectory() as out:
            start = time.perf_counter()
            proc = subprocess.run([*BUILD_CMD, "--path-output", out, str(ROOT)], cwd=ROOT,
                                  capture_output=True, text=True)
            build = time.perf_counter() - start
        status = "ok" if proc.returncode == 0 else f"FAILED (exit {proc.returncode})"
        print(f"{'whole clean build':<28}{build:>9.1f}  {build / BUILD_BUDGET_S:>8.0%}  {status}")
        print(f"build / sum of chapters: {build / total:.2f}")
        if build > BUILD_BUDGET_S or proc.returncode != 0:
            over.append("build")
    if over:
        print("over budget: " + ", ".join(over))
    return 1 if over else 0


if __name__ == "__main__":
    raise SystemExit(main())
