"""Every declared dependency floor is a tested one: the package's tests at the lowest versions.

``pyproject.toml`` declares the lowest version of each dependency it accepts. This module reads
those floors (the core dependencies and :data:`FLOOR_EXTRAS`: the kit's, the progress bar's,
Dask's, Stone Soup's, the sliders' and the compiled route's), builds a virtual environment with each pinned exactly at its floor, plus the
pytest and hypothesis of this environment, installs this checkout into it plainly (a
non-editable install without dependencies, as ``tests/test_packaging.py`` makes it) and runs
:data:`FLOOR_TESTS` and the package's doctests there, from a folder with no checkout in it.
It fails naming every test that failed at the floors. Tests that need what the floors
environment lacks (the tools that build the book) skip there.

The README example must print, at the floors, exactly what it prints here.

The environment is kept between runs in ``.cache/floors-py<version>-<key>/`` (git-ignored;
the key hashes the interpreter and every pin), so only the first run installs from the package
index; the package itself is installed afresh each run. Without a reachable package index the tests are
skipped locally; under ``CI=true`` they fail.
"""

from __future__ import annotations

import hashlib
import importlib.metadata as md
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
from book_tools import ROOT, plain_install
from packaging.version import Version

tomllib = pytest.importorskip("tomllib")  # Python >= 3.11

#: Extras whose floors the floors environment installs: the kit's (sympy, matplotlib), the
#: progress bar's (tqdm), Dask's, Stone Soup's, the sliders' (ipywidgets) and the compiled
#: route's (numba). The tools that build the book are not installed: the tests that need them
#: skip there.
FLOOR_EXTRAS = {"book": ("sympy", "matplotlib"), "progress": ("tqdm",), "dask": ("dask",),
                "stonesoup": ("stonesoup",), "widgets": ("ipywidgets",), "fast": ("numba",)}

#: Test files run at the floors: every numerical path of the engine and the chapter modules
#: whose answer a NumPy or scipy release could change (batched solves, sparse solvers, HiGHS,
#: special functions), the kit's checks and plots, and the README example with its oracle.
FLOOR_TESTS = (
    "test_assignment.py", "test_association.py", "test_capstone.py", "test_checks.py",
    "test_domain.py", "test_edges.py", "test_features.py", "test_fusion.py", "test_gating.py",
    "test_grouping.py", "test_linalg.py", "test_montecarlo.py", "test_plotting.py",
    "test_proximity.py", "test_readme_usage.py", "test_symbolic.py", "test_tracker.py",
    "test_trackfusion.py", "test_tracking.py", "test_validation.py",
    # the sliders (the rest of test_interactive.py draws players: slow, and matplotlib only)
    "test_interactive.py::test_slider_updates_on_release", "test_interactive.py::test_bad_input",
    "test_interactive.py::test_fuzz_slider_accepts_or_names_the_argument",
    # Stone Soup's trackers through tracking.stonesoup_track (the hour-long runs are slow)
    "test_tracking_realistic.py::test_stonesoup_bad_input_and_missing_package",
    "test_tracking_realistic.py::test_stonesoup_state_order_and_a_lone_target",
    # chapter 12's architectures end to end, on the shortest of its tests
    "test_architectures.py::test_track_then_fuse_keeps_identities_through_a_one_scan_glitch",
)

#: Not run at the floors, each with its reason.
FLOOR_DESELECT = {
    # Stone Soup 1.9 on NumPy 1.26 and scipy 1.11 books a pair farther apart than the cut-off c
    # as localisation (c^p), on NumPy 2 as a miss and a false track (c^p / 2 each): the same
    # total, which matches the package's at the floors too, and the package splits it the same
    # way under both; only the oracle's split moves (test_gospa_brute_force runs here).
    "test_capstone.py::test_gospa_against_stone_soup",
}

CACHE = ROOT / ".cache"
SECTION = "## Use the package"


def _requirement(spec: str) -> tuple[str, str]:
    """``"numpy>=1.26"`` -> ``("numpy", "1.26")``: the name (with its extras, as in
    ``"dask[distributed]"``) and its declared floor."""
    m = re.fullmatch(r"([A-Za-z0-9_.\-]+(?:\[[^\]]*\])?)\s*>=\s*([0-9][0-9A-Za-z.]*)\s*(,.*)?",
                     spec)
    if m is None:
        raise AssertionError(f"{spec!r} declares no floor (name>=version)")
    return m.group(1).lower(), m.group(2)


def floors() -> dict[str, str]:
    """The pins of the floors environment, read from ``pyproject.toml``: {requirement: floor}."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    pins = dict(_requirement(s) for s in project["dependencies"])
    extras = project["optional-dependencies"]
    for extra, names in FLOOR_EXTRAS.items():
        declared = {name.split("[")[0]: (name, floor) for name, floor in
                    (_requirement(s) for s in extras[extra] if not s.startswith("radarfusion"))}
        for name in names:
            requirement, floor = declared[name]
            pins[requirement] = floor
    return pins


def _dist(requirement: str) -> str:
    """``"dask[distributed]"`` -> ``"dask"``: the distribution whose version is pinned."""
    return requirement.split("[")[0]


def test_floors_are_read_from_pyproject():
    """Every core dependency has a floor, and the floors environment pins exactly those."""
    pins = floors()
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    core = {_requirement(s)[0] for s in project["dependencies"]}
    assert core == {"numpy", "scipy"}, "core: only what the engine and chapter modules import"
    assert set(pins) == core | {"sympy", "matplotlib", "tqdm", "dask[distributed]", "stonesoup",
                                "ipywidgets", "numba"}
    assert all(re.fullmatch(r"[0-9]+(\.[0-9]+)+", v) for v in pins.values()), pins
    with pytest.raises(AssertionError, match="declares no floor"):
        _requirement("numpy")


def _ci() -> bool:
    return os.environ.get("CI", "").lower() == "true"


def _unavailable(why: str):
    if _ci():
        pytest.fail(f"{why}; under CI=true the floors environment must be built")
    pytest.skip(why)


def _bin(venv: Path, name: str) -> Path:
    return venv / ("Scripts" if os.name == "nt" else "bin") / name


def _index_reachable(python: str) -> bool:
    """pip reaches its package index (its own configuration: index, proxies)."""
    try:
        proc = subprocess.run([python, "-m", "pip", "index", "versions", "numpy",
                               "--disable-pip-version-check"],
                              capture_output=True, text=True, timeout=120)
    except subprocess.TimeoutExpired:
        return False
    return proc.returncode == 0 and "numpy" in proc.stdout


def _build_venv(pins: dict[str, str]) -> Path:
    """The cached floors environment for `pins`; built (once) if missing."""
    tools = {name: md.version(name) for name in ("pytest", "hypothesis")}
    spec = [f"{n}=={v}" for n, v in sorted(pins.items())] + \
           [f"{n}=={v}" for n, v in sorted(tools.items())]
    py = f"{sys.version_info.major}.{sys.version_info.minor}"
    # the venv links to this interpreter: its path and exact version are part of the key
    key = hashlib.sha256(json.dumps([sys.version, os.path.realpath(sys.executable), spec])
                         .encode()).hexdigest()[:12]
    venv = CACHE / f"floors-py{py}-{key}"
    if (venv / "ready").exists():
        return venv
    if not _index_reachable(sys.executable):
        _unavailable("pip cannot reach the package index to build the floors environment")
    CACHE.mkdir(exist_ok=True)
    build = Path(tempfile.mkdtemp(prefix="floors-build-", dir=CACHE))
    try:
        subprocess.run([sys.executable, "-m", "venv", str(build)], check=True,
                       capture_output=True, timeout=300)
        proc = subprocess.run(
            [str(_bin(build, "python")), "-m", "pip", "install", "--quiet",
             "--disable-pip-version-check", "--only-binary=:all:", *spec],
            capture_output=True, text=True, timeout=1200)
        if proc.returncode != 0:
            pytest.fail(f"the floors environment ({' '.join(spec)}) cannot be installed:\n"
                        + "\n".join((proc.stdout + proc.stderr).splitlines()[-30:]))
        (build / "ready").write_text(" ".join(spec) + "\n", encoding="utf-8")
        try:
            build.rename(venv)                      # atomic: a parallel run may have won
        except OSError:
            if not (venv / "ready").exists():
                raise
    finally:
        shutil.rmtree(build, ignore_errors=True)
    return venv


@pytest.fixture(scope="module")
def floor_env(tmp_path_factory):
    """(python of the floors environment, the folder the package is installed in, the pins)."""
    pins = floors()
    venv = _build_venv(pins)
    python = str(_bin(venv, "python"))
    tmp = tmp_path_factory.mktemp("floors")
    site = plain_install(tmp)          # built here, for the floors' Python too
    return python, site, pins


def _env(site: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    return env | {"PYTHONPATH": str(site), "PYTHONDONTWRITEBYTECODE": "1"}


def test_floors_environment_holds_the_floors_and_the_installed_package(floor_env):
    python, site, pins = floor_env
    code = ("import json, importlib.metadata as md, radarfusion_ref\n"
            f"print(json.dumps({{'file': radarfusion_ref.__file__, 'versions': "
            f"{{n: md.version(n) for n in {sorted(map(_dist, pins))!r}}}}}))\n")
    proc = subprocess.run([python, "-c", code], cwd=site.parent, env=_env(site),
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    got = json.loads(proc.stdout.splitlines()[-1])
    assert got["file"].startswith(str(site)), got["file"]
    # PEP 440: the floor "1.26" is the release 1.26.0
    assert {n: Version(v) for n, v in got["versions"].items()} == \
        {_dist(n): Version(v) for n, v in pins.items()}, (pins, got["versions"])


def test_package_tests_pass_at_the_floors(floor_env):
    """FLOOR_TESTS and every doctest of the installed package, at the floors."""
    python, site, pins = floor_env
    report = site.parent / "floors.xml"
    cmd = [python, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-c",
           str(ROOT / "pyproject.toml"), "--rootdir", str(ROOT), f"--junitxml={report}",
           *(str(ROOT / "tests" / f) for f in FLOOR_TESTS), str(site / "radarfusion_ref"),
           *(f"--deselect=tests/{f}" for f in sorted(FLOOR_DESELECT)), "--disable-warnings"]
    proc = subprocess.run(cmd, cwd=site.parent, env=_env(site), capture_output=True, text=True,
                          timeout=1800)
    failed = []
    if report.exists():
        for case in ET.parse(report).getroot().iter("testcase"):
            bad = case.find("failure")
            bad = case.find("error") if bad is None else bad
            if bad is not None:
                why = (bad.get("message") or "").strip().splitlines()[:1]
                failed.append(f"{case.get('classname')}::{case.get('name')}: {''.join(why)}")
    pinned = ", ".join(f"{n} {v}" for n, v in sorted(pins.items()))
    tail = "\n".join((proc.stdout + proc.stderr).splitlines()[-40:])
    assert proc.returncode == 0 and not failed, (
        f"at the floors ({pinned}) {len(failed)} test(s) failed (pytest exit "
        f"{proc.returncode}):\n" + "\n".join(failed) + f"\n{tail}")
    summary = proc.stdout.strip().splitlines()[-1]
    assert re.search(r"\b[1-9][0-9]* passed", summary), summary   # something ran


def _readme_examples() -> list[str]:
    """The Python blocks of the README's "Use the package": association first, then tracking."""
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split(SECTION, 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)\n```", section, flags=re.S)
    assert len(blocks) >= 2, f"the README's {SECTION!r} lost an example"
    return blocks


@pytest.mark.parametrize("example", [0, 1], ids=["association", "tracking"])
def test_readme_example_prints_the_same_at_the_floors(floor_env, example):
    """The same installed package, run by this environment and by the floors one."""
    python, site, _ = floor_env
    code = _readme_examples()[example]
    out = []
    for exe in (sys.executable, python):
        proc = subprocess.run([exe, "-c", code], cwd=site.parent, env=_env(site),
                              capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        out.append(proc.stdout)
    here, floor = out
    assert here.strip() and all(here.splitlines()), here
    if example == 0:
        assert len(here.splitlines()) == 3, here                       # three fused pairs
    assert floor == here


def test_without_the_package_index_skipped_locally_failed_under_ci(monkeypatch, tmp_path):
    """No cached environment and pip cannot reach its index (an index on a closed port)."""
    monkeypatch.setattr(sys.modules[__name__], "CACHE", tmp_path / "cache")
    monkeypatch.setenv("PIP_CONFIG_FILE", os.devnull)          # no configured extra index
    for name in ("PIP_FIND_LINKS", "PIP_EXTRA_INDEX_URL", "PIP_NO_INDEX"):
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("PIP_INDEX_URL", "http://127.0.0.1:9/simple")
    monkeypatch.setenv("PIP_RETRIES", "0")
    monkeypatch.setenv("PIP_TIMEOUT", "2")
    assert not _index_reachable(sys.executable)
    monkeypatch.delenv("CI", raising=False)
    with pytest.raises(pytest.skip.Exception, match="cannot reach the package index"):
        _build_venv(floors())
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="under CI=true"):
        _build_venv(floors())
    assert not (tmp_path / "cache").exists()                  # nothing half-built is left
