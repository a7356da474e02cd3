"""Where cost grows: the model's and the optimiser's cost against the size of what they are given.

1. points: box_kim.yaml evaluated over n = 100 … 32 361 operating points (γ × τ⊥ over the variant's ranges),
   compiled to C and interpreted (CVTDESIGN_COMPILE=always / never, one model each, as bench_model.py).
2. rollers: box_kim.yaml's four drive and follower rollers with 2, 4, 8 or 12 steering rollers of 10 mm radius
   on the z-fork planes (azimuth 135° and −45°) at several polar angles, generated in a temporary folder,
   and existing_kim.yaml (4 rollers): unknowns, the one-off compile to C, and µs/point on the 17 × 21 envelope.
3. rows and design variables: one IPOPT solve (`solve_from`, working set, from the base design) of the box
   placement study (studies/box_placement_kim.yaml) with its envelope coarsened and refined (rows ∝ points),
   and with 1 to 4 of its parameters free.
Growth laws are least-squares fits of log(cost) against log(size). Best of REPEATS, the machine being shared
and noisy; the load average is printed.

Run: python benchmarks/bench_scaling.py
"""
import os
os.environ["CVTDESIGN_COMPILE"] = "always"      # compile at first use; switched per model below

import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

from cvtdesign.core.model import compile_model
from cvtdesign.design.problem import build_problem
from cvtdesign.design.solve import solve_from, starts
from cvtdesign.design.study_file import load_study
from cvtdesign.io.variant import load_variant
from timing import best_of

ROOT = Path(__file__).resolve().parents[1]
REPEATS = 3
STEER_RADIUS = "10 mm"                          # small enough that 12 steering rollers do not overlap
STEER_POLAR = {2: [28], 4: [28], 8: [24, 48], 12: [16, 32, 48]}   # [deg] per hemisphere


def exponent(sizes, costs):
    """k of cost ∝ size^k (least squares in log–log)."""
    return float(np.polyfit(np.log(sizes), np.log(costs), 1)[0])


def grid(L, ng, nl):
    return np.meshgrid(np.linspace(L.gamma_grid.min(), L.gamma_grid.max(), ng),
                       np.linspace(L.load_grid.min(), L.load_grid.max(), nl), indexing="ij")


def timed_models(L):
    """{'compiled': model, 'interpreted': model} of layout L, and the one-off compile to C [s] (empty cache)."""
    models = {}
    for what, policy in (("compiled", "always"), ("interpreted", "never")):
        os.environ["CVTDESIGN_COMPILE"] = policy
        models[what] = compile_model(L)
    t_compile, _ = best_of(models["compiled"].native_point, 1)
    return models, t_compile


def us_per_point(models, G, T):
    """Best-of-REPEATS µs/point of each model over the grid (G, T), interleaved, after a warm-up call."""
    best = {}
    for what, m in models.items():
        os.environ["CVTDESIGN_COMPILE"] = "always" if what == "compiled" else "never"
        m.evaluate(G, T)                                    # loads the library, builds the thread map
    for _ in range(REPEATS):
        for what, m in models.items():
            os.environ["CVTDESIGN_COMPILE"] = "always" if what == "compiled" else "never"
            t, _ = best_of(lambda: m.evaluate(G, T), 1)
            best[what] = min(best.get(what, np.inf), t / G.size * 1e6)
    return best


def points_axis():
    L = load_variant(ROOT / "variants/box_kim.yaml")
    models, _ = timed_models(L)
    sizes, rows = [], []
    for ng, nl in ((10, 10), (25, 40), (100, 100), (161, 201)):
        G, T = grid(L, ng, nl)
        us = us_per_point(models, G, T)
        sizes.append(G.size)
        rows.append((G.size, us["compiled"], us["interpreted"]))
    print(f"\n### Points (box_kim.yaml, best of {REPEATS})\n")
    print("| points | compiled µs/point | compiled total | interpreted µs/point | interpreted total |")
    print("| ---: | ---: | ---: | ---: | ---: |")
    for n, c, i in rows:
        print(f"| {n:,} | {c:.2f} | {c * n / 1e3:.1f} ms | {i:.1f} | {i * n / 1e3:.0f} ms |")
    kc = exponent(sizes, [n * c for n, c, _ in rows])
    ki = exponent(sizes, [n * i for n, _, i in rows])
    (bc, ac), (bi, ai) = (np.polyfit(sizes, [n * r[k] for n, *r in rows], 1) for k in (0, 1))
    print(f"\npoints: total time ∝ n^{kc:.2f} compiled, n^{ki:.2f} interpreted over the whole range; "
          f"affine fit: {ac / 1e3:.1f} ms + {bc:.2f} µs·n compiled, {ai / 1e3:.1f} ms + {bi:.2f} µs·n interpreted "
          f"(linear once the fixed cost of a call is spread)")


def steering_layout(n_steer: int, folder: Path) -> Path:
    """box_kim.yaml with its steering rollers replaced by n_steer rollers of STEER_RADIUS on the z-fork planes,
    one fork a hemisphere (2: one fork holding two antipodal rollers, so that the preloads balance)."""
    data = yaml.safe_load((ROOT / "variants/box_kim.yaml").read_text())
    template = data["rollers"]["N1"]
    rollers = {k: v for k, v in data["rollers"].items() if v["role"] != "steering"}
    forks = []
    for hemi in ("N", "S"):
        names = []
        for j, polar in enumerate(STEER_POLAR[n_steer]):
            for az in (135, -45):
                if n_steer == 2 and (hemi, az) in (("S", 135), ("N", -45)):
                    continue
                name = f"{hemi}{j}{'a' if az == 135 else 'b'}"
                p = polar if hemi == "N" else 180 - polar
                rollers[name] = dict(template, contact={"polar": f"{p} deg", "azimuth": f"{az} deg"},
                                     radius=STEER_RADIUS)
                names.append(name)
        forks.append({"rollers": names, "axis": "z", "sign": 1})
    data["rollers"], data["steering"]["forks"] = rollers, [f for f in forks if f["rollers"]]
    path = folder / f"box_steer{n_steer}.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True, sort_keys=False))
    return path


def rollers_axis(folder: Path):
    layouts = [("existing_kim.yaml", ROOT / "variants/existing_kim.yaml")]
    layouts += [(f"box, 4 + {n} steering", steering_layout(n, folder)) for n in (2, 4, 8, 12)]
    rows = []
    for label, path in layouts:
        L = load_variant(path)
        models, t_compile = timed_models(L)
        G, T = grid(L, 17, 21)
        us = us_per_point(models, G, T)
        rows.append((label, len(L.rollers), models["compiled"].residual.size1_in(0), t_compile,
                     us["compiled"], us["interpreted"]))
    print(f"\n### Rollers (17 × 21 = 357 points, best of {REPEATS}; compile: once, empty cache)\n")
    print("| layout | rollers | unknowns | compile to C | compiled µs/point | interpreted µs/point |")
    print("| --- | ---: | ---: | ---: | ---: | ---: |")
    for label, n, nx, tc, c, i in rows:
        print(f"| {label} | {n} | {nx} | {tc:.1f} s | {c:.1f} | {i:.0f} |")
    n, nx, tc, c, i = (np.array([r[k] for r in rows], float) for k in range(1, 6))
    print(f"\nrollers: unknowns ∝ rollers^{exponent(n, nx):.2f}; compile ∝ rollers^{exponent(n, tc):.2f}, "
          f"compiled µs/point ∝ rollers^{exponent(n, c):.2f}, interpreted ∝ rollers^{exponent(n, i):.2f}")


def solve_time(study: Path):
    """(rows, envelope points, points in the final working set, build [s], best solve [s], status, rounds,
    one evaluation of every row [s], the envelope check of the optimum [s]) of one study."""
    t = time.perf_counter()
    pr = build_problem(load_study(study))
    t_build = time.perf_counter() - t
    z0 = starts(pr)[0]
    solve_from(pr, z0)                                      # builds the working-set solvers it needs
    t_solve, sol = best_of(lambda: solve_from(pr, z0), REPEATS)
    x = np.append(sol.z, sol.objective) if pr.epigraph else sol.z
    t_rows, _ = best_of(lambda: pr.evaluate(x), REPEATS)
    t_check, _ = best_of(lambda: pr.check(sol.design), REPEATS)
    return len(pr.g_lb), pr.parts.gamma.size, sol.points, t_build, t_solve, sol.status, sol.rounds, t_rows, t_check


def study_file(folder: Path, name: str, design: list, g_step: float, l_step: float) -> Path:
    data = yaml.safe_load((ROOT / "studies/box_placement_kim.yaml").read_text())
    data["base"] = str(ROOT / "variants/box_kim.yaml")
    bounds = {"preload": {"lower": "60 N", "upper": "140 N"}}
    data["design"] = {k: data["design"].get(k) or bounds[k] for k in design}
    data["envelope"] = {"gamma": {"start": "-80 deg", "stop": "80 deg", "step": f"{g_step} deg"},
                        "load": {"start": "-1 N*m", "stop": "1 N*m", "step": f"{l_step} N*m"}}
    path = folder / f"{name}.yaml"
    path.write_text(yaml.safe_dump(data, allow_unicode=True, sort_keys=False))
    return path


def optimiser_axis(folder: Path):
    os.environ["CVTDESIGN_COMPILE"] = "auto"                # what `cvtdesign study` runs with
    three = ["d", "r_drive", "r_steer"]
    print(f"\n### Rows (box placement, 3 design variables + t, one IPOPT solve from the base design, best of {REPEATS})\n")
    print("| envelope | points | rows | working-set points | rounds | build NLP | solve | in it: every row once | in it: envelope check |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    res = []
    for g, l in ((20, 0.2), (10, 0.1), (5, 0.05), (2.5, 0.025)):
        r = solve_time(study_file(folder, f"rows_{g}", three, g, l))
        res.append(r)
        print(f"| γ step {g}°, load step {l} N m | {r[1]} | {r[0]} | {r[2]} | {r[6]} | {r[3]:.2f} s | {r[4] * 1e3:.0f} ms | {r[7] * 1e3:.0f} ms | {r[8] * 1e3:.0f} ms |")
    rows_n = [r[0] for r in res]
    print(f"\nrows: solve ∝ rows^{exponent(rows_n, [r[4] for r in res]):.2f}, "
          f"build ∝ rows^{exponent(rows_n, [r[3] for r in res]):.2f}, one evaluation of every row "
          f"∝ rows^{exponent(rows_n, [r[7] for r in res]):.2f}, check "
          f"∝ rows^{exponent(rows_n, [r[8] for r in res]):.2f}")
    print(f"\n### Free design variables (17 × 21 envelope, best of {REPEATS})\n")
    print("| free design variables | rows | working-set points | build NLP | solve | status |")
    print("| --- | ---: | ---: | ---: | ---: | --- |")
    res = []
    for k in (1, 2, 3, 4):
        names = (three + ["preload"])[:k]
        r = solve_time(study_file(folder, f"vars_{k}", names, 10, 0.1))
        res.append(r)
        print(f"| {k}: {', '.join(names)} | {r[0]} | {r[2]} | {r[3]:.2f} s | {r[4] * 1e3:.0f} ms | {r[5]} |")
    print(f"\ndesign variables: solve ∝ k^{exponent([1, 2, 3, 4], [r[4] for r in res]):.2f}, "
          f"build ∝ k^{exponent([1, 2, 3, 4], [r[3] for r in res]):.2f}")


if __name__ == "__main__":
    load = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        os.environ["CVTDESIGN_CACHE"] = str(Path(tmp) / "cache")   # empty: every compile is timed
        points_axis()
        rollers_axis(Path(tmp))
        optimiser_axis(Path(tmp))
    print(f"\nload average (1, 5, 15 min) before {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, "
          f"after {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
