"""Operating points given by steering angle instead of γ, and by brake torque τ2 instead of τ⊥, with the
model interpreted and compiled."""
import casadi as ca
import numpy as np
import pytest

import layout_transforms as lt
from conftest import ROOT
from kim_closed_forms import kim_gamma_from_phi  # tests/validation is on sys.path (tests/conftest.py)
from cvtdesign.core import native
from cvtdesign.core.geometry import ideal_gamma
from cvtdesign.core.model import CONTACT_OUTPUTS, POINT_OUTPUTS, compile_model
from cvtdesign.core.status import STATUS
from cvtdesign.io.variant import load_variant


@pytest.fixture(scope="module", params=["never", "always"])
def existing(request):
    """existing_kim.yaml interpreted, and compiled to C (CVTDESIGN_COMPILE; skipped without a C compiler)."""
    if request.param == "always" and native.compiler() is None:
        pytest.skip("no C compiler on this machine")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("CVTDESIGN_COMPILE", request.param)
        yield compile_model(load_variant(ROOT / "variants/existing_kim.yaml"))


def test_forward_kinematics_is_kim_eq5(existing):
    for phi in np.radians([-60.0, -20.0, 0.0, 15.0, 50.0]):
        g = ideal_gamma(existing.layout, phi)
        assert np.isclose(np.tan(g), np.tan(kim_gamma_from_phi(phi)), rtol=1e-12, atol=1e-12)


def test_steering_angle_input_equals_gamma_input(existing):
    phis = np.radians([-40.0, 10.0, 35.0])
    by_phi = existing.evaluate(None, 0.6, steering_angles=phis)
    by_gamma = existing.evaluate(kim_gamma_from_phi(phis), 0.6)
    np.testing.assert_allclose(by_phi["phi"], phis, atol=1e-12)
    np.testing.assert_allclose(by_phi["alpha"], by_gamma["alpha"], rtol=1e-10, atol=1e-14)


def test_brake_torque_load(existing):
    """A τ⊥ point re-solved with its own τ2 as the load is the same state."""
    g = np.radians([-50.0, 20.0, 70.0])
    a = existing.evaluate(g, 0.8)
    b = existing.evaluate(g, a["tau_2"], load_kind="tau_2")
    np.testing.assert_allclose(b["tau_2"], a["tau_2"], rtol=1e-12)
    np.testing.assert_allclose(b["alpha"], a["alpha"], rtol=1e-9)
    tau_perp = -b["tau_1"] * np.sin(g) + b["tau_2"] * np.cos(g)
    np.testing.assert_allclose(tau_perp, 0.8, rtol=1e-9)
    with pytest.raises(ValueError):
        existing.evaluate(g, 0.8, load_kind="brake")


def loaded_from_rest(model, gamma, load, steps=64) -> dict:
    """The state a rig reaches by raising the load from rest at γ [rad] in `steps` small steps, each Newton
    solve (CasADi's own rootfinder, on the model's residual) starting from the last: the reference for the
    root `evaluate` must report. Returns the point's outputs, with 'converged'."""
    phi0, _ = model.steering_guess(np.array([gamma]))
    steer = ca.rootfinder("steer", "newton", model.steering_residual, {"error_on_fail": False})
    phi = float(steer(phi0[0], gamma))
    solve = ca.rootfinder("rest", "newton", model.residual, {"abstol": 1e-12, "max_iter": 60, "error_on_fail": False})
    params = lambda f: ca.vertcat(gamma, model.layout.motor_speed, f, 0.0, phi, np.asarray(model.param_values, float))
    x = model.initial_guess(params(0.0))
    for k in range(1, steps + 1):
        x = solve(x, params(load * k / steps))
    out = dict(zip(POINT_OUTPUTS + CONTACT_OUTPUTS, (np.array(v).ravel() for v in model.outputs(x, params(load)))))
    return out | {"converged": float(ca.norm_inf(model.residual(x, params(load)))) < 1e-8}


def test_past_the_envelope_the_root_is_the_one_loading_from_rest_reaches(existing):
    """Past Kim's envelope (existing CVT, γ = −80°, τ⊥ = 2.1 N·m) the Newton solve from ideal kinematics found a
    second root of the equations: ω2 = +907 rad/s where the ideal law gives −56.7 (power entering at both
    shafts, 351 W lost), reported `ok` with α = −10.6° (the ±90° wrap of a 169° error); it was then flagged
    `reversed`. `evaluate` now reports the root a rig reaches by loading from rest: ω2 = −20.2 rad/s, power in
    at shaft 1 and out at shaft 2, the loss their sum, the same state as 64 small load steps."""
    res = existing.evaluate(np.radians([-80.0, -80.0]), [2.1, 1.0])
    assert list(res["status"]) == [STATUS.index("ok")] * 2
    assert res["omega_2"][0] == pytest.approx(-20.226, abs=1e-3)
    p_in, p_out = res["tau_1"][0] * res["omega_1"][0], res["tau_2"][0] * res["omega_2"][0]
    assert p_in > 0 > p_out and res["power_loss"][0] == pytest.approx(p_in + p_out, rel=1e-12)
    ref = loaded_from_rest(existing, np.radians(-80.0), 2.1)
    assert ref["converged"] and res["omega_2"][0] == pytest.approx(ref["omega_2"][0], rel=1e-9)
    G, T = np.meshgrid(existing.layout.gamma_grid, existing.layout.load_grid, indexing="ij")
    assert not np.any(existing.evaluate(G, T)["status"] == STATUS.index("reversed"))


def test_a_solve_that_did_not_converge_is_not_called_gross_slip():
    """With a saturation law (existing_kim.yaml + normal_force_variation + traction_saturation):
    - γ = −60°, τ⊥ = 6 N·m ended with ω2 = NaN and a residual whose ∞-norm skipped the NaN: it was counted
      as converged, and then as gross slip. Loaded from rest, the model ends on a root with the sphere
      turning backwards (past |F| = 11 μN on the way): no number, and not gross slip either;
    - γ = −80°, τ⊥ = 1.8 N·m did not converge from ideal kinematics (residual 0.13) and was called gross slip
      because the last iterate had a contact near μN. Loaded from rest it converges, with every contact
      below half of μN: the state of 64 small load steps."""
    L = load_variant(ROOT / "variants/existing_kim.yaml")
    m = compile_model(L, ("drive_longitudinal_creep", "steering_lateral_creep", "normal_force_variation",
                          "traction_saturation"))
    res = m.evaluate(np.radians([-60.0, -80.0]), [6.0, 1.8])
    assert res["status"][0] in (STATUS.index("not_converged"), STATUS.index("reversed")) and np.isnan(res["alpha"][0])
    assert res["status"][1] == STATUS.index("ok") and np.max(res["utilisation"][:, 1]) < 0.5
    ref = loaded_from_rest(m, np.radians(-80.0), 1.8)
    assert ref["converged"] and res["alpha"][1] == pytest.approx(ref["alpha"][0], abs=1e-10)


@pytest.mark.slow
@pytest.mark.parametrize("compile_policy", ["never", "always"])
def test_under_kalkers_law_the_answer_does_not_depend_on_how_the_layout_is_written(compile_policy, monkeypatch):
    """tests/data/asym_kalker.yaml, an asymmetric box under Kalker's law, at γ = 85°: with Polach's closed form
    (the law before the FASTSIM surface) it had two converged roots at τ⊥ ≥ 1 N·m, and the file as written
    gave α = 2.612° where the same machine rotated by 37° about (1, 2, 3) gave 2.610°. Under FASTSIM's surface
    the root is unique there: both layouts give the state of 64 small load steps from rest, to 1e-9°."""
    if compile_policy == "always" and native.compiler() is None:
        pytest.skip("no C compiler on this machine")
    monkeypatch.setenv("CVTDESIGN_COMPILE", compile_policy)
    data = lt.read(ROOT / "tests/data/asym_kalker.yaml")
    models = [compile_model(lt.layout_of(d)) for d in (data, lt.rotate(data, lt.axis_angle_matrix((1, 2, 3), np.radians(37))))]
    g, loads = np.radians(85.0), np.array([0.3, 0.8, 1.0, 1.1])
    res = [m.evaluate(np.full(loads.size, g), loads) for m in models]
    ref = [np.degrees(loaded_from_rest(models[0], g, f)["alpha"][0]) for f in loads]
    for r in res:
        assert list(r["status"]) == [STATUS.index("ok")] * 4
        np.testing.assert_allclose(np.degrees(r["alpha"]), ref, atol=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("compile_policy", ["never", "always"])
def test_a_second_root_near_the_friction_limit_is_not_reported_as_the_rig_s(compile_policy, monkeypatch):
    """existing.yaml at γ = −16°, τ⊥ = 2.5 N·m (past its envelope; contacts at 0.68 μN): the Newton solve
    from ideal kinematics lands on α = 18.492° while loading from rest reaches 18.350° (in 4, 16, 64 or 256
    steps alike). Its Jacobian determinant has the zero-load state's sign, so a check of that sign would have
    accepted it; where a contact uses more than half its friction the point is also solved from rest, so it is
    `multiple_roots`, with no number, however the layout is written. At 2.4 N·m the root is unique."""
    if compile_policy == "always" and native.compiler() is None:
        pytest.skip("no C compiler on this machine")
    monkeypatch.setenv("CVTDESIGN_COMPILE", compile_policy)
    data = lt.read(ROOT / "variants/existing.yaml")
    models = [compile_model(lt.layout_of(d)) for d in (data, lt.rotate(data, lt.axis_angle_matrix((3, 1, 2), np.radians(23))))]
    g = np.radians(-16.0)
    for m in models:
        r = m.evaluate(np.full(2, g), [2.4, 2.5])
        assert list(r["status"]) == [STATUS.index("ok"), STATUS.index("multiple_roots")]
        assert np.isnan(r["alpha"][1])
        assert np.degrees(r["alpha"][0]) == pytest.approx(np.degrees(loaded_from_rest(m, g, 2.4)["alpha"][0]), abs=1e-9)
    assert np.degrees(loaded_from_rest(models[0], g, 2.5)["alpha"][0]) == pytest.approx(18.350, abs=1e-3)
