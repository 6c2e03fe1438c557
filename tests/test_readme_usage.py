"""The README's "Use the package" examples run and print the right results.

The oracles are independent of the package. The fusion example: squared Mahalanobis
distances and the inverse-covariance weighted (BLUE) fusion computed with numpy, the
chi-square gate with scipy, and the best one-to-one pairing by enumerating every pairing.
The tracking example: a constant-velocity Kalman filter written out here, run on each
aircraft's reports in time order.
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


def _blocks():
    blocks = re.findall(r"```python\n(.*?)\n```", _section(), flags=re.S)
    assert len(blocks) == 2, "two examples: fusion, then tracking"
    return blocks


def _execute(code):
    """Execute `code` in a fresh namespace; return (namespace, stdout)."""
    assert len(code.splitlines()) <= 25, "a short example"
    namespace: dict = {"__name__": "__readme__"}
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, "README.md", "exec"), namespace)
    return namespace, out.getvalue()


@pytest.fixture(scope="module")
def run():
    return _execute(_blocks()[0])


@pytest.fixture(scope="module")
def run_tracking():
    return _execute(_blocks()[1])


def test_section_installs_the_package_plainly():
    assert re.search(r"```bash\npip install \.\n```", _section())


def private_names(code):
    """Names starting with an underscore in `code`: module paths and attributes alike."""
    return re.findall(r"(?<![\w])_[A-Za-z]\w*", code.replace("__name__", ""))


def test_examples_use_public_names_only():
    for code in _blocks():
        assert not private_names(code), "no private names"
        assert "radarfusion_ref" in code


def test_howto_tracking_uses_public_names_only():
    """The how-to page's code (every cell, hidden ones too) names nothing private."""
    page = (ROOT / "book" / "howto_tracking.md").read_text(encoding="utf-8")
    cells = re.findall(r"```\{code-cell\}[^\n]*\n(.*?)\n```", page, flags=re.S)
    assert len(cells) >= 5 and any("trk.track_reports(" in c for c in cells)
    found = [n for c in cells for n in private_names(c)]
    assert not found, f"private names on the how-to page: {found}"


def test_the_private_name_rule_can_fail():
    assert private_names("from radarfusion_ref.tracking._evaluation import x")
    assert private_names("h = trk._tracks_at(h, t, 1.0)")
    assert not private_names("history = tracking.track_reports(time, position)")


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


def _kalman(t, z, R, q, v_max):
    """Constant-velocity Kalman filter (continuous white acceleration of intensity q per
    axis, x y z) on position reports in time order, started at the first report with
    velocity 0 ± v_max (per axis); returns the last time and state."""
    q = np.diag(np.broadcast_to(np.asarray(q, float), 3))
    x = np.r_[z[0], 0.0, 0.0, 0.0]
    P = np.zeros((6, 6))
    P[:3, :3] = R[0]
    P[3:, 3:] = np.diag(np.broadcast_to(np.asarray(v_max, float), 3) ** 2)
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    for k in range(1, len(t)):
        dt = t[k] - t[k - 1]
        F = np.eye(6) + np.diag([dt] * 3, 3)
        Q = np.block([[dt**3 / 3 * q, dt**2 / 2 * q], [dt**2 / 2 * q, dt * q]])
        x, P = F @ x, F @ P @ F.T + Q
        K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R[k])
        x, P = x + K @ (z[k] - H @ x), (np.eye(6) - K @ H) @ P
    return t[-1], x


def test_tracking_example_prints_each_aircraft_filtered(run_tracking):
    ns, out = run_tracking
    t, z, R = (np.asarray(ns[k], dtype=float) for k in ("time", "position", "covariance"))
    radar, aircraft = np.asarray(ns["radar"]), np.asarray(ns["aircraft"])
    assert "length_unit=1000.0" in _section(), "positions in km, settings in SI"
    # the defaults' m²/s³ and m/s (horizontal, horizontal, vertical), in km
    q_km = np.array([50.0, 50.0, 0.03]) / 1e6
    v_km = np.array([250.0, 250.0, 5.0]) / 1e3
    printed = re.findall(r"track (\d+): at \[([^\]]*)\] km, moving \[([^\]]*)\] km/s", out)
    assert len(printed) == 2, out
    assert re.search(r"TrackHistory\(\d+ rows, 2 tracks, 2 confirmed", out), out
    at = 120.0
    for a in (0, 1):
        mine = np.flatnonzero(aircraft == a)
        mine = mine[np.lexsort((radar[mine], t[mine]))]      # time, then radar
        t_last, x = _kalman(t[mine], z[mine], R[mine], q_km, v_km)
        want = np.r_[x[:3] + (at - t_last) * x[3:], x[3:]]
        got = [np.r_[np.array(p.split(), float), np.array(v.split(), float)]
               for _, p, v in printed]
        best = min(got, key=lambda g: np.linalg.norm(g[:3] - want[:3]))
        np.testing.assert_allclose(best[:3], want[:3], atol=0.0051)
        np.testing.assert_allclose(best[3:], want[3:], atol=0.00051)
