"""Optimisation: exact derivatives, an optimum known in closed form, bad study files."""
import json
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
import yaml

from cvtdesign.cli import main
from cvtdesign.optimise import build_problem, solve_from, starts

ROOT = Path(__file__).resolve().parents[2]


def study(tmp_path, **fields):
    data = {"name": "t", "base": str(ROOT / "variants/box.yaml"), "design": {"d": {"lower": "30 mm", "upper": "110 mm"}},
            "multistart": {"starts": 1}}
    data.update(fields)
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


def test_gradients_match_finite_differences(tmp_path):
    """d(objective, constraints)/d(design) through the Newton solves (implicit function theorem) vs central
    differences of the same functions."""
    pr = build_problem(study(tmp_path, design={"d": {"lower": "30 mm", "upper": "110 mm"},
                                               "r_drive": {"lower": "20 mm", "upper": "60 mm"},
                                               "preload": {"lower": "50 N", "upper": "200 N"}},
                             effects=["drive_longitudinal_creep", "steering_lateral_creep", "normal_force_variation",
                                      "rolling_resistance"], objective={"kind": "power_loss"}))
    x0 = np.array([0.35, 0.5, 0.3])
    jac = pr.evaluate.factory("J", ["i0"], ["jac:o0:i0", "jac:o1:i0"])
    Jf, Jg = (np.asarray(a) for a in jac(x0))
    h = 1e-5   # the Newton solves are converged to ~1e-10, so differences carry ~1e-5 of noise at this step
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        fp, gp = (np.asarray(a).ravel() for a in pr.evaluate(x0 + e))
        fm, gm = (np.asarray(a).ravel() for a in pr.evaluate(x0 - e))
        np.testing.assert_allclose(Jf[0, k], (fp - fm)[0] / (2 * h), rtol=1e-5)
        fd = (gp - gm) / (2 * h)
        np.testing.assert_allclose(Jg[:, k], fd, rtol=1e-4, atol=2e-5)
        big = np.abs(Jg[:, k]) > 1e-2
        assert big.sum() > 100 and np.max(np.abs(Jg[big, k] / fd[big] - 1)) < 1e-3


def test_steering_pair_moves_to_the_largest_moment_arm(tmp_path):
    """Kim sec. 5.1: the pole rollers' lateral forces have their largest moment about the centre when the pair
    sits at the pole; the tandem pair can only come as close as the clearance lets it: centre distance
    2 (R + r_s) sin θ = 2 r_s + c, i.e. d = 2 R sin θ = R (2 r_s + c)/(R + r_s) = 48.80 mm."""
    pr = build_problem(study(tmp_path, constraints={"clearance": "2 mm", "traction_margin": None,
                                                    "hertz_pressure": False}))
    sol = solve_from(pr, starts(pr)[0])
    R, rs, c = 0.0635, 0.038, 0.002
    assert sol.success
    assert sol.design["d"] == pytest.approx(R * (2 * rs + c) / (R + rs), rel=1e-4)


def test_optimise_cli_improves_box(tmp_path):
    path = study(tmp_path, constraints={"clearance": "2 mm", "envelope_radius": "143.5 mm"},
                 design={"d": {"lower": "30 mm", "upper": "110 mm"}, "r_steer": {"lower": "20 mm", "upper": "60 mm"}})
    assert main(["optimise", str(path), "--out", str(tmp_path / "res"), "--json", str(tmp_path / "o.json"), "--step"]) == 0
    res = json.loads((tmp_path / "o.json").read_text())
    # --step: the optimum's assembly for mechanical review, next to its variant file
    name = Path(res["variant_file"]).stem
    step = Path(res["variant_file"]).parent / "step" / f"{name}.step"
    assert step.stat().st_size > 10_000 and (step.parent / f"{name}.svg").exists()
    assert res["status"] == "Solve_Succeeded"
    assert res["objective"] < 4.166 - 0.3                       # variants/box.yaml: max |α| = 4.166°
    assert {"worst_alpha", "clearance"} <= set(res["active_constraints"])
    assert main(["compare", res["variant_file"], "--out", str(tmp_path / "c"), "--json", str(tmp_path / "c.json")]) == 0
    rows = json.loads((tmp_path / "c.json").read_text())["variants"]
    assert rows[-1]["max_abs_alpha_deg"] == pytest.approx(res["objective"], rel=1e-6)
    assert Path(res["variant_file"]).read_text().startswith("# Optimised by `cvtdesign optimise")


@pytest.mark.parametrize("fields, message", [
    ({"design": {"d": {"lower": "90 mm", "upper": "40 mm"}}}, "design.d: inverted bounds"),
    ({"design": {"r_driv": {"lower": "20 mm", "upper": "40 mm"}}}, "has no parameter 'r_driv' (did you mean 'r_drive'?)"),
    ({"objectiv": {"kind": "worst_alpha"}}, "objectiv: unknown field (did you mean 'objective'?)"),
    ({"base": "nowhere.yaml"}, "base: no variant file 'nowhere.yaml'"),
])
def test_bad_study(tmp_path, capsys, fields, message):
    assert main(["optimise", str(study(tmp_path, **fields))]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
