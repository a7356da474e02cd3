"""Optimisation: exact derivatives, an optimum known in closed form, bad study files."""
import json
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
import yaml

from cvtdesign.cli import main
from cvtdesign.model import compile_model
from cvtdesign.optimise import build_problem, constraint_report, solve_from, starts
from cvtdesign.variant import load_spec, resolve

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


def test_working_set_reaches_the_optimum_of_every_row(tmp_path):
    """IPOPT on a working set of envelope rows (violated rows added, solved again) ends where IPOPT on every
    row at once does, with every row of the whole formulation satisfied; here the traction limit binds at
    points the first working set leaves out, so it takes more than one round."""
    pr = build_problem(study(tmp_path, design={"d": {"lower": "30 mm", "upper": "110 mm"},
                                               "preload": {"lower": "50 N", "upper": "200 N"}},
                             effects=["drive_longitudinal_creep", "steering_lateral_creep", "normal_force_variation",
                                      "rolling_resistance"],
                             objective={"kind": "power_loss", "duty_cycle": [
                                 {"gamma": "30 deg", "load": "0.5 N*m", "weight": 2}, {"gamma": "-60 deg", "load": "-1 N*m"}]},
                             constraints={"traction_margin": 0.75, "clearance": "2 mm"},
                             envelope={"gamma": {"start": "-80 deg", "stop": "80 deg", "step": "20 deg"},
                                       "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "0.5 N*m"}}))
    z0 = starts(pr)[0]
    ws, full = solve_from(pr, z0), solve_from(pr, z0, method="full")
    assert ws.success and full.success and ws.rounds >= 2 and ws.points < 45
    assert ws.objective == pytest.approx(full.objective, rel=1e-7)
    np.testing.assert_allclose(ws.z, full.z, atol=1e-6)
    g = np.asarray(pr.evaluate(np.asarray(ws.z))[1]).ravel()
    np.testing.assert_allclose(g, ws.g)
    tol = 1e-8 * np.maximum(1, np.minimum(np.abs(pr.g_lb), np.abs(pr.g_ub)))
    assert np.all(g <= pr.g_ub + tol) and np.all(g >= pr.g_lb - tol)
    report = {r["name"]: r for r in constraint_report(pr, ws)}
    assert report["traction"]["active"] and report["traction"]["multiplier"] > 0


def test_constraint_labels_name_their_roller_and_point(tmp_path):
    """Each row's label names the roller and operating point whose value it holds (checked against a direct
    evaluation of the model at the same design)."""
    pr = build_problem(study(tmp_path, envelope={"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "30 deg"},
                                                 "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}}))
    z = np.array([0.3])
    g = np.asarray(pr.evaluate(np.append(z, 0.0))[1]).ravel()
    d = pr.lower[0] + (pr.upper[0] - pr.lower[0]) * z[0]
    box = ROOT / "variants/box.yaml"
    m = compile_model(resolve(load_spec(box), str(box), overrides={"d": d}))
    for fam, key, scale in (("traction", "utilisation", 1.0), ("hertz_pressure", "p_max", 6e6)):
        rows = [i for i, f in enumerate(pr.g_family) if f == fam]
        assert len(rows) == 8 * 15
        for i in rows[::7]:
            lab = pr.g_labels[i]
            roller = lab.split(" of ")[1].split(" at ")[0]
            gam, load = lab.split("γ=")[1].split("° τ⊥=")
            res = m.evaluate(np.radians(float(gam)), float(load))
            assert g[i] == pytest.approx(float(res[key][m.roller_names.index(roller)]) / scale, rel=1e-9), lab


def test_design_variable_free_in_some_variants_only(tmp_path, capsys):
    """A design variable with `variants` is free only in those variant files; the others optimise without it."""
    path = study(tmp_path, design={"r_steer": {"lower": "20 mm", "upper": "60 mm"},
                                   "d": {"lower": "30 mm", "upper": "110 mm", "variants": [str(ROOT / "variants/box.yaml")]}},
                 batch={"variants": [str(ROOT / "variants/existing.yaml"), str(ROOT / "variants/box.yaml")]},
                 envelope={"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                           "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "2 N*m"}})
    from cvtdesign.optimise import load_study
    spec, _ = load_study(path)
    assert build_problem(path, spec, ROOT / "variants/existing.yaml").names == ["r_steer"]
    assert sorted(build_problem(path, spec, ROOT / "variants/box.yaml").names) == ["d", "r_steer"]
    data = yaml.safe_load(path.read_text())
    data["design"]["d"]["variants"] = ["bx.yaml"]
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    assert main(["optimise", str(path)]) == 2
    assert "design.d.variants: no variant file" in capsys.readouterr().err


def test_written_variant_carries_sweep_parameters_and_study_envelope(tmp_path):
    """A sweep case's optimum is written with its fixed parameters and the envelope it was optimised over,
    so the variant file reproduces the optimum (it kept the base's r_steer and envelope before)."""
    from cvtdesign.optimise import load_study, write_variant
    from cvtdesign.variant import load_variant

    env = {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "30 deg"},
           "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}}
    path = study(tmp_path, constraints={"clearance": "2 mm"}, envelope=env)
    spec, base = load_study(path)
    pr = build_problem(path, spec, base, {"r_steer": 0.030})
    sol = solve_from(pr, starts(pr)[0])
    assert sol.success
    L = load_variant(write_variant(pr, sol, tmp_path, "swept"))
    steer = [r for r in L.rollers if r.role == "steering"]
    assert all(abs(r.radius - 0.030) < 1e-9 for r in steer)
    np.testing.assert_allclose(np.degrees(L.gamma_grid), [-60, -30, 0, 30, 60], atol=1e-12)
    m = compile_model(L)
    G, T = np.meshgrid(L.gamma_grid, L.load_grid, indexing="ij")
    assert np.degrees(np.nanmax(np.abs(m.evaluate(G, T)["alpha"]))) == pytest.approx(sol.objective, rel=1e-5)
