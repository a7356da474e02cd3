"""Bad variant files: one line naming the file and field, exit status 2, no traceback, nothing written."""
import re

import pytest

from conftest import variant_path

from cvtdesign.cli import main

EXISTING = variant_path("existing_kim")


def edited(tmp_path, *pairs, name="bad.yaml"):
    text = EXISTING.read_text()
    for old, new in pairs:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / name
    path.write_text(text)
    return path


S1 = "S1: {role: steering, contact: c1, axle: c2,"
S2 = "S2: {role: steering, contact: c2, axle: c1,"
FORK2 = "{rollers: [S2], axis: c2, sign: -1}"
CASES = {
    "unknown key": ([("radius: 40 mm, crown", "radus: 40 mm, crown")],
                    r"rollers\.D1\.radus: unknown field \(did you mean 'radius'\?\)"),
    "missing field": ([("sphere: {radius: 63.5 mm, material: bowling_ball}", "")], r"sphere: missing required field"),
    "zero radius": ([("axle: -d1, radius: 40 mm", "axle: -d1, radius: 0 mm")],
                    r"rollers\.D1\.radius: expected a positive radius, got 0"),
    "negative radius": ([("axle: -d1, radius: 40 mm", "axle: -d1, radius: -4 cm")],
                        r"rollers\.D1\.radius: expected a positive radius, got -0\.04"),
    "wrong unit": ([("axle: -d1, radius: 40 mm", "axle: -d1, radius: 40 N")],
                   r"rollers\.D1\.radius: expected a length like '40 mm', got '40 N'"),
    "axle not perpendicular": ([("contact: d2, axle: -d1", "contact: d2, axle: [1, 0, 0]")],
                               r"rollers\.D1\.axle: not perpendicular to the contact normal"),
    "overlapping rollers": ([(S2, "S2: {role: steering, contact: c1, axle: c2,"), (FORK2, "{rollers: [S2], axis: c1, sign: 1}")],
                            r"rollers\.S1, rollers\.S2: the two rollers overlap"),
    "steering cannot fix an axis": ([(S1, "S1: {role: steering, contact: -x, axle: y,"), ("axis: c1, sign: 1", "axis: -x, sign: 1"),
                                     (S2, "S2: {role: steering, contact: x, axle: y,"), (FORK2, "{rollers: [S2], axis: x, sign: 1}")],
                                    r"steering: the steering rollers cannot fix the sphere's axis"),
    "unknown effect": ([("effects: [drive_longitudinal_creep,", "effects: [drive_longitudinal_crep,")],
                       r"effects: unknown effect 'drive_longitudinal_crep' \(did you mean 'drive_longitudinal_creep'\?\)"),
    "unknown material": ([("crown_radius: 15 mm, material: urethane_82A}", "crown_radius: 15 mm, material: urethane_82B}")],
                         r"rollers\.D1\.material: unknown material 'urethane_82B' \(did you mean 'urethane_82A'\?\)"),
}


@pytest.mark.parametrize("case", CASES)
def test_bad_variant_one_line_exit_2(case, tmp_path, capsys):
    pairs, pattern = CASES[case]
    path = edited(tmp_path, *pairs)
    out = tmp_path / "plots"
    assert main(["compare", str(path), "--out", str(out), "--json", str(tmp_path / "f.json")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"cvtdesign: error: {path}: ")
    assert re.search(pattern, err), err
    assert not out.exists() and not (tmp_path / "f.json").exists()


def test_not_yaml(tmp_path, capsys):
    path = tmp_path / "broken.yaml"
    path.write_text("name: [unclosed\n  rollers: x\n")
    assert main(["compare", str(path)]) == 2
    err = capsys.readouterr().err
    assert re.fullmatch(rf"cvtdesign: error: {re.escape(str(path))}: not valid YAML \(line 2\): .+\n", err)


def test_missing_file(tmp_path, capsys):
    assert main(["compare", str(tmp_path / "nope.yaml")]) == 2
    assert "cannot read file" in capsys.readouterr().err
