"""Shaft kinematics derived from the layout (kinematics.py) and the physical-validity status of every point.

The non-perpendicular layout reproduces an issue's figure: with γ and α measured against fixed d1, d2, a
drive roller turned 20° about z reported 20° of "drive slip" at zero load; derived from the layout it is 0.
"""
import dataclasses
import json

import numpy as np
import pytest
import yaml

from conftest import variant_path

from cvtdesign.diagnosis import measured
from cvtdesign.diagnosis import rig
from cvtdesign.cli import main
from cvtdesign.core.geometry import FRAME
from cvtdesign.core.kinematics import shaft_frame
from cvtdesign.core.model import compile_model
from cvtdesign.core.status import STATUS
from cvtdesign.io.variant import load_variant

EXISTING = str(variant_path("existing_kim"))


def non_perpendicular(tmp_path, theta_deg=20.0):
    """existing_kim.yaml with shaft 2's roller turned by θ about z (shaft axes 90° + θ apart); the drive
    preloads rebalanced so that Σ P n = 0: P_D2 = P/cos θ, P_D1 = P (1 − tan θ)."""
    d = yaml.safe_load(open(EXISTING))
    th = np.radians(theta_deg)
    Rz = np.array([[np.cos(th), -np.sin(th), 0], [np.sin(th), np.cos(th), 0], [0, 0, 1]])
    d["rollers"]["D2"].update(contact=(Rz @ FRAME["d1"]).tolist(), axle=(-Rz @ FRAME["d2"]).tolist(),
                              preload=f"{float(100 / np.cos(th))!r} N")
    d["rollers"]["D1"]["preload"] = f"{float(100 * (1 - np.tan(th)))!r} N"
    path = tmp_path / "non_perpendicular.yaml"
    path.write_text(yaml.safe_dump(d))
    return path


def test_kims_layout_is_the_special_case():
    """For Kim's CVT the derived frame is d1, d2 with c = 0, s = 1, k = r1/r2 (Kim eqs 8, 15, 17 exactly)."""
    f = shaft_frame(load_variant(variant_path("unequal_kim")))
    assert np.allclose(f.u1, FRAME["d1"], atol=1e-15) and np.allclose(f.u2, FRAME["d2"], atol=1e-15)
    assert f.c == 0.0 and f.s == pytest.approx(1.0, abs=1e-15) and f.k == pytest.approx(30 / 45, rel=1e-15)
    g = np.radians([-70.0, 10.0, 55.0])
    tau_perp, tau_par = f.load_split(g, 0.3, -0.7)
    assert np.allclose(tau_perp, -0.3 * np.sin(g) - 0.7 * np.cos(g), rtol=0, atol=1e-15)
    assert np.allclose(tau_par, 0.3 * np.cos(g) - 0.7 * np.sin(g), rtol=0, atol=1e-15)
    assert np.allclose(f.ideal_ratio(g), (30 / 45) * np.tan(g), rtol=1e-14)
    assert np.allclose(f.slip_angle(2.0, 2.0 * f.ideal_ratio(g), g), 0.0, atol=1e-15)


def test_non_perpendicular_shafts_have_no_slip_at_zero_load(tmp_path):
    L = load_variant(non_perpendicular(tmp_path))
    m = compile_model(L)
    assert m.frame.c == pytest.approx(np.cos(np.radians(110.0)), abs=1e-14)
    r = m.evaluate(L.gamma_grid, 0.0)
    assert r["ok"].all()
    assert np.max(np.abs(r["alpha"])) < 1e-9               # was 20° with d1, d2 hard-wired
    assert np.max(np.abs(r["alpha_drive"])) < 1e-9
    ideal = m.frame.ideal_ratio(L.gamma_grid)
    assert np.allclose(r["omega_2"] / r["omega_1"], ideal, rtol=1e-9)


@pytest.mark.slow
def test_flipped_axle_gives_the_same_compare_table(tmp_path, capsys):
    """Shaft 2's roller declared with axle d2 instead of −d2 is the same machine (it reported max |α| 89.2°)."""
    flipped = tmp_path / "flipped.yaml"
    flipped.write_text(open(EXISTING).read().replace("contact: d1, axle: -d2", "contact: d1, axle: d2"))
    out = tmp_path / "compare.json"
    assert main(["compare", EXISTING, str(flipped), "--out", str(tmp_path), "--json", str(out)]) == 0
    assert "ω2/ω1 = 1 · tan γ" in capsys.readouterr().out
    a, b = json.loads(out.read_text())["variants"]
    for key, value in a.items():
        if isinstance(value, float):
            assert b[key] == pytest.approx(value, rel=1e-9, abs=1e-12), key
    assert a["max_abs_alpha_deg"] == pytest.approx(10.761, abs=5e-4)


def test_measured_alpha_uses_the_layouts_kinematics(tmp_path):
    """Rig data of the flipped layout, read back, give the model's own α (shaft 2 counted the other way)."""
    flipped = tmp_path / "flipped.yaml"
    flipped.write_text(open(EXISTING).read().replace("contact: d1, axle: -d2", "contact: d1, axle: d2"))
    L = load_variant(flipped)
    rows, left_out = rig.simulate(L, L.effects, noise=rig.Noise(0, 0, 0))
    # in the file's own convention the ideal law is still ω2/ω1 = tan γ
    assert left_out == {} and (rows["omega_2"] * rows["gamma_cmd_deg"] >= 0).all()
    path = tmp_path / "data.csv"
    path.write_text(rig.to_csv_text(rows))
    data = measured.load_measured(path, L)
    m = compile_model(L)
    r = m.evaluate(np.radians(data.rows["gamma_cmd_deg"].to_numpy()), data.rows["tau_perp"].to_numpy())
    assert np.allclose(data.rows["alpha_deg"], np.degrees(r["alpha"]), atol=1e-6)
    assert np.allclose(data.rows["gamma_axis_deg"] - data.rows["gamma_cmd_deg"], np.degrees(r["alpha_steering"]),
                       atol=1e-6)


def raw_point(m, gamma, load):
    """The compiled point function at one operating point, without the status mask."""
    phi0, _ = m.steering_guess([gamma])
    out = m.point(gamma, m.layout.motor_speed, load, 0.0, phi0[0], np.array(m.param_values), np.zeros(0))
    return {k: np.asarray(v).ravel() for k, v in zip(m.point.name_out(), out)}


@pytest.mark.parametrize("effects", [None, ("drive_longitudinal_creep", "steering_lateral_creep",
                                             "normal_force_variation", "traction_saturation")])
def test_heavy_loads_are_physical_or_flagged(effects):
    """±6 N·m on the existing CVT: every point that carries numbers has N > 0 and |F| ≤ μN at every contact;
    every flagged point is flagged for a reason the raw solution shows (N ≤ 0 at the named contact, or
    |F| > μN there). Before, 42 of 69 'converged' points at 1-40 N·m had N < 0."""
    L = load_variant(EXISTING)
    L = dataclasses.replace(L, gamma_grid=np.radians(np.arange(-80, 81, 20.0)), load_grid=np.linspace(-6, 6, 7))
    m = compile_model(L, effects)
    G, T = np.meshgrid(L.gamma_grid, L.load_grid, indexing="ij")
    r = m.evaluate(G, T)
    ok = r["ok"]
    assert (r["status"] == STATUS.index("lost_contact")).sum() > 0 or (r["status"] == STATUS.index("gross_slip")).sum() > 0
    assert (r["N"][:, ok] > 0).all()
    assert (np.hypot(r["F_t"], r["F_a"])[:, ok] <= r["mu"][:, ok] * r["N"][:, ok]).all()
    assert np.isnan(r["alpha"][~ok]).all()
    for i, j in zip(*np.nonzero(r["status"] >= 2)):
        raw, k = raw_point(m, G[i, j], T[i, j]), r["failed_contact"][i, j]
        if r["status"][i, j] == STATUS.index("reversed"):     # the output shaft runs against the ideal law
            assert raw["residual"][0] < 1e-8 and raw["omega_2"][0] * m.frame.ideal_ratio(G[i, j]) < 0
        elif r["status"][i, j] == STATUS.index("lost_contact"):
            assert raw["N"][k] <= 0 and raw["N"][k] == raw["N"].min()
        elif r["status"][i, j] == STATUS.index("gross_slip") and not raw["residual"][0] > 1e-8:   # the named contact exceeds μN
            assert np.hypot(raw["F_t"][k], raw["F_a"][k]) > raw["mu"][k] * raw["N"][k]


def test_gross_slip_is_reported_not_returned():
    """With traction saturation and too little friction the contact cannot carry 1 N·m: no number comes back."""
    m = compile_model(load_variant(EXISTING), effects=["drive_longitudinal_creep", "steering_lateral_creep",
                                                       "traction_saturation"])
    theta = np.array(m.param_values)
    theta[m.param_names.index("traction_saturation.mu_scale")] = 0.2   # μN = 16 N at the preload
    r = m.evaluate(np.radians([30.0, 30.0]), [0.1, 1.0], theta=theta)
    assert r["status"].tolist() == [STATUS.index("ok"), STATUS.index("gross_slip")]
    assert m.roller_names[r["failed_contact"][1]] == "D2"     # the brake roller carries the largest |F| − μN
    assert np.isfinite(r["alpha"][0]) and np.isnan(r["alpha"][1]) and np.isnan(r["N"][:, 1]).all()


@pytest.mark.slow
def test_heavy_envelope_json_is_strict_and_counts_flags(tmp_path, capsys):
    heavy = tmp_path / "heavy.yaml"
    heavy.write_text(open(EXISTING).read().replace("load: {start: -1 N*m, stop: 1 N*m, step: 0.1 N*m}",
                                                   "load: {start: -6 N*m, stop: 6 N*m, step: 2 N*m}"))
    out = tmp_path / "c.json"
    assert main(["compare", str(heavy), "--out", str(tmp_path), "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "lost contact at" in printed and "gross slip at" in printed
    rows = json.loads(out.read_text(), parse_constant=lambda c: pytest.fail(f"{c} in the JSON"))["variants"]
    heavy_row = next(r for r in rows if r["file"] == str(heavy))
    assert heavy_row["lost_contact"] > 0 and heavy_row["gross_slip"] > 0
    assert set(heavy_row["lost_contact_at"]) <= {"D1", "D2", "S1", "S2"}
    assert heavy_row["ok"] + heavy_row["lost_contact"] + heavy_row["gross_slip"] + heavy_row["not_converged"] \
        == heavy_row["points"]
    assert heavy_row["max_traction_utilisation"] <= 1.0        # it printed 25.8 at ±6 N·m before
