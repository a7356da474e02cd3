"""Speed of `cvtdesign life` as ratios to baselines measured in the same run.

1. The whole command as the README shows it (`life variants/box.yaml variants/existing.yaml --duty
   studies/cobot_duty.yaml`, in process: reading and compiling both variants, the consistent temperatures,
   every contact's life, the intervals (the chain re-run once per uncertain input) and the worn model's
   ratio error) against a fixed numpy computation (`reference`: what this machine does in a given time,
   whatever cvtdesign's code does), and against one evaluation of box.yaml's model at the duty's points, the
   unit the chain is made of.
2. Its parts on box.yaml: one run of the chain (model ⇄ temperatures to the consistent state, then the
   contacts' lives) and the interval, each in evaluations of the model at the duty's points.

The rounds are interleaved (each baseline is measured next to what it is the baseline of) and each figure is
the best of the rounds: the machine is shared and noisy. The load average is printed at the start and end.

Run: python benchmarks/bench_life.py [--rounds N]
"""
import argparse
import contextlib
import io
import os
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from cvtdesign.cli import life as life_cli
from cvtdesign.core.inputs import uncertain_model
from cvtdesign.core.life.run import life_interval, machine_life
from cvtdesign.io.duty_file import load_duty
from cvtdesign.io.variant import load_variant
from timing import best_of

ROOT = Path(__file__).resolve().parents[1]
FILES = [ROOT / "variants" / "box.yaml", ROOT / "variants" / "existing.yaml"]
DUTY = ROOT / "studies" / "cobot_duty.yaml"


def reference() -> float:
    """The fixed baseline computation (numpy, one thread; as bench_diagnose.py's): sort a million random
    numbers and sum a function of them."""
    x = np.random.default_rng(0).random(1_000_000)
    return float(np.sum(np.sin(np.sort(x)) * np.exp(-x)))


def command():
    """`cvtdesign life` on the README's two variants, in process, its printing discarded."""
    args = SimpleNamespace(variants=[str(f) for f in FILES], duty=str(DUTY), json=None, plots=None, report=None)
    with contextlib.redirect_stdout(io.StringIO()):
        life_cli.run(args)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="interleaved rounds; each figure is the best (default 3)")
    args = parser.parse_args()
    print(f"load average {os.getloadavg()[0]:.1f} at the start; best of {args.rounds} interleaved rounds")
    duty = load_duty(DUTY)
    model = uncertain_model(load_variant(FILES[0]))
    ages = life_cli.ageing_of(FILES[0], model)
    evaluate = lambda: model.evaluate(duty.gamma, duty.load, speeds=duty.speed)   # noqa: E731
    evaluate()
    t_ref, t_eval, t_cmd, t_chain, t_iv = [], [], [], [], []
    for _ in range(args.rounds):
        t_ref.append(best_of(reference, 10)[0])
        t_eval.append(best_of(evaluate, 20)[0])
        t_cmd.append(best_of(command, 1)[0])
        t, base = best_of(lambda: machine_life(model, duty, ages), 5)
        t_chain.append(t)
        t_iv.append(best_of(lambda: life_interval(model, duty, ages, base), 1)[0])
    ref, ev = min(t_ref), min(t_eval)
    print(f"1. life, {len(FILES)} variants, {duty.gamma.size} duty points: {min(t_cmd):.2f} s; reference "
          f"{1e3 * ref:.1f} ms, ratio {min(t_cmd) / ref:.0f}; one evaluation of box.yaml's model at the duty "
          f"points {1e3 * ev:.2f} ms, ratio {min(t_cmd) / ev:.0f}")
    print(f"2. box.yaml: one run of the chain {1e3 * min(t_chain):.0f} ms ({base.iterations} model evaluations "
          f"to the consistent state), ratio {min(t_chain) / ev:.1f} evaluations; the interval "
          f"{min(t_iv):.2f} s, ratio {min(t_iv) / ev:.0f} evaluations, {min(t_iv) / min(t_chain):.0f} runs of the chain")
    print(f"load average {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
