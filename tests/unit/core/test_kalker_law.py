"""contact.law: kalker in the model: what the variant may say with it, calibration, and what it changes.
(Its invariance under rotation, mirroring and axle flips is in test_invariance.py, its contact physics in
test_creep.py, test_contact_command.py and tests/validation.)"""
import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import variant_data, write_yaml

from cvtdesign.cli import main
from cvtdesign.core.model import compile_model
from cvtdesign.core.contact.patch import theory_patch
from cvtdesign.io.variant import load_variant
from cvtdesign.io.shipped import shipped_variant

GAMMAS = np.radians(np.arange(-80, 81, 10.0))


def kalker(tmp_path, name="existing_kim", calibration=None, **extra):
    data = variant_data(name)
    data["contact"] = {"law": "kalker"} | ({"calibration": calibration} if calibration else {})
    data.update(extra)
    return write_yaml(tmp_path / f"{name}_kalker.yaml", data)


@pytest.mark.parametrize("edit, message", [
    (lambda d: d["contact"].update(creep_drive="0.0038 1/N"),
     "contact.creep_drive: a fitted creep constant belongs to a law with fitted constants (kim); under law kalker"),
    (lambda d: d.update(effects=["drive_longitudinal_creep", "normal_force_variation"]),
     "effects: normal_force_variation is part of contact.law kalker"),
    (lambda d: d["contact"].update(law="kim", calibration={"drive": 2}),
     "contact.calibration: applies to a law on a theory's compliances, not to law kim (Kim et al.'s fitted "
     "linear creep constants); expected contact.law: kalker with it"),
])
def test_what_the_law_refuses(tmp_path, capsys, edit, message):
    data = variant_data("existing_kim")
    data["contact"] = {"law": "kalker"}
    edit(data)
    assert main(["compare", str(write_yaml(tmp_path / "v.yaml", data)), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err


@pytest.mark.slow
def test_calibration_and_the_creep_effects_scale_are_one_factor(tmp_path):
    """contact.calibration.drive = 2 and drive_longitudinal_creep.scale = 2 (the parameter diagnose fits
    under kalker) multiply the same compliances: identical α everywhere. (A factor given, even 1, replaces the
    materials library's calibration of those contacts.)"""
    a = compile_model(load_variant(kalker(tmp_path, calibration={"drive": 2.0})))
    b = compile_model(load_variant(kalker(tmp_path, calibration={"drive": 1.0},
                                          effect_parameters={"drive_longitudinal_creep": {"scale": 2.0}})))
    ra, rb = a.evaluate(GAMMAS, 0.7), b.evaluate(GAMMAS, 0.7)
    assert ra["ok"].all() and rb["ok"].all()
    np.testing.assert_allclose(ra["alpha"], rb["alpha"], rtol=0, atol=1e-13)


def test_spin_gives_an_axis_offset_at_zero_load(tmp_path):
    """Kim's law has no slip without load (α = 0 to the solver's accuracy). Under Kalker's theory spin makes slip
    at zero load: the steering rollers' spin force (C23) is a lateral creep that moves the axis (the steering
    part of α), and the contacts' spin moments (C33), balanced on the sphere by drive forces, add a drive part.
    Measured on the existing CVT, calibrated: |α| up to 0.139°, steering part 0.201°, drive part 0.062°."""
    L = load_variant(shipped_variant("existing_kim"))
    d, s = L.rollers[0], next(r for r in L.rollers if r.role == "steering")
    cal = {"drive": 0.0038 / float(theory_patch(L, d, 100.0)["eps_long"]),
           "steering": 0.0049 / float(theory_patch(L, s, 100.0)["eps_lat"])}
    kim = compile_model(L).evaluate(GAMMAS, 0 * GAMMAS)
    kal = compile_model(load_variant(kalker(tmp_path, calibration=cal))).evaluate(GAMMAS, 0 * GAMMAS)
    assert kim["ok"].all() and kal["ok"].all()
    assert np.max(np.abs(kim["alpha"])) < 1e-9
    offset = np.degrees(np.abs(kal["alpha"]))
    assert 0.1 < offset.max() < 0.2
    drive = np.degrees(np.abs(kal["alpha"] - kal["alpha_steering"]))
    assert 0.03 < drive.max() < 0.1


@pytest.mark.slow
def test_calibrated_box_follows_kims_fit_in_the_linear_range(tmp_path):
    """Calibrated so that the compliances at 100 N are Kim's ε_D and ε_S, the box CVT (its pole rollers see
    little spin) slips like Kim's fitted model at small loads: dα/dτ⊥ at γ = 40° within 0.5 % (measured
    −0.42 %: 4.1292 against 4.1468 °/(N·m); −0.07 % before the spin moment was in the law)."""
    L = load_variant(shipped_variant("box_kim"))
    d, s = L.rollers[0], next(r for r in L.rollers if r.role == "steering")
    cal = {"drive": 0.0038 / float(theory_patch(L, d, 100.0)["eps_long"]),
           "steering": 0.0049 / float(theory_patch(L, s, 100.0)["eps_lat"])}
    g = np.radians([40.0, 40.0])
    kim = compile_model(L).evaluate(g, np.array([0.05, -0.05]))
    kal = compile_model(load_variant(kalker(tmp_path, "box_kim", calibration=cal))).evaluate(g, np.array([0.05, -0.05]))
    slope = lambda r: (r["alpha"][0] - r["alpha"][1]) / 0.1    # noqa: E731
    assert slope(kal) == pytest.approx(slope(kim), rel=5e-3)


def fitted_report(path, **values) -> str:
    """A diagnosis report (the part `--calibration` reads): final_fit {effect.param: {value, std, ...}}."""
    path.write_text(json.dumps({"verdict": "none", "final_fit": {
        k.replace("__", "."): {"value": v, "std": 0.01, "identifiable": True} for k, v in values.items()}}))
    return str(path)


@pytest.mark.slow
def test_optimise_carries_a_fitted_calibration(tmp_path):
    """optimise --calibration REPORT.json: under kalker the fitted drive_longitudinal_creep.scale multiplies the
    drive contacts' compliances in the study, and the optimum's variant file carries it, so compare of that
    file gives the study's objective (to 1e-6°)."""
    study = tmp_path / "study.yaml"
    study.write_text(yaml.safe_dump({
        "name": "t", "base": str(shipped_variant("box")), "design": {"d": {"lower": "40 mm", "upper": "90 mm"}},
        "multistart": {"starts": 1},
        "envelope": {"gamma": {"start": "20 deg", "stop": "60 deg", "step": "20 deg"},
                     "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}}}))
    report = fitted_report(tmp_path / "fit.json", drive_longitudinal_creep__scale=1.4)
    out = tmp_path / "res"
    assert main(["optimise", str(study), "--out", str(out), "--json", str(tmp_path / "o.json"),
                 "--calibration", report]) == 0
    res = json.loads((tmp_path / "o.json").read_text())
    variant = Path(res["variant_file"])
    text = variant.read_text()
    assert "# calibration: " in text and yaml.safe_load(text)["effect_parameters"]["drive_longitudinal_creep"]["scale"] == 1.4
    assert main(["compare", str(variant), str(variant), "--out", str(tmp_path / "p"), "--json", str(tmp_path / "c.json")]) == 0
    row = json.loads((tmp_path / "c.json").read_text())["variants"][0]
    assert row["max_abs_alpha_deg"] == pytest.approx(res["objective"], abs=1e-6)
    plain = tmp_path / "plain"
    assert main(["optimise", str(study), "--out", str(plain), "--json", str(tmp_path / "p.json")]) == 0
    assert json.loads((tmp_path / "p.json").read_text())["objective"] < res["objective"]    # softer drive contacts


@pytest.mark.parametrize("content, message", [
    ("not json", "not a JSON file"),
    ('{"verdict": "none"}', "final_fit: missing"),
    ('{"final_fit": {"no_such_effect.scale": {"value": 1}}}', "final_fit.no_such_effect.scale: not a parameter"),
    ('{"final_fit": {"drive_longitudinal_creep.scale": {"value": -2}}}', "final_fit.drive_longitudinal_creep.scale"),
])
def test_bad_calibration_report_is_one_line(tmp_path, capsys, content, message):
    (tmp_path / "fit.json").write_text(content)
    study = tmp_path / "study.yaml"
    study.write_text(yaml.safe_dump({"name": "t", "base": str(shipped_variant("box")),
                                     "design": {"d": {"lower": "40 mm", "upper": "90 mm"}}}))
    assert main(["optimise", str(study), "--calibration", str(tmp_path / "fit.json"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and "Traceback" not in err, err


@pytest.mark.slow
@pytest.mark.parametrize("name", ["box", "existing"])
def test_energy_balance_with_the_spin_moment(name):
    """The power the shafts put in, τ1ω1 + τ2ω2, is what the contacts dissipate: −Σ F·s (creep) − Σ Mz Ω·n
    (the spin moment on the sphere against its spin over the roller), to 1e-9 of the largest term, at every
    ok point, and each contact's `loss` output is its share. At zero load there is still a loss: the spin
    moments, and the creep of the forces that balance them on the sphere; the spin moments' own share is most
    of it (measured ≥ 0.96 on both variants)."""
    from cvtdesign.core.geometry import pose
    L = load_variant(shipped_variant(name))
    m = compile_model(L)
    g, t = np.meshgrid(np.radians(np.arange(-80, 81, 20.0)), [-0.6, 0.0, 0.6], indexing="ij")
    r = m.evaluate(g, t)
    ok = r["ok"]
    assert ok.sum() >= 0.9 * ok.size
    Om = np.stack([r["Omega_x"], r["Omega_y"], r["Omega_z"]])
    creep, spin = np.zeros(g.shape), np.zeros(g.shape)
    for k, roller in enumerate(L.rollers):
        for idx in zip(*np.nonzero(ok)):
            n, a = pose(roller, r["phi"][idx])
            om = Om[(slice(None),) + idx]
            spin[idx] -= r["M_spin"][(k,) + idx] * (om @ n)
    creep = np.nansum(r["loss"], axis=0) - spin
    power = r["tau_1"] * r["omega_1"] + r["tau_2"] * r["omega_2"]
    scale = np.nanmax(np.abs(power))
    np.testing.assert_allclose(power[ok], (creep + spin)[ok], rtol=0, atol=1e-9 * scale)
    assert np.all(r["loss"][:, ok] >= -1e-9 * scale)
    assert np.all(spin[ok] >= -1e-12) and np.all(creep[ok] >= -1e-9 * scale)
    zero = ok & (t == 0)
    print(f"\n{name}: loss up to {scale:.3f} W; at zero load {np.nanmax(power[zero]):.3f} W, "
          f"of which spin moment {np.nanmax(spin[zero]):.3f} W")
    share = np.min(spin[zero] / power[zero])
    print(f"  spin moments' share of the zero-load loss ≥ {share:.3f}")
    assert share > 0.95


def test_zero_load_brake_speed_against_brokowski():
    """At zero load the kalker law turns the sphere's axis away from γ = 0 through the steering rollers' spin,
    so the brake shaft (2) runs faster than ideal near γ = 0 and slower near ±90°, with either motor sense:
    existing +1.30 % at γ = −10°, +0.69 % at 10°, −1.28 % at −80°, −0.68 % at 80°, the steering part of
    α −0.178° at −10°. Brokowski et al. define tan g = ω_motor/ω_brake, so their g = ±90° (where they saw the
    brake 'rotating faster than we would expect', from a transmission-angle error) is γ ≈ 0 here
    (docs/contact.md derives it)."""
    m = compile_model(load_variant(shipped_variant("existing")))
    g = np.radians([-80.0, -10.0, 10.0, 80.0])
    for w1 in (10.0, -10.0):
        r = m.evaluate(g, 0.0 * g, speeds=w1)
        faster = 100 * (r["omega_2"] / r["omega_1"] / m.frame.ideal_ratio(g) - 1)
        np.testing.assert_allclose(faster, [-1.28, 1.30, 0.69, -0.68], atol=0.01)
        np.testing.assert_allclose(np.degrees(r["alpha_steering"][1]), -0.178, atol=1e-3)
