"""Speed of `cvtdesign transient` as ratios to baselines measured in the same run.

1. The whole command as the README shows it (`transient variants/box.yaml variants/existing.yaml`, in process:
   reading both variants, compiling their dynamic models, each one's step, bandwidth at three points, rendering
   and the fastest-ratio-change search), and with --quick (no search, no rendering), against a fixed numpy
   computation (`reference`: what this machine does in a given time, whatever cvtdesign's code does).
2. Its parts on each variant, in step responses (one integration of the step, the unit the others are made
   of): the bandwidth at one point (a steady state and the exact Jacobian), the rendering (two periods of a
   sinusoidal profile and its quasi-static points) and the fastest-change search (a bisection of ramps).

The rounds are interleaved (each baseline is measured next to what it is the baseline of) and each figure is
the best of the rounds: the machine is shared and noisy. The load average is printed at the start and end.

Run: python benchmarks/bench_transient.py [--rounds N]
"""
import argparse
import contextlib
import io
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from cvtdesign.cli import transient as transient_cli
from cvtdesign.core.dynamics.linear import linear_at
from cvtdesign.core.dynamics.model import compile_dynamics
from cvtdesign.core.dynamics.render import render
from cvtdesign.core.dynamics.response import fastest_change, step_response
from cvtdesign.io.dynamics import dynamic_parameters
from cvtdesign.io.variant import load_variant
from timing import best_of

ROOT = Path(__file__).resolve().parents[1]
FILES = [ROOT / "variants" / "box.yaml", ROOT / "variants" / "existing.yaml"]
G0, G1, LOAD = np.radians(10), np.radians(40), 0.5      # the command's defaults on the shipped envelopes


def reference() -> float:
    """The fixed baseline computation (numpy, one thread; as bench_life.py's): sort a million random numbers
    and sum a function of them."""
    x = np.random.default_rng(0).random(1_000_000)
    return float(np.sum(np.sin(np.sort(x)) * np.exp(-x)))


def command(quick: bool):
    """`cvtdesign transient` on the README's two variants, in process, its printing discarded."""
    args = SimpleNamespace(variants=[str(f) for f in FILES], gamma_from=None, gamma_to=None, load=None,
                           bandwidth_at=None, render_hz=None, quick=quick, json=None, plots=None, report=None,
                           argv=["transient"])
    with contextlib.redirect_stdout(io.StringIO()):
        transient_cli.run(args)


def parts(model, rounds: int) -> dict:
    """The best time [s] of each part on one model."""
    out = {"step": best_of(lambda: step_response(model, G0, G1, LOAD), 3)[0],
           "bandwidth": best_of(lambda: linear_at(model, G0, LOAD).bandwidth("gamma_axis"), 3)[0],
           "render": best_of(lambda: render(model, G0, G1, LOAD, 1.0), 1)[0]}
    out["fastest change"] = best_of(lambda: fastest_change(model, G0, G1, LOAD), 1)[0] if rounds else np.nan
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=1, help="interleaved rounds; each figure is the best (default "
                        "1: a round takes minutes)")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} at the start; best of {args.rounds} interleaved rounds")
    models = {f.stem: compile_dynamics(lay, dynamic_parameters(lay)) for f in FILES for lay in [load_variant(f)]}
    t_ref, t_cmd, t_quick, t_parts = [], [], [], {k: [] for k in models}
    for _ in range(args.rounds):
        t_ref.append(best_of(reference, 10)[0])
        t_quick.append(best_of(lambda: command(True), 1)[0])
        t_cmd.append(best_of(lambda: command(False), 1)[0])
        for k, m in models.items():
            t_parts[k].append(parts(m, args.rounds))
    ref = min(t_ref)
    print(f"1. transient, {len(FILES)} variants: {min(t_cmd):.1f} s, ratio {min(t_cmd) / ref:.0f} to the reference "
          f"({1e3 * ref:.1f} ms); --quick {min(t_quick):.2f} s, ratio {min(t_quick) / ref:.0f}")
    for k, runs in t_parts.items():
        best = {p: min(r[p] for r in runs) for p in runs[0]}
        step = best["step"]
        print(f"2. {k}: a step response {1e3 * step:.0f} ms (ratio {step / ref:.1f} to the reference); in step "
              "responses: " + ", ".join(f"{p} {best[p] / step:.2g}" for p in best if p != "step"))
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
