"""The rows of a study's NLP (design.problem): the point rows over the envelope (epigraph α, Hertz pressure,
traction, normal force, steering torque, linkage misfit), the capacity rows, the rows of the design alone
(clearance, envelope radius, ε), and the NLP's inputs they are built from (NLP).

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
from dataclasses import dataclass

import casadi as ca
import numpy as np

from cvtdesign.core.geometry import roller_pose, steering_angle_guess, steering_data
from cvtdesign.core.steering import sliding_lever_expr
from cvtdesign.design.dynamic_rows import dynamic_rows
from cvtdesign.design.life_rows import life_rows
from cvtdesign.design.objectives import Objective
from cvtdesign.design.study_file import StudySpec, duty_cycle
from cvtdesign.io.variant import parameter_value


@dataclass(kw_only=True)
class NLP:
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


class Rows:
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


def point_function(nlp: NLP, outputs: list, objective: bool = False, extra: tuple = (),
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


def _steering_rows(nlp: NLP, out: dict) -> list:
    """The steering motor's torque over the study's limit while rolling and at standstill (core.steering:
    Σ k_i T_i and Σ |k_i| μ_i N_i L_i, L the sliding patch's lever)."""
    still = 0
    for i, r in enumerate(nlp.layout.rollers):
        if r.fork_axis is not None:
            lever = sliding_lever_expr(out["a"][i], out["b"][i], out["fork_pivot"][i], out["fork_slide"][i])
            still += abs(r.fork_ratio) * out["mu"][i] * out["N"][i] * lever
    return [out["steering_torque"] / nlp.steer_max, still / nlp.steer_max]


def envelope_rows(nlp: NLP, rows: Rows) -> tuple:
    """Every point row at every envelope point, added to `rows` block by block (the linkage misfit once per
    γ). Returns (point_rows, blocks, pt_index, reach_index, misfit_row, the objective's per-point values or
    None); the objective's values come from the same Newton solves as the rows."""
    cs = nlp.spec.constraints
    need = row_outputs(nlp)
    point_rows, blocks = point_function(nlp, need)
    misfit_row = len(blocks) - 1 if cs.reach_gamma else None
    grid_args = [nlp.x, nlp.g_pts[None, :], nlp.l_pts[None, :], nlp.phi0[None, :], nlp.P0, nlp.theta_pts]
    per_point = nlp.objective.per_point(nlp)
    if per_point:
        point_all = point_function(nlp, list(dict.fromkeys(need + [per_point])), objective=True)[0]
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


def row_outputs(nlp: NLP) -> list:
    """The model outputs the point rows need."""
    steer = ["steering_torque", "a", "b", "mu", "fork_pivot", "fork_slide"] if nlp.steer_max is not None else []
    return list(dict.fromkeys((["alpha"] if nlp.epigraph else []) + ["N"] + (
        ["F_t", "F_a", "mu"] if nlp.margin is not None else []) + steer +
        (["steer_misfit"] if nlp.spec.constraints.reach_gamma else [])))


def _clearance_rows(nlp: NLP, c: float) -> tuple[list, list]:
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


def design_rows(nlp: NLP, rows: Rows) -> None:
    """The rows that depend on the design alone, added to `rows`: clearance and envelope radius (compiled
    into one function of the design), the capacity and life rows (design.life_rows), the dynamic rows
    (design.dynamic_rows), and for the Pareto
    problem worst |α| ≤ ε (t − ε ≤ 0)."""
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
    if cs.min_life_h is not None:
        life_rows(nlp, rows)
    dynamic_rows(nlp, rows)
    nlp.objective.add_rows(nlp, rows)


def _capacity_rows(nlp: NLP, rows: Rows, c: float) -> None:
    """Load capacity ≥ c [N m]: the contacts' rows (Hertz, traction margin, normal force) at τ⊥ = ±c at every γ
    of the envelope, at the nominal calibration, added to `rows` as rows that every solve holds (beside the
    design rows; few points, so not worth a working set). Where the contacts' margins shrink monotonically
    with the load, as on the shipped layouts (docs/capacity.md), this is the capacity's own limit; the
    optimum is then checked on the whole envelope as usual, and `cvtdesign capacity` gives the full search."""
    first = nlp.first
    gam = np.repeat(nlp.g_pts[first], 2)
    load = np.tile([-c, c], first.size)
    fn, blocks = point_function(nlp, list(dict.fromkeys(["N"] + (["F_t", "F_a", "mu"] if nlp.margin is not None
                                                                 else []))), contacts_only=True)
    M = fn.map(gam.size, "serial").call([nlp.x, gam[None, :], load[None, :], np.repeat(nlp.phi0[first], 2)[None, :],
                                         nlp.P0, np.repeat(nlp.theta_pts[:, first], 2, axis=1)])[0]
    where = [f"γ={np.degrees(g):+.0f}° τ⊥={t:+.3g}" for g, t in zip(gam, load)]
    for r, (lo, hi, _, lab, _) in enumerate(blocks):
        rows.add(M[r, :].T, lo, hi, "capacity", [f"capacity: {lab(s)}" for s in where])


def row_maps(nlp: NLP, blocks: list, pt_index, reach_index, misfit_row, nrows: int) -> tuple:
    """Per row of g: its row of point_rows and its envelope point (−1 for the design rows), and the scale
    of its near-binding margin (NaN for the epigraph rows)."""
    row_r, row_k, row_scale = np.full(nrows, -1), np.full(nrows, -1), np.full(nrows, np.nan)
    for r, b in enumerate(blocks):
        idx = reach_index if r == misfit_row else pt_index[r] + np.arange(nlp.npts)
        row_r[idx], row_k[idx] = r, nlp.first if r == misfit_row else np.arange(nlp.npts)
        row_scale[idx] = np.nan if b[4] is None else b[4]
    return row_r, row_k, row_scale


def report_scale(nlp: NLP, blocks: list, pt_index, nrows: int) -> np.ndarray:
    """Per row of g: the factor to the report's units (P₀ of the roller for its normal_force rows: N)."""
    g_report = np.ones(nrows)
    nf = [r for r, b in enumerate(blocks) if b[2] == "normal_force"]
    for i, r in enumerate(nf):
        g_report[pt_index[r] + np.arange(nlp.npts)] = nlp.pre0[i]
    return g_report
