"""The dynamic model (core.dynamics) against the physics it must keep (issue 37's validation):

* its steady state is the quasi-static model's operating point (compare's figures) within 1e-6;
* with every contact removed, the sphere's angular momentum is conserved (and it is not with them);
* the power balance holds with the kinetic energy: dE_k/dt = P_in − P_loss, at states away from equilibrium;
* the linearised model's −3 dB bandwidth agrees with the response to a sinusoidal command within 5 %;
* a rotated statement of a layout has the same dynamic figures (the model refers to no fixed frame).
"""
from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from conftest import shipped_layout, shipped_model
from layout_transforms import axis_angle_matrix, dump, read, rotate
from cvtdesign.core.dynamics.linear import linear_at, sine_gain
from cvtdesign.core.dynamics.model import compile_dynamics
from cvtdesign.core.dynamics.response import command, step_response
from cvtdesign.core.dynamics.simulate import simulate, steady_state
from cvtdesign.io.dynamics import dynamic_parameters
from cvtdesign.io.variant import load_variant

DEG = np.pi / 180


def dynamic(name: str):
    layout = shipped_layout(name)
    return _models.setdefault(name, compile_dynamics(layout, dynamic_parameters(layout)))


_models: dict = {}


def outputs(model, X, u):
    return {k: np.array(v).ravel() for k, v in zip(model.outputs.name_out(), model.outputs(0, X, u, model.param_values))}


def steady_points(name: str, gammas, loads):
    """(steady model's result, [(γ, load, dynamic steady outputs or None)]) at the ok points of the grid."""
    model = shipped_model(name)
    g, l = np.meshgrid(gammas, loads, indexing="ij")
    res = model.evaluate(g, l)
    dyn = dynamic(name)
    got = []
    for i, j in zip(*np.nonzero(res["ok"])):
        u = command(dyn, g[i, j], l[i, j])
        X = steady_state(dyn, u)
        got.append(((i, j), None if X is None else outputs(dyn, X, u)))
    return res, got


def check_steady(name, gammas, loads):
    res, got = steady_points(name, gammas, loads)
    assert got, "no ok point to check"
    for (i, j), out in got:
        assert out is not None, f"{name}: no steady state at γ {np.degrees(res['gamma_cmd'][i, j]):g}°"
        assert abs(out["alpha"][0] - res["alpha"][i, j]) < 1e-6
        assert abs(out["ratio"][0] * res["omega_1"][i, j] - res["omega_2"][i, j]) < 1e-6 * abs(res["omega_1"][i, j])
        for k in ("tau_1", "tau_2"):
            assert abs(out[k][0] - res[k][i, j]) < 1e-6 * max(1.0, abs(res[k][i, j]))
        eff_dyn = out["power_loss"][0]
        assert abs(eff_dyn - res["power_loss"][i, j]) < 1e-6 * max(1.0, abs(res["power_loss"][i, j]))
        assert abs(out["motor_torque"][0] - res["steering_torque"][i, j]) < 1e-6


@pytest.mark.parametrize("name", ["box", "existing"])
def test_steady_state_is_the_quasi_static_point(name):
    check_steady(name, np.radians([-60, -20, 10, 40, 70]), [-0.8, 0.0, 0.6])


@pytest.mark.slow
@pytest.mark.parametrize("name", ["box", "existing"])
def test_steady_state_is_the_quasi_static_point_over_the_envelope(name):
    layout = shipped_layout(name)
    check_steady(name, layout.gamma_grid, layout.load_grid)


def test_angular_momentum_is_conserved_without_contacts():
    dyn = dynamic("box")
    u_on = command(dyn, 25 * DEG, 0.0)
    X0 = steady_state(dyn, u_on)
    J = dyn.parameters.sphere_inertia
    n = 3

    def sphere_momentum(tr):
        om_ref = np.linalg.norm(X0[:n])
        return J * tr.X[:n] / om_ref

    off = command(dyn, 40 * DEG, 0.0, contacts=False)
    tr = simulate(dyn, X0, [off], 0.2, 50)
    L = sphere_momentum(tr)
    assert np.max(np.abs(L - L[:, :1])) < 1e-9 * np.linalg.norm(L[:, 0])
    idlers = slice(4, 4 + sum(r.role == "steering" for r in dyn.layout.rollers))
    assert np.max(np.abs(tr.X[idlers] - tr.X[idlers, :1])) < 1e-9        # free rollers keep their speed
    assert np.max(np.abs(tr.out["phi"][-1] - 40 * DEG)) < 1e-3           # the forks still turn
    on = simulate(dyn, X0, [command(dyn, 40 * DEG, 0.0)], 0.2, 50)
    assert np.max(np.abs(sphere_momentum(on) - L[:, :1])) > 1e-3 * np.linalg.norm(L[:, 0])   # not vacuous


@pytest.mark.parametrize("name", ["box", "existing"])
def test_power_balance_with_kinetic_energy(name):
    dyn = dynamic(name)
    st = step_response(dyn, 10 * DEG, 40 * DEG, 0.5, duration=0.1)
    tr = st.trajectory
    X, u = ca.MX.sym("X", dyn.n_states), ca.MX.sym("u", 9)
    th = dyn.param_values
    ke = dict(zip(dyn.outputs.name_out(), dyn.outputs.call([0, X, u, th])))["kinetic_energy"]
    rate = ca.Function("dke", [X, u], [ca.jtimes(ke, X, dyn.rhs(0, X, u, th))])
    u1 = command(dyn, 40 * DEG, 0.5)
    moving = 0
    for k in range(0, tr.t.size, 25):
        out = outputs(dyn, tr.X[:, k], u1)
        dke = float(rate(tr.X[:, k], u1))
        scale = abs(out["power_in"][0]) + abs(out["power_loss"][0])
        assert abs(dke - (out["power_in"][0] - out["power_loss"][0])) < 1e-9 * scale
        moving += abs(dke) > 1e-3 * scale
    assert moving > 3          # states away from equilibrium, where kinetic energy changes


@pytest.mark.slow
def test_linear_bandwidth_agrees_with_the_time_response():
    dyn = dynamic("box")
    lin = linear_at(dyn, 25 * DEG, 0.5)
    assert lin.stable
    f = lin.bandwidth("gamma_axis")
    h0 = abs(lin.response("gamma_axis", [0.0])[0])
    measured = sine_gain(dyn, 25 * DEG, 0.5, f, pieces=30)
    assert abs(abs(measured) / h0 / (1 / np.sqrt(2)) - 1) < 0.05
    assert abs(np.angle(measured) - np.angle(lin.response("gamma_axis", [f])[0])) < 0.05


def test_a_faster_servo_gives_a_faster_step():
    """The step's times follow the steering motor: a servo twice as fast rises sooner (the figures move the
    right way with their cause)."""
    layout = shipped_layout("existing")
    base = dynamic_parameters(layout)
    fast = compile_dynamics(layout, dataclasses.replace(base, servo_bandwidth=2 * base.servo_bandwidth))
    slow = step_response(dynamic("existing"), 10 * DEG, 12 * DEG, 0.5)
    quick = step_response(fast, 10 * DEG, 12 * DEG, 0.5)
    assert slow.ok and quick.ok
    assert quick.rise_s < 0.8 * slow.rise_s


@pytest.mark.slow
def test_a_rotated_layout_has_the_same_dynamics():
    """The box stated in another orientation: the same bandwidth and step response (to solver tolerance)."""
    data = rotate(read("box"), axis_angle_matrix([0.3, -0.5, 0.8], 1.1))
    with tempfile.TemporaryDirectory() as d:
        layout = load_variant(dump(data, Path(d) / "box_rotated.yaml"))
        turned = compile_dynamics(layout, dynamic_parameters(layout))
        figures = [(linear_at(m, 25 * DEG, 0.5).bandwidth("ratio"),
                    step_response(m, 20 * DEG, 25 * DEG, 0.5, duration=0.3)) for m in (dynamic("box"), turned)]
    (f0, s0), (f1, s1) = figures
    assert abs(f1 / f0 - 1) < 1e-6
    assert abs(s1.rise_s - s0.rise_s) < 2e-3 and abs(s1.lag_s - s0.lag_s) < 2e-3
