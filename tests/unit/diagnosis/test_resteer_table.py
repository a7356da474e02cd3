"""`cvtdesign resteer VARIANT.yaml --table FILE.csv`: the controller table (diagnosis.resteer.command_table) on
Kim's existing CVT: its CSV format, every number in it re-evaluated on the model, the nodes without a
command marked and empty, and the controller-loop example of docs/diagnosis.md run on a written table."""
from __future__ import annotations

import re
import shlex

import numpy as np
import pandas as pd
import pytest

from conftest import ROOT, shipped_model, variant_path

from cvtdesign.diagnosis import resteer

EXISTING = variant_path("existing_kim")


def read_table(path) -> pd.DataFrame:
    frame = pd.read_csv(path)
    assert tuple(frame.columns) == resteer.TABLE_COLUMNS
    return frame


def model_ratio(gamma_deg, tau):
    return resteer.ratio(shipped_model("existing_kim"), np.radians(gamma_deg), np.asarray(tau, float))


def test_table_rows_and_every_number_on_the_model(cli, tmp_path):
    """Ratios in the outer order, loads in the inner; γ_ideal = atan(ratio) (Kim eq 8, equal radii); the model
    at γ_cmd gives the ratio (residual below 1e-9, as written); the ideal error is the model's ratio at
    γ_ideal minus the ratio, zero without load; the command turns against the load's slip."""
    out = tmp_path / "t.csv"
    rc, stdout, err = cli("resteer", EXISTING, "--table", out, "--table-ratios", "0.5:2:4", "--table-loads", "-1:1:3")
    assert rc == 0 and err == "", err
    t = read_table(out)
    np.testing.assert_allclose(t["ratio"], np.repeat([0.5, 1.0, 1.5, 2.0], 3))
    np.testing.assert_allclose(t["tau_perp_Nm"], np.tile([-1.0, 0.0, 1.0], 4))
    assert set(t["status"]) == {"ok"}
    np.testing.assert_allclose(t["gamma_ideal_deg"], np.degrees(np.arctan(t["ratio"])), atol=1e-8)
    achieved = model_ratio(t["gamma_cmd_deg"], t["tau_perp_Nm"])
    assert np.max(np.abs(achieved - t["ratio"])) < 1e-9 and np.max(np.abs(t["residual_ratio_error"])) < 1e-9
    at_ideal = model_ratio(t["gamma_ideal_deg"], t["tau_perp_Nm"])
    np.testing.assert_allclose(t["ideal_ratio_error"], at_ideal - t["ratio"], rtol=1e-8, atol=1e-9)  # γ to 10 digits
    unloaded = t["tau_perp_Nm"] == 0
    assert np.max(np.abs(t["ideal_ratio_error"][unloaded])) < 1e-6
    assert np.all(np.abs(t["ideal_ratio_error"][~unloaded]) > 0.01)
    shift = (t["gamma_cmd_deg"] - t["gamma_ideal_deg"])[~unloaded]
    assert np.all(np.sign(shift) == -np.sign(t["tau_perp_Nm"][~unloaded]))
    assert "controller table: γ_cmd from the nominal model for 4 ratios" in " ".join(stdout.split())


def test_a_node_without_a_command_is_marked_and_empty(cli, tmp_path):
    """5.6 needs γ past the envelope's 80° under −1 N·m (test_commands): no command, an empty field, status
    'unreachable', counted in the summary; the other nodes keep theirs."""
    out = tmp_path / "t.csv"
    rc, stdout, err = cli("resteer", "--variant", EXISTING, "--table", out, "--table-ratios", "1,5.6",
                          "--table-loads=-1,0,1")
    assert rc == 0 and err == "", err
    text = out.read_text().splitlines()
    t = read_table(out)
    bad = (t["ratio"] == 5.6) & (t["tau_perp_Nm"] == -1)
    assert list(t["status"][bad]) == ["unreachable"] and set(t["status"][~bad]) == {"ok"}
    assert t["gamma_cmd_deg"][bad].isna().all() and t["residual_ratio_error"][bad].isna().all()
    assert text[4].split(",")[2] == "" and text[4].endswith(",unreachable")
    assert t["gamma_cmd_deg"][~bad].notna().all()
    assert "no command at 1 of 6 nodes (unreachable" in " ".join(stdout.split())


def test_no_solution_where_the_model_slips_grossly():
    """Under 3 N·m Kim's CVT slips grossly near ratio 1 (its capacity there is 1.9 N·m): no command, and the
    reason is the model's, not the envelope's."""
    g, why = resteer.model_commands(shipped_model("existing_kim"), [1.0, 1.0], [0.5, 3.0])
    assert np.isfinite(g[0]) and np.isnan(g[1]) and list(why) == ["ok", "no_solution"]


def test_interpolating_a_finer_table_leaves_less():
    """interpolation_error at the cells' centres: the worst is re-evaluated there by hand, and halving the
    ratio step lowers it."""
    m = shipped_model("existing_kim")
    errors = []
    for count in (5, 9):
        table = resteer.command_table(m, np.linspace(0.5, 2.5, count), [-1.0, 0.0, 1.0])
        between = resteer.interpolation_error(m, table)
        cmd = table["gamma_cmd"]
        i = int(np.argmin(np.abs(table["ratio"][:-1, 0] + table["ratio"][1:, 0] - 2 * between["ratio"])))
        j = int(np.argmin(np.abs(table["tau_perp"][0, :-1] + table["tau_perp"][0, 1:] - 2 * between["tau_perp"])))
        centre = cmd[i:i + 2, j:j + 2].mean()
        hand = resteer.ratio(m, centre, between["tau_perp"])[0] - between["ratio"]
        np.testing.assert_allclose(abs(hand), between["max_abs"], rtol=1e-9)
        assert between["cells"] == 2 * (count - 1)
        errors.append(between["max_abs"])
    assert errors[1] < 0.5 * errors[0]


@pytest.mark.slow
def test_controller_loop_example_in_the_docs_runs(cli, tmp_path, monkeypatch):
    """The example of docs/diagnosis.md, on the table its command line writes: the interpolated command for
    ratio 1.2 under 0.35 N·m gives that ratio on the model to the interpolation's 1e-3."""
    docs = (ROOT / "docs" / "diagnosis.md").read_text()
    command = re.search(r"cvtdesign resteer variants/existing\.yaml --table (\S+) \\\n\s+(.*)\n", docs)
    example = docs.split("<!-- controller-loop example")[1].split("```python\n")[1].split("```")[0]
    monkeypatch.chdir(tmp_path)
    (tmp_path / "results").mkdir()
    rc, _, err = cli("resteer", EXISTING, "--table", command.group(1), *shlex.split(command.group(2)))
    assert rc == 0 and err == "", err
    scope = {}
    exec(compile(example, "docs/diagnosis.md", "exec"), scope)
    gamma = scope["gamma"]
    assert gamma is not None and abs(model_ratio(gamma, 0.35)[0] - 1.2) < 1e-3
    assert scope["steering_command"](9.0, 0.0) is None                   # off the table: None, not a number



@pytest.mark.slow
def test_table_from_measured_data_uses_the_fitted_model(cli, tmp_path):
    """`resteer DATA.csv --variant V --table`: the commands of the model fitted to the rig's data (Kim's own
    effects, so the fitted scales are 1 within their σ and the commands within 0.01° of the nominal ones, but
    not the nominal ones), with the fitted parameters printed."""
    data = tmp_path / "rig.csv"
    assert cli("rig", EXISTING, "--out", data, "--seed", "1")[0] == 0
    grid = ("--table-ratios", "0.5,1,2", "--table-loads=-1,1")
    rc, out, err = cli("resteer", data, "--variant", EXISTING, "--table", tmp_path / "fit.csv", *grid)
    assert rc == 0 and err == "", err
    assert "from the fitted model" in out and "fitted: drive_longitudinal_creep.scale = " in " ".join(out.split())
    assert cli("resteer", EXISTING, "--table", tmp_path / "nominal.csv", *grid)[0] == 0
    shift = read_table(tmp_path / "fit.csv")["gamma_cmd_deg"] - read_table(tmp_path / "nominal.csv")["gamma_cmd_deg"]
    assert 1e-6 < np.max(np.abs(shift)) < 0.01
