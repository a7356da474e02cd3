"""compile(layout, effects) → CasADi functions of one steady operating point and of a grid.

One generalised model for every variant; no variant-specific equations. Notation (per contact i):
n_i outward contact normal, a_i roller axle (positive spin axis), t_i = n_i × a_i rolling direction,
R sphere radius, r_i roller radius, Ω sphere angular velocity, ω_i roller speed about a_i, F_i the
tangential force ON THE SPHERE from roller i (components F_t along t_i, F_a along a_i), N_i normal force.

Equations (all derived from the vectors; DESIGN.md sec. 1 conventions):
 * slip velocity of sphere over roller at the contact: s_i = R·Ω × n_i − r_i·ω_i·t_i
   (no slip: r_i ω_i = −R Ω·a_i, which gives ω1 = (R/r1)Ω·d1 for Kim's D1 at d2 with axle −d1);
 * creep law, dissipative (F·s ≤ 0): s_t + c_t·F_t = 0, s_a + c_a·F_a = 0 with c = ε·V (Kim's slip ratio
   ψ = ε_D F and slip angle α⊥ = ε_S F, V = |R Ω·a_i| the rolling speed) plus Gillespie's spin term
   (b/(μN))·|Ω·n_i| on drive rollers (Brokowski eqs 14-19), and a tiny floor EPS_RIGID·V_ref on directions
   no effect makes compliant (rigid in Kim's sense, but keeps the statically indeterminate system regular);
 * sphere moment balance: Σ R n_i × F_i + Σ (rolling-resistance moments) = 0;
 * sphere force balance on preloaded compliant mounts: N_i = P_i + k_i n_i·δ, Σ (F_i − N_i n_i) = 0,
   solved for the sphere's displacement δ in closed form (a 3×3 solve), so the normal-force distribution of
   an over-constrained layout comes from compliance;
 * idler (steering) roller torque balance: −r_i F_t,i + M_rr,i = 0;
 * shaft torques τ_s = Σ_{i on s} ρ_i (r_i F_t,i − M_rr,i) (torque applied to the shaft from outside);
 * the operating point fixes ω1 and the lateral load τ⊥ = −τ1 sin γ_cmd + τ2 cos γ_cmd (Kim eq 17).
Unknowns: Ω, ω2, idler speeds, (F_t, F_a) per contact. Solved by CasADi's Newton rootfinder, whose implicit
derivatives give the optimiser exact gradients.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from . import contact
from .effects import EFFECTS, parameter_vector
from .geometry import D1, D2, ideal_gamma, roller_pose, steering_angle_guess, steering_data, vec
from .variant import Layout

EPS_RIGID = 1e-9      # [1/N] creep-compliance floor of the directions that are rigid in the model
F_SCALE = 10.0        # [N] force scaling of the unknowns
RES_TOL = 1e-8        # scaled residual above which a point is reported as not converged
SAT_LIMIT = 0.999     # traction utilisation |F|/(μN) beyond which traction_saturation means gross slip

CONTACT_OUTPUTS = ("N", "F_t", "F_a", "utilisation", "p_max", "xi", "eta", "spin")
POINT_OUTPUTS = ("omega_2", "tau_1", "tau_2", "phi", "gamma_axis", "alpha", "alpha_steering", "alpha_drive",
                 "power_loss", "residual", "Omega_x", "Omega_y", "Omega_z")


def _wrap(x):
    """Wrap an angle between two axis directions to [−π/2, π/2]: an axis is a line, defined modulo π
    (with ω1 < 0 the shaft-speed vector points the other way along the same line)."""
    return ca.atan2(ca.sin(2 * x), ca.cos(2 * x)) / 2


def _sabs(x, eps):
    return ca.sqrt(x * x + eps * eps)


@dataclass
class CompiledModel:
    """The compiled model of one layout with one set of effects.

    `point` maps (γ_cmd [rad], ω1 [rad/s], load [N m], load_is_τ2 (0: the load is τ⊥, 1: it is the brake
    torque τ2), φ guess [rad], θ effect parameters, p design) to a
    dict of POINT_OUTPUTS (scalars) and CONTACT_OUTPUTS (one entry per roller). `grid` evaluates many
    points at once, compiled and mapped."""
    layout: Layout
    effects: tuple
    param_names: list
    param_values: list
    design: ca.SX
    point: ca.Function
    roller_names: list
    residual: ca.Function          # (x, params) → scaled residual; params = [γ, ω1, load, load_is_τ2, φ_cmd, θ, p]
    initial_guess: ca.Function     # params → x0 (ideal kinematics, no forces)
    outputs: ca.Function           # (x, params) → the point outputs
    _maps: dict = field(default_factory=dict)
    _point_builder: object = None  # names → a `point` function with only those outputs
    hertz_p0: ca.Function = None       # design → Hertz peak pressure of each contact at its preload [Pa]
    peak_pressure: ca.Function = None  # (N, p0, design) → Hertz peak pressure p0·(max(N, 0)/preload)^(1/3) [Pa]

    def point_function(self, outputs) -> ca.Function:
        """`point` restricted to the named outputs (POINT_OUTPUTS, CONTACT_OUTPUTS, 'steer_misfit'): same
        inputs and the same expressions, but only what those outputs need is evaluated and differentiated
        (the Newton solve is left out when only 'steer_misfit' is asked for)."""
        return self._point_builder(list(outputs))

    def steering_guess(self, gammas):
        return steering_angle_guess(*steering_data(self.layout), np.asarray(gammas, float))

    def evaluate(self, gammas, loads, speeds=None, theta=None, design=None, load_kind="tau_perp",
                 steering_angles=None):
        """Evaluate operating points (broadcastable arrays): commanded γ [rad] (or, with `steering_angles`
        [rad], the linkage's angle φ, and γ_cmd is then the ideal γ of that φ), loads [N m] that are the
        lateral load τ⊥ (load_kind 'tau_perp') or the brake-shaft torque τ2 ('tau_2'), motor speeds ω1
        [rad/s] (default: the variant's). Returns a dict of numpy arrays; points whose Newton solve did
        not converge have `converged` False and NaN in every output."""
        if load_kind not in ("tau_perp", "tau_2"):
            raise ValueError(f"load_kind must be 'tau_perp' or 'tau_2', not {load_kind!r}")
        if steering_angles is not None:
            gammas = np.vectorize(lambda p: ideal_gamma(self.layout, p))(np.asarray(steering_angles, float))
        gammas, loads = np.broadcast_arrays(np.asarray(gammas, float), np.asarray(loads, float))
        shape = gammas.shape
        g, l = gammas.ravel(), loads.ravel()
        w = np.broadcast_to(self.layout.motor_speed if speeds is None else np.asarray(speeds, float), shape).ravel()
        phi0, _ = self.steering_guess(g)
        th = np.asarray(self.param_values if theta is None else theta, float)
        p = np.zeros(self.design.numel()) if design is None else np.asarray(design, float)
        n = g.size
        if n not in self._maps:
            self._maps[n] = self.point.map(n, "thread", 2)
        out = self._maps[n](g, w, l, float(load_kind == "tau_2"), phi0, th, p)
        names = self.point.name_out()
        res = {k: np.asarray(v) for k, v in zip(names, out)}
        converged = np.isfinite(res["residual"][0]) & (res["residual"][0] < RES_TOL)
        result = {"converged": converged.reshape(shape), "gamma_cmd": gammas, "load": loads,
                  "omega_1": w.reshape(shape)}
        for k, v in res.items():
            v = np.where(converged, v, np.nan)
            result[k] = v[0].reshape(shape) if v.shape[0] == 1 else v.reshape((v.shape[0],) + shape)
        return result


def _steering_solver(layout: Layout, design: ca.SX):
    """Rootfinder φ(γ_cmd): the steering angle at which every steered roller rolls without lateral slip
    about the commanded axis u = cos γ d1 + sin γ d2 (least squares, so over-determined linkages work).
    For Kim's linkage it reproduces eq 5 inverted."""
    phi, gamma = ca.SX.sym("phi"), ca.SX.sym("gamma")
    u = ca.cos(gamma) * vec(D1) + ca.sin(gamma) * vec(D2)
    res = ca.vertcat(*[ca.dot(ca.cross(*roller_pose(r, phi)), u) for r in layout.rollers if r.fork_axis is not None])
    g = ca.jacobian(ca.sumsqr(res) / 2, phi)
    f = ca.Function("steer_res", [phi, ca.vertcat(gamma, design)], [g])
    misfit = ca.Function("steer_misfit", [phi, ca.vertcat(gamma, design)], [ca.sqrt(ca.sumsqr(res) + 1e-30)])
    return ca.rootfinder("steer", "newton", f, {"abstol": 1e-14, "max_iter": 30, "error_on_fail": False,
                                                  "show_eval_warnings": False}), misfit


def compile_model(layout: Layout, effects=None, design: ca.SX | None = None) -> CompiledModel:
    """Compile `layout` with the given effects (default: the variant's) into a CompiledModel.

    `design` is the vector of CasADi symbols that the layout's fields may depend on (design variables of
    an optimisation study); numeric layouts need none."""
    effects = tuple(layout.effects if effects is None else effects)
    on = set(effects)
    for e in effects:
        if e not in EFFECTS:
            raise ValueError(f"unknown effect '{e}'")
    design = ca.SX(0, 1) if design is None else design
    pnames, pvalues = parameter_vector(effects, layout.effect_parameters)
    theta = ca.SX.sym("theta", len(pnames))
    P = {name: theta[i] for i, name in enumerate(pnames)}

    def par(effect, name):
        return P[f"{effect}.{name}"]

    rollers = layout.rollers
    R = layout.sphere_radius
    gamma, w1, load, brake, phi_cmd = (ca.SX.sym(s) for s in ("gamma_cmd", "omega_1", "load", "load_is_tau_2", "phi_cmd"))
    # steering_offset: the linkage's actual angle is the commanded one plus a constant
    phi = phi_cmd + (par("steering_offset", "offset") if "steering_offset" in on else 0)

    # per-contact constants at the preload: Hertz ellipse and Kalker/Kim creep compliances
    sm = layout.sphere_material
    const = []
    for r in rollers:
        A, B = contact.curvature_sums(R, r.radius, r.crown_radius)
        Es, G, nu = contact.contact_material(r.material.E, r.material.nu, sm.E, sm.nu)
        a, b, p0, _ = contact.hertz_ellipse(A, B, r.preload, Es)
        C11, C22, _ = contact.kalker_coefficients(a / b, nu)
        e_long, e_lat = contact.creep_compliances(G, a, b, C11, C22)
        drive = r.role != "steering"
        kim = layout.creep_drive if drive else layout.creep_steering
        eps0 = kim if kim is not None else (e_long if drive else e_lat)
        # the normal force at which eps0 holds: the variant's reference force for given creep constants
        # (Kim's were fitted at a 100 N preload), else the preload at which Hertz + Kalker computed them
        n_ref = layout.creep_reference_force if kim is not None and layout.creep_reference_force is not None \
            else r.preload
        mu = ca.fmin(r.material.mu, sm.mu)
        const.append(dict(a=a, b=b, p0=p0, eps0=eps0, mu=mu, n_ref=n_ref))

    primary = {s: next(r for r in rollers if r.role == "drive" and r.shaft == s) for s in (1, 2)}
    idlers = [r for r in rollers if r.role == "steering"]
    nc, ni = len(rollers), len(idlers)
    v_ref = w1 * primary[1].radius                   # [m/s] speed scale
    om_ref = v_ref / R                               # [rad/s] sphere speed scale

    x = ca.SX.sym("x", 4 + ni + 2 * nc)
    Om = om_ref * x[0:3]
    w2 = w1 * x[3]
    w_idle = {r.name: w1 * x[4 + j] for j, r in enumerate(idlers)}
    Ft = F_SCALE * x[4 + ni: 4 + ni + nc]
    Fa = F_SCALE * x[4 + ni + nc:]

    poses = [roller_pose(r, phi) for r in rollers]
    tdirs = [ca.cross(n, a) for n, a in poses]
    Fvec = [Ft[i] * tdirs[i] + Fa[i] * poses[i][1] for i in range(nc)]

    # sphere force balance on preloaded compliant mounts → displacement δ → normal forces
    K = sum(r.stiffness * ca.mtimes(n, n.T) for r, (n, _) in zip(rollers, poses))
    rhs = sum(Fvec[i] - rollers[i].preload * poses[i][0] for i in range(nc))
    delta = ca.solve(K, rhs)
    N = [r.preload + r.stiffness * ca.dot(n, delta) for r, (n, _) in zip(rollers, poses)]
    # normal_force_variation: creep, spin creep, rolling resistance and saturation use the balanced N
    N_eff = N if "normal_force_variation" in on else [r.preload for r in rollers]
    # creep compliance follows the Hertz patch, ε ∝ N^(-2/3): at the preload, or with
    # normal_force_variation at the force-balanced N (and the effect's exponent)
    n_exp = par("normal_force_variation", "exponent") if "normal_force_variation" in on else 2.0 / 3.0

    slip_res, moment = [], ca.SX.zeros(3)
    idle_res, tau = [], {1: 0, 2: 0}
    xi, eta, spin, util, pmax, sat = [], [], [], [], [], []
    for i, r in enumerate(rollers):
        n, a = poses[i]
        t = tdirs[i]
        c = const[i]
        drive = r.role != "steering"
        r_eff = r.radius
        if "drive_radius_mismatch" in on and drive and r.shaft == 2:
            r_eff = r.radius * (1 + par("drive_radius_mismatch", "delta"))
        if drive:
            w_i = r.ratio * (w1 if r.shaft == 1 else w2)
        else:
            w_i = w_idle[r.name]
        s = R * ca.cross(Om, n) - r_eff * w_i * t
        s_t, s_a = ca.dot(s, t), ca.dot(s, a)
        V = _sabs(R * ca.dot(Om, a), 1e-9 * v_ref)          # rolling speed [m/s]
        w_spin = ca.dot(Om, n)                               # spin [rad/s]
        nscale = (c["n_ref"] / N_eff[i]) ** n_exp            # ε ∝ N^(-2/3) (Hertz + Kalker)
        mu = c["mu"] * (par("traction_saturation", "mu_scale") if "traction_saturation" in on else 1)
        ct = 0
        if drive and "drive_longitudinal_creep" in on:
            ct += par("drive_longitudinal_creep", "scale") * c["eps0"] * nscale * V
        if drive and "drive_spin_creep" in on:
            b_n = c["b"] * (N_eff[i] / r.preload) ** (1.0 / 3.0)  # Hertz half-width at N_eff
            ct += par("drive_spin_creep", "scale") * b_n / (mu * N_eff[i]) * _sabs(w_spin, 1e-9 * om_ref)
        if not drive and "steering_lateral_creep" in on:
            ca_ = par("steering_lateral_creep", "scale") * c["eps0"] * nscale * V
        else:
            ca_ = 0
        if "traction_saturation" in on:
            u = ca_fmin_sqrt(Ft[i], Fa[i], mu * N_eff[i])
            sat.append(u)
            gsat = ca_atanh_ratio(u)
            ct, ca_ = ct * gsat, ca_ * gsat
        floor = EPS_RIGID * ca.fabs(v_ref)
        slip_res += [(s_t + (ct + floor) * Ft[i]) / v_ref, (s_a + (ca_ + floor) * Fa[i]) / v_ref]

        moment += R * ca.cross(n, Fvec[i])
        m_rr = 0                                              # rolling-resistance torque on the roller about a
        if "rolling_resistance" in on:
            e_off = par("rolling_resistance", "offset")
            sigma = -ca.dot(Om, a) / _sabs(ca.dot(Om, a), 1e-6 * om_ref)   # sign of the surface speed along t
            moment += e_off * sigma * N_eff[i] * a            # pressure centre behind by e: sphere moment eσN a
            m_rr = -e_off * sigma * N_eff[i]
        if drive:
            tau[r.shaft] = tau[r.shaft] + r.ratio * (r_eff * Ft[i] - m_rr)
        else:
            idle_res.append((-r.radius * Ft[i] + m_rr) / (r.radius * F_SCALE))

        xi.append(s_t / V)
        eta.append(s_a / V)
        spin.append(w_spin / V)
        util.append(ca.sqrt(Ft[i] ** 2 + Fa[i] ** 2 + 1e-6) / (mu * N[i]))   # smooth on a 1 mN scale at F = 0

    # Hertz peak pressure p0·(N/P)^(1/3): p0, the peak at the preload P, depends on the design only, so an
    # optimiser evaluates it once per design (hertz_p0) and per operating point only the cheap scaling
    n_sym, p0_sym = ca.SX.sym("N", nc), ca.SX.sym("p0", nc)
    peak_pressure = ca.Function("peak_pressure", [n_sym, p0_sym, design], [ca.vertcat(*[
        p0_sym[i] * (ca.fmax(n_sym[i], 0) / r.preload) ** (1.0 / 3.0) for i, r in enumerate(rollers)])],
        ["N", "p0", "design"], ["p_max"])
    p0_all = ca.vertcat(*[c["p0"] for c in const])
    hertz_p0 = ca.Function("hertz_p0", [design], [ca.cse(p0_all)], ["design"], ["p0"])
    pmax = ca.vertsplit(peak_pressure(ca.vertcat(*N), p0_all, design))

    # the load: lateral torque τ⊥ = −τ1 sin γ + τ2 cos γ (Kim eq 17), or the brake-shaft torque τ2 itself
    load_res = (1 - brake) * (-tau[1] * ca.sin(gamma) + tau[2] * ca.cos(gamma) - load) + brake * (tau[2] - load)
    resid = ca.vertcat(*slip_res, moment / (R * F_SCALE), *idle_res, load_res)
    params = ca.vertcat(gamma, w1, load, brake, phi_cmd, theta, design)
    G = ca.Function("residual", [x, params], [ca.cse(resid)])
    solver = ca.rootfinder("cvt", "newton", G, {"abstol": 1e-12, "max_iter": 40, "error_on_fail": False,
                                                  "show_eval_warnings": False})

    # initial guess: ideal kinematics about the commanded axis, no forces
    gains = {s: -R / (primary[s].ratio * primary[s].radius) * vec(primary[s].axle) for s in (1, 2)}
    u = ca.cos(gamma) * vec(D1) + ca.sin(gamma) * vec(D2)
    Om0 = u * w1 / ca.dot(gains[1], u)
    x0 = ca.vertcat(Om0 / om_ref, ca.dot(gains[2], Om0) / w1,
                    *[-R * ca.dot(Om0, roller_pose(r, phi)[1]) / (r.radius * w1) for r in idlers], ca.SX.zeros(2 * nc))
    x0_fn = ca.Function("x0", [params], [x0])

    g1, g2 = ca.norm_2(gains[1]), ca.norm_2(gains[2])
    gamma_axis = ca.atan2(ca.dot(Om, vec(D2)), ca.dot(Om, vec(D1)))
    alpha = _wrap(ca.atan2(w2 / g2, w1 / g1) - gamma)
    alpha_s = _wrap(gamma_axis - gamma)
    tau1, tau2 = tau[1], tau[2]
    outs = {
        "omega_2": w2, "tau_1": tau1, "tau_2": tau2, "phi": phi, "gamma_axis": gamma_axis,
        "alpha": alpha, "alpha_steering": alpha_s, "alpha_drive": _wrap(alpha - alpha_s),
        "power_loss": tau1 * w1 + tau2 * w2,
        # a solve that needs |F| → μN at a contact (traction_saturation) is gross slip, not a creep state
        "residual": ca.if_else(ca.mmax(ca.vertcat(0, *sat)) > SAT_LIMIT, ca.inf, ca.norm_inf(resid)),
        "Omega_x": Om[0], "Omega_y": Om[1], "Omega_z": Om[2],
        "N": ca.vertcat(*N), "F_t": Ft, "F_a": Fa, "utilisation": ca.vertcat(*util),
        "p_max": ca.vertcat(*pmax), "xi": ca.vertcat(*xi), "eta": ca.vertcat(*eta),
        "spin": ca.vertcat(*spin),
    }
    names = list(POINT_OUTPUTS) + list(CONTACT_OUTPUTS)
    post = ca.Function("post", [x, params], [outs[k] for k in names])
    steer, misfit = _steering_solver(layout, design)

    def build_point(selected, name="point"):
        """One operating point: φ from the linkage's inverse kinematics, then the Newton solve, then the
        selected outputs (only the expressions they need)."""
        in_names = ["gamma_cmd", "omega_1", "load", "load_is_tau_2", "phi_guess", "theta", "design"]
        ins = [ca.MX.sym(n, *(theta.shape if n == "theta" else design.shape if n == "design" else (1, 1)))
               for n in in_names]
        g_m, w_m, l_m, b_m, pg_m, th_m, d_m = ins
        phi_m = steer(pg_m, ca.vertcat(g_m, d_m))
        p_m = ca.vertcat(g_m, w_m, l_m, b_m, phi_m, th_m, d_m)
        model_names = [k for k in selected if k != "steer_misfit"]
        out_m = []
        if model_names:
            sel = post if model_names == names else \
                ca.Function("post_sel", [x, params], ca.cse([outs[k] for k in model_names]))
            out_m = sel.call([solver(x0_fn(p_m), p_m), p_m])
        res = dict(zip(model_names, out_m))
        # how far the linkage is from rolling about the commanded axis (0 where it reaches γ)
        res["steer_misfit"] = misfit(phi_m, ca.vertcat(g_m, d_m))
        return ca.Function(name, ins, [res[k] for k in selected], in_names, list(selected))

    point = build_point(names + ["steer_misfit"])
    return CompiledModel(layout, effects, pnames, pvalues, design, point, [r.name for r in rollers], G, x0_fn, post,
                         _point_builder=lambda sel: build_point(sel, "point_" + "_".join(sel)),
                         hertz_p0=hertz_p0, peak_pressure=peak_pressure)


def ca_fmin_sqrt(ft, fa, limit):
    """Traction utilisation u = |F|/(μN), kept just below 1 so the inverse saturation law stays finite
    while Newton iterates (a solution beyond SAT_LIMIT is reported as gross slip)."""
    return ca.fmin(ca.sqrt(ft * ft + fa * fa + 1e-18) / limit, 1 - 1e-9)


def ca_atanh_ratio(u):
    """atanh(u)/u, → 1 as u → 0 (series below 1e-4): the creep-compliance amplification of saturation."""
    return ca.if_else(u < 1e-4, 1 + u * u / 3, ca.atanh(u) / ca.fmax(u, 1e-4))
