"""Solving a study's NLP: IPOPT from several space-filling starts, over a working set of envelope rows.

The formulation has a row per constraint per envelope point (9415 for the box placement study), but at an
optimum only a handful bind. `solve_from` therefore gives IPOPT a working set of envelope rows, checks
every row of the whole formulation at its solution, adds the violated ones and solves again (see there):
the same optimum as IPOPT on every row at once (`method="full"`), much faster (benchmarks/bench_optimise.py).
Every successful solve is checked on the whole envelope by the numeric model (see solution.py).

`run` is one study: built, solved from the base design and a Latin hypercube of starts (`starts`), the
distinct optima grouped (`distinct_optima`) and the best reported (report.py). `pareto_front` is the
ε-constraint sweep of slip against power loss, `knee` its knee.
"""
from __future__ import annotations

from pathlib import Path
from typing import Literal

import casadi as ca
import numpy as np
from scipy.stats import qmc

from cvtdesign.design.infeasibility import unmet_constraints
from cvtdesign.design.objectives import objective
from cvtdesign.design.optimum_intervals import optimum_intervals
from cvtdesign.design.problem import Problem, build_problem, nlpsol
from cvtdesign.design.report import constraint_report, variant_text, write_variant
from cvtdesign.design.solution import Solution
from cvtdesign.design.study_file import Study

NEAR_BINDING = 0.01  # working set: envelope points with a row within this fraction of its bound's scale
WORKING_SET_MAX = 2_000_000   # entries of the working set's row-selection matrix beyond which every row is used
VIOLATION_TOL = 1e-8  # a row beyond its bound by more than this (× max(1, |bound|)) is violated (IPOPT relaxes
#                      its bounds by bound_relax_factor = 1e-8 the same way)


def _bucket(k: int) -> int:
    """Capacity for k working-set points or rows: a few sizes, so that solvers are reused across rounds
    and starts (padding costs a little evaluation, a new size a new solver)."""
    if k == 0:
        return 0
    size = 1
    while size < k:
        size = size + 1 if size < 4 else int(size * 1.5)
    return size


def _ws_solver(problem: Problem, npoints: int, nrows: int) -> ca.Function:
    """IPOPT on the design rows and `nrows` rows of `npoints` envelope points: the points' (γ, load,
    φ guess) and a 0/1 matrix selecting the rows are parameters, so one solver serves every working set of
    that capacity."""
    key = ("ws", npoints, nrows)
    if key not in problem.solvers:
        pt = problem.parts
        m = pt.pt_lb.size
        data = ca.MX.sym("points", 3 + pt.theta_pts.shape[0], npoints)
        select = ca.MX.sym("select", nrows, m * npoints)
        g = pt.g_design
        if npoints and nrows:
            rows = pt.point_rows.map(npoints, "serial").call([pt.x, data[0, :], data[1, :], data[2, :], pt.P0,
                                                              data[3:, :]])[0]
            g = ca.vertcat(g, ca.mtimes(select, ca.vec(rows)))
        problem.solvers[key] = nlpsol(pt.x, pt.f, g, ca.vertcat(pt.eps, ca.vec(data), ca.vec(select)),
                                       problem.spec.max_iter)
    return problem.solvers[key]


def rows_at(problem: Problem, x, points) -> np.ndarray:
    """The point rows (m × len(points)) at x for the given envelope points."""
    pt = problem.parts
    key = ("rows", len(points))
    if key not in problem.solvers:
        data = ca.MX.sym("points", 3 + pt.theta_pts.shape[0], len(points))
        rows = pt.point_rows.map(len(points), "serial").call([pt.x, data[0, :], data[1, :], data[2, :], pt.P0,
                                                              data[3:, :]])[0]
        problem.solvers[key] = ca.Function("rows_at", [pt.x, data], [rows])
    data = point_data(pt, points)
    return np.asarray(problem.solvers[key](x, data)).reshape(-1, len(points), order="F")


def point_data(pt, points) -> np.ndarray:
    """The point rows' inputs at these envelope points: γ, load, φ guess and the model's θ, one column each."""
    return np.vstack([pt.gamma[points], pt.load[points], pt.phi0[points], pt.theta_pts[:, points]])


def _near_binding(problem: Problem, g: np.ndarray, t: float, rows=None) -> np.ndarray:
    """Mask over g (or over the full rows listed in `rows`): point rows within NEAR_BINDING of their bound's
    scale, or beyond it (the epigraph rows α ∓ t: within NEAR_BINDING·t of t)."""
    pt = problem.parts
    rows = np.arange(problem.g_lb.size) if rows is None else rows
    scale = np.where(np.isnan(pt.row_scale[rows]), max(abs(t), 1e-6), pt.row_scale[rows])
    with np.errstate(invalid="ignore"):
        slack = np.minimum(problem.g_ub[rows] - g, g - problem.g_lb[rows])
    return (pt.row_k[rows] >= 0) & (slack <= NEAR_BINDING * scale)


def solve_from(problem: Problem, z0, start_index=0, eps: float = 0.0, warm: Solution | None = None,
               method: Literal["working_set", "full"] = "working_set") -> Solution:
    """Solve from normalised design z0 (and, for the Pareto problem, bound ε on worst |α| [deg]);
    `warm` passes a neighbouring solution's multipliers as a warm start.

    method 'working_set': IPOPT on the objective, the design rows and a working set of envelope rows only,
    an active-set / cutting-plane scheme. The first working set: the rows near their bound at the
    envelope's largest |load| (where slip, forces and pressures peak; near: within NEAR_BINDING of the
    bound's scale, the epigraph rows within NEAR_BINDING·t of the worst |α|). After each solve every row of
    the whole formulation is evaluated; the violated rows (with the rows now near their bound) join the
    set and IPOPT solves again from there, until no row anywhere is violated by more than VIOLATION_TOL.
    The result is then an optimum of the whole formulation (the rows left out are inactive: multiplier 0);
    g and lam_g are returned for every row. 'full': IPOPT on every row at once."""
    pt = problem.parts
    z0 = np.asarray(z0, float)
    lam_full = None if warm is None else warm.lam_g
    if method == "full":
        x0 = list(z0) + ([float(problem.start_t(z0)) * 1.05 + 1e-3] if problem.epigraph else [])
        return _every_row(problem, x0, lam_full, eps, start_index)
    work, x0 = _first_working_set(problem, z0)
    iters, rounds, history = 0, 0, []
    while True:
        rounds += 1
        points = np.unique(pt.row_k[work])
        if _bucket(work.size) * pt.pt_lb.size * _bucket(points.size) > WORKING_SET_MAX:
            # most rows bind somewhere: every row at once is cheaper
            return _every_row(problem, x0, lam_full, eps, start_index, iters, rounds - 1, history)
        sol, st, lam = _working_set_solve(problem, work, points, x0, lam_full, eps)
        iters += int(st["iter_count"])
        history += iterations(st, rounds)
        xs = np.asarray(sol["x"]).ravel()
        g, at_seeds = problem.rows_and_points(xs, eps)
        ok = bool(st["success"]) or st["return_status"] == "Solved_To_Acceptable_Level"
        violated = _violated(problem, g, work)
        if not ok or not violated.any():
            out = _solution(problem, sol, st, g, lam, iters, start_index, rounds, points.size, at_seeds)
            out.history = history
            return out
        # the violated rows join, with every row now near its bound; solve again from here
        near = _near_binding(problem, g, xs[-1] if problem.epigraph else 0.0)
        work = np.union1d(work, np.flatnonzero(violated | near))
        x0, lam_full = xs, lam


def _box(problem: Problem) -> tuple[list, list]:
    """Bounds of x = (z, t): z ∈ [0, 1], t ≥ 0."""
    n = len(problem.names)
    return [0.0] * n + ([0.0] if problem.epigraph else []), [1.0] * n + ([np.inf] if problem.epigraph else [])


def _every_row(problem: Problem, x0, lam, eps: float, start_index: int, iters: int = 0, rounds: int = 0,
               history: list | None = None) -> Solution:
    """IPOPT on every row at once from x0 (lam: multipliers of every row as a warm start, or None); iters,
    rounds and history count the working-set solves before it."""
    lbx, ubx = _box(problem)
    extra = {} if lam is None else {"lam_g0": lam}
    sol = problem.solver(x0=x0, lbx=lbx, ubx=ubx, lbg=problem.g_lb, ubg=problem.g_ub, p=eps, **extra)
    st = problem.solver.stats()
    out = _solution(problem, sol, st, np.asarray(sol["g"]).ravel(), np.asarray(sol["lam_g"]).ravel(),
                    iters + int(st["iter_count"]), start_index, rounds + 1, problem.parts.gamma.size)
    out.history = (history or []) + iterations(st, rounds + 1)
    return out


def iterations(stats: dict, round_: int) -> list[tuple[int, float, float]]:
    """IPOPT's iterations from its stats: (working-set round, objective, primal infeasibility) each."""
    it = stats.get("iterations") or {}
    return [(round_, float(o), float(p)) for o, p in zip(it.get("obj", []), it.get("inf_pr", []))]


def _first_working_set(problem: Problem, z0: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(rows of g, x0): the rows near their bound at the envelope's largest |load|, and the start with t0
    = 1.05 · the worst |α| there + 0.001 [deg] for epigraph objectives."""
    pt = problem.parts
    rows = rows_at(problem, np.append(z0, 0.0) if problem.epigraph else z0, pt.screen)
    t0 = worst = 0.0
    if problem.epigraph:
        worst = float(np.max(np.abs(rows[0])))                # rows[0] = α − t at t = 0
        rows[:2] -= worst                                       # the epigraph rows at t = worst |α|
        t0 = worst * 1.05 + 1e-3
    full = np.array([[pt.pt_index[r] + k if r != pt.misfit_row else pt.reach_index[pt.gamma_of[k]]
                      for k in pt.screen] for r in range(pt.pt_lb.size)], int)
    work = np.unique(full[_near_binding(problem, rows.ravel(), worst, full.ravel()).reshape(full.shape)])
    return work, (np.append(z0, t0) if problem.epigraph else z0)


def _working_set_solve(problem: Problem, work: np.ndarray, points: np.ndarray, x0, lam_full, eps: float) -> tuple:
    """IPOPT on the design rows and the rows `work` of g (at the envelope points `points`), from x0 with
    lam_full (multipliers of every row, or None) as a warm start: (IPOPT's result, its stats, the
    multipliers of every row, 0 for those left out)."""
    pt = problem.parts
    m, nd = pt.pt_lb.size, pt.design_index.size
    npoints, nrows = _bucket(points.size), _bucket(work.size)
    slots = np.concatenate([points, np.full(npoints - points.size, points[0] if points.size else 0, int)])
    select = np.zeros((nrows, m * npoints))
    select[np.arange(work.size), np.searchsorted(points, pt.row_k[work]) * m + pt.row_r[work]] = 1
    pad = nrows - work.size
    lbg = np.concatenate([problem.g_lb[pt.design_index], problem.g_lb[work], np.full(pad, -np.inf)])
    ubg = np.concatenate([problem.g_ub[pt.design_index], problem.g_ub[work], np.full(pad, np.inf)])
    data = point_data(pt, slots)
    extra = {} if lam_full is None else \
        {"lam_g0": np.concatenate([lam_full[pt.design_index], lam_full[work], np.zeros(pad)])}
    solver = _ws_solver(problem, npoints, nrows)
    lbx, ubx = _box(problem)
    sol = solver(x0=x0, lbx=lbx, ubx=ubx, lbg=lbg, ubg=ubg,
                 p=np.concatenate([[eps], data.ravel(order="F"), select.ravel(order="F")]), **extra)
    lam_ws = np.asarray(sol["lam_g"]).ravel()
    lam = np.zeros(problem.g_lb.size)
    lam[pt.design_index] = lam_ws[:nd]
    lam[work] = lam_ws[nd: nd + work.size]
    return sol, solver.stats(), lam


def _violated(problem: Problem, g: np.ndarray, work: np.ndarray) -> np.ndarray:
    """Mask over g: the envelope rows outside the working set `work` beyond their bound by more than
    VIOLATION_TOL × max(1, |bound|)."""
    tol = VIOLATION_TOL * np.maximum(1.0, np.minimum(np.abs(problem.g_lb), np.abs(problem.g_ub)))
    violated = (g > problem.g_ub + tol) | (g < problem.g_lb - tol)
    violated[work] = False
    violated[problem.parts.design_index] = False
    return violated


def _solution(problem, sol, st, g, lam_g, iterations, start_index, rounds, points, at_seeds=None) -> Solution:
    """The Solution of an IPOPT run; a successful one is checked on the whole envelope by the model at the
    optimum (Problem.check; `at_seeds`: its points from Problem.rows_and_points, if evaluated already) and
    reported as failed ('Failed_Envelope_Check') if any point is outside the physics."""
    n = len(problem.names)
    zs = np.asarray(sol["x"]).ravel()[:n]
    values = problem.lower + (problem.upper - problem.lower) * zs
    design = dict(zip(problem.names, values.tolist()))
    status = st["return_status"]
    success = bool(st["success"]) or status == "Solved_To_Acceptable_Level"
    check = None
    if success:
        check = problem.check(design, at_seeds)
        if not check.ok:
            success, status = False, f"Failed_Envelope_Check: {check.summary()}"
    return Solution(status, success, float(sol["f"]), zs, design, g, lam_g,
                    np.asarray(sol["lam_x"]).ravel()[:n], iterations, start_index, rounds, points, check,
                    st["return_status"])




def starts(problem: Problem) -> np.ndarray:
    """The base design first, then a Latin hypercube of the design box."""
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


def run(study: Study, out_dir: Path | None = None, n_starts: int | None = None, progress=None,
        write: bool = True, calibration=None) -> dict:
    """Build, multistart-solve and report one study (study_file.load_study); writes the best design as a
    variant file (with `write` False it is not written: result['pending_files'] = {path: text}, for the
    caller to write together with its own files). `calibration`: a diagnosis report whose fitted effect
    parameters the base variant carries (overrides the study's `calibration`)."""
    spec = study.spec.model_copy(deep=True)          # the caller's study stays as it was read
    study = Study(study.path, spec, study.base)
    if calibration is not None:
        spec.calibration = str(Path(calibration).resolve())
    if n_starts is not None:
        spec.multistart.starts = n_starts
    if objective(spec.objective.kind).solves(spec.multistart.starts, False)[1]:   # the front; its knee the optimum
        problem, solutions, front = _front_knee(study, progress)
        optima = [(solutions[0], 1)] if solutions[0].success else []
    else:
        (problem, solutions), front = _multistart(study, progress), None
        optima = distinct_optima(solutions)
    result = {"study": problem.spec.name, "starts": len(solutions),
              "statuses": [s.status for s in solutions],
              "optima": [{"objective": s.objective, "design": s.design, "found": n} for s, n in optima]}
    if front is not None:
        result["front"] = [{k: p[k] for k in ("eps", "worst_alpha_deg", "power_loss_W", "design", "status")}
                           for p in front]
    result["envelope_checks"] = [s.check.as_dict() if s.check else None for s in solutions]
    if not write:
        result["pending_files"] = {}
    if not optima:
        # no start passed IPOPT and the envelope check: report the best failure, write no variant
        best = min(solutions, key=lambda s: s.objective)
        result.update(status=best.status, success=False, objective=None, design=best.design,
                      active_constraints=[], constraints=[], variant_file=None,
                      envelope_check=best.check.as_dict() if best.check else None,
                      unmet_constraints=[] if best.check else strip(unmet_constraints(problem, starts(problem))))
        return result
    best = optima[0][0]
    report = constraint_report(problem, best)
    out_dir = Path(out_dir or Path("results") / problem.spec.name)
    if write:
        variant = write_variant(problem, best, out_dir)
    else:
        variant, text = variant_text(problem, best, out_dir)
        result["pending_files"][variant] = text
    base_design = dict(zip(problem.names, problem.base_values.tolist()))
    result.update(status=best.status, success=True, objective=best.objective, design=best.design,
                  envelope_check=best.check.as_dict(), base_envelope_check=problem.check(base_design).as_dict(),
                  history=[{"round": r, "objective": o, "infeasibility": f} for r, o, f in best.history],
                  start_objectives=[s.objective if s.success else None for s in solutions],
                  constraints=report, active_constraints=[r["name"] for r in report if r["active"]],
                  variant_file=str(variant), objective_kind=problem.spec.objective.kind,
                  base_variant=str(problem.base_file), base_design=base_design)
    result["intervals"] = optimum_intervals(problem, best.design)
    if problem.spec.robust is not None:     # the worst case over the region, and the same design at its middle
        result["robust"] = {"confidence": problem.spec.robust.confidence, "corners": problem.parts.nlp.scenarios,
                            "worst_alpha_deg": best.objective,
                            "nominal_worst_alpha_deg": problem.nominal_worst_alpha(best.design)}
    return result


def strip(unmet: list[dict]) -> list[dict]:
    """The unmet constraints as the JSON gives them (without the sort key)."""
    return [{k: v for k, v in u.items() if k != "miss"} for u in unmet]


def _multistart(study: Study, progress) -> tuple[Problem, list[Solution]]:
    """The study's problem solved from each of its starts."""
    problem = build_problem(study)
    zs = starts(problem)
    solutions = []
    for k, z0 in enumerate(zs):
        solutions.append(solve_from(problem, z0, k))
        if progress:
            progress(k + 1, len(zs), solutions[-1])
    return problem, solutions


def _front_knee(study: Study, progress) -> tuple[Problem, list[Solution], list]:
    """A `pareto` study: the front (pareto_front), its knee's solution first (the optimum reported), then the
    other points' (the front's ε-constraint problem)."""
    front = pareto_front(study)
    k = knee(front)
    order = [k] + [i for i in range(len(front)) if i != k]
    if progress:
        progress(len(front), len(front), front[k]["solution"])
    return front[k]["problem"], [front[i]["solution"] for i in order], front


def pareto_front(study: Study, fixed: dict | None = None, points: int | None = None) -> list[dict]:
    """Slip/efficiency trade-off by the ε-constraint method: minimise power loss subject to worst |α| ≤ ε,
    ε from the slip optimum's worst |α| to that of the loss optimum, each point warm-started from the last.
    Returns one dict per point: eps, worst_alpha_deg, power_loss_W, design, status, solution."""
    slip = build_problem(study, fixed, kind="worst_alpha")
    loss = build_problem(study, fixed, kind="power_loss")
    front = build_problem(study, fixed, kind="pareto")
    z0 = starts(slip)[0]
    s_slip, s_loss = solve_from(slip, z0), solve_from(loss, z0)
    lo, hi = s_slip.objective, float(slip.start_t(s_loss.z))
    out, prev = [], s_slip
    for k, eps in enumerate(np.linspace(lo, hi, points or study.spec.pareto.points)):
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
    (ux, uy), v = a[-1] - a[0], a - a[0]
    d = np.abs(ux * v[:, 1] - uy * v[:, 0]) / max(np.hypot(ux, uy), 1e-12)     # |u × v| / |u|
    return ok[int(np.argmax(d))]["index"]
