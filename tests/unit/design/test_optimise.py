"""Optimisation: exact derivatives, an optimum known in closed form, bad study files."""
import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from conftest import ROOT

from cvtdesign.cli import main
from cvtdesign.core.model import compile_model
from cvtdesign.core.status import STATUS
from cvtdesign.design.problem import build_problem
from cvtdesign.design.report import constraint_report
from cvtdesign.design.solution import check_envelope
from cvtdesign.design.solve import solve_from, starts
from cvtdesign.design.study_file import Study, load_study
from cvtdesign.errors import InputError
from cvtdesign.io.variant import load_spec, load_variant, resolve


def study(tmp_path, **fields):
    data = {"name": "t", "base": str(ROOT / "variants/box_kim.yaml"), "design": {"d": {"lower": "30 mm", "upper": "110 mm"}},
            "multistart": {"starts": 1}}
    data.update(fields)
    path = tmp_path / "study.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


def test_gradients_match_finite_differences(tmp_path):
    """d(objective, constraints)/d(design) through the Newton solves (implicit function theorem) vs central
    differences of the same functions."""
    pr = build_problem(load_study(study(tmp_path, design={"d": {"lower": "30 mm", "upper": "110 mm"},
                                               "r_drive": {"lower": "20 mm", "upper": "60 mm"},
                                               "preload": {"lower": "50 N", "upper": "200 N"}},
                             effects=["drive_longitudinal_creep", "steering_lateral_creep", "normal_force_variation",
                                      "rolling_resistance"], objective={"kind": "power_loss"})))
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
    pr = build_problem(load_study(study(tmp_path, constraints={"clearance": "2 mm", "traction_margin": None,
                                                    "hertz_pressure": False})))
    sol = solve_from(pr, starts(pr)[0])
    R, rs, c = 0.0635, 0.038, 0.002
    assert sol.success
    assert sol.design["d"] == pytest.approx(R * (2 * rs + c) / (R + rs), rel=1e-4)


@pytest.mark.slow
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
    # the optimum: r_steer at its 20 mm bound and the tandem pair as close as the 2 mm clearance lets it,
    # d = R (2 r_s + c)/(R + r_s) (test_steering_pair_moves_to_the_largest_moment_arm), with worst |α| =
    # 3.77885° (measured; variants/box_kim.yaml has 4.166°), pinned to 1e-5 relative (IPOPT's tolerance)
    assert {"worst_alpha", "clearance", "envelope_radius", "bound r_steer"} <= set(res["active_constraints"])
    R, rs, c = 0.0635, 0.020, 0.002
    assert res["design"]["r_steer"] == pytest.approx(rs, rel=1e-6)
    assert res["design"]["d"] == pytest.approx(R * (2 * rs + c) / (R + rs), rel=1e-6)
    assert res["objective"] == pytest.approx(3.778852, rel=1e-5)
    assert main(["compare", res["variant_file"], "--out", str(tmp_path / "c"), "--json", str(tmp_path / "c.json")]) == 0
    rows = json.loads((tmp_path / "c.json").read_text())["variants"]
    assert rows[-1]["max_abs_alpha_deg"] == pytest.approx(res["objective"], rel=1e-6)
    # the optimum's figures carry compare's intervals from every uncertain input (the same draws: sampled where the
    # first order misses, as compare's), and its gain is judged at them:
    # as two builds (each its own preload) it is not resolved; at one preload it is
    got = res["details"]["intervals"]
    assert got["optimum"]["max_abs_alpha_deg"] == pytest.approx(res["objective"], rel=1e-6)
    assert got["optimum"]["max_abs_alpha_deg_interval"] == pytest.approx(rows[-1]["max_abs_alpha_deg_interval"], rel=1e-6)
    assert any(k.startswith("preload") for k in got["optimum"]["max_abs_alpha_deg_budget"])
    slip = {key: next(o for o in got[key] if o["figure"] == "max_abs_alpha_deg")
            for key in ("orderings", "orderings_one_preload")}
    assert slip["orderings"]["better"] == "optimum" and not slip["orderings"]["resolved"]
    assert slip["orderings_one_preload"]["better"] == "optimum" and slip["orderings_one_preload"]["resolved"]
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


def test_a_design_variable_no_field_uses_is_refused(tmp_path, capsys):
    """A box written out in plain numbers (for example rotated and saved) keeps its parameters but no field
    uses them: optimising d then reported "optimum d = 69.13 mm" and two "distinct" optima of the same
    4.166°. The layout is now resolved at both bounds, and the same layout at both is refused."""
    variant = yaml.safe_load((ROOT / "variants/box_kim.yaml").read_text())
    variant["parameters"]["spare"] = "10 mm"
    (tmp_path / "box_kim.yaml").write_text(yaml.safe_dump(variant, allow_unicode=True))
    path = study(tmp_path, base=str(tmp_path / "box_kim.yaml"), design={"spare": {"lower": "5 mm", "upper": "20 mm"}})
    assert main(["optimise", str(path), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "design.spare: no field of the variant" in err and "uses the parameter 'spare'" in err
    assert err.count("\n") == 1 and not (tmp_path / "o").exists()


@pytest.mark.slow
def test_working_set_reaches_the_optimum_of_every_row(tmp_path):
    """IPOPT on a working set of envelope rows (violated rows added, solved again) ends where IPOPT on every
    row at once does, with every row of the whole formulation satisfied; here the traction limit binds at
    points the first working set leaves out, so it takes more than one round."""
    pr = build_problem(load_study(study(tmp_path, design={"d": {"lower": "30 mm", "upper": "110 mm"},
                                               "preload": {"lower": "50 N", "upper": "200 N"}},
                             effects=["drive_longitudinal_creep", "steering_lateral_creep", "normal_force_variation",
                                      "rolling_resistance"],
                             objective={"kind": "power_loss", "duty_cycle": [
                                 {"gamma": "30 deg", "load": "0.5 N*m", "weight": 2}, {"gamma": "-60 deg", "load": "-1 N*m"}]},
                             constraints={"traction_margin": 0.75, "clearance": "2 mm"},
                             envelope={"gamma": {"start": "-80 deg", "stop": "80 deg", "step": "20 deg"},
                                       "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "0.5 N*m"}})))
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
    evaluation of the model at the same design): Hertz p_max/p_allow, traction (|F| − 0.8 μN)/(μP), i.e.
    (F/(μN) − 0.8)·N/P, and normal force N/P₀ ≥ 5 % of the preload P₀ = P = 100 N (the default floor)."""
    pr = build_problem(load_study(study(tmp_path, envelope={"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "30 deg"},
                                                 "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}})))
    z = np.array([0.3])
    g = np.asarray(pr.evaluate(np.append(z, 0.0))[1]).ravel()
    d = pr.lower[0] + (pr.upper[0] - pr.lower[0]) * z[0]
    box = ROOT / "variants/box_kim.yaml"
    m = compile_model(resolve(load_spec(box), str(box), overrides={"d": d}))
    expected = {"traction": lambda r: (r["utilisation"] - 0.8) * r["N"] / 100.0,
                "hertz_pressure": lambda r: r["p_max"] / 6e6, "normal_force": lambda r: r["N"] / 100.0}
    for fam, value in expected.items():
        rows = [i for i, f in enumerate(pr.g_family) if f == fam]
        assert len(rows) == 8 * 15
        for i in rows[::7]:
            lab = pr.g_labels[i]
            roller = lab.split(" of ")[1].split(" at ")[0]
            gam, load = lab.split("γ=")[1].split("° τ⊥=")
            res = m.evaluate(np.radians(float(gam)), float(load))
            assert g[i] == pytest.approx(float(value(res)[m.roller_names.index(roller)]), rel=1e-9), lab
    nf = [i for i, f in enumerate(pr.g_family) if f == "normal_force"]
    np.testing.assert_allclose(pr.g_lb[nf], 0.05)
    np.testing.assert_allclose(pr.g_report[nf], 100.0)     # reported in newtons


def test_design_variable_free_in_some_variants_only(tmp_path, capsys):
    """A design variable with `variants` is free only in those variant files; the others optimise without it."""
    path = study(tmp_path, design={"r_steer": {"lower": "20 mm", "upper": "60 mm"},
                                   "d": {"lower": "30 mm", "upper": "110 mm", "variants": [str(ROOT / "variants/box_kim.yaml")]}},
                 batch={"variants": [str(ROOT / "variants/existing_kim.yaml"), str(ROOT / "variants/box_kim.yaml")]},
                 envelope={"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
                           "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "2 N*m"}})
    from cvtdesign.design.study_file import load_study
    spec = load_study(path).spec
    assert build_problem(Study(path, spec, ROOT / "variants/existing_kim.yaml")).names == ["r_steer"]
    assert sorted(build_problem(Study(path, spec, ROOT / "variants/box_kim.yaml")).names) == ["d", "r_steer"]
    data = yaml.safe_load(path.read_text())
    data["design"]["d"]["variants"] = ["bx.yaml"]
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    assert main(["optimise", str(path)]) == 2
    assert "design.d.variants: no variant file" in capsys.readouterr().err


def test_written_variant_carries_sweep_parameters_and_study_envelope(tmp_path):
    """A sweep case's optimum is written with its fixed parameters and the envelope it was optimised over,
    so the variant file reproduces the optimum (it kept the base's r_steer and envelope before)."""
    from cvtdesign.design.report import write_variant
    from cvtdesign.design.study_file import load_study
    from cvtdesign.io.variant import load_variant

    env = {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "30 deg"},
           "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}}
    path = study(tmp_path, constraints={"clearance": "2 mm"}, envelope=env)
    pr = build_problem(load_study(path), {"r_steer": 0.030})
    sol = solve_from(pr, starts(pr)[0])
    assert sol.success
    L = load_variant(write_variant(pr, sol, tmp_path, "swept"))
    steer = [r for r in L.rollers if r.role == "steering"]
    assert all(abs(r.radius - 0.030) < 1e-9 for r in steer)
    np.testing.assert_allclose(np.degrees(L.gamma_grid), [-60, -30, 0, 30, 60], atol=1e-12)
    m = compile_model(L)
    G, T = np.meshgrid(L.gamma_grid, L.load_grid, indexing="ij")
    assert np.degrees(np.nanmax(np.abs(m.evaluate(G, T)["alpha"]))) == pytest.approx(sol.objective, rel=1e-5)


def lossy_existing(tmp_path):
    """Kim's existing CVT with a 2 mm rolling-resistance offset: the loss optimum takes little preload, and
    its lateral load unloads one steering roller (at τ⊥ = 1 N·m, N ≈ P − 43 N)."""
    data = yaml.safe_load((ROOT / "variants/existing_kim.yaml").read_text())
    data["effect_parameters"] = {"rolling_resistance": {"offset": "2 mm"}}
    path = tmp_path / "lossy.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True, sort_keys=False))
    return path


@pytest.mark.slow
def test_normal_force_floor_holds_where_the_optimum_would_unload_a_contact(tmp_path):
    """Minimum power loss with the preload free: without a floor that binds, the optimum (P = 68.9 N) leaves a
    steering roller at 25.9 N; with min_normal_force 40 N the floor is the active constraint (the preload
    rises until the least-loaded contact carries 40 N over the whole envelope) and the report says so, in
    newtons, with its multiplier (the loss per newton of floor)."""
    fields = dict(base=str(lossy_existing(tmp_path)), design={"preload": {"lower": "5 N", "upper": "200 N"}},
                  effects=["drive_longitudinal_creep", "steering_lateral_creep", "rolling_resistance"],
                  objective={"kind": "power_loss"},
                  envelope={"gamma": {"start": "-80 deg", "stop": "80 deg", "step": "20 deg"},
                            "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "0.5 N*m"}})
    free = build_problem(load_study(study(tmp_path, constraints={"min_normal_force": "1 N"}, **fields)))
    s_free = solve_from(free, starts(free)[0])
    assert s_free.success and s_free.check.ok
    assert s_free.check.min_normal_force < 30                 # the unconstrained optimum unloads a contact
    pr = build_problem(load_study(study(tmp_path, constraints={"min_normal_force": "40 N"}, **fields)))
    sol = solve_from(pr, starts(pr)[0])
    assert sol.success and sol.check.ok and sol.objective > s_free.objective
    nf = {r["name"]: r for r in constraint_report(pr, sol)}["normal_force"]
    assert nf["active"] and nf["multiplier"] > 0 and nf["bound"] == pytest.approx(40.0)
    assert nf["value"] >= 40.0 - 1e-5                         # IPOPT's bound relaxation: 1e-8 of P₀ = 100 N
    assert " of S" in nf["where"] and "γ=" in nf["where"]     # a steering roller at an envelope point
    # the numeric model agrees: the least normal force over the envelope is the floor
    assert sol.check.min_normal_force == pytest.approx(40.0, abs=1e-4)
    L = resolve(load_spec(lossy_existing(tmp_path)), "lossy", overrides=sol.design)
    G, T = np.meshgrid(np.radians(np.arange(-80, 81, 20.0)), np.linspace(-1, 1, 5), indexing="ij")
    res = compile_model(L, effects=pr.spec.effects).evaluate(G, T)
    assert res["ok"].all() and np.min(res["N"]) == pytest.approx(40.0, abs=1e-4)


def test_envelope_check_flags_lost_contact_and_traction_row_cannot_pass_it(tmp_path):
    """Kim's existing CVT at τ⊥ = ±4 N·m: a steering roller's normal force goes negative (down to −49 N at
    100 N preload), where F/(μN) is negative too. The post-solve check counts those points as lost contact,
    and the traction row |F| − 0.8 μN is positive there, so it can no longer pass them."""
    m = compile_model(load_variant(ROOT / "variants/existing_kim.yaml"))
    G, T = np.meshgrid(np.radians(np.arange(-80, 81, 20.0)), [-4.0, 0.0, 4.0], indexing="ij")
    g, l = G.ravel(), T.ravel()
    # the raw model outputs (evaluate blanks the points outside the physics): N < 0 with utilisation < 0
    raw = m.point_function(["N", "utilisation", "residual"]).map(g.size)
    N, U, resid = (np.asarray(a) for a in raw(g, m.layout.motor_speed, l, 0.0, m.steering_guess(g)[0],
                                               m.param_values, np.zeros(0)))
    converged = resid.ravel() < 1e-8
    res = m.evaluate(G, T)
    # a root with the sphere turning backwards is counted as reversed, whatever its normal forces
    lost = converged & (N.min(axis=0) <= 0) & (res["status"].ravel() != STATUS.index("reversed"))
    assert lost.sum() >= 5 and np.all(U.min(axis=0)[lost] < 0)
    chk = check_envelope(res, m.roller_names)
    assert not chk.ok and chk.points == 27 and chk.lost_contact == lost.sum()
    assert chk.failed == chk.lost_contact + chk.gross_slip + chk.not_converged + chk.reversed + chk.multiple_roots
    assert "lost contact" in chk.worst and chk.worst.endswith(("S1", "S2"))
    assert f"{chk.failed} of 27 envelope points: {chk.lost_contact} lost contact" in chk.summary()
    G1, T1 = np.meshgrid(np.radians(np.arange(-80, 81, 20.0)), [-1.0, 0.0, 1.0], indexing="ij")
    ok = check_envelope(m.evaluate(G1, T1), m.roller_names)     # Kim's envelope: every contact loaded
    assert ok.ok and ok.summary().startswith("0 of 27") and 0 < ok.min_normal_force < 100 and ok.max_utilisation < 1

    # the rows of a study over that load, at the base design: wherever N < 0, the traction row is violated
    pr = build_problem(load_study(study(tmp_path, base=str(ROOT / "variants/existing_kim.yaml"),
                             design={"r_steer": {"lower": "20 mm", "upper": "60 mm"}},
                             envelope={"gamma": {"start": "-80 deg", "stop": "80 deg", "step": "20 deg"},
                                       "load": {"start": "-4 N*m", "stop": "4 N*m", "step": "4 N*m"}})))
    rows = np.asarray(pr.evaluate(np.array([(0.038 - 0.020) / 0.040, 0.0]))[1]).ravel()
    fam = np.array(pr.g_family)
    n_rows, t_rows = rows[fam == "normal_force"], rows[fam == "traction"]
    assert (n_rows < 0).sum() >= 5 and np.all(t_rows[n_rows < 0] > 0)


def test_optimum_failing_the_envelope_check_is_not_an_optimum(tmp_path):
    """Without a traction margin, Kim's existing CVT at τ⊥ = ±2 N·m: IPOPT solves (nothing in the rows
    limits F/(μN)), but at 4 points a contact needs more traction than μN. The solve is reported as failed
    with the count, and no variant file is written."""
    path = study(tmp_path, base=str(ROOT / "variants/existing_kim.yaml"), design={"r_steer": {"lower": "20 mm", "upper": "60 mm"}},
                 constraints={"traction_margin": None},
                 envelope={"gamma": {"start": "-40 deg", "stop": "40 deg", "step": "20 deg"},
                           "load": {"start": "-2 N*m", "stop": "2 N*m", "step": "2 N*m"}})
    pr = build_problem(load_study(path))
    sol = solve_from(pr, starts(pr)[0])
    assert sol.ipopt_status == "Solve_Succeeded" and not sol.success
    assert sol.status.startswith("Failed_Envelope_Check: 4 of 15 envelope points") and sol.check.gross_slip == 4
    assert sol.check.lost_contact == 0 and "gross slip (|F| > μN) at S" in sol.check.worst
    from cvtdesign.design.report import write_variant
    with pytest.raises(ValueError):
        write_variant(pr, sol, tmp_path)
    out = tmp_path / "res"
    assert main(["optimise", str(path), "--out", str(out), "--json", str(tmp_path / "o.json")]) == 1
    res = json.loads((tmp_path / "o.json").read_text())
    assert res["variant_file"] is None and not out.exists()
    assert res["status"].startswith("Failed_Envelope_Check") and res["details"]["envelope_check"]["gross_slip"] == 4


@pytest.mark.parametrize("value, message", [
    ("2 kg", "constraints.min_normal_force: expected a force like '100 N', got '2 kg'"),
    ("-5 N", "constraints.min_normal_force: expected a positive force like '5 N', got '-5 N'"),
    ("0 N", "constraints.min_normal_force: expected a positive force like '5 N', got '0 N'"),
    (False, "constraints.min_normal_force: expected a force like '5 N'"),
])
def test_bad_min_normal_force(tmp_path, capsys, value, message):
    path = study(tmp_path, constraints={"min_normal_force": value})
    with pytest.raises(InputError, match=message.replace("(", r"\(").replace(")", r"\)")):
        build_problem(load_study(path))
    assert main(["optimise", str(path)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1
