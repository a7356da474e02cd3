"""core.sensitivity: the outputs' derivatives at solved points by the implicit function theorem written out
give the numbers of CasADi's own implicit derivatives (the point function, Newton rootfinder included,
differentiated as a whole: what core.uncertainty did before), under Kim's law with design symbols that move
the linkage (so the steering angle's own derivative counts: existing_kim with its first fork's axis a
design input) and under the FASTSIM law (deferred calls)."""
import casadi as ca
import numpy as np
import pytest

from cvtdesign.core.model import compile_model
from cvtdesign.core.sensitivity import derivatives
from cvtdesign.core.geometry import steering_angle_guess, steering_data
from cvtdesign.io.variant import load_spec, load_variant, resolve

OUTPUTS = ["alpha", "omega_2", "power_loss", "steering_torque", "N", "a", "fork_pivot", "fork_slide"]


def whole_point_jacobian(model, g, t, phi0, outputs, theta_cols, design_cols):
    """The reference: d outputs/d(θ[cols], design[cols]) of the point function differentiated as a whole."""
    pf = model.point_function(outputs)
    ins = [ca.MX.sym(n, pf.sparsity_in(i)) for i, n in enumerate(pf.name_in())]
    th, de = (ins[pf.name_in().index(w)] for w in ("theta", "design"))
    jac = ca.Function("ref", ins, [ca.horzcat(ca.jacobian(o, th)[:, theta_cols], ca.jacobian(o, de)[:, design_cols])
                                   for o in pf.call(ins)])
    got = jac.map(g.size)(g, model.layout.motor_speed, t, 0.0, phi0, model.param_values,
                          np.zeros((model.design.numel(), 1)))
    k = len(theta_cols) + len(design_cols)
    return [np.asarray(v).reshape(-1, g.size, k) for v in got]


def design_model(path, deltas: dict, effects=None):
    """The model of the variant at `path` with design symbols p added to its parameters (SI values + p, so
    design 0 is the variant)."""
    p = ca.SX.sym("p", len(deltas))
    return compile_model(resolve(load_spec(path), str(path), overrides={k: v + p[j] for j, (k, v) in
                                                                         enumerate(deltas.items())}), effects, design=p)


def polar_parameter(data: dict) -> None:
    """The axis of Kim's first fork (c1: polar 45°, azimuth −90°) at a parameter's polar angle, so that the
    linkage, and the steering angle, move with it."""
    data["parameters"] = {"pol": "45 deg", **data["parameters"]}
    data["steering"]["forks"][0]["axis"] = {"polar": "= pol", "azimuth": "-90 deg"}


NFV = ("drive_longitudinal_creep", "steering_lateral_creep", "normal_force_variation", "rolling_resistance")


# normal_force_variation makes ∂F/∂x ill-conditioned (condition number 2e8 at these points): two solves of it
# agree to about cond·ε = 4e-8 relative, and CasADi's unpivoted symbolic one was 2 % off
@pytest.mark.parametrize("name, deltas, effects, rtol", [
    ("existing_kim", {"pol": np.radians(45.0), "preload": 100.0, "r_steer": 0.038}, None, 1e-8),
    ("existing_kim", {"pol": np.radians(45.0)}, NFV, 1e-6),
    pytest.param("box", {"preload": 100.0, "r_drive": 0.040}, None, 1e-8, marks=pytest.mark.slow)])   # 7 s
def test_derivatives_match_the_whole_point_functions(name, deltas, effects, rtol, make_variant):
    g, t = np.radians([-60.0, -20.0, 10.0, 50.0]), np.array([-0.8, 0.3, 1.0, -0.2])
    path = make_variant(name, polar_parameter if name == "existing_kim" else None)
    model = design_model(path, deltas, effects)
    phi0 = steering_angle_guess(*steering_data(load_variant(path)), g)[0]   # of the numeric layout
    theta_cols, design_cols = list(range(len(model.param_names))), list(range(len(deltas)))
    ref = whole_point_jacobian(model, g, t, phi0, OUTPUTS, theta_cols, design_cols)
    got = derivatives(model, g, np.full(g.size, model.layout.motor_speed), t, phi0, OUTPUTS,
                      theta_cols, design_cols)
    for out, a, b in zip(OUTPUTS, ref, got):
        assert np.all(np.isfinite(b)), out
        # round-off where an output does not move (Kim's law: no spin moment on a steering fork)
        np.testing.assert_allclose(b, a, rtol=rtol, atol=max(rtol / 10 * np.abs(a).max(), 1e-12), err_msg=out)
    assert min(np.abs(r).max() for r in ref[:2] + ref[4:6]) > 1e-6        # α, ω2, N, a move with the inputs
    if name == "existing_kim":      # the steering angle moves with the fork's axis: the part through φ is there
        phi = derivatives(model, g, np.full(g.size, model.layout.motor_speed), t, phi0, ["phi"], [], [0])[0]
        assert np.abs(phi).min() > 1e-3


def test_points_asked_again_are_solved_once(make_variant, monkeypatch):
    """Derivatives at points the model has solved for derivatives before (a layout's figures' gradients and its
    plot's bands: the same ok points) reuse their solutions: one Newton solve of them, and the same numbers as a
    fresh model's; other points, or other loads, are solved anew."""
    from cvtdesign.core import sensitivity
    g, t = np.radians([-60.0, -20.0, 10.0, 50.0]), np.array([-0.8, 0.3, 1.0, -0.2])
    path = make_variant("existing_kim", polar_parameter)
    model = design_model(path, {"pol": np.radians(45.0)})
    phi0 = steering_angle_guess(*steering_data(load_variant(path)), g)[0]
    w = np.full(g.size, model.layout.motor_speed)
    solves, real = [], sensitivity.call_mapped
    monkeypatch.setattr(sensitivity, "call_mapped", lambda fn, args: (solves.append(fn.name()), real(fn, args))[1])
    roots_solved = lambda: sum("root" in name for name in solves)                 # noqa: E731
    first = derivatives(model, g, w, t, phi0, ["alpha"], [0, 1], [])
    again = derivatives(model, g, w, t, phi0, ["alpha", "omega_2", "N"], [0, 1], [0])
    assert roots_solved() == 1
    fresh = design_model(path, {"pol": np.radians(45.0)})
    for got, want in zip(first + again, derivatives(fresh, g, w, t, phi0, ["alpha"], [0, 1], []) +
                         derivatives(fresh, g, w, t, phi0, ["alpha", "omega_2", "N"], [0, 1], [0])):
        np.testing.assert_array_equal(got, want)
    derivatives(model, g[:3], w[:3], t[:3], phi0[:3], ["alpha"], [0], [])
    derivatives(model, g, w, t * 1.01, phi0, ["alpha"], [0], [])
    assert roots_solved() == 3
