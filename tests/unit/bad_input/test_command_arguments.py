"""Bad arguments of single commands (a file or an option that the command itself refuses): one line on
stderr naming the argument, exit status 2, nothing written. (Every command's bad inputs in one table:
test_every_command.py.)"""
import re

import pytest

from conftest import ROOT, variant_path

from cvtdesign.cli import main

EXISTING = variant_path("existing_kim")


# ----------------------------------------------------------------------------------------------------- rig

BAD_RIG = {
    "unknown effect": (["--effects", "steering_lateral_crep"], r"--effects: unknown effect 'steering_lateral_crep' \(did you mean 'steering_lateral_creep'\?\)"),
    "unknown parameter": (["--set", "steering_lateral_creep.scal=2"], r"--set: effect steering_lateral_creep has no parameter 'scal'"),
    "effect not on": (["--set", "steering_offset.offset=1 deg"], r"--set: steering_offset.offset is set but steering_offset is not among the effects"),
    "bad unit": (["--effects", "steering_offset", "--set", "steering_offset.offset=1 N"], r"--set: steering_offset.offset: expected an angle like '10 deg', got '1 N'"),
    "bad noise": (["--noise", "sped=0.1"], r"--noise: expected name=value with names speed, torque, axis, got 'sped=0.1' \(did you mean 'speed'\?\)"),
}


@pytest.mark.parametrize("case", BAD_RIG)
def test_rig_bad_input(case, tmp_path, capsys):
    args, pattern = BAD_RIG[case]
    out = tmp_path / "d.csv"
    assert main(["rig", str(EXISTING), "--out", str(out), *args]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert re.search(pattern, err), err
    assert not out.exists()


# ---------------------------------------------------------------------------------------------------- show

def test_bad_file_is_one_line_and_writes_nothing(cli, make_variant, tmp_path):
    bad = make_variant("existing_kim", lambda d: d["rollers"]["D1"].update(radius="forty mm"), file="bad")
    code, out, err = cli("show", bad, "--out", tmp_path / "out")
    assert code == 2 and out == ""
    assert len(err.splitlines()) == 1 and err.startswith(f"cvtdesign: error: {bad}: rollers.D1.radius")
    assert "Traceback" not in err and not (tmp_path / "out").exists()


def test_gamma_outside_the_envelope_is_refused(cli, tmp_path):
    code, _, err = cli("show", ROOT / "variants/existing_kim.yaml", "--gamma", 95, "--out", tmp_path / "out")
    assert code == 2 and len(err.splitlines()) == 1 and "--gamma" in err and not (tmp_path / "out").exists()


# ------------------------------------------------------------------------------------------------- resteer

def test_resteer_bad_truth_set_is_one_line(cli, tmp_path):
    rc, _, err = cli("resteer", "--variant", EXISTING, "--truth-set", "steering_offset.offset=1 deg",
                     "--json", tmp_path / "r.json")
    assert rc == 2 and err.count("\n") == 1 and "--truth-set" in err
    assert not (tmp_path / "r.json").exists()


# ---------------------------------------------------------------------------------------- compare --points

@pytest.mark.parametrize("name", ["p.txt", "p"])
def test_an_unknown_format_is_one_line(tmp_path, capsys, name):
    assert main(["compare", str(ROOT / "variants/box_kim.yaml"), "--out", str(tmp_path), "--points", str(tmp_path / name)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--points" in err and ".csv or .parquet" in err
    assert not (tmp_path / name).exists()
