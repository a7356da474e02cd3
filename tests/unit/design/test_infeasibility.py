"""Optimisers that say why: a study with no feasible design names the constraint family, the part and the
margin (design.infeasibility), and a batch study groups its failed cases by that reason."""
from __future__ import annotations

import json

import pandas as pd
import pytest

from conftest import variant_data, write_yaml
from cvtdesign.cli.study import failure_note

SMALL = {"gamma": {"start": "-60 deg", "stop": "60 deg", "step": "60 deg"},
         "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "1 N*m"}}


def _study(tmp_path, **constraints):
    box = variant_data("box_kim")
    box["parameters"]["r_drive"] = "45 mm"          # fixed: R + 2 r = 63.5 + 90 = 153.5 mm
    data = {"name": "t", "base": str(write_yaml(tmp_path / "box45.yaml", box)), "envelope": SMALL,
            "design": {"d": {"lower": "30 mm", "upper": "110 mm"}, "r_steer": {"lower": "20 mm", "upper": "60 mm"}},
            "constraints": constraints, "multistart": {"starts": 2}}
    return write_yaml(tmp_path / "study.yaml", data)


def test_an_envelope_radius_no_design_meets_names_the_roller(tmp_path, cli):
    """The issue's case: a fixed 45 mm drive roller reaches 153.5 mm, the study allows 120 mm. IPOPT says only
    Infeasible_Problem_Detected; optimise names the family, the roller and the margin, for every design."""
    code, out, _ = cli("optimise", _study(tmp_path, envelope_radius="120 mm"), "--out", tmp_path / "o",
                       "--json", tmp_path / "r.json")
    flat = " ".join(out.split())
    assert code != 0 and "Infeasible_Problem_Detected" in flat
    assert "cannot be met: envelope_radius: extent of A reaches 153.5 mm > 120 mm for every design within the " \
           "bounds (also extent of A_, extent of B, extent of B_)" in flat
    unmet = json.loads((tmp_path / "r.json").read_text())["unmet_constraints"]
    assert [(u["family"], u["where"], u["unit"], u["every_design"]) for u in unmet] == \
        [("envelope_radius", "extent of A", "mm", True)]
    assert unmet[0]["value"] == pytest.approx(153.5, rel=1e-9) and unmet[0]["bound"] == pytest.approx(120.0)


def test_a_design_row_some_design_meets_is_not_named(tmp_path, cli):
    """With 150 mm allowed, only the drive rollers (fixed) miss: a steering roller, whose radius is free, is
    named nowhere, since r_steer = 20 mm meets it; and the clearance (met by some designs) is not named."""
    code, out, _ = cli("optimise", _study(tmp_path, envelope_radius="150 mm"), "--out", tmp_path / "o")
    flat = " ".join(out.split())
    assert "extent of A reaches 153.5 mm > 150 mm for every design" in flat
    assert "extent of N1" not in flat and "clearance" not in flat.split("cannot be met")[1]


def test_a_point_row_says_where_it_was_evaluated(tmp_path, cli):
    """A traction margin of 0.99 (|F| ≤ 0.01 μN) that no loaded contact can keep: the family and the contact are
    named, at the designs evaluated (the base and the corners of the bounds), not 'for every design'."""
    code, out, _ = cli("optimise", _study(tmp_path, traction_margin=0.99), "--out", tmp_path / "o")
    flat = " ".join(out.split())
    assert code != 0
    line = next(p for p in flat.split("cannot be met: ")[1:] if p.startswith("traction:"))
    assert "at the base design and at every corner of the bounds" in line and "every design within" not in line


def test_study_groups_failed_cases_by_reason():
    """Failed cases of one family and part, with different margins, are one group with its count; a case with
    no named reason is grouped by its status."""
    df = pd.DataFrame({"case_id": ["a", "b", "c", "d"], "success": [False] * 4,
                       "status": ["Infeasible_Problem_Detected"] * 3 + ["Maximum_Iterations_Exceeded"],
                       "reason": ["envelope_radius: extent of A reaches 153.5 mm > 120 mm for every design within "
                                  "the bounds", "envelope_radius: extent of A reaches 155.5 mm > 120 mm for every "
                                  "design within the bounds", "envelope_radius: extent of A reaches 153.5 mm > 120 "
                                  "mm for every design within the bounds", ""]})
    text = failure_note(df).text
    assert text.startswith("no case succeeded: all 4 cases failed: envelope_radius: extent of A ×3 (e.g. reaches ")
    assert "Maximum_Iterations_Exceeded ×1" in text
