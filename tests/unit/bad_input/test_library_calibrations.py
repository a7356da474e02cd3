"""A materials library's calibrations are checked as its materials are (issue 38).

`std: -1.3 %` in a library calibration was accepted, and the note printed "±-1.3%"; a calibration naming
`sphere: bal` (the library's material is `ball`) was never matched, and silently turned the rollers to THEORY
ONLY, moving the figures about 3×. Now each is one line naming the library file and the field, exit status 2,
nothing written (the promise of test_every_command.py)."""
from __future__ import annotations

import copy

import pytest
import yaml

from conftest import ROOT
from test_every_command import check_promise, deadline, make_env, snapshot

from cvtdesign.cli import main

KALKER = ROOT / "variants" / "existing.yaml"     # under Kalker's law a library calibration applies
BALL = {"youngs_modulus": "2 GPa", "poisson_ratio": 0.35, "allowable_pressure": "60 MPa"}
PAIRS = [{"materials": [m, "ball"], "friction": 0.8, "range": [0.6, 1.0], "source": "assumed"}
         for m in ("urethane_82A", "urethane_84A")]
GOOD = {"roller": "urethane_82A", "sphere": "ball", "creep_modulus": "3.399 MPa", "std": "1.3 %",
        "machine": "our rig", "data": "our data", "fit": "by hand"}


def library_case(env, **calibration) -> list[str]:
    """A variant (existing.yaml on a sphere of `ball`) naming in/lib.yaml, whose one calibration is GOOD with
    `calibration`'s fields; the argv of `compare` on it."""
    lib = {"materials": {"ball": BALL}, "pairs": PAIRS, "calibrations": [GOOD | calibration]}
    (env.inp / "lib.yaml").write_text(yaml.safe_dump(lib, sort_keys=False))
    data = copy.deepcopy(yaml.safe_load(KALKER.read_text()))
    data["sphere"]["material"] = "ball"
    data["material_library"] = ["lib.yaml"]
    (env.inp / "v.yaml").write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
    return ["compare", str(env.inp / "v.yaml"), "--out", str(env.out / "p"), "--json", str(env.out / "c.json")]


CASES = [
    ("sphere material misspelt", {"sphere": "bal"}, ("lib.yaml: calibrations[0].sphere", "unknown material 'bal'",
                                                     "did you mean 'ball'")),
    ("roller material misspelt", {"roller": "urethane_82"}, ("calibrations[0].roller", "did you mean 'urethane_82A'")),
    ("std negative", {"std": "-1.3 %"}, ("lib.yaml: calibrations[0].std", "'-1.3 %' is not a plausible relative "
                                                                          "standard deviation", "more than 0")),
    ("std zero", {"std": "0 %"}, ("calibrations[0].std", "more than 0")),
    ("std above 100 %", {"std": "250 %"}, ("calibrations[0].std", "at most 1")),
    ("std as a plain 1.3", {"std": 1.3}, ("calibrations[0].std", "did you mean '1.3 %'")),
    ("std nan", {"std": "nan %"}, "calibrations[0].std"),
    ("std with a unit of another kind", {"std": "1.3 mm"}, "calibrations[0].std"),
    ("creep modulus as a plain 3.4", {"creep_modulus": 3.4}, ("calibrations[0].creep_modulus", "did you mean '3.4 MPa'")),
    ("creep modulus negative", {"creep_modulus": "-3.4 MPa"}, ("calibrations[0].creep_modulus", "plausible")),
]


@pytest.mark.parametrize("edit, expect", [pytest.param(e, x, id=i) for i, e, x in CASES])
def test_a_bad_library_calibration_is_one_line(edit, expect, tmp_path, capfd, monkeypatch):
    env = make_env(tmp_path)
    monkeypatch.chdir(env.work)
    argv = library_case(env, **edit)
    before = snapshot(tmp_path)
    capfd.readouterr()
    with deadline(60):
        rc = main(argv)
    out, err = capfd.readouterr()
    check_promise(rc, out, err, expect, before, snapshot(tmp_path))


def test_a_good_library_calibration_applies(tmp_path):
    """The same library with its names and numbers right: the drive rollers take its calibration."""
    from cvtdesign.io.variant import load_variant
    env = make_env(tmp_path)
    library_case(env)
    layout = load_variant(env.inp / "v.yaml")
    drive = next(r for r in layout.rollers if r.role == "drive")
    assert drive.creep.kind == "library" and drive.creep.std == pytest.approx(0.013), drive.creep
