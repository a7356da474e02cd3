"""The NLP of a study: where should the rollers go and how big should they be.

The model is compiled with the free parameters as CasADi symbols, so the objective and every constraint
over the operating envelope have exact derivatives (through the model's Newton solves by the implicit
function theorem). `build_problem` formulates it (Problem): the design variables normalised to [0, 1], the
objective (design.objectives: `worst_alpha` as an epigraph variable t with −t ≤ α_k ≤ t; `rms_alpha`;
`power_loss`, the weighted mean power loss over the duty cycle [W]; `pareto`, power loss with worst |α| ≤ ε), a row per
constraint per envelope point, and the rows that depend on the design alone: roller–roller clearance
(distance of roller centres minus both radii: exact for rollers in one plane such as a tandem pair,
conservative otherwise) and the assembly envelope radius. The formulation has 9415 rows for the box
placement study, of which only a handful bind at an optimum (see solve.solve_from).

The rows themselves, and the normal-force and traction rows' form, are in design.rows.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from cvtdesign.core.geometry import roller_pose, steering_angle_guess, steering_data
from cvtdesign.core.kinematics import ShaftFrame, shaft_frame, vec
from cvtdesign.core.model import compile_model, failed_contact, status_codes
from cvtdesign.design.objectives import Objective, objective
from cvtdesign.design.robust import scenarios
from cvtdesign.design.rows import (
    NLP,
    Rows,
    design_rows,
    envelope_rows,
    point_function,
    report_scale,
    row_maps,
    row_outputs,
)
from cvtdesign.design.solution import EnvelopeCheck, check_envelope
from cvtdesign.design.study_file import (
    Study,
    StudySpec,
    min_normal_force,
    on_study_envelope,
    problem_inputs,
)
from cvtdesign.io.variant import parameter_value, resolve

CHECK_OUTPUTS = ("status", "alpha", "N", "F_t", "F_a", "mu", "utilisation")   # what check_envelope reads
IPOPT_OPTIONS = {"tol": 1e-8, "acceptable_tol": 1e-6, "hessian_approximation": "limited-memory",
                 "limited_memory_aug_solver": "extended"}   # few variables, many rows: cheaper than Sherman-Morrison


@dataclass(kw_only=True)
class Parts:
    """The pieces both NLPs are built from. Per envelope point k, `point_rows` gives m rows (epigraph
    α ∓ t, Hertz p_max/p_allow per roller, traction (|F| − (1 − margin)μN)/(μP) per roller, normal force
    N/P₀ per roller, linkage misfit); row r of point k is
    row `pt_index[r] + k` of the whole formulation (the misfit row only depends on γ: it is row
    `reach_index[γ]`, taken at the γ's first point). Design rows (clearance, envelope radius, ε) depend on
    the design alone: `design_index`."""
    x: ca.MX
    eps: ca.MX
    f: ca.MX
    g_full: ca.MX
    g_design: ca.MX
    P0: ca.MX                 # Hertz peak pressure at the preload, per roller (design only)
    point_rows: ca.Function   # (x, γ, load, φ guess, p0) → m rows
    pt_lb: np.ndarray
    pt_ub: np.ndarray
    pt_index: np.ndarray      # per row of point_rows: offset in g (−1 for the misfit row)
    misfit_row: int | None
    reach_index: np.ndarray   # per γ: the row of its linkage misfit in g
    design_index: np.ndarray
    row_r: np.ndarray         # per row of g: its row of point_rows (−1: a design row)
    row_k: np.ndarray         # per row of g: its envelope point (the misfit row: the γ's first point)
    row_scale: np.ndarray     # per row of g: scale of its near-binding margin (NaN: the epigraph t)
    gamma: np.ndarray         # the envelope points
    load: np.ndarray
    phi0: np.ndarray
    gamma_of: np.ndarray      # γ index of each point
    screen: np.ndarray        # the points at the envelope's largest |load|, evaluated first
    nlp: NLP = None          # the inputs and the model it was built from (for the functions built on first use)
    theta_pts: np.ndarray = None   # the model's θ at each point (len(θ) × points): a robust study's corners


@dataclass(kw_only=True)
class Problem:
    """The NLP of one study, in normalised design variables z ∈ [0, 1]^n (p = lower + (upper − lower)·z),
    with the epigraph variable t appended for worst-|α| objectives: x = (z, t).

    g (bounds g_lb ≤ g ≤ g_ub, one label and family per row) is the whole formulation: every constraint
    row at every point of the envelope. `solve.solve_from` solves it with IPOPT over a working set of
    envelope points (see there); `solver` is IPOPT on all rows at once."""
    spec: StudySpec
    study_file: str
    base_file: Path
    names: list
    lower: np.ndarray
    upper: np.ndarray
    nx: int
    g_lb: np.ndarray
    g_ub: np.ndarray
    g_labels: list          # one label per constraint row
    g_family: list          # constraint family per row
    evaluate: ca.Function   # x (, eps) → (objective, g), all rows
    epigraph: bool
    start_t: ca.Function | None = None
    base_values: np.ndarray = field(default=None)
    parts: Parts = None
    solvers: dict = field(default_factory=dict)   # IPOPT solvers and row functions built so far, by key
    fixed: dict = field(default_factory=dict)     # sweep parameters (SI) set for this case
    g_report: np.ndarray = None   # per row: factor from g's units to the report's (P₀ for normal_force: N)
    vspec: object = None          # the base VariantSpec (the effect parameters of a written variant)
    motor_speed: float = None     # ω1 of the envelope [rad/s]

    @property
    def solver(self) -> ca.Function:
        """IPOPT on the whole formulation (every row at every envelope point), built on first use."""
        if "full" not in self.solvers:
            pt = self.parts
            self.solvers["full"] = nlpsol(pt.x, pt.f, pt.g_full, pt.eps, self.spec.max_iter)
        return self.solvers["full"]

    def check(self, design: dict, at_nlp_seeds: dict | None = None) -> EnvelopeCheck:
        """The design (SI values of the design variables) on the whole envelope (`envelope`), counted by
        check_envelope."""
        return check_envelope(self.envelope(design, at_nlp_seeds), self.parts.nlp.model.roller_names)

    def nominal_worst_alpha(self, design: dict) -> float:
        """Worst |α| [deg] over the envelope at the model's nominal θ (a robust study's points sit at the
        corners of the calibration's region; this is the same design at its middle)."""
        res = self.envelope(design, theta=np.asarray(self.parts.nlp.model.param_values, float)[:, None])
        ok = np.ravel(res["status"]) == 0
        return float(np.degrees(np.max(np.abs(np.ravel(res["alpha"])[ok])))) if ok.any() else float("nan")

    def envelope(self, design: dict, at_nlp_seeds: dict | None = None, theta=None) -> dict:
        """The design's operating points over the whole envelope, as `CompiledModel.evaluate` gives them for
        the numeric model of the design (the base variant with this design and the case's sweep
        parameters): `status` (STATUS codes, not_converged where the solve gave no number), `failed_contact`,
        γ_cmd, load and the raw CHECK_OUTPUTS (contact outputs: rollers × points).

        The same physics without compiling a model per design: the study's model takes the design as an
        input, and each point's steering solve is seeded, as `evaluate` seeds it, by the scan of this
        design's own linkage. Where that scan gives the NLP's seeds (the base design's scan) bit for bit,
        `at_nlp_seeds` (the CHECK_OUTPUTS of this design by `rows_and_points`), if given, are these numbers
        already: the same Newton solves from the same seeds. Otherwise the points are evaluated here. The
        functions are built on first use. `theta`: the model's θ at every point instead of the study's."""
        pt, model = self.parts, self.parts.nlp.model
        p = np.array([design[n] for n in self.names], float)
        if "steering" not in self.solvers:
            self.solvers["steering"] = _steering_data(pt.nlp)
        data, ratios = self.solvers["steering"]
        t0, axes, u1, u2, k, c, s = (np.asarray(v, float) for v in data(p))
        frame = ShaftFrame(u1.ravel(), u2.ravel(), k.item(), c.item(), s.item())
        phi0, _ = steering_angle_guess(t0.reshape(-1, 3), (axes.reshape(-1, 3), ratios), frame, pt.gamma)
        res = at_nlp_seeds if theta is None else None
        if res is None or not np.array_equal(phi0, pt.phi0):
            if "envelope" not in self.solvers:
                self.solvers["envelope"] = model.point_function(CHECK_OUTPUTS).map(pt.gamma.size, "serial")
            out = self.solvers["envelope"](pt.gamma, self.motor_speed, pt.load, 0.0, phi0,
                                           pt.theta_pts if theta is None else theta, p)
            res = {k: np.asarray(v) for k, v in zip(CHECK_OUTPUTS, out)}
        status = status_codes(res)
        return res | {"status": status, "failed_contact": failed_contact(res, status), "gamma_cmd": pt.gamma,
                      "load": pt.load}

    def rows_and_points(self, x, eps: float = 0.0) -> tuple[np.ndarray, dict]:
        """(every row g of the whole formulation at x, as `evaluate` gives it; the CHECK_OUTPUTS at every
        envelope point) from one Newton solve a point, seeded as the NLP seeds it. The function is built
        on first use."""
        pt = self.parts
        if "rows_and_points" not in self.solvers:
            outputs = list(dict.fromkeys(row_outputs(pt.nlp) + list(CHECK_OUTPUTS)))
            checked = point_function(pt.nlp, outputs, extra=CHECK_OUTPUTS)[0]
            out = checked.map(pt.gamma.size, "serial").call(
                [pt.x, pt.gamma[None, :], pt.load[None, :], pt.phi0[None, :], pt.P0, pt.theta_pts])
            self.solvers["rows_and_points"] = ca.Function("rows_and_points", [pt.x, pt.eps], [*out, pt.g_design])
        out = [np.asarray(v) for v in self.solvers["rows_and_points"](x, eps)]
        point = pt.row_k >= 0
        g = np.empty(self.g_lb.size)
        g[point] = out[0][pt.row_r[point], pt.row_k[point]]
        g[pt.design_index] = out[-1].ravel()
        return g, dict(zip(CHECK_OUTPUTS, out[1:-1]))


def nlpsol(x, f, g, p, max_iter: int) -> ca.Function:
    """IPOPT (IPOPT_OPTIONS, silent, at most max_iter iterations) on min f(x, p) subject to the rows g."""
    opts = {"ipopt": IPOPT_OPTIONS | {"print_level": 0, "max_iter": max_iter, "sb": "yes"}, "print_time": False}
    return ca.nlpsol("design", "ipopt", {"x": x, "f": f, "g": g, "p": p}, opts)


def build_problem(study: Study, fixed: dict | None = None, kind: str | None = None) -> Problem:
    """The NLP of a study (study_file.load_study; its `base` the variant to design from). `fixed` sets other
    variant parameters (SI) for a sweep case; `kind` overrides the study's objective kind (design.objectives;
    'pareto' builds the ε-constraint problem)."""
    study_path, spec, base_file = study.path, study.spec, study.base
    fixed = fixed or {}
    nlp = _setup(study_path, spec, base_file, fixed, objective(kind or spec.objective.kind))
    rows = Rows()
    point_rows, blocks, pt_index, reach_index, misfit_row, obj_grid = envelope_rows(nlp, rows)
    design_start, n_point_blocks = len(rows.lb), len(rows.exprs)
    design_rows(nlp, rows)
    g_full = ca.vertcat(*rows.exprs)
    design_index = np.arange(design_start, len(rows.lb))
    # the design rows on their own (a slice of g_full would still depend on every envelope point)
    g_design = ca.vertcat(*rows.exprs[n_point_blocks:]) if design_index.size else ca.MX(0, 1)
    f = nlp.objective.value(nlp, obj_grid)
    evaluate = ca.Function("evaluate", nlp.objective.inputs(nlp), [f, g_full])
    row_r, row_k, row_scale = row_maps(nlp, blocks, pt_index, reach_index, misfit_row, len(rows.lb))
    big = np.abs(nlp.l_pts) >= np.max(np.abs(nlp.l_pts)) * (1 - 1e-12)
    parts = Parts(x=nlp.x, eps=nlp.eps, f=f, g_full=g_full, g_design=g_design, P0=nlp.P0, point_rows=point_rows,
                  pt_lb=np.array([b[0] for b in blocks], float), pt_ub=np.array([b[1] for b in blocks], float),
                  pt_index=pt_index, misfit_row=misfit_row, reach_index=reach_index, design_index=design_index,
                  row_r=row_r, row_k=row_k, row_scale=row_scale, gamma=nlp.g_pts, load=nlp.l_pts, phi0=nlp.phi0,
                  gamma_of=(np.arange(nlp.npts) % nlp.per_scenario) // nlp.nload, screen=np.flatnonzero(big),
                  nlp=nlp, theta_pts=nlp.theta_pts)
    return Problem(spec=spec, study_file=nlp.where, base_file=base_file, names=nlp.names, lower=nlp.lower,
                   upper=nlp.upper, nx=nlp.x.shape[0], g_lb=np.array(rows.lb), g_ub=np.array(rows.ub),
                   g_labels=rows.labels, g_family=rows.family, evaluate=evaluate, epigraph=nlp.epigraph,
                   start_t=_start_t(nlp), base_values=np.array([nlp.base.parameters[n] for n in nlp.names]),
                   parts=parts, fixed=dict(fixed), g_report=report_scale(nlp, blocks, pt_index, len(rows.lb)),
                   vspec=nlp.vspec, motor_speed=float(nlp.w1))


def _setup(study_path, spec: StudySpec, base_file: Path, fixed: dict, goal: Objective) -> NLP:
    """The checked inputs (study_file.problem_inputs), the model compiled with the design variables as
    symbols, the NLP's variables x = (z, t) and ε, the envelope points and the constraint settings."""
    where = str(study_path)
    vspec, base, names, lower, upper = problem_inputs(study_path, spec, base_file, fixed)
    p = ca.SX.sym("p", len(names))
    layout = resolve(vspec, str(base_file), overrides=fixed | {n: p[i] for i, n in enumerate(names)})
    model = compile_model(layout, effects=spec.effects, design=p)
    thetas, labels = scenarios(model, spec.robust, where)
    g_pts, l_pts, phi0, nload = (np.tile(v, len(thetas)) if isinstance(v, np.ndarray) else v
                                 for v in _envelope_points(spec, base, where))
    theta_pts = np.repeat(thetas.T, g_pts.size // len(thetas), axis=1)
    z = ca.MX.sym("z", len(names))
    t = ca.MX.sym("t") if goal.epigraph else ca.MX(0, 1)
    eps = ca.MX.sym("eps")
    x = ca.vertcat(z, t)
    P = ca.DM(lower) + ca.DM(upper - lower) * z
    P0 = model.hertz_p0(P)
    cs = spec.constraints
    margin = None if cs.traction_margin is None else \
        float(parameter_value(cs.traction_margin, f"{where}: constraints.traction_margin", {}))
    steer_max = None if cs.max_steering_torque is None else \
        float(parameter_value(cs.max_steering_torque, f"{where}: constraints.max_steering_torque", {}))
    allow = [r.material.p_allow if cs.hertz_pressure else None for r in layout.rollers]
    pre0 = np.array([float(r.preload) for r in base.rollers])
    n_min = min_normal_force(cs.min_normal_force, pre0, f"{where}: constraints.min_normal_force", base.parameters)
    preload = ca.Function("preload", [p], [ca.vertcat(*[r.preload for r in layout.rollers])])
    return NLP(where=where, spec=spec, objective=goal, vspec=vspec, base=base, layout=layout, model=model,
               names=names, lower=lower, upper=upper, p=p, z=z, t=t, eps=eps, x=x, P=P, P0=P0, g_pts=g_pts,
               l_pts=l_pts, phi0=phi0, nload=nload, margin=margin, allow=allow, pre0=pre0, n_min=n_min,
               preload=preload, theta_pts=theta_pts, scenarios=labels, steer_max=steer_max)


def _steering_data(nlp: NLP) -> tuple[ca.Function, np.ndarray]:
    """(design → the steering data of the layout at that design, fork gear ratios): geometry.steering_data as
    a function of the design, its outputs t0 (rolling directions at φ = 0), the fork axes (one row per
    steered roller) and the ShaftFrame's u1, u2, k, c, s."""
    steered = [r for r in nlp.layout.rollers if r.fork_axis is not None]
    t0 = [ca.cross(*roller_pose(r, 0.0)).T for r in steered]
    axes = [vec(r.fork_axis).T for r in steered]
    frame = shaft_frame(nlp.layout)
    outs = [ca.vertcat(ca.SX(0, 3), *t0), ca.vertcat(ca.SX(0, 3), *axes), ca.SX(vec(frame.u1)),
            ca.SX(vec(frame.u2))] + [ca.SX(v) for v in (frame.k, frame.c, frame.s)]
    return ca.Function("steering_data", [nlp.p], outs), np.array([r.fork_ratio for r in steered], float)


def _envelope_points(spec: StudySpec, base, where: str) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """The envelope (the study's, else the base variant's) as points: γ [rad], load [N m] and a steering
    angle guess φ [rad] per point, γ-major, and the number of loads per γ."""
    on = on_study_envelope(spec, base, where)
    G, T = np.meshgrid(on.gamma_grid, on.load_grid, indexing="ij")
    g_pts, l_pts = G.ravel(), T.ravel()
    phi0, _ = steering_angle_guess(*steering_data(base), g_pts)
    return g_pts, l_pts, phi0, G.shape[1]


def _start_t(nlp: NLP) -> ca.Function | None:
    """z → worst |α| [deg] over the envelope (the epigraph variable's start), for epigraph objectives."""
    if not nlp.epigraph:
        return None
    alpha_grid = nlp.model.point_function(["alpha"]).map(nlp.npts, "serial")(
        nlp.g_pts, nlp.w1, nlp.l_pts, 0.0, nlp.phi0, nlp.theta_pts, nlp.P)
    return ca.Function("start_t", [nlp.z], [ca.mmax(ca.fabs(alpha_grid)) * (180 / np.pi)])


