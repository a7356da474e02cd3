"""Physically impossible layouts are refused when a variant loads, each with one line naming the file and
the field: preloads that do not balance, no or empty steering forks, contact points off the sphere, axles
not in the tangent plane of a contact point, a shaft without a drive roller, rollers that overlap. Shipped and
balanced custom layouts still load."""
import copy
import itertools
import re
from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np
import pytest
import yaml

from conftest import ROOT, shipped_layout

from cvtdesign.core.checks import N_RIM, check_overlaps, check_preload_equilibrium, overlapping_rollers
from cvtdesign.cli import main
from cvtdesign.core.geometry import FRAME, pose, steering_angle_guess, steering_data
from cvtdesign.errors import InputError
from cvtdesign.io.variant import load_spec, load_variant, resolve

VARIANTS = ROOT / "variants"
R_MM = 63.5                      # sphere radius of existing_kim.yaml
ON_SPHERE = f"{R_MM / np.sqrt(2):.12f} mm"   # a coordinate of a contact point R·d2 = R·(−1, 1, 0)/√2


def variant(name="existing_kim"):
    return yaml.safe_load((VARIANTS / f"{name}.yaml").read_text())


def write(tmp_path, data, name="bad.yaml"):
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
    return path


def refusal(tmp_path, data) -> tuple[Path, str]:
    path = write(tmp_path, data)
    with pytest.raises(InputError) as e:
        load_variant(path)
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"{path}: "), msg
    return path, msg


def without(data, roller):
    """`data` with `roller` removed from the rollers and from its fork (an emptied fork is dropped)."""
    d = copy.deepcopy(data)
    del d["rollers"][roller]
    forks = []
    for f in d["steering"]["forks"]:
        f["rollers"] = [r for r in f["rollers"] if r != roller]
        if f["rollers"]:
            forks.append(f)
    d["steering"]["forks"] = forks
    return d


def run_compare(tmp_path, capsys, path):
    out = tmp_path / "plots"
    status = main(["compare", str(path), "--out", str(out), "--json", str(tmp_path / "f.json")])
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert err.startswith(f"cvtdesign: error: {path}: "), err
    assert not out.exists() and not (tmp_path / "f.json").exists()
    return err


# --- what must still load ------------------------------------------------------------------------------

@pytest.mark.parametrize("name, rollers", [("existing_kim", 4), ("box_kim", 8), ("unequal_kim", 4)])
def test_shipped_variants_load(name, rollers):
    """Each shipped layout loads and meets what the checks require: preloads in balance (Σ P n = 0), unit
    normals, axles in the tangent planes, a drive roller on each shaft."""
    layout = shipped_layout(name)
    assert len(layout.rollers) == rollers
    n = np.array([np.ravel(np.asarray(r.normal, float)) for r in layout.rollers])
    a = np.array([np.ravel(np.asarray(r.axle, float)) for r in layout.rollers])
    P = np.array([float(r.preload) for r in layout.rollers])
    assert np.linalg.norm(P @ n) < 1e-9 * P.sum()
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, rtol=1e-14)
    np.testing.assert_allclose(np.sum(n * a, axis=1), 0.0, atol=1e-14)
    assert {r.shaft for r in layout.rollers if r.role == "drive"} == {1, 2}


def test_balanced_custom_layouts_load(tmp_path):
    d = variant()
    d["parameters"]["preload"] = "200 N"                         # every preload doubled
    assert {r.preload for r in load_variant(write(tmp_path, d, "double.yaml")).rollers} == {200.0}
    b = variant("box_kim")
    b["rollers"]["A"]["preload"] = b["rollers"]["A_"]["preload"] = "150 N"   # opposite rollers, equal preloads
    load_variant(write(tmp_path, b, "box150.yaml"))


def test_symbolic_preloads_skip_the_balance_check():
    """An optimiser's CasADi parameters cannot be checked numerically: the check is skipped, not crashed."""
    spec = load_spec(VARIANTS / "existing_kim.yaml")
    spec.rollers.pop("S1")
    spec.steering.forks.pop(0)
    layout = resolve(spec, "existing_kim.yaml", overrides={"preload": ca.SX.sym("preload")})
    assert check_preload_equilibrium(layout) is None
    with pytest.raises(InputError, match="preloads do not balance"):
        check_preload_equilibrium(resolve(spec, "existing_kim.yaml"))


# --- 1. preload equilibrium ----------------------------------------------------------------------------

def test_unbalanced_preloads_one_line_exit_2(tmp_path, capsys):
    """Kim's layout without S1: the three remaining preloads push the sphere along −c1 (100 N)."""
    err = run_compare(tmp_path, capsys, write(tmp_path, without(variant(), "S1")))
    assert re.search(r": rollers: the preloads do not balance \(Σ P_i n_i = 100 N along \(0, 0\.707, -0\.707\) = -c1\); "
                     r"at rest the mounts would move the sphere 3\.16 mm and the smallest normal force would be 0 N "
                     r"on rollers\.\w+ \(unloaded\)", err), err


def test_unbalanced_preloads_name_the_roller_that_lifts_off(tmp_path):
    b = variant("box_kim")
    b["rollers"]["A"]["preload"] = "1000 N"
    _, msg = refusal(tmp_path, b)
    assert re.search(r"rollers: the preloads do not balance \(Σ P_i n_i = 900 N along \(-0\.707, 0\.707, 0\) = d2\)", msg), msg
    assert re.search(r"smallest normal force would be -46\.98 N on rollers\.S1 \(it would lift off\)", msg), msg


def test_unbalanced_single_preload(tmp_path):
    d = variant()
    d["rollers"]["S1"]["preload"] = "300 N"
    _, msg = refusal(tmp_path, d)
    assert "rollers: the preloads do not balance (Σ P_i n_i = 200 N along (0, -0.707, 0.707) = c1)" in msg
    assert "smallest normal force would be 150 N" in msg


def test_tiny_imbalance_is_accepted(tmp_path):
    d = variant()
    d["rollers"]["S1"]["preload"] = "100.00001 N"          # |Σ P n| = 1e-5 N < 1e-6 · 400 N
    load_variant(write(tmp_path, d))


def test_balance_check_direct():
    layout = load_variant(VARIANTS / "existing_kim.yaml")
    check_preload_equilibrium(layout)
    lopsided = replace(layout, rollers=tuple(replace(r, preload=50.0) if r.name == "D1" else r for r in layout.rollers))
    with pytest.raises(InputError, match=r"= 50 N along \(0\.707, -0\.707, 0\) = -d2\).*87\.5 N on rollers"):
        check_preload_equilibrium(lopsided)


# --- 2. steering forks ---------------------------------------------------------------------------------

def test_no_forks_no_steering_rollers_one_line_exit_2(tmp_path, capsys):
    d = variant()
    d["steering"]["forks"] = []
    del d["rollers"]["S1"], d["rollers"]["S2"]
    err = run_compare(tmp_path, capsys, write(tmp_path, d))
    assert ": steering.forks: no steering roller on any fork; without steering rollers nothing fixes the sphere's axis" in err


def test_no_forks_with_steering_rollers(tmp_path):
    d = variant()
    d["steering"]["forks"] = []
    _, msg = refusal(tmp_path, d)
    assert msg.endswith(": rollers.S1: steering roller is on no fork (steering.forks[].rollers)")


def test_fork_without_rollers(tmp_path):
    d = variant()
    d["steering"]["forks"][0]["rollers"] = []
    del d["rollers"]["S1"]
    _, msg = refusal(tmp_path, d)
    assert msg.endswith(": steering.forks[0].rollers: empty; every fork holds at least one roller (a steering roller's name)")


# --- 3. contact points on the sphere -------------------------------------------------------------------

def test_contact_point_on_the_sphere_loads(tmp_path):
    d = variant()
    d["rollers"]["D1"]["contact"] = [f"-{ON_SPHERE}", ON_SPHERE, "0 mm"]          # = R·d2
    b = variant("box_kim")
    b["rollers"]["A"]["contact"] = ["= -R/sqrt(2)", "= R/sqrt(2)", "0 mm"]        # expressions over parameters
    for data, name, ref in ((d, "D1", load_variant(VARIANTS / "existing_kim.yaml")),
                            (b, "A", load_variant(VARIANTS / "box_kim.yaml"))):
        layout = load_variant(write(tmp_path, data, f"{name}.yaml"))
        normal = next(r.normal for r in layout.rollers if r.name == name)
        np.testing.assert_allclose(np.ravel(normal), FRAME["d2"], atol=1e-12)
        assert len(layout.rollers) == len(ref.rollers)


def test_plain_numbers_are_a_direction(tmp_path):
    d = variant()
    d["rollers"]["D1"]["contact"] = [-3, 3, 0]
    layout = load_variant(write(tmp_path, d))
    np.testing.assert_allclose(layout.rollers[0].normal, FRAME["d2"], atol=1e-15)


def test_contact_point_off_the_sphere_one_line_exit_2(tmp_path, capsys):
    d = variant()
    d["rollers"]["D1"]["contact"] = ["-44.9 mm", "44.9 mm", "0 mm"]    # 63.498 mm from the centre
    err = run_compare(tmp_path, capsys, write(tmp_path, d))
    assert (": rollers.D1.contact: the contact point is 63.4982 mm from the sphere centre but the sphere radius "
            "is 63.5 mm; a contact point must lie on the sphere") in err


def test_contact_point_at_the_centre(tmp_path):
    d = variant()
    d["rollers"]["D1"]["contact"] = ["0 mm", "0 mm", "0 mm"]
    _, msg = refusal(tmp_path, d)
    assert "rollers.D1.contact: the contact point is 0 mm from the sphere centre but the sphere radius is 63.5 mm" in msg


def test_contact_mixing_numbers_and_quantities(tmp_path):
    d = variant()
    d["rollers"]["D1"]["contact"] = ["-44.9 mm", "44.9 mm", 0]
    _, msg = refusal(tmp_path, d)
    assert re.search(r": rollers\.D1\.contact: mixes plain numbers and lengths \(-44\.9 mm, 44\.9 mm, 0\); give a "
                     r"direction \(plain numbers or '= expressions'\) or a point of three lengths", msg), msg


def test_contact_of_numbers_and_expressions_is_a_direction(tmp_path):
    """The reference says a direction may be three numbers or '= expressions': [-1, '= 1', 0] was refused
    ("mixes plain numbers and quantities") and three expressions were read as a point in metres ("the contact
    point is 1000 mm from the sphere centre"). Both are D1's contact direction -d1 + d2 now."""
    for contact in ([-1, "= 1", 0], ["= -sqrt(0.5)", "= sqrt(0.5)", "= 0"]):
        d = variant()
        d["rollers"]["D1"]["contact"] = contact
        d["rollers"]["D1"]["axle"] = [1, 1, 0]
        path = tmp_path / "v.yaml"
        path.write_text(yaml.safe_dump(d))
        layout = load_variant(path, check=False)
        normal = next(r.normal for r in layout.rollers if r.name == "D1")
        np.testing.assert_allclose(np.asarray(normal, float).ravel(), [-np.sqrt(0.5), np.sqrt(0.5), 0], atol=1e-15)


def test_contact_point_wrong_unit_or_size(tmp_path):
    d = variant()
    d["rollers"]["D1"]["contact"] = ["-44.9 N", "44.9 mm", "0 mm"]
    _, msg = refusal(tmp_path, d)
    assert msg.endswith(": rollers.D1.contact[0]: expected a length like '40 mm', got '-44.9 N'")
    d["rollers"]["D1"]["contact"] = ["63.5 mm", "0 mm"]
    _, msg = refusal(tmp_path, d)
    assert msg.endswith(": rollers.D1.contact: expected a point of 3 lengths, got 2")


# --- 4. axle perpendicular to the normal of a contact point ----------------------------------------------

def test_axle_not_perpendicular_to_contact_point(tmp_path):
    d = variant()
    d["rollers"]["D1"]["contact"] = [f"-{ON_SPHERE}", ON_SPHERE, "0 mm"]          # normal d2
    d["rollers"]["D1"]["axle"] = "x"                                              # x·d2 = −0.707
    _, msg = refusal(tmp_path, d)
    assert re.search(r": rollers\.D1\.axle: not perpendicular to the contact normal \(axle·normal = -0\.7071\)", msg), msg


# --- 5. each shaft has a drive roller ----------------------------------------------------------------------

@pytest.mark.parametrize("shaft", [1, 2])
def test_shaft_without_drive_roller(tmp_path, shaft):
    d = variant()
    roller = {1: "D1", 2: "D2"}[shaft]
    d["rollers"][roller]["role"] = "follower"                                      # coupled, but nothing drives it
    _, msg = refusal(tmp_path, d)
    assert msg.endswith(f": rollers: no drive roller on shaft {shaft} (role: drive, shaft: {shaft})")


def test_direction_lists_take_expressions(tmp_path):
    """A direction may be three numbers or '= expressions' (dimensionless, over the parameters): D1's axle -d1
    written as ['= -1/sqrt(2)', '= -1/sqrt(2)', 0] is the same axle to the last bit."""
    d = variant()
    d["rollers"]["D1"]["axle"] = ["= -1/sqrt(2)", "= -1/sqrt(2)", 0]
    layout = load_variant(write(tmp_path, d))
    np.testing.assert_allclose(layout.rollers[0].axle, -FRAME["d1"], atol=1e-15)


def test_rounded_directions_are_refused_with_the_reason(tmp_path):
    """The box's follower A_ with its axle -d1 typed to six decimals, [-0.707107, -0.707106, 0], is within 1e-6
    of perpendicular to its normal but turned by 4e-5° against drive roller A on the same shaft: the laterally
    rigid rollers then fight, and the message says that rounding may be why."""
    d = variant("box_kim")
    d["rollers"]["A_"]["axle"] = [-0.707107, -0.707106, 0]
    _, msg = refusal(tmp_path, d)
    assert "(rollers fight)" in msg and "no direction is rounded" in msg, msg


# --- 6. rollers that overlap ----------------------------------------------------------------------------------

def sampled_overlaps(layout) -> list[tuple[float, str, str]]:
    """The overlap test written plainly, as the check was before it was vectorised: per γ and pair of rollers,
    every point sampled on one roller's cylinder (rims and 0.66, 0.33 of the radius on both faces and the
    mid-plane, and the centre; poses from geometry.pose) tested against the other cylinder, and vice versa."""
    R = float(layout.sphere_radius)
    gammas = np.linspace(layout.gamma_grid.min(), layout.gamma_grid.max(), 9)
    phis, _ = steering_angle_guess(*steering_data(layout), gammas)
    th = np.linspace(0, 2 * np.pi, N_RIM, endpoint=False)

    def body(r, phi):
        n, a = pose(r, phi)
        t = np.cross(n, a)
        rad, half = float(r.radius), float(r.width) / 2
        c = (R + rad) * n
        pts = [c + s * a + f * rad * (np.cos(th)[:, None] * n + np.sin(th)[:, None] * t)
               for s in (-half, 0.0, half) for f in (1.0, 0.66, 0.33)]
        return np.vstack(pts + [c[None, :]]), c, a, rad, half

    found = []
    for g, phi in zip(gammas, phis):
        bodies = {r.name: body(r, phi) for r in layout.rollers}
        for (na, A), (nb, B) in itertools.combinations(bodies.items(), 2):
            for (pts, *_), (_, c, ax, rad, half) in ((A, B), (B, A)):
                d = pts - c
                along = d @ ax
                radial = np.linalg.norm(d - np.outer(along, ax), axis=1)
                if np.any((np.abs(along) < half * (1 - 1e-9)) & (radial < rad * (1 - 1e-9))):
                    found.append((float(g), na, nb))
                    break
    return found


def grown(layout, factor):
    """The layout with every roller's radius and width times `factor` (the rollers close in on each other)."""
    return replace(layout, rollers=tuple(replace(r, radius=float(r.radius) * factor, width=float(r.width) * factor)
                                         for r in layout.rollers))


@pytest.mark.parametrize("name", ["existing_kim", "box_kim", "unequal_kim"])
def test_overlap_check_agrees_with_the_plain_test(name):
    """The vectorised check finds the same overlapping pairs at the same γ as the plain test: none on the
    shipped variants, and the same ones when the rollers grow until they overlap (box: at 1.5×, the steering
    pairs first; existing and unequal: S1 and S2 at 4×)."""
    layout = shipped_layout(name)
    assert overlapping_rollers(layout) == sampled_overlaps(layout) == []
    check_overlaps(layout)
    for factor in (1.25, 1.5, 2.0, 3.0, 4.0):
        big = grown(layout, factor)
        assert overlapping_rollers(big) == sampled_overlaps(big), f"{name} × {factor}"
    assert overlapping_rollers(grown(layout, 4.0))


def test_overlapping_steering_rollers_are_refused_at_the_first_gamma():
    """Box with its rollers 1.5× as large: N1/N2 and S1/S2 overlap; the message names the first pair at the
    first γ of the envelope."""
    big = grown(shipped_layout("box_kim"), 1.5)
    g, a, b = sampled_overlaps(big)[0]
    with pytest.raises(InputError, match=rf"rollers\.{a}, rollers\.{b}: the two rollers overlap at "
                                         rf"γ = {np.degrees(g):.0f}°; move them apart or make them smaller"):
        check_overlaps(big)
