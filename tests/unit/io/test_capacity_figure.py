"""capacity's figure as a reader meets it (issue 38): a contact's name sits beside its curve, never on a marker or
the line, and the legend shows the envelope band in the colour it is drawn in."""
import numpy as np
from figure_checks import captured, text_problems
from matplotlib.colors import to_rgba

from cvtdesign.io import plots

GAMMAS = list(range(-80, 81, 10))
TOP = [3.63, 3.65, 3.76, 4.03, 4.2, 3.88, 3.75, 3.71, 3.73, 2.88, 2.49, 2.28, 2.19, 2.2, 2.31, 2.52, 1.64]
BOTTOM = [-1.58, -2.73, -3.5, -3.92, -3.93, -3.72, -3.63, -3.63, -3.69, -3.06, -2.52, -2.31, -2.2, -2.19, -2.28,
          -2.49, -2.88]


def record(name="existing", scale=1.0):
    """A `capacity --json` record shaped as existing's at --max-slip 90deg (contacts D2, D1, S1 on top, S2 below)."""
    top = ["D2"] * 4 + ["D1"] * 4 + ["S1"] * 8 + [None]
    bottom = [None] * 8 + ["S2"] * 9
    rows = [{"gamma_deg": float(g), "tau_perp_max_Nm": scale * hi, "tau_perp_min_Nm": scale * lo,
             "limit_max": "gross_slip" if a else "runaway", "limit_min": "gross_slip" if b else "runaway",
             "contacts_max": [a] if a else [], "contacts_min": [b] if b else [],
             "held_max_Nm": None, "held_min_Nm": None}
            for g, hi, lo, a, b in zip(GAMMAS, TOP, BOTTOM, top, bottom)]
    return {"name": name, "safety": 1.0, "max_slip_deg": None, "capacity": rows,
            "pivoting": {"points": [{"gamma_deg": 0.0}]},
            "envelope": {"gamma_deg": [-80.0, 80.0], "tau_perp_Nm": [-1.0, 1.0]}}


def drawn_points(ax, renderer):
    """Every marker and every point of the drawn lines (each segment sampled every pixel) in pixels."""
    pts = []
    for line in ax.get_lines():
        xy = ax.transData.transform(np.asarray(line.get_xydata(), float))
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        if line.get_linestyle() not in ("None", "none", "") and len(xy) > 1:
            for a, b in zip(xy[:-1], xy[1:]):
                n = int(np.hypot(*(b - a))) + 2
                pts.append(a + np.linspace(0, 1, n)[:, None] * (b - a))
        pts.append(xy)
    return np.vstack(pts)


def test_contact_labels_sit_beside_the_curve_not_on_a_marker_or_line(monkeypatch, tmp_path):
    """S2 was written on the line between the markers at γ = 40° and 50°."""
    figures = captured(monkeypatch, plots)
    plots.capacity_figure([record()], tmp_path / "c.png")
    fig = figures[-1]
    ax = fig.axes[0]
    renderer = fig.canvas.get_renderer()
    pts = drawn_points(ax, renderer)
    names = {t.get_text(): t.get_window_extent(renderer) for t in ax.texts}
    assert set(names) == {"D1", "D2", "S1", "S2"}
    for name, box in names.items():
        on = (pts[:, 0] > box.x0) & (pts[:, 0] < box.x1) & (pts[:, 1] > box.y0) & (pts[:, 1] < box.y1)
        assert not on.any(), f"{name} sits on a marker or the line"
    assert text_problems(fig) == []


def test_the_legend_shows_each_envelope_band_in_its_own_colour(monkeypatch, tmp_path):
    """The band was drawn in the variant's colour and the legend showed it grey."""
    figures = captured(monkeypatch, plots)
    for records in ([record()], [record(), record("box", 1.5)]):
        plots.capacity_figure(records, tmp_path / "c.png")
        ax = figures[-1].axes[0]
        bands = [c for c in ax.collections if len(c.get_paths()) and c.get_label().startswith("_")]
        drawn = {tuple(np.round(c.get_facecolor()[0], 3)) for c in bands}
        legend = ax.get_legend()
        shown = {tuple(np.round(to_rgba(h.get_facecolor()), 3)) for h, t in zip(legend.legend_handles, legend.texts)
                 if "envelope" in t.get_text()}
        assert len(drawn) == len(records) and shown == drawn
