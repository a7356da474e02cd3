"""The compare figure (io.plots.compare_figure) on two small envelopes: one y-scale per row of panels that holds
every variant's curves and the ideal CVT's reference, one colour scale for the efficiency maps, flagged points
marked; drawn by the plotting process (io.plots.Background), which never leaves a half-written file."""
import time
from dataclasses import replace

import numpy as np
import pytest

from conftest import ROOT

from cvtdesign.core.metrics import envelope
from cvtdesign.core.model import compile_model
from cvtdesign.io.plots import Background, compare_figure
from cvtdesign.io.plots.compare import COMPARE_ROWS
from cvtdesign.io.variant import load_variant

LOADS = (-1.0, -0.5, 0.5, 1.0)
PNG = b"\x89PNG\r\n\x1a\n"


def coarse(name):
    """The shipped variant's envelope on a coarse grid: γ −80..80° by 20°, τ⊥ −1..1 N·m by 0.5."""
    layout = replace(load_variant(ROOT / f"variants/{name}.yaml"), gamma_grid=np.radians(np.arange(-80.0, 81.0, 20.0)),
                     load_grid=np.array([-1.0, -0.5, 0.0, 0.5, 1.0]))
    return name, envelope(compile_model(layout))


@pytest.fixture(scope="module")
def results():
    return [coarse("existing_kim"), coarse("box_kim")]


def drawn(res, key, conv):
    """The values the line panels draw: the quantity at the grid loads nearest LOADS (here exactly those)."""
    cols = [int(np.argmin(np.abs(res["load"][0] - L))) for L in LOADS]
    return conv(res[key][:, cols])


def test_rows_share_one_y_scale_holding_every_variant(results, tmp_path):
    path = tmp_path / "compare.png"
    limits = compare_figure(results, path, LOADS)
    assert path.read_bytes()[:8] == PNG and path.stat().st_size > 20_000
    assert set(limits["ylim"]) == {"alpha", "alpha_steering", "alpha_drive", "efficiency"}
    for key, label, conv in COMPARE_ROWS:
        panels = limits["ylim"][key]
        assert len(panels) == 2 and all(p == panels[0] for p in panels), f"{key}: panels on different y-scales"
        lo, hi = panels[0]
        reference = 1.0 if key == "efficiency" else 0.0       # the ideal CVT
        assert lo < reference < hi
        for name, res in results:
            v = drawn(res, key, conv)
            assert lo <= np.nanmin(v) and np.nanmax(v) <= hi, f"{key}: {name} outside the row's y-scale"
    # the point of one scale: Kim's existing CVT slips more than twice as much as the box CVT (Kim sec. 5.1),
    # and its largest |α| nearly fills the row's scale
    (_, existing), (_, box) = results
    a_existing, a_box = (np.nanmax(np.abs(drawn(r, "alpha", np.degrees))) for r in (existing, box))
    assert 9.0 < a_existing < 12.0 and a_box < 0.5 * a_existing
    assert a_existing > 0.8 * max(abs(x) for x in limits["ylim"]["alpha"][0])


def test_efficiency_maps_share_one_colour_scale(results, tmp_path):
    limits = compare_figure(results, tmp_path / "compare.png", LOADS)
    lo, hi = limits["clim"]
    assert hi == 1.0                                     # the ideal CVT's efficiency
    for _, res in results:
        eff = res["efficiency"]
        assert np.isnan(eff[:, 2]).all()                 # τ⊥ = 0: no power in, drawn hatched (not blank)
        assert lo <= np.nanmin(eff) and np.nanmax(eff) <= hi
    assert lo == 0.0                                     # at γ = 0 no power leaves: efficiency 0


def test_flagged_points_stay_marked(results, tmp_path):
    name, res = results[0]
    res = {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in res.items()}
    res["status"][1, 0], res["status"][3, 4], res["status"][5, 1] = 3, 2, 1   # gross slip, lost contact, not converged
    for k in ("alpha", "alpha_steering", "alpha_drive", "efficiency"):
        for i, j in ((1, 0), (3, 4), (5, 1)):
            res[k][i, j] = np.nan
    path = tmp_path / "flagged.png"
    limits = compare_figure([(name, res), results[1]], path, LOADS)
    assert path.read_bytes()[:8] == PNG
    assert limits["marked"] == [3, 0]


@pytest.mark.parametrize("delay", [0.0, 0.2, 0.6])
def test_closing_the_plotting_process_leaves_no_half_written_file(results, tmp_path, delay):
    """The parent fails while the plotting process draws and closes it (Background.close) at some moment
    of the drawing: the figure is then either whole or absent, and no temporary file is left behind."""
    painter = Background()
    painter.draw(compare_figure, results, tmp_path / "compare.png")
    time.sleep(delay)
    painter.close()
    assert not painter.proc.is_alive()
    files = [p.name for p in tmp_path.iterdir()]
    assert files in ([], ["compare.png"]), files
    if files:
        data = (tmp_path / "compare.png").read_bytes()
        assert data[:8] == PNG and data[-8:-4] == b"IEND"


# ------------------------------------------------------------------ a figure that scales (issue 28)

from figure_checks import captured, text_problems  # noqa: E402

from cvtdesign.cli import main  # noqa: E402
from cvtdesign.io import plots  # noqa: E402


@pytest.fixture(scope="module")
def five(results):
    return results + [coarse(n) for n in ("unequal_kim", "box", "existing")]


def legend_colours(fig) -> dict:
    """{label: colour} of the figure's legend entries drawn as lines."""
    from matplotlib.colors import to_hex
    return {h.get_label(): to_hex(h.get_color()) for h in fig.legends[0].legend_handles if hasattr(h, "get_color")}


@pytest.mark.slow
@pytest.mark.parametrize("count", [2, 3, 5])
def test_legend_and_labels_inside_the_canvas(five, count, monkeypatch, tmp_path):
    """With 3 or more variants the legend ran off both edges. Now it takes as many columns as fit, the
    panels start below it, and no text is cut or overlaps another."""
    figures = captured(monkeypatch, plots)
    compare_figure(five[:count], tmp_path / "c.png", LOADS)
    assert text_problems(figures[-1]) == []


@pytest.mark.slow
def test_beyond_three_variants_each_gets_its_column(five, monkeypatch, tmp_path):
    """Five variants overlaid made 20 curves a panel. Beyond OVERLAY_MAX each variant has a column of its
    own (its four loads only), every row still on one y-scale; beyond PANELS_MAX the figure draws existing
    and the variants of smallest worst |α|, and says the table has the rest."""
    figures = captured(monkeypatch, plots)
    limits = compare_figure(five, tmp_path / "c.png", LOADS)
    assert limits["shown"] == [n for n, _ in five]
    for key, _, _ in COMPARE_ROWS:
        assert len(limits["ylim"][key]) == 5 and len(set(limits["ylim"][key])) == 1
    panel = next(ax for ax in figures[-1].axes if ax.get_title() == "box_kim")
    assert len([line for line in panel.get_lines() if len(line.get_xdata()) > 2]) == len(LOADS)
    eight = five + [(f"copy_{n}", r) for n, r in five[:3]]        # copies of existing, box, unequal
    limits = compare_figure(eight, tmp_path / "c8.png", LOADS)
    worst = {n: np.nanmax(np.abs(r["alpha"][r["status"] == 0])) for n, r in eight}
    assert len(limits["shown"]) == plots.PANELS_MAX and "existing_kim" in limits["shown"]
    left = set(worst) - set(limits["shown"])
    assert min(worst[n] for n in left) >= max(worst[n] for n in limits["shown"] if n != "existing_kim")
    assert "6 of 8 variants drawn" in figures[-1]._suptitle.get_text()
    assert text_problems(figures[-1]) == []


def test_colours_do_not_depend_on_the_order():
    names = ["unequal_kim", "box_kim", "existing_kim", "box", "existing"]
    colours = plots.variant_colours(names)
    assert colours == plots.variant_colours(reversed(names)) == plots.variant_colours(names[:2] + ["existing_kim"])\
        | {n: colours[n] for n in names[3:]}
    assert colours["existing_kim"] == colours["existing"] == plots.EXISTING_COLOUR     # one machine, either law
    assert len(set(colours.values())) == len(names) - 1
    assert plots.IDEAL_COLOUR not in colours.values()


class InlinePainter:
    """The plotting process's part done in this process, so that a test sees the figure."""

    def draw(self, figure, *args):
        self.limits = figure(*args)

    def wait(self):
        return None

    def close(self):
        pass


@pytest.mark.slow
def test_two_runs_in_another_order_give_each_variant_its_colour(monkeypatch, tmp_path, capsys):
    """existing was blue, then green, then orange, by its place on the command line. Two runs of compare
    with the variants in another order draw each in the same colour (existing's always), write one figure
    named after the set (not compare.png, which every run overwrote), and say that the second replaced it."""
    monkeypatch.setattr(plots, "Background", InlinePainter)
    figures = captured(monkeypatch, plots)
    files = [str(ROOT / f"variants/{n}.yaml") for n in ("unequal_kim", "existing_kim", "box_kim")]
    runs = []
    for order in (files, files[::-1]):
        assert main(["compare", *order, "--out", str(tmp_path)]) == 0
        runs.append(legend_colours(figures[-1]))
    assert runs[0] == runs[1] and runs[0]["existing_kim"] == plots.EXISTING_COLOUR
    assert runs[0]["ideal CVT (α = 0, efficiency 1)"] == plots.IDEAL_COLOUR
    assert len({runs[0][n] for n in ("unequal_kim", "existing_kim", "box_kim")}) == 3
    assert [p.name for p in tmp_path.iterdir()] == ["box_kim+existing_kim+unequal_kim.png"]
    out = capsys.readouterr().out
    assert out.count("(replaced the earlier figure of these variants)") == 1
