"""api.diagnose: rig data as a DataFrame is checked as a CSV's rows are, and diagnosed as `cvtdesign diagnose`
diagnoses the file (the same JSON, but for the run's seconds)."""
import json

import numpy as np
import pandas as pd
import pytest

from conftest import ROOT

from cvtdesign import api
from cvtdesign.cli import main
from cvtdesign.errors import InputError
from cvtdesign.io.measured_csv import read_measured, read_measured_frame

RIG = ROOT / "examples" / "data" / "kim_rig.csv"      # `cvtdesign rig variants/existing_kim.yaml --seed 1`
VARIANT = ROOT / "variants" / "existing_kim.yaml"


def test_a_data_frame_is_read_as_its_csv():
    rows, dropped = read_measured(RIG, (-80, 80))
    frame_rows, frame_dropped = read_measured_frame(pd.read_csv(RIG), "frame", (-80, 80))
    pd.testing.assert_frame_equal(rows, frame_rows)
    assert dropped == frame_dropped == {}


@pytest.mark.parametrize("edit, match", [
    (lambda f: f.drop(columns="tau_2"), "frame: missing column 'tau_2'"),
    (lambda f: f.assign(tau_1=np.where(f.index == 3, np.nan, f.tau_1)), "frame: line 5: "),
    (lambda f: f.assign(gamma_cmd_deg=f.gamma_cmd_deg + 200), "outside the variant's range"),
])
def test_a_bad_data_frame_is_refused_in_one_line(edit, match):
    with pytest.raises(InputError, match=match) as e:
        read_measured_frame(edit(pd.read_csv(RIG)), "frame", (-80, 80))
    assert "\n" not in str(e.value)


def test_diagnose_refuses_unknown_effects_and_a_candidate_in_the_base():
    with pytest.raises(InputError, match="base: unknown effect"):
        api.diagnose(VARIANT, RIG, base=["drive_creep"])
    with pytest.raises(InputError, match="already in the base model"):
        api.diagnose(VARIANT, RIG, base=["drive_longitudinal_creep"], candidates=["drive_longitudinal_creep"])


@pytest.mark.slow
def test_diagnose_gives_the_commands_json(tmp_path):
    assert main(["diagnose", str(RIG), "--variant", str(VARIANT), "--base", "drive_longitudinal_creep",
                 "--json", str(tmp_path / "d.json")]) == 0
    result = api.diagnose(VARIANT, pd.read_csv(RIG), base=["drive_longitudinal_creep"])
    ours, theirs = json.loads(result.to_json()), json.loads((tmp_path / "d.json").read_text())
    assert ours.pop("seconds") > 0 and theirs.pop("seconds") > 0
    assert ours == theirs
    assert result.report.verdict == "steering_lateral_creep"
    assert result.table["effect"].iloc[0] == "steering_lateral_creep"
    folder = result.plot(tmp_path / "figures")
    assert (folder / "residual_map.png").stat().st_size > 10_000 and (folder / "fit.png").stat().st_size > 10_000
