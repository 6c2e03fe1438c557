"""Interactive helpers: the static sweep player works offline."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import pytest

from radarfusion_ref.interactive import slider, sweep_player


def test_sweep_player_has_one_frame_per_value_and_no_cdn():
    def draw(fig, value):
        fig.clear()
        fig.add_subplot().plot([0, 1], [0, value])

    html = sweep_player(draw, [1, 2, 3], fig=plt.figure(figsize=(2, 2))).data
    assert html.count("data:image/png;base64") == 3
    assert "font-awesome" not in html and "http://" not in html and "https://" not in html
    assert 'class="fa' not in html


def test_slider_updates_on_release():
    s = slider(0.3, 0.0, 1.0, 0.1, description="sigma")
    assert s.continuous_update is False and s.value == 0.3


def test_bad_input():
    with pytest.raises(ValueError, match="`value`"):
        slider(2.0, 0.0, 1.0)
    with pytest.raises(ValueError, match="`len\\(values\\)`"):
        sweep_player(lambda fig, v: None, [])
    with pytest.raises(TypeError, match="`draw`"):
        sweep_player("not callable", [1])
