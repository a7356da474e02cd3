"""Steering linkages beyond two rollers (docs/linkages.md): a refusal names the roller that breaks the rule
and a change that fixes it; forks of any gear ratio steer where the rule allows it, checked against the
vectors (every steering roller's axle line passes through the commanded axis); `new --steering N`."""
import re
from pathlib import Path

import numpy as np
import pytest
import yaml

from conftest import ROOT
from kim_closed_forms import kim_gamma_from_phi  # tests/validation is on sys.path (tests/conftest.py)
from cvtdesign.cad import step
from cvtdesign.cli import main
from cvtdesign.core.geometry import ideal_gamma, pose
from cvtdesign.core.kinematics import shaft_frame
from cvtdesign.io.variant import load_variant

EXISTING = (ROOT / "variants/existing_kim.yaml").read_text(encoding="utf-8")


def three_steering_rollers(tmp_path) -> Path:
    """Kim's drive rollers with three steering rollers 120° apart around the pole (polar 45°), each on its own
    fork about its contact normal with its axle along its meridian, as Kim's S1: the layout that was refused
    with 'the steering rollers cannot all roll about the commanded axis … misfit 0.87', naming no roller."""
    head, tail = EXISTING.split("  S1: ")[0], "contact:" + EXISTING.split("\ncontact:")[1]
    rollers, forks = "", ""
    for i, az in enumerate((-90, 30, 150), 1):
        where = f"{{polar: 45 deg, azimuth: {az} deg}}"
        rollers += (f"  S{i}: {{role: steering, contact: {where}, axle: {{polar: 135 deg, azimuth: {az} deg}}, "
                    "radius: 25 mm, crown_radius: 15 mm, material: urethane_84A}\n")
        forks += f"    - {{rollers: [S{i}], axis: {where}, sign: 1}}\n"
    path = tmp_path / "three.yaml"
    path.write_text(head + rollers + "steering:\n  forks:\n" + forks + tail, encoding="utf-8")
    return path


def refused(path, capsys) -> str:
    """The one error line of `show` on a variant the layout checks refuse."""
    assert main(["show", str(path), "--out", str(Path(path).parent / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err.strip()


@pytest.mark.slow
def test_three_rollers_120_apart_refused_naming_the_rollers_and_their_fix(tmp_path, capsys):
    path = three_steering_rollers(tmp_path)
    err = refused(path, capsys)
    assert err.startswith(f"cvtdesign: error: {path}: steering.forks: S2's and S3's axles do not pass through the "
                          "commanded axis that S1 steers the sphere to (S2 misses it by up to 59.6° at γ = 40°"), err
    assert err.endswith("or put every fork about the pole z with one ratio, each axle through the commanded axis "
                        "at φ = 0 (the rule: docs/linkages.md)"), err
    # each named fix, applied, puts its roller on S1's law: the linkage passes (the preloads are the next rule)
    text = path.read_text(encoding="utf-8")
    for i, az in ((2, 30), (3, 150)):
        m = re.search(rf"fix S{i} with rollers\.S{i}\.contact: (\S+), axle: (\S+) and steering\.forks\[{i - 1}\]\.axis: "
                      r"([^;\s]+)", err)
        assert m, err
        old = f"{{polar: 45 deg, azimuth: {az} deg}}"
        text = text.replace(f"contact: {old}, axle: {{polar: 135 deg, azimuth: {az} deg}}",
                            f"contact: {m[1]}, axle: {m[2]}").replace(f"[S{i}], axis: {old}", f"[S{i}], axis: {m[3]}")
    fixed = tmp_path / "fixed.yaml"
    fixed.write_text(text, encoding="utf-8")
    err = refused(fixed, capsys)
    assert ": rollers: the preloads do not balance" in err and "steering.forks" not in err, err


def test_a_fork_turning_the_wrong_way_is_named_with_its_ratio(tmp_path, capsys):
    path = tmp_path / "wrong_way.yaml"
    path.write_text(EXISTING.replace("axis: c2, sign: -1", "axis: c2, sign: 1"), encoding="utf-8")
    assert refused(path, capsys) == (
        f"cvtdesign: error: {path}: steering.forks: S2's axle does not pass through the commanded axis that S1 steers "
        "the sphere to (S2 misses it by up to 54.7° at γ = 0°); fix S2 with steering.forks[1].ratio: -1 (the rule: "
        "docs/linkages.md)")


def with_forks(path, forks) -> Path:
    """The variant file with each fork's (axis, ratio) set."""
    data = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    for fork, (axis, ratio) in zip(data["steering"]["forks"], forks, strict=True):
        fork.update(axis=axis, ratio=ratio)
    Path(path).write_text(yaml.safe_dump(data, sort_keys=False), encoding="utf-8")
    return Path(path)


def axle_misses(layout, phi: float, gamma: float) -> float:
    """Largest |c·(a × u)| [m] over the steering rollers at steering angle φ: c = (R + r) n the roller's
    centre, a its axle, u = u(γ). It is zero iff the roller's axle line and the commanded axis (through the
    sphere centre) are coplanar, i.e. meet or are parallel (a pole roller's axle is parallel to u): the
    roller rolls about u(γ) without lateral slip (docs/linkages.md, eq. 1). Otherwise it is their distance
    times the sine of the angle between them."""
    u = shaft_frame(layout).axis(gamma)
    worst = 0.0
    for r in (r for r in layout.rollers if r.role == "steering"):
        n, a = (np.asarray(v, float).ravel() for v in pose(r, phi))
        centre = (float(layout.sphere_radius) + float(r.radius)) * n
        worst = max(worst, abs(centre @ np.cross(a, u)))
    return worst


def test_non_unit_ratios_steer_by_the_vectors(tmp_path, capsys):
    """Kim's forks geared 2 and −2 realise Kim's law at 2φ; the pole forks of `new --steering 3` geared 0.5
    (one about z, one about −z with −0.5: the same fork) realise γ = φ/2. At each φ the rigid rolling
    constraints give γ (geometry.ideal_gamma), and every steering roller's axle passes through u(γ)."""
    kim = tmp_path / "kim2.yaml"
    kim.write_text(EXISTING.replace("axis: c1, sign: 1", "axis: c1, ratio: 2").replace("axis: c2, sign: -1",
                                                                                         "axis: c2, ratio: -2"))
    assert main(["new", "pole", "--steering", "3", "--out", str(tmp_path / "pole.yaml")]) == 0
    pole = with_forks(tmp_path / "pole.yaml", [("z", 0.5), ("-z", -0.5)])
    laws = {kim: lambda phi: kim_gamma_from_phi(2 * phi), pole: lambda phi: phi / 2}
    for path, law in laws.items():
        layout = load_variant(path)
        for phi in np.radians([-35.0, -12.0, 0.0, 7.0, 30.0]):
            gamma = ideal_gamma(layout, phi)
            off = (gamma - law(phi) + np.pi / 2) % np.pi - np.pi / 2           # the same axis line: mod 180°
            assert abs(off) < 1e-9, (path.name, phi)
            assert axle_misses(layout, phi, gamma) < 1e-12, (path.name, phi)
            assert axle_misses(layout, phi, gamma + 0.01) > 1e-4      # and not about a neighbouring axis
    # geared unlike the other fork, a fork is refused with the ratio that fits
    err = refused(with_forks(pole, [("z", 2), ("z", 1)]), capsys)
    assert err.endswith("; fix S1 with steering.forks[1].ratio: 2 (the rule: docs/linkages.md)"), err


@pytest.mark.slow
def test_three_steering_rollers_from_new_export_one_solid_per_part(tmp_path, capsys):
    """`new --steering 3` → `export --check`: a STEP file re-read with one valid solid per part."""
    path = tmp_path / "three.yaml"
    assert main(["new", "three", "--steering", "3", "--out", str(path)]) == 0
    assert main(["export", str(path), "--check", "--out", str(tmp_path / "cad")]) == 0
    parts = step.read_step(tmp_path / "cad/three.step")
    assert {"steering_N1", "steering_N2", "steering_S1", "fork_1", "fork_2"} <= set(parts)
    for name, (shape, _) in parts.items():
        assert len(shape.Solids()) == 1 and shape.Solids()[0].isValid(), name
