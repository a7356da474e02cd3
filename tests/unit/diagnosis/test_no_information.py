"""Data that cannot inform a fit, and fits that end on a bound (issue 38).

`resteer` accepted rig data whose output shaft never turns (ω2 = 0 in every row), and after 74 s reported
`drive_longitudinal_creep.scale = 50 ± 4.9`, where 50 is that parameter's bound, with a table of commands
built on it. Such data are refused in one line (resteer and diagnose), and a fit that ends on a bound is
marked wherever its value is given: the text, the JSON and the report's table."""
from __future__ import annotations

import json
import types

import numpy as np
import pytest

from conftest import ROOT

from cvtdesign.cli import main
from cvtdesign.diagnosis.diagnose import fitting

EXISTING = ROOT / "variants" / "existing_kim.yaml"
PROTOCOL = "gamma: {start: -60 deg, stop: 60 deg, step: 20 deg}\nload: ['-0.8 N*m', '0 N*m', '0.8 N*m']\n"


@pytest.fixture(scope="module")
def rig_data(tmp_path_factory):
    """21 rows of the virtual rig on Kim's CVT (7 γ × 3 loads)."""
    folder = tmp_path_factory.mktemp("rig")
    (folder / "p.yaml").write_text(PROTOCOL)
    assert main(["rig", str(EXISTING), "--protocol", str(folder / "p.yaml"), "--out", str(folder / "d.csv")]) == 0
    return folder / "d.csv"


def still_output(rig_data, tmp_path):
    """The rig's rows with omega_2 = 0 in every row (an encoder not connected)."""
    lines = rig_data.read_text().splitlines()
    head = lines[0].split(",")
    k = head.index("omega_2")
    rows = [",".join("0" if j == k else v for j, v in enumerate(ln.split(","))) for ln in lines[1:]]
    f = tmp_path / "still.csv"
    f.write_text("\n".join([lines[0], *rows]) + "\n")
    return f


@pytest.mark.parametrize("command", ["resteer", "diagnose"])
def test_an_output_shaft_that_never_turns_is_refused(rig_data, tmp_path, capsys, command):
    data = still_output(rig_data, tmp_path)
    argv = {"resteer": ["resteer", str(data), "--variant", str(EXISTING), "--json", str(tmp_path / "r.json")],
            "diagnose": ["diagnose", str(data), "--variant", str(EXISTING), "--json", str(tmp_path / "r.json")]}
    assert main(argv[command]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1, err
    assert err.startswith(f"cvtdesign: error: {data}: omega_2: 0 in every row, where the ideal law has the output "
                          "shaft turn at 18 of the 21 rows"), err
    assert not (tmp_path / "r.json").exists()


def test_a_nearly_still_output_shaft_is_refused_too(rig_data, tmp_path, capsys):
    """A disconnected encoder that reads its own noise (|ω2| ≤ 0.01 rad/s, where the ideal law gives ~10)."""
    data = still_output(rig_data, tmp_path)
    lines = data.read_text().splitlines()
    k = lines[0].split(",").index("omega_2")
    noisy = [",".join(f"{0.01 * (-1) ** i:g}" if j == k else v for j, v in enumerate(ln.split(",")))
             for i, ln in enumerate(lines[1:])]
    data.write_text("\n".join([lines[0], *noisy]) + "\n")
    assert main(["diagnose", str(data), "--variant", str(EXISTING)]) == 2
    assert "omega_2: at most 0.01 rad/s in every row" in capsys.readouterr().err


def narrow_bounds(names):
    """The effects' bounds with every creep scale's upper bound at 0.8, below the rig's truth of 1."""
    lo, hi = REAL_BOUNDS(names)
    return lo, np.where([n.endswith(".scale") for n in names], 0.8, hi)


REAL_BOUNDS = fitting.bounds


def test_resteer_marks_a_fit_on_its_bound_in_text_and_json(rig_data, tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(fitting, "bounds", narrow_bounds)
    out_json = tmp_path / "r.json"
    assert main(["resteer", str(rig_data), "--variant", str(EXISTING), "--json", str(out_json)]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "drive_longitudinal_creep.scale = 0.8 ± " in out and "(AT ITS UPPER BOUND: the bound's value, not the " \
        "data's)" in out, out
    fit = json.loads(out_json.read_text())["commands"]["fit"]
    assert fit["drive_longitudinal_creep.scale"]["at_bound"] == "upper"


def test_a_fit_inside_its_bounds_is_not_marked(rig_data, tmp_path, capsys):
    out_json = tmp_path / "r.json"
    assert main(["resteer", str(rig_data), "--variant", str(EXISTING), "--json", str(out_json)]) == 0
    assert "BOUND" not in capsys.readouterr().out
    assert all(p["at_bound"] is None for p in json.loads(out_json.read_text())["commands"]["fit"].values())


def test_the_diagnosis_text_and_report_table_mark_a_bound():
    """diagnose's words (`fitted`, the rankings) and its fit table (text and HTML report alike) mark it."""
    from cvtdesign.cli.diagnosis_text import fit_blocks, fitted
    p = {"drive_longitudinal_creep.scale": {"value": 50.0, "std": 4.9, "identifiable": True, "at_bound": "upper"},
         "steering_lateral_creep.scale": {"value": 1.0, "std": 0.01, "identifiable": True, "at_bound": None}}
    assert "scale = 50 ± 4.9 (AT ITS UPPER BOUND" in fitted(p, "drive_longitudinal_creep")
    assert "BOUND" not in fitted(p, "steering_lateral_creep")
    rep = types.SimpleNamespace(base=["drive_longitudinal_creep", "steering_lateral_creep"], accepted=[],
                                base_fit=p, final_fit=dict(p))
    (table,) = fit_blocks(rep)
    rows = {r[0]: r for r in table.rows}
    assert rows["drive_longitudinal_creep.scale"][3] == "no: at its upper bound"
    assert rows["steering_lateral_creep.scale"][3] == "yes"


def test_ends_at():
    lo, hi = np.array([0.1, -1.0, 0.0]), np.array([50.0, 1.0, np.inf])
    assert fitting.ends_at(np.array([49.99, 0.0, 0.0]), lo, hi, np.ones(3)) == ["upper", None, "lower"]
    assert fitting.ends_at(np.array([0.1, 0.9, 5.0]), lo, hi, np.ones(3)) == ["lower", None, None]


def test_resteer_plots_without_truth_effects(rig_data, tmp_path, capsys, monkeypatch):
    """`resteer DATA --variant V --plots DIR` wrote nothing and said nothing without --truth-effects (the
    README promises <stem>_resteer.png); now it draws the commands' corrections, the nominal line seen beside
    the fitted one (its open squares larger than the fitted triangles)."""
    from cvtdesign.io import plots
    from figure_checks import captured
    figures = captured(monkeypatch, plots)
    assert main(["resteer", str(rig_data), "--variant", str(EXISTING), "--plots", str(tmp_path / "pl")]) == 0
    png = tmp_path / "pl" / "existing_kim_resteer.png"
    assert png.stat().st_size > 0 and f"plot: {png}" in capsys.readouterr().out
    lines = {ln.get_label(): ln for ln in figures[-1].axes[0].get_lines() if not ln.get_label().startswith("_")}
    assert list(lines) == ["ideal", "nominal", "fitted", "lookup"]
    nominal, fitted = lines["nominal"], lines["fitted"]
    assert nominal.get_marker() != fitted.get_marker() and nominal.get_markersize() > fitted.get_markersize()
    assert nominal.get_markerfacecolor() == "none"
