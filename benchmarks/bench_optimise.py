"""Optimisation speed, printed side by side in one run.

1. The box placement-and-radii study (studies/box_placement.yaml: 3 design variables and the epigraph
   variable t, every constraint row at every point of the 17 × 21 envelope) solved from the base design by
   - IPOPT, exact derivatives, over a working set of envelope rows (`solve_from`: the rows near their bound
     at the largest |load| first, every row checked after each solve, violated rows added, solved again);
   - scipy.optimize.minimize, SLSQP with finite-difference gradients, on the same formulation: the same
     variables, bounds, objective and every constraint row, evaluated by the same compiled function, from
     the same start (z0 and t0 = 1.05 · worst |α| + 0.001);
   - IPOPT on every row at once (`method="full"`), to show what the working set buys.
   Both optima are checked against every row. Timings: wall time of the solve only; building the NLP
   (model compilation and the CasADi functions, shared by both methods) is shown separately, and so is the
   one-off construction IPOPT's working-set solvers need on a problem's first solve (a multistart or a
   study case reuses them). Best of several repeats: the machine is shared and noisy.
(Batch studies on 1 and 2 Dask workers: benchmarks/bench_cluster.py.)

Run: python benchmarks/bench_optimise.py
"""
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from cvtdesign.design.problem import build_problem
from cvtdesign.design.solve import rows_at, solve_from, starts
import timing

ROOT = Path(__file__).resolve().parents[1]
REPEATS = 5


def best_of(fn, repeats=REPEATS):
    return timing.best_of(fn, repeats)


def violation(pr, g):
    """Largest violation of any row (0 if every row holds)."""
    return float(np.max(np.maximum(0, np.maximum(g - pr.g_ub, pr.g_lb - g))))


def ipopt_vs_slsqp():
    t = time.perf_counter()
    pr = build_problem(ROOT / "studies/box_placement.yaml")
    t_build = time.perf_counter() - t
    z0 = starts(pr)[0]
    x0 = np.append(z0, float(pr.start_t(z0)) * 1.05 + 1e-3)
    # IPOPT's working set takes t0 from the largest |load| only: the same start if the worst |α| is there
    screen = rows_at(pr, np.append(z0, 0.0), pr.parts.screen)
    assert abs(np.max(np.abs(screen[0])) * 1.05 + 1e-3 - x0[-1]) < 1e-12, "not the same start"

    t = time.perf_counter()
    solve_from(pr, z0)                                      # builds the working-set solvers it needs
    t_ipopt_first = time.perf_counter() - t
    t_ipopt, sol = best_of(lambda: solve_from(pr, z0))
    t_full, full = best_of(lambda: solve_from(pr, z0, method="full"), 1)

    fin_lo, fin_hi = np.isfinite(pr.g_lb), np.isfinite(pr.g_ub)
    calls = {"n": 0}

    def cons(x):
        calls["n"] += 1
        g = np.asarray(pr.evaluate(x)[1]).ravel()
        return np.concatenate([g[fin_lo] - pr.g_lb[fin_lo], pr.g_ub[fin_hi] - g[fin_hi]])

    bounds = [(0, 1)] * len(pr.names) + [(0, None)]

    def slsqp():
        calls["n"] = 0
        return minimize(lambda x: x[-1], x0, method="SLSQP", bounds=bounds,
                        constraints=[{"type": "ineq", "fun": cons}], options={"ftol": 1e-10, "maxiter": 500})

    t = time.perf_counter()
    slsqp()
    t_slsqp_first = time.perf_counter() - t
    t_slsqp, res = best_of(slsqp)

    span = pr.upper - pr.lower
    d_ip, d_sl, d_full = (pr.lower + span * z for z in (sol.z, res.x[:-1], full.z))
    g_sl = np.asarray(pr.evaluate(res.x)[1]).ravel()
    rel = np.max(np.abs(d_ip - d_sl) / np.abs(d_ip))
    print(f"box placement and radii: {len(pr.names)} design variables + t, {len(pr.g_lb)} constraint rows "
          f"({pr.parts.gamma.size} envelope points), from the base design")
    print(f"  NLP construction (model, CasADi functions; shared by both methods) {t_build:6.2f} s")
    print(f"  {'method':44s} {'wall':>8s}  {'objective':>12s}  {'max row violation':>17s}")
    print(f"  {'IPOPT, exact derivatives, working set':44s} {t_ipopt * 1e3:6.0f} ms  {sol.objective:12.8f}  "
          f"{violation(pr, sol.g):17.1e}   {sol.status}, {sol.iterations} it, {sol.rounds} round(s), "
          f"{sol.points} of {pr.parts.gamma.size} points")
    print(f"  {'SLSQP, finite differences, every row':44s} {t_slsqp * 1e3:6.0f} ms  {res.fun:12.8f}  "
          f"{violation(pr, g_sl):17.1e}   {res.message}, {res.nit} it, {calls['n']} evaluations of all rows")
    print(f"  {'IPOPT, exact derivatives, every row':44s} {t_full * 1e3:6.0f} ms  {full.objective:12.8f}  "
          f"{violation(pr, full.g):17.1e}   {full.status}, {full.iterations} it")
    print(f"  first solve on a fresh problem: IPOPT {t_ipopt_first * 1e3:.0f} ms (incl. building its working-set "
          f"solvers), SLSQP {t_slsqp_first * 1e3:.0f} ms")
    print(f"  speed-up IPOPT (working set) over SLSQP: {t_slsqp / t_ipopt:.1f} × (first solves: "
          f"{t_slsqp_first / t_ipopt_first:.1f} ×)   target ≥ 10 ×")
    print(f"  optimum: objective difference {abs(res.fun - sol.objective) / sol.objective:.1e} relative, "
          f"designs {rel:.1e} (largest relative difference)   target ≤ 1e-4")
    for n, a, b, c in zip(pr.names, d_ip, d_sl, d_full):
        print(f"    {n:8s} IPOPT {a:.8g}   SLSQP {b:.8g}   IPOPT every row {c:.8g}")


if __name__ == "__main__":
    ipopt_vs_slsqp()
