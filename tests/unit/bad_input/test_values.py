"""Every bad input: ONE line on stderr naming the file, the field or row and what was expected, exit status 2,
no traceback, nothing written. The CLI is called in-process (cvtdesign.cli.main); bad variants are
variants/existing_kim.yaml loaded, edited and dumped (or raw text for cases below the YAML level). Most cases
fail before any model is compiled, so the module runs in seconds.

Also: the shipped variants and studies still load, and `compare variants/box_kim.yaml` gives its figures."""
import copy
import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from conftest import ROOT

from cvtdesign.diagnosis import measured
from cvtdesign.diagnosis import rig
from cvtdesign.cli import main
from cvtdesign.errors import InputError
from cvtdesign.io.units import to_si
from cvtdesign.io.variant import load_variant, quantity

EXISTING = ROOT / "variants" / "existing_kim.yaml"
BOX = ROOT / "variants" / "box_kim.yaml"
UNEQUAL = ROOT / "variants" / "unequal_kim.yaml"
# the shipped studies: optimisation studies, and tolerance studies (a `tolerances:` list; cvtdesign tolerance)
TOLERANCE_STUDIES = [f for f in sorted((ROOT / "studies").glob("*.yaml")) if "tolerances" in yaml.safe_load(f.read_text())]
# duty cycles (points or a task log; cvtdesign life --duty) are read by io.duty_file, not as studies
DUTY_FILES = [f for f in sorted((ROOT / "studies").glob("*.yaml")) if {"points", "log"} & set(yaml.safe_load(f.read_text()))]
STUDIES = [f for f in sorted((ROOT / "studies").glob("*.yaml")) if f not in TOLERANCE_STUDIES + DUTY_FILES]
INF, NAN = float("inf"), float("nan")


# ---------------------------------------------------------------------------------------------- builders

def _set(data, path, value):
    node = data
    for k in path[:-1]:
        node = node[k] if isinstance(node, list) else node.setdefault(k, {})
    node[path[-1]] = value


def variant(*edits, base=EXISTING):
    """A builder: the base variant with `edits` ((path, value) pairs) dumped to tmp/bad.yaml; compared."""
    def build(tmp):
        data = copy.deepcopy(yaml.safe_load(base.read_text()))
        for path, value in edits:
            _set(data, path, value)
        f = tmp / "bad.yaml"
        f.write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
        return ["compare", str(f), "--out", str(tmp / "out" / "plots"), "--json", str(tmp / "out" / "c.json")], f
    return build


def raw_variant(content):
    """A builder: a variant file with this text or these bytes (a function of the shipped text), compared."""
    def build(tmp):
        f = tmp / "bad.yaml"
        data = content(EXISTING.read_text()) if callable(content) else content
        (f.write_bytes if isinstance(data, bytes) else f.write_text)(data)
        return ["compare", str(f), "--out", str(tmp / "out" / "plots"), "--json", str(tmp / "out" / "c.json")], f
    return build


def study(**fields):
    """A builder: studies/box_placement_kim.yaml with `fields` merged into its sections; optimised."""
    def build(tmp):
        data = yaml.safe_load((ROOT / "studies" / "box_placement_kim.yaml").read_text())
        data["base"] = str(BOX)
        for k, v in fields.items():
            if isinstance(v, dict) and isinstance(data.get(k), dict):
                data[k] = {**data[k], **v}
            else:
                data[k] = v
        f = tmp / "bad_study.yaml"
        f.write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
        return ["optimise", str(f), "--out", str(tmp / "out" / "res"), "--json", str(tmp / "out" / "o.json")], f
    return build


HEADER = "gamma_cmd_deg,omega_1,omega_2,tau_1,tau_2\n"
ROWS = "".join(f"{g},10,{10 * math.tan(math.radians(g)):.5f},{t},{t}\n"
               for g in range(-60, 61, 20) for t in (-0.5, 0.0, 0.5))      # 21 operating points


def csv(content):
    """A builder: a measured-data file with this text or these bytes, diagnosed against existing_kim.yaml."""
    def build(tmp):
        f = tmp / "data.csv"
        (f.write_bytes if isinstance(content, bytes) else f.write_text)(content)
        return ["diagnose", str(f), "--variant", str(EXISTING), "--json", str(tmp / "out" / "r.json"),
                "--plots", str(tmp / "out" / "plots")], f
    return build


def cli(*args):
    """A builder: a command line; {out} is the output folder, {existing} the shipped variant. (The pattern
    names the argument; a message about a file names the file.)"""
    def build(tmp):
        return [a.format(out=tmp / "out", existing=EXISTING) for a in args], None
    return build


RD = ("rollers", "D1")
MAT = ("materials", "urethane_82A")
EP = ("effect_parameters",)

# description → (builder, pattern the one line must match: the field and what was expected)
CASES = {
    # ---- non-finite values
    "sphere radius .inf": (variant((("sphere", "radius"), INF)), r"sphere\.radius: expected a finite length"),
    "roller radius .inf": (variant((RD + ("radius",), INF)), r"rollers\.D1\.radius: expected a finite length"),
    "crown radius .inf": (variant((RD + ("crown_radius",), INF)), r"rollers\.D1\.crown_radius: expected a finite"),
    "mount stiffness .inf": (variant((("roller_defaults", "mount_stiffness"), INF)),
                             r"roller_defaults\.mount_stiffness: expected a finite stiffness"),
    "preload .inf": (variant((RD + ("preload",), INF)), r"rollers\.D1\.preload: expected a finite force"),
    "Young's modulus .inf": (variant((MAT + ("youngs_modulus",), INF)), r"urethane_82A\.youngs_modulus: expected a finite"),
    "friction .inf": (variant((("pairs", 0, "friction"), INF)), r"pairs\.0\.friction: expected a finite"),
    "friction on a material": (variant((MAT + ("friction",), 0.8)), r"urethane_82A\.friction: friction belongs to a pair"),
    "nan in a contact vector": (variant((RD + ("contact",), [NAN, 1.0, 0.0])),
                                r"rollers\.D1\.contact: expected a non-zero vector of 3 finite numbers"),
    "envelope.gamma.stop .inf": (variant((("envelope", "gamma", "stop"), INF)), r"envelope\.gamma\.stop: expected a finite angle"),
    "1e-9 deg envelope step": (variant((("envelope", "gamma", "step"), "1e-9 deg")),
                               r"envelope\.gamma\.step: .*expected at most 100000 points per envelope axis"),
    "1e-12 N*m load step": (variant((("envelope", "load", "step"), "1e-12 N*m")), r"envelope\.load\.step: .*at most 100000"),
    "'= 1/0'": (variant((("parameters", "preload"), "= 1/0")), r"parameters\.preload: expression '= 1/0' divides by zero"),
    "'= 10**400'": (variant((("parameters", "preload"), "= 10**400")), r"parameters\.preload: expression '= 10\*\*400' overflows"),
    "'= sqrt(-1)' in a field": (variant((RD + ("radius",), "= sqrt(-1)")), r"rollers\.D1\.radius: expression .* gives nan"),
    "a power tower in a unit": (variant((RD + ("radius",), "1 m**9**9**9")), r"rollers\.D1\.radius: expected a length like '40 mm'"),
    # ---- the file itself
    "20,000-deep nested list": (raw_variant("name: " + "[" * 20000 + "]" * 20000 + "\n"),
                                r"not valid YAML \(line 1\): collections nested more than 50 deep"),
    "non-UTF-8 bytes": (raw_variant(lambda t: t.encode().replace(b"Kim's", b"Kim\xff\xfe")),
                        r"line \d+: not UTF-8 text \(byte 0xff\)"),
    "file over 10 MB": (raw_variant(lambda t: t + "#" + "x" * (10 * 2**20) + "\n"), r"larger than 10 MB"),
    "YAML integer of 5000 digits": (raw_variant(lambda t: t.replace("radius: 63.5 mm", "radius: 1" + "0" * 5000)),
                                    r"(not valid YAML|sphere\.radius)"),
    "aliases expanding to 10^9 nodes": (raw_variant("a: &a [1,1,1,1,1,1,1,1,1,1]\n" + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join(['*' + chr(97 + i)] * 10)}]\n" for i in range(8))),
        r"aliases expand to more than 1000000 YAML nodes"),
    "duplicate roller key": (raw_variant(lambda t: t.replace("  S1: {role: steering", "  D1: {role: drive, shaft: 1, contact: "
                                                             "d2, axle: -d1, radius: 30 mm, material: urethane_82A}\n  S1: {role: steering")),
                             r"not valid YAML \(line \d+\): duplicate key 'D1' \(first on line \d+\)"),
    "a name that is a path": (variant((("name",), "../../evil")), r": name: expected a name of letters, digits"),
    "line break in a key": (variant((("rollers", "D1", "radi\nus"), "40 mm")), r"rollers\.D1\.radi\\nus: unknown field"),
    # ---- booleans are not numbers
    "sphere.radius: true": (variant((("sphere", "radius"), True)), r"sphere\.radius: expected a number .*got true"),
    "shaft: true": (variant((RD + ("shaft",), True)), r"rollers\.D1\.shaft: expected a number .*got true"),
    "axle [true, 0, 0]": (variant((RD + ("axle",), [True, 0, 0])), r"rollers\.D1\.axle"),
    # ---- physical ranges
    "allowable_pressure < 0": (variant((MAT + ("allowable_pressure",), "-6 MPa")),
                               r"urethane_82A\.allowable_pressure: expected a positive pressure"),
    "allowable_pressure = 0": (variant((MAT + ("allowable_pressure",), "0 MPa")),
                               r"urethane_82A\.allowable_pressure: expected a positive pressure"),
    "rolling-resistance offset < 0": (variant((EP, {"rolling_resistance": {"offset": "-0.1 mm"}})),
                                      r"effect_parameters\.rolling_resistance\.offset: .* \(expected more than 0 mm\)"),
    "rolling-resistance offset = 0": (variant((EP, {"rolling_resistance": {"offset": 0}})),
                                      r"effect_parameters\.rolling_resistance\.offset: .*expected more than 0"),
    "rolling-resistance offset 10 mm": (variant((EP, {"rolling_resistance": {"offset": "10 mm"}})),
                                        r"rolling_resistance\.offset: .*expected at most 5 mm"),
    "creep scale < 0": (variant((EP, {"drive_longitudinal_creep": {"scale": -1}})),
                        r"effect_parameters\.drive_longitudinal_creep\.scale: .*expected more than 0"),
    "creep scale = 0": (variant((EP, {"steering_lateral_creep": {"scale": 0}})),
                        r"effect_parameters\.steering_lateral_creep\.scale: .*expected more than 0"),
    "μ scale = 0": (variant((EP, {"traction_saturation": {"mu_scale": 0}})),
                    r"effect_parameters\.traction_saturation\.mu_scale: .*expected at least 0\.05"),
    "μ scale < 0": (variant((EP, {"traction_saturation": {"mu_scale": -0.5}})),
                    r"effect_parameters\.traction_saturation\.mu_scale: .*expected at least 0\.05"),
    "Poisson ratio 0.5": (variant((MAT + ("poisson_ratio",), 0.5)), r"urethane_82A\.poisson_ratio: expected 0 <= ν < 0\.5"),
    "Poisson ratio < 0": (variant((MAT + ("poisson_ratio",), -0.1)), r"urethane_82A\.poisson_ratio: expected 0 <= ν < 0\.5"),
    # ---- plain numbers are SI: implausible ones get the unit they probably meant
    "roller radius 45 (m)": (variant((RD + ("radius",), 45)),
                             r"rollers\.D1\.radius: 45 m is not a plausible roller radius .*did you mean '45 mm'\?"),
    "sphere radius 63.5 (m)": (variant((("sphere", "radius"), 63.5)), r"sphere\.radius: 63\.5 m is not .*'63\.5 mm'"),
    "preload 2e5 N": (variant((RD + ("preload",), 2e5)), r"rollers\.D1\.preload: 200000 N is not a plausible preload"),
    "Young's modulus 10.7 (Pa)": (variant((MAT + ("youngs_modulus",), 10.7)),
                                  r"urethane_82A\.youngs_modulus: 10\.7 Pa is not .*did you mean '10\.7 MPa'\?"),
    "envelope γ 80 (rad)": (variant((("envelope", "gamma", "stop"), 80)),
                            r"envelope\.gamma\.stop: 80 rad is not a plausible transmission angle γ \(expected at most 180 "
                            r"deg\); did you mean '80 deg'\?"),
    # ---- study files
    "clearance 2 kg": (study(constraints={"clearance": "2 kg"}), r"constraints\.clearance: expected a length"),
    "bounds 30 mm .. 0.2 kg": (study(design={"d": {"lower": "30 mm", "upper": "0.2 kg"}}),
                               r"design\.d\.upper: '0\.2 kg' is a mass but the variant's parameter d is a length"),
    "force bounds on a length": (study(design={"d": {"lower": "30 N", "upper": "40 N"}}),
                                 r"design\.d\.lower: '30 N' is a force .* is a length"),
    "plain bounds on a length": (study(design={"d": {"lower": 30, "upper": 110}}),
                                 r"design\.d\.lower: '30' is a plain number .* is a length"),
    "envelope_radius 2 kg": (study(constraints={"envelope_radius": "2 kg"}), r"constraints\.envelope_radius: expected a length"),
    "traction_margin 1": (study(constraints={"traction_margin": 1}), r"constraints\.traction_margin: .*expected less than 1"),
    "traction_margin < 0": (study(constraints={"traction_margin": -0.1}), r"constraints\.traction_margin: .*expected at least 0"),
    "traction_margin 2 mm": (study(constraints={"traction_margin": "2 mm"}), r"constraints\.traction_margin: expected a plain number"),
    "inverted bounds": (study(design={"d": {"lower": "90 mm", "upper": "40 mm"}}), r"design\.d: inverted bounds"),
    "negative clearance": (study(constraints={"clearance": "-2 mm"}), r"constraints\.clearance: .*expected at least 0 mm"),
    "clearance 2 (m)": (study(constraints={"clearance": 2}), r"constraints\.clearance: 2 m is not .*did you mean '2 mm'\?"),
    "bound .inf": (study(design={"d": {"lower": "30 mm", "upper": INF}}), r"design\.d\.upper: expected a finite"),
    "clearance nan": (study(constraints={"clearance": "nan mm"}), r"constraints\.clearance: expected a finite length"),
    "duty-cycle γ in N": (study(objective={"kind": "power_loss", "duty_cycle": [{"gamma": "30 N", "load": "1 N*m"}]}),
                          r"objective\.duty_cycle\[0\]\.gamma: expected an angle"),
    "study name that is a path": (study(name="../x"), r"bad_study\.yaml: name: expected a name of letters"),
    "starts: true": (study(multistart={"starts": True}), r"multistart\.starts: expected a number"),
    "sweep value of the wrong kind": (study(batch={"sweep": {"preload": ["100 mm"]}}),
                                      r"batch\.sweep\.preload\[0\]: '100 mm' is a length .* is a force"),
    # ---- measured data
    "inf cell": (csv(HEADER + ROWS + "0,10,inf,0.1,0.1\n"), r"line 23: column 'omega_2': 'inf' is not a finite number"),
    "one-row CSV": (csv(HEADER + "30,10,5.77,0.1,0.1\n"), r"1 operating point \(1 row\); expected at least 10 "),
    "nine operating points": (csv(HEADER + "".join(ROWS.splitlines(keepends=True)[:9])), r"9 operating points .*at least 10"),
    "non-UTF-8 CSV": (csv((HEADER + ROWS).encode() + b"0,10,\xff\xfe,1,1\n"), r"line 23: not a readable CSV file \(byte 0xff is not UTF-8"),
    "binary file as CSV": (csv(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256))),
                           r"line 1: not a readable CSV file \(byte 0x89 is not UTF-8"),
    "NUL bytes in a CSV": (csv(HEADER + "0,10,\x00\x01,1,1\n"), r"line 2: not a readable CSV file \(a NUL byte"),
    "a YAML file as CSV": (cli("diagnose", "{existing}", "--variant", "{existing}", "--json", "{out}/r.json"),
                           r"existing_kim\.yaml: not a readable CSV file"),
    # ---- bounded command-line values
    "resteer --load nan": (cli("resteer", "--variant", "{existing}", "--load", "nan N*m", "--json", "{out}/r.json"),
                           r"--load: expected a finite torque"),
    "resteer --load 1000 N*m": (cli("resteer", "--variant", "{existing}", "--load", "1000 N*m", "--json", "{out}/r.json"),
                                r"--load: τ⊥ = 1000 N·m is outside the variant's envelope load range -1\.\.1 N·m"),
    "resteer --load -1.5": (cli("resteer", "--variant", "{existing}", "--load", "-1.5", "--json", "{out}/r.json"),
                            r"--load: τ⊥ = -1\.5 N·m is outside"),
    "resteer --ratios 1,nan": (cli("resteer", "--variant", "{existing}", "--ratios", "1,nan", "--json", "{out}/r.json"),
                               r"--ratios: expected finite positive speed ratios"),
    "export --gamma nan": (cli("export", "{existing}", "--gamma", "nan", "--out", "{out}/cad"),
                           r"--gamma: γ = nan° is outside the variant's envelope\.gamma range -80\.\.80°"),
    "export --gamma 85": (cli("export", "{existing}", "--gamma", "85", "--out", "{out}/cad"),
                          r"--gamma: γ = 85° is outside the variant's envelope\.gamma range -80\.\.80°"),
    "export --gamma -inf": (cli("export", "{existing}", "--gamma=-inf", "--out", "{out}/cad"), r"--gamma: γ = -inf°"),
    "rig --set inf": (cli("rig", "{existing}", "--set", "steering_lateral_creep.scale=inf", "--out", "{out}/d.csv"),
                      r"--set: steering_lateral_creep\.scale: expected a finite"),
    "rig --set nan": (cli("rig", "{existing}", "--set", "drive_longitudinal_creep.scale=nan", "--out", "{out}/d.csv"),
                      r"--set: drive_longitudinal_creep\.scale: expected a finite"),
    "rig --set negative offset": (cli("rig", "{existing}", "--effects", "drive_longitudinal_creep,rolling_resistance",
                                      "--set", "rolling_resistance.offset=-0.1 mm", "--out", "{out}/d.csv"),
                                  r"--set: rolling_resistance\.offset: .*expected more than 0"),
    "rig --noise nan": (cli("rig", "{existing}", "--noise", "speed=nan", "--out", "{out}/d.csv"), r"--noise: speed: expected a finite"),
    "rig --noise inf": (cli("rig", "{existing}", "--noise", "torque=inf N*m", "--out", "{out}/d.csv"), r"--noise: torque: expected a finite"),
    "rig --noise < 0": (cli("rig", "{existing}", "--noise", "axis=-0.1 deg", "--out", "{out}/d.csv"),
                        r"--noise: axis: expected a standard deviation >= 0"),
    "rig --seed -1": (cli("rig", "{existing}", "--seed", "-1", "--out", "{out}/d.csv"), r"seed: expected an integer >= 0"),
    "rig --replicates -1": (cli("rig", "{existing}", "--replicates", "-1", "--out", "{out}/d.csv"), r"replicates: expected from 1 to 10000"),
}


def _files(folder: Path) -> set:
    return {p for p in folder.rglob("*")}


@pytest.mark.parametrize("case", CASES)
def test_bad_input_is_one_line_exit_2_nothing_written(case, tmp_path, capsys, monkeypatch):
    build, pattern = CASES[case]
    monkeypatch.chdir(tmp_path)          # a stray relative output would land here and be seen
    argv, bad_file = build(tmp_path)
    before = _files(tmp_path)
    capsys.readouterr()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.count("\n") == 1 and err.endswith("\n"), err
    assert err.startswith(f"cvtdesign: error: {bad_file}: " if bad_file else "cvtdesign: error: "), err
    assert re.search(pattern, err), err
    assert _files(tmp_path) == before, _files(tmp_path) - before


# ------------------------------------------------------------------------------ what must keep working

@pytest.mark.parametrize("path", [EXISTING, BOX, UNEQUAL], ids=lambda p: p.stem)
def test_shipped_variants_load_unchanged(path):
    L = load_variant(path)
    assert L.sphere_radius == pytest.approx(0.0635) and len(L.gamma_grid) == 17 and len(L.load_grid) == 21
    assert {r.material.E for r in L.rollers} <= {10.7e6, 12.3e6}
    assert all(float(r.preload) == 100.0 and float(r.stiffness) == 1e5 for r in L.rollers)


@pytest.mark.slow
def test_shipped_studies_build(tmp_path):
    from cvtdesign.design.problem import build_problem
    from cvtdesign.design.study_file import Study, load_study

    for f in STUDIES:
        study = load_study(f)
        for v in (study.spec.batch.variants or [study.spec.base]):
            problem = build_problem(Study(f, study.spec, (f.parent / v).resolve()))
            assert np.all(problem.lower < problem.upper) and np.all(np.isfinite(problem.upper))


def test_shipped_duty_files_load():
    from cvtdesign.io.duty_file import load_duty
    assert [f.name for f in DUTY_FILES] == ["cobot_duty.yaml"]
    assert all(load_duty(f).period > 0 for f in DUTY_FILES)


def test_shipped_tolerance_studies_load():
    """studies/box_tolerances.yaml (the issue's shipped tolerance study) reads against the variant it names in
    its header, every dimension a finite size."""
    from cvtdesign.io.tolerance_file import load_tolerances
    assert [f.name for f in TOLERANCE_STUDIES] == ["box_tolerances.yaml"]
    spec, dims = load_tolerances(TOLERANCE_STUDIES[0], load_variant(ROOT / "variants/box.yaml"))
    assert len(dims) == 42 and all(np.isfinite(d.size) and d.size > 0 for d in dims)


@pytest.mark.slow
def test_compare_box_figures_unchanged(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    js = tmp_path / "c.json"
    assert main(["compare", str(BOX), "--out", str(tmp_path / "plots"), "--json", str(js)]) == 0
    rows = {r["name"]: r for r in json.loads(js.read_text())["variants"]}
    assert round(rows["box_kim"]["max_abs_alpha_deg"], 3) == 4.166
    assert round(rows["existing_kim"]["max_abs_alpha_deg"], 3) == 10.761


def test_plausible_plain_numbers_are_still_si(tmp_path):
    """Plain numbers stay SI: radius 0.04 is 40 mm; the command line's plain numbers too."""
    data = yaml.safe_load(EXISTING.read_text())
    data["rollers"]["D1"]["radius"] = 0.04
    f = tmp_path / "plain.yaml"
    f.write_text(yaml.safe_dump(data))
    assert float(load_variant(f).rollers[0].radius) == pytest.approx(0.04)
    noise = rig.parse_noise("speed=0.02,torque=0.01,axis=0.001")
    assert (noise.speed, noise.torque, noise.axis) == (0.02, 0.01, 0.001)
    assert to_si("0.5 mm", "length", "w") == pytest.approx(5e-4) and to_si("45", "length", "w") == 45.0
    with pytest.raises(InputError, match=r"w: 45 m is not a plausible roller radius .*did you mean '45 mm'"):
        quantity("45", "roller_radius", "w")


def test_ten_operating_points_are_enough(tmp_path):
    f = tmp_path / "d.csv"
    f.write_text(HEADER + "".join(ROWS.splitlines(keepends=True)[:10]))
    data = measured.load_measured(f, load_variant(EXISTING))
    assert len(measured.merge_points(data).rows) == 10
