"""Robust design (design.robust): a study's `robust: {over: calibration, confidence}` minimises the worst
|α| over the corners of the calibration's confidence region, with every constraint held at each corner."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from conftest import ROOT

from cvtdesign.design.problem import build_problem
from cvtdesign.design.study_file import load_study


def study(folder: Path, worst_case=True, **extra) -> Path:
    data = {"name": "r", "base": str(ROOT / "variants/box.yaml"),
            "design": {"d": {"lower": "40 mm", "upper": "100 mm"}},
            "constraints": {"clearance": "2 mm", "traction_margin": 0.2},
            "envelope": {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                         "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}},
            "multistart": {"starts": 1, "seed": 1}}
    if worst_case:
        data["robust"] = {"over": "calibration", "confidence": 0.95}
    data.update(extra)
    path = folder / ("robust.yaml" if worst_case else "nominal.yaml")
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


@pytest.mark.slow
def test_the_corners_are_the_calibrations_95_percent_box(tmp_path):
    """box's drive (82A, σ 1.3 %) and steering (84A, σ 1.0 %) calibrations are independent: 4 corners at
    ±2.236σ (a box of joint probability 0.95), each the whole envelope, and the misfit rows once per γ."""
    path = study(tmp_path)
    p = build_problem(load_study(path))
    nlp = p.parts.nlp
    assert nlp.scenarios == ["drive ×0.971, steering ×0.978", "drive ×1.029, steering ×0.978",
                             "drive ×0.971, steering ×1.022", "drive ×1.029, steering ×1.022"]
    names = nlp.model.param_names
    d, s = names.index("drive_longitudinal_creep.scale"), names.index("steering_lateral_creep.scale")
    corners = np.unique(p.parts.theta_pts[[d, s]].T, axis=0)
    assert corners == pytest.approx(1 + 2.2414 * np.array([[-0.013, -0.01], [-0.013, 0.01], [0.013, -0.01],
                                                          [0.013, 0.01]]), abs=2e-4)
    assert p.parts.gamma.size == 4 * 9 and sum(f == "reach_gamma" for f in p.g_family) in (0, 3)


@pytest.mark.slow
def test_the_robust_optimum_holds_over_the_region(tmp_path, cli):
    """The robust optimum's worst |α| over the corners is its objective, at least its nominal worst |α|, and no
    more than the nominal optimum's own worst over the corners (measured: the same design, 1e-9 mm apart:
    α scales with the compliance, and clearance fixes d)."""
    code, _, err = cli("optimise", study(tmp_path), "--out", tmp_path / "o", "--json", tmp_path / "r.json")
    assert code == 0, err
    r = json.loads((tmp_path / "r.json").read_text())["details"]
    code, _, err = cli("optimise", study(tmp_path, worst_case=False), "--out", tmp_path / "o", "--json",
                       tmp_path / "n.json")
    n = json.loads((tmp_path / "n.json").read_text())["details"]
    rob = r["robust"]
    assert rob["worst_alpha_deg"] == r["objective"] > rob["nominal_worst_alpha_deg"]
    assert rob["nominal_worst_alpha_deg"] == pytest.approx(n["objective"], rel=1e-6)
    p = build_problem(load_study(tmp_path / "robust.yaml"))
    z = (np.array([n["design"][k] for k in p.names]) - p.lower) / (p.upper - p.lower)
    assert r["objective"] <= float(p.start_t(z)) + 1e-6


@pytest.mark.parametrize("edit, message", [
    ({"objective": {"kind": "rms_alpha"}}, "robust: the worst case over the region is built for objective kind"),
    ({"robust": {"over": "calibration", "confidence": 1.2}}, "robust.confidence: expected a probability"),
    ({"base": str(ROOT / "variants/existing_kim.yaml").replace("existing_kim", "box_kim"),
      "robust": {"over": "tolerances"}}, "robust.over"),
])
def test_bad_robust_settings_are_one_line(tmp_path, cli, edit, message):
    path = study(tmp_path, **edit)
    code, out, err = cli("optimise", path, "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1 and message in err and not (tmp_path / "o").exists()


@pytest.mark.slow
def test_robust_needs_a_stated_uncertainty(tmp_path, cli):
    """A base variant whose compliance has no σ (THEORY ONLY here: kalker factors of 1) is refused in one line."""
    v = yaml.safe_load((ROOT / "variants/box.yaml").read_text())
    v["contact"] = {"law": "kalker", "calibration": {"drive": 1, "steering": 1}}
    (tmp_path / "theory.yaml").write_text(yaml.safe_dump(v, allow_unicode=True))
    code, out, err = cli("optimise", study(tmp_path, base=str(tmp_path / "theory.yaml")), "--out", tmp_path / "o")
    assert code == 2 and err.count("\n") == 1 and "robust: over calibration: the base variant's creep compliance" in err
