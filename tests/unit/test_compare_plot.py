"""The compare figure (io.plots.compare_figure) on two small envelopes: one y-scale per row of panels that holds
every variant's curves and the ideal CVT's reference, one colour scale for the efficiency maps, flagged points
marked; drawn by the plotting process (io.plots.Background), which never leaves a half-written file."""
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from cvtdesign.core.metrics import envelope
from cvtdesign.core.model import compile_model
from cvtdesign.io.plots import COMPARE_ROWS, Background, compare_figure
from cvtdesign.io.variant import load_variant

ROOT = Path(__file__).resolve().parents[2]
LOADS = (-1.0, -0.5, 0.5, 1.0)
PNG = b"\x89PNG\r\n\x1a\n"


def coarse(name):
    """The shipped variant's envelope on a coarse grid: γ −80..80° by 20°, τ⊥ −1..1 N·m by 0.5."""
    layout = replace(load_variant(ROOT / f"variants/{name}.yaml"), gamma_grid=np.radians(np.arange(-80.0, 81.0, 20.0)),
                     load_grid=np.array([-1.0, -0.5, 0.0, 0.5, 1.0]))
    return name, envelope(compile_model(layout))


@pytest.fixture(scope="module")
def results():
    return [coarse("existing"), coarse("box")]


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
    painter.draw("compare_figure", results, tmp_path / "compare.png")
    time.sleep(delay)
    painter.close()
    assert not painter.proc.is_alive()
    files = [p.name for p in tmp_path.iterdir()]
    assert files in ([], ["compare.png"]), files
    if files:
        data = (tmp_path / "compare.png").read_bytes()
        assert data[:8] == PNG and data[-8:-4] == b"IEND"
