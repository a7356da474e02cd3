"""Speed of the compiled model, printed as figures and as ratios to baselines run in the same process.

1. box_kim.yaml over a 161 × 201 envelope (γ and τ⊥ over the variant's ranges): the model compiled to C (what
   `evaluate` runs once the library is in the cache), and interpreted, against a numpy baseline run in the
   same process: np.linalg.solve on a stack of 3 well-conditioned random 24 × 24 systems a point (a Newton
   solve of the box's 24 unknowns takes about that much linear algebra). Goal: the compiled model within
   1.5 × the baseline. Also the one-off compile and the load of the cached library on a later run.
2. The `kalker` contact law against Kim's (`kim`) on the same layout and grid: box.yaml against box_kim.yaml
   over box's envelope at 61 × 61 points, both compiled, interleaved. Goal: a kalker point at most 3 × a kim
   point. Printed as `kalker/kim compiled cost ratio: X`.
3. `cvtdesign compare variants/box.yaml` (the default basis) from a cold start (a new process), also with
   `--samples 0` and on box_kim.yaml (Kim's law), against `python -c "import casadi"` as the baseline of what
   merely starting Python with CasADi costs on this machine now, in CPU time (both processes), with the
   compiled-model cache warm (filled by a run before), then once with an empty cache (a user's first run).
   Goal: at most 8 ×. Then one unprofiled run's timeline of both processes (goal: the table printed by 5 × the
   baseline's wall time), and the floor the figure sets: the baseline's start-up plus what the plotting
   process alone needs (importing matplotlib, drawing the figure).

Run: python benchmarks/bench_model.py [--cold: the cold start alone]   (the machine is shared and noisy: best of
several repeats)
"""
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from cvtdesign.core.model import compile_model
from cvtdesign.core.native import FLAGS
from cvtdesign.io.variant import load_variant
from timing import best_of, run_timed

ROOT = Path(__file__).resolve().parents[1]



def grid_benchmark(repeats: int = 5, goal: float = 1.5):
    L = load_variant(ROOT / "variants/box_kim.yaml")
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
    print(f"box_kim.yaml, {G.shape[0]} × {G.shape[1]} = {n} operating points (best of {repeats}, interleaved; "
          f"load average {load:.2f} before, {os.getloadavg()[0]:.2f} after)")
    print(f"  numpy baseline, 3 × 24×24 solves a point     {us['numpy']:6.2f} µs/point")
    print(f"  model, compiled (evaluate)                   {us['compiled']:6.2f} µs/point   {ratio:4.2f} × the baseline   "
          f"goal ≤ {goal:g} ×: {'met' if ratio <= goal else 'not met'}")
    print(f"  model, interpreted (CVTDESIGN_COMPILE=never) {us['interpreted']:6.2f} µs/point "
          f"{best['interpreted'] / best['numpy']:4.2f} × the baseline")
    print(f"  compiled and interpreted agree (status, α to 1e-10): {same}")
    print(f"  one-off compile (generate C, cc {' '.join(FLAGS)}, load) {t_compile:5.2f} s;   "
          f"later runs, from the cache (generate C, hash, load) {t_load * 1e3:5.0f} ms")


def law_benchmark(repeats: int = 5, goal: float = 3.0):
    """The kalker law's compiled cost per point against Kim's law's, on box's envelope (module docstring)."""
    G, T, models = None, None, {}
    with tempfile.TemporaryDirectory() as cache:
        os.environ["CVTDESIGN_CACHE"], os.environ["CVTDESIGN_COMPILE"] = cache, "always"
        for law, name in (("kim", "box_kim"), ("kalker", "box")):
            L = load_variant(ROOT / f"variants/{name}.yaml")
            G, T = np.meshgrid(np.linspace(L.gamma_grid.min(), L.gamma_grid.max(), 61),
                               np.linspace(L.load_grid.min(), L.load_grid.max(), 61), indexing="ij")
            models[law] = compile_model(L)
            models[law].evaluate(G, T)                   # compiles, loads the library, builds the thread map
        best = {}
        for _ in range(repeats):
            for law, m in models.items():
                best[law] = min(best.get(law, np.inf), best_of(lambda: m.evaluate(G, T), 1)[0])
        del os.environ["CVTDESIGN_COMPILE"], os.environ["CVTDESIGN_CACHE"]
    ratio = best["kalker"] / best["kim"]
    print(f"contact laws on box's envelope, {G.size} points, compiled (best of {repeats}, interleaved; load average "
          f"{os.getloadavg()[0]:.2f})")
    for law in models:
        print(f"  {law:6s} {best[law] / G.size * 1e6:7.2f} µs/point")
    print(f"  kalker/kim compiled cost ratio: {ratio:.2f}   goal ≤ {goal:g}: {'met' if ratio <= goal else 'not met'}")


COLD_TIMELINE = """
import importlib, json, os, resource, sys, time
t0, started = time.perf_counter(), time.time()
marks = {}
mark = lambda what: marks.setdefault(what, time.perf_counter() - t0)
out = sys.argv[1]
import_module = importlib.import_module

def timed(fn, before=None, after=None, write=False):
    def call(*args, **kw):
        if before:
            mark(before)
        value = fn(*args, **kw)
        mark(after)
        if write:                     # in the plotting process: its marks, and its own CPU time since the fork
            marks["CPU"] = time.process_time()
            with open(os.path.join(out, "painter.json"), "w") as f:
                json.dump(marks, f)
        return value
    return call

def hooked(name, *args, **kw):        # wraps the functions of interest as cli.parser imports their modules
    module = import_module(name, *args, **kw)
    if name == "cvtdesign.io.plots":
        mark("io.plots imported (numpy, CasADi); the plotting process is forked")
        drawn = timed(module.compare_figure, "data received", "figure drawn and written", True)
        # sent to the plotting process by reference (module and name), so the wrapper stands in its module
        drawn.__module__, drawn.__qualname__ = module.compare_figure.__module__, "compare_figure"
        module.compare_figure = sys.modules[drawn.__module__].compare_figure = drawn
    if name == "cvtdesign.cli.compare":
        mark("the compare command's modules imported (pint, pydantic, rich, the model)")
        module.envelope = timed(module.envelope, after="first variant evaluated")
        module.plots.Background.draw = timed(module.plots.Background.draw, after="second variant evaluated: data sent")
        module.show = timed(module.show, after="ideal CVT evaluated, table printed")
        module.plots.Background.wait = timed(module.plots.Background.wait, after="figure written (the wait ends)")
    return module

importlib.import_module = hooked
from cvtdesign.cli import main
mark("cvtdesign.cli imported (the arguments' parser)")
sys.argv = ["cvtdesign", "compare", "variants/box.yaml", "--out", out]     # as the `cvtdesign` script runs it
main()
mark("command returns")
cpu = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"main": marks, "main CPU": cpu.ru_utime + cpu.ru_stime, "started": started,
                  "returned": time.time()}))
"""

FLOOR = """
import gc, pickle, sys, time
from cvtdesign.io import plots        # what the plotting process has when it is forked
gc.disable()                          # as in the plotting process
t = time.perf_counter()
plots.figure_parts()
t_mpl = time.perf_counter() - t
with open(sys.argv[1], "rb") as f:
    data = pickle.load(f)
t = time.perf_counter()
plots.compare_figure(data, sys.argv[2])
print(t_mpl, time.perf_counter() - t)
"""

FIGURE_DATA = """
import pickle, sys
from cvtdesign.cli.compare import run
sent = []
class Painter:                       # takes the figure's data instead of drawing it
    draw = lambda self, name, data, path: sent.append(data)
    wait = lambda self: None
run(type("Args", (), {"variants": ["variants/box.yaml"], "out": sys.argv[2], "json": None, "report": None,
                      "points": None, "envelope": None, "as_written": False, "duty": None, "samples": 64,
                      "painter": Painter()})())
with open(sys.argv[1], "wb") as f:
    pickle.dump(sent[0], f)
"""


def cold_timeline(out: str) -> float:
    """One unprofiled run of the command in a new process: when each step ends, in both processes [s from
    the interpreter's start of the command's code], and each process's CPU time; returns when the table was
    printed [s since the interpreter started]."""
    spawned = time.time()
    run = subprocess.run([sys.executable, "-c", COLD_TIMELINE, out], cwd=ROOT, check=True, capture_output=True,
                         text=True)
    ended = time.time()
    main = json.loads(run.stdout.strip().splitlines()[-1])
    painter = json.loads((Path(out) / "painter.json").read_text())
    events = sorted([(t, "main   ", what) for what, t in main["main"].items()] +
                    [(t, "plotter", what) for what, t in painter.items() if what not in main["main"] and what != "CPU"])
    print("  one run, unprofiled (wall time since the script started; plotter = the plotting process):")
    print(f"    {spawned - main['started']:6.3f} s  main     the interpreter starts")
    for t, who, what in events:
        print(f"    {t:6.3f} s  {who}  {what}")
    print(f"    {ended - main['started']:6.3f} s  main     the process has ended")
    print(f"    CPU time: main process {main['main CPU']:.2f} s, plotting process {painter['CPU']:.2f} s")
    return main["main"]["ideal CVT evaluated, table printed"] + main["started"] - spawned


def drawing_floor(out: str, w_base: float, rounds: int = 3) -> None:
    """What the plotting process alone needs, each part the best of `rounds` new processes: importing
    matplotlib and drawing the figure of box + existing. With the baseline's start-up before it, this is the
    command's floor however fast the rest became."""
    data = Path(out) / "figure_data.pkl"
    subprocess.run([sys.executable, "-c", FIGURE_DATA, str(data), out], cwd=ROOT, check=True, capture_output=True)
    runs = [subprocess.run([sys.executable, "-c", FLOOR, str(data), str(Path(out) / "floor.png")], cwd=ROOT,
                           check=True, capture_output=True, text=True).stdout.split() for _ in range(rounds)]
    t_mpl, t_draw = (min(float(r[k]) for r in runs) for k in (0, 1))
    floor = w_base + t_mpl + t_draw
    print(f"  the plotting process alone (best of {rounds}): importing matplotlib {t_mpl:.2f} s, drawing and writing "
          f"the figure {t_draw:.2f} s (= {t_draw / w_base:.1f} × the baseline);")
    print(f"  with the baseline's start-up before them: a floor of {floor:.2f} s = {floor / w_base:.1f} × the "
          "baseline while matplotlib draws this figure")


COMMANDS = (("compare variants/box.yaml", ["compare", "variants/box.yaml"]),
            ("  --samples 0 (first order only)", ["compare", "variants/box.yaml", "--samples", "0"]),
            ("compare variants/box_kim.yaml (Kim's law)", ["compare", "variants/box_kim.yaml"]))


def cold_start_benchmark(rounds: int = 3, goal: float = 8.0, table_goal: float = 5.0):
    """Cold `cvtdesign compare variants/box.yaml` (a new process; also with --samples 0, and box_kim.yaml)
    against `python -c "import casadi"`, run in turn `rounds` times, best of each, in CPU time (goal: `goal`; on
    a loaded machine CPU time is what stays put), with the compiled-model cache warm (a run before the timed
    ones fills it: what every run after a user's first sees); then one run with an empty cache (the first run,
    which compiles the models), one run's timeline, when its table is printed (goal: `table_goal` × the
    baseline's wall time), and the floor the figure sets."""
    out = tempfile.mkdtemp(prefix="cvtdesign_bench_")
    exe = str(Path(sys.executable).parent / "cvtdesign")
    base = [sys.executable, "-c", "import casadi"]

    def timed(c, env=None):
        """(wall time, CPU time of the process and its children, the plotting process included) [s]"""
        return run_timed(c, ROOT, env)

    cmds = [[exe, *args, "--out", out] for _, args in COMMANDS]
    for c in cmds:                         # fills the compiled-model cache: the timed runs find it warm
        timed(c)
    load = os.getloadavg()[0]
    rows = [[timed(base)] + [timed(c) for c in cmds] for _ in range(rounds)]
    best = [tuple(min(x) for x in zip(*col)) for col in zip(*rows)]
    (w_base, c_base) = best[0]
    print(f"cold start, compiled-model cache warm (best of {rounds}, interleaved; load average {load:.2f} before, "
          f"{os.getloadavg()[0]:.2f} after)")
    print(f"  python -c 'import casadi' (baseline)        {w_base:6.2f} s   CPU {c_base:5.2f} s")
    for (what, _), (w, c) in zip(COMMANDS, best[1:]):
        print(f"  {what:42s} {w:6.2f} s   CPU {c:5.2f} s   {c / c_base:5.1f} × the baseline's CPU")
    ratio = best[1][1] / c_base
    print(f"  compare variants/box.yaml: CPU time ratio {ratio:.1f} ×   goal ≤ {goal:g} ×: "
          f"{'met' if ratio <= goal else 'not met'}   (wall time: {best[1][0] / w_base:.1f} ×)")
    with tempfile.TemporaryDirectory() as empty:
        w, c = timed(cmds[0], env=os.environ | {"CVTDESIGN_CACHE": empty})
    print(f"  the same with an empty cache (the first run: it compiles the models; load average "
          f"{os.getloadavg()[0]:.2f}): {w:.1f} s, CPU {c:.1f} s = {c / c_base:.0f} × (the compilers' CPU included)")
    table = cold_timeline(out)
    print(f"  the table printed at {table:.2f} s = {table / w_base:.1f} × the baseline's wall time   goal ≤ "
          f"{table_goal:g} ×: {'met' if table / w_base <= table_goal else 'not met'}")
    drawing_floor(out, w_base)


if __name__ == "__main__":
    if "--cold" not in sys.argv[1:]:      # --cold: the cold start alone
        grid_benchmark()
        law_benchmark()
    cold_start_benchmark()
