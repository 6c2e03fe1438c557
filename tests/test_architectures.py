"""Architecture (c), track then fuse: identities across fusion instants (constructed scene)."""

from __future__ import annotations

import numpy as np
import pytest

from radarfusion_ref.tracking import TrackHistory, track_then_fuse
from radarfusion_ref.tracking import _architectures as arch

SEP = 300.0                                      # lateral separation of the two aircraft, m
SPEED = 200.0
RADARS = ((5.0, 0.5), (4.0, 1.0), (3.0, 1.5))    # (scan period, first scan) per radar, s
DURATION = 120.0
GLITCH = 50.5                                    # radar 0's scan with a 0.6 SEP error


def _truth(t):
    """Positions (2, T, 3) of two aircraft flying in parallel, SEP apart."""
    t = np.asarray(t, float)
    x = np.stack([SPEED * t, np.zeros_like(t), np.full_like(t, 8000.0)], -1)
    return np.stack([x, x + np.array([0.0, SEP, 0.0])])


def _local_tracks(radar, *, b_first):
    """Exact local tracks of one radar; radar 0 pulls both tracks 0.6 SEP towards each
    other at one scan (its tracks then sit on the wrong side of each other).
    `b_first`: radar 0 numbers aircraft B's track first."""
    per, ph = RADARS[radar]
    t = np.arange(ph, DURATION, per)
    pos = _truth(t)                                                    # (2, T, 3)
    if radar == 0:
        k = np.flatnonzero(np.isclose(t, GLITCH))[0]
        pos[0, k, 1] += 0.6 * SEP
        pos[1, k, 1] -= 0.6 * SEP
    vel = np.broadcast_to([SPEED, 0.0, 0.0], pos.shape)
    state = np.concatenate([pos, vel], -1).reshape(-1, 6)
    ids = np.repeat([1, 0] if (b_first and radar == 0) else [0, 1], t.size)
    time = np.tile(t, 2)
    var = 4e4 if radar == 0 else 1e4                   # radar 0: the least accurate
    cov = np.broadcast_to(np.diag([var, var, var, 25.0, 25.0, 25.0]), (time.size, 6, 6))
    o = np.lexsort((ids, time))
    return TrackHistory(ids[o], time[o], state[o], cov[o].copy(), np.ones(time.size, bool))


def _reports():
    """One report per radar scan (the local tracks are given; only the scan instants count)."""
    rows = [(t, r, k) for r, (per, ph) in enumerate(RADARS)
            for k, t in enumerate(np.arange(ph, DURATION, per))]
    t, r, k = (np.array(c) for c in zip(*sorted(rows), strict=True))
    z = _truth(t)[0]
    return t, z, np.broadcast_to(np.eye(3) * 1e4, (t.size, 3, 3)).copy(), r, k


@pytest.mark.parametrize("rule", ["ci", "naive"])
@pytest.mark.parametrize("b_first", [False, True])
def test_track_then_fuse_keeps_identities_through_a_one_scan_glitch(monkeypatch, rule,
                                                                    b_first):
    # radar 0's tracks are swapped in position at one scan: a memoryless association pairs
    # them with the other radars' tracks of the other aircraft at that instant; the fused
    # tracks must still follow one aircraft each, at every instant
    def fake(time, position, covariance, radar, scan, *, settings=None):
        return _local_tracks(int(radar[0]), b_first=b_first)

    monkeypatch.setattr(arch, "track_reports", fake)
    h = track_then_fuse(*_reports(), period=5.0, rule=rule)
    assert np.unique(h.track).size == 2
    truth = _truth(h.time)                                             # (2, K, 3)
    d = np.linalg.norm(h.state[None, :, :3] - truth, axis=-1)           # (2, K)
    near = d.argmin(0)
    for k in np.unique(h.track):
        rows = h.track == k
        assert np.unique(near[rows]).size == 1, (k, h.time[rows][near[rows] != near[rows][0]])
    # and every fused row lies within its own aircraft's half of the separation
    assert np.all(d.min(0) < SEP / 2)


def test_identities_majority_vote():
    # the identity most of a group's local tracks carried wins, one identity per group
    ident = {(0, 1): 5, (1, 7): 2, (2, 3): 2, (0, 4): 2, (1, 8): 5, (2, 9): 5}
    gid, nxt = arch._identities([[(0, 1), (1, 7), (2, 3)], [(0, 4), (1, 8), (2, 9)],
                                 [(1, 99)]], ident, 6)
    assert gid.tolist() == [2, 5, 6] and nxt == 7
