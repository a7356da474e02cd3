"""The envelope check of an optimum (Problem.check) evaluates the study's model, which takes the design as
an input, instead of compiling a numeric model per design: it must give what the numeric model of that
design gives, point for point, failing points included."""

import numpy as np
import pytest
import yaml

from conftest import ROOT

from cvtdesign.core.model import compile_model
from cvtdesign.design.problem import build_problem
from cvtdesign.design.solution import check_envelope
from cvtdesign.design.solve import solve_from, starts
from cvtdesign.design.study_file import load_study
from cvtdesign.io.variant import resolve

COARSE = {"gamma": {"start": "-80 deg", "stop": "80 deg", "step": "20 deg"}}


def study(tmp_path, name, **fields):
    data = {"name": name, "base": str(ROOT / "variants/box_kim.yaml"), "multistart": {"starts": 1}} | fields
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True))
    return path


def numeric(pr, design):
    """The check as it was: the numeric model of the design, compiled afresh and evaluated on the envelope
    (its evaluate() result and its check)."""
    model = compile_model(resolve(pr.vspec, str(pr.base_file), overrides=pr.fixed | design), effects=pr.spec.effects)
    res = model.evaluate(pr.parts.gamma, pr.parts.load, pr.motor_speed)
    return res, check_envelope(res, model.roller_names)


def assert_same_points(pr, design):
    """Problem.envelope at `design` against the fresh numeric model: the same status at every point, the
    same α (1e-10 rad) and normal forces where both are ok, and the named failing contact one with the same
    largest excess (symmetric contacts, such as A and A', tie to round-off, so either may be named)."""
    mine, (ref, ref_check) = pr.envelope(design), numeric(pr, design)
    np.testing.assert_array_equal(mine["status"], ref["status"])
    ok = ref["ok"]
    np.testing.assert_allclose(mine["alpha"][0][ok], ref["alpha"][ok], rtol=0, atol=1e-10)
    np.testing.assert_allclose(mine["N"][:, ok], ref["N"][:, ok], rtol=1e-10, atol=1e-9)
    excess = np.hypot(mine["F_t"], mine["F_a"]) - mine["mu"] * mine["N"]
    k = np.arange(excess.shape[1])
    slip, lost = mine["status"] == 3, mine["status"] == 2
    np.testing.assert_array_equal(mine["failed_contact"] >= 0, ref["failed_contact"] >= 0)
    for where, value in ((slip, excess), (lost, -mine["N"])):
        np.testing.assert_allclose(value[mine["failed_contact"][where], k[where]],
                                   value[ref["failed_contact"][where], k[where]], rtol=1e-9, atol=1e-9)
    a, b = pr.check(design).as_dict(), ref_check.as_dict()
    assert {key: a[key] for key in ("points", "failed", "not_converged", "lost_contact", "gross_slip")} == \
        {key: b[key] for key in ("points", "failed", "not_converged", "lost_contact", "gross_slip")}
    for key in ("min_normal_force_N", "max_utilisation", "max_abs_alpha_deg"):
        assert a[key] == pytest.approx(b[key], rel=1e-9, abs=1e-9, nan_ok=True)
    return mine["status"]


def test_check_is_the_numeric_model_of_the_design():
    """Box placement (its envelope, 357 points): the base design, the optimum's corner and two far corners
    of the design box; every point ok."""
    pr = build_problem(load_study(ROOT / "studies/box_placement_kim.yaml"))
    for d, r_drive, r_steer in [(0.06, 0.04, 0.038), (0.0319401, 0.04, 0.02), (0.11, 0.06, 0.06), (0.03, 0.02, 0.06)]:
        status = assert_same_points(pr, {"d": d, "r_drive": r_drive, "r_steer": r_steer})
        assert (status == 0).all()


@pytest.mark.slow
def test_check_is_the_numeric_model_where_points_fail(tmp_path):
    """Points that slip grossly or do not converge (box, low preloads, τ⊥ to ±2 N·m), points that lose
    contact (Kim's existing CVT at τ⊥ = ±4 N·m) and a reversed root (the same with a saturation law at
    γ = −60°, τ⊥ = 6 N·m): the same statuses as the numeric model."""
    pr = build_problem(load_study(study(tmp_path, "slip", design={"d": {"lower": "30 mm", "upper": "110 mm"},
                                                       "preload": {"lower": "5 N", "upper": "200 N"},
                                                       "r_steer": {"lower": "20 mm", "upper": "60 mm"}},
                             envelope=COARSE | {"load": {"start": "-2 N*m", "stop": "2 N*m", "step": "0.5 N*m"}})))
    seen = set()
    for d, preload, r_steer in [(0.06, 100.0, 0.038), (0.06, 10.0, 0.038), (0.03, 5.0, 0.06), (0.11, 30.0, 0.02)]:
        seen |= set(assert_same_points(pr, {"d": d, "preload": preload, "r_steer": r_steer}).tolist())
    pr = build_problem(load_study(study(tmp_path, "lost", base=str(ROOT / "variants/existing_kim.yaml"),
                             design={"r_steer": {"lower": "20 mm", "upper": "60 mm"}},
                             envelope=COARSE | {"load": {"start": "-4 N*m", "stop": "4 N*m", "step": "2 N*m"}})))
    for r_steer in (0.038, 0.02):
        seen |= set(assert_same_points(pr, {"r_steer": r_steer}).tolist())
    # loaded from rest, Kim's law reaches a reversed root only with a saturation law, far past gross slip
    pr = build_problem(load_study(study(tmp_path, "reversed", base=str(ROOT / "variants/existing_kim.yaml"),
                             design={"r_steer": {"lower": "20 mm", "upper": "60 mm"}},
                             effects=["drive_longitudinal_creep", "steering_lateral_creep", "normal_force_variation",
                                      "traction_saturation"],
                             envelope={"gamma": {"start": "-60 deg", "stop": "-40 deg", "step": "20 deg"},
                                       "load": {"start": "-6 N*m", "stop": "6 N*m", "step": "6 N*m"}})))
    seen |= set(assert_same_points(pr, {"r_steer": 0.038}).tolist())
    assert seen == {0, 1, 2, 3, 4}     # ok, not converged, lost contact, gross slip and reversed all came up


def test_a_solve_checks_with_its_own_row_evaluation_only_where_the_seeds_agree(tmp_path):
    """solve_from evaluates every row at the optimum (Problem.rows_and_points); the same Newton solves give
    the check's outputs. They stand for the check only where the design's own steering scan gives the NLP's
    seeds bit for bit, and then they are the check's numbers bit for bit; where the seeds differ, the check
    evaluates the points itself."""
    pr = build_problem(load_study(ROOT / "studies/box_placement_kim.yaml"))
    sol = solve_from(pr, starts(pr)[0])
    x = np.append(sol.z, sol.objective)
    g, points = pr.rows_and_points(x)
    np.testing.assert_array_equal(g, np.asarray(pr.evaluate(x)[1]).ravel())
    np.testing.assert_array_equal(g, sol.g)
    own = pr.envelope(sol.design)
    shared = pr.envelope(sol.design, points)
    for key in own:
        np.testing.assert_array_equal(shared[key], own[key])
    assert sol.check == pr.check(sol.design)
    fake = {key: np.full_like(v, np.nan) for key, v in points.items()}
    pr.parts.phi0 = pr.parts.phi0 + 1e-9                   # the NLP's seeds are no longer the design's
    np.testing.assert_array_equal(pr.envelope(sol.design, fake)["status"], own["status"])
