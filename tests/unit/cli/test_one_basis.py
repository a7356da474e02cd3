"""One physical basis for every figure (issue 'Figures a designer can bet on'), as a user meets it through
`compare`: a design of PU-95A rollers takes μ from its pair and a transferred calibration (never 'fitted'),
Kim's constants left in place for other materials are refused, and an ordering is claimed only where the
intervals resolve it."""
from __future__ import annotations

import json

import pandas as pd
import pytest

from conftest import variant_data, write_yaml
from cvtdesign.cli import main

KIM_CONSTANTS = {"law": "kim", "creep_drive": "0.0038 1/N", "creep_steering": "0.0049 1/N",
                 "creep_reference_force": "100 N",
                 "fitted_on": {"drive": ["urethane_82A", "bowling_ball"], "steering": ["urethane_84A", "bowling_ball"]}}


def pu95(sphere="bowling_ball", contact=None, name="pu95", coarse=True):
    """The box's layout with every roller of PU 95A, on `sphere`, with `contact` (None: the default basis)."""
    d = variant_data("box")
    d["name"] = name
    for r in d["rollers"].values():
        r["material"] = "urethane_95A"
    d["sphere"]["material"] = sphere
    if contact is not None:
        d["contact"] = contact
    if coarse:
        d["envelope"]["gamma"]["step"] = "20 deg"
        d["envelope"]["load"]["step"] = "0.25 N*m"
    return d


def compare(tmp_path, *variants, extra=()):
    files = [str(write_yaml(tmp_path / f"{d['name']}.yaml", d)) for d in variants]
    out = tmp_path / "c.json"
    assert main(["compare", *files, "--out", str(tmp_path / "p"), "--json", str(out), *extra]) == 0
    return json.loads(out.read_text())


@pytest.mark.slow
def test_pu95_on_steel_takes_mu_from_its_pair(tmp_path, capsys):
    """PU 95A on steel runs at the pair's μ (0.6, not the smaller of two materials' values: steel's 0.15 sent
    128 of 357 points into gross slip), and its calibration is transferred from the urethanes', never fitted."""
    got = compare(tmp_path, pu95("steel"), extra=["--points", str(tmp_path / "pts.csv"), "--samples", "0"])
    row = got["variants"][-1]
    assert row["calibration"]["kind"] == "transferred" and "fitted" not in row["calibration"]["cell"]
    pts = pd.read_csv(tmp_path / "pts.csv")
    assert (pts[pts.variant == "pu95"].mu >= 0.4).all()
    assert row["gross_slip"] == 0


def test_kims_constants_left_in_for_other_materials_are_refused(tmp_path, capsys):
    """Kim's fitted constants belong to urethane on his ball: a PU-95A design that keeps them is refused in one
    line naming the roller, its pair and the constants' pair (it never prints 'own ε (fitted)')."""
    f = write_yaml(tmp_path / "v.yaml", pu95(contact=KIM_CONSTANTS))
    assert main(["compare", str(f), "--out", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "urethane_95A on bowling_ball" in err and "fitted for urethane_82A" in err
    assert not (tmp_path / "p").exists()


@pytest.mark.slow
def test_a_transferred_calibration_holds_the_spread_measured_on_kims_machine(tmp_path):
    """PU 95A on the bowling ball: a transferred best estimate whose max |α| interval holds both 3.1× and 3.6×
    the theory's figure (Hertz + Kalker alone is 3.1–3.6× too stiff on Kim's machine)."""
    theory = pu95(contact={"calibration": {"drive": 1, "steering": 1}}, name="theory")
    got = compare(tmp_path, pu95(), theory)
    best, bare = got["variants"]
    assert best["calibration"]["kind"] == "transferred" and bare["calibration"]["uncalibrated"]
    lo, hi = best["max_abs_alpha_deg_interval"]
    assert lo <= 3.1 * bare["max_abs_alpha_deg"] and 3.6 * bare["max_abs_alpha_deg"] <= hi, (lo, hi, bare)


@pytest.mark.slow
def test_no_ordering_is_claimed_between_existing_and_a_101_N_copy(tmp_path):
    """existing.yaml against a copy whose preloads are 101 N: the difference is far inside what the inputs
    leave open, so no ordering is resolved, and each says P and what would settle it."""
    a, b = variant_data("existing"), variant_data("existing")
    b["name"], b["parameters"]["preload"] = "existing_101N", "101 N"
    for d in (a, b):
        d["envelope"]["gamma"]["step"] = "20 deg"
        d["envelope"]["load"]["step"] = "0.25 N*m"
    got = compare(tmp_path, a, b)
    assert got["orderings"] and not any(o["resolved"] for o in got["orderings"])
    assert all(0.5 <= o["p_better"] < 0.975 for o in got["orderings"])


def test_optimise_says_when_kims_law_lets_a_radius_run_to_its_bound():
    """Optimising the box under Kim's law shrank the steering rollers to their 20 mm bound without a word; the
    law's fitted constants do not depend on a roller's radius. Now the optimum says so, under that law only."""
    from conftest import ROOT
    from cvtdesign.cli.optimise import law_notes
    from cvtdesign.design.study_file import load_study
    variables = {"r_steer": ("length", 0.020, 0.045), "d": ("length", 0.030, 0.11)}
    res = {"success": True, "design": {"r_steer": 0.020, "d": 0.0319}}
    kim = law_notes(load_study(ROOT / "studies" / "box_placement_kim.yaml"), res, variables)
    assert len(kim) == 1 and kim[0].text.startswith("r_steer ended on its bound under contact law kim")
    assert law_notes(load_study(ROOT / "studies" / "box_placement.yaml"), res, variables) == []
