"""Speed of a tolerance study's samples, as a ratio to a baseline measured in the same run.

1. One sample of box.yaml under studies/box_tolerances.yaml (42 toleranced dimensions, with the variant's
   physical inputs sampled beside them, as by default, and with --dimensions-only; Kim's protocol: 17 × 21
   points): what a worker spends on it (its share of its chunk's one call of the compiled model over
   samples × points, the standstill torques, the figures and the row), against one compiled evaluation of the
   nominal envelope (the same library at x = 0, the envelope's points in one call). Goal: at most SAMPLE_GOAL.
   The model is loaded as a worker loads it (core.model.library_model, from the C source the study carries);
   building it, as the command's own process does once, is timed too.
2. With --samples N: the whole command, `cvtdesign tolerance variants/box.yaml --tolerances
   studies/box_tolerances.yaml --samples N` on 2 workers into a new store, wall and CPU time (the goal for
   N = 1000: at most 2 min).

Run: python benchmarks/bench_tolerance.py [--rounds N] [--samples N]
"""
import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from cvtdesign.core.metrics import envelopes
from cvtdesign.core.model import compile_model, library_model
from cvtdesign.design import tolerance
from cvtdesign.design.tolerance_inputs import model_arguments
from timing import best_of, run_timed

ROOT = Path(__file__).resolve().parents[1]
VARIANT, TOLERANCES = ROOT / "variants/box.yaml", ROOT / "studies/box_tolerances.yaml"
SAMPLE_GOAL = 20.0        # [×] a sample against one compiled evaluation of the nominal envelope, at most


def sample_ratio(rounds: int, dimensions_only: bool) -> None:
    t = time.process_time()
    content = tolerance.with_code(tolerance.tolerance_content(VARIANT, TOLERANCES, dimensions_only))
    built = time.process_time() - t
    model = library_model(content.layout, content.code, content.design_size)
    nominal = {"ok": tolerance.built_model(content)[1]["ok"]}
    L = model.layout
    G, T = np.meshgrid(L.gamma_grid, L.load_grid, indexing="ij")
    zero, x = np.zeros(content.design_size), tolerance.chunk_draws(content, 0)
    plain = compile_model(content.layout)           # the variant's own model, no deviation among its inputs
    plain = library_model(content.layout, plain.point_source()) or plain

    def chunk():
        design, theta = model_arguments(model, len(content.dims), content.inputs, x)
        return [tolerance.sample_row(model, nominal, content.sources, x[i], res)
                for i, res in enumerate(envelopes(model, design, theta))]
    t_eval, t_chunk, t_plain = [], [], []
    for _ in range(rounds):          # interleaved: each is measured next to the other
        t_eval.append(best_of(lambda: model.evaluate(G, T, design=zero), 5)[0])
        t_plain.append(best_of(lambda: plain.evaluate(G, T), 5)[0])
        t, rows = best_of(chunk, 2)
        t_chunk.append(t / len(rows))
    ratio = min(t_chunk) / min(t_eval)
    held = sum(r["status"] == "ok" for r in rows)
    what = "dimensions only" if dimensions_only else f"{len(content.dims)} dimensions and {len(content.inputs)} physical inputs"
    print(f"1. {what}: model built in {built:.1f} s CPU (once, by the command's process); one compiled evaluation of the "
          f"nominal envelope ({G.size} points) {1e3 * min(t_eval):.1f} ms; a sample {1e3 * min(t_chunk):.1f} ms "
          f"(chunks of {len(rows)}, {held} held): ratio {ratio:.2f}; against the variant's own compiled model "
          f"({1e3 * min(t_plain):.1f} ms): {min(t_chunk) / min(t_plain):.2f}")
    print(f"   goal: a sample ≤ {SAMPLE_GOAL:g}× one compiled evaluation: {ratio:.2f}× — "
          f"{'met' if ratio <= SAMPLE_GOAL else 'not met'}")


def whole_command(samples: int) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "cvtdesign", "tolerance", str(VARIANT), "--tolerances", str(TOLERANCES),
               "--samples", str(samples), "--workers", "2", "--store", str(Path(tmp) / "store")]
        wall, cpu = run_timed(cmd, ROOT)
    print(f"2. tolerance --samples {samples} on 2 workers: {wall:.0f} s wall, {cpu:.0f} s CPU (this process's "
          f"children: the command and the cluster it starts)")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds; each figure is the best (default 3)")
    parser.add_argument("--samples", type=int, default=0, help="also run the whole command with this many samples")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} at the start")
    sample_ratio(args.rounds, dimensions_only=False)
    sample_ratio(args.rounds, dimensions_only=True)
    if args.samples:
        whole_command(args.samples)
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
