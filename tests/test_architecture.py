"""The package's architecture: three layers, no cycles, small modules, clean docstrings, types.

* import-linter's contracts in ``pyproject.toml`` (``[tool.importlinter]``): the kit above
  the chapter modules above the engine, and no import cycle between the modules of any
  package, even through an import inside a function;
* the chapter modules and the kit use the engine through public names only: no import of
  a private engine module or object (a leading underscore), and every public engine kernel
  (``*_kernel``) says that it trusts its input;
* no module over :data:`MAX_LINES` lines;
* no chapter page shows a private name through ``literalinclude :pyobject:``;
* no ``noqa: F401`` re-export outside an ``__init__.py``;
* no docstring (nor any other bare string statement) holds a control character;
* mypy passes on the engine layer (``[tool.mypy]``).
"""

from __future__ import annotations

import ast
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

from book_tools import ROOT

PACKAGE = ROOT / "radarfusion_ref"

#: A module that passes this many lines is a concept asking to become a subpackage.
MAX_LINES = 1000

LINT_IMPORTS = [sys.executable, "-c",
                "import sys; from importlinter.cli import lint_imports_command; "
                "sys.exit(lint_imports_command())"]


def _lint_imports(cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(cwd)}
    return subprocess.run([*LINT_IMPORTS, "--no-cache", "--no-logo"], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def _sources() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def _rel(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


# ----------------------------------------------------------------------------- layers
def test_import_contracts_are_kept():
    proc = _lint_imports(ROOT)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "0 broken" in proc.stdout


def _module_file(package: Path, stem: str) -> Path:
    """``<stem>.py`` or, once the module became a subpackage, ``<stem>/__init__.py``."""
    flat = package / f"{stem}.py"
    return flat if flat.exists() else package / stem / "__init__.py"


def test_import_contracts_catch_a_planted_violation(tmp_path):
    """A copy of the package with one import of each forbidden kind breaks each contract.

    The imports sit inside functions, where Python would tolerate a cycle at run time.
    """
    package = tmp_path / "radarfusion_ref"
    shutil.copytree(PACKAGE, package, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy2(ROOT / "pyproject.toml", tmp_path / "pyproject.toml")
    (package / "engine" / "planted.py").write_text(
        "def planted():\n    from .. import fusion\n    return fusion\n", encoding="utf-8")
    plants = {"fusion": "from .kit import checks\n    from . import trackfusion\n",
              "trackfusion": "from . import fusion\n"}
    for stem, body in plants.items():
        path = _module_file(package, stem)
        path.write_text(path.read_text(encoding="utf-8")
                        + f"\n\ndef _planted():\n    {body}", encoding="utf-8")
    (package / "stray.py").write_text('"""A module no layer names."""\n', encoding="utf-8")

    out = _lint_imports(tmp_path)
    text = out.stdout + out.stderr
    assert out.returncode != 0, text
    assert "radarfusion_ref.engine.planted -> radarfusion_ref.fusion" in text, text
    assert re.search(r"radarfusion_ref\.fusion(\.\w+)* -> radarfusion_ref\.kit\.checks", text), text
    assert re.search(r"\.(fusion -> \.trackfusion|trackfusion -> \.fusion) \(", text), text
    assert "radarfusion_ref.stray" in text, text


# ----------------------------------------------------------------------------- public engine
def _imported_engine_names(path: Path, package: Path):
    """Each ``(module, name)`` the file imports from the engine, relative imports resolved.

    ``import radarfusion_ref.engine._x`` gives ``("radarfusion_ref.engine._x", "")``.
    """
    tree = ast.parse(path.read_text(encoding="utf-8"))
    # the package a relative import starts from: the file's folder (for an __init__.py too)
    here = ["radarfusion_ref", *path.relative_to(package).parent.parts]
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            base = here[: len(here) - node.level + 1] if node.level else []
            module = ".".join([*base, *([node.module] if node.module else [])])
            for alias in node.names:
                yield node.lineno, module, alias.name
        elif isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name, ""


def _private_engine_imports(package: Path) -> list[str]:
    """Imports of a private engine module or object by a chapter module or the kit."""
    out = []
    for path in sorted(package.rglob("*.py")):
        rel = path.relative_to(package)
        if rel.parts[0] == "engine" or "__pycache__" in rel.parts:
            continue
        for line, module, name in _imported_engine_names(path, package):
            if module != "radarfusion_ref.engine" and not module.startswith(
                    "radarfusion_ref.engine."):
                continue
            dotted = [*module.split(".")[2:], *([name] if name else [])]
            if any(part.startswith("_") for part in dotted):
                out.append(f"{rel.as_posix()}:{line}: {module} import {name or '(module)'}")
    return out


def test_chapter_modules_and_kit_import_no_private_engine_name():
    """The engine's shared parts are its API: chapter modules and the kit use public names."""
    private = _private_engine_imports(PACKAGE)
    assert not private, "private engine names imported outside the engine:\n" + "\n".join(
        private)


def test_private_engine_import_detector_sees_planted_imports(tmp_path):
    """Each kind of private import, planted in a copy of a chapter module and the kit, is seen."""
    package = tmp_path / "radarfusion_ref"
    (package / "engine" / "tracker").mkdir(parents=True)
    (package / "kit").mkdir()
    (package / "engine" / "__init__.py").write_text("", encoding="utf-8")
    (package / "engine" / "_hidden.py").write_text("x = 1\n", encoding="utf-8")
    (package / "engine" / "tracker" / "_kalman.py").write_text("y = 1\n", encoding="utf-8")
    (package / "fusion.py").write_text(
        "import numpy as np\n"
        "from .engine.linalg import _ldl_kappa, mahalanobis_sq\n"   # a private object
        "from .engine import _hidden\n"                             # a private module by name
        "from .kit import checks\n", encoding="utf-8")
    (package / "kit" / "plotting.py").write_text(
        "def f():\n"
        "    from ..engine.tracker._kalman import y\n"               # through a private module
        "    import radarfusion_ref.engine._hidden\n"                # absolute, in a function
        "    from ..engine.validation import as_float\n", encoding="utf-8")
    (package / "engine" / "planted.py").write_text(                  # the engine itself may
        "from ._hidden import x\n", encoding="utf-8")
    found = _private_engine_imports(package)
    assert found == [
        "fusion.py:2: radarfusion_ref.engine.linalg import _ldl_kappa",
        "fusion.py:3: radarfusion_ref.engine import _hidden",
        "kit/plotting.py:2: radarfusion_ref.engine.tracker._kalman import y",
        "kit/plotting.py:3: radarfusion_ref.engine._hidden import (module)",
    ], found


def test_public_engine_kernels_say_they_trust_their_input():
    """A public kernel skips validation (the fuzz net leaves out a summary opening "Kernel").

    Every public ``*_kernel`` opens its summary with "Kernel", and every such summary says
    that its input is trusted.
    """
    import importlib
    import inspect
    import pkgutil

    import radarfusion_ref.engine as engine

    kernels = []
    for info in pkgutil.walk_packages(engine.__path__, "radarfusion_ref.engine."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        module = importlib.import_module(info.name)
        for name in getattr(module, "__all__", []):
            summary = (inspect.getdoc(getattr(module, name)) or "").split("\n\n")[0]
            if name.endswith("_kernel") or summary.startswith("Kernel"):
                kernels.append(name)
                assert summary.startswith("Kernel") and "trusted" in summary, (
                    f"{info.name}.{name}: its summary does not open with 'Kernel' and say "
                    f"that its input is trusted: {summary!r}")
    assert {"mahalanobis_sq_kernel", "predict_kernel", "cv_matrices"} <= set(kernels), kernels


# ----------------------------------------------------------------------------- size
def test_no_module_over_the_line_limit():
    sizes = {_rel(p): len(p.read_text(encoding="utf-8").splitlines()) for p in _sources()}
    assert len(sizes) > 20, "the walk found the package"
    over = {p: n for p, n in sorted(sizes.items()) if n > MAX_LINES}
    assert not over, f"modules over {MAX_LINES} lines (split them by concept): {over}"


# ----------------------------------------------------------------------------- pages
def _pyobject_targets(book=None):
    for page in sorted((book or ROOT / "book").rglob("*.md")):
        text = page.read_text(encoding="utf-8")
        for m in re.finditer(r"```\{literalinclude\}[^\n]*\n((?::[^\n]*\n)*)", text):
            for name in re.findall(r"^:pyobject:\s*(\S+)", m.group(1), flags=re.M):
                yield page, name


def _private_listings(book=None):
    return [f"{page.name}: {name}" for page, name in _pyobject_targets(book)
            if any(part.startswith("_") for part in name.split("."))]


def test_pages_literalinclude_only_public_names(tmp_path):
    """A page that still shows package source shows a public object (the reader's
    functions replaced most listings); the rule is shown to catch a private one."""
    assert not _private_listings(), f"pages show private code: {_private_listings()}"
    (tmp_path / "page.md").write_text("```{literalinclude} ../x.py\n:pyobject: _kernel\n```\n"
                                      "```{literalinclude} ../x.py\n:pyobject: public\n```\n",
                                      encoding="utf-8")
    assert _private_listings(tmp_path) == ["page.md: _kernel"]


# ----------------------------------------------------------------------------- shims
def test_no_noqa_f401_reexport_outside_init():
    hits = [f"{_rel(p)}:{i}" for p in _sources() if p.name != "__init__.py"
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
            if re.search(r"noqa:[^#\n]*\bF401\b", line)]
    assert not hits, f"re-export shims (import from the home module instead): {hits}"


# ----------------------------------------------------------------------------- docstrings
def _bare_strings(tree: ast.AST):
    """Every docstring and every other bare string statement (attribute docs) of a module."""
    for node in ast.walk(tree):
        if (isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
                and isinstance(node.value.value, str)):
            yield node.lineno, node.value.value


def _control_characters(text: str) -> set[str]:
    return {repr(c) for c in text if ord(c) < 0x20 and c != "\n"}


def test_control_character_detector_sees_an_escaped_tab():
    tree = ast.parse('def f():\n    """The cost \\text{c}."""\n')
    assert [_control_characters(s) for _, s in _bare_strings(tree)] == [{"'\\t'"}]
    tree = ast.parse('def f():\n    r"""The cost \\text{c}."""\n')
    assert [_control_characters(s) for _, s in _bare_strings(tree)] == [set()]


def test_no_docstring_holds_a_control_character():
    bad = []
    for path in _sources():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for line, text in _bare_strings(tree):
            if found := _control_characters(text):
                bad.append(f"{_rel(path)}:{line}: {sorted(found)}")
    assert not bad, f"docstrings holding control characters (make them raw): {bad}"


# ----------------------------------------------------------------------------- types
def test_engine_type_checks():
    """mypy, configured in ``pyproject.toml`` to check the engine layer."""
    engine_files = len(list((PACKAGE / "engine").rglob("*.py")))
    proc = subprocess.run(
        [sys.executable, "-m", "mypy", "--cache-dir", str(ROOT / "_build" / ".mypy_cache")],
        cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    checked = re.search(r"no issues found in (\d+) source files?", proc.stdout)
    assert checked and int(checked.group(1)) >= engine_files, proc.stdout

