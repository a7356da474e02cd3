"""Operating points given by steering angle instead of γ, and by brake torque τ2 instead of τ⊥, with the
model interpreted and compiled."""
from pathlib import Path

import numpy as np
import pytest

from cvtdesign.core import native
from cvtdesign.core.geometry import ideal_gamma, kim_gamma_from_phi
from cvtdesign.core.model import STATUS, compile_model
from cvtdesign.io.variant import load_variant

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module", params=["never", "always"])
def existing(request):
    """existing.yaml interpreted, and compiled to C (CVTDESIGN_COMPILE; skipped without a C compiler)."""
    if request.param == "always" and native.compiler() is None:
        pytest.skip("no C compiler on this machine")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("CVTDESIGN_COMPILE", request.param)
        yield compile_model(load_variant(ROOT / "variants/existing.yaml"))


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


def test_a_root_with_the_sphere_turning_backwards_is_not_a_number(existing):
    """Past Kim's envelope (existing CVT, γ = −80°, τ⊥ = 2.1 N·m) the Newton solve from ideal kinematics found a
    second root of the equations: ω2 = +907 rad/s where the ideal law gives −56.7 (power entering at both
    shafts, 351 W lost), reported `ok` with α = −10.6° (the ±90° wrap of a 169° error). Loading from rest
    reaches another root (ω2 ≈ −20 rad/s). A root where the sphere turns against the commanded axis is now
    `reversed` and carries no number; the shipped envelope has none."""
    res = existing.evaluate(np.radians([-80.0, -80.0]), [2.1, 1.0])
    assert list(res["status"]) == [STATUS.index("reversed"), STATUS.index("ok")]
    assert np.isnan(res["alpha"][0]) and np.isnan(res["omega_2"][0]) and np.isfinite(res["omega_2"][1])
    G, T = np.meshgrid(existing.layout.gamma_grid, existing.layout.load_grid, indexing="ij")
    assert not np.any(existing.evaluate(G, T)["status"] == STATUS.index("reversed"))


def test_a_solve_that_did_not_converge_is_not_called_gross_slip():
    """With a saturation law (existing.yaml + normal_force_variation + traction_saturation):
    - γ = −60°, τ⊥ = 6 N·m ended with ω2 = NaN and a residual whose ∞-norm skipped the NaN: it was counted
      as converged, and then as gross slip;
    - γ = −80°, τ⊥ = 1.8 N·m did not converge (residual 0.13) and was called gross slip because the last
      iterate had a contact near μN; stepping the load up from rest converges there with every contact
      near half of μN.
    Both are not_converged now."""
    L = load_variant(ROOT / "variants/existing.yaml")
    m = compile_model(L, ("drive_longitudinal_creep", "steering_lateral_creep", "normal_force_variation",
                          "traction_saturation"))
    res = m.evaluate(np.radians([-60.0, -80.0]), [6.0, 1.8])
    assert list(res["status"]) == [STATUS.index("not_converged")] * 2
