"""compile_dynamics(layout, parameters) → the layout's dynamic model: an ODE compiled from the same equations as
the steady model (core.equations), so that its equilibria are the steady model's operating points.

States (scaled as the steady model's unknowns, core.equations.unknowns, then three of the steering):
  Ω/Ω_ref (3), ω2/ω1, each idler's ω/ω1, each contact's F_t/F_s and F_a/F_s (F_s = F_SCALE), the steering
  angle φ [rad], its rate φ̇ [rad/s] and the servo's integral ∫(φ_cmd − φ) dt [rad s].
Inputs (`INPUTS`): the commanded γ and its rate, the linkage's φ_cmd and its rate (held linear in time over a
  segment from t0), the motor shaft's speed ω1 (imposed), the load (τ⊥ or the brake torque τ2), whether it is τ2,
  and a switch that removes every contact (0) for the conservation checks.

Equations (J_s the sphere's inertia, J_i an idler's, J_2 shaft 2's, J_φ the steering's, at φ):
 * sphere:   J_s Ω̇ = Σ_i M_i, M_i = R n_i × F_i − M_r,i a_i + M_z,i n_i, each contact's moment about the centre
   (the steady model's moment balance, Kim et al., "Causes of microslip in a continuously variable
   transmission", eqs 19-32, generalised);
 * idler i:  J_i ω̇_i = −r_i F_t,i + M_r,i (the roller's torque balance, with its inertia);
 * shaft 2:  J_2 ω̇_2 = τ_2,ext − Σ_{i on 2} ρ_i (r_i F_t,i − M_r,i); the outside torque τ_2,ext is the load
   input itself (load_is_tau_2 = 1: a brake, or the operator's push on the joint; what the transient figures
   hold, core.dynamics.response.start), or the one that holds τ⊥ at the load, τ⊥ = −τ1 sin γ + τ2 (s cos γ −
   c sin γ) (core.kinematics) with τ1 the motor's torque Σ_{i on 1} ρ_i (r_i F_t,i − M_r,i) at the imposed ω1:
   the steady model's definition of an operating point, exact at a steady state, but in a transient it makes
   shaft 2's torque follow the motor's instantly (an operator of no inertia and infinite speed), which on the
   box swings the axis through 180° during a fast step;
 * contact i: Ḟ_i = −((V_i + w_i) / σ_i) K_i ρ_i, ρ_i the law's two residual rows at the current slip (zero at
   the steady law), K_i the force each row stands for at fixed slip (ContactRows.force_per_row): the force
   relaxes to the law's over the relaxation length σ_i = k_σ a_i (Pacejka) of the distance the patch's material
   travels, rolled (V_i) and slid (w_i = |(s_t, s_a, a_i Ω_spin)|, the slip and the spin at the patch's edge).
   Under a linear law this is Ḟ = −((V + w)/σ)(F + s/c): at creepages of 1e-3 the slid part moves the rate by
   1e-3; where the contact stops rolling and slides (a fork turned fast), it still reaches its sliding force
   over σ of sliding, as a patch does, instead of freezing;
 * steering: J_φ φ̈ = τ_m − Σ_i ρ_i f_i·M_i (each fork's contact moment through the linkage, as the steady
   model's `steering_torque`); a turning fork moves its contact (core.equations, fork_rate);
 * motor: a position servo u = K_p e + K_i ∫e − K_d φ̇, e = φ_cmd − φ (core.dynamics.parameters), and the
   torque it gets, τ_m = clip(u, ±τ_max (1 − |φ̇|/φ̇_max)); the integral is held back while clipped
   (back-calculation, d∫e/dt = e + 3 (τ_m − u)/K_p).

At an equilibrium Ω̇ = 0 is the moment balance, ω̇_i = 0 the idlers', ω̇_2 = 0 the load's row, Ḟ = 0 the law's
rows, and φ = φ_cmd, φ̇ = 0: the steady model's residual (core.model) and the linkage's angle, so the dynamic
model's steady state is the quasi-static model's answer (tests/unit/core/test_dynamics.py).
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from cvtdesign.core.contact.laws import check_effects, contact_law
from cvtdesign.core.deferred import DeferredCalls
from cvtdesign.core.dynamics.parameters import DynamicParameters
from cvtdesign.core.effects import parameter_vector
from cvtdesign.core.equations import F_SCALE, Hooks, equations, unknowns
from cvtdesign.core.kinematics import shaft_frame
from cvtdesign.core.layout import Layout
from cvtdesign.core.model import ideal_unknowns

INPUTS = ("gamma_cmd", "gamma_rate", "phi_cmd", "phi_rate", "t0", "omega_1", "load", "load_is_tau_2", "contacts")
OUTPUTS = ("gamma_axis", "ratio", "alpha", "phi", "phi_rate", "motor_torque", "motor_demand", "motor_available",
           "steering_torque",
           "tau_1", "tau_2", "kinetic_energy", "power_in", "power_loss", "utilisation", "N", "F_t", "F_a")


@dataclass
class DynamicModel:
    """The compiled dynamic model of one layout (module docstring). `rhs(t, X, u, θ)` → Ẋ and
    `outputs(t, X, u, θ)` → OUTPUTS (scalars, and one row per contact for utilisation, N, F_t, F_a), with u the
    INPUTS in their order and θ the effects' parameters (and the design's values last, for a model compiled
    with design symbols); `steady_guess(u)` the ideal kinematics with no force, the servo at rest."""
    layout: Layout
    parameters: DynamicParameters
    param_values: list
    rhs: ca.Function
    outputs: ca.Function
    steady_guess: ca.Function
    n_states: int
    roller_names: list
    layout_frame: object = None    # the layout's core.kinematics.ShaftFrame

    def inputs(self, gamma, phi, omega_1=None, load=0.0, load_is_tau_2=False, gamma_rate=0.0, phi_rate=0.0,
               t0=0.0, contacts=True) -> np.ndarray:
        """The INPUTS vector of a segment that starts at t0 [s] at command γ [rad] (linkage angle φ [rad])
        and moves at the given rates [rad/s]."""
        w1 = self.layout.motor_speed if omega_1 is None else omega_1
        return np.array([gamma, gamma_rate, phi, phi_rate, t0, w1, load, float(load_is_tau_2), float(contacts)],
                        float)


def compile_dynamics(layout: Layout, parameters: DynamicParameters, effects=None, design: ca.SX | None = None
                     ) -> DynamicModel:
    """The layout's dynamic model with the given effects (default: the variant's; module docstring). `design`:
    the symbols the layout's fields depend on (an optimisation study's, core.model.compile_model); its
    functions then take the design's values as a last input. The parameters (inertias, motor) stay numbers."""
    law = contact_law(layout.contact_law)
    effects = check_effects(tuple(layout.effects if effects is None else effects), f"{layout.file}: effects",
                            layout.contact_law)
    pnames, pvalues = parameter_vector(effects, layout.effect_parameters)
    theta = ca.SX.sym("theta", len(pnames))
    hooks = Hooks(effects, theta, pnames)
    t = ca.SX.sym("t")
    u_in = ca.SX.sym("u", len(INPUTS))
    g0, g_rate, p0, p_rate, t0, w1, load, brake, on = ca.vertsplit(u_in)
    gamma, phi_cmd = g0 + g_rate * (t - t0), p0 + p_rate * (t - t0)
    u = unknowns(layout, w1)
    phi, phid, integral = (ca.SX.sym(s) for s in ("phi", "phi_rate", "servo_integral"))
    X = ca.vertcat(u.x, phi, phid, integral)
    phi_eff = hooks.transform("steering_angle", phi)
    calls = DeferredCalls()
    const = [law.constants(layout, r) for r in layout.rollers]
    gear = ca.jacobian(phi_eff, phi)          # dφ_eff/dφ: 1 unless an effect scales the linkage's angle
    slip, moment, idle, tau, per, _ = equations(layout, hooks, law, const, u, w1, phi_eff, calls,
                                                fork_rate=gear * phid)
    relax, sliding = _relaxation(layout, slip, per, parameters, u)
    steer = gear * sum(r.fork_ratio * tf for r, tf in zip(layout.rollers, per["T_fork"]))
    motor = _servo(parameters, phi_cmd - phi, integral, phid)
    frame = shaft_frame(layout)
    tau2_ext = brake * load + (1 - brake) * (load + on * tau[1] * ca.sin(gamma)) / (
        frame.s * ca.cos(gamma) - frame.c * ca.sin(gamma))
    J = parameters
    idlers = [r for r in layout.rollers if r.role == "steering"]
    dOm = on * moment / J.sphere_inertia
    dw2 = (tau2_ext - on * tau[2]) / J.output_inertia
    dwi = [on * row * r.radius * F_SCALE / J.roller_inertia[layout.rollers.index(r)] for row, r in zip(idle, idlers)]
    dphid = (motor["torque"] - on * steer) / J.steering_inertia
    Xdot = ca.vertcat(dOm / u.om_ref, dw2 / w1, *[d / w1 for d in dwi], relax / F_SCALE, phid, dphid, motor["integral"])
    ins = [t, X, u_in, theta] + ([] if design is None else [design])
    names = ["t", "X", "u", "theta", "design"][:len(ins)]
    rhs = calls.close("dynamics", ins, [Xdot])
    outs = _outputs(layout, parameters, u, per, tau, tau2_ext, motor, steer, frame, gamma, w1, phi, phid, on)
    outs["utilisation"] = ca.fmax(outs["utilisation"], sliding)
    outputs = calls.close("dynamics_outputs", ins, [outs[k] for k in OUTPUTS])
    guess = _steady_guess(layout, frame, [u_in] + ins[4:], u.om_ref, phi_eff, phi)
    return DynamicModel(layout, parameters, pvalues, rhs, ca.Function("outputs", ins, outputs.call(ins), names,
                                                                      list(OUTPUTS)),
                        guess, X.numel(), [r.name for r in layout.rollers], frame)


def _relaxation(layout, slip, per, parameters, u):
    """(Ḟ [N/s] of every contact's two forces, F_t of every contact then F_a; the traction utilisation of the
    force the law gives at each contact's current slip, F* = F − K ρ): each force relaxes to F* at the rate
    (V + w)/σ, σ = k_σ a (module docstring); `slip` the laws' rows, two a contact. A contact is in gross slip
    when its force or F* reaches μN: a force that lags may still be below μN while the patch already slides."""
    dFt, dFa, target = [], [], []
    for i in range(len(layout.rollers)):
        rate = (per["V"][i] + per["slide"][i]) / (parameters.relaxation_factor * per["a"][i])
        kt, ka = per["force_per_row"][i]
        dFt.append(-rate * kt * slip[2 * i])
        dFa.append(-rate * ka * slip[2 * i + 1])
        ft, fa = u.Ft[i] - kt * slip[2 * i], u.Fa[i] - ka * slip[2 * i + 1]
        target.append(ca.sqrt(ft ** 2 + fa ** 2 + 1e-6) / (per["mu"][i] * per["N"][i]))
    return ca.vertcat(*dFt, *dFa), ca.vertcat(*target)


def _servo(parameters: DynamicParameters, error, integral, phid) -> dict:
    """The steering motor (module docstring): its demand u, the torque its curve allows at φ̇, the torque it
    gives, and the integral's rate."""
    kp, ki, kd = parameters.servo_gains()
    demand = kp * error + ki * integral - kd * phid
    available = parameters.motor_torque * ca.fmax(0, 1 - ca.fabs(phid) / parameters.motor_speed)
    torque = ca.fmin(ca.fmax(demand, -available), available)
    return {"demand": demand, "available": available, "torque": torque,
            "integral": error + (torque - demand) * 3 / kp}


def _outputs(layout, parameters, u, per, tau, tau2_ext, motor, steer, frame, gamma, w1, phi, phid, on) -> dict:
    """OUTPUTS as expressions of the state (module docstring). The kinetic energy leaves out shaft 1, whose speed
    is imposed; power_in is what the motor shaft, the load and the steering motor put in, power_loss what the
    contacts dissipate (core.equations' `loss`, at the forks' rates), so d(kinetic_energy)/dt = power_in −
    power_loss."""
    J = parameters
    idlers = [(r, u.w_idle[r.name]) for r in layout.rollers if r.role == "steering"]
    ke = 0.5 * (J.sphere_inertia * ca.sumsqr(u.Om) + J.output_inertia * u.w2 ** 2 + J.steering_inertia * phid ** 2
                + sum(J.roller_inertia[layout.rollers.index(r)] * w ** 2 for r, w in idlers))
    return {"gamma_axis": frame.axis_angle(u.Om), "ratio": u.w2 / w1, "alpha": frame.slip_angle(w1, u.w2, gamma),
            "phi": phi, "phi_rate": phid, "motor_torque": motor["torque"], "motor_demand": motor["demand"],
            "motor_available": motor["available"], "steering_torque": on * steer, "tau_1": on * tau[1],
            "tau_2": tau2_ext, "kinetic_energy": ke,
            "power_in": on * tau[1] * w1 + tau2_ext * u.w2 + motor["torque"] * phid,
            "power_loss": on * sum(per["loss"]), "utilisation": ca.vertcat(*per["utilisation"]),
            "N": ca.vertcat(*per["N"]), "F_t": u.Ft, "F_a": u.Fa}


def _steady_guess(layout, frame, ins, om_ref, phi_eff, phi) -> ca.Function:
    """(u[, design]) → the state of the ideal kinematics about the commanded axis with no force, φ = φ_cmd, the
    servo at rest: where a steady-state solve starts (as the steady model's does, core.model.ideal_unknowns)."""
    g0, _, p0, _, _, w1, *_ = ca.vertsplit(ins[0])
    x0 = ideal_unknowns(layout, frame, g0, w1, ca.substitute(phi_eff, phi, p0), om_ref)
    return ca.Function("steady_guess", ins, [ca.vertcat(x0, p0, 0, 0)])
