"""`cvtdesign compare`: the table, the JSON figures and the plot, end to end."""
import json
from pathlib import Path

import numpy as np
import pytest

from conftest import shipped_model

from cvtdesign.cli import main
from cvtdesign.core.model import EPS_RIGID

ROOT = Path(__file__).resolve().parents[2]
KEYS = {"name", "file", "max_abs_alpha_deg", "rms_alpha_deg", "max_abs_alpha_steering_deg",
        "max_abs_alpha_drive_deg", "ratio_error_pct_at_max_load", "min_efficiency",
        "max_traction_utilisation", "max_hertz_pressure_MPa"}


@pytest.fixture(scope="module")
def box_vs_existing(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("compare")
    code = main(["compare", str(ROOT / "variants/box.yaml"), "--out", str(tmp / "plots"), "--json", str(tmp / "f.json")])
    return code, tmp


def test_single_file_compares_with_ideal_and_existing(box_vs_existing, monkeypatch):
    code, tmp = box_vs_existing
    assert code == 0
    rows = json.loads((tmp / "f.json").read_text())["variants"]
    assert [r["name"] for r in rows] == ["ideal (box)", "existing", "box"]
    for r in rows:
        assert KEYS <= set(r)
    ideal, existing, box = rows
    # the ideal CVT slips only by the model's rigid-direction floor: α ≲ EPS_RIGID · F with F < 50 N
    assert ideal["max_abs_alpha_deg"] < np.degrees(EPS_RIGID * 50) and ideal["min_efficiency"] > 1 - 1e-6
    # Kim sec. 5.1: the box CVT slips less in both parts
    assert box["max_abs_alpha_drive_deg"] < 0.6 * existing["max_abs_alpha_drive_deg"]
    assert box["max_abs_alpha_steering_deg"] < 0.5 * existing["max_abs_alpha_steering_deg"]
    assert box["min_efficiency"] > existing["min_efficiency"]


def test_plot_written(box_vs_existing):
    _, tmp = box_vs_existing
    png = tmp / "plots" / "compare.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    assert [p.name for p in (tmp / "plots").iterdir()] == ["compare.png"]   # no temporary files left


def test_three_variants_side_by_side(tmp_path, capsys):
    files = [str(ROOT / f"variants/{n}.yaml") for n in ("existing", "box", "unequal")]
    assert main(["compare", *files, "--out", str(tmp_path), "--json", str(tmp_path / "f.json")]) == 0
    rows = json.loads((tmp_path / "f.json").read_text())["variants"]
    assert [r["name"] for r in rows] == ["existing", "box", "unequal"]
    # each figure is its own variant's: max |α| over the envelope, re-evaluated here from the compiled model
    for r in rows:
        m = shipped_model(r["name"])
        G, T = np.meshgrid(m.layout.gamma_grid, m.layout.load_grid, indexing="ij")
        assert r["max_abs_alpha_deg"] == pytest.approx(np.degrees(np.nanmax(np.abs(m.evaluate(G, T)["alpha"]))),
                                                       rel=1e-9), r["name"]
    table = capsys.readouterr().out
    assert "max |α| [°]" in table and "unequal" in table
