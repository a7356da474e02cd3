"""optimise's report: the optimum beside its base design (issue 38: in placement.html the layout thumbnails were
tiny, three views a row in a figure shown at the page's width, each view under a third of it)."""
import numpy as np
import pytest
from figure_checks import captured, text_problems

from conftest import ROOT
from cvtdesign.io.plots import layout as layout_drawing
from cvtdesign.io.variant import load_variant


@pytest.mark.slow
def test_each_view_takes_about_half_the_figure_and_no_text_overlaps(monkeypatch, tmp_path):
    figures = captured(monkeypatch, layout_drawing)
    box = ROOT / "variants/box_kim.yaml"
    layouts = [("base design", load_variant(box)), ("optimum: d = 48.8 mm (base 60 mm)", load_variant(box, {"d": 0.0488}))]
    assert layout_drawing.beside_figure(layouts, np.radians(45.0), tmp_path / "beside.png") == 0
    fig = figures[-1]
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    width = fig.bbox.width
    views = [ax for ax in fig.axes if ax.get_title()]
    assert len(views) == 6
    for ax in views:
        assert ax.get_window_extent(renderer).width >= 0.38 * width, ax.get_title()
    # the same view of the two layouts side by side, in one row
    for title, *_ in layout_drawing.VIEWS:
        same = [ax.get_window_extent(renderer) for ax in views if ax.get_title() == title]
        assert len(same) == 2 and abs(same[0].y0 - same[1].y0) < 1 and same[0].x1 < same[1].x0
    assert text_problems(fig) == []
