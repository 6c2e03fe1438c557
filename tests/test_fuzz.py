"""Bad input at every public entry point of the package: refused, and refused by name.

For every public function of every module (its ``__all__``), each required
argument in turn receives generated garbage — ``None``, strings (numeric ones
too), booleans, NaN, infinities, empty and ragged lists, dictionaries — while
the other required arguments receive the same kind of garbage. The call must
raise :class:`ValueError` or :class:`TypeError` (never a raw ``LinAlgError``,
``IndexError``, ``AttributeError`` …, never a result), and the message must
name, in backticks, one of the function's public arguments. The check helpers
(:mod:`radarfusion_ref.kit.checks`, :mod:`radarfusion_ref.kit.symbolic`) may also fail
with their :class:`~radarfusion_ref.kit.checks.CheckError`: failing is their job.

Empty arrays are not garbage here: for element-wise functions an empty input
has an empty answer. Where a result is undefined on empty input, the module's
own tests require the refusal.

The per-module test files hold the hand-written bad-input cases and the property
tests on valid generated input; this file is the net under all of them.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import radarfusion_ref
from radarfusion_ref.kit.checks import CheckError

#: Functions that take no data (styles, ledgers) or whose arguments are callables and
#: drawing targets checked in their own test files.
SKIP = {
    "plotting.use_book_style", "plotting.book_style", "checks.passed",
    "interactive.controls", "interactive.sweep_player", "interactive.slider",
    "symbolic.show",
    # labels and a True condition are legitimate: check_equal("abc", "abc") holds;
    # its refusals are tested in tests/test_checks.py
    "checks.check_equal", "checks.check_true",
    # the doors' helpers that accept anything by design (a message's description of the
    # received value, the scalar/array return convention), or whose arguments are sizes the
    # caller computed; None is a valid `rng`, True a valid bool; their refusals are tested in
    # test_validation.py
    "validation.describe", "validation.unwrap", "validation.check_size",
    "validation.as_rng", "validation.as_seed_sequence", "validation.as_bool",
    "assignment.as_threshold",           # None means "no gate"; refusals in test_assignment.py
}
#: The doors take the caller's public name for the value they check (and its choices): the
#: net gives them a fixed name, garbage as the value, and requires that name in the message.
DOOR_ARGUMENTS = {"name": "probe", "choices": ("a", "b")}


def _short(module_name: str) -> str:
    """``radarfusion_ref.engine.montecarlo`` -> ``montecarlo``: the name without its layer."""
    parts = module_name.split(".")[1:]
    return ".".join(parts[1:] if parts[0] in ("engine", "kit") else parts)


def public_functions():
    out = []
    for info in pkgutil.walk_packages(radarfusion_ref.__path__, "radarfusion_ref."):
        if any(part.startswith("_") for part in info.name.split(".")):
            continue
        module = importlib.import_module(info.name)
        short = _short(info.name)
        for name in getattr(module, "__all__", []):
            obj = getattr(module, name)
            if (not inspect.isfunction(obj) or f"{short}.{name}" in SKIP
                    or (inspect.getdoc(obj) or "").startswith("Kernel")):   # trusted input
                continue
            params = [p for p in inspect.signature(obj).parameters.values()
                      if p.default is inspect.Parameter.empty
                      and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)]
            if params:
                out.append((f"{short}.{name}", obj, params))
    return out


FUNCTIONS = public_functions()

GARBAGE = st.sampled_from([
    None, "abc", "1.5", True, np.nan, np.inf, -np.inf, [[1.0, 2.0], [3.0]], {"a": 1},
    [np.nan, 1.0], ["1", "2"], object(),
])


def call(fn, params, values):
    args, kwargs = [], {}
    for p, v in zip(params, values, strict=True):
        if p.kind == p.KEYWORD_ONLY:
            kwargs[p.name] = v
        else:
            args.append(v)
    return fn(*args, **kwargs)


@pytest.mark.parametrize(("qualname", "fn", "params"), FUNCTIONS, ids=[f[0] for f in FUNCTIONS])
@given(data=st.data())
def test_garbage_is_refused_by_name(qualname, fn, params, data):
    door = qualname.startswith("validation.")
    values = [DOOR_ARGUMENTS[p.name] if door and p.name in DOOR_ARGUMENTS
              else data.draw(GARBAGE, label=p.name) for p in params]
    names = {DOOR_ARGUMENTS["name"]} if door else set(inspect.signature(fn).parameters)
    refusal = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            result = call(fn, params, values)
        except CheckError as exc:
            if qualname.split(".")[0] not in ("checks", "symbolic"):
                pytest.fail(f"{qualname} raised a CheckError on bad input: {exc}")
            return
        except (ValueError, TypeError) as exc:
            refusal = str(exc)
        except Exception as exc:  # the point is to report the wrong class
            pytest.fail(f"{qualname}{tuple(values)!r} raised {type(exc).__name__}, not "
                        f"ValueError/TypeError: {exc}")
    if refusal is None:
        pytest.fail(f"{qualname}{tuple(values)!r} accepted garbage and returned {result!r:.200}")
    named = set(re.findall(r"`([A-Za-z_][\w.\[\]()]*)`", refusal))
    assert named, f"{qualname}: the message names no argument: {refusal}"
    bases = {re.split(r"[.\[(]", n)[0] for n in named}
    assert bases & names, (
        f"{qualname}: the message names {sorted(named)}, none of its arguments "
        f"{sorted(names)}: {refusal}")


def test_the_net_covers_the_package():
    """Every module's public functions are in the net (or deliberately skipped)."""
    modules = {q.rsplit(".", 1)[0] for q, _, _ in FUNCTIONS}
    assert len(FUNCTIONS) >= 60, len(FUNCTIONS)
    assert {"fusion", "proximity", "gating", "association", "features", "conversion",
            "separated", "grouping", "checks", "montecarlo", "scenes",
            "assignment", "registration", "trackfusion", "metrics", "linalg", "geodesy",
            "capstone.detections", "capstone.evaluation", "capstone.pipeline",
            "capstone.radars", "capstone.traffic", "tracker",
            "tracking", "tracking.stonesoup", "validation"} <= modules


# --------------------------------------------------------------------------- extreme magnitudes
def _scene_calls():
    from radarfusion_ref.engine import scenes as sc

    base = dict(spacing=1.0, sigma1=0.1, sigma2=0.2, rng=1)
    return [
        (sc.two_radar_scene, (3,), dict(base, layout="uniform", dim=2)),
        (sc.two_radar_clutter_scene, (3,), dict(base, false_density1=0.5, dim=2)),
        (sc.typed_scene, (3,), dict(base, type_means=[0.0, 5.0], type_vars=[1.0, 1.0],
                                    feature_sigma1=0.1, feature_sigma2=0.1)),
        (sc.grouping_scene, (3, 2), dict(spacing=1.0, cov=np.eye(2)[None, None], rng=1)),
    ]


def _all_finite(obj) -> bool:
    fields = getattr(obj, "__dataclass_fields__", {})
    return all(np.all(np.isfinite(v)) for k in fields
               if isinstance(v := getattr(obj, k), np.ndarray) and v.dtype.kind == "f")


@pytest.mark.parametrize("value", [1e154, 1e200, 1e300, 1e308])
def test_extreme_finite_magnitudes_give_finite_scenes_or_a_named_refusal(value):
    """A finite but extreme spacing or sigma: a finite scene, or a refusal naming it."""
    for fn, args, kw in _scene_calls():
        for name in [k for k, v in kw.items() if isinstance(v, float)]:
            refusal, out = None, None
            with warnings.catch_warnings():
                warnings.simplefilter("error", RuntimeWarning)
                try:
                    out = fn(*args, **dict(kw, **{name: value}))
                except (ValueError, TypeError) as exc:
                    refusal = str(exc)
            if refusal is not None:
                assert f"`{name}`" in refusal, (fn.__name__, name, refusal)
            else:
                assert _all_finite(out), (fn.__name__, name, value)
