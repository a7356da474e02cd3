"""compile(layout, effects) → CasADi functions of one steady operating point and of a grid.

One generalised model for every layout; no layout-specific equations. Notation (per contact i): n_i outward
contact normal, a_i roller axle (positive spin axis), t_i = n_i × a_i rolling direction, R sphere radius,
r_i roller radius, Ω sphere angular velocity, ω_i roller speed about a_i, F_i the tangential force ON THE
SPHERE from roller i (components F_t along t_i, F_a along a_i), N_i normal force.

Equations (derived from the vectors; the effects' terms come from effects.py, by hook):
 * slip velocity of sphere over roller at the contact: s_i = R·Ω × n_i − r_i·ω_i·t_i
   (no slip: r_i ω_i = −R Ω·a_i, so shaft s turns at ω_s = g_s·Ω, kinematics.py);
 * creep law, dissipative (F·s ≤ 0), by the variant's contact law (core.contact.laws): two rows per contact
   relating s_i, the spin Ω·n_i and F_i, and the spin moment Mz_i the patch puts on the sphere:
   - a linear law (fitted creep constants): s_t + c_t·F_t = 0, s_a + c_a·F_a = 0, with the compliances c
     the effects contribute, rigid where no effect adds compliance; no spin moment;
   - a law on Kalker's theory: the Hertz patch at N_i, creep and spin combined by FASTSIM's creep-force
     surface (core.contact.surface), scaled by the calibration;
 * sphere moment balance: Σ R n_i × F_i + Σ Mz_i n_i − Σ M_i a_i = 0 (M_i: `resistance` moments on the
   rollers);
 * sphere force balance on preloaded compliant mounts: N_i = P_i + k_i n_i·δ, Σ (F_i − N_i n_i) = 0, solved
   for the sphere's displacement δ in closed form (a 3×3 solve), so the normal-force distribution of an
   over-constrained layout comes from compliance;
 * idler (steering) roller torque balance: −r_i F_t,i + M_i = 0;
 * shaft torques τ_s = Σ_{i on s} ρ_i (r_i F_t,i − M_i) (torque applied to the shaft from outside);
 * the operating point fixes ω1 and either the lateral load τ⊥ (kinematics.ShaftFrame.load_split; Kim eq 17
   for Kim's layout) or the brake torque τ2; the steering angle φ comes from the linkage's inverse kinematics.
Unknowns: Ω, ω2, idler speeds, (F_t, F_a) per contact. Solved by CasADi's Newton rootfinder (with its line
search), whose implicit derivatives give the optimiser exact gradients. Evaluated interpreted by CasADi, or
compiled to C (core.native): the compiled functions solve by the same iteration written out (core.newton),
which gives the same numbers.

Past the envelope the equations can have several roots (`_solve_from_rest`): where a point has two, the
state depends on the load's history and the point is `multiple_roots`. A solution is returned only where
the physics holds (`status`): the solve converged, to the point's only root, on a root where the sphere
turns with the commanded axis (else `reversed`), every N_i > 0 (else
`lost_contact`) and every |F_i| ≤ μ_i N_i (else `gross_slip`, which is also what a saturation law's converged
solution at |F| ≥ SAT_LIMIT·μN means). A solve that did not converge is `not_converged`.
"""
from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from cvtdesign.core.contact.laws import check_effects, contact_law
from cvtdesign.core.deferred import DeferredCalls
from cvtdesign.core.effects import parameter_vector
from cvtdesign.core.equations import F_SCALE, Hooks, equations, unknowns
from cvtdesign.core.geometry import ideal_gamma, roller_pose, steering_angle_guess, steering_data
from cvtdesign.core.kinematics import ShaftFrame, shaft_frame, shaft_gain, wrap_axis_angle
from cvtdesign.core.layout import Layout
from cvtdesign.core.native import Tiered, compiled, from_source
from cvtdesign.core.status import Status
from cvtdesign.core.newton import newton_solver

RES_TOL = 1e-8        # scaled residual above which a point is reported as not converged
LOAD_STEPS = 4        # steps of the continuation in the load from rest (_solve_from_rest)
SAT_LIMIT = 0.999     # traction utilisation |F|/(μN) of a saturation law beyond which a point is gross slip

ROOT_TOL = 1e-6       # scaled unknowns' largest difference beyond which two converged solutions are two roots
UTIL_CHECK = 0.5      # traction utilisation above which a law with several roots also solves from rest
CONTACT_OUTPUTS = ("N", "F_t", "F_a", "utilisation", "p_max", "xi", "eta", "spin", "mu", "M_spin", "loss", "a", "b",
                   "G", "C11", "C22", "C23", "roll_sign", "T_fork", "fork_pivot", "fork_slide")
POINT_OUTPUTS = ("omega_2", "tau_1", "tau_2", "phi", "gamma_axis", "alpha", "alpha_steering", "alpha_drive",
                 "power_loss", "residual", "status", "Omega_x", "Omega_y", "Omega_z", "steering_torque")


@dataclass
class CompiledModel:
    """The compiled model of one layout with one set of effects.

    `point` maps (γ_cmd [rad], ω1 [rad/s], load [N m], load_is_τ2 (0: the load is τ⊥, 1: it is the brake
    torque τ2), φ guess [rad], θ effect parameters, p design) to a dict of POINT_OUTPUTS (scalars) and
    CONTACT_OUTPUTS (one entry per roller), interpreted by CasADi. `evaluate` evaluates many points at once,
    mapped on two threads, and compiled to C once the model has been used long enough to pay for that
    (core.native.Tiered); `native_point` is `point` compiled now."""
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
    frame: ShaftFrame = None       # the layout's shaft axes and ideal law
    _maps: dict = field(default_factory=dict)
    _point_builder: object = None  # (names, written_out) → a `point` function with only those outputs
    _tiered: Tiered = None         # `point`, interpreted until compiled
    hertz_p0: ca.Function = None       # design → Hertz peak pressure of each contact at its preload [Pa]
    peak_pressure: ca.Function = None  # (N, p0, design) → Hertz peak pressure p0·(max(N, 0)/preload)^(1/3) [Pa]
    steering_residual: ca.Function = None  # (φ, [γ_cmd, design]) → residual whose root is the steering angle

    def point_function(self, outputs, written_out: bool = False) -> ca.Function:
        """`point` restricted to the named outputs (POINT_OUTPUTS, CONTACT_OUTPUTS, 'steer_misfit', 'root'): same
        inputs and the same expressions, but only what those outputs need is evaluated and differentiated
        (the Newton solve is left out when only 'steer_misfit' is asked for); `written_out`: in nodes that can
        be compiled (core.newton), with the same numbers."""
        return self._point_builder(list(outputs), written_out)

    def native_point(self, derivatives: bool = False) -> ca.Function | None:
        """`point` compiled to C (from the cache, else compiled now; with `derivatives`, the library also
        holds its forward and reverse derivatives), or None where there is no working C compiler."""
        return compiled(self._point_builder(list(self.point.name_out()), written_out="derivatives" if derivatives
                                            else True), derivatives)

    def point_source(self) -> str:
        """The C source `evaluate` compiles (core.native.Tiered), from which `library_model` evaluates it."""
        return self._tiered.code()

    def steering_guess(self, gammas):
        return steering_angle_guess(*steering_data(self.layout), np.asarray(gammas, float))

    def evaluate(self, gammas, loads, speeds=None, theta=None, design=None, load_kind="tau_perp",
                 steering_angles=None):
        """Evaluate operating points (broadcastable arrays): commanded γ [rad] (or, with `steering_angles`
        [rad], the linkage's angle φ, and γ_cmd is then the ideal γ of that φ), loads [N m] that are the
        lateral load τ⊥ (load_kind 'tau_perp') or the brake-shaft torque τ2 ('tau_2'), motor speeds ω1
        [rad/s] (default: the variant's). Returns a dict of numpy arrays. `status` holds each point's
        STATUS code, `ok` is status == ok, `failed_contact` the index of the contact that lost contact or
        slips grossly (−1 where none); every other output is NaN where the point is not ok."""
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
        fn = self._tiered.function(n)
        if (id(fn), n) not in self._maps:
            self._maps[id(fn), n] = fn.map(n, "thread", 2)
        t = time.perf_counter()
        out = call_mapped(self._maps[id(fn), n], [g, w, l, np.full(n, float(load_kind == "tau_2")), phi0, th, p])
        self._tiered.record(fn, n, time.perf_counter() - t)
        res = dict(zip(self.point.name_out(), out))
        status = status_codes(res)
        ok = status == Status.OK
        result = {"status": status.reshape(shape), "ok": ok.reshape(shape),
                  "converged": (status != Status.NOT_CONVERGED).reshape(shape),
                  "failed_contact": failed_contact(res, status).reshape(shape),
                  "gamma_cmd": gammas, "load": loads, "omega_1": w.reshape(shape)}
        for k, v in res.items():
            if k == "status":
                continue
            v = np.where(ok, v, np.nan)
            result[k] = v[0].reshape(shape) if v.shape[0] == 1 else v.reshape((v.shape[0],) + shape)
        return result


def call_mapped(mapped: ca.Function, args: list) -> list[np.ndarray]:
    """Outputs (rows × points arrays) of a function mapped over points, given per-point inputs (length-n
    vectors) and shared ones (vectors repeated for every point). Evaluated on numpy buffers (CasADi's
    FunctionBuffer), with no conversion from CasADi matrices, which for ~100 rows of 30k points costs half
    as long again as the compiled model itself."""
    n = mapped.size2_in(0)
    # CasADi stores a rows × points input column by column: a points × rows C array
    rows = [mapped.size1_in(i) for i in range(len(args))]
    ins = [np.ascontiguousarray(np.broadcast_to(np.asarray(a, float).reshape(-1, r), (n, r))) if r else np.empty((n, 0))
           for a, r in zip(args, rows)]
    outs = [np.empty((n, mapped.size1_out(i))) for i in range(mapped.n_out())]
    buf, run = mapped.buffer()
    for i, a in enumerate(ins):
        buf.set_arg(i, memoryview(a))
    for i, o in enumerate(outs):
        buf.set_res(i, memoryview(o))
    run()
    return [o.T for o in outs]


def status_codes(res: dict) -> np.ndarray:
    """Per point, the STATUS code of raw point outputs (`status` row), not_converged where the solve gave no
    number at all."""
    return np.where(np.isfinite(res["status"][0]), res["status"][0], Status.NOT_CONVERGED).astype(int)


def failed_contact(res: dict, status: np.ndarray) -> np.ndarray:
    """Per point, the index of the contact behind a lost_contact (smallest N) or gross_slip (largest
    |F| − μN) status; −1 for the other points."""
    out = np.full(status.shape, -1)
    lost, slip = status == Status.LOST_CONTACT, status == Status.GROSS_SLIP
    if lost.any():
        out[lost] = np.argmin(res["N"][:, lost], axis=0)
    if slip.any():
        excess = np.hypot(res["F_t"], res["F_a"]) - res["mu"] * res["N"]
        out[slip] = np.argmax(np.nan_to_num(excess[:, slip], nan=-np.inf), axis=0)
    return out


def status_counts(res: dict, roller_names) -> dict:
    """{status: count} over an evaluate() result (every STATUS key), with the contacts behind lost_contact and
    gross_slip: {'lost_contact_at': {roller: count}, 'gross_slip_at': {...}}."""
    st, fc = res["status"].ravel(), res["failed_contact"].ravel()
    counts = {s.label: int(np.sum(st == s)) for s in Status}
    for k, name in ((s, s.label) for s in (Status.LOST_CONTACT, Status.GROSS_SLIP)):
        idx = fc[st == k]
        counts[f"{name}_at"] = {roller_names[i]: int(np.sum(idx == i)) for i in np.unique(idx) if i >= 0}
    return counts


def _steering_residual(layout: Layout, frame: ShaftFrame, design: ca.SX):
    """(residual, misfit) of the steering angle φ(γ_cmd) at which every steered roller rolls without lateral
    slip about the commanded axis u(γ) (least squares, so over-determined linkages work; for Kim's linkage
    the root is Kim eq 5 inverted): the residual's root is φ, the misfit is how far the rollers are then
    from rolling about u(γ)."""
    phi, gamma = ca.SX.sym("phi"), ca.SX.sym("gamma")
    u = frame.axis(gamma)
    res = ca.vertcat(*[ca.dot(ca.cross(*roller_pose(r, phi)), u) for r in layout.rollers if r.fork_axis is not None])
    g = ca.jacobian(ca.sumsqr(res) / 2, phi)
    f = ca.Function("steer_res", [phi, ca.vertcat(gamma, design)], [g])
    misfit = ca.Function("steer_misfit", [phi, ca.vertcat(gamma, design)], [ca.sqrt(ca.sumsqr(res) + 1e-30)])
    return f, misfit


def _solvers(residual: ca.Function, jacobian: ca.Function, steer_residual: ca.Function, written_out: bool,
             derivatives: bool = False, hoisted=None):
    """The model's and the steering angle's Newton solvers: CasADi's rootfinders, or (written_out) the same
    iteration in nodes that can be code-generated (core.newton), differentiable if `derivatives`."""
    tol = {"cvt": (1e-12, 1e-12, 40), "steer": (1e-14, 1e-12, 30)}   # abstol, abstolStep, max_iter
    fns = {"cvt": residual, "steer": steer_residual}
    if written_out:
        return (newton_solver("cvt", residual, *tol["cvt"], derivatives, jacobian, hoisted()),
                newton_solver("steer", steer_residual, *tol["steer"], derivatives))
    return tuple(ca.rootfinder(k, "newton", fns[k], {"abstol": tol[k][0], "abstolStep": tol[k][1], "max_iter": tol[k][2],
                                                    "error_on_fail": False, "show_eval_warnings": False})
                 for k in ("cvt", "steer"))


def _status(resid, per, sat, forward):
    """STATUS code of a solution: not_converged unless `_converged`; then reversed unless `forward` (the
    sphere's Ω has a positive component along the ideal kinematics' Ω: a root with the sphere turning against
    the commanded axis and the output shaft running backwards); then lost_contact if some N ≤ 0, gross_slip if
    some |F| > μN or a saturation law is at |F| ≥ SAT_LIMIT·μN. A solve that did not converge is
    not_converged whatever its last iterate (near μN is no proof of gross slip)."""
    N = ca.vertcat(*per["N"])
    excess = ca.vertcat(*[ca.sqrt(ft ** 2 + fa ** 2) - mu * n for ft, fa, mu, n in
                          zip(per["F_t"], per["F_a"], per["mu"], per["N"])])
    saturated = ca.mmax(ca.vertcat(0, *sat)) > SAT_LIMIT
    converged = _converged(resid)
    slipping = ca.if_else(ca.logic_or(ca.mmax(excess) > 0, saturated), int(Status.GROSS_SLIP), int(Status.OK))
    physical = ca.if_else(ca.mmin(N) <= 0, int(Status.LOST_CONTACT), slipping)
    return ca.if_else(converged, ca.if_else(forward, physical, int(Status.REVERSED)), int(Status.NOT_CONVERGED))


def _converged(resid):
    """Every scaled residual finite and below RES_TOL (a NaN entry would pass a plain ∞-norm, whose max skips
    NaN)."""
    return ca.logic_and(ca.norm_inf(resid) < RES_TOL, ca.fabs(ca.sum1(resid)) < ca.inf)


def _peak_pressure_functions(layout: Layout, const, design):
    """Hertz peak pressure p0·(N/P)^(1/3): p0, the peak at the preload P, depends on the design only, so an
    optimiser evaluates it once per design (hertz_p0) and per operating point only the cheap scaling."""
    nc = len(layout.rollers)
    n_sym, p0_sym = ca.SX.sym("N", nc), ca.SX.sym("p0", nc)
    peak_pressure = ca.Function("peak_pressure", [n_sym, p0_sym, design], [ca.vertcat(*[
        p0_sym[i] * (ca.fmax(n_sym[i], 0) / r.preload) ** (1.0 / 3.0) for i, r in enumerate(layout.rollers)])],
        ["N", "p0", "design"], ["p_max"])
    p0_all = ca.vertcat(*[c["p0"] for c in const])
    hertz_p0 = ca.Function("hertz_p0", [design], [ca.cse(p0_all)], ["design"], ["p0"])
    return hertz_p0, peak_pressure, p0_all


def ideal_unknowns(layout: Layout, frame: ShaftFrame, gamma, w1, phi, om_ref):
    """Ideal kinematics about the commanded axis u(γ), no forces (in the scaled unknowns)."""
    R = layout.sphere_radius
    g1, g2 = shaft_gain(layout, 1), shaft_gain(layout, 2)
    u = frame.axis(gamma)
    Om0 = u * w1 / ca.dot(g1, u)
    idlers = [r for r in layout.rollers if r.role == "steering"]
    nc = len(layout.rollers)
    return ca.vertcat(Om0 / om_ref, ca.dot(g2, Om0) / w1,
                      *[-R * ca.dot(Om0, roller_pose(r, phi)[1]) / (r.radius * w1) for r in idlers],
                      ca.SX.zeros(2 * nc))


def compile_model(layout: Layout, effects=None, design: ca.SX | None = None,
                  as_built: Layout | None = None, switched: bool = False) -> CompiledModel:
    """Compile `layout` with the given effects (default: the variant's) into a CompiledModel.

    `design` is the vector of CasADi symbols that the layout's fields may depend on (design variables of
    an optimisation study); numeric layouts need none. `as_built`: the machine as manufactured, `layout`
    with rollers whose fields are expressions of `design` (toleranced dimensions: design.tolerance). Its
    rollers are what the equations hold, while the ideal law, γ and α and the linkage's inverse kinematics
    stay those of `layout`, the drawing: a machine built off its drawing is commanded, and judged, by it.
    `switched`: each effect has a switch in θ (core.effects.parameter_vector): one model for every subset."""
    built = layout if as_built is None else as_built
    law = contact_law(layout.contact_law)
    effects = check_effects(tuple(layout.effects if effects is None else effects), f"{layout.file}: effects",
                            layout.contact_law)
    design = ca.SX(0, 1) if design is None else design
    pnames, pvalues = parameter_vector(effects, layout.effect_parameters, switched)
    theta = ca.SX.sym("theta", len(pnames))
    hooks = Hooks(effects, theta, pnames)
    frame = shaft_frame(layout)
    const = [law.constants(built, r) for r in built.rollers]
    gamma, w1, load, brake, phi_cmd = (ca.SX.sym(s) for s in ("gamma_cmd", "omega_1", "load", "load_is_tau_2", "phi_cmd"))
    phi = hooks.transform("steering_angle", phi_cmd)
    u = unknowns(built, w1)
    calls = DeferredCalls()
    slip, moment, idle, tau, per, sat = equations(built, hooks, law, const, u, w1, phi, calls)
    per["F_t"], per["F_a"] = ca.vertsplit(u.Ft), ca.vertsplit(u.Fa)
    hertz_p0, peak_pressure, p0_all = _peak_pressure_functions(built, const, design)
    tau_perp, _ = frame.load_split(gamma, tau[1], tau[2])
    load_res = (1 - brake) * (tau_perp - load) + brake * (tau[2] - load)
    resid = ca.vertcat(*slip, moment / (built.sphere_radius * F_SCALE), *idle, load_res)
    params = ca.vertcat(gamma, w1, load, brake, phi_cmd, theta, design)
    G = calls.close("residual", [u.x, params], [resid])
    G_jac = calls.jacobian("residual_jac", [u.x, params], resid, 0)
    x0 = ideal_unknowns(built, frame, gamma, w1, phi, u.om_ref)
    x0_fn = ca.Function("x0", [params], [x0])

    alpha = frame.slip_angle(w1, u.w2, gamma)
    alpha_s = wrap_axis_angle(frame.axis_angle(u.Om) - gamma)
    outs = {
        "omega_2": u.w2, "tau_1": tau[1], "tau_2": tau[2], "phi": phi, "gamma_axis": frame.axis_angle(u.Om),
        "alpha": alpha, "alpha_steering": alpha_s, "alpha_drive": wrap_axis_angle(alpha - alpha_s),
        "power_loss": tau[1] * w1 + tau[2] * u.w2, "residual": ca.norm_inf(resid),
        "status": _status(resid, per, sat, ca.dot(u.x[0:3], x0[:3]) > 0),   # Ω·Ω_ideal / om_ref² (any sign of ω1)
        "Omega_x": u.Om[0], "Omega_y": u.Om[1], "Omega_z": u.Om[2],
        "N": ca.vertcat(*per["N"]), "F_t": u.Ft, "F_a": u.Fa, "utilisation": ca.vertcat(*per["utilisation"]),
        "p_max": peak_pressure(ca.vertcat(*per["N"]), p0_all, design), "xi": ca.vertcat(*per["xi"]),
        "eta": ca.vertcat(*per["eta"]), "spin": ca.vertcat(*per["spin"]), "mu": ca.vertcat(*per["mu"]),
        **{k: ca.vertcat(*per[k]) for k in ("M_spin", "loss", "a", "b", "G", "C11", "C22", "C23", "roll_sign",
                                            "T_fork", "fork_pivot", "fork_slide")},
        "steering_torque": sum(r.fork_ratio * t for r, t in zip(layout.rollers, per["T_fork"])),
    }
    steer_res, misfit = _steering_residual(layout, frame, design)
    closed = {}

    def close(name, names):       # the selected outputs as a function of (x, params), built once a selection
        if tuple(names) not in closed:     # (`outputs` is the point's: building it twice took a third of a build)
            closed[tuple(names)] = calls.close(name, [u.x, params], [outs[k] for k in names])
        return closed[tuple(names)]
    build = _point_builder(close, G, G_jac, x0_fn, steer_res, misfit, theta, design,
                           close("utilisation", ["utilisation"]) if law.several_roots else None,
                           functools.cache(lambda: calls.newton_functions("residual", u.x, params, resid)))
    every = list(POINT_OUTPUTS) + list(CONTACT_OUTPUTS) + ["steer_misfit"]
    point = build(every)
    return CompiledModel(layout, effects, pnames, pvalues, design, point, [r.name for r in layout.rollers], G,
                         x0_fn, close("post", POINT_OUTPUTS + CONTACT_OUTPUTS),
                         frame=frame, hertz_p0=hertz_p0, peak_pressure=peak_pressure, steering_residual=steer_res,
                         _point_builder=lambda sel, written_out=False: build(
                             sel, "point" if sel == every else "point_" + "_".join(sel), written_out),
                         _tiered=Tiered(point, lambda: build(every, "point", True)))


def library_model(layout: Layout, code: str, design_size: int = 0, effects=None) -> CompiledModel | None:
    """`layout`'s model for evaluation only, `point` the library of `code` (CompiledModel.point_source) from the
    cache or compiled now: nothing symbolic is built (box_tolerances' model: 9 s of CPU) or can be
    differentiated (`residual`, `outputs`, … are None). None where there is no working C compiler."""
    contact_law(layout.contact_law).load_natives()       # the symbols the library calls, before it is loaded
    if (fn := from_source(code, "point")) is None:
        return None
    effects = check_effects(tuple(layout.effects if effects is None else effects), layout.file, layout.contact_law)
    tiered = Tiered(fn, lambda: fn, native=fn)
    return CompiledModel(layout, effects, *parameter_vector(effects, layout.effect_parameters),
                         ca.SX.sym("design", design_size), fn, [r.name for r in layout.rollers], None, None, None,
                         frame=shaft_frame(layout), _tiered=tiered)


def _point_builder(close, residual, jacobian, x0_fn, steer_res, misfit, theta, design, utilisation, hoisted):
    """(names, name, written_out) → a CasADi Function of one operating point: φ from the linkage's inverse
    kinematics, then the solve (_solve_from_rest), then only the selected outputs' expressions (`close`:
    (name, output names) → their Function of (x, params)); with the solvers that can be code-generated if
    written_out (_solvers)."""
    solvers = {}

    def build(selected, name="point", written_out=False):
        if written_out not in solvers:
            solvers[written_out] = _solvers(residual, jacobian, steer_res, bool(written_out), written_out == "derivatives",
                                            hoisted)
        solver, steer = solvers[written_out]
        in_names = ["gamma_cmd", "omega_1", "load", "load_is_tau_2", "phi_guess", "theta", "design"]
        ins = [ca.MX.sym(n, *(theta.shape if n == "theta" else design.shape if n == "design" else (1, 1)))
               for n in in_names]
        g_m, w_m, l_m, b_m, pg_m, th_m, d_m = ins
        phi_m = steer(pg_m, ca.vertcat(g_m, d_m))
        p_m = ca.vertcat(g_m, w_m, l_m, b_m, phi_m, th_m, d_m)
        model_names = [k for k in selected if k not in ("steer_misfit", "root")]
        res = {}
        if model_names or "root" in selected:      # root: the solution x and the parameters it solves (core.sensitivity)
            x_m, several = _solve_from_rest(solver, residual, x0_fn, p_m, utilisation)
            res = {"root": ca.vertcat(x_m, p_m)} | (dict(zip(model_names, close("post_sel", model_names).call(
                [x_m, p_m]))) if model_names else {})
            if "status" in res:
                res["status"] = ca.if_else(several, int(Status.MULTIPLE_ROOTS), res["status"])
        # how far the linkage is from rolling about the commanded axis (0 where it reaches γ)
        res["steer_misfit"] = misfit(phi_m, ca.vertcat(g_m, d_m))
        return ca.Function(name, ins, [res[k] for k in selected], in_names, list(selected))
    return build


def _solve_from_rest(solver, residual: ca.Function, x0_fn: ca.Function, p: ca.MX, utilisation: ca.Function | None):
    """(x, several): the operating point's solution, and whether the equations hold another one there.

    Past the envelope the equations can have more than one root, and the Newton solve from the ideal
    kinematics (no forces) can land on either, depending on round-off: an asymmetric box under Hertz + Kalker
    + FASTSIM reaches α = 2.612° written one way and 2.610° rotated, both converged, where loading from rest
    reaches 2.679°. The state then depends on how the load came, which no steady-state model can tell, so such a
    point carries no number (`multiple_roots`).

    Where the contact law can have several roots (laws.*.several_roots), the direct root stands unless it
    failed or some contact uses more than UTIL_CHECK of its friction: a second root needs the law to bend,
    which it does near saturation (existing.yaml at γ = −16°, τ⊥ = 2.5 N·m, contacts at 0.68 μN: the
    direct solve reaches α = 18.49°, loading from rest 18.35°; inside the shipped envelopes no contact passes
    0.38 μN, and the shipped variants of such a law and an asymmetric box have no second root below 0.5 μN
    over γ ±88°, τ⊥ ±4 N·m). There the point is also solved as a rig reaches it, the load applied from rest in
    LOAD_STEPS equal steps, each solve starting from the last converged one. Where both hold and differ (by
    more than ROOT_TOL in the scaled unknowns), the point is `multiple_roots`; where only one holds, that one
    is the solution. The stepped solution alone is no answer: near a fold its steps land on whichever root
    they reach, and its α can jump by 0.6° between loads one ulp apart.

    Under a linear law (fitted creep constants) the roots inside the envelopes are unique, and the stepped
    solve only replaces a direct one that fails or turns backwards (existing_kim.yaml at (−80°, 2.1 N·m) is
    `reversed` from the ideal kinematics and ω2 = −20.2 rad/s from rest). Derivatives are those of the solve
    whose root is returned, by the implicit function theorem."""
    def good(x, q):      # converged, on a forward root (as _status judges them)
        return ca.logic_and(_converged(residual(x, q)), ca.dot(x[0:3], x0_fn(q)[0:3]) > 0)

    def stepped(q):
        x = x0_fn(q)
        for k in range(1, LOAD_STEPS + 1):
            qk = q if k == LOAD_STEPS else ca.vertcat(q[0:2], q[2] * k / LOAD_STEPS, q[3:])
            xk = solver(x, qk)
            x = xk if k == LOAD_STEPS else ca.if_else(good(xk, qk), xk, x)
        return x

    direct = solver(x0_fn(p), p)
    # the branches as functions of the direct solution: `if_else` alone would build them from the graph's
    # inputs and so solve the direct problem a second time inside the switch
    d, q = ca.MX.sym("direct", direct.sparsity()), ca.MX.sym("params", p.sparsity())
    if utilisation is None:             # a law whose roots are unique (laws.*.several_roots)
        pick = ca.Function("from_rest", [d, q], [ca.if_else(good(d, q), d, stepped(q), True)])
        return pick(direct, p), ca.MX(0)
    rest = stepped(q)
    ok_d, ok_r = good(d, q), good(rest, q)
    several = ca.logic_and(ca.logic_and(ok_d, ok_r), ca.norm_inf(d - rest) > ROOT_TOL)
    suspect = ca.logic_or(ca.logic_not(ok_d), ca.mmax(utilisation(d, q)) > UTIL_CHECK)
    check = ca.Function("check_roots", [d, q], [ca.if_else(suspect, ca.vertcat(ca.if_else(ok_d, d, rest), several),
                                                             ca.vertcat(d, 0), True)])
    out = check(direct, p)
    return out[:-1], out[-1]
