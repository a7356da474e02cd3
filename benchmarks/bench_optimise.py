"""Optimisation speed, printed side by side in one run: the goals of issue 12 are IPOPT's first solve on a
fresh problem ≥ 10× faster than SLSQP with finite differences, and its later solves ≥ 20×.

The box placement-and-radii study (studies/box_placement_kim.yaml: 3 design variables and the epigraph variable
t, every constraint row at every point of the 17 × 21 envelope), solved from the base design by
 - IPOPT, exact derivatives, over a working set of envelope rows (`solve_from`: the rows near their bound at
   the largest |load| first, every row evaluated after each solve, violated rows added, solved again);
 - scipy.optimize.minimize, SLSQP with finite-difference gradients, on the same formulation: the same
   variables, bounds, objective and every constraint row, evaluated by the same CasADi function
   (`Problem.evaluate`), from the same start (z0 and t0 = 1.05 · worst |α| + 0.001);
 - IPOPT on every row at once (`method="full"`), to show what the working set buys.

What each time includes (wall time, best of REPEATS, the two methods alternating so that both see the same
load on this shared machine):
 - IPOPT: `solve_from` whole: the first screening, every round (IPOPT, then every row at every envelope
   point) and the envelope check of the optimum.
 - SLSQP: `minimize` and the same envelope check of its optimum (`Problem.check`). The check is in both
   because a design is only ever reported after it: the tool never hands out an optimum that was not
   checked on the whole envelope, so the comparison is the time to a checked optimum. The check's own time
   is printed beside SLSQP's, so SLSQP unchecked can be read off.
 - Not in either: building the NLP (the model compiled with the design as symbols, the CasADi functions;
   shared by both, printed separately), and loading libraries once a process: scipy.optimize is imported
   before anything is timed, and IPOPT's plugin is loaded as a study worker loads it at start-up
   (`study.warm_worker`, its time printed).
 - First solve on a fresh problem: IPOPT's includes building its working-set solvers and the derivatives
   they need (later solves and starts of the same problem reuse them); SLSQP's its first call.
The ceiling: every IPOPT solve ends with one evaluation of every row (to find violated rows and to give the
check its per-point outputs) and the check; SLSQP pays that evaluation at each of its ~31 calls. Their ratio,
printed last, is the speed-up IPOPT would reach if its working-set solve, seed scan and screening took no
time: under fair terms (both methods evaluating rows by the same function) no solver change can exceed it.
(Batch studies on 1 and 2 Dask workers: benchmarks/bench_cluster.py.)

Run: python benchmarks/bench_optimise.py
"""
import os
import time
from pathlib import Path

import numpy as np
from scipy.optimize import minimize

from cvtdesign.design.problem import build_problem
from cvtdesign.design.solve import rows_at, solve_from, starts
from cvtdesign.design.study import warm_worker
from cvtdesign.design.study_file import load_study

ROOT = Path(__file__).resolve().parents[1]
REPEATS = 5


def violation(pr, g):
    """Largest violation of any row (0 if every row holds)."""
    return float(np.max(np.maximum(0, np.maximum(g - pr.g_ub, pr.g_lb - g))))


def timed(fn):
    t = time.perf_counter()
    out = fn()
    return time.perf_counter() - t, out


def slsqp_solver(pr, x0):
    """SLSQP with finite differences on every row, from x0: a function returning (result, its design, the
    envelope check of that design, the check's time [s]), and the count of row evaluations."""
    fin_lo, fin_hi = np.isfinite(pr.g_lb), np.isfinite(pr.g_ub)
    calls = {"n": 0}
    bounds = [(0, 1)] * len(pr.names) + [(0, None)]

    def cons(x):
        calls["n"] += 1
        g = np.asarray(pr.evaluate(x)[1]).ravel()
        return np.concatenate([g[fin_lo] - pr.g_lb[fin_lo], pr.g_ub[fin_hi] - g[fin_hi]])

    def solve():
        calls["n"] = 0
        res = minimize(lambda x: x[-1], x0, method="SLSQP", bounds=bounds,
                       constraints=[{"type": "ineq", "fun": cons}], options={"ftol": 1e-10, "maxiter": 500})
        design = dict(zip(pr.names, (pr.lower + (pr.upper - pr.lower) * res.x[:-1]).tolist()))
        t_check, check = timed(lambda: pr.check(design))
        return res, design, check, t_check
    return solve, calls


def floor(pr, sol) -> float:
    """Best-of-REPEATS wall time [s] of what every IPOPT solve does besides IPOPT: one evaluation of every row
    at the optimum (`Problem.rows_and_points`, which also gives the check's per-point outputs) and the
    envelope check on them. SLSQP needs the same evaluation at each of its function calls."""
    x = np.append(sol.z, sol.objective) if pr.epigraph else sol.z

    def once():
        g, at_seeds = pr.rows_and_points(x)
        return pr.check(sol.design, at_seeds)
    return min(timed(once)[0] for _ in range(REPEATS))


def ipopt_vs_slsqp():
    load0 = os.getloadavg()
    t_warm, _ = timed(warm_worker)
    t_build, pr = timed(lambda: build_problem(load_study(ROOT / "studies/box_placement_kim.yaml")))
    z0 = starts(pr)[0]
    x0 = np.append(z0, float(pr.start_t(z0)) * 1.05 + 1e-3)
    # IPOPT's working set takes t0 from the largest |load| only: the same start if the worst |α| is there
    screen = rows_at(pr, np.append(z0, 0.0), pr.parts.screen)
    assert abs(np.max(np.abs(screen[0])) * 1.05 + 1e-3 - x0[-1]) < 1e-12, "not the same start"
    slsqp, calls = slsqp_solver(pr, x0)

    t_ipopt_first, _ = timed(lambda: solve_from(pr, z0))       # builds the working-set solvers it needs
    t_slsqp_first, _ = timed(slsqp)
    t_ipopt, t_slsqp = [], []
    for _ in range(REPEATS):
        t, sol = timed(lambda: solve_from(pr, z0))
        t_ipopt.append(t)
        t, (res, d_sl, chk_sl, t_check) = timed(slsqp)
        t_slsqp.append(t)
    t_ipopt, t_slsqp = min(t_ipopt), min(t_slsqp)
    t_floor = floor(pr, sol)
    t_full, full = timed(lambda: solve_from(pr, z0, method="full"))
    load1 = os.getloadavg()

    span = pr.upper - pr.lower
    d_ip, d_full = (pr.lower + span * z for z in (sol.z, full.z))
    d_sl = np.array([d_sl[n] for n in pr.names])
    g_sl = np.asarray(pr.evaluate(res.x)[1]).ravel()
    rel = np.max(np.abs(d_ip - d_sl) / np.abs(d_ip))
    print(f"load average {load0[0]:.2f} before, {load1[0]:.2f} after; best of {REPEATS}, alternating")
    print(f"box placement and radii: {len(pr.names)} design variables + t, {len(pr.g_lb)} constraint rows "
          f"({pr.parts.gamma.size} envelope points), from the base design")
    print(f"  NLP construction (model, CasADi functions; shared by both methods) {t_build:6.2f} s; "
          f"IPOPT's plugin, loaded once a process {t_warm * 1e3:.0f} ms")
    print(f"  {'method (each with the envelope check of its optimum)':52s} {'wall':>8s}  {'objective':>12s}  "
          f"{'max row violation':>17s}")
    print(f"  {'IPOPT, exact derivatives, working set':52s} {t_ipopt * 1e3:6.1f} ms  {sol.objective:12.8f}  "
          f"{violation(pr, sol.g):17.1e}   {sol.status}, {sol.iterations} it, {sol.rounds} round(s), "
          f"{sol.points} of {pr.parts.gamma.size} points; check: {sol.check.summary()}")
    print(f"  {'SLSQP, finite differences, every row':52s} {t_slsqp * 1e3:6.1f} ms  {res.fun:12.8f}  "
          f"{violation(pr, g_sl):17.1e}   {res.message}, {res.nit} it, {calls['n']} evaluations of all rows; "
          f"its check {t_check * 1e3:.1f} ms: {chk_sl.summary()}")
    print(f"  {'IPOPT, exact derivatives, every row (one run)':52s} {t_full * 1e3:6.0f} ms  {full.objective:12.8f}  "
          f"{violation(pr, full.g):17.1e}   {full.status}, {full.iterations} it")
    print(f"  first solve on a fresh problem: IPOPT {t_ipopt_first * 1e3:.1f} ms (incl. building its working-set "
          f"solvers), SLSQP {t_slsqp_first * 1e3:.1f} ms")
    print(f"  speed-up of IPOPT (working set) over SLSQP: first solve {t_slsqp_first / t_ipopt_first:.1f} × "
          f"(goal ≥ 10 ×), later solves {t_slsqp / t_ipopt:.1f} × (goal ≥ 20 ×)")
    print(f"  what no IPOPT solve can skip: one evaluation of every row (with the check's outputs) and the check "
          f"{t_floor * 1e3:.1f} ms; the speed-up over SLSQP if the working-set solve, seed scan and screening took no "
          f"time: {t_slsqp / t_floor:.1f} ×")
    print(f"  optimum: objective difference {abs(res.fun - sol.objective) / sol.objective:.1e} relative, "
          f"designs {rel:.1e} (largest relative difference)   target ≤ 1e-4")
    for n, a, b, c in zip(pr.names, d_ip, d_sl, d_full):
        print(f"    {n:8s} IPOPT {a:.12g}   SLSQP {b:.8g}   IPOPT every row {c:.10g}")
    print(f"    objective IPOPT {sol.objective:.12g}")


if __name__ == "__main__":
    ipopt_vs_slsqp()
