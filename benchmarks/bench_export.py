"""Speed of `cvtdesign export`, printed next to baselines run in the same process or run, as ratios.

1. Cold start: `cvtdesign export variants/box_kim.yaml` (STEP + SVG + PNG, as the README shows it) in a new
   process against `python -c "import cadquery"`, what merely loading cadquery costs on this machine now;
   the two are run in turn, and each figure is the best of the rounds. Goal (issue 12): at most COLD_GOAL ×.
2. Warm (cadquery loaded): `export_layout` (the file read, then `export_variant`) for box_kim.yaml and
   existing_kim.yaml against the bare assembly of the same layout (the sphere and plain cylinders of the rollers' radius and width at their poses, no
   crowns, bores, axles, forks, couplings, screen or drawings, written to STEP), and the `--check` time.

Run: python benchmarks/bench_export.py [--rounds N]   (the machine is shared and noisy: best of the rounds)
"""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from cvtdesign.cad.kernel import kernel
from cvtdesign.cad.plan import Plan
from cvtdesign.cad.step import step_header, write_step
from cvtdesign.cli.export import export_layout
from cvtdesign.core.geometry import pose, steering_angle
from cvtdesign.io.variant import load_variant
from timing import best_of

ROOT = Path(__file__).resolve().parents[1]
COLD_GOAL = 2.5            # [×] cold export of box_kim.yaml against `import cadquery`, at most


def bare_assembly(path, out):
    """The baseline: sphere and plain roller cylinders where the model puts them, as a STEP assembly."""
    cq = kernel().cq
    layout = load_variant(path)
    phi = steering_angle(layout, np.radians(45.0))
    R = 1000 * layout.sphere_radius
    assy = cq.Assembly(name=layout.name)
    assy.add(cq.Solid.makeSphere(R, angleDegrees1=-90, angleDegrees2=90), name="sphere")
    for r in layout.rollers:
        n, a = pose(r, phi)
        w = 1000 * r.width
        base = (R + 1000 * r.radius) * n - w / 2 * a
        assy.add(cq.Solid.makeCylinder(1000 * r.radius, w, cq.Vector(*base), cq.Vector(*a)), name=r.name)
    write_step(assy, Path(out) / f"{layout.name}_bare.step", step_header(Plan(layout, np.radians(45.0), phi), f"{layout.name}_bare.step"))


def cold_start(tmp, rounds):
    env = dict(os.environ, PYTHONPATH=str(ROOT))

    def run(command):
        t = time.perf_counter()
        out = subprocess.run(command, cwd=ROOT, env=env, check=True, capture_output=True, text=True).stdout
        return time.perf_counter() - t, out

    t_cq, t_exp, inside = [], [], []
    for _ in range(rounds):
        t_cq.append(run([sys.executable, "-c", "import cadquery"])[0])
        t, out = run([sys.executable, "-m", "cvtdesign", "export", "variants/box_kim.yaml", "--out", tmp])
        t_exp.append(t)
        inside.append(float(re.search(r" in ([\d.]+) s;", out).group(1)))
    ratio = min(t_exp) / min(t_cq)
    print(f"cold start (new processes, best of {rounds} rounds, each round both in turn)")
    print(f"  cvtdesign export variants/box_kim.yaml       {min(t_exp):6.2f} s   (of which export_variant, cadquery's "
          f"import included, {min(inside):.2f} s)")
    print(f"  python -c 'import cadquery' (baseline)   {min(t_cq):6.2f} s   ratio {ratio:.2f} ×")
    verdict = "met" if ratio <= COLD_GOAL else "not met"
    print(f"  goal: cold export ≤ {COLD_GOAL:g} × import cadquery: {ratio:.2f} × — {verdict}")


def warm(tmp):
    kernel()
    print("warm (cadquery loaded), best of 3")
    for name in ("box_kim", "existing_kim"):
        path = ROOT / "variants" / f"{name}.yaml"
        t_bare, _ = best_of(lambda: bare_assembly(path, tmp), 3)
        t_exp, res = best_of(lambda: export_layout(path, tmp), 3)
        t_chk, res_c = best_of(lambda: export_layout(path, tmp, check=True), 1)
        ok = all(r["ok"] for r in res_c["checks"])
        print(f"  {name:9s} export {t_exp:5.2f} s ({len(res['parts'])} parts)   bare sphere + cylinders "
              f"{t_bare:5.2f} s   ratio {t_exp / t_bare:5.1f} ×   check {res_c['check_seconds']:5.2f} s "
              f"({'all pass' if ok else 'FAILED'})")


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5, help="cold-start rounds; each figure is the best (default 5)")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} at the start")
    with tempfile.TemporaryDirectory() as tmp:
        cold_start(tmp, args.rounds)
        warm(tmp)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")
