"""Speed of the compiled model, printed as figures and as ratios to baselines run in the same process.

1. box.yaml over a 161 × 201 envelope (γ and τ⊥ over the variant's ranges): the model compiled to C (what
   `evaluate` runs once the library is in the cache), and interpreted, against a numpy baseline run in the
   same process: np.linalg.solve on a stack of 3 well-conditioned random 24 × 24 systems a point (a Newton
   solve of the box's 24 unknowns takes about that much linear algebra). Goal: the compiled model within
   1.5 × the baseline. Also the one-off compile and the load of the cached library on a later run.
2. `cvtdesign compare variants/box.yaml` from a cold start (a new process), against `python -c "import
   casadi"` as the baseline of what merely starting Python with CasADi costs on this machine now.

Run: python benchmarks/bench_model.py   (the machine is shared and noisy: best of several repeats)
"""
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from cvtdesign.core.model import compile_model
from cvtdesign.core.native import FLAGS
from cvtdesign.io.variant import load_variant
from timing import best_of

ROOT = Path(__file__).resolve().parents[1]



def grid_benchmark(repeats: int = 5, goal: float = 1.5):
    L = load_variant(ROOT / "variants/box.yaml")
    G, T = np.meshgrid(np.linspace(L.gamma_grid.min(), L.gamma_grid.max(), 161),
                       np.linspace(L.load_grid.min(), L.load_grid.max(), 201), indexing="ij")
    n = G.size
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as cache:
        os.environ["CVTDESIGN_CACHE"] = cache                   # an empty cache: the first compile is timed
        model = compile_model(L)
        t_compile, _ = best_of(model.native_point, 1)           # generate C, compile, load
        t_load, _ = best_of(model.native_point, 3)              # a later run: generate C, find it cached, load
        models = {}
        for what, policy in (("compiled", "always"), ("interpreted", "never")):
            os.environ["CVTDESIGN_COMPILE"] = policy            # read by evaluate at each call
            models[what] = compile_model(L)
            models[what].evaluate(G, T)                         # loads the library, builds the thread map
        rng = np.random.default_rng(0)
        A = rng.standard_normal((3 * n, 24, 24)) + 24 * np.eye(24)   # diagonally dominant: well conditioned
        b = rng.standard_normal((3 * n, 24, 1))
        best, res = {}, {}
        for _ in range(repeats):                                # interleaved: the load changes for all alike
            for what in ("compiled", "numpy", "interpreted"):
                os.environ["CVTDESIGN_COMPILE"] = "always" if what == "compiled" else "never"
                t, res[what] = best_of((lambda: np.linalg.solve(A, b)) if what == "numpy" else
                                       (lambda: models[what].evaluate(G, T)), 1)
                best[what] = min(best.get(what, np.inf), t)
        del os.environ["CVTDESIGN_COMPILE"], os.environ["CVTDESIGN_CACHE"]
    a, c = res["compiled"], res["interpreted"]
    same = np.array_equal(a["status"], c["status"]) and np.allclose(a["alpha"], c["alpha"], rtol=1e-10, atol=1e-14, equal_nan=True)
    ratio = best["compiled"] / best["numpy"]
    us = {k: v / n * 1e6 for k, v in best.items()}
    print(f"box.yaml, {G.shape[0]} × {G.shape[1]} = {n} operating points (best of {repeats}, interleaved; "
          f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after)")
    print(f"  numpy baseline, 3 × 24×24 solves a point     {us['numpy']:6.2f} µs/point")
    print(f"  model, compiled (evaluate)                   {us['compiled']:6.2f} µs/point   {ratio:4.2f} × the baseline   "
          f"goal ≤ {goal:g} ×: {'met' if ratio <= goal else 'not met'}")
    print(f"  model, interpreted (CVTDESIGN_COMPILE=never) {us['interpreted']:6.2f} µs/point "
          f"{best['interpreted'] / best['numpy']:4.2f} × the baseline")
    print(f"  compiled and interpreted agree (status, α to 1e-10): {same}")
    print(f"  one-off compile (generate C, cc {' '.join(FLAGS)}, load) {t_compile:5.2f} s;   "
          f"later runs, from the cache (generate C, hash, load) {t_load * 1e3:5.0f} ms")


COLD_PROFILE = """
import cProfile, json, pstats, sys, time
t0 = time.perf_counter()
profile = cProfile.Profile()
profile.enable()
import cvtdesign.cli.compare
t_import = time.perf_counter() - t0
from cvtdesign.cli import main
from cvtdesign.io import plots
sent = []
draw = plots.Background.draw
plots.Background.draw = lambda self, *job: (sent.append(job), draw(self, *job))[1]
main(["compare", "variants/box.yaml", "--out", sys.argv[1]])
profile.disable()
total = time.perf_counter() - t0
t = time.perf_counter()
plots._mpl()                      # what the plotting process does, again here, unprofiled
t_mpl = time.perf_counter() - t
t = time.perf_counter()
getattr(plots, sent[0][0])(*sent[0][1:])
t_draw = time.perf_counter() - t

def entry(targets, callers=None):
    # cumulative time of the calls into the modules `targets` from `callers` (None: from any other module)
    inside = lambda f: any(t in f[0] for t in targets)
    return sum(ct for f, (_, _, _, _, by) in pstats.Stats(profile).stats.items() if inside(f)
               for c, (_, _, _, ct) in by.items() if (not inside(c) if callers is None else any(k in c[0] for k in callers)))

print(json.dumps({"total": total, "import of cvtdesign (the compare command's modules)": t_import,
                  "reading and validating the YAML (io.yaml_file, io.schema)": entry(["io/yaml_file.py"], ["io/variant.py"]),
                  "unit parsing (io.units)": entry(["io/units.py"]),
                  "geometric checks (core.checks)": entry(["core/checks.py"], ["io/variant.py"]),
                  "evaluation (compile, envelope, metrics)": entry(["core/model.py", "core/metrics.py"], ["cli/compare.py"]),
                  "plotting (waiting for the plotting process)": entry(["io/plots.py"], ["cli/compare.py"]),
                  "painter": {"importing matplotlib": t_mpl, "drawing and writing the figure": t_draw}}))
"""


def cold_start_benchmark(rounds: int = 5, goal: float = 4.0):
    """Cold `cvtdesign compare variants/box.yaml` (a new process) against `python -c "import casadi"`, run in
    turn `rounds` times, best of each; then where the time goes, from one profile of the command in a new
    process (profiling slows every call, so read its shares rather than its seconds)."""
    out = tempfile.mkdtemp(prefix="cvtdesign_bench_")
    cmd = [str(Path(sys.executable).parent / "cvtdesign"), "compare", "variants/box.yaml", "--out", out]
    base = [sys.executable, "-c", "import casadi"]

    def timed(c):
        """(wall time, CPU time of the process and its children, the plotting process included) [s]"""
        r0, t = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
        subprocess.run(c, cwd=ROOT, check=True, capture_output=True)
        wall, r1 = time.perf_counter() - t, resource.getrusage(resource.RUSAGE_CHILDREN)
        return wall, r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime

    load = os.getloadavg()[0]
    rows = [(timed(base), timed(cmd)) for _ in range(rounds)]
    (w_base, c_base), (w_cmp, c_cmp) = ([min(x) for x in zip(*col)] for col in zip(*rows))
    ratio = w_cmp / w_base
    print(f"cold start (best of {rounds}, interleaved; load average {load:.2f} before, {os.getloadavg()[0]:.2f} after)")
    print(f"  python -c 'import casadi' (baseline)  {w_base:6.2f} s   CPU {c_base:5.2f} s")
    print(f"  cvtdesign compare variants/box.yaml   {w_cmp:6.2f} s   CPU {c_cmp:5.2f} s (both processes)")
    print(f"  ratio {ratio:.1f} × the baseline   goal ≤ {goal:g} ×: {'met' if ratio <= goal else 'not met'}   "
          f"(CPU time: {c_cmp / c_base:.1f} ×; on a busy machine the wall-time ratio tends to it)")
    run = subprocess.run([sys.executable, "-c", COLD_PROFILE, out], cwd=ROOT, check=True, capture_output=True, text=True)
    phases = json.loads(run.stdout.strip().splitlines()[-1])
    total, painter = phases.pop("total"), phases.pop("painter")
    print(f"  where the time goes (one profile of the command in a new process, {total:.2f} s profiled):")
    for what, t in [*phases.items(), ("the rest (interpreter start, argument parsing, the table, JSON)",
                                      total - sum(phases.values()))]:
        print(f"    {what:66s} {t:6.2f} s  {100 * t / total:3.0f} %")
    print("  the plotting process's work, done again in that process after the command, unprofiled (it starts "
          "with the command and imports matplotlib while the variants are evaluated):")
    for what, t in painter.items():
        print(f"    {what:66s} {t:6.2f} s")


if __name__ == "__main__":
    grid_benchmark()
    cold_start_benchmark()
