"""A study's dynamic constraints (docs/dynamics.md, docs/optimisation.md): the transmission's bandwidth and the
fastest ratio change its steering allows, as rows of the design at a few operating points of the envelope, from
the dynamic model compiled with the design variables as symbols (core.dynamics.model).

* `constraints.min_bandwidth_Hz: f`: at each point, the axis angle's small-signal response to the command at f
  is at least 1/√2 of its static gain, |H(j2πf)|² / |H(0)|² ≥ 1/2, H from the model linearised at its steady
  state with shaft 2's torque held (core.dynamics.linear). Where the response falls monotonically, as on the
  shipped layouts below their first resonance, this is f_3dB ≥ f. The steady state comes from a Newton solve
  of Ẋ = 0 and the linearisation from the model's Jacobian, so the row's derivatives follow by the implicit
  function theorem; the derivative of the Jacobian needs the creep-force table's second derivatives, which
  CasADi takes by finite differences of its exact first ones (the one part that is not exact).
* `constraints.min_ratio_rate_deg_s: r`: at each point, with the forks turning steadily at the rate that changes
  γ at ±r (φ̇ = ±r dφ/dγ) and the sphere, rollers and contact forces at their steady state under that rate, the
  steering motor's torque-speed curve gives the contacts' torque through the linkage, |τ| ≤ τ_max (1 −
  |φ̇|/φ̇_max), and no contact passes (1 − traction margin) of its friction. The dynamic model's fastest ratio
  change (core.dynamics.response, `cvtdesign transient`) checks the optimum in time.

The inertias and the steering motor are the base design's (io.dynamics): a motor and its servo tuned once. The
points: the commanded γ of `constraints.dynamic_gamma` (default: POINTS spread over the study's envelope), at the
envelope's largest positive load. Near γ = ±90° the output shaft turns much faster than the motor's, so its
inertia seen from the motor's side is large and its speed settles slowly (on the box at ±80° and 1 N·m, a pole at
−4.9 1/s: 0.8 Hz whatever the placement); a study asks for a bandwidth where the cobot needs it.
"""
from __future__ import annotations

import casadi as ca
import numpy as np

from cvtdesign.core.dynamics.model import INPUTS, OUTPUTS, compile_dynamics
from cvtdesign.core.geometry import steering_angle_guess, steering_data
from cvtdesign.errors import InputError
from cvtdesign.io.dynamics import dynamic_parameters
from cvtdesign.io.units import is_plain_number, to_si

POINTS = 5          # commanded γ at which the dynamic rows hold


def dynamic_rows(nlp, rows) -> None:
    """Add the study's bandwidth and ratio-rate rows (module docstring) to `rows`, if it asks for them."""
    f_min, rate_min = dynamic_limits(nlp.spec.constraints, nlp.where)
    if f_min is None and rate_min is None:
        return
    dyn = compile_dynamics(nlp.layout, dynamic_parameters(nlp.base), effects=nlp.spec.effects, design=nlp.p)
    gammas = _gammas(nlp)
    load = float(np.max(nlp.l_pts))
    theta = ca.DM(nlp.model.param_values)
    phi_fn = nlp.model.point_function(["phi"])
    fns = _functions(dyn, nlp, theta)
    for g, phi0 in zip(gammas, steering_angle_guess(*steering_data(nlp.base), gammas)[0]):
        phi = phi_fn(g, nlp.w1, load, 0.0, phi0, theta, nlp.P)
        slope = _linkage_slope(nlp)(phi, g, nlp.P)
        at = f"γ={np.degrees(g):+.0f}° τ⊥={load:+.3g}"
        if f_min is not None:
            rows.add(_bandwidth_row(dyn, fns, nlp, g, load, phi, slope, f_min), 0.0, np.inf, "bandwidth",
                     [f"bandwidth ≥ {f_min:g} Hz at {at}"])
        if rate_min is not None:
            for sign in (1, -1):
                expr, labels = _rate_rows(dyn, fns, nlp, theta, g, load, phi, sign * rate_min * slope, at,
                                          sign * np.degrees(rate_min))
                rows.add(expr, -np.inf, 0.0, "ratio_rate", labels)


def _gammas(nlp) -> np.ndarray:
    """The commanded γ [rad] of the dynamic rows: constraints.dynamic_gamma, else POINTS spread over the
    envelope's γ."""
    given = nlp.spec.constraints.dynamic_gamma
    grid = np.unique(nlp.g_pts)
    if not given:
        return grid[np.unique(np.round(np.linspace(0, grid.size - 1, min(POINTS, grid.size))).astype(int))]
    out = []
    for i, raw in enumerate(given):
        where = f"{nlp.where}: constraints.dynamic_gamma[{i}]"
        g = to_si(raw, "angle", where)
        if not grid.min() - 1e-12 <= g <= grid.max() + 1e-12:
            raise InputError(f"{where}: expected an angle within the envelope's γ, {np.degrees(grid.min()):g}.."
                             f"{np.degrees(grid.max()):g} deg, got {raw}")
        out.append(float(g))
    return np.array(out)


def _inputs(nlp, g, load, phi):
    """The INPUTS of a constant command at γ, load and linkage angle φ."""
    values = {"gamma_cmd": g, "gamma_rate": 0.0, "phi_cmd": phi, "phi_rate": 0.0, "t0": 0.0, "omega_1": nlp.w1,
              "load": load, "load_is_tau_2": 0.0, "contacts": 1.0}
    return ca.vertcat(*[values[k] for k in INPUTS])


def _functions(dyn, nlp, theta) -> dict:
    """What every point's rows call, built once: Newton on Ẋ = 0 ('steady'), on the first states' rates at a
    given fork rate ('rate'), shaft 2's torque at a state ('held') and the linearisation (A, ∂Ẋ/∂u, ∂γ_axis/∂X)."""
    n, nx = dyn.n_states, dyn.n_states - 3
    Xs, us, ps, rate = ca.MX.sym("X", n), ca.MX.sym("u", len(INPUTS)), ca.MX.sym("p", nlp.p.numel()), ca.MX.sym("r")
    opts = {"abstol": 1e-12, "max_iter": 60, "error_on_fail": False, "show_eval_warnings": False}
    f = dyn.rhs(0, Xs, us, theta, ps)
    outs = dyn.outputs.call([0, Xs, us, theta, ps])
    xs = ca.MX.sym("x", nx)
    f_rate = dyn.rhs(0, ca.vertcat(xs, us[INPUTS.index("phi_cmd")], rate, 0), us, theta, ps)[:nx]
    return {"steady": ca.rootfinder("dyn_steady", "newton", ca.Function("g", [Xs, ca.vertcat(us, ps)], [f]), opts),
            "rate": ca.rootfinder("dyn_rate", "newton", ca.Function("g", [xs, ca.vertcat(us, ps, rate)], [f_rate]),
                                  opts),
            "held": ca.Function("held", [Xs, us, ps], [outs[OUTPUTS.index("tau_2")]]),
            "lin": ca.Function("lin", [Xs, us, ps], [ca.jacobian(f, Xs), ca.jacobian(f, us),
                                                     ca.jacobian(outs[OUTPUTS.index("gamma_axis")], Xs)])}


def _bandwidth_row(dyn, fns, nlp, g, load, phi, slope, f_hz):
    """|H(j2πf)|²/|H(0)|² − 1/2 of the axis angle at one point (module docstring); `fns` from _functions."""
    u = _inputs(nlp, g, load, phi)
    n = dyn.n_states
    X = fns["steady"](dyn.steady_guess(u, nlp.P), ca.vertcat(u, nlp.P))
    held = fns["held"](X, u, nlp.P)
    u_held = ca.vertcat(u[:INPUTS.index("load")], held, 1, u[INPUTS.index("contacts"):])   # shaft 2's torque held
    A, Bu, C = fns["lin"](X, u_held, nlp.P)
    B0 = Bu[:, INPUTS.index("gamma_cmd")] + Bu[:, INPUTS.index("phi_cmd")] * slope
    w = 2 * np.pi * f_hz
    eye = ca.MX.eye(n)
    xr_xi = ca.solve(ca.vertcat(ca.horzcat(-A, -w * eye), ca.horzcat(w * eye, -A)), ca.vertcat(B0, ca.MX(n, 1)))
    h = ca.mtimes(ca.horzcat(C, ca.MX(1, n)), xr_xi), ca.mtimes(ca.horzcat(ca.MX(1, n), C), xr_xi)
    h0 = -ca.mtimes(C, ca.solve(A, B0))
    return (h[0] ** 2 + h[1] ** 2) / h0 ** 2 - 0.5


def _rate_rows(dyn, fns, nlp, theta, g, load, phi, phi_rate, at, rate_deg):
    """The motor's torque against its curve and each contact's traction at a steady fork rate (module
    docstring): rows ≤ 0, and their labels; `fns` from _functions."""
    u = _inputs(nlp, g, load, phi)
    nx = dyn.n_states - 3
    x = fns["rate"](dyn.steady_guess(u, nlp.P)[:nx], ca.vertcat(u, nlp.P, phi_rate))
    outs = dict(zip(OUTPUTS, dyn.outputs.call([0, ca.vertcat(x, phi, phi_rate, 0), u, theta, nlp.P])))
    P = dyn.parameters
    available = P.motor_torque * (1 - ca.fabs(phi_rate) / P.motor_speed)
    margin = 0.0 if nlp.margin is None else nlp.margin
    torque = ca.vertcat(outs["steering_torque"] - available, -outs["steering_torque"] - available)
    util = outs["utilisation"] - (1 - margin)
    labels = [f"steering torque at {rate_deg:+g}°/s, {at}"] * 2 + \
             [f"traction of {r} at {rate_deg:+g}°/s, {at}" for r in nlp.model.roller_names]
    return ca.vertcat(torque, util), labels


def _linkage_slope(nlp) -> ca.Function:
    """(φ, γ, design) → dφ/dγ of the linkage at its solved angle: −(∂r/∂γ)/(∂r/∂φ) of the steering residual r."""
    phi, g = ca.SX.sym("phi"), ca.SX.sym("gamma")
    r = nlp.model.steering_residual(phi, ca.vertcat(g, nlp.p))
    return ca.Function("linkage_slope", [phi, g, nlp.p], [-ca.jacobian(r, g) / ca.jacobian(r, phi)])


def dynamic_limits(cs, where: str) -> tuple[float | None, float | None]:
    """(constraints.min_bandwidth_Hz [Hz], constraints.min_ratio_rate_deg_s [rad/s]) of a study's Constraints
    (design.study_file, which checks them with this before any work), each None when not set. A
    plain number is in the unit the field's name gives (Hz, deg/s); a quantity is converted ('0.5 rad/s')."""
    got = []
    for key, kind, unit, factor, hi in (("min_bandwidth_Hz", "frequency", "Hz", 1.0, 1000.0),
                                        ("min_ratio_rate_deg_s", "speed", "deg/s", np.pi / 180, 1e5)):
        raw, w = getattr(cs, key), f"{where}: constraints.{key}"
        if raw is None:
            got.append(None)
            continue
        value = float(raw) * factor if is_plain_number(raw) else to_si(raw, kind, w)
        if not 0 < value / factor <= hi:
            raise InputError(f"{w}: expected more than 0 and at most {hi:g} {unit}, got {raw}")
        got.append(value)
    return got[0], got[1]
