"""The Python API (cvtdesign.api, docs/python-api.md): the same numbers and the same JSON as the commands, the
`--points` columns at operating points of the caller's own, tables whose intervals are the JSON's, and bad
arguments refused in one line."""
import json

import numpy as np
import pandas as pd
import pytest

from conftest import ROOT

from cvtdesign import api
from cvtdesign.cli import main
from cvtdesign.errors import InputError
from cvtdesign.io.points import COLUMNS

BOX = "variants/box_kim.yaml"


@pytest.fixture(scope="module")
def box_comparison(tmp_path_factory, monkeypatch_module):
    tmp = tmp_path_factory.mktemp("api_compare")
    assert main(["compare", BOX, "--samples", "0", "--json", str(tmp / "c.json"), "--out", str(tmp / "plots"),
                 "--points", str(tmp / "points.csv")]) == 0
    return api.compare(BOX, samples=0), tmp


@pytest.fixture(scope="module")
def monkeypatch_module():
    with pytest.MonkeyPatch.context() as mp:
        mp.chdir(ROOT)                       # the variant paths as a user in the repository writes them
        yield mp


def test_compare_gives_the_commands_json(box_comparison):
    result, tmp = box_comparison
    assert result.to_json() == (tmp / "c.json").read_text()
    assert [r["name"] for r in result.rows] == ["ideal (box_kim)", "existing_kim", "box_kim"]
    assert json.loads(result.to_json())["orderings"] == json.loads(json.dumps(result.orderings))


def test_comparison_table_holds_the_rows_figures_and_intervals(box_comparison):
    result, _ = box_comparison
    table = result.table
    assert list(table.index) == [r["name"] for r in result.rows]
    box = result.rows[-1]
    assert table.loc["box_kim", "max_abs_alpha_deg"] == box["max_abs_alpha_deg"]
    assert [table.loc["box_kim", "max_abs_alpha_deg_low"], table.loc["box_kim", "max_abs_alpha_deg_high"]] == \
        box["max_abs_alpha_deg_interval"]
    assert box["max_abs_alpha_deg_interval"][0] < box["max_abs_alpha_deg"] < box["max_abs_alpha_deg_interval"][1]
    assert "max_abs_alpha_deg_budget" in box and "max_abs_alpha_deg_budget" not in table.columns


def test_evaluate_gives_the_points_rows_of_compare(box_comparison):
    """At the envelope's own points, evaluate's rows are those `compare --points` wrote (to the CSV's 9 digits)."""
    result, tmp = box_comparison
    written = pd.read_csv(tmp / "points.csv")
    written = written[written["variant"] == "box_kim"].reset_index(drop=True)
    layout = result.layouts[-1]
    G, T = np.meshgrid(np.degrees(layout.gamma_grid), layout.load_grid, indexing="ij")
    states = api.evaluate(layout, G, T)
    assert list(states.columns) == COLUMNS and len(states) == len(written) == G.size * len(layout.rollers)
    assert (states["status"] == written["status"]).all() and (states["roller"] == written["roller"]).all()
    numbers = COLUMNS[6:]
    np.testing.assert_allclose(states[numbers].to_numpy(float), written[numbers].to_numpy(float), rtol=1e-8,
                               atol=1e-12, equal_nan=True)


def test_evaluate_sweeps_gamma_at_one_load():
    states = api.evaluate(ROOT / BOX, np.arange(-60, 61, 30), 0.5)
    layout = api.load_variant(ROOT / BOX)
    assert len(states) == 5 * len(layout.rollers)
    assert sorted(set(states["gamma_cmd_deg"])) == [-60.0, -30.0, 0.0, 30.0, 60.0]
    assert (states["tau_perp_Nm"] == 0.5).all() and (states["status"] == "ok").all()
    assert states["N_N"].gt(0).all()


@pytest.mark.parametrize("gamma, load, match", [
    (np.nan, 0.1, "gamma_deg: expected finite numbers"),
    (10.0, np.inf, "load_Nm: expected finite numbers"),
    (10.0, 1e4, "more than this variant's contacts can carry"),
])
def test_evaluate_refuses_bad_points_in_one_line(gamma, load, match):
    with pytest.raises(InputError, match=match) as e:
        api.evaluate(ROOT / BOX, gamma, load)
    assert "\n" not in str(e.value)


def test_compare_and_capacity_refuse_no_variant_and_bad_options():
    with pytest.raises(InputError, match="no variant"):
        api.compare()
    with pytest.raises(InputError, match="--samples"):
        api.compare(ROOT / BOX, samples=5)
    with pytest.raises(InputError, match="--safety"):
        api.capacity(ROOT / BOX, safety=0.5)


def test_capacity_gives_the_commands_json(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    assert main(["capacity", BOX, "--max-slip", "3deg", "--json", str(tmp_path / "cap.json")]) == 0
    result = api.capacity(BOX, max_slip=3)
    assert result.to_json() == (tmp_path / "cap.json").read_text()
    table = result.table
    record = result.rows[0]
    assert len(table) == len(record["capacity"]) and set(table["variant"]) == {"box_kim"}
    assert table["tau_perp_max_Nm"].tolist() == [r["tau_perp_max_Nm"] for r in record["capacity"]]
    assert record["max_slip_deg"] == pytest.approx(3.0)


@pytest.mark.slow
def test_plots_are_written_where_asked(box_comparison, tmp_path):
    result, _ = box_comparison
    path = result.plot(tmp_path / "figure.png")
    assert path == tmp_path / "figure.png" and path.stat().st_size > 20_000
