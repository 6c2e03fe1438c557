"""The executed book can fail: break one core function per chapter, and the chapter must stop.

Each entry perturbs one package function slightly (a variance scaled by 1 %, a
sign flipped) in the chapter's kernel, before the chapter's first cell, and
replaces it everywhere the package refers to it. The chapter must then fail
*at one of its own checks* — a :class:`radarfusion_ref.kit.checks.CheckError` —
not at some unrelated error. This proves that the chapter's verification,
hidden from the page, is live.
"""

from __future__ import annotations

import textwrap

import pytest
from book_tools import ROOT, ChapterExecutionError, execute_chapter

#: chapter (``page`` or ``page:variant`` for a further mutation of the same page) →
#: (module, function, wrapper). The wrapper is Python source of a
#: function ``wrap(f)`` returning the perturbed function (``np``, ``dataclasses``
#: and ``functools`` are available to it).
MUTATIONS = {
    "book/01_fusion": ("radarfusion_ref.fusion", "fuse", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                r = f(*a, **k)
                return dataclasses.replace(r, variance=np.asarray(r.variance) * 1.01)
            return g
        """),
    "book/02_proximity": ("radarfusion_ref.proximity", "proximity", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/03_gating": ("radarfusion_ref.gating", "gate_threshold", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/04_association": ("radarfusion_ref.association", "associate_joint", """
        def wrap(f):
            @functools.wraps(f)
            def g(cost, *a, **k):
                c = np.asarray(cost, dtype=float)   # costs tilted by up to 1 % across columns
                return f(c * (1.0 + 0.01 * np.linspace(0.0, 1.0, c.shape[-1])), *a, **k)
            return g
        """),
    "book/05_features": ("radarfusion_ref.features", "type_posterior", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/06_conversion": ("radarfusion_ref.conversion", "conversion_bias", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                r = f(*a, **k)
                return -np.asarray(r) if not dataclasses.is_dataclass(r) else r
            return g
        """),
    "book/07_separated": ("radarfusion_ref.separated", "pair_statistic", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/08_grouping": ("radarfusion_ref.grouping", "group_costs", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/09_registration": ("radarfusion_ref.registration", "bias_information", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                return np.asarray(f(*a, **k)) * 1.01
            return g
        """),
    "book/10_trackfusion": ("radarfusion_ref.trackfusion", "bar_shalom_campo", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                r = f(*a, **k)
                return dataclasses.replace(r, covariance=np.asarray(r.covariance) * 1.01)
            return g
        """),
    # a plausible bug: ω optimised for the trace whatever criterion is asked for
    "book/10_trackfusion:ci-criterion": ("radarfusion_ref.trackfusion", "ci_weight", """
        def wrap(f):
            @functools.wraps(f)
            def g(P1, P2, *, criterion="det"):
                return f(P1, P2, criterion="trace")
            return g
        """),
    "book/11_capstone": ("radarfusion_ref.engine.metrics", "gospa", """
        def wrap(f):
            @functools.wraps(f)
            def g(*a, **k):
                r = f(*a, **k)
                return dataclasses.replace(r, total=r.total * 1.01)
            return g
        """),
    "book/montecarlo": ("radarfusion_ref.engine.montecarlo", "unit_rng", """
        def wrap(f):
            @functools.wraps(f)
            def g(root, point, unit):
                return f(root, 0, unit)   # every point, one stream
            return g
        """),
}

PREAMBLE = """\
import dataclasses, functools, importlib, sys
import numpy as np
{wrap}
_module = importlib.import_module({module!r})
_original = getattr(_module, {name!r})
_mutant = wrap(_original)
for _m in list(sys.modules.values()):
    if getattr(_m, "__name__", "").startswith("radarfusion_ref"):
        for _k, _v in list(vars(_m).items()):
            if _v is _original:
                setattr(_m, _k, _mutant)
del _m, _k, _v
"""

CHECK_ERRORS = ("CheckError", "SymbolicCheckError", "MonteCarloCheckError")


def preamble(module: str, name: str, wrap: str) -> str:
    return PREAMBLE.format(wrap=textwrap.dedent(wrap).strip(), module=module, name=name)


@pytest.mark.notebook
@pytest.mark.parametrize("docname", sorted(MUTATIONS))
def test_a_broken_function_stops_its_chapter_at_a_check(docname):
    module, name, wrap = MUTATIONS[docname]
    with pytest.raises(ChapterExecutionError) as info:
        execute_chapter(ROOT / f"{docname.split(':')[0]}.md", cache_dir=None,
                        preamble=preamble(module, name, wrap))
    text = str(info.value)
    assert any(err in text for err in CHECK_ERRORS), (
        f"{docname} failed, but not at one of its checks:\n{text[-3000:]}"
    )
