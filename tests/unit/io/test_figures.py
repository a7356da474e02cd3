"""The figures a design review pastes as they are (issue 28): the Pareto front and the resteering plot,
judged by matplotlib's own measure of their text (tests/figure_checks.py)."""
import numpy as np
from figure_checks import captured, text_problems

from cvtdesign.cli.study import label_points
from cvtdesign.io import plots


def front(preloads, d=0.0488):
    return [{"point": k, "worst_alpha_deg": 1.9 + 0.8 * k, "power_loss_W": 8.0 / (1 + k), "design.preload": p,
             "design.d": d, "success": True, "variant_file": f"/r/variants/box_pareto_pareto{k}.yaml"}
            for k, p in enumerate(preloads)]


def test_pareto_points_are_labelled_with_their_design(monkeypatch, tmp_path):
    """pareto.png labelled each point with a file name (box_pareto_pareto3). Now with its design: the
    variables that vary along the front, in units, the ones that do not named once in the legend; no label
    overlaps another, a marker or the canvas's edge."""
    figures = captured(monkeypatch, plots)
    pts = front([300.0, 179.0, 121.9, 90.18, 70.42, 56.93, 47.24, 40.0])
    same = label_points(pts, {"preload": "force", "d": "length"})
    assert same == "d = 48.8 mm" and pts[2]["label"] == "preload = 121.9 N"
    plots.pareto_figure([(f"box_pareto ({same} at every point)", pts, 2)], tmp_path / "pareto.png")
    fig = figures[-1]
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert sorted(texts) == sorted(p["label"] for p in pts) and not any(".yaml" in t or "pareto" in t for t in texts)
    assert text_problems(fig) == []
    varying = front([300.0, 100.0, 40.0])
    for p, d in zip(varying, (0.04, 0.05, 0.06)):
        p["design.d"] = d
    assert label_points(varying, {"preload": "force", "d": "length"}) == ""
    assert varying[1]["label"] == "preload = 100 N, d = 50 mm"


def test_resteer_ticks_are_the_ratios_asked_for(monkeypatch, tmp_path):
    """resteer.png had a stray '6×10⁻¹' tick among the requested ratios (the log scale's own minor label)."""
    figures = captured(monkeypatch, plots)
    ratios = [0.4, 0.5, 0.8, 1.0, 1.25, 2.0, 2.5]
    table = {m: {"error_pct": list(np.linspace(-30, -10, 7) * s), "mean_abs_error_pct": 20.0 * s}
             for m, s in (("ideal", 1.0), ("nominal", 0.5))}
    plots.resteer_figure(ratios, 1.0, table, tmp_path / "r.png")
    fig = figures[-1]
    fig.canvas.draw()
    ax = fig.axes[0]
    shown = [t.get_text() for t in ax.get_xticklabels(minor=False) + ax.get_xticklabels(minor=True) if t.get_text()]
    assert shown == ["0.4", "0.5", "0.8", "1", "1.25", "2", "2.5"]
    assert text_problems(fig) == []


def test_pareto_labels_keep_off_the_front_and_each_name_its_nearest_point(monkeypatch, tmp_path):
    """box_pareto's pareto.png (issue 38): along the flat end of the front the labels crowded each other, one
    nearer its neighbour's point than its own, some on the line. Now each label is nearer its own point than any
    other, keeps 4 px from every other label and covers no part of the front."""
    from cvtdesign.io.plots import points_along

    figures = captured(monkeypatch, plots)
    alpha = [1.92, 2.68, 3.45, 4.22, 4.99, 5.74, 6.5, 7.28]
    loss = [8.0, 5.03, 3.705, 3.03, 2.66, 2.45, 2.35, 2.31]
    pts = front([300.0, 179.0, 121.9, 90.18, 70.42, 56.93, 47.24, 40.0])
    for p, a, w in zip(pts, alpha, loss):
        p["worst_alpha_deg"], p["power_loss_W"] = a, w
    label_points(pts, {"preload": "force", "d": "length"})
    plots.pareto_figure([("box_kim_pareto (d = 48.8 mm at every point)", pts, 2)], tmp_path / "pareto.png")
    fig = figures[-1]
    ax = fig.axes[0]
    renderer = fig.canvas.get_renderer()
    markers = ax.transData.transform(np.column_stack([alpha, loss]))
    line = ax.transData.transform(points_along(np.column_stack([alpha, loss]), per_segment=60))
    boxes = {t.get_text(): t.get_window_extent(renderer) for t in ax.texts}
    for p in pts:
        box = boxes[p["label"]]
        gap = [np.hypot(max(box.x0 - x, 0, x - box.x1), max(box.y0 - y, 0, y - box.y1)) for x, y in markers]
        assert int(np.argmin(gap)) == p["point"], f"{p['label']} is nearer another point than its own"
        on = (line[:, 0] > box.x0) & (line[:, 0] < box.x1) & (line[:, 1] > box.y0) & (line[:, 1] < box.y1)
        assert not on.any(), f"{p['label']} covers the front"
        for q in pts:
            if q is not p:
                assert not box.expanded(1, 1).padded(4).overlaps(boxes[q["label"]]), f"{p['label']} crowds {q['label']}"
    assert text_problems(fig) == []
