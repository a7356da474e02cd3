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

Normal force and traction. The model's normal forces come from the sphere's force balance on compliant
mounts, N_i = P_i + k_i n_i·δ, and nothing in that balance keeps them positive: a large lateral load can
unload a contact below zero, where the roller has lifted off and the model (creep, Hertz, traction) no
longer describes it. So
 * `normal_force` (always on): N_i ≥ N_min at every contact and envelope point, written N_i/P₀_i ≥
   N_min/P₀_i with P₀_i roller i's preload at the base design (rows of order 1); the constraint report
   gives its value, bound, slack in newtons and its multiplier per newton (`Problem.g_report`).
 * `traction` is |F_i| − (1 − margin)·μ_i·N_i ≤ 0, not F/(μN) ≤ 1 − margin: the utilisation u = |F|/(μN) is
   negative when N < 0 and would pass that row at a point that has lost contact. The row is
   (|F_i| − (1 − margin)·μ_i·N_i)/(μ_i·P_i), with the model's own μ_i (its `mu` output, friction effects
   included), |F| with the model's 1 mN smoothing (as in its utilisation), and P_i the design's preload
   (= (u_i − (1 − margin))·N_i/P_i: the utilisation row's value wherever N = P). It is positive whenever N_i ≤ 0,
   and smooth through N = 0, where u has a pole; where N > 0 it has the sign of u − (1 − margin), so the
   feasible set, and every optimum with the contacts loaded, is the one of the utilisation row. (The
   alternative, keeping u and relying on the normal_force rows being present, would leave that pole in
   the rows IPOPT differentiates.)
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from pathlib import Path

import casadi as ca
import numpy as np

from cvtdesign.core.geometry import roller_pose, steering_angle_guess, steering_data
from cvtdesign.core.kinematics import ShaftFrame, shaft_frame, vec
from cvtdesign.core.model import compile_model, failed_contact, status_codes
from cvtdesign.core.steering import sliding_lever_expr
from cvtdesign.design.objectives import Objective, objective
from cvtdesign.design.robust import scenarios
from cvtdesign.design.solution import EnvelopeCheck, check_envelope
from cvtdesign.design.study_file import (
    StudySpec,
    duty_cycle,
    load_study,
    min_normal_force,
    problem_inputs,
)
from cvtdesign.io.variant import grid, parameter_value, resolve

CHECK_OUTPUTS = ("status", "alpha", "N", "F_t", "F_a", "mu", "utilisation")   # what check_envelope reads
IPOPT_OPTIONS = {"tol": 1e-8, "acceptable_tol": 1e-6, "hessian_approximation": "limited-memory",
                 "limited_memory_aug_solver": "extended"}   # few variables, many rows: cheaper than Sherman-Morrison


@dataclass
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
    nlp: _NLP = None          # the inputs and the model it was built from (for the functions built on first use)
    theta_pts: np.ndarray = None   # the model's θ at each point (len(θ) × points): a robust study's corners


@dataclass
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
            outputs = list(dict.fromkeys(_row_outputs(pt.nlp) + list(CHECK_OUTPUTS)))
            checked = _point_function(pt.nlp, outputs, extra=CHECK_OUTPUTS)[0]
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


@dataclass
class _NLP:
    """What the pieces of build_problem share: the study's checked inputs, the model compiled with the
    design as symbols p, the NLP's variables and the envelope points."""
    where: str
    spec: StudySpec
    objective: Objective      # what is minimised (design.objectives; 'pareto': the ε-constraint problem)
    vspec: object
    base: object              # the base layout at the sweep point (numeric)
    layout: object            # the same with the design variables as the symbols p
    model: object             # its CompiledModel
    names: list
    lower: np.ndarray
    upper: np.ndarray
    p: ca.SX
    z: ca.MX
    t: ca.MX                  # the epigraph variable (empty without one)
    eps: ca.MX                # ε of the Pareto sweep: worst |α| ≤ ε [deg]
    x: ca.MX
    P: ca.MX                  # the design [SI] as a function of z
    P0: ca.MX                 # Hertz peak pressure at the preload, per roller
    g_pts: np.ndarray         # the envelope points: γ [rad], load [N m], steering angle guess [rad]; a robust
    l_pts: np.ndarray         # study's envelope once per scenario (design.robust), scenario-major
    phi0: np.ndarray
    nload: int                # loads per γ
    margin: float | None      # traction margin (None: no traction rows)
    allow: list               # per roller: allowable Hertz pressure [Pa] (None: no Hertz row)
    pre0: np.ndarray          # P₀: the preloads at the base design [N]
    n_min: np.ndarray         # N_min per roller [N]
    preload: ca.Function      # P(design) per roller [N]
    theta_pts: np.ndarray     # the model's θ at each point (len(θ) × points)
    scenarios: list           # a label per scenario ([''] without `robust`)
    steer_max: float | None = None   # the steering motor's largest torque [N m] (None: no steering rows)

    @property
    def epigraph(self) -> bool:
        return self.objective.epigraph

    def duty_mean(self, output: str):
        """The weighted mean of a model output over the study's duty cycle, as a function of the design."""
        dg, dl, w = duty_cycle(self.spec, self.g_pts, self.l_pts, self.where)
        dphi, _ = steering_angle_guess(*steering_data(self.base), dg)
        values = self.model.point_function([output]).map(len(dg), "serial")(dg, self.w1, dl, 0.0, dphi, self.theta,
                                                                            self.P)
        return ca.dot(ca.DM(w / w.sum()), ca.vec(values))

    @property
    def npts(self) -> int:
        return self.g_pts.size

    @property
    def per_scenario(self) -> int:
        return self.npts // len(self.scenarios)

    @property
    def first(self) -> np.ndarray:
        """One point per γ (the linkage misfit depends on γ only), in the first scenario."""
        return np.arange(0, self.per_scenario, self.nload)

    @property
    def w1(self) -> float:
        return self.base.motor_speed

    @property
    def theta(self) -> np.ndarray:
        return np.array(self.model.param_values)


class _Rows:
    """The rows of g being assembled: expressions, bounds, labels and families."""

    def __init__(self):
        self.exprs, self.lb, self.ub, self.labels, self.family = [], [], [], [], []

    def add(self, expr, lo, hi, fam: str, labs: list) -> int:
        """Append the rows of `expr` (bounds lo, hi; broadcast) and return the index of the first."""
        expr = ca.vec(expr)
        start = len(self.lb)
        self.exprs.append(expr)
        self.lb.extend(np.broadcast_to(lo, expr.shape[0]))
        self.ub.extend(np.broadcast_to(hi, expr.shape[0]))
        self.labels.extend(labs)
        self.family.extend([fam] * expr.shape[0])
        return start


def build_problem(study_path, spec: StudySpec | None = None, base_file: Path | None = None,
                  fixed: dict | None = None, kind: str | None = None) -> Problem:
    """The NLP of a study. `fixed` sets other variant parameters (SI) for a sweep case; `kind` overrides the
    study's objective kind (design.objectives; 'pareto' builds the ε-constraint problem)."""
    if spec is None:
        spec, base_file = load_study(study_path)
    fixed = fixed or {}
    nlp = _setup(study_path, spec, base_file, fixed, objective(kind or spec.objective.kind))
    rows = _Rows()
    point_rows, blocks, pt_index, reach_index, misfit_row, obj_grid = _envelope_rows(nlp, rows)
    design_start, n_point_blocks = len(rows.lb), len(rows.exprs)
    _design_rows(nlp, rows)
    g_full = ca.vertcat(*rows.exprs)
    design_index = np.arange(design_start, len(rows.lb))
    # the design rows on their own (a slice of g_full would still depend on every envelope point)
    g_design = ca.vertcat(*rows.exprs[n_point_blocks:]) if design_index.size else ca.MX(0, 1)
    f = nlp.objective.value(nlp, obj_grid)
    inputs = [nlp.x, nlp.eps] if nlp.objective.eps_row else [nlp.x]
    evaluate = ca.Function("evaluate", inputs, [f, g_full])
    row_r, row_k, row_scale = _row_maps(nlp, blocks, pt_index, reach_index, misfit_row, len(rows.lb))
    big = np.abs(nlp.l_pts) >= np.max(np.abs(nlp.l_pts)) * (1 - 1e-12)
    parts = Parts(nlp.x, nlp.eps, f, g_full, g_design, nlp.P0, point_rows, np.array([b[0] for b in blocks], float),
                  np.array([b[1] for b in blocks], float), pt_index, misfit_row, reach_index, design_index,
                  row_r, row_k, row_scale, nlp.g_pts, nlp.l_pts, nlp.phi0,
                  (np.arange(nlp.npts) % nlp.per_scenario) // nlp.nload, np.flatnonzero(big), nlp=nlp,
                  theta_pts=nlp.theta_pts)
    return Problem(spec, nlp.where, base_file, nlp.names, nlp.lower, nlp.upper, nlp.x.shape[0], np.array(rows.lb),
                   np.array(rows.ub), rows.labels, rows.family, evaluate, nlp.epigraph, _start_t(nlp),
                   np.array([nlp.base.parameters[n] for n in nlp.names]), parts, fixed=dict(fixed),
                   g_report=_report_scale(nlp, blocks, pt_index, len(rows.lb)), vspec=nlp.vspec,
                   motor_speed=float(nlp.w1))


def _setup(study_path, spec: StudySpec, base_file: Path, fixed: dict, goal: Objective) -> _NLP:
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
    return _NLP(where, spec, goal, vspec, base, layout, model, names, lower, upper, p, z, t, eps, x, P, P0,
                g_pts, l_pts, phi0, nload, margin, allow, pre0, n_min, preload, theta_pts, labels, steer_max)


def _steering_data(nlp: _NLP) -> tuple[ca.Function, np.ndarray]:
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
    gammas, loads = base.gamma_grid, base.load_grid
    if spec.envelope is not None:
        gammas = grid(spec.envelope.gamma, "angle", f"{where}: envelope.gamma")
        loads = grid(spec.envelope.load, "torque", f"{where}: envelope.load")
    G, T = np.meshgrid(gammas, loads, indexing="ij")
    g_pts, l_pts = G.ravel(), T.ravel()
    phi0, _ = steering_angle_guess(*steering_data(base), g_pts)
    return g_pts, l_pts, phi0, G.shape[1]


def _point_function(nlp: _NLP, outputs: list, objective: bool = False, extra: tuple = (),
                    contacts_only: bool = False) -> tuple[ca.Function, list]:
    """(x, γ, load, φ guess, p0, θ) → the rows of one envelope point (then, with `objective`, the objective's
    per-point value, and the model outputs named in `extra`), evaluating only the model outputs they need;
    blocks: (lb, ub, family, label of a point, margin scale). `contacts_only`: the contacts' rows alone (Hertz,
    traction, normal force), as the capacity rows hold them."""
    n, rn = len(nlp.names), nlp.model.roller_names
    nc = len(rn)
    xs, gs, ls, ps = ca.MX.sym("x", nlp.x.shape[0]), ca.MX.sym("gamma"), ca.MX.sym("load"), ca.MX.sym("phi0")
    p0s, ths = ca.MX.sym("p0", nc), ca.MX.sym("theta", nlp.theta_pts.shape[0])
    Ps = ca.DM(nlp.lower) + ca.DM(nlp.upper - nlp.lower) * xs[:n]
    out = dict(zip(outputs, nlp.model.point_function(outputs).call([gs, nlp.w1, ls, 0.0, ps, ths, Ps]))) \
        if outputs else {}
    rows_, blocks = [], []
    if nlp.epigraph and not contacts_only:
        a_deg = out["alpha"] * (180 / np.pi)
        rows_ += [a_deg - xs[n], -a_deg - xs[n]]
        blocks += [(-np.inf, 0.0, "worst_alpha", lambda s: f"α ≤ t at {s}", None),
                   (-np.inf, 0.0, "worst_alpha", lambda s: f"−α ≤ t at {s}", None)]
    if any(a is not None for a in nlp.allow):
        pm = nlp.model.peak_pressure(out["N"], p0s, Ps)
        for i, a in enumerate(nlp.allow):
            if a is not None:
                rows_.append(pm[i] / a)
                blocks.append((-np.inf, 1.0, "hertz_pressure", lambda s, i=i: f"p_max/p_allow of {rn[i]} at {s}", 1.0))
    margin = nlp.margin
    if margin is not None:
        # (|F| − (1 − margin)μN)/(μP) ≤ 0: positive wherever N ≤ 0 (u = |F|/(μN) is negative there)
        f_abs = ca.sqrt(out["F_t"] ** 2 + out["F_a"] ** 2 + 1e-6)       # the model's 1 mN smoothing
        mu_p = out["mu"] * nlp.preload(Ps)
        for i in range(nc):
            rows_.append((f_abs[i] - (1 - margin) * out["mu"][i] * out["N"][i]) / mu_p[i])
            blocks.append((-np.inf, 0.0, "traction",
                           lambda s, i=i: f"(|F| − {1 - margin:g}μN)/(μP) of {rn[i]} at {s}", 1 - margin))
    for i in range(nc):       # N ≥ N_min, over P₀ (reported in newtons: g_report)
        rows_.append(out["N"][i] / nlp.pre0[i])
        blocks.append((nlp.n_min[i] / nlp.pre0[i], np.inf, "normal_force", lambda s, i=i: f"N [N] of {rn[i]} at {s}", 1.0))
    if nlp.steer_max is not None and not contacts_only:
        rows_ += _steering_rows(nlp, out)
        blocks += [(-1.0, 1.0, "steering_torque", lambda s: f"rolling steering torque/T_max at {s}", 1.0),
                   (-np.inf, 1.0, "steering_torque", lambda s: f"standstill steering torque/T_max at {s}", 1.0)]
    if nlp.spec.constraints.reach_gamma and not contacts_only:
        rows_.append(out["steer_misfit"])
        blocks.append((-np.inf, 1e-6, "reach_gamma", None, 1e-6))
    res = [ca.vertcat(*rows_) if rows_ else ca.MX(0, 1)]
    if objective:
        res.append(out[nlp.objective.per_point(nlp)])
    return ca.Function("point_rows", [xs, gs, ls, ps, p0s, ths], res + [out[k] for k in extra]), blocks


def _steering_rows(nlp: _NLP, out: dict) -> list:
    """The steering motor's torque over the study's limit while rolling and at standstill (core.steering:
    Σ k_i T_i and Σ |k_i| μ_i N_i L_i, L the sliding patch's lever)."""
    still = 0
    for i, r in enumerate(nlp.layout.rollers):
        if r.fork_axis is not None:
            lever = sliding_lever_expr(out["a"][i], out["b"][i], out["fork_pivot"][i], out["fork_slide"][i])
            still += abs(r.fork_ratio) * out["mu"][i] * out["N"][i] * lever
    return [out["steering_torque"] / nlp.steer_max, still / nlp.steer_max]


def _envelope_rows(nlp: _NLP, rows: _Rows) -> tuple:
    """Every point row at every envelope point, added to `rows` block by block (the linkage misfit once per
    γ). Returns (point_rows, blocks, pt_index, reach_index, misfit_row, the objective's per-point values or
    None); the objective's values come from the same Newton solves as the rows."""
    cs = nlp.spec.constraints
    need = _row_outputs(nlp)
    point_rows, blocks = _point_function(nlp, need)
    misfit_row = len(blocks) - 1 if cs.reach_gamma else None
    grid_args = [nlp.x, nlp.g_pts[None, :], nlp.l_pts[None, :], nlp.phi0[None, :], nlp.P0, nlp.theta_pts]
    per_point = nlp.objective.per_point(nlp)
    if per_point:
        point_all = _point_function(nlp, list(dict.fromkeys(need + [per_point])), objective=True)[0]
        M, obj_grid = point_all.map(nlp.npts, "serial").call(grid_args)
    else:
        M, obj_grid = point_rows.map(nlp.npts, "serial").call(grid_args)[0], None
    scen = np.repeat(nlp.scenarios, nlp.per_scenario)
    pt_label = [f"γ={np.degrees(g):+.0f}° τ⊥={l:+.2g}" + (f" ({s})" if s else "")
                for g, l, s in zip(nlp.g_pts, nlp.l_pts, scen)]
    first = nlp.first
    pt_index = np.full(len(blocks), -1)
    reach_index = np.zeros(0, int)
    for r, (lo, hi, fam, lab, _) in enumerate(blocks):
        if r == misfit_row:
            labs = [f"linkage misfit at γ={np.degrees(nlp.g_pts[k]):+.0f}°" for k in first]
            reach_index = rows.add(M[r, first].T, lo, hi, fam, labs) + np.arange(first.size)
        else:
            pt_index[r] = rows.add(M[r, :].T, lo, hi, fam, [lab(s) for s in pt_label])
    return point_rows, blocks, pt_index, reach_index, misfit_row, obj_grid


def _row_outputs(nlp: _NLP) -> list:
    """The model outputs the point rows need."""
    steer = ["steering_torque", "a", "b", "mu", "fork_pivot", "fork_slide"] if nlp.steer_max is not None else []
    return list(dict.fromkeys((["alpha"] if nlp.epigraph else []) + ["N"] + (
        ["F_t", "F_a", "mu"] if nlp.margin is not None else []) + steer +
        (["steer_misfit"] if nlp.spec.constraints.reach_gamma else [])))


def _clearance_rows(nlp: _NLP, c: float) -> tuple[list, list]:
    """Roller–roller clearance ≥ c [m] (SX rows in p): (rows, [(count, lb, ub, family, labels)])."""
    R, rn = nlp.layout.sphere_radius, nlp.model.roller_names
    phis = np.unique(np.round(nlp.phi0, 12))[:: max(1, len(np.unique(nlp.phi0)) // 5)]
    design_rows, design_spec = [], []
    for (a, ra), (b, rb) in itertools.combinations(enumerate(nlp.layout.rollers), 2):
        # two fixed rollers, or two turned by the same angle about the same fork axis, keep their
        # distance at every φ: one row (the same row at each φ would be a duplicate constraint)
        rigid = (ra.fork_axis is None and rb.fork_axis is None) or (
            ra.fork_axis is not None and rb.fork_axis is not None and ra.fork_ratio == rb.fork_ratio
            and np.allclose(ca.DM(ra.fork_axis).full(), ca.DM(rb.fork_axis).full()))
        gaps, labs = [], []
        for ph in phis[:1] if rigid else phis:
            ca_ = (R + ra.radius) * roller_pose(ra, ph)[0]
            cb = (R + rb.radius) * roller_pose(rb, ph)[0]
            gaps.append(ca.norm_2(ca_ - cb) - ra.radius - rb.radius)
            labs.append(f"clearance {rn[a]}–{rn[b]}" + ("" if rigid else f" at φ={np.degrees(ph):+.0f}°"))
        design_rows += gaps
        design_spec.append((len(gaps), c, np.inf, "clearance", labs))
    return design_rows, design_spec


def _design_rows(nlp: _NLP, rows: _Rows) -> None:
    """The rows that depend on the design alone, added to `rows`: clearance and envelope radius (compiled
    into one function of the design), and for the Pareto problem worst |α| ≤ ε (t − ε ≤ 0)."""
    cs, where = nlp.spec.constraints, nlp.where
    design_rows, design_spec = [], []
    if cs.clearance is not None:
        c = float(parameter_value(cs.clearance, f"{where}: constraints.clearance", {}))
        design_rows, design_spec = _clearance_rows(nlp, c)
    if cs.envelope_radius is not None:
        e = float(parameter_value(cs.envelope_radius, f"{where}: constraints.envelope_radius", {}))
        rn = nlp.model.roller_names
        design_rows += [nlp.layout.sphere_radius + 2 * r.radius for r in nlp.layout.rollers]
        design_spec.append((len(rn), -np.inf, e, "envelope_radius", [f"extent of {r}" for r in rn]))
    if design_rows:
        D = ca.Function("design_rows", [nlp.p], [ca.cse(ca.vertcat(*design_rows))])(nlp.P)
        at = 0
        for size, lo, hi, fam, labs in design_spec:
            rows.add(D[at: at + size], lo, hi, fam, labs)
            at += size
    if cs.min_capacity is not None:
        _capacity_rows(nlp, rows, float(parameter_value(cs.min_capacity, f"{where}: constraints.min_capacity", {})))
    if nlp.objective.eps_row:
        rows.add(nlp.t - nlp.eps, -np.inf, 0, "epsilon", ["worst |α| ≤ ε"])


def _capacity_rows(nlp: _NLP, rows: _Rows, c: float) -> None:
    """Load capacity ≥ c [N m]: the contacts' rows (Hertz, traction margin, normal force) at τ⊥ = ±c at every γ
    of the envelope, at the nominal calibration, added to `rows` as rows that every solve holds (beside the
    design rows; few points, so not worth a working set). Where the contacts' margins shrink monotonically
    with the load, as on the shipped layouts (docs/capacity.md), this is the capacity's own limit; the
    optimum is then checked on the whole envelope as usual, and `cvtdesign capacity` gives the full search."""
    first = nlp.first
    gam = np.repeat(nlp.g_pts[first], 2)
    load = np.tile([-c, c], first.size)
    fn, blocks = _point_function(nlp, list(dict.fromkeys(["N"] + (["F_t", "F_a", "mu"] if nlp.margin is not None
                                                                 else []))), contacts_only=True)
    M = fn.map(gam.size, "serial").call([nlp.x, gam[None, :], load[None, :], np.repeat(nlp.phi0[first], 2)[None, :],
                                         nlp.P0, np.repeat(nlp.theta_pts[:, first], 2, axis=1)])[0]
    where = [f"γ={np.degrees(g):+.0f}° τ⊥={t:+.3g}" for g, t in zip(gam, load)]
    for r, (lo, hi, _, lab, _) in enumerate(blocks):
        rows.add(M[r, :].T, lo, hi, "capacity", [f"capacity: {lab(s)}" for s in where])


def _start_t(nlp: _NLP) -> ca.Function | None:
    """z → worst |α| [deg] over the envelope (the epigraph variable's start), for epigraph objectives."""
    if not nlp.epigraph:
        return None
    alpha_grid = nlp.model.point_function(["alpha"]).map(nlp.npts, "serial")(
        nlp.g_pts, nlp.w1, nlp.l_pts, 0.0, nlp.phi0, nlp.theta_pts, nlp.P)
    return ca.Function("start_t", [nlp.z], [ca.mmax(ca.fabs(alpha_grid)) * (180 / np.pi)])


def _row_maps(nlp: _NLP, blocks: list, pt_index, reach_index, misfit_row, nrows: int) -> tuple:
    """Per row of g: its row of point_rows and its envelope point (−1 for the design rows), and the scale
    of its near-binding margin (NaN for the epigraph rows)."""
    row_r, row_k, row_scale = np.full(nrows, -1), np.full(nrows, -1), np.full(nrows, np.nan)
    for r, b in enumerate(blocks):
        idx = reach_index if r == misfit_row else pt_index[r] + np.arange(nlp.npts)
        row_r[idx], row_k[idx] = r, nlp.first if r == misfit_row else np.arange(nlp.npts)
        row_scale[idx] = np.nan if b[4] is None else b[4]
    return row_r, row_k, row_scale


def _report_scale(nlp: _NLP, blocks: list, pt_index, nrows: int) -> np.ndarray:
    """Per row of g: the factor to the report's units (P₀ of the roller for its normal_force rows: N)."""
    g_report = np.ones(nrows)
    nf = [r for r, b in enumerate(blocks) if b[2] == "normal_force"]
    for i, r in enumerate(nf):
        g_report[pt_index[r] + np.arange(nlp.npts)] = nlp.pre0[i]
    return g_report
