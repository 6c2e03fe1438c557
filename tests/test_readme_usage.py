"""The README's "Use the package" example runs and prints the right pairs and fused estimates.

The oracle is independent of the package: squared Mahalanobis distances and the inverse-
covariance weighted (BLUE) fusion computed with numpy, the chi-square gate with scipy, and the
best one-to-one pairing by enumerating every pairing.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import re

import numpy as np
import pytest
from book_tools import ROOT
from scipy import stats

SECTION = "## Use the package"


def _section() -> str:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert SECTION in readme
    return readme.split(SECTION, 1)[1].split("\n## ", 1)[0]


@pytest.fixture(scope="module")
def run():
    """Execute the section's one python block in a fresh namespace; return (namespace, stdout)."""
    blocks = re.findall(r"```python\n(.*?)\n```", _section(), flags=re.S)
    assert len(blocks) == 1, "one example"
    code = blocks[0]
    assert len(code.splitlines()) <= 25, "a short example"
    namespace: dict = {"__name__": "__readme__"}
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), namespace)
    return namespace, out.getvalue()


def test_section_installs_the_package_plainly():
    assert re.search(r"```bash\npip install \.\n```", _section())


def test_example_uses_public_names_only():
    code = re.findall(r"```python\n(.*?)\n```", _section(), flags=re.S)[0]
    assert not re.search(r"\b_[a-z]", code.replace("__name__", "")), "no private names"
    assert "radarfusion_ref" in code


def _blue(x, cov):
    """Inverse-covariance weighted mean of the reports and its covariance."""
    info = sum(np.linalg.inv(c) for c in cov)
    fused_cov = np.linalg.inv(info)
    return fused_cov @ sum(np.linalg.solve(c, v) for v, c in zip(x, cov, strict=True)), fused_cov


def test_example_prints_the_best_gated_pairs_fused(run):
    ns, out = run
    x1, x2, cov1, cov2 = (np.asarray(ns[k], dtype=float) for k in ("x1", "x2", "cov1", "cov2"))
    n1, n2 = len(x1), len(x2)
    kappa = np.array([[(x1[i] - x2[j]) @ np.linalg.solve(cov1[i] + cov2[j], x1[i] - x2[j])
                       for j in range(n2)] for i in range(n1)])
    assert "p_false_reject=0.01" in _section(), "the oracle's gate is the example's"
    gate = stats.chi2.ppf(1 - 0.01, df=2)
    best = min((cols for cols in itertools.permutations(range(n2), n1)
                if all(kappa[i, j] < gate for i, j in enumerate(cols))),
               key=lambda cols: sum(kappa[i, j] for i, j in enumerate(cols)))

    printed = re.findall(r"radar 1 report (\d+) \+ radar 2 report (\d+): \[\s*([-\d.]+)\s+"
                         r"([-\d.]+)\s*\]", out)
    assert [(int(i), int(j)) for i, j, _, _ in printed] == list(enumerate(best)), out
    for i, j, e, n in printed:
        expected, _ = _blue([x1[int(i)], x2[int(j)]], [cov1[int(i)], cov2[int(j)]])
        np.testing.assert_allclose([float(e), float(n)], expected, atol=5.1e-4)


def test_example_scene_is_not_trivial(run):
    """The radars list the aircraft in different orders, and radar 2 has one report more."""
    ns, out = run
    assert len(ns["x2"]) > len(ns["x1"])
    printed = [(int(i), int(j)) for i, j in re.findall(r"report (\d+) \+ radar 2 report (\d+)", out)]
    assert len(printed) == len(ns["x1"])
    assert any(i != j for i, j in printed)
