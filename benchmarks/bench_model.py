"""Speed of the compiled model, printed as figures and as ratios to baselines run in the same process.

1. box.yaml over its 17 × 21 envelope after compilation: the compiled, mapped CasADi model against a plain
   scipy per-point solve of the same equations (scipy.optimize.root, 'hybr', on the same residual function
   and initial guess; steering angles from the same linkage solve). Both must agree.
2. `cvtdesign compare variants/box.yaml` from a cold start (a new process), against `python -c "import
   casadi"` as the baseline of what merely starting Python with CasADi costs on this machine now.

Run: python benchmarks/bench_model.py   (the machine is shared and noisy: best of several repeats)
"""
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import root

from cvtdesign.core.model import compile_model
from cvtdesign.io.variant import load_variant
from timing import best_of

ROOT = Path(__file__).resolve().parents[1]



def grid_benchmark():
    L = load_variant(ROOT / "variants/box.yaml")
    t = time.perf_counter()
    m = compile_model(L)
    G, T = np.meshgrid(L.gamma_grid, L.load_grid, indexing="ij")
    m.evaluate(G, T)  # first call builds the mapped function
    t_compile = time.perf_counter() - t
    t_casadi, res = best_of(lambda: m.evaluate(G, T), 20)

    phi = res["phi"].ravel()
    th = np.array(m.param_values)

    def scipy_solve():
        alphas = []
        for g, l, p in zip(G.ravel(), T.ravel(), phi):
            params = np.concatenate([[g, L.motor_speed, l, 0.0, p], th])
            sol = root(lambda x: np.asarray(m.residual(x, params)).ravel(), np.asarray(m.initial_guess(params)).ravel(),
                       method="hybr", options={"xtol": 1e-13})
            alphas.append(float(m.outputs(sol.x, params)[5]))
        return np.array(alphas)

    t_scipy, alpha_scipy = best_of(scipy_solve, 2)
    err = np.max(np.abs(alpha_scipy - res["alpha"].ravel()))
    n = G.size
    print(f"box.yaml, {G.shape[0]} × {G.shape[1]} = {n} operating points")
    print(f"  compile + first call          {t_compile * 1e3:8.1f} ms")
    print(f"  compiled CasADi grid          {t_casadi * 1e3:8.1f} ms   ({t_casadi / n * 1e6:.1f} µs/point)   target < 20 ms")
    print(f"  scipy per-point root (hybr)   {t_scipy * 1e3:8.1f} ms")
    print(f"  speed-up                      {t_scipy / t_casadi:8.1f} ×    max |Δα| = {np.degrees(err):.2e} deg")


def cold_start_benchmark():
    exe = Path(sys.executable).parent / "cvtdesign"
    cmd = [str(exe), "compare", "variants/box.yaml", "--out", "/tmp/cvtdesign_bench"]
    run = lambda c: subprocess.run(c, cwd=ROOT, check=True, capture_output=True)
    t_cmp, _ = best_of(lambda: run(cmd), 3)
    t_base, _ = best_of(lambda: run([sys.executable, "-c", "import casadi"]), 3)
    print("cold start")
    print(f"  cvtdesign compare variants/box.yaml   {t_cmp:6.2f} s   target < 3 s")
    print(f"  python -c 'import casadi' (baseline)  {t_base:6.2f} s   ratio {t_cmp / t_base:.1f} ×")
    mods = subprocess.run([sys.executable, "-c", "import sys; from cvtdesign.cli import main; "
                           "main(['compare', 'variants/box.yaml', '--out', '/tmp/cvtdesign_bench']); "
                           "print('cadquery' in sys.modules, file=sys.stderr)"], cwd=ROOT, capture_output=True, text=True)
    print(f"  cadquery imported on this path: {mods.stderr.strip().splitlines()[-1]}")


if __name__ == "__main__":
    grid_benchmark()
    cold_start_benchmark()
