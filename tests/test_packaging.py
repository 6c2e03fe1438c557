"""A plain (non-editable) install works: version, licence and the capstone's data ship inside.

The project is copied to a temporary folder and installed from there with
``pip install --no-deps --no-build-isolation --no-index --target <site>`` (no network, and
nothing written into the work tree); the installed package is then imported in a fresh
interpreter whose only route to ``radarfusion_ref`` is ``PYTHONPATH=<site>``, from a folder
with no checkout in it.
"""

from __future__ import annotations

import csv
import gzip
import io
import json
import os
import re
import subprocess
import sys

import pytest
from book_tools import ROOT, plain_install

#: The installed package's data files (the capstone's traffic), as installed paths.
DATA_GLOB = "radarfusion_ref/capstone/data/*.csv.gz"


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    """Install a copy of the project into an empty target; return (site, workdir)."""
    tmp = tmp_path_factory.mktemp("install")
    site, work = plain_install(tmp), tmp / "elsewhere"
    work.mkdir()
    return site, work


def _run(installed, code: str) -> dict:
    """Run `code` in a fresh interpreter that sees only the installed copy; return its JSON."""
    site, work = installed
    env = {**os.environ, "PYTHONPATH": str(site)}
    proc = subprocess.run([sys.executable, "-c", code], cwd=work, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_pyproject_has_one_version_source_and_an_spdx_licence():
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    assert "version" not in project["project"], "the version is written once, in the package"
    assert "version" in project["project"]["dynamic"]
    assert project["tool"]["setuptools"]["dynamic"]["version"] == {
        "attr": "radarfusion_ref.__version__"}
    assert project["project"]["license"] == "MIT"
    assert project["project"]["license-files"] == ["LICENSE"]
    assert "MIT License" in (ROOT / "LICENSE").read_text(encoding="utf-8")


def test_installed_copy_is_the_one_imported_and_has_the_metadata_version(installed):
    site, _ = installed
    got = _run(installed, (
        "import json, importlib.metadata as md, radarfusion_ref as r\n"
        f"dists = list(md.distributions(name='radarfusion-ref', path=[{str(site)!r}]))\n"
        "print(json.dumps({'file': r.__file__, 'version': r.__version__,\n"
        "                  'meta': [d.version for d in dists],\n"
        "                  'licence': [d.metadata['License-Expression'] for d in dists]}))\n"))
    assert got["file"].startswith(str(site)), got["file"]
    assert got["meta"] == [got["version"]]
    assert got["licence"] == ["MIT"]
    assert list(site.glob("radarfusion_ref-*.dist-info/licenses/LICENSE"))


def test_installed_copy_loads_the_capstone_traffic(installed):
    """The data ships inside the package; the public loader finds it with no checkout around.

    The expected record count is read from the installed file itself with gzip and csv, not
    from the loader. Adapt the loader's name here if the capstone renames it.
    """
    site, _ = installed
    files = sorted(site.glob(DATA_GLOB))
    assert files, f"no {DATA_GLOB} in the installed package: the data is not packaged"
    with gzip.open(files[0], "rt", encoding="ascii") as fh:
        rows = list(csv.reader(io.StringIO(fh.read())))[1:]
    n_aircraft = len({r[1] for r in rows})
    got = _run(installed, (
        "import json\n"
        "from radarfusion_ref import capstone\n"
        "tr = capstone.load_traffic()\n"
        "print(json.dumps({'records': int(tr.t.size), 'aircraft': len(tr.icao24)}))\n"))
    assert got == {"records": len(rows), "aircraft": n_aircraft}


#: Optional packages: the extras of pyproject.toml (README "Use the package").
OPTIONAL = ("sympy", "matplotlib", "tqdm", "dask", "distributed", "stonesoup", "ipywidgets",
            "IPython", "numba")


def test_plain_install_imports_engine_and_chapter_modules_without_any_extra(installed):
    """With every optional package blocked (``sys.modules[name] = None``: importing it raises),
    the installed engine and every chapter module import; the kit refuses naming its extra."""
    got = _run(installed, (
        "import importlib, json, pkgutil, sys\n"
        f"for name in {OPTIONAL!r}:\n"
        "    sys.modules[name] = None\n"
        "import radarfusion_ref\n"
        "mods = []\n"
        "for info in pkgutil.walk_packages(radarfusion_ref.__path__, 'radarfusion_ref.'):\n"
        "    if not info.name.startswith('radarfusion_ref.kit'):\n"
        "        importlib.import_module(info.name)\n"
        "        mods.append(info.name)\n"
        "try:\n"
        "    importlib.import_module('radarfusion_ref.kit.checks')\n"
        "    kit = None\n"
        "except ImportError as exc:\n"
        "    kit = str(exc)\n"
        "print(json.dumps({'file': radarfusion_ref.__file__, 'modules': mods, 'kit': kit}))\n"))
    site, _ = installed
    assert got["file"].startswith(str(site)), got["file"]
    for name in ("radarfusion_ref.engine.montecarlo", "radarfusion_ref.engine.assignment",
                 "radarfusion_ref.fusion", "radarfusion_ref.capstone",
                 "radarfusion_ref.tracking.stonesoup", "radarfusion_ref.trackfusion"):
        assert name in got["modules"], name
    assert got["kit"] == ("the book kit (radarfusion_ref.kit) needs matplotlib, which is not "
                          "installed: pip install 'radarfusion-ref[book]'")


def test_every_optional_package_names_a_declared_extra_that_installs_it():
    tomllib = pytest.importorskip("tomllib")
    from radarfusion_ref.engine.optional import EXTRAS

    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    extras = project["optional-dependencies"]
    assert set(EXTRAS) == set(OPTIONAL)
    # what installs each top-level package: its distribution, or the one that brings it
    brings = {"distributed": "dask[distributed]", "IPython": "ipykernel"}
    for top, extra in EXTRAS.items():
        names = [re.split(r"[<>=,;\s]", s, maxsplit=1)[0] for s in extras[extra]]
        names += [n.split("[")[0] for n in names]                   # dask[distributed] is dask
        assert brings.get(top, top) in names, (top, extra, names)
    assert {"book", "dask", "fast", "progress", "stonesoup", "widgets"} <= set(extras)
    assert extras["all"] == ["radarfusion-ref[book,dask,fast,progress,stonesoup,widgets]"]
    assert {re.split(r"[<>=\[]", s, maxsplit=1)[0] for s in project["dependencies"]} == \
        {"numpy", "scipy"}
