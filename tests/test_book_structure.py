"""The book's layout: chapters, modules and tests share stems; conventions hold."""

from __future__ import annotations

import re

import pytest
from book_tools import ROOT, is_notebook, live_form, notebook_docnames, toc_docnames

from radarfusion_ref.kit import catalog

# a chapter is book/NN_<stem>; its sub-pages book/NN_<stem>_<topic> are sections of it
CHAPTER_DOCS = [d for d in notebook_docnames() if re.search(r"/\d\d_[a-z]+$", d)]


def test_catalog_matches_the_table_of_contents():
    assert [c.docname for c in catalog.CHAPTERS] == CHAPTER_DOCS


@pytest.mark.parametrize("chapter", catalog.CHAPTERS, ids=lambda c: c.stem)
def test_chapter_module_and_tests_exist(chapter):
    assert (ROOT / f"{chapter.docname}.md").exists()
    package = ROOT / "radarfusion_ref"
    assert ((package / f"{chapter.stem}.py").exists()
            or (package / chapter.stem / "__init__.py").exists()), chapter.module
    assert (ROOT / "tests" / f"test_{chapter.stem}.py").exists()
    assert (ROOT / "book" / "errata" / f"{chapter.stem}.md").exists()


@pytest.mark.parametrize("chapter", catalog.CHAPTERS, ids=lambda c: c.stem)
def test_catalog_titles_are_the_chapter_titles(chapter):
    text = (ROOT / f"{chapter.docname}.md").read_text(encoding="utf-8")
    title = re.search(r"^# (.+)$", text, flags=re.M).group(1).strip()
    assert title == chapter.title


def test_every_toc_entry_exists():
    for docname in toc_docnames():
        assert (ROOT / f"{docname}.md").exists(), docname


MAIN_PAGES = {c.docname for c in catalog.CHAPTERS} | {"book/intro"}


@pytest.mark.parametrize("docname", notebook_docnames())
def test_chapter_conventions(docname):
    text = (ROOT / f"{docname}.md").read_text(encoding="utf-8")
    assert is_notebook(ROOT / f"{docname}.md")
    assert "jupytext:" in text.split("---", 2)[1], "jupytext front matter"
    if docname in MAIN_PAGES:
        assert "{exercise-start}" in text, "a chapter ends with exercises"
    solutions = re.findall(r"```\{solution-start\}[^\n]*\n((?::[^\n]*\n)*)", text)
    if docname in MAIN_PAGES:
        assert solutions, "exercises have solutions"
    assert all(":class: dropdown" in opts for opts in solutions), "solutions hidden by default"
    if "rng" in text:
        assert "default_rng(" in text, "one seeded generator per page that draws"


def test_no_global_numpy_random_state():
    pattern = re.compile(r"np\.random\.(seed|rand|randn|randint|choice|normal|uniform|shuffle"
                         r"|permutation|random_sample)\(")
    offenders = []
    for path in [*ROOT.rglob("radarfusion_ref/**/*.py"), *ROOT.glob("book/*.md"),
                 *ROOT.glob("benchmarks/*.py")]:
        for i, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if pattern.search(line):
                offenders.append(f"{path.relative_to(ROOT)}:{i}: {line.strip()}")
    assert not offenders, offenders


def test_no_assert_for_validation_in_the_package():
    offenders = [f"{p.name}:{i}" for p in ROOT.rglob("radarfusion_ref/**/*.py")
                 for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
                 if re.match(r"\s*assert\s", line)]
    assert not offenders, offenders


def test_ci_runs_exactly_the_readme_test_command():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```bash\n(.*?)\n```", readme, flags=re.S)
    test_cmd = next(b for b in blocks if "pytest" in b)
    ci = (ROOT / ".ci" / "run").read_text(encoding="utf-8").splitlines()
    assert ci[-1] == test_cmd


def test_errata_page_includes_every_chapter_fragment():
    errata = (ROOT / "book" / "errata.md").read_text(encoding="utf-8")
    included = set(re.findall(r"\{include\} errata/(\w+)\.md", errata))
    assert included == {c.stem for c in catalog.CHAPTERS}


def test_errata_page_has_a_heading_per_paper():
    errata = (ROOT / "book" / "errata.md").read_text(encoding="utf-8")
    papers = [key for key, (_, bibkey) in catalog.PAPERS.items() if bibkey]
    assert len(re.findall(r"^## ", errata, flags=re.M)) == len(papers)


@pytest.mark.parametrize("chapter", catalog.CHAPTERS, ids=lambda c: c.stem)
def test_every_erratum_has_printed_corrected_and_evidence(chapter):
    text = (ROOT / "book" / "errata" / f"{chapter.stem}.md").read_text(encoding="utf-8")
    assert not re.search(r"^#{1,2} ", text, flags=re.M), "fragments use ### headings only"
    entries = re.split(r"^### ", text, flags=re.M)[1:]
    for entry in entries:
        title = entry.splitlines()[0]
        for part in ("Printed", "Corrected", "Evidence"):
            assert re.search(rf"^{part}\n: ", entry, flags=re.M), f"{title}: no {part}"
        evidence = entry.split("\nEvidence\n", 1)[1]
        assert "{ref}" in evidence, f"{title}: evidence links no executed cell"


def _api_units() -> dict[str, list[str]]:
    """Each public module or subpackage directly under the package, the engine or the kit.

    Maps its API page's stem to the dotted modules that page must document: the module
    itself, or a subpackage's public submodules (the subpackage itself when all of them are
    private).
    """
    units: dict[str, list[str]] = {}
    for layer in ("radarfusion_ref", "radarfusion_ref/engine", "radarfusion_ref/kit"):
        for path in sorted((ROOT / layer).iterdir()):
            if path.name.startswith("_") or path.name in ("engine", "kit"):
                continue
            dotted = f"{layer.replace('/', '.')}.{path.stem}"
            if path.suffix == ".py":
                documented = [dotted]
            elif (path / "__init__.py").exists():
                subs = sorted(f"{dotted}.{p.stem}" for p in path.glob("*.py")
                              if not p.name.startswith("_"))
                documented = subs or [dotted]
            else:
                continue
            assert path.stem not in units, f"two API units named {path.stem}"
            units[path.stem] = documented
    return units


def test_every_module_has_an_api_page():
    """One API page per public module or subpackage of the chapter, engine and kit layers."""
    units = _api_units()
    assert {"fusion", "montecarlo", "checks"} <= set(units), "the walk found all three layers"
    pages = {p.stem for p in (ROOT / "book" / "api").glob("*.md")} - {"index"}
    assert set(units) == pages
    listed = set(toc_docnames())
    assert {f"book/api/{m}" for m in units} <= listed
    undocumented = []
    for stem, modules in units.items():
        text = (ROOT / "book" / "api" / f"{stem}.md").read_text(encoding="utf-8")
        shown = set(re.findall(r"^\.\. automodule:: (\S+)", text, flags=re.M))
        undocumented += [f"{stem}.md: {m}" for m in modules if m not in shown]
    assert not undocumented, undocumented


def test_every_literalinclude_pattern_is_in_its_source():
    """`start-at` / `end-before` patterns of the chapters' literalincludes still match.

    A moved line would otherwise show up only as a warning in the book build.
    """
    import importlib
    import inspect

    missing = []
    for page in sorted((ROOT / "book").glob("*.md")):
        text = page.read_text(encoding="utf-8")
        for m in re.finditer(r"```\{literalinclude\} ([^\n]+)\n((?::[^\n]*\n)*)", text):
            path = (page.parent / m.group(1).strip()).resolve()
            opts = dict(re.findall(r":([\w-]+):\s*(.*)", m.group(2)))
            source = path.read_text(encoding="utf-8")
            if "pyobject" in opts:
                dotted = ".".join(path.relative_to(ROOT).with_suffix("").parts)
                obj = importlib.import_module(dotted)
                for part in opts["pyobject"].split("."):
                    obj = getattr(obj, part)
                source = inspect.getsource(obj)
            for key in ("start-at", "start-after", "end-before", "end-at"):
                if key in opts and (opts[key].startswith("#") or opts[key] not in source):
                    # MyST reads an option value that starts with # as a comment
                    missing.append(f"{page.name}: {key} {opts[key]!r}")
    assert not missing, missing


@pytest.mark.parametrize("docname", notebook_docnames())
def test_every_page_is_in_its_live_form(docname):
    """A reader who opens, runs and saves a page in JupyterLab leaves its source unchanged:
    the page is already written as jupytext writes it back, with the kernelspec the
    kernel reports, and its hidden cells collapsed in the notebook (tests/test_live.py
    saves one in a real browser)."""
    path = ROOT / f"{docname}.md"
    text = path.read_text(encoding="utf-8")
    if live_form(text) != text:
        import difflib

        diff = list(difflib.unified_diff(text.splitlines(), live_form(text).splitlines(),
                                         lineterm="", n=0))
        pytest.fail(f"{docname}.md would be rewritten by a save in JupyterLab; run "
                    f"`python tests/book_tools.py live-form {docname}.md`:\n"
                    + "\n".join(diff[:20]))


def test_live_form_collapses_hidden_cells_and_keeps_live_controls_open():
    import jupytext

    page = ("---\njupytext:\n  text_representation:\n    extension: .md\n"
            "    format_name: myst\nkernelspec:\n  display_name: Python 3\n"
            "  language: python\n  name: python3\n---\n\n# T\n\n"
            "```{code-cell} ipython3\n:tags: [remove-cell]\n\nx = 1\n```\n"
            "```{code-cell} ipython3\n:tags: [remove-cell]\n\ncontrols(view)\n```\n"
            "```{code-cell} ipython3\n\ny = 2\n```\n"
            "```{solution-start} ex-a\n```\n"
            "```{code-cell} ipython3\n\nz = 3\n```\n"
            "```{solution-end}\n```\n"
            "```{code-cell} ipython3\n\nw = 4\n```\n")
    out = live_form(page)
    assert out != page
    assert live_form(out) == out  # idempotent
    nb = jupytext.reads(out, fmt="md:myst")
    code = [c for c in nb.cells if c.cell_type == "code"]
    hidden = {"source_hidden": True}
    assert [c.metadata.get("jupyter") for c in code] == [hidden, None, None, hidden, None]
    assert nb.metadata["kernelspec"]["display_name"] == "Python 3 (ipykernel)"
