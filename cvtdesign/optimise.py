"""Design optimisation: where should the rollers go and how big should they be.

A study file names a base variant, the variant parameters that are free (with bounds), an objective and
constraints. The model is compiled with the free parameters as CasADi symbols, so the objective and every
constraint over the operating envelope have exact derivatives (through the model's Newton solves by the
implicit function theorem); IPOPT solves the NLP from several space-filling starts.

Objectives: `worst_alpha` (max |α| over the envelope, as an epigraph variable t with −t ≤ α_k ≤ t),
`rms_alpha`, `power_loss` (weighted mean power loss over a duty cycle of (γ, τ⊥) points [W]).
Constraints: Hertz peak pressure ≤ the material's allowable, traction utilisation F/(μN) ≤ 1 − margin
(no gross slip), roller–roller clearance (distance of roller centres minus both radii: exact for rollers in
one plane such as a tandem pair, conservative otherwise), an assembly envelope radius, and the steering
linkage still reaching every γ of the envelope.
"""
from __future__ import annotations

import datetime
import itertools
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import casadi as ca
import numpy as np
import yaml

from .checks import check_layout
from .geometry import roller_pose, steering_angle_guess, steering_data
from .model import compile_model
from .units import InputError, registry
from .variant import EnvelopeSpec, Num, Strict, _grid, _param, _suggest, load_spec, read_spec, resolve


class DesignVar(Strict):
    lower: Num
    upper: Num


class DutyPoint(Strict):
    gamma: Num
    load: Num
    weight: float = 1.0


class Objective(Strict):
    kind: Literal["worst_alpha", "rms_alpha", "power_loss"] = "worst_alpha"
    duty_cycle: list[DutyPoint] | None = None


class Constraints(Strict):
    hertz_pressure: bool = True
    traction_margin: Num | None = 0.2
    clearance: Num | None = "2 mm"
    envelope_radius: Num | None = None
    reach_gamma: bool = True


class Multistart(Strict):
    starts: int = 6
    seed: int = 0


class Batch(Strict):
    """What `cvtdesign study` runs as separate cases: every base variant × every combination of the swept
    (fixed) parameters × every multistart point, and one Pareto chain per variant × sweep combination."""
    variants: list[str] | None = None                 # default: [base]
    sweep: dict[str, list[Num]] = {}
    pareto: bool = False


class Pareto(Strict):
    """ε-constraint sweep: minimise power loss subject to worst |α| ≤ ε, ε from the slip optimum to the
    loss optimum's slip, warm-started point to point."""
    points: int = 8


class StudySpec(Strict):
    name: str
    description: str = ""
    base: str
    effects: list[str] | None = None
    design: dict[str, DesignVar]
    objective: Objective = Objective()
    constraints: Constraints = Constraints()
    multistart: Multistart = Multistart()
    envelope: EnvelopeSpec | None = None              # default: the variant's envelope
    batch: Batch = Batch()
    pareto: Pareto = Pareto()
    max_iter: int = 200


def load_study(path) -> tuple[StudySpec, Path]:
    where = str(path)
    spec = read_spec(path, StudySpec, "name, base, design, objective")
    base = (Path(path).parent / spec.base)
    if not base.exists():
        raise InputError(f"{where}: base: no variant file '{spec.base}' next to the study")
    return spec, base


IPOPT_OPTIONS = {"tol": 1e-8, "acceptable_tol": 1e-6, "hessian_approximation": "limited-memory"}
ACTIVE_TOL = 1e-7   # a constraint within this (relative) slack of its bound counts as active


@dataclass
class Problem:
    """The NLP of one study, in normalised design variables z ∈ [0, 1]^n (p = lower + (upper − lower)·z)."""
    spec: StudySpec
    study_file: str
    base_file: Path
    names: list
    lower: np.ndarray
    upper: np.ndarray
    solver: ca.Function
    nx: int
    g_lb: np.ndarray
    g_ub: np.ndarray
    g_labels: list          # one label per constraint row
    g_family: list          # constraint family per row
    evaluate: ca.Function   # z → (objective, g)
    epigraph: bool
    start_t: ca.Function | None = None
    base_values: np.ndarray = field(default=None)


def _unit_of(raw) -> str | None:
    if isinstance(raw, str) and not raw.strip().startswith("="):
        return str(registry().Quantity(raw.strip()).units)
    return None


def build_problem(study_path, spec: StudySpec | None = None, base_file: Path | None = None,
                  fixed: dict | None = None, objective: str | None = None) -> Problem:
    """The NLP of a study. `fixed` sets other variant parameters (SI) for a sweep case; `objective`
    overrides the study's objective kind ('pareto' builds the ε-constraint problem)."""
    if spec is None:
        spec, base_file = load_study(study_path)
    where = str(study_path)
    vspec = load_spec(base_file)
    fixed = fixed or {}
    for n in fixed:
        if n not in vspec.parameters:
            raise InputError(f"{where}: batch.sweep.{n}: the variant {base_file.name} has no parameter '{n}'"
                             f"{_suggest(n, vspec.parameters)}")
        if n in spec.design:
            raise InputError(f"{where}: batch.sweep.{n}: '{n}' is a design variable; sweep fixed parameters only")
    base = resolve(vspec, str(base_file), overrides=fixed)
    check_layout(base)
    names = list(spec.design)
    if not names:
        raise InputError(f"{where}: design: no design variables")
    lower, upper = [], []
    for n in names:
        if n not in vspec.parameters:
            raise InputError(f"{where}: design.{n}: the variant {base_file.name} has no parameter '{n}'"
                             f"{_suggest(n, vspec.parameters)} (parameters: {', '.join(vspec.parameters) or 'none'})")
        lo = _param(spec.design[n].lower, f"{where}: design.{n}.lower", {})
        hi = _param(spec.design[n].upper, f"{where}: design.{n}.upper", {})
        if not lo < hi:
            raise InputError(f"{where}: design.{n}: inverted bounds (lower {spec.design[n].lower} must be below "
                             f"upper {spec.design[n].upper})")
        lower.append(lo)
        upper.append(hi)
    lower, upper = np.array(lower), np.array(upper)
    base_values = np.array([base.parameters[n] for n in names])

    p = ca.SX.sym("p", len(names))
    layout = resolve(vspec, str(base_file), overrides=fixed | {n: p[i] for i, n in enumerate(names)})
    model = compile_model(layout, effects=spec.effects, design=p)
    gammas, loads = base.gamma_grid, base.load_grid
    if spec.envelope is not None:
        gammas = _grid(spec.envelope.gamma, "angle", f"{where}: envelope.gamma")
        loads = _grid(spec.envelope.load, "torque", f"{where}: envelope.load")
    G, T = np.meshgrid(gammas, loads, indexing="ij")
    g_pts, l_pts = G.ravel(), T.ravel()
    phi0, _ = steering_angle_guess(*steering_data(base), g_pts)
    theta = np.array(model.param_values)
    npts = g_pts.size

    z = ca.MX.sym("z", len(names))
    P = ca.DM(lower) + ca.DM(upper - lower) * z
    out = dict(zip(model.point.name_out(),
                   model.point.map(npts, "serial")(g_pts, base.motor_speed, l_pts, 0.0, phi0, theta, P)))
    alpha_deg = out["alpha"] * (180 / np.pi)

    rows, lb, ub, labels, family = [], [], [], [], []

    def add(expr, lo, hi, fam, labs):
        expr = ca.vec(expr)
        rows.append(expr)
        lb.extend(np.broadcast_to(lo, expr.shape[0]))
        ub.extend(np.broadcast_to(hi, expr.shape[0]))
        labels.extend(labs)
        family.extend([fam] * expr.shape[0])

    pt_label = [f"γ={np.degrees(g):+.0f}° τ⊥={l:+.2g}" for g, l in zip(g_pts, l_pts)]
    rn = model.roller_names
    kind = objective or spec.objective.kind
    epigraph = kind in ("worst_alpha", "pareto")
    t = ca.MX.sym("t") if epigraph else ca.MX(0, 1)
    eps = ca.MX.sym("eps")          # ε of the Pareto sweep: worst |α| ≤ ε [deg]
    if epigraph:
        f = t
        add(alpha_deg.T - t, -np.inf, 0, "worst_alpha", [f"α ≤ t at {s}" for s in pt_label])
        add(-alpha_deg.T - t, -np.inf, 0, "worst_alpha", [f"−α ≤ t at {s}" for s in pt_label])
    if kind == "rms_alpha":
        f = ca.sqrt(ca.sumsqr(alpha_deg) / npts)
    elif kind in ("power_loss", "pareto"):
        duty = spec.objective.duty_cycle
        if duty:
            dg = np.array([_param(d.gamma, f"{where}: objective.duty_cycle.gamma", {}) for d in duty])
            dl = np.array([_param(d.load, f"{where}: objective.duty_cycle.load", {}) for d in duty])
            w = np.array([d.weight for d in duty])
            dphi, _ = steering_angle_guess(*steering_data(base), dg)
            dout = dict(zip(model.point.name_out(), model.point.map(len(dg), "serial")(
                dg, base.motor_speed, dl, 0.0, dphi, theta, P)))
            f = ca.dot(ca.DM(w / w.sum()), ca.vec(dout["power_loss"]))
        else:
            f = ca.sum2(out["power_loss"]) / npts

    cs = spec.constraints
    if cs.hertz_pressure:
        for i, r in enumerate(layout.rollers):
            allow = r.material.p_allow
            if allow is not None:
                add(out["p_max"][i, :] / allow, -np.inf, 1.0, "hertz_pressure",
                    [f"p_max/p_allow of {rn[i]} at {s}" for s in pt_label])
    if cs.traction_margin is not None:
        margin = float(_param(cs.traction_margin, f"{where}: constraints.traction_margin", {}))
        add(out["utilisation"].T.reshape((-1, 1)), -np.inf, 1 - margin, "traction",
            [f"F/(μN) of {rn[i]} at {s}" for s in pt_label for i in range(len(rn))])
    if cs.reach_gamma:
        first = np.arange(0, npts, G.shape[1])          # one point per γ
        add(out["steer_misfit"][first], -np.inf, 1e-6, "reach_gamma",
            [f"linkage misfit at γ={np.degrees(g_pts[k]):+.0f}°" for k in first])
    R = layout.sphere_radius
    if cs.clearance is not None:
        c = float(_param(cs.clearance, f"{where}: constraints.clearance", {}))
        phis = np.unique(np.round(phi0, 12))[:: max(1, len(np.unique(phi0)) // 5)]
        for (a, ra), (b, rb) in itertools.combinations(enumerate(layout.rollers), 2):
            gaps, labs = [], []
            for ph in phis:
                ca_ = (R + ra.radius) * roller_pose(ra, ph)[0]
                cb = (R + rb.radius) * roller_pose(rb, ph)[0]
                gaps.append(ca.norm_2(ca_ - cb) - ra.radius - rb.radius)
                labs.append(f"clearance {rn[a]}–{rn[b]} at φ={np.degrees(ph):+.0f}°")
            gfun = ca.Function("gap", [p], [ca.vertcat(*gaps)])
            add(gfun(P), c, np.inf, "clearance", labs)
    if cs.envelope_radius is not None:
        e = float(_param(cs.envelope_radius, f"{where}: constraints.envelope_radius", {}))
        ext = ca.Function("extent", [p], [ca.vertcat(*[R + 2 * r.radius for r in layout.rollers])])
        add(ext(P), -np.inf, e, "envelope_radius", [f"extent of {r}" for r in rn])

    if kind == "pareto":
        add(t - eps, -np.inf, 0, "epsilon", ["worst |α| ≤ ε"])
    g = ca.vertcat(*rows)
    x = ca.vertcat(z, t)
    opts = {"ipopt": IPOPT_OPTIONS | {"print_level": 0, "max_iter": spec.max_iter, "sb": "yes"}, "print_time": False}
    solver = ca.nlpsol("design", "ipopt", {"x": x, "f": f, "g": g, "p": eps}, opts)
    evaluate = ca.Function("evaluate", [x, eps], [f, g]) if kind == "pareto" else ca.Function("evaluate", [x], [f, g])
    start_t = ca.Function("start_t", [z], [ca.mmax(ca.fabs(alpha_deg))]) if epigraph else None
    return Problem(spec, where, base_file, names, lower, upper, solver, x.shape[0], np.array(lb), np.array(ub),
                   labels, family, evaluate, epigraph, start_t, base_values)


@dataclass
class Solution:
    status: str
    success: bool
    objective: float
    z: np.ndarray
    design: dict
    g: np.ndarray
    lam_g: np.ndarray
    lam_x: np.ndarray
    iterations: int
    start: int


def solve_from(problem: Problem, z0, start_index=0, eps: float = 0.0, warm: Solution | None = None) -> Solution:
    """Solve from normalised design z0 (and, for the Pareto problem, bound ε on worst |α| [deg]);
    `warm` passes a neighbouring solution's multipliers as a warm start."""
    x0 = list(z0)
    if problem.epigraph:
        x0.append(float(problem.start_t(z0)) * 1.05 + 1e-3)
    n = len(problem.names)
    lbx = [0.0] * n + ([0.0] if problem.epigraph else [])
    ubx = [1.0] * n + ([np.inf] if problem.epigraph else [])
    extra = {} if warm is None else {"lam_g0": warm.lam_g}
    sol = problem.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=problem.g_lb, ubg=problem.g_ub, p=eps, **extra)
    st = problem.solver.stats()
    zs = np.asarray(sol["x"]).ravel()[:n]
    values = problem.lower + (problem.upper - problem.lower) * zs
    return Solution(st["return_status"], bool(st["success"]) or st["return_status"] == "Solved_To_Acceptable_Level",
                    float(sol["f"]), zs,
                    dict(zip(problem.names, values.tolist())), np.asarray(sol["g"]).ravel(),
                    np.asarray(sol["lam_g"]).ravel(), np.asarray(sol["lam_x"]).ravel()[:n], int(st["iter_count"]),
                    start_index)


def starts(problem: Problem) -> np.ndarray:
    """The base design first, then a Latin hypercube of the design box."""
    from scipy.stats import qmc

    n = len(problem.names)
    z_base = np.clip((problem.base_values - problem.lower) / (problem.upper - problem.lower), 0, 1)
    k = max(problem.spec.multistart.starts, 1)
    rest = qmc.LatinHypercube(d=n, seed=problem.spec.multistart.seed).random(k - 1) if k > 1 else np.zeros((0, n))
    return np.vstack([z_base[None, :], rest])


def distinct_optima(solutions: list[Solution], tol=1e-3) -> list[tuple[Solution, int]]:
    """Group successful solutions whose designs (normalised) agree within tol: (best of group, count)."""
    groups: list[list[Solution]] = []
    for s in sorted((s for s in solutions if s.success), key=lambda s: s.objective):
        for grp in groups:
            if np.max(np.abs(grp[0].z - s.z)) < tol:
                grp.append(s)
                break
        else:
            groups.append([s])
    return [(grp[0], len(grp)) for grp in groups]


def constraint_report(problem: Problem, sol: Solution) -> list[dict]:
    """Per constraint family, the most binding row: value, bound, slack, multiplier and whether active."""
    rows = []
    for fam in dict.fromkeys(problem.g_family):
        idx = [i for i, f in enumerate(problem.g_family) if f == fam]
        slack = np.minimum(sol.g[idx] - problem.g_lb[idx], problem.g_ub[idx] - sol.g[idx])
        j = idx[int(np.argmin(slack))]
        bound = problem.g_ub[j] if np.isfinite(problem.g_ub[j]) and problem.g_ub[j] - sol.g[j] <= sol.g[j] - problem.g_lb[j] \
            else problem.g_lb[j]
        s = float(np.min(slack))
        lam = float(np.max(np.abs(sol.lam_g[idx])))
        rows.append({"name": fam, "where": problem.g_labels[j], "value": float(sol.g[j]), "bound": float(bound),
                     "slack": s, "multiplier": lam, "active": bool(s <= ACTIVE_TOL * max(1.0, abs(bound)))})
    for i, n in enumerate(problem.names):
        at_lo, at_hi = sol.z[i] < 1e-6, sol.z[i] > 1 - 1e-6
        if at_lo or at_hi:
            rows.append({"name": f"bound {n}", "where": "lower" if at_lo else "upper",
                         "value": sol.design[n], "bound": float(problem.lower[i] if at_lo else problem.upper[i]),
                         "slack": 0.0, "multiplier": float(abs(sol.lam_x[i]) / (problem.upper[i] - problem.lower[i])),
                         "active": True})
    return rows


def write_variant(problem: Problem, sol: Solution, out_dir: Path, name: str | None = None) -> Path:
    """The optimised design as a variant file `compare` reads, with a provenance header
    (name: default '<base variant>_<study>')."""
    from .cli import write_atomic

    data = yaml.safe_load(problem.base_file.read_text())
    for n, v in sol.design.items():
        unit = _unit_of(data["parameters"][n])
        if unit:
            q = registry().Quantity(v, registry().Quantity(1, unit).to_base_units().units).to(unit)
            data["parameters"][n] = f"{q.magnitude:.6g} {unit}"
        else:
            data["parameters"][n] = float(f"{v:.6g}")
    name = name or f"{data['name']}_{problem.spec.name}"
    data["description"] = f"{problem.spec.name} optimum of {data['name']}. " + problem.spec.description
    data["name"] = name
    header = (f"# Optimised by `cvtdesign optimise {problem.study_file}`\n"
              f"# study: {problem.spec.name}; objective: {problem.spec.objective.kind} = {sol.objective:.6g}\n"
              f"# date: {datetime.datetime.now().isoformat(timespec='seconds')}; solver: IPOPT, status "
              f"{sol.status}, {sol.iterations} iterations, start {sol.start}\n"
              f"# base variant: {problem.base_file}\n")
    path = out_dir / f"{name}.yaml"
    write_atomic(path, header + yaml.safe_dump(data, sort_keys=False, allow_unicode=True))
    return path


def run(study_path, out_dir: Path | None = None, n_starts: int | None = None, progress=None) -> dict:
    """Build, multistart-solve and report one study; writes the best design as a variant file."""
    problem = build_problem(study_path)
    if n_starts is not None:
        problem.spec.multistart.starts = n_starts
    zs = starts(problem)
    solutions = []
    for k, z0 in enumerate(zs):
        solutions.append(solve_from(problem, z0, k))
        if progress:
            progress(k + 1, len(zs), solutions[-1])
    optima = distinct_optima(solutions)
    result = {"study": problem.spec.name, "starts": len(zs),
              "statuses": [s.status for s in solutions],
              "optima": [{"objective": s.objective, "design": s.design, "found": n} for s, n in optima]}
    if not optima:
        best = min(solutions, key=lambda s: s.objective)
        result.update(status=best.status, success=False, objective=None, design=best.design,
                      active_constraints=[], constraints=[], variant_file=None)
        return result
    best = optima[0][0]
    report = constraint_report(problem, best)
    out_dir = Path(out_dir or Path("results") / problem.spec.name)
    variant = write_variant(problem, best, out_dir)
    result.update(status=best.status, success=True, objective=best.objective, design=best.design,
                  constraints=report, active_constraints=[r["name"] for r in report if r["active"]],
                  variant_file=str(variant), objective_kind=problem.spec.objective.kind,
                  base_variant=str(problem.base_file), base_design=dict(zip(problem.names, problem.base_values.tolist())))
    return result


def pareto_front(study_path, spec: StudySpec, base_file: Path, fixed: dict | None = None,
                 points: int | None = None) -> list[dict]:
    """Slip/efficiency trade-off by the ε-constraint method: minimise power loss subject to worst |α| ≤ ε,
    ε from the slip optimum's worst |α| to that of the loss optimum, each point warm-started from the last.
    Returns one dict per point: eps, worst_alpha_deg, power_loss_W, design, status, solution."""
    slip = build_problem(study_path, spec, base_file, fixed, objective="worst_alpha")
    loss = build_problem(study_path, spec, base_file, fixed, objective="power_loss")
    front = build_problem(study_path, spec, base_file, fixed, objective="pareto")
    z0 = starts(slip)[0]
    s_slip, s_loss = solve_from(slip, z0), solve_from(loss, z0)
    lo, hi = s_slip.objective, float(slip.start_t(s_loss.z))
    out, prev = [], s_slip
    for k, eps in enumerate(np.linspace(lo, hi, points or spec.pareto.points)):
        sol = solve_from(front, prev.z, k, eps=float(eps))
        worst = float(slip.start_t(sol.z))
        out.append({"index": k, "eps": float(eps), "worst_alpha_deg": worst, "power_loss_W": sol.objective,
                    "design": sol.design, "status": sol.status, "success": sol.success, "solution": sol,
                    "problem": front})
        if sol.success:
            prev = sol
    return out


def knee(front: list[dict]) -> int:
    """Index of the knee: the successful point farthest from the straight line joining the two ends
    (both objectives scaled to [0, 1])."""
    ok = [p for p in front if p["success"]]
    if len(ok) < 3:
        return ok[0]["index"] if ok else 0
    a = np.array([[p["worst_alpha_deg"], p["power_loss_W"]] for p in ok])
    a = (a - a.min(0)) / np.where(np.ptp(a, 0) > 0, np.ptp(a, 0), 1)
    d = np.abs(np.cross(a[-1] - a[0], a - a[0])) / max(np.linalg.norm(a[-1] - a[0]), 1e-12)
    return ok[int(np.argmax(d))]["index"]
