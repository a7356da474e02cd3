"""A fresh sample of bad inputs aimed at the newest commands and files (issue 38): capacity, tolerance and its
tolerances file, compare's --points, and the materials library. Each keeps the promise of
test_every_command.py: exit status 2, one line naming the file, field or option, no traceback, nothing
written."""
from __future__ import annotations

import copy

import pytest
import yaml

from conftest import ROOT
from test_every_command import cli, run_and_check


KALKER = ROOT / "variants" / "box.yaml"
CASES = []


def case(id, expect, build):
    CASES.append(pytest.param(build, expect, id=id))


def line(id, expect, *argv):
    case(id, expect, cli(*argv))


# ------------------------------------------------------------------------------------------------ capacity
C = ("capacity", "{v}")
line("capacity: --json under a file", ("--json", "not a folder"), *C, "--json", "{plain}/c.json")
line("capacity: --json in a missing folder", ("--json", "no folder"), *C, "--json", "{tmp}/nowhere/deep/c.json")
line("capacity: --json to /dev/null", ("--json", "character device"), *C, "--json", "/dev/null")
line("capacity: --plots under a file", ("--plots", "lies under"), *C, "--plots", "{plain}/p")
line("capacity: a folder as the variant", ("adir", "cannot read file"), "capacity", "{adir}")
line("capacity: no variant", ("capacity", "variants"), "capacity")
line("capacity: --safety 1e400 (inf)", ("--safety", "finite"), *C, "--safety", "1e400")
line("capacity: a study file as the variant", ("box_placement.yaml", "unknown field"),
     "capacity", "{tmp}/work/studies/box_placement.yaml")
line("capacity: --safety given twice, the last empty", ("argument --safety", "invalid float value: ''"), *C,
     "--safety", "2", "--safety", "")


# ---------------------------------------------------------------------------------------------- tolerance

def tolerances(entries=None, raw=None, **top):
    """`tolerance` on box with in/t.yaml: `raw` text, or {name, seed, tolerances: entries} with `top`."""
    def build(env):
        f = env.inp / "t.yaml"
        data = {"name": "t", "seed": 0, "tolerances": entries if entries is not None else
                [{"dimension": "axle", "rollers": "all", "normal": "0.1 deg"}]} | top
        f.write_text(raw if raw is not None else yaml.safe_dump(data, sort_keys=False))
        return ["tolerance", str(KALKER), "--tolerances", str(f), "--samples", "2", "--store", str(env.out / "s"),
                "--json", str(env.out / "t.json")]
    return build


def entry(**fields):
    return [{"dimension": "axle", "rollers": "all", "normal": "0.1 deg"} | fields]


T = ("tolerance", str(KALKER), "--tolerances", str(ROOT / "tests" / "data" / "box_axle_tolerances.yaml"))
case("tolerance: unknown dimension", ("t.yaml", "axel", "did you mean 'axle'"), tolerances(entry(dimension="axel")))
case("tolerance: unknown roller", ("t.yaml", "Z9"), tolerances(entry(rollers=["Z9"])))
case("tolerance: normal and uniform both", ("t.yaml", "normal", "uniform"), tolerances(entry(uniform="0.1 deg")))
case("tolerance: neither normal nor uniform", ("t.yaml",), tolerances([{"dimension": "axle", "rollers": "all"}]))
case("tolerance: negative σ", ("t.yaml", "normal"), tolerances(entry(normal="-0.1 deg")))
case("tolerance: an axle σ in mm", ("t.yaml", "normal"), tolerances(entry(normal="0.1 mm")))
case("tolerance: a preload ±150 %", ("t.yaml", "uniform"),
     tolerances([{"dimension": "preload", "rollers": "all", "uniform": "150 %"}]))
case("tolerance: a radius ±1 m", ("t.yaml", "uniform"),
     tolerances([{"dimension": "radius", "rollers": "all", "uniform": "1 m"}]))
case("tolerance: no tolerances", ("t.yaml", "tolerances"), tolerances([]))
case("tolerance: seed -1", ("t.yaml", "seed"), tolerances(seed=-1))
case("tolerance: a duplicate key", ("t.yaml", "duplicate key 'seed'"), tolerances(raw="name: t\nseed: 0\nseed: 1\n"
                                                                                     "tolerances: []\n"))
case("tolerance: a fork tolerance on drive rollers", ("t.yaml", "fork"),
     tolerances([{"dimension": "fork", "rollers": "drive", "normal": "0.1 deg"}]))
case("tolerance: contact without along", ("t.yaml", "along"),
     tolerances([{"dimension": "contact", "rollers": "all", "normal": "0.2 mm"}]))
case("tolerance: along on an axle", ("t.yaml", "along"), tolerances(entry(along="rolling")))
case("tolerance: field typo", ("t.yaml", "rolers", "did you mean 'rollers'"),
     tolerances([{"dimension": "axle", "rolers": "all", "normal": "0.1 deg"}]))
line("tolerance: --tolerances missing", ("nope.yaml",), *T[:2], "--tolerances", "{in}/nope.yaml")
line("tolerance: --tolerances a folder", ("adir",), *T[:2], "--tolerances", "{adir}")
line("tolerance: --store is a file", ("--store", "is not a folder"), *T, "--store", "{plain}")
line("tolerance: --json to a directory", ("--json", "is a directory"), *T, "--json", "{adir}")
line("tolerance: --samples 1.5", ("argument --samples",), *T, "--samples", "1.5")
line("tolerance: --workers 0", ("--workers",), *T, "--workers", "0")
line("tolerance: --dimensions-only given a value", ("argument --dimensions-only", "ignored explicit argument 'no'"), *T,
     "--dimensions-only=no")

case("tolerance: name with a space", ("t.yaml", "name"), tolerances(name="my set"))
case("tolerance: shared 'yes'", ("t.yaml", "shared"), tolerances(entry(shared="yes")))
case("tolerance: a σ of nan", ("t.yaml", "normal"), tolerances(entry(normal="nan deg")))
case("tolerance: a list of one unknown and one known roller", ("t.yaml", "N9"), tolerances(entry(rollers=["N1", "N9"])))
case("tolerance: the tolerances file is the variant", ("--tolerances", "existing_kim.yaml is also this command's variant"),
     cli("tolerance", "{v}", "--tolerances", "{v}", "--samples", "2", "--store", "{out}/s"))
case("tolerance: tolerances as a mapping", ("t.yaml", "tolerances"),
     tolerances({"axle": {"normal": "0.1 deg"}}))
line("tolerance: --samples 0", ("--samples",), *T, "--samples", "0")
line("rig: --protocol is the variant", ("--protocol", "existing_kim.yaml is also this command's variant"),
     "rig", "{v}", "--protocol", "{v}", "--out", "{out}/d.csv")
line("optimise: --calibration is the study", ("--calibration", "is also this command's study"),
     "optimise", "{tmp}/work/studies/box_placement.yaml", "--calibration", "{tmp}/work/studies/box_placement.yaml")
line("tolerance: --json is the tolerances file", ("--json", "this command's input"), *T, "--json", T[3])


# ------------------------------------------------------------------------------------------ compare --points
P = ("compare", "{v}", "--out", "{out}/p")
line("compare --points: unknown extension", ("--points", ".txt"), *P, "--points", "{out}/pts.txt")
line("compare --points: a directory", ("--points", "is a directory"), *P, "--points", "{adir}")
line("compare --points: the variant itself", ("--points", "this command's input"), *P, "--points", "{v}")
line("compare --points: under a file", ("--points", "not a folder"), *P, "--points", "{plain}/p.csv")
line("compare --points: no extension", ("--points",), *P, "--points", "{out}/points")
line("compare --points: .csv.gz", ("--points", ".gz"), *P, "--points", "{out}/p.csv.gz")
line("compare --points: the same file as --report", ("--report", "--points"), *P, "--points", "{out}/x.csv",
     "--report", "{out}/x.csv")


# ----------------------------------------------------------------------------------------- materials library

def library(text: str, *, variant_edit=None):
    """compare on existing_kim.yaml naming in/lib.yaml (written as `text`)."""
    def build(env):
        (env.inp / "lib.yaml").write_text(text)
        data = copy.deepcopy(yaml.safe_load((ROOT / "variants" / "existing_kim.yaml").read_text()))
        data["material_library"] = ["lib.yaml"]
        if variant_edit:
            variant_edit(data)
        (env.inp / "v.yaml").write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
        return ["compare", str(env.inp / "v.yaml"), "--out", str(env.out / "p")]
    return build


STEEL = "materials:\n  hard: {youngs_modulus: 200 GPa, poisson_ratio: 0.29}\n"
case("library: not YAML", ("lib.yaml", "not valid YAML"), library("materials: [unclosed\n"))
case("library: top-level typo", ("lib.yaml", "calibration", "did you mean 'calibrations'"),
     library(STEEL + "calibration: []\n"))
case("library: a plain Young's modulus", ("lib.yaml", "youngs_modulus", "did you mean '10.7 MPa'"),
     library("materials:\n  soft: {youngs_modulus: 10.7, poisson_ratio: 0.48}\n"))
case("library: Poisson's ratio 0.6", ("lib.yaml", "poisson_ratio"),
     library("materials:\n  soft: {youngs_modulus: 10 MPa, poisson_ratio: 0.6}\n"))
case("library: materials as a list", ("lib.yaml", "materials"), library("materials: [hard, soft]\n"))
case("library: a duplicate material", ("lib.yaml", "duplicate key 'hard'"), library(STEEL + STEEL[10:]))
case("library: a calibration without fit", ("lib.yaml", "calibrations.0.fit", "missing"),
     library("calibrations:\n  - {roller: urethane_82A, sphere: bowling_ball, creep_modulus: 3 MPa, std: 1 %, "
             "machine: m, data: d}\n"))
case("library: a calibration field typo", ("lib.yaml", "creep_modulos", "did you mean 'creep_modulus'"),
     library("calibrations:\n  - {roller: urethane_82A, sphere: bowling_ball, creep_modulos: 3 MPa, std: 1 %, "
             "machine: m, data: d, fit: f}\n"))
case("library: the variant names itself as its library", ("material_library[0]", "'v.yaml' is the variant itself"),
     lambda env: library("")(env) and _self_library(env))
case("library: a friction of 0", ("lib.yaml", "pairs.0.friction"),
     library("pairs:\n  - {materials: [urethane_82A, bowling_ball], friction: 0, range: [0, 1], source: s}\n"))
case("library: a friction on a material", ("lib.yaml", "slick.friction", "belongs to a pair"),
     library("materials:\n  slick: {youngs_modulus: 200 GPa, poisson_ratio: 0.29, friction: 0.3}\n"))
case("library: a pair's range the wrong way", ("lib.yaml", "pairs.0.range", "low <= friction <= high"),
     library("pairs:\n  - {materials: [urethane_82A, bowling_ball], friction: 0.8, range: [0.9, 0.6], source: s}\n"))
case("library: a pair of one material", ("lib.yaml", "pairs.0.materials", "expected two"),
     library("pairs:\n  - {materials: [urethane_82A], friction: 0.8, range: [0.6, 1.0], source: s}\n"))
case("library: an allowable pressure in N", ("lib.yaml", "allowable_pressure"),
     library("materials:\n  hard: {youngs_modulus: 200 GPa, poisson_ratio: 0.29, "
             "allowable_pressure: 1 N}\n"))
case("library: a calibration as a mapping", ("lib.yaml", "calibrations"),
     library("calibrations: {roller: urethane_82A}\n"))
case("library: not UTF-8", ("lib.yaml", "not UTF-8"), lambda env: _latin1(env))
case("library: a folder", ("material_library[0]",), library("", variant_edit=lambda d: d.update(
    material_library=["."])))


def _latin1(env):
    argv = library(STEEL)(env)
    (env.inp / "lib.yaml").write_bytes(b"# caf\xe9\n" + STEEL.encode())
    return argv


def _self_library(env):
    data = yaml.safe_load((env.inp / "v.yaml").read_text())
    data["material_library"] = ["v.yaml"]
    (env.inp / "v.yaml").write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
    return ["compare", str(env.inp / "v.yaml"), "--out", str(env.out / "p")]


@pytest.mark.parametrize("build, expect", CASES)
def test_bad_input(build, expect, tmp_path, capfd, monkeypatch):
    run_and_check(build, expect, tmp_path, capfd, monkeypatch, 60)


def test_at_least_thirty():
    assert len(CASES) >= 30
