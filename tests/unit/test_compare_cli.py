"""`cvtdesign compare`: the table, the JSON figures and the plot, end to end."""
import json
from pathlib import Path

import numpy as np
import pytest

from conftest import shipped_model

from cvtdesign.cli import main
from cvtdesign.core.metrics import envelope, ideal_model, metrics
from cvtdesign.core.contact.laws import EPS_RIGID
from cvtdesign.io.variant import load_variant

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


def test_single_file_outside_the_repository_still_compares_with_existing(tmp_path, monkeypatch, make_variant):
    """Run from another folder with a copy of box.yaml there: Kim's existing CVT comes from the package, not
    from a `variants/` folder beside the working directory, so its column is never silently dropped."""
    box = make_variant("box")
    monkeypatch.chdir(tmp_path)
    assert main(["compare", str(box), "--out", "plots", "--json", "f.json"]) == 0
    rows = json.loads((tmp_path / "f.json").read_text())["variants"]
    assert [r["name"] for r in rows] == ["ideal (box)", "existing", "box"]
    assert rows[1]["max_abs_alpha_deg"] == pytest.approx(10.761, abs=5e-4)


def test_roller_defaults_supply_any_roller_field(make_variant, tmp_path):
    """A roller field given once in roller_defaults means the same as on every roller that omits it: the
    drive rollers' radius and material moved there give figures identical to the file that repeats them."""
    def hoist(data):
        rollers = data["rollers"]
        data["roller_defaults"] |= {"radius": rollers["D1"]["radius"], "material": rollers["D1"]["material"]}
        for r in ("D1", "D2"):
            del rollers[r]["radius"], rollers[r]["material"]
    hoisted = make_variant("existing", hoist, file="hoisted")
    assert main(["compare", str(ROOT / "variants/existing.yaml"), str(hoisted), "--out", str(tmp_path / "p"),
                 "--json", str(tmp_path / "f.json")]) == 0
    a, b = json.loads((tmp_path / "f.json").read_text())["variants"]
    assert {k: v for k, v in a.items() if k not in ("name", "file")} == \
        {k: v for k, v in b.items() if k not in ("name", "file")}


def test_the_ideal_cvt_is_ideal_under_kalkers_law():
    """Kalker's law creeps with no effect on, so the 'ideal' column of `compare box_kalker.yaml` slipped like
    the variant (max |α| 4.185°). The ideal CVT is the layout with rigid rolling contacts, whatever its law."""
    for name in ("box_kalker", "box"):
        m = ideal_model(load_variant(ROOT / f"variants/{name}.yaml"))
        row = metrics(m, envelope(m))
        assert row["max_abs_alpha_deg"] < np.degrees(EPS_RIGID * 50) and row["min_efficiency"] > 1 - 1e-6, name
