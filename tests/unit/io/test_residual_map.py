"""The diagnosis's residual map (issue 38): region labels were cut at the panel's edge and drawn over each
other where regions share a corner (R5/R6), and the diagnosed model's panel was a flat grey on the base
model's ±5° scale. Labels now sit inside their boxes, stacked at a shared corner, and each panel has its own
scale."""
import numpy as np

from cvtdesign.io import plots
from figure_checks import captured, text_problems


def test_labels_inside_and_apart_and_each_panel_its_own_scale(monkeypatch, tmp_path):
    figures = captured(monkeypatch, plots)
    g, t = (a.ravel() for a in np.meshgrid(np.arange(-80, 81, 10.0), np.linspace(-1, 1, 11)))
    rng = np.random.default_rng(0)
    base, after = 5 + 0.3 * rng.standard_normal(g.size), 0.05 * rng.standard_normal(g.size)
    regions = [{"gamma_deg": [-80, 80], "load_Nm": [-1, 1], "mean_residual_deg": 5.0},
               {"gamma_deg": [-80, -40], "load_Nm": [0.6, 1], "mean_residual_deg": 5.6},
               {"gamma_deg": [40, 80], "load_Nm": [0.6, 1], "mean_residual_deg": 5.5}]
    plots.residual_map_figure([("base", g, t, base), ("diagnosed", g, t, after)], regions, tmp_path / "m.png")
    fig = figures[-1]
    assert text_problems(fig) == []
    left, right = fig.axes[0], fig.axes[1]
    inside = left.get_window_extent()
    for label in left.texts:
        box = label.get_window_extent()
        assert inside.x0 <= box.x0 and box.x1 <= inside.x1 and inside.y0 <= box.y0 and box.y1 <= inside.y1, label
    assert right.collections[0].get_clim()[1] < 0.5 < left.collections[0].get_clim()[1]
