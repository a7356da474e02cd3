"""The materials library: a new design of Kim's rollers on his ball inherits the calibration fitted to his
machine (under either law), a pair with no calibration is marked theory only everywhere, and a user's own
library file or redefined material is taken as written and said so."""
from __future__ import annotations

import json

import numpy as np
import yaml
import pytest

from conftest import variant_data, write_yaml
from cvtdesign.core.contact.patch import calibrated_compliance, theory_patch
from cvtdesign.core.metrics import envelope, metrics
from cvtdesign.core.model import compile_model
from cvtdesign.io.variant import load_variant

KIM_FITTED = {"law": "kim", "creep_drive": "0.0038 1/N", "creep_steering": "0.0049 1/N", "creep_reference_force": "100 N",
              "fitted_on": {"drive": ["urethane_82A", "bowling_ball"], "steering": ["urethane_84A", "bowling_ball"]}}
KALKER_FACTORS = {"law": "kalker", "calibration": {"drive": 3.1364, "steering": 3.6033}}


def three_steering(contact=None, **edits) -> dict:
    """A new layout of Kim's rollers on his ball: a third steering roller S3 at −c2 on S2's fork (S2's preload
    doubled so the preloads balance), its materials from the library (no `materials:`), and `contact` as given
    (None: no contact section)."""
    d = variant_data("existing_kim")
    d["name"] = "three"
    del d["materials"]
    d["rollers"]["S2"]["preload"] = "200 N"
    d["rollers"]["S3"] = dict(d["rollers"]["S2"], contact="-c2", preload="100 N")
    d["steering"]["forks"][1]["rollers"] = ["S2", "S3"]
    d.pop("contact")
    if contact is not None:
        d["contact"] = contact
    d.update(edits)
    return d


def figures(path) -> dict:
    m = compile_model(load_variant(path))
    return metrics(m, envelope(m))


@pytest.mark.slow
@pytest.mark.parametrize("law, explicit", [("kim", KIM_FITTED), ("kalker", KALKER_FACTORS)])
def test_a_new_layout_of_kims_materials_is_calibrated(tmp_path, law, explicit):
    """The same new layout with no contact section (the library's calibration) and with Kim's fitted constants
    written out (kim) or the factors that give them (kalker): the figures agree within 5 % (measured: max |α|
    within 0.3 %), and the library's figures are not the theory's (about 3× smaller)."""
    lib = write_yaml(tmp_path / "lib.yaml", three_steering({"law": law}))
    own = write_yaml(tmp_path / "own.yaml", three_steering(explicit))
    theory = write_yaml(tmp_path / "theory.yaml", three_steering(
        {"law": law, "calibration": {"drive": 1, "steering": 1}} if law == "kalker" else
        {"law": law}, materials={"urethane_82A": {"youngs_modulus": "10.7 MPa", "poisson_ratio": 0.481},
                                 "urethane_84A": {"youngs_modulus": "12.3 MPa", "poisson_ratio": 0.481}}))
    a, b, t = figures(lib), figures(own), figures(theory)
    for key in ("max_abs_alpha_deg", "rms_alpha_deg", "max_abs_alpha_steering_deg", "max_abs_alpha_drive_deg"):
        assert a[key] == pytest.approx(b[key], rel=0.05), key
    assert a["max_abs_alpha_deg"] == pytest.approx(b["max_abs_alpha_deg"], rel=3e-3)
    assert t["max_abs_alpha_deg"] < 0.45 * a["max_abs_alpha_deg"]
    L = load_variant(lib)
    assert {r.creep.kind for r in L.rollers} == {"library"}
    assert "cvtdesign's materials library: calibrations[0]" in L.rollers[0].creep.source
    assert {r.creep.kind for r in load_variant(theory).rollers} == {"theory"}


def test_the_calibration_gives_kims_constants_at_his_rollers(tmp_path):
    """One creep modulus for both urethanes: at Kim's drive rollers (40 mm, 82A) it gives ε_D = 0.0038 1/N and
    at his steering rollers (38 mm, 84A) ε_S = 0.0049 1/N, at 100 N, under kalker; the theory alone gives the
    0.00121 and 0.00140 1/N that are 3.1–3.6× stiffer."""
    L = load_variant(write_yaml(tmp_path / "v.yaml", three_steering({"law": "kalker"})))
    d1, s1 = L.rollers[0], next(r for r in L.rollers if r.role == "steering")
    assert calibrated_compliance(L, d1) == pytest.approx(0.0038, rel=1e-3)
    assert calibrated_compliance(L, s1) == pytest.approx(0.0049, rel=0.00005 / 0.0049)
    ratio = (calibrated_compliance(L, d1) / float(theory_patch(L, d1)["eps_long"]),
             calibrated_compliance(L, s1) / float(theory_patch(L, s1)["eps_lat"]))
    assert ratio == pytest.approx((3.1364, 3.6033), rel=2e-3)


@pytest.mark.slow
def test_a_pair_with_no_calibration_is_transferred_or_theory_only_everywhere(tmp_path, cli):
    """Urethane on a steel ball: no calibration of the pair, but one of its family (polyurethane): TRANSFERRED in
    the table, the JSON and the report, with an interval. Nylon rollers on steel: no family calibrated, so the
    JSON says uncalibrated: true with the theory's known gap, the table's calibration row THEORY ONLY, and the
    HTML report too; its interval holds the other inputs, never the theory's own gap (the notes say so)."""
    def steel(d):
        for r in d["rollers"].values():
            r["material"] = "nylon_66"
        return d
    urethane = write_yaml(tmp_path / "steel.yaml", three_steering(sphere={"radius": "63.5 mm", "material": "steel"},
                                                                 name="steel"))
    nylon = write_yaml(tmp_path / "nylon.yaml", steel(three_steering(sphere={"radius": "63.5 mm",
                                                                             "material": "steel"}, name="nylon")))
    code, out, err = cli("compare", urethane, nylon, "--out", tmp_path / "p", "--json", tmp_path / "f.json",
                         "--report", tmp_path / "r.html", "--samples", "0")
    assert code == 0, err
    rows = {r["name"]: r for r in json.loads((tmp_path / "f.json").read_text())["variants"]}
    assert rows["steel"]["calibration"]["kind"] == "transferred" and rows["steel"]["max_abs_alpha_deg_interval"]
    assert "TRANSFERRED to urethane_82A" in rows["steel"]["calibration"]["contacts"]["D1"]["source"]
    row = rows["nylon"]
    assert row["calibration"]["uncalibrated"] is True
    assert "3.1–3.6×" in row["calibration"]["text"] and "no calibration of nylon_66 on steel" in \
        row["calibration"]["contacts"]["D1"]["source"]
    row_line = next(line for line in out.splitlines() if line.startswith("│ calibration"))
    assert "TRANSFERRED" in row_line and row_line.rstrip(" │").endswith("THEORY ONLY")
    assert "THEORY ONLY" in (tmp_path / "r.html").read_text()


def test_a_redefined_material_loses_the_calibration_and_says_why(tmp_path):
    """A variant that redefines urethane_82A with another modulus keeps its own values, and the library's
    calibration (fitted with the library's values) no longer applies: theory only, with the reason."""
    d = three_steering(materials={"urethane_82A": {"youngs_modulus": "20 MPa", "poisson_ratio": 0.48}})
    L = load_variant(write_yaml(tmp_path / "v.yaml", d))
    d1, s1 = L.rollers[0], next(r for r in L.rollers if r.role == "steering")
    assert d1.material.E == 20e6 and d1.creep.uncalibrated
    assert "urethane_82A differs from the library's" in d1.creep.source
    assert s1.creep.kind == "library"                  # 84A is still the library's


def test_a_users_library_file_adds_a_calibration(tmp_path):
    """A library file of the user's own (`material_library:`) calibrates urethane on steel: the contacts take it,
    with its file named as the source and its σ in the interval; a missing file is one line naming the field."""
    (tmp_path / "mine.yaml").write_text(
        "calibrations:\n"
        "  - {roller: urethane_82A, sphere: steel, creep_modulus: 4 MPa, std: 5 %, machine: our rig,\n"
        "     data: one wheel's creep curve at 100 N, fit: least squares on the linear part}\n"
        "  - {roller: urethane_84A, sphere: steel, creep_modulus: 4.5 MPa, std: 5 %, machine: our rig,\n"
        "     data: one wheel's creep curve at 100 N, fit: least squares on the linear part}\n")
    d = three_steering(sphere={"radius": "63.5 mm", "material": "steel"}, material_library=["mine.yaml"])
    L = load_variant(write_yaml(tmp_path / "v.yaml", d))
    assert {r.creep.kind for r in L.rollers} == {"library"}
    assert str(tmp_path / "mine.yaml") in L.rollers[0].creep.source and L.rollers[0].creep.std == 0.05
    assert L.rollers[0].creep.creep_modulus == 4e6
    d["material_library"] = ["nope.yaml"]
    with pytest.raises(Exception, match=r"v\.yaml: material_library\[0\]: no such file"):
        load_variant(write_yaml(tmp_path / "v.yaml", d))


def test_a_bad_library_entry_is_one_line(tmp_path, cli):
    (tmp_path / "mine.yaml").write_text("calibrations:\n  - {roller: urethane_82A, sphere: steel, creep_modulus: 4 mm}\n")
    d = three_steering(sphere={"radius": "63.5 mm", "material": "steel"}, material_library=["mine.yaml"])
    code, out, err = cli("compare", write_yaml(tmp_path / "v.yaml", d), "--out", tmp_path / "p")
    assert code == 2 and err.count("\n") == 1 and "mine.yaml" in err and "calibrations" in err
    assert not (tmp_path / "p").exists()


def test_the_kim_variant_and_the_library_agree_on_kims_machine(tmp_path):
    """variants/existing_kim.yaml (Kim's fitted constants written out) and the same machine on the library's
    calibration: max |α| 10.761° both, to 0.1 %."""
    d = variant_data("existing_kim")
    del d["materials"]
    d["contact"] = {"law": "kim"}
    lib = figures(write_yaml(tmp_path / "lib.yaml", d))
    own = figures(write_yaml(tmp_path / "own.yaml", variant_data("existing_kim")))
    assert lib["max_abs_alpha_deg"] == pytest.approx(own["max_abs_alpha_deg"], rel=1e-3)
    assert np.isclose(own["max_abs_alpha_deg"], 10.761, atol=5e-4)


@pytest.mark.slow
def test_a_diagnosis_saves_its_calibration_for_later_variants(tmp_path, cli):
    """Rig data of Kim's CVT with the drive contacts 1.5× and the steering contacts 0.8× as compliant as the
    library's calibration; `diagnose --save-calibration` writes the library entries (creep moduli 3.399/1.5 and
    3.399/0.8 MPa, to the fit's accuracy, with σ and provenance), and a variant naming the file predicts what
    the rig's machine does: max |α| within 0.3 % of the truth's (measured 0.1 %). Run again, the file keeps its
    other entries and replaces those of the same pair."""
    d = variant_data("existing_kim")
    del d["contact"], d["materials"]
    v = write_yaml(tmp_path / "v.yaml", d)
    rig = tmp_path / "rig.csv"
    assert cli("rig", v, "--set", "drive_longitudinal_creep.scale=1.5", "--set", "steering_lateral_creep.scale=0.8",
               "--out", rig)[0] == 0
    lib = tmp_path / "ours.yaml"
    lib.write_text("calibrations:\n  - {roller: nylon_66, sphere: steel, creep_modulus: 1 GPa, std: 5 %, machine: m,"
                   " data: d, fit: f}\n")
    code, out, err = cli("diagnose", rig, "--variant", v, "--candidates", "steering_offset", "--save-calibration", lib)
    assert code == 0, err
    assert f"calibration written to {lib} (a variant uses it with material_library: [ours.yaml])" in " ".join(out.split())
    saved = yaml.safe_load(lib.read_text())["calibrations"]
    assert [(c["roller"], c["sphere"]) for c in saved] == [("nylon_66", "steel"), ("urethane_82A", "bowling_ball"),
                                                          ("urethane_84A", "bowling_ball")]
    moduli = [float(c["creep_modulus"].split()[0]) for c in saved[1:]]
    assert moduli == pytest.approx([3.399 / 1.5, 3.399 / 0.8], rel=5e-3)
    assert all("rig.csv (187 rows)" in c["data"] and "diagnose" in c["fit"] for c in saved[1:])
    d["material_library"] = ["ours.yaml"]
    later = figures(write_yaml(tmp_path / "later.yaml", d))
    d.pop("material_library")
    d["effect_parameters"] = {"drive_longitudinal_creep": {"scale": 1.5}, "steering_lateral_creep": {"scale": 0.8}}
    truth = figures(write_yaml(tmp_path / "truth.yaml", d))
    assert later["max_abs_alpha_deg"] == pytest.approx(truth["max_abs_alpha_deg"], rel=3e-3)
    assert cli("diagnose", rig, "--variant", v, "--candidates", "steering_offset", "--save-calibration", lib)[0] == 0
    assert len(yaml.safe_load(lib.read_text())["calibrations"]) == 3


def test_save_calibration_needs_a_fitted_compliance(tmp_path, cli):
    """A base model that fits no creep scale has nothing to save: one line, before any work, nothing written."""
    v = write_yaml(tmp_path / "v.yaml", variant_data("existing_kim"))
    (tmp_path / "rig.csv").write_text("gamma_cmd_deg,omega_1,omega_2,tau_1,tau_2\n10,10,1.7,0.1,-0.5\n")
    code, out, err = cli("diagnose", tmp_path / "rig.csv", "--variant", v, "--base", "steering_offset",
                         "--save-calibration", tmp_path / "lib.yaml")
    assert code == 2 and err.count("\n") == 1 and "--save-calibration: the base model (steering_offset)" in err
    assert not (tmp_path / "lib.yaml").exists()
