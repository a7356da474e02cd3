"""Optimisation speed, printed side by side in one run.

1. The box placement-and-radii study (studies/box_placement.yaml, 17 × 21 envelope) solved by IPOPT with
   the model's exact derivatives, against scipy.optimize.minimize (SLSQP, finite-difference gradients) on
   the same formulation (same variables, objective and constraints, evaluated by the same compiled
   functions) from the same start: both optima and the wall-time ratio.
2. A 16-case study on a Dask LocalCluster with 2 workers against 1 worker.

Run: python benchmarks/bench_optimise.py
"""
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from scipy.optimize import minimize

from cvtdesign.optimise import build_problem, solve_from, starts
from cvtdesign.study import run_study

ROOT = Path(__file__).resolve().parents[1]


def ipopt_vs_slsqp():
    pr = build_problem(ROOT / "studies/box_placement.yaml")
    z0 = starts(pr)[0]
    t = time.perf_counter()
    sol = solve_from(pr, z0)
    t_ipopt = time.perf_counter() - t

    x0 = np.append(z0, float(pr.start_t(z0)) * 1.05 + 1e-3)
    fin_lo, fin_hi = np.isfinite(pr.g_lb), np.isfinite(pr.g_ub)
    calls = {"n": 0}

    def g(x):
        calls["n"] += 1
        return np.asarray(pr.evaluate(x)[1]).ravel()

    cons = [{"type": "ineq", "fun": lambda x: np.concatenate([g(x)[fin_lo] - pr.g_lb[fin_lo], pr.g_ub[fin_hi] - g(x)[fin_hi]])}]
    bounds = [(0, 1)] * len(pr.names) + [(0, None)]
    t = time.perf_counter()
    res = minimize(lambda x: x[-1], x0, method="SLSQP", bounds=bounds, constraints=cons,
                   options={"ftol": 1e-10, "maxiter": 500})
    t_slsqp = time.perf_counter() - t
    z_s = res.x[:-1]
    d_ip = pr.lower + (pr.upper - pr.lower) * sol.z
    d_sl = pr.lower + (pr.upper - pr.lower) * z_s
    rel = np.max(np.abs(d_ip - d_sl) / np.abs(d_ip))
    print(f"box placement and radii ({len(pr.names)} variables, {len(pr.g_lb)} constraints, 17 × 21 envelope)")
    print(f"  IPOPT, exact derivatives     {t_ipopt:7.2f} s   objective {sol.objective:.8f}   {sol.status}, {sol.iterations} it")
    print(f"  SLSQP, finite differences    {t_slsqp:7.2f} s   objective {res.fun:.8f}   {res.message}, {res.nit} it, {calls['n']} constraint evaluations")
    print(f"  speed-up {t_slsqp / t_ipopt:.1f} ×   optimum: max relative design difference {rel:.1e}, "
          f"objective difference {abs(res.fun - sol.objective) / sol.objective:.1e}")
    for n, a, b in zip(pr.names, d_ip, d_sl):
        print(f"    {n:8s} IPOPT {a:.8g}   SLSQP {b:.8g}")


def scaling():
    data = yaml.safe_load((ROOT / "studies/box_placement.yaml").read_text())
    data["base"] = str(ROOT / "variants/box.yaml")
    data["multistart"] = {"starts": 8, "seed": 3}
    data["batch"] = {"sweep": {"preload": ["80 N", "120 N"]}}     # 2 × 8 = 16 cases
    data["envelope"] = {"gamma": {"start": "-80 deg", "stop": "80 deg", "step": "20 deg"},
                        "load": {"start": "-1 N*m", "stop": "1 N*m", "step": "0.5 N*m"}}
    with tempfile.TemporaryDirectory() as tmp:
        study = Path(tmp) / "scaling.yaml"
        study.write_text(yaml.safe_dump(data, allow_unicode=True))
        times = {}
        for w in (1, 2):
            t = time.perf_counter()
            res = run_study(study, Path(tmp) / f"w{w}", workers=w)
            times[w] = time.perf_counter() - t
            ok = res["table"]["success"].sum()
            print(f"16-case study, {w} worker(s): {times[w]:6.1f} s ({ok}/16 succeeded)")
        print(f"  speed-up on 2 workers: {times[1] / times[2]:.2f} ×   target ≥ 1.7 ×")


if __name__ == "__main__":
    ipopt_vs_slsqp()
    scaling()
